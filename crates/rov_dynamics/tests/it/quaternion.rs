//! The quaternion attitude option against the Euler path.

use nalgebra::{UnitQuaternion, Vector3};
use rov_dynamics::integrators::rk4_step;
use rov_dynamics::kinematics::{
    QuatPose, QuatState, normalize_quat_state, quat_state, quat_state_dot, unpack_quat_state,
};
use rov_dynamics::models::{Model3, ModelState, load_default_model};
use rov_dynamics::process::CurrentSample;
use rov_dynamics::{Vector6, kinematics};

#[test]
fn quaternion_path_matches_euler_path_for_moderate_angles() {
    let base = load_default_model("model3").unwrap();
    let m3 = base.as_any().downcast_ref::<Model3>().unwrap();
    let pm = m3.process();
    let tau = Vector6::new(8.0, 0.0, 3.0, 0.05, 0.0, 0.6);
    let current = CurrentSample::constant(0.2, 0.4);
    let eta0 = Vector6::new(1.0, -2.0, 3.0, 0.3, -0.25, 2.0);
    let nu0 = Vector6::new(0.2, 0.1, -0.1, 0.3, 0.2, -0.1);
    let h = 0.01;
    let mut e = ModelState::new(eta0, nu0);
    let mut q = quat_state(&QuatPose::from_eta(&eta0), &nu0);
    let mut max_roll_pitch: f64 = 0.0;
    for k in 0..1000 {
        let t = k as f64 * h;
        e = rk4_step(
            |_, s: &ModelState| {
                let (ed, nd) = pm.state_derivative(&s.eta, &s.nu, &tau, &current);
                ModelState::new(ed, nd)
            },
            t,
            &e,
            h,
        );
        q = rk4_step(
            |_, s: &QuatState| pm.quat_state_derivative(s, &tau, &current),
            t,
            &q,
            h,
        );
        normalize_quat_state(&mut q);
        max_roll_pitch = max_roll_pitch.max(e.eta[3].abs()).max(e.eta[4].abs());
    }
    let (pose, nu_q) = unpack_quat_state(&q);
    let eta_q = pose.to_eta(e.eta[5]);
    assert!((eta_q - e.eta).norm() < 1e-8, "{eta_q} vs {}", e.eta);
    assert!((nu_q - e.nu).norm() < 1e-8);
    assert!(
        max_roll_pitch > 0.2,
        "the test exercises non-trivial angles"
    );
}

#[test]
fn quaternion_path_passes_through_ninety_degrees_pitch() {
    // Pure kinematics: constant pitch rate 1 rad/s for 3 s (through θ = 90° at t = π/2).
    let nu = Vector6::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0);
    let no_accel = Vector6::zeros();
    let h = 0.001;
    let mut x = quat_state(&QuatPose::from_eta(&Vector6::zeros()), &nu);
    for k in 0..3000 {
        x = rk4_step(
            |_, s: &QuatState| quat_state_dot(s, &no_accel),
            k as f64 * h,
            &x,
            h,
        );
        normalize_quat_state(&mut x);
        assert!(x.iter().all(|v| v.is_finite()));
    }
    let (pose, _) = unpack_quat_state(&x);
    let expected = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 3.0);
    assert!(pose.ned_from_body.angle_to(&expected) < 1e-9);
    // Position: a loop of radius 1 m in the x-z plane: x = sin 3, z = -(1 - cos 3).
    assert!(
        (pose.pos_ned_m - Vector3::new(3.0_f64.sin(), 0.0, -(1.0 - 3.0_f64.cos()))).norm() < 1e-9
    );
    // The Euler path cannot do this: T(φ, θ) is singular at θ = 90°.
    let t = kinematics::Attitude::new(0.0, std::f64::consts::FRAC_PI_2, 0.0)
        .euler_rates_from_body_rates();
    assert!(t[(2, 2)].abs() > 1e15 || !t[(2, 2)].is_finite());
}
