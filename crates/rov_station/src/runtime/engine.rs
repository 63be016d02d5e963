//! The live engine: the [`StationCore`] plus everything the pilot needs around it (input
//! selection and shaping, hold-to-arm, camera, alarms, prediction, records, recording,
//! publication). Clock-free: the drivers (`live`, `sim`) pass the time in.

mod checklist;
mod pad_input;
mod recording;

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::Ordering;

use firmware_proto::ControlBlock;
use rov_control::{Axis, AxisMode, ModeCommand, ModelSet, PilotInput, TickOutput};
use rov_driver::{Health, Link, LinkEvent, StatusTelemetry, Telemetry};
use rov_session::{
    AutopilotRecord, Direction, EventRecord, LinkRecord, Mode, NavRecord, ObserverRecord,
    PilotRecord, SessionInfo, Severity, StatusRecord, ThrustRecord,
};

use crate::core::{StationCommand, StationCore};
use crate::runtime::alarms::{AlarmChange, AlarmInputs, AlarmLevel, Alarms};
use crate::runtime::dive::{
    DiveEvent, DiveLog, Item, ItemStatus, THRUSTERS, ThrusterTest, thruster_detail,
};
use crate::runtime::finisher::{EXIT_WAIT, Finished, Finishers};
use crate::runtime::history::HistorySample;
use crate::runtime::pad::{Action, PadButton, PadState};
use crate::runtime::predict::{Anchor, Predictor};
use crate::runtime::recorder::{RecordItem, Recorder};
use crate::runtime::shaping::{ArmHold, Gain, StickShaping, to_controller};
use crate::runtime::view::{AxisModeView, PadStatus, Pipeline, Source, WatchAlertView, link_state};
use crate::runtime::watch::{StationWatch, nav_row};
use crate::runtime::{
    CameraCommand, ChecklistCommand, GainCommand, RuntimeCommand, RuntimeConfig, RuntimeError,
    Shared, lock, try_lock,
};
use rov_types::conventions::PhysicsThrust;

/// Gamepad sticks older than this (gamepad thread heartbeat) count as centred, µs.
const PAD_STALE_US: u64 = 100_000;
/// Link statistics interval, µs.
const LINK_RECORD_US: u64 = 500_000;

/// What a command asks of the driver beyond the engine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Followup {
    None,
    Shutdown,
    Stall(std::time::Duration),
}

#[derive(Debug)]
pub(crate) struct Engine {
    /// The model watch (issue 23); `None` when off or its model did not load.
    watch: Option<StationWatch>,
    /// Where injected faults go (the simulated vehicle only).
    fault_inbox: Option<rov_vehicle::runner::FaultInbox>,
    /// The thrust command in force (the watch's rows carry it), %.
    thrust_now_pct: [f64; 3],
    /// The latest change the watch found, in noise floors (the alarm's cause).
    vehicle_changed_noise: Option<f64>,
    core: StationCore,
    models: ModelSet,
    cfg: RuntimeConfig,
    pub pipeline: Pipeline,
    alarms: Alarms,
    predictor: Predictor,
    shaping: StickShaping,
    gain: Gain,
    keyboard: Option<(PilotInput, u64)>,
    arm: ArmHold,
    arm_pad: ArmHold,
    lights_pct: u8,
    tilt_deg: i8,
    focus_pct: i8,
    recorder: Option<Recorder>,
    /// Stopped recordings being saved on their own threads (see `finisher`).
    finishers: Finishers,
    /// The live Foxglove server's tap (records are copied to it, recording or not).
    live: Option<crate::runtime::foxglove_live::LiveTap>,
    /// Live sim mode: the vehicle thread's latest truth, for `/truth/state`.
    truth_tap: Option<rov_vehicle::runner::TruthTap>,
    /// The camera (see `video`): the recording's encoder starts and stops with it.
    video: Option<Arc<crate::runtime::video::StationVideo>>,
    /// Serial mode: the port's state and re-connection (see `reconnect`).
    pub(crate) port: Option<crate::runtime::reconnect::PortMonitor>,
    shared: Arc<Shared>,
    pending: Vec<HistorySample>,
    ever_connected: bool,
    tare_sent: bool,
    last_tick_us: Option<u64>,
    last_link_us: Option<u64>,
    last_nav_us: Option<u64>,
    last_status: Option<StatusTelemetry>,
    watchdog_seen: u64,
    prev_modes: (Mode, Mode),
    prev_armed: bool,
    overridden: (bool, bool),
    source_label: String,
    /// Time of the last recorded message, ns: later messages are stamped no earlier, so
    /// a recording is in time order even when a frame received before a tick is
    /// handled after it.
    last_record_ns: std::cell::Cell<u64>,
    /// When the current hint was shown, µs.
    hint_since_us: Option<u64>,
    dive: DiveLog,
    thruster_test: Option<ThrusterTest>,
    /// The thrust the test commanded last tick (ramped at 10 %/tick).
    test_pct: [f64; 3],
    last_pressure_mbar: Option<f64>,
    /// A virtual pad's last state and when it came.
    virtual_pad: Option<(PadState, u64)>,
    virtual_centred: bool,
    /// Buttons held at the last tick (press edges).
    pad_buttons: u32,
    /// The feedforward model's name of the last tick (reused).
    last_model_name: String,
    /// The inputs of the last automatic checklist update (updated on change only).
    auto_key: Option<(u8, i64, i64, bool)>,
}

