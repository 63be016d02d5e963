//! Headless GUI tests (egui_kittest, wgpu on a CPU adapter, no DISPLAY): every panel
//! rendered and compared with the PNGs in `tests/snapshots/`, and the pilot's main
//! actions: hold to arm, engage depth hold, change a setpoint, open a replay, run a
//! diagnosis in the lab.
//!
//! The GUI talks to a `VirtualStation` (the real engine on virtual time, seeded) behind an
//! ordinary `StationHandle`; the test is the clock, so every frame is deterministic.
//! Regenerate the images with `UPDATE_SNAPSHOTS=1` (then look at them).

use crate::common;

use std::path::Path;
use std::time::{Duration, Instant};

use common::{FRAME_S, Rig, rig, tmp};
use egui::{Event, vec2};
use egui_kittest::kittest::Queryable;
use rov_gui::Tab;
use rov_station::runtime::{AlarmKind, AxisModeView};

#[test]
fn fly_tab_arm_hold_depth_hold_and_setpoint() {
    let mut r = rig("fly.mcap");
    r.run(2.0);
    assert_eq!(r.view().link.health, "connected");
    r.snapshot("fly_disarmed");

    // Hold to arm: a short press does nothing, a 1 s hold arms.
    let p = r.centre("HOLD TO ARM");
    r.press(p, true);
    r.run(0.3);
    r.press(p, false);
    r.run(1.2);
    assert!(!r.view().snapshot.armed, "a short press must not arm");
    r.press(p, true);
    r.run(0.55);
    r.snapshot_here("fly_arming");
    r.run(0.65);
    r.press(p, false);
    r.run(0.1);
    assert!(r.view().snapshot.armed);
    r.snapshot("fly_armed");

    // Engage depth hold (the first OFF button is the depth row's).
    r.click_nth("OFF", 0);
    assert_eq!(
        r.view().depth.mode,
        AxisModeView::Hold,
        "{:?} {:?}",
        r.view().last_refusal,
        r.view().events
    );
    let sp0 = r.view().depth.setpoint.unwrap();
    r.run(1.0);
    r.snapshot("fly_depth_hold");

    // Change the setpoint: +1 m with the step button, then type 2.5 m.
    r.click_nth("+1", 0);
    let sp1 = r.view().depth.setpoint.unwrap();
    assert!((sp1 - sp0 - 1.0).abs() < 1e-9, "{sp0} -> {sp1}");
    r.run(8.0);
    let d = r.view().snapshot.depth_m.unwrap();
    assert!((d - sp1).abs() < 0.3, "depth {d} vs setpoint {sp1}");
    r.snapshot("fly_setpoint_step");
    let field = r
        .harness
        .query_all(
            egui_kittest::kittest::By::new()
                .label("DEPTH")
                .role(egui::Role::TextInput),
        )
        .next()
        .unwrap()
        .rect()
        .center();
    r.harness.event(Event::PointerMoved(field));
    r.press(field, true);
    r.press(field, false);
    r.run(FRAME_S);
    r.harness.event(Event::Text("2.5".into()));
    r.run(FRAME_S);
    r.click_nth("Go", 0);
    assert!((r.view().depth.setpoint.unwrap() - 2.5).abs() < 1e-9);

    // Drag the setpoint on the depth tape: from the centre 60 px down = deeper.
    r.run(6.0);
    let before = r.view().depth.setpoint.unwrap();
    let c = r
        .harness
        .get_by_label_contains("depth tape")
        .rect()
        .center();
    r.press(c, true);
    for k in 1..=6 {
        r.harness
            .event(Event::PointerMoved(c + vec2(0.0, 10.0 * k as f32)));
        r.run(FRAME_S);
    }
    r.press(c + vec2(0.0, 60.0), false);
    r.run(FRAME_S);
    let after = r.view().depth.setpoint.unwrap();
    assert!(after > before + 0.3, "drag set {before} -> {after}");

    // One-action disarm drops the holds.
    r.click("DISARM");
    assert!(!r.view().snapshot.armed);
    assert_eq!(r.view().depth.mode, AxisModeView::Manual);
}

