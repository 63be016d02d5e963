//! Design experiments behind the lab's choices (calibration views, screening, the timing
//! rule, dead zone and tether identifiability, sweeps over magnitudes). They print tables
//! and assert nothing, so they are ignored in the suite; the acceptance tests are in
//! hidden_effects.rs, nulls_and_pairs.rs and lab_api.rs.
//!
//! `cargo test -p rov_lab --test it experiment:: -- --ignored --nocapture`

use crate::common;
use common::*;
use rov_dynamics::models::Channel;
use rov_lab::calibrate::View;
use rov_lab::metrics::channel_metrics;
use rov_lab::sim::simulate_run;
use rov_lab::{BaseKind, LabModel, Run};

fn report(tag: &str, m: &LabModel, run: &Run) {
    for view in [View::FreeRun, View::Shooting(20.0)] {
        let p = simulate_run(m, run, &view.resets(run)).unwrap();
        let mut s = format!("{tag} {view:?}:");
        for ch in [
            Channel::Depth,
            Channel::Heading,
            Channel::Pitch,
            Channel::Roll,
        ] {
            if let Some(mm) = channel_metrics(run, &p, ch) {
                s += &format!(" {:?} rmse={:.4} max={:.4}", ch, mm.rmse, mm.max_abs);
            }
        }
        println!("{s}");
    }
}

#[test]
#[ignore = "design experiment: prints tables, asserts nothing; run with --ignored --nocapture"]
fn exp_calibrate() {
    use rov_lab::calibrate::calibrate;
    use rov_lab::lm::LmOptions;
    let (tr, va) = case(1, &[]);
    println!("truth {}", truth_summary(1, 0.2));
    let tr = Run::from_series(&tr, "train").unwrap();
    let va = Run::from_series(&va, "val").unwrap();
    for kind in [BaseKind::Model3, BaseKind::Model1] {
        let m = LabModel::default_base(kind).unwrap();
        let t = std::time::Instant::now();
        let runs = vec![tr.clone()];
        let cal = calibrate(
            &m,
            &runs,
            &LmOptions {
                max_iter: 10,
                threads: 1,
                ..Default::default()
            },
        )
        .unwrap();
        println!(
            "{kind:?} calib {:?} iters {} evals {} cost0 {:.1} cost {:.1} n {}",
            t.elapsed(),
            cal.lm.iterations,
            cal.lm.evaluations,
            cal.cost0,
            cal.cost,
            cal.n_res
        );
        for f in &cal.fitted {
            println!(
                "  {} {:.4} ± {:.4} (init {:.4})",
                f.key, f.value, f.std, f.initial
            );
        }
        report("cal-train", &cal.model, &tr);
        report("cal-val", &cal.model, &va);
    }
}

#[test]
#[ignore = "design experiment: prints tables, asserts nothing; run with --ignored --nocapture"]
fn exp_consistency() {
    let sched = paper_schedule(1, 200.0, &[30.0, 60.0, 90.0], 12.0, 8.0);
    let s = truth_run(1, 1, &[], &sched, 0.0, 0.05);
    let run = Run::from_series(&s, "t").unwrap();
    let m = LabModel::default_base(BaseKind::Model3).unwrap();
    report("nominal", &m, &run);
    let m1 = LabModel::default_base(BaseKind::Model1).unwrap();
    report("nominal-m1", &m1, &run);
    let m2 = LabModel::default_base(BaseKind::Model2).unwrap();
    report("nominal-m2", &m2, &run);
    let p1 = simulate_run(&m1, &run, &[0]).unwrap();
    for k in (0..run.len()).step_by(200) {
        println!(
            "m1 t={:.2} y={:.2} p={:.2} z={:.3} pz={:.3}",
            run.t[k],
            run.channel(Channel::Heading).unwrap()[k],
            p1.channel(Channel::Heading).unwrap()[k],
            run.channel(Channel::Depth).unwrap()[k],
            p1.channel(Channel::Depth).unwrap()[k]
        );
    }
    let p = simulate_run(&m, &run, &[0]).unwrap();
    let y = run.channel(Channel::Heading).unwrap();
    let ph = p.channel(Channel::Heading).unwrap();
    for k in (0..run.len()).step_by(100) {
        println!(
            "t={:.2} cmd={:?} y={:.2} p={:.2} z={:.3} pz={:.3}",
            run.t[k],
            run.cmd[k],
            y[k],
            ph[k],
            run.channel(Channel::Depth).unwrap()[k],
            p.channel(Channel::Depth).unwrap()[k]
        );
    }
}

fn run_case(tag: &str, kind: BaseKind, hidden: &[Hidden], seed: u64) {
    use rov_lab::diagnose::{DiagnoseOptions, diagnose};
    let tl: f64 = std::env::var("TL")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(600.0);
    let vl: f64 = std::env::var("VL")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(300.0);
    let (tr, va) = case_len(seed, hidden, tl, vl);
    let tr = Run::from_series(&tr, "train").unwrap();
    let va = Run::from_series(&va, "val").unwrap();
    let m = LabModel::default_base(kind).unwrap();
    let t = std::time::Instant::now();
    let s0 = rov_lab::sim::simulation_count();
    let d = diagnose(
        &m,
        kind.name(),
        &[tr],
        &[va],
        &DiagnoseOptions {
            threads: 1,
            ..Default::default()
        },
    )
    .unwrap();
    println!(
        "=== {tag} {hidden:?} seed {seed}: {} ({:?}, {} sims)",
        d.summary,
        t.elapsed(),
        rov_lab::sim::simulation_count() - s0
    );
    for (k, b) in &d.baseline {
        println!(
            "   base {k}: rmse {:.4} shoot {:.4} noise {:.4}",
            b.rmse_free_run, b.rmse_shooting, b.noise
        );
    }
    for f in d.findings.iter().take(7) {
        let red: Vec<String> = f
            .validation_rmse_reduction_pct
            .iter()
            .map(|(k, v)| format!("{k}:{v:.0}"))
            .collect();
        let reds: Vec<String> = f
            .validation_rmse_reduction_pct_shooting
            .iter()
            .map(|(k, v)| format!("{k}:{v:.0}"))
            .collect();
        let ps: Vec<String> = f
            .params
            .iter()
            .map(|(k, v)| format!("{k}={:.4}", v.value))
            .collect();
        println!(
            "  {} {:?} sig={} dbic={:?} score={:.1} free[{}] shoot[{}] {}",
            f.effect,
            f.status,
            f.significant,
            f.delta_bic.map(|x| x.round()),
            f.score,
            red.join(" "),
            reds.join(" "),
            ps.join(" ")
        );
        if std::env::var("EXPL").is_ok() {
            println!("      {}", f.explanation);
        }
    }
}

