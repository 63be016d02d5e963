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

#[cfg(test)]
mod tests {
    use super::*;

    /// Each loader names the file the pilot chose, with the lower crate's error kept
    /// as the source.
    #[test]
    fn files_that_cannot_be_used_are_named() {
        let root = std::env::temp_dir().join(format!("rov_gui_file_error_{}", std::process::id()));
        std::fs::create_dir_all(&root).unwrap();
        // A model file that is not there.
        let missing = root.join("missing.toml");
        let e = crate::autopilot_model::load_file(&missing).unwrap_err();
        assert!(
            matches!(&e, FileError::Read { path, .. } if path == &missing),
            "{e:?}"
        );
        assert!(
            e.to_string().starts_with(&missing.display().to_string()),
            "{e}"
        );
        assert!(std::error::Error::source(&e).is_some());
        // A session to export that is not an MCAP file: named, even if the session
        // layer's words do not name it.
        let text = root.join("notes.mcap");
        std::fs::write(&text, b"not a session").unwrap();
        let e = crate::sessions::export_csv(&text, &root.join("out.csv")).unwrap_err();
        assert!(
            matches!(&e, FileError::OpenSession { path, .. } if path == &text),
            "{e:?}"
        );
        assert!(
            e.to_string().starts_with(&text.display().to_string()),
            "{e}"
        );
        // Lab data that is not a log: the lab's error, as it is.
        let junk = root.join("junk.csv");
        std::fs::write(&junk, b"a,b\n1,2\n").unwrap();
        let e = crate::lab::load(&junk).map(|_| ()).unwrap_err();
        assert!(matches!(&e, FileError::Lab(_)), "{e:?}");
        std::fs::remove_dir_all(&root).ok();
    }
}
