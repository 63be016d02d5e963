//! Saving and loading extended models.
//!
//! A saved extended model is the base model's parameter file (unchanged, so its units
//! and sources stay) followed by a `[lab]` table:
//!
//! ```toml
//! [lab]
//! base = "model3"
//! effects = ["thruster-lag"]
//! [lab.params]
//! lag_time_constant_s = { value = 0.25, unit = "s", source = "model lab fit (± 0.01)" }
//! thrust_quadratic_scale_vertical = { value = 0.87, unit = "-", source = "model lab calibration" }
//! ```
//!
//! `lab.params` holds every calibrated and effect parameter by key ([`Param::key`]); on
//! loading they are applied to the base. Discovered terms follow as an array of tables,
//! each with its DOF, its formula ([`crate::terms::TermKind::formula`]), its coefficient
//! (N or N m per unit of the regressor) and the regressor's typical size:
//!
//! ```toml
//! [[lab.terms]]
//! dof = "heave"
//! term = "r^2"
//! coefficient = { value = 1.9, unit = "N per (rad/s)^2", source = "model lab fit (± 0.2)" }
//! scale = 0.41
//! ```
//!
//! The base is either a Pro 4 model file (key `model`) or a vehicle definition file (key
//! `vehicle`, see [`rov_dynamics::models::vehicle`]). A file without `[lab]` is a plain
//! base model. The saved file needs nothing else: no run, no lab state.
//! It is loaded by the lab's one model loader, [`crate::load_model`], as a [`LabModel`]
//! (a [`rov_dynamics::models::VehicleModel`] that `sim`, `hold` and the autopilot use
//! like any model).

use crate::LabError;
use crate::catalog::EffectId;
use crate::model::{BaseKind, LabModel};
use crate::params::Param;
use crate::terms::{DOF_NAMES, Term, TermKind};

/// Parameters written to a saved model: those applicable to the base that calibration
/// or an effect can change.
fn saved_params(model: &LabModel) -> Vec<Param> {
    let mut v: Vec<Param> = model.calibration_params();
    for e in model.active_effects() {
        for p in crate::params::effect_params(*e) {
            if !v.contains(&p) {
                v.push(p);
            }
        }
    }
    for p in [Param::NetWeight, Param::CgX, Param::CgY] {
        if model.applicable(p) && !v.contains(&p) {
            v.push(p);
        }
    }
    v.retain(|p| model.applicable(*p));
    v
}

/// The saved-model TOML text of a lab model. `note` goes into the parameters' source.
pub fn save_extended_model(model: &LabModel, note: &str) -> String {
    let mut out = String::new();
    out.push_str(&format!(
        "# Extended model saved by the topside model lab: {} ({note}).\n# The base model's parameter file follows unchanged; the [lab] table at the end holds the\n# calibrated and effect parameters, applied on loading.\n\n",
        rov_dynamics::models::VehicleModel::name(model)
    ));
    out.push_str(model.base_text().trim_end());
    out.push_str("\n\n[lab]\n");
    out.push_str(&format!("base = \"{}\"\n", model.base_name()));
    let effects: Vec<String> = model
        .active_effects()
        .iter()
        .map(|e| format!("\"{}\"", e.key()))
        .collect();
    out.push_str(&format!("effects = [{}]\n", effects.join(", ")));
    out.push_str("\n[lab.params]\n");
    for p in saved_params(model) {
        if let Some(v) = model.get(p) {
            out.push_str(&format!(
                "{} = {{ value = {}, unit = \"{}\", source = \"model lab ({note})\" }}\n",
                p.key(),
                fmt_f64(v),
                p.meta().unit
            ));
        }
    }
    let names = model.command_names();
    for t in model.terms() {
        out.push_str("\n[[lab.terms]]\n");
        out.push_str(&format!(
            "dof = \"{}\"\n",
            DOF_NAMES.get(t.dof as usize).copied().unwrap_or("?")
        ));
        out.push_str(&format!("term = \"{}\"\n", t.kind.formula(&names)));
        out.push_str(&format!(
            "coefficient = {{ value = {}, unit = \"{} per {}\", source = \"model lab ({note})\" }}\n",
            fmt_f64(t.coef),
            t.force_unit(),
            t.kind.regressor_unit()
        ));
        out.push_str(&format!("scale = {}\n", fmt_f64(t.scale)));
    }
    out
}

