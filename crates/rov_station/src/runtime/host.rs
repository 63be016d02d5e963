//! The host: the pilot core's [`Engine`] with the threads and devices around it.
//!
//! The control thread (`live`) and the virtual-time station (`sim`) hold one `Host`. It
//! feeds the engine (link events, commands, the gamepad slot, the watchdog's count, the
//! model watch's alerts, the recorder's progress) and drains what the engine hands out:
//! records go to the recorder and the live Foxglove tap, [`Output`]s are carried out
//! here (the recorder started and stopped, a fault given to the simulated vehicle). It
//! owns the recorder, the finishers, the camera, the live tap, the truth tap, the model
//! watch's thread, the serial port's monitor and the shared state; the engine owns none.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::Ordering;

use rov_control::{ModelSet, TickOutput};
use rov_driver::{Link, LinkEvent};
use rov_session::{SessionInfo, Severity};

use crate::pilot::view::Source;
use crate::pilot::{Engine, Input, Output, RecordingProgress, Saved, WatchStatus, file_name};
use crate::runtime::finisher::{EXIT_WAIT, Finished, Finishers};
use crate::runtime::recorder::Recorder;
use crate::runtime::watch::{StationWatch, nav_row};
use crate::runtime::{RuntimeCommand, RuntimeConfig, RuntimeError, Shared, lock, try_lock};

/// What a command asks of the driver beyond the engine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Followup {
    None,
    Shutdown,
    Stall(std::time::Duration),
}

/// See the [module docs](self).
#[derive(Debug)]
pub(crate) struct Host {
    engine: Engine,
    /// The model watch (issue 23); `None` when off or its model did not load.
    watch: Option<StationWatch>,
    /// Where injected faults go (the simulated vehicle only).
    fault_inbox: Option<rov_vehicle::runner::FaultInbox>,
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
    /// The finishers' files, as last told to the engine.
    finishing: Vec<PathBuf>,
}

impl Host {
    pub fn new(
        cfg: RuntimeConfig,
        models: ModelSet,
        shared: Arc<Shared>,
        source: Source,
    ) -> Result<Self, RuntimeError> {
        let (watch, off) = if cfg.watch {
            let model = match &cfg.watch_model {
                Some(m) => Ok(m.clone()),
                None => rov_lab::load_model(
                    &rov_types::ModelId::Base(cfg.control.feedforward_model),
                    None,
                ),
            };
            match model {
                Ok(m) => (Some(StationWatch::new(m, false)), None),
                Err(e) => (None, Some(format!("its model did not load: {e}"))),
            }
        } else {
            (None, Some("off in the settings".to_string()))
        };
        let mut engine = Engine::new(cfg, models, source)?;
        engine.set_watch_off(off);
        Ok(Self {
            engine,
            watch,
            fault_inbox: None,
            recorder: None,
            finishers: Finishers::default(),
            live: None,
            truth_tap: None,
            video: None,
            port: None,
            shared,
            finishing: Vec::new(),
        })
    }

    /// The pilot core.
    pub fn engine_mut(&mut self) -> &mut Engine {
        &mut self.engine
    }

    /// Records `/truth/state` from the simulated vehicle's thread (live sim mode).
    pub fn attach_truth_tap(&mut self, tap: rov_vehicle::runner::TruthTap) {
        self.truth_tap = Some(tap);
    }

    /// The camera whose video recordings hold.
    pub fn attach_video(&mut self, video: Arc<crate::runtime::video::StationVideo>) {
        self.video = Some(video);
    }

    /// The simulated vehicle's fault inbox (`RuntimeCommand::InjectFault` goes there).
    pub fn attach_fault_inbox(&mut self, inbox: rov_vehicle::runner::FaultInbox) {
        self.fault_inbox = Some(inbox);
    }

    /// Runs the model watch inline (virtual time: no thread, same alerts).
    pub fn watch_inline(&mut self) {
        if let Some(w) = &mut self.watch {
            w.set_inline();
        }
    }

