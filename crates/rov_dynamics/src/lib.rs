//! Dynamics of the VideoRay Pro 4 ROV: pure math on nalgebra, no I/O, no clock (time is
//! always an argument).
//!
//! Frames and conventions (Fossen): NED {n} (x north, y east, z down) and body {b}
//! (x forward, y starboard, z down). The body origin CO is the centre of buoyancy; the CG
//! of the Pro 4 lies 5.59 mm below it. η = [x, y, z, φ, θ, ψ], ν = [u, v, w, p, q, r],
//! τ = [X, Y, Z, K, M, N], SI units throughout (angles in radians inside the math,
//! degrees only at the measurement/CSV boundary).
//!
//! Modules (seed 001 unless noted):
//!
//! * [`kinematics`]: J(η) with ZYX Euler angles (eq. 1, 3) and a quaternion option.
//! * [`process`]: the process plant model (eq. 4–26) with the ocean current through the
//!   relative velocity, exactly as the fossen_reference README states.
//! * [`current`]: constant or Gauss–Markov ocean current (eq. 33–37).
//! * [`thrusters`]: thrust maps, propeller models, K_T(J) polynomials, geometry → τ.
//! * [`control_plant`]: the control plant model (eq. 28–32) and discretised
//!   depth and heading channels for an observer.
//! * [`sensors`]: IMU, DVL, transponder, pressure gauge (eq. 42–48) and the Pro 4's
//!   integer telemetry ([`sensors::Pro4Outputs`]).
//! * [`integrators`]: RK4 and Fossen's semi-implicit Euler.
//! * [`plant`]: a model reduced to heave and yaw with its thrust path, for autopilots
//!   ([`VehicleModel::plant`]).
//! * [`models`]: the three VideoRay models of seed 000 behind [`models::VehicleModel`],
//!   their parameter-file loaders and [`models::simulate`].
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

pub mod control_plant;
pub mod current;
pub mod error;
pub mod integrators;
pub mod kinematics;
pub mod math;
pub mod models;
pub mod plant;
pub mod process;
pub mod sensors;
pub mod thrusters;

pub use error::DynamicsError;
pub use math::{Matrix6, Vector6};
pub use models::{
    Channel, Environment, ExternalForce, InitialConditions, ModelOutput, ModelState, VehicleModel,
    load_default_model, load_model, simulate,
};
pub use thrusters::{ThrustPct, ThrusterForces};
