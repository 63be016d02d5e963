//! The verdict: is the model (after its findings) consistent with the held-out data?
//!
//! # The test (stated here and in `topside lab --help`)
//!
//! For every channel the model predicts and the held-out runs measure, with e the
//! multiple-shooting residual (spikes excluded) and N its sample count:
//!
//! 0. **H₀ fitted.** The model under test is first refitted under H₀ ([`null`]): its
//!    free parameters and the documented-uncertain ones the calibration keeps fixed
//!    move to their maximum a posteriori point on the training runs (a Gauss–Newton step
//!    with the documented priors), so a vehicle whose fixed parameters differ from the
//!    base file's within their documented σ is not mistaken for a misfit. The steps
//!    below test that refit — or the model as it is, when that already passes within
//!    the noise alone, or passes in more channels, or in as many while closer to the
//!    held-out data in noise floors (Σ_c (RMSE_c/σ_n,c)²).
//! 1. **Expected level.** Under H₀ e is sensor noise plus the prediction error that
//!    parameter uncertainty, the inputs' resolution and the windows' start states allow:
//!    s₀² = σ_n² + σ_θ² + σ_u² + σ_x²,
//!    where σ_n is the channel's noise floor estimated from the data (never below the
//!    quantisation floor q/√12 of a signal recorded on a lattice of step q,
//!    [`crate::analysis::quantisation_floor`]); σ_θ² the mean prediction variance from
//!    the joint posterior covariance under H₀ of the free and the documented-uncertain
//!    fixed parameters (the same Gauss–Newton linearisation with residuals at the noise
//!    floor, inflated by N/N_eff, plus every parameter's documented prior): the
//!    uncertainty the parameters keep once the data has spoken, not their bare priors;
//!    and σ_u the spread the recorded commands' own uncertainty leaves ([`input_spread`]:
//!    their resolution — a Pro 4 runs whole percent, a station log records the
//!    autopilot's unrounded demand — and their timing, aligned with the measurements
//!    only to within one sample); and σ_x the spread the multiple-shooting windows'
//!    start states leave ([`reset_spread`]: each window starts from readings smoothed over
//!    ±0.3 s, off by their smoothing error, and a lightly damped axis such as pitch on its
//!    restoring moment rings from such a start for seconds).
//! 2. **Level test.** With N_eff the effective sample size of e (Bartlett: N / (1 + 2 Σ
//!    ρ_k) over the lags before the autocorrelation first turns negative), N_eff·MS/s₀²
//!    is χ²(N_eff) under H₀. The level is consistent when MS/s₀² ≤ χ²_{1−α/m}(N_eff)/N_eff
//!    with α = [`ALPHA`] over the m tested channels (Bonferroni).
//! 3. **Structure.** A channel above that level is still consistent when its residual is
//!    white (at most [`WHITE_FRACTION`] of the autocorrelation lags 1..L outside ±z/√N,
//!    z = 2.58) *and* correlates with no input (cross-correlation at lags 0..L against
//!    the Bartlett bound for coloured signals) and no state: then the excess is noise the
//!    floor estimate missed, which no model could predict. Otherwise it is inconsistent.
//! 4. **Distance.** Whatever the test above says, a channel whose RMSE exceeds
//!    [`MAX_RATIO`] noise floors is inconsistent: parameter uncertainty may excuse a
//!    modest excess, never a model that far from its noise floor.
//! 5. **Floor.** Within that distance, whatever steps 2 and 3 say, a channel whose RMSE is within
//!    [`FLOOR_TOLERANCE`] of its expected level s₀ is consistent: σ_n is itself an
//!    estimate (third differences assume white noise; a sensor's own filtering or a
//!    simulation's discretisation bias it by a few per cent), and a residual at the
//!    level of the noise leaves nothing any model could still explain.
//!
//! The verdict is `adequate` when every channel of the calibrated base is consistent and
//! no finding was needed, `explained` when the accepted findings make every channel
//! consistent, and `unexplained` when some channel is still inconsistent. For each
//! unexplained channel the report says where the misfit lives (the conditions under which
//! its squared error concentrates: a command's sign, turning fast, transients after a
//! command change, the worst window) and which signals it correlates with best.
//!
//! No threshold here is tuned to test data: α, the whiteness band and the condition
//! screen are conventional (99 %), and everything else comes from the data and the
//! documented parameter uncertainties.

