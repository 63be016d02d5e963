//! Topside driver for the VideoRay Pro 4 tether link.
//!
//! * [`link`]: the sans-IO [`Link`] state machine: one request in flight, response
//!   matching, timeouts, retries, error counters by class, round-trip statistics, link
//!   health (connected / degraded / lost) and the SEARCHING → INIT → RUNNING sequence
//!   of protocol.md §12.2, on time passed in as an argument.
//! * [`failsafe`]: arming and the latched link-loss failsafe gating every outgoing
//!   command (see `SAFETY.md`).
//! * [`transport`]: an in-memory pipe, probing for the vehicle, what a vanished port
//!   looks like; with feature `serial`: the serial port (`serialport`, no libudev),
//!   pseudo-terminal pairs, port enumeration, by-id names and autodetect by ping.
//! * [`reconnect`]: the sans-IO re-connection policy (backoff schedule, candidate
//!   order, outage summary) that a runtime drives after a port vanished.
//! * [`runner`]: wall-clock runners: a blocking loop, and with feature `tokio` a tokio
//!   task with a handle.
//!
//! # Features
//!
//! * `serial` (default): the serial transport, port listing, autodetect.
//! * `tokio`: the tokio runner (`spawn`, `LinkHandle`).
//!
//! With no features the crate is the sans-IO link, failsafe, statistics, telemetry,
//! re-connection policy, the transport traits, the in-memory pipe and the blocking
//! runner.
//!
//! Wire values become physics values (depth down, pitch nose up, roll starboard down,
//! positive vertical thrust down) only through [`rov_types::conventions`].
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

pub mod config;
pub mod error;
pub mod failsafe;
pub mod link;
pub mod reconnect;
pub mod runner;
pub mod stats;
pub mod telemetry;
pub mod transport;

pub use config::LinkConfig;
pub use error::{ArmError, ConfigError, DriverError, TransportError};
pub use failsafe::{Alarm, Failsafe, LatchedAlarm, is_neutral, neutral};
pub use link::Link;
pub use reconnect::{
    Candidate, CandidateSource, OutageSummary, Reconnect, ReconnectConfig, ReconnectStatus,
};
#[cfg(feature = "tokio")]
pub use runner::{LinkHandle, LinkSnapshot, RunnerOptions, spawn};
pub use runner::{MonoClock, run_blocking};
pub use stats::{FailCause, LinkCounters, RttStats, RttSummary};
pub use telemetry::{
    ExchangeKind, Health, LinkEvent, Phase, Request, RequestId, RequestOutcome, StatusTelemetry,
    Telemetry,
};
#[cfg(feature = "serial")]
pub use transport::serial::{AutodetectReport, BY_ID_DIR, PRO4_BAUD, autodetect, by_id_name};
pub use transport::{
    ByteSink, ByteSource, MemoryTransport, PortGone, ProbeReply, SplitHalves, Transport,
    classify_io_error, memory_pair, probe, probe_with,
};
#[cfg(feature = "serial")]
pub use transport::{SerialTransport, available_port_names};
