//! Library-level tests of compare, add, save/load and the diagnose JSON shape.

use crate::common;

use common::{Hidden, case_len, planar_trim_case};
use rov_dynamics::models::{Channel, InitialConditions, VehicleModel, simulate};
use rov_dynamics::thrusters::ThrustPct;
use rov_lab::diagnose::{DiagnoseOptions, diagnose};
use rov_lab::lab::{add, compare, diagnose_json};
use rov_lab::params::Param;
use rov_lab::{BaseKind, EffectId, LabError, LabModel, Run, save_extended_model};
use rov_types::model_id::ModelId;

/// A model file's text through the lab's one loader, named `file` in errors.
fn load_file(text: &str, file: &str) -> Result<LabModel, LabError> {
    rov_lab::load_model(&ModelId::File(file.into()), Some(text))
}

fn runs(seed: u64, hidden: &[Hidden], tl: f64, vl: f64) -> (Run, Run) {
    let (tr, va) = case_len(seed, hidden, tl, vl);
    (
        Run::from_series(&tr, "train.csv").unwrap(),
        Run::from_series(&va, "val.csv").unwrap(),
    )
}

#[test]
fn saved_extended_model_loads_and_simulates_like_the_original() {
    let m = LabModel::default_base(BaseKind::Model3)
        .unwrap()
        .with(
            &[
                Param::LagTau,
                Param::ArmXv,
                Param::ReverseRatio(rov_lab::params::Thr::Vertical),
                Param::DragQuad(rov_lab::params::Axis::Heave),
                Param::ThrustQuad(rov_lab::params::Thr::Port),
            ],
            &[0.2, 0.012, 0.7, 30.0, 1.1],
        )
        .unwrap();
    let mut m = m;
    m.add_effect(EffectId::ThrusterLag);
    m.add_effect(EffectId::ThrusterMomentArm);
    m.add_effect(EffectId::ThrustAsymmetry);
    let text = save_extended_model(&m, "test");
    assert!(text.contains("[lab]"));
    assert!(text.contains("lag_time_constant_s = { value = 0.2"));
    let loaded: Box<dyn rov_dynamics::VehicleModel> =
        Box::new(load_file(&text, "saved.toml").unwrap());
    assert_eq!(
        loaded.name(),
        "model3+thruster-lag+thruster-moment-arm+thrust-asymmetry"
    );
    let inputs: Vec<(f64, ThrustPct)> = (0..200)
        .map(|k| {
            let u = if k < 100 { 70.0 } else { -70.0 };
            (k as f64 * 0.05, ThrustPct::new(20.0, -20.0, u))
        })
        .collect();
    let ic = InitialConditions::at_rest(3.0, 0.0);
    let a = simulate(&m, &m.initial_state(&ic), &inputs, 0.01).unwrap();
    let b = simulate(loaded.as_ref(), &loaded.initial_state(&ic), &inputs, 0.01).unwrap();
    for (x, y) in a.iter().zip(&b) {
        assert!((x.depth_m.unwrap() - y.depth_m.unwrap()).abs() < 1e-9);
        assert!((x.pitch_deg.unwrap() - y.pitch_deg.unwrap()).abs() < 1e-9);
    }
    // The lag and the moment arm act in the VehicleModel form too.
    let base = LabModel::default_base(BaseKind::Model3).unwrap();
    let c = simulate(&base, &base.initial_state(&ic), &inputs, 0.01).unwrap();
    assert!((a[20].depth_m.unwrap() - c[20].depth_m.unwrap()).abs() > 1e-3);
    assert!((a[90].pitch_deg.unwrap() - c[90].pitch_deg.unwrap()).abs() > 1.0);
    // A plain base file loads as the base; a bad [lab] is reported with the file name.
    let plain = rov_dynamics::models::default_model_text("model1").unwrap();
    let l = load_file(plain, "model1.toml").unwrap();
    assert_eq!(l.kind(), BaseKind::Model1);
    let bad = format!("{text}\n[lab.extra]\nx = 1\n");
    assert!(load_file(&bad, "bad.toml").is_err());
    let bad = text.replace(
        "lag_time_constant_s = { value = 0.2",
        "lag_time_constant_s = { value = 99.0",
    );
    let e = load_file(&bad, "bad.toml").unwrap_err().to_string();
    assert!(e.contains("bad.toml") && e.contains("out of range"), "{e}");
}

