//! The pilot core's engine: the [`StationCore`] plus everything the pilot needs around it
//! (input selection and shaping, hold-to-arm, camera, alarms, prediction, the checklist,
//! the dive log, the model watch's alerts, records). Sans-IO: see the module docs of
//! [`crate::pilot`]. Files: `commands.rs` (pilot commands), `tick.rs` (the control tick
//! in phases), `recording.rs` (a recording's state as the pilot sees it),
//! `checklist.rs`, `pad_input.rs`.

mod checklist;
mod commands;
mod pad_input;
mod recording;
mod tick;

use std::collections::VecDeque;
use std::path::PathBuf;

use firmware_proto::ControlBlock;
use rov_control::{Axis, AxisMode, ModeCommand, ModelSet, PilotInput, TickOutput};
use rov_driver::{Health, Link, LinkEvent, StatusTelemetry, Telemetry};
use rov_session::{
    AutopilotRecord, Direction, EventRecord, LinkRecord, Mode, NavRecord, ObserverRecord,
    PilotRecord, Severity, StatusRecord, ThrustRecord,
};

use crate::core::{StationCommand, StationCore};
use crate::pilot::alarms::{AlarmChange, AlarmInputs, AlarmLevel, Alarms};
use crate::pilot::dive::{
    DiveEvent, DiveLog, Item, ItemStatus, THRUSTERS, ThrusterTest, thruster_detail,
};
use crate::pilot::history::HistorySample;
use crate::pilot::pad::{Action, PadButton, PadSlot, PadState};
use crate::pilot::predict::{Anchor, Predictor};
use crate::pilot::record::RecordItem;
use crate::pilot::shaping::{ArmHold, Gain, StickShaping, to_controller};
use crate::pilot::timers::{HINT_US, LINK_RECORD_US, Timer, Timers};
use crate::pilot::view::{AxisModeView, PadStatus, Pipeline, Source, WatchAlertView, link_state};
use crate::runtime::{
    CameraCommand, ChecklistCommand, GainCommand, RuntimeCommand, RuntimeConfig, RuntimeError,
};
use rov_types::conventions::PhysicsThrust;

/// Gamepad sticks older than this (gamepad thread heartbeat) count as centred, µs.
const PAD_STALE_US: u64 = 100_000;

/// One input to the engine ([`Engine::handle`]).
#[derive(Debug)]
pub enum Input<'a> {
    /// An event of the link (telemetry, status, a state change, a frame, a failsafe).
    Link(&'a LinkEvent),
    /// A pilot command (GUI, keyboard, script). Commands for the world around the engine
    /// (recording, live serving, fault injection, stall, shutdown) come back out of
    /// [`Engine::poll_output`].
    Command(RuntimeCommand),
    /// The gamepad thread's latest state (read before each tick).
    Pad(&'a PadSlot),
    /// The watchdog's trip count (a change raises the control-stall alarm) and the
    /// commands the GUI's queue dropped.
    Counters {
        /// Watchdog trips since the start.
        watchdog_trips: u64,
        /// Commands dropped because the queue was full.
        commands_dropped: u64,
    },
    /// The model watch's new alerts and its state.
    Watch {
        /// New alerts.
        alerts: Vec<rov_lab::watch::Alert>,
        /// Its state.
        status: WatchStatus,
    },
    /// The simulated vehicle's true state (recorded as `/truth/state`).
    Truth(&'a rov_sim::TruthState),
    /// A recording started (its file is open).
    RecordingStarted(PathBuf),
    /// A recording could not start (the text says why).
    RecordingRefused(String),
    /// The running recording's progress.
    RecordingProgress(RecordingProgress),
    /// The recording stopped: its file is being saved.
    RecordingStopped,
    /// The files still being saved.
    Finishing(&'a [PathBuf]),
    /// A recording was saved (or failed).
    Saved(Saved),
    /// Whether a live Foxglove server takes the records.
    LiveServing(bool),
    /// A line for the view's event list only (not a session event).
    Note(String),
}

/// The model watch's state for the view.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct WatchStatus {
    /// Its worker runs.
    pub running: bool,
    /// Rows taken.
    pub rows: u64,
    /// Rows dropped (the worker was behind).
    pub dropped_rows: u64,
    /// Why it stopped, if it did.
    pub error: Option<String>,
}

/// A running recording's counters.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct RecordingProgress {
    /// Messages queued.
    pub messages: u64,
    /// Messages dropped (queue full).
    pub dropped: u64,
    /// The writer's error, if writing failed.
    pub error: Option<String>,
}

/// A recording saved (or failed) by its finisher.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Saved {
    /// Its file.
    pub path: PathBuf,
    /// Messages written, or why it failed.
    pub result: Result<u64, String>,
    /// The video encoder's error at the end, if any.
    pub video_error: Option<String>,
}

