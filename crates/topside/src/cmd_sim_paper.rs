//! `topside sim paper --out DIR`: seed 000's open-loop experiments through all three models.
//!
//! For each experiment the simulated vehicle (the "measurement", standing in for the paper's
//! tank runs) and the three published models run on the same thrust schedule. The command
//! writes, per experiment:
//! * `NAME.csv`: the simulated measurement in the measurement CSV format (20 Hz, sensor noise
//!   and quantisation as the Pro 4 reports them);
//! * `NAME.model1.csv` … `NAME.model3.csv`: each model's free-run prediction from the
//!   measured initial state (channels a model does not predict are `nan`);
//! * `NAME.png`: thrust, depth, heading, pitch and roll against time, the measurement in blue
//!   and the models in the paper's colours (purple, green, black);
//!
//! and `summary.json` with the RMSE of each model per channel and experiment.
//!
//! The simulated vehicle (`--truth paper`, the default) is model3's 6-DOF plant with the two
//! effects the paper measured and none of the models has: weaker reverse thrust (reverse /
//! forward ratios 0.39 horizontal and 0.63 vertical, the Pro III values of parameters.md) and
//! a vertical-thruster moment arm (the thrust line 10 mm forward of the CG line, chosen so that
//! ±60 % vertical thrust pitches the vehicle about −10°/+6°, as the paper's figure 5 reports).
//! `--truth nominal` uses model3 exactly as configured.

use std::fs;
use std::path::Path;

use anyhow::Context;
use rov_dynamics::models::model3::{Model3, Model3Params};
use rov_dynamics::thrusters::{QuadraticThrustMap, ThrustMap, ThrustPair, ThrusterGeometry};
use rov_dynamics::{VehicleModel, load_model};
use rov_plot::measurement::comparison_figure;
use rov_sim::{SimConfig, predict_measured, run_schedule};
use rov_types::ParamFile;
use rov_types::measurement::MeasurementSeries;

use crate::cmd_sim::{PaperArgs, TruthArg};

/// Sample period of the written measurement (the paper's telemetry is of this order).
const SAMPLE_PERIOD_S: f64 = 0.05;
/// Largest integration step of the model predictions.
const MODEL_DT_MAX_S: f64 = 0.01;
/// Reverse/forward thrust ratios of the "paper" vehicle (parameters.md, Pro III values).
const REVERSE_RATIO_HORIZONTAL: f64 = 0.39;
const REVERSE_RATIO_VERTICAL: f64 = 0.63;
/// Vertical thrust line forward of the CG line in the "paper" vehicle, m.
const VERTICAL_ARM_X_M: f64 = 0.010;

const MODELS: [&str; 3] = ["model1", "model2", "model3"];

fn scaled(pair: ThrustPair, ratio: f64) -> ThrustPair {
    ThrustPair {
        linear_n: pair.linear_n * ratio,
        quadratic_n: pair.quadratic_n * ratio,
    }
}

fn with_reverse_ratio(map: ThrustMap, ratio: f64) -> ThrustMap {
    match map {
        ThrustMap::Quadratic(q) => ThrustMap::Quadratic(QuadraticThrustMap {
            forward: q.forward,
            reverse: scaled(q.forward, ratio),
        }),
        other => other,
    }
}

/// model3's parameters with the paper-observed effects added.
fn paper_vehicle(mut params: Model3Params) -> anyhow::Result<Box<dyn VehicleModel>> {
    let t = &mut params.thrusters;
    t.port.map = with_reverse_ratio(t.port.map, REVERSE_RATIO_HORIZONTAL);
    t.starboard.map = with_reverse_ratio(t.starboard.map, REVERSE_RATIO_HORIZONTAL);
    t.vertical.map = with_reverse_ratio(t.vertical.map, REVERSE_RATIO_VERTICAL);
    let g = t.vertical.geometry;
    let mut pos = g.position_m();
    pos.x = VERTICAL_ARM_X_M;
    t.vertical.geometry = ThrusterGeometry::new(pos, g.direction())?;
    Ok(Box::new(Model3::new(params)?))
}

