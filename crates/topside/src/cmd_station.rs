//! `topside` with no subcommand: the station window.
//!
//! * No arguments: the simulated Pro 4, in-process.
//! * `--port PATH`: a real Pro 4 on a serial port (if the port does not open, the window
//!   still opens, on the Connection tab, with the error shown).
//! * Hidden `--screenshot PATH --screenshot-after-s N`: after N seconds the window takes a
//!   screenshot of itself (eframe viewport screenshot), saves it as PNG and closes; the
//!   exit status says whether the PNG was written (used by the Xvfb test).
//!
//! * `--video SOURCE`: the camera (see `rov_station::runtime::video`); default the
//!   `[video] source` of the settings (`auto`: the simulator's camera with the simulated
//!   vehicle, the first capture device with `--port`, else none). A source that does not
//!   start never stops the window from opening: the Fly view says NO VIDEO with the
//!   source and what is missing, and so does stderr.
//!
//! The settings (control, alarms, the pilot's `[station]` table, stick shaping and the
//! gamepad map) come from `--config PATH`, else the user's `station.toml` in the
//! platform's configuration directory, else the built-in defaults (see
//! [`crate::config_file`]); the Settings and Gamepad pages save into the file read, or
//! create the user's file. Every session is recorded from the
//! moment the station starts, to `./recordings/session-<unix time>.mcap` (`--recordings DIR` elsewhere; REC
//! stops and restarts it; `--no-record` starts without recording).
//! * `--foxglove-ws ADDR:PORT` (or `[foxglove] enabled = true`): the live Foxglove server
//!   (`rov_station::runtime::foxglove_live`); a bad address is a warning naming it, and
//!   the window opens without the server.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::Ordering;

use anyhow::Context as _;
use rov_gui::{RealBackend, ScreenshotRequest, StationApp, Tab};
use rov_station::runtime::settings::{self, FoxgloveSettings, StationSettings};
use rov_station::runtime::{Connection, Runtime, RuntimeConfig};

/// The runtime settings (see [`crate::config_file`]), on the given port or the
/// simulator, and the `[foxglove]` settings, with the file's name for messages. Shared
/// with `topside record`.
pub fn config_and_foxglove(
    port: Option<String>,
    config: Option<&std::path::Path>,
) -> anyhow::Result<(RuntimeConfig, FoxgloveSettings, String)> {
    let (cfg, _, path, fox) = config_all(port, config)?;
    Ok((cfg, fox, path.display().to_string()))
}

/// The runtime settings, the pilot's `[station]` settings, where the Settings tab saves
/// and `[foxglove]`: control, alarms, stick shaping and the gamepad map come from the
/// same file, checked with the file, key, value and range named on an error.
fn config_all(
    port: Option<String>,
    config: Option<&std::path::Path>,
) -> anyhow::Result<(RuntimeConfig, StationSettings, PathBuf, FoxgloveSettings)> {
    let user = crate::config_file::user_config_path();
    let loaded = crate::config_file::load(config, user.as_deref())?;
    let label = loaded.path.as_ref().map_or_else(
        || "built-in station.toml".to_string(),
        |p| p.display().to_string(),
    );
    if let Some(p) = &loaded.path {
        eprintln!("settings from {}", p.display());
    }
    let pilot =
        settings::load_all(&loaded.text, &label).with_context(|| format!("reading {label}"))?;
    let (alarms, station) = (pilot.alarms, pilot.station);
    // `[autopilot] model`: a relative file is taken from the settings file's folder.
    let autopilot_id = pilot
        .autopilot
        .model
        .clone()
        .map(|id| match (id, &loaded.path) {
            (rov_types::ModelId::File(p), Some(cfg_path)) if p.is_relative() => {
                rov_types::ModelId::File(
                    cfg_path.parent().map_or_else(|| p.clone(), |d| d.join(&p)),
                )
            }
            (id, _) => id,
        });
    let mut sim_faults = rov_station::runtime::SimFaults::none();
    sim_faults.drop_reply = station.sim_link_errors_pct / 100.0;
    let save_to = loaded
        .path
        .clone()
        .or(user)
        .unwrap_or_else(|| PathBuf::from("station.toml"));
    let mut control = loaded.control;
    let mut autopilot_model = None;
    match &autopilot_id {
        Some(rov_types::ModelId::Base(b)) => control.feedforward_model = *b,
        Some(id @ rov_types::ModelId::File(_)) => {
            autopilot_model = crate::cmd_hold::autopilot_model(id)
                .with_context(|| format!("{label}: [autopilot] model"))?;
        }
        None => {}
    }
    Ok((
        RuntimeConfig {
            connection: port.map_or(Connection::Sim, Connection::Serial),
            control,
            autopilot_model,
            config_toml: loaded.text,
            alarms,
            sim_faults,
            shaping: pilot.shaping,
            pad_map: pilot.pad,
            video: pilot.video,
            ..RuntimeConfig::default()
        },
        station,
        save_to,
        pilot.foxglove,
    ))
}

/// Where the window's settings and models come from: `--config`, `--model`, `--vehicle`.
#[derive(Debug, Default)]
pub struct StationSources<'a> {
    /// The settings file.
    pub config: Option<&'a std::path::Path>,
    /// The autopilot's model.
    pub model: Option<rov_types::ModelId>,
    /// The simulated vehicle's model file.
    pub vehicle: Option<PathBuf>,
    /// Faults the simulated vehicle suffers (`--fault`).
    pub faults: Vec<rov_sim::FaultSpec>,
}

