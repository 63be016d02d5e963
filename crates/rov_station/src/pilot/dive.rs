//! The dive log and the pre-dive checklist, run in the control tick (never in a GUI
//! frame); both are recorded in the session as `/events` (kinds `dive_start`,
//! `dive_end`, `note`, `marker`, `checklist`), so replay shows them in its index.
//!
//! * [`DiveLog`]: the dive timer (a dive starts when the vehicle goes below
//!   [`DIVE_START_M`] and ends when it has been above [`DIVE_END_M`] for
//!   [`DIVE_END_S`]), the deepest point, and numbered notes and markers.
//! * [`Checklist`]: leak check (humidity reported, below the warning limit, not
//!   rising), compass check (the pilot confirms the heading against a known bearing),
//!   thruster test, depth zero at the surface, recording on.
//! * [`ThrusterTest`]: each thruster in turn at [`TEST_PCT`] for [`TEST_ON_S`] with a
//!   pause between, the commanded thrust and the 12 V current seen before and during;
//!   only when armed and confirmed by the pilot, with the holds off, aborted by a stick
//!   input, a disarm or a link loss, and never longer than the sequence.

use serde::Serialize;

/// A dive starts below this depth, m.
pub const DIVE_START_M: f64 = 0.5;
/// A dive ends above this depth ...
pub const DIVE_END_M: f64 = 0.3;
/// ... held this long, s.
pub const DIVE_END_S: f64 = 5.0;

/// The dive log as the GUI shows it.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct DiveView {
    /// A dive is under way.
    pub diving: bool,
    /// Length of the current (or last) dive, s.
    pub dive_s: f64,
    /// Dives so far on this connection.
    pub dives: u32,
    /// Deepest point of the current (or last) dive, m.
    pub max_depth_m: f64,
    /// Notes recorded.
    pub notes: u32,
    /// Markers recorded.
    pub markers: u32,
}

/// What the dive log wants recorded.
#[derive(Debug, Clone, PartialEq)]
pub enum DiveEvent {
    /// A dive started.
    Started,
    /// A dive ended after this long, this deep.
    Ended {
        /// Length, s.
        dive_s: f64,
        /// Deepest point, m.
        max_depth_m: f64,
    },
}

/// The dive timer; see the module docs.
#[derive(Debug, Clone, Default)]
pub struct DiveLog {
    view: DiveView,
    started_s: Option<f64>,
    surfaced_since_s: Option<f64>,
}

impl DiveLog {
    /// The view.
    #[must_use]
    pub const fn view(&self) -> DiveView {
        self.view
    }

    /// One tick at `t_s` with the measured depth.
    pub fn update(&mut self, t_s: f64, depth_m: Option<f64>) -> Option<DiveEvent> {
        let d = depth_m.filter(|d| d.is_finite())?;
        match self.started_s {
            None if d > DIVE_START_M => {
                self.started_s = Some(t_s);
                self.surfaced_since_s = None;
                self.view.diving = true;
                self.view.dives += 1;
                self.view.dive_s = 0.0;
                self.view.max_depth_m = d;
                Some(DiveEvent::Started)
            }
            None => None,
            Some(t0) => {
                self.view.dive_s = (t_s - t0).max(0.0);
                self.view.max_depth_m = self.view.max_depth_m.max(d);
                if d < DIVE_END_M {
                    let since = *self.surfaced_since_s.get_or_insert(t_s);
                    if t_s - since >= DIVE_END_S {
                        self.started_s = None;
                        self.surfaced_since_s = None;
                        self.view.diving = false;
                        self.view.dive_s = (since - t0).max(0.0);
                        return Some(DiveEvent::Ended {
                            dive_s: self.view.dive_s,
                            max_depth_m: self.view.max_depth_m,
                        });
                    }
                } else {
                    self.surfaced_since_s = None;
                }
                None
            }
        }
    }