/// The names of the buttons held (an empty list, no allocation, when none is).
fn held_names(bits: u32) -> Vec<String> {
    if bits == 0 {
        return Vec::new();
    }
    PadButton::ALL
        .iter()
        .filter(|b| bits & b.bit() != 0)
        .map(|b| b.key().to_string())
        .collect()
}

/// Shown when the gamepad thread stops reporting.
static STALE_PAD: PadStatus = PadStatus::Stale;

/// A virtual pad's sticks are all inside the centre zone.
fn virtual_centred(st: &PadState) -> bool {
    st.axes.iter().take(4).all(|x| x.abs() < 0.1)
}

/// How long a hint stays in the view, µs.
const HINT_US: u64 = 4_000_000;

/// The hint after a short press of the arm button.
pub const ARM_HINT: &str = "Hold to arm: keep the arm button (or Space) pressed for 1 s";

/// The hint when a hold stopped being reported (the GUI or gamepad froze for over 1 s).
pub const ARM_STALE_HINT: &str =
    "Arming cancelled: the station lost the held button for over 1 s (press and hold again)";

fn axis_mode(m: AxisMode) -> Mode {
    match m {
        AxisMode::Manual => Mode::Manual,
        AxisMode::Hold => Mode::Hold,
        AxisMode::VehicleAuto => Mode::Onboard,
    }
}

fn nav_record(t: &Telemetry) -> NavRecord {
    NavRecord {
        heading_deg: t.heading_deg,
        pitch_deg: t.pitch_deg,
        roll_deg: t.roll_deg,
        pressure_mbar: Some(t.pressure_mbar),
        depth_m: t.depth_m,
        yaw_rate_dps: Some(t.yaw_rate_radps.to_degrees()),
        pitch_rate_dps: Some(t.pitch_rate_radps.to_degrees()),
        roll_rate_dps: Some(t.roll_rate_radps.to_degrees()),
        surge_accel_mps2: None,
        sway_accel_mps2: None,
        heave_accel_mps2: None,
        mag_x: Some(f64::from(t.mag_raw[0])),
        mag_y: Some(f64::from(t.mag_raw[1])),
        mag_z: Some(f64::from(t.mag_raw[2])),
        attitude_status: Some(u64::from(t.attitude_status.cast_unsigned())),
        humidity_pct: Some(t.humidity_pct),
        water_temp_c: Some(t.water_temp_c),
        power_pct: Some(f64::from(t.power_pct)),
    }
}

/// The internal temperature the vehicle reports, °C: the CPU board's sensor (CSR 0x82,
/// marked reserved in the Pro 4's map; read as whole °C, to be checked on hardware).
/// 0 means not reported (the simulated vehicle leaves it at 0).
fn internal_temp_c(s: StatusTelemetry) -> Option<f64> {
    let raw = s.raw.internal_temp_cpu_raw;
    (raw != 0).then(|| f64::from(raw))
}

fn status_record(s: &StatusTelemetry) -> StatusRecord {
    StatusRecord {
        water_temp_c: s.water_temp_c,
        tether_v: s.tether_v,
        rail_12v_v: s.rail_12v_v,
        rail_12v_ma: s.rail_12v_a * 1000.0,
        humidity_pct: s.humidity_pct,
        comm_errors: u64::from(s.comm_errors),
    }
}

impl Engine {
    pub fn new(
        cfg: RuntimeConfig,
        models: ModelSet,
        shared: Arc<Shared>,
        source: Source,
    ) -> Result<Self, RuntimeError> {
        let mut core = StationCore::new(cfg.control, models.clone())?;
        if let Some(a) = &cfg.autopilot_model {
            core.set_plant(&a.label, a.plant.clone())?;
        }
        let source_label = match &source {
            Source::Serial(p) => format!("serial:{p}"),
            _ => "sim".to_string(),
        };
        let mut pipeline = Pipeline::new(source);
        pipeline.view.alarm_limits = cfg.alarms;
        pipeline.view.pilot.pad_map = cfg.pad_map.clone();
        let mut watch_off: Option<String> = (!cfg.watch).then(|| "off in the settings".into());
        let watch = if cfg.watch {
            let model = match &cfg.watch_model {
                Some(m) => Ok(m.clone()),
                None => rov_lab::load_model(
                    &rov_types::ModelId::Base(cfg.control.feedforward_model),
                    None,
                ),
            };
            match model {
                Ok(m) => Some(StationWatch::new(m, false)),
                Err(e) => {
                    watch_off = Some(format!("its model did not load: {e}"));
                    None
                }
            }
        } else {
            None
        };
        pipeline.view.watch.off_reason = watch_off;
        Ok(Self {
            watch,
            fault_inbox: None,
            thrust_now_pct: [0.0; 3],
            vehicle_changed_noise: None,
            core,
            models,
            alarms: Alarms::new(cfg.alarms),
            predictor: Predictor::default(),
            shaping: cfg.shaping,
            gain: Gain::with_index(cfg.gain_index),
            pipeline,
            keyboard: None,
            arm: ArmHold::default(),
            arm_pad: ArmHold::default(),
            lights_pct: 0,
            tilt_deg: 0,
            focus_pct: 0,
            recorder: None,
            finishers: Finishers::default(),
            video: None,
            live: None,
            truth_tap: None,
            port: None,
            shared,
            pending: Vec::new(),
            ever_connected: false,
            tare_sent: false,
            last_tick_us: None,
            last_link_us: None,
            last_nav_us: None,
            last_status: None,
            watchdog_seen: 0,
            prev_modes: (Mode::Manual, Mode::Manual),
            prev_armed: false,
            overridden: (false, false),
            source_label,
            last_record_ns: std::cell::Cell::new(0),
            hint_since_us: None,
            dive: DiveLog::default(),
            thruster_test: None,
            test_pct: [0.0; 3],
            last_pressure_mbar: None,
            virtual_pad: None,
            virtual_centred: false,
            pad_buttons: 0,
            last_model_name: String::new(),
            auto_key: None,
            cfg,
        })
    }

