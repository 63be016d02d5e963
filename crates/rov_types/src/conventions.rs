//! Wire ↔ physics sign and unit conventions for the Pro 4 tether protocol: the ONE place
//! where both the topside driver (`rov_driver`) and the simulated vehicle (`rov_vehicle`)
//! turn wire integers into physical quantities and back.
//!
//! The physics side follows the measurement CSV (`crate::measurement`) and Fossen: depth
//! positive down, pitch positive nose up, roll positive starboard down, heading in degrees
//! [0, 360) turning clockwise seen from above, and positive vertical thrust pushing the
//! vehicle **down**.
//!
//! VideoRay does not document the sign of the vertical thrust, of pitch or of roll on the
//! wire, nor whether the pressure field is absolute or gauge (protocol.md §6.1, §6.5, §11).
//! Every such choice is therefore a setting of [`WireConventions`], with a documented
//! default:
//!
//! | setting | default | meaning of the default |
//! |---|---|---|
//! | `vertical_positive_down` | `true` | a positive wire vertical thrust pushes the vehicle down (same sign as physics) |
//! | `pitch_positive_nose_up` | `true` | a positive wire pitch is nose up (same sign as physics) |
//! | `roll_positive_starboard_down` | `true` | a positive wire roll is starboard down (same sign as physics) |
//! | `heading_offset_deg` | `0.0` | physics heading = wire heading + offset, wrapped to [0, 360) |
//! | `surface_pressure_mbar` | `1013.25` | the pressure read at the surface (tare); the wire pressure is taken as absolute mbar |
//! | `water_density_kg_m3` | `1000.0` | fresh water (sea water ≈ 1025) |
//! | `gravity_mps2` | `9.81` | |
//!
//! Depth from pressure: depth = (P − P_surface) · 100 / (ρ g), with P in mbar (1 mbar =
//! 100 Pa), about 0.0102 m/mbar in fresh water. The simulator's pressure gauge uses the
//! same defaults (ρ = 1000, g = 9.81, P_atm = 1013.25 mbar), so the defaults agree
//! between the two sides.
//!
//! Pure functions only: no I/O, no clock.

use serde::{Deserialize, Serialize};

/// Largest thrust magnitude on the wire, % (protocol.md §6.1).
pub const THRUST_LIMIT_PCT: f64 = 100.0;

/// A [`WireConventions`] value out of range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("wire conventions: {field} = {value} is out of range (allowed {allowed})")]
pub struct ConventionsError {
    /// The setting.
    pub field: &'static str,
    /// Its value.
    pub value: f64,
    /// What is accepted.
    pub allowed: &'static str,
}

/// How wire values map to the physics convention. See the [module docs](self) for the
/// defaults and why each is a setting.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WireConventions {
    /// A positive wire vertical thrust pushes the vehicle down (default `true`).
    pub vertical_positive_down: bool,
    /// A positive wire pitch means nose up (default `true`).
    pub pitch_positive_nose_up: bool,
    /// A positive wire roll means starboard down (default `true`).
    pub roll_positive_starboard_down: bool,
    /// Physics heading = wire heading + this, degrees (default 0).
    pub heading_offset_deg: f64,
    /// Absolute pressure at the surface (tare), mbar (default 1013.25).
    pub surface_pressure_mbar: f64,
    /// Water density ρ, kg/m³ (default 1000, fresh water).
    pub water_density_kg_m3: f64,
    /// Gravity g, m/s² (default 9.81).
    pub gravity_mps2: f64,
}

impl Default for WireConventions {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Physical thrust command, % of full power, −100..=100 each. Positive `vertical` pushes
/// the vehicle down; port above starboard turns to starboard.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct PhysicsThrust {
    /// Port (left) horizontal thruster, %.
    pub port_pct: f64,
    /// Starboard (right) horizontal thruster, %.
    pub starboard_pct: f64,
    /// Vertical thruster, %; positive pushes down.
    pub vertical_pct: f64,
}

impl PhysicsThrust {
    /// All thrusters off.
    pub const NEUTRAL: Self = Self {
        port_pct: 0.0,
        starboard_pct: 0.0,
        vertical_pct: 0.0,
    };
}

