//! Physics outside the catalog: sparse regression of the residual generalised force on a
//! library of physically meaningful terms, each pick confirmed in simulation on the
//! held-out runs like a catalog effect.
//!
//! 1. **Equation error.** On the training runs, the state at every sample is the
//!    measurement where one exists (depth, attitude, measured rates and velocities; rates
//!    the sensors do not give directly come from the slope of a local quadratic fit over
//!    ±[`SLOPE_HALF_WINDOW_S`] through the inverted attitude kinematics) and the
//!    calibrated model's own multiple-shooting trajectory elsewhere (surge and sway
//!    without a velocity sensor). Over windows of [`WINDOW_S`] (half overlapping, away
//!    from command steps, where the local fit smooths a step in acceleration) the weak
//!    form of the equations of motion compares the measured change of each observable
//!    velocity with the change the model predicts (its acceleration integrated by the
//!    trapezoid rule with the command held), and turns the difference into a mean
//!    residual generalised force per window (× the DOF's effective inertia). The weak
//!    form needs first derivatives of the measurements only, never second ones
//!    (modellab.md §1.2).
//! 2. **Shortlist.** Per DOF, the residual force is regressed on the base parameters'
//!    sensitivities (always in: the null is "base refit") plus library terms chosen by
//!    forward selection (normalised columns, effective-sample ΔBIC above [`MIN_DBIC`], at
//!    most [`MAX_TERMS_PER_DOF`]); a block bootstrap of the selection (E-SINDy) keeps the
//!    stable picks (inclusion ≥ [`MIN_INCLUSION`]), and the [`SHORTLIST_PER_DOF`] terms
//!    that explain most of the residual alone join them. The equation error is noisy
//!    (rates differentiated from 20 Hz sensors), so it shortlists; it does not decide.
//! 3. **Not a catalog effect in disguise.** A term whose column (base projected out) has
//!    a cosine above [`CATALOG_COSINE`] with the equation-error signature of a catalog
//!    candidate *whose catalog home covers the term's DOF* is that effect's signature,
//!    reported under the effect, not as a new term. An effect whose home lies elsewhere
//!    does not shadow a DOF's own terms: its column there is a side effect (a thrust
//!    change's pitch moment through the thrusters' arm); a missing pitch moment ∝ u|u|
//!    was lost to the refused power limit that way (issue 26 §3a).
//! 4. **Simulation screening.** Each shortlisted term's sensitivity in simulation error
//!    (multiple shooting on the training runs, its DOF's channels at noise weight), with
//!    the base parameters' sensitivities projected out, gives its linearised gain and
//!    ΔBIC; the best of each DOF go on first, ranked by the share of the residual they
//!    explain. The screening gates are per DOF (a share of the DOF's own best, not of
//!    the best anywhere), and the term rounds confirm every DOF's best pick: each
//!    moment's own candidates are tested before a term elsewhere is accepted.
//! 5. **Confirmation.** Each surviving term is added to the model and fitted jointly with
//!    the base parameters in simulation error (multiple shooting), then judged on the
//!    held-out runs exactly like a catalog effect ([`judge`]: both views, the own-term
//!    control, no channel made worse, ΔBIC), and its coefficient must be physically
//!    plausible: the force at the term's typical size no more than the thrusters' own
//!    capability on that DOF.

use nalgebra::{DMatrix, DVector};
use rov_dynamics::Vector6;
use rov_dynamics::models::{Channel, ModelState};
use rov_dynamics::process::CurrentSample;

use crate::LabError;
use crate::calibrate::{Objective, View, effective_n, fit_scaled};
use crate::catalog::EffectId;
use crate::data::{Run, ch_index, local_quadratic};
use crate::evaluate::{Evaluation, evaluate};
use crate::lm::LmOptions;
use crate::model::LabModel;
use crate::params::Param;
use crate::sim::{SampleState, simulate_states};
use crate::terms::{DOF_FORCE, DOF_NAMES, Sig, Term, TermInputs, TermKind, library};

use super::*;

mod confirm;
mod equation_error;
mod regression;

pub(super) use confirm::{confirm_term, explain_term, regress_one, resemblance};
use equation_error::*;
use regression::*;

