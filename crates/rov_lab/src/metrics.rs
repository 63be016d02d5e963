//! Error metrics per channel: fit % (MATLAB `compare`: 100·(1 − ‖y − ŷ‖/‖y − ȳ‖)) and
//! RMSE from [`rov_types::fit`] (the one implementation; heading and roll errors wrapped
//! to ±180°), and beside them max |e|, bias (mean e) and drift rate (least-squares slope
//! of e(t)), with e = ŷ − y. The lab's layer on top is the noise-floor gate: fit % is left
//! out (`None`) when the measured channel barely moves (‖y − ȳ‖ below 3 noise floors per
//! sample): report RMSE then.

use rov_dynamics::models::Channel;
use rov_types::fit::{ErrorKind, fit, fit_pooled};
use serde::Serialize;

use crate::data::{Run, ch_index, ch_wraps, wrap180};
use crate::sim::Prediction;

/// Metrics of one channel over a stretch of samples.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ChannelMetrics {
    /// Fit %, or `None` when the reference barely moves (low excitation).
    pub fit_pct: Option<f64>,
    /// Root-mean-square error.
    pub rmse: f64,
    /// Largest |error|.
    pub max_abs: f64,
    /// Mean error (model − measured).
    pub bias: f64,
    /// Slope of the error in time, units per second.
    pub drift_per_s: f64,
    /// Samples used.
    pub n: usize,
}

/// The residual e = ŷ − y of a channel at sample k (NaN when either is missing).
#[inline]
pub fn residual(ch: Channel, y: f64, yhat: f64) -> f64 {
    let e = yhat - y;
    if ch_wraps(ch) { wrap180(e) } else { e }
}

/// How [`rov_types::fit`] forms a channel's error.
pub fn error_kind(ch: Channel) -> ErrorKind {
    ErrorKind::angular_if(ch_wraps(ch))
}

/// Residuals of a channel over a run.
pub fn residuals(run: &Run, pred: &Prediction, ch: Channel) -> Option<Vec<f64>> {
    let y = run.channel(ch)?;
    let p = pred.channel(ch)?;
    Some(y.iter().zip(p).map(|(a, b)| residual(ch, *a, *b)).collect())
}

/// (measured, predicted) pairs and the sample index of each.
type Pairs = (Vec<(f64, f64)>, Vec<usize>);

/// The (measured, predicted) pairs of a channel over samples `range` where both are
/// finite, with the sample indices.
fn finite_pairs(
    run: &Run,
    pred: &Prediction,
    ch: Channel,
    range: std::ops::Range<usize>,
) -> Option<Pairs> {
    let y = run.channel(ch)?;
    let p = pred.channel(ch)?;
    let (mut pairs, mut idx) = (Vec::new(), Vec::new());
    for k in range {
        let (Some(yk), Some(pk)) = (y.get(k), p.get(k)) else {
            continue;
        };
        if yk.is_finite() && pk.is_finite() {
            pairs.push((*yk, *pk));
            idx.push(k);
        }
    }
    Some((pairs, idx))
}

/// The noise-floor gate: whether the measurement moves enough (‖y − ȳ‖ above 3 noise
/// floors per √sample) for fit % to mean something.
fn excited(pairs: &[(f64, f64)], noise: f64) -> bool {
    let n = pairs.len();
    if n == 0 {
        return false;
    }
    let mean = pairs.iter().map(|(y, _)| y).sum::<f64>() / n as f64;
    let dev2: f64 = pairs.iter().map(|(y, _)| (y - mean) * (y - mean)).sum();
    dev2 > 0.0 && dev2.sqrt() > 3.0 * noise * (n as f64).sqrt()
}

/// Metrics over samples `range` of a run.
pub fn channel_metrics_range(
    run: &Run,
    pred: &Prediction,
    ch: Channel,
    range: std::ops::Range<usize>,
) -> Option<ChannelMetrics> {
    let (pairs, idx) = finite_pairs(run, pred, ch, range.clone())?;
    let core = fit(&pairs, error_kind(ch));
    let rmse = core.rmse?;
    let n = core.samples;
    let noise = run.noise[ch_index(ch)];
    let fit_pct = core.fit_pct.filter(|_| excited(&pairs, noise));
    // The lab's further numbers on the residual e = ŷ − y.
    let (mut max_abs, mut sum_e) = (0.0f64, 0.0);
    let (mut st, mut stt, mut ste) = (0.0, 0.0, 0.0);
    let t0 = run.t.get(range.start).copied().unwrap_or(0.0);
    for ((y, yh), k) in pairs.iter().zip(&idx) {
        let e = residual(ch, *y, *yh);
        let t = run.t[*k] - t0;
        sum_e += e;
        max_abs = max_abs.max(e.abs());
        st += t;
        stt += t * t;
        ste += t * e;
    }
    let nf = n as f64;
    let denom = stt - st * st / nf;
    let drift = if denom > 1e-12 {
        (ste - st * sum_e / nf) / denom
    } else {
        0.0
    };
    Some(ChannelMetrics {
        fit_pct,
        rmse,
        max_abs,
        bias: sum_e / nf,
        drift_per_s: drift,
        n,
    })
}

/// Metrics over a whole run.
pub fn channel_metrics(run: &Run, pred: &Prediction, ch: Channel) -> Option<ChannelMetrics> {
    channel_metrics_range(run, pred, ch, 0..run.len())
}

/// Pooled metrics over several runs: fit % and RMSE from [`rov_types::fit::fit_pooled`]
/// (each run's variation around its own mean), fit % shown when any run passes the
/// noise-floor gate.
pub fn pooled_metrics(items: &[(&Run, &Prediction)], ch: Channel) -> Option<ChannelMetrics> {
    let mut n = 0usize;
    let (mut sum_e, mut max_abs, mut drift_w) = (0.0, 0.0f64, 0.0);
    let mut any_fit = false;
    let mut stretches: Vec<Vec<(f64, f64)>> = Vec::new();
    for (run, pred) in items {
        let Some(m) = channel_metrics(run, pred, ch) else {
            continue;
        };
        let Some((pairs, _)) = finite_pairs(run, pred, ch, 0..run.len()) else {
            continue;
        };
        stretches.push(pairs);
        any_fit |= m.fit_pct.is_some();
        sum_e += m.bias * m.n as f64;
        max_abs = max_abs.max(m.max_abs);
        drift_w += m.drift_per_s * m.n as f64;
        n += m.n;
    }
    let core = fit_pooled(stretches.iter().map(Vec::as_slice), error_kind(ch));
    let rmse = core.rmse?;
    if n == 0 {
        return None;
    }
    let nf = n as f64;
    Some(ChannelMetrics {
        fit_pct: core.fit_pct.filter(|_| any_fit),
        rmse,
        max_abs,
        bias: sum_e / nf,
        drift_per_s: drift_w / nf,
        n,
    })
}

/// Sliding windows (`len_s` long, 50 % overlap) as sample ranges.
pub fn windows(run: &Run, len_s: f64) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let n = run.len();
    if n == 0 {
        return out;
    }
    let mut start = 0;
    while start < n {
        let t_end = run.t[start] + len_s;
        let mut end = start;
        while end < n && run.t[end] < t_end {
            end += 1;
        }
        if end - start >= 4 {
            out.push(start..end);
        }
        if end >= n {
            break;
        }
        let t_next = run.t[start] + len_s * 0.5;
        let mut s2 = start + 1;
        while s2 < n && run.t[s2] < t_next {
            s2 += 1;
        }
        start = s2;
    }
    out
}
