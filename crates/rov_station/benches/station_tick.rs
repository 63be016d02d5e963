//! One control period of the whole station on virtual time (issue 24: the pilot core's
//! reshaping must not make the station's tick slower).
//! `cargo bench -p rov_station --bench station_tick`.
//!
//! * `station_tick/virtual_20ms`: [`VirtualStation::advance`] by one 20-ms control
//!   period, armed, depth and heading holding, the pilot's sticks centred, no recording:
//!   the engine's tick (sticks, controller, records for the view, alarms, prediction,
//!   dive log, view) plus the link's exchanges with the simulated Pro 4 and the
//!   simulator's integration over the period (the simulator's share is the same before
//!   and after the reshaping). The model watch is off (it has its own bench, `watch`).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use rov_control::Axis;
use rov_station::{RuntimeCommand, RuntimeConfig, VirtualStation};

fn bench(c: &mut Criterion) {
    let cfg = RuntimeConfig {
        watch: false,
        gamepad: false,
        ..RuntimeConfig::default()
    };
    let (mut station, handle) = VirtualStation::new(cfg).unwrap();
    station.advance(2.0).unwrap();
    // Arm (hold the button for 1.4 s, reported every 0.2 s) and engage both holds.
    for _ in 0..7 {
        handle.command(RuntimeCommand::ArmButton(true));
        station.advance(0.2).unwrap();
    }
    handle.command(RuntimeCommand::ArmButton(false));
    handle.command(RuntimeCommand::ToggleHold(Axis::Depth));
    handle.command(RuntimeCommand::ToggleHold(Axis::Heading));
    station.advance(5.0).unwrap();
    assert!(handle.snapshot().armed, "the bench flies an armed vehicle");
    c.bench_function("station_tick/virtual_20ms", |b| {
        b.iter(|| black_box(station.advance(0.02)));
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
