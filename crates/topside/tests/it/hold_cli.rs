//! `topside hold ... --json`: the real binary, the exact JSON layout and sane values.

use std::process::Command;

fn hold(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_topside"))
        .arg("hold")
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn hold_prints_the_documented_json() {
    let out = hold(&[
        "--model",
        "model1",
        "--depth-m",
        "6",
        "--heading-deg",
        "10",
        "--duration-s",
        "25",
        "--disturbance",
        "tether",
        "--seed",
        "3",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let keys = |o: &serde_json::Value| -> Vec<String> {
        let mut k: Vec<String> = o.as_object().unwrap().keys().cloned().collect();
        k.sort();
        k
    };
    assert_eq!(keys(&v), ["depth", "heading", "observer", "thrust"]);
    assert_eq!(
        keys(&v["depth"]),
        ["overshoot_pct", "rmse_m", "settle_s", "steady_error_m"]
    );
    assert_eq!(
        keys(&v["heading"]),
        ["overshoot_deg", "rmse_deg", "settle_s", "steady_error_deg"]
    );
    assert_eq!(keys(&v["thrust"]), ["saturated_pct"]);
    assert_eq!(keys(&v["observer"]), ["depth_rmse_m", "heading_rmse_deg"]);
    // Default start: 2 m shallower, 90° off; heading 10° means starting at 280° (through north).
    assert!(v["depth"]["settle_s"].as_f64().unwrap() <= 10.0, "{v}");
    assert!(v["heading"]["settle_s"].as_f64().unwrap() <= 8.0, "{v}");
    assert!(
        v["heading"]["steady_error_deg"].as_f64().unwrap() <= 1.0,
        "{v}"
    );
}

#[test]
fn hold_options_parse_and_bad_values_fail_clearly() {
    let out = hold(&[
        "--model",
        "model3",
        "--depth-m",
        "3",
        "--heading-deg",
        "-30",
        "--duration-s",
        "12",
        "--start-depth-m",
        "3.5",
        "--start-heading-deg",
        "300",
        "--no-feedforward",
        "--observer",
        "off",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v["observer"]["depth_rmse_m"].is_number() || v["observer"]["depth_rmse_m"].is_null());
    let out = hold(&[
        "--model",
        "model4",
        "--depth-m",
        "3",
        "--heading-deg",
        "0",
        "--duration-s",
        "5",
        "--json",
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("model4"));
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(e.contains("model1, model2, model3 or a FILE.toml"), "{e}");
    // A model file drives the autopilot; one that does not exist is refused, named.
    let out = hold(&[
        "--model",
        "learned.toml",
        "--depth-m",
        "3",
        "--heading-deg",
        "0",
        "--duration-s",
        "5",
    ]);
    assert!(!out.status.success());
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(e.contains("reading learned.toml"), "{e}");
    let out = hold(&[
        "--model",
        "model1",
        "--depth-m",
        "900",
        "--heading-deg",
        "0",
        "--duration-s",
        "5",
        "--json",
    ]);
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("0..=300"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn survey(model: &str, extra: &[&str]) -> serde_json::Value {
    let mut args = vec![
        "--model",
        model,
        "--depth-m",
        "4",
        "--heading-deg",
        "350",
        "--duration-s",
        "0",
        "--profile",
        "survey",
        "--json",
    ];
    args.extend_from_slice(extra);
    let out = hold(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn hold_profile_survey_reports_tracking_rmse_next_to_the_step_metrics() {
    let v = survey("model3", &[]);
    let mut keys: Vec<&String> = v.as_object().unwrap().keys().collect();
    keys.sort();
    assert_eq!(
        keys,
        ["depth", "heading", "observer", "thrust", "tracking_rmse"]
    );
    let d = v["tracking_rmse"]["depth_m"].as_f64().unwrap();
    let h = v["tracking_rmse"]["heading_deg"].as_f64().unwrap();
    eprintln!("model3 survey: {v}");
    // Plausible: the loop follows 1–2 m moves to centimetres and 60–150° moves to a few
    // degrees; zero would mean the truth was compared with itself.
    assert!(d > 0.001 && d < 0.15, "depth tracking RMSE {d} m");
    assert!(h > 0.05 && h < 5.0, "heading tracking RMSE {h} deg");
    // The step metrics describe the final step (+1 m, +90° at 110 s), which settles
    // within the profile's 14 s of hold.
    assert!(v["depth"]["settle_s"].as_f64().unwrap() <= 14.0, "{v}");
    assert!(v["heading"]["settle_s"].as_f64().unwrap() <= 14.0, "{v}");
    assert!(
        v["heading"]["steady_error_deg"].as_f64().unwrap() <= 1.0,
        "{v}"
    );

    // The same reference without feedforward: PID alone tracks the moves worse.
    let pid = survey("model3", &["--no-feedforward"]);
    let dp = pid["tracking_rmse"]["depth_m"].as_f64().unwrap();
    let hp = pid["tracking_rmse"]["heading_deg"].as_f64().unwrap();
    eprintln!("no feedforward survey: {pid}");
    assert!(
        dp > d && hp > h,
        "feedforward {d} m {h} deg, PID only {dp} m {hp} deg"
    );
}

#[test]
fn hold_profile_is_documented_and_a_plain_hold_keeps_its_text() {
    let out = hold(&["--help"]);
    let help = String::from_utf8_lossy(&out.stdout);
    for needle in [
        "--profile",
        "survey",
        "ramp -150 deg",
        "step +1.0 m (down)",
        "tracking_rmse",
    ] {
        assert!(help.contains(needle), "{needle:?} missing from hold --help");
    }
    let out = hold(&[
        "--model",
        "model2",
        "--depth-m",
        "3",
        "--heading-deg",
        "0",
        "--duration-s",
        "10",
    ]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(text.lines().count(), 3, "{text}");
    assert!(!text.contains("tracking"), "{text}");
    // A profile that would take the vehicle below its rating is refused before running.
    let out = hold(&[
        "--model",
        "model1",
        "--depth-m",
        "299",
        "--heading-deg",
        "0",
        "--duration-s",
        "0",
        "--profile",
        "survey",
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("0..=300"));
}
