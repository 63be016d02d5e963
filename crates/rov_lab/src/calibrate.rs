//! Calibration: bounded Levenberg–Marquardt on the simulation error over several runs,
//! with parameter uncertainty.
//!
//! The objective stacks, over all runs and compared channels, the residuals e = ŷ − y of
//! a multiple-shooting simulation (re-initialised at manoeuvre-segment starts at least
//! [`SHOOTING_WINDOW_S`] apart), each divided by the channel's noise floor. Missing
//! samples contribute zero, so the residual vector keeps its length.
//!
//! # Channel weights (unknown per-channel error variance)
//!
//! Dividing by the sensor noise alone lets a channel the model cannot explain at all (a
//! pitch response to a missing moment arm at 15 noise floors, an unmodelled surge at 10)
//! dominate the cost, and the base parameters then bend to shave that channel's error
//! (an added mass ten times its prior, a CG height an eighth of it) at the expense of the
//! channels the base *can* explain. Fits therefore weight channel c by
//! 1/max(σ_noise,c, s_c), where s_c is the structural part of the channel's
//! multiple-shooting RMSE under the reference model ([`misfit_scales`],
//! [`structural_scales`]; one scale per channel for every view): the maximum-likelihood
//! criterion for unknown per-channel error variances (minimising Σ_c N_c ln RSS_c,
//! MATLAB's "determinant" criterion), solved by iterative reweighting. The weights are
//! taken from a *converged* fit — [`staged_fit`] first calibrates with noise weights and
//! reweights only the channels that fit still misses by more than [`REWEIGHT_FACTOR`]
//! noise floors (weights from an unconverged start would penalise mere mistuning), and the
//! diagnosis re-estimates them after every accepted effect. A channel within a couple of
//! noise floors keeps its noise weight, so on effect-free data the weights are the plain
//! noise weights.
//!
//! # Never worse than the prior
//!
//! A parameter whose own axis the data barely moves (its channels within three noise
//! floors, [`axis_excitation`]) is set by its documented prior, not by the data; but the
//! short-horizon first stage can carry such parameters far from the prior into a basin
//! the multiple-shooting stages cannot leave (on an effect-free station dive whose depth
//! hold barely moved pitch, the pitch damping ended 3.7 documented σ from the true value
//! and the model was worse on the training runs than the uncalibrated base). So the
//! calibration's result is never worse, by its own criterion (Σ_c N_c ln MSE_c over the
//! channels, multiple shooting: the maximum-likelihood criterion for unknown per-channel
//! error variances), than two points it can name without fitting: the staged fit with
//! every parameter of a barely excited or unmeasured axis put back at its prior mean, and
//! the uncalibrated base. When one is better, a multiple-shooting stage continues from
//! the best of them ([`calibrate`]). On data where the staged fit is already better, this
//! costs one training simulation per point.
//!
//! Free base parameters ([`BaseKind::calibration_params`]): thrust scales (linear and
//! quadratic part of each thruster's map), heave and yaw damping (linear, quadratic),
//! and for model3 roll/pitch linear damping and the CG height (restoring stiffness).
//! Mass, inertia and added masses stay fixed: with motion data, thrust gain, damping and
//! inertia are determined only up to a common scale.

use rov_dynamics::models::Channel;
use serde::Serialize;

use crate::LabError;
use crate::data::{N_CHANNELS, Run, ch_index};
use crate::lm::{Bound, LmOptions, LmResult, minimize_with};
use crate::model::LabModel;
use crate::params::{Axis, Param, Thr};
use crate::sim::{compared_channels, simulate_run};

/// Shortest multiple-shooting window, s.
pub const SHOOTING_WINDOW_S: f64 = 20.0;

/// Which error view an objective uses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum View {
    /// One initialisation at the start.
    FreeRun,
    /// Re-initialised at segment starts at least this many seconds apart.
    Shooting(f64),
    /// Re-initialised every k samples.
    KStep(usize),
}

impl View {
    /// Reset indices for a run.
    pub fn resets(self, run: &Run) -> Vec<usize> {
        match self {
            View::FreeRun => vec![0],
            View::Shooting(w) => run.shooting_starts(w),
            View::KStep(k) => run.every_k(k),
        }
    }
}

/// Per-channel model-misfit scales (index as [`Channel::ALL`], same unit as the channel);
/// 0 = weight by the noise floor only.
pub type ChannelScales = [f64; N_CHANNELS];

/// No misfit scales: plain noise weights.
pub const NOISE_ONLY: ChannelScales = [0.0; N_CHANNELS];

/// A stacked, noise-normalised simulation-error objective over runs.
#[derive(Debug, Clone)]
pub struct Objective<'a> {
    /// The runs.
    pub runs: &'a [Run],
    /// Reset indices per run.
    pub resets: Vec<Vec<usize>>,
    /// Channels used.
    pub channels: Vec<Channel>,
    /// Per run, per channel (index as `Channel::ALL`) weight 1/σ.
    pub weights: Vec<[f64; 12]>,
}

impl<'a> Objective<'a> {
    /// Builds the objective for a model's predicted channels (noise weights).
    pub fn new(model: &LabModel, runs: &'a [Run], view: View) -> Self {
        Self::scaled(model, runs, view, &NOISE_ONLY)
    }

