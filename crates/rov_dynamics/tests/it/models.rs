//! Behaviour of the three VideoRay models loaded from config/models/*.toml.

use rov_dynamics::models::{
    Channel, Environment, ExternalForce, InitialConditions, Model3, ModelState, VehicleModel,
    advance, load_default_model, simulate,
};
use rov_dynamics::process::MunkMoment;
use rov_dynamics::{DynamicsError, ThrustPct, Vector6};
use rov_types::MeasurementRow;
use rov_types::measurement::OptionalChannel;

fn model(name: &str) -> Box<dyn VehicleModel> {
    load_default_model(name).unwrap()
}

fn run_const(m: &dyn VehicleModel, cmd: ThrustPct, seconds: f64) -> ModelState {
    let x0 = m.initial_state(&InitialConditions::at_rest(5.0, 0.0));
    advance(m, &x0, 0.0, seconds, &cmd, 0.01, &Environment::calm()).unwrap()
}

/// Positive root of d_q x² + d_l x = f.
fn drag_root(d_l: f64, d_q: f64, f: f64) -> f64 {
    (-d_l + (d_l * d_l + 4.0 * d_q * f).sqrt()) / (2.0 * d_q)
}

#[test]
fn full_forward_thrust_steady_surge_matches_drag_balance() {
    // model1 and model2: 2 x 17 N against 1.2 u + 7.9 u².
    let expected = drag_root(1.2, 7.9, 34.0);
    for name in ["model1", "model2"] {
        let x = run_const(
            model(name).as_ref(),
            ThrustPct::new(100.0, 100.0, 0.0),
            40.0,
        );
        assert!(
            (x.nu[0] - expected).abs() < 1e-6,
            "{name}: u = {} vs {expected}",
            x.nu[0]
        );
        assert!(x.eta[0] > 50.0, "{name} moves north");
    }
    // model3: eq. 23 makes the drag at u_max = 2.1 m/s equal the full thrust.
    let m3 = model("model3");
    let x = run_const(m3.as_ref(), ThrustPct::new(100.0, 100.0, 0.0), 40.0);
    assert!((x.nu[0] - 2.1).abs() < 1e-6, "model3: u = {}", x.nu[0]);
    // The start-up acceleration excites pitch through M_RB's m z_g coupling; it decays
    // slowly (residual C_A[4][2] term and heave drag) and stays small.
    assert!(
        x.eta[4].to_degrees().abs() < 3.0,
        "pitch {} deg",
        x.eta[4].to_degrees()
    );
    let p = m3.as_any().downcast_ref::<Model3>().unwrap().params();
    let d = p.process.damping;
    assert!((d.linear[(0, 0)] - 34.0 / (0.16 * 2.1 * 2.1 + 2.1)).abs() < 1e-12);
    assert!((d.quadratic[0] / d.linear[(0, 0)] - 0.16).abs() < 1e-12);
}

#[test]
fn full_vertical_thrust_steady_heave_matches_drag_balance() {
    // 10 N down against 4.8 w + 34 w², neutral buoyancy in all three models.
    let expected = drag_root(4.8, 34.0, 10.0);
    for name in ["model1", "model2", "model3"] {
        let x = run_const(model(name).as_ref(), ThrustPct::new(0.0, 0.0, 100.0), 30.0);
        assert!(
            (x.nu[2] - expected).abs() < 1e-6,
            "{name}: w = {} vs {expected}",
            x.nu[2]
        );
        assert!(x.eta[2] > 10.0, "{name} goes down");
        let x = run_const(model(name).as_ref(), ThrustPct::new(0.0, 0.0, -100.0), 30.0);
        assert!((x.nu[2] + expected).abs() < 1e-6, "{name}: symmetric up");
    }
}

#[test]
fn port_above_starboard_turns_to_starboard_with_drag_balanced_rate() {
    // 2 x 17 N differential on a 0.10 m arm against 0.04 r + 0.8 r².
    let arm1 = 0.164 * 37.6_f64.to_radians().sin();
    for (name, arm, tol) in [
        ("model1", arm1, 1e-6),
        ("model2", 0.1, 1e-6),
        ("model3", 0.1, 0.02),
    ] {
        let expected = drag_root(0.04, 0.8, 34.0 * arm);
        let x = run_const(
            model(name).as_ref(),
            ThrustPct::new(100.0, -100.0, 0.0),
            20.0,
        );
        assert!(x.nu[5] > 0.0 && x.eta[5] > 0.0, "{name}: heading increases");
        assert!(
            (x.nu[5] - expected).abs() < tol * expected.max(1.0),
            "{name}: r = {} vs {expected}",
            x.nu[5]
        );
    }
}

