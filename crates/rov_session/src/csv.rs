//! Measurement CSV export and import.
//!
//! # Export ([`export_csv`])
//!
//! The measurement CSV format of `rov_types::measurement`, then one extra column per field
//! of every decoded channel.
//!
//! * **Rows** are the `/telemetry/nav` messages. `time_s` is the message time in seconds
//!   since the session's first message (any topic; `/session/info` for a recording), as
//!   numeric seconds, strictly increasing. Nav messages with the same time are merged (the
//!   later one in the file wins) and out-of-order messages are sorted, each with a warning.
//! * **Timing rule**: row k's measurements are the nav sample at t_k; row k's command is
//!   the last `/command/thrust` sent *before* t_{k+1}, i.e. the command in force during
//!   [t_k, t_{k+1}) (zero-order hold, as the measurement format defines). For the last row,
//!   t_{k+1} is t_k plus the previous interval. Before the first command, thrust is 0 %.
//!   Commands outside −100..100 % are clamped and non-finite ones become 0, with a warning.
//! * **Optional columns**: `yaw_rate_dps`, `pitch_rate_dps`, `roll_rate_dps` from nav when
//!   any nav message has them; `surge_mps`, `sway_mps`, `heave_mps`, `north_m`, `east_m`
//!   from `/truth/state` when the session has it (the last truth sample at or before t_k).
//! * **Extra columns** `topic.field` (topic without its leading `/`, `/` → `_`, e.g.
//!   `telemetry_status.tether_v`) for every JSON topic except `/session/info`, known or
//!   not (unknown topics: their top-level fields), each the last value at or before t_k
//!   (empty before the first message). Note that `command_thrust.*` is therefore the
//!   command known at t_k, while the required thrust columns follow the timing rule.
//!   Numbers as in the measurement format, flags as 1/0, lists joined with `|`, text with
//!   commas and line breaks replaced. `MeasurementSeries::parse_csv` ignores these columns
//!   (one warning per column); PlotJuggler and spreadsheets plot them.
//!
//! # Import ([`import_csv`])
//!
//! A measurement CSV becomes a session: `/session/info` (vehicle `import`) at t = 0, then
//! per row, at `time_s`, a `/telemetry/nav` (depth, attitude, rates) and the
//! `/command/thrust` in force from then on, and a `/truth/state` when the file has any of
//! the velocity or position columns (NaN in the fields it does not give). Exporting the
//! result gives back the measurement columns (times to the nanosecond).

use std::fmt::Write as _;
use std::path::Path;

use rov_types::measurement::{MeasurementRow, MeasurementSeries, OptionalChannel};

use crate::error::{Result, SessionError};
use crate::reader::Session;
use crate::record::{
    AutopilotRecord, Cell, EventRecord, JSON_ENCODING, LinkRecord, NavRecord, ObserverRecord,
    PilotRecord, Record, SessionInfo, StatusRecord, ThrustRecord, Topic, TruthRecord,
};
use crate::writer::{SessionWriter, WriteSummary, WriterOptions};

/// The result of [`export_csv`].
#[derive(Debug, Clone, PartialEq)]
pub struct CsvExport {
    /// The CSV text.
    pub text: String,
    /// Rows written.
    pub rows: usize,
    /// Extra (`topic.field`) columns written.
    pub extra_columns: Vec<String>,
    /// What was merged, sorted, clamped or left out.
    pub warnings: Vec<String>,
}

type NavGetter = fn(&NavRecord) -> Option<f64>;
type TruthGetter = fn(&TruthRecord) -> f64;

