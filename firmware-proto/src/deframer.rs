//! Streaming deframer (protocol.md §12.4): bytes in chunks of any size in,
//! [`Frame`]s and typed [`DeframeError`]s out.
//!
//! # Behaviour
//!
//! The deframer keeps unconsumed bytes in a fixed internal array and scans it:
//!
//! 1. Bytes that cannot start a valid sync pair (`FA AF` or `FD DF`; mixed pairs
//!    `FA DF`/`FD AF` are rejected) are skipped. A run of them is reported once,
//!    as one [`DeframeErrorKind::BadSync`] event, when the run ends.
//! 2. On a header-check, extended-length-check, overlong or total-check failure
//!    exactly **one** byte (the candidate's first) is dropped and the scan restarts
//!    at the next byte, so a frame that starts inside a rejected candidate is
//!    still found, and one corrupted byte costs at most its own frame.
//! 3. A valid frame of a direction that is not accepted (an echo) is consumed
//!    whole and reported as [`DeframeErrorKind::WrongDirection`].
//! 4. If a candidate is still incomplete when the line has been quiet for longer
//!    than the gap limit (default [`DEFAULT_GAP_US`] = 10 ms, measured from the
//!    last byte received), the buffered bytes are treated as a finished burst:
//!    frames inside them are still delivered, every incomplete candidate loses
//!    its first byte with a [`DeframeErrorKind::Stall`] error. Time is always an
//!    argument (`now_us`); the deframer never reads a clock.
//!
//! The event sequence does not depend on how the input is split into chunks
//! (as long as the timestamps do not trigger a stall).
//!
//! # Memory
//!
//! `Deframer<N>` owns a `[u8; N]` buffer and nothing else; it never allocates.
//! `N` must be at least [`MAX_NORMAL_FRAME_LEN`] (262); the extended-length cap is
//! `min(config.max_ext_len, N - 11)`, so the default `N` =
//! [`DEFAULT_CAPACITY`] (2048) holds the largest default frame,
//! [`MAX_FRAME_LEN`] = 7 + 3 + 1024 + 1 = 1035 bytes. Frames are handed out
//! borrowing the buffer (no copy); the borrow ends before the next call.
//!
//! # Example: vehicle side
//!
//! ```
//! use firmware_proto::{Deframer, Event};
//!
//! let mut rx = Deframer::vehicle(); // accepts requests (FA AF) only
//! let mut input: &[u8] = &[0x00, 0x13, 0xFA, 0xAF, 0x01, 0x01, 0x00, 0x00, 0x55, 0x00];
//! let mut frames = 0;
//! while let Some(event) = rx.feed(&mut input, 0) {
//!     match event {
//!         Event::Frame { frame, offset } => {
//!             assert_eq!((frame.flags(), offset), (0x01, 2));
//!             frames += 1;
//!         }
//!         Event::Error(err) => assert_eq!((err.offset, err.len), (0, 2)),
//!     }
//! }
//! assert_eq!(frames, 1);
//! ```

use core::fmt;

use crate::error::FrameError;
#[cfg(doc)]
use crate::frame::MAX_FRAME_LEN;
use crate::frame::{
    Direction, EXT_HEADER_LEN, Frame, FrameInfo, MAX_EXTENDED_PAYLOAD_LEN, MAX_NORMAL_FRAME_LEN,
    SYNC_REQUEST, SYNC_RESPONSE, parse_info,
};

/// Default buffer capacity: holds the largest default frame ([`MAX_FRAME_LEN`])
/// with room to spare.
pub const DEFAULT_CAPACITY: usize = 2048;

/// Default inter-byte gap limit: 10 ms (protocol.md §8, our choice).
pub const DEFAULT_GAP_US: u64 = 10_000;

/// Which frame directions a deframer delivers; the others are reported as
/// [`DeframeErrorKind::WrongDirection`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
pub enum Accept {
    /// Requests only (`FA AF`): the vehicle side.
    Requests,
    /// Responses only (`FD DF`): the host side.
    Responses,
    /// Both directions: bus monitors and tools.
    Both,
}

impl Accept {
    /// True if frames of `direction` are delivered.
    #[must_use]
    pub const fn accepts(self, direction: Direction) -> bool {
        matches!(
            (self, direction),
            (Self::Both, _)
                | (Self::Requests, Direction::Request)
                | (Self::Responses, Direction::Response)
        )
    }
}

