//! Closed loop against a decoupled heave/yaw plant built from each model's own
//! parameters (a quick check that runs without the 6-DOF simulator). Sensor path:
//! integer mbar pressure and heading ×10 integers, plus noise.

use crate::common::{AxisPlant, Rng, StepMetrics, step_metrics};
use rov_control::{
    ControlConfig, Controller, Measurements, ModeCommand, ModelChoice, ModelSet, PilotInput,
    PlantModel,
};

const DT: f64 = 0.02;
const MBAR_PER_M: f64 = 1000.0 * 9.81 / 100.0;

fn sense(plant: &AxisPlant, rng: &mut Rng) -> Measurements {
    let p_mbar = (1013.0 + plant.depth_m * MBAR_PER_M + 0.5 * rng.normal()).round();
    let h10 = ((plant.heading_deg() + 0.2 * rng.normal()) * 10.0).round();
    Measurements {
        depth_m: Some((p_mbar - 1013.0) / MBAR_PER_M),
        heading_deg: Some(h10 / 10.0),
        yaw_rate_rad_s: None,
    }
}

struct Run {
    depth: StepMetrics,
    heading: StepMetrics,
}

fn step_run(
    truth: PlantModel,
    plant: ModelChoice,
    ff: ModelChoice,
    heave_dist_n: f64,
    yaw_dist_nm: f64,
) -> Run {
    let cfg = ControlConfig {
        feedforward_model: ff,
        plant_model: plant,
        ..ControlConfig::default()
    };
    let mut c = Controller::new(cfg, ModelSet::load_default().unwrap()).unwrap();
    let mut rng = Rng::new(11);
    let (d0, d1, h0, h1) = (3.0, 5.0, 0.0, 90.0);
    let mut plant = AxisPlant::new(truth, d0, h0);
    plant.heave_disturbance_n = heave_dist_n;
    plant.yaw_disturbance_nm = yaw_dist_nm;
    let (mut t_log, mut d_log, mut h_log) = (Vec::new(), Vec::new(), Vec::new());
    c.tick(0.0, &sense(&plant, &mut rng), &PilotInput::default());
    c.command(ModeCommand::SetDepth { depth_m: d1 }).unwrap();
    c.command(ModeCommand::SetHeading { heading_deg: h1 })
        .unwrap();
    for k in 1..=(40.0 / DT) as usize {
        let t = k as f64 * DT;
        let out = c.tick(t, &sense(&plant, &mut rng), &PilotInput::default());
        let cmd = out.command;
        plant.step(cmd.port_pct(), cmd.starboard_pct(), cmd.vertical_pct(), DT);
        t_log.push(t);
        d_log.push(plant.depth_m);
        h_log.push(plant.heading_deg());
    }
    Run {
        depth: step_metrics(&t_log, &d_log, d0, d1, 0.02 * (d1 - d0).abs(), 10.0, false),
        heading: step_metrics(&t_log, &h_log, h0, h1, 1.0, 10.0, true),
    }
}

fn check(label: &str, r: &Run) {
    println!(
        "{label}: depth {:?}\n{label}: heading {:?}",
        r.depth, r.heading
    );
    assert!(
        r.depth.settle_s.is_some_and(|s| s <= 10.0),
        "{label} depth settle {:?}",
        r.depth.settle_s
    );
    assert!(
        r.depth.overshoot <= 0.05 * 2.0,
        "{label} depth overshoot {}",
        r.depth.overshoot
    );
    assert!(
        r.depth.steady_error <= 0.03,
        "{label} depth steady {}",
        r.depth.steady_error
    );
    assert!(
        r.heading.settle_s.is_some_and(|s| s <= 8.0),
        "{label} heading settle {:?}",
        r.heading.settle_s
    );
    assert!(
        r.heading.overshoot <= 3.0,
        "{label} heading overshoot {}",
        r.heading.overshoot
    );
    assert!(
        r.heading.steady_error <= 1.0,
        "{label} heading steady {}",
        r.heading.steady_error
    );
}

/// If the vehicle really behaved like model m, `plant_model = m` (and its feedforward)
/// holds it to the same limits.
#[test]
fn step_response_each_model_on_its_own_axes() {
    for m in ModelChoice::ALL {
        let r = step_run(PlantModel::load_default(m).unwrap(), m, m, 0.0, 0.0);
        check(m.name(), &r);
    }
}

#[test]
fn step_response_with_constant_disturbances() {
    for m in ModelChoice::ALL {
        // 30 % of the vertical thrust and 20 % of the yaw moment (C6-like).
        let r = step_run(
            PlantModel::load_default(ModelChoice::Model3).unwrap(),
            ModelChoice::Model3,
            m,
            3.0,
            0.68,
        );
        check(&format!("{} disturbed", m.name()), &r);
    }
}

