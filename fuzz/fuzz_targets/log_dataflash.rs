//! Fuzz the ArduSub DataFlash reader: arbitrary bytes (with and without a named time
//! field), and valid logs from the crate's writer cut at any byte or with bytes flipped.
//! Invariants: `log_common::check_log` on every read; the reader parses strictly in order,
//! so a prefix of any input reads a prefix of every field (`check_prefix`); a valid log
//! cut at byte k reads exactly the records that end at or before k, and says truncated
//! unless k is a record boundary.
#![no_main]

#[path = "log_common.rs"]
mod log_common;

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use rov_logs::ReadOptions;
use rov_logs::dataflash::{self, Writer};

#[derive(Debug, Arbitrary)]
enum Source {
    /// The bytes as they are.
    Raw(Vec<u8>),
    /// A valid log of these messages (type selector, time, values).
    Valid(Vec<(u8, u32, [i32; 4], [f32; 2])>),
}

#[derive(Debug, Arbitrary)]
struct Input {
    source: Source,
    /// Read with `TimeMS` named as the time field instead of the default.
    time_ms: bool,
    /// Where to cut, 1/65536 of the length.
    cut: u16,
    /// Bytes to flip in the valid log (position 1/65536, xor mask).
    flips: Vec<(u16, u8)>,
}

/// The message types of the valid logs, all format characters the reader decodes.
const TYPES: [(u8, &str, &str, &[&str]); 3] = [
    (
        130,
        "BARO",
        "QBffhHg",
        &["TimeUS", "I", "Press", "Temp", "A", "B", "G"],
    ),
    (
        131,
        "RCOU",
        "QcCeELbB",
        &["TimeUS", "C1", "C2", "C3", "C4", "Lat", "S", "U"],
    ),
    (
        132,
        "TXT",
        "QnNZdqi",
        &["TimeUS", "A", "B", "Msg", "D", "Q", "I"],
    ),
];

fn valid(msgs: &[(u8, u32, [i32; 4], [f32; 2])]) -> (Vec<u8>, Vec<usize>) {
    let mut w = Writer::new();
    for (ty, name, fmt, cols) in TYPES {
        w.declare(ty, name, fmt, cols).expect("valid format");
    }
    // Record ends: FMT of FMT, then the three FMTs.
    let mut ends: Vec<usize> = (1..=4).map(|i| i * dataflash::FMT_LEN).collect();
    let mut len = *ends.last().unwrap_or(&0);
    for (sel, t, i, f) in msgs {
        let (ty, _, fmt, _) = TYPES[usize::from(*sel) % TYPES.len()];
        let t = f64::from(*t);
        let i: Vec<f64> = i.iter().map(|x| f64::from(*x)).collect();
        let f: Vec<f64> = f.iter().map(|x| f64::from(*x)).collect();
        let values: Vec<f64> = match ty {
            130 => vec![t, i[0], f[0], f[1], i[1], i[2], f[1]],
            131 => vec![
                t,
                i[0] * 0.01,
                i[1] * 0.01,
                i[2] * 0.01,
                i[3] * 0.01,
                i[0] * 1e-7,
                i[1],
                i[2],
            ],
            _ => vec![t, 0.0, 0.0, 0.0, f[0], i[0], i[1]],
        };
        w.write(ty, &values).expect("declared type");
        len += 3 + fmt
            .bytes()
            .map(|c| dataflash::field_size(c).unwrap_or(0))
            .sum::<usize>();
        ends.push(len);
    }
    (w.into_bytes(), ends)
}

fuzz_target!(|input: Input| {
    let opts = ReadOptions {
        time_field: input.time_ms.then(|| "X.TimeMS".to_string()),
        ..Default::default()
    };
    let (data, ends) = match &input.source {
        Source::Raw(b) => (b.clone(), None),
        Source::Valid(m) => {
            let (mut b, ends) = valid(m);
            let clean = input.flips.is_empty();
            let n = b.len();
            for (at, x) in &input.flips {
                if n > 0 {
                    let k = log_common::at(*at, n - 1);
                    b[k] ^= x;
                }
            }
            (b, clean.then_some(ends))
        }
    };
    let whole = dataflash::read(&data, "fuzz.BIN", &opts).expect("the reader never fails");
    log_common::check_log(&whole, data.len());
    let k = log_common::at(input.cut, data.len());
    let prefix = dataflash::read(&data[..k], "fuzz.BIN", &opts).expect("never fails");
    log_common::check_log(&prefix, k);
    log_common::check_prefix(&prefix, &whole, false);
    if let Some(ends) = ends {
        assert_eq!(whole.report.records, ends.len());
        assert!(whole.report.truncated.is_none() && whole.report.skipped_bytes == 0);
        let whole_records = ends.iter().filter(|e| **e <= k).count();
        assert_eq!(prefix.report.records, whole_records, "cut at {k}");
        let boundary = k == 0 || ends.contains(&k);
        assert_eq!(prefix.report.truncated.is_none(), boundary, "cut at {k}");
    }
});
