//! Closed loop against rov_sim's 6-DOF simulator with the model3 truth (see
//! `common::sim6`), with each model's feedforward: step response, disturbances,
//! feedforward benefit, observer accuracy.

use crate::common::sim6::{Disturbance, Sim6};
use crate::common::{StepMetrics, rms, step_metrics};
use rov_control::angle::wrap_deg_180;
use rov_control::{ControlConfig, Controller, ModeCommand, ModelChoice, ModelSet, PilotInput};

const DT: f64 = 0.02;

#[derive(Debug)]
struct StepRun {
    depth: StepMetrics,
    heading: StepMetrics,
    depth_obs_rmse_m: f64,
    depth_meas_rmse_m: f64,
    heading_obs_rmse_deg: f64,
    heading_meas_rmse_deg: f64,
    saturated_pct: f64,
}

fn controller(model: ModelChoice, ff: bool) -> Controller {
    let cfg = ControlConfig {
        feedforward_model: model,
        feedforward_enabled: ff,
        ..ControlConfig::default()
    };
    Controller::new(cfg, ModelSet::load_default().unwrap()).unwrap()
}

/// A step to (`depth_m`, `heading_deg`) from 2 m shallower and 90° off (`turn_sign` = +1:
/// the start is 90° to port of the target, so the vehicle turns to starboard), 40 s.
fn step_run(
    model: ModelChoice,
    dist: Disturbance,
    seed: u64,
    (depth_m, heading_deg, turn_sign): (f64, f64, f64),
    path: SensorPath,
) -> StepRun {
    let (d0, h0) = (depth_m - 2.0, heading_deg - turn_sign * 90.0);
    let mut sim = Sim6::new(d0, h0, dist, seed).with_gyro(path.gyro);
    let mut c = controller(model, true);
    c.tick(0.0, &sim.measure(), &PilotInput::default());
    c.command(ModeCommand::SetDepth { depth_m }).unwrap();
    c.command(ModeCommand::SetHeading { heading_deg }).unwrap();
    let mut t_log = Vec::new();
    let (mut d_log, mut h_log) = (Vec::new(), Vec::new());
    let (mut d_obs, mut d_meas, mut h_obs, mut h_meas) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut saturated = 0usize;
    let mut cmd = c.last_command();
    let n = (40.0 / DT) as usize;
    let mut pending = sim.measure();
    for k in 1..=n {
        sim.step(&cmd, DT);
        let t = k as f64 * DT;
        // With a delayed path the controller sees the sample taken one tick earlier (the
        // reply to the previous request), as through the tether protocol.
        let fresh = sim.measure();
        let m = if path.delayed {
            std::mem::replace(&mut pending, fresh)
        } else {
            fresh
        };
        let out = c.tick(t, &m, &PilotInput::default());
        cmd = out.command;
        if [cmd.port_pct(), cmd.starboard_pct(), cmd.vertical_pct()]
            .iter()
            .any(|v| v.abs() >= 99.5)
        {
            saturated += 1;
        }
        t_log.push(t);
        d_log.push(sim.depth_m());
        h_log.push(sim.heading_deg());
        let dg = out.diagnostics;
        d_obs.push(dg.depth_estimate_m().unwrap() - sim.depth_m());
        d_meas.push(m.depth_m.unwrap() - sim.depth_m());
        h_obs.push(wrap_deg_180(
            dg.heading_estimate_deg().unwrap() - sim.heading_deg(),
        ));
        h_meas.push(wrap_deg_180(m.heading_deg.unwrap() - sim.heading_deg()));
    }
    StepRun {
        depth: step_metrics(&t_log, &d_log, d0, depth_m, 0.02 * 2.0, 10.0, false),
        heading: step_metrics(&t_log, &h_log, h0, heading_deg, 1.0, 10.0, true),
        depth_obs_rmse_m: rms(&d_obs),
        depth_meas_rmse_m: rms(&d_meas),
        heading_obs_rmse_deg: rms(&h_obs),
        heading_meas_rmse_deg: rms(&h_meas),
        saturated_pct: 100.0 * saturated as f64 / n as f64,
    }
}

