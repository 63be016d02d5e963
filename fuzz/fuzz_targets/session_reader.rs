//! Fuzz the session reader: open, read and check arbitrary files, and valid sessions
//! truncated, corrupted, with hostile indexes (a summary rewritten with forged offsets,
//! lengths and counts whose CRC is made to match again) and huge length fields.
//!
//! Both ways of opening are exercised: through the summary (the tools' fast path) and by
//! a scan (recovery's). Invariants checked (not just "no panic"):
//! * a scanned session reads back exactly the messages its scan counted, unless the
//!   read reports damage;
//! * reads never return a message out of time order, whatever the indexes claim;
//! * every message returned decodes or fails with an error, never a panic (records,
//!   Foxglove messages, video);
//! * allocations stay bounded: run with `-malloc_limit_mb=256` (fuzz/README.md), so one
//!   allocation sized from a forged length field fails the run.
#![no_main]

use std::sync::OnceLock;

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use rov_session::{
    NavRecord, ReadOptions, Session, SessionInfo, SessionWriter, ThrustRecord, TruthRecord,
    WriterOptions,
};

#[derive(Debug, Arbitrary)]
enum Source {
    /// The bytes as they are.
    Raw(Vec<u8>),
    /// One of the valid seed sessions, then edits.
    Seed(u8),
}

#[derive(Debug, Arbitrary)]
enum Edit {
    /// XOR a byte (position as a fraction of the file, 1/65536).
    Flip(u16, u8),
    /// Overwrite 8 bytes with a little-endian value (a length, an offset, a count).
    Word(u16, u64),
    /// Cut the file there.
    Truncate(u16),
    /// Insert bytes.
    Insert(u16, Vec<u8>),
}

#[derive(Debug, Arbitrary)]
struct Input {
    source: Source,
    edits: Vec<Edit>,
    /// Recompute the summary CRC after the edits, so forged indexes are trusted.
    fix_summary_crc: bool,
    /// Read a topic over a time window (a fraction of the session), and seek there.
    window: (u16, u16),
    /// Which reads to run besides the full one (bits: window, seek state, video,
    /// measurements).
    ops: u8,
    /// Open by a scan (recovery's way) instead of through the summary.
    scan: bool,
}

