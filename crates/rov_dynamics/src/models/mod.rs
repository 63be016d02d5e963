//! The three VideoRay Pro 4 models of seed 000 behind one interface.
//!
//! * [`model1`]: Enevoldsen et al. 2018, decoupled surge/heave/yaw Newton model with the
//!   tuning factors α, β (seed 000 eq. 1–7).
//! * [`model2`]: Arnesen 2016, Fossen 3-DOF (u, w, r) with a linear thrust map
//!   (seed 000 eq. 8–17).
//! * [`model3`]: Mai et al. 2017, full 6-DOF Fossen model with quadratic thrusters
//!   (seed 000 eq. 18–28).
//!
//! # Common interface
//!
//! Every model takes the same input ([`ThrustPct`]: port, starboard, vertical in percent)
//! and produces the same [`ModelOutput`] channels; a channel a model does not predict is
//! `None` and [`VehicleModel::predicts`] says so. All models use the 6-DOF [`ModelState`]
//! layout (η, ν in Fossen's order); models 1 and 2 keep v = p = q = 0 and φ = θ = 0.
//!
//! # Pipeline (for the model lab)
//!
//! [`VehicleModel::derivative`] chains four separable stages, each a trait method an
//! extension can override (wrap a base model and delegate the rest):
//!
//! 1. (a) [`VehicleModel::thruster_forces`]: percent → force per thruster (N);
//! 2. (b) [`VehicleModel::generalized_force`]: forces → τ (N, N m), then τ_ext is added;
//! 3. (c) [`VehicleModel::dynamics`]: state derivative from (η, ν, τ + τ_ext, current);
//!    [`VehicleModel::extra_dynamics`] adds the derivatives of extra states;
//! 4. (d) [`VehicleModel::outputs`]: state → measured channels.
//!
//! Extra states (e.g. a thruster lag) live in [`ModelState::extra`] (up to
//! [`MAX_EXTRA_STATES`], fixed size so the hot path does not allocate).
//!
//! # Simulation
//!
//! [`simulate`] follows the measurement CSV timing rule: output k is taken at t_k before
//! command k acts; command k is held from t_k to t_{k+1} (zero-order hold); sampling may be
//! uneven; the interval is integrated with equal RK4 sub-steps of at most `dt_max_s`.

pub mod model1;
pub mod model2;
pub mod model3;
mod param_util;
pub mod vehicle;

use std::any::Any;
use std::fmt;

use rov_types::measurement::{MeasurementRow, OptionalChannel};
use rov_types::{ConfigError, ParamFile};

use crate::current::CurrentRamp;
use crate::error::DynamicsError;
use crate::integrators::{StateVector, rk4_step};
use crate::math::Vector6;
use crate::process::CurrentSample;
pub use crate::thrusters::{ThrustPct, ThrusterForces};

pub use model1::{Model1, Model1Params};
pub use model2::{Model2, Model2Params};
pub use model3::{Model3, Model3Params, SurgeDragReading};

/// Room for extra model states (thruster lag and the like).
pub const MAX_EXTRA_STATES: usize = 8;

/// The names accepted by [`load_model`].
pub const MODEL_NAMES: [&str; 3] = rov_types::BaseModel::NAMES;

/// State of any model: η, ν (6-DOF layout) and extra states.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ModelState {
    /// η = [x, y, z, φ, θ, ψ] (m, rad; NED; ψ continuous).
    pub eta: Vector6,
    /// ν = [u, v, w, p, q, r] (m/s, rad/s; body).
    pub nu: Vector6,
    /// Extra states; a model uses the first [`VehicleModel::n_extra_states`].
    pub extra: [f64; MAX_EXTRA_STATES],
}

impl ModelState {
    /// From η and ν, no extra states.
    pub fn new(eta: Vector6, nu: Vector6) -> Self {
        Self {
            eta,
            nu,
            extra: [0.0; MAX_EXTRA_STATES],
        }
    }

    /// Whether every component is finite.
    pub fn is_finite(&self) -> bool {
        self.all_finite()
    }
}

