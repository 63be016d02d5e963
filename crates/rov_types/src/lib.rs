//! Shared data types of the topside workspace.
//!
//! * [`params`]: TOML parameter files whose every value carries its unit and source, read
//!   with errors that name the file, the key path, the value and the allowed range.
//! * [`measurement`]: the measurement CSV format that the simulator writes and the model
//!   lab and the session tools read.
//! * [`number`]: how every CSV writer formats numbers (shortest round trip).
//! * [`angle`]: angle wrapping, both conventions named (the one implementation).
//! * [`model_id`]: which model (model1|model2|model3|FILE.toml), parsed in one place.
//! * [`fit`]: fit % and RMSE of a prediction against a measurement (the one
//!   implementation).
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

pub mod angle;
pub mod conventions;
pub mod fit;
pub mod measurement;
pub mod model_id;
pub mod number;
pub mod params;

pub use measurement::{MeasurementError, MeasurementRow, MeasurementSeries};
pub use model_id::{BaseModel, ModelId, ModelIdError};
pub use params::{ConfigError, ParamFile};
