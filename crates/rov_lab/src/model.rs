//! The lab model: a base model (model1, model2 or model3) with calibrated thrust scales
//! and damping, plus any catalog effects, behind [`VehicleModel`] so that `sim`, `hold`
//! and the lab load it like any model.
//!
//! # Layers
//!
//! * Thrust (stage a): per thruster F = k_l A u + k_q B u|u| with the base's own
//!   coefficients (A, B) and the calibrated scales (k_l, k_q); the dead zone shifts u,
//!   the asymmetry scales reverse thrust, the power limit scales all three.
//! * Generalized force (stage b): the base's allocation, plus the moment arms and the
//!   propeller reaction torques.
//! * Dynamics (stage c): the base's dynamics with extra body forces (net buoyancy for
//!   model1, tether, asymmetric drag) and the effect's current; for model1/model2 the trim
//!   angle of `pitch-depth-coupling` enters the depth kinematics.
//! * Outputs (stage d): depth drift, compass deviation and interference, attitude biases.
//!
//! Thruster lag: in [`VehicleModel`] form it is three extra states with ȧ = (u − a)/τ
//! (τ → 0 switches it off). The lab's own simulator ([`crate::sim`]) updates the lag
//! exactly on the held command instead, which stays valid for τ → 0.

use std::any::Any;

use rov_dynamics::Vector6;
use rov_dynamics::kinematics::Attitude;
use rov_dynamics::models::{
    Channel, InitialConditions, Model1, Model2, Model3, ModelOutput, ModelState, ThrusterForces,
    VehicleModel, load_model,
};
use rov_dynamics::process::CurrentSample;
use rov_dynamics::thrusters::{ThrustMap, ThrustPct};

use crate::LabError;
use crate::catalog::EffectId;
use crate::params::{Axis, Param, Thr};

/// Tether attachment point from the CO (body axes), m: behind the hull on its axis.
pub const TETHER_ATTACH_X_M: f64 = -0.2;

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
}

impl BaseKind {
    /// All three.
    pub const ALL: [BaseKind; 3] = [BaseKind::Model1, BaseKind::Model2, BaseKind::Model3];

