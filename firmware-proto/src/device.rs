//! Device-type byte (payload byte 0 of every response), protocol.md §5.3.

use core::fmt;

/// Device type carried as the first payload byte of a response.
///
/// Values not in the list are kept as [`DeviceType::Unknown`], so
/// `DeviceType::from_byte(b).to_byte() == b` for every byte.
/// [`DeviceType::from_byte`] never returns `Unknown` for a listed code.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[non_exhaustive]
pub enum DeviceType {
    /// 0x00: host.
    Host,
    /// 0x01: VideoRay Pro 4 ROV.
    Pro4Rov,
    /// 0x02: manipulator.
    Manipulator,
    /// 0x03: camera.
    Camera,
    /// 0x04: thruster module.
    ThrusterModule,
    /// 0x05: radiation sensor.
    RadiationSensor,
    /// 0x06: CP probe.
    CpProbe,
    /// 0x07: light.
    Light,
    /// 0x08: laser in S1, "generic sensor" in S5.
    Laser,
    /// 0x09: external power.
    ExternalPower,
    /// 0x0A: DVL.
    Dvl,
    /// 0x0B: DSS transponder.
    DssTransponder,
    /// 0x0C: altimeter.
    Altimeter,
    /// 0x0D: GPS.
    Gps,
    /// 0x10: protocol adapter / mux.
    ProtocolAdapter,
    /// 0x20: generic sensor (S1).
    GenericSensor,
    /// 0x30: generic camera.
    GenericCamera,
    /// 0x31: Inuktun camera.
    InuktunCamera,
    /// 0x50: KCF smart tether node.
    KcfSmartTetherNode,
    /// 0x81: M5 thruster.
    M5Thruster,
    /// 0x82: M5 75 V power supply.
    M5Power75V,
    /// 0x83: M5 LED.
    M5Led,
    /// 0xC0: M5 SPAM.
    M5Spam,
    /// 0xC1: M5 comms hub.
    M5CommsHub,
    /// 0xC2: M5 attitude sensor.
    M5Attitude,
    /// 0xC3: M5 420 V power supply.
    M5Power420V,
    /// 0xFF: an extended type follows in the next byte (S1; not used by the Pro 4).
    Extended,
    /// Any other value, preserved.
    Unknown(u8),
}

impl DeviceType {
    /// Decodes a device-type byte (never fails).
    #[must_use]
    pub const fn from_byte(b: u8) -> Self {
        match b {
            0x00 => Self::Host,
            0x01 => Self::Pro4Rov,
            0x02 => Self::Manipulator,
            0x03 => Self::Camera,
            0x04 => Self::ThrusterModule,
            0x05 => Self::RadiationSensor,
            0x06 => Self::CpProbe,
            0x07 => Self::Light,
            0x08 => Self::Laser,
            0x09 => Self::ExternalPower,
            0x0A => Self::Dvl,
            0x0B => Self::DssTransponder,
            0x0C => Self::Altimeter,
            0x0D => Self::Gps,
            0x10 => Self::ProtocolAdapter,
            0x20 => Self::GenericSensor,
            0x30 => Self::GenericCamera,
            0x31 => Self::InuktunCamera,
            0x50 => Self::KcfSmartTetherNode,
            0x81 => Self::M5Thruster,
            0x82 => Self::M5Power75V,
            0x83 => Self::M5Led,
            0xC0 => Self::M5Spam,
            0xC1 => Self::M5CommsHub,
            0xC2 => Self::M5Attitude,
            0xC3 => Self::M5Power420V,
            0xFF => Self::Extended,
            other => Self::Unknown(other),
        }
    }

    /// The wire byte.
    #[must_use]
    pub const fn to_byte(self) -> u8 {
        match self {
            Self::Host => 0x00,
            Self::Pro4Rov => 0x01,
            Self::Manipulator => 0x02,
            Self::Camera => 0x03,
            Self::ThrusterModule => 0x04,
            Self::RadiationSensor => 0x05,
            Self::CpProbe => 0x06,
            Self::Light => 0x07,
            Self::Laser => 0x08,
            Self::ExternalPower => 0x09,
            Self::Dvl => 0x0A,
            Self::DssTransponder => 0x0B,
            Self::Altimeter => 0x0C,
            Self::Gps => 0x0D,
            Self::ProtocolAdapter => 0x10,
            Self::GenericSensor => 0x20,
            Self::GenericCamera => 0x30,
            Self::InuktunCamera => 0x31,
            Self::KcfSmartTetherNode => 0x50,
            Self::M5Thruster => 0x81,
            Self::M5Power75V => 0x82,
            Self::M5Led => 0x83,
            Self::M5Spam => 0xC0,
            Self::M5CommsHub => 0xC1,
            Self::M5Attitude => 0xC2,
            Self::M5Power420V => 0xC3,
            Self::Extended => 0xFF,
            Self::Unknown(b) => b,
        }
    }
}

impl From<u8> for DeviceType {
    fn from(b: u8) -> Self {
        Self::from_byte(b)
    }
}

impl From<DeviceType> for u8 {
    fn from(t: DeviceType) -> Self {
        t.to_byte()
    }
}

impl fmt::Display for DeviceType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Unknown(b) => write!(f, "unknown device type {b:#04X}"),
            other => write!(f, "{other:?} ({:#04X})", other.to_byte()),
        }
    }
}

/// Generated through the byte so that `Unknown` never holds a listed code.
#[cfg(feature = "arbitrary")]
impl<'a> arbitrary::Arbitrary<'a> for DeviceType {
    fn arbitrary(u: &mut arbitrary::Unstructured<'a>) -> arbitrary::Result<Self> {
        u8::arbitrary(u).map(Self::from_byte)
    }

    fn size_hint(depth: usize) -> (usize, Option<usize>) {
        <u8 as arbitrary::Arbitrary>::size_hint(depth)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_byte_round_trips_and_listed_codes_are_named() {
        for b in 0..=u8::MAX {
            let t = DeviceType::from_byte(b);
            assert_eq!(t.to_byte(), b);
            if let DeviceType::Unknown(x) = t {
                assert_eq!(x, b);
            }
        }
        assert_eq!(DeviceType::from_byte(0x01), DeviceType::Pro4Rov);
        assert_eq!(DeviceType::from_byte(0x0E), DeviceType::Unknown(0x0E));
        assert_eq!(DeviceType::from_byte(0xC3), DeviceType::M5Power420V);
    }
}
