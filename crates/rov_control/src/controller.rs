//! One control tick: observer update → reference model → feedforward → PIDs →
//! allocation → output guard.
//!
//! The loop itself (50 Hz by default) runs in the station runtime; [`Controller::tick`]
//! is pure: time is an argument and nothing is logged. Every tick returns the guarded
//! [`ThrustCommand`], the targets for the vehicle's own auto modes, and diagnostics
//! (estimates, setpoints, reference, PID terms, fault flags).
//!
//! Timing of the observer input: the command returned by tick k is applied by the vehicle
//! until tick k+1, so tick k+1 first predicts over its dt with the force that command
//! produces, then updates with the new measurement.
//!
//! **Which model does what.** The *selected* model (model1, model2 or model3, switchable
//! at run time) supplies only the feedforward: its inverse dynamics of the reference's
//! velocity and acceleration, through its own inverted thrust map (linear G map for
//! model2, reverse coefficients where a model has them), give a feedforward command in
//! percent. The observer, the thrust-map inversion of the feedback and the force limits
//! use the *control plant model* ([`ControlConfig::plant_model`], default model3: the
//! seed-001 control plant model is derived from the 6-DOF process model), so the loop's
//! gain does not change when the feedforward model is switched. The feedback adds its
//! force to the force that the feedforward command produces and inverts the sum:
//! `u = map⁻¹(map(u_ff) + F_fb)`, which is exact superposition in force. With
//! `plant_model = feedforward model` this is the plain model-based design.
//!
//! **Any model.** [`Controller::set_plant`] replaces both with one custom plant (any
//! model's [`PlantModel`], e.g. a lab-extended model's, under a label): feedforward,
//! observer, feedback inversion and force limits then all use it, so a learned model
//! improves the estimate as well as the feedforward. Its thrust path is honoured: the
//! observer's input is the force of the *lagged* command (the lag's state is tracked
//! per thruster), the hold's whole demand gets a bounded lead `τ·du/dt`
//! ([`crate::feedforward::LAG_LEAD_MAX_PCT`]), the dead band is added to non-zero demands
//! and the vertical thruster's reaction torque is a known yaw load.

use crate::allocation::{Allocation, ThrustDemand, allocate_in_force};
use crate::angle::{wrap_2pi, wrap_pi};
use crate::config::{AxisConfig, ControlConfig, FeedforwardForce};
use crate::error::ControlError;
use crate::feedforward::{FeedforwardModel, ModelChoice, PlantModel};
use crate::guard::{GuardReport, OutputGuard, ThrustCommand};
use crate::observer::{ChannelEstimate, ChannelStats, KalmanChannel, Observer, SampleOutcome};
use crate::pid::{Pid, PidTerms};
use crate::pilot::{
    Axis, AxisMode, AxisState, ModeCommand, PilotInput, SurfaceTare, VehicleAutoTargets,
    check_tare, depth_m_from_mbar, depth_target_mbar, heading_target_deg, stick_to_pct,
};
use crate::reference::{ReferenceModel, ReferenceState};

/// Typed setpoints that follow each other within this time make a moving setpoint whose
/// rate is fed through the reference model (s).
pub const MOVING_SETPOINT_WINDOW_S: f64 = 0.25;

/// Time constant of the low-pass filter on differentiated raw samples (observer off), s.
const RAW_RATE_FILTER_S: f64 = 0.2;

/// Largest plausible heading sample magnitude, degrees; beyond it a sample is missing.
const HEADING_SANE_DEG: f64 = 1e5;
/// Largest plausible yaw rate sample, rad/s.
const YAW_RATE_SANE_RAD_S: f64 = 50.0;

/// The sensor values of one tick. `None` and NaN both mean "no sample".
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Measurements {
    /// Depth, m (positive down), e.g. from the pressure with the surface tare.
    pub depth_m: Option<f64>,
    /// Heading, degrees (increasing to starboard); any range, wrapped.
    pub heading_deg: Option<f64>,
    /// Heading rate ψ̇, rad/s (positive to starboard), if a gyro is available. This is the
    /// Euler-angle rate, equal to the body yaw rate r only when the vehicle is level; use
    /// [`heading_rate_from_body_rates`] to convert gyro rates (a pitched or rolled vehicle
    /// otherwise feeds the observer a biased rate).
    pub yaw_rate_rad_s: Option<f64>,
}

/// The heading (Euler yaw) rate from body rates and attitude (ZYX Euler angles):
/// `ψ̇ = (q·sin φ + r·cos φ) / cos θ`. `None` near θ = ±90° or for non-finite input.
pub fn heading_rate_from_body_rates(
    pitch_rate_rad_s: f64,
    yaw_rate_rad_s: f64,
    roll_rad: f64,
    pitch_rad: f64,
) -> Option<f64> {
    let (s_phi, c_phi) = roll_rad.sin_cos();
    let c_theta = pitch_rad.cos();
    let rate = (pitch_rate_rad_s * s_phi + yaw_rate_rad_s * c_phi) / c_theta;
    (c_theta.abs() > 1e-3 && rate.is_finite()).then_some(rate)
}

/// The three models the feedforward can switch between at run time.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelSet {
    /// Model1.
    pub model1: PlantModel,
    /// Model2.
    pub model2: PlantModel,
    /// Model3.
    pub model3: PlantModel,
}

impl ModelSet {
    /// The three models from the parameter files shipped in `config/models/` (through
    /// rov_dynamics' loaders).
    pub fn load_default() -> Result<Self, rov_types::ConfigError> {
        Ok(ModelSet {
            model1: PlantModel::load_default(ModelChoice::Model1)?,
            model2: PlantModel::load_default(ModelChoice::Model2)?,
            model3: PlantModel::load_default(ModelChoice::Model3)?,
        })
    }

    /// From three loaded rov_dynamics models (e.g. with parameter files other than the
    /// shipped ones); `None` if one is not of the expected kind.
    pub fn from_vehicle_models(
        model1: &dyn rov_dynamics::VehicleModel,
        model2: &dyn rov_dynamics::VehicleModel,
        model3: &dyn rov_dynamics::VehicleModel,
    ) -> Option<Self> {
        Some(ModelSet {
            model1: PlantModel::from_vehicle_model(model1)?,
            model2: PlantModel::from_vehicle_model(model2)?,
            model3: PlantModel::from_vehicle_model(model3)?,
        })
    }

    /// The model for a choice.
    pub fn get(&self, choice: ModelChoice) -> &PlantModel {
        match choice {
            ModelChoice::Model1 => &self.model1,
            ModelChoice::Model2 => &self.model2,
            ModelChoice::Model3 => &self.model3,
        }
    }

