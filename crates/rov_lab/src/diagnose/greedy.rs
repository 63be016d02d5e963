//! The state of the greedy forward selection — the current model, its held-out
//! evaluation, the free parameters, the screening caches and the channel weights — with
//! its three steps (screen, confirm, accept). The diagnosis drives it over the catalog;
//! `lab add` drives the same steps over the effects it is given, so both reach the same
//! fit of the same effect on the same data.

use crate::LabError;
use crate::calibrate::{Calibration, SHOOTING_WINDOW_S, View};
use crate::data::Run;
use crate::evaluate::{Evaluation, evaluate};
use crate::model::LabModel;
use crate::params::{Param, axis_params_of};

use super::*;

/// The greedy selection's state.
pub(super) struct Greedy<'a> {
    pub(super) train: &'a [Run],
    pub(super) val: &'a [Run],
    /// The calibrated base (the screening's linearisation point).
    pub(super) calibrated: LabModel,
    pub(super) current: LabModel,
    pub(super) current_eval: Evaluation,
    pub(super) current_free: Vec<Param>,
    cache_short: ColumnCache,
    cache_shoot: ColumnCache,
    cache_free: ColumnCache,
    pub(super) scales: ViewScales,
    pub(super) closed_loop: bool,
    threads: usize,
}

impl<'a> Greedy<'a> {
    /// Starts from a calibration.
    pub(super) fn new(
        cal: &Calibration,
        train: &'a [Run],
        val: &'a [Run],
        closed_loop: bool,
        threads: usize,
    ) -> Result<Self, LabError> {
        let current = cal.model.clone();
        let current_eval = evaluate(&current, val)?;
        let scales = ViewScales::of_model(&current, train)?;
        Ok(Self {
            train,
            val,
            calibrated: current.clone(),
            current,
            current_eval,
            current_free: cal.params.clone(),
            cache_short: ColumnCache::new(),
            cache_shoot: ColumnCache::new(),
            cache_free: ColumnCache::new(),
            scales,
            closed_loop,
            threads,
        })
    }

    /// Screens candidates on the current model: the fast ones on the short horizon and in
    /// multiple shooting (each keeps the view where it explains more), the slow ones in
    /// the free run; ranked (ΔBIC above [`MIN_DBIC`] first, then by explained fraction).
    pub(super) fn screen(&mut self, cands: &[Candidate]) -> Result<Vec<Screened>, LabError> {
        let (slow, fast): (Vec<Candidate>, Vec<Candidate>) = cands
            .iter()
            .cloned()
            .partition(|c| primary_view(c.effect) == View::FreeRun);
        let short = screen(
            &self.current,
            self.train,
            &self.current_free,
            &fast,
            short_view(self.train),
            &self.scales.short,
            self.threads,
            &mut self.cache_short,
        )?;
        let long = screen(
            &self.current,
            self.train,
            &self.current_free,
            &fast,
            View::Shooting(SHOOTING_WINDOW_S),
            &self.scales.shoot,
            self.threads,
            &mut self.cache_shoot,
        )?;
        let mut screened: Vec<Screened> = Vec::new();
        for a in short {
            match long.iter().find(|b| b.cand.effect == a.cand.effect) {
                Some(b) if b.explained > a.explained => screened.push(b.clone()),
                _ => screened.push(a),
            }
        }
        for b in &long {
            if !screened.iter().any(|a| a.cand.effect == b.cand.effect) {
                screened.push(b.clone());
            }
        }
        // In the free run only the base parameters of the slow candidates' own axes are
        // refitted with them (see `confirm_stage1`), so only those are screened with them.
        let slow_base: Vec<Param> = {
            let mut own: Vec<Param> = Vec::new();
            for c in &slow {
                own.extend(axis_params_of(&home_channels(c.effect)));
            }
            self.current_free
                .iter()
                .copied()
                .filter(|p| own.contains(p))
                .collect()
        };
        screened.extend(screen(
            &self.current,
            self.train,
            &slow_base,
            &slow,
            View::FreeRun,
            &self.scales.free,
            self.threads,
            &mut self.cache_free,
        )?);
        screened.sort_by(|a, b| {
            (b.dbic > MIN_DBIC)
                .cmp(&(a.dbic > MIN_DBIC))
                .then(b.explained.total_cmp(&a.explained))
        });
        Ok(screened)
    }

