//! The real-time station runtime: the link, the transport and the [`StationCore`] on
//! their own threads, ticking on deadlines, independent of any GUI frame.
//!
//! # Threads ([`Runtime::start`])
//!
//! * `station-control`: owns the [`Link`](rov_driver::Link) and the `host`: the pilot
//!   core's [`Engine`](crate::pilot::Engine) (sans-IO: the [`StationCore`], alarms,
//!   checklist, records) with the recorder, finishers, camera, live tap and model watch
//!   around it. It waits for bytes or the next deadline (the control tick, at 50 Hz by default,
//!   scheduled as `t₀ + k·P`, so sleeping never accumulates drift, or the link's next
//!   timeout), feeds the link, runs the tick, applies pilot commands, and publishes a
//!   [`StationView`] and one history sample per tick.
//! * `station-rx` / `station-tx`: move bytes between the transport and the control
//!   thread (blocking I/O never runs on the control thread). On a serial port they
//!   also re-open a port that vanished (an unplugged USB adapter), see [`reconnect`].
//! * `station-watchdog`: if no control tick completes within three periods it sends a
//!   neutral control frame through the tx thread every period until ticks resume, and the
//!   runtime raises [`AlarmKind::ControlStall`] (style G2). The frame zeroes thrust and
//!   both autopilots but keeps the lights and camera of the last frame sent, so a stalled
//!   station does not leave the pilot in the dark.
//! * `station-vehicle` (sim mode): the simulated Pro 4 (`rov_vehicle::runner`) on the other
//!   end of an in-memory transport, on wall time, so sim and serial share every line of
//!   the station's code.
//! * `station-gamepad` (feature `gamepad`): gilrs with hotplug; see [`gamepad`].
//! * `station-recorder` while recording; see [`recorder`].
//! * `station-foxglove-feed` and the `station-foxglove` tokio runtime while the live
//!   Foxglove server runs (it outlives a station); see [`foxglove_live`].
//!
//! The GUI talks to all of this through a [`StationHandle`]: latest-value reads (a lock
//! held only for a copy), a bounded command queue (overflow counted), and a history feed
//! it pulls from. A GUI that stalls delays none of the above.
//!
//! # Deterministic variants
//!
//! [`VirtualStation`] runs the same host and engine on virtual time through
//! `rov_station::SimLink`, stepped by the caller (GUI tests, benchmarks);
//! [`Runtime::replay`] / [`VirtualReplay`] play a recorded session through the same view
//! pipeline.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError, sync_channel};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::Duration;

use rov_control::{Axis, ControlConfig, ModelSet};
use rov_driver::{LinkConfig, MonoClock};

use crate::core::{Snapshot, StationCommand};

pub use crate::pilot::{alarms, dive, history, pad, predict, shaping, timing, view};
pub mod finisher;
pub mod foxglove_live;
#[cfg(feature = "gamepad")]
pub mod gamepad;
mod host;
mod live;
pub mod priority;
pub mod reconnect;
pub mod recorder;
pub mod replay;
pub mod settings;
mod sim;
pub mod video;
pub mod video_replay;
pub mod watch;

#[cfg(test)]
mod tests;

pub use alarms::{AlarmConfig, AlarmKind, AlarmLevel, AlarmState, Limit};
pub use history::{Channel, History, HistorySample, decimate_min_max};
pub use reconnect::{PortLister, PortView, ReconnectSettings};
pub use replay::VirtualReplay;
/// A fault of the simulated vehicle (`--fault` grammar; the GUI's fault form builds one
/// through [`FaultSpec::parse`]).
pub use rov_sim::FaultSpec;
pub use rov_vehicle::FaultConfig as SimFaults;
pub use shaping::{AxisShaping, GAIN_STEPS_PCT, Gain, StickShaping};
pub use sim::VirtualStation;
#[cfg(test)]
pub(crate) use sim::sim_vehicle;
pub use timing::TickStats;
pub use view::{
    AxisModeView, AxisView, CameraView, HealthView, IndexedEvent, LinkView, PadStatus, PilotView,
    Quality, RecordingView, ReplayView, STALE_AFTER_S, Source, StaleView, StationView,
};

/// How to reach the vehicle.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum Connection {
    /// The simulated Pro 4, in-process.
    #[default]
    Sim,
    /// A real Pro 4 on a serial port (115200 8N1). A port that vanishes is looked for
    /// again (see [`reconnect`] and [`RuntimeConfig::reconnect`]).
    Serial(String),
}