/// Deframer settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
pub struct DeframerConfig {
    /// Directions delivered.
    pub accept: Accept,
    /// A partial frame older than this (µs since the last byte) is abandoned.
    pub gap_us: u64,
    /// Extended lengths above this are corruption ([`DeframeErrorKind::Overlong`]).
    /// Clamped to `N - 11` by the deframer.
    pub max_ext_len: usize,
}

impl DeframerConfig {
    /// Host side: responses only, 10 ms gap, 1024-byte extended cap.
    #[must_use]
    pub const fn host() -> Self {
        Self::new(Accept::Responses)
    }

    /// Vehicle side: requests only, 10 ms gap, 1024-byte extended cap.
    #[must_use]
    pub const fn vehicle() -> Self {
        Self::new(Accept::Requests)
    }

    /// Both directions, default gap and cap.
    #[must_use]
    pub const fn new(accept: Accept) -> Self {
        Self {
            accept,
            gap_us: DEFAULT_GAP_US,
            max_ext_len: MAX_EXTENDED_PAYLOAD_LEN,
        }
    }

    /// With another gap limit.
    #[must_use]
    pub const fn with_gap_us(mut self, gap_us: u64) -> Self {
        self.gap_us = gap_us;
        self
    }

    /// With another extended-length cap.
    #[must_use]
    pub const fn with_max_ext_len(mut self, max_ext_len: usize) -> Self {
        self.max_ext_len = max_ext_len;
        self
    }
}

impl Default for DeframerConfig {
    /// Both directions, default gap and cap.
    fn default() -> Self {
        Self::new(Accept::Both)
    }
}

/// Class of a deframing error. Every class except `BadSync` and `WrongDirection`
/// drops exactly one byte.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
#[non_exhaustive]
pub enum DeframeErrorKind {
    /// A run of bytes that cannot start a valid sync pair (line noise, mixed
    /// pairs, remains of a rejected candidate).
    BadSync,
    /// Header check mismatch.
    HeaderCheck,
    /// Extended-length check mismatch.
    ExtLengthCheck,
    /// Extended length above the cap.
    Overlong,
    /// Total (payload) check mismatch.
    TotalCheck,
    /// An incomplete candidate abandoned after the gap limit.
    Stall,
    /// An incomplete candidate abandoned by [`Deframer::finish`].
    Truncated,
    /// A valid frame of a direction that is not accepted (e.g. an echo).
    WrongDirection,
}

impl DeframeErrorKind {
    /// Short lowercase description.
    #[must_use]
    pub const fn as_str(self) -> &'static str {
        match self {
            Self::BadSync => "bad sync",
            Self::HeaderCheck => "header check mismatch",
            Self::ExtLengthCheck => "extended-length check mismatch",
            Self::Overlong => "extended length over the cap",
            Self::TotalCheck => "total check mismatch",
            Self::Stall => "partial frame stalled",
            Self::Truncated => "truncated frame",
            Self::WrongDirection => "frame of the wrong direction",
        }
    }
}

impl fmt::Display for DeframeErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A stretch of input the deframer dropped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct DeframeError {
    /// Why.
    pub kind: DeframeErrorKind,
    /// Stream offset of the first dropped byte (bytes taken since creation or
    /// the last [`Deframer::reset_counters`]).
    pub offset: u64,
    /// Number of bytes dropped.
    pub len: u64,
}

impl fmt::Display for DeframeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} at stream offset {} ({} byte{} dropped)",
            self.kind,
            self.offset,
            self.len,
            if self.len == 1 { "" } else { "s" }
        )
    }
}

impl core::error::Error for DeframeError {}

/// Output of the deframer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Event<'a> {
    /// A valid frame of an accepted direction, borrowing the deframer's buffer.
    Frame {
        /// The frame.
        frame: Frame<'a>,
        /// Stream offset of its first byte.
        offset: u64,
    },
    /// Dropped input.
    Error(DeframeError),
}

/// Running totals. Each error class that drops one byte counts events (= bytes);
/// `garbage_bytes` counts bytes.
///
/// Invariant: `bytes_in == frame_bytes + bytes_discarded() + buffered`, where
/// `buffered` is [`Deframer::buffered_len`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Counters {
    /// Bytes taken from the input.
    pub bytes_in: u64,
    /// Frames delivered.
    pub frames_ok: u64,
    /// Bytes in delivered frames.
    pub frame_bytes: u64,
    /// Bytes skipped while hunting for a sync pair.
    pub garbage_bytes: u64,
    /// Header check failures.
    pub header_check: u64,
    /// Extended-length check failures.
    pub ext_len_check: u64,
    /// Extended lengths over the cap.
    pub overlong: u64,
    /// Total (payload) check failures.
    pub total_check: u64,
    /// Incomplete candidates abandoned after the gap limit.
    pub stall: u64,
    /// Incomplete candidates abandoned by [`Deframer::finish`].
    pub truncated: u64,
    /// Valid frames of a direction that is not accepted.
    pub wrong_direction: u64,
    /// Bytes in those frames.
    pub wrong_direction_bytes: u64,
    /// Bytes thrown away by [`Deframer::reset`].
    pub reset_bytes: u64,
}

