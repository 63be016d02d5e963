//! Pilot input, hold modes with cruise-control semantics, and the targets for the
//! vehicle's own auto-depth and auto-heading (CSR 0x0B and 0x0D).
//!
//! Per axis (depth, heading) the mode is one of
//!
//! * [`AxisMode::Manual`]: the stick drives the thrust directly;
//! * [`AxisMode::Hold`]: the topside autopilot (observer, reference model, feedforward,
//!   PID) holds the setpoint. Moving the stick out of its deadband overrides the hold on
//!   that axis (the stick drives the thrust, [`AxisState::overridden`]); releasing it
//!   latches a new setpoint;
//! * [`AxisMode::VehicleAuto`]: the vehicle's onboard auto-depth / auto-heading holds the
//!   target sent in the control block; topside sends neutral on that axis, the stick
//!   overrides (the target is sent as off, 0xFFFF, while overridden) and releasing it
//!   latches the current value as the new target.
//!
//! **Stick-release latch rule (our choice).** The setpoint is latched immediately when
//! the stick re-enters the deadband, at the *stopping point*: the current estimate plus
//! the distance the reference model needs to brake from the current estimated rate
//! (`v·|v| / (2·a_brake)`). The reference model restarts from the current estimate and
//! rate, so the thrust does not jump, the vehicle decelerates smoothly and it does not
//! swing back to the point where the stick was released. In VehicleAuto mode (no topside
//! reference model) the current value is latched as is.
//!
//! Setpoints can also be typed ([`ModeCommand::SetDepth`], [`ModeCommand::SetHeading`])
//! or stepped ([`ModeCommand::StepDepth`], [`ModeCommand::StepHeading`]); on a manual
//! axis those engage the hold ("go to depth").

use crate::angle::wrap_deg_360;
use crate::error::ControlError;
use crate::feedforward::ModelChoice;

/// A controlled axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Axis {
    /// Depth (vertical thruster).
    Depth,
    /// Heading (differential horizontal thrust).
    Heading,
}

/// Who controls an axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AxisMode {
    /// The stick drives the thruster.
    #[default]
    Manual,
    /// The topside autopilot holds a setpoint.
    Hold,
    /// The vehicle's own auto-depth / auto-heading holds a target.
    VehicleAuto,
}

/// Mode and override state of one axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct AxisState {
    /// The selected mode.
    pub mode: AxisMode,
    /// In `Hold` or `VehicleAuto`: the stick is out of its deadband and drives the thrust.
    pub overridden: bool,
}

/// Stick positions, each −1..1 (clamped; non-finite counts as centred and is flagged).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PilotInput {
    /// Forward (+) / astern (−).
    pub surge: f64,
    /// Turn to starboard (+) / port (−).
    pub yaw: f64,
    /// Dive (+, deeper) / rise (−).
    pub vertical: f64,
}

/// A mode or setpoint command from the pilot (GUI, gamepad button, CLI).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ModeCommand {
    /// Hold the current value (latched like a stick release).
    Engage(Axis),
    /// Back to manual on that axis.
    Disengage(Axis),
    /// Hand the axis to the vehicle's own auto mode, target = current value.
    EngageVehicleAuto(Axis),
    /// Go to and hold this depth, m (engages the hold on a manual axis).
    SetDepth {
        /// Target depth, m (positive down).
        depth_m: f64,
    },
    /// Move the depth setpoint by this much, m (positive deeper).
    StepDepth {
        /// Step, m.
        delta_m: f64,
    },
    /// Go to and hold this heading, degrees.
    SetHeading {
        /// Target heading, degrees (any value; wrapped to 0..360).
        heading_deg: f64,
    },
    /// Move the heading setpoint by this much, degrees (positive to starboard).
    StepHeading {
        /// Step, degrees.
        delta_deg: f64,
    },
    /// Switch the feedforward model.
    SelectModel(ModelChoice),
    /// Feedforward on or off.
    SetFeedforward(bool),
    /// The surface pressure tare, mbar (taken at connection by the station).
    SetSurfaceTare {
        /// Absolute pressure at the surface, mbar.
        pressure_mbar: f64,
    },
}

/// Standard gravity used for pressure conversions, m/s².
pub const GRAVITY_M_S2: f64 = 9.81;

/// Where the surface-pressure tare comes from.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum SurfaceTare {
    /// Taken at connection (the station sends [`ModeCommand::SetSurfaceTare`]).
    #[default]
    AtConnection,
    /// A fixed configured value, mbar.
    Configured(f64),
}

/// Allowed surface pressures, mbar (absolute: about 1013; some firmware reports gauge
/// pressure near 0).
pub const TARE_RANGE_MBAR: (f64, f64) = (-100.0, 2000.0);

/// Checks a tare value.
pub fn check_tare(pressure_mbar: f64) -> Result<f64, ControlError> {
    let (lo, hi) = TARE_RANGE_MBAR;
    if pressure_mbar.is_finite() && (lo..=hi).contains(&pressure_mbar) {
        Ok(pressure_mbar)
    } else {
        Err(ControlError::InvalidTare {
            value_mbar: pressure_mbar,
            allowed: format!("{lo}..={hi}"),
        })
    }
}

