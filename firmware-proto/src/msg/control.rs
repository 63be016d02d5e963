//! The 15-byte control block at CSR 0x00 (protocol.md §6.1).

use crate::bytes::{Reader, fill};
use crate::csr;
use crate::error::{DecodeError, EncodeError, RangeError};
use crate::frame::{Direction, Frame, NodeId, encode_request};

use super::{expect_addr, expect_direction, expect_len};

/// Length of the control block (CSR 0x00–0x0E).
pub const CONTROL_BLOCK_LEN: usize = csr::CONTROL_LEN;

/// Wire value of an autopilot target that is off.
pub const TARGET_OFF: u16 = 0xFFFF;

/// Bits of the camera-button byte (CSR 0x0A).
pub mod camera_button {
    /// Menu.
    pub const MENU: u8 = 0x01;
    /// Up.
    pub const UP: u8 = 0x02;
    /// Down.
    pub const DOWN: u8 = 0x04;
    /// Left.
    pub const LEFT: u8 = 0x08;
    /// Right.
    pub const RIGHT: u8 = 0x10;
    /// Menu off (if supported).
    pub const MENU_OFF: u8 = 0x20;
}

/// The control block the host writes to CSR 0x00 every cycle.
///
/// Wire layout (little endian): port, starboard, vertical thrust (i16 each),
/// lights (u8), tilt (i8), focus (i8), camera control (u8), camera buttons (u8),
/// auto-depth target (u16), auto-heading target (u16).
///
/// The fields hold wire values and are not range-checked when encoding (the
/// wire can carry any value); [`ControlBlock::validate`] checks the documented
/// ranges. `Some(0xFFFF)` as a target encodes as "off" and decodes as `None`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
pub struct ControlBlock {
    /// Port thruster, −100..=100 % power (negative = reverse).
    pub port_pct: i16,
    /// Starboard thruster, −100..=100 %.
    pub starboard_pct: i16,
    /// Vertical thruster, −100..=100 % (physical sign UNCERTAIN).
    pub vertical_pct: i16,
    /// Main lights, 0..=100 %.
    pub lights_pct: u8,
    /// Camera tilt, −90..=90, roughly degrees.
    pub tilt_deg: i8,
    /// Camera focus, −100..=100 % of the focal range.
    pub focus_pct: i8,
    /// Camera control bitfield (CSR 0x09).
    pub camera_control: u8,
    /// Camera button bitfield (CSR 0x0A, see [`camera_button`]).
    pub camera_buttons: u8,
    /// Auto-depth target in mbar; `None` = off (0xFFFF).
    pub depth_target_mbar: Option<u16>,
    /// Auto-heading target in whole degrees 0..=359; `None` = off (0xFFFF).
    pub heading_target_deg: Option<u16>,
}

impl Default for ControlBlock {
    /// [`ControlBlock::ALL_STOP`].
    fn default() -> Self {
        Self::ALL_STOP
    }
}

fn target_to_wire(target: Option<u16>) -> u16 {
    target.unwrap_or(TARGET_OFF)
}

fn target_from_wire(raw: u16) -> Option<u16> {
    (raw != TARGET_OFF).then_some(raw)
}

fn check(field: &'static str, value: i32, min: i32, max: i32) -> Result<(), RangeError> {
    if (min..=max).contains(&value) {
        Ok(())
    } else {
        Err(RangeError {
            field,
            value,
            min,
            max,
        })
    }
}

impl ControlBlock {
    /// Zero thrust, lights off, camera neutral, both autopilots off: the safe
    /// first command after (re)connecting (vector V17).
    pub const ALL_STOP: Self = Self {
        port_pct: 0,
        starboard_pct: 0,
        vertical_pct: 0,
        lights_pct: 0,
        tilt_deg: 0,
        focus_pct: 0,
        camera_control: 0,
        camera_buttons: 0,
        depth_target_mbar: None,
        heading_target_deg: None,
    };