#[test]
fn plots_connection_and_alarm_panels() {
    let mut r = rig("plots.mcap");
    r.run(2.0);
    r.arm();
    r.click_nth("OFF", 1); // heading hold
    r.click_nth("+10", 0);
    r.click_nth("OFF", 0); // depth hold
    r.click_nth("+1", 0);
    r.run(20.0);
    r.harness.state_mut().set_tab(Tab::Plots);
    r.run(FRAME_S);
    assert!(r.harness.state().live_history().len() > 1000);
    r.snapshot("plots");

    r.harness.state_mut().set_tab(Tab::Connection);
    r.run(FRAME_S);
    r.click("Autodetect (ping)");
    r.run(FRAME_S);
    r.snapshot("connection");

    // Link loss: the vehicle goes silent for 3 s; the alarm latches until acknowledged.
    r.harness.state_mut().set_tab(Tab::Fly);
    let now = r.st.now_us();
    r.st.vehicle_mut()
        .faults_mut()
        .dead_windows
        .push((now, now + 3_000_000));
    r.run(4.0);
    let v = r.view();
    assert!(
        v.alarms.iter().any(|a| a.kind == AlarmKind::LinkLost),
        "{:?}",
        v.alarms
    );
    assert!(!v.snapshot.armed, "link loss disarms");
    r.run(2.0);
    assert_eq!(r.view().link.health, "connected");
    assert!(
        !r.view().alarms.is_empty(),
        "latched after the link came back"
    );
    r.snapshot("alarm_latched");
    // One alarm: "ACK (K)"; several: "ACK ALL (K)" (the strip's first button).
    let ack = if r.has_label_containing("ACK ALL (K)") {
        "ACK ALL (K)"
    } else {
        "ACK (K)"
    };
    r.click(ack);
    r.run(FRAME_S);
    assert!(
        r.view()
            .alarms
            .iter()
            .all(|a| a.kind != AlarmKind::LinkLost),
        "{:?}",
        r.view().alarms
    );
}

#[test]
fn record_then_open_a_replay() {
    let mut r = rig("replay-source.mcap");
    r.run(2.0);
    r.arm();
    // Every connection records from its start.
    assert!(r.view().recording.path.is_some());
    r.click_nth("OFF", 0);
    r.click_nth("+1", 0);
    r.click_nth("OFF", 0); // the heading row's (depth now shows HOLD)
    r.click_nth("+10", 0);
    r.run(8.0);
    assert!(r.view().recording.path.is_some());
    r.snapshot("fly_recording");
    r.click("STOP REC");
    r.run(0.2);
    let last = r.view().recording.last_file.clone().unwrap();
    assert!(last.exists());

    // Open it from the Replay tab.
    r.harness.state_mut().set_tab(Tab::Replay);
    r.run(FRAME_S);
    r.click("Open the last recording (replay-source.mcap)");
    assert!(
        r.harness.state().replay_view().is_some(),
        "{:?}",
        r.harness.state().message()
    );
    r.run(FRAME_S);
    // The recordings folder's list (paths and dates of this machine) is folded away so
    // the picture is the same on every machine.
    r.click("Sessions in the recordings folder");
    r.run(0.5);
    let field = r
        .harness
        .query_all(
            egui_kittest::kittest::By::new()
                .label("File")
                .role(egui::Role::TextInput),
        )
        .next()
        .unwrap()
        .rect();
    r.snapshot_masked("replay_tab", field);
    r.click("Play");
    r.run(1.0);
    let rv = r.harness.state().replay_view().unwrap().clone();
    let pos = rv.replay.as_ref().unwrap().position_s;
    assert!(pos > 0.5, "{pos}");
    assert!(rv.source.is_replay());
    r.click("Pause");
    r.harness.state_mut().set_tab(Tab::Fly);
    r.run(FRAME_S);
    r.snapshot("replay_fly");
    r.click("Step");
    r.harness.state_mut().set_tab(Tab::Plots);
    r.run(FRAME_S);
    r.snapshot("replay_plots");
    r.click("Back to live");
    assert!(r.harness.state().replay_view().is_none());
}

