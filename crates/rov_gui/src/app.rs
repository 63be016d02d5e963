//! The station application: state, the frame, the top bar, the alarm bar, keyboard
//! input, and the tabs.
//!
//! Layout (a pilot's priorities): the top bar always shows arming, thrust gain, link
//! quality, recording and the REPLAY badge; latched alarms sit right under it in red
//! until acknowledged (never a modal dialog); the Fly tab has the instruments in the
//! middle and the autopilot, health and camera controls beside them.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Receiver;
use std::time::Duration;

use egui::{Color32, Key, RichText, Ui, vec2};
use rov_control::PilotInput;
use rov_station::StationCommand;
use rov_station::runtime::{
    AlarmKind, Connection, GainCommand, History, RuntimeCommand, RuntimeError, StationHandle,
    StationView,
};

use crate::theme;

/// Where the app gets its stations from (real threads, or virtual ones in tests).
pub trait Backend {
    /// Starts a live station.
    ///
    /// # Errors
    /// Why the station did not start (shown to the pilot).
    fn connect(&mut self, connection: &Connection) -> Result<StationHandle, RuntimeError>;
    /// Opens a recorded session for replay.
    ///
    /// # Errors
    /// Why the session could not be replayed (shown to the pilot).
    fn open_replay(&mut self, path: &Path) -> Result<StationHandle, RuntimeError>;
    /// Serial ports to offer.
    fn ports(&mut self) -> Vec<String>;
    /// Pings the ports in the background; the receiver yields one result.
    fn autodetect(&mut self, ports: Vec<String>) -> Receiver<AutodetectResult>;
    /// A fresh recording file name.
    fn recording_path(&mut self) -> PathBuf;
    /// The folder recordings go to (the session browser lists it).
    fn recordings_dir(&self) -> PathBuf;
    /// Asks for a file to open (a native dialog). None: cancelled, or no dialog on this
    /// desktop (the typed path stays).
    fn pick_file(&mut self, _title: &str, _extensions: &[&str]) -> Option<PathBuf> {
        None
    }
    /// Asks where to save a file.
    fn save_file(&mut self, _title: &str, _default_name: &str) -> Option<PathBuf> {
        None
    }
    /// Asks for a folder.
    fn pick_folder(&mut self, _title: &str) -> Option<PathBuf> {
        None
    }
}

/// What an autodetect found.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct AutodetectResult {
    /// The port that answered the ping.
    pub found: Option<String>,
    /// Every port tried, with why it was not chosen.
    pub tried: Vec<(String, Option<String>)>,
}

/// The tabs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Tab {
    /// Instruments and controls.
    #[default]
    Fly,
    /// Time plots.
    Plots,
    /// Replay a session.
    Replay,
    /// The model lab.
    Lab,
    /// Vehicle connection.
    Connection,
    /// The pre-dive checklist.
    PreDive,
    /// Gamepad and keyboard setup.
    Gamepad,
    /// Units, port, recordings, alarm limits.
    Settings,
}

impl Tab {
    const ALL: [(Tab, &'static str); 8] = [
        (Tab::Fly, "Fly"),
        (Tab::PreDive, "Pre-dive"),
        (Tab::Plots, "Plots"),
        (Tab::Replay, "Replay"),
        (Tab::Lab, "Model lab"),
        (Tab::Connection, "Connection"),
        (Tab::Gamepad, "Gamepad"),
        (Tab::Settings, "Settings"),
    ];
}

/// A request to screenshot the window after some seconds, save it and close.
#[derive(Debug)]
pub struct ScreenshotRequest {
    /// PNG path.
    pub path: PathBuf,
    /// Seconds after the first frame.
    pub after_s: f64,
    pub(crate) state: ScreenshotState,
}

#[derive(Debug, Default)]
pub(crate) struct ScreenshotState {
    pub started: Option<std::time::Instant>,
    pub requested: bool,
    pub done: Arc<AtomicBool>,
    pub ok: Arc<AtomicBool>,
}

impl ScreenshotRequest {
    /// A request.
    #[must_use]
    pub fn new(path: PathBuf, after_s: f64) -> Self {
        Self {
            path,
            after_s,
            state: ScreenshotState::default(),
        }
    }

    /// Whether the screenshot was saved.
    #[must_use]
    pub fn saved(&self) -> bool {
        self.state.ok.load(Ordering::Relaxed)
    }

