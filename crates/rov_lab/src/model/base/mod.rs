//! The base models the lab builds on: one file per base ([`model1`], [`model2`],
//! [`model3`], [`vehicle`]), each implementing [`BaseModel`] — what differs from base to
//! base: its parameters (which exist, their values, setting them), its dynamics through
//! `rov_dynamics`, the channels and degrees of freedom it predicts, its command channels
//! and thrusters, and its name. [`LabModel`] holds one [`Base`] and puts the calibration,
//! the effects and the discovered terms on top without looking at which base it is.
//!
//! Adding a base: a file here implementing [`BaseModel`], a [`BaseKind`] and a [`Base`]
//! variant, and its arm in the dispatch below ([`Base::from_text`], [`Base::model`],
//! [`Base::model_mut`], [`BaseKind`]'s facts).

pub(super) mod model1;
pub(super) mod model2;
pub(super) mod model3;
pub(super) mod vehicle;

use rov_dynamics::Vector6;
use rov_dynamics::kinematics::QuatState;
use rov_dynamics::models::vehicle::{ChannelTable, CommandChannel, Commands, MAX_THRUSTERS};
use rov_dynamics::models::{Channel, ModelState, ThrusterForces, VehicleModel};
use rov_dynamics::plant::PlantDescription;
use rov_dynamics::process::{CurrentSample, ProcessParams};
use rov_dynamics::thrusters::{QuadraticThrustMap, ThrustPair};

use super::{LabModel, PerThruster, Signals};
use crate::LabError;
use crate::catalog::EffectId;
use crate::params::{Axis, Documented, Param, Thr};

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
            BaseKind::Model1 => model1::NAME,
            BaseKind::Model2 => model2::NAME,
            BaseKind::Model3 => model3::NAME,
            BaseKind::Vehicle => vehicle::NAME,
        }
    }

    /// Parses a Pro 4 base name through the one model identity
    /// ([`rov_types::model_id::BaseModel`]).
    pub fn parse(s: &str) -> Option<Self> {
        rov_types::model_id::BaseModel::from_name(s).map(Self::from)
    }

    /// Whether the base has pitch and roll (a vehicle file: see [`LabModel::has_attitude`]).
    pub fn has_attitude(self) -> bool {
        match self {
            BaseKind::Model1 => model1::HAS_ATTITUDE,
            BaseKind::Model2 => model2::HAS_ATTITUDE,
            BaseKind::Model3 => model3::HAS_ATTITUDE,
            BaseKind::Vehicle => vehicle::HAS_ATTITUDE,
        }
    }

    /// Effects the base already contains (see [`crate::catalog`]).
    pub fn contains(self, e: EffectId) -> bool {
        match self {
            BaseKind::Model1 => model1::contains(e),
            BaseKind::Model2 => model2::contains(e),
            BaseKind::Model3 => model3::contains(e),
            BaseKind::Vehicle => vehicle::contains(e),
        }
    }

    /// Why an effect cannot be represented in this base at all (it acts only through
    /// states the base does not have), if so.
    pub fn not_applicable(self, e: EffectId) -> Option<&'static str> {
        match self {
            BaseKind::Model1 => model1::not_applicable(e),
            BaseKind::Model2 => model2::not_applicable(e),
            BaseKind::Model3 => model3::not_applicable(e),
            BaseKind::Vehicle => vehicle::not_applicable(e),
        }
    }

    /// The base parameters that calibration frees (four-channel data) for the Pro 4
    /// bases (a vehicle file: [`LabModel::calibration_params`]).
    pub fn calibration_params(self) -> Vec<Param> {
        match self {
            BaseKind::Model1 => model1::calibration_params(),
            BaseKind::Model2 => model2::calibration_params(),
            BaseKind::Model3 => model3::calibration_params(),
            BaseKind::Vehicle => vehicle::calibration_params(),
        }
    }
}

