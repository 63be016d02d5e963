//! The measurement CSV format.
//!
//! The simulator writes it; the model lab and the session tools read it.
//!
//! * Required columns (any order): `time_s,port_pct,starboard_pct,vertical_pct,depth_m,
//!   heading_deg,pitch_deg,roll_deg`.
//! * Optional: `yaw_rate_dps,pitch_rate_dps,roll_rate_dps,surge_mps,sway_mps,heave_mps,
//!   north_m,east_m`. Other columns are ignored with a warning.
//! * Thrust is in percent, −100..100; positive `vertical_pct` pushes the vehicle down.
//! * Depth positive down; heading in degrees, any wrap; pitch positive nose up; roll
//!   positive starboard down. The `*_rate_dps` columns are body rates (gyro p, q, r).
//! * Timing: row k's commands act from `time_s[k]` until `time_s[k+1]` (zero-order hold).
//!   Row k's measurements are taken at `time_s[k]`, before row k's command has acted.
//!   Sampling may be uneven, but time must increase strictly.
//!
//! An empty cell, `nan` or `NaN` in a measurement column is a missing sample (kept as
//! NaN, never dropped). Time and thrust cells must be finite.

/// The required columns, in the order the writer uses.
pub const REQUIRED_COLUMNS: [&str; 8] = [
    "time_s",
    "port_pct",
    "starboard_pct",
    "vertical_pct",
    "depth_m",
    "heading_deg",
    "pitch_deg",
    "roll_deg",
];

/// The optional columns, in the order the writer uses.
pub const OPTIONAL_COLUMNS: [&str; 8] = [
    "yaw_rate_dps",
    "pitch_rate_dps",
    "roll_rate_dps",
    "surge_mps",
    "sway_mps",
    "heave_mps",
    "north_m",
    "east_m",
];

/// One row: the command held from this time on, and the measurements taken at this time.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MeasurementRow {
    /// Sample time, s.
    pub time_s: f64,
    /// Port thruster command, % (−100..100).
    pub port_pct: f64,
    /// Starboard thruster command, %.
    pub starboard_pct: f64,
    /// Vertical thruster command, %; positive pushes down.
    pub vertical_pct: f64,
    /// Depth, m, positive down.
    pub depth_m: f64,
    /// Heading, degrees (any wrap).
    pub heading_deg: f64,
    /// Pitch, degrees, positive nose up.
    pub pitch_deg: f64,
    /// Roll, degrees, positive starboard down.
    pub roll_deg: f64,
    /// Optional channels, in [`OPTIONAL_COLUMNS`] order; `None` when the column is absent.
    pub optional: [Option<f64>; 8],
}

impl MeasurementRow {
    /// Appends the row's cells (the required columns, then the optional ones `present`
    /// marks, NaN where absent) as CSV, without a line end; numbers as
    /// [`crate::number`] writes them.
    pub fn push_csv(&self, out: &mut String, present: &[bool; 8]) {
        let req = [
            self.time_s,
            self.port_pct,
            self.starboard_pct,
            self.vertical_pct,
            self.depth_m,
            self.heading_deg,
            self.pitch_deg,
            self.roll_deg,
        ];
        for (i, x) in req.iter().enumerate() {
            if i > 0 {
                out.push(',');
            }
            push_num(out, *x);
        }
        for (value, present) in self.optional.iter().zip(present) {
            if *present {
                out.push(',');
                push_num(out, value.unwrap_or(f64::NAN));
            }
        }
    }
}

/// Index of each optional channel in [`MeasurementRow::optional`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(usize)]
pub enum OptionalChannel {
    /// Body yaw rate r, deg/s.
    YawRateDps = 0,
    /// Body pitch rate q, deg/s.
    PitchRateDps = 1,
    /// Body roll rate p, deg/s.
    RollRateDps = 2,
    /// Surge velocity u, m/s.
    SurgeMps = 3,
    /// Sway velocity v, m/s.
    SwayMps = 4,
    /// Heave velocity w, m/s.
    HeaveMps = 5,
    /// North position, m.
    NorthM = 6,
    /// East position, m.
    EastM = 7,
}

impl MeasurementRow {
    /// The value of an optional channel, if present.
    pub fn get(&self, ch: OptionalChannel) -> Option<f64> {
        self.optional.get(ch as usize).copied().flatten()
    }

