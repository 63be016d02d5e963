//! `topside record --sim`: a headless simulated dive through the whole station, recorded
//! to MCAP, read back with the session reader and through `topside export`.

use std::path::{Path, PathBuf};
use std::process::Command;

fn topside() -> Command {
    Command::new(env!("CARGO_BIN_EXE_topside"))
}

fn tmp(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("record_cli");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn run_json(args: &[&str]) -> serde_json::Value {
    let out = topside().args(args).output().unwrap();
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

/// The exported measurement CSV as (time, depth, heading, port %, starboard %) rows.
fn exported(mcap: &Path) -> Vec<[f64; 5]> {
    let csv = mcap.with_extension("csv");
    let out = topside()
        .arg("export")
        .arg(mcap)
        .arg("--csv")
        .arg(&csv)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let idx = [
        col("time_s"),
        col("depth_m"),
        col("heading_deg"),
        col("port_pct"),
        col("starboard_pct"),
    ];
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            idx.map(|i| f[i].parse::<f64>().unwrap_or(f64::NAN))
        })
        .collect()
}

fn at(rows: &[[f64; 5]], t: f64) -> [f64; 5] {
    *rows
        .iter()
        .min_by(|a, b| (a[0] - t).abs().total_cmp(&(b[0] - t).abs()))
        .unwrap()
}

#[test]
fn fast_builtin_dive_is_recorded_whole_and_flies_the_script() {
    let out = tmp("fast.mcap");
    let j = run_json(&[
        "record",
        "--sim",
        "--duration-s",
        "60",
        "--out",
        out.to_str().unwrap(),
        "--fast",
        "--json",
    ]);
    assert_eq!(j["complete"], true);
    assert_eq!(j["armed_as_scripted"], true);
    assert!(
        (j["duration_s"].as_f64().unwrap() - 60.0).abs() < 0.5,
        "{j}"
    );
    // 50 Hz control loop: every tick's command and telemetry, nothing dropped.
    let topics = &j["topics"];
    for (topic, min) in [
        ("/command/thrust", 2950),
        ("/telemetry/nav", 2950),
        ("/autopilot/state", 2950),
        ("/observer/state", 2950),
        ("/pro4/tx", 2950),
        ("/pro4/rx", 2950),
        ("/telemetry/status", 250),
        ("/link/stats", 100),
        ("/session/info", 1),
        ("/truth/state", 2950),
    ] {
        let n = topics[topic].as_u64().unwrap_or(0);
        assert!(n >= min, "{topic}: {n} < {min}");
    }
    let session = rov_session::open(&out).unwrap();
    assert!(session.is_complete());
    // The built-in dive: 3 m / 090° after 2 s, 5 m / 180° after 30 s.
    let rows = exported(&out);
    let r = at(&rows, 12.0);
    assert!(
        (r[1] - 3.0).abs() < 0.1 && (r[2] - 90.0).abs() < 2.0,
        "{r:?}"
    );
    let r = at(&rows, 20.0);
    // 40 % stick through the default 50 % gain and the stick expo.
    assert!(r[3] > 5.0 && r[4] > 5.0, "cruising forward: {r:?}");
    let r = at(&rows, 55.0);
    assert!(
        (r[1] - 5.0).abs() < 0.1 && (r[2] - 180.0).abs() < 2.0,
        "{r:?}"
    );
}

