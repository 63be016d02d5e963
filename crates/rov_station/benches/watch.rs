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
use rov_dynamics::ThrustPct;
use rov_lab::watch::{Watch, WatchConfig};
use rov_sim::{SimConfig, Simulator};
use rov_station::runtime::watch::StationWatch;
use rov_types::measurement::MeasurementRow;

fn rows(n: usize) -> Vec<MeasurementRow> {
    let mut sim = Simulator::new(SimConfig::default_model3().unwrap(), 5).unwrap();
    let mut out = Vec::with_capacity(n);
    for k in 0..n {
        let t = k as f64 * 0.1;
        let phase = (t / 7.0).sin();
        let cmd = ThrustPct {
            port: 30.0 + 15.0 * phase,
            starboard: 30.0 - 15.0 * phase,
            vertical: 10.0 * (t / 11.0).cos(),
        };
        sim.set_command(cmd).unwrap();
        sim.advance_to(t).unwrap();
        let s = sim.sensors();
        let mut optional = [None; 8];
        optional[0] = Some(s.gyro_body_radps.z.to_degrees());
        optional[1] = Some(s.gyro_body_radps.y.to_degrees());
        optional[2] = Some(s.gyro_body_radps.x.to_degrees());
        out.push(MeasurementRow {
            time_s: t,
            port_pct: cmd.port,
            starboard_pct: cmd.starboard,
            vertical_pct: cmd.vertical,
            depth_m: s.depth_from_pressure_m,
            heading_deg: s.heading_rad.to_degrees(),
            pitch_deg: s.pitch_rad.to_degrees(),
            roll_deg: s.roll_rad.to_degrees(),
            optional,
        });
    }
    out
}

fn model3() -> rov_lab::LabModel {
    rov_lab::load_model(
        &rov_types::ModelId::Base(rov_types::BaseModel::Model3),
        None,
    )
    .unwrap()
}

fn bench(c: &mut Criterion) {
    let data = rows(3000);
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