#[test]
#[ignore = "design experiment: prints tables, asserts nothing; run with --ignored --nocapture"]
fn exp_diag() {
    let which = std::env::var("EXP").unwrap_or_default();
    let cases: Vec<(&str, Vec<Hidden>)> = vec![
        ("null", vec![]),
        ("asymV", vec![Hidden::AsymVertical(0.7)]),
        ("lag", vec![Hidden::Lag(0.25)]),
        ("armxv", vec![Hidden::ArmXv(0.02)]),
        ("torque", vec![Hidden::TorqueV(0.002)]),
        ("tether", vec![Hidden::Tether(1.0, 60.0)]),
        ("drift", vec![Hidden::DepthDrift(3.0)]),
        ("emi", vec![Hidden::CompassEmiV(5.0)]),
        ("buoy", vec![Hidden::NetBuoyancy(0.6)]),
        ("dead", vec![Hidden::Deadzone(0.15)]),
        ("power", vec![Hidden::PowerLimit(0.6)]),
        ("cgx", vec![Hidden::CgX(0.0005)]),
        ("pbias", vec![Hidden::PitchBias(2.0)]),
        ("dragh", vec![Hidden::DragHeave(1.4)]),
        ("dead2", vec![Hidden::Deadzone(0.2)]),
        ("asym1", vec![Hidden::AsymVertical(0.75)]),
        ("arm1", vec![Hidden::ArmXv(0.01)]),
        ("power1", vec![Hidden::PowerLimit(0.8)]),
        ("dead1", vec![Hidden::Deadzone(0.12)]),
        ("null", vec![]),
        ("arm2", vec![Hidden::ArmXv(0.025)]),
        ("drift1", vec![Hidden::DepthDrift(4.0)]),
        ("cgx2", vec![Hidden::CgX(0.0008)]),
    ];
    for (tag, h) in cases {
        if !which.is_empty() && !which.split(',').any(|w| w == tag) {
            continue;
        }
        let seed = std::env::var("SEED")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(3);
        run_case(tag, BaseKind::Model3, &h, seed);
    }
}

#[test]
#[ignore = "design experiment: prints tables, asserts nothing; run with --ignored --nocapture"]
fn exp_timing() {
    use rov_lab::calibrate::{Objective, View, calibrate};
    use rov_lab::lm::LmOptions;
    let (tr, _va) = case(3, &[]);
    let tr = Run::from_series(&tr, "train").unwrap();
    let runs = vec![tr];
    for kind in [BaseKind::Model3, BaseKind::Model1] {
        let m = LabModel::default_base(kind).unwrap();
        let obj = Objective::new(&m, &runs, View::Shooting(20.0));
        let t = std::time::Instant::now();
        for _ in 0..20 {
            let _ = obj.residuals(&m).unwrap();
        }
        println!("{kind:?} one sim {:?}", t.elapsed() / 20);
        let t = std::time::Instant::now();
        let cal = calibrate(
            &m,
            &runs,
            &LmOptions {
                max_iter: 10,
                threads: 1,
                ..Default::default()
            },
        )
        .unwrap();
        println!(
            "{kind:?} calibrate {:?} iters {} evals {}",
            t.elapsed(),
            cal.lm.iterations,
            cal.lm.evaluations
        );
    }
}

#[test]
#[ignore = "design experiment: prints tables, asserts nothing; run with --ignored --nocapture"]
fn exp_dead() {
    use rov_lab::calibrate::{SHOOTING_WINDOW_S, View, calibrate, fit};
    use rov_lab::lm::LmOptions;
    use rov_lab::params::Param;
    let (tr, va) = case(3, &[Hidden::Deadzone(0.15)]);
    let tr = Run::from_series(&tr, "train").unwrap();
    let _va = Run::from_series(&va, "val").unwrap();
    let runs = vec![tr];
    let m = LabModel::default_base(BaseKind::Model3).unwrap();
    let opts = LmOptions {
        max_iter: 8,
        threads: 2,
        ..Default::default()
    };
    let cal = calibrate(&m, &runs, &opts).unwrap();
    for f in &cal.fitted {
        println!("  {} {:.4}", f.key, f.value);
    }
    println!("cal cost {:.0}", cal.cost);
    let mut free = cal.params.clone();
    free.push(Param::Deadzone);
    for v in [
        View::KStep(40),
        View::KStep(100),
        View::Shooting(SHOOTING_WINDOW_S),
    ] {
        for u0 in [0.0, 0.08, 0.15] {
            let start = cal.model.with(&[Param::Deadzone], &[u0]).unwrap();
            let f0 = fit(
                &cal.model,
                &runs,
                &cal.params,
                v,
                None,
                None,
                &LmOptions {
                    max_iter: 0,
                    ..opts
                },
            )
            .unwrap();
            let r = fit(&start, &runs, &free, v, None, None, &opts).unwrap();
            println!(
                "{v:?} start u0 {u0}: base cost {:.0} -> fitted cost {:.0} (start {:.0}), u0 = {:.4}",
                f0.cost,
                r.cost,
                r.cost0,
                r.model.get(Param::Deadzone).unwrap()
            );
        }
    }
}

#[test]
#[ignore = "design experiment: prints tables, asserts nothing; run with --ignored --nocapture"]
fn exp_tether() {
    use rov_lab::evaluate::evaluate;
    use rov_lab::params::Param;
    let (tr, va) = case(3, &[Hidden::Tether(1.0, 60.0)]);
    let _tr = Run::from_series(&tr, "train").unwrap();
    let va = Run::from_series(&va, "val").unwrap();
    let m = LabModel::default_base(BaseKind::Model3).unwrap();
    let mut mt = m
        .with(&[Param::TetherN, Param::TetherE], &[0.5, 0.866])
        .unwrap();
    mt.add_effect(rov_lab::EffectId::Tether);
    for (name, model) in [("nominal", &m), ("nominal+tether", &mt)] {
        let e = evaluate(model, std::slice::from_ref(&va)).unwrap();
        for (k, c) in &e.channels {
            println!(
                "{name} {}: free {:.3} shoot {:.3}",
                k.name(),
                c.free_run.rmse,
                c.shooting.rmse
            );
        }
        let p = simulate_run(model, &va, &[0]).unwrap();
        let r = p.channel(Channel::Roll).unwrap();
        let y = va.channel(Channel::Roll).unwrap();
        let mx = r.iter().fold(0.0f64, |a, b| a.max(b.abs()));
        let my = y.iter().fold(0.0f64, |a, b| a.max(b.abs()));
        println!("{name}: max |roll| model {mx:.2} truth {my:.2}");
        for k in (0..va.len()).step_by(300) {
            print!("({:.0}: {:.1}/{:.1}) ", va.t[k], r[k], y[k]);
        }
        println!();
    }
}