/// C6 run: holding at 10 m / 200°, a buoyancy offset of `sign` × 30 % of the vertical
/// thrust (3 N) and a yaw moment of `sign` × 20 % of the maximum (0.68 N·m) appear at
/// t = 10 s over `onset_s` (0 = a step). Returns the largest depth and heading deviations.
fn c6_run(sign: f64, onset_s: f64) -> (f64, f64) {
    let mut c =
        Controller::new(ControlConfig::default(), ModelSet::load_default().unwrap()).unwrap();
    let mut rng = Rng::new(21);
    let mut plant = AxisPlant::new(
        PlantModel::load_default(ModelChoice::Model3).unwrap(),
        10.0,
        200.0,
    );
    c.tick(0.0, &sense(&plant, &mut rng), &PilotInput::default());
    c.command(ModeCommand::Engage(rov_control::Axis::Depth))
        .unwrap();
    c.command(ModeCommand::Engage(rov_control::Axis::Heading))
        .unwrap();
    let (mut max_dd, mut max_dh) = (0.0_f64, 0.0_f64);
    for k in 1..=(40.0 / DT) as usize {
        let t = k as f64 * DT;
        let share = if onset_s > 0.0 {
            ((t - 10.0) / onset_s).clamp(0.0, 1.0)
        } else if t >= 10.0 {
            1.0
        } else {
            0.0
        };
        plant.heave_disturbance_n = sign * 3.0 * share;
        plant.yaw_disturbance_nm = sign * 0.68 * share;
        let cmd = c
            .tick(t, &sense(&plant, &mut rng), &PilotInput::default())
            .command;
        plant.step(cmd.port_pct(), cmd.starboard_pct(), cmd.vertical_pct(), DT);
        max_dd = max_dd.max((plant.depth_m - 10.0).abs());
        max_dh = max_dh.max(rov_control::angle::wrap_deg_180(plant.heading_deg() - 200.0).abs());
    }
    (max_dd, max_dh)
}

/// C6 (reliability doc): holding, a buoyancy offset of ±30 % of the vertical thrust must
/// keep the depth within ±0.3 m — met, with margin. A yaw moment of 20 % of the maximum
/// should keep the heading within ±3° — NOT met by the default gains, which are tuned for
/// the ±1° noise band of the acceptance: the heading deviates about 5° when the
/// moment builds up over 2 s and about 8° for a step (kp = 5 N·m/rad gives 7.8° of
/// static deflection before the integrator and the bias estimate take over). This test
/// guards those figures against regression.
#[test]
fn c6_disturbance_rejection_while_holding() {
    for sign in [1.0, -1.0] {
        let (dd, dh) = c6_run(sign, 2.0);
        let (sd, sh) = c6_run(sign, 0.0);
        println!(
            "sign {sign}: 2 s onset: depth {dd:.3} m, heading {dh:.2}° | step: depth {sd:.3} m, heading {sh:.2}°"
        );
        assert!(dd <= 0.3 && sd <= 0.3, "depth {dd} / {sd}");
        assert!(dh <= 6.0, "heading (2 s onset) {dh}");
        assert!(sh <= 9.0, "heading (step) {sh}");
    }
}

/// Heading wrap: holding 359°, a setpoint of 1° turns 2° to starboard, never the long way.
#[test]
fn heading_wrap_goes_the_short_way() {
    let mut c =
        Controller::new(ControlConfig::default(), ModelSet::load_default().unwrap()).unwrap();
    let mut rng = Rng::new(5);
    let mut plant = AxisPlant::new(
        PlantModel::load_default(ModelChoice::Model3).unwrap(),
        5.0,
        359.0,
    );
    c.tick(0.0, &sense(&plant, &mut rng), &PilotInput::default());
    c.command(ModeCommand::SetHeading { heading_deg: 1.0 })
        .unwrap();
    let mut first_yaw = None;
    let mut worst = 0.0_f64;
    for k in 1..=(10.0 / DT) as usize {
        let out = c.tick(
            k as f64 * DT,
            &sense(&plant, &mut rng),
            &PilotInput::default(),
        );
        let cmd = out.command;
        if first_yaw.is_none() && cmd.port_pct() != cmd.starboard_pct() {
            first_yaw = Some(cmd.port_pct() - cmd.starboard_pct());
        }
        plant.step(cmd.port_pct(), cmd.starboard_pct(), cmd.vertical_pct(), DT);
        worst = worst.max(rov_control::angle::wrap_deg_180(plant.heading_deg() - 0.0).abs());
    }
    assert!(
        first_yaw.is_some_and(|d| d > 0.0),
        "first turn to starboard: {first_yaw:?}"
    );
    assert!(worst < 3.0, "stayed near north: {worst}");
    assert!(rov_control::angle::wrap_deg_180(plant.heading_deg() - 1.0).abs() < 1.0);
}