/// The calibrated scales of a thruster's group: linear, quadratic and reverse ratio.
#[derive(Debug, Clone, Copy)]
pub(super) struct ThrustScales {
    pub lin: f64,
    pub quad: f64,
    pub reverse_ratio: f64,
}

impl ThrustScales {
    /// The one thrust map (rov_dynamics::thrusters::QuadraticThrustMap): the calibrated
    /// forward pair, and the reverse pair weakened by the asymmetry effect.
    pub fn map(&self, fwd: ThrustPair, rev: ThrustPair) -> QuadraticThrustMap {
        QuadraticThrustMap {
            forward: ThrustPair {
                linear_n: self.lin * fwd.linear_n,
                quadratic_n: self.quad * fwd.quadratic_n,
            },
            reverse: ThrustPair {
                linear_n: self.lin * rev.linear_n * self.reverse_ratio,
                quadratic_n: self.quad * rev.quadratic_n * self.reverse_ratio,
            },
        }
    }
}

/// What differs from base to base. The lab's layers ([`LabModel`]) call these and never
/// ask which base they hold.
pub(super) trait BaseModel {
    /// Which base.
    fn kind(&self) -> BaseKind;

    /// The base's name: "model1" … (default: its kind's) or the vehicle file's `vehicle`.
    fn name(&self) -> &str {
        self.kind().name()
    }

    /// The vehicle definition of a vehicle-file base.
    fn vehicle(&self) -> Option<&rov_dynamics::models::vehicle::VehicleDef> {
        None
    }

    /// Number of thrusters and each one's calibration group (default: the Pro 4's port,
    /// starboard and vertical).
    fn thrusters(&self) -> (usize, [Thr; MAX_THRUSTERS]) {
        pro4_thrusters()
    }

    /// Factor from a body force to the base's τ, per DOF (model1 scales its inputs).
    fn drag_tau_factor(&self) -> [f64; 6] {
        [1.0; 6]
    }

    /// The vehicle's weight W, N.
    fn weight_n(&self) -> f64;

    /// The base's `rov_dynamics` model, where the base is one (the Pro 4 bases): the
    /// defaults below go through it.
    fn rov_model(&self) -> Option<&dyn VehicleModel> {
        None
    }

    /// (linear, quadratic) full-command thrust per thruster of the base's own curves, N
    /// (the Pro 4 bases; none for a base with its own [`Self::thrust_n`]).
    fn thrust_pairs(&self) -> &[(f64, f64)] {
        &[]
    }

    /// Whether the base has pitch and roll (default: its kind's).
    fn has_attitude(&self) -> bool {
        self.kind().has_attitude()
    }

    /// Which of ν = (u, v, w, p, q, r) the base's state can move.
    fn nu_active(&self) -> [bool; 6];

    /// Whether the base predicts a channel (default: as its `rov_dynamics` model).
    fn predicts(&self, ch: Channel) -> bool {
        self.rov_model().is_some_and(|m| m.predicts(ch))
    }

    /// Whether the lab's simulator integrates the attitude with quaternions.
    fn uses_quaternion(&self) -> bool {
        false
    }

    /// Whether the thrust lines are calibrated (the moment arms are base parameters).
    fn arms_calibrated(&self) -> bool {
        false
    }

    /// Whether the base already contains an effect (default: its kind's).
    fn contains(&self, e: EffectId) -> bool {
        self.kind().contains(e)
    }