use std::collections::BTreeMap;

use rov_dynamics::models::Channel;
use serde::Serialize;

use crate::analysis::autocorrelation;
use crate::calibrate::bounds_for;
use crate::data::{N_CHANNELS, Run, ch_index, ch_name, ch_unit};
use crate::evaluate::Evaluation;
use crate::metrics::residual;
use crate::model::LabModel;
use crate::params::Param;
use crate::sim::Prediction;

mod null;
pub use null::{
    KnownJacobian, NullRefit, PRO4_COMMAND_RESOLUTION_PCT, input_spread, null_refit,
    null_refit_from, reset_spread,
};

/// Family-wise significance level of the level test.
pub const ALPHA: f64 = 0.01;
/// Largest fraction of autocorrelation lags outside the 99 % band for a white residual.
pub const WHITE_FRACTION: f64 = 0.05;
/// A channel whose held-out RMSE exceeds this many noise floors is never consistent,
/// whatever the parameter spread allows: a model that far from its noise floor is not
/// adequate (RULES: "never adequate while a channel is far from its noise floor").
pub const MAX_RATIO: f64 = 3.0;
/// A channel whose RMSE is at most this factor above its expected level s₀ is
/// consistent (module documentation, step 5).
pub const FLOOR_TOLERANCE: f64 = 1.1;

/// The verdict.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// Every channel consistent with noise and parameter uncertainty, no finding needed.
    Adequate,
    /// The accepted findings bring every channel there.
    Explained,
    /// Some channel is still beyond it.
    Unexplained,
}

impl Verdict {
    /// The verdict's name.
    pub fn name(self) -> &'static str {
        match self {
            Verdict::Adequate => "adequate",
            Verdict::Explained => "explained",
            Verdict::Unexplained => "unexplained",
        }
    }
}

/// A signal a residual correlates with.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Correlate {
    /// The signal ("yaw rate", "vertical command", …).
    pub signal: String,
    /// Correlation coefficient at the best lag.
    pub r: f64,
    /// The lag, s (positive: the signal leads the residual).
    pub lag_s: f64,
}

/// A condition under which a channel's misfit concentrates.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Condition {
    /// The condition in words ("during turns faster than 20 °/s").
    pub description: String,
    /// Fraction of the channel's squared error under the condition.
    pub share_of_error: f64,
    /// Fraction of the time under the condition.
    pub share_of_time: f64,
}

/// The consistency test of one channel.
#[derive(Debug, Clone, Serialize)]
pub struct ChannelTest {
    /// Channel.
    pub channel: String,
    /// Held-out multiple-shooting RMSE.
    pub rmse: f64,
    /// Noise floor σ_n.
    pub noise: f64,
    /// Prediction spread the test allows besides the noise: √(σ_θ² + σ_u² + σ_x²),
    /// parameter uncertainty, the commands' resolution and the windows' start states.
    pub param_spread: f64,
    /// RMSE / σ_n.
    pub ratio: f64,
    /// MS / s₀² against its critical value.
    pub level: f64,
    /// Critical value χ²_{1−α/m}(N_eff)/N_eff.
    pub level_critical: f64,
    /// Effective sample size.
    pub n_eff: f64,
    /// Fraction of autocorrelation lags outside the band.
    pub autocorrelation_outside: f64,
    /// Best input or state correlations beyond their bounds, strongest first.
    pub correlates_with: Vec<Correlate>,
    /// Whether the channel is consistent with noise and parameter uncertainty.
    pub consistent: bool,
}

/// An unexplained channel in the report.
#[derive(Debug, Clone, Serialize)]
pub struct Unexplained {
    /// Channel.
    pub channel: String,
    /// Held-out multiple-shooting RMSE (channel units).
    pub rmse: f64,
    /// Noise floor.
    pub noise: f64,
    /// RMSE / noise floor.
    pub ratio: f64,
    /// What parameter uncertainty allows (s₀).
    pub expected: f64,
    /// Where the misfit concentrates, strongest first.
    #[serde(rename = "where")]
    pub where_: Vec<Condition>,
    /// Signals it correlates with best.
    pub correlates_with: Vec<Correlate>,
    /// All of it in words.
    pub description: String,
}

