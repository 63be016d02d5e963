//! Cheap screening of every candidate: sensitivities of the training residual to the base
//! and effect parameters, a bounded linearised least-squares fit against the base-refit
//! null, ΔBIC with an effective sample size; the channel weights of each candidate.

use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector};

use crate::LabError;
use crate::calibrate::{
    ChannelScales, Objective, SHOOTING_WINDOW_S, View, effective_n, misfit_scales, row_factors,
    structural_scales,
};
use crate::data::Run;
use crate::model::LabModel;
use crate::params::{Param, axis_params_of};

use super::*;

/// The Jacobian of the objective's residual w.r.t. parameters at `model` (the lab's one
/// forward-difference Jacobian, [`crate::lm::fd_columns`], on `threads` workers), reported
/// as the progress stage `stage`.
pub(super) fn jacobian_cols(
    stage: &str,
    model: &LabModel,
    obj: &Objective<'_>,
    r0: &[f64],
    params: &[Param],
    steps: &[f64],
    threads: usize,
) -> Vec<Option<Vec<f64>>> {
    let counter = crate::progress::Counter::start(stage, params.len(), "sensitivities");
    crate::lm::fd_columns(r0, params.len(), threads, |i| {
        let _tick = TickOnDrop(&counter);
        let p = *params.get(i)?;
        let v0 = model.get(p).or_else(|| p.off_value()).unwrap_or(0.0);
        let h = crate::lm::fd_step(v0, *steps.get(i)?, p.meta().hi);
        let m = model.with(&[p], &[v0 + h]).ok()?;
        let r = obj.residuals(&m).ok()?;
        Some((h, r))
    })
}

pub(crate) use crate::par::par_map;

/// Ticks its counter when dropped (an item counts as done however it ended).
pub(super) struct TickOnDrop<'a>(pub(super) &'a crate::progress::Counter);

impl Drop for TickOnDrop<'_> {
    fn drop(&mut self) {
        self.0.tick();
    }
}

#[derive(Debug, Clone)]
pub(super) struct Screened {
    pub(super) cand: Candidate,
    pub(super) dbic: f64,
    /// Largest explained fraction of a home channel's training residual.
    pub(super) explained: f64,
    pub(super) start: Vec<f64>,
    /// The base parameters' values of the same linearised step.
    pub(super) start_base: Vec<f64>,
    /// The base parameters of `start_base` (those screened with the candidate).
    pub(super) base_params: Vec<Param>,
    /// Base parameters confounded with the effect (reported in debugging only).
    #[allow(dead_code)]
    pub(super) confounded: Vec<Param>,
    /// The view the screening used.
    pub(super) view: View,
}

/// Smallest explained fraction of a home channel's training residual (linearised) for a
/// candidate to be confirmed in simulation.
pub(super) const MIN_SCREEN_EXPLAINED: f64 = 0.03;

/// A candidate is confirmed only if it explains at least this fraction of what the best
/// screened candidate explains.
pub(super) const RELATIVE_SCREEN_GATE: f64 = 0.2;

/// Further starts a confirmation tries when its fit ends pinned at a plausibility bound.
pub(super) const MAX_EXTRA_STARTS: usize = 2;

/// Most base parameters refitted jointly with an effect.
pub(super) const MAX_CONFOUNDED: usize = 10;
/// Cosine between an effect's and a base parameter's sensitivity above which the base
/// parameter is refitted with the effect.
pub(super) const CONFOUND_COSINE: f64 = 0.1;

/// Multiplies row k of `m` by `f[k]`.
pub(super) fn scale_rows(m: &mut DMatrix<f64>, f: &[f64]) {
    for j in 0..m.ncols() {
        for (x, k) in m.column_mut(j).iter_mut().zip(f) {
            *x *= k;
        }
    }
}