    /// Why an effect cannot be represented in this base, if so (default: its kind's).
    fn not_applicable(&self, e: EffectId) -> Option<&'static str> {
        self.kind().not_applicable(e)
    }

    /// The base parameters that calibration frees (default: its kind's).
    fn calibration_params(&self) -> Vec<Param> {
        self.kind().calibration_params()
    }

    /// Whether a parameter exists with this base (every parameter but the terms').
    fn applicable(&self, p: Param) -> bool;

    /// The documented uncertainty of a base parameter (`None`: no prior; default: the
    /// Pro 4's, [`crate::params::documented_pro4`]).
    fn documented(&self, p: Param) -> Option<Documented> {
        crate::params::documented_pro4(p)
    }

    /// σ of the calibrated moment arms' prior, m (when [`Self::arms_calibrated`]).
    fn arms_sigma_m(&self) -> Option<f64> {
        None
    }

    /// Value of a parameter the base holds (damping, added mass, CG, net weight,
    /// command gain); `None` for the others.
    fn get(&self, p: Param) -> Option<f64>;

    /// (linear, quadratic) damping of an axis.
    fn drag(&self, a: Axis) -> (f64, f64);

    /// Sets parameters the base holds (applicable, clamped) and rebuilds the base once.
    fn set_many(&mut self, pv: &[(Param, f64)]) -> Result<(), LabError>;

    /// Net vertical body force the lab adds for the base (model1's W − B), N.
    fn lab_heave_force_n(&self) -> f64 {
        0.0
    }

    /// The command channels the base reads (default: the Pro 4's three).
    fn command_channels(&self) -> &[CommandChannel] {
        &PRO4_CHANNELS
    }

    /// The base's channel table (default: the built-in channels only).
    fn channel_table(&self) -> &ChannelTable {
        static BUILTIN: ChannelTable = ChannelTable::builtin();
        &BUILTIN
    }

    /// Names of the base's command signals (at most [`super::MAX_SIGNALS`]).
    fn command_names(&self) -> Vec<&str> {
        PRO4_CHANNELS
            .iter()
            .filter_map(|c| c.builtin_name())
            .collect()
    }

    /// The command signals (fractions of full command) from a command vector (default:
    /// the Pro 4's three channels).
    fn command_signals(&self, c: &Commands) -> Signals {
        let mut out = [0.0; super::MAX_SIGNALS];
        for (o, ch) in out.iter_mut().zip(PRO4_CHANNELS) {
            *o = c[ch.index()] * 0.01;
        }
        out
    }

    /// Thruster commands (%) for a command vector (default: the Pro 4's port, starboard
    /// and vertical channels).
    fn thruster_targets(&self, c: &Commands) -> PerThruster {
        let mut out = [0.0; MAX_THRUSTERS];
        for (o, ch) in out.iter_mut().zip(PRO4_CHANNELS) {
            *o = c[ch.index()];
        }
        out
    }

    /// The step of the commands the vehicle receives, % (`None`: not documented). The
    /// Pro 4 receives whole percent ([`crate::verdict::PRO4_COMMAND_RESOLUTION_PCT`]).
    fn command_resolution_pct(&self) -> Option<f64> {
        Some(crate::verdict::PRO4_COMMAND_RESOLUTION_PCT)
    }

    /// Adds the base's own thruster lags (s) to the effect's.
    fn add_thruster_lags(&self, _taus: &mut PerThruster) {}

    /// The base's own (linear, quadratic) full-command thrust of thruster `i`, N (zeros
    /// past [`Self::thrust_pairs`]).
    fn thrust_pair(&self, i: usize) -> (f64, f64) {
        self.thrust_pairs().get(i).copied().unwrap_or((0.0, 0.0))
    }

    /// Thrust of thruster `i` for a command in percent (after the dead zone), N
    /// (default: the base's [`Self::thrust_pair`] through the calibrated map).
    fn thrust_n(&self, i: usize, pct: f64, s: ThrustScales) -> f64 {
        let (l, q) = self.thrust_pair(i);
        let pair = ThrustPair {
            linear_n: l,
            quadratic_n: q,
        };
        s.map(pair, pair).force_n(pct)
    }

    /// τ of the thrusters (allocation plus the effects' arms and reaction torques;
    /// default: the `rov_dynamics` model's allocation of the Pro 4's three thrusters plus
    /// the effects' moment arms and propeller reaction torques).
    fn thrust_tau(&self, lab: &LabModel, f: &PerThruster, state: &ModelState) -> Vector6 {
        let mut tau = match self.rov_model() {
            Some(m) => m.generalized_force(&pro4_forces(f), state),
            None => Vector6::zeros(),
        };
        let x = lab.effect_values();
        tau[3] += x.arm_yv_m * f[2] + x.torque_h_m * (f[0] - f[1]);
        tau[4] += x.arm_zh_m * (f[0] + f[1]) - x.arm_xv_m * f[2];
        tau[5] += x.torque_v_m * f[2];
        tau
    }

    /// (η̇, ν̇) for τ of the thrusters and terms, with the effects' body forces (default:
    /// through [`Self::body_derivative`]).
    fn eta_nu_derivative(
        &self,
        lab: &LabModel,
        eta: &Vector6,
        nu: &Vector6,
        tau_thrust: &Vector6,
        current: &CurrentSample,
    ) -> (Vector6, Vector6) {
        let d = self.body_derivative(lab, &ModelState::new(*eta, *nu), tau_thrust, current);
        (d.eta, d.nu)
    }

    /// State derivative for τ of the thrusters and terms, with the effects' body forces
    /// and current (default: the `rov_dynamics` model's dynamics; for a base without pitch
    /// the `pitch-depth-coupling` trim enters the depth kinematics; a base without a
    /// `rov_dynamics` model goes through [`Self::eta_nu_derivative`], which it overrides).
    fn body_derivative(
        &self,
        lab: &LabModel,
        state: &ModelState,
        tau_thrust: &Vector6,
        current: &CurrentSample,
    ) -> ModelState {
        let Some(m) = self.rov_model() else {
            let (eta, nu) = self.eta_nu_derivative(lab, &state.eta, &state.nu, tau_thrust, current);
            return ModelState::new(eta, nu);
        };
        let tau = tau_thrust + lab.extra_tau(state);
        let mut d = m.dynamics(state, &tau, &lab.effect_current(current));
        let trim_rad = lab.effect_values().trim_rad;
        if trim_rad != 0.0 && !self.has_attitude() {
            let (s, c) = trim_rad.sin_cos();
            d.eta[2] = state.nu[2] * c - state.nu[0] * s;
        }
        d
    }

    /// Quaternion-state derivative (`None` unless [`Self::uses_quaternion`]).
    fn quat_derivative(
        &self,
        _lab: &LabModel,
        _x: &QuatState,
        _tau_thrust: &Vector6,
        _current: &CurrentSample,
        _yaw_hint_rad: f64,
    ) -> Option<QuatState> {
        None
    }

    /// Thruster forces for the [`VehicleModel`] record.
    fn forces_record(&self, f: &PerThruster) -> ThrusterForces {
        pro4_forces(f)
    }

    /// τ of a [`VehicleModel`] force record.
    fn tau_of_record(&self, lab: &LabModel, f: &PerThruster, state: &ModelState) -> Vector6 {
        self.thrust_tau(lab, f, state)
    }

    /// The base's plant reduction (`None`: not reducible; default: its `rov_dynamics`
    /// model's).
    fn plant(&self) -> Option<PlantDescription> {
        self.rov_model()?.plant()
    }
}

