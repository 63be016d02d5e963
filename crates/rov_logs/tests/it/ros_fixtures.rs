//! ROS 1 bags and ROS 2 MCAP bags written by an independent writer (the `rosbags` Python
//! package, `scripts/fixtures/make_rosbags.py`), read here and compared value by value
//! with what rosbags' own readers decoded (`tests/fixtures/ros_expected.json`); the same
//! files cut short and corrupted; undecodable types skipped and counted.

#![allow(clippy::needless_range_loop)] // value-by-value comparisons index two lists alike

use std::collections::BTreeSet;

use rov_logs::{Format, LogMap, ReadOptions, read};

use serde_json::Value;

const DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures");

fn file(name: &str) -> Vec<u8> {
    std::fs::read(format!("{DIR}/{name}")).unwrap()
}

fn expected(which: &str) -> serde_json::Map<String, Value> {
    let text = std::fs::read_to_string(format!("{DIR}/ros_expected.json")).unwrap();
    let v: Value = serde_json::from_str(&text).unwrap();
    v[which].as_object().unwrap().clone()
}

fn nums(v: &Value) -> Vec<Option<f64>> {
    v.as_array().unwrap().iter().map(Value::as_f64).collect()
}

fn opts(time: &str, names: impl Iterator<Item = String>) -> ReadOptions {
    ReadOptions {
        time_field: Some(time.into()),
        time_scale: None,
        only: Some(names.collect::<BTreeSet<_>>()),
    }
}

/// Every expected field read with both time spellings and compared value by value;
/// with `prefix`, the log may hold fewer samples (a cut copy) but at least one.
fn compare(bytes: &[u8], which: &str, prefix: bool) -> rov_logs::Log {
    let exp = expected(which);
    let mut last = None;
    for stamp in [false, true] {
        let time = if stamp {
            "/imu:header.stamp"
        } else {
            "@log_time"
        };
        let log = read(bytes, None, which, &opts(time, exp.keys().cloned())).unwrap();
        for (name, e) in &exp {
            let s = log
                .fields
                .get(name)
                .unwrap_or_else(|| panic!("{which}: {name} missing; have {:?}", log.names()));
            let v = nums(&e["v"]);
            let t_stamp = nums(&e["t_stamp_s"]);
            let t_log = nums(&e["t_log_s"]);
            if prefix {
                assert!(!s.is_empty() && s.len() <= v.len(), "{which} {name}");
            } else {
                assert_eq!(s.len(), v.len(), "{which} {name}");
            }
            for k in 0..s.len() {
                // serde_json's default float parsing may be one ulp off the shortest
                // round-trip text Python writes: equal to 1e-14 relative.
                let e = v[k].unwrap();
                assert!(
                    (s.v[k] - e).abs() <= 1e-14 * e.abs().max(1.0),
                    "{which} {name} value {k}: {} vs {e}",
                    s.v[k]
                );
                let t = if stamp {
                    t_stamp[k].or(t_log[k])
                } else {
                    t_log[k]
                };
                let t = t.unwrap();
                assert!(
                    (s.t_s[k] - t).abs() < 1e-6,
                    "{which} {name} time {k}: {} vs {t}",
                    s.t_s[k]
                );
            }
        }
        if stamp {
            // /depth and /array are std_msgs without a header: timed by their log time, said.
            let notes = log.report.notes.join(" ");
            assert!(
                notes.contains("/depth") && notes.contains("/array"),
                "{notes}"
            );
            assert!(!notes.contains("/imu"), "{notes}");
        }
        last = Some(log);
    }
    last.unwrap()
}

#[test]
fn ros1_bag_matches_rosbags_value_by_value() {
    let bytes = file("ros1.bag");
    assert_eq!(Format::detect(&bytes), Some(Format::Ros1));
    let log = compare(&bytes, "ros1", false);
    assert!(log.report.truncated.is_none(), "{:?}", log.report);
    // The connection whose definition names an undefined type: skipped and counted.
    let unknown: usize = log
        .report
        .unknown_types
        .iter()
        .filter(|(k, _)| k.contains("foo_msgs/Broken"))
        .map(|(_, n)| *n)
        .sum();
    assert_eq!(unknown, 4, "{:?}", log.report.unknown_types);
    assert_eq!(log.report.bad_records, 0);
}

#[test]
fn ros1_bag_with_lz4_chunks_reads_the_same() {
    let bytes = file("ros1_lz4.bag");
    let log = compare(&bytes, "ros1", false);
    assert!(log.report.truncated.is_none());
}

