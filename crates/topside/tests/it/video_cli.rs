//! Camera video through the real binary (issue 12): `record --sim --fast` records
//! `/camera/video` that the official Python `mcap` reader finds (channel, schema) and whose
//! H.264, extracted, decodes with ffmpeg to one 640×480 frame per message, changing as the
//! vehicle moves; `export --video` writes an MP4 (one H.264 stream of the video's
//! duration, ffprobe) and its `.ass` telemetry; `session recover` keeps the video up to
//! the last good record.

use std::path::{Path, PathBuf};
use std::process::Command;

fn topside() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_topside"));
    // No user configuration leaks into the test.
    c.env(
        "XDG_CONFIG_HOME",
        std::env::temp_dir().join("topside_video_cli_cfg"),
    );
    c
}

fn tmp(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("video_cli");
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

/// Python: the official `mcap` reader lists the video channel's encoding and schema, and
/// writes the access units (the protobuf's `data`, field 3) as one Annex-B stream.
const EXTRACT_PY: &str = r#"
import sys, json
from mcap.reader import make_reader

def fields(buf):
    i, out = 0, {}
    while i < len(buf):
        key = 0; shift = 0
        while True:
            b = buf[i]; i += 1; key |= (b & 0x7f) << shift; shift += 7
            if b < 0x80: break
        num, wt = key >> 3, key & 7
        if wt == 2:
            n = 0; shift = 0
            while True:
                b = buf[i]; i += 1; n |= (b & 0x7f) << shift; shift += 7
                if b < 0x80: break
            out[num] = buf[i:i+n]; i += n
        elif wt == 0:
            while buf[i] & 0x80: i += 1
            i += 1
        else:
            raise ValueError("wire type %d" % wt)
    return out

with open(sys.argv[1], "rb") as f, open(sys.argv[2], "wb") as out:
    r = make_reader(f)
    s = r.get_summary()
    ch = [c for c in s.channels.values() if c.topic == "/camera/video"]
    info = {"channels": len(ch)}
    if ch:
        sc = s.schemas[ch[0].schema_id]
        info.update(message_encoding=ch[0].message_encoding, schema=sc.name,
                    schema_encoding=sc.encoding)
    n = 0; formats = set(); last = -1; ordered = True
    for schema, channel, message in r.iter_messages(topics=["/camera/video"]):
        m = fields(message.data)
        formats.add(m[4].decode())
        out.write(m[3]); n += 1
        ordered &= message.log_time >= last; last = message.log_time
    info.update(messages=n, formats=sorted(formats), ordered=ordered)
    print(json.dumps(info))
"#;

fn extract(mcap: &Path, h264: &Path) -> serde_json::Value {
    let out = Command::new("python3")
        .args(["-c", EXTRACT_PY])
        .arg(mcap)
        .arg(h264)
        .output()
        .expect("python3 with the mcap package (scripts/setup.sh)");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn ffprobe(path: &Path, count: bool) -> serde_json::Value {
    let mut c = Command::new("ffprobe");
    c.args([
        "-v",
        "error",
        "-print_format",
        "json",
        "-show_streams",
        "-show_format",
    ]);
    if count {
        c.arg("-count_frames");
    }
    let out = c
        .arg(path)
        .output()
        .expect("ffprobe (ffmpeg) must be installed");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

/// Decodes to 80×60 grey frames (ffmpeg) and returns them.
fn grey_frames(h264: &Path) -> Vec<Vec<u8>> {
    let out = Command::new("ffmpeg")
        .args(["-v", "error", "-i"])
        .arg(h264)
        .args([
            "-vf",
            "scale=80:60",
            "-pix_fmt",
            "gray",
            "-f",
            "rawvideo",
            "-",
        ])
        .output()
        .expect("ffmpeg");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out.stdout
        .chunks_exact(80 * 60)
        .map(<[u8]>::to_vec)
        .collect()
}

fn diff(a: &[u8], b: &[u8]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| f64::from(x.abs_diff(*y)))
        .sum::<f64>()
        / a.len() as f64
}

#[test]
fn record_fast_with_video_decodes_and_exports() {
    let session = tmp("dive.mcap");
    let out = topside()
        .args([
            "record",
            "--sim",
            "--fast",
            "--duration-s",
            "10",
            "--json",
            "--out",
        ])
        .arg(&session)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(j["video"]["source"], "sim", "{j}");
    assert_eq!(j["video"]["encoder_dropped"], 0, "{j}");
    let n_msgs = j["topics"]["/camera/video"].as_u64().unwrap();
    // 25 fps of virtual time over 10 s.
    assert!((248..=253).contains(&n_msgs), "{j}");

    // The official reader: channel, schema, one unit per message.
    let h264 = tmp("dive.h264");
    let info = extract(&session, &h264);
    assert_eq!(info["channels"], 1, "{info}");
    assert_eq!(info["message_encoding"], "protobuf", "{info}");
    assert_eq!(info["schema"], "foxglove.CompressedVideo", "{info}");
    assert_eq!(info["schema_encoding"], "protobuf", "{info}");
    assert_eq!(info["formats"], serde_json::json!(["h264"]), "{info}");
    assert_eq!(info["messages"].as_u64(), Some(n_msgs), "{info}");
    let p = ffprobe(&h264, true);
    let s = &p["streams"][0];
    assert_eq!(s["codec_name"], "h264", "{p}");
    assert_eq!(
        (s["width"].as_u64(), s["height"].as_u64()),
        (Some(640), Some(480))
    );
    let decoded: u64 = s["nb_read_frames"].as_str().unwrap().parse().unwrap();
    assert_eq!(decoded, n_msgs, "{p}");
    // The built-in dive descends and turns from 2 s: the picture changes second by
    // second, and a lot from start to end.
    let g = grey_frames(&h264);
    assert_eq!(g.len() as u64, n_msgs);
    let per_s: Vec<f64> = (3..9).map(|k| diff(&g[k * 25], &g[(k + 1) * 25])).collect();
    let whole = diff(&g[25], &g[g.len() - 1]);
    eprintln!("picture change per second {per_s:.1?}, start→end {whole:.1}");
    assert!(per_s.iter().all(|d| *d > 0.3), "{per_s:?}");
    assert!(whole > 5.0, "{whole}");

    // Export: MP4 of the video's duration and the telemetry subtitles.
    let mp4 = tmp("dive.mp4");
    let _ = std::fs::remove_file(&mp4);
    let out = topside()
        .arg("export")
        .arg(&session)
        .arg("--video")
        .arg(&mp4)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let p = ffprobe(&mp4, false);
    let streams = p["streams"].as_array().unwrap();
    assert_eq!(streams.len(), 1, "{p}");
    assert_eq!(streams[0]["codec_name"], "h264");
    let dur: f64 = p["format"]["duration"].as_str().unwrap().parse().unwrap();
    let expected = n_msgs as f64 / 25.0;
    assert!((dur - expected).abs() < 0.1, "{dur} s vs {expected} s");
    let ass = std::fs::read_to_string(mp4.with_extension("ass")).unwrap();
    let lines: Vec<&str> = ass.lines().filter(|l| l.starts_with("Dialogue:")).collect();
    assert!(lines.len() as f64 >= expected, "{} lines", lines.len());
    let last = lines.last().unwrap();
    for w in ["depth", "heading", "pitch", "roll", "AP"] {
        assert!(last.contains(w), "{last}");
    }
    assert!(
        ass.contains("depth 3.0 m, heading 090°"),
        "autopilot state in the subtitles"
    );
    // `--csv` still works alone, and one of the two is required.
    let csv = tmp("dive.csv");
    let out = topside()
        .arg("export")
        .arg(&session)
        .arg("--csv")
        .arg(&csv)
        .output()
        .unwrap();
    assert!(out.status.success() && csv.is_file());
    let out = topside().arg("export").arg(&session).output().unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--csv"));

    // Recovery: a recording cut at 60 % keeps its video up to the last good record.
    let bytes = std::fs::read(&session).unwrap();
    let cut = tmp("cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() * 6 / 10]).unwrap();
    let out = topside()
        .args(["session", "recover"])
        .arg(&cut)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let recovered = cut.with_extension("recovered.mcap");
    let h264r = tmp("cut.h264");
    let info = extract(&recovered, &h264r);
    let kept = info["messages"].as_u64().unwrap();
    assert!(kept > 50 && kept < n_msgs, "{info}");
    let p = ffprobe(&h264r, true);
    let decoded: u64 = p["streams"][0]["nb_read_frames"]
        .as_str()
        .unwrap()
        .parse()
        .unwrap();
    assert_eq!(decoded, kept, "{p}");
    let r = rov_session::open(&recovered).unwrap();
    assert!(r.is_complete());
    let last_video = r.video(0, u64::MAX).last().unwrap().t_ns;
    let end = r.end_ns().unwrap();
    assert!(
        end - last_video < 200_000_000,
        "video kept to {last_video} of {end}"
    );
}

#[test]
fn record_refuses_a_capture_on_virtual_time_and_unknown_sources() {
    let out = topside()
        .args([
            "record",
            "--sim",
            "--fast",
            "--duration-s",
            "1",
            "--video",
            "test",
            "--out",
        ])
        .arg(tmp("x.mcap"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--video test"));
    let out = topside()
        .args([
            "record",
            "--sim",
            "--duration-s",
            "1",
            "--video",
            "v4l2:/dev/video0",
            "--out",
        ])
        .arg(tmp("y.mcap"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("sim, test or none"));
}
