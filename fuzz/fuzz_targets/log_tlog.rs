//! Fuzz the MAVLink tlog reader: arbitrary bytes (timed by the record stamps or by a
//! message field), and valid tlogs written with the `mavlink` crate, cut at any byte or
//! with bytes flipped. Invariants: `log_common::check_log` on every read; a valid tlog
//! cut at byte k reads exactly the records that end at or before k, and says truncated
//! unless k is a record boundary; a valid tlog with flipped bytes reads no more records
//! than it has (resynchronisation never invents one).
#![no_main]

#[path = "log_common.rs"]
mod log_common;

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use mavlink::dialects::ardupilotmega::{
    ATTITUDE_DATA, HEARTBEAT_DATA, MavMessage, SCALED_PRESSURE2_DATA, SERVO_OUTPUT_RAW_DATA,
};
use mavlink::{MavHeader, MavlinkVersion};
use rov_logs::{ReadOptions, tlog};

#[derive(Debug, Arbitrary)]
enum Source {
    /// The bytes as they are.
    Raw(Vec<u8>),
    /// A valid tlog of these messages (kind, v2?, stamp step, values).
    Valid(Vec<(u8, bool, u16, u32, [f32; 3], [u16; 4])>),
}

#[derive(Debug, Arbitrary)]
struct Input {
    source: Source,
    /// Time each message by its `time_boot_ms` instead of the record stamp.
    boot_time: bool,
    /// Where to cut, 1/65536 of the length.
    cut: u16,
    /// Bytes to flip in the valid log (position 1/65536, xor mask).
    flips: Vec<(u16, u8)>,
}

fn message(kind: u8, ms: u32, f: [f32; 3], u: [u16; 4]) -> MavMessage {
    match kind % 4 {
        0 => MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: ms,
            ..Default::default()
        }),
        1 => MavMessage::ATTITUDE(ATTITUDE_DATA {
            time_boot_ms: ms,
            roll: f[0],
            pitch: f[1],
            yawspeed: f[2],
            ..Default::default()
        }),
        2 => MavMessage::SERVO_OUTPUT_RAW(SERVO_OUTPUT_RAW_DATA {
            time_usec: ms,
            servo1_raw: u[0],
            servo3_raw: u[1],
            servo8_raw: u[2],
            servo12_raw: u[3],
            ..Default::default()
        }),
        _ => MavMessage::SCALED_PRESSURE2(SCALED_PRESSURE2_DATA {
            time_boot_ms: ms,
            press_abs: f[0],
            press_diff: f[1],
            temperature: u[0] as i16,
            ..Default::default()
        }),
    }
}

type Msgs = [(u8, bool, u16, u32, [f32; 3], [u16; 4])];

fn valid(msgs: &Msgs) -> (Vec<u8>, Vec<usize>) {
    let mut out = Vec::new();
    let mut ends = Vec::new();
    let mut stamp_us: u64 = 1_790_000_000_000_000;
    for (seq, (kind, v2, step, ms, f, u)) in msgs.iter().enumerate() {
        stamp_us += u64::from(*step);
        out.extend(stamp_us.to_be_bytes());
        let header = MavHeader {
            system_id: 1,
            component_id: 1,
            sequence: seq as u8,
        };
        let version = if *v2 {
            MavlinkVersion::V2
        } else {
            MavlinkVersion::V1
        };
        mavlink::write_versioned_msg(&mut out, version, header, &message(*kind, *ms, *f, *u))
            .expect("writing to a Vec");
        ends.push(out.len());
    }
    (out, ends)
}

fuzz_target!(|input: Input| {
    let opts = ReadOptions {
        time_field: input.boot_time.then(|| "ATTITUDE.time_boot_ms".to_string()),
        ..Default::default()
    };
    let read = |b: &[u8]| tlog::read(b, "fuzz.tlog", &opts);
    match &input.source {
        Source::Raw(b) => {
            if let Ok(log) = read(b) {
                log_common::check_log(&log, b.len());
            }
            let k = log_common::at(input.cut, b.len());
            if let Ok(log) = read(&b[..k]) {
                log_common::check_log(&log, k);
            }
        }
        Source::Valid(m) => {
            let (data, ends) = valid(m);
            let whole = match read(&data) {
                Ok(l) => l,
                // Timed by a field no message has (only HEARTBEAT/SERVO_OUTPUT_RAW).
                Err(_) => return,
            };
            log_common::check_log(&whole, data.len());
            assert_eq!(whole.report.records, ends.len());
            assert!(whole.report.truncated.is_none());
            assert_eq!(whole.report.bad_records + whole.report.skipped_bytes, 0);
            let k = log_common::at(input.cut, data.len());
            if let Ok(prefix) = read(&data[..k]) {
                log_common::check_log(&prefix, k);
                log_common::check_prefix(&prefix, &whole, false);
                let whole_records = ends.iter().filter(|e| **e <= k).count();
                assert_eq!(prefix.report.records, whole_records, "cut at {k}");
                let boundary = k == 0 || ends.contains(&k);
                assert_eq!(prefix.report.truncated.is_none(), boundary, "cut at {k}");
            }
            if !input.flips.is_empty() && !data.is_empty() {
                let mut bad = data.clone();
                for (at, x) in &input.flips {
                    let k = log_common::at(*at, bad.len() - 1);
                    bad[k] ^= x;
                }
                if let Ok(log) = read(&bad) {
                    log_common::check_log(&log, bad.len());
                    assert!(log.report.records <= whole.report.records);
                }
            }
        }
    }
});
