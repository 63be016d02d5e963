//! Errors of the session layer.

use std::path::PathBuf;

/// Why a session operation failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SessionError {
    /// A file could not be created, read, written or synced.
    #[error("{path}: {action}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What was being done (e.g. "create", "read", "fsync").
        action: &'static str,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// A message is larger than the cap; nothing was written.
    #[error(
        "message on {topic} is larger than the {max} byte cap (at least {len} bytes); not written"
    )]
    MessageTooLarge {
        /// Topic.
        topic: String,
        /// Size reached before giving up, bytes.
        len: usize,
        /// The cap, bytes.
        max: usize,
    },
    /// A video access unit was refused.
    #[error("{topic}: {source}")]
    Video {
        /// Topic.
        topic: String,
        /// What is wrong with it.
        #[source]
        source: crate::foxglove::VideoError,
    },
    /// A record could not be encoded as JSON.
    #[error("{topic}: cannot encode the record as JSON: {detail}")]
    Encode {
        /// Topic.
        topic: String,
        /// serde_json's message.
        detail: String,
    },
    /// The file is not an MCAP file at all.
    #[error("{path}: not an MCAP session file: {detail}")]
    NotMcap {
        /// The file (or a label for bytes in memory).
        path: PathBuf,
        /// What was found instead.
        detail: String,
    },
    /// A message of a known topic does not decode as its record type.
    #[error("{topic} message {sequence} at t = {t_ns} ns does not decode: {detail}")]
    Decode {
        /// Topic.
        topic: String,
        /// The message's sequence number.
        sequence: u32,
        /// The message's log time, ns.
        t_ns: u64,
        /// serde_json's message.
        detail: String,
    },
    /// A topic has a different encoding from the one its record type needs.
    #[error("{topic} has message encoding {found:?}, expected {expected:?}")]
    WrongEncoding {
        /// Topic.
        topic: String,
        /// Encoding in the file.
        found: String,
        /// Encoding expected.
        expected: &'static str,
    },
    /// The session lacks what an operation needs.
    #[error("{0}")]
    Unusable(String),
    /// A measurement CSV could not be read.
    #[error(transparent)]
    Csv(#[from] rov_types::MeasurementError),
}

/// Shorthand result.
pub type Result<T, E = SessionError> = std::result::Result<T, E>;

pub(crate) fn io_err(
    path: &std::path::Path,
    action: &'static str,
) -> impl FnOnce(std::io::Error) -> SessionError {
    let path = path.to_path_buf();
    move |source| SessionError::Io {
        path,
        action,
        source,
    }
}