/// Standard normal quantile (Acklam's rational approximation, |error| < 1.2e-9).
fn norm_quantile(p: f64) -> f64 {
    let p = p.clamp(1e-300, 1.0 - 1e-16);
    const A: [f64; 6] = [
        -3.969683028665376e1,
        2.209460984245205e2,
        -2.759285104469687e2,
        1.383_577_518_672_69e2,
        -3.066479806614716e1,
        2.506628277459239,
    ];
    const B: [f64; 5] = [
        -5.447609879822406e1,
        1.615858368580409e2,
        -1.556989798598866e2,
        6.680131188771972e1,
        -1.328068155288572e1,
    ];
    const C: [f64; 6] = [
        -7.784894002430293e-3,
        -3.223964580411365e-1,
        -2.400758277161838,
        -2.549732539343734,
        4.374664141464968,
        2.938163982698783,
    ];
    const D: [f64; 4] = [
        7.784695709041462e-3,
        3.224671290700398e-1,
        2.445134137142996,
        3.754408661907416,
    ];
    let pl = 0.02425;
    if p < pl {
        let q = (-2.0 * p.ln()).sqrt();
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    } else if p <= 1.0 - pl {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    } else {
        -norm_quantile(1.0 - p)
    }
}

/// χ²_p(k)/k by the Wilson–Hilferty approximation.
pub fn chi2_quantile_per_dof(p: f64, k: f64) -> f64 {
    let k = k.max(1.0);
    let z = norm_quantile(p);
    let a = 2.0 / (9.0 * k);
    (1.0 - a + z * a.sqrt()).powi(3).max(0.0)
}

/// Effective sample size of a residual made of per-run pieces: N / (1 + 2 Σ_{k≥1} ρ_k)
/// summed over the lags before the pooled autocorrelation first turns negative
/// (at most `max_lag`).
pub fn effective_n_bartlett(pieces: &[Vec<f64>], max_lag: usize) -> f64 {
    // Each piece centred on its own mean, missing samples set to 0 (they add nothing to
    // a lagged product sum, exactly as if skipped).
    let mut centred: Vec<Vec<f64>> = Vec::new();
    let mut n = 0usize;
    for e in pieces {
        let f: Vec<f64> = e.iter().copied().filter(|x| x.is_finite()).collect();
        if f.is_empty() {
            continue;
        }
        let mean = f.iter().sum::<f64>() / f.len() as f64;
        centred.push(
            e.iter()
                .map(|x| if x.is_finite() { x - mean } else { 0.0 })
                .collect(),
        );
        n += f.len();
    }
    // The pooled autocovariance at one lag (pieces in order, samples in order).
    let cov = |lag: usize| -> f64 {
        let mut c = 0.0;
        for d in &centred {
            if lag < d.len() {
                for (a, b) in d[lag..].iter().zip(d) {
                    c += a * b;
                }
            }
        }
        c
    };
    let c0 = cov(0);
    if n == 0 || c0 <= 0.0 {
        return n as f64;
    }
    // Lags one at a time, up to the first non-positive one (the later ones do not count).
    let mut s = 0.0;
    for lag in 1..=max_lag {
        let rho = cov(lag) / c0;
        if rho <= 0.0 {
            break;
        }
        s += rho;
    }
    (n as f64 / (1.0 + 2.0 * s)).clamp(1.0, n as f64)
}

/// The fixed base parameters whose documented uncertainty counts as parameter
/// uncertainty: applicable, with a documented prior, not calibrated, not a parameter of a
/// catalog effect (those are diagnosed, not forgiven).
pub(crate) fn fixed_uncertain(model: &LabModel, free: &[Param]) -> Vec<Param> {
    let mut out = Vec::new();
    for p in Param::all() {
        let base_only = matches!(
            p,
            Param::AddedMass(_) | Param::DragLin(_) | Param::DragQuad(_) | Param::ThrustQuad(_)
        ) || matches!(p, Param::ThrustLin(_));
        if base_only && !free.contains(&p) && model.applicable(p) && model.prior_of(p).is_some() {
            out.push(p);
        }
    }
    out
}

