//! Probe of issue 26 §3 ("honest on more of what it meets", design experiment, asserts
//! nothing): one case per class of error the issue names, on the test generator's model3
//! truth (tests/common, written independently of the lab's term code):
//! (a) a missing moment that depends on the body velocities, in pitch, roll and yaw;
//! (b) the base carrying a coupling the vehicle lacks (the truth cancels model3's kept
//!     added-mass Munk coupling), on a short well-excited dive and a long one, and
//!     effect-free vehicles whose parameters are all off by 10–30 % (random sign) at
//!     5, 20 and 50 Hz;
//! (c) a long, slowly sampled dive (5 Hz) with one right term present;
//! (d) a slow depth-sensor drift alone and beside a net-buoyancy error;
//! (e) two separate causes at once, each on its own channels.
//!
//! For each case: what was accepted, the verdict, each channel's held-out rmse over its
//! noise floor, and a judgement: RIGHT; HONEST MISS (an expected name missed, or an
//! effect-free dive not called adequate, with nothing false named and the verdict
//! "unexplained": "I cannot explain this, here is where it fails"); WRONG (a name the
//! truth does not carry, a parameter more than 35 % off, or an adequate/explained verdict
//! with a channel above 2× its floor).
//!
//! Run: `cargo test -p rov_lab --release --test it honesty_probe:: -- --ignored
//! --nocapture` (`PROBE=a1,d2` runs only those cases).

use crate::common;

use common::{Hidden, case_sampled};
use rov_lab::diagnose::{DiagnoseOptions, Diagnosis, diagnose};
use rov_lab::verdict::Verdict;
use rov_lab::{BaseKind, LabModel, Run};

/// One probe case.
pub struct Case {
    id: &'static str,
    seed: u64,
    hidden: Vec<Hidden>,
    /// Training and held-out durations, s, and the sample period, s.
    train_s: f64,
    val_s: f64,
    dt_s: f64,
    /// Names (catalog keys or `term:` id prefixes) that should be accepted.
    expect: Vec<&'static str>,
    /// Parameter to compare with the truth: (finding prefix, parameter, truth).
    param: Option<(&'static str, &'static str, f64)>,
}

fn case(
    id: &'static str,
    seed: u64,
    hidden: Vec<Hidden>,
    (train_s, val_s, dt_s): (f64, f64, f64),
    expect: Vec<&'static str>,
    param: Option<(&'static str, &'static str, f64)>,
) -> Case {
    Case {
        id,
        seed,
        hidden,
        train_s,
        val_s,
        dt_s,
        expect,
        param,
    }
}

/// Six minutes of training and three held out at 20 Hz (the other lab tests' size).
const SHORT: (f64, f64, f64) = (360.0, 180.0, 0.05);