    /// Counts a note; returns its number.
    pub fn note(&mut self) -> u32 {
        self.view.notes += 1;
        self.view.notes
    }

    /// Counts a marker; returns its number.
    pub fn marker(&mut self) -> u32 {
        self.view.markers += 1;
        self.view.markers
    }
}

/// Thrust of the thruster test, %.
pub const TEST_PCT: f64 = 25.0;
/// Each thruster runs this long, s.
pub const TEST_ON_S: f64 = 1.0;
/// Pause after each thruster, s.
pub const TEST_PAUSE_S: f64 = 0.5;
/// The thrusters in test order.
pub const THRUSTERS: [&str; 3] = ["port", "starboard", "vertical"];

/// One thruster's result.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct ThrusterResult {
    /// Thrust commanded, %.
    pub commanded_pct: f64,
    /// 12 V current just before, A.
    pub idle_a: Option<f64>,
    /// Highest 12 V current while it ran, A.
    pub peak_a: Option<f64>,
}

impl ThrusterResult {
    /// The thruster drew current: at least 0.1 A more than before.
    #[must_use]
    pub fn drew_current(&self) -> bool {
        matches!((self.idle_a, self.peak_a), (Some(i), Some(p)) if p - i >= 0.1)
    }
}

/// The thruster test in progress.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct ThrusterTest {
    /// Started at, s.
    pub started_s: f64,
    /// Results so far, by thruster.
    pub results: [ThrusterResult; 3],
}

impl ThrusterTest {
    /// The sequence's total length, s.
    pub const DURATION_S: f64 = 3.0 * (TEST_ON_S + TEST_PAUSE_S);

    /// The thrust to command at `t_s` (port, starboard, vertical %), and which thruster
    /// runs (None in a pause); None when the sequence is over.
    #[must_use]
    pub fn command(&self, t_s: f64) -> Option<([f64; 3], Option<usize>)> {
        let dt = t_s - self.started_s;
        if !(0.0..Self::DURATION_S).contains(&dt) {
            return None;
        }
        let slot = TEST_ON_S + TEST_PAUSE_S;
        let i = (dt / slot).floor() as usize;
        let on = dt - i as f64 * slot < TEST_ON_S;
        let mut pct = [0.0; 3];
        if on && let Some(p) = pct.get_mut(i) {
            *p = TEST_PCT;
        }
        Some((pct, on.then_some(i)))
    }
}

/// A checklist item's state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub enum ItemStatus {
    /// Not done.
    #[default]
    Pending,
    /// Running (the thruster test).
    Running,
    /// Passed.
    Pass,
    /// Failed (see the detail).
    Fail,
}

/// The checklist items.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub enum Item {
    /// Humidity reported, below the warning limit and not rising.
    Leak,
    /// The pilot confirmed the heading against a known bearing.
    Compass,
    /// Each thruster ran and drew current.
    Thrusters,
    /// Depth zeroed at the surface.
    DepthZero,
    /// A recording is running.
    Recording,
}

impl Item {
    /// In checklist order.
    pub const ALL: [Item; 5] = [
        Item::Leak,
        Item::Compass,
        Item::Thrusters,
        Item::DepthZero,
        Item::Recording,
    ];

    /// Name for the pilot.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Item::Leak => "Leak check",
            Item::Compass => "Compass check",
            Item::Thrusters => "Thruster test",
            Item::DepthZero => "Depth zero at the surface",
            Item::Recording => "Recording on",
        }
    }
}

/// One item as shown.
#[derive(Debug, PartialEq, Default, Serialize)]
pub struct ItemView {
    /// State.
    pub status: ItemStatus,
    /// What was seen.
    pub detail: String,
}

