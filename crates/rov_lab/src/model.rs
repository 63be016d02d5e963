//! The lab model: a base (model1, model2, model3 or a vehicle definition file) with
//! calibrated thrust scales and damping, plus any catalog effects and discovered terms,
//! behind [`VehicleModel`] so that `sim`, `hold` and the lab load it like any model.
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

use std::any::Any;

use rov_dynamics::Vector6;
use rov_dynamics::kinematics::{Attitude, QuatState, unpack_quat_state};
use rov_dynamics::models::vehicle::{
    ChannelTable, CommandChannel, Commands, MAX_THRUSTERS, Structure, VehicleDef, VehicleDynamics,
};
use rov_dynamics::models::{
    Channel, Environment, InitialConditions, Model1, Model2, Model3, ModelOutput, ModelState,
    ThrusterForces, VehicleModel, load_model,
};
use rov_dynamics::plant::{PathEffects, PlantDescription};
use rov_dynamics::process::CurrentSample;
use rov_dynamics::thrusters::{QuadraticThrustMap, ThrustMap, ThrustPair, ThrustPct};

use crate::LabError;
use crate::catalog::EffectId;
use crate::params::{Axis, Param, Thr};
use crate::terms::{FILTER_TAUS_S, Term, TermInputs};

/// Tether attachment point from the CO (body axes), m: behind the hull on its axis.
pub const TETHER_ATTACH_X_M: f64 = -0.2;

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

/// Which base model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum BaseKind {
    /// Enevoldsen et al. 2018, decoupled 3-DOF.
    Model1,
    /// Arnesen 2016, Fossen 3-DOF.
    Model2,
    /// Mai et al. 2017, Fossen 6-DOF.
    Model3,
    /// A vehicle definition file (`config/vehicles/`).
    Vehicle,
}

impl From<rov_types::model_id::BaseModel> for BaseKind {
    fn from(b: rov_types::model_id::BaseModel) -> Self {
        use rov_types::model_id::BaseModel;
        match b {
            BaseModel::Model1 => BaseKind::Model1,
            BaseModel::Model2 => BaseKind::Model2,
            BaseModel::Model3 => BaseKind::Model3,
        }
    }
}

impl BaseKind {
    /// The three Pro 4 models.
    pub const ALL: [BaseKind; 3] = [BaseKind::Model1, BaseKind::Model2, BaseKind::Model3];

    /// "model1" …
    pub fn name(self) -> &'static str {
        match self {
            BaseKind::Model1 => "model1",
            BaseKind::Model2 => "model2",
            BaseKind::Model3 => "model3",
            BaseKind::Vehicle => "vehicle",
        }
    }

    /// Parses a Pro 4 base name through the one model identity
    /// ([`rov_types::model_id::BaseModel`]).
    pub fn parse(s: &str) -> Option<Self> {
        rov_types::model_id::BaseModel::from_name(s).map(Self::from)
    }

    /// Whether the base has pitch and roll (a vehicle file: see [`LabModel::has_attitude`]).
    pub fn has_attitude(self) -> bool {
        matches!(self, BaseKind::Model3 | BaseKind::Vehicle)
    }

    /// Effects the base already contains (see [`crate::catalog`]).
    pub fn contains(self, e: EffectId) -> bool {
        match self {
            BaseKind::Model1 => matches!(e, EffectId::AddedMass),
            BaseKind::Model2 => matches!(
                e,
                EffectId::AddedMass | EffectId::NetBuoyancy | EffectId::Coriolis
            ),
            BaseKind::Model3 | BaseKind::Vehicle => matches!(
                e,
                EffectId::AddedMass
                    | EffectId::NetBuoyancy
                    | EffectId::Coriolis
                    | EffectId::RestoringOffset
                    | EffectId::PitchDepthCoupling
            ),
        }
    }

    /// Why an effect cannot be represented in this base at all (it acts only through
    /// states the base does not have), if so.
    pub fn not_applicable(self, e: EffectId) -> Option<&'static str> {
        if self == BaseKind::Vehicle {
            return match e {
                EffectId::PropellerTorque => Some(
                    "its parameters are the Pro 4's vertical and horizontal thruster torques; a vehicle file has its own thruster layout",
                ),
                _ => None,
            };
        }
        if self.has_attitude() {
            return None;
        }
        match e {
            EffectId::ThrusterMomentArm => Some(
                "its moments act on pitch and roll, which this model does not have (use model3)",
            ),
            EffectId::RestoringOffset => {
                Some("it acts on pitch and roll, which this model does not have (use model3)")
            }
            EffectId::AttitudeBias => {
                Some("it offsets pitch and roll, which this model does not predict (use model3)")
            }
            EffectId::Coriolis => Some(
                "its terms act through sway, roll and pitch, which this model does not have (use model3)",
            ),
            _ => None,
        }
    }

    /// The base parameters that calibration frees (four-channel data) for the Pro 4
    /// bases (a vehicle file: [`LabModel::calibration_params`]).
    pub fn calibration_params(self) -> Vec<Param> {
        let mut v = Vec::new();
        for t in [Thr::Port, Thr::Starboard, Thr::Vertical] {
            v.push(Param::ThrustLin(t));
            if self != BaseKind::Model2 {
                v.push(Param::ThrustQuad(t));
            }
        }
        for a in [Axis::Heave, Axis::Yaw] {
            v.push(Param::DragLin(a));
            v.push(Param::DragQuad(a));
        }
        if self == BaseKind::Model3 {
            v.push(Param::DragLin(Axis::Roll));
            v.push(Param::DragLin(Axis::Pitch));
            v.push(Param::CgZ);
            // Sway, roll and pitch added mass shape the 6-DOF coupling (heel and yaw in
            // turns); they are not scale-ambiguous like heave and yaw, which stay fixed.
            v.push(Param::AddedMass(Axis::Sway));
            v.push(Param::AddedMass(Axis::Roll));
            v.push(Param::AddedMass(Axis::Pitch));
        }
        v
    }
}

/// Number of thruster groups ([`Thr::ALL`]).
pub const N_GROUPS: usize = 5;

/// Values of every effect parameter (off values when an effect is absent).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EffectValues {
    /// Reverse/forward thrust ratio per thruster group.
    pub reverse_ratio: [f64; N_GROUPS],
    /// Lag time constant, s.
    pub lag_tau_s: f64,
    /// Dead zone, fraction of full command.
    pub deadzone: f64,
    /// Power budget in Σ|u|³ units (three-thruster equivalents).
    pub power_max: f64,
    /// Horizontal line of action below CO, m.
    pub arm_zh_m: f64,
    /// Vertical thruster forward of CO, m.
    pub arm_xv_m: f64,
    /// Vertical thruster to starboard of CO, m.
    pub arm_yv_m: f64,
    /// A vehicle's non-vertical thrusters shifted forward, m.
    pub arm_xh_m: f64,
    /// A vehicle's non-vertical thrusters shifted to starboard, m.
    pub arm_yh_m: f64,
    /// Vertical reaction torque per N, m.
    pub torque_v_m: f64,
    /// Horizontal differential reaction roll torque per N, m.
    pub torque_h_m: f64,
    /// model1's W − B, N.
    pub net_weight_m1_n: f64,
    /// Trim for the depth kinematics (models without pitch), rad.
    pub trim_rad: f64,
    /// Reverse/forward quadratic drag ratio per axis.
    pub drag_ratio: [f64; 6],
    /// Current (north, east), m/s.
    pub current_ne_mps: [f64; 2],
    /// Tether pull (north, east), N.
    pub tether_ne_n: [f64; 2],
    /// Depth drift, m/s.
    pub depth_drift_mps: f64,
    /// Compass deviation (sin, cos), deg.
    pub compass_dev_deg: [f64; 2],
    /// Compass interference per unit |u| of a thruster group, deg.
    pub emi_deg: [f64; N_GROUPS],
    /// Roll bias, deg.
    pub bias_roll_deg: f64,
    /// Pitch bias, deg.
    pub bias_pitch_deg: f64,
}

