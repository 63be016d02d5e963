//! Replay: a recorded session played with `rov_session`'s [`Playback`] through the same
//! view [`Pipeline`] the live engine feeds, behind an ordinary [`StationHandle`]
//! ([`Source::Replay`] gives the GUI its REPLAY badge).
//!
//! * [`Runtime::replay`](crate::runtime::Runtime::replay) plays on wall time on its own
//!   thread; [`VirtualReplay`] is stepped by the caller (tests).
//! * Opening reads the file's index only (an 8-hour session opens in well under 2 s); the
//!   player reads the chunks as the position reaches them.
//! * The plots grow as the player advances, like a live session. The whole session's plot
//!   history (a decimated [`History`], bounded) and the tether-turn count at each second
//!   are computed by an indexing pass over the file: on a thread of its own for the
//!   threaded replay (the plots and turn counts of positions it has not reached yet come
//!   when it gets there), before opening returns for [`VirtualReplay`] (deterministic).
//! * A seek rebuilds the state from the last message of each topic before the new position
//!   (read backwards from it), and replaces the plot history with the samples up to it.
//! * The model prediction (the plots' overlay) is the model lab's engine along the
//!   session ([`rov_lab::engine::predict_series`]: the session read into runs like `lab
//!   compare` reads it, the model re-anchored to the measurement every [`HORIZON_S`]),
//!   with the feed-forward model of the session's first autopilot record (a base model,
//!   or a model file that is still readable; else model3), computed by the indexing pass
//!   before it reads the rest. Sessions longer than [`OVERLAY_MAX_S`] get no overlay
//!   (the lab holds a run in memory).
//! * The indexing pass also collects every event of the session (arm, disarm, holds,
//!   alarms, notes, markers): the Replay tab's clickable index. Step and step back move
//!   one control tick of the recording (its thrust commands' mean interval, from the
//!   file's summary), rebuilt like a seek.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, TryRecvError};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use rov_lab::engine::SeriesPrediction;
use rov_session::{Decoded, Message, Playback, ReadOptions, Session, Topic};
use rov_types::model_id::{BaseModel, ModelId};

use crate::pilot::dive::DiveLog;
use crate::pilot::history::{History, HistorySample};
pub use crate::pilot::predict::HORIZON_S;
use crate::pilot::view::{IndexedEvent, Pipeline, ReplayView, Source};
use crate::runtime::{
    ReplayCommand, RuntimeCommand, RuntimeError, Shared, StationHandle, command_channel, lock,
    spawn_named, try_lock,
};
use rov_driver::MonoClock;

/// Turn-count checkpoints are at least this far apart, s (a Pro 4 turns far less than
/// 180° in that time, so the count between two checkpoints follows from the headings).
const CHECKPOINT_S: f64 = 1.0;
/// The indexing pass publishes its progress every this much session time, s.
const PUBLISH_EVERY_S: f64 = 30.0;

/// The topics the view pipeline uses.
const PIPELINE_TOPICS: [Topic; 8] = [
    Topic::Nav,
    Topic::Status,
    Topic::Thrust,
    Topic::Pilot,
    Topic::Autopilot,
    Topic::Observer,
    Topic::Link,
    Topic::Events,
];

/// Longest session that gets a model overlay, s.
pub const OVERLAY_MAX_S: f64 = 3600.0;

/// The replay's model overlay: the engine's prediction along the session.
#[derive(Debug, Clone, Default)]
pub struct Overlay {
    /// The model's name (as the session named it, or `model3`).
    pub model: String,
    /// The prediction, on the measurement series' time base.
    pub prediction: SeriesPrediction,
    /// Session time (from the start) minus the series' time, s.
    pub offset_s: f64,
}

impl Overlay {
    /// The predicted (depth m, heading deg) at session time `t_s` (the measurement row
    /// at or before it, at most 0.5 s old).
    #[must_use]
    pub fn at(&self, t_s: f64) -> Option<(f64, f64)> {
        self.prediction.at(t_s - self.offset_s, 0.5)
    }
}