impl StateVector for ModelState {
    #[inline]
    fn add_scaled(&self, d: &Self, h: f64) -> Self {
        let mut extra = self.extra;
        for (x, dx) in extra.iter_mut().zip(d.extra.iter()) {
            *x += dx * h;
        }
        Self {
            eta: self.eta + d.eta * h,
            nu: self.nu + d.nu * h,
            extra,
        }
    }

    #[inline]
    fn rk4_combine(&self, k1: &Self, k2: &Self, k3: &Self, k4: &Self, h: f64) -> Self {
        let s = h / 6.0;
        let mut extra = self.extra;
        for (i, x) in extra.iter_mut().enumerate() {
            *x += (k1.extra[i] + 2.0 * k2.extra[i] + 2.0 * k3.extra[i] + k4.extra[i]) * s;
        }
        Self {
            eta: self.eta + (k1.eta + k2.eta * 2.0 + k3.eta * 2.0 + k4.eta) * s,
            nu: self.nu + (k1.nu + k2.nu * 2.0 + k3.nu * 2.0 + k4.nu) * s,
            extra,
        }
    }

    fn all_finite(&self) -> bool {
        self.eta
            .iter()
            .chain(self.nu.iter())
            .chain(self.extra.iter())
            .all(|x| x.is_finite())
    }
}

/// A measured channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Channel {
    /// Depth of CO, m (down).
    Depth,
    /// Heading ψ, deg.
    Heading,
    /// Pitch θ, deg (nose up).
    Pitch,
    /// Roll φ, deg (starboard down).
    Roll,
    /// Surge u, m/s.
    Surge,
    /// Sway v, m/s.
    Sway,
    /// Heave w, m/s.
    Heave,
    /// Roll rate p, deg/s.
    RollRate,
    /// Pitch rate q, deg/s.
    PitchRate,
    /// Yaw rate r, deg/s.
    YawRate,
    /// North position x, m.
    North,
    /// East position y, m.
    East,
}

impl Channel {
    /// Every channel.
    pub const ALL: [Channel; 12] = [
        Channel::Depth,
        Channel::Heading,
        Channel::Pitch,
        Channel::Roll,
        Channel::Surge,
        Channel::Sway,
        Channel::Heave,
        Channel::RollRate,
        Channel::PitchRate,
        Channel::YawRate,
        Channel::North,
        Channel::East,
    ];

    /// The value of this channel in a state (SI except angles in degrees).
    pub fn value(self, s: &ModelState) -> f64 {
        match self {
            Channel::Depth => s.eta[2],
            Channel::Heading => s.eta[5].to_degrees(),
            Channel::Pitch => s.eta[4].to_degrees(),
            Channel::Roll => s.eta[3].to_degrees(),
            Channel::Surge => s.nu[0],
            Channel::Sway => s.nu[1],
            Channel::Heave => s.nu[2],
            Channel::RollRate => s.nu[3].to_degrees(),
            Channel::PitchRate => s.nu[4].to_degrees(),
            Channel::YawRate => s.nu[5].to_degrees(),
            Channel::North => s.eta[0],
            Channel::East => s.eta[1],
        }
    }

    /// Writes a measured value of this channel (units of [`Channel::value`]: SI, angles and
    /// angular rates in degrees) into its place in a state: the inverse of
    /// [`Channel::value`], the one measurement → state table (the lab's re-initialisation
    /// and its equation error use it).
    pub fn set_value(self, s: &mut ModelState, v: f64) {
        match self {
            Channel::Depth => s.eta[2] = v,
            Channel::Heading => s.eta[5] = v.to_radians(),
            Channel::Pitch => s.eta[4] = v.to_radians(),
            Channel::Roll => s.eta[3] = v.to_radians(),
            Channel::Surge => s.nu[0] = v,
            Channel::Sway => s.nu[1] = v,
            Channel::Heave => s.nu[2] = v,
            Channel::RollRate => s.nu[3] = v.to_radians(),
            Channel::PitchRate => s.nu[4] = v.to_radians(),
            Channel::YawRate => s.nu[5] = v.to_radians(),
            Channel::North => s.eta[0] = v,
            Channel::East => s.eta[1] = v,
        }
    }

