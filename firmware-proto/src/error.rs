//! Error types. All are plain `Copy` values with hand-written `Display` and
//! `core::error::Error` implementations (the crate is `no_std`).

use core::fmt;

use crate::frame::Direction;

/// Encoding a frame failed. Nothing useful was written to the output buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum EncodeError {
    /// The output buffer is shorter than the encoded frame.
    BufferTooSmall {
        /// Bytes the frame needs.
        needed: usize,
        /// Bytes the buffer has.
        available: usize,
    },
    /// The payload does not fit the chosen length field.
    PayloadTooLong {
        /// Payload length asked for (including a response's device-type byte).
        len: usize,
        /// Largest payload the length field allows.
        max: usize,
    },
}

impl fmt::Display for EncodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::BufferTooSmall { needed, available } => write!(
                f,
                "output buffer too small: frame needs {needed} bytes, buffer has {available}"
            ),
            Self::PayloadTooLong { len, max } => {
                write!(f, "payload of {len} bytes is longer than the maximum {max}")
            }
        }
    }
}

impl core::error::Error for EncodeError {}

/// A byte slice is not one valid frame (see [`Frame::parse`](crate::Frame::parse)).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum FrameError {
    /// The slice ends before the frame does; at least `needed` bytes in total are
    /// required to say more.
    Incomplete {
        /// Minimum total length needed to continue.
        needed: usize,
    },
    /// The slice does not start with `FA AF` or `FD DF` (mixed pairs included).
    BadSync,
    /// The header check byte is not the XOR of bytes 0..=5.
    HeaderCheck {
        /// XOR computed over the received header.
        computed: u8,
        /// Check byte received.
        received: u8,
    },
    /// The extended-length check byte is not low ^ high.
    ExtLengthCheck {
        /// XOR of the two received length bytes.
        computed: u8,
        /// Check byte received.
        received: u8,
    },
    /// The extended length exceeds the cap.
    Overlong {
        /// Extended length received.
        len: usize,
        /// Cap in force.
        max: usize,
    },
    /// The total check byte is not the XOR of the preceding bytes.
    TotalCheck {
        /// XOR computed over the received payload.
        computed: u8,
        /// Check byte received.
        received: u8,
    },
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::Incomplete { needed } => write!(f, "incomplete frame: {needed} bytes needed"),
            Self::BadSync => f.write_str("no valid sync pair (FA AF or FD DF)"),
            Self::HeaderCheck { computed, received } => write!(
                f,
                "header check mismatch: computed {computed:#04X}, received {received:#04X}"
            ),
            Self::ExtLengthCheck { computed, received } => write!(
                f,
                "extended-length check mismatch: computed {computed:#04X}, received {received:#04X}"
            ),
            Self::Overlong { len, max } => {
                write!(f, "extended length {len} exceeds the cap of {max} bytes")
            }
            Self::TotalCheck { computed, received } => write!(
                f,
                "total check mismatch: computed {computed:#04X}, received {received:#04X}"
            ),
        }
    }
}

impl core::error::Error for FrameError {}

/// A valid frame is not the typed message asked for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum DecodeError {
    /// The frame goes the other way.
    WrongDirection {
        /// Direction the message needs.
        expected: Direction,
    },
    /// The FLAGS byte does not select this message.
    WrongFlags {
        /// FLAGS received.
        found: u8,
    },
    /// The CSR address is not the one the message lives at.
    WrongAddr {
        /// Address the message needs.
        expected: u8,
        /// Address received.
        found: u8,
    },
    /// The payload has the wrong length.
    WrongLength {
        /// Payload length the message needs (for a response: including the type byte).
        expected: usize,
        /// Payload length received.
        found: usize,
    },
    /// A response without the device-type byte.
    MissingDeviceType,
    /// A write to the utility register that is not the reboot magic `DE AD`.
    NotReboot,
}

impl fmt::Display for DecodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::WrongDirection { expected } => {
                write!(f, "wrong direction: expected a {}", expected.as_str())
            }
            Self::WrongFlags { found } => write!(f, "unexpected FLAGS {found:#04X}"),
            Self::WrongAddr { expected, found } => write!(
                f,
                "unexpected CSR address {found:#04X} (expected {expected:#04X})"
            ),
            Self::WrongLength { expected, found } => {
                write!(f, "payload of {found} bytes (expected {expected})")
            }
            Self::MissingDeviceType => f.write_str("response without device-type byte"),
            Self::NotReboot => f.write_str("utility-register write is not the reboot magic DE AD"),
        }
    }
}

impl core::error::Error for DecodeError {}

/// A field of a typed message is outside its documented range
/// (see [`ControlBlock::validate`](crate::ControlBlock::validate)).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RangeError {
    /// Field name as in the Rust struct.
    pub field: &'static str,
    /// Value found.
    pub value: i32,
    /// Smallest allowed value.
    pub min: i32,
    /// Largest allowed value.
    pub max: i32,
}

impl fmt::Display for RangeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} = {} is out of range {}..={}",
            self.field, self.value, self.min, self.max
        )
    }
}

impl core::error::Error for RangeError {}
