//! Measurement CSV export and import.
//!
//! # Export ([`export_csv_to`], [`export_csv`])
//!
//! The measurement CSV format of `rov_types::measurement`, then one extra column per field
//! of every decoded channel. The export streams: one read of the session in time order,
//! each row written as soon as its command is known, so memory does not grow with the
//! length of the session.
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
//!   the first [`DISCOVERY_SAMPLES`] nav messages have them; `surge_mps`, `sway_mps`,
//!   `heave_mps`, `north_m`, `east_m` from `/truth/state` when the session has it (the last
//!   truth sample at or before t_k).
//! * **Extra columns** `topic.field` (topic without its leading `/`, `/` → `_`, e.g.
//!   `telemetry_status.tether_v`) for every JSON topic except `/session/info`, known or
//!   not (unknown topics: the top-level fields of their first [`DISCOVERY_SAMPLES`]
//!   messages; a field first seen later is left out, with a warning), each the last value
//!   at or before t_k (empty before the first message). Note that `command_thrust.*` is
//!   therefore the command known at t_k, while the required thrust columns follow the
//!   timing rule. The raw frames and the Foxglove topics (pose, track, video) are not
//!   columns.
//! * **Numbers** in the shortest form that reads back to the same value
//!   (`rov_types::number`), flags as 1/0, lists joined with `|`, text with commas and line
//!   breaks replaced. `MeasurementSeries::parse_csv` ignores the extra columns (one
//!   warning per column); PlotJuggler and spreadsheets plot them.
//!
//! # Import ([`import_csv`])
//!
//! A measurement CSV becomes a session: `/session/info` (vehicle `import`) at t = 0, then
//! per row, at `time_s`, a `/telemetry/nav` (depth, attitude, rates) and the
//! `/command/thrust` in force from then on, and a `/truth/state` when the file has any of
//! the velocity or position columns (NaN in the fields it does not give). Exporting the
//! result gives back the measurement columns (times to the nanosecond).

use std::ops::ControlFlow;
use std::path::Path;

use rov_types::measurement::{
    MeasurementRow, MeasurementSeries, OPTIONAL_COLUMNS, OptionalChannel, REQUIRED_COLUMNS,
};
use rov_types::number::{push_f64, push_u64};

use crate::error::{Result, SessionError};
use crate::message::Message;
use crate::record::{
    AutopilotRecord, Cell, EventRecord, LinkRecord, NavRecord, ObserverRecord, PilotRecord, Record,
    SessionInfo, StatusRecord, ThrustRecord, Topic, TruthRecord,
};
use crate::session::Session;
use crate::stream::{ReadOptions, ReadReport};
use crate::writer::{SessionWriter, WriteSummary, WriterOptions};

/// Messages of a topic read before the export fixes its columns.
pub const DISCOVERY_SAMPLES: usize = 1000;

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

/// What [`export_csv_to`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct CsvSummary {
    /// Rows written.
    pub rows: usize,
    /// Extra (`topic.field`) columns written.
    pub extra_columns: Vec<String>,
    /// What was merged, sorted, clamped or left out, and what the read found.
    pub warnings: Vec<String>,
    /// What the read of the session found (damage, messages out of order, gaps).
    pub read: ReadReport,
}

type NavGetter = fn(&NavRecord) -> Option<f64>;
type TruthGetter = fn(&TruthRecord) -> f64;

const RATE_COLS: [(OptionalChannel, NavGetter); 3] = [
    (OptionalChannel::YawRateDps, |n| n.yaw_rate_dps),
    (OptionalChannel::PitchRateDps, |n| n.pitch_rate_dps),
    (OptionalChannel::RollRateDps, |n| n.roll_rate_dps),
];

const TRUTH_COLS: [(OptionalChannel, TruthGetter); 5] = [
    (OptionalChannel::SurgeMps, |t| t.u_mps),
    (OptionalChannel::SwayMps, |t| t.v_mps),
    (OptionalChannel::HeaveMps, |t| t.w_mps),
    (OptionalChannel::NorthM, |t| t.north_m),
    (OptionalChannel::EastM, |t| t.east_m),
];

