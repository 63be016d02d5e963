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
use rov_lab::{LabModel, Run, load_model};

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
        let names: Vec<&str> = def
            .channels()
            .iter()
            .filter_map(|c| def.channel_table.name(*c))
            .collect();
        assert_eq!(names, channels, "{file}");
        // Every number carries a source (the parser refuses a bare number; here: no empty
        // source strings either).
        assert!(!text.contains("source = \"\""), "{file}");
        // The lab and the saved-model loader take it as a base.
        LabModel::from_vehicle_text(&text, file).unwrap();
        load_model(&file.parse().unwrap(), Some(&text)).unwrap();
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

/// A BlueROV2-like run at 10 Hz: surge, yaw, heave and sway demand steps at `levels` (fractions
/// of full demand, both signs), each held long enough to settle, with the six body-axis
/// command channels of `rov_lab::bluerov`; outputs from `fill` (a model's prediction), or
/// a placeholder level until then.
fn demand_steps_run(levels: &[f64], fill: Option<&rov_lab::sim::Prediction>) -> Run {
    use rov_dynamics::models::vehicle::{CommandChannel, N_COMMANDS};
    use rov_types::measurement::{MeasurementRow, MeasurementSeries, OptionalChannel};
    // (channel, seconds on) per step; 4 s of nothing after each.
    let mut plan: Vec<(CommandChannel, f64, f64)> = Vec::new();
    for l in levels {
        for sign in [1.0, -1.0] {
            plan.push((CommandChannel::SURGE, sign * l, 6.0));
            plan.push((CommandChannel::YAW, sign * l, 3.0));
            plan.push((CommandChannel::HEAVE, sign * l, 4.0));
            plan.push((CommandChannel::SWAY, sign * l, 5.0));
        }
    }
    let dt = 0.1;
    let mut demand: Vec<[f64; N_COMMANDS]> = Vec::new();
    for _ in 0..30 {
        demand.push([0.0; N_COMMANDS]);
    }
    for (ch, v, on) in &plan {
        let mut c = [0.0; N_COMMANDS];
        c[ch.index()] = 100.0 * v;
        for _ in 0..(on / dt).round() as usize {
            demand.push(c);
        }
        for _ in 0..40 {
            demand.push([0.0; N_COMMANDS]);
        }
    }
    let mut series = MeasurementSeries {
        present: [true; 8],
        ..Default::default()
    };
    let get = |ch: Channel, k: usize, dflt: f64| -> f64 {
        fill.and_then(|p| p.channel(ch))
            .and_then(|v| v.get(k).copied())
            .unwrap_or(dflt)
    };
    for k in 0..demand.len() {
        let mut row = MeasurementRow {
            time_s: k as f64 * dt,
            port_pct: 0.0,
            starboard_pct: 0.0,
            vertical_pct: 0.0,
            depth_m: get(Channel::Depth, k, 2.0),
            heading_deg: get(Channel::Heading, k, 10.0),
            pitch_deg: get(Channel::Pitch, k, 0.0),
            roll_deg: get(Channel::Roll, k, 0.0),
            optional: [None; 8],
        };
        for (o, ch) in [
            (OptionalChannel::SurgeMps, Channel::Surge),
            (OptionalChannel::SwayMps, Channel::Sway),
            (OptionalChannel::HeaveMps, Channel::Heave),
            (OptionalChannel::RollRateDps, Channel::RollRate),
            (OptionalChannel::PitchRateDps, Channel::PitchRate),
            (OptionalChannel::YawRateDps, Channel::YawRate),
            (OptionalChannel::NorthM, Channel::North),
            (OptionalChannel::EastM, Channel::East),
        ] {
            row.set(o, Some(get(ch, k, 0.0)));
        }
        series.rows.push(row);
    }
    let mut present = [false; N_COMMANDS];
    for c in [
        CommandChannel::SURGE,
        CommandChannel::SWAY,
        CommandChannel::HEAVE,
        CommandChannel::ROLL,
        CommandChannel::PITCH,
        CommandChannel::YAW,
    ] {
        present[c.index()] = true;
    }
    Run::from_series_inputs(&series, "steps", Some((demand, present))).unwrap()
}