    /// "model1" …
    pub fn name(self) -> &'static str {
        match self {
            BaseKind::Model1 => "model1",
            BaseKind::Model2 => "model2",
            BaseKind::Model3 => "model3",
        }
    }

    /// Parses a base name.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.iter().copied().find(|k| k.name() == s)
    }

    /// Whether the base has pitch and roll.
    pub fn has_attitude(self) -> bool {
        self == BaseKind::Model3
    }

    /// Effects the base already contains (see [`crate::catalog`]).
    pub fn contains(self, e: EffectId) -> bool {
        match self {
            BaseKind::Model1 => matches!(e, EffectId::AddedMass),
            BaseKind::Model2 => matches!(
                e,
                EffectId::AddedMass | EffectId::NetBuoyancy | EffectId::Coriolis
            ),
            BaseKind::Model3 => matches!(
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

    /// The base parameters that calibration frees (four-channel data).
    pub fn calibration_params(self) -> Vec<Param> {
        let mut v = Vec::new();
        for t in Thr::ALL {
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

/// Values of every effect parameter (off values when an effect is absent).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EffectValues {
    /// Reverse/forward thrust ratio per thruster.
    pub reverse_ratio: [f64; 3],
    /// Lag time constant, s.
    pub lag_tau_s: f64,
    /// Dead zone, fraction of full command.
    pub deadzone: f64,
    /// Power budget in Σ|u|³ units.
    pub power_max: f64,
    /// Horizontal line of action below CO, m.
    pub arm_zh_m: f64,
    /// Vertical thruster forward of CO, m.
    pub arm_xv_m: f64,
    /// Vertical thruster to starboard of CO, m.
    pub arm_yv_m: f64,
    /// Vertical reaction torque per N, m.
    pub torque_v_m: f64,
    /// Horizontal differential reaction roll torque per N, m.
    pub torque_h_m: f64,
    /// model1's W − B, N.
    pub net_weight_m1_n: f64,
    /// Trim for the depth kinematics (model1/model2), rad.
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
    /// Compass interference per unit |u|, deg.
    pub emi_deg: [f64; 3],
    /// Roll bias, deg.
    pub bias_roll_deg: f64,
    /// Pitch bias, deg.
    pub bias_pitch_deg: f64,
}

impl Default for EffectValues {
    fn default() -> Self {
        Self {
            reverse_ratio: [1.0; 3],
            lag_tau_s: 0.0,
            deadzone: 0.0,
            power_max: 3.0,
            arm_zh_m: 0.0,
            arm_xv_m: 0.0,
            arm_yv_m: 0.0,
            torque_v_m: 0.0,
            torque_h_m: 0.0,
            net_weight_m1_n: 0.0,
            trim_rad: 0.0,
            drag_ratio: [1.0; 6],
            current_ne_mps: [0.0; 2],
            tether_ne_n: [0.0; 2],
            depth_drift_mps: 0.0,
            compass_dev_deg: [0.0; 2],
            emi_deg: [0.0; 3],
            bias_roll_deg: 0.0,
            bias_pitch_deg: 0.0,
        }
    }
}

#[derive(Debug, Clone)]
enum Base {
    M1(Model1),
    M2(Model2),
    M3(Box<Model3>),
}

/// A base model with calibration and effects.
#[derive(Debug, Clone)]
pub struct LabModel {
    kind: BaseKind,
    base: Base,
    base_text: String,
    coef_lin: [f64; 3],
    coef_quad: [f64; 3],
    thrust_lin: [f64; 3],
    thrust_quad: [f64; 3],
    fx: EffectValues,
    active: Vec<EffectId>,
    name: String,
    drag_tau_factor: [f64; 6],
    has_sensor_fx: bool,
    has_body_fx: bool,
}

fn thrust_coefs(map: &ThrustMap) -> (f64, f64) {
    match map {
        ThrustMap::Quadratic(q) => (q.forward.linear_n, q.forward.quadratic_n),
        ThrustMap::Linear(l) => (l.gain_n_per_pct * 100.0, 0.0),
    }
}

impl LabModel {
    /// From a base model's parameter-file text (`label` names it in errors).
    pub fn from_base_text(kind: BaseKind, text: &str, label: &str) -> Result<Self, LabError> {
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
        };
        let mut drag_tau_factor = [1.0; 6];
        if let Base::M1(m) = &base {
            let a = m.params().alpha;
            drag_tau_factor[0] = 1.0 / a[0];
            drag_tau_factor[2] = 1.0 / a[1];
            drag_tau_factor[5] = 1.0 / a[2];
        }
        Ok(Self {
            kind,
            base,
            base_text: text.to_string(),
            coef_lin,
            coef_quad,
            thrust_lin: [1.0; 3],
            thrust_quad: [1.0; 3],
            fx: EffectValues::default(),
            active: Vec::new(),
            name: kind.name().to_string(),
            drag_tau_factor,
            has_sensor_fx: false,
            has_body_fx: false,
        })
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

    /// The base kind.
    pub fn kind(&self) -> BaseKind {
        self.kind
    }

    /// The base parameter-file text this model was built from.
    pub fn base_text(&self) -> &str {
        &self.base_text
    }

    /// Effects added to the base (in order of addition).
    pub fn active_effects(&self) -> &[EffectId] {
        &self.active
    }

    /// The effect values.
    pub fn effect_values(&self) -> &EffectValues {
        &self.fx
    }

    /// Marks an effect as part of the model (its parameters keep their values). A
    /// contained effect is not added (its parameters are base parameters).
    pub fn add_effect(&mut self, e: EffectId) {
        if !self.kind.contains(e) && !self.active.contains(&e) {
            self.active.push(e);
        }
        self.refresh_name();
    }

    fn refresh_name(&mut self) {
        let mut n = self.kind.name().to_string();
        for e in &self.active {
            n.push('+');
            n.push_str(e.key());
        }
        self.name = n;
        let f = &self.fx;
        self.has_sensor_fx = f.depth_drift_mps != 0.0
            || f.compass_dev_deg != [0.0; 2]
            || f.emi_deg != [0.0; 3]
            || f.bias_roll_deg != 0.0
            || f.bias_pitch_deg != 0.0;
        self.has_body_fx =
            f.net_weight_m1_n != 0.0 || f.tether_ne_n != [0.0; 2] || f.drag_ratio != [1.0; 6];
    }

    /// Whether a parameter exists in this model.
    pub fn applicable(&self, p: Param) -> bool {
        let m3 = self.kind == BaseKind::Model3;
        match p {
            Param::ThrustQuad(_) => self.kind != BaseKind::Model2,
            Param::DragLin(a) | Param::DragQuad(a) => {
                m3 || matches!(a, Axis::Surge | Axis::Heave | Axis::Yaw)
            }
            Param::AddedMass(a) => m3 || matches!(a, Axis::Surge | Axis::Heave | Axis::Yaw),
            Param::CgZ | Param::CgX | Param::CgY => m3,
            Param::ArmZh
            | Param::ArmXv
            | Param::ArmYv
            | Param::TorqueH
            | Param::BiasRoll
            | Param::BiasPitch => m3,
            Param::TrimDeg => !m3,
            Param::DragRatio(a) => m3 || matches!(a, Axis::Surge | Axis::Heave | Axis::Yaw),
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
            Param::CgZ | Param::CgX | Param::CgY => match &self.base {
                Base::M3(m) => {
                    let cg = m.params().process.rigid_body.cg_from_co_m;
                    match p {
                        Param::CgX => cg.x,
                        Param::CgY => cg.y,
                        _ => cg.z,
                    }
                }
                _ => return None,
            },
            Param::NetWeight => match &self.base {
                Base::M1(_) => f.net_weight_m1_n,
                Base::M2(m) => m.params().weight_n - m.params().buoyancy_n,
                Base::M3(m) => m.net_weight_n(),
            },
            Param::AddedMass(a) => self.added_mass(a)?,
            Param::ReverseRatio(t) => f.reverse_ratio[t.index()],
            Param::LagTau => f.lag_tau_s,
            Param::Deadzone => f.deadzone,
            Param::PowerMax => f.power_max,
            Param::ArmZh => f.arm_zh_m,
            Param::ArmXv => f.arm_xv_m,
            Param::ArmYv => f.arm_yv_m,
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
                    if let Some(q) = m3.as_mut() {
                        let i = a.index();
                        if lin {
                            q.process.damping.linear[(i, i)] = v;
                        } else {
                            q.process.damping.quadratic[i] = v;
                        }
                    }
                }
                Param::CgX | Param::CgY | Param::CgZ => {
                    if let Some(q) = m3.as_mut() {
                        let k = match p {
                            Param::CgX => 0,
                            Param::CgY => 1,
                            _ => 2,
                        };
                        q.process.rigid_body.cg_from_co_m[k] = v;
                        q.process.hydrostatics.cg_from_co_m[k] = v;
                    }
                }
                Param::NetWeight => {
                    if m1.is_some() {
                        f.net_weight_m1_n = v;
                    }
                    if let Some(q) = m2.as_mut() {
                        q.buoyancy_n = q.weight_n - v;
                    }
                    if let Some(q) = m3.as_mut() {
                        q.process.hydrostatics.buoyancy_n = q.process.hydrostatics.weight_n - v;
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
                    if let Some(q) = m3.as_mut() {
                        let i = a.index();
                        q.process.added_mass[(i, i)] = v;
                    }
                }
                Param::ReverseRatio(t) => f.reverse_ratio[t.index()] = v,
                Param::LagTau => f.lag_tau_s = v,
                Param::Deadzone => f.deadzone = v,
                Param::PowerMax => f.power_max = v,
                Param::ArmZh => f.arm_zh_m = v,
                Param::ArmXv => f.arm_xv_m = v,
                Param::ArmYv => f.arm_yv_m = v,
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

    fn base_dyn(&self) -> &dyn VehicleModel {
        match &self.base {
            Base::M1(m) => m,
            Base::M2(m) => m,
            Base::M3(m) => m.as_ref(),
        }
    }

    /// Thrust of one thruster for a command in percent (before the power limit), N.
    #[inline]
    pub fn thrust_n(&self, t: usize, pct: f64) -> f64 {
        let mut u = pct * 0.01;
        let dz = self.fx.deadzone;
        if dz > 0.0 {
            let a = (u.abs() - dz).max(0.0) / (1.0 - dz);
            u = if u < 0.0 { -a } else { a };
        }
        let f = self.thrust_lin[t] * self.coef_lin[t] * u
            + self.thrust_quad[t] * self.coef_quad[t] * u * u.abs();
        if u < 0.0 {
            f * self.fx.reverse_ratio[t]
        } else {
            f
        }
    }

    /// Per-thruster forces for a command (after the power limit).
    #[inline]
    pub fn forces(&self, cmd: &ThrustPct) -> ThrusterForces {
        let mut f = [
            self.thrust_n(0, cmd.port),
            self.thrust_n(1, cmd.starboard),
            self.thrust_n(2, cmd.vertical),
        ];
        let pmax = self.fx.power_max;
        if pmax < 3.0 {
            let c = |x: f64| (x * 0.01).abs().powi(3);
            let demand = c(cmd.port) + c(cmd.starboard) + c(cmd.vertical);
            if demand > pmax {
                let s = pmax / demand;
                for x in &mut f {
                    *x *= s;
                }
            }
        }
        ThrusterForces {
            port_n: f[0],
            starboard_n: f[1],
            vertical_n: f[2],
        }
    }

    /// τ of the thrusters: the base allocation plus arms and reaction torques.
    #[inline]
    pub fn thrust_tau(&self, f: &ThrusterForces, state: &ModelState) -> Vector6 {
        let mut tau = self.base_dyn().generalized_force(f, state);
        let x = &self.fx;
        tau[3] += x.arm_yv_m * f.vertical_n + x.torque_h_m * (f.port_n - f.starboard_n);
        tau[4] += x.arm_zh_m * (f.port_n + f.starboard_n) - x.arm_xv_m * f.vertical_n;
        tau[5] += x.torque_v_m * f.vertical_n;
        tau
    }

    /// State-dependent extra body forces of the effects.
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
        let a = match i {
            0 => Axis::Surge,
            1 => Axis::Sway,
            2 => Axis::Heave,
            3 => Axis::Roll,
            4 => Axis::Pitch,
            _ => Axis::Yaw,
        };
        self.drag(a).1
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

    /// (η̇, ν̇) for a thrust τ: the hot path of the lab's simulator.
    #[inline]
    pub fn eta_nu_derivative(
        &self,
        eta: &Vector6,
        nu: &Vector6,
        tau_thrust: &Vector6,
        current: &CurrentSample,
    ) -> (Vector6, Vector6) {
        if let Base::M3(m) = &self.base {
            let st = ModelState::new(*eta, *nu);
            let tau = tau_thrust + self.extra_tau(&st);
            return m
                .process()
                .state_derivative(eta, nu, &tau, &self.effect_current(current));
        }
        let d = self.body_derivative(&ModelState::new(*eta, *nu), tau_thrust, current);
        (d.eta, d.nu)
    }

    /// State derivative for a thrust τ (without extra states).
    #[inline]
    pub fn body_derivative(
        &self,
        state: &ModelState,
        tau_thrust: &Vector6,
        current: &CurrentSample,
    ) -> ModelState {
        let tau = tau_thrust + self.extra_tau(state);
        let mut d = self
            .base_dyn()
            .dynamics(state, &tau, &self.effect_current(current));
        if self.fx.trim_rad != 0.0 && self.kind != BaseKind::Model3 {
            let (s, c) = self.fx.trim_rad.sin_cos();
            d.eta[2] = state.nu[2] * c - state.nu[0] * s;
        }
        d
    }

    /// Whether any sensor effect is non-zero.
    pub fn has_sensor_effects(&self) -> bool {
        self.has_sensor_fx
    }

    /// The measured value of a channel: the state seen through the sensor effects.
    /// `t_rel_s` counts from the start of the run; `prev_cmd` is the command acting just
    /// before the sample (for thruster interference on the compass).
    #[inline]
    pub fn sensor_value(
        &self,
        ch: Channel,
        state: &ModelState,
        t_rel_s: f64,
        prev_cmd: &ThrustPct,
    ) -> f64 {
        let v = ch.value(state);
        if !self.has_sensor_fx {
            return v;
        }
        let f = &self.fx;
        match ch {
            Channel::Depth => v + f.depth_drift_mps * t_rel_s,
            Channel::Heading => v + self.heading_offset_deg(state.eta[5], prev_cmd),
            Channel::Pitch => v + f.bias_pitch_deg,
            Channel::Roll => v + f.bias_roll_deg,
            _ => v,
        }
    }

    /// The compass reading's offset (deviation and thruster interference) at a heading
    /// under the command acting just before the sample, deg.
    #[inline]
    pub(crate) fn heading_offset_deg(&self, psi_rad: f64, cmd: &ThrustPct) -> f64 {
        let f = &self.fx;
        let (s, c) = psi_rad.sin_cos();
        f.compass_dev_deg[0] * s
            + f.compass_dev_deg[1] * c
            + f.emi_deg[0] * (cmd.port * 0.01).abs()
            + f.emi_deg[1] * (cmd.starboard * 0.01).abs()
            + f.emi_deg[2] * (cmd.vertical * 0.01).abs()
    }

    /// Inverts the sensor model of a channel: the state value (deg or m) that reads `y`.
    pub fn sensor_inverse(&self, ch: Channel, y: f64, t_rel_s: f64, prev_cmd: &ThrustPct) -> f64 {
        if !self.has_sensor_fx {
            return y;
        }
        let f = &self.fx;
        match ch {
            Channel::Depth => y - f.depth_drift_mps * t_rel_s,
            Channel::Heading => {
                let mut psi = y;
                for _ in 0..8 {
                    psi = y - self.heading_offset_deg(psi.to_radians(), prev_cmd);
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
        self.base_dyn().predicts(ch)
    }

    /// Keeps only the DOFs the base has.
    pub fn restrict_state(&self, mut s: ModelState) -> ModelState {
        if self.kind != BaseKind::Model3 {
            s.eta[3] = 0.0;
            s.eta[4] = 0.0;
            s.nu[1] = 0.0;
            s.nu[3] = 0.0;
            s.nu[4] = 0.0;
        }
        s
    }

    fn lag_on(&self) -> bool {
        self.fx.lag_tau_s > 1e-4
    }
}

impl VehicleModel for LabModel {
    fn name(&self) -> &str {
        &self.name
    }

    fn predicts(&self, ch: Channel) -> bool {
        self.base_dyn().predicts(ch)
    }

    fn thruster_forces(&self, cmd: &ThrustPct, state: &ModelState) -> ThrusterForces {
        if self.lag_on() {
            self.forces(&ThrustPct::new(
                state.extra[0],
                state.extra[1],
                state.extra[2],
            ))
        } else {
            self.forces(cmd)
        }
    }

    fn generalized_force(&self, forces: &ThrusterForces, state: &ModelState) -> Vector6 {
        self.thrust_tau(forces, state)
    }

    fn dynamics(&self, state: &ModelState, tau: &Vector6, current: &CurrentSample) -> ModelState {
        self.body_derivative(state, tau, current)
    }

    fn outputs(&self, time_s: f64, state: &ModelState) -> ModelOutput {
        let mut o = self.base_dyn().outputs(time_s, state);
        if self.has_sensor_fx {
            let z = ThrustPct::ZERO;
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
        if self.lag_on() { 3 } else { 0 }
    }

    fn extra_dynamics(&self, _t: f64, state: &ModelState, cmd: &ThrustPct, deriv: &mut ModelState) {
        if self.lag_on() {
            let tau = self.fx.lag_tau_s;
            let u = [cmd.port, cmd.starboard, cmd.vertical];
            for (i, ui) in u.iter().enumerate() {
                deriv.extra[i] = (ui - state.extra[i]) / tau;
            }
        }
    }

    fn initial_state(&self, ic: &InitialConditions) -> ModelState {
        self.base_dyn().initial_state(ic)
    }

    fn clone_box(&self) -> Box<dyn VehicleModel> {
        Box::new(self.clone())
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}
