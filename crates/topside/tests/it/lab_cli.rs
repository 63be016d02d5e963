//! `topside lab` through the real binary, end to end: list the catalog and the models,
//! diagnose data with a hidden effect, add it, save the extended model, and load the
//! saved model in `lab compare`, `sim run` and `hold` like any other model.

use std::path::{Path, PathBuf};
use std::process::Command;

use rov_dynamics::models::{InitialConditions, Model3, load_default_model};
use rov_dynamics::sensors::SensorConfig;
use rov_dynamics::thrusters::{ThrustPct, ThrusterGeometry};
use rov_sim::{Schedule, SimConfig, Simulator, run_schedule_on};

fn topside() -> Command {
    Command::new(env!("CARGO_BIN_EXE_topside"))
}

fn tmp(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("lab_cli");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn run_ok(args: &[&str]) -> String {
    let out = topside().args(args).output().unwrap();
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// Runs `topside ARGS`, expecting a failure whose message names `needle`.
fn fails_naming(args: &[&str], needle: &str) {
    let o = topside().args(args).output().unwrap();
    assert!(!o.status.success(), "{args:?} succeeded");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains(needle), "{args:?}: {err}");
}

/// `lab diagnose --model model3 --data TRAIN --validate VAL --json`.
fn diagnose_args<'a>(train: &'a str, val: &'a str) -> [&'a str; 9] {
    [
        "lab",
        "diagnose",
        "--model",
        "model3",
        "--data",
        train,
        "--validate",
        val,
        "--json",
    ]
}

fn json(args: &[&str]) -> serde_json::Value {
    serde_json::from_str(&run_ok(args)).unwrap()
}

/// model3 with its vertical thruster 20 mm forward of the CO (hidden
/// `thruster-moment-arm`), driven by steps of both signs on every thruster; 20 Hz.
fn hidden_arm_csv(path: &Path, seed: u64, duration_s: f64) {
    let base = load_default_model("model3").unwrap();
    let mut p = *base.as_any().downcast_ref::<Model3>().unwrap().params();
    let g = p.thrusters.vertical.geometry;
    let pos = g.position_m();
    p.thrusters.vertical.geometry =
        ThrusterGeometry::new(nalgebra::Vector3::new(0.020, pos.y, pos.z), g.direction()).unwrap();
    let mut cfg = SimConfig::with_model(Box::new(Model3::new(p).unwrap()));
    cfg.initial = InitialConditions::at_rest(4.0, 30.0);
    let mut sim = Simulator::new(cfg, seed).unwrap();
    // A deterministic pseudo-random sequence of holds (LCG), levels of both signs.
    let mut x = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    let mut next = || {
        x = x
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((x >> 33) as f64) / f64::from(1u32 << 31)
    };
    let mut holds = Vec::new();
    let mut t = 0.0;
    while t < duration_s {
        let level = [-60.0, -40.0, -20.0, 20.0, 40.0, 60.0][(next() * 6.0) as usize % 6];
        let cmd = match (next() * 3.0) as usize {
            0 => ThrustPct::new(0.0, 0.0, level),
            1 => ThrustPct::new(level * 0.5, -level * 0.5, 0.0),
            _ => ThrustPct::new(level * 0.5, level * 0.5, -level * 0.4),
        };
        holds.push((6.0, cmd));
        holds.push((4.0, ThrustPct::new(0.0, 0.0, 0.0)));
        t += 10.0;
    }
    let schedule = Schedule::from_holds(&holds).unwrap();
    let series = run_schedule_on(&mut sim, &SensorConfig::default(), &schedule, 0.05).unwrap();
    std::fs::write(path, series.to_csv()).unwrap();
}

#[test]
fn catalog_and_models_are_listed() {
    let effects = json(&["lab", "effects", "--json"]);
    let ids: Vec<&str> = effects
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["id"].as_str().unwrap())
        .collect();
    assert_eq!(ids.len(), 17, "{ids:?}");
    for id in [
        "thrust-asymmetry",
        "thruster-lag",
        "thruster-deadzone",
        "power-limit",
        "thruster-moment-arm",
        "propeller-torque",
        "net-buoyancy",
        "restoring-offset",
        "pitch-depth-coupling",
        "coriolis",
        "added-mass",
        "drag-form",
        "current",
        "tether",
        "depth-sensor-drift",
        "compass-deviation",
        "attitude-bias",
    ] {
        assert!(ids.contains(&id), "{id}");
    }
    let models = json(&["lab", "models", "--json"]);
    let models = models.as_array().unwrap();
    assert_eq!(models.len(), 3);
    let m3 = models.iter().find(|m| m["model"] == "model3").unwrap();
    let contains: Vec<&str> = m3["contains"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert!(contains.contains(&"added-mass") && contains.contains(&"net-buoyancy"));
    // The text forms work too.
    assert!(run_ok(&["lab", "effects"]).contains("thruster-moment-arm"));
    assert!(run_ok(&["lab", "models"]).contains("model2"));
}

