//! `topside export FILE.mcap [--csv OUT.csv] [--video OUT.mp4 [--overlay]]`: a session
//! as a measurement CSV plus every decoded channel, and/or its camera video as an MP4
//! with `OUT.ass` telemetry subtitles (see [`crate::cmd_export_video`]). At least one of
//! `--csv` and `--video` is required.
//!
//! The columns, the time axis (strictly increasing numeric seconds since the first
//! message), the number format (shortest round trip) and the timing rule (row k's command
//! is the last one sent before the next sample) are those of `rov_session::csv`. The export
//! streams: the session is read chunk by chunk and the CSV written row by row (to
//! `OUT.csv.partial`, renamed when complete), so an 8-hour session needs no more memory
//! than a short one. A truncated or damaged file is exported as far as it is intact, with
//! a warning on stderr. Warnings go to stderr, one per line.

use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use rov_session::{Session, export_csv_to};

/// Arguments of `topside export`.
#[derive(Debug, Args)]
pub struct ExportArgs {
    /// The session file (a truncated recording is accepted, with a warning).
    #[arg(value_name = "FILE.mcap")]
    pub file: PathBuf,
    /// Output CSV (measurement format plus `topic.field` columns).
    #[arg(long, value_name = "OUT.csv", required_unless_present = "video")]
    pub csv: Option<PathBuf>,
    /// Output MP4 of the session's camera video (H.264), plus OUT.ass subtitles with the
    /// telemetry.
    #[arg(long, value_name = "OUT.mp4")]
    pub video: Option<PathBuf>,
    /// Burn the telemetry text into the video's frames (re-encodes).
    #[arg(long, requires = "video")]
    pub overlay: bool,
}

/// Prints a session's damage (as far as known) on stderr.
pub fn warn_damage(path: &std::path::Path, session: &Session) {
    if let Some(d) = session.damage() {
        eprintln!(
            "warning: {}: {d}; using what is intact (`topside session recover {}` writes a complete copy)",
            path.display(),
            path.display()
        );
    }
}

/// Opens a session (its index only) and prints, on stderr, its damage and warnings
/// (shared by the session commands).
pub fn open_with_warnings(path: &std::path::Path) -> anyhow::Result<Session> {
    let session = Session::open(path)?;
    warn_damage(path, &session);
    for w in session.warnings() {
        eprintln!("warning: {}: {w}", path.display());
    }
    Ok(session)
}

pub fn run(args: ExportArgs) -> anyhow::Result<ExitCode> {
    let session = open_with_warnings(&args.file)?;
    if let Some(csv) = &args.csv {
        write_csv(&session, &args.file, csv)?;
    }
    if let Some(mp4) = &args.video {
        crate::cmd_export_video::export_video(&session, &args.file, mp4, args.overlay)?;
    }
    Ok(ExitCode::SUCCESS)
}

fn write_csv(
    session: &Session,
    source: &std::path::Path,
    csv_path: &std::path::Path,
) -> anyhow::Result<()> {
    let partial = {
        let mut name = csv_path.to_path_buf().into_os_string();
        name.push(".partial");
        PathBuf::from(name)
    };
    let file = std::fs::File::create(&partial)
        .with_context(|| format!("creating {}", partial.display()))?;
    let mut out = std::io::BufWriter::with_capacity(1 << 20, file);
    let csv = match export_csv_to(session, &mut out) {
        Ok(c) => c,
        Err(e) => {
            drop(out);
            let _ = std::fs::remove_file(&partial);
            return Err(e.into());
        }
    };
    out.flush()
        .with_context(|| format!("writing {}", partial.display()))?;
    drop(out);
    std::fs::rename(&partial, csv_path)
        .with_context(|| format!("renaming {} to {}", partial.display(), csv_path.display()))?;
    // Damage a read found on the way (a complete file opens without reading its chunks).
    if csv.read.damage.is_some() && session.is_indexed() {
        warn_damage(source, session);
    }
    for w in &csv.warnings {
        eprintln!("warning: {w}");
    }
    eprintln!(
        "wrote {}: {} rows, the measurement columns and {} channel columns",
        csv_path.display(),
        csv.rows,
        csv.extra_columns.len()
    );
    Ok(())
}
