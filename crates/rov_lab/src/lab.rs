//! The lab's user-level operations behind `topside lab compare|diagnose|add`, with
//! serialisable reports (the CLI prints them as text or JSON).

use std::collections::BTreeMap;

use rov_dynamics::models::Channel;
use serde::Serialize;

use crate::LabError;
use crate::analysis::{ChannelFailure, channel_failure, segment_metrics};
use crate::calibrate::{FittedParam, SHOOTING_WINDOW_S, View};
use crate::catalog::EffectId;
use crate::data::{Run, ch_name};
use crate::diagnose::{Diagnosis, Finding};
use crate::evaluate::Evaluation;
use crate::lm::LmOptions;
use crate::metrics::{ChannelMetrics, channel_metrics, pooled_metrics, windows};
use crate::model::LabModel;
use crate::sim::{Prediction, compared_channels, simulate_run};

/// k of the k-step view, s.
pub const K_STEP_S: f64 = 5.0;

/// Metrics of all compared channels in one view.
#[derive(Debug, Clone, Serialize)]
pub struct ViewMetrics {
    /// Per channel.
    pub channels: BTreeMap<String, ChannelMetrics>,
}

/// A segment's metrics.
#[derive(Debug, Clone, Serialize)]
pub struct SegmentReport {
    /// Label, e.g. "vertical 60 %".
    pub label: String,
    /// Start, s.
    pub t_start_s: f64,
    /// End, s.
    pub t_end_s: f64,
    /// Per channel (multiple-shooting view).
    pub channels: BTreeMap<String, ChannelMetrics>,
}

/// A window's metrics.
#[derive(Debug, Clone, Serialize)]
pub struct WindowReport {
    /// Start, s.
    pub t_start_s: f64,
    /// End, s.
    pub t_end_s: f64,
    /// Per channel (free-run view).
    pub channels: BTreeMap<String, ChannelMetrics>,
}

/// One run's comparison.
#[derive(Debug, Clone, Serialize)]
pub struct RunReport {
    /// Run name.
    pub name: String,
    /// Duration, s.
    pub duration_s: f64,
    /// Per view: "free_run", "shooting", "k_step".
    pub views: BTreeMap<String, ViewMetrics>,
    /// Per manoeuvre segment.
    pub segments: Vec<SegmentReport>,
    /// Per 10 s window (50 % overlap).
    pub windows: Vec<WindowReport>,
}

/// Result of [`compare`].
#[derive(Debug, Clone, Serialize)]
pub struct CompareReport {
    /// Model name as given.
    pub model: String,
    /// Effects in the model.
    pub effects: Vec<String>,
    /// Whether the effects' parameters were fitted on the compared data.
    pub effects_fitted_in_sample: bool,
    /// Per channel, pooled over runs: the lab's summary with both views
    /// ([`ChannelSummary`]: `rmse` is multiple shooting, as in `add` and `diagnose`).
    pub channels: BTreeMap<String, ChannelSummary>,
    /// Pooled over runs, per view.
    pub pooled: BTreeMap<String, ViewMetrics>,
    /// Per run.
    pub runs: Vec<RunReport>,
    /// Measured channels the model does not predict.
    pub not_predicted: Vec<String>,
    /// Failure views per channel (multiple-shooting residuals).
    pub failures: Vec<ChannelFailure>,
    /// Fitted effect parameters, if any.
    pub params: Vec<FittedParam>,
    /// Notes.
    pub notes: Vec<String>,
    /// Predictions per run in the free-run view (for plots; not serialised).
    #[serde(skip)]
    pub free_run: Vec<Prediction>,
    /// Predictions per run in the multiple-shooting view.
    #[serde(skip)]
    pub shooting: Vec<Prediction>,
}

fn view_metrics(run: &Run, pred: &Prediction, chans: &[Channel]) -> ViewMetrics {
    ViewMetrics {
        channels: chans
            .iter()
            .filter_map(|c| channel_metrics(run, pred, *c).map(|m| (ch_name(*c).to_string(), m)))
            .collect(),
    }
}