#[test]
fn a_pilot_script_drives_the_dive() {
    let script = tmp("dive.toml");
    std::fs::write(
        &script,
        r#"
        [[command]]
        t_s = 0.5
        arm = true
        [[command]]
        t_s = 2.0
        hold = "depth"
        sticks = { yaw = 0.5 }
        [[command]]
        t_s = 6.0
        sticks = { yaw = 0.0 }
        step_depth_m = 1.5
        [[command]]
        t_s = 18.0
        disarm = true
        "#,
    )
    .unwrap();
    let out = tmp("scripted.mcap");
    let j = run_json(&[
        "record",
        "--sim",
        "--duration-s",
        "20",
        "--out",
        out.to_str().unwrap(),
        "--script",
        script.to_str().unwrap(),
        "--fast",
        "--json",
    ]);
    assert_eq!(j["complete"], true);
    let rows = exported(&out);
    let start = at(&rows, 1.0);
    // Yawed to starboard under the stick, then held 1.5 m deeper than where the hold latched.
    let turned = at(&rows, 6.0)[2] - start[2];
    assert!(turned > 20.0, "turned {turned}°");
    let deeper = at(&rows, 17.0)[1] - at(&rows, 2.0)[1];
    assert!((deeper - 1.5).abs() < 0.15, "deeper by {deeper} m");
    // Disarmed: neutral thrust at the end.
    let end = at(&rows, 19.5);
    assert!(end[3].abs() < 1e-9 && end[4].abs() < 1e-9, "{end:?}");
}

#[test]
fn real_time_recording_runs_on_the_wall_clock() {
    let out = tmp("rt.mcap");
    let t0 = std::time::Instant::now();
    let j = run_json(&[
        "record",
        "--sim",
        "--duration-s",
        "3",
        "--out",
        out.to_str().unwrap(),
        "--json",
    ]);
    let wall = t0.elapsed().as_secs_f64();
    assert!(wall >= 3.0, "took {wall} s");
    assert_eq!(j["mode"], "real_time");
    assert_eq!(j["complete"], true);
    let d = j["duration_s"].as_f64().unwrap();
    assert!((2.5..4.0).contains(&d), "session {d} s");
    assert!(j["topics"]["/telemetry/nav"].as_u64().unwrap() > 100, "{j}");
    // The simulated vehicle's truth, taken from its own thread, is recorded beside the
    // telemetry and agrees with the measured depth (sensor noise aside).
    assert!(j["topics"]["/truth/state"].as_u64().unwrap() > 100, "{j}");
    let session = rov_session::open(&out).unwrap();
    let truth = session.records::<rov_session::TruthRecord>().unwrap();
    let nav = session.records::<rov_session::NavRecord>().unwrap();
    let (t_truth, last_truth) = truth.last().unwrap();
    let (_, last_nav) = nav.iter().rev().find(|(t, _)| t <= t_truth).unwrap();
    assert!(
        (last_truth.depth_m - last_nav.depth_m).abs() < 0.1,
        "truth {last_truth:?} vs nav {last_nav:?}"
    );
}

#[test]
fn bad_scripts_and_arguments_are_named() {
    let out = tmp("bad.mcap");
    let cases: [(&str, &[&str]); 3] = [
        (
            "[[command]]\nt_s = 1.0\nsticks = { surge = 1.5 }\n",
            &["command #1", "sticks.surge", "1.5", "-1..1"],
        ),
        (
            "[[command]]\nt_s = 1.0\ndepth_m = -3.0\n",
            &["depth_m", "-3", "0..300"],
        ),
        ("[[command]]\nt_s = 1.0\nwarp = 9\n", &["warp"]),
    ];
    for (i, (text, needles)) in cases.iter().enumerate() {
        let script = tmp(&format!("bad{i}.toml"));
        std::fs::write(&script, text).unwrap();
        let o = topside()
            .args(["record", "--sim", "--fast", "--duration-s", "5", "--out"])
            .arg(&out)
            .arg("--script")
            .arg(&script)
            .output()
            .unwrap();
        assert!(!o.status.success());
        let err = String::from_utf8_lossy(&o.stderr);
        for n in *needles {
            assert!(err.contains(n), "{n:?} not in {err}");
        }
    }
    let o = topside()
        .args(["record", "--duration-s", "5", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--sim"));
    let o = topside()
        .args(["record", "--sim", "--duration-s", "nan", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(!o.status.success());
}