    /// Confirms screened candidates: the first stage for all, the refinement for the most
    /// promising (by first-stage held-out score, and any close second; with `refine_all`,
    /// every one). Candidates not refined are not significant.
    pub(super) fn confirm(
        &self,
        top: &[&Screened],
        iterations: usize,
        refine_all: bool,
    ) -> Vec<(Confirmed, Judgement)> {
        let caches = Caches {
            short: &self.cache_short,
            shoot: &self.cache_shoot,
            free: &self.cache_free,
            scales: &self.scales,
            closed_loop: self.closed_loop,
        };
        let counter = crate::progress::Counter::start("confirming", top.len(), "candidates");
        let stage1: Vec<(Confirmed, Judgement)> = par_map(top.len(), self.threads, |i| {
            let _tick = super::screening::TickOnDrop(&counter);
            confirm_stage1(
                &self.current,
                &self.current_eval,
                self.train,
                self.val,
                &self.current_free,
                top[i],
                iterations,
                false,
                &caches,
            )
        })
        .into_iter()
        .flatten()
        .collect();
        let mut order: Vec<usize> = (0..stage1.len()).collect();
        order.sort_by(|a, b| stage1[*b].1.score.total_cmp(&stage1[*a].1.score));
        let lead = order.first().map_or(0.0, |i| stage1[*i].1.score);
        let to_refine: Vec<usize> = if refine_all {
            order.clone()
        } else {
            order
                .iter()
                .copied()
                .enumerate()
                .filter(|(rank, i)| {
                    let sc = stage1[*i].1.score;
                    sc > 0.0
                        && !stage1[*i].1.channels.is_empty()
                        && (*rank == 0 || sc >= 0.5 * lead)
                })
                .map(|(_, i)| i)
                .take(2)
                .collect()
        };
        let refined: Vec<Result<(Confirmed, Judgement), LabError>> =
            par_map(to_refine.len(), self.threads, |k| {
                let (c1, _) = &stage1[to_refine[k]];
                refine(
                    &self.current,
                    &self.current_eval,
                    self.train,
                    self.val,
                    c1,
                    c1.contained,
                    iterations,
                    false,
                    &self.scales,
                    self.closed_loop,
                )
            });
        let mut judged: Vec<(Confirmed, Judgement)> = Vec::new();
        let mut refined_ok: Vec<usize> = Vec::new();
        for (k, r) in refined.into_iter().enumerate() {
            if let Ok(x) = r {
                refined_ok.push(to_refine[k]);
                judged.push(x);
            }
        }
        for (i, (c, j)) in stage1.into_iter().enumerate() {
            if refined_ok.contains(&i) {
                continue;
            }
            let mut j = j;
            if j.significant {
                j.significant = false;
                j.reason = "weaker than the leading candidate in the first-stage fit".into();
            }
            judged.push((c, j));
        }
        judged.sort_by(|a, b| {
            b.1.significant
                .cmp(&a.1.significant)
                .then(b.1.score.total_cmp(&a.1.score))
        });
        judged
    }

    /// The confirmation of an accepted candidate again, with every fit (each stage-1
    /// start that the short confirmation tried, the settling, the refinement) continued
    /// to convergence ([`continued`]); `None` unless it fits the training runs at least
    /// as well as `accepted` (the same refinement objective) and stays significant. Paid
    /// only for accepted findings: their parameters are what the report states.
    pub(super) fn polish(
        &self,
        s: &Screened,
        accepted: &Confirmed,
        iterations: usize,
    ) -> Option<(Confirmed, Judgement)> {
        if !accepted.ran_out {
            // Every fit converged within the short budget: a longer one follows the same
            // path to the same result.
            return None;
        }
        let caches = Caches {
            short: &self.cache_short,
            shoot: &self.cache_shoot,
            free: &self.cache_free,
            scales: &self.scales,
            closed_loop: self.closed_loop,
        };
        let (c1, _) = confirm_stage1(
            &self.current,
            &self.current_eval,
            self.train,
            self.val,
            &self.current_free,
            s,
            iterations,
            true,
            &caches,
        )
        .ok()?;
        let (c, j) = refine(
            &self.current,
            &self.current_eval,
            self.train,
            self.val,
            &c1,
            c1.contained,
            iterations,
            true,
            &self.scales,
            self.closed_loop,
        )
        .ok()?;
        (j.significant && c.fit.cost <= accepted.fit.cost).then_some((c, j))
    }

