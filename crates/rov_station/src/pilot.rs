//! The pilot core: the station's pilot logic as a sans-IO state machine.
//!
//! Nothing in this module starts a thread, takes a lock, reads a clock, opens a file or
//! talks to a device (`tests/it/layering.rs` checks its source for them). Time is an
//! argument (`now_us`, µs of the runtime's monotonic clock) and the driver's
//! [`Link`](rov_driver::Link), itself sans-IO, is passed in by the caller. The
//! [`Engine`] is driven as
//!
//! * [`Engine::handle`]: one [`Input`] (a link event, a pilot command, the gamepad's
//!   latest state, the watchdog's count, a recording's progress or result) at `now_us`;
//! * [`Engine::tick`]: one control tick at `now_us` (phases in `engine/tick.rs`), which
//!   returns the thrust command sent;
//! * [`Engine::poll_record`]: the records to write and serve live, in time order;
//! * [`Engine::poll_output`]: what the engine asks of the world around it (start or stop
//!   a recording, inject a simulated fault, stall, shut down);
//! * [`Engine::poll_timeout`]: the earliest of its timers (one [`timers::Timers`] table).
//!
//! `crate::runtime` owns the threads and devices (link transport, recorder, finishers,
//! camera, live Foxglove tap, model-watch thread, serial-port monitor, shared state):
//! its `Host` feeds the engine and drains its outputs. [`crate::runtime::VirtualStation`]
//! runs the same engine on virtual time.
//!
//! Modules: [`alarms`], [`dive`] (checklist, dive log, thruster test), [`pad`] (gamepad
//! map), [`shaping`] (sticks, gain, hold-to-arm), [`predict`], [`history`], [`view`] (what
//! the GUI shows), [`timing`] (tick statistics), [`record`] (recorder items), [`timers`].

pub mod alarms;
pub mod dive;
mod engine;
pub mod history;
pub mod pad;
pub mod predict;
pub mod record;
pub mod shaping;
pub mod timers;
pub mod timing;
pub mod view;

#[cfg(test)]
mod tests;

pub use engine::{
    ARM_HINT, ARM_STALE_HINT, Engine, Input, Output, RecordingProgress, Saved, WatchStatus,
};
pub(crate) use engine::{file_name, truth_record};
