//! The verdict's null hypothesis, fitted before it is tested.
//!
//! H₀ is "the model is right up to its parameters' documented uncertainty". The
//! calibration frees only the parameters the data determines well (thrust scales, the
//! damping of the excited axes, …) and keeps the rest (most added masses and dampings) at
//! the base file's values; a vehicle whose true values differ from those within their
//! documented σ leaves a residual that is not a misfit of the model's structure. So the
//! test is run on the *null refit* of the model under test: every free parameter and
//! every documented-uncertain fixed one ([`super::fixed_uncertain`]) moved to the
//! maximum a posteriori point of
//!
//! ```text
//! P(θ) = Σ r(θ)² / κ + Σ_i ((θ_i − μ_i)/σ_i)²,    κ = N / N_eff,
//! ```
//!
//! r the training multiple-shooting residual in the diagnosis' channel weights, μ, σ the
//! documented prior (a weak prior at the current value for effect and term parameters,
//! [`crate::calibrate::bounds_for`]) and κ the correlation inflation the rest of the lab
//! uses. One Gauss–Newton step from the model under test (the step halved until P falls,
//! at most twice; bounds respected) — the ridge null fit the term screening uses, taken
//! to the model. The same linearisation gives the posterior covariance (in noise
//! weights) behind σ_θ, the prediction spread the test allows; the spread the windows'
//! start states leave, σ_x ([`reset_spread`]), is added to it.

use nalgebra::{DMatrix, DVector};
use rov_dynamics::models::Channel;

use crate::LabError;
use crate::calibrate::{ChannelScales, NOISE_ONLY, Objective, SHOOTING_WINDOW_S, View, bounds_for};
use crate::data::{N_CHANNELS, Run, ch_index};
use crate::evaluate::{Evaluation, evaluate};
use crate::metrics::residual;
use crate::model::LabModel;
use crate::params::Param;
use crate::sim::{Prediction, simulate_run};

use super::fixed_uncertain;

/// The model under test with its parameters refitted under H₀, and what that leaves.
#[derive(Debug, Clone)]
pub struct NullRefit {
    /// The refitted model.
    pub model: LabModel,
    /// Its held-out evaluation.
    pub eval: Evaluation,
    /// √(σ_θ² + σ_x²) per channel (index as [`Channel::ALL`]): the prediction spread of
    /// the parameters under H₀ and of the reset states ([`reset_spread`]).
    pub spread: [f64; N_CHANNELS],
    /// Parameters the refit moved by at least half their prior σ: (key, from, to), display
    /// units.
    pub moved: Vec<(String, f64, f64)>,
    /// The refitted parameters.
    pub params: Vec<Param>,
    /// The training Jacobian of the multiple-shooting residual to them (weights
    /// `scales`), at the model the refit started from (shared by the refits that reuse
    /// it: a whole dive's rows).
    pub jacobian: std::sync::Arc<DMatrix<f64>>,
    /// The channel scales of that Jacobian's weights.
    pub scales: ChannelScales,
}

/// A training Jacobian already at hand: its columns for the leading `free` parameters, in
/// the weights of `scales`, with the residual at the model.
#[derive(Debug, Clone, Copy)]
pub struct KnownJacobian<'a> {
    /// Columns (rows as [`Objective`]).
    pub columns: &'a DMatrix<f64>,
    /// The residual at the model.
    pub residual: &'a [f64],
}

