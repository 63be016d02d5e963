//! Simulation-error confirmation of the screened candidates: joint Levenberg–Marquardt
//! fits of the effect with the base, from several starts, then a refinement with every
//! base parameter free; the "base refit only" control.

use rov_dynamics::models::Channel;

use crate::LabError;
use crate::calibrate::{Calibration, Objective, View, bounds_for, fit_scaled, row_factors};
use crate::catalog::EffectId;
use crate::data::Run;
use crate::evaluate::{Evaluation, evaluate};
use crate::lm::{Bound, LmOptions};
use crate::model::LabModel;
use crate::params::{Param, axis_params_of};

use super::*;

/// What a confirmation fits: a catalog effect or a discovered term.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Subject {
    /// A catalog effect.
    Effect(EffectId),
    /// A discovered term (its coefficient is the fitted parameter).
    Term(crate::terms::Term),
}

impl Subject {
    /// The channels where its signature lives first.
    pub(super) fn home(&self) -> Vec<Channel> {
        match self {
            Subject::Effect(e) => home_channels(*e),
            Subject::Term(t) => term_home(t.dof),
        }
    }

    /// The catalog effect, if it is one.
    pub(super) fn effect(&self) -> Option<EffectId> {
        match self {
            Subject::Effect(e) => Some(*e),
            Subject::Term(_) => None,
        }
    }
}

/// The channels that show a force on a DOF first.
pub(super) fn term_home(dof: u8) -> Vec<Channel> {
    use Channel::*;
    match dof {
        0 => vec![Surge, North, East],
        1 => vec![Sway, North, East],
        2 => vec![Depth, Heave],
        3 => vec![Roll, RollRate],
        4 => vec![Pitch, PitchRate],
        _ => vec![Heading, YawRate],
    }
}

#[derive(Debug, Clone)]
pub(super) struct Confirmed {
    pub(super) subject: Subject,
    pub(super) contained: bool,
    pub(super) params: Vec<Param>,
    /// Base parameters refitted with the effect.
    pub(super) base_fit: Vec<Param>,
    pub(super) fit: Calibration,
    pub(super) eval: Evaluation,
    pub(super) control: Option<Evaluation>,
    pub(super) dbic: f64,
    pub(super) view: View,
    /// An effect-specific signature check that failed, if any.
    pub(super) signature_failed: Option<String>,
    /// Whether a fit of its confirmation (a stage-1 start, the settling, the refinement)
    /// stopped at its iteration limit rather than converged: only then can continuing
    /// it ([`Greedy::polish`]) change the result.
    pub(super) ran_out: bool,
}

/// First confirmation stage: the effect's parameters with every calibrated base
/// parameter, in the view where the candidate screened best, then settled in its primary
/// view; Levenberg–Marquardt with Broyden updates from the screening Jacobian (cheap).
/// Started from the better of "effect off", the screening's linearised step and spread
/// values of kinked parameters; judged on the held-out runs.
#[allow(clippy::too_many_arguments)]
pub(super) fn confirm_stage1(
    model: &LabModel,
    base_eval: &Evaluation,
    train: &[Run],
    val: &[Run],
    base_free: &[Param],
    s: &Screened,
    iterations: usize,
    converge: bool,
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
    let home = home_channels(s.cand.effect);
    let cs_first = candidate_scales(&home, caches.scales.of(first_view));
    let cs_view = candidate_scales(&home, caches.scales.of(view));
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
        let spread = p.start_spread();
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
    let kinked = s.cand.params.iter().any(|p| !p.start_spread().is_empty());
    let n_starts = if kinked { 2 } else { 1 };
    let bounds = effect_bounds(model, &free, &s.cand.params, &fit_base);
    let opts = LmOptions {
        max_iter: iterations * 2 * budget_factor(converge),
        threads: 1,
        ..Default::default()
    };
    let mut stage1: Option<Calibration> = None;
    let mut ran_out = false;
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
        )
        .map(Calibration::lean) else {
            continue;
        };
        let f1 = if converge {
            continued(f1, |m| {
                fit_scaled(
                    m,
                    train,
                    &free,
                    first_view,
                    None,
                    Some(bounds.clone()),
                    &opts,
                    None,
                    &cs_first,
                )
                .map(Calibration::lean)
            })
        } else {
            f1
        };
        ran_out |= !f1.lm.converged;
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
        .map(Calibration::lean)
    {
        let f2 = if converge {
            continued(f2, |m| {
                fit_scaled(
                    m,
                    train,
                    &free,
                    view,
                    None,
                    Some(bounds.clone()),
                    &opts,
                    None,
                    &cs_view,
                )
                .map(Calibration::lean)
            })
        } else {
            f2
        };
        ran_out |= !f2.lm.converged;
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
        subject: Subject::Effect(s.cand.effect),
        contained: s.cand.contained,
        params: s.cand.params.clone(),
        base_fit: fit_base.clone(),
        fit: stage1,
        eval,
        control,
        dbic: f64::INFINITY,
        view,
        signature_failed: None,
        ran_out,
    };
    let j = judge(base_eval, &c, caches.closed_loop);
    Ok((c, j))
}

/// Most repetitions of a fit's LM budget when an accepted finding's fit is continued to
/// convergence ([`continued`]).
pub(super) const MAX_CONTINUATIONS: usize = 2;

