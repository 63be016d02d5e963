//! The tlog reader on a log written by an independent writer: `tests/fixtures/pymavlink.tlog`
//! was written by pymavlink (`scripts/fixtures/make_tlog.py`), and
//! `pymavlink_tlog.json` is what pymavlink's own reader got back from it. Every field is
//! compared value by value, through the reader and through a map; a copy cut mid-record
//! reads to its last good record and says so; flipped bytes are skipped and counted.

use std::collections::{BTreeMap, BTreeSet};

use rov_logs::{Format, LogError, LogMap, ReadOptions, Series, read};
use serde_json::Value;

const TLOG: &[u8] = include_bytes!("../fixtures/pymavlink.tlog");
const JSON: &str = include_str!("../fixtures/pymavlink_tlog.json");

/// Enumeration fields: pymavlink gives their integer, the reader leaves them out (the
/// `mavlink` crate decodes them to enum variants, not numbers).
const ENUM_FIELDS: [&str; 7] = [
    "HEARTBEAT.type",
    "HEARTBEAT.autopilot",
    "HEARTBEAT.system_status",
    "BATTERY_STATUS.battery_function",
    "BATTERY_STATUS.type",
    "BATTERY_STATUS.charge_state",
    "BATTERY_STATUS.mode",
];

/// pymavlink's messages as series per `MESSAGE.field`, timed by the record timestamp (s),
/// or by each message's `time_field` (scaled) when given (messages without it left out).
fn expected(time_field: Option<(&str, f64)>) -> BTreeMap<String, Series> {
    let doc: Value = serde_json::from_str(JSON).unwrap();
    let mut out: BTreeMap<String, Series> = BTreeMap::new();
    for m in doc["messages"].as_array().unwrap() {
        let ty = m["type"].as_str().unwrap();
        let fields = m["fields"].as_object().unwrap();
        let t = match time_field {
            None => m["t_us"].as_u64().unwrap() as f64 * 1e-6,
            Some((f, scale)) => match fields.get(f) {
                Some(v) => v.as_f64().unwrap() * scale,
                None => continue,
            },
        };
        for (name, v) in fields {
            let s = out.entry(format!("{ty}.{name}")).or_default();
            s.t_s.push(t);
            s.v.push(v.as_f64().unwrap());
        }
    }
    out
}

#[test]
fn pymavlink_tlog_read_value_by_value() {
    assert_eq!(Format::detect(TLOG), Some(Format::Tlog));
    let log = read(TLOG, None, "pymavlink.tlog", &ReadOptions::default()).unwrap();
    let want = expected(None);
    let doc: Value = serde_json::from_str(JSON).unwrap();
    let n_msgs = doc["messages"].as_array().unwrap().len();
    assert_eq!(log.report.records, n_msgs);
    assert_eq!(log.report.bad_records, 0);
    assert_eq!(log.report.skipped_bytes, 0);
    assert!(log.report.truncated.is_none());
    // pymavlink's UNKNOWN_8002 (ASLUAV's SENS_POWER) is skipped and counted.
    let unknown = doc["unknown"]["UNKNOWN_8002"].as_u64().unwrap() as usize;
    assert!(unknown > 0);
    assert_eq!(log.report.unknown_types.get("msgid 8002"), Some(&unknown));
    assert_eq!(log.report.unknown_types.len(), 1);
    // Every field pymavlink decoded, except the enumerations, with the same samples.
    let got: BTreeSet<&str> = log.fields.keys().map(String::as_str).collect();
    let missing: BTreeSet<&str> = want
        .keys()
        .map(String::as_str)
        .filter(|k| !got.contains(k))
        .collect();
    assert_eq!(missing, ENUM_FIELDS.into_iter().collect());
    for name in &got {
        let w = want
            .get(*name)
            .unwrap_or_else(|| panic!("{name} not in pymavlink's dump"));
        let g = &log.fields[*name];
        assert_eq!(g.len(), w.len(), "{name}");
        for k in 0..g.len() {
            assert_eq!(g.t_s[k], w.t_s[k], "{name}[{k}] time");
            assert_eq!(g.v[k], w.v[k], "{name}[{k}]");
        }
    }
    // The fields the issue names, MAVLink v1 frames and the v2 extension outputs included.
    assert_eq!(log.fields["ATTITUDE.roll"].len(), 63);
    assert_eq!(log.fields["SERVO_OUTPUT_RAW.servo3_raw"].len(), 60);
    assert_eq!(log.fields["SERVO_OUTPUT_RAW.servo16_raw"].len(), 60);
    assert_eq!(log.fields["SCALED_PRESSURE2.press_abs"].len(), 60);
    assert_eq!(log.fields["VFR_HUD.alt"].len(), 60);
    assert_eq!(log.fields["BATTERY_STATUS.voltages[9]"].v[0], 65535.0);
    assert_eq!(log.fields["HEARTBEAT.base_mode"].v[1], 129.0);
}

