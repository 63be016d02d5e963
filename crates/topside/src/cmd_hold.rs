//! `topside hold`: depth and heading hold closed through the mock link and the simulated
//! vehicle on virtual time; prints the step-response metrics of the true state.

use clap::{Args, ValueEnum};
use rov_control::{ModelChoice, TrackingProfile};
use rov_station::{AutopilotModel, Disturbance, HoldSpec, VehicleDynamics, run_hold};
use rov_types::ModelId;
use rov_types::angle::wrap_deg_360;

/// `--model`: parsed as every model name is ([`rov_types::ModelId`]).
fn parse_model(s: &str) -> Result<ModelId, String> {
    s.parse::<ModelId>().map_err(|e| e.to_string())
}

/// A model file as a simulation model, through the one loader
/// ([`crate::cmd_lab::load_model_id`]): every file `lab add --save` writes and the shipped
/// parameter files (errors name `flag`, the file, key, value and range).
pub fn load_model_file(
    path: &std::path::Path,
    flag: &str,
) -> anyhow::Result<(String, Box<dyn rov_dynamics::VehicleModel>)> {
    let model = crate::cmd_lab::load_model_id(&ModelId::File(path.to_path_buf()), flag)?;
    Ok((path.display().to_string(), Box::new(model)))
}

/// The autopilot's model for `--model`: a shipped base (`None`, selected by name) or a
/// model file's plant, refused with the file named before anything runs.
pub fn autopilot_model(id: &ModelId) -> anyhow::Result<Option<AutopilotModel>> {
    match id {
        ModelId::Base(_) => Ok(None),
        ModelId::File(path) => {
            let (label, model) = load_model_file(path, "--model")?;
            Ok(Some(AutopilotModel::from_vehicle_model(
                &label,
                model.as_ref(),
            )?))
        }
    }
}

/// Disturbance on the simulated vehicle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum DisturbanceArg {
    /// Still water.
    None,
    /// Constant 0.3 m/s current toward north.
    Current,
    /// 0.8 N earth-fixed pull toward azimuth 135° at (−0.20, 0, −0.08) m.
    Tether,
}

/// Tracking profile.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ProfileArg {
    /// 130 s of depth and heading steps and ramps in both directions (table below).
    Survey,
}

/// On or off.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum OnOff {
    /// Enabled.
    On,
    /// Disabled.
    Off,
}

/// `topside hold --model M --depth-m D --heading-deg H --duration-s T [...] --json`
#[derive(Debug, Args)]
#[command(allow_negative_numbers = true, after_long_help = PROFILE_HELP)]
pub struct HoldArgs {
    /// The autopilot's model (feedforward; with a file also the observer and the
    /// feedback's thrust inversion): model1 (Enevoldsen et al. 2018), model2 (Arnesen
    /// 2016), model3 (Mai et al. 2017) or FILE.toml (a model the lab saved with `lab add
    /// --save`, or a shipped parameter file), whose effects (asymmetric reverse thrust,
    /// dead zone, lag, reaction torque) the autopilot inverts.
    #[arg(long, value_parser = parse_model, value_name = "MODEL|FILE.toml")]
    model: ModelId,
    /// Depth target, m (positive down).
    #[arg(long)]
    depth_m: f64,
    /// Heading target, degrees.
    #[arg(long)]
    heading_deg: f64,
    /// Run length after the holds engage, s (with --profile: extra hold time after the
    /// profile, may be 0).
    #[arg(long)]
    duration_s: f64,
    /// Fly a fixed tracking profile from --depth-m/--heading-deg instead of one step
    /// (the whole profile always runs; see the table in --help). --json then adds
    /// "tracking_rmse": {"depth_m", "heading_deg"} over the profile, and the step
    /// metrics describe the profile's final step.
    #[arg(long, value_enum)]
    profile: Option<ProfileArg>,
    /// Starting depth, m (default: 2 m shallower than the target, not above the surface;
    /// with --profile: the target).
    #[arg(long)]
    start_depth_m: Option<f64>,
    /// Starting heading, degrees (default: 90° off the target; with --profile: the
    /// target).
    #[arg(long)]
    start_heading_deg: Option<f64>,
    /// Disturbance.
    #[arg(long, value_enum, default_value_t = DisturbanceArg::None)]
    disturbance: DisturbanceArg,
    /// Turn the model feedforward off (PID only).
    #[arg(long)]
    no_feedforward: bool,
    /// Kalman observer on or off.
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    observer: OnOff,
    /// Seed of the simulated sensor noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// The simulated vehicle's dynamics: a model file (for example one the model lab
    /// extended and saved with `topside lab add --save`, or config/models/model3.toml).
    /// Default: model3 as configured.
    #[arg(long, value_name = "FILE.toml")]
    vehicle: Option<std::path::PathBuf>,
    /// Print the report as JSON on stdout.
    #[arg(long)]
    json: bool,
}