/// A small synthetic measurement CSV: model3 in the simulator with a hidden effect from
/// the catalog (the vertical thruster 25 mm forward of the CO, so pitch follows vertical
/// thrust), stepped thrust of both signs, 180 s at 10 Hz.
fn synthetic_csv(path: &Path) {
    use rov_dynamics::models::{Model3, load_default_model};
    use rov_dynamics::thrusters::{ThrustPct, ThrusterGeometry};
    let base = load_default_model("model3").unwrap();
    let mut p = *base.as_any().downcast_ref::<Model3>().unwrap().params();
    let g = p.thrusters.vertical.geometry;
    let pos = g.position_m();
    p.thrusters.vertical.geometry =
        ThrusterGeometry::new(nalgebra::Vector3::new(0.025, pos.y, pos.z), g.direction()).unwrap();
    let mut cfg = rov_sim::SimConfig::with_model(Box::new(Model3::new(p).unwrap()));
    cfg.initial = rov_dynamics::InitialConditions::at_rest(3.0, 0.0);
    let mut sim = rov_sim::Simulator::new(cfg, 7).unwrap();
    let block: Vec<(f64, ThrustPct)> = vec![
        (5.0, ThrustPct::new(0.0, 0.0, 0.0)),
        (8.0, ThrustPct::new(0.0, 0.0, 40.0)),
        (8.0, ThrustPct::new(0.0, 0.0, -40.0)),
        (8.0, ThrustPct::new(30.0, -30.0, 0.0)),
        (8.0, ThrustPct::new(-30.0, 30.0, 0.0)),
        (8.0, ThrustPct::new(0.0, 0.0, 60.0)),
        (8.0, ThrustPct::new(40.0, 40.0, -20.0)),
        (8.0, ThrustPct::new(0.0, 0.0, -60.0)),
        (8.0, ThrustPct::new(20.0, -20.0, 30.0)),
        (8.0, ThrustPct::new(0.0, 0.0, 0.0)),
        (8.0, ThrustPct::new(-20.0, 20.0, -30.0)),
    ];
    // Two passes of the block, the second with the commands scaled, so that the held-out
    // third sees levels the training part also contains.
    let mut holds = block.clone();
    holds.extend(block.iter().map(|(d, c)| {
        (
            *d,
            ThrustPct::new(c.port * 0.7, c.starboard * 0.7, c.vertical * 0.7),
        )
    }));
    let schedule = rov_sim::Schedule::from_holds(&holds).unwrap();
    let sensors = rov_dynamics::sensors::SensorConfig::default();
    let series = rov_sim::run_schedule_on(&mut sim, &sensors, &schedule, 0.1).unwrap();
    std::fs::write(path, series.to_csv()).unwrap();
}