    /// A flag that turns true once the screenshot is saved (readable after the window
    /// closed and the app was dropped).
    #[must_use]
    pub fn saved_flag(&self) -> Arc<AtomicBool> {
        Arc::clone(&self.state.ok)
    }
}

/// The station application; see the module docs.
pub struct StationApp {
    pub(crate) backend: Box<dyn Backend>,
    pub(crate) live: Option<StationHandle>,
    pub(crate) live_view: StationView,
    pub(crate) live_hist: History,
    pub(crate) replay: Option<StationHandle>,
    pub(crate) replay_view: StationView,
    pub(crate) replay_hist: History,
    pub(crate) tab: Tab,
    pub(crate) depth_drag: Option<f64>,
    pub(crate) heading_drag: Option<f64>,
    pub(crate) depth_text: String,
    pub(crate) heading_text: String,
    pub(crate) onboard: bool,
    pub(crate) shaping: rov_station::runtime::StickShaping,
    pub(crate) kb_active: bool,
    pub(crate) arm_reported: bool,
    pub(crate) space_held: bool,
    pub(crate) conn: crate::connection::ConnectionState,
    pub(crate) replay_path: String,
    pub(crate) plot_window_s: f64,
    pub(crate) lab: crate::lab::LabState,
    pub(crate) message: Option<String>,
    pub(crate) screenshot: Option<ScreenshotRequest>,
    pub(crate) repaint_ms: u64,
    pub(crate) styled: bool,
    /// Start recording on every new connection (settings; on by default).
    pub(crate) record_on_connect: bool,
    /// The recordings of this station run, oldest first (kept across connections).
    pub(crate) recordings: Vec<PathBuf>,
    /// What fills the Fly tab's centre instead of the instrument layout (the camera).
    pub(crate) main_view: Option<Box<dyn crate::fly::MainView>>,
    /// The V key's choice: the instrument-only layout even when a main view exists.
    pub(crate) instruments_only: bool,
    /// O: the camera picture without the HUD (the status strip stays).
    pub(crate) hud_hidden: bool,
    /// The marker/note toast: its text and when it appeared (egui time, s).
    pub(crate) toast: Option<(String, f64)>,
    /// The newest marker/note line already seen (None until the first frame).
    pub(crate) toast_seen: Option<Option<String>>,
    /// The live vehicle was armed at the last frame (for the record offer).
    pub(crate) was_armed: bool,
    /// Armed while not recording: the offer to record is up.
    pub(crate) record_offer: bool,
    /// The camera picture's texture and latency figures.
    pub(crate) video_pane: crate::video::VideoPane,
    /// The `[video]` settings being edited (Settings tab, Connection tab's devices).
    pub(crate) video_settings: rov_station::runtime::video::VideoSettings,
    /// The Settings tab's simulated-fault form (issue 23).
    pub(crate) fault_form: crate::watch_page::FaultForm,
    /// The Model lab's camera frame.
    pub(crate) lab_video: crate::lab_video::LabVideo,
    /// Capture devices found (Connection tab), or why the listing failed.
    pub(crate) capture_devices:
        Option<Result<Vec<rov_video::CaptureDevice>, rov_video::VideoError>>,
    /// What the last frame laid out (for the clipping checks).
    pub(crate) layout: crate::layout::LayoutAudit,
    /// The station configuration file the Settings tab saves to.
    pub(crate) config_path: Option<PathBuf>,
    /// The alarm limits being edited.
    pub(crate) alarm_limits: rov_station::runtime::AlarmConfig,
    /// The pilot's settings.
    pub(crate) station: rov_station::runtime::settings::StationSettings,
    /// The dive-log note being typed.
    pub(crate) note_text: String,
    /// Focus the note field next frame (N key).
    pub(crate) focus_note: bool,
    /// The pilot asked for the thruster test and must confirm.
    pub(crate) confirm_thruster_test: bool,
    /// The keys-and-buttons window is open (F1 or ?).
    pub(crate) help_open: bool,
    /// The gamepad map being edited.
    pub(crate) pad_map: rov_station::runtime::pad::PadMap,
    /// The recordings folder as a list.
    pub(crate) browser: crate::sessions::SessionBrowser,
    /// How many recordings the browser's last scan knew of (rescans after a new one).
    pub(crate) browser_seen: usize,
    /// The live Foxglove server (Settings tab).
    pub(crate) foxglove: crate::foxglove_live::FoxgloveState,
    /// The model files the autopilot panel offers (the user's models folder).
    pub(crate) models: crate::autopilot_model::ModelsFolder,
    /// The last autopilot model change and the station's answer.
    pub(crate) model_switch: crate::autopilot_model::ModelSwitch,
}

impl std::fmt::Debug for StationApp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StationApp")
            .field("tab", &self.tab)
            .finish_non_exhaustive()
    }
}

