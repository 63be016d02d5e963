//! The lab's one log loader: a log's bytes (or a session's streamed rows) read into a
//! [`LoadedLog`] — its measured rows, its command channels and what the reader met —
//! before they become runs.
//!
//! [`LoadedLog::runs`] makes the runs through [`crate::ingest`] (gaps split the log,
//! spikes excluded, closed loop recognised, every treatment recorded);
//! [`LoadedLog::rows`] keeps a stretch of the rows (the GUI's training and held-out
//! parts, a model-watch alert's window), so that a part of a log goes through exactly
//! the treatment the whole log does. `topside lab` (every subcommand), `sim run`, the
//! GUI's Model lab and `topside import` read logs here; the caller reads the file (this
//! crate does no I/O).
//!
//! Formats: a measurement CSV (extra `NAME_pct` columns become command channels), a CSV
//! with the columns of a shipped log map ([`crate::ingest::SHIPPED_MAPS`]: the BlueROV2
//! tank data set) read through that map, any log through a given map
//! ([`read_mapped`]), and a session's rows streamed through [`crate::stream::LogStream`]
//! ([`crate::stream::LogStream::finish_log`]).

use rov_dynamics::models::vehicle::{CommandChannel, Commands, N_COMMANDS};
use rov_logs::LogMap;
use rov_types::measurement::MeasurementSeries;

use crate::LabError;
use crate::data::Run;
use crate::stream::RawStats;

/// A log's command channels beside its rows.
#[derive(Debug, Clone, PartialEq)]
enum LogCommands {
    /// Only the Pro 4's three thrusters, in the series' own columns.
    Pro4,
    /// Every built-in command channel per row, and which the log holds (a measurement
    /// CSV with extra `NAME_pct` columns).
    Builtin(Vec<Commands>, [bool; N_COMMANDS]),
    /// Named command channels (a log map's), % per row.
    Named(Vec<(String, Vec<f64>)>),
}

/// A log read, before it becomes runs (see the module docs).
#[derive(Debug, Clone)]
pub struct LoadedLog {
    /// The label runs are named after (the file name).
    pub label: String,
    /// The measured rows (times increasing: rows whose time did not increase are
    /// dropped and counted) with the Pro 4 command view.
    pub series: MeasurementSeries,
    commands: LogCommands,
    raw: Option<RawStats>,
    dropped_rows: Option<usize>,
    notes: Vec<String>,
}

impl LoadedLog {
    /// A session's kept rows (the Pro 4's commands), with what the raw rows showed when
    /// the stream decimated them.
    pub(crate) fn from_stream(
        label: &str,
        series: MeasurementSeries,
        raw: Option<RawStats>,
    ) -> Self {
        Self {
            label: label.to_string(),
            series,
            commands: LogCommands::Pro4,
            raw,
            dropped_rows: None,
            notes: Vec::new(),
        }
    }

    /// Rows.
    pub fn len(&self) -> usize {
        self.series.rows.len()
    }

    /// Whether the log has no rows.
    pub fn is_empty(&self) -> bool {
        self.series.rows.is_empty()
    }

    /// The log's command channels by name (the Pro 4's three when it has only those).
    pub fn command_names(&self) -> Vec<&str> {
        match &self.commands {
            LogCommands::Pro4 => vec!["port", "starboard", "vertical"],
            LogCommands::Builtin(_, present) => CommandChannel::BUILTIN
                .iter()
                .filter(|c| present.get(c.index()).copied().unwrap_or(false))
                .filter_map(|c| c.builtin_name())
                .collect(),
            LogCommands::Named(c) => c.iter().map(|(n, _)| n.as_str()).collect(),
        }
    }

    /// What the reader met, in words (each run's treatment notes carry it too).
    pub fn notes(&self) -> &[String] {
        &self.notes
    }

    /// The log as runs: split at gaps, spikes excluded, closed loop recognised
    /// ([`crate::ingest::series_runs_with`]), with the reader's notes and dropped rows in
    /// every run's treatment.
    pub fn runs(&self) -> Result<Vec<Run>, LabError> {
        let raw = self.raw.as_ref();
        let mut runs = match &self.commands {
            LogCommands::Pro4 => {
                crate::ingest::series_runs_with(&self.series, &self.label, None, raw)?
            }
            LogCommands::Builtin(v, p) => crate::ingest::series_runs_with(
                &self.series,
                &self.label,
                Some((v.clone(), *p)),
                raw,
            )?,
            LogCommands::Named(c) => {
                Run::runs_from_named_commands(&self.series, &self.label, c, raw)?
            }
        };
        for r in &mut runs {
            if let Some(d) = self.dropped_rows {
                r.treatment.dropped_time_rows = d;
            }
            r.treatment.notes.extend(self.notes.iter().cloned());
        }
        Ok(runs)
    }