/// Checks the acceptance limits; returns a description of every violation.
fn check(label: &str, r: &StepRun) -> Vec<String> {
    println!(
        "{label}: depth settle {:?} s, overshoot {:.2} %, steady {:.4} m | heading settle {:?} s, overshoot {:.2}°, steady {:.3}° | observer depth {:.4} vs meas {:.4} m, heading {:.3} vs {:.3}° | sat {:.1} %",
        r.depth.settle_s,
        100.0 * r.depth.overshoot / 2.0,
        r.depth.steady_error,
        r.heading.settle_s,
        r.heading.overshoot,
        r.heading.steady_error,
        r.depth_obs_rmse_m,
        r.depth_meas_rmse_m,
        r.heading_obs_rmse_deg,
        r.heading_meas_rmse_deg,
        r.saturated_pct,
    );
    let mut bad = Vec::new();
    let mut req = |ok: bool, what: String| {
        if !ok {
            bad.push(format!("{label}: {what}"));
        }
    };
    req(
        r.depth.settle_s.is_some_and(|s| s <= 10.0),
        format!("depth settle {:?}", r.depth.settle_s),
    );
    req(
        r.depth.overshoot <= 0.05 * 2.0,
        format!("depth overshoot {}", r.depth.overshoot),
    );
    req(
        r.depth.steady_error <= 0.03,
        format!("depth steady error {}", r.depth.steady_error),
    );
    req(
        r.heading.settle_s.is_some_and(|s| s <= 8.0),
        format!("heading settle {:?}", r.heading.settle_s),
    );
    req(
        r.heading.overshoot <= 3.0,
        format!("heading overshoot {}", r.heading.overshoot),
    );
    req(
        r.heading.steady_error <= 1.0,
        format!("heading steady error {}", r.heading.steady_error),
    );
    req(
        r.depth_obs_rmse_m < r.depth_meas_rmse_m,
        "depth observer no better than raw".into(),
    );
    req(
        r.heading_obs_rmse_deg < r.heading_meas_rmse_deg,
        "heading observer no better than raw".into(),
    );
    bad
}

/// Targets (depth m, heading °, turn direction): across north, both turn directions,
/// and every tether geometry quadrant.
const GEOMETRIES: [(f64, f64, f64); 6] = [
    (5.0, 30.0, 1.0),
    (5.0, 30.0, -1.0),
    (8.0, 90.0, 1.0),
    (8.0, 180.0, -1.0),
    (3.0, 270.0, 1.0),
    (3.0, 0.0, -1.0),
];

/// How the measurements reach the controller.
#[derive(Debug, Clone, Copy)]
struct SensorPath {
    /// Feed the gyro's heading rate.
    gyro: bool,
    /// One control period of latency.
    delayed: bool,
}

const PLAIN: SensorPath = SensorPath {
    gyro: false,
    delayed: false,
};

fn step_suite(dist: Disturbance, path: SensorPath) {
    let mut bad = Vec::new();
    for (g, geometry) in GEOMETRIES.iter().enumerate() {
        for m in ModelChoice::ALL {
            let label = format!(
                "{} {dist:?} target {:?}{}",
                m.name(),
                geometry,
                match (path.gyro, path.delayed) {
                    (false, false) => "",
                    (true, false) => " gyro",
                    (false, true) => " delayed",
                    (true, true) => " gyro delayed",
                }
            );
            bad.extend(check(
                &label,
                &step_run(m, dist, 10 * g as u64 + 1, *geometry, path),
            ));
        }
    }
    assert!(bad.is_empty(), "{bad:#?}");
}

#[test]
fn step_response_calm_each_model() {
    step_suite(Disturbance::None, PLAIN);
}

#[test]
fn step_response_current_each_model() {
    step_suite(Disturbance::Current, PLAIN);
}

#[test]
fn step_response_tether_each_model() {
    step_suite(Disturbance::Tether, PLAIN);
}

/// The same with the gyro's yaw rate fed to the observer.
#[test]
fn step_response_with_gyro_rate() {
    for dist in [Disturbance::None, Disturbance::Current, Disturbance::Tether] {
        step_suite(
            dist,
            SensorPath {
                gyro: true,
                delayed: false,
            },
        );
    }
}

/// The same with one control period of measurement latency (the tether protocol's
/// request/reply cycle).
#[test]
fn step_response_with_one_tick_latency() {
    for dist in [Disturbance::None, Disturbance::Current, Disturbance::Tether] {
        step_suite(
            dist,
            SensorPath {
                gyro: false,
                delayed: true,
            },
        );
    }
}

/// Tracking errors over a moving reference: (vs the reference model's desired
/// position, vs the moving setpoint itself).
#[derive(Debug, Clone, Copy)]
struct Tracking {
    depth_vs_ref_m: f64,
    depth_vs_setpoint_m: f64,
    heading_vs_ref_deg: f64,
    heading_vs_setpoint_deg: f64,
}

