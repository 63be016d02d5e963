//! One 6-DOF RK4 step of model 3 (full M with M_RB couplings, C_RB and C_A, linear plus
//! quadratic damping, restoring forces, three quadratic thrusters, a constant current),
//! and one simulated hour at 100 Hz.
//!
//! Run: `cargo bench -p rov_dynamics --bench step -- --warm-up-time 1 --measurement-time 3`

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use rov_dynamics::ThrustPct;
use rov_dynamics::integrators::rk4_step;
use rov_dynamics::models::{
    Environment, InitialConditions, Model3, ModelState, VehicleModel, load_default_model,
};
use rov_dynamics::process::CurrentSample;

fn setup() -> (Model3, ModelState) {
    let boxed = load_default_model("model3").expect("model3 loads");
    let m3 = boxed
        .as_any()
        .downcast_ref::<Model3>()
        .expect("is model3")
        .clone();
    let mut ic = InitialConditions::at_rest(5.0, 30.0);
    ic.surge_mps = Some(0.5);
    ic.pitch_deg = 3.0;
    ic.roll_deg = -2.0;
    ic.yaw_rate_dps = Some(5.0);
    let x0 = m3.initial_state(&ic);
    (m3, x0)
}

fn bench(c: &mut Criterion) {
    let (m3, x0) = setup();
    let cmd = ThrustPct::new(60.0, 40.0, -30.0);
    let env = Environment::with_current(CurrentSample::constant(0.3, 0.7));
    let h = 0.01;

    // The integrator every caller uses (simulator, `advance`, the model lab).
    c.bench_function("rk4_step_6dof", |b| {
        let mut x = x0;
        let mut t = 0.0;
        b.iter(|| {
            x = m3.rk4_step(t, black_box(&x), black_box(&cmd), &env, h);
            t += h;
            if t > 1000.0 {
                x = x0;
                t = 0.0;
            }
            black_box(&x);
        });
    });

    // The same step through the generic four-stage derivative (thrust at every stage),
    // the path extended models take.
    c.bench_function("rk4_step_6dof_generic_derivative", |b| {
        let mut x = x0;
        let mut t = 0.0;
        b.iter(|| {
            x = rk4_step(
                |tt, s: &ModelState| m3.derivative(tt, s, black_box(&cmd), &env),
                t,
                black_box(&x),
                h,
            );
            t += h;
            if t > 1000.0 {
                x = x0;
                t = 0.0;
            }
            black_box(&x);
        });
    });

    let mut group = c.benchmark_group("simulated_hour");
    group.sample_size(10);
    group.bench_function("one_hour_100hz_360000_steps", |b| {
        b.iter(|| {
            let mut x = x0;
            for k in 0..360_000 {
                let t = k as f64 * h;
                x = m3.rk4_step(t, &x, black_box(&cmd), &env, h);
            }
            black_box(x)
        });
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
