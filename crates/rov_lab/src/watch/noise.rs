//! The noise floor of each channel's residual, learned during the dive.
//!
//! For a channel and sub-window j the residual mean f_j is modelled as
//! f_j = μ_j + ε with ε ~ N(0, s₀² + κ²·a_j²): μ_j the model's steady offset, s₀ the floor
//! at rest (sensor noise and the window's start-state error), κ the model's relative
//! error, growing with the motion a_j it predicts. Fitted robustly (medians) from the hops
//! of a baseline: s₀ from the calmer half (by a), κ from the busier half.

use super::SUB;
use super::features::Hop;

/// Median of a χ²₁ variable: a median of squares over this is a variance.
const CHI2_1_MEDIAN: f64 = 0.455;

/// Predicted motion, in floors s₀, above which a sub-window informs the relative error.
const KAPPA_MIN_MOTION: f64 = 5.0;

/// The relative model error assumed where the dive cannot measure it (and the least
/// ever assumed): a calibrated model still errs by a few percent of what it predicts.
pub(crate) const KAPPA_PRIOR: f64 = 0.05;

/// The 90th percentile of |z| for a standard normal z.
const Z_Q90: f64 = 1.645;

/// Least hops for a fit.
pub(crate) const MIN_HOPS: usize = 10;

/// One channel's residual noise model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ChannelNoise {
    /// Median residual per sub-window.
    pub mu: [f64; SUB],
    /// Floor at rest (same unit as the channel).
    pub s0: f64,
    /// Relative model error per unit of predicted motion.
    pub kappa: f64,
    /// Share of baseline hops whose raw readings were frozen.
    pub frozen_share: f64,
    /// Hops the fit used.
    pub n: usize,
    /// The sensor's own floor the fit was given (the least s₀ allowed).
    pub sensor_floor: f64,
}

impl ChannelNoise {
    /// σ of a sub-window mean for a predicted motion `a`.
    pub fn sigma(&self, a: f64) -> f64 {
        let a = if a.is_finite() { a } else { 0.0 };
        (self.s0 * self.s0 + self.kappa * self.kappa * a * a).sqrt()
    }

    /// Normalised residual per sub-window (NaN where absent).
    pub fn zs(&self, f: &[f64; SUB], a: &[f64; SUB]) -> [f64; SUB] {
        std::array::from_fn(|j| (f[j] - self.mu[j]) / self.sigma(a[j]))
    }

    /// The combined statistic of a hop: Σ_j z_j / √SUB over the finite sub-windows.
    pub fn z(&self, f: &[f64; SUB], a: &[f64; SUB]) -> Option<f64> {
        let zs = self.zs(f, a);
        let fin: Vec<f64> = zs.into_iter().filter(|z| z.is_finite()).collect();
        if fin.is_empty() {
            return None;
        }
        Some(fin.iter().sum::<f64>() / (fin.len() as f64).sqrt())
    }

