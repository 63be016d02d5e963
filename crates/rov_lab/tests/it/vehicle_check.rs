//! `vehicle check` (issue 22, part 2): the templates load and check clean, and the sign
//! and response check, on data the lab's own simulator makes through a six-thruster
//! vehicle file with one free command channel per thruster, agrees with the file that
//! made the data and catches a flipped thruster and a swapped pair of channels.

use rov_dynamics::models::Channel;
use rov_dynamics::models::vehicle::VehicleDef;
use rov_lab::calibrate::View;
use rov_lab::sim::{Prediction, simulate_run};
use rov_lab::vehicle_check::sign::{ChannelCheck, sign_check};
use rov_lab::vehicle_check::{VehicleReport, check_vehicle};
use rov_lab::{LabModel, Run};
use rov_types::measurement::{MeasurementRow, MeasurementSeries, OptionalChannel};

fn config(path: &str) -> String {
    let p = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../config/vehicles")
        .join(path);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

const CHANNELS: [&str; 6] = ["thr1", "thr2", "thr3", "thr4", "thr5", "thr6"];

/// 10 Hz commands: each thruster alone at +50 % and −50 % (4 s on, 4 s off), then
/// pairs and triples of thrusters together at other levels (so the channels are not
/// collinear and the check must separate them).
fn commands() -> Vec<[f64; 6]> {
    let mut out = vec![[0.0; 6]; 30];
    let hold = |c: [f64; 6], s: f64, out: &mut Vec<[f64; 6]>| {
        for _ in 0..(s * 10.0) as usize {
            out.push(c);
        }
    };
    for level in [50.0, -50.0, 30.0] {
        for k in 0..6 {
            let mut c = [0.0; 6];
            c[k] = level;
            hold(c, 4.0, &mut out);
            hold([0.0; 6], 4.0, &mut out);
        }
    }
    for (a, b, l) in [
        (0, 3, 40.0),
        (1, 2, -40.0),
        (0, 1, 35.0),
        (4, 5, -45.0),
        (2, 3, 45.0),
        (4, 0, 40.0),
        (5, 1, -35.0),
        (3, 5, 40.0),
    ] {
        let mut c = [0.0; 6];
        c[a] = l;
        c[b] = -0.7 * l;
        hold(c, 4.0, &mut out);
        hold([0.0; 6], 3.0, &mut out);
    }
    out
}

/// A run of the commands; outputs from `fill` (a model's prediction, with a small
/// deterministic ripple as sensor noise) or placeholders.
fn run_of(cmds: &[[f64; 6]], fill: Option<&Prediction>) -> Run {
    let mut series = MeasurementSeries {
        present: [true; 8],
        ..Default::default()
    };
    let get = |ch: Channel, k: usize, dflt: f64| -> f64 {
        let ripple = 1e-3 * ((k * 7919 % 13) as f64 - 6.0);
        fill.and_then(|p| p.channel(ch))
            .and_then(|v| v.get(k).copied())
            .map_or(dflt, |v| v + ripple)
    };
    for k in 0..cmds.len() {
        let mut row = MeasurementRow {
            time_s: k as f64 * 0.1,
            depth_m: get(Channel::Depth, k, 5.0),
            heading_deg: get(Channel::Heading, k, 40.0),
            pitch_deg: get(Channel::Pitch, k, 0.0),
            roll_deg: get(Channel::Roll, k, 0.0),
            ..Default::default()
        };
        for (o, ch) in [
            (OptionalChannel::SurgeMps, Channel::Surge),
            (OptionalChannel::SwayMps, Channel::Sway),
            (OptionalChannel::HeaveMps, Channel::Heave),
            (OptionalChannel::RollRateDps, Channel::RollRate),
            (OptionalChannel::PitchRateDps, Channel::PitchRate),
            (OptionalChannel::YawRateDps, Channel::YawRate),
        ] {
            row.set(o, Some(get(ch, k, 0.0)));
        }
        series.rows.push(row);
    }
    let named: Vec<(String, Vec<f64>)> = CHANNELS
        .iter()
        .enumerate()
        .map(|(i, n)| (n.to_string(), cmds.iter().map(|c| c[i]).collect()))
        .collect();
    let mut runs = Run::runs_from_named_commands(&series, "six.csv", &named, None).unwrap();
    assert_eq!(runs.len(), 1);
    runs.remove(0)
}

/// The custom template's six-thruster vehicle flown through the lab's simulator.
fn simulated_log(text: &str) -> Run {
    let truth = LabModel::from_vehicle_text(text, "custom.toml").unwrap();
    let cmds = commands();
    let shape = run_of(&cmds, None);
    let p = simulate_run(&truth, &shape, &View::FreeRun.resets(&shape)).unwrap();
    run_of(&cmds, Some(&p))
}

fn check(text: &str, log: &Run) -> (VehicleReport, Vec<ChannelCheck>) {
    let def = VehicleDef::parse(text, "checked.toml").unwrap();
    let report = check_vehicle(&def).unwrap();
    let channels = sign_check(&def, &report, std::slice::from_ref(log));
    (report, channels)
}

fn agree_of(c: &[ChannelCheck], name: &str) -> Option<bool> {
    c.iter().find(|x| x.channel == name).and_then(|x| x.agree)
}

#[test]
fn every_template_loads_and_checks_clean() {
    for frame in [
        "pro4",
        "pro4-lateral",
        "bluerov2",
        "bluerov2-heavy",
        "custom",
    ] {
        let text = config(&format!("templates/{frame}.toml"));
        let def = VehicleDef::parse(&text, frame).unwrap_or_else(|e| panic!("{frame}: {e}"));
        let r = check_vehicle(&def).unwrap();
        assert!(r.issues.is_empty(), "{frame}: {:?}", r.issues);
        // Every number has a source; whatever the maker or literature cannot give is a
        // TODO with an uncertainty.
        assert!(!text.contains("source = \"\""), "{frame}");
        assert!(def.hull_size_m.is_some(), "{frame}");
        LabModel::from_vehicle_text(&text, frame).unwrap();
    }
    // The per-motor templates: one free channel per thruster, as ArduSub logs them.
    let def = VehicleDef::parse(&config("templates/bluerov2-heavy.toml"), "h").unwrap();
    assert_eq!(def.channel_table.free_names().len(), 8);
    let custom = config("templates/custom.toml");
    assert!(custom.matches("TODO").count() > 20);
    // The Pro 4 template's numbers are the shipped lateral file's without the accessory.
    let lat = VehicleDef::parse(&config("videoray_pro4_lateral.toml"), "l").unwrap();
    let tl = VehicleDef::parse(&config("templates/pro4-lateral.toml"), "tl").unwrap();
    assert_eq!(lat.process, tl.process);
    assert_eq!(lat.thrusters, tl.thrusters);
}

#[test]
fn the_sign_check_agrees_with_the_file_that_made_the_data() {
    let text = config("templates/custom.toml");
    let log = simulated_log(&text);
    let (_, c) = check(&text, &log);
    assert_eq!(c.len(), 6);
    for x in &c {
        assert_eq!(x.agree, Some(true), "{x:#?}");
        assert!(x.correlation.unwrap().abs() > 0.3, "{x:#?}");
        assert!(x.lag_s.unwrap() <= 2.0);
    }
    // The vertical thrusters push down: heave (depth rate) rises with their command.
    let v = c.iter().find(|x| x.channel == "thr5").unwrap();
    let heave = v.responses.iter().find(|r| r.dof == "heave").unwrap();
    assert!(heave.correlation > 0.3, "{v:#?}");
}

#[test]
fn the_sign_check_catches_a_flipped_thruster_and_a_swapped_pair() {
    let text = config("templates/custom.toml");
    let log = simulated_log(&text);
    // thr3 mounted the other way round in the file given to check.
    let (head, tail) = text.split_at(text.find("[thrusters.thr3]").unwrap());
    let flipped = format!(
        "{head}{}",
        tail.replacen(
            "direction = { value = [0.707107, -0.707107, 0.0]",
            "direction = { value = [-0.707107, 0.707107, 0.0]",
            1,
        )
    );
    assert_ne!(flipped, text);
    let (_, c) = check(&flipped, &log);
    assert_eq!(agree_of(&c, "thr3"), Some(false), "{c:#?}");
    for n in ["thr1", "thr2", "thr4", "thr5", "thr6"] {
        assert_eq!(agree_of(&c, n), Some(true), "{n}: {c:#?}");
    }
    // The front pair's channels swapped in the file (thr1 wired to the left thruster).
    let swapped = text
        .replace("mix_thr1 = ", "mix_tmp = ")
        .replace("mix_thr2 = ", "mix_thr1 = ")
        .replace("mix_tmp = ", "mix_thr2 = ");
    let (_, c) = check(&swapped, &log);
    assert_eq!(agree_of(&c, "thr1"), Some(false), "{c:#?}");
    assert_eq!(agree_of(&c, "thr2"), Some(false), "{c:#?}");
    for n in ["thr3", "thr4", "thr5", "thr6"] {
        assert_eq!(agree_of(&c, n), Some(true), "{n}: {c:#?}");
    }
}

#[test]
fn a_channel_the_log_does_not_excite_is_null() {
    let text = config("templates/custom.toml");
    let mut cmds = commands();
    for c in &mut cmds {
        c[5] = 0.0;
    }
    let truth = LabModel::from_vehicle_text(&text, "custom.toml").unwrap();
    let shape = run_of(&cmds, None);
    let p = simulate_run(&truth, &shape, &View::FreeRun.resets(&shape)).unwrap();
    let log = run_of(&cmds, Some(&p));
    let (_, c) = check(&text, &log);
    let x = c.iter().find(|x| x.channel == "thr6").unwrap();
    assert_eq!(x.agree, None, "{x:#?}");
    assert_eq!(x.observed_dof, None);
    assert!(x.note.contains("not excited"), "{}", x.note);
}

/// A run names its channels in its own order: the model reads them by name, and a saved
/// extended model of a free-channel vehicle loads with the same channels and predicts the
/// same.
#[test]
fn free_channels_are_read_by_name_and_survive_saving() {
    use rov_lab::params::{Param, Thr};
    let text = config("templates/custom.toml");
    let m = LabModel::from_vehicle_text(&text, "custom.toml").unwrap();
    let m = m
        .with(&[Param::ThrustLin(Thr::Horizontal)], &[0.8])
        .unwrap();
    let cmds = commands();
    let ordered = run_of(&cmds, None);
    // The same commands, channels named in reverse order.
    let named: Vec<(String, Vec<f64>)> = CHANNELS
        .iter()
        .enumerate()
        .rev()
        .map(|(i, n)| (n.to_string(), cmds.iter().map(|c| c[i]).collect()))
        .collect();
    let reversed = Run::runs_from_named_commands(
        &MeasurementSeries {
            rows: (0..cmds.len())
                .map(|k| MeasurementRow {
                    time_s: k as f64 * 0.1,
                    depth_m: 5.0,
                    heading_deg: 40.0,
                    ..Default::default()
                })
                .collect(),
            present: [true; 8],
            ..Default::default()
        },
        "reversed.csv",
        &named,
        None,
    )
    .unwrap()
    .remove(0);
    assert_ne!(reversed.channels, ordered.channels);
    let resets = View::FreeRun.resets(&ordered);
    let a = simulate_run(&m, &ordered, &resets).unwrap();
    let b = simulate_run(&m, &reversed, &resets).unwrap();
    let (ya, yb) = (
        a.channel(Channel::Heading).unwrap(),
        b.channel(Channel::Heading).unwrap(),
    );
    assert!(ya.iter().any(|v| (v - 40.0).abs() > 5.0));
    assert_eq!(ya, yb);
    // Saved and loaded: the same channels, the same prediction.
    let saved = rov_lab::save_extended_model(&m, "test");
    let id: rov_types::model_id::ModelId = "saved.toml".parse().unwrap();
    let back = rov_lab::load_model(&id, Some(&saved)).unwrap();
    assert_eq!(back.channel_table(), m.channel_table());
    assert_eq!(back.command_names(), m.command_names());
    let c = simulate_run(&back, &reversed, &resets).unwrap();
    assert_eq!(c.channel(Channel::Heading).unwrap(), ya);
}

/// The named-command constructor: a name that is not a channel name is refused, a series
/// of the wrong length is refused, values beyond ±100 % are clamped and counted, NaN holds.
#[test]
fn named_commands_are_checked_clamped_and_held() {
    let series = MeasurementSeries {
        rows: (0..40)
            .map(|k| MeasurementRow {
                time_s: k as f64 * 0.1,
                depth_m: 5.0,
                heading_deg: 40.0,
                ..Default::default()
            })
            .collect(),
        present: [true; 8],
        ..Default::default()
    };
    let mut v: Vec<f64> = (0..40).map(|k| f64::from(k) * 5.0).collect();
    v[3] = f64::NAN;
    let runs = Run::runs_from_named_commands(&series, "x", &[("esc_1".into(), v)], None).unwrap();
    let r = &runs[0];
    let c = r.channels.index_of("esc_1").unwrap();
    assert!(r.input_present[c.index()]);
    assert_eq!(r.inputs[3][c.index()], 10.0);
    assert_eq!(r.inputs[39][c.index()], 100.0);
    assert!(
        r.treatment
            .notes
            .iter()
            .any(|n| n.contains("19 value(s)") && n.contains("esc_1")),
        "{:?}",
        r.treatment.notes
    );
    let e = Run::runs_from_named_commands(&series, "x", &[("Esc 1".into(), vec![0.0; 40])], None)
        .unwrap_err();
    assert!(e.to_string().contains("Esc 1"), "{e}");
    let e = Run::runs_from_named_commands(&series, "x", &[("esc".into(), vec![0.0; 3])], None)
        .unwrap_err();
    assert!(e.to_string().contains("3 values for 40 rows"), "{e}");
}
