//! `topside`: the VideoRay Pro 4 control station.
//!
//! With no arguments it opens the station on the built-in simulated vehicle. The
//! subcommands give headless access for scripts and tests; each lives in its own module.
//! Settings: `--config PATH`, else the user's file in the platform's configuration
//! directory, else built in ([`config_file`]); the binary needs no file beside it.

mod cmd_export;
mod cmd_export_video;
mod cmd_hold;
mod cmd_import;
mod cmd_lab;
mod cmd_lab_cv;
mod cmd_lab_watch;
mod cmd_proto;
mod cmd_record;
mod cmd_replay;
mod cmd_session;
mod cmd_sim;
mod cmd_sim_paper;
mod cmd_sim_reference;
mod cmd_sim_run;
mod cmd_station;
mod cmd_vehicle;
mod config_file;
mod foxglove_ws;
mod lab_progress;

use clap::{Parser, Subcommand};

#[derive(Debug, Parser)]
#[command(
    name = "topside",
    version,
    about = "Control station for the VideoRay Pro 4 ROV"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    /// Fly a real Pro 4 on this serial port (default: the built-in simulated vehicle).
    #[arg(long, value_name = "PATH")]
    port: Option<String>,
    /// Station settings file (default: station.toml in the platform's configuration
    /// directory, e.g. ~/.config/topside/ on Linux, else the built-in defaults).
    #[arg(long, value_name = "PATH", global = true)]
    config: Option<std::path::PathBuf>,
    /// Start the station without recording (by default every session is recorded to
    /// ./recordings/).
    #[arg(long)]
    no_record: bool,
    /// Directory for the station's recordings.
    #[arg(long, value_name = "DIR", default_value = "recordings")]
    recordings: std::path::PathBuf,
    /// Serve the station's channels live to Foxglove on ADDR:PORT (e.g. 127.0.0.1:8765;
    /// the Settings tab and `[foxglove]` in the settings file do the same).
    #[arg(long, value_name = "ADDR:PORT")]
    foxglove_ws: Option<String>,
    /// Test hook: screenshot the window to this PNG, then exit.
    #[arg(long, value_name = "PATH", hide = true)]
    screenshot: Option<std::path::PathBuf>,
    /// Test hook: seconds to wait before the screenshot.
    #[arg(long, value_name = "S", hide = true, default_value_t = 3.0)]
    screenshot_after_s: f64,
    /// The camera: sim (default with the simulated vehicle), none, test (a GStreamer
    /// test pattern), v4l2:/dev/videoN, a URI (rtsp://, udp://[HOST]:PORT, file:///) or
    /// a GStreamer pipeline ending in a raw-video element. With --port the default is
    /// the first capture device found, else none. Overrides `[video] source`.
    #[arg(long, value_name = "SOURCE")]
    video: Option<String>,
    /// The autopilot's model: model1, model2, model3 or FILE.toml (a model the lab saved
    /// with `lab add --save`: feedforward, observer and thrust inversion from it).
    /// Overrides `[autopilot] model` in the settings file.
    #[arg(long, value_name = "MODEL|FILE.toml", value_parser = parse_model_id)]
    model: Option<rov_types::ModelId>,
    /// The simulated vehicle's dynamics: any model file `--model` accepts (effects
    /// included), behind the same wire protocol and sensors. Default: model3 as shipped.
    #[arg(long, value_name = "FILE.toml")]
    vehicle: Option<std::path::PathBuf>,
    /// Inject a fault into the simulated vehicle (repeatable; training and tests):
    /// KIND[:TARGET][:SIZE]@T_S, e.g. thrust-loss:port:0.4@300, buoyancy:3@200,
    /// drag:2.5@100, snag:15@250, depth-sensor:stuck@120, compass:25@90 (T_S: seconds
    /// of the simulator's clock). The Settings tab injects them live too.
    #[arg(long = "fault", value_name = "SPEC", value_parser = parse_fault)]
    faults: Vec<rov_sim::FaultSpec>,
    /// Window size, WIDTHxHEIGHT (default 1280x800).
    #[arg(long, value_name = "WxH", hide = true)]
    window_size: Option<String>,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Encode and decode Pro 4 tether-protocol frames.
    Proto(cmd_proto::ProtoArgs),
    /// Run the simulator: reproduce the paper's experiments or a Fossen reference case.
    Sim(cmd_sim::SimArgs),
    /// Depth and heading hold through the mock link and the simulated vehicle (virtual time).
    Hold(cmd_hold::HoldArgs),
    /// Replay a recorded session headlessly and fit a model to it.
    Replay(cmd_replay::ReplayArgs),
    /// Export a session: measurement CSV (plus every decoded channel) and/or camera video (MP4 + .ass).
    Export(cmd_export::ExportArgs),
    /// Import a measurement CSV as a session.
    Import(cmd_import::ImportArgs),
    /// Session file tools (recover a truncated recording).
    Session(cmd_session::SessionArgs),
    /// Record a headless simulated dive to an MCAP session (real time, or --fast).
    Record(cmd_record::RecordArgs),
    /// Model lab: compare a model with measurements, diagnose and add missing effects.
    Lab(cmd_lab::LabArgs),
    /// Vehicle files: a commented template for a frame (`new`), and a check of a file's
    /// statics, mixing and signs, against a log too (`check`).
    Vehicle(cmd_vehicle::VehicleArgs),
}