/// The checklist as shown.
#[derive(Debug, PartialEq, Default, Serialize)]
pub struct ChecklistView {
    /// Leak, compass, thrusters, depth zero, recording (in [`Item::ALL`] order).
    pub items: [ItemView; 5],
    /// The thruster test's results (the last run).
    pub thrusters: [ThrusterResult; 3],
    /// The thruster test runs now: the thruster running (None in a pause).
    pub test_running: Option<Option<usize>>,
    /// The result was recorded in the session.
    pub recorded: bool,
}

impl ChecklistView {
    /// An item.
    pub fn item_mut(&mut self, item: Item) -> Option<&mut ItemView> {
        let i = Item::ALL.iter().position(|x| *x == item)?;
        self.items.get_mut(i)
    }

    /// An item.
    #[must_use]
    pub fn item(&self, item: Item) -> Option<&ItemView> {
        let i = Item::ALL.iter().position(|x| *x == item)?;
        self.items.get(i)
    }

    /// Items passed.
    #[must_use]
    pub fn passed(&self) -> usize {
        self.items
            .iter()
            .filter(|i| i.status == ItemStatus::Pass)
            .count()
    }

    /// The one-line result recorded in the session.
    #[must_use]
    pub fn summary(&self) -> String {
        let items: Vec<String> = Item::ALL
            .iter()
            .zip(&self.items)
            .map(|(i, v)| {
                let s = match v.status {
                    ItemStatus::Pass => "pass",
                    ItemStatus::Fail => "FAIL",
                    ItemStatus::Pending | ItemStatus::Running => "not done",
                };
                format!("{}: {s} ({})", i.name(), v.detail)
            })
            .collect();
        format!(
            "pre-dive checklist {}/{} passed; {}",
            self.passed(),
            Item::ALL.len(),
            items.join("; ")
        )
    }
}

/// The thruster results as text.
#[must_use]
pub fn thruster_detail(r: &[ThrusterResult; 3]) -> String {
    let a = |x: Option<f64>| x.map_or_else(|| "---".to_string(), |v| format!("{v:.2}"));
    THRUSTERS
        .iter()
        .zip(r)
        .map(|(n, r)| {
            format!(
                "{n} {:+.0} %: {} -> {} A",
                r.commanded_pct,
                a(r.idle_a),
                a(r.peak_a)
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

crate::clone_fields!(ItemView { status, detail });

crate::clone_fields!(ChecklistView {
    items,
    thrusters,
    test_running,
    recorded
});

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_dive_starts_below_half_a_metre_and_ends_after_five_seconds_up() {
        let mut d = DiveLog::default();
        assert_eq!(d.update(0.0, Some(0.1)), None);
        assert_eq!(d.update(1.0, Some(0.6)), Some(DiveEvent::Started));
        assert_eq!(d.update(30.0, Some(12.0)), None);
        assert!(d.view().diving && d.view().dive_s == 29.0);
        assert_eq!(d.update(40.0, Some(0.2)), None);
        assert_eq!(d.update(42.0, Some(0.4)), None, "not yet 5 s above");
        assert_eq!(d.update(43.0, Some(0.1)), None);
        assert_eq!(
            d.update(48.0, Some(0.1)),
            Some(DiveEvent::Ended {
                dive_s: 42.0,
                max_depth_m: 12.0
            })
        );
        assert!(!d.view().diving);
    }

    #[test]
    fn the_thruster_sequence_runs_each_thruster_once_and_ends() {
        let t = ThrusterTest {
            started_s: 10.0,
            ..ThrusterTest::default()
        };
        assert_eq!(t.command(10.5), Some(([TEST_PCT, 0.0, 0.0], Some(0))));
        assert_eq!(t.command(11.2), Some(([0.0; 3], None)));
        assert_eq!(t.command(11.6), Some(([0.0, TEST_PCT, 0.0], Some(1))));
        assert_eq!(t.command(13.1), Some(([0.0, 0.0, TEST_PCT], Some(2))));
        assert_eq!(t.command(10.0 + ThrusterTest::DURATION_S), None);
        assert_eq!(t.command(9.0), None);
    }
}
