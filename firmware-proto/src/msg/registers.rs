//! CSR reads and dumps (protocol.md §5.2, §6.3), the status block at 0x7A and
//! the reboot write (§6.4).

use crate::bytes::{Reader, fill};
use crate::csr;
use crate::device::DeviceType;
use crate::error::{DecodeError, EncodeError};
use crate::frame::{
    Direction, Frame, NodeId, RequestFlags, encode_request, encode_response, flags,
};

use super::{expect_addr, expect_direction, expect_len};

/// Registers in the status block (0x7A–0x87).
pub const STATUS_BLOCK_LEN: usize = 14;
/// Payload of the status reply: type byte + 14 register bytes.
pub const STATUS_PAYLOAD_LEN: usize = STATUS_BLOCK_LEN + 1;

/// A CSR read request: FLAGS ≥ 0x80, no payload (vectors V7, V9, V11, V12).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
pub struct CsrRead {
    /// First register (CSR ADDRESS).
    pub start: u8,
    /// FLAGS: 0x80 = to the end of the application region, 0x81..=0xFF =
    /// `flags & 0x7F` bytes. Values below 0x80 are encoded as given but are not
    /// reads.
    pub flags: u8,
}

impl CsrRead {
    /// Full dump of the application region from 0 (reply: 240 bytes; V11).
    pub const FULL: Self = Self {
        start: csr::CONTROL,
        flags: flags::DUMP,
    };
    /// The 14-byte status block at 0x7A (FLAGS 0x8E; V7).
    pub const STATUS: Self = Self {
        start: csr::WATER_TEMP,
        flags: flags::STATUS_DUMP,
    };
    /// The configuration data at 0xF7 (extended reply; V12).
    pub const CONFIG: Self = Self {
        start: csr::CONFIG_DATA,
        flags: flags::DUMP,
    };

    /// A read of `count` (1..=127) registers from `start`; `None` if `count` is
    /// out of range.
    #[must_use]
    pub const fn range(start: u8, count: u8) -> Option<Self> {
        if count >= 1 && count <= 0x7F {
            Some(Self {
                start,
                flags: 0x80 | count,
            })
        } else {
            None
        }
    }

    /// Number of register bytes the reply carries (see
    /// [`RequestFlags::dump_len`]); `None` for special registers above 0xEF read
    /// with FLAGS 0x80 (e.g. the config read).
    #[must_use]
    pub const fn count(&self) -> Option<usize> {
        RequestFlags::from_byte(self.flags).dump_len(self.start)
    }

    /// Encodes `FA AF node FLAGS start 00 HC 00`. Returns 8.
    ///
    /// # Errors
    /// [`EncodeError::BufferTooSmall`] if `out` is shorter than 8 bytes.
    pub fn encode_request(&self, node: NodeId, out: &mut [u8]) -> Result<usize, EncodeError> {
        encode_request(node, self.flags, self.start, &[], out)
    }

    /// Decodes a request with FLAGS ≥ 0x80 and no payload.
    ///
    /// # Errors
    /// [`DecodeError`] for anything else.
    pub fn from_frame(frame: &Frame<'_>) -> Result<Self, DecodeError> {
        expect_direction(frame, Direction::Request)?;
        if !frame.request_flags().is_dump() {
            return Err(DecodeError::WrongFlags {
                found: frame.flags(),
            });
        }
        expect_len(frame.payload_len(), 0)?;
        Ok(Self {
            start: frame.addr(),
            flags: frame.flags(),
        })
    }
}

fn check_dump(frame: &Frame<'_>) -> Result<(), DecodeError> {
    expect_direction(frame, Direction::Response)?;
    // S1 says a dump reply always has FLAGS 0x80; accept any FLAGS ≥ 0x80
    // (protocol.md §11 item 6).
    if frame.flags() < flags::DUMP {
        return Err(DecodeError::WrongFlags {
            found: frame.flags(),
        });
    }
    if frame.payload().is_empty() {
        return Err(DecodeError::MissingDeviceType);
    }
    Ok(())
}

/// A CSR dump reply: registers `start..start + data.len()`, borrowed from the
/// frame (vectors V10 and the 249-byte full dump).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
pub struct CsrDump<'a> {
    /// Responder's device type.
    pub device_type: DeviceType,
    /// Address of `data[0]` (the reply's CSR ADDRESS).
    pub start: u8,
    /// Register bytes.
    pub data: &'a [u8],
}

