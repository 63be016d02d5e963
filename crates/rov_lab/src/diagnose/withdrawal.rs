//! Step 7 of the diagnosis, the **trade withdrawal**: a trade between channels is
//! tolerated only while it leads somewhere. When the calibrated base was structurally
//! inadequate and, with every accepted effect, still is (`judging::Inadequacy::left_by`),
//! the first accepted effect that bought its gain with a channel in the verdict's view is
//! withdrawn with everything fitted on top of it.

use crate::LabError;

use super::replacement::LastAccepted;
use super::session::Session;
use super::tested::VerdictTests;
use super::*;

impl Session<'_> {
    /// Withdraws the first accepted effect that traded a channel, with every effect
    /// accepted after it, when the base was structurally inadequate and the accepted
    /// effects leave it so. Not tried after a replacement (its term passed the immediate
    /// veto; the withdrawal would drop it with the effects it was fitted on top of) — and
    /// run after the replacement test because a term that replaces the trading effect
    /// may leave the model adequate. Reads `history`, `replaced` and the base's
    /// evaluation; writes the greedy state (back to before the withdrawn effect),
    /// `accepted`, the error fall, the withdrawn cards (from `findings` to
    /// `latest_terms`, the first one's conflicts marked as blocking) and `tests.last`.
    pub(super) fn withdraw_trade(&mut self, tests: &mut VerdictTests) -> Result<(), LabError> {
        let base_inadequacy = inadequacy(&self.base_eval, self.closed_loop);
        let (false, Some(inad), Some(left)) = (
            self.replaced,
            base_inadequacy.as_ref(),
            Inadequacy::left_by(&self.base_eval, &self.g.current_eval, self.closed_loop),
        ) else {
            return Ok(());
        };
        let Some(i) = self.history.iter().position(|h| !h.traded.is_empty()) else {
            return Ok(());
        };
        let dropped: Vec<LastAccepted> = self.history.drain(i..).collect();
        if let Some(first) = dropped.first() {
            self.g.restore(first.before.clone());
        }
        self.accepted.truncate(i);
        self.error_fall.truncate(i + 1);
        let first_key = dropped.first().map(|h| h.effect.key()).unwrap_or_default();
        for (k, h) in dropped.iter().enumerate() {
            let key = h.effect.key();
            let Some(pos) = self.findings.iter().position(|f| f.effect == key) else {
                continue;
            };
            let mut f = self.findings.remove(pos);
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
            self.latest_terms.push(f);
        }
        self.retest(tests)
    }
}
