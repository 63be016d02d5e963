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