#[test]
fn lab_tab_runs_a_diagnosis_off_the_gui_thread() {
    let csv = tmp("lab-synthetic.csv");
    synthetic_csv(&csv);
    let mut r = rig("lab.mcap");
    load_in_lab(&mut r, &csv);
    assert!(
        r.harness.state().lab().data.is_some(),
        "{:?}",
        r.harness.state().lab().error
    );
    r.click("Diagnose");
    assert!(r.harness.state().lab().is_busy());
    // The GUI keeps drawing frames while the worker runs.
    let frames = wait_lab(&mut r, 600.0);
    assert!(frames > 0);
    let lab = r.harness.state().lab();
    assert!(lab.error.is_none(), "{:?}", lab.error);
    let diag = lab.diagnosis.as_ref().unwrap();
    assert!(!diag.findings.is_empty());
    // The hidden effect is named first (the lab itself is tested in rov_lab).
    assert_eq!(
        diag.findings[0].effect, "thruster-moment-arm",
        "{}",
        diag.summary
    );
    assert!(diag.findings[0].significant);
    assert!(!lab.fall.is_empty());
    eprintln!("lab: {}", diag.summary);
    r.snapshot_masked("lab_diagnosis", data_field(&r));
    // Add the first addable effect; the refit runs in the background too.
    let n_fall = r.harness.state().lab().fall.len();
    let enabled = r
        .harness
        .query_all(
            egui_kittest::kittest::By::new()
                .label("Add effect")
                .predicate(|n| !n.is_disabled()),
        )
        .next()
        .unwrap()
        .rect()
        .center();
    r.harness.event(Event::PointerMoved(enabled));
    r.harness.step();
    r.press(enabled, true);
    r.press(enabled, false);
    r.run(FRAME_S);
    assert!(r.harness.state().lab().is_busy());
    wait_lab(&mut r, 600.0);
    let lab = r.harness.state().lab();
    assert!(lab.error.is_none(), "{:?}", lab.error);
    assert_eq!(lab.fall.len(), n_fall + 1);
    assert_eq!(lab.added.len(), 1);
    // Adding the moment arm cuts the held-out pitch error (the error-fall chart's data).
    let (before, after) = (&lab.fall[0].1, &lab.fall[n_fall].1);
    assert!(
        after["pitch"] < 0.5 * before["pitch"],
        "pitch RMSE {} -> {}",
        before["pitch"],
        after["pitch"]
    );
    // Issue 15 #5: the headline figures and the error fall agree: the last step is the
    // RMSE of the comparison shown (same view, same held-out data).
    let c = lab.comparison.clone().unwrap();
    let c = &c;
    assert_eq!(c.scope, rov_gui::lab::HELD_OUT);
    assert_eq!(lab.fall[n_fall].1, c.rmse(), "error fall vs headline");
    // Units on the headline figures; heading drawn within one turn.
    let titles = r.labels_containing("RMSE");
    assert!(
        titles
            .iter()
            .any(|t| t.starts_with("depth:") && t.ends_with(" m")),
        "{titles:?}"
    );
    assert!(
        titles
            .iter()
            .any(|t| t.starts_with("heading:") && t.ends_with(" °")),
        "{titles:?}"
    );
    let heading = c.channels.iter().find(|ch| ch.name == "heading").unwrap();
    let (meas, pred) =
        rov_gui::lab::channel_lines(&c.t, heading, rov_gui::lab::ErrorView::FreeRun, 1);
    // Issue 25 item 8: unwrapped, so no segment jumps across the axis at north.
    for seg in meas.iter().chain(&pred) {
        for w in seg.windows(2) {
            assert!((w[1][1] - w[0][1]).abs() < 180.0, "heading jumps {w:?}");
        }
    }
    assert_eq!(meas.len(), 1, "one measured heading line");
    r.snapshot_masked("lab_effect_added", data_field(&r));
    // Issue 26: both error views, one summary line per channel. The free run is shown
    // first with the shooting RMSE and the noise floor beside it; the other view plots
    // the multiple-shooting prediction (re-anchored every 20 s: closer to the data).
    let depth = c.channels.iter().find(|ch| ch.name == "depth").unwrap();
    let free_title = rov_gui::lab::channel_title(depth, rov_gui::lab::ErrorView::FreeRun);
    assert!(
        r.labels_containing("RMSE").contains(&free_title),
        "{free_title}"
    );
    assert!(
        free_title.contains("multiple shooting RMSE"),
        "{free_title}"
    );
    assert!(depth.rmse_shooting < depth.rmse, "{free_title}");
    assert_eq!(depth.shooting.len(), depth.predicted.len());
    r.click("multiple shooting");
    r.run(FRAME_S);
    assert_eq!(
        r.harness.state().lab().view,
        rov_gui::lab::ErrorView::Shooting
    );
    let shot_title = rov_gui::lab::channel_title(depth, rov_gui::lab::ErrorView::Shooting);
    assert!(shot_title.contains("free run RMSE"), "{shot_title}");
    assert!(
        r.labels_containing("RMSE").contains(&shot_title),
        "{shot_title}"
    );
    let (_, shot) = rov_gui::lab::channel_lines(&c.t, depth, rov_gui::lab::ErrorView::Shooting, 1);
    let (_, free) = rov_gui::lab::channel_lines(&c.t, depth, rov_gui::lab::ErrorView::FreeRun, 1);
    assert_ne!(shot, free, "the shooting view plots its own prediction");
    r.snapshot_masked("lab_shooting_view", data_field(&r));
    r.click("free run");
    r.run(FRAME_S);

    // An added effect can be removed: the refit goes back to the calibrated base.
    r.click("Remove");
    wait_lab(&mut r, 600.0);
    let lab = r.harness.state().lab();
    assert!(lab.error.is_none(), "{:?}", lab.error);
    assert!(lab.added.is_empty(), "{:?}", lab.added);
    assert!(lab.model.as_ref().unwrap().active_effects().is_empty());
    assert_eq!(lab.fall.len(), n_fall + 2);
    assert_eq!(
        lab.fall.last().unwrap().1,
        lab.fall[0].1,
        "back to the base's RMSE"
    );
    assert!(lab.fall.last().unwrap().0.starts_with('-'));
}

