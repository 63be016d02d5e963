//! Diagnosis: rank the catalog effects by evidence, confirm the best in simulation, accept
//! on held-out data, greedy forward selection.
//!
//! 1. **Calibrate** the base on the training runs ([`crate::calibrate::calibrate`]), so a
//!    mistuned parameter is never mistaken for missing physics. Channels the calibrated
//!    base still misses by more than a few noise floors (missing physics) are down-weighted
//!    to their structural misfit, so they cannot bend the base parameters (see
//!    [`crate::calibrate`], "Channel weights").
//! 2. **Screen** every testable candidate cheaply: sensitivities of the training residual
//!    to the base parameters (Jacobian) and to each effect parameter (one probe
//!    simulation each, from "off" to a typical value); a bounded least-squares fit of the
//!    residual on [base | effect] columns (a parameter at a bound may only move inwards)
//!    against the base-refit-only null gives ΔRSS and ΔBIC with an effective sample size.
//!    Each candidate is weighted at the solution it claims: its home channels at their
//!    noise floor, the others at the current structural misfit ([`candidate_scales`]).
//! 3. **Confirm** the top candidates: simulation-error Levenberg–Marquardt of the effect's
//!    parameters jointly with the base parameters (only those of the effect's own axes
//!    when the fit runs in the free-run view), started from "effect off" or from the
//!    screening estimate, whichever fits better.
//! 4. **Accept** on the held-out runs, every candidate on the same two views (multiple
//!    shooting and free run; see [`judge`] for the rules): a channel clearly above its
//!    noise floor falls by at least [`MIN_REDUCTION`] in both views; no channel gets
//!    worse beyond what noise or an unrelated structural misfit accounts for; switching
//!    the effect's own term off again (base refit kept) brings the error back (the "base
//!    refit only" control); no effect parameter is pinned at a plausibility bound;
//!    training ΔBIC above [`MIN_DBIC`]; sensor effects agree with the measured rates when
//!    there are any (a depth drift with the heave velocity, a compass deviation with the
//!    yaw rate: [`kinematic_ratio`]).
//! 5. **Greedy**: accept the best, reweight the channels, screen again on top of it,
//!    until nothing passes.
//!
//! Two candidates whose confirmed fits change the held-out predictions the same way
//! (cosine > [`AMBIGUITY_COSINE`]) and score alike are reported as ambiguous, with the
//! experiment that would separate them (modellab.md §3.4).

use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector};
use rov_dynamics::models::Channel;
use serde::Serialize;

use crate::LabError;
use crate::calibrate::{
    Calibration, ChannelScales, FittedParam, Objective, REWEIGHT_FACTOR, SHOOTING_WINDOW_S, View,
    bounds_for, calibrate, effective_n, excited, fit_scaled, misfit_scales, row_factors,
    structural_scales,
};
use crate::catalog::EffectId;
use crate::data::{Run, SegmentKind, ch_name};
use crate::evaluate::{ChannelKey, Evaluation, evaluate};
use crate::lm::{Bound, LmOptions};
use crate::model::{BaseKind, LabModel};
use crate::params::{Axis, Param, Thr, effect_params};

/// Smallest held-out RMSE reduction that counts (fraction).
pub const MIN_REDUCTION: f64 = 0.15;
/// A channel counts only if its calibrated held-out RMSE is this many noise floors.
pub const NOISE_FACTOR: f64 = 1.3;
/// Largest tolerated worsening of another channel (fraction).
pub const MAX_WORSE: f64 = 0.05;
/// A worsened channel is tolerated when its noise-normalised loss is below this fraction
/// of the noise-normalised gain summed over channels.
pub const WORSE_FRACTION_OF_GAIN: f64 = 0.2;
/// A worsened channel whose held-out prediction moved by less than this fraction of its
/// noise floor (RMS) is within noise (see [`judge`]).
pub const WORSE_NOISE_FRACTION: f64 = 0.5;
/// Largest tolerated worsening of a channel the effect does not claim and the base
/// already misses structurally (fraction, see [`judge`]).
pub const MAX_WORSE_UNEXPLAINED: f64 = 0.25;
/// An effect parameter within this fraction of its range from a plausibility bound is
/// pinned there (see [`judge`]).
pub const BOUND_MARGIN: f64 = 0.03;
/// Training ΔBIC needed (effective sample size).
pub const MIN_DBIC: f64 = 10.0;
/// Own-term control: with the effect switched off again (base refit kept) the error must
/// rise by this fraction of the improvement, and by [`MIN_REDUCTION`] of itself.
pub const CONTROL_FRACTION: f64 = 0.1;
/// A thruster lag shorter than this fraction of the sample period is not resolvable.
pub const LAG_RESOLUTION: f64 = 0.5;
/// Cosine similarity of prediction changes above which two findings are ambiguous.
pub const AMBIGUITY_COSINE: f64 = 0.9;

/// Options of [`diagnose`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiagnoseOptions {
    /// Worker threads (1 = serial).
    pub threads: usize,
    /// Most effects accepted.
    pub max_effects: usize,
    /// Candidates confirmed in simulation in the first round.
    pub confirm_first: usize,
    /// Candidates confirmed in later rounds.
    pub confirm_later: usize,
    /// LM iterations of the calibration stages.
    pub calibration_iterations: usize,
    /// LM iterations of a confirmation fit.
    pub confirm_iterations: usize,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        Self {
            threads: 2,
            max_effects: 3,
            confirm_first: 3,
            confirm_later: 2,
            calibration_iterations: 8,
            confirm_iterations: 4,
        }
    }
}

/// Status of a finding.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Accepted: significant on held-out data.
    Significant,
    /// Significant but indistinguishable from another candidate on this data.
    Ambiguous,
    /// Fitted in simulation; did not pass the held-out tests.
    NotSignificant,
    /// Screened only; too little evidence to confirm.
    Screened,
    /// The data cannot excite it.
    NotTestable,
    /// The model cannot represent it.
    NotApplicable,
    /// Already in the model; its parameters are calibrated or fixed as documented.
    Contained,
}

/// A parameter in a report.
#[derive(Debug, Clone, Serialize)]
pub struct ParamReport {
    /// Value (display unit).
    pub value: f64,
    /// Standard deviation (display unit), if known.
    pub std: Option<f64>,
    /// Display unit.
    pub unit: String,
}

/// One effect's evidence card.
#[derive(Debug, Clone, Serialize)]
pub struct Finding {
    /// Effect ID.
    pub effect: String,
    /// Whether it was accepted.
    pub significant: bool,
    /// Status.
    pub status: Status,
    /// Whether the base model already contains it (a refit, not an addition).
    pub contained: bool,
    /// Channels it explains.
    pub channels: Vec<String>,
    /// Error view of `validation_rmse_reduction_pct`: "shooting" (multiple shooting) or
    /// "free_run", whichever shows the finding's home channels falling more. Every
    /// candidate is judged on both views alike.
    pub view: String,
    /// Held-out RMSE reduction per predicted channel in `view`, %.
    pub validation_rmse_reduction_pct: BTreeMap<String, f64>,
    /// Held-out free-run RMSE reduction per predicted channel, %.
    pub validation_rmse_reduction_pct_free_run: BTreeMap<String, f64>,
    /// Held-out multiple-shooting RMSE reduction per predicted channel, %.
    pub validation_rmse_reduction_pct_shooting: BTreeMap<String, f64>,
    /// Fitted parameters.
    pub params: BTreeMap<String, ParamReport>,
    /// Plain explanation.
    pub explanation: String,
    /// Training ΔBIC (effective sample size), if fitted or screened.
    pub delta_bic: Option<f64>,
    /// Evidence score (held-out noise-normalised RMSE reduction summed over channels).
    pub score: f64,
    /// Effects it cannot be told apart from on this data.
    pub ambiguous_with: Vec<String>,
    /// The experiment that would separate it from those.
    pub separating_experiment: Option<String>,
    /// Greedy round in which it was evaluated (1-based; 0 = not evaluated).
    pub round: usize,
}

/// Per-channel baseline numbers.
#[derive(Debug, Clone, Serialize)]
pub struct BaselineChannel {
    /// Fit % (multiple shooting), `None` for low excitation.
    pub fit_pct: Option<f64>,
    /// RMSE (multiple shooting).
    pub rmse_shooting: f64,
    /// Fit % (free run).
    pub fit_pct_free_run: Option<f64>,
    /// RMSE (free run).
    pub rmse: f64,
    /// Noise floor estimated from the data.
    pub noise: f64,
}

/// Held-out RMSE per channel in both views.
#[derive(Debug, Clone, Default, Serialize)]
pub struct RmseMaps {
    /// Multiple shooting.
    pub shooting: BTreeMap<String, f64>,
    /// Free run.
    pub free_run: BTreeMap<String, f64>,
}

/// Result of [`diagnose`].
#[derive(Debug, Clone)]
pub struct Diagnosis {
    /// Model name as given.
    pub model: String,
    /// Calibrated base on the held-out runs.
    pub baseline: BTreeMap<String, BaselineChannel>,
    /// Channels the model does not predict (measured in the data).
    pub not_predicted: Vec<String>,
    /// Calibration parameters.
    pub calibration: Vec<FittedParam>,
    /// Findings, best first.
    pub findings: Vec<Finding>,
    /// Accepted effects, in order.
    pub accepted: Vec<EffectId>,
    /// The calibrated base.
    pub calibrated: LabModel,
    /// The calibrated base plus the accepted effects, refitted.
    pub final_model: LabModel,
    /// Held-out RMSE per channel after each accepted addition (first = base).
    pub error_fall: Vec<(String, RmseMaps)>,
    /// One-line summary ("nothing significant", "found …").
    pub summary: String,
}

#[derive(Debug, Clone)]
struct Candidate {
    effect: EffectId,
    params: Vec<Param>,
    contained: bool,
}

enum Availability {
    Candidate(Candidate),
    NotApplicable(String),
    NotTestable(String),
    Contained(String),
}

fn any_cmd(runs: &[Run], f: impl Fn(&rov_dynamics::ThrustPct) -> bool) -> bool {
    runs.iter().any(|r| r.cmd.iter().any(&f))
}

fn measured(model: &LabModel, runs: &[Run], ch: Channel) -> bool {
    model.predicts_channel(ch) && runs.iter().any(|r| r.has(ch))
}

/// Whether a parameter is excited by the data (beyond [`excited`]'s base rules).
fn effect_param_testable(model: &LabModel, runs: &[Run], p: Param) -> bool {
    let depth = measured(model, runs, Channel::Depth) || measured(model, runs, Channel::Heave);
    let heading =
        measured(model, runs, Channel::Heading) || measured(model, runs, Channel::YawRate);
    let pitch = measured(model, runs, Channel::Pitch) || measured(model, runs, Channel::PitchRate);
    let roll = measured(model, runs, Channel::Roll) || measured(model, runs, Channel::RollRate);
    let on = |x: f64| x.abs() >= 5.0;
    match p {
        Param::ReverseRatio(t) => {
            let rev = runs.iter().any(|r| r.reverse_present()[t.index()]);
            rev && match t {
                Thr::Vertical => depth,
                _ => heading,
            }
        }
        Param::LagTau => runs.iter().any(|r| r.segments.len() > 2) && (depth || heading),
        Param::Deadzone => any_cmd(runs, |c| on(c.port) || on(c.starboard) || on(c.vertical)),
        Param::PowerMax => any_cmd(runs, |c| {
            let n = [c.port, c.starboard, c.vertical]
                .iter()
                .filter(|x| on(**x))
                .count();
            n >= 2
        }),
        Param::ArmZh => pitch && any_cmd(runs, |c| on(c.port) && on(c.starboard)),
        Param::ArmXv => pitch && any_cmd(runs, |c| on(c.vertical)),
        Param::ArmYv => roll && any_cmd(runs, |c| on(c.vertical)),
        Param::TorqueV => heading && any_cmd(runs, |c| on(c.vertical)),
        Param::TorqueH => roll && any_cmd(runs, |c| on(c.port - c.starboard)),
        Param::NetWeight => depth,
        Param::CgX => pitch,
        Param::CgY => roll,
        Param::TrimDeg => {
            depth
                && runs
                    .iter()
                    .any(|r| r.segments.iter().any(|s| s.kind == SegmentKind::Surge))
        }
        Param::DragRatio(Axis::Heave) => depth && any_cmd(runs, |c| c.vertical <= -5.0),
        Param::DragRatio(Axis::Yaw) => heading && any_cmd(runs, |c| on(c.port - c.starboard)),
        Param::DragRatio(_) => false,
        Param::CurrentN | Param::CurrentE => {
            measured(model, runs, Channel::North)
                || measured(model, runs, Channel::East)
                || measured(model, runs, Channel::Surge)
                || measured(model, runs, Channel::Sway)
        }
        Param::TetherN | Param::TetherE => heading,
        Param::DepthDrift => measured(model, runs, Channel::Depth),
        Param::CompassSin | Param::CompassCos => measured(model, runs, Channel::Heading),
        Param::Emi(t) => {
            measured(model, runs, Channel::Heading)
                && any_cmd(runs, |c| match t {
                    Thr::Port => on(c.port),
                    Thr::Starboard => on(c.starboard),
                    Thr::Vertical => on(c.vertical),
                })
        }
        Param::BiasRoll => measured(model, runs, Channel::Roll),
        Param::BiasPitch => measured(model, runs, Channel::Pitch),
        Param::AddedMass(_) => depth || heading,
        _ => excited(model, runs, p),
    }
}