/// Length of an equation-error window, s.
pub const WINDOW_S: f64 = 2.5;
/// Half-width of the local fit that gives a rate from an angle or a depth, s.
pub const SLOPE_HALF_WINDOW_S: f64 = 0.5;
/// Most terms selected per DOF in one search.
pub const MAX_TERMS_PER_DOF: usize = 2;
/// Bootstrap resamples of the selection.
pub const BOOTSTRAP: usize = 30;
/// Smallest inclusion probability of a term that goes on to confirmation (E-SINDy's 0.6).
pub const MIN_INCLUSION: f64 = 0.6;
/// Cosine above which a term's signature is a catalog effect's.
pub const CATALOG_COSINE: f64 = 0.9;
/// A runner-up on the same DOF is confirmed too when it explains at least this share of
/// what the DOF's best pick explains.
pub const NEAR_TIE: f64 = 0.9;
/// Most runners-up confirmed per search round (the best pick of every DOF is always
/// confirmed).
pub const MAX_CONFIRM: usize = 3;

/// The DOFs whose own quadratic drag the base calibrates (`Param::DragQuad` free): not
/// library terms there.
pub(super) fn quad_calibrated(base_free: &[Param]) -> [bool; 6] {
    let mut out = [false; 6];
    for p in base_free {
        if let Param::DragQuad(a) = p
            && let Some(o) = out.get_mut(a.index())
        {
            *o = true;
        }
    }
    out
}

/// The equation-error data of one DOF.
pub(super) struct DofData {
    pub(super) dof: usize,
    /// Mean residual force per window (N or N m).
    pub(super) y: Vec<f64>,
    /// Base-parameter sensitivities of the same (columns).
    pub(super) base: Vec<Vec<f64>>,
    /// Library columns: mean regressor per window.
    pub(super) lib: Vec<(TermKind, Vec<f64>)>,
    /// Catalog candidates' signatures: (effect, column).
    pub(super) catalog: Vec<(EffectId, Vec<f64>)>,
    /// Window → run index (bootstrap blocks).
    pub(super) block: Vec<usize>,
}

/// A term that survived the regression.
#[derive(Debug, Clone)]
pub(super) struct TermPick {
    pub(super) term: Term,
    /// Share of the DOF's residual force variance it explains (after the base refit).
    pub(super) explained: f64,
    pub(super) dbic: f64,
    pub(super) inclusion: f64,
}

/// What the search reports besides its picks.
#[derive(Debug, Clone, Default)]
pub(super) struct SearchNotes {
    /// Library picks that are a catalog effect's signature: (DOF, formula, effect).
    pub(super) catalog_like: Vec<(usize, String, EffectId)>,
}

