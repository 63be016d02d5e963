//! Replay: a recorded session played with `rov_session`'s [`Playback`] through the same
//! view [`Pipeline`] the live engine feeds, behind an ordinary [`StationHandle`]
//! ([`Source::Replay`] gives the GUI its REPLAY badge).
//!
//! * [`Runtime::replay`](crate::runtime::Runtime::replay) plays on wall time on its own
//!   thread; [`VirtualReplay`] is stepped by the caller (tests).
//! * The plots grow as the player advances, like a live session. A seek rebuilds the
//!   state from the last message of each topic before the new position, and replaces
//!   the plot history with the samples up to it (computed once when the file is opened).
//! * The model prediction is recomputed from the recorded thrust with the model the
//!   session recorded (or model3).

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::sync::mpsc::{Receiver, RecvTimeoutError, TryRecvError};
use std::time::{Duration, Instant};

use rov_control::{ModelChoice, ModelSet};
use rov_session::{Decoded, MessageRef, Playback, Session};

use crate::runtime::history::{History, HistorySample};
use crate::runtime::predict::{Anchor, Predictor};
use crate::runtime::view::{IndexedEvent, Pipeline, ReplayView, Source};
use crate::runtime::{
    ReplayCommand, RuntimeCommand, RuntimeError, Shared, StationHandle, command_channel, lock,
    spawn_named, try_lock,
};
use rov_driver::MonoClock;

/// Replays a session; see the module docs.
#[derive(Debug)]
pub(crate) struct ReplayEngine {
    session: Arc<Session>,
    player: Playback<Arc<Session>>,
    pipeline: Pipeline,
    predictor: Predictor,
    models: ModelSet,
    start_ns: u64,
    last_nav_s: Option<f64>,
    full: History,
    /// (t_s, turns, heading) at each navigation record, for seeks.
    turns: Vec<(f64, f64, Option<f64>)>,
    pending: Vec<HistorySample>,
    replace: Option<History>,
    warnings: Vec<String>,
    /// Every event of the session.
    index: Vec<IndexedEvent>,
    /// One control tick of the recording, s.
    tick_s: f64,
}

/// The control tick of a recording: the mean interval of its thrust commands (one per
/// tick), 20 ms when it has too few.
fn tick_of(session: &Session) -> f64 {
    let times: Vec<u64> = session
        .topic_messages(rov_session::record::TOPIC_THRUST)
        .map(|m| m.t_ns)
        .collect();
    match (times.first(), times.last()) {
        (Some(a), Some(b)) if times.len() > 10 && b > a => {
            (b - a) as f64 * 1e-9 / (times.len() - 1) as f64
        }
        _ => 0.02,
    }
}

/// Every event of a session, in time order (the replay's index).
fn index_of(session: &Session, start_ns: u64) -> Vec<IndexedEvent> {
    session
        .records::<rov_session::EventRecord>()
        .unwrap_or_default()
        .into_iter()
        .map(|(t, e)| IndexedEvent {
            t_s: t.saturating_sub(start_ns) as f64 * 1e-9,
            kind: e.kind,
            severity: e.severity,
            text: e.text,
        })
        .collect()
}

impl ReplayEngine {
    pub fn open(path: &Path, models: ModelSet) -> Result<Self, RuntimeError> {
        let session = Arc::new(rov_session::open(path)?);
        let start_ns = session.start_ns().unwrap_or(0);
        let mut warnings = session.warnings.clone();
        // Events come when something happens: a gap in /events is not a fault (the
        // reader's gap check is meant for the periodic topics).
        warnings.retain(|w| !w.starts_with("/events: "));
        if let Some(d) = session.damage() {
            warnings.push(format!(
                "the file is damaged ({d:?}); replaying what is intact"
            ));
        }
        let mut e = Self {
            session: Arc::clone(&session),
            player: Playback::new(Arc::clone(&session)),
            pipeline: Pipeline::new(Source::Replay(path.to_path_buf())),
            predictor: Predictor::default(),
            models,
            start_ns,
            last_nav_s: None,
            full: History::default(),
            turns: Vec::new(),
            pending: Vec::new(),
            replace: None,
            warnings,
            index: index_of(&session, start_ns),
            tick_s: tick_of(&session),
        };
        // One pass over the file: the full plot history and the turns at each sample.
        let mut pass = Self {
            session: Arc::clone(&session),
            player: Playback::new(Arc::clone(&session)),
            pipeline: Pipeline::new(Source::None),
            predictor: Predictor::default(),
            models: e.models.clone(),
            start_ns,
            last_nav_s: None,
            full: History::default(),
            turns: Vec::new(),
            pending: Vec::new(),
            replace: None,
            warnings: Vec::new(),
            index: Vec::new(),
            tick_s: 0.02,
        };
        let mut full = History::default();
        let mut turns = Vec::new();
        for m in session.messages() {
            if let Some(s) = pass.apply(&m) {
                full.push(&s);
                turns.push((
                    s.t_s,
                    pass.pipeline.view.turns,
                    pass.pipeline.view.snapshot.heading_deg,
                ));
            }
        }
        e.full = full;
        e.turns = turns;
        e.seek(0.0);
        Ok(e)
    }

