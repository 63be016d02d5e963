//! The evidence cards of confirmed findings: a catalog effect's, a discovered term's, and
//! the term search's note for terms that are a catalog effect's signature. The catalog
//! rounds, the replacement test, the term rounds and `lab add` all write them here.

use super::*;

/// The evidence card of a confirmed discovered term: the diagnosis' term rounds, the
/// replacement test and `lab add --terms` all write it here. `outranked`: a better term
/// was accepted this round, so a significant one is reported as not significant.
pub(super) fn term_card(
    c: &Confirmed,
    j: &Judgement,
    model: &LabModel,
    round: usize,
    pick: Option<&discovery::TermPick>,
    outranked: bool,
) -> Finding {
    let names = model.command_names();
    let Subject::Term(t) = c.subject else {
        return effect_finding(c, j, model, round);
    };
    let significant = j.significant && !outranked;
    let mut f = Finding::blank_term(&t, &names);
    f.significant = significant;
    f.status = if significant {
        Status::Significant
    } else {
        Status::NotSignificant
    };
    fill_evidence(&mut f, c, j, round);
    let ex = explain(c, j, model);
    let evidence = pick.map_or(String::new(), |p| {
        format!(
            " (found by sparse regression on the residual {}: explains {:.0} % of it, ΔBIC {:.0}, selected in {:.0} % of bootstrap resamples)",
            crate::terms::DOF_FORCE.get(t.dof as usize).copied().unwrap_or("force"),
            p.explained * 100.0,
            p.dbic,
            p.inclusion * 100.0
        )
    });
    f.explanation = if significant {
        format!("{ex}{evidence}")
    } else if j.significant {
        format!("not significant: weaker than a better term this round ({ex}{evidence})")
    } else {
        format!("not significant: {} ({ex}{evidence})", j.reason)
    };
    f
}

/// The evidence card of a confirmed catalog effect.
pub(super) fn effect_finding(
    c: &Confirmed,
    j: &Judgement,
    model: &LabModel,
    round: usize,
) -> Finding {
    let effect = c.subject.effect().unwrap_or(EffectId::AddedMass);
    let expl = if j.significant {
        explain(c, j, model)
    } else {
        format!("not significant: {} ({})", j.reason, explain(c, j, model))
    };
    let mut f = Finding::blank(
        effect,
        if j.significant {
            Status::Significant
        } else {
            Status::NotSignificant
        },
        expl,
        c.contained,
    );
    f.significant = j.significant;
    fill_evidence(&mut f, c, j, round);
    f
}

/// Writes a confirmed finding's evidence into its card: the channels it explains, its
/// view, the held-out RMSE reductions in both views, the fitted parameters, the training
/// ΔBIC, the held-out score, the round and the channels it makes worse.
fn fill_evidence(f: &mut Finding, c: &Confirmed, j: &Judgement, round: usize) {
    f.channels = j.channels.iter().map(|k| k.name().to_string()).collect();
    f.view = view_name(j.view).into();
    f.validation_rmse_reduction_pct = j.primary.clone();
    f.validation_rmse_reduction_pct_free_run = j.free.clone();
    f.validation_rmse_reduction_pct_shooting = j.shoot.clone();
    f.params = param_reports(c);
    f.delta_bic = Some(c.dbic);
    f.score = j.score;
    f.round = round;
    f.conflicts = j.conflicts.clone();
}

/// The term search's note for library terms whose residual force follows a catalog
/// effect's signature: reported under the effect, not as new terms.
pub(super) fn catalog_like_note(dof: usize, effect: &str, forms: &[String]) -> String {
    let force = crate::terms::DOF_FORCE.get(dof).copied().unwrap_or("force");
    let listed = match forms {
        [] => String::new(),
        [one] => one.clone(),
        [init @ .., last] => format!("{} and {last}", init.join(", ")),
    };
    let (them, terms) = if forms.len() > 1 {
        ("these are", "new terms")
    } else {
        ("it is", "a new term")
    };
    format!(
        "the residual {force} follows {listed}: {them} the signature of the catalog effect {effect} (reported under it, not as {terms})"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn catalog_like_terms_make_one_note_per_effect() {
        let forms: Vec<String> = ["w*|r|", "r*|w|", "r^2"].map(String::from).into();
        assert_eq!(
            catalog_like_note(5, "thrust-asymmetry", &forms),
            "the residual yaw moment follows w*|r|, r*|w| and r^2: these are the signature of the catalog effect thrust-asymmetry (reported under it, not as new terms)"
        );
        assert_eq!(
            catalog_like_note(0, "thruster-deadzone", &forms[..1]),
            "the residual surge force follows w*|r|: it is the signature of the catalog effect thruster-deadzone (reported under it, not as a new term)"
        );
    }
}
