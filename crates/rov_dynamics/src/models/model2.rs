//! Model 2: Arnesen 2016 (seed 000 eq. 8–17), Fossen's equations reduced to surge, heave
//! and yaw (the sway thruster of the thesis removed, as in the comparison paper).
//!
//! ```text
//! M ν̇ = τ − C(ν) ν − D(ν) ν − g(η),   ν = (u, w, r)
//! M = diag(m − X_u̇, m − Z_ẇ, I_z − N_ṙ)
//! D(ν) = −diag(X_u + X_|u|u |u|, Z_w + Z_|w|w |w|, N_r + N_|r|r |r|)
//! g = (0, −(W − B), 0)  (eq. 16's heave row, z down)
//! τ = (G1 (u_p + u_s), G2 u_v, G3 (u_p − u_s)),  commands in percent (eq. 17 mapped to
//!     the project's yaw sign: port above starboard turns to starboard)
//! ```
//!
//! C(ν) is the 6-DOF Kirchhoff C of diag(m − X_u̇, ·, m − Z_ẇ, ·, ·, I_z − N_ṙ) evaluated
//! with v = p = q = 0, keeping the u, w, r rows (for a diagonal M these rows vanish; the
//! couplings go through v, p, q only). Hydrodynamic derivatives carry Fossen's signs
//! (negative). Stage (a) gives the per-thruster forces G1 u_p, G1 u_s, G2 u_v; stage (b) uses
//! the yaw arm G3/G1 so that τ_yaw = G3 (u_p − u_s). Drag uses the velocity relative to the
//! water. Not predicted: pitch, roll, sway, roll rate, pitch rate.

use std::any::Any;

use rov_types::{ConfigError, ParamFile};

use super::model1::{planar_current, planar_eta_dot, planar_initial, planar_predicts};
use super::{Channel, ModelState, ThrusterForces, VehicleModel};
use crate::math::{Matrix6, Vector6, coriolis_times_nu};
use crate::process::CurrentSample;
use crate::thrusters::ThrustPct;

/// Parameters of model 2 (Fossen signs: added masses and damping derivatives ≤ 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Model2Params {
    /// m, kg.
    pub mass_kg: f64,
    /// I_z, kg m².
    pub yaw_inertia_kgm2: f64,
    /// X_u̇, kg.
    pub x_udot_kg: f64,
    /// Z_ẇ, kg.
    pub z_wdot_kg: f64,
    /// N_ṙ, kg m².
    pub n_rdot_kgm2: f64,
    /// X_u, N s/m.
    pub x_u: f64,
    /// X_|u|u, N s²/m².
    pub x_uu: f64,
    /// Z_w, N s/m.
    pub z_w: f64,
    /// Z_|w|w, N s²/m².
    pub z_ww: f64,
    /// N_r, N m s.
    pub n_r: f64,
    /// N_|r|r, N m s².
    pub n_rr: f64,
    /// W, N.
    pub weight_n: f64,
    /// B, N.
    pub buoyancy_n: f64,
    /// G1, N per % (per horizontal thruster).
    pub g1_n_per_pct: f64,
    /// G2, N per % (vertical thruster, positive pushes down).
    pub g2_n_per_pct: f64,
    /// G3, N m per % of differential command.
    pub g3_nm_per_pct: f64,
}

impl Model2Params {
    /// Reads `[rigid_body]`, `[added_mass]`, `[damping]`, `[hydrostatics]`, `[thrust_map]`.
    pub fn from_params(pf: &ParamFile) -> Result<Self, ConfigError> {
        Ok(Self {
            mass_kg: pf.f64("rigid_body.mass_kg", 0.1..=100.0)?,
            yaw_inertia_kgm2: pf.f64("rigid_body.yaw_inertia_kgm2", 1e-4..=10.0)?,
            x_udot_kg: pf.f64("added_mass.x_udot_kg", -100.0..=0.0)?,
            z_wdot_kg: pf.f64("added_mass.z_wdot_kg", -100.0..=0.0)?,
            n_rdot_kgm2: pf.f64("added_mass.n_rdot_kgm2", -10.0..=0.0)?,
            x_u: pf.f64("damping.x_u_nspm", -1000.0..=0.0)?,
            x_uu: pf.f64("damping.x_uu_ns2pm2", -1000.0..=0.0)?,
            z_w: pf.f64("damping.z_w_nspm", -1000.0..=0.0)?,
            z_ww: pf.f64("damping.z_ww_ns2pm2", -1000.0..=0.0)?,
            n_r: pf.f64("damping.n_r_nms", -100.0..=0.0)?,
            n_rr: pf.f64("damping.n_rr_nms2", -100.0..=0.0)?,
            weight_n: pf.f64("hydrostatics.weight_n", 0.0..=2000.0)?,
            buoyancy_n: pf.f64("hydrostatics.buoyancy_n", 0.0..=2000.0)?,
            g1_n_per_pct: pf.f64("thrust_map.g1_n_per_pct", 1e-6..=10.0)?,
            g2_n_per_pct: pf.f64("thrust_map.g2_n_per_pct", 0.0..=10.0)?,
            g3_nm_per_pct: pf.f64("thrust_map.g3_nm_per_pct", 0.0..=10.0)?,
        })
    }
}