#[test]
fn ros2_mcap_matches_rosbags_value_by_value() {
    let bytes = file("ros2.mcap");
    assert_eq!(Format::detect(&bytes), Some(Format::Mcap));
    // The fixture holds both byte orders: /odom_be big-endian (CDR header 00 00).
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        let be = m.channel.topic == "/odom_be";
        assert_eq!(
            m.data[..2],
            if be { [0, 0] } else { [0, 1] },
            "{}",
            m.channel.topic
        );
    }
    let log = compare(&bytes, "ros2", false);
    assert!(log.report.truncated.is_none(), "{:?}", log.report);
    assert!(log.report.unknown_types.is_empty());
    assert_eq!(log.report.bad_records, 0);
}

#[test]
fn cut_short_bags_read_to_their_last_good_record() {
    for (name, which) in [
        ("ros1.bag", "ros1"),
        ("ros1_lz4.bag", "ros1"),
        ("ros2.mcap", "ros2"),
    ] {
        let bytes = file(name);
        let cut = &bytes[..bytes.len() * 3 / 5];
        let log = compare(cut, which, true);
        let t = log.report.truncated.clone();
        assert!(t.is_some(), "{name}: {:?}", log.report);
        let full = read(
            &bytes,
            None,
            name,
            &opts(
                "@log_time",
                ["/imu:angular_velocity.z".to_string()].into_iter(),
            ),
        )
        .unwrap();
        let n_cut = log.fields["/imu:angular_velocity.z"].len();
        let n_full = full.fields["/imu:angular_velocity.z"].len();
        assert!(
            n_cut > n_full / 4 && n_cut < n_full,
            "{name}: {n_cut} of {n_full}"
        );
        assert!(
            log.report
                .sentences()
                .iter()
                .any(|s| s.contains("last good record"))
        );
    }
}

/// Through a log map: a ROS 2 bag's IMU, depth and RC outputs become the lab's signals and
/// a command channel (ENU→NED, rad→deg, PWM→%), each with its own times.
#[test]
fn ros_bags_through_a_log_map() {
    let exp = expected("ros2");
    for (name, format) in [("ros2.mcap", "mcap"), ("ros1.bag", "ros1")] {
        let map = LogMap::parse(
            &format!(
                r#"
format = "{format}"
[time]
field = "/imu:header.stamp"
[commands.thr3]
field = "/rc_out:channels[2]"
pwm = [1100, 1500, 1900]
[signals]
yaw_rate_dps = {{ field = "/imu:angular_velocity.z", unit = "rad", frame = "enu" }}
depth_m = {{ field = "/depth:data" }}
surge_mps = {{ field = "/odom:twist.twist.linear.x" }}
"#
            ),
            "ros.toml",
        )
        .unwrap();
        let m = map.read_apply(&file(name), name).unwrap();
        let r = &m.signals["yaw_rate_dps"];
        let z = nums(&exp["/imu:angular_velocity.z"]["v"]);
        let ts = nums(&exp["/imu:angular_velocity.z"]["t_stamp_s"]);
        assert_eq!(r.len(), z.len());
        for k in 0..r.len() {
            // ENU/FLU yaw rate (z up) is the negative of the NED/FRD one.
            assert!((r.v[k] + z[k].unwrap().to_degrees()).abs() < 1e-9);
            assert!((r.t_s[k] - ts[k].unwrap()).abs() < 1e-6);
        }
        let thr = &m.commands["thr3"];
        let ch = nums(&exp["/rc_out:channels[2]"]["v"]);
        assert_eq!(thr.len(), ch.len());
        let mut clamped = 0;
        for k in 0..thr.len() {
            let us = ch[k].unwrap();
            let pct = (100.0 * (us - 1500.0) / 400.0).clamp(-100.0, 100.0);
            clamped += usize::from(!(1100.0..=1900.0).contains(&us));
            assert!((thr.v[k] - pct).abs() < 1e-9, "{name} thr3 {k}");
        }
        assert_eq!(m.clamped.get("thr3").copied().unwrap_or(0), clamped);
        assert_eq!(
            m.signals["depth_m"].len(),
            nums(&exp["/depth:data"]["v"]).len()
        );
        assert_eq!(m.signals["surge_mps"].len(), 100);
        // A field the log lacks is named with the fields present.
        let bad = LogMap::parse(
            &format!("format = \"{format}\"\n[signals]\ndepth_m = {{ field = \"/depth:dat\" }}\n"),
            "bad.toml",
        )
        .unwrap();
        let err = bad.read_apply(&file(name), name).unwrap_err().to_string();
        assert!(
            err.contains("/depth:dat") && err.contains("/depth:data"),
            "{err}"
        );
        assert!(err.contains("/imu:angular_velocity.z"), "{err}");
    }
}

