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
//!    a cosine above [`CATALOG_COSINE`] with a catalog candidate's equation-error
//!    signature is that effect's signature, reported under the effect, not as a new term.
//! 4. **Simulation screening.** Each shortlisted term's sensitivity in simulation error
//!    (multiple shooting on the training runs, its DOF's channels at noise weight), with
//!    the base parameters' sensitivities projected out, gives its linearised gain and
//!    ΔBIC; the best of each DOF go on first, ranked by the share of the residual they
//!    explain.
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
/// Most terms confirmed per search round.
pub const MAX_CONFIRM: usize = 3;

/// The equation-error data of one DOF.
struct DofData {
    dof: usize,
    /// Mean residual force per window (N or N m).
    y: Vec<f64>,
    /// Base-parameter sensitivities of the same (columns).
    base: Vec<Vec<f64>>,
    /// Library columns: mean regressor per window.
    lib: Vec<(TermKind, Vec<f64>)>,
    /// Catalog candidates' signatures: (effect, column).
    catalog: Vec<(EffectId, Vec<f64>)>,
    /// Window → run index (bootstrap blocks).
    block: Vec<usize>,
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

/// The state at each sample: measured where measured (or derived), modelled elsewhere.
fn measured_state(run: &Run, sim: &[SampleState], k: usize, active: &[bool; 6]) -> ModelState {
    let mut s = sim.get(k).map_or_else(ModelState::default, |x| x.state);
    let val = |ch: Channel| -> Option<f64> {
        run.smooth[ch_index(ch)]
            .as_ref()
            .and_then(|v| v.get(k))
            .copied()
            .filter(|x| x.is_finite())
    };
    let slope = |ch: Channel| -> Option<f64> {
        let y = run.channel(ch)?;
        local_quadratic(&run.t, y, k, SLOPE_HALF_WINDOW_S, SLOPE_HALF_WINDOW_S)
            .map(|(_, b)| b)
            .filter(|x| x.is_finite())
    };
    if let Some(z) = val(Channel::Depth) {
        s.eta[2] = z;
    }
    if let Some(h) = val(Channel::Heading) {
        s.eta[5] = h.to_radians();
    }
    if active[4]
        && let Some(p) = val(Channel::Pitch)
    {
        s.eta[4] = p.to_radians();
    }
    if active[3]
        && let Some(r) = val(Channel::Roll)
    {
        s.eta[3] = r.to_radians();
    }
    for (ch, i, deg) in [
        (Channel::Surge, 0, false),
        (Channel::Sway, 1, false),
        (Channel::Heave, 2, false),
        (Channel::RollRate, 3, true),
        (Channel::PitchRate, 4, true),
        (Channel::YawRate, 5, true),
    ] {
        if active[i]
            && let Some(v) = val(ch)
        {
            s.nu[i] = if deg { v.to_radians() } else { v };
        }
    }
    // Rates the sensors do not give: from the slopes through the kinematics, inverted in
    // closed form (q = θ̇ cφ + ψ̇ cθ sφ, r = ψ̇ cθ cφ − θ̇ sφ, p = φ̇ − ψ̇ sθ), with the
    // Euler rates of unmeasured angles taken from the model's own trajectory.
    let (phi, th) = (s.eta[3], s.eta[4]);
    let (sp, cp, st, ct) = (phi.sin(), phi.cos(), th.sin(), th.cos());
    let [p0, q0, r0] = [s.nu[3], s.nu[4], s.nu[5]];
    let mut euler = [
        p0 + (q0 * sp + r0 * cp) * th.tan(),
        q0 * cp - r0 * sp,
        (q0 * sp + r0 * cp) / if ct.abs() < 1e-3 { 1e-3 } else { ct },
    ];
    for (i, ch, on) in [
        (0, Channel::Roll, active[3]),
        (1, Channel::Pitch, active[4]),
        (2, Channel::Heading, active[5]),
    ] {
        if on && let Some(d) = slope(ch) {
            euler[i] = d.to_radians();
        }
    }
    let [dphi, dth, dpsi] = euler;
    let body = [
        dphi - dpsi * st,
        dth * cp + dpsi * ct * sp,
        dpsi * ct * cp - dth * sp,
    ];
    for (i, ch) in [
        (3, Channel::RollRate),
        (4, Channel::PitchRate),
        (5, Channel::YawRate),
    ] {
        if active[i] && run.channel(ch).is_none() && body[i - 3].is_finite() {
            s.nu[i] = body[i - 3];
        }
    }
    // Heave from the depth rate (ż = −u sθ + v cθ sφ + w cθ cφ), where it is well posed.
    if active[2]
        && run.channel(Channel::Heave).is_none()
        && (ct * cp).abs() >= 0.3
        && let Some(zd) = slope(Channel::Depth)
    {
        s.nu[2] = (zd + s.nu[0] * st - s.nu[1] * ct * sp) / (ct * cp);
    }
    s
}

/// Which DOFs have an observed velocity (measured or derived) in the runs.
fn observed_dofs(model: &LabModel, runs: &[Run]) -> Vec<usize> {
    let active = model.nu_active();
    let has = |c: Channel| runs.iter().any(|r| r.has(c));
    let mut out = Vec::new();
    let obs = [
        has(Channel::Surge),
        has(Channel::Sway),
        has(Channel::Heave) || has(Channel::Depth),
        has(Channel::RollRate) || has(Channel::Roll),
        has(Channel::PitchRate) || has(Channel::Pitch),
        has(Channel::YawRate) || has(Channel::Heading),
    ];
    for i in 0..6 {
        if active[i] && obs[i] {
            out.push(i);
        }
    }
    out
}

/// ν̇ of the model at a state with the command of sample `k` and the lag/filter states.
fn nu_dot(model: &LabModel, st: &ModelState, run: &Run, k: usize, s: &SampleState) -> Vector6 {
    let f = model.thrusts(&s.lagged);
    let signals = model.command_signals(&run.inputs[k]);
    let tau = model.thrust_tau(&f, st) + model.terms_tau(st, &signals, &s.filt);
    model
        .eta_nu_derivative(&st.eta, &st.nu, &tau, &CurrentSample::none())
        .1
}

/// The effective inverse inertia ∂ν̇_j/∂τ_j of each DOF at a state.
fn inverse_inertia(model: &LabModel, st: &ModelState) -> [f64; 6] {
    let base = model
        .eta_nu_derivative(&st.eta, &st.nu, &Vector6::zeros(), &CurrentSample::none())
        .1;
    let mut out = [0.0; 6];
    for (j, o) in out.iter_mut().enumerate() {
        let mut tau = Vector6::zeros();
        tau[j] = 1.0;
        let d = model
            .eta_nu_derivative(&st.eta, &st.nu, &tau, &CurrentSample::none())
            .1;
        *o = d[j] - base[j];
    }
    out
}

/// Equation-error windows of one run: (start, end) sample indices.
fn windows_of(run: &Run) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let n = run.len();
    let mut a = 0;
    while a + 1 < n {
        let t_end = run.t[a] + WINDOW_S;
        let mut b = a + 1;
        while b + 1 < n && run.t[b] < t_end - 1e-9 {
            b += 1;
        }
        if run.t[b] - run.t[a] >= 0.5 * WINDOW_S {
            out.push((a, b));
        }
        let t_next = run.t[a] + 0.5 * WINDOW_S;
        let mut a2 = a + 1;
        while a2 + 1 < n && run.t[a2] < t_next - 1e-9 {
            a2 += 1;
        }
        if b + 1 >= n {
            break;
        }
        a = a2;
    }
    out
}

