//! The live engine: the [`StationCore`] plus everything the pilot needs around it (input
//! selection and shaping, hold-to-arm, camera, alarms, prediction, records, recording,
//! publication). Clock-free: the drivers (`live`, `sim`) pass the time in.

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
use crate::runtime::history::HistorySample;
use crate::runtime::predict::{Anchor, Predictor};
use crate::runtime::recorder::{RecordItem, Recorder};
use crate::runtime::shaping::{ArmHold, Gain, StickShaping, to_controller};
use crate::runtime::view::{AxisModeView, PadStatus, Pipeline, Source, link_state};
use crate::runtime::{
    CameraCommand, GainCommand, RuntimeCommand, RuntimeConfig, RuntimeError, Shared, lock, try_lock,
};

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
    /// Live sim mode: the vehicle thread's latest truth, for `/truth/state`.
    truth_tap: Option<rov_vehicle::runner::TruthTap>,
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
        let core = StationCore::new(cfg.control, models.clone())?;
        let source_label = match &source {
            Source::Serial(p) => format!("serial:{p}"),
            _ => "sim".to_string(),
        };
        let mut pipeline = Pipeline::new(source);
        pipeline.view.alarm_limits = cfg.alarms;
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
            truth_tap: None,
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
            cfg,
        })
    }

    fn record(&self, item: impl FnOnce(u64) -> RecordItem, now_us: u64) {
        if let Some(r) = &self.recorder {
            let t = r.t_ns(now_us).max(self.last_record_ns.get());
            self.last_record_ns.set(t);
            r.send(item(t));
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

    /// Records the simulated vehicle's truth (`/truth/state`) when a recording is running.
    /// The station's control path never reads it: truth is for the engineer comparing
    /// the estimate with reality afterwards.
    pub fn record_truth(&self, truth: &rov_sim::TruthState, now_us: u64) {
        if self.recorder.is_some() {
            let rec = truth_record(truth);
            self.record(|t| RecordItem::Truth(t, rec), now_us);
        }
    }

    fn event(&mut self, now_us: u64, kind: &str, severity: Severity, text: String) {
        let r = EventRecord {
            kind: kind.to_string(),
            severity,
            text,
        };
        self.pipeline.event(now_us as f64 * 1e-6, &r);
        self.record(|t| RecordItem::Event(t, r), now_us);
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
            LinkEvent::FrameTx { bytes, time_us } => {
                let b = bytes.clone();
                self.record(|t| RecordItem::Raw(Direction::Tx, t, b), *time_us);
            }
            LinkEvent::FrameRx { bytes, time_us } => {
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
            RuntimeCommand::StartRecording(path) => self.start_recording(&path, now_us),
            RuntimeCommand::StopRecording => self.stop_recording(now_us),
            RuntimeCommand::Replay(_) => {}
            RuntimeCommand::InjectStall(d) => return Followup::Stall(d),
            RuntimeCommand::Shutdown => return Followup::Shutdown,
        }
        Followup::None
    }

    fn start_recording(&mut self, path: &std::path::Path, now_us: u64) {
        if self.recorder.is_some() {
            self.stop_recording(now_us);
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
                self.recorder = Some(r);
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

    pub fn stop_recording(&mut self, now_us: u64) {
        let Some(r) = self.recorder.take() else {
            return;
        };
        let path = r.path().to_path_buf();
        let result = r.stop();
        let v = &mut self.pipeline.view.recording;
        v.path = None;
        v.last_file = Some(path.clone());
        match result {
            Ok(s) => {
                v.messages = s.messages;
                self.event(
                    now_us,
                    "recording",
                    Severity::Info,
                    format!(
                        "recording stopped: {} ({} messages)",
                        file_name(&path),
                        s.messages
                    ),
                );
            }
            Err(e) => {
                v.error = Some(e.clone());
                self.event(
                    now_us,
                    "recording",
                    Severity::Warning,
                    format!("recording failed: {e}"),
                );
            }
        }
    }

    fn pilot_input(&mut self, now_us: u64) -> (PilotInput, &'static str) {
        let pad = {
            let slot = lock(&self.shared.pad);
            let fresh = now_us.saturating_sub(slot.heartbeat_us) <= PAD_STALE_US;
            self.pipeline.view.pilot.pad = if fresh || matches!(slot.status, PadStatus::Off) {
                slot.status.clone()
            } else {
                PadStatus::Unavailable("gamepad thread not responding".into())
            };
            self.pipeline.view.pilot.buttons.clone_from(&slot.buttons);
            self.arm_pad.report(slot.arm_held && fresh, now_us);
            let early = self.arm_pad.take_released_early();
            if early {
                self.pipeline.view.hint = Some(ARM_HINT.to_string());
                self.hint_since_us = Some(now_us);
            }
            (slot.live && fresh).then_some(slot.sticks)
        };
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
        let (raw, input) = self.pilot_input(now_us);
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
        let dt_s = self
            .last_tick_us
            .map_or(0.0, |t| now_us.saturating_sub(t) as f64 * 1e-6);
        self.last_tick_us = Some(now_us);

        // Records: thrust, pilot, autopilot, observer (and link stats every 0.5 s).
        let c = out.command;
        let cmd = *link.command();
        let thrust = ThrustRecord {
            port_pct: c.port_pct(),
            starboard_pct: c.starboard_pct(),
            vertical_pct: c.vertical_pct(),
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
            buttons: self.pipeline.view.pilot.buttons.clone(),
        };
        let ctl = self.core.controller();
        let ds = ctl.axis_state(Axis::Depth);
        let hs = ctl.axis_state(Axis::Heading);
        let auto = AutopilotRecord {
            depth_mode: axis_mode(ds.mode),
            heading_mode: axis_mode(hs.mode),
            depth_setpoint_m: ctl.depth_setpoint_m(),
            heading_setpoint_deg: ctl.heading_setpoint_deg(),
            feedforward_model: if ctl.feedforward_enabled() {
                ctl.model().name().to_string()
            } else {
                String::new()
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
        self.record(|t| RecordItem::Autopilot(t, auto), now_us);
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
        let model = self.models.get(model_choice);
        self.pipeline.view.prediction = self.predictor.step(
            model,
            t_s,
            dt_s,
            &anchor,
            [c.port_pct(), c.starboard_pct(), c.vertical_pct()],
        );

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
        v.pilot.input = input.to_string();
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

    /// Finishes a recording (shutdown).
    pub fn finish(&mut self, now_us: u64) {
        self.stop_recording(now_us);
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