#[test]
#[ignore = "design experiment: prints tables, asserts nothing; run with --ignored --nocapture"]
fn exp_sweep() {
    use rov_lab::diagnose::{DiagnoseOptions, diagnose};
    let Ok(which) = std::env::var("SWEEP") else {
        return;
    };
    let tl: f64 = std::env::var("TL")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(360.0);
    let vl: f64 = std::env::var("VL")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(180.0);
    let seeds: Vec<u64> = std::env::var("SEEDS")
        .unwrap_or("11".into())
        .split(',')
        .map(|s| s.parse().unwrap())
        .collect();
    let all: Vec<(&str, Hidden, &str, f64)> = vec![
        (
            "asym1",
            Hidden::AsymVertical(0.75),
            "reverse_ratio_vertical",
            0.75,
        ),
        (
            "asym2",
            Hidden::AsymVertical(0.55),
            "reverse_ratio_vertical",
            0.55,
        ),
        ("lag1", Hidden::Lag(0.12), "lag_time_constant_s", 0.12),
        ("lag2", Hidden::Lag(0.3), "lag_time_constant_s", 0.3),
        ("dead1", Hidden::Deadzone(0.12), "deadzone_fraction", 12.0),
        ("dead2", Hidden::Deadzone(0.2), "deadzone_fraction", 20.0),
        ("power1", Hidden::PowerLimit(0.8), "power_max", 0.8),
        ("power2", Hidden::PowerLimit(0.5), "power_max", 0.5),
        ("arm1", Hidden::ArmXv(0.01), "vertical_arm_x_m", 10.0),
        ("arm2", Hidden::ArmXv(0.025), "vertical_arm_x_m", 25.0),
        ("torque1", Hidden::TorqueV(0.001), "torque_vertical_m", 1.0),
        ("torque2", Hidden::TorqueV(0.003), "torque_vertical_m", 3.0),
        ("buoy1", Hidden::NetBuoyancy(0.3), "net_weight_n", 0.3),
        ("buoy2", Hidden::NetBuoyancy(0.8), "net_weight_n", 0.8),
        ("cgx1", Hidden::CgX(0.0003), "cg_x_m", 0.3),
        ("cgx2", Hidden::CgX(0.0008), "cg_x_m", 0.8),
        ("drag1", Hidden::DragHeave(1.25), "drag_ratio_heave", 1.25),
        ("drag2", Hidden::DragHeave(1.5), "drag_ratio_heave", 1.5),
        (
            "tether1",
            Hidden::Tether(0.3, 60.0),
            "tether_east_n",
            0.3 * 0.866,
        ),
        (
            "tether2",
            Hidden::Tether(0.6, 60.0),
            "tether_east_n",
            0.6 * 0.866,
        ),
        ("drift1", Hidden::DepthDrift(4.0), "depth_drift_mps", 4.0),
        ("drift2", Hidden::DepthDrift(10.0), "depth_drift_mps", 10.0),
        (
            "emi1",
            Hidden::CompassEmiV(4.0),
            "compass_interference_vertical_deg",
            4.0,
        ),
        (
            "emi2",
            Hidden::CompassEmiV(8.0),
            "compass_interference_vertical_deg",
            8.0,
        ),
        ("bias1", Hidden::PitchBias(1.5), "pitch_bias_deg", 1.5),
        ("bias2", Hidden::PitchBias(3.0), "pitch_bias_deg", 3.0),
    ];
    for seed in seeds {
        for (tag, h, key, truth) in &all {
            if which != "all" && !which.split(',').any(|w| tag.starts_with(w)) {
                continue;
            }
            let (tr, va) = case_len(seed, &[*h], tl, vl);
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
                    ..Default::default()
                },
            )
            .unwrap();
            let f = &d.findings[0];
            let p = f.params.get(*key).map(|p| p.value).unwrap_or(f64::NAN);
            let home = match f.effect.as_str() {
                "thrust-asymmetry" | "net-buoyancy" | "drag-form" | "depth-sensor-drift" => "depth",
                "thruster-moment-arm" | "restoring-offset" | "attitude-bias" => "pitch",
                _ => "heading",
            };
            let red = f
                .validation_rmse_reduction_pct
                .get(home)
                .copied()
                .unwrap_or(f64::NAN);
            println!(
                "SWEEP {tag} seed {seed}: first {} sig {} red[{home}] {:.0}% param {:.4} truth {:.4} err {:.0}% | accepted {:?} | {:.1}s",
                f.effect,
                f.significant,
                red,
                p,
                truth,
                100.0 * (p - truth).abs() / truth.abs(),
                d.accepted,
                t.elapsed().as_secs_f64()
            );
        }
    }
}