/// Samples between the grid points of the weak-form integrals.
pub const INTEGRAL_STRIDE: usize = 4;

/// A command change larger than this (percentage points in one sample) is a step.
pub const STEP_PCT: f64 = 10.0;

/// The equation-error windows of a run away from command steps: a rate derived by a
/// local fit smooths the step in acceleration over ±[`SLOPE_HALF_WINDOW_S`], and windows
/// that see it measure the smoothing, not the physics. Windows within that half-width of
/// a step are dropped, unless that would drop most of the run (frequent steps: all are
/// kept).
fn steady_windows(run: &Run) -> Vec<(usize, usize)> {
    let all = windows_of(run);
    let steps: Vec<f64> = (1..run.len())
        .filter(|&k| {
            run.inputs[k]
                .iter()
                .zip(&run.inputs[k - 1])
                .any(|(a, b)| (a - b).abs() > STEP_PCT)
        })
        .map(|k| run.t[k])
        .collect();
    let near = |a: usize, b: usize| {
        let (ta, tb) = (
            run.t[a] - SLOPE_HALF_WINDOW_S,
            run.t[b] + SLOPE_HALF_WINDOW_S,
        );
        steps.iter().any(|t| *t >= ta && *t <= tb)
    };
    let kept: Vec<(usize, usize)> = all.iter().copied().filter(|(a, b)| !near(*a, *b)).collect();
    if kept.len() * 2 >= all.len() {
        kept
    } else {
        all
    }
}

