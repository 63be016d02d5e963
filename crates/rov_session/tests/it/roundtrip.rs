//! Round trip of every topic, cross-checked with the `mcap` crate's reader and the
//! official Python reader.

use crate::common;

use std::collections::BTreeMap;

use crate::common::{info, python_read, record};
use rov_session::{
    AutopilotRecord, Decoded, Direction, EventRecord, LinkRecord, NavRecord, ObserverRecord,
    PilotRecord, Record, SessionInfo, StatusRecord, ThrustRecord, Topic, TruthRecord,
    WriterOptions, open,
};

fn expect_records<T: Record>(s: &rov_session::Session, want: Vec<(u64, T)>) {
    let got = s.records::<T>().unwrap();
    assert_eq!(got.len(), want.len(), "{}", T::TOPIC.name());
    for (g, w) in got.iter().zip(&want) {
        assert_eq!(g, w, "{}", T::TOPIC.name());
    }
}

#[test]
fn every_topic_reads_back_identical() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("dive.mcap");
    let ticks = record(&path, 600, WriterOptions::default());
    let s = open(&path).unwrap();
    assert!(s.is_complete(), "{:?}", s.damage());
    assert!(s.warnings().is_empty(), "{:?}", s.warnings());
    assert!(s.is_indexed(), "a complete file opens through its summary");

    let nav: Vec<_> = ticks
        .iter()
        .map(|t| (t.t_ns + 6_000_000, t.nav.clone()))
        .collect();
    expect_records::<NavRecord>(&s, nav);
    expect_records::<TruthRecord>(
        &s,
        ticks
            .iter()
            .map(|t| (t.t_ns + 6_000_000, t.truth.clone()))
            .collect(),
    );
    expect_records::<ObserverRecord>(
        &s,
        ticks
            .iter()
            .map(|t| (t.t_ns + 6_100_000, t.observer.clone()))
            .collect(),
    );
    expect_records::<PilotRecord>(
        &s,
        ticks
            .iter()
            .map(|t| (t.t_ns + 6_100_000, t.pilot.clone()))
            .collect(),
    );
    expect_records::<AutopilotRecord>(
        &s,
        ticks
            .iter()
            .map(|t| (t.t_ns + 6_100_000, t.autopilot.clone()))
            .collect(),
    );
    expect_records::<ThrustRecord>(
        &s,
        ticks
            .iter()
            .map(|t| (t.t_ns + 6_200_000, t.thrust.clone()))
            .collect(),
    );
    let sparse = |f: &dyn Fn(&common::Tick) -> bool| ticks.iter().filter(|t| f(t)).count();
    expect_records::<StatusRecord>(
        &s,
        ticks
            .iter()
            .filter_map(|t| t.status.clone().map(|r| (t.t_ns + 7_000_000, r)))
            .collect(),
    );
    expect_records::<LinkRecord>(
        &s,
        ticks
            .iter()
            .filter_map(|t| t.link.clone().map(|r| (t.t_ns + 7_000_000, r)))
            .collect(),
    );
    expect_records::<EventRecord>(
        &s,
        ticks
            .iter()
            .filter_map(|t| t.event.clone().map(|r| (t.t_ns + 7_000_000, r)))
            .collect(),
    );
    assert_eq!(s.records::<SessionInfo>().unwrap(), vec![(0, info())]);
    assert_eq!(s.info(), Some(info()));

    let tx: Vec<(u64, Vec<u8>)> = s.raw_frames(Direction::Tx).collect();
    let want_tx: Vec<(u64, Vec<u8>)> = ticks.iter().map(|t| (t.t_ns, t.tx.clone())).collect();
    assert_eq!(tx, want_tx);
    let rx: Vec<(u64, Vec<u8>)> = s.raw_frames(Direction::Rx).collect();
    let want_rx: Vec<(u64, Vec<u8>)> = ticks
        .iter()
        .map(|t| (t.t_ns + 6_000_000, t.rx.clone()))
        .collect();
    assert_eq!(rx, want_rx);

    let n = ticks.len();
    // The pose topics: one pose every 100 ms of nav (every 5th tick), a track every 10 s.
    let poses = n.div_ceil(5);
    assert_eq!(s.count("/tf"), poses);
    assert_eq!(s.count("/vehicle/pose"), poses);
    assert_eq!(s.count("/vehicle/track"), 2);
    let total = 1
        + 8 * n
        + sparse(&|t| t.status.is_some())
        + sparse(&|t| t.link.is_some())
        + sparse(&|t| t.event.is_some())
        + 2 * poses
        + 2;
    assert_eq!(s.len(), total);
    assert_eq!(s.topics().len(), 15);
    assert!(s.unknown_topics().is_empty());
    // Time order, and every message decodes by its topic.
    let mut last = 0;
    let mut count = 0;
    for m in s.messages() {
        assert!(m.t_ns >= last);
        last = m.t_ns;
        count += 1;
        match m.decode_any().unwrap() {
            Decoded::UnknownJson(_) | Decoded::UnknownBytes(_) => {
                panic!("unknown {}", m.topic())
            }
            Decoded::Raw { direction, frame } => {
                assert_eq!(direction.topic().name(), m.topic(), "{frame:?}")
            }
            _ => {}
        }
    }
    assert_eq!(count, total);
    assert_eq!(
        s.config_toml().as_deref(),
        Some(info().config_toml.as_str())
    );
    let (name, meta) = &s.metadata()[0];
    assert_eq!(name, "session");
    assert_eq!(meta["vehicle"], "sim");
    assert_eq!(s.attachments()[0].media_type, "application/toml");
    let nav_schema = s
        .schemas()
        .values()
        .find(|sc| sc.name == "topside.TelemetryNav")
        .unwrap();
    assert_eq!(nav_schema.encoding, "jsonschema");
    let schema: serde_json::Value = serde_json::from_slice(&nav_schema.data).unwrap();
    assert_eq!(
        schema["properties"]["depth_m"]["description"],
        "Depth, m, positive down."
    );
    assert!((s.duration_s() - (n as f64 - 1.0) * 0.02 - 0.0062).abs() < 1e-9);
}

