//! Issue 25, the station as a pilot flies it: nothing moves under the pointer when an
//! alarm comes or a result line appears (item 2), the HUD's parts and the top bar do not
//! overlap (item 4), the right panel reaches lights and tilt (item 15), the pilot's keys
//! and the marker toast (items 9, 10, 15), the arm-unrecorded offer (item 13). Each at
//! 1024×600, 1280×800 and 1920×1080 where the size matters.

use crate::common;

use common::{FRAME_S, Rig, rig_sized};
use egui::{Key, Rect, vec2};
use egui_kittest::kittest::{NodeT, Queryable};
use rov_gui::Tab;
use rov_station::runtime::AlarmKind;

const SIZES: [(f32, f32); 3] = [(1024.0, 600.0), (1280.0, 800.0), (1920.0, 1080.0)];

/// The rectangle of the n-th widget labelled `label`.
fn rect_of(r: &Rig, label: &str, n: usize) -> Rect {
    r.harness
        .get_all_by_label(label)
        .nth(n)
        .unwrap_or_else(|| panic!("no {label:?} #{n}"))
        .rect()
}

/// Sets the n-th drag value labelled `label` through accesskit.
fn set_value(r: &mut Rig, label: &str, n: usize, value: f64) {
    r.harness
        .get_all_by_label(label)
        .filter(|node| node.accesskit_node().role() == egui::accesskit::Role::SpinButton)
        .nth(n)
        .unwrap_or_else(|| panic!("no drag value {label:?} #{n}"))
        .set_value_accesskit(value);
    r.run(FRAME_S);
}

/// The Fly tab's controls a pilot clicks: depth −1/+1, heading −10/+10, Go, the lights
/// slider (labels as accesskit names them, with the index among equal labels).
const FLY_CONTROLS: [(&str, usize); 6] = [
    ("+1", 0),
    ("-1", 0),
    ("+10", 0),
    ("-10", 0),
    ("Go", 0),
    ("Go", 1),
];

fn fly_rects(r: &Rig) -> Vec<(String, Rect)> {
    let mut out: Vec<(String, Rect)> = FLY_CONTROLS
        .iter()
        .map(|(l, n)| (format!("{l}#{n}"), rect_of(r, l, *n)))
        .collect();
    // The depth hold toggle (OFF while off, HOLD when on): the first axis button.
    let toggle = r
        .harness
        .query_all_by_label("OFF")
        .chain(r.harness.query_all_by_label("HOLD"))
        .map(|n| n.rect())
        .min_by(|a, b| a.min.y.total_cmp(&b.min.y))
        .expect("depth hold toggle");
    out.push(("depth hold toggle".into(), toggle));
    out
}

/// Item 2: the rectangles of the Fly tab's controls, of Settings → Apply and of the
/// pre-dive buttons are the same with and without an alarm (and after a checklist
/// result line appears), at the three sizes.
#[test]
fn item2_nothing_moves_when_an_alarm_comes_or_a_result_appears() {
    for (w, h) in SIZES {
        let mut r = rig_sized(&format!("i25_move_{w}.mcap"), vec2(w, h));
        r.run(2.0);
        r.arm();
        assert!(r.view().alarms.is_empty(), "{:?}", r.view().alarms);
        let fly0 = fly_rects(&r);

        // Pre-dive: a result line appears under the compass item, the buttons stay.
        r.harness.state_mut().set_tab(Tab::PreDive);
        r.run(FRAME_S);
        let pre = [
            "Heading is right",
            "Zero depth here",
            "Record the result in the session",
        ];
        let pre0: Vec<Rect> = pre.iter().map(|l| rect_of(&r, l, 0)).collect();
        r.click("Heading is right");
        r.run(0.2);
        let pre1: Vec<Rect> = pre.iter().map(|l| rect_of(&r, l, 0)).collect();
        assert_eq!(pre0, pre1, "{w}x{h} pre-dive buttons moved after a result");

        // Settings: limits that the vehicle crosses at once; Apply does not move when
        // the alarm comes.
        r.harness.state_mut().set_tab(Tab::Settings);
        r.run(FRAME_S);
        set_value(&mut r, "Max depth", 0, 0.3);
        set_value(&mut r, "Max depth", 1, 0.5);
        let apply0 = rect_of(&r, "Apply", 0);
        r.click("Apply");
        r.harness.state_mut().set_tab(Tab::Fly);
        r.run(FRAME_S);
        r.click_nth("OFF", 0);
        r.click_nth("+1", 0);
        let mut alarmed = false;
        for _ in 0..150 {
            r.run(0.1);
            alarmed = r
                .view()
                .alarms
                .iter()
                .any(|a| a.kind == AlarmKind::DepthMax && a.active);
            if alarmed {
                break;
            }
        }
        assert!(
            alarmed,
            "{w}x{h}: no depth alarm at {:?}",
            r.view().snapshot.depth_m
        );
        assert!(r.has_label_containing("DEPTH LIMIT"));
        let fly1 = fly_rects(&r);
        assert_eq!(fly0, fly1, "{w}x{h} Fly controls moved when the alarm came");
        r.harness.state_mut().set_tab(Tab::Settings);
        r.run(FRAME_S);
        assert_eq!(apply0, rect_of(&r, "Apply", 0), "{w}x{h} Apply moved");

        // Item 9: K acknowledges; the units are on the limit too.
        let text = r.labels_containing("DEPTH LIMIT").join(" ");
        assert!(
            text.contains(" m (limit ") && text.ends_with(" m)"),
            "{text}"
        );
        r.harness.key_press(Key::K);
        r.run(FRAME_S);
        assert!(
            r.view().alarms.iter().all(|a| a.acknowledged),
            "{:?}",
            r.view().alarms
        );
        r.harness.state_mut().set_tab(Tab::Fly);
        r.run(FRAME_S);
        assert_eq!(fly0, fly_rects(&r), "{w}x{h} Fly controls moved on ACK");
        if w == 1280.0 {
            r.snapshot("issue25_fly_alarm_acknowledged");
        }
    }
}

