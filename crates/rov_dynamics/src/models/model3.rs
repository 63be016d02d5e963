//! Model 3: Mai et al. 2017 (seed 000 eq. 18–28), the full 6-DOF Fossen process plant
//! model ([`crate::process`]) with quadratic thrusters at the Pro 4 geometry.
//!
//! * Buoyancy from the volume, B = ρ g V (eq. 18); weight W = m g (eq. 19).
//! * CG 5.59 mm below CB; CO = CB (project decision).
//! * Thrusters F = T_l u + T_q u|u| per thruster with forward/reverse pairs (eq. 21), at
//!   the positions and directions of the parameter file; τ = Σ [F d; r × F d].
//! * Translational surge drag from the maximum speed (eq. 23–24), read **literally**:
//!   F_l(1) + F_r(1) = D_q u_max² + D_l u_max and D_q / D_l = C, so
//!   D_l = (F_l(1) + F_r(1)) / (C u_max² + u_max), D_q = C D_l. With C = 0.16 and
//!   u_max = 2.1 m/s the surge drag is mostly linear. parameters.md proposes another
//!   reading (C relates the linear to the quadratic part at u_max: D_l u_max = C D_q u_max²),
//!   available as [`SurgeDragReading::LinearShare`] (balanced so the drag at u_max still
//!   equals the full thrust). Other axes' drag: parameters.md estimates.
//! * Munk moments: `options.munk_moment = "zeroed"` (default; Fossen's REMUS 100 fix) or
//!   `"full"`; see [`MunkMoment`]. With "full" a bluff body with M_A33 > M_A11 is
//!   statically unstable in pitch above ≈ 0.3 m/s (parameters.md §4).

use std::any::Any;

use nalgebra::{SMatrix, Vector3};
use rov_types::{ConfigError, ParamFile};

use super::param_util::{geometry, quadratic_map, vec3, vec6};
use super::{Channel, Environment, ModelState, ThrusterForces, VehicleModel};
use crate::error::DynamicsError;
use crate::integrators::{EtaNu, rk4_step};
use crate::math::{Matrix6, Vector6};
use crate::process::{
    CurrentSample, Damping, DampingForm, Hydrostatics, MunkMoment, ProcessModel, ProcessParams,
    RigidBody,
};
use crate::thrusters::{ThrustMap, ThrustPct, Thruster, ThrusterSet};

/// How seed 000 eq. 23–24 turn C and u_max into the surge drag.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SurgeDragReading {
    /// D_q / D_l = C and F_total = D_q u_max² + D_l u_max (the paper, literally).
    #[default]
    PaperLiteral,
    /// parameters.md's reading: D_l u_max = C · D_q u_max² (linear share C of the
    /// quadratic drag at u_max), with F_total = D_q u_max² + D_l u_max.
    LinearShare,
}

/// Surge drag (D_l, D_q) from the total forward thrust at full command, the maximum speed
/// and the ratio C.
pub fn surge_drag_from_max_speed(
    total_thrust_n: f64,
    max_speed_mps: f64,
    ratio_c: f64,
    reading: SurgeDragReading,
) -> (f64, f64) {
    let u = max_speed_mps;
    match reading {
        SurgeDragReading::PaperLiteral => {
            let d_l = total_thrust_n / (ratio_c * u * u + u);
            (d_l, ratio_c * d_l)
        }
        SurgeDragReading::LinearShare => {
            let d_q = total_thrust_n / ((1.0 + ratio_c) * u * u);
            (ratio_c * d_q * u, d_q)
        }
    }
}

/// Parameters of model 3.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Model3Params {
    /// The 6-DOF process plant parameters (surge drag already derived).
    pub process: ProcessParams,
    /// Thrusters.
    pub thrusters: ThrusterSet,
    /// Volume V, m³.
    pub volume_m3: f64,
    /// Water density ρ, kg/m³.
    pub water_density_kgpm3: f64,
    /// Gravity g, m/s².
    pub gravity_mps2: f64,
    /// Drag ratio C.
    pub surge_drag_ratio_c: f64,
    /// u_max, m/s.
    pub max_speed_mps: f64,
    /// Reading of eq. 23–24.
    pub surge_drag_reading: SurgeDragReading,
}