fn fmt_f64(v: f64) -> String {
    let s = format!("{v:?}");
    if s.contains('.') || s.contains('e') || s.contains("inf") || s.contains("NaN") {
        s
    } else {
        format!("{s}.0")
    }
}

fn bad(file: &str, detail: impl Into<String>) -> LabError {
    LabError::SavedModel {
        file: file.into(),
        detail: detail.into(),
    }
}

/// Parses a saved extended model (or a plain base-model or vehicle-definition file) as a
/// lab model: the file half of [`crate::load_model`], which every caller goes through.
pub(crate) fn parse_model_file(text: &str, label: &str) -> Result<LabModel, LabError> {
    let mut table: toml::Table = text
        .parse()
        .map_err(|e: toml::de::Error| bad(label, format!("not valid TOML: {e}")))?;
    let lab = table.remove("lab");
    let is_vehicle = table.contains_key("vehicle");
    let kind = if is_vehicle {
        BaseKind::Vehicle
    } else {
        let kind_name = match table.get("model") {
            Some(toml::Value::String(s)) => s.clone(),
            _ => {
                return Err(bad(
                    label,
                    "key `model` (model1, model2 or model3) or `vehicle` (a vehicle definition) is missing",
                ));
            }
        };
        BaseKind::parse(&kind_name).ok_or_else(|| LabError::UnknownModel {
            name: kind_name.clone(),
        })?
    };
    let base_text = if lab.is_some() {
        toml::to_string(&table).map_err(|e| bad(label, e.to_string()))?
    } else {
        text.to_string()
    };
    let mut model = LabModel::from_base_text(kind, &base_text, label)?;
    let Some(lab) = lab else {
        return Ok(model);
    };
    let toml::Value::Table(lab) = lab else {
        return Err(bad(label, "`lab` must be a table"));
    };
    if let Some(k) = lab
        .keys()
        .find(|k| !matches!(k.as_str(), "base" | "effects" | "params" | "terms"))
    {
        return Err(bad(
            label,
            format!("lab.{k}: unknown key (allowed: base, effects, params, terms)"),
        ));
    }
    if let Some(b) = lab.get("base")
        && b.as_str() != Some(model.base_name())
    {
        return Err(bad(
            label,
            format!(
                "lab.base = {b} does not match the base in the file (\"{}\")",
                model.base_name()
            ),
        ));
    }
    if let Some(v) = lab.get("terms") {
        let arr = v
            .as_array()
            .ok_or_else(|| bad(label, "lab.terms must be an array of tables [[lab.terms]]"))?;
        for (i, t) in arr.iter().enumerate() {
            model.add_term(parse_term(t, i, &model, label)?);
        }
    }
    let mut effects = Vec::new();
    if let Some(v) = lab.get("effects") {
        let arr = v
            .as_array()
            .ok_or_else(|| bad(label, "lab.effects must be an array of effect IDs"))?;
        for e in arr {
            let s = e
                .as_str()
                .ok_or_else(|| bad(label, "lab.effects must hold strings"))?;
            let id = EffectId::parse(s).ok_or_else(|| {
                bad(
                    label,
                    format!("lab.effects: unknown effect {s:?} (see `topside lab effects`)"),
                )
            })?;
            if let Some(reason) = model.not_applicable(id) {
                return Err(bad(label, format!("lab.effects: {s} — {reason}")));
            }
            effects.push(id);
        }
    }
    let mut params = Vec::new();
    let mut values = Vec::new();
    if let Some(t) = lab.get("params") {
        let t = t
            .as_table()
            .ok_or_else(|| bad(label, "lab.params must be a table"))?;
        for (k, v) in t {
            let p = Param::from_key(k)
                .ok_or_else(|| bad(label, format!("lab.params.{k}: unknown parameter")))?;
            let x = match v {
                toml::Value::Table(vt) => vt
                    .get("value")
                    .and_then(|x| x.as_float().or_else(|| x.as_integer().map(|i| i as f64))),
                toml::Value::Float(f) => Some(*f),
                toml::Value::Integer(i) => Some(*i as f64),
                _ => None,
            }
            .ok_or_else(|| {
                bad(
                    label,
                    format!("lab.params.{k}: expected {{ value = number, … }}"),
                )
            })?;
            let m = p.meta();
            if !(x.is_finite() && x >= m.lo && x <= m.hi) {
                return Err(bad(
                    label,
                    format!(
                        "lab.params.{k} = {x} is out of range (allowed {}..={})",
                        m.lo, m.hi
                    ),
                ));
            }
            if !model.applicable(p) {
                return Err(bad(
                    label,
                    format!("lab.params.{k} does not apply to {}", model.base_name()),
                ));
            }
            params.push(p);
            values.push(x);
        }
    }
    model.set_many(&params, &values)?;
    for e in effects {
        model.add_effect(e);
    }
    Ok(model)
}