impl Default for EffectValues {
    fn default() -> Self {
        Self {
            reverse_ratio: [1.0; N_GROUPS],
            lag_tau_s: 0.0,
            deadzone: 0.0,
            power_max: 3.0,
            arm_zh_m: 0.0,
            arm_xv_m: 0.0,
            arm_yv_m: 0.0,
            arm_xh_m: 0.0,
            arm_yh_m: 0.0,
            torque_v_m: 0.0,
            torque_h_m: 0.0,
            net_weight_m1_n: 0.0,
            trim_rad: 0.0,
            drag_ratio: [1.0; 6],
            current_ne_mps: [0.0; 2],
            tether_ne_n: [0.0; 2],
            depth_drift_mps: 0.0,
            compass_dev_deg: [0.0; 2],
            emi_deg: [0.0; N_GROUPS],
            bias_roll_deg: 0.0,
            bias_pitch_deg: 0.0,
        }
    }
}

/// A vehicle-file base: the definition (with calibrated process parameters) and its
/// precomputed dynamics.
#[derive(Debug, Clone)]
struct VehicleBase {
    def: VehicleDef,
    dynm: VehicleDynamics,
    /// The command channels some thruster mixes ([`VehicleDef::channels`]), kept so the
    /// simulators' inner loops do not rebuild the list.
    chans: Vec<CommandChannel>,
}

#[derive(Debug, Clone)]
enum Base {
    M1(Model1),
    M2(Model2),
    M3(Box<Model3>),
    Vehicle(Box<VehicleBase>),
}

/// Per-thruster thrust values (N) or commands (%), up to [`MAX_THRUSTERS`].
pub type PerThruster = [f64; MAX_THRUSTERS];

/// A base model with calibration, effects and discovered terms.
#[derive(Debug, Clone)]
pub struct LabModel {
    kind: BaseKind,
    base: Base,
    base_text: String,
    /// Thrusters: count and calibration group of each.
    n_thr: usize,
    thr_group: [Thr; MAX_THRUSTERS],
    /// Pro 4 bases: the base's own (T_l, T_q) per thruster.
    coef_lin: PerThruster,
    coef_quad: PerThruster,
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

fn thrust_coefs(map: &ThrustMap) -> (f64, f64) {
    match map {
        ThrustMap::Quadratic(q) => (q.forward.linear_n, q.forward.quadratic_n),
        ThrustMap::Linear(l) => (l.gain_n_per_pct * 100.0, 0.0),
    }
}

/// The Pro 4's command channels, in its thruster order.
const PRO4_CHANNELS: [CommandChannel; 3] = [
    CommandChannel::PORT,
    CommandChannel::STARBOARD,
    CommandChannel::VERTICAL,
];

impl LabModel {
    fn blank(kind: BaseKind, base: Base, base_text: &str) -> Self {
        Self {
            kind,
            base,
            base_text: base_text.to_string(),
            n_thr: 3,
            thr_group: [Thr::Port; MAX_THRUSTERS],
            coef_lin: [0.0; MAX_THRUSTERS],
            coef_quad: [0.0; MAX_THRUSTERS],
            thrust_lin: [1.0; N_GROUPS],
            thrust_quad: [1.0; N_GROUPS],
            fx: EffectValues::default(),
            active: Vec::new(),
            terms: Vec::new(),
            filters: Vec::new(),
            name: kind.name().to_string(),
            drag_tau_factor: [1.0; 6],
            has_sensor_fx: false,
            has_body_fx: false,
            nominal: Vec::new(),
        }
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
        if matches!(
            p,
            Param::ArmZh | Param::ArmXv | Param::ArmYv | Param::ArmXh | Param::ArmYh
        ) && self.arms_calibrated()
        {
            let s = match &self.base {
                Base::Vehicle(v) => v.def.uncertainty.thruster_position_m,
                _ => return None,
            };
            return Some((0.0, s));
        }
        let mean = self.nominal(p)?;
        let doc = match &self.base {
            Base::Vehicle(v) => {
                let u = &v.def.uncertainty;
                match p {
                    Param::ThrustLin(_) | Param::ThrustQuad(_) => {
                        Documented::Rel(u.thrust_gain_rel)
                    }
                    Param::DragLin(_) | Param::DragQuad(_) => Documented::Rel(u.damping_rel),
                    Param::AddedMass(_) => Documented::Rel(u.added_mass_rel),
                    Param::CgX | Param::CgY | Param::CgZ => Documented::Abs(u.cg_m),
                    Param::NetWeight => Documented::Abs(u.net_weight_n),
                    Param::CommandGain if u.command_gain > 0.0 => Documented::Abs(u.command_gain),
                    _ => return None,
                }
            }
            _ => crate::params::documented_pro4(p)?,
        };
        let sigma = match doc {
            Documented::Rel(r) => (r * mean.abs()).max(p.meta().scale),
            Documented::Abs(a) => a.max(1e-9),
        };
        Some((mean, sigma))
    }

    /// From a base model's parameter-file text (`label` names it in errors).
    pub fn from_base_text(kind: BaseKind, text: &str, label: &str) -> Result<Self, LabError> {
        if kind == BaseKind::Vehicle {
            return Self::from_vehicle_text(text, label);
        }
        let boxed = load_model(kind.name(), text, label)?;
        let base = if let Some(m) = boxed.as_any().downcast_ref::<Model1>() {
            Base::M1(m.clone())
        } else if let Some(m) = boxed.as_any().downcast_ref::<Model2>() {
            Base::M2(m.clone())
        } else if let Some(m) = boxed.as_any().downcast_ref::<Model3>() {
            Base::M3(Box::new(m.clone()))
        } else {
            return Err(LabError::Model {
                detail: format!("{label}: unexpected model type"),
            });
        };
        let (coef_lin, coef_quad) = match &base {
            Base::M1(m) => {
                let p = m.params();
                let f = |q: &rov_dynamics::thrusters::QuadraticThrustMap| {
                    (q.forward.linear_n, q.forward.quadratic_n)
                };
                let (a, b, c) = (f(&p.port), f(&p.starboard), f(&p.vertical));
                ([a.0, b.0, c.0], [a.1, b.1, c.1])
            }
            Base::M2(m) => {
                let p = m.params();
                (
                    [
                        p.g1_n_per_pct * 100.0,
                        p.g1_n_per_pct * 100.0,
                        p.g2_n_per_pct * 100.0,
                    ],
                    [0.0; 3],
                )
            }
            Base::M3(m) => {
                let t = &m.params().thrusters;
                let (a, b, c) = (
                    thrust_coefs(&t.port.map),
                    thrust_coefs(&t.starboard.map),
                    thrust_coefs(&t.vertical.map),
                );
                ([a.0, b.0, c.0], [a.1, b.1, c.1])
            }
            Base::Vehicle(_) => ([0.0; 3], [0.0; 3]),
        };
        let mut m = Self::blank(kind, base, text);
        m.coef_lin[..3].copy_from_slice(&coef_lin);
        m.coef_quad[..3].copy_from_slice(&coef_quad);
        m.thr_group[0] = Thr::Port;
        m.thr_group[1] = Thr::Starboard;
        m.thr_group[2] = Thr::Vertical;
        if let Base::M1(b) = &m.base {
            let a = b.params().alpha;
            m.drag_tau_factor[0] = 1.0 / a[0];
            m.drag_tau_factor[2] = 1.0 / a[1];
            m.drag_tau_factor[5] = 1.0 / a[2];
        }
        Ok(m.record_nominal())
    }