pub fn cases() -> Vec<Case> {
    vec![
        // (a) Moments from the body velocities.
        case(
            "a1",
            201,
            vec![Hidden::PitchSpeedSq(0.04)],
            SHORT,
            vec!["term:pitch"],
            Some(("term:pitch", "coefficient", 0.04)),
        ),
        case(
            "a2",
            202,
            vec![Hidden::RollTurnSpeed(0.05)],
            SHORT,
            vec!["term:roll"],
            Some(("term:roll", "coefficient", 0.05)),
        ),
        case(
            "a3",
            203,
            vec![Hidden::YawSpeedSq(0.02)],
            SHORT,
            vec!["term:yaw"],
            Some(("term:yaw", "coefficient", 0.02)),
        ),
        case(
            "a4",
            204,
            vec![Hidden::PitchSurgeHeave(0.15)],
            SHORT,
            vec!["term:pitch"],
            Some(("term:pitch", "coefficient", 0.15)),
        ),
        // (b) The base's coupling the vehicle lacks; effect-free with all parameters off.
        case(
            "b1",
            211,
            vec![Hidden::MunkRemoved(1.0, 1.0)],
            (240.0, 120.0, 0.05),
            vec!["term:pitch"],
            None,
        ),
        case(
            "b2",
            212,
            vec![Hidden::MunkRemoved(1.0, 1.0)],
            (1200.0, 360.0, 0.1),
            vec!["term:pitch"],
            None,
        ),
        case(
            "b3",
            213,
            vec![Hidden::Perturb(0.1, 0.3)],
            SHORT,
            vec![],
            None,
        ),
        case(
            "b4",
            214,
            vec![Hidden::Perturb(0.1, 0.3)],
            (1800.0, 600.0, 0.2),
            vec![],
            None,
        ),
        case(
            "b5",
            215,
            vec![Hidden::Perturb(0.1, 0.3)],
            (600.0, 240.0, 0.02),
            vec![],
            None,
        ),
        // More of (a) and (b): other signs, seeds and sizes (not tuned on).
        case(
            "a5",
            205,
            vec![Hidden::PitchSpeedSq(-0.03)],
            SHORT,
            vec!["term:pitch"],
            None,
        ),
        case(
            "a6",
            206,
            vec![Hidden::RollTurnSpeed(-0.04)],
            SHORT,
            vec!["term:roll"],
            None,
        ),
        case(
            "b6",
            216,
            vec![Hidden::MunkRemoved(0.5, 0.0)],
            (240.0, 120.0, 0.05),
            vec!["term:pitch"],
            None,
        ),
        case(
            "b7",
            217,
            vec![Hidden::Perturb(0.1, 0.3)],
            (600.0, 300.0, 0.05),
            vec![],
            None,
        ),
        case(
            "b8",
            218,
            vec![Hidden::Perturb(0.1, 0.3)],
            (240.0, 120.0, 0.1),
            vec![],
            None,
        ),
        // (c) Long, slowly sampled, one right term.
        case(
            "c1",
            221,
            vec![Hidden::YawSpeedDamp(0.15)],
            (2400.0, 720.0, 0.2),
            vec!["term:yaw:r_absu"],
            Some(("term:yaw:r_absu", "coefficient", -0.15)),
        ),
        case(
            "c2",
            222,
            vec![Hidden::HeaveLift(-0.3)],
            (1800.0, 600.0, 0.2),
            vec!["term:heave:u_absu"],
            Some(("term:heave:u_absu", "coefficient", -0.3)),
        ),
        // (d) Depth-sensor drift alone and beside a net-buoyancy error.
        case(
            "d1",
            231,
            vec![Hidden::DepthDrift(5.0)],
            SHORT,
            vec!["depth-sensor-drift"],
            Some(("depth-sensor-drift", "depth_drift_mps", 5.0)),
        ),
        case(
            "d2",
            232,
            vec![Hidden::DepthDrift(5.0), Hidden::NetBuoyancy(0.6)],
            SHORT,
            vec!["depth-sensor-drift"],
            Some(("depth-sensor-drift", "depth_drift_mps", 5.0)),
        ),
        case(
            "d3",
            233,
            vec![Hidden::DepthDrift(12.0)],
            SHORT,
            vec!["depth-sensor-drift"],
            Some(("depth-sensor-drift", "depth_drift_mps", 12.0)),
        ),
        case(
            "d4",
            234,
            vec![Hidden::NetBuoyancy(0.6)],
            SHORT,
            vec!["net-buoyancy"],
            None,
        ),
        case(
            "d5",
            235,
            vec![Hidden::DepthDrift(5.0)],
            (600.0, 300.0, 0.05),
            vec!["depth-sensor-drift"],
            Some(("depth-sensor-drift", "depth_drift_mps", 5.0)),
        ),
        case(
            "d6",
            236,
            vec![Hidden::DepthDrift(-4.0), Hidden::NetBuoyancy(-0.5)],
            (600.0, 300.0, 0.05),
            vec!["depth-sensor-drift"],
            Some(("depth-sensor-drift", "depth_drift_mps", -4.0)),
        ),
        // (e) Two separate causes, each on its own channels.
        case(
            "e1",
            241,
            vec![Hidden::PowerLimit(0.7), Hidden::Tether(0.8, 150.0)],
            SHORT,
            vec!["power-limit", "tether"],
            Some(("power-limit", "power_max", 0.7)),
        ),
        case(
            "e2",
            242,
            vec![Hidden::Lag(0.25), Hidden::Tether(0.8, 240.0)],
            SHORT,
            vec!["thruster-lag", "tether"],
            Some(("thruster-lag", "lag_time_constant_s", 0.25)),
        ),
        // e2's causes alone (what each does without the other), and its vehicle
        // without either.
        case("e0", 242, vec![], SHORT, vec![], None),
        case(
            "e3",
            242,
            vec![Hidden::Tether(0.8, 240.0)],
            SHORT,
            vec!["tether"],
            None,
        ),
        case(
            "e4",
            242,
            vec![Hidden::Lag(0.25)],
            SHORT,
            vec!["thruster-lag"],
            Some(("thruster-lag", "lag_time_constant_s", 0.25)),
        ),
        case(
            "e5",
            245,
            vec![Hidden::AsymVertical(0.7), Hidden::Tether(0.5, 60.0)],
            SHORT,
            vec!["thrust-asymmetry", "tether"],
            Some(("thrust-asymmetry", "reverse_ratio_vertical", 0.7)),
        ),
    ]
}

