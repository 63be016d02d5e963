//! Generator independence: hidden effects from a truth generator that shares nothing with
//! `tests/common`, so that passing is not a matter of having been tuned to one generator.
//!
//! | | tests/common | here |
//! |---|---|---|
//! | base parameters | model3 loaded as a model, ±20 % uniform (seeded RNG) on thrust, damping, added mass, CG height | model3 parsed from its parameter file, ±25 % from a hash pattern on thrust, damping (incl. roll/pitch quadratic), added mass, rigid-body inertia and CG height; surge drag at nominal |
//! | schedule | 6 + 3 min, shuffled steps of 12 s | the paper's short experiments (`rov_sim::experiments`: 42–62 s each), three for training, two held out, each starting at its own heading |
//! | sensors | Pro 4 noise and quantisation, four channels | other noise levels, 200 Hz simulation; all twelve channels (the paper data) or the Pro 4's four |
//! | effects | its own wrapper model | reverse thrust in the thrust maps' reverse pairs, moment arm in the thruster position, a propeller-speed lag in a wrapper of its own, a tether at its own attachment point (above and behind the CO) through the simulator's external-force hook |
//!
//! Cases: (a) vertical reverse weakness alone, (b) vertical-thruster moment arm alone,
//! (c) both with the horizontal reverse weakness (the `topside sim paper` truth),
//! (d) no effect (twelve and four channels), (e) a heading-channel effect (thruster lag),
//! (f) a tether, (g) a lag outside the catalog's form (on the force) — no wrong answer,
//! (h) a real depth-sensor drift with the heave velocity measured (the kinematic check
//! must confirm it, as it must refuse the drift the paper truth's dynamics suggest).

use nalgebra::Vector3;
use rov_dynamics::Vector6;
use rov_dynamics::models::{
    Channel, InitialConditions, Model3, Model3Params, ModelState, ThrusterForces, VehicleModel,
};
use rov_dynamics::process::CurrentSample;
use rov_dynamics::thrusters::{ThrustMap, ThrustPct, ThrusterGeometry};
use rov_lab::diagnose::{DiagnoseOptions, Diagnosis, diagnose};
use rov_lab::{BaseKind, LabModel, Run};
use rov_sim::{SimConfig, Simulator, TetherForce, run_schedule_on};
use rov_types::measurement::MeasurementSeries;

/// What the truth hides.
#[derive(Debug, Clone, Copy, Default)]
struct Hidden {
    /// Reverse/forward ratio of the horizontal thrusters (1 = none).
    reverse_horizontal: Option<f64>,
    /// Reverse/forward ratio of the vertical thruster.
    reverse_vertical: Option<f64>,
    /// Vertical thruster forward of the CO, m.
    arm_x_m: Option<f64>,
    /// First-order lag on each propeller's speed (thrust from the map of the lagged
    /// speed, ∝ n|n|), s.
    speed_lag_s: Option<f64>,
    /// First-order lag on each thruster's force, s.
    force_lag_s: Option<f64>,
    /// Tether pull (N) towards an azimuth (deg), attached at a point of its own.
    tether: Option<(f64, f64)>,
    /// Drift of the depth reading, cm/min (from each run's start).
    depth_drift_cm_per_min: Option<f64>,
}

/// A number in [−1, 1] from a seed and an index (SplitMix64 finaliser): the perturbation
/// pattern, deliberately unlike the uniform RNG stream of `tests/common`.
fn pattern(seed: u64, i: u64) -> f64 {
    let mut z = seed
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add(i.wrapping_mul(0xBF58_476D_1CE4_E5B9));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
}

/// model3's parameter file, perturbed ±25 % in the hash pattern of `seed`.
fn perturbed_params(seed: u64) -> Model3Params {
    let text = rov_dynamics::models::default_model_text("model3").unwrap();
    let pf = rov_types::ParamFile::parse(text, "model3.toml", true).unwrap();
    let mut p = Model3Params::from_params(&pf).unwrap();

    let mut i = 0u64;
    let mut f = |x: f64| {
        i += 1;
        x * (1.0 + 0.25 * pattern(seed, i))
    };
    for t in [
        &mut p.thrusters.port,
        &mut p.thrusters.starboard,
        &mut p.thrusters.vertical,
    ] {
        if let ThrustMap::Quadratic(q) = &mut t.map {
            q.forward.linear_n = f(q.forward.linear_n);
            q.forward.quadratic_n = f(q.forward.quadratic_n);
            q.reverse = q.forward;
        }
    }
    for k in 1..6 {
        p.process.damping.linear[(k, k)] = f(p.process.damping.linear[(k, k)]);
        p.process.damping.quadratic[k] = f(p.process.damping.quadratic[k]);
        p.process.added_mass[(k, k)] = f(p.process.added_mass[(k, k)]);
    }
    for k in 0..3 {
        let v = p.process.rigid_body.inertia_cg_kgm2[(k, k)];
        p.process.rigid_body.inertia_cg_kgm2[(k, k)] =
            v * (1.0 + 0.1 * pattern(seed, 100 + k as u64));
    }
    let zg = f(p.process.rigid_body.cg_from_co_m.z);
    p.process.rigid_body.cg_from_co_m.z = zg;
    p.process.hydrostatics.cg_from_co_m.z = zg;
    p
}