    /// Validates all three.
    pub fn validate(&self) -> Result<(), ControlError> {
        self.model1.validate()?;
        self.model2.validate()?;
        self.model3.validate()
    }
}

/// Diagnostics of one axis. Units: depth in m, m/s, m/s², N; heading in rad, rad/s,
/// rad/s², N·m (use the helpers on [`TickDiagnostics`] for degrees).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AxisDiagnostics {
    /// Mode and override state after this tick.
    pub state: AxisState,
    /// Held setpoint (Hold) or target (VehicleAuto), if any.
    pub setpoint: Option<f64>,
    /// Reference model output (position, velocity, acceleration).
    pub reference: ReferenceState,
    /// Observer estimate (None before the first valid sample).
    pub estimate: Option<ChannelEstimate>,
    /// Position and rate the PID used (observer or raw), if available.
    pub feedback: Option<(f64, f64)>,
    /// What the observer did with this tick's sample.
    pub sample: SampleOutcome,
    /// This tick's sample was non-finite or implausible (treated as missing).
    pub sample_invalid: bool,
    /// Time since the last usable sample, s.
    pub sample_age_s: f64,
    /// PID terms (zero while not holding).
    pub pid: PidTerms,
    /// Model feedforward as the force (N or N·m) its command produces according to the
    /// control plant model.
    pub feedforward: f64,
    /// Model feedforward command in % (vertical, or differential for heading), from the
    /// selected model's inverted thrust map.
    pub feedforward_pct: f64,
    /// The feedforward demand was beyond the thrusters' reach: its command is the ±100 %
    /// limit.
    pub feedforward_saturated: bool,
    /// Static-load and bias compensation: −(known load of the control plant model +
    /// bias estimate), N or N·m.
    pub bias_compensation: f64,
    /// Demand in %: vertical for depth, differential for heading.
    pub demand_pct: f64,
}

/// Fault flags of one tick. None of them stops the tick: the output stays finite and
/// bounded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Faults {
    /// `t_s` was non-finite or not increasing (dt = 0 used for this tick), or dt
    /// exceeded `max_dt_s` (clamped).
    pub dt_invalid: bool,
    /// A stick value was non-finite (taken as centred).
    pub stick_non_finite: bool,
    /// A depth hold dropped to manual because no usable sample arrived within the timeout.
    pub depth_sensor_lost: bool,
    /// A heading hold dropped to manual for the same reason.
    pub heading_sensor_lost: bool,
    /// The guard saw a non-finite value (should never happen; ramps to neutral).
    pub output_non_finite: bool,
}

/// Diagnostics of one tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TickDiagnostics {
    /// The dt used, s.
    pub dt_s: f64,
    /// Depth axis.
    pub depth: AxisDiagnostics,
    /// Heading axis.
    pub heading: AxisDiagnostics,
    /// The feedforward model in use.
    pub model: ModelChoice,
    /// Feedforward on.
    pub feedforward_enabled: bool,
    /// Allocation before the guard.
    pub allocation: Allocation,
    /// What the guard did.
    pub guard: GuardReport,
    /// Fault flags.
    pub faults: Faults,
    /// Observer counters (depth, heading).
    pub observer_stats: (ChannelStats, ChannelStats),
}

impl TickDiagnostics {
    /// Estimated depth, m.
    pub fn depth_estimate_m(&self) -> Option<f64> {
        self.depth.estimate.map(|e| e.pos)
    }

    /// Estimated heading, degrees 0..360.
    pub fn heading_estimate_deg(&self) -> Option<f64> {
        self.heading.estimate.map(|e| e.pos.to_degrees())
    }

    /// Depth setpoint, m.
    pub fn depth_setpoint_m(&self) -> Option<f64> {
        self.depth.setpoint
    }

    /// Heading setpoint, degrees 0..360.
    pub fn heading_setpoint_deg(&self) -> Option<f64> {
        self.heading.setpoint.map(f64::to_degrees)
    }
}

/// The result of one tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TickOutput {
    /// The guarded thrust command.
    pub command: ThrustCommand,
    /// Targets for CSR 0x0B / 0x0D (off unless an axis is in VehicleAuto).
    pub vehicle_targets: VehicleAutoTargets,
    /// Everything else.
    pub diagnostics: TickDiagnostics,
}

/// Raw-measurement feedback (observer off): last sample and its derivative.
#[derive(Debug, Clone, Copy, Default)]
struct RawFeedback {
    pos: Option<f64>,
    vel: f64,
    since_last_s: f64,
}

/// Per-axis controller state.
#[derive(Debug, Clone)]
struct AxisCtl {
    angle: bool,
    state: AxisState,
    setpoint: f64,
    /// Rate of a moving setpoint (typed in quick succession), m/s or rad/s.
    setpoint_rate: f64,
    /// Time (of the tick before) and value of the last typed setpoint.
    last_typed: Option<(f64, f64)>,
    reference: ReferenceModel,
    pid: Pid,
    raw: RawFeedback,
    sample_age_s: f64,
    /// VehicleAuto target (m or rad), None = off.
    vehicle_target: Option<f64>,
    last_diag: AxisDiagnostics,
    /// Last hold demand before its lead (for the lag compensation's du/dt), %.
    demand_prev_pct: Option<f64>,
}

impl AxisCtl {
    fn new(cfg: &AxisConfig, angle: bool) -> Self {
        AxisCtl {
            angle,
            state: AxisState::default(),
            setpoint: 0.0,
            setpoint_rate: 0.0,
            last_typed: None,
            reference: if angle {
                ReferenceModel::new_angle(cfg.reference)
            } else {
                ReferenceModel::new(cfg.reference)
            },
            pid: Pid::new(cfg.pid),
            raw: RawFeedback::default(),
            sample_age_s: f64::INFINITY,
            vehicle_target: None,
            last_diag: AxisDiagnostics::default(),
            demand_prev_pct: None,
        }
    }

    fn norm(&self, pos: f64) -> f64 {
        if self.angle { wrap_2pi(pos) } else { pos }
    }

    fn diff(&self, a: f64, b: f64) -> f64 {
        if self.angle { wrap_pi(a - b) } else { a - b }
    }

    /// Latches the stopping point of the current motion and restarts the reference there.
    fn latch(&mut self, pos: f64, vel: f64) {
        self.reference.reset(pos, vel);
        self.setpoint = self.norm(pos + self.reference.stopping_distance(vel));
        self.setpoint_rate = 0.0;
        self.last_typed = None;
    }