    /// The measurement-CSV optional column of this channel, if it is one.
    pub fn optional_column(self) -> Option<OptionalChannel> {
        Some(match self {
            Channel::YawRate => OptionalChannel::YawRateDps,
            Channel::PitchRate => OptionalChannel::PitchRateDps,
            Channel::RollRate => OptionalChannel::RollRateDps,
            Channel::Surge => OptionalChannel::SurgeMps,
            Channel::Sway => OptionalChannel::SwayMps,
            Channel::Heave => OptionalChannel::HeaveMps,
            Channel::North => OptionalChannel::NorthM,
            Channel::East => OptionalChannel::EastM,
            Channel::Depth | Channel::Heading | Channel::Pitch | Channel::Roll => return None,
        })
    }
}

/// Model outputs at one time; `None` where the model does not predict the channel.
/// Heading is continuous (not wrapped): the measurement CSV accepts any wrap.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ModelOutput {
    /// Time, s.
    pub time_s: f64,
    /// Depth of CO, m.
    pub depth_m: Option<f64>,
    /// Heading, deg (continuous).
    pub heading_deg: Option<f64>,
    /// Pitch, deg, nose up.
    pub pitch_deg: Option<f64>,
    /// Roll, deg, starboard down.
    pub roll_deg: Option<f64>,
    /// Surge u, m/s.
    pub surge_mps: Option<f64>,
    /// Sway v, m/s.
    pub sway_mps: Option<f64>,
    /// Heave w, m/s.
    pub heave_mps: Option<f64>,
    /// Roll rate p, deg/s.
    pub roll_rate_dps: Option<f64>,
    /// Pitch rate q, deg/s.
    pub pitch_rate_dps: Option<f64>,
    /// Yaw rate r, deg/s.
    pub yaw_rate_dps: Option<f64>,
    /// North, m.
    pub north_m: Option<f64>,
    /// East, m.
    pub east_m: Option<f64>,
}

impl ModelOutput {
    /// Output of `state` keeping only the channels for which `predicts` is true.
    pub fn from_state(time_s: f64, state: &ModelState, predicts: impl Fn(Channel) -> bool) -> Self {
        let get = |ch: Channel| predicts(ch).then(|| ch.value(state));
        Self {
            time_s,
            depth_m: get(Channel::Depth),
            heading_deg: get(Channel::Heading),
            pitch_deg: get(Channel::Pitch),
            roll_deg: get(Channel::Roll),
            surge_mps: get(Channel::Surge),
            sway_mps: get(Channel::Sway),
            heave_mps: get(Channel::Heave),
            roll_rate_dps: get(Channel::RollRate),
            pitch_rate_dps: get(Channel::PitchRate),
            yaw_rate_dps: get(Channel::YawRate),
            north_m: get(Channel::North),
            east_m: get(Channel::East),
        }
    }

    /// One channel.
    pub fn get(&self, ch: Channel) -> Option<f64> {
        match ch {
            Channel::Depth => self.depth_m,
            Channel::Heading => self.heading_deg,
            Channel::Pitch => self.pitch_deg,
            Channel::Roll => self.roll_deg,
            Channel::Surge => self.surge_mps,
            Channel::Sway => self.sway_mps,
            Channel::Heave => self.heave_mps,
            Channel::RollRate => self.roll_rate_dps,
            Channel::PitchRate => self.pitch_rate_dps,
            Channel::YawRate => self.yaw_rate_dps,
            Channel::North => self.north_m,
            Channel::East => self.east_m,
        }
    }
}

