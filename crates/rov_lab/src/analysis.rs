//! "Where it fails": residuals binned by thruster, command sign and level, by segment
//! type and by state; residual autocorrelation and cross-correlation with each input
//! (with confidence bounds); the worst windows with their time ranges.
//!
//! Confidence bounds: autocorrelation ±z/√N (99 %, z = 2.58). For the cross-correlation
//! of a coloured residual with a coloured input the variance of the estimate is
//! Σ_k ρ_e(k) ρ_u(k) / N (Bartlett), so the bound is z·sqrt(1 + 2 Σ_{k≥1} ρ_e(k) ρ_u(k))/√N
//! (truncated at the lag range); a positive-lag peak means input dynamics the model lacks.

use rov_dynamics::models::Channel;
use serde::Serialize;

use crate::data::{Run, SegmentKind, ch_name};
use crate::metrics::{ChannelMetrics, channel_metrics_range, residuals, windows};
use crate::sim::Prediction;

/// 99 % normal quantile.
pub const Z99: f64 = 2.576;

/// The noise floor that quantisation alone sets on a signal recorded on a lattice: q/√12
/// for a lattice step q (the variance of a uniform error over one step, the standard
/// model of a quantiser's error), or 0 when the signal is not on a lattice.
///
/// The step is the smallest non-zero change between successive finite samples; the
/// signal is on that lattice when at least 95 % of its non-zero changes (at least 20 of
/// them) are whole multiples of it (to 10⁻³ of a step). A held signal read through a
/// 1 mbar pressure sensor changes by whole centimetre steps or not at all: its third
/// differences are mostly zero and estimate almost no noise, yet a model can predict it
/// no better than to within q/√12 (Widrow's quantisation noise).
pub fn quantisation_floor(v: &[f64]) -> f64 {
    let big = v
        .iter()
        .filter(|x| x.is_finite())
        .fold(0.0f64, |m, x| m.max(x.abs()));
    let tiny = 1e-9 * big.max(1e-300);
    let d: Vec<f64> = v
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|x| x.is_finite() && *x > tiny)
        .collect();
    if d.len() < 20 {
        return 0.0;
    }
    let q = d.iter().copied().fold(f64::INFINITY, f64::min);
    let on = d
        .iter()
        .filter(|x| {
            let m = *x / q;
            (m - m.round()).abs() <= 1e-3
        })
        .count();
    if on as f64 >= 0.95 * d.len() as f64 {
        q / 12f64.sqrt()
    } else {
        0.0
    }
}

/// Mean residual in one bin with its 95 % interval.
#[derive(Debug, Clone, Serialize)]
pub struct Bin {
    /// Bin label, e.g. "vertical -60 %".
    pub label: String,
    /// Samples.
    pub n: usize,
    /// Mean residual (model − measured).
    pub mean: f64,
    /// Half-width of the 95 % interval (white-noise approximation within the bin).
    pub ci95: f64,
    /// RMS residual.
    pub rms: f64,
}

/// Correlation function with its bound.
#[derive(Debug, Clone, Serialize)]
pub struct Correlation {
    /// What is correlated ("residual" or an input name).
    pub with: String,
    /// Lags in samples (−L..=L for cross-correlation, 0..=L for autocorrelation).
    pub lags: Vec<i64>,
    /// Normalised correlation per lag.
    pub values: Vec<f64>,
    /// 99 % insignificance bound.
    pub bound: f64,
    /// Lags outside the bound.
    pub significant_lags: Vec<i64>,
}

/// A window with its metrics.
#[derive(Debug, Clone, Serialize)]
pub struct WorstWindow {
    /// Run.
    pub run: String,
    /// Start, s.
    pub t_start_s: f64,
    /// End, s.
    pub t_end_s: f64,
    /// RMSE in the window.
    pub rmse: f64,
    /// Bias in the window.
    pub bias: f64,
}

/// Failure views of one channel.
#[derive(Debug, Clone, Serialize)]
pub struct ChannelFailure {
    /// Channel.
    pub channel: String,
    /// Bins by thruster, sign and level (e.g. "vertical +90 %").
    pub by_command: Vec<Bin>,
    /// Bins by segment type.
    pub by_segment: Vec<Bin>,
    /// Bins by state (depth, heading sector, pitch and roll sign).
    pub by_state: Vec<Bin>,
    /// Residual autocorrelation.
    pub autocorrelation: Correlation,
    /// Cross-correlation with each thruster command.
    pub cross_correlation: Vec<Correlation>,
    /// Worst 10 s windows.
    pub worst_windows: Vec<WorstWindow>,
    /// Whiteness: fraction of autocorrelation lags (1..L) outside the bound.
    pub autocorrelation_outside: f64,
}