/// Searches the library for terms that explain the residual generalised force of the
/// current model on the training runs (on the DOFs `dofs` only, when given).
#[allow(clippy::too_many_arguments)]
pub(super) fn search(
    model: &LabModel,
    train: &[Run],
    base_free: &[Param],
    catalog: &[(EffectId, Vec<Param>)],
    scales: &ViewScales,
    base_cols: &ColumnCache,
    threads: usize,
    dofs: Option<&[usize]>,
) -> Result<(Vec<TermPick>, SearchNotes), LabError> {
    let fixed = crate::verdict::fixed_uncertain(model, base_free);
    let (data, _) = equation_error(model, train, base_free, catalog)?;
    let names = model.command_names();
    let mut notes = SearchNotes::default();
    // Stage 1: the shortlist from the equation error.
    let mut shortlist: Vec<(Term, f64)> = Vec::new();
    for d in &data {
        let n = d.y.len();
        if n < 30 || dofs.is_some_and(|ds| !ds.contains(&d.dof)) {
            continue;
        }
        let all: Vec<usize> = (0..n).collect();
        // Effective sample size of the null residual (overlapping windows, coloured noise).
        let base_refs: Vec<&Vec<f64>> = d.base.iter().collect();
        let (r0, _) = ls(&d.y, &base_refs);
        let r0n = rss(&r0);
        if r0n <= 0.0 {
            continue;
        }
        let ratio = effective_n(&r0, n) / n as f64;
        let lib0: Vec<Vec<f64>> = d.lib.iter().map(|(_, c)| ls(c, &base_refs).0).collect();
        let sel = forward_select(&r0, &lib0, &all, ratio);
        let inclusion = bootstrap_inclusion(d, &r0, &lib0, ratio);
        // Single-term explained shares (base projected out), best first.
        let mut single: Vec<(usize, f64)> = lib0
            .iter()
            .enumerate()
            .map(|(i, c)| (i, 1.0 - rss(&ls(&r0, &[c]).0) / r0n))
            .filter(|(_, e)| e.is_finite() && *e > 0.0)
            .collect();
        single.sort_by(|a, b| b.1.total_cmp(&a.1));
        let mut chosen: Vec<usize> = sel
            .iter()
            .filter(|(i, _)| inclusion.get(*i).copied().unwrap_or(0.0) >= MIN_INCLUSION)
            .map(|(i, _)| *i)
            .collect();
        for (i, _) in single.iter().take(SHORTLIST_PER_DOF) {
            if !chosen.contains(i) {
                chosen.push(*i);
            }
        }
        for i in chosen {
            let Some((kind, col)) = d.lib.get(i) else {
                continue;
            };
            // A catalog effect's signature in disguise? Only an effect whose signature
            // lives on this DOF's channels (its catalog home) can stand for a term here:
            // elsewhere its column is a side effect (a thrust change's pitch moment
            // through the thrusters' arm), and a moment of the DOF's own would be lost
            // to an effect the catalog rounds already refused.
            let lc = &lib0[i];
            let dof_home = super::term_home(d.dof as u8);
            let catalog_like = d
                .catalog
                .iter()
                .filter(|(e, _)| e.home_channels().iter().any(|c| dof_home.contains(c)))
                .filter(|(_, cc)| {
                    super::judging::cosine(lc, &ls(cc, &base_refs).0).abs() > CATALOG_COSINE
                })
                .map(|(e, _)| *e)
                .next();
            if let Some(e) = catalog_like {
                notes.catalog_like.push((d.dof, kind.formula(&names), e));
                continue;
            }
            let rms = (col.iter().map(|x| x * x).sum::<f64>() / col.len().max(1) as f64).sqrt();
            if rms > 0.0 && rms.is_finite() {
                shortlist.push((
                    Term {
                        dof: d.dof as u8,
                        kind: *kind,
                        coef: 0.0,
                        scale: rms,
                    },
                    inclusion.get(i).copied().unwrap_or(0.0),
                ));
            }
        }
    }
    // Stage 2: each shortlisted term's linearised gain in simulation error (multiple
    // shooting on the training runs, the term's home channels at noise weight), with the
    // base parameters' sensitivities projected out (a term the base can mimic gains
    // nothing).
    let view = View::Shooting(crate::calibrate::SHOOTING_WINDOW_S);
    // Sensitivity columns of the fixed base parameters in the screening's weights (the
    // calibrated ones are cached from the catalog's screening).
    let fixed_cols: Vec<Option<Vec<f64>>> = if fixed.is_empty() || shortlist.is_empty() {
        Vec::new()
    } else {
        let obj = Objective::scaled(model, train, view, scales.of(view));
        let r0 = obj.residuals(model)?;
        let steps: Vec<f64> = fixed.iter().map(|p| p.meta().scale).collect();
        jacobian_cols(
            "term search: base",
            model,
            &obj,
            &r0,
            &fixed,
            &steps,
            threads,
        )
    };
    // (DOF, residual, residual with the base projected out, its N_eff, base columns).
    // The null every term must beat is a refit of the base: the calibrated parameters
    // freely, and the ones the calibration keeps fixed within their documented
    // uncertainty (an added mass or a drag the data shows to be off by its documented σ
    // is a base parameter, not new physics): a ridge fit with the fixed parameters'
    // prior information.
    let fixed_lambda: Vec<f64> = fixed
        .iter()
        .zip(&fixed_cols)
        .filter(|(_, c)| c.is_some())
        .map(|(p, _)| match model.prior_of(*p) {
            Some((_, sd)) if sd > 0.0 => 1.0 / (sd * sd),
            _ => 0.0,
        })
        .collect();
    let n_free_cols = base_free
        .iter()
        .filter(|p| base_cols.contains_key(p))
        .count();
    let lambda: Vec<f64> = std::iter::repeat_n(0.0, n_free_cols)
        .chain(fixed_lambda.iter().copied())
        .collect();
    // The base's sensitivity columns, borrowed from the screening's cache and shared by
    // every DOF's null fit (each DOF weighs the rows by its own factors, applied on the
    // fly: a weighted copy per DOF of a whole dive's columns was most of a long
    // diagnosis's memory).
    let n_rows = Objective::scaled(model, train, view, scales.of(view))
        .residuals(model)?
        .len();
    let fixed_cached: Vec<Vec<f32>> = fixed_cols
        .iter()
        .flatten()
        .map(|c| super::screening::to_cache(c))
        .collect();
    let base: Vec<&[f32]> = base_free
        .iter()
        .filter_map(|p| base_cols.get(p))
        .chain(fixed_cached.iter())
        .filter(|c| c.len() == n_rows)
        .map(Vec::as_slice)
        .collect();
    type Home = (u8, Vec<f64>, Vec<f64>, f64, NullFit);
    let mut homes: Vec<Home> = Vec::new();
    for dof in shortlist.iter().map(|(t, _)| t.dof) {
        if homes.iter().any(|(d, ..)| *d == dof) {
            continue;
        }
        let cs = candidate_scales(&term_home(dof), scales.of(view));
        let r0 = Objective::scaled(model, train, view, &cs).residuals(model)?;
        let f = crate::calibrate::row_factors(model, train, view, scales.of(view), &cs)
            .filter(|f| f.len() == n_rows);
        let null = if r0.len() == n_rows {
            NullFit::new(&base, f, &lambda, threads)
        } else {
            NullFit::none()
        };
        let r0p = null.residual(&base, &r0);
        let n_eff = effective_n(&r0p, r0p.len().max(2));
        homes.push((dof, r0, r0p, n_eff, null));
    }
    let dofs: Vec<&str> = homes
        .iter()
        .filter_map(|(d, ..)| crate::terms::DOF_NAMES.get(*d as usize).copied())
        .collect();
    let counter = crate::progress::Counter::start(
        format!("term search: {}", dofs.join(", ")),
        shortlist.len(),
        "terms",
    );
    let gains: Vec<Option<TermPick>> = par_map(shortlist.len(), threads, |i| {
        let _tick = super::screening::TickOnDrop(&counter);
        let (t, inclusion) = &shortlist[i];
        let (_, raw, r0, n_eff, null) = homes.iter().find(|(d, ..)| *d == t.dof)?;
        let mut m = model.clone();
        let idx = m.add_term(*t);
        let p = Param::TermCoef(idx as u8, t.rotational());
        let step = p.meta().scale;
        let m1 = m.with(&[p], &[step]).ok()?;
        let cs = candidate_scales(&term_home(t.dof), scales.of(view));
        let r1 = Objective::scaled(model, train, view, &cs)
            .residuals(&m1)
            .ok()?;
        if r1.len() != raw.len() {
            return None;
        }
        let c: Vec<f64> = r1.iter().zip(raw).map(|(a, b)| (a - b) / step).collect();
        let c = null.residual(&base, &c);
        let cc: f64 = c.iter().map(|x| x * x).sum();
        let cr: f64 = c.iter().zip(r0).map(|(a, b)| a * b).sum();
        let cost0 = rss(r0);
        if cc <= 0.0 || cost0 <= 0.0 {
            return None;
        }
        let cost1 = (cost0 - cr * cr / cc).max(1e-300);
        let dbic = n_eff * (cost0 / cost1).ln() - n_eff.max(2.0).ln();
        let value = -cr / cc;
        (dbic > MIN_DBIC && value.is_finite()).then(|| TermPick {
            term: Term {
                coef: value / t.scale,
                ..*t
            },
            explained: 1.0 - cost1 / cost0,
            dbic,
            inclusion: *inclusion,
        })
    });
    // Best first by the share of the home-weighted residual each explains (ΔBIC grows
    // with a DOF's sample count and would rank every pick of a well-sampled DOF above
    // the best of another); one pick per DOF first, then the runners-up.
    let mut picks: Vec<TermPick> = gains.into_iter().flatten().collect();
    picks.sort_by(|a, b| b.explained.total_cmp(&a.explained));
    // Only terms that explain a real share, and a fair part of what the best of their
    // own DOF explains, go on to confirmation (the catalog's screening gates, per DOF:
    // a moment of one DOF is not screened out because another DOF's residual is larger
    // or easier to explain; each DOF's own candidates are tested).
    let mut best = [0.0f64; 6];
    for p in &picks {
        if let Some(b) = best.get_mut(p.term.dof as usize) {
            *b = b.max(p.explained);
        }
    }
    picks.retain(|p| {
        let b = best.get(p.term.dof as usize).copied().unwrap_or(0.0);
        p.explained >= MIN_SCREEN_EXPLAINED && p.explained >= RELATIVE_SCREEN_GATE * b
    });
    let mut firsts: Vec<TermPick> = Vec::new();
    let mut rest: Vec<TermPick> = Vec::new();
    for p in picks {
        if firsts.iter().any(|f| f.term.dof == p.term.dof) {
            rest.push(p);
        } else {
            firsts.push(p);
        }
    }
    firsts.extend(rest);
    Ok((firsts, notes))
}

