//! Model 1: Enevoldsen et al. 2018 (seed 000 eq. 1–7), decoupled surge, heave and yaw.
//!
//! The paper's tuned equations, implemented literally (eq. 5–7):
//!
//! ```text
//! m u̇   = β_u (α_u (F_r + F_l) − F_d^u),   F_d^u = d_u u + d_uu u|u|
//! m ẇ   = β_w (α_w F_t − F_d^w),           F_d^w = d_w w + d_ww w|w|
//! I_z ṙ = β_r (α_r τ_rear − τ_d^r),        τ_d^r = d_r r + d_rr r|r|
//! ```
//!
//! with τ_rear = R sin γ (F_port − F_starboard) (eq. 4 with one sign convention: port thrust
//! above starboard thrust turns to starboard), neutral buoyancy (no W − B) and the
//! kinematics ẋ = u cos ψ, ẏ = u sin ψ, ż = w, ψ̇ = r. Thrusters: F = T_l u + T_q u|u|.
//!
//! **α/β mapping.** parameters.md lists α as an inertia factor k (1.4, 1.8, 1.3) and β as
//! a drag factor β' (1.0): k m ẋ = F − β' F_d. Dividing by k gives the paper's form with
//! α = 1/β' and β = β'/k; for β' = 1 that is α = 1 and β = 1/k. The parameter file holds
//! the paper's α and β.
//!
//! Drag uses the velocity relative to the water (u − u_c, w − w_c) when a current is
//! given; the sway part of a current is ignored (the model has no sway). τ_ext enters like
//! thrust (scaled by α). Not predicted: pitch, roll, sway, roll rate, pitch rate.

use std::any::Any;

use rov_types::{ConfigError, ParamFile};

use super::param_util::quadratic_map;
use super::{Channel, ModelState, ThrusterForces, VehicleModel};
use crate::math::Vector6;
use crate::process::CurrentSample;
use crate::thrusters::{QuadraticThrustMap, ThrustPct};

/// Linear plus quadratic drag F = d_l x + d_q x|x| (positive coefficients).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DragPair {
    /// d_l (N s/m or N m s).
    pub linear: f64,
    /// d_q (N s²/m² or N m s²).
    pub quadratic: f64,
}

impl DragPair {
    /// Drag at speed x.
    #[inline]
    pub fn force(&self, x: f64) -> f64 {
        self.linear * x + self.quadratic * x * x.abs()
    }
}

/// Parameters of model 1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Model1Params {
    /// m, kg.
    pub mass_kg: f64,
    /// I_z (I_r in the paper), kg m².
    pub yaw_inertia_kgm2: f64,
    /// (α_u, α_w, α_r): the paper's thrust factors.
    pub alpha: [f64; 3],
    /// (β_u, β_w, β_r): the paper's overall factors.
    pub beta: [f64; 3],
    /// Surge drag.
    pub surge_drag: DragPair,
    /// Heave drag.
    pub heave_drag: DragPair,
    /// Yaw drag (a_d = quadratic, b_d = linear in eq. 4).
    pub yaw_drag: DragPair,
    /// R: distance CG – horizontal thruster, m.
    pub yaw_radius_m: f64,
    /// γ: angle between thrust line and radius, rad.
    pub yaw_angle_rad: f64,
    /// Port thrust map.
    pub port: QuadraticThrustMap,
    /// Starboard thrust map.
    pub starboard: QuadraticThrustMap,
    /// Vertical thrust map (positive pushes down).
    pub vertical: QuadraticThrustMap,
}

impl Model1Params {
    /// Reads `[rigid_body]`, `[tuning]`, `[drag]`, `[geometry]` and
    /// `[thrusters.port|starboard|vertical]`.
    pub fn from_params(pf: &ParamFile) -> Result<Self, ConfigError> {
        let drag = |axis: &str, unit_l: &str, unit_q: &str| -> Result<DragPair, ConfigError> {
            Ok(DragPair {
                linear: pf.f64(&format!("drag.{axis}_linear_{unit_l}"), 0.0..=1000.0)?,
                quadratic: pf.f64(&format!("drag.{axis}_quadratic_{unit_q}"), 0.0..=1000.0)?,
            })
        };
        Ok(Self {
            mass_kg: pf.f64("rigid_body.mass_kg", 0.1..=100.0)?,
            yaw_inertia_kgm2: pf.f64("rigid_body.yaw_inertia_kgm2", 1e-4..=10.0)?,
            alpha: [
                pf.f64("tuning.alpha_u", 0.01..=100.0)?,
                pf.f64("tuning.alpha_w", 0.01..=100.0)?,
                pf.f64("tuning.alpha_r", 0.01..=100.0)?,
            ],
            beta: [
                pf.f64("tuning.beta_u", 0.01..=100.0)?,
                pf.f64("tuning.beta_w", 0.01..=100.0)?,
                pf.f64("tuning.beta_r", 0.01..=100.0)?,
            ],
            surge_drag: drag("surge", "nspm", "ns2pm2")?,
            heave_drag: drag("heave", "nspm", "ns2pm2")?,
            yaw_drag: drag("yaw", "nms", "nms2")?,
            yaw_radius_m: pf.f64("geometry.yaw_radius_m", 0.0..=2.0)?,
            yaw_angle_rad: pf
                .f64("geometry.yaw_angle_deg", -180.0..=180.0)?
                .to_radians(),
            port: quadratic_map(pf, "thrusters.port")?,
            starboard: quadratic_map(pf, "thrusters.starboard")?,
            vertical: quadratic_map(pf, "thrusters.vertical")?,
        })
    }

