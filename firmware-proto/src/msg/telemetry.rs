//! Device-specific replies: ping (FLAGS 0x01) and navigation (FLAGS 0x05),
//! protocol.md §6.2.

use crate::bytes::{Reader, fill};
use crate::device::DeviceType;
use crate::error::{DecodeError, EncodeError};
use crate::frame::{Direction, Frame, NodeId, encode_request, flags};

use super::{deg_x10_to_deg, expect_addr, expect_direction, expect_len, heading_x10_to_deg};

/// Payload length of the ping reply: type byte + 4 × i16.
pub const PING_REPLY_PAYLOAD_LEN: usize = 9;
/// Payload length of the navigation reply: type byte + 33 data bytes.
pub const NAV_PAYLOAD_LEN: usize = 34;

/// The ping / autodetect request: FLAGS 0x01, no payload (vector V1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
pub struct Ping;

impl Ping {
    /// Encodes `FA AF node 01 00 00 HC 00`. Returns 8.
    ///
    /// # Errors
    /// [`EncodeError::BufferTooSmall`] if `out` is shorter than 8 bytes.
    pub fn encode_request(node: NodeId, out: &mut [u8]) -> Result<usize, EncodeError> {
        encode_request(node, flags::PING, 0x00, &[], out)
    }

    /// Accepts a request with FLAGS 0x01 and no payload (the address is ignored).
    ///
    /// # Errors
    /// [`DecodeError`] for anything else.
    pub fn from_frame(frame: &Frame<'_>) -> Result<Self, DecodeError> {
        expect_direction(frame, Direction::Request)?;
        if frame.flags() != flags::PING {
            return Err(DecodeError::WrongFlags {
                found: frame.flags(),
            });
        }
        expect_len(frame.payload_len(), 0)?;
        Ok(Self)
    }
}

fn check_device_specific(frame: &Frame<'_>, flags: u8, len: usize) -> Result<(), DecodeError> {
    expect_direction(frame, Direction::Response)?;
    if frame.flags() != flags {
        return Err(DecodeError::WrongFlags {
            found: frame.flags(),
        });
    }
    expect_addr(frame.addr(), 0x00)?;
    expect_len(frame.payload_len(), len)
}

/// Reply to FLAGS 0x01 (ping): device type + heading, pitch, roll, depth
/// (4 × i16; vector V2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
pub struct PingReply {
    /// Responder's device type (0x01 for the Pro 4).
    pub device_type: DeviceType,
    /// Heading, degrees ×10, signed.
    pub heading_deg_x10: i16,
    /// Pitch, degrees ×10.
    pub pitch_deg_x10: i16,
    /// Roll, degrees ×10.
    pub roll_deg_x10: i16,
    /// Depth as pressure, mbar.
    pub pressure_mbar: i16,
}

impl PingReply {
    /// Heading in degrees, normalised to [0, 360).
    #[must_use]
    pub fn heading_deg(&self) -> f64 {
        heading_x10_to_deg(self.heading_deg_x10)
    }

    /// Pitch in degrees.
    #[must_use]
    pub fn pitch_deg(&self) -> f64 {
        deg_x10_to_deg(self.pitch_deg_x10)
    }

    /// Roll in degrees.
    #[must_use]
    pub fn roll_deg(&self) -> f64 {
        deg_x10_to_deg(self.roll_deg_x10)
    }

    /// The 9 payload bytes (type byte first).
    #[must_use]
    pub fn to_payload(&self) -> [u8; PING_REPLY_PAYLOAD_LEN] {
        fill(|w| {
            w.u8(self.device_type.to_byte());
            w.i16(self.heading_deg_x10);
            w.i16(self.pitch_deg_x10);
            w.i16(self.roll_deg_x10);
            w.i16(self.pressure_mbar);
        })
    }