/// model3 whose propellers spin up and down with a first-order lag: the normalised speed
/// n of each follows the command, ṅ = (u − n)/τ, and the thrust is the map's at n.
#[derive(Debug, Clone)]
struct SpeedLag {
    plant: Model3,
    tau_s: f64,
}

impl VehicleModel for SpeedLag {
    fn name(&self) -> &str {
        "speed-lag truth"
    }
    fn predicts(&self, ch: Channel) -> bool {
        self.plant.predicts(ch)
    }
    fn thruster_forces(&self, _cmd: &ThrustPct, state: &ModelState) -> ThrusterForces {
        let n = ThrustPct::new(state.extra[0], state.extra[1], state.extra[2]);
        self.plant.thruster_forces(&n, state)
    }
    fn generalized_force(&self, forces: &ThrusterForces, state: &ModelState) -> Vector6 {
        self.plant.generalized_force(forces, state)
    }
    fn dynamics(&self, state: &ModelState, tau: &Vector6, current: &CurrentSample) -> ModelState {
        self.plant.dynamics(state, tau, current)
    }
    fn n_extra_states(&self) -> usize {
        3
    }
    fn extra_dynamics(&self, _t: f64, state: &ModelState, cmd: &ThrustPct, d: &mut ModelState) {
        for (i, u) in [cmd.port, cmd.starboard, cmd.vertical]
            .into_iter()
            .enumerate()
        {
            d.extra[i] = (u - state.extra[i]) / self.tau_s;
        }
    }
    fn initial_state(&self, ic: &InitialConditions) -> ModelState {
        self.plant.initial_state(ic)
    }
    fn clone_box(&self) -> Box<dyn VehicleModel> {
        Box::new(self.clone())
    }
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}

/// model3 whose thrusters deliver their force through a first-order lag on the force.
#[derive(Debug, Clone)]
struct ForceLag {
    plant: Model3,
    tau_s: f64,
}

impl VehicleModel for ForceLag {
    fn name(&self) -> &str {
        "force-lag truth"
    }
    fn predicts(&self, ch: Channel) -> bool {
        self.plant.predicts(ch)
    }
    fn thruster_forces(&self, _cmd: &ThrustPct, state: &ModelState) -> ThrusterForces {
        ThrusterForces {
            port_n: state.extra[0],
            starboard_n: state.extra[1],
            vertical_n: state.extra[2],
        }
    }
    fn generalized_force(&self, forces: &ThrusterForces, state: &ModelState) -> Vector6 {
        self.plant.generalized_force(forces, state)
    }
    fn dynamics(&self, state: &ModelState, tau: &Vector6, current: &CurrentSample) -> ModelState {
        self.plant.dynamics(state, tau, current)
    }
    fn n_extra_states(&self) -> usize {
        3
    }
    fn extra_dynamics(&self, _t: f64, state: &ModelState, cmd: &ThrustPct, d: &mut ModelState) {
        let target = self.plant.thruster_forces(cmd, state);
        for (i, f) in [target.port_n, target.starboard_n, target.vertical_n]
            .into_iter()
            .enumerate()
        {
            d.extra[i] = (f - state.extra[i]) / self.tau_s;
        }
    }
    fn initial_state(&self, ic: &InitialConditions) -> ModelState {
        self.plant.initial_state(ic)
    }
    fn clone_box(&self) -> Box<dyn VehicleModel> {
        Box::new(self.clone())
    }
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}

fn with_reverse(map: &mut ThrustMap, ratio: f64) {
    if let ThrustMap::Quadratic(q) = map {
        q.reverse.linear_n = q.forward.linear_n * ratio;
        q.reverse.quadratic_n = q.forward.quadratic_n * ratio;
    }
}

