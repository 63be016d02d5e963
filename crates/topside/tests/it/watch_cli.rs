//! The model watch through the binary (issue 23): `record --sim --fast --fault SPEC`
//! flies the transect script with the autopilot on and sensor noise, `record --json`
//! reports `watch.alerts`, and `lab watch` finds the same change in the session and in
//! its exported measurement CSV, and nothing on the same dive without the fault.

use std::path::PathBuf;
use std::process::Command;

fn topside() -> Command {
    Command::new(env!("CARGO_BIN_EXE_topside"))
}

fn tmp(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("watch_cli");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn script() -> String {
    format!(
        "{}/../../config/scripts/transect.toml",
        env!("CARGO_MANIFEST_DIR")
    )
}

/// Records a 360-s transect with the given faults; returns the session and the JSON.
fn record(name: &str, faults: &[&str]) -> (PathBuf, serde_json::Value) {
    let out = tmp(&format!("{name}.mcap"));
    let mut c = topside();
    c.args([
        "record",
        "--sim",
        "--fast",
        "--duration-s",
        "360",
        "--video",
        "none",
    ])
    .args(["--script", &script(), "--json", "--out"])
    .arg(&out);
    for f in faults {
        c.args(["--fault", f]);
    }
    let o = c.output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    (out, serde_json::from_slice(&o.stdout).unwrap())
}

fn lab_watch(file: &std::path::Path) -> serde_json::Value {
    let o = topside()
        .args(["lab", "watch", "--json"])
        .arg(file)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).unwrap()
}

fn changes(j: &serde_json::Value) -> Vec<serde_json::Value> {
    j["alerts"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|a| a["kind"] == "change")
        .cloned()
        .collect()
}

fn export_csv(mcap: &std::path::Path) -> PathBuf {
    let csv = mcap.with_extension("csv");
    let o = topside()
        .arg("export")
        .arg(mcap)
        .arg("--csv")
        .arg(&csv)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    csv
}