fn not_predicted(model: &LabModel, runs: &[Run]) -> Vec<String> {
    Channel::ALL
        .iter()
        .filter(|c| runs.iter().any(|r| r.has(**c)) && !model.predicts_channel(**c))
        .map(|c| ch_name(*c).to_string())
        .collect()
}

/// Adds effects to a model and fits them jointly with the base on `runs`, in-sample (the
/// fit of [`crate::diagnose::add_to_model`] with the same runs held out). Contained
/// effects refit their base parameters instead of adding a term.
pub fn fit_with_effects(
    model: &LabModel,
    runs: &[Run],
    effects: &[EffectId],
    opts: &LmOptions,
) -> Result<(LabModel, Vec<FittedParam>), LabError> {
    let runs = crate::data::aligned(runs, model.channel_table());
    let runs = &runs[..];
    let d = crate::diagnose::DiagnoseOptions {
        threads: opts.threads,
        calibration_iterations: opts.max_iter,
        ..Default::default()
    };
    let added = crate::diagnose::add_to_model(model, runs, runs, effects, &[], &d)?;
    Ok(match added.steps.last() {
        Some(s) => (s.model.clone(), s.fitted.clone()),
        None => (
            added.calibration.model.clone(),
            added.calibration.fitted.clone(),
        ),
    })
}

/// One run of [`compare`]: its report and its predictions in the three views (free run,
/// multiple shooting, k-step with `k` steps).
fn compare_run(
    m: &LabModel,
    run: &Run,
    k: usize,
) -> Result<(RunReport, Prediction, Prediction, Prediction), LabError> {
    let chans = compared_channels(m, run);
    let pf = simulate_run(m, run, &View::FreeRun.resets(run))?;
    let ps = simulate_run(m, run, &View::Shooting(SHOOTING_WINDOW_S).resets(run))?;
    let pk = simulate_run(m, run, &View::KStep(k).resets(run))?;
    let mut views = BTreeMap::new();
    views.insert("free_run".to_string(), view_metrics(run, &pf, &chans));
    views.insert("shooting".to_string(), view_metrics(run, &ps, &chans));
    views.insert("k_step".to_string(), view_metrics(run, &pk, &chans));
    let mut seg_map: Vec<SegmentReport> = Vec::new();
    for ch in &chans {
        for (label, t0, t1, mm) in segment_metrics(run, &ps, *ch) {
            match seg_map
                .iter_mut()
                .find(|s| s.t_start_s == t0 && s.label == label)
            {
                Some(s) => {
                    s.channels.insert(ch_name(*ch).to_string(), mm);
                }
                None => seg_map.push(SegmentReport {
                    label,
                    t_start_s: t0,
                    t_end_s: t1,
                    channels: [(ch_name(*ch).to_string(), mm)].into_iter().collect(),
                }),
            }
        }
    }
    let win = windows(run, 10.0)
        .into_iter()
        .map(|w| WindowReport {
            t_start_s: run.t[w.start],
            t_end_s: run.t[w.end - 1],
            channels: chans
                .iter()
                .filter_map(|c| {
                    crate::metrics::channel_metrics_range(run, &pf, *c, w.clone())
                        .map(|mm| (ch_name(*c).to_string(), mm))
                })
                .collect(),
        })
        .collect();
    Ok((
        RunReport {
            name: run.name.clone(),
            duration_s: run.duration_s(),
            views,
            segments: seg_map,
            windows: win,
        },
        pf,
        ps,
        pk,
    ))
}