/// The model of the overlay: the feed-forward model of the first autopilot record that
/// names one, loaded by the one loader ([`rov_lab::load_model`]); model3 otherwise, with
/// a note saying why when the named model does not load.
fn overlay_model(
    session: &Session,
) -> Result<(String, rov_lab::LabModel, Option<String>), OverlayError> {
    let named = session
        .read(ReadOptions::topics(&[Topic::Autopilot.name()]))
        .filter_map(|m| match m.decode_any() {
            Ok(Decoded::Autopilot(r)) if !r.feedforward_model.is_empty() => {
                Some(r.feedforward_model)
            }
            _ => None,
        })
        .next();
    let mut note = None;
    if let Some(name) = named {
        let loaded = name
            .parse::<ModelId>()
            .map_err(NamedModelError::Name)
            .and_then(|id| {
                let text = match &id {
                    ModelId::Base(_) => None,
                    ModelId::File(p) => Some(std::fs::read_to_string(p).map_err(|source| {
                        NamedModelError::Read {
                            path: p.clone(),
                            source,
                        }
                    })?),
                };
                Ok(rov_lab::load_model(&id, text.as_deref())?)
            });
        match loaded {
            Ok(m) => return Ok((name, m, None)),
            Err(e) => {
                note = Some(format!(
                    "the session's model {name} does not load ({e}); the overlay shows model3"
                ));
            }
        }
    }
    let m3 = rov_lab::load_model(&ModelId::Base(BaseModel::Model3), None)?;
    Ok(("model3".to_string(), m3, note))
}

/// The replay's model overlay of a session (see the module docs) and a note when the
/// session's own model was replaced by model3, or why there is no overlay.
///
/// # Errors
/// [`OverlayError`]: the session is too long, its measurements do not read, or the
/// model does not load or run.
pub fn model_overlay(session: &Session) -> Result<(Overlay, Option<String>), OverlayError> {
    if session.duration_s() > OVERLAY_MAX_S {
        return Err(OverlayError::TooLong {
            max_h: OVERLAY_MAX_S / 3600.0,
        });
    }
    let (name, model, note) = overlay_model(session)?;
    let (series, times_ns, _) = rov_session::measurements(session)?;
    let start_ns = session.start_ns().unwrap_or(0);
    let offset_s = match (series.rows.first(), times_ns.first()) {
        (Some(r), Some(ns)) => ns.saturating_sub(start_ns) as f64 * 1e-9 - r.time_s,
        _ => 0.0,
    };
    let prediction = rov_lab::engine::predict_series(&model, &series, &name, HORIZON_S)?;
    Ok((
        Overlay {
            model: name,
            prediction,
            offset_s,
        },
        note,
    ))
}