/// LM budget multiplier of a fit continued to convergence: one long LM call keeps its
/// damping and its Broyden-updated Jacobian, which restarts of the short budget lose
/// (on the probe's lag case five restarted rounds of 8 iterations still fell by 1-2 % each
/// at 0.15 s, one call of 24 reached 0.20 s); LM's relative-tolerance stop ends it earlier
/// when it has converged.
const CONVERGE_BUDGET: usize = 3;

/// The LM budget multiplier of a confirmation fit.
fn budget_factor(converge: bool) -> usize {
    if converge { CONVERGE_BUDGET } else { 1 }
}

/// Relative cost drop of one repetition below which a continued fit has converged.
pub(super) const CONVERGED_DROP: f64 = 1e-3;

/// Continues a fit that ran out of LM iterations with the same budget, each round from
/// the previous result, until a round converges by LM's own tolerance, lowers
/// the cost by less than [`CONVERGED_DROP`] (relative) or fails, or after
/// [`MAX_CONTINUATIONS`] rounds; keeps the lowest-cost result. Used only for accepted
/// findings: their parameters are reported, so they are fitted to convergence, while the
/// screening of candidates keeps the short budget.
pub(super) fn continued(
    first: Calibration,
    again: impl Fn(&LabModel) -> Result<Calibration, LabError>,
) -> Calibration {
    let mut best = first;
    for _ in 0..MAX_CONTINUATIONS {
        if best.lm.converged {
            break;
        }
        let Ok(next) = again(&best.model) else {
            break;
        };
        if !next.cost.is_finite() || next.cost >= best.cost {
            break;
        }
        let drop = (best.cost - next.cost) / best.cost.max(1e-300);
        best = next;
        if drop < CONVERGED_DROP {
            break;
        }
    }
    best
}

/// "Base refit only" control: the fitted model with the effect's own parameters back at
/// "off" (for a contained effect, back at their previous values), on the held-out runs.
pub(super) fn control_eval(
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
pub(super) fn effect_bounds(
    model: &LabModel,
    free: &[Param],
    effect: &[Param],
    keep_prior: &[Param],
) -> Vec<Bound> {
    let mut b = bounds_for(model, free, true);
    for (i, p) in free.iter().enumerate() {
        if effect.contains(p) && !keep_prior.contains(p) {
            b[i].prior = None;
        } else if let Some(prior) = model.prior_of(*p) {
            b[i].prior = Some(prior);
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
pub(super) fn refine(
    model: &LabModel,
    base_eval: &Evaluation,
    train: &[Run],
    val: &[Run],
    stage1: &Confirmed,
    contained: bool,
    iterations: usize,
    converge: bool,
    scales: &ViewScales,
    closed_loop: bool,
) -> Result<(Confirmed, Judgement), LabError> {
    let view = stage1.view;
    let mut all_free: Vec<Param> = stage1.base_fit.clone();
    for p in &stage1.params {
        if !all_free.contains(p) {
            all_free.push(*p);
        }
    }
    let opts = LmOptions {
        max_iter: iterations * budget_factor(converge),
        threads: 1,
        ..Default::default()
    };
    let bounds = effect_bounds(model, &all_free, &stage1.params, &stage1.base_fit);
    let cs = candidate_scales(&stage1.subject.home(), scales.of(view));
    let fit_from = |m: &LabModel| {
        fit_scaled(
            m,
            train,
            &all_free,
            view,
            None,
            Some(bounds.clone()),
            &opts,
            None,
            &cs,
        )
        .map(Calibration::lean)
    };
    let fitted = fit_from(&stage1.fit.model)?;
    let fitted = if converge {
        continued(fitted, fit_from)
    } else {
        fitted
    };
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
    if stage1.subject == Subject::Effect(EffectId::ThrusterLag) {
        let dt = train.first().map_or(0.05, |r| r.median_dt());
        let tau = fitted.model.get(Param::LagTau).unwrap_or(0.0);
        if tau < LAG_RESOLUTION * dt {
            signature_failed = Some(format!(
                "the fitted lag of {:.0} ms is shorter than the sample period ({:.0} ms), too short to resolve at this rate",
                tau * 1000.0,
                LAG_RESOLUTION * dt * 1000.0
            ));
        }
    }
    let all_runs: Vec<Run> = train.iter().chain(val.iter()).cloned().collect();
    if stage1.subject == Subject::Effect(EffectId::DepthSensorDrift) {
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
    if stage1.subject == Subject::Effect(EffectId::CompassDeviation) {
        let m = &fitted.model;
        if let Some((beta, se)) = kinematic_ratio(&all_runs, Channel::Heading, |run, k| {
            let psi = run
                .channel(Channel::Heading)
                .and_then(|h| h.get(k))
                .copied()
                .unwrap_or(0.0);
            let prev = crate::sim::prev_targets(m, run, k);
            m.heading_offset_deg(psi.to_radians(), &prev)
        }) && !kinematic_consistent(beta, se)
        {
            signature_failed = Some(format!(
                "the measured yaw rate accounts for the heading changes: the compass departs from the integrated rate by {:.2} ± {:.2} of the fitted deviation and interference, so the heading error is in the motion, not in the compass",
                beta, se
            ));
        }
    }
    let control = control_eval(model, &fitted.model, &stage1.params, contained, val);
    let ran_out = stage1.ran_out || !fitted.lm.converged;
    let c = Confirmed {
        subject: stage1.subject,
        contained,
        params: stage1.params.clone(),
        base_fit: stage1.base_fit.clone(),
        fit: fitted,
        eval,
        control,
        dbic,
        view,
        signature_failed,
        ran_out,
    };
    let j = judge(base_eval, &c, closed_loop);
    Ok((c, j))
}
