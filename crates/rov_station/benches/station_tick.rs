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
//! * `station_tick/virtual_20ms_watch_inline`: the same with the model watch on, run
//!   inline on the ticking thread as on virtual time (its 1-s evaluation, a 12-s
//!   simulation, falls on one tick in fifty): the watch's whole cost spread over the
//!   ticks, an upper bound. The live station runs the watch on its own thread and its
//!   control thread pays only the row's hand-off (`watch/control_thread_per_nav_row`).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use rov_control::Axis;
use rov_station::{RuntimeCommand, RuntimeConfig, StationHandle, VirtualStation};

/// An armed station on virtual time, holding depth and heading, sticks centred, and its
/// handle (the station shuts down when the handle goes).
fn flying(watch: bool) -> (VirtualStation, StationHandle) {
    let cfg = RuntimeConfig {
        watch,
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
    // Past the watch's baseline (it learns the noise floors first).
    station.advance(if watch { 90.0 } else { 5.0 }).unwrap();
    assert!(handle.snapshot().armed, "the bench flies an armed vehicle");
    if watch {
        let view = handle.view();
        assert!(view.watch.running, "the watch runs: {:?}", view.watch);
    }
    (station, handle)
}

fn bench(c: &mut Criterion) {
    for (name, watch) in [
        ("station_tick/virtual_20ms", false),
        ("station_tick/virtual_20ms_watch_inline", true),
    ] {
        let (mut station, handle) = flying(watch);
        c.bench_function(name, |b| {
            b.iter(|| black_box(station.advance(0.02)));
        });
        assert!(
            handle.snapshot().armed,
            "{name}: still flying after the bench"
        );
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
