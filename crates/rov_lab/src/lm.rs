//! Bounded Levenberg–Marquardt on a residual vector, with forward-difference Jacobians
//! evaluated on up to `threads` workers of the lab's pool ([`crate::par`]), optional Gaussian priors (ridge toward prior
//! values) and the Gauss–Newton covariance at the optimum.
//!
//! Parameters are scaled by their typical magnitude; a trial step is projected onto the
//! bounds. A residual function returning `None` (the simulation diverged) rejects the
//! trial point.

use nalgebra::{DMatrix, DVector};

/// Options of [`minimize`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LmOptions {
    /// Iteration limit (Jacobian evaluations).
    pub max_iter: usize,
    /// Worker threads for the Jacobian (1 = serial).
    pub threads: usize,
    /// Stop when an accepted step lowers the cost by less than this fraction.
    pub rel_tol: f64,
    /// Forward-difference step as a fraction of each parameter's scale.
    pub fd_fraction: f64,
}

impl Default for LmOptions {
    fn default() -> Self {
        Self {
            max_iter: 12,
            threads: 1,
            rel_tol: 1e-4,
            fd_fraction: 0.1,
        }
    }
}

/// A parameter's bounds, scale and optional prior (value, standard deviation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bound {
    /// Lower bound.
    pub lo: f64,
    /// Upper bound.
    pub hi: f64,
    /// Typical change.
    pub scale: f64,
    /// Prior (value, σ); adds ((x − value)/σ)² to the cost.
    pub prior: Option<(f64, f64)>,
}

/// Result of [`minimize`].
#[derive(Debug, Clone)]
pub struct LmResult {
    /// Best parameters.
    pub x: Vec<f64>,
    /// Data cost Σ r² at `x` (priors excluded).
    pub cost: f64,
    /// Cost at the start.
    pub cost0: f64,
    /// Number of residuals.
    pub n_res: usize,
    /// Jacobian at the last linearisation (natural units), if any iteration ran.
    pub jacobian: Option<DMatrix<f64>>,
    /// Residuals at `x`.
    pub residuals: Vec<f64>,
    /// Iterations done.
    pub iterations: usize,
    /// Residual evaluations done.
    pub evaluations: usize,
    /// Whether the search stopped because it converged (a step below the relative
    /// tolerance, or no descent left), not because it ran out of iterations.
    pub converged: bool,
}

impl LmResult {
    /// Gauss–Newton standard deviations σ̂·sqrt(diag (JᵀJ)⁻¹), with σ̂² = cost/(N − p),
    /// inflated by `inflation` (N/N_eff for correlated residuals).
    pub fn std_devs(&self, inflation: f64) -> Vec<f64> {
        let p = self.x.len();
        let Some(j) = &self.jacobian else {
            return vec![f64::NAN; p];
        };
        let jtj = j.tr_mul(j);
        let dof = (self.n_res as f64 - p as f64).max(1.0);
        let s2 = self.cost / dof * inflation.max(1.0);
        // Small relative ridge keeps unexcited directions finite (reported huge).
        let mut a = jtj.clone();
        let maxd = (0..p).map(|i| a[(i, i)]).fold(0.0f64, f64::max).max(1e-300);
        for i in 0..p {
            a[(i, i)] += 1e-12 * maxd;
        }
        match a.try_inverse() {
            Some(inv) => (0..p).map(|i| (inv[(i, i)].max(0.0) * s2).sqrt()).collect(),
            None => vec![f64::INFINITY; p],
        }
    }
}

fn cost_of(r: &[f64]) -> f64 {
    r.iter().map(|x| x * x).sum()
}

fn prior_cost(x: &[f64], b: &[Bound]) -> f64 {
    x.iter()
        .zip(b)
        .map(|(xi, bi)| match bi.prior {
            Some((v, s)) if s > 0.0 => ((xi - v) / s).powi(2),
            _ => 0.0,
        })
        .sum()
}

