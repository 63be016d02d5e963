//! Diagnosing the full catalog and the term search on a 10-minute, 20 Hz training run
//! plus a 5-minute validation run, on one core (threads = 1): an effect-free vehicle, one
//! with a hidden thruster lag (a catalog effect), and one with a heave force outside the
//! catalog (u·|u|, found by the term search). Target ≤ 5 s. The `growth` group measures
//! the same diagnosis (hidden lag) on 30- and 60-minute training runs.
//!
//! Measured (CPU s on one thread, `exp_diag_growth_cpu` in tests/experiment.rs, on two
//! cores shared with other builds, load ~6.7): effect-free 1.1–1.2, hidden lag 3.3,
//! heave lift 4.1–4.3; this bench's wall times under that load 1.6 / 4.6 / 6.2 s.
//!
//! The `threads` group runs the hidden lag on one thread and on every core.
//!
//! `cargo bench -p rov_lab --bench diagnose` (`-- growth` for the growth group only)

#[path = "../tests/it/common/mod.rs"]
mod common;

use criterion::{Criterion, criterion_group, criterion_main};
use rov_lab::diagnose::{DiagnoseOptions, diagnose};
use rov_lab::{BaseKind, LabModel, Run};

fn run_case(
    g: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    name: &str,
    hidden: &[common::Hidden],
    train_s: f64,
    val_s: f64,
    threads: usize,
) {
    let (tr, va) = common::case_len(7, hidden, train_s, val_s);
    let tr = Run::from_series(&tr, "train").unwrap();
    let va = Run::from_series(&va, "val").unwrap();
    let m = LabModel::default_base(BaseKind::Model3).unwrap();
    let opts = DiagnoseOptions {
        threads,
        ..Default::default()
    };
    g.bench_function(name, |b| {
        b.iter(|| {
            diagnose(
                &m,
                "model3",
                std::slice::from_ref(&tr),
                std::slice::from_ref(&va),
                &opts,
            )
            .unwrap()
        })
    });
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("diagnose_10min_train_5min_val");
    g.sample_size(10);
    g.measurement_time(std::time::Duration::from_secs(40));
    run_case(&mut g, "effect_free", &[], 600.0, 300.0, 1);
    run_case(
        &mut g,
        "hidden_lag",
        &[common::Hidden::Lag(0.2)],
        600.0,
        300.0,
        1,
    );
    run_case(
        &mut g,
        "outside_catalog_heave_lift",
        &[common::Hidden::HeaveLift(-0.3)],
        600.0,
        300.0,
        1,
    );
    g.finish();
}

fn growth(c: &mut Criterion) {
    let mut g = c.benchmark_group("growth");
    g.sample_size(10);
    g.measurement_time(std::time::Duration::from_secs(60));
    for minutes in [30.0, 60.0] {
        run_case(
            &mut g,
            &format!("hidden_lag_{minutes}min_train_5min_val"),
            &[common::Hidden::Lag(0.2)],
            minutes * 60.0,
            300.0,
            1,
        );
    }
    g.finish();
}

/// The hidden-lag case on 1 and on every core (the lab's worker pool; same result).
fn threads(c: &mut Criterion) {
    let mut g = c.benchmark_group("threads");
    g.sample_size(10);
    g.measurement_time(std::time::Duration::from_secs(40));
    let all = rov_lab::par::default_threads();
    for n in [1, all] {
        run_case(
            &mut g,
            &format!("hidden_lag_10min_{n}_threads"),
            &[common::Hidden::Lag(0.2)],
            600.0,
            300.0,
            n,
        );
    }
    g.finish();
}

criterion_group!(benches, bench, growth, threads);
criterion_main!(benches);