impl Counters {
    /// Every byte dropped for any reason.
    #[must_use]
    pub const fn bytes_discarded(&self) -> u64 {
        self.garbage_bytes
            + self.single_byte_errors()
            + self.wrong_direction_bytes
            + self.reset_bytes
    }

    /// Error events that dropped one byte each (header, extended length,
    /// overlong, total, stall, truncated).
    #[must_use]
    pub const fn single_byte_errors(&self) -> u64 {
        self.header_check
            + self.ext_len_check
            + self.overlong
            + self.total_check
            + self.stall
            + self.truncated
    }
}

/// Why buffered bytes are being flushed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Drain {
    Stall,
    EndOfInput,
}

/// Outcome of one scan step, without borrowing the buffer.
enum Step {
    Frame { info: FrameInfo, offset: u64 },
    Error(DeframeError),
    NeedMore,
}

/// The streaming deframer. See the [module documentation](self).
#[derive(Clone)]
pub struct Deframer<const N: usize = DEFAULT_CAPACITY> {
    buf: [u8; N],
    /// Unconsumed bytes are `buf[start..end]`.
    start: usize,
    end: usize,
    config: DeframerConfig,
    max_ext_len: usize,
    counters: Counters,
    last_rx_us: u64,
    drain: Option<Drain>,
    /// A run of skipped bytes not yet reported: (offset, len).
    pending_garbage: Option<(u64, u64)>,
}

impl Deframer<DEFAULT_CAPACITY> {
    /// A deframer with the default capacity.
    #[must_use]
    pub const fn new(config: DeframerConfig) -> Self {
        Self::with_config(config)
    }

    /// Host side: delivers responses, reports requests as wrong-direction.
    #[must_use]
    pub const fn host() -> Self {
        Self::with_config(DeframerConfig::host())
    }

    /// Vehicle side: delivers requests, reports responses as wrong-direction.
    #[must_use]
    pub const fn vehicle() -> Self {
        Self::with_config(DeframerConfig::vehicle())
    }
}

impl<const N: usize> Deframer<N> {
    /// A deframer with capacity `N` (checked at compile time: `N` ≥ 262).
    #[must_use]
    pub const fn with_config(config: DeframerConfig) -> Self {
        const {
            assert!(
                N >= MAX_NORMAL_FRAME_LEN,
                "Deframer capacity must hold a 262-byte normal frame"
            );
        }
        let room = N - EXT_HEADER_LEN - 1;
        let max_ext_len = if config.max_ext_len < room {
            config.max_ext_len
        } else {
            room
        };
        Self {
            buf: [0; N],
            start: 0,
            end: 0,
            config,
            max_ext_len,
            counters: Counters {
                bytes_in: 0,
                frames_ok: 0,
                frame_bytes: 0,
                garbage_bytes: 0,
                header_check: 0,
                ext_len_check: 0,
                overlong: 0,
                total_check: 0,
                stall: 0,
                truncated: 0,
                wrong_direction: 0,
                wrong_direction_bytes: 0,
                reset_bytes: 0,
            },
            last_rx_us: 0,
            drain: None,
            pending_garbage: None,
        }
    }

    /// The configuration.
    #[must_use]
    pub const fn config(&self) -> &DeframerConfig {
        &self.config
    }

    /// Extended-length cap in force (`config.max_ext_len` clamped to `N - 11`).
    #[must_use]
    pub const fn max_ext_len(&self) -> usize {
        self.max_ext_len
    }

    /// Running totals.
    #[must_use]
    pub const fn counters(&self) -> &Counters {
        &self.counters
    }

    /// Bytes held waiting for the rest of a frame.
    #[must_use]
    pub const fn buffered_len(&self) -> usize {
        self.end - self.start
    }

    /// Stream offset of the next byte to be taken from the input (= bytes taken
    /// so far).
    #[must_use]
    pub const fn stream_offset(&self) -> u64 {
        self.counters.bytes_in
    }

