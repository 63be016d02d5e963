//! Cheap screening of every candidate: sensitivities of the training residual to the base
//! and effect parameters, a bounded linearised least-squares fit against the base-refit
//! null, ΔBIC with an effective sample size; the channel weights of each candidate.

use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector};

use crate::LabError;
use crate::calibrate::{
    ChannelScales, Objective, SHOOTING_WINDOW_S, View, block_factors, effective_n, misfit_scales,
    row_factors, structural_scales,
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

/// Rows per chunk when the block Gram matrices are summed (a chunk of every column is
/// copied to double precision at a time: memory of the columns' count × this, not of
/// the dive).
const GRAM_CHUNK: usize = 2048;

/// What the screening needs of the residual r0 and the sensitivity columns M: per block
/// (one run's one channel, where every candidate's row weights are constant, see
/// [`crate::calibrate::block_factors`]) the Gram matrix of [r0 | M]. A bounded least
/// squares of f ⊙ (r0 + M δ) over any subset of the columns, its residual's cost per
/// channel and the cosines between weighted columns all follow from these
/// (1 + columns)² numbers per block; no whole-dive matrix is formed.
struct BlockGrams {
    /// Per block: the objective's channel index and the Gram matrix (index 0 = r0,
    /// j + 1 = column j).
    blocks: Vec<(usize, DMatrix<f64>)>,
}

impl BlockGrams {
    /// The Gram matrices of r0 and `cols` (a missing column counts as zeros) over the
    /// objective's blocks, one block per worker at a time.
    fn new(obj: &Objective<'_>, r0: &[f64], cols: &[Option<&Vec<f32>>], threads: usize) -> Self {
        let nch = obj.channels.len();
        let mut spans: Vec<(usize, usize, usize)> = Vec::new();
        let mut off = 0;
        for run in obj.runs {
            for ci in 0..nch {
                spans.push((ci, off, run.len()));
                off += run.len();
            }
        }
        let p1 = cols.len() + 1;
        let grams = crate::par::par_map_items(&spans, threads, |&(_, start, len)| {
            let mut g = DMatrix::zeros(p1, p1);
            let mut k0 = 0;
            while k0 < len {
                let k1 = (k0 + GRAM_CHUNK).min(len);
                let rows = start + k0..start + k1;
                let mut m = DMatrix::zeros(k1 - k0, p1);
                if let Some(seg) = r0.get(rows.clone()) {
                    m.column_mut(0).copy_from_slice(seg);
                }
                for (j, c) in cols.iter().enumerate() {
                    if let Some(seg) = c.and_then(|c| c.get(rows.clone())) {
                        for (x, v) in m.column_mut(j + 1).iter_mut().zip(seg) {
                            *x = f64::from(*v);
                        }
                    }
                }
                g.gemm_tr(1.0, &m, &m, 1.0);
                k0 = k1;
            }
            g
        });
        Self {
            blocks: spans.iter().map(|s| s.0).zip(grams).collect(),
        }
    }

    /// Block b's squared row factor (1 without factors).
    fn f2(f: Option<&[f64]>, b: usize) -> f64 {
        f.and_then(|f| f.get(b)).map_or(1.0, |x| x * x)
    }

    /// Σ_b f_b² G_b restricted to the indices `s` (0 = r0, j + 1 = column j).
    fn weighted(&self, f: Option<&[f64]>, s: &[usize]) -> DMatrix<f64> {
        let mut a = DMatrix::zeros(s.len(), s.len());
        for (b, (_, g)) in self.blocks.iter().enumerate() {
            let w = Self::f2(f, b);
            for (r, &i) in s.iter().enumerate() {
                for (c, &j) in s.iter().enumerate() {
                    a[(r, c)] += w * g[(i, j)];
                }
            }
        }
        a
    }

    /// Per objective channel (`nch` of them), Σ_b f_b² zᵀ G_b[s, s] z: the cost of the
    /// weighted residual f ⊙ (r0 + M_s δ) with z = [1, δ] and `s` = [0, columns…].
    fn channel_costs(&self, f: Option<&[f64]>, s: &[usize], z: &[f64], nch: usize) -> Vec<f64> {
        let mut costs = vec![0.0; nch];
        for (b, (ci, g)) in self.blocks.iter().enumerate() {
            let mut q = 0.0;
            for (r, &i) in s.iter().enumerate() {
                for (c, &j) in s.iter().enumerate() {
                    q += z[r] * g[(i, j)] * z[c];
                }
            }
            if let Some(c) = costs.get_mut(*ci) {
                *c += Self::f2(f, b) * q.max(0.0);
            }
        }
        costs
    }
}

/// The null of a screening (the base columns alone) under one set of block row factors,
/// and its δ: every candidate with the same factors shares it.
struct NullFit {
    /// The block factors it was weighted with (bit patterns; `None` = unweighted).
    key: Option<Vec<u64>>,
    /// The base columns' δ of the null fit.
    x: Vec<f64>,
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
    let grams = BlockGrams::new(&obj, &r0, &cols, threads);
    drop(r0);
    let nch = obj.channels.len();
    let nb = base_free.len();
    // Gram indices: 0 = r0, j + 1 = column j of `all` (the base columns first).
    let b_s: Vec<usize> = std::iter::once(0).chain(1..=nb).collect();
    let mut out = Vec::new();
    // The null fit (base columns alone) depends on the candidate only through its row
    // factors: it is computed once per distinct factor set (bit-equal), not per candidate.
    let mut null_fits: Vec<NullFit> = Vec::new();
    for c in cands {
        let idx: Vec<usize> = c
            .params
            .iter()
            .filter_map(|p| eff_index.get(p).copied())
            .collect();
        if idx.is_empty() {
            continue;
        }
        let f = block_factors(
            model,
            runs,
            view,
            scales,
            &candidate_scales(&home_channels(c.effect), scales),
        );
        let f = f.as_deref();
        let side: Vec<i8> = base_free
            .iter()
            .chain(c.params.iter().filter(|p| eff_index.contains_key(p)))
            .map(|p| bound_side(model, *p))
            .collect();
        let key: Option<Vec<u64>> = f.map(|f| f.iter().map(|x| x.to_bits()).collect());
        let null_at = match null_fits.iter().position(|n| n.key == key) {
            Some(i) => i,
            None => {
                let x = if nb == 0 {
                    Vec::new()
                } else {
                    let a = grams.weighted(f, &b_s);
                    let btb = a.view((1, 1), (nb, nb)).into_owned();
                    let btr = a.view((1, 0), (nb, 1)).column(0).into_owned();
                    let Some(x) = bounded_ls_gram(&btb, &btr, side.get(..nb).unwrap_or(&[])) else {
                        continue;
                    };
                    x
                };
                null_fits.push(NullFit { key, x });
                null_fits.len() - 1
            }
        };
        let Some(null) = null_fits.get(null_at) else {
            continue;
        };
        // The alternative [B C]: its Gram block, bounded least squares.
        let s_all: Vec<usize> = b_s
            .iter()
            .copied()
            .chain(idx.iter().map(|i| i + 1))
            .collect();
        let a = grams.weighted(f, &s_all);
        let p = s_all.len() - 1;
        let am = a.view((1, 1), (p, p)).into_owned();
        let g = a.view((1, 0), (p, 1)).column(0).into_owned();
        let Some(dx) = bounded_ls_gram(&am, &g, &side) else {
            continue;
        };
        let z0: Vec<f64> = std::iter::once(1.0)
            .chain(null.x.iter().copied())
            .chain(std::iter::repeat_n(0.0, idx.len()))
            .collect();
        let z1: Vec<f64> = std::iter::once(1.0).chain(dx.iter().copied()).collect();
        let c0 = grams.channel_costs(f, &s_all, &z0, nch);
        let c1 = grams.channel_costs(f, &s_all, &z1, nch);
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
        let (rss0, rss1): (f64, f64) = (c0.iter().sum(), c1.iter().sum());
        let q = idx.len() as f64;
        let ratio = (rss0 / rss1.max(1e-300)).max(1.0);
        let dbic = n_eff * ratio.ln() - q * n_eff.ln();
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
        // Base parameters whose sensitivity overlaps the effect's (cosines of the weighted
        // columns, from the alternative's Gram block).
        let mut conf: Vec<(f64, Param)> = Vec::new();
        for (bi, bp) in base_free.iter().enumerate() {
            let bn = a[(bi + 1, bi + 1)].max(0.0).sqrt();
            if bn <= 0.0 {
                continue;
            }
            let mut best: f64 = 0.0;
            for j in nb + 1..=p {
                let cn = a[(j, j)].max(0.0).sqrt();
                if cn > 0.0 {
                    best = best.max((a[(bi + 1, j)] / (bn * cn)).abs());
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
