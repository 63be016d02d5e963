//! Configuration data read from register 0xF7 (protocol.md §6.4, S2/S7): an
//! extended-length reply carrying the bootloader block and the hardware
//! configuration block.

use crate::bytes::{Reader, Writer, fill};
use crate::csr;
use crate::device::DeviceType;
use crate::error::{DecodeError, EncodeError};
use crate::frame::{Direction, Frame, Header, LengthField, NodeId, encode_frame, flags};

use super::{expect_addr, expect_direction, expect_len};

/// Size of the bootloader block.
pub const BOOTLOADER_BLOCK_LEN: usize = 32;
/// Size of the hardware-configuration block (u32 + 8 × 32 bytes).
pub const HARDWARE_CONFIG_LEN: usize = 260;
/// Size of each ASCII field of the hardware configuration.
pub const CONFIG_TEXT_LEN: usize = 32;
/// Payload of the config reply: type byte + 32 + 260 = 293 (EXT LEN 0x0125).
pub const CONFIG_PAYLOAD_LEN: usize = 1 + BOOTLOADER_BLOCK_LEN + HARDWARE_CONFIG_LEN;
/// Valid-application flag (bytes `60 0D F0 0D` on the wire).
pub const VALID_APP_FLAG: u32 = 0x0DF0_0D60;

/// The text of a NUL-padded ASCII field: the bytes before the first NUL, if they
/// are valid UTF-8.
#[must_use]
pub fn ascii_text(field: &[u8]) -> Option<&str> {
    let end = field.iter().position(|&b| b == 0).unwrap_or(field.len());
    core::str::from_utf8(field.get(..end)?).ok()
}

/// Bootloader block (32 bytes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
pub struct BootloaderBlock {
    /// Bootloader version.
    pub version: u16,
    /// Device type as stored by the bootloader (u16; 1 = Pro 4).
    pub device_type: u16,
    /// Serial number, ASCII padded with NUL (see [`BootloaderBlock::serial_str`]).
    pub serial: [u8; 16],
    /// Reserved bytes, kept as received.
    pub reserved: [u8; 8],
    /// [`VALID_APP_FLAG`] when the application image is valid.
    pub valid_app_flag: u32,
}

impl BootloaderBlock {
    /// Serial number up to the first NUL.
    #[must_use]
    pub fn serial_str(&self) -> Option<&str> {
        ascii_text(&self.serial)
    }

    /// True if the valid-application flag is 0x0DF00D60.
    #[must_use]
    pub const fn is_app_valid(&self) -> bool {
        self.valid_app_flag == VALID_APP_FLAG
    }

    fn write(&self, w: &mut Writer<'_>) {
        w.u16(self.version);
        w.u16(self.device_type);
        w.put(&self.serial);
        w.put(&self.reserved);
        w.u32(self.valid_app_flag);
    }

    fn read(r: &mut Reader<'_>) -> Option<Self> {
        Some(Self {
            version: r.u16()?,
            device_type: r.u16()?,
            serial: r.array()?,
            reserved: r.array()?,
            valid_app_flag: r.u32()?,
        })
    }
}

/// Hardware-configuration block (260 bytes): structure version and eight
/// NUL-padded 32-byte ASCII revision fields (read them with [`ascii_text`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
pub struct HardwareConfig {
    /// Structure version.
    pub structure_version: u32,
    /// CPU board revision.
    pub cpu_board: [u8; CONFIG_TEXT_LEN],
    /// Power board revision.
    pub power_board: [u8; CONFIG_TEXT_LEN],
    /// Depth board revision.
    pub depth_board: [u8; CONFIG_TEXT_LEN],
    /// Camera-IO board revision.
    pub camera_io_board: [u8; CONFIG_TEXT_LEN],
    /// Camera revision.
    pub camera: [u8; CONFIG_TEXT_LEN],
    /// Lights revision.
    pub lights: [u8; CONFIG_TEXT_LEN],
    /// Horizontal thruster revision.
    pub horizontal_thrusters: [u8; CONFIG_TEXT_LEN],
    /// Vertical thruster revision.
    pub vertical_thrusters: [u8; CONFIG_TEXT_LEN],
}

impl HardwareConfig {
    /// All zero (an empty block, as in vector V18).
    pub const EMPTY: Self = Self {
        structure_version: 0,
        cpu_board: [0; CONFIG_TEXT_LEN],
        power_board: [0; CONFIG_TEXT_LEN],
        depth_board: [0; CONFIG_TEXT_LEN],
        camera_io_board: [0; CONFIG_TEXT_LEN],
        camera: [0; CONFIG_TEXT_LEN],
        lights: [0; CONFIG_TEXT_LEN],
        horizontal_thrusters: [0; CONFIG_TEXT_LEN],
        vertical_thrusters: [0; CONFIG_TEXT_LEN],
    };