/// Rounds and saturates a percentage to a wire thrust value (NaN gives 0).
fn pct_to_wire(pct: f64) -> i16 {
    if pct.is_nan() {
        0
    } else {
        // In range after the clamp, so the cast is exact.
        pct.clamp(-THRUST_LIMIT_PCT, THRUST_LIMIT_PCT).round() as i16
    }
}

/// Rounds and saturates to i16 (NaN gives 0).
fn saturate_i16(x: f64) -> i16 {
    if x.is_nan() {
        0
    } else {
        x.round().clamp(f64::from(i16::MIN), f64::from(i16::MAX)) as i16
    }
}

fn sign(positive_is_physics: bool) -> f64 {
    if positive_is_physics { 1.0 } else { -1.0 }
}

/// Wraps degrees to [0, 360) (the one implementation is in [`crate::angle`]).
pub use crate::angle::wrap_deg_360;

impl WireConventions {
    /// The documented defaults (see the [module docs](self)).
    pub const DEFAULT: Self = Self {
        vertical_positive_down: true,
        pitch_positive_nose_up: true,
        roll_positive_starboard_down: true,
        heading_offset_deg: 0.0,
        surface_pressure_mbar: 1013.25,
        water_density_kg_m3: 1000.0,
        gravity_mps2: 9.81,
    };

    /// Checks the numeric settings: finite, heading offset within ±360°, surface
    /// pressure 500..=1500 mbar, density 900..=1100 kg/m³, gravity 9..=10.5 m/s².
    ///
    /// # Errors
    /// The first setting out of range.
    pub fn validate(&self) -> Result<(), ConventionsError> {
        let checks: [(&'static str, f64, f64, f64, &'static str); 4] = [
            (
                "heading_offset_deg",
                self.heading_offset_deg,
                -360.0,
                360.0,
                "-360..=360",
            ),
            (
                "surface_pressure_mbar",
                self.surface_pressure_mbar,
                500.0,
                1500.0,
                "500..=1500",
            ),
            (
                "water_density_kg_m3",
                self.water_density_kg_m3,
                900.0,
                1100.0,
                "900..=1100",
            ),
            ("gravity_mps2", self.gravity_mps2, 9.0, 10.5, "9..=10.5"),
        ];
        for (field, value, min, max, allowed) in checks {
            if !(value.is_finite() && (min..=max).contains(&value)) {
                return Err(ConventionsError {
                    field,
                    value,
                    allowed,
                });
            }
        }
        Ok(())
    }

    /// With another surface pressure (tare), mbar.
    #[must_use]
    pub const fn with_surface_pressure_mbar(mut self, mbar: f64) -> Self {
        self.surface_pressure_mbar = mbar;
        self
    }

    /// +1.0 if a positive wire vertical thrust pushes down, else −1.0.
    #[must_use]
    pub fn vertical_sign(&self) -> f64 {
        sign(self.vertical_positive_down)
    }

    /// +1.0 if a positive wire pitch (and pitch rate) is nose up, else −1.0.
    #[must_use]
    pub fn pitch_sign(&self) -> f64 {
        sign(self.pitch_positive_nose_up)
    }

    /// +1.0 if a positive wire roll (and roll rate) is starboard down, else −1.0.
    #[must_use]
    pub fn roll_sign(&self) -> f64 {
        sign(self.roll_positive_starboard_down)
    }

    // ---- thrust -------------------------------------------------------------------

    /// Physics vertical thrust (% , positive down) → wire value (rounded, ±100).
    #[must_use]
    pub fn vertical_to_wire(&self, vertical_pct: f64) -> i16 {
        pct_to_wire(sign(self.vertical_positive_down) * vertical_pct)
    }

    /// Wire vertical thrust → physics % (positive down).
    #[must_use]
    pub fn vertical_from_wire(&self, wire: i16) -> f64 {
        sign(self.vertical_positive_down) * f64::from(wire)
    }

    /// Physics thrust → wire `[port, starboard, vertical]` (rounded, saturated to ±100,
    /// NaN → 0). The horizontal thrusters keep their sign: positive is forward thrust on
    /// both the wire and the physics side (protocol.md §6.1: negative is reverse).
    #[must_use]
    pub fn thrust_to_wire(&self, thrust: &PhysicsThrust) -> [i16; 3] {
        [
            pct_to_wire(thrust.port_pct),
            pct_to_wire(thrust.starboard_pct),
            self.vertical_to_wire(thrust.vertical_pct),
        ]
    }

