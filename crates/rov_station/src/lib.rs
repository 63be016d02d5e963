//! The station runtime.
//!
//! * [`core`]: the station logic between the link and the controller (events in, one
//!   control tick out, failsafe wiring, pilot commands, a snapshot for the GUI).
//! * [`hold`]: the `topside hold` scenario on virtual time (mock link + simulated vehicle).
//! * [`metrics`]: step-response metrics on the true state.
//! * [`sim_link`]: the virtual-time harness joining the driver's `Link` and the simulated
//!   Pro 4 (`rov_vehicle::Vehicle`): used by `hold`, `VirtualStation` and the scenarios.
//! * [`pilot`]: the pilot core, a sans-IO state machine (events and time in; records,
//!   requests and the view out): alarms, checklist, dive log, sticks and arming,
//!   prediction, the view the GUI shows.
//! * [`runtime`]: the real-time runtime (threads, deadlines, watchdog, gamepad, recording,
//!   replay) behind a [`StationHandle`] for the GUI.
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::indexing_slicing,
        clippy::panic
    )
)]

/// `Clone` with a field-wise `clone_from`: the runtime copies its view into the shared
/// slot every tick, and a field-wise `clone_from` reuses the strings' and vectors'
/// memory (derived `clone_from` clones anew), so publishing does not allocate.
macro_rules! clone_fields {
    ($t:ty { $($f:ident),+ $(,)? }) => {
        impl Clone for $t {
            fn clone(&self) -> Self {
                Self { $($f: self.$f.clone()),+ }
            }
            fn clone_from(&mut self, other: &Self) {
                $(self.$f.clone_from(&other.$f);)+
            }
        }
    };
}
pub(crate) use clone_fields;

pub mod core;
pub mod hold;
pub mod import;
pub mod metrics;
pub mod pilot;
pub mod runtime;
pub mod sim_link;

pub use core::{CommandError, Snapshot, StationCommand, StationCore};
pub use hold::{
    AutopilotModel, Disturbance, HoldError, HoldReport, HoldSpec, HoldTrace, TrackingReport,
    VehicleDynamics, run_hold, run_hold_with,
};
pub use runtime::{
    Connection, Runtime, RuntimeCommand, RuntimeConfig, RuntimeError, StationHandle, StationView,
    VirtualReplay, VirtualStation,
};
pub use sim_link::{SimApp, SimLink, SimLinkStats};
