//! Export through real GStreamer pipelines, checked with ffprobe/ffmpeg (independent of
//! GStreamer): the MP4 plays (one H.264 stream of the expected size, frames and
//! duration), the `.ass` parses with the telemetry lines, the overlay draws the text
//! into the picture, and a session without a key frame is a clear error.

use crate::common::{encode, ffmpeg_frame, ffprobe};
use rov_video::simcam::{CameraModel, CameraPose, SimCamera, SimScene};
use rov_video::subtitles::{TelemetryText, lines_from_samples, telemetry_text};
use rov_video::{AccessUnit, EncoderConfig, ExportOptions, VideoError, export_mp4};

const FRAME_NS: u64 = 40_000_000;
/// Session time of the first frame (the station's clock does not start at the video).
const T0_NS: u64 = 3_000_000_000;

/// 6 s of the sim camera at 25 fps, and telemetry text at 2 Hz over the same time.
fn session() -> (Vec<AccessUnit>, Vec<rov_video::subtitles::SubtitleLine>) {
    let cam = SimCamera::new(SimScene::default(), CameraModel::default(), false).unwrap();
    let frames = (0..150u64).map(|i| {
        let t = i as f64 * 0.04;
        let pose = CameraPose::from_degrees(0.0, 0.0, 2.0 + 0.3 * t, 0.0, 0.0, 15.0 * t, -10.0);
        cam.render(&pose, 50.0, T0_NS + i * FRAME_NS, i)
    });
    let aus = encode(frames, EncoderConfig::default());
    let samples = (0..12u64)
        .map(|k| {
            let t_s = 3.0 + k as f64 * 0.5;
            let text = telemetry_text(&TelemetryText {
                t_s,
                depth_m: 2.0 + 0.3 * (t_s - 3.0),
                heading_deg: 15.0 * (t_s - 3.0),
                pitch_deg: 0.5,
                roll_deg: -0.2,
                autopilot: "depth 3.0 m".to_owned(),
            });
            ((t_s * 1e9) as u64, text)
        })
        .collect();
    (aus, lines_from_samples(samples, 500_000_000))
}

fn f64_of(v: &serde_json::Value) -> f64 {
    v.as_str().unwrap().parse().unwrap()
}

#[test]
fn passthrough_mp4_plays_and_the_ass_has_the_telemetry() {
    let dir = tempfile::tempdir().unwrap();
    let (aus, lines) = session();
    let out = dir.path().join("sub/dive.mp4");
    let s = export_mp4(aus.clone(), &lines, &out, &ExportOptions::default()).unwrap();
    assert_eq!(s.frames, 150);
    assert_eq!((s.skipped_before_key, s.malformed), (0, 0));
    assert_eq!(s.origin_ns, T0_NS);
    assert!((s.duration_s - 6.0).abs() < 1e-9, "{}", s.duration_s);

    let probe = ffprobe(&out, false);
    let streams = probe["streams"].as_array().unwrap();
    assert_eq!(streams.len(), 1, "{probe}");
    let v = &streams[0];
    assert_eq!(v["codec_name"], "h264");
    assert_eq!(
        (v["width"].as_u64(), v["height"].as_u64()),
        (Some(640), Some(480))
    );
    assert_eq!(v["nb_frames"].as_str(), Some("150"));
    let duration = f64_of(&probe["format"]["duration"]);
    assert!((duration - 6.0).abs() <= 0.04, "duration {duration}");
    // Passthrough: the stored pictures are the recorded ones, bit for bit.
    let mp4 = std::fs::read(&out).unwrap();
    let third = &aus[3].data;
    let slice = &third[third.len() - 64..];
    assert!(mp4.windows(64).any(|w| w == slice));

    // The subtitles: ffprobe reads the .ass as one ASS stream with a packet per line.
    assert_eq!(s.ass, dir.path().join("sub/dive.ass"));
    let sub = ffprobe(&s.ass, true);
    assert_eq!(sub["streams"][0]["codec_name"], "ass", "{sub}");
    let packets = sub["packets"].as_array().unwrap();
    assert_eq!(packets.len(), 12);
    // Times count from the first frame: the line of t = 3.5 s shows at 0.5 s.
    assert!(
        (f64_of(&packets[1]["pts_time"]) - 0.5).abs() < 0.011,
        "{}",
        packets[1]
    );
    let text = std::fs::read_to_string(&s.ass).unwrap();
    assert!(text.contains("Dialogue: 0,0:00:00.50,0:00:01.00,Telemetry,,0,0,0,,T+3.5 s  depth 2.15 m  heading 008°\\Npitch 0.5°  roll -0.2°  AP depth 3.0 m"), "{text}");
}

