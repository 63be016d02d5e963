//! `topside replay FILE.mcap --headless [--speed X] [--model M]`: replay a session without
//! the GUI and print a summary.
//!
//! The session runs through the sans-IO player (`rov_session::Playback`) on virtual wall
//! time in 20 ms frames at the given speed (0.1–50×), every message decoded by its topic
//! as the station pipeline would; then the recorded thrust commands drive the chosen
//! model (default model3). Output: one JSON object on stdout with `file`, `complete`,
//! `damage`, `duration_s`, `messages`, `speed`, `replay_wall_s` (the wall time the replay
//! takes at that speed), `channels` (topic, encoding, schema, count, decode errors),
//! `model` and `fit` (per channel: `predicted`, `samples`, `fit_pct`, `rmse`), and
//! `warnings`; the same in words on stderr. A truncated file is replayed as far as it is
//! intact, with a warning.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use rov_session::{Playback, ResimOptions, resimulate};
use serde_json::json;

use crate::cmd_export::open_with_warnings;
use crate::cmd_session::damage_json;

/// Arguments of `topside replay`.
#[derive(Debug, Args)]
pub struct ReplayArgs {
    /// The session file (a truncated recording is accepted, with a warning).
    #[arg(value_name = "FILE.mcap")]
    pub file: PathBuf,
    /// Replay without the GUI and print a summary (the GUI replay is not built yet).
    #[arg(long)]
    pub headless: bool,
    /// Playback speed, 0.1–50 (clamped).
    #[arg(long, default_value_t = 1.0)]
    pub speed: f64,
    /// Model the recorded commands drive: model1, model2 or model3.
    #[arg(long, default_value = "model3")]
    pub model: String,
}

/// Wall-time frame of the headless player, s.
const FRAME_S: f64 = 0.02;

pub fn run(args: ReplayArgs) -> anyhow::Result<ExitCode> {
    if !args.headless {
        anyhow::bail!("the replay GUI is not built yet; use --headless");
    }
    let model = rov_dynamics::load_default_model(&args.model)?;
    let session = open_with_warnings(&args.file)?;

    // Playback on virtual wall time: every message once, decoded by its topic.
    let mut player = Playback::new(&session);
    let speed = player.set_speed(args.speed);
    if speed != args.speed {
        eprintln!("warning: speed {} clamped to {speed}", args.speed);
    }
    let mut decode_errors: BTreeMap<String, u64> = BTreeMap::new();
    let mut first_error: Option<String> = None;
    let mut frames = 0u64;
    player.play();
    while player.is_playing() {
        for m in player.advance_messages(FRAME_S) {
            if let Err(e) = m.decode_any() {
                *decode_errors.entry(m.topic.to_string()).or_insert(0) += 1;
                first_error.get_or_insert_with(|| e.to_string());
            }
        }
        frames += 1;
    }
    if let Some(e) = &first_error {
        eprintln!("warning: some messages do not decode, e.g. {e}");
    }
    let replay_wall_s = frames as f64 * FRAME_S;

    let channels: Vec<serde_json::Value> = session
        .topics()
        .iter()
        .map(|t| {
            json!({
                "topic": t.topic,
                "encoding": t.encoding,
                "schema": t.schema_name,
                "known": t.known.is_some(),
                "count": t.count,
                "decode_errors": decode_errors.get(&t.topic).copied().unwrap_or(0),
            })
        })
        .collect();

    let resim = resimulate(&session, model.as_ref(), &ResimOptions::default());
    let (fit, fit_error, mut warnings) = match &resim {
        Ok(r) => {
            let fits: Vec<serde_json::Value> = r
                .fits
                .iter()
                .map(|f| {
                    json!({
                        "channel": f.name,
                        "predicted": f.predicted,
                        "samples": f.samples,
                        "fit_pct": f.fit_pct,
                        "rmse": f.rmse,
                    })
                })
                .collect();
            (Some(fits), None, r.warnings.clone())
        }
        Err(e) => {
            eprintln!("warning: no model fit: {e}");
            (None, Some(e.to_string()), Vec::new())
        }
    };
    let mut all_warnings = session.warnings.clone();
    all_warnings.append(&mut warnings);

    let out = json!({
        "file": args.file,
        "complete": session.is_complete(),
        "damage": damage_json(session.damage()),
        "duration_s": session.duration_s(),
        "messages": session.len(),
        "speed": speed,
        "replay_wall_s": replay_wall_s,
        "channels": channels,
        "model": args.model,
        "fit": fit,
        "fit_error": fit_error,
        "warnings": all_warnings,
    });
    println!("{out}");

    eprintln!(
        "{}: {:.3} s, {} messages{}; replay at {speed}x takes {replay_wall_s:.2} s",
        args.file.display(),
        session.duration_s(),
        session.len(),
        if session.is_complete() {
            ""
        } else {
            " (damaged: intact part only)"
        }
    );
    eprintln!("{:<22} {:>9}  encoding", "channel", "messages");
    for t in session.topics() {
        eprintln!(
            "{:<22} {:>9}  {}{}",
            t.topic,
            t.count,
            t.encoding,
            if t.known.is_some() {
                ""
            } else {
                " (unknown topic)"
            }
        );
    }
    if let Ok(r) = &resim {
        eprintln!(
            "fit of {} (fit % = 100 (1 - |y - yhat| / |y - mean y|)):",
            args.model
        );
        for f in &r.fits {
            match (f.predicted, f.fit_pct, f.rmse) {
                (false, _, _) => eprintln!("  {:<14} not predicted by {}", f.name, args.model),
                (true, Some(fit), Some(rmse)) => {
                    eprintln!(
                        "  {:<14} fit {fit:7.2} %  RMSE {rmse:.4} ({} samples)",
                        f.name, f.samples
                    )
                }
                (true, None, Some(rmse)) => {
                    eprintln!(
                        "  {:<14} fit undefined (constant measurement)  RMSE {rmse:.4}",
                        f.name
                    )
                }
                (true, _, None) => eprintln!("  {:<14} no finite samples to compare", f.name),
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}
