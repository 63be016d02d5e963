//! Typed Pro 4 messages (protocol.md §6), encoded and decoded on both sides.
//!
//! Every message keeps the raw wire integers in public fields (so decoding then
//! encoding reproduces the bytes exactly) and offers scaled accessors such as
//! [`NavReply::heading_deg`]. Response types carry their `device_type` byte.
//!
//! Each type has:
//! * `to_bytes`/`to_payload` and `from_bytes`/`from_payload`: the payload only;
//! * `encode_request`/`encode_response`: the whole frame into a caller buffer;
//! * `from_frame`: checks direction, FLAGS, address and length, then decodes.

mod config;
mod control;
mod registers;
mod telemetry;

pub use config::{
    BOOTLOADER_BLOCK_LEN, BootloaderBlock, CONFIG_PAYLOAD_LEN, CONFIG_TEXT_LEN, ConfigData,
    HARDWARE_CONFIG_LEN, HardwareConfig, VALID_APP_FLAG, ascii_text,
};
pub use control::{CONTROL_BLOCK_LEN, ControlBlock, TARGET_OFF, camera_button};
pub use registers::{CsrDump, CsrRead, Reboot, STATUS_BLOCK_LEN, STATUS_PAYLOAD_LEN, StatusBlock};
pub use telemetry::{NAV_PAYLOAD_LEN, NavReply, PING_REPLY_PAYLOAD_LEN, Ping, PingReply};

use crate::error::DecodeError;
use crate::frame::{Direction, Frame};

/// Checks direction and returns the device type + data of a response.
pub(crate) fn expect_direction(frame: &Frame<'_>, expected: Direction) -> Result<(), DecodeError> {
    if frame.direction() == expected {
        Ok(())
    } else {
        Err(DecodeError::WrongDirection { expected })
    }
}

pub(crate) fn expect_len(found: usize, expected: usize) -> Result<(), DecodeError> {
    if found == expected {
        Ok(())
    } else {
        Err(DecodeError::WrongLength { expected, found })
    }
}

pub(crate) fn expect_addr(found: u8, expected: u8) -> Result<(), DecodeError> {
    if found == expected {
        Ok(())
    } else {
        Err(DecodeError::WrongAddr { expected, found })
    }
}

/// Degrees ×10 → degrees.
pub(crate) fn deg_x10_to_deg(raw: i16) -> f64 {
    f64::from(raw) / 10.0
}

/// Heading degrees ×10 (signed; −1800..=1800 and 0..=3599 both occur) →
/// degrees in [0, 360).
pub(crate) fn heading_x10_to_deg(raw: i16) -> f64 {
    f64::from(i32::from(raw).rem_euclid(3600)) / 10.0
}
