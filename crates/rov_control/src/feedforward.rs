//! Model feedforward: inverse dynamics of the heave and yaw axes of one of the three
//! VideoRay models, and that model's thrust map, inverted per sign.
//!
//! * heave: `Z = m_eff·ẇ_d + (d_l + d_q·|w_d|)·w_d − (W − B)` (z down; a heavy vehicle,
//!   W > B, needs upward thrust; model1 assumes neutral buoyancy, so W − B = 0 there);
//! * yaw: `N = I_eff·ṙ_d + (d_l + d_q·|r_d|)·r_d`;
//! * thrust maps: quadratic `F = T_l·u + T_q·u·|u|` per thruster, `u ∈ [−1, 1]`, with
//!   separate forward and reverse coefficient pairs (so a model with reverse-thrust
//!   asymmetry is honoured), or model2's linear `F = G·u%`.
//!
//! The same [`PlantModel`] also tells the observer which force a command produces
//! ([`FeedforwardModel::vertical_force_for_pct`], [`FeedforwardModel::yaw_moment_for_pct`])
//! and which inertia and damping the axes have.
//!
//! Sign conventions: positive vertical thrust pushes the vehicle down (deeper); a
//! positive yaw moment turns to starboard and comes from port thrust above starboard
//! thrust: `N = arm·(F_port − F_starboard)`.

use crate::error::ControlError;

/// Which of the three published VideoRay models supplies the feedforward: the
/// workspace's one model identity, [`rov_types::BaseModel`] (`model1`, `model2`,
/// `model3`; the default is model3).
pub use rov_types::BaseModel as ModelChoice;

/// What the controller and observer need from a vehicle model.
pub trait FeedforwardModel {
    /// Heave force (N, positive down) needed for vertical velocity `w_mps` and
    /// acceleration `wdot_mps2` (both positive down).
    fn heave_force_n(&self, w_mps: f64, wdot_mps2: f64) -> f64;
    /// Yaw moment (N·m, positive to starboard) needed for yaw rate `r_rad_s` and yaw
    /// acceleration `rdot_rad_s2`.
    fn yaw_moment_nm(&self, r_rad_s: f64, rdot_rad_s2: f64) -> f64;
    /// Vertical command (%, −100..100) that produces heave force `f_n`; clamped.
    fn vertical_pct_for_force(&self, f_n: f64) -> f64;
    /// Differential command (%): port = +pct, starboard = −pct, which produces the yaw
    /// moment `n_nm` with no surge; clamped to −100..100.
    fn differential_pct_for_moment(&self, n_nm: f64) -> f64;
    /// Heave force (N) produced by a vertical command in %.
    fn vertical_force_for_pct(&self, vertical_pct: f64) -> f64;
    /// Yaw moment (N·m) produced by port and starboard commands in %.
    fn yaw_moment_for_pct(&self, port_pct: f64, starboard_pct: f64) -> f64;
}

/// A thruster's command-to-force map `F = T_l·u + T_q·u·|u|` with `u = pct/100`, with
/// separate forward (u ≥ 0) and reverse (u < 0) coefficient pairs, and its inverse: the
/// one implementation in `rov_dynamics::thrusters` (the simulator's map), used here as is.
pub use rov_dynamics::thrusters::QuadraticThrustMap as ThrustMap;

/// Checks a thrust map's coefficients (finite, 0..=1e4 N, thrust in both directions).
fn validate_map(map: &ThrustMap, model: &str, field: &str) -> Result<(), ControlError> {
    let coeffs = [
        ("fwd_lin_n", map.forward.linear_n),
        ("fwd_quad_n", map.forward.quadratic_n),
        ("rev_lin_n", map.reverse.linear_n),
        ("rev_quad_n", map.reverse.quadratic_n),
    ];
    for (name, v) in coeffs {
        if !(v.is_finite() && (0.0..=1e4).contains(&v)) {
            return Err(ControlError::InvalidModel {
                model: model.to_string(),
                field: format!("{field}.{name}"),
                value: v,
                allowed: "0..=10000".into(),
            });
        }
    }
    if map.forward.linear_n + map.forward.quadratic_n <= 0.0
        || map.reverse.linear_n + map.reverse.quadratic_n <= 0.0
    {
        return Err(ControlError::InvalidModel {
            model: model.to_string(),
            field: field.to_string(),
            value: 0.0,
            allowed: "a map that produces thrust in both directions".into(),
        });
    }
    Ok(())
}

/// One axis' rigid-body-plus-added-mass dynamics: `inertia·v̇ + (d_l + d_q·|v|)·v = τ + load`.
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

    fn validate(&self, model: &str, axis: &str) -> Result<(), ControlError> {
        let fields = [
            ("inertia", self.inertia, 1e-4, 1e4),
            ("damping_lin", self.damping_lin, 0.0, 1e4),
            ("damping_quad", self.damping_quad, 0.0, 1e4),
            ("static_load", self.static_load, -1e4, 1e4),
        ];
        for (name, v, lo, hi) in fields {
            if !(v.is_finite() && v >= lo && v <= hi) {
                return Err(ControlError::InvalidModel {
                    model: model.to_string(),
                    field: format!("{axis}.{name}"),
                    value: v,
                    allowed: format!("{lo}..={hi}"),
                });
            }
        }
        Ok(())
    }
}

