//! CSV/TSV logs with any columns.
//!
//! The header row names the fields; the delimiter is the first of tab, `;` and `,` that
//! splits the header into more than one cell. Every numeric cell is a sample of its column
//! at its row's time; an empty or non-numeric cell is no sample (never a zero). Rows whose
//! time is missing are skipped and counted, and so are rows whose time does not increase
//! (a log's clock that steps back cannot say when their values were measured). A last row
//! cut short (no line end and fewer cells than the header) is dropped as truncated. Lines
//! starting with `#` are comments. Header names are made unique so that no column hides
//! another ([`unique_names`]: an empty name is `column N`, a repeated one `NAME#2`, …).

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
    let header = unique_names(
        header_line
            .split(delim)
            .map(|h| h.trim().trim_matches('"').to_string()),
    );
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

/// Header names made unique, so that no column hides another: an empty name becomes
/// `column N` (1-based position), the k-th repeat of a name `NAME#k` (k ≥ 2).
pub fn unique_names(names: impl Iterator<Item = String>) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    let mut taken: std::collections::HashSet<String> = std::collections::HashSet::new();
    let mut seen: std::collections::HashMap<String, usize> = std::collections::HashMap::new();
    for (i, h) in names.enumerate() {
        let h = if h.is_empty() {
            format!("column {}", i + 1)
        } else {
            h
        };
        let n = seen.entry(h.clone()).or_insert(0);
        *n += 1;
        let mut name = if *n == 1 {
            h.clone()
        } else {
            format!("{h}#{n}")
        };
        // A generated name that a later (or earlier) header spells too: count on.
        while taken.contains(&name) {
            *n += 1;
            name = format!("{h}#{n}");
        }
        taken.insert(name.clone());
        out.push(name);
    }
    out
}

/// A finite number in a cell (quotes allowed), or none.
fn parse_num(c: &str) -> Option<f64> {
    c.trim_matches('"')
        .parse::<f64>()
        .ok()
        .filter(|x| x.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Found by the `log_csv` fuzz target: with two columns of one name the later one
    /// replaced the earlier, so a prefix of the file and the whole file gave that name
    /// different columns. Every column keeps its own name now.
    #[test]
    fn repeated_and_empty_header_names_keep_every_column() {
        let text = "t,a,,a,a#2\n0,1,2,3,4\n1,5,6,7,8\n";
        let log = read(
            text.as_bytes(),
            "dup.csv",
            &ReadOptions {
                time_field: Some("t".into()),
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(log.names(), ["a", "a#2", "a#2#2", "column 3"]);
        assert_eq!(log.fields["a"].v, [1.0, 5.0]);
        assert_eq!(log.fields["column 3"].v, [2.0, 6.0]);
        assert_eq!(log.fields["a#2"].v, [3.0, 7.0]);
        assert_eq!(log.fields["a#2#2"].v, [4.0, 8.0]);
        // A prefix names the same columns the same way.
        let cut = read(
            &text.as_bytes()[..19],
            "dup.csv",
            &ReadOptions {
                time_field: Some("t".into()),
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(cut.fields["a#2"].v, [3.0]);
    }
}
