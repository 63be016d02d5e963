//! Physics outside the catalog (issue 13, part 2): the test generator's truth carries a
//! generalised force that no catalog effect describes (tests/common `Hidden::HeaveYawSq`,
//! `YawSpeedDamp`, `HeaveLift`, written into the truth's dynamics independently of the
//! lab's term code). The diagnosis must find the term by sparse regression on the
//! residual generalised force, name it (DOF and formula), confirm it in simulation on the
//! held-out run, and report it as a `"discovered"` finding with a confidence interval and
//! what known physics it resembles; the final model carries it, saves it and every loader
//! simulates it. A catalog effect in the same position is still named as the catalog
//! effect (effect-free data gaining no term is checked in tests/nulls_and_pairs.rs).
//!
//! Training 6 min, held-out 3 min at 20 Hz, model3 under test, as tests/hidden_effects.rs.

use crate::common;

use common::{Hidden, case_len};
use rov_dynamics::models::{InitialConditions, VehicleModel, simulate};
use rov_dynamics::thrusters::ThrustPct;
use rov_lab::diagnose::{DiagnoseOptions, Diagnosis, Status, diagnose};
use rov_lab::lab::diagnose_json;
use rov_lab::terms::TermKind;
use rov_lab::{BaseKind, LabModel, Run, load_model, save_extended_model};
use rov_types::model_id::ModelId;

const TRAIN_S: f64 = 360.0;
const VAL_S: f64 = 180.0;

fn run_case(seed: u64, hidden: &[Hidden]) -> Diagnosis {
    let (tr, va) = case_len(seed, hidden, TRAIN_S, VAL_S);
    let tr = Run::from_series(&tr, "train").unwrap();
    let va = Run::from_series(&va, "val").unwrap();
    let m = LabModel::default_base(BaseKind::Model3).unwrap();
    diagnose(
        &m,
        "model3",
        &[tr],
        &[va],
        &DiagnoseOptions {
            threads: 1,
            ..Default::default()
        },
    )
    .unwrap()
}

fn describe(d: &Diagnosis) -> String {
    let mut s = format!(
        "summary: {}\naccepted {:?}, terms {:?}\n",
        d.summary,
        d.accepted,
        d.accepted_terms
            .iter()
            .map(|t| t.id(&["port", "starboard", "vertical"]))
            .collect::<Vec<_>>()
    );
    for f in d.findings.iter().take(4) {
        s += &format!(
            "  {} [{}] {:?}: {}\n",
            f.effect, f.kind, f.status, f.explanation
        );
    }
    for f in d.findings.iter().skip(4).filter(|f| f.kind == "discovered") {
        s += &format!("  {} {:?}: {}\n", f.effect, f.status, f.explanation);
    }
    for c in &d.consistency {
        s += &format!(
            "  test {}: rmse {:.3} noise {:.3} spread {:.3} level {:.2}/{:.2} n_eff {:.0} consistent {}\n",
            c.channel,
            c.rmse,
            c.noise,
            c.param_spread,
            c.level,
            c.level_critical,
            c.n_eff,
            c.consistent
        );
    }
    for n in &d.search_notes {
        s += &format!("  search: {n}\n");
    }
    s
}

