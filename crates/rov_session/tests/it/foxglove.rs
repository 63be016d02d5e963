//! Foxglove's schemas in the sessions: the pose topics read by the official Python `mcap`
//! reader with its protobuf decoder (the transforms decode, the pose moves, NED → ENU),
//! and the camera video: written, read by time, from a key frame, corrupted messages
//! skipped and counted, kept by recovery.

use crate::common;

use std::collections::BTreeMap;

use crate::common::{info, record};
use rov_session::foxglove::{VehiclePose, decode_video, encode, video_message};
use rov_session::{
    NavRecord, Session, SessionError, SessionWriter, TruthRecord, WriterOptions, open, recover,
};

/// An H.264 access unit: a key frame (SPS, PPS, IDR) or a delta frame, tagged with `k`.
fn access_unit(k: u8, key: bool) -> Vec<u8> {
    if key {
        vec![
            0, 0, 0, 1, 0x67, 0x42, k, 0, 0, 1, 0x68, 0xCE, 0, 0, 1, 0x65, 0x88, k,
        ]
    } else {
        vec![0, 0, 0, 1, 0x41, 0x9A, k, k]
    }
}

/// The official Python reader with the protobuf decoder of `mcap-protobuf-support`.
fn python_decode(path: &std::path::Path) -> serde_json::Value {
    let script = r#"
import json, sys
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory
out = {"schemas": {}, "tf": [], "pose": [], "track": [], "video": []}
with open(sys.argv[1], "rb") as f:
    reader = make_reader(f, decoder_factories=[DecoderFactory()], validate_crcs=True)
    for schema, channel, message, proto in reader.iter_decoded_messages(
        topics=["/tf", "/vehicle/pose", "/vehicle/track", "/camera/video"]
    ):
        out["schemas"][channel.topic] = [schema.name, schema.encoding, channel.message_encoding]
        if channel.topic == "/tf":
            t, r = proto.translation, proto.rotation
            out["tf"].append([message.log_time, proto.parent_frame_id, proto.child_frame_id,
                              t.x, t.y, t.z, r.x, r.y, r.z, r.w,
                              proto.timestamp.seconds * 10**9 + proto.timestamp.nanos])
        elif channel.topic == "/vehicle/pose":
            p = proto.pose.position
            out["pose"].append([message.log_time, proto.frame_id, p.x, p.y, p.z])
        elif channel.topic == "/vehicle/track":
            out["track"].append([message.log_time, len(proto.poses)])
        else:
            out["video"].append([message.log_time, proto.format, proto.frame_id, list(proto.data)])
print(json.dumps(out))
"#;
    common::python_json(script, path)
}

/// The official reader decodes the transforms with the schema in the file; the vehicle
/// moves along its track and dives (ENU: z = −depth, x = east, y = north).
#[test]
fn the_official_reader_decodes_the_pose_and_the_pose_moves() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("dive.mcap");
    let ticks = record(&path, 1200, WriterOptions::default()); // 24 s
    let py = python_decode(&path);
    assert_eq!(
        py["schemas"]["/tf"],
        serde_json::json!(["foxglove.FrameTransform", "protobuf", "protobuf"])
    );
    assert_eq!(py["schemas"]["/vehicle/pose"][0], "foxglove.PoseInFrame");
    assert_eq!(py["schemas"]["/vehicle/track"][0], "foxglove.PosesInFrame");
    let tf = py["tf"].as_array().unwrap();
    assert_eq!(tf.len(), 240, "10 Hz");
    let row = |i: usize| -> Vec<f64> {
        tf[i].as_array().unwrap()[3..10]
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect()
    };
    assert_eq!(tf[0][1], "world");
    assert_eq!(tf[0][2], "vehicle");
    assert_eq!(tf[0][0], tf[0][10], "the stamp is the log time");
    // Each transform is its nav record's depth and attitude, at the position of the truth
    // written before it (the tick before: write_tick writes nav, then truth).
    for i in [0usize, 1, 100, 239] {
        let log_time = tf[i][0].as_u64().unwrap();
        let k = ((log_time - 6_000_000) / common::TICK_NS) as usize;
        let nav = &ticks[k].nav;
        let r = row(i);
        let want = VehiclePose::from_nav(log_time, nav, None).unwrap();
        let (east, north) = match k.checked_sub(1) {
            Some(p) => (ticks[p].truth.east_m, ticks[p].truth.north_m),
            None => (0.0, 0.0),
        };
        assert_eq!(
            &r[..3],
            &[east, north, -nav.depth_m],
            "x east, y north, z up"
        );
        for (a, b) in r[3..7].iter().zip(want.orientation_enu_flu()) {
            assert!((a - b).abs() < 1e-12, "{r:?}");
        }
    }
    // The pose moves: north 0.1 m/s (ENU y) and east −0.05 m/s (ENU x), depth changes.
    let (a, b) = (row(10), row(239));
    assert!(b[1] - a[1] > 2.0, "north: {a:?} → {b:?}");
    assert!(b[0] - a[0] < -1.0, "east: {a:?} → {b:?}");
    assert!((b[2] - a[2]).abs() > 0.1, "depth: {a:?} → {b:?}");
    let pose = py["pose"].as_array().unwrap();
    assert_eq!(pose.len(), 240);
    assert_eq!(pose[0][1], "world");
    assert_eq!(
        py["track"].as_array().unwrap().len(),
        3,
        "a track every 10 s"
    );
    assert!(py["track"][2][1].as_u64().unwrap() >= 4);
}

