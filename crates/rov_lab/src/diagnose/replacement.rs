//! A catalog effect against the library's terms of its own DOFs, as a replacement.
//!
//! The term search normally runs on top of the accepted effects, so it can only add to
//! them. An outside-catalog force that is nearly proportional to a catalog effect's
//! signature on the training data (a yaw moment ∝ w|w| against the vertical thruster's
//! reaction torque: in steady heave w|w| follows the vertical thrust) is then taken by
//! the catalog effect, with a parameter far from its usual range, and the term search
//! finds only scraps. So when the last accepted catalog effect leaves one of its own
//! home channels inconsistent with the held-out data (the verdict's test), the library
//! terms of those channels' DOFs are searched and confirmed on the model *without* that
//! effect, exactly as an addition would be, and the held-out score of the best term is
//! compared with the effect's own (both judged against the same model): the data's
//! preference decides which is kept, and the report names the other as the alternative.
//! Nothing of this runs unless that situation occurs.

use crate::LabError;
use crate::catalog::EffectId;
use crate::data::Run;
use crate::params::Param;
use crate::terms::Term;
use crate::verdict::ChannelTest;

use super::greedy::{Greedy, Snapshot};
use super::session::Session;
use super::tested::VerdictTests;
use super::*;

/// The last catalog effect the greedy loop accepted, with the state before it.
pub(super) struct LastAccepted {
    pub(super) effect: EffectId,
    /// Its held-out score against the model before it ([`judge`]).
    pub(super) score: f64,
    pub(super) before: Snapshot,
    /// Excited channels it made worse in the multiple-shooting view beyond rule (b)'s
    /// tolerance (`Judgement::conflict_channels`).
    pub(super) traded: Vec<String>,
}

/// What the comparison decided.
pub(super) enum Outcome {
    /// The term replaces the effect; the greedy state is the model before the effect
    /// plus the term.
    Replaced {
        term: Term,
        /// The term's evidence card.
        card: Finding,
        /// Why, for the effect's card.
        why: String,
    },
    /// The effect stays (the greedy state is unchanged); `card` is the best term's card
    /// (not significant), `why` for the effect's card.
    Kept { card: Option<Finding>, why: String },
}

/// The DOF whose force a channel shows first (the inverse of `term_home`).
fn dof_of(ch: Channel) -> usize {
    use Channel::*;
    match ch {
        Surge | North | East => 0,
        Sway => 1,
        Depth | Heave => 2,
        Roll | RollRate => 3,
        Pitch | PitchRate => 4,
        Heading | YawRate => 5,
    }
}

