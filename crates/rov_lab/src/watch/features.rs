//! Residual features of one hop: the model's short-window prediction for the commands
//! actually sent, against the measurement.
//!
//! A hop at time t takes the last `history_s` of rows as a lab [`Run`] (the lab's own
//! treatment: spikes excluded, readings smoothed for re-initialisation) and simulates it
//! with the lab's simulator ([`crate::sim::simulate_run`]) re-initialised at
//! t − `window_s`: position and attitude from the smoothed readings, the measured body
//! rates, and the unmeasured velocities (heave, surge, …) from the model's own run over
//! the history before. The residual e = y − ŷ over the last window is summarised per
//! channel by its mean over [`SUB`] equal sub-windows (f), with the model's predicted
//! motion since the window's start over the same sub-windows (a), which sets how much
//! model error to expect.

use rov_dynamics::models::Channel;
use rov_types::measurement::{MeasurementRow, MeasurementSeries};

use crate::data::{Run, ch_index, wrap180};
use crate::model::LabModel;
use crate::sim::simulate_run;

use super::{CHANNELS, SUB, WatchConfig};

/// One evaluation of the residuals.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Hop {
    /// End of the window (the hop's time), s on the rows' time axis.
    pub t_s: f64,
    /// Mean residual per channel ([`CHANNELS`] order) and sub-window; NaN when absent.
    pub f: [[f64; SUB]; 4],
    /// Mean |predicted motion since the window's start| per channel and sub-window.
    pub a: [[f64; SUB]; 4],
    /// Whether every raw reading of the channel over the window was the same value.
    pub frozen: [bool; 4],
    /// The lab's white-noise floor of the channel over the history (per sample).
    pub noise: [f64; 4],
}

/// The history of one hop as a lab run, with the window's re-initialisation sample.
#[derive(Debug, Clone)]
pub(crate) struct Chunk {
    pub run: Run,
    /// Sample where the window starts (re-initialisation).
    pub reset: usize,
    /// The hop's time, s.
    pub t_end_s: f64,
}

/// The rows of `[t_end − history, t_end]` as a run. `None` when there are too few rows
/// or the lab refuses them (a gap).
pub(crate) fn chunk(
    rows: &[MeasurementRow],
    present: [bool; 8],
    t_end_s: f64,
    cfg: &WatchConfig,
) -> Option<Chunk> {
    chunk_between(rows, present, t_end_s - cfg.history_s, t_end_s, cfg)
}

/// [`chunk`] over `[t_start, t_end]` (a history shorter than `history_s`).
pub(crate) fn chunk_between(
    rows: &[MeasurementRow],
    present: [bool; 8],
    t_start: f64,
    t_end_s: f64,
    cfg: &WatchConfig,
) -> Option<Chunk> {
    let picked: Vec<MeasurementRow> = rows
        .iter()
        .filter(|r| r.time_s >= t_start - 1e-9 && r.time_s <= t_end_s + 1e-9)
        .copied()
        .collect();
    if picked.len() < 20 {
        return None;
    }
    let series = MeasurementSeries {
        rows: picked,
        present,
        warnings: Vec::new(),
    };
    let run = Run::from_series(&series, "watch").ok()?;
    let t_reset = t_end_s - cfg.window_s;
    let reset = run.t.iter().position(|t| *t >= t_reset - 1e-9)?;
    // The window needs samples in every sub-window and history before it.
    if reset < 5 || run.len() - reset < 2 * SUB {
        return None;
    }
    Some(Chunk {
        run,
        reset,
        t_end_s,
    })
}

/// The model's prediction over a chunk's window, sample by sample: times and, per
/// channel, the predicted reading (empty when the channel is not compared).
#[derive(Debug, Clone, Default)]
pub(crate) struct Trajectory {
    pub t: Vec<f64>,
    pub y: [Vec<f64>; 4],
    pub yhat: [Vec<f64>; 4],
}

/// Simulates `model` over the chunk (re-initialised at the window's start) and returns
/// the window's measured and predicted samples.
pub(crate) fn trajectory(model: &LabModel, c: &Chunk) -> Option<Trajectory> {
    let pred = simulate_run(model, &c.run, &[c.reset]).ok()?;
    let mut out = Trajectory {
        t: c.run.t.get(c.reset..)?.to_vec(),
        ..Default::default()
    };
    for (i, ch) in CHANNELS.iter().enumerate() {
        let (Some(y), Some(p)) = (c.run.channel(*ch), pred.channel(*ch)) else {
            continue;
        };
        if let (Some(ys), Some(ps)) = (y.get(c.reset..), p.get(c.reset..)) {
            out.y[i] = ys.to_vec();
            out.yhat[i] = ps.to_vec();
        }
    }
    Some(out)
}