/// The signed forward-difference step of size `h` at `x`: backwards when forwards would
/// cross the upper bound `hi`.
pub(crate) fn fd_step(x: f64, h: f64, hi: f64) -> f64 {
    if x + h > hi { -h } else { h }
}

/// Writes the forward-difference column (r − r₀)/h into `col` (zeros when the
/// evaluation failed or has another length); whether it succeeded.
fn fd_column_into(col: &mut [f64], r0: &[f64], eval: Option<(f64, Vec<f64>)>) -> bool {
    match eval {
        Some((h, r)) if r.len() == r0.len() && col.len() == r0.len() => {
            for ((v, a), c) in col.iter_mut().zip(&r).zip(r0) {
                *v = (a - c) / h;
            }
            true
        }
        _ => {
            col.iter_mut().for_each(|v| *v = 0.0);
            false
        }
    }
}

/// The lab's one forward-difference Jacobian, as separate columns: `eval(i)` returns
/// column i's signed step h and the residual at the stepped point (`None`: that column
/// is missing). Columns are evaluated on up to `threads` workers ([`crate::par`]).
pub(crate) fn fd_columns<F>(r0: &[f64], p: usize, threads: usize, eval: F) -> Vec<Option<Vec<f64>>>
where
    F: Fn(usize) -> Option<(f64, Vec<f64>)> + Sync + Send,
{
    crate::par::par_map(p, threads, |i| {
        let mut col = vec![0.0; r0.len()];
        fd_column_into(&mut col, r0, eval(i)).then_some(col)
    })
}

/// [`fd_columns`] written straight into one matrix (a missing column stays zero).
pub(crate) fn fd_matrix<F>(r0: &[f64], p: usize, threads: usize, eval: F) -> DMatrix<f64>
where
    F: Fn(usize) -> Option<(f64, Vec<f64>)> + Sync + Send,
{
    let n = r0.len();
    let mut j = DMatrix::zeros(n, p);
    if n > 0 {
        crate::par::par_chunks_mut(j.as_mut_slice(), n, threads, |i, col| {
            fd_column_into(col, r0, eval(i));
        });
    }
    j
}

/// Evaluates the Jacobian (natural units) by forward differences.
fn jacobian<F>(f: &F, x: &[f64], r0: &[f64], b: &[Bound], opts: &LmOptions) -> (DMatrix<f64>, usize)
where
    F: Fn(&[f64]) -> Option<Vec<f64>> + Sync,
{
    let p = x.len();
    let j = fd_matrix(r0, p, opts.threads, |i| {
        let h = fd_step(x[i], b[i].scale * opts.fd_fraction, b[i].hi);
        let mut xp = x.to_vec();
        xp[i] += h;
        f(&xp).map(|r| (h, r))
    });
    (j, p)
}

/// Minimises Σ r(x)² (+ priors) within bounds, starting at `x0`.
pub fn minimize<F>(f: &F, x0: &[f64], bounds: &[Bound], opts: &LmOptions) -> Option<LmResult>
where
    F: Fn(&[f64]) -> Option<Vec<f64>> + Sync,
{
    minimize_with(f, x0, bounds, opts, None)
}

/// Rank-one Broyden update of a Jacobian (natural units) from a step `dx` with residual
/// change `dr`, in the scaled metric z = x / scale.
fn broyden_update(j: &mut DMatrix<f64>, dx: &[f64], dr: &[f64], sc: &[f64]) {
    let dz: Vec<f64> = dx.iter().zip(sc).map(|(a, s)| a / s).collect();
    let nz: f64 = dz.iter().map(|v| v * v).sum();
    if nz <= 0.0 || !nz.is_finite() {
        return;
    }
    let jdx = &*j * DVector::from_column_slice(dx);
    let u: Vec<f64> = dr.iter().zip(jdx.iter()).map(|(a, b)| a - b).collect();
    for (c, (dzc, s)) in dz.iter().zip(sc).enumerate() {
        let w = dzc / s / nz;
        if w == 0.0 {
            continue;
        }
        for (k, v) in j.column_mut(c).iter_mut().enumerate() {
            *v += u[k] * w;
        }
    }
}

