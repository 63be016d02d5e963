//! The simulator core: determinism, timing, sensors, current, external forces, the paper
//! schedules and the model-prediction series.

use nalgebra::Vector3;
use rov_dynamics::current::{CurrentModel, GaussMarkovChannel};
use rov_dynamics::models::{InitialConditions, load_default_model};
use rov_dynamics::{DynamicsError, ThrustPct, Vector6};
use rov_sim::{
    FnForce, Schedule, SimConfig, SimError, Simulator, TetherForce, experiments, predict_measured,
    predict_schedule, run_schedule,
};
use rov_types::measurement::OptionalChannel;

fn config() -> SimConfig {
    SimConfig::default_model3().unwrap()
}

#[test]
fn same_seed_same_run_and_time_does_not_drift() {
    let run = |seed| {
        let mut sim = Simulator::new(config(), seed).unwrap();
        sim.set_command(ThrustPct::new(40.0, 20.0, -30.0)).unwrap();
        let mut out = Vec::new();
        for k in 1..=300 {
            sim.step().unwrap();
            out.push(sim.sensors().pressure_mbar);
            assert_eq!(sim.time_s(), k as f64 * 0.01);
        }
        (out, sim.truth().state)
    };
    let (a, sa) = run(42);
    let (b, sb) = run(42);
    assert_eq!(a, b);
    assert_eq!(sa, sb);
    let (c, sc) = run(43);
    assert_ne!(a, c, "noise depends on the seed");
    assert_eq!(sa, sc, "truth does not depend on the sensor noise");
}

#[test]
fn advance_to_steps_at_100_hz() {
    let mut sim = Simulator::new(config(), 1).unwrap();
    assert_eq!(sim.step_s(), 0.01);
    sim.advance_to(1.0).unwrap();
    assert!((sim.time_s() - 1.0).abs() < 1e-12);
    sim.advance_to(0.5).unwrap();
    assert!((sim.time_s() - 1.0).abs() < 1e-12, "no going back");
    sim.advance_to(1.234).unwrap();
    assert!((sim.time_s() - 1.23).abs() < 1e-12);
}

#[test]
fn commands_are_saturated_and_non_finite_rejected() {
    let mut sim = Simulator::new(config(), 1).unwrap();
    sim.set_command(ThrustPct::new(150.0, -120.0, 30.0))
        .unwrap();
    assert_eq!(sim.command(), ThrustPct::new(100.0, -100.0, 30.0));
    let e = sim
        .set_command(ThrustPct::new(f64::NAN, 0.0, 0.0))
        .unwrap_err();
    assert!(matches!(e, SimError::InvalidInput { .. }));
    assert_eq!(sim.command(), ThrustPct::new(100.0, -100.0, 30.0));
}

#[test]
fn level_vehicle_at_rest_reads_gravity_and_pressure() {
    let mut cfg = config();
    cfg.noiseless = true;
    cfg.initial = InitialConditions::at_rest(3.0, 90.0);
    let mut sim = Simulator::new(cfg, 1).unwrap();
    sim.step().unwrap();
    let r = sim.sensors();
    assert_eq!(r.pro4.heave_accel_milli_mps2, -9810);
    assert_eq!(r.pro4.heading_deci_deg, 900);
    assert_eq!(
        r.pro4.pressure_mbar,
        (1013.25_f64 + 1000.0 * 9.81 * 3.0 / 100.0).round() as i16
    );
    assert!((r.depth_from_pressure_m - 3.0).abs() < 1e-9);
    // Mag field: heading east, the north field component appears on −y body.
    assert!(r.mag_body_ut.y < -19.0 && r.pro4.mag_y_raw < -200);
}