/// `--model` and `--vehicle` on top of the settings: the autopilot's model (a shipped
/// one by name, or a model file's plant) and the simulated vehicle's dynamics (any model
/// file). Both are loaded and checked here, before a station starts or anything is armed;
/// an error names the file, key, value and allowed range.
pub fn apply_models(
    cfg: &mut RuntimeConfig,
    model: Option<&rov_types::ModelId>,
    vehicle: Option<&std::path::Path>,
) -> anyhow::Result<()> {
    match model {
        Some(rov_types::ModelId::Base(b)) => {
            cfg.control.feedforward_model = *b;
            cfg.autopilot_model = None;
        }
        Some(id @ rov_types::ModelId::File(path)) => {
            // One load: the autopilot's plant and the model watch's model (the lab's
            // reading, effects and terms included) are the same model.
            let model = crate::cmd_lab::load_model_id(id, "--model")?;
            cfg.autopilot_model = Some(
                rov_station::AutopilotModel::from_vehicle_model(
                    &path.display().to_string(),
                    &model,
                )
                .context("--model")?,
            );
            cfg.watch_model = Some(model);
        }
        None => {}
    }
    if let Some(path) = vehicle {
        let (label, model) = crate::cmd_hold::load_model_file(path, "--vehicle")?;
        cfg.sim_vehicle = Some(rov_station::VehicleDynamics { label, model });
    }
    Ok(())
}

/// "1024x600" → [1024, 600] (at least 1024×600, at most 7680×4320).
fn parse_size(s: &str) -> Option<[f32; 2]> {
    let (w, h) = s.split_once('x')?;
    let (w, h) = (w.trim().parse::<u32>().ok()?, h.trim().parse::<u32>().ok()?);
    ((1024..=7680).contains(&w) && (600..=4320).contains(&h)).then_some([w as f32, h as f32])
}

/// Opens the station window; see the module docs.
pub fn run_station(
    port: Option<String>,
    video: Option<String>,
    settings: StationSources<'_>,
    record_to: Option<PathBuf>,
    screenshot: Option<(PathBuf, f64)>,
    window_size: Option<String>,
    foxglove_ws: Option<String>,
) -> anyhow::Result<ExitCode> {
    let config_path = settings.config;
    let size = match window_size.as_deref().map(parse_size) {
        Some(Some(s)) => Some(s),
        Some(None) => anyhow::bail!(
            "--window-size {}: expected WIDTHxHEIGHT, at least 1024x600",
            window_size.unwrap_or_default()
        ),
        None => None,
    };
    let explicit_port = port.is_some();
    let (mut cfg, station, save_to, mut foxglove) = config_all(port, config_path)?;
    apply_models(
        &mut cfg,
        settings.model.as_ref(),
        settings.vehicle.as_deref(),
    )?;
    if !explicit_port && !station.serial_port.trim().is_empty() {
        cfg.connection = Connection::Serial(station.serial_port.trim().to_string());
    }
    if !settings.faults.is_empty() && cfg.connection != Connection::Sim {
        anyhow::bail!(
            "--fault injects faults into the built-in simulated vehicle; this station flies a real vehicle ({:?})",
            cfg.connection
        );
    }
    cfg.vehicle_faults.clone_from(&settings.faults);
    if let Some(v) = video {
        cfg.video.source = v;
    }
    let recordings = record_to
        .clone()
        .unwrap_or_else(|| PathBuf::from("recordings"));
    cfg.recordings_dir = Some(recordings.clone());
    let backend = RealBackend::new(cfg.clone(), recordings);
    let (live, error) = match Runtime::start(cfg.clone()) {
        Ok(h) => {
            if let Some(e) = h.video().and_then(|v| v.status().error) {
                eprintln!("warning: {e}; the station runs without video");
            }
            (Some(h), None)
        }
        Err(e) => (None, Some(format!("cannot start the station: {e}"))),
    };
    // Every connection records from its start (the app starts it, with the same file
    // naming as the REC button), unless --no-record.
    // The live Foxglove server: a bad address is shown in the Settings tab and on stderr;
    // the station opens anyway.
    let flag = foxglove_ws.is_some();
    let live_server = match crate::foxglove_ws::wanted(foxglove_ws.as_deref(), &mut foxglove) {
        Some(addr) => {
            crate::foxglove_ws::start(&addr, flag, &save_to.display().to_string()).map(Some)
        }
        None => Ok(None),
    };
    if let Err(e) = &live_server {
        eprintln!("warning: {e}");
    }
    let fox_error = live_server.as_ref().err().map(ToString::to_string);
    let mut app = StationApp::new(Box::new(backend), None)
        .with_record_on_connect(record_to.is_some() && station.record_on_connect)
        .with_settings(save_to, cfg.alarms, station)
        .with_gamepad(cfg.pad_map.clone(), cfg.shaping)
        .with_video_settings(cfg.video.clone())
        .with_foxglove(foxglove, live_server)
        .with_models_dir(crate::config_file::user_models_dir());
    app.connect_handle(live);
    if let Some(e) = fox_error {
        app.set_message(e);
    }
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
    rov_gui::run_native_sized(app, size)
        .map_err(|e| anyhow::anyhow!("cannot open the window: {e}"))?;
    match saved {
        Some(flag) if !flag.load(Ordering::Relaxed) => {
            eprintln!("error: the screenshot was not saved");
            Ok(ExitCode::from(1))
        }
        _ => Ok(ExitCode::SUCCESS),
    }
}