    fn record(&self, item: impl FnOnce(u64) -> RecordItem, now_us: u64) {
        if let Some(r) = &self.recorder {
            let t = r.t_ns(now_us).max(self.last_record_ns.get());
            self.last_record_ns.set(t);
            let item = item(t);
            self.serve_live(now_us, &item);
            r.send(item);
        } else if self.live.is_some() {
            self.serve_live(now_us, &item(0));
        }
    }

    /// Whether records are wanted (recording, or serving them live).
    fn records_wanted(&self) -> bool {
        self.recorder.is_some() || self.live.is_some()
    }

    /// A copy of a record for the live Foxglove server, if one is attached.
    fn serve_live(&self, now_us: u64, item: &RecordItem) {
        if let Some(l) = &self.live {
            l.send(now_us, item);
        }
    }

    fn hint(&mut self, text: &str, now_us: u64) {
        self.pipeline.view.hint = Some(text.to_string());
        self.hint_since_us = Some(now_us);
    }

    /// Records `/truth/state` from the simulated vehicle's thread (live sim mode).
    pub fn attach_truth_tap(&mut self, tap: rov_vehicle::runner::TruthTap) {
        self.truth_tap = Some(tap);
    }

    /// The camera whose video recordings hold.
    pub fn attach_video(&mut self, video: Arc<crate::runtime::video::StationVideo>) {
        self.video = Some(video);
    }

    /// Records the attached tap's latest truth, at most one vehicle-runner wake-up
    /// (≈ 2 ms) old. Never waits for the vehicle thread.
    pub fn record_tapped_truth(&self, now_us: u64) {
        let latest = self
            .truth_tap
            .as_ref()
            .and_then(|t| t.try_lock().ok())
            .and_then(|slot| *slot);
        if let Some(truth) = latest {
            self.record_truth(&truth, now_us);
        }
    }

    /// Records the simulated vehicle's truth (`/truth/state`) when a recording (or the live
    /// Foxglove server) is running.
    /// The station's control path never reads it: truth is for the engineer comparing
    /// the estimate with reality afterwards.
    pub fn record_truth(&self, truth: &rov_sim::TruthState, now_us: u64) {
        if self.records_wanted() {
            let rec = truth_record(truth);
            self.record(|t| RecordItem::Truth(t, rec), now_us);
        }
    }

    /// An event: the view's event list and the session's `/events`.
    pub(crate) fn event(&mut self, now_us: u64, kind: &str, severity: Severity, text: String) {
        let r = EventRecord {
            kind: kind.to_string(),
            severity,
            text,
        };
        self.pipeline.event(now_us as f64 * 1e-6, &r);
        self.record(|t| RecordItem::Event(t, r), now_us);
    }

    /// [`RuntimeCommand::AutopilotModel`].
    /// The simulated vehicle's fault inbox (RuntimeCommand::InjectFault goes there).
    pub fn attach_fault_inbox(&mut self, inbox: rov_vehicle::runner::FaultInbox) {
        self.fault_inbox = Some(inbox);
    }

    /// Runs the model watch inline (virtual time: no thread, same alerts).
    pub fn watch_inline(&mut self) {
        if let Some(w) = &mut self.watch {
            w.set_inline();
        }
    }