fn truth(seed: u64, h: &Hidden) -> Box<dyn VehicleModel> {
    let mut p = perturbed_params(seed);
    if let Some(r) = h.reverse_horizontal {
        with_reverse(&mut p.thrusters.port.map, r);
        with_reverse(&mut p.thrusters.starboard.map, r);
    }
    if let Some(r) = h.reverse_vertical {
        with_reverse(&mut p.thrusters.vertical.map, r);
    }
    if let Some(x) = h.arm_x_m {
        let g = p.thrusters.vertical.geometry;
        let mut pos = g.position_m();
        pos.x = x;
        p.thrusters.vertical.geometry = ThrusterGeometry::new(pos, g.direction()).unwrap();
    }
    let plant = Model3::new(p).unwrap();
    match (h.speed_lag_s, h.force_lag_s) {
        (Some(tau_s), _) => Box::new(SpeedLag { plant, tau_s }),
        (None, Some(tau_s)) => Box::new(ForceLag { plant, tau_s }),
        (None, None) => Box::new(plant),
    }
}

/// Sensors unlike both the Pro 4 defaults and `tests/common`.
fn sensors(cfg: &mut SimConfig) {
    cfg.sensors.pressure.noise_std_mbar = 1.0;
    cfg.sensors.attitude.heading_noise_std_deg = 0.4;
    cfg.sensors.attitude.pitch_noise_std_deg = 0.25;
    cfg.sensors.attitude.roll_noise_std_deg = 0.25;
    cfg.sensors.imu.gyro_noise_std_radps = 0.003;
    cfg.sensors.dvl.noise_std_mps = 0.015;
    cfg.sensors.transponder.noise_std_m = 0.3;
}

/// Training (heave steps, yaw steps, combined) and held-out (heave ±60, yaw ±60) runs.
fn runs(seed: u64, h: &Hidden, four_channels: bool) -> (Vec<Run>, Vec<Run>) {
    let model = truth(seed, h);
    let exps = rov_sim::experiments().unwrap();
    let mut train = Vec::new();
    let mut val = Vec::new();
    for (i, exp) in exps.iter().enumerate() {
        let mut cfg = SimConfig::with_model(model.clone_box());
        cfg.step_s = 0.005;
        sensors(&mut cfg);
        let heading = (37.0 + 113.0 * i as f64) % 360.0;
        cfg.initial = InitialConditions::at_rest(3.0 + 0.4 * i as f64, heading);
        let sensor_cfg = cfg.sensors;
        let mut sim =
            Simulator::new(cfg, seed.wrapping_mul(31).wrapping_add(i as u64 * 977)).unwrap();
        if let Some((force, az)) = h.tether {
            let a = f64::to_radians(az);
            sim.set_external_force(Some(Box::new(TetherForce {
                force_ned_n: Vector3::new(force * a.cos(), force * a.sin(), 0.0),
                attach_body_m: Vector3::new(-0.16, 0.0, -0.04),
            })));
        }
        let mut s: MeasurementSeries =
            run_schedule_on(&mut sim, &sensor_cfg, &exp.schedule, 0.05).unwrap();
        if let Some(d) = h.depth_drift_cm_per_min {
            let t0 = s.rows.first().map_or(0.0, |r| r.time_s);
            for r in &mut s.rows {
                r.depth_m += d / 6000.0 * (r.time_s - t0);
            }
        }
        if four_channels {
            s.present = [false; 8];
            for r in &mut s.rows {
                r.optional = [None; 8];
            }
        }
        let run = Run::from_series(&s, exp.name).unwrap();
        if exp.name.ends_with("_60") && exp.name != "combined_60" {
            val.push(run);
        } else {
            train.push(run);
        }
    }
    (train, val)
}

fn diagnosed(seed: u64, h: Hidden, four_channels: bool) -> Diagnosis {
    let (train, val) = runs(seed, &h, four_channels);
    assert_eq!((train.len(), val.len()), (3, 2));
    let m = LabModel::default_base(BaseKind::Model3).unwrap();
    let d = diagnose(
        &m,
        "model3",
        &train,
        &val,
        &DiagnoseOptions {
            threads: 1,
            ..Default::default()
        },
    )
    .unwrap();
    eprintln!(
        "{h:?} ({} channels): {}",
        if four_channels { 4 } else { 12 },
        d.summary
    );
    for (ch, b) in &d.baseline {
        eprintln!(
            "  baseline {ch}: RMSE {:.4} (free run {:.4}), noise {:.4}",
            b.rmse_shooting, b.rmse_free_run, b.noise
        );
    }
    for f in d.findings.iter().take(4) {
        eprintln!(
            "  {} {:?} score {:.1} params {:?} reductions ({}) {:?}: {}",
            f.effect,
            f.status,
            f.score,
            f.params
                .iter()
                .map(|(k, p)| format!("{k}={:.3}", p.value))
                .collect::<Vec<_>>(),
            f.view,
            f.validation_rmse_reduction_pct
                .iter()
                .map(|(k, v)| format!("{k} {v:.0}"))
                .collect::<Vec<_>>(),
            f.explanation
        );
    }
    d
}