fn bin_of(label: String, vals: &[f64]) -> Option<Bin> {
    let v: Vec<f64> = vals.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    Some(Bin {
        label,
        n: v.len(),
        mean,
        ci95: 1.96 * (var / n).sqrt(),
        rms: (v.iter().map(|x| x * x).sum::<f64>() / n).sqrt(),
    })
}

/// Σ_k a_k b_{k−lag} / n over the overlap (n the shorter length), with missing samples
/// already set to 0 by [`normalised`] (they add nothing, exactly as if skipped).
fn corr(a: &[f64], b: &[f64], lag: i64) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let l = lag.unsigned_abs().min(n as u64) as usize;
    // k − lag ∈ [0, n): for lag ≥ 0, k ∈ [lag, n) against b[0..]; else k ∈ [0, n − |lag|)
    // against b[|lag|..].
    let (x, y) = if lag >= 0 {
        (&a[l..], &b[..n - l])
    } else {
        (&a[..n - l], &b[l..])
    };
    let mut s = 0.0;
    for (p, q) in x.iter().zip(y) {
        s += p * q;
    }
    if n == 0 { 0.0 } else { s / n as f64 }
}

/// A signal normalised to zero mean and unit variance over its finite samples, with its
/// missing (non-finite) samples set to 0 so that they add nothing to a lagged product sum
/// (the same sums as skipping them, bit for bit), and the number of finite samples.
fn normalised(v: &[f64]) -> (Vec<f64>, usize) {
    let f: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if f.is_empty() {
        return (vec![0.0; v.len()], 0);
    }
    let mean = f.iter().sum::<f64>() / f.len() as f64;
    let sd = (f.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / f.len() as f64)
        .sqrt()
        .max(1e-300);
    let mut finite = 0;
    let z = v
        .iter()
        .map(|x| {
            let z = (x - mean) / sd;
            if z.is_finite() {
                finite += 1;
                z
            } else {
                0.0
            }
        })
        .collect();
    (z, finite)
}

/// Autocorrelation of a residual up to `max_lag`.
pub fn autocorrelation(e: &[f64], max_lag: usize) -> Correlation {
    let (z, finite) = normalised(e);
    let n = finite.max(1) as f64;
    let lags: Vec<i64> = (0..=max_lag as i64).collect();
    let values: Vec<f64> = lags.iter().map(|l| corr(&z, &z, *l)).collect();
    let bound = Z99 / n.sqrt();
    let significant_lags = lags
        .iter()
        .zip(&values)
        .filter(|(l, v)| **l > 0 && v.abs() > bound)
        .map(|(l, _)| *l)
        .collect();
    Correlation {
        with: "residual".into(),
        lags,
        values,
        bound,
        significant_lags,
    }
}

/// Cross-correlation of residual and input, lags −L..=L (positive: input leads).
pub fn cross_correlation(e: &[f64], u: &[f64], max_lag: usize, name: &str) -> Correlation {
    ResidualAcf::new(e, max_lag).cross_correlation(u, max_lag, name)
}

/// A residual normalised once, with its autocorrelation up to a lag, for
/// cross-correlating it with several signals (the Bartlett variance of every
/// cross-correlation needs the residual's autocorrelation: computed once, not once per
/// signal).
pub(crate) struct ResidualAcf {
    z: Vec<f64>,
    finite: usize,
    /// ρ_e(k) for k = 1..=L (index k − 1).
    acf: Vec<f64>,
}

impl ResidualAcf {
    /// The residual `e` with its autocorrelation up to `max_lag`.
    pub(crate) fn new(e: &[f64], max_lag: usize) -> Self {
        let (z, finite) = normalised(e);
        let acf = (1..=max_lag as i64).map(|k| corr(&z, &z, k)).collect();
        Self { z, finite, acf }
    }