    /// Decodes exactly 9 payload bytes.
    ///
    /// # Errors
    /// [`DecodeError::WrongLength`] for any other length.
    pub fn from_payload(payload: &[u8]) -> Result<Self, DecodeError> {
        expect_len(payload.len(), PING_REPLY_PAYLOAD_LEN)?;
        let mut r = Reader::new(payload);
        let mut read = || -> Option<Self> {
            Some(Self {
                device_type: DeviceType::from_byte(r.u8()?),
                heading_deg_x10: r.i16()?,
                pitch_deg_x10: r.i16()?,
                roll_deg_x10: r.i16()?,
                pressure_mbar: r.i16()?,
            })
        };
        read().ok_or(DecodeError::WrongLength {
            expected: PING_REPLY_PAYLOAD_LEN,
            found: payload.len(),
        })
    }

    /// Encodes the reply frame (FLAGS 0x01, address 0). Returns 17.
    ///
    /// # Errors
    /// [`EncodeError::BufferTooSmall`] if `out` is shorter than 17 bytes.
    pub fn encode_response(&self, node: NodeId, out: &mut [u8]) -> Result<usize, EncodeError> {
        crate::frame::encode_frame(
            &crate::frame::Header::response(node, flags::PING, 0x00),
            &self.to_payload(),
            crate::frame::LengthField::Normal,
            out,
        )
    }

    /// Decodes a response with FLAGS 0x01, address 0 and a 9-byte payload.
    ///
    /// # Errors
    /// [`DecodeError`] for anything else.
    pub fn from_frame(frame: &Frame<'_>) -> Result<Self, DecodeError> {
        check_device_specific(frame, flags::PING, PING_REPLY_PAYLOAD_LEN)?;
        Self::from_payload(frame.payload())
    }
}

/// Reply to FLAGS 0x05: navigation and health (type byte + 33 data bytes; vector
/// V6). All int16 little endian unless noted.
///
/// Field order follows the captured data (protocol.md §6.2): humidity at p = 29,
/// then water temperature at p = 31, not the order of S2's struct.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
pub struct NavReply {
    /// p0: responder's device type (0x01 for the Pro 4).
    pub device_type: DeviceType,
    /// p1: heading, degrees ×10, signed (see [`NavReply::heading_deg`]).
    pub heading_deg_x10: i16,
    /// p3: pitch, degrees ×10.
    pub pitch_deg_x10: i16,
    /// p5: roll, degrees ×10.
    pub roll_deg_x10: i16,
    /// p7: depth as pressure, mbar (same as CSR 0x66).
    pub pressure_mbar: i16,
    /// p9: "yaw acceleration", sensor units (probably gyro rate ×1000).
    pub yaw_accel_raw: i16,
    /// p11: "pitch acceleration", sensor units.
    pub pitch_accel_raw: i16,
    /// p13: "roll acceleration", sensor units.
    pub roll_accel_raw: i16,
    /// p15: surge acceleration, probably m/s² ×1000.
    pub surge_accel_raw: i16,
    /// p17: sway acceleration, probably m/s² ×1000.
    pub sway_accel_raw: i16,
    /// p19: heave acceleration, probably m/s² ×1000 (≈ −9040 when level).
    pub heave_accel_raw: i16,
    /// p21: raw magnetometer X, ADC units.
    pub mag_x_raw: i16,
    /// p23: raw magnetometer Y, ADC units.
    pub mag_y_raw: i16,
    /// p25: raw magnetometer Z, ADC units.
    pub mag_z_raw: i16,
    /// p27: attitude-sensor status code (0 = OK in the examples).
    pub attitude_status: i16,
    /// p29: internal relative humidity, % RH.
    pub humidity_pct: i16,
    /// p31: water temperature, °C ×100 (see [`NavReply::water_temp_c`]).
    pub water_temp_c_x100: i16,
    /// p33 (u8): total power available, 0..=100 %.
    pub power_pct: u8,
}

impl NavReply {
    /// Heading in degrees, normalised to [0, 360) (the vehicle sends both
    /// −1800..=1800 and 0..=3599).
    #[must_use]
    pub fn heading_deg(&self) -> f64 {
        heading_x10_to_deg(self.heading_deg_x10)
    }

    /// Pitch in degrees.
    #[must_use]
    pub fn pitch_deg(&self) -> f64 {
        deg_x10_to_deg(self.pitch_deg_x10)
    }