/// Video written, read by time range and from the key frame at or before a time; the
/// official reader decodes it too.
#[test]
fn video_is_written_and_read_by_time_and_key_frame() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("video.mcap");
    let mut w = SessionWriter::create(&path, &info(), 0).unwrap();
    // 25 fps for 12 s, a key frame every 2 s (50 frames), telemetry alongside.
    for k in 0..300u64 {
        let t = k * 40_000_000;
        let key = k % 50 == 0;
        w.write_video(t + 1_000, &access_unit(k as u8, key), key)
            .unwrap();
        if k % 2 == 0 {
            w.write(
                t,
                &NavRecord {
                    depth_m: 1.0,
                    ..NavRecord::default()
                },
            )
            .unwrap();
        }
    }
    // Refused: a key frame without parameter sets, an unflagged IDR, not Annex B.
    for (au, key) in [
        (access_unit(1, false), true),
        (access_unit(1, true), false),
        (vec![1, 2, 3], false),
    ] {
        let e = w.write_video(13_000_000_000, &au, key).unwrap_err();
        assert!(matches!(e, SessionError::Video { .. }), "{e}");
    }
    w.finish().unwrap();
    let s = open(&path).unwrap();
    assert_eq!(s.count("/camera/video"), 300);
    let frames: Vec<_> = s.video(2_000_000_000, 4_000_000_000).collect();
    assert_eq!(frames.len(), 50);
    assert!(frames.windows(2).all(|f| f[0].t_ns < f[1].t_ns));
    assert_eq!(frames[0].t_ns, 2_000_001_000);
    assert!(frames[0].key_frame && frames.iter().skip(1).all(|f| !f.key_frame));
    let key = s.video_key_frame_at_or_before(5_500_000_000).unwrap();
    assert_eq!(key.t_ns, 4_000_001_000);
    assert_eq!(&key.data[..], &access_unit(100, true)[..]);
    assert!(s.video_key_frame_at_or_before(0).is_none());
    let from_key: Vec<_> = s
        .video_from_key_frame(5_500_000_000, 5_500_000_000)
        .collect();
    assert_eq!(from_key.first().map(|f| f.t_ns), Some(4_000_001_000));
    assert_eq!(from_key.last().map(|f| f.t_ns), Some(5_480_001_000));
    let py = python_decode(&path);
    assert_eq!(
        py["schemas"]["/camera/video"][0],
        "foxglove.CompressedVideo"
    );
    let v = py["video"].as_array().unwrap();
    assert_eq!(v.len(), 300);
    assert_eq!(v[50][1], "h264");
    assert_eq!(v[50][2], "camera");
    let bytes: Vec<u8> = v[50][3]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| b.as_u64().unwrap() as u8)
        .collect();
    assert_eq!(bytes, access_unit(50, true));
}

/// A corrupted video message (another writer's junk) is skipped and counted; the frames
/// around it are returned.
#[test]
fn corrupted_video_messages_are_skipped_and_counted() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("junk.mcap");
    {
        let file = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
        let mut w = mcap::WriteOptions::new().create(file).unwrap();
        let schema = rov_session::foxglove::channel_schema(rov_session::Topic::Video);
        let sid = w
            .add_schema(&schema.name, &schema.encoding, &schema.data)
            .unwrap();
        let ch = w
            .add_channel(sid, "/camera/video", "protobuf", &BTreeMap::new())
            .unwrap();
        for k in 0..10u32 {
            let t = u64::from(k) * 40_000_000;
            let data = match k {
                3 => vec![0xFF; 7],                         // not protobuf
                6 => encode(&video_message(t, &[9, 9, 9])), // not Annex B
                _ => encode(&video_message(t, &access_unit(k as u8, k == 0))),
            };
            let h = mcap::records::MessageHeader {
                channel_id: ch,
                sequence: k,
                log_time: t,
                publish_time: t,
            };
            w.write_to_known_channel(&h, &data).unwrap();
        }
        w.finish().unwrap();
    }
    let s = open(&path).unwrap();
    let mut v = s.video(0, u64::MAX);
    let got: Vec<u64> = v.by_ref().map(|f| f.t_ns).collect();
    assert_eq!(got.len(), 8);
    assert!(!got.contains(&120_000_000) && !got.contains(&240_000_000));
    assert_eq!(v.stats().skipped, 2);
    assert_eq!(v.stats().frames, 8);
    assert!(
        v.stats()
            .first_error
            .as_deref()
            .unwrap()
            .contains("CompressedVideo")
    );
    assert!(decode_video(0, &[0xFF; 7]).is_err());
}

/// A killed recording with video: recovery keeps the video up to the last good record.
#[test]
fn recovery_keeps_the_video() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cut.mcap");
    let mut w = SessionWriter::create(&path, &info(), 0).unwrap();
    for k in 0..250u64 {
        let t = k * 40_000_000;
        w.write_video(t, &access_unit(k as u8, k % 50 == 0), k % 50 == 0)
            .unwrap();
        w.write(
            t,
            &TruthRecord {
                north_m: 1.0,
                ..TruthRecord::default()
            },
        )
        .unwrap();
    }
    w.flush().unwrap();
    // Killed: no summary; and the copy was cut two thirds of the way, inside a chunk.
    std::mem::forget(w);
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() * 2 / 3]).unwrap();
    let cut = Session::open(&path).unwrap();
    assert!(cut.damage().is_some());
    let before: Vec<u64> = cut.video(0, u64::MAX).map(|f| f.t_ns).collect();
    assert!(before.len() > 100 && before.len() < 250, "{}", before.len());
    let report = recover(&path).unwrap();
    let rec = open(&report.output).unwrap();
    assert!(rec.is_complete());
    let after: Vec<u64> = rec.video(0, u64::MAX).map(|f| f.t_ns).collect();
    assert_eq!(after, before);
    assert_eq!(
        rec.video_key_frame_at_or_before(u64::MAX).map(|k| k.t_ns),
        cut.video_key_frame_at_or_before(u64::MAX).map(|k| k.t_ns)
    );
}
