//! The live engine: the [`StationCore`] plus everything the pilot needs around it (input
//! selection and shaping, hold-to-arm, camera, alarms, prediction, records, recording,
//! publication). Clock-free: the drivers (`live`, `sim`) pass the time in.

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
use crate::runtime::view::{AxisModeView, PadStatus, Pipeline, Source, link_state};
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
        Ok(Self {
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
            RuntimeCommand::Shutdown => return Followup::Shutdown,
        }
        Followup::None
    }

    fn start_recording(&mut self, path: &std::path::Path, now_us: u64) {
        if self.recorder.is_some() {
            self.stop_recording(now_us);
        }
        if self.finishers.is_finishing(path) {
            let e = format!(
                "{} is still being saved from the last recording; record to another file",
                file_name(path)
            );
            self.pipeline.view.recording.error = Some(e.clone());
            self.event(
                now_us,
                "recording",
                Severity::Warning,
                format!("cannot record: {e}"),
            );
            return;
        }
        let info = SessionInfo {
            vehicle: self.source_label.clone(),
            software_version: env!("CARGO_PKG_VERSION").to_string(),
            started_unix_s: std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0.0, |d| d.as_secs_f64()),
            config_toml: self.cfg.config_toml.clone(),
        };
        match Recorder::start(path, &info, now_us, self.cfg.record_blocking) {
            Ok(r) => {
                self.last_record_ns.set(0);
                let video = self
                    .video
                    .as_ref()
                    .map(|v| v.begin_recording(r.video_tap().with_live(self.live.clone())));
                self.recorder = Some(r);
                if let Some(Err(e)) = video {
                    self.event(
                        now_us,
                        "recording",
                        Severity::Warning,
                        format!("recording without video: {e}"),
                    );
                }
                let v = &mut self.pipeline.view.recording;
                v.path = Some(path.to_path_buf());
                v.error = None;
                self.event(
                    now_us,
                    "recording",
                    Severity::Info,
                    format!("recording to {}", file_name(path)),
                );
            }
            Err(e) => {
                self.pipeline.view.recording.error = Some(e.clone());
                self.event(
                    now_us,
                    "recording",
                    Severity::Warning,
                    format!("cannot record: {e}"),
                );
            }
        }
    }

    /// Stops the recording: its encoder and writer are handed to a finisher thread (the
    /// encoder's last units, the summary and the sync take up to seconds the control
    /// loop must not spend); the view lists the file as being saved until it is. On
    /// virtual time (`record_blocking`) the file is finished before this returns.
    pub fn stop_recording(&mut self, now_us: u64) {
        let Some(r) = self.recorder.take() else {
            return;
        };
        let path = r.path().to_path_buf();
        let encoder = self.video.as_ref().and_then(|v| v.detach_recording());
        self.finishers.start(r, encoder);
        let v = &mut self.pipeline.view.recording;
        v.path = None;
        v.elapsed_s = 0.0;
        self.event(
            now_us,
            "recording",
            Severity::Info,
            format!("recording stopped: {}, saving", file_name(&path)),
        );
        if self.cfg.record_blocking {
            // Virtual time: no real-time loop to protect, and the run's next step may
            // read the file.
            self.wait_for_finishers(EXIT_WAIT, now_us);
        } else {
            self.show_finishing();
        }
    }

    /// The files being saved, in the view (changed only when the list changes).
    fn show_finishing(&mut self) {
        let v = &mut self.pipeline.view.recording.finishing;
        if !v.iter().map(PathBuf::as_path).eq(self.finishers.paths()) {
            *v = self.finishers.paths().map(Path::to_path_buf).collect();
        }
    }

    /// Takes in the recordings saved since the last call (each tick; never waits).
    fn poll_finishers(&mut self, now_us: u64) {
        if self.finishers.is_empty() {
            return;
        }
        let mut done = Vec::new();
        self.finishers.poll(|f| done.push(f));
        for f in done {
            self.saved(f, now_us);
        }
        self.show_finishing();
    }

    /// Waits for every recording being saved, at most `limit` in all.
    fn wait_for_finishers(&mut self, limit: std::time::Duration, now_us: u64) {
        let mut done = Vec::new();
        let left = self.finishers.wait_all(limit, |f| done.push(f));
        for f in done {
            self.saved(f, now_us);
        }
        for p in left {
            let e = format!(
                "{} was not finished within {} s; open it to recover what was written",
                file_name(&p),
                limit.as_secs()
            );
            self.pipeline.view.recording.error = Some(e.clone());
            self.event(now_us, "recording", Severity::Warning, e);
        }
        self.show_finishing();
    }

    /// A recording is saved (or failed): the view and the events say so.
    fn saved(&mut self, f: Finished, now_us: u64) {
        let name = file_name(&f.path);
        if let Some(e) = f.video_error {
            self.event(
                now_us,
                "recording",
                Severity::Warning,
                format!("video recording of {name} ended with an error: {e}"),
            );
        }
        let recording = self.recorder.is_some();
        let v = &mut self.pipeline.view.recording;
        match f.result {
            Ok(s) => {
                v.last_file = Some(f.path);
                if !recording {
                    v.messages = s.messages;
                }
                self.event(
                    now_us,
                    "recording",
                    Severity::Info,
                    format!("recording saved: {name} ({} messages)", s.messages),
                );
            }
            Err(e) => {
                v.error = Some(format!("{name}: {e}"));
                self.event(
                    now_us,
                    "recording",
                    Severity::Warning,
                    format!("recording failed: {name}: {e}"),
                );
            }
        }
    }

    /// "at 12.3 m, heading 090°, dive 03:12" for notes and markers.
    fn where_now(&self) -> String {
        let s = &self.pipeline.view.snapshot;
        let d = s
            .depth_m
            .map_or_else(|| "depth ---".into(), |d| format!("at {d:.1} m"));
        let h = s.heading_deg.map_or_else(
            || "heading ---".into(),
            |h| format!("heading {:03.0}°", h.rem_euclid(360.0)),
        );
        let t = self.dive.view().dive_s as u64;
        format!("{d}, {h}, dive {:02}:{:02}", t / 60, t % 60)
    }

    fn set_item(&mut self, item: Item, status: ItemStatus, detail: String) {
        if let Some(i) = self.pipeline.view.checklist.item_mut(item) {
            i.status = status;
            i.detail = detail;
        }
    }

    fn checklist(&mut self, link: &mut Link, c: ChecklistCommand, now_us: u64) {
        let t_s = now_us as f64 * 1e-6;
        match c {
            ChecklistCommand::CompassOk | ChecklistCommand::CompassBad => {
                let h = self.pipeline.view.snapshot.heading_deg;
                let hs = h.map_or_else(
                    || "---".into(),
                    |h| format!("{:03.0}°", h.rem_euclid(360.0)),
                );
                let (st, d) = match (c, h) {
                    (_, None) => (ItemStatus::Fail, "no heading from the vehicle".to_string()),
                    (ChecklistCommand::CompassOk, Some(_)) => (
                        ItemStatus::Pass,
                        format!("heading {hs} matches the known bearing"),
                    ),
                    _ => (ItemStatus::Fail, format!("heading {hs} does not match")),
                };
                self.set_item(Item::Compass, st, d);
            }
            ChecklistCommand::ZeroDepth => {
                let depth = self.pipeline.view.snapshot.depth_m;
                match (self.last_pressure_mbar, depth) {
                    (Some(p), Some(d)) if d.abs() < 2.0 => {
                        let was = link.config().conventions.surface_pressure_mbar;
                        link.set_surface_pressure_mbar(p);
                        let cmd =
                            StationCommand::Mode(ModeCommand::SetSurfaceTare { pressure_mbar: p });
                        let _ = self.core.command(link, cmd, now_us);
                        let text = format!(
                            "depth zeroed: surface pressure {p:.0} mbar (was {was:.0}; depth read {d:+.2} m)"
                        );
                        self.event(now_us, "depth_zero", Severity::Info, text.clone());
                        self.set_item(Item::DepthZero, ItemStatus::Pass, text);
                    }
                    (_, Some(d)) => self.set_item(
                        Item::DepthZero,
                        ItemStatus::Fail,
                        format!("not at the surface ({d:.1} m): zero at the surface"),
                    ),
                    _ => self.set_item(
                        Item::DepthZero,
                        ItemStatus::Fail,
                        "no pressure reading".into(),
                    ),
                }
            }
            ChecklistCommand::StartThrusterTest => {
                if !link.failsafe().is_armed() {
                    self.set_item(
                        Item::Thrusters,
                        ItemStatus::Fail,
                        "arm first (the test drives each thruster for 1 s)".into(),
                    );
                    return;
                }
                // Holds off: the test commands the thrusters itself.
                for axis in [Axis::Depth, Axis::Heading] {
                    if self.core.holding(axis) {
                        let m = StationCommand::Mode(ModeCommand::Disengage(axis));
                        let _ = self.core.command(link, m, now_us);
                    }
                }
                let idle = self.last_status.map(|s| s.rail_12v_a);
                let mut test = ThrusterTest {
                    started_s: t_s,
                    ..ThrusterTest::default()
                };
                for r in &mut test.results {
                    r.idle_a = idle;
                }
                self.thruster_test = Some(test);
                self.test_pct = [0.0; 3];
                self.set_item(Item::Thrusters, ItemStatus::Running, "running".into());
                self.event(
                    now_us,
                    "checklist",
                    Severity::Info,
                    "thruster test started".into(),
                );
            }
            ChecklistCommand::AbortThrusterTest => {
                self.end_thruster_test(now_us, Some("stopped by the pilot"))
            }
            ChecklistCommand::Record => self.record_checklist(now_us),
        }
    }

    fn record_checklist(&mut self, now_us: u64) {
        let c = &self.pipeline.view.checklist;
        let all = c.passed() == Item::ALL.len();
        let text = c.summary();
        self.pipeline.view.checklist.recorded = true;
        let sev = if all {
            Severity::Info
        } else {
            Severity::Warning
        };
        self.event(now_us, "checklist", sev, text);
    }

    fn end_thruster_test(&mut self, now_us: u64, aborted: Option<&str>) {
        let Some(test) = self.thruster_test.take() else {
            return;
        };
        self.test_pct = [0.0; 3];
        self.pipeline.view.checklist.test_running = None;
        self.pipeline.view.checklist.thrusters = test.results;
        let detail = thruster_detail(&test.results);
        let (st, text) = match aborted {
            Some(why) => (ItemStatus::Fail, format!("aborted ({why}); {detail}")),
            None => {
                let dead: Vec<&str> = THRUSTERS
                    .iter()
                    .zip(&test.results)
                    .filter(|(_, r)| !r.drew_current())
                    .map(|(n, _)| *n)
                    .collect();
                if dead.is_empty() {
                    (ItemStatus::Pass, detail)
                } else {
                    (
                        ItemStatus::Fail,
                        format!("no current rise on {}; {detail}", dead.join(", ")),
                    )
                }
            }
        };
        self.event(
            now_us,
            "checklist",
            Severity::Info,
            format!("thruster test: {text}"),
        );
        self.set_item(Item::Thrusters, st, text);
    }

    /// The thruster test's command for this tick (after the controller's), or None.
    fn thruster_test_tick(
        &mut self,
        link: &mut Link,
        raw: &PilotInput,
        now_us: u64,
    ) -> Option<[f64; 3]> {
        let test = self.thruster_test?;
        let t_s = now_us as f64 * 1e-6;
        let abort = if !link.failsafe().is_armed() {
            Some("disarmed")
        } else if link.health() == Health::Lost {
            Some("link lost")
        } else if raw.surge.abs() > 0.2 || raw.yaw.abs() > 0.2 || raw.vertical.abs() > 0.2 {
            Some("stick moved")
        } else {
            None
        };
        if abort.is_some() {
            self.end_thruster_test(now_us, abort);
            return None;
        }
        let Some((target, running)) = test.command(t_s) else {
            self.end_thruster_test(now_us, None);
            return None;
        };
        // Ramp at the output guard's default rate (10 % a tick).
        for (p, t) in self.test_pct.iter_mut().zip(target) {
            *p += (t - *p).clamp(-10.0, 10.0);
        }
        let pct = self.test_pct;
        link.set_thrust(&PhysicsThrust {
            port_pct: pct[0],
            starboard_pct: pct[1],
            vertical_pct: pct[2],
        });
        let current = self.last_status.map(|s| s.rail_12v_a);
        if let Some(t) = self.thruster_test.as_mut()
            && let Some(i) = running
            && let Some(r) = t.results.get_mut(i)
        {
            r.commanded_pct = r.commanded_pct.max(pct.get(i).copied().unwrap_or(0.0));
            if let Some(a) = current {
                r.peak_a = Some(r.peak_a.map_or(a, |p: f64| p.max(a)));
            }
        }
        if let Some(t) = &self.thruster_test {
            self.pipeline.view.checklist.thrusters = t.results;
        }
        self.pipeline.view.checklist.test_running = Some(running);
        Some(pct)
    }

    /// The items the station checks by itself: leak and recording.
    fn auto_items(&mut self) {
        if self.pipeline.view.checklist.recorded {
            return;
        }
        let lim = self.alarms.config();
        let h = self.pipeline.view.health.humidity_pct;
        let rate = self.alarms.humidity_rate_pct_per_min();
        // Only when something shown changes (no text formatted per tick).
        let key = (
            u8::from(h.is_some()) + 2 * u8::from(rate.is_some()),
            h.map_or(0, |h| (h * 10.0).round() as i64),
            rate.map_or(0, |r| (r * 10.0).round() as i64),
            self.pipeline.view.recording.path.is_some(),
        );
        if self.auto_key == Some(key) {
            return;
        }
        self.auto_key = Some(key);
        let (st, d) = match h {
            None => (
                ItemStatus::Pending,
                "waiting for the humidity reading".to_string(),
            ),
            Some(h) if h >= lim.humidity_pct.warn => (
                ItemStatus::Fail,
                format!(
                    "humidity {h:.1} % at or above {:.0} %",
                    lim.humidity_pct.warn
                ),
            ),
            Some(h) => match rate {
                Some(r) if r >= lim.humidity_rise_pct_per_min.warn => (
                    ItemStatus::Fail,
                    format!("humidity {h:.1} % rising {r:+.1} %/min"),
                ),
                Some(r) => (
                    ItemStatus::Pass,
                    format!("humidity {h:.1} %, {r:+.1} %/min"),
                ),
                None => (
                    ItemStatus::Pass,
                    format!("humidity {h:.1} % (rate after 10 s)"),
                ),
            },
        };
        self.set_item(Item::Leak, st, d);
        let rec = match &self.pipeline.view.recording.path {
            Some(p) => (
                ItemStatus::Pass,
                p.file_name()
                    .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
            ),
            None => (ItemStatus::Fail, "not recording".to_string()),
        };
        self.set_item(Item::Recording, rec.0, rec.1);
    }

    /// The pad this tick: the gamepad thread's, or a virtual pad's (tests), mapped with
    /// the pilot's map. Buttons act on their press (the shift layer while the shift
    /// button is held); the arm button is timed like the GUI's.
    fn pad_input(&mut self, link: &mut Link, now_us: u64) -> Option<PilotInput> {
        let (state, raw, live) = {
            let slot = lock(&self.shared.pad);
            let fresh = now_us.saturating_sub(slot.heartbeat_us) <= PAD_STALE_US;
            match self.virtual_pad {
                Some((st, t)) if now_us.saturating_sub(t) <= self.cfg.keyboard_timeout_us => {
                    if !self.virtual_centred && virtual_centred(&st) {
                        self.virtual_centred = true;
                    }
                    let live = self.virtual_centred;
                    let status = if live {
                        PadStatus::Connected("virtual pad".into())
                    } else {
                        PadStatus::WaitingForCentre("virtual pad".into())
                    };
                    if self.pipeline.view.pilot.pad != status {
                        self.pipeline.view.pilot.pad = status;
                    }
                    (if live { st } else { PadState::default() }, st, live)
                }
                _ => {
                    if self.virtual_pad.take().is_some() {
                        self.virtual_centred = false;
                    }
                    let status = if fresh || matches!(slot.status, PadStatus::Off) {
                        &slot.status
                    } else {
                        &STALE_PAD
                    };
                    if self.pipeline.view.pilot.pad != *status {
                        self.pipeline.view.pilot.pad = status.clone();
                    }
                    let live = slot.live && fresh;
                    (
                        if live {
                            slot.state
                        } else {
                            PadState::default()
                        },
                        if fresh { slot.raw } else { PadState::default() },
                        live,
                    )
                }
            }
        };
        self.pipeline.view.pilot.pad_raw = raw;
        let map = &self.cfg.pad_map;
        let shift = map.shift.is_some_and(|b| state.held(b));
        self.pipeline.view.pilot.shift = shift;
        // Arm: held (in the current layer) and timed by the runtime.
        let arm_held = PadButton::ALL
            .iter()
            .any(|b| state.held(*b) && map.action(*b, shift) == Some(Action::Arm));
        self.arm_pad.report(arm_held, now_us);
        if self.arm_pad.take_released_early() {
            self.hint(ARM_HINT, now_us);
        }
        let pressed = state.buttons & !self.pad_buttons;
        self.pad_buttons = state.buttons;
        if pressed != 0 {
            let actions: Vec<Action> = PadButton::ALL
                .iter()
                .filter(|b| pressed & b.bit() != 0)
                .filter_map(|b| self.cfg.pad_map.action(*b, shift))
                .collect();
            for a in actions {
                self.pad_action(link, a, now_us);
            }
        }
        live.then(|| PilotInput {
            surge: state.axis(self.cfg.pad_map.surge),
            yaw: state.axis(self.cfg.pad_map.yaw),
            // Stick up rises; positive vertical dives.
            vertical: -state.axis(self.cfg.pad_map.vertical),
        })
    }

    /// A gamepad button's function.
    fn pad_action(&mut self, link: &mut Link, a: Action, now_us: u64) {
        let cmd = match a {
            Action::Arm => return, // timed in pad_input
            Action::Disarm => RuntimeCommand::Station(StationCommand::Disarm),
            Action::DepthHold => RuntimeCommand::ToggleHold(Axis::Depth),
            Action::HeadingHold => RuntimeCommand::ToggleHold(Axis::Heading),
            Action::GainUp => RuntimeCommand::Gain(GainCommand::Up),
            Action::GainDown => RuntimeCommand::Gain(GainCommand::Down),
            Action::LightsUp => {
                RuntimeCommand::Camera(CameraCommand::Lights(f64::from(self.lights_pct) + 10.0))
            }
            Action::LightsDown => {
                RuntimeCommand::Camera(CameraCommand::Lights(f64::from(self.lights_pct) - 10.0))
            }
            Action::TiltUp => {
                RuntimeCommand::Camera(CameraCommand::Tilt(f64::from(self.tilt_deg) + 10.0))
            }
            Action::TiltDown => {
                RuntimeCommand::Camera(CameraCommand::Tilt(f64::from(self.tilt_deg) - 10.0))
            }
            Action::TiltCentre => RuntimeCommand::Camera(CameraCommand::Tilt(0.0)),
            Action::Record => {
                if self.recorder.is_some() {
                    RuntimeCommand::StopRecording
                } else if let Some(dir) = self.cfg.recordings_dir.clone() {
                    RuntimeCommand::StartRecording(crate::runtime::recording_path_in(&dir))
                } else {
                    return;
                }
            }
            Action::Marker => RuntimeCommand::Marker,
            Action::AckAlarms => RuntimeCommand::AckAlarm(None),
            Action::ResetTurns => RuntimeCommand::ResetTurns,
        };
        let _ = self.apply(link, cmd, now_us);
    }

    fn pilot_input(&mut self, link: &mut Link, now_us: u64) -> (PilotInput, &'static str) {
        let pad = self.pad_input(link, now_us);
        let kb = self
            .keyboard
            .filter(|(_, t)| now_us.saturating_sub(*t) <= self.cfg.keyboard_timeout_us)
            .map(|(p, _)| p);
        let pick = |a: f64, b: f64| if b.abs() > a.abs() { b } else { a };
        match (pad, kb) {
            (Some(p), Some(k)) => (
                PilotInput {
                    surge: pick(p.surge, k.surge),
                    yaw: pick(p.yaw, k.yaw),
                    vertical: pick(p.vertical, k.vertical),
                },
                "gamepad+keyboard",
            ),
            (Some(p), None) => (p, "gamepad"),
            (None, Some(k)) => (k, "keyboard"),
            (None, None) => (PilotInput::default(), "none"),
        }
    }

    /// One control tick at `now_us`.
    pub fn tick(&mut self, link: &mut Link, now_us: u64) -> TickOutput {
        let t_s = now_us as f64 * 1e-6;
        // Arming by holding a button.
        let (raw, input) = self.pilot_input(link, now_us);
        let arm_gui = self.arm.poll(now_us);
        let arm_pad = self.arm_pad.poll(now_us);
        if (arm_gui || arm_pad) && !link.failsafe().is_armed() {
            match self.core.command(link, StationCommand::Arm, now_us) {
                Ok(()) => self.pipeline.view.last_refusal = None,
                Err(e) => self.refuse(now_us, "Arm", e.to_string()),
            }
        }
        // Sticks: shaped, gain, mapped onto the controller's deadband.
        let shaped = self.shaping.apply(&raw);
        let to_ctl = to_controller(&shaped, self.gain, &self.cfg.control);
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