    /// [`cross_correlation`] of the residual with `u`, lags −L..=L.
    pub(crate) fn cross_correlation(&self, u: &[f64], max_lag: usize, name: &str) -> Correlation {
        let ze = &self.z;
        let (zu, _) = normalised(u);
        let n = self.finite.max(1) as f64;
        let l = max_lag as i64;
        let lags: Vec<i64> = (-l..=l).collect();
        let values: Vec<f64> = lags.iter().map(|k| corr(ze, &zu, *k)).collect();
        // Bartlett variance for coloured signals.
        let mut s = 1.0;
        for k in 1..=l {
            let re = match self.acf.get(k as usize - 1) {
                Some(v) => *v,
                None => corr(ze, ze, k),
            };
            s += 2.0 * re * corr(&zu, &zu, k);
        }
        let bound = Z99 * s.max(1.0).sqrt() / n.sqrt();
        let significant_lags = lags
            .iter()
            .zip(&values)
            .filter(|(_, v)| v.abs() > bound)
            .map(|(l, _)| *l)
            .collect();
        Correlation {
            with: name.into(),
            lags,
            values,
            bound,
            significant_lags,
        }
    }
}

/// Failure views of one channel over runs (residuals from `preds`, same order).
pub fn channel_failure(runs: &[Run], preds: &[Prediction], ch: Channel) -> Option<ChannelFailure> {
    let mut by_cmd: std::collections::BTreeMap<String, Vec<f64>> = Default::default();
    let mut by_seg: std::collections::BTreeMap<String, Vec<f64>> = Default::default();
    let mut by_state: std::collections::BTreeMap<String, Vec<f64>> = Default::default();
    let mut all_e: Vec<f64> = Vec::new();
    let mut inputs: [Vec<f64>; 3] = Default::default();
    let mut worst: Vec<WorstWindow> = Vec::new();
    let dt = runs.first().map_or(0.05, |r| r.median_dt());
    for (run, pred) in runs.iter().zip(preds) {
        let Some(e) = residuals(run, pred, ch) else {
            continue;
        };
        for seg in &run.segments {
            let slice = &e[seg.start..seg.end];
            by_seg
                .entry(seg.kind.name().to_string())
                .or_default()
                .extend_from_slice(slice);
            let c = seg.cmd;
            for (name, u) in [
                ("port", c.port),
                ("starboard", c.starboard),
                ("vertical", c.vertical),
            ] {
                if u.abs() >= 0.5 {
                    let lvl = (u / 15.0).round() * 15.0;
                    by_cmd
                        .entry(format!("{name} {lvl:+.0} %"))
                        .or_default()
                        .extend_from_slice(slice);
                }
            }
            if seg.kind == SegmentKind::Rest {
                by_cmd
                    .entry("all off".into())
                    .or_default()
                    .extend_from_slice(slice);
            }
        }
        let y = |c: Channel| run.channel(c);
        for k in 0..run.len() {
            if let Some(d) = y(Channel::Depth) {
                let b = (d[k] / 2.0).floor() * 2.0;
                if b.is_finite() {
                    by_state
                        .entry(format!("depth {b:.0}..{:.0} m", b + 2.0))
                        .or_default()
                        .push(e[k]);
                }
            }
            if let Some(h) = y(Channel::Heading) {
                let sector = ((h[k].rem_euclid(360.0)) / 45.0).floor() * 45.0;
                if sector.is_finite() {
                    by_state
                        .entry(format!("heading {sector:03.0}..{:03.0}°", sector + 45.0))
                        .or_default()
                        .push(e[k]);
                }
            }
            for (c, name) in [(Channel::Pitch, "pitch"), (Channel::Roll, "roll")] {
                if let Some(v) = y(c) {
                    let lab = if v[k] > 2.0 {
                        format!("{name} > +2°")
                    } else if v[k] < -2.0 {
                        format!("{name} < −2°")
                    } else {
                        format!("{name} level")
                    };
                    if v[k].is_finite() {
                        by_state.entry(lab).or_default().push(e[k]);
                    }
                }
            }
        }
        all_e.extend_from_slice(&e);
        for (i, u) in inputs.iter_mut().enumerate() {
            u.extend(run.cmd.iter().map(|c| match i {
                0 => c.port,
                1 => c.starboard,
                _ => c.vertical,
            }));
        }
        for w in windows(run, 10.0) {
            if let Some(m) = channel_metrics_range(run, pred, ch, w.clone()) {
                worst.push(WorstWindow {
                    run: run.name.clone(),
                    t_start_s: run.t[w.start],
                    t_end_s: run.t[w.end - 1],
                    rmse: m.rmse,
                    bias: m.bias,
                });
            }
        }
    }
    if all_e.is_empty() {
        return None;
    }
    worst.sort_by(|a, b| b.rmse.total_cmp(&a.rmse));
    worst.truncate(5);
    let max_lag = ((5.0 / dt).round() as usize).clamp(5, 100);
    let autocorrelation = autocorrelation(&all_e, max_lag);
    let outside = autocorrelation.significant_lags.len() as f64 / max_lag as f64;
    let acf = ResidualAcf::new(&all_e, max_lag);
    let cross = ["port", "starboard", "vertical"]
        .iter()
        .enumerate()
        .map(|(i, n)| acf.cross_correlation(&inputs[i], max_lag, n))
        .collect();
    let to_bins = |m: std::collections::BTreeMap<String, Vec<f64>>| -> Vec<Bin> {
        m.into_iter().filter_map(|(k, v)| bin_of(k, &v)).collect()
    };
    Some(ChannelFailure {
        channel: ch_name(ch).to_string(),
        by_command: to_bins(by_cmd),
        by_segment: to_bins(by_seg),
        by_state: to_bins(by_state),
        autocorrelation,
        cross_correlation: cross,
        worst_windows: worst,
        autocorrelation_outside: outside,
    })
}

