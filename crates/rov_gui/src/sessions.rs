//! The session browser (Replay tab): the recordings folder as a list (date, duration,
//! size, vehicle, notes) with Replay, Export CSV and Send to lab; read on a worker
//! thread and cached by (path, size, modification time), so a folder of long dives is
//! read once.
//!
//! Reading a session's metadata goes through [`summarize`] only, with `rov_session`'s
//! public API (open, info, duration, events): when the reader streams from the MCAP
//! summary and indexes, the list gets cheap without changes here.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, channel};
use std::time::SystemTime;

use crate::FileError;

/// One recording in the list.
#[derive(Debug, Clone, PartialEq)]
pub struct SessionSummary {
    /// The file.
    pub path: PathBuf,
    /// Size, bytes.
    pub size_bytes: u64,
    /// Start, seconds since the Unix epoch (the session's info; else the file time).
    pub started_unix_s: f64,
    /// Duration, s.
    pub duration_s: f64,
    /// `sim`, `serial:PATH` or `import`.
    pub vehicle: String,
    /// The dive-log notes (their text).
    pub notes: Vec<String>,
    /// Markers.
    pub markers: usize,
    /// The file is complete (else truncated or damaged: replayable up to the damage).
    pub complete: bool,
    /// Why it could not be read.
    pub error: Option<String>,
}

/// Reads one session's summary (the only place the browser reads a session).
#[must_use]
pub fn summarize(path: &Path, size_bytes: u64, modified_unix_s: f64) -> SessionSummary {
    let mut s = SessionSummary {
        path: path.to_path_buf(),
        size_bytes,
        started_unix_s: modified_unix_s,
        duration_s: 0.0,
        vehicle: String::new(),
        notes: Vec::new(),
        markers: 0,
        complete: false,
        error: None,
    };
    match rov_session::open(path) {
        Ok(session) => {
            s.duration_s = session.duration_s();
            s.complete = session.is_complete();
            if let Some(info) = session.info() {
                s.vehicle = info.vehicle;
                if info.started_unix_s > 0.0 {
                    s.started_unix_s = info.started_unix_s;
                }
            }
            let events = session
                .records::<rov_session::EventRecord>()
                .unwrap_or_else(|e| {
                    // The list still shows the session; its notes are missing, and why
                    // is said.
                    tracing::warn!("{}: dive notes unreadable: {e}", path.display());
                    Vec::new()
                });
            for (_, e) in events {
                match e.kind.as_str() {
                    "note" => s.notes.push(e.text),
                    "marker" => s.markers += 1,
                    _ => {}
                }
            }
        }
        Err(e) => s.error = Some(e.to_string()),
    }
    s
}

/// "2026-11-25 17:41" (UTC) of Unix seconds.
#[must_use]
pub fn utc_text(unix_s: f64) -> String {
    let secs = unix_s.max(0.0) as i64;
    let days = secs.div_euclid(86_400);
    let rem = secs.rem_euclid(86_400);
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02} {:02}:{:02}",
        rem / 3600,
        rem % 3600 / 60
    )
}

type Key = (PathBuf, u64, u64);
/// A finished scan: the list and the cache for the next one.
type Scan = (Vec<SessionSummary>, HashMap<Key, SessionSummary>);

/// The browser's state.
#[derive(Debug, Default)]
pub struct SessionBrowser {
    /// The folder listed.
    pub dir: PathBuf,
    /// The list, newest first.
    pub entries: Vec<SessionSummary>,
    /// A scan running.
    pending: Option<Receiver<Scan>>,
    cache: HashMap<Key, SessionSummary>,
    /// The last scan's error.
    pub error: Option<String>,
    /// An import running (see [`SessionBrowser::start_import`]).
    importing: Option<Receiver<ImportDone>>,
    /// The last import's outcome in words, and whether it worked.
    pub import_note: Option<(bool, String)>,
}

/// A finished import: the session written and the import's report, or why not.
type ImportDone = Result<(PathBuf, rov_session::ImportReport), rov_station::import::ImportError>;