/// The GUI's lab reads a log through the lab's one loader, as `topside lab` does: a log
/// with a 10 s gap in its time stamps is split into the same two runs (same names,
/// samples and times, the same treatment) as the CLI's reading
/// (`rov_lab::loader::read_bytes`, what `topside lab`'s `load_log` calls), the page says
/// so in the CLI's words, and the training and held-out parts are read the same way.
#[test]
fn lab_tab_splits_a_log_at_a_gap_as_the_cli_does() {
    let clean = tmp("lab-gap-clean.csv");
    synthetic_csv(&clean);
    let text = std::fs::read_to_string(&clean).unwrap();
    // Shift every row from 100 s on by 10 s: a gap the lab must not simulate across.
    let mut lines = text.lines();
    let mut gapped = format!("{}\n", lines.next().unwrap());
    for line in lines {
        let (t, rest) = line.split_once(',').unwrap();
        let t: f64 = t.parse().unwrap();
        let t = if t >= 100.0 { t + 10.0 } else { t };
        gapped.push_str(&format!("{t},{rest}\n"));
    }
    let csv = tmp("lab-gap.csv");
    std::fs::write(&csv, &gapped).unwrap();
    let label = "lab-gap.csv";
    let cli = rov_lab::loader::read_bytes(gapped.as_bytes(), label)
        .unwrap()
        .runs()
        .unwrap();
    assert_eq!(cli.len(), 2, "the CLI's reading splits at the gap");

    let mut r = rig("lab-gap.mcap");
    load_in_lab(&mut r, &csv);
    let lab = r.harness.state().lab();
    let d = lab
        .data
        .as_ref()
        .unwrap_or_else(|| panic!("{:?}", lab.error));
    assert_eq!(d.full.len(), cli.len());
    for (g, c) in d.full.iter().zip(&cli) {
        assert_eq!(g.name, c.name);
        assert_eq!(g.t, c.t, "{}", g.name);
        assert_eq!(g.treatment, c.treatment, "{}", g.name);
    }
    // The data notes are the CLI's ("data: ..." in `lab diagnose`'s text report).
    let notes = rov_lab::ingest::treatment_sentences(&cli);
    assert!(
        notes
            .iter()
            .any(|n| n.contains("split the run into 2 segments")),
        "{notes:?}"
    );
    assert_eq!(d.warnings, notes);
    // Training: the first two thirds of the rows (the run before the gap and the start
    // of the one after it); held out: the rest. Each part through the same treatment.
    let t_cut = d.val.first().unwrap().t[0];
    assert!(d.train.iter().all(|r| r.t.iter().all(|t| *t < t_cut)));
    assert!(d.val.iter().all(|r| r.t.iter().all(|t| *t > 110.0)));
    // The page says it in words, and Compare plots both runs, broken at the gap.
    let shown = r.labels_containing("gaps split the log");
    assert!(shown.iter().any(|l| l.contains("in 2 runs")), "{shown:?}");
    assert!(
        !r.labels_containing("split the run into 2 segments")
            .is_empty()
    );
    r.click("Compare");
    wait_lab(&mut r, 60.0);
    let lab = r.harness.state().lab();
    let c = lab
        .comparison
        .as_ref()
        .unwrap_or_else(|| panic!("{:?}", lab.error));
    let depth = c.channels.iter().find(|ch| ch.name == "depth").unwrap();
    let (meas, pred) =
        rov_gui::lab::channel_lines(&c.t, depth, rov_gui::lab::ErrorView::FreeRun, 1);
    assert_eq!((meas.len(), pred.len()), (2, 2), "one line per run");
    r.snapshot_masked("lab_gap_split", data_field(&r));
}