/// The difference of two readings of a channel (wrapped for heading, roll and pitch).
pub(crate) fn diff(ch: Channel, a: f64, b: f64) -> f64 {
    if ch == Channel::Depth {
        a - b
    } else {
        wrap180(a - b)
    }
}

/// The sub-window of a sample at `t_s` in a window from `t0_s` to `t1_s`.
pub(crate) fn sub_of(t_s: f64, t0_s: f64, t1_s: f64) -> usize {
    let span = (t1_s - t0_s).max(1e-9);
    let j = ((t_s - t0_s) / span * SUB as f64).floor();
    if j.is_finite() && j > 0.0 {
        (j as usize).min(SUB - 1)
    } else {
        0
    }
}

/// Sub-window means of `value(k)` over a trajectory's samples (NaN where none is finite).
pub(crate) fn sub_means(tr: &Trajectory, value: impl Fn(usize) -> f64) -> [f64; SUB] {
    let (t0, t1) = match (tr.t.first(), tr.t.last()) {
        (Some(a), Some(b)) => (*a, *b),
        _ => return [f64::NAN; SUB],
    };
    let mut sum = [0.0; SUB];
    let mut n = [0usize; SUB];
    for (k, t) in tr.t.iter().enumerate() {
        let v = value(k);
        if v.is_finite() {
            let j = sub_of(*t, t0, t1);
            sum[j] += v;
            n[j] += 1;
        }
    }
    let mut out = [f64::NAN; SUB];
    for j in 0..SUB {
        if n[j] > 0 {
            out[j] = sum[j] / n[j] as f64;
        }
    }
    out
}

/// Residual means `f` and predicted-motion means `a` of a trajectory.
pub(crate) fn residual_features(tr: &Trajectory) -> ([[f64; SUB]; 4], [[f64; SUB]; 4]) {
    let mut f = [[f64::NAN; SUB]; 4];
    let mut a = [[f64::NAN; SUB]; 4];
    for (i, ch) in CHANNELS.iter().enumerate() {
        let (y, p) = (&tr.y[i], &tr.yhat[i]);
        if y.is_empty() || p.len() != y.len() {
            continue;
        }
        let p0 = p.first().copied().unwrap_or(f64::NAN);
        f[i] = sub_means(tr, |k| match (y.get(k), p.get(k)) {
            (Some(yk), Some(pk)) => diff(*ch, *yk, *pk),
            _ => f64::NAN,
        });
        a[i] = sub_means(tr, |k| {
            p.get(k).map_or(f64::NAN, |pk| diff(*ch, *pk, p0).abs())
        });
    }
    (f, a)
}

/// The hop's features for the model, from a chunk and the raw rows of its window.
pub(crate) fn hop(
    model: &LabModel,
    c: &Chunk,
    raw: &[MeasurementRow],
    cfg: &WatchConfig,
) -> Option<Hop> {
    let tr = trajectory(model, c)?;
    let (f, a) = residual_features(&tr);
    let mut noise = [f64::NAN; 4];
    for (i, ch) in CHANNELS.iter().enumerate() {
        if c.run.has(*ch) {
            noise[i] = c.run.noise[ch_index(*ch)];
        }
    }
    Some(Hop {
        t_s: c.t_end_s,
        f,
        a,
        frozen: frozen(raw, c.t_end_s - cfg.window_s, c.t_end_s),
        noise,
    })
}

/// Whether each channel's raw readings over `[t0, t1]` are all one value (at least 10
/// finite readings).
pub(crate) fn frozen(rows: &[MeasurementRow], t0_s: f64, t1_s: f64) -> [bool; 4] {
    let mut first: [Option<f64>; 4] = [None; 4];
    let mut same = [true; 4];
    let mut n = [0usize; 4];
    for r in rows
        .iter()
        .filter(|r| r.time_s >= t0_s - 1e-9 && r.time_s <= t1_s + 1e-9)
    {
        for (i, v) in reading(r).into_iter().enumerate() {
            if !v.is_finite() {
                continue;
            }
            n[i] += 1;
            match first[i] {
                None => first[i] = Some(v),
                Some(f) if f.to_bits() != v.to_bits() => same[i] = false,
                Some(_) => {}
            }
        }
    }
    std::array::from_fn(|i| same[i] && n[i] >= 10)
}

/// A row's raw readings in [`CHANNELS`] order.
pub(crate) fn reading(r: &MeasurementRow) -> [f64; 4] {
    [r.depth_m, r.heading_deg, r.pitch_deg, r.roll_deg]
}