#[test]
fn diagnose_add_save_and_reuse_the_extended_model() {
    let (train, val) = (tmp("train.csv"), tmp("val.csv"));
    hidden_arm_csv(&train, 3, 300.0);
    hidden_arm_csv(&val, 4, 150.0);
    let (train_s, val_s) = (train.to_str().unwrap(), val.to_str().unwrap());

    // Diagnose: the documented JSON, the hidden effect first and significant.
    let d = json(&diagnose_args(train_s, val_s));
    assert_eq!(d["model"], "model3");
    for ch in ["depth", "heading", "pitch", "roll"] {
        let c = &d["baseline"]["channels"][ch];
        assert!(c["rmse"].as_f64().unwrap() > 0.0, "{ch}: {c}");
        assert!(c.get("fit_pct").is_some(), "{ch}: {c}");
    }
    let first = &d["findings"][0];
    assert_eq!(first["effect"], "thruster-moment-arm", "{first}");
    assert_eq!(first["significant"], true);
    assert!(first["explanation"].as_str().unwrap().contains("mm"));
    assert!(
        first["channels"]
            .as_array()
            .unwrap()
            .iter()
            .any(|c| c == "pitch")
    );
    let red = &first["validation_rmse_reduction_pct"];
    for ch in ["depth", "heading", "pitch", "roll"] {
        assert!(red[ch].is_number(), "{ch} missing: {red}");
    }
    assert!(red["pitch"].as_f64().unwrap() >= 50.0, "{red}");
    let arm_mm = first["params"]["vertical_arm_x_m"]["value"]
        .as_f64()
        .unwrap();
    assert!((arm_mm - 20.0).abs() <= 7.0, "arm {arm_mm} mm");

    // Add it, save, plot.
    let saved = tmp("model3-arm.toml");
    let plots = tmp("plots");
    let _ = std::fs::remove_dir_all(&plots);
    let a = json(&[
        "lab",
        "add",
        "--model",
        "model3",
        "--effects",
        "thruster-moment-arm",
        "--data",
        train_s,
        "--validate",
        val_s,
        "--json",
        "--save",
        saved.to_str().unwrap(),
        "--plots",
        plots.to_str().unwrap(),
    ]);
    let before = a["before"]["pitch"]["rmse"].as_f64().unwrap();
    let after = a["after"]["pitch"]["rmse"].as_f64().unwrap();
    assert!(after < 0.5 * before, "pitch RMSE {before} -> {after}");
    assert!(saved.is_file());
    let pngs = std::fs::read_dir(&plots)
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .path()
                .extension()
                .is_some_and(|x| x == "png")
        })
        .count();
    assert!(pngs >= 2, "{pngs} PNGs");

    // The saved model loads like any model: lab compare, sim run, hold.
    let c = json(&[
        "lab",
        "compare",
        "--model",
        saved.to_str().unwrap(),
        "--data",
        val_s,
        "--json",
    ]);
    let base = json(&[
        "lab", "compare", "--model", "model3", "--data", val_s, "--json",
    ]);
    let rmse = |j: &serde_json::Value| {
        j["pooled"]["free_run"]["channels"]["pitch"]["rmse"]
            .as_f64()
            .unwrap()
    };
    assert!(
        rmse(&c) < 0.5 * rmse(&base),
        "{} vs {}",
        rmse(&c),
        rmse(&base)
    );

    let pred = tmp("pred.csv");
    run_ok(&[
        "sim",
        "run",
        "--model",
        saved.to_str().unwrap(),
        "--data",
        val_s,
        "--out",
        pred.to_str().unwrap(),
    ]);
    let text = std::fs::read_to_string(&pred).unwrap();
    let header = text.lines().next().unwrap();
    assert!(header.starts_with("time_s,port_pct,starboard_pct,vertical_pct"));
    assert!(header.contains("pitch_deg") && header.contains("depth_m"));
    assert!(text.lines().count() > 2000);

    let h = json(&[
        "hold",
        "--model",
        "model3",
        "--depth-m",
        "5",
        "--heading-deg",
        "90",
        "--duration-s",
        "30",
        "--vehicle",
        saved.to_str().unwrap(),
        "--json",
    ]);
    assert!(h["depth"]["settle_s"].is_number(), "{h}");
}