/// The heave and yaw part of one vehicle model plus its thrust maps: everything the
/// feedforward, the thrust-map inversion and the observer need.
#[derive(Debug, Clone, PartialEq)]
pub struct PlantModel {
    /// Label for diagnostics and errors.
    pub name: String,
    /// Heave axis (z down).
    pub heave: AxisDynamics,
    /// Yaw axis (positive to starboard); `static_load` is normally 0.
    pub yaw: AxisDynamics,
    /// Vertical thruster map, as heave force (positive pushes down).
    pub vertical: ThrustMap,
    /// Port thruster map (positive forward).
    pub port: ThrustMap,
    /// Starboard thruster map (positive forward).
    pub starboard: ThrustMap,
    /// Yaw lever arm of the horizontal pair, m: `N = arm·(F_port − F_starboard)`.
    pub yaw_arm_m: f64,
}

impl PlantModel {
    /// Checks every parameter for finiteness and physical range.
    pub fn validate(&self) -> Result<(), ControlError> {
        self.heave.validate(&self.name, "heave")?;
        self.yaw.validate(&self.name, "yaw")?;
        validate_map(&self.vertical, &self.name, "vertical")?;
        validate_map(&self.port, &self.name, "port")?;
        validate_map(&self.starboard, &self.name, "starboard")?;
        if !(self.yaw_arm_m.is_finite() && self.yaw_arm_m > 1e-4 && self.yaw_arm_m < 10.0) {
            return Err(ControlError::InvalidModel {
                model: self.name.clone(),
                field: "yaw_arm_m".into(),
                value: self.yaw_arm_m,
                allowed: "0.0001..10".into(),
            });
        }
        Ok(())
    }

    /// Heave force range (N) the vertical thruster can produce: (most upward, most down).
    pub fn vertical_force_range_n(&self) -> (f64, f64) {
        (self.vertical.force_n(-100.0), self.vertical.force_n(100.0))
    }

    /// Largest yaw moment magnitude (N·m) at full differential thrust.
    pub fn yaw_moment_max_nm(&self) -> f64 {
        let d = ThrustMap::differential(&self.port, &self.starboard);
        self.yaw_arm_m * d.force_n(100.0).min(-d.force_n(-100.0))
    }

    /// Model1 (Enevoldsen et al. 2018) from rov_dynamics' parameters. The paper's form
    /// `m·ẇ = β_w·(α_w·F − D(w))` gives the thrust needed as
    /// `F = m/(α_w·β_w)·ẇ + D(w)/α_w`, so the equivalent axis has inertia
    /// `m/(α·β)` and damping `D/α`; neutral buoyancy (no W − B).
    pub fn from_model1(p: &rov_dynamics::models::Model1Params) -> Self {
        let [_, alpha_w, alpha_r] = p.alpha;
        let [_, beta_w, beta_r] = p.beta;
        PlantModel {
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
        }
    }

    /// Model2 (Arnesen 2016) from rov_dynamics' parameters: `M = m − Z_ẇ`, `I_z − N_ṙ`,
    /// damping `−Z_w, −Z_|w|w, −N_r, −N_|r|r`, load `W − B`, linear maps G1 (per
    /// horizontal thruster) and G2, lever arm `G3/G1`.
    pub fn from_model2(p: &rov_dynamics::models::Model2Params) -> Self {
        PlantModel {
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
            vertical: ThrustMap::linear(p.g2_n_per_pct),
            port: ThrustMap::linear(p.g1_n_per_pct),
            starboard: ThrustMap::linear(p.g1_n_per_pct),
            yaw_arm_m: if p.g1_n_per_pct > 0.0 {
                p.g3_nm_per_pct / p.g1_n_per_pct
            } else {
                0.0
            },
        }
    }

    /// Model3 (Mai et al. 2017): the heave and yaw diagonal of its 6-DOF mass matrix
    /// (rigid body about CO plus added mass) and damping, `W − B`, and the thrusters'
    /// maps scaled by their geometry (heave force per newton of the vertical thruster,
    /// yaw moment per newton of each horizontal one).
    pub fn from_model3(m: &rov_dynamics::models::Model3) -> Self {
        let p = m.params();
        let mm = m.process().mass_matrix();
        let d = &p.process.damping;
        let entry =
            |mat: &rov_dynamics::Matrix6, i: usize| mat.get((i, i)).copied().unwrap_or(f64::NAN);
        let quad = |i: usize| d.quadratic.get(i).copied().unwrap_or(f64::NAN);
        let th = &p.thrusters;
        let heave_per_n = th
            .vertical
            .geometry
            .tau(1.0)
            .get(2)
            .copied()
            .unwrap_or(f64::NAN);
        let yaw_port = th
            .port
            .geometry
            .tau(1.0)
            .get(5)
            .copied()
            .unwrap_or(f64::NAN);
        let yaw_stbd = -th
            .starboard
            .geometry
            .tau(1.0)
            .get(5)
            .copied()
            .unwrap_or(f64::NAN);
        let arm = 0.5 * (yaw_port + yaw_stbd);
        // Per-thruster maps carry any port/starboard difference in lever arm.
        let (port_k, stbd_k) = if arm > 0.0 {
            (yaw_port / arm, yaw_stbd / arm)
        } else {
            (1.0, 1.0)
        };
        PlantModel {
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
        }
    }

