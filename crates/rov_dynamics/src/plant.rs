//! The control plant of a vehicle model: what a depth and heading autopilot needs to
//! know about it, described by the model itself ([`crate::VehicleModel::plant`]).
//!
//! A [`PlantDescription`] reduces a model to two decoupled axes and its thrust path:
//!
//! * heave (z down): `inertia·ẇ + (d_l + d_q·|w|)·w = Z + static_load`, with `Z` the heave
//!   force of the vertical thruster and `static_load = W − B` (a heavy vehicle sinks);
//! * yaw (to starboard): `inertia·ṙ + (d_l + d_q·|r|)·r = N + yaw_per_heave_m·Z`, with
//!   `N = yaw_arm_m·(F_port − F_starboard)` and the vertical thruster's reaction torque
//!   `yaw_per_heave_m` (0 for the published models);
//! * per thruster ([`ThrusterPath`]): the command-to-force map per sign (asymmetric
//!   reverse thrust), a dead zone (a command inside `±dead_zone` gives no thrust, outside
//!   it the map sees `(|u| − dz)/(1 − dz)`), and a first-order lag of the command
//!   (`ȧ = (u − a)/τ`, the map sees `a`).
//!
//! The vertical map is in heave force (positive pushes the vehicle down); the port and
//! starboard maps are scaled so that `N = yaw_arm_m·(F_port − F_starboard)` holds with
//! one arm even when the two lever arms differ.
//!
//! Every model that can be reduced this way returns one (the three published models, the
//! lab's extended models); the autopilot's feedforward and observer are built from it
//! (`rov_control::PlantModel::from_description`), so no autopilot crate needs to know
//! the concrete model type.

use crate::models::{Model1Params, Model2Params, Model3};
use crate::thrusters::QuadraticThrustMap;

/// One axis' rigid-body-plus-added-mass dynamics:
/// `inertia·v̇ + (d_l + d_q·|v|)·v = τ + static_load`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisDynamics {
    /// Effective inertia: mass incl. added mass (kg) or yaw inertia incl. added (kg·m²).
    pub inertia: f64,
    /// Linear damping (N·s/m or N·m·s/rad), ≥ 0.
    pub damping_lin: f64,
    /// Quadratic damping (N·s²/m² or N·m·s²/rad²), ≥ 0.
    pub damping_quad: f64,
    /// Constant external load (N or N·m) in the axis direction; for heave W − B (a
    /// heavy vehicle sinks, so the load is positive = down). 0 for yaw.
    pub static_load: f64,
}

impl AxisDynamics {
    /// The force needed for velocity `v` and acceleration `vdot`.
    pub fn inverse(&self, v: f64, vdot: f64) -> f64 {
        self.inertia * vdot + (self.damping_lin + self.damping_quad * v.abs()) * v
            - self.static_load
    }
}

/// What lies between a thruster's command and its map: a dead zone and a lag.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PathEffects {
    /// Dead zone, fraction of full command (0 ≤ dz < 1): `|u| ≤ dz` gives no thrust.
    pub dead_zone: f64,
    /// First-order lag of the command, s (0: none).
    pub lag_tau_s: f64,
}

impl PathEffects {
    /// The command the map sees for a command `pct` (%), after the dead zone (the lag is
    /// a state, see [`PathEffects::lag_step`]).
    pub fn through_dead_zone(&self, pct: f64) -> f64 {
        let dz = self.dead_zone;
        if dz <= 0.0 || dz >= 1.0 {
            return pct;
        }
        let a = ((pct.abs() * 0.01 - dz).max(0.0) / (1.0 - dz)) * 100.0;
        if pct < 0.0 { -a } else { a }
    }

    /// The command (%) that gives the map the command `pct_eff` (%) through the dead
    /// zone: `sign·(dz + (1 − dz)·|u_eff|)`. Within `blend_pct` of zero the added dead
    /// band fades in linearly, so a demand that changes sign does not jump across the
    /// band; the result stays within ±100 % and is never NaN.
    pub fn before_dead_zone(&self, pct_eff: f64, blend_pct: f64) -> f64 {
        if !pct_eff.is_finite() {
            return 0.0;
        }
        let dz = self.dead_zone;
        if dz <= 0.0 || dz >= 1.0 {
            return pct_eff.clamp(-100.0, 100.0);
        }
        let m = pct_eff.abs().min(100.0);
        let band = if blend_pct > 0.0 && m < blend_pct {
            100.0 * dz * m / blend_pct
        } else {
            100.0 * dz
        };
        let u = band + (1.0 - dz) * m;
        if pct_eff < 0.0 { -u } else { u }
    }

