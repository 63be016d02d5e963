//! `lab add`: catalog effects, then discovered terms, added in order to a calibrated base
//! and each fitted exactly as the diagnosis fits it, on the same [`Session`].

use crate::LabError;
use crate::model::LabModel;

use super::session::{Session, require_runs};
use super::*;

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
    require_runs(train, val, "adding")?;
    for e in effects {
        if let Some(reason) = base.not_applicable(*e) {
            return Err(LabError::NotApplicable {
                effect: e.key().into(),
                model: base.base_name().into(),
                reason: reason.into(),
            });
        }
    }
    let mut s = Session::start(base, train, val, opts)?;
    let mut steps = Vec::new();
    let mut notes = Vec::new();
    for (round, e) in effects.iter().enumerate() {
        crate::progress::stage(
            format!("adding {}", e.key()),
            round + 1,
            effects.len(),
            "effects",
        );
        match s.add_effect(*e, round + 1)? {
            Ok(step) => steps.push(step),
            Err(note) => notes.push(note),
        }
    }
    for id in terms {
        steps.extend(s.add_term(id)?);
    }
    Ok(Added {
        calibration: s.cal,
        base_eval: s.base_eval,
        steps,
        notes,
    })
}

impl Session<'_> {
    /// Adds one catalog effect as the catalog rounds accept one: screened alone on the
    /// current model, every start confirmed and refined, its fits continued to
    /// convergence ([`Greedy::polish`](super::greedy::Greedy::polish)), accepted whatever
    /// the held-out runs say (its card, of round `round`, says that). `Err(note)` when the
    /// base already contains it; an error when it is not applicable or testable, or
    /// could not be fitted.
    fn add_effect(
        &mut self,
        e: EffectId,
        round: usize,
    ) -> Result<Result<AddedStep, String>, LabError> {
        let cand = match availability(&self.g.current, self.train, e) {
            Availability::Candidate(c) => c,
            Availability::Contained(why) => return Ok(Err(format!("{}: {why}", e.key()))),
            Availability::NotApplicable(why) | Availability::NotTestable(why) => {
                return Err(LabError::NotApplicable {
                    effect: e.key().into(),
                    model: self.g.current.base_name().into(),
                    reason: why,
                });
            }
        };
        let screened = self.g.screen(std::slice::from_ref(&cand))?;
        let Some(sc) = screened.first() else {
            return Err(LabError::Model {
                detail: format!("{}: could not be screened", e.key()),
            });
        };
        let judged = self.g.confirm(&[sc], self.opts.confirm_iterations, true);
        let Some((c, j)) = judged.first() else {
            return Err(LabError::Model {
                detail: format!("{}: no start could be fitted", e.key()),
            });
        };
        // As in the diagnosis: an accepted effect's fits are continued to convergence.
        let polished = self.g.polish(sc, c, self.opts.confirm_iterations);
        let (c, j) = match &polished {
            Some((pc, pj)) => (pc, pj),
            None => (c, j),
        };
        let finding = effect_finding(c, j, &self.g.current, round);
        Ok(Ok(self.added(c, format!("+ {}", e.key()), finding)?))
    }

    /// Adds one discovered term (id `term:DOF:SLUG`) as the term rounds accept one: its
    /// coefficient regressed on the residual, confirmed on the held-out runs, vetoed on a
    /// structurally inadequate model, accepted whatever they say. `None` when the id is
    /// not a term.
    fn add_term(&mut self, id: &str) -> Result<Option<AddedStep>, LabError> {
        let pick = discovery::regress_one(&self.g.current, self.train, &self.g.current_free, id)?;
        let (c, mut j) = self
            .g
            .confirm_term(&pick, None, self.opts.confirm_iterations)?;
        veto_on_inadequate_base(&mut j, self.g.inadequacy().as_ref());
        let Subject::Term(t) = c.subject else {
            return Ok(None);
        };
        let names = self.command_names();
        let names: Vec<&str> = names.iter().map(String::as_str).collect();
        let finding = term_card(&c, &j, &self.g.current, 0, None, false);
        Ok(Some(self.added(
            &c,
            format!("+ {}", t.id(&names)),
            finding,
        )?))
    }

    /// Accepts a confirmed addition ([`Session::accept`]) and describes the step.
    fn added(
        &mut self,
        c: &Confirmed,
        label: String,
        finding: Finding,
    ) -> Result<AddedStep, LabError> {
        self.accept(c, label.clone())?;
        Ok(AddedStep {
            label,
            model: self.g.current.clone(),
            eval: self.g.current_eval.clone(),
            finding,
            fitted: c.fit.fitted.clone(),
        })
    }
}