fn availability(model: &LabModel, runs: &[Run], e: EffectId) -> Availability {
    let kind = model.kind();
    if let Some(reason) = kind.not_applicable(e) {
        return Availability::NotApplicable(format!("not testable with {}: {reason}", kind.name()));
    }
    match e {
        EffectId::Coriolis => {
            return Availability::Contained(format!(
                "{} already contains it; its coefficients follow from the mass, added mass and CG",
                kind.name()
            ));
        }
        EffectId::AddedMass => {
            return Availability::Contained(format!(
                "{} already contains it; with motion data only, added mass, thrust gain and damping are determined up to a common scale, so it is kept fixed and the calibration's thrust and damping carry the scale",
                kind.name()
            ));
        }
        EffectId::PitchDepthCoupling if kind == BaseKind::Model3 => {
            return Availability::Contained(
                "model3's 6-DOF kinematics already carry it; a trim angle shows up as restoring-offset"
                    .into(),
            );
        }
        _ => {}
    }
    let params: Vec<Param> = effect_params(e)
        .into_iter()
        .filter(|p| model.applicable(*p) && effect_param_testable(model, runs, *p))
        .collect();
    if params.is_empty() {
        let why = match e {
            EffectId::Current => "not testable with this data: a constant current only shows in earth-fixed position (north/east) or body velocity (surge/sway), and the data has none of them; depth, heading, pitch and roll cannot reveal it".to_string(),
            _ => format!("not testable with this data: it needs {}", e.info().needs),
        };
        return Availability::NotTestable(why);
    }
    Availability::Candidate(Candidate {
        effect: e,
        params,
        contained: kind.contains(e),
    })
}

/// The Jacobian of the objective's residual w.r.t. parameters at `model` (forward
/// differences, `threads` workers).
fn jacobian_cols(
    model: &LabModel,
    obj: &Objective<'_>,
    r0: &[f64],
    params: &[Param],
    steps: &[f64],
    threads: usize,
) -> Vec<Option<Vec<f64>>> {
    let col = |i: usize| -> Option<Vec<f64>> {
        let p = params[i];
        let v0 = model.get(p).or_else(|| p.off_value()).unwrap_or(0.0);
        let meta = p.meta();
        let mut h = steps[i];
        if v0 + h > meta.hi {
            h = -h;
        }
        let m = model.with(&[p], &[v0 + h]).ok()?;
        let r = obj.residuals(&m).ok()?;
        Some(r.iter().zip(r0).map(|(a, b)| (a - b) / h).collect())
    };
    par_map(params.len(), threads, col)
}

/// Runs `f(0..n)` on `threads` workers, keeping order.
pub(crate) fn par_map<T: Send, F: Fn(usize) -> T + Sync>(n: usize, threads: usize, f: F) -> Vec<T> {
    let threads = threads.max(1).min(n.max(1));
    if threads <= 1 {
        return (0..n).map(f).collect();
    }
    let mut out: Vec<Option<T>> = (0..n).map(|_| None).collect();
    std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads)
            .map(|w| {
                let f = &f;
                s.spawn(move || {
                    (w..n)
                        .step_by(threads)
                        .map(|i| (i, f(i)))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        for h in handles {
            if let Ok(v) = h.join() {
                for (i, x) in v {
                    out[i] = Some(x);
                }
            }
        }
    });
    let mut res = Vec::with_capacity(n);
    for (i, x) in out.into_iter().enumerate() {
        match x {
            Some(v) => res.push(v),
            None => res.push(f(i)),
        }
    }
    res
}

#[derive(Debug, Clone)]
struct Screened {
    cand: Candidate,
    dbic: f64,
    /// Largest explained fraction of a home channel's training residual.
    explained: f64,
    start: Vec<f64>,
    /// The base parameters' values of the same linearised step.
    start_base: Vec<f64>,
    /// The base parameters of `start_base` (those screened with the candidate).
    base_params: Vec<Param>,
    /// Base parameters confounded with the effect (reported in debugging only).
    #[allow(dead_code)]
    confounded: Vec<Param>,
    /// The view the screening used.
    view: View,
}

/// Smallest explained fraction of a home channel's training residual (linearised) for a
/// candidate to be confirmed in simulation.
const MIN_SCREEN_EXPLAINED: f64 = 0.03;

/// A candidate is confirmed only if it explains at least this fraction of what the best
/// screened candidate explains.
const RELATIVE_SCREEN_GATE: f64 = 0.2;

/// Further starts a confirmation tries when its fit ends pinned at a plausibility bound.
const MAX_EXTRA_STARTS: usize = 2;

/// Most base parameters refitted jointly with an effect.
const MAX_CONFOUNDED: usize = 10;
/// Cosine between an effect's and a base parameter's sensitivity above which the base
/// parameter is refitted with the effect.
const CONFOUND_COSINE: f64 = 0.1;

/// Multiplies row k of `m` by `f[k]`.
fn scale_rows(m: &mut DMatrix<f64>, f: &[f64]) {
    for j in 0..m.ncols() {
        for (x, k) in m.column_mut(j).iter_mut().zip(f) {
            *x *= k;
        }
    }
}

/// Direction a parameter may move from its current value in a linearised step: +1 when
/// it sits at its lower bound, −1 at its upper bound, 0 when free both ways.
fn bound_side(model: &LabModel, p: Param) -> i8 {
    let m = p.meta();
    let v = model.get(p).or_else(|| p.off_value()).unwrap_or(0.0);
    let tol = 1e-9 * m.scale.max(1e-12);
    if v <= m.lo + tol {
        1
    } else if v >= m.hi - tol {
        -1
    } else {
        0
    }
}

/// Bounded linear least squares of r0 + M δ (columns normalised, tiny ridge): a column
/// whose step would leave its bound (`side`, see [`bound_side`]) is held at zero and the
/// rest refitted (active set). Returns the residual and δ.
fn bounded_ls(
    r0: &DVector<f64>,
    m: &DMatrix<f64>,
    side: &[i8],
) -> Option<(DVector<f64>, Vec<f64>)> {
    let p = m.ncols();
    if p == 0 {
        return Some((r0.clone(), Vec::new()));
    }
    let norms: Vec<f64> = (0..p).map(|j| m.column(j).norm().max(1e-300)).collect();
    let mut ms = m.clone();
    for (j, n) in norms.iter().enumerate() {
        ms.column_mut(j).scale_mut(1.0 / n);
    }
    let a = ms.transpose() * &ms;
    let g = ms.transpose() * r0;
    let mut active: Vec<usize> = (0..p).collect();
    let mut x_full = vec![0.0; p];
    for _ in 0..=p {
        let k = active.len();
        x_full = vec![0.0; p];
        if k == 0 {
            break;
        }
        let mut sub = DMatrix::zeros(k, k);
        let mut gs = DVector::zeros(k);
        for (r, &i) in active.iter().enumerate() {
            gs[r] = -g[i];
            for (c, &j) in active.iter().enumerate() {
                sub[(r, c)] = a[(i, j)];
            }
            sub[(r, r)] += 1e-9;
        }
        let x = sub.cholesky()?.solve(&gs);
        for (r, &i) in active.iter().enumerate() {
            x_full[i] = x[r];
        }
        let before = active.len();
        active.retain(|&i| {
            let sd = side.get(i).copied().unwrap_or(0);
            !(sd != 0 && x_full[i] * f64::from(sd) < 0.0)
        });
        if active.len() == before {
            break;
        }
    }
    let xv = DVector::from_column_slice(&x_full);
    let res = r0 + &ms * &xv;
    let xs = x_full.iter().zip(&norms).map(|(v, n)| v / n).collect();
    Some((res, xs))
}

/// Bounded least squares of r0 + [B C] δ (null: B alone): returns (residual null,
/// residual alt, δ of [B C]).
#[allow(clippy::type_complexity)]
fn ls_gain(
    r0: &DVector<f64>,
    b: &DMatrix<f64>,
    c: &DMatrix<f64>,
    side: &[i8],
) -> Option<(DVector<f64>, DVector<f64>, Vec<f64>)> {
    let nb = b.ncols();
    let (res0, _) = bounded_ls(r0, b, side.get(..nb).unwrap_or(&[]))?;
    let mut bc = DMatrix::zeros(b.nrows(), nb + c.ncols());
    bc.view_mut((0, 0), (b.nrows(), nb)).copy_from(b);
    bc.view_mut((0, nb), (c.nrows(), c.ncols())).copy_from(c);
    let (res1, x) = bounded_ls(r0, &bc, side)?;
    Some((res0, res1, x))
}

fn probe_value(model: &LabModel, runs: &[Run], p: Param) -> f64 {
    if p == Param::PowerMax {
        // Below the largest combined demand in the data.
        let mut dmax: f64 = 0.0;
        for r in runs {
            for c in &r.cmd {
                let d = (c.port * 0.01).abs().powi(3)
                    + (c.starboard * 0.01).abs().powi(3)
                    + (c.vertical * 0.01).abs().powi(3);
                dmax = dmax.max(d);
            }
        }
        return (0.6 * dmax).max(0.05);
    }
    let cur = model.get(p).or_else(|| p.off_value()).unwrap_or(0.0);
    match p.off_value() {
        Some(off) => cur + (p.probe_value() - off),
        None => cur + p.meta().scale * 4.0,
    }
}

/// The error view in which an effect is *fitted* (every effect is *judged* on both views,
/// see [`judge`]): slow sensor drift needs the free run (multiple shooting re-initialises
/// most of it away); everything else is fitted with multiple shooting.
fn primary_view(e: EffectId) -> View {
    match e {
        EffectId::DepthSensorDrift => View::FreeRun,
        _ => View::Shooting(SHOOTING_WINDOW_S),
    }
}

/// Prediction horizon of the short screening view and of the first confirmation stage,
/// s: short enough to keep large missing effects (a tether's weathervaning) near-linear.
/// Screening also runs in the multiple-shooting view, where rate errors (a dead zone's
/// wrong steady speeds) stand above the noise and the calibrated base is at its optimum.
pub const SCREEN_HORIZON_S: f64 = 2.0;

fn short_view(runs: &[Run]) -> View {
    let dt = runs.first().map_or(0.05, |r| r.median_dt()).max(1e-3);
    View::KStep((SCREEN_HORIZON_S / dt).round().max(2.0) as usize)
}

/// Screens candidates in `view`: linearised fit of the training residual on the base
/// and effect sensitivities.
/// Sensitivity columns of the screening objective, kept across greedy rounds (the
/// linearisation of the calibrated base stays a fair screening approximation after an
/// effect is added, and it saves most of the cost of later rounds).
type ColumnCache = BTreeMap<Param, Vec<f64>>;

#[allow(clippy::too_many_arguments)]
fn screen(
    model: &LabModel,
    runs: &[Run],
    base_free: &[Param],
    cands: &[Candidate],
    view: View,
    scales: &ChannelScales,
    threads: usize,
    cache: &mut ColumnCache,
) -> Result<Vec<Screened>, LabError> {
    if cands.is_empty() {
        return Ok(Vec::new());
    }
    let obj = Objective::scaled(model, runs, view, scales);
    let r0 = obj.residuals(model)?;
    let n_eff = effective_n(&r0, runs.first().map_or(1, |r| r.len()));
    let n = r0.len();
    // Base columns (small steps) and effect columns (probe secants) in one parallel pass.
    let mut all: Vec<Param> = base_free.to_vec();
    let mut steps: Vec<f64> = base_free.iter().map(|p| p.meta().scale * 0.1).collect();
    let mut eff_index: BTreeMap<Param, usize> = BTreeMap::new();
    for c in cands {
        for p in &c.params {
            if eff_index.contains_key(p) || base_free.contains(p) {
                continue;
            }
            let cur = model.get(*p).or_else(|| p.off_value()).unwrap_or(0.0);
            let probe = probe_value(model, runs, *p);
            eff_index.insert(*p, all.len());
            all.push(*p);
            let step = probe - cur;
            steps.push(if step.abs() > 1e-12 {
                step
            } else {
                p.meta().scale
            });
        }
    }
    let missing: Vec<usize> = (0..all.len())
        .filter(|i| !cache.contains_key(&all[*i]))
        .collect();
    let miss_params: Vec<Param> = missing.iter().map(|i| all[*i]).collect();
    let miss_steps: Vec<f64> = missing.iter().map(|i| steps[*i]).collect();
    let new_cols = jacobian_cols(model, &obj, &r0, &miss_params, &miss_steps, threads);
    for (p, c) in miss_params.iter().zip(new_cols) {
        if let Some(c) = c
            && c.len() == n
        {
            cache.insert(*p, c);
        }
    }
    let cols: Vec<Option<&Vec<f64>>> = all.iter().map(|p| cache.get(p)).collect();
    let to_mat = |idx: &[usize]| -> DMatrix<f64> {
        let mut m = DMatrix::zeros(n, idx.len());
        for (j, &i) in idx.iter().enumerate() {
            if let Some(c) = cols[i] {
                for (k, v) in c.iter().enumerate() {
                    m[(k, j)] = *v;
                }
            }
        }
        m
    };
    let b_idx: Vec<usize> = (0..base_free.len()).collect();
    let b = to_mat(&b_idx);
    let rv = DVector::from_column_slice(&r0);
    let mut out = Vec::new();
    for c in cands {
        let idx: Vec<usize> = c
            .params
            .iter()
            .filter_map(|p| eff_index.get(p).copied())
            .collect();
        if idx.is_empty() {
            continue;
        }
        let mut cm = to_mat(&idx);
        let f = row_factors(
            model,
            runs,
            view,
            scales,
            &candidate_scales(c.effect, scales),
        );
        let (rv_c, b_c) = match &f {
            Some(f) => {
                let mut bb = b.clone();
                scale_rows(&mut bb, f);
                scale_rows(&mut cm, f);
                (rv.component_mul(&DVector::from_column_slice(f)), bb)
            }
            None => (rv.clone(), b.clone()),
        };
        let (rv, b) = (&rv_c, &b_c);
        let side: Vec<i8> = base_free
            .iter()
            .chain(c.params.iter().filter(|p| eff_index.contains_key(p)))
            .map(|p| bound_side(model, *p))
            .collect();
        let Some((res0, res1, dx)) = ls_gain(rv, b, &cm, &side) else {
            continue;
        };
        let nb = base_free.len();
        let dc: Vec<f64> = dx.iter().skip(nb).copied().collect();
        let start_base: Vec<f64> = base_free
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let m = p.meta();
                let v = model.get(*p).unwrap_or(0.0);
                // Damped Gauss–Newton step of the base, kept within bounds.
                (v + 0.8 * dx.get(i).copied().unwrap_or(0.0)).clamp(m.lo, m.hi)
            })
            .collect();
        let (rss0, rss1) = (res0.norm_squared(), res1.norm_squared());
        let q = idx.len() as f64;
        let ratio = (rss0 / rss1.max(1e-300)).max(1.0);
        let dbic = n_eff * ratio.ln() - q * n_eff.ln();
        let c0 = obj.channel_costs(res0.as_slice());
        let c1 = obj.channel_costs(res1.as_slice());
        let home = home_channels(c.effect);
        let frac = |only_home: bool| {
            obj.channels
                .iter()
                .enumerate()
                .filter(|(_, ch)| !only_home || home.contains(ch))
                .map(|(i, _)| {
                    if c0[i] > 0.0 {
                        1.0 - c1[i] / c0[i]
                    } else {
                        0.0
                    }
                })
                .fold(f64::NEG_INFINITY, f64::max)
        };
        let mut explained = frac(true);
        if !explained.is_finite() {
            explained = frac(false);
        }
        let start = c
            .params
            .iter()
            .enumerate()
            .map(|(j, p)| {
                let cur = model.get(*p).or_else(|| p.off_value()).unwrap_or(0.0);
                let meta = p.meta();
                (cur + dc.get(j).copied().unwrap_or(0.0)).clamp(meta.lo, meta.hi)
            })
            .collect();
        // Base parameters whose sensitivity overlaps the effect's.
        let mut conf: Vec<(f64, Param)> = Vec::new();
        for (bi, bp) in base_free.iter().enumerate() {
            let bcol = b.column(bi);
            let bn = bcol.norm();
            if bn <= 0.0 {
                continue;
            }
            let mut best: f64 = 0.0;
            for j in 0..cm.ncols() {
                let ccol = cm.column(j);
                let cn = ccol.norm();
                if cn > 0.0 {
                    best = best.max((bcol.dot(&ccol) / (bn * cn)).abs());
                }
            }
            conf.push((best, *bp));
        }
        conf.sort_by(|a, b| b.0.total_cmp(&a.0));
        // The base parameters of the axes where the effect shows are always refitted
        // with it (a reverse-thrust ratio trades against the thrust gain and the drag of
        // its axis), then the most overlapping others.
        let mut confounded: Vec<Param> = base_free
            .iter()
            .copied()
            .filter(|p| axis_params_of(&home).contains(p))
            .collect();
        for (cs, p) in &conf {
            if confounded.len() >= MAX_CONFOUNDED {
                break;
            }
            if *cs > CONFOUND_COSINE && !confounded.contains(p) {
                confounded.push(*p);
            }
        }
        out.push(Screened {
            cand: c.clone(),
            dbic,
            explained: explained.max(0.0),
            start,
            start_base,
            base_params: base_free.to_vec(),
            confounded,
            view,
        });
    }
    Ok(out)
}