#[test]
fn channels_not_predicted_are_none() {
    for name in ["model1", "model2"] {
        let m = model(name);
        for ch in [
            Channel::Pitch,
            Channel::Roll,
            Channel::Sway,
            Channel::RollRate,
            Channel::PitchRate,
        ] {
            assert!(!m.predicts(ch), "{name} {ch:?}");
        }
        let out = m.outputs(
            0.0,
            &m.initial_state(&InitialConditions::at_rest(1.0, 10.0)),
        );
        assert!(out.pitch_deg.is_none() && out.roll_deg.is_none() && out.sway_mps.is_none());
        assert_eq!(out.depth_m, Some(1.0));
        assert!((out.heading_deg.unwrap() - 10.0).abs() < 1e-12);
    }
    let m3 = model("model3");
    assert!(Channel::ALL.iter().all(|ch| m3.predicts(*ch)));
}

#[test]
fn initial_state_from_measured_row() {
    let mut row = MeasurementRow {
        time_s: 3.0,
        depth_m: 2.5,
        heading_deg: 350.0,
        pitch_deg: 4.0,
        roll_deg: -2.0,
        ..Default::default()
    };
    row.set(OptionalChannel::SurgeMps, Some(0.3));
    row.set(OptionalChannel::YawRateDps, Some(f64::NAN));
    let ic = InitialConditions::from_row(&row).unwrap();
    assert_eq!(
        ic.yaw_rate_dps, None,
        "NaN optional channels are treated as missing"
    );
    let s3 = model("model3").initial_state(&ic);
    assert!((s3.eta[4] - 4.0_f64.to_radians()).abs() < 1e-15 && (s3.nu[0] - 0.3).abs() < 1e-15);
    let s1 = model("model1").initial_state(&ic);
    assert_eq!(
        (s1.eta[3], s1.eta[4]),
        (0.0, 0.0),
        "model1 keeps roll and pitch at zero"
    );
    assert!((s1.eta[5] - 350.0_f64.to_radians()).abs() < 1e-15);
    row.depth_m = f64::NAN;
    assert!(matches!(
        InitialConditions::from_row(&row),
        Err(DynamicsError::InvalidInput { .. })
    ));
}

#[test]
fn simulate_honours_the_csv_timing_rule_with_uneven_sampling() {
    let m = model("model3");
    let x0 = m.initial_state(&InitialConditions::at_rest(2.0, 0.0));
    let cmd = ThrustPct::new(0.0, 0.0, 60.0);
    // Uneven times; the step command is set at row 1 (t = 0.5).
    let inputs = vec![
        (0.0, ThrustPct::ZERO),
        (0.5, cmd),
        (0.53, cmd),
        (1.7, cmd),
        (4.0, ThrustPct::ZERO),
        (4.01, ThrustPct::ZERO),
    ];
    let out = simulate(m.as_ref(), &x0, &inputs, 0.01).unwrap();
    assert_eq!(out.len(), inputs.len());
    // Row 1 is measured before its command acts: nothing has moved yet.
    assert_eq!(out[1].depth_m, Some(2.0));
    assert_eq!(out[1].heave_mps, Some(0.0));
    assert!(
        out[2].heave_mps.unwrap() > 0.0,
        "command 1 acts from t = 0.5 on"
    );
    // Same result with a fine uniform grid holding the same commands.
    let fine: Vec<(f64, ThrustPct)> = (0..=401)
        .map(|k| {
            let t = k as f64 * 0.01;
            (
                t,
                if (0.5..4.0).contains(&(t + 1e-9)) {
                    cmd
                } else {
                    ThrustPct::ZERO
                },
            )
        })
        .collect();
    let out_fine = simulate(m.as_ref(), &x0, &fine, 0.01).unwrap();
    let z_fine = out_fine
        .iter()
        .find(|o| (o.time_s - 4.0).abs() < 1e-9)
        .unwrap()
        .depth_m
        .unwrap();
    assert!(
        (out[4].depth_m.unwrap() - z_fine).abs() < 1e-9,
        "{} vs {z_fine}",
        out[4].depth_m.unwrap()
    );
}