#[test]
fn pymavlink_tlog_through_a_map() {
    let map = r#"
format = "tlog"
[time]
field = "tlog.timestamp_us"
[commands.thr3]
field = "SERVO_OUTPUT_RAW.servo3_raw"
pwm = [1100, 1500, 1900]
[commands.thr10]
field = "SERVO_OUTPUT_RAW.servo10_raw"
pwm = [1100, 1500, 1900]
[signals]
roll_deg = { field = "ATTITUDE.roll", unit = "rad" }
pitch_deg = { field = "ATTITUDE.pitch", unit = "rad" }
yaw_rate_dps = { field = "ATTITUDE.yawspeed", unit = "rad" }
heading_deg = { field = "VFR_HUD.heading" }
depth_m = { pressure_pa = "SCALED_PRESSURE2.press_abs", pressure_scale = 100.0, surface_pa = 101325.0, density_kg_m3 = 1025.0 }
"#;
    let m = LogMap::parse(map, "map.toml").unwrap();
    let mapped = m.read_apply(TLOG, "pymavlink.tlog").unwrap();
    let want = expected(None);
    let check = |got: &Series, from: &str, f: &dyn Fn(f64) -> f64| {
        let w = &want[from];
        assert_eq!(got.len(), w.len(), "{from}");
        for k in 0..w.len() {
            assert_eq!(got.t_s[k], w.t_s[k], "{from}[{k}] time");
            let (g, e) = (got.v[k], f(w.v[k]));
            assert!(
                (g - e).abs() <= 1e-9 * e.abs().max(1.0),
                "{from}[{k}]: {g} vs {e}"
            );
        }
    };
    let pwm = |us: f64| ((us - 1500.0) / 4.0).clamp(-100.0, 100.0);
    check(
        &mapped.commands["thr3"],
        "SERVO_OUTPUT_RAW.servo3_raw",
        &pwm,
    );
    check(
        &mapped.commands["thr10"],
        "SERVO_OUTPUT_RAW.servo10_raw",
        &pwm,
    );
    let deg = |x: f64| x * 180.0 / std::f64::consts::PI;
    check(&mapped.signals["roll_deg"], "ATTITUDE.roll", &deg);
    check(&mapped.signals["pitch_deg"], "ATTITUDE.pitch", &deg);
    check(&mapped.signals["yaw_rate_dps"], "ATTITUDE.yawspeed", &deg);
    check(&mapped.signals["heading_deg"], "VFR_HUD.heading", &|x| x);
    check(
        &mapped.signals["depth_m"],
        "SCALED_PRESSURE2.press_abs",
        &|hpa| (hpa * 100.0 - 101_325.0) / (1025.0 * 9.80665),
    );
    let table = mapped.lab_table();
    assert!(!table.t_s.is_empty());
    assert_eq!(table.commands.len(), 2);
    // servo3 swings ±300 µs about 1500 inside [1100, 1900]: nothing clamped.
    assert!(mapped.clamped.is_empty());
}

