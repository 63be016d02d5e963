//! The diagnosis's context: the data, the options, the base calibration, the greedy state
//! and what the steps have decided so far. Its methods are the documented steps
//! ([`super::diagnose`] lists them in order; each lives in the file of its idea); `lab
//! add` ([`super::add_to_model`]) starts one too and drives the same fits.

use std::collections::BTreeMap;

use crate::LabError;
use crate::calibrate::{Calibration, calibrate};
use crate::catalog::EffectId;
use crate::data::Run;
use crate::evaluate::Evaluation;
use crate::lm::LmOptions;
use crate::model::LabModel;
use crate::sim::MemoScope;
use crate::terms::Term;

use super::greedy::Greedy;
use super::replacement::LastAccepted;
use super::*;

/// One diagnosis (or `lab add`) in progress.
pub(super) struct Session<'a> {
    /// Training runs.
    pub(super) train: &'a [Run],
    /// Held-out runs.
    pub(super) val: &'a [Run],
    pub(super) opts: DiagnoseOptions,
    /// The base calibration (step 1).
    pub(super) cal: Calibration,
    /// Whether any run was recorded in closed loop.
    pub(super) closed_loop: bool,
    /// The greedy state: current model, its held-out evaluation, free parameters,
    /// screening caches and channel weights.
    pub(super) g: Greedy<'a>,
    /// The calibrated base's held-out evaluation.
    pub(super) base_eval: Evaluation,
    /// Catalog candidates not accepted (yet).
    pub(super) remaining: Vec<Candidate>,
    /// Cards of the catalog effects never fitted (not applicable, not testable, contained).
    pub(super) passive: Vec<Finding>,
    /// Catalog effects accepted, in order.
    pub(super) accepted: Vec<EffectId>,
    /// Discovered terms accepted, in order.
    pub(super) accepted_terms: Vec<Term>,
    /// Cards of the accepted findings, in order.
    pub(super) findings: Vec<Finding>,
    /// The latest card of each catalog candidate evaluated and not accepted.
    pub(super) latest: BTreeMap<EffectId, Finding>,
    /// Cards of terms not accepted and of effects withdrawn or replaced.
    pub(super) latest_terms: Vec<Finding>,
    /// Held-out RMSE per channel after each addition (first: the calibrated base).
    pub(super) error_fall: Vec<(String, RmseMaps)>,
    /// The accepted catalog effects with the greedy state before each (for the
    /// replacement test and the trade withdrawal).
    pub(super) history: Vec<LastAccepted>,
    /// Whether the replacement test replaced the last accepted effect.
    pub(super) replaced: bool,
    /// What the term search saw besides its findings.
    pub(super) search_notes: Vec<String>,
    /// Simulations memoised over these runs while the session lives.
    _memo: MemoScope<'a>,
}

impl<'a> Session<'a> {
    /// Step 1, **calibrate**: memoises simulations over the runs, calibrates the base on
    /// the training runs ([`calibrate`], `calibration_iterations` LM iterations) and
    /// starts the greedy state there; the error fall starts at the calibrated base.
    /// Reads the runs and options; writes everything else (no candidates yet).
    pub(super) fn start(
        base: &LabModel,
        train: &'a [Run],
        val: &'a [Run],
        opts: &DiagnoseOptions,
    ) -> Result<Self, LabError> {
        let memo = crate::sim::memo_scope(&[train, val]);
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
        let g = Greedy::new(&cal, train, val, closed_loop, opts.threads)?;
        let base_eval = g.current_eval.clone();
        Ok(Self {
            train,
            val,
            opts: *opts,
            error_fall: vec![("calibrated base".to_string(), rmse_map(&base_eval))],
            cal,
            closed_loop,
            g,
            base_eval,
            remaining: Vec::new(),
            passive: Vec::new(),
            accepted: Vec::new(),
            accepted_terms: Vec::new(),
            findings: Vec::new(),
            latest: BTreeMap::new(),
            latest_terms: Vec::new(),
            history: Vec::new(),
            replaced: false,
            search_notes: Vec::new(),
            _memo: memo,
        })
    }

    /// Makes a confirmed finding part of the model and appends it to the error fall
    /// under `label` (the greedy state is reweighted: [`Greedy::accept`]).
    pub(super) fn accept(&mut self, c: &Confirmed, label: String) -> Result<(), LabError> {
        self.g.accept(c)?;
        self.error_fall
            .push((label, rmse_map(&self.g.current_eval)));
        Ok(())
    }

    /// The names of the model's command signals (in term ids).
    pub(super) fn command_names(&self) -> Vec<String> {
        self.g.current.command_names_owned()
    }
}

/// The error when `train` or `val` is empty (`what`: "diagnose", "adding").
pub(super) fn require_runs(train: &[Run], val: &[Run], what: &str) -> Result<(), LabError> {
    if train.is_empty() || val.is_empty() {
        return Err(LabError::Data {
            run: "(none)".into(),
            detail: format!("{what} needs at least one training and one validation run"),
        });
    }
    Ok(())
}
