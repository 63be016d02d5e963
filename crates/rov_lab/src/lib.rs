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

// The modules in reading order: data in → model → simulate and fit → compare →
// diagnose (with the verdict) → report; then the tools built on them. Each is
// declared on its own (a blank line between) so the order stays as written.

// 1. Data in: a log's bytes to lab runs.

// The one log loader (CSV, MCAP rows, any log through a map).
pub mod loader;

// The real-log treatment (sample intervals, gaps, spikes), said in words.
pub mod ingest;

// A log read through a log map (`rov_logs`).
pub mod mapped;

// Long logs streamed and decimated to a bounded number of rows.
pub mod stream;

// A measured run: commands, channels, noise floors.
pub mod data;

// 2. The model.

// `LabModel`: a base behind the `BaseModel` trait, with effects and terms.
pub mod model;

// Named scalar parameters that calibration frees.
pub mod params;

// The 17 catalog effects and their physics.
pub mod catalog;

// Discovered terms outside the catalog.
pub mod terms;

// Saving and loading extended models.
pub mod persist;

// The one model engine: load a model, fit it on runs, predict a session.
pub mod engine;

// 3. Simulate and fit.

// A model driven by a run's commands, in three error views.
pub mod sim;

// The one worker pool.
pub mod par;

// Bounded Levenberg–Marquardt with finite-difference Jacobians.
pub mod lm;

// Calibration on the simulation error over runs.
pub mod calibrate;

// 4. Compare.

// Fit % and RMSE per channel.
pub mod metrics;

// Held-out evaluation pooled over runs.
pub mod evaluate;

// Where it fails: residuals by thruster, command, segment.
pub mod analysis;

// Per-session and leave-one-session-out held-out fit.
pub mod cross_validate;

// 5. Diagnose, with the verdict.

// The diagnosis: catalog rounds, term search, report.
pub mod diagnose;

// Is the model consistent with the held-out data?
pub mod verdict;

// 6. Report and the user-level operations.

// PNG figures.
pub mod plots;

// Stages and Cancel of long work.
pub mod progress;

// `topside lab compare|diagnose|add`.
pub mod lab;

// 7. Tools on the same parts.

// `topside vehicle check`.
pub mod vehicle_check;

// The model watch (the station's second pair of eyes).
pub mod watch;

mod error;

pub use catalog::{EffectId, parse_effect_list};
pub use data::Run;
pub use engine::{ChannelFit, fit_runs, load_model};
pub use error::LabError;
pub use model::{BaseKind, LabModel};
pub use persist::save_extended_model;
