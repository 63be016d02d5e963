//! Issue 22, part 3 (a trial, `#[ignore]`: about a minute in release): the BlueROV2 Heavy
//! vehicle file on the six real tank sessions, leave-one-session-out: per session the
//! held-out fit (multiple shooting and free run) per channel before calibration and after
//! calibrating on the other five. Run with
//! `TOPSIDE_SHARED_DIR=/path/to/shared cargo test --release -p rov_lab --test it bluerov_cv:: -- --ignored --nocapture`.

use std::path::PathBuf;

use rov_lab::LabModel;
use rov_lab::cross_validate::leave_one_session_out;
use rov_lab::ingest::runs_from_text;
use rov_lab::lm::LmOptions;

fn data_dir() -> PathBuf {
    let shared = std::env::var_os("TOPSIDE_SHARED_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared"));
    shared.join("real_data/bluerov2_saabmarine_mex")
}

/// The multiple-shooting window: `CV_WINDOW_S` (the reference figures use 5 s), else
/// the lab's 20 s.
fn window_s() -> f64 {
    std::env::var("CV_WINDOW_S")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(rov_lab::calibrate::SHOOTING_WINDOW_S)
}

#[test]
#[ignore = "a minute in release; prints the held-out table"]
fn bluerov_heavy_leave_one_session_out() {
    let dir = data_dir();
    let Ok(entries) = std::fs::read_dir(&dir) else {
        eprintln!("{} is not present; nothing to check", dir.display());
        return;
    };
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "csv"))
        .collect();
    files.sort();
    let mut runs = Vec::new();
    for f in &files {
        let name = f.file_name().unwrap().to_string_lossy().to_string();
        runs.extend(runs_from_text(&std::fs::read_to_string(f).unwrap(), &name).unwrap());
    }
    let text = std::fs::read_to_string(
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../config/vehicles/bluerov2_heavy.toml"),
    )
    .unwrap();
    let model = LabModel::from_vehicle_text(&text, "bluerov2_heavy.toml").unwrap();
    let cv = leave_one_session_out(
        &model,
        &runs,
        &LmOptions {
            threads: 2,
            ..Default::default()
        },
        window_s(),
    )
    .unwrap();
    assert_eq!(cv.sessions.len(), 6);
    let f = |x: Option<f64>| x.map_or("     -".to_string(), |v| format!("{v:6.1}"));
    for s in &cv.sessions {
        println!(
            "held out {} ({} runs), cost {:.3e} -> {:.3e}",
            s.session, s.runs, s.calibration_cost.0, s.calibration_cost.1
        );
        for (ch, b) in &s.before {
            let a = s.after.get(ch);
            println!(
                "  {ch:<10} shooting {} -> {}  free run {} -> {}",
                f(b.fit_pct),
                f(a.and_then(|c| c.fit_pct)),
                f(b.fit_pct_free_run),
                f(a.and_then(|c| c.fit_pct_free_run))
            );
        }
    }
    println!("median over sessions (shooting before -> after, free run before -> after):");
    for (ch, m) in &cv.median {
        println!(
            "  {ch:<10} {} -> {}   {} -> {}   ({} sessions)",
            f(m.shooting_before),
            f(m.shooting_after),
            f(m.free_run_before),
            f(m.free_run_after),
            m.sessions
        );
        assert!(m.shooting_after.is_none_or(f64::is_finite));
    }
}