impl Session<'_> {
    /// Step 6, **replacement**: when term search is on and the last accepted catalog
    /// effect leaves one of its home channels inconsistent in the verdict's tests
    /// (`tests.last`), its DOFs' library terms are confirmed on the model without it
    /// (module docs). A term the held-out data prefers replaces it (in `accepted`,
    /// `findings`, the error fall and the greedy state; `replaced` is set and the tests
    /// are taken again); otherwise the effect's card says why it is kept and the best
    /// term's card goes to `latest_terms`.
    pub(super) fn try_replacement(&mut self, tests: &mut VerdictTests) -> Result<(), LabError> {
        if self.opts.max_terms == 0 {
            return Ok(());
        }
        // Out of `history` while the test changes the session; back in whatever it says.
        let Some(last) = self.history.pop() else {
            return Ok(());
        };
        let outcome = self.replacement_for(&last, &tests.last.tests);
        self.history.push(last);
        let Some(last) = self.history.last() else {
            return Ok(());
        };
        let (effect, key) = (last.effect, last.effect.key());
        match outcome? {
            None => {}
            Some(Outcome::Kept { card, why }) => {
                if let Some(f) = self.findings.iter_mut().find(|f| f.effect == key) {
                    f.explanation = format!("{} — {why}", f.explanation);
                }
                self.latest_terms.extend(card);
            }
            Some(Outcome::Replaced { term, card, why }) => {
                self.replaced = true;
                self.accepted.retain(|e| *e != effect);
                if let Some(i) = self.findings.iter().position(|f| f.effect == key) {
                    let mut f = self.findings.remove(i);
                    f.significant = false;
                    f.status = Status::NotSignificant;
                    f.explanation =
                        format!("not significant: replaced — {why} ({})", f.explanation);
                    self.latest_terms.push(f);
                }
                self.error_fall.pop();
                let names = self.command_names();
                let names: Vec<&str> = names.iter().map(String::as_str).collect();
                self.error_fall.push((
                    format!("+ {}", term.id(&names)),
                    rmse_map(&self.g.current_eval),
                ));
                self.accepted_terms.push(term);
                self.findings.push(card);
                self.retest(tests)?;
            }
        }
        Ok(())
    }

    /// Tests the library terms of the DOFs of `last`'s inconsistent home channels (in
    /// `tests`) as a replacement for it (module docs). `None` when its home channels are
    /// consistent or no term could be confirmed; the greedy state is then as it was.
    fn replacement_for(
        &mut self,
        last: &LastAccepted,
        tests: &[ChannelTest],
    ) -> Result<Option<Outcome>, LabError> {
        let (train, opts, round) = (self.train, self.opts, self.accepted.len());
        let home = last.effect.home_channels();
        let mut dofs: Vec<usize> = Vec::new();
        for t in tests.iter().filter(|t| !t.consistent) {
            if let Some(ch) = home.iter().find(|c| crate::data::ch_name(**c) == t.channel) {
                let d = dof_of(*ch);
                if !dofs.contains(&d) {
                    dofs.push(d);
                }
            }
        }
        if dofs.is_empty() {
            return Ok(None);
        }
        let after = self.g.snapshot();
        self.g.restore(last.before.clone());
        // The catalog-signature filter keeps every other candidate (a term that is another
        // catalog effect's signature is that effect); the effect under test is left out:
        // its own signature is what the terms are compared with here.
        let catalog: Vec<(EffectId, Vec<Param>)> = self
            .remaining
            .iter()
            .filter(|c| c.effect != last.effect)
            .map(|c| (c.effect, c.params.clone()))
            .collect();
        let (picks, _) = self.g.search_terms(&catalog, Some(&dofs))?;
        let top: Vec<&discovery::TermPick> = picks.iter().take(discovery::MAX_CONFIRM).collect();
        if top.is_empty() {
            self.g.restore(after);
            return Ok(None);
        }
        let inadequate = self.g.inadequacy();
        // Each term's coefficient is first fitted alone on the short horizon, where the
        // misfit the effect took is still small and smooth (a heading missed by 80° over a
        // 10 s window is neither): the start of its confirmation.
        let g = &self.g;
        let started: Vec<(discovery::TermPick, LabModel)> = par_map(top.len(), opts.threads, |i| {
            short_start(g, train, top[i], opts.confirm_iterations)
        });
        let top: Vec<&discovery::TermPick> = started.iter().map(|(p, _)| p).collect();
        let mut judged: Vec<(Confirmed, Judgement, usize)> =
            par_map(top.len(), opts.threads, |i| {
                g.confirm_term(top[i], Some(&started[i].1), opts.confirm_iterations)
                    .map(|(c, j)| (c, j, i))
            })
            .into_iter()
            .flatten()
            .collect();
        for (_, j, _) in &mut judged {
            veto_on_inadequate_base(j, inadequate.as_ref());
        }
        // A term is a candidate replacement when it is significant, scores higher on the
        // held-out runs than the effect, and brings the home channels the effect left
        // inconsistent within the verdict's distance limit ([`crate::verdict::MAX_RATIO`]
        // noise floors): a term that leaves the same misfit is the effect's own form over
        // again (the vertical command on yaw against a propeller torque).
        let fixes_home = |c: &Confirmed| {
            tests
                .iter()
                .filter(|t| {
                    !t.consistent && home.iter().any(|h| crate::data::ch_name(*h) == t.channel)
                })
                .all(|t| {
                    c.eval.channels.iter().any(|(k, ce)| {
                        k.name() == t.channel
                            && ce.shooting.rmse <= crate::verdict::MAX_RATIO * ce.noise
                    })
                })
        };
        let mut judged: Vec<(Confirmed, Judgement, usize, bool)> = judged
            .into_iter()
            .map(|(c, j, i)| {
                let ok = j.significant && j.score > last.score && fixes_home(&c);
                (c, j, i, ok)
            })
            .collect();
        judged.sort_by(|a, b| {
            b.3.cmp(&a.3)
                .then(b.1.significant.cmp(&a.1.significant))
                .then(b.1.score.total_cmp(&a.1.score))
        });
        let Some((c, j, i, preferred)) = judged.into_iter().next() else {
            self.g.restore(after);
            return Ok(None);
        };
        let Subject::Term(t) = c.subject else {
            self.g.restore(after);
            return Ok(None);
        };
        let names = self.g.current.command_names();
        let id = t.id(&names);
        let formula = format!(
            "{} ∝ {}",
            crate::terms::DOF_FORCE
                .get(t.dof as usize)
                .copied()
                .unwrap_or("force"),
            t.kind.formula(&names)
        );
        let both = format!(
            "{} or a {formula}: tested as alternatives on the same model, the held-out data prefers",
            last.effect.key()
        );

        let mut card = term_card(&c, &j, &self.g.current, round, top.get(i).copied(), false);
        if preferred {
            let why = format!(
                "{both} the term (held-out score {:.1} against {:.1}; it brings {} within {} noise floors, which {} left inconsistent)",
                j.score,
                last.score,
                home_names(home, tests),
                crate::verdict::MAX_RATIO,
                last.effect.key()
            );
            card.explanation = format!(
                "{} — a replacement for {}: {why}",
                card.explanation,
                last.effect.key()
            );
            self.g.accept(&c)?;
            Ok(Some(Outcome::Replaced { term: t, card, why }))
        } else {
            self.g.restore(after);
            let why = if j.significant && j.score > last.score {
                format!(
                    "{both} neither clearly: {id} scores {:.1} against {:.1} but leaves {} as far from the noise as the catalog effect does, so the catalog effect is kept",
                    j.score,
                    last.score,
                    home_names(home, tests)
                )
            } else {
                format!(
                    "{both} the catalog effect (held-out score {:.1} against {:.1} for {id}{})",
                    last.score,
                    j.score,
                    if j.significant {
                        String::new()
                    } else {
                        format!(", which is not significant: {}", j.reason)
                    }
                )
            };
            card.significant = false;
            card.status = Status::NotSignificant;
            if j.significant {
                card.explanation = format!(
                    "not significant: an alternative to {}, and weaker — {why} ({})",
                    last.effect.key(),
                    card.explanation
                );
            }
            Ok(Some(Outcome::Kept {
                card: Some(card),
                why,
            }))
        }
    }
}