#[test]
fn bad_lab_input_is_named() {
    let o = topside()
        .args([
            "lab",
            "compare",
            "--model",
            "model9",
            "--data",
            "nothing.csv",
        ])
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("model9"));
    let bad = tmp("bad.csv");
    std::fs::write(&bad, "time_s,depth_m\n0,nan\n").unwrap();
    let o = topside()
        .args(["lab", "compare", "--model", "model3", "--data"])
        .arg(&bad)
        .output()
        .unwrap();
    assert!(!o.status.success());
    let o = topside()
        .args([
            "lab",
            "add",
            "--model",
            "model3",
            "--effects",
            "warp-drive",
            "--data",
            "a.csv",
            "--validate",
            "b.csv",
        ])
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("warp-drive"));
    // A worker count outside 1..=1024 is refused, naming the option and the range.
    fails_naming(
        &[
            "lab",
            "diagnose",
            "--model",
            "model3",
            "--data",
            "a.csv",
            "--validate",
            "b.csv",
            "--threads",
            "0",
        ],
        "--threads",
    );
    fails_naming(
        &[
            "lab",
            "compare",
            "--model",
            "model3",
            "--data",
            "a.csv",
            "--threads",
            "0",
        ],
        "1..=1024",
    );
}

/// `lab --help` states the verdict's statistical test.
#[test]
fn lab_help_states_the_verdict_test() {
    let out = topside().args(["lab", "--help"]).output().unwrap();
    assert!(out.status.success());
    let help = String::from_utf8_lossy(&out.stdout);
    for needle in [
        "adequate",
        "explained",
        "unexplained",
        "chi^2",
        "noise floor",
        "white",
    ] {
        assert!(
            help.contains(needle),
            "`lab --help` lacks {needle:?}:\n{help}"
        );
    }
}

/// shared/real_data's BlueROV2 tank CSVs, if present.
fn bluerov_csv(name: &str) -> Option<PathBuf> {
    let shared = std::env::var_os("TOPSIDE_SHARED_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared"));
    let p = shared.join("real_data/bluerov2_saabmarine_mex").join(name);
    p.exists().then_some(p)
}