    /// Builds the objective with channel weights 1/max(σ_noise, s_c) (see the module
    /// documentation).
    pub fn scaled(model: &LabModel, runs: &'a [Run], view: View, scales: &ChannelScales) -> Self {
        let mut channels: Vec<Channel> = Vec::new();
        for run in runs {
            for c in compared_channels(model, run) {
                if !channels.contains(&c) {
                    channels.push(c);
                }
            }
        }
        let weights = runs
            .iter()
            .map(|r| {
                let mut w = [0.0; 12];
                for c in &channels {
                    let i = ch_index(*c);
                    let sigma = r.noise[i].max(scales[i]);
                    if sigma > 0.0 && sigma.is_finite() {
                        w[i] = 1.0 / sigma;
                    }
                }
                w
            })
            .collect();
        Self {
            runs,
            resets: runs.iter().map(|r| view.resets(r)).collect(),
            channels,
            weights,
        }
    }

    /// Number of residuals.
    pub fn len(&self) -> usize {
        self.runs.iter().map(|r| r.len()).sum::<usize>() * self.channels.len()
    }

    /// Whether there are no residuals.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The stacked weighted residuals of a model.
    pub fn residuals(&self, model: &LabModel) -> Result<Vec<f64>, LabError> {
        let mut out = Vec::with_capacity(self.len());
        for (ri, run) in self.runs.iter().enumerate() {
            let pred = simulate_run(model, run, &self.resets[ri])?;
            for ch in &self.channels {
                let i = ch_index(*ch);
                let w = self.weights[ri][i];
                match (run.channel(*ch), pred.channel(*ch)) {
                    (Some(y), Some(p)) => {
                        out.extend(y.iter().zip(p).map(|(a, b)| {
                            let e = crate::metrics::residual(*ch, *a, *b) * w;
                            if e.is_finite() { e } else { 0.0 }
                        }));
                    }
                    _ => out.extend(std::iter::repeat_n(0.0, run.len())),
                }
            }
        }
        Ok(out)
    }

    /// Sum of squared weighted residuals per channel (index as `self.channels`).
    pub fn channel_costs(&self, r: &[f64]) -> Vec<f64> {
        let mut costs = vec![0.0; self.channels.len()];
        let mut off = 0;
        for run in self.runs {
            for c in costs.iter_mut() {
                *c += r[off..off + run.len()].iter().map(|x| x * x).sum::<f64>();
                off += run.len();
            }
        }
        costs
    }
}

/// Pooled RMSE per channel of a model on runs in a view: the misfit scales of the
/// objective's channel weights. Channels the model does not predict stay 0.
pub fn misfit_scales(
    model: &LabModel,
    runs: &[Run],
    view: View,
) -> Result<ChannelScales, LabError> {
    let mut sum = [0.0; N_CHANNELS];
    let mut cnt = [0usize; N_CHANNELS];
    for run in runs {
        let pred = simulate_run(model, run, &view.resets(run))?;
        for ch in compared_channels(model, run) {
            let i = ch_index(ch);
            if let (Some(y), Some(p)) = (run.channel(ch), pred.channel(ch)) {
                for (a, b) in y.iter().zip(p) {
                    let e = crate::metrics::residual(ch, *a, *b);
                    if e.is_finite() {
                        sum[i] += e * e;
                        cnt[i] += 1;
                    }
                }
            }
        }
    }
    let mut out = NOISE_ONLY;
    for i in 0..N_CHANNELS {
        if cnt[i] > 0 {
            out[i] = (sum[i] / cnt[i] as f64).sqrt();
        }
    }
    Ok(out)
}

/// Effective sample size of a residual vector split into blocks of `block` samples:
/// N·(1 − ρ₁)/(1 + ρ₁) with the pooled lag-1 autocorrelation (at least 1 % of N).
pub fn effective_n(r: &[f64], block: usize) -> f64 {
    let n = r.len() as f64;
    let (mut c0, mut c1) = (0.0, 0.0);
    for chunk in r.chunks(block.max(2)) {
        for w in chunk.windows(2) {
            c1 += w[0] * w[1];
        }
        c0 += chunk.iter().map(|x| x * x).sum::<f64>();
    }
    if c0 <= 0.0 {
        return n;
    }
    let rho = (c1 / c0).clamp(0.0, 0.999);
    (n * (1.0 - rho) / (1.0 + rho)).max(0.01 * n).max(1.0)
}

/// A fitted parameter with its uncertainty.
#[derive(Debug, Clone, Serialize)]
pub struct FittedParam {
    /// Key.
    pub key: String,
    /// Value (display units).
    pub value: f64,
    /// Standard deviation (display units), N/N_eff-inflated.
    pub std: f64,
    /// Display unit.
    pub unit: String,
    /// Whether the value sits at a bound.
    pub at_bound: bool,
    /// Value before the fit (display units).
    pub initial: f64,
}

/// Result of a calibration.
#[derive(Debug, Clone)]
pub struct Calibration {
    /// The calibrated model.
    pub model: LabModel,
    /// Free parameters.
    pub params: Vec<Param>,
    /// Their fitted values and uncertainties.
    pub fitted: Vec<FittedParam>,
    /// Weighted cost before and after.
    pub cost0: f64,
    /// Weighted cost after.
    pub cost: f64,
    /// Residual count.
    pub n_res: usize,
    /// Effective residual count.
    pub n_eff: f64,
    /// The LM result (Jacobian for screening).
    pub lm: LmResult,
    /// The channel misfit scales of the objective's weights.
    pub scales: ChannelScales,
}

impl Calibration {
    /// The fit without its linearisation (the Jacobian and residual over the whole
    /// training data), for a fit read only for its model, costs and uncertainties: a
    /// diagnosis keeps many (every confirmed candidate's), and each would hold a whole
    /// dive's rows × parameters.
    pub fn lean(mut self) -> Self {
        self.lm.jacobian = None;
        self.lm.residuals = Vec::new();
        self
    }
}