    /// A typed setpoint at (the last tick's) time `now_s`: if the previous one came
    /// within [`MOVING_SETPOINT_WINDOW_S`], the setpoint is moving and its rate is fed to
    /// the reference model.
    fn type_setpoint(&mut self, value: f64, now_s: Option<f64>) {
        let value = self.norm(value);
        self.setpoint_rate = match (now_s, self.last_typed) {
            (Some(now), Some((t_prev, v_prev)))
                if now > t_prev && now - t_prev <= MOVING_SETPOINT_WINDOW_S =>
            {
                self.diff(value, v_prev) / (now - t_prev)
            }
            _ => 0.0,
        };
        if !self.setpoint_rate.is_finite() {
            self.setpoint_rate = 0.0;
        }
        self.last_typed = now_s.map(|t| (t, value));
        self.setpoint = value;
    }

    /// Raw feedback update with a valid sample.
    fn raw_sample(&mut self, z: f64, dt: f64) {
        self.raw.since_last_s += dt;
        if let Some(prev) = self.raw.pos
            && self.raw.since_last_s > 0.0
        {
            // Quantised samples (1 mbar ≈ 1 cm, 0.1°) make the raw difference spiky: low-pass
            // it before the PID's own derivative filter.
            let inst = self.diff(z, prev) / self.raw.since_last_s;
            let alpha = -(-self.raw.since_last_s / RAW_RATE_FILTER_S).exp_m1();
            self.raw.vel += alpha * (inst - self.raw.vel);
        }
        self.raw.pos = Some(z);
        self.raw.since_last_s = 0.0;
    }
}

/// Inputs of one axis step that come from the rest of the tick.
struct AxisInputs<'a> {
    cfg: &'a AxisConfig,
    dt: f64,
    now_s: Option<f64>,
    stick: f64,
    feedback: Option<(f64, f64)>,
    bias: Option<f64>,
    ff_enabled: bool,
    /// Force (N or N·m) the last command produces (for bumpless re-engage).
    current_force: f64,
    force_range: (f64, f64),
    /// Feedforward for (vel, acc): the selected model's inverse dynamics through its
    /// inverted thrust map gives a command in %; returns (the force that command produces
    /// according to the control plant model, the command in %).
    feedforward: &'a dyn Fn(f64, f64) -> (f64, f64),
    /// Force → % through the control plant model's inverted thrust map.
    to_pct: &'a dyn Fn(f64) -> f64,
    /// Lag time constant of the axis' thrusters (s): the hold's demand gets the lead
    /// `τ·du/dt` (0: none).
    lead_tau_s: f64,
}

/// The depth and heading autopilot.
#[derive(Debug, Clone)]
pub struct Controller {
    cfg: ControlConfig,
    models: ModelSet,
    model: ModelChoice,
    ff_enabled: bool,
    observer: Observer,
    depth: AxisCtl,
    heading: AxisCtl,
    guard: OutputGuard,
    last_t_s: Option<f64>,
    surface_tare_mbar: Option<f64>,
    /// A custom plant (any model's) used for everything instead of the model set.
    custom: Option<PlantModel>,
    /// The lag's state per thruster (port, starboard, vertical), %: the command the
    /// thrusters act on according to the plant in use.
    lagged_pct: [f64; 3],
}

impl Controller {
    /// A controller in manual mode on both axes, thrust neutral.
    pub fn new(cfg: ControlConfig, models: ModelSet) -> Result<Self, ControlError> {
        cfg.validate()?;
        models.validate()?;
        let surface_tare_mbar = match cfg.surface_tare {
            SurfaceTare::Configured(p) => Some(check_tare(p)?),
            SurfaceTare::AtConnection => None,
        };
        Ok(Controller {
            observer: Observer::new(cfg.depth.observer, cfg.heading.observer),
            depth: AxisCtl::new(&cfg.depth, false),
            heading: AxisCtl::new(&cfg.heading, true),
            guard: OutputGuard::new(cfg.guard)?,
            model: cfg.feedforward_model,
            ff_enabled: cfg.feedforward_enabled,
            last_t_s: None,
            surface_tare_mbar,
            cfg,
            models,
            custom: None,
            lagged_pct: [0.0; 3],
        })
    }

    /// Uses `plant` (any model's, e.g. from [`PlantModel::from_vehicle_model`]) under
    /// `label` for the feedforward, the observer, the feedback inversion and the force
    /// limits. The plant is validated first; on an error the controller keeps the model
    /// it had. Holding axes re-engage bumplessly. [`ModeCommand::SelectModel`] returns to
    /// the model set.
    pub fn set_plant(&mut self, label: &str, mut plant: PlantModel) -> Result<(), ControlError> {
        plant.name = label.to_string();
        plant.validate()?;
        self.custom = Some(plant);
        self.reengage_holding_axes();
        Ok(())
    }

    /// The custom plant in use, if any.
    pub fn custom_plant(&self) -> Option<&PlantModel> {
        self.custom.as_ref()
    }

    /// The label of the model the autopilot uses: the custom plant's label, else the
    /// selected feedforward model's name.
    pub fn model_label(&self) -> &str {
        match &self.custom {
            Some(p) => &p.name,
            None => self.model.name(),
        }
    }

