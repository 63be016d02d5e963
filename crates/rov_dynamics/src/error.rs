//! Typed errors of the dynamics crate.

/// Why a dynamics computation or simulation stopped.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum DynamicsError {
    /// The state became NaN or infinite; the simulation stops instead of going on silently.
    #[error("state became non-finite at t = {time_s} s: {state}")]
    NonFinite {
        /// Simulation time at which the non-finite state was detected, s.
        time_s: f64,
        /// The offending state, printed.
        state: String,
    },
    /// A parameter set cannot be used (non-finite, or a mass matrix not positive definite).
    #[error("invalid parameter for {what}: {detail}")]
    InvalidParameter {
        /// What the parameter belongs to.
        what: String,
        /// Why it is invalid.
        detail: String,
    },
    /// An input sequence or argument is unusable.
    #[error("invalid input: {detail}")]
    InvalidInput {
        /// What is wrong.
        detail: String,
    },
}