    /// From any rov_dynamics model that is one of the three (by downcasting); `None` for
    /// other models.
    pub fn from_vehicle_model(m: &dyn rov_dynamics::VehicleModel) -> Option<Self> {
        let any = m.as_any();
        if let Some(m1) = any.downcast_ref::<rov_dynamics::models::Model1>() {
            Some(Self::from_model1(m1.params()))
        } else if let Some(m2) = any.downcast_ref::<rov_dynamics::models::Model2>() {
            Some(Self::from_model2(m2.params()))
        } else {
            any.downcast_ref::<rov_dynamics::models::Model3>()
                .map(Self::from_model3)
        }
    }

    /// The model shipped in `config/models/<name>.toml`, through rov_dynamics' loader.
    pub fn load_default(choice: ModelChoice) -> Result<Self, rov_types::ConfigError> {
        let m = rov_dynamics::load_default_model(choice.name())?;
        Self::from_vehicle_model(m.as_ref()).ok_or_else(|| rov_types::ConfigError::Inconsistent {
            file: format!("config/models/{}.toml", choice.name()),
            message: format!(
                "loaded model {:?} is not one of model1, model2, model3",
                m.name()
            ),
        })
    }
}

impl FeedforwardModel for PlantModel {
    fn heave_force_n(&self, w_mps: f64, wdot_mps2: f64) -> f64 {
        self.heave.inverse(w_mps, wdot_mps2)
    }

    fn yaw_moment_nm(&self, r_rad_s: f64, rdot_rad_s2: f64) -> f64 {
        self.yaw.inverse(r_rad_s, rdot_rad_s2)
    }

    fn vertical_pct_for_force(&self, f_n: f64) -> f64 {
        self.vertical.pct_for_force(f_n)
    }

    fn differential_pct_for_moment(&self, n_nm: f64) -> f64 {
        if !(n_nm.is_finite() && self.yaw_arm_m > 0.0) {
            return 0.0;
        }
        ThrustMap::differential(&self.port, &self.starboard).pct_for_force(n_nm / self.yaw_arm_m)
    }

    fn vertical_force_for_pct(&self, vertical_pct: f64) -> f64 {
        self.vertical.force_n_clamped(vertical_pct)
    }

    fn yaw_moment_for_pct(&self, port_pct: f64, starboard_pct: f64) -> f64 {
        self.yaw_arm_m
            * (self.port.force_n_clamped(port_pct) - self.starboard.force_n_clamped(starboard_pct))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn differential_moment_round_trip_all_models() {
        for choice in ModelChoice::ALL {
            let p = PlantModel::load_default(choice).unwrap();
            p.validate().unwrap();
            for n in [-3.0, -0.5, -0.01, 0.0, 0.2, 1.0, 3.0] {
                let pct = p.differential_pct_for_moment(n);
                let back = p.yaw_moment_for_pct(pct, -pct);
                assert!((back - n).abs() < 1e-9, "{choice:?} {n} -> {pct} -> {back}");
            }
            for f in [-9.0, -1.0, 0.0, 0.3, 9.0] {
                let pct = p.vertical_pct_for_force(f);
                assert!((p.vertical_force_for_pct(pct) - f).abs() < 1e-9);
            }
            // Full differential gives about 3.4 N·m in every shipped model (model1: R·sin γ ≈ 0.1 m).
            assert!(
                (p.yaw_moment_max_nm() - 3.4).abs() < 0.01,
                "{choice:?} {}",
                p.yaw_moment_max_nm()
            );
        }
    }

    #[test]
    fn inverse_dynamics_signs() {
        let mut p = PlantModel::load_default(ModelChoice::Model3).unwrap();
        p.heave.static_load = 0.5; // heavy: sinks
        // Hovering needs 0.5 N upward (negative).
        assert!((p.heave_force_n(0.0, 0.0) + 0.5).abs() < 1e-12);
        // Descending at 0.2 m/s needs downward thrust for the drag.
        assert!(p.heave_force_n(0.2, 0.0) > 0.0);
        assert!(p.yaw_moment_nm(0.3, 0.0) > 0.0 && p.yaw_moment_nm(0.0, -1.0) < 0.0);
        assert_eq!(ModelChoice::from_name("model2"), Some(ModelChoice::Model2));
        assert_eq!(ModelChoice::Model1.name(), "model1");
        assert!(ModelChoice::from_name("model4").is_none());
    }
}