#[test]
fn noiseless_truth_series_equals_model_prediction() {
    let mut cfg = config();
    cfg.noiseless = true;
    cfg.initial = InitialConditions::at_rest(2.0, 10.0);
    let exp = &experiments().unwrap()[4];
    let truth = run_schedule(cfg.clone(), 7, &exp.schedule, 0.1).unwrap();
    let model = load_default_model("model3").unwrap();
    let pred = predict_schedule(model.as_ref(), &cfg.initial, &exp.schedule, 0.1, 0.01).unwrap();
    assert_eq!(truth.rows.len(), pred.rows.len());
    assert_eq!(truth.rows.len(), 421);
    for (a, b) in truth.rows.iter().zip(&pred.rows) {
        assert!((a.time_s - b.time_s).abs() < 1e-9);
        assert_eq!(
            (a.port_pct, a.starboard_pct, a.vertical_pct),
            (b.port_pct, b.starboard_pct, b.vertical_pct)
        );
        for (x, y) in [
            (a.depth_m, b.depth_m),
            (a.heading_deg, b.heading_deg),
            (a.pitch_deg, b.pitch_deg),
            (a.roll_deg, b.roll_deg),
        ] {
            assert!((x - y).abs() < 1e-8, "t = {}: {x} vs {y}", a.time_s);
        }
        for ch in [
            OptionalChannel::YawRateDps,
            OptionalChannel::SurgeMps,
            OptionalChannel::NorthM,
        ] {
            assert!((a.get(ch).unwrap() - b.get(ch).unwrap()).abs() < 1e-8);
        }
    }
    // The vehicle did move in depth and heading.
    assert!(
        truth
            .rows
            .iter()
            .any(|r| (r.heading_deg - 10.0).abs() > 5.0)
    );
    assert!(truth.rows.iter().any(|r| (r.depth_m - 2.0).abs() > 0.5));
    // And the free-run prediction from the measured series starts from its first row.
    let again = predict_measured(model.as_ref(), &truth, 0.01).unwrap();
    assert!((again.rows[200].depth_m - pred.rows[200].depth_m).abs() < 1e-8);
    let csv = truth.to_csv();
    assert!(csv.starts_with("time_s,port_pct,starboard_pct,vertical_pct,depth_m"));
}

#[test]
fn model_predictions_mark_unpredicted_channels_nan() {
    let exp = &experiments().unwrap()[0];
    let m1 = load_default_model("model1").unwrap();
    let s = predict_schedule(
        m1.as_ref(),
        &InitialConditions::at_rest(1.0, 0.0),
        &exp.schedule,
        0.1,
        0.01,
    )
    .unwrap();
    assert!(
        s.rows
            .iter()
            .all(|r| r.pitch_deg.is_nan() && r.roll_deg.is_nan())
    );
    assert!(
        s.rows
            .iter()
            .all(|r| r.depth_m.is_finite() && r.get(OptionalChannel::SwayMps).unwrap().is_nan())
    );
    assert!(s.to_csv().contains(",nan,"));
}

#[test]
fn paper_experiments_run_through_all_models_and_the_simulator() {
    let exps = experiments().unwrap();
    let names: Vec<&str> = exps.iter().map(|e| e.name).collect();
    assert_eq!(
        names,
        [
            "heave_steps",
            "heave_60",
            "yaw_steps",
            "yaw_60",
            "combined_60"
        ]
    );
    let heave = &exps[0].schedule;
    assert_eq!(heave.end_s(), 62.0);
    assert_eq!(heave.command_at(2.0), ThrustPct::new(0.0, 0.0, 30.0));
    assert_eq!(heave.command_at(12.5), ThrustPct::new(0.0, 0.0, -30.0));
    assert_eq!(heave.command_at(52.0), ThrustPct::new(0.0, 0.0, -90.0));
    assert_eq!(
        exps[2].schedule.command_at(22.0),
        ThrustPct::new(60.0, -60.0, 0.0)
    );
    let combined = &exps[4].schedule;
    let mut combos = std::collections::BTreeSet::new();
    for s in combined.steps() {
        if s.command.vertical != 0.0 && s.command.port != 0.0 {
            combos.insert(((s.command.vertical > 0.0), (s.command.port > 0.0)));
        }
    }
    assert_eq!(
        combos.len(),
        4,
        "all four sign combinations of top and rear at 60 %"
    );
    for e in &exps {
        for name in ["model1", "model2", "model3"] {
            let m = load_default_model(name).unwrap();
            let s = predict_schedule(
                m.as_ref(),
                &InitialConditions::at_rest(5.0, 0.0),
                &e.schedule,
                0.1,
                0.01,
            )
            .unwrap();
            assert!(
                s.rows
                    .iter()
                    .all(|r| r.depth_m.is_finite() && r.heading_deg.is_finite()),
                "{} {name}",
                e.name
            );
        }
        let mut cfg = config();
        cfg.initial = InitialConditions::at_rest(5.0, 0.0);
        let s = run_schedule(cfg, 3, &e.schedule, 0.05).unwrap();
        assert!(s.rows.iter().all(|r| r.depth_m.is_finite()));
    }
}

