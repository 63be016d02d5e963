//! Effect-free station dives: the calm dive `topside record --sim` flies without a script
//! (tests/common `station_dive_run`: the station's autopilot holds depth and heading, one
//! cruise, one step), whose depth hold barely moves pitch and roll. The lab once called such
//! dives "unexplained: pitch_rate 1.2× its noise floor": the calibration carried the
//! parameters of the barely excited axes (pitch and roll damping, CG height, added
//! masses) far from their documented priors into a basin worse on the training runs than
//! the uncalibrated base — here the documented model3 is the truth, so its prior is right;
//! and the verdict did not count the spread that a multiple-shooting window's start,
//! smoothed from noisy readings, leaves on those lightly damped axes.

use crate::common;

use rov_lab::calibrate::{View, calibrate, misfit_scales};
use rov_lab::diagnose::{DiagnoseOptions, diagnose};
use rov_lab::ingest::runs_from_text;
use rov_lab::lm::LmOptions;
use rov_lab::verdict::Verdict;
use rov_lab::{BaseKind, LabModel, Run};

/// A training and a held-out station dive (240 s each, other sensor noise) of the
/// documented model3, read back from CSV text as the lab reads a log.
fn dives(seed: u64) -> (Vec<Run>, Vec<Run>) {
    let tr = common::station_dive_run(seed, seed, &[], 0.0, 240.0);
    let va = common::station_dive_run(seed, seed + 100, &[], 0.0, 240.0);
    (
        runs_from_text(&tr.to_csv(), "train.csv").unwrap(),
        runs_from_text(&va.to_csv(), "val.csv").unwrap(),
    )
}

/// The calibration's criterion: Σ_c N_c ln MSE_c over the compared channels, multiple
/// shooting (lower is better).
fn det_criterion(model: &LabModel, runs: &[Run]) -> f64 {
    let m = misfit_scales(
        model,
        runs,
        View::Shooting(rov_lab::calibrate::SHOOTING_WINDOW_S),
    )
    .unwrap();
    let n: usize = runs.iter().map(|r| r.len()).sum();
    m.iter()
        .filter(|x| **x > 0.0)
        .map(|x| n as f64 * (x * x).ln())
        .sum()
}

/// Seeds 1 and 2 ended worse than the prior before the calibration's last safeguard
/// (`calibrate::back_to_the_prior`): by −268747 against −269260 and −267223 against
/// −268123.
#[test]
fn calibration_on_a_calm_dive_ends_no_worse_than_the_documented_prior() {
    let base = LabModel::default_base(BaseKind::Model3).unwrap();
    let opts = LmOptions {
        max_iter: DiagnoseOptions::default().calibration_iterations,
        threads: 2,
        ..Default::default()
    };
    for seed in [1, 2] {
        let (tr, _) = dives(seed);
        let cal = calibrate(&base, &tr, &opts).unwrap();
        let (c, p) = (det_criterion(&cal.model, &tr), det_criterion(&base, &tr));
        assert!(
            c <= p,
            "seed {seed}: calibrated {c:.1} is worse than the uncalibrated base {p:.1}"
        );
    }
}

/// The documented model3 is this data's truth, so the verdict must find it adequate. Seeds
/// 2, 5 and 6 were "unexplained" (roll rate 1.12×, pitch rate 1.14–1.38× their noise
/// floors) before the verdict counted the spread the reset states' own smoothing error
/// leaves ([`rov_lab::verdict::reset_spread`]): the documented model missed pitch rate by
/// 1.31 noise floors in the shooting view and by 0.98 in the free run.
#[test]
fn the_verdict_finds_the_true_model_adequate_on_calm_dives() {
    let base = LabModel::default_base(BaseKind::Model3).unwrap();
    for seed in [2, 5, 6] {
        let (tr, va) = dives(seed);
        let d = diagnose(&base, "model3", &tr, &va, &DiagnoseOptions::default()).unwrap();
        assert_eq!(d.verdict, Verdict::Adequate, "seed {seed}: {}", d.summary);
    }
}

/// `TRAIN=d1.csv VAL=d2.csv`: the diagnosis of two recorded dives, with the calibrated
/// parameters against their priors (design experiment, asserts nothing).
#[test]
#[ignore = "design experiment on recorded dives: TRAIN=… VAL=… cargo test --release -p rov_lab --test it station_dive:: -- --ignored --nocapture"]
fn exp_recorded_dives() {
    let load = |v: &str| {
        let path = std::env::var(v).unwrap();
        runs_from_text(&std::fs::read_to_string(&path).unwrap(), &path).unwrap()
    };
    let (tr, va) = (load("TRAIN"), load("VAL"));
    let base = LabModel::default_base(BaseKind::Model3).unwrap();
    let d = diagnose(&base, "model3", &tr, &va, &DiagnoseOptions::default()).unwrap();
    println!("{}", d.summary);
    for f in &d.calibration {
        let q = rov_lab::params::Param::from_key(&f.key).unwrap();
        let (m, s) = base.prior_of(q).unwrap_or((f64::NAN, f64::NAN));
        let (m, s) = (q.display(m).0, q.display(s).0.abs());
        println!(
            "  {:<34} {:>10.4} ± {:<8.4} prior {:>10.4} ± {:<8.4} ({:+.2} σ)",
            f.key,
            f.value,
            f.std,
            m,
            s,
            (f.value - m) / s
        );
    }
    for n in &d.calibration_notes {
        println!("  note: {n}");
    }
    for c in &d.consistency {
        println!(
            "  {:<11} rmse {:.4} noise {:.4} spread {:.4} ratio {:.3} level {:.3}/{:.3} → {}",
            c.channel,
            c.rmse,
            c.noise,
            c.param_spread,
            c.ratio,
            c.level,
            c.level_critical,
            c.consistent
        );
    }
}

/// Verdicts of generated calm dives (`SEEDS=1,2,… FRAC=0.2`; design experiment, asserts
/// nothing), with the documented model's own test on the held-out dive.
#[test]
#[ignore = "design experiment: prints verdicts; run with --ignored --nocapture"]
fn exp_generated_dives() {
    let seeds: Vec<u64> = std::env::var("SEEDS")
        .ok()
        .map(|s| s.split(',').filter_map(|x| x.parse().ok()).collect())
        .unwrap_or_else(|| vec![1, 2, 3, 4, 5, 6]);
    let frac: f64 = std::env::var("FRAC")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0.0);
    let base = LabModel::default_base(BaseKind::Model3).unwrap();
    for seed in seeds {
        let tr = common::station_dive_run(seed, seed, &[], frac, 240.0);
        let va = common::station_dive_run(seed, seed + 100, &[], frac, 240.0);
        let tr = runs_from_text(&tr.to_csv(), "train.csv").unwrap();
        let va = runs_from_text(&va.to_csv(), "val.csv").unwrap();
        let t = std::time::Instant::now();
        let d = diagnose(&base, "model3", &tr, &va, &DiagnoseOptions::default()).unwrap();
        let off: Vec<String> = d
            .consistency
            .iter()
            .filter(|c| !c.consistent || c.channel.ends_with("_rate"))
            .map(|c| {
                format!(
                    "{} {:.3} (s0 {:.3} floors){}",
                    c.channel,
                    c.ratio,
                    c.noise.hypot(c.param_spread) / c.noise,
                    if c.consistent { "" } else { " INCONSISTENT" }
                )
            })
            .collect();
        println!(
            "seed {seed}: {:.1?} {} | {}",
            t.elapsed(),
            d.verdict.name(),
            off.join(", ")
        );
    }
}