    /// The eight text fields with their names, in wire order.
    #[must_use]
    pub fn text_fields(&self) -> [(&'static str, &[u8; CONFIG_TEXT_LEN]); 8] {
        [
            ("cpu_board", &self.cpu_board),
            ("power_board", &self.power_board),
            ("depth_board", &self.depth_board),
            ("camera_io_board", &self.camera_io_board),
            ("camera", &self.camera),
            ("lights", &self.lights),
            ("horizontal_thrusters", &self.horizontal_thrusters),
            ("vertical_thrusters", &self.vertical_thrusters),
        ]
    }

    fn write(&self, w: &mut Writer<'_>) {
        w.u32(self.structure_version);
        for (_, field) in self.text_fields() {
            w.put(field);
        }
    }

    fn read(r: &mut Reader<'_>) -> Option<Self> {
        Some(Self {
            structure_version: r.u32()?,
            cpu_board: r.array()?,
            power_board: r.array()?,
            depth_board: r.array()?,
            camera_io_board: r.array()?,
            camera: r.array()?,
            lights: r.array()?,
            horizontal_thrusters: r.array()?,
            vertical_thrusters: r.array()?,
        })
    }
}

/// The configuration data: reply to the read of 0xF7 (vector V18; 304 bytes on
/// the wire, extended length 293).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
pub struct ConfigData {
    /// Responder's device type (payload byte 0).
    pub device_type: DeviceType,
    /// Bootloader block.
    pub bootloader: BootloaderBlock,
    /// Hardware-configuration block.
    pub hardware: HardwareConfig,
}

impl ConfigData {
    /// The 293 payload bytes (type byte first).
    #[must_use]
    pub fn to_payload(&self) -> [u8; CONFIG_PAYLOAD_LEN] {
        fill(|w| {
            w.u8(self.device_type.to_byte());
            self.bootloader.write(w);
            self.hardware.write(w);
        })
    }

    /// Decodes exactly 293 payload bytes.
    ///
    /// # Errors
    /// [`DecodeError::WrongLength`] for any other length.
    pub fn from_payload(payload: &[u8]) -> Result<Self, DecodeError> {
        expect_len(payload.len(), CONFIG_PAYLOAD_LEN)?;
        let mut r = Reader::new(payload);
        let mut read = || -> Option<Self> {
            let data = Self {
                device_type: DeviceType::from_byte(r.u8()?),
                bootloader: BootloaderBlock::read(&mut r)?,
                hardware: HardwareConfig::read(&mut r)?,
            };
            r.is_empty().then_some(data)
        };
        read().ok_or(DecodeError::WrongLength {
            expected: CONFIG_PAYLOAD_LEN,
            found: payload.len(),
        })
    }

    /// Encodes the extended-length reply (FLAGS 0x80, CSR ADDRESS 0xF7).
    /// Returns 304.
    ///
    /// # Errors
    /// [`EncodeError::BufferTooSmall`] if `out` is shorter than 304 bytes.
    pub fn encode_response(&self, node: NodeId, out: &mut [u8]) -> Result<usize, EncodeError> {
        encode_frame(
            &Header::response(node, flags::DUMP, csr::CONFIG_DATA),
            &self.to_payload(),
            LengthField::Extended,
            out,
        )
    }

    /// Decodes a dump reply at 0xF7 with a 293-byte payload (normally extended
    /// length; FLAGS ≥ 0x80).
    ///
    /// # Errors
    /// [`DecodeError`] for anything else.
    pub fn from_frame(frame: &Frame<'_>) -> Result<Self, DecodeError> {
        expect_direction(frame, Direction::Response)?;
        if frame.flags() < flags::DUMP {
            return Err(DecodeError::WrongFlags {
                found: frame.flags(),
            });
        }
        expect_addr(frame.addr(), csr::CONFIG_DATA)?;
        Self::from_payload(frame.payload())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ascii_text_stops_at_nul() {
        assert_eq!(ascii_text(b"J14461\0\0junk"), Some("J14461"));
        assert_eq!(ascii_text(b"abc"), Some("abc"));
        assert_eq!(ascii_text(&[0xFF, 0]), None);
        assert_eq!(ascii_text(&[]), Some(""));
    }
}