#[test]
fn tlog_timed_by_a_message_field() {
    let opts = ReadOptions {
        time_field: Some("ATTITUDE.time_boot_ms".into()),
        ..Default::default()
    };
    let log = read(TLOG, Some(Format::Tlog), "pymavlink.tlog", &opts).unwrap();
    let want = expected(Some(("time_boot_ms", 1e-3)));
    for name in ["ATTITUDE.roll", "SCALED_PRESSURE2.press_abs"] {
        assert_eq!(log.fields[name].t_s, want[name].t_s, "{name}");
        assert_eq!(log.fields[name].v, want[name].v, "{name}");
    }
    // Messages without `time_boot_ms` (HEARTBEAT, SERVO_OUTPUT_RAW, VFR_HUD,
    // BATTERY_STATUS) are untimed: skipped and counted, never given another clock.
    assert!(!log.fields.contains_key("VFR_HUD.alt"));
    assert_eq!(log.report.untimed_records, 6 + 60 + 60 + 5);
    // A time field no message has is an error that says what to name instead.
    let opts = ReadOptions {
        time_field: Some("X.no_such_time".into()),
        ..Default::default()
    };
    match read(TLOG, Some(Format::Tlog), "pymavlink.tlog", &opts) {
        Err(LogError::Unreadable { detail, .. }) => {
            assert!(detail.contains("no_such_time"), "{detail}");
            assert!(detail.contains("tlog.timestamp_us"), "{detail}");
        }
        other => panic!("{other:?}"),
    }
}

/// Record offsets of the fixture (every record: 8-byte stamp, frame).
fn record_starts() -> Vec<usize> {
    let mut out = Vec::new();
    let mut p = 0;
    while p < TLOG.len() {
        out.push(p);
        let len = TLOG[p + 9] as usize;
        let signed = TLOG[p + 8] == 0xFD && TLOG[p + 10] & 1 != 0;
        p += 8 + len + if TLOG[p + 8] == 0xFE { 8 } else { 12 } + if signed { 13 } else { 0 };
    }
    assert_eq!(p, TLOG.len());
    out
}

#[test]
fn tlog_cut_mid_record_reads_to_its_last_good_record() {
    let full = read(TLOG, None, "t", &ReadOptions::default()).unwrap();
    let starts = record_starts();
    let total = full.report.records + full.report.unknown_types.values().sum::<usize>();
    assert_eq!(starts.len(), total);
    // Cut inside the last record's frame, inside its stamp, and just after its stamp.
    let last = *starts.last().unwrap();
    for cut in [TLOG.len() - 3, last + 5, last + 9] {
        let log = read(
            &TLOG[..cut],
            Some(Format::Tlog),
            "t",
            &ReadOptions::default(),
        )
        .unwrap();
        assert_eq!(log.report.records, full.report.records - 1, "cut at {cut}");
        let why = log.report.truncated.as_deref().unwrap();
        assert!(
            log.report
                .sentences()
                .iter()
                .any(|s| s.contains("last good record")),
            "{why}"
        );
        let n: usize = log.fields.values().map(Series::len).sum();
        assert!(n < full.fields.values().map(Series::len).sum::<usize>());
    }
    // Cut at half the file, mid-record: every record before the cut is read.
    let mid = TLOG.len() / 2;
    let whole_before = starts.iter().filter(|s| **s < mid).count() - 1;
    let log = read(
        &TLOG[..mid],
        Some(Format::Tlog),
        "t",
        &ReadOptions::default(),
    )
    .unwrap();
    let unknown: usize = log.report.unknown_types.values().sum();
    assert_eq!(log.report.records + unknown, whole_before);
    assert!(log.report.truncated.is_some());
}

