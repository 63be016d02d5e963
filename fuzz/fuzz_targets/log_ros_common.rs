//! Shared by the ROS log fuzz targets: inputs, edits and invariants.

use std::collections::BTreeSet;

use arbitrary::Arbitrary;
use rov_logs::{Format, Log, ReadOptions};

#[derive(Debug, Arbitrary)]
pub enum Edit {
    /// XOR a byte (position as a fraction of the file, 1/65536).
    Flip(u16, u8),
    /// Overwrite 4 bytes with a little-endian value (a length, a count).
    Word(u16, u32),
    /// Cut the file there.
    Truncate(u16),
    /// Insert bytes.
    Insert(u16, Vec<u8>),
}

#[derive(Debug, Arbitrary)]
pub struct Input {
    /// Start from the seed (else from `raw`).
    seed: bool,
    raw: Vec<u8>,
    edits: Vec<Edit>,
    /// Which of the all-read's fields to read again selectively (bit per field).
    pick: u64,
    /// Time by the header stamp instead of the log time.
    stamp: bool,
}

fn at(frac: u16, len: usize) -> usize {
    (usize::from(frac) * len) >> 16
}

fn apply(bytes: &mut Vec<u8>, e: &Edit) {
    match e {
        Edit::Flip(p, x) => {
            let i = at(*p, bytes.len());
            if let Some(b) = bytes.get_mut(i) {
                *b ^= x;
            }
        }
        Edit::Word(p, v) => {
            let i = at(*p, bytes.len());
            if let Some(s) = bytes.get_mut(i..i + 4) {
                s.copy_from_slice(&v.to_le_bytes());
            }
        }
        Edit::Truncate(p) => {
            let i = at(*p, bytes.len());
            bytes.truncate(i);
        }
        Edit::Insert(p, more) => {
            let i = at(*p, bytes.len());
            let tail = bytes.split_off(i.min(bytes.len()));
            bytes.extend_from_slice(more);
            bytes.extend_from_slice(&tail);
        }
    }
}

fn check(log: &Log) {
    for (name, s) in &log.fields {
        assert_eq!(s.t_s.len(), s.v.len(), "{name}");
        for w in s.t_s.windows(2) {
            assert!(w[1] > w[0], "{name}: time {} after {}", w[1], w[0]);
        }
        assert!(s.t_s.iter().chain(&s.v).all(|x| x.is_finite()), "{name}");
    }
}

pub fn run(input: &Input, seed: &[u8], format: Format) {
    let mut bytes = if input.seed {
        seed.to_vec()
    } else {
        input.raw.clone()
    };
    for e in input.edits.iter().take(8) {
        apply(&mut bytes, e);
    }
    let time = if input.stamp {
        "/imu:header.stamp"
    } else {
        "@log_time"
    };
    let all_opts = ReadOptions {
        time_field: Some(time.into()),
        time_scale: None,
        only: None,
    };
    let Ok(all) = rov_logs::read(&bytes, Some(format), "fuzz", &all_opts) else {
        return;
    };
    check(&all);
    let _ = all.report.sentences();
    let picked: BTreeSet<String> = all
        .fields
        .keys()
        .enumerate()
        .filter(|(i, _)| *i < 64 && input.pick & (1 << i) != 0)
        .map(|(_, k)| k.clone())
        .collect();
    let some = rov_logs::read(
        &bytes,
        Some(format),
        "fuzz",
        &ReadOptions {
            only: Some(picked.clone()),
            ..all_opts
        },
    )
    .expect("a log read once reads again");
    check(&some);
    for name in &picked {
        assert_eq!(some.fields.get(name), all.fields.get(name), "{name}");
    }
    assert_eq!(some.report.truncated, all.report.truncated);
}