fn assert_first(d: &Diagnosis, effect: &str) {
    let f = &d.findings[0];
    assert_eq!(f.effect, effect, "{}: {}", d.summary, f.explanation);
    assert!(f.significant, "{}", f.explanation);
}

/// One hidden effect found: ranked first and significant, the held-out RMSE of `channel`
/// down by ≥ 30 %, and its parameter `key` within 35 % of `truth` (in the reported unit).
fn assert_found_alone(d: &Diagnosis, effect: &str, channel: &str, key: &str, truth: f64) {
    assert_first(d, effect);
    let cut = d.findings[0].validation_rmse_reduction_pct[channel];
    assert!(cut >= 30.0, "{effect}: {channel} cut {cut} %");
    let v = param(d, effect, key);
    assert!(
        (v - truth).abs() <= 0.35 * truth.abs(),
        "{effect}: {key} = {v}, truth {truth}"
    );
}

fn param(d: &Diagnosis, effect: &str, key: &str) -> f64 {
    d.findings
        .iter()
        .find(|f| f.effect == effect)
        .and_then(|f| f.params.get(key))
        .map(|p| p.value)
        .unwrap_or(f64::NAN)
}

#[test]
fn a_vertical_reverse_weakness_alone() {
    let d = diagnosed(
        3,
        Hidden {
            reverse_vertical: Some(0.6),
            ..Default::default()
        },
        true,
    );
    assert_found_alone(
        &d,
        "thrust-asymmetry",
        "depth",
        "reverse_ratio_vertical",
        0.6,
    );
}

#[test]
fn b_vertical_thruster_moment_arm_alone() {
    let d = diagnosed(
        4,
        Hidden {
            arm_x_m: Some(-0.012),
            ..Default::default()
        },
        false,
    );
    // The arm is reported in mm.
    assert_found_alone(
        &d,
        "thruster-moment-arm",
        "pitch",
        "vertical_arm_x_m",
        -12.0,
    );
}

#[test]
fn c_reverse_weakness_and_moment_arm_together_the_paper_truth() {
    let d = diagnosed(
        5,
        Hidden {
            reverse_horizontal: Some(0.39),
            reverse_vertical: Some(0.63),
            arm_x_m: Some(0.010),
            ..Default::default()
        },
        false,
    );
    let keys: Vec<&str> = d.accepted.iter().map(|e| e.key()).collect();
    assert!(
        keys.len() >= 2
            && keys[..2].contains(&"thrust-asymmetry")
            && keys[..2].contains(&"thruster-moment-arm"),
        "{keys:?}"
    );
    assert!(!keys.contains(&"depth-sensor-drift"), "{keys:?}");
    assert!(d.findings[0].significant && d.findings[1].significant);
    let r = param(&d, "thrust-asymmetry", "reverse_ratio_vertical");
    assert!(
        (r - 0.63).abs() <= 0.35 * 0.63,
        "vertical reverse ratio {r}"
    );
    for side in ["port", "starboard"] {
        let r = param(&d, "thrust-asymmetry", &format!("reverse_ratio_{side}"));
        assert!((r - 0.39).abs() <= 0.35 * 0.39, "{side} reverse ratio {r}");
    }
    let x = param(&d, "thruster-moment-arm", "vertical_arm_x_m");
    assert!((x - 10.0).abs() <= 3.5, "arm {x} mm");
}

#[test]
fn d_effect_free_reports_nothing() {
    for (seed, four) in [(6, false), (7, true)] {
        let d = diagnosed(seed, Hidden::default(), four);
        assert!(d.accepted.is_empty(), "seed {seed}: {}", d.summary);
        assert!(d.findings.iter().all(|f| !f.significant));
    }
}

#[test]
fn e_heading_channel_thruster_lag() {
    let d = diagnosed(
        8,
        Hidden {
            speed_lag_s: Some(0.25),
            ..Default::default()
        },
        true,
    );
    assert_found_alone(&d, "thruster-lag", "heading", "lag_time_constant_s", 0.25);
}