#[test]
fn simulate_rejects_bad_inputs() {
    let m = model("model1");
    let x0 = ModelState::default();
    let bad_time = [(0.0, ThrustPct::ZERO), (0.0, ThrustPct::ZERO)];
    assert!(matches!(
        simulate(m.as_ref(), &x0, &bad_time, 0.01),
        Err(DynamicsError::InvalidInput { .. })
    ));
    let bad_cmd = [(0.0, ThrustPct::new(150.0, 0.0, 0.0))];
    assert!(matches!(
        simulate(m.as_ref(), &x0, &bad_cmd, 0.01),
        Err(DynamicsError::InvalidInput { .. })
    ));
    let ok = [(0.0, ThrustPct::ZERO)];
    assert!(matches!(
        simulate(m.as_ref(), &x0, &ok, 0.0),
        Err(DynamicsError::InvalidInput { .. })
    ));
}

#[derive(Debug)]
struct PoisonAfter(f64);

impl ExternalForce for PoisonAfter {
    fn tau_body(&self, time_s: f64, _eta: &Vector6, _nu: &Vector6) -> Vector6 {
        if time_s > self.0 {
            Vector6::repeat(f64::NAN)
        } else {
            Vector6::zeros()
        }
    }
}

#[test]
fn non_finite_state_stops_with_time_and_state() {
    let m = model("model3");
    let x0 = m.initial_state(&InitialConditions::at_rest(1.0, 0.0));
    let poison = PoisonAfter(1.0);
    let env = Environment {
        external: Some(&poison),
        ..Environment::calm()
    };
    let inputs: Vec<(f64, ThrustPct)> =
        (0..30).map(|k| (k as f64 * 0.1, ThrustPct::ZERO)).collect();
    let err = rov_dynamics::models::simulate_in(m.as_ref(), &x0, &inputs, 0.01, &env).unwrap_err();
    match &err {
        DynamicsError::NonFinite { time_s, state } => {
            assert!((*time_s - 1.01).abs() < 1e-9, "stopped at {time_s}");
            assert!(state.contains("model3") && state.contains("NaN"), "{state}");
        }
        other => panic!("unexpected {other}"),
    }
    assert!(err.to_string().contains("non-finite at t = 1.01"), "{err}");
}

/// Pitch after 30 s at 1 m/s surge, starting with a 2° pitch disturbance.
fn pitch_after_cruise(munk: MunkMoment) -> f64 {
    let base = model("model3");
    let m3 = base
        .as_any()
        .downcast_ref::<Model3>()
        .unwrap()
        .with_munk(munk)
        .unwrap();
    // Thrust per thruster that balances the surge drag at 1 m/s: solve 1.7 u + 15.3 u² = F.
    let d = m3.params().process.damping;
    let f_each = 0.5 * (d.linear[(0, 0)] + d.quadratic[0]);
    let u = drag_root(1.7, 15.3, f_each) * 100.0;
    let mut ic = InitialConditions::at_rest(10.0, 0.0);
    ic.surge_mps = Some(1.0);
    ic.pitch_deg = 2.0;
    let x0 = m3.initial_state(&ic);
    let mut x = x0;
    let mut max_pitch: f64 = 0.0;
    for k in 0..300 {
        x = match advance(
            &m3,
            &x,
            k as f64 * 0.1,
            0.1,
            &ThrustPct::new(u, u, 0.0),
            0.01,
            &Environment::calm(),
        ) {
            Ok(x) => x,
            Err(_) => return f64::INFINITY,
        };
        max_pitch = max_pitch.max(x.eta[4].to_degrees().abs());
    }
    max_pitch
}

#[test]
fn munk_moment_full_diverges_in_pitch_while_zeroed_stays_level() {
    let zeroed = pitch_after_cruise(MunkMoment::Zeroed);
    let full = pitch_after_cruise(MunkMoment::Full);
    eprintln!("max |pitch| over 30 s at 1 m/s: zeroed {zeroed:.3} deg, full {full:.1} deg");
    assert!(zeroed < 3.0, "zeroed: max pitch {zeroed} deg");
    assert!(full > 30.0, "full: max pitch {full} deg");
}

