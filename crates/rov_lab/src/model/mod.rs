//! The lab model: a base (model1, model2, model3 or a vehicle definition file) with
//! calibrated thrust scales and damping, plus any catalog effects and discovered terms,
//! behind [`VehicleModel`] so that `sim`, `hold` and the lab load it like any model.
//!
//! # Files
//!
//! * [`base`]: the [`BaseModel`](base) trait and one file per base — everything that
//!   differs between bases (parameters, dynamics, channels, thrusters, name).
//! * this file: [`LabModel`] (a base plus the layers on top), its parameters and the
//!   thrust path.
//! * `effects.rs`: the catalog effects' values and their body forces, current and sensor
//!   model.
//! * `discovered.rs`: the discovered terms and their filtered commands.
//! * `vehicle_model.rs`: [`LabModel`] as a [`VehicleModel`].
//! * Saving and loading: [`crate::persist`].
//!
//! # Layers
//!
//! * Commands (stage 0): the run's command signals ([`Commands`], percent). The Pro 4
//!   bases read the port, starboard and vertical channels as their three thrusters; a
//!   vehicle file mixes its command channels into its thrusters
//!   ([`VehicleDef::thruster_commands`]).
//! * Thrust (stage a): per thruster F = k_l A(u) + k_q B(u) with the base's own curve (A,
//!   B: the linear and quadratic parts, or a table) and the calibrated scales (k_l, k_q) of
//!   the thruster's group; the dead zone shifts u, the asymmetry scales reverse thrust, the
//!   power limit scales all of them.
//! * Generalized force (stage b): the base's allocation (a vehicle's thruster positions
//!   and directions), plus the Pro 4's moment arms and propeller reaction torques.
//! * Dynamics (stage c): the base's dynamics with extra body forces (net buoyancy for
//!   model1, tether, asymmetric drag, discovered terms) and the effect's current; for
//!   models without pitch the trim angle of `pitch-depth-coupling` enters the depth
//!   kinematics.
//! * Outputs (stage d): depth drift, compass deviation and interference, attitude biases.
//!
//! Thruster lag: in [`VehicleModel`] form it is one extra state per thruster with
//! ȧ = (u − a)/τ (τ → 0 switches it off). The lab's own simulator ([`crate::sim`]) updates
//! the lag exactly on the held command instead, which stays valid for τ → 0.

mod base;
mod discovered;
mod effects;
mod vehicle_model;

use rov_dynamics::Vector6;
use rov_dynamics::kinematics::QuatState;
use rov_dynamics::models::vehicle::{
    ChannelTable, CommandChannel, Commands, MAX_THRUSTERS, VehicleDef,
};
use rov_dynamics::models::{Channel, ModelState, ThrusterForces};
use rov_dynamics::process::CurrentSample;
use rov_dynamics::thrusters::ThrustPct;

use crate::LabError;
use crate::catalog::EffectId;
use crate::params::{Axis, Param, Thr};
use crate::terms::Term;
use base::{Base, BaseModel, ThrustScales, on_base};

pub use base::BaseKind;
pub use effects::{EffectValues, N_GROUPS, TETHER_ATTACH_X_M};

/// Most filtered-command signals a model's terms may use.
pub const MAX_FILTERS: usize = 4;

/// Most command signals a model hands its terms and the verdict's input tests
/// ([`LabModel::command_signals`]): the first ten of its channels (a vehicle file that
/// mixes more channels drives its thrusters from all of them; only the terms and the
/// input-correlation tests see the first ten). Sized as the ten built-in channels so the
/// simulators' per-sample copies stay as small as before free channel names.
pub const MAX_SIGNALS: usize = rov_dynamics::models::vehicle::N_BUILTIN;

/// A model's command signals (fractions of full command, in its channel order).
pub type Signals = [f64; MAX_SIGNALS];

/// Per-thruster thrust values (N) or commands (%), up to [`MAX_THRUSTERS`].
pub type PerThruster = [f64; MAX_THRUSTERS];

