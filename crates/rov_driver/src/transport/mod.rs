//! Byte transports: the real serial port and pseudo-terminal pairs (feature `serial`)
//! and an in-memory pipe, behind one blocking interface with short timeouts; probing a
//! transport for the vehicle; what a vanished port looks like ([`PortGone`]).
//!
//! The traits, the in-memory pipe and [`PortGone`] live in `rov_transport`, which the
//! simulated vehicle shares; they are re-exported here. The [`Link`](crate::Link) itself does no I/O; the runners
//! ([`run_blocking`](crate::run_blocking) and the tokio [`runner`](crate::runner)) move
//! bytes between a transport and the link.

pub mod probe;
#[cfg(feature = "serial")]
pub mod serial;

pub use probe::{ProbeReply, probe, probe_with};
pub use rov_transport::{
    ByteSink, ByteSource, MemoryTransport, PortGone, SplitHalves, Transport, classify_io_error,
    gone, memory, memory_pair,
};
#[cfg(feature = "serial")]
pub use serial::{SerialTransport, available_port_names};