impl StationApp {
    /// An app connected to `live` (if any), getting further stations from `backend`.
    #[must_use]
    pub fn new(backend: Box<dyn Backend>, live: Option<StationHandle>) -> Self {
        let mut app = Self {
            backend,
            live: None,
            live_view: StationView::default(),
            live_hist: History::default(),
            replay: None,
            replay_view: StationView::default(),
            replay_hist: History::default(),
            tab: Tab::Fly,
            depth_drag: None,
            heading_drag: None,
            depth_text: String::new(),
            heading_text: String::new(),
            onboard: false,
            shaping: rov_station::runtime::StickShaping::default(),
            kb_active: false,
            arm_reported: false,
            space_held: false,
            conn: crate::connection::ConnectionState::default(),
            replay_path: String::new(),
            plot_window_s: 120.0,
            lab: crate::lab::LabState::default(),
            message: None,
            screenshot: None,
            repaint_ms: 33,
            styled: false,
            record_on_connect: true,
            recordings: Vec::new(),
            main_view: None,
            instruments_only: false,
            hud_hidden: false,
            toast: None,
            toast_seen: None,
            was_armed: false,
            record_offer: false,
            video_pane: crate::video::VideoPane::default(),
            video_settings: rov_station::runtime::video::VideoSettings::default(),
            fault_form: crate::watch_page::FaultForm::default(),
            capture_devices: None,
            lab_video: crate::lab_video::LabVideo::default(),
            layout: crate::layout::LayoutAudit::default(),
            config_path: None,
            alarm_limits: rov_station::runtime::AlarmConfig::default(),
            station: rov_station::runtime::settings::StationSettings::default(),
            note_text: String::new(),
            focus_note: false,
            confirm_thruster_test: false,
            help_open: false,
            pad_map: rov_station::runtime::pad::PadMap::default(),
            browser: crate::sessions::SessionBrowser::default(),
            browser_seen: usize::MAX,
            foxglove: crate::foxglove_live::FoxgloveState::default(),
            models: crate::autopilot_model::ModelsFolder::default(),
            model_switch: crate::autopilot_model::ModelSwitch::default(),
        };
        app.set_live(live);
        app
    }

    /// Whether every new connection starts a recording (default on).
    #[must_use]
    pub fn with_record_on_connect(mut self, on: bool) -> Self {
        self.record_on_connect = on;
        self
    }

    /// The settings from the station configuration `path` (the Settings tab edits them
    /// and saves them there).
    #[must_use]
    pub fn with_settings(
        mut self,
        path: PathBuf,
        alarms: rov_station::runtime::AlarmConfig,
        station: rov_station::runtime::settings::StationSettings,
    ) -> Self {
        self.config_path = Some(path);
        self.alarm_limits = alarms;
        self.station = station;
        self
    }

    /// The `[video]` settings from the station configuration (the Settings tab edits
    /// them, the Connection tab's device choice is saved into them).
    #[must_use]
    pub fn with_video_settings(
        mut self,
        video: rov_station::runtime::video::VideoSettings,
    ) -> Self {
        self.video_settings = video;
        self
    }

    /// The `[video]` settings as edited.
    #[must_use]
    pub fn video_settings(&self) -> &rov_station::runtime::video::VideoSettings {
        &self.video_settings
    }

    /// Capture-to-screen latency of the shown video (median, p99), ms, and frames
    /// uploaded.
    #[must_use]
    pub fn video_figures(&self) -> (Option<(f64, f64)>, u64) {
        (self.video_pane.latency_ms(), self.video_pane.uploads())
    }

    /// The gamepad map and stick shaping from the station configuration.
    #[must_use]
    pub fn with_gamepad(
        mut self,
        map: rov_station::runtime::pad::PadMap,
        shaping: rov_station::runtime::StickShaping,
    ) -> Self {
        self.pad_map = map;
        self.shaping = shaping;
        self
    }

    /// Where the Settings and Gamepad pages save (the station configuration).
    pub(crate) fn config_target(&self) -> PathBuf {
        self.config_path
            .clone()
            .unwrap_or_else(|| PathBuf::from("config/station.toml"))
    }

    /// The pilot's settings as edited.
    #[must_use]
    pub fn station_settings(&self) -> &rov_station::runtime::settings::StationSettings {
        &self.station
    }

    /// Sets what fills the Fly tab's centre (the camera picture); the instruments are
    /// drawn over it, and V switches to the instrument-only layout.
    pub fn set_main_view(&mut self, view: Box<dyn crate::fly::MainView>) {
        self.main_view = Some(view);
    }

    /// The recordings made since the station started, oldest first.
    #[must_use]
    pub fn recordings(&self) -> &[PathBuf] {
        &self.recordings
    }

    /// The most recent finished (or current) recording.
    #[must_use]
    pub fn last_recording(&self) -> Option<&PathBuf> {
        self.recordings.last()
    }

