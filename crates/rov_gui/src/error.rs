//! Why a file the pilot chose could not be used: a model for the autopilot, data for
//! the Model lab, a session to export. The GUI shows the error's `Display` (each
//! variant names the file and keeps the lower crate's error as its source).

use std::path::PathBuf;

/// A file the pilot chose could not be read, written or used.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FileError {
    /// The file cannot be read.
    #[error("{}: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// The file cannot be written.
    #[error("{}: {source}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// The session does not open (named, whatever the session layer's error says).
    #[error("{}: {source}", path.display())]
    OpenSession {
        /// The session file.
        path: PathBuf,
        /// The session layer's error (boxed: it is large, and rare).
        #[source]
        source: Box<rov_session::SessionError>,
    },
    /// The session's records do not give what was asked (its error names the topic).
    #[error(transparent)]
    Session(Box<rov_session::SessionError>),
    /// The lab refused the data or the model (its error names the file, key or run).
    #[error(transparent)]
    Lab(Box<rov_lab::LabError>),
    /// The model has no valid plant for the autopilot.
    #[error(transparent)]
    Plant(#[from] rov_station::HoldError),
}

impl From<rov_session::SessionError> for FileError {
    fn from(e: rov_session::SessionError) -> Self {
        Self::Session(Box::new(e))
    }
}

impl From<rov_lab::LabError> for FileError {
    fn from(e: rov_lab::LabError) -> Self {
        Self::Lab(Box::new(e))
    }
}