/// Direction a parameter may move from its current value in a linearised step: +1 when
/// it sits at its lower bound, −1 at its upper bound, 0 when free both ways.
pub(super) fn bound_side(model: &LabModel, p: Param) -> i8 {
    let m = p.meta();
    let v = model.get(p).or_else(|| p.off_value()).unwrap_or(0.0);
    let tol = 1e-9 * m.scale.max(1e-12);
    if v <= m.lo + tol {
        1
    } else if v >= m.hi - tol {
        -1
    } else {
        0
    }
}

/// Bounded linear least squares of r0 + M δ (columns normalised, tiny ridge): a column
/// whose step would leave its bound (`side`, see [`bound_side`]) is held at zero and the
/// rest refitted (active set). Returns the residual and δ. (The screening itself works
/// on cached Gram blocks, see [`NullBlock`].)
#[cfg(test)]
pub(super) fn bounded_ls(
    r0: &DVector<f64>,
    m: &DMatrix<f64>,
    side: &[i8],
) -> Option<(DVector<f64>, Vec<f64>)> {
    if m.ncols() == 0 {
        return Some((r0.clone(), Vec::new()));
    }
    let x = bounded_ls_gram(&m.tr_mul(m), &m.tr_mul(r0), side)?;
    let res = r0 + m * DVector::from_column_slice(&x);
    Some((res, x))
}

/// [`bounded_ls`] from the normal equations: the Gram matrix A = MᵀM and g = Mᵀr0 of the
/// problem r0 + M δ (the columns normalised here by √A_jj). Returns δ.
pub(super) fn bounded_ls_gram(a: &DMatrix<f64>, g: &DVector<f64>, side: &[i8]) -> Option<Vec<f64>> {
    let p = a.ncols();
    let norms: Vec<f64> = (0..p)
        .map(|j| a[(j, j)].max(0.0).sqrt().max(1e-300))
        .collect();
    let mut active: Vec<usize> = (0..p).collect();
    let mut x_full = vec![0.0; p];
    for _ in 0..=p {
        let k = active.len();
        x_full = vec![0.0; p];
        if k == 0 {
            break;
        }
        let mut sub = DMatrix::zeros(k, k);
        let mut gs = DVector::zeros(k);
        for (r, &i) in active.iter().enumerate() {
            gs[r] = -g[i] / norms[i];
            for (c, &j) in active.iter().enumerate() {
                sub[(r, c)] = a[(i, j)] / (norms[i] * norms[j]);
            }
            sub[(r, r)] += 1e-9;
        }
        let x = sub.cholesky()?.solve(&gs);
        for (r, &i) in active.iter().enumerate() {
            x_full[i] = x[r];
        }
        let before = active.len();
        active.retain(|&i| {
            let sd = side.get(i).copied().unwrap_or(0);
            !(sd != 0 && x_full[i] * f64::from(sd) < 0.0)
        });
        if active.len() == before {
            break;
        }
    }
    Some(x_full.iter().zip(&norms).map(|(v, n)| v / n).collect())
}

/// The null of a screening (the base columns B alone, rows weighted for a candidate's
/// channel weights) with what every alternative [B C] reuses: the weighted B and r0,
/// BᵀB, Bᵀr0 and the null's residual.
struct NullBlock {
    /// The row factors it was weighted with (bit patterns; `None` = unweighted).
    key: Option<Vec<u64>>,
    /// Weighted B and r0 (`None`: the unweighted ones).
    weighted: Option<(DMatrix<f64>, DVector<f64>)>,
    btb: DMatrix<f64>,
    btr: DVector<f64>,
    res0: DVector<f64>,
}

impl NullBlock {
    fn new(
        key: Option<Vec<u64>>,
        weighted: Option<(DMatrix<f64>, DVector<f64>)>,
        b0: &DMatrix<f64>,
        r0: &DVector<f64>,
        side: &[i8],
    ) -> Option<Self> {
        let (b, r) = match &weighted {
            Some((b, r)) => (b, r),
            None => (b0, r0),
        };
        let btb = b.tr_mul(b);
        let btr = b.tr_mul(r);
        let res0 = if b.ncols() == 0 {
            r.clone()
        } else {
            let x = bounded_ls_gram(&btb, &btr, side)?;
            r + b * DVector::from_column_slice(&x)
        };
        Some(Self {
            key,
            weighted,
            btb,
            btr,
            res0,
        })
    }

