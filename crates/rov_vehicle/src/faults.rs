//! Fault injection for the simulated vehicle: configurable, seeded and counted so that
//! tests can compare the driver's counters with what was injected.
//!
//! Per reply, in this order (at most one of drop / bit flip):
//!
//! * **drop**: nothing at all is sent (the host sees a timeout);
//! * **bit flip**: one bit of one byte at index ≥ 2 is flipped. The sync pair is never
//!   touched, so each flipped reply fails exactly one check on the host, which one is
//!   known from the index: bytes 2..=6 → header check, 7..=9 of an extended frame →
//!   extended-length check, the rest → total check;
//! * **delay**: extra turnaround;
//! * **garbage**: a burst of random bytes on the line before the reply. By default the
//!   burst never contains 0xFA or 0xFD, so it cannot start a false candidate and the
//!   host's garbage-byte counter rises by exactly the burst length
//!   (`garbage_any_bytes = true` lifts that);
//! * **fragmentation**: the reply leaves in 2..=`fragment_max_pieces` pieces with gaps
//!   (below the 10 ms inter-byte limit by default, so it is not an error).
//!
//! Requests: **corrupt request** flips one bit at index ≥ 6 of a request as it arrives
//! (header check or payload/total check), so the vehicle drops it, bumps its comm error
//! counter (CSR 0x86) and does not reply. **Dead windows** make the vehicle deaf: every
//! request that arrives inside one is ignored (the tether is cut); bytes already on the
//! wire still arrive.

use crate::rng::FaultRng;

/// Fault settings. Probabilities are per reply (or per request for
/// `corrupt_request`); all zero by default.
#[derive(Debug, Clone, PartialEq)]
pub struct FaultConfig {
    /// Seed of the fault generator.
    pub seed: u64,
    /// Probability of dropping a reply.
    pub drop_reply: f64,
    /// Probability of flipping one bit in a reply.
    pub bit_flip: f64,
    /// Probability of extra delay before a reply.
    pub delay: f64,
    /// Extra delay range, µs (inclusive).
    pub delay_us: (u64, u64),
    /// Probability of a garbage burst before a reply.
    pub garbage: f64,
    /// Garbage burst length range, bytes (inclusive).
    pub garbage_len: (u64, u64),
    /// Allow 0xFA / 0xFD in garbage (false: exact byte accounting on the host).
    pub garbage_any_bytes: bool,
    /// Probability of sending a reply in pieces.
    pub fragment: f64,
    /// Most pieces (at least 2).
    pub fragment_max_pieces: u64,
    /// Gap between pieces, µs (inclusive).
    pub fragment_gap_us: (u64, u64),
    /// Probability of corrupting an arriving request.
    pub corrupt_request: f64,
    /// Windows `[start, end)` in µs of vehicle time during which the vehicle is deaf.
    pub dead_windows: Vec<(u64, u64)>,
}

impl Default for FaultConfig {
    fn default() -> Self {
        Self {
            seed: 0x5EED,
            drop_reply: 0.0,
            bit_flip: 0.0,
            delay: 0.0,
            delay_us: (1_000, 20_000),
            garbage: 0.0,
            garbage_len: (1, 16),
            garbage_any_bytes: false,
            fragment: 0.0,
            fragment_max_pieces: 6,
            fragment_gap_us: (200, 2_000),
            corrupt_request: 0.0,
            dead_windows: Vec::new(),
        }
    }
}

impl FaultConfig {
    /// No faults.
    #[must_use]
    pub fn none() -> Self {
        Self::default()
    }

    /// Whether `t_us` is inside a dead window.
    #[must_use]
    pub fn is_dead(&self, t_us: u64) -> bool {
        self.dead_windows
            .iter()
            .any(|&(start, end)| (start..end).contains(&t_us))
    }
}