/// Whether some thruster of group `g` runs in the data (|command| ≥ 5 %); with
/// `reverse`, runs in reverse.
pub fn group_used(model: &LabModel, runs: &[Run], g: Thr, reverse: bool) -> bool {
    if !model.has_group(g) {
        return false;
    }
    let n = model.n_thrusters();
    runs.iter().any(|r| {
        r.inputs.iter().any(|c| {
            let t = model.thruster_targets(c);
            (0..n).any(|i| {
                model.thruster_group(i) == g
                    && if reverse {
                        t[i] <= -5.0
                    } else {
                        t[i].abs() >= 5.0
                    }
            })
        })
    })
}

/// Whether the data drives a group's thrusters with both signs at once on different
/// thrusters or differentially (a yaw or roll demand): some sample has two thrusters of
/// the group (or the Pro 4's port and starboard) commanded apart by at least 5 %.
pub fn differential_used(model: &LabModel, runs: &[Run]) -> bool {
    let n = model.n_thrusters();
    runs.iter().any(|r| {
        r.inputs.iter().any(|c| {
            let t = model.thruster_targets(c);
            (0..n).any(|i| {
                (0..n).any(|j| {
                    i < j
                        && model.thruster_group(i) != Thr::Vertical
                        && model.thruster_group(j) != Thr::Vertical
                        && (t[i] - t[j]).abs() >= 5.0
                })
            })
        })
    })
}

/// Whether a parameter can be excited by the data (thruster used, channel measured).
pub fn excited(model: &LabModel, runs: &[Run], p: Param) -> bool {
    let used = |t: Thr| group_used(model, runs, t, false);
    let has = |ch: Channel| runs.iter().any(|r| r.has(ch)) && model.predicts_channel(ch);
    let heading_or_rate = has(Channel::Heading) || has(Channel::YawRate);
    match p {
        Param::ThrustLin(t) | Param::ThrustQuad(t) => {
            used(t)
                && match t {
                    Thr::Vertical => has(Channel::Depth) || has(Channel::Heave),
                    _ => heading_or_rate || has(Channel::Surge) || has(Channel::North),
                }
        }
        Param::DragLin(a) | Param::DragQuad(a) => match a {
            Axis::Heave => has(Channel::Depth) || has(Channel::Heave),
            Axis::Yaw => heading_or_rate,
            Axis::Roll => has(Channel::Roll) || has(Channel::RollRate),
            Axis::Pitch => has(Channel::Pitch) || has(Channel::PitchRate),
            Axis::Surge => has(Channel::Surge) || has(Channel::North) || has(Channel::East),
            Axis::Sway => has(Channel::Sway),
        },
        Param::CgZ => has(Channel::Pitch) || has(Channel::Roll),
        Param::AddedMass(Axis::Sway) => {
            (has(Channel::Roll) || has(Channel::Heading) || has(Channel::Sway))
                && model.has_attitude()
        }
        Param::AddedMass(Axis::Roll) => has(Channel::Roll),
        Param::AddedMass(Axis::Pitch) => has(Channel::Pitch),
        _ => true,
    }
}

/// Bounds with priors: a base parameter's documented prior (the base file's value and its
/// documented uncertainty, [`LabModel::prior_of`]); with `prior_at_current`, any other
/// parameter gets a weak prior at its current value (keeps unexcited directions put).
pub fn bounds_for(model: &LabModel, params: &[Param], prior_at_current: bool) -> Vec<Bound> {
    params
        .iter()
        .map(|p| {
            let m = p.meta();
            let v = model.get(*p).or_else(|| p.off_value()).unwrap_or(0.0);
            let prior = model
                .prior_of(*p)
                .or_else(|| prior_at_current.then(|| (v, (v.abs() * 2.0).max(m.scale * 20.0))));
            Bound {
                lo: m.lo,
                hi: m.hi,
                scale: m.scale,
                prior,
            }
        })
        .collect()
}

/// Fits `free` parameters of `model` on `runs` with the given view.
pub fn fit(
    model: &LabModel,
    runs: &[Run],
    free: &[Param],
    view: View,
    x0: Option<&[f64]>,
    bounds: Option<Vec<Bound>>,
    opts: &LmOptions,
) -> Result<Calibration, LabError> {
    fit_scaled(model, runs, free, view, x0, bounds, opts, None, &NOISE_ONLY)
}

/// [`fit`] with an optional starting Jacobian `j0` (Broyden updates afterwards, see
/// [`crate::lm::minimize_with`]) and channel misfit scales in the weights (see the
/// module documentation).
#[allow(clippy::too_many_arguments)]
pub fn fit_scaled(
    model: &LabModel,
    runs: &[Run],
    free: &[Param],
    view: View,
    x0: Option<&[f64]>,
    bounds: Option<Vec<Bound>>,
    opts: &LmOptions,
    j0: Option<nalgebra::DMatrix<f64>>,
    scales: &ChannelScales,
) -> Result<Calibration, LabError> {
    let obj = Objective::scaled(model, runs, view, scales);
    if obj.is_empty() {
        return Err(LabError::Data {
            run: runs
                .first()
                .map(|r| r.name.clone())
                .unwrap_or_else(|| "(no runs)".into()),
            detail: format!(
                "no channel is both measured and predicted by {}",
                model.base_name()
            ),
        });
    }
    let bounds = bounds.unwrap_or_else(|| bounds_for(model, free, true));
    let start = x0.map(|v| v.to_vec()).unwrap_or_else(|| model.values(free));
    let f = |x: &[f64]| -> Option<Vec<f64>> {
        let m = model.with(free, x).ok()?;
        obj.residuals(&m).ok()
    };
    let lm = minimize_with(&f, &start, &bounds, opts, j0).ok_or_else(|| LabError::Model {
        detail: format!(
            "{} cannot be simulated on the data from its starting parameters",
            model.base_name()
        ),
    })?;
    let fitted_model = model.with(free, &lm.x)?;
    let n_eff = effective_n(&lm.residuals, runs.first().map_or(1, |r| r.len()));
    let inflation = lm.n_res as f64 / n_eff.max(1.0);
    let std = lm.std_devs(inflation);
    let fitted = free
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let (v, unit) = p.display(lm.x[i]);
            let (s, _) = p.display(std[i]);
            let (v0, _) = p.display(start[i]);
            let b = &bounds[i];
            FittedParam {
                key: p.key(),
                value: v,
                std: s.abs(),
                unit: unit.to_string(),
                at_bound: (lm.x[i] - b.lo).abs() < 1e-9 * b.scale.max(1e-12)
                    || (lm.x[i] - b.hi).abs() < 1e-9 * b.scale.max(1e-12),
                initial: v0,
            }
        })
        .collect();
    Ok(Calibration {
        model: fitted_model,
        params: free.to_vec(),
        fitted,
        cost0: lm.cost0,
        cost: lm.cost,
        n_res: lm.n_res,
        n_eff,
        lm,
        scales: *scales,
    })
}

