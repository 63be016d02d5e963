//! Issue 15, what a pilot brings to a real dive: the pages and tools added (alarm limits
//! and the Settings page, ...), each exercised through the GUI on the virtual station
//! and snapshotted (look at the PNGs in `tests/snapshots/`).

use crate::common;

use common::{FRAME_S, rig};
use egui_kittest::kittest::{NodeT, Queryable};
use rov_gui::Tab;
use rov_station::runtime::dive::ItemStatus;
use rov_station::runtime::{AlarmKind, AlarmLevel};

/// Sets the n-th drag value labelled `label` through accesskit.
fn set_value(r: &mut common::Rig, label: &str, n: usize, value: f64) {
    r.harness
        .get_all_by_label(label)
        .filter(|node| node.accesskit_node().role() == egui::accesskit::Role::SpinButton)
        .nth(n)
        .unwrap_or_else(|| panic!("no drag value {label:?} #{n}"))
        .set_value_accesskit(value);
    r.run(FRAME_S);
}

#[test]
fn alarm_limits_set_in_settings_warn_then_alarm_and_acknowledge() {
    let mut r = rig("alarms.mcap");
    r.run(2.0);
    r.arm();
    r.harness.state_mut().set_tab(Tab::Settings);
    r.run(FRAME_S);
    set_value(&mut r, "Max depth", 0, 1.5);
    set_value(&mut r, "Max depth", 1, 2.2);
    r.snapshot("settings_page");
    r.click("Apply");
    assert_eq!(r.view().alarm_limits.depth_m.warn, 1.5);
    assert_eq!(r.view().alarm_limits.depth_m.alarm, 2.2);
    r.harness.state_mut().set_tab(Tab::Fly);
    r.run(FRAME_S);
    // Hold depth and go 3 m deeper: first the warning, then the alarm. The simulated
    // vehicle starts floating at the surface (0.11 m), so the setpoint ends at 3.1 m,
    // past both limits (two steps, 2.1 m, would stop short of the 2.2 m alarm).
    r.click_nth("OFF", 0);
    for _ in 0..3 {
        r.click_nth("+1", 0);
    }
    let mut saw_warning = false;
    for _ in 0..200 {
        r.run(0.1);
        let v = r.view();
        if let Some(a) = v.alarms.iter().find(|a| a.kind == AlarmKind::DepthMax) {
            saw_warning |= a.level == AlarmLevel::Warning;
            if a.level == AlarmLevel::Alarm {
                break;
            }
        }
    }
    let v = r.view();
    let a = v
        .alarms
        .iter()
        .find(|a| a.kind == AlarmKind::DepthMax)
        .copied()
        .unwrap_or_else(|| panic!("{:?} at {:?} m", v.alarms, v.snapshot.depth_m));
    assert!(saw_warning, "no warning before the alarm");
    assert_eq!(a.level, AlarmLevel::Alarm);
    assert_eq!(a.limit, Some(2.2));
    assert!(!a.acknowledged);
    assert!(r.has_label_containing("DEPTH LIMIT"));
    r.snapshot("alarm_depth_limit");
    // One alarm: "ACK (K)"; several: "ACK ALL (K)" (the strip's first button).
    let ack = if r.has_label_containing("ACK ALL (K)") {
        "ACK ALL (K)"
    } else {
        "ACK (K)"
    };
    r.click(ack);
    let a = r
        .view()
        .alarms
        .iter()
        .find(|a| a.kind == AlarmKind::DepthMax)
        .copied()
        .unwrap();
    assert!(a.acknowledged && a.active);
    // The event log recorded the warning and the alarm.
    let events = r.view().events.join("\n");
    assert!(events.contains("DEPTH LIMIT (warning)"), "{events}");
    assert!(events.contains("DEPTH LIMIT (ALARM)"), "{events}");
}