    /// Checks the documented ranges: thrust −100..=100, lights 0..=100, tilt
    /// −90..=90, focus −100..=100, depth target 0..=65534, heading target 0..=359.
    ///
    /// # Errors
    /// The first field out of range.
    pub fn validate(&self) -> Result<(), RangeError> {
        check("port_pct", self.port_pct.into(), -100, 100)?;
        check("starboard_pct", self.starboard_pct.into(), -100, 100)?;
        check("vertical_pct", self.vertical_pct.into(), -100, 100)?;
        check("lights_pct", self.lights_pct.into(), 0, 100)?;
        check("tilt_deg", self.tilt_deg.into(), -90, 90)?;
        check("focus_pct", self.focus_pct.into(), -100, 100)?;
        if let Some(d) = self.depth_target_mbar {
            check("depth_target_mbar", d.into(), 0, 65_534)?;
        }
        if let Some(h) = self.heading_target_deg {
            check("heading_target_deg", h.into(), 0, 359)?;
        }
        Ok(())
    }

    /// The 15 payload bytes.
    #[must_use]
    pub fn to_bytes(&self) -> [u8; CONTROL_BLOCK_LEN] {
        fill(|w| {
            w.i16(self.port_pct);
            w.i16(self.starboard_pct);
            w.i16(self.vertical_pct);
            w.u8(self.lights_pct);
            w.i8(self.tilt_deg);
            w.i8(self.focus_pct);
            w.u8(self.camera_control);
            w.u8(self.camera_buttons);
            w.u16(target_to_wire(self.depth_target_mbar));
            w.u16(target_to_wire(self.heading_target_deg));
        })
    }

    /// Decodes exactly 15 payload bytes.
    ///
    /// # Errors
    /// [`DecodeError::WrongLength`] for any other length.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, DecodeError> {
        expect_len(bytes.len(), CONTROL_BLOCK_LEN)?;
        let wrong = DecodeError::WrongLength {
            expected: CONTROL_BLOCK_LEN,
            found: bytes.len(),
        };
        let mut r = Reader::new(bytes);
        let mut read = || -> Option<Self> {
            Some(Self {
                port_pct: r.i16()?,
                starboard_pct: r.i16()?,
                vertical_pct: r.i16()?,
                lights_pct: r.u8()?,
                tilt_deg: r.i8()?,
                focus_pct: r.i8()?,
                camera_control: r.u8()?,
                camera_buttons: r.u8()?,
                depth_target_mbar: target_from_wire(r.u16()?),
                heading_target_deg: target_from_wire(r.u16()?),
            })
        };
        read().ok_or(wrong)
    }

    /// Encodes the request that writes this block to CSR 0x00 of `node` and asks
    /// for the reply selected by `flags` (normally [`flags::NAV`](crate::flags::NAV)).
    /// Returns the frame length (23).
    ///
    /// # Errors
    /// [`EncodeError::BufferTooSmall`] if `out` is shorter than 23 bytes.
    pub fn encode_request(
        &self,
        node: NodeId,
        flags: u8,
        out: &mut [u8],
    ) -> Result<usize, EncodeError> {
        encode_request(node, flags, csr::CONTROL, &self.to_bytes(), out)
    }

    /// Decodes a request that writes 15 bytes at CSR 0x00 (any FLAGS).
    ///
    /// # Errors
    /// [`DecodeError`] if the frame is not such a request.
    pub fn from_frame(frame: &Frame<'_>) -> Result<Self, DecodeError> {
        expect_direction(frame, Direction::Request)?;
        expect_addr(frame.addr(), csr::CONTROL)?;
        Self::from_bytes(frame.payload())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validate_names_the_field() {
        let mut c = ControlBlock::ALL_STOP;
        assert_eq!(c.validate(), Ok(()));
        c.tilt_deg = -91;
        assert_eq!(
            c.validate(),
            Err(RangeError {
                field: "tilt_deg",
                value: -91,
                min: -90,
                max: 90
            })
        );
        c.tilt_deg = 0;
        c.heading_target_deg = Some(360);
        assert_eq!(c.validate().map_err(|e| e.field), Err("heading_target_deg"));
    }

    #[test]
    fn from_bytes_rejects_wrong_length() {
        assert_eq!(
            ControlBlock::from_bytes(&[0; 14]),
            Err(DecodeError::WrongLength {
                expected: 15,
                found: 14
            })
        );
    }
}