/// The term is found, named, confirmed and carried by the final model; its coefficient
/// is within `tol` of the truth.
fn check_discovered(seed: u64, hidden: Hidden, dof: u8, kind: TermKind, truth: f64, tol: f64) {
    let d = run_case(seed, &[hidden]);
    let text = describe(&d);
    eprintln!("{hidden:?}\n{text}");
    // Found and accepted: the final model carries exactly this term.
    let t = d
        .accepted_terms
        .iter()
        .find(|t| t.dof == dof && t.kind == kind)
        .unwrap_or_else(|| panic!("term not accepted\n{text}"));
    assert!(
        d.final_model
            .terms()
            .iter()
            .any(|x| x.kind == kind && x.dof == dof),
        "{text}"
    );
    // Named and confirmed: a significant finding of kind "discovered" with its id.
    let id = t.id(&d.final_model.command_names());
    let f = d
        .findings
        .iter()
        .find(|f| f.effect == id)
        .unwrap_or_else(|| panic!("no finding {id}\n{text}"));
    assert_eq!(f.kind, "discovered", "{text}");
    assert_eq!(f.status, Status::Significant, "{text}");
    assert!(f.significant, "{text}");
    assert!(f.term.as_deref().is_some_and(|s| s.contains('∝')), "{text}");
    assert!(
        f.resembles.as_deref().is_some_and(|s| !s.is_empty()),
        "{text}"
    );
    // The coefficient with its 95 % interval, in physical units; the truth within tol.
    let c = &f.params["coefficient"];
    let ci = c.ci95.unwrap_or_else(|| panic!("no interval\n{text}"));
    assert!(ci[0] < c.value && c.value < ci[1], "{ci:?} {}", c.value);
    let err = (c.value - truth).abs() / truth.abs();
    assert!(
        err <= tol,
        "coefficient {} vs truth {truth} ({:.0} %)\n{text}",
        c.value,
        100.0 * err
    );
    // No catalog effect was accepted in its place (a refit of a base parameter the model
    // already has, such as W − B absorbing the mean of a one-signed force, is not one).
    for e in &d.accepted {
        let f = d.findings.iter().find(|f| f.effect == e.key()).unwrap();
        assert!(f.contained, "catalog effect {} accepted: {text}", e.key());
    }
    // The JSON carries it.
    let j = serde_json::to_value(diagnose_json(&d)).unwrap();
    let jf = j["findings"]
        .as_array()
        .unwrap()
        .iter()
        .find(|x| x["effect"] == id.as_str())
        .unwrap();
    assert_eq!(jf["kind"], "discovered");
    assert!(jf["term"].is_string() && jf["resembles"].is_string());
    assert!(
        j["accepted"]
            .as_array()
            .unwrap()
            .iter()
            .any(|x| x == id.as_str())
    );
    // Saved with the model; both loaders simulate it like the original.
    let saved = save_extended_model(&d.final_model, "test");
    assert!(saved.contains("[[lab.terms]]"), "{saved}");
    let id: ModelId = "saved.toml".parse().unwrap();
    let lab_loaded = load_model(&id, Some(&saved)).unwrap();
    assert_eq!(lab_loaded.terms().len(), d.final_model.terms().len());
    let boxed: Box<dyn rov_dynamics::VehicleModel> = Box::new(lab_loaded.clone());
    let inputs: Vec<(f64, ThrustPct)> = (0..400)
        .map(|k| {
            let s = if k < 200 { 60.0 } else { -60.0 };
            (k as f64 * 0.05, ThrustPct::new(s, 0.6 * s, 0.4 * s))
        })
        .collect();
    let ic = InitialConditions::at_rest(3.0, 0.0);
    let m = &d.final_model;
    let a = simulate(m, &m.initial_state(&ic), &inputs, 0.01).unwrap();
    let b = simulate(boxed.as_ref(), &boxed.initial_state(&ic), &inputs, 0.01).unwrap();
    let base = &d.calibrated;
    let c0 = simulate(base, &base.initial_state(&ic), &inputs, 0.01).unwrap();
    let mut differs = 0.0f64;
    for ((x, y), z) in a.iter().zip(&b).zip(&c0) {
        assert!((x.depth_m.unwrap() - y.depth_m.unwrap()).abs() < 1e-9);
        assert!((x.heading_deg.unwrap() - y.heading_deg.unwrap()).abs() < 1e-7);
        differs = differs
            .max((x.depth_m.unwrap() - z.depth_m.unwrap()).abs())
            .max((x.heading_deg.unwrap() - z.heading_deg.unwrap()).abs() * 0.01);
    }
    assert!(differs > 1e-3, "the term changes nothing in simulation");
}

#[test]
fn heave_force_from_the_yaw_rate_squared_is_discovered() {
    // A 2-DOF coupling: turning pushes the vehicle down (0.3 N at 1 rad/s).
    check_discovered(
        3,
        Hidden::HeaveYawSq(0.3),
        2,
        TermKind::Prod(rov_lab::terms::Sig::Nu(5), rov_lab::terms::Sig::Nu(5)),
        0.3,
        0.35,
    );
}