#[test]
#[ignore = "design experiment: prints tables, asserts nothing; run with --ignored --nocapture"]
fn exp_asym() {
    use rov_lab::calibrate::{SHOOTING_WINDOW_S, View, calibrate, fit};
    use rov_lab::lm::LmOptions;
    use rov_lab::params::{Param, Thr};
    let (tr, _va) = case_len(11, &[Hidden::AsymVertical(0.75)], 360.0, 180.0);
    let tr = Run::from_series(&tr, "train").unwrap();
    let runs = vec![tr];
    let m = LabModel::default_base(BaseKind::Model3).unwrap();
    let opts = LmOptions {
        max_iter: 8,
        threads: 2,
        ..Default::default()
    };
    let cal = calibrate(&m, &runs, &opts).unwrap();
    for f in &cal.fitted {
        println!("  {} {:.4}", f.key, f.value);
    }
    let mut free = cal.params.clone();
    free.push(Param::ReverseRatio(Thr::Vertical));
    for v in [View::KStep(40), View::Shooting(SHOOTING_WINDOW_S)] {
        for r0 in [1.0, 0.8, 0.6] {
            let start = cal
                .model
                .with(&[Param::ReverseRatio(Thr::Vertical)], &[r0])
                .unwrap();
            let r = fit(&start, &runs, &free, v, None, None, &opts).unwrap();
            println!(
                "{v:?} start {r0}: cost0 {:.0} -> {:.0}, rho {:.4} iters {}",
                r.cost0,
                r.cost,
                r.model.get(Param::ReverseRatio(Thr::Vertical)).unwrap(),
                r.lm.iterations
            );
        }
        let mut sub: Vec<Param> = vec![
            Param::ThrustLin(Thr::Vertical),
            Param::ThrustQuad(Thr::Vertical),
            Param::DragLin(rov_lab::params::Axis::Heave),
            Param::DragQuad(rov_lab::params::Axis::Heave),
            Param::ThrustLin(Thr::Port),
            Param::ThrustQuad(Thr::Port),
            Param::ThrustLin(Thr::Starboard),
            Param::ThrustQuad(Thr::Starboard),
            Param::DragLin(rov_lab::params::Axis::Yaw),
            Param::DragQuad(rov_lab::params::Axis::Yaw),
        ];
        sub.extend([
            Param::ReverseRatio(Thr::Port),
            Param::ReverseRatio(Thr::Starboard),
            Param::ReverseRatio(Thr::Vertical),
        ]);
        for it in [4, 8] {
            let r = fit(
                &cal.model,
                &runs,
                &sub,
                v,
                None,
                None,
                &LmOptions {
                    max_iter: it,
                    threads: 2,
                    ..Default::default()
                },
            )
            .unwrap();
            println!(
                "{v:?} subset it {it}: cost0 {:.0} -> {:.0}, rho {:.4} iters {} evals {}",
                r.cost0,
                r.cost,
                r.model.get(Param::ReverseRatio(Thr::Vertical)).unwrap(),
                r.lm.iterations,
                r.lm.evaluations
            );
        }
        let only = vec![Param::ReverseRatio(Thr::Vertical)];
        let r = fit(&cal.model, &runs, &only, v, None, None, &opts).unwrap();
        println!(
            "{v:?} rho only: cost0 {:.0} -> {:.0}, rho {:.4}",
            r.cost0,
            r.cost,
            r.model.get(Param::ReverseRatio(Thr::Vertical)).unwrap()
        );
    }
}

#[test]
#[ignore = "design experiment: prints tables, asserts nothing; run with --ignored --nocapture"]
fn exp_null() {
    use rov_lab::diagnose::{DiagnoseOptions, diagnose};
    let Ok(seeds) = std::env::var("NULLS") else {
        return;
    };
    let tl: f64 = std::env::var("TL")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(360.0);
    let vl: f64 = std::env::var("VL")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(180.0);
    let kind = match std::env::var("KIND").as_deref() {
        Ok("model1") => BaseKind::Model1,
        Ok("model2") => BaseKind::Model2,
        _ => BaseKind::Model3,
    };
    let (a, b): (u64, u64) = {
        let v: Vec<u64> = seeds.split('-').map(|s| s.parse().unwrap()).collect();
        (v[0], v[1])
    };
    let mut fp = 0;
    for seed in a..=b {
        let (tr, va) = case_len(seed, &[], tl, vl);
        let tr = Run::from_series(&tr, "train").unwrap();
        let va = Run::from_series(&va, "val").unwrap();
        let m = LabModel::default_base(kind).unwrap();
        let t = std::time::Instant::now();
        let d = diagnose(
            &m,
            "m",
            &[tr],
            &[va],
            &DiagnoseOptions {
                threads: 2,
                ..Default::default()
            },
        )
        .unwrap();
        if !d.accepted.is_empty() || !d.accepted_terms.is_empty() {
            fp += 1;
        }
        if !d.accepted_terms.is_empty() {
            println!(
                "  terms {:?} verdict {:?}",
                d.accepted_terms
                    .iter()
                    .map(|t| t.id(&["port", "starboard", "vertical"]))
                    .collect::<Vec<_>>(),
                d.verdict
            );
        }
        let f = &d.findings[0];
        println!(
            "NULL seed {seed}: accepted {:?} | top {} {:?} score {:.1} red {:?} | {:.1}s",
            d.accepted,
            f.effect,
            f.status,
            f.score,
            f.validation_rmse_reduction_pct
                .iter()
                .map(|(k, v)| format!("{k}:{v:.0}"))
                .collect::<Vec<_>>(),
            t.elapsed().as_secs_f64()
        );
    }
    println!("NULL false positives {fp} of {}", b - a + 1);
}

#[test]
#[ignore = "design experiment: prints tables, asserts nothing; run with --ignored --nocapture"]
fn exp_spikes_on_clean_data() {
    for seed in 1..12u64 {
        let (tr, va) = case_len(seed, &[], 360.0, 180.0);
        for s in [tr, va] {
            let r = Run::from_series(&s, "x").unwrap();
            println!(
                "seed {seed}: spikes {:?} closed {:?}",
                r.treatment.spikes, r.treatment.closed_loop
            );
        }
    }
}

#[test]
#[ignore = "design experiment: prints tables, asserts nothing; run with --ignored --nocapture"]
fn exp_bluerov_ingest() {
    let dir = std::path::PathBuf::from(std::env::var("TOPSIDE_SHARED_DIR").unwrap_or_default())
        .join("real_data/bluerov2_saabmarine_mex");
    let Ok(rd) = std::fs::read_dir(&dir) else {
        return;
    };
    let mut files: Vec<_> = rd.filter_map(|e| e.ok()).map(|e| e.path()).collect();
    files.sort();
    for f in files
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e == "csv"))
    {
        let text = std::fs::read_to_string(f).unwrap();
        let name = f.file_name().unwrap().to_string_lossy().to_string();
        let runs = rov_lab::ingest::runs_from_text(&text, &name).unwrap();
        for s in rov_lab::ingest::treatment_sentences(&runs) {
            println!("{s}");
        }
        for r in &runs {
            println!(
                "  {} n={} segs={} spikes={:?}",
                r.name,
                r.len(),
                r.segments.len(),
                r.treatment.spikes
            );
        }
    }
}