    /// The scroll areas of the last frame: id and how many points of their content did
    /// not fit (see [`crate::layout::scroll`]).
    #[must_use]
    pub fn scroll_hidden(&self) -> &[(String, f32)] {
        &self.layout.scroll_hidden
    }

    /// Controls the last frame cut off (see [`crate::layout`]).
    #[must_use]
    pub fn clipped_widgets(&self, ctx: &egui::Context) -> Vec<crate::layout::ClippedWidget> {
        crate::layout::clipped_widgets(ctx, &self.layout, 1.0)
    }

    /// The Fly tab's main view rectangle in the last frame.
    #[must_use]
    pub fn main_view_rect(&self) -> Option<egui::Rect> {
        self.layout.main_rect
    }

    /// Takes a screenshot after `after_s` seconds, saves it and closes the window.
    #[must_use]
    pub fn with_screenshot(mut self, req: ScreenshotRequest) -> Self {
        self.screenshot = Some(req);
        self
    }

    /// Selects a tab.
    pub fn set_tab(&mut self, tab: Tab) {
        self.tab = tab;
    }

    /// The tab shown.
    #[must_use]
    pub const fn tab(&self) -> Tab {
        self.tab
    }

    /// The live view last read.
    #[must_use]
    pub const fn live_view(&self) -> &StationView {
        &self.live_view
    }

    /// The replay view last read, when replaying.
    #[must_use]
    pub fn replay_view(&self) -> Option<&StationView> {
        self.replay.as_ref().map(|_| &self.replay_view)
    }

    /// Shows fixed data without a station (benchmarks, demos): the view and history
    /// stay until a station is connected.
    pub fn show_offline(&mut self, view: StationView, history: History) {
        self.live = None;
        self.live_view = view;
        self.live_hist = history;
    }

    /// Sets the plot window, s (`f64::INFINITY`: everything).
    pub fn set_plot_window(&mut self, window_s: f64) {
        self.plot_window_s = window_s;
    }

    /// The live history held by the GUI.
    #[must_use]
    pub const fn live_history(&self) -> &History {
        &self.live_hist
    }

    /// Whether the screenshot (if requested) has been saved.
    #[must_use]
    pub fn screenshot_saved(&self) -> bool {
        self.screenshot
            .as_ref()
            .is_some_and(ScreenshotRequest::saved)
    }

    /// Shows a message in the status line.
    pub fn set_message(&mut self, m: String) {
        self.message = Some(m);
    }

    /// The message line (errors from the last action).
    #[must_use]
    pub fn message(&self) -> Option<&str> {
        self.message.as_deref()
    }

    /// The session browser (for tests).
    #[must_use]
    pub fn browser(&self) -> &crate::sessions::SessionBrowser {
        &self.browser
    }

    /// The session browser, to wait for its scan (tests).
    pub fn browser_mut(&mut self) -> &mut crate::sessions::SessionBrowser {
        &mut self.browser
    }

    /// The lab state (for tests).
    #[must_use]
    pub fn lab(&self) -> &crate::lab::LabState {
        &self.lab
    }

    /// The lab state, to set (for tests) the model the lab holds.
    pub fn lab_mut(&mut self) -> &mut crate::lab::LabState {
        &mut self.lab
    }

    /// The folder of model files the autopilot panel offers (the binary passes the
    /// user's `models/` next to `station.toml`); scanned now and on the pilot's Rescan.
    #[must_use]
    pub fn with_models_dir(mut self, dir: Option<PathBuf>) -> Self {
        self.set_models_dir(dir);
        self
    }

    /// Sets (and scans) the models folder.
    pub fn set_models_dir(&mut self, dir: Option<PathBuf>) {
        self.models = crate::autopilot_model::ModelsFolder::scan(dir);
    }

    /// The model files found in the models folder.
    #[must_use]
    pub fn model_files(&self) -> &[PathBuf] {
        &self.models.files
    }

    /// The station's answer to the last autopilot model change.
    #[must_use]
    pub fn model_switch_result(&self) -> Option<&crate::autopilot_model::SwitchResult> {
        self.model_switch.result.as_ref()
    }

    pub(crate) fn set_live(&mut self, live: Option<StationHandle>) {
        self.live = live;
        self.live_hist = History::default();
        self.live_view = StationView::default();
        self.toast_seen = None;
        if let Some(h) = &self.live
            && self.foxglove.server.is_some()
        {
            self.foxglove.attach(h);
        }
        if self.record_on_connect && self.live.is_some() {
            // Every connection records from its start, unless the pilot switched it
            // off in the settings; the REC control shows which.
            let path = self.backend.recording_path();
            self.live_cmd(RuntimeCommand::StartRecording(path));
        }
        self.poll();
    }