    /// One link event; telemetry also goes to the model watch.
    pub fn on_event(&mut self, link: &mut Link, ev: &LinkEvent, now_us: u64) {
        self.engine.handle(Input::Link(ev), link, now_us);
        if let (LinkEvent::Telemetry(t), Some(w)) = (ev, &mut self.watch) {
            let row = nav_row(now_us as f64 * 1e-6, self.engine.thrust_now_pct(), t);
            let alerts = w.push(row);
            let status = watch_status(w);
            self.engine
                .handle(Input::Watch { alerts, status }, link, now_us);
        }
        self.drain(link, now_us);
    }

    /// One command.
    pub fn apply(&mut self, link: &mut Link, cmd: RuntimeCommand, now_us: u64) -> Followup {
        self.engine.handle(Input::Command(cmd), link, now_us);
        self.drain(link, now_us)
    }

    /// One control tick at `now_us`: the inputs read from the other threads first, then
    /// the engine's tick, then its records, then the recorder's counters.
    pub fn tick(&mut self, link: &mut Link, now_us: u64) -> TickOutput {
        self.poll_finishers(link, now_us);
        {
            let slot = lock(&self.shared.pad);
            self.engine.handle(Input::Pad(&slot), link, now_us);
        }
        let counters = Input::Counters {
            watchdog_trips: self.shared.watchdog_trips.load(Ordering::Relaxed),
            commands_dropped: self.shared.commands_dropped.load(Ordering::Relaxed),
        };
        self.engine.handle(counters, link, now_us);
        if let Some(w) = &mut self.watch {
            let alerts = w.poll();
            let status = watch_status(w);
            self.engine
                .handle(Input::Watch { alerts, status }, link, now_us);
        }
        let out = self.engine.tick(link, now_us);
        self.drain(link, now_us);
        // The recorder's counters after this tick's records went to it.
        if let Some(r) = &self.recorder {
            let p = RecordingProgress {
                messages: r.queued(),
                dropped: r.dropped(),
                error: r.error(),
            };
            self.engine
                .handle(Input::RecordingProgress(p), link, now_us);
        }
        out
    }

    /// Records the simulated vehicle's truth (`/truth/state`) when a recording (or the live
    /// Foxglove server) is running. The station's control path never reads it: truth is
    /// for the engineer comparing the estimate with reality afterwards.
    pub fn record_truth(&mut self, link: &mut Link, truth: &rov_sim::TruthState, now_us: u64) {
        self.engine.handle(Input::Truth(truth), link, now_us);
        self.drain(link, now_us);
    }

    /// Records the attached tap's latest truth, at most one vehicle-runner wake-up
    /// (≈ 2 ms) old. Never waits for the vehicle thread.
    pub fn record_tapped_truth(&mut self, link: &mut Link, now_us: u64) {
        let latest = self
            .truth_tap
            .as_ref()
            .and_then(|t| t.try_lock().ok())
            .and_then(|slot| *slot);
        if let Some(truth) = latest {
            self.record_truth(link, &truth, now_us);
        }
    }

    /// A line in the view's event list (the transport's failures).
    pub fn note(&mut self, link: &mut Link, line: String, now_us: u64) {
        self.engine.handle(Input::Note(line), link, now_us);
    }

    /// Publishes the view and the pending history samples. Never waits for a reader:
    /// if the GUI holds a lock right now, the publication is retried next tick.
    pub fn publish(&mut self, tick: Option<crate::runtime::TickStats>) {
        let view = self.engine.view_mut();
        if let Some(t) = tick {
            view.tick = t;
        }
        if view.control_priority.is_empty()
            && let Some(p) = try_lock(&self.shared.priorities)
            && let Some((_, g)) = p.iter().find(|(n, _)| n == "station-control")
        {
            view.control_priority = g.to_string();
        }
        view.seq += 1;
        if let Some(mut v) = try_lock(&self.shared.view) {
            v.clone_from(self.engine.view());
        }
        let pending = self.engine.pending_history();
        if !pending.is_empty()
            && let Some(mut f) = try_lock(&self.shared.feed)
        {
            f.extend(pending.drain(..));
        }
        // Bound the backlog if a reader sat on the lock for very long.
        if pending.len() > crate::pilot::history::FEED_CAPACITY {
            let extra = pending.len() - crate::pilot::history::FEED_CAPACITY;
            pending.drain(..extra);
        }
    }