/// Corrupted bytes: a ROS 1 record header made unparseable, an MCAP chunk whose CRC fails.
/// Both are read to their last good record and say so.
#[test]
fn corrupted_bags_read_to_their_last_good_record() {
    let imu = || {
        opts(
            "@log_time",
            ["/imu:angular_velocity.z".to_string()].into_iter(),
        )
    };
    // ROS 1: the field length before the third chunk's `compression=` made huge.
    let mut bag = file("ros1.bag");
    let needle = b"compression=none";
    let at: Vec<usize> = bag
        .windows(needle.len())
        .enumerate()
        .filter(|(_, w)| *w == needle)
        .map(|(i, _)| i)
        .collect();
    assert!(at.len() >= 4, "want several chunks, have {}", at.len());
    bag[at[2] - 4..at[2]].copy_from_slice(&[0xff; 4]);
    let full = read(&file("ros1.bag"), None, "a", &imu()).unwrap();
    let log = read(&bag, None, "a", &imu()).unwrap();
    let n = log.fields["/imu:angular_velocity.z"].len();
    let n_full = full.fields["/imu:angular_velocity.z"].len();
    assert!(n > 0 && n < n_full, "{n} of {n_full}");
    assert_eq!(
        log.fields["/imu:angular_velocity.z"].v[..n],
        full.fields["/imu:angular_velocity.z"].v[..n]
    );
    let said = log.report.truncated.clone().unwrap();
    assert!(said.contains("corrupt"), "{said}");

    // MCAP: rosbags writes one uncompressed chunk without a CRC, where flipped bytes
    // cannot be told from data; the same messages rewritten by the `mcap` crate in small
    // zstd chunks with CRCs, then bytes in the middle flipped: the chunk's CRC fails.
    let m0 = rechunk(&file("ros2.mcap"));
    let mut m = m0.clone();
    let zstd_frames: Vec<usize> = m
        .windows(4)
        .enumerate()
        .filter(|(_, w)| *w == [0x28, 0xb5, 0x2f, 0xfd])
        .map(|(i, _)| i)
        .collect();
    assert!(zstd_frames.len() > 4, "{} chunks", zstd_frames.len());
    let mid = zstd_frames[zstd_frames.len() / 2] + 64;
    for b in &mut m[mid..mid + 16] {
        *b ^= 0x5a;
    }
    let full = read(&m0, None, "b", &imu()).unwrap();
    let log = read(&m, None, "b", &imu()).unwrap();
    let n = log.fields["/imu:angular_velocity.z"].len();
    let n_full = full.fields["/imu:angular_velocity.z"].len();
    assert!(n > 0 && n < n_full, "{n} of {n_full}: {:?}", log.report);
    assert_eq!(
        log.fields["/imu:angular_velocity.z"].v[..n],
        full.fields["/imu:angular_velocity.z"].v[..n]
    );
    assert!(log.report.truncated.is_some(), "{:?}", log.report);
}

/// The fixture's messages rewritten by the `mcap` crate: zstd chunks of 16 KiB with CRCs,
/// and a JSON channel this crate does not decode.
fn rechunk(bytes: &[u8]) -> Vec<u8> {
    let mut w = mcap::WriteOptions::new()
        .compression(Some(mcap::Compression::Zstd))
        .chunk_size(Some(16 * 1024))
        .create(std::io::Cursor::new(Vec::new()))
        .unwrap();
    let json_schema = w.add_schema("Status", "jsonschema", b"{}").unwrap();
    let json = w
        .add_channel(json_schema, "/json_status", "json", &Default::default())
        .unwrap();
    let mut ids = std::collections::HashMap::new();
    for (k, m) in mcap::MessageStream::new(bytes).unwrap().enumerate() {
        let m = m.unwrap();
        let ch = &m.channel;
        let id = *ids.entry(ch.id).or_insert_with(|| {
            let s = ch.schema.as_ref().unwrap();
            let sid = w.add_schema(&s.name, &s.encoding, &s.data).unwrap();
            w.add_channel(sid, &ch.topic, &ch.message_encoding, &ch.metadata)
                .unwrap()
        });
        let h = mcap::records::MessageHeader {
            channel_id: id,
            sequence: m.sequence,
            log_time: m.log_time,
            publish_time: m.publish_time,
        };
        w.write_to_known_channel(&h, &m.data).unwrap();
        if k % 100 == 0 {
            let h = mcap::records::MessageHeader {
                channel_id: json,
                sequence: k as u32,
                log_time: m.log_time,
                publish_time: m.log_time,
            };
            w.write_to_known_channel(&h, b"{\"ok\": true}").unwrap();
        }
    }
    w.finish().unwrap();
    w.into_inner().into_inner()
}

#[test]
fn mcap_in_zstd_chunks_reads_the_same_and_counts_undecodable_channels() {
    let m = rechunk(&file("ros2.mcap"));
    let log = compare(&m, "ros2", false);
    assert!(log.report.truncated.is_none(), "{:?}", log.report);
    let unknown: usize = log
        .report
        .unknown_types
        .iter()
        .filter(|(k, _)| k.contains("Status") && k.contains("json"))
        .map(|(_, n)| *n)
        .sum();
    assert_eq!(unknown, 11, "{:?}", log.report.unknown_types);
}