#[test]
#[ignore = "design experiment: prints tables, asserts nothing; run with --ignored --nocapture"]
fn exp_calibrate_iters() {
    use rov_lab::calibrate::calibrate;
    use rov_lab::lm::LmOptions;
    let seed: u64 = std::env::var("SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(5);
    let (tr, va) = case_len(seed, &[], 360.0, 180.0);
    let tr = Run::from_series(&tr, "train").unwrap();
    let va = Run::from_series(&va, "val").unwrap();
    let m = LabModel::default_base(BaseKind::Model3).unwrap();
    for it in [8usize, 16, 30] {
        let t = std::time::Instant::now();
        let cal = calibrate(
            &m,
            std::slice::from_ref(&tr),
            &LmOptions {
                max_iter: it,
                threads: 2,
                ..Default::default()
            },
        )
        .unwrap();
        println!(
            "iters {it}: {:?} lm iters {} cost0 {:.1} cost {:.1} scales heading {:.3}",
            t.elapsed(),
            cal.lm.iterations,
            cal.cost0,
            cal.cost,
            cal.scales[1]
        );
        report("  val", &cal.model, &va);
        report("  train", &cal.model, &tr);
        for f in &cal.fitted {
            println!(
                "  {} {:.4} ± {:.4} (init {:.4}) bound {}",
                f.key, f.value, f.std, f.initial, f.at_bound
            );
        }
        for n in rov_lab::calibrate::calibration_notes(&cal, std::slice::from_ref(&tr)) {
            println!("  note: {n}");
        }
    }
}

#[test]
#[ignore = "design experiment: prints tables, asserts nothing; run with --ignored --nocapture"]
fn exp_calibrate_seeds() {
    use rov_lab::calibrate::calibrate;
    use rov_lab::lm::LmOptions;
    let kind = match std::env::var("KIND").as_deref() {
        Ok("model1") => BaseKind::Model1,
        Ok("model2") => BaseKind::Model2,
        _ => BaseKind::Model3,
    };
    let seeds: Vec<u64> = std::env::var("SEEDS")
        .ok()
        .map(|s| s.split(',').filter_map(|x| x.parse().ok()).collect())
        .unwrap_or_else(|| (100..114).collect());
    let hidden: Vec<Hidden> = match std::env::var("HID").as_deref() {
        Ok("yawspeed") => vec![Hidden::YawSpeedDamp(0.15)],
        Ok("heaverr") => vec![Hidden::HeaveYawSq(0.06)],
        _ => vec![],
    };
    for seed in seeds {
        let (tr, va) = case_len(seed, &hidden, 360.0, 180.0);
        let tr = Run::from_series(&tr, "train").unwrap();
        let va = Run::from_series(&va, "val").unwrap();
        let m = LabModel::default_base(kind).unwrap();
        eprintln!("{}", common::truth_summary(seed, 0.2));
        let t = std::time::Instant::now();
        let cal = calibrate(
            &m,
            std::slice::from_ref(&tr),
            &LmOptions {
                max_iter: 8,
                threads: 2,
                ..Default::default()
            },
        )
        .unwrap();
        let el = t.elapsed();
        let mut s = format!("seed {seed} {:.2}s:", el.as_secs_f64());
        for f in &cal.fitted {
            eprint!(" {}={:.3}", f.key, f.value);
        }
        eprintln!();
        for (tag, run) in [("tr", &tr), ("va", &va)] {
            let p = simulate_run(&cal.model, run, &View::Shooting(20.0).resets(run)).unwrap();
            for ch in [
                Channel::Depth,
                Channel::Heading,
                Channel::Pitch,
                Channel::Roll,
            ] {
                if let Some(mm) = channel_metrics(run, &p, ch) {
                    s += &format!(
                        " {tag}-{:?} {:.1}",
                        ch,
                        mm.rmse / run.noise[rov_lab::data::ch_index(ch)]
                    );
                }
            }
        }
        println!("{s}");
    }
}

fn bluerov_sessions() -> Vec<Run> {
    let dir = std::path::PathBuf::from(std::env::var("TOPSIDE_SHARED_DIR").unwrap_or_default())
        .join("real_data/bluerov2_saabmarine_mex");
    let Ok(rd) = std::fs::read_dir(&dir) else {
        return vec![];
    };
    let mut files: Vec<_> = rd.filter_map(|e| e.ok()).map(|e| e.path()).collect();
    files.sort();
    let mut out = Vec::new();
    for f in files
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e == "csv"))
    {
        let text = std::fs::read_to_string(f).unwrap();
        let name = f.file_name().unwrap().to_string_lossy().to_string();
        out.extend(rov_lab::ingest::runs_from_text(&text, &name[8..27]).unwrap());
    }
    out
}

#[test]
#[ignore = "design experiment: prints tables, asserts nothing; run with --ignored --nocapture"]
fn exp_bluerov_vehicle() {
    use rov_lab::calibrate::calibrate;
    use rov_lab::lm::LmOptions;
    let runs = bluerov_sessions();
    if runs.is_empty() {
        return;
    }
    let text = std::fs::read_to_string(
        std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../../config/vehicles/bluerov2_heavy.toml"),
    )
    .unwrap();
    let m = LabModel::from_vehicle_text(&text, "bluerov2_heavy.toml").unwrap();
    let show = |tag: &str, m: &LabModel, r: &Run| {
        let mut s = format!("{tag} {}:", r.name);
        for view in [View::Shooting(20.0), View::FreeRun] {
            let p = simulate_run(m, r, &view.resets(r));
            let Ok(p) = p else {
                s += &format!(" {view:?} diverged");
                continue;
            };
            for ch in [
                Channel::Depth,
                Channel::Heading,
                Channel::Surge,
                Channel::Pitch,
                Channel::Roll,
                Channel::YawRate,
            ] {
                if let Some(mm) = channel_metrics(r, &p, ch) {
                    s += &format!(
                        " {}{:?}={:.0}",
                        if matches!(view, View::FreeRun) {
                            "fr-"
                        } else {
                            ""
                        },
                        ch,
                        mm.fit_pct.unwrap_or(f64::NAN)
                    );
                }
            }
        }
        println!("{s}");
    };
    for r in &runs {
        show("nominal", &m, r);
    }
    if std::env::var("CV").is_err() {
        return;
    }
    for i in 0..runs.len() {
        let train: Vec<Run> = runs
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != i)
            .map(|(_, r)| r.clone())
            .collect();
        let t = std::time::Instant::now();
        let cal = calibrate(
            &m,
            &train,
            &LmOptions {
                max_iter: 8,
                threads: 2,
                ..Default::default()
            },
        );
        match cal {
            Ok(cal) => {
                println!("fold {i}: {:?}", t.elapsed());
                show("  held-out", &cal.model, &runs[i]);
                for f in &cal.fitted {
                    print!(" {}={:.3}", f.key, f.value);
                }
                println!();
            }
            Err(e) => println!("fold {i}: {e}"),
        }
    }
}

