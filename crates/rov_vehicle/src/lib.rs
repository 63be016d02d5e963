//! The simulated VideoRay Pro 4 behind the wire protocol.
//!
//! * [`vehicle`]: [`Vehicle`], sans-IO: a 256-byte register image initialised from
//!   `firmware_proto::csr::DEFAULT_IMAGE`, answers exactly as protocol.md §5–7 and
//!   §12.3 describe, drives the `rov_sim` simulator from the control block (with a 1 s
//!   command watchdog, our choice), fills the navigation reply and the telemetry
//!   registers from the simulated sensors, and schedules its reply bytes at the baud
//!   rate after a turnaround ([`WireTiming`]).
//! * [`autopilot`]: the onboard auto-depth / auto-heading. **Ours**: the real vehicle's
//!   internal loop is not documented.
//! * [`faults`]: seeded, counted fault injection (dropped replies, garbage, bit flips,
//!   fragmentation, delay, dead link, corrupted requests).
//! * [`runner`]: the wall-time runner: the vehicle in a thread on a transport (pty end,
//!   serial port, memory pipe), paced.
//!
//! Wire ↔ physics conversions go through `rov_types::conventions` only, the same
//! settings as the driver's.
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]
#![warn(missing_docs)]

pub mod autopilot;
pub mod faults;
pub mod rng;
pub mod runner;
pub mod vehicle;

pub use autopilot::{AutopilotConfig, AxisGains};
pub use faults::{FaultConfig, FaultCounts};
pub use runner::{RunnerConfig, VehicleRunner};
pub use vehicle::{
    Vehicle, VehicleConfig, VehicleCounts, VehicleError, WireTiming, sim_config_data,
};
