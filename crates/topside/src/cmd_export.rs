//! `topside export FILE.mcap --csv OUT.csv`: a session as a measurement CSV plus every
//! decoded channel.
//!
//! The columns, the time axis (strictly increasing numeric seconds since the first
//! message) and the timing rule (row k's command is the last one sent before the next
//! sample) are those of `rov_session::csv`. A truncated or damaged file is exported as far
//! as it is intact, with a warning on stderr. Warnings go to stderr, one per line.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use rov_session::{Session, export_csv};

/// Arguments of `topside export`.
#[derive(Debug, Args)]
pub struct ExportArgs {
    /// The session file (a truncated recording is accepted, with a warning).
    #[arg(value_name = "FILE.mcap")]
    pub file: PathBuf,
    /// Output CSV (measurement format plus `topic.field` columns).
    #[arg(long, value_name = "OUT.csv")]
    pub csv: PathBuf,
}

/// Opens a session and prints, on stderr, its damage and warnings (shared by the session
/// commands).
pub fn open_with_warnings(path: &std::path::Path) -> anyhow::Result<Session> {
    let session = Session::open(path)?;
    if let Some(d) = session.damage() {
        eprintln!(
            "warning: {}: {d}; using what is intact (`topside session recover {}` writes a complete copy)",
            path.display(),
            path.display()
        );
    }
    for w in &session.warnings {
        eprintln!("warning: {}: {w}", path.display());
    }
    Ok(session)
}

pub fn run(args: ExportArgs) -> anyhow::Result<ExitCode> {
    let session = open_with_warnings(&args.file)?;
    let csv = export_csv(&session)?;
    for w in &csv.warnings {
        eprintln!("warning: {w}");
    }
    std::fs::write(&args.csv, &csv.text)
        .with_context(|| format!("writing {}", args.csv.display()))?;
    eprintln!(
        "wrote {}: {} rows, the measurement columns and {} channel columns",
        args.csv.display(),
        csv.rows,
        csv.extra_columns.len()
    );
    Ok(ExitCode::SUCCESS)
}