/// One base (enum dispatch over the [`BaseModel`] implementations keeps [`LabModel`]
/// `Clone`).
#[derive(Debug, Clone)]
pub(super) enum Base {
    M1(model1::Model1Base),
    M2(model2::Model2Base),
    M3(Box<model3::Model3Base>),
    Vehicle(Box<vehicle::VehicleBase>),
}

/// Calls a [`BaseModel`] method on a [`Base`] with static dispatch (each arm its own
/// monomorphised call, so the simulator's hot path inlines as it did before the trait).
macro_rules! on_base {
    ($base:expr, $b:ident => $call:expr) => {
        match $base {
            $crate::model::base::Base::M1($b) => $call,
            $crate::model::base::Base::M2($b) => $call,
            $crate::model::base::Base::M3($b) => $call,
            $crate::model::base::Base::Vehicle($b) => $call,
        }
    };
}
pub(super) use on_base;

impl Base {
    /// A base of a kind from its parameter-file text (`label` names it in errors).
    pub fn from_text(kind: BaseKind, text: &str, label: &str) -> Result<Self, LabError> {
        Ok(match kind {
            BaseKind::Model1 => Base::M1(model1::Model1Base::from_text(text, label)?),
            BaseKind::Model2 => Base::M2(model2::Model2Base::from_text(text, label)?),
            BaseKind::Model3 => Base::M3(Box::new(model3::Model3Base::from_text(text, label)?)),
            BaseKind::Vehicle => {
                Base::Vehicle(Box::new(vehicle::VehicleBase::from_text(text, label)?))
            }
        })
    }

