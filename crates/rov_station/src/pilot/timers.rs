//! The pilot core's timers, in one table.
//!
//! Each timer is a deadline in µs of the runtime's clock; a timer is reached at the first
//! `now_us >= at_us`. The engine reads them on its ticks (50 Hz), so a timer acts within
//! one control period of its deadline. [`Timers::next`] is the engine's `poll_timeout`.
//! Other timing lives with its owner and is driven by the same `now_us`: the hold-to-arm
//! button (`shaping::ArmHold`), the alarms' debounce and nav age (`alarms`), the link's
//! own timeouts (`rov_driver::Link::next_timeout`).

/// The engine's timers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Timer {
    /// The next `/link/stats` record (every [`LINK_RECORD_US`]).
    LinkRecord,
    /// The hint shown to the pilot goes away ([`HINT_US`] after it was shown).
    Hint,
    /// The keyboard/GUI sticks count as released (they are a stream that must be refreshed
    /// within `RuntimeConfig::keyboard_timeout_us`).
    KeyboardSticks,
    /// A virtual gamepad's state goes stale (same timeout as the keyboard).
    VirtualPad,
}

impl Timer {
    /// Every timer, in table order.
    pub const ALL: [Self; 4] = [
        Self::LinkRecord,
        Self::Hint,
        Self::KeyboardSticks,
        Self::VirtualPad,
    ];

    const fn index(self) -> usize {
        match self {
            Self::LinkRecord => 0,
            Self::Hint => 1,
            Self::KeyboardSticks => 2,
            Self::VirtualPad => 3,
        }
    }
}

/// Link statistics interval, µs.
pub const LINK_RECORD_US: u64 = 500_000;
/// How long a hint stays in the view, µs.
pub const HINT_US: u64 = 4_000_000;

/// The table: one optional deadline per [`Timer`].
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Timers {
    at_us: [Option<u64>; Timer::ALL.len()],
}

impl Timers {
    /// Sets a timer to `at_us` (replacing its deadline).
    pub fn set(&mut self, timer: Timer, at_us: u64) {
        if let Some(slot) = self.at_us.get_mut(timer.index()) {
            *slot = Some(at_us);
        }
    }

    /// Stops a timer.
    pub fn clear(&mut self, timer: Timer) {
        if let Some(slot) = self.at_us.get_mut(timer.index()) {
            *slot = None;
        }
    }

    /// The timer's deadline, if it is set.
    #[must_use]
    pub fn at(&self, timer: Timer) -> Option<u64> {
        self.at_us.get(timer.index()).copied().flatten()
    }

    /// Whether the timer is set and reached at `now_us`.
    #[must_use]
    pub fn reached(&self, timer: Timer, now_us: u64) -> bool {
        self.at(timer).is_some_and(|t| now_us >= t)
    }

    /// Whether the timer is set and not yet reached at `now_us`.
    #[must_use]
    pub fn running(&self, timer: Timer, now_us: u64) -> bool {
        self.at(timer).is_some_and(|t| now_us < t)
    }

    /// The earliest deadline set, and its timer.
    #[must_use]
    pub fn next(&self) -> Option<(Timer, u64)> {
        Timer::ALL
            .iter()
            .filter_map(|t| self.at(*t).map(|at| (*t, at)))
            .min_by_key(|(_, at)| *at)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_timer_is_reached_at_its_deadline_and_the_table_gives_the_earliest() {
        let mut t = Timers::default();
        assert_eq!(t.next(), None);
        assert!(!t.reached(Timer::Hint, u64::MAX));
        t.set(Timer::Hint, 4_000);
        t.set(Timer::LinkRecord, 500);
        assert_eq!(t.next(), Some((Timer::LinkRecord, 500)));
        assert!(!t.reached(Timer::LinkRecord, 499));
        assert!(t.running(Timer::LinkRecord, 499));
        assert!(t.reached(Timer::LinkRecord, 500));
        assert!(!t.running(Timer::LinkRecord, 500));
        t.clear(Timer::LinkRecord);
        assert_eq!(t.next(), Some((Timer::Hint, 4_000)));
        t.set(Timer::Hint, 10);
        assert_eq!(t.at(Timer::Hint), Some(10));
    }
}
