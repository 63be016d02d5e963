//! A log read through a log map ([`rov_logs`]) as lab runs.
//!
//! The map gives each canonical signal and command channel its own timestamped series;
//! [`rov_logs::MappedLog::lab_table`] puts them on the measurement times (commands by
//! zero-order hold, measurements never invented) and this module builds the lab's
//! measurement series and command vectors from that table, then the runs as for any log
//! ([`crate::ingest::series_runs`]: gaps split, spikes excluded, closed loop detected).
//!
//! A map's command channels are any names a vehicle file can declare: the built-in ones
//! (`port`, `starboard`, `vertical`, `lateral`, `surge` … `yaw`) keep their meaning, any
//! other valid name becomes a free channel of the runs ([`Run::runs_from_named_commands`]),
//! which a vehicle file's `mix_NAME` keys drive. The Pro 4 view of a row (port,
//! starboard, vertical) is 0 % where the map has no such channel. A required signal the
//! map lacks (depth, heading, pitch, roll) is missing (NaN), never zero.

use rov_dynamics::models::vehicle::{CommandChannel, Commands, N_COMMANDS, valid_channel_name};
use rov_logs::{LogMap, MappedLog};
use rov_types::measurement::{MeasurementRow, MeasurementSeries, OPTIONAL_COLUMNS};

use crate::LabError;
use crate::data::Run;

/// A mapped log as the lab's series and its command channels.
#[derive(Debug, Clone)]
pub struct MappedSeries {
    /// The measurement series (Pro 4 command view).
    pub series: MeasurementSeries,
    /// Each command channel the map gives (name, % on the series' rows), in name order.
    pub commands: Vec<(String, Vec<f64>)>,
    /// What was done and met, in words (reader report, clamping, dropped rows).
    pub notes: Vec<String>,
    /// Rows dropped because their time did not increase.
    pub dropped_rows: usize,
}

/// The series of a mapped log.
pub fn mapped_series(mapped: &MappedLog, map_label: &str) -> Result<MappedSeries, LabError> {
    let table = mapped.lab_table();
    for name in table.commands.keys() {
        if !valid_channel_name(name) {
            return Err(LabError::UndeclaredChannel {
                map: map_label.into(),
                channel: name.clone(),
                known: "a name of 1 to 32 characters a-z, 0-9 and _, starting with a letter \
                        (port, starboard, vertical, lateral, surge, sway, heave, roll, pitch, \
                        yaw keep their built-in meaning)"
                    .into(),
            });
        }
    }
    let command = |name: &str, k: usize| -> f64 {
        table
            .commands
            .get(name)
            .and_then(|c| c.get(k))
            .copied()
            .filter(|x| x.is_finite())
            .unwrap_or(0.0)
    };
    let sig = |name: &str| table.signals.get(name);
    let mut opt_present = [false; 8];
    let opt_cols: Vec<Option<&Vec<f64>>> = OPTIONAL_COLUMNS.iter().map(|name| sig(name)).collect();
    for (p, c) in opt_present.iter_mut().zip(&opt_cols) {
        *p = c.is_some();
    }
    let at = |col: Option<&Vec<f64>>, k: usize| -> f64 {
        col.and_then(|c| c.get(k)).copied().unwrap_or(f64::NAN)
    };
    let mut series = MeasurementSeries {
        present: opt_present,
        ..Default::default()
    };
    for (k, t) in table.t_s.iter().enumerate() {
        let mut row = MeasurementRow {
            time_s: *t,
            port_pct: command("port", k),
            starboard_pct: command("starboard", k),
            vertical_pct: command("vertical", k),
            depth_m: at(sig("depth_m"), k),
            heading_deg: at(sig("heading_deg"), k),
            pitch_deg: at(sig("pitch_deg"), k),
            roll_deg: at(sig("roll_deg"), k),
            optional: [None; 8],
        };
        for (slot, col) in row.optional.iter_mut().zip(&opt_cols) {
            *slot = col.map(|_| at(*col, k)).filter(|x| x.is_finite());
        }
        series.rows.push(row);
    }
    let mut notes = mapped.sentences();
    if table.rows_before_commands > 0 {
        notes.push(format!(
            "{} measurement time(s) before every command channel had a sample were dropped",
            table.rows_before_commands
        ));
    }
    let commands = table
        .commands
        .iter()
        .map(|(n, v)| (n.clone(), v.clone()))
        .collect();
    Ok(MappedSeries {
        series,
        commands,
        notes,
        dropped_rows: mapped.report.non_increasing,
    })
}

impl MappedSeries {
    /// The built-in command channels as command vectors per row, and which the map gives
    /// (free-named channels are not in this view; [`mapped_runs`] keeps them).
    pub fn builtin_inputs(&self) -> (Vec<Commands>, [bool; N_COMMANDS]) {
        let mut present = [false; N_COMMANDS];
        let mut inputs: Vec<Commands> = vec![[0.0; N_COMMANDS]; self.series.rows.len()];
        for (name, values) in &self.commands {
            let Some(c) = CommandChannel::parse_builtin(name) else {
                continue;
            };
            present[c.index()] = true;
            for (inp, v) in inputs.iter_mut().zip(values) {
                if let Some(slot) = inp.get_mut(c.index()) {
                    *slot = if v.is_finite() { *v } else { 0.0 };
                }
            }
        }
        (inputs, present)
    }
}

/// Reads a log (bytes) through a map into lab runs ([`crate::loader::read_mapped`], then
/// [`crate::loader::LoadedLog::runs`]).
pub fn mapped_runs(bytes: &[u8], map: &LogMap, label: &str) -> Result<Vec<Run>, LabError> {
    crate::loader::read_mapped(bytes, map, label)?.runs()
}