    /// The weighted B and r0.
    fn parts<'a>(
        &'a self,
        b0: &'a DMatrix<f64>,
        r0: &'a DVector<f64>,
    ) -> (&'a DMatrix<f64>, &'a DVector<f64>) {
        match &self.weighted {
            Some((b, r)) => (b, r),
            None => (b0, r0),
        }
    }

    /// Bounded least squares of r0 + [B C] δ from the cached blocks (only BᵀC, CᵀC and
    /// Cᵀr0 are new): the alternative's residual and δ.
    fn alt(
        &self,
        b0: &DMatrix<f64>,
        r0: &DVector<f64>,
        c: &DMatrix<f64>,
        side: &[i8],
    ) -> Option<(DVector<f64>, Vec<f64>)> {
        let (b, r) = self.parts(b0, r0);
        let (nb, nc) = (b.ncols(), c.ncols());
        let btc = b.tr_mul(c);
        let ctc = c.tr_mul(c);
        let ctr = c.tr_mul(r);
        let p = nb + nc;
        let mut a = DMatrix::zeros(p, p);
        let mut g = DVector::zeros(p);
        a.view_mut((0, 0), (nb, nb)).copy_from(&self.btb);
        a.view_mut((0, nb), (nb, nc)).copy_from(&btc);
        a.view_mut((nb, 0), (nc, nb)).copy_from(&btc.transpose());
        a.view_mut((nb, nb), (nc, nc)).copy_from(&ctc);
        g.rows_mut(0, nb).copy_from(&self.btr);
        g.rows_mut(nb, nc).copy_from(&ctr);
        let x = bounded_ls_gram(&a, &g, side)?;
        let mut res = r.clone();
        res.gemv(1.0, b, &DVector::from_column_slice(&x[..nb]), 1.0);
        res.gemv(1.0, c, &DVector::from_column_slice(&x[nb..]), 1.0);
        Some((res, x))
    }
}

/// Prediction horizon of the short screening view and of the first confirmation stage,
/// s: short enough to keep large missing effects (a tether's weathervaning) near-linear.
/// Screening also runs in the multiple-shooting view, where rate errors (a dead zone's
/// wrong steady speeds) stand above the noise and the calibrated base is at its optimum.
pub const SCREEN_HORIZON_S: f64 = 2.0;

pub(super) fn short_view(runs: &[Run]) -> View {
    let dt = runs.first().map_or(0.05, |r| r.median_dt()).max(1e-3);
    View::KStep((SCREEN_HORIZON_S / dt).round().max(2.0) as usize)
}

/// Screens candidates in `view`: linearised fit of the training residual on the base
/// and effect sensitivities.
/// Sensitivity columns of the screening objective, kept across greedy rounds (the
/// linearisation of the calibrated base stays a fair screening approximation after an
/// effect is added, and it saves most of the cost of later rounds). Stored in single
/// precision: a column is a whole dive's rows × channels, two views keep one per
/// parameter (1.7 GB in f64 on a 1-hour, 50 Hz dive), and a finite-difference
/// sensitivity has far fewer than seven significant digits; every product is summed in
/// double precision.
pub(super) type ColumnCache = BTreeMap<Param, Vec<f32>>;

/// A column into the cache's single precision.
pub(super) fn to_cache(c: &[f64]) -> Vec<f32> {
    c.iter().map(|&x| x as f32).collect()
}

