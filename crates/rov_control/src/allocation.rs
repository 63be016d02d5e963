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
//! [`allocate`] works in percent, which is exact for a linear thrust map and for pure yaw
//! or pure surge. With both at once and a quadratic map it is not: the moment a
//! differential of `d` % produces grows with the common mode (model3 at 50 % surge: ten
//! times the moment of `d` alone for a small `d`), so the heading loop's gain multiplied
//! with the pilot's forward stick and the hold limit-cycled at ~3.7 Hz against the
//! output slew limit while surging (issue 25). [`allocate_in_force`] is what the
//! controller uses: the yaw demand becomes the force difference it stands for on the
//! control plant's thrust map, that difference is split evenly about each thruster's
//! surge force, and each thruster's command is that force through its own inverse map
//! (dead zone included). The same priority holds: when a thruster would pass the limit
//! the surge is scaled down (bisection on the common mode) until both fit.

use crate::feedforward::{DEAD_ZONE_BLEND_PCT, FeedforwardModel, PlantModel};

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

/// Allocates `demand` in force on the control plant's thrust maps (see the module
/// documentation): `yaw_pct` is a pure-differential demand (what
/// [`FeedforwardModel::differential_pct_for_moment`] returns) and is kept as the yaw
/// moment it produces, whatever the surge; `surge_pct` is the command both horizontal
/// thrusters get without yaw. Falls back to [`allocate`] if the plant cannot produce the
/// moment even with no surge (an asymmetric map at the limit).
pub fn allocate_in_force(demand: ThrustDemand, limit_pct: f64, plant: &PlantModel) -> Allocation {
    let pct_alloc = allocate(demand, limit_pct);
    if pct_alloc.non_finite_demand {
        return pct_alloc;
    }
    let limit = limit_pct.clamp(0.0, 100.0);
    let yaw_c = demand.yaw_pct.clamp(-limit, limit);
    let surge_c = demand.surge_pct.clamp(-limit, limit);
    let half_diff_n = 0.5 * plant.yaw_moment_for_pct(yaw_c, -yaw_c) / plant.yaw_arm_m;
    // Port and starboard commands for the surge scaled by `s`, if both are within limit.
    let pair = |s: f64| -> Option<(f64, f64)> {
        let sp = s * surge_c;
        let fp = plant
            .port
            .force_n_clamped(plant.port_path.through_dead_zone(sp))
            + half_diff_n;
        let fs = plant
            .starboard
            .force_n_clamped(plant.starboard_path.through_dead_zone(sp))
            - half_diff_n;
        let ip = plant.port.inverse(fp);
        let is = plant.starboard.inverse(fs);
        let pp = plant
            .port_path
            .before_dead_zone(ip.pct, DEAD_ZONE_BLEND_PCT);
        let ps = plant
            .starboard_path
            .before_dead_zone(is.pct, DEAD_ZONE_BLEND_PCT);
        let within = |p: f64| p.is_finite() && p.abs() <= limit + 1e-9;
        (!ip.saturated && !is.saturated && within(pp) && within(ps)).then_some((pp, ps))
    };
    let (scale, (port, starboard)) = match pair(1.0) {
        Some(p) => (1.0, p),
        None => {
            let Some(at_zero) = pair(0.0) else {
                return pct_alloc;
            };
            // Largest feasible common mode: 30 halvings resolve it to 1e-9 of the demand.
            let (mut lo, mut hi, mut best) = (0.0, 1.0, at_zero);
            for _ in 0..30 {
                let mid = 0.5 * (lo + hi);
                match pair(mid) {
                    Some(p) => {
                        lo = mid;
                        best = p;
                    }
                    None => hi = mid,
                }
            }
            (lo, best)
        }
    };
    Allocation {
        port_pct: port.clamp(-limit, limit),
        starboard_pct: starboard.clamp(-limit, limit),
        surge_reduced: scale < 1.0 || surge_c != demand.surge_pct,
        ..pct_alloc
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