#[test]
#[ignore = "design experiment: prints tables, asserts nothing; run with --ignored --nocapture"]
fn exp_bluerov_trace() {
    let runs = bluerov_sessions();
    if runs.is_empty() {
        return;
    }
    let text = std::fs::read_to_string(
        std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../../config/vehicles/bluerov2_heavy.toml"),
    )
    .unwrap();
    let m = LabModel::from_vehicle_text(&text, "bluerov2_heavy.toml").unwrap();
    let idx: usize = std::env::var("RUN")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(3);
    let r = &runs[idx];
    let p = simulate_run(&m, r, &View::Shooting(20.0).resets(r)).unwrap();
    let chans: Vec<Channel> = match std::env::var("CH").as_deref() {
        Ok("yaw") => vec![
            Channel::YawRate,
            Channel::Heading,
            Channel::Roll,
            Channel::Pitch,
        ],
        _ => vec![
            Channel::Depth,
            Channel::Heave,
            Channel::Pitch,
            Channel::Roll,
            Channel::Surge,
        ],
    };
    let step: usize = std::env::var("STEP")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(5);
    for k in (0..r.len()).step_by(step).take(80) {
        let c = r.inputs[k];
        let mut s = format!(
            "t {:6.1} surge {:4.0} heave {:4.0} yaw {:4.0} |",
            r.t[k], c[4], c[6], c[9]
        );
        for ch in chans.iter().copied() {
            let y = r.channel(ch).map_or(f64::NAN, |v| v[k]);
            let yh = p.channel(ch).map_or(f64::NAN, |v| v[k]);
            s += &format!(" {:?} {:7.2}/{:7.2}", ch, y, yh);
        }
        println!("{s}");
    }
}

#[test]
#[ignore = "design experiment: prints tables, asserts nothing; run with --ignored --nocapture"]
fn exp_bluerov_diag() {
    use rov_lab::diagnose::{DiagnoseOptions, diagnose};
    let runs = bluerov_sessions();
    if runs.is_empty() {
        return;
    }
    let text = std::fs::read_to_string(
        std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../../config/vehicles/bluerov2_heavy.toml"),
    )
    .unwrap();
    let m = match std::env::var("KIND").as_deref() {
        Ok("model3") => LabModel::default_base(BaseKind::Model3).unwrap(),
        _ => LabModel::from_vehicle_text(&text, "bluerov2_heavy.toml").unwrap(),
    };
    let folds: Vec<usize> = std::env::var("FOLDS")
        .ok()
        .map(|s| s.split(',').filter_map(|x| x.parse().ok()).collect())
        .unwrap_or_else(|| (0..runs.len()).collect());
    for i in folds {
        let train: Vec<Run> = runs
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != i)
            .map(|(_, r)| r.clone())
            .collect();
        let val = vec![runs[i].clone()];
        let t = std::time::Instant::now();
        let d = diagnose(
            &m,
            "bluerov",
            &train,
            &val,
            &DiagnoseOptions {
                threads: 2,
                ..Default::default()
            },
        );
        match d {
            Ok(d) => {
                println!(
                    "=== fold {i} ({}) {:?}: {}",
                    runs[i].name,
                    t.elapsed(),
                    d.summary
                );
                for (k, b) in &d.baseline {
                    println!(
                        "   base {k}: fit shoot {:?} free {:?} rmse {:.3} noise {:.3}",
                        b.fit_pct.map(|x| x.round()),
                        b.fit_pct_free_run.map(|x| x.round()),
                        b.rmse_shooting,
                        b.noise
                    );
                }
                let fin = rov_lab::evaluate::evaluate(&d.final_model, &val).unwrap();
                for (k, c) in &fin.channels {
                    println!(
                        "   final {}: fit shoot {:?} free {:?}",
                        k.name(),
                        c.shooting.fit_pct.map(|x| x.round()),
                        c.free_run.fit_pct.map(|x| x.round())
                    );
                }
                for f in d.findings.iter().take(5) {
                    println!("  {} {:?}: {}", f.effect, f.status, f.explanation);
                }
                for n in &d.calibration_notes {
                    println!("  cal: {n}");
                }
                for n in &d.search_notes {
                    println!("  search: {n}");
                }
                for c in &d.calibration {
                    print!(" {}={:.3}", c.key, c.value);
                }
                println!();
            }
            Err(e) => println!("=== fold {i}: {e}"),
        }
    }
}

#[test]
#[ignore = "design experiment: prints tables, asserts nothing; run with --ignored --nocapture"]
fn exp_vehicle_idle() {
    let text = std::fs::read_to_string(
        std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../../config/vehicles/bluerov2_heavy.toml"),
    )
    .unwrap();
    let m = LabModel::from_vehicle_text(&text, "bluerov2_heavy.toml").unwrap();
    let roll0: f64 = std::env::var("ROLL0")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0.2);
    let p0: f64 = std::env::var("P0")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0.0);
    let v0: f64 = std::env::var("V0")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0.0);
    let r0: f64 = std::env::var("R0")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0.0);
    let mut csv = String::from(
        "t,dt_next,x,y,z,roll,pitch,yaw,u,v,w,p,q,r,ch1_pitch,ch2_roll,ch3_heave,ch4_yaw,ch5_surge,ch6_sway\n",
    );
    for k in 0..300 {
        let t = k as f64 * 0.2;
        csv += &format!("{t},0.2,0,0,0,{roll0},0,0,0,{v0},0,{p0},0,{r0},0,0,0,0,0,0\n");
    }
    let runs = rov_lab::ingest::runs_from_text(&csv, "idle").unwrap();
    let r = &runs[0];
    let p = simulate_run(&m, r, &[0]).unwrap();
    for k in (0..r.len()).step_by(10) {
        println!(
            "t {:5.1} roll {:8.2} pitch {:8.2} yawrate {:8.3}",
            r.t[k],
            p.channel(Channel::Roll).map_or(f64::NAN, |v| v[k]),
            p.channel(Channel::Pitch).map_or(f64::NAN, |v| v[k]),
            p.channel(Channel::YawRate).map_or(f64::NAN, |v| v[k]),
        );
    }
}