/// One topic's extra columns and its latest cells.
struct Extra {
    topic: String,
    known: Option<Topic>,
    /// The fields (JSON keys), and their column names.
    fields: Vec<String>,
    columns: Vec<String>,
    latest: Option<Vec<Cell>>,
    bad: usize,
    late_fields: Vec<String>,
}

impl Extra {
    fn update(&mut self, m: &Message) -> Result<()> {
        let cells = match self.known {
            Some(Topic::Nav) => m.decode::<NavRecord>()?.cells(),
            Some(Topic::Status) => m.decode::<StatusRecord>()?.cells(),
            Some(Topic::Thrust) => m.decode::<ThrustRecord>()?.cells(),
            Some(Topic::Pilot) => m.decode::<PilotRecord>()?.cells(),
            Some(Topic::Autopilot) => m.decode::<AutopilotRecord>()?.cells(),
            Some(Topic::Observer) => m.decode::<ObserverRecord>()?.cells(),
            Some(Topic::Link) => m.decode::<LinkRecord>()?.cells(),
            Some(Topic::Events) => m.decode::<EventRecord>()?.cells(),
            Some(Topic::Truth) => m.decode::<TruthRecord>()?.cells(),
            _ => match untyped_cells(m.data(), &self.fields) {
                Some((cells, late)) => {
                    for f in late {
                        if !self.late_fields.contains(&f) && self.late_fields.len() < 16 {
                            self.late_fields.push(f);
                        }
                    }
                    cells
                }
                None => {
                    self.bad += 1;
                    return Ok(());
                }
            },
        };
        self.latest = Some(cells);
        Ok(())
    }
}

fn json_cell(v: serde_json::Value) -> Cell {
    match v {
        serde_json::Value::Null => Cell::Missing,
        serde_json::Value::Bool(b) => Cell::Bool(b),
        serde_json::Value::Number(n) => n
            .as_u64()
            .map_or(Cell::Num(n.as_f64().unwrap_or(f64::NAN)), Cell::Int),
        serde_json::Value::String(s) => Cell::Text(s),
        other => Cell::Text(other.to_string()),
    }
}

/// The cells of an unknown JSON topic's message in `columns` order, and its fields that
/// have no column; `None` when it is not a JSON object.
fn untyped_cells(data: &[u8], columns: &[String]) -> Option<(Vec<Cell>, Vec<String>)> {
    let serde_json::Value::Object(obj) = serde_json::from_slice::<serde_json::Value>(data).ok()?
    else {
        return None;
    };
    let mut cells = vec![Cell::Missing; columns.len()];
    let mut late = Vec::new();
    for (k, v) in obj {
        match columns.iter().position(|c| *c == k) {
            Some(i) => {
                if let Some(slot) = cells.get_mut(i) {
                    *slot = json_cell(v);
                }
            }
            None => late.push(k),
        }
    }
    Some((cells, late))
}

