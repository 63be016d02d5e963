//! The station GUI (egui/eframe): the pilot's HUD, autopilot, health, plots, recording,
//! replay and the model lab.
//!
//! The GUI renders [`StationView`](rov_station::runtime::StationView)s and emits commands;
//! control and safety timers (the control tick, hold-to-arm, input liveness, watchdog,
//! alarms) live in [`rov_station::runtime`], never in a GUI frame.
//!
//! * [`app`]: [`StationApp`] (state, frame, top bar, alarm bar, keyboard) and the
//!   [`Backend`] that supplies stations (real threads in the binary, virtual ones in
//!   tests).
//! * [`instruments`]: depth tape, heading tape with turns counter, artificial horizon,
//!   pitch glyph, thruster bars, hold-to-arm button.
//! * `fly`, `panels`: the Fly tab and its side panels.
//! * [`plots`]: decimated time plots.
//! * `replay`, `connection`, [`lab`]: the other tabs.
//! * [`run_native`]: opens the window.

pub mod app;
pub mod autopilot_model;
mod connection;
mod dive;
pub mod error;
pub mod fly;
mod foxglove_live;
mod help;
pub mod instruments;
pub mod lab;
pub mod lab_source;
mod lab_video;
pub mod layout;
mod pad_page;
mod panels;
pub mod pilot_keys;
pub mod plots;
mod replay;
pub mod screenshot;
pub mod sessions;
pub mod settings;
pub mod theme;
pub mod video;
mod video_settings;
mod watch_page;

use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, channel};
use std::time::Duration;

pub use app::{AutodetectResult, Backend, ScreenshotRequest, StationApp, Tab};
pub use error::FileError;
pub use fly::MainView;

/// The keys the F1 window lists (for tests and documentation).
#[must_use]
pub fn help_keys() -> Vec<&'static str> {
    help_lines().into_iter().map(|(k, _)| k).collect()
}

/// The F1 window's keyboard lines: (keys, what they do).
#[must_use]
pub fn help_lines() -> Vec<(&'static str, &'static str)> {
    help::KEYS
        .iter()
        .chain(&pilot_keys::KEYS)
        .copied()
        .collect()
}
use rov_station::runtime::{Connection, Runtime, RuntimeConfig, RuntimeError, StationHandle};

/// The real backend: stations on their own threads ([`Runtime`]).
#[derive(Debug, Clone)]
pub struct RealBackend {
    /// Template for new live stations (the connection is replaced).
    pub config: RuntimeConfig,
    /// Where recordings go.
    pub recordings_dir: PathBuf,
}

impl RealBackend {
    /// With a configuration; recordings go to `recordings_dir`.
    #[must_use]
    pub fn new(config: RuntimeConfig, recordings_dir: PathBuf) -> Self {
        Self {
            config,
            recordings_dir,
        }
    }
}

impl Backend for RealBackend {
    fn connect(&mut self, connection: &Connection) -> Result<StationHandle, RuntimeError> {
        let cfg = RuntimeConfig {
            connection: connection.clone(),
            ..self.config.clone()
        };
        Runtime::start(cfg)
    }

    fn open_replay(&mut self, path: &Path) -> Result<StationHandle, RuntimeError> {
        Runtime::replay(path)
    }

    fn ports(&mut self) -> Vec<String> {
        // The port field stays editable: a failed listing offers no names, and says why.
        rov_driver::available_port_names().unwrap_or_else(|e| {
            tracing::warn!("cannot list the serial ports: {e}");
            Vec::new()
        })
    }

    fn autodetect(&mut self, ports: Vec<String>) -> Receiver<AutodetectResult> {
        let (tx, rx) = channel();
        let node = self.config.link.node;
        let failed = tx.clone();
        let spawned = std::thread::Builder::new()
            .name("autodetect".into())
            .spawn(move || {
                let r = rov_driver::autodetect(&ports, node, Duration::from_millis(400));
                // The Connection tab has gone if this fails: nobody waits for it.
                let _ = tx.send(AutodetectResult {
                    found: r.found.map(|p| p.port),
                    tried: r.tried,
                });
            });
        if let Err(e) = spawned {
            // The tab shows the reason instead of a spinner; `rx` is still held here, so
            // the send cannot fail.
            let _ = failed.send(AutodetectResult {
                found: None,
                tried: vec![(
                    "autodetect".into(),
                    Some(format!("cannot start the autodetect thread: {e}")),
                )],
            });
        }
        rx
    }

    fn recording_path(&mut self) -> PathBuf {
        rov_station::runtime::recording_path_in(&self.recordings_dir)
    }

    fn recordings_dir(&self) -> PathBuf {
        self.recordings_dir.clone()
    }

    fn pick_file(&mut self, title: &str, extensions: &[&str]) -> Option<PathBuf> {
        rfd::FileDialog::new()
            .set_title(title)
            .add_filter(extensions.join(", "), extensions)
            .set_directory(&self.recordings_dir)
            .pick_file()
    }

    fn save_file(&mut self, title: &str, default_name: &str) -> Option<PathBuf> {
        rfd::FileDialog::new()
            .set_title(title)
            .set_file_name(default_name)
            .set_directory(&self.recordings_dir)
            .save_file()
    }

    fn pick_folder(&mut self, title: &str) -> Option<PathBuf> {
        rfd::FileDialog::new().set_title(title).pick_folder()
    }
}

/// Window options for the station (1280×800 unless given, at least 1024×600, titled).
#[must_use]
pub fn native_options(size: Option<[f32; 2]>) -> eframe::NativeOptions {
    eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_inner_size(size.unwrap_or([1280.0, 800.0]))
            .with_min_inner_size([1024.0, 600.0])
            .with_title("topside — VideoRay Pro 4 station"),
        ..eframe::NativeOptions::default()
    }
}

/// Opens the station window and runs until it is closed.
///
/// # Errors
/// eframe's error when the window cannot be created.
pub fn run_native(app: StationApp) -> Result<(), eframe::Error> {
    run_native_sized(app, None)
}

/// [`run_native`] with a window size (points).
///
/// # Errors
/// eframe's error when the window cannot be created.
pub fn run_native_sized(app: StationApp, size: Option<[f32; 2]>) -> Result<(), eframe::Error> {
    eframe::run_native(
        "topside",
        native_options(size),
        Box::new(move |cc| {
            theme::apply(&cc.egui_ctx);
            Ok(Box::new(app))
        }),
    )
}