/// Accepted effect keys and term ids.
pub fn accepted(d: &Diagnosis) -> Vec<String> {
    let names = d.final_model.command_names();
    d.accepted
        .iter()
        .map(|e| e.key().to_string())
        .chain(d.accepted_terms.iter().map(|t| t.id(&names)))
        .collect()
}

/// Each channel's held-out rmse over its noise floor.
pub fn ratios(d: &Diagnosis) -> String {
    d.consistency
        .iter()
        .map(|t| format!("{} {:.1}", t.channel, t.ratio))
        .collect::<Vec<_>>()
        .join(", ")
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
        let contained = d
            .findings
            .iter()
            .find(|f| f.effect == *a)
            .is_some_and(|f| f.contained);
        if !expected && !contained {
            why.push(format!("false {a}"));
        }
    }
    if let Some((e, p, truth)) = c.param
        && let Some(f) = d
            .findings
            .iter()
            .find(|f| f.effect.starts_with(e) && f.significant)
        && let Some(v) = f.params.get(p)
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
    if c.expect.is_empty() && d.verdict != Verdict::Adequate {
        why.push(format!("{} on an effect-free dive", d.verdict.name()));
    }
    if matches!(d.verdict, Verdict::Adequate | Verdict::Explained) {
        for t in &d.consistency {
            if t.ratio > 2.0 {
                why.push(format!(
                    "{} with {} at {:.1}× floor",
                    d.verdict.name(),
                    t.channel,
                    t.ratio
                ));
            }
        }
    }
    (why.is_empty(), why)
}

#[test]
#[ignore = "design experiment: prints a table, asserts nothing; run with --ignored --nocapture"]
fn honesty_probe() {
    let only: Option<Vec<String>> = std::env::var("PROBE")
        .ok()
        .map(|s| s.split(',').map(str::to_string).collect());
    let mut rows = Vec::new();
    for c in cases() {
        if only.as_ref().is_some_and(|o| !o.iter().any(|x| x == c.id)) {
            continue;
        }
        let (tr, va) = case_sampled(c.seed, &c.hidden, c.train_s, c.val_s, c.dt_s);
        let tr = Run::from_series(&tr, "train").unwrap();
        let va = Run::from_series(&va, "val").unwrap();
        let m = LabModel::default_base(BaseKind::Model3).unwrap();
        let t = std::time::Instant::now();
        let d = diagnose(
            &m,
            "model3",
            &[tr],
            &[va],
            &DiagnoseOptions {
                threads: 2,
                // Experiment hooks: PROBE_CAL_ITERS and PROBE_CONFIRM_ITERS override the LM
                // budgets of the calibration and of the confirmation fits.
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
        let top = d.findings.first().map_or("-".to_string(), |f| {
            format!(
                "{} {}",
                f.effect,
                f.params
                    .iter()
                    .map(|(k, p)| format!("{k}={:.3}", p.value))
                    .collect::<Vec<_>>()
                    .join(" ")
            )
        });
        let row = format!(
            "| {} | {:?} {:.0}+{:.0} s @{:.0} Hz | {} | {} | {} | {} | {} | {:.0} s |",
            c.id,
            c.hidden,
            c.train_s,
            c.val_s,
            1.0 / c.dt_s,
            d.verdict.name(),
            accepted(&d).join(", "),
            top,
            ratios(&d),
            if ok {
                "RIGHT".to_string()
            } else if d.verdict == Verdict::Unexplained
                && why
                    .iter()
                    .all(|w| w.starts_with("missed") || w.starts_with("unexplained"))
            {
                // Nothing false named, and the verdict says the model is not adequate.
                format!("HONEST MISS: {}", why.join("; "))
            } else {
                format!("WRONG: {}", why.join("; "))
            },
            secs
        );
        println!("{row}\n    summary: {}", d.summary);
        if std::env::var("PROBE_EXPLAIN").is_ok() {
            println!(
                "    calibration {:?}",
                d.calibration
                    .iter()
                    .map(|p| format!("{}={:.4}", p.key, p.value))
                    .collect::<Vec<_>>()
            );
            for f in &d.findings {
                println!(
                    "    finding {} [{}] {:?}: {}",
                    f.effect, f.kind, f.status, f.explanation
                );
            }
        }
        for n in d.search_notes.iter().chain(&d.calibration_notes) {
            println!("    note: {n}");
        }
        rows.push(row);
    }
    println!("| case | truth | verdict | accepted | top finding | rmse/noise | judged | time |");
    println!("|---|---|---|---|---|---|---|---|");
    for r in rows {
        println!("{r}");
    }
}
