//! Stage 1 of the term search: the equation error — the residual generalised force per
//! window from the measured (or modelled) states, with the base sensitivities, the library
//! columns and the catalog signatures on the same windows.

use super::*;

/// The state at each sample: measured where measured (or derived), modelled elsewhere.
pub(super) fn measured_state(
    run: &Run,
    sim: &[SampleState],
    k: usize,
    active: &[bool; 6],
) -> ModelState {
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
    // Depth and heading always; the other channels where their DOF is active (the
    // measurement → state table is `Channel::set_value`; positions are not used).
    for (ch, on) in [
        (Channel::Depth, true),
        (Channel::Heading, true),
        (Channel::Pitch, active[4]),
        (Channel::Roll, active[3]),
        (Channel::Surge, active[0]),
        (Channel::Sway, active[1]),
        (Channel::Heave, active[2]),
        (Channel::RollRate, active[3]),
        (Channel::PitchRate, active[4]),
        (Channel::YawRate, active[5]),
    ] {
        if on && let Some(v) = val(ch) {
            ch.set_value(&mut s, v);
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
pub(super) fn observed_dofs(model: &LabModel, runs: &[Run]) -> Vec<usize> {
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
pub(super) fn nu_dot(
    model: &LabModel,
    st: &ModelState,
    run: &Run,
    k: usize,
    s: &SampleState,
) -> Vector6 {
    let f = model.thrusts(&s.lagged);
    let signals = model.command_signals(&run.inputs[k]);
    let tau = model.thrust_tau(&f, st) + model.terms_tau(st, &signals, &s.filt);
    model
        .eta_nu_derivative(&st.eta, &st.nu, &tau, &CurrentSample::none())
        .1
}

/// The effective inverse inertia ∂ν̇_j/∂τ_j of each DOF at a state.
pub(super) fn inverse_inertia(model: &LabModel, st: &ModelState) -> [f64; 6] {
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
pub(super) fn windows_of(run: &Run) -> Vec<(usize, usize)> {
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
pub(super) fn steady_windows(run: &Run) -> Vec<(usize, usize)> {
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
pub(super) fn equation_error(
    model: &LabModel,
    runs: &[Run],
    base_free: &[Param],
    catalog: &[(EffectId, Vec<Param>)],
) -> Result<(Vec<DofData>, [f64; 6]), LabError> {
    let dofs = observed_dofs(model, runs);
    let active = model.nu_active();
    let names = model.command_names();
    let lib = library(&dofs, &active, names.len(), &quad_calibrated(base_free));
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
