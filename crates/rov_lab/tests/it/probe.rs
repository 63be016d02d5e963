//! Probe of the lab the way issue 13's held-out evaluation will judge it (design
//! experiment, asserts nothing): cases no other test covers — the bases model1 and model2
//! with a hidden catalog effect, two simultaneous effects on model2, closed-loop dives
//! (the station's autopilot in the loop) with a hidden effect, a messy log (jittered
//! intervals, spikes, a gap) with a hidden effect, a term outside the catalog on model2
//! (a yaw moment ∝ w|w|, not one of tests/discovered_terms.rs's), and an effect-free messy
//! closed-loop dive on model2. Seeds and amplitudes differ from the other tests.
//!
//! For each case it prints the truth, the verdict, what was accepted, the top finding with
//! its parameters against the truth, and whether the answer is right; then a detail block
//! (top findings, channel consistency, unexplained channels).
//!
//! Cases 9, 10, 14 and 15 put the model3 truth under a planar base or repeat a case's
//! effect alone, to separate causes. Cases 17 and 18 are hidden_effects' tether_small and
//! nulls_and_pairs' two effects (the structural-base rule's boundaries); 19–21 add two
//! effects under model1 and in a messy closed loop, and an outside term in closed loop.
//!
//! Run: `cargo test -p rov_lab --release --test it probe:: -- --ignored --nocapture`
//! (`PROBE=1,4` runs only those cases; `PROBE_EXPLAIN=1` adds every finding's
//! explanation, conflicts and per-view reductions, the calibration and the truth;
//! `PROBE_CAL_ITERS` / `PROBE_CONFIRM_ITERS` override the LM iteration budgets).

use crate::common;

use common::{Hidden, case_len, closed_loop_run, mess_up, planar_case};
use rov_lab::diagnose::{DiagnoseOptions, Diagnosis, diagnose};
use rov_lab::ingest::runs_from_text;
use rov_lab::verdict::Verdict;
use rov_lab::{BaseKind, LabModel, Run};

/// How the data of a case is made.
#[derive(Clone, Copy)]
enum Data {
    /// Open-loop paper-like steps, 6 min training + 3 min held-out, 20 Hz, quantised.
    OpenLoop,
    /// The same schedules on a planar truth of the base's own structure (model1 or model2
    /// perturbed ±20 %, tests/common `planar_case`).
    PlanarOpenLoop,
    /// Closed-loop dives (autopilot in the loop, jittered 40–60 ms), 7 + 4 min.
    ClosedLoop,
    /// [`Data::ClosedLoop`] with spikes in depth and heading and a 3-s gap, read back from
    /// CSV text as a real log is.
    ClosedLoopMessy,
}

/// An expected parameter: (finding, parameter, truth in display units).
type Expect = (&'static str, &'static str, f64);

struct Case {
    id: usize,
    base: BaseKind,
    seed: u64,
    hidden: Vec<Hidden>,
    data: Data,
    /// Effects (catalog keys, or a `term:` id prefix) that should be accepted.
    expect: Vec<&'static str>,
    /// Parameters to compare with the truth.
    params: Vec<Expect>,
}