/// Calibrates a model's base parameters (those the data excites): first on a short
/// horizon (re-initialised every [`SHORT_HORIZON_S`], where heading errors stay far from
/// ±180° even for a badly tuned start), then on multiple-shooting windows; a second start
/// when that leaves a channel far off, and never worse than the prior (module
/// documentation).
pub fn calibrate(
    model: &LabModel,
    runs: &[Run],
    opts: &LmOptions,
) -> Result<Calibration, LabError> {
    let free: Vec<Param> = model
        .calibration_params()
        .into_iter()
        .filter(|p| excited(model, runs, *p))
        .collect();
    let a = staged_fit(model, runs, &free, opts)?;
    let cal = second_start(model, runs, &free, opts, a)?;
    back_to_the_prior(model, runs, &free, opts, cal)
}

/// The second start of [`calibrate`]. The short-horizon start can end in a poor basin (a
/// channel the base could fit left several noise floors off). Then one more start, begun
/// with a multiple-shooting fit: from the first result with every parameter that moved
/// more than one documented σ from its prior mean put back there (a basin reached by
/// trading one parameter against another far from where the documentation puts them),
/// or, when none did, from the uncalibrated base. The better by the maximum-likelihood
/// criterion for unknown per-channel error variances (Σ_c N_c ln MSE_c) is kept. (From
/// the reset point a short-horizon first stage led straight back to the poor basin: on
/// probe case 15, no effect, thrust scales 0.80/0.67/0.56 against the truth's
/// 1.13/0.98/0.83 and "unexplained: heading 4.8×"; begun in multiple shooting the
/// criterion falls from −53112 to −57935 and heading is consistent.)
fn second_start(
    model: &LabModel,
    runs: &[Run],
    free: &[Param],
    opts: &LmOptions,
    a: Calibration,
) -> Result<Calibration, LabError> {
    if worst_misfit_ratio(&a.model, runs)? <= SECOND_START_RATIO {
        return Ok(a);
    }
    let values = a.model.values(free);
    let mut moved = false;
    let reset: Vec<f64> = free
        .iter()
        .zip(&values)
        .map(|(p, v)| match model.prior_of(*p) {
            Some((mean, sigma)) if (v - mean).abs() > sigma => {
                moved = true;
                mean
            }
            _ => *v,
        })
        .collect();
    let bar = det_criterion(&a.model, runs)?;
    let second = if moved {
        a.model
            .with(free, &reset)
            .and_then(|start| staged_fit_from(&start, runs, free, opts, false, Some(bar)))
    } else {
        staged_fit_from(model, runs, free, opts, false, Some(bar))
    };
    match second {
        Ok(b) if det_criterion(&b.model, runs)? < bar => Ok(b),
        _ => Ok(a),
    }
}

/// The body axes a base parameter acts on directly (empty for thrust scales, which act
/// through the thrusters on several): the CG height sets the restoring moment of both
/// roll and pitch.
fn own_axes(p: Param) -> &'static [Axis] {
    match p {
        Param::CgZ => &[Axis::Roll, Axis::Pitch],
        Param::AddedMass(a) | Param::DragLin(a) | Param::DragQuad(a) => match a {
            Axis::Surge => &[Axis::Surge],
            Axis::Sway => &[Axis::Sway],
            Axis::Heave => &[Axis::Heave],
            Axis::Roll => &[Axis::Roll],
            Axis::Pitch => &[Axis::Pitch],
            Axis::Yaw => &[Axis::Yaw],
        },
        _ => &[],
    }
}

/// The free parameters (indices into `free`) whose own axes the runs barely excite or do
/// not measure at all ([`axis_excitation`]), with their documented prior means.
fn unexcited_with_prior(model: &LabModel, runs: &[Run], free: &[Param]) -> Vec<(usize, f64)> {
    free.iter()
        .enumerate()
        .filter(|(_, p)| {
            let axes = own_axes(**p);
            !axes.is_empty()
                && axes
                    .iter()
                    .all(|a| axis_excitation(runs, *a) != AxisExcitation::Excited)
        })
        .filter_map(|(i, p)| model.prior_of(*p).map(|(mean, _)| (i, mean)))
        .collect()
}