/// Fits H₀ to `model` (free parameters `free`) on `train` and evaluates it on `val`
/// (module documentation).
pub fn null_refit(
    model: &LabModel,
    free: &[Param],
    train: &[Run],
    val: &[Run],
    scales: &ChannelScales,
    known: Option<KnownJacobian<'_>>,
    threads: usize,
) -> Result<NullRefit, LabError> {
    let fixed = fixed_uncertain(model, free);
    let all: Vec<Param> = free
        .iter()
        .chain(&fixed)
        .copied()
        .filter(|p| model.get(*p).is_some())
        .collect();
    let n = all.len();
    let shooting = View::Shooting(SHOOTING_WINDOW_S);
    let obj = Objective::scaled(model, train, shooting, scales);
    let known = known.filter(|k| k.columns.nrows() == k.residual.len());
    let r0: Vec<f64> = match &known {
        Some(k) if k.residual.len() == obj.len() => k.residual.to_vec(),
        _ => obj.residuals(model)?,
    };
    let rows = r0.len();
    // Columns: the known ones for the leading free parameters, forward differences of one
    // parameter scale for the rest.
    let known_cols = known
        .as_ref()
        .filter(|k| k.columns.nrows() == rows)
        .map_or(0, |k| k.columns.ncols().min(free.len()));
    let mut j = DMatrix::zeros(rows, n);
    if let Some(k) = &known {
        for c in 0..known_cols {
            j.set_column(c, &k.columns.column(c));
        }
    }
    // The other columns written straight into the matrix (a failed one stays zero).
    if rows > 0
        && let Some(rest) = j.as_mut_slice().get_mut(known_cols * rows..)
    {
        crate::par::par_chunks_mut(rest, rows, threads, |i, col| {
            let Some(&p) = all.get(known_cols + i) else {
                return;
            };
            let Some(v0) = model.get(p) else {
                return;
            };
            let meta = p.meta();
            let h = if v0 + meta.scale > meta.hi {
                -meta.scale
            } else {
                meta.scale
            };
            let Ok(m) = model.with(&[p], &[v0 + h]) else {
                return;
            };
            if let Ok(r) = obj.residuals(&m)
                && r.len() == rows
            {
                for ((x, a), b) in col.iter_mut().zip(&r).zip(&r0) {
                    *x = (a - b) / h;
                }
            }
        });
    }
    let (refit, moved, cov) = map_step(model, &all, &j, &r0, &obj, train, scales)?;
    let eval = evaluate(&refit, val)?;
    let mut spread = match &cov {
        Some(cov) => prediction_spread(&refit, &all, val, &eval.shooting, cov, threads),
        None => [0.0; N_CHANNELS],
    };
    let reset = reset_spread(&refit, val, &eval.shooting, threads);
    for (s, x) in spread.iter_mut().zip(reset) {
        *s = s.hypot(x);
    }
    Ok(NullRefit {
        model: refit,
        eval,
        spread,
        moved,
        params: all,
        jacobian: std::sync::Arc::new(j),
        scales: *scales,
    })
}

/// [`null_refit`] of a model that extends the one `prior` was fitted to (the calibrated
/// base with accepted findings), reusing its linearisation: the same parameters refitted
/// from this model's own training residual with `prior`'s Jacobian (adding an effect
/// hardly changes the base parameters' sensitivities; the findings' own parameters were
/// fitted by their confirmation), and `prior`'s posterior prediction spread. One
/// training simulation and the held-out evaluation instead of a Jacobian.
pub fn null_refit_from(
    prior: &NullRefit,
    model: &LabModel,
    train: &[Run],
    val: &[Run],
) -> Result<NullRefit, LabError> {
    let all = prior.params.clone();
    let obj = Objective::scaled(
        model,
        train,
        View::Shooting(SHOOTING_WINDOW_S),
        &prior.scales,
    );
    let r0 = obj.residuals(model)?;
    if all.iter().any(|p| model.get(*p).is_none()) || r0.len() != prior.jacobian.nrows() {
        return Err(LabError::Model {
            detail: "the H₀ linearisation does not fit this model".into(),
        });
    }
    let (refit, moved, _) = map_step(
        model,
        &all,
        &prior.jacobian,
        &r0,
        &obj,
        train,
        &prior.scales,
    )?;
    let eval = evaluate(&refit, val)?;
    Ok(NullRefit {
        model: refit,
        eval,
        spread: prior.spread,
        moved,
        params: all,
        jacobian: std::sync::Arc::clone(&prior.jacobian),
        scales: prior.scales,
    })
}

