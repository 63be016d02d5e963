//! `topside session recover`, `export`, `import` and `replay --headless` end to end: the
//! real binary on files made here.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use rov_dynamics::{InitialConditions, ThrustPct, load_default_model, simulate};
use rov_session::{NavRecord, SessionInfo, SessionWriter, ThrustRecord};
use rov_types::measurement::{MeasurementRow, MeasurementSeries};

fn topside(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_topside"))
        .args(args)
        .output()
        .expect("run topside")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn json_out(o: &Output) -> serde_json::Value {
    serde_json::from_slice(&o.stdout).unwrap_or_else(|e| {
        panic!(
            "stdout is not JSON ({e}):\n{}\nstderr:\n{}",
            String::from_utf8_lossy(&o.stdout),
            stderr(o)
        )
    })
}

/// A scratch directory removed on drop.
struct Scratch(PathBuf);

impl Scratch {
    fn new(name: &str) -> Self {
        let dir =
            std::env::temp_dir().join(format!("topside-session-cli-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Self(dir)
    }
    fn path(&self, file: &str) -> PathBuf {
        self.0.join(file)
    }
    fn arg(&self, file: &str) -> String {
        self.path(file).display().to_string()
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// 20 s of a dive "measured" by model3 itself, as a measurement CSV.
fn model3_csv() -> String {
    let m3 = load_default_model("model3").unwrap();
    let x0 = m3.initial_state(&InitialConditions::at_rest(2.0, 90.0));
    let inputs: Vec<(f64, ThrustPct)> = (0..1000)
        .map(|k| {
            let t = k as f64 * 0.02;
            (
                t,
                ThrustPct::new(
                    50.0,
                    if t < 8.0 { 50.0 } else { 10.0 },
                    30.0 * (0.5 * t).sin(),
                ),
            )
        })
        .collect();
    let out = simulate(m3.as_ref(), &x0, &inputs, 0.02).unwrap();
    let rows = inputs
        .iter()
        .zip(&out)
        .map(|((t, c), o)| MeasurementRow {
            time_s: *t,
            port_pct: c.port,
            starboard_pct: c.starboard,
            vertical_pct: c.vertical,
            depth_m: o.depth_m.unwrap(),
            heading_deg: o.heading_deg.unwrap(),
            pitch_deg: o.pitch_deg.unwrap(),
            roll_deg: o.roll_deg.unwrap(),
            optional: [None; 8],
        })
        .collect();
    MeasurementSeries {
        rows,
        ..MeasurementSeries::default()
    }
    .to_csv()
}

#[test]
fn import_export_and_replay() {
    let d = Scratch::new("roundtrip");
    let csv = model3_csv();
    std::fs::write(d.path("in.csv"), &csv).unwrap();

    let o = topside(&["import", &d.arg("in.csv"), "--out", &d.arg("s.mcap")]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("1000 rows"), "{}", stderr(&o));

    let o = topside(&["export", &d.arg("s.mcap"), "--csv", &d.arg("out.csv")]);
    assert!(o.status.success(), "{}", stderr(&o));
    let back = MeasurementSeries::parse_csv(
        &std::fs::read_to_string(d.path("out.csv")).unwrap(),
        "out.csv",
    )
    .unwrap();
    let orig = MeasurementSeries::parse_csv(&csv, "in.csv").unwrap();
    assert_eq!(back.rows.len(), orig.rows.len());
    for (a, b) in back.rows.iter().zip(&orig.rows) {
        assert!((a.time_s - b.time_s).abs() < 1e-9);
        assert_eq!(
            (a.port_pct, a.vertical_pct, a.depth_m, a.heading_deg),
            (b.port_pct, b.vertical_pct, b.depth_m, b.heading_deg)
        );
    }
    assert!(back.rows.windows(2).all(|w| w[1].time_s > w[0].time_s));

    // The summary alone: from the index, no model fit, no decoding.
    let o = topside(&["replay", &d.arg("s.mcap"), "--headless", "--speed", "50"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = json_out(&o);
    assert_eq!(j["complete"], true);
    assert_eq!(j["model"], serde_json::Value::Null);
    assert_eq!(j["fit"], serde_json::Value::Null);
    assert_eq!(j["checked"], false);
    assert!(
        j["channels"]
            .as_array()
            .unwrap()
            .iter()
            .all(|c| c["decode_errors"].is_null())
    );
    assert!((j["duration_s"].as_f64().unwrap() - 19.98).abs() < 1e-9);

    let o = topside(&[
        "replay",
        &d.arg("s.mcap"),
        "--headless",
        "--speed",
        "50",
        "--model",
        "model3",
        "--check",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = json_out(&o);
    assert_eq!(j["complete"], true);
    assert_eq!(j["model"], "model3");
    assert_eq!(j["checked"], true);
    assert_eq!(j["speed"], 50.0);
    assert!(
        (j["duration_s"].as_f64().unwrap() - 19.98).abs() < 1e-9,
        "{j}"
    );
    assert!(
        (j["replay_wall_s"].as_f64().unwrap() - 19.98 / 50.0).abs() < 0.05,
        "{j}"
    );
    let channels = j["channels"].as_array().unwrap();
    let count = |topic: &str| {
        channels
            .iter()
            .find(|c| c["topic"] == topic)
            .map(|c| c["count"].clone())
    };
    assert_eq!(count("/telemetry/nav"), Some(1000.into()));
    assert_eq!(count("/command/thrust"), Some(1000.into()));
    assert_eq!(count("/session/info"), Some(1.into()));
    assert_eq!(count("/tf"), Some(200.into()), "poses at 10 Hz");
    assert!(
        channels.iter().all(|c| c["decode_errors"] == 0),
        "{channels:?}"
    );
    let fit = j["fit"].as_array().unwrap();
    assert_eq!(fit.len(), 4);
    for f in fit {
        assert_eq!(f["predicted"], true, "{f}");
        assert!(f["fit_pct"].as_f64().unwrap() > 99.9, "{f}");
    }
    assert!(stderr(&o).contains("depth_m"), "{}", stderr(&o));

    let o = topside(&[
        "replay",
        &d.arg("s.mcap"),
        "--headless",
        "--model",
        "model1",
        "--speed",
        "500",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = json_out(&o);
    assert_eq!(j["speed"], 50.0, "clamped");
    let pitch = j["fit"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["channel"] == "pitch_deg")
        .unwrap()
        .clone();
    assert_eq!(pitch["predicted"], false);
    assert!(
        stderr(&o).contains("pitch_deg      not predicted by model1"),
        "{}",
        stderr(&o)
    );
}

fn record(path: &Path, ticks: u64) {
    let info = SessionInfo {
        vehicle: "sim".into(),
        software_version: "cli test".into(),
        started_unix_s: 1.75e9,
        config_toml: "x = 1\n".into(),
    };
    let mut w = SessionWriter::create(path, &info, 0).unwrap();
    for k in 0..ticks {
        let t = k * 20_000_000;
        let nav = NavRecord {
            depth_m: 1.0 + k as f64 * 0.001,
            heading_deg: 45.0,
            pitch_deg: 0.0,
            roll_deg: 0.0,
            ..NavRecord::default()
        };
        w.write(t + 6_000_000, &nav).unwrap();
        let c = ThrustRecord {
            port_pct: 10.0,
            starboard_pct: 10.0,
            vertical_pct: 20.0,
            ..ThrustRecord::default()
        };
        w.write(t + 6_100_000, &c).unwrap();
    }
    w.finish().unwrap();
}

#[test]
fn truncated_files_export_and_replay_with_a_warning_and_recover() {
    let d = Scratch::new("truncated");
    record(&d.path("full.mcap"), 500);
    let bytes = std::fs::read(d.path("full.mcap")).unwrap();
    let cut = &bytes[..bytes.len() * 6 / 10];
    std::fs::write(d.path("cut.mcap"), cut).unwrap();

    let o = topside(&["export", &d.arg("cut.mcap"), "--csv", &d.arg("cut.csv")]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("warning:") && stderr(&o).contains("truncated"),
        "{}",
        stderr(&o)
    );
    let m = MeasurementSeries::parse_csv(
        &std::fs::read_to_string(d.path("cut.csv")).unwrap(),
        "cut.csv",
    )
    .unwrap();
    assert!(m.rows.len() > 100 && m.rows.len() < 500, "{}", m.rows.len());

    let o = topside(&["replay", &d.arg("cut.mcap"), "--headless"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("truncated"), "{}", stderr(&o));
    let j = json_out(&o);
    assert_eq!(j["complete"], false);
    assert_eq!(j["damage"]["kind"], "truncated");

    let o = topside(&["session", "recover", &d.arg("cut.mcap")]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = json_out(&o);
    assert_eq!(j["output"], d.arg("cut.recovered.mcap"));
    assert!(j["lost_bytes"].as_u64().unwrap() > 0);
    assert_eq!(j["input_bytes"].as_u64().unwrap(), cut.len() as u64);
    assert_eq!(
        std::fs::read(d.path("cut.mcap")).unwrap(),
        cut,
        "input untouched"
    );
    let o = topside(&[
        "export",
        &d.arg("cut.recovered.mcap"),
        "--csv",
        &d.arg("rec.csv"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        !stderr(&o).contains("warning"),
        "the recovered file is complete: {}",
        stderr(&o)
    );
    assert_eq!(
        std::fs::read_to_string(d.path("rec.csv")).unwrap(),
        std::fs::read_to_string(d.path("cut.csv")).unwrap()
    );
}

#[test]
fn bad_input_is_a_clear_error() {
    let d = Scratch::new("bad");
    let mut png = vec![0x89, b'P', b'N', b'G', 0x0D, 0x0A, 0x1A, 0x0A];
    png.extend([7u8; 64]);
    std::fs::write(d.path("x.png"), &png).unwrap();
    let png_arg = d.arg("x.png");
    let out_arg = d.arg("o.csv");
    for args in [
        vec!["export", png_arg.as_str(), "--csv", out_arg.as_str()],
        vec!["replay", png_arg.as_str(), "--headless"],
        vec!["session", "recover", png_arg.as_str()],
    ] {
        let o = topside(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        assert!(
            stderr(&o).contains("not an MCAP session file: a PNG image"),
            "{args:?}: {}",
            stderr(&o)
        );
    }
    record(&d.path("s.mcap"), 10);
    let o = topside(&["replay", &d.arg("s.mcap")]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--headless"), "{}", stderr(&o));
    let o = topside(&[
        "replay",
        &d.arg("s.mcap"),
        "--headless",
        "--model",
        "model9",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("model9"), "{}", stderr(&o));
    std::fs::write(d.path("bad.csv"), "time_s,depth_m\n0,1\n").unwrap();
    let o = topside(&["import", &d.arg("bad.csv"), "--out", &d.arg("b.mcap")]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("required column port_pct is missing"),
        "{}",
        stderr(&o)
    );
    let o = topside(&["export", &d.arg("missing.mcap"), "--csv", &d.arg("o.csv")]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("missing.mcap"), "{}", stderr(&o));
}