#[test]
fn compare_reports_three_views_segments_windows_and_unpredicted_channels() {
    let (tr, _) = runs(21, &[], 120.0, 60.0);
    let m1 = LabModel::default_base(BaseKind::Model1).unwrap();
    let r = compare(&m1, "model1", std::slice::from_ref(&tr), &[], 1).unwrap();
    for v in ["free_run", "shooting", "k_step"] {
        let vm = &r.pooled[v];
        assert!(vm.channels.contains_key("depth") && vm.channels.contains_key("heading"));
        assert!(
            !vm.channels.contains_key("pitch"),
            "model1 does not predict pitch"
        );
        assert!(vm.channels["depth"].rmse.is_finite());
    }
    assert_eq!(
        r.not_predicted,
        vec!["pitch".to_string(), "roll".to_string()]
    );
    assert!(!r.runs[0].segments.is_empty() && !r.runs[0].windows.is_empty());
    assert!(!r.failures.is_empty() && !r.failures[0].by_command.is_empty());
    // Plots render.
    let pngs = rov_lab::plots::failure_pngs(&r.failures, "t").unwrap();
    assert_eq!(pngs.len(), 2);
    let c = rov_lab::plots::comparison_png(&tr, &[("m1", &r.free_run[0])], "t").unwrap();
    assert!(c.1.starts_with(&[0x89, b'P', b'N', b'G']));
    let json = serde_json::to_value(&r).unwrap();
    assert!(json["pooled"]["shooting"]["channels"]["depth"]["fit_pct"].is_number());
}

#[test]
fn add_cuts_the_error_and_reports_an_error_fall() {
    let (tr, va) = runs(22, &[Hidden::AsymVertical(0.6)], 240.0, 120.0);
    let m3 = LabModel::default_base(BaseKind::Model3).unwrap();
    let r = add(
        &m3,
        "model3",
        &[EffectId::ThrustAsymmetry, EffectId::NetBuoyancy],
        &[tr],
        &[va],
        2,
    )
    .unwrap();
    assert_eq!(r.error_fall.len(), 3);
    assert_eq!(r.refitted_contained, vec!["net-buoyancy".to_string()]);
    assert!(
        r.rmse_reduction_pct["depth"] > 30.0,
        "{:?}",
        r.rmse_reduction_pct
    );
    let m = r.model_fitted.as_ref().unwrap();
    let rho = m
        .get(Param::ReverseRatio(rov_lab::params::Thr::Vertical))
        .unwrap();
    assert!((rho - 0.6).abs() < 0.6 * 0.35, "{rho}");
    assert!(rov_lab::plots::error_fall_png(&r.error_fall, "t").is_ok());
    // Effects a base cannot represent are refused with the reason.
    let m1 = LabModel::default_base(BaseKind::Model1).unwrap();
    let (tr, va) = runs(23, &[], 60.0, 60.0);
    let e = add(
        &m1,
        "model1",
        &[EffectId::ThrusterMomentArm],
        &[tr],
        &[va],
        1,
    )
    .unwrap_err();
    assert!(e.to_string().contains("pitch and roll"), "{e}");
}