#[derive(Debug, Clone)]
struct Confirmed {
    effect: EffectId,
    contained: bool,
    params: Vec<Param>,
    /// Base parameters refitted with the effect.
    base_fit: Vec<Param>,
    fit: Calibration,
    eval: Evaluation,
    control: Option<Evaluation>,
    dbic: f64,
    view: View,
    /// An effect-specific signature check that failed, if any.
    signature_failed: Option<String>,
}

/// Depth-residual slope while the thrusters rest (last 60 % of rest segments of at
/// least 4 s), pooled: (slope m/s, standard error). A sensor drift keeps growing while
/// the vehicle is still; a dynamic mismatch does not.
fn rest_depth_slope(model: &LabModel, runs: &[Run]) -> Option<(f64, f64)> {
    let (mut sxy, mut sxx, mut n_tot, mut rss) = (0.0, 0.0, 0usize, 0.0);
    let mut pieces = Vec::new();
    for run in runs {
        let y = run.channel(Channel::Depth)?;
        let pred = crate::sim::simulate_run(model, run, &[0]).ok()?;
        let p = pred.channel(Channel::Depth)?;
        for seg in &run.segments {
            if seg.kind != SegmentKind::Rest || seg.t_end_s - seg.t_start_s < 4.0 {
                continue;
            }
            let start = seg.start + (seg.end - seg.start) * 2 / 5;
            let pts: Vec<(f64, f64)> = (start..seg.end)
                .filter(|k| y[*k].is_finite() && p[*k].is_finite())
                .map(|k| (run.t[k], p[k] - y[k]))
                .collect();
            if pts.len() < 5 {
                continue;
            }
            let m = pts.len() as f64;
            let tm = pts.iter().map(|q| q.0).sum::<f64>() / m;
            let em = pts.iter().map(|q| q.1).sum::<f64>() / m;
            let a: f64 = pts.iter().map(|q| (q.0 - tm) * (q.1 - em)).sum();
            let b: f64 = pts.iter().map(|q| (q.0 - tm).powi(2)).sum();
            sxy += a;
            sxx += b;
            pieces.push((pts, tm, em));
        }
    }
    if sxx <= 0.0 {
        return None;
    }
    // Model error e = prediction − measurement; a reading drifting up makes e fall.
    let slope = sxy / sxx;
    for (pts, tm, em) in &pieces {
        for q in pts {
            rss += (q.1 - em - slope * (q.0 - tm)).powi(2);
            n_tot += 1;
        }
    }
    let dof = (n_tot as f64 - 2.0 * pieces.len() as f64).max(1.0);
    let se = (rss / dof / sxx).sqrt();
    Some((-slope, se))
}

/// Kinematic check of a sensor effect on depth or heading against the measured rates
/// (heave velocity with surge, sway and attitude when present; yaw rate with pitch rate
/// and attitude). Per run, the discrepancy D_k = y_k − y_0 − ∫ ẏ dt between the reading
/// and the integrated measured rate is regressed (through the origin, pooled over runs)
/// on the reading offset S_k = o_k − o_0 that the fitted sensor effect predicts:
/// (β, standard error, inflated for the residual's lag-1 autocorrelation). β ≈ 1: the
/// reading departs from the motion as the effect says; β ≈ 0: the motion accounts for
/// the reading. `None` when the rate is not measured or the effect predicts no offset.
fn kinematic_ratio(
    runs: &[Run],
    ch: Channel,
    offset: impl Fn(&Run, usize) -> f64,
) -> Option<(f64, f64)> {
    let rate_ch = match ch {
        Channel::Depth => Channel::Heave,
        Channel::Heading => Channel::YawRate,
        _ => return None,
    };
    let (mut sds, mut sss) = (0.0, 0.0);
    let mut pairs: Vec<Vec<(f64, f64)>> = Vec::new();
    for run in runs {
        let (Some(y), Some(main_rate)) = (run.channel(ch), run.channel(rate_ch)) else {
            continue;
        };
        let get = |c: Channel, k: usize| -> f64 {
            run.channel(c)
                .and_then(|v| v.get(k))
                .copied()
                .filter(|x| x.is_finite())
                .unwrap_or(0.0)
        };
        // The channel's rate from the measured body rates and attitude, per second.
        let rate = |k: usize| -> Option<f64> {
            let r = main_rate.get(k).copied().filter(|x| x.is_finite())?;
            let (th, ph) = (
                get(Channel::Pitch, k).to_radians(),
                get(Channel::Roll, k).to_radians(),
            );
            Some(match ch {
                Channel::Depth => {
                    -get(Channel::Surge, k) * th.sin()
                        + get(Channel::Sway, k) * th.cos() * ph.sin()
                        + r * th.cos() * ph.cos()
                }
                _ => (get(Channel::PitchRate, k) * ph.sin() + r * ph.cos()) / th.cos().max(0.1),
            })
        };
        let (Some(&y0), Some(r0)) = (y.first(), rate(0)) else {
            continue;
        };
        let o0 = offset(run, 0);
        let mut integral = 0.0;
        let mut prev = r0;
        let mut pts = Vec::with_capacity(run.len());
        for (k, yk) in y.iter().enumerate().skip(1) {
            let rk = rate(k).unwrap_or(prev);
            integral += 0.5 * (prev + rk) * (run.t[k] - run.t[k - 1]);
            prev = rk;
            if !yk.is_finite() || !y0.is_finite() {
                continue;
            }
            let d = yk - y0 - integral;
            let sk = offset(run, k) - o0;
            sds += d * sk;
            sss += sk * sk;
            pts.push((d, sk));
        }
        pairs.push(pts);
    }
    if sss <= 0.0 || !sss.is_finite() {
        return None;
    }
    let beta = sds / sss;
    let (mut rss, mut c1, mut n) = (0.0, 0.0, 0usize);
    for pts in &pairs {
        let mut prev: Option<f64> = None;
        for (d, sk) in pts {
            let e = d - beta * sk;
            rss += e * e;
            if let Some(p) = prev {
                c1 += p * e;
            }
            prev = Some(e);
            n += 1;
        }
    }
    if n < 3 || rss <= 0.0 {
        return Some((beta, 0.0));
    }
    let rho = (c1 / rss).clamp(0.0, 0.99);
    let se = (rss / (n as f64 - 1.0) / sss).sqrt() * ((1.0 + rho) / (1.0 - rho)).sqrt();
    Some((beta, se))
}

