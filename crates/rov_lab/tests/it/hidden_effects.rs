//! Acceptance on data with a hidden effect (issue 6): the test suite's own truth generator
//! (tests/common: model3 perturbed ±20 %, one effect switched on, Pro 4 noise and
//! quantisation, paper-like steps of both signs, a separate held-out run with other order
//! and levels). For every effect the four channels can reveal, at two magnitudes:
//!
//! * the hidden effect is ranked first and marked significant;
//! * adding it cuts the held-out RMSE of the affected channel by ≥ 30 % (≥ 50 % at the
//!   larger magnitude);
//! * its parameter is recovered within 35 %.
//!
//! Training 6 min, held-out 3 min at 20 Hz (shorter than the benchmark's 10 + 5 min to keep
//! the suite fast; the dead zone uses 10 + 5 min); model3 is the model under test (net-buoyancy and restoring-offset are
//! contained in it and found as refits).

use crate::common;

use common::{Hidden, case_len, planar_case};
use rov_lab::diagnose::{DiagnoseOptions, diagnose};
use rov_lab::{BaseKind, LabModel, Run};

const TRAIN_S: f64 = 360.0;
const VAL_S: f64 = 180.0;

struct Case {
    hidden: Hidden,
    effect: &'static str,
    channel: &'static str,
    param: &'static str,
    /// Expected parameter value in the reported (display) unit.
    truth: f64,
    min_reduction_pct: f64,
}

fn check(seed: u64, c: Case) {
    check_len(seed, c, TRAIN_S, VAL_S);
}

fn check_len(seed: u64, c: Case, train_s: f64, val_s: f64) {
    let (tr, va) = case_len(seed, &[c.hidden], train_s, val_s);
    let tr = Run::from_series(&tr, "train").unwrap();
    let va = Run::from_series(&va, "val").unwrap();
    let m = LabModel::default_base(BaseKind::Model3).unwrap();
    let d = diagnose(
        &m,
        "model3",
        &[tr],
        &[va],
        &DiagnoseOptions {
            threads: 1,
            ..Default::default()
        },
    )
    .unwrap();
    let f = &d.findings[0];
    let summary = format!(
        "{:?}: first {} ({:?}), accepted {:?}; reductions {:?}; params {:?}",
        c.hidden,
        f.effect,
        f.status,
        d.accepted,
        f.validation_rmse_reduction_pct,
        f.params
            .iter()
            .map(|(k, p)| format!("{k}={:.4}", p.value))
            .collect::<Vec<_>>()
    );
    eprintln!("{summary}");
    assert_eq!(f.effect, c.effect, "{summary}");
    assert!(f.significant, "{summary}");
    let red = f.validation_rmse_reduction_pct[c.channel];
    assert!(
        red >= c.min_reduction_pct,
        "{} reduction {red:.1} %: {summary}",
        c.channel
    );
    let p = f.params[c.param].value;
    let err = (p - c.truth).abs() / c.truth.abs();
    assert!(
        err <= 0.35,
        "{} = {p} vs {} ({:.0} %): {summary}",
        c.param,
        c.truth,
        err * 100.0
    );
}

macro_rules! hidden_case {
    ($name:ident, $seed:expr, $hidden:expr, $effect:expr, $ch:expr, $param:expr, $truth:expr, $red:expr) => {
        #[test]
        fn $name() {
            check(
                $seed,
                Case {
                    hidden: $hidden,
                    effect: $effect,
                    channel: $ch,
                    param: $param,
                    truth: $truth,
                    min_reduction_pct: $red,
                },
            );
        }
    };
}

