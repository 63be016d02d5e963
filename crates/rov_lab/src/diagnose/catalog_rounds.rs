//! Steps 2–5 of the diagnosis, the **catalog rounds**: screen every remaining candidate,
//! confirm the strongest in simulation, judge them on the held-out runs, accept the best
//! (its fits continued to convergence), name the candidates it cannot be told apart
//! from, and go again on top of it.

use crate::LabError;
use crate::calibrate::View;
use crate::evaluate::ChannelKey;

use super::replacement::LastAccepted;
use super::session::Session;
use super::*;

impl Session<'_> {
    /// The catalog's candidates for the calibrated base and data ([`candidates_of`];
    /// `skip`: effects the base already carries). With closed-loop data the slow ones
    /// (seen only in the free run) are not testable. Writes `remaining` and `passive`.
    pub(super) fn list_candidates(&mut self, skip: &[EffectId]) {
        let (mut all, mut passive) = candidates_of(&self.cal.model, self.train, skip);
        if self.closed_loop {
            // A slow sensor drift shows only in the free run, which closed-loop data voids.
            let (slow, fast): (Vec<Candidate>, Vec<Candidate>) = all
                .into_iter()
                .partition(|c| primary_view(c.effect) == View::FreeRun);
            all = fast;
            for c in slow {
                passive.push(Finding::blank(
                    c.effect,
                    Status::NotTestable,
                    "not testable with closed-loop data: it shows only in the free run, and an autopilot corrected the real vehicle where the free-running model is not corrected".into(),
                    c.contained,
                ));
            }
        }
        self.remaining = all;
        self.passive = passive;
    }

    /// Up to `max_effects` catalog rounds ([`Session::catalog_round`]); they stop when
    /// nothing is left to test, nothing passes, or the model is consistent with the
    /// held-out data within its noise alone.
    pub(super) fn catalog_rounds(&mut self) -> Result<(), LabError> {
        for round in 1..=self.opts.max_effects.max(1) {
            if self.remaining.is_empty() || !self.catalog_round(round)? {
                break;
            }
        }
        Ok(())
    }

    /// One catalog round: screens `remaining` on the current model, confirms the
    /// shortlist, writes every candidate's latest card (`latest`) and accepts the best
    /// significant one ([`Session::accept_effect`]). `false` when the rounds are over.
    fn catalog_round(&mut self, round: usize) -> Result<bool, LabError> {
        let screened = self.g.screen(&self.remaining)?;
        self.note_screened(&screened, round);
        let top = self.shortlist(&screened, round);
        if top.is_empty() {
            return Ok(false);
        }
        let judged = self.g.confirm(&top, self.opts.confirm_iterations, false);
        for (c, j) in &judged {
            let Some(effect) = c.subject.effect() else {
                continue;
            };
            self.latest
                .insert(effect, effect_finding(c, j, &self.g.current, round));
        }
        let Some((best, bj)) = judged.first().filter(|(_, j)| j.significant) else {
            return Ok(false);
        };
        let Some(best_effect) = best.subject.effect() else {
            return Ok(false);
        };
        // Accepted: its fits are continued to convergence (`Greedy::polish`).
        let polished = top
            .iter()
            .find(|s| s.cand.effect == best_effect)
            .and_then(|s| self.g.polish(s, best, self.opts.confirm_iterations));
        let (best, bj) = match &polished {
            Some((c, j)) => {
                self.latest
                    .insert(best_effect, effect_finding(c, j, &self.g.current, round));
                (c, j)
            }
            None => (best, bj),
        };
        self.mark_ambiguous(best_effect, best, bj, &judged);
        self.accept_effect(best_effect, best, bj)?;
        // Consistent with the held-out data within its noise alone (no parameter spread:
        // the strictest form of the verdict's test): nothing is left to find.
        let zero = [0.0; crate::data::N_CHANNELS];
        Ok(!verdict::all_consistent(&verdict::test_channels(
            &self.g.current,
            self.val,
            &self.g.current_eval,
            &zero,
        )))
    }

    /// A "screened only" card for every screened candidate not evaluated before.
    fn note_screened(&mut self, screened: &[Screened], round: usize) {
        for s in screened {
            self.latest.entry(s.cand.effect).or_insert_with(|| {
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
    }

    /// The candidates confirmed this round: the best `confirm_first` (round 1) or
    /// `confirm_later` fast ones past the screening gates, the best slow one, and every
    /// one that was significant or ambiguous in an earlier round.
    fn shortlist<'s>(&self, screened: &'s [Screened], round: usize) -> Vec<&'s Screened> {
        let k = if round == 1 {
            self.opts.confirm_first
        } else {
            self.opts.confirm_later
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
        for s in screened {
            let was_sig = self
                .latest
                .get(&s.cand.effect)
                .is_some_and(|f| matches!(f.status, Status::Significant | Status::Ambiguous));
            if was_sig && !top.iter().any(|t| t.cand.effect == s.cand.effect) {
                top.push(s);
            }
        }
        top
    }

    /// Ambiguity: the other significant candidates of this round that score alike and
    /// change the held-out predictions of the best's channels the same way (cosine above
    /// [`AMBIGUITY_COSINE`], in noise floors of the current model) are marked ambiguous,
    /// and the best's card names them with the experiment that would separate them.
    fn mark_ambiguous(
        &mut self,
        best_effect: EffectId,
        best: &Confirmed,
        bj: &Judgement,
        judged: &[(Confirmed, Judgement)],
    ) {
        let noise: BTreeMap<ChannelKey, f64> = self
            .g
            .current_eval
            .channels
            .iter()
            .map(|(k, c)| (*k, c.noise))
            .collect();
        let mut amb = Vec::new();
        for (c, j) in judged.iter().skip(1) {
            if !j.significant || j.score < 0.7 * bj.score {
                continue;
            }
            let chans: Vec<ChannelKey> = bj.channels.clone();
            let da = prediction_change(&best.eval, &self.g.current_eval, &chans, &noise);
            let db = prediction_change(&c.eval, &self.g.current_eval, &chans, &noise);
            if cosine(&da, &db) > AMBIGUITY_COSINE
                && let Some(e) = c.subject.effect()
            {
                amb.push(e);
            }
        }
        if amb.is_empty() {
            return;
        }
        let names: Vec<String> = amb.iter().map(|e| e.key().to_string()).collect();
        let exps: Vec<String> = amb
            .iter()
            .map(|e| separating_experiment(best_effect, *e))
            .collect();
        if let Some(f) = self.latest.get_mut(&best_effect) {
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
            if let Some(f) = self.latest.get_mut(e) {
                f.status = Status::Ambiguous;
                f.significant = false;
                f.ambiguous_with = vec![best_effect.key().to_string()];
                f.separating_experiment = Some(separating_experiment(best_effect, *e));
            }
        }
    }

    /// Accepts a catalog effect: its card moves from `latest` to `findings`, the state
    /// before it goes to `history` (with the channels it traded), the greedy state takes
    /// it, the error fall gains a step, and it leaves `remaining`.
    fn accept_effect(
        &mut self,
        effect: EffectId,
        best: &Confirmed,
        bj: &Judgement,
    ) -> Result<(), LabError> {
        self.accepted.push(effect);
        if let Some(f) = self.latest.remove(&effect) {
            self.findings.push(f);
        }
        self.history.push(LastAccepted {
            effect,
            score: bj.score,
            before: self.g.snapshot(),
            traded: bj
                .conflict_channels
                .iter()
                .filter(|(_, t)| *t)
                .map(|(c, _)| c.clone())
                .collect(),
        });
        self.accept(best, format!("+ {}", effect.key()))?;
        self.remaining.retain(|c| c.effect != effect);
        Ok(())
    }
}