fn push_cell(out: &mut String, cell: &Cell) {
    match cell {
        Cell::Num(x) => push_f64(out, *x),
        Cell::Int(i) => push_u64(out, *i),
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

/// A row waiting for its command (the next nav message's time).
struct Pending {
    t_ns: u64,
    nav: NavRecord,
    /// t_k + the previous interval: the end of the last row's hold.
    guess_next_ns: u64,
    /// The last command before `guess_next_ns` (used if this is the last row).
    cmd_before_guess: Option<ThrustRecord>,
    /// Truth and extra cells at t_k, taken once time has moved past t_k.
    truth: Option<Option<TruthRecord>>,
    extras_text: Option<String>,
}

/// Builds measurement rows from a time-ordered read; see the module docs for the rule.
struct Rows<'a> {
    t0: u64,
    rates: [bool; 3],
    has_truth: bool,
    extras: Vec<Extra>,
    /// The last command sent strictly before the current time, and the latest one.
    cmd_before: Option<ThrustRecord>,
    cmd_latest: Option<(u64, ThrustRecord)>,
    truth_latest: Option<TruthRecord>,
    cur_t: Option<u64>,
    pending: Option<Pending>,
    last_nav_t: Option<u64>,
    prev_time_s: Option<f64>,
    merged: usize,
    before_first: usize,
    clamped: usize,
    dropped: Vec<String>,
    sink: &'a mut dyn RowSink,
    rows: usize,
}

/// Where rows go: the export's CSV text, or a series in memory.
trait RowSink {
    /// The header line (measurement columns, then the extra columns) and which optional
    /// measurement columns it has, before any row.
    fn header(&mut self, header: &str, present: &[bool; 8]) -> Result<()>;
    /// One row: its time (ns), the measurement cells, the extra cells (each led by a comma).
    fn row(&mut self, t_ns: u64, row: &MeasurementRow, extras: &str) -> Result<()>;
}

impl Rows<'_> {
    /// Time moves to `t`: settle what "before t" and "at or before the pending row" mean.
    fn advance_to(&mut self, t: u64) {
        if self.cur_t.is_some_and(|c| t <= c) {
            return;
        }
        if let Some((_, c)) = &self.cmd_latest {
            self.cmd_before = Some(c.clone());
        }
        self.cur_t = Some(t);
        self.snapshot_pending();
    }

    /// Takes the pending row's truth and extras (everything at or before t_k has been seen).
    fn snapshot_pending(&mut self) {
        let Some(p) = &mut self.pending else {
            return;
        };
        if p.truth.is_none() {
            p.truth = Some(self.truth_latest.clone());
        }
        if p.extras_text.is_none() {
            let mut s = String::new();
            for e in &self.extras {
                for i in 0..e.columns.len() {
                    s.push(',');
                    if let Some(cell) = e.latest.as_ref().and_then(|c| c.get(i)) {
                        push_cell(&mut s, cell);
                    }
                }
            }
            p.extras_text = Some(s);
        }
    }

    fn message(&mut self, m: &Message) -> Result<()> {
        self.advance_to(m.t_ns);
        match m.known() {
            Some(Topic::Nav) => {
                let nav = m.decode::<NavRecord>()?;
                if let Some(e) = self.extras.iter_mut().find(|e| e.known == Some(Topic::Nav)) {
                    e.latest = Some(nav.cells());
                }
                if let Some(p) = &mut self.pending
                    && p.t_ns == m.t_ns
                {
                    p.nav = nav;
                    p.extras_text = None;
                    p.truth = None;
                    self.merged += 1;
                    return Ok(());
                }
                let cmd = self.cmd_before.clone();
                self.flush_pending(cmd)?;
                let guess = match self.last_nav_t {
                    Some(prev) => m.t_ns.saturating_add(m.t_ns.saturating_sub(prev)),
                    None => m.t_ns.saturating_add(1),
                };
                self.last_nav_t = Some(m.t_ns);
                let cmd_before_guess = self.cmd_latest.as_ref().map(|(_, c)| c.clone());
                self.pending = Some(Pending {
                    t_ns: m.t_ns,
                    nav,
                    guess_next_ns: guess,
                    cmd_before_guess,
                    truth: None,
                    extras_text: None,
                });
                return Ok(());
            }
            Some(Topic::Thrust) => {
                let c = m.decode::<ThrustRecord>()?;
                if let Some(p) = &mut self.pending
                    && m.t_ns < p.guess_next_ns
                {
                    p.cmd_before_guess = Some(c.clone());
                }
                self.cmd_latest = Some((m.t_ns, c));
            }
            Some(Topic::Truth) if self.has_truth => {
                self.truth_latest = Some(m.decode::<TruthRecord>()?);
            }
            _ => {}
        }
        if let Some(e) = self.extras.iter_mut().find(|e| e.topic == m.topic()) {
            e.update(m)?;
        }
        Ok(())
    }

    /// Writes the pending row with its command.
    fn flush_pending(&mut self, cmd: Option<ThrustRecord>) -> Result<()> {
        self.snapshot_pending();
        let Some(p) = self.pending.take() else {
            return Ok(());
        };
        let (port, stbd, vert) = match &cmd {
            Some(c) => (c.port_pct, c.starboard_pct, c.vertical_pct),
            None => {
                self.before_first += 1;
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
                self.clamped += 1;
            }
            y
        };
        let time_s = p.t_ns.saturating_sub(self.t0) as f64 / 1e9;
        if self.prev_time_s.is_some_and(|q| time_s <= q) {
            if self.dropped.len() < 20 {
                self.dropped.push(format!(
                    "row at t = {time_s} s does not advance time in seconds; dropped"
                ));
            }
            return Ok(());
        }
        self.prev_time_s = Some(time_s);
        let nav = &p.nav;
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
        for ((ch, get), on) in RATE_COLS.iter().zip(self.rates) {
            if on {
                row.set(*ch, Some(get(nav).unwrap_or(f64::NAN)));
            }
        }
        if self.has_truth {
            let truth = p.truth.flatten();
            for (ch, get) in TRUTH_COLS {
                row.set(ch, Some(truth.as_ref().map_or(f64::NAN, get)));
            }
        }
        self.sink
            .row(p.t_ns, &row, p.extras_text.as_deref().unwrap_or(""))?;
        self.rows += 1;
        Ok(())
    }

    fn finish(&mut self) -> Result<Vec<String>> {
        self.snapshot_pending();
        let cmd = self
            .pending
            .as_ref()
            .and_then(|p| p.cmd_before_guess.clone());
        self.flush_pending(cmd)?;
        let mut w = Vec::new();
        if self.merged > 0 {
            w.push(format!(
                "{} {} messages had the same time as the one before; the later one kept",
                self.merged,
                Topic::Nav.name()
            ));
        }
        w.append(&mut self.dropped);
        if self.before_first > 0 {
            w.push(format!(
                "{} rows precede the first {} message; their thrust is 0 %",
                self.before_first,
                Topic::Thrust.name()
            ));
        }
        if self.clamped > 0 {
            w.push(format!(
                "{} thrust values were outside -100..100 % or not finite; clamped",
                self.clamped
            ));
        }
        for e in &self.extras {
            if e.bad > 0 {
                w.push(format!(
                    "{}: {} messages are not JSON objects; left out of the CSV",
                    e.topic, e.bad
                ));
            }
            if !e.late_fields.is_empty() {
                w.push(format!(
                    "{}: fields {} first appear after the first {DISCOVERY_SAMPLES} messages; left out of the CSV",
                    e.topic,
                    e.late_fields.join(", ")
                ));
            }
        }
        Ok(w)
    }
}