/// A named signal over the held-out samples (per run).
struct Signal {
    name: String,
    values: Vec<Vec<f64>>,
    /// Whether the signal is an input (cross-correlated at positive lags) or a state.
    input: bool,
}

fn derivative(t: &[f64], v: &[f64]) -> Vec<f64> {
    let n = v.len();
    (0..n)
        .map(|k| {
            let (a, b) = (k.saturating_sub(1), (k + 1).min(n.saturating_sub(1)));
            let dt = t.get(b).copied().unwrap_or(0.0) - t.get(a).copied().unwrap_or(0.0);
            if dt > 0.0 {
                (v[b] - v[a]) / dt
            } else {
                f64::NAN
            }
        })
        .collect()
}

/// The inputs and states a residual is checked against.
fn signals(model: &LabModel, runs: &[Run]) -> Vec<Signal> {
    let mut out: Vec<Signal> = Vec::new();
    let names = model.command_names();
    for (ci, name) in names.iter().enumerate() {
        let v: Vec<Vec<f64>> = runs
            .iter()
            .map(|r| {
                r.inputs
                    .iter()
                    .map(|c| model.command_signals(c).get(ci).copied().unwrap_or(0.0))
                    .collect()
            })
            .collect();
        let abs: Vec<Vec<f64>> = v
            .iter()
            .map(|x| x.iter().map(|y| y.abs()).collect())
            .collect();
        out.push(Signal {
            name: format!("{name} command"),
            values: v,
            input: true,
        });
        out.push(Signal {
            name: format!("|{name} command|"),
            values: abs,
            input: true,
        });
    }
    let state = |name: &str, f: &dyn Fn(&Run) -> Option<Vec<f64>>| -> Option<Signal> {
        let vals: Vec<Vec<f64>> = runs
            .iter()
            .map(|r| f(r).unwrap_or_else(|| vec![f64::NAN; r.len()]))
            .collect();
        vals.iter()
            .any(|v| v.iter().any(|x| x.is_finite()))
            .then(|| Signal {
                name: name.to_string(),
                values: vals,
                input: false,
            })
    };
    let rate = |r: &Run, measured: Channel, angle: Channel| -> Option<Vec<f64>> {
        if let Some(v) = r.channel(measured) {
            return Some(v.to_vec());
        }
        let s = r.smooth[ch_index(angle)].as_ref()?;
        Some(derivative(&r.t, s))
    };
    let candidates: Vec<Option<Signal>> = vec![
        state("depth", &|r| r.channel(Channel::Depth).map(<[f64]>::to_vec)),
        state("pitch", &|r| r.channel(Channel::Pitch).map(<[f64]>::to_vec)),
        state("roll", &|r| r.channel(Channel::Roll).map(<[f64]>::to_vec)),
        state("sin(heading)", &|r| {
            r.channel(Channel::Heading)
                .map(|h| h.iter().map(|x| x.to_radians().sin()).collect())
        }),
        state("cos(heading)", &|r| {
            r.channel(Channel::Heading)
                .map(|h| h.iter().map(|x| x.to_radians().cos()).collect())
        }),
        state("yaw rate", &|r| rate(r, Channel::YawRate, Channel::Heading)),
        state("|yaw rate|", &|r| {
            rate(r, Channel::YawRate, Channel::Heading).map(|v| v.iter().map(|x| x.abs()).collect())
        }),
        state("heave rate", &|r| rate(r, Channel::Heave, Channel::Depth)),
        state("pitch rate", &|r| {
            rate(r, Channel::PitchRate, Channel::Pitch)
        }),
        state("roll rate", &|r| rate(r, Channel::RollRate, Channel::Roll)),
        state("surge", &|r| r.channel(Channel::Surge).map(<[f64]>::to_vec)),
        state("sway", &|r| r.channel(Channel::Sway).map(<[f64]>::to_vec)),
        state("time", &|r| Some(r.t.iter().map(|t| t - r.t[0]).collect())),
    ];
    out.extend(candidates.into_iter().flatten());
    out
}

