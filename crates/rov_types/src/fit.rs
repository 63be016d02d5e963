//! Fit % and RMSE of a prediction against a measurement: the one implementation the
//! station, the session tools and the simulator's reports use.
//!
//! * RMSE = √(mean e²) over the pairs where both values are finite;
//! * fit % = 100 · (1 − ‖y − ŷ‖ / ‖y − ȳ‖) (the normalised RMSE fit: 100 is perfect,
//!   0 is no better than the measured mean, negative is worse), `None` when the
//!   measurement does not vary.
//!
//! For angles ([`ErrorKind::AngleDeg`]) the error `y − ŷ` is wrapped to `[−180, 180)`
//! ([`crate::angle::wrap_deg_180`]; the squared error does not depend on which signed
//! convention is used). `ȳ` and `‖y − ȳ‖` use the measured values as given, so a caller
//! computing fit % of a heading passes the measured trace unwrapped
//! ([`crate::angle::nearest_deg`]). Pure functions.

use crate::angle::wrap_deg_180;

/// How an error is formed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorKind {
    /// `y − ŷ`.
    Linear,
    /// `y − ŷ` wrapped to `[−180, 180)` degrees.
    AngleDeg,
}

impl ErrorKind {
    /// `Linear` or, when `angular`, `AngleDeg`.
    #[must_use]
    pub fn angular_if(angular: bool) -> Self {
        if angular {
            Self::AngleDeg
        } else {
            Self::Linear
        }
    }

    /// The error `y − ŷ` in this kind.
    #[must_use]
    pub fn error(self, y: f64, y_hat: f64) -> f64 {
        match self {
            Self::Linear => y - y_hat,
            Self::AngleDeg => wrap_deg_180(y - y_hat),
        }
    }
}

/// Fit of one channel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fit {
    /// Pairs used (both finite).
    pub samples: usize,
    /// RMSE, in the channel's unit (`None` without samples).
    pub rmse: Option<f64>,
    /// Fit %, `None` without samples or when the measurement is constant.
    pub fit_pct: Option<f64>,
}

#[must_use]
/// The median of `v` (sorted in place; the mean of the two middle values for an even
/// count); `None` when empty. NaN sorts last ([`f64::total_cmp`]): filter it first.
pub fn median(v: &mut [f64]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    let hi = v.get(n / 2).copied()?;
    Some(if n % 2 == 1 {
        hi
    } else {
        0.5 * (v.get(n / 2 - 1).copied()? + hi)
    })
}

/// Root mean square of the finite values (`None` if there are none).
#[must_use]
pub fn rms(values: impl IntoIterator<Item = f64>) -> Option<f64> {
    let (mut s, mut n) = (0.0, 0usize);
    for v in values {
        if v.is_finite() {
            s += v * v;
            n += 1;
        }
    }
    (n > 0).then(|| (s / n as f64).sqrt())
}

/// RMSE between two aligned series (pairs with a non-finite value skipped; the longer
/// series' tail is ignored).
#[must_use]
pub fn rmse(measured: &[f64], predicted: &[f64], kind: ErrorKind) -> Option<f64> {
    rms(measured
        .iter()
        .zip(predicted)
        .filter(|(y, p)| y.is_finite() && p.is_finite())
        .map(|(y, p)| kind.error(*y, *p)))
}

/// Fit % and RMSE of `(measured, predicted)` pairs; pairs with a non-finite value are
/// skipped.
#[must_use]
pub fn fit(pairs: &[(f64, f64)], kind: ErrorKind) -> Fit {
    fit_pooled([pairs], kind)
}

