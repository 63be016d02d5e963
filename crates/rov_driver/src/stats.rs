//! Error accounting (style A7) and round-trip latency statistics.

use std::collections::VecDeque;

/// Why an exchange failed. Each failed exchange is counted under exactly one cause,
/// the most specific thing seen while waiting for its response:
/// a check failure (header, extended length / overlong, total) first, then a valid but
/// non-matching frame, then a stalled partial frame, then bytes that never formed a
/// frame (sync), and plain silence (timeout) last.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FailCause {
    /// Nothing at all arrived before the response timeout.
    Timeout,
    /// Only bytes that never formed a sync pair arrived (line noise).
    Sync,
    /// A candidate frame failed its header check.
    HeaderCheck,
    /// A candidate frame failed its extended-length check or was overlong.
    ExtLength,
    /// A candidate frame failed its total (payload) check.
    TotalCheck,
    /// A partial frame stalled longer than the inter-byte gap limit.
    Stall,
    /// A valid frame arrived that did not match the request (node, FLAGS, address,
    /// device type or length).
    Unexpected,
    /// The port vanished while the exchange was in flight
    /// ([`Link::on_port_lost`](crate::Link::on_port_lost)); not a frame error.
    PortGone,
}

impl FailCause {
    /// Priority when several things were seen (higher wins).
    pub(crate) const fn rank(self) -> u8 {
        match self {
            Self::Timeout => 0,
            Self::Sync => 1,
            Self::Stall => 2,
            Self::Unexpected => 3,
            Self::TotalCheck | Self::HeaderCheck | Self::ExtLength => 4,
            Self::PortGone => 5,
        }
    }

    /// Short name.
    #[must_use]
    pub const fn as_str(self) -> &'static str {
        match self {
            Self::Timeout => "timeout",
            Self::Sync => "sync",
            Self::HeaderCheck => "header check",
            Self::ExtLength => "extended length",
            Self::TotalCheck => "total check",
            Self::Stall => "stall",
            Self::Unexpected => "unexpected response",
            Self::PortGone => "port gone",
        }
    }
}

/// Counters of the link. Exchange-level counters (`failed_*`) count each failed
/// request once; byte-level detail is in `deframer` (every error event of the
/// host-side deframer, see [`firmware_proto::Counters`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LinkCounters {
    /// Requests sent (including retries).
    pub requests: u64,
    /// Requests that were retries.
    pub retries: u64,
    /// Requests answered by a matching valid response.
    pub responses: u64,
    /// Failed exchanges: nothing arrived (a dropped reply, a dead link, a corrupted
    /// request the vehicle ignored).
    pub failed_timeout: u64,
    /// Failed exchanges: only line noise arrived.
    pub failed_sync: u64,
    /// Failed exchanges: a header check failed.
    pub failed_header_check: u64,
    /// Failed exchanges: an extended-length check failed or the length was overlong.
    pub failed_ext_length: u64,
    /// Failed exchanges: a total check failed.
    pub failed_total_check: u64,
    /// Failed exchanges: a partial frame stalled.
    pub failed_stall: u64,
    /// Failed exchanges: only non-matching valid frames arrived.
    pub failed_unexpected: u64,
    /// Failed exchanges: the port vanished while they were in flight.
    pub failed_port_gone: u64,
    /// Times the port vanished ([`Link::on_port_lost`](crate::Link::on_port_lost)).
    pub port_losses: u64,
    /// Valid frames that matched no outstanding request (late replies, other nodes).
    pub unexpected_frames: u64,
    /// Bytes thrown away when the input was flushed before a request.
    pub flushed_bytes: u64,
    /// Events dropped because the event queue was full.
    pub events_dropped: u64,
    /// Times the link was declared lost.
    pub link_losses: u64,
    /// Byte-level counters of the host-side deframer.
    pub deframer: firmware_proto::Counters,
}

impl LinkCounters {
    /// All failed exchanges.
    #[must_use]
    pub const fn failed(&self) -> u64 {
        self.failed_timeout
            + self.failed_sync
            + self.failed_header_check
            + self.failed_ext_length
            + self.failed_total_check
            + self.failed_stall
            + self.failed_unexpected
            + self.failed_port_gone
    }