#[allow(clippy::too_many_arguments)]
pub(super) fn screen(
    model: &LabModel,
    runs: &[Run],
    base_free: &[Param],
    cands: &[Candidate],
    view: View,
    scales: &ChannelScales,
    threads: usize,
    cache: &mut ColumnCache,
) -> Result<Vec<Screened>, LabError> {
    if cands.is_empty() {
        return Ok(Vec::new());
    }
    let obj = Objective::scaled(model, runs, view, scales);
    let r0 = obj.residuals(model)?;
    let n_eff = effective_n(&r0, runs.first().map_or(1, |r| r.len()));
    let n = r0.len();
    // Base columns (small steps) and effect columns (probe secants) in one parallel pass.
    let mut all: Vec<Param> = base_free.to_vec();
    let mut steps: Vec<f64> = base_free.iter().map(|p| p.meta().scale * 0.1).collect();
    let mut eff_index: BTreeMap<Param, usize> = BTreeMap::new();
    for c in cands {
        for p in &c.params {
            if eff_index.contains_key(p) || base_free.contains(p) {
                continue;
            }
            let cur = model.get(*p).or_else(|| p.off_value()).unwrap_or(0.0);
            let probe = probe_value(model, runs, *p);
            eff_index.insert(*p, all.len());
            all.push(*p);
            let step = probe - cur;
            steps.push(if step.abs() > 1e-12 {
                step
            } else {
                p.meta().scale
            });
        }
    }
    let missing: Vec<usize> = (0..all.len())
        .filter(|i| !cache.contains_key(&all[*i]))
        .collect();
    let miss_params: Vec<Param> = missing.iter().map(|i| all[*i]).collect();
    let miss_steps: Vec<f64> = missing.iter().map(|i| steps[*i]).collect();
    let new_cols = jacobian_cols(
        "screening",
        model,
        &obj,
        &r0,
        &miss_params,
        &miss_steps,
        threads,
    );
    for (p, c) in miss_params.iter().zip(new_cols) {
        if let Some(c) = c
            && c.len() == n
        {
            cache.insert(*p, to_cache(&c));
        }
    }
    let cols: Vec<Option<&Vec<f32>>> = all.iter().map(|p| cache.get(p)).collect();
    let to_mat = |idx: &[usize]| -> DMatrix<f64> {
        let mut m = DMatrix::zeros(n, idx.len());
        for (j, &i) in idx.iter().enumerate() {
            if let Some(c) = cols[i] {
                for (k, v) in c.iter().enumerate() {
                    m[(k, j)] = f64::from(*v);
                }
            }
        }
        m
    };
    let b_idx: Vec<usize> = (0..base_free.len()).collect();
    let b = to_mat(&b_idx);
    let rv = DVector::from_column_slice(&r0);
    let mut out = Vec::new();
    // The null fit (base columns alone) depends on the candidate only through its row
    // factors: it is computed once per distinct factor set (bit-equal), not per candidate.
    let mut null_fits: Vec<NullBlock> = Vec::new();
    for c in cands {
        let idx: Vec<usize> = c
            .params
            .iter()
            .filter_map(|p| eff_index.get(p).copied())
            .collect();
        if idx.is_empty() {
            continue;
        }
        let mut cm = to_mat(&idx);
        let f = row_factors(
            model,
            runs,
            view,
            scales,
            &candidate_scales(&home_channels(c.effect), scales),
        );
        if let Some(f) = &f {
            scale_rows(&mut cm, f);
        }
        let side: Vec<i8> = base_free
            .iter()
            .chain(c.params.iter().filter(|p| eff_index.contains_key(p)))
            .map(|p| bound_side(model, *p))
            .collect();
        let nb = base_free.len();
        let key: Option<Vec<u64>> = f.as_ref().map(|f| f.iter().map(|x| x.to_bits()).collect());
        let null_at = match null_fits.iter().position(|n| n.key == key) {
            Some(i) => i,
            None => {
                let weighted = f.as_ref().map(|f| {
                    let mut bb = b.clone();
                    scale_rows(&mut bb, f);
                    (bb, rv.component_mul(&DVector::from_column_slice(f)))
                });
                let Some(nf) =
                    NullBlock::new(key, weighted, &b, &rv, side.get(..nb).unwrap_or(&[]))
                else {
                    continue;
                };
                null_fits.push(nf);
                null_fits.len() - 1
            }
        };
        let Some(null) = null_fits.get(null_at) else {
            continue;
        };
        let res0 = &null.res0;
        let Some((res1, dx)) = null.alt(&b, &rv, &cm, &side) else {
            continue;
        };
        let (b, _) = null.parts(&b, &rv);
        let dc: Vec<f64> = dx.iter().skip(nb).copied().collect();
        let start_base: Vec<f64> = base_free
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let m = p.meta();
                let v = model.get(*p).unwrap_or(0.0);
                // Damped Gauss–Newton step of the base, kept within bounds.
                (v + 0.8 * dx.get(i).copied().unwrap_or(0.0)).clamp(m.lo, m.hi)
            })
            .collect();
        let (rss0, rss1) = (res0.norm_squared(), res1.norm_squared());
        let q = idx.len() as f64;
        let ratio = (rss0 / rss1.max(1e-300)).max(1.0);
        let dbic = n_eff * ratio.ln() - q * n_eff.ln();
        let c0 = obj.channel_costs(res0.as_slice());
        let c1 = obj.channel_costs(res1.as_slice());
        let home = home_channels(c.effect);
        let frac = |only_home: bool| {
            obj.channels
                .iter()
                .enumerate()
                .filter(|(_, ch)| !only_home || home.contains(ch))
                .map(|(i, _)| {
                    if c0[i] > 0.0 {
                        1.0 - c1[i] / c0[i]
                    } else {
                        0.0
                    }
                })
                .fold(f64::NEG_INFINITY, f64::max)
        };
        let mut explained = frac(true);
        if !explained.is_finite() {
            explained = frac(false);
        }
        let start = c
            .params
            .iter()
            .enumerate()
            .map(|(j, p)| {
                let cur = model.get(*p).or_else(|| p.off_value()).unwrap_or(0.0);
                let meta = p.meta();
                (cur + dc.get(j).copied().unwrap_or(0.0)).clamp(meta.lo, meta.hi)
            })
            .collect();
        // Base parameters whose sensitivity overlaps the effect's.
        let mut conf: Vec<(f64, Param)> = Vec::new();
        for (bi, bp) in base_free.iter().enumerate() {
            let bcol = b.column(bi);
            let bn = bcol.norm();
            if bn <= 0.0 {
                continue;
            }
            let mut best: f64 = 0.0;
            for j in 0..cm.ncols() {
                let ccol = cm.column(j);
                let cn = ccol.norm();
                if cn > 0.0 {
                    best = best.max((bcol.dot(&ccol) / (bn * cn)).abs());
                }
            }
            conf.push((best, *bp));
        }
        conf.sort_by(|a, b| b.0.total_cmp(&a.0));
        // The base parameters of the axes where the effect shows are always refitted
        // with it (a reverse-thrust ratio trades against the thrust gain and the drag of
        // its axis), then the most overlapping others.
        let mut confounded: Vec<Param> = base_free
            .iter()
            .copied()
            .filter(|p| axis_params_of(&home).contains(p))
            .collect();
        for (cs, p) in &conf {
            if confounded.len() >= MAX_CONFOUNDED {
                break;
            }
            if *cs > CONFOUND_COSINE && !confounded.contains(p) {
                confounded.push(*p);
            }
        }
        out.push(Screened {
            cand: c.clone(),
            dbic,
            explained: explained.max(0.0),
            start,
            start_base,
            base_params: base_free.to_vec(),
            confounded,
            view,
        });
    }
    Ok(out)
}

