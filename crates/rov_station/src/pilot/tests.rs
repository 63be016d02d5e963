//! The pilot core driven by events and times alone: the engine, the driver's sans-IO
//! [`Link`] and the simulated Pro 4 joined on virtual time by [`SimLink`] (no thread, no
//! sleep, no clock, no file). Records and outputs are collected as the engine hands them
//! out.

use std::path::PathBuf;

use rov_control::ModelSet;
use rov_driver::{Link, LinkEvent};
use rov_session::Severity;
use rov_vehicle::Vehicle;

use super::record::RecordItem;
use super::{ARM_HINT, Engine, Input, Output, Saved};
use crate::core::StationCommand;
use crate::pilot::alarms::AlarmKind;
use crate::pilot::view::Source;
use crate::runtime::{RuntimeCommand, RuntimeConfig};
use crate::sim_link::{SimApp, SimLink};

/// The engine as a [`SimApp`]: link events and ticks in, records and outputs collected.
struct Pilot {
    engine: Engine,
    records: Vec<(u64, RecordItem)>,
    outputs: Vec<Output>,
}

impl Pilot {
    fn drain(&mut self) {
        while let Some(r) = self.engine.poll_record() {
            self.records.push(r);
        }
        while let Some(o) = self.engine.poll_output() {
            self.outputs.push(o);
        }
    }
}

impl SimApp for Pilot {
    fn on_event(&mut self, link: &mut Link, _vehicle: &Vehicle, event: LinkEvent, now_us: u64) {
        self.engine.handle(Input::Link(&event), link, now_us);
        self.drain();
    }

    fn on_tick(&mut self, link: &mut Link, _vehicle: &mut Vehicle, now_us: u64) {
        self.engine.tick(link, now_us);
        self.drain();
    }
}

struct Bench {
    sim: SimLink,
    pilot: Pilot,
}

impl Bench {
    fn new(cfg: RuntimeConfig) -> Self {
        let period_us = cfg.period_us();
        let mut link_cfg = cfg.link;
        link_cfg.record_frames = false;
        let link = Link::new(link_cfg).unwrap();
        let vehicle = crate::runtime::sim_vehicle(&cfg).unwrap();
        let engine = Engine::new(cfg, ModelSet::load_default().unwrap(), Source::Sim).unwrap();
        Self {
            sim: SimLink::new(link, vehicle, period_us),
            pilot: Pilot {
                engine,
                records: Vec::new(),
                outputs: Vec::new(),
            },
        }
    }

    fn run_to(&mut self, t_s: f64) {
        let t_us = (t_s * 1e6).round() as u64;
        self.sim.run_until(t_us, &mut self.pilot).unwrap();
    }

    fn now_us(&self) -> u64 {
        self.sim.now_us()
    }

    fn input(&mut self, input: Input<'_>) {
        let now = self.sim.now_us();
        self.pilot.engine.handle(input, &mut self.sim.link, now);
        self.pilot.drain();
    }

    fn command(&mut self, c: RuntimeCommand) {
        self.input(Input::Command(c));
    }

    fn view(&self) -> &crate::pilot::view::StationView {
        self.pilot.engine.view()
    }

    fn has_event(&self, text: &str) -> bool {
        self.view().events.iter().any(|e| e.contains(text))
    }

    /// Holds the arm button from now for `hold_s`, reported every 0.2 s as the GUI does.
    fn hold_arm(&mut self, hold_s: f64) {
        let t0 = self.now_us() as f64 * 1e-6;
        let mut t = t0;
        while t < t0 + hold_s {
            self.command(RuntimeCommand::ArmButton(true));
            t += 0.2;
            self.run_to(t);
        }
    }
}

fn cfg() -> RuntimeConfig {
    RuntimeConfig {
        watch: false,
        gamepad: false,
        ..RuntimeConfig::default()
    }
}

