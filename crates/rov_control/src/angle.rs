//! Angle helpers: the workspace's one implementation, [`rov_types::angle`], re-exported
//! under the names the controller has always used. Headings increase turning to
//! starboard (clockwise seen from above). Every function returns NaN for a non-finite
//! input; callers check finiteness first.
//!
//! * [`wrap_pi`]: signed difference, radians, `[−π, π)`;
//! * [`wrap_2pi`]: absolute angle, radians, `[0, 2π)`;
//! * [`wrap_deg_180`]: signed difference, degrees, `[−180, 180)`;
//! * [`wrap_deg_360`]: absolute angle, degrees, `[0, 360)`.

pub use rov_types::angle::{wrap_2pi, wrap_deg_180, wrap_deg_360, wrap_pi};