/// The starting Jacobian of a fit from screening columns (`None` if any is missing), rows
/// rescaled by `rows` when the fit's weights differ from the screening's.
pub(super) fn cached_jacobian(
    cache: &ColumnCache,
    free: &[Param],
    rows: Option<&[f64]>,
) -> Option<DMatrix<f64>> {
    let cols: Vec<&Vec<f32>> = free.iter().map(|p| cache.get(p)).collect::<Option<_>>()?;
    let n = cols.first().map_or(0, |c| c.len());
    if cols.iter().any(|c| c.len() != n) || n == 0 {
        return None;
    }
    let mut j = DMatrix::zeros(n, free.len());
    for (c, col) in cols.iter().enumerate() {
        for (k, v) in col.iter().enumerate() {
            j[(k, c)] = f64::from(*v);
        }
    }
    if let Some(f) = rows {
        if f.len() != n {
            return None;
        }
        scale_rows(&mut j, f);
    }
    Some(j)
}

/// The screening caches by view.
pub(super) struct Caches<'a> {
    pub(super) short: &'a ColumnCache,
    pub(super) shoot: &'a ColumnCache,
    pub(super) free: &'a ColumnCache,
    pub(super) scales: &'a ViewScales,
    /// Whether the data is closed-loop (judged on multiple shooting only).
    pub(super) closed_loop: bool,
}