/// A pick whose coefficient is fitted on the short horizon from its linearised estimate,
/// with the base parameters of its own axes, and the base with those parameters there:
/// the start of its confirmation (the pick and the base as they are when that fails).
fn short_start(
    g: &Greedy<'_>,
    train: &[Run],
    pick: &discovery::TermPick,
    iterations: usize,
) -> (discovery::TermPick, LabModel) {
    let mut m = g.current.clone();
    let idx = m.add_term(Term {
        coef: 0.0,
        ..pick.term
    });
    let p = Param::TermCoef(idx as u8, pick.term.rotational());
    let view = short_view(train);
    let cs = candidate_scales(&term_home(pick.term.dof), g.scales.of(view));
    let opts = crate::lm::LmOptions {
        max_iter: iterations * 2,
        threads: 1,
        ..Default::default()
    };
    // With the base parameters of the term's own axes: the calibration may have bent
    // them towards the missing force (a yaw damping near zero).
    let own = crate::params::axis_params_of(&term_home(pick.term.dof));
    let mut free = vec![p];
    free.extend(g.current_free.iter().copied().filter(|q| own.contains(q)));
    let fit = m
        .with(&[p], &[pick.term.coef * pick.term.scale])
        .ok()
        .and_then(|m0| {
            crate::calibrate::fit_scaled(&m0, train, &free, view, None, None, &opts, None, &cs)
                .map(crate::calibrate::Calibration::lean)
                .ok()
        });
    let fitted = fit
        .as_ref()
        .and_then(|f| f.model.terms().get(idx).map(|t| t.coef))
        .filter(|c| c.is_finite());
    // The base with those axis parameters where the short fit put them.
    let base = fit.as_ref().and_then(|f| {
        let qs: Vec<Param> = free.iter().copied().filter(|q| *q != p).collect();
        let vs: Option<Vec<f64>> = qs.iter().map(|q| f.model.get(*q)).collect();
        g.current.with(&qs, &vs?).ok()
    });
    let mut out = pick.clone();
    match (fitted, base) {
        (Some(c), Some(b)) => {
            out.term.coef = c;
            (out, b)
        }
        _ => (out, g.current.clone()),
    }
}

/// The home channels a test left inconsistent, "heading, yaw_rate".
fn home_names(home: &[Channel], tests: &[ChannelTest]) -> String {
    tests
        .iter()
        .filter(|t| !t.consistent && home.iter().any(|h| crate::data::ch_name(*h) == t.channel))
        .map(|t| t.channel.clone())
        .collect::<Vec<_>>()
        .join(", ")
}
