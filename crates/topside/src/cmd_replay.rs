//! `topside replay FILE.mcap --headless [--speed X] [--model M] [--check]`: a session's
//! summary without the GUI, optionally a model fit and a full check.
//!
//! * By default the summary comes from the file's index alone (the MCAP summary section:
//!   statistics, channels, chunk indexes), so it takes the same fraction of a second for an
//!   8-hour session as for a minute: `file`, `complete` (no damage known), `damage`,
//!   `duration_s`, `messages`, `speed`, `replay_wall_s` (the wall time a replay at that
//!   speed takes: the duration divided by the speed), `channels` (topic, encoding, schema,
//!   known, count), `warnings`.
//! * `--check` reads every message, decodes each by its topic (JSON records, raw frames,
//!   the Foxglove messages) and checks every chunk: `decode_errors` per channel, damage
//!   anywhere, messages out of order and gaps in the warnings.
//! * `--model M` (model1, model2, model3 or a `FILE.toml`: a saved extended model, a
//!   vehicle definition) drives the model with the recorded thrust commands and reports
//!   the fit per channel (`model`, `fit`: `channel`, `predicted`, `samples`, `fit_pct`,
//!   `rmse`; `fit_notes`). It is the model lab's engine and data path: the session read
//!   into runs like `lab compare --data FILE.mcap` (the real-log treatment; a gap splits
//!   the session into runs), loaded by [`crate::cmd_lab::load_model_arg`], the free run
//!   pooled over the runs by [`rov_lab::fit_runs`]: the same numbers as `lab compare`'s
//!   `pooled.free_run`. `fit_pct` is null when the channel barely moves (the lab's
//!   noise-floor gate); it reads nav, thrust and truth.
//!
//! Output: one JSON object on stdout, the same in words on stderr. A truncated file is
//! summarised as far as it is intact, with a warning.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use rov_session::{MAX_SPEED, MIN_SPEED};
use serde_json::json;

use crate::cmd_export::{open_with_warnings, warn_damage};
use crate::cmd_session::damage_json;

/// Arguments of `topside replay`.
#[derive(Debug, Args)]
pub struct ReplayArgs {
    /// The session file (a truncated recording is accepted, with a warning).
    #[arg(value_name = "FILE.mcap")]
    pub file: PathBuf,
    /// Replay without the GUI and print a summary (the GUI replays from its Replay tab).
    #[arg(long)]
    pub headless: bool,
    /// Playback speed, 0.1–50 (clamped); sets `replay_wall_s`.
    #[arg(long, default_value_t = 1.0)]
    pub speed: f64,
    /// Fit this model to the session (model1, model2, model3 or FILE.toml): the recorded
    /// thrust commands drive it (the model lab's engine, free run).
    #[arg(long)]
    pub model: Option<String>,
    /// Read and decode every message and check every chunk.
    #[arg(long)]
    pub check: bool,
}