/// The last safeguard of [`calibrate`]: the calibration never ends worse, by its own
/// criterion (Σ_c N_c ln MSE_c, multiple shooting), than two points it can name without
/// fitting — the calibrated model with every parameter of a barely excited or unmeasured
/// axis ([`unexcited_with_prior`]) put back at its documented prior mean, and the
/// uncalibrated base itself. A parameter the data hardly moves is set by the prior, and
/// a short-horizon start can carry such parameters far from it into a basin the
/// multiple-shooting stages cannot leave (an effect-free station dive whose calm depth
/// hold barely moves pitch ended with the pitch damping 3.7 documented σ from the truth,
/// worse on the training runs than the prior itself). When one of them is better, one
/// more multiple-shooting stage (the last stage's weights, continued while it still
/// gains like the others) starts from the best, and its result is kept if it is still
/// better than the staged fit. Costs one training simulation per point otherwise.
fn back_to_the_prior(
    model: &LabModel,
    runs: &[Run],
    free: &[Param],
    opts: &LmOptions,
    cal: Calibration,
) -> Result<Calibration, LabError> {
    let mut points: Vec<LabModel> = Vec::new();
    let unexcited = unexcited_with_prior(model, runs, free);
    if !unexcited.is_empty() {
        let mut v = cal.model.values(free);
        for (i, mean) in &unexcited {
            v[*i] = *mean;
        }
        points.push(cal.model.with(free, &v)?);
    }
    points.push(model.clone());
    let bar = det_criterion(&cal.model, runs)?;
    let mut best: Option<(f64, LabModel)> = None;
    for m in points {
        let c = det_criterion(&m, runs)?;
        if c < bar && best.as_ref().is_none_or(|(b, _)| c < *b) {
            best = Some((c, m));
        }
    }
    let Some((_, start)) = best else {
        return Ok(cal);
    };
    let shooting = View::Shooting(SHOOTING_WINDOW_S);
    let bounds = || Some(bounds_for(model, free, true));
    let Ok(mut last) = fit_scaled(
        &start,
        runs,
        free,
        shooting,
        None,
        bounds(),
        opts,
        None,
        &cal.scales,
    ) else {
        return Ok(cal);
    };
    for round in 0..MAX_MORE_ROUNDS {
        if !another_round(&last, round) {
            break;
        }
        last = last.lean();
        last = fit_scaled(
            &last.model,
            runs,
            free,
            shooting,
            None,
            bounds(),
            opts,
            None,
            &cal.scales,
        )?;
    }
    Ok(if det_criterion(&last.model, runs)? < bar {
        last
    } else {
        cal
    })
}

/// A calibration whose worst channel misfits its training runs by more than this many
/// noise floors (multiple shooting) gets a second start (see [`calibrate`]).
pub const SECOND_START_RATIO: f64 = 2.5;

/// The largest training misfit of a model in noise floors (multiple shooting).
fn worst_misfit_ratio(model: &LabModel, runs: &[Run]) -> Result<f64, LabError> {
    let m = misfit_scales(model, runs, View::Shooting(SHOOTING_WINDOW_S))?;
    let mut worst: f64 = 0.0;
    for (i, mi) in m.iter().enumerate() {
        let (mut s, mut n) = (0.0, 0usize);
        for r in runs {
            if r.y[i].is_some() {
                s += r.noise[i].powi(2) * r.len() as f64;
                n += r.len();
            }
        }
        if n > 0 && *mi > 0.0 {
            worst = worst.max(mi / (s / n as f64).sqrt().max(1e-12));
        }
    }
    Ok(worst)
}

/// Σ_c N_c ln MSE_c over the compared channels (multiple shooting): the ML criterion for
/// unknown per-channel error variances (lower is better).
fn det_criterion(model: &LabModel, runs: &[Run]) -> Result<f64, LabError> {
    let m = misfit_scales(model, runs, View::Shooting(SHOOTING_WINDOW_S))?;
    let mut out = 0.0;
    for (i, mi) in m.iter().enumerate() {
        let n: usize = runs
            .iter()
            .filter(|r| r.y[i].is_some())
            .map(|r| r.len())
            .sum();
        if n > 0 && *mi > 0.0 {
            out += n as f64 * (mi * mi).ln();
        }
    }
    Ok(out)
}

/// Short prediction horizon of the first calibration stage, s.
pub const SHORT_HORIZON_S: f64 = 2.0;

/// The staged fit of [`calibrate`] for any free set, with one reweighting of the
/// channels (module documentation):
///
/// 1. short horizon, then multiple shooting, with noise weights, from the given model
///    (the original calibration);
/// 2. if that converged fit leaves some channel above [`REWEIGHT_FACTOR`] noise floors
///    (a misfit the base cannot remove, not a mistuning it has not removed yet), both
///    stages again with weights from that structural misfit ([`structural_scales`]): the
///    short horizon started from the better (under the new weights) of the given model
///    and the stage-1 short-horizon result (from the latter with its Jacobian, rows
///    reweighted, and Broyden updates: cheap), then multiple shooting with the weights
///    re-estimated from there (fresh Jacobians).
pub fn staged_fit(
    model: &LabModel,
    runs: &[Run],
    free: &[Param],
    opts: &LmOptions,
) -> Result<Calibration, LabError> {
    staged_fit_from(model, runs, free, opts, true, None)
}