/// The MAP step of [`null_refit`] from `model` with the Jacobian `j` of the residual `r0`
/// (weights of `obj`), the step halved until the penalised cost falls (at most twice):
/// the refitted model, the parameters it moved by at least half their prior σ, and the
/// posterior covariance in noise weights.
#[allow(clippy::type_complexity)]
fn map_step(
    model: &LabModel,
    all: &[Param],
    j: &DMatrix<f64>,
    r0: &[f64],
    obj: &Objective<'_>,
    train: &[Run],
    scales: &ChannelScales,
) -> Result<(LabModel, Vec<(String, f64, f64)>, Option<DMatrix<f64>>), LabError> {
    let n = all.len();
    let rows = r0.len();
    let shooting = View::Shooting(SHOOTING_WINDOW_S);
    let n_eff = crate::calibrate::effective_n(r0, train.first().map_or(1, |r| r.len()));
    let infl = (rows as f64 / n_eff.max(1.0)).max(1.0);
    let bounds = bounds_for(model, all, true);
    let theta0 = model.values(all);
    let lambda: Vec<f64> = bounds
        .iter()
        .map(|b| match b.prior {
            Some((_, s)) if s > 0.0 => 1.0 / (s * s),
            _ => 0.0,
        })
        .collect();
    let mu: Vec<f64> = bounds
        .iter()
        .zip(&theta0)
        .map(|(b, v)| b.prior.map_or(*v, |(m, _)| m))
        .collect();
    let ridge = |a: &mut DMatrix<f64>| {
        let maxd = (0..n).map(|i| a[(i, i)]).fold(0.0f64, f64::max).max(1e-300);
        for i in 0..n {
            a[(i, i)] += 1e-9 * maxd + lambda[i];
        }
    };
    // The MAP step in the diagnosis' weights.
    // Products of the whole-dive Jacobian without a transposed or weighted copy of it.
    let mut a = j.tr_mul(j) / infl;
    ridge(&mut a);
    let r0v = DVector::from_column_slice(r0);
    let mut g = j.tr_mul(&r0v) / infl;
    for i in 0..n {
        g[i] += lambda[i] * (theta0[i] - mu[i]);
    }
    let penalised = |r: &[f64], th: &[f64]| -> f64 {
        r.iter().map(|x| x * x).sum::<f64>() / infl
            + th.iter()
                .zip(&mu)
                .zip(&lambda)
                .map(|((t, m), l)| l * (t - m) * (t - m))
                .sum::<f64>()
    };
    let mut refit = model.clone();
    if let Some(step) = a.clone().cholesky().map(|c| c.solve(&(-&g))) {
        let p0 = penalised(r0, &theta0);
        let mut frac = 1.0;
        for _ in 0..3 {
            let th: Vec<f64> = theta0
                .iter()
                .zip(step.iter())
                .zip(&bounds)
                .map(|((t, d), b)| (t + frac * d).clamp(b.lo, b.hi))
                .collect();
            if let Ok(m) = model.with(all, &th)
                && let Ok(r) = obj.residuals(&m)
                && r.len() == rows
                && penalised(&r, &th) < p0
            {
                refit = m;
                break;
            }
            frac *= 0.5;
        }
    }
    // The posterior covariance under H₀: the rows back to noise weights.
    let factors = crate::calibrate::row_factors(model, train, shooting, scales, &NOISE_ONLY);
    let mut an = match factors.as_ref().filter(|f| f.len() == rows) {
        Some(f) => weighted_gram(j, f),
        None => j.tr_mul(j),
    } / infl;
    ridge(&mut an);
    let cov = an.try_inverse();
    let theta1 = refit.values(all);
    let moved = all
        .iter()
        .zip(theta0.iter().zip(&theta1))
        .zip(&lambda)
        .filter(|(_, l)| **l > 0.0)
        .filter(|((_, (a, b)), l)| (**b - **a).abs() * l.sqrt() >= 0.5)
        .map(|((p, (a, b)), _)| (p.key(), p.display(*a).0, p.display(*b).0))
        .collect();
    Ok((refit, moved, cov))
}