/// What the engine asks of the world around it ([`Engine::poll_output`]).
#[derive(Debug)]
pub enum Output {
    /// Start recording to this file.
    StartRecording(PathBuf),
    /// Start recording to a new file in this folder (the gamepad's Record button).
    StartRecordingIn(PathBuf),
    /// Stop the recording.
    StopRecording,
    /// Serve records to this live Foxglove tap (`None`: stop).
    FoxgloveLive(Option<crate::runtime::foxglove_live::LiveTap>),
    /// Give the simulated vehicle this fault.
    InjectFault(rov_sim::FaultSpec),
    /// Block the control thread for this long (fault injection for tests).
    Stall(std::time::Duration),
    /// Stop the station.
    Shutdown,
}

/// The pilot core's engine (see [`crate::pilot`]).
#[derive(Debug)]
pub struct Engine {
    /// The thrust command in force (the model watch's rows carry it), %.
    thrust_now_pct: [f64; 3],
    /// The latest change the watch found, in noise floors (the alarm's cause).
    vehicle_changed_noise: Option<f64>,
    core: StationCore,
    models: ModelSet,
    cfg: RuntimeConfig,
    pipeline: Pipeline,
    alarms: Alarms,
    predictor: Predictor,
    shaping: StickShaping,
    gain: Gain,
    /// The keyboard/GUI sticks ([`Timer::KeyboardSticks`] says until when they hold).
    keyboard: Option<PilotInput>,
    arm: ArmHold,
    arm_pad: ArmHold,
    lights_pct: u8,
    tilt_deg: i8,
    focus_pct: i8,
    /// The recording running: its station time of t = 0, µs.
    recording_started_us: Option<u64>,
    /// A live Foxglove server takes the records.
    live: bool,
    /// Records for the recorder and the live server, with their station time, µs.
    records: VecDeque<(u64, RecordItem)>,
    /// Requests for the world around the engine.
    outputs: VecDeque<Output>,
    timers: Timers,
    /// The gamepad thread's latest state (copied in before each tick).
    pad_slot: PadSlot,
    watchdog_trips: u64,
    pending: Vec<HistorySample>,
    ever_connected: bool,
    tare_sent: bool,
    last_tick_us: Option<u64>,
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
    last_record_ns: u64,
    dive: DiveLog,
    thruster_test: Option<ThrusterTest>,
    /// The thrust the test commanded last tick (ramped at 10 %/tick).
    test_pct: [f64; 3],
    last_pressure_mbar: Option<f64>,
    /// A virtual pad's last state ([`Timer::VirtualPad`] says until when it holds).
    virtual_pad: Option<PadState>,
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
    /// A new engine for `cfg` with the shipped `models`, fed from `source`.
    ///
    /// # Errors
    /// [`RuntimeError::Control`] if the controller refuses the configuration or the
    /// autopilot model.
    pub fn new(cfg: RuntimeConfig, models: ModelSet, source: Source) -> Result<Self, RuntimeError> {
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
            recording_started_us: None,
            live: false,
            records: VecDeque::new(),
            outputs: VecDeque::new(),
            timers: Timers::default(),
            pad_slot: PadSlot::default(),
            watchdog_trips: 0,
            pending: Vec::new(),
            ever_connected: false,
            tare_sent: false,
            last_tick_us: None,
            last_nav_us: None,
            last_status: None,
            watchdog_seen: 0,
            prev_modes: (Mode::Manual, Mode::Manual),
            prev_armed: false,
            overridden: (false, false),
            source_label,
            last_record_ns: 0,
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

    /// One input at `now_us` (see [`Input`]). The link is the one the engine drives
    /// (commands go out through it).
    pub fn handle(&mut self, input: Input<'_>, link: &mut Link, now_us: u64) {
        match input {
            Input::Link(ev) => self.on_link_event(link, ev, now_us),
            Input::Command(c) => self.apply(link, c, now_us),
            Input::Pad(slot) => self.pad_slot.clone_from(slot),
            Input::Counters {
                watchdog_trips,
                commands_dropped,
            } => {
                self.watchdog_trips = watchdog_trips;
                self.pipeline.view.commands_dropped = commands_dropped;
            }
            Input::Watch { alerts, status } => self.take_alerts(alerts, &status, now_us),
            Input::Truth(truth) => {
                if self.records_wanted() {
                    let rec = truth_record(truth);
                    self.record(|t| RecordItem::Truth(t, rec), now_us);
                }
            }
            Input::RecordingStarted(path) => self.recording_started(path, now_us),
            Input::RecordingRefused(why) => self.recording_refused(why, now_us),
            Input::RecordingProgress(p) => self.recording_progress(p),
            Input::RecordingStopped => self.recording_stopped(now_us),
            Input::Finishing(paths) => self.show_finishing(paths),
            Input::Saved(s) => self.saved(s, now_us),
            Input::LiveServing(on) => self.live = on,
            Input::Note(line) => self.pipeline.push_event(line),
        }
    }

    /// The next record to write (and serve live) with its station time, µs; `None` when
    /// there is none. Records are queued only while a recording runs or a live server
    /// takes them.
    pub fn poll_record(&mut self) -> Option<(u64, RecordItem)> {
        self.records.pop_front()
    }

    /// The next request for the world around the engine.
    pub fn poll_output(&mut self) -> Option<Output> {
        self.outputs.pop_front()
    }

    /// The earliest deadline of the engine's timers, µs (it acts on them on its ticks).
    #[must_use]
    pub fn poll_timeout(&self) -> Option<u64> {
        self.timers.next().map(|(_, at)| at)
    }

    /// What the GUI shows.
    #[must_use]
    pub fn view(&self) -> &crate::pilot::view::StationView {
        &self.pipeline.view
    }

    /// The view, for the runtime's own fields (tick statistics, the serial port, the
    /// thread priorities).
    pub(crate) fn view_mut(&mut self) -> &mut crate::pilot::view::StationView {
        &mut self.pipeline.view
    }

    /// The history samples since the last call's drain (one per tick).
    pub(crate) fn pending_history(&mut self) -> &mut Vec<HistorySample> {
        &mut self.pending
    }

    /// The thrust command in force, % (port, starboard, vertical): the model watch's
    /// rows carry it.
    #[must_use]
    pub fn thrust_now_pct(&self) -> [f64; 3] {
        self.thrust_now_pct
    }

    /// Whether a recording runs.
    #[must_use]
    pub fn recording(&self) -> bool {
        self.recording_started_us.is_some()
    }

    /// The configuration the engine runs with.
    #[must_use]
    pub fn config(&self) -> &RuntimeConfig {
        &self.cfg
    }

    /// The session's vehicle label (`sim`, `serial:/dev/…`).
    #[must_use]
    pub fn source_label(&self) -> &str {
        &self.source_label
    }

    fn record(&mut self, item: impl FnOnce(u64) -> RecordItem, now_us: u64) {
        if let Some(started_us) = self.recording_started_us {
            let t = now_us
                .saturating_sub(started_us)
                .saturating_mul(1000)
                .max(self.last_record_ns);
            self.last_record_ns = t;
            self.records.push_back((now_us, item(t)));
        } else if self.live {
            self.records.push_back((now_us, item(0)));
        }
    }

    /// Whether records are wanted (recording, or serving them live).
    fn records_wanted(&self) -> bool {
        self.recording_started_us.is_some() || self.live
    }

    fn hint(&mut self, text: &str, now_us: u64) {
        self.pipeline.view.hint = Some(text.to_string());
        self.timers
            .set(Timer::Hint, now_us.saturating_add(HINT_US + 1));
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

    /// The model watch is off (the settings, or its model did not load).
    pub(crate) fn set_watch_off(&mut self, reason: Option<String>) {
        self.pipeline.view.watch.off_reason = reason;
    }

    /// The model watch's alerts into the dive: an event each (in the replay index), the
    /// VEHICLE CHANGED alarm for a change, the words in the view. A mismatch is only an
    /// event and a line (the model was wrong from the start: a job for the lab, not an
    /// alarm).
    fn take_alerts(
        &mut self,
        alerts: Vec<rov_lab::watch::Alert>,
        status: &WatchStatus,
        now_us: u64,
    ) {
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
                        .reraise(crate::pilot::alarms::AlarmKind::VehicleChanged);
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
        let v = &mut self.pipeline.view.watch;
        v.running = status.running;
        v.rows = status.rows;
        v.dropped_rows = status.dropped_rows;
        if let Some(e) = &status.error {
            v.off_reason = Some(e.clone());
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

    pub(crate) fn refuse(&mut self, now_us: u64, what: &str, why: String) {
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
    fn on_link_event(&mut self, link: &mut Link, ev: &LinkEvent, now_us: u64) {
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
            LinkEvent::FrameTx { bytes, time_us } if self.recording() => {
                let b = bytes.clone();
                self.record(|t| RecordItem::Raw(Direction::Tx, t, b), *time_us);
            }
            LinkEvent::FrameRx { bytes, time_us } if self.recording() => {
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
}

/// The file name of a path (events name the file; the folder is in the settings).
pub(crate) fn file_name(path: &std::path::Path) -> String {
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