/// Initial conditions, e.g. from a measured row. Angles in degrees as in the CSV.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct InitialConditions {
    /// Depth, m.
    pub depth_m: f64,
    /// Heading, deg.
    pub heading_deg: f64,
    /// Pitch, deg (nose up).
    pub pitch_deg: f64,
    /// Roll, deg (starboard down).
    pub roll_deg: f64,
    /// North, m (0 when unknown).
    pub north_m: f64,
    /// East, m (0 when unknown).
    pub east_m: f64,
    /// Surge, m/s.
    pub surge_mps: Option<f64>,
    /// Sway, m/s.
    pub sway_mps: Option<f64>,
    /// Heave, m/s.
    pub heave_mps: Option<f64>,
    /// Roll rate p, deg/s.
    pub roll_rate_dps: Option<f64>,
    /// Pitch rate q, deg/s.
    pub pitch_rate_dps: Option<f64>,
    /// Yaw rate r, deg/s.
    pub yaw_rate_dps: Option<f64>,
}

impl InitialConditions {
    /// At rest at a depth and heading, level.
    pub fn at_rest(depth_m: f64, heading_deg: f64) -> Self {
        Self {
            depth_m,
            heading_deg,
            ..Self::default()
        }
    }

    /// From a measured row: depth, heading, pitch and roll must be present (finite);
    /// missing (NaN or absent) optional velocities are taken as zero; missing north/east
    /// as zero.
    pub fn from_row(row: &MeasurementRow) -> Result<Self, DynamicsError> {
        for (name, v) in [
            ("depth_m", row.depth_m),
            ("heading_deg", row.heading_deg),
            ("pitch_deg", row.pitch_deg),
            ("roll_deg", row.roll_deg),
        ] {
            if !v.is_finite() {
                return Err(DynamicsError::InvalidInput {
                    detail: format!(
                        "initial row at t = {} s has {name} = {v}; a finite value is needed to start a model",
                        row.time_s
                    ),
                });
            }
        }
        let opt = |ch: OptionalChannel| row.get(ch).filter(|x| x.is_finite());
        Ok(Self {
            depth_m: row.depth_m,
            heading_deg: row.heading_deg,
            pitch_deg: row.pitch_deg,
            roll_deg: row.roll_deg,
            north_m: opt(OptionalChannel::NorthM).unwrap_or(0.0),
            east_m: opt(OptionalChannel::EastM).unwrap_or(0.0),
            surge_mps: opt(OptionalChannel::SurgeMps),
            sway_mps: opt(OptionalChannel::SwayMps),
            heave_mps: opt(OptionalChannel::HeaveMps),
            roll_rate_dps: opt(OptionalChannel::RollRateDps),
            pitch_rate_dps: opt(OptionalChannel::PitchRateDps),
            yaw_rate_dps: opt(OptionalChannel::YawRateDps),
        })
    }

    /// The full 6-DOF state.
    pub fn to_state(&self) -> ModelState {
        let eta = Vector6::new(
            self.north_m,
            self.east_m,
            self.depth_m,
            self.roll_deg.to_radians(),
            self.pitch_deg.to_radians(),
            self.heading_deg.to_radians(),
        );
        let nu = Vector6::new(
            self.surge_mps.unwrap_or(0.0),
            self.sway_mps.unwrap_or(0.0),
            self.heave_mps.unwrap_or(0.0),
            self.roll_rate_dps.unwrap_or(0.0).to_radians(),
            self.pitch_rate_dps.unwrap_or(0.0).to_radians(),
            self.yaw_rate_dps.unwrap_or(0.0).to_radians(),
        );
        ModelState::new(eta, nu)
    }
}

/// An external generalized force τ_ext(t, η, ν) in body axes about CO (e.g. a tether).
pub trait ExternalForce: fmt::Debug + Send + Sync {
    /// τ_ext, N and N m.
    fn tau_body(&self, time_s: f64, eta: &Vector6, nu: &Vector6) -> Vector6;
}

/// The environment during an integration step.
#[derive(Debug, Clone, Copy, Default)]
pub struct Environment<'a> {
    /// Current over the step.
    pub current: CurrentRamp,
    /// External force, if any.
    pub external: Option<&'a dyn ExternalForce>,
}