/// Issue 22: the GUI's lab opens another vehicle's log through a log map and fits a
/// model file, as `topside lab --map MAP --model FILE.toml` does. The log is the synthetic
/// dive rewritten as a foreign logger would (time in ms, PWM commands, its own column
/// names); through its map and with model3 saved as a model file, Compare gives the same
/// numbers as the plain measurement CSV with the built-in model3.
#[test]
fn lab_tab_reads_a_foreign_log_through_a_map_and_fits_a_model_file() {
    let clean = tmp("lab-foreign-clean.csv");
    synthetic_csv(&clean);
    let text = std::fs::read_to_string(&clean).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    // Time in ms, the three commands as PWM (m1..m3), every signal under a name of its own
    // ("log_" + the lab's name), each mapped back by the map.
    let commands = ["port_pct", "starboard_pct", "vertical_pct"];
    let mut foreign = String::new();
    for h in &header {
        let name = match *h {
            "time_s" => "t_ms".to_string(),
            c if commands.contains(&c) => {
                format!("m{}", 1 + commands.iter().position(|x| *x == c).unwrap())
            }
            other => format!("log_{other}"),
        };
        foreign.push_str(&name);
        foreign.push(if h == header.last().unwrap() {
            '\n'
        } else {
            ','
        });
    }
    for line in lines {
        let cells: Vec<String> = header
            .iter()
            .zip(line.split(','))
            .map(|(h, x)| {
                let v: f64 = x.parse().unwrap();
                match *h {
                    "time_s" => format!("{}", v * 1000.0),
                    c if commands.contains(&c) => format!("{}", 1500.0 + 4.0 * v),
                    _ => x.to_string(),
                }
            })
            .collect();
        foreign.push_str(&cells.join(","));
        foreign.push('\n');
    }
    let log = tmp("lab-foreign.csv");
    std::fs::write(&log, foreign).unwrap();
    let map = tmp("lab-foreign-map.toml");
    let mut map_text = String::from("format = \"csv\"\n[time]\nfield = \"t_ms\"\nscale = 0.001\n");
    for (k, c) in commands.iter().enumerate() {
        let channel = c.trim_end_matches("_pct");
        map_text.push_str(&format!(
            "[commands.{channel}]\nfield = \"m{}\"\npwm = [1100, 1500, 1900]\n",
            k + 1
        ));
    }
    map_text.push_str("[signals]\n");
    for h in header
        .iter()
        .filter(|h| **h != "time_s" && !commands.contains(h))
    {
        map_text.push_str(&format!("{h} = {{ field = \"log_{h}\" }}\n"));
    }
    std::fs::write(&map, map_text).unwrap();
    let model_file = tmp("lab-model3-file.toml");
    let m3 = rov_lab::LabModel::default_base(rov_lab::BaseKind::Model3).unwrap();
    std::fs::write(&model_file, rov_lab::save_extended_model(&m3, "test")).unwrap();

    // The reference: the plain CSV with the built-in model3.
    let mut r = rig("lab-foreign.mcap");
    load_in_lab(&mut r, &clean);
    r.click("Compare");
    wait_lab(&mut r, 60.0);
    let want = r.harness.state().lab().comparison.clone().unwrap();

    // The foreign log through its map, the model from its file.
    {
        let lab = r.harness.state_mut().lab_mut();
        lab.map_path = map.display().to_string();
        lab.model_path = model_file.display().to_string();
        lab.path.clear();
    }
    load_in_lab(&mut r, &log);
    let lab = r.harness.state().lab();
    assert!(lab.error.is_none(), "{:?}", lab.error);
    let d = lab.data.as_ref().unwrap();
    assert_eq!(d.name, "lab-foreign.csv");
    assert!(!d.full.is_empty());
    // Without its map the same log is not lab data (its columns mean nothing).
    assert!(rov_gui::lab::load(&log).is_err());
    assert_eq!(lab.base(), rov_gui::lab::LabBase::File(model_file.clone()));
    assert!(r.has_label_containing("the log is read through lab-foreign-map.toml"));
    r.click("Compare");
    wait_lab(&mut r, 60.0);
    let lab = r.harness.state().lab();
    let got = lab
        .comparison
        .clone()
        .unwrap_or_else(|| panic!("{:?}", lab.error));
    for (w, g) in want.channels.iter().zip(&got.channels) {
        assert_eq!(w.name, g.name);
        assert!(
            (w.rmse - g.rmse).abs() <= 1e-6 * w.rmse.max(1e-9),
            "{}: {} through the map vs {} plain",
            w.name,
            g.rmse,
            w.rmse
        );
    }
    assert_eq!(want.channels.len(), got.channels.len());
    // Headed with the model file's name, not its kind.
    assert_eq!(got.model, "lab-model3-file.toml");
    assert!(r.has_label_containing("MODEL lab-model3-file.toml VS MEASURED"));

    // A model file that is not one is said, naming the file; nothing is compared.
    let bad = tmp("lab-not-a-model.toml");
    std::fs::write(&bad, "mass_kg = \"heavy\"\n").unwrap();
    r.harness.state_mut().lab_mut().model_path = bad.display().to_string();
    r.run(FRAME_S);
    r.click("Compare");
    wait_lab(&mut r, 60.0);
    let lab = r.harness.state().lab();
    let err = lab.error.clone().unwrap_or_default();
    assert!(err.contains("lab-not-a-model.toml"), "{err}");
}