#[test]
#[ignore = "design experiment: prints tables, asserts nothing; run with --ignored --nocapture"]
fn exp_seed22_truth_params() {
    use rov_lab::params::{Axis, Param, Thr};
    let (tr, va) = case_len(22, &[], 360.0, 180.0);
    let tr = Run::from_series(&tr, "train").unwrap();
    let va = Run::from_series(&va, "val").unwrap();
    let m = LabModel::default_base(BaseKind::Model3).unwrap();
    let ps = [
        Param::ThrustLin(Thr::Vertical),
        Param::ThrustQuad(Thr::Vertical),
        Param::ThrustLin(Thr::Port),
        Param::ThrustQuad(Thr::Port),
        Param::ThrustLin(Thr::Starboard),
        Param::ThrustQuad(Thr::Starboard),
        Param::DragLin(Axis::Heave),
        Param::DragQuad(Axis::Heave),
        Param::DragLin(Axis::Yaw),
        Param::DragQuad(Axis::Yaw),
        Param::CgZ,
    ];
    let vals = [
        0.879, 1.011, 1.012, 0.827, 0.946, 0.830, 4.186, 36.887, 0.0435, 0.8123, 0.00631,
    ];
    let mt = m.with(&ps, &vals).unwrap();
    for (tag, run) in [("tr", &tr), ("va", &va)] {
        let p = simulate_run(&mt, run, &View::Shooting(20.0).resets(run)).unwrap();
        let mut s = String::from(tag);
        for ch in [
            Channel::Depth,
            Channel::Heading,
            Channel::Pitch,
            Channel::Roll,
        ] {
            if let Some(mm) = channel_metrics(run, &p, ch) {
                s += &format!(
                    " {:?} {:.1}",
                    ch,
                    mm.rmse / run.noise[rov_lab::data::ch_index(ch)]
                );
            }
        }
        println!("{s}");
    }
}

