//! Control-tick timing: each tick's wall timestamp, its lateness against its deadline,
//! period statistics and missed deadlines.

use std::collections::VecDeque;

use serde::Serialize;

/// Tick timestamps kept for inspection (160 s at 50 Hz).
pub const TICK_LOG_CAPACITY: usize = 8192;

/// A tick that starts this late (or later) counts as missed, µs.
pub const MISSED_LATE_US: u64 = 20_000;

/// Histogram bin of the lateness, µs.
const BIN_US: u64 = 100;
/// Histogram bins (0..50 ms; later ticks go to the last bin).
const BINS: usize = 500;

/// Tick timing statistics.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct TickStats {
    /// Nominal period, µs.
    pub period_us: u64,
    /// Ticks run.
    pub ticks: u64,
    /// Missed deadlines: ticks that started [`MISSED_LATE_US`] or more late, and
    /// deadlines skipped because the loop ran more than one period late.
    pub missed: u64,
    /// Ticks that ran more than one period late.
    pub late_ticks: u64,
    /// Largest lateness (tick time − deadline), µs.
    pub max_late_us: u64,
    /// 99th percentile of the lateness, µs (100 µs resolution).
    pub p99_late_us: u64,
    /// Last measured period, µs.
    pub last_period_us: u64,
    /// Smallest and largest measured period, µs.
    pub min_period_us: u64,
    /// Largest measured period, µs.
    pub max_period_us: u64,
    /// Watchdog trips (no tick within three periods).
    pub watchdog_trips: u64,
    /// Neutral frames the watchdog sent.
    pub watchdog_frames: u64,
    /// Longest time from the last completed tick to the watchdog's first neutral frame
    /// of a trip, µs (G2: at most 3 P + P).
    pub watchdog_max_gap_us: u64,
}

/// The accumulator, owned by the control loop.
#[derive(Debug, Clone)]
pub struct TickTimer {
    stats: TickStats,
    hist: Vec<u64>,
    last_tick_us: Option<u64>,
    log: VecDeque<u64>,
}

impl TickTimer {
    /// For a period in µs.
    #[must_use]
    pub fn new(period_us: u64) -> Self {
        Self {
            stats: TickStats {
                period_us,
                ticks: 0,
                missed: 0,
                late_ticks: 0,
                max_late_us: 0,
                p99_late_us: 0,
                last_period_us: 0,
                min_period_us: u64::MAX,
                max_period_us: 0,
                watchdog_trips: 0,
                watchdog_frames: 0,
                watchdog_max_gap_us: 0,
            },
            hist: vec![0; BINS],
            last_tick_us: None,
            log: VecDeque::with_capacity(TICK_LOG_CAPACITY),
        }
    }

    /// A tick ran at `now_us` for the deadline `deadline_us`.
    pub fn record(&mut self, deadline_us: u64, now_us: u64) {
        let s = &mut self.stats;
        s.ticks += 1;
        let late = now_us.saturating_sub(deadline_us);
        s.max_late_us = s.max_late_us.max(late);
        if late > s.period_us {
            s.late_ticks += 1;
        }
        if late >= MISSED_LATE_US {
            s.missed += 1;
        }
        let bin = usize::try_from(late / BIN_US)
            .unwrap_or(BINS - 1)
            .min(BINS - 1);
        if let Some(h) = self.hist.get_mut(bin) {
            *h += 1;
        }
        if let Some(prev) = self.last_tick_us {
            let p = now_us.saturating_sub(prev);
            s.last_period_us = p;
            s.min_period_us = s.min_period_us.min(p);
            s.max_period_us = s.max_period_us.max(p);
        }
        self.last_tick_us = Some(now_us);
        if self.log.len() >= TICK_LOG_CAPACITY {
            self.log.pop_front();
        }
        self.log.push_back(now_us);
    }

    /// Deadlines skipped.
    pub fn add_missed(&mut self, n: u64) {
        self.stats.missed += n;
    }

    /// Sets the watchdog counters.
    pub fn set_watchdog(&mut self, trips: u64, frames: u64, max_gap_us: u64) {
        self.stats.watchdog_trips = trips;
        self.stats.watchdog_frames = frames;
        self.stats.watchdog_max_gap_us = max_gap_us;
    }

    /// The statistics now.
    #[must_use]
    pub fn stats(&self) -> TickStats {
        let mut s = self.stats.clone();
        let target = s.ticks.saturating_mul(99).div_ceil(100);
        let mut acc = 0;
        for (i, n) in self.hist.iter().enumerate() {
            acc += n;
            if acc >= target && target > 0 {
                s.p99_late_us = (i as u64 + 1) * BIN_US;
                break;
            }
        }
        if s.min_period_us == u64::MAX {
            s.min_period_us = 0;
        }
        s
    }

    /// The timestamps of the last ticks (µs of the runtime clock), oldest first.
    #[must_use]
    pub fn log(&self) -> Vec<u64> {
        self.log.iter().copied().collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statistics_of_a_few_ticks() {
        let mut t = TickTimer::new(20_000);
        for k in 0..100u64 {
            let late = if k == 50 { 30_000 } else { 150 };
            t.record(k * 20_000, k * 20_000 + late);
        }
        let s = t.stats();
        assert_eq!(s.ticks, 100);
        assert_eq!(s.max_late_us, 30_000);
        assert_eq!(s.late_ticks, 1);
        assert_eq!(s.missed, 1, "30 ms late is missed");
        assert_eq!(s.p99_late_us, 200);
        assert_eq!(s.max_period_us, 20_000 + 30_000 - 150);
        assert_eq!(t.log().len(), 100);
    }
}