    /// The base behind its trait.
    #[inline]
    pub fn model(&self) -> &dyn BaseModel {
        match self {
            Base::M1(b) => b,
            Base::M2(b) => b,
            Base::M3(b) => b.as_ref(),
            Base::Vehicle(b) => b.as_ref(),
        }
    }

    /// The base behind its trait, to change it.
    pub fn model_mut(&mut self) -> &mut dyn BaseModel {
        match self {
            Base::M1(b) => b,
            Base::M2(b) => b,
            Base::M3(b) => b.as_mut(),
            Base::Vehicle(b) => b.as_mut(),
        }
    }
}

// ---- What the three Pro 4 bases share ----

/// The Pro 4's command channels, in its thruster order.
const PRO4_CHANNELS: [CommandChannel; 3] = [
    CommandChannel::PORT,
    CommandChannel::STARBOARD,
    CommandChannel::VERTICAL,
];

/// The Pro 4's three thrusters and their groups.
fn pro4_thrusters() -> (usize, [Thr; MAX_THRUSTERS]) {
    let mut g = [Thr::Port; MAX_THRUSTERS];
    g[0] = Thr::Port;
    g[1] = Thr::Starboard;
    g[2] = Thr::Vertical;
    (3, g)
}

/// The first three thrusters as the Pro 4's port, starboard and vertical.
fn pro4_forces(f: &PerThruster) -> ThrusterForces {
    ThrusterForces {
        port_n: f[0],
        starboard_n: f[1],
        vertical_n: f[2],
    }
}

/// Whether a parameter exists with a Pro 4 base: `six_dof` for model3, `quad` when the
/// thrust curves have a quadratic part.
pub(super) fn pro4_applicable(p: Param, six_dof: bool, quad: bool) -> bool {
    let planar_axis = |a: Axis| matches!(a, Axis::Surge | Axis::Heave | Axis::Yaw);
    let pro4_group = |g: Thr| matches!(g, Thr::Port | Thr::Starboard | Thr::Vertical);
    match p {
        Param::CommandGain | Param::ArmXh | Param::ArmYh => false,
        Param::ThrustLin(g) | Param::ReverseRatio(g) | Param::Emi(g) => pro4_group(g),
        Param::ThrustQuad(g) => quad && pro4_group(g),
        Param::DragLin(a) | Param::DragQuad(a) => six_dof || planar_axis(a),
        Param::AddedMass(a) => six_dof || planar_axis(a),
        Param::CgZ | Param::CgX | Param::CgY => six_dof,
        Param::ArmZh
        | Param::ArmXv
        | Param::ArmYv
        | Param::TorqueH
        | Param::BiasRoll
        | Param::BiasPitch => six_dof,
        Param::TrimDeg => !six_dof,
        Param::DragRatio(a) => six_dof || planar_axis(a),
        _ => true,
    }
}

/// The Pro 4 calibration set: thrust scales (quadratic ones when `quad`), heave and yaw
/// damping, then `extra`.
pub(super) fn pro4_calibration_params(quad: bool, extra: &[Param]) -> Vec<Param> {
    let mut v = Vec::new();
    for t in [Thr::Port, Thr::Starboard, Thr::Vertical] {
        v.push(Param::ThrustLin(t));
        if quad {
            v.push(Param::ThrustQuad(t));
        }
    }
    for a in [Axis::Heave, Axis::Yaw] {
        v.push(Param::DragLin(a));
        v.push(Param::DragQuad(a));
    }
    v.extend_from_slice(extra);
    v
}