/// Opens the lab tab, types `path` into its data field and loads it (waits for the
/// worker).
fn load_in_lab(r: &mut Rig, path: &Path) {
    r.harness.state_mut().set_tab(Tab::Lab);
    r.run(FRAME_S);
    let field = data_field(r).center();
    r.press(field, true);
    r.press(field, false);
    r.run(FRAME_S);
    r.harness.event(Event::Text(path.display().to_string()));
    r.run(FRAME_S);
    r.click("Load");
    wait_lab(r, 60.0);
}

/// The lab's data path field (masked in snapshots: the path depends on the machine).
fn data_field(r: &Rig) -> egui::Rect {
    r.harness
        .query_all(
            egui_kittest::kittest::By::new()
                .label("Data (CSV or MCAP)")
                .role(egui::Role::TextInput),
        )
        .next()
        .unwrap()
        .rect()
}

/// Steps frames until the lab worker is idle; returns the frames drawn meanwhile.
fn wait_lab(r: &mut Rig, timeout_s: f64) -> usize {
    let t0 = Instant::now();
    let mut frames = 0;
    while r.harness.state().lab().is_busy() {
        assert!(
            t0.elapsed().as_secs_f64() < timeout_s,
            "lab worker timed out"
        );
        std::thread::sleep(Duration::from_millis(20));
        r.harness.step();
        frames += 1;
    }
    r.run(FRAME_S);
    frames
}