/// A base model with calibration, effects and discovered terms.
#[derive(Debug, Clone)]
pub struct LabModel {
    base: Base,
    base_text: String,
    /// Thrusters: count and calibration group of each (the base's, kept for the hot
    /// paths).
    n_thr: usize,
    thr_group: [Thr; MAX_THRUSTERS],
    /// Calibrated scales per thruster group.
    thrust_lin: [f64; N_GROUPS],
    thrust_quad: [f64; N_GROUPS],
    fx: EffectValues,
    active: Vec<EffectId>,
    terms: Vec<Term>,
    /// (command index, filter index) of the filtered-command signals the terms use.
    filters: Vec<(u8, u8)>,
    name: String,
    drag_tau_factor: [f64; 6],
    has_sensor_fx: bool,
    has_body_fx: bool,
    /// The base file's own values of the base parameters (the priors' means).
    nominal: Vec<(Param, f64)>,
}

/// Whether the base holds a parameter's value (the others are thrust scales, effect
/// values and term coefficients, which the layers on top hold).
fn held_by_base(p: Param) -> bool {
    matches!(
        p,
        Param::DragLin(_)
            | Param::DragQuad(_)
            | Param::CgX
            | Param::CgY
            | Param::CgZ
            | Param::NetWeight
            | Param::AddedMass(_)
            | Param::CommandGain
    )
}

impl LabModel {
    /// A model of a base, without calibration, effects or terms.
    fn of_base(base: Base, base_text: &str) -> Self {
        let (n_thr, thr_group) = base.model().thrusters();
        let drag_tau_factor = base.model().drag_tau_factor();
        let mut m = Self {
            base,
            base_text: base_text.to_string(),
            n_thr,
            thr_group,
            thrust_lin: [1.0; N_GROUPS],
            thrust_quad: [1.0; N_GROUPS],
            fx: EffectValues::default(),
            active: Vec::new(),
            terms: Vec::new(),
            filters: Vec::new(),
            name: String::new(),
            drag_tau_factor,
            has_sensor_fx: false,
            has_body_fx: false,
            nominal: Vec::new(),
        };
        m.refresh_name();
        m.record_nominal()
    }

    /// Records the base parameters' current values as the nominal ones.
    fn record_nominal(mut self) -> Self {
        self.nominal = Param::all()
            .into_iter()
            .filter(|p| {
                p.off_value().is_none() || matches!(p, Param::NetWeight | Param::CgX | Param::CgY)
            })
            .filter_map(|p| self.get(p).map(|v| (p, v)))
            .collect();
        self
    }

    /// The base file's own value of a base parameter (thrust scales: 1).
    pub fn nominal(&self, p: Param) -> Option<f64> {
        self.nominal.iter().find(|(q, _)| *q == p).map(|(_, v)| *v)
    }

    /// The documented prior of a base parameter: (mean = the base file's value, σ)
    /// (`None` for effect parameters). Pro 4 bases: [`crate::params::documented_pro4`];
    /// vehicle files: their `[uncertainty]` table.
    pub fn prior_of(&self, p: Param) -> Option<(f64, f64)> {
        use crate::params::Documented;
        let base = self.base.model();
        if matches!(
            p,
            Param::ArmZh | Param::ArmXv | Param::ArmYv | Param::ArmXh | Param::ArmYh
        ) && base.arms_calibrated()
        {
            return Some((0.0, base.arms_sigma_m()?));
        }
        let mean = self.nominal(p)?;
        let sigma = match base.documented(p)? {
            Documented::Rel(r) => (r * mean.abs()).max(p.meta().scale),
            Documented::Abs(a) => a.max(1e-9),
        };
        Some((mean, sigma))
    }

    /// From a base model's parameter-file text (`label` names it in errors).
    pub fn from_base_text(kind: BaseKind, text: &str, label: &str) -> Result<Self, LabError> {
        Ok(Self::of_base(Base::from_text(kind, text, label)?, text))
    }

    /// From a vehicle definition file's text (see [`rov_dynamics::models::vehicle`]).
    pub fn from_vehicle_text(text: &str, label: &str) -> Result<Self, LabError> {
        Self::from_base_text(BaseKind::Vehicle, text, label)
    }

    /// A shipped base model (`config/models/`).
    pub fn default_base(kind: BaseKind) -> Result<Self, LabError> {
        let text = rov_dynamics::models::default_model_text(kind.name()).ok_or_else(|| {
            LabError::UnknownModel {
                name: kind.name().into(),
            }
        })?;
        Self::from_base_text(kind, text, &format!("config/models/{}.toml", kind.name()))
    }