/// Why an effect cannot be represented in a Pro 4 base without pitch and roll.
pub(super) fn pro4_planar_not_applicable(e: EffectId) -> Option<&'static str> {
    match e {
        EffectId::ThrusterMomentArm => {
            Some("its moments act on pitch and roll, which this model does not have (use model3)")
        }
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

/// Effects a 6-DOF base contains (model3, vehicle files).
pub(super) fn six_dof_contains(e: EffectId) -> bool {
    matches!(
        e,
        EffectId::AddedMass
            | EffectId::NetBuoyancy
            | EffectId::Coriolis
            | EffectId::RestoringOffset
            | EffectId::PitchDepthCoupling
    )
}

/// The planar Pro 4 bases' state: surge, heave and yaw.
pub(super) const PLANAR_NU: [bool; 6] = [true, false, true, false, false, true];

/// A `rov_dynamics` model that the base's parameters made invalid.
pub(super) fn model_error(e: impl std::fmt::Display) -> LabError {
    LabError::Model {
        detail: e.to_string(),
    }
}

/// Loads a Pro 4 base through `rov_dynamics` and takes it as its own type.
pub(super) fn load_pro4<T: Clone + 'static>(
    kind: BaseKind,
    text: &str,
    label: &str,
) -> Result<T, LabError> {
    let boxed = rov_dynamics::models::load_model(kind.name(), text, label)?;
    boxed
        .as_any()
        .downcast_ref::<T>()
        .cloned()
        .ok_or_else(|| LabError::Model {
            detail: format!("{label}: unexpected model type"),
        })
}

// ---- What the 6-DOF process bases share (model3, vehicle files) ----

/// A base parameter held in `rov_dynamics`' process parameters (damping, CG, net weight,
/// added mass); `None` for the others.
pub(super) fn process_get(q: &ProcessParams, p: Param) -> Option<f64> {
    match p {
        Param::DragLin(a) => Some(process_drag(q, a).0),
        Param::DragQuad(a) => Some(process_drag(q, a).1),
        Param::CgX => Some(q.rigid_body.cg_from_co_m.x),
        Param::CgY => Some(q.rigid_body.cg_from_co_m.y),
        Param::CgZ => Some(q.rigid_body.cg_from_co_m.z),
        Param::NetWeight => Some(q.hydrostatics.weight_n - q.hydrostatics.buoyancy_n),
        Param::AddedMass(a) => {
            let i = a.index();
            Some(q.added_mass[(i, i)])
        }
        _ => None,
    }
}

/// (linear, quadratic) damping of an axis in process parameters.
pub(super) fn process_drag(q: &ProcessParams, a: Axis) -> (f64, f64) {
    let i = a.index();
    (q.damping.linear[(i, i)], q.damping.quadratic[i])
}

/// Sets a base parameter held in process parameters (others are left alone).
pub(super) fn process_set(q: &mut ProcessParams, p: Param, v: f64) {
    match p {
        Param::DragLin(a) => {
            let i = a.index();
            q.damping.linear[(i, i)] = v;
        }
        Param::DragQuad(a) => q.damping.quadratic[a.index()] = v,
        Param::CgX | Param::CgY | Param::CgZ => {
            let k = match p {
                Param::CgX => 0,
                Param::CgY => 1,
                _ => 2,
            };
            q.rigid_body.cg_from_co_m[k] = v;
            q.hydrostatics.cg_from_co_m[k] = v;
        }
        Param::NetWeight => q.hydrostatics.buoyancy_n = q.hydrostatics.weight_n - v,
        Param::AddedMass(a) => {
            let i = a.index();
            q.added_mass[(i, i)] = v;
        }
        _ => {}
    }
}