/// The equation-error data of a model on runs.
fn equation_error(
    model: &LabModel,
    runs: &[Run],
    base_free: &[Param],
    catalog: &[(EffectId, Vec<Param>)],
) -> Result<(Vec<DofData>, [f64; 6]), LabError> {
    let dofs = observed_dofs(model, runs);
    let active = model.nu_active();
    let names = model.command_names();
    let lib = library(&dofs, &active, names.len());
    let mut data: Vec<DofData> = dofs
        .iter()
        .map(|d| DofData {
            dof: *d,
            y: Vec::new(),
            base: vec![Vec::new(); base_free.len()],
            lib: lib
                .iter()
                .filter(|(dd, _)| *dd as usize == *d)
                .map(|(_, k)| (*k, Vec::new()))
                .collect(),
            catalog: catalog.iter().map(|(e, _)| (*e, Vec::new())).collect(),
            block: Vec::new(),
        })
        .collect();
    // Perturbed models for the base and catalog sensitivities.
    let perturb = |p: Param| -> Option<(LabModel, f64)> {
        let v0 = model.get(p).or_else(|| p.off_value())?;
        let step = match p.off_value() {
            Some(off) if (v0 - off).abs() < 1e-12 => p.probe_value() - off,
            _ => p.meta().scale,
        };
        let step = if step.abs() < 1e-12 {
            p.meta().scale
        } else {
            step
        };
        model.with(&[p], &[v0 + step]).ok().map(|m| (m, step))
    };
    let base_models: Vec<Option<(LabModel, f64)>> = base_free.iter().map(|p| perturb(*p)).collect();
    let cat_models: Vec<Vec<(LabModel, f64)>> = catalog
        .iter()
        .map(|(e, ps)| {
            let mut m = model.clone();
            m.add_effect(*e);
            ps.iter()
                .filter_map(|p| {
                    let v0 = m.get(*p).or_else(|| p.off_value())?;
                    let step = match p.off_value() {
                        Some(off) => p.probe_value() - off,
                        None => p.meta().scale,
                    };
                    m.with(&[*p], &[v0 + step]).ok().map(|x| (x, step))
                })
                .collect()
        })
        .collect();
    let mut inv_inertia = [0.0; 6];
    let mut have_inertia = false;
    for (ri, run) in runs.iter().enumerate() {
        let sim = simulate_states(
            model,
            run,
            &View::Shooting(crate::calibrate::SHOOTING_WINDOW_S).resets(run),
        )?;
        let states: Vec<ModelState> = (0..run.len())
            .map(|k| measured_state(run, &sim, k, &active))
            .collect();
        if !have_inertia && let Some(s0) = states.first() {
            inv_inertia = inverse_inertia(model, s0);
            have_inertia = true;
        }
        // The windows, and the grid the weak-form integrals run on: every
        // [`INTEGRAL_STRIDE`]-th sample inside a window (the integrands are smooth between
        // command steps, which the windows avoid).
        let wins = steady_windows(run);
        let n = run.len();
        let mut on_grid = vec![false; n];
        for (a, b) in &wins {
            let mut k = *a;
            while k < *b {
                on_grid[k] = true;
                k += INTEGRAL_STRIDE;
            }
        }
        // Model acceleration at a grid point, averaged over its interval (trapezoid,
        // command of the interval's start).
        let acc = |m: &LabModel, k: usize| -> Vector6 {
            let s = &sim[k];
            let k1 = (k + INTEGRAL_STRIDE).min(n.saturating_sub(1));
            0.5 * (nu_dot(m, &states[k], run, k, s) + nu_dot(m, &states[k1], run, k, s))
        };
        let grid_acc = |m: &LabModel| -> Vec<Vector6> {
            (0..n)
                .map(|k| {
                    if on_grid[k] {
                        acc(m, k)
                    } else {
                        Vector6::zeros()
                    }
                })
                .collect()
        };
        let a0: Vec<Vector6> = grid_acc(model);
        let a_base: Vec<Option<Vec<Vector6>>> = base_models
            .iter()
            .map(|bm| bm.as_ref().map(|(m, _)| grid_acc(m)))
            .collect();
        let a_cat: Vec<Vec<Vec<Vector6>>> = cat_models
            .iter()
            .map(|ms| ms.iter().map(|(m, _)| grid_acc(m)).collect())
            .collect();
        // Regressors per sample.
        let theta = |kind: &TermKind, k: usize, kc: usize| -> f64 {
            let sig = model.command_signals(&run.inputs[kc]);
            let s = &sim[k.min(sim.len().saturating_sub(1))];
            kind.value(&TermInputs {
                eta: &states[k].eta,
                nu: &states[k].nu,
                cmd: &sig,
                filt: &s.filt,
            })
        };
        for &(a, b) in &wins {
            let grid: Vec<usize> = (a..b).step_by(INTEGRAL_STRIDE).collect();
            // The last grid interval ends at the window's end.
            let hk = |k: usize| -> f64 {
                let k1 = (k + INTEGRAL_STRIDE).min(b);
                run.t[k1] - run.t[k]
            };
            let len: f64 = run.t[b] - run.t[a];
            if len <= 0.0 {
                continue;
            }
            for d in &mut data {
                let j = d.dof;
                let (va, vb) = (states[a].nu[j], states[b].nu[j]);
                if !(va.is_finite() && vb.is_finite()) || inv_inertia[j].abs() < 1e-12 {
                    continue;
                }
                let m_eff = 1.0 / inv_inertia[j];
                let integral = |acc: &[Vector6]| -> f64 {
                    grid.iter().map(|&k| acc[k][j] * hk(k)).sum::<f64>()
                };
                let model_change = integral(&a0);
                let y = m_eff * ((vb - va) - model_change) / len;
                if !y.is_finite() {
                    continue;
                }
                d.y.push(y);
                d.block.push(ri);
                for (bi, col) in d.base.iter_mut().enumerate() {
                    let v = match (&a_base[bi], &base_models[bi]) {
                        (Some(ab), Some((_, step))) => {
                            m_eff * (integral(ab) - model_change) / len / step
                        }
                        _ => 0.0,
                    };
                    col.push(v);
                }
                for (ci, (_, col)) in d.catalog.iter_mut().enumerate() {
                    // The effect's combined signature: the sum over its parameters.
                    let mut v = 0.0;
                    for (pi, ab) in a_cat[ci].iter().enumerate() {
                        if let Some((_, step)) = cat_models[ci].get(pi) {
                            v +=
                                m_eff * (integral(ab) - model_change) / len / step.abs().max(1e-12);
                        }
                    }
                    col.push(v);
                }
                for (kind, col) in &mut d.lib {
                    let v: f64 = grid
                        .iter()
                        .map(|&k| {
                            let k1 = (k + INTEGRAL_STRIDE).min(b);
                            0.5 * (theta(kind, k, k) + theta(kind, k1, k)) * hk(k)
                        })
                        .sum::<f64>()
                        / len;
                    col.push(v);
                }
            }
        }
    }
    Ok((data, inv_inertia))
}