/// Auto-depth target in mbar for CSR 0x0B: `surface + depth_m · ρ·g / 100`, rounded.
/// `None` (send 0xFFFF = off) if an input is non-finite or the value does not fit in
/// 0..=0xFFFE.
pub fn depth_target_mbar(surface_mbar: f64, depth_m: f64, water_density_kg_m3: f64) -> Option<u16> {
    let p = surface_mbar + depth_m * water_density_kg_m3 * GRAVITY_M_S2 / 100.0;
    if p.is_finite() && (0.0..=f64::from(u16::MAX - 1)).contains(&p.round()) {
        Some(p.round() as u16)
    } else {
        None
    }
}

/// Depth in m from an absolute pressure in mbar: `(p − surface) · 100 / (ρ·g)`.
pub fn depth_m_from_mbar(pressure_mbar: f64, surface_mbar: f64, water_density_kg_m3: f64) -> f64 {
    (pressure_mbar - surface_mbar) * 100.0 / (water_density_kg_m3 * GRAVITY_M_S2)
}

/// Auto-heading target for CSR 0x0D: whole degrees 0..=359; `None` if non-finite.
pub fn heading_target_deg(heading_deg: f64) -> Option<u16> {
    if !heading_deg.is_finite() {
        return None;
    }
    let whole = wrap_deg_360(heading_deg).round();
    Some(if whole >= 360.0 { 0 } else { whole as u16 })
}

/// Targets for the vehicle's own auto modes; `None` is sent as 0xFFFF (off).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct VehicleAutoTargets {
    /// Auto-depth target, mbar (CSR 0x0B–0x0C).
    pub depth_mbar: Option<u16>,
    /// Auto-heading target, whole degrees 0..=359 (CSR 0x0D–0x0E).
    pub heading_deg: Option<u16>,
}

impl VehicleAutoTargets {
    /// The value that means "off" in the control block.
    pub const OFF: u16 = 0xFFFF;

    /// The two control-block words `[0x0B, 0x0D]`, with 0xFFFF for off.
    pub fn csr_words(&self) -> [u16; 2] {
        [
            self.depth_mbar.unwrap_or(Self::OFF),
            self.heading_deg.unwrap_or(Self::OFF),
        ]
    }
}

/// Maps a stick value (−1..1) to a thrust percentage with a deadband: 0 inside the
/// deadband, then linear from 0 to `max_pct` at full deflection. Non-finite → 0.
pub fn stick_to_pct(stick: f64, deadband: f64, max_pct: f64) -> f64 {
    if !stick.is_finite() {
        return 0.0;
    }
    let s = stick.clamp(-1.0, 1.0);
    let db = deadband.clamp(0.0, 0.99);
    if s.abs() <= db {
        0.0
    } else {
        ((s.abs() - db) / (1.0 - db) * max_pct).copysign(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mbar_target_conversion() {
        // Fresh water: 98.1 mbar per metre.
        assert_eq!(depth_target_mbar(1013.0, 10.0, 1000.0), Some(1994));
        assert_eq!(depth_target_mbar(1013.25, 0.0, 1000.0), Some(1013));
        // Sea water 1025 kg/m³: 100.55 mbar/m.
        assert_eq!(depth_target_mbar(1000.0, 2.0, 1025.0), Some(1201));
        assert_eq!(depth_target_mbar(1013.0, f64::NAN, 1000.0), None);
        assert_eq!(depth_target_mbar(1013.0, 1000.0, 1000.0), None);
        assert_eq!(depth_target_mbar(0.0, -5.0, 1000.0), None);
        let d = depth_m_from_mbar(2000.0, 1013.0, 1000.0);
        assert!((d - 10.061_162_079_510_703).abs() < 1e-12);
        assert_eq!(VehicleAutoTargets::default().csr_words(), [0xFFFF, 0xFFFF]);
    }

    #[test]
    fn heading_target_is_whole_degrees() {
        assert_eq!(heading_target_deg(359.6), Some(0));
        assert_eq!(heading_target_deg(-90.2), Some(270));
        assert_eq!(heading_target_deg(725.0), Some(5));
        assert_eq!(heading_target_deg(f64::INFINITY), None);
        let t = VehicleAutoTargets {
            depth_mbar: Some(1200),
            heading_deg: Some(90),
        };
        assert_eq!(t.csr_words(), [1200, 90]);
    }

    #[test]
    fn stick_deadband() {
        assert_eq!(stick_to_pct(0.04, 0.05, 100.0), 0.0);
        assert_eq!(stick_to_pct(1.0, 0.05, 80.0), 80.0);
        assert_eq!(stick_to_pct(-2.0, 0.05, 80.0), -80.0);
        assert_eq!(stick_to_pct(f64::NAN, 0.05, 80.0), 0.0);
        assert!((stick_to_pct(0.525, 0.05, 100.0) - 50.0).abs() < 1e-9);
        assert!(check_tare(1013.0).is_ok() && check_tare(f64::NAN).is_err());
    }
}