/// The null fit of the simulation screening: least squares on base sensitivity columns,
/// with a ridge λ_i on column i (0 for a calibrated parameter, the documented prior's
/// information 1/σ² for a fixed one).
struct NullFit {
    /// The DOF's row factors on the shared base columns B (`None`: rows as they are).
    rows: Option<Vec<f64>>,
    /// (BᵀB + Λ)⁻¹ of the row-weighted columns, `None` when there are no columns or the
    /// system is singular.
    inv: Option<DMatrix<f64>>,
}

impl NullFit {
    /// No null fit (a residual stays as it is).
    fn none() -> Self {
        NullFit {
            rows: None,
            inv: None,
        }
    }

    /// The ridge fit on the columns `b` (each n long) with rows weighted by `rows`; the
    /// Gram matrix is summed column pair by column pair (no copy of the columns).
    fn new(b: &[&[f32]], rows: Option<Vec<f64>>, lambda: &[f64], threads: usize) -> Self {
        let p = b.len();
        if p == 0 {
            return Self::none();
        }
        let w2: Option<Vec<f64>> = rows.as_ref().map(|f| f.iter().map(|k| k * k).collect());
        let gram_row = |j: usize| -> Vec<f64> {
            (0..p)
                .map(|k| {
                    if k < j {
                        return 0.0;
                    }
                    match &w2 {
                        Some(w) => b[j]
                            .iter()
                            .zip(b[k].iter())
                            .zip(w)
                            .map(|((x, y), w)| f64::from(*x) * f64::from(*y) * w)
                            .sum(),
                        None => b[j]
                            .iter()
                            .zip(b[k].iter())
                            .map(|(x, y)| f64::from(*x) * f64::from(*y))
                            .sum(),
                    }
                })
                .collect()
        };
        let upper = par_map(p, threads, gram_row);
        let mut a = DMatrix::from_fn(p, p, |j, k| if k >= j { upper[j][k] } else { upper[k][j] });
        let maxd = (0..p).map(|i| a[(i, i)]).fold(0.0f64, f64::max).max(1e-300);
        for i in 0..p {
            a[(i, i)] += 1e-9 * maxd + lambda.get(i).copied().unwrap_or(0.0);
        }
        NullFit {
            rows,
            inv: a.try_inverse(),
        }
    }

    /// v minus its null fit on the columns `b` (those `new` was given).
    fn residual(&self, b: &[&[f32]], v: &[f64]) -> Vec<f64> {
        let Some(inv) = &self.inv else {
            return v.to_vec();
        };
        if inv.nrows() != b.len() || b.iter().any(|c| c.len() != v.len()) {
            return v.to_vec();
        }
        let vw: Vec<f64> = match &self.rows {
            Some(f) => v.iter().zip(f).map(|(a, k)| a * k).collect(),
            None => v.to_vec(),
        };
        let g = DVector::from_iterator(
            b.len(),
            b.iter().map(|c| {
                c.iter()
                    .zip(&vw)
                    .map(|(x, y)| f64::from(*x) * y)
                    .sum::<f64>()
            }),
        );
        let coef = inv * g;
        let mut fit = vec![0.0; v.len()];
        for (c, k) in b.iter().zip(coef.iter()) {
            fit.iter_mut()
                .zip(c.iter())
                .for_each(|(f, x)| *f += k * f64::from(*x));
        }
        if let Some(f) = &self.rows {
            fit.iter_mut().zip(f).for_each(|(x, k)| *x *= k);
        }
        v.iter().zip(&fit).map(|(a, b)| a - b).collect()
    }
}