/// [`minimize`] with an optional starting Jacobian (natural units, one column per
/// parameter). With one, later Jacobians come from rank-one Broyden updates of every
/// evaluated trial point (one simulation per iteration instead of one per parameter); a
/// fresh finite-difference Jacobian replaces it when the updated one stops giving descent.
pub fn minimize_with<F>(
    f: &F,
    x0: &[f64],
    bounds: &[Bound],
    opts: &LmOptions,
    j0: Option<DMatrix<f64>>,
) -> Option<LmResult>
where
    F: Fn(&[f64]) -> Option<Vec<f64>> + Sync,
{
    let p = x0.len();
    let mut x: Vec<f64> = x0
        .iter()
        .zip(bounds)
        .map(|(v, b)| v.clamp(b.lo, b.hi))
        .collect();
    let mut r = f(&x)?;
    let mut evaluations = 1;
    let cost0 = cost_of(&r);
    let mut cost = cost0;
    let mut total = cost + prior_cost(&x, bounds);
    let mut lambda = 1e-3;
    let n = r.len();
    let mut jac: Option<DMatrix<f64>> = j0.filter(|j| j.nrows() == n && j.ncols() == p);
    let broyden = jac.is_some();
    let mut fresh = false;
    let mut iterations = 0;
    if p == 0 {
        return Some(LmResult {
            x,
            cost,
            cost0,
            n_res: n,
            jacobian: None,
            residuals: r,
            iterations,
            evaluations,
            converged: true,
        });
    }
    let sc: Vec<f64> = bounds.iter().map(|b| b.scale).collect();
    let mut refreshes = 0;
    let mut converged = false;
    // The scaled Gram matrix S JᵀJ S (S = diag(scale)), kept while the Jacobian stays the
    // same (a fresh one is kept over all later iterations; only Broyden updates change
    // it). The scaling is applied to the p × p products, not to a copy of the n × p
    // Jacobian (a whole dive's Jacobian is hundreds of MB).
    let mut normal: Option<DMatrix<f64>> = None;
    while iterations < opts.max_iter {
        iterations += 1;
        if jac.is_none() {
            let (j, evals) = jacobian(f, &x, &r, bounds, opts);
            evaluations += evals;
            jac = Some(j);
            fresh = true;
            normal = None;
        }
        let Some(j) = jac.as_mut() else { break };
        // Scaled normal equations: z = x / scale.
        let a0 = normal.get_or_insert_with(|| {
            let mut a0 = j.tr_mul(j);
            for c in 0..p {
                for k in 0..p {
                    a0[(k, c)] *= sc[k] * sc[c];
                }
            }
            a0
        });
        let mut a = a0.clone();
        let rv = DVector::from_column_slice(&r);
        let mut g = j.tr_mul(&rv);
        for (gi, s) in g.iter_mut().zip(&sc) {
            *gi *= s;
        }
        for i in 0..p {
            if let Some((v, s)) = bounds[i].prior
                && s > 0.0
            {
                let w = sc[i] / s;
                a[(i, i)] += w * w;
                g[i] += w * (x[i] - v) / s;
            }
        }
        let maxd = (0..p).map(|i| a[(i, i)]).fold(0.0f64, f64::max).max(1e-30);
        let mut improved = false;
        let mut stop = false;
        let mut rejections = 0;
        let mut updates: Vec<(Vec<f64>, Vec<f64>)> = Vec::new();
        while lambda < 1e8 {
            let mut m = a.clone();
            for i in 0..p {
                m[(i, i)] += lambda * (a[(i, i)] + 1e-9 * maxd);
            }
            let Some(step) = m.cholesky().map(|c| c.solve(&(-&g))) else {
                lambda *= 10.0;
                continue;
            };
            let xn: Vec<f64> = (0..p)
                .map(|i| (x[i] + step[i] * sc[i]).clamp(bounds[i].lo, bounds[i].hi))
                .collect();
            if xn.iter().zip(&x).all(|(a, b)| a == b) {
                stop = true;
                break;
            }
            evaluations += 1;
            if let Some(rn) = f(&xn) {
                if broyden {
                    let dx: Vec<f64> = xn.iter().zip(&x).map(|(a, b)| a - b).collect();
                    let dr: Vec<f64> = rn.iter().zip(&r).map(|(a, b)| a - b).collect();
                    updates.push((dx, dr));
                }
                let cn = cost_of(&rn);
                let tn = cn + prior_cost(&xn, bounds);
                if tn < total {
                    let rel = (total - tn) / total.max(1e-300);
                    x = xn;
                    r = rn;
                    cost = cn;
                    total = tn;
                    lambda = (lambda / 5.0).max(1e-7);
                    improved = true;
                    if rel < opts.rel_tol {
                        stop = true;
                    }
                    break;
                }
            }
            lambda *= 6.0;
            rejections += 1;
            if broyden && !fresh && rejections >= 2 {
                break;
            }
        }
        if broyden {
            for (dx, dr) in &updates {
                broyden_update(j, dx, dr, &sc);
            }
            if !updates.is_empty() {
                normal = None;
            }
            fresh = false;
        }
        if !improved {
            // An updated Jacobian that no longer descends: take a fresh one once more.
            if broyden && refreshes < 2 && !stop {
                jac = None;
                refreshes += 1;
                lambda = 1e-3;
                continue;
            }
            converged = true;
            break;
        }
        if stop {
            converged = true;
            break;
        }
    }
    Some(LmResult {
        x,
        cost,
        cost0,
        n_res: n,
        jacobian: jac,
        residuals: r,
        iterations,
        evaluations,
        converged,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fits_a_bounded_exponential() {
        // y = a·exp(−b t) with a = 2, b = 0.7; b bounded to [0, 0.5] → converges to the bound.
        let t: Vec<f64> = (0..50).map(|k| k as f64 * 0.1).collect();
        let y: Vec<f64> = t.iter().map(|x| 2.0 * (-0.7 * x).exp()).collect();
        let f = |p: &[f64]| -> Option<Vec<f64>> {
            Some(
                t.iter()
                    .zip(&y)
                    .map(|(x, yy)| p[0] * (-p[1] * x).exp() - yy)
                    .collect(),
            )
        };
        let free = [
            Bound {
                lo: 0.0,
                hi: 10.0,
                scale: 0.1,
                prior: None,
            },
            Bound {
                lo: 0.0,
                hi: 2.0,
                scale: 0.05,
                prior: None,
            },
        ];
        let r = minimize(
            &f,
            &[1.0, 0.2],
            &free,
            &LmOptions {
                max_iter: 50,
                threads: 2,
                rel_tol: 1e-12,
                fd_fraction: 0.01,
            },
        )
        .unwrap();
        assert!(
            (r.x[0] - 2.0).abs() < 1e-4 && (r.x[1] - 0.7).abs() < 1e-4,
            "{:?}",
            r.x
        );
        assert!(r.cost < 1e-8);
        let bounded = [
            free[0],
            Bound {
                lo: 0.0,
                hi: 0.5,
                scale: 0.05,
                prior: None,
            },
        ];
        let r = minimize(
            &f,
            &[1.0, 0.2],
            &bounded,
            &LmOptions {
                max_iter: 50,
                ..Default::default()
            },
        )
        .unwrap();
        assert!((r.x[1] - 0.5).abs() < 1e-9, "{:?}", r.x);
        assert!(r.std_devs(1.0).iter().all(|s| s.is_finite()));
    }
}