impl Caches<'_> {
    pub(super) fn of(&self, v: View) -> &ColumnCache {
        match v {
            View::FreeRun => self.free,
            View::Shooting(_) => self.shoot,
            View::KStep(_) => self.short,
        }
    }
}

/// Channel misfit scales of the current model in each error view (the objective weights,
/// see [`crate::calibrate`]): every candidate of a round is fitted and scored with the
/// same weights, re-estimated after each accepted effect.
#[derive(Debug, Clone, Copy)]
pub(super) struct ViewScales {
    pub(super) short: ChannelScales,
    pub(super) shoot: ChannelScales,
    pub(super) free: ChannelScales,
}

impl ViewScales {
    pub(super) fn of_model(model: &LabModel, runs: &[Run]) -> Result<Self, LabError> {
        // One scale per channel for every view: the channel's error level under the
        // current model in multiple shooting (the calibration's view). The free run's
        // accumulated error (a sensor drift's) is what a slow effect must explain, so it
        // must not lower that channel's weight.
        let s = structural_scales(
            runs,
            &misfit_scales(model, runs, View::Shooting(SHOOTING_WINDOW_S))?,
        );
        Ok(Self {
            short: s,
            shoot: s,
            free: s,
        })
    }

    pub(super) fn of(&self, v: View) -> &ChannelScales {
        match v {
            View::FreeRun => &self.free,
            View::Shooting(_) => &self.shoot,
            View::KStep(_) => &self.short,
        }
    }
}

/// Rescales cached sensitivity columns from the weights of `old` to those of `new`.
pub(super) fn rescale_cache(
    cache: &mut ColumnCache,
    model: &LabModel,
    runs: &[Run],
    view: View,
    old: &ChannelScales,
    new: &ChannelScales,
) {
    let Some(f) = row_factors(model, runs, view, old, new) else {
        return;
    };
    for col in cache.values_mut() {
        col.iter_mut()
            .zip(&f)
            .for_each(|(x, k)| *x = (f64::from(*x) * k) as f32);
    }
}

/// The channel weights of one candidate's fits: the channels where its signature lives
/// carry their noise weights, all others the structural misfit of the current model
/// (`base`). Iterative reweighting evaluates the weights at the solution it expects, and a
/// candidate that is right brings its own channels down to their noise while leaving
/// the others as they are; the home channels' large current misfit must therefore not
/// discount the very evidence the candidate is judged on, and the other channels' misfit
/// must not dominate its fit (a pitch response to a missing moment arm steering the fit
/// of a thrust asymmetry).
pub(super) fn candidate_scales(home: &[Channel], base: &ChannelScales) -> ChannelScales {
    let mut s = *base;
    for ch in home.iter().copied() {
        s[crate::data::ch_index(ch)] = 0.0;
    }
    s
}