fn cases() -> Vec<Case> {
    vec![
        Case {
            id: 1,
            base: BaseKind::Model1,
            seed: 61,
            hidden: vec![Hidden::AsymVertical(0.65)],
            data: Data::PlanarOpenLoop,
            expect: vec!["thrust-asymmetry"],
            params: vec![("thrust-asymmetry", "reverse_ratio_vertical", 0.65)],
        },
        Case {
            id: 2,
            base: BaseKind::Model2,
            seed: 62,
            hidden: vec![Hidden::Lag(0.2)],
            data: Data::PlanarOpenLoop,
            expect: vec!["thruster-lag"],
            params: vec![("thruster-lag", "lag_time_constant_s", 0.2)],
        },
        Case {
            id: 3,
            base: BaseKind::Model2,
            seed: 63,
            hidden: vec![Hidden::AsymHorizontal(0.7), Hidden::DepthDrift(6.0)],
            data: Data::PlanarOpenLoop,
            expect: vec!["thrust-asymmetry", "depth-sensor-drift"],
            params: vec![
                ("thrust-asymmetry", "reverse_ratio_port", 0.7),
                ("thrust-asymmetry", "reverse_ratio_starboard", 0.7),
                ("depth-sensor-drift", "depth_drift_mps", 6.0),
            ],
        },
        Case {
            id: 4,
            base: BaseKind::Model1,
            seed: 64,
            hidden: vec![Hidden::TorqueV(0.002), Hidden::CompassEmiV(6.0)],
            data: Data::PlanarOpenLoop,
            expect: vec!["propeller-torque", "compass-deviation"],
            params: vec![
                ("propeller-torque", "torque_vertical_m", 2.0),
                (
                    "compass-deviation",
                    "compass_interference_vertical_deg",
                    6.0,
                ),
            ],
        },
        Case {
            id: 5,
            base: BaseKind::Model3,
            seed: 65,
            hidden: vec![Hidden::AsymVertical(0.6)],
            data: Data::ClosedLoop,
            expect: vec!["thrust-asymmetry"],
            params: vec![("thrust-asymmetry", "reverse_ratio_vertical", 0.6)],
        },
        Case {
            id: 6,
            base: BaseKind::Model3,
            seed: 66,
            hidden: vec![Hidden::TorqueV(0.0025)],
            data: Data::ClosedLoopMessy,
            expect: vec!["propeller-torque"],
            params: vec![("propeller-torque", "torque_vertical_m", 2.5)],
        },
        Case {
            id: 7,
            base: BaseKind::Model2,
            seed: 67,
            hidden: vec![Hidden::YawHeaveSq(0.5)],
            data: Data::PlanarOpenLoop,
            expect: vec!["term:yaw:w_absw"],
            params: vec![("term:yaw:w_absw", "coefficient", 0.5)],
        },
        Case {
            id: 8,
            base: BaseKind::Model2,
            seed: 68,
            hidden: vec![],
            data: Data::ClosedLoopMessy,
            expect: vec![],
            params: vec![],
        },
        // The same effects on the model3 truth, diagnosed with a planar base (a base
        // without the truth's pitch and roll).
        Case {
            id: 9,
            base: BaseKind::Model1,
            seed: 61,
            hidden: vec![Hidden::AsymVertical(0.65)],
            data: Data::OpenLoop,
            expect: vec!["thrust-asymmetry"],
            params: vec![("thrust-asymmetry", "reverse_ratio_vertical", 0.65)],
        },
        Case {
            id: 10,
            base: BaseKind::Model2,
            seed: 62,
            hidden: vec![Hidden::Lag(0.2)],
            data: Data::OpenLoop,
            expect: vec!["thruster-lag"],
            params: vec![("thruster-lag", "lag_time_constant_s", 0.2)],
        },
        // Case 3's drift alone on the planar model2 truth and on the model3 truth.
        Case {
            id: 13,
            base: BaseKind::Model2,
            seed: 63,
            hidden: vec![Hidden::DepthDrift(6.0)],
            data: Data::PlanarOpenLoop,
            expect: vec!["depth-sensor-drift"],
            params: vec![("depth-sensor-drift", "depth_drift_mps", 6.0)],
        },
        Case {
            id: 14,
            base: BaseKind::Model3,
            seed: 63,
            hidden: vec![Hidden::DepthDrift(6.0)],
            data: Data::OpenLoop,
            expect: vec!["depth-sensor-drift"],
            params: vec![("depth-sensor-drift", "depth_drift_mps", 6.0)],
        },
        // Case 14's truth without the drift.
        Case {
            id: 15,
            base: BaseKind::Model3,
            seed: 63,
            hidden: vec![],
            data: Data::OpenLoop,
            expect: vec![],
            params: vec![],
        },
        // Case 8 on model3 (the base of the truth) and another seed than real_logs.rs.
        Case {
            id: 16,
            base: BaseKind::Model3,
            seed: 69,
            hidden: vec![],
            data: Data::ClosedLoopMessy,
            expect: vec![],
            params: vec![],
        },
        // hidden_effects.rs's tether_small: a right finding that trades depth and roll
        // for heading on a base that misses several channels (the structural-base veto's
        // boundary).
        Case {
            id: 17,
            base: BaseKind::Model3,
            seed: 11,
            hidden: vec![Hidden::Tether(0.3, 60.0)],
            data: Data::OpenLoop,
            expect: vec!["tether"],
            params: vec![("tether", "tether_east_n", 0.3 * 0.866)],
        },
        // nulls_and_pairs.rs's two simultaneous effects (the structural-base veto's
        // other boundary: the second effect's channels stay missed).
        Case {
            id: 18,
            base: BaseKind::Model3,
            seed: 31,
            hidden: vec![Hidden::AsymVertical(0.55), Hidden::TorqueV(0.0012)],
            data: Data::OpenLoop,
            expect: vec!["thrust-asymmetry", "propeller-torque"],
            params: vec![
                ("thrust-asymmetry", "reverse_ratio_vertical", 0.55),
                ("propeller-torque", "torque_vertical_m", 1.2),
            ],
        },
        // What the hidden evaluation names and the cases above lack: two simultaneous
        // effects under model1 and in closed loop, an outside-catalog term in closed loop.
        Case {
            id: 19,
            base: BaseKind::Model1,
            seed: 81,
            hidden: vec![Hidden::AsymVertical(0.6), Hidden::TorqueV(0.002)],
            data: Data::PlanarOpenLoop,
            expect: vec!["thrust-asymmetry", "propeller-torque"],
            params: vec![
                ("thrust-asymmetry", "reverse_ratio_vertical", 0.6),
                ("propeller-torque", "torque_vertical_m", 2.0),
            ],
        },
        Case {
            id: 20,
            base: BaseKind::Model3,
            seed: 82,
            hidden: vec![Hidden::AsymVertical(0.6), Hidden::TorqueV(0.0025)],
            data: Data::ClosedLoopMessy,
            expect: vec!["thrust-asymmetry", "propeller-torque"],
            params: vec![
                ("thrust-asymmetry", "reverse_ratio_vertical", 0.6),
                ("propeller-torque", "torque_vertical_m", 2.5),
            ],
        },
        Case {
            id: 21,
            base: BaseKind::Model3,
            seed: 83,
            hidden: vec![Hidden::YawHeaveSq(0.5)],
            data: Data::ClosedLoop,
            expect: vec!["term:yaw:w_absw"],
            params: vec![("term:yaw:w_absw", "coefficient", 0.5)],
        },
        // Effect-free planar truths (false findings on the planar bases).
        Case {
            id: 11,
            base: BaseKind::Model1,
            seed: 71,
            hidden: vec![],
            data: Data::PlanarOpenLoop,
            expect: vec![],
            params: vec![],
        },
        Case {
            id: 12,
            base: BaseKind::Model2,
            seed: 72,
            hidden: vec![],
            data: Data::PlanarOpenLoop,
            expect: vec![],
            params: vec![],
        },
    ]
}

