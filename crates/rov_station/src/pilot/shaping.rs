//! Stick shaping (deadband that rescales the rest of the travel, expo, invert), thrust
//! gain steps, and the hold-to-arm timer.
//!
//! Shaping happens in the runtime, for every input source alike (gamepad, keyboard). The
//! controller applies its own stick deadband and maps the travel beyond it linearly to
//! thrust (`rov_control::pilot::stick_to_pct`). The runtime therefore hands the
//! controller `db_c + (1 − db_c)·gain·shaped` (with the controller's deadband `db_c` of
//! that axis), so that the thrust is exactly `gain · shaped · max` and the shaped zero
//! stays inside the controller's deadband (a centred stick never overrides a hold).

use rov_control::{ControlConfig, PilotInput};

/// Shaping of one stick axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisShaping {
    /// Deadband, fraction of full travel (0..0.5). Inside it the output is 0; beyond it
    /// the rest of the travel is rescaled to 0..1, so there is no step at its edge.
    pub deadband: f64,
    /// Expo, 0..1: 0 is linear, 1 is cubic (`(1 − e)·x + e·x³`).
    pub expo: f64,
    /// Reverse the axis.
    pub invert: bool,
    /// Output at full deflection, 0.1..1 (before the thrust gain).
    pub scale: f64,
}

impl Default for AxisShaping {
    fn default() -> Self {
        Self {
            deadband: 0.08,
            expo: 0.3,
            invert: false,
            scale: 1.0,
        }
    }
}

impl AxisShaping {
    /// The shaped value of a raw stick value (−1..1); non-finite counts as centred.
    #[must_use]
    pub fn apply(&self, raw: f64) -> f64 {
        if !raw.is_finite() {
            return 0.0;
        }
        let x = raw.clamp(-1.0, 1.0);
        let x = if self.invert { -x } else { x };
        let db = if self.deadband.is_finite() {
            self.deadband.clamp(0.0, 0.5)
        } else {
            0.0
        };
        if x.abs() <= db {
            return 0.0;
        }
        let r = (x.abs() - db) / (1.0 - db);
        let e = if self.expo.is_finite() {
            self.expo.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let y = (1.0 - e) * r + e * r * r * r;
        let k = if self.scale.is_finite() {
            self.scale.clamp(0.0, 1.0)
        } else {
            1.0
        };
        (y.clamp(0.0, 1.0) * k).copysign(x)
    }
}

/// Shaping of the three axes.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StickShaping {
    /// Forward / astern.
    pub surge: AxisShaping,
    /// Turn.
    pub yaw: AxisShaping,
    /// Dive / rise.
    pub vertical: AxisShaping,
}

impl StickShaping {
    /// Reads `[gamepad.surge]`, `[gamepad.yaw]`, `[gamepad.vertical]` (deadband 0..0.5,
    /// expo 0..1, invert, scale 0.1..1; every key optional).
    ///
    /// # Errors
    /// [`rov_types::params::ConfigError`] naming the file, key, value and range.
    pub fn from_param_file(
        f: &rov_types::params::ParamFile,
    ) -> Result<Self, rov_types::params::ConfigError> {
        let d = Self::default();
        let axis = |name: &str, d: AxisShaping| -> Result<AxisShaping, _> {
            let k = |x: &str| format!("gamepad.{name}.{x}");
            Ok(AxisShaping {
                deadband: f.f64_or(&k("deadband"), 0.0..=0.5, d.deadband)?,
                expo: f.f64_or(&k("expo"), 0.0..=1.0, d.expo)?,
                invert: f.bool_or(&k("invert"), d.invert)?,
                scale: f.f64_or(&k("scale"), 0.1..=1.0, d.scale)?,
            })
        };
        Ok(Self {
            surge: axis("surge", d.surge)?,
            yaw: axis("yaw", d.yaw)?,
            vertical: axis("vertical", d.vertical)?,
        })
    }

    /// One axis's table as TOML lines.
    #[must_use]
    pub fn axis_toml(a: &AxisShaping) -> String {
        format!(
            "deadband = {:?}\nexpo = {:?}\ninvert = {}\nscale = {:?}\n",
            a.deadband, a.expo, a.invert, a.scale
        )
    }

    /// Shaped sticks (−1..1 each) from raw sticks.
    #[must_use]
    pub fn apply(&self, raw: &PilotInput) -> PilotInput {
        PilotInput {
            surge: self.surge.apply(raw.surge),
            yaw: self.yaw.apply(raw.yaw),
            vertical: self.vertical.apply(raw.vertical),
        }
    }
}

/// The thrust gain steps, % of full thrust.
pub const GAIN_STEPS_PCT: [f64; 4] = [25.0, 50.0, 75.0, 100.0];