/// Runtime settings.
#[derive(Debug, Clone)]
pub struct RuntimeConfig {
    /// The vehicle.
    pub connection: Connection,
    /// The controller's configuration (its `rate_hz` is the tick rate).
    pub control: ControlConfig,
    /// The configuration text stored in recordings.
    pub config_toml: String,
    /// The link's configuration (frame recording is switched on by the runtime).
    pub link: LinkConfig,
    /// Stick shaping.
    pub shaping: StickShaping,
    /// The gamepad map.
    pub pad_map: pad::PadMap,
    /// Where the gamepad's Record button records (None: the button does nothing).
    pub recordings_dir: Option<PathBuf>,
    /// Initial gain step (index into [`GAIN_STEPS_PCT`]).
    pub gain_index: usize,
    /// Alarm thresholds.
    pub alarms: AlarmConfig,
    /// Poll a gamepad (gilrs; needs the `gamepad` feature).
    pub gamepad: bool,
    /// Seed of the simulated vehicle's sensor noise.
    pub sim_seed: u64,
    /// Faults the simulated vehicle injects on its link (none by default: a clean
    /// link; for training and tests).
    pub sim_faults: rov_vehicle::FaultConfig,
    /// Faults the simulated vehicle itself suffers (issue 23: thrust loss, buoyancy, drag,
    /// snag, depth sensor, compass), each from its own time on the simulator's clock
    /// (`--fault SPEC`); none by default.
    pub vehicle_faults: Vec<rov_sim::FaultSpec>,
    /// The model watch's model (`--model FILE.toml`'s lab model); `None`: the shipped
    /// base model the autopilot uses (`control.feedforward_model`).
    pub watch_model: Option<rov_lab::LabModel>,
    /// Run the model watch (on by default).
    pub watch: bool,
    /// Keyboard sticks older than this count as released, µs.
    pub keyboard_timeout_us: u64,
    /// Recording waits for the writer instead of dropping messages when its queue is
    /// full. Off for live dives (the control loop must never wait on the disk); on for
    /// virtual-time runs, which have no real-time loop to protect
    /// ([`VirtualStation`] switches it on).
    pub record_blocking: bool,
    /// Re-connection of a serial port that vanished (backoff, by-id names, scanning).
    pub reconnect: ReconnectSettings,
    /// The camera (`[video]`, `--video`); none by default.
    pub video: video::VideoSettings,
    /// The simulated vehicle's dynamics (`--vehicle FILE.toml`: any model, effects
    /// included, behind the same wire protocol and sensors); `None`: model3 as shipped.
    pub sim_vehicle: Option<crate::hold::VehicleDynamics>,
    /// The autopilot's model when it is not one of the shipped set (`--model FILE.toml`,
    /// `[autopilot] model`): set before the first tick; `None`: `control.feedforward_model`.
    pub autopilot_model: Option<crate::hold::AutopilotModel>,
}

impl Default for RuntimeConfig {
    fn default() -> Self {
        Self {
            connection: Connection::Sim,
            control: ControlConfig::default(),
            config_toml: String::new(),
            link: LinkConfig::default(),
            shaping: StickShaping::default(),
            pad_map: pad::PadMap::default(),
            recordings_dir: None,
            gain_index: Gain::default().index(),
            alarms: AlarmConfig::default(),
            gamepad: true,
            sim_seed: 1,
            sim_faults: rov_vehicle::FaultConfig::none(),
            vehicle_faults: Vec::new(),
            watch_model: None,
            watch: true,
            keyboard_timeout_us: 300_000,
            record_blocking: false,
            reconnect: ReconnectSettings::default(),
            video: video::VideoSettings::none(),
            sim_vehicle: None,
            autopilot_model: None,
        }
    }
}

impl RuntimeConfig {
    /// The control period, µs.
    #[must_use]
    pub fn period_us(&self) -> u64 {
        let hz = if self.control.rate_hz.is_finite() && self.control.rate_hz >= 1.0 {
            self.control.rate_hz.min(1000.0)
        } else {
            50.0
        };
        (1e6 / hz).round() as u64
    }
}

/// Gain changes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GainCommand {
    /// One step up.
    Up,
    /// One step down.
    Down,
    /// A given step.
    Set(usize),
}

/// Lights and camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CameraCommand {
    /// Lights, % (0..100).
    Lights(f64),
    /// Camera tilt, degrees (−90..90).
    Tilt(f64),
    /// Focus, % (−100..100).
    Focus(f64),
}

