//! `topside lab watch FILE [--model M] [--map MAP] [--json]`: the station's model watch
//! ([`rov_lab::watch`]) run over a recorded session or any log the lab reads, printing
//! the alerts it raises: a **mismatch** (the model was wrong from the start: use the lab)
//! or a **change** (the vehicle changed during the dive), with the likely causes ranked.
//!
//! A session is streamed row by row (an 8-hour dive in bounded memory, like the station
//! feeds its own watch); a CSV or a mapped log is read whole. JSON (pinned):
//! `{"alerts": [{"t_s", "kind", "channel", "size_noise", "causes": [{"cause", "size",
//! "unit", "score"}]}]}`, `t_s` seconds from the log's start, causes best first; plus
//! `judged_s`, the seconds judged after the watch's first minute (0: not judged at all,
//! the log was too short).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context as _;
use clap::Args;
use rov_lab::watch::{Alert, Watch, WatchConfig, WatchStats, watch_json};
use rov_types::measurement::MeasurementRow;

/// `topside lab watch`.
#[derive(Debug, Args)]
pub struct WatchArgs {
    /// The log: a session (.mcap), a measurement CSV, or any log a --map describes.
    file: PathBuf,
    /// The model the vehicle is compared with: model1, model2, model3, a vehicle file or a
    /// saved extended model (the autopilot's model, for a dive flown on it).
    #[arg(long, default_value = "model3")]
    model: String,
    /// Log map (TOML) for a log that is not a session or a measurement CSV.
    #[arg(long, value_name = "MAP.toml")]
    map: Option<PathBuf>,
    /// JSON on stdout.
    #[arg(long)]
    json: bool,
}

/// Which optional columns (body rates) a row carries.
fn present_of(row: &MeasurementRow) -> [bool; 8] {
    std::array::from_fn(|i| row.optional.get(i).is_some_and(Option::is_some))
}

/// Feeds rows to a watch created on the first row (which says what the log carries).
struct Feeder {
    model: rov_lab::LabModel,
    cfg: WatchConfig,
    watch: Option<Watch>,
}

impl Feeder {
    fn push(&mut self, row: &MeasurementRow) {
        let w = self
            .watch
            .get_or_insert_with(|| Watch::new(self.model.clone(), self.cfg, present_of(row)));
        w.push(row);
    }

    fn finish(self) -> (Vec<Alert>, WatchStats) {
        match self.watch {
            Some(mut w) => {
                w.finish();
                (w.alerts().to_vec(), w.stats())
            }
            None => (Vec::new(), WatchStats::default()),
        }
    }
}

/// Runs the watch over one log: its alerts and counters.
pub fn watch_file(
    path: &Path,
    model: rov_lab::LabModel,
    map: Option<&rov_logs::LogMap>,
) -> anyhow::Result<(Vec<Alert>, WatchStats)> {
    let mut feed = Feeder {
        model,
        cfg: WatchConfig::default(),
        watch: None,
    };
    let is_session = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mcap"));
    if is_session && map.is_none() {
        let session = rov_session::open(path)
            .with_context(|| format!("opening session {}", path.display()))?;
        let done = rov_session::measurements_each(&session, &mut |_, row| feed.push(row))
            .with_context(|| format!("reading measurements from {}", path.display()))?;
        for w in done.warnings {
            eprintln!("warning: {}: {w}", path.display());
        }
        return Ok(feed.finish());
    }
    let label = path.display().to_string();
    let bytes = std::fs::read(path).with_context(|| format!("reading {label}"))?;
    // Read as the lab reads a log (rov_lab::loader): through the map, or a measurement
    // CSV / a CSV a shipped map reads.
    let log = match map {
        Some(map) => rov_lab::loader::read_mapped(&bytes, map, &label)
            .with_context(|| format!("reading {label} through the map {}", map.label))?,
        None => rov_lab::loader::read_bytes(&bytes, &label)?,
    };
    let extra: Vec<&str> = log
        .command_names()
        .into_iter()
        .filter(|n| !["port", "starboard", "vertical"].contains(n))
        .collect();
    if !extra.is_empty() {
        anyhow::bail!(
            "{label}: the watch flies the Pro 4's port, starboard and vertical command channels; this log also drives {} (a vehicle the watch does not model yet)",
            extra.join(", ")
        );
    }
    let series = log.series;
    for w in &series.warnings {
        eprintln!("warning: {w}");
    }
    let mut w = Watch::new(feed.model, feed.cfg, series.present);
    for r in &series.rows {
        w.push(r);
    }
    w.finish();
    Ok((w.alerts().to_vec(), w.stats()))
}

/// Prints alerts for a person.
pub fn print_alerts(alerts: &[Alert], stats: &WatchStats) {
    let cfg = WatchConfig::default();
    if stats.judged_hops == 0 {
        println!(
            "not judged: the log ({} rows) is shorter than the watch's first {:.0} s, in which it learns its noise floor",
            stats.rows,
            cfg.history_s + cfg.baseline_s
        );
    } else if alerts.is_empty() {
        println!(
            "no alert: the vehicle behaved like its model over {:.0} s judged ({} rows)",
            stats.judged_hops as f64 * cfg.hop_s,
            stats.rows
        );
    }
    for a in alerts {
        println!(
            "{:>9.1} s  {:<8} {:<7} {:6.1} noise floors  {}",
            a.t_s,
            match a.kind {
                rov_lab::watch::AlertKind::Change => "CHANGE",
                rov_lab::watch::AlertKind::Mismatch => "MISMATCH",
            },
            a.channel,
            a.size_noise,
            a.words()
        );
        for c in a.causes.iter().take(4) {
            println!(
                "             {:<24} {:>9.3} {:<8} score {:.2}",
                c.cause, c.size, c.unit, c.score
            );
        }
    }
    if stats.rows_refused > 0 || stats.hops_skipped > 0 {
        println!(
            "({} rows refused, {} evaluations skipped for gaps or too few rows)",
            stats.rows_refused, stats.hops_skipped
        );
    }
}

/// Runs `topside lab watch`.
pub fn run(a: WatchArgs) -> anyhow::Result<ExitCode> {
    let model = crate::cmd_lab::load_model_arg(&a.model)?;
    let map = crate::cmd_lab::load_map(a.map.as_deref())?;
    let (alerts, stats) = watch_file(&a.file, model, map.as_ref())?;
    if a.json {
        println!("{}", watch_json(&alerts, &stats, &WatchConfig::default()));
    } else {
        print_alerts(&alerts, &stats);
    }
    Ok(ExitCode::SUCCESS)
}