/// JᵀF²J for the row factors f (F = diag f), summed column pair by column pair (no
/// weighted copy of J).
fn weighted_gram(j: &DMatrix<f64>, f: &[f64]) -> DMatrix<f64> {
    let p = j.ncols();
    let mut a = DMatrix::zeros(p, p);
    for c in 0..p {
        for r in 0..=c {
            let v: f64 = j
                .column(r)
                .iter()
                .zip(j.column(c).iter())
                .zip(f)
                .map(|((x, y), k)| x * k * (y * k))
                .sum();
            a[(r, c)] = v;
            a[(c, r)] = v;
        }
    }
    a
}

/// σ_θ per channel: the RMS over the held-out samples of sᵀ C s, s the sensitivities of
/// the multiple-shooting prediction to `params` (forward differences of one scale).
fn prediction_spread(
    model: &LabModel,
    params: &[Param],
    val: &[Run],
    pred: &[Prediction],
    cov: &DMatrix<f64>,
    threads: usize,
) -> [f64; N_CHANNELS] {
    let n = params.len();
    let sens: Vec<Option<PerRun>> = crate::diagnose::par_map(n, threads, |i| {
        let p = params[i];
        let v0 = model.get(p)?;
        let meta = p.meta();
        let h = if v0 + meta.scale > meta.hi {
            -meta.scale
        } else {
            meta.scale
        };
        let m = model.with(&[p], &[v0 + h]).ok()?;
        let mut out = Vec::with_capacity(val.len());
        for (run, b) in val.iter().zip(pred) {
            let pr = simulate_run(&m, run, &View::Shooting(SHOOTING_WINDOW_S).resets(run)).ok()?;
            let mut per: [Option<Vec<f64>>; N_CHANNELS] = Default::default();
            for ch in Channel::ALL {
                if let (Some(a), Some(c)) = (pr.channel(ch), b.channel(ch)) {
                    per[ch_index(ch)] = Some(
                        a.iter()
                            .zip(c)
                            .map(|(x, y)| {
                                let d = residual(ch, *y, *x) / h;
                                if d.is_finite() { d } else { 0.0 }
                            })
                            .collect(),
                    );
                }
            }
            out.push(per);
        }
        Some(out)
    });
    let mut var = [0.0; N_CHANNELS];
    let mut cnt = [0usize; N_CHANNELS];
    let mut s = vec![0.0; n];
    for (ri, run) in val.iter().enumerate() {
        for ch in Channel::ALL {
            let ci = ch_index(ch);
            if pred.get(ri).and_then(|p| p.channel(ch)).is_none() || !run.has(ch) {
                continue;
            }
            for k in 0..run.len() {
                for (a, sa) in s.iter_mut().enumerate() {
                    *sa = sens[a]
                        .as_ref()
                        .and_then(|v| v.get(ri))
                        .and_then(|per| per[ci].as_ref())
                        .and_then(|x| x.get(k))
                        .copied()
                        .unwrap_or(0.0);
                }
                let mut v = 0.0;
                for a in 0..n {
                    if s[a] == 0.0 {
                        continue;
                    }
                    for b in 0..n {
                        v += s[a] * cov[(a, b)] * s[b];
                    }
                }
                var[ci] += v.max(0.0);
                cnt[ci] += 1;
            }
        }
    }
    let mut out = [0.0; N_CHANNELS];
    for i in 0..N_CHANNELS {
        if cnt[i] > 0 {
            out[i] = (var[i] / cnt[i] as f64).sqrt();
        }
    }
    out
}

/// The measured state a multiple-shooting reset takes from the data ([`crate::sim`]'s
/// re-initialisation: positions and angles, measured rates and body velocities).
const RESET_CHANNELS: [Channel; 12] = Channel::ALL;