    /// Sets an optional channel.
    pub fn set(&mut self, ch: OptionalChannel, value: Option<f64>) {
        if let Some(slot) = self.optional.get_mut(ch as usize) {
            *slot = value;
        }
    }
}

/// A whole measurement file.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MeasurementSeries {
    /// The rows, time strictly increasing.
    pub rows: Vec<MeasurementRow>,
    /// Which optional columns are present.
    pub present: [bool; 8],
    /// Warnings raised while reading (ignored columns and the like).
    pub warnings: Vec<String>,
}

/// Why a measurement CSV could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum MeasurementError {
    /// The file has no header line.
    #[error("{file}: empty file, expected a header line")]
    Empty {
        /// File label.
        file: String,
    },
    /// A required column is missing.
    #[error("{file}: required column {column} is missing from the header")]
    MissingColumn {
        /// File label.
        file: String,
        /// Column name.
        column: String,
    },
    /// A column name appears twice.
    #[error("{file}: column {column} appears twice in the header")]
    DuplicateColumn {
        /// File label.
        file: String,
        /// Column name.
        column: String,
    },
    /// A row has a different number of cells from the header.
    #[error("{file}:{line}: {found} cells, the header has {expected}")]
    RowLength {
        /// File label.
        file: String,
        /// 1-based line number.
        line: usize,
        /// Cells found.
        found: usize,
        /// Cells expected.
        expected: usize,
    },
    /// A cell does not hold an acceptable number.
    #[error("{file}:{line}: column {column} = {value:?} is invalid (allowed {allowed})")]
    BadValue {
        /// File label.
        file: String,
        /// 1-based line number.
        line: usize,
        /// Column name.
        column: String,
        /// The cell as written.
        value: String,
        /// What is accepted.
        allowed: String,
    },
    /// Time does not increase strictly.
    #[error("{file}:{line}: time_s = {time_s} does not increase (previous row {previous_s})")]
    TimeNotIncreasing {
        /// File label.
        file: String,
        /// 1-based line number.
        line: usize,
        /// This row's time.
        time_s: f64,
        /// The previous row's time.
        previous_s: f64,
    },
}

enum Slot {
    Required(usize),
    Optional(usize),
    Ignored,
}