/// Whether a topic of the session is absent or usable as `T` (a foreign encoding counts as
/// absent, with a warning).
fn usable<T: Record>(session: &Session, warnings: &mut Vec<String>) -> bool {
    let t = T::TOPIC;
    match session.topics().into_iter().find(|s| s.topic == t.name()) {
        None => false,
        Some(s) if s.known.is_none() => {
            warnings.push(
                format!(
                    "{}",
                    SessionError::WrongEncoding {
                        topic: t.name().into(),
                        found: s.encoding,
                        expected: t.encoding(),
                    }
                ) + "; treated as absent",
            );
            false
        }
        Some(s) => s.count > 0,
    }
}

/// Which rate columns the first nav messages carry.
fn discover_rates(session: &Session) -> Result<[bool; 3]> {
    let mut rates = [false; 3];
    for r in session
        .record_stream::<NavRecord>()?
        .take(DISCOVERY_SAMPLES)
    {
        let (_, nav) = r?;
        for ((_, get), on) in RATE_COLS.iter().zip(rates.iter_mut()) {
            *on |= get(&nav).is_some();
        }
    }
    Ok(rates)
}

/// What a pass over the rows found.
struct RowsDone {
    rows: usize,
    rates: [bool; 3],
    has_truth: bool,
    extra_columns: Vec<String>,
    warnings: Vec<String>,
    read: ReadReport,
}