    /// Finishes a recording (shutdown) and waits for every recording being saved, at
    /// most [`EXIT_WAIT`] in all: nothing is lost at exit.
    pub fn finish(&mut self, link: &mut Link, now_us: u64) {
        self.stop_recording(link, now_us);
        self.wait_for_finishers(link, EXIT_WAIT, now_us);
    }

    /// Hands the engine's records and requests on (after an input from outside).
    pub fn flush(&mut self, link: &mut Link, now_us: u64) -> Followup {
        self.drain(link, now_us)
    }

    /// Carries out what the engine asked for and hands its records to the recorder and
    /// the live tap, until it asks for nothing more.
    fn drain(&mut self, link: &mut Link, now_us: u64) -> Followup {
        let mut followup = Followup::None;
        loop {
            self.send_records();
            let Some(out) = self.engine.poll_output() else {
                break;
            };
            match out {
                Output::StartRecording(path) => self.start_recording(link, &path, now_us),
                Output::StartRecordingIn(dir) => {
                    let path = crate::runtime::recording_path_in(&dir);
                    self.start_recording(link, &path, now_us);
                }
                Output::StopRecording => self.stop_recording(link, now_us),
                Output::FoxgloveLive(tap) => {
                    let on = tap.is_some();
                    self.live = tap;
                    self.engine.handle(Input::LiveServing(on), link, now_us);
                }
                Output::InjectFault(spec) => self.inject_fault(spec, now_us),
                Output::Stall(d) => followup = Followup::Stall(d),
                Output::Shutdown => followup = Followup::Shutdown,
            }
        }
        followup
    }

    /// The engine's records to the recorder and the live tap.
    fn send_records(&mut self) {
        while let Some((now_us, item)) = self.engine.poll_record() {
            if let Some(l) = &self.live {
                l.send(now_us, &item);
            }
            if let Some(r) = &self.recorder {
                r.send(item);
            }
        }
    }

    fn inject_fault(&mut self, spec: rov_sim::FaultSpec, now_us: u64) {
        let Some(inbox) = &self.fault_inbox else {
            self.engine.refuse(
                now_us,
                "inject a fault",
                "fault injection needs the built-in simulated vehicle".into(),
            );
            return;
        };
        // The control thread never waits on the vehicle: a busy lock is said, and the
        // pilot presses again.
        if inbox.try_lock().map(|mut v| v.push(spec)).is_ok() {
            self.engine.event(
                now_us,
                "fault_injected",
                Severity::Warning,
                format!("simulated fault injected: {spec}"),
            );
        } else {
            self.engine.refuse(
                now_us,
                "inject a fault",
                "the vehicle was busy; try again".into(),
            );
        }
    }

