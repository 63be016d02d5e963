//! Angle wrapping: the one implementation every crate uses.
//!
//! Headings increase turning to starboard (clockwise seen from above). Two conventions
//! exist and each has its own name, so a caller always says which one it means:
//!
//! * **absolute** angles (a heading, a compass reading): `[0, 360)` degrees
//!   ([`wrap_deg_360`]) or `[0, 2π)` radians ([`wrap_2pi`]);
//! * **signed differences** (an error, a turn): `[−180, 180)` degrees ([`wrap_deg_180`])
//!   or `[−π, π)` radians ([`wrap_pi`]). A difference of exactly ±180° is ambiguous;
//!   this convention reports it as −180°. [`wrap_deg_180_incl`] is the mirror
//!   `(−180, 180]` (reports +180°), used where a report has always shown +180°.
//!
//! Every function returns NaN for a non-finite input; callers check finiteness first.
//! Pure functions, no I/O.

use std::f64::consts::{PI, TAU};

/// Wraps a signed angle difference in radians to `[−π, π)`.
#[must_use]
pub fn wrap_pi(angle_rad: f64) -> f64 {
    (angle_rad + PI).rem_euclid(TAU) - PI
}

/// Wraps an absolute angle in radians to `[0, 2π)`.
#[must_use]
pub fn wrap_2pi(angle_rad: f64) -> f64 {
    let w = angle_rad.rem_euclid(TAU);
    // rem_euclid can round up to exactly TAU for tiny negative inputs.
    if w >= TAU { 0.0 } else { w }
}

/// Wraps a signed angle difference in degrees to `[−180, 180)`.
#[must_use]
pub fn wrap_deg_180(angle_deg: f64) -> f64 {
    (angle_deg + 180.0).rem_euclid(360.0) - 180.0
}

/// Wraps a signed angle difference in degrees to `(−180, 180]` (+180 kept, −180 → +180).
#[must_use]
pub fn wrap_deg_180_incl(angle_deg: f64) -> f64 {
    let w = wrap_deg_180(angle_deg);
    if w <= -180.0 { w + 360.0 } else { w }
}

/// Wraps an absolute angle in degrees to `[0, 360)`.
#[must_use]
pub fn wrap_deg_360(angle_deg: f64) -> f64 {
    let w = angle_deg.rem_euclid(360.0);
    // rem_euclid can return 360.0 for tiny negative inputs.
    if w >= 360.0 { 0.0 } else { w }
}

/// An absolute heading rounded to `step_deg` (1° for a compass readout, 0.1° for
/// telemetry) and then wrapped to `[0, 360)`: 359.6° shows as 000°, never 360°.
/// Rounding after wrapping (`format!("{:03.0}", h.rem_euclid(360.0))`) is what made a
/// compass reading flip between 000°, 001° and 360° about north (issue 25). A
/// non-positive or non-finite step rounds to 1°.
#[must_use]
pub fn round_heading_deg(heading_deg: f64, step_deg: f64) -> f64 {
    let step = if step_deg.is_finite() && step_deg > 0.0 {
        step_deg
    } else {
        1.0
    };
    // `+ 0.0` turns a −0 (from rounding −0.4) into 0, which prints as "000", not "-00".
    wrap_deg_360((heading_deg / step).round() * step) + 0.0
}

/// A heading as the three-digit compass text the station shows ("000".."359"), from
/// [`round_heading_deg`]; "---" for a non-finite heading.
#[must_use]
pub fn compass_text(heading_deg: f64) -> String {
    if heading_deg.is_finite() {
        format!("{:03.0}", round_heading_deg(heading_deg, 1.0))
    } else {
        "---".to_owned()
    }
}

/// The representation of `angle_deg` closest to `near_deg` (within ±180°): for drawing
/// a heading trace next to its reference without a jump at north, and for unwrapping a
/// series sample by sample.
#[must_use]
pub fn nearest_deg(angle_deg: f64, near_deg: f64) -> f64 {
    near_deg + wrap_deg_180(angle_deg - near_deg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_compass_reading_about_north_is_000_never_360() {
        for h in [359.5, 359.6, 359.99, 360.0, 360.4, -0.4, 0.0, 720.2, -1e-12] {
            assert_eq!(compass_text(h), "000", "{h}");
        }
        assert_eq!(compass_text(0.5), "001");
        assert_eq!(compass_text(359.4), "359");
        assert_eq!(compass_text(f64::NAN), "---");
        assert_eq!(round_heading_deg(359.96, 0.1), 0.0);
        assert!((round_heading_deg(359.94, 0.1) - 359.9).abs() < 1e-9);
        for k in 0..36_000 {
            let r = round_heading_deg(f64::from(k) * 0.01 - 0.3, 1.0);
            assert!((0.0..360.0).contains(&r), "{k}: {r}");
        }
    }

    #[test]
    fn both_conventions_wrap_to_the_short_way() {
        assert!((wrap_deg_180(1.0 - 359.0) - 2.0).abs() < 1e-12);
        assert!((wrap_deg_180(359.0 - 1.0) + 2.0).abs() < 1e-12);
        assert!((wrap_pi(3.0 * PI) + PI).abs() < 1e-12);
        assert!((wrap_deg_360(-1.0) - 359.0).abs() < 1e-12);
        assert!(wrap_2pi(-1e-18) < TAU);
        assert!(wrap_deg_360(-1e-15) < 360.0);
        assert!(wrap_pi(f64::NAN).is_nan());
        assert!(wrap_deg_180_incl(f64::INFINITY).is_nan());
    }

    #[test]
    fn the_two_signed_conventions_differ_only_at_180() {
        assert_eq!(wrap_deg_180(180.0), -180.0);
        assert_eq!(wrap_deg_180(-180.0), -180.0);
        assert_eq!(wrap_deg_180_incl(180.0), 180.0);
        assert_eq!(wrap_deg_180_incl(-180.0), 180.0);
        for k in -1000..1000 {
            let x = f64::from(k) * 0.731;
            let (a, b) = (wrap_deg_180(x), wrap_deg_180_incl(x));
            assert!((-180.0..180.0).contains(&a), "{x} -> {a}");
            assert!(b > -180.0 && b <= 180.0, "{x} -> {b}");
            if a != -180.0 {
                assert_eq!(a, b);
            }
            // Same angle modulo 360.
            assert!(((x - a) / 360.0 - ((x - a) / 360.0).round()).abs() < 1e-9);
        }
    }

    #[test]
    fn nearest_representation_unwraps_through_north() {
        assert!((nearest_deg(2.0, 358.0) - 362.0).abs() < 1e-12);
        assert!((nearest_deg(358.0, 2.0) - -2.0).abs() < 1e-12);
        assert!((nearest_deg(90.0, 720.0 + 80.0) - 810.0).abs() < 1e-9);
    }
}