impl<'a> CsrDump<'a> {
    /// True for a full application-region dump: 240 bytes from address 0.
    #[must_use]
    pub fn is_full(&self) -> bool {
        self.start == 0 && self.data.len() == csr::APP_REGION_LEN
    }

    /// The register at CSR address `addr`, if the dump covers it.
    #[must_use]
    pub fn u8_at(&self, addr: u8) -> Option<u8> {
        let i = usize::from(addr).checked_sub(usize::from(self.start))?;
        self.data.get(i).copied()
    }

    /// The little-endian i16 at `addr`, if the dump covers both bytes.
    #[must_use]
    pub fn i16_at(&self, addr: u8) -> Option<i16> {
        let i = usize::from(addr).checked_sub(usize::from(self.start))?;
        let bytes = self.data.get(i..)?.first_chunk::<2>()?;
        Some(i16::from_le_bytes(*bytes))
    }

    /// The little-endian u16 at `addr`, if the dump covers both bytes.
    #[must_use]
    pub fn u16_at(&self, addr: u8) -> Option<u16> {
        self.i16_at(addr)
            .map(|v| u16::from_le_bytes(v.to_le_bytes()))
    }

    /// Encodes the reply (FLAGS 0x80, CSR ADDRESS = `start`, normal length:
    /// at most 253 data bytes). Returns the frame length (`data.len() + 9`).
    ///
    /// # Errors
    /// [`EncodeError`] if the data is too long or `out` too small.
    pub fn encode_response(&self, node: NodeId, out: &mut [u8]) -> Result<usize, EncodeError> {
        encode_response(
            node,
            flags::DUMP,
            self.start,
            self.device_type,
            self.data,
            out,
        )
    }

    /// Decodes any dump reply (FLAGS ≥ 0x80, at least the type byte).
    ///
    /// # Errors
    /// [`DecodeError`] for anything else.
    pub fn from_frame(frame: &Frame<'a>) -> Result<Self, DecodeError> {
        check_dump(frame)?;
        Ok(Self {
            device_type: frame.device_type().unwrap_or(DeviceType::Unknown(0)),
            start: frame.addr(),
            data: frame.data(),
        })
    }
}

/// The status block: reply to the 14-byte read at 0x7A (vector V8).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
pub struct StatusBlock {
    /// Responder's device type.
    pub device_type: DeviceType,
    /// 0x7A: water temperature, °C ×100.
    pub water_temp_c_x100: i16,
    /// 0x7C: tether voltage, V ×100.
    pub tether_v_x100: u16,
    /// 0x7E: 12 V rail voltage, V ×100.
    pub rail_12v_v_x100: u16,
    /// 0x80: 12 V rail current, mA.
    pub rail_12v_ma: u16,
    /// 0x82 (u8): internal temperature, CPU board (reserved, raw).
    pub internal_temp_cpu_raw: u8,
    /// 0x83 (u8): internal temperature, power board (reserved, raw).
    pub internal_temp_power_raw: u8,
    /// 0x84: internal relative humidity, % RH.
    pub humidity_pct: u16,
    /// 0x86: comm error count (wrapping).
    pub comm_errors: u16,
}

impl StatusBlock {
    /// Water temperature in °C.
    #[must_use]
    pub fn water_temp_c(&self) -> f64 {
        f64::from(self.water_temp_c_x100) / 100.0
    }

    /// Tether voltage in V.
    #[must_use]
    pub fn tether_v(&self) -> f64 {
        f64::from(self.tether_v_x100) / 100.0
    }

    /// 12 V rail voltage in V.
    #[must_use]
    pub fn rail_12v_v(&self) -> f64 {
        f64::from(self.rail_12v_v_x100) / 100.0
    }

    /// The 15 payload bytes (type byte first).
    #[must_use]
    pub fn to_payload(&self) -> [u8; STATUS_PAYLOAD_LEN] {
        fill(|w| {
            w.u8(self.device_type.to_byte());
            w.i16(self.water_temp_c_x100);
            w.u16(self.tether_v_x100);
            w.u16(self.rail_12v_v_x100);
            w.u16(self.rail_12v_ma);
            w.u8(self.internal_temp_cpu_raw);
            w.u8(self.internal_temp_power_raw);
            w.u16(self.humidity_pct);
            w.u16(self.comm_errors);
        })
    }