/// Whether a kinematic ratio (see [`kinematic_ratio`]) confirms a sensor effect: the
/// reading departs from the integrated motion by at least half and at most twice the
/// fitted offset, clearly (three standard errors) above zero.
fn kinematic_consistent(beta: f64, se: f64) -> bool {
    (0.5..=2.0).contains(&beta) && beta > 3.0 * se
}

/// The starting Jacobian of a fit from screening columns (`None` if any is missing), rows
/// rescaled by `rows` when the fit's weights differ from the screening's.
fn cached_jacobian(
    cache: &ColumnCache,
    free: &[Param],
    rows: Option<&[f64]>,
) -> Option<DMatrix<f64>> {
    let cols: Vec<&Vec<f64>> = free.iter().map(|p| cache.get(p)).collect::<Option<_>>()?;
    let n = cols.first().map_or(0, |c| c.len());
    if cols.iter().any(|c| c.len() != n) || n == 0 {
        return None;
    }
    let mut j = DMatrix::zeros(n, free.len());
    for (c, col) in cols.iter().enumerate() {
        for (k, v) in col.iter().enumerate() {
            j[(k, c)] = *v;
        }
    }
    if let Some(f) = rows {
        if f.len() != n {
            return None;
        }
        scale_rows(&mut j, f);
    }
    Some(j)
}

/// The screening caches by view.
struct Caches<'a> {
    short: &'a ColumnCache,
    shoot: &'a ColumnCache,
    free: &'a ColumnCache,
    scales: &'a ViewScales,
}

impl Caches<'_> {
    fn of(&self, v: View) -> &ColumnCache {
        match v {
            View::FreeRun => self.free,
            View::Shooting(_) => self.shoot,
            View::KStep(_) => self.short,
        }
    }
}

/// Channel misfit scales of the current model in each error view (the objective weights,
/// see [`crate::calibrate`]): every candidate of a round is fitted and scored with the
/// same weights, re-estimated after each accepted effect.
#[derive(Debug, Clone, Copy)]
struct ViewScales {
    short: ChannelScales,
    shoot: ChannelScales,
    free: ChannelScales,
}

impl ViewScales {
    fn of_model(model: &LabModel, runs: &[Run]) -> Result<Self, LabError> {
        // One scale per channel for every view: the channel's error level under the
        // current model in multiple shooting (the calibration's view). The free run's
        // accumulated error (a sensor drift's) is what a slow effect must explain, so it
        // must not lower that channel's weight.
        let s = structural_scales(
            runs,
            &misfit_scales(model, runs, View::Shooting(SHOOTING_WINDOW_S))?,
        );
        Ok(Self {
            short: s,
            shoot: s,
            free: s,
        })
    }

    fn of(&self, v: View) -> &ChannelScales {
        match v {
            View::FreeRun => &self.free,
            View::Shooting(_) => &self.shoot,
            View::KStep(_) => &self.short,
        }
    }
}

/// Rescales cached sensitivity columns from the weights of `old` to those of `new`.
fn rescale_cache(
    cache: &mut ColumnCache,
    model: &LabModel,
    runs: &[Run],
    view: View,
    old: &ChannelScales,
    new: &ChannelScales,
) {
    let Some(f) = row_factors(model, runs, view, old, new) else {
        return;
    };
    for col in cache.values_mut() {
        col.iter_mut().zip(&f).for_each(|(x, k)| *x *= k);
    }
}

/// The channel weights of one candidate's fits: the channels where its signature lives
/// carry their noise weights, all others the structural misfit of the current model
/// (`base`). Iterative reweighting evaluates the weights at the solution it expects, and a
/// candidate that is right brings its own channels down to their noise while leaving
/// the others as they are; the home channels' large current misfit must therefore not
/// discount the very evidence the candidate is judged on, and the other channels' misfit
/// must not dominate its fit (a pitch response to a missing moment arm steering the fit
/// of a thrust asymmetry).
fn candidate_scales(effect: EffectId, base: &ChannelScales) -> ChannelScales {
    let mut s = *base;
    for ch in home_channels(effect) {
        s[crate::data::ch_index(ch)] = 0.0;
    }
    s
}

/// First confirmation stage: the effect's parameters with every calibrated base
/// parameter, in the view where the candidate screened best, then settled in its primary
/// view; Levenberg–Marquardt with Broyden updates from the screening Jacobian (cheap).
/// Started from the better of "effect off", the screening's linearised step and spread
/// values of kinked parameters; judged on the held-out runs.
#[allow(clippy::too_many_arguments)]
fn confirm_stage1(
    model: &LabModel,
    base_eval: &Evaluation,
    train: &[Run],
    val: &[Run],
    base_free: &[Param],
    s: &Screened,
    iterations: usize,
    caches: &Caches<'_>,
) -> Result<(Confirmed, Judgement), LabError> {
    let view = primary_view(s.cand.effect);
    // The calibrated base parameters are refitted with the effect (modellab.md §4.7: the
    // null is "base refit", and an effect that corrects a base parameter's compensation
    // must be able to move it back, e.g. the CG height after a missing moment arm). In the
    // free-run view (slow sensor drift) only the parameters of the effect's own axes are:
    // the base was calibrated on re-initialised windows, and in the free run the
    // accumulated error of an unrelated channel (heading) would otherwise pull its
    // parameters away from that calibration. (Sensitivity overlaps are no guide there:
    // any two slowly accumulating errors look alike.)
    let fit_base: Vec<Param> = if view == View::FreeRun || s.view == View::FreeRun {
        let own = axis_params_of(&home_channels(s.cand.effect));
        base_free
            .iter()
            .copied()
            .filter(|p| own.contains(p))
            .collect()
    } else {
        base_free.to_vec()
    };
    let mut free: Vec<Param> = fit_base.clone();
    for p in &s.cand.params {
        if !free.contains(p) {
            free.push(*p);
        }
    }
    let mut with_effect = model.clone();
    with_effect.add_effect(s.cand.effect);
    let first_view = s.view;
    let cs_first = candidate_scales(s.cand.effect, caches.scales.of(first_view));
    let cs_view = candidate_scales(s.cand.effect, caches.scales.of(view));
    let rows_first = row_factors(
        model,
        train,
        first_view,
        caches.scales.of(first_view),
        &cs_first,
    );
    let rows_view = row_factors(model, train, view, caches.scales.of(view), &cs_view);
    let obj = Objective::scaled(model, train, first_view, &cs_first);
    let cost_of = |m: &LabModel| -> f64 {
        obj.residuals(m)
            .map(|r| r.iter().map(|x| x * x).sum())
            .unwrap_or(f64::INFINITY)
    };
    let off_base = model.values(base_free);
    // The screening's linearised base step, on the refitted parameters only.
    let step_base: Vec<f64> = base_free
        .iter()
        .zip(&off_base)
        .map(|(p, off)| {
            let screened = s
                .base_params
                .iter()
                .position(|q| q == p)
                .and_then(|i| s.start_base.get(i));
            match screened {
                Some(v) if fit_base.contains(p) => *v,
                _ => *off,
            }
        })
        .collect();
    let mut starts: Vec<(Vec<f64>, Vec<f64>)> = vec![
        (off_base.clone(), model.values(&s.cand.params)),
        (step_base.clone(), s.start.clone()),
        (off_base.clone(), s.start.clone()),
    ];
    for (j, p) in s.cand.params.iter().enumerate() {
        let spread: &[f64] = match p {
            Param::PowerMax => &[0.3, 0.6, 1.0, 1.5],
            Param::Deadzone => &[0.05, 0.12, 0.2],
            Param::LagTau => &[0.1, 0.3],
            _ => &[],
        };
        for v in spread {
            let mut x = s.start.clone();
            x[j] = *v;
            starts.push((step_base.clone(), x));
        }
    }
    let mut ranked: Vec<(f64, LabModel)> = Vec::new();
    for (b, e) in starts {
        let Ok(m) = with_effect
            .with(base_free, &b)
            .and_then(|m| m.with(&s.cand.params, &e))
        else {
            continue;
        };
        ranked.push((cost_of(&m), m));
    }
    ranked.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Kinked parameters (power budget, dead zone, lag) get a second start.
    let kinked = s
        .cand
        .params
        .iter()
        .any(|p| matches!(p, Param::PowerMax | Param::Deadzone | Param::LagTau));
    let n_starts = if kinked { 2 } else { 1 };
    let bounds = effect_bounds(model, &free, &s.cand.params, &fit_base);
    let opts = LmOptions {
        max_iter: iterations * 2,
        threads: 1,
        ..Default::default()
    };
    let mut stage1: Option<Calibration> = None;
    let mut tried = 0;
    // A fit that ends pinned at a plausibility bound has failed (see [`pinned_param`]):
    // then the next start is tried too, and an unpinned fit is preferred to a pinned one.
    let pinned = |c: &Calibration| pinned_in(&c.model, &s.cand.params).is_some();
    for (_, start_model) in ranked.iter() {
        let needed = tried < n_starts || stage1.as_ref().is_some_and(&pinned);
        if !needed || tried >= n_starts + MAX_EXTRA_STARTS {
            break;
        }
        tried += 1;
        let Ok(f1) = fit_scaled(
            start_model,
            train,
            &free,
            first_view,
            None,
            Some(bounds.clone()),
            &opts,
            cached_jacobian(caches.of(first_view), &free, rows_first.as_deref()),
            &cs_first,
        ) else {
            continue;
        };
        let better = match &stage1 {
            None => true,
            Some(b) => {
                let (pf, pb) = (pinned(&f1), pinned(b));
                if pf != pb { !pf } else { f1.cost < b.cost }
            }
        };
        if better {
            stage1 = Some(f1);
        }
    }
    // Screened (and first fitted) in the short view: the best start settles in the
    // primary view.
    if first_view != view
        && let Some(f1) = &stage1
        && let Ok(f2) = fit_scaled(
            &f1.model,
            train,
            &free,
            view,
            None,
            Some(bounds.clone()),
            &opts,
            cached_jacobian(caches.of(view), &free, rows_view.as_deref()),
            &cs_view,
        )
    {
        stage1 = Some(f2);
    }
    let Some(stage1) = stage1 else {
        return Err(LabError::Model {
            detail: format!(
                "{}: no start of {tried} could be fitted",
                s.cand.effect.key()
            ),
        });
    };
    let eval = evaluate(&stage1.model, val)?;
    let control = control_eval(model, &stage1.model, &s.cand.params, s.cand.contained, val);
    let c = Confirmed {
        effect: s.cand.effect,
        contained: s.cand.contained,
        params: s.cand.params.clone(),
        base_fit: fit_base.clone(),
        fit: stage1,
        eval,
        control,
        dbic: f64::INFINITY,
        view,
        signature_failed: None,
    };
    let j = judge(base_eval, &c);
    Ok((c, j))
}

/// "Base refit only" control: the fitted model with the effect's own parameters back at
/// "off" (for a contained effect, back at their previous values), on the held-out runs.
fn control_eval(
    model: &LabModel,
    fitted: &LabModel,
    params: &[Param],
    contained: bool,
    val: &[Run],
) -> Option<Evaluation> {
    let off: Vec<f64> = params
        .iter()
        .map(|p| {
            if contained {
                model.get(*p).or_else(|| p.off_value()).unwrap_or(0.0)
            } else {
                p.off_value().or_else(|| model.get(*p)).unwrap_or(0.0)
            }
        })
        .collect();
    let ctrl = fitted.with(params, &off).ok()?;
    evaluate(&ctrl, val).ok()
}

/// Bounds for a joint fit: effect parameters without prior, base parameters with a weak
/// prior at their current values.
fn effect_bounds(
    model: &LabModel,
    free: &[Param],
    effect: &[Param],
    keep_prior: &[Param],
) -> Vec<Bound> {
    let mut b = bounds_for(model, free, true);
    for (i, p) in free.iter().enumerate() {
        if effect.contains(p) && !keep_prior.contains(p) {
            b[i].prior = None;
        } else if let Some(v) = model.get(*p) {
            let m = p.meta();
            b[i].prior = Some((v, (v.abs() * 2.0).max(m.scale * 20.0)));
        }
    }
    b
}