/// The gain step in force.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Gain {
    index: usize,
}

impl Default for Gain {
    /// 50 %.
    fn default() -> Self {
        Self { index: 1 }
    }
}

impl Gain {
    /// The step with this index (clamped).
    #[must_use]
    pub fn with_index(index: usize) -> Self {
        Self {
            index: index.min(GAIN_STEPS_PCT.len() - 1),
        }
    }

    /// The index into [`GAIN_STEPS_PCT`].
    #[must_use]
    pub const fn index(self) -> usize {
        self.index
    }

    /// The gain, %.
    #[must_use]
    pub fn pct(self) -> f64 {
        GAIN_STEPS_PCT.get(self.index).copied().unwrap_or(100.0)
    }

    /// One step up (saturating).
    #[must_use]
    pub fn up(self) -> Self {
        Self::with_index(self.index + 1)
    }

    /// One step down (saturating).
    #[must_use]
    pub fn down(self) -> Self {
        Self::with_index(self.index.saturating_sub(1))
    }
}

/// Maps shaped sticks and the gain to the controller's input (see the module docs).
#[must_use]
pub fn to_controller(shaped: &PilotInput, gain: Gain, cfg: &ControlConfig) -> PilotInput {
    let g = gain.pct() / 100.0;
    let map = |v: f64, db: f64| {
        if v == 0.0 || !v.is_finite() {
            0.0
        } else {
            let db = db.clamp(0.0, 0.99);
            (db + (1.0 - db) * (g * v.abs()).min(1.0)).copysign(v)
        }
    };
    PilotInput {
        surge: map(shaped.surge, cfg.surge_deadband),
        yaw: map(shaped.yaw, cfg.heading.stick_deadband),
        vertical: map(shaped.vertical, cfg.depth.stick_deadband),
    }
}

/// How long the arm button must be held, µs.
pub const ARM_HOLD_US: u64 = 1_000_000;

/// A held arm button (GUI or gamepad) must be reported again within this time, µs, or
/// the hold is cancelled (a frozen GUI cannot finish arming). Generous on purpose: a
/// loaded laptop's GUI may refresh only every 400-500 ms, and arming must still work.
pub const ARM_REFRESH_US: u64 = 1_000_000;

/// The hold-to-arm timer, on the runtime's clock and driven by the button's reports
/// (press, still held, release), never by how often the GUI draws: the hold starts at the
/// first "held" report and completes at the first "held" report at least
/// [`ARM_HOLD_US`] later, so a GUI reporting every 400 ms arms at 1.2 s, and a frozen
/// GUI (no report after the second) cannot arm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ArmHold {
    since_us: Option<u64>,
    last_seen_us: u64,
    fired: bool,
    released_early: bool,
    went_stale: bool,
}

impl ArmHold {
    /// The button is reported held (`true`) or released at `now_us`.
    pub fn report(&mut self, pressed: bool, now_us: u64) {
        if pressed {
            if self.since_us.is_some() && now_us.saturating_sub(self.last_seen_us) > ARM_REFRESH_US
            {
                // Reports stopped for too long: this is a new press.
                self.since_us = None;
            }
            if self.since_us.is_none() {
                self.since_us = Some(now_us);
                self.fired = false;
            }
            self.last_seen_us = now_us;
        } else {
            if self.since_us.is_some() && !self.fired {
                self.released_early = true;
            }
            self.since_us = None;
            self.fired = false;
        }
    }

    /// Whether the button was released before the hold completed since the last call
    /// (the pilot pressed briefly: tell them to hold it).
    pub fn take_released_early(&mut self) -> bool {
        std::mem::take(&mut self.released_early)
    }

    /// Whether a hold was cancelled because its reports stopped since the last call
    /// (tell the pilot why the hold did not arm).
    pub fn take_went_stale(&mut self) -> bool {
        std::mem::take(&mut self.went_stale)
    }

    /// Advances to `now_us`; returns true once per hold when the hold completes.
    pub fn poll(&mut self, now_us: u64) -> bool {
        let Some(since) = self.since_us else {
            return false;
        };
        if now_us.saturating_sub(self.last_seen_us) > ARM_REFRESH_US {
            self.since_us = None;
            if !self.fired {
                self.went_stale = true;
            }
            self.fired = false;
            return false;
        }
        if !self.fired && self.last_seen_us.saturating_sub(since) >= ARM_HOLD_US {
            self.fired = true;
            return true;
        }
        false
    }