#[test]
fn a_varying_current_carries_a_neutral_vehicle_along() {
    // With ν_r = 0 there is no damping or Coriolis force and (level, neutral) no restoring
    // force, so ν̇ = ν̇_c exactly: the ground velocity must follow Rᵀ v_c(t), which needs
    // the Rᵀ v̇_c term.
    use nalgebra::Vector3;
    use rov_dynamics::current::CurrentRamp;
    let m = model("model3");
    let heading = 0.6_f64;
    let ramp = CurrentRamp {
        t0_s: 0.0,
        start_ned_mps: Vector3::new(0.1, -0.05, 0.0),
        rate_ned_mps2: Vector3::new(0.02, 0.01, 0.0),
    };
    let rt = rov_dynamics::kinematics::Attitude::new(0.0, 0.0, heading)
        .ned_from_body()
        .transpose();
    let v0 = rt * ramp.start_ned_mps;
    let mut ic = InitialConditions::at_rest(5.0, heading.to_degrees());
    ic.surge_mps = Some(v0.x);
    ic.sway_mps = Some(v0.y);
    let x0 = m.initial_state(&ic);
    let env = Environment {
        current: ramp,
        external: None,
    };
    let x = advance(m.as_ref(), &x0, 0.0, 10.0, &ThrustPct::ZERO, 0.01, &env).unwrap();
    let v10 = rt * ramp.at(10.0).vel_ned_mps;
    assert!(
        (x.nu[0] - v10.x).abs() < 1e-9 && (x.nu[1] - v10.y).abs() < 1e-9,
        "{} {}",
        x.nu,
        v10
    );
    let expected_north = 0.1 * 10.0 + 0.5 * 0.02 * 100.0;
    assert!((x.eta[0] - expected_north).abs() < 1e-8);
}

/// A state-dependent external force (a soft tether pulling aft and down), so the hoisted
/// step must still evaluate τ_ext at every stage.
#[derive(Debug)]
struct SoftTether;

impl ExternalForce for SoftTether {
    fn tau_body(&self, time_s: f64, eta: &Vector6, nu: &Vector6) -> Vector6 {
        Vector6::new(
            -2.0 - 3.0 * nu[0],
            -0.5 * eta[1],
            0.8 + 0.1 * time_s.sin(),
            -0.05 * nu[3],
            0.02 * eta[2],
            -0.1 * nu[5],
        )
    }
}

#[test]
fn each_models_rk4_step_equals_the_four_stage_derivative_step() {
    use nalgebra::Vector3;
    use rov_dynamics::current::CurrentRamp;
    use rov_dynamics::integrators::rk4_step;

    let tether = SoftTether;
    let envs = [
        Environment::calm(),
        Environment {
            // A current that changes over the step (Gauss–Markov ramp) and τ_ext.
            current: CurrentRamp::between(
                1.0,
                0.01,
                Vector3::new(0.2, -0.1, 0.01),
                Vector3::new(0.21, -0.12, 0.0),
            ),
            external: Some(&tether),
        },
    ];
    let cmds = [
        ThrustPct::new(60.0, 40.0, -30.0),
        ThrustPct::new(-80.0, 25.0, 90.0),
    ];
    for name in ["model1", "model2", "model3"] {
        let m = model(name);
        let mut ic = InitialConditions::at_rest(5.0, 30.0);
        ic.surge_mps = Some(0.5);
        ic.pitch_deg = 3.0;
        ic.roll_deg = -2.0;
        ic.yaw_rate_dps = Some(5.0);
        for env in &envs {
            for cmd in &cmds {
                let mut fast = m.initial_state(&ic);
                let mut generic = fast;
                for k in 0..200 {
                    let t = 1.0 + k as f64 * 0.01;
                    fast = m.rk4_step(t, &fast, cmd, env, 0.01);
                    generic = rk4_step(
                        |tt, s: &ModelState| m.derivative(tt, s, cmd, env),
                        t,
                        &generic,
                        0.01,
                    );
                }
                // Same arithmetic in the same order: identical, not merely close.
                assert_eq!(fast.eta, generic.eta, "{name} {cmd:?} eta");
                assert_eq!(fast.nu, generic.nu, "{name} {cmd:?} nu");
                assert!(fast.nu.norm() > 0.01, "{name}: the vehicle moved");
            }
        }
    }
}

/// `Channel::set_value` is the inverse of `Channel::value`: each channel writes its own
/// place in the state (no other), in the units `value` reads.
#[test]
fn channel_set_value_inverts_value() {
    use rov_dynamics::models::{Channel, ModelState};
    let base = ModelState::new(
        nalgebra::Vector6::new(1.0, 2.0, 3.0, 0.1, 0.2, 0.3),
        nalgebra::Vector6::new(0.4, 0.5, 0.6, 0.07, 0.08, 0.09),
    );
    for ch in Channel::ALL {
        let mut s = base;
        let v = ch.value(&base) + 1.5;
        ch.set_value(&mut s, v);
        assert!((ch.value(&s) - v).abs() < 1e-12, "{ch:?}");
        for other in Channel::ALL.iter().filter(|o| **o != ch) {
            assert_eq!(
                other.value(&s),
                other.value(&base),
                "{ch:?} moved {other:?}"
            );
        }
    }
}
