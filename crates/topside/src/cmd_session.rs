//! `topside session recover FILE.mcap`: rewrite a damaged (e.g. killed) recording as a
//! complete file.
//!
//! Writes `FILE.recovered.mcap` beside the input (the input is never modified) holding
//! every message up to the last good record, with a fresh summary and indexes. Prints a
//! JSON report on stdout (`input`, `output`, `input_bytes`, `good_bytes`, `lost_bytes`,
//! `messages_recovered`, `last_good_t_s`, `damage`, `warnings`) and the same in words on
//! stderr. Exit status 0 when messages were recovered, 1 when none were (the output is
//! still written, empty), 2 when the input is not a session file.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Subcommand};
use rov_session::{Damage, recover};
use serde_json::json;

/// Arguments of `topside session`.
#[derive(Debug, Args)]
pub struct SessionArgs {
    #[command(subcommand)]
    command: SessionCommand,
}

#[derive(Debug, Subcommand)]
enum SessionCommand {
    /// Write FILE.recovered.mcap: everything up to the last good record, as a complete file.
    Recover(RecoverArgs),
}

/// `topside session recover FILE.mcap`
#[derive(Debug, Args)]
struct RecoverArgs {
    /// The session file (left unchanged).
    #[arg(value_name = "FILE.mcap")]
    file: PathBuf,
}

/// The damage as JSON (shared by the session commands).
pub fn damage_json(d: Option<&Damage>) -> serde_json::Value {
    match d {
        None => serde_json::Value::Null,
        Some(Damage::Truncated {
            at_byte,
            messages_recovered,
        }) => {
            json!({"kind": "truncated", "at_byte": at_byte, "messages_recovered": messages_recovered})
        }
        Some(Damage::Corrupt {
            at_byte,
            detail,
            messages_recovered,
        }) => json!({
            "kind": "corrupt",
            "at_byte": at_byte,
            "detail": detail,
            "messages_recovered": messages_recovered,
        }),
    }
}

pub fn run(args: SessionArgs) -> anyhow::Result<ExitCode> {
    match args.command {
        SessionCommand::Recover(a) => run_recover(&a),
    }
}

fn run_recover(args: &RecoverArgs) -> anyhow::Result<ExitCode> {
    let report = recover(&args.file)?;
    let out = json!({
        "input": report.input,
        "output": report.output,
        "input_bytes": report.input_bytes,
        "good_bytes": report.good_bytes,
        "lost_bytes": report.lost_bytes,
        "messages_recovered": report.messages_recovered,
        "last_good_t_s": report.last_good_t_ns.map(|t| t as f64 * 1e-9),
        "damage": damage_json(report.damage.as_ref()),
        "warnings": report.warnings,
    });
    println!("{out}");
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    eprintln!("{report}");
    Ok(if report.messages_recovered == 0 {
        eprintln!("error: no message could be recovered");
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}
