//! Encoding and decoding through real GStreamer pipelines: the simulator's camera encoded
//! and decoded back (count, size, times, motion), the stream's structure (one access unit
//! per frame, no B-frames, SPS/PPS with every key frame, a key frame at least every 2 s),
//! size changes, the bit rate budget, corrupt units, and seeking.

use std::sync::Arc;
use std::time::Duration;

use crate::common::{encode, sim_camera};
use rov_video::annexb::{self, nal};
use rov_video::simcam::{CameraModel, CameraPose, SimCamera, SimScene};
use rov_video::stamp;
use rov_video::{AccessUnit, AuStore, Decoder, EncoderConfig, FrameSeeker, VideoFrame};

const FRAME_NS: u64 = 40_000_000;

/// `n` stamped frames of the sim camera turning at 30°/s and diving at 0.2 m/s.
fn sim_frames(n: u64, t0_ns: u64) -> Vec<VideoFrame> {
    let cam = SimCamera::new(SimScene::default(), CameraModel::default(), true).unwrap();
    (0..n)
        .map(|i| {
            let t = i as f64 * 0.04;
            let pose = CameraPose {
                down_m: 2.0 + 0.2 * t,
                yaw_rad: (30.0 * t).to_radians(),
                ..CameraPose::default()
            };
            cam.render(&pose, 0.0, t0_ns + i * FRAME_NS, i)
        })
        .collect()
}

fn decode_all(aus: &[AccessUnit]) -> (Vec<VideoFrame>, rov_video::DecoderStats) {
    let mut dec = Decoder::new(Duration::from_millis(500)).unwrap();
    let frames = aus.iter().filter_map(|a| dec.decode(a).unwrap()).collect();
    (frames, dec.stats())
}

#[test]
fn sim_camera_round_trip_keeps_count_size_times_and_motion() {
    let t0 = 5_000_000_000;
    let frames = sim_frames(75, t0);
    let aus = encode(frames.clone(), EncoderConfig::default());
    // One access unit per frame, in capture order, with the capture times.
    assert_eq!(aus.len(), 75);
    let pts: Vec<u64> = aus.iter().map(|a| a.pts_ns).collect();
    let expected: Vec<u64> = frames.iter().map(|f| f.capture_ns).collect();
    assert_eq!(pts, expected);
    // The first unit is a key frame with SPS and PPS; so is every key frame.
    assert!(aus[0].key_frame && aus[0].has_parameter_sets());
    for a in &aus {
        assert_eq!(
            a.key_frame,
            annexb::nal_types(&a.data).any(|t| t == nal::IDR)
        );
        assert_eq!(a.key_frame, a.has_parameter_sets(), "at {}", a.pts_ns);
        assert!(annexb::check(&a.data).is_ok());
        // Exactly one picture per unit.
        let slices_idr = annexb::nal_types(&a.data)
            .filter(|t| *t == nal::IDR)
            .count();
        let slices_p = annexb::nal_types(&a.data)
            .filter(|t| *t == nal::SLICE)
            .count();
        assert!(slices_idr == 0 || slices_p == 0);
    }
    // Decoded: same count, size and times; the stamp survives compression.
    let (decoded, stats) = decode_all(&aus);
    assert_eq!(decoded.len(), 75, "{stats:?}");
    for (d, f) in decoded.iter().zip(&frames) {
        assert_eq!((d.width_px, d.height_px), (640, 480));
        assert_eq!(d.capture_ns, f.capture_ns);
        assert_eq!(
            stamp::read_time(d),
            Some(f.capture_ns),
            "stamp of {}",
            f.capture_ns
        );
        // Close to the original (lossy, but the same picture).
        assert!(
            d.mean_abs_diff(f).unwrap() < 6.0,
            "{}",
            d.mean_abs_diff(f).unwrap()
        );
    }
    // Frames differ as the camera moves, and a lot over 3 s.
    let steps: Vec<f64> = decoded
        .windows(2)
        .map(|w| w[0].mean_abs_diff(&w[1]).unwrap())
        .collect();
    assert!(steps.iter().all(|d| *d > 0.05), "{steps:?}");
    assert!(decoded[0].mean_abs_diff(&decoded[74]).unwrap() > 5.0);
}