    /// The model watch's alerts into the dive: an event each (in the replay index), the
    /// VEHICLE CHANGED alarm for a change, the words in the view. A mismatch is only an
    /// event and a line (the model was wrong from the start: a job for the lab, not an
    /// alarm).
    fn take_alerts(&mut self, alerts: Vec<rov_lab::watch::Alert>, now_us: u64) {
        let t_s = now_us as f64 * 1e-6;
        for a in alerts {
            let words = a.words();
            // The alert's times count from the watch's first row; the onset in station
            // time is as far before now as the alert says it was before its detection.
            let since_s = t_s - (a.detected_s - a.t_s).max(0.0);
            let (kind, sev) = match a.kind {
                rov_lab::watch::AlertKind::Change => {
                    self.vehicle_changed_noise = Some(a.size_noise);
                    self.alarms
                        .reraise(crate::runtime::alarms::AlarmKind::VehicleChanged);
                    ("change", Severity::Warning)
                }
                rov_lab::watch::AlertKind::Mismatch => ("mismatch", Severity::Info),
            };
            let causes: Vec<String> = a
                .causes
                .iter()
                .take(3)
                .map(|c| format!("{} {} {} ({:.2})", c.cause, c.size, c.unit, c.score))
                .collect();
            self.event(
                now_us,
                "model_watch",
                sev,
                format!(
                    "{kind} on {} since {since_s:.1} s, {:.1} noise floors: {words}; causes: {}",
                    a.channel,
                    a.size_noise,
                    causes.join(", ")
                ),
            );
            self.pipeline.view.watch.alerts.push(WatchAlertView {
                kind: kind.into(),
                channel: a.channel.clone(),
                since_s,
                words,
                size_noise: a.size_noise,
            });
        }
        if let Some(w) = &self.watch {
            let v = &mut self.pipeline.view.watch;
            v.running = w.running();
            v.rows = w.rows;
            v.dropped_rows = w.dropped_rows;
            if let Some(e) = &w.error {
                v.off_reason = Some(e.clone());
            }
        }
    }

    fn autopilot_model(
        &mut self,
        link: &Link,
        model: Option<Box<crate::hold::AutopilotModel>>,
        confirmed: bool,
        now_us: u64,
    ) {
        if link.failsafe().is_armed() && !confirmed {
            self.refuse(
                now_us,
                "changing the autopilot model",
                "the vehicle is armed (disarm first, or confirm)".into(),
            );
            return;
        }
        let result = match &model {
            Some(m) => self.core.set_plant(&m.label, m.plant.clone()),
            None => {
                let choice = self.cfg.control.feedforward_model;
                self.core
                    .controller_command(rov_control::ModeCommand::SelectModel(choice))
            }
        };
        match result {
            Ok(()) => {
                let text = format!("autopilot model: {}", self.core.controller().model_label());
                self.event(now_us, "autopilot", Severity::Info, text);
            }
            Err(e) => self.refuse(now_us, "the autopilot model", e.to_string()),
        }
    }

    fn refuse(&mut self, now_us: u64, what: &str, why: String) {
        // "cannot arm: ..." says it already.
        let text = if why.starts_with("cannot") {
            why
        } else {
            format!("{what} refused: {why}")
        };
        self.pipeline.view.last_refusal = Some(text.clone());
        self.event(now_us, "refused", Severity::Warning, text);
    }

    /// One link event.
    pub fn on_event(&mut self, link: &mut Link, ev: &LinkEvent, now_us: u64) {
        self.core.on_event(link, ev);
        let t_s = now_us as f64 * 1e-6;
        match ev {
            LinkEvent::Telemetry(t) => {
                let r = nav_record(t);
                self.last_pressure_mbar = Some(t.pressure_mbar);
                self.pipeline.nav(t_s, &r);
                self.last_nav_us = Some(now_us);
                self.record(|ts| RecordItem::Nav(ts, r), now_us);
                if let Some(w) = &mut self.watch {
                    let alerts = w.push(nav_row(t_s, self.thrust_now_pct, t));
                    self.take_alerts(alerts, now_us);
                }
                if !self.tare_sent {
                    // The link converts pressure to depth with its surface pressure; the
                    // controller's tare (for the vehicle's own auto-depth target) must
                    // match it.
                    let p = link.config().conventions.surface_pressure_mbar;
                    let cmd =
                        StationCommand::Mode(ModeCommand::SetSurfaceTare { pressure_mbar: p });
                    self.tare_sent = self.core.command(link, cmd, now_us).is_ok();
                }
            }
            LinkEvent::Status(s) => {
                let r = status_record(s);
                self.pipeline.status(&r);
                self.pipeline.view.health.internal_temp_c = internal_temp_c(*s);
                self.last_status = Some(*s);
                self.record(|ts| RecordItem::Status(ts, r), now_us);
            }
            LinkEvent::StateChanged { health, phase, .. } => {
                let text = format!("link {health:?} ({phase:?})").to_lowercase();
                let sev = if *health == Health::Lost && self.ever_connected {
                    Severity::Alarm
                } else {
                    Severity::Info
                };
                if *health == Health::Connected {
                    self.ever_connected = true;
                }
                self.event(now_us, "link_state", sev, text);
            }
            LinkEvent::FrameTx { bytes, time_us } if self.recorder.is_some() => {
                let b = bytes.clone();
                self.record(|t| RecordItem::Raw(Direction::Tx, t, b), *time_us);
            }
            LinkEvent::FrameRx { bytes, time_us } if self.recorder.is_some() => {
                let b = bytes.clone();
                self.record(|t| RecordItem::Raw(Direction::Rx, t, b), *time_us);
            }
            LinkEvent::AlarmRaised { alarm, .. } => {
                self.event(
                    now_us,
                    "failsafe",
                    Severity::Alarm,
                    format!("failsafe: {alarm:?}, thrust neutral until re-armed"),
                );
            }
            _ => {}
        }
    }