impl Environment<'_> {
    /// No current, no external force.
    pub fn calm() -> Self {
        Self::default()
    }

    /// A constant current.
    pub fn with_current(current: CurrentSample) -> Self {
        Self {
            current: CurrentRamp::constant(&current),
            external: None,
        }
    }

    /// The total generalized force at one instant: the thrust τ plus τ_ext, if any.
    #[inline]
    pub fn total_tau(
        &self,
        tau_thrust: &Vector6,
        time_s: f64,
        eta: &Vector6,
        nu: &Vector6,
    ) -> Vector6 {
        match self.external {
            Some(ext) => tau_thrust + ext.tau_body(time_s, eta, nu),
            None => *tau_thrust,
        }
    }
}

/// A vehicle model. See the module docs for the pipeline.
pub trait VehicleModel: fmt::Debug + Send + Sync {
    /// "model1", "model2", "model3" or an extension's name.
    fn name(&self) -> &str;

    /// Whether the model predicts a channel.
    fn predicts(&self, ch: Channel) -> bool;

    /// Stage (a): per-thruster force, N.
    fn thruster_forces(&self, cmd: &ThrustPct, state: &ModelState) -> ThrusterForces;

    /// Stage (b): generalized force τ from the thruster forces.
    fn generalized_force(&self, forces: &ThrusterForces, state: &ModelState) -> Vector6;

    /// Stage (c): the state derivative for the total force `tau` (thrust + τ_ext) and the
    /// current at this instant. Extra-state derivatives are left zero here.
    fn dynamics(&self, state: &ModelState, tau: &Vector6, current: &CurrentSample) -> ModelState;

    /// Stage (d): measured channels.
    fn outputs(&self, time_s: f64, state: &ModelState) -> ModelOutput {
        ModelOutput::from_state(time_s, state, |ch| self.predicts(ch))
    }

    /// Number of extra states used.
    fn n_extra_states(&self) -> usize {
        0
    }

    /// Adds the derivatives of extra states to `deriv` (default: none).
    fn extra_dynamics(
        &self,
        _time_s: f64,
        _state: &ModelState,
        _cmd: &ThrustPct,
        _deriv: &mut ModelState,
    ) {
    }

    /// The initial state for given conditions (models that do not model a DOF zero it).
    fn initial_state(&self, ic: &InitialConditions) -> ModelState {
        ic.to_state()
    }

    /// The full derivative: stages (a) → (b) → + τ_ext → (c) → extra states.
    #[inline]
    fn derivative(
        &self,
        time_s: f64,
        state: &ModelState,
        cmd: &ThrustPct,
        env: &Environment<'_>,
    ) -> ModelState {
        let forces = self.thruster_forces(cmd, state);
        let tau = env.total_tau(
            &self.generalized_force(&forces, state),
            time_s,
            &state.eta,
            &state.nu,
        );
        let mut d = self.dynamics(state, &tau, &env.current.at(time_s));
        self.extra_dynamics(time_s, state, cmd, &mut d);
        d
    }

    /// Whether stages (a) and (b) ignore the state and the model has no extra-state
    /// dynamics (models 1, 2 and 3), so that [`VehicleModel::rk4_step`] may compute the
    /// thrust once per step. Default: false.
    fn thrust_is_state_independent(&self) -> bool {
        false
    }

    /// One classical RK4 step of length `h_s` from `(t_s, state)` with `cmd` held over the
    /// step: the integrator of the simulator and [`advance`]. The default evaluates
    /// [`VehicleModel::derivative`] at the four stages, or goes through
    /// [`rk4_step_fixed_thrust`] (same result, thrust computed once) when
    /// [`VehicleModel::thrust_is_state_independent`].
    fn rk4_step(
        &self,
        t_s: f64,
        state: &ModelState,
        cmd: &ThrustPct,
        env: &Environment<'_>,
        h_s: f64,
    ) -> ModelState {
        if self.thrust_is_state_independent() {
            return rk4_step_fixed_thrust(self, t_s, state, cmd, env, h_s);
        }
        rk4_step(
            |tt, s: &ModelState| self.derivative(tt, s, cmd, env),
            t_s,
            state,
            h_s,
        )
    }