#[test]
fn key_frames_at_least_every_2_s_of_capture_time_even_at_a_low_rate() {
    for (fps, seconds) in [(25u64, 9u64), (10, 9), (4, 12)] {
        let cam = sim_camera(160, 120);
        let period = 1_000_000_000 / fps;
        let frames = (0..fps * seconds).map(|i| {
            let pose = CameraPose {
                down_m: 3.0,
                yaw_rad: i as f64 * 0.01,
                ..CameraPose::default()
            };
            cam.render(&pose, 0.0, i * period, i)
        });
        let aus = encode(frames, EncoderConfig::default());
        assert_eq!(aus.len() as u64, fps * seconds);
        let keys: Vec<u64> = aus
            .iter()
            .filter(|a| a.key_frame)
            .map(|a| a.pts_ns)
            .collect();
        assert_eq!(keys[0], 0);
        let last = aus.last().unwrap().pts_ns;
        let gaps: Vec<u64> = keys
            .windows(2)
            .map(|w| w[1] - w[0])
            .chain([last - keys[keys.len() - 1]])
            .collect();
        assert!(
            gaps.iter().all(|g| *g <= 2_000_000_000),
            "{fps} fps: key gaps {gaps:?}"
        );
        // …and not far more often than needed (the stream stays small).
        assert!(
            keys.len() as u64 <= seconds,
            "{fps} fps: {} key frames in {seconds} s",
            keys.len()
        );
    }
}

#[test]
fn a_size_change_starts_a_new_sequence_and_decodes() {
    let mut frames = Vec::new();
    for (k, (w, h)) in [(320u32, 240u32), (176, 144), (320, 240)]
        .into_iter()
        .enumerate()
    {
        let cam = sim_camera(w, h);
        for i in 0..15u64 {
            let n = k as u64 * 15 + i;
            frames.push(cam.render(
                &CameraPose {
                    down_m: 3.0,
                    ..CameraPose::default()
                },
                50.0,
                n * FRAME_NS,
                n,
            ));
        }
    }
    let aus = encode(frames, EncoderConfig::default());
    assert_eq!(aus.len(), 45);
    for i in [0, 15, 30] {
        assert!(aus[i].key_frame && aus[i].has_parameter_sets(), "unit {i}");
    }
    let (decoded, _) = decode_all(&aus);
    let sizes: Vec<(u32, u32)> = decoded.iter().map(|f| (f.width_px, f.height_px)).collect();
    assert_eq!(decoded.len(), 45);
    assert_eq!(sizes[14], (320, 240));
    assert_eq!(sizes[15], (176, 144));
    assert_eq!(sizes[30], (320, 240));
}

/// Worst case for the bit rate: every frame is fresh noise. Extrapolated to an hour at
/// 25 fps, the stream must stay under 1 GB.
#[test]
fn one_hour_at_640x480_and_25_fps_stays_under_1_gb() {
    let mut state = 0x1234_5678_9abc_def0u64;
    let frames: Vec<VideoFrame> = (0..100u64)
        .map(|i| {
            let rgba: Vec<u8> = (0..640 * 480)
                .flat_map(|_| {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    let b = state.to_le_bytes();
                    [b[0], b[1], b[2], 255]
                })
                .collect();
            VideoFrame::new(640, 480, i * FRAME_NS, i, rgba).unwrap()
        })
        .collect();
    let aus = encode(frames, EncoderConfig::default());
    let bytes: usize = aus.iter().map(|a| a.data.len()).sum();
    let per_hour = bytes as f64 / 4.0 * 3600.0;
    println!("noise at 1500 kbit/s: {:.0} MB per hour", per_hour / 1e6);
    assert!(per_hour < 1e9, "{:.0} MB per hour", per_hour / 1e6);
    // The rate control really works at this setting (not a tiny stream by accident).
    assert!(per_hour > 2e8, "{:.0} MB per hour", per_hour / 1e6);
}