#[test]
fn the_predive_checklist_runs_and_its_result_is_recorded() {
    let mut r = rig("predive.mcap");
    r.run(2.0);
    r.harness.state_mut().set_tab(Tab::PreDive);
    r.run(FRAME_S);
    r.click("Heading is right");
    r.click("Zero depth here");
    let c = r.view().checklist;
    assert_eq!(c.items[1].status, ItemStatus::Pass, "{:?}", c.items[1]);
    assert_eq!(c.items[3].status, ItemStatus::Pass, "{:?}", c.items[3]);
    // The thruster test needs arming and a confirmation.
    assert!(
        r.harness
            .get_by_label("Run thruster test")
            .accesskit_node()
            .is_disabled()
    );
    r.harness.state_mut().set_tab(Tab::Fly);
    r.run(FRAME_S);
    r.arm();
    r.harness.state_mut().set_tab(Tab::PreDive);
    r.run(FRAME_S);
    r.click("Run thruster test");
    assert!(
        r.view().checklist.test_running.is_none(),
        "not before the confirmation"
    );
    r.click("Start the test");
    r.run(0.4);
    assert_eq!(r.view().checklist.test_running, Some(Some(0)), "port first");
    assert!(r.view().snapshot.thrust.port_pct > 20.0);
    r.run(5.0);
    let c = r.view().checklist;
    assert_eq!(c.test_running, None);
    for t in c.thrusters {
        assert_eq!(t.commanded_pct, 25.0);
        assert!(t.drew_current(), "{t:?}");
    }
    assert_eq!(c.items[2].status, ItemStatus::Pass, "{:?}", c.items[2]);
    assert_eq!(c.passed(), 5, "{:#?}", c.items);
    r.snapshot("predive_checklist");
    r.click("Record the result in the session");
    r.click("STOP REC");
    r.run(0.3);
    let path = r.view().recording.last_file.clone().unwrap();
    let session = rov_session::open(&path).unwrap();
    let events = session.records::<rov_session::EventRecord>().unwrap();
    let rec = events
        .iter()
        .find(|(_, e)| e.kind == "checklist" && e.text.starts_with("pre-dive checklist"))
        .unwrap_or_else(|| panic!("{events:#?}"));
    assert!(rec.1.text.contains("5/5 passed"), "{}", rec.1.text);
    assert!(rec.1.text.contains("port +25 %"), "{}", rec.1.text);
}

#[test]
fn dive_log_markers_and_notes_are_recorded_and_shown_in_replay() {
    let mut r = rig("divelog.mcap");
    r.run(2.0);
    r.arm();
    r.click_nth("OFF", 0);
    r.click_nth("+1", 0);
    r.run(4.0);
    assert!(r.view().dive.diving, "{:?}", r.view().dive);
    r.harness.key_press(egui::Key::M);
    r.run(FRAME_S);
    r.harness.key_press(egui::Key::N);
    r.run(FRAME_S);
    r.harness.event(egui::Event::Text("wreck in sight".into()));
    r.run(FRAME_S);
    r.harness.key_press(egui::Key::Enter);
    r.run(0.2);
    let d = r.view().dive;
    assert_eq!((d.markers, d.notes), (1, 1), "{d:?}");
    assert!(d.dive_s > 2.0 && d.max_depth_m > 0.5, "{d:?}");
    r.snapshot("fly_dive_log");
    r.click("STOP REC");
    r.run(0.2);
    r.harness.state_mut().set_tab(Tab::Replay);
    r.run(FRAME_S);
    r.click_containing("Open the last recording");
    r.run(FRAME_S);
    let labels = r.labels_containing("marker 1");
    assert!(!labels.is_empty(), "marker not in the replay index");
    let notes = r.labels_containing("wreck in sight");
    assert!(notes.iter().any(|l| l.contains("note 1")), "{notes:?}");
    assert!(r.has_label_containing("dive 1 started"));
}

#[test]
fn f1_shows_every_key_and_gamepad_binding() {
    let mut r = rig("help.mcap");
    r.run(1.0);
    assert!(!r.has_label_containing("Keys and buttons"));
    r.harness.key_press(egui::Key::F1);
    r.run(FRAME_S);
    assert!(r.has_label_containing("Keys and buttons"));
    for k in rov_gui::help_keys() {
        assert!(r.has_label_containing(k), "{k} missing");
    }
    for text in [
        "depth hold on/off",
        "record on/off",
        "with left_trigger held",
    ] {
        assert!(r.has_label_containing(text), "{text} missing");
    }
    r.snapshot("help_keys_and_buttons");
    r.harness.key_press(egui::Key::F1);
    r.run(FRAME_S);
    assert!(!r.has_label_containing("Keys and buttons"));
}