/// Lab work shows the stage the lab reports, with a bar when it is counted, and Cancel
/// stops it: the worker's result is dropped and the tab says nothing changed.
/// Loading a session is a stage of the lab's progress ("loading NAME n/N rows"), and a
/// cancelled load stops reading within one report's rows instead of reading the whole
/// session (issue 26: loading as a progress stage, Cancel within a second).
#[test]
fn loading_a_session_is_a_counted_stage_and_cancel_stops_the_read() {
    use rov_lab::progress::{Loading, Progress};
    use rov_session::{NavRecord, SessionInfo, SessionWriter, ThrustRecord};
    let path = tmp("lab_loading.mcap");
    let info = SessionInfo {
        vehicle: "sim".into(),
        software_version: "topside test".into(),
        started_unix_s: 1_750_000_000.0,
        config_toml: String::new(),
    };
    let rows = 3 * Loading::REPORT_ROWS + 100;
    let mut w = SessionWriter::create(&path, &info, 0).unwrap();
    for k in 0..rows as u64 {
        let t_ns = k * 100_000_000;
        let x = (k as f64 * 0.01).sin();
        let thrust = ThrustRecord {
            port_pct: 30.0 * x,
            starboard_pct: -30.0 * x,
            vertical_pct: 20.0 * x,
            ..ThrustRecord::default()
        };
        w.write(t_ns, &thrust).unwrap();
        let nav = NavRecord {
            depth_m: 3.0 + x,
            heading_deg: 100.0 + 10.0 * x,
            ..NavRecord::default()
        };
        w.write(t_ns + 1_000_000, &nav).unwrap();
    }
    w.finish().unwrap();
    let seen = std::sync::Arc::new(std::sync::Mutex::new(Vec::<String>::new()));
    let s2 = seen.clone();
    let p = Progress::with_sink(move |s| s2.lock().unwrap().push(s.to_string()));
    let data = p.run_with(|| rov_gui::lab::load(&path)).unwrap();
    assert!(data.full.iter().map(|r| r.len()).sum::<usize>() > rows - 10);
    let seen = seen.lock().unwrap().clone();
    let want = format!("loading lab_loading.mcap 0/{rows} rows");
    assert_eq!(seen.first(), Some(&want), "{seen:?}");
    for k in 1..=3 {
        let want = format!(
            "loading lab_loading.mcap {}/{rows} rows",
            k * Loading::REPORT_ROWS
        );
        assert!(seen.contains(&want), "{want} not in {seen:?}");
    }
    // Cancelled while reading (at the first report after the start, from the sink, so
    // the test does not race the reader): the read stops there and the load says so.
    let read = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let r2 = read.clone();
    let me = std::sync::Arc::new(std::sync::OnceLock::<Progress>::new());
    let me2 = me.clone();
    let p = Progress::with_sink(move |s| {
        r2.store(s.done, std::sync::atomic::Ordering::Relaxed);
        if s.done > 0
            && let Some(p) = me2.get()
        {
            p.cancel();
        }
    });
    me.set(p.clone()).unwrap();
    let out = p.run_with(|| rov_gui::lab::load(&path));
    assert!(
        matches!(&out, Err(rov_gui::FileError::Lab(e)) if **e == rov_lab::LabError::Cancelled),
        "{:?}",
        out.map(|d| d.name)
    );
    let stopped_at = read.load(std::sync::atomic::Ordering::Relaxed);
    assert_eq!(
        stopped_at,
        Loading::REPORT_ROWS,
        "the read went on after Cancel ({stopped_at} of {rows} rows reported)"
    );
}

#[test]
fn lab_work_shows_its_stage_and_cancel_stops_it() {
    use rov_gui::lab::LabResult;
    use rov_lab::progress::Stage;
    let mut r = rig("lab_progress.mcap");
    r.harness.state_mut().set_tab(Tab::Lab);
    r.run(FRAME_S);
    // When the worker saw the cancel (the GUI's frames, slow on a loaded machine with a
    // software renderer, are not part of the stop time).
    let stopped_at = std::sync::Arc::new(std::sync::Mutex::new(None::<Instant>));
    let stopped = stopped_at.clone();
    r.harness
        .state_mut()
        .lab_mut()
        .start_job("diagnosing", move |p| {
            p.report(Stage {
                name: "screening".into(),
                done: 9,
                total: 17,
                unit: "sensitivities",
            });
            let t0 = Instant::now();
            while !p.is_cancelled() && t0.elapsed() < Duration::from_secs(60) {
                std::thread::sleep(Duration::from_millis(5));
            }
            if let Ok(mut s) = stopped.lock() {
                *s = Some(Instant::now());
            }
            LabResult::Failed("the job was not cancelled".into())
        });
    r.run(FRAME_S);
    assert!(r.harness.state().lab().is_busy());
    assert!(
        r.harness
            .query_by_label_contains("diagnosing: screening 9/17 sensitivities")
            .is_some()
    );
    r.snapshot("lab_progress");
    r.click("Cancel");
    // The click's frame set the flag; from here the worker must stop at once.
    let t0 = Instant::now();
    wait_lab(&mut r, 30.0);
    let stop = stopped_at.lock().unwrap().map(|t| t.duration_since(t0));
    assert!(
        stop.is_some_and(|d| d < Duration::from_secs(1)),
        "the worker stopped {stop:?} after Cancel"
    );
    let lab = r.harness.state().lab();
    assert!(lab.error.is_none(), "{:?}", lab.error);
    assert_eq!(lab.cancelled.as_deref(), Some("diagnosing"));
    assert!(
        r.harness
            .query_by_label_contains("diagnosing cancelled: nothing changed")
            .is_some()
    );
}