    /// Confirms a discovered term on the current model (from `start` when given: the
    /// replacement test's short-horizon start), as the term rounds, the replacement test
    /// and `lab add --terms` do ([`discovery::confirm_term`]).
    pub(super) fn confirm_term(
        &self,
        pick: &discovery::TermPick,
        start: Option<&LabModel>,
        iterations: usize,
    ) -> Result<(Confirmed, Judgement), LabError> {
        discovery::confirm_term(
            start.unwrap_or(&self.current),
            &self.current_eval,
            self.train,
            self.val,
            &self.current_free,
            pick,
            iterations,
            &self.scales,
            self.closed_loop,
        )
    }

    /// The library's term picks on the current model's training residual
    /// ([`discovery::search`]): candidates of the DOFs `dofs` (all when `None`), with a
    /// catalog-signature filter over `catalog`.
    pub(super) fn search_terms(
        &self,
        catalog: &[(crate::catalog::EffectId, Vec<Param>)],
        dofs: Option<&[usize]>,
    ) -> Result<(Vec<discovery::TermPick>, discovery::SearchNotes), LabError> {
        discovery::search(
            &self.current,
            self.train,
            &self.current_free,
            catalog,
            &self.scales,
            &self.cache_shoot,
            self.threads,
            dofs,
        )
    }

    /// Whether the current model is structurally inadequate for the data
    /// ([`inadequacy`] of its held-out evaluation): then a finding that makes another
    /// excited channel clearly worse is refused ([`veto_on_inadequate_base`]).
    pub(super) fn inadequacy(&self) -> Option<Inadequacy> {
        inadequacy(&self.current_eval, self.closed_loop)
    }

    /// The state an [`Greedy::accept`] changes, to go back to ([`Greedy::restore`]).
    pub(super) fn snapshot(&self) -> Snapshot {
        Snapshot {
            current: self.current.clone(),
            current_eval: self.current_eval.clone(),
            current_free: self.current_free.clone(),
            scales: self.scales,
        }
    }

    /// Goes back to a [`Greedy::snapshot`] (undoes the acceptances since).
    pub(super) fn restore(&mut self, s: Snapshot) {
        self.current = s.current;
        self.current_eval = s.current_eval;
        self.current_free = s.current_free;
        self.rescale(s.scales);
    }

    /// Makes a confirmed candidate part of the model and reweights for the next round.
    pub(super) fn accept(&mut self, c: &Confirmed) -> Result<(), LabError> {
        for p in &c.params {
            if !self.current_free.contains(p) {
                self.current_free.push(*p);
            }
        }
        self.current = c.fit.model.clone();
        self.current_eval = c.eval.clone();
        let new_scales = ViewScales::of_model(&self.current, self.train)?;
        self.rescale(new_scales);
        Ok(())
    }

    /// Moves the screening caches and the weights to new channel scales.
    fn rescale(&mut self, new_scales: ViewScales) {
        for (cache, view) in [
            (&mut self.cache_short, short_view(self.train)),
            (&mut self.cache_shoot, View::Shooting(SHOOTING_WINDOW_S)),
            (&mut self.cache_free, View::FreeRun),
        ] {
            rescale_cache(
                cache,
                &self.calibrated,
                self.train,
                view,
                self.scales.of(view),
                new_scales.of(view),
            );
        }
        self.scales = new_scales;
    }
}

/// The part of the greedy state an acceptance changes.
#[derive(Clone)]
pub(super) struct Snapshot {
    current: LabModel,
    current_eval: Evaluation,
    current_free: Vec<Param>,
    scales: ViewScales,
}