    /// One exact step of the lag's state `a` (%) towards the held command `pct` over
    /// `dt_s`; without a lag the state is the command.
    pub fn lag_step(&self, a: f64, pct: f64, dt_s: f64) -> f64 {
        if self.lag_tau_s <= 1e-6 || !(dt_s.is_finite() && dt_s > 0.0) || !a.is_finite() {
            return pct;
        }
        a + (pct - a) * (1.0 - (-dt_s / self.lag_tau_s).exp())
    }
}

/// The heave and yaw reduction of a vehicle model with its thrust path.
#[derive(Debug, Clone, PartialEq)]
pub struct PlantDescription {
    /// The model's name (for diagnostics and errors).
    pub name: String,
    /// Heave axis (z down).
    pub heave: AxisDynamics,
    /// Yaw axis (positive to starboard).
    pub yaw: AxisDynamics,
    /// Vertical thruster map, as heave force (positive pushes down).
    pub vertical: QuadraticThrustMap,
    /// Port thruster map (positive forward), scaled to [`PlantDescription::yaw_arm_m`].
    pub port: QuadraticThrustMap,
    /// Starboard thruster map (positive forward), scaled to the same arm.
    pub starboard: QuadraticThrustMap,
    /// Yaw lever arm of the horizontal pair, m: `N = arm·(F_port − F_starboard)`.
    pub yaw_arm_m: f64,
    /// Yaw moment per newton of vertical heave force (reaction torque), m.
    pub yaw_per_heave_m: f64,
    /// Dead zone and lag of the vertical thruster.
    pub vertical_path: PathEffects,
    /// Dead zone and lag of the port thruster.
    pub port_path: PathEffects,
    /// Dead zone and lag of the starboard thruster.
    pub starboard_path: PathEffects,
}

impl PlantDescription {
    /// Model1 (Enevoldsen et al. 2018). The paper's form `m·ẇ = β_w·(α_w·F − D(w))`
    /// gives the thrust needed as `F = m/(α_w·β_w)·ẇ + D(w)/α_w`, so the equivalent axis
    /// has inertia `m/(α·β)` and damping `D/α`; neutral buoyancy (no W − B).
    pub fn from_model1(p: &Model1Params) -> Self {
        let [_, alpha_w, alpha_r] = p.alpha;
        let [_, beta_w, beta_r] = p.beta;
        PlantDescription {
            name: "model1".into(),
            heave: AxisDynamics {
                inertia: p.mass_kg / (alpha_w * beta_w),
                damping_lin: p.heave_drag.linear / alpha_w,
                damping_quad: p.heave_drag.quadratic / alpha_w,
                static_load: 0.0,
            },
            yaw: AxisDynamics {
                inertia: p.yaw_inertia_kgm2 / (alpha_r * beta_r),
                damping_lin: p.yaw_drag.linear / alpha_r,
                damping_quad: p.yaw_drag.quadratic / alpha_r,
                static_load: 0.0,
            },
            vertical: p.vertical,
            port: p.port,
            starboard: p.starboard,
            yaw_arm_m: p.yaw_arm_m(),
            yaw_per_heave_m: 0.0,
            vertical_path: PathEffects::default(),
            port_path: PathEffects::default(),
            starboard_path: PathEffects::default(),
        }
    }

    /// Model2 (Arnesen 2016): `M = m − Z_ẇ`, `I_z − N_ṙ`, damping `−Z_w, −Z_|w|w, −N_r,
    /// −N_|r|r`, load `W − B`, linear maps G1 (per horizontal thruster) and G2, lever arm
    /// `G3/G1`.
    pub fn from_model2(p: &Model2Params) -> Self {
        PlantDescription {
            name: "model2".into(),
            heave: AxisDynamics {
                inertia: p.mass_kg - p.z_wdot_kg,
                damping_lin: -p.z_w,
                damping_quad: -p.z_ww,
                static_load: p.weight_n - p.buoyancy_n,
            },
            yaw: AxisDynamics {
                inertia: p.yaw_inertia_kgm2 - p.n_rdot_kgm2,
                damping_lin: -p.n_r,
                damping_quad: -p.n_rr,
                static_load: 0.0,
            },
            vertical: QuadraticThrustMap::linear(p.g2_n_per_pct),
            port: QuadraticThrustMap::linear(p.g1_n_per_pct),
            starboard: QuadraticThrustMap::linear(p.g1_n_per_pct),
            yaw_arm_m: if p.g1_n_per_pct > 0.0 {
                p.g3_nm_per_pct / p.g1_n_per_pct
            } else {
                0.0
            },
            yaw_per_heave_m: 0.0,
            vertical_path: PathEffects::default(),
            port_path: PathEffects::default(),
            starboard_path: PathEffects::default(),
        }
    }

