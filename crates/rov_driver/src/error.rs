//! Errors of the driver.

pub use rov_transport::TransportError;

/// A [`LinkConfig`](crate::LinkConfig) value out of range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("link config: {field} = {value} is out of range (allowed {allowed})")]
pub struct ConfigError {
    /// The setting.
    pub field: &'static str,
    /// Its value, as text.
    pub value: String,
    /// What is accepted.
    pub allowed: String,
}

/// Why [`Failsafe::arm`](crate::Failsafe::arm) refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ArmError {
    /// The link is not connected (degraded, lost or still searching).
    #[error("cannot arm: the link is not connected")]
    LinkNotConnected,
    /// The link has been healthy for less than the required time.
    #[error("cannot arm: link healthy for {healthy_us} µs, {required_us} µs required")]
    NotHealthyLongEnough {
        /// How long it has been healthy, µs.
        healthy_us: u64,
        /// How long it must be, µs.
        required_us: u64,
    },
}

/// Any driver error.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DriverError {
    /// Transport failure.
    #[error(transparent)]
    Transport(#[from] TransportError),
    /// Invalid configuration.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// Invalid wire conventions.
    #[error(transparent)]
    Conventions(#[from] rov_types::conventions::ConventionsError),
    /// A frame could not be encoded (a bug or an out-of-range request).
    #[error("encode: {0}")]
    Encode(firmware_proto::EncodeError),
    /// The async runner stopped (its task ended or panicked).
    #[error("the link task has stopped")]
    RunnerStopped,
    /// Arming refused.
    #[error(transparent)]
    Arm(#[from] ArmError),
}

impl From<firmware_proto::EncodeError> for DriverError {
    fn from(e: firmware_proto::EncodeError) -> Self {
        Self::Encode(e)
    }
}
