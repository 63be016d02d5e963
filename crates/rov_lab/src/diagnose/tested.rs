//! The verdict's tests of a model (H₀ fitted first: [`crate::verdict`]): of the
//! calibrated base once, and of the current model after every step that changes it.

use crate::LabError;
use crate::calibrate::{ChannelScales, SHOOTING_WINDOW_S, View};
use crate::evaluate::Evaluation;
use crate::model::LabModel;
use crate::params::Param;

use super::session::Session;
use super::*;

/// A model's consistency tests as the verdict takes them, with the model and evaluation
/// they were taken on.
#[derive(Debug, Clone)]
pub(super) struct Tested {
    pub(super) tests: Vec<verdict::ChannelTest>,
    pub(super) model: LabModel,
    pub(super) eval: Evaluation,
    /// Parameters the H₀ refit moved (key, from, to).
    pub(super) moved: Vec<(String, f64, f64)>,
    /// The H₀ refit, when one was needed.
    pub(super) null: Option<Box<verdict::NullRefit>>,
}

/// The verdict's tests of the calibrated base and of the current model (the last
/// accepted state).
pub(super) struct VerdictTests {
    pub(super) base: Tested,
    pub(super) last: Tested,
}

/// A model as the verdict tests it: free parameters, held-out evaluation and the
/// multiple-shooting channel weights of its H₀ refit.
struct UnderTest<'m> {
    model: &'m LabModel,
    free: &'m [Param],
    eval: &'m Evaluation,
    scales: &'m ChannelScales,
}

impl Session<'_> {
    /// The verdict's tests of the catalog rounds' result: of the calibrated base (its
    /// H₀ refit starts from the calibration's Jacobian) and of the current model (its
    /// H₀ refit starts from the base's). Reads the calibration and the greedy state.
    pub(super) fn verdict_tests(&self) -> Result<VerdictTests, LabError> {
        let known = self
            .cal
            .lm
            .jacobian
            .as_ref()
            .map(|j| verdict::KnownJacobian {
                columns: j,
                residual: &self.cal.lm.residuals,
            });
        let base = self.tested(
            UnderTest {
                model: &self.cal.model,
                free: &self.cal.params,
                eval: &self.base_eval,
                scales: &self.cal.scales,
            },
            known,
            None,
        )?;
        let last = self.tested_current(&base)?;
        Ok(VerdictTests { base, last })
    }

    /// Tests the current model again after a step changed it (`tests.last`).
    pub(super) fn retest(&self, tests: &mut VerdictTests) -> Result<(), LabError> {
        tests.last = self.tested_current(&tests.base)?;
        Ok(())
    }

    /// The current model's tests: the base's when nothing is accepted.
    fn tested_current(&self, base: &Tested) -> Result<Tested, LabError> {
        if self.accepted.is_empty() && self.accepted_terms.is_empty() {
            return Ok(base.clone());
        }
        self.tested(
            UnderTest {
                model: &self.g.current,
                free: &self.g.current_free,
                eval: &self.g.current_eval,
                scales: self.g.scales.of(View::Shooting(SHOOTING_WINDOW_S)),
            },
            None,
            base.null.as_deref(),
        )
    }

    /// The verdict's tests of a model: the model as it is, when every channel already
    /// passes within its noise alone (the strictest form); otherwise its H₀ refit (from
    /// `prior`'s parameters when given, else fitted with the Jacobian `known` when given)
    /// with the parameter and input spread ([`verdict::null_refit`],
    /// [`verdict::input_spread`]) — or the model as it is with that spread, when that
    /// leaves fewer channels inconsistent, or as few while closer to the held-out data in
    /// noise floors (both are the model within its parameter uncertainty).
    fn tested(
        &self,
        m: UnderTest<'_>,
        known: Option<verdict::KnownJacobian<'_>>,
        prior: Option<&verdict::NullRefit>,
    ) -> Result<Tested, LabError> {
        let UnderTest {
            model,
            free,
            eval,
            scales,
        } = m;
        let (train, val, threads) = (self.train, self.val, self.opts.threads);
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
}
