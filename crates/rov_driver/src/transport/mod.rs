//! Byte transports: the real serial port and pseudo-terminal pairs (feature `serial`)
//! and an in-memory pipe, behind one blocking interface with short timeouts; probing a
//! transport for the vehicle; what a vanished port looks like ([`PortGone`]).
//!
//! The [`Link`](crate::Link) itself does no I/O; the runners
//! ([`run_blocking`](crate::run_blocking) and the tokio [`runner`](crate::runner)) move
//! bytes between a transport and the link.

use std::time::Duration;

use crate::error::TransportError;

pub mod gone;
pub mod memory;
pub mod probe;
#[cfg(feature = "serial")]
pub mod serial;

pub use gone::{PortGone, classify_io_error};
pub use memory::{MemoryTransport, memory_pair};
pub use probe::{ProbeReply, probe, probe_with};
#[cfg(feature = "serial")]
pub use serial::{SerialTransport, available_port_names};

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
