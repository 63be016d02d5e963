//! `topside` with no subcommand: the station window.
//!
//! * No arguments: the simulated Pro 4, in-process.
//! * `--port PATH`: a real Pro 4 on a serial port (if the port does not open, the window
//!   still opens, on the Connection tab, with the error shown).
//! * Hidden `--screenshot PATH --screenshot-after-s N`: after N seconds the window takes a
//!   screenshot of itself (eframe viewport screenshot), saves it as PNG and closes; the
//!   exit status says whether the PNG was written (used by the Xvfb test).
//!
//! The control settings come from `--config PATH`, else the user's `station.toml` in the
//! platform's configuration directory, else the built-in defaults (see
//! [`crate::config_file`]). Every session is recorded from the
//! moment the station starts, to `./recordings/session-<unix time>.mcap` (`--recordings DIR` elsewhere; REC
//! stops and restarts it; `--no-record` starts without recording).

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::Ordering;

use rov_gui::{Backend as _, RealBackend, ScreenshotRequest, StationApp, Tab};
use rov_station::runtime::{Connection, Runtime, RuntimeConfig};

/// The runtime settings (see [`crate::config_file`]), on the given port or the
/// simulator. Shared with `topside record`.
pub fn config(
    port: Option<String>,
    config: Option<&std::path::Path>,
) -> anyhow::Result<RuntimeConfig> {
    let user = crate::config_file::user_config_path();
    let loaded = crate::config_file::load(config, user.as_deref())?;
    if let Some(p) = &loaded.path {
        eprintln!("settings from {}", p.display());
    }
    Ok(RuntimeConfig {
        connection: port.map_or(Connection::Sim, Connection::Serial),
        control: loaded.control,
        config_toml: loaded.text,
        ..RuntimeConfig::default()
    })
}

/// Opens the station window; see the module docs.
pub fn run_station(
    port: Option<String>,
    config_path: Option<&std::path::Path>,
    record_to: Option<PathBuf>,
    screenshot: Option<(PathBuf, f64)>,
) -> anyhow::Result<ExitCode> {
    let cfg = config(port, config_path)?;
    let recordings = record_to
        .clone()
        .unwrap_or_else(|| PathBuf::from("recordings"));
    let mut backend = RealBackend::new(cfg.clone(), recordings);
    let (live, error) = match Runtime::start(cfg.clone()) {
        Ok(h) => (Some(h), None),
        Err(e) => (None, Some(format!("cannot start the station: {e}"))),
    };
    if let (Some(h), Some(_)) = (&live, &record_to) {
        // The same file naming as the REC button.
        let path = backend.recording_path();
        eprintln!("recording to {}", path.display());
        h.start_recording(&path);
    }
    let mut app = StationApp::new(Box::new(backend), live);
    if let Some(e) = error {
        eprintln!("warning: {e}");
        app.set_message(e);
        app.set_tab(Tab::Connection);
    }
    let mut saved = None;
    if let Some((path, after_s)) = screenshot {
        let req = ScreenshotRequest::new(path, after_s);
        saved = Some(req.saved_flag());
        app = app.with_screenshot(req);
    }
    rov_gui::run_native(app).map_err(|e| anyhow::anyhow!("cannot open the window: {e}"))?;
    match saved {
        Some(flag) if !flag.load(Ordering::Relaxed) => {
            eprintln!("error: the screenshot was not saved");
            Ok(ExitCode::from(1))
        }
        _ => Ok(ExitCode::SUCCESS),
    }
}