/// Small valid sessions: a recording with every topic (some video), and an uncompressed
/// one with one chunk per message.
fn seeds() -> &'static [Vec<u8>] {
    static SEEDS: OnceLock<Vec<Vec<u8>>> = OnceLock::new();
    SEEDS.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("session_reader_fuzz_{}", std::process::id()));
        let _ = std::fs::create_dir_all(&dir);
        let mut out = Vec::new();
        for (k, opts) in [
            WriterOptions::default(),
            WriterOptions {
                compress: false,
                flush_interval_ns: 40_000_000,
                ..WriterOptions::default()
            },
        ]
        .into_iter()
        .enumerate()
        {
            let path = dir.join(format!("seed{k}.mcap"));
            let info = SessionInfo {
                vehicle: "sim".into(),
                software_version: "fuzz".into(),
                started_unix_s: 1.7e9,
                config_toml: "a = 1\n".into(),
            };
            let mut w = SessionWriter::create_with(&path, &info, 0, opts).unwrap();
            for i in 0..12u64 {
                let t = i * 20_000_000;
                let nav = NavRecord {
                    depth_m: 1.0 + i as f64 * 0.1,
                    heading_deg: (i * 9) as f64,
                    pitch_deg: 0.5,
                    roll_deg: -0.5,
                    ..NavRecord::default()
                };
                w.write(t, &nav).unwrap();
                w.write(t, &TruthRecord {
                    north_m: i as f64,
                    east_m: 0.0,
                    ..TruthRecord::default()
                })
                .unwrap();
                w.write(t + 100_000, &ThrustRecord::default()).unwrap();
                let au: &[u8] = if i % 6 == 0 {
                    &[0, 0, 0, 1, 0x67, 1, 0, 0, 1, 0x68, 2, 0, 0, 1, 0x65, 3]
                } else {
                    &[0, 0, 1, 0x41, 9, 9]
                };
                w.write_video(t + 200_000, au, i % 6 == 0).unwrap();
            }
            w.finish().unwrap();
            out.push(std::fs::read(&path).unwrap());
            let _ = std::fs::remove_file(&path);
        }
        out
    })
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
            if let Some(s) = bytes.get_mut(i..i + 8) {
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

/// Rewrites the footer's summary CRC to match the (edited) summary.
fn fix_summary_crc(bytes: &mut [u8]) {
    let len = bytes.len();
    let Some(footer) = len.checked_sub(8 + 29) else {
        return;
    };
    let Some(start) = bytes
        .get(footer + 9..footer + 17)
        .and_then(|b| b.try_into().ok())
        .map(u64::from_le_bytes)
        .and_then(|s| usize::try_from(s).ok())
    else {
        return;
    };
    if start < 8 || start > footer {
        return;
    }
    let crc = match bytes.get(start..footer + 25) {
        Some(covered) => crc32fast::hash(covered),
        None => return,
    };
    if let Some(slot) = bytes.get_mut(footer + 25..footer + 29) {
        slot.copy_from_slice(&crc.to_le_bytes());
    }
}

fn exercise(s: &Session, input: &Input) {
    // Every message, time order: ordered, each decodes or fails cleanly.
    let mut read = s.messages();
    let mut last = 0u64;
    let mut n = 0u64;
    for m in read.by_ref() {
        assert!(m.t_ns >= last, "out of order: {} after {last}", m.t_ns);
        last = last.max(m.t_ns);
        let _ = m.validate();
        n += 1;
    }
    let report = read.report();
    assert_eq!(report.messages, n);
    // A window of one topic, a seek's state, video.
    let (a, b) = input.window;
    let (t0, t1) = (s.start_ns().unwrap_or(0), s.end_ns().unwrap_or(0));
    let span = t1.saturating_sub(t0);
    let lo = t0 + (u128::from(span) * u128::from(a) >> 16) as u64;
    let hi = t0 + (u128::from(span) * u128::from(b) >> 16) as u64;
    if input.ops & 1 != 0 {
        for m in s.read(ReadOptions::topics(&["/telemetry/nav"]).between(lo, hi)) {
            assert!(m.t_ns >= lo && m.t_ns <= hi);
            let _ = m.decode::<NavRecord>();
        }
    }
    if input.ops & 2 != 0 {
        let _ = s.latest_before(hi);
    }
    if input.ops & 4 != 0 {
        for f in s.video(lo, hi) {
            let _ = f.key_frame;
        }
        let _ = s.video_key_frame_at_or_before(hi);
    }
    if input.ops & 8 != 0 {
        let _ = rov_session::measurements(s);
    }
    let _ = s.topics();
}

fuzz_target!(|input: Input| {
    let mut bytes = match &input.source {
        Source::Raw(b) => b.clone(),
        Source::Seed(k) => {
            let seeds = seeds();
            seeds[usize::from(*k) % seeds.len()].clone()
        }
    };
    for e in input.edits.iter().take(8) {
        apply(&mut bytes, e);
    }
    if input.fix_summary_crc {
        fix_summary_crc(&mut bytes);
    }
    if !input.scan {
        if let Ok(s) = Session::from_bytes(bytes, "fuzz") {
            exercise(&s, &input);
        }
    } else if let Ok(s) = Session::from_bytes_scanned(bytes, "fuzz") {
        let mut read = s.messages_in_file_order();
        let n = read.by_ref().count() as u64;
        if read.damage().is_none() {
            assert_eq!(n, s.len() as u64, "a scan counted what a read returns");
        }
        exercise(&s, &input);
    }
});
