//! Angle helpers. Headings increase turning to starboard (clockwise seen from above).
//!
//! Every function returns NaN for a non-finite input; callers check finiteness first.

use std::f64::consts::{PI, TAU};

/// Wraps an angle in radians to `[-π, π)`.
pub fn wrap_pi(angle_rad: f64) -> f64 {
    (angle_rad + PI).rem_euclid(TAU) - PI
}

/// Wraps an angle in radians to `[0, 2π)`.
pub fn wrap_2pi(angle_rad: f64) -> f64 {
    let w = angle_rad.rem_euclid(TAU);
    // rem_euclid can round up to exactly TAU for tiny negative inputs.
    if w >= TAU { 0.0 } else { w }
}

/// Wraps an angle in degrees to `[-180, 180)`.
pub fn wrap_deg_180(angle_deg: f64) -> f64 {
    (angle_deg + 180.0).rem_euclid(360.0) - 180.0
}

/// Wraps an angle in degrees to `[0, 360)`.
pub fn wrap_deg_360(angle_deg: f64) -> f64 {
    let w = angle_deg.rem_euclid(360.0);
    if w >= 360.0 { 0.0 } else { w }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wraps_to_the_short_way() {
        assert!((wrap_deg_180(1.0 - 359.0) - 2.0).abs() < 1e-12);
        assert!((wrap_deg_180(359.0 - 1.0) + 2.0).abs() < 1e-12);
        assert!((wrap_pi(3.0 * PI) + PI).abs() < 1e-12);
        assert!((wrap_deg_360(-1.0) - 359.0).abs() < 1e-12);
        assert!(wrap_2pi(-1e-18) < TAU);
        assert!(wrap_deg_360(-1e-15) < 360.0);
        assert!(wrap_pi(f64::NAN).is_nan());
    }
}