/// Compares a model (with optional effects fitted on the same data) with measured runs in
/// the three views.
pub fn compare(
    model: &LabModel,
    model_label: &str,
    runs: &[Run],
    effects: &[EffectId],
    threads: usize,
) -> Result<CompareReport, LabError> {
    let runs = crate::data::aligned(runs, model.channel_table());
    let runs = &runs[..];
    let mut notes = Vec::new();
    let (m, params) = if effects.is_empty() {
        (model.clone(), Vec::new())
    } else {
        notes.push(
            "the effects' parameters were fitted jointly with the base calibration on the compared data (in-sample); use `lab add` for a held-out comparison".into(),
        );
        fit_with_effects(
            model,
            runs,
            effects,
            &LmOptions {
                max_iter: 8,
                threads,
                ..Default::default()
            },
        )?
    };
    let dt = runs.first().map_or(0.05, |r| r.median_dt()).max(1e-3);
    let k = (K_STEP_S / dt).round().max(1.0) as usize;
    let mut run_reports = Vec::new();
    let (mut free, mut shoot, mut kstep) = (Vec::new(), Vec::new(), Vec::new());
    // Each run on its own (a worker each; the results back in run order).
    let counter = crate::progress::Counter::start("comparing", runs.len(), "runs");
    let per_run = crate::par::par_map_items(runs, threads, |run| {
        let out = compare_run(&m, run, k);
        counter.tick();
        out
    });
    for r in per_run {
        let (report, pf, ps, pk) = r?;
        run_reports.push(report);
        free.push(pf);
        shoot.push(ps);
        kstep.push(pk);
    }
    let mut all: Vec<Channel> = Vec::new();
    for r in runs {
        for c in compared_channels(&m, r) {
            if !all.contains(&c) {
                all.push(c);
            }
        }
    }
    let pooled_view = |preds: &[Prediction]| -> ViewMetrics {
        let items: Vec<(&Run, &Prediction)> = runs.iter().zip(preds.iter()).collect();
        ViewMetrics {
            channels: all
                .iter()
                .filter_map(|c| pooled_metrics(&items, *c).map(|mm| (ch_name(*c).to_string(), mm)))
                .collect(),
        }
    };
    let (pooled_free, pooled_shoot) = (pooled_view(&free), pooled_view(&shoot));
    let channels = all
        .iter()
        .filter_map(|c| {
            let name = ch_name(*c);
            let (f, s) = (
                pooled_free.channels.get(name),
                pooled_shoot.channels.get(name),
            );
            (f.is_some() || s.is_some()).then(|| {
                let noise = crate::evaluate::pooled_noise(runs, *c);
                (name.to_string(), ChannelSummary::of_views(f, s, noise))
            })
        })
        .collect();
    let mut pooled = BTreeMap::new();
    pooled.insert("free_run".to_string(), pooled_free);
    pooled.insert("shooting".to_string(), pooled_shoot);
    pooled.insert("k_step".to_string(), pooled_view(&kstep));
    let failures = all
        .iter()
        .filter_map(|c| channel_failure(runs, &shoot, *c))
        .collect();
    notes.extend(crate::ingest::treatment_sentences(runs));
    let np = not_predicted(&m, runs);
    if !np.is_empty() {
        notes.push(format!(
            "{} does not predict {}; they are left out of the metrics",
            model_label,
            np.join(", ")
        ));
    }
    Ok(CompareReport {
        model: model_label.into(),
        effects: m
            .active_effects()
            .iter()
            .map(|e| e.key().to_string())
            .collect(),
        effects_fitted_in_sample: !effects.is_empty(),
        channels,
        pooled,
        runs: run_reports,
        not_predicted: np,
        failures,
        params,
        notes,
        free_run: free,
        shooting: shoot,
    })
}