/// Why the session's own model does not load (the overlay then shows model3, and a
/// note says why).
#[derive(Debug, thiserror::Error)]
enum NamedModelError {
    /// The recorded name is not a model name.
    #[error(transparent)]
    Name(#[from] rov_types::ModelIdError),
    /// The recorded model file cannot be read here.
    #[error("cannot read {}: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// The lab does not load it.
    #[error(transparent)]
    Load(#[from] rov_lab::LabError),
}

/// Why a replay has no model overlay (the replay goes on without).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OverlayError {
    /// The session is longer than the overlay is computed for.
    #[error("no model overlay: the session is longer than {max_h:.0} h")]
    TooLong {
        /// The limit, hours.
        max_h: f64,
    },
    /// The session's measurements do not read.
    #[error("no model overlay: {0}")]
    Session(#[from] rov_session::SessionError),
    /// The model does not load or its prediction fails.
    #[error("no model overlay: {0}")]
    Lab(#[from] rov_lab::LabError),
}

/// The pipeline fed with recorded messages, and the model prediction.
#[derive(Debug)]
struct Feed {
    pipeline: Pipeline,
    overlay: Option<Arc<Overlay>>,
    start_ns: u64,
    /// The dive log over the recorded depth, as the live station kept it (issue 25: the
    /// replayed dive panel said "at the surface" at 5 m because nothing fed it).
    dive: DiveLog,
}

impl Feed {
    fn new(source: Source, start_ns: u64) -> Self {
        Self {
            pipeline: Pipeline::new(source),
            overlay: None,
            start_ns,
            dive: DiveLog::default(),
        }
    }

    fn t_s(&self, t_ns: u64) -> f64 {
        t_ns.saturating_sub(self.start_ns) as f64 * 1e-9
    }

    /// Feeds one message; returns the plot sample of a navigation record.
    fn apply(&mut self, m: &Message) -> Option<HistorySample> {
        let t_s = self.t_s(m.t_ns);
        let Ok(d) = m.decode_any() else {
            return None;
        };
        let p = &mut self.pipeline;
        match d {
            Decoded::Nav(r) => {
                p.nav(t_s, &r);
                let _ = self.dive.update(t_s, p.view.snapshot.depth_m);
                let counts = (p.view.dive.markers, p.view.dive.notes);
                p.view.dive = self.dive.view();
                (p.view.dive.markers, p.view.dive.notes) = counts;
                p.view.prediction = self.overlay.as_ref().and_then(|o| o.at(t_s));
                p.set_time(t_s);
                return Some(p.sample(t_s));
            }
            Decoded::Status(r) => p.status(&r),
            Decoded::Thrust(r) => p.thrust(&r),
            Decoded::Pilot(r) => p.pilot(&r),
            Decoded::Autopilot(r) => p.autopilot(&r),
            Decoded::Observer(r) => p.observer(&r),
            Decoded::Link(r) => p.link(t_s, &r),
            Decoded::Event(r) => {
                match r.kind.as_str() {
                    "marker" => p.view.dive.markers += 1,
                    "note" => p.view.dive.notes += 1,
                    _ => {}
                }
                p.event(t_s, &r);
            }
            _ => {}
        }
        None
    }

    /// The dive log at `pos_s` from the session's depth history up to there and its
    /// markers and notes.
    fn rebuild_dive(&mut self, history: &History, pos_s: f64, events: &[IndexedEvent]) {
        self.dive = DiveLog::default();
        for i in history.range(f64::NEG_INFINITY, pos_s) {
            if let Some(s) = history.sample(i) {
                let d = f64::from(s.depth_m);
                let _ = self.dive.update(s.t_s, d.is_finite().then_some(d));
            }
        }
        let v = &mut self.pipeline.view;
        v.dive = self.dive.view();
        let before = events.iter().filter(|e| e.t_s <= pos_s);
        let (mut markers, mut notes) = (0, 0);
        for e in before {
            match e.kind.as_str() {
                "marker" => markers += 1,
                "note" => notes += 1,
                _ => {}
            }
        }
        (v.dive.markers, v.dive.notes) = (markers, notes);
    }
}

/// What the indexing pass has computed so far.
#[derive(Debug, Default)]
struct IndexState {
    /// The whole session's plot history up to `progress_s`.
    full: History,
    /// (t_s, turns, heading) at navigation records at least [`CHECKPOINT_S`] apart.
    checkpoints: Vec<(f64, f64, Option<f64>)>,
    /// Every event of the session indexed so far, in time order.
    events: Vec<IndexedEvent>,
    /// Session time indexed so far, s.
    progress_s: f64,
    done: bool,
    /// The model overlay, once computed (first thing the pass does).
    overlay: Option<Arc<Overlay>>,
    /// Why there is no overlay, or what replaced the session's model.
    overlay_note: Option<String>,
}

/// The control tick of a recording: the mean interval of its thrust commands (one per
/// tick), from the summary; 20 ms when it has too few.
fn tick_of(session: &Session) -> f64 {
    session
        .topics()
        .into_iter()
        .find(|t| t.known == Some(Topic::Thrust))
        .filter(|t| t.count > 10 && t.last_ns > t.first_ns)
        .map_or(0.02, |t| {
            (t.last_ns - t.first_ns) as f64 * 1e-9 / (t.count - 1) as f64
        })
}

/// The indexing pass; see the module docs.
fn index_session(session: &Session, state: &Mutex<IndexState>, cancel: &AtomicBool) {
    let start_ns = session.start_ns().unwrap_or(0);
    let mut feed = Feed::new(Source::None, start_ns);
    let (overlay, note) = match model_overlay(session) {
        Ok((o, note)) => (Some(Arc::new(o)), note),
        Err(e) => (None, Some(e.to_string())),
    };
    feed.overlay.clone_from(&overlay);
    // `lock`: a poisoned index (a panic while publishing) is still read, not dropped.
    {
        let mut g = lock(state);
        g.overlay = overlay;
        g.overlay_note = note;
    }
    let names: Vec<&str> = PIPELINE_TOPICS.iter().map(|t| t.name()).collect();
    let mut batch: Vec<HistorySample> = Vec::new();
    let mut events: Vec<IndexedEvent> = Vec::new();
    let mut checkpoints: Vec<(f64, f64, Option<f64>)> = Vec::new();
    let mut last_cp = f64::NEG_INFINITY;
    let mut last_publish = 0.0;
    let mut t_now = 0.0;
    let publish = |batch: &mut Vec<HistorySample>,
                   cps: &mut Vec<(f64, f64, Option<f64>)>,
                   evs: &mut Vec<IndexedEvent>,
                   t: f64,
                   done: bool| {
        {
            let mut g = lock(state);
            for s in batch.drain(..) {
                g.full.push(&s);
            }
            g.checkpoints.append(cps);
            g.events.append(evs);
            g.progress_s = g.progress_s.max(t);
            g.done = done;
        }
    };
    for m in session.read(ReadOptions::topics(&names)) {
        if cancel.load(Ordering::Relaxed) {
            return;
        }
        t_now = feed.t_s(m.t_ns);
        if m.known() == Some(Topic::Events)
            && let Ok(Decoded::Event(e)) = m.decode_any()
        {
            events.push(IndexedEvent {
                t_s: t_now,
                kind: e.kind.clone(),
                severity: e.severity,
                text: e.text.clone(),
            });
        }
        if let Some(s) = feed.apply(&m) {
            batch.push(s);
            if s.t_s - last_cp >= CHECKPOINT_S {
                last_cp = s.t_s;
                let v = &feed.pipeline.view;
                checkpoints.push((s.t_s, v.turns, v.snapshot.heading_deg));
            }
        }
        if t_now - last_publish >= PUBLISH_EVERY_S {
            last_publish = t_now;
            publish(&mut batch, &mut checkpoints, &mut events, t_now, false);
        }
    }
    publish(&mut batch, &mut checkpoints, &mut events, t_now, true);
}

/// Replays a session; see the module docs.
#[derive(Debug)]
pub(crate) struct ReplayEngine {
    player: Playback,
    feed: Feed,
    index: Arc<Mutex<IndexState>>,
    cancel: Arc<AtomicBool>,
    indexer: Option<JoinHandle<()>>,
    /// The plot history given at the last seek is partial (not yet indexed there).
    stale_history: bool,
    pending: Vec<HistorySample>,
    replace: Option<History>,
    warnings: Vec<String>,
    /// One control tick of the recording, s.
    tick_s: f64,
    /// The recorded video, shown at the play-head (see `video_replay`).
    video: Arc<crate::runtime::video::StationVideo>,
    start_ns: u64,
}

impl Drop for ReplayEngine {
    fn drop(&mut self) {
        self.cancel.store(true, Ordering::Relaxed);
        if let Some(j) = self.indexer.take() {
            crate::runtime::join_or_warn(j);
        }
    }
}

impl ReplayEngine {
    /// Opens a session; `background`: index on a thread of its own (else before returning).
    pub fn open(path: &Path, background: bool) -> Result<Self, RuntimeError> {
        let session = rov_session::open(path)?;
        let start_ns = session.start_ns().unwrap_or(0);
        let mut warnings = session.warnings().to_vec();
        // Events come when something happens: a gap in /events is not a fault (the
        // reader's gap check is meant for the periodic topics).
        warnings.retain(|w| !w.starts_with("/events: "));
        let tick_s = tick_of(&session);
        if let Some(d) = session.damage() {
            warnings.push(format!(
                "the file is damaged ({d}); replaying what is intact"
            ));
        }
        let index = Arc::new(Mutex::new(IndexState::default()));
        let cancel = Arc::new(AtomicBool::new(false));
        let indexer = if background {
            let (s, st, c) = (session.clone(), Arc::clone(&index), Arc::clone(&cancel));
            Some(spawn_named("station-replay-index", move || {
                index_session(&s, &st, &c);
            })?)
        } else {
            index_session(&session, &index, &cancel);
            None
        };
        let video = Arc::new(crate::runtime::video::StationVideo::replay(session.clone()));
        let mut e = Self {
            video,
            start_ns,
            player: Playback::new(session),
            feed: Feed::new(Source::Replay(path.to_path_buf()), start_ns),
            index,
            cancel,
            indexer,
            stale_history: false,
            pending: Vec::new(),
            replace: None,
            warnings,
            tick_s,
        };
        e.seek(0.0);
        Ok(e)
    }

    fn seek(&mut self, t_s: f64) {
        self.player.seek(t_s);
        let pos = self.player.position_s();
        let source = self.feed.pipeline.view.source.clone();
        let events = std::mem::take(&mut self.feed.pipeline.view.events);
        self.feed.pipeline = Pipeline::new(source);
        self.feed.pipeline.view.events = events;
        self.take_overlay();
        let latest = self.player.latest_before();
        for m in &latest {
            let _ = self.feed.apply(m);
        }
        let last_nav = latest
            .iter()
            .rev()
            .find(|m| m.known() == Some(Topic::Nav))
            .map(|m| self.feed.t_s(m.t_ns));
        let h = {
            let g = lock(&self.index);
            let indexed = g.done || g.progress_s >= pos;
            // Tether turns at the last navigation record: from the checkpoint before it.
            if let Some(t_nav) = last_nav
                && indexed
            {
                let k = g.checkpoints.partition_point(|(t, _, _)| *t <= t_nav);
                if let Some(&(_, turns, heading)) =
                    k.checked_sub(1).and_then(|i| g.checkpoints.get(i))
                {
                    let now = self.feed.pipeline.view.snapshot.heading_deg;
                    let extra = match (heading, now) {
                        (Some(a), Some(b)) => rov_types::angle::wrap_deg_180(b - a) / 360.0,
                        _ => 0.0,
                    };
                    self.feed.pipeline.set_turns(turns + extra, now);
                }
            }
            let mut h = History::with_capacity(g.full.capacity());
            for i in g.full.range(f64::NEG_INFINITY, pos) {
                if let Some(s) = g.full.sample(i) {
                    h.push(&s);
                }
            }
            self.stale_history = !indexed;
            self.feed.rebuild_dive(&h, pos, &g.events);
            h
        };
        self.pending.clear();
        self.replace = Some(h);
        self.feed.pipeline.set_time(pos);
    }

    pub fn command(&mut self, c: ReplayCommand) {
        match c {
            ReplayCommand::Play => self.player.play(),
            ReplayCommand::Pause => self.player.pause(),
            ReplayCommand::Toggle => {
                if self.player.at_end() {
                    self.seek(0.0);
                }
                self.player.toggle();
            }
            ReplayCommand::Speed(x) => {
                self.player.set_speed(x);
            }
            ReplayCommand::Seek(t) => self.seek(t),
            ReplayCommand::Step | ReplayCommand::StepBack => {
                // One control tick: the state at the new position is rebuilt like a
                // seek (the last message of each topic before it).
                self.player.pause();
                let dir = if c == ReplayCommand::Step { 1.0 } else { -1.0 };
                let to = (self.player.position_s() + dir * self.tick_s)
                    .clamp(0.0, self.player.duration_s());
                self.seek(to);
            }
        }
    }

    /// The overlay from the indexing pass, once it has computed it.
    fn take_overlay(&mut self) {
        if self.feed.overlay.is_none()
            && let Some(g) = try_lock(&self.index)
        {
            self.feed.overlay.clone_from(&g.overlay);
        }
    }

    pub fn advance(&mut self, dt_wall_s: f64) {
        self.take_overlay();
        for m in self.player.advance(dt_wall_s) {
            if let Some(s) = self.feed.apply(&m) {
                self.pending.push(s);
            }
        }
        let pos = self.player.position_s();
        self.feed.pipeline.set_time(pos);
        // The indexing pass finished after a seek it had not reached: the full history up
        // to the position replaces the partial one.
        if self.stale_history
            && let Some(g) = try_lock(&self.index)
            && g.done
        {
            let mut h = History::with_capacity(g.full.capacity());
            for i in g.full.range(f64::NEG_INFINITY, pos) {
                if let Some(s) = g.full.sample(i) {
                    h.push(&s);
                }
            }
            drop(g);
            self.pending.clear();
            self.replace = Some(h);
            self.stale_history = false;
        }
    }

    pub fn publish(&mut self, shared: &Shared) {
        let mut warnings = self.warnings.clone();
        if let Some(d) = self.player.report().damage
            && !warnings.iter().any(|w| w.contains("damaged"))
        {
            warnings.push(format!(
                "the file is damaged ({d}); replaying what is intact"
            ));
        }
        let index = {
            let g = lock(&self.index);
            if let Some(n) = &g.overlay_note {
                warnings.push(n.clone());
            }
            g.events.clone()
        };
        let (position_s, duration_s, playing, speed, messages) = (
            self.player.position_s(),
            self.player.duration_s(),
            self.player.is_playing(),
            self.player.speed(),
            self.player.session().len(),
        );
        self.video.show_at(
            self.start_ns
                .saturating_add((position_s.max(0.0) * 1e9).round() as u64),
        );
        let v = &mut self.feed.pipeline.view;
        v.seq += 1;
        v.replay = Some(ReplayView {
            position_s,
            duration_s,
            playing,
            speed,
            messages,
            warnings,
            index,
            tick_s: self.tick_s,
        });
        if let Some(mut g) = try_lock(&shared.view) {
            g.clone_from(v);
        }
        if let Some(mut f) = try_lock(&shared.feed) {
            if let Some(h) = self.replace.take() {
                f.replace(h);
            }
            f.extend(self.pending.drain(..));
        }
    }
}

pub(crate) fn start(path: &Path) -> Result<StationHandle, RuntimeError> {
    let mut engine = ReplayEngine::open(path, true)?;
    let shared = Arc::new(Shared::new(20_000, MonoClock::new()));
    let (tx, rx) = command_channel();
    engine.publish(&shared);
    let video = Arc::clone(&engine.video);
    let s = Arc::clone(&shared);
    let t = spawn_named("station-replay", move || replay_loop(engine, &rx, &s))?;
    Ok(StationHandle::new(shared, tx, vec![t]).with_video(video))
}

fn replay_loop(mut engine: ReplayEngine, rx: &Receiver<RuntimeCommand>, shared: &Shared) {
    let mut last = Instant::now();
    while shared.running.load(Ordering::Relaxed) {
        match rx.recv_timeout(Duration::from_millis(20)) {
            Ok(RuntimeCommand::Replay(c)) => engine.command(c),
            Ok(RuntimeCommand::Shutdown) | Err(RecvTimeoutError::Disconnected) => break,
            Ok(_) | Err(RecvTimeoutError::Timeout) => {}
        }
        loop {
            match rx.try_recv() {
                Ok(RuntimeCommand::Replay(c)) => engine.command(c),
                Ok(RuntimeCommand::Shutdown) => {
                    shared.running.store(false, Ordering::Relaxed);
                    break;
                }
                Ok(_) => {}
                Err(TryRecvError::Empty | TryRecvError::Disconnected) => break,
            }
        }
        let now = Instant::now();
        engine.advance(now.duration_since(last).as_secs_f64());
        last = now;
        engine.publish(shared);
        lock(&shared.ticks).record(0, 0);
    }
    shared.running.store(false, Ordering::Relaxed);
}

/// A replay stepped by the caller (deterministic; for tests).
#[derive(Debug)]
pub struct VirtualReplay {
    engine: ReplayEngine,
    rx: Receiver<RuntimeCommand>,
    shared: Arc<Shared>,
    path: PathBuf,
}

impl VirtualReplay {
    /// Opens a session paused at its start (indexed before this returns), and its handle.
    ///
    /// # Errors
    /// [`RuntimeError::Session`] if the file does not open.
    pub fn open(path: &Path) -> Result<(Self, StationHandle), RuntimeError> {
        let engine = ReplayEngine::open(path, false)?;
        let video = Arc::clone(&engine.video);
        let shared = Arc::new(Shared::new(20_000, MonoClock::new()));
        let (tx, rx) = command_channel();
        let mut v = Self {
            engine,
            rx,
            shared: Arc::clone(&shared),
            path: path.to_path_buf(),
        };
        v.engine.publish(&v.shared);
        Ok((
            v,
            StationHandle::new(shared, tx, Vec::new()).with_video(video),
        ))
    }

    /// The file.
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Applies the queued commands, advances by `dt_wall_s` (× speed while playing) and
    /// publishes.
    pub fn advance(&mut self, dt_wall_s: f64) {
        while let Ok(c) = self.rx.try_recv() {
            if let RuntimeCommand::Replay(c) = c {
                self.engine.command(c);
            }
        }
        self.engine.advance(dt_wall_s);
        self.engine.publish(&self.shared);
    }
}
