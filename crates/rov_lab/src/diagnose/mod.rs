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

use rov_dynamics::models::Channel;
use serde::Serialize;

use crate::LabError;
use crate::calibrate::{SHOOTING_WINDOW_S, View, calibrate};
use crate::catalog::EffectId;
use crate::data::{Run, ch_name};
use crate::evaluate::{ChannelKey, evaluate};
use crate::lm::LmOptions;
use crate::model::LabModel;
use crate::params::{Param, axis_params_of};

mod candidates;
mod confirmation;
mod explanations;
mod judging;
mod report;
mod screening;
mod signatures;

pub use crate::catalog::separating_experiment;
use candidates::*;
use confirmation::*;
use explanations::*;
use judging::*;
pub use report::*;
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