/// The residual of a channel over held-out runs (spikes and missing samples NaN).
fn residuals_of(runs: &[Run], preds: &[Prediction], ch: Channel) -> Vec<Vec<f64>> {
    runs.iter()
        .zip(preds)
        .map(|(r, p)| match (r.channel(ch), p.channel(ch)) {
            (Some(y), Some(yh)) => y
                .iter()
                .zip(yh)
                .map(|(a, b)| residual(ch, *a, *b))
                .collect(),
            _ => vec![f64::NAN; r.len()],
        })
        .collect()
}

/// Significant correlations of a residual with the signals, strongest first.
fn correlates(e: &[Vec<f64>], sigs: &[Signal], dt: f64, max_lag: usize) -> Vec<Correlate> {
    let flat_e: Vec<f64> = e.iter().flatten().copied().collect();
    let acf = crate::analysis::ResidualAcf::new(&flat_e, max_lag.max(1));
    let mut out = Vec::new();
    for s in sigs {
        let flat_s: Vec<f64> = s.values.iter().flatten().copied().collect();
        if flat_s.len() != flat_e.len() {
            continue;
        }
        let var = {
            let f: Vec<f64> = flat_s.iter().copied().filter(|x| x.is_finite()).collect();
            let m = f.iter().sum::<f64>() / f.len().max(1) as f64;
            f.iter().map(|x| (x - m).powi(2)).sum::<f64>() / f.len().max(1) as f64
        };
        if var <= 1e-18 {
            continue;
        }
        let lag = if s.input { max_lag } else { 0 };
        let c = acf.cross_correlation(&flat_s, lag.max(1), &s.name);
        let best = c
            .lags
            .iter()
            .zip(&c.values)
            .filter(|(l, _)| **l >= 0 && (s.input || **l == 0))
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()));
        if let Some((l, v)) = best
            && v.abs() > c.bound
        {
            out.push(Correlate {
                signal: s.name.clone(),
                r: *v,
                lag_s: *l as f64 * dt,
            });
        }
    }
    out.sort_by(|a, b| b.r.abs().total_cmp(&a.r.abs()));
    out
}

