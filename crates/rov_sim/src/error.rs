//! Errors of the simulator.

use rov_dynamics::DynamicsError;
use rov_types::ConfigError;

/// Why a simulation could not run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SimError {
    /// The dynamics stopped (non-finite state, bad parameter, bad input).
    #[error(transparent)]
    Dynamics(#[from] DynamicsError),
    /// A parameter file is invalid.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A simulator argument is unusable.
    #[error("invalid simulator input: {detail}")]
    InvalidInput {
        /// What is wrong.
        detail: String,
    },
}