fn runs_of(c: &Case) -> (Vec<Run>, Vec<Run>) {
    match c.data {
        Data::OpenLoop => {
            let (tr, va) = case_len(c.seed, &c.hidden, 360.0, 180.0);
            (
                vec![Run::from_series(&tr, "train").unwrap()],
                vec![Run::from_series(&va, "val").unwrap()],
            )
        }
        Data::PlanarOpenLoop => {
            let (tr, va) = planar_case(c.base.name(), c.seed, &c.hidden, 360.0, 180.0);
            (
                vec![Run::from_series(&tr, "train").unwrap()],
                vec![Run::from_series(&va, "val").unwrap()],
            )
        }
        Data::ClosedLoop | Data::ClosedLoopMessy => {
            let mut tr = closed_loop_run(c.seed, c.seed, &c.hidden, 420.0);
            let mut va = closed_loop_run(c.seed, c.seed + 1, &c.hidden, 240.0);
            if matches!(c.data, Data::ClosedLoopMessy) {
                mess_up(&mut tr, c.seed + 7, 3, 2, Some((150.0, 2.5)));
                mess_up(&mut va, c.seed + 8, 2, 3, None);
            }
            (
                runs_from_text(&tr.to_csv(), "train.csv").unwrap(),
                runs_from_text(&va.to_csv(), "val.csv").unwrap(),
            )
        }
    }
}