/// The smoothed reading's standard error at sample `k` in units of the channel's noise
/// floor: √(e₁ᵀ(ΦᵀΦ)⁻¹e₁) of the local quadratic least-squares fit over ±0.3 s that
/// [`Run::smooth`] holds (white noise; the leverage of the fit at its centre — about
/// 0.42 for 13 samples at 20 Hz).
fn smoothing_error(t: &[f64], y: &[f64], k: usize) -> Option<f64> {
    let tk = *t.get(k)?;
    let mut s = nalgebra::Matrix3::<f64>::zeros();
    let mut n = 0usize;
    for (tj, yj) in t.iter().zip(y) {
        let x = tj - tk;
        if x.abs() > 0.3 + 1e-9 || !yj.is_finite() {
            continue;
        }
        let phi = nalgebra::Vector3::new(1.0, x, x * x);
        s += phi * phi.transpose();
        n += 1;
    }
    if n < 4 {
        return None;
    }
    let inv = s.try_inverse()?;
    let h = inv[(0, 0)];
    (h.is_finite() && h > 0.0).then(|| h.min(1.0).sqrt())
}

/// σ_x per channel: the prediction spread that the reset states' own uncertainty leaves.
/// Every multiple-shooting window starts from the smoothed readings at its first sample
/// ([`crate::sim`]), each off by its smoothing error (the channel's noise floor times
/// [`smoothing_error`]); a lightly damped axis (pitch and roll on their restoring
/// moment) rings from such a start for seconds, which the noise floor does not cover
/// (on a calm station dive the documented model3, the simulator's own vehicle, missed
/// pitch rate by 1.3 noise floors in the shooting view and by 0.98 in the free run). Per
/// reset channel one simulation with every window's start moved by its smoothing error
/// (windows restart independently, so one run gives every window's sensitivity); the
/// mean squared prediction changes are added over the reset channels (independent errors,
/// linearised). The run-start sample, which the data takes from a line over the first
/// rest instead, is counted with the same centred error (an approximation).
pub fn reset_spread(
    model: &LabModel,
    val: &[Run],
    pred: &[Prediction],
    threads: usize,
) -> [f64; N_CHANNELS] {
    let view = View::Shooting(SHOOTING_WINDOW_S);
    let jobs: Vec<(usize, Channel)> = val
        .iter()
        .enumerate()
        .flat_map(|(ri, run)| {
            RESET_CHANNELS
                .iter()
                .filter(|ch| run.smooth[ch_index(**ch)].is_some() && run.has(**ch))
                .map(move |ch| (ri, *ch))
        })
        .collect();
    let per_job: Vec<Option<[(f64, usize); N_CHANNELS]>> =
        crate::diagnose::par_map(jobs.len(), threads, |j| {
            let (ri, ch) = jobs[j];
            let run = &val[ri];
            let i = ch_index(ch);
            let y = run.y[i].as_ref()?;
            let resets = view.resets(run);
            let mut moved = run.clone();
            let sm = moved.smooth[i].as_mut()?;
            for &k in &resets {
                if let (Some(f), Some(v)) = (smoothing_error(&run.t, y, k), sm.get_mut(k)) {
                    *v += f * run.noise[i];
                }
            }
            let pr = simulate_run(model, &moved, &resets).ok()?;
            let base = pred.get(ri)?;
            let mut out = [(0.0, 0usize); N_CHANNELS];
            for c in Channel::ALL {
                if let (Some(a), Some(b)) = (pr.channel(c), base.channel(c)) {
                    let o = &mut out[ch_index(c)];
                    for (x, y) in a.iter().zip(b) {
                        let d = residual(c, *y, *x);
                        if d.is_finite() {
                            o.0 += d * d;
                            o.1 += 1;
                        }
                    }
                }
            }
            Some(out)
        });
    // Per channel: the variances of the reset channels added (per run, each variant's
    // mean square), pooled over the runs by sample count.
    let mut var = [0.0; N_CHANNELS];
    let mut cnt = [0usize; N_CHANNELS];
    for (ri, run) in val.iter().enumerate() {
        let mut sum = [0.0; N_CHANNELS];
        let mut seen = [false; N_CHANNELS];
        for (j, (r, _)) in jobs.iter().enumerate() {
            if *r != ri {
                continue;
            }
            if let Some(Some(o)) = per_job.get(j) {
                for c in 0..N_CHANNELS {
                    if o[c].1 > 0 {
                        sum[c] += o[c].0 / o[c].1 as f64;
                        seen[c] = true;
                    }
                }
            }
        }
        for c in (0..N_CHANNELS).filter(|c| seen[*c]) {
            var[c] += sum[c] * run.len() as f64;
            cnt[c] += run.len();
        }
    }
    let mut out = [0.0; N_CHANNELS];
    for c in 0..N_CHANNELS {
        if cnt[c] > 0 {
            out[c] = (var[c] / cnt[c] as f64).sqrt();
        }
    }
    out
}