    /// The rows `range` (clamped to the log) as a log of their own, under `label`.
    pub fn rows(&self, range: std::ops::Range<usize>, label: &str) -> Self {
        let n = self.len();
        let r = range.start.min(n)..range.end.min(n).max(range.start.min(n));
        let commands = match &self.commands {
            LogCommands::Pro4 => LogCommands::Pro4,
            LogCommands::Builtin(v, p) => {
                LogCommands::Builtin(v.get(r.clone()).unwrap_or_default().to_vec(), *p)
            }
            LogCommands::Named(c) => LogCommands::Named(
                c.iter()
                    .map(|(name, v)| (name.clone(), v.get(r.clone()).unwrap_or_default().to_vec()))
                    .collect(),
            ),
        };
        Self {
            label: label.to_string(),
            series: MeasurementSeries {
                rows: self.series.rows.get(r).unwrap_or_default().to_vec(),
                present: self.series.present,
                warnings: self.series.warnings.clone(),
            },
            commands,
            raw: self.raw.clone(),
            dropped_rows: self.dropped_rows,
            notes: self.notes.clone(),
        }
    }

    /// The rows from `from_s` to `to_s` after the log's first row, under `label`.
    pub fn window(&self, from_s: f64, to_s: f64, label: &str) -> Self {
        let t0 = self.series.rows.first().map_or(0.0, |r| r.time_s);
        let t = |k: usize| {
            self.series
                .rows
                .get(k)
                .map_or(f64::INFINITY, |r| r.time_s - t0)
        };
        let a = (0..self.len())
            .find(|k| t(*k) >= from_s)
            .unwrap_or(self.len());
        let b = (a..self.len()).find(|k| t(*k) > to_s).unwrap_or(self.len());
        self.rows(a..b, label)
    }
}

/// Extra command columns a measurement CSV may carry: `NAME_pct` for every command
/// channel beyond the Pro 4's three.
fn extra_command_columns(header: &[&str]) -> Vec<(usize, CommandChannel)> {
    header
        .iter()
        .enumerate()
        .filter_map(|(i, h)| {
            let name = h.strip_suffix("_pct")?;
            let c = CommandChannel::parse_builtin(name)?;
            (!matches!(
                c,
                CommandChannel::PORT | CommandChannel::STARBOARD | CommandChannel::VERTICAL
            ))
            .then_some((i, c))
        })
        .collect()
}