/// Runs the rows of a session into `sink`: the header, then each row in time order.
fn build_rows(session: &Session, with_extras: bool, sink: &mut dyn RowSink) -> Result<RowsDone> {
    let mut warnings = Vec::new();
    if session.count(Topic::Nav.name()) == 0 {
        return Err(SessionError::Unusable(format!(
            "{}: no {} messages, so no measurement rows",
            session.source().display(),
            Topic::Nav.name()
        )));
    }
    let rates = discover_rates(session)?;
    let has_thrust = usable::<ThrustRecord>(session, &mut warnings);
    let has_truth = usable::<TruthRecord>(session, &mut warnings);
    let mut topics: Vec<String> = vec![Topic::Nav.name().to_string()];
    if has_thrust {
        topics.push(Topic::Thrust.name().to_string());
    }
    if has_truth {
        topics.push(Topic::Truth.name().to_string());
    }
    let mut extras = Vec::new();
    if with_extras {
        for t in session.topics() {
            let known_json = t
                .known
                .is_some_and(|k| k.is_json() && k != Topic::SessionInfo);
            let unknown_json = t.known.is_none() && t.encoding == crate::record::JSON_ENCODING;
            if !(known_json || unknown_json) {
                if t.known.is_none() {
                    warnings.push(format!(
                        "{}: encoding {:?} is not decoded; left out of the CSV",
                        t.topic, t.encoding
                    ));
                }
                continue;
            }
            let prefix = column_prefix(&t.topic);
            let fields: Vec<String> = match t.known {
                Some(k) => crate::record::fields_of(k)
                    .iter()
                    .map(|f| (*f).to_string())
                    .collect(),
                None => {
                    let mut cols: Vec<String> = Vec::new();
                    for m in session.topic_messages(&t.topic).take(DISCOVERY_SAMPLES) {
                        if let Ok(serde_json::Value::Object(obj)) =
                            serde_json::from_slice::<serde_json::Value>(m.data())
                        {
                            for k in obj.keys() {
                                if !cols.contains(k) {
                                    cols.push(k.clone());
                                }
                            }
                        }
                    }
                    cols
                }
            };
            if !topics.contains(&t.topic) {
                topics.push(t.topic.clone());
            }
            extras.push(Extra {
                topic: t.topic.clone(),
                known: t.known,
                columns: fields.iter().map(|f| format!("{prefix}.{f}")).collect(),
                fields,
                latest: None,
                bad: 0,
                late_fields: Vec::new(),
            });
        }
    }
    let mut rows = Rows {
        t0: session.start_ns().unwrap_or(0),
        rates,
        has_truth,
        extras,
        cmd_before: None,
        cmd_latest: None,
        truth_latest: None,
        cur_t: None,
        pending: None,
        last_nav_t: None,
        prev_time_s: None,
        merged: 0,
        before_first: 0,
        clamped: 0,
        dropped: Vec::new(),
        sink,
        rows: 0,
    };
    let extra_columns: Vec<String> = rows
        .extras
        .iter()
        .flat_map(|e| e.columns.iter().cloned())
        .collect();
    let mut header = measurement_header(rates, has_truth);
    for c in &extra_columns {
        header.push(',');
        header.push_str(c);
    }
    header.push('\n');
    let mut present = [false; 8];
    for (i, p) in present.iter_mut().enumerate() {
        *p = match i {
            0..=2 => rates.get(i).copied().unwrap_or(false),
            _ => has_truth,
        };
    }
    rows.sink.header(&header, &present)?;
    let mut read = session.read(ReadOptions::topics(&topics));
    for m in read.by_ref() {
        rows.message(&m)?;
    }
    let mut w = rows.finish()?;
    warnings.append(&mut w);
    let report = read.report();
    warnings.extend(report.warnings.iter().cloned());
    Ok(RowsDone {
        rows: rows.rows,
        rates,
        has_truth,
        extra_columns,
        warnings,
        read: report,
    })
}

