//! `topside hold`: the station's control loop closed through the mock link and the
//! simulated vehicle, on virtual time.
//!
//! * Truth: the 6-DOF simulator with model3's nominal parameters (Munk moments zeroed, the
//!   documented default of `config/models/model3.toml`), sensor noise on, seeded.
//! * The selected model supplies only the feedforward, so model1 and model2 control a
//!   vehicle that differs from them.
//! * `current`: a constant 0.3 m/s current flowing toward north. `tether`: a 0.8 N
//!   horizontal pull toward azimuth 135°, fixed in the earth frame, applied at
//!   (−0.20, 0, −0.08) m from CO.
//! * Sequence: the link connects (ping → register dump → control), the station arms as
//!   soon as the link allows (1 s of healthy link), engages both holds with the targets,
//!   and from that instant (t = 0 of the metrics) runs for `duration_s`.
//! * Metrics use the true state (see [`crate::metrics`]).
//! * With a tracking profile ([`rov_control::TrackingProfile`]) the station types the
//!   profile's smooth reference every tick as a moving setpoint, starting from the
//!   targets; the run is the whole profile plus `duration_s`. The report then adds
//!   `tracking_rmse` (true state against the profile's reference over the profile), and
//!   the step metrics describe the profile's final step (from its start to the end).

use crate::sim_link::{SimApp, SimLink};
use nalgebra::Vector3;
use rov_control::{ControlConfig, ModeCommand, ModelChoice, ModelSet, TrackingProfile};
use rov_driver::{Link, LinkConfig, LinkEvent};
use rov_dynamics::InitialConditions;
use rov_dynamics::current::CurrentModel;
use rov_sim::{SimConfig, Simulator, TetherForce};
use rov_types::angle::wrap_deg_360;
use rov_vehicle::{Vehicle, VehicleConfig};
use serde::Serialize;

use crate::core::{StationCommand, StationCore};
use crate::metrics::{StepMetrics, rmse_between, step_metrics};

/// Control period, µs (50 Hz).
pub const TICK_US: u64 = 20_000;

/// A disturbance acting on the simulated vehicle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Disturbance {
    /// Still water, no tether.
    #[default]
    None,
    /// A constant 0.3 m/s current flowing toward north.
    Current,
    /// A 0.8 N horizontal pull toward azimuth 135°, earth-fixed, at (−0.20, 0, −0.08) m.
    Tether,
}

/// What to run.
#[derive(Debug, Clone, PartialEq)]
pub struct HoldSpec {
    /// Feedforward model (when `autopilot_model` is `None`).
    pub model: ModelChoice,
    /// Any model's plant for the autopilot (feedforward, observer, feedback), e.g. from
    /// a model file the lab saved; `None`: `model` from the shipped set.
    pub autopilot_model: Option<AutopilotModel>,
    /// Depth target, m.
    pub depth_m: f64,
    /// Heading target, degrees.
    pub heading_deg: f64,
    /// Run length after engagement, s (with a profile: extra hold time after it).
    pub duration_s: f64,
    /// A tracking profile flown from the targets instead of one step.
    pub profile: Option<TrackingProfile>,
    /// Starting depth, m.
    pub start_depth_m: f64,
    /// Starting heading, degrees.
    pub start_heading_deg: f64,
    /// Disturbance.
    pub disturbance: Disturbance,
    /// Feedforward on.
    pub feedforward: bool,
    /// Observer on.
    pub observer: bool,
    /// Seed of the sensor noise.
    pub seed: u64,
    /// Control configuration (gains, limits, observer noise).
    pub control: ControlConfig,
    /// The simulated vehicle's dynamics: `None` for model3 as configured, or another
    /// model (for example one the model lab extended and saved).
    pub vehicle: Option<VehicleDynamics>,
}

/// A plant for the autopilot with the label it is reported under.
#[derive(Debug, Clone, PartialEq)]
pub struct AutopilotModel {
    /// Where the model came from (a file name).
    pub label: String,
    /// The plant.
    pub plant: rov_control::PlantModel,
}