    fn t_s(&self, t_ns: u64) -> f64 {
        t_ns.saturating_sub(self.start_ns) as f64 * 1e-9
    }

    /// Feeds one message; returns the plot sample of a navigation record.
    fn apply(&mut self, m: &MessageRef<'_>) -> Option<HistorySample> {
        let t_s = self.t_s(m.t_ns);
        let Ok(d) = m.decode_any() else {
            return None;
        };
        let p = &mut self.pipeline;
        match d {
            Decoded::Nav(r) => {
                p.nav(t_s, &r);
                let dt = self.last_nav_s.map_or(0.0, |t| t_s - t);
                self.last_nav_s = Some(t_s);
                let (w, rr) = p.observer_rates();
                let s = &p.view.snapshot;
                let anchor = Anchor {
                    depth_m: s.depth_estimate_m.or(s.depth_m),
                    w_mps: w,
                    heading_deg: s.heading_estimate_deg.or(s.heading_deg),
                    r_rad_s: rr,
                };
                let th = s.thrust;
                let choice = if p.view.feedforward {
                    p.view.model
                } else {
                    ModelChoice::Model3
                };
                p.view.prediction = self.predictor.step(
                    self.models.get(choice),
                    t_s,
                    dt,
                    &anchor,
                    [th.port_pct, th.starboard_pct, th.vertical_pct],
                );
                p.set_time(t_s);
                return Some(p.sample(t_s));
            }
            Decoded::Status(r) => p.status(&r),
            Decoded::Thrust(r) => p.thrust(&r),
            Decoded::Pilot(r) => p.pilot(&r),
            Decoded::Autopilot(r) => p.autopilot(&r),
            Decoded::Observer(r) => p.observer(&r),
            Decoded::Link(r) => p.link(t_s, &r),
            Decoded::Event(r) => p.event(t_s, &r),
            _ => {}
        }
        None
    }

    fn seek(&mut self, t_s: f64) {
        self.player.seek(t_s);
        let pos = self.player.position_s();
        let source = self.pipeline.view.source.clone();
        let events = std::mem::take(&mut self.pipeline.view.events);
        self.pipeline = Pipeline::new(source);
        self.pipeline.view.events = events;
        self.predictor.reset();
        self.last_nav_s = None;
        let session = Arc::clone(&self.session);
        let mut probe = Playback::new(&*session);
        probe.seek(pos);
        let latest = probe.latest_before();
        for m in &latest {
            let _ = self.apply(m);
        }
        let k = self.turns.partition_point(|(t, _, _)| *t <= pos);
        if let Some(&(_, turns, heading)) = k.checked_sub(1).and_then(|i| self.turns.get(i)) {
            self.pipeline.set_turns(turns, heading);
        }
        let r = self.full.range(f64::NEG_INFINITY, pos);
        let mut h = History::with_capacity(self.full.capacity());
        for i in r {
            if let Some(s) = self.full.sample(i) {
                h.push(&s);
            }
        }
        self.pending.clear();
        self.replace = Some(h);
        self.pipeline.set_time(pos);
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

    pub fn advance(&mut self, dt_wall_s: f64) {
        let range = self.player.advance(dt_wall_s);
        let session = Arc::clone(&self.session);
        for i in range {
            if let Some(m) = session.message(i)
                && let Some(s) = self.apply(&m)
            {
                self.pending.push(s);
            }
        }
        let pos = self.player.position_s();
        self.pipeline.set_time(pos);
    }

    pub fn publish(&mut self, shared: &Shared) {
        let v = &mut self.pipeline.view;
        v.seq += 1;
        v.replay = Some(ReplayView {
            position_s: self.player.position_s(),
            duration_s: self.player.duration_s(),
            playing: self.player.is_playing(),
            speed: self.player.speed(),
            messages: self.player.session().len(),
            warnings: self.warnings.clone(),
            index: self.index.clone(),
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

pub(crate) fn start(path: &Path, models: ModelSet) -> Result<StationHandle, RuntimeError> {
    let mut engine = ReplayEngine::open(path, models)?;
    let shared = Arc::new(Shared::new(20_000, MonoClock::new()));
    let (tx, rx) = command_channel();
    engine.publish(&shared);
    let s = Arc::clone(&shared);
    let t = spawn_named("station-replay", move || replay_loop(engine, &rx, &s))?;
    Ok(StationHandle::new(shared, tx, vec![t]))
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
    /// Opens a session paused at its start, and its handle.
    ///
    /// # Errors
    /// [`RuntimeError::Session`] if the file does not open.
    pub fn open(path: &Path) -> Result<(Self, StationHandle), RuntimeError> {
        let engine = ReplayEngine::open(path, ModelSet::load_default()?)?;
        let shared = Arc::new(Shared::new(20_000, MonoClock::new()));
        let (tx, rx) = command_channel();
        let mut v = Self {
            engine,
            rx,
            shared: Arc::clone(&shared),
            path: path.to_path_buf(),
        };
        v.engine.publish(&v.shared);
        Ok((v, StationHandle::new(shared, tx, Vec::new())))
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