/// The lab's one per-channel summary, in every JSON document of `topside lab` (`compare`'s
/// `channels`, `add`'s `before`/`after`, `diagnose`'s `baseline.channels`, `cv`'s
/// `before`/`after`), with both error views under explicit keys:
///
/// * `rmse_shooting`: RMSE of the multiple-shooting view (the model re-started from the
///   measured state every [`SHOOTING_WINDOW_S`]).
/// * `rmse_free_run`: RMSE of the free run (one simulation from the first sample).
/// * `rmse`: kept for scripts with the meaning it has always had in these summaries:
///   the multiple-shooting RMSE (equal to `rmse_shooting`).
///
/// Both views come from [`crate::metrics::pooled_metrics`] (the fit metrics of
/// [`rov_types::fit`]), pooled over the runs. A view that cannot be computed for a
/// channel (no finite predicted sample, e.g. a free run that diverged) is `null`.
#[derive(Debug, Clone, Serialize)]
pub struct ChannelSummary {
    /// Fit % (multiple shooting).
    pub fit_pct: Option<f64>,
    /// RMSE (multiple shooting); the same number as `rmse_shooting`.
    pub rmse: Option<f64>,
    /// Fit % (free run).
    pub fit_pct_free_run: Option<f64>,
    /// RMSE (free run).
    pub rmse_free_run: Option<f64>,
    /// RMSE (multiple shooting).
    pub rmse_shooting: Option<f64>,
    /// Noise floor estimated from the data.
    pub noise: f64,
}

impl ChannelSummary {
    /// The summary of a channel's pooled metrics in the two views (`None` where a view
    /// could not be computed).
    pub fn of_views(
        free_run: Option<&ChannelMetrics>,
        shooting: Option<&ChannelMetrics>,
        noise: f64,
    ) -> Self {
        Self {
            fit_pct: shooting.and_then(|m| m.fit_pct),
            rmse: shooting.map(|m| m.rmse),
            fit_pct_free_run: free_run.and_then(|m| m.fit_pct),
            rmse_free_run: free_run.map(|m| m.rmse),
            rmse_shooting: shooting.map(|m| m.rmse),
            noise,
        }
    }
}

/// Channel summaries of an evaluation.
pub fn summarize(e: &Evaluation) -> BTreeMap<String, ChannelSummary> {
    e.channels
        .iter()
        .map(|(k, c)| {
            (
                k.name().to_string(),
                ChannelSummary::of_views(Some(&c.free_run), Some(&c.shooting), c.noise),
            )
        })
        .collect()
}

/// A step of the error fall.
#[derive(Debug, Clone, Serialize)]
pub struct ErrorFallStep {
    /// "calibrated base", "+ thruster-lag", …
    pub label: String,
    /// Held-out RMSE per channel (multiple shooting; the same as `rmse_shooting`).
    pub rmse: BTreeMap<String, f64>,
    /// Held-out RMSE per channel (free run).
    pub rmse_free_run: BTreeMap<String, f64>,
    /// Held-out RMSE per channel (multiple shooting).
    pub rmse_shooting: BTreeMap<String, f64>,
}

/// Result of [`add`].
#[derive(Debug, Clone, Serialize)]
pub struct AddReport {
    /// Model name as given.
    pub model: String,
    /// Effects added (contained ones are refitted).
    pub effects: Vec<String>,
    /// Effects the base already contained (refitted, not added).
    pub refitted_contained: Vec<String>,
    /// Held-out metrics of the calibrated base.
    pub before: BTreeMap<String, ChannelSummary>,
    /// Held-out metrics after adding and refitting.
    pub after: BTreeMap<String, ChannelSummary>,
    /// Held-out RMSE reduction per channel, % (multiple shooting; free run below).
    pub rmse_reduction_pct: BTreeMap<String, f64>,
    /// Held-out RMSE reduction per channel, free run, %.
    pub rmse_reduction_pct_free_run: BTreeMap<String, f64>,
    /// Error fall across successive additions.
    pub error_fall: Vec<ErrorFallStep>,
    /// Base calibration.
    pub calibration: Vec<FittedParam>,
    /// Fitted parameters of the final model.
    pub params: Vec<FittedParam>,
    /// Measured channels the model does not predict.
    pub not_predicted: Vec<String>,
    /// Each addition's evidence on the held-out runs (as the diagnosis reports it).
    pub findings: Vec<Finding>,
    /// Additions that were not possible, in words.
    pub notes: Vec<String>,
    /// What was done to the data, in words.
    pub data: Vec<String>,
    /// The final model (not serialised).
    #[serde(skip)]
    pub model_fitted: Option<LabModel>,
    /// Held-out evaluations: base then after each addition (not serialised).
    #[serde(skip)]
    pub evaluations: Vec<Evaluation>,
}