/// Second confirmation stage for the promising candidates: every base parameter free,
/// the primary view, then the held-out judgement with the "base refit only" control and
/// the effect's signature checks.
#[allow(clippy::too_many_arguments)]
fn refine(
    model: &LabModel,
    base_eval: &Evaluation,
    train: &[Run],
    val: &[Run],
    stage1: &Confirmed,
    contained: bool,
    iterations: usize,
    scales: &ViewScales,
) -> Result<(Confirmed, Judgement), LabError> {
    let view = stage1.view;
    let mut all_free: Vec<Param> = stage1.base_fit.clone();
    for p in &stage1.params {
        if !all_free.contains(p) {
            all_free.push(*p);
        }
    }
    let opts = LmOptions {
        max_iter: iterations,
        threads: 1,
        ..Default::default()
    };
    let bounds = effect_bounds(model, &all_free, &stage1.params, &stage1.base_fit);
    let cs = candidate_scales(stage1.effect, scales.of(view));
    let fitted = fit_scaled(
        &stage1.fit.model,
        train,
        &all_free,
        view,
        None,
        Some(bounds),
        &opts,
        None,
        &cs,
    )?;
    let obj_v = Objective::scaled(model, train, view, &cs);
    let base_cost: f64 = obj_v
        .residuals(model)
        .map(|r| r.iter().map(|x| x * x).sum())
        .unwrap_or(f64::INFINITY);
    let n_eff = fitted.n_eff;
    let q = stage1.params.len() as f64;
    let dbic = n_eff * (base_cost / fitted.cost.max(1e-300)).max(1.0).ln() - q * n_eff.ln();
    let eval = evaluate(&fitted.model, val)?;
    let mut signature_failed = None;
    if stage1.effect == EffectId::ThrusterLag {
        let dt = train.first().map_or(0.05, |r| r.median_dt());
        let tau = fitted.model.get(Param::LagTau).unwrap_or(0.0);
        if tau < LAG_RESOLUTION * dt {
            signature_failed = Some(format!(
                "the fitted lag of {:.0} ms is below half the sample period ({:.0} ms), too short to resolve at this rate",
                tau * 1000.0,
                LAG_RESOLUTION * dt * 1000.0
            ));
        }
    }
    let all_runs: Vec<Run> = train.iter().chain(val.iter()).cloned().collect();
    if stage1.effect == EffectId::DepthSensorDrift {
        let rate = fitted.model.get(Param::DepthDrift).unwrap_or(0.0);
        if let Some((beta, se)) = kinematic_ratio(&all_runs, Channel::Depth, |run, k| {
            rate * (run.t[k] - run.t[0])
        }) {
            // The heave velocity is measured: a drifting reading must depart from the
            // depth change that the measured velocity integrates to, at the fitted rate.
            if !kinematic_consistent(beta, se) {
                signature_failed = Some(format!(
                    "the measured heave velocity accounts for the depth change: the depth reading departs from the integrated velocity at {:.1} ± {:.1} cm/min, not at the {:.1} cm/min fitted, so the drift is in the motion, not in the sensor",
                    beta * rate * 6000.0,
                    se * (rate * 6000.0).abs(),
                    rate * 6000.0
                ));
            }
        } else {
            match rest_depth_slope(model, &all_runs) {
                Some((slope, se)) => {
                    let ok = slope * rate > 0.0
                        && slope.abs() >= 0.4 * rate.abs()
                        && slope.abs() > 2.0 * se;
                    if !ok {
                        signature_failed = Some(format!(
                            "the depth error does not grow while the vehicle rests ({:.1} ± {:.1} cm/min against {:.1} cm/min fitted), so the drift is dynamic, not the sensor",
                            slope * 6000.0,
                            se * 6000.0,
                            rate * 6000.0
                        ));
                    }
                }
                None => {
                    signature_failed = Some(
                        "no rest segments of 4 s or more to check that the drift persists at rest"
                            .into(),
                    );
                }
            }
        }
    }
    if stage1.effect == EffectId::CompassDeviation {
        let m = &fitted.model;
        if let Some((beta, se)) = kinematic_ratio(&all_runs, Channel::Heading, |run, k| {
            let psi = run
                .channel(Channel::Heading)
                .and_then(|h| h.get(k))
                .copied()
                .unwrap_or(0.0);
            let cmd = if k == 0 { run.cmd[0] } else { run.cmd[k - 1] };
            m.heading_offset_deg(psi.to_radians(), &cmd)
        }) && !kinematic_consistent(beta, se)
        {
            signature_failed = Some(format!(
                "the measured yaw rate accounts for the heading changes: the compass departs from the integrated rate by {:.2} ± {:.2} of the fitted deviation and interference, so the heading error is in the motion, not in the compass",
                beta, se
            ));
        }
    }
    let control = control_eval(model, &fitted.model, &stage1.params, contained, val);
    let c = Confirmed {
        effect: stage1.effect,
        contained,
        params: stage1.params.clone(),
        base_fit: stage1.base_fit.clone(),
        fit: fitted,
        eval,
        control,
        dbic,
        view,
        signature_failed,
    };
    let j = judge(base_eval, &c);
    Ok((c, j))
}

#[derive(Debug, Clone)]
struct Judgement {
    significant: bool,
    channels: Vec<ChannelKey>,
    /// The view that shows the finding best (its home channels' larger reduction).
    view: View,
    primary: BTreeMap<String, f64>,
    free: BTreeMap<String, f64>,
    shoot: BTreeMap<String, f64>,
    score: f64,
    explained: BTreeMap<ChannelKey, f64>,
    reason: String,
}

fn reduction(base: f64, new: f64) -> f64 {
    if base > 0.0 { 1.0 - new / base } else { 0.0 }
}

/// RMS change of a channel's held-out prediction between two evaluations, in the
/// (shooting, free-run) views.
fn prediction_change_rms(a: &Evaluation, b: &Evaluation, ch: Channel) -> (f64, f64) {
    let rms = |pa: &[crate::sim::Prediction], pb: &[crate::sim::Prediction]| {
        let (mut s, mut n) = (0.0, 0usize);
        for (x, y) in pa.iter().zip(pb) {
            if let (Some(x), Some(y)) = (x.channel(ch), y.channel(ch)) {
                for (p, q) in x.iter().zip(y) {
                    let d = crate::metrics::residual(ch, *p, *q);
                    if d.is_finite() {
                        s += d * d;
                        n += 1;
                    }
                }
            }
        }
        if n > 0 { (s / n as f64).sqrt() } else { 0.0 }
    };
    (rms(&a.shooting, &b.shooting), rms(&a.free_run, &b.free_run))
}

/// An effect parameter of a fitted candidate that sits at (within [`BOUND_MARGIN`] of the
/// range) a bound that is a plausibility limit, not a physical one: (key, value, bound),
/// display units.
fn pinned_param(c: &Confirmed) -> Option<(String, f64, f64)> {
    pinned_in(&c.fit.model, &c.params)
}

/// [`pinned_param`] for a model and a parameter list.
fn pinned_in(model: &LabModel, params: &[Param]) -> Option<(String, f64, f64)> {
    for p in params {
        let m = p.meta();
        let Some(v) = model.get(*p) else {
            continue;
        };
        let margin = BOUND_MARGIN * (m.hi - m.lo);
        for (bound, upper) in [(m.lo, false), (m.hi, true)] {
            if (v - bound).abs() <= margin && !p.bound_is_physical(upper) {
                return Some((p.key(), p.display(v).0, p.display(bound).0));
            }
        }
    }
    None
}

/// Judges a fitted candidate against the current model on the held-out runs. Every
/// candidate is judged the same way, on both error views (multiple shooting and free
/// run), whichever view it was fitted in:
///
/// * **explained channel**: its held-out RMSE falls by [`MIN_REDUCTION`] in *both* views
///   (a real effect improves the re-initialised windows and the free run alike; a gain in
///   one view only is that view's artefact: slow compensation accumulating in the free
///   run, re-initialisation in the windows); it was above [`NOISE_FACTOR`] noise floors in
///   at least one view; and switching the effect's own term off again (base refit kept)
///   brings the error back (the "base refit only" control, as the two views' mean). At
///   least one explained channel must be a home channel of the fitted parameters.
/// * **made worse** (a veto): the two-view mean RMSE rises by more than [`MAX_WORSE`] and
///   sits above the floor — unless the rise is not evidence against the effect:
///   (a) *comparable to noise*: the effect moved that channel's held-out prediction by
///   less than [`WORSE_NOISE_FRACTION`] of its noise floor (RMS, mean of the views), so
///   the RMSE change is within what the noise makes of any small change; or
///   (b) *already badly fitted for reasons the effect does not touch*: the channel is
///   not one the effect claims, the base misses it by more than [`REWEIGHT_FACTOR`]
///   noise floors (a structural misfit: missing physics elsewhere), and the rise is at
///   most [`MAX_WORSE_UNEXPLAINED`] of that misfit — its error is dominated by what is
///   still missing and moves with any coupling; the greedy loop judges it again once that
///   is found; or (c) the loss is small against the gain, both in noise floors
///   ([`WORSE_FRACTION_OF_GAIN`]).
/// * **plausible parameters**: no effect parameter sits at a plausibility bound
///   ([`pinned_param`]): a fit pinned there stands in for something else (a depth drift
///   at its 60 cm/min limit absorbing a thrust asymmetry).
/// * training ΔBIC above [`MIN_DBIC`] and the effect's signature checks.
///
/// The ranking score is the same for every candidate: the noise-normalised held-out RMSE
/// gain summed over channels, both views counting half.
fn judge(base: &Evaluation, c: &Confirmed) -> Judgement {
    let mut free = BTreeMap::new();
    let mut shoot = BTreeMap::new();
    let mut channels = Vec::new();
    let mut score = 0.0;
    let mut worse: Vec<(String, f64)> = Vec::new();
    let home = fitted_home_channels(c);
    let mut claimed = home.clone();
    for ch in home_channels(c.effect) {
        if !claimed.contains(&ch) {
            claimed.push(ch);
        }
    }
    let mut home_hit = false;
    // Best home-channel reduction per view (for the reported view).
    let (mut best_shoot, mut best_free) = (f64::NEG_INFINITY, f64::NEG_INFINITY);
    for (k, b) in &base.channels {
        let Some(n) = c.eval.channels.get(k) else {
            continue;
        };
        let ch = k.channel();
        let name = k.name().to_string();
        let bv = [b.shooting.rmse, b.free_run.rmse];
        let nv = [n.shooting.rmse, n.free_run.rmse];
        let red = [reduction(bv[0], nv[0]), reduction(bv[1], nv[1])];
        shoot.insert(name.clone(), 100.0 * red[0]);
        free.insert(name.clone(), 100.0 * red[1]);
        if claimed.contains(&ch) {
            best_shoot = best_shoot.max(red[0]);
            best_free = best_free.max(red[1]);
        }
        let mean_red = 0.5 * (red[0] + red[1]);
        let floor = b.noise * NOISE_FACTOR;
        let above = bv.iter().any(|x| *x > floor);
        let control_ok = match &c.control {
            None => true,
            Some(ctrl) => ctrl.channels.get(k).is_some_and(|cc| {
                let cv = [cc.shooting.rmse, cc.free_run.rmse];
                let back = [cv[0] - nv[0], cv[1] - nv[1]];
                let back_rel = 0.5
                    * (if cv[0] > 0.0 { back[0] / cv[0] } else { 0.0 }
                        + if cv[1] > 0.0 { back[1] / cv[1] } else { 0.0 });
                back[0] + back[1] >= CONTROL_FRACTION * (bv[0] - nv[0] + bv[1] - nv[1])
                    && back_rel >= MIN_REDUCTION
            }),
        };
        if above && red[0].min(red[1]) >= MIN_REDUCTION && control_ok {
            channels.push(*k);
            home_hit |= home.contains(&ch);
        }
        let sigma = b.noise.max(1e-12);
        let worse_view_above = (0..2).any(|v| red[v] < -MAX_WORSE && nv[v] > floor);
        if mean_red < -MAX_WORSE && worse_view_above {
            let (ds, df) = prediction_change_rms(&c.eval, base, ch);
            let within_noise = 0.5 * (ds + df) < WORSE_NOISE_FRACTION * sigma;
            let unexplained = !claimed.contains(&ch)
                && bv[0] > REWEIGHT_FACTOR * sigma
                && -mean_red <= MAX_WORSE_UNEXPLAINED;
            if !within_noise && !unexplained {
                let loss = 0.5 * ((nv[0] - bv[0]) + (nv[1] - bv[1])) / sigma;
                worse.push((name, loss));
            }
        }
        score += 0.5 * (((bv[0] - nv[0]) / sigma).max(0.0) + ((bv[1] - nv[1]) / sigma).max(0.0));
    }
    let view = if best_free > best_shoot {
        View::FreeRun
    } else {
        View::Shooting(SHOOTING_WINDOW_S)
    };
    let primary = match view {
        View::FreeRun => free.clone(),
        _ => shoot.clone(),
    };
    let mut explained = BTreeMap::new();
    for k in &channels {
        if let (Some(b), Some(n)) = (base.channels.get(k), c.eval.channels.get(k)) {
            let (bb, nn) = match view {
                View::FreeRun => (b.free_run.rmse, n.free_run.rmse),
                _ => (b.shooting.rmse, n.shooting.rmse),
            };
            explained.insert(*k, (1.0 - (nn / bb.max(1e-300)).powi(2)).max(0.0));
        }
    }
    // (c): a worsened channel whose loss is small against the gain does not block.
    let worse: Vec<String> = worse
        .into_iter()
        .filter(|(_, loss)| *loss > WORSE_FRACTION_OF_GAIN * score)
        .map(|(n, _)| n)
        .collect();
    let mut reason = String::new();
    if channels.is_empty() {
        reason = format!(
            "no channel above its noise floor improved by {:.0} % on the held-out data in both the shooting and the free-run view with the effect's own term mattering",
            MIN_REDUCTION * 100.0
        );
    } else if !home_hit {
        reason = format!(
            "it improves only {} on the held-out data, not where its signature lives",
            channels
                .iter()
                .map(|k| k.name())
                .collect::<Vec<_>>()
                .join(", ")
        );
    } else if !worse.is_empty() {
        reason = format!(
            "it makes {} worse on the held-out data, by more than the noise and more than a channel's unexplained misfit can account for",
            worse.join(", ")
        );
    } else if let Some((key, v, bound)) = pinned_param(c) {
        reason = format!(
            "its {key} = {v:.3} sits at the bound of its plausible range ({bound}); a fit pinned there stands in for another effect rather than measuring this one"
        );
    } else if c.dbic < MIN_DBIC {
        reason = format!("training ΔBIC {:.1} is below {MIN_DBIC}", c.dbic);
    } else if let Some(why) = &c.signature_failed {
        reason = why.clone();
    }
    Judgement {
        significant: reason.is_empty(),
        channels,
        view,
        primary,
        free,
        shoot,
        score,
        explained,
        reason,
    }
}