/// [`staged_fit`], its very first fit on the short horizon (`short_first`) or in
/// multiple shooting. With `abandon_above`, a start whose first multiple-shooting fit is
/// no better than that criterion (Σ_c N_c ln MSE_c) stops there: a further start that is
/// not already better after its first stages seldom wins, and the stages after them
/// are most of the cost.
fn staged_fit_from(
    model: &LabModel,
    runs: &[Run],
    free: &[Param],
    opts: &LmOptions,
    short_first: bool,
    abandon_above: Option<f64>,
) -> Result<Calibration, LabError> {
    let dt = runs.first().map_or(0.05, |r| r.median_dt()).max(1e-3);
    let k = (SHORT_HORIZON_S / dt).round().max(2.0) as usize;
    let short = View::KStep(k);
    let shooting = View::Shooting(SHOOTING_WINDOW_S);
    let first_view = if short_first { short } else { shooting };
    crate::progress::stage("calibrating", 1, 4, "stages");
    let mut short_fit = fit(model, runs, free, first_view, None, None, opts)?;
    if !short_fit.lm.converged {
        short_fit = short_fit.lean();
        short_fit = fit(&short_fit.model, runs, free, first_view, None, None, opts)?;
    }
    crate::progress::stage("calibrating", 2, 4, "stages");
    let mut noise_fit = fit(
        &short_fit.model,
        runs,
        free,
        shooting,
        None,
        Some(bounds_for(model, free, true)),
        &LmOptions {
            max_iter: (opts.max_iter / 2).max(3),
            ..*opts
        },
    )?;
    if let Some(bar) = abandon_above
        && det_criterion(&noise_fit.model, runs)? >= bar
    {
        return Ok(noise_fit);
    }
    // The reweighting below must judge a converged fit: a channel a still-moving fit has
    // not reached yet is not a structural misfit. Continue until the noise-weighted fit
    // has converged ([`another_round`]).
    for round in 0..MAX_MORE_ROUNDS {
        if !another_round(&noise_fit, round) {
            break;
        }
        // Only the last round's linearisation is ever read: a whole dive's Jacobian
        // less while the next round builds its own.
        noise_fit = noise_fit.lean();
        noise_fit = fit(
            &noise_fit.model,
            runs,
            free,
            shooting,
            None,
            Some(bounds_for(model, free, true)),
            &LmOptions {
                max_iter: opts.max_iter,
                ..*opts
            },
        )?;
    }
    let s1 = structural_scales(runs, &misfit_scales(&noise_fit.model, runs, shooting)?);
    if s1 == NOISE_ONLY {
        return Ok(noise_fit);
    }
    drop(noise_fit);
    let rows = row_factors(model, runs, short, &NOISE_ONLY, &s1);
    let obj = Objective::scaled(model, runs, short, &s1);
    let cost = |m: &LabModel| -> f64 {
        obj.residuals(m)
            .map(|r| r.iter().map(|x| x * x).sum())
            .unwrap_or(f64::INFINITY)
    };
    let (start, j0) = if cost(&short_fit.model) <= cost(model) {
        let j0 = short_fit.lm.jacobian.take().map(|mut j| {
            if let Some(f) = &rows
                && f.len() == j.nrows()
            {
                for c in 0..j.ncols() {
                    for (x, k) in j.column_mut(c).iter_mut().zip(f) {
                        *x *= k;
                    }
                }
            }
            j
        });
        (&short_fit.model, j0)
    } else {
        (model, None)
    };
    crate::progress::stage("calibrating", 3, 4, "stages");
    let first = fit_scaled(
        start,
        runs,
        free,
        short,
        None,
        Some(bounds_for(model, free, true)),
        opts,
        j0,
        &s1,
    )?
    .lean();
    let s2 = structural_scales(runs, &misfit_scales(&first.model, runs, shooting)?);
    // Fresh Jacobians here: with channels down-weighted, parameters acting mostly on them
    // are weakly determined, and rank-one updates let them wander. Continued until
    // converged, like the noise-weighted stage.
    crate::progress::stage("calibrating", 4, 4, "stages");
    let mut last = fit_scaled(
        &first.model,
        runs,
        free,
        shooting,
        None,
        Some(bounds_for(model, free, true)),
        &LmOptions {
            max_iter: (opts.max_iter / 2).max(3),
            ..*opts
        },
        None,
        &s2,
    )?;
    for round in 0..MAX_MORE_ROUNDS {
        if !another_round(&last, round) {
            break;
        }
        last = last.lean();
        last = fit_scaled(
            &last.model,
            runs,
            free,
            shooting,
            None,
            Some(bounds_for(model, free, true)),
            opts,
            None,
            &s2,
        )?;
    }
    Ok(last)
}

/// Rounds a multiple-shooting stage of [`staged_fit`] may be continued after its first
/// fit (each a fresh LM search from where the previous one stopped).
pub const MAX_MORE_ROUNDS: usize = 4;

/// Rounds continued whenever the previous one ended unconverged.
const UNCONVERGED_ROUNDS: usize = 2;

/// After [`UNCONVERGED_ROUNDS`], a stage is continued only while its last round, still
/// unconverged, lowered the cost by more than this fraction: on the 6-DOF base the
/// noise-weighted stage can still gain 15 % a round after two continuations (probe case
/// 15), and the structural reweighting must not judge a fit that is still moving.
pub const CONTINUE_REL_DROP: f64 = 1e-3;

/// Whether a stage whose fit after `round` continuations is `fit` gets another round.
fn another_round(fit: &Calibration, round: usize) -> bool {
    if fit.lm.converged {
        return false;
    }
    round < UNCONVERGED_ROUNDS || fit.lm.cost0 - fit.lm.cost > CONTINUE_REL_DROP * fit.lm.cost0
}

/// Per-sample factors taking a weighted residual (layout of [`Objective`]) from the
/// weights of `old` to those of `new` (`None` when they are all 1).
pub(crate) fn row_factors(
    model: &LabModel,
    runs: &[Run],
    view: View,
    old: &ChannelScales,
    new: &ChannelScales,
) -> Option<Vec<f64>> {
    let blocks = block_factors(model, runs, view, old, new)?;
    let lens = runs.iter().flat_map(|r| {
        let nch = blocks.len() / runs.len().max(1);
        std::iter::repeat_n(r.len(), nch)
    });
    let mut out = Vec::new();
    for (f, len) in blocks.iter().zip(lens) {
        out.extend(std::iter::repeat_n(*f, len));
    }
    Some(out)
}