fn fall_step(label: String, e: &Evaluation) -> ErrorFallStep {
    let view = |f: fn(&crate::evaluate::ChannelEval) -> f64| -> BTreeMap<String, f64> {
        e.channels
            .iter()
            .map(|(k, c)| (k.name().to_string(), f(c)))
            .collect()
    };
    ErrorFallStep::new(label, view(|c| c.shooting.rmse), view(|c| c.free_run.rmse))
}

impl ErrorFallStep {
    /// A step from its held-out RMSE maps in the two views.
    pub fn new(
        label: String,
        shooting: BTreeMap<String, f64>,
        free_run: BTreeMap<String, f64>,
    ) -> Self {
        Self {
            label,
            rmse: shooting.clone(),
            rmse_free_run: free_run,
            rmse_shooting: shooting,
        }
    }
}

/// Calibrates the base on `train`, adds the effects one after the other exactly as the
/// diagnosis fits them (each time refitting the base jointly), and reports held-out
/// metrics before and after, the error fall and each addition's evidence.
pub fn add(
    model: &LabModel,
    model_label: &str,
    effects: &[EffectId],
    train: &[Run],
    val: &[Run],
    threads: usize,
) -> Result<AddReport, LabError> {
    add_with_terms(model, model_label, effects, &[], train, val, threads)
}

/// [`add`], then the discovered terms (ids `term:DOF:SLUG`, as the diagnosis reports them).
pub fn add_with_terms(
    model: &LabModel,
    model_label: &str,
    effects: &[EffectId],
    terms: &[String],
    train: &[Run],
    val: &[Run],
    threads: usize,
) -> Result<AddReport, LabError> {
    let (train, val) = (
        crate::data::aligned(train, model.channel_table()),
        crate::data::aligned(val, model.channel_table()),
    );
    let (train, val) = (&train[..], &val[..]);
    let opts = crate::diagnose::DiagnoseOptions {
        threads,
        ..Default::default()
    };
    let added = crate::diagnose::add_to_model(model, train, val, effects, terms, &opts)?;
    let base_eval = added.base_eval.clone();
    let mut evaluations = vec![base_eval.clone()];
    let mut fall = vec![fall_step("calibrated base".into(), &base_eval)];
    for s in &added.steps {
        fall.push(fall_step(s.label.clone(), &s.eval));
        evaluations.push(s.eval.clone());
    }
    let last = evaluations.last().cloned().unwrap_or_default();
    let red = |f: fn(&crate::evaluate::ChannelEval) -> f64| -> BTreeMap<String, f64> {
        base_eval
            .channels
            .iter()
            .filter_map(|(k, b)| {
                last.channels.get(k).map(|a| {
                    let (x, y) = (f(b), f(a));
                    (
                        k.name().to_string(),
                        if x > 0.0 { 100.0 * (1.0 - y / x) } else { 0.0 },
                    )
                })
            })
            .collect()
    };
    let final_model = added
        .steps
        .last()
        .map(|s| s.model.clone())
        .unwrap_or_else(|| added.calibration.model.clone());
    let params = added
        .steps
        .last()
        .map(|s| s.fitted.clone())
        .unwrap_or_else(|| added.calibration.fitted.clone());
    let mut names: Vec<String> = effects.iter().map(|e| e.key().to_string()).collect();
    names.extend(terms.iter().cloned());
    Ok(AddReport {
        model: model_label.into(),
        effects: names,
        refitted_contained: effects
            .iter()
            .filter(|e| model.contains(**e))
            .map(|e| e.key().to_string())
            .collect(),
        before: summarize(&base_eval),
        after: summarize(&last),
        rmse_reduction_pct: red(|c| c.shooting.rmse),
        rmse_reduction_pct_free_run: red(|c| c.free_run.rmse),
        error_fall: fall,
        calibration: added.calibration.fitted.clone(),
        params,
        not_predicted: not_predicted(model, val),
        findings: added.steps.iter().map(|s| s.finding.clone()).collect(),
        notes: added.notes.clone(),
        data: {
            let mut d = crate::ingest::treatment_sentences(train);
            for s in crate::ingest::treatment_sentences(val) {
                if !d.contains(&s) {
                    d.push(s);
                }
            }
            d
        },
        model_fitted: Some(final_model),
        evaluations,
    })
}

