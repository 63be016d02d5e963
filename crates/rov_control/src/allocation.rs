//! Thrust allocation for the Pro 4's three thrusters.
//!
//! Demands are in percent of full thrust: surge (common mode of the horizontal pair),
//! yaw (differential mode: port = +yaw, starboard = −yaw, so positive yaw turns to
//! starboard) and vertical (positive pushes down). Then
//!
//! ```text
//! port      = surge + yaw
//! starboard = surge − yaw
//! vertical  = vertical
//! ```
//!
//! **Saturation priority (yaw over surge).** When `|surge| + |yaw|` exceeds the limit,
//! the yaw demand is kept (clamped only to the limit by itself) and the surge demand is
//! reduced until both horizontal thrusters are within the limit. Heading authority is
//! therefore never traded for speed: a pilot who drives full ahead while the heading hold
//! corrects still gets the full correction, and only the forward speed drops. The
//! vertical thruster is independent and only clamped.
//!
//! The allocation is done in percent, which is exact for a linear thrust map and for
//! pure yaw or pure surge with a quadratic one; with both at once a quadratic map makes
//! the produced moment somewhat larger than the differential map predicts, which the
//! heading feedback absorbs.

/// Demands in percent.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ThrustDemand {
    /// Surge (common mode), %; positive forward.
    pub surge_pct: f64,
    /// Yaw (differential mode), %; positive turns to starboard (port above starboard).
    pub yaw_pct: f64,
    /// Vertical, %; positive pushes down.
    pub vertical_pct: f64,
}

/// The allocated thruster commands (not yet guarded) and what was limited.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Allocation {
    /// Port thruster, %.
    pub port_pct: f64,
    /// Starboard thruster, %.
    pub starboard_pct: f64,
    /// Vertical thruster, %.
    pub vertical_pct: f64,
    /// Surge was reduced to keep the yaw demand.
    pub surge_reduced: bool,
    /// The yaw demand alone exceeded the limit and was clamped.
    pub yaw_saturated: bool,
    /// The vertical demand was clamped.
    pub vertical_saturated: bool,
    /// A demand was non-finite and replaced by 0.
    pub non_finite_demand: bool,
}

/// Allocates `demand` with per-thruster limit `limit_pct` (clamped to 0..=100).
pub fn allocate(demand: ThrustDemand, limit_pct: f64) -> Allocation {
    let limit = if limit_pct.is_finite() {
        limit_pct.clamp(0.0, 100.0)
    } else {
        0.0
    };
    let mut non_finite = false;
    let mut clean = |v: f64| {
        if v.is_finite() {
            v
        } else {
            non_finite = true;
            0.0
        }
    };
    let surge = clean(demand.surge_pct);
    let yaw = clean(demand.yaw_pct);
    let vertical = clean(demand.vertical_pct);

    let yaw_c = yaw.clamp(-limit, limit);
    let room = limit - yaw_c.abs();
    let surge_c = surge.clamp(-room, room);
    let vertical_c = vertical.clamp(-limit, limit);
    Allocation {
        port_pct: surge_c + yaw_c,
        starboard_pct: surge_c - yaw_c,
        vertical_pct: vertical_c,
        surge_reduced: surge_c != surge,
        yaw_saturated: yaw_c != yaw,
        vertical_saturated: vertical_c != vertical,
        non_finite_demand: non_finite,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yaw_is_preserved_over_surge() {
        let a = allocate(
            ThrustDemand {
                surge_pct: 90.0,
                yaw_pct: 30.0,
                vertical_pct: 0.0,
            },
            100.0,
        );
        assert_eq!((a.port_pct, a.starboard_pct), (100.0, 40.0));
        assert!((a.port_pct - a.starboard_pct) / 2.0 == 30.0);
        assert!(a.surge_reduced && !a.yaw_saturated);

        let a = allocate(
            ThrustDemand {
                surge_pct: -100.0,
                yaw_pct: -60.0,
                vertical_pct: 0.0,
            },
            100.0,
        );
        assert_eq!((a.port_pct, a.starboard_pct), (-100.0, 20.0));
        assert!((a.port_pct - a.starboard_pct) / 2.0 == -60.0);

        // Yaw alone above the limit: pure rotation at the limit, no surge.
        let a = allocate(
            ThrustDemand {
                surge_pct: 50.0,
                yaw_pct: 150.0,
                vertical_pct: 0.0,
            },
            100.0,
        );
        assert_eq!((a.port_pct, a.starboard_pct), (100.0, -100.0));
        assert!(a.surge_reduced && a.yaw_saturated);
    }

    #[test]
    fn unsaturated_is_exact_and_limits_hold() {
        let a = allocate(
            ThrustDemand {
                surge_pct: 20.0,
                yaw_pct: -10.0,
                vertical_pct: -40.0,
            },
            100.0,
        );
        assert_eq!(
            (a.port_pct, a.starboard_pct, a.vertical_pct),
            (10.0, 30.0, -40.0)
        );
        assert!(!a.surge_reduced && !a.yaw_saturated && !a.vertical_saturated);
        let a = allocate(
            ThrustDemand {
                surge_pct: f64::NAN,
                yaw_pct: 1e300,
                vertical_pct: -1e300,
            },
            80.0,
        );
        assert!(a.non_finite_demand);
        assert_eq!(
            (a.port_pct, a.starboard_pct, a.vertical_pct),
            (80.0, -80.0, -80.0)
        );
    }
}
