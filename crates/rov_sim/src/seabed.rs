//! A flat seabed the simulated vehicle cannot pass: a penalty contact (spring–damper
//! normal force and regularised Coulomb friction) at the hull's lowest point.
//!
//! * Contact points: the four bottom corners of the hull's box, `hull_bottom_m` below
//!   the body origin (the Pro 4 is 0.375 × 0.289 × 0.223 m, parameters.md §1; the
//!   origin, the centre of buoyancy, sits about mid-height, so 0.11 m), each carrying a
//!   quarter of the contact, so a pitched or rolled hull lands on its lowest corner.
//! * Normal force (NED, up), summed over the corners: `F = k·p + c·ṗ` for penetration
//!   `p > 0`, never pulling
//!   (clamped at 0 while the contact unloads). The default `k` = 8000 N/m keeps the
//!   penetration to about a centimetre with full vertical thrust (10 N) on two corners
//!   (a pitched hull driving along the bottom); `c` = 400 N s/m damps the contact
//!   (ζ ≈ 0.7 on the ~11 kg of mass plus heave added mass), so the vehicle settles
//!   without bouncing. With the 100 Hz RK4 step the contact's period (0.23 s) is
//!   resolved by ~23 steps.
//! * Friction: `μ·F` against the horizontal velocity of the contact point, regularised
//!   below `slip_speed_mps` (a smooth `v/max(|v|, v_s)`) so that the integrator sees no
//!   discontinuity; μ = 0.4 (plastic skids on sand, an estimate).
//!
//! The forces act at the contact point, so the friction also pitches the vehicle, as a
//! skid on the bottom does. The camera's scene uses the same depth
//! (`rov_station::runtime::video`), so the vehicle meets the bottom the picture shows.

use nalgebra::Vector3;
use rov_dynamics::Vector6;
use rov_dynamics::kinematics::Attitude;
use rov_dynamics::models::ExternalForce;

/// The seabed and its contact parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Seabed {
    /// Depth of the flat bottom, m (> 0).
    pub depth_m: f64,
    /// The hull's lowest point below the body origin, m.
    pub hull_bottom_m: f64,
    /// Contact stiffness, N/m.
    pub stiffness_n_per_m: f64,
    /// Contact damping, N s/m.
    pub damping_n_s_per_m: f64,
    /// Friction coefficient (tangential force per normal force).
    pub friction: f64,
    /// Speed below which friction is proportional to the slip (regularisation), m/s.
    pub slip_speed_mps: f64,
}

impl Seabed {
    /// A seabed at `depth_m` with the Pro 4's contact defaults (see the module docs).
    #[must_use]
    pub const fn at_depth(depth_m: f64) -> Self {
        Self {
            depth_m,
            hull_bottom_m: 0.11,
            stiffness_n_per_m: 8000.0,
            damping_n_s_per_m: 400.0,
            friction: 0.4,
            slip_speed_mps: 0.05,
        }
    }

    /// Whether every parameter is finite and physical.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        self.depth_m.is_finite()
            && self.depth_m > 0.0
            && self.hull_bottom_m.is_finite()
            && self.hull_bottom_m >= 0.0
            && self.stiffness_n_per_m.is_finite()
            && self.stiffness_n_per_m > 0.0
            && self.damping_n_s_per_m.is_finite()
            && self.damping_n_s_per_m >= 0.0
            && self.friction.is_finite()
            && self.friction >= 0.0
            && self.slip_speed_mps.is_finite()
            && self.slip_speed_mps > 0.0
    }

    /// The deepest the body origin goes at rest on the bottom with no load, m.
    #[must_use]
    pub fn resting_depth_m(&self) -> f64 {
        self.depth_m - self.hull_bottom_m
    }
}