/// Accepted effect keys and term ids.
fn accepted(d: &Diagnosis) -> Vec<String> {
    let names = d.final_model.command_names();
    d.accepted
        .iter()
        .map(|e| e.key().to_string())
        .chain(d.accepted_terms.iter().map(|t| t.id(&names)))
        .collect()
}

fn finding<'a>(d: &'a Diagnosis, key: &str) -> Option<&'a rov_lab::diagnose::Finding> {
    d.findings.iter().find(|f| f.effect.starts_with(key))
}

/// Right or wrong, with the reasons.
fn judge(c: &Case, d: &Diagnosis) -> (bool, Vec<String>) {
    let acc = accepted(d);
    let mut why = Vec::new();
    for e in &c.expect {
        if !acc.iter().any(|a| a.starts_with(e)) {
            why.push(format!("missed {e}"));
        }
    }
    for a in &acc {
        let expected = c.expect.iter().any(|e| a.starts_with(e));
        // A refit of a base parameter the model already has is not a false finding.
        let contained = finding(d, a).is_some_and(|f| f.contained);
        if !expected && !contained {
            why.push(format!("false {a}"));
        }
    }
    if let Some(top) = c.expect.first()
        && !d.findings.is_empty()
        && !c.expect.iter().any(|e| d.findings[0].effect.starts_with(e))
        && acc.iter().any(|a| a.starts_with(top))
    {
        why.push(format!("top is {}", d.findings[0].effect));
    }
    for (e, p, truth) in &c.params {
        if let Some(f) = finding(d, e).filter(|f| f.significant)
            && let Some(v) = f.params.get(*p)
        {
            let err = (v.value - truth).abs() / truth.abs();
            if err > 0.35 {
                why.push(format!(
                    "{p} {:.3} vs {truth} ({:.0} %)",
                    v.value,
                    100.0 * err
                ));
            }
        }
    }
    if matches!(d.verdict, Verdict::Adequate | Verdict::Explained) {
        for t in &d.consistency {
            if t.ratio > 2.0 {
                why.push(format!(
                    "{} verdict with {} at {:.1}× its floor",
                    d.verdict.name(),
                    t.channel,
                    t.ratio
                ));
            }
        }
    }
    (why.is_empty(), why)
}

fn detail(d: &Diagnosis, expect: &[&str]) -> String {
    let mut s = format!("    summary: {}\n", d.summary);
    for f in d.findings.iter().take(4) {
        s += &format!(
            "    finding {} [{}] {:?} contained {} score {:.1} red {:?} params {:?}\n",
            f.effect,
            f.kind,
            f.status,
            f.contained,
            f.score,
            f.validation_rmse_reduction_pct
                .iter()
                .map(|(k, v)| format!("{k}:{v:.0}"))
                .collect::<Vec<_>>(),
            f.params
                .iter()
                .map(|(k, p)| format!("{k}={:.4}", p.value))
                .collect::<Vec<_>>()
        );
    }
    if std::env::var("PROBE_EXPLAIN").is_ok() {
        let expected_later = d
            .findings
            .iter()
            .skip(4)
            .filter(|f| expect.iter().any(|e| f.effect.starts_with(e)));
        for f in d.findings.iter().take(4).chain(expected_later) {
            s += &format!(
                "    why {}: {}\n      reductions shooting {:?} free run {:?}\n",
                f.effect,
                f.explanation,
                f.validation_rmse_reduction_pct_shooting
                    .iter()
                    .map(|(k, v)| format!("{k}:{v:.0}"))
                    .collect::<Vec<_>>(),
                f.validation_rmse_reduction_pct_free_run
                    .iter()
                    .map(|(k, v)| format!("{k}:{v:.0}"))
                    .collect::<Vec<_>>()
            );
            for c in &f.conflicts {
                s += &format!("      conflict: {c}\n");
            }
        }
    }
    if std::env::var("PROBE_EXPLAIN").is_ok() {
        s += &format!(
            "    calibration {:?}\n",
            d.calibration
                .iter()
                .map(|p| format!(
                    "{}={:.4}{}",
                    p.key,
                    p.value,
                    if p.at_bound { " (at bound)" } else { "" }
                ))
                .collect::<Vec<_>>()
        );
    }
    for (ch, b) in &d.baseline {
        s += &format!(
            "    base {ch}: rmse shooting {:.4} free run {:.4} noise {:.4}\n",
            b.rmse_shooting, b.rmse_free_run, b.noise
        );
    }
    for (name, m) in &d.error_fall {
        s += &format!(
            "    fall {name}: shooting {:?} free {:?}\n",
            m.shooting
                .iter()
                .map(|(k, v)| format!("{k}:{v:.4}"))
                .collect::<Vec<_>>(),
            m.free_run
                .iter()
                .map(|(k, v)| format!("{k}:{v:.4}"))
                .collect::<Vec<_>>()
        );
    }
    for t in &d.consistency {
        s += &format!(
            "    test {}: rmse {:.4} noise {:.4} ratio {:.2} level {:.2}/{:.2} consistent {}\n",
            t.channel, t.rmse, t.noise, t.ratio, t.level, t.level_critical, t.consistent
        );
    }
    for u in &d.unexplained {
        s += &format!("    unexplained {} ratio {:.2}\n", u.channel, u.ratio);
    }
    for n in d.calibration_notes.iter().chain(&d.search_notes) {
        s += &format!("    note: {n}\n");
    }
    s
}