    /// Decodes exactly 15 payload bytes.
    ///
    /// # Errors
    /// [`DecodeError::WrongLength`] for any other length.
    pub fn from_payload(payload: &[u8]) -> Result<Self, DecodeError> {
        expect_len(payload.len(), STATUS_PAYLOAD_LEN)?;
        let mut r = Reader::new(payload);
        let mut read = || -> Option<Self> {
            Some(Self {
                device_type: DeviceType::from_byte(r.u8()?),
                water_temp_c_x100: r.i16()?,
                tether_v_x100: r.u16()?,
                rail_12v_v_x100: r.u16()?,
                rail_12v_ma: r.u16()?,
                internal_temp_cpu_raw: r.u8()?,
                internal_temp_power_raw: r.u8()?,
                humidity_pct: r.u16()?,
                comm_errors: r.u16()?,
            })
        };
        read().ok_or(DecodeError::WrongLength {
            expected: STATUS_PAYLOAD_LEN,
            found: payload.len(),
        })
    }

    /// Encodes the reply (FLAGS 0x80, CSR ADDRESS 0x7A). Returns 23.
    ///
    /// # Errors
    /// [`EncodeError::BufferTooSmall`] if `out` is shorter than 23 bytes.
    pub fn encode_response(&self, node: NodeId, out: &mut [u8]) -> Result<usize, EncodeError> {
        crate::frame::encode_frame(
            &crate::frame::Header::response(node, flags::DUMP, csr::WATER_TEMP),
            &self.to_payload(),
            crate::frame::LengthField::Normal,
            out,
        )
    }

    /// Decodes a dump reply at 0x7A with a 15-byte payload.
    ///
    /// # Errors
    /// [`DecodeError`] for anything else.
    pub fn from_frame(frame: &Frame<'_>) -> Result<Self, DecodeError> {
        check_dump(frame)?;
        expect_addr(frame.addr(), csr::WATER_TEMP)?;
        Self::from_payload(frame.payload())
    }
}

/// The reboot request: write `DE AD` to the utility register 0xFE (vector V14).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
pub struct Reboot;

impl Reboot {
    /// Encodes `FA AF node 00 FE 02 HC DE AD TC` (FLAGS 0: no reply). Returns 10.
    ///
    /// # Errors
    /// [`EncodeError::BufferTooSmall`] if `out` is shorter than 10 bytes.
    pub fn encode_request(node: NodeId, out: &mut [u8]) -> Result<usize, EncodeError> {
        encode_request(node, flags::NONE, csr::UTILITY, &csr::REBOOT_MAGIC, out)
    }

    /// Accepts a request that writes `DE AD` at 0xFE (any FLAGS).
    ///
    /// # Errors
    /// [`DecodeError`] for anything else.
    pub fn from_frame(frame: &Frame<'_>) -> Result<Self, DecodeError> {
        expect_direction(frame, Direction::Request)?;
        expect_addr(frame.addr(), csr::UTILITY)?;
        if frame.payload() == csr::REBOOT_MAGIC {
            Ok(Self)
        } else {
            Err(DecodeError::NotReboot)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csr_read_counts() {
        assert_eq!(CsrRead::FULL.count(), Some(240));
        assert_eq!(CsrRead::STATUS.count(), Some(14));
        assert_eq!(CsrRead::CONFIG.count(), None);
        assert_eq!(
            CsrRead::range(0x68, 2),
            Some(CsrRead {
                start: 0x68,
                flags: 0x82
            })
        );
        assert_eq!(CsrRead::range(0x68, 0), None);
        assert_eq!(CsrRead::range(0x68, 128), None);
    }

    #[test]
    fn dump_register_accessors() {
        let data = [0xD2, 0x04, 0x07];
        let d = CsrDump {
            device_type: DeviceType::Pro4Rov,
            start: 0x68,
            data: &data,
        };
        assert_eq!(d.i16_at(0x68), Some(1234));
        assert_eq!(d.u8_at(0x6A), Some(7));
        assert_eq!(d.i16_at(0x6A), None);
        assert_eq!(d.u8_at(0x67), None);
        assert!(!d.is_full());
    }
}
