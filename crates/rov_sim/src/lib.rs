//! The simulated VideoRay Pro 4: a truth model on virtual time with thrusters, ocean
//! current, external forces (e.g. a tether) and sensors, deterministic for a given seed.
//!
//! * [`simulator`]: [`Simulator`] (fixed step, default 100 Hz), [`SimConfig`],
//!   [`TruthState`], [`TetherForce`], [`FnForce`].
//! * [`series`]: thrust [`Schedule`]s, [`run_schedule`] (truth through the sensors as a
//!   measurement series) and the model-prediction series ([`predict_schedule`],
//!   [`predict_inputs`], [`predict_measured`]).
//! * [`fault`]: the `--fault` grammar ([`FaultSpec`], issue 23).
//! * [`paper`]: seed 000's experiments as named schedules.
//! * [`reference`]: parser and runner for the Fossen reference parameter files
//!   (`topside sim reference`).
//!
//! The mock vehicle behind the wire protocol lives in other modules of this crate.
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

pub mod error;
pub mod fault;
pub mod paper;
pub mod reference;
pub mod seabed;
pub mod series;
pub mod simulator;

pub use error::SimError;
pub use fault::{
    DepthSensorFault, FaultForce, FaultKind, FaultSpec, FaultSpecError, SensorFaultState, Thruster,
    apply_sensor_faults,
};
pub use paper::{Experiment, experiments};
pub use seabed::{Seabed, WaterSurface};
pub use series::{
    Schedule, ScheduleStep, predict_inputs, predict_measured, predict_schedule, run_schedule,
    run_schedule_on,
};
pub use simulator::{FnForce, SimConfig, Simulator, TetherForce, TruthState};
