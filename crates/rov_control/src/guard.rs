//! Output guard: the only place a [`ThrustCommand`] is made from computed values.
//!
//! For each thruster it
//!
//! 1. replaces a non-finite value by neutral (0 %) and raises a fault flag,
//! 2. clamps to `±max_pct` (never beyond the Pro 4's ±100 %),
//! 3. moves from the previous command by at most `max_step_pct` (the per-tick slew
//!    limit, mirroring the thrusters' own acceleration registers).
//!
//! A non-finite value therefore ramps to neutral at the slew rate, so every command the
//! guard lets out is finite, within limits and rate-limited. The one exception is
//! [`OutputGuard::force_neutral`] for failsafes: stopping is always allowed at once.

use crate::error::{ControlError, check_range};

/// A guarded thrust command in percent (−100..100) for the Pro 4's three thrusters.
/// Fields are private: it can only come out of an [`OutputGuard`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThrustCommand {
    port_pct: f64,
    starboard_pct: f64,
    vertical_pct: f64,
}

impl ThrustCommand {
    const ZERO: ThrustCommand = ThrustCommand {
        port_pct: 0.0,
        starboard_pct: 0.0,
        vertical_pct: 0.0,
    };

    /// Port thruster, % (positive forward).
    pub fn port_pct(&self) -> f64 {
        self.port_pct
    }

    /// Starboard thruster, % (positive forward).
    pub fn starboard_pct(&self) -> f64 {
        self.starboard_pct
    }

    /// Vertical thruster, % (positive pushes down).
    pub fn vertical_pct(&self) -> f64 {
        self.vertical_pct
    }

    /// Whether every thruster is at 0 %.
    pub fn is_neutral(&self) -> bool {
        self.port_pct == 0.0 && self.starboard_pct == 0.0 && self.vertical_pct == 0.0
    }

    /// The values for the control block (CSR 0x00–0x05): `[port, starboard, vertical]`
    /// rounded to whole percent.
    pub fn to_wire_pct(&self) -> [i16; 3] {
        // Values are finite and within ±100 by construction, so the casts are exact.
        let r = |v: f64| v.round().clamp(-100.0, 100.0) as i16;
        [
            r(self.port_pct),
            r(self.starboard_pct),
            r(self.vertical_pct),
        ]
    }
}

/// Limits of the guard.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GuardConfig {
    /// Per-thruster magnitude limit, % (0..=100).
    pub max_pct: f64,
    /// Largest change of any thruster per tick, % (> 0).
    pub max_step_pct: f64,
}

impl GuardConfig {
    /// Checks the fields.
    pub fn validate(&self, name: &str) -> Result<(), ControlError> {
        check_range(&format!("{name}.max_pct"), self.max_pct, 0.0, 100.0)?;
        check_range(
            &format!("{name}.max_step_pct"),
            self.max_step_pct,
            0.01,
            200.0,
        )?;
        Ok(())
    }
}

/// What the guard did this tick, per thruster `[port, starboard, vertical]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct GuardReport {
    /// The input was non-finite (fault): the thruster is ramping to neutral.
    pub non_finite: [bool; 3],
    /// The input exceeded the magnitude limit.
    pub clamped: [bool; 3],
    /// The slew limit was active.
    pub rate_limited: [bool; 3],
}

impl GuardReport {
    /// Any non-finite input this tick.
    pub fn fault(&self) -> bool {
        self.non_finite.iter().any(|&b| b)
    }
}

/// The output guard with its memory of the last command.
#[derive(Debug, Clone)]
pub struct OutputGuard {
    max_pct: f64,
    max_step_pct: f64,
    last: ThrustCommand,
}

impl OutputGuard {
    /// A guard starting from neutral.
    pub fn new(cfg: GuardConfig) -> Result<Self, ControlError> {
        cfg.validate("guard")?;
        Ok(Self {
            max_pct: cfg.max_pct,
            max_step_pct: cfg.max_step_pct,
            last: ThrustCommand::ZERO,
        })
    }

    /// The last command let out.
    pub fn last(&self) -> ThrustCommand {
        self.last
    }

    /// Guards one tick's values and returns the command.
    pub fn apply(
        &mut self,
        port_pct: f64,
        starboard_pct: f64,
        vertical_pct: f64,
    ) -> (ThrustCommand, GuardReport) {
        let mut report = GuardReport::default();
        let prev = [
            self.last.port_pct,
            self.last.starboard_pct,
            self.last.vertical_pct,
        ];
        let mut out = [0.0; 3];
        for (k, (o, (&input, &before))) in out
            .iter_mut()
            .zip(
                [port_pct, starboard_pct, vertical_pct]
                    .iter()
                    .zip(prev.iter()),
            )
            .enumerate()
        {
            let target = if input.is_finite() {
                input
            } else {
                if let Some(f) = report.non_finite.get_mut(k) {
                    *f = true;
                }
                0.0
            };
            let limited = target.clamp(-self.max_pct, self.max_pct);
            if limited != target
                && let Some(f) = report.clamped.get_mut(k)
            {
                *f = true;
            }
            let stepped = limited.clamp(before - self.max_step_pct, before + self.max_step_pct);
            if stepped != limited
                && let Some(f) = report.rate_limited.get_mut(k)
            {
                *f = true;
            }
            // `before` is finite and within limits by induction; keep it so if anything
            // above went wrong.
            *o = if stepped.is_finite() {
                stepped.clamp(-self.max_pct, self.max_pct)
            } else {
                0.0
            };
        }
        let [port_pct, starboard_pct, vertical_pct] = out;
        self.last = ThrustCommand {
            port_pct,
            starboard_pct,
            vertical_pct,
        };
        (self.last, report)
    }

    /// Failsafe: neutral at once (no slew limit), and the next ticks start from neutral.
    pub fn force_neutral(&mut self) -> ThrustCommand {
        self.last = ThrustCommand::ZERO;
        self.last
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn non_finite_ramps_to_neutral_with_fault() {
        let mut g = OutputGuard::new(GuardConfig {
            max_pct: 100.0,
            max_step_pct: 10.0,
        })
        .unwrap();
        for _ in 0..20 {
            g.apply(100.0, -100.0, 50.0);
        }
        assert_eq!(g.last().to_wire_pct(), [100, -100, 50]);
        let (c, r) = g.apply(f64::NAN, f64::INFINITY, f64::NEG_INFINITY);
        assert!(r.fault() && r.non_finite == [true, true, true]);
        assert_eq!(c.to_wire_pct(), [90, -90, 40]);
        for _ in 0..10 {
            g.apply(f64::NAN, f64::NAN, f64::NAN);
        }
        assert!(g.last().is_neutral());
        let (c, r) = g.apply(1e300, -1e300, 5.0);
        assert_eq!(c.to_wire_pct(), [10, -10, 5]);
        assert!(r.clamped[0] && r.rate_limited[0] && !r.rate_limited[2]);
        assert!(g.force_neutral().is_neutral());
    }

    #[test]
    fn rejects_bad_config() {
        assert!(
            OutputGuard::new(GuardConfig {
                max_pct: 120.0,
                max_step_pct: 1.0
            })
            .is_err()
        );
        assert!(
            OutputGuard::new(GuardConfig {
                max_pct: 100.0,
                max_step_pct: f64::NAN
            })
            .is_err()
        );
        assert!(
            OutputGuard::new(GuardConfig {
                max_pct: 100.0,
                max_step_pct: 0.0
            })
            .is_err()
        );
    }
}