/// [`row_factors`] by block: one factor per run and channel (run-major, channels as the
/// objective's), the same for every sample of the block.
pub(crate) fn block_factors(
    model: &LabModel,
    runs: &[Run],
    view: View,
    old: &ChannelScales,
    new: &ChannelScales,
) -> Option<Vec<f64>> {
    if old == new {
        return None;
    }
    let a = Objective::scaled(model, runs, view, old);
    let b = Objective::scaled(model, runs, view, new);
    let mut out = Vec::with_capacity(runs.len() * a.channels.len());
    let mut any = false;
    for ri in 0..runs.len() {
        for ch in &a.channels {
            let i = ch_index(*ch);
            let (wa, wb) = (a.weights[ri][i], b.weights[ri][i]);
            let f = if wa > 0.0 { wb / wa } else { 0.0 };
            any |= f != 1.0;
            out.push(f);
        }
    }
    any.then_some(out)
}

/// A channel whose misfit exceeds this many noise floors is down-weighted.
pub const REWEIGHT_FACTOR: f64 = 2.0;

/// The structural part of a misfit: per channel max(σ, s − (K − 1)σ) with K =
/// [`REWEIGHT_FACTOR`] and σ the runs' pooled noise floor, or 0 (noise weight) when the
/// misfit is within K noise floors. Continuous in s; close to s for a large misfit. A
/// misfit within a few noise floors may be an underestimated floor or a calibration that
/// has not fully converged, and keeps the plain noise weight.
pub fn structural_scales(runs: &[Run], misfit: &ChannelScales) -> ChannelScales {
    let mut out = NOISE_ONLY;
    for (i, o) in out.iter_mut().enumerate() {
        let (mut sum, mut n) = (0.0, 0usize);
        for r in runs {
            if r.y[i].is_some() && r.noise[i] > 0.0 {
                sum += r.noise[i].powi(2) * r.len() as f64;
                n += r.len();
            }
        }
        if n == 0 {
            continue;
        }
        let sigma = (sum / n as f64).sqrt();
        if misfit[i] > REWEIGHT_FACTOR * sigma {
            *o = (misfit[i] - (REWEIGHT_FACTOR - 1.0) * sigma).max(sigma);
        }
    }
    out
}

/// The data's information on each calibrated parameter alone, in units of its documented
/// prior's (diagonal of the Gauss–Newton information in prior-scaled coordinates, with
/// the effective sample size; `None` without a Jacobian).
fn param_information(cal: &Calibration, bounds: &[Bound]) -> Vec<Option<f64>> {
    let p = cal.params.len();
    let Some(j) = cal.lm.jacobian.as_ref().filter(|j| j.ncols() == p) else {
        return vec![None; p];
    };
    let dof = (cal.lm.n_res as f64 - p as f64).max(1.0);
    let s2 = (cal.lm.cost / dof).max(1e-300);
    let ratio = (cal.n_eff / cal.lm.n_res.max(1) as f64).clamp(0.0, 1.0);
    (0..p)
        .map(|i| {
            let sig = cal
                .model
                .prior_of(cal.params[i])
                .map(|(_, s)| s)
                .or_else(|| bounds.get(i).map(|b| b.scale * 20.0))?;
            let c = j.column(i);
            Some(c.dot(&c) * sig * sig * ratio / s2)
        })
        .collect()
}

/// The measured channels of a body axis (its velocity and the position or angle it
/// integrates to).
fn axis_channels(a: Axis) -> &'static [Channel] {
    match a {
        Axis::Surge => &[Channel::Surge],
        Axis::Sway => &[Channel::Sway],
        Axis::Heave => &[Channel::Heave, Channel::Depth],
        Axis::Roll => &[Channel::RollRate, Channel::Roll],
        Axis::Pitch => &[Channel::PitchRate, Channel::Pitch],
        Axis::Yaw => &[Channel::YawRate, Channel::Heading],
    }
}

/// The body axis a base parameter acts on directly (`None` for thrust scales, which act
/// through the thrusters on several).
fn own_axis(p: Param) -> Option<Axis> {
    match p {
        Param::AddedMass(a) | Param::DragLin(a) | Param::DragQuad(a) => Some(a),
        Param::CgZ => Some(Axis::Pitch),
        _ => None,
    }
}

/// How much the data excites a body axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AxisExcitation {
    /// Some measured channel of the axis moves by more than three noise floors (RMS about
    /// its mean over the pooled runs): the criterion under which the metrics report a
    /// fit % instead of "low excitation" ([`crate::metrics`]).
    Excited,
    /// The axis is measured but barely moves.
    Low,
    /// Nothing in the data measures the axis: its parameters act on the data only
    /// through couplings.
    Unmeasured,
}

/// How much the runs excite a body axis.
pub fn axis_excitation(runs: &[Run], a: Axis) -> AxisExcitation {
    let mut measured = false;
    for ch in axis_channels(a) {
        let i = ch_index(*ch);
        let (mut n, mut s, mut ss, mut noise2) = (0usize, 0.0, 0.0, 0.0);
        for r in runs {
            let Some(y) = r.y[i].as_ref() else { continue };
            for v in y.iter().filter(|v| v.is_finite()) {
                n += 1;
                s += v;
                ss += v * v;
                noise2 += r.noise[i] * r.noise[i];
            }
        }
        if n < 2 {
            continue;
        }
        measured = true;
        let nf = n as f64;
        let var = (ss - s * s / nf).max(0.0) / nf;
        if var.sqrt() > 3.0 * (noise2 / nf).sqrt() {
            return AxisExcitation::Excited;
        }
    }
    if measured {
        AxisExcitation::Low
    } else {
        AxisExcitation::Unmeasured
    }
}