impl AutopilotModel {
    /// The autopilot plant of any model, or an error naming the model when it cannot be
    /// reduced to the autopilot's axes (a vehicle-file base) or its plant is invalid.
    pub fn from_vehicle_model(
        label: &str,
        model: &dyn rov_dynamics::VehicleModel,
    ) -> Result<Self, HoldError> {
        let plant = rov_control::PlantModel::from_vehicle_model(model).ok_or_else(|| {
            HoldError::Invalid(format!(
                "{label}: this model has no heave/yaw plant for the autopilot (a vehicle \
                 file with its own thruster layout); use a model1, model2 or model3 base"
            ))
        })?;
        let mut plant = plant;
        plant.name = label.to_string();
        plant.validate()?;
        Ok(Self {
            label: label.to_string(),
            plant,
        })
    }
}

/// A vehicle model for the simulated vehicle of a hold run, with a label for reports.
#[derive(Debug, Clone)]
pub struct VehicleDynamics {
    /// Where the model came from (a file name).
    pub label: String,
    /// The model.
    pub model: Box<dyn rov_dynamics::VehicleModel>,
}

impl PartialEq for VehicleDynamics {
    fn eq(&self, other: &Self) -> bool {
        self.label == other.label
    }
}

impl HoldSpec {
    /// The default scenario: start 2 m shallower and 90° off.
    pub fn step(model: ModelChoice, depth_m: f64, heading_deg: f64, duration_s: f64) -> Self {
        Self {
            model,
            autopilot_model: None,
            depth_m,
            heading_deg,
            duration_s,
            profile: None,
            start_depth_m: depth_m - 2.0,
            start_heading_deg: wrap_deg_360(heading_deg - 90.0),
            disturbance: Disturbance::None,
            feedforward: true,
            observer: true,
            seed: 1,
            control: ControlConfig::default(),
            vehicle: None,
        }
    }
}

/// Depth metrics in the CLI's JSON layout.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DepthReport {
    /// Settling time, s.
    pub settle_s: Option<f64>,
    /// Overshoot, % of the step.
    pub overshoot_pct: f64,
    /// |mean error| over the last 10 s, m.
    pub steady_error_m: f64,
    /// RMSE over the run, m.
    pub rmse_m: f64,
}

/// Heading metrics in the CLI's JSON layout.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct HeadingReport {
    /// Settling time, s.
    pub settle_s: Option<f64>,
    /// Overshoot, degrees.
    pub overshoot_deg: f64,
    /// |mean error| over the last 10 s, degrees.
    pub steady_error_deg: f64,
    /// RMSE over the run, degrees.
    pub rmse_deg: f64,
}

/// Thrust statistics.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ThrustReport {
    /// Share of ticks with any thruster at its ±100 % limit, %.
    pub saturated_pct: f64,
}

/// Observer accuracy against the truth.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ObserverReport {
    /// Depth estimate RMSE, m.
    pub depth_rmse_m: f64,
    /// Heading estimate RMSE, degrees.
    pub heading_rmse_deg: f64,
}

/// Tracking error over a profile: RMSE of the true state against the profile's smooth
/// reference, from engagement to the end of the profile.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrackingReport {
    /// Depth RMSE, m.
    pub depth_m: f64,
    /// Heading RMSE (wrapped errors), degrees.
    pub heading_deg: f64,
}

/// The result of a hold run, serialised exactly as `topside hold --json` prints it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HoldReport {
    /// Depth channel.
    pub depth: DepthReport,
    /// Heading channel.
    pub heading: HeadingReport,
    /// Thrust.
    pub thrust: ThrustReport,
    /// Observer.
    pub observer: ObserverReport,
    /// Tracking over the profile (only with a profile; absent from the JSON otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tracking_rmse: Option<TrackingReport>,
}