/// `[uncertainty] command_gain` makes the pilot gain a calibrated parameter: data from a
/// vehicle flown at gain 0.8 (the file says 0.5) is fitted and the gain recovered, not
/// absorbed into the thrust scales, because the T200 curve is not linear and the steps
/// use several demand levels.
#[test]
fn calibration_recovers_the_pilot_gain_of_a_vehicle_file() {
    let text = vehicle_text("bluerov2_heavy.toml");
    let m = LabModel::from_vehicle_text(&text, "bluerov2_heavy.toml").unwrap();
    assert!(m.calibration_params().contains(&Param::CommandGain));
    assert_eq!(m.get(Param::CommandGain), Some(0.5));
    // The documented prior: mean the file's gain, σ from [uncertainty].
    assert_eq!(m.prior_of(Param::CommandGain), Some((0.5, 0.25)));
    // The gain reaches the thrusters: a surge step at gain 0.8 is faster than at 0.5.
    let truth = m.with(&[Param::CommandGain], &[0.8]).unwrap();
    let levels = [0.15, 0.4, 0.7];
    let shape = demand_steps_run(&levels, None);
    let p_true = simulate_run(&truth, &shape, &View::FreeRun.resets(&shape)).unwrap();
    let p_nom = simulate_run(&m, &shape, &View::FreeRun.resets(&shape)).unwrap();
    let peak = |p: &rov_lab::sim::Prediction| {
        p.channel(Channel::Surge)
            .unwrap()
            .iter()
            .fold(0.0f64, |a, b| a.max(*b))
    };
    assert!(
        peak(&p_true) > 1.2 * peak(&p_nom),
        "{} vs {}",
        peak(&p_true),
        peak(&p_nom)
    );
    let data = vec![demand_steps_run(&levels, Some(&p_true))];
    let cal = calibrate(
        &m,
        &data,
        &LmOptions {
            threads: 2,
            ..Default::default()
        },
    )
    .unwrap();
    let g = cal.model.get(Param::CommandGain).unwrap();
    eprintln!(
        "gain {g}, thrust scales {:?} {:?}",
        cal.model.get(Param::ThrustLin(Thr::Horizontal)),
        cal.model.get(Param::ThrustLin(Thr::Vertical))
    );
    assert!((g - 0.8).abs() < 0.08, "calibrated gain {g}, truth 0.8");
    // Not bought with the thrust scales: they stay near the truth's 1.
    for grp in [Thr::Horizontal, Thr::Vertical] {
        let k = cal.model.get(Param::ThrustLin(grp)).unwrap();
        assert!((k - 1.0).abs() < 0.2, "{grp:?} thrust scale {k}");
    }
}

/// A vehicle file with uncertain thruster positions refits the horizontal thrusters'
/// line of action in x and y too: data from a vehicle whose horizontal group sits 15 mm
/// forward and 10 mm to port of the file's positions (sway then turns it one way, surge
/// the other) is fitted and both offsets recovered.
#[test]
fn calibration_recovers_the_horizontal_thrust_line_offsets() {
    let text = vehicle_text("bluerov2_heavy.toml");
    let m = LabModel::from_vehicle_text(&text, "bluerov2_heavy.toml").unwrap();
    let arms = [Param::ArmXh, Param::ArmYh];
    for p in arms {
        assert!(m.calibration_params().contains(&p), "{p:?}");
        assert_eq!(m.get(p), Some(0.0));
    }
    let truth = m.with(&arms, &[0.015, -0.010]).unwrap();
    let levels = [0.2, 0.5];
    let shape = demand_steps_run(&levels, None);
    let p_true = simulate_run(&truth, &shape, &View::FreeRun.resets(&shape)).unwrap();
    let p_nom = simulate_run(&m, &shape, &View::FreeRun.resets(&shape)).unwrap();
    // The offsets turn the vehicle: its heading departs from the nominal one.
    let h_t = p_true.channel(Channel::Heading).unwrap();
    let h_n = p_nom.channel(Channel::Heading).unwrap();
    let most = h_t.iter().zip(h_n).fold(0.0f64, |a, (x, y)| {
        a.max(rov_types::angle::wrap_deg_180(x - y).abs())
    });
    assert!(most > 10.0, "heading departs by only {most} deg");
    let data = vec![demand_steps_run(&levels, Some(&p_true))];
    let cal = calibrate(
        &m,
        &data,
        &LmOptions {
            threads: 2,
            ..Default::default()
        },
    )
    .unwrap();
    let x = cal.model.get(Param::ArmXh).unwrap();
    let y = cal.model.get(Param::ArmYh).unwrap();
    eprintln!("horizontal arms x {x}, y {y}");
    assert!((x - 0.015).abs() < 0.003, "x offset {x}, truth 0.015");
    assert!((y + 0.010).abs() < 0.003, "y offset {y}, truth -0.010");
}