/// The `mcap` crate's own reader sees exactly the messages ours sees, in file order.
#[test]
fn the_mcap_crate_reads_the_same_messages() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("dive.mcap");
    record(&path, 300, WriterOptions::default());
    let bytes = std::fs::read(&path).unwrap();
    let theirs: Vec<(String, u64, u32, Vec<u8>)> = mcap::MessageStream::new(&bytes)
        .unwrap()
        .map(|m| {
            let m = m.unwrap();
            (
                m.channel.topic.clone(),
                m.log_time,
                m.sequence,
                m.data.into_owned(),
            )
        })
        .collect();
    let s = open(&path).unwrap();
    let ours: Vec<(String, u64, u32, Vec<u8>)> = s
        .messages_in_file_order()
        .map(|m| (m.topic().to_string(), m.t_ns, m.sequence, m.data().to_vec()))
        .collect();
    assert_eq!(ours.len(), theirs.len());
    assert!(ours == theirs, "message streams differ");
    let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
    assert_eq!(summary.stats.unwrap().message_count, s.len() as u64);
    assert!(
        summary.chunk_indexes.len() > 20,
        "small chunks: {}",
        summary.chunk_indexes.len()
    );
}

/// The official Python reader (PyPI `mcap`) reads every message of a file we wrote.
#[test]
fn the_official_python_reader_reads_every_message() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("dive.mcap");
    let ticks = record(&path, 400, WriterOptions::default());
    let s = open(&path).unwrap();
    let py = python_read(&path);
    let mut ours = BTreeMap::new();
    for t in s.topics() {
        ours.insert(t.topic.clone(), t.count as u64);
    }
    let theirs: BTreeMap<String, u64> = serde_json::from_value(py["counts"].clone()).unwrap();
    assert_eq!(theirs, ours);
    assert_eq!(py["summary_messages"], s.len() as u64);
    for topic in Topic::ALL.into_iter().filter(|t| *t != Topic::Video) {
        let enc = &py["encodings"][topic.name()];
        assert_eq!(enc[0], topic.encoding(), "{}", topic.name());
        let schema_encoding = if topic.is_raw() {
            ""
        } else if topic.is_foxglove() {
            "protobuf"
        } else {
            "jsonschema"
        };
        assert_eq!(enc[1], schema_encoding, "{}", topic.name());
    }
    let nav = &py["first"]["/telemetry/nav"];
    assert_eq!(nav["depth_m"].as_f64().unwrap(), ticks[0].nav.depth_m);
    assert_eq!(
        nav["heading_deg"].as_f64().unwrap(),
        ticks[0].nav.heading_deg
    );
    assert_eq!(py["first"]["/autopilot/state"]["depth_mode"], "hold");
    assert_eq!(py["first"]["/session/info"]["vehicle"], "sim");
    assert_eq!(py["attachments"][0], "config.toml");
    assert_eq!(py["metadata"]["session"]["vehicle"], "sim");
}

#[test]
fn uncompressed_files_read_too() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("plain.mcap");
    let opts = WriterOptions {
        compress: false,
        ..WriterOptions::default()
    };
    let ticks = record(&path, 100, opts);
    let s = open(&path).unwrap();
    assert!(s.is_complete());
    let nav = s.records::<NavRecord>().unwrap();
    assert_eq!(nav.last().unwrap().1, ticks.last().unwrap().nav);
    let py = python_read(&path);
    assert_eq!(py["counts"]["/telemetry/nav"], 100);
}

/// Files of other writers: lz4 chunks and unchunked messages read the same.
#[test]
fn lz4_and_unchunked_files_of_other_writers_read_too() {
    let dir = tempfile::tempdir().unwrap();
    for (name, compression, chunks) in [
        ("lz4.mcap", Some(mcap::Compression::Lz4), true),
        ("plain.mcap", None, false),
    ] {
        let path = dir.path().join(name);
        let navs: Vec<NavRecord> = (0..300).map(|k| common::tick(k).nav).collect();
        {
            let file = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
            let mut w = mcap::WriteOptions::new()
                .compression(compression)
                .use_chunks(chunks)
                .chunk_size(Some(4096))
                .create(file)
                .unwrap();
            let schema = w
                .add_schema(
                    "topside.TelemetryNav",
                    "jsonschema",
                    NavRecord::json_schema().to_string().as_bytes(),
                )
                .unwrap();
            let ch = w
                .add_channel(schema, "/telemetry/nav", "json", &BTreeMap::new())
                .unwrap();
            for (k, nav) in navs.iter().enumerate() {
                let header = mcap::records::MessageHeader {
                    channel_id: ch,
                    sequence: k as u32,
                    log_time: k as u64 * 20_000_000,
                    publish_time: 0,
                };
                w.write_to_known_channel(&header, &serde_json::to_vec(nav).unwrap())
                    .unwrap();
            }
            w.finish().unwrap();
        }
        let s = open(&path).unwrap();
        assert!(s.is_complete(), "{name}: {:?}", s.damage());
        let back: Vec<NavRecord> = s
            .records::<NavRecord>()
            .unwrap()
            .into_iter()
            .map(|(_, n)| n)
            .collect();
        assert_eq!(back, navs, "{name}");
    }
}