/// The JSON of `topside lab diagnose`.
#[derive(Debug, Clone, Serialize)]
pub struct DiagnoseJson {
    /// Model name as given.
    pub model: String,
    /// "adequate", "explained" or "unexplained" (see [`crate::verdict`]).
    pub verdict: crate::verdict::Verdict,
    /// Channels still inconsistent with noise and parameter uncertainty, with where their
    /// misfit lives (empty unless the verdict is "unexplained").
    pub unexplained: Vec<crate::verdict::Unexplained>,
    /// The consistency test of every channel (final model, held-out data).
    pub consistency: Vec<crate::verdict::ChannelTest>,
    /// What was done to the data (spikes, gaps, time stamps, closed loop), in words.
    pub data: Vec<String>,
    /// Whether the data was recorded in closed loop.
    pub closed_loop: bool,
    /// Calibration parameters at a bound or along an unidentifiable direction.
    pub calibration_notes: Vec<String>,
    /// What the term search saw besides its findings.
    pub search_notes: Vec<String>,
    /// Calibrated base on the held-out data.
    pub baseline: BaselineJson,
    /// Findings, best first.
    pub findings: Vec<Finding>,
    /// Summary.
    pub summary: String,
    /// Accepted effects in order.
    pub accepted: Vec<String>,
    /// Channels measured but not predicted.
    pub not_predicted: Vec<String>,
    /// Base calibration.
    pub calibration: Vec<FittedParam>,
    /// Error fall across accepted effects (held-out RMSE, multiple shooting).
    pub error_fall: Vec<ErrorFallStep>,
}

/// `baseline` of [`DiagnoseJson`].
#[derive(Debug, Clone, Serialize)]
pub struct BaselineJson {
    /// Per predicted channel.
    pub channels: BTreeMap<String, ChannelSummary>,
}

impl From<&crate::diagnose::BaselineChannel> for ChannelSummary {
    fn from(b: &crate::diagnose::BaselineChannel) -> Self {
        Self {
            fit_pct: b.fit_pct,
            rmse: Some(b.rmse_shooting),
            fit_pct_free_run: b.fit_pct_free_run,
            rmse_free_run: Some(b.rmse_free_run),
            rmse_shooting: Some(b.rmse_shooting),
            noise: b.noise,
        }
    }
}

/// Builds the diagnose JSON document.
pub fn diagnose_json(d: &Diagnosis) -> DiagnoseJson {
    let names = d.final_model.command_names();
    let mut accepted: Vec<String> = d.accepted.iter().map(|e| e.key().to_string()).collect();
    accepted.extend(d.accepted_terms.iter().map(|t| t.id(&names)));
    DiagnoseJson {
        model: d.model.clone(),
        verdict: d.verdict,
        unexplained: d.unexplained.clone(),
        consistency: d.consistency.clone(),
        data: d.data_notes.clone(),
        closed_loop: d.closed_loop,
        calibration_notes: d.calibration_notes.clone(),
        search_notes: d.search_notes.clone(),
        baseline: BaselineJson {
            channels: d
                .baseline
                .iter()
                .map(|(k, b)| (k.clone(), ChannelSummary::from(b)))
                .collect(),
        },
        findings: d.findings.clone(),
        summary: d.summary.clone(),
        accepted,
        not_predicted: d.not_predicted.clone(),
        calibration: d.calibration.clone(),
        error_fall: d
            .error_fall
            .iter()
            .map(|(label, m)| {
                ErrorFallStep::new(label.clone(), m.shooting.clone(), m.free_run.clone())
            })
            .collect(),
    }
}