#[test]
#[ignore = "design experiment: prints a table, asserts nothing; run with --ignored --nocapture"]
fn probe() {
    let only: Option<Vec<usize>> = std::env::var("PROBE")
        .ok()
        .map(|s| s.split(',').filter_map(|x| x.parse().ok()).collect());
    let mut rows = Vec::new();
    for c in cases() {
        if only.as_ref().is_some_and(|o| !o.contains(&c.id)) {
            continue;
        }
        let (tr, va) = runs_of(&c);
        let m = LabModel::default_base(c.base).unwrap();
        let t = std::time::Instant::now();
        let d = diagnose(
            &m,
            c.base.name(),
            &tr,
            &va,
            &DiagnoseOptions {
                threads: 2,
                // Experiment hooks: PROBE_CAL_ITERS and PROBE_CONFIRM_ITERS override the
                // LM iterations of the calibration and of the confirmation fits.
                calibration_iterations: std::env::var("PROBE_CAL_ITERS")
                    .ok()
                    .and_then(|s| s.parse().ok())
                    .unwrap_or(DiagnoseOptions::default().calibration_iterations),
                confirm_iterations: std::env::var("PROBE_CONFIRM_ITERS")
                    .ok()
                    .and_then(|s| s.parse().ok())
                    .unwrap_or(DiagnoseOptions::default().confirm_iterations),
                ..Default::default()
            },
        )
        .unwrap();
        let secs = t.elapsed().as_secs_f64();
        let (ok, why) = judge(&c, &d);
        if std::env::var("PROBE_EXPLAIN").is_ok() && matches!(c.data, Data::OpenLoop) {
            println!("    truth: {}", common::truth_summary(c.seed, 0.2));
        }
        let top = d.findings.first().map_or("-".to_string(), |f| {
            format!(
                "{} {:?} {}",
                f.effect,
                f.status,
                f.params
                    .iter()
                    .map(|(k, p)| format!("{k}={:.3}", p.value))
                    .collect::<Vec<_>>()
                    .join(" ")
            )
        });
        let truth = c
            .params
            .iter()
            .map(|(_, p, v)| format!("{p}={v}"))
            .collect::<Vec<_>>()
            .join(" ");
        let row = format!(
            "| {} | {} | {:?} {} | {} | {} | {} | {} | {} | {:.0} s |",
            c.id,
            c.base.name(),
            c.hidden,
            match c.data {
                Data::OpenLoop => "open, model3 truth",
                Data::PlanarOpenLoop => "open, planar truth",
                Data::ClosedLoop => "closed",
                Data::ClosedLoopMessy => "closed+messy",
            },
            d.verdict.name(),
            accepted(&d).join(", "),
            top,
            truth,
            if ok {
                "RIGHT".to_string()
            } else {
                format!("WRONG: {}", why.join("; "))
            },
            secs
        );
        println!("{row}\n{}", detail(&d, &c.expect));
        rows.push(row);
    }
    println!(
        "| # | base | truth | verdict | accepted | top finding | truth params | judged | time |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for r in rows {
        println!("{r}");
    }
}