fn param_reports(c: &Confirmed) -> BTreeMap<String, ParamReport> {
    let mut out = BTreeMap::new();
    for p in &c.params {
        if let Some(i) = c.fit.params.iter().position(|x| x == p)
            && let Some(f) = c.fit.fitted.get(i)
        {
            out.insert(
                f.key.clone(),
                ParamReport {
                    value: f.value,
                    std: f.std.is_finite().then_some(f.std),
                    unit: f.unit.clone(),
                },
            );
        }
    }
    out
}

fn view_name(v: View) -> &'static str {
    match v {
        View::FreeRun => "free_run",
        View::Shooting(_) => "shooting",
        View::KStep(_) => "k_step",
    }
}

/// The experiment that separates two effects (modellab.md §3.4).
pub fn separating_experiment(a: EffectId, b: EffectId) -> String {
    use EffectId::*;
    let pair = |x: EffectId, y: EffectId| (a == x && b == y) || (a == y && b == x);
    let s = if pair(ThrustAsymmetry, NetBuoyancy) {
        "zero-thrust hovers between the up and down vertical steps"
    } else if pair(ThrustAsymmetry, DragForm) {
        "steps from rest and cut-offs at speed, in both directions"
    } else if pair(NetBuoyancy, DepthSensorDrift) {
        "a recording at rest at a known depth (or at the surface) at the start and at the end"
    } else if pair(PitchDepthCoupling, NetBuoyancy)
        || pair(PitchDepthCoupling, ThrustAsymmetry)
        || pair(PitchDepthCoupling, DepthSensorDrift)
    {
        "pure surge runs in both directions and pure vertical runs"
    } else if pair(ThrusterLag, AddedMass) || pair(ThrusterLag, ThrusterDeadzone) {
        "a higher sample rate and fast on/off pulses"
    } else if pair(ThrusterMomentArm, RestoringOffset) || pair(ThrusterMomentArm, AttitudeBias) {
        "pitch and roll at rest compared with pitch and roll during up and down vertical steps"
    } else if pair(PropellerTorque, Tether)
        || pair(PropellerTorque, CompassDeviation)
        || pair(Tether, CompassDeviation)
    {
        "vertical steps at several headings, a slack versus a taut tether, and a rate-gyro log"
    } else if pair(PropellerTorque, Coriolis) {
        "spinning in place versus turning while moving"
    } else if pair(Current, Tether) {
        "runs at different distances and headings"
    } else if pair(PowerLimit, Coriolis) || pair(PowerLimit, ThrustAsymmetry) {
        "combined steps at low and high speed, and single steps at the same levels"
    } else if pair(RestoringOffset, AttitudeBias) {
        "attitude logged with the vehicle levelled in a known state, and surge runs in both directions"
    } else {
        "steps that excite one effect and not the other (see the catalog's needs)"
    };
    s.to_string()
}

fn fmt_pct(x: f64) -> String {
    format!("{:.0} %", x * 100.0)
}

/// The channels where an effect's signature lives first.
fn home_channels(e: EffectId) -> Vec<Channel> {
    use Channel::*;
    match e {
        EffectId::ThrusterMomentArm
        | EffectId::RestoringOffset
        | EffectId::AttitudeBias
        | EffectId::Coriolis => vec![Pitch, Roll, PitchRate, RollRate],
        EffectId::PropellerTorque | EffectId::Tether | EffectId::CompassDeviation => {
            vec![Heading, YawRate]
        }
        EffectId::NetBuoyancy | EffectId::PitchDepthCoupling | EffectId::DepthSensorDrift => {
            vec![Depth, Heave]
        }
        EffectId::Current => vec![North, East, Surge, Sway],
        // Thruster effects: the axes the thrusters drive (surge when measured: a weak
        // reverse thrust surges the vehicle in differential turns).
        _ => vec![Depth, Heading, Heave, YawRate, Surge],
    }
}

/// Base parameters acting on the axes of some channels.
fn axis_params_of(chans: &[Channel]) -> Vec<Param> {
    let mut v = Vec::new();
    for ch in chans {
        let ps: &[Param] = match ch {
            Channel::Depth | Channel::Heave => &[
                Param::ThrustLin(Thr::Vertical),
                Param::ThrustQuad(Thr::Vertical),
                Param::DragLin(Axis::Heave),
                Param::DragQuad(Axis::Heave),
            ],
            Channel::Heading | Channel::YawRate => &[
                Param::ThrustLin(Thr::Port),
                Param::ThrustQuad(Thr::Port),
                Param::ThrustLin(Thr::Starboard),
                Param::ThrustQuad(Thr::Starboard),
                Param::DragLin(Axis::Yaw),
                Param::DragQuad(Axis::Yaw),
            ],
            Channel::Pitch | Channel::PitchRate => &[Param::DragLin(Axis::Pitch), Param::CgZ],
            Channel::Roll | Channel::RollRate => &[Param::DragLin(Axis::Roll), Param::CgZ],
            _ => &[],
        };
        for p in ps {
            if !v.contains(p) {
                v.push(*p);
            }
        }
    }
    v
}

/// Home channels of one parameter (where its own signature lives).
fn param_home(p: Param) -> Option<Vec<Channel>> {
    use Channel::*;
    Some(match p {
        Param::ReverseRatio(Thr::Vertical) | Param::DragRatio(Axis::Heave) => vec![Depth, Heave],
        Param::ReverseRatio(_) => vec![Heading, YawRate, Surge],
        Param::TorqueV
        | Param::DragRatio(Axis::Yaw)
        | Param::CompassSin
        | Param::CompassCos
        | Param::Emi(_) => vec![Heading, YawRate],
        Param::TorqueH | Param::ArmYv | Param::CgY | Param::BiasRoll => vec![Roll, RollRate],
        Param::ArmZh | Param::ArmXv | Param::CgX | Param::BiasPitch => vec![Pitch, PitchRate],
        _ => return None,
    })
}

/// Home channels of a fitted effect: those of its parameters that moved noticeably
/// from "off" (so a torque that only moved its roll part must show in roll).
fn fitted_home_channels(c: &Confirmed) -> Vec<Channel> {
    let mut out: Vec<Channel> = Vec::new();
    let mut any_param = false;
    for p in &c.params {
        let (Some(off), Some(home)) = (p.off_value(), param_home(*p)) else {
            continue;
        };
        any_param = true;
        let v = c.fit.model.get(*p).unwrap_or(off);
        if (v - off).abs() >= 0.25 * (p.probe_value() - off).abs() {
            for ch in home {
                if !out.contains(&ch) {
                    out.push(ch);
                }
            }
        }
    }
    if out.is_empty() && !any_param {
        return home_channels(c.effect);
    }
    out
}

