//! Errors of the driver.

use std::io;

/// A byte-transport failure (serial port, pty, in-memory pipe).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TransportError {
    /// The device went away (unplugged adapter, closed pty): the port must be opened
    /// again, maybe at another path. Not a frame error.
    #[error("{port}: port gone ({cause}): {detail}")]
    Gone {
        /// Port name.
        port: String,
        /// How it showed.
        cause: crate::transport::PortGone,
        /// The operating system's text.
        detail: String,
    },
    /// Any other I/O error from the operating system.
    #[error("{port}: I/O error: {source}")]
    Io {
        /// Port name.
        port: String,
        /// The error.
        #[source]
        source: io::Error,
    },
    /// The serial-port library failed (open, configure, clone).
    #[cfg(feature = "serial")]
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

impl TransportError {
    /// An I/O error on `port`, classified: [`TransportError::Gone`] when the device
    /// went away ([`classify_io_error`](crate::transport::classify_io_error)),
    /// [`TransportError::Io`] otherwise.
    #[must_use]
    pub fn from_io(port: &str, source: io::Error) -> Self {
        match crate::transport::classify_io_error(&source) {
            Some(cause) => Self::Gone {
                port: port.to_string(),
                cause,
                detail: source.to_string(),
            },
            None => Self::Io {
                port: port.to_string(),
                source,
            },
        }
    }

    /// Why the port is gone, if this error means it is (a vanished device or a closed
    /// pipe); `None` for errors that leave the port usable or are about something else.
    #[must_use]
    pub const fn port_gone(&self) -> Option<crate::transport::PortGone> {
        match self {
            Self::Gone { cause, .. } => Some(*cause),
            Self::Closed { .. } => Some(crate::transport::PortGone::Closed),
            _ => None,
        }
    }
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