    /// The vehicle's weight W, N.
    pub fn weight_n(&self) -> f64 {
        self.base.model().weight_n()
    }

    /// The base kind.
    pub fn kind(&self) -> BaseKind {
        self.base.model().kind()
    }

    /// The base's name: "model1" … or the vehicle file's `vehicle`.
    pub fn base_name(&self) -> &str {
        self.base.model().name()
    }

    /// The vehicle definition of a vehicle-file base.
    pub fn vehicle(&self) -> Option<&VehicleDef> {
        self.base.model().vehicle()
    }

    /// The base parameter-file text this model was built from.
    pub fn base_text(&self) -> &str {
        &self.base_text
    }

    /// Effects added to the base (in order of addition).
    pub fn active_effects(&self) -> &[EffectId] {
        &self.active
    }

    /// Whether the model has pitch and roll.
    pub fn has_attitude(&self) -> bool {
        self.base.model().has_attitude()
    }

    /// Which of ν = (u, v, w, p, q, r) the model's state can move.
    pub fn nu_active(&self) -> [bool; 6] {
        self.base.model().nu_active()
    }

    /// Whether the base already contains an effect.
    pub fn contains(&self, e: EffectId) -> bool {
        self.base.model().contains(e)
    }

    /// Why an effect cannot be represented in this model, if so.
    pub fn not_applicable(&self, e: EffectId) -> Option<&'static str> {
        self.base.model().not_applicable(e)
    }

    /// The base parameters that calibration frees.
    pub fn calibration_params(&self) -> Vec<Param> {
        self.base.model().calibration_params()
    }

    /// Marks an effect as part of the model (its parameters keep their values). A
    /// contained effect is not added (its parameters are base parameters).
    pub fn add_effect(&mut self, e: EffectId) {
        if !self.contains(e) && !self.active.contains(&e) {
            self.active.push(e);
        }
        self.refresh_name();
    }

    /// The model's name (base, effects, terms) and which layers are on.
    fn refresh_name(&mut self) {
        let mut n = self.base_name().to_string();
        for e in &self.active {
            n.push('+');
            n.push_str(e.key());
        }
        let names = self.command_names();
        for t in &self.terms {
            n.push('+');
            n.push_str(&t.id(&names));
        }
        self.name = n;
        self.has_sensor_fx = self.fx.any_sensor();
        self.has_body_fx = self.base.model().lab_heave_force_n() != 0.0
            || self.fx.any_body()
            || !self.terms.is_empty();
    }

    /// Number of thrusters.
    pub fn n_thrusters(&self) -> usize {
        self.n_thr
    }

    /// The calibration group of thruster `i`.
    pub fn thruster_group(&self, i: usize) -> Thr {
        self.thr_group.get(i).copied().unwrap_or(Thr::Port)
    }

    /// Whether some thruster belongs to a group.
    pub fn has_group(&self, g: Thr) -> bool {
        self.thr_group[..self.n_thr].contains(&g)
    }

    /// The command channels the model reads.
    pub fn command_channels(&self) -> Vec<CommandChannel> {
        self.base.model().command_channels().to_vec()
    }

    /// The model's channel table: the names of a vehicle file's free channels (none for
    /// the Pro 4 models). Runs are re-indexed to it ([`crate::data::Run::align_channels`]).
    pub fn channel_table(&self) -> &ChannelTable {
        self.base.model().channel_table()
    }

    /// [`LabModel::command_names`] owned (for callers that change the model meanwhile).
    pub fn command_names_owned(&self) -> Vec<String> {
        self.command_names()
            .into_iter()
            .map(str::to_string)
            .collect()
    }

    /// Names of the model's command signals (terms' `cmd_NAME`; at most [`MAX_SIGNALS`]).
    pub fn command_names(&self) -> Vec<&str> {
        self.base.model().command_names()
    }

    /// The model's command signals (fractions of full command) from a command vector.
    #[inline]
    pub fn command_signals(&self, c: &Commands) -> Signals {
        self.base.model().command_signals(c)
    }

    /// Thruster commands (%) for a command vector (the mix of a vehicle file; the Pro 4's
    /// port, starboard and vertical channels otherwise).
    #[inline]
    pub fn thruster_targets(&self, c: &Commands) -> PerThruster {
        self.base.model().thruster_targets(c)
    }

    /// The step of the commands the vehicle receives, % (`None` where the base documents
    /// none: vehicle files).
    pub fn command_resolution_pct(&self) -> Option<f64> {
        self.base.model().command_resolution_pct()
    }

    /// Lag time constant of each thruster, s: the vehicle file's own lag plus the
    /// `thruster-lag` effect's.
    pub fn lag_taus(&self) -> PerThruster {
        let mut out = [self.fx.lag_tau_s; MAX_THRUSTERS];
        self.base.model().add_thruster_lags(&mut out);
        out
    }

    /// Whether any thruster lags.
    pub fn lag_on(&self) -> bool {
        self.lag_taus()[..self.n_thr].iter().any(|t| *t > 1e-4)
    }

    /// Whether a parameter exists in this model.
    pub fn applicable(&self, p: Param) -> bool {
        match p {
            Param::TermCoef(i, _) => (i as usize) < self.terms.len(),
            _ => self.base.model().applicable(p),
        }
    }

    /// A parameter's value (`None` if not applicable).
    pub fn get(&self, p: Param) -> Option<f64> {
        if !self.applicable(p) {
            return None;
        }
        match p {
            Param::ThrustLin(t) => Some(self.thrust_lin[t.index()]),
            Param::ThrustQuad(t) => Some(self.thrust_quad[t.index()]),
            Param::TermCoef(i, _) => {
                let t = self.terms.get(i as usize)?;
                Some(t.coef * t.scale)
            }
            _ if held_by_base(p) => self.base.model().get(p),
            _ => self.fx.get(p),
        }
    }

    /// A copy with parameters set (clamped to their bounds); the base is rebuilt once.
    pub fn with(&self, params: &[Param], values: &[f64]) -> Result<Self, LabError> {
        let mut m = self.clone();
        m.set_many(params, values)?;
        Ok(m)
    }

    /// Sets parameters (clamped to bounds) and rebuilds the base once.
    pub fn set_many(&mut self, params: &[Param], values: &[f64]) -> Result<(), LabError> {
        let mut for_base = Vec::new();
        for (p, v) in params.iter().zip(values) {
            if !self.applicable(*p) || !v.is_finite() {
                continue;
            }
            let meta = p.meta();
            let v = v.clamp(meta.lo, meta.hi);
            match p {
                Param::ThrustLin(t) => self.thrust_lin[t.index()] = v,
                Param::ThrustQuad(t) => self.thrust_quad[t.index()] = v,
                Param::TermCoef(i, _) => {
                    if let Some(t) = self.terms.get_mut(*i as usize)
                        && t.scale > 0.0
                    {
                        t.coef = v / t.scale;
                    }
                }
                _ if held_by_base(*p) => for_base.push((*p, v)),
                _ => self.fx.set(*p, v),
            }
        }
        self.base.model_mut().set_many(&for_base)?;
        self.refresh_name();
        Ok(())
    }

    /// Current values of a parameter list (off/0 for inapplicable ones).
    pub fn values(&self, params: &[Param]) -> Vec<f64> {
        params
            .iter()
            .map(|p| self.get(*p).or_else(|| p.off_value()).unwrap_or(0.0))
            .collect()
    }

    /// (linear, quadratic) damping of the base on an axis.
    fn drag(&self, a: Axis) -> (f64, f64) {
        self.base.model().drag(a)
    }

    /// Thrust of thruster `i` for a command in percent (before the power limit), N.
    #[inline]
    pub fn thrust_n(&self, i: usize, pct: f64) -> f64 {
        // The dead zone (an effect) reshapes the command before the thrust map.
        let dz = self.fx.deadzone;
        let pct = if dz > 0.0 {
            let u = pct * 0.01;
            let a = (u.abs() - dz).max(0.0) / (1.0 - dz);
            100.0 * if u < 0.0 { -a } else { a }
        } else {
            pct
        };
        let g = self.thruster_group(i).index();
        let scales = ThrustScales {
            lin: self.thrust_lin[g],
            quad: self.thrust_quad[g],
            reverse_ratio: self.fx.reverse_ratio[g],
        };
        on_base!(&self.base, b => b.thrust_n(i, pct, scales))
    }

    /// Per-thruster forces for thruster commands in percent (after the power limit), N.
    #[inline]
    pub fn thrusts(&self, pct: &PerThruster) -> PerThruster {
        let mut f = [0.0; MAX_THRUSTERS];
        for (i, x) in f.iter_mut().enumerate().take(self.n_thr) {
            *x = self.thrust_n(i, pct[i]);
        }
        let pmax = self.fx.power_max;
        if pmax < 3.0 {
            // Σ|u|³ in three-thruster equivalents (the Pro 4's scale; 3 never limits).
            let norm = 3.0 / self.n_thr.max(1) as f64;
            let demand = norm
                * pct[..self.n_thr]
                    .iter()
                    .map(|x| (x * 0.01).abs().powi(3))
                    .sum::<f64>();
            if demand > pmax {
                let s = pmax / demand;
                for x in &mut f {
                    *x *= s;
                }
            }
        }
        f
    }

    /// Per-thruster forces for a Pro 4 command (after the power limit).
    pub fn forces(&self, cmd: &ThrustPct) -> ThrusterForces {
        let c = Self::commands_of(cmd);
        let f = self.thrusts(&self.thruster_targets(&c));
        ThrusterForces {
            port_n: f[0],
            starboard_n: f[1],
            vertical_n: f[2],
        }
    }

    /// τ of the thrusters: the base allocation plus arms and reaction torques. No lab base
    /// reads `state` here (the simulator relies on it to reuse τ while the commands are
    /// held; a test checks it for every base).
    #[inline]
    pub fn thrust_tau(&self, f: &PerThruster, state: &ModelState) -> Vector6 {
        on_base!(&self.base, b => b.thrust_tau(self, f, state))
    }

    /// (η̇, ν̇) for a given τ of the thrusters and terms: the hot path of the lab's
    /// simulator.
    #[inline]
    pub fn eta_nu_derivative(
        &self,
        eta: &Vector6,
        nu: &Vector6,
        tau_thrust: &Vector6,
        current: &CurrentSample,
    ) -> (Vector6, Vector6) {
        on_base!(&self.base, b => b.eta_nu_derivative(self, eta, nu, tau_thrust, current))
    }

    /// State derivative for a τ of the thrusters and terms (without extra states).
    #[inline]
    pub fn body_derivative(
        &self,
        state: &ModelState,
        tau_thrust: &Vector6,
        current: &CurrentSample,
    ) -> ModelState {
        on_base!(&self.base, b => b.body_derivative(self, state, tau_thrust, current))
    }

    /// The quaternion-state derivative of a 6-DOF vehicle-file base for a τ of the
    /// thrusters and terms (`None` for the other bases); `yaw_hint_rad` picks the heading
    /// branch of the Euler angles the effects see.
    #[inline]
    pub fn quat_derivative(
        &self,
        x: &QuatState,
        tau_thrust: &Vector6,
        current: &CurrentSample,
        yaw_hint_rad: f64,
    ) -> Option<QuatState> {
        on_base!(&self.base, b => b.quat_derivative(self, x, tau_thrust, current, yaw_hint_rad))
    }

    /// Whether the lab's simulator integrates this model's attitude with quaternions (a
    /// 6-DOF vehicle file: tank vehicles roll over and pitch past 80°).
    pub fn uses_quaternion(&self) -> bool {
        self.base.model().uses_quaternion()
    }

    /// Whether the model predicts a channel.
    pub fn predicts_channel(&self, ch: Channel) -> bool {
        self.base.model().predicts(ch)
    }

    /// Keeps only the DOFs the base has.
    pub fn restrict_state(&self, mut s: ModelState) -> ModelState {
        let a = self.nu_active();
        for (i, on) in a.iter().enumerate() {
            if !on {
                s.nu[i] = 0.0;
            }
        }
        if !a[3] {
            s.eta[3] = 0.0;
        }
        if !a[4] {
            s.eta[4] = 0.0;
        }
        s
    }

    /// A Pro 4 command as a command vector.
    pub fn commands_of(cmd: &ThrustPct) -> Commands {
        crate::data::commands_of_pct(cmd)
    }
}