/// The measurement rows of a session (see the module docs for the timing rule), with
/// warnings. This is the export without the extra columns, and the re-simulation input.
pub fn measurements(session: &Session) -> Result<(MeasurementSeries, Vec<u64>, Vec<String>)> {
    let mut warnings = Vec::new();
    let navs = session.records::<NavRecord>()?;
    if navs.is_empty() {
        return Err(SessionError::Unusable(format!(
            "{}: no {} messages, so no measurement rows",
            session.source().display(),
            Topic::Nav.name()
        )));
    }
    let t0 = session.start_ns().unwrap_or(0);
    // Merge duplicates (time order is already stable: the later message wins).
    let mut rows_nav: Vec<(u64, NavRecord)> = Vec::with_capacity(navs.len());
    let mut merged = 0usize;
    for (t, nav) in navs {
        match rows_nav.last_mut() {
            Some(last) if last.0 == t => {
                *last = (t, nav);
                merged += 1;
            }
            _ => rows_nav.push((t, nav)),
        }
    }
    if merged > 0 {
        warnings.push(format!(
            "{merged} {} messages had the same time as the one before; the later one kept",
            Topic::Nav.name()
        ));
    }
    let thrusts = records_or_warn::<ThrustRecord>(session, &mut warnings)?;
    let truths = records_or_warn::<TruthRecord>(session, &mut warnings)?;
    let mut series = MeasurementSeries::default();
    let rate_cols: [(OptionalChannel, NavGetter); 3] = [
        (OptionalChannel::YawRateDps, |n: &NavRecord| n.yaw_rate_dps),
        (OptionalChannel::PitchRateDps, |n: &NavRecord| {
            n.pitch_rate_dps
        }),
        (OptionalChannel::RollRateDps, |n: &NavRecord| {
            n.roll_rate_dps
        }),
    ];
    for (ch, get) in rate_cols {
        if rows_nav.iter().any(|(_, n)| get(n).is_some()) {
            set_present(&mut series, ch);
        }
    }
    let truth_cols: [(OptionalChannel, TruthGetter); 5] = [
        (OptionalChannel::SurgeMps, |t| t.u_mps),
        (OptionalChannel::SwayMps, |t| t.v_mps),
        (OptionalChannel::HeaveMps, |t| t.w_mps),
        (OptionalChannel::NorthM, |t| t.north_m),
        (OptionalChannel::EastM, |t| t.east_m),
    ];
    if !truths.is_empty() {
        for (ch, _) in truth_cols {
            set_present(&mut series, ch);
        }
    }
    let mut cmd_i = 0usize;
    let mut truth_i = 0usize;
    let mut current: Option<&ThrustRecord> = None;
    let mut before_first = 0usize;
    let mut clamped = 0usize;
    let mut times = Vec::with_capacity(rows_nav.len());
    let mut prev_time_s: Option<f64> = None;
    for (k, (t, nav)) in rows_nav.iter().enumerate() {
        let t_next = match (
            rows_nav.get(k + 1),
            k.checked_sub(1).and_then(|p| rows_nav.get(p)),
        ) {
            (Some((tn, _)), _) => *tn,
            (None, Some((tp, _))) => t.saturating_add(t.saturating_sub(*tp)),
            (None, None) => t.saturating_add(1),
        };
        while let Some((tc, c)) = thrusts.get(cmd_i) {
            if *tc < t_next {
                current = Some(c);
                cmd_i += 1;
            } else {
                break;
            }
        }
        let (port, stbd, vert) = match current {
            Some(c) => (c.port_pct, c.starboard_pct, c.vertical_pct),
            None => {
                before_first += 1;
                (0.0, 0.0, 0.0)
            }
        };
        let mut fix = |x: f64| {
            let y = if x.is_finite() {
                x.clamp(-100.0, 100.0)
            } else {
                0.0
            };
            if y.to_bits() != x.to_bits() {
                clamped += 1;
            }
            y
        };
        let time_s = t.saturating_sub(t0) as f64 / 1e9;
        if prev_time_s.is_some_and(|p| time_s <= p) {
            warnings.push(format!(
                "row at t = {time_s} s does not advance time in seconds; dropped"
            ));
            continue;
        }
        prev_time_s = Some(time_s);
        let mut row = MeasurementRow {
            time_s,
            port_pct: fix(port),
            starboard_pct: fix(stbd),
            vertical_pct: fix(vert),
            depth_m: nav.depth_m,
            heading_deg: nav.heading_deg,
            pitch_deg: nav.pitch_deg,
            roll_deg: nav.roll_deg,
            optional: [None; 8],
        };
        for (ch, get) in rate_cols {
            if is_present(&series, ch) {
                row.set(ch, Some(get(nav).unwrap_or(f64::NAN)));
            }
        }
        if !truths.is_empty() {
            while truths.get(truth_i + 1).is_some_and(|(tt, _)| tt <= t) {
                truth_i += 1;
            }
            let sample = truths
                .get(truth_i)
                .filter(|(tt, _)| tt <= t)
                .map(|(_, r)| r);
            for (ch, get) in truth_cols {
                row.set(ch, Some(sample.map_or(f64::NAN, get)));
            }
        }
        series.rows.push(row);
        times.push(*t);
    }
    if before_first > 0 {
        warnings.push(format!(
            "{before_first} rows precede the first {} message; their thrust is 0 %",
            Topic::Thrust.name()
        ));
    }
    if clamped > 0 {
        warnings.push(format!(
            "{clamped} thrust values were outside -100..100 % or not finite; clamped"
        ));
    }
    Ok((series, times, warnings))
}