    fn start_recording(&mut self, link: &mut Link, path: &Path, now_us: u64) {
        if self.recorder.is_some() {
            self.stop_recording(link, now_us);
        }
        if self.finishers.is_finishing(path) {
            let e = format!(
                "{} is still being saved from the last recording; record to another file",
                file_name(path)
            );
            self.engine.handle(Input::RecordingRefused(e), link, now_us);
            return;
        }
        let info = SessionInfo {
            vehicle: self.engine.source_label().to_string(),
            software_version: env!("CARGO_PKG_VERSION").to_string(),
            started_unix_s: std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0.0, |d| d.as_secs_f64()),
            config_toml: self.engine.config().config_toml.clone(),
        };
        let blocking = self.engine.config().record_blocking;
        match Recorder::start(path, &info, now_us, blocking) {
            Ok(r) => {
                let video = self
                    .video
                    .as_ref()
                    .map(|v| v.begin_recording(r.video_tap().with_live(self.live.clone())));
                self.recorder = Some(r);
                link.set_record_frames(true);
                self.engine
                    .handle(Input::RecordingStarted(path.to_path_buf()), link, now_us);
                if let Some(Err(e)) = video {
                    // The error says "recording without video" itself.
                    self.engine
                        .event(now_us, "recording", Severity::Warning, e.to_string());
                }
            }
            Err(e) => self
                .engine
                .handle(Input::RecordingRefused(e.to_string()), link, now_us),
        }
        self.send_records();
    }

    /// Stops the recording: its encoder and writer are handed to a finisher thread (the
    /// encoder's last units, the summary and the sync take up to seconds the control
    /// loop must not spend); the view lists the file as being saved until it is. On
    /// virtual time (`record_blocking`) the file is finished before this returns.
    fn stop_recording(&mut self, link: &mut Link, now_us: u64) {
        link.set_record_frames(false);
        let Some(r) = self.recorder.take() else {
            return;
        };
        // The records of this recording go to its writer first.
        self.send_records();
        let encoder = self.video.as_ref().and_then(|v| v.detach_recording());
        self.finishers.start(r, encoder);
        self.engine.handle(Input::RecordingStopped, link, now_us);
        self.send_records();
        if self.engine.config().record_blocking {
            // Virtual time: no real-time loop to protect, and the run's next step may
            // read the file.
            self.wait_for_finishers(link, EXIT_WAIT, now_us);
        } else {
            self.show_finishing(link, now_us);
        }
    }

    /// The files being saved, to the engine (when the list changes).
    fn show_finishing(&mut self, link: &mut Link, now_us: u64) {
        if !self
            .finishing
            .iter()
            .map(PathBuf::as_path)
            .eq(self.finishers.paths())
        {
            self.finishing = self.finishers.paths().map(Path::to_path_buf).collect();
            let paths = std::mem::take(&mut self.finishing);
            self.engine.handle(Input::Finishing(&paths), link, now_us);
            self.finishing = paths;
        }
    }

    /// Takes in the recordings saved since the last call (each tick; never waits).
    fn poll_finishers(&mut self, link: &mut Link, now_us: u64) {
        if self.finishers.is_empty() && self.finishing.is_empty() {
            return;
        }
        let mut done = Vec::new();
        self.finishers.poll(|f| done.push(f));
        for f in done {
            self.saved(link, f, now_us);
        }
        self.show_finishing(link, now_us);
        self.send_records();
    }

    /// Waits for every recording being saved, at most `limit` in all.
    fn wait_for_finishers(&mut self, link: &mut Link, limit: std::time::Duration, now_us: u64) {
        let mut done = Vec::new();
        let left = self.finishers.wait_all(limit, |f| done.push(f));
        for f in done {
            self.saved(link, f, now_us);
        }
        for p in left {
            let e = format!(
                "{} was not finished within {} s; open it to recover what was written",
                file_name(&p),
                limit.as_secs()
            );
            self.engine.view_mut().recording.error = Some(e.clone());
            self.engine.event(now_us, "recording", Severity::Warning, e);
        }
        self.show_finishing(link, now_us);
        self.send_records();
    }

    fn saved(&mut self, link: &mut Link, f: Finished, now_us: u64) {
        let saved = Saved {
            path: f.path,
            result: f.result.map(|s| s.messages).map_err(|e| e.to_string()),
            video_error: f.video_error,
        };
        self.engine.handle(Input::Saved(saved), link, now_us);
    }
}

/// The model watch's state for the view.
fn watch_status(w: &StationWatch) -> WatchStatus {
    WatchStatus {
        running: w.running(),
        rows: w.rows,
        dropped_rows: w.dropped_rows,
        error: w.error.clone(),
    }
}
