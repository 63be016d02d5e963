//! Held-out evaluation of a model: per-channel metrics pooled over runs in the free-run
//! and multiple-shooting views.

use std::collections::BTreeMap;

use rov_dynamics::models::Channel;
use serde::Serialize;

use crate::LabError;
use crate::calibrate::{SHOOTING_WINDOW_S, View};
use crate::data::{Run, ch_index, ch_name};
use crate::metrics::{ChannelMetrics, pooled_metrics};
use crate::model::LabModel;
use crate::sim::{Prediction, compared_channels, simulate_run};

/// Metrics of one channel in both views.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ChannelEval {
    /// Free-run metrics.
    pub free_run: ChannelMetrics,
    /// Multiple-shooting metrics.
    pub shooting: ChannelMetrics,
    /// Pooled noise floor.
    pub noise: f64,
}

/// A model's held-out evaluation.
#[derive(Debug, Clone, Default)]
pub struct Evaluation {
    /// Per channel.
    pub channels: BTreeMap<ChannelKey, ChannelEval>,
    /// Free-run predictions per run (for plots and similarity).
    pub free_run: Vec<Prediction>,
    /// Shooting predictions per run.
    pub shooting: Vec<Prediction>,
}

/// A channel usable as a map key in report order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ChannelKey(pub usize);

impl ChannelKey {
    /// From a channel.
    pub fn of(ch: Channel) -> Self {
        Self(ch_index(ch))
    }

    /// The channel.
    pub fn channel(self) -> Channel {
        Channel::ALL[self.0.min(11)]
    }

    /// Report name.
    pub fn name(self) -> &'static str {
        ch_name(self.channel())
    }
}

/// A channel's noise floor pooled over runs (root mean square of the runs' floors,
/// weighted by their samples; runs that do not measure it left out).
pub fn pooled_noise(runs: &[Run], ch: Channel) -> f64 {
    let (mut nsum, mut nn) = (0.0, 0.0);
    for r in runs {
        if r.has(ch) {
            let w = r.len() as f64;
            nsum += r.noise[ch_index(ch)].powi(2) * w;
            nn += w;
        }
    }
    (nsum / nn.max(1.0)).sqrt()
}

/// Evaluates a model on runs in both views.
pub fn evaluate(model: &LabModel, runs: &[Run]) -> Result<Evaluation, LabError> {
    evaluate_window(model, runs, SHOOTING_WINDOW_S)
}

/// [`evaluate`] with multiple-shooting windows of `window_s` (the lab's own views use
/// [`SHOOTING_WINDOW_S`]).
pub fn evaluate_window(
    model: &LabModel,
    runs: &[Run],
    window_s: f64,
) -> Result<Evaluation, LabError> {
    let runs = crate::data::aligned(runs, model.channel_table());
    let runs = &runs[..];
    let mut free = Vec::with_capacity(runs.len());
    let mut shoot = Vec::with_capacity(runs.len());
    for r in runs {
        free.push(simulate_run(model, r, &View::FreeRun.resets(r))?);
        shoot.push(simulate_run(model, r, &View::Shooting(window_s).resets(r))?);
    }
    let mut channels = BTreeMap::new();
    let mut all: Vec<Channel> = Vec::new();
    for r in runs {
        for c in compared_channels(model, r) {
            if !all.contains(&c) {
                all.push(c);
            }
        }
    }
    for ch in all {
        let fi: Vec<(&Run, &Prediction)> = runs.iter().zip(free.iter()).collect();
        let si: Vec<(&Run, &Prediction)> = runs.iter().zip(shoot.iter()).collect();
        let (Some(f), Some(s)) = (pooled_metrics(&fi, ch), pooled_metrics(&si, ch)) else {
            continue;
        };
        channels.insert(
            ChannelKey::of(ch),
            ChannelEval {
                free_run: f,
                shooting: s,
                noise: pooled_noise(runs, ch),
            },
        );
    }
    Ok(Evaluation {
        channels,
        free_run: free,
        shooting: shoot,
    })
}