fn unix(t: SystemTime) -> f64 {
    t.duration_since(SystemTime::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

impl SessionBrowser {
    /// Whether a scan is running.
    #[must_use]
    pub fn busy(&self) -> bool {
        self.pending.is_some()
    }

    /// Lists `dir` again in the background (files already read are taken from the
    /// cache).
    pub fn refresh(&mut self, dir: &Path) {
        self.dir = dir.to_path_buf();
        let dir = dir.to_path_buf();
        let cache = self.cache.clone();
        let (tx, rx) = channel();
        let spawned = std::thread::Builder::new()
            .name("session-browser".into())
            .spawn(move || {
                let mut out = Vec::new();
                let mut next = HashMap::new();
                let listing = std::fs::read_dir(&dir).map_err(|e| {
                    // No folder yet is an empty list; any other failure is said.
                    if e.kind() != std::io::ErrorKind::NotFound {
                        tracing::warn!("recordings folder {}: {e}", dir.display());
                    }
                });
                if let Ok(rd) = listing {
                    for e in rd.flatten() {
                        let p = e.path();
                        if !p
                            .extension()
                            .is_some_and(|x| x.eq_ignore_ascii_case("mcap"))
                        {
                            continue;
                        }
                        // A file removed while listing is skipped.
                        let Ok(meta) = e.metadata() else { continue };
                        let modified = meta.modified().map(unix).unwrap_or(0.0);
                        let key = (p.clone(), meta.len(), modified.to_bits());
                        let s = cache
                            .get(&key)
                            .cloned()
                            .unwrap_or_else(|| summarize(&p, meta.len(), modified));
                        next.insert(key, s.clone());
                        out.push(s);
                    }
                }
                out.sort_by(|a, b| b.started_unix_s.total_cmp(&a.started_unix_s));
                // The browser has gone (app closing) if this fails: nobody waits.
                let _ = tx.send((out, next));
            });
        match spawned {
            Ok(_) => {
                self.pending = Some(rx);
                self.error = None;
            }
            Err(e) => self.error = Some(format!("cannot list the folder: {e}")),
        }
    }

    /// Whether an import is running.
    #[must_use]
    pub fn importing(&self) -> bool {
        self.importing.is_some()
    }

    /// Imports another vehicle's log (through `map` when given: DataFlash, tlog, ROS bag,
    /// a CSV with its own columns; a measurement CSV or a shipped map's CSV without) as a
    /// session in `dir` named after the log, on a worker
    /// ([`rov_station::import::import_log`], what `topside import` does); the list is read
    /// again when it is done.
    pub fn start_import(&mut self, log: PathBuf, map: Option<PathBuf>, dir: &Path) {
        let dir = dir.to_path_buf();
        let (tx, rx) = channel();
        let spawned = std::thread::Builder::new()
            .name("session-import".into())
            .spawn(move || {
                let made = std::fs::create_dir_all(&dir).map_err(|source| {
                    rov_station::import::ImportError::Read {
                        path: dir.clone(),
                        source,
                    }
                });
                let out = rov_station::import::session_path_for(&dir, &log);
                let done = made
                    .and_then(|()| rov_station::import::import_log(&log, map.as_deref(), &out))
                    .map(|r| (out, r));
                // The browser has gone (app closing) if this fails: nobody waits.
                let _ = tx.send(done);
            });
        match spawned {
            Ok(_) => {
                self.importing = Some(rx);
                self.import_note = None;
            }
            Err(e) => self.import_note = Some((false, format!("cannot start the import: {e}"))),
        }
    }

    /// Takes a finished import (its note; the folder is listed again).
    fn poll_import(&mut self) {
        let Some(rx) = &self.importing else { return };
        let done = match rx.try_recv() {
            Ok(d) => d,
            Err(std::sync::mpsc::TryRecvError::Empty) => return,
            Err(std::sync::mpsc::TryRecvError::Disconnected) => {
                self.importing = None;
                self.import_note = Some((false, "the import stopped".into()));
                return;
            }
        };
        self.importing = None;
        self.import_note = Some(match done {
            Ok((out, r)) => {
                let name = out
                    .file_name()
                    .map_or_else(|| out.display().to_string(), |n| n.to_string_lossy().into());
                let mut text = format!("imported as {name}: {} rows", r.rows);
                if let Some(w) = r.warnings.first() {
                    text.push_str(&format!(" ({w}"));
                    if r.warnings.len() > 1 {
                        text.push_str(&format!("; {} more warnings", r.warnings.len() - 1));
                    }
                    text.push(')');
                }
                (true, text)
            }
            Err(e) => (false, format!("import failed: {e}")),
        });
        let dir = self.dir.clone();
        self.refresh(&dir);
    }

    /// Waits for a running import (tests).
    pub fn wait_import(&mut self) {
        while self.importing.is_some() {
            self.poll_import();
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
    }

    /// Takes a finished scan or import.
    pub fn poll(&mut self) {
        self.poll_import();
        if let Some(rx) = &self.pending
            && let Ok((entries, cache)) = rx.try_recv()
        {
            self.entries = entries;
            self.cache = cache;
            self.pending = None;
        }
    }

    /// Waits for a running scan (tests).
    pub fn wait(&mut self) {
        if let Some(rx) = self.pending.take()
            && let Ok((entries, cache)) = rx.recv()
        {
            self.entries = entries;
            self.cache = cache;
        }
    }
}

/// Exports a session as the measurement CSV plus every decoded channel (what `topside
/// export` writes); returns a line for the pilot.
///
/// # Errors
/// [`FileError`] naming the file.
pub fn export_csv(session_path: &Path, out: &Path) -> Result<String, FileError> {
    let session = rov_session::open(session_path).map_err(|e| FileError::OpenSession {
        path: session_path.to_path_buf(),
        source: Box::new(e),
    })?;
    let csv = rov_session::export_csv(&session)?;
    std::fs::write(out, &csv.text).map_err(|source| FileError::Write {
        path: out.to_path_buf(),
        source,
    })?;
    Ok(format!(
        "exported {} rows to {}{}",
        csv.rows,
        out.display(),
        if csv.warnings.is_empty() {
            String::new()
        } else {
            format!(" ({} warnings)", csv.warnings.len())
        }
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utc_dates() {
        assert_eq!(utc_text(0.0), "1970-01-01 00:00");
        assert_eq!(utc_text(951_782_400.0), "2000-02-29 00:00");
        assert_eq!(utc_text(1_795_630_067.0), "2026-11-25 18:07");
    }
}
