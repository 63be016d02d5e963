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
//!    budget that ranks the candidates ([`greedy::Greedy::polish`]): its parameters are reported.
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
//!    inconsistent ([`discovery`]); every DOF's best pick is confirmed, so a moment's own
//!    candidates are tested before a term on another DOF is accepted.
//!
//! Two candidates whose confirmed fits change the held-out predictions the same way
//! (cosine > [`AMBIGUITY_COSINE`]) and score alike are reported as ambiguous, with the
//! experiment that would separate them (modellab.md §3.4).
//!
//! The steps are the methods of one context, `session::Session` (the data, the options,
//! the calibration, the greedy state and what was decided so far), each in the file of
//! its idea: `session` (1), `catalog_rounds` (2–5), `tested` (the verdict's tests),
//! `replacement` (6), `withdrawal` (7), `term_rounds` (8), `conclusion` (verdict and
//! report). [`add_to_model`] (`lab add`) drives the same session.

use std::collections::BTreeMap;

use rov_dynamics::models::Channel;
use serde::Serialize;

use crate::LabError;
use crate::calibrate::{SHOOTING_WINDOW_S, View};
use crate::catalog::EffectId;
use crate::data::Run;
use crate::model::LabModel;
use crate::params::Param;
use crate::verdict::{self, Verdict};

mod add;
mod candidates;
mod cards;
mod catalog_rounds;
mod conclusion;
mod confirmation;
mod discovery;
mod explanations;
mod greedy;
mod judging;
mod options;
mod replacement;
mod report;
mod screening;
mod session;
mod signatures;
mod term_rounds;
mod tested;
#[cfg(test)]
mod tests;
mod withdrawal;

pub use crate::catalog::separating_experiment;
pub use add::{Added, AddedStep, add_to_model};
use candidates::*;
use cards::*;
use confirmation::*;
use explanations::*;
use judging::*;
pub use options::*;
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

/// Diagnoses a base model on training runs, judging on held-out runs: the steps of the
/// module documentation, in order, on one `session::Session`.
pub fn diagnose(
    base: &LabModel,
    model_label: &str,
    train: &[Run],
    val: &[Run],
    opts: &DiagnoseOptions,
) -> Result<Diagnosis, LabError> {
    let train = crate::data::aligned(train, base.channel_table());
    let val = crate::data::aligned(val, base.channel_table());
    session::require_runs(&train, &val, "diagnose")?;
    let mut s = session::Session::start(base, &train, &val, opts)?;
    s.list_candidates(base.active_effects());
    s.catalog_rounds()?;
    let mut tests = s.verdict_tests()?;
    s.try_replacement(&mut tests)?;
    s.withdraw_trade(&mut tests)?;
    s.term_rounds(&mut tests)?;
    let conclusion = s.verdict(&tests);
    Ok(s.report(model_label, tests, conclusion))
}