#[test]
fn gauss_markov_current_drifts_the_vehicle_deterministically() {
    let mut cfg = config();
    cfg.current = CurrentModel::GaussMarkov {
        speed: GaussMarkovChannel {
            initial: 0.2,
            mu_per_s: 0.05,
            mean: 0.2,
            sigma: 0.05,
        },
        speed_limits_mps: (0.0, 0.5),
        vertical_angle: GaussMarkovChannel::fixed(0.0),
        direction: GaussMarkovChannel {
            initial: std::f64::consts::FRAC_PI_2,
            mu_per_s: 0.0,
            mean: 0.0,
            sigma: 0.02,
        },
    };
    let run = |seed| {
        let mut sim = Simulator::new(cfg.clone(), seed).unwrap();
        sim.advance_to(60.0).unwrap();
        (sim.truth().state, sim.truth().current_ned_mps)
    };
    let (s1, c1) = run(5);
    let (s2, c2) = run(5);
    assert_eq!(s1, s2);
    assert_eq!(c1, c2);
    assert!(
        s1.eta[1] > 3.0,
        "drifts east with the current: {}",
        s1.eta[1]
    );
    let (s3, _) = run(6);
    assert_ne!(s1, s3);
}

#[test]
fn tether_force_hook_pulls_the_vehicle() {
    let mut sim = Simulator::new(config(), 1).unwrap();
    sim.set_external_force(Some(Box::new(TetherForce {
        force_ned_n: Vector3::new(-3.0, 0.0, 0.0),
        attach_body_m: Vector3::new(-0.15, 0.0, -0.1),
    })));
    let nu_dot0 = sim.truth().nu_dot;
    assert!(nu_dot0[0] < 0.0, "pulled backwards");
    assert!(
        nu_dot0[4].abs() > 0.0,
        "a force above CO makes a pitch moment"
    );
    sim.advance_to(20.0).unwrap();
    assert!(sim.truth().state.eta[0] < -2.0);
}

#[test]
fn non_finite_external_force_stops_the_simulation() {
    let mut sim = Simulator::new(config(), 1).unwrap();
    sim.set_external_force(Some(Box::new(FnForce(
        |t: f64, _eta: &Vector6, _nu: &Vector6| {
            if t >= 0.5 {
                Vector6::repeat(f64::INFINITY)
            } else {
                Vector6::zeros()
            }
        },
    ))));
    let err = sim.advance_to(2.0).unwrap_err();
    match err {
        SimError::Dynamics(DynamicsError::NonFinite { time_s, state }) => {
            assert!(
                (time_s - 0.51).abs() < 1e-9 || (time_s - 0.5).abs() < 1e-9,
                "{time_s}"
            );
            assert!(state.contains("model3"), "{state}");
        }
        other => panic!("unexpected {other}"),
    }
}

#[test]
fn schedule_validation() {
    assert!(Schedule::from_holds(&[(1.0, ThrustPct::new(0.0, 0.0, 200.0))]).is_err());
    assert!(Schedule::new(vec![], f64::NAN).is_err());
    let s = Schedule::from_holds(&[
        (1.0, ThrustPct::ZERO),
        (2.0, ThrustPct::new(10.0, 10.0, 0.0)),
    ])
    .unwrap();
    assert_eq!(s.end_s(), 3.0);
    assert_eq!(s.sample(0.5).unwrap().len(), 7);
    assert!(
        run_schedule(config(), 1, &s, 0.015).is_err(),
        "sample period must be a multiple of the step"
    );
}
