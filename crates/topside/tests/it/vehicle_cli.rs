//! `topside vehicle new|check` through the binary (issue 22, part 2): every frame's
//! template is written, parses and checks clean; the JSON carries the pinned keys; an
//! implausible file exits 1 naming the problem; on the real BlueROV2 tank data the shipped
//! Heavy file's six channel signs agree with the log, and a file with the yaw mix flipped
//! is caught.

use std::path::PathBuf;
use std::process::{Command, Output};

fn topside() -> Command {
    Command::new(env!("CARGO_BIN_EXE_topside"))
}

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("topside-vehicle-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn json_of(out: &Output) -> serde_json::Value {
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "{e}: {}\n{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        )
    })
}

#[test]
fn every_frame_template_is_written_and_checks_clean() {
    let dir = tmp_dir("new");
    for frame in [
        "pro4",
        "pro4-lateral",
        "bluerov2",
        "bluerov2-heavy",
        "custom",
    ] {
        let file = dir.join(format!("{frame}.toml"));
        let _ = std::fs::remove_file(&file);
        let out = topside()
            .args(["vehicle", "new", "--frame", frame, "--out"])
            .arg(&file)
            .output()
            .unwrap();
        assert!(out.status.success(), "{frame}: {out:?}");
        // It does not overwrite without --force.
        let again = topside()
            .args(["vehicle", "new", "--frame", frame, "--out"])
            .arg(&file)
            .output()
            .unwrap();
        assert!(!again.status.success());
        assert!(String::from_utf8_lossy(&again.stderr).contains("--force"));
        let out = topside()
            .args(["vehicle", "check"])
            .arg(&file)
            .arg("--json")
            .output()
            .unwrap();
        assert!(out.status.success(), "{frame}: {out:?}");
        let j = json_of(&out);
        assert!(j["statics"]["mass_kg"].as_f64().unwrap() > 1.0, "{frame}");
        assert!(j["issues"].as_array().unwrap().is_empty(), "{frame}: {j}");
        let channels = j["channels"].as_array().unwrap();
        assert!(channels.len() >= 3, "{frame}");
        for c in channels {
            for key in [
                "channel",
                "expected_dof",
                "expected_sign",
                "observed_dof",
                "observed_sign",
                "correlation",
                "lag_s",
                "agree",
            ] {
                assert!(c.get(key).is_some(), "{frame}: {key} missing in {c}");
            }
            assert!(c["agree"].is_null());
        }
        assert_eq!(j["mixing"].as_array().unwrap().len(), channels.len());
    }
}

#[test]
fn an_implausible_file_exits_1_and_names_the_problem() {
    let dir = tmp_dir("bad");
    let file = dir.join("custom.toml");
    let _ = std::fs::remove_file(&file);
    assert!(
        topside()
            .args(["vehicle", "new", "--frame", "custom", "--out"])
            .arg(&file)
            .status()
            .unwrap()
            .success()
    );
    let text = std::fs::read_to_string(&file).unwrap().replace(
        "cg_from_co_m = { value = [0.0, 0.0, 0.02]",
        "cg_from_co_m = { value = [0.6, 0.0, 0.02]",
    );
    std::fs::write(&file, text).unwrap();
    let out = topside()
        .args(["vehicle", "check"])
        .arg(&file)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    let s = String::from_utf8_lossy(&out.stdout);
    assert!(s.contains("cg-outside-hull"), "{s}");
    // A map that does not exist is named in the error.
    let out = topside()
        .args(["vehicle", "check"])
        .arg(&file)
        .args(["--log", "x.csv", "--map", "m.toml"])
        .output()
        .unwrap();
    assert_ne!(out.status.code(), Some(0));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("m.toml"), "{err}");
}

/// shared/real_data's BlueROV2 tank CSVs, if present.
fn bluerov_csv(name: &str) -> Option<PathBuf> {
    let shared = std::env::var_os("TOPSIDE_SHARED_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared"));
    let p = shared.join("real_data/bluerov2_saabmarine_mex").join(name);
    p.exists().then_some(p)
}

#[test]
fn the_heavys_signs_agree_with_the_tank_data_and_a_flipped_yaw_is_caught() {
    let Some(log) = bluerov_csv("session_2025_05_27-12_04_31_0_6dof.csv") else {
        eprintln!("shared/real_data is not present; nothing to check");
        return;
    };
    let shipped =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../config/vehicles/bluerov2_heavy.toml");
    let check = |file: &std::path::Path| {
        let out = topside()
            .args(["vehicle", "check"])
            .arg(file)
            .arg("--log")
            .arg(&log)
            .arg("--json")
            .output()
            .unwrap();
        (out.status.code(), json_of(&out))
    };
    let (code, j) = check(&shipped);
    assert_eq!(code, Some(0), "{j}");
    for c in j["channels"].as_array().unwrap() {
        assert_eq!(c["agree"], serde_json::Value::Bool(true), "{c}");
        assert_eq!(c["observed_dof"], c["expected_dof"], "{c}");
    }
    // Every horizontal thruster's yaw factor negated: the yaw demand turns the vehicle
    // anticlockwise in the file, clockwise in the tank.
    let text = std::fs::read_to_string(&shipped).unwrap();
    let flipped = text
        .replace("mix_yaw = { value = 1.0,", "mix_yaw = { value = X,")
        .replace("mix_yaw = { value = -1.0,", "mix_yaw = { value = 1.0,")
        .replace("mix_yaw = { value = X,", "mix_yaw = { value = -1.0,");
    let dir = tmp_dir("yaw");
    let file = dir.join("flipped.toml");
    std::fs::write(&file, flipped).unwrap();
    let (code, j) = check(&file);
    assert_eq!(code, Some(1), "{j}");
    let yaw = j["channels"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["channel"] == "yaw")
        .unwrap();
    assert_eq!(yaw["agree"], serde_json::Value::Bool(false), "{yaw}");
    assert_eq!(yaw["observed_dof"], "yaw");
    assert_eq!(yaw["observed_sign"], 1);
}