hidden_case!(
    asymmetry_small,
    11,
    Hidden::AsymVertical(0.75),
    "thrust-asymmetry",
    "depth",
    "reverse_ratio_vertical",
    0.75,
    30.0
);
hidden_case!(
    asymmetry_large,
    11,
    Hidden::AsymVertical(0.55),
    "thrust-asymmetry",
    "depth",
    "reverse_ratio_vertical",
    0.55,
    50.0
);
hidden_case!(
    lag_small,
    11,
    Hidden::Lag(0.12),
    "thruster-lag",
    "heading",
    "lag_time_constant_s",
    0.12,
    30.0
);
hidden_case!(
    lag_large,
    11,
    Hidden::Lag(0.3),
    "thruster-lag",
    "heading",
    "lag_time_constant_s",
    0.3,
    50.0
);
hidden_case!(
    power_small,
    11,
    Hidden::PowerLimit(0.8),
    "power-limit",
    "heading",
    "power_max",
    0.8,
    30.0
);
hidden_case!(
    power_large,
    11,
    Hidden::PowerLimit(0.5),
    "power-limit",
    "heading",
    "power_max",
    0.5,
    50.0
);
hidden_case!(
    arm_small,
    11,
    Hidden::ArmXv(0.01),
    "thruster-moment-arm",
    "pitch",
    "vertical_arm_x_m",
    10.0,
    30.0
);
hidden_case!(
    arm_large,
    11,
    Hidden::ArmXv(0.025),
    "thruster-moment-arm",
    "pitch",
    "vertical_arm_x_m",
    25.0,
    50.0
);
hidden_case!(
    torque_small,
    11,
    Hidden::TorqueV(0.001),
    "propeller-torque",
    "heading",
    "torque_vertical_m",
    1.0,
    30.0
);
hidden_case!(
    torque_large,
    11,
    Hidden::TorqueV(0.003),
    "propeller-torque",
    "heading",
    "torque_vertical_m",
    3.0,
    50.0
);
hidden_case!(
    buoyancy_small,
    11,
    Hidden::NetBuoyancy(0.3),
    "net-buoyancy",
    "depth",
    "net_weight_n",
    0.3,
    30.0
);
hidden_case!(
    buoyancy_large,
    11,
    Hidden::NetBuoyancy(0.8),
    "net-buoyancy",
    "depth",
    "net_weight_n",
    0.8,
    50.0
);
hidden_case!(
    restoring_small,
    11,
    Hidden::CgX(0.0003),
    "restoring-offset",
    "pitch",
    "cg_x_m",
    0.3,
    30.0
);
hidden_case!(
    restoring_large,
    11,
    Hidden::CgX(0.0008),
    "restoring-offset",
    "pitch",
    "cg_x_m",
    0.8,
    50.0
);
hidden_case!(
    drag_small,
    11,
    Hidden::DragHeave(1.25),
    "drag-form",
    "depth",
    "drag_ratio_heave",
    1.25,
    30.0
);
hidden_case!(
    drag_large,
    11,
    Hidden::DragHeave(1.5),
    "drag-form",
    "depth",
    "drag_ratio_heave",
    1.5,
    50.0
);
hidden_case!(
    tether_small,
    11,
    Hidden::Tether(0.3, 60.0),
    "tether",
    "heading",
    "tether_east_n",
    0.3 * 0.866,
    30.0
);
hidden_case!(
    tether_large,
    11,
    Hidden::Tether(0.6, 60.0),
    "tether",
    "heading",
    "tether_east_n",
    0.6 * 0.866,
    50.0
);
hidden_case!(
    depth_drift_small,
    11,
    Hidden::DepthDrift(4.0),
    "depth-sensor-drift",
    "depth",
    "depth_drift_mps",
    4.0,
    30.0
);
hidden_case!(
    depth_drift_large,
    11,
    Hidden::DepthDrift(10.0),
    "depth-sensor-drift",
    "depth",
    "depth_drift_mps",
    10.0,
    50.0
);
hidden_case!(
    compass_small,
    11,
    Hidden::CompassEmiV(4.0),
    "compass-deviation",
    "heading",
    "compass_interference_vertical_deg",
    4.0,
    30.0
);
hidden_case!(
    compass_large,
    11,
    Hidden::CompassEmiV(8.0),
    "compass-deviation",
    "heading",
    "compass_interference_vertical_deg",
    8.0,
    50.0
);
hidden_case!(
    attitude_bias_small,
    11,
    Hidden::PitchBias(1.5),
    "attitude-bias",
    "pitch",
    "pitch_bias_deg",
    1.5,
    30.0
);
hidden_case!(
    attitude_bias_large,
    11,
    Hidden::PitchBias(3.0),
    "attitude-bias",
    "pitch",
    "pitch_bias_deg",
    3.0,
    50.0
);

