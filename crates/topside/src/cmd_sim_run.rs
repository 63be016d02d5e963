//! `topside sim run --model M --data F.csv --out OUT.csv [--shooting-s W]`: runs a model on
//! a measured run's thrust commands (zero-order hold, the measurement CSV's timing rule)
//! from its measured initial state and writes the prediction.
//!
//! `M` is `model1`, `model2`, `model3` or a model the lab saved (`topside lab add --save
//! FILE.toml`), so an extended model simulates like any other. `F` is a measurement CSV,
//! an MCAP session or a BlueROV2 tank CSV. The output has `time_s`, the commands, and one
//! column per channel the model predicts (`depth_m`, `heading_deg`, … in the measurement
//! CSV's units), numbers in the shortest form that reads back exactly, written row by row;
//! the per-channel fit is printed.

use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context as _;
use clap::Args;
use rov_dynamics::models::Channel;
use rov_lab::calibrate::View;
use rov_lab::metrics::channel_metrics;
use rov_lab::sim::simulate_run;
use rov_types::number::push_f64;

/// `topside sim run`
#[derive(Debug, Args)]
pub struct RunArgs {
    /// model1, model2, model3, or a saved extended model (TOML).
    #[arg(long)]
    model: String,
    /// Measured run whose commands drive the model.
    #[arg(long)]
    data: PathBuf,
    /// Log map (TOML) for --data (any supported log format).
    #[arg(long, value_name = "MAP.toml")]
    map: Option<PathBuf>,
    /// Output CSV.
    #[arg(long)]
    out: PathBuf,
    /// Reset the model to the measured state every W seconds (multiple shooting) instead
    /// of one free run.
    #[arg(long, value_name = "W")]
    shooting_s: Option<f64>,
}

/// Column name and unit suffix of a channel in the output.
pub(crate) fn column(ch: Channel) -> String {
    let unit = match ch {
        Channel::Depth | Channel::North | Channel::East => "m",
        Channel::Heading | Channel::Pitch | Channel::Roll => "deg",
        Channel::Surge | Channel::Sway | Channel::Heave => "mps",
        Channel::RollRate | Channel::PitchRate | Channel::YawRate => "dps",
    };
    format!("{}_{unit}", rov_lab::data::ch_name(ch))
}

/// Runs `topside sim run`.
pub fn run(args: RunArgs) -> anyhow::Result<ExitCode> {
    let model = crate::cmd_lab::load_model_arg(&args.model)?;
    let map = crate::cmd_lab::load_map(args.map.as_deref())?;
    let run = crate::cmd_lab::load_run(&args.data, map.as_ref())?;
    let view = match args.shooting_s {
        Some(w) if w.is_finite() && w > 0.0 => View::Shooting(w),
        Some(w) => anyhow::bail!("--shooting-s {w} must be a positive number of seconds"),
        None => View::FreeRun,
    };
    let pred = simulate_run(&model, &run, &view.resets(&run))?;
    let chans: Vec<Channel> = Channel::ALL
        .iter()
        .copied()
        .filter(|c| pred.channel(*c).is_some())
        .collect();
    let file = std::fs::File::create(&args.out)
        .with_context(|| format!("writing {}", args.out.display()))?;
    let mut out = std::io::BufWriter::with_capacity(1 << 20, file);
    let mut line = String::from("time_s,port_pct,starboard_pct,vertical_pct");
    for c in &chans {
        line.push(',');
        line.push_str(&column(*c));
    }
    line.push('\n');
    let werr = |e: std::io::Error| anyhow::anyhow!("writing {}: {e}", args.out.display());
    out.write_all(line.as_bytes()).map_err(werr)?;
    for (k, (t, cmd)) in run.t.iter().zip(&run.cmd).enumerate() {
        line.clear();
        for (i, x) in [*t, cmd.port, cmd.starboard, cmd.vertical]
            .into_iter()
            .enumerate()
        {
            if i > 0 {
                line.push(',');
            }
            push_f64(&mut line, x);
        }
        for c in &chans {
            let v = pred
                .channel(*c)
                .and_then(|y| y.get(k))
                .copied()
                .unwrap_or(f64::NAN);
            line.push(',');
            push_f64(&mut line, v);
        }
        line.push('\n');
        out.write_all(line.as_bytes()).map_err(werr)?;
    }
    out.flush().map_err(werr)?;
    println!(
        "{} on {} ({} samples, {:.1} s, {}) -> {}",
        args.model,
        args.data.display(),
        run.len(),
        run.t.last().copied().unwrap_or(0.0) - run.t.first().copied().unwrap_or(0.0),
        match view {
            View::FreeRun => "free run".to_string(),
            View::Shooting(w) => format!("reset every {w} s"),
            _ => "k-step".to_string(),
        },
        args.out.display()
    );
    for c in &chans {
        if let Some(m) = channel_metrics(&run, &pred, *c) {
            println!(
                "  {:<10} fit {:>7} %  RMSE {:.4}",
                rov_lab::data::ch_name(*c),
                m.fit_pct.map_or("n/a".into(), |f| format!("{f:.1}")),
                m.rmse
            );
        }
    }
    Ok(ExitCode::SUCCESS)
}