#[test]
fn corrupt_units_are_skipped_and_counted() {
    let frames = sim_frames(100, 0);
    let mut aus = encode(frames, EncoderConfig::default());
    let keys: Vec<usize> = aus
        .iter()
        .enumerate()
        .filter(|(_, a)| a.key_frame)
        .map(|(i, _)| i)
        .collect();
    assert!(keys.len() >= 2, "{keys:?}");
    // Truncated to its start code, garbage without a start code, slice data scrambled.
    aus[5].data.truncate(4);
    aus[6].data = vec![0xde, 0xad, 0xbe, 0xef, 1, 2, 3];
    let n = aus[20].data.len();
    for b in &mut aus[20].data[n / 3..2 * n / 3] {
        *b ^= 0x5a;
    }
    let (decoded, stats) = decode_all(&aus);
    assert_eq!(stats.malformed, 2, "{stats:?}");
    assert!(
        decoded.len() >= 100 - 3 - 1,
        "{} decoded, {stats:?}",
        decoded.len()
    );
    // After the next key frame everything decodes and carries its time again.
    let after = aus[keys[1]].pts_ns;
    let good: Vec<&VideoFrame> = decoded.iter().filter(|f| f.capture_ns >= after).collect();
    assert_eq!(good.len(), 100 - keys[1]);
    assert!(
        good.iter()
            .all(|f| stamp::read_time(f) == Some(f.capture_ns))
    );
}

#[test]
fn seeking_shows_the_frame_of_the_time_forward_backward_and_far() {
    let frames = sim_frames(150, 1_000_000_000);
    let mut aus: Vec<AccessUnit> = encode(frames, EncoderConfig::default());
    let mut seeker = FrameSeeker::new().unwrap();
    // Before the first frame: nothing.
    assert!(seeker.frame_at(&mut aus, 999_999_999).unwrap().is_none());
    // Play-head positions: forward in small steps, a jump back, a jump far ahead, a
    // repeat, between frames.
    let times_ms: [u64; 12] = [
        1000, 1040, 1061, 1200, 5000, 1500, 3333, 3333, 6960, 7000, 2000, 4999,
    ];
    for t_ms in times_ms {
        let t = t_ms * 1_000_000;
        let f = seeker.frame_at(&mut aus, t).unwrap().unwrap();
        // The frame on screen at t: the last one captured at or before t.
        let expect = aus.iter().rev().find(|a| a.pts_ns <= t).unwrap().pts_ns;
        assert_eq!(f.capture_ns, expect, "at {t_ms} ms");
        assert_eq!(stamp::read_time(&f), Some(expect), "stamp at {t_ms} ms");
    }
    let st = seeker.stats();
    assert!(st.resets >= 3, "{st:?}");
    // Playing forward frame by frame decodes each unit once.
    let before = seeker.stats().decoded;
    for i in 0..25u64 {
        seeker
            .frame_at(&mut aus, 5_000_000_000 + i * FRAME_NS)
            .unwrap()
            .unwrap();
    }
    let used = seeker.stats().decoded - before;
    assert!(used <= 25 + 50, "{used} decodes for 25 frames");
    assert_eq!(aus.len(), 150);
    assert!(AuStore::entry(&aus, 0).unwrap().key_frame);
}

#[test]
fn a_frame_with_a_bad_buffer_is_refused_by_the_encoder_queue_not_fed() {
    let enc_out = Arc::new(std::sync::Mutex::new(Vec::new()));
    let o = Arc::clone(&enc_out);
    let enc = rov_video::Encoder::start(EncoderConfig::default(), move |au| {
        o.lock().unwrap().push(au)
    })
    .unwrap();
    let good = sim_frames(3, 0);
    let mut bad = good[1].clone();
    bad.rgba.truncate(100); // claims 640×480, holds 100 bytes
    enc.push_blocking(Arc::new(good[0].clone())).unwrap();
    enc.push_blocking(Arc::new(bad)).unwrap();
    enc.push_blocking(Arc::new(good[2].clone())).unwrap();
    let st = enc.finish(Duration::from_secs(30)).unwrap();
    assert_eq!(st.frames_dropped, 1);
    assert_eq!(enc_out.lock().unwrap().len(), 2);
}
