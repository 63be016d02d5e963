//! [`Playback`]: a player over a session, on wall time given as an argument.
//!
//! The player keeps a position on the session's time axis (seconds since the first
//! message) and a stream of the messages from there on ([`crate::Messages`]: the chunks are
//! read as the position reaches them). Wall time is an argument: [`Playback::advance`]
//! moves the position by `dt_wall_s × speed` while playing and returns the messages passed,
//! in time order. It reads no clock; the station feeds what it returns into the same state
//! pipeline the live link feeds.
//!
//! Semantics:
//!
//! * Every message is emitted exactly once between seeks, in time order. `advance` emits
//!   the messages with time < the new position (a message exactly at the position comes
//!   with the next advance or step).
//! * A new player is paused at 0 with speed 1×. Reaching the end pauses it.
//! * [`Playback::set_speed`] clamps to 0.1×–50× (non-finite values are ignored).
//! * [`Playback::seek`] moves the position (clamped to the session) and restarts the stream
//!   at the first message at or after it; nothing is emitted. Use
//!   [`Playback::latest_before`] to rebuild state at the new position.
//! * [`Playback::step`] pauses and emits the next single message, moving the position to
//!   its time.

use crate::message::Message;
use crate::session::Session;
use crate::stream::{Messages, ReadOptions};

/// Slowest playback speed.
pub const MIN_SPEED: f64 = 0.1;
/// Fastest playback speed.
pub const MAX_SPEED: f64 = 50.0;

/// A player; see the module docs.
#[derive(Debug)]
pub struct Playback {
    session: Session,
    start_ns: u64,
    duration_ns: u64,
    /// Position, ns since the first message.
    position_ns: f64,
    /// The messages from the position on.
    stream: Messages,
    /// The next message to emit, taken from the stream.
    next: Option<Message>,
    /// Messages emitted since the last seek.
    emitted: u64,
    playing: bool,
    speed: f64,
}

impl Playback {
    /// A paused player at the start, speed 1×.
    pub fn new(session: Session) -> Self {
        let start_ns = session.start_ns().unwrap_or(0);
        let duration_ns = session.end_ns().unwrap_or(0).saturating_sub(start_ns);
        let stream = session.messages();
        Self {
            session,
            start_ns,
            duration_ns,
            position_ns: 0.0,
            stream,
            next: None,
            emitted: 0,
            playing: false,
            speed: 1.0,
        }
    }

    /// The session.
    pub fn session(&self) -> &Session {
        &self.session
    }

    /// Starts playing (from the end, it starts over from 0).
    pub fn play(&mut self) {
        if self.at_end() {
            self.seek(0.0);
        }
        self.playing = true;
    }

    /// Pauses.
    pub fn pause(&mut self) {
        self.playing = false;
    }

    /// Play if paused, pause if playing.
    pub fn toggle(&mut self) {
        if self.playing {
            self.pause()
        } else {
            self.play()
        }
    }

    /// Whether it is playing.
    pub fn is_playing(&self) -> bool {
        self.playing
    }

    /// Sets the speed, clamped to [`MIN_SPEED`]..=[`MAX_SPEED`]; returns the speed in force.
    pub fn set_speed(&mut self, speed: f64) -> f64 {
        if speed.is_finite() {
            self.speed = speed.clamp(MIN_SPEED, MAX_SPEED);
        }
        self.speed
    }

    /// The speed.
    pub fn speed(&self) -> f64 {
        self.speed
    }

    /// Position, s since the first message.
    pub fn position_s(&self) -> f64 {
        self.position_ns * 1e-9
    }

    /// Position as a message time (the writer's time base), ns.
    pub fn position_t_ns(&self) -> u64 {
        self.start_ns.saturating_add(self.position_ns as u64)
    }

    /// Duration, s.
    pub fn duration_s(&self) -> f64 {
        self.duration_ns as f64 * 1e-9
    }

    /// Messages emitted since the last seek (or the start).
    pub fn emitted(&self) -> u64 {
        self.emitted
    }

    fn peek(&mut self) -> Option<&Message> {
        if self.next.is_none() {
            self.next = self.stream.next();
        }
        self.next.as_ref()
    }

    /// Whether every message has been emitted.
    pub fn at_end(&mut self) -> bool {
        self.peek().is_none()
    }

    /// Moves to `t_s` seconds since the first message (clamped); emits nothing.
    pub fn seek(&mut self, t_s: f64) {
        let t = if t_s.is_finite() { t_s } else { 0.0 };
        let ns = (t * 1e9).clamp(0.0, self.duration_ns as f64);
        self.position_ns = ns;
        let from = self.start_ns.saturating_add(ns as u64);
        self.stream = self
            .session
            .read(ReadOptions::all().between(from, u64::MAX));
        self.next = None;
        self.emitted = 0;
    }

    /// Advances by `dt_wall_s` of wall time (× speed, only while playing) and returns the
    /// messages passed, in time order.
    pub fn advance(&mut self, dt_wall_s: f64) -> Vec<Message> {
        let mut out = Vec::new();
        if !(self.playing && dt_wall_s.is_finite() && dt_wall_s > 0.0) {
            return out;
        }
        self.position_ns =
            (self.position_ns + dt_wall_s * self.speed * 1e9).min(self.duration_ns as f64 + 1.0);
        let limit = self.start_ns as f64 + self.position_ns;
        while self.peek().is_some_and(|m| (m.t_ns as f64) < limit) {
            if let Some(m) = self.next.take() {
                out.push(m);
            }
        }
        self.emitted += out.len() as u64;
        if self.peek().is_none() {
            self.position_ns = self.duration_ns as f64;
            self.playing = false;
        }
        out
    }

    /// Pauses and emits the next message, moving the position to its time; `None` at the
    /// end.
    pub fn step(&mut self) -> Option<Message> {
        self.playing = false;
        self.peek()?;
        let m = self.next.take()?;
        self.emitted += 1;
        self.position_ns = self
            .position_ns
            .max(m.t_ns.saturating_sub(self.start_ns) as f64);
        Some(m)
    }

    /// For each topic, the last message before the next one to emit (what a pipeline needs
    /// to show the state at the position after a seek), in time order. Reads only the
    /// chunks that hold them.
    pub fn latest_before(&mut self) -> Vec<Message> {
        let until = match self.peek() {
            Some(m) => m.t_ns,
            None => self.session.end_ns().map_or(0, |e| e.saturating_add(1)),
        };
        self.session.latest_before(until)
    }

    /// What the read found so far (damage stops the player at the last good message).
    pub fn report(&self) -> crate::ReadReport {
        self.stream.report()
    }
}