/// Plain-language explanation of a confirmed finding.
fn explain(c: &Confirmed, j: &Judgement, model: &LabModel) -> String {
    let v = |p: Param| c.fit.model.get(p).unwrap_or(0.0);
    let home = home_channels(c.effect);
    let pick = |only_home: bool| {
        j.explained
            .iter()
            .filter(|(k, _)| !only_home || home.contains(&k.channel()))
            .max_by(|a, b| a.1.total_cmp(b.1))
            .map(|(k, f)| (k.name(), *f))
    };
    let (main_ch, frac) = pick(true).or_else(|| pick(false)).unwrap_or(("", 0.0));
    let tail = if main_ch.is_empty() {
        String::new()
    } else {
        format!(" explains {} of the {main_ch} residual", fmt_pct(frac))
    };
    let mm = |x: f64| format!("{:.0} mm", x * 1000.0);
    match c.effect {
        EffectId::ThrustAsymmetry => {
            let mut parts = Vec::new();
            for t in Thr::ALL {
                if c.params.contains(&Param::ReverseRatio(t)) {
                    let r = v(Param::ReverseRatio(t));
                    if (r - 1.0).abs() > 0.03 {
                        parts.push(format!("{} {:.0} %", t.name(), r * 100.0));
                    }
                }
            }
            format!(
                "equal and opposite steps reach different speeds; reverse thrust at {} of forward{tail}",
                if parts.is_empty() {
                    "≈100 %".into()
                } else {
                    parts.join(", ")
                }
            )
        }
        EffectId::ThrusterLag => format!(
            "the response trails every command change and the model leads the data at step onsets; a thruster lag of {:.2} s{tail}",
            v(Param::LagTau)
        ),
        EffectId::ThrusterDeadzone => format!(
            "the lowest command levels deliver far less than the model expects while high levels fit; a dead zone of {:.0} % of full command{tail}",
            v(Param::Deadzone) * 100.0
        ),
        EffectId::PowerLimit => format!(
            "single-thruster steps fit but combined manoeuvres are weaker; a shared power budget of Σ|u|³ = {:.2} (thrust scaled down when exceeded){tail}",
            v(Param::PowerMax)
        ),
        EffectId::ThrusterMomentArm => {
            let xv = v(Param::ArmXv);
            let zh = v(Param::ArmZh);
            let yv = v(Param::ArmYv);
            let mut s = Vec::new();
            if xv.abs() >= 0.001 {
                s.push(format!(
                    "pitch follows vertical thrust with the command's sign; a vertical-thruster moment arm of {} ({} of the CO)",
                    mm(xv.abs()),
                    if xv > 0.0 { "forward" } else { "aft" }
                ));
            }
            if zh.abs() >= 0.001 {
                s.push(format!(
                    "pitch follows surge thrust; the horizontal thrusters act {} {} the CO",
                    mm(zh.abs()),
                    if zh > 0.0 { "below" } else { "above" }
                ));
            }
            if yv.abs() >= 0.001 {
                s.push(format!(
                    "roll follows vertical thrust; the vertical thruster sits {} to {}",
                    mm(yv.abs()),
                    if yv > 0.0 { "starboard" } else { "port" }
                ));
            }
            format!("{}{tail}", s.join("; "))
        }
        EffectId::PropellerTorque => {
            let cv = v(Param::TorqueV);
            let full = model
                .forces(&rov_dynamics::ThrustPct::new(0.0, 0.0, 100.0))
                .vertical_n;
            format!(
                "heading turns whenever the vertical thruster runs, with the command's sign and whatever the heading; a reaction torque of {:.2} mm per newton ({:.3} N m at full vertical thrust){tail}",
                cv * 1000.0,
                cv * full
            )
        }
        EffectId::NetBuoyancy => {
            let wb = v(Param::NetWeight);
            format!(
                "depth drifts at zero vertical thrust, the same way whatever the thrust sign; the vehicle is {} by {:.2} N ({:.1} % of its weight){}{tail}",
                if wb > 0.0 { "heavy" } else { "light" },
                wb.abs(),
                wb.abs() / 59.8 * 100.0,
                if c.contained {
                    "; refitted W − B, which the model already has"
                } else {
                    ""
                }
            )
        }
        EffectId::RestoringOffset => {
            let x = v(Param::CgX);
            let y = v(Param::CgY);
            let zg = c.fit.model.get(Param::CgZ).unwrap_or(0.0056).max(1e-4);
            let trim = (-x / zg).atan().to_degrees();
            let heel = (y / zg).atan().to_degrees();
            format!(
                "the vehicle rests trimmed {:.1}° nose {} and heeled {:.1}° to {} at zero thrust; the CG sits {} {} and {} to {} of the CB (refitted CG offset, which model3 already has){tail}",
                trim.abs(),
                if trim >= 0.0 { "up" } else { "down" },
                heel.abs(),
                if heel >= 0.0 { "starboard" } else { "port" },
                mm(x.abs()),
                if x >= 0.0 { "forward" } else { "aft" },
                mm(y.abs()),
                if y >= 0.0 { "starboard" } else { "port" }
            )
        }
        EffectId::PitchDepthCoupling => format!(
            "depth changes during surge runs with the surge direction; a trim of {:.1}° couples surge speed into depth{tail}",
            v(Param::TrimDeg)
        ),
        EffectId::DragForm => {
            let rh = v(Param::DragRatio(Axis::Heave));
            let ry = v(Param::DragRatio(Axis::Yaw));
            format!(
                "steady speeds differ between directions while accelerations from rest agree; quadratic drag moving up is {:.2}× that moving down, turning to port {:.2}× that to starboard{tail}",
                rh, ry
            )
        }
        EffectId::Current => {
            let (n, e) = (v(Param::CurrentN), v(Param::CurrentE));
            format!(
                "the vehicle drifts over ground independent of heading and thrust; a current of {:.2} m/s towards {:.0}°{tail}",
                n.hypot(e),
                e.atan2(n).to_degrees().rem_euclid(360.0)
            )
        }
        EffectId::Tether => {
            let (n, e) = (v(Param::TetherN), v(Param::TetherE));
            format!(
                "heading weathervanes at zero thrust and the pull depends on heading; a tether pull of {:.2} N towards {:.0}° at 0.2 m behind the CO{tail}",
                n.hypot(e),
                e.atan2(n).to_degrees().rem_euclid(360.0)
            )
        }
        EffectId::DepthSensorDrift => format!(
            "depth drifts linearly from the start of the run regardless of thrust, with no matching heave acceleration; the depth reading drifts {:.1} cm/min{tail}",
            v(Param::DepthDrift) * 6000.0
        ),
        EffectId::CompassDeviation => {
            let mut s = Vec::new();
            for t in Thr::ALL {
                if c.params.contains(&Param::Emi(t)) {
                    let e = v(Param::Emi(t));
                    if e.abs() >= 0.3 {
                        s.push(format!("{:.1}° at full {} thrust", e, t.name()));
                    }
                }
            }
            let dev = v(Param::CompassSin).hypot(v(Param::CompassCos));
            format!(
                "heading jumps when thrusters switch, with no turning phase, and its error varies with heading; compass interference {}{}{tail}",
                if s.is_empty() {
                    "negligible".into()
                } else {
                    s.join(", ")
                },
                if dev >= 0.3 {
                    format!(" and a deviation of {dev:.1}° amplitude")
                } else {
                    String::new()
                }
            )
        }
        EffectId::AttitudeBias => format!(
            "pitch and roll read offset with no matching motion; mounting biases of {:.1}° in pitch and {:.1}° in roll{tail}",
            v(Param::BiasPitch),
            v(Param::BiasRoll)
        ),
        EffectId::AddedMass | EffectId::Coriolis => format!("refitted{tail}"),
    }
}

fn prediction_change(
    a: &Evaluation,
    b: &Evaluation,
    ch: &[ChannelKey],
    noise: &BTreeMap<ChannelKey, f64>,
) -> Vec<f64> {
    let mut v = Vec::new();
    for (pa, pb) in a.shooting.iter().zip(&b.shooting) {
        for k in ch {
            let c = k.channel();
            if let (Some(x), Some(y)) = (pa.channel(c), pb.channel(c)) {
                let s = noise.get(k).copied().unwrap_or(1.0).max(1e-12);
                v.extend(x.iter().zip(y).map(|(p, q)| {
                    let d = crate::metrics::residual(c, *p, *q) / s;
                    if d.is_finite() { d } else { 0.0 }
                }));
            }
        }
    }
    v
}

fn cosine(a: &[f64], b: &[f64]) -> f64 {
    let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        ab += x * y;
        aa += x * x;
        bb += y * y;
    }
    if aa <= 0.0 || bb <= 0.0 {
        0.0
    } else {
        ab / (aa * bb).sqrt()
    }
}

fn rmse_map(e: &Evaluation) -> RmseMaps {
    RmseMaps {
        shooting: e
            .channels
            .iter()
            .map(|(k, c)| (k.name().to_string(), c.shooting.rmse))
            .collect(),
        free_run: e
            .channels
            .iter()
            .map(|(k, c)| (k.name().to_string(), c.free_run.rmse))
            .collect(),
    }
}

fn candidates_of(
    model: &LabModel,
    train: &[Run],
    skip: &[EffectId],
) -> (Vec<Candidate>, Vec<Finding>) {
    let mut cands = Vec::new();
    let mut other = Vec::new();
    for e in EffectId::ALL {
        if skip.contains(&e) {
            continue;
        }
        let blank = |status: Status, expl: String, contained: bool| Finding {
            effect: e.key().into(),
            significant: false,
            status,
            contained,
            channels: vec![],
            view: String::new(),
            validation_rmse_reduction_pct: BTreeMap::new(),
            validation_rmse_reduction_pct_free_run: BTreeMap::new(),
            validation_rmse_reduction_pct_shooting: BTreeMap::new(),
            params: BTreeMap::new(),
            explanation: expl,
            delta_bic: None,
            score: 0.0,
            ambiguous_with: vec![],
            separating_experiment: None,
            round: 0,
        };
        match availability(model, train, e) {
            Availability::Candidate(c) => cands.push(c),
            Availability::NotApplicable(s) => other.push(blank(Status::NotApplicable, s, false)),
            Availability::NotTestable(s) => {
                other.push(blank(Status::NotTestable, s, model.kind().contains(e)))
            }
            Availability::Contained(s) => other.push(blank(Status::Contained, s, true)),
        }
    }
    (cands, other)
}