    /// One command.
    pub fn apply(&mut self, link: &mut Link, cmd: RuntimeCommand, now_us: u64) -> Followup {
        match cmd {
            RuntimeCommand::Station(StationCommand::Sticks(p)) => {
                self.keyboard = Some((p, now_us));
            }
            RuntimeCommand::Station(c) => {
                let label = format!("{c:?}");
                match self.core.command(link, c, now_us) {
                    Ok(()) => {
                        if matches!(c, StationCommand::Disarm) {
                            self.arm = ArmHold::default();
                            self.arm_pad = ArmHold::default();
                        }
                        if matches!(c, StationCommand::Mode(_)) {
                            self.pipeline.view.last_refusal = None;
                        }
                    }
                    Err(e) => self.refuse(now_us, &label, e.to_string()),
                }
            }
            RuntimeCommand::ArmButton(b) => {
                self.arm.report(b, now_us);
                if self.arm.take_released_early() {
                    self.hint(ARM_HINT, now_us);
                }
            }
            RuntimeCommand::ToggleHold(axis) => {
                let m = if self.core.holding(axis) {
                    ModeCommand::Disengage(axis)
                } else {
                    ModeCommand::Engage(axis)
                };
                if let Err(e) = self.core.command(link, StationCommand::Mode(m), now_us) {
                    self.refuse(now_us, &format!("{m:?}"), e.to_string());
                }
            }
            RuntimeCommand::Gain(g) => {
                self.gain = match g {
                    GainCommand::Up => self.gain.up(),
                    GainCommand::Down => self.gain.down(),
                    GainCommand::Set(i) => Gain::with_index(i),
                };
            }
            RuntimeCommand::Camera(c) => match c {
                CameraCommand::Lights(x) if x.is_finite() => {
                    self.lights_pct = x.round().clamp(0.0, 100.0) as u8;
                }
                CameraCommand::Tilt(x) if x.is_finite() => {
                    self.tilt_deg = x.round().clamp(-90.0, 90.0) as i8;
                }
                CameraCommand::Focus(x) if x.is_finite() => {
                    self.focus_pct = x.round().clamp(-100.0, 100.0) as i8;
                }
                _ => {}
            },
            RuntimeCommand::Shaping(s) => self.shaping = s,
            RuntimeCommand::AckAlarm(k) => {
                self.alarms.acknowledge(k);
                self.alarms.list_into(&mut self.pipeline.view.alarms);
            }
            RuntimeCommand::AlarmLimits(c) => {
                self.alarms.set_config(c);
                self.pipeline.view.alarm_limits = c;
                self.event(
                    now_us,
                    "settings",
                    Severity::Info,
                    "alarm limits changed".into(),
                );
            }
            RuntimeCommand::ResetTurns => self.pipeline.reset_turns(),
            RuntimeCommand::Note(text) => {
                let n = self.dive.note();
                let text = format!("note {n}: {} ({})", text.trim(), self.where_now());
                self.event(now_us, "note", Severity::Info, text);
            }
            RuntimeCommand::Marker => {
                let n = self.dive.marker();
                let text = format!("marker {n} ({})", self.where_now());
                self.event(now_us, "marker", Severity::Info, text);
            }
            RuntimeCommand::Checklist(c) => self.checklist(link, c, now_us),
            RuntimeCommand::StartRecording(path) => {
                self.start_recording(&path, now_us);
                link.set_record_frames(self.recorder.is_some());
            }
            RuntimeCommand::StopRecording => {
                self.stop_recording(now_us);
                link.set_record_frames(false);
            }
            RuntimeCommand::FoxgloveLive(tap) => self.live = tap,
            RuntimeCommand::Replay(_) => {}
            RuntimeCommand::PadMap(m) => {
                self.pipeline.view.pilot.pad_map = m.clone();
                self.cfg.pad_map = m;
            }
            RuntimeCommand::PadInput(st) => self.virtual_pad = Some((st, now_us)),
            RuntimeCommand::AutopilotModel { model, confirmed } => {
                self.autopilot_model(link, model, confirmed, now_us);
            }
            RuntimeCommand::InjectStall(d) => return Followup::Stall(d),
            RuntimeCommand::InjectFault(spec) => match &self.fault_inbox {
                Some(inbox) => {
                    // The control thread never waits on the vehicle: a busy lock is
                    // said, and the pilot presses again.
                    let taken = inbox.try_lock().map(|mut v| v.push(spec)).is_ok();
                    if taken {
                        self.event(
                            now_us,
                            "fault_injected",
                            Severity::Warning,
                            format!("simulated fault injected: {spec}"),
                        );
                    } else {
                        self.refuse(
                            now_us,
                            "inject a fault",
                            "the vehicle was busy; try again".into(),
                        );
                    }
                }
                None => self.refuse(
                    now_us,
                    "inject a fault",
                    "fault injection needs the built-in simulated vehicle".into(),
                ),
            },
            RuntimeCommand::Shutdown => return Followup::Shutdown,
        }
        Followup::None
    }