/// Metrics per segment of a run (segments of at least 2 s).
pub fn segment_metrics(
    run: &Run,
    pred: &Prediction,
    ch: Channel,
) -> Vec<(String, f64, f64, ChannelMetrics)> {
    run.segments
        .iter()
        .filter(|s| s.t_end_s - s.t_start_s >= 2.0)
        .filter_map(|s| {
            channel_metrics_range(run, pred, ch, s.start..s.end).map(|m| {
                (
                    format!("{} {:.0} %", s.kind.name(), s.level_pct),
                    s.t_start_s,
                    s.t_end_s,
                    m,
                )
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A coloured test signal with missing samples.
    fn gappy(n: usize, seed: f64) -> Vec<f64> {
        (0..n)
            .map(|k| {
                let t = k as f64;
                if k % 37 == 5 || k % 101 == 0 {
                    f64::NAN
                } else {
                    (0.05 * t + seed).sin() + 0.3 * (1.7 * t * seed).cos()
                }
            })
            .collect()
    }

    #[test]
    fn lagged_sums_over_zeroed_gaps_equal_those_skipping_them_bit_for_bit() {
        // The reference: the sum over the overlap skipping any pair with a missing sample.
        let skip = |a: &[f64], b: &[f64], lag: i64| -> f64 {
            let n = a.len().min(b.len()) as i64;
            let mut s = 0.0;
            for k in 0..n {
                let j = k - lag;
                if j >= 0 && j < n && a[k as usize].is_finite() && b[j as usize].is_finite() {
                    s += a[k as usize] * b[j as usize];
                }
            }
            s / n as f64
        };
        let (a, b) = (gappy(500, 0.3), gappy(480, 1.1));
        let norm = |v: &[f64]| -> Vec<f64> {
            let f: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
            let m = f.iter().sum::<f64>() / f.len() as f64;
            let sd = (f.iter().map(|x| (x - m).powi(2)).sum::<f64>() / f.len() as f64).sqrt();
            v.iter().map(|x| (x - m) / sd).collect()
        };
        let (na, nb) = (norm(&a), norm(&b));
        let ((za, fa), (zb, _)) = (normalised(&a), normalised(&b));
        assert_eq!(fa, a.iter().filter(|x| x.is_finite()).count());
        for lag in -600..=600 {
            assert_eq!(
                corr(&za, &zb, lag).to_bits(),
                skip(&na, &nb, lag).to_bits(),
                "lag {lag}"
            );
        }
    }

    #[test]
    fn quantisation_floor_of_a_lattice_and_of_a_continuous_signal() {
        // A held depth read in 1.02 cm steps (1 mbar): mostly unchanged, a few steps.
        let q = 0.0102;
        let held: Vec<f64> = (0..600)
            .map(|k| q * (200.0 + ((k as f64 * 0.37).sin() * 1.4).round()))
            .collect();
        let f = quantisation_floor(&held);
        assert!((f - q / 12f64.sqrt()).abs() < 1e-9, "{f}");
        // A continuous signal is on no lattice.
        let smooth: Vec<f64> = (0..600).map(|k| 2.0 + (k as f64 * 0.01).sin()).collect();
        assert_eq!(quantisation_floor(&smooth), 0.0);
        // Too few changes to tell.
        assert_eq!(quantisation_floor(&[1.0, 1.0, 2.0, 2.0]), 0.0);
    }
}