    /// The yaw lever arm R sin γ, m.
    pub fn yaw_arm_m(&self) -> f64 {
        self.yaw_radius_m * self.yaw_angle_rad.sin()
    }
}

/// Model 1.
#[derive(Debug, Clone, PartialEq)]
pub struct Model1 {
    params: Model1Params,
}

impl Model1 {
    /// From parameters.
    pub fn new(params: Model1Params) -> Self {
        Self { params }
    }

    /// The parameters.
    pub fn params(&self) -> &Model1Params {
        &self.params
    }
}

/// Planar kinematics shared by models 1 and 2: ẋ = u cos ψ, ẏ = u sin ψ, ż = w, ψ̇ = r.
#[inline]
pub(crate) fn planar_eta_dot(state: &ModelState) -> Vector6 {
    let (s, c) = state.eta[5].sin_cos();
    let u = state.nu[0];
    Vector6::new(u * c, u * s, state.nu[2], 0.0, 0.0, state.nu[5])
}

/// Surge and heave components of the current in the body frame of a level vehicle.
#[inline]
pub(crate) fn planar_current(state: &ModelState, current: &CurrentSample) -> (f64, f64) {
    let (s, c) = state.eta[5].sin_cos();
    let v = current.vel_ned_mps;
    (c * v.x + s * v.y, v.z)
}

/// Keeps only the DOFs of the planar models (x, y, z, ψ; u, w, r).
pub(crate) fn planar_initial(mut s: ModelState) -> ModelState {
    s.eta[3] = 0.0;
    s.eta[4] = 0.0;
    s.nu[1] = 0.0;
    s.nu[3] = 0.0;
    s.nu[4] = 0.0;
    s
}

pub(crate) fn planar_predicts(ch: Channel) -> bool {
    matches!(
        ch,
        Channel::Depth
            | Channel::Heading
            | Channel::Surge
            | Channel::Heave
            | Channel::YawRate
            | Channel::North
            | Channel::East
    )
}

impl VehicleModel for Model1 {
    fn name(&self) -> &str {
        "model1"
    }

    fn predicts(&self, ch: Channel) -> bool {
        planar_predicts(ch)
    }

    fn thruster_forces(&self, cmd: &ThrustPct, _state: &ModelState) -> ThrusterForces {
        ThrusterForces {
            port_n: self.params.port.force_n(cmd.port),
            starboard_n: self.params.starboard.force_n(cmd.starboard),
            vertical_n: self.params.vertical.force_n(cmd.vertical),
        }
    }

    fn generalized_force(&self, f: &ThrusterForces, _state: &ModelState) -> Vector6 {
        Vector6::new(
            f.port_n + f.starboard_n,
            0.0,
            f.vertical_n,
            0.0,
            0.0,
            self.params.yaw_arm_m() * (f.port_n - f.starboard_n),
        )
    }

    fn dynamics(&self, state: &ModelState, tau: &Vector6, current: &CurrentSample) -> ModelState {
        let p = &self.params;
        let (uc, wc) = planar_current(state, current);
        let u_r = state.nu[0] - uc;
        let w_r = state.nu[2] - wc;
        let r = state.nu[5];
        let u_dot = p.beta[0] * (p.alpha[0] * tau[0] - p.surge_drag.force(u_r)) / p.mass_kg;
        let w_dot = p.beta[1] * (p.alpha[1] * tau[2] - p.heave_drag.force(w_r)) / p.mass_kg;
        let r_dot = p.beta[2] * (p.alpha[2] * tau[5] - p.yaw_drag.force(r)) / p.yaw_inertia_kgm2;
        ModelState::new(
            planar_eta_dot(state),
            Vector6::new(u_dot, 0.0, w_dot, 0.0, 0.0, r_dot),
        )
    }

    fn initial_state(&self, ic: &super::InitialConditions) -> ModelState {
        planar_initial(ic.to_state())
    }

    fn thrust_is_state_independent(&self) -> bool {
        true
    }

    fn plant(&self) -> Option<crate::plant::PlantDescription> {
        Some(crate::plant::PlantDescription::from_model1(&self.params))
    }

    fn clone_box(&self) -> Box<dyn VehicleModel> {
        Box::new(self.clone())
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}
