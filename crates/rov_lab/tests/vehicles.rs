//! The shipped vehicle definition files (issue 13, part 3): they load with their own
//! command channels and thrusters, the lab simulates them with the physics the file
//! states, and calibration recovers a thrust gain of the lateral-thruster Pro 4.

use rov_dynamics::models::Channel;
use rov_dynamics::models::vehicle::VehicleDef;
use rov_lab::calibrate::{View, calibrate};
use rov_lab::ingest::runs_from_text;
use rov_lab::lm::LmOptions;
use rov_lab::params::{Param, Thr};
use rov_lab::sim::simulate_run;
use rov_lab::{LabModel, Run, load_lab_model};

fn vehicle_text(file: &str) -> String {
    let p = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../config/vehicles")
        .join(file);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

#[test]
fn shipped_vehicle_files_load_with_their_own_channels() {
    for (file, n_thrusters, channels) in [
        (
            "bluerov2_heavy.toml",
            8,
            vec!["surge", "sway", "heave", "roll", "pitch", "yaw"],
        ),
        (
            "videoray_pro4_lateral.toml",
            4,
            vec!["port", "starboard", "vertical", "lateral"],
        ),
    ] {
        let text = vehicle_text(file);
        let def = VehicleDef::parse(&text, file).unwrap();
        assert_eq!(def.thrusters.len(), n_thrusters, "{file}");
        let names: Vec<&str> = def.channels().iter().map(|c| c.name()).collect();
        assert_eq!(names, channels, "{file}");
        // Every number carries a source (the parser refuses a bare number; here: no empty
        // source strings either).
        assert!(!text.contains("source = \"\""), "{file}");
        // The lab and the saved-model loader take it as a base.
        LabModel::from_vehicle_text(&text, file).unwrap();
        load_lab_model(&text, file).unwrap();
    }
}

/// 90 s at 20 Hz: the lateral thruster at `lateral_pct` from 5 s to 50 s, nothing else;
/// the outputs are placeholders (a small deterministic ripple) until a model fills them.
fn lateral_csv(lateral_pct: f64, fill: Option<&rov_lab::sim::Prediction>) -> String {
    let mut out = String::from(
        "time_s,port_pct,starboard_pct,vertical_pct,depth_m,heading_deg,pitch_deg,roll_deg,yaw_rate_dps,surge_mps,sway_mps,heave_mps,lateral_pct\n",
    );
    let n = 1800;
    for k in 0..n {
        let t = k as f64 * 0.05;
        let lat = if (5.0..50.0).contains(&t) {
            lateral_pct
        } else {
            0.0
        };
        let ripple = 1e-3 * ((k * 7919 % 13) as f64 - 6.0);
        let get = |ch: Channel, dflt: f64| -> f64 {
            fill.and_then(|p| p.channel(ch))
                .and_then(|v| v.get(k).copied())
                .map_or(dflt, |v| v + ripple)
        };
        out.push_str(&format!(
            "{t:.3},0,0,0,{},{},0,0,{},{},{},{},{lat}\n",
            get(Channel::Depth, 5.0 + ripple),
            get(Channel::Heading, 30.0 + ripple),
            get(Channel::YawRate, ripple),
            get(Channel::Surge, ripple),
            get(Channel::Sway, ripple),
            get(Channel::Heave, ripple),
        ));
    }
    out
}

fn one_run(text: &str) -> Run {
    let mut runs = runs_from_text(text, "lateral.csv").unwrap();
    assert_eq!(runs.len(), 1);
    runs.remove(0)
}

#[test]
fn the_lateral_thruster_drives_sway_to_its_drag_balance_and_is_calibrated() {
    let text = vehicle_text("videoray_pro4_lateral.toml");
    let m = LabModel::from_vehicle_text(&text, "videoray_pro4_lateral.toml").unwrap();
    let run = one_run(&lateral_csv(100.0, None));
    let p = simulate_run(&m, &run, &View::FreeRun.resets(&run)).unwrap();
    let sway = p.channel(Channel::Sway).unwrap();
    // Full lateral thrust (1 + 9 = 10 N) against the file's sway drag 7.6 v + 40 v²:
    // v = (−7.6 + √(7.6² + 4·40·10)) / 80 = 0.4139 m/s, to starboard.
    let v_ss = (-7.6 + (7.6f64 * 7.6 + 1600.0).sqrt()) / 80.0;
    let at_45s = sway[900];
    assert!((at_45s - v_ss).abs() < 0.02 * v_ss, "{at_45s} vs {v_ss}");
    // The accessory sits on the vertical through the CO: no yaw, no surge.
    let heading = p.channel(Channel::Heading).unwrap();
    assert!((heading[900] - 30.0).abs() < 0.5, "{}", heading[900]);
    assert!(p.channel(Channel::Surge).unwrap()[900].abs() < 0.01);

    // A truth whose lateral thruster gives 70 % of the file's thrust: calibration of the
    // nominal file on its (steps of both signs) data finds the gain.
    let gains = [
        Param::ThrustLin(Thr::Lateral),
        Param::ThrustQuad(Thr::Lateral),
    ];
    let truth = m.with(&gains, &[0.7, 0.7]).unwrap();
    let mut data = Vec::new();
    for level in [60.0, -80.0, 100.0] {
        let r = one_run(&lateral_csv(level, None));
        let p = simulate_run(&truth, &r, &View::FreeRun.resets(&r)).unwrap();
        data.push(one_run(&lateral_csv(level, Some(&p))));
    }
    let cal = calibrate(
        &m,
        &data,
        &LmOptions {
            threads: 2,
            ..Default::default()
        },
    )
    .unwrap();
    let f = |p: Param| cal.model.get(p).unwrap();
    // The force at full command is what the data determines (linear and quadratic scales
    // trade against each other): 0.7 × 10 N within 5 %.
    let force = 1.0 * f(gains[0]) + 9.0 * f(gains[1]);
    assert!(
        (force - 7.0).abs() < 0.35,
        "lateral force at 100 %: {force} N"
    );
}