/// Diagnoses a base model on training runs, judging on held-out runs.
pub fn diagnose(
    base: &LabModel,
    model_label: &str,
    train: &[Run],
    val: &[Run],
    opts: &DiagnoseOptions,
) -> Result<Diagnosis, LabError> {
    if train.is_empty() || val.is_empty() {
        return Err(LabError::Data {
            run: "(none)".into(),
            detail: "diagnose needs at least one training and one validation run".into(),
        });
    }
    let lm_opts = LmOptions {
        max_iter: opts.calibration_iterations,
        threads: opts.threads,
        ..Default::default()
    };
    let cal = calibrate(base, train, &lm_opts)?;
    let base_free = cal.params.clone();
    let calibrated = cal.model.clone();
    let base_eval = evaluate(&calibrated, val)?;
    let mut current = calibrated.clone();
    let mut current_eval = base_eval.clone();
    let mut current_free = base_free.clone();
    let (all_cands, mut passive) = candidates_of(&calibrated, train, base.active_effects());
    let mut remaining = all_cands.clone();
    let mut accepted: Vec<EffectId> = Vec::new();
    let mut findings: Vec<Finding> = Vec::new();
    let mut error_fall = vec![("calibrated base".to_string(), rmse_map(&base_eval))];
    let mut latest: BTreeMap<EffectId, Finding> = BTreeMap::new();
    let mut cache_short = ColumnCache::new();
    let mut cache_shoot = ColumnCache::new();
    let mut cache_free = ColumnCache::new();
    let mut scales = ViewScales::of_model(&current, train)?;
    for round in 1..=opts.max_effects.max(1) {
        if remaining.is_empty() {
            break;
        }
        let (slow, fast): (Vec<Candidate>, Vec<Candidate>) = remaining
            .iter()
            .cloned()
            .partition(|c| primary_view(c.effect) == View::FreeRun);
        let short = screen(
            &current,
            train,
            &current_free,
            &fast,
            short_view(train),
            &scales.short,
            opts.threads,
            &mut cache_short,
        )?;
        let long = screen(
            &current,
            train,
            &current_free,
            &fast,
            View::Shooting(SHOOTING_WINDOW_S),
            &scales.shoot,
            opts.threads,
            &mut cache_shoot,
        )?;
        // Per candidate, keep the view where it explains more.
        let mut screened: Vec<Screened> = Vec::new();
        for a in short {
            match long.iter().find(|b| b.cand.effect == a.cand.effect) {
                Some(b) if b.explained > a.explained => screened.push(b.clone()),
                _ => screened.push(a),
            }
        }
        for b in &long {
            if !screened.iter().any(|a| a.cand.effect == b.cand.effect) {
                screened.push(b.clone());
            }
        }
        // In the free run only the base parameters of the slow candidates' own axes are
        // refitted with them (see `confirm_stage1`), so only those are screened with them.
        let slow_base: Vec<Param> = {
            let mut own: Vec<Param> = Vec::new();
            for c in &slow {
                own.extend(axis_params_of(&home_channels(c.effect)));
            }
            current_free
                .iter()
                .copied()
                .filter(|p| own.contains(p))
                .collect()
        };
        screened.extend(screen(
            &current,
            train,
            &slow_base,
            &slow,
            View::FreeRun,
            &scales.free,
            opts.threads,
            &mut cache_free,
        )?);
        screened.sort_by(|a, b| {
            (b.dbic > MIN_DBIC)
                .cmp(&(a.dbic > MIN_DBIC))
                .then(b.explained.total_cmp(&a.explained))
        });
        for s in &screened {
            latest.entry(s.cand.effect).or_insert_with(|| Finding {
                effect: s.cand.effect.key().into(),
                significant: false,
                status: Status::Screened,
                contained: s.cand.contained,
                channels: vec![],
                view: String::new(),
                validation_rmse_reduction_pct: BTreeMap::new(),
                validation_rmse_reduction_pct_free_run: BTreeMap::new(),
                validation_rmse_reduction_pct_shooting: BTreeMap::new(),
                params: BTreeMap::new(),
                explanation: format!(
                    "screened only (training ΔBIC {:.1}, explains {:.0} % of its channel's training residual); not among the strongest candidates",
                    s.dbic,
                    s.explained * 100.0
                ),
                delta_bic: Some(s.dbic),
                score: 0.0,
                ambiguous_with: vec![],
                separating_experiment: None,
                round,
            });
        }
        let k = if round == 1 {
            opts.confirm_first
        } else {
            opts.confirm_later
        };
        // The fast (short-horizon) and slow (free-run) screens are not on a common scale:
        // take the best k of the first and the best of the second.
        let best_expl = screened
            .iter()
            .filter(|s| s.dbic > MIN_DBIC)
            .map(|s| s.explained)
            .fold(0.0f64, f64::max);
        let gate = |s: &&Screened| {
            s.dbic > MIN_DBIC
                && s.explained >= MIN_SCREEN_EXPLAINED
                && s.explained >= RELATIVE_SCREEN_GATE * best_expl
        };
        let is_slow = |s: &&Screened| primary_view(s.cand.effect) == View::FreeRun;
        let mut top: Vec<&Screened> = screened
            .iter()
            .filter(|s| gate(s) && !is_slow(s))
            .take(k)
            .collect();
        top.extend(screened.iter().filter(|s| gate(s) && is_slow(s)).take(1));
        for s in &screened {
            let was_sig = latest
                .get(&s.cand.effect)
                .is_some_and(|f| matches!(f.status, Status::Significant | Status::Ambiguous));
            if was_sig && !top.iter().any(|t| t.cand.effect == s.cand.effect) {
                top.push(s);
            }
        }
        if top.is_empty() {
            break;
        }
        let caches = Caches {
            short: &cache_short,
            shoot: &cache_shoot,
            free: &cache_free,
            scales: &scales,
        };
        let stage1: Vec<(Confirmed, Judgement)> = par_map(top.len(), opts.threads, |i| {
            confirm_stage1(
                &current,
                &current_eval,
                train,
                val,
                &current_free,
                top[i],
                opts.confirm_iterations,
                &caches,
            )
        })
        .into_iter()
        .flatten()
        .collect();
        // Refine the most promising (by first-stage held-out score) and any close second.
        let mut order: Vec<usize> = (0..stage1.len()).collect();
        order.sort_by(|a, b| stage1[*b].1.score.total_cmp(&stage1[*a].1.score));
        let lead = order.first().map_or(0.0, |i| stage1[*i].1.score);
        let to_refine: Vec<usize> = order
            .iter()
            .copied()
            .enumerate()
            .filter(|(rank, i)| {
                let sc = stage1[*i].1.score;
                sc > 0.0 && !stage1[*i].1.channels.is_empty() && (*rank == 0 || sc >= 0.5 * lead)
            })
            .map(|(_, i)| i)
            .take(2)
            .collect();
        let refined: Vec<Result<(Confirmed, Judgement), LabError>> =
            par_map(to_refine.len(), opts.threads, |k| {
                let (c1, _) = &stage1[to_refine[k]];
                refine(
                    &current,
                    &current_eval,
                    train,
                    val,
                    c1,
                    c1.contained,
                    opts.confirm_iterations,
                    &scales,
                )
            });
        let mut judged: Vec<(Confirmed, Judgement)> = Vec::new();
        let mut refined_ok: Vec<usize> = Vec::new();
        for (k, r) in refined.into_iter().enumerate() {
            if let Ok(x) = r {
                refined_ok.push(to_refine[k]);
                judged.push(x);
            }
        }
        for (i, (c, j)) in stage1.into_iter().enumerate() {
            if refined_ok.contains(&i) {
                continue;
            }
            let mut j = j;
            if j.significant {
                j.significant = false;
                j.reason = "weaker than the leading candidate in the first-stage fit".into();
            }
            judged.push((c, j));
        }
        judged.sort_by(|a, b| {
            b.1.significant
                .cmp(&a.1.significant)
                .then(b.1.score.total_cmp(&a.1.score))
        });
        let noise: BTreeMap<ChannelKey, f64> = current_eval
            .channels
            .iter()
            .map(|(k, c)| (*k, c.noise))
            .collect();
        for (c, j) in &judged {
            let expl = if j.significant {
                explain(c, j, &current)
            } else {
                format!(
                    "not significant: {} ({})",
                    j.reason,
                    explain(c, j, &current)
                )
            };
            latest.insert(
                c.effect,
                Finding {
                    effect: c.effect.key().into(),
                    significant: j.significant,
                    status: if j.significant {
                        Status::Significant
                    } else {
                        Status::NotSignificant
                    },
                    contained: c.contained,
                    channels: j.channels.iter().map(|k| k.name().to_string()).collect(),
                    view: view_name(j.view).into(),
                    validation_rmse_reduction_pct: j.primary.clone(),
                    validation_rmse_reduction_pct_free_run: j.free.clone(),
                    validation_rmse_reduction_pct_shooting: j.shoot.clone(),
                    params: param_reports(c),
                    explanation: expl,
                    delta_bic: Some(c.dbic),
                    score: j.score,
                    ambiguous_with: vec![],
                    separating_experiment: None,
                    round,
                },
            );
        }
        let Some((best, bj)) = judged.first().filter(|(_, j)| j.significant) else {
            break;
        };
        // Ambiguity with other significant candidates of this round.
        let mut amb = Vec::new();
        for (c, j) in judged.iter().skip(1) {
            if !j.significant || j.score < 0.7 * bj.score {
                continue;
            }
            let chans: Vec<ChannelKey> = bj.channels.clone();
            let da = prediction_change(&best.eval, &current_eval, &chans, &noise);
            let db = prediction_change(&c.eval, &current_eval, &chans, &noise);
            if cosine(&da, &db) > AMBIGUITY_COSINE {
                amb.push(c.effect);
            }
        }
        if !amb.is_empty() {
            let names: Vec<String> = amb.iter().map(|e| e.key().to_string()).collect();
            let exps: Vec<String> = amb
                .iter()
                .map(|e| separating_experiment(best.effect, *e))
                .collect();
            if let Some(f) = latest.get_mut(&best.effect) {
                f.ambiguous_with = names.clone();
                f.separating_experiment = Some(exps.join("; "));
                f.explanation = format!(
                    "{} — ambiguous with {} on this data; to separate them record {}",
                    f.explanation,
                    names.join(", "),
                    exps.join("; ")
                );
            }
            for e in &amb {
                if let Some(f) = latest.get_mut(e) {
                    f.status = Status::Ambiguous;
                    f.significant = false;
                    f.ambiguous_with = vec![best.effect.key().to_string()];
                    f.separating_experiment = Some(separating_experiment(best.effect, *e));
                }
            }
        }
        accepted.push(best.effect);
        if let Some(f) = latest.remove(&best.effect) {
            findings.push(f);
        }
        for p in &best.params {
            if !current_free.contains(p) {
                current_free.push(*p);
            }
        }
        current = best.fit.model.clone();
        current_eval = best.eval.clone();
        // Reweight for the next round (the accepted effect fits its channels better now).
        let new_scales = ViewScales::of_model(&current, train)?;
        for (cache, view) in [
            (&mut cache_short, short_view(train)),
            (&mut cache_shoot, View::Shooting(SHOOTING_WINDOW_S)),
            (&mut cache_free, View::FreeRun),
        ] {
            rescale_cache(
                cache,
                &calibrated,
                train,
                view,
                scales.of(view),
                new_scales.of(view),
            );
        }
        scales = new_scales;
        error_fall.push((format!("+ {}", best.effect.key()), rmse_map(&current_eval)));
        remaining.retain(|c| c.effect != best.effect);
    }
    // Remaining evaluated findings, best first.
    let mut rest: Vec<Finding> = latest.into_values().collect();
    rest.sort_by(|a, b| {
        let rank = |f: &Finding| match f.status {
            Status::Ambiguous => 0,
            Status::Significant => 0,
            Status::NotSignificant => 1,
            Status::Screened => 2,
            _ => 3,
        };
        rank(a)
            .cmp(&rank(b))
            .then(b.score.total_cmp(&a.score))
            .then(
                b.delta_bic
                    .unwrap_or(f64::NEG_INFINITY)
                    .total_cmp(&a.delta_bic.unwrap_or(f64::NEG_INFINITY)),
            )
    });
    findings.extend(rest);
    passive.sort_by_key(|f| match f.status {
        Status::NotTestable => 0,
        Status::NotApplicable => 1,
        _ => 2,
    });
    findings.extend(passive);
    let baseline = base_eval
        .channels
        .iter()
        .map(|(k, c)| {
            (
                k.name().to_string(),
                BaselineChannel {
                    fit_pct: c.shooting.fit_pct,
                    rmse_shooting: c.shooting.rmse,
                    fit_pct_free_run: c.free_run.fit_pct,
                    rmse: c.free_run.rmse,
                    noise: c.noise,
                },
            )
        })
        .collect();
    let mut not_predicted = Vec::new();
    for ch in Channel::ALL {
        if val.iter().any(|r| r.has(ch)) && !calibrated.predicts_channel(ch) {
            not_predicted.push(ch_name(ch).to_string());
        }
    }
    let summary = if accepted.is_empty() {
        "nothing significant: the calibrated model is adequate for this data".to_string()
    } else {
        format!(
            "found {}",
            accepted
                .iter()
                .map(|e| e.key())
                .collect::<Vec<_>>()
                .join(", then ")
        )
    };
    Ok(Diagnosis {
        model: model_label.to_string(),
        baseline,
        not_predicted,
        calibration: cal.fitted,
        findings,
        accepted,
        calibrated,
        final_model: current,
        error_fall,
        summary,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rov_types::measurement::{MeasurementRow, MeasurementSeries, OptionalChannel};

    /// A 60 s run whose vehicle heaves sinusoidally; the depth reading optionally drifts.
    fn heaving_run(drift_mps: f64) -> Run {
        let mut x = 987654321u64;
        let mut noise = || {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let rows: Vec<MeasurementRow> = (0..1200)
            .map(|k| {
                let t = k as f64 * 0.05;
                let w = 0.2 * (0.3 * t).sin();
                let z = 2.0 + 0.2 / 0.3 * (1.0 - (0.3 * t).cos());
                let mut row = MeasurementRow {
                    time_s: t,
                    vertical_pct: if (0.3 * t).sin() > 0.0 { 50.0 } else { -50.0 },
                    depth_m: z + drift_mps * t + 0.005 * noise(),
                    heading_deg: 10.0,
                    ..Default::default()
                };
                row.set(OptionalChannel::HeaveMps, Some(w + 0.01 * noise()));
                row
            })
            .collect();
        let mut present = [false; 8];
        present[OptionalChannel::HeaveMps as usize] = true;
        Run::from_series(
            &MeasurementSeries {
                rows,
                present,
                ..Default::default()
            },
            "heave",
        )
        .unwrap()
    }

    #[test]
    fn kinematic_check_tells_a_drifting_reading_from_real_motion() {
        let rate = 0.002;
        let offset = |run: &Run, k: usize| rate * (run.t[k] - run.t[0]);
        // The measured heave integrates to the depth change: no sensor drift.
        let (b0, se0) = kinematic_ratio(&[heaving_run(0.0)], Channel::Depth, offset).unwrap();
        assert!(
            b0.abs() < 0.1 && !kinematic_consistent(b0, se0),
            "{b0} ± {se0}"
        );
        // The reading drifts away from the integrated heave at the fitted rate.
        let (b1, se1) = kinematic_ratio(&[heaving_run(rate)], Channel::Depth, offset).unwrap();
        assert!(
            (b1 - 1.0).abs() < 0.1 && kinematic_consistent(b1, se1),
            "{b1} ± {se1}"
        );
        // Without a rate channel there is nothing to check.
        assert!(kinematic_ratio(&[heaving_run(0.0)], Channel::Heading, offset).is_none());
    }

    #[test]
    fn bounded_least_squares_holds_a_pinned_column_at_zero() {
        // r0 + a·c1 + b·c2: the unconstrained fit wants a = −1, b = 2.
        let c1 = DVector::from_vec(vec![1.0, 0.0, 1.0, 0.0]);
        let c2 = DVector::from_vec(vec![0.0, 1.0, 0.0, 1.0]);
        let r0 = -(c1.scale(-1.0) + c2.scale(2.0));
        let m = DMatrix::from_columns(&[c1, c2]);
        let (_, x) = bounded_ls(&r0, &m, &[0, 0]).unwrap();
        assert!(
            (x[0] + 1.0).abs() < 1e-6 && (x[1] - 2.0).abs() < 1e-6,
            "{x:?}"
        );
        // Column 1 at its lower bound may only grow: held at zero, column 2 unchanged.
        let (res, x) = bounded_ls(&r0, &m, &[1, 0]).unwrap();
        assert!(x[0] == 0.0 && (x[1] - 2.0).abs() < 1e-6, "{x:?}");
        assert!((res.norm_squared() - 2.0).abs() < 1e-6);
    }

    #[test]
    fn structural_scales_keep_noise_weights_near_the_floor() {
        let run = heaving_run(0.0);
        let i = crate::data::ch_index(Channel::Depth);
        let sigma = run.noise[i];
        let mut misfit = crate::calibrate::NOISE_ONLY;
        misfit[i] = 1.5 * sigma;
        assert_eq!(
            structural_scales(std::slice::from_ref(&run), &misfit)[i],
            0.0
        );
        misfit[i] = 10.0 * sigma;
        let s = structural_scales(std::slice::from_ref(&run), &misfit)[i];
        assert!((s - 9.0 * sigma).abs() < 1e-12, "{s} vs {sigma}");
    }

    #[test]
    fn only_plausibility_bounds_pin_an_effect() {
        assert!(Param::LagTau.bound_is_physical(false));
        assert!(!Param::LagTau.bound_is_physical(true));
        assert!(!Param::DepthDrift.bound_is_physical(true));
        assert!(!Param::ReverseRatio(Thr::Vertical).bound_is_physical(false));
        assert!(Param::PowerMax.bound_is_physical(true));
    }
}