/// Time series of a hold run (for tests, plots and the RMSE of raw measurements).
#[derive(Debug, Clone, Default)]
pub struct HoldTrace {
    /// Time since engagement, s.
    pub t_s: Vec<f64>,
    /// True depth, m.
    pub depth_true_m: Vec<f64>,
    /// True heading, degrees.
    pub heading_true_deg: Vec<f64>,
    /// Measured depth (latest telemetry), m.
    pub depth_meas_m: Vec<f64>,
    /// Measured heading, degrees.
    pub heading_meas_deg: Vec<f64>,
    /// Observer depth estimate, m.
    pub depth_est_m: Vec<f64>,
    /// Observer heading estimate, degrees.
    pub heading_est_deg: Vec<f64>,
    /// Reference depth (setpoint), m.
    pub depth_ref_m: Vec<f64>,
    /// Reference heading (setpoint), degrees.
    pub heading_ref_deg: Vec<f64>,
    /// Commanded thrust [port, starboard, vertical], %.
    pub thrust_pct: Vec<[f64; 3]>,
    /// Reference-model depth (the smoothed trajectory the loop tracks), m.
    pub depth_traj_m: Vec<f64>,
    /// Reference-model heading, degrees.
    pub heading_traj_deg: Vec<f64>,
    /// Observer depth-channel bias, N (positive down).
    pub depth_bias_n: Vec<f64>,
    /// Observer heading-channel bias, N·m (positive to starboard).
    pub heading_bias_nm: Vec<f64>,
}