/// The header of the measurement columns.
fn measurement_header(rates: [bool; 3], has_truth: bool) -> String {
    let mut h: Vec<&str> = REQUIRED_COLUMNS.to_vec();
    for (i, name) in OPTIONAL_COLUMNS.iter().enumerate() {
        let on = match i {
            0..=2 => rates.get(i).copied().unwrap_or(false),
            _ => has_truth,
        };
        if on {
            h.push(name);
        }
    }
    h.join(",")
}

/// The rows collected in memory.
#[derive(Default)]
struct SeriesSink {
    rows: Vec<MeasurementRow>,
    times: Vec<u64>,
}

impl RowSink for SeriesSink {
    fn header(&mut self, _: &str, _: &[bool; 8]) -> Result<()> {
        Ok(())
    }
    fn row(&mut self, t_ns: u64, row: &MeasurementRow, _: &str) -> Result<()> {
        self.rows.push(*row);
        self.times.push(t_ns);
        Ok(())
    }
}

/// Which optional measurement columns a pass found.
fn present_of(done: &RowsDone) -> [bool; 8] {
    let mut present = [false; 8];
    for (i, on) in done.rates.iter().enumerate() {
        if let Some(p) = present.get_mut(i) {
            *p = *on;
        }
    }
    for (ch, _) in TRUTH_COLS {
        if let Some(p) = present.get_mut(ch as usize) {
            *p = done.has_truth;
        }
    }
    present
}

/// The measurement rows of a session (see the module docs for the timing rule), their
/// times (ns) and warnings: the export without the extra columns, and the input of the
/// model lab (`lab`, `sim run`, `replay --model`, the replay's model overlay). Reads only nav, thrust and truth, in one pass. Holds every
/// row (192 B each); a long session streams through [`measurements_each`] instead.
pub fn measurements(session: &Session) -> Result<(MeasurementSeries, Vec<u64>, Vec<String>)> {
    let mut sink = SeriesSink::default();
    let done = build_rows(session, false, &mut sink)?;
    let series = MeasurementSeries {
        rows: sink.rows,
        present: present_of(&done),
        warnings: Vec::new(),
    };
    Ok((series, sink.times, done.warnings))
}

/// What [`measurements_each`] passed on.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MeasurementsStreamed {
    /// Rows passed on.
    pub rows: usize,
    /// Which optional columns ([`rov_types::measurement::OPTIONAL_COLUMNS`]) the rows have.
    pub present: [bool; 8],
    /// Warnings of the pass (as [`measurements`] gives them).
    pub warnings: Vec<String>,
}

/// The rows of [`measurements`] handed one at a time, in time order, to `each` (time in
/// ns and the row) and not kept: memory stays flat however long the session is. Reads
/// only nav, thrust and truth, in one pass.
pub fn measurements_each(
    session: &Session,
    each: &mut dyn FnMut(u64, &MeasurementRow),
) -> Result<MeasurementsStreamed> {
    let mut go_on = |t_ns: u64, row: &MeasurementRow| {
        each(t_ns, row);
        ControlFlow::Continue(())
    };
    // `go_on` never breaks, so the pass always ends with the whole result.
    measurements_until(session, &mut go_on).map(|done| done.unwrap_or_default())
}

/// [`measurements_each`] that stops reading as soon as `each` breaks (a load the user
/// cancelled): `Ok(None)` then, without reading the rest of the session.
pub fn measurements_until(
    session: &Session,
    each: &mut dyn FnMut(u64, &MeasurementRow) -> ControlFlow<()>,
) -> Result<Option<MeasurementsStreamed>> {
    let mut sink = FnSink {
        each,
        stopped: false,
    };
    let done = build_rows(session, false, &mut sink);
    if sink.stopped {
        return Ok(None);
    }
    let done = done?;
    Ok(Some(MeasurementsStreamed {
        rows: done.rows,
        present: present_of(&done),
        warnings: done.warnings,
    }))
}

