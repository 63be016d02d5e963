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

use anyhow::Context;
use clap::Args;
use rov_session::{import_csv, import_series};

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
    let label = args.csv.display().to_string();
    let bytes = std::fs::read(&args.csv).with_context(|| format!("reading {label}"))?;
    // The map: the one given, else the shipped map whose columns a CSV has (the BlueROV2
    // tank CSVs), as the lab reads logs (rov_lab::loader).
    let map = match &args.map {
        Some(map_path) => {
            let map_text = std::fs::read_to_string(map_path)
                .with_context(|| format!("reading the log map {}", map_path.display()))?;
            let map = rov_logs::LogMap::parse(&map_text, &map_path.display().to_string())?;
            Some((map, map_text))
        }
        None => std::str::from_utf8(&bytes)
            .ok()
            .and_then(rov_lab::ingest::shipped_map_for)
            .and_then(|map| {
                let (_, text) = rov_lab::ingest::SHIPPED_MAPS
                    .iter()
                    .find(|(name, _)| *name == map.label)?;
                Some((map, (*text).to_string()))
            }),
    };
    let report = if let Some((map, map_text)) = map {
        let log = rov_lab::loader::read_mapped(&bytes, &map, &label)?;
        let left_out: Vec<&str> = log
            .command_names()
            .into_iter()
            .filter(|n| !matches!(*n, "port" | "starboard" | "vertical"))
            .collect();
        let mut series = log.series.clone();
        series.warnings.extend(log.notes().iter().cloned());
        if !left_out.is_empty() {
            series.warnings.push(format!(
                "command channel(s) {} are not Pro 4 thrusters and are not stored in the \
                 session (the lab reads them from the log with --map)",
                left_out.join(", ")
            ));
        }
        import_series(&series, &label, &map_text, &args.out)?
    } else {
        match rov_logs::Format::detect(&bytes) {
            Some(rov_logs::Format::Csv) | None => {}
            Some(f) => anyhow::bail!(
                "{label}: a {} log; importing it needs a log map (--map MAP.toml)",
                f.name()
            ),
        }
        let text = String::from_utf8(bytes)
            .map_err(|_| anyhow::anyhow!("{label}: not UTF-8 text; a binary log needs --map"))?;
        import_csv(&text, &label, &args.out)?
    };
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
