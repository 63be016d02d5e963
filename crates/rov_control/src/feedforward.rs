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
//! Any model that describes itself ([`rov_dynamics::VehicleModel::plant`], for example a
//! lab-extended model) gives a [`PlantModel`] ([`PlantModel::from_description`]) with its
//! full thrust path, which the inversion honours: per-sign maps (asymmetric reverse
//! thrust), dead zones (the band is added to a non-zero demand, faded in over
//! [`DEAD_ZONE_BLEND_PCT`]), the lag (lead compensation of the hold's demand in the
//! controller, bounded by [`LAG_LEAD_MAX_PCT`]) and the vertical thruster's reaction torque on yaw.
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

/// One axis' rigid-body-plus-added-mass dynamics (the one definition, in rov_dynamics).
pub use rov_dynamics::plant::{AxisDynamics, PathEffects, PlantDescription};

/// A dead zone's band is added in full to demands beyond this command (%) and faded in
/// linearly below it, so a demand that changes sign does not jump across the band.
pub const DEAD_ZONE_BLEND_PCT: f64 = 2.0;

/// Largest lead (%) the lag compensation `τ·du/dt` may add to a hold's demand.
pub const LAG_LEAD_MAX_PCT: f64 = 40.0;

/// Checks an axis' parameters for finiteness and physical range.
fn validate_axis(ax: &AxisDynamics, model: &str, axis: &str) -> Result<(), ControlError> {
    let fields = [
        ("inertia", ax.inertia, 1e-4, 1e4),
        ("damping_lin", ax.damping_lin, 0.0, 1e4),
        ("damping_quad", ax.damping_quad, 0.0, 1e4),
        ("static_load", ax.static_load, -1e4, 1e4),
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

/// Checks a thrust path's dead zone (0..0.5) and lag (0..5 s).
fn validate_path(p: &PathEffects, model: &str, field: &str) -> Result<(), ControlError> {
    for (name, v, lo, hi) in [
        ("dead_zone", p.dead_zone, 0.0, 0.5),
        ("lag_tau_s", p.lag_tau_s, 0.0, 5.0),
    ] {
        if !(v.is_finite() && v >= lo && v <= hi) {
            return Err(ControlError::InvalidModel {
                model: model.to_string(),
                field: format!("{field}.{name}"),
                value: v,
                allowed: format!("{lo}..={hi}"),
            });
        }
    }
    Ok(())
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
    /// Yaw moment per newton of vertical heave force (the vertical thruster's reaction
    /// torque), m; 0 for the published models.
    pub yaw_per_heave_m: f64,
    /// Dead zone and lag of the vertical thruster.
    pub vertical_path: PathEffects,
    /// Dead zone and lag of the port thruster.
    pub port_path: PathEffects,
    /// Dead zone and lag of the starboard thruster.
    pub starboard_path: PathEffects,
}

impl PlantModel {
    /// Checks every parameter for finiteness and physical range.
    pub fn validate(&self) -> Result<(), ControlError> {
        validate_axis(&self.heave, &self.name, "heave")?;
        validate_axis(&self.yaw, &self.name, "yaw")?;
        validate_path(&self.vertical_path, &self.name, "vertical_path")?;
        validate_path(&self.port_path, &self.name, "port_path")?;
        validate_path(&self.starboard_path, &self.name, "starboard_path")?;
        if !(self.yaw_per_heave_m.is_finite() && self.yaw_per_heave_m.abs() <= 1.0) {
            return Err(ControlError::InvalidModel {
                model: self.name.clone(),
                field: "yaw_per_heave_m".into(),
                value: self.yaw_per_heave_m,
                allowed: "-1..=1".into(),
            });
        }
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

    /// From a model's own plant description ([`rov_dynamics::VehicleModel::plant`]).
    pub fn from_description(d: PlantDescription) -> Self {
        PlantModel {
            name: d.name,
            heave: d.heave,
            yaw: d.yaw,
            vertical: d.vertical,
            port: d.port,
            starboard: d.starboard,
            yaw_arm_m: d.yaw_arm_m,
            yaw_per_heave_m: d.yaw_per_heave_m,
            vertical_path: d.vertical_path,
            port_path: d.port_path,
            starboard_path: d.starboard_path,
        }
    }

    /// Model1 (Enevoldsen et al. 2018) from rov_dynamics' parameters
    /// ([`PlantDescription::from_model1`]).
    pub fn from_model1(p: &rov_dynamics::models::Model1Params) -> Self {
        Self::from_description(PlantDescription::from_model1(p))
    }

    /// Model2 (Arnesen 2016) ([`PlantDescription::from_model2`]).
    pub fn from_model2(p: &rov_dynamics::models::Model2Params) -> Self {
        Self::from_description(PlantDescription::from_model2(p))
    }

    /// Model3 (Mai et al. 2017) ([`PlantDescription::from_model3`]).
    pub fn from_model3(m: &rov_dynamics::models::Model3) -> Self {
        Self::from_description(PlantDescription::from_model3(m))
    }

    /// From any rov_dynamics model that describes its plant (the three published models,
    /// the lab's extended models); `None` for a model that does not.
    pub fn from_vehicle_model(m: &dyn rov_dynamics::VehicleModel) -> Option<Self> {
        m.plant().map(Self::from_description)
    }

    /// The lag time constants (s) of the vertical channel and of the horizontal pair
    /// (their mean): what the lead compensation of each axis uses.
    pub fn lag_taus_s(&self) -> (f64, f64) {
        (
            self.vertical_path.lag_tau_s,
            0.5 * (self.port_path.lag_tau_s + self.starboard_path.lag_tau_s),
        )
    }

    /// Whether any thruster lags.
    pub fn has_lag(&self) -> bool {
        let (v, h) = self.lag_taus_s();
        v > 1e-6 || h > 1e-6
    }

    /// The vertical command that produces heave force `f_n` through the whole path
    /// (per-sign map, then the dead band added); saturates at ±100 % and says so, never
    /// NaN.
    pub fn vertical_inverse(&self, f_n: f64) -> rov_dynamics::thrusters::ThrustInverse {
        let inv = self.vertical.inverse(f_n);
        rov_dynamics::thrusters::ThrustInverse {
            pct: self
                .vertical_path
                .before_dead_zone(inv.pct, DEAD_ZONE_BLEND_PCT),
            saturated: inv.saturated,
        }
    }

    /// The differential command (port +pct, starboard −pct) that produces yaw moment
    /// `n_nm` through the whole path; saturates and says so, never NaN.
    pub fn differential_inverse(&self, n_nm: f64) -> rov_dynamics::thrusters::ThrustInverse {
        if !(n_nm.is_finite() && self.yaw_arm_m > 0.0) {
            return rov_dynamics::thrusters::ThrustInverse {
                pct: 0.0,
                saturated: !n_nm.is_finite(),
            };
        }
        let inv =
            ThrustMap::differential(&self.port, &self.starboard).inverse(n_nm / self.yaw_arm_m);
        let path = PathEffects {
            dead_zone: 0.5 * (self.port_path.dead_zone + self.starboard_path.dead_zone),
            lag_tau_s: 0.0,
        };
        rov_dynamics::thrusters::ThrustInverse {
            pct: path.before_dead_zone(inv.pct, DEAD_ZONE_BLEND_PCT),
            saturated: inv.saturated,
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
        self.vertical_inverse(f_n).pct
    }

    fn differential_pct_for_moment(&self, n_nm: f64) -> f64 {
        self.differential_inverse(n_nm).pct
    }

    fn vertical_force_for_pct(&self, vertical_pct: f64) -> f64 {
        self.vertical
            .force_n_clamped(self.vertical_path.through_dead_zone(vertical_pct))
    }

    fn yaw_moment_for_pct(&self, port_pct: f64, starboard_pct: f64) -> f64 {
        self.yaw_arm_m
            * (self
                .port
                .force_n_clamped(self.port_path.through_dead_zone(port_pct))
                - self
                    .starboard
                    .force_n_clamped(self.starboard_path.through_dead_zone(starboard_pct)))
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

    /// model3 with a weak reverse vertical map, a dead zone, a lag and a reaction torque.
    fn hurt_plant() -> PlantModel {
        let mut p = PlantModel::load_default(ModelChoice::Model3).unwrap();
        p.vertical.reverse = p.vertical.forward;
        p.vertical.reverse.linear_n *= 0.5;
        p.vertical.reverse.quadratic_n *= 0.5;
        let path = PathEffects {
            dead_zone: 0.08,
            lag_tau_s: 0.3,
        };
        p.vertical_path = path;
        p.port_path = path;
        p.starboard_path = path;
        p.yaw_per_heave_m = 0.02;
        p.validate().unwrap();
        p
    }

    #[test]
    fn full_thrust_path_round_trips_per_sign_through_the_dead_zone() {
        let p = hurt_plant();
        let (lo, hi) = p.vertical_force_range_n();
        // The reverse (upward) reach is half the forward reach.
        assert!((lo + 0.5 * hi).abs() < 1e-9, "{lo} {hi}");
        for f in [lo * 0.99, -3.0, -0.4, 0.4, 3.0, hi * 0.99] {
            let inv = p.vertical_inverse(f);
            assert!(!inv.saturated);
            // Beyond the blend the dead band is added in full.
            assert!(
                inv.pct.abs() >= 8.0 + DEAD_ZONE_BLEND_PCT * 0.92 - 1e-9,
                "{f}: {}",
                inv.pct
            );
            let back = p.vertical_force_for_pct(inv.pct);
            assert!((back - f).abs() < 1e-9, "{f} -> {} -> {back}", inv.pct);
        }
        for n in [-2.0, -0.3, 0.3, 2.0] {
            let pct = p.differential_pct_for_moment(n);
            assert!((p.yaw_moment_for_pct(pct, -pct) - n).abs() < 1e-9);
        }
        // A command inside the dead zone gives no force.
        assert_eq!(p.vertical_force_for_pct(7.9), 0.0);
        assert_eq!(p.lag_taus_s(), (0.3, 0.3));
        assert!(p.has_lag());
    }

    #[test]
    fn full_path_inverse_saturates_and_says_so_never_nan() {
        let p = hurt_plant();
        let (lo, hi) = p.vertical_force_range_n();
        for f in [
            lo * 1.5,
            hi * 1.5,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ] {
            let inv = p.vertical_inverse(f);
            assert!(inv.saturated, "{f}");
            assert!(
                inv.pct.is_finite() && inv.pct.abs() <= 100.0,
                "{f}: {}",
                inv.pct
            );
        }
        assert_eq!(p.vertical_inverse(lo * 2.0).pct, -100.0);
        for n in [1e6, -1e6, f64::NAN] {
            let inv = p.differential_inverse(n);
            assert!(inv.saturated && inv.pct.is_finite() && inv.pct.abs() <= 100.0);
        }
    }

    #[test]
    fn a_bad_path_parameter_is_refused_with_field_value_and_range() {
        let mut p = hurt_plant();
        p.vertical_path.dead_zone = 0.7;
        let e = p.validate().unwrap_err().to_string();
        assert!(
            e.contains("vertical_path.dead_zone") && e.contains("0.7"),
            "{e}"
        );
        let mut p = hurt_plant();
        p.port_path.lag_tau_s = f64::NAN;
        assert!(
            p.validate()
                .unwrap_err()
                .to_string()
                .contains("port_path.lag_tau_s")
        );
    }

    #[test]
    fn the_published_models_describe_themselves() {
        for choice in ModelChoice::ALL {
            let m = rov_dynamics::load_default_model(choice.name()).unwrap();
            let d = m.plant().expect("a published model has a plant");
            let p = PlantModel::from_description(d);
            assert_eq!(p, PlantModel::load_default(choice).unwrap());
            assert!(!p.has_lag() && p.yaw_per_heave_m == 0.0);
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