    /// From a vehicle definition file's text (see [`rov_dynamics::models::vehicle`]).
    pub fn from_vehicle_text(text: &str, label: &str) -> Result<Self, LabError> {
        let def = VehicleDef::parse(text, label)?;
        let dynm = VehicleDynamics::new(&def).map_err(|e| LabError::Model {
            detail: format!("{label}: {e}"),
        })?;
        let n_thr = def.thrusters.len().min(MAX_THRUSTERS);
        let mut groups = [Thr::Horizontal; MAX_THRUSTERS];
        for (g, t) in groups.iter_mut().zip(&def.thrusters) {
            *g = t.group;
        }
        let name = def.name.clone();
        let mut m = Self::blank(
            BaseKind::Vehicle,
            Base::Vehicle(Box::new(VehicleBase {
                chans: def.channels(),
                def,
                dynm,
            })),
            text,
        );
        m.n_thr = n_thr;
        m.thr_group = groups;
        m.name = name;
        m.refresh_name();
        Ok(m.record_nominal())
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
        match &self.base {
            Base::M1(m) => m.params().mass_kg * 9.81,
            Base::M2(m) => m.params().weight_n,
            Base::M3(m) => m.params().process.hydrostatics.weight_n,
            Base::Vehicle(v) => v.def.process.hydrostatics.weight_n,
        }
    }

    /// The base kind.
    pub fn kind(&self) -> BaseKind {
        self.kind
    }

    /// The base's name: "model1" … or the vehicle file's `vehicle`.
    pub fn base_name(&self) -> &str {
        match &self.base {
            Base::Vehicle(v) => &v.def.name,
            _ => self.kind.name(),
        }
    }

    /// The vehicle definition of a vehicle-file base.
    pub fn vehicle(&self) -> Option<&VehicleDef> {
        match &self.base {
            Base::Vehicle(v) => Some(&v.def),
            _ => None,
        }
    }

    /// The base parameter-file text this model was built from.
    pub fn base_text(&self) -> &str {
        &self.base_text
    }

    /// Effects added to the base (in order of addition).
    pub fn active_effects(&self) -> &[EffectId] {
        &self.active
    }

    /// Discovered terms of the model (in order of addition).
    pub fn terms(&self) -> &[Term] {
        &self.terms
    }

    /// The effect values.
    pub fn effect_values(&self) -> &EffectValues {
        &self.fx
    }

    /// Whether the model has pitch and roll.
    pub fn has_attitude(&self) -> bool {
        match &self.base {
            Base::Vehicle(v) => v.def.structure == Structure::Fossen6,
            _ => self.kind.has_attitude(),
        }
    }

    /// Which of ν = (u, v, w, p, q, r) the model's state can move.
    pub fn nu_active(&self) -> [bool; 6] {
        match &self.base {
            Base::Vehicle(v) => v.def.structure.active(),
            Base::M3(_) => [true; 6],
            _ => [true, false, true, false, false, true],
        }
    }

    /// Whether a vehicle file documents its thruster positions as uncertain, so that the
    /// calibration refits the thrust lines (the moment arms become base parameters).
    fn arms_calibrated(&self) -> bool {
        matches!(&self.base, Base::Vehicle(v) if v.def.uncertainty.thruster_position_m > 0.0 && v.def.structure == Structure::Fossen6)
    }

    /// Whether the base already contains an effect.
    pub fn contains(&self, e: EffectId) -> bool {
        if e == EffectId::ThrusterMomentArm {
            return self.arms_calibrated();
        }
        if e == EffectId::PitchDepthCoupling || e == EffectId::RestoringOffset {
            return self.has_attitude() && self.kind.contains(e);
        }
        self.kind.contains(e)
    }

    /// Why an effect cannot be represented in this model, if so.
    pub fn not_applicable(&self, e: EffectId) -> Option<&'static str> {
        if let Some(r) = self.kind.not_applicable(e) {
            return Some(r);
        }
        if self.kind == BaseKind::Vehicle && !self.has_attitude() {
            return match e {
                EffectId::RestoringOffset
                | EffectId::AttitudeBias
                | EffectId::ThrusterMomentArm => Some(
                    "it acts on pitch and roll, which this vehicle's structure locks (use structure = \"fossen6\")",
                ),
                _ => None,
            };
        }
        None
    }

    /// The base parameters that calibration frees.
    pub fn calibration_params(&self) -> Vec<Param> {
        let Base::Vehicle(v) = &self.base else {
            return self.kind.calibration_params();
        };
        let mut out = Vec::new();
        for g in v.def.groups() {
            out.push(Param::ThrustLin(g));
            if v.def
                .thrusters
                .iter()
                .any(|t| t.group == g && t.forward.is_quadratic())
            {
                out.push(Param::ThrustQuad(g));
            }
        }
        let active = v.def.structure.active();
        for a in Axis::ALL {
            if active[a.index()] {
                out.push(Param::DragLin(a));
                out.push(Param::DragQuad(a));
            }
        }
        if v.def.structure == Structure::Fossen6 {
            out.push(Param::CgZ);
            out.push(Param::AddedMass(Axis::Sway));
            out.push(Param::AddedMass(Axis::Roll));
            out.push(Param::AddedMass(Axis::Pitch));
        }
        // The gain setting, when the file says it is not known (it scales every command
        // before the mixer and the non-linear thrust curves).
        if v.def.uncertainty.command_gain > 0.0 {
            out.push(Param::CommandGain);
        }
        if self.arms_calibrated() {
            for p in [
                Param::ArmZh,
                Param::ArmXv,
                Param::ArmYv,
                Param::ArmXh,
                Param::ArmYh,
            ] {
                if self.applicable(p) {
                    out.push(p);
                }
            }
        }
        out
    }

    /// Marks an effect as part of the model (its parameters keep their values). A
    /// contained effect is not added (its parameters are base parameters).
    pub fn add_effect(&mut self, e: EffectId) {
        if !self.contains(e) && !self.active.contains(&e) {
            self.active.push(e);
        }
        self.refresh_name();
    }

    /// Adds a discovered term (coefficient as given); returns its index. A term of the
    /// same DOF and form replaces the old one's coefficient.
    pub fn add_term(&mut self, term: Term) -> usize {
        if let Some(i) = self
            .terms
            .iter()
            .position(|t| t.dof == term.dof && t.kind == term.kind)
        {
            if let Some(t) = self.terms.get_mut(i) {
                *t = term;
            }
            return i;
        }
        self.terms.push(term);
        if let Some(f) = term.kind.filter()
            && !self.filters.contains(&f)
            && self.filters.len() < MAX_FILTERS
        {
            self.filters.push(f);
        }
        self.refresh_name();
        self.terms.len() - 1
    }

