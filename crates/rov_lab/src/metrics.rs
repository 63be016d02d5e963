//! Error metrics per channel: fit % (MATLAB `compare`: 100·(1 − ‖y − ŷ‖/‖y − ȳ‖)),
//! RMSE, max |e|, bias (mean e), drift rate (least-squares slope of e(t)), with e = ŷ − y
//! wrapped to ±180° for heading. Fit % is left out (`None`) when the measured channel
//! barely moves (‖y − ȳ‖ below 3 noise floors per sample): report RMSE then.

use rov_dynamics::models::Channel;
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

/// Residuals of a channel over a run.
pub fn residuals(run: &Run, pred: &Prediction, ch: Channel) -> Option<Vec<f64>> {
    let y = run.channel(ch)?;
    let p = pred.channel(ch)?;
    Some(y.iter().zip(p).map(|(a, b)| residual(ch, *a, *b)).collect())
}

/// Metrics over samples `range` of a run.
pub fn channel_metrics_range(
    run: &Run,
    pred: &Prediction,
    ch: Channel,
    range: std::ops::Range<usize>,
) -> Option<ChannelMetrics> {
    let y = run.channel(ch)?;
    let p = pred.channel(ch)?;
    let noise = run.noise[ch_index(ch)];
    let mut n = 0usize;
    let (mut se, mut sy, mut syy, mut max_abs, mut sum_e) = (0.0, 0.0, 0.0, 0.0f64, 0.0);
    let (mut st, mut stt, mut ste) = (0.0, 0.0, 0.0);
    let t0 = run.t.get(range.start).copied().unwrap_or(0.0);
    for k in range {
        let (Some(yk), Some(pk)) = (y.get(k), p.get(k)) else {
            continue;
        };
        if !(yk.is_finite() && pk.is_finite()) {
            continue;
        }
        let e = residual(ch, *yk, *pk);
        let t = run.t[k] - t0;
        n += 1;
        se += e * e;
        sum_e += e;
        max_abs = max_abs.max(e.abs());
        sy += yk;
        syy += yk * yk;
        st += t;
        stt += t * t;
        ste += t * e;
    }
    if n == 0 {
        return None;
    }
    let nf = n as f64;
    let var_y = (syy - sy * sy / nf).max(0.0);
    let fit_pct = (var_y.sqrt() > 3.0 * noise * nf.sqrt() && var_y > 0.0)
        .then(|| 100.0 * (1.0 - (se / var_y).sqrt()));
    let denom = stt - st * st / nf;
    let drift = if denom > 1e-12 {
        (ste - st * sum_e / nf) / denom
    } else {
        0.0
    };
    Some(ChannelMetrics {
        fit_pct,
        rmse: (se / nf).sqrt(),
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

/// Pooled metrics over several runs (fit % from the pooled sums).
pub fn pooled_metrics(items: &[(&Run, &Prediction)], ch: Channel) -> Option<ChannelMetrics> {
    let mut n = 0usize;
    let (mut se, mut sum_e, mut max_abs, mut ss_y, mut drift_w) = (0.0, 0.0, 0.0f64, 0.0, 0.0);
    let mut any_fit = false;
    for (run, pred) in items {
        let Some(m) = channel_metrics(run, pred, ch) else {
            continue;
        };
        let Some(y) = run.channel(ch) else { continue };
        let p = pred.channel(ch).unwrap_or(&[]);
        let vals: Vec<f64> = y
            .iter()
            .zip(p)
            .filter(|(a, b)| a.is_finite() && b.is_finite())
            .map(|(a, _)| *a)
            .collect();
        let mean = vals.iter().sum::<f64>() / vals.len().max(1) as f64;
        ss_y += vals.iter().map(|v| (v - mean).powi(2)).sum::<f64>();
        any_fit |= m.fit_pct.is_some();
        se += m.rmse * m.rmse * m.n as f64;
        sum_e += m.bias * m.n as f64;
        max_abs = max_abs.max(m.max_abs);
        drift_w += m.drift_per_s * m.n as f64;
        n += m.n;
    }
    if n == 0 {
        return None;
    }
    let nf = n as f64;
    Some(ChannelMetrics {
        fit_pct: (any_fit && ss_y > 0.0).then(|| 100.0 * (1.0 - (se / ss_y).sqrt())),
        rmse: (se / nf).sqrt(),
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
