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
//!    until nothing passes. The confirmation of the accepted effect is done again with
//!    every fit continued to convergence when one of them ran out of the short LM
//!    budget that ranks the candidates ([`Greedy::polish`]): its parameters are reported.
//! 6. **Replacement**: when the last accepted effect leaves one of its home channels
//!    inconsistent, its DOF's library terms are confirmed on the model without it; a term
//!    that scores higher on the held-out runs and brings those channels within the
//!    verdict's distance limit replaces it, and both cards name the alternative
//!    (`replacement`).
//! 7. **Structurally inadequate base**: when the calibrated base misses at least
//!    [`INADEQUATE_CHANNELS`] excited channels beyond [`INADEQUATE_FACTOR`] noise floors
//!    and, with every accepted effect, still does (those channels carrying at least
//!    [`INADEQUATE_SHARE`] of its misfit), the first accepted effect that made an excited
//!    channel worse in the multiple-shooting view (beyond rule (b) of [`judge`]) is
//!    withdrawn with everything fitted on top of it, and the report says the base looks
//!    structurally inadequate and why (not tried after a replacement, whose term passed
//!    the same rule); a term is refused on the same ground
//!    (`judging::veto_on_inadequate_base`).
//! 8. **Terms** outside the catalog while the verdict still finds a channel
//!    inconsistent ([`discovery`]).
//!
//! Two candidates whose confirmed fits change the held-out predictions the same way
//! (cosine > [`AMBIGUITY_COSINE`]) and score alike are reported as ambiguous, with the
//! experiment that would separate them (modellab.md §3.4).

use std::collections::BTreeMap;

use rov_dynamics::models::Channel;
use serde::Serialize;

use crate::LabError;
use crate::calibrate::{SHOOTING_WINDOW_S, View, calibrate};
use crate::catalog::EffectId;
use crate::data::{Run, ch_name};
use crate::evaluate::ChannelKey;
use crate::lm::LmOptions;
use crate::model::LabModel;
use crate::params::Param;
use crate::verdict::{self, Verdict};

mod candidates;
mod confirmation;
mod discovery;
mod explanations;
mod greedy;
mod judging;
mod replacement;
mod report;
mod screening;
mod signatures;

pub use crate::catalog::separating_experiment;
use candidates::*;
use confirmation::*;
use explanations::*;
use greedy::Greedy;
use judging::*;
pub use report::*;
pub(crate) use screening::par_map;
use screening::*;
use signatures::*;

/// The error view an effect's parameters are fitted in (the catalog's `fit_view`).
fn primary_view(e: EffectId) -> View {
    match e.info().fit_view {
        crate::catalog::FitView::FreeRun => View::FreeRun,
        crate::catalog::FitView::Shooting => View::Shooting(SHOOTING_WINDOW_S),
    }
}

/// The channels where an effect's signature lives first (the catalog's `home`).
fn home_channels(e: EffectId) -> Vec<Channel> {
    e.home_channels().to_vec()
}

/// Smallest held-out RMSE reduction that counts (fraction).
pub const MIN_REDUCTION: f64 = 0.15;
/// A channel counts only if its calibrated held-out RMSE is this many noise floors.
pub const NOISE_FACTOR: f64 = 1.3;
/// A worsened channel is tolerated when its noise-normalised loss is below this fraction
/// of the noise-normalised gain summed over channels (reported as a conflict).
pub const WORSE_FRACTION_OF_GAIN: f64 = 0.2;
/// Largest tolerated worsening of another channel (fraction).
pub const MAX_WORSE: f64 = 0.05;
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
/// A model is structurally inadequate for the data when it misses at least
/// [`INADEQUATE_CHANNELS`] excited channels by more than this many noise floors
/// (multiple-shooting held-out RMSE): a finding that leaves it so ([`INADEQUATE_SHARE`])
/// and makes another excited channel clearly worse is then refused
/// (`judging::veto_on_inadequate_base`).
pub const INADEQUATE_FACTOR: f64 = 2.0;
/// See [`INADEQUATE_FACTOR`].
pub const INADEQUATE_CHANNELS: usize = 2;
/// A finding leaves a base structurally inadequate when the channels still beyond
/// [`INADEQUATE_FACTOR`] floors with it carry at least this share of the base's misfit
/// beyond that level (`judging::Inadequacy::left_by`).
pub const INADEQUATE_SHARE: f64 = 0.25;
/// Cosine similarity of prediction changes above which two findings are ambiguous.
pub const AMBIGUITY_COSINE: f64 = 0.9;

/// Options of [`diagnose`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiagnoseOptions {
    /// Worker threads (1 = serial; default: every core). The result is the same for
    /// any count ([`crate::par`]).
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
    /// Most terms outside the catalog accepted (0 switches the term search off).
    pub max_terms: usize,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        Self {
            threads: crate::par::default_threads(),
            max_effects: 3,
            confirm_first: 3,
            confirm_later: 2,
            calibration_iterations: 8,
            confirm_iterations: 4,
            max_terms: 2,
        }
    }
}