    /// One control tick at `now_us`.
    pub fn tick(&mut self, link: &mut Link, now_us: u64) -> TickOutput {
        let t_s = now_us as f64 * 1e-6;
        // Arming by holding a button.
        let (raw, input) = self.pilot_input(link, now_us);
        let arm_gui = self.arm.poll(now_us);
        let arm_pad = self.arm_pad.poll(now_us);
        if self.arm.take_went_stale() || self.arm_pad.take_went_stale() {
            self.hint(ARM_STALE_HINT, now_us);
        }
        if (arm_gui || arm_pad) && !link.failsafe().is_armed() {
            match self.core.command(link, StationCommand::Arm, now_us) {
                Ok(()) => self.pipeline.view.last_refusal = None,
                Err(e) => self.refuse(now_us, "Arm", e.to_string()),
            }
        }
        // Sticks: shaped, gain, mapped onto the controller's deadband.
        let shaped = self.shaping.apply(&raw);
        let to_ctl = to_controller(&shaped, self.gain, &self.cfg.control);
        // Sticks are never refused (they only replace the pilot input).
        let _ = self
            .core
            .command(link, StationCommand::Sticks(to_ctl), now_us);
        // Lights and camera ride in the same control block.
        let mut block: ControlBlock = *link.command();
        block.lights_pct = self.lights_pct;
        block.tilt_deg = self.tilt_deg;
        block.focus_pct = self.focus_pct;
        link.set_command(block);

        let out = self.core.tick(link, now_us);
        self.poll_finishers(now_us);
        let test_thrust = self.thruster_test_tick(link, &raw, now_us);
        let dt_s = self
            .last_tick_us
            .map_or(0.0, |t| now_us.saturating_sub(t) as f64 * 1e-6);
        self.last_tick_us = Some(now_us);

        // Records: thrust, pilot, autopilot, observer (and link stats every 0.5 s).
        let c = out.command;
        let cmd = *link.command();
        let [tp, ts, tv] =
            test_thrust.unwrap_or([c.port_pct(), c.starboard_pct(), c.vertical_pct()]);
        let thrust = ThrustRecord {
            port_pct: tp,
            starboard_pct: ts,
            vertical_pct: tv,
            lights_pct: f64::from(cmd.lights_pct),
            tilt: f64::from(cmd.tilt_deg),
            focus: f64::from(cmd.focus_pct),
            depth_target_mbar: cmd.depth_target_mbar.map(f64::from),
            heading_target_deg: cmd.heading_target_deg.map(f64::from),
        };
        let armed = link.failsafe().is_armed();
        let pilot = PilotRecord {
            surge: raw.surge,
            yaw: raw.yaw,
            heave: raw.vertical,
            armed,
            gain_pct: self.gain.pct(),
            buttons: held_names(self.pad_buttons),
        };
        let ctl = self.core.controller();
        let ds = ctl.axis_state(Axis::Depth);
        let hs = ctl.axis_state(Axis::Heading);
        let auto = AutopilotRecord {
            depth_mode: axis_mode(ds.mode),
            heading_mode: axis_mode(hs.mode),
            depth_setpoint_m: ctl.depth_setpoint_m(),
            heading_setpoint_deg: ctl.heading_setpoint_deg(),
            // The model name is taken from the last record unless it changed (no
            // allocation per tick).
            feedforward_model: {
                let name = if ctl.feedforward_enabled() {
                    ctl.model_label()
                } else {
                    ""
                };
                if self.last_model_name != name {
                    name.clone_into(&mut self.last_model_name);
                }
                std::mem::take(&mut self.last_model_name)
            },
        };
        let model_choice = ctl.model();
        let d = &out.diagnostics;
        let de = d.depth.estimate;
        let he = d.heading.estimate;
        let observer = ObserverRecord {
            depth_m: de.map_or(f64::NAN, |e| e.pos),
            heave_mps: de.map_or(f64::NAN, |e| e.vel),
            depth_bias: de.map_or(f64::NAN, |e| e.bias),
            heading_deg: he.map_or(f64::NAN, |e| e.pos.to_degrees()),
            yaw_rate_dps: he.map_or(f64::NAN, |e| e.vel.to_degrees()),
            heading_bias: he.map_or(f64::NAN, |e| e.bias),
            depth_var: de.map_or(f64::NAN, |e| e.pos_std * e.pos_std),
            heading_var: he.map_or(f64::NAN, |e| (e.pos_std.to_degrees()).powi(2)),
        };
        let sensor_fault = d.faults.depth_sensor_lost || d.faults.heading_sensor_lost;
        self.overridden = (ds.overridden, hs.overridden);

        // Events: arming and mode changes.
        if armed != self.prev_armed {
            self.prev_armed = armed;
            let (kind, text) = if armed {
                ("armed", "ARMED")
            } else {
                ("disarmed", "disarmed")
            };
            self.event(now_us, kind, Severity::Info, text.into());
        }
        let modes = (auto.depth_mode, auto.heading_mode);
        if modes != self.prev_modes {
            self.prev_modes = modes;
            let text = format!("depth {} / heading {}", modes.0.as_str(), modes.1.as_str());
            self.event(now_us, "autopilot", Severity::Info, text);
        }

        self.thrust_now_pct = [tp, ts, tv];
        if let Some(w) = &mut self.watch {
            let alerts = w.poll();
            self.take_alerts(alerts, now_us);
        }
        self.pipeline.thrust(&thrust);
        self.pipeline.pilot(&pilot);
        self.pipeline.autopilot(&auto);
        self.pipeline.observer(&observer);
        self.record(|t| RecordItem::Thrust(t, thrust), now_us);
        self.record(|t| RecordItem::Pilot(t, pilot), now_us);
        if self.records_wanted() {
            let rec = auto.clone();
            self.record(|t| RecordItem::Autopilot(t, rec), now_us);
        }
        self.last_model_name = auto.feedforward_model;
        self.record(|t| RecordItem::Observer(t, observer), now_us);
        if self
            .last_link_us
            .is_none_or(|t| now_us.saturating_sub(t) >= LINK_RECORD_US)
        {
            self.last_link_us = Some(now_us);
            let k = link.counters();
            let rtt = link.rtt();
            let health = match link.health() {
                Health::Connected => "connected",
                Health::Degraded => "degraded",
                Health::Lost => "lost",
            };
            let lr = LinkRecord {
                state: link_state(health),
                exchanges: k.requests,
                timeouts: k.failed_timeout,
                sync_errors: k.deframer.garbage_bytes,
                header_errors: k.failed_header_check,
                total_errors: k.failed(),
                unexpected: k.unexpected_frames,
                rtt_p50_ms: rtt.p50_us as f64 * 1e-3,
                rtt_p99_ms: rtt.p99_us as f64 * 1e-3,
            };
            self.pipeline.link(t_s, &lr);
            self.record(|t| RecordItem::Link(t, lr), now_us);
        }
        // The link's health string changes at once (the record above is periodic).
        let health = match link.health() {
            Health::Connected => "connected",
            Health::Degraded => "degraded",
            Health::Lost => "lost",
        };
        if self.pipeline.view.link.health != health {
            self.pipeline.view.link.health = health.to_string();
            self.pipeline.view.snapshot.link_health = health.to_string();
        }

        // Alarms.
        let trips = self.shared.watchdog_trips.load(Ordering::Relaxed);
        let stall = trips != self.watchdog_seen;
        self.watchdog_seen = trips;
        let s = self.last_status;
        let inputs = AlarmInputs {
            link_lost: link.health() == Health::Lost,
            ever_connected: self.ever_connected,
            humidity_pct: self.pipeline.view.health.humidity_pct,
            depth_m: self.pipeline.view.snapshot.depth_m,
            turns: Some(self.pipeline.view.turns),
            tether_v: s.map(|s| s.tether_v),
            rail_v: s.map(|s| s.rail_12v_v),
            internal_temp_c: s.and_then(internal_temp_c),
            nav_age_s: self
                .last_nav_us
                .map(|t| now_us.saturating_sub(t) as f64 * 1e-6),
            sensor_fault,
            control_stall: stall,
            vehicle_changed_noise: self.vehicle_changed_noise,
        };
        for change in self.alarms.evaluate(t_s, &inputs) {
            match change {
                AlarmChange::Raised(k, level) => {
                    let (sev, what) = match level {
                        AlarmLevel::Alarm => (Severity::Alarm, "ALARM"),
                        AlarmLevel::Warning => (Severity::Warning, "warning"),
                    };
                    self.event(now_us, k.key(), sev, format!("{} ({what})", k.text()));
                }
                AlarmChange::Cleared(k) => self.event(
                    now_us,
                    k.key(),
                    Severity::Info,
                    format!("{} cleared (acknowledge to remove)", k.text()),
                ),
            }
        }

        // Prediction.
        let (w, r) = self.pipeline.observer_rates();
        let snap = &self.pipeline.view.snapshot;
        let anchor = Anchor {
            depth_m: snap.depth_estimate_m.or(snap.depth_m),
            w_mps: w,
            heading_deg: snap.heading_estimate_deg.or(snap.heading_deg),
            r_rad_s: r,
        };
        // The autopilot's own model predicts (a custom plant when one is set).
        let model = match self.core.controller().custom_plant() {
            Some(p) => p,
            None => self.models.get(model_choice),
        };
        if self.pipeline.view.model_label != self.core.controller().model_label() {
            self.core
                .controller()
                .model_label()
                .clone_into(&mut self.pipeline.view.model_label);
        }
        self.pipeline.view.prediction = self.predictor.step(
            model,
            t_s,
            dt_s,
            &anchor,
            [c.port_pct(), c.starboard_pct(), c.vertical_pct()],
        );

        // Dive log and checklist.
        match self.dive.update(t_s, self.pipeline.view.snapshot.depth_m) {
            Some(DiveEvent::Started) => {
                let n = self.dive.view().dives;
                self.event(
                    now_us,
                    "dive_start",
                    Severity::Info,
                    format!("dive {n} started"),
                );
            }
            Some(DiveEvent::Ended {
                dive_s,
                max_depth_m,
            }) => {
                let n = self.dive.view().dives;
                let t = dive_s as u64;
                let text = format!(
                    "dive {n} ended: {:02}:{:02}, deepest {max_depth_m:.1} m",
                    t / 60,
                    t % 60
                );
                self.event(now_us, "dive_end", Severity::Info, text);
            }
            None => {}
        }
        self.pipeline.view.dive = self.dive.view();
        self.auto_items();

        // View.
        self.pipeline.set_time(t_s);
        self.pipeline
            .sensor_lost(d.faults.depth_sensor_lost, d.faults.heading_sensor_lost);
        if self
            .hint_since_us
            .is_some_and(|t| now_us.saturating_sub(t) > HINT_US)
        {
            self.hint_since_us = None;
            self.pipeline.view.hint = None;
        }
        let v = &mut self.pipeline.view;
        v.snapshot.armed = armed;
        v.snapshot.alarm = link.failsafe().alarm().map(|a| format!("{:?}", a.alarm));
        v.depth.overridden = self.overridden.0;
        v.heading.overridden = self.overridden.1;
        if v.depth.mode == AxisModeView::Manual {
            v.depth.overridden = false;
        }
        if v.heading.mode == AxisModeView::Manual {
            v.heading.overridden = false;
        }
        v.health.humidity_rate_pct_per_min = self.alarms.humidity_rate_pct_per_min();
        self.alarms.list_into(&mut v.alarms);
        v.pilot.raw = raw.into();
        v.pilot.shaped = shaped.into();
        v.pilot.gain_pct = self.gain.pct();
        v.pilot.gain_index = self.gain.index();
        v.pilot.arm_progress = self.arm.progress(now_us).max(self.arm_pad.progress(now_us));
        if v.pilot.input != input {
            input.clone_into(&mut v.pilot.input);
        }
        match &self.recorder {
            Some(r) => {
                v.recording.elapsed_s = now_us.saturating_sub(r.started_us()) as f64 * 1e-6;
                v.recording.messages = r.queued();
                v.recording.dropped = r.dropped();
                if let Some(e) = r.error() {
                    v.recording.error = Some(e);
                }
            }
            None => v.recording.elapsed_s = 0.0,
        }
        v.commands_dropped = self.shared.commands_dropped.load(Ordering::Relaxed);
        let sample = self.pipeline.sample(t_s);
        self.pending.push(sample);
        out
    }