/// Rows handed to a closure until it breaks.
struct FnSink<'a> {
    each: &'a mut dyn FnMut(u64, &MeasurementRow) -> ControlFlow<()>,
    /// The closure broke: the pass is ended by an error that is not one.
    stopped: bool,
}

impl RowSink for FnSink<'_> {
    fn header(&mut self, _: &str, _: &[bool; 8]) -> Result<()> {
        Ok(())
    }
    fn row(&mut self, t_ns: u64, row: &MeasurementRow, _: &str) -> Result<()> {
        if (self.each)(t_ns, row).is_break() {
            self.stopped = true;
            // Ends `build_rows` at once; `measurements_until` reports the stop, never
            // this error.
            return Err(SessionError::Unusable("stopped by the reader".into()));
        }
        Ok(())
    }
}

/// Rows written as CSV text to an output.
struct TextSink<'a> {
    out: &'a mut dyn std::io::Write,
    line: String,
    /// The optional columns of the header.
    present: [bool; 8],
}

impl TextSink<'_> {
    fn write(&mut self, bytes: &[u8]) -> Result<()> {
        self.out.write_all(bytes).map_err(|e| SessionError::Io {
            path: "CSV output".into(),
            action: "write",
            source: e,
        })
    }
}

impl RowSink for TextSink<'_> {
    fn header(&mut self, header: &str, present: &[bool; 8]) -> Result<()> {
        self.present = *present;
        self.write(header.as_bytes())
    }
    fn row(&mut self, _: u64, row: &MeasurementRow, extras: &str) -> Result<()> {
        let mut line = std::mem::take(&mut self.line);
        line.clear();
        row.push_csv(&mut line, &self.present);
        line.push_str(extras);
        line.push('\n');
        let r = self.write(line.as_bytes());
        self.line = line;
        r
    }
}

/// Exports a session as a measurement CSV plus every decoded channel to `out`, streaming
/// (see the module docs). Fails when the session has no `/telemetry/nav` message or `out`
/// fails. Give `out` a buffer (`BufWriter`): rows are written one at a time.
pub fn export_csv_to(session: &Session, out: &mut dyn std::io::Write) -> Result<CsvSummary> {
    let mut sink = TextSink {
        out,
        line: String::with_capacity(1024),
        present: [false; 8],
    };
    let done = build_rows(session, true, &mut sink)?;
    Ok(CsvSummary {
        rows: done.rows,
        extra_columns: done.extra_columns,
        warnings: done.warnings,
        read: done.read,
    })
}

/// [`export_csv_to`] into a string (short sessions and tests).
pub fn export_csv(session: &Session) -> Result<CsvExport> {
    let mut buf = Vec::new();
    let s = export_csv_to(session, &mut buf)?;
    Ok(CsvExport {
        text: String::from_utf8_lossy(&buf).into_owned(),
        rows: s.rows,
        extra_columns: s.extra_columns,
        warnings: s.warnings,
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
    import_series(&series, label, "", out)
}

/// Imports a measurement series (from any log: a measurement CSV, or another vehicle's log
/// read through a log map) as a session file at `out` (see the module docs).
/// `config_toml` is kept in the session's info as its provenance (the log map for a mapped
/// log; empty for a CSV).
pub fn import_series(
    series: &MeasurementSeries,
    label: &str,
    config_toml: &str,
    out: impl AsRef<Path>,
) -> Result<ImportReport> {
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
        config_toml: config_toml.to_owned(),
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
    }
    let written = w.finish()?;
    Ok(ImportReport {
        written,
        rows: series.rows.len(),
        warnings,
    })
}