/// What was injected (and what the vehicle saw), for comparison with the host's
/// counters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FaultCounts {
    /// Valid requests received (addressed to anyone), excluding those ignored while dead.
    pub requests: u64,
    /// Replies built (before faults).
    pub replies: u64,
    /// Replies dropped.
    pub replies_dropped: u64,
    /// Replies with a bit flipped in the header (bytes 2..=6).
    pub flipped_header: u64,
    /// Replies with a bit flipped in the extended-length bytes.
    pub flipped_ext: u64,
    /// Replies with a bit flipped in the payload or total check.
    pub flipped_total: u64,
    /// Replies delayed.
    pub delayed: u64,
    /// Largest injected delay, µs.
    pub delay_max_us: u64,
    /// Garbage bursts.
    pub garbage_bursts: u64,
    /// Garbage bytes.
    pub garbage_bytes: u64,
    /// Replies sent in pieces.
    pub fragmented: u64,
    /// Pieces in those replies.
    pub fragments: u64,
    /// Requests corrupted on arrival.
    pub requests_corrupted: u64,
    /// Requests ignored because the vehicle was deaf (dead window).
    pub requests_ignored_dead: u64,
}

impl FaultCounts {
    /// Replies with a bit flipped, any position.
    #[must_use]
    pub const fn flipped(&self) -> u64 {
        self.flipped_header + self.flipped_ext + self.flipped_total
    }
}

/// Where a flipped bit landed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum FlipClass {
    Header,
    Ext,
    Total,
}

/// One reply after the fault decisions.
#[derive(Debug, Default)]
pub(crate) struct FaultedReply {
    pub extra_delay_us: u64,
    pub garbage: Vec<u8>,
    /// Piece boundaries (byte counts) and the gap after each piece but the last.
    pub pieces: Vec<(usize, u64)>,
}

/// Applies the reply faults. Returns `None` if the reply is dropped.
pub(crate) fn fault_reply(
    cfg: &FaultConfig,
    rng: &mut FaultRng,
    counts: &mut FaultCounts,
    frame: &mut [u8],
) -> Option<FaultedReply> {
    counts.replies += 1;
    if rng.chance(cfg.drop_reply) {
        counts.replies_dropped += 1;
        return None;
    }
    if frame.len() > 2 && rng.chance(cfg.bit_flip) {
        let idx = rng.range(2, frame.len() as u64 - 1) as usize;
        let bit = rng.range(0, 7) as u32;
        let extended = frame.get(5) == Some(&0xFF);
        if let Some(b) = frame.get_mut(idx) {
            *b ^= 1u8 << bit;
        }
        match flip_class(idx, extended) {
            FlipClass::Header => counts.flipped_header += 1,
            FlipClass::Ext => counts.flipped_ext += 1,
            FlipClass::Total => counts.flipped_total += 1,
        }
    }
    let mut out = FaultedReply::default();
    if rng.chance(cfg.delay) {
        out.extra_delay_us = rng.range(cfg.delay_us.0, cfg.delay_us.1);
        counts.delayed += 1;
        counts.delay_max_us = counts.delay_max_us.max(out.extra_delay_us);
    }
    if rng.chance(cfg.garbage) {
        let n = rng.range(cfg.garbage_len.0.max(1), cfg.garbage_len.1);
        for _ in 0..n {
            let mut b = rng.next_u64() as u8;
            while !cfg.garbage_any_bytes && (b == 0xFA || b == 0xFD) {
                b = rng.next_u64() as u8;
            }
            out.garbage.push(b);
        }
        counts.garbage_bursts += 1;
        counts.garbage_bytes += n;
    }
    if frame.len() >= 2 && rng.chance(cfg.fragment) {
        let max = cfg.fragment_max_pieces.max(2).min(frame.len() as u64);
        let pieces = rng.range(2, max) as usize;
        // Distinct cut points in 1..len, sorted.
        let mut cuts: Vec<usize> = Vec::with_capacity(pieces);
        while cuts.len() < pieces - 1 {
            let c = rng.range(1, frame.len() as u64 - 1) as usize;
            if !cuts.contains(&c) {
                cuts.push(c);
            }
        }
        cuts.sort_unstable();
        let mut last = 0;
        for c in cuts {
            let gap = rng.range(cfg.fragment_gap_us.0, cfg.fragment_gap_us.1);
            out.pieces.push((c - last, gap));
            last = c;
        }
        out.pieces.push((frame.len() - last, 0));
        counts.fragmented += 1;
        counts.fragments += pieces as u64;
    } else {
        out.pieces.push((frame.len(), 0));
    }
    Some(out)
}