/// Conditions under which the squared residual concentrates.
fn conditions(model: &LabModel, runs: &[Run], e: &[Vec<f64>], sigs: &[Signal]) -> Vec<Condition> {
    let total: f64 = e
        .iter()
        .flatten()
        .filter(|x| x.is_finite())
        .map(|x| x * x)
        .sum();
    let n_total = e.iter().flatten().filter(|x| x.is_finite()).count();
    if total <= 0.0 || n_total == 0 {
        return Vec::new();
    }
    let mut cands: Vec<(String, Vec<Vec<bool>>)> = Vec::new();
    let names = model.command_names();
    for (ci, name) in names.iter().enumerate() {
        let sign_mask = |pos: bool| -> Vec<Vec<bool>> {
            runs.iter()
                .map(|r| {
                    r.inputs
                        .iter()
                        .map(|c| {
                            let x = model.command_signals(c).get(ci).copied().unwrap_or(0.0);
                            if pos { x > 0.05 } else { x < -0.05 }
                        })
                        .collect()
                })
                .collect()
        };
        cands.push((
            format!("while the {name} command is positive"),
            sign_mask(true),
        ));
        cands.push((
            format!("while the {name} command is negative"),
            sign_mask(false),
        ));
    }
    cands.push((
        "while every command is off".into(),
        runs.iter()
            .map(|r| {
                r.inputs
                    .iter()
                    .map(|c| model.command_signals(c).iter().all(|x| x.abs() <= 0.05))
                    .collect()
            })
            .collect(),
    ));
    cands.push((
        "while two or more commands are on".into(),
        runs.iter()
            .map(|r| {
                r.inputs
                    .iter()
                    .map(|c| {
                        model
                            .command_signals(c)
                            .iter()
                            .filter(|x| x.abs() > 0.05)
                            .count()
                            >= 2
                    })
                    .collect()
            })
            .collect(),
    ));
    cands.push((
        "within 2 s after a command change".into(),
        runs.iter()
            .map(|r| {
                let mut last = f64::NEG_INFINITY;
                (0..r.len())
                    .map(|k| {
                        if k > 0 && r.inputs[k] != r.inputs[k - 1] {
                            last = r.t[k];
                        }
                        r.t[k] - last <= 2.0
                    })
                    .collect()
            })
            .collect(),
    ));
    let thresh =
        |name: &str, unit: &str, levels: &[f64], word: &str| -> Vec<(String, Vec<Vec<bool>>)> {
            let Some(s) = sigs.iter().find(|s| s.name == name) else {
                return Vec::new();
            };
            levels
                .iter()
                .map(|lv| {
                    (
                        format!("{word} {lv} {unit}"),
                        s.values
                            .iter()
                            .map(|v| v.iter().map(|x| x.abs() > *lv).collect())
                            .collect(),
                    )
                })
                .collect()
        };
    cands.extend(thresh(
        "yaw rate",
        "°/s",
        &[10.0, 20.0, 40.0],
        "during turns faster than",
    ));
    cands.extend(thresh(
        "heave rate",
        "m/s",
        &[0.1, 0.2],
        "while climbing or diving faster than",
    ));
    cands.extend(thresh(
        "pitch",
        "°",
        &[5.0, 15.0],
        "while pitched more than",
    ));
    cands.extend(thresh("roll", "°", &[5.0, 15.0], "while heeled more than"));
    cands.extend(thresh(
        "surge",
        "m/s",
        &[0.2, 0.5],
        "while moving faster than",
    ));
    // The worst 10 s window.
    let mut worst: Option<(f64, String, usize, usize, usize)> = None;
    for (ri, (r, er)) in runs.iter().zip(e).enumerate() {
        for w in crate::metrics::windows(r, 10.0) {
            let s: f64 = er[w.clone()]
                .iter()
                .filter(|x| x.is_finite())
                .map(|x| x * x)
                .sum();
            if worst.as_ref().is_none_or(|b| s > b.0) {
                worst = Some((
                    s,
                    format!(
                        "in {} at t = {:.0}–{:.0} s",
                        r.name,
                        r.t[w.start] - r.t[0],
                        r.t[w.end - 1] - r.t[0]
                    ),
                    ri,
                    w.start,
                    w.end,
                ));
            }
        }
    }
    if let Some((_, label, ri, a, b)) = worst {
        cands.push((
            label,
            runs.iter()
                .enumerate()
                .map(|(i, r)| (0..r.len()).map(|k| i == ri && k >= a && k < b).collect())
                .collect(),
        ));
    }
    let mut out: Vec<Condition> = cands
        .into_iter()
        .filter_map(|(d, mask)| {
            let (mut se, mut n) = (0.0, 0usize);
            for (er, m) in e.iter().zip(&mask) {
                for (x, on) in er.iter().zip(m) {
                    if *on && x.is_finite() {
                        se += x * x;
                        n += 1;
                    }
                }
            }
            let share_time = n as f64 / n_total as f64;
            let share_err = se / total;
            ((0.01..=0.8).contains(&share_time)
                && share_err >= 0.25
                && share_err >= 1.5 * share_time)
                .then_some(Condition {
                    description: d,
                    share_of_error: share_err,
                    share_of_time: share_time,
                })
        })
        .collect();
    out.sort_by(|a, b| {
        let sa = a.share_of_error * (a.share_of_error / a.share_of_time.max(1e-9) - 1.0);
        let sb = b.share_of_error * (b.share_of_error / b.share_of_time.max(1e-9) - 1.0);
        sb.total_cmp(&sa)
    });
    // Keep the strongest of each family (one threshold per signal).
    let mut kept: Vec<Condition> = Vec::new();
    for c in out {
        let family = c
            .description
            .split(" faster than")
            .next()
            .unwrap_or("")
            .to_string();
        let family = family.split(" more than").next().unwrap_or("").to_string();
        if !kept
            .iter()
            .any(|k| k.description.starts_with(&family) && family.len() > 6)
        {
            kept.push(c);
        }
        if kept.len() >= 3 {
            break;
        }
    }
    kept
}