pub fn run(args: ReplayArgs) -> anyhow::Result<ExitCode> {
    if !args.headless {
        anyhow::bail!("the replay GUI is the station window's Replay tab; use --headless here");
    }
    let model = match &args.model {
        Some(m) => Some(crate::cmd_lab::load_model_arg(m)?),
        None => None,
    };
    let session = open_with_warnings(&args.file)?;
    let speed = if args.speed.is_finite() {
        args.speed.clamp(MIN_SPEED, MAX_SPEED)
    } else {
        1.0
    };
    if speed != args.speed {
        eprintln!("warning: speed {} clamped to {speed}", args.speed);
    }
    let mut warnings = session.warnings().to_vec();

    let mut decode_errors: BTreeMap<String, u64> = BTreeMap::new();
    if args.check {
        let mut read = session.messages_in_file_order();
        let mut first_error: Option<String> = None;
        for m in read.by_ref() {
            if let Err(e) = m.validate() {
                *decode_errors.entry(m.topic().to_string()).or_insert(0) += 1;
                first_error.get_or_insert_with(|| e.to_string());
            }
        }
        if let Some(e) = &first_error {
            eprintln!("warning: some messages do not decode, e.g. {e}");
        }
        let report = read.report();
        for w in &report.warnings {
            eprintln!("warning: {w}");
        }
        warnings.extend(report.warnings);
        if report.damage.is_some() && session.is_indexed() {
            warn_damage(&args.file, &session);
        }
    }
    let duration_s = session.duration_s();
    let replay_wall_s = duration_s / speed;

    let topics = session.topics();
    let channels: Vec<serde_json::Value> = topics
        .iter()
        .map(|t| {
            json!({
                "topic": t.topic,
                "encoding": t.encoding,
                "schema": t.schema_name,
                "known": t.known.is_some(),
                "count": t.count,
                "decode_errors": args.check.then(|| decode_errors.get(&t.topic).copied().unwrap_or(0)),
            })
        })
        .collect();

    // The model lab's engine on the lab's runs of this session (the same reading as
    // `lab compare --data FILE.mcap`).
    let resim = model.as_ref().map(|m| -> anyhow::Result<_> {
        let runs = crate::cmd_lab::load_log(&args.file)?;
        let fits = rov_lab::fit_runs(m, &runs)?;
        Ok((fits, rov_lab::ingest::treatment_sentences(&runs)))
    });
    let (fit, fit_error, fit_notes) = match &resim {
        Some(Ok((fits, notes))) => {
            let fits: Vec<serde_json::Value> = fits
                .iter()
                .map(|f| {
                    json!({
                        "channel": crate::cmd_sim_run::column(f.channel),
                        "predicted": f.predicted,
                        "samples": f.samples,
                        "fit_pct": f.fit_pct,
                        "rmse": f.rmse,
                    })
                })
                .collect();
            (Some(fits), None, Some(notes.clone()))
        }
        Some(Err(e)) => {
            eprintln!("warning: no model fit: {e:#}");
            (None, Some(format!("{e:#}")), None)
        }
        None => (None, None, None),
    };
    if model.is_some() && session.is_indexed() && session.damage().is_some() && !args.check {
        warn_damage(&args.file, &session);
    }

    let out = json!({
        "file": args.file,
        "complete": session.is_complete(),
        "damage": damage_json(session.damage().as_ref()),
        "duration_s": duration_s,
        "messages": session.len(),
        "speed": speed,
        "replay_wall_s": replay_wall_s,
        "channels": channels,
        "checked": args.check,
        "model": args.model,
        "fit": fit,
        "fit_error": fit_error,
        "fit_notes": fit_notes,
        "warnings": warnings,
    });
    println!("{out}");

    eprintln!(
        "{}: {:.3} s, {} messages{}; replay at {speed}x takes {replay_wall_s:.2} s",
        args.file.display(),
        duration_s,
        session.len(),
        if session.is_complete() {
            ""
        } else {
            " (damaged: intact part only)"
        }
    );
    eprintln!("{:<22} {:>9}  encoding", "channel", "messages");
    for t in &topics {
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
    if let (Some(Ok((fits, notes))), Some(name)) = (&resim, &args.model) {
        eprintln!(
            "free-run fit of {name} (fit % = 100 (1 - |y - yhat| / |y - mean y|), the model lab's engine):"
        );
        for f in fits {
            let col = crate::cmd_sim_run::column(f.channel);
            match (f.predicted, f.fit_pct, f.rmse) {
                (false, _, _) => eprintln!("  {col:<14} not predicted by {name}"),
                (true, Some(fit), Some(rmse)) => {
                    eprintln!(
                        "  {col:<14} fit {fit:7.2} %  RMSE {rmse:.4} ({} samples)",
                        f.samples
                    )
                }
                (true, None, Some(rmse)) => {
                    eprintln!("  {col:<14} fit n/a (the measurement barely moves)  RMSE {rmse:.4}")
                }
                (true, _, None) => eprintln!("  {col:<14} no finite samples to compare"),
            }
        }
        for n in notes {
            eprintln!("  note: {n}");
        }
    }
    Ok(ExitCode::SUCCESS)
}
