//! The sparse regression of the term search: least squares, forward selection by
//! effective-sample ΔBIC and its block bootstrap (E-SINDy inclusion probabilities).

use super::*;

/// Residual of y after least squares on the columns (small ridge), and the coefficients.
pub(super) fn ls(y: &[f64], cols: &[&Vec<f64>]) -> (Vec<f64>, Vec<f64>) {
    let n = y.len();
    let p = cols.len();
    if p == 0 || n == 0 {
        return (y.to_vec(), Vec::new());
    }
    let norms: Vec<f64> = cols
        .iter()
        .map(|c| (c.iter().map(|x| x * x).sum::<f64>()).sqrt().max(1e-300))
        .collect();
    let mut a = DMatrix::<f64>::zeros(p, p);
    let mut b = DVector::<f64>::zeros(p);
    for i in 0..p {
        for k in 0..n {
            b[i] += cols[i][k] / norms[i] * y[k];
        }
        for j in i..p {
            let s: f64 =
                (0..n).map(|k| cols[i][k] * cols[j][k]).sum::<f64>() / (norms[i] * norms[j]);
            a[(i, j)] = s;
            a[(j, i)] = s;
        }
        a[(i, i)] += 1e-9;
    }
    let x = a
        .cholesky()
        .map(|c| c.solve(&b))
        .unwrap_or_else(|| DVector::zeros(p));
    let coef: Vec<f64> = (0..p).map(|i| x[i] / norms[i]).collect();
    let res: Vec<f64> = (0..n)
        .map(|k| y[k] - (0..p).map(|i| coef[i] * cols[i][k]).sum::<f64>())
        .collect();
    (res, coef)
}

pub(super) fn rss(r: &[f64]) -> f64 {
    r.iter().map(|x| x * x).sum()
}

/// Forward selection of library columns (`lib0`, the base projected out of each) on the
/// residual `y0` (the base projected out), over the rows `rows`: indices of the picked
/// columns with their ΔBIC. Each step orthogonalises the candidates against the picks
/// (Gram–Schmidt), so a step costs one pass over the columns.
pub(super) fn forward_select(
    y0: &[f64],
    lib0: &[Vec<f64>],
    rows: &[usize],
    n_eff_ratio: f64,
) -> Vec<(usize, f64)> {
    let take = |c: &[f64]| -> Vec<f64> {
        rows.iter()
            .map(|k| c.get(*k).copied().unwrap_or(0.0))
            .collect()
    };
    let mut cur = take(y0);
    let cols: Vec<Vec<f64>> = lib0.iter().map(|c| take(c)).collect();
    let n_eff = (rows.len() as f64 * n_eff_ratio).max(2.0);
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let mut basis: Vec<Vec<f64>> = Vec::new();
    let mut picked: Vec<(usize, f64)> = Vec::new();
    for _ in 0..MAX_TERMS_PER_DOF {
        let rss0 = dot(&cur, &cur);
        if rss0 <= 0.0 {
            break;
        }
        let mut best: Option<(usize, f64, Vec<f64>)> = None;
        for (i, c) in cols.iter().enumerate() {
            if picked.iter().any(|(p, _)| *p == i) {
                continue;
            }
            let mut cp = c.clone();
            for b in &basis {
                let k = dot(b, &cp);
                cp.iter_mut().zip(b).for_each(|(x, y)| *x -= k * y);
            }
            let cc = dot(&cp, &cp);
            if cc <= 1e-18 * rss0.max(1e-300) {
                continue;
            }
            let g = dot(&cp, &cur);
            let v = rss0 - g * g / cc;
            if best.as_ref().is_none_or(|(_, bv, _)| v < *bv) {
                best = Some((i, v, cp));
            }
        }
        let Some((i, v, cp)) = best else { break };
        let dbic = n_eff * (rss0 / v.max(1e-300)).ln() - n_eff.ln();
        if dbic <= MIN_DBIC {
            break;
        }
        picked.push((i, dbic));
        let norm = dot(&cp, &cp).sqrt();
        let b: Vec<f64> = cp.iter().map(|x| x / norm).collect();
        let k = dot(&b, &cur);
        cur.iter_mut().zip(&b).for_each(|(x, y)| *x -= k * y);
        basis.push(b);
    }
    picked
}

/// Deterministic pseudo-random numbers for the bootstrap (SplitMix64).
pub(super) fn splitmix(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Library terms shortlisted per DOF by their single-term share of the equation error
/// (besides the forward selection's stable picks).
pub const SHORTLIST_PER_DOF: usize = 8;

/// Block-bootstrap inclusion probability of every library column in the forward
/// selection (E-SINDy; blocks of 20 windows within runs).
pub(super) fn bootstrap_inclusion(
    d: &DofData,
    y0: &[f64],
    lib0: &[Vec<f64>],
    ratio: f64,
) -> Vec<f64> {
    let n = y0.len();
    let block_len = 20usize;
    let mut blocks: Vec<Vec<usize>> = Vec::new();
    let mut cur: Vec<usize> = Vec::new();
    for k in 0..n {
        if !cur.is_empty() && (cur.len() >= block_len || d.block[k] != d.block[k - 1]) {
            blocks.push(std::mem::take(&mut cur));
        }
        cur.push(k);
    }
    if !cur.is_empty() {
        blocks.push(cur);
    }
    let mut counts = vec![0usize; d.lib.len()];
    if blocks.is_empty() {
        return vec![0.0; d.lib.len()];
    }
    let mut rng = 0x5EED_0000_0000_0000u64 ^ d.dof as u64;
    for _ in 0..BOOTSTRAP {
        let mut rows = Vec::with_capacity(n);
        for _ in 0..blocks.len() {
            let b = (splitmix(&mut rng) % blocks.len() as u64) as usize;
            rows.extend_from_slice(&blocks[b]);
        }
        for (i, _) in forward_select(y0, lib0, &rows, ratio) {
            if let Some(c) = counts.get_mut(i) {
                *c += 1;
            }
        }
    }
    counts
        .iter()
        .map(|c| *c as f64 / BOOTSTRAP as f64)
        .collect()
}