impl MeasurementSeries {
    /// Parses CSV text; `file` labels errors and warnings.
    pub fn parse_csv(text: &str, file: &str) -> Result<Self, MeasurementError> {
        let mut lines = text
            .lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l.trim_end_matches('\r')))
            .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
        let Some((_, header)) = lines.next() else {
            return Err(MeasurementError::Empty { file: file.into() });
        };
        let names: Vec<&str> = header.split(',').map(str::trim).collect();
        let mut series = MeasurementSeries::default();
        let mut slots = Vec::with_capacity(names.len());
        let mut seen_req = [false; 8];
        let mut ignored: Vec<&str> = Vec::new();
        for name in &names {
            if let Some(i) = REQUIRED_COLUMNS.iter().position(|c| c == name) {
                if seen_req.get(i).copied().unwrap_or(false) {
                    return Err(MeasurementError::DuplicateColumn {
                        file: file.into(),
                        column: (*name).into(),
                    });
                }
                if let Some(s) = seen_req.get_mut(i) {
                    *s = true;
                }
                slots.push(Slot::Required(i));
            } else if let Some(i) = OPTIONAL_COLUMNS.iter().position(|c| c == name) {
                if series.present.get(i).copied().unwrap_or(false) {
                    return Err(MeasurementError::DuplicateColumn {
                        file: file.into(),
                        column: (*name).into(),
                    });
                }
                if let Some(p) = series.present.get_mut(i) {
                    *p = true;
                }
                slots.push(Slot::Optional(i));
            } else {
                ignored.push(*name);
                slots.push(Slot::Ignored);
            }
        }
        if let Some(w) = ignored_columns_note(file, &ignored) {
            series.warnings.push(w);
        }
        for (i, seen) in seen_req.iter().enumerate() {
            if !seen {
                return Err(MeasurementError::MissingColumn {
                    file: file.into(),
                    column: REQUIRED_COLUMNS.get(i).copied().unwrap_or("?").into(),
                });
            }
        }
        let mut previous: Option<f64> = None;
        for (line_no, line) in lines {
            let cells: Vec<&str> = line.split(',').map(str::trim).collect();
            if cells.len() != names.len() {
                return Err(MeasurementError::RowLength {
                    file: file.into(),
                    line: line_no,
                    found: cells.len(),
                    expected: names.len(),
                });
            }
            let mut req = [f64::NAN; 8];
            let mut row = MeasurementRow::default();
            for ((cell, slot), name) in cells.iter().zip(&slots).zip(&names) {
                let bad = |allowed: &str| MeasurementError::BadValue {
                    file: file.into(),
                    line: line_no,
                    column: (*name).into(),
                    value: (*cell).into(),
                    allowed: allowed.into(),
                };
                match slot {
                    Slot::Ignored => {}
                    Slot::Required(i) => {
                        let x = parse_cell(cell).ok_or_else(|| bad("a number"))?;
                        match *i {
                            0 if !x.is_finite() => return Err(bad("a finite time")),
                            1..=3 if !(x.is_finite() && (-100.0..=100.0).contains(&x)) => {
                                return Err(bad("-100..=100 %"));
                            }
                            _ => {}
                        }
                        if let Some(r) = req.get_mut(*i) {
                            *r = x;
                        }
                    }
                    Slot::Optional(i) => {
                        let x = parse_cell(cell).ok_or_else(|| bad("a number or empty"))?;
                        if let Some(o) = row.optional.get_mut(*i) {
                            *o = Some(x);
                        }
                    }
                }
            }
            let [
                time_s,
                port_pct,
                starboard_pct,
                vertical_pct,
                depth_m,
                heading_deg,
                pitch_deg,
                roll_deg,
            ] = req;
            if let Some(prev) = previous
                && time_s <= prev
            {
                return Err(MeasurementError::TimeNotIncreasing {
                    file: file.into(),
                    line: line_no,
                    time_s,
                    previous_s: prev,
                });
            }
            previous = Some(time_s);
            row.time_s = time_s;
            row.port_pct = port_pct;
            row.starboard_pct = starboard_pct;
            row.vertical_pct = vertical_pct;
            row.depth_m = depth_m;
            row.heading_deg = heading_deg;
            row.pitch_deg = pitch_deg;
            row.roll_deg = roll_deg;
            series.rows.push(row);
        }
        Ok(series)
    }

    /// Writes the series as CSV: the required columns, then every present optional one.
    /// Numbers use the shortest text that reads back to the same `f64`; NaN is `nan`.
    pub fn to_csv(&self) -> String {
        let mut out = String::with_capacity(64 + self.rows.len() * 96);
        let mut header: Vec<&str> = REQUIRED_COLUMNS.to_vec();
        for (name, present) in OPTIONAL_COLUMNS.iter().zip(self.present) {
            if present {
                header.push(name);
            }
        }
        out.push_str(&header.join(","));
        out.push('\n');
        for row in &self.rows {
            row.push_csv(&mut out, &self.present);
            out.push('\n');
        }
        out
    }

    /// Duration from the first to the last row, s.
    pub fn duration_s(&self) -> f64 {
        match (self.rows.first(), self.rows.last()) {
            (Some(a), Some(b)) => b.time_s - a.time_s,
            _ => 0.0,
        }
    }
}

/// One note for every column outside the measurement format. A session export
/// (`topside export --csv`) adds one `topic.field` column per decoded channel, about 75 of
/// them: those are named per topic (`autopilot_state.* (5)`), so the note stays one line
/// and still says exactly what was left out.
fn ignored_columns_note(file: &str, ignored: &[&str]) -> Option<String> {
    match ignored {
        [] => None,
        [one] => Some(format!(
            "{file}: column {one:?} is not part of the measurement format; ignored"
        )),
        many => {
            // (prefix, count, the single name when the group has one column), in order.
            let mut groups: Vec<(&str, usize, &str)> = Vec::new();
            for name in many {
                let prefix = name.split_once('.').map_or(*name, |(p, _)| p);
                match groups.iter_mut().find(|(p, _, _)| *p == prefix) {
                    Some(g) => g.1 += 1,
                    None => groups.push((prefix, 1, name)),
                }
            }
            let listed: Vec<String> = groups
                .iter()
                .map(|(prefix, n, first)| {
                    if *n == 1 {
                        format!("{first:?}")
                    } else {
                        format!("{prefix}.* ({n})")
                    }
                })
                .collect();
            Some(format!(
                "{file}: {} columns are not part of the measurement format; ignored: {}",
                many.len(),
                listed.join(", ")
            ))
        }
    }
}

