//! Fuzz the CSV/TSV log reader: arbitrary text read with and without a named time
//! column; every read satisfies `log_common::check_log`; a copy cut at any byte after the
//! header reads every whole row the full read did, identically (the cut row's value may
//! differ: a number cut short is still a number).
#![no_main]

#[path = "log_common.rs"]
mod log_common;

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use rov_logs::{ReadOptions, csv};

#[derive(Debug, Arbitrary)]
struct Input {
    text: Vec<u8>,
    /// Name the first header cell as the time column (else the default names).
    named_time: bool,
    /// Time scale, if any.
    scale: Option<f64>,
    /// Where to cut, 1/65536 of the length.
    cut: u16,
}

fuzz_target!(|input: Input| {
    let data = &input.text;
    let first_line = data.split(|b| *b == b'\n').next().unwrap_or_default();
    let first_cell = String::from_utf8_lossy(first_line)
        .split([',', '\t', ';'])
        .next()
        .unwrap_or_default()
        .trim()
        .trim_matches('"')
        .to_string();
    let opts = ReadOptions {
        time_field: input.named_time.then_some(first_cell),
        time_scale: input.scale,
        only: None,
    };
    let Ok(whole) = csv::read(data, "fuzz.csv", &opts) else {
        return;
    };
    log_common::check_log(&whole, data.len());
    let k = log_common::at(input.cut, data.len());
    // Cut after the header line (and its line end), so the header is the same.
    let Some(header_end) = data.iter().position(|b| *b == b'\n') else {
        return;
    };
    let header = String::from_utf8_lossy(&data[..header_end]);
    if k <= header_end || header.trim().is_empty() || header.trim_start().starts_with('#') {
        return;
    }
    if let Ok(prefix) = csv::read(&data[..k], "fuzz.csv", &opts) {
        log_common::check_log(&prefix, k);
        log_common::check_prefix(&prefix, &whole, true);
    }
});