/// A lag on the thrust *force* (a force that also decays slowly at switch-off, unlike a
/// propeller whose thrust ∝ n|n| falls faster than its speed) is outside what the lab's
/// lag represents: the honest outcome is that lag or nothing, not a confident wrong effect.
#[test]
fn g_force_lag_outside_the_catalog_gives_no_wrong_answer() {
    let d = diagnosed(
        8,
        Hidden {
            force_lag_s: Some(0.3),
            ..Default::default()
        },
        true,
    );
    assert!(
        d.accepted.is_empty() || d.accepted[0].key() == "thruster-lag",
        "{}",
        d.summary
    );
}

#[test]
fn f_heading_channel_tether() {
    let d = diagnosed(
        9,
        Hidden {
            tether: Some((0.5, 200.0)),
            ..Default::default()
        },
        true,
    );
    assert_first(&d, "tether");
    assert!(d.findings[0].validation_rmse_reduction_pct["heading"] >= 30.0);
}

#[test]
fn h_depth_sensor_drift_confirmed_by_the_measured_heave() {
    let d = diagnosed(
        10,
        Hidden {
            depth_drift_cm_per_min: Some(12.0),
            ..Default::default()
        },
        false,
    );
    assert_first(&d, "depth-sensor-drift");
    let r = param(&d, "depth-sensor-drift", "depth_drift_mps");
    assert!((r - 12.0).abs() <= 0.35 * 12.0, "drift {r} cm/min");
}

/// The `topside sim paper` truth exactly (model3 as shipped, reverse/forward ratios 0.39
/// horizontal and 0.63 vertical, the vertical thrust line 10 mm forward; default sensors,
/// seed 1, at rest 2 m deep heading 90°; all twelve channels), diagnosed as in the
/// report that found a 60 cm/min depth-sensor drift: heave steps, yaw steps and the
/// combined run for training, heave ±60 and yaw ±60 held out.
#[test]
fn paper_truth_as_generated_by_topside() {
    let text = rov_dynamics::models::default_model_text("model3").unwrap();
    let pf = rov_types::ParamFile::parse(text, "model3.toml", true).unwrap();
    let mut p = Model3Params::from_params(&pf).unwrap();
    with_reverse(&mut p.thrusters.port.map, 0.39);
    with_reverse(&mut p.thrusters.starboard.map, 0.39);
    with_reverse(&mut p.thrusters.vertical.map, 0.63);
    let g = p.thrusters.vertical.geometry;
    let mut pos = g.position_m();
    pos.x = 0.010;
    p.thrusters.vertical.geometry = ThrusterGeometry::new(pos, g.direction()).unwrap();
    let truth = Model3::new(p).unwrap();
    let (mut train, mut val) = (Vec::new(), Vec::new());
    for exp in rov_sim::experiments().unwrap() {
        let mut cfg = SimConfig::with_model(Box::new(truth.clone()));
        cfg.initial = InitialConditions::at_rest(2.0, 90.0);
        let s = rov_sim::run_schedule(cfg, 1, &exp.schedule, 0.05).unwrap();
        let run = Run::from_series(&s, exp.name).unwrap();
        if exp.name == "heave_60" || exp.name == "yaw_60" {
            val.push(run);
        } else {
            train.push(run);
        }
    }
    let m = LabModel::default_base(BaseKind::Model3).unwrap();
    let d = diagnose(
        &m,
        "model3",
        &train,
        &val,
        &DiagnoseOptions {
            threads: 1,
            ..Default::default()
        },
    )
    .unwrap();
    eprintln!("paper truth: {}", d.summary);
    for f in d.findings.iter().take(3) {
        eprintln!(
            "  {} {:?} {:?}: {}",
            f.effect,
            f.status,
            f.params
                .iter()
                .map(|(k, p)| format!("{k}={:.3}", p.value))
                .collect::<Vec<_>>(),
            f.explanation
        );
    }
    let keys: Vec<&str> = d.accepted.iter().map(|e| e.key()).collect();
    assert_eq!(
        keys,
        ["thrust-asymmetry", "thruster-moment-arm"],
        "{}",
        d.summary
    );
    let r = param(&d, "thrust-asymmetry", "reverse_ratio_vertical");
    assert!((r - 0.63).abs() <= 0.1 * 0.63, "vertical reverse ratio {r}");
    for side in ["port", "starboard"] {
        let r = param(&d, "thrust-asymmetry", &format!("reverse_ratio_{side}"));
        assert!((r - 0.39).abs() <= 0.2 * 0.39, "{side} reverse ratio {r}");
    }
    let x = param(&d, "thruster-moment-arm", "vertical_arm_x_m");
    assert!((x - 10.0).abs() <= 1.0, "arm {x} mm");
    assert!(
        d.findings
            .iter()
            .all(|f| f.effect != "depth-sensor-drift" || !f.significant)
    );
}
