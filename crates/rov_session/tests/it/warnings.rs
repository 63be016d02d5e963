//! Sessions with gaps, out-of-order timestamps or unknown topics load, with warnings.

use std::collections::BTreeMap;

use crate::common::{info, tick, write_tick};
use rov_session::{Decoded, NavRecord, SessionError, SessionWriter, ThrustRecord, open};

#[test]
fn gaps_and_out_of_order_times_load_with_warnings() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("gappy.mcap");
    let mut w = SessionWriter::create(&path, &info(), 0).unwrap();
    for k in 0..100 {
        write_tick(&mut w, &tick(k)).unwrap();
    }
    // A 5 s hole in everything, then two nav messages written late (out of order).
    for k in 350..400 {
        write_tick(&mut w, &tick(k)).unwrap();
    }
    let late = NavRecord {
        depth_m: 42.0,
        ..NavRecord::default()
    };
    w.write(7_000_000_000 + 3, &late).unwrap();
    w.write(7_000_000_000 + 1, &late).unwrap();
    w.finish().unwrap();

    let s = open(&path).unwrap();
    assert!(s.is_complete());
    // Order and gaps are what a read of the messages finds.
    let report = s.check();
    assert!(report.damage.is_none());
    let all = report.warnings.join("\n");
    assert!(
        all.contains("earlier than the message before them"),
        "{all}"
    );
    assert!(all.contains("/telemetry/nav: 1 gap(s)"), "{all}");
    assert!(all.contains("the longest is 5.020 s"), "{all}");
    // Sorted by time: the late messages sit in order among the others.
    let times: Vec<u64> = s.messages().map(|m| m.t_ns).collect();
    assert!(times.windows(2).all(|w| w[0] <= w[1]));
    let nav = s.records::<NavRecord>().unwrap();
    assert_eq!(nav.len(), 152);
    let i = nav.iter().position(|(t, _)| *t == 7_000_000_001).unwrap();
    assert_eq!(nav[i + 1].0, 7_000_000_003);
    assert!(nav[i - 1].0 < 7_000_000_001 && nav[i + 2].0 > 7_000_000_003);
    // Time order is stable among equal times and file order is kept for recovery.
    assert_eq!(s.messages_in_file_order().count(), s.len());
}

/// A file from another writer: unchunked, an unknown JSON topic, an unknown binary topic
/// and a known topic name with a foreign encoding.
#[test]
fn unknown_topics_are_kept_raw_and_listed() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("foreign.mcap");
    {
        let file = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
        let mut w = mcap::WriteOptions::new()
            .use_chunks(false)
            .compression(None)
            .create(file)
            .unwrap();
        let none = BTreeMap::new();
        let sonar = w.add_channel(0, "/sonar/ping", "json", &none).unwrap();
        let jpeg = w.add_channel(0, "/camera/jpeg", "jpeg", &none).unwrap();
        let nav_cbor = w.add_channel(0, "/command/thrust", "cbor", &none).unwrap();
        let nav_schema = w
            .add_schema("topside.TelemetryNav", "jsonschema", b"{}")
            .unwrap();
        let nav = w
            .add_channel(nav_schema, "/telemetry/nav", "json", &none)
            .unwrap();
        for k in 0..20u32 {
            let t = u64::from(k) * 50_000_000;
            let hdr = |channel_id| mcap::records::MessageHeader {
                channel_id,
                sequence: k,
                log_time: t,
                publish_time: t,
            };
            let ping = format!(
                r#"{{"range_m": {}, "ok": true, "label": "a,b"}}"#,
                f64::from(k) * 0.5
            );
            w.write_to_known_channel(&hdr(sonar), ping.as_bytes())
                .unwrap();
            w.write_to_known_channel(&hdr(jpeg), &[0xFF, 0xD8, k as u8])
                .unwrap();
            w.write_to_known_channel(&hdr(nav_cbor), &[0xA0]).unwrap();
            let n = serde_json::to_vec(&NavRecord {
                depth_m: f64::from(k),
                ..NavRecord::default()
            })
            .unwrap();
            w.write_to_known_channel(&hdr(nav), &n).unwrap();
        }
        w.finish().unwrap();
    }
    let s = open(&path).unwrap();
    assert!(s.is_complete(), "{:?}", s.damage());
    let mut unknown = s.unknown_topics();
    unknown.sort();
    assert_eq!(unknown, ["/camera/jpeg", "/command/thrust", "/sonar/ping"]);
    let all = s.warnings().join("\n");
    assert!(
        all.contains("unknown topic /sonar/ping (20 messages"),
        "{all}"
    );
    assert!(all.contains(r#"unknown topic /command/thrust (20 messages, encoding "cbor" where "json" is expected)"#), "{all}");
    assert_eq!(s.records::<NavRecord>().unwrap().len(), 20);
    let e = s.records::<ThrustRecord>().unwrap_err();
    assert!(matches!(e, SessionError::WrongEncoding { .. }), "{e}");
    let ping = s.topic_messages("/sonar/ping").next().unwrap();
    assert_eq!(ping.topic(), "/sonar/ping");
    match ping.decode_any().unwrap() {
        Decoded::UnknownJson(v) => assert_eq!(v["ok"], true),
        other => panic!("{other:?}"),
    }
    let jpeg = s.topic_messages("/camera/jpeg").nth(3).unwrap();
    assert_eq!(
        jpeg.decode_any().unwrap(),
        Decoded::UnknownBytes(&[0xFF, 0xD8, 3])
    );
    // The export keeps the unknown JSON topic's fields as columns and says what it left out.
    let csv = rov_session::export_csv(&s).unwrap();
    assert!(
        csv.extra_columns
            .contains(&"sonar_ping.range_m".to_string()),
        "{:?}",
        csv.extra_columns
    );
    let header: Vec<&str> = csv.text.lines().next().unwrap().split(',').collect();
    let row: Vec<&str> = csv.text.lines().nth(2).unwrap().split(',').collect();
    let cell = |name: &str| row[header.iter().position(|h| *h == name).unwrap()];
    assert_eq!(cell("sonar_ping.range_m"), "0.5");
    assert_eq!(cell("sonar_ping.ok"), "1");
    assert_eq!(
        cell("sonar_ping.label"),
        "a;b",
        "commas in text are replaced"
    );
    assert_eq!(cell("depth_m"), "1");
    assert!(
        csv.warnings.iter().any(|w| w.contains("/camera/jpeg")),
        "{:?}",
        csv.warnings
    );
}