    /// Model3 (Mai et al. 2017): the heave and yaw diagonal of its 6-DOF mass matrix
    /// (rigid body about CO plus added mass) and damping, `W − B`, and the thrusters'
    /// maps scaled by their geometry (heave force per newton of the vertical thruster,
    /// yaw moment per newton of each horizontal one).
    pub fn from_model3(m: &Model3) -> Self {
        let p = m.params();
        let mm = m.process().mass_matrix();
        let d = &p.process.damping;
        let entry = |mat: &crate::Matrix6, i: usize| mat.get((i, i)).copied().unwrap_or(f64::NAN);
        let quad = |i: usize| d.quadratic.get(i).copied().unwrap_or(f64::NAN);
        let th = &p.thrusters;
        let tau_of = |g: &crate::thrusters::ThrusterGeometry, i: usize| {
            g.tau(1.0).get(i).copied().unwrap_or(f64::NAN)
        };
        let heave_per_n = tau_of(&th.vertical.geometry, 2);
        let yaw_port = tau_of(&th.port.geometry, 5);
        let yaw_stbd = -tau_of(&th.starboard.geometry, 5);
        let arm = 0.5 * (yaw_port + yaw_stbd);
        let (port_k, stbd_k) = if arm > 0.0 {
            (yaw_port / arm, yaw_stbd / arm)
        } else {
            (1.0, 1.0)
        };
        PlantDescription {
            name: "model3".into(),
            heave: AxisDynamics {
                inertia: entry(mm, 2),
                damping_lin: entry(&d.linear, 2),
                damping_quad: quad(2),
                static_load: m.net_weight_n(),
            },
            yaw: AxisDynamics {
                inertia: entry(mm, 5),
                damping_lin: entry(&d.linear, 5),
                damping_quad: quad(5),
                static_load: 0.0,
            },
            vertical: th.vertical.map.as_quadratic().scaled(heave_per_n),
            port: th.port.map.as_quadratic().scaled(port_k),
            starboard: th.starboard.map.as_quadratic().scaled(stbd_k),
            yaw_arm_m: arm,
            yaw_per_heave_m: 0.0,
            vertical_path: PathEffects::default(),
            port_path: PathEffects::default(),
            starboard_path: PathEffects::default(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dead_zone_round_trips_and_never_nan() {
        let p = PathEffects {
            dead_zone: 0.1,
            lag_tau_s: 0.0,
        };
        for pct in [-100.0, -55.0, -10.5, 0.0, 3.0, 42.0, 100.0] {
            let u = p.before_dead_zone(pct, 0.0);
            assert!(u.abs() <= 100.0);
            assert!((p.through_dead_zone(u) - pct).abs() < 1e-9, "{pct} -> {u}");
        }
        // A non-zero demand gets the band added; inside the blend it fades in.
        assert!((p.before_dead_zone(50.0, 2.0) - 55.0).abs() < 1e-9);
        assert!((p.before_dead_zone(-1.0, 2.0) + (5.0 + 0.9)).abs() < 1e-9);
        assert_eq!(p.before_dead_zone(f64::NAN, 2.0), 0.0);
        assert_eq!(p.before_dead_zone(f64::INFINITY, 2.0), 0.0);
        assert!((p.before_dead_zone(500.0, 2.0) - 100.0).abs() < 1e-9);
        assert_eq!(p.through_dead_zone(9.0), 0.0);
    }

    #[test]
    fn lag_step_is_exact_and_off_without_tau() {
        let p = PathEffects {
            dead_zone: 0.0,
            lag_tau_s: 0.5,
        };
        let a = p.lag_step(0.0, 100.0, 0.5);
        assert!((a - 100.0 * (1.0 - (-1.0f64).exp())).abs() < 1e-9);
        assert_eq!(PathEffects::default().lag_step(3.0, 40.0, 0.02), 40.0);
        assert_eq!(p.lag_step(f64::NAN, 40.0, 0.02), 40.0);
    }
}