/// A path that is both the time and a mapped field gives both (found by the fuzz target
/// `log_ros1`: the time's slot replaced the field's).
#[test]
fn the_time_path_can_also_be_a_field() {
    let bytes = file("ros1.bag");
    let log = read(
        &bytes,
        None,
        "a",
        &opts(
            "/imu:header.stamp",
            [
                "/odom:header.stamp".to_string(),
                "/imu:header.stamp".to_string(),
            ]
            .into_iter(),
        ),
    )
    .unwrap();
    for f in ["/odom:header.stamp", "/imu:header.stamp"] {
        let s = &log.fields[f];
        assert!(!s.is_empty());
        assert_eq!(s.t_s, s.v, "{f}: timed by its own stamp");
    }
}

/// The shipped mavros map (config/maps/mavros_ardusub.toml) on the fixtures, its topics
/// renamed to the fixtures' (/imu, /depth, /rc_out carry the same message types) and the
/// fixtures' four RC channels: depth from rel_alt, FLU rates and the ENU quaternion to
/// NED, PWM to percent.
#[test]
fn shipped_mavros_map_reads_ros_bags() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../config/maps/mavros_ardusub.toml"
    ))
    .unwrap();
    let cut = text.find("[commands.thr5]").unwrap();
    let end = text.find("[signals]").unwrap();
    let text = format!("{}{}", &text[..cut], &text[end..])
        .replace("/mavros/imu/data", "/imu")
        .replace("/mavros/global_position/rel_alt", "/depth")
        .replace("/mavros/rc/out", "/rc_out");
    let map = LogMap::parse(&text, "mavros_ardusub.toml").unwrap();
    let exp = expected("ros1");
    for name in ["ros1.bag", "ros2.mcap"] {
        let m = map.read_apply(&file(name), name).unwrap();
        let d = &m.signals["depth_m"];
        let data = nums(&exp["/depth:data"]["v"]);
        assert_eq!(d.len(), data.len());
        for (x, e) in d.v.iter().zip(&data) {
            assert!((x + e.unwrap()).abs() < 1e-12);
        }
        let h = &m.signals["heading_deg"];
        assert_eq!(h.len(), 300);
        for (k, x) in h.v.iter().enumerate() {
            // The fixture's orientation: ENU yaw a = 0.3·sin(0.05k) rad; heading 90° − a.
            let a = (0.3 * (0.05 * k as f64).sin()).to_degrees();
            let dh = (x - (90.0 - a)).rem_euclid(360.0);
            assert!(dh.min(360.0 - dh) < 1e-6, "{name} heading {k}: {x}");
        }
        let r = &m.signals["yaw_rate_dps"];
        let z = nums(&exp["/imu:angular_velocity.z"]["v"]);
        for (x, e) in r.v.iter().zip(&z) {
            assert!((x + e.unwrap().to_degrees()).abs() < 1e-9);
        }
        let thr1 = &m.commands["thr1"];
        let ch = nums(&exp["/rc_out:channels[0]"]["v"]);
        assert_eq!(thr1.len(), ch.len());
        for (x, us) in thr1.v.iter().zip(&ch) {
            assert!((x - (us.unwrap() - 1500.0) / 4.0).abs() < 1e-9);
        }
        assert_eq!(m.commands.len(), 4);
    }
}

/// An input the fuzz target `log_mcap` found: an uncompressed chunk whose record claims
/// more than the chunk holds overflows inside mcap 0.26 (a panic with overflow checks, as
/// in this debug test build). The read ends as a corrupt file instead.
#[test]
fn mcap_chunk_record_longer_than_its_chunk_is_an_error_not_a_crash() {
    let mut m = mcap::MAGIC.to_vec();
    // Chunk record (op 0x06): times, uncompressed size, CRC 0, no compression, and
    // 13 bytes of records, of which the first claims 4 096 bytes.
    let mut body = Vec::new();
    body.extend(0u64.to_le_bytes());
    body.extend(0u64.to_le_bytes());
    body.extend(13u64.to_le_bytes());
    body.extend(0u32.to_le_bytes());
    body.extend(0u32.to_le_bytes()); // compression "" (length 0)
    body.extend(13u64.to_le_bytes());
    body.push(0x05);
    body.extend(4096u64.to_le_bytes());
    body.extend([0u8; 4]);
    body.extend([0u8; 4200]);
    m.push(0x06);
    m.extend((body.len() as u64).to_le_bytes());
    m.extend(body);
    let log = read(&m, Some(Format::Mcap), "bad.mcap", &ReadOptions::default()).unwrap();
    let said = log.report.truncated.clone().unwrap_or_default();
    assert!(
        said.contains("malformed") || said.contains("ended"),
        "{said}"
    );
}
