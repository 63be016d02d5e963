//! One named term regressed on its own (`lab add --terms`), a term confirmed in
//! simulation on the held-out runs, and its physical reading.

use super::*;

/// The equation-error pick of one named term (`term:DOF:SLUG`): its coefficient from the
/// least-squares fit of the residual generalised force on the base and this term alone
/// (the start of its confirmation, as a search pick is).
pub(in crate::diagnose) fn regress_one(
    model: &LabModel,
    train: &[Run],
    base_free: &[Param],
    id: &str,
) -> Result<TermPick, LabError> {
    let names = model.command_names();
    let lib = library(
        &[0, 1, 2, 3, 4, 5],
        &model.nu_active(),
        names.len(),
        &quad_calibrated(base_free),
    );
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
pub(in crate::diagnose) fn confirm_term(
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
        )
        .map(crate::calibrate::Calibration::lean) else {
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
    // A coefficient whose 95 % interval contains zero is not a finding, whatever the
    // held-out gain (the gain then comes from the base refit around it).
    let ci_spans_zero = fit
        .fitted
        .iter()
        .zip(&fit.params)
        .find(|(_, q)| **q == p)
        .and_then(|(f, _)| interval_refusal(f, fitted_term.force_unit()));
    let signature_failed = (force > limit).then(|| {
        format!(
            "its fitted size ({force:.2} {} at the term's typical value) exceeds twice what the thrusters can produce on {} ({:.2} {}): physically implausible, it stands in for something else",
            fitted_term.force_unit(),
            DOF_NAMES.get(fitted_term.dof as usize).copied().unwrap_or("?"),
            cap[pick.term.dof as usize],
            fitted_term.force_unit()
        )
    });
    let signature_failed = signature_failed.or(ci_spans_zero);
    let ran_out = !fit.lm.converged;
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
        ran_out,
    };
    let j = judge(base_eval, &c, closed_loop);
    Ok((c, j))
}

/// Why a term's fitted coefficient is not a finding when its 95 % interval (±1.96 σ)
/// contains zero or is unknown (a non-finite σ); `None` when it excludes zero.
pub(in crate::diagnose) fn interval_refusal(
    f: &crate::calibrate::FittedParam,
    unit: &str,
) -> Option<String> {
    let half = 1.96 * f.std;
    let excludes_zero = half.is_finite() && f.value.is_finite() && f.value.abs() > half;
    (!excludes_zero).then(|| {
        format!(
            "its coefficient's 95 % interval contains zero ({:.3} ± {:.3} {unit} at the term's typical value): the data do not show it",
            f.value, half
        )
    })
}

/// What known physics a term resembles.
pub(in crate::diagnose) fn resemblance(t: &Term) -> &'static str {
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
pub(in crate::diagnose) fn explain_term(
    c: &Confirmed,
    t: &Term,
    model: &LabModel,
    tail: &str,
) -> String {
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

#[cfg(test)]
mod tests {
    use super::*;

    fn fitted(value: f64, std: f64) -> crate::calibrate::FittedParam {
        crate::calibrate::FittedParam {
            key: "term_0_coefficient".into(),
            value,
            std,
            unit: "N".into(),
            at_bound: false,
            initial: 0.0,
        }
    }

    #[test]
    fn a_term_whose_interval_contains_zero_is_refused() {
        // Case 8 of the probe: heave w|w| at −4.1 ± 158.7 N was accepted.
        let why = interval_refusal(&fitted(-4.1, 158.7 / 1.96), "N");
        assert!(why.is_some_and(|w| w.contains("contains zero")));
        assert!(interval_refusal(&fitted(0.3, 0.2), "N").is_some());
        assert!(interval_refusal(&fitted(0.3, f64::NAN), "N").is_some());
        assert!(interval_refusal(&fitted(0.3, 0.1), "N").is_none());
        assert!(interval_refusal(&fitted(-0.3, 0.1), "N").is_none());
    }
}