#[test]
fn diagnose_json_has_the_documented_shape() {
    let (tr, va) = planar_trim_case(41, 8.0, 360.0, 180.0);
    let (tr, va) = (
        Run::from_series(&tr, "train.csv").unwrap(),
        Run::from_series(&va, "val.csv").unwrap(),
    );
    let m1 = LabModel::default_base(BaseKind::Model1).unwrap();
    let d = diagnose(
        &m1,
        "model1",
        &[tr],
        &[va],
        &DiagnoseOptions {
            threads: 2,
            ..Default::default()
        },
    )
    .unwrap();
    let j = serde_json::to_value(diagnose_json(&d)).unwrap();
    assert_eq!(j["model"], "model1");
    let ch = &j["baseline"]["channels"];
    assert!(ch["depth"]["fit_pct"].is_number() && ch["depth"]["rmse"].is_number());
    assert!(ch["heading"]["rmse"].is_number());
    assert!(
        ch.get("pitch").is_none(),
        "model1 does not predict pitch: {ch}"
    );
    let f = j["findings"].as_array().unwrap();
    assert_eq!(
        f.iter().filter(|x| x["kind"] == "catalog").count(),
        17,
        "every catalog effect appears once"
    );
    // Discovered terms (if the catalog left a channel inconsistent) carry their formula.
    for x in f.iter().filter(|x| x["kind"] == "discovered") {
        assert!(x["term"].is_string() && x["resembles"].is_string(), "{x}");
        assert!(x["effect"].as_str().unwrap().starts_with("term:"), "{x}");
    }
    // The verdict and its test.
    assert!(
        ["adequate", "explained", "unexplained"].contains(&j["verdict"].as_str().unwrap()),
        "{}",
        j["verdict"]
    );
    assert!(j["unexplained"].is_array() && j["data"].is_array());
    for c in j["consistency"].as_array().unwrap() {
        assert!(c["channel"].is_string() && c["consistent"].is_boolean());
        assert!(c["ratio"].is_number() && c["n_eff"].is_number());
    }
    for x in f {
        assert!(x["effect"].is_string() && x["significant"].is_boolean());
        assert!(x["channels"].is_array() && x["params"].is_object());
        assert!(x["explanation"].is_string());
        let red = x["validation_rmse_reduction_pct"].as_object().unwrap();
        assert!(red.get("pitch").is_none() && red.get("roll").is_none());
    }
    assert_eq!(f[0]["effect"], "pitch-depth-coupling", "{}", f[0]);
    assert_eq!(f[0]["significant"], true);
    assert!(f[0]["validation_rmse_reduction_pct"]["heading"].is_number());
    assert!(
        f[0]["validation_rmse_reduction_pct"]["depth"]
            .as_f64()
            .unwrap()
            > 30.0
    );
    assert!(f[0]["params"]["trim_deg"]["value"].is_number());
    // model1 cannot hold the attitude-only effects: "not applicable", never "absent".
    let arm = f
        .iter()
        .find(|x| x["effect"] == "thruster-moment-arm")
        .unwrap();
    assert_eq!(arm["status"], "not_applicable");
    let cur = f.iter().find(|x| x["effect"] == "current").unwrap();
    assert_eq!(cur["status"], "not_testable");
    let _ = Channel::Depth;
}

/// Issue 13, part 5: the diagnosis's fit of an effect and `lab add` of the same effect on
/// the same data are one fit path, so they reach the same optimum (parameters and held-out
/// error).
#[test]
fn diagnose_and_add_reach_the_same_optimum() {
    let (tr, va) = runs(31, &[Hidden::Lag(0.25)], 240.0, 120.0);
    let m3 = LabModel::default_base(BaseKind::Model3).unwrap();
    let d = diagnose(
        &m3,
        "model3",
        std::slice::from_ref(&tr),
        std::slice::from_ref(&va),
        &DiagnoseOptions {
            threads: 2,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(
        d.accepted.first(),
        Some(&EffectId::ThrusterLag),
        "{}",
        d.summary
    );
    let fd = d
        .findings
        .iter()
        .find(|f| f.effect == "thruster-lag")
        .unwrap();
    let r = add(&m3, "model3", &[EffectId::ThrusterLag], &[tr], &[va], 2).unwrap();
    let fa = r
        .findings
        .iter()
        .find(|f| f.effect == "thruster-lag")
        .unwrap();
    assert!(!fd.params.is_empty());
    for (k, pd) in &fd.params {
        let pa = &fa.params[k];
        let tol = 1e-3 * pd.value.abs().max(1e-6) + 0.05 * pd.std.unwrap_or(0.0);
        assert!(
            (pd.value - pa.value).abs() <= tol,
            "{k}: diagnose {} vs add {}",
            pd.value,
            pa.value
        );
    }
    for (ch, red) in &fd.validation_rmse_reduction_pct_shooting {
        let ra = fa.validation_rmse_reduction_pct_shooting[ch];
        assert!((red - ra).abs() < 0.5, "{ch}: {red} vs {ra}");
    }
}
