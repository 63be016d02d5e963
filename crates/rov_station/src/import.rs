//! Any log the lab reads, as a session: what `topside import LOG [--map MAP] --out
//! FILE.mcap` and the session browser's "Import a log…" do, so that replay, plots,
//! export and the lab work on another vehicle's log.
//!
//! - With a log map: the log is read through it by the lab's one loader
//!   ([`rov_lab::loader::read_with_map_text`]) and its measurement series stored; the map's
//!   text goes into the session's configuration.
//! - Without one: a CSV whose columns are those of a shipped map (the BlueROV2 tank data)
//!   goes through that map; a measurement CSV is imported as it is
//!   ([`rov_session::import_csv`]); a binary log (DataFlash, tlog, ROS bag, MCAP with CDR
//!   messages) is refused with the way out (a map).
//!
//! A session stores the Pro 4's three thruster commands: other command channels of a
//! mapped log are named in a warning (the lab reads them from the log with the map).

use std::path::{Path, PathBuf};

use rov_session::ImportReport;

/// Why a log could not be imported.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    /// The log or the map cannot be read.
    #[error("{}: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// A binary log without a map.
    #[error(
        "{log}: a {format} log; importing it needs a log map (--map MAP.toml; see README, \
         \"Logs of other vehicles\")"
    )]
    NeedsMap {
        /// The log.
        log: String,
        /// Its format.
        format: &'static str,
    },
    /// Neither a known log format nor UTF-8 text.
    #[error("{log}: not UTF-8 text; a binary log needs a log map (--map MAP.toml)")]
    NotText {
        /// The log.
        log: String,
    },
    /// The map does not parse, or the log does not read through it.
    #[error(transparent)]
    Lab(Box<rov_lab::LabError>),
    /// The session cannot be written, or the CSV is not a measurement CSV.
    #[error(transparent)]
    Session(Box<rov_session::SessionError>),
}

impl From<rov_lab::LabError> for ImportError {
    fn from(e: rov_lab::LabError) -> Self {
        Self::Lab(Box::new(e))
    }
}

impl From<rov_session::SessionError> for ImportError {
    fn from(e: rov_session::SessionError) -> Self {
        Self::Session(Box::new(e))
    }
}

fn read(path: &Path) -> Result<Vec<u8>, ImportError> {
    std::fs::read(path).map_err(|source| ImportError::Read {
        path: path.to_path_buf(),
        source,
    })
}

/// Imports `log` (through `map` when given) as a session file at `out`.
///
/// # Errors
/// [`ImportError`]: a file cannot be read or written, a binary log has no map, the map
/// does not parse or the log does not read through it.
pub fn import_log(log: &Path, map: Option<&Path>, out: &Path) -> Result<ImportReport, ImportError> {
    let label = log.display().to_string();
    let bytes = read(log)?;
    let mapped = match map {
        Some(map_path) => {
            let text = String::from_utf8_lossy(&read(map_path)?).into_owned();
            let map_label = map_path.display().to_string();
            let loaded = rov_lab::loader::read_with_map_text(&bytes, &text, &map_label, &label)?;
            Some((loaded, text))
        }
        None => shipped(&bytes, &label)?,
    };
    if let Some((loaded, map_text)) = mapped {
        let left_out: Vec<&str> = loaded
            .command_names()
            .into_iter()
            .filter(|n| !matches!(*n, "port" | "starboard" | "vertical"))
            .collect();
        let mut series = loaded.series.clone();
        series.warnings.extend(loaded.notes().iter().cloned());
        if !left_out.is_empty() {
            series.warnings.push(format!(
                "command channel(s) {} are not Pro 4 thrusters and are not stored in the \
                 session (the lab reads them from the log with --map)",
                left_out.join(", ")
            ));
        }
        return Ok(rov_session::import_series(&series, &label, &map_text, out)?);
    }
    if let Some(format) = rov_lab::loader::format_needing_map(&bytes) {
        return Err(ImportError::NeedsMap { log: label, format });
    }
    let text = String::from_utf8(bytes).map_err(|_| ImportError::NotText { log: label.clone() })?;
    Ok(rov_session::import_csv(&text, &label, out)?)
}

/// A CSV with the columns of a shipped map, read through it, with the map's text.
fn shipped(
    bytes: &[u8],
    label: &str,
) -> Result<Option<(rov_lab::loader::LoadedLog, String)>, ImportError> {
    let Some(map) = std::str::from_utf8(bytes)
        .ok()
        .and_then(rov_lab::ingest::shipped_map_for)
    else {
        return Ok(None);
    };
    let Some((_, text)) = rov_lab::ingest::SHIPPED_MAPS
        .iter()
        .find(|(name, _)| *name == map.label)
    else {
        return Ok(None);
    };
    let loaded = rov_lab::loader::read_mapped(bytes, &map, label)?;
    Ok(Some((loaded, (*text).to_string())))
}

/// A file name in `dir` for the session of `log`: its stem with `.mcap`, or with `-2`,
/// `-3` … when taken.
#[must_use]
pub fn session_path_for(dir: &Path, log: &Path) -> PathBuf {
    let stem = log.file_stem().map_or_else(
        || "imported".to_string(),
        |s| s.to_string_lossy().into_owned(),
    );
    let mut k = 1usize;
    loop {
        let name = if k == 1 {
            format!("{stem}.mcap")
        } else {
            format!("{stem}-{k}.mcap")
        };
        let p = dir.join(name);
        if !p.exists() || k >= 10_000 {
            return p;
        }
        k += 1;
    }
}
