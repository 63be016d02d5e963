//! Errors of the driver.

use std::io;

/// A byte-transport failure (serial port, pty, in-memory pipe).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TransportError {
    /// An I/O error from the operating system (unplug, EIO, ...).
    #[error("{port}: I/O error: {source}")]
    Io {
        /// Port name.
        port: String,
        /// The error.
        #[source]
        source: io::Error,
    },
    /// The serial-port library failed (open, configure, clone).
    #[error("{port}: serial port error: {source}")]
    Serial {
        /// Port name.
        port: String,
        /// The error.
        #[source]
        source: serialport::Error,
    },
    /// The other end of an in-memory pipe or pty went away.
    #[error("{port}: the other end closed")]
    Closed {
        /// Port name.
        port: String,
    },
    /// The operation is not available on this platform or transport.
    #[error("{0}")]
    Unsupported(String),
}

/// A [`LinkConfig`](crate::LinkConfig) value out of range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("link config: {field} = {value} is out of range (allowed {allowed})")]
pub struct ConfigError {
    /// The setting.
    pub field: &'static str,
    /// Its value, as text.
    pub value: String,
    /// What is accepted.
    pub allowed: String,
}

/// Why [`Failsafe::arm`](crate::Failsafe::arm) refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ArmError {
    /// The link is not connected (degraded, lost or still searching).
    #[error("cannot arm: the link is not connected")]
    LinkNotConnected,
    /// The link has been healthy for less than the required time.
    #[error("cannot arm: link healthy for {healthy_us} µs, {required_us} µs required")]
    NotHealthyLongEnough {
        /// How long it has been healthy, µs.
        healthy_us: u64,
        /// How long it must be, µs.
        required_us: u64,
    },
}

/// Any driver error.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DriverError {
    /// Transport failure.
    #[error(transparent)]
    Transport(#[from] TransportError),
    /// Invalid configuration.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// Invalid wire conventions.
    #[error(transparent)]
    Conventions(#[from] rov_types::conventions::ConventionsError),
    /// A frame could not be encoded (a bug or an out-of-range request).
    #[error("encode: {0}")]
    Encode(firmware_proto::EncodeError),
    /// The async runner stopped (its task ended or panicked).
    #[error("the link task has stopped")]
    RunnerStopped,
    /// Arming refused.
    #[error(transparent)]
    Arm(#[from] ArmError),
}

impl From<firmware_proto::EncodeError> for DriverError {
    fn from(e: firmware_proto::EncodeError) -> Self {
        Self::Encode(e)
    }
}
