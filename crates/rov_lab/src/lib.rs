//! Model lab for the VideoRay Pro 4: compare a model with measurements, see where it
//! fails, learn which physical effect is missing, add it and watch the error fall.
//!
//! Method (shared/reference/modellab.md): three error views, metrics per channel,
//! calibration by bounded Levenberg–Marquardt on simulation error, a 17-effect catalog,
//! cheap screening by linearised sensitivities, simulation-error confirmation of the
//! best candidates with the base refitted jointly, acceptance on held-out data, greedy
//! forward selection.
//!
//! Pure library: no clock, no file I/O (callers read and write files).
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

pub mod analysis;
pub mod calibrate;
pub mod catalog;
pub mod cross_validate;
pub mod data;
pub mod diagnose;
pub mod engine;
mod error;
pub mod evaluate;
pub mod ingest;
pub mod lab;
pub mod lm;
pub mod loader;
pub mod mapped;
pub mod metrics;
pub mod model;
pub mod par;
pub mod params;
pub mod persist;
pub mod plots;
pub mod progress;
pub mod sim;
pub mod stream;
pub mod terms;
pub mod vehicle_check;
pub mod verdict;
pub mod watch;

pub use catalog::{EffectId, parse_effect_list};
pub use data::Run;
pub use engine::{ChannelFit, fit_runs, load_model};
pub use error::LabError;
pub use model::{BaseKind, LabModel};
pub use persist::save_extended_model;