/// The calibration's parameters that need saying: those at a bound of their range (a
/// physical limit, or a plausibility limit that makes the value suspect — unless the
/// data leaves the parameter unidentifiable: its own axis barely moves in `runs`, or the
/// data's information on it alone is below its documented prior's; then it is said to be
/// unidentifiable from this data, not evidence of anything) and the directions of the
/// parameter space the data leaves undetermined (eigenvectors of the Gauss–Newton
/// information matrix in prior-scaled coordinates, with the effective sample size, whose
/// eigenvalue is below the prior's own information), in words.
pub fn calibration_notes(cal: &Calibration, runs: &[Run]) -> Vec<String> {
    let mut out = Vec::new();
    let bounds = bounds_for(&cal.model, &cal.params, true);
    let info = param_information(cal, &bounds);
    for (i, p) in cal.params.iter().enumerate() {
        let (Some(v), Some(b)) = (cal.model.get(*p), bounds.get(i)) else {
            continue;
        };
        let tol = 1e-6 * (b.hi - b.lo).abs().max(1e-12);
        for (bound, upper) in [(b.lo, false), (b.hi, true)] {
            if (v - bound).abs() > tol {
                continue;
            }
            let (dv, unit) = p.display(v);
            let side = if upper { "upper" } else { "lower" };
            let unexcited = own_axis(*p)
                .map(|a| (a, axis_excitation(runs, a)))
                .filter(|(_, e)| *e != AxisExcitation::Excited);
            let weak = info.get(i).copied().flatten().filter(|x| *x < 1.0);
            out.push(if let Some((a, e)) = unexcited {
                let why = if e == AxisExcitation::Low {
                    format!("the {} axis barely moves in this data (low excitation)", a.name())
                } else {
                    format!("nothing in this data measures the {} axis", a.name())
                };
                format!(
                    "{} = {dv:.4} {unit} ended at its {side} limit, but {why}: it is unidentifiable from this data, and the value at the limit is not evidence of anything (neither a finding nor a structural misfit); record {} motion to calibrate it",
                    p.key(),
                    a.name()
                )
            } else if let Some(x) = weak {
                format!(
                    "{} = {dv:.4} {unit} ended at its {side} limit, but this data barely determines it (its information is {x:.2} of the documented prior's): it is unidentifiable from this data, and the value at the limit is not evidence of anything",
                    p.key()
                )
            } else if p.bound_is_physical(upper) {
                format!(
                    "{} = {dv:.4} {unit} ended at its physical {side} limit: the data wants it beyond what is possible, a sign of a structural misfit it compensates",
                    p.key()
                )
            } else {
                format!(
                    "{} = {dv:.4} {unit} ended at the {side} bound of its plausible range: implausible, it stands in for something the base lacks",
                    p.key()
                )
            });
        }
    }
    let Some(j) = cal.lm.jacobian.as_ref() else {
        return out;
    };
    let p = cal.params.len();
    if j.ncols() != p || p == 0 {
        return out;
    }
    // The data's information in prior-scaled coordinates z = (x − μ)/σ_prior, with the
    // effective sample size (correlated residuals carry less information than their count):
    // a direction whose eigenvalue is below 1 is determined less by the data than by the
    // documented prior.
    let dof = (cal.lm.n_res as f64 - p as f64).max(1.0);
    let s2 = (cal.lm.cost / dof).max(1e-300);
    let ratio = (cal.n_eff / cal.lm.n_res.max(1) as f64).clamp(0.0, 1.0);
    let sig: Vec<f64> = cal
        .params
        .iter()
        .zip(&bounds)
        .map(|(q, b)| {
            cal.model
                .prior_of(*q)
                .map(|(_, s)| s)
                .unwrap_or(b.scale * 20.0)
        })
        .collect();
    let mut a = j.tr_mul(j);
    for r in 0..p {
        for c in 0..p {
            a[(r, c)] *= sig[r] * sig[c] * ratio / s2;
        }
    }
    let eig = nalgebra::SymmetricEigen::new(a);
    let mut weak: Vec<(f64, usize)> = eig
        .eigenvalues
        .iter()
        .enumerate()
        .filter(|(_, ev)| **ev < 1.0)
        .map(|(k, ev)| (*ev, k))
        .collect();
    weak.sort_by(|x, y| x.0.total_cmp(&y.0));
    for (ev, k) in weak.into_iter().take(3) {
        let v = eig.eigenvectors.column(k);
        let mut comp: Vec<(f64, Param)> = cal
            .params
            .iter()
            .enumerate()
            .map(|(i, q)| (v[i], *q))
            .filter(|(c, _)| c.abs() >= 0.3)
            .collect();
        comp.sort_by(|x, y| y.0.abs().total_cmp(&x.0.abs()));
        if comp.len() >= 2 {
            let names: Vec<String> = comp
                .iter()
                .map(|(c, q)| format!("{}{}", if *c < 0.0 { "−" } else { "+" }, q.key()))
                .collect();
            out.push(format!(
                "unidentifiable direction: {} move together with little change of the fit (the data's information there is {:.2} of the documented prior's); only their combination is determined, and their individual values rest on the priors",
                names.join(" "),
                ev
            ));
        } else if let Some((_, q)) = comp.first() {
            out.push(format!(
                "{} is barely determined by this data (information {:.2} of its documented prior's); it stays near its prior",
                q.key(),
                ev
            ));
        }
    }
    out
}