    /// Wire `[port, starboard, vertical]` → physics thrust (saturated to ±100).
    #[must_use]
    pub fn thrust_from_wire(&self, wire: [i16; 3]) -> PhysicsThrust {
        let [port, starboard, vertical] = wire;
        let clamp = |x: f64| x.clamp(-THRUST_LIMIT_PCT, THRUST_LIMIT_PCT);
        PhysicsThrust {
            port_pct: clamp(f64::from(port)),
            starboard_pct: clamp(f64::from(starboard)),
            vertical_pct: clamp(self.vertical_from_wire(vertical)),
        }
    }

    // ---- attitude -----------------------------------------------------------------

    /// Wire heading (degrees ×10, signed: real vehicles send both −1800..=1800 and
    /// 0..=3599) → physics heading in degrees, [0, 360).
    #[must_use]
    pub fn heading_deg_from_wire(&self, deci_deg: i16) -> f64 {
        wrap_deg_360(f64::from(deci_deg) / 10.0 + self.heading_offset_deg)
    }

    /// Physics heading in degrees → wire heading ×10 in 0..=3599.
    #[must_use]
    pub fn heading_to_wire(&self, heading_deg: f64) -> i16 {
        if !heading_deg.is_finite() {
            return 0;
        }
        let mut x = (wrap_deg_360(heading_deg - self.heading_offset_deg) * 10.0).round();
        if x >= 3600.0 {
            x -= 3600.0;
        }
        saturate_i16(x)
    }

    /// Wire pitch (degrees ×10) → physics pitch in degrees (positive nose up).
    #[must_use]
    pub fn pitch_deg_from_wire(&self, deci_deg: i16) -> f64 {
        sign(self.pitch_positive_nose_up) * f64::from(deci_deg) / 10.0
    }

    /// Physics pitch in degrees (positive nose up) → wire ×10.
    #[must_use]
    pub fn pitch_to_wire(&self, pitch_deg: f64) -> i16 {
        saturate_i16(sign(self.pitch_positive_nose_up) * pitch_deg * 10.0)
    }

    /// Wire roll (degrees ×10) → physics roll in degrees (positive starboard down).
    #[must_use]
    pub fn roll_deg_from_wire(&self, deci_deg: i16) -> f64 {
        sign(self.roll_positive_starboard_down) * f64::from(deci_deg) / 10.0
    }

    /// Physics roll in degrees (positive starboard down) → wire ×10.
    #[must_use]
    pub fn roll_to_wire(&self, roll_deg: f64) -> i16 {
        saturate_i16(sign(self.roll_positive_starboard_down) * roll_deg * 10.0)
    }

    // ---- pressure and depth -----------------------------------------------------

    /// Metres of water per mbar: 100 / (ρ g).
    #[must_use]
    pub fn metres_per_mbar(&self) -> f64 {
        100.0 / (self.water_density_kg_m3 * self.gravity_mps2)
    }

    /// Absolute pressure in mbar → depth in metres (positive down; negative above the
    /// tare).
    #[must_use]
    pub fn depth_m_from_pressure(&self, pressure_mbar: f64) -> f64 {
        (pressure_mbar - self.surface_pressure_mbar) * self.metres_per_mbar()
    }

    /// Depth in metres → absolute pressure in mbar.
    #[must_use]
    pub fn pressure_mbar_from_depth(&self, depth_m: f64) -> f64 {
        self.surface_pressure_mbar + depth_m / self.metres_per_mbar()
    }

    /// Wire pressure field (int16 mbar) → depth in metres.
    #[must_use]
    pub fn depth_m_from_wire(&self, pressure_mbar: i16) -> f64 {
        self.depth_m_from_pressure(f64::from(pressure_mbar))
    }

    /// Depth in metres → the wire pressure field (rounded, saturated to int16).
    #[must_use]
    pub fn pressure_to_wire(&self, depth_m: f64) -> i16 {
        saturate_i16(self.pressure_mbar_from_depth(depth_m))
    }

    /// Depth in metres → the auto-depth target of CSR 0x0B (mbar, u16; rounded and
    /// clamped to 0..=65534 so it can never read as "off"). `None` for a non-finite
    /// depth.
    #[must_use]
    pub fn depth_target_mbar(&self, depth_m: f64) -> Option<u16> {
        let p = self.pressure_mbar_from_depth(depth_m);
        p.is_finite().then(|| p.round().clamp(0.0, 65_534.0) as u16)
    }