    /// Publishes the view and the pending history samples. Never waits for a reader:
    /// if the GUI holds a lock right now, the publication is retried next tick.
    pub fn publish(&mut self, tick: Option<crate::runtime::TickStats>) {
        if let Some(t) = tick {
            self.pipeline.view.tick = t;
        }
        if self.pipeline.view.control_priority.is_empty()
            && let Some(p) = try_lock(&self.shared.priorities)
            && let Some((_, g)) = p.iter().find(|(n, _)| n == "station-control")
        {
            self.pipeline.view.control_priority = g.to_string();
        }
        self.pipeline.view.seq += 1;
        if let Some(mut v) = try_lock(&self.shared.view) {
            v.clone_from(&self.pipeline.view);
        }
        if !self.pending.is_empty()
            && let Some(mut f) = try_lock(&self.shared.feed)
        {
            f.extend(self.pending.drain(..));
        }
        // Bound the backlog if a reader sat on the lock for very long.
        if self.pending.len() > crate::runtime::history::FEED_CAPACITY {
            let extra = self.pending.len() - crate::runtime::history::FEED_CAPACITY;
            self.pending.drain(..extra);
        }
    }

    /// Finishes a recording (shutdown) and waits for every recording being saved, at
    /// most [`EXIT_WAIT`] in all: nothing is lost at exit.
    pub fn finish(&mut self, now_us: u64) {
        self.stop_recording(now_us);
        self.wait_for_finishers(EXIT_WAIT, now_us);
    }
}

/// The file name of a path (events name the file; the folder is in the settings).
fn file_name(path: &std::path::Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

/// `/truth/state` from the simulator's truth, in the units of the measured channels
/// (`rov_dynamics::Channel::value`), with the heading wrapped to 0..360°.
pub(crate) fn truth_record(t: &rov_sim::TruthState) -> rov_session::TruthRecord {
    use rov_dynamics::models::Channel;
    let v = |ch: Channel| ch.value(&t.state);
    rov_session::TruthRecord {
        north_m: v(Channel::North),
        east_m: v(Channel::East),
        depth_m: v(Channel::Depth),
        roll_deg: v(Channel::Roll),
        pitch_deg: v(Channel::Pitch),
        heading_deg: v(Channel::Heading).rem_euclid(360.0),
        u_mps: v(Channel::Surge),
        v_mps: v(Channel::Sway),
        w_mps: v(Channel::Heave),
        p_dps: v(Channel::RollRate),
        q_dps: v(Channel::PitchRate),
        r_dps: v(Channel::YawRate),
    }
}