    /// Makes `live` the live station (a new connection: it records when recording on
    /// connection is on).
    pub fn connect_handle(&mut self, live: Option<StationHandle>) {
        self.set_live(live);
    }

    /// Opens a session for replay, or says what is missing when `text` is empty.
    pub(crate) fn open_replay_text(&mut self, text: &str) {
        let t = text.trim();
        if t.is_empty() {
            self.message =
                Some("no file chosen: type the path of a session (.mcap) or use Browse".into());
            return;
        }
        self.open_replay(Path::new(t));
    }

    /// Opens a session for replay (errors go to the message line).
    pub fn open_replay(&mut self, path: &Path) {
        match self.backend.open_replay(path) {
            Ok(h) => {
                self.replay = Some(h);
                self.replay_hist = History::default();
                self.message = None;
                self.poll();
            }
            Err(e) => self.message = Some(format!("cannot open {}: {e}", path.display())),
        }
    }

    /// Closes the replay (back to live).
    pub fn close_replay(&mut self) {
        self.replay = None;
        self.replay_hist = History::default();
    }

    /// Sends a command to the live station (what the pages do; also for tests and
    /// other input devices).
    pub fn command(&mut self, c: RuntimeCommand) {
        self.live_cmd(c);
    }

    /// Sends a command to the live station.
    pub(crate) fn live_cmd(&mut self, c: RuntimeCommand) {
        if let Some(h) = &self.live
            && !h.command(c)
        {
            self.message = Some("command queue full: command dropped".into());
        }
    }

    /// Sends a model for the autopilot (or shows why it could not be loaded); the answer
    /// is picked out of the station's events.
    pub(crate) fn send_autopilot_model(
        &mut self,
        model: Result<rov_station::AutopilotModel, crate::FileError>,
        confirmed: bool,
    ) {
        let mut dropped = false;
        let live = &self.live;
        self.model_switch.send(
            |c| {
                if let Some(h) = live {
                    dropped = !h.command(c);
                }
            },
            &self.live_view,
            model,
            confirmed,
        );
        if dropped {
            self.message = Some("command queue full: command dropped".into());
        }
    }

    pub(crate) fn replay_cmd(&self, c: rov_station::runtime::ReplayCommand) {
        if let Some(h) = &self.replay {
            h.command(RuntimeCommand::Replay(c));
        }
    }

    /// The view the instruments show (the replay's while replaying).
    pub(crate) fn shown(&self) -> (&StationView, &History) {
        if self.replay.is_some() {
            (&self.replay_view, &self.replay_hist)
        } else {
            (&self.live_view, &self.live_hist)
        }
    }

    /// Reads the stations (latest values, new history samples).
    pub fn poll(&mut self) {
        if let Some(h) = &self.live {
            self.live_view = h.view();
            h.sync_history(&mut self.live_hist);
            let r = &self.live_view.recording;
            for p in [r.last_file.as_ref(), r.path.as_ref()]
                .into_iter()
                .flatten()
            {
                if !self.recordings.contains(p) {
                    self.recordings.push(p.clone());
                }
            }
        }
        if let Some(h) = &self.replay {
            self.replay_view = h.view();
            h.sync_history(&mut self.replay_hist);
        }
        self.lab.poll();
        self.model_switch.poll(&self.live_view);
        self.conn.poll();
        self.browser.poll();
    }

    /// One frame.
    pub fn ui(&mut self, ui: &mut Ui) {
        if !self.styled {
            theme::apply(ui.ctx());
            self.styled = true;
        }
        self.poll();
        self.layout.scroll_viewports.clear();
        self.layout.scroll_hidden.clear();
        self.layout.main_rect = None;
        self.keyboard(ui);
        self.top_bar(ui);
        self.alarm_bar(ui);
        if self.replay.is_some() {
            crate::replay::replay_bar(self, ui);
        }
        self.status_bar(ui);
        egui::CentralPanel::default().show(ui, |ui| match self.tab {
            Tab::Fly => crate::fly::fly(self, ui),
            Tab::Plots => crate::plots::plots_tab(self, ui),
            Tab::Replay => crate::replay::replay_tab(self, ui),
            Tab::Lab => crate::lab::lab_tab(self, ui),
            Tab::Connection => crate::connection::connection_tab(self, ui),
            Tab::Settings => crate::settings::settings_tab(self, ui),
            Tab::PreDive => crate::dive::predive_tab(self, ui),
            Tab::Gamepad => crate::pad_page::gamepad_tab(self, ui),
        });
        crate::help::help_window(self, ui.ctx());
        crate::pilot_keys::toast(self, ui.ctx());
        crate::pilot_keys::record_offer(self, ui.ctx());
        self.screenshot_step(ui.ctx());
        ui.ctx()
            .request_repaint_after(Duration::from_millis(self.repaint_ms));
    }