/// The body τ with the effects' extra forces when any is on (the hot path skips the
/// zero sum).
#[inline]
pub(super) fn with_body_effects(
    lab: &LabModel,
    tau_thrust: &Vector6,
    state: impl FnOnce() -> ModelState,
) -> Vector6 {
    if lab.has_body_effects() {
        tau_thrust + lab.extra_tau(&state())
    } else {
        *tau_thrust
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::LabModel;

    fn vehicle(file: &str) -> LabModel {
        let path = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../../config/vehicles")
            .join(file);
        let text = std::fs::read_to_string(path).unwrap();
        LabModel::from_vehicle_text(&text, file).unwrap()
    }

    #[test]
    fn each_pro4_base_is_of_its_kind_and_has_its_kinds_facts() {
        for kind in BaseKind::ALL {
            let m = LabModel::default_base(kind).unwrap();
            assert_eq!(m.kind(), kind);
            assert_eq!(m.base_name(), kind.name());
            assert_eq!(m.has_attitude(), kind.has_attitude());
            assert_eq!(m.calibration_params(), kind.calibration_params());
            for e in EffectId::ALL {
                assert_eq!(m.contains(e), kind.contains(e), "{kind:?} {e:?}");
                assert_eq!(
                    m.not_applicable(e),
                    kind.not_applicable(e),
                    "{kind:?} {e:?}"
                );
            }
            assert_eq!(m.n_thrusters(), 3);
            assert_eq!(m.command_names(), ["port", "starboard", "vertical"]);
        }
    }

    #[test]
    fn a_vehicle_files_structure_decides_what_its_base_has() {
        let four = vehicle("videoray_pro4_lateral.toml");
        let six = vehicle("bluerov2_heavy.toml");
        for m in [&four, &six] {
            assert_eq!(m.kind(), BaseKind::Vehicle);
            assert_eq!(Some(m.base_name()), m.vehicle().map(|v| v.name.as_str()));
            assert_eq!(m.command_resolution_pct(), None);
        }
        // Locked pitch and roll: no attitude effects, a trim for the depth kinematics.
        assert!(!four.has_attitude() && !four.uses_quaternion());
        assert!(four.not_applicable(EffectId::AttitudeBias).is_some());
        assert!(
            BaseKind::Vehicle
                .not_applicable(EffectId::AttitudeBias)
                .is_none()
        );
        assert!(!four.contains(EffectId::PitchDepthCoupling));
        assert!(four.applicable(Param::TrimDeg) && !four.applicable(Param::CgZ));
        assert!(six.has_attitude() && six.uses_quaternion());
        assert!(six.contains(EffectId::PitchDepthCoupling));
        assert!(!six.applicable(Param::TrimDeg) && six.applicable(Param::CgZ));
        assert_eq!(six.n_thrusters(), 8);
    }

    #[test]
    fn model1s_net_weight_is_held_by_its_base_and_reaches_the_plant() {
        use rov_dynamics::models::VehicleModel;
        let mut m = LabModel::default_base(BaseKind::Model1).unwrap();
        let load0 = m.plant().unwrap().heave.static_load;
        assert_eq!(m.get(Param::NetWeight), Some(0.0));
        m.set_many(&[Param::NetWeight], &[5.0]).unwrap();
        assert_eq!(m.get(Param::NetWeight), Some(5.0));
        assert_eq!(m.plant().unwrap().heave.static_load, load0 + 5.0);
        // model2 keeps W − B in its own parameters: no lab-carried force.
        let mut m2 = LabModel::default_base(BaseKind::Model2).unwrap();
        m2.set_many(&[Param::NetWeight], &[5.0]).unwrap();
        assert_eq!(m2.get(Param::NetWeight), Some(5.0));
        assert_eq!(m2.base.model().lab_heave_force_n(), 0.0);
        assert_eq!(m.base.model().lab_heave_force_n(), 5.0);
    }
}
