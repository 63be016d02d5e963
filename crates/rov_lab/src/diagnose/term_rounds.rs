//! Step 8 of the diagnosis, the **term rounds**: while the verdict still finds a channel
//! inconsistent, search the term library on the current model's residual
//! ([`discovery`]), confirm the best pick of each DOF (and a near-equivalent runner-up)
//! on the held-out runs, and accept the best significant one.

use crate::LabError;

use super::session::Session;
use super::tested::VerdictTests;
use super::*;

/// Library terms whose residual force is a catalog effect's signature, per (DOF,
/// effect), in the order found: one note each ([`catalog_like_note`]).
type CatalogLike = Vec<((usize, &'static str), Vec<String>)>;

impl Session<'_> {
    /// Term rounds up to `max_terms` accepted terms (a replacement's term counts); they
    /// stop when the verdict's tests (`tests.last`) pass, or a round accepts nothing.
    /// Writes the term search's notes (`search_notes`).
    pub(super) fn term_rounds(&mut self, tests: &mut VerdictTests) -> Result<(), LabError> {
        let mut catalog_like: CatalogLike = Vec::new();
        for round in (self.accepted_terms.len() + 1)..=self.opts.max_terms {
            if verdict::all_consistent(&tests.last.tests)
                || !self.term_round(round, &mut catalog_like)?
            {
                break;
            }
            self.retest(tests)?;
        }
        self.search_notes.extend(
            catalog_like
                .iter()
                .map(|((dof, effect), forms)| catalog_like_note(*dof, effect, forms)),
        );
        Ok(())
    }

    /// One term round: searches the library on the current model (catalog-signature
    /// picks are noted in `catalog_like`), confirms the best pick of each DOF and its
    /// runner-up when it explains nearly as much (near-equivalent forms of the same
    /// residual: the held-out data decides), up to [`discovery::MAX_CONFIRM`], each
    /// vetoed on a structurally inadequate model; the best significant one is accepted
    /// (card in `findings`, the others' in `latest_terms`). `false` when none is.
    fn term_round(
        &mut self,
        round: usize,
        catalog_like: &mut CatalogLike,
    ) -> Result<bool, LabError> {
        let catalog: Vec<(EffectId, Vec<Param>)> = self
            .remaining
            .iter()
            .map(|c| (c.effect, c.params.clone()))
            .collect();
        let (picks, notes) = self.g.search_terms(&catalog, None)?;
        for (dof, formula, e) in &notes.catalog_like {
            let key = (*dof, e.key());
            match catalog_like.iter_mut().find(|(k, _)| *k == key) {
                Some((_, forms)) if forms.contains(formula) => {}
                Some((_, forms)) => forms.push(formula.clone()),
                None => catalog_like.push((key, vec![formula.clone()])),
            }
        }
        let mut top: Vec<&discovery::TermPick> = Vec::new();
        let mut runners_up = 0;
        for p in &picks {
            let same: Vec<&&discovery::TermPick> =
                top.iter().filter(|t| t.term.dof == p.term.dof).collect();
            // Every DOF's best pick is confirmed (a moment's own candidates are tested
            // before a term elsewhere is accepted), and near-equivalent runners-up up
            // to MAX_CONFIRM.
            let keep = match same.first() {
                None => true,
                Some(b) => {
                    same.len() < 2
                        && p.explained >= discovery::NEAR_TIE * b.explained
                        && runners_up < discovery::MAX_CONFIRM
                }
            };
            if keep {
                runners_up += usize::from(!same.is_empty());
                top.push(p);
            }
        }
        if top.is_empty() {
            return Ok(false);
        }
        let (g, iterations) = (&self.g, self.opts.confirm_iterations);
        let mut judged: Vec<(Confirmed, Judgement)> = par_map(top.len(), self.opts.threads, |i| {
            g.confirm_term(top[i], None, iterations)
        })
        .into_iter()
        .flatten()
        .collect();
        let inadequate = self.g.inadequacy();
        for (_, j) in &mut judged {
            veto_on_inadequate_base(j, inadequate.as_ref());
        }
        judged.sort_by(|a, b| {
            b.1.significant
                .cmp(&a.1.significant)
                .then(b.1.score.total_cmp(&a.1.score))
        });
        let mut best_term: Option<(Confirmed, Judgement)> = None;
        for (k, (c, j)) in judged.into_iter().enumerate() {
            let Subject::Term(t) = c.subject else {
                continue;
            };
            let pick = top
                .iter()
                .find(|p| p.term.dof == t.dof && p.term.kind == t.kind);
            let significant = j.significant && k == 0;
            let f = term_card(&c, &j, &self.g.current, round, pick.copied(), k > 0);
            if significant {
                self.findings.push(f);
                best_term = Some((c, j));
            } else {
                self.latest_terms.push(f);
            }
        }
        let Some((best, _)) = best_term else {
            return Ok(false);
        };
        let Subject::Term(t) = best.subject else {
            return Ok(false);
        };
        self.accepted_terms.push(t);
        let names = self.command_names();
        let names: Vec<&str> = names.iter().map(String::as_str).collect();
        self.accept(&best, format!("+ {}", t.id(&names)))?;
        Ok(true)
    }
}