// The dead zone trades against the linear share of the thrust map and the drag shape at
// steady state; it needs the full 10 min of training data (the benchmark length).
#[test]
fn deadzone_small() {
    check_len(
        12,
        Case {
            hidden: Hidden::Deadzone(0.12),
            effect: "thruster-deadzone",
            channel: "heading",
            param: "deadzone_fraction",
            truth: 12.0,
            min_reduction_pct: 30.0,
        },
        600.0,
        300.0,
    );
}

#[test]
fn deadzone_large() {
    check_len(
        12,
        Case {
            hidden: Hidden::Deadzone(0.2),
            effect: "thruster-deadzone",
            channel: "heading",
            param: "deadzone_fraction",
            truth: 20.0,
            min_reduction_pct: 50.0,
        },
        600.0,
        300.0,
    );
}

/// A depth-sensor drift next to another effect (the probe's case 3: a planar model2 truth
/// with weak reverse thrust on the horizontal thrusters and a 6 cm/min drift). The drift
/// shows only in the free run (every re-initialised window removes it), so it must be
/// judged there; with the asymmetry explaining the base's shooting misfit it was missed
/// when both views had to improve.
#[test]
fn depth_drift_next_to_another_effect_is_found_in_the_free_run() {
    let hidden = [Hidden::AsymHorizontal(0.7), Hidden::DepthDrift(6.0)];
    let (tr, va) = planar_case("model2", 63, &hidden, TRAIN_S, VAL_S);
    let tr = Run::from_series(&tr, "train").unwrap();
    let va = Run::from_series(&va, "val").unwrap();
    let m = LabModel::default_base(BaseKind::Model2).unwrap();
    let d = diagnose(
        &m,
        "model2",
        &[tr],
        &[va],
        &DiagnoseOptions {
            threads: 1,
            ..Default::default()
        },
    )
    .unwrap();
    let keys: Vec<&str> = d.accepted.iter().map(|e| e.key()).collect();
    let summary = format!("accepted {keys:?}: {}", d.summary);
    assert!(keys.contains(&"thrust-asymmetry"), "{summary}");
    assert!(keys.contains(&"depth-sensor-drift"), "{summary}");
    let f = d
        .findings
        .iter()
        .find(|f| f.effect == "depth-sensor-drift")
        .unwrap();
    // Found is what this test is about. The fitted rate is still low (3.2 cm/min on this
    // seed: the asymmetry's fit with the base absorbs part of the drift), so the test
    // asks for the right sign and order only, not the 35 % (a known weakness).
    let rate = f.params["depth_drift_mps"].value;
    assert!(
        (0.4 * 6.0..=1.5 * 6.0).contains(&rate),
        "drift {rate} cm/min vs 6: {summary}"
    );
}

/// An accepted effect's parameter is fitted to convergence (the probe's case 2: a planar
/// model2 truth with a 0.2 s thruster lag). The short confirmation budget that ranks the
/// candidates stopped at 0.12 s here (restarting it from where it stopped crept on by
/// 1-2 % of the cost a round, to 0.15 s); one long LM call per start reaches 0.20 s. Only
/// the accepted effect pays for the longer fit.
#[test]
fn an_accepted_lag_is_fitted_to_convergence() {
    let (tr, va) = planar_case("model2", 62, &[Hidden::Lag(0.2)], TRAIN_S, VAL_S);
    let tr = Run::from_series(&tr, "train").unwrap();
    let va = Run::from_series(&va, "val").unwrap();
    let m = LabModel::default_base(BaseKind::Model2).unwrap();
    let d = diagnose(
        &m,
        "model2",
        &[tr],
        &[va],
        &DiagnoseOptions {
            threads: 1,
            ..Default::default()
        },
    )
    .unwrap();
    let keys: Vec<&str> = d.accepted.iter().map(|e| e.key()).collect();
    let summary = format!("accepted {keys:?}: {}", d.summary);
    assert!(keys.contains(&"thruster-lag"), "{summary}");
    let f = d
        .findings
        .iter()
        .find(|f| f.effect == "thruster-lag")
        .unwrap();
    let tau = f.params["lag_time_constant_s"].value;
    assert!(
        (tau - 0.2).abs() <= 0.1 * 0.2,
        "lag {tau} s vs 0.2 s: {summary}"
    );
}