#[test]
fn the_gamepad_page_shows_raw_and_shaped_and_applies_the_shaping() {
    use rov_station::runtime::RuntimeCommand;
    use rov_station::runtime::pad::PadState;
    let mut r = rig("pad.mcap");
    r.run(1.0);
    r.harness.state_mut().set_tab(Tab::Gamepad);
    let mut half = PadState::default();
    // Centre first (the reconnect rule), then the left stick half forward.
    for _ in 0..4 {
        r.harness
            .state_mut()
            .command(RuntimeCommand::PadInput(PadState::default()));
        r.run(FRAME_S);
    }
    half.axes[1] = 0.5;
    let push = |r: &mut common::Rig| {
        r.harness
            .state_mut()
            .command(RuntimeCommand::PadInput(half));
        r.run(FRAME_S);
    };
    for _ in 0..4 {
        push(&mut r);
    }
    let p = r.view().pilot;
    assert_eq!(p.input, "gamepad");
    assert_eq!(p.raw.surge, 0.5);
    assert!(
        p.shaped.surge > 0.2 && p.shaped.surge < 0.5,
        "{:?}",
        p.shaped
    );
    assert!(r.has_label_containing("left_y +0.50"));
    r.snapshot("gamepad_page");
    // A 0.5 deadband on surge swallows a half deflection.
    set_value(&mut r, "surge", 0, 0.5);
    r.click("Apply map");
    for _ in 0..3 {
        push(&mut r);
    }
    assert_eq!(
        r.view().pilot.shaped.surge,
        0.0,
        "{:?}",
        r.view().pilot.shaped
    );
}

/// Every tab at the smallest and the largest window a pilot uses: no control cut off
/// (egui's clipped rectangles; scroll areas excepted), the Fly tab's main view fills
/// the space left by the side panel (no empty band), and the Settings tab needs no
/// scrolling. Snapshots of each.
fn every_tab_fits(w: f32, h: f32) {
    let mut problems = Vec::new();
    let mut r = common::rig_sized(&format!("size{w}/size.mcap"), egui::vec2(w, h));
    for e in std::fs::read_dir(common::tmp(&format!("size{w}")))
        .unwrap()
        .flatten()
    {
        if e.path().extension().is_some_and(|x| x == "mcap") && !e.path().ends_with("size.mcap") {
            let _ = std::fs::remove_file(e.path());
        }
    }
    r.run(2.0);
    r.arm();
    r.click_nth("OFF", 0);
    r.run(1.0);
    // A finished recording: the session browser's row is the same on every run.
    r.click("STOP REC");
    r.run(0.2);
    for (tab, name) in [
        (Tab::Fly, "fly"),
        (Tab::PreDive, "predive"),
        (Tab::Plots, "plots"),
        (Tab::Replay, "replay"),
        (Tab::Lab, "lab"),
        (Tab::Connection, "connection"),
        (Tab::Gamepad, "gamepad"),
        (Tab::Settings, "settings"),
    ] {
        r.harness.state_mut().set_tab(tab);
        r.run(FRAME_S);
        r.harness.state_mut().browser_mut().wait();
        r.run(FRAME_S);
        r.harness.step();
        for c in r.harness.state().clipped_widgets(&r.harness.ctx) {
            problems.push(format!(
                "{w}x{h} {name}: {:?} at {:?} visible {:?}",
                c.label, c.rect, c.visible
            ));
        }
        // The Settings tab shows all of itself without scrolling (two columns).
        if tab == Tab::Settings {
            for (id, hidden) in r.harness.state().scroll_hidden() {
                if *hidden > 0.5 {
                    problems.push(format!("{w}x{h} {name}: {id} hides {hidden:.0} points"));
                }
            }
            if r.harness.state().scroll_hidden().is_empty() {
                problems.push(format!("{w}x{h} {name}: no scroll area recorded"));
            }
        }
        if tab == Tab::Fly {
            let main = r.harness.state().main_view_rect().unwrap();
            if !(main.width() > 0.6 * w && main.height() > h - 200.0) {
                problems.push(format!("{w}x{h}: main view {main:?}"));
            }
        }
        r.snapshot(&format!("size_{w}x{h}_{name}"));
    }
    assert!(
        problems.is_empty(),
        "controls cut off:\n{}",
        problems.join("\n")
    );
}

