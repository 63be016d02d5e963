//! [`Playback`]: a sans-IO player over a loaded session.
//!
//! The player keeps a position on the session's time axis (seconds since the first
//! message) and a cursor into the messages in time order. Wall time is an argument:
//! [`Playback::advance`] moves the position by `dt_wall_s × speed` while playing and
//! returns the messages passed, in time order, as a range of time-order positions
//! ([`Playback::advance_messages`] returns the messages themselves when the player
//! borrows the session). It reads no clock and does no I/O; the
//! station feeds what it returns into the same state pipeline the live link feeds.
//!
//! Semantics:
//!
//! * Every message is emitted exactly once between seeks, in time order. `advance` emits
//!   the messages with time < the new position (a message exactly at the position comes
//!   with the next advance or step).
//! * A new player is paused at 0 with speed 1×. Reaching the end pauses it.
//! * [`Playback::set_speed`] clamps to 0.1×–50× (non-finite values are ignored).
//! * [`Playback::seek`] moves the position (clamped to the session) and the cursor to the
//!   first message at or after it; nothing is emitted. Use
//!   [`Playback::latest_before`] to rebuild state at the new position.
//! * [`Playback::step`] pauses and emits the next single message, moving the position to
//!   its time.

use std::borrow::Borrow;
use std::ops::Range;

use crate::reader::{MessageRef, Session};

/// Slowest playback speed.
pub const MIN_SPEED: f64 = 0.1;
/// Fastest playback speed.
pub const MAX_SPEED: f64 = 50.0;

/// A sans-IO player. `S` is anything that borrows a [`Session`] (`&Session`,
/// `Arc<Session>`, `Session`).
#[derive(Debug, Clone)]
pub struct Playback<S: Borrow<Session>> {
    session: S,
    start_ns: u64,
    duration_ns: u64,
    /// Position, ns since the first message.
    position_ns: f64,
    /// Next message to emit (time-order position).
    cursor: usize,
    playing: bool,
    speed: f64,
}

impl<S: Borrow<Session>> Playback<S> {
    /// A paused player at the start, speed 1×.
    pub fn new(session: S) -> Self {
        let s: &Session = session.borrow();
        let start_ns = s.start_ns().unwrap_or(0);
        let duration_ns = s.end_ns().unwrap_or(0).saturating_sub(start_ns);
        Self {
            session,
            start_ns,
            duration_ns,
            position_ns: 0.0,
            cursor: 0,
            playing: false,
            speed: 1.0,
        }
    }

    /// The session.
    pub fn session(&self) -> &Session {
        self.session.borrow()
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

    /// Whether every message has been emitted.
    pub fn at_end(&self) -> bool {
        self.cursor >= self.session().len()
    }

    /// Index (time order) of the next message to emit.
    pub fn cursor(&self) -> usize {
        self.cursor
    }

    /// Moves to `t_s` seconds since the first message (clamped); emits nothing.
    pub fn seek(&mut self, t_s: f64) {
        let t = if t_s.is_finite() { t_s } else { 0.0 };
        let ns = (t * 1e9).clamp(0.0, self.duration_ns as f64);
        self.position_ns = ns;
        self.cursor = self
            .session()
            .lower_bound(self.start_ns.saturating_add(ns as u64));
    }

    /// Advances by `dt_wall_s` of wall time (× speed, only while playing) and returns the
    /// time-order positions of the messages passed (read them with
    /// [`Playback::messages`] or [`Session::message`]).
    pub fn advance(&mut self, dt_wall_s: f64) -> Range<usize> {
        let from = self.cursor;
        if !(self.playing && dt_wall_s.is_finite() && dt_wall_s > 0.0) {
            return from..from;
        }
        self.position_ns =
            (self.position_ns + dt_wall_s * self.speed * 1e9).min(self.duration_ns as f64 + 1.0);
        let s: &Session = self.session.borrow();
        let n = s.len();
        let limit = self.start_ns as f64 + self.position_ns;
        let mut to = from;
        while to < n && s.time_at(to).is_some_and(|t| (t as f64) < limit) {
            to += 1;
        }
        self.cursor = to;
        if to >= n {
            self.position_ns = self.duration_ns as f64;
            self.playing = false;
        }
        from..to
    }

    /// Pauses and emits the next message (its time-order position), moving the position to
    /// its time; `None` at the end.
    pub fn step(&mut self) -> Option<usize> {
        self.playing = false;
        let s: &Session = self.session.borrow();
        let t = s.time_at(self.cursor)?;
        let i = self.cursor;
        self.cursor += 1;
        self.position_ns = self.position_ns.max(t.saturating_sub(self.start_ns) as f64);
        Some(i)
    }

    /// The messages at a range of time-order positions (as returned by
    /// [`Playback::advance`]).
    pub fn messages(&self, range: Range<usize>) -> Vec<MessageRef<'_>> {
        let s = self.session();
        range.filter_map(|i| s.message(i)).collect()
    }

    /// For each topic, the last message before the cursor (what a pipeline needs to show
    /// the state at the position after a seek), in time order.
    pub fn latest_before(&self) -> Vec<MessageRef<'_>> {
        let s = self.session();
        let mut out: Vec<MessageRef<'_>> = Vec::new();
        for t in s.topics() {
            let positions = s.topic_positions(&t.topic);
            let n = positions.partition_point(|&p| (p as usize) < self.cursor);
            if let Some(m) = n
                .checked_sub(1)
                .and_then(|i| positions.get(i))
                .and_then(|&p| s.message(p as usize))
            {
                out.push(m);
            }
        }
        out.sort_by_key(|m| m.t_ns);
        out
    }
}

impl<'s> Playback<&'s Session> {
    /// [`Playback::advance`], returning the messages (borrowed from the session, not from
    /// the player).
    pub fn advance_messages(&mut self, dt_wall_s: f64) -> Vec<MessageRef<'s>> {
        let s: &'s Session = self.session;
        self.advance(dt_wall_s)
            .filter_map(|i| s.message(i))
            .collect()
    }

    /// [`Playback::step`], returning the message.
    pub fn step_message(&mut self) -> Option<MessageRef<'s>> {
        let s: &'s Session = self.session;
        self.step().and_then(|i| s.message(i))
    }
}