    /// Fits channel `i` from hops; `floor` is the smallest s₀ allowed. `None` with fewer
    /// than [`MIN_HOPS`] usable hops.
    pub fn fit(hops: &[&Hop], i: usize, floor: f64) -> Option<Self> {
        let usable: Vec<&&Hop> = hops
            .iter()
            .filter(|h| h.f.get(i).is_some_and(|f| f.iter().all(|x| x.is_finite())))
            .collect();
        if usable.len() < MIN_HOPS {
            return None;
        }
        let mut mu = [0.0; SUB];
        for (j, m) in mu.iter_mut().enumerate() {
            let mut v: Vec<f64> = usable.iter().map(|h| h.f[i][j]).collect();
            *m = median(&mut v).unwrap_or(0.0);
        }
        // (a, r²) pairs over every sub-window.
        let mut pairs: Vec<(f64, f64)> = usable
            .iter()
            .flat_map(|h| {
                (0..SUB).map(move |j| {
                    let a = h.a[i][j];
                    (
                        if a.is_finite() { a } else { 0.0 },
                        (h.f[i][j] - mu[j]).powi(2),
                    )
                })
            })
            .collect();
        pairs.sort_by(|x, y| x.0.total_cmp(&y.0));
        let half = pairs.len() / 2;
        let mut low: Vec<f64> = pairs.iter().take(half.max(1)).map(|p| p.1).collect();
        let s0 = (median(&mut low).unwrap_or(0.0) / CHI2_1_MEDIAN)
            .sqrt()
            .max(floor);
        // κ only from sub-windows whose predicted motion stands well above the floor:
        // where a ≈ s₀ the ratio is noise over a small number and says nothing of the
        // model's relative error. Too few such sub-windows: κ stays at its prior.
        let mut ratios: Vec<f64> = pairs
            .iter()
            .filter(|p| p.0 > KAPPA_MIN_MOTION * s0)
            .map(|p| ((p.1 / CHI2_1_MEDIAN - s0 * s0).max(0.0)) / (p.0 * p.0))
            .collect();
        let kappa = if ratios.len() >= MIN_HOPS {
            median(&mut ratios).unwrap_or(0.0).sqrt().max(KAPPA_PRIOR)
        } else {
            KAPPA_PRIOR
        };
        let frozen_share =
            usable.iter().filter(|h| h.frozen[i]).count() as f64 / usable.len() as f64;
        let mut fit = Self {
            mu,
            s0,
            kappa: if kappa.is_finite() { kappa } else { 0.0 },
            frozen_share,
            n: usable.len(),
            sensor_floor: floor,
        };
        // Calibration on the baseline itself: the model's errors are not Gaussian (a
        // turn it times a little wrong gives a run of large residuals). Where the
        // baseline's 90th percentile of |z| per sub-window exceeds the Gaussian's 1.645,
        // both s₀ and κ are widened by that ratio, so the dive's own tails are normal.
        let mut az: Vec<f64> = usable
            .iter()
            .flat_map(|h| fit.zs(&h.f[i], &h.a[i]))
            .filter(|z| z.is_finite())
            .map(f64::abs)
            .collect();
        az.sort_by(f64::total_cmp);
        let q90 = az
            .get((az.len() as f64 * 0.9) as usize)
            .copied()
            .unwrap_or(0.0);
        let inflate = (q90 / Z_Q90).max(1.0);
        if inflate.is_finite() {
            fit.s0 *= inflate;
            fit.kappa *= inflate;
        }
        Some(fit)
    }

    /// The larger of two fits, sub-window by sub-window for the offsets of `self`.
    pub fn at_least(self, other: &Self) -> Self {
        Self {
            s0: self.s0.max(other.s0),
            kappa: self.kappa.max(other.kappa),
            ..self
        }
    }
}

pub(crate) use rov_types::fit::median;

#[cfg(test)]
mod tests {
    use super::*;

    fn hop(f: f64, a: f64) -> Hop {
        Hop {
            t_s: 0.0,
            f: [[f; SUB]; 4],
            a: [[a; SUB]; 4],
            frozen: [false; 4],
            noise: [0.01; 4],
        }
    }

    #[test]
    fn fits_floor_and_relative_error() {
        // Residual ±0.01 at rest, ±(0.01 + 0.1·a) with motion.
        let mut hops = Vec::new();
        for k in 0..200 {
            let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
            let a: f64 = if k < 100 { 0.0 } else { 2.0 };
            let s = (0.01f64.powi(2) + (0.1 * a).powi(2)).sqrt();
            hops.push(hop(0.5 + sign * s * 0.6745, a));
        }
        let refs: Vec<&Hop> = hops.iter().collect();
        let n = ChannelNoise::fit(&refs, 0, 0.001).unwrap();
        assert!((n.mu[0] - 0.5).abs() < 0.05, "{n:?}");
        assert!(n.s0 > 0.005 && n.s0 < 0.03, "{n:?}");
        assert!(n.kappa > 0.05 && n.kappa < 0.2, "{n:?}");
        // A residual 10 σ off reads as such.
        let z = n.z(&[0.5 + 0.1; SUB], &[0.0; SUB]).unwrap();
        assert!(z > 5.0, "{z}");
        assert!(ChannelNoise::fit(&refs[..5], 0, 0.001).is_none());
    }
}