    /// Roll in degrees.
    #[must_use]
    pub fn roll_deg(&self) -> f64 {
        deg_x10_to_deg(self.roll_deg_x10)
    }

    /// Water temperature in °C.
    #[must_use]
    pub fn water_temp_c(&self) -> f64 {
        f64::from(self.water_temp_c_x100) / 100.0
    }

    /// The 34 payload bytes (type byte first).
    #[must_use]
    pub fn to_payload(&self) -> [u8; NAV_PAYLOAD_LEN] {
        fill(|w| {
            w.u8(self.device_type.to_byte());
            for v in [
                self.heading_deg_x10,
                self.pitch_deg_x10,
                self.roll_deg_x10,
                self.pressure_mbar,
                self.yaw_accel_raw,
                self.pitch_accel_raw,
                self.roll_accel_raw,
                self.surge_accel_raw,
                self.sway_accel_raw,
                self.heave_accel_raw,
                self.mag_x_raw,
                self.mag_y_raw,
                self.mag_z_raw,
                self.attitude_status,
                self.humidity_pct,
                self.water_temp_c_x100,
            ] {
                w.i16(v);
            }
            w.u8(self.power_pct);
        })
    }

    /// Decodes exactly 34 payload bytes.
    ///
    /// # Errors
    /// [`DecodeError::WrongLength`] for any other length.
    pub fn from_payload(payload: &[u8]) -> Result<Self, DecodeError> {
        expect_len(payload.len(), NAV_PAYLOAD_LEN)?;
        let mut r = Reader::new(payload);
        let mut read = || -> Option<Self> {
            Some(Self {
                device_type: DeviceType::from_byte(r.u8()?),
                heading_deg_x10: r.i16()?,
                pitch_deg_x10: r.i16()?,
                roll_deg_x10: r.i16()?,
                pressure_mbar: r.i16()?,
                yaw_accel_raw: r.i16()?,
                pitch_accel_raw: r.i16()?,
                roll_accel_raw: r.i16()?,
                surge_accel_raw: r.i16()?,
                sway_accel_raw: r.i16()?,
                heave_accel_raw: r.i16()?,
                mag_x_raw: r.i16()?,
                mag_y_raw: r.i16()?,
                mag_z_raw: r.i16()?,
                attitude_status: r.i16()?,
                humidity_pct: r.i16()?,
                water_temp_c_x100: r.i16()?,
                power_pct: r.u8()?,
            })
        };
        read().ok_or(DecodeError::WrongLength {
            expected: NAV_PAYLOAD_LEN,
            found: payload.len(),
        })
    }

    /// Encodes the reply frame (FLAGS 0x05, address 0). Returns 42.
    ///
    /// # Errors
    /// [`EncodeError::BufferTooSmall`] if `out` is shorter than 42 bytes.
    pub fn encode_response(&self, node: NodeId, out: &mut [u8]) -> Result<usize, EncodeError> {
        crate::frame::encode_frame(
            &crate::frame::Header::response(node, flags::NAV, 0x00),
            &self.to_payload(),
            crate::frame::LengthField::Normal,
            out,
        )
    }

    /// Decodes a response with FLAGS 0x05, address 0 and a 34-byte payload.
    ///
    /// # Errors
    /// [`DecodeError`] for anything else.
    pub fn from_frame(frame: &Frame<'_>) -> Result<Self, DecodeError> {
        check_device_specific(frame, flags::NAV, NAV_PAYLOAD_LEN)?;
        Self::from_payload(frame.payload())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heading_is_normalised() {
        let mut r = PingReply {
            device_type: DeviceType::Pro4Rov,
            heading_deg_x10: -132,
            pitch_deg_x10: 37,
            roll_deg_x10: -30,
            pressure_mbar: 0,
        };
        assert_eq!(r.heading_deg(), 346.8);
        r.heading_deg_x10 = 3600;
        assert_eq!(r.heading_deg(), 0.0);
        r.heading_deg_x10 = i16::MIN;
        assert!((0.0..360.0).contains(&r.heading_deg()));
        assert_eq!(r.pitch_deg(), 3.7);
        assert_eq!(r.roll_deg(), -3.0);
    }
}