/// Holds 3 m / 0° for 10 s, then moves the depth setpoint at 0.2 m/s and the heading
/// setpoint at 20 °/s for 10 s (typed every tick), then holds for 5 s. RMS errors of
/// the true depth and heading over the ramp and the 5 s after it.
fn ramp_run(model: ModelChoice, ff: bool, dist: Disturbance) -> Tracking {
    let mut sim = Sim6::new(3.0, 0.0, dist, 5);
    let mut c = controller(model, ff);
    c.tick(0.0, &sim.measure(), &PilotInput::default());
    c.command(ModeCommand::SetDepth { depth_m: 3.0 }).unwrap();
    c.command(ModeCommand::SetHeading { heading_deg: 0.0 })
        .unwrap();
    let mut cmd = c.last_command();
    let (mut dr, mut ds, mut hr, mut hs) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for k in 1..=(25.0 / DT) as usize {
        sim.step(&cmd, DT);
        let t = k as f64 * DT;
        let ramp_t = (t - 10.0).clamp(0.0, 10.0);
        let (sp_d, sp_h) = (3.0 + 0.2 * ramp_t, 20.0 * ramp_t);
        if t > 10.0 {
            c.command(ModeCommand::SetDepth { depth_m: sp_d }).unwrap();
            c.command(ModeCommand::SetHeading { heading_deg: sp_h })
                .unwrap();
        }
        let out = c.tick(t, &sim.measure(), &PilotInput::default());
        cmd = out.command;
        if t > 10.0 {
            let dg = out.diagnostics;
            dr.push(sim.depth_m() - dg.depth.reference.pos);
            ds.push(sim.depth_m() - sp_d);
            hr.push(wrap_deg_180(
                sim.heading_deg() - dg.heading.reference.pos.to_degrees(),
            ));
            hs.push(wrap_deg_180(sim.heading_deg() - sp_h));
        }
    }
    Tracking {
        depth_vs_ref_m: rms(&dr),
        depth_vs_setpoint_m: rms(&ds),
        heading_vs_ref_deg: rms(&hr),
        heading_vs_setpoint_deg: rms(&hs),
    }
}

/// Feedforward benefit on a 0.2 m/s depth ramp and a 20 °/s heading sweep, RMSE against
/// the reference trajectory, with and without feedforward (same PID, same observer).
///
/// Asserted: ≥ 30 % for model1 and model3 in calm water and in the current, and a
/// positive cut for model2 there. Printed only: model2's figures (its linear thrust map
/// gives the model3 vehicle 3–7× less low-thrust force than model2 intends, so its
/// feedforward delivers only that share) and the tether case (the tether's yaw moment
/// turns with the heading during the sweep and dominates the heading error).
#[test]
fn feedforward_cuts_tracking_rmse() {
    let mut failures = Vec::new();
    for dist in [Disturbance::None, Disturbance::Current, Disturbance::Tether] {
        let without = ramp_run(ModelChoice::Model3, false, dist);
        for m in ModelChoice::ALL {
            let with = ramp_run(m, true, dist);
            let cut_d = 1.0 - with.depth_vs_ref_m / without.depth_vs_ref_m;
            let cut_h = 1.0 - with.heading_vs_ref_deg / without.heading_vs_ref_deg;
            println!(
                "{dist:?} {}: depth RMSE vs reference {:.4} m (no FF {:.4}) cut {:.0} %, vs setpoint {:.4} (no FF {:.4}) | heading vs reference {:.3}° (no FF {:.3}) cut {:.0} %, vs setpoint {:.3} (no FF {:.3})",
                m.name(),
                with.depth_vs_ref_m,
                without.depth_vs_ref_m,
                100.0 * cut_d,
                with.depth_vs_setpoint_m,
                without.depth_vs_setpoint_m,
                with.heading_vs_ref_deg,
                without.heading_vs_ref_deg,
                100.0 * cut_h,
                with.heading_vs_setpoint_deg,
                without.heading_vs_setpoint_deg,
            );
            if dist == Disturbance::Tether {
                continue;
            }
            let need = if m == ModelChoice::Model2 { 0.0 } else { 0.30 };
            if cut_d <= need {
                failures.push(format!("{dist:?} {}: depth cut {cut_d:.2}", m.name()));
            }
            if cut_h <= need {
                failures.push(format!("{dist:?} {}: heading cut {cut_h:.2}", m.name()));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// The observer's bias state absorbs the tether's yaw moment.
#[test]
fn bias_absorbs_the_tether_moment() {
    let mut sim = Sim6::new(5.0, 30.0, Disturbance::Tether, 9);
    let mut c = controller(ModelChoice::Model3, true);
    c.tick(0.0, &sim.measure(), &PilotInput::default());
    c.command(ModeCommand::Engage(rov_control::Axis::Depth))
        .unwrap();
    c.command(ModeCommand::Engage(rov_control::Axis::Heading))
        .unwrap();
    let mut cmd = c.last_command();
    let mut bias = Vec::new();
    let mut truth = Vec::new();
    for k in 1..=(60.0 / DT) as usize {
        sim.step(&cmd, DT);
        let out = c.tick(k as f64 * DT, &sim.measure(), &PilotInput::default());
        cmd = out.command;
        if k as f64 * DT > 40.0 {
            bias.push(out.diagnostics.heading.estimate.unwrap().bias);
            truth.push(sim.tether_yaw_moment_nm());
        }
    }
    let b = bias.iter().sum::<f64>() / bias.len() as f64;
    let t = truth.iter().sum::<f64>() / truth.len() as f64;
    println!("tether yaw moment {t:.4} N·m, bias estimate {b:.4} N·m");
    assert!(
        t.abs() > 0.05,
        "the tether must load the yaw axis in this scenario: {t}"
    );
    assert!(
        (b - t).abs() < 0.25 * t.abs(),
        "bias {b} vs tether moment {t}"
    );
}