/// The `survey` profile, for `hold --help` (the same table as `rov_control::profile`).
const PROFILE_HELP: &str = "\
Tracking profile `survey` (--profile survey), 130 s, offsets from --depth-m/--heading-deg
(depth positive down, heading positive to starboard). Steps are quick S-shaped changes,
ramps run at a constant rate with 2 s blends; the reference is smooth (continuous rate and
acceleration) and the station types it every tick as a moving setpoint:

  t (s)     depth                       heading
  0-10      hold                        hold
  10-16     step +1.0 m (down)
  20-24                                 step +60 deg (starboard)
  30-50     ramp +2.0 m (down, 0.11 m/s)
  40-58                                 ramp -150 deg (port, 9.4 deg/s)
  62-70     step -1.5 m (up)
  72-76                                 step -60 deg (port)
  80-100    ramp -1.5 m (up, 0.083 m/s)
  84-104                                ramp +150 deg (starboard, 8.3 deg/s)
  110-116   step +1.0 m (down)          step +90 deg (starboard)
  116-130   hold                        hold

tracking_rmse compares the true depth and heading with this reference from engagement to
130 s; it is the same reference for every --model, so runs compare. --duration-s adds
hold time after the profile. The step metrics then describe the final step at 110 s.";

pub fn run(args: HoldArgs) -> anyhow::Result<std::process::ExitCode> {
    let base = match &args.model {
        ModelId::Base(b) => *b,
        ModelId::File(_) => ModelChoice::Model3,
    };
    let mut spec = HoldSpec::step(base, args.depth_m, args.heading_deg, args.duration_s);
    spec.autopilot_model = autopilot_model(&args.model)?;
    spec.profile = args.profile.map(|p| match p {
        ProfileArg::Survey => TrackingProfile::Survey,
    });
    let (default_start_depth_m, default_start_heading_deg) = if spec.profile.is_some() {
        (args.depth_m, wrap_deg_360(args.heading_deg))
    } else {
        (
            (args.depth_m - 2.0).max(0.0),
            wrap_deg_360(args.heading_deg - 90.0),
        )
    };
    spec.start_depth_m = args.start_depth_m.unwrap_or(default_start_depth_m);
    spec.start_heading_deg = args.start_heading_deg.unwrap_or(default_start_heading_deg);
    spec.disturbance = match args.disturbance {
        DisturbanceArg::None => Disturbance::None,
        DisturbanceArg::Current => Disturbance::Current,
        DisturbanceArg::Tether => Disturbance::Tether,
    };
    spec.feedforward = !args.no_feedforward;
    spec.observer = args.observer == OnOff::On;
    spec.seed = args.seed;
    if let Some(path) = &args.vehicle {
        let (label, model) = load_model_file(path, "--vehicle")?;
        spec.vehicle = Some(VehicleDynamics { label, model });
    }
    let (report, _trace) = run_hold(&spec)?;
    if args.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        let d = &report.depth;
        let h = &report.heading;
        let fmt = |s: Option<f64>| s.map_or("never".to_string(), |v| format!("{v:.2} s"));
        println!(
            "depth:   settle {}, overshoot {:.1} %, steady error {:.3} m, RMSE {:.3} m",
            fmt(d.settle_s),
            d.overshoot_pct,
            d.steady_error_m,
            d.rmse_m
        );
        println!(
            "heading: settle {}, overshoot {:.2} deg, steady error {:.2} deg, RMSE {:.2} deg",
            fmt(h.settle_s),
            h.overshoot_deg,
            h.steady_error_deg,
            h.rmse_deg
        );
        println!(
            "thrust saturated {:.1} % of ticks; observer RMSE depth {:.3} m, heading {:.2} deg",
            report.thrust.saturated_pct,
            report.observer.depth_rmse_m,
            report.observer.heading_rmse_deg
        );
        if let Some(t) = &report.tracking_rmse {
            println!(
                "tracking over the profile: depth RMSE {:.3} m, heading RMSE {:.2} deg",
                t.depth_m, t.heading_deg
            );
        }
    }
    Ok(std::process::ExitCode::SUCCESS)
}