    /// The counter of one cause.
    #[must_use]
    pub const fn failed_by(&self, cause: FailCause) -> u64 {
        match cause {
            FailCause::Timeout => self.failed_timeout,
            FailCause::Sync => self.failed_sync,
            FailCause::HeaderCheck => self.failed_header_check,
            FailCause::ExtLength => self.failed_ext_length,
            FailCause::TotalCheck => self.failed_total_check,
            FailCause::Stall => self.failed_stall,
            FailCause::Unexpected => self.failed_unexpected,
            FailCause::PortGone => self.failed_port_gone,
        }
    }

    pub(crate) fn count_failure(&mut self, cause: FailCause) {
        let c = match cause {
            FailCause::Timeout => &mut self.failed_timeout,
            FailCause::Sync => &mut self.failed_sync,
            FailCause::HeaderCheck => &mut self.failed_header_check,
            FailCause::ExtLength => &mut self.failed_ext_length,
            FailCause::TotalCheck => &mut self.failed_total_check,
            FailCause::Stall => &mut self.failed_stall,
            FailCause::Unexpected => &mut self.failed_unexpected,
            FailCause::PortGone => &mut self.failed_port_gone,
        };
        *c += 1;
    }
}

/// Round-trip time summary over the window, µs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RttSummary {
    /// Samples in the window.
    pub count: usize,
    /// Median.
    pub p50_us: u64,
    /// 99th percentile (nearest rank).
    pub p99_us: u64,
    /// Largest in the window.
    pub max_us: u64,
    /// Mean in the window.
    pub mean_us: u64,
    /// Largest since the start.
    pub max_ever_us: u64,
}

/// Round-trip times (request handed out → matching response complete) over a sliding
/// window.
#[derive(Debug, Clone)]
pub struct RttStats {
    window: VecDeque<u64>,
    capacity: usize,
    max_ever_us: u64,
    scratch: Vec<u64>,
}

impl RttStats {
    /// A window of `capacity` samples (at least 1).
    #[must_use]
    pub fn new(capacity: usize) -> Self {
        let capacity = capacity.max(1);
        Self {
            window: VecDeque::with_capacity(capacity),
            capacity,
            max_ever_us: 0,
            scratch: Vec::with_capacity(capacity),
        }
    }

    /// Adds a sample.
    pub fn push(&mut self, rtt_us: u64) {
        if self.window.len() == self.capacity {
            self.window.pop_front();
        }
        self.window.push_back(rtt_us);
        self.max_ever_us = self.max_ever_us.max(rtt_us);
    }

    /// Percentiles over the window (all zero when empty).
    pub fn summary(&mut self) -> RttSummary {
        let n = self.window.len();
        if n == 0 {
            return RttSummary {
                max_ever_us: self.max_ever_us,
                ..RttSummary::default()
            };
        }
        self.scratch.clear();
        self.scratch.extend(self.window.iter().copied());
        self.scratch.sort_unstable();
        let rank = |p: usize| -> u64 {
            // Nearest rank: ceil(p/100 · n), 1-based.
            let k = (p * n).div_ceil(100).clamp(1, n);
            self.scratch.get(k - 1).copied().unwrap_or(0)
        };
        let sum: u64 = self.scratch.iter().sum();
        RttSummary {
            count: n,
            p50_us: rank(50),
            p99_us: rank(99),
            max_us: self.scratch.last().copied().unwrap_or(0),
            mean_us: sum / n as u64,
            max_ever_us: self.max_ever_us,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_nearest_rank() {
        let mut s = RttStats::new(100);
        for v in 1..=100 {
            s.push(v);
        }
        let r = s.summary();
        assert_eq!(
            (r.count, r.p50_us, r.p99_us, r.max_us, r.mean_us),
            (100, 50, 99, 100, 50)
        );
        s.push(1000);
        let r = s.summary();
        assert_eq!((r.count, r.max_us, r.max_ever_us), (100, 1000, 1000));
    }

    #[test]
    fn failure_ranks_prefer_checks() {
        assert!(FailCause::TotalCheck.rank() > FailCause::Unexpected.rank());
        assert!(FailCause::Sync.rank() > FailCause::Timeout.rank());
    }
}