/// Diagnoses a base model on training runs, judging on held-out runs.
pub fn diagnose(
    base: &LabModel,
    model_label: &str,
    train: &[Run],
    val: &[Run],
    opts: &DiagnoseOptions,
) -> Result<Diagnosis, LabError> {
    let (train, val) = (
        crate::data::aligned(train, base.channel_table()),
        crate::data::aligned(val, base.channel_table()),
    );
    let (train, val) = (&train[..], &val[..]);
    if train.is_empty() || val.is_empty() {
        return Err(LabError::Data {
            run: "(none)".into(),
            detail: "diagnose needs at least one training and one validation run".into(),
        });
    }
    let _memo = crate::sim::memo_scope(&[train, val]);
    let lm_opts = LmOptions {
        max_iter: opts.calibration_iterations,
        threads: opts.threads,
        ..Default::default()
    };
    let cal = calibrate(base, train, &lm_opts)?;
    let closed_loop = train
        .iter()
        .chain(val.iter())
        .any(|r| r.treatment.closed_loop());
    let calibrated = cal.model.clone();
    let mut g = Greedy::new(&cal, train, val, closed_loop, opts.threads)?;
    let base_eval = g.current_eval.clone();
    let (mut all_cands, mut passive) = candidates_of(&calibrated, train, base.active_effects());
    if closed_loop {
        // A slow sensor drift shows only in the free run, which closed-loop data voids.
        let (slow, fast): (Vec<Candidate>, Vec<Candidate>) = all_cands
            .into_iter()
            .partition(|c| primary_view(c.effect) == View::FreeRun);
        all_cands = fast;
        for c in slow {
            passive.push(Finding::blank(
                c.effect,
                Status::NotTestable,
                "not testable with closed-loop data: it shows only in the free run, and an autopilot corrected the real vehicle where the free-running model is not corrected".into(),
                c.contained,
            ));
        }
    }
    let mut remaining = all_cands.clone();
    let mut accepted: Vec<EffectId> = Vec::new();
    let mut findings: Vec<Finding> = Vec::new();
    let mut error_fall = vec![("calibrated base".to_string(), rmse_map(&base_eval))];
    let mut latest: BTreeMap<EffectId, Finding> = BTreeMap::new();
    let mut latest_terms: Vec<Finding> = Vec::new();
    let mut history: Vec<replacement::LastAccepted> = Vec::new();
    for round in 1..=opts.max_effects.max(1) {
        if remaining.is_empty() {
            break;
        }
        let screened = g.screen(&remaining)?;
        for s in &screened {
            latest.entry(s.cand.effect).or_insert_with(|| {
                let mut f = Finding::blank(
                    s.cand.effect,
                    Status::Screened,
                    format!(
                        "screened only (training ΔBIC {:.1}, explains {:.0} % of its channel's training residual); not among the strongest candidates",
                        s.dbic,
                        s.explained * 100.0
                    ),
                    s.cand.contained,
                );
                f.delta_bic = Some(s.dbic);
                f.round = round;
                f
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
        let judged = g.confirm(&top, opts.confirm_iterations, false);
        let noise: BTreeMap<ChannelKey, f64> = g
            .current_eval
            .channels
            .iter()
            .map(|(k, c)| (*k, c.noise))
            .collect();
        for (c, j) in &judged {
            let Some(effect) = c.subject.effect() else {
                continue;
            };
            latest.insert(effect, effect_finding(c, j, &g.current, round));
        }
        let Some((best, bj)) = judged.first().filter(|(_, j)| j.significant) else {
            break;
        };
        let Some(best_effect) = best.subject.effect() else {
            break;
        };
        // Accepted: its fits are continued to convergence (`Greedy::polish`).
        let polished = top
            .iter()
            .find(|s| s.cand.effect == best_effect)
            .and_then(|s| g.polish(s, best, opts.confirm_iterations));
        let (best, bj) = match &polished {
            Some((c, j)) => {
                latest.insert(best_effect, effect_finding(c, j, &g.current, round));
                (c, j)
            }
            None => (best, bj),
        };
        // Ambiguity with other significant candidates of this round.
        let mut amb = Vec::new();
        for (c, j) in judged.iter().skip(1) {
            if !j.significant || j.score < 0.7 * bj.score {
                continue;
            }
            let chans: Vec<ChannelKey> = bj.channels.clone();
            let da = prediction_change(&best.eval, &g.current_eval, &chans, &noise);
            let db = prediction_change(&c.eval, &g.current_eval, &chans, &noise);
            if cosine(&da, &db) > AMBIGUITY_COSINE
                && let Some(e) = c.subject.effect()
            {
                amb.push(e);
            }
        }
        if !amb.is_empty() {
            let names: Vec<String> = amb.iter().map(|e| e.key().to_string()).collect();
            let exps: Vec<String> = amb
                .iter()
                .map(|e| separating_experiment(best_effect, *e))
                .collect();
            if let Some(f) = latest.get_mut(&best_effect) {
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
                    f.ambiguous_with = vec![best_effect.key().to_string()];
                    f.separating_experiment = Some(separating_experiment(best_effect, *e));
                }
            }
        }
        accepted.push(best_effect);
        if let Some(f) = latest.remove(&best_effect) {
            findings.push(f);
        }
        history.push(replacement::LastAccepted {
            effect: best_effect,
            score: bj.score,
            before: g.snapshot(),
            traded: bj
                .conflict_channels
                .iter()
                .filter(|(_, t)| *t)
                .map(|(c, _)| c.clone())
                .collect(),
        });
        g.accept(best)?;
        error_fall.push((
            format!("+ {}", best_effect.key()),
            rmse_map(&g.current_eval),
        ));
        remaining.retain(|c| c.effect != best_effect);
        // Consistent with the held-out data within its noise alone (no parameter spread:
        // the strictest form of the verdict's test): nothing is left to find.
        let zero = [0.0; crate::data::N_CHANNELS];
        if verdict::all_consistent(&verdict::test_channels(
            &g.current,
            val,
            &g.current_eval,
            &zero,
        )) {
            break;
        }
    }
    // The verdict on the catalog's result (H₀ fitted first: `crate::verdict`); the term
    // search when it is not enough.
    let known = cal.lm.jacobian.as_ref().map(|j| verdict::KnownJacobian {
        columns: j,
        residual: &cal.lm.residuals,
    });
    let base_tested = tested(
        &calibrated,
        &cal.params,
        train,
        val,
        &base_eval,
        &cal.scales,
        known,
        None,
        opts.threads,
    )?;
    let mut final_tested = if accepted.is_empty() {
        base_tested.clone()
    } else {
        tested(
            &g.current,
            &g.current_free,
            train,
            val,
            &g.current_eval,
            g.scales.of(View::Shooting(SHOOTING_WINDOW_S)),
            None,
            base_tested.null.as_deref(),
            opts.threads,
        )?
    };
    let base_tests = base_tested.tests.clone();
    let mut accepted_terms: Vec<crate::terms::Term> = Vec::new();
    let mut search_notes: Vec<String> = Vec::new();
    // Library terms whose residual force is a catalog effect's signature, per (DOF,
    // effect), in the order found: one note each (`catalog_like_note`).
    let mut catalog_like: Vec<((usize, &str), Vec<String>)> = Vec::new();
    let names_owned = g.current.command_names_owned();
    let names: Vec<&str> = names_owned.iter().map(String::as_str).collect();
    // The last accepted catalog effect against the library's terms of its own DOFs, as a
    // replacement, when it leaves a home channel inconsistent (`replacement`).
    let mut replaced = false;
    if let Some(last) = history.last().filter(|_| opts.max_terms > 0) {
        let outcome = replacement::try_replace(
            &mut g,
            last,
            &final_tested.tests,
            &remaining,
            train,
            val,
            opts,
            accepted.len(),
        )?;
        let key = last.effect.key();
        match outcome {
            None => {}
            Some(replacement::Outcome::Kept { card, why }) => {
                if let Some(f) = findings.iter_mut().find(|f| f.effect == key) {
                    f.explanation = format!("{} — {why}", f.explanation);
                }
                latest_terms.extend(card);
            }
            Some(replacement::Outcome::Replaced { term, card, why }) => {
                replaced = true;
                accepted.retain(|e| *e != last.effect);
                if let Some(i) = findings.iter().position(|f| f.effect == key) {
                    let mut f = findings.remove(i);
                    f.significant = false;
                    f.status = Status::NotSignificant;
                    f.explanation =
                        format!("not significant: replaced — {why} ({})", f.explanation);
                    latest_terms.push(f);
                }
                error_fall.pop();
                error_fall.push((format!("+ {}", term.id(&names)), rmse_map(&g.current_eval)));
                accepted_terms.push(term);
                findings.push(card);
                final_tested = tested(
                    &g.current,
                    &g.current_free,
                    train,
                    val,
                    &g.current_eval,
                    g.scales.of(View::Shooting(SHOOTING_WINDOW_S)),
                    None,
                    base_tested.null.as_deref(),
                    opts.threads,
                )?;
            }
        }
    }
    // A trade between channels is tolerated only while it leads somewhere: when the base
    // was structurally inadequate and, with every accepted effect, still is
    // (`judging::Inadequacy::left_by`), the first effect that bought its gain with a
    // channel in the verdict's view is withdrawn with everything fitted on top of it.
    // (After the replacement test: a term that replaces the trading effect may leave
    // the model adequate.)
    let base_inadequacy = inadequacy(&base_eval, closed_loop);
    // (A replacement's term passed the immediate veto; the withdrawal, which would drop
    // it with the effects it was fitted on top of, is not tried after one.)
    if let (false, Some(inad), Some(left)) = (
        replaced,
        base_inadequacy.as_ref(),
        Inadequacy::left_by(&base_eval, &g.current_eval, closed_loop),
    ) && let Some(i) = history.iter().position(|h| !h.traded.is_empty())
    {
        let dropped: Vec<replacement::LastAccepted> = history.drain(i..).collect();
        if let Some(first) = dropped.first() {
            g.restore(first.before.clone());
        }
        accepted.truncate(i);
        error_fall.truncate(i + 1);
        let first_key = dropped.first().map(|h| h.effect.key()).unwrap_or_default();
        for (k, h) in dropped.iter().enumerate() {
            let key = h.effect.key();
            let Some(pos) = findings.iter().position(|f| f.effect == key) else {
                continue;
            };
            let mut f = findings.remove(pos);
            f.significant = false;
            f.status = Status::NotSignificant;
            f.explanation = if k == 0 {
                mark_base_veto(&mut f.conflicts, &h.traded, inad);
                format!(
                    "not significant: {} ({})",
                    base_veto_reason(&h.traded, inad, &left),
                    f.explanation
                )
            } else {
                format!(
                    "not significant: withdrawn with {first_key}, on top of which it was fitted ({})",
                    f.explanation
                )
            };
            latest_terms.push(f);
        }
        final_tested = if accepted.is_empty() && accepted_terms.is_empty() {
            base_tested.clone()
        } else {
            tested(
                &g.current,
                &g.current_free,
                train,
                val,
                &g.current_eval,
                g.scales.of(View::Shooting(SHOOTING_WINDOW_S)),
                None,
                base_tested.null.as_deref(),
                opts.threads,
            )?
        };
    }
    for round in (accepted_terms.len() + 1)..=opts.max_terms {
        if verdict::all_consistent(&final_tested.tests) {
            break;
        }
        let catalog: Vec<(EffectId, Vec<Param>)> = remaining
            .iter()
            .map(|c| (c.effect, c.params.clone()))
            .collect();
        let (picks, notes) = discovery::search(
            &g.current,
            train,
            &g.current_free,
            &catalog,
            &g.scales,
            g.shooting_columns(),
            opts.threads,
            None,
        )?;
        for (dof, formula, e) in &notes.catalog_like {
            let key = (*dof, e.key());
            match catalog_like.iter_mut().find(|(k, _)| *k == key) {
                Some((_, forms)) if forms.contains(formula) => {}
                Some((_, forms)) => forms.push(formula.clone()),
                None => catalog_like.push((key, vec![formula.clone()])),
            }
        }
        // The best pick of each DOF, and its runner-up only when it explains nearly as
        // much (near-equivalent forms of the same residual: the held-out data decides),
        // up to MAX_CONFIRM.
        let mut top: Vec<&discovery::TermPick> = Vec::new();
        for p in &picks {
            let same: Vec<&&discovery::TermPick> =
                top.iter().filter(|t| t.term.dof == p.term.dof).collect();
            let keep = match same.first() {
                None => true,
                Some(b) => same.len() < 2 && p.explained >= discovery::NEAR_TIE * b.explained,
            };
            if keep && top.len() < discovery::MAX_CONFIRM {
                top.push(p);
            }
        }
        if top.is_empty() {
            break;
        }
        let judged: Vec<(Confirmed, Judgement)> = par_map(top.len(), opts.threads, |i| {
            discovery::confirm_term(
                &g.current,
                &g.current_eval,
                train,
                val,
                &g.current_free,
                top[i],
                opts.confirm_iterations,
                &g.scales,
                closed_loop,
            )
        })
        .into_iter()
        .flatten()
        .collect();
        let mut judged = judged;
        let inadequate = g.inadequacy();
        for (_, j) in &mut judged {
            veto_on_inadequate_base(j, inadequate.as_ref());
        }
        judged.sort_by(|a, b| {
            b.1.significant
                .cmp(&a.1.significant)
                .then(b.1.score.total_cmp(&a.1.score))
        });
        let mut best_term: Option<(Confirmed, Judgement)> = None;
        for (k, (c, j)) in judged.into_iter().enumerate() {
            let Subject::Term(t) = c.subject else {
                continue;
            };
            let pick = top
                .iter()
                .find(|p| p.term.dof == t.dof && p.term.kind == t.kind);
            let significant = j.significant && k == 0;
            let f = term_card(&c, &j, &g.current, round, pick.copied(), k > 0);
            if significant {
                findings.push(f);
                best_term = Some((c, j));
            } else {
                latest_terms.push(f);
            }
        }
        let Some((best, _)) = best_term else {
            break;
        };
        let Subject::Term(t) = best.subject else {
            break;
        };
        accepted_terms.push(t);
        g.accept(&best)?;
        error_fall.push((format!("+ {}", t.id(&names)), rmse_map(&g.current_eval)));
        final_tested = tested(
            &g.current,
            &g.current_free,
            train,
            val,
            &g.current_eval,
            g.scales.of(View::Shooting(SHOOTING_WINDOW_S)),
            None,
            base_tested.null.as_deref(),
            opts.threads,
        )?;
    }
    search_notes.extend(
        catalog_like
            .iter()
            .map(|((dof, effect), forms)| catalog_like_note(*dof, effect, forms)),
    );
    // Remaining evaluated findings, best first.
    let mut rest: Vec<Finding> = latest.into_values().collect();
    rest.extend(latest_terms);
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
    let final_tests = final_tested.tests.clone();
    let consistent = verdict::all_consistent(&final_tests);
    let any_finding = !accepted.is_empty() || !accepted_terms.is_empty();
    let verdict = match (consistent, any_finding) {
        (true, false) => Verdict::Adequate,
        (true, true) => Verdict::Explained,
        (false, _) => Verdict::Unexplained,
    };
    let unexplained =
        verdict::unexplained(&final_tested.model, val, &final_tested.eval, &final_tests);
    let mut found: Vec<String> = accepted.iter().map(|e| e.key().to_string()).collect();
    found.extend(accepted_terms.iter().map(|t| t.id(&names)));
    // Accepted findings that trade another channel: said in the summary, not only in
    // their evidence cards.
    let traded: Vec<String> = findings
        .iter()
        .filter(|f| f.significant && !f.conflicts.is_empty())
        .map(|f| {
            let chans: Vec<&str> = f
                .conflicts
                .iter()
                .filter_map(|c| c.split(" gets ").next())
                .collect();
            format!(
                "{} was accepted with a conflict: it leaves {} worse beyond the noise in a view (its conflicts say how much); a trade between channels usually means the base's structure is wrong or missing",
                f.effect,
                chans.join(", ")
            )
        })
        .collect();
    let summary = match verdict {
        Verdict::Adequate => "nothing significant: the calibrated model is adequate for this data (every channel within its noise floor and the uncertainty of its parameters and inputs)".to_string(),
        Verdict::Explained => format!(
            "found {}: with them the model is consistent with the held-out data (explained)",
            found.join(", then ")
        ),
        Verdict::Unexplained => {
            let u: Vec<String> = unexplained
                .iter()
                .map(|u| {
                    let mut s = format!("{} {:.1}× its noise floor", u.channel, u.ratio);
                    if let Some(c) = u.where_.first() {
                        s.push_str(&format!(", mostly {}", c.description));
                    }
                    s
                })
                .collect();
            if found.is_empty() {
                format!(
                    "nothing significant, but the model is not adequate for this data — unexplained: {}",
                    u.join("; ")
                )
            } else {
                format!(
                    "found {}; still unexplained: {}",
                    found.join(", then "),
                    u.join("; ")
                )
            }
        }
    };
    let summary = if traded.is_empty() {
        summary
    } else {
        format!("{summary} ({})", traded.join("; "))
    };
    // A structurally inadequate base (`judging::inadequacy`): said, with what it refused.
    let refused: Vec<(String, Vec<String>)> = findings
        .iter()
        .filter(|f| !f.significant)
        .filter_map(|f| {
            let chans: Vec<String> = f
                .conflicts
                .iter()
                .filter(|c| c.contains(BASE_VETO_MARK))
                .filter_map(|c| c.split(" gets ").next().map(str::to_string))
                .collect();
            (!chans.is_empty()).then(|| (f.effect.clone(), chans))
        })
        .collect();
    // Said only while it is true of the result: the accepted findings still leave a
    // share of the base's misfit (`Inadequacy::left_by`; with nothing accepted, all of it),
    // or a trading finding was refused. A base missing many channels because one effect
    // is missing (the GUI's moment-arm case: pitch 25×, and five channels beyond 2× with
    // it) is not called inadequate once that effect is found.
    let base_note = inadequacy_note(
        base_inadequacy.as_ref(),
        Inadequacy::left_by(&base_eval, &g.current_eval, closed_loop).as_ref(),
        &refused,
    );
    let summary = match &base_note {
        Some(n) if !matches!(verdict, Verdict::Explained) => format!("{summary}. Note: {n}"),
        _ => summary,
    };
    let mut data_notes = crate::ingest::treatment_sentences(train);
    for s in crate::ingest::treatment_sentences(val) {
        if !data_notes.contains(&s) {
            data_notes.push(s);
        }
    }
    let mut calibration_notes = crate::calibrate::calibration_notes(&cal, train);
    calibration_notes.extend(base_note);
    if !final_tested.moved.is_empty() {
        let moved: Vec<String> = final_tested
            .moved
            .iter()
            .map(|(k, a, b)| format!("{k} {a:.4} → {b:.4}"))
            .collect();
        calibration_notes.push(format!(
            "the verdict tests the model with its parameters refitted within their documented uncertainty (H₀: the model is right up to its parameters), which moved {}",
            moved.join(", ")
        ));
    }
    Ok(Diagnosis {
        model: model_label.to_string(),
        baseline,
        not_predicted,
        calibration: cal.fitted,
        findings,
        accepted,
        accepted_terms,
        calibrated,
        final_model: g.current.clone(),
        error_fall,
        summary,
        verdict,
        consistency: final_tests,
        consistency_base: base_tests,
        unexplained,
        data_notes,
        closed_loop,
        calibration_notes,
        search_notes,
    })
}

/// A model's consistency tests as the verdict takes them, with the model and evaluation
/// they were taken on.
#[derive(Debug, Clone)]
struct Tested {
    tests: Vec<verdict::ChannelTest>,
    model: LabModel,
    eval: crate::evaluate::Evaluation,
    /// Parameters the H₀ refit moved (key, from, to).
    moved: Vec<(String, f64, f64)>,
    /// The H₀ refit, when one was needed.
    null: Option<Box<verdict::NullRefit>>,
}

/// The verdict's tests of `model` (free parameters `free`, held-out evaluation `eval`):
/// the model as it is, when every channel already passes within its noise alone (the
/// strictest form); otherwise its H₀ refit with the parameter and input spread
/// ([`verdict::null_refit`], [`verdict::input_spread`]) — or the model as it is with that
/// spread, when that leaves fewer channels inconsistent, or as few while closer to the
/// held-out data in noise floors (both are the model within its parameter uncertainty).
#[allow(clippy::too_many_arguments)]
fn tested(
    model: &LabModel,
    free: &[Param],
    train: &[Run],
    val: &[Run],
    eval: &crate::evaluate::Evaluation,
    scales: &crate::calibrate::ChannelScales,
    known: Option<verdict::KnownJacobian<'_>>,
    prior: Option<&verdict::NullRefit>,
    threads: usize,
) -> Result<Tested, LabError> {
    let zero = [0.0; crate::data::N_CHANNELS];
    let plain = verdict::test_channels(model, val, eval, &zero);
    if verdict::all_consistent(&plain) {
        return Ok(Tested {
            tests: plain,
            model: model.clone(),
            eval: eval.clone(),
            moved: Vec::new(),
            null: None,
        });
    }
    let null = match prior.map(|p| verdict::null_refit_from(p, model, train, val)) {
        Some(Ok(n)) => n,
        _ => verdict::null_refit(model, free, train, val, scales, known, threads)?,
    };
    let input = verdict::input_spread(&null.model, val, &null.eval.shooting);
    let mut spread = null.spread;
    for (s, u) in spread.iter_mut().zip(input) {
        *s = s.hypot(u);
    }
    let refit = verdict::test_channels(&null.model, val, &null.eval, &spread);
    let as_is = verdict::test_channels(model, val, eval, &spread);
    // Fewer inconsistent channels first; on a tie, the one closer to the held-out data in
    // noise floors (Σ_c (RMSE_c/σ_n,c)²): both pass the test alike, and a refit that
    // trades one channel for another within a wide parameter spread is not preferred.
    let bad = |t: &[verdict::ChannelTest]| t.iter().filter(|c| !c.consistent).count();
    let distance =
        |t: &[verdict::ChannelTest]| -> f64 { t.iter().map(|c| c.ratio * c.ratio).sum() };
    let as_is_favoured = match bad(&as_is).cmp(&bad(&refit)) {
        std::cmp::Ordering::Less => true,
        std::cmp::Ordering::Equal => distance(&as_is) < distance(&refit),
        std::cmp::Ordering::Greater => false,
    };
    Ok(if as_is_favoured {
        Tested {
            tests: as_is,
            model: model.clone(),
            eval: eval.clone(),
            moved: Vec::new(),
            null: Some(Box::new(null)),
        }
    } else {
        Tested {
            tests: refit,
            model: null.model.clone(),
            eval: null.eval.clone(),
            moved: null.moved.clone(),
            null: Some(Box::new(null)),
        }
    })
}

/// One addition of [`add_to_model`].
#[derive(Debug, Clone)]
pub struct AddedStep {
    /// "+ thruster-lag", "+ term:heave:r_2", …
    pub label: String,
    /// The model after the addition (base and everything added so far refitted).
    pub model: LabModel,
    /// Its held-out evaluation.
    pub eval: crate::evaluate::Evaluation,
    /// The addition's evidence card on the held-out runs.
    pub finding: Finding,
    /// The fitted parameters of that step's fit.
    pub fitted: Vec<crate::calibrate::FittedParam>,
}

/// Result of [`add_to_model`].
#[derive(Debug, Clone)]
pub struct Added {
    /// The base calibration.
    pub calibration: crate::calibrate::Calibration,
    /// The calibrated base's held-out evaluation.
    pub base_eval: crate::evaluate::Evaluation,
    /// One step per addition, in order.
    pub steps: Vec<AddedStep>,
    /// Additions that were not possible, in words.
    pub notes: Vec<String>,
}

/// Adds catalog effects, then discovered terms (ids `term:DOF:SLUG`), in order, fitting
/// each exactly as the diagnosis fits it — the same calibration, screening start,
/// confirmation and refinement — and keeping it whatever the held-out runs say (its
/// evidence card says that). So `lab add` of an effect the diagnosis found reaches the
/// diagnosis's optimum.
pub fn add_to_model(
    base: &LabModel,
    train: &[Run],
    val: &[Run],
    effects: &[EffectId],
    terms: &[String],
    opts: &DiagnoseOptions,
) -> Result<Added, LabError> {
    if train.is_empty() || val.is_empty() {
        return Err(LabError::Data {
            run: "(none)".into(),
            detail: "adding needs at least one training and one validation run".into(),
        });
    }
    for e in effects {
        if let Some(reason) = base.not_applicable(*e) {
            return Err(LabError::NotApplicable {
                effect: e.key().into(),
                model: base.base_name().into(),
                reason: reason.into(),
            });
        }
    }
    let _memo = crate::sim::memo_scope(&[train, val]);
    let lm_opts = LmOptions {
        max_iter: opts.calibration_iterations,
        threads: opts.threads,
        ..Default::default()
    };
    let cal = calibrate(base, train, &lm_opts)?;
    let closed_loop = train
        .iter()
        .chain(val.iter())
        .any(|r| r.treatment.closed_loop());
    let mut g = Greedy::new(&cal, train, val, closed_loop, opts.threads)?;
    let base_eval = g.current_eval.clone();
    let mut steps = Vec::new();
    let mut notes = Vec::new();
    for (round, e) in effects.iter().enumerate() {
        crate::progress::stage(
            format!("adding {}", e.key()),
            round + 1,
            effects.len(),
            "effects",
        );
        let cand = match availability(&g.current, train, *e) {
            Availability::Candidate(c) => c,
            Availability::Contained(why) => {
                notes.push(format!("{}: {why}", e.key()));
                continue;
            }
            Availability::NotApplicable(why) | Availability::NotTestable(why) => {
                return Err(LabError::NotApplicable {
                    effect: e.key().into(),
                    model: g.current.base_name().into(),
                    reason: why,
                });
            }
        };
        let screened = g.screen(std::slice::from_ref(&cand))?;
        let Some(s) = screened.first() else {
            return Err(LabError::Model {
                detail: format!("{}: could not be screened", e.key()),
            });
        };
        let judged = g.confirm(&[s], opts.confirm_iterations, true);
        let Some((c, j)) = judged.first() else {
            return Err(LabError::Model {
                detail: format!("{}: no start could be fitted", e.key()),
            });
        };
        // As in the diagnosis: an accepted effect's fits are continued to convergence.
        let polished = g.polish(s, c, opts.confirm_iterations);
        let (c, j) = match &polished {
            Some((pc, pj)) => (pc, pj),
            None => (c, j),
        };
        let finding = effect_finding(c, j, &g.current, round + 1);
        g.accept(c)?;
        steps.push(AddedStep {
            label: format!("+ {}", e.key()),
            model: g.current.clone(),
            eval: g.current_eval.clone(),
            finding,
            fitted: c.fit.fitted.clone(),
        });
    }
    for id in terms {
        let pick = discovery::regress_one(&g.current, train, &g.current_free, id)?;
        let (c, j) = discovery::confirm_term(
            &g.current,
            &g.current_eval,
            train,
            val,
            &g.current_free,
            &pick,
            opts.confirm_iterations,
            &g.scales,
            closed_loop,
        )?;
        let mut j = j;
        veto_on_inadequate_base(&mut j, g.inadequacy().as_ref());
        let Subject::Term(t) = c.subject else {
            continue;
        };
        let names_owned = g.current.command_names_owned();
        let names: Vec<&str> = names_owned.iter().map(String::as_str).collect();
        let finding = term_card(&c, &j, &g.current, 0, None, false);
        g.accept(&c)?;
        steps.push(AddedStep {
            label: format!("+ {}", t.id(&names)),
            model: g.current.clone(),
            eval: g.current_eval.clone(),
            finding,
            fitted: c.fit.fitted.clone(),
        });
    }
    Ok(Added {
        calibration: cal,
        base_eval,
        steps,
        notes,
    })
}

/// The evidence card of a confirmed discovered term: the diagnosis' term rounds, the
/// replacement test and `lab add --terms` all write it here. `outranked`: a better term
/// was accepted this round, so a significant one is reported as not significant.
fn term_card(
    c: &Confirmed,
    j: &Judgement,
    model: &LabModel,
    round: usize,
    pick: Option<&discovery::TermPick>,
    outranked: bool,
) -> Finding {
    let names = model.command_names();
    let Subject::Term(t) = c.subject else {
        return effect_finding(c, j, model, round);
    };
    let significant = j.significant && !outranked;
    let mut f = Finding::blank_term(&t, &names);
    f.significant = significant;
    f.status = if significant {
        Status::Significant
    } else {
        Status::NotSignificant
    };
    f.channels = j.channels.iter().map(|k| k.name().to_string()).collect();
    f.view = view_name(j.view).into();
    f.validation_rmse_reduction_pct = j.primary.clone();
    f.validation_rmse_reduction_pct_free_run = j.free.clone();
    f.validation_rmse_reduction_pct_shooting = j.shoot.clone();
    f.params = param_reports(c);
    let ex = explain(c, j, model);
    let evidence = pick.map_or(String::new(), |p| {
        format!(
            " (found by sparse regression on the residual {}: explains {:.0} % of it, ΔBIC {:.0}, selected in {:.0} % of bootstrap resamples)",
            crate::terms::DOF_FORCE.get(t.dof as usize).copied().unwrap_or("force"),
            p.explained * 100.0,
            p.dbic,
            p.inclusion * 100.0
        )
    });
    f.explanation = if significant {
        format!("{ex}{evidence}")
    } else if j.significant {
        format!("not significant: weaker than a better term this round ({ex}{evidence})")
    } else {
        format!("not significant: {} ({ex}{evidence})", j.reason)
    };
    f.delta_bic = Some(c.dbic);
    f.score = j.score;
    f.round = round;
    f.conflicts = j.conflicts.clone();
    f
}

/// The evidence card of a confirmed catalog effect.
fn effect_finding(c: &Confirmed, j: &Judgement, model: &LabModel, round: usize) -> Finding {
    let effect = c.subject.effect().unwrap_or(EffectId::AddedMass);
    let expl = if j.significant {
        explain(c, j, model)
    } else {
        format!("not significant: {} ({})", j.reason, explain(c, j, model))
    };
    let mut f = Finding::blank(
        effect,
        if j.significant {
            Status::Significant
        } else {
            Status::NotSignificant
        },
        expl,
        c.contained,
    );
    f.significant = j.significant;
    f.channels = j.channels.iter().map(|k| k.name().to_string()).collect();
    f.view = view_name(j.view).into();
    f.validation_rmse_reduction_pct = j.primary.clone();
    f.validation_rmse_reduction_pct_free_run = j.free.clone();
    f.validation_rmse_reduction_pct_shooting = j.shoot.clone();
    f.params = param_reports(c);
    f.delta_bic = Some(c.dbic);
    f.score = j.score;
    f.round = round;
    f.conflicts = j.conflicts.clone();
    f
}

/// The term search's note for library terms whose residual force follows a catalog
/// effect's signature: reported under the effect, not as new terms.
fn catalog_like_note(dof: usize, effect: &str, forms: &[String]) -> String {
    let force = crate::terms::DOF_FORCE.get(dof).copied().unwrap_or("force");
    let listed = match forms {
        [] => String::new(),
        [one] => one.clone(),
        [init @ .., last] => format!("{} and {last}", init.join(", ")),
    };
    let (them, terms) = if forms.len() > 1 {
        ("these are", "new terms")
    } else {
        ("it is", "a new term")
    };
    format!(
        "the residual {force} follows {listed}: {them} the signature of the catalog effect {effect} (reported under it, not as {terms})"
    )
}

#[cfg(test)]
mod tests {
    #[test]
    fn catalog_like_terms_make_one_note_per_effect() {
        let forms: Vec<String> = ["w*|r|", "r*|w|", "r^2"].map(String::from).into();
        assert_eq!(
            catalog_like_note(5, "thrust-asymmetry", &forms),
            "the residual yaw moment follows w*|r|, r*|w| and r^2: these are the signature of the catalog effect thrust-asymmetry (reported under it, not as new terms)"
        );
        assert_eq!(
            catalog_like_note(0, "thruster-deadzone", &forms[..1]),
            "the residual surge force follows w*|r|: it is the signature of the catalog effect thruster-deadzone (reported under it, not as a new term)"
        );
    }

    use super::*;
    use crate::calibrate::structural_scales;
    use nalgebra::{DMatrix, DVector};
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
        assert!(!Param::ReverseRatio(crate::params::Thr::Vertical).bound_is_physical(false));
        assert!(Param::PowerMax.bound_is_physical(true));
    }
}