/// A model's parameter file: from `dir`, or the built-in one.
fn read_model_text(dir: Option<&Path>, name: &str) -> anyhow::Result<(String, String)> {
    let Some(dir) = dir else {
        let text = rov_dynamics::models::default_model_text(name)
            .with_context(|| format!("no built-in model {name}"))?;
        return Ok((
            text.to_string(),
            format!("built-in config/models/{name}.toml"),
        ));
    };
    let path = dir.join(format!("{name}.toml"));
    let text = fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    Ok((text, path.display().to_string()))
}

fn rmse(
    a: &MeasurementSeries,
    b: &MeasurementSeries,
    pick: fn(&rov_types::MeasurementRow) -> f64,
    wrap: bool,
) -> Option<f64> {
    let xs: Vec<f64> = a.rows.iter().map(pick).collect();
    let ys: Vec<f64> = b.rows.iter().map(pick).collect();
    rov_types::fit::rmse(&xs, &ys, rov_types::fit::ErrorKind::angular_if(wrap))
}

pub fn run(args: PaperArgs) -> anyhow::Result<std::process::ExitCode> {
    fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let mut models = Vec::new();
    for name in MODELS {
        let (text, label) = read_model_text(args.models.as_deref(), name)?;
        models.push((name, load_model(name, &text, &label)?));
    }
    let (m3_text, m3_label) = read_model_text(args.models.as_deref(), "model3")?;
    let m3_params = Model3Params::from_params(&ParamFile::parse(&m3_text, &m3_label, true)?)?;
    let truth: Box<dyn VehicleModel> = match args.truth {
        TruthArg::Paper => paper_vehicle(m3_params)?,
        TruthArg::Nominal => Box::new(Model3::new(m3_params)?),
    };

    let mut summary = serde_json::Map::new();
    for exp in rov_sim::experiments()? {
        let mut config = SimConfig::with_model(truth.clone_box());
        config.initial = rov_dynamics::InitialConditions::at_rest(2.0, 90.0);
        let measured = run_schedule(config, args.seed, &exp.schedule, SAMPLE_PERIOD_S)
            .with_context(|| format!("simulating {}", exp.name))?;
        let csv_path = args.out.join(format!("{}.csv", exp.name));
        fs::write(&csv_path, measured.to_csv())
            .with_context(|| format!("writing {}", csv_path.display()))?;

        let mut predictions = Vec::new();
        for (name, model) in &models {
            let pred = predict_measured(model.as_ref(), &measured, MODEL_DT_MAX_S)
                .with_context(|| format!("{name} on {}", exp.name))?;
            let path = args.out.join(format!("{}.{name}.csv", exp.name));
            fs::write(&path, pred.to_csv())
                .with_context(|| format!("writing {}", path.display()))?;
            predictions.push((*name, pred));
        }

        let refs: Vec<(&str, &MeasurementSeries)> =
            predictions.iter().map(|(n, p)| (*n, p)).collect();
        let short = exp
            .description
            .split(" (")
            .next()
            .unwrap_or(exp.description);
        let title = format!("{}: {short}", exp.name);
        let png = comparison_figure(&title, &measured, &refs).render_png()?;
        let png_path = args.out.join(format!("{}.png", exp.name));
        fs::write(&png_path, png).with_context(|| format!("writing {}", png_path.display()))?;

        let mut per_model = serde_json::Map::new();
        for (name, pred) in &predictions {
            let entry = serde_json::json!({
                "depth_rmse_m": rmse(&measured, pred, |r| r.depth_m, false),
                "heading_rmse_deg": rmse(&measured, pred, |r| r.heading_deg, true),
                "pitch_rmse_deg": rmse(&measured, pred, |r| r.pitch_deg, false),
                "roll_rmse_deg": rmse(&measured, pred, |r| r.roll_deg, false),
            });
            per_model.insert((*name).to_string(), entry);
        }
        summary.insert(exp.name.to_string(), serde_json::Value::Object(per_model));
        eprintln!("wrote {} (+ CSVs)", png_path.display());
    }
    let summary = serde_json::Value::Object(summary);
    let text = serde_json::to_string_pretty(&summary)?;
    fs::write(args.out.join("summary.json"), &text)?;
    println!("{text}");
    Ok(std::process::ExitCode::SUCCESS)
}