/// A topic's records; a topic with a foreign encoding counts as absent, with a warning.
fn records_or_warn<T: Record>(
    session: &Session,
    warnings: &mut Vec<String>,
) -> Result<Vec<(u64, T)>> {
    match session.records::<T>() {
        Err(e @ SessionError::WrongEncoding { .. }) => {
            warnings.push(format!("{e}; treated as absent"));
            Ok(Vec::new())
        }
        other => other,
    }
}

fn set_present(series: &mut MeasurementSeries, ch: OptionalChannel) {
    if let Some(p) = series.present.get_mut(ch as usize) {
        *p = true;
    }
}

fn is_present(series: &MeasurementSeries, ch: OptionalChannel) -> bool {
    series.present.get(ch as usize).copied().unwrap_or(false)
}

/// One topic's extra columns: names and (time, cells) samples in time order.
struct Extra {
    columns: Vec<String>,
    samples: Vec<(u64, Vec<Cell>)>,
}

fn typed<T: Record>(session: &Session, prefix: &str) -> Result<Extra> {
    let samples = session
        .records::<T>()?
        .into_iter()
        .map(|(t, r)| (t, r.cells()))
        .collect();
    Ok(Extra {
        columns: T::FIELDS.iter().map(|f| format!("{prefix}.{f}")).collect(),
        samples,
    })
}

fn untyped(session: &Session, topic: &str, prefix: &str, warnings: &mut Vec<String>) -> Extra {
    let mut columns: Vec<String> = Vec::new();
    let mut raw: Vec<(u64, Vec<(usize, Cell)>)> = Vec::new();
    let mut bad = 0usize;
    for m in session.topic_messages(topic) {
        let Ok(serde_json::Value::Object(obj)) =
            serde_json::from_slice::<serde_json::Value>(m.data)
        else {
            bad += 1;
            continue;
        };
        let mut cells = Vec::with_capacity(obj.len());
        for (k, v) in obj {
            let idx = match columns.iter().position(|c| *c == k) {
                Some(i) => i,
                None => {
                    columns.push(k);
                    columns.len() - 1
                }
            };
            let cell = match v {
                serde_json::Value::Null => Cell::Missing,
                serde_json::Value::Bool(b) => Cell::Bool(b),
                serde_json::Value::Number(n) => n
                    .as_u64()
                    .map_or(Cell::Num(n.as_f64().unwrap_or(f64::NAN)), Cell::Int),
                serde_json::Value::String(s) => Cell::Text(s),
                other => Cell::Text(other.to_string()),
            };
            cells.push((idx, cell));
        }
        raw.push((m.t_ns, cells));
    }
    if bad > 0 {
        warnings.push(format!(
            "{topic}: {bad} messages are not JSON objects; left out of the CSV"
        ));
    }
    let n = columns.len();
    let samples = raw
        .into_iter()
        .map(|(t, cells)| {
            let mut row = vec![Cell::Missing; n];
            for (i, c) in cells {
                if let Some(slot) = row.get_mut(i) {
                    *slot = c;
                }
            }
            (t, row)
        })
        .collect();
    Extra {
        columns: columns
            .into_iter()
            .map(|c| format!("{prefix}.{c}"))
            .collect(),
        samples,
    }
}