/// Item 4: the HUD's parts over the picture do not overlap; the heading setpoint's
/// plate never covers the tape's numerals or the heading box; the clock does not sit
/// under the source label; at the three sizes.
#[test]
fn item4_hud_parts_top_bar_and_tape_labels_do_not_overlap() {
    for (w, h) in SIZES {
        let mut r = rig_sized(&format!("i25_overlap_{w}.mcap"), vec2(w, h));
        r.run(1.0);
        let main = r.harness.state().main_view_rect().expect("fly main area");
        let l = rov_gui::fly::hud_layout(main);
        let parts = [
            ("heading tape", l.top),
            ("depth tape", l.left),
            ("horizon", l.mid),
            ("thrust box", l.bars),
            ("tilt", l.tilt),
            ("status strip", l.status),
        ];
        for (i, (a, ra)) in parts.iter().enumerate() {
            assert!(ra.is_positive(), "{w}x{h} {a} {ra:?}");
            assert!(
                main.contains_rect(*ra),
                "{w}x{h} {a} {ra:?} outside {main:?}"
            );
            for (b, rb) in &parts[i + 1..] {
                assert!(
                    !ra.intersects(*rb),
                    "{w}x{h}: {a} {ra:?} overlaps {b} {rb:?}"
                );
            }
        }
        // The setpoint plate at every position along the HUD's heading scale.
        let scale = rov_gui::instruments::heading_scale(l.top);
        let band = rov_gui::instruments::heading_numeral_band(scale);
        let hbox = rov_gui::instruments::heading_box(scale);
        let mut x = scale.min.x;
        while x <= scale.max.x {
            let p = rov_gui::instruments::setpoint_plate(scale, x);
            assert!(
                !p.intersects(band),
                "{w}x{h} plate {p:?} on numerals {band:?}"
            );
            assert!(
                !p.intersects(hbox),
                "{w}x{h} plate {p:?} on the box {hbox:?}"
            );
            x += 3.0;
        }
        // The clock and the source label.
        let sim = rect_of(&r, "SIM", 0);
        let clock = r
            .harness
            .query_all_by_label_contains(" s")
            .find(|n| {
                let node = n.accesskit_node();
                let l = node
                    .label()
                    .filter(|l| !l.is_empty())
                    .or_else(|| node.value())
                    .unwrap_or_default();
                l.starts_with("t ") && l.ends_with(" s")
            })
            .unwrap_or_else(|| panic!("no clock in {:?}", r.labels_containing(" s")))
            .rect();
        assert!(
            !sim.intersects(clock),
            "{w}x{h}: clock {clock:?} under SIM {sim:?}"
        );
        assert!(
            clock.max.x <= w && clock.min.x >= 0.0,
            "{w}x{h} clock {clock:?}"
        );
        // F1: the help window fits the window.
        r.harness.key_press(Key::F1);
        r.run(FRAME_S);
        let title = rect_of(&r, "Keys and buttons", 0);
        assert!(
            title.min.y >= 0.0 && title.min.x >= 0.0,
            "{w}x{h} help at {title:?}"
        );
        let widest_ok = r
            .harness
            .query_all_by_label_contains("acknowledge the alarms")
            .next()
            .is_some();
        assert!(widest_ok, "{w}x{h}: K missing from the help");
        // The keyboard column ends before the gamepad column starts (its long lines ran
        // into the gamepad's at 1024×600): every description, found in its key's row.
        let pad_left = r
            .harness
            .query_all_by_label_contains("surge: ")
            .map(|n| n.rect().min.x)
            .fold(f32::INFINITY, f32::min);
        assert!(pad_left.is_finite(), "{w}x{h}: no gamepad column");
        let mut checked = 0;
        for (k, what) in rov_gui::help_lines() {
            let keys: Vec<Rect> = r.harness.query_all_by_label(k).map(|n| n.rect()).collect();
            for d in r.harness.query_all_by_label(what).map(|n| n.rect()) {
                let in_row = keys
                    .iter()
                    .any(|kr| (kr.center().y - d.center().y).abs() < 4.0 && kr.max.x <= d.min.x);
                if in_row {
                    checked += 1;
                    assert!(
                        d.max.x <= pad_left,
                        "{w}x{h}: {what:?} {d:?} runs into the gamepad column at x {pad_left}"
                    );
                }
            }
        }
        assert!(
            checked >= rov_gui::help_lines().len() - 2,
            "{w}x{h}: only {checked} keyboard lines found"
        );
        if w == 1024.0 {
            r.snapshot("issue25_help_1024x600");
        }
    }
}