#[test]
fn every_tab_fits_at_1024x600() {
    every_tab_fits(1024.0, 600.0);
}

#[test]
fn every_tab_fits_at_1920x1080() {
    every_tab_fits(1920.0, 1080.0);
}

#[test]
fn the_session_browser_lists_exports_replays_and_sends_to_the_lab() {
    let mut r = rig("browser/first.mcap");
    r.run(2.0);
    r.harness.key_press(egui::Key::N);
    r.run(FRAME_S);
    r.harness.event(egui::Event::Text("pier leg B".into()));
    r.run(FRAME_S);
    r.harness.key_press(egui::Key::Enter);
    r.run(2.0);
    r.click("STOP REC");
    r.run(0.3);
    r.harness.state_mut().set_tab(Tab::Replay);
    r.run(FRAME_S);
    r.harness.state_mut().browser_mut().wait();
    r.run(FRAME_S);
    let entries = r.harness.state().browser().entries.clone();
    assert_eq!(entries.len(), 1, "{entries:#?}");
    let e = &entries[0];
    assert_eq!(e.vehicle, "sim");
    assert!(
        e.duration_s > 3.0 && e.complete && e.size_bytes > 10_000,
        "{e:?}"
    );
    assert!(e.notes.iter().any(|n| n.contains("pier leg B")), "{e:?}");
    assert!(r.has_label_containing("pier leg B"));
    // The folder and the wall-clock date depend on the machine and the moment
    // (snapshot() masks them).
    r.snapshot("session_browser");
    // Export through the save dialog (the test backend answers it).
    let csv = common::tmp("browser/first-export.csv");
    let _ = std::fs::remove_file(&csv);
    *r.shared.dialog.lock().unwrap() = Some(csv.clone());
    r.click("Export CSV");
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(
        text.starts_with("t_s,") || text.contains("depth_m"),
        "{}",
        &text[..200.min(text.len())]
    );
    assert!(r.message().unwrap_or_default().contains("exported"));
    // To the lab: loads in the background.
    r.click("To lab");
    assert_eq!(r.harness.state().tab(), Tab::Lab);
    let t0 = std::time::Instant::now();
    while r.harness.state().lab().is_busy() && t0.elapsed().as_secs() < 60 {
        r.run(FRAME_S);
    }
    assert!(
        r.harness.state().lab().data.is_some(),
        "{:?}",
        r.harness.state().lab().error
    );
    // Replay through the open dialog.
    r.harness.state_mut().set_tab(Tab::Replay);
    r.run(FRAME_S);
    *r.shared.dialog.lock().unwrap() = Some(e.path.clone());
    r.click("Browse…");
    assert!(
        r.harness.state().replay_view().is_some(),
        "{:?}",
        r.message()
    );
}