/// Per held-out run, per channel: a sensitivity series.
type PerRun = Vec<[Option<Vec<f64>>; N_CHANNELS]>;

/// Resolution of a Pro 4 thrust command on the link, percent: the station sends whole
/// percent (`rov_types::conventions`, the wire's thrust value is the rounded percentage).
pub const PRO4_COMMAND_RESOLUTION_PCT: f64 = 1.0;

/// σ_u per channel: the prediction spread that the recorded commands' own uncertainty
/// leaves, from two independent sources, each the RMS change of the held-out
/// multiple-shooting prediction `pred` under one variant of the commands (variances
/// added):
///
/// * **Resolution.** A Pro 4 receives its thrust in whole percent while a station log
///   records the autopilot's unrounded demand, so the command the vehicle ran is known
///   only to ±0.5 %: the commands rounded to [`PRO4_COMMAND_RESOLUTION_PCT`] (nothing
///   for commands already on that lattice, or for vehicle files, which document no
///   resolution).
/// * **Timing.** A log aligns a command with the measurements only to within one sample:
///   a station records the command it computed with the last measurement it had, and
///   the vehicle applies it when it arrives, up to one exchange later. The commands
///   delayed by one sample. (For held steps this matters only at the edges; for an
///   autopilot's demand, which changes every sample, it is the whole signal.)
pub fn input_spread(model: &LabModel, val: &[Run], pred: &[Prediction]) -> [f64; N_CHANNELS] {
    let mut var = [0.0; N_CHANNELS];
    let mut cnt = [0usize; N_CHANNELS];
    let resolution = model.command_resolution_pct();
    for (run, p) in val.iter().zip(pred) {
        let mut variants: Vec<Run> = Vec::new();
        if let Some(q) = resolution {
            let mut rounded = run.clone();
            let mut changed = false;
            for c in rounded.inputs.iter_mut() {
                for x in c.iter_mut() {
                    let r = (*x / q).round() * q;
                    changed |= (r - *x).abs() > 1e-9;
                    *x = r;
                }
            }
            if changed {
                variants.push(rounded);
            }
        }
        let mut delayed = run.clone();
        for k in (1..delayed.inputs.len()).rev() {
            delayed.inputs[k] = delayed.inputs[k - 1];
        }
        variants.push(delayed);
        let mut sum = [0.0; N_CHANNELS];
        let mut n = [0usize; N_CHANNELS];
        for v in &variants {
            let Ok(pr) = simulate_run(model, v, &View::Shooting(SHOOTING_WINDOW_S).resets(run))
            else {
                continue;
            };
            for ch in Channel::ALL {
                if let (Some(a), Some(b)) = (pr.channel(ch), p.channel(ch)) {
                    let i = ch_index(ch);
                    for (x, y) in a.iter().zip(b) {
                        let d = residual(ch, *y, *x);
                        if d.is_finite() {
                            sum[i] += d * d;
                            n[i] += 1;
                        }
                    }
                }
            }
        }
        // Per sample: the variances of the variants added (each variant's mean square).
        let per_variant = variants.len().max(1);
        for i in 0..N_CHANNELS {
            if n[i] > 0 {
                var[i] += sum[i];
                cnt[i] += n[i] / per_variant;
            }
        }
    }
    let mut out = [0.0; N_CHANNELS];
    for i in 0..N_CHANNELS {
        if cnt[i] > 0 {
            out[i] = (var[i] / cnt[i] as f64).sqrt();
        }
    }
    out
}