    /// The filtered-command signals the terms use: (command index, filter index).
    pub fn filters(&self) -> &[(u8, u8)] {
        &self.filters
    }

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
        let f = &self.fx;
        self.has_sensor_fx = f.depth_drift_mps != 0.0
            || f.compass_dev_deg != [0.0; 2]
            || f.emi_deg != [0.0; N_GROUPS]
            || f.bias_roll_deg != 0.0
            || f.bias_pitch_deg != 0.0;
        self.has_body_fx = f.net_weight_m1_n != 0.0
            || f.tether_ne_n != [0.0; 2]
            || f.drag_ratio != [1.0; 6]
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
        match &self.base {
            Base::Vehicle(v) => v.chans.clone(),
            _ => PRO4_CHANNELS.to_vec(),
        }
    }

    /// The model's channel table: the names of a vehicle file's free channels (none for
    /// the Pro 4 models). Runs are re-indexed to it ([`crate::data::Run::align_channels`]).
    pub fn channel_table(&self) -> &ChannelTable {
        static BUILTIN: ChannelTable = ChannelTable::builtin();
        match &self.base {
            Base::Vehicle(v) => &v.def.channel_table,
            _ => &BUILTIN,
        }
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
        match &self.base {
            Base::Vehicle(v) => v
                .chans
                .iter()
                .take(MAX_SIGNALS)
                .map(|c| v.def.channel_table.name(*c).unwrap_or("?"))
                .collect(),
            _ => PRO4_CHANNELS
                .iter()
                .filter_map(|c| c.builtin_name())
                .collect(),
        }
    }

    /// The model's command signals (fractions of full command) from a command vector.
    #[inline]
    pub fn command_signals(&self, c: &Commands) -> Signals {
        let mut out = [0.0; MAX_SIGNALS];
        match &self.base {
            Base::Vehicle(v) => {
                for (o, ch) in out.iter_mut().zip(&v.chans) {
                    *o = c.get(ch.index()).copied().unwrap_or(0.0) * 0.01;
                }
            }
            _ => {
                for (o, ch) in out.iter_mut().zip(PRO4_CHANNELS) {
                    *o = c[ch.index()] * 0.01;
                }
            }
        }
        out
    }

    /// Thruster commands (%) for a command vector (the mix of a vehicle file; the Pro 4's
    /// port, starboard and vertical channels otherwise).
    #[inline]
    pub fn thruster_targets(&self, c: &Commands) -> PerThruster {
        let mut out = [0.0; MAX_THRUSTERS];
        match &self.base {
            Base::Vehicle(v) => {
                let u = v.def.thruster_commands(c);
                for (o, x) in out.iter_mut().zip(u) {
                    *o = x * 100.0;
                }
            }
            _ => {
                for (o, ch) in out.iter_mut().zip(PRO4_CHANNELS) {
                    *o = c[ch.index()];
                }
            }
        }
        out
    }

    /// Lag time constant of each thruster, s: the vehicle file's own lag plus the
    /// `thruster-lag` effect's.
    pub fn lag_taus(&self) -> PerThruster {
        let mut out = [self.fx.lag_tau_s; MAX_THRUSTERS];
        if let Base::Vehicle(v) = &self.base {
            for (o, t) in out.iter_mut().zip(&v.def.thrusters) {
                *o += t.lag_s;
            }
        }
        out
    }

    /// Whether any thruster lags.
    pub fn lag_on(&self) -> bool {
        self.lag_taus()[..self.n_thr].iter().any(|t| *t > 1e-4)
    }

    /// Whether a parameter exists in this model.
    pub fn applicable(&self, p: Param) -> bool {
        let m3 = self.kind == BaseKind::Model3;
        let planar_axis = |a: Axis| matches!(a, Axis::Surge | Axis::Heave | Axis::Yaw);
        if let Base::Vehicle(v) = &self.base {
            let active = v.def.structure.active();
            let six = v.def.structure == Structure::Fossen6;
            return match p {
                Param::ThrustLin(g) | Param::ReverseRatio(g) | Param::Emi(g) => self.has_group(g),
                Param::ThrustQuad(g) => v
                    .def
                    .thrusters
                    .iter()
                    .any(|t| t.group == g && t.forward.is_quadratic()),
                Param::DragLin(a) | Param::DragQuad(a) | Param::AddedMass(a) => active[a.index()],
                Param::DragRatio(a) => active[a.index()],
                Param::CgZ | Param::CgX | Param::CgY | Param::BiasRoll | Param::BiasPitch => six,
                // A vehicle's moment arms shift its thrusters from the file's positions:
                // the non-vertical thrusters' height, the vertical ones' x and y.
                Param::ArmZh => {
                    six && self.thr_group[..self.n_thr]
                        .iter()
                        .any(|g| *g != Thr::Vertical)
                }
                Param::ArmXv | Param::ArmYv => six && self.has_group(Thr::Vertical),
                Param::ArmXh | Param::ArmYh => {
                    six && self.thr_group[..self.n_thr]
                        .iter()
                        .any(|g| *g != Thr::Vertical)
                }
                Param::TorqueV | Param::TorqueH => false,
                Param::TrimDeg => !active[4],
                Param::TermCoef(i, _) => (i as usize) < self.terms.len(),
                _ => true,
            };
        }
        if matches!(p, Param::CommandGain | Param::ArmXh | Param::ArmYh) {
            return false;
        }
        match p {
            Param::ThrustLin(g) | Param::ReverseRatio(g) | Param::Emi(g) => {
                matches!(g, Thr::Port | Thr::Starboard | Thr::Vertical)
            }
            Param::ThrustQuad(g) => {
                self.kind != BaseKind::Model2
                    && matches!(g, Thr::Port | Thr::Starboard | Thr::Vertical)
            }
            Param::DragLin(a) | Param::DragQuad(a) => m3 || planar_axis(a),
            Param::AddedMass(a) => m3 || planar_axis(a),
            Param::CgZ | Param::CgX | Param::CgY => m3,
            Param::ArmZh
            | Param::ArmXv
            | Param::ArmYv
            | Param::TorqueH
            | Param::BiasRoll
            | Param::BiasPitch => m3,
            Param::TrimDeg => !m3,
            Param::DragRatio(a) => m3 || planar_axis(a),
            Param::TermCoef(i, _) => (i as usize) < self.terms.len(),
            _ => true,
        }
    }

    /// A parameter's value (`None` if not applicable).
    pub fn get(&self, p: Param) -> Option<f64> {
        if !self.applicable(p) {
            return None;
        }
        let f = &self.fx;
        Some(match p {
            Param::ThrustLin(t) => self.thrust_lin[t.index()],
            Param::ThrustQuad(t) => self.thrust_quad[t.index()],
            Param::DragLin(a) => self.drag(a).0,
            Param::DragQuad(a) => self.drag(a).1,
            Param::CgZ | Param::CgX | Param::CgY => {
                let cg = match &self.base {
                    Base::M3(m) => m.params().process.rigid_body.cg_from_co_m,
                    Base::Vehicle(v) => v.def.process.rigid_body.cg_from_co_m,
                    _ => return None,
                };
                match p {
                    Param::CgX => cg.x,
                    Param::CgY => cg.y,
                    _ => cg.z,
                }
            }
            Param::NetWeight => match &self.base {
                Base::M1(_) => f.net_weight_m1_n,
                Base::M2(m) => m.params().weight_n - m.params().buoyancy_n,
                Base::M3(m) => m.net_weight_n(),
                Base::Vehicle(v) => {
                    let h = &v.def.process.hydrostatics;
                    h.weight_n - h.buoyancy_n
                }
            },
            Param::AddedMass(a) => self.added_mass(a)?,
            Param::ReverseRatio(t) => f.reverse_ratio[t.index()],
            Param::LagTau => f.lag_tau_s,
            Param::Deadzone => f.deadzone,
            Param::PowerMax => f.power_max,
            Param::ArmZh => f.arm_zh_m,
            Param::ArmXv => f.arm_xv_m,
            Param::ArmYv => f.arm_yv_m,
            Param::ArmXh => f.arm_xh_m,
            Param::ArmYh => f.arm_yh_m,
            Param::TorqueV => f.torque_v_m,
            Param::TorqueH => f.torque_h_m,
            Param::TrimDeg => f.trim_rad.to_degrees(),
            Param::DragRatio(a) => f.drag_ratio[a.index()],
            Param::CurrentN => f.current_ne_mps[0],
            Param::CurrentE => f.current_ne_mps[1],
            Param::TetherN => f.tether_ne_n[0],
            Param::TetherE => f.tether_ne_n[1],
            Param::DepthDrift => f.depth_drift_mps,
            Param::CompassSin => f.compass_dev_deg[0],
            Param::CompassCos => f.compass_dev_deg[1],
            Param::Emi(t) => f.emi_deg[t.index()],
            Param::BiasRoll => f.bias_roll_deg,
            Param::BiasPitch => f.bias_pitch_deg,
            Param::TermCoef(i, _) => {
                let t = self.terms.get(i as usize)?;
                t.coef * t.scale
            }
            Param::CommandGain => match &self.base {
                Base::Vehicle(v) => v.def.command_gain,
                _ => return None,
            },
        })
    }

    fn drag(&self, a: Axis) -> (f64, f64) {
        match &self.base {
            Base::M1(m) => {
                let p = m.params();
                let d = match a {
                    Axis::Surge => p.surge_drag,
                    Axis::Heave => p.heave_drag,
                    _ => p.yaw_drag,
                };
                (d.linear, d.quadratic)
            }
            Base::M2(m) => {
                let p = m.params();
                match a {
                    Axis::Surge => (-p.x_u, -p.x_uu),
                    Axis::Heave => (-p.z_w, -p.z_ww),
                    _ => (-p.n_r, -p.n_rr),
                }
            }
            Base::M3(m) => {
                let d = &m.params().process.damping;
                let i = a.index();
                (d.linear[(i, i)], d.quadratic[i])
            }
            Base::Vehicle(v) => {
                let d = &v.def.process.damping;
                let i = a.index();
                (d.linear[(i, i)], d.quadratic[i])
            }
        }
    }

    fn added_mass(&self, a: Axis) -> Option<f64> {
        match &self.base {
            Base::M1(m) => {
                let p = m.params();
                let (beta, inertia) = match a {
                    Axis::Surge => (p.beta[0], p.mass_kg),
                    Axis::Heave => (p.beta[1], p.mass_kg),
                    Axis::Yaw => (p.beta[2], p.yaw_inertia_kgm2),
                    _ => return None,
                };
                Some(inertia / beta - inertia)
            }
            Base::M2(m) => {
                let p = m.params();
                match a {
                    Axis::Surge => Some(-p.x_udot_kg),
                    Axis::Heave => Some(-p.z_wdot_kg),
                    Axis::Yaw => Some(-p.n_rdot_kgm2),
                    _ => None,
                }
            }
            Base::M3(m) => {
                let i = a.index();
                Some(m.params().process.added_mass[(i, i)])
            }
            Base::Vehicle(v) => {
                let i = a.index();
                Some(v.def.process.added_mass[(i, i)])
            }
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
        let mut m1 = match &self.base {
            Base::M1(m) => Some(*m.params()),
            _ => None,
        };
        let mut m2 = match &self.base {
            Base::M2(m) => Some(*m.params()),
            _ => None,
        };
        let mut m3 = match &self.base {
            Base::M3(m) => Some(*m.params()),
            _ => None,
        };
        let mut vp = match &self.base {
            Base::Vehicle(v) => Some(v.def.process),
            _ => None,
        };
        for (p, v) in params.iter().zip(values) {
            if !self.applicable(*p) || !v.is_finite() {
                continue;
            }
            let meta = p.meta();
            let v = v.clamp(meta.lo, meta.hi);
            let f = &mut self.fx;
            match p {
                Param::ThrustLin(t) => self.thrust_lin[t.index()] = v,
                Param::ThrustQuad(t) => self.thrust_quad[t.index()] = v,
                Param::DragLin(a) | Param::DragQuad(a) => {
                    let lin = matches!(p, Param::DragLin(_));
                    if let Some(q) = m1.as_mut() {
                        let d = match a {
                            Axis::Surge => &mut q.surge_drag,
                            Axis::Heave => &mut q.heave_drag,
                            _ => &mut q.yaw_drag,
                        };
                        if lin {
                            d.linear = v;
                        } else {
                            d.quadratic = v;
                        }
                    }
                    if let Some(q) = m2.as_mut() {
                        let slot = match (a, lin) {
                            (Axis::Surge, true) => &mut q.x_u,
                            (Axis::Surge, false) => &mut q.x_uu,
                            (Axis::Heave, true) => &mut q.z_w,
                            (Axis::Heave, false) => &mut q.z_ww,
                            (_, true) => &mut q.n_r,
                            (_, false) => &mut q.n_rr,
                        };
                        *slot = -v;
                    }
                    let process = m3.as_mut().map(|q| &mut q.process).or(vp.as_mut());
                    if let Some(q) = process {
                        let i = a.index();
                        if lin {
                            q.damping.linear[(i, i)] = v;
                        } else {
                            q.damping.quadratic[i] = v;
                        }
                    }
                }
                Param::CgX | Param::CgY | Param::CgZ => {
                    let process = m3.as_mut().map(|q| &mut q.process).or(vp.as_mut());
                    if let Some(q) = process {
                        let k = match p {
                            Param::CgX => 0,
                            Param::CgY => 1,
                            _ => 2,
                        };
                        q.rigid_body.cg_from_co_m[k] = v;
                        q.hydrostatics.cg_from_co_m[k] = v;
                    }
                }
                Param::NetWeight => {
                    if m1.is_some() {
                        f.net_weight_m1_n = v;
                    }
                    if let Some(q) = m2.as_mut() {
                        q.buoyancy_n = q.weight_n - v;
                    }
                    let process = m3.as_mut().map(|q| &mut q.process).or(vp.as_mut());
                    if let Some(q) = process {
                        q.hydrostatics.buoyancy_n = q.hydrostatics.weight_n - v;
                    }
                }
                Param::AddedMass(a) => {
                    if let Some(q) = m1.as_mut() {
                        let (k, inertia) = match a {
                            Axis::Surge => (0, q.mass_kg),
                            Axis::Heave => (1, q.mass_kg),
                            _ => (2, q.yaw_inertia_kgm2),
                        };
                        q.beta[k] = inertia / (inertia + v);
                    }
                    if let Some(q) = m2.as_mut() {
                        match a {
                            Axis::Surge => q.x_udot_kg = -v,
                            Axis::Heave => q.z_wdot_kg = -v,
                            _ => q.n_rdot_kgm2 = -v,
                        }
                    }
                    let process = m3.as_mut().map(|q| &mut q.process).or(vp.as_mut());
                    if let Some(q) = process {
                        let i = a.index();
                        q.added_mass[(i, i)] = v;
                    }
                }
                Param::ReverseRatio(t) => f.reverse_ratio[t.index()] = v,
                Param::LagTau => f.lag_tau_s = v,
                Param::Deadzone => f.deadzone = v,
                Param::PowerMax => f.power_max = v,
                Param::ArmZh => f.arm_zh_m = v,
                Param::ArmXv => f.arm_xv_m = v,
                Param::ArmYv => f.arm_yv_m = v,
                Param::ArmXh => f.arm_xh_m = v,
                Param::ArmYh => f.arm_yh_m = v,
                Param::TorqueV => f.torque_v_m = v,
                Param::TorqueH => f.torque_h_m = v,
                Param::TrimDeg => f.trim_rad = v.to_radians(),
                Param::DragRatio(a) => f.drag_ratio[a.index()] = v,
                Param::CurrentN => f.current_ne_mps[0] = v,
                Param::CurrentE => f.current_ne_mps[1] = v,
                Param::TetherN => f.tether_ne_n[0] = v,
                Param::TetherE => f.tether_ne_n[1] = v,
                Param::DepthDrift => f.depth_drift_mps = v,
                Param::CompassSin => f.compass_dev_deg[0] = v,
                Param::CompassCos => f.compass_dev_deg[1] = v,
                Param::Emi(t) => f.emi_deg[t.index()] = v,
                Param::BiasRoll => f.bias_roll_deg = v,
                Param::BiasPitch => f.bias_pitch_deg = v,
                Param::TermCoef(i, _) => {
                    if let Some(t) = self.terms.get_mut(*i as usize)
                        && t.scale > 0.0
                    {
                        t.coef = v / t.scale;
                    }
                }
                Param::CommandGain => {
                    if let Base::Vehicle(vb) = &mut self.base {
                        vb.def.command_gain = v;
                    }
                }
            }
        }
        if let Some(p) = m1 {
            self.base = Base::M1(Model1::new(p));
        }
        if let Some(p) = m2 {
            self.base = Base::M2(Model2::new(p));
        }
        if let Some(p) = m3 {
            let m = Model3::new(p).map_err(|e| LabError::Model {
                detail: e.to_string(),
            })?;
            self.base = Base::M3(Box::new(m));
        }
        if let (Some(p), Base::Vehicle(v)) = (vp, &mut self.base) {
            let dynm = VehicleDynamics::with_process(&v.def, p).map_err(|e| LabError::Model {
                detail: e.to_string(),
            })?;
            v.def.process = p;
            v.dynm = dynm;
        }
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

    fn pro4_dyn(&self) -> Option<&dyn VehicleModel> {
        match &self.base {
            Base::M1(m) => Some(m),
            Base::M2(m) => Some(m),
            Base::M3(m) => Some(m.as_ref()),
            Base::Vehicle(_) => None,
        }
    }

    /// Thrust of thruster `i` for a command in percent (before the power limit), N.
    #[inline]
    pub fn thrust_n(&self, i: usize, pct: f64) -> f64 {
        use rov_dynamics::models::vehicle::ThrustCurve;
        use rov_dynamics::thrusters::{QuadraticThrustMap, ThrustPair};
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
        let (kl, kq, rr) = (
            self.thrust_lin[g],
            self.thrust_quad[g],
            self.fx.reverse_ratio[g],
        );
        // The one thrust map (rov_dynamics::thrusters::QuadraticThrustMap): the
        // calibrated forward pair, and the reverse pair weakened by the asymmetry effect.
        let map = |fwd: ThrustPair, rev: ThrustPair| QuadraticThrustMap {
            forward: ThrustPair {
                linear_n: kl * fwd.linear_n,
                quadratic_n: kq * fwd.quadratic_n,
            },
            reverse: ThrustPair {
                linear_n: kl * rev.linear_n * rr,
                quadratic_n: kq * rev.quadratic_n * rr,
            },
        };
        match &self.base {
            Base::Vehicle(v) => {
                let Some(t) = v.def.thrusters.get(i) else {
                    return 0.0;
                };
                match (t.forward, t.reverse) {
                    (ThrustCurve::Quadratic(f), ThrustCurve::Quadratic(r)) => {
                        map(f, r).force_n(pct)
                    }
                    _ => {
                        // A tabulated curve is not quadratic: interpolated in its table.
                        let u = pct * 0.01;
                        let curve = if u >= 0.0 { &t.forward } else { &t.reverse };
                        let (a, b) = curve.parts(u.abs());
                        let f = u.signum() * (kl * a + kq * b);
                        if u < 0.0 { f * rr } else { f }
                    }
                }
            }
            _ => {
                let pair = ThrustPair {
                    linear_n: self.coef_lin.get(i).copied().unwrap_or(0.0),
                    quadratic_n: self.coef_quad.get(i).copied().unwrap_or(0.0),
                };
                map(pair, pair).force_n(pct)
            }
        }
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
        if let Base::Vehicle(v) = &self.base {
            let mut tau = v.dynm.tau(f);
            let x = &self.fx;
            if x.arm_zh_m != 0.0
                || x.arm_xv_m != 0.0
                || x.arm_yv_m != 0.0
                || x.arm_xh_m != 0.0
                || x.arm_yh_m != 0.0
            {
                // Moving a thruster by Δr adds Δr × F d to the moment.
                for (i, fi) in f.iter().enumerate().take(self.n_thr) {
                    if *fi == 0.0 {
                        continue;
                    }
                    let d = v.dynm.column(i);
                    let dr = if self.thruster_group(i) == Thr::Vertical {
                        nalgebra::Vector3::new(x.arm_xv_m, x.arm_yv_m, 0.0)
                    } else {
                        nalgebra::Vector3::new(x.arm_xh_m, x.arm_yh_m, x.arm_zh_m)
                    };
                    let m = dr.cross(&nalgebra::Vector3::new(d[0], d[1], d[2])) * *fi;
                    tau[3] += m.x;
                    tau[4] += m.y;
                    tau[5] += m.z;
                }
            }
            return tau;
        }
        let forces = ThrusterForces {
            port_n: f[0],
            starboard_n: f[1],
            vertical_n: f[2],
        };
        let mut tau = match self.pro4_dyn() {
            Some(m) => m.generalized_force(&forces, state),
            None => Vector6::zeros(),
        };
        let x = &self.fx;
        tau[3] += x.arm_yv_m * f[2] + x.torque_h_m * (f[0] - f[1]);
        tau[4] += x.arm_zh_m * (f[0] + f[1]) - x.arm_xv_m * f[2];
        tau[5] += x.torque_v_m * f[2];
        tau
    }

    /// τ of the discovered terms for a state, command signals and filter states.
    #[inline]
    pub fn terms_tau(&self, state: &ModelState, cmd: &[f64], filt: &[f64]) -> Vector6 {
        let mut tau = Vector6::zeros();
        if self.terms.is_empty() {
            return tau;
        }
        let x = TermInputs {
            eta: &state.eta,
            nu: &state.nu,
            cmd,
            filt,
        };
        for t in &self.terms {
            let d = t.dof as usize;
            if d < 6 {
                tau[d] += t.coef * t.kind.value(&x) * self.drag_tau_factor[d];
            }
        }
        tau
    }

    /// State-dependent extra body forces of the effects (not the terms).
    #[inline]
    fn extra_tau(&self, state: &ModelState) -> Vector6 {
        let x = &self.fx;
        let mut tau = Vector6::zeros();
        if !self.has_body_fx {
            return tau;
        }
        if x.net_weight_m1_n != 0.0 {
            tau[2] += x.net_weight_m1_n;
        }
        if x.tether_ne_n != [0.0; 2] {
            let att = Attitude::from_eta(&state.eta);
            let f_ned = nalgebra::Vector3::new(x.tether_ne_n[0], x.tether_ne_n[1], 0.0);
            let fb = att.ned_from_body().transpose() * f_ned;
            let r = nalgebra::Vector3::new(TETHER_ATTACH_X_M, 0.0, 0.0);
            let m = r.cross(&fb);
            tau[0] += fb.x;
            tau[1] += fb.y;
            tau[2] += fb.z;
            tau[3] += m.x;
            tau[4] += m.y;
            tau[5] += m.z;
        }
        for (i, ratio) in x.drag_ratio.iter().enumerate() {
            if *ratio != 1.0 {
                let v = state.nu[i];
                if v < 0.0 {
                    let dq = self.drag_q_index(i);
                    tau[i] += (ratio - 1.0) * dq * v * v * self.drag_tau_factor[i];
                }
            }
        }
        tau
    }

    fn drag_q_index(&self, i: usize) -> f64 {
        self.drag(Axis::ALL.get(i).copied().unwrap_or(Axis::Yaw)).1
    }

    #[inline]
    fn effect_current(&self, current: &CurrentSample) -> CurrentSample {
        let c = self.fx.current_ne_mps;
        if c == [0.0; 2] {
            *current
        } else {
            let mut s = *current;
            s.vel_ned_mps.x += c[0];
            s.vel_ned_mps.y += c[1];
            s
        }
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
        match &self.base {
            Base::M3(m) => {
                let tau = if self.has_body_fx {
                    tau_thrust + self.extra_tau(&ModelState::new(*eta, *nu))
                } else {
                    *tau_thrust
                };
                m.process()
                    .state_derivative(eta, nu, &tau, &self.effect_current(current))
            }
            Base::Vehicle(v) => {
                let st = ModelState::new(*eta, *nu);
                let tau = tau_thrust + self.extra_tau(&st);
                let (mut ed, nd) =
                    v.dynm
                        .state_derivative(eta, nu, &tau, &self.effect_current(current));
                if self.fx.trim_rad != 0.0 && !v.def.structure.active()[4] {
                    let (s, c) = self.fx.trim_rad.sin_cos();
                    ed[2] = nu[2] * c - nu[0] * s;
                }
                (ed, nd)
            }
            _ => {
                let d = self.body_derivative(&ModelState::new(*eta, *nu), tau_thrust, current);
                (d.eta, d.nu)
            }
        }
    }

    /// State derivative for a τ of the thrusters and terms (without extra states).
    #[inline]
    pub fn body_derivative(
        &self,
        state: &ModelState,
        tau_thrust: &Vector6,
        current: &CurrentSample,
    ) -> ModelState {
        let Some(base) = self.pro4_dyn() else {
            let (eta, nu) = self.eta_nu_derivative(&state.eta, &state.nu, tau_thrust, current);
            return ModelState::new(eta, nu);
        };
        let tau = tau_thrust + self.extra_tau(state);
        let mut d = base.dynamics(state, &tau, &self.effect_current(current));
        if self.fx.trim_rad != 0.0 && self.kind != BaseKind::Model3 {
            let (s, c) = self.fx.trim_rad.sin_cos();
            d.eta[2] = state.nu[2] * c - state.nu[0] * s;
        }
        d
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
        let Base::Vehicle(v) = &self.base else {
            return None;
        };
        let tau = if self.has_body_fx {
            let (pose, nu) = unpack_quat_state(x);
            let st = ModelState::new(pose.to_eta(yaw_hint_rad), nu);
            tau_thrust + self.extra_tau(&st)
        } else {
            *tau_thrust
        };
        Some(
            v.dynm
                .process()
                .quat_state_derivative(x, &tau, &self.effect_current(current)),
        )
    }

    /// Whether the lab's simulator integrates this model's attitude with quaternions (a
    /// 6-DOF vehicle file: tank vehicles roll over and pitch past 80°).
    pub fn uses_quaternion(&self) -> bool {
        matches!(&self.base, Base::Vehicle(v) if v.def.structure == Structure::Fossen6)
    }

    /// Whether any sensor effect is non-zero.
    pub fn has_sensor_effects(&self) -> bool {
        self.has_sensor_fx
    }

    /// The measured value of a channel: the state seen through the sensor effects.
    /// `t_rel_s` counts from the start of the run; `prev` holds the thruster commands (%)
    /// acting just before the sample (for thruster interference on the compass).
    #[inline]
    pub fn sensor_value(
        &self,
        ch: Channel,
        state: &ModelState,
        t_rel_s: f64,
        prev: &PerThruster,
    ) -> f64 {
        let v = ch.value(state);
        if !self.has_sensor_fx {
            return v;
        }
        let f = &self.fx;
        match ch {
            Channel::Depth => v + f.depth_drift_mps * t_rel_s,
            Channel::Heading => v + self.heading_offset_deg(state.eta[5], prev),
            Channel::Pitch => v + f.bias_pitch_deg,
            Channel::Roll => v + f.bias_roll_deg,
            _ => v,
        }
    }

    /// The compass reading's offset (deviation and thruster interference) at a heading
    /// under the thruster commands (%) acting just before the sample, deg.
    #[inline]
    pub(crate) fn heading_offset_deg(&self, psi_rad: f64, prev: &PerThruster) -> f64 {
        let f = &self.fx;
        // Without deviation the sin/cos terms are zeros (skipped: the same sum).
        let mut off = if f.compass_dev_deg == [0.0; 2] {
            0.0
        } else {
            let (s, c) = psi_rad.sin_cos();
            f.compass_dev_deg[0] * s + f.compass_dev_deg[1] * c
        };
        for (i, u) in prev.iter().enumerate().take(self.n_thr) {
            let e = f.emi_deg[self.thruster_group(i).index()];
            if e != 0.0 {
                off += e * (u * 0.01).abs();
            }
        }
        off
    }

    /// Inverts the sensor model of a channel: the state value (deg or m) that reads `y`.
    pub fn sensor_inverse(&self, ch: Channel, y: f64, t_rel_s: f64, prev: &PerThruster) -> f64 {
        if !self.has_sensor_fx {
            return y;
        }
        let f = &self.fx;
        match ch {
            Channel::Depth => y - f.depth_drift_mps * t_rel_s,
            Channel::Heading => {
                let mut psi = y;
                for _ in 0..8 {
                    psi = y - self.heading_offset_deg(psi.to_radians(), prev);
                }
                psi
            }
            Channel::Pitch => y - f.bias_pitch_deg,
            Channel::Roll => y - f.bias_roll_deg,
            _ => y,
        }
    }

    /// Whether the model predicts a channel.
    pub fn predicts_channel(&self, ch: Channel) -> bool {
        match &self.base {
            Base::Vehicle(v) => {
                let a = v.def.structure.active();
                match ch {
                    Channel::Pitch | Channel::PitchRate => a[4],
                    Channel::Roll | Channel::RollRate => a[3],
                    Channel::Sway => a[1],
                    _ => true,
                }
            }
            _ => self.pro4_dyn().is_some_and(|m| m.predicts(ch)),
        }
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

    /// Extra states of the [`VehicleModel`] form: lags of the thrusters, then the filters.
    fn n_lag_states(&self) -> usize {
        if self.lag_on() { self.n_thr } else { 0 }
    }
}

impl VehicleModel for LabModel {
    fn name(&self) -> &str {
        &self.name
    }

    fn predicts(&self, ch: Channel) -> bool {
        self.predicts_channel(ch)
    }

    fn thruster_forces(&self, cmd: &ThrustPct, state: &ModelState) -> ThrusterForces {
        let c = Self::commands_of(cmd);
        let mut targets = self.thruster_targets(&c);
        if self.lag_on() {
            for (i, t) in targets.iter_mut().enumerate().take(self.n_thr) {
                *t = state.extra.get(i).copied().unwrap_or(*t);
            }
        }
        let f = self.thrusts(&targets);
        if self.kind == BaseKind::Vehicle {
            // Group totals for the record (the exact τ comes from `derivative`).
            let mut out = ThrusterForces::default();
            for (i, fi) in f.iter().enumerate().take(self.n_thr) {
                match self.thruster_group(i) {
                    Thr::Port => out.port_n += fi,
                    Thr::Starboard => out.starboard_n += fi,
                    Thr::Vertical => out.vertical_n += fi,
                    _ => {}
                }
            }
            return out;
        }
        ThrusterForces {
            port_n: f[0],
            starboard_n: f[1],
            vertical_n: f[2],
        }
    }

    fn generalized_force(&self, forces: &ThrusterForces, state: &ModelState) -> Vector6 {
        let mut f = [0.0; MAX_THRUSTERS];
        f[0] = forces.port_n;
        f[1] = forces.starboard_n;
        f[2] = forces.vertical_n;
        if self.kind == BaseKind::Vehicle {
            return Vector6::zeros();
        }
        self.thrust_tau(&f, state)
    }

    fn dynamics(&self, state: &ModelState, tau: &Vector6, current: &CurrentSample) -> ModelState {
        self.body_derivative(state, tau, current)
    }

    fn derivative(
        &self,
        time_s: f64,
        state: &ModelState,
        cmd: &ThrustPct,
        env: &Environment<'_>,
    ) -> ModelState {
        let c = Self::commands_of(cmd);
        let mut targets = self.thruster_targets(&c);
        let nl = self.n_lag_states();
        if nl > 0 {
            for (i, t) in targets.iter_mut().enumerate().take(nl) {
                *t = state.extra.get(i).copied().unwrap_or(*t);
            }
        }
        let f = self.thrusts(&targets);
        let signals = self.command_signals(&c);
        let mut filt = [0.0; 2 * MAX_SIGNALS];
        for (k, (ci, fk)) in self.filters.iter().enumerate() {
            let slot = *ci as usize * FILTER_TAUS_S.len() + *fk as usize;
            if let (Some(s), Some(x)) = (filt.get_mut(slot), state.extra.get(nl + k)) {
                *s = *x;
            }
        }
        let tau = self.thrust_tau(&f, state) + self.terms_tau(state, &signals, &filt);
        let tau = env.total_tau(&tau, time_s, &state.eta, &state.nu);
        let mut d = self.body_derivative(state, &tau, &env.current.at(time_s));
        self.extra_dynamics(time_s, state, cmd, &mut d);
        d
    }

    fn outputs(&self, time_s: f64, state: &ModelState) -> ModelOutput {
        let mut o = ModelOutput::from_state(time_s, state, |ch| self.predicts_channel(ch));
        if self.has_sensor_fx {
            let z = [0.0; MAX_THRUSTERS];
            if o.depth_m.is_some() {
                o.depth_m = Some(self.sensor_value(Channel::Depth, state, time_s, &z));
            }
            if o.heading_deg.is_some() {
                o.heading_deg = Some(self.sensor_value(Channel::Heading, state, time_s, &z));
            }
            if o.pitch_deg.is_some() {
                o.pitch_deg = Some(self.sensor_value(Channel::Pitch, state, time_s, &z));
            }
            if o.roll_deg.is_some() {
                o.roll_deg = Some(self.sensor_value(Channel::Roll, state, time_s, &z));
            }
        }
        o
    }

    fn n_extra_states(&self) -> usize {
        (self.n_lag_states() + self.filters.len()).min(rov_dynamics::models::MAX_EXTRA_STATES)
    }

    fn extra_dynamics(&self, _t: f64, state: &ModelState, cmd: &ThrustPct, deriv: &mut ModelState) {
        let c = Self::commands_of(cmd);
        let nl = self.n_lag_states();
        if nl > 0 {
            let taus = self.lag_taus();
            let targets = self.thruster_targets(&c);
            for i in 0..nl.min(rov_dynamics::models::MAX_EXTRA_STATES) {
                let tau = taus[i].max(1e-4);
                deriv.extra[i] = (targets[i] - state.extra[i]) / tau;
            }
        }
        let signals = self.command_signals(&c);
        for (k, (ci, fk)) in self.filters.iter().enumerate() {
            let slot = nl + k;
            let tau = FILTER_TAUS_S.get(*fk as usize).copied().unwrap_or(1.0);
            if let (Some(d), Some(x), Some(u)) = (
                deriv.extra.get_mut(slot),
                state.extra.get(slot),
                signals.get(*ci as usize),
            ) {
                *d = (u - x) / tau;
            }
        }
    }

    fn initial_state(&self, ic: &InitialConditions) -> ModelState {
        self.restrict_state(ic.to_state())
    }

    /// The base's heave and yaw reduction (with calibrated damping, added mass and
    /// buoyancy) and this model's thrust path: the calibrated per-thruster maps with the
    /// reverse ratio of the asymmetry effect, the dead zone, the lags, and the vertical
    /// thruster's reaction torque on yaw. The power limit, asymmetric drag, tether,
    /// current and discovered terms are not part of the reduction (the observer's bias
    /// takes what they leave). `None` for vehicle-file bases (N thrusters).
    fn plant(&self) -> Option<PlantDescription> {
        let mut d = self.pro4_dyn()?.plant()?;
        let taus = self.lag_taus();
        let mut maps = [d.port, d.starboard, d.vertical];
        let mut paths = [PathEffects::default(); 3];
        let mut gains = [0.0; 3];
        for (i, (map, path)) in maps.iter_mut().zip(paths.iter_mut()).enumerate() {
            let (cl, cq) = (
                self.coef_lin.get(i).copied().unwrap_or(0.0),
                self.coef_quad.get(i).copied().unwrap_or(0.0),
            );
            // The base map's geometry factor (axis force per newton of this thruster).
            let base_n = cl + cq;
            let k = if base_n > 0.0 {
                (map.forward.linear_n + map.forward.quadratic_n) / base_n
            } else {
                0.0
            };
            let g = self.thruster_group(i).index();
            let forward = ThrustPair {
                linear_n: self.thrust_lin[g] * cl,
                quadratic_n: self.thrust_quad[g] * cq,
            };
            let r = self.fx.reverse_ratio[g];
            let reverse = ThrustPair {
                linear_n: r * forward.linear_n,
                quadratic_n: r * forward.quadratic_n,
            };
            *map = QuadraticThrustMap { forward, reverse }.scaled(k);
            *path = PathEffects {
                dead_zone: self.fx.deadzone,
                lag_tau_s: taus.get(i).copied().unwrap_or(0.0),
            };
            gains[i] = k;
        }
        let [port, starboard, vertical] = maps;
        d.port = port;
        d.starboard = starboard;
        d.vertical = vertical;
        [d.port_path, d.starboard_path, d.vertical_path] = paths;
        if self.kind == BaseKind::Model1 {
            d.heave.static_load += self.fx.net_weight_m1_n;
        }
        d.yaw_per_heave_m = if gains[2] > 0.0 {
            self.fx.torque_v_m / gains[2]
        } else {
            0.0
        };
        d.name = self.name.clone();
        Some(d)
    }

    fn clone_box(&self) -> Box<dyn VehicleModel> {
        Box::new(self.clone())
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}
