//! A log read through a log map ([`rov_logs`]) as lab runs.
//!
//! The map gives each canonical signal and command channel its own timestamped series;
//! [`rov_logs::MappedLog::lab_table`] puts them on the measurement times (commands by
//! zero-order hold, measurements never invented) and this module builds the lab's
//! measurement series and command vectors from that table, then the runs as for any log
//! ([`crate::ingest::series_runs`]: gaps split, spikes excluded, closed loop detected).
//!
//! The lab's command vocabulary is [`CommandChannel`]: a map's command channel must be one
//! of its names (`port`, `starboard`, `vertical`, `lateral`, `surge` … `yaw`); another
//! name is [`LabError::UndeclaredChannel`]. The Pro 4 view of a row (port, starboard,
//! vertical) is 0 % where the map has no such channel. A required signal the map lacks
//! (depth, heading, pitch, roll) is missing (NaN), never zero.

use rov_dynamics::models::vehicle::{CommandChannel, Commands, N_COMMANDS};
use rov_logs::{LogMap, MappedLog};
use rov_types::measurement::{MeasurementRow, MeasurementSeries, OPTIONAL_COLUMNS};

use crate::LabError;
use crate::data::Run;

/// A mapped log as the lab's series and its command channels.
#[derive(Debug, Clone)]
pub struct MappedSeries {
    /// The measurement series (Pro 4 command view).
    pub series: MeasurementSeries,
    /// Every command channel per row, %.
    pub inputs: Vec<Commands>,
    /// Which command channels the map gives.
    pub present: [bool; N_COMMANDS],
    /// What was done and met, in words (reader report, clamping, dropped rows).
    pub notes: Vec<String>,
    /// Rows dropped because their time did not increase.
    pub dropped_rows: usize,
}

/// The series of a mapped log.
pub fn mapped_series(mapped: &MappedLog, map_label: &str) -> Result<MappedSeries, LabError> {
    let mut channels: Vec<(CommandChannel, &Vec<f64>)> = Vec::new();
    let table = mapped.lab_table();
    for (name, col) in &table.commands {
        let c = CommandChannel::parse(name).ok_or_else(|| LabError::UndeclaredChannel {
            map: map_label.into(),
            channel: name.clone(),
            known: CommandChannel::ALL.map(CommandChannel::name).join(", "),
        })?;
        channels.push((c, col));
    }
    let mut present = [false; N_COMMANDS];
    for (c, _) in &channels {
        present[c.index()] = true;
    }
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
    let mut inputs = Vec::with_capacity(table.t_s.len());
    for (k, t) in table.t_s.iter().enumerate() {
        let mut cmd: Commands = [0.0; N_COMMANDS];
        for (c, col) in &channels {
            cmd[c.index()] = col.get(k).copied().filter(|x| x.is_finite()).unwrap_or(0.0);
        }
        let mut row = MeasurementRow {
            time_s: *t,
            port_pct: cmd[CommandChannel::Port.index()],
            starboard_pct: cmd[CommandChannel::Starboard.index()],
            vertical_pct: cmd[CommandChannel::Vertical.index()],
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
        inputs.push(cmd);
    }
    let mut notes = mapped.sentences();
    if table.rows_before_commands > 0 {
        notes.push(format!(
            "{} measurement time(s) before every command channel had a sample were dropped",
            table.rows_before_commands
        ));
    }
    Ok(MappedSeries {
        series,
        inputs,
        present,
        notes,
        dropped_rows: mapped.report.non_increasing,
    })
}

/// Reads a log (bytes) through a map into lab runs.
pub fn mapped_runs(bytes: &[u8], map: &LogMap, label: &str) -> Result<Vec<Run>, LabError> {
    let mapped = map.read_apply(bytes, label)?;
    let m = mapped_series(&mapped, &map.label)?;
    let mut runs = crate::ingest::series_runs(&m.series, label, Some((m.inputs, m.present)))?;
    for r in &mut runs {
        r.treatment.dropped_time_rows = m.dropped_rows;
        r.treatment
            .notes
            .push(format!("read through the log map {}", map.label));
        r.treatment.notes.extend(m.notes.iter().cloned());
    }
    Ok(runs)
}
