//! Diagnosing the full catalog on a 10-minute, 20 Hz training run plus a 5-minute
//! validation run, on one core (threads = 1), for an effect-free vehicle and for one with
//! a hidden thruster lag. Target ≤ 5 s.
//!
//! `cargo bench -p rov_lab --bench diagnose`

#[path = "../tests/common/mod.rs"]
mod common;

use criterion::{Criterion, criterion_group, criterion_main};
use rov_lab::diagnose::{DiagnoseOptions, diagnose};
use rov_lab::{BaseKind, LabModel, Run};

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("diagnose_10min_train_5min_val");
    g.sample_size(10);
    g.measurement_time(std::time::Duration::from_secs(40));
    for (name, hidden) in [
        ("effect_free", vec![]),
        ("hidden_lag", vec![common::Hidden::Lag(0.2)]),
    ] {
        let (tr, va) = common::case(7, &hidden);
        let tr = Run::from_series(&tr, "train").unwrap();
        let va = Run::from_series(&va, "val").unwrap();
        let m = LabModel::default_base(BaseKind::Model3).unwrap();
        let opts = DiagnoseOptions {
            threads: 1,
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
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