    /// The model reduced to the heave and yaw axes with its thrust path (dead zones, lags,
    /// per-sign maps, arms): what a depth and heading autopilot's feedforward and observer
    /// are built from. `None` (the default) for a model that cannot be reduced this way.
    fn plant(&self) -> Option<crate::plant::PlantDescription> {
        None
    }

    /// A boxed copy.
    fn clone_box(&self) -> Box<dyn VehicleModel>;

    /// For downcasting to the concrete model (e.g. to read its parameters).
    fn as_any(&self) -> &dyn Any;
}

impl Clone for Box<dyn VehicleModel> {
    fn clone(&self) -> Self {
        self.clone_box()
    }
}

/// [`VehicleModel::rk4_step`] for a model whose stages (a) and (b) ignore the state and
/// which has no extra-state dynamics (models 1 and 2; model 3 has its own 12-state
/// version of the same step): the thrust τ is computed once
/// per step instead of at each of the four stages. τ_ext and the current are still
/// evaluated at every stage, so the result is identical to the generic step.
#[inline]
pub fn rk4_step_fixed_thrust<M: VehicleModel + ?Sized>(
    model: &M,
    t_s: f64,
    state: &ModelState,
    cmd: &ThrustPct,
    env: &Environment<'_>,
    h_s: f64,
) -> ModelState {
    let tau_thrust = model.generalized_force(&model.thruster_forces(cmd, state), state);
    rk4_step(
        |tt, s: &ModelState| {
            let tau = env.total_tau(&tau_thrust, tt, &s.eta, &s.nu);
            model.dynamics(s, &tau, &env.current.at(tt))
        },
        t_s,
        state,
        h_s,
    )
}

/// Integrates `state` from `t0_s` over `duration_s` with command `cmd` held, in equal RK4
/// sub-steps of at most `dt_max_s`. Stops with [`DynamicsError::NonFinite`] when the
/// state stops being finite.
pub fn advance(
    model: &dyn VehicleModel,
    state: &ModelState,
    t0_s: f64,
    duration_s: f64,
    cmd: &ThrustPct,
    dt_max_s: f64,
    env: &Environment<'_>,
) -> Result<ModelState, DynamicsError> {
    if duration_s <= 0.0 {
        return Ok(*state);
    }
    let n = ((duration_s / dt_max_s) - 1e-9).ceil().max(1.0) as usize;
    let h = duration_s / n as f64;
    let mut x = *state;
    for i in 0..n {
        let t = t0_s + i as f64 * h;
        x = model.rk4_step(t, &x, cmd, env, h);
        if !x.all_finite() {
            return Err(DynamicsError::NonFinite {
                time_s: t + h,
                state: format!(
                    "{} state eta = {:?}, nu = {:?}",
                    model.name(),
                    x.eta.as_slice(),
                    x.nu.as_slice()
                ),
            });
        }
    }
    Ok(x)
}

/// Runs a model over timed inputs (t_k, command_k) with the measurement-CSV timing rule
/// (see the module docs). Returns one output per input row.
pub fn simulate(
    model: &dyn VehicleModel,
    initial_state: &ModelState,
    inputs: &[(f64, ThrustPct)],
    dt_max_s: f64,
) -> Result<Vec<ModelOutput>, DynamicsError> {
    simulate_in(model, initial_state, inputs, dt_max_s, &Environment::calm())
}