    /// The plant of the observer, feedback inversion and limits.
    fn control_plant(&self) -> &PlantModel {
        match &self.custom {
            Some(p) => p,
            None => self.models.get(self.cfg.plant_model),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &ControlConfig {
        &self.cfg
    }

    /// The feedforward model in use.
    pub fn model(&self) -> ModelChoice {
        self.model
    }

    /// Whether the feedforward is on.
    pub fn feedforward_enabled(&self) -> bool {
        self.ff_enabled
    }

    /// The observer (estimates, covariances, counters).
    pub fn observer(&self) -> &Observer {
        &self.observer
    }

    /// Mode and override state of an axis.
    pub fn axis_state(&self, axis: Axis) -> AxisState {
        self.axis(axis).state
    }

    /// The held depth setpoint, m (Hold or VehicleAuto).
    pub fn depth_setpoint_m(&self) -> Option<f64> {
        self.setpoint_of(Axis::Depth)
    }

    /// The held heading setpoint, degrees 0..360 (Hold or VehicleAuto).
    pub fn heading_setpoint_deg(&self) -> Option<f64> {
        self.setpoint_of(Axis::Heading).map(f64::to_degrees)
    }

    /// The last command let out.
    pub fn last_command(&self) -> ThrustCommand {
        self.guard.last()
    }

    /// The surface pressure tare, mbar, if known.
    pub fn surface_tare_mbar(&self) -> Option<f64> {
        self.surface_tare_mbar
    }

    /// Depth from an absolute pressure with the controller's tare and water density;
    /// `None` until a tare is known or for non-finite input.
    pub fn depth_m_from_pressure(&self, pressure_mbar: f64) -> Option<f64> {
        let tare = self.surface_tare_mbar?;
        let d = depth_m_from_mbar(pressure_mbar, tare, self.cfg.water_density_kg_m3);
        d.is_finite().then_some(d)
    }

    /// The current targets for the vehicle's own auto modes.
    pub fn vehicle_targets(&self) -> VehicleAutoTargets {
        let depth_mbar = match (
            self.depth.state.mode,
            self.depth.vehicle_target,
            self.surface_tare_mbar,
        ) {
            (AxisMode::VehicleAuto, Some(d), Some(tare)) if !self.depth.state.overridden => {
                depth_target_mbar(tare, d, self.cfg.water_density_kg_m3)
            }
            _ => None,
        };
        let heading_deg = match (self.heading.state.mode, self.heading.vehicle_target) {
            (AxisMode::VehicleAuto, Some(h)) if !self.heading.state.overridden => {
                heading_target_deg(h.to_degrees())
            }
            _ => None,
        };
        VehicleAutoTargets {
            depth_mbar,
            heading_deg,
        }
    }

    /// Failsafe: both axes to manual and thrust neutral at once (bypassing the slew limit).
    pub fn failsafe_neutral(&mut self) -> ThrustCommand {
        for ax in [&mut self.depth, &mut self.heading] {
            ax.state = AxisState::default();
            ax.vehicle_target = None;
            ax.pid.reset();
        }
        self.guard.force_neutral()
    }

    fn axis(&self, axis: Axis) -> &AxisCtl {
        match axis {
            Axis::Depth => &self.depth,
            Axis::Heading => &self.heading,
        }
    }

    fn setpoint_of(&self, axis: Axis) -> Option<f64> {
        let ax = self.axis(axis);
        match ax.state.mode {
            AxisMode::Manual => None,
            AxisMode::Hold => Some(ax.setpoint),
            AxisMode::VehicleAuto => ax.vehicle_target,
        }
    }

    fn channel(&self, axis: Axis) -> &KalmanChannel {
        match axis {
            Axis::Depth => &self.observer.depth,
            Axis::Heading => &self.observer.heading,
        }
    }

    /// Position and rate used for feedback on an axis: the observer's estimate, or the
    /// raw measurement and its derivative when the observer is off.
    fn feedback(&self, axis: Axis) -> Option<(f64, f64)> {
        if self.cfg.observer_enabled {
            self.channel(axis).estimate().map(|e| (e.pos, e.vel))
        } else {
            let raw = self.axis(axis).raw;
            raw.pos.map(|p| (p, raw.vel))
        }
    }

    /// The force or moment (N, N·m) that the last command produces according to the
    /// control plant model.
    fn current_force(&self, axis: Axis) -> f64 {
        let m = self.control_plant();
        let [port, starboard, vertical] = self.acting_pct();
        match axis {
            Axis::Depth => m.vertical_force_for_pct(vertical),
            Axis::Heading => m.yaw_moment_for_pct(port, starboard),
        }
    }

    /// The commands (port, starboard, vertical, %) the thrusters act on: the last
    /// command, or the lag's state when the plant in use has a lag.
    fn acting_pct(&self) -> [f64; 3] {
        let c = self.guard.last();
        if self.control_plant().has_lag() {
            self.lagged_pct
        } else {
            [c.port_pct(), c.starboard_pct(), c.vertical_pct()]
        }
    }

    /// Applies a pilot command. Engaging needs a valid measurement on that axis.
    pub fn command(&mut self, cmd: ModeCommand) -> Result<(), ControlError> {
        match cmd {
            ModeCommand::Engage(axis) => self.engage_hold(axis, None),
            ModeCommand::Disengage(axis) => {
                let ax = self.axis_mut(axis);
                ax.state = AxisState::default();
                ax.vehicle_target = None;
                Ok(())
            }
            ModeCommand::EngageVehicleAuto(axis) => {
                let (pos, _) = self
                    .feedback(axis)
                    .ok_or(ControlError::NoEstimate { axis })?;
                let ax = self.axis_mut(axis);
                ax.state = AxisState {
                    mode: AxisMode::VehicleAuto,
                    overridden: false,
                };
                ax.vehicle_target = Some(pos);
                Ok(())
            }
            ModeCommand::SetDepth { depth_m } => {
                let (lo, hi) = (self.cfg.depth_valid_min_m, self.cfg.depth_valid_max_m);
                if !(depth_m.is_finite() && (lo..=hi).contains(&depth_m)) {
                    return Err(ControlError::InvalidSetpoint {
                        axis: Axis::Depth,
                        value: depth_m,
                        allowed: format!("{lo}..={hi} m"),
                    });
                }
                self.set_target(Axis::Depth, depth_m)
            }
            ModeCommand::StepDepth { delta_m } => {
                let base = self.target_base(Axis::Depth)?;
                self.command(ModeCommand::SetDepth {
                    depth_m: base + delta_m,
                })
            }
            ModeCommand::SetHeading { heading_deg } => {
                if !(heading_deg.is_finite() && heading_deg.abs() <= HEADING_SANE_DEG) {
                    return Err(ControlError::InvalidSetpoint {
                        axis: Axis::Heading,
                        value: heading_deg,
                        allowed: "finite degrees".into(),
                    });
                }
                self.set_target(Axis::Heading, wrap_2pi(heading_deg.to_radians()))
            }
            ModeCommand::StepHeading { delta_deg } => {
                let base = self.target_base(Axis::Heading)?;
                self.command(ModeCommand::SetHeading {
                    heading_deg: base.to_degrees() + delta_deg,
                })
            }
            ModeCommand::SelectModel(choice) => {
                if choice != self.model || self.custom.is_some() {
                    self.model = choice;
                    self.custom = None;
                    self.reengage_holding_axes();
                }
                Ok(())
            }
            ModeCommand::SetFeedforward(on) => {
                if on != self.ff_enabled {
                    self.ff_enabled = on;
                    self.reengage_holding_axes();
                }
                Ok(())
            }
            ModeCommand::SetSurfaceTare { pressure_mbar } => {
                self.surface_tare_mbar = Some(check_tare(pressure_mbar)?);
                Ok(())
            }
        }
    }

    fn axis_mut(&mut self, axis: Axis) -> &mut AxisCtl {
        match axis {
            Axis::Depth => &mut self.depth,
            Axis::Heading => &mut self.heading,
        }
    }

    /// The value a step is added to: the current setpoint/target, else the estimate.
    fn target_base(&self, axis: Axis) -> Result<f64, ControlError> {
        match self.setpoint_of(axis) {
            Some(s) => Ok(s),
            None => self
                .feedback(axis)
                .map(|(p, _)| p)
                .ok_or(ControlError::NoEstimate { axis }),
        }
    }

    fn set_target(&mut self, axis: Axis, value: f64) -> Result<(), ControlError> {
        match self.axis(axis).state.mode {
            AxisMode::Manual => self.engage_hold(axis, Some(value)),
            AxisMode::Hold => {
                let now = self.last_t_s;
                self.axis_mut(axis).type_setpoint(value, now);
                Ok(())
            }
            AxisMode::VehicleAuto => {
                self.axis_mut(axis).vehicle_target = Some(value);
                Ok(())
            }
        }
    }

    /// Engages the topside hold bumplessly: latch at the stopping point (or `target`),
    /// reference from the current estimate, integrator set so the output starts at the
    /// current command.
    fn engage_hold(&mut self, axis: Axis, target: Option<f64>) -> Result<(), ControlError> {
        let (pos, vel) = self
            .feedback(axis)
            .ok_or(ControlError::NoEstimate { axis })?;
        let force = self.current_force(axis);
        let now = self.last_t_s;
        let ax = self.axis_mut(axis);
        ax.latch(pos, vel);
        if let Some(t) = target {
            ax.type_setpoint(t, now);
        }
        ax.pid.engage(force);
        ax.state = AxisState {
            mode: AxisMode::Hold,
            overridden: false,
        };
        Ok(())
    }

    fn reengage_holding_axes(&mut self) {
        for axis in [Axis::Depth, Axis::Heading] {
            let force = self.current_force(axis);
            let ax = self.axis_mut(axis);
            if ax.state.mode == AxisMode::Hold && !ax.state.overridden {
                ax.pid.engage(force);
            }
        }
    }

    /// One control tick at time `t_s` (monotonic seconds, any origin).
    pub fn tick(&mut self, t_s: f64, meas: &Measurements, pilot: &PilotInput) -> TickOutput {
        let mut faults = Faults::default();
        // --- time step
        let nominal = 1.0 / self.cfg.rate_hz;
        let dt = match self.last_t_s {
            None if t_s.is_finite() => nominal,
            None => {
                faults.dt_invalid = true;
                0.0
            }
            Some(last) => {
                let dt = t_s - last;
                if !(dt.is_finite() && dt > 0.0) {
                    faults.dt_invalid = true;
                    0.0
                } else if dt > self.cfg.max_dt_s {
                    faults.dt_invalid = true;
                    self.cfg.max_dt_s
                } else {
                    dt
                }
            }
        };
        // A finite time always becomes the new base, so a clock that jumps back costs
        // one tick with dt = 0 (flagged) instead of freezing the controller.
        if t_s.is_finite() {
            self.last_t_s = Some(t_s);
        }

        // --- sticks
        let mut stick = |v: f64| {
            if v.is_finite() {
                v.clamp(-1.0, 1.0)
            } else {
                faults.stick_non_finite = true;
                0.0
            }
        };
        let sticks = PilotInput {
            surge: stick(pilot.surge),
            yaw: stick(pilot.yaw),
            vertical: stick(pilot.vertical),
        };

        // --- samples (implausible = missing)
        let depth_z = meas.depth_m.filter(|d| {
            d.is_finite() && (self.cfg.depth_valid_min_m..=self.cfg.depth_valid_max_m).contains(d)
        });
        let heading_z = meas
            .heading_deg
            .filter(|h| h.is_finite() && h.abs() <= HEADING_SANE_DEG)
            .map(|h| wrap_2pi(h.to_radians()));
        let rate_z = meas
            .yaw_rate_rad_s
            .filter(|r| r.is_finite() && r.abs() <= YAW_RATE_SANE_RAD_S);
        let depth_invalid = meas.depth_m.is_some() && depth_z.is_none();
        let heading_invalid = meas.heading_deg.is_some() && heading_z.is_none();

        // --- the lag's state over this dt (the last command was held), then the observer:
        // predict with the force the (lagged) last command produces, then update
        {
            let c = self.guard.last();
            let last = [c.port_pct(), c.starboard_pct(), c.vertical_pct()];
            let p = self.control_plant();
            let paths = [p.port_path, p.starboard_path, p.vertical_path];
            for ((a, u), path) in self.lagged_pct.iter_mut().zip(last).zip(paths) {
                *a = path.lag_step(*a, u, dt);
            }
        }
        let current_heave = self.current_force(Axis::Depth);
        let current_yaw = self.current_force(Axis::Heading);
        let plant = match &self.custom {
            Some(p) => p,
            None => self.models.get(self.cfg.plant_model),
        };
        let ffm = match &self.custom {
            Some(p) => p,
            None => self.models.get(self.model),
        };
        // The vertical thruster's reaction torque is a known yaw load.
        let yaw_coupling = plant.yaw_per_heave_m * current_heave;
        let heave_in = current_heave + plant.heave.static_load;
        let yaw_in = current_yaw + plant.yaw.static_load + yaw_coupling;
        self.observer.depth.predict(dt, heave_in, &plant.heave);
        self.observer.heading.predict(dt, yaw_in, &plant.yaw);
        let depth_outcome = self.observer.depth.update_position(depth_z);
        let heading_outcome = self.observer.heading.update_position(heading_z);
        self.observer.heading.update_rate(rate_z);

        // --- raw feedback and sample age
        let used = |o: SampleOutcome| {
            matches!(
                o,
                SampleOutcome::Accepted | SampleOutcome::Initialised | SampleOutcome::Reset
            )
        };
        let obs_on = self.cfg.observer_enabled;
        for (ax, z, outcome) in [
            (&mut self.depth, depth_z, depth_outcome),
            (&mut self.heading, heading_z, heading_outcome),
        ] {
            match z {
                Some(z) => ax.raw_sample(z, dt),
                None => ax.raw.since_last_s += dt,
            }
            let fresh = if obs_on { used(outcome) } else { z.is_some() };
            ax.sample_age_s = if fresh { 0.0 } else { ax.sample_age_s + dt };
        }
        if !obs_on && let Some(r) = rate_z {
            self.heading.raw.vel = r;
        }

        // --- axes
        let max_pct = self.cfg.guard.max_pct;
        let (f_lo, f_hi) = (
            plant.vertical_force_for_pct(-max_pct),
            plant.vertical_force_for_pct(max_pct),
        );
        let n_max = plant.yaw_moment_for_pct(max_pct, -max_pct);
        let bias_on = self.cfg.bias_compensation && obs_on;
        // With bias compensation the static loads are compensated from the control plant
        // model (known part) and the bias estimate (the rest), so the feedforward carries
        // only the dynamic part of the selected model's inverse dynamics.
        let (heave_ff_load, yaw_ff_load) = if bias_on {
            (ffm.heave.static_load, ffm.yaw.static_load)
        } else {
            (0.0, 0.0)
        };
        let as_modelled = self.cfg.feedforward_force == FeedforwardForce::AsModelled;
        let by = if as_modelled { ffm } else { plant };
        let heave_ff = |v: f64, a: f64| {
            let pct = ffm.vertical_pct_for_force(ffm.heave_force_n(v, a) + heave_ff_load);
            (by.vertical_force_for_pct(pct), pct)
        };
        let yaw_ff = |r: f64, rdot: f64| {
            let pct = ffm.differential_pct_for_moment(ffm.yaw_moment_nm(r, rdot) + yaw_ff_load);
            (by.yaw_moment_for_pct(pct, -pct), pct)
        };
        let (lead_v_s, lead_h_s) = plant.lag_taus_s();
        let depth_in = AxisInputs {
            cfg: &self.cfg.depth,
            dt,
            now_s: self.last_t_s,
            stick: sticks.vertical,
            feedback: self.feedback(Axis::Depth),
            bias: bias_on
                .then(|| {
                    self.observer
                        .depth
                        .estimate()
                        .map(|e| e.bias + plant.heave.static_load)
                })
                .flatten(),
            ff_enabled: self.ff_enabled,
            current_force: current_heave,
            force_range: (f_lo, f_hi),
            feedforward: &heave_ff,
            to_pct: &|f| plant.vertical_pct_for_force(f),
            lead_tau_s: lead_v_s,
        };
        let heading_in = AxisInputs {
            cfg: &self.cfg.heading,
            dt,
            now_s: self.last_t_s,
            stick: sticks.yaw,
            feedback: self.feedback(Axis::Heading),
            bias: bias_on
                .then(|| {
                    self.observer
                        .heading
                        .estimate()
                        .map(|e| e.bias + plant.yaw.static_load + yaw_coupling)
                })
                .flatten(),
            ff_enabled: self.ff_enabled,
            current_force: current_yaw,
            force_range: (-n_max, n_max),
            feedforward: &yaw_ff,
            to_pct: &|n| plant.differential_pct_for_moment(n),
            lead_tau_s: lead_h_s,
        };
        let mut d_diag = step_axis(&mut self.depth, &depth_in, &mut faults.depth_sensor_lost);
        let mut h_diag = step_axis(
            &mut self.heading,
            &heading_in,
            &mut faults.heading_sensor_lost,
        );
        d_diag.estimate = self.observer.depth.estimate();
        d_diag.sample = depth_outcome;
        d_diag.sample_invalid = depth_invalid;
        h_diag.estimate = self.observer.heading.estimate();
        h_diag.sample = heading_outcome;
        h_diag.sample_invalid = heading_invalid;

        // --- allocation and guard
        let surge_pct = stick_to_pct(
            sticks.surge,
            self.cfg.surge_deadband,
            self.cfg.surge_max_pct,
        );
        let allocation = allocate_in_force(
            ThrustDemand {
                surge_pct,
                yaw_pct: h_diag.demand_pct,
                vertical_pct: d_diag.demand_pct,
            },
            self.cfg.guard.max_pct,
            plant,
        );
        let (command, guard) = self.guard.apply(
            allocation.port_pct,
            allocation.starboard_pct,
            allocation.vertical_pct,
        );
        faults.output_non_finite = guard.fault() || allocation.non_finite_demand;
        self.depth.last_diag = d_diag;
        self.heading.last_diag = h_diag;

        TickOutput {
            command,
            vehicle_targets: self.vehicle_targets(),
            diagnostics: TickDiagnostics {
                dt_s: dt,
                depth: d_diag,
                heading: h_diag,
                model: self.model,
                feedforward_enabled: self.ff_enabled,
                allocation,
                guard,
                faults,
                observer_stats: (self.observer.depth.stats(), self.observer.heading.stats()),
            },
        }
    }
}

/// Lag compensation of a hold's demand `u` (%): `u + τ·du/dt`, the lead bounded by
/// [`crate::feedforward::LAG_LEAD_MAX_PCT`] and the result by ±100 %. The lag sits
/// between the command and the thrust map, so leading the whole demand (feedforward and
/// feedback) inverts it: the thrusters then act on about the demand itself, and the
/// feedback loop keeps the phase margin it was designed with.
fn lag_lead(ax: &mut AxisCtl, u: f64, inp: &AxisInputs<'_>) -> f64 {
    if !(inp.lead_tau_s > 0.0 && u.is_finite()) {
        ax.demand_prev_pct = None;
        return u;
    }
    let rate = match ax.demand_prev_pct {
        Some(prev) if inp.dt > 0.0 => (u - prev) / inp.dt,
        _ => 0.0,
    };
    ax.demand_prev_pct = Some(u);
    let max = crate::feedforward::LAG_LEAD_MAX_PCT;
    let lead = (inp.lead_tau_s * rate).clamp(-max, max);
    if lead.is_finite() {
        (u + lead).clamp(-100.0, 100.0)
    } else {
        u
    }
}

/// One axis' mode logic and control law; returns its diagnostics (estimate and sample
/// fields are filled in by the caller).
fn step_axis(ax: &mut AxisCtl, inp: &AxisInputs<'_>, sensor_lost: &mut bool) -> AxisDiagnostics {
    let cfg = inp.cfg;
    let stick_active = inp.stick.abs() > cfg.stick_deadband;
    let stick_pct = stick_to_pct(inp.stick, cfg.stick_deadband, cfg.manual_max_pct);
    let mut diag = AxisDiagnostics {
        feedback: inp.feedback,
        sample_age_s: ax.sample_age_s,
        ..Default::default()
    };

    // A hold without usable samples drops to manual (neutral with a centred stick).
    let stale = ax.sample_age_s > cfg.sensor_timeout_s || inp.feedback.is_none();
    if ax.state.mode != AxisMode::Manual && stale {
        ax.state = AxisState::default();
        ax.vehicle_target = None;
        *sensor_lost = true;
    }

    let demand_pct = match (ax.state.mode, inp.feedback) {
        (AxisMode::Hold, Some((pos, vel))) => {
            if stick_active {
                ax.state.overridden = true;
                ax.reference.reset(pos, vel);
                stick_pct
            } else {
                if ax.state.overridden {
                    // Stick released: latch at the stopping point, bumpless re-engage.
                    ax.latch(pos, vel);
                    ax.pid.engage(inp.current_force);
                    ax.state.overridden = false;
                }
                if let (Some((t_typed, _)), Some(now)) = (ax.last_typed, inp.now_s)
                    && now - t_typed > MOVING_SETPOINT_WINDOW_S
                {
                    ax.setpoint_rate = 0.0;
                }
                let r = ax
                    .reference
                    .step_moving(ax.setpoint, ax.setpoint_rate, inp.dt);
                let (ff, ff_pct) = if inp.ff_enabled {
                    (inp.feedforward)(r.vel, r.acc)
                } else {
                    (0.0, 0.0)
                };

                let bias_comp = inp.bias.map_or(0.0, |b| -b);
                let error = ax.diff(r.pos, pos);
                let terms = ax.pid.update(
                    error,
                    r.vel - vel,
                    ff + bias_comp,
                    inp.dt,
                    inp.force_range.0,
                    inp.force_range.1,
                );
                diag.reference = r;
                diag.pid = terms;
                diag.feedforward = ff;
                diag.feedforward_pct = ff_pct;
                diag.feedforward_saturated = ff_pct.abs() >= 100.0 - 1e-9;
                diag.bias_compensation = bias_comp;
                diag.setpoint = Some(ax.setpoint);
                let u = (inp.to_pct)(terms.output);
                lag_lead(ax, u, inp)
            }
        }
        (AxisMode::VehicleAuto, Some((pos, _))) => {
            if stick_active {
                ax.state.overridden = true;
                stick_pct
            } else {
                if ax.state.overridden {
                    ax.vehicle_target = Some(pos);
                    ax.state.overridden = false;
                }
                diag.setpoint = ax.vehicle_target;
                0.0
            }
        }
        (_, feedback) => {
            ax.state = AxisState::default();
            if let Some((pos, vel)) = feedback {
                ax.reference.reset(pos, vel);
            }
            stick_pct
        }
    };
    if ax.state.mode != AxisMode::Hold || ax.state.overridden {
        diag.reference = ax.reference.state();
        ax.demand_prev_pct = None;
    }
    diag.state = ax.state;
    diag.demand_pct = demand_pct;
    diag
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ctl() -> Controller {
        Controller::new(ControlConfig::default(), ModelSet::load_default().unwrap()).unwrap()
    }

    fn meas(depth_m: f64, heading_deg: f64) -> Measurements {
        Measurements {
            depth_m: Some(depth_m),
            heading_deg: Some(heading_deg),
            yaw_rate_rad_s: None,
        }
    }

    #[test]
    fn engage_needs_a_measurement() {
        let mut c = ctl();
        assert!(matches!(
            c.command(ModeCommand::Engage(Axis::Depth)),
            Err(ControlError::NoEstimate { .. })
        ));
        c.tick(0.0, &meas(3.0, 90.0), &PilotInput::default());
        c.command(ModeCommand::Engage(Axis::Depth)).unwrap();
        assert_eq!(c.axis_state(Axis::Depth).mode, AxisMode::Hold);
        assert!((c.depth_setpoint_m().unwrap() - 3.0).abs() < 1e-9);
        c.command(ModeCommand::StepDepth { delta_m: 0.5 }).unwrap();
        assert!((c.depth_setpoint_m().unwrap() - 3.5).abs() < 1e-9);
        assert!(
            c.command(ModeCommand::SetDepth { depth_m: f64::NAN })
                .is_err()
        );
        c.command(ModeCommand::SetHeading { heading_deg: -10.0 })
            .unwrap();
        assert!((c.heading_setpoint_deg().unwrap() - 350.0).abs() < 1e-9);
        c.command(ModeCommand::StepHeading { delta_deg: 15.0 })
            .unwrap();
        assert!((c.heading_setpoint_deg().unwrap() - 5.0).abs() < 1e-9);
    }

    #[test]
    fn stick_overrides_and_release_latches() {
        let mut c = ctl();
        let mut t = 0.0;
        let still = PilotInput::default();
        c.tick(t, &meas(3.0, 90.0), &still);
        c.command(ModeCommand::Engage(Axis::Depth)).unwrap();
        let dive = PilotInput {
            vertical: 0.8,
            ..still
        };
        let out = c.tick(t + 0.02, &meas(3.0, 90.0), &dive);
        assert!(c.axis_state(Axis::Depth).overridden);
        assert!(out.command.vertical_pct() > 0.0);
        // Pretend the vehicle descended to 4 m while the stick was held.
        for k in 0..200 {
            t += 0.02;
            let d = 3.0 + 0.005 * k as f64;
            c.tick(t, &meas(d, 90.0), &dive);
        }
        t += 0.02;
        c.tick(t, &meas(4.0, 90.0), &still);
        let s = c.axis_state(Axis::Depth);
        assert_eq!((s.mode, s.overridden), (AxisMode::Hold, false));
        let sp = c.depth_setpoint_m().unwrap();
        assert!(sp > 4.0 && sp < 4.3, "latched at the stopping point: {sp}");
    }

    #[test]
    fn vehicle_auto_targets() {
        let cfg = ControlConfig {
            surface_tare: SurfaceTare::Configured(1013.0),
            ..ControlConfig::default()
        };
        let mut c = Controller::new(cfg, ModelSet::load_default().unwrap()).unwrap();
        c.tick(0.0, &meas(10.0, 359.7), &PilotInput::default());
        c.command(ModeCommand::EngageVehicleAuto(Axis::Depth))
            .unwrap();
        c.command(ModeCommand::EngageVehicleAuto(Axis::Heading))
            .unwrap();
        let out = c.tick(0.02, &meas(10.0, 359.7), &PilotInput::default());
        assert_eq!(out.vehicle_targets.depth_mbar, Some(1994));
        assert_eq!(out.vehicle_targets.heading_deg, Some(0));
        assert!(out.command.is_neutral());
        // Override: target off while the stick is out.
        let out = c.tick(
            0.04,
            &meas(10.0, 359.7),
            &PilotInput {
                vertical: -0.5,
                ..Default::default()
            },
        );
        assert_eq!(out.vehicle_targets.csr_words()[0], 0xFFFF);
        assert!(out.command.vertical_pct() < 0.0);
        let rise = PilotInput {
            vertical: -0.5,
            ..Default::default()
        };
        let mut t = 0.04;
        for k in 0..=200 {
            t += 0.02;
            c.tick(t, &meas(10.0 - k as f64 / 200.0, 359.7), &rise);
        }
        for _ in 0..100 {
            t += 0.02;
            c.tick(t, &meas(9.0, 359.7), &rise);
        }
        let out = c.tick(t + 0.02, &meas(9.0, 359.7), &PilotInput::default());
        let mbar = out.vehicle_targets.depth_mbar.unwrap();
        assert!((1895..=1897).contains(&mbar), "{mbar}");
        // Without a tare (at-connection mode, not yet tared) the depth target stays off.
        let mut c2 = ctl();
        c2.tick(0.0, &meas(10.0, 0.0), &PilotInput::default());
        c2.command(ModeCommand::EngageVehicleAuto(Axis::Depth))
            .unwrap();
        assert_eq!(c2.vehicle_targets().depth_mbar, None);
        c2.command(ModeCommand::SetSurfaceTare {
            pressure_mbar: 1000.0,
        })
        .unwrap();
        assert_eq!(c2.vehicle_targets().depth_mbar, Some(1981));
        assert!((c2.depth_m_from_pressure(1981.0).unwrap() - 10.0).abs() < 0.01);
    }

    #[test]
    fn sensor_loss_drops_to_manual_with_fault() {
        let mut c = ctl();
        c.tick(0.0, &meas(3.0, 10.0), &PilotInput::default());
        c.command(ModeCommand::Engage(Axis::Depth)).unwrap();
        let mut lost = false;
        for k in 1..100 {
            let out = c.tick(
                0.02 * k as f64,
                &Measurements {
                    depth_m: None,
                    heading_deg: Some(10.0),
                    yaw_rate_rad_s: None,
                },
                &PilotInput::default(),
            );
            lost |= out.diagnostics.faults.depth_sensor_lost;
        }
        assert!(lost);
        assert_eq!(c.axis_state(Axis::Depth).mode, AxisMode::Manual);
        assert_eq!(c.last_command().vertical_pct(), 0.0);
    }

    /// Engages a depth hold at 3 m with `plant` (None: the model set) and returns the
    /// vertical demand (%) of the tick after (the static-load compensation, before the
    /// observer's bias has moved).
    fn hover_demand(plant: Option<PlantModel>) -> f64 {
        let mut c = ctl();
        if let Some(p) = plant {
            c.set_plant("custom", p).unwrap();
        }
        let mut t = 0.0;
        let still = PilotInput::default();
        c.tick(t, &meas(3.0, 90.0), &still);
        c.command(ModeCommand::Engage(Axis::Depth)).unwrap();
        let mut out = 0.0;
        for _ in 0..2 {
            t += 0.02;
            out = c
                .tick(t, &meas(3.0, 90.0), &still)
                .diagnostics
                .depth
                .demand_pct;
        }
        out
    }

    #[test]
    fn a_custom_plant_drives_everything_and_a_bad_one_leaves_the_model() {
        let mut c = ctl();
        let mut bad = PlantModel::load_default(ModelChoice::Model3).unwrap();
        bad.heave.inertia = f64::NAN;
        let e = c.set_plant("bad.toml", bad).unwrap_err().to_string();
        assert!(e.contains("heave.inertia"), "{e}");
        assert_eq!(c.model_label(), "model3");
        assert!(c.custom_plant().is_none());

        // Half the thrust both ways: holding against the same static load needs more
        // command, because the observer, the load compensation and the inversion all use
        // the custom plant.
        let mut heavy = PlantModel::load_default(ModelChoice::Model3).unwrap();
        heavy.heave.static_load = 2.0;
        let mut weak = heavy.clone();
        weak.vertical = weak.vertical.scaled(0.5);
        let base = hover_demand(Some(heavy));
        let custom = hover_demand(Some(weak.clone()));
        assert!(base < -1.0, "a heavy vehicle needs upward thrust: {base}");
        assert!(
            custom.abs() > 1.3 * base.abs() && custom.signum() == base.signum(),
            "{base} vs {custom}"
        );

        c.set_plant("learned.toml", weak).unwrap();
        assert_eq!(c.model_label(), "learned.toml");
        c.command(ModeCommand::SelectModel(ModelChoice::Model2))
            .unwrap();
        assert_eq!(c.model_label(), "model2");
        assert!(c.custom_plant().is_none());
    }

    #[test]
    fn a_lagging_plant_gets_a_bounded_lead_on_its_demand() {
        let run = |lag_s: f64| {
            let mut p = PlantModel::load_default(ModelChoice::Model3).unwrap();
            p.vertical_path.lag_tau_s = lag_s;
            // Observer off: the lead is then the only difference between the two runs.
            let cfg = ControlConfig {
                observer_enabled: false,
                ..ControlConfig::default()
            };
            let mut c = Controller::new(cfg, ModelSet::load_default().unwrap()).unwrap();
            c.set_plant("p", p).unwrap();
            let still = PilotInput::default();
            let mut t = 0.0;
            c.tick(t, &meas(3.0, 90.0), &still);
            c.command(ModeCommand::Engage(Axis::Depth)).unwrap();
            c.command(ModeCommand::SetDepth { depth_m: 4.0 }).unwrap();
            let mut ff = Vec::new();
            for _ in 0..150 {
                t += 0.02;
                let o = c.tick(t, &meas(3.0, 90.0), &still);
                assert!(o.command.vertical_pct().is_finite());
                ff.push(o.diagnostics.depth.demand_pct);
            }
            ff
        };
        let plain = run(0.0);
        let lagged = run(0.4);
        let diffs: Vec<f64> = plain.iter().zip(&lagged).map(|(a, b)| b - a).collect();
        let max = diffs.iter().fold(0.0f64, |m, d| m.max(d.abs()));
        assert!(max > 1.0, "the lead changes the demand: {max}");
        assert!(
            max <= crate::feedforward::LAG_LEAD_MAX_PCT + 1e-9,
            "bounded: {max}"
        );
        // The lead comes first: the lagged plant's demand rises earlier.
        let first = |v: &[f64]| v.iter().position(|x| x.abs() > 2.0);
        assert!(
            first(&lagged) <= first(&plain),
            "{:?} {:?}",
            first(&lagged),
            first(&plain)
        );
    }
}