/// Issue 22: the session browser opens another vehicle's log through a log map: "Import
/// a log…" asks for the log, then its map, writes the session into the recordings folder
/// (what `topside import --map` does) and lists it; a binary log without a map is
/// refused in words, with the way out.
#[test]
fn the_session_browser_imports_a_log_through_its_map() {
    let mut r = rig("import/first.mcap");
    // The rig's recordings folder (the recording's own folder).
    let dir = common::tmp("import/first.mcap")
        .parent()
        .unwrap()
        .to_path_buf();
    for old in ["foreign dive.mcap", "foreign dive-2.mcap"] {
        let _ = std::fs::remove_file(dir.join(old));
    }
    r.harness.state_mut().set_tab(Tab::Replay);
    r.run(FRAME_S);
    // A foreign CSV: its own column names, time in ms, PWM commands.
    let log = common::tmp("import-src/foreign dive.csv");
    std::fs::create_dir_all(log.parent().unwrap()).unwrap();
    let mut text = String::from("t_ms,m1,m2,m3,dep,yaw_deg\n");
    for k in 0..300 {
        let t = k as f64 * 0.1;
        text.push_str(&format!(
            "{},{},{},{},{},{}\n",
            t * 1000.0,
            1500.0 + 100.0 * (t * 0.3).sin(),
            1500.0 - 100.0 * (t * 0.3).sin(),
            1600.0,
            2.0 + 0.01 * t,
            (10.0 + t) % 360.0
        ));
    }
    std::fs::write(&log, text).unwrap();
    let map = common::tmp("import-src/foreign_map.toml");
    let pwm = "pwm = [1100, 1500, 1900]";
    std::fs::write(
        &map,
        format!(
            "format = \"csv\"\n[time]\nfield = \"t_ms\"\nscale = 0.001\n\
             [commands.port]\nfield = \"m1\"\n{pwm}\n[commands.starboard]\nfield = \"m2\"\n{pwm}\n\
             [commands.vertical]\nfield = \"m3\"\n{pwm}\n\
             [signals]\ndepth_m = {{ field = \"dep\" }}\nheading_deg = {{ field = \"yaw_deg\" }}\n"
        ),
    )
    .unwrap();
    r.shared
        .dialogs
        .lock()
        .unwrap()
        .extend([Some(log.clone()), Some(map.clone())]);
    r.click("Import a log…");
    r.harness.state_mut().browser_mut().wait_import();
    r.harness.state_mut().browser_mut().wait();
    r.run(FRAME_S);
    let note = r.harness.state().browser().import_note.clone();
    assert!(
        matches!(&note, Some((true, n)) if n.starts_with("imported as foreign dive.mcap: 300 rows")),
        "{note:?}"
    );
    let entries = r.harness.state().browser().entries.clone();
    let e = entries
        .iter()
        .find(|e| e.path == dir.join("foreign dive.mcap"))
        .unwrap_or_else(|| panic!("{entries:#?}"));
    assert_eq!(e.vehicle, "import");
    assert!((e.duration_s - 29.9).abs() < 0.2, "{e:?}");
    // The session holds the log's values in the lab's units: 1600 µs is 25 % vertical.
    let s = rov_session::open(&e.path).unwrap();
    let (series, _, _) = rov_session::measurements(&s).unwrap();
    let last = series.rows.last().unwrap();
    assert!((last.vertical_pct - 25.0).abs() < 1e-9, "{last:?}");
    assert!((series.rows[0].depth_m - 2.0).abs() < 1e-9);
    assert!(r.has_label_containing("imported as foreign dive.mcap"));
    r.snapshot("session_browser_import");
    // A DataFlash log without a map: refused, saying what it is and what is needed.
    let bin = common::tmp("import-src/log.BIN");
    std::fs::write(&bin, [0xA3, 0x95, 0x80, 0x80, 0x59, b'F', b'M', b'T', 0]).unwrap();
    r.shared.dialogs.lock().unwrap().extend([Some(bin), None]);
    r.click("Import a log…");
    r.harness.state_mut().browser_mut().wait_import();
    r.run(FRAME_S);
    let note = r.harness.state().browser().import_note.clone();
    assert!(
        matches!(&note, Some((false, n)) if n.contains("dataflash") && n.contains("log map")),
        "{note:?}"
    );
}

/// Opens a WebSocket connection by hand (the HTTP upgrade with Foxglove's subprotocol)
/// and returns the stream once the server switched protocols.
fn foxglove_client(addr: std::net::SocketAddr) -> std::net::TcpStream {
    use std::io::{Read, Write};
    let mut s = std::net::TcpStream::connect(addr).unwrap();
    write!(
        s,
        "GET / HTTP/1.1\r\nHost: {addr}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\nSec-WebSocket-Protocol: foxglove.sdk.v1\r\n\r\n"
    )
    .unwrap();
    let mut head = [0u8; 12];
    s.read_exact(&mut head).unwrap();
    assert_eq!(&head, b"HTTP/1.1 101", "{}", String::from_utf8_lossy(&head));
    s
}