#[test]
fn yaw_damping_growing_with_speed_is_discovered() {
    // Speed-dependent: yaw damping −k r |u| (0.15 N m at 1 rad/s and 1 m/s).
    check_discovered(
        5,
        Hidden::YawSpeedDamp(0.15),
        5,
        TermKind::ProdAbs(rov_lab::terms::Sig::Nu(5), rov_lab::terms::Sig::Nu(0)),
        -0.15,
        0.35,
    );
}

#[test]
fn heave_lift_growing_with_surge_speed_squared_is_discovered() {
    // Speed-dependent 2-DOF coupling: −0.3 N per (m/s)² u|u| (lift upwards when moving
    // forward).
    check_discovered(
        7,
        Hidden::HeaveLift(-0.3),
        2,
        TermKind::ProdAbs(rov_lab::terms::Sig::Nu(0), rov_lab::terms::Sig::Nu(0)),
        -0.3,
        0.35,
    );
}

#[test]
fn a_catalog_effect_is_still_named_as_the_catalog_effect() {
    // The vertical thruster's reaction torque is a yaw moment ∝ the vertical command's
    // thrust: the term library could write it as cmd_vertical*|cmd_vertical|, but the
    // catalog's propeller-torque is the name.
    let d = run_case(11, &[Hidden::TorqueV(0.003)]);
    let text = describe(&d);
    eprintln!("{text}");
    assert_eq!(d.findings[0].effect, "propeller-torque", "{text}");
    assert!(d.findings[0].significant, "{text}");
    assert!(d.accepted_terms.is_empty(), "{text}");
    assert!(
        !d.findings
            .iter()
            .any(|f| f.kind == "discovered" && f.significant),
        "{text}"
    );
}

/// Probe case 7: on model2, a yaw moment 0.5·w|w| (outside the catalog). In steady heave
/// w|w| is nearly proportional to the vertical thrust, so the catalog's propeller torque
/// took 92 % of the heading misfit at 10.8 mm/N (five times the other tests' values) and
/// was accepted with heading still 9.5× its noise floor; the term search, running on top
/// of it, found only scraps. An accepted effect that leaves its own home channel
/// inconsistent is now tested against its DOF's library terms as a replacement, and the
/// held-out data's preference is kept, with the alternative named.
#[test]
fn an_outside_term_collinear_with_a_catalog_effect_replaces_it() {
    let (tr, va) = common::planar_case("model2", 67, &[Hidden::YawHeaveSq(0.5)], TRAIN_S, VAL_S);
    let d = diagnose(
        &LabModel::default_base(BaseKind::Model2).unwrap(),
        "model2",
        &[Run::from_series(&tr, "train").unwrap()],
        &[Run::from_series(&va, "val").unwrap()],
        &DiagnoseOptions {
            threads: 2,
            ..Default::default()
        },
    )
    .unwrap();
    let names = d.final_model.command_names();
    let ids: Vec<String> = d.accepted_terms.iter().map(|t| t.id(&names)).collect();
    assert!(
        ids.iter().any(|i| i == "term:yaw:w_absw"),
        "accepted terms {ids:?}, effects {:?}: {}",
        d.accepted,
        describe(&d)
    );
    assert!(
        !d.accepted.iter().any(|e| e.key() == "propeller-torque"),
        "{}",
        describe(&d)
    );
    let Some(f) = d.findings.iter().find(|f| f.effect == "term:yaw:w_absw") else {
        panic!("{}", describe(&d));
    };
    let c = f.params["coefficient"].value;
    assert!((c - 0.5).abs() <= 0.35 * 0.5, "coefficient {c}");
    // Both readings are said: the term's card names the effect it replaces, the effect's
    // card the term the data prefers.
    assert!(
        f.explanation.contains("propeller-torque"),
        "{}",
        f.explanation
    );
    let Some(t) = d.findings.iter().find(|f| f.effect == "propeller-torque") else {
        panic!("{}", describe(&d));
    };
    assert!(
        !t.significant && t.explanation.contains("prefers the term"),
        "{}",
        t.explanation
    );
    assert_eq!(
        d.verdict,
        rov_lab::verdict::Verdict::Explained,
        "{}",
        d.summary
    );
}