/// Tests every compared channel of a model's held-out evaluation (shooting view).
/// `spread` is σ_θ per channel (zeros when not computed).
pub fn test_channels(
    model: &LabModel,
    val: &[Run],
    eval: &Evaluation,
    spread: &[f64; N_CHANNELS],
) -> Vec<ChannelTest> {
    let dt = val.first().map_or(0.05, |r| r.median_dt()).max(1e-3);
    let max_lag = ((5.0 / dt).round() as usize).clamp(5, 50);
    let sigs = signals(model, val);
    let m = eval.channels.len().max(1) as f64;
    let mut out = Vec::new();
    for (k, ce) in &eval.channels {
        let ch = k.channel();
        let e = residuals_of(val, &eval.shooting, ch);
        let flat: Vec<f64> = e
            .iter()
            .flatten()
            .copied()
            .filter(|x| x.is_finite())
            .collect();
        if flat.is_empty() {
            continue;
        }
        let ms = flat.iter().map(|x| x * x).sum::<f64>() / flat.len() as f64;
        let sigma_n = ce.noise.max(1e-12);
        let s0_2 = sigma_n.powi(2) + spread[ch_index(ch)].powi(2);
        let n_eff = effective_n_bartlett(&e, max_lag * 4);
        let crit = chi2_quantile_per_dof(1.0 - ALPHA / m, n_eff);
        let level = ms / s0_2;
        let ac = autocorrelation(&e.iter().flatten().copied().collect::<Vec<_>>(), max_lag);
        let outside = ac.significant_lags.len() as f64 / max_lag as f64;
        let corr = correlates(&e, &sigs, dt, max_lag);
        let white = outside <= WHITE_FRACTION;
        let ratio = ms.sqrt() / sigma_n;
        let at_floor = ms.sqrt() <= FLOOR_TOLERANCE * s0_2.sqrt();
        let consistent =
            ratio <= MAX_RATIO && (at_floor || level <= crit || (white && corr.is_empty()));
        out.push(ChannelTest {
            channel: ch_name(ch).to_string(),
            rmse: ms.sqrt(),
            noise: sigma_n,
            param_spread: spread[ch_index(ch)],
            ratio,
            level,
            level_critical: crit,
            n_eff,
            autocorrelation_outside: outside,
            correlates_with: corr,
            consistent,
        });
    }
    out
}

/// The unexplained channels of a test, with where their misfit lives.
pub fn unexplained(
    model: &LabModel,
    val: &[Run],
    eval: &Evaluation,
    tests: &[ChannelTest],
) -> Vec<Unexplained> {
    let sigs = signals(model, val);
    let mut out = Vec::new();
    for t in tests.iter().filter(|t| !t.consistent) {
        let Some(ch) = Channel::ALL
            .iter()
            .copied()
            .find(|c| ch_name(*c) == t.channel)
        else {
            continue;
        };
        let e = residuals_of(val, &eval.shooting, ch);
        let where_ = conditions(model, val, &e, &sigs);
        let correlates_with: Vec<Correlate> = t.correlates_with.iter().take(3).cloned().collect();
        let unit = ch_unit(ch);
        let mut d = format!(
            "{} off by {:.3} {unit} RMS, {:.1}× its noise floor ({:.3} {unit})",
            t.channel, t.rmse, t.ratio, t.noise
        );
        if t.param_spread > 0.05 * t.noise {
            d.push_str(&format!(
                "; parameter uncertainty allows {:.3} {unit}",
                (t.noise.powi(2) + t.param_spread.powi(2)).sqrt()
            ));
        }
        if !where_.is_empty() {
            let w: Vec<String> = where_
                .iter()
                .map(|c| {
                    format!(
                        "{} ({:.0} % of the squared error in {:.0} % of the time)",
                        c.description,
                        c.share_of_error * 100.0,
                        c.share_of_time * 100.0
                    )
                })
                .collect();
            d.push_str(&format!("; mostly {}", w.join(", and ")));
        }
        if !correlates_with.is_empty() {
            let c: Vec<String> = correlates_with
                .iter()
                .map(|c| {
                    if c.lag_s > 0.0 {
                        format!("{} {:.1} s earlier (r = {:+.2})", c.signal, c.lag_s, c.r)
                    } else {
                        format!("{} (r = {:+.2})", c.signal, c.r)
                    }
                })
                .collect();
            d.push_str(&format!("; correlates best with {}", c.join(", ")));
        }
        out.push(Unexplained {
            channel: t.channel.clone(),
            rmse: t.rmse,
            noise: t.noise,
            ratio: t.ratio,
            expected: (t.noise.powi(2) + t.param_spread.powi(2)).sqrt(),
            where_,
            correlates_with,
            description: d,
        });
    }
    out
}