/// Item 4: the depth setpoint's number never covers the depth value box, on the
/// instrument layout's tape and on the HUD's, at every setpoint position, at the three
/// sizes (it sat on the box's top edge when the setpoint was near the depth).
#[test]
fn item4_depth_setpoint_label_clear_of_the_value_box() {
    use rov_gui::instruments::{depth_box, depth_scale, depth_setpoint_plate};
    for (w, h) in SIZES {
        let mut r = rig_sized(&format!("i25_dsp_{w}.mcap"), vec2(w, h));
        r.run(1.0);
        let tape = r.harness.get_by_label_contains("depth tape").rect();
        let main = r.harness.state().main_view_rect().expect("fly main area");
        let hud = rov_gui::fly::hud_layout(main).left;
        for (name, rect) in [("instruments", tape), ("hud", hud)] {
            let scale = depth_scale(rect);
            let vbox = depth_box(scale);
            assert!(scale.contains_rect(vbox), "{w}x{h} {name}: box {vbox:?}");
            let mut y = scale.min.y + 6.0;
            while y <= scale.max.y - 6.0 {
                let p = depth_setpoint_plate(scale, y);
                assert!(
                    !p.intersects(vbox),
                    "{w}x{h} {name}: plate {p:?} at y {y} on the box {vbox:?}"
                );
                assert!(
                    scale.contains_rect(p),
                    "{w}x{h} {name}: plate {p:?} off the scale {scale:?}"
                );
                y += 1.0;
            }
        }
    }
}

/// Item 15: at 1280×800 the lights and tilt sliders and the autopilot's toggles are all
/// in view together, without scrolling.
#[test]
fn item15_lights_and_tilt_in_view_with_the_autopilot_at_1280x800() {
    let mut r = rig_sized("i25_side.mcap", vec2(1280.0, 800.0));
    r.run(1.0);
    let bottom = 800.0 - 30.0; // above the status bar
    for (l, n) in [
        ("OFF", 0),
        ("OFF", 1),
        ("lights %", 0),
        ("camera tilt °", 0),
    ] {
        let rc = rect_of(&r, l, n);
        assert!(
            rc.min.y > 60.0 && rc.max.y < bottom,
            "{l} #{n} at {rc:?} not in view"
        );
    }
}