    /// Keyboard: W/S surge, A/D yaw, R/F rise/dive (sticks at full deflection, sent every
    /// frame while held: the runtime centres them 0.3 s after the last report);
    /// Space held = arm; Esc = disarm; 1–4 = gain step; H / J = depth / heading hold.
    fn keyboard(&mut self, ui: &mut Ui) {
        if ui.ctx().egui_wants_keyboard_input() {
            if self.kb_active {
                self.live_cmd(RuntimeCommand::Station(StationCommand::Sticks(
                    PilotInput::default(),
                )));
                self.kb_active = false;
            }
            return;
        }
        let (marker, note, help) = ui.input(|i| {
            (
                i.key_pressed(Key::M),
                i.key_pressed(Key::N),
                i.key_pressed(Key::F1) || i.key_pressed(Key::Questionmark),
            )
        });
        if marker && self.replay.is_none() {
            self.live_cmd(RuntimeCommand::Marker);
        }
        if note {
            self.tab = Tab::Fly;
            self.focus_note = true;
        }
        if help {
            self.help_open = !self.help_open;
        }
        let (step, toggle_view) = ui.input(|i| {
            let step = if i.key_pressed(Key::Period) {
                Some(rov_station::runtime::ReplayCommand::Step)
            } else if i.key_pressed(Key::Comma) {
                Some(rov_station::runtime::ReplayCommand::StepBack)
            } else {
                None
            };
            (step, i.key_pressed(Key::V))
        });
        if ui.input(|i| i.key_pressed(Key::O)) {
            self.hud_hidden = !self.hud_hidden;
        }
        if let Some(c) = step {
            self.replay_cmd(c);
        }
        if toggle_view && (self.main_view.is_some() || crate::video::shown_video(self).is_some()) {
            self.instruments_only = !self.instruments_only;
        }
        crate::pilot_keys::keys(self, ui);
        let (sticks, space, esc, gain, hold_d, hold_h) = ui.input(|i| {
            let axis = |pos: Key, neg: Key| {
                f64::from(u8::from(i.key_down(pos))) - f64::from(u8::from(i.key_down(neg)))
            };
            let sticks = PilotInput {
                surge: axis(Key::W, Key::S),
                yaw: axis(Key::D, Key::A),
                vertical: axis(Key::F, Key::R),
            };
            let gain = [Key::Num1, Key::Num2, Key::Num3, Key::Num4]
                .iter()
                .position(|k| i.key_pressed(*k));
            (
                sticks,
                i.key_down(Key::Space),
                i.key_pressed(Key::Escape),
                gain,
                i.key_pressed(Key::H),
                i.key_pressed(Key::J),
            )
        });
        let any = sticks != PilotInput::default();
        if any || self.kb_active {
            self.live_cmd(RuntimeCommand::Station(StationCommand::Sticks(sticks)));
        }
        self.kb_active = any;
        self.space_held = space;
        if esc {
            self.live_cmd(RuntimeCommand::Station(StationCommand::Disarm));
        }
        if let Some(g) = gain {
            self.live_cmd(RuntimeCommand::Gain(GainCommand::Set(g)));
        }
        if hold_d {
            self.live_cmd(RuntimeCommand::ToggleHold(rov_control::Axis::Depth));
        }
        if hold_h {
            self.live_cmd(RuntimeCommand::ToggleHold(rov_control::Axis::Heading));
        }
    }