fn push_cell(out: &mut String, cell: &Cell) {
    match cell {
        Cell::Num(x) if x.is_nan() => out.push_str("nan"),
        Cell::Num(x) => {
            let _ = write!(out, "{x}");
        }
        Cell::Int(i) => {
            let _ = write!(out, "{i}");
        }
        Cell::Bool(b) => out.push(if *b { '1' } else { '0' }),
        Cell::Text(s) => out.extend(s.chars().map(|c| match c {
            ',' => ';',
            '\n' | '\r' => ' ',
            c => c,
        })),
        Cell::Missing => {}
    }
}

/// Column prefix of a topic: `/telemetry/status` → `telemetry_status`.
pub fn column_prefix(topic: &str) -> String {
    topic.trim_start_matches('/').replace(['/', ','], "_")
}

/// Exports a session as a measurement CSV plus every decoded channel (see the module
/// docs). Fails when the session has no `/telemetry/nav` message.
pub fn export_csv(session: &Session) -> Result<CsvExport> {
    let (series, times, mut warnings) = measurements(session)?;
    let mut extras: Vec<Extra> = Vec::new();
    for t in session.topics() {
        let prefix = column_prefix(&t.topic);
        let extra = match t.known {
            Some(Topic::SessionInfo) | Some(Topic::Pro4Tx) | Some(Topic::Pro4Rx) => continue,
            Some(Topic::Nav) => typed::<NavRecord>(session, &prefix)?,
            Some(Topic::Status) => typed::<StatusRecord>(session, &prefix)?,
            Some(Topic::Thrust) => typed::<ThrustRecord>(session, &prefix)?,
            Some(Topic::Pilot) => typed::<PilotRecord>(session, &prefix)?,
            Some(Topic::Autopilot) => typed::<AutopilotRecord>(session, &prefix)?,
            Some(Topic::Observer) => typed::<ObserverRecord>(session, &prefix)?,
            Some(Topic::Link) => typed::<LinkRecord>(session, &prefix)?,
            Some(Topic::Events) => typed::<EventRecord>(session, &prefix)?,
            Some(Topic::Truth) => typed::<TruthRecord>(session, &prefix)?,
            None if t.encoding == JSON_ENCODING => {
                untyped(session, &t.topic, &prefix, &mut warnings)
            }
            None => {
                warnings.push(format!(
                    "{}: encoding {:?} is not decoded; left out of the CSV",
                    t.topic, t.encoding
                ));
                continue;
            }
        };
        extras.push(extra);
    }
    let base = series.to_csv();
    let extra_columns: Vec<String> = extras
        .iter()
        .flat_map(|e| e.columns.iter().cloned())
        .collect();
    let mut text = String::with_capacity(base.len() + times.len() * extra_columns.len() * 8);
    let mut lines = base.lines();
    if let Some(header) = lines.next() {
        text.push_str(header);
        for c in &extra_columns {
            text.push(',');
            text.push_str(c);
        }
        text.push('\n');
    }
    let mut cursors = vec![0usize; extras.len()];
    for (line, &t) in lines.zip(&times) {
        text.push_str(line);
        for (e, cur) in extras.iter().zip(cursors.iter_mut()) {
            while e.samples.get(*cur).is_some_and(|(ts, _)| *ts <= t) {
                *cur += 1;
            }
            let sample = cur
                .checked_sub(1)
                .and_then(|i| e.samples.get(i))
                .map(|(_, c)| c);
            for i in 0..e.columns.len() {
                text.push(',');
                if let Some(cell) = sample.and_then(|c| c.get(i)) {
                    push_cell(&mut text, cell);
                }
            }
        }
        text.push('\n');
    }
    Ok(CsvExport {
        text,
        rows: series.rows.len(),
        extra_columns,
        warnings,
    })
}

