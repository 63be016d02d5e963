//! Typed errors of the model lab.

use rov_types::{ConfigError, MeasurementError};

/// Why a lab operation failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum LabError {
    /// A model parameter file or saved extended model is invalid.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A measurement CSV is invalid.
    #[error(transparent)]
    Measurement(#[from] MeasurementError),
    /// The model name is neither a base model nor usable.
    #[error(
        "unknown model {name:?}: expected model1, model2, model3 or a saved extended-model TOML"
    )]
    UnknownModel {
        /// What was given.
        name: String,
    },
    /// An effect ID is not in the catalog.
    #[error("unknown effect {name:?}; `topside lab effects` lists the 17 IDs")]
    UnknownEffect {
        /// What was given.
        name: String,
    },
    /// An effect cannot be added to this model.
    #[error("effect {effect} cannot be added to {model}: {reason}")]
    NotApplicable {
        /// Effect ID.
        effect: String,
        /// Model name.
        model: String,
        /// Why.
        reason: String,
    },
    /// The data cannot be used.
    #[error("{run}: {detail}")]
    Data {
        /// Run label.
        run: String,
        /// What is wrong.
        detail: String,
    },
    /// A model could not be built or simulated.
    #[error("model: {detail}")]
    Model {
        /// What went wrong.
        detail: String,
    },
    /// A saved extended model is malformed.
    #[error("{file}: {detail}")]
    SavedModel {
        /// File label.
        file: String,
        /// What is wrong.
        detail: String,
    },
    /// A log could not be read or its map is invalid.
    #[error(transparent)]
    Log(#[from] rov_logs::LogError),
    /// A log map names a command channel the lab's vocabulary does not have.
    #[error("{map}: `{channel}` cannot name a command channel (allowed: {known})")]
    UndeclaredChannel {
        /// The map's label.
        map: String,
        /// The channel name.
        channel: String,
        /// What a channel name may be.
        known: String,
    },
    /// A plot could not be rendered.
    #[error("plot {name}: {detail}")]
    Plot {
        /// Plot name.
        name: String,
        /// What went wrong.
        detail: String,
    },
    /// The work was cancelled (see [`crate::progress::Progress::cancel`]).
    #[error("cancelled")]
    Cancelled,
}