/// Issue 13, part 1: a BlueROV2 tank run mapped onto the Pro 4 (model3) comes out
/// "unexplained", with `--json` stdout holding only the JSON; the text report says it in
/// words.
#[test]
fn bluerov_on_the_pro4_is_unexplained_and_json_stdout_is_pure() {
    let (Some(train), Some(val)) = (
        bluerov_csv("session_2025_05_27-11_57_50_0_3dof.csv"),
        bluerov_csv("session_2025_05_27-11_10_52_sync_0_3dof.csv"),
    ) else {
        eprintln!("shared/real_data is not present; nothing to check");
        return;
    };
    let (t, v) = (train.to_str().unwrap(), val.to_str().unwrap());
    let out = topside()
        .args([
            "lab",
            "diagnose",
            "--model",
            "model3",
            "--data",
            t,
            "--validate",
            v,
            "--json",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // The whole of stdout parses as one JSON document.
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(j["verdict"], "unexplained", "{}", j["summary"]);
    let un = j["unexplained"].as_array().unwrap();
    assert!(!un.is_empty());
    for u in un {
        for key in [
            "channel",
            "rmse",
            "noise",
            "ratio",
            "where",
            "correlates_with",
        ] {
            assert!(!u[key].is_null(), "{key} missing in {u}");
        }
    }
    assert!(
        !j["data"].as_array().unwrap().is_empty(),
        "treatments in words"
    );
    let text = run_ok(&[
        "lab",
        "diagnose",
        "--model",
        "model3",
        "--data",
        t,
        "--validate",
        v,
    ]);
    assert!(text.contains("verdict: unexplained"), "{text}");
    assert!(text.contains("unexplained: "), "{text}");
}

/// `lab add --terms` adds a discovered-term form like an effect, and the saved model
/// carries it: the term table is in the file and the file loads in `lab compare`.
#[test]
fn add_terms_saves_a_model_that_carries_them() {
    let (train, val) = (tmp("terms_train.csv"), tmp("terms_val.csv"));
    hidden_arm_csv(&train, 7, 120.0);
    hidden_arm_csv(&val, 8, 60.0);
    let saved = tmp("with_term.toml");
    let (t, v) = (train.to_str().unwrap(), val.to_str().unwrap());
    let r = json(&[
        "lab",
        "add",
        "--model",
        "model3",
        "--terms",
        "term:heave:r2",
        "--data",
        t,
        "--validate",
        v,
        "--json",
        "--save",
        saved.to_str().unwrap(),
    ]);
    assert_eq!(r["effects"][0], "term:heave:r2", "{r}");
    let text = std::fs::read_to_string(&saved).unwrap();
    assert!(
        text.contains("[[lab.terms]]") && text.contains("dof = \"heave\""),
        "{text}"
    );
    let c = json(&[
        "lab",
        "compare",
        "--model",
        saved.to_str().unwrap(),
        "--data",
        v,
        "--json",
    ]);
    assert!(
        c["pooled"]["shooting"]["channels"]["depth"]["rmse"].is_number(),
        "{c}"
    );
    // An unknown term is refused by name.
    fails_naming(
        &[
            "lab",
            "add",
            "--model",
            "model3",
            "--terms",
            "term:heave:warp",
            "--data",
            t,
            "--validate",
            v,
        ],
        "term:heave:warp",
    );
}

/// Every per-channel summary of `lab compare`, `add` and `diagnose` carries both error
/// views under explicit keys; `rmse` keeps its meaning (multiple shooting in all three:
/// in `diagnose`'s `baseline` too), and on a model with a missing effect the free run (which integrates the
/// error) and multiple shooting (re-started from the measurement every window) differ.
#[test]
fn summaries_name_both_error_views() {
    let (train, val) = (tmp("views_train.csv"), tmp("views_val.csv"));
    hidden_arm_csv(&train, 7, 120.0);
    hidden_arm_csv(&val, 8, 60.0);
    let (t, v) = (train.to_str().unwrap(), val.to_str().unwrap());
    let f = |c: &serde_json::Value, key: &str| -> f64 {
        c[key]
            .as_f64()
            .unwrap_or_else(|| panic!("{key} missing: {c}"))
    };
    // The summary's two views are the pooled views' own numbers, and `rmse` is shooting.
    let check = |summary: &serde_json::Value, what: &str| {
        let chans = summary.as_object().unwrap();
        assert!(!chans.is_empty(), "{what}: no channels");
        for (ch, c) in chans {
            assert_eq!(f(c, "rmse"), f(c, "rmse_shooting"), "{what} {ch}: {c}");
            assert!(f(c, "rmse_free_run") > 0.0, "{what} {ch}: {c}");
        }
    };
    let c = json(&["lab", "compare", "--model", "model3", "--data", v, "--json"]);
    check(&c["channels"], "compare");
    for ch in ["depth", "heading", "pitch", "roll"] {
        let s = &c["channels"][ch];
        assert_eq!(
            f(s, "rmse_free_run"),
            f(&c["pooled"]["free_run"]["channels"][ch], "rmse"),
            "{ch}"
        );
        assert_eq!(
            f(s, "rmse_shooting"),
            f(&c["pooled"]["shooting"]["channels"][ch], "rmse"),
            "{ch}"
        );
    }
    // Heading integrates the yaw rate: a model error accumulates over the free run but
    // only over one window in multiple shooting, so the free run's error is larger.
    let h = &c["channels"]["heading"];
    assert!(
        f(h, "rmse_free_run") > 1.2 * f(h, "rmse_shooting"),
        "the views coincide: {h}"
    );
    // The moment arm added (`lab add`, as `diagnose_add_save_and_reuse_the_extended_model`).
    let mut add = diagnose_args(t, v);
    add[1] = "add";
    let add = [&add[..], &["--effects", "thruster-moment-arm"]].concat();
    let a = json(&add);
    check(&a["before"], "add before");
    check(&a["after"], "add after");
    for s in a["error_fall"].as_array().unwrap() {
        assert_eq!(s["rmse"], s["rmse_shooting"], "{s}");
        assert!(s["rmse_free_run"].is_object(), "{s}");
    }
    let d = json(&diagnose_args(t, v));
    check(&d["baseline"]["channels"], "diagnose");
    let dh = &d["baseline"]["channels"]["heading"];
    assert!(
        f(dh, "rmse_free_run") > f(dh, "rmse_shooting"),
        "the views coincide: {dh}"
    );
}

/// `import` reads a log as the lab does (`rov_lab::loader`): a BlueROV2 tank CSV needs no
/// `--map` (its shipped map is recognised from the header), and the session holds the rows
/// the lab reads from the CSV.
#[test]
fn import_reads_a_bluerov_csv_as_the_lab_does() {
    let Some(csv) = bluerov_csv("session_2025_05_27-11_10_52_sync_0_3dof.csv") else {
        eprintln!("shared/real_data is not present; nothing to check");
        return;
    };
    let out = tmp("bluerov_import.mcap");
    let o = topside()
        .arg("import")
        .arg(&csv)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("not Pro 4 thrusters"), "{err}");
    let bytes = std::fs::read(&csv).unwrap();
    let lab = rov_lab::loader::read_bytes(&bytes, "bluerov.csv").unwrap();
    let s = rov_session::open(&out).unwrap();
    let (series, _, _) = rov_session::measurements(&s).unwrap();
    assert_eq!(series.rows.len(), lab.len());
    for (a, b) in series.rows.iter().zip(&lab.series.rows).step_by(97) {
        assert!((a.time_s - b.time_s).abs() < 1e-6, "{a:?} {b:?}");
        assert!((a.depth_m - b.depth_m).abs() < 1e-6, "{a:?} {b:?}");
    }
}