#[test]
fn arming_needs_the_button_held_and_a_short_press_gives_a_hint_that_times_out() {
    let mut b = Bench::new(cfg());
    b.run_to(2.0);
    assert_eq!(b.view().link.health, "connected");
    // A short press: not armed, a hint, and the hint's timer in the table.
    b.command(RuntimeCommand::ArmButton(true));
    b.run_to(2.2);
    b.command(RuntimeCommand::ArmButton(false));
    b.run_to(2.3);
    assert!(!b.view().snapshot.armed);
    assert_eq!(b.view().hint.as_deref(), Some(ARM_HINT));
    let hint_at = b.pilot.engine.poll_timeout().unwrap();
    assert!(hint_at > b.now_us(), "the hint's deadline is ahead");
    b.run_to(7.0);
    assert_eq!(b.view().hint, None, "the hint went away after 4 s");
    // Held for 1.4 s: armed, and the event says so.
    b.hold_arm(1.4);
    b.command(RuntimeCommand::ArmButton(false));
    b.run_to(8.6);
    assert!(b.view().snapshot.armed);
    assert!(b.has_event("ARMED"));
    assert!(b.sim.link.failsafe().is_armed());
}

#[test]
fn a_link_loss_disarms_through_the_failsafe_raises_the_alarm_and_stays_disarmed() {
    let mut c = cfg();
    // The vehicle is deaf from 5 to 9 s of its clock.
    c.sim_faults.dead_windows = vec![(5_000_000, 9_000_000)];
    let mut b = Bench::new(c);
    b.run_to(2.0);
    b.hold_arm(1.4);
    b.command(RuntimeCommand::ArmButton(false));
    b.run_to(4.0);
    assert!(b.view().snapshot.armed);
    b.run_to(8.5);
    assert_eq!(b.view().link.health, "lost");
    assert!(!b.view().snapshot.armed, "the failsafe disarmed");
    assert!(b.has_event("failsafe"), "events: {:?}", b.view().events);
    assert!(
        b.view()
            .alarms
            .iter()
            .any(|a| a.kind == AlarmKind::LinkLost && a.active),
        "alarms: {:?}",
        b.view().alarms
    );
    // The link comes back; thrust stays neutral until the pilot re-arms.
    b.run_to(12.0);
    assert_eq!(b.view().link.health, "connected");
    assert!(!b.view().snapshot.armed);
    assert!(!b.sim.link.failsafe().is_armed());
}

#[test]
fn recording_start_and_stop_are_outputs_and_records_count_from_the_start() {
    let mut b = Bench::new(cfg());
    b.run_to(1.0);
    assert!(b.pilot.records.is_empty(), "nothing recorded unless asked");
    let path = PathBuf::from("dive.mcap");
    b.command(RuntimeCommand::StartRecording(path.clone()));
    assert!(matches!(b.pilot.outputs.as_slice(), [Output::StartRecording(p)] if *p == path));
    assert!(
        b.pilot.records.is_empty(),
        "not recording until the runtime says so"
    );
    // The runtime opened the file.
    let t0_us = b.now_us();
    b.input(Input::RecordingStarted(path.clone()));
    assert!(b.pilot.engine.recording());
    b.run_to(3.0);
    let recs = std::mem::take(&mut b.pilot.records);
    assert!(recs.iter().any(|(_, r)| matches!(r, RecordItem::Nav(..))));
    assert!(
        recs.iter()
            .any(|(_, r)| matches!(r, RecordItem::Thrust(..)))
    );
    assert!(
        recs.iter().any(
            |(_, r)| matches!(r, RecordItem::Event(_, e) if e.text == "recording to dive.mcap")
        )
    );
    // Stamped in ns since the recording started, in time order.
    for (now_us, r) in &recs {
        assert!(r.t_ns() <= now_us.saturating_sub(t0_us) * 1000);
    }
    assert!(recs.windows(2).all(|w| w[0].1.t_ns() <= w[1].1.t_ns()));
    assert!((b.view().recording.elapsed_s - 2.0).abs() < 0.05);
    b.command(RuntimeCommand::StopRecording);
    assert!(matches!(
        b.pilot.outputs.last(),
        Some(Output::StopRecording)
    ));
    b.input(Input::RecordingStopped);
    b.run_to(4.0);
    assert!(
        b.pilot.records.is_empty(),
        "nothing recorded after the stop"
    );
    assert_eq!(b.view().recording.path, None);
    b.input(Input::Saved(Saved {
        path: path.clone(),
        result: Ok(321),
        video_error: None,
    }));
    assert_eq!(
        b.view().recording.last_file.as_deref(),
        Some(path.as_path())
    );
    assert!(b.has_event("recording saved: dive.mcap (321 messages)"));
    // A refusal is said, and nothing is recorded.
    b.input(Input::RecordingRefused("the disk is full".into()));
    assert_eq!(
        b.view().recording.error.as_deref(),
        Some("the disk is full")
    );
    assert!(b.has_event("cannot record: the disk is full"));
}