    /// Progress of the hold, 0..1 (0 when not held).
    #[must_use]
    pub fn progress(&self, now_us: u64) -> f64 {
        if now_us.saturating_sub(self.last_seen_us) > ARM_REFRESH_US {
            return 0.0;
        }
        match self.since_us {
            Some(since) if !self.fired => {
                (now_us.saturating_sub(since) as f64 / ARM_HOLD_US as f64).clamp(0.0, 1.0)
            }
            Some(_) => 1.0,
            None => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deadband_rescales_without_a_step() {
        let s = AxisShaping {
            deadband: 0.1,
            expo: 0.0,
            invert: false,
            scale: 1.0,
        };
        assert_eq!(s.apply(0.05), 0.0);
        assert_eq!(s.apply(0.1), 0.0);
        assert!(s.apply(0.1001) < 1e-3);
        assert!((s.apply(0.55) - 0.5).abs() < 1e-12);
        assert_eq!(s.apply(1.0), 1.0);
        assert_eq!(s.apply(-1.0), -1.0);
        assert_eq!(s.apply(f64::NAN), 0.0);
        assert_eq!(s.apply(7.0), 1.0);
    }

    #[test]
    fn expo_softens_the_centre_and_keeps_the_ends() {
        let s = AxisShaping {
            deadband: 0.0,
            expo: 1.0,
            invert: true,
            scale: 1.0,
        };
        assert!((s.apply(0.5) + 0.125).abs() < 1e-12);
        assert_eq!(s.apply(-1.0), 1.0);
        let half = AxisShaping { scale: 0.5, ..s };
        assert_eq!(half.apply(-1.0), 0.5);
    }

    #[test]
    fn gain_steps_saturate() {
        let g = Gain::default();
        assert_eq!(g.pct(), 50.0);
        assert_eq!(g.up().up().up().pct(), 100.0);
        assert_eq!(g.down().down().pct(), 25.0);
    }

    #[test]
    fn controller_mapping_gives_gain_times_shaped_thrust() {
        let cfg = ControlConfig::default();
        let shaped = PilotInput {
            surge: 1.0,
            yaw: 0.0,
            vertical: -0.5,
        };
        let p = to_controller(&shaped, Gain::with_index(0), &cfg);
        let db = cfg.surge_deadband;
        // stick_to_pct maps db..1 linearly to 0..max: thrust fraction = (p − db)/(1 − db).
        assert!(((p.surge - db) / (1.0 - db) - 0.25).abs() < 1e-12);
        assert_eq!(p.yaw, 0.0);
        let dbv = cfg.depth.stick_deadband;
        assert!(((-p.vertical - dbv) / (1.0 - dbv) - 0.125).abs() < 1e-12);
    }

    #[test]
    fn arm_needs_one_second_of_fresh_holding() {
        let mut a = ArmHold::default();
        a.report(true, 0);
        for t in (0..1_000_000).step_by(100_000) {
            a.report(true, t);
            assert!(!a.poll(t), "{t}");
        }
        a.report(true, 1_000_000);
        assert!(a.poll(1_000_000));
        assert!(!a.poll(1_100_000), "fires once per hold");
        // A stale report cancels, and says so.
        let mut b = ArmHold::default();
        b.report(true, 0);
        assert!(!b.poll(900_000), "no report since the press: not complete");
        assert!(!b.poll(1_100_000));
        assert_eq!(b.progress(1_100_000), 0.0);
        assert!(b.take_went_stale());
        b.report(true, 1_200_000);
        assert!(!b.poll(1_300_000), "a report after a gap starts a new hold");
        // Releasing cancels.
        let mut c = ArmHold::default();
        c.report(true, 0);
        c.report(false, 500_000);
        c.report(true, 600_000);
        c.report(true, 1_000_000);
        assert!(!c.poll(1_100_000));
        assert!((c.progress(1_100_000) - 0.5).abs() < 1e-9);
    }

    #[test]
    fn arm_completes_when_the_gui_reports_only_every_400_ms() {
        // A loaded laptop: the GUI draws (and reports the held button) every 400 ms
        // while the runtime ticks at 50 Hz. The hold completes at the first report at
        // or after 1 s (1.2 s here) and never resets on the way.
        let mut a = ArmHold::default();
        let mut armed_at = None;
        let mut last_progress = 0.0;
        for tick in 0..100u64 {
            let now = tick * 20_000;
            if now % 400_000 == 0 && now <= 1_600_000 {
                a.report(true, now);
            }
            if a.poll(now) && armed_at.is_none() {
                armed_at = Some(now);
            }
            if armed_at.is_none() {
                let p = a.progress(now);
                assert!(p >= last_progress, "progress fell at {now} µs: {p}");
                last_progress = p;
            }
        }
        assert_eq!(armed_at, Some(1_200_000));
        assert!(!a.take_went_stale());
    }
}
