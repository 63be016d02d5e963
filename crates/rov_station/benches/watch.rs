//! The model watch's cost (issue 23). `cargo bench -p rov_station --bench watch`.
//!
//! * `watch/control_thread_per_nav_row`: what the control thread pays per navigation
//!   reply: the row built and `try_send` to the watch thread (the thread keeps up at
//!   10 Hz; the queue is never full here).
//! * `watch/watch_thread_per_second`: what the watch thread does per second of dive
//!   (10 rows and one evaluation: a short-window simulation of 12 s through the lab's
//!   simulator), steady state after the baseline, no alert.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use rov_lab::watch::{Watch, WatchConfig};
use rov_station::runtime::watch::StationWatch;

fn model3() -> rov_lab::LabModel {
    rov_lab::load_model(
        &rov_types::ModelId::Base(rov_types::BaseModel::Model3),
        None,
    )
    .unwrap()
}

fn bench(c: &mut Criterion) {
    let data = rov_station::runtime::watch::simulated_rows(3000, &[]).unwrap();
    // Control thread: one row per call into a running watch thread, paced so the thread
    // keeps up (criterion's iterations are far faster than 10 Hz; the rows cycle).
    let mut station = StationWatch::new(model3(), false);
    let mut k = 0usize;
    c.bench_function("watch/control_thread_per_nav_row", |b| {
        b.iter(|| {
            let mut r = data[k % data.len()];
            r.time_s = k as f64 * 0.1;
            k += 1;
            black_box(station.push(black_box(r)))
        });
    });
    // Watch thread: a watch past its baseline, one second of rows per iteration.
    let mut w = Watch::new(
        model3(),
        WatchConfig::default(),
        [true, true, true, false, false, false, false, false],
    );
    for r in &data[..1000] {
        w.push(r);
    }
    let mut i = 1000usize;
    c.bench_function("watch/watch_thread_per_second", |b| {
        b.iter(|| {
            for _ in 0..10 {
                let mut r = data[i % data.len()];
                r.time_s = i as f64 * 0.1;
                i += 1;
                black_box(w.push(&r));
            }
        });
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