fn flip_class(idx: usize, extended: bool) -> FlipClass {
    match idx {
        0..=6 => FlipClass::Header,
        7..=9 if extended => FlipClass::Ext,
        _ => FlipClass::Total,
    }
}

/// Corrupts requests as their bytes arrive: tracks request frames (FA AF ... LEN) in the
/// raw stream and, for a chosen one, flips one bit at index 6..len.
#[derive(Debug, Clone, Default)]
pub(crate) struct RequestCorruptor {
    prev: u8,
    /// (index of the next byte, frame length once known, index to flip, corrupt?)
    frame: Option<(usize, Option<usize>, Option<usize>, bool)>,
}

impl RequestCorruptor {
    pub(crate) fn process(
        &mut self,
        bytes: &mut [u8],
        p: f64,
        rng: &mut FaultRng,
        counts: &mut FaultCounts,
    ) {
        for b in bytes.iter_mut() {
            match self.frame.as_mut() {
                None => {
                    if self.prev == 0xFA && *b == 0xAF && p > 0.0 {
                        self.frame = Some((2, None, None, rng.chance(p)));
                    }
                }
                Some((idx, len, flip, corrupt)) => {
                    if *idx == 5 {
                        if *b == 0xFF {
                            // Extended requests are not corrupted.
                            self.frame = None;
                            self.prev = *b;
                            continue;
                        }
                        let n = usize::from(*b) + 8;
                        *len = Some(n);
                        if *corrupt {
                            *flip = Some(rng.range(6, n as u64 - 1) as usize);
                        }
                    }
                    if *flip == Some(*idx) {
                        *b ^= 1u8 << rng.range(0, 7);
                        counts.requests_corrupted += 1;
                    }
                    *idx += 1;
                    if len.is_some_and(|n| *idx >= n) {
                        self.frame = None;
                    }
                }
            }
            self.prev = *b;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corruptor_hits_exactly_the_chosen_frames() {
        let frame = [0xFA, 0xAF, 0x01, 0x01, 0x00, 0x00, 0x55, 0x00];
        let mut c = RequestCorruptor::default();
        let mut rng = FaultRng::new(1);
        let mut counts = FaultCounts::default();
        let mut changed = 0;
        for _ in 0..1000 {
            let mut f = frame;
            c.process(&mut f, 0.3, &mut rng, &mut counts);
            if f != frame {
                changed += 1;
                assert_eq!(&f[..6], &frame[..6]);
            }
        }
        assert_eq!(changed, counts.requests_corrupted);
        assert!((200..400).contains(&changed));
    }

    #[test]
    fn reply_faults_are_counted() {
        let cfg = FaultConfig {
            drop_reply: 0.1,
            bit_flip: 0.1,
            garbage: 0.2,
            fragment: 0.2,
            delay: 0.2,
            ..FaultConfig::default()
        };
        let mut rng = FaultRng::new(7);
        let mut counts = FaultCounts::default();
        for _ in 0..2000 {
            let mut f = vec![0xFD, 0xDF, 1, 5, 0, 3, 0x25, 1, 2, 3, 0];
            if let Some(r) = fault_reply(&cfg, &mut rng, &mut counts, &mut f) {
                assert_eq!(r.pieces.iter().map(|p| p.0).sum::<usize>(), f.len());
                assert!(r.garbage.iter().all(|&b| b != 0xFA && b != 0xFD));
                assert_eq!(&f[..2], &[0xFD, 0xDF]);
            }
        }
        assert_eq!(counts.replies, 2000);
        assert!(counts.replies_dropped > 100 && counts.flipped() > 100);
        assert!(counts.fragments >= 2 * counts.fragmented);
    }
}
