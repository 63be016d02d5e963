//! Invariants shared by the log-reader targets (`log_csv`, `log_dataflash`, `log_tlog`).
//! A new reader's target (ROS 1 bag, MCAP) includes this file the same way
//! (`#[path = "log_common.rs"] mod log_common;`) and calls [`check_log`] on every read,
//! [`check_prefix`] where its reader parses strictly in order, and a structured
//! "valid log cut at byte k" case (see `log_tlog.rs`): exactly the records that end at or
//! before k are read, and the read says truncated unless k is a record boundary.
#![allow(dead_code)]

use rov_logs::{Log, Series};

/// Samples a record can give at most (a MAVLink message of ~60 numeric fields, an array
/// field of up to 256 elements, a DataFlash record's fields twice): a reader whose
/// output grows faster than its input allocates from something other than the input.
pub const MAX_SAMPLES_PER_RECORD: usize = 600;

/// What every read must satisfy, whatever the bytes.
pub fn check_log(log: &Log, input_len: usize) {
    let r = &log.report;
    // Counted things are things met in the input (at least one byte each).
    let met = r.records + r.bad_records + r.untimed_records + r.skipped_bytes;
    assert!(
        met <= input_len.max(1) * 2,
        "{met} things met in {input_len} bytes"
    );
    let unknown: usize = r.unknown_types.values().sum();
    assert!(
        unknown <= input_len,
        "{unknown} unknown records in {input_len} bytes"
    );
    let samples: usize = log.fields.values().map(Series::len).sum();
    assert!(
        samples <= (r.records + 1) * MAX_SAMPLES_PER_RECORD,
        "{samples} samples from {} records",
        r.records
    );
    for (name, s) in &log.fields {
        assert_eq!(s.t_s.len(), s.v.len(), "{name}");
        for w in s.t_s.windows(2) {
            assert!(w[0] < w[1], "{name}: time not increasing: {w:?}");
        }
        assert!(
            s.t_s.iter().all(|t| t.is_finite()),
            "{name}: time not finite"
        );
    }
    // The report in words never panics and names a truncation when there is one.
    let words = r.sentences();
    if r.truncated.is_some() {
        assert!(words.iter().any(|w| w.contains("last good record")));
    }
}

/// For a reader that parses strictly in order: reading a prefix gives, for every field, a
/// prefix of the whole read's samples, except that the prefix's last sample may differ
/// where `last_may_differ` (a text reader cut inside a number).
pub fn check_prefix(prefix: &Log, whole: &Log, last_may_differ: bool) {
    for (name, p) in &prefix.fields {
        let n = if last_may_differ {
            p.len().saturating_sub(1)
        } else {
            p.len()
        };
        let Some(w) = whole.fields.get(name) else {
            assert!(last_may_differ && n == 0, "{name} only in the prefix");
            continue;
        };
        assert!(n <= w.len(), "{name}: prefix has more samples");
        for k in 0..n {
            assert_eq!(p.t_s[k].to_bits(), w.t_s[k].to_bits(), "{name}[{k}] time");
            assert!(
                p.v[k].to_bits() == w.v[k].to_bits() || (p.v[k].is_nan() && w.v[k].is_nan()),
                "{name}[{k}]"
            );
        }
    }
    assert!(prefix.report.records <= whole.report.records + usize::from(last_may_differ));
}

/// A position in `0..=len` from a fraction in 1/65536.
pub fn at(frac: u16, len: usize) -> usize {
    (len as u64 * u64::from(frac) / 65_535) as usize
}
