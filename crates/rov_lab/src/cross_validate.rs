//! Per-session and leave-one-session-out held-out fit of a model on its own command
//! channels, before and after calibration (issue 22, part 3).
//!
//! Sessions are the runs' sources (a log that gaps split into several runs is one
//! session). For each session s:
//!
//! * **before**: the model as given, evaluated on s (free run and multiple shooting);
//! * **after**: the model calibrated ([`crate::calibrate::calibrate`], the documented
//!   priors) on every other session, evaluated on s: a held-out fit, never in-sample.
//!
//! The median over sessions per channel summarises both. Fit % is MATLAB's
//! (`rov_types::fit`, through [`crate::lab::summarize`]); null where a channel barely moves
//! (the lab's noise-floor gate).

use std::collections::BTreeMap;

use serde::Serialize;

use crate::calibrate::calibrate;
use crate::lab::{ChannelSummary, summarize};
use crate::lm::LmOptions;
use crate::{LabError, LabModel, Run};

/// One session's held-out numbers.
#[derive(Debug, Clone, Serialize)]
pub struct SessionFit {
    /// The session (the runs' source).
    pub session: String,
    /// Runs it holds (gaps split a session).
    pub runs: usize,
    /// The model as given, per channel.
    pub before: BTreeMap<String, ChannelSummary>,
    /// The model calibrated on the other sessions, per channel.
    pub after: BTreeMap<String, ChannelSummary>,
    /// Weighted calibration cost on the other sessions, before and after.
    pub calibration_cost: (f64, f64),
}

/// Median fit % over sessions of one channel.
#[derive(Debug, Clone, Default, Serialize)]
pub struct MedianFit {
    /// Multiple shooting, before calibration.
    pub shooting_before: Option<f64>,
    /// Multiple shooting, held out after calibration.
    pub shooting_after: Option<f64>,
    /// Free run, before.
    pub free_run_before: Option<f64>,
    /// Free run, held out after.
    pub free_run_after: Option<f64>,
    /// Sessions with a fit % (the channel moves in them).
    pub sessions: usize,
}

/// The whole cross-validation.
#[derive(Debug, Clone, Serialize)]
pub struct CrossValidation {
    /// Per session.
    pub sessions: Vec<SessionFit>,
    /// Medians per channel.
    pub median: BTreeMap<String, MedianFit>,
    /// The multiple-shooting window, s.
    pub window_s: f64,
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    rov_types::fit::median(&mut v)
}

/// Runs grouped by session, in first-seen order.
pub fn sessions_of(runs: &[Run]) -> Vec<(String, Vec<Run>)> {
    let mut out: Vec<(String, Vec<Run>)> = Vec::new();
    for r in runs {
        let key = if r.treatment.source.is_empty() {
            r.name.clone()
        } else {
            r.treatment.source.clone()
        };
        match out.iter_mut().find(|(k, _)| *k == key) {
            Some((_, v)) => v.push(r.clone()),
            None => out.push((key, vec![r.clone()])),
        }
    }
    out
}

/// Session `i` of `groups` held out: the model as given, and calibrated on the others.
fn session_fit(
    model: &LabModel,
    groups: &[(String, Vec<Run>)],
    i: usize,
    opts: &LmOptions,
    window_s: f64,
) -> Result<SessionFit, LabError> {
    let Some((name, held)) = groups.get(i) else {
        return Err(LabError::Data {
            run: "(sessions)".into(),
            detail: format!("no session {i}"),
        });
    };
    let train: Vec<Run> = groups
        .iter()
        .enumerate()
        .filter(|(j, _)| *j != i)
        .flat_map(|(_, (_, r))| r.iter().cloned())
        .collect();
    let before = summarize(&crate::evaluate::evaluate_window(model, held, window_s)?);
    let cal = calibrate(model, &train, opts)?;
    let after = summarize(&crate::evaluate::evaluate_window(
        &cal.model, held, window_s,
    )?);
    Ok(SessionFit {
        session: name.clone(),
        runs: held.len(),
        before,
        after,
        calibration_cost: (cal.cost0, cal.cost),
    })
}

/// Leave-one-session-out cross-validation (at least two sessions), multiple shooting in
/// windows of `window_s` (the lab's own views: [`crate::calibrate::SHOOTING_WINDOW_S`]).
pub fn leave_one_session_out(
    model: &LabModel,
    runs: &[Run],
    opts: &LmOptions,
    window_s: f64,
) -> Result<CrossValidation, LabError> {
    let runs = crate::data::aligned(runs, model.channel_table());
    let groups = sessions_of(&runs);
    if groups.len() < 2 {
        return Err(LabError::Data {
            run: "(sessions)".into(),
            detail: format!(
                "{} session(s); leave-one-session-out needs at least two",
                groups.len()
            ),
        });
    }
    // Each held-out session on its own worker (its calibration's Jacobian nests in the
    // same pool); the results back in session order.
    let counter = crate::progress::Counter::start("cross-validating", groups.len(), "sessions");
    let fits = crate::par::par_map(groups.len(), opts.threads, |i| {
        let out = session_fit(model, &groups, i, opts, window_s);
        counter.tick();
        out
    });
    let sessions = fits
        .into_iter()
        .collect::<Result<Vec<SessionFit>, LabError>>()?;
    let mut median_map: BTreeMap<String, MedianFit> = BTreeMap::new();
    let channels: Vec<String> = sessions
        .iter()
        .flat_map(|s| s.before.keys().chain(s.after.keys()).cloned())
        .collect();
    for ch in channels {
        if median_map.contains_key(&ch) {
            continue;
        }
        let pick = |f: &dyn Fn(&SessionFit) -> Option<f64>| -> Vec<f64> {
            sessions.iter().filter_map(f).collect()
        };
        let sb = pick(&|s| s.before.get(&ch).and_then(|c| c.fit_pct));
        let sa = pick(&|s| s.after.get(&ch).and_then(|c| c.fit_pct));
        let fb = pick(&|s| s.before.get(&ch).and_then(|c| c.fit_pct_free_run));
        let fa = pick(&|s| s.after.get(&ch).and_then(|c| c.fit_pct_free_run));
        let n = sa.len().max(sb.len());
        median_map.insert(
            ch.clone(),
            MedianFit {
                shooting_before: median(sb),
                shooting_after: median(sa),
                free_run_before: median(fb),
                free_run_after: median(fa),
                sessions: n,
            },
        );
    }
    Ok(CrossValidation {
        sessions,
        median: median_map,
        window_s,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(vec![3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(vec![4.0, 1.0, 2.0, 3.0]), Some(2.5));
        assert_eq!(median(vec![]), None);
    }
}