/// [`simulate`] in a given environment (constant current ramp, external force).
pub fn simulate_in(
    model: &dyn VehicleModel,
    initial_state: &ModelState,
    inputs: &[(f64, ThrustPct)],
    dt_max_s: f64,
    env: &Environment<'_>,
) -> Result<Vec<ModelOutput>, DynamicsError> {
    if !(dt_max_s.is_finite() && dt_max_s > 0.0) {
        return Err(DynamicsError::InvalidInput {
            detail: format!("dt_max_s = {dt_max_s} must be finite and > 0"),
        });
    }
    for (k, (t, cmd)) in inputs.iter().enumerate() {
        if !t.is_finite() {
            return Err(DynamicsError::InvalidInput {
                detail: format!("input {k}: time {t} is not finite"),
            });
        }
        if !cmd.is_valid() {
            return Err(DynamicsError::InvalidInput {
                detail: format!(
                    "input {k} at t = {t} s: command {cmd:?} must be finite and within -100..=100 %"
                ),
            });
        }
        if k > 0 && inputs.get(k - 1).is_some_and(|(tp, _)| *t <= *tp) {
            return Err(DynamicsError::InvalidInput {
                detail: format!("input {k}: time {t} s does not increase"),
            });
        }
    }
    let t0 = inputs.first().map_or(0.0, |(t, _)| *t);
    if !initial_state.all_finite() {
        return Err(DynamicsError::NonFinite {
            time_s: t0,
            state: format!(
                "initial {} state eta = {:?}, nu = {:?}",
                model.name(),
                initial_state.eta.as_slice(),
                initial_state.nu.as_slice()
            ),
        });
    }
    let mut out = Vec::with_capacity(inputs.len());
    let mut x = *initial_state;
    for (k, (t, cmd)) in inputs.iter().enumerate() {
        out.push(model.outputs(*t, &x));
        if let Some((t_next, _)) = inputs.get(k + 1) {
            x = advance(model, &x, *t, t_next - t, cmd, dt_max_s, env)?;
        }
    }
    Ok(out)
}

/// The parameter file text shipped in `config/models/` for a model name.
pub fn default_model_text(name: &str) -> Option<&'static str> {
    match name {
        "model1" => Some(include_str!("../../../../config/models/model1.toml")),
        "model2" => Some(include_str!("../../../../config/models/model2.toml")),
        "model3" => Some(include_str!("../../../../config/models/model3.toml")),
        _ => None,
    }
}

/// Loads a model by name from parameter-file text (`file_label` names the file in
/// errors). Every parameter must carry a unit and a source; unknown keys are rejected.
pub fn load_model(
    name: &str,
    text: &str,
    file_label: &str,
) -> Result<Box<dyn VehicleModel>, ConfigError> {
    let pf = ParamFile::parse(text, file_label, true)?;
    if !MODEL_NAMES.contains(&name) {
        return Err(ConfigError::OutOfRange {
            file: file_label.to_string(),
            key: "model".into(),
            value: format!("{name:?}"),
            allowed: format!("one of {}", MODEL_NAMES.join(", ")),
        });
    }
    let declared = pf.choice("model", &MODEL_NAMES, None)?;
    if declared != name {
        return Err(ConfigError::Inconsistent {
            file: file_label.to_string(),
            message: format!("key model = {declared:?} but the file was loaded as {name:?}"),
        });
    }
    pf.string_or("description", "")?;
    let model: Box<dyn VehicleModel> = match name {
        "model1" => Box::new(Model1::new(Model1Params::from_params(&pf)?)),
        "model2" => Box::new(Model2::new(Model2Params::from_params(&pf)?)),
        _ => Box::new(Model3::new(Model3Params::from_params(&pf)?).map_err(|e| {
            ConfigError::Inconsistent {
                file: file_label.to_string(),
                message: e.to_string(),
            }
        })?),
    };
    pf.reject_unknown("")?;
    Ok(model)
}

/// Loads a model from the parameter file shipped in `config/models/`.
pub fn load_default_model(name: &str) -> Result<Box<dyn VehicleModel>, ConfigError> {
    let text = default_model_text(name).ok_or_else(|| ConfigError::OutOfRange {
        file: "config/models".into(),
        key: "model".into(),
        value: format!("{name:?}"),
        allowed: format!("one of {}", MODEL_NAMES.join(", ")),
    })?;
    load_model(name, text, &format!("config/models/{name}.toml"))
}