/// Fit % and RMSE pooled over several stretches (runs) of one channel: RMSE over all
/// finite pairs, fit % = 100 · (1 − √(Σ‖y − ŷ‖²) / √(Σ‖y − ȳ_run‖²)), each stretch's
/// deviation taken around its own mean ȳ_run (a run's offset is not variation the model
/// has to explain). One stretch gives exactly [`fit`].
#[must_use]
pub fn fit_pooled<'a>(
    stretches: impl IntoIterator<Item = &'a [(f64, f64)]>,
    kind: ErrorKind,
) -> Fit {
    let (mut err2, mut dev2, mut n) = (0.0, 0.0, 0usize);
    for pairs in stretches {
        let finite = || pairs.iter().filter(|(y, p)| y.is_finite() && p.is_finite());
        let m = finite().count();
        if m == 0 {
            continue;
        }
        let mean = finite().map(|(y, _)| y).sum::<f64>() / m as f64;
        for (y, p) in finite() {
            let e = kind.error(*y, *p);
            err2 += e * e;
            dev2 += (y - mean) * (y - mean);
        }
        n += m;
    }
    if n == 0 {
        return Fit {
            samples: 0,
            rmse: None,
            fit_pct: None,
        };
    }
    Fit {
        samples: n,
        rmse: Some((err2 / n as f64).sqrt()),
        fit_pct: (dev2 > 0.0).then(|| 100.0 * (1.0 - (err2 / dev2).sqrt())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perfect_and_mean_predictions() {
        let y: Vec<f64> = (0..50).map(|k| f64::from(k).sin()).collect();
        let pairs: Vec<(f64, f64)> = y.iter().map(|v| (*v, *v)).collect();
        let f = fit(&pairs, ErrorKind::Linear);
        assert_eq!((f.samples, f.rmse, f.fit_pct), (50, Some(0.0), Some(100.0)));
        let mean = y.iter().sum::<f64>() / 50.0;
        let pairs: Vec<(f64, f64)> = y.iter().map(|v| (*v, mean)).collect();
        let f = fit(&pairs, ErrorKind::Linear);
        assert!(f.fit_pct.unwrap().abs() < 1e-12, "{f:?}");
    }

    #[test]
    fn known_values_nan_skipping_and_constant_measurements() {
        // Errors 3 and 4: RMSE √12.5.
        assert_eq!(
            rmse(&[3.0, 4.0, f64::NAN], &[0.0, 0.0, 1.0], ErrorKind::Linear),
            Some(12.5f64.sqrt())
        );
        assert_eq!(rmse(&[f64::NAN], &[1.0], ErrorKind::Linear), None);
        assert_eq!(rms([f64::INFINITY, 2.0, -2.0]), Some(2.0));
        let f = fit(&[(1.0, 1.5), (1.0, 0.5)], ErrorKind::Linear);
        assert_eq!((f.rmse, f.fit_pct), (Some(0.5), None));
        assert_eq!(fit(&[], ErrorKind::Linear).rmse, None);
    }

    #[test]
    fn pooled_stretches_use_their_own_means() {
        // Two stretches offset by 10: pooled, the offset is not variation.
        let a = [(1.0, 1.5), (3.0, 2.5)];
        let b = [(11.0, 11.5), (13.0, 12.5)];
        let f = fit_pooled([&a[..], &b[..]], ErrorKind::Linear);
        assert_eq!((f.samples, f.rmse), (4, Some(0.5)));
        // Σe² = 1, Σ(y − ȳ_run)² = 4: fit 100 (1 − ½) = 50 %.
        assert_eq!(f.fit_pct, Some(50.0));
        assert_eq!(
            fit_pooled([&a[..]], ErrorKind::Linear),
            fit(&a, ErrorKind::Linear)
        );
        assert_eq!(fit_pooled([&[][..]], ErrorKind::Linear).rmse, None);
    }

    #[test]
    fn angular_errors_wrap_through_north() {
        // 359 vs 1 is a 2° error, not 358°.
        assert_eq!(
            rmse(&[359.0, 1.0], &[1.0, 359.0], ErrorKind::AngleDeg),
            Some(2.0)
        );
        assert_eq!(ErrorKind::angular_if(true).error(10.0, 350.0), 20.0);
        assert_eq!(ErrorKind::angular_if(false).error(10.0, 350.0), -340.0);
    }
}