/// One `[[lab.terms]]` entry.
fn parse_term(v: &toml::Value, i: usize, model: &LabModel, label: &str) -> Result<Term, LabError> {
    let at = format!("lab.terms[{i}]");
    let t = v
        .as_table()
        .ok_or_else(|| bad(label, format!("{at} must be a table")))?;
    if let Some(k) = t
        .keys()
        .find(|k| !matches!(k.as_str(), "dof" | "term" | "coefficient" | "scale"))
    {
        return Err(bad(
            label,
            format!("{at}.{k}: unknown key (allowed: dof, term, coefficient, scale)"),
        ));
    }
    let dof_s = t.get("dof").and_then(|d| d.as_str()).ok_or_else(|| {
        bad(
            label,
            format!("{at}.dof is missing (one of {})", DOF_NAMES.join(", ")),
        )
    })?;
    let dof = DOF_NAMES.iter().position(|d| *d == dof_s).ok_or_else(|| {
        bad(
            label,
            format!("{at}.dof = {dof_s:?} (allowed: {})", DOF_NAMES.join(", ")),
        )
    })?;
    let names = model.command_names();
    let term_s = t
        .get("term")
        .and_then(|d| d.as_str())
        .ok_or_else(|| bad(label, format!("{at}.term is missing")))?;
    let kind = TermKind::parse(term_s, &names).ok_or_else(|| {
        bad(
            label,
            format!(
                "{at}.term = {term_s:?} is not a term formula of this model (its commands: {})",
                names.join(", ")
            ),
        )
    })?;
    let num = |v: &toml::Value| -> Option<f64> {
        match v {
            toml::Value::Table(vt) => vt
                .get("value")
                .and_then(|x| x.as_float().or_else(|| x.as_integer().map(|i| i as f64))),
            toml::Value::Float(f) => Some(*f),
            toml::Value::Integer(i) => Some(*i as f64),
            _ => None,
        }
    };
    let coef = t
        .get("coefficient")
        .and_then(num)
        .filter(|x| x.is_finite())
        .ok_or_else(|| {
            bad(
                label,
                format!("{at}.coefficient: expected {{ value = number, … }}"),
            )
        })?;
    let scale = t
        .get("scale")
        .and_then(num)
        .filter(|x| x.is_finite() && *x > 0.0)
        .ok_or_else(|| {
            bad(
                label,
                format!("{at}.scale: expected a positive number (the regressor's typical size)"),
            )
        })?;
    let term = Term {
        dof: dof as u8,
        kind,
        coef,
        scale,
    };
    let meta = Param::TermCoef(0, term.rotational()).meta();
    let normalised = coef * scale;
    if !(meta.lo..=meta.hi).contains(&normalised) {
        return Err(bad(
            label,
            format!(
                "{at}.coefficient = {coef} gives {normalised} {} at the typical regressor size, out of range (allowed {}..={})",
                meta.unit, meta.lo, meta.hi
            ),
        ));
    }
    Ok(term)
}