#[test]
fn tlog_with_flipped_bytes_skips_and_counts() {
    let starts = record_starts();
    let full = read(TLOG, None, "t", &ReadOptions::default()).unwrap();
    // Flip a payload byte of record 20 (CRC fails), the length byte of record 40 (the
    // frame boundary is lost: resynchronise), and the start byte of record 60.
    let mut bad = TLOG.to_vec();
    bad[starts[20] + 8 + 12] ^= 0x5A;
    bad[starts[40] + 9] ^= 0x21;
    bad[starts[60] + 8] ^= 0xFF;
    let log = read(&bad, Some(Format::Tlog), "t", &ReadOptions::default()).unwrap();
    assert!(log.report.truncated.is_none());
    assert_eq!(log.report.bad_records, 2, "{:?}", log.report);
    assert_eq!(log.report.records, full.report.records - 3);
    assert!(log.report.skipped_bytes > 0);
    assert!(!log.report.sentences().is_empty());
    // Every value read is one pymavlink read at the same time (nothing invented).
    let want = expected(None);
    for (name, s) in &log.fields {
        let w = &want[name];
        let mut j = 0;
        for (t, v) in s.t_s.iter().zip(&s.v) {
            while w.t_s[j] != *t {
                j += 1;
            }
            assert_eq!(w.v[j], *v, "{name} at {t}");
        }
    }
    // Garbage between records and a stray tail.
    let mut g = TLOG[..starts[10]].to_vec();
    g.extend([0xFE, 0x00, 0x13, 0x37, 0xFD, 0xFD, 0x42]);
    g.extend(&TLOG[starts[10]..]);
    g.extend([0xAA; 5]);
    let log = read(&g, Some(Format::Tlog), "t", &ReadOptions::default()).unwrap();
    assert_eq!(log.report.records, full.report.records);
    assert_eq!(log.report.skipped_bytes, 7);
    assert!(log.report.truncated.is_some());
}

#[test]
fn signed_v2_frames_are_read() {
    // The fixture's second record (an ATTITUDE, MAVLink v2), re-sent signed: incompat
    // flag bit 0 set, CRC recomputed (it covers the flags), 13 signature bytes appended
    // (link id, 6-byte timestamp, 6-byte signature: not checked, as no key is known).
    let starts = record_starts();
    let rec = &TLOG[starts[1]..starts[2]];
    assert_eq!(rec[8], 0xFD);
    let mut frame = rec[8..rec.len() - 2].to_vec();
    frame[2] |= 0x01;
    let extra = 39; // ATTITUDE's CRC-extra
    let crc = mavlink::calculate_crc(&frame[1..], extra);
    let mut signed = rec[..8].to_vec();
    signed.extend(&frame);
    signed.extend(crc.to_le_bytes());
    signed.extend([7u8; 13]);
    // The signed record, then the rest of the log.
    let mut log_bytes = signed.clone();
    log_bytes.extend(&TLOG[starts[2]..]);
    let log = read(&log_bytes, None, "signed.tlog", &ReadOptions::default()).unwrap();
    assert_eq!(log.report.bad_records, 0, "{:?}", log.report);
    assert_eq!(log.report.skipped_bytes, 0);
    let want = expected(None);
    assert_eq!(log.fields["ATTITUDE.roll"].v, want["ATTITUDE.roll"].v);
}

/// The shipped ArduSub tlog map (config/maps/ardusub_tlog.toml) reads the pymavlink log:
/// every field it names exists with MAVLink's spelling, six motor channels and the seven
/// signals come out, and the heading is ATTITUDE.yaw in degrees.
#[test]
fn shipped_ardusub_tlog_map_reads_the_pymavlink_log() {
    let text = include_str!("../../../../config/maps/ardusub_tlog.toml");
    let m = LogMap::parse(text, "ardusub_tlog.toml").unwrap();
    let mapped = m.read_apply(TLOG, "pymavlink.tlog").unwrap();
    assert_eq!(mapped.commands.len(), 6);
    assert_eq!(mapped.signals.len(), 7);
    let want = expected(None);
    let yaw = &want["ATTITUDE.yaw"];
    let got = &mapped.signals["heading_deg"];
    assert_eq!(got.len(), yaw.len());
    for (g, e) in got.v.iter().zip(&yaw.v) {
        assert!((g - e.to_degrees()).abs() < 1e-9, "{g} vs {e}");
    }
    let table = mapped.lab_table();
    assert!(table.t_s.len() > 10);
    assert!(table.signals["depth_m"].iter().any(|d| d.is_finite()));
}
