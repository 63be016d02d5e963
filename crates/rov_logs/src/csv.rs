//! CSV/TSV logs with any columns.
//!
//! The header row names the fields; the delimiter is the first of tab, `;` and `,` that
//! splits the header into more than one cell. Every numeric cell is a sample of its column
//! at its row's time; an empty or non-numeric cell is no sample (never a zero). Rows whose
//! time is missing are skipped and counted, and so are rows whose time does not increase
//! (a log's clock that steps back cannot say when their values were measured). A last row
//! cut short (no line end and fewer cells than the header) is dropped as truncated. Lines
//! starting with `#` are comments.

use crate::{Log, LogError, ReadOptions, Series};

/// Column names taken as time when the map names none (first match, case-insensitive).
pub const DEFAULT_TIME_COLUMNS: [&str; 4] = ["time_s", "time", "t", "timestamp"];

/// Reads a CSV/TSV log.
pub fn read(bytes: &[u8], label: &str, opts: &ReadOptions) -> Result<Log, LogError> {
    let text = String::from_utf8_lossy(bytes);
    let unreadable = |detail: String| LogError::Unreadable {
        file: label.into(),
        detail,
    };
    let mut lines = text
        .split('\n')
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let Some((_, header_line)) = lines.next() else {
        return Err(unreadable("empty file: no header row".into()));
    };
    let header_line = header_line.trim_end_matches('\r');
    let delim = ['\t', ';', ',']
        .into_iter()
        .find(|d| header_line.split(*d).count() > 1)
        .unwrap_or(',');
    let header: Vec<String> = header_line
        .split(delim)
        .map(|h| h.trim().trim_matches('"').to_string())
        .collect();
    let t_col = match &opts.time_field {
        Some(name) => header.iter().position(|h| h == name).ok_or_else(|| {
            unreadable(format!(
                "time column `{name}` is missing; columns present: {}",
                header.join(", ")
            ))
        })?,
        None => DEFAULT_TIME_COLUMNS
            .iter()
            .find_map(|d| header.iter().position(|h| h.eq_ignore_ascii_case(d)))
            .ok_or_else(|| {
                unreadable(format!(
                    "no time column (looked for {}; name one with the map's [time] field); columns present: {}",
                    DEFAULT_TIME_COLUMNS.join(", "),
                    header.join(", ")
                ))
            })?,
    };
    let scale = opts.time_scale.unwrap_or(1.0);
    let mut log = Log::default();
    let keep: Vec<bool> = header
        .iter()
        .enumerate()
        .map(|(i, h)| i != t_col && opts.wants(h))
        .collect();
    let mut cols: Vec<Series> = vec![Series::default(); header.len()];
    let ends_with_newline = text.ends_with('\n');
    let mut last_t = f64::NEG_INFINITY;
    let lines: Vec<(usize, &str)> = lines.collect();
    let n_lines = lines.len();
    for (k, (line_no, line)) in lines.into_iter().enumerate() {
        let line = line.trim_end_matches('\r');
        let cells: Vec<&str> = line.split(delim).map(str::trim).collect();
        if k + 1 == n_lines && !ends_with_newline && cells.len() < header.len() {
            log.report.truncated = Some(format!(
                "line {} has {} of {} cells and no line end",
                line_no + 1,
                cells.len(),
                header.len()
            ));
            break;
        }
        log.report.records += 1;
        let t = cells
            .get(t_col)
            .and_then(|c| parse_num(c))
            .map(|x| x * scale)
            .filter(|x| x.is_finite());
        let Some(t) = t else {
            log.report.untimed_records += 1;
            continue;
        };
        if t <= last_t {
            log.report.non_increasing += 1;
            continue;
        }
        last_t = t;
        for (i, c) in cells.iter().enumerate() {
            if !keep.get(i).copied().unwrap_or(false) {
                continue;
            }
            if let (Some(x), Some(col)) = (parse_num(c), cols.get_mut(i)) {
                col.push(t, x);
            }
        }
    }
    for ((h, s), k) in header.into_iter().zip(cols).zip(keep) {
        if k && !s.is_empty() {
            log.fields.insert(h, s);
        }
    }
    Ok(log)
}

/// A finite number in a cell (quotes allowed), or none.
fn parse_num(c: &str) -> Option<f64> {
    c.trim_matches('"')
        .parse::<f64>()
        .ok()
        .filter(|x| x.is_finite())
}
