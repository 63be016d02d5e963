//! Depth and heading hold for the VideoRay Pro 4: the pure control tick.
//!
//! One [`Controller::tick`] runs
//!
//! 1. the Kalman [`observer`] on the control plant model (depth and heading channels,
//!    each with position, velocity and a first-order Markov bias),
//! 2. the [`reference`](mod@reference) model (smooth desired position, velocity and acceleration within
//!    limits; heading on the shortest wrapped path),
//! 3. the model [`feedforward`] (inverse heave and yaw dynamics of model1, model2 or
//!    model3, through that model's inverted thrust map),
//! 4. a [`pid`] per axis (derivative on the measured rate, clamping anti-windup, output
//!    and slew limits, bumpless engage),
//! 5. thrust [`allocation`] (yaw authority kept over surge) and
//! 6. the output [`guard`], the only constructor of a [`ThrustCommand`]: finite, within
//!    ±100 %, rate-limited.
//!
//! [`profile`] has the fixed tracking profiles `topside hold --profile` flies (pure
//! functions of time). [`pilot`] holds the cruise-control mode logic (stick override, latch on release,
//! typed and stepped setpoints) and the targets for the vehicle's own auto-depth and
//! auto-heading (CSR 0x0B/0x0D). [`config`] has the defaults and the `[control]` loader.
//!
//! No I/O, no clock: time and dt are arguments. Conventions: depth positive down;
//! heading increases turning to starboard; port thrust above starboard turns to
//! starboard; positive vertical thrust pushes the vehicle down. Internal units are SI
//! with radians.
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

pub mod allocation;
pub mod angle;
pub mod config;
pub mod controller;
pub mod error;
pub mod feedforward;
pub mod guard;
pub mod observer;
pub mod pid;
pub mod pilot;
pub mod profile;
pub mod reference;

pub use allocation::{Allocation, ThrustDemand, allocate, allocate_in_force};
pub use config::{AxisConfig, ControlConfig, FeedforwardForce};
pub use controller::{
    AxisDiagnostics, Controller, Faults, Measurements, ModelSet, TickDiagnostics, TickOutput,
    heading_rate_from_body_rates,
};
pub use error::ControlError;
pub use feedforward::{AxisDynamics, FeedforwardModel, ModelChoice, PlantModel, ThrustMap};
pub use guard::{GuardConfig, GuardReport, OutputGuard, ThrustCommand};
pub use observer::{
    ChannelEstimate, ChannelNoise, ChannelStats, KalmanChannel, Observer, SampleOutcome,
};
pub use pid::{Pid, PidConfig, PidTerms};
pub use pilot::{
    Axis, AxisMode, AxisState, ModeCommand, PilotInput, SurfaceTare, VehicleAutoTargets,
    depth_m_from_mbar, depth_target_mbar, heading_target_deg,
};
pub use profile::{ProfilePoint, TrackingProfile};
pub use reference::{ReferenceConfig, ReferenceModel, ReferenceState};