#[test]
fn foxglove_live_serves_from_the_settings_tab_and_names_a_bad_address() {
    use rov_station::runtime::settings::FoxgloveSettings;
    let mut r = rig("foxglove_live.mcap");
    r.run(1.0);
    // An address in use: the error names it, nothing is served, the station flies on.
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let in_use = taken.local_addr().unwrap().to_string();
    let settings = |ws: &str| FoxgloveSettings {
        enabled: false,
        ws: ws.into(),
    };
    r.harness
        .state_mut()
        .set_foxglove(settings(&in_use), Ok(None));
    r.harness.state_mut().set_tab(Tab::Settings);
    r.run(FRAME_S);
    assert!(r.has_label_containing("off: serves the station's channels"));
    r.click("Serve");
    assert!(r.harness.state().foxglove_status().is_none());
    let e = r.harness.state().foxglove_error().unwrap().to_string();
    assert!(e.contains(&in_use) && e.contains("in use"), "{e}");
    assert!(r.has_label_containing(&in_use));

    // A free port: served, and the station's records reach the server.
    r.harness
        .state_mut()
        .set_foxglove(settings("127.0.0.1:0"), Ok(None));
    r.run(FRAME_S);
    r.click("Serve");
    let st = r
        .harness
        .state()
        .foxglove_status()
        .expect("not serving on a free port");
    assert!(r.has_label_containing(&format!("serving {} · 0 clients connected", st.url())));
    let client = foxglove_client(st.addr);
    r.run(1.0);
    let st = r.harness.state().foxglove_status().unwrap();
    assert_eq!(st.clients, 1);
    assert!(st.queued > 20 && st.dropped == 0, "{st:?}");
    assert!(r.has_label_containing("1 client connected"));
    // The port and the counts change from run to run: masked.
    r.harness.event(egui::Event::PointerGone);
    r.harness.step();
    let mut masked: Vec<egui::Rect> = ["serving ws://", "messages sent"]
        .iter()
        .map(|t| r.harness.get_by_label_contains(t).rect())
        .collect();
    masked.extend(r.volatile_rects());
    for m in masked {
        r.harness.mask(m);
    }
    r.snapshot_here("settings_foxglove_live");
    // Off again: the server stops and frees the port.
    r.click("Serve");
    assert!(r.harness.state().foxglove_status().is_none());
    drop(client);
    std::net::TcpListener::bind(st.addr).unwrap();
}

/// Issue 23: the Settings tab's model watch and fault form. A compass fault injected from
/// the form raises VEHICLE CHANGED in the alarm strip with the cause in words; the
/// section lists it.
#[test]
fn an_injected_fault_shows_in_the_alarm_strip_in_words() {
    let mut r = rig("watch.mcap");
    r.run(2.0);
    r.arm();
    // At rest for the watch's first minute (it learns its floor from the readings).
    r.run(80.0);
    assert!(r.view().watch.running, "{:?}", r.view().watch);
    assert!(
        r.view().watch.alerts.is_empty(),
        "{:?}",
        r.view().watch.alerts
    );
    r.harness.state_mut().set_tab(Tab::Settings);
    r.run(FRAME_S);
    r.click_containing("Model watch: watching");
    // The form's kind: thrust-loss by default; choose compass.
    r.click("Fault");
    r.click("compass");
    r.click_containing("Inject now (compass:25@0)");
    r.run(10.0);
    let v = r.view();
    assert!(
        v.alarms
            .iter()
            .any(|a| a.kind == AlarmKind::VehicleChanged && a.level == AlarmLevel::Warning),
        "{:?}",
        v.alarms
    );
    let strip = r.labels_containing("VEHICLE CHANGED");
    assert!(
        strip
            .iter()
            .any(|l| l.contains("COMPASS OFF +25") && l.contains("since T+")),
        "{strip:?}"
    );
    assert!(
        r.has_label_containing("CHANGE heading"),
        "the section lists it"
    );
    r.snapshot("settings_model_watch");
    // "Open in lab": the recording around the alert, in the Model lab tab.
    r.click("Open in lab");
    for _ in 0..100 {
        r.run(0.1);
        if r.has_label_containing("watch.mcap [") {
            break;
        }
    }
    let names = r.labels_containing("watch.mcap [");
    // The window: two minutes before the alert (from 0 here) to one after; the lab
    // says what it loaded (no snapshot: the page shows this machine's path).
    assert!(names.iter().any(|n| n.contains("[0–")), "{names:?}");
}
