//! One control tick: observer (depth + heading), reference models, feedforward, both
//! PIDs, allocation and guard, with both axes holding and a moving setpoint.

use criterion::{Criterion, criterion_group, criterion_main};
use rov_control::{
    Axis, ControlConfig, Controller, Measurements, ModeCommand, ModelSet, PilotInput,
};
use std::hint::black_box;

fn tick(c: &mut Criterion) {
    let mut ctl = Controller::new(
        ControlConfig::default(),
        ModelSet::load_default().expect("models"),
    )
    .expect("controller");
    let meas = |k: u64| Measurements {
        depth_m: Some(5.0 + 0.01 * ((k % 7) as f64 - 3.0)),
        heading_deg: Some(90.0 + 0.1 * ((k % 5) as f64 - 2.0)),
        yaw_rate_rad_s: None,
    };
    ctl.tick(0.0, &meas(0), &PilotInput::default());
    ctl.command(ModeCommand::Engage(Axis::Depth))
        .expect("engage depth");
    ctl.command(ModeCommand::SetHeading { heading_deg: 120.0 })
        .expect("engage heading");
    let mut k = 1u64;
    c.bench_function("control_tick", |b| {
        b.iter(|| {
            k += 1;
            let t = k as f64 * 0.02;
            if k.is_multiple_of(1000) {
                // Keep the reference moving so the feedforward is exercised.
                let _ = ctl.command(ModeCommand::StepHeading { delta_deg: 30.0 });
            }
            black_box(ctl.tick(
                black_box(t),
                black_box(&meas(k)),
                black_box(&PilotInput::default()),
            ))
        })
    });
}

criterion_group!(benches, tick);
criterion_main!(benches);