#[test]
fn overlay_burns_the_text_into_the_frames() {
    let dir = tempfile::tempdir().unwrap();
    let (aus, lines) = session();
    let plain = dir.path().join("plain.mp4");
    let burned = dir.path().join("burned.mp4");
    export_mp4(aus.clone(), &lines, &plain, &ExportOptions::default()).unwrap();
    let s = export_mp4(
        aus,
        &lines,
        &burned,
        &ExportOptions {
            overlay: true,
            ..ExportOptions::default()
        },
    )
    .unwrap();
    assert_eq!(s.frames, 150);
    let probe = ffprobe(&burned, false);
    assert_eq!(probe["streams"].as_array().unwrap().len(), 1);
    assert_eq!(probe["streams"][0]["codec_name"], "h264");
    assert_eq!(probe["streams"][0]["nb_frames"].as_str(), Some("150"));
    let duration = f64_of(&probe["format"]["duration"]);
    assert!((duration - 6.0).abs() <= 0.04, "duration {duration}");
    // Frame 60 (2.4 s): the bottom-left corner holds the text, the top does not change.
    let a = ffmpeg_frame(&plain, 60, 640, 480);
    let b = ffmpeg_frame(&burned, 60, 640, 480);
    let region = |f: &rov_video::VideoFrame, y0: u32, y1: u32| -> Vec<[u8; 4]> {
        (y0..y1)
            .flat_map(|y| (0..320).map(move |x| (x, y)))
            .map(|(x, y)| f.pixel(x, y).unwrap())
            .collect()
    };
    let diff = |p: &[[u8; 4]], q: &[[u8; 4]]| -> f64 {
        p.iter()
            .zip(q)
            .map(|(x, y)| (0..3).map(|k| f64::from(x[k].abs_diff(y[k]))).sum::<f64>())
            .sum::<f64>()
            / (p.len() * 3) as f64
    };
    let bottom = diff(&region(&a, 400, 480), &region(&b, 400, 480));
    let top = diff(&region(&a, 100, 180), &region(&b, 100, 180));
    assert!(
        bottom > 15.0 && top < 6.0,
        "bottom {bottom:.1}, top {top:.1}"
    );
}

#[test]
fn units_before_the_first_key_frame_and_garbage_are_left_out() {
    let dir = tempfile::tempdir().unwrap();
    let (aus, lines) = session();
    let first_key_after_start = aus.iter().skip(1).position(|a| a.key_frame).unwrap() + 1;
    // Start the recording in the middle of a group of pictures, and damage a unit.
    let mut cut: Vec<AccessUnit> = aus[10..].to_vec();
    cut[first_key_after_start + 5 - 10].data = vec![1, 2, 3];
    let out = dir.path().join("cut.mp4");
    let s = export_mp4(cut, &lines, &out, &ExportOptions::default()).unwrap();
    assert_eq!(s.skipped_before_key, (first_key_after_start - 10) as u64);
    assert_eq!(s.malformed, 1);
    assert_eq!(s.frames, 150 - first_key_after_start as u64 - 1);
    assert_eq!(s.origin_ns, aus[first_key_after_start].pts_ns);
    let probe = ffprobe(&out, false);
    assert_eq!(
        probe["streams"][0]["nb_frames"].as_str(),
        Some(s.frames.to_string().as_str())
    );

    // Nothing decodable: a clear error, and no file left behind.
    let deltas: Vec<AccessUnit> = aus.iter().filter(|a| !a.key_frame).cloned().collect();
    let bad = dir.path().join("none.mp4");
    let e = export_mp4(deltas, &lines, &bad, &ExportOptions::default()).unwrap_err();
    assert!(matches!(e, VideoError::NoVideo { .. }), "{e}");
    assert!(e.to_string().contains("no key frame"), "{e}");
    assert!(!bad.exists());
}
