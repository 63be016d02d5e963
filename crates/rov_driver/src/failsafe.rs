//! Arming and the link-loss failsafe (style B2, B3, G4). See `SAFETY.md`.
//!
//! The [`Failsafe`] gates every outgoing control block:
//!
//! * not armed → neutral: all three thrusters 0 and both onboard autopilot targets
//!   off (0xFFFF); lights, tilt, focus and camera bits pass through as requested
//!   (protocol.md §12.2);
//! * the link is lost → the failsafe disarms and raises the [`Alarm::LinkLost`] alarm,
//!   which **latches**: it stays raised after the link comes back, and thrust stays
//!   neutral until the pilot re-arms. A successful [`Failsafe::arm`] clears it;
//! * arming needs a connected link that has been healthy for at least
//!   [`LinkConfig::arm_min_healthy_us`](crate::LinkConfig::arm_min_healthy_us).
//!
//! The failsafe starts disarmed, so the first frames after connecting carry neutral
//! thrust. No feature or `cfg` switches any of this off (B5).

use firmware_proto::ControlBlock;

use crate::error::ArmError;

/// A failsafe alarm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Alarm {
    /// No valid response for T_loss.
    LinkLost,
}

/// A raised alarm and whether its cause is still present.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LatchedAlarm {
    /// Which alarm.
    pub alarm: Alarm,
    /// When it was raised, µs.
    pub raised_us: u64,
    /// Whether the cause is still present (false once the link is back; the alarm
    /// stays latched until re-arm).
    pub cause_active: bool,
}

/// Arming state and the latched link-loss alarm.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Failsafe {
    armed: bool,
    alarm: Option<LatchedAlarm>,
    connected_since_us: Option<u64>,
    min_healthy_us: u64,
}

impl Failsafe {
    /// Disarmed, no alarm, link not connected. Arming needs `min_healthy_us` of
    /// connected link.
    #[must_use]
    pub const fn new(min_healthy_us: u64) -> Self {
        Self {
            armed: false,
            alarm: None,
            connected_since_us: None,
            min_healthy_us,
        }
    }

    /// Whether the pilot's thrust passes through.
    #[must_use]
    pub const fn is_armed(&self) -> bool {
        self.armed
    }

    /// The latched alarm, if any.
    #[must_use]
    pub const fn alarm(&self) -> Option<&LatchedAlarm> {
        self.alarm.as_ref()
    }

    /// Arms, clearing a latched alarm whose cause is gone.
    ///
    /// # Errors
    /// [`ArmError`] if the link is not connected or not yet healthy for long enough.
    pub fn arm(&mut self, now_us: u64) -> Result<(), ArmError> {
        let Some(since) = self.connected_since_us else {
            return Err(ArmError::LinkNotConnected);
        };
        let healthy_us = now_us.saturating_sub(since);
        if healthy_us < self.min_healthy_us {
            return Err(ArmError::NotHealthyLongEnough {
                healthy_us,
                required_us: self.min_healthy_us,
            });
        }
        self.armed = true;
        self.alarm = None;
        Ok(())
    }

    /// Disarms (thrust neutral from the next frame on).
    pub fn disarm(&mut self) {
        self.armed = false;
    }

    /// The link became connected (a valid response after searching or loss).
    pub fn on_link_connected(&mut self, now_us: u64) {
        if self.connected_since_us.is_none() {
            self.connected_since_us = Some(now_us);
        }
        if let Some(a) = self.alarm.as_mut() {
            a.cause_active = false;
        }
    }

    /// The link is degraded: arming is refused until it is connected again, the
    /// healthy time restarts; an armed pilot stays armed.
    pub fn on_link_degraded(&mut self) {
        self.connected_since_us = None;
    }

    /// The link is lost: disarm and latch [`Alarm::LinkLost`]. Returns true if the
    /// alarm was newly raised.
    pub fn on_link_lost(&mut self, now_us: u64) -> bool {
        self.armed = false;
        self.connected_since_us = None;
        match self.alarm.as_mut() {
            Some(a) => {
                a.cause_active = true;
                false
            }
            None => {
                self.alarm = Some(LatchedAlarm {
                    alarm: Alarm::LinkLost,
                    raised_us: now_us,
                    cause_active: true,
                });
                true
            }
        }
    }

    /// The command that may go on the wire: `cmd` when armed, otherwise `cmd` with
    /// neutral thrust and both onboard autopilots off.
    #[must_use]
    pub fn gate(&self, cmd: &ControlBlock) -> ControlBlock {
        if self.armed { *cmd } else { neutral(cmd) }
    }
}

/// `cmd` with zero thrust and both autopilot targets off (lights and camera kept).
#[must_use]
pub const fn neutral(cmd: &ControlBlock) -> ControlBlock {
    ControlBlock {
        port_pct: 0,
        starboard_pct: 0,
        vertical_pct: 0,
        depth_target_mbar: None,
        heading_target_deg: None,
        ..*cmd
    }
}

/// Whether a control block commands no thrust and no autopilot.
#[must_use]
pub const fn is_neutral(cmd: &ControlBlock) -> bool {
    cmd.port_pct == 0
        && cmd.starboard_pct == 0
        && cmd.vertical_pct == 0
        && cmd.depth_target_mbar.is_none()
        && cmd.heading_target_deg.is_none()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cmd() -> ControlBlock {
        ControlBlock {
            port_pct: 40,
            starboard_pct: 40,
            vertical_pct: -20,
            lights_pct: 50,
            depth_target_mbar: Some(1200),
            ..ControlBlock::ALL_STOP
        }
    }

    #[test]
    fn starts_disarmed_and_neutral() {
        let f = Failsafe::new(0);
        assert!(!f.is_armed());
        let g = f.gate(&cmd());
        assert!(is_neutral(&g));
        assert_eq!(g.lights_pct, 50);
    }

    #[test]
    fn arming_needs_a_healthy_link() {
        let mut f = Failsafe::new(1_000_000);
        assert_eq!(f.arm(0), Err(ArmError::LinkNotConnected));
        f.on_link_connected(100);
        assert!(matches!(
            f.arm(500_000),
            Err(ArmError::NotHealthyLongEnough { .. })
        ));
        assert_eq!(f.arm(1_000_100), Ok(()));
        assert_eq!(f.gate(&cmd()), cmd());
    }

    #[test]
    fn loss_latches_until_rearm() {
        let mut f = Failsafe::new(0);
        f.on_link_connected(0);
        f.arm(0).unwrap();
        assert!(f.on_link_lost(10));
        assert!(!f.on_link_lost(20));
        assert!(!f.is_armed());
        assert!(is_neutral(&f.gate(&cmd())));
        f.on_link_connected(30);
        let a = f.alarm().copied().unwrap();
        assert_eq!(
            (a.alarm, a.raised_us, a.cause_active),
            (Alarm::LinkLost, 10, false)
        );
        assert!(is_neutral(&f.gate(&cmd())));
        f.arm(40).unwrap();
        assert!(f.alarm().is_none());
        assert_eq!(f.gate(&cmd()), cmd());
    }

    #[test]
    fn degraded_blocks_arming_but_keeps_armed() {
        let mut f = Failsafe::new(0);
        f.on_link_connected(0);
        f.arm(0).unwrap();
        f.on_link_degraded();
        assert!(f.is_armed());
        f.disarm();
        assert_eq!(f.arm(5), Err(ArmError::LinkNotConnected));
    }
}