#[test]
#[ignore = "design experiment: prints tables, asserts nothing; run with --ignored --nocapture"]
fn exp_term_sizes() {
    let seed: u64 = std::env::var("SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(3);
    let (a, _) = case_len(seed, &[], 360.0, 180.0);
    let k = |n: &str, d: f64| {
        std::env::var(n)
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(d)
    };
    for h in [
        Hidden::HeaveYawSq(k("K1", 0.8)),
        Hidden::YawSpeedDamp(k("K2", 0.6)),
        Hidden::HeaveLift(k("K3", -2.5)),
        Hidden::TorqueV(0.003),
    ] {
        let (b, _) = case_len(seed, &[h], 360.0, 180.0);
        let ra = Run::from_series(&a, "a").unwrap();
        let rb = Run::from_series(&b, "b").unwrap();
        let mut s = format!("{h:?}:");
        for ch in [
            Channel::Depth,
            Channel::Heading,
            Channel::Pitch,
            Channel::Roll,
        ] {
            let (Some(ya), Some(yb)) = (ra.channel(ch), rb.channel(ch)) else {
                continue;
            };
            let d = ya.iter().zip(yb).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / ya.len() as f64;
            s += &format!(
                " {ch:?} rms diff {:.3} (noise {:.3})",
                d.sqrt(),
                ra.noise[rov_lab::data::ch_index(ch)]
            );
        }
        println!("{s}");
    }
    // Speed ranges from the depth/heading derivatives.
    let r = Run::from_series(&a, "a").unwrap();
    let h = r.channel(Channel::Heading).unwrap();
    let mut rmax: f64 = 0.0;
    for k in 1..h.len() {
        rmax = rmax.max(((h[k] - h[k - 1]) / (r.t[k] - r.t[k - 1])).abs());
    }
    println!("max heading rate {rmax:.1} deg/s");
}

#[test]
#[ignore = "design experiment: prints tables, asserts nothing; run with --ignored --nocapture"]
fn exp_diag_cost() {
    let cpu = cpu_seconds;
    use rov_lab::calibrate::{Objective, View, calibrate};
    use rov_lab::diagnose::{DiagnoseOptions, diagnose};
    use rov_lab::lm::LmOptions;
    for (name, hidden) in [
        ("free", vec![]),
        ("lag", vec![Hidden::Lag(0.2)]),
        ("lift", vec![Hidden::HeaveLift(-0.3)]),
    ] {
        let (tr, va) = case_len(7, &hidden, 600.0, 300.0);
        let tr = Run::from_series(&tr, "train").unwrap();
        let va = Run::from_series(&va, "val").unwrap();
        let m = LabModel::default_base(BaseKind::Model3).unwrap();
        let runs = vec![tr.clone()];
        let obj = Objective::new(&m, &runs, View::Shooting(20.0));
        let t = std::time::Instant::now();
        for _ in 0..10 {
            let _ = obj.residuals(&m).unwrap();
        }
        let one = t.elapsed() / 10;
        let s0 = rov_lab::sim::simulation_count();
        let t = std::time::Instant::now();
        let _ = calibrate(
            &m,
            &runs,
            &LmOptions {
                max_iter: 8,
                threads: 1,
                ..Default::default()
            },
        )
        .unwrap();
        let cal_t = t.elapsed();
        let s1 = rov_lab::sim::simulation_count();
        let t = std::time::Instant::now();
        let c0 = cpu();
        let d = diagnose(
            &m,
            "m",
            &[tr],
            &[va],
            &DiagnoseOptions {
                threads: 1,
                ..Default::default()
            },
        )
        .unwrap();
        println!("{name}: diagnose CPU {:.2} s", cpu() - c0);
        let s2 = rov_lab::sim::simulation_count();
        println!(
            "{name}: one train sim {one:?}; calibrate {cal_t:?} ({} sims); diagnose {:?} ({} sims) terms {}",
            s1 - s0,
            t.elapsed(),
            s2 - s1,
            d.accepted_terms.len()
        );
    }
}

/// The issue-13 BlueROV2 report: leave-one-session-out cross-validation of the BlueROV2
/// Heavy vehicle file on the six tank sessions. Per held-out session: the file's nominal
/// values, the calibrated base and the final model (accepted findings) in both views, the
/// verdict and the findings. `TOPSIDE_SHARED_DIR=/work/shared cargo test -p rov_lab
/// --test it experiment::exp_bluerov_report -- --ignored --nocapture`
#[test]
#[ignore = "design experiment: prints tables, asserts nothing; run with --ignored --nocapture"]
fn exp_bluerov_report() {
    use rov_lab::diagnose::{DiagnoseOptions, diagnose};
    let runs = bluerov_sessions();
    if runs.is_empty() {
        return;
    }
    let text = std::fs::read_to_string(
        std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../../config/vehicles/bluerov2_heavy.toml"),
    )
    .unwrap();
    let m = LabModel::from_vehicle_text(&text, "bluerov2_heavy.toml").unwrap();
    let mut sessions: Vec<String> = Vec::new();
    for r in &runs {
        if !sessions.contains(&r.treatment.source) {
            sessions.push(r.treatment.source.clone());
        }
    }
    let chans = [Channel::Depth, Channel::Heading, Channel::Surge];
    let fits = |e: &rov_lab::evaluate::Evaluation| -> String {
        chans
            .iter()
            .map(|c| {
                e.channels
                    .get(&rov_lab::evaluate::ChannelKey::of(*c))
                    .map_or("–/–".to_string(), |x| {
                        format!(
                            "{:.0}/{:.0}",
                            x.shooting.fit_pct.unwrap_or(f64::NAN),
                            x.free_run.fit_pct.unwrap_or(f64::NAN)
                        )
                    })
            })
            .collect::<Vec<_>>()
            .join(" | ")
    };
    println!(
        "| held-out session | nominal depth | heading | surge | calibrated depth | heading | surge | final depth | heading | surge | verdict | accepted |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for s in &sessions {
        let train: Vec<Run> = runs
            .iter()
            .filter(|r| &r.treatment.source != s)
            .cloned()
            .collect();
        let val: Vec<Run> = runs
            .iter()
            .filter(|r| &r.treatment.source == s)
            .cloned()
            .collect();
        let nominal = rov_lab::evaluate::evaluate(&m, &val).unwrap();
        let t = std::time::Instant::now();
        let d = match diagnose(
            &m,
            "bluerov2_heavy",
            &train,
            &val,
            &DiagnoseOptions {
                threads: 2,
                ..Default::default()
            },
        ) {
            Ok(d) => d,
            Err(e) => {
                println!("| {s} | diagnose failed: {e} |");
                continue;
            }
        };
        let base = rov_lab::evaluate::evaluate(&d.calibrated, &val).unwrap();
        let fin = rov_lab::evaluate::evaluate(&d.final_model, &val).unwrap();
        let names = d.final_model.command_names();
        let mut acc: Vec<String> = d.accepted.iter().map(|e| e.key().to_string()).collect();
        acc.extend(d.accepted_terms.iter().map(|t| t.id(&names)));
        println!(
            "| {s} | {} | {} | {} | {} | {} |",
            fits(&nominal),
            fits(&base),
            fits(&fin),
            d.verdict.name(),
            if acc.is_empty() {
                "–".into()
            } else {
                acc.join(", ")
            }
        );
        eprintln!("--- {s} ({:?}): {}", t.elapsed(), d.summary);
        for f in d.findings.iter().filter(|f| f.significant) {
            eprintln!("    finding {}: {}", f.effect, f.explanation);
        }
        for u in &d.unexplained {
            eprintln!("    unexplained: {}", u.description);
        }
        for n in &d.calibration_notes {
            eprintln!("    calibration: {n}");
        }
        eprintln!(
            "    calibrated: {}",
            d.calibration
                .iter()
                .map(|c| format!("{} = {:.4} ± {:.4}", c.key, c.value, c.std))
                .collect::<Vec<_>>()
                .join("; ")
        );
        // The data notes are the same in every fold: once.
        if Some(s) == sessions.first() {
            for n in &d.data_notes {
                eprintln!("    data: {n}");
            }
        }
    }
}

/// CPU seconds of one diagnosis (catalog and term search, one thread) as the training
/// run grows, 5-minute validation; `MINUTES=10,30,60` (default), `CASE=lag|free|lift`.
/// CPU time, not wall time, so a loaded machine does not inflate it.
#[test]
#[ignore = "design experiment: prints tables, asserts nothing; run with --ignored --nocapture"]
fn exp_diag_growth_cpu() {
    use rov_lab::diagnose::{DiagnoseOptions, diagnose};
    let cpu = cpu_seconds;
    let minutes: Vec<f64> = std::env::var("MINUTES")
        .ok()
        .map(|s| s.split(',').filter_map(|x| x.parse().ok()).collect())
        .unwrap_or_else(|| vec![10.0, 30.0, 60.0]);
    let hidden = match std::env::var("CASE").as_deref() {
        Ok("free") => vec![],
        Ok("lift") => vec![Hidden::HeaveLift(-0.3)],
        _ => vec![Hidden::Lag(0.2)],
    };
    for m in minutes {
        let (tr, va) = case_len(7, &hidden, m * 60.0, 300.0);
        let tr = Run::from_series(&tr, "train").unwrap();
        let va = Run::from_series(&va, "val").unwrap();
        let base = LabModel::default_base(BaseKind::Model3).unwrap();
        let c0 = cpu();
        let t = std::time::Instant::now();
        let d = diagnose(
            &base,
            "model3",
            &[tr],
            &[va],
            &DiagnoseOptions {
                threads: 1,
                ..Default::default()
            },
        )
        .unwrap();
        println!(
            "{m} min train + 5 min val: CPU {:.2} s, wall {:.2?}; {}",
            cpu() - c0,
            t.elapsed(),
            d.summary
        );
    }
}

/// CPU seconds this process has used (user + system, from /proc/self/stat at 100 Hz).
fn cpu_seconds() -> f64 {
    let s = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let f: Vec<&str> = s
        .rsplit(')')
        .next()
        .unwrap_or("")
        .split_whitespace()
        .collect();
    let t = |i: usize| f.get(i).and_then(|x| x.parse::<f64>().ok()).unwrap_or(0.0);
    (t(11) + t(12)) / 100.0
}