/// Whether every tested channel is consistent.
pub fn all_consistent(tests: &[ChannelTest]) -> bool {
    tests.iter().all(|t| t.consistent)
}

/// Channel tests keyed by channel name.
pub fn by_channel(tests: &[ChannelTest]) -> BTreeMap<String, ChannelTest> {
    tests
        .iter()
        .map(|t| (t.channel.clone(), t.clone()))
        .collect()
}

/// Bounds with the documented priors (re-export for the verdict's users).
pub fn documented_bounds(model: &LabModel, params: &[Param]) -> Vec<crate::lm::Bound> {
    bounds_for(model, params, true)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn effective_sample_size_equals_the_all_lags_form_bit_for_bit() {
        // The form computing every lag, skipping pairs with a missing sample.
        let reference = |pieces: &[Vec<f64>], max_lag: usize| -> f64 {
            let mut c = vec![0.0; max_lag + 1];
            let mut n = 0usize;
            for e in pieces {
                let f: Vec<f64> = e.iter().copied().filter(|x| x.is_finite()).collect();
                if f.is_empty() {
                    continue;
                }
                let mean = f.iter().sum::<f64>() / f.len() as f64;
                for (lag, ck) in c.iter_mut().enumerate() {
                    for k in lag..e.len() {
                        let (a, b) = (e[k], e[k - lag]);
                        if a.is_finite() && b.is_finite() {
                            *ck += (a - mean) * (b - mean);
                        }
                    }
                }
                n += f.len();
            }
            if n == 0 || c[0] <= 0.0 {
                return n as f64;
            }
            let mut s = 0.0;
            for ck in c.iter().skip(1) {
                let rho = ck / c[0];
                if rho <= 0.0 {
                    break;
                }
                s += rho;
            }
            (n as f64 / (1.0 + 2.0 * s)).clamp(1.0, n as f64)
        };
        let piece = |n: usize, w: f64| -> Vec<f64> {
            (0..n)
                .map(|k| {
                    if k % 29 == 3 {
                        f64::NAN
                    } else {
                        (w * k as f64).sin() + 0.2 * (3.1 * k as f64).cos()
                    }
                })
                .collect()
        };
        let pieces = vec![
            piece(400, 0.05),
            vec![f64::NAN; 7],
            piece(250, 0.2),
            piece(3, 0.1),
        ];
        for max_lag in [0, 1, 5, 50, 200, 500] {
            assert_eq!(
                effective_n_bartlett(&pieces, max_lag).to_bits(),
                reference(&pieces, max_lag).to_bits(),
                "max lag {max_lag}"
            );
        }
    }

    #[test]
    fn chi_square_quantiles_match_tables() {
        // χ²_0.99(10) = 23.209, χ²_0.99(100) = 135.807, χ²_0.95(50) = 67.505.
        assert!((chi2_quantile_per_dof(0.99, 10.0) * 10.0 - 23.209).abs() < 0.15);
        assert!((chi2_quantile_per_dof(0.99, 100.0) * 100.0 - 135.807).abs() < 0.3);
        assert!((chi2_quantile_per_dof(0.95, 50.0) * 50.0 - 67.505).abs() < 0.2);
        assert!((norm_quantile(0.975) - 1.959964).abs() < 1e-5);
    }

    #[test]
    fn effective_n_of_white_and_ar1_noise() {
        let mut x = 99u64;
        let mut g = || {
            let mut s = 0.0;
            for _ in 0..12 {
                x = x
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                s += (x >> 11) as f64 / (1u64 << 53) as f64;
            }
            s - 6.0
        };
        let white: Vec<f64> = (0..20000).map(|_| g()).collect();
        let n = effective_n_bartlett(&[white], 50);
        assert!(n > 15000.0, "{n}");
        let mut a = 0.0;
        let ar: Vec<f64> = (0..20000)
            .map(|_| {
                a = 0.9 * a + g();
                a
            })
            .collect();
        // N (1 − ρ)/(1 + ρ) ≈ 20000/19 ≈ 1050 for ρ = 0.9.
        let n = effective_n_bartlett(&[ar], 200);
        assert!((600.0..1600.0).contains(&n), "{n}");
    }
}
