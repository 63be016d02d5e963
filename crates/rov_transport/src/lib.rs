//! Byte transports as the topside driver and the simulated vehicle share them.
//!
//! Both ends of the tether move bytes the same way: the driver (`rov_driver`) between a
//! serial port and its sans-IO link, the simulated Pro 4 (`rov_vehicle`) between its
//! register image and a pseudo-terminal or an in-memory pipe. This crate holds what both
//! need and nothing else, so neither depends on the other:
//!
//! * the blocking transport traits ([`ByteSource`], [`ByteSink`], [`Transport`]) with
//!   short timeouts;
//! * the transport error ([`TransportError`]) and what a vanished port looks like
//!   ([`gone`]: [`PortGone`], [`classify_io_error`]);
//! * an in-memory, wall-time duplex pipe ([`memory`]: [`memory_pair`]);
//! * the monotonic microsecond clock both runners use ([`MonoClock`]).
//!
//! The serial port itself (serialport, pseudo-terminals, port listing) stays in
//! `rov_driver`'s `serial` feature; it reports its library's errors through
//! [`TransportError::Serial`].
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::indexing_slicing,
        clippy::panic
    )
)]
#![warn(missing_docs)]

use std::io;
use std::time::{Duration, Instant};

pub mod gone;
pub mod memory;

pub use gone::{PortGone, classify_io_error};
pub use memory::{MemoryTransport, memory_pair};

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
        cause: PortGone,
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
    /// The serial-port library failed (open, configure, clone). The library's own
    /// error is kept as the source, boxed so that this crate does not depend on it.
    #[error("{port}: serial port error: {source}")]
    Serial {
        /// Port name.
        port: String,
        /// The library's error.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
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
    /// went away ([`classify_io_error`]), [`TransportError::Io`] otherwise.
    #[must_use]
    pub fn from_io(port: &str, source: io::Error) -> Self {
        match classify_io_error(&source) {
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
    pub const fn port_gone(&self) -> Option<PortGone> {
        match self {
            Self::Gone { cause, .. } => Some(*cause),
            Self::Closed { .. } => Some(PortGone::Closed),
            _ => None,
        }
    }
}

/// The receiving half of a transport.
pub trait ByteSource: Send {
    /// Waits up to `timeout` for bytes and copies what arrived into `buf`; `Ok(0)` when
    /// nothing arrived in time.
    ///
    /// # Errors
    /// [`TransportError`] when the port failed or the other end closed.
    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, TransportError>;
}

/// The sending half of a transport.
pub trait ByteSink: Send {
    /// Writes all of `bytes` (blocking briefly).
    ///
    /// # Errors
    /// [`TransportError`] when the port failed or the other end closed.
    fn send(&mut self, bytes: &[u8]) -> Result<(), TransportError>;
}

/// The two halves of a split transport.
pub type SplitHalves = (Box<dyn ByteSource>, Box<dyn ByteSink>);

/// A bidirectional byte transport.
pub trait Transport: ByteSource + ByteSink {
    /// A name for messages (the device path, "memory", ...).
    fn name(&self) -> String;

    /// Splits into halves that can be used from two threads.
    ///
    /// # Errors
    /// [`TransportError`] if the underlying handle cannot be duplicated.
    fn split(self: Box<Self>) -> Result<SplitHalves, TransportError>;
}

/// A monotonic microsecond clock starting at zero: the one wall clock of the runners
/// that move bytes (the driver's and the simulated vehicle's). The sans-IO code never
/// reads it; it is given the readings.
#[derive(Debug, Clone, Copy)]
pub struct MonoClock {
    start: Instant,
}

impl Default for MonoClock {
    fn default() -> Self {
        Self::new()
    }
}

impl MonoClock {
    /// Starts now.
    #[must_use]
    pub fn new() -> Self {
        Self {
            start: Instant::now(),
        }
    }

    /// Microseconds since the start.
    #[must_use]
    pub fn now_us(&self) -> u64 {
        u64::try_from(self.start.elapsed().as_micros()).unwrap_or(u64::MAX)
    }

    /// The instant of a clock reading.
    #[must_use]
    pub fn instant_at(&self, t_us: u64) -> Instant {
        self.start + Duration::from_micros(t_us)
    }
}