    fn top_bar(&mut self, ui: &mut Ui) {
        egui::Panel::top("top_bar")
            .frame(
                egui::Frame::new()
                    .fill(Color32::from_rgb(28, 32, 38))
                    .inner_margin(6.0),
            )
            .show(ui, |ui| {
                ui.horizontal(|ui| {
                    let v = self.live_view.clone();
                    // Arming (always the live station, also while replaying).
                    let (held, disarm) =
                        crate::instruments::arm_control(ui, v.snapshot.armed, v.pilot.arm_progress);
                    let held = held || self.space_held;
                    if held || self.arm_reported {
                        self.live_cmd(RuntimeCommand::ArmButton(held));
                    }
                    self.arm_reported = held;
                    if disarm {
                        self.live_cmd(RuntimeCommand::Station(StationCommand::Disarm));
                    }
                    let (state, color) = if v.snapshot.armed {
                        ("ARMED", theme::RED)
                    } else {
                        ("SAFE", theme::GREEN)
                    };
                    ui.vertical(|ui| {
                        ui.label(RichText::new(state).size(22.0).strong().color(color));
                        // Always a line (blank without a hint), so the bar's height and
                        // everything under it stay put when a hint comes and goes.
                        let hint = v.hint.as_deref().unwrap_or(" ");
                        ui.label(RichText::new(hint).small().strong().color(theme::AMBER));
                    });
                    ui.separator();
                    // Gain steps, always visible.
                    ui.vertical(|ui| {
                        ui.label(RichText::new("GAIN").small().color(theme::DIM));
                        ui.horizontal(|ui| {
                            ui.spacing_mut().item_spacing.x = 2.0;
                            for (i, g) in rov_station::runtime::GAIN_STEPS_PCT.iter().enumerate() {
                                let on = i == v.pilot.gain_index;
                                let text = RichText::new(format!("{g:.0}"))
                                    .monospace()
                                    .color(if on { Color32::BLACK } else { theme::DIM });
                                let b = egui::Button::new(text)
                                    .fill(if on {
                                        theme::THRUST
                                    } else {
                                        Color32::from_gray(45)
                                    })
                                    .min_size(vec2(30.0, 20.0));
                                if ui.add(b).clicked() {
                                    self.live_cmd(RuntimeCommand::Gain(GainCommand::Set(i)));
                                }
                            }
                            ui.label(RichText::new("%").small());
                        });
                    });
                    ui.separator();
                    crate::panels::link_pill(ui, &v);
                    ui.separator();
                    crate::panels::recording_control(self, ui);
                    ui.separator();
                    if self.replay.is_some() {
                        let badge = egui::Button::new(
                            RichText::new(" REPLAY ")
                                .size(20.0)
                                .strong()
                                .color(Color32::BLACK),
                        )
                        .fill(theme::REPLAY);
                        ui.add(badge);
                    } else {
                        let src = match &v.source {
                            rov_station::runtime::Source::Sim => "SIM".to_string(),
                            rov_station::runtime::Source::Serial(p) => p.clone(),
                            rov_station::runtime::Source::Replay(_) => "REPLAY".to_string(),
                            rov_station::runtime::Source::None => "NO VEHICLE".to_string(),
                        };
                        ui.label(RichText::new(src).strong().color(theme::SCALE));
                    }
                });
                ui.horizontal(|ui| {
                    for (tab, name) in Tab::ALL {
                        ui.selectable_value(&mut self.tab, tab, RichText::new(name).size(15.0));
                    }
                    // The clock at the right of the tab row, which has room at every
                    // width (in the first row it slid under the source, item 4).
                    ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
                        ui.label(
                            RichText::new(format!("t {:.1} s", self.shown().0.snapshot.time_s))
                                .monospace()
                                .color(theme::DIM),
                        );
                    });
                });
            });
    }

    /// The alarm banner under the top bar: red while an unacknowledged alarm is listed,
    /// amber for warnings only, brown once everything is acknowledged; each entry says
    /// what, how serious, the value and the limit crossed, with its ACK button.
    fn alarm_bar(&mut self, ui: &mut Ui) {
        use rov_station::runtime::AlarmLevel;
        let mut alarms = self.live_view.alarms.clone();
        // Unacknowledged first, alarms before warnings: what the strip cannot fit is the
        // least urgent.
        alarms.sort_by_key(|a| (a.acknowledged, a.level != AlarmLevel::Alarm));
        let failsafe = self.live_view.snapshot.alarm.clone();
        let v_watch = self.live_view.watch.clone();
        let unacked = |lvl: AlarmLevel| alarms.iter().any(|a| !a.acknowledged && a.level == lvl);
        let (fill, title) = if alarms.is_empty() && failsafe.is_none() {
            (Color32::from_rgb(30, 34, 40), "NO ALARMS")
        } else if unacked(AlarmLevel::Alarm) || failsafe.is_some() {
            (theme::RED, "ALARM")
        } else if unacked(AlarmLevel::Warning) {
            (Color32::from_rgb(200, 120, 0), "WARNING")
        } else {
            (Color32::from_rgb(90, 60, 15), "ACKNOWLEDGED")
        };
        let n_unacked = alarms.iter().filter(|a| !a.acknowledged).count();
        // A strip of fixed height, always there: an alarm appearing or clearing never
        // moves a control under the pointer (issue 25 item 2). What does not fit the
        // width is clipped at the right (unacknowledged alarms come first).
        egui::Panel::top("alarm_bar")
            .exact_size(ALARM_STRIP_H)
            .resizable(false)
            .frame(
                egui::Frame::new()
                    .fill(fill)
                    .inner_margin(egui::Margin::symmetric(6, 2)),
            )
            .show(ui, |ui| {
                ui.horizontal_centered(|ui| {
                    let title_color = if alarms.is_empty() && failsafe.is_none() {
                        theme::DIM
                    } else {
                        Color32::WHITE
                    };
                    ui.label(RichText::new(title).size(18.0).strong().color(title_color));
                    if n_unacked > 0 {
                        let text = if n_unacked > 1 {
                            "ACK ALL (K)"
                        } else {
                            "ACK (K)"
                        };
                        if ui.button(text).clicked() {
                            self.live_cmd(RuntimeCommand::AckAlarm(None::<AlarmKind>));
                        }
                    }
                    if let Some(f) = &failsafe {
                        ui.label(
                            RichText::new(format!("FAILSAFE {f}: thrust neutral until re-armed"))
                                .size(16.0)
                                .color(Color32::WHITE),
                        );
                    }
                    for a in &alarms {
                        // The station's wording: every number with its unit, and where
                        // a held level lets go (issue 25 item 9).
                        let mut text = a.describe();
                        // The model watch's finding in words (issue 23).
                        if a.kind == AlarmKind::VehicleChanged
                            && let Some(w) = v_watch.latest_change()
                        {
                            text = format!("{text}: {w}");
                        }
                        let color = if a.acknowledged {
                            Color32::from_gray(200)
                        } else {
                            Color32::WHITE
                        };
                        ui.label(RichText::new(text).size(16.0).strong().color(color));
                        if !a.acknowledged && n_unacked > 1 && ui.button("ACK").clicked() {
                            self.live_cmd(RuntimeCommand::AckAlarm(Some(a.kind)));
                        }
                        ui.separator();
                    }
                });
            });
    }

    fn status_bar(&mut self, ui: &mut Ui) {
        egui::Panel::bottom("status_bar")
            .frame(
                egui::Frame::new()
                    .fill(Color32::from_rgb(24, 27, 32))
                    .inner_margin(4.0),
            )
            .show(ui, |ui| {
                ui.horizontal(|ui| {
                    let v = &self.live_view;
                    let t = &v.tick;
                    ui.label(
                        RichText::new(format!(
                            "control {:.0} Hz  late p99 {:.1} ms  missed {}  watchdog {}",
                            if t.period_us > 0 {
                                1e6 / t.period_us as f64
                            } else {
                                0.0
                            },
                            t.p99_late_us as f64 * 1e-3,
                            t.missed,
                            t.watchdog_trips
                        ))
                        .monospace()
                        .small()
                        .color(theme::DIM),
                    );
                    ui.separator();
                    let pad = crate::panels::pad_text(&v.pilot.pad);
                    ui.label(RichText::new(pad).small().color(theme::DIM));
                    ui.separator();
                    if let Some(m) = &self.message {
                        ui.label(RichText::new(m).small().color(theme::AMBER));
                    } else if let Some(r) = &v.last_refusal {
                        ui.label(RichText::new(r).small().color(theme::AMBER));
                    } else if let Some(e) = self.shown().0.events.last() {
                        ui.label(RichText::new(e).small().color(theme::DIM));
                    }
                });
            });
    }

    fn screenshot_step(&mut self, ctx: &egui::Context) {
        let Some(req) = self.screenshot.as_mut() else {
            return;
        };
        let now = std::time::Instant::now();
        let started = *req.state.started.get_or_insert(now);
        if req.state.done.load(Ordering::Relaxed) {
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
            return;
        }
        if !req.state.requested && now.duration_since(started).as_secs_f64() >= req.after_s {
            req.state.requested = true;
            let path = req.path.clone();
            // The layout check of this very frame, next to the PNG.
            let report = serde_json::json!({
                "window": [ctx.content_rect().width(), ctx.content_rect().height()],
                "main_view": self.layout.main_rect.map(|r| [r.min.x, r.min.y, r.max.x, r.max.y]),
                "clipped": crate::layout::clipped_widgets(ctx, &self.layout, 1.0),
                "link_quality": format!("{:?}", self.live_view.link.quality),
                "link_errors": self.live_view.link.errors,
            });
            if let Err(e) = std::fs::write(path.with_extension("layout.json"), report.to_string()) {
                eprintln!("layout report: {e}");
            }
            let done = Arc::clone(&req.state.done);
            let ok = Arc::clone(&req.state.ok);
            let c = ctx.clone();
            ctx.request_screenshot(move |image| {
                match crate::screenshot::save_png(&image, &path) {
                    Ok(()) => ok.store(true, Ordering::Relaxed),
                    Err(e) => eprintln!("screenshot: {e}"),
                }
                done.store(true, Ordering::Relaxed);
                c.request_repaint();
            });
        }
        ctx.request_repaint_after(Duration::from_millis(50));
    }
}

/// Height of the alarm strip under the top bar, points (always shown, see `alarm_bar`).
pub const ALARM_STRIP_H: f32 = 32.0;

impl eframe::App for StationApp {
    fn ui(&mut self, ui: &mut Ui, _frame: &mut eframe::Frame) {
        StationApp::ui(self, ui);
    }
}