/// Model 2.
#[derive(Debug, Clone, PartialEq)]
pub struct Model2 {
    params: Model2Params,
    /// The 6-DOF diagonal mass matrix used for C(ν) (sway/roll/pitch entries are unused
    /// because v = p = q = 0).
    m6: Matrix6,
}

impl Model2 {
    /// From parameters.
    pub fn new(params: Model2Params) -> Self {
        let m11 = params.mass_kg - params.x_udot_kg;
        let m33 = params.mass_kg - params.z_wdot_kg;
        let m66 = params.yaw_inertia_kgm2 - params.n_rdot_kgm2;
        let m6 = Matrix6::from_diagonal(&Vector6::new(m11, m11, m33, 1.0, 1.0, m66));
        Self { params, m6 }
    }

    /// The parameters.
    pub fn params(&self) -> &Model2Params {
        &self.params
    }

    /// diag(M) on (u, w, r).
    pub fn mass_diagonal(&self) -> [f64; 3] {
        [self.m6[(0, 0)], self.m6[(2, 2)], self.m6[(5, 5)]]
    }
}

impl VehicleModel for Model2 {
    fn name(&self) -> &str {
        "model2"
    }

    fn predicts(&self, ch: Channel) -> bool {
        planar_predicts(ch)
    }

    fn thruster_forces(&self, cmd: &ThrustPct, _state: &ModelState) -> ThrusterForces {
        let p = &self.params;
        ThrusterForces {
            port_n: p.g1_n_per_pct * cmd.port,
            starboard_n: p.g1_n_per_pct * cmd.starboard,
            vertical_n: p.g2_n_per_pct * cmd.vertical,
        }
    }

    fn generalized_force(&self, f: &ThrusterForces, _state: &ModelState) -> Vector6 {
        let arm = self.params.g3_nm_per_pct / self.params.g1_n_per_pct;
        Vector6::new(
            f.port_n + f.starboard_n,
            0.0,
            f.vertical_n,
            0.0,
            0.0,
            arm * (f.port_n - f.starboard_n),
        )
    }

    fn dynamics(&self, state: &ModelState, tau: &Vector6, current: &CurrentSample) -> ModelState {
        let p = &self.params;
        let (uc, wc) = planar_current(state, current);
        let (u, w, r) = (state.nu[0] - uc, state.nu[2] - wc, state.nu[5]);
        let nu_r6 = Vector6::new(u, 0.0, w, 0.0, 0.0, r);
        let c = coriolis_times_nu(&self.m6, &nu_r6);
        let d_u = -(p.x_u + p.x_uu * u.abs()) * u;
        let d_w = -(p.z_w + p.z_ww * w.abs()) * w;
        let d_r = -(p.n_r + p.n_rr * r.abs()) * r;
        let g_w = -(p.weight_n - p.buoyancy_n);
        let [m11, m33, m66] = self.mass_diagonal();
        let u_dot = (tau[0] - c[0] - d_u) / m11;
        let w_dot = (tau[2] - c[2] - d_w - g_w) / m33;
        let r_dot = (tau[5] - c[5] - d_r) / m66;
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
        Some(crate::plant::PlantDescription::from_model2(&self.params))
    }

    fn clone_box(&self) -> Box<dyn VehicleModel> {
        Box::new(self.clone())
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}
