//! The autopilot's plant of a lab model (`VehicleModel::plant`): the calibrated thrust
//! path with the catalog's thrust effects, consistent with what the model simulates.

use rov_dynamics::VehicleModel;
use rov_dynamics::models::ModelState;
use rov_lab::params::{Param, Thr};
use rov_lab::{BaseKind, EffectId, LabModel};

/// model3 with a weak reverse vertical thrust, a lag, a dead zone and a reaction torque.
fn hurt_model3() -> LabModel {
    let mut m = LabModel::default_base(BaseKind::Model3).unwrap();
    m.set_many(
        &[
            Param::ReverseRatio(Thr::Vertical),
            Param::LagTau,
            Param::Deadzone,
            Param::TorqueV,
            Param::ThrustLin(Thr::Vertical),
        ],
        &[0.5, 0.3, 0.06, 0.01, 0.9],
    )
    .unwrap();
    for e in [
        EffectId::ThrustAsymmetry,
        EffectId::ThrusterLag,
        EffectId::ThrusterDeadzone,
        EffectId::PropellerTorque,
    ] {
        m.add_effect(e);
    }
    m
}

#[test]
fn the_plant_carries_the_effects_and_matches_the_models_own_thrust() {
    let m = hurt_model3();
    let p = m.plant().expect("a Pro 4 base has a plant");
    assert!((p.vertical.reverse.linear_n - 0.5 * p.vertical.forward.linear_n).abs() < 1e-12);
    assert!((p.vertical.reverse.quadratic_n - 0.5 * p.vertical.forward.quadratic_n).abs() < 1e-12);
    assert_eq!(p.vertical_path.lag_tau_s, 0.3);
    assert_eq!(p.port_path.lag_tau_s, 0.3);
    assert_eq!(p.vertical_path.dead_zone, 0.06);
    let state = ModelState::default();
    for pct in [-100.0, -60.0, -20.0, -3.0, 0.0, 4.0, 35.0, 100.0] {
        // The heave force and yaw moment the lab model's own stages give for a held
        // vertical command (lag settled: the command itself) ...
        let f = m.thrusts(&{
            let mut t = [0.0; rov_dynamics::models::vehicle::MAX_THRUSTERS];
            t[2] = pct;
            t
        });
        let tau = m.thrust_tau(&f, &state);
        // ... equal the plant's.
        let z = p.vertical.force_n(p.vertical_path.through_dead_zone(pct));
        assert!((tau[2] - z).abs() < 1e-9, "{pct}: {} vs {z}", tau[2]);
        assert!(
            (tau[5] - p.yaw_per_heave_m * z).abs() < 1e-9,
            "{pct}: yaw {}",
            tau[5]
        );
    }
}

#[test]
fn model1_net_weight_is_the_plants_static_load_and_bases_match_the_published_plants() {
    let mut m = LabModel::default_base(BaseKind::Model1).unwrap();
    m.set_many(&[Param::NetWeight], &[0.7]).unwrap();
    m.add_effect(EffectId::NetBuoyancy);
    let p = m.plant().unwrap();
    assert!((p.heave.static_load - 0.7).abs() < 1e-12);
    for kind in BaseKind::ALL {
        let lab = LabModel::default_base(kind).unwrap().plant().unwrap();
        let shipped = rov_dynamics::load_default_model(kind.name())
            .unwrap()
            .plant()
            .unwrap();
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * (1.0 + b.abs());
        assert!(close(lab.heave.inertia, shipped.heave.inertia), "{kind:?}");
        assert!(
            close(lab.yaw.damping_quad, shipped.yaw.damping_quad),
            "{kind:?}"
        );
        assert!(close(
            lab.vertical.forward.quadratic_n,
            shipped.vertical.forward.quadratic_n
        ));
        assert!(
            close(lab.port.forward.linear_n, shipped.port.forward.linear_n),
            "{kind:?}"
        );
        assert!(close(lab.yaw_arm_m, shipped.yaw_arm_m), "{kind:?}");
    }
}
