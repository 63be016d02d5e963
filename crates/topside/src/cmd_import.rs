//! `topside import IN.csv --out FILE.mcap`: outside measurements (the measurement CSV
//! format) as a session.
//!
//! The session holds `/session/info` (vehicle `import`), then per row a `/telemetry/nav`
//! and the `/command/thrust` in force from that row on, and `/truth/state` when the CSV has
//! velocity or position columns. `OUT` is overwritten. Warnings (e.g. ignored columns) go
//! to stderr.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use rov_session::import_csv;

/// Arguments of `topside import`.
#[derive(Debug, Args)]
pub struct ImportArgs {
    /// Measurement CSV to import.
    #[arg(value_name = "IN.csv")]
    pub csv: PathBuf,
    /// Session file to write (overwritten).
    #[arg(long, value_name = "FILE.mcap")]
    pub out: PathBuf,
}

pub fn run(args: ImportArgs) -> anyhow::Result<ExitCode> {
    let text = std::fs::read_to_string(&args.csv)
        .with_context(|| format!("reading {}", args.csv.display()))?;
    let label = args.csv.display().to_string();
    let report = import_csv(&text, &label, &args.out)?;
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    eprintln!(
        "wrote {}: {} rows as {} messages",
        args.out.display(),
        report.rows,
        report.written.messages
    );
    Ok(ExitCode::SUCCESS)
}