/// Pre-dive checklist actions (see [`dive`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ChecklistCommand {
    /// The heading shown matches a known bearing.
    CompassOk,
    /// It does not.
    CompassBad,
    /// Zero the depth here (at the surface): the pressure now becomes the surface
    /// pressure.
    ZeroDepth,
    /// Run the thruster test (armed; the GUI asks the pilot to confirm first).
    StartThrusterTest,
    /// Stop the thruster test.
    AbortThrusterTest,
    /// Record the checklist's result in the session now.
    Record,
}

/// Replay controls.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ReplayCommand {
    /// Play.
    Play,
    /// Pause.
    Pause,
    /// Play/pause.
    Toggle,
    /// Speed, × (clamped to 0.1–50).
    Speed(f64),
    /// Seek to s since the session start.
    Seek(f64),
    /// One control tick forward (pauses).
    Step,
    /// One control tick back (pauses).
    StepBack,
}

/// Everything the GUI (or a script) can ask of the runtime.
#[derive(Debug, Clone, PartialEq)]
pub enum RuntimeCommand {
    /// A station command. `Sticks` are keyboard/GUI sticks: a stream that must be
    /// refreshed (older than [`RuntimeConfig::keyboard_timeout_us`] → centred).
    Station(StationCommand),
    /// The arm button is held (`true`) or released: arms after about 1 s of holding,
    /// reported at least every 250 ms.
    ArmButton(bool),
    /// Toggle a hold on an axis (engage holding the current value, or back to manual).
    ToggleHold(Axis),
    /// Gain step.
    Gain(GainCommand),
    /// Lights and camera.
    Camera(CameraCommand),
    /// New stick shaping.
    Shaping(StickShaping),
    /// Acknowledge an alarm (`None`: all).
    AckAlarm(Option<AlarmKind>),
    /// New alarm limits (the pilot's settings).
    AlarmLimits(AlarmConfig),
    /// A note for the dive log (recorded as an event).
    Note(String),
    /// A marker in the dive log (recorded as an event with the depth and heading).
    Marker,
    /// A pre-dive checklist action.
    Checklist(ChecklistCommand),
    /// Zero the tether turns counter.
    ResetTurns,
    /// Start recording to a file.
    StartRecording(PathBuf),
    /// Stop recording.
    StopRecording,
    /// Serve the station's records to a live Foxglove server through this tap (`None`:
    /// stop serving); see [`foxglove_live`].
    FoxgloveLive(Option<foxglove_live::LiveTap>),
    /// Replay controls (replay sources only).
    Replay(ReplayCommand),
    /// A new gamepad map (axes, buttons, shift layer).
    PadMap(pad::PadMap),
    /// A virtual gamepad's raw state (tests and other input devices): mapped exactly
    /// like a real pad's, and stale after [`RuntimeConfig::keyboard_timeout_us`].
    PadInput(pad::PadState),
    /// Use this model for the autopilot (feedforward, observer, feedback inversion);
    /// `None`: back to `control.feedforward_model` of the shipped set. Refused while the
    /// vehicle is armed unless `confirmed` (the GUI's hold-to-confirm); a plant that does
    /// not validate is refused too, and the autopilot keeps its previous model (the
    /// refusal is an event and `StationView::last_refusal`).
    AutopilotModel {
        /// The model (None: the configured shipped one).
        model: Option<Box<crate::hold::AutopilotModel>>,
        /// The pilot confirmed the change while armed.
        confirmed: bool,
    },
    /// Fault injection for tests: block the control thread for this long.
    InjectStall(Duration),
    /// A fault the simulated vehicle suffers (issue 23, training): its start time
    /// counts from when the vehicle takes it (`@0`: at once). Refused with a real
    /// vehicle.
    InjectFault(rov_sim::FaultSpec),
    /// Stop the runtime.
    Shutdown,
}

