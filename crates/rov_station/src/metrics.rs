//! Step-response metrics of a hold run, exactly as `topside hold` reports them.
//!
//! All metrics use the TRUE state from the simulator, never the noisy measurements:
//! * `settle_s`: time from the start until the true value enters the band and stays
//!   there for the rest of the run (band: 2 % of the step for depth, ±1° for heading);
//!   `None` if it never settles.
//! * overshoot: the largest true excursion past the target in the direction of the step
//!   (depth in % of the step size, heading in degrees); 0 when it never passes.
//! * steady error: the mean true error over the last 10 s (absolute value of the mean).
//! * RMSE over the whole run ([`rov_types::fit`]).

use rov_types::fit::{ErrorKind, rms, rmse};
use serde::Serialize;

/// Length of the steady-state window at the end of a run, s.
pub const STEADY_WINDOW_S: f64 = 10.0;

/// Wraps an angle difference to (−180, 180] degrees: the hold reports' convention,
/// [`rov_types::angle::wrap_deg_180_incl`].
pub use rov_types::angle::wrap_deg_180_incl as wrap_deg;

/// One channel's step metrics.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StepMetrics {
    /// Settling time, s (None: never settled).
    pub settle_s: Option<f64>,
    /// Overshoot: % of the step (depth) or degrees (heading).
    pub overshoot: f64,
    /// |mean error| over the last 10 s, m or degrees.
    pub steady_error: f64,
    /// RMSE over the run, m or degrees.
    pub rmse: f64,
}

/// Metrics of a step from `start` to `target` given samples `(t_s, value)` with t from 0.
///
/// `angular` wraps errors to ±180° (heading); then the step is the wrapped difference,
/// `band` is absolute (degrees) and overshoot is reported in degrees. Otherwise `band`
/// is a fraction of the step size and overshoot is in % of the step.
pub fn step_metrics(
    samples: &[(f64, f64)],
    start: f64,
    target: f64,
    angular: bool,
    band: f64,
) -> StepMetrics {
    let err = |v: f64| {
        if angular {
            wrap_deg(v - target)
        } else {
            v - target
        }
    };
    let step = if angular {
        wrap_deg(target - start)
    } else {
        target - start
    };
    let dir = if step >= 0.0 { 1.0 } else { -1.0 };
    let band_abs = if angular {
        band
    } else {
        (band * step.abs()).max(1e-9)
    };
    let finite: Vec<(f64, f64)> = samples
        .iter()
        .copied()
        .filter(|(t, v)| t.is_finite() && v.is_finite())
        .collect();

    // Settling: the last sample outside the band; settled from the next sample on.
    let mut settle_s = Some(0.0);
    for (i, (_, v)) in finite.iter().enumerate() {
        if err(*v).abs() > band_abs {
            settle_s = finite.get(i + 1).map(|(t, _)| *t);
        }
    }
    // Overshoot: the largest excursion past the target in the direction of the step.
    let past = finite
        .iter()
        .map(|(_, v)| dir * err(*v))
        .fold(0.0_f64, f64::max);
    let overshoot = if angular {
        past
    } else if step.abs() > 1e-12 {
        100.0 * past / step.abs()
    } else {
        0.0
    };
    let t_end = finite.last().map(|(t, _)| *t).unwrap_or(0.0);
    let tail: Vec<f64> = finite
        .iter()
        .filter(|(t, _)| *t >= t_end - STEADY_WINDOW_S)
        .map(|(_, v)| err(*v))
        .collect();
    let steady_error = if tail.is_empty() {
        f64::NAN
    } else {
        (tail.iter().sum::<f64>() / tail.len() as f64).abs()
    };
    let rmse = rms(finite.iter().map(|(_, v)| err(*v))).unwrap_or(f64::NAN);
    StepMetrics {
        settle_s,
        overshoot,
        steady_error,
        rmse,
    }
}

/// RMSE between two aligned series (optionally wrapped in degrees); NaN pairs skipped;
/// NaN when no pair is finite (the report's field stays a number). Computed by
/// [`rov_types::fit::rmse`].
pub fn rmse_between(a: &[f64], b: &[f64], angular: bool) -> f64 {
    rmse(a, b, ErrorKind::angular_if(angular)).unwrap_or(f64::NAN)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_order_step_settles_where_expected() {
        // x(t) = 2 (1 - exp(-t/τ)), τ = 1 s: within 2 % after τ·ln(50) = 3.91 s.
        let s: Vec<(f64, f64)> = (0..=3000)
            .map(|k| {
                let t = k as f64 * 0.01;
                (t, 2.0 * (1.0 - (-t).exp()))
            })
            .collect();
        let m = step_metrics(&s, 0.0, 2.0, false, 0.02);
        let settle = m.settle_s.unwrap();
        assert!((settle - 50f64.ln()).abs() < 0.02, "{settle}");
        assert_eq!(m.overshoot, 0.0);
        assert!(m.steady_error < 1e-4);
    }

    #[test]
    fn overshoot_in_step_direction_only() {
        // Step down from 5 to 3: a dip to 2.8 is 10 % overshoot; values above 5 are not.
        let s = vec![(0.0, 5.2), (1.0, 4.0), (2.0, 2.8), (3.0, 3.0), (15.0, 3.0)];
        let m = step_metrics(&s, 5.0, 3.0, false, 0.02);
        assert!((m.overshoot - 10.0).abs() < 1e-9, "{}", m.overshoot);
        assert_eq!(m.settle_s, Some(3.0));
    }

    #[test]
    fn heading_wraps_through_north() {
        // 350 -> 10 (a +20 step through north), overshooting to 13.
        let s = vec![
            (0.0, 350.0),
            (1.0, 0.0),
            (2.0, 13.0),
            (3.0, 10.5),
            (20.0, 10.2),
        ];
        let m = step_metrics(&s, 350.0, 10.0, true, 1.0);
        assert!((m.overshoot - 3.0).abs() < 1e-9, "{}", m.overshoot);
        assert_eq!(m.settle_s, Some(3.0));
        assert!((wrap_deg(359.0 - 1.0) - -2.0).abs() < 1e-12);
        assert_eq!(wrap_deg(180.0), 180.0);
        assert_eq!(wrap_deg(-180.0), 180.0);
    }

    #[test]
    fn never_settling_is_none() {
        let s: Vec<(f64, f64)> = (0..100)
            .map(|k| (k as f64, if k % 2 == 0 { 0.0 } else { 2.0 }))
            .collect();
        assert_eq!(step_metrics(&s, 0.0, 1.0, false, 0.02).settle_s, None);
    }
}