/// A `--fault` argument ([`rov_sim::FaultSpec`]'s grammar; the error says where it is
/// wrong).
pub fn parse_fault(s: &str) -> Result<rov_sim::FaultSpec, String> {
    rov_sim::FaultSpec::parse(s).map_err(|e| e.to_string())
}

/// A model argument, parsed as every model name is ([`rov_types::ModelId`]).
pub fn parse_model_id(s: &str) -> Result<rov_types::ModelId, String> {
    s.parse::<rov_types::ModelId>().map_err(|e| e.to_string())
}

/// The libraries' warnings (`tracing::warn!`: errors with no place on screen) go to
/// stderr; `RUST_LOG` chooses more or less (default: warnings).
fn init_logging() {
    let filter = match tracing_subscriber::EnvFilter::try_from_default_env() {
        Ok(f) => f,
        Err(e) => {
            if std::env::var_os("RUST_LOG").is_some() {
                eprintln!("warning: RUST_LOG: {e}; showing warnings");
            }
            tracing_subscriber::EnvFilter::new("warn")
        }
    };
    let installed = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_target(false)
        .try_init();
    if let Err(e) = installed {
        eprintln!("warning: no log output: {e}");
    }
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    init_logging();
    let result = match cli.command {
        Some(Command::Proto(args)) => cmd_proto::run(args),
        Some(Command::Sim(args)) => cmd_sim::run(args),
        Some(Command::Hold(args)) => cmd_hold::run(args),
        Some(Command::Replay(args)) => cmd_replay::run(args),
        Some(Command::Export(args)) => cmd_export::run(args),
        Some(Command::Import(args)) => cmd_import::run(args),
        Some(Command::Session(args)) => cmd_session::run(args),
        Some(Command::Record(args)) => cmd_record::run(args, cli.config.as_deref()),
        Some(Command::Lab(args)) => cmd_lab::run(args),
        Some(Command::Vehicle(args)) => cmd_vehicle::run(args),
        None => cmd_station::run_station(
            cli.port,
            cli.video,
            cmd_station::StationSources {
                config: cli.config.as_deref(),
                model: cli.model,
                vehicle: cli.vehicle,
                faults: cli.faults,
            },
            (!cli.no_record).then_some(cli.recordings),
            cli.screenshot.map(|p| (p, cli.screenshot_after_s)),
            cli.window_size,
            cli.foxglove_ws,
        ),
    };
    match result {
        Ok(code) => code,
        Err(err) => {
            eprintln!("error: {err:#}");
            std::process::ExitCode::from(2)
        }
    }
}