#[test]
fn a_compass_disturbance_is_found_named_and_sized_and_a_clean_dive_raises_nothing() {
    // Fault-free: no alert of any kind, in the record summary and in `lab watch`.
    let (clean, j) = record("clean", &[]);
    assert_eq!(j["watch"]["alerts"], serde_json::json!([]), "{j}");
    // Judged from the end of its first minute (12 s of history + 60 s) to the end.
    let judged = j["watch"]["judged_s"].as_f64().unwrap();
    assert!((280.0..=290.0).contains(&judged), "{judged}");
    assert_eq!(j["watch"]["model"], "model3");
    assert!(changes(&lab_watch(&clean)).is_empty());
    assert!(changes(&lab_watch(&export_csv(&clean))).is_empty());

    // The same dive with a 25° compass disturbance at 300 s.
    let (faulty, j) = record("compass", &["compass:25@300"]);
    let from_record = changes(&j["watch"]);
    let from_lab = changes(&lab_watch(&faulty));
    assert_eq!(from_record, from_lab, "one watch, one answer");
    let first = from_lab.first().expect("a change alert");
    let t_s = first["t_s"].as_f64().unwrap();
    assert!((300.0 - 1.0..=310.0).contains(&t_s), "{first}");
    assert_eq!(first["channel"], "heading", "{first}");
    let best = &first["causes"][0];
    assert_eq!(best["cause"], "compass", "{first}");
    assert_eq!(best["unit"], "deg");
    let size = best["size"].as_f64().unwrap();
    assert!((size - 25.0).abs() < 3.0, "{best}");
    // The pinned keys, and causes best first.
    for key in ["t_s", "kind", "channel", "size_noise", "causes"] {
        assert!(first.get(key).is_some(), "{key} in {first}");
    }
    let scores: Vec<f64> = first["causes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["score"].as_f64().unwrap())
        .collect();
    assert!(scores.windows(2).all(|w| w[0] >= w[1]), "{scores:?}");

    // The station's own watch (inline on virtual time) raised it while the dive was
    // flown: a model_watch event in the session, with the cause in words.
    let csv = export_csv(&faulty);
    let text = std::fs::read_to_string(&csv).unwrap();
    let live: Vec<&str> = text.lines().filter(|l| l.contains("model_watch")).collect();
    assert_eq!(live.len(), 1, "{live:?}");
    assert!(
        live[0].contains("change on heading") && live[0].contains("COMPASS OFF +25"),
        "{}",
        live[0]
    );
    let clean_csv = std::fs::read_to_string(export_csv(&clean)).unwrap();
    assert!(!clean_csv.contains("model_watch"));

    // The exported measurement CSV gives the same finding.
    let csv_changes = changes(&lab_watch(&csv));
    let c = csv_changes.first().expect("a change alert from the CSV");
    assert_eq!(c["causes"][0]["cause"], "compass", "{c}");
    assert!((c["t_s"].as_f64().unwrap() - t_s).abs() < 1.0, "{c}");
}

#[test]
fn a_port_thrust_loss_is_named_with_its_size() {
    let (_, j) = record("port", &["thrust-loss:port:0.4@300"]);
    let ch = changes(&j["watch"]);
    let first = ch.first().expect("a change alert");
    let t_s = first["t_s"].as_f64().unwrap();
    assert!((299.0..=310.0).contains(&t_s), "{first}");
    let best = &first["causes"][0];
    assert_eq!(best["cause"], "thrust-loss:port", "{first}");
    assert_eq!(best["unit"], "fraction");
    let lost = best["size"].as_f64().unwrap();
    assert!((lost - 0.4).abs() < 0.1, "{best}");
}

#[test]
fn a_model_that_is_merely_wrong_gives_one_mismatch_and_no_change() {
    // The vehicle has a 0.4-s thruster lag and half-strength reverse vertical thrust
    // (a lab-learned extended model); the autopilot and the watch use plain model3.
    let base = std::fs::read_to_string(format!(
        "{}/../../config/models/model3.toml",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap();
    let vehicle = tmp("lagged.toml");
    std::fs::write(
        &vehicle,
        format!(
            "{base}\n[lab]\nbase = \"model3\"\neffects = [\"thrust-asymmetry\", \"thruster-lag\"]\n[lab.params]\nreverse_ratio_vertical = {{ value = 0.5, unit = \"-\", source = \"test\" }}\nlag_time_constant_s = {{ value = 0.4, unit = \"s\", source = \"test\" }}\n"
        ),
    )
    .unwrap();
    let out = tmp("lagged.mcap");
    let o = topside()
        .args([
            "record",
            "--sim",
            "--fast",
            "--duration-s",
            "600",
            "--video",
            "none",
        ])
        .args(["--script", &script(), "--json", "--vehicle"])
        .arg(&vehicle)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let alerts = j["watch"]["alerts"].as_array().unwrap();
    assert_eq!(alerts.len(), 1, "{alerts:?}");
    assert_eq!(alerts[0]["kind"], "mismatch", "{alerts:?}");
    // It is dated in the first minute (the baseline) and sized in noise floors.
    assert!(alerts[0]["t_s"].as_f64().unwrap() < 60.0, "{alerts:?}");
    assert!(
        alerts[0]["size_noise"].as_f64().unwrap() > 3.0,
        "{alerts:?}"
    );
}

#[test]
fn a_log_shorter_than_the_first_minute_is_not_judged_and_says_so() {
    let out = tmp("short30.mcap");
    let o = topside()
        .args([
            "record",
            "--sim",
            "--fast",
            "--duration-s",
            "30",
            "--video",
            "none",
        ])
        .args(["--script", &script(), "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success());
    let o = topside().args(["lab", "watch"]).arg(&out).output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("not judged"), "{text}");
    assert_eq!(lab_watch(&out)["judged_s"], 0.0);
}

#[test]
fn bad_fault_specs_are_named() {
    for (spec, says) in [
        ("thrust-loss:aft:0.4@300", "aft"),
        ("buoyancy:3", "@"),
        ("warp:3@10", "warp"),
    ] {
        let o = topside()
            .args([
                "record",
                "--sim",
                "--fast",
                "--duration-s",
                "5",
                "--video",
                "none",
            ])
            .args(["--out", "/nonexistent/x.mcap", "--fault", spec])
            .output()
            .unwrap();
        assert!(!o.status.success(), "{spec} accepted");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(spec) && err.contains(says), "{spec}: {err}");
    }
}