impl ExternalForce for Seabed {
    fn tau_body(&self, _time_s: f64, eta: &Vector6, nu: &Vector6) -> Vector6 {
        let ned_from_body = Attitude::from_eta(eta).ned_from_body();
        let w = Vector3::new(nu[3], nu[4], nu[5]);
        let v = Vector3::new(nu[0], nu[1], nu[2]);
        let mut tau = Vector6::zeros();
        // The four bottom corners of the hull's box, each a quarter of the contact.
        let (hx, hy) = (0.5 * HULL_LENGTH_M, 0.5 * HULL_WIDTH_M);
        for (x, y) in [(hx, hy), (hx, -hy), (-hx, hy), (-hx, -hy)] {
            let r_body = Vector3::new(x, y, self.hull_bottom_m);
            let pen = eta[2] + (ned_from_body * r_body).z - self.depth_m;
            if pen.is_nan() || pen <= 0.0 {
                continue;
            }
            // Velocity of the contact point, NED.
            let v_point = ned_from_body * (v + w.cross(&r_body));
            let normal = (0.25
                * (self.stiffness_n_per_m * pen + self.damping_n_s_per_m * v_point.z))
                .max(0.0);
            let slip = Vector3::new(v_point.x, v_point.y, 0.0);
            let scale = slip.norm().max(self.slip_speed_mps);
            let friction = -slip * (self.friction * normal / scale);
            let f_body = ned_from_body.transpose() * Vector3::new(friction.x, friction.y, -normal);
            let m = r_body.cross(&f_body);
            tau += Vector6::new(f_body.x, f_body.y, f_body.z, m.x, m.y, m.z);
        }
        tau
    }
}

/// The Pro 4's length and width, m (0.375 × 0.289, parameters.md §1): the contact
/// corners.
const HULL_LENGTH_M: f64 = 0.375;
const HULL_WIDTH_M: f64 = 0.289;

/// The water's surface: the buoyancy of the part of the hull above it is lost, so a
/// vehicle at the surface floats there instead of rising into the air (the simulated
/// station starts its vehicle floating, issue 25, item 11).
///
/// The hull is a box `height_m` high whose top is `hull_top_m` above the body origin;
/// the share of it above the surface (depth < 0 at its top) loses that share of
/// `buoyancy_n`, a downward force at the origin. The default buoyancy is model3's:
/// ρ·g·V = 1000 · 9.81 · 6.1e-3 m³ = 59.8 N (config/models/model3.toml); a neutral
/// vehicle then rests with its top at the waterline (body origin at 0.11 m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WaterSurface {
    /// The hull's top above the body origin, m.
    pub hull_top_m: f64,
    /// The hull's height, m.
    pub height_m: f64,
    /// Buoyancy of the whole hull submerged, N.
    pub buoyancy_n: f64,
}

impl Default for WaterSurface {
    fn default() -> Self {
        Self {
            hull_top_m: 0.11,
            height_m: 0.223,
            buoyancy_n: 1000.0 * 9.81 * 6.1e-3,
        }
    }
}

impl WaterSurface {
    /// Whether every parameter is finite and physical.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        self.hull_top_m.is_finite()
            && self.hull_top_m >= 0.0
            && self.height_m.is_finite()
            && self.height_m > 0.0
            && self.buoyancy_n.is_finite()
            && self.buoyancy_n >= 0.0
    }

    /// The depth of the body origin with the hull's top at the waterline, m.
    #[must_use]
    pub fn floating_depth_m(&self) -> f64 {
        self.hull_top_m
    }
}

impl ExternalForce for WaterSurface {
    fn tau_body(&self, _time_s: f64, eta: &Vector6, _nu: &Vector6) -> Vector6 {
        let top_depth = eta[2] - self.hull_top_m;
        let emerged = (-top_depth).clamp(0.0, self.height_m);
        if emerged.is_nan() || emerged <= 0.0 {
            return Vector6::zeros();
        }
        let lost = self.buoyancy_n * emerged / self.height_m;
        let ned_from_body = Attitude::from_eta(eta).ned_from_body();
        let f_body = ned_from_body.transpose() * Vector3::new(0.0, 0.0, lost);
        Vector6::new(f_body.x, f_body.y, f_body.z, 0.0, 0.0, 0.0)
    }
}