/// What [`import_csv`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportReport {
    /// The writer's summary.
    pub written: WriteSummary,
    /// Rows imported.
    pub rows: usize,
    /// Warnings of the CSV reader and of the import.
    pub warnings: Vec<String>,
}

/// Imports a measurement CSV (`label` names it in errors) as a session file at `out` (see
/// the module docs).
pub fn import_csv(text: &str, label: &str, out: impl AsRef<Path>) -> Result<ImportReport> {
    let series = MeasurementSeries::parse_csv(text, label)?;
    let mut warnings = series.warnings.clone();
    let Some(first) = series.rows.first() else {
        return Err(SessionError::Unusable(format!("{label}: no data rows")));
    };
    let shift = if first.time_s < 0.0 {
        warnings.push(format!(
            "{label}: time starts at {} s; shifted by {} s so the session starts at 0",
            first.time_s, -first.time_s
        ));
        -first.time_s
    } else {
        0.0
    };
    let mut times = Vec::with_capacity(series.rows.len());
    for row in &series.rows {
        let t = ((row.time_s + shift) * 1e9).round();
        if !(t.is_finite() && (0.0..1.8e19).contains(&t)) {
            return Err(SessionError::Unusable(format!(
                "{label}: time_s = {} cannot be stored in nanoseconds",
                row.time_s
            )));
        }
        let t = t as u64;
        if times.last().is_some_and(|&p| t <= p) {
            return Err(SessionError::Unusable(format!(
                "{label}: rows at {} s and the one before are less than 1 ns apart",
                row.time_s
            )));
        }
        times.push(t);
    }
    let info = SessionInfo {
        vehicle: "import".into(),
        software_version: format!("rov_session {}", env!("CARGO_PKG_VERSION")),
        started_unix_s: f64::NAN,
        config_toml: String::new(),
    };
    // An import is not a live recording: flush rarely, sync once at the end.
    let opts = WriterOptions {
        flush_interval_ns: 10_000_000_000,
        sync_interval_ns: u64::MAX,
        ..WriterOptions::default()
    };
    let mut w = SessionWriter::create_with(out, &info, 0, opts)?;
    let has = |ch: OptionalChannel| series.present.get(ch as usize).copied().unwrap_or(false);
    let has_truth = [
        OptionalChannel::SurgeMps,
        OptionalChannel::SwayMps,
        OptionalChannel::HeaveMps,
        OptionalChannel::NorthM,
        OptionalChannel::EastM,
    ]
    .into_iter()
    .any(has);
    let opt = |row: &MeasurementRow, ch: OptionalChannel| if has(ch) { row.get(ch) } else { None };
    for (row, &t) in series.rows.iter().zip(&times) {
        let nav = NavRecord {
            heading_deg: row.heading_deg,
            pitch_deg: row.pitch_deg,
            roll_deg: row.roll_deg,
            depth_m: row.depth_m,
            yaw_rate_dps: opt(row, OptionalChannel::YawRateDps),
            pitch_rate_dps: opt(row, OptionalChannel::PitchRateDps),
            roll_rate_dps: opt(row, OptionalChannel::RollRateDps),
            ..NavRecord::default()
        };
        w.write(t, &nav)?;
        let thrust = ThrustRecord {
            port_pct: row.port_pct,
            starboard_pct: row.starboard_pct,
            vertical_pct: row.vertical_pct,
            lights_pct: 0.0,
            tilt: 0.0,
            focus: 0.0,
            depth_target_mbar: None,
            heading_target_deg: None,
        };
        w.write(t, &thrust)?;
        if has_truth {
            let g = |ch| opt(row, ch).unwrap_or(f64::NAN);
            let truth = TruthRecord {
                north_m: g(OptionalChannel::NorthM),
                east_m: g(OptionalChannel::EastM),
                u_mps: g(OptionalChannel::SurgeMps),
                v_mps: g(OptionalChannel::SwayMps),
                w_mps: g(OptionalChannel::HeaveMps),
                ..TruthRecord::default()
            };
            w.write(t, &truth)?;
        }
    }
    let written = w.finish()?;
    Ok(ImportReport {
        written,
        rows: series.rows.len(),
        warnings,
    })
}