#[test]
fn requests_for_the_world_come_back_out_and_the_gamepad_record_button_asks_for_a_new_file() {
    let mut c = cfg();
    c.recordings_dir = Some(PathBuf::from("sessions"));
    let mut b = Bench::new(c);
    b.run_to(0.5);
    b.command(RuntimeCommand::InjectStall(
        std::time::Duration::from_millis(5),
    ));
    b.command(RuntimeCommand::Shutdown);
    assert!(matches!(
        b.pilot.outputs.as_slice(),
        [Output::Stall(d), Output::Shutdown] if d.as_millis() == 5
    ));
    b.pilot.outputs.clear();
    // The gamepad's Record button (a virtual pad: centred first, then the button).
    let map = b.pilot.engine.config().pad_map.clone();
    // Record sits on the shift layer of the default map.
    let shift = map.shift.expect("the default map has a shift button");
    let record = crate::pilot::pad::PadButton::ALL
        .into_iter()
        .find(|btn| map.action(*btn, true) == Some(crate::pilot::pad::Action::Record))
        .expect("the default map has a Record button");
    b.command(RuntimeCommand::PadInput(
        crate::pilot::pad::PadState::default(),
    ));
    b.run_to(0.6);
    let pressed = crate::pilot::pad::PadState {
        buttons: shift.bit() | record.bit(),
        ..Default::default()
    };
    b.command(RuntimeCommand::PadInput(pressed));
    b.run_to(0.7);
    assert!(
        matches!(b.pilot.outputs.as_slice(), [Output::StartRecordingIn(d)] if d.as_path() == std::path::Path::new("sessions")),
        "outputs: {:?}",
        b.pilot.outputs
    );
}

#[test]
fn keyboard_sticks_hold_until_their_timer_and_no_longer() {
    let mut b = Bench::new(cfg());
    b.run_to(1.0);
    let sticks = rov_control::PilotInput {
        surge: 0.5,
        yaw: 0.0,
        vertical: 0.0,
    };
    b.command(RuntimeCommand::Station(StationCommand::Sticks(sticks)));
    let expires = b.now_us() + b.pilot.engine.config().keyboard_timeout_us + 1;
    assert!(b.pilot.engine.poll_timeout().is_some_and(|t| t <= expires));
    b.run_to(1.2);
    assert_eq!(b.view().pilot.input, "keyboard");
    assert!((b.view().pilot.raw.surge - 0.5).abs() < 1e-9);
    b.run_to(1.5);
    assert_eq!(
        b.view().pilot.input,
        "none",
        "released after 0.3 s without a refresh"
    );
    assert_eq!(b.view().pilot.raw.surge, 0.0);
}

#[test]
fn a_fault_injection_command_is_handed_to_the_runtime_and_severities_are_kept() {
    let mut b = Bench::new(cfg());
    b.run_to(0.5);
    let spec = rov_sim::FaultSpec::parse("compass:25@0").unwrap();
    b.command(RuntimeCommand::InjectFault(spec));
    assert!(matches!(b.pilot.outputs.as_slice(), [Output::InjectFault(s)] if *s == spec));
    // The runtime's events come in through the engine's event list.
    let now = b.now_us();
    b.pilot.engine.event(
        now,
        "fault_injected",
        Severity::Warning,
        "simulated fault injected".into(),
    );
    assert!(b.has_event("simulated fault injected"));
}

#[test]
fn markers_and_notes_stay_in_the_dive_log_when_the_events_scroll_past_them() {
    let mut b = Bench::new(cfg());
    b.run_to(1.0);
    b.command(RuntimeCommand::Marker);
    b.command(RuntimeCommand::Note("pipe joint".into()));
    // More events than the event list keeps (each a "settings" event).
    for _ in 0..(crate::pilot::view::EVENT_LINES + 5) {
        b.command(RuntimeCommand::AlarmLimits(b.view().alarm_limits));
    }
    b.run_to(1.5);
    assert!(
        !b.has_event("marker 1"),
        "the events list scrolled past the marker"
    );
    let log = &b.view().dive_log;
    assert_eq!(log.len(), 2, "{log:?}");
    assert!(log[0].contains("marker 1 (at "), "{log:?}");
    assert!(log[1].contains("note 1: pipe joint (at "), "{log:?}");
}
