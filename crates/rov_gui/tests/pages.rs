//! Issue 15, what a pilot brings to a real dive: the pages and tools added (alarm limits
//! and the Settings page, ...), each exercised through the GUI on the virtual station
//! and snapshotted (look at the PNGs in `tests/snapshots/`).

mod common;

use common::{FRAME_S, rig};
use egui_kittest::kittest::{NodeT, Queryable};
use rov_gui::Tab;
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
    // Hold depth and go 2 m deeper: first the warning, then the alarm.
    r.click_nth("OFF", 0);
    r.click_nth("+1", 0);
    r.click_nth("+1", 0);
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
    r.click("ACK");
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
