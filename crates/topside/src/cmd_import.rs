//! `topside import LOG [--map MAP.toml] --out FILE.mcap`: outside measurements as a
//! session: a measurement CSV as it is, or any log a log map describes (CSV/TSV,
//! DataFlash, tlog, ROS bags, MCAP with CDR messages), so replay, plots, export and the
//! GUI work on it.
//!
//! The session holds `/session/info` (vehicle `import`), then per row a `/telemetry/nav`
//! and the `/command/thrust` in force from that row on, and `/truth/state` when the CSV has
//! velocity or position columns. `OUT` is overwritten. Warnings (e.g. ignored columns) go
//! to stderr. A mapped log's command channels that are not the Pro 4's three thrusters
//! (`port`, `starboard`, `vertical`) have no place in a session's thrust record: the import
//! says which it left out (the lab reads them from the log itself with `--map`), and the
//! session's info keeps the map's text as its provenance. Logs are read as the lab reads
//! them ([`rov_lab::loader`]): a CSV with the columns of a shipped map (the BlueROV2 tank
//! CSVs) is read through that map without `--map`.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

/// Arguments of `topside import`.
#[derive(Debug, Args)]
pub struct ImportArgs {
    /// Log to import: a measurement CSV, or with --map any log the map describes.
    #[arg(value_name = "LOG")]
    pub csv: PathBuf,
    /// Log map (TOML): how the log's fields become the session's signals and commands.
    #[arg(long, value_name = "MAP.toml")]
    pub map: Option<PathBuf>,
    /// Session file to write (overwritten).
    #[arg(long, value_name = "FILE.mcap")]
    pub out: PathBuf,
}

pub fn run(args: ImportArgs) -> anyhow::Result<ExitCode> {
    let report = rov_station::import::import_log(&args.csv, args.map.as_deref(), &args.out)?;
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