impl RuntimeCommand {
    /// The command's name (its variant), for the control thread's slow-command warning.
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            Self::Station(_) => "Station",
            Self::ArmButton(_) => "ArmButton",
            Self::ToggleHold(_) => "ToggleHold",
            Self::Gain(_) => "Gain",
            Self::Camera(_) => "Camera",
            Self::Shaping(_) => "Shaping",
            Self::AckAlarm(_) => "AckAlarm",
            Self::AlarmLimits(_) => "AlarmLimits",
            Self::Note(_) => "Note",
            Self::Marker => "Marker",
            Self::Checklist(_) => "Checklist",
            Self::ResetTurns => "ResetTurns",
            Self::StartRecording(_) => "StartRecording",
            Self::StopRecording => "StopRecording",
            Self::FoxgloveLive(_) => "FoxgloveLive",
            Self::Replay(_) => "Replay",
            Self::PadMap(_) => "PadMap",
            Self::PadInput(_) => "PadInput",
            Self::AutopilotModel { .. } => "AutopilotModel",
            Self::InjectStall(_) => "InjectStall",
            Self::InjectFault(_) => "InjectFault",
            Self::Shutdown => "Shutdown",
        }
    }
}

/// Why the runtime could not start.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RuntimeError {
    /// The controller refused its configuration.
    #[error("control: {0}")]
    Control(#[from] rov_control::ControlError),
    /// The link refused its configuration.
    #[error("link: {0}")]
    Link(#[from] rov_driver::ConfigError),
    /// The transport failed.
    #[error("transport: {0}")]
    Transport(#[from] rov_driver::TransportError),
    /// The simulated vehicle failed.
    #[error("vehicle: {0}")]
    Vehicle(#[from] rov_vehicle::VehicleError),
    /// A model file failed to load.
    #[error("model: {0}")]
    Model(#[from] rov_types::ConfigError),
    /// A session file failed to open.
    #[error("session: {0}")]
    Session(#[from] rov_session::SessionError),
    /// A thread could not be started.
    #[error("cannot start a thread ({name}): {source}")]
    Thread {
        /// The thread's name.
        name: String,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// The simulated vehicle's thread ended before handing over its runner.
    #[error("cannot start a thread: the simulated vehicle did not start")]
    VehicleDidNotStart,
}

/// A fresh recording file in `dir`: `session-<unix time>.mcap` (one naming rule for the
/// REC button, the gamepad and `topside`). The recorder makes the folder when it starts
/// (and says so when it cannot).
#[must_use]
pub fn recording_path_in(dir: &Path) -> PathBuf {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let mut p = dir.join(format!("session-{secs}.mcap"));
    let mut k = 1;
    while p.exists() {
        k += 1;
        p = dir.join(format!("session-{secs}-{k}.mcap"));
    }
    p
}

/// Command queue capacity.
pub const COMMAND_CAPACITY: usize = 256;

pub use crate::pilot::pad::PadSlot;

/// State shared between the runtime threads and the handle. Each field names the
/// thread that writes it (one writer per field; everyone else reads). "control" is
/// `station-control` (the [`host`]'s engine in live mode; the caller's thread for a
/// [`VirtualStation`]), "replay" the replay thread, "GUI" any [`StationHandle`] holder.
#[derive(Debug)]
pub(crate) struct Shared {
    /// Written by: control (or replay), once per tick (`Host::publish`, try-lock: never
    /// waits for the GUI). Read by: GUI.
    pub view: Mutex<StationView>,
    /// Written by: control (or replay), samples appended per tick. Read (drained) by: GUI.
    pub feed: Mutex<history::HistoryFeed>,
    /// Written by: control (tick start and end times). Read by: GUI (statistics).
    pub ticks: Mutex<timing::TickTimer>,
    /// Written by: `station-gamepad` (each poll). Read by: control (before each tick).
    pub pad: Mutex<PadSlot>,
    /// Written by: control (end of each tick). Read by: `station-watchdog`.
    pub last_tick_us: AtomicU64,
    /// Written by: `station-watchdog`. Read by: control (the control-stall alarm), GUI.
    pub watchdog_trips: AtomicU64,
    /// Written by: `station-watchdog`. Read by: control, GUI.
    pub watchdog_frames: AtomicU64,
    /// Written by: `station-watchdog`. Read by: control, GUI.
    pub watchdog_max_gap_us: AtomicU64,
    /// Lights and camera of the last control frame, kept by the watchdog's neutral
    /// frames (see `live::pack_kept`). Written by: control. Read by: `station-watchdog`,
    /// the simulated camera's pose source.
    pub watchdog_kept: AtomicU64,
    /// Written by: GUI (a command that found the queue full). Read by: control (view).
    pub commands_dropped: AtomicU64,
    /// Written by: GUI (shutdown), control and replay (as they end). Read by: every
    /// thread's loop.
    pub running: AtomicBool,
    /// Not written (a copy of the monotonic clock's origin).
    pub clock: MonoClock,
    /// What each real-time thread got (thread name, grant). Written by: each real-time
    /// thread once, as it starts. Read by: control (view), GUI.
    pub priorities: Mutex<Vec<(String, priority::Granted)>>,
    /// Heap allocations of the control thread's wake-ups (tests only). Written by: control.
    #[cfg(test)]
    pub test_allocations: AtomicU64,
    /// Control thread wake-ups counted (tests only). Written by: control.
    #[cfg(test)]
    pub test_wakeups: AtomicU64,
}

impl Shared {
    pub fn new(period_us: u64, clock: MonoClock) -> Self {
        Self {
            view: Mutex::new(StationView::default()),
            feed: Mutex::new(history::HistoryFeed::default()),
            ticks: Mutex::new(timing::TickTimer::new(period_us)),
            pad: Mutex::new(PadSlot::default()),
            last_tick_us: AtomicU64::new(0),
            watchdog_trips: AtomicU64::new(0),
            watchdog_frames: AtomicU64::new(0),
            watchdog_max_gap_us: AtomicU64::new(0),
            watchdog_kept: AtomicU64::new(0),
            commands_dropped: AtomicU64::new(0),
            running: AtomicBool::new(true),
            clock,
            priorities: Mutex::new(Vec::new()),
            #[cfg(test)]
            test_allocations: AtomicU64::new(0),
            #[cfg(test)]
            test_wakeups: AtomicU64::new(0),
        }
    }
}

/// Locks a mutex, taking the data of a poisoned one (a panicked holder leaves valid
/// plain data here).
pub(crate) fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Tries to lock without waiting (a poisoned mutex is taken as is).
pub(crate) fn try_lock<T>(m: &Mutex<T>) -> Option<MutexGuard<'_, T>> {
    match m.try_lock() {
        Ok(g) => Some(g),
        Err(std::sync::TryLockError::Poisoned(p)) => Some(p.into_inner()),
        Err(std::sync::TryLockError::WouldBlock) => None,
    }
}

/// The GUI's handle on a running station (live or replay). Dropping it shuts the
/// runtime down.
#[derive(Debug)]
pub struct StationHandle {
    shared: Arc<Shared>,
    tx: SyncSender<RuntimeCommand>,
    threads: Vec<JoinHandle<()>>,
    video: Option<Arc<video::StationVideo>>,
}

impl StationHandle {
    pub(crate) fn new(
        shared: Arc<Shared>,
        tx: SyncSender<RuntimeCommand>,
        threads: Vec<JoinHandle<()>>,
    ) -> Self {
        Self {
            shared,
            tx,
            threads,
            video: None,
        }
    }

    /// The same handle with its camera.
    pub(crate) fn with_video(mut self, video: Arc<video::StationVideo>) -> Self {
        self.video = Some(video);
        self
    }

    /// The station's camera (live, virtual or the recorded video of a replay); `None`
    /// when it has none.
    #[must_use]
    pub fn video(&self) -> Option<&Arc<video::StationVideo>> {
        self.video.as_ref()
    }

    /// The latest station snapshot (a copy).
    #[must_use]
    pub fn snapshot(&self) -> Snapshot {
        lock(&self.shared.view).snapshot.clone()
    }

    /// The latest full view (a copy).
    #[must_use]
    pub fn view(&self) -> StationView {
        lock(&self.shared.view).clone()
    }

    /// Sends a station command; false if the queue was full (counted) or the runtime
    /// has stopped.
    pub fn send(&self, cmd: StationCommand) -> bool {
        self.command(RuntimeCommand::Station(cmd))
    }

    /// Sends any runtime command; false if the queue was full (counted) or the runtime
    /// has stopped.
    pub fn command(&self, cmd: RuntimeCommand) -> bool {
        match self.tx.try_send(cmd) {
            Ok(()) => true,
            Err(TrySendError::Full(_)) => {
                self.shared.commands_dropped.fetch_add(1, Ordering::Relaxed);
                false
            }
            Err(TrySendError::Disconnected(_)) => false,
        }
    }

    /// Commands dropped because the queue was full.
    #[must_use]
    pub fn commands_dropped(&self) -> u64 {
        self.shared.commands_dropped.load(Ordering::Relaxed)
    }

    /// Copies the history samples `into` has not seen yet; returns how many.
    pub fn sync_history(&self, into: &mut History) -> usize {
        lock(&self.shared.feed).pull(into)
    }

    /// Tick timing statistics.
    #[must_use]
    pub fn tick_stats(&self) -> TickStats {
        let mut s = lock(&self.shared.ticks).stats();
        s.watchdog_trips = self.shared.watchdog_trips.load(Ordering::Relaxed);
        s.watchdog_frames = self.shared.watchdog_frames.load(Ordering::Relaxed);
        s.watchdog_max_gap_us = self.shared.watchdog_max_gap_us.load(Ordering::Relaxed);
        s
    }

    /// The priority each real-time thread got (thread name, grant).
    #[must_use]
    pub fn priorities(&self) -> Vec<(String, priority::Granted)> {
        lock(&self.shared.priorities).clone()
    }

    /// Wall timestamps of the last ticks, µs of [`StationHandle::now_us`]'s clock.
    #[must_use]
    pub fn tick_times(&self) -> Vec<u64> {
        lock(&self.shared.ticks).log()
    }

    /// The runtime clock now, µs.
    #[must_use]
    pub fn now_us(&self) -> u64 {
        self.shared.clock.now_us()
    }

    /// Acknowledges an alarm (`None`: all).
    pub fn ack_alarm(&self, kind: Option<AlarmKind>) -> bool {
        self.command(RuntimeCommand::AckAlarm(kind))
    }

    /// Starts recording to `path`.
    pub fn start_recording(&self, path: &Path) -> bool {
        self.command(RuntimeCommand::StartRecording(path.to_path_buf()))
    }

    /// Stops recording.
    pub fn stop_recording(&self) -> bool {
        self.command(RuntimeCommand::StopRecording)
    }

    /// Whether the runtime is still running.
    #[must_use]
    pub fn is_running(&self) -> bool {
        self.shared.running.load(Ordering::Relaxed)
    }

    /// Stops the threads and waits for them (a recording is finished first).
    pub fn shutdown(mut self) {
        self.stop();
    }

    fn stop(&mut self) {
        // The queue may be full: the flag alone stops the loops too.
        let _ = self.tx.try_send(RuntimeCommand::Shutdown);
        self.shared.running.store(false, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            join_or_warn(t);
        }
        if let Some(v) = &self.video {
            v.stop();
        }
    }
}

impl Drop for StationHandle {
    fn drop(&mut self) {
        self.stop();
    }
}

/// Entry points.
#[derive(Debug)]
pub struct Runtime;

impl Runtime {
    /// Starts a live station (sim or serial) on its own threads; see the module docs.
    ///
    /// # Errors
    /// [`RuntimeError`] if the configuration is refused, the models do not load, the
    /// port does not open, or a thread cannot start.
    pub fn start(cfg: RuntimeConfig) -> Result<StationHandle, RuntimeError> {
        live::start(cfg, ModelSet::load_default()?)
    }

    /// Plays a recorded session through the view pipeline on its own thread (paused at
    /// the start). Control with [`RuntimeCommand::Replay`].
    ///
    /// # Errors
    /// [`RuntimeError::Session`] if the file does not open.
    pub fn replay(path: &Path) -> Result<StationHandle, RuntimeError> {
        replay::start(path)
    }
}

pub(crate) fn command_channel() -> (SyncSender<RuntimeCommand>, Receiver<RuntimeCommand>) {
    sync_channel(COMMAND_CAPACITY)
}

/// Spawns a real-time thread: it raises its own priority first (see [`priority`]) and
/// records what it got.
pub(crate) fn spawn_raised(
    name: &str,
    rt: u8,
    shared: &Arc<Shared>,
    f: impl FnOnce() + Send + 'static,
) -> Result<JoinHandle<()>, RuntimeError> {
    let shared = Arc::clone(shared);
    let label = name.to_string();
    spawn_named(name, move || {
        let granted = priority::raise_current(rt);
        lock(&shared.priorities).push((label, granted));
        f();
    })
}

/// Waits for a thread; one that panicked is said (its panic message went to stderr),
/// not ignored.
pub(crate) fn join_or_warn<T>(t: JoinHandle<T>) {
    let name = t.thread().name().unwrap_or("unnamed").to_string();
    if t.join().is_err() {
        tracing::warn!("station thread {name} panicked");
    }
}

pub(crate) fn spawn_named(
    name: &str,
    f: impl FnOnce() + Send + 'static,
) -> Result<JoinHandle<()>, RuntimeError> {
    std::thread::Builder::new()
        .name(name.into())
        .spawn(move || {
            priority::normal_current();
            f();
        })
        .map_err(|source| RuntimeError::Thread {
            name: name.to_string(),
            source,
        })
}
