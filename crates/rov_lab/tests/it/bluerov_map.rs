//! The shipped log map of the BlueROV2 tank data (config/maps/bluerov2_saabmarine_mex.toml)
//! gives, on all six files, the same rows, measurements and command channels as the
//! converter written for those files did (kept here as the reference), sample for sample.

use std::path::PathBuf;

use rov_lab::mapped::mapped_series;
use rov_logs::LogMap;

fn data_dir() -> PathBuf {
    let shared = std::env::var_os("TOPSIDE_SHARED_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared"));
    shared.join("real_data/bluerov2_saabmarine_mex")
}

fn same(a: f64, b: f64) -> bool {
    (a.is_nan() && b.is_nan()) || (a - b).abs() <= 1e-9 * (1.0 + a.abs())
}

#[test]
fn shipped_map_equals_the_converter_on_all_six_files() {
    let map_text = include_str!("../../../../config/maps/bluerov2_saabmarine_mex.toml");
    let map = LogMap::parse(map_text, "bluerov2_saabmarine_mex.toml").unwrap();
    let Ok(dir) = std::fs::read_dir(data_dir()) else {
        eprintln!("shared/real_data is not present; nothing to check");
        return;
    };
    let mut files: Vec<PathBuf> = dir
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "csv"))
        .collect();
    files.sort();
    assert_eq!(files.len(), 6);
    for path in &files {
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        let text = std::fs::read_to_string(path).unwrap();
        let old = reference::bluerov_to_series_inputs(&text, &name).unwrap();
        let mapped = map.read_apply(text.as_bytes(), &name).unwrap();
        let new = mapped_series(&mapped, &map.label).unwrap();
        let (new_inputs, new_present) = new.builtin_inputs();
        assert_eq!(new.series.rows.len(), old.series.rows.len(), "{name}");
        // The converter predates free channels and marks their unused slots too; the
        // built-in channels are what it defines.
        let nb = rov_dynamics::models::vehicle::N_BUILTIN;
        assert_eq!(new_present[..nb], old.present[..nb], "{name}");
        assert_eq!(new.series.present, old.series.present, "{name}");
        assert_eq!(new.dropped_rows, old.dropped_rows, "{name}");
        for (k, (a, b)) in new.series.rows.iter().zip(&old.series.rows).enumerate() {
            let pa = [
                a.time_s,
                a.port_pct,
                a.starboard_pct,
                a.vertical_pct,
                a.depth_m,
                a.heading_deg,
                a.pitch_deg,
                a.roll_deg,
            ];
            let pb = [
                b.time_s,
                b.port_pct,
                b.starboard_pct,
                b.vertical_pct,
                b.depth_m,
                b.heading_deg,
                b.pitch_deg,
                b.roll_deg,
            ];
            for (i, (x, y)) in pa.iter().zip(&pb).enumerate() {
                assert!(same(*x, *y), "{name} row {k} column {i}: {x} vs {y}");
            }
            for (i, (x, y)) in a.optional.iter().zip(&b.optional).enumerate() {
                let (x, y) = (x.unwrap_or(f64::NAN), y.unwrap_or(f64::NAN));
                assert!(same(x, y), "{name} row {k} optional {i}: {x} vs {y}");
            }
        }
        for (k, (a, b)) in new_inputs.iter().zip(&old.inputs).enumerate() {
            for (i, (x, y)) in a.iter().zip(b).enumerate() {
                assert!(same(*x, *y), "{name} row {k} command {i}: {x} vs {y}");
            }
        }
        eprintln!("{name}: {} rows equal", new.series.rows.len());
    }
}

/// The read path of `lab compare|diagnose` on these files goes through the map.
#[test]
fn runs_from_text_reads_the_tank_csv_through_the_shipped_map() {
    let name = "session_2025_05_27-12_04_31_0_6dof.csv";
    let Ok(text) = std::fs::read_to_string(data_dir().join(name)) else {
        eprintln!("shared/real_data is not present; nothing to check");
        return;
    };
    let runs = rov_lab::ingest::runs_from_text(&text, name).unwrap();
    assert!(!runs.is_empty());
    assert!(
        runs[0]
            .treatment
            .notes
            .iter()
            .any(|n| n.contains("bluerov2_saabmarine_mex.toml")),
        "{:?}",
        runs[0].treatment.notes
    );
    let surge = rov_dynamics::models::vehicle::CommandChannel::SURGE.index();
    assert!(runs[0].input_present[surge]);
}

#[path = "../reference/bluerov_converter.rs"]
mod reference;