/// Residual of y after least squares on the columns (small ridge), and the coefficients.
fn ls(y: &[f64], cols: &[&Vec<f64>]) -> (Vec<f64>, Vec<f64>) {
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

fn rss(r: &[f64]) -> f64 {
    r.iter().map(|x| x * x).sum()
}

/// Forward selection of library columns (`lib0`, the base projected out of each) on the
/// residual `y0` (the base projected out), over the rows `rows`: indices of the picked
/// columns with their ΔBIC. Each step orthogonalises the candidates against the picks
/// (Gram–Schmidt), so a step costs one pass over the columns.
fn forward_select(
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
fn splitmix(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Searches the library for terms that explain the residual generalised force of the
/// current model on the training runs.
pub(super) fn search(
    model: &LabModel,
    train: &[Run],
    base_free: &[Param],
    catalog: &[(EffectId, Vec<Param>)],
    scales: &ViewScales,
    base_cols: &ColumnCache,
    threads: usize,
) -> Result<(Vec<TermPick>, SearchNotes), LabError> {
    let fixed = crate::verdict::fixed_uncertain(model, base_free);
    let (data, _) = equation_error(model, train, base_free, catalog)?;
    let names = model.command_names();
    let mut notes = SearchNotes::default();
    // Stage 1: the shortlist from the equation error.
    let mut shortlist: Vec<(Term, f64)> = Vec::new();
    for d in &data {
        let n = d.y.len();
        if n < 30 {
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
            // A catalog effect's signature in disguise?
            let lc = &lib0[i];
            let catalog_like = d
                .catalog
                .iter()
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
        jacobian_cols(model, &obj, &r0, &fixed, &steps, threads)
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
    type Home = (u8, Vec<f64>, Vec<f64>, f64, NullFit);
    let mut homes: Vec<Home> = Vec::new();
    for dof in shortlist.iter().map(|(t, _)| t.dof) {
        if homes.iter().any(|(d, ..)| *d == dof) {
            continue;
        }
        let cs = candidate_scales(&term_home(dof), scales.of(view));
        let r0 = Objective::scaled(model, train, view, &cs).residuals(model)?;
        let f = crate::calibrate::row_factors(model, train, view, scales.of(view), &cs);
        let base: Vec<Vec<f64>> = base_free
            .iter()
            .filter_map(|p| base_cols.get(p))
            .chain(fixed_cols.iter().flatten())
            .filter(|c| c.len() == r0.len())
            .map(|c| match &f {
                Some(f) if f.len() == c.len() => c.iter().zip(f).map(|(a, b)| a * b).collect(),
                _ => c.clone(),
            })
            .collect();
        let null = NullFit::new(base, &lambda);
        let r0p = null.residual(&r0);
        let n_eff = effective_n(&r0p, r0p.len().max(2));
        homes.push((dof, r0, r0p, n_eff, null));
    }
    let gains: Vec<Option<TermPick>> = par_map(shortlist.len(), threads, |i| {
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
        let c = null.residual(&c);
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
    // Only terms that explain a real share, and a fair part of what the best explains,
    // go on to confirmation (the catalog's screening gates).
    let best = picks.first().map_or(0.0, |p| p.explained);
    picks.retain(|p| {
        p.explained >= MIN_SCREEN_EXPLAINED && p.explained >= RELATIVE_SCREEN_GATE * best
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
    cols: DMatrix<f64>,
    /// (BᵀB + Λ)⁻¹, `None` when there are no columns or the system is singular.
    inv: Option<DMatrix<f64>>,
}

impl NullFit {
    fn new(cols: Vec<Vec<f64>>, lambda: &[f64]) -> Self {
        let n = cols.first().map_or(0, |c| c.len());
        let p = cols.len();
        let mut b = DMatrix::zeros(n, p);
        for (j, c) in cols.iter().enumerate() {
            for (i, v) in c.iter().enumerate() {
                b[(i, j)] = *v;
            }
        }
        let mut a = b.transpose() * &b;
        let maxd = (0..p).map(|i| a[(i, i)]).fold(0.0f64, f64::max).max(1e-300);
        for i in 0..p {
            a[(i, i)] += 1e-9 * maxd + lambda.get(i).copied().unwrap_or(0.0);
        }
        let inv = if p == 0 { None } else { a.try_inverse() };
        NullFit { cols: b, inv }
    }

    /// v minus its null fit.
    fn residual(&self, v: &[f64]) -> Vec<f64> {
        let Some(inv) = &self.inv else {
            return v.to_vec();
        };
        if self.cols.nrows() != v.len() {
            return v.to_vec();
        }
        let vv = DVector::from_column_slice(v);
        let coef = inv * (self.cols.transpose() * &vv);
        let fit = &self.cols * coef;
        v.iter().zip(fit.iter()).map(|(a, b)| a - b).collect()
    }
}

/// Library terms shortlisted per DOF by their single-term share of the equation error
/// (besides the forward selection's stable picks).
pub const SHORTLIST_PER_DOF: usize = 8;

/// Block-bootstrap inclusion probability of every library column in the forward
/// selection (E-SINDy; blocks of 20 windows within runs).
fn bootstrap_inclusion(d: &DofData, y0: &[f64], lib0: &[Vec<f64>], ratio: f64) -> Vec<f64> {
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

/// The equation-error pick of one named term (`term:DOF:SLUG`): its coefficient from the
/// least-squares fit of the residual generalised force on the base and this term alone
/// (the start of its confirmation, as a search pick is).
pub(super) fn regress_one(
    model: &LabModel,
    train: &[Run],
    base_free: &[Param],
    id: &str,
) -> Result<TermPick, LabError> {
    let names = model.command_names();
    let lib = library(&[0, 1, 2, 3, 4, 5], &model.nu_active(), names.len());
    let Some((dof, kind)) = crate::terms::parse_term_id(id, &lib, &names) else {
        return Err(LabError::UnknownEffect {
            name: format!(
                "{id} (a discovered term is term:DOF:SLUG, e.g. term:heave:r_2, with DOF one of {} and the terms of this model's library)",
                DOF_NAMES.join(", ")
            ),
        });
    };
    let (data, _) = equation_error(model, train, base_free, &[])?;
    let Some(d) = data.iter().find(|d| d.dof == dof as usize) else {
        return Err(LabError::Data {
            run: train.first().map(|r| r.name.clone()).unwrap_or_default(),
            detail: format!(
                "{id}: the data does not observe {} (no measurement of its velocity or position)",
                DOF_NAMES.get(dof as usize).copied().unwrap_or("?")
            ),
        });
    };
    let Some((_, col)) = d.lib.iter().find(|(k, _)| *k == kind) else {
        return Err(LabError::UnknownEffect { name: id.into() });
    };
    let mut cols: Vec<&Vec<f64>> = d.base.iter().collect();
    cols.push(col);
    let (_, coef) = ls(&d.y, &cols);
    let c = coef.last().copied().unwrap_or(0.0);
    let rms = (col.iter().map(|x| x * x).sum::<f64>() / col.len().max(1) as f64).sqrt();
    Ok(TermPick {
        term: Term {
            dof,
            kind,
            coef: if c.is_finite() { c } else { 0.0 },
            scale: if rms > 0.0 { rms } else { 1.0 },
        },
        explained: 0.0,
        dbic: 0.0,
        inclusion: 1.0,
    })
}

/// The largest generalised force the thrusters can produce on each DOF (single thrusters
/// and commands at ±100 %), N or N m.
fn thrust_capability(model: &LabModel) -> [f64; 6] {
    use rov_dynamics::models::vehicle::N_COMMANDS;
    let mut cap = [0.0f64; 6];
    for c in model.command_channels() {
        for sign in [-100.0, 100.0] {
            let mut cmd = [0.0; N_COMMANDS];
            cmd[c.index()] = sign;
            let f = model.thrusts(&model.thruster_targets(&cmd));
            let tau = model.thrust_tau(&f, &ModelState::default());
            for (j, cj) in cap.iter_mut().enumerate() {
                *cj = cj.max(tau[j].abs());
            }
        }
    }
    cap
}

/// Confirms a picked term in simulation error and judges it on the held-out runs.
#[allow(clippy::too_many_arguments)]
pub(super) fn confirm_term(
    model: &LabModel,
    base_eval: &Evaluation,
    train: &[Run],
    val: &[Run],
    base_free: &[Param],
    pick: &TermPick,
    iterations: usize,
    scales: &ViewScales,
    closed_loop: bool,
) -> Result<(Confirmed, Judgement), LabError> {
    let view = View::Shooting(crate::calibrate::SHOOTING_WINDOW_S);
    let mut with_term = model.clone();
    let idx = with_term.add_term(Term {
        coef: 0.0,
        ..pick.term
    });
    let p = Param::TermCoef(idx as u8, pick.term.rotational());
    let mut free: Vec<Param> = base_free.to_vec();
    free.push(p);
    let home = term_home(pick.term.dof);
    let cs = candidate_scales(&home, scales.of(view));
    let obj = Objective::scaled(model, train, view, &cs);
    let cost_of = |m: &LabModel| -> f64 {
        obj.residuals(m)
            .map(|r| r.iter().map(|x| x * x).sum())
            .unwrap_or(f64::INFINITY)
    };
    let base_cost = cost_of(model);
    let bounds = effect_bounds(model, &free, &[p], base_free);
    let opts = LmOptions {
        max_iter: iterations * 2,
        threads: 1,
        ..Default::default()
    };
    let mut best: Option<crate::calibrate::Calibration> = None;
    for start in [pick.term.coef * pick.term.scale, 0.0] {
        let Ok(m0) = with_term.with(&[p], &[start]) else {
            continue;
        };
        let Ok(f) = fit_scaled(
            &m0,
            train,
            &free,
            view,
            None,
            Some(bounds.clone()),
            &opts,
            None,
            &cs,
        ) else {
            continue;
        };
        if best.as_ref().is_none_or(|b| f.cost < b.cost) {
            best = Some(f);
        }
    }
    let Some(fit) = best else {
        return Err(LabError::Model {
            detail: format!(
                "term {}: no start could be fitted",
                pick.term.kind.formula(&model.command_names())
            ),
        });
    };
    let eval = evaluate(&fit.model, val)?;
    let control = fit
        .model
        .with(&[p], &[0.0])
        .ok()
        .and_then(|m| evaluate(&m, val).ok());
    let n_eff = fit.n_eff;
    let dbic = n_eff * (base_cost / fit.cost.max(1e-300)).max(1.0).ln() - n_eff.ln();
    let fitted_term = fit.model.terms().get(idx).copied().unwrap_or(pick.term);
    // Plausibility: no more force at the term's typical size than twice the thrusters'
    // own capability on that DOF (or 5 % of the weight on a DOF no thruster drives).
    let cap = thrust_capability(model);
    let w = model.weight_n();
    let limit = (2.0 * cap[pick.term.dof as usize])
        .max(0.05 * w * if pick.term.rotational() { 0.1 } else { 1.0 });
    let force = (fitted_term.coef * fitted_term.scale).abs();
    let signature_failed = (force > limit).then(|| {
        format!(
            "its fitted size ({force:.2} {} at the term's typical value) exceeds twice what the thrusters can produce on {} ({:.2} {}): physically implausible, it stands in for something else",
            fitted_term.force_unit(),
            DOF_NAMES.get(fitted_term.dof as usize).copied().unwrap_or("?"),
            cap[pick.term.dof as usize],
            fitted_term.force_unit()
        )
    });
    let c = Confirmed {
        subject: Subject::Term(fitted_term),
        contained: false,
        params: vec![p],
        base_fit: base_free.to_vec(),
        fit,
        eval,
        control,
        dbic,
        view,
        signature_failed,
    };
    let j = judge(base_eval, &c, closed_loop);
    Ok((c, j))
}

/// What known physics a term resembles.
pub(super) fn resemblance(t: &Term) -> &'static str {
    let dof = t.dof;
    match t.kind {
        TermKind::Lin(_) => {
            "cross-coupled linear damping (the centre of drag is off the body origin, or a lifting surface)"
        }
        TermKind::ProdAbs(Sig::Nu(a), Sig::Nu(b)) if a == b && a == dof => {
            "a quadratic drag on its own DOF (already in the base; a calibration problem)"
        }
        TermKind::ProdAbs(Sig::Nu(_), Sig::Nu(_)) => {
            "cross-coupled drag (flow along one axis loading another)"
        }
        TermKind::ProdAbs(_, _) => "a thruster interaction that depends on the flow",
        TermKind::Prod(Sig::Nu(a), Sig::Nu(b)) if a == b && a < 3 && dof == 2 => {
            "a hydrodynamic lift growing with the square of the speed"
        }
        TermKind::Prod(Sig::Nu(a), Sig::Nu(b)) if a == b && a >= 3 => {
            "a centrifugal or lift force while rotating (grows with the square of the rate)"
        }
        TermKind::Prod(Sig::Nu(a), Sig::Nu(b)) if a == b => "a drag that differs with direction",
        TermKind::Prod(Sig::Nu(a), Sig::Nu(b)) if (a < 3) != (b < 3) => {
            "a Coriolis/centripetal or added-mass (Munk) coupling"
        }
        TermKind::Prod(_, _) => "a coupling between two velocities (added-mass or lift)",
        TermKind::Cube(_) => "speed-dependent (cubic) damping",
        TermKind::Cmd(_) | TermKind::CmdSq(_) => {
            "a thruster interaction: thrust leaking into this DOF (a misaligned thruster or its wash on the hull)"
        }
        TermKind::CmdVel(_, _) => {
            "thrust that changes with the inflow speed (the propeller's advance ratio)"
        }
        TermKind::Filtered(_, _) => {
            "a slow thruster or wake dynamic (a force that lags the command)"
        }
        TermKind::Sin(crate::terms::Angle::Heading)
        | TermKind::Cos(crate::terms::Angle::Heading) => {
            "a heading-dependent pull (a tether or a current)"
        }
        TermKind::Sin(_) | TermKind::Cos(_) => "a restoring or trim moment (a CG/CB offset)",
        TermKind::Const => "a constant force or moment (buoyancy, trim or a steady pull)",
    }
}

/// Plain-language explanation of a discovered term.
pub(super) fn explain_term(c: &Confirmed, t: &Term, model: &LabModel, tail: &str) -> String {
    let names = model.command_names();
    let std = c
        .fit
        .fitted
        .iter()
        .zip(&c.fit.params)
        .find(|(_, p)| matches!(p, Param::TermCoef(..)))
        .map(|(f, _)| f.std / t.scale.max(1e-300));
    let ci = std
        .filter(|s| s.is_finite())
        .map(|s| format!(" ± {:.3}", 1.96 * s))
        .unwrap_or_default();
    format!(
        "{} ∝ {}: coefficient {:.4}{ci} {} per {} (95 % interval), {:.3} {} at its typical size; resembles {}{tail}",
        DOF_FORCE.get(t.dof as usize).copied().unwrap_or("force"),
        t.kind.formula(&names),
        t.coef,
        t.force_unit(),
        t.kind.regressor_unit(),
        t.coef * t.scale,
        t.force_unit(),
        resemblance(t)
    )
}
