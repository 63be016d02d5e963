//! Shared data types of the topside workspace.
//!
//! * [`params`]: TOML parameter files whose every value carries its unit and source, read
//!   with errors that name the file, the key path, the value and the allowed range.
//! * [`measurement`]: the measurement CSV format that the simulator writes and the model
//!   lab and the session tools read.
//! * [`number`]: how every CSV writer formats numbers (shortest round trip).
//!
//! This crate does no I/O: it parses and formats text. Callers read and write files.
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::indexing_slicing,
        clippy::panic
    )
)]

pub mod conventions;
pub mod measurement;
pub mod number;
pub mod params;

pub use measurement::{MeasurementError, MeasurementRow, MeasurementSeries};
pub use params::{ConfigError, ParamFile};