fn push_num(out: &mut String, x: f64) {
    crate::number::push_f64(out, x);
}

fn parse_cell(cell: &str) -> Option<f64> {
    if cell.is_empty() || cell.eq_ignore_ascii_case("nan") {
        return Some(f64::NAN);
    }
    cell.parse::<f64>().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = "roll_deg,time_s,port_pct,starboard_pct,vertical_pct,depth_m,heading_deg,pitch_deg,yaw_rate_dps,extra\n\
        0.5,0,10,-10,30,1.0,90,-2,1.5,x\n\
        0.6,0.1,10,-10,30,1.01,91,,2.0,y\n";

    #[test]
    fn parses_any_column_order_and_optional_columns() {
        let s = MeasurementSeries::parse_csv(GOOD, "run.csv").unwrap();
        assert_eq!(s.rows.len(), 2);
        assert_eq!(s.rows[1].time_s, 0.1);
        assert_eq!(s.rows[0].roll_deg, 0.5);
        assert!(
            s.rows[1].pitch_deg.is_nan(),
            "empty cell is a missing sample"
        );
        assert_eq!(s.rows[1].get(OptionalChannel::YawRateDps), Some(2.0));
        assert!(s.present[OptionalChannel::YawRateDps as usize]);
        assert_eq!(s.warnings.len(), 1);
        assert!(s.warnings[0].contains("extra"));
    }

    #[test]
    fn many_extra_columns_make_one_note_grouped_by_topic() {
        let text = "time_s,port_pct,starboard_pct,vertical_pct,depth_m,heading_deg,\
                    roll_deg,pitch_deg,a.x,a.y,a.z,b.only,loose\n\
                    0,0,0,0,1,0,0,0,1,2,3,4,5\n";
        let s = MeasurementSeries::parse_csv(text, "dive.csv").unwrap();
        assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
        assert_eq!(
            s.warnings[0],
            "dive.csv: 5 columns are not part of the measurement format; ignored: \
             a.* (3), \"b.only\", \"loose\""
        );
        assert_eq!(s.rows.len(), 1);
    }

    #[test]
    fn round_trips_exactly() {
        let s = MeasurementSeries::parse_csv(GOOD, "run.csv").unwrap();
        let text = s.to_csv();
        let back = MeasurementSeries::parse_csv(&text, "again.csv").unwrap();
        assert_eq!(back.rows.len(), s.rows.len());
        for (a, b) in back.rows.iter().zip(&s.rows) {
            assert_eq!(a.time_s.to_bits(), b.time_s.to_bits());
            assert_eq!(a.depth_m.to_bits(), b.depth_m.to_bits());
            assert_eq!(a.optional[0], b.optional[0]);
        }
    }

    #[test]
    fn bad_input_names_line_column_and_value() {
        let text = "time_s,port_pct,starboard_pct,vertical_pct,depth_m,heading_deg,pitch_deg,roll_deg\n0,150,0,0,1,0,0,0\n";
        let e = MeasurementSeries::parse_csv(text, "bad.csv").unwrap_err();
        assert_eq!(
            e.to_string(),
            "bad.csv:2: column port_pct = \"150\" is invalid (allowed -100..=100 %)"
        );
        let text = "time_s,port_pct,starboard_pct,vertical_pct,depth_m,heading_deg,pitch_deg,roll_deg\n1,0,0,0,1,0,0,0\n1,0,0,0,1,0,0,0\n";
        let e = MeasurementSeries::parse_csv(text, "t.csv").unwrap_err();
        assert!(
            matches!(e, MeasurementError::TimeNotIncreasing { line: 3, .. }),
            "{e}"
        );
        let e = MeasurementSeries::parse_csv("time_s,depth_m\n", "h.csv").unwrap_err();
        assert!(matches!(e, MeasurementError::MissingColumn { .. }));
        assert!(matches!(
            MeasurementSeries::parse_csv("", "e.csv").unwrap_err(),
            MeasurementError::Empty { .. }
        ));
        let text = "time_s,port_pct,starboard_pct,vertical_pct,depth_m,heading_deg,pitch_deg,roll_deg\n0,0,0\n";
        assert!(matches!(
            MeasurementSeries::parse_csv(text, "r.csv").unwrap_err(),
            MeasurementError::RowLength {
                line: 2,
                found: 3,
                expected: 8,
                ..
            }
        ));
    }
}