/// A measurement CSV read: rows with non-increasing time dropped (counted); extra
/// `NAME_pct` command columns (a lateral thruster, body-axis demands) become command
/// channels.
pub fn read_measurement_csv(text: &str, label: &str) -> Result<LoadedLog, LabError> {
    let mut lines = text.lines();
    let Some(header_line) = lines.next() else {
        return Err(LabError::Data {
            run: label.into(),
            detail: "empty file".into(),
        });
    };
    let header: Vec<&str> = header_line.split(',').map(str::trim).collect();
    let t_col = header.iter().position(|h| *h == "time_s");
    let extra = extra_command_columns(&header);
    // Keep line numbers for the parser's messages: dropped rows become comment lines.
    let mut cleaned = String::with_capacity(text.len());
    cleaned.push_str(header_line);
    cleaned.push('\n');
    let mut last_t = f64::NEG_INFINITY;
    let mut dropped = 0usize;
    let mut extra_rows: Vec<Vec<f64>> = Vec::new();
    for line in lines {
        let trimmed = line.trim();
        if trimmed.is_empty() || trimmed.starts_with('#') {
            cleaned.push_str(line);
            cleaned.push('\n');
            continue;
        }
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        let t = t_col
            .and_then(|i| cells.get(i))
            .and_then(|c| c.parse::<f64>().ok());
        if let Some(t) = t
            && t.is_finite()
        {
            if t <= last_t {
                dropped += 1;
                cleaned.push_str("# dropped: time does not increase\n");
                continue;
            }
            last_t = t;
        }
        extra_rows.push(
            extra
                .iter()
                .map(|(i, _)| {
                    cells
                        .get(*i)
                        .and_then(|c| c.parse::<f64>().ok())
                        .filter(|x| x.is_finite())
                        .map_or(0.0, |x| x.clamp(-100.0, 100.0))
                })
                .collect(),
        );
        cleaned.push_str(line);
        cleaned.push('\n');
    }
    let mut series = MeasurementSeries::parse_csv(&cleaned, label)?;
    series.warnings.retain(|w| {
        !extra
            .iter()
            .any(|(i, _)| header.get(*i).is_some_and(|h| w.contains(h)))
    });
    let inputs = if extra.is_empty() || extra_rows.len() != series.rows.len() {
        None
    } else {
        let mut present = crate::data::pro4_present();
        for (_, c) in &extra {
            present[c.index()] = true;
        }
        let v: Vec<Commands> = series
            .rows
            .iter()
            .zip(&extra_rows)
            .map(|(r, e)| {
                let mut c = crate::data::commands_of_pct(&rov_dynamics::ThrustPct::new(
                    r.port_pct,
                    r.starboard_pct,
                    r.vertical_pct,
                ));
                for ((_, ch), x) in extra.iter().zip(e) {
                    c[ch.index()] = *x;
                }
                c
            })
            .collect();
        Some((v, present))
    };
    let notes = series.warnings.clone();
    Ok(LoadedLog {
        label: label.to_string(),
        series,
        commands: match inputs {
            Some((v, p)) => LogCommands::Builtin(v, p),
            None => LogCommands::Pro4,
        },
        raw: None,
        dropped_rows: Some(dropped),
        notes,
    })
}

/// A log (bytes) through a map: the map's signals and named command channels.
pub fn read_mapped(bytes: &[u8], map: &LogMap, label: &str) -> Result<LoadedLog, LabError> {
    let mapped = map.read_apply(bytes, label)?;
    let m = crate::mapped::mapped_series(&mapped, &map.label)?;
    let mut notes = vec![format!("read through the log map {}", map.label)];
    notes.extend(m.notes);
    Ok(LoadedLog {
        label: label.to_string(),
        series: m.series,
        commands: LogCommands::Named(m.commands),
        raw: None,
        dropped_rows: Some(m.dropped_rows),
        notes,
    })
}

/// [`read_mapped`] with the log map given as its TOML text (`map_label`: its file, named
/// in its errors), as `--map MAP.toml` reads a log.
///
/// # Errors
/// The map does not parse, or the log does not read through it.
pub fn read_with_map_text(
    bytes: &[u8],
    map_text: &str,
    map_label: &str,
    label: &str,
) -> Result<LoadedLog, LabError> {
    let map = LogMap::parse(map_text, map_label)?;
    read_mapped(bytes, &map, label)
}

/// A log of any supported text format: a CSV with the columns of a shipped log map
/// ([`crate::ingest::SHIPPED_MAPS`]) through that map, else a measurement CSV.
pub fn read_text(text: &str, label: &str) -> Result<LoadedLog, LabError> {
    if let Some(map) = crate::ingest::shipped_map_for(text) {
        return read_mapped(text.as_bytes(), &map, label);
    }
    read_measurement_csv(text, label)
}

/// The name of the log format of `bytes` when it is one that can only be read through a
/// log map (DataFlash, tlog, ROS bags, MCAP with CDR messages); `None` for text.
pub fn format_needing_map(bytes: &[u8]) -> Option<&'static str> {
    match rov_logs::Format::detect(bytes) {
        Some(rov_logs::Format::Csv) | None => None,
        Some(f) => Some(f.name()),
    }
}

/// A log file's bytes (not a session): text through [`read_text`]; a binary log format
/// that needs a log map is refused, naming the format.
pub fn read_bytes(bytes: &[u8], label: &str) -> Result<LoadedLog, LabError> {
    if let Some(format) = format_needing_map(bytes) {
        return Err(LabError::Data {
            run: label.into(),
            detail: format!(
                "a {format} log; it needs a log map (--map MAP.toml) that says which fields are \
                 the signals and command channels (see README, \"Logs of other vehicles\")"
            ),
        });
    }
    let text = std::str::from_utf8(bytes).map_err(|_| LabError::Data {
        run: label.into(),
        detail: "not UTF-8 text, and not a session".into(),
    })?;
    read_text(text, label)
}