impl Model3Params {
    /// Reads `[rigid_body]`, `[hydrostatics]`, `[added_mass]`, `[damping]`, `[surge_drag]`,
    /// `[thrusters.*]` and `[options]`.
    pub fn from_params(pf: &ParamFile) -> Result<Self, ConfigError> {
        let mass_kg = pf.f64("rigid_body.mass_kg", 0.1..=100.0)?;
        let [ix, iy, iz] = pf.array::<3>("rigid_body.inertia_cg_kgm2", 1e-4..=10.0)?;
        let [ixy, ixz, iyz] = pf.array::<3>("rigid_body.products_of_inertia_kgm2", -10.0..=10.0)?;
        let cg = vec3(pf, "rigid_body.cg_from_co_m", -0.5..=0.5)?;
        let volume_m3 = pf.f64("hydrostatics.volume_m3", 1e-4..=1.0)?;
        let rho = pf.f64("hydrostatics.water_density_kgpm3", 900.0..=1100.0)?;
        let g = pf.f64("hydrostatics.gravity_mps2", 9.7..=9.9)?;
        let cb = vec3(pf, "hydrostatics.cb_from_co_m", -0.5..=0.5)?;
        let added = vec6(pf, "added_mass.diagonal", 0.0..=100.0)?;
        let lin =
            |axis: &str, unit: &str| pf.f64(&format!("damping.linear.{axis}_{unit}"), 0.0..=1000.0);
        let quad = |axis: &str, unit: &str| {
            pf.f64(&format!("damping.quadratic.{axis}_{unit}"), 0.0..=1000.0)
        };
        let ratio_c = pf.f64("surge_drag.ratio_c", 1e-3..=100.0)?;
        let max_speed = pf.f64("surge_drag.max_speed_mps", 0.1..=10.0)?;
        let reading = match pf
            .choice(
                "surge_drag.reading",
                &["paper_literal", "linear_share"],
                Some("paper_literal"),
            )?
            .as_str()
        {
            "linear_share" => SurgeDragReading::LinearShare,
            _ => SurgeDragReading::PaperLiteral,
        };
        let munk = match pf
            .choice("options.munk_moment", &["zeroed", "full"], Some("zeroed"))?
            .as_str()
        {
            "full" => MunkMoment::Full,
            _ => MunkMoment::Zeroed,
        };
        let damping_form = pf.choice(
            "options.damping_form",
            &["linear_quadratic", "exponential"],
            Some("linear_quadratic"),
        )?;
        let alpha = pf.f64_or("options.exponential_alpha_s_per_m", 0.0..=100.0, 0.0)?;
        let form = if damping_form == "exponential" {
            DampingForm::Exponential {
                alpha_s_per_m: alpha,
            }
        } else {
            DampingForm::LinearQuadratic
        };
        let thruster = |name: &str| -> Result<Thruster, ConfigError> {
            let prefix = format!("thrusters.{name}");
            Ok(Thruster {
                map: ThrustMap::Quadratic(quadratic_map(pf, &prefix)?),
                geometry: geometry(pf, &prefix)?,
            })
        };
        let thrusters = ThrusterSet {
            port: thruster("port")?,
            starboard: thruster("starboard")?,
            vertical: thruster("vertical")?,
        };
        // Eq. 23: the forward force of both horizontal thrusters at full command.
        let total = thrusters.port.map.force_n(100.0) + thrusters.starboard.map.force_n(100.0);
        let (surge_l, surge_q) = surge_drag_from_max_speed(total, max_speed, ratio_c, reading);
        let linear = Vector6::new(
            surge_l,
            lin("sway", "nspm")?,
            lin("heave", "nspm")?,
            lin("roll", "nms")?,
            lin("pitch", "nms")?,
            lin("yaw", "nms")?,
        );
        let quadratic = Vector6::new(
            surge_q,
            quad("sway", "ns2pm2")?,
            quad("heave", "ns2pm2")?,
            quad("roll", "nms2")?,
            quad("pitch", "nms2")?,
            quad("yaw", "nms2")?,
        );
        let rigid_body = RigidBody {
            mass_kg,
            inertia_cg_kgm2: RigidBody::inertia_tensor(ix, iy, iz, ixy, ixz, iyz),
            cg_from_co_m: cg,
        };
        let process = ProcessParams {
            rigid_body,
            added_mass: Matrix6::from_diagonal(&added),
            damping: Damping {
                linear: Matrix6::from_diagonal(&linear),
                quadratic,
                form,
            },
            hydrostatics: Hydrostatics {
                weight_n: mass_kg * g,
                buoyancy_n: rho * g * volume_m3,
                cg_from_co_m: cg,
                cb_from_co_m: cb,
            },
            munk,
        };
        Ok(Self {
            process,
            thrusters,
            volume_m3,
            water_density_kgpm3: rho,
            gravity_mps2: g,
            surge_drag_ratio_c: ratio_c,
            max_speed_mps: max_speed,
            surge_drag_reading: reading,
        })
    }
}