/// Items 9, 10, 15: the pilot's keys send their commands; M raises a toast with depth
/// and heading and the dive panel lists it; a setpoint entry error clears after the
/// next valid entry.
#[test]
fn items_10_15_keys_toast_and_setpoint_error() {
    let mut r = rig_sized("i25_keys.mcap", vec2(1280.0, 800.0));
    r.run(2.0);
    r.arm();
    let cam0 = r.view().camera;
    r.harness.key_press(Key::CloseBracket);
    r.harness.key_press(Key::T);
    r.run(0.3);
    let cam1 = r.view().camera;
    assert!(
        (cam1.lights_pct - (cam0.lights_pct + 10.0).min(100.0)).abs() < 1e-6,
        "{cam0:?} -> {cam1:?}"
    );
    assert!(
        (cam1.tilt_deg - (cam0.tilt_deg + 10.0)).abs() < 1e-6,
        "{cam1:?}"
    );
    r.harness.key_press(Key::OpenBracket);
    r.harness.key_press(Key::G);
    r.run(0.3);
    let cam2 = r.view().camera;
    assert!((cam2.lights_pct - cam0.lights_pct).abs() < 1e-6, "{cam2:?}");
    assert!((cam2.tilt_deg - cam0.tilt_deg).abs() < 1e-6, "{cam2:?}");

    // Depth hold on, then ↓ deepens the setpoint by 0.1 m, → turns the heading +1°.
    r.click_nth("OFF", 0);
    r.click_nth("OFF", 0); // heading (the depth's button reads HOLD now)
    let (d0, h0) = (
        r.view().depth.setpoint.unwrap(),
        r.view().heading.setpoint.unwrap(),
    );
    r.harness.key_press(Key::ArrowDown);
    r.harness.key_press(Key::ArrowRight);
    r.run(0.2);
    let (d1, h1) = (
        r.view().depth.setpoint.unwrap(),
        r.view().heading.setpoint.unwrap(),
    );
    assert!((d1 - d0 - 0.1).abs() < 1e-6, "depth setpoint {d0} -> {d1}");
    let dh = rov_types::angle::wrap_deg_180(h1 - h0);
    assert!((dh - 1.0).abs() < 1e-6, "heading setpoint {h0} -> {h1}");

    // M: a toast with the marker's depth and heading, and the dive panel lists it.
    assert!(r.has_label_containing("no markers or notes yet"));
    r.harness.key_press(Key::M);
    r.run(0.3);
    let toast = r.labels_containing(rov_gui::pilot_keys::TOAST_PREFIX);
    assert!(
        toast
            .iter()
            .any(|t| t.contains("marker 1") && t.contains(" m") && t.contains("heading")),
        "{toast:?}"
    );
    assert!(
        r.labels_containing("marker 1").len() >= 2,
        "toast and dive panel: {:?}",
        r.labels_containing("marker 1")
    );
    r.snapshot("issue25_marker_toast");
    r.run(3.5);
    assert!(
        r.labels_containing(rov_gui::pilot_keys::TOAST_PREFIX)
            .is_empty(),
        "the toast goes after 3 s"
    );
    assert!(
        r.has_label_containing("marker 1"),
        "the dive panel keeps it"
    );

    // A bad entry, then a good one: the error goes.
    r.type_into("DEPTH", "abc");
    r.harness.key_press(Key::Enter);
    r.run(FRAME_S);
    assert!(
        r.message().is_some_and(|m| m.starts_with("not a number")),
        "{:?}",
        r.message()
    );
    // The bad text stays in the field for correcting: delete it, type a number.
    r.type_into("DEPTH", "");
    for _ in 0..3 {
        r.harness.key_press(Key::Backspace);
    }
    r.harness.event(egui::Event::Text("2".into()));
    r.run(FRAME_S);
    r.harness.key_press(Key::Enter);
    r.run(FRAME_S);
    assert!(r.message().is_none(), "{:?}", r.message());
    assert!((r.view().depth.setpoint.unwrap() - 2.0).abs() < 1e-9);
}

/// Item 13: arming while not recording offers recording; the offer records.
#[test]
fn item13_arming_unrecorded_offers_recording() {
    let mut r = rig_sized("i25_rec.mcap", vec2(1280.0, 800.0));
    r.run(1.0);
    r.click("STOP REC");
    r.run(0.5);
    assert!(r.view().recording.path.is_none());
    assert!(!r.has_label_containing("Record this dive"));
    r.arm();
    assert!(r.has_label_containing("Armed: not recording"));
    r.snapshot("issue25_record_offer");
    r.click("Record this dive");
    r.run(0.3);
    assert!(r.view().recording.path.is_some());
    assert!(!r.has_label_containing("Record this dive"));
}