    /// Takes bytes from the front of `input` (advancing it) and returns the next
    /// event. Returns `None` only when `input` is empty and no event is ready;
    /// call it in a loop until then. `now_us` is the arrival time of `input`.
    ///
    /// If more than the gap limit has passed since the last byte and a partial
    /// frame is buffered, it is abandoned first (see the module documentation).
    pub fn feed<'s>(&'s mut self, input: &mut &[u8], now_us: u64) -> Option<Event<'s>> {
        self.check_gap(now_us);
        self.next_event(input, now_us)
    }

    /// Feeds all of `input` and calls `on_event` for each event.
    pub fn push(&mut self, input: &[u8], now_us: u64, mut on_event: impl FnMut(Event<'_>)) {
        let mut rest = input;
        while let Some(event) = self.feed(&mut rest, now_us) {
            on_event(event);
        }
    }

    /// Lets time pass without new bytes: abandons a stalled partial frame. Call
    /// in a loop until `None` (as [`Deframer::feed`] with empty input).
    pub fn poll(&mut self, now_us: u64) -> Option<Event<'_>> {
        self.feed(&mut &[][..], now_us)
    }

    /// End of input: delivers the frames still buffered and reports every
    /// incomplete candidate as [`DeframeErrorKind::Truncated`] (one byte each, then
    /// rescan). Call in a loop until `None`.
    pub fn finish(&mut self) -> Option<Event<'_>> {
        if self.drain.is_none() && (self.start != self.end || self.pending_garbage.is_some()) {
            self.drain = Some(Drain::EndOfInput);
        }
        let now_us = self.last_rx_us;
        self.next_event(&mut &[][..], now_us)
    }

    /// Throws away buffered bytes (e.g. after a response timeout) and returns how
    /// many. A pending garbage report is dropped (its bytes are already counted).
    pub fn reset(&mut self) -> usize {
        let n = self.buffered_len();
        self.counters.reset_bytes += n as u64;
        self.start = 0;
        self.end = 0;
        self.drain = None;
        self.pending_garbage = None;
        n
    }

    /// Zeroes the counters (stream offsets restart at 0). Buffered bytes are
    /// counted as if they had just arrived.
    pub fn reset_counters(&mut self) {
        self.counters = Counters {
            bytes_in: self.buffered_len() as u64,
            ..Counters::default()
        };
        self.pending_garbage = None;
    }

    fn check_gap(&mut self, now_us: u64) {
        let idle = self.start != self.end || self.pending_garbage.is_some();
        if self.drain.is_none()
            && idle
            && now_us.saturating_sub(self.last_rx_us) > self.config.gap_us
        {
            self.drain = Some(Drain::Stall);
        }
    }

    fn next_event<'s>(&'s mut self, input: &mut &[u8], now_us: u64) -> Option<Event<'s>> {
        loop {
            match self.step() {
                Step::Frame { info, offset } => {
                    let end = self.start;
                    let begin = end - info.wire_len();
                    let bytes = self.buf.get(begin..end).unwrap_or_default();
                    return Some(Event::Frame {
                        frame: Frame::from_info(bytes, &info),
                        offset,
                    });
                }
                Step::Error(err) => return Some(Event::Error(err)),
                Step::NeedMore => {
                    if input.is_empty() {
                        return None;
                    }
                    if !self.refill(input, now_us) {
                        // Unreachable (a candidate always fits), but never spin:
                        // throw the buffer away and go on.
                        debug_assert!(false, "deframer buffer full with an incomplete candidate");
                        self.reset();
                    }
                }
            }
        }
    }

    /// Moves as many input bytes as fit into the buffer; false if none fit.
    fn refill(&mut self, input: &mut &[u8], now_us: u64) -> bool {
        if self.start == self.end {
            self.start = 0;
            self.end = 0;
        } else if self.end + input.len() > N && self.start > 0 {
            self.buf.copy_within(self.start..self.end, 0);
            self.end -= self.start;
            self.start = 0;
        }
        let n = input.len().min(N - self.end);
        match (
            self.buf.get_mut(self.end..self.end + n),
            input.split_at_checked(n),
        ) {
            (Some(dst), Some((src, rest))) if n > 0 => {
                dst.copy_from_slice(src);
                *input = rest;
                self.end += n;
                self.counters.bytes_in += n as u64;
                self.last_rx_us = now_us;
                true
            }
            _ => false,
        }
    }

    /// Stream offset of `buf[start]`.
    fn offset_of_start(&self) -> u64 {
        self.counters.bytes_in - self.buffered_len() as u64
    }

    /// Drops `n` bytes at the front, returning their stream offset.
    fn drop_front(&mut self, n: usize) -> u64 {
        let offset = self.offset_of_start();
        self.start += n.min(self.buffered_len());
        offset
    }

    fn drop_one(&mut self, kind: DeframeErrorKind) -> Step {
        let offset = self.drop_front(1);
        let c = &mut self.counters;
        match kind {
            DeframeErrorKind::HeaderCheck => c.header_check += 1,
            DeframeErrorKind::ExtLengthCheck => c.ext_len_check += 1,
            DeframeErrorKind::Overlong => c.overlong += 1,
            DeframeErrorKind::TotalCheck => c.total_check += 1,
            DeframeErrorKind::Stall => c.stall += 1,
            DeframeErrorKind::Truncated => c.truncated += 1,
            DeframeErrorKind::BadSync | DeframeErrorKind::WrongDirection => {
                debug_assert!(false, "not a single-byte error");
            }
        }
        Step::Error(DeframeError {
            kind,
            offset,
            len: 1,
        })
    }

    /// Skips `n` bytes that cannot start a frame and merges them into the
    /// pending garbage run.
    fn skip_garbage(&mut self, n: usize) {
        let offset = self.drop_front(n);
        let n = n as u64;
        self.counters.garbage_bytes += n;
        self.pending_garbage = match self.pending_garbage {
            Some((start, len)) if start + len == offset => Some((start, len + n)),
            _ => Some((offset, n)),
        };
    }

    fn take_pending_garbage(&mut self) -> Option<DeframeError> {
        self.pending_garbage
            .take()
            .map(|(offset, len)| DeframeError {
                kind: DeframeErrorKind::BadSync,
                offset,
                len,
            })
    }

    fn step(&mut self) -> Step {
        loop {
            let avail = self.buf.get(self.start..self.end).unwrap_or_default();
            if avail.is_empty() {
                if self.drain.take().is_some()
                    && let Some(err) = self.take_pending_garbage()
                {
                    return Step::Error(err);
                }
                return Step::NeedMore;
            }
            let parsed = parse_info(avail, self.max_ext_len);
            if let Err(FrameError::BadSync) = parsed {
                let n = garbage_run(avail);
                self.skip_garbage(n);
                continue;
            }
            // A lone first sync byte: wait for its partner (the garbage run may go
            // on), unless the burst is being flushed, where it is garbage too.
            if avail.len() == 1 {
                if self.drain.is_some() {
                    self.skip_garbage(1);
                    continue;
                }
                return Step::NeedMore;
            }
            // A valid sync pair: report the garbage run before it.
            if let Some(err) = self.take_pending_garbage() {
                return Step::Error(err);
            }
            return match parsed {
                Ok(info) => {
                    let len = info.wire_len();
                    let offset = self.drop_front(len);
                    if self.config.accept.accepts(info.header.direction) {
                        self.counters.frames_ok += 1;
                        self.counters.frame_bytes += len as u64;
                        Step::Frame { info, offset }
                    } else {
                        self.counters.wrong_direction += 1;
                        self.counters.wrong_direction_bytes += len as u64;
                        Step::Error(DeframeError {
                            kind: DeframeErrorKind::WrongDirection,
                            offset,
                            len: len as u64,
                        })
                    }
                }
                Err(FrameError::Incomplete { .. }) => match self.drain {
                    None => Step::NeedMore,
                    Some(Drain::Stall) => self.drop_one(DeframeErrorKind::Stall),
                    Some(Drain::EndOfInput) => self.drop_one(DeframeErrorKind::Truncated),
                },
                Err(FrameError::HeaderCheck { .. }) => self.drop_one(DeframeErrorKind::HeaderCheck),
                Err(FrameError::ExtLengthCheck { .. }) => {
                    self.drop_one(DeframeErrorKind::ExtLengthCheck)
                }
                Err(FrameError::Overlong { .. }) => self.drop_one(DeframeErrorKind::Overlong),
                // (BadSync was handled above; keep the match total.)
                Err(FrameError::TotalCheck { .. } | FrameError::BadSync) => {
                    self.drop_one(DeframeErrorKind::TotalCheck)
                }
            };
        }
    }
}