/// Why a hold run failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum HoldError {
    /// Bad input.
    #[error("invalid hold request: {0}")]
    Invalid(String),
    /// The simulator failed.
    #[error("simulator: {0}")]
    Sim(#[from] rov_sim::SimError),
    /// The vehicle failed.
    #[error("vehicle: {0}")]
    Vehicle(#[from] rov_vehicle::VehicleError),
    /// The controller refused its configuration or a command.
    #[error("control: {0}")]
    Control(#[from] rov_control::ControlError),
    /// The station refused a command.
    #[error("station: {0}")]
    Command(#[from] crate::core::CommandError),
    /// The link configuration is invalid.
    #[error("link: {0}")]
    Link(#[from] rov_driver::ConfigError),
    /// The link never became armable.
    #[error("the link did not come up within {0} s of virtual time")]
    NoLink(f64),
    /// A model file failed to load.
    #[error("model: {0}")]
    Model(#[from] rov_types::ConfigError),
}

/// A custom step applied each tick after engagement (for moving-reference tests):
/// returns the setpoints to command at time `t_s` since engagement, or None to leave them.
pub type ReferenceSchedule = dyn FnMut(f64) -> Option<(f64, f64)>;

struct App<'a> {
    core: StationCore,
    spec: &'a HoldSpec,
    engaged_us: Option<u64>,
    end_us: u64,
    trace: HoldTrace,
    saturated_ticks: u64,
    ticks_after: u64,
    error: Option<HoldError>,
    schedule: Option<&'a mut ReferenceSchedule>,
}

impl SimApp for App<'_> {
    fn on_event(&mut self, link: &mut Link, _vehicle: &Vehicle, event: LinkEvent, _now_us: u64) {
        self.core.on_event(link, &event);
    }

    fn on_tick(&mut self, link: &mut Link, vehicle: &mut Vehicle, now_us: u64) {
        if self.error.is_some() {
            return;
        }
        // Arming is refused until the link is up: tried again each tick.
        if self.engaged_us.is_none() && link.arm(now_us).is_ok() {
            if let Err(e) = self.engage(link, now_us) {
                self.error = Some(e);
                return;
            }
            self.engaged_us = Some(now_us);
            let run_s = self.spec.duration_s + self.spec.profile.map_or(0.0, |p| p.duration_s());
            self.end_us = now_us + (run_s * 1e6).round() as u64;
        }
        if let (Some(t0), Some(schedule)) = (self.engaged_us, self.schedule.as_mut()) {
            let t = (now_us.saturating_sub(t0)) as f64 * 1e-6;
            if let Some((d, h)) = schedule(t) {
                let r1 = self.core.command(
                    link,
                    StationCommand::Mode(ModeCommand::SetDepth { depth_m: d }),
                    now_us,
                );
                let r2 = self.core.command(
                    link,
                    StationCommand::Mode(ModeCommand::SetHeading { heading_deg: h }),
                    now_us,
                );
                if let Err(e) = r1.and(r2) {
                    self.error = Some(e.into());
                }
            }
        }
        let out = self.core.tick(link, now_us);
        let Some(t0) = self.engaged_us else { return };
        let truth = vehicle.sim().truth();
        let eta = truth.state.eta;
        let d = &out.diagnostics;
        let meas = self.core.last_telemetry();
        self.trace.t_s.push((now_us - t0) as f64 * 1e-6);
        self.trace.depth_true_m.push(eta.z);
        self.trace
            .heading_true_deg
            .push(wrap_deg_360(eta.b.to_degrees()));
        self.trace
            .depth_meas_m
            .push(meas.map_or(f64::NAN, |m| m.depth_m));
        self.trace
            .heading_meas_deg
            .push(meas.map_or(f64::NAN, |m| m.heading_deg));
        self.trace
            .depth_est_m
            .push(d.depth_estimate_m().unwrap_or(f64::NAN));
        self.trace
            .heading_est_deg
            .push(d.heading_estimate_deg().unwrap_or(f64::NAN));
        self.trace
            .depth_ref_m
            .push(d.depth_setpoint_m().unwrap_or(f64::NAN));
        self.trace
            .heading_ref_deg
            .push(d.heading_setpoint_deg().unwrap_or(f64::NAN));
        self.trace.depth_traj_m.push(d.depth.reference.pos);
        self.trace
            .heading_traj_deg
            .push(wrap_deg_360(d.heading.reference.pos.to_degrees()));
        self.trace
            .depth_bias_n
            .push(d.depth.estimate.map_or(f64::NAN, |e| e.bias));
        self.trace
            .heading_bias_nm
            .push(d.heading.estimate.map_or(f64::NAN, |e| e.bias));
        let c = out.command;
        let th = [c.port_pct(), c.starboard_pct(), c.vertical_pct()];
        self.trace.thrust_pct.push(th);
        self.ticks_after += 1;
        if th.iter().any(|x| x.abs() >= 99.5) {
            self.saturated_ticks += 1;
        }
    }
}

impl App<'_> {
    fn engage(&mut self, link: &mut Link, now_us: u64) -> Result<(), HoldError> {
        let s = self.spec;
        // A custom autopilot model was set before arming; selecting a shipped one would
        // replace it.
        let select = s
            .autopilot_model
            .is_none()
            .then_some(ModeCommand::SelectModel(s.model));
        for m in select.into_iter().chain([
            ModeCommand::SetFeedforward(s.feedforward),
            ModeCommand::SetDepth { depth_m: s.depth_m },
            ModeCommand::SetHeading {
                heading_deg: s.heading_deg,
            },
        ]) {
            self.core.command(link, StationCommand::Mode(m), now_us)?;
        }
        Ok(())
    }
}

/// Builds the simulated vehicle of a hold run.
fn build_vehicle(spec: &HoldSpec) -> Result<Vehicle, HoldError> {
    let mut cfg = match &spec.vehicle {
        Some(v) => SimConfig::with_model(v.model.clone()),
        None => SimConfig::default_model3()?,
    };
    cfg.initial = InitialConditions::at_rest(spec.start_depth_m, spec.start_heading_deg);
    if spec.disturbance == Disturbance::Current {
        cfg.current = CurrentModel::Constant {
            speed_mps: 0.3,
            vertical_angle_rad: 0.0,
            direction_rad: 0.0,
        };
    }
    let mut sim = Simulator::new(cfg, spec.seed)?;
    if spec.disturbance == Disturbance::Tether {
        let az = 135f64.to_radians();
        sim.set_external_force(Some(Box::new(TetherForce {
            force_ned_n: Vector3::new(0.8 * az.cos(), 0.8 * az.sin(), 0.0),
            attach_body_m: Vector3::new(-0.20, 0.0, -0.08),
        })));
    }
    Ok(Vehicle::new(VehicleConfig::default(), sim))
}

/// Runs a hold and returns its report and trace.
pub fn run_hold(spec: &HoldSpec) -> Result<(HoldReport, HoldTrace), HoldError> {
    run_hold_with(spec, None)
}

/// [`run_hold`] with a setpoint schedule applied after engagement (moving references).
pub fn run_hold_with(
    spec: &HoldSpec,
    schedule: Option<&mut ReferenceSchedule>,
) -> Result<(HoldReport, HoldTrace), HoldError> {
    let finite = [
        spec.depth_m,
        spec.heading_deg,
        spec.duration_s,
        spec.start_depth_m,
        spec.start_heading_deg,
    ];
    // With a profile the run is never empty, so no extra hold time is allowed.
    let min_duration_ok = if spec.profile.is_some() {
        spec.duration_s >= 0.0
    } else {
        spec.duration_s > 0.0
    };
    if finite.iter().any(|x| !x.is_finite()) || !min_duration_ok || spec.duration_s > 24.0 * 3600.0
    {
        return Err(HoldError::Invalid(format!(
            "targets, start and duration must be finite and the duration in (0, 86400] s \
             ([0, 86400] s after a profile): {spec:?}"
        )));
    }
    let deepest_m = spec.depth_m + spec.profile.map_or(0.0, |p| p.max_depth_offset_m());
    if !(0.0..=300.0).contains(&spec.depth_m)
        || !(0.0..=300.0).contains(&spec.start_depth_m)
        || deepest_m > 300.0
    {
        return Err(HoldError::Invalid(format!(
            "depths must lie in 0..=300 m (the Pro 4's rating; the profile goes {:.1} m below \
             --depth-m)",
            deepest_m - spec.depth_m
        )));
    }
    let mut profile_schedule = spec.profile.map(|p| {
        let (d0, h0) = (spec.depth_m, spec.heading_deg);
        move |t: f64| {
            let r = p.reference(t, d0, h0);
            Some((r.depth_m, r.heading_deg))
        }
    });
    let schedule: Option<&mut ReferenceSchedule> = match (schedule, profile_schedule.as_mut()) {
        (Some(_), Some(_)) => {
            return Err(HoldError::Invalid(
                "a profile and a custom setpoint schedule cannot be combined".into(),
            ));
        }
        (Some(s), None) => Some(s),
        (None, Some(p)) => Some(p),
        (None, None) => None,
    };
    let mut control = spec.control;
    control.observer_enabled = spec.observer;
    control.feedforward_model = spec.model;
    control.feedforward_enabled = spec.feedforward;
    let mut core = StationCore::new(control, ModelSet::load_default()?)?;
    if let Some(a) = &spec.autopilot_model {
        core.set_plant(&a.label, a.plant.clone())?;
    }
    let link = Link::new(LinkConfig::default())?;
    let vehicle = build_vehicle(spec)?;
    let mut sim = SimLink::new(link, vehicle, TICK_US);
    let mut app = App {
        core,
        spec,
        engaged_us: None,
        end_us: u64::MAX,
        trace: HoldTrace::default(),
        saturated_ticks: 0,
        ticks_after: 0,
        error: None,
        schedule,
    };
    // Bring the link up (at most 10 s of virtual time), then run to the end.
    let mut t_us = 0u64;
    while app.engaged_us.is_none() {
        t_us += 100_000;
        if t_us > 10_000_000 {
            return Err(HoldError::NoLink(10.0));
        }
        sim.run_until(t_us, &mut app)?;
        if let Some(e) = app.error.take() {
            return Err(e);
        }
    }
    sim.run_until(app.end_us, &mut app)?;
    if let Some(e) = app.error.take() {
        return Err(e);
    }
    let tr = app.trace;
    let depth_samples: Vec<(f64, f64)> = tr
        .t_s
        .iter()
        .copied()
        .zip(tr.depth_true_m.iter().copied())
        .collect();
    let heading_samples: Vec<(f64, f64)> = tr
        .t_s
        .iter()
        .copied()
        .zip(tr.heading_true_deg.iter().copied())
        .collect();
    // The step the metrics describe: the run's only step, or a profile's final step
    // (times from its start).
    let (step_t0, depth_from_to, heading_from_to) = match spec.profile {
        None => (
            0.0,
            (spec.start_depth_m, spec.depth_m),
            (spec.start_heading_deg, spec.heading_deg),
        ),
        Some(p) => {
            let t0 = p.final_step_t0_s();
            let before = p.reference(t0, spec.depth_m, spec.heading_deg);
            let after = p.reference(p.duration_s(), spec.depth_m, spec.heading_deg);
            (
                t0,
                (before.depth_m, after.depth_m),
                (before.heading_deg, after.heading_deg),
            )
        }
    };
    let from_step = |s: Vec<(f64, f64)>| -> Vec<(f64, f64)> {
        s.into_iter()
            .filter(|(t, _)| *t >= step_t0)
            .map(|(t, v)| (t - step_t0, v))
            .collect()
    };
    let dm: StepMetrics = step_metrics(
        &from_step(depth_samples),
        depth_from_to.0,
        depth_from_to.1,
        false,
        0.02,
    );
    let hm: StepMetrics = step_metrics(
        &from_step(heading_samples),
        heading_from_to.0,
        heading_from_to.1,
        true,
        1.0,
    );
    let tracking = spec
        .profile
        .map(|p| profile_tracking(p, spec, &tr.t_s, &tr.depth_true_m, &tr.heading_true_deg));
    let report = HoldReport {
        depth: DepthReport {
            settle_s: dm.settle_s,
            overshoot_pct: dm.overshoot,
            steady_error_m: dm.steady_error,
            rmse_m: dm.rmse,
        },
        heading: HeadingReport {
            settle_s: hm.settle_s,
            overshoot_deg: hm.overshoot,
            steady_error_deg: hm.steady_error,
            rmse_deg: hm.rmse,
        },
        thrust: ThrustReport {
            saturated_pct: if app.ticks_after == 0 {
                0.0
            } else {
                100.0 * app.saturated_ticks as f64 / app.ticks_after as f64
            },
        },
        observer: ObserverReport {
            depth_rmse_m: rmse_between(&tr.depth_est_m, &tr.depth_true_m, false),
            heading_rmse_deg: rmse_between(&tr.heading_est_deg, &tr.heading_true_deg, true),
        },
        tracking_rmse: tracking,
    };
    Ok((report, tr))
}

/// Tracking RMSE of the true state against a profile's smooth reference, over the
/// samples from engagement to the end of the profile.
fn profile_tracking(
    profile: TrackingProfile,
    spec: &HoldSpec,
    t_s: &[f64],
    depth_m: &[f64],
    heading_deg: &[f64],
) -> TrackingReport {
    let (mut d_ref, mut h_ref, mut d, mut h) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for ((t, dv), hv) in t_s.iter().zip(depth_m).zip(heading_deg) {
        if *t <= profile.duration_s() {
            let r = profile.reference(*t, spec.depth_m, spec.heading_deg);
            d_ref.push(r.depth_m);
            h_ref.push(r.heading_deg);
            d.push(*dv);
            h.push(*hv);
        }
    }
    TrackingReport {
        depth_m: rmse_between(&d, &d_ref, false),
        heading_deg: rmse_between(&h, &h_ref, true),
    }
}
