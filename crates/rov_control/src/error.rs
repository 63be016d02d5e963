//! Errors of the control crate.

use crate::pilot::Axis;

/// An error from building or commanding the controller. Per-tick problems (bad samples,
/// non-finite outputs) are never errors: they are reported as fault flags in the tick's
/// diagnostics while the output stays finite and bounded.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ControlError {
    /// A configuration value is non-finite or outside its allowed range.
    #[error("control config: {field} = {value} is out of range (allowed {allowed})")]
    InvalidConfig {
        /// Dotted field path, as in the `[control]` section of `station.toml`.
        field: String,
        /// The offending value.
        value: f64,
        /// The allowed range.
        allowed: String,
    },
    /// A model parameter is non-finite or outside its physical range.
    #[error("feedforward model {model}: {field} = {value} is out of range (allowed {allowed})")]
    InvalidModel {
        /// Model name (`model1`, `model2`, `model3` or a custom label).
        model: String,
        /// Parameter name.
        field: String,
        /// The offending value.
        value: f64,
        /// The allowed range.
        allowed: String,
    },
    /// A hold cannot be engaged because the axis has no valid measurement yet.
    #[error("cannot hold {axis:?}: no valid measurement yet")]
    NoEstimate {
        /// The axis.
        axis: Axis,
    },
    /// A typed setpoint is non-finite or outside the allowed range.
    #[error("setpoint {value} for {axis:?} is out of range (allowed {allowed})")]
    InvalidSetpoint {
        /// The axis.
        axis: Axis,
        /// The offending value.
        value: f64,
        /// The allowed range.
        allowed: String,
    },
    /// A surface-pressure tare is non-finite or implausible.
    #[error("surface pressure tare {value_mbar} mbar is out of range (allowed {allowed})")]
    InvalidTare {
        /// The offending value in mbar.
        value_mbar: f64,
        /// The allowed range.
        allowed: String,
    },
}

/// Checks `lo <= value <= hi` (and finiteness) for a config field.
pub(crate) fn check_range(field: &str, value: f64, lo: f64, hi: f64) -> Result<(), ControlError> {
    if value.is_finite() && value >= lo && value <= hi {
        Ok(())
    } else {
        Err(ControlError::InvalidConfig {
            field: field.to_string(),
            value,
            allowed: format!("{lo}..={hi}"),
        })
    }
}
