//! `topside sim paper`: runs the real binary and checks that what it writes makes physical
//! sense, not only that files appear.

use std::path::{Path, PathBuf};
use std::process::Command;

use rov_types::measurement::MeasurementSeries;

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn read(dir: &Path, name: &str) -> MeasurementSeries {
    let path = dir.join(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    MeasurementSeries::parse_csv(&text, name).unwrap()
}

/// Mean of `pick` over rows whose time lies in [t0, t1].
fn mean_between(
    s: &MeasurementSeries,
    t0: f64,
    t1: f64,
    pick: fn(&rov_types::MeasurementRow) -> f64,
) -> f64 {
    let v: Vec<f64> = s
        .rows
        .iter()
        .filter(|r| r.time_s >= t0 && r.time_s <= t1)
        .map(pick)
        .filter(|x| x.is_finite())
        .collect();
    assert!(!v.is_empty(), "no samples in [{t0}, {t1}]");
    v.iter().sum::<f64>() / v.len() as f64
}

#[test]
fn paper_experiments_are_written_and_physically_sensible() {
    let out = std::env::temp_dir().join(format!("topside_paper_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let status = Command::new(env!("CARGO_BIN_EXE_topside"))
        .current_dir(workspace_root())
        .args(["sim", "paper", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        status.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&status.stderr)
    );

    for exp in [
        "heave_steps",
        "heave_60",
        "yaw_steps",
        "yaw_60",
        "combined_60",
    ] {
        let png = std::fs::read(out.join(format!("{exp}.png"))).unwrap();
        assert_eq!(&png[1..4], b"PNG", "{exp}.png is a PNG");
        assert!(png.len() > 20_000, "{exp}.png has content");
        let measured = read(&out, &format!("{exp}.csv"));
        assert!(measured.rows.len() > 500);
        for model in ["model1", "model2", "model3"] {
            let pred = read(&out, &format!("{exp}.{model}.csv"));
            assert_eq!(pred.rows.len(), measured.rows.len(), "{exp}.{model}");
            let predicts_attitude = pred.rows.iter().any(|r| r.pitch_deg.is_finite());
            assert_eq!(
                predicts_attitude,
                model == "model3",
                "only model3 predicts pitch ({exp}.{model})"
            );
        }
    }

    // Heave: +30 % vertical (2..7 s) pushes down; every model and the vehicle go deeper.
    for file in [
        "heave_steps.csv",
        "heave_steps.model1.csv",
        "heave_steps.model2.csv",
        "heave_steps.model3.csv",
    ] {
        let s = read(&out, file);
        let before = mean_between(&s, 0.0, 1.5, |r| r.depth_m);
        let after = mean_between(&s, 6.5, 7.0, |r| r.depth_m);
        assert!(
            after > before + 0.2,
            "{file}: depth {before} -> {after} under +30 % vertical"
        );
    }
    // The simulated vehicle's reverse thrust is weaker: after +-90 % it ends deeper than it
    // started (the paper's depth drift), while the symmetric models come back.
    let measured = read(&out, "heave_steps.csv");
    let m3 = read(&out, "heave_steps.model3.csv");
    let end = measured.rows.last().unwrap().time_s;
    let drift = mean_between(&measured, end - 1.0, end, |r| r.depth_m)
        - mean_between(&measured, 0.0, 1.5, |r| r.depth_m);
    let drift_m3 = mean_between(&m3, end - 1.0, end, |r| r.depth_m)
        - mean_between(&m3, 0.0, 1.5, |r| r.depth_m);
    assert!(drift > 0.5, "vehicle drifts deeper: {drift}");
    assert!(drift_m3.abs() < 0.1, "model3 returns: {drift_m3}");
    // Pushing down pitches the vehicle nose down (paper fig. 5); model3 misses it.
    let h60 = read(&out, "heave_60.csv");
    let min_pitch = h60
        .rows
        .iter()
        .filter(|r| r.time_s < 8.0)
        .map(|r| r.pitch_deg)
        .fold(f64::MAX, f64::min);
    assert!(
        (-20.0..-5.0).contains(&min_pitch),
        "nose-down pitch under +60 % vertical: {min_pitch}"
    );

    // Yaw: port above starboard (2..7 s) turns to starboard: heading increases.
    for file in [
        "yaw_steps.csv",
        "yaw_steps.model1.csv",
        "yaw_steps.model2.csv",
        "yaw_steps.model3.csv",
    ] {
        let s = read(&out, file);
        let before = mean_between(&s, 0.0, 1.5, |r| r.heading_deg);
        let after = mean_between(&s, 6.5, 7.0, |r| r.heading_deg);
        assert!(
            after > before + 30.0,
            "{file}: heading {before} -> {after} under port +30/stbd -30"
        );
    }

    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert!(
        summary["heave_60"]["model1"]["pitch_rmse_deg"].is_null(),
        "model1 does not predict pitch"
    );
    assert!(
        summary["heave_60"]["model3"]["pitch_rmse_deg"]
            .as_f64()
            .unwrap()
            > 2.0,
        "model3 misses the pitch coupling"
    );
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn paper_reports_a_bad_model_file_by_key() {
    let dir = std::env::temp_dir().join(format!("topside_badmodels_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let models = workspace_root().join("config/models");
    for m in ["model1", "model2", "model3"] {
        std::fs::copy(
            models.join(format!("{m}.toml")),
            dir.join(format!("{m}.toml")),
        )
        .unwrap();
    }
    let text = std::fs::read_to_string(dir.join("model3.toml")).unwrap();
    let bad = text.replacen("value = 6.1", "value = -6.1", 1);
    assert_ne!(bad, text, "model3.toml holds the mass as `value = 6.1`");
    std::fs::write(dir.join("model3.toml"), bad).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_topside"))
        .args(["sim", "paper", "--out"])
        .arg(dir.join("out"))
        .arg("--models")
        .arg(&dir)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("model3.toml") && err.contains("mass_kg") && err.contains("-6.1"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