/// Model 3.
#[derive(Debug, Clone, PartialEq)]
pub struct Model3 {
    params: Model3Params,
    process: ProcessModel,
    allocation: SMatrix<f64, 6, 3>,
}

impl Model3 {
    /// Precomputes the process model (fails if M is not positive definite).
    pub fn new(params: Model3Params) -> Result<Self, DynamicsError> {
        Ok(Self {
            process: ProcessModel::new(params.process)?,
            allocation: params.thrusters.allocation_matrix(),
            params,
        })
    }

    /// The parameters.
    pub fn params(&self) -> &Model3Params {
        &self.params
    }

    /// The process plant model.
    pub fn process(&self) -> &ProcessModel {
        &self.process
    }

    /// A copy with another Munk-moment option.
    pub fn with_munk(&self, munk: MunkMoment) -> Result<Self, DynamicsError> {
        let mut p = self.params;
        p.process.munk = munk;
        Self::new(p)
    }

    /// Net weight W − B, N (positive sinks).
    pub fn net_weight_n(&self) -> f64 {
        self.params.process.hydrostatics.weight_n - self.params.process.hydrostatics.buoyancy_n
    }

    /// CG from CO, m.
    pub fn cg_from_co_m(&self) -> Vector3<f64> {
        self.params.process.rigid_body.cg_from_co_m
    }
}

impl VehicleModel for Model3 {
    fn name(&self) -> &str {
        "model3"
    }

    fn predicts(&self, _ch: Channel) -> bool {
        true
    }

    #[inline]
    fn thruster_forces(&self, cmd: &ThrustPct, _state: &ModelState) -> ThrusterForces {
        self.params.thrusters.forces(cmd)
    }

    #[inline]
    fn generalized_force(&self, forces: &ThrusterForces, _state: &ModelState) -> Vector6 {
        self.allocation * Vector3::new(forces.port_n, forces.starboard_n, forces.vertical_n)
    }

    #[inline]
    fn dynamics(&self, state: &ModelState, tau: &Vector6, current: &CurrentSample) -> ModelState {
        let (eta_dot, nu_dot) = self
            .process
            .state_derivative(&state.eta, &state.nu, tau, current);
        ModelState::new(eta_dot, nu_dot)
    }

    #[inline]
    fn rk4_step(
        &self,
        t_s: f64,
        state: &ModelState,
        cmd: &ThrustPct,
        env: &Environment<'_>,
        h_s: f64,
    ) -> ModelState {
        // Same result as `rk4_step_fixed_thrust`, on the 12 states model 3 uses (a
        // ModelState also carries the unused extra states through every stage).
        let tau_thrust = self.generalized_force(&self.thruster_forces(cmd, state), state);
        let x = rk4_step(
            |tt, s: &EtaNu| {
                let tau = env.total_tau(&tau_thrust, tt, &s.eta, &s.nu);
                let (eta, nu) =
                    self.process
                        .state_derivative(&s.eta, &s.nu, &tau, &env.current.at(tt));
                EtaNu { eta, nu }
            },
            t_s,
            &EtaNu {
                eta: state.eta,
                nu: state.nu,
            },
            h_s,
        );
        ModelState {
            eta: x.eta,
            nu: x.nu,
            extra: state.extra,
        }
    }

    fn plant(&self) -> Option<crate::plant::PlantDescription> {
        Some(crate::plant::PlantDescription::from_model3(self))
    }

    fn clone_box(&self) -> Box<dyn VehicleModel> {
        Box::new(self.clone())
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}