/// Length of the run at the front of `bytes` that cannot start a valid sync
/// pair: stops at a first sync byte followed by its partner, or at a first sync
/// byte that is the last byte (its partner may still arrive). At least 1.
fn garbage_run(bytes: &[u8]) -> usize {
    let mut i = 1;
    while let Some(&b) = bytes.get(i) {
        let partner = if b == SYNC_REQUEST[0] {
            Some(SYNC_REQUEST[1])
        } else if b == SYNC_RESPONSE[0] {
            Some(SYNC_RESPONSE[1])
        } else {
            None
        };
        if let Some(partner) = partner {
            match bytes.get(i + 1) {
                None => return i,
                Some(&next) if next == partner => return i,
                Some(_) => {}
            }
        }
        i += 1;
    }
    i
}

impl<const N: usize> fmt::Debug for Deframer<N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Deframer")
            .field("capacity", &N)
            .field("buffered_len", &self.buffered_len())
            .field("config", &self.config)
            .field("max_ext_len", &self.max_ext_len)
            .field("counters", &self.counters)
            .field("last_rx_us", &self.last_rx_us)
            .finish_non_exhaustive()
    }
}

impl Default for Deframer<DEFAULT_CAPACITY> {
    /// Both directions, default gap and cap.
    fn default() -> Self {
        Self::new(DeframerConfig::default())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const V5: [u8; 8] = [0xFA, 0xAF, 0x01, 0x05, 0x00, 0x00, 0x51, 0x00];

    fn collect<const N: usize>(d: &mut Deframer<N>, input: &[u8], now_us: u64) -> [u64; 3] {
        // (frames, errors, bytes in error events)
        let mut out = [0u64; 3];
        d.push(input, now_us, |e| match e {
            Event::Frame { .. } => out[0] += 1,
            Event::Error(err) => {
                out[1] += 1;
                out[2] += err.len;
            }
        });
        out
    }

    #[test]
    fn garbage_run_stops_at_sync_pairs_only() {
        assert_eq!(garbage_run(&[0x00, 0x13, 0xFA, 0x00, 0x55, 0xFA, 0xAF]), 5);
        assert_eq!(garbage_run(&[0x00, 0xFA]), 1);
        assert_eq!(garbage_run(&[0xFA, 0xDF, 0x01]), 3);
        assert_eq!(garbage_run(&[0x00, 0xFD, 0xDF]), 1);
    }

    #[test]
    fn small_capacity_clamps_extended_cap() {
        let d = Deframer::<300>::with_config(DeframerConfig::default());
        assert_eq!(d.max_ext_len(), 289);
        let d = Deframer::new(DeframerConfig::default().with_max_ext_len(5000));
        assert_eq!(d.max_ext_len(), DEFAULT_CAPACITY - 11);
    }

    #[test]
    fn poll_abandons_stalled_candidate_and_finds_frame_inside() {
        // A false header announcing 15 payload bytes, then a whole V5, then silence.
        let mut input = [0u8; 15];
        input[..7].copy_from_slice(&[0xFA, 0xAF, 0x01, 0x05, 0x00, 0x0F, 0x5E]);
        input[7..].copy_from_slice(&V5);
        let mut d = Deframer::default();
        assert_eq!(collect(&mut d, &input, 0), [0, 0, 0]);
        assert_eq!(d.buffered_len(), 15);
        assert!(d.poll(DEFAULT_GAP_US).is_none(), "not yet past the gap");
        let mut events = [None; 4];
        let mut n = 0;
        while let Some(e) = d.poll(DEFAULT_GAP_US + 1) {
            events[n] = Some(match e {
                Event::Frame { offset, .. } => (None, offset),
                Event::Error(err) => (Some(err.kind), err.offset),
            });
            n += 1;
        }
        assert_eq!(n, 3);
        assert_eq!(events[0], Some((Some(DeframeErrorKind::Stall), 0)));
        assert_eq!(events[1], Some((Some(DeframeErrorKind::BadSync), 1)));
        assert_eq!(events[2], Some((None, 7)));
        assert_eq!(d.counters().stall, 1);
        assert_eq!(d.counters().frames_ok, 1);
        assert_eq!(d.buffered_len(), 0);
    }

    #[test]
    fn reset_counts_discarded_bytes() {
        let mut d = Deframer::default();
        collect(&mut d, &V5[..5], 0);
        assert_eq!(d.reset(), 5);
        let c = *d.counters();
        assert_eq!(c.bytes_in, c.frame_bytes + c.bytes_discarded());
        assert_eq!(collect(&mut d, &V5, 0), [1, 0, 0]);
    }
}