    /// Physics heading in degrees → the auto-heading target of CSR 0x0D (whole degrees
    /// 0..=359, wire frame). `None` for a non-finite heading.
    #[must_use]
    pub fn heading_target_deg(&self, heading_deg: f64) -> Option<u16> {
        if !heading_deg.is_finite() {
            return None;
        }
        let w = wrap_deg_360(heading_deg - self.heading_offset_deg).round();
        Some(if w >= 360.0 { 0 } else { w as u16 })
    }

    /// The auto-heading target of CSR 0x0D (wire degrees) → physics heading, degrees.
    #[must_use]
    pub fn heading_target_to_physics(&self, wire_deg: u16) -> f64 {
        wrap_deg_360(f64::from(wire_deg) + self.heading_offset_deg)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_identity_signs_and_fresh_water() {
        let c = WireConventions::default();
        assert_eq!(c, WireConventions::DEFAULT);
        assert!(c.validate().is_ok());
        assert_eq!(c.vertical_to_wire(25.4), 25);
        assert_eq!(c.vertical_from_wire(-40), -40.0);
        assert_eq!(c.pitch_to_wire(3.7), 37);
        assert_eq!(c.roll_deg_from_wire(-30), -3.0);
        assert!((c.metres_per_mbar() - 0.010_193_679_918).abs() < 1e-9);
    }

    #[test]
    fn flipped_signs_round_trip() {
        let c = WireConventions {
            vertical_positive_down: false,
            pitch_positive_nose_up: false,
            roll_positive_starboard_down: false,
            heading_offset_deg: 10.0,
            ..WireConventions::DEFAULT
        };
        assert_eq!(c.vertical_to_wire(30.0), -30);
        assert_eq!(c.vertical_from_wire(-30), 30.0);
        assert_eq!(c.pitch_to_wire(5.0), -50);
        assert_eq!(c.pitch_deg_from_wire(-50), 5.0);
        assert_eq!(c.roll_to_wire(-2.5), 25);
        assert_eq!(c.heading_to_wire(5.0), 3550);
        assert_eq!(c.heading_deg_from_wire(3550), 5.0);
        assert_eq!(c.heading_target_deg(100.0), Some(90));
        assert_eq!(c.heading_target_to_physics(90), 100.0);
    }

    #[test]
    fn thrust_saturates_and_handles_nan() {
        let c = WireConventions::DEFAULT;
        let w = c.thrust_to_wire(&PhysicsThrust {
            port_pct: 250.0,
            starboard_pct: f64::NAN,
            vertical_pct: -100.4,
        });
        assert_eq!(w, [100, 0, -100]);
        let p = c.thrust_from_wire([i16::MIN, 5, 120]);
        assert_eq!(
            (p.port_pct, p.starboard_pct, p.vertical_pct),
            (-100.0, 5.0, 100.0)
        );
    }

    #[test]
    fn heading_wraps_and_accepts_negative_wire_values() {
        let c = WireConventions::DEFAULT;
        assert_eq!(c.heading_deg_from_wire(-132), 346.8);
        assert_eq!(c.heading_to_wire(359.97), 0);
        assert_eq!(c.heading_to_wire(-90.0), 2700);
        assert_eq!(c.heading_to_wire(f64::NAN), 0);
    }

    #[test]
    fn pressure_depth_round_trip() {
        let c = WireConventions::DEFAULT.with_surface_pressure_mbar(1000.0);
        let p = c.pressure_mbar_from_depth(2.0);
        assert!((p - 1196.2).abs() < 1e-9);
        assert!((c.depth_m_from_pressure(p) - 2.0).abs() < 1e-12);
        assert_eq!(c.pressure_to_wire(2.0), 1196);
        assert_eq!(c.depth_target_mbar(2.0), Some(1196));
        assert_eq!(c.depth_target_mbar(1e9), Some(65_534));
        assert_eq!(c.depth_target_mbar(f64::NAN), None);
    }

    #[test]
    fn validate_names_the_setting() {
        let c = WireConventions {
            water_density_kg_m3: f64::NAN,
            ..WireConventions::DEFAULT
        };
        assert_eq!(
            c.validate().map_err(|e| e.field),
            Err("water_density_kg_m3")
        );
    }
}
