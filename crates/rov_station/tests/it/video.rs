//! The station's video module with real GStreamer pipelines and the real runtime: the
//! test source's frames, a source killed mid-run (NO VIDEO within 1 s, no control tick
//! missed, reconnect), and a virtual-time recording whose replay shows, at a seek time,
//! the frame that was on screen then (read back from the time stamped into its pixels).

use std::sync::Mutex;
use std::time::{Duration, Instant};

use rov_control::{ModeCommand, PilotInput};
use rov_station::StationCommand;
use rov_station::runtime::video::{StationVideo, VideoSettings};
use rov_station::runtime::{
    Connection, ReplayCommand, Runtime, RuntimeCommand, RuntimeConfig, VirtualReplay,
    VirtualStation,
};
use rov_video::VideoFrame;
use rov_video::simcam::{CameraModel, CameraPose, SimCamera, SimScene};

/// The RTP sender shared with rov_video's tests (one copy).
#[path = "../../../rov_video/tests/it/common/rtp.rs"]
mod rtp;
use rtp::{free_udp_port, udp_sender};

/// One test at a time: the kill test measures control timing.
static SERIAL: Mutex<()> = Mutex::new(());

fn serial() -> std::sync::MutexGuard<'static, ()> {
    SERIAL
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

fn wait_until(timeout: Duration, mut cond: impl FnMut() -> bool) -> Option<Duration> {
    let t0 = Instant::now();
    while t0.elapsed() < timeout {
        if cond() {
            return Some(t0.elapsed());
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    None
}

fn settings(source: &str) -> VideoSettings {
    VideoSettings {
        source: source.into(),
        ..VideoSettings::default()
    }
}

#[test]
fn the_gstreamer_test_source_reaches_the_station_as_640x480_at_25_fps() {
    let _alone = crate::one_at_a_time();
    let _s = serial();
    let clock = Instant::now();
    let v = StationVideo::start_live(
        &settings("test"),
        &Connection::Sim,
        move || u64::try_from(clock.elapsed().as_nanos()).unwrap(),
        None,
    );
    assert_eq!(v.status().error, None);
    assert!(
        wait_until(Duration::from_secs(10), || v
            .status()
            .stats
            .is_some_and(|s| s.state.has_video()))
        .is_some(),
        "{:?}",
        v.status()
    );
    // Watch the slot for 2 s: every new frame, its size and capture time.
    let slot = v.slot().unwrap();
    let mut seen = Vec::new();
    let t0 = Instant::now();
    let mut last = None;
    while t0.elapsed() < Duration::from_secs(2) {
        if let Some(f) = slot.newer_than(last) {
            last = Some(f.seq);
            assert_eq!((f.width_px, f.height_px), (640, 480));
            assert_eq!(f.rgba.len(), 640 * 480 * 4);
            seen.push(f.capture_ns);
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    let n = seen.len();
    assert!((45..=55).contains(&n), "{n} frames in 2 s");
    assert!(
        seen.windows(2).all(|w| w[1] > w[0]),
        "capture times increase"
    );
    let span_s = (seen[n - 1] - seen[0]) as f64 * 1e-9;
    let fps = (n - 1) as f64 / span_s;
    assert!((23.0..=27.0).contains(&fps), "{fps:.2} fps");
    let st = v.status().stats.unwrap();
    assert!((23.0..=27.0).contains(&st.fps), "{st:?}");
    eprintln!(
        "test source: {n} frames in 2 s ({fps:.2} fps), latency p99 {:?} ms",
        st.latency_p99_ms
    );
    v.stop();
}

#[test]
fn a_source_killed_mid_run_shows_no_video_within_1_s_and_misses_no_control_tick() {
    let _alone = crate::one_at_a_time();
    let _s = serial();
    let port = free_udp_port();
    let mut sender = udp_sender(port);
    let h = Runtime::start(RuntimeConfig {
        gamepad: false,
        video: settings(&format!("udp://127.0.0.1:{port}")),
        ..RuntimeConfig::default()
    })
    .unwrap();
    let video = h.video().unwrap().clone();
    assert!(
        wait_until(Duration::from_secs(15), || video
            .status()
            .stats
            .is_some_and(|s| s.state.has_video()))
        .is_some(),
        "{:?}",
        video.status()
    );
    std::thread::sleep(Duration::from_millis(500));
    let before = h.tick_stats();
    sender.kill().unwrap();
    let killed = Instant::now();
    sender.wait().unwrap();
    let gone = wait_until(Duration::from_secs(3), || {
        video.status().no_video_label().is_some()
    });
    let label = video.status().no_video_label();
    let gone =
        gone.unwrap_or_else(|| panic!("still video 3 s after the kill: {:?}", video.status()));
    let after_kill = killed.elapsed();
    eprintln!(
        "NO VIDEO {:.0} ms after the kill: {label:?}",
        gone.as_secs_f64() * 1e3
    );
    assert!(after_kill <= Duration::from_millis(1100), "{after_kill:?}");
    let label = label.unwrap();
    assert!(label.starts_with("NO VIDEO"), "{label}");
    assert!(
        label.contains(&format!("udp://127.0.0.1:{port}")),
        "{label}"
    );
    // The station kept flying: ticks went on, none missed.
    std::thread::sleep(Duration::from_millis(500));
    let after = h.tick_stats();
    assert!(after.ticks > before.ticks + 40, "{before:?} → {after:?}");
    assert_eq!(after.missed, before.missed, "{before:?} → {after:?}");
    assert_eq!(after.watchdog_trips, 0);
    // The source returns: the station reconnects.
    let mut sender = udp_sender(port);
    let back = wait_until(Duration::from_secs(15), || {
        video.status().stats.is_some_and(|s| s.state.has_video())
    });
    let _ = sender.kill();
    let _ = sender.wait();
    assert!(back.is_some(), "no reconnect: {:?}", video.status());
    h.shutdown();
}

#[test]
fn a_bad_source_leaves_the_station_running_without_video_and_says_why() {
    let _alone = crate::one_at_a_time();
    let _s = serial();
    let h = Runtime::start(RuntimeConfig {
        gamepad: false,
        video: settings("v4l2:/dev/video99"),
        ..RuntimeConfig::default()
    })
    .unwrap();
    let v = h.video().unwrap().clone();
    let ok = wait_until(Duration::from_secs(10), || {
        v.status().no_video_label().is_some()
    });
    let label = v.status().no_video_label().unwrap_or_default();
    assert!(ok.is_some() && label.contains("/dev/video99"), "{label}");
    assert!(
        wait_until(Duration::from_secs(10), || h.view().link.health
            == "connected")
        .is_some()
    );
    h.shutdown();
    // A source text that is not a source at all.
    let v = StationVideo::start_live(&settings("rtsp://"), &Connection::Sim, || 0, None);
    let e = v.status().error.unwrap();
    assert!(e.contains("rtsp://"), "{e}");
}

/// Virtual time: a recording started at 0.5 s with the stamped sim camera; replaying it,
/// the frame shown after each seek (forward, back, far) is the last frame captured at or
/// before the seek time, and its pixels carry that capture time.
#[test]
fn replay_shows_the_frame_of_the_seek_time() {
    let _alone = crate::one_at_a_time();
    let _s = serial();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("video.mcap");
    let (mut st, h) = VirtualStation::new(RuntimeConfig {
        gamepad: false,
        video: VideoSettings {
            sim_stamp_time: true,
            ..settings("sim")
        },
        ..RuntimeConfig::default()
    })
    .unwrap();
    st.advance(0.5).unwrap();
    h.start_recording(&path);
    for k in 0..300 {
        if k == 20 {
            h.send(StationCommand::Mode(rov_control::ModeCommand::SetHeading {
                heading_deg: 90.0,
            }));
        }
        st.advance(0.02).unwrap();
    }
    st.finish();
    let rec = h.video().unwrap().status();
    assert_eq!(rec.record_dropped, 0, "{rec:?}");
    drop(h);
    let session = rov_session::open(&path).unwrap();
    let n = session.count("/camera/video");
    assert!((148..=152).contains(&n), "{n} video messages in 6 s");
    assert_eq!(session.video(0, u64::MAX).stats().skipped, 0);

    let (mut replay, rh) = VirtualReplay::open(&path).unwrap();
    let v = rh.video().unwrap().clone();
    let slot = v.slot().unwrap();
    let start_ns = session.start_ns().unwrap();
    let mut offsets = Vec::new();
    for seek_s in [1.0, 3.33, 2.02, 5.5, 0.3, 4.0] {
        rh.command(RuntimeCommand::Replay(ReplayCommand::Seek(seek_s)));
        replay.advance(0.0);
        let want_ns = start_ns + (seek_s * 1e9) as u64;
        let mut frame = None;
        wait_until(Duration::from_secs(10), || {
            frame = slot
                .latest()
                .filter(|f| f.capture_ns <= want_ns && want_ns - f.capture_ns < 40_000_000);
            frame.is_some()
        });
        let f = frame.unwrap_or_else(|| {
            panic!(
                "seek {seek_s} s: shown {:?}",
                slot.latest().map(|f| f.capture_ns)
            )
        });
        // The pixels' stamp: the station's (virtual) capture time = session time + the
        // recording's start.
        let stamp = rov_video::stamp::read_time(&f).expect("stamp readable after H.264");
        offsets.push(stamp as i64 - f.capture_ns as i64);
    }
    assert!(offsets.windows(2).all(|w| w[0] == w[1]), "{offsets:?}");
    // The recording started at 0.5 s of virtual time (applied at the next 20 ms tick).
    assert!(
        (480_000_000..=540_000_000).contains(&offsets[0]),
        "{offsets:?}"
    );
}

// --- the simulator's camera over the station's built-in dive (moved from rov_video's
// simcam test: rov_video sits below the station and does not depend on it)

/// The luminance standard deviation of the lower quarter (seabed structure).
fn lower_structure(f: &VideoFrame) -> f64 {
    let start = (f.height_px as usize * 3 / 4) * f.width_px as usize * 4;
    let lum: Vec<f64> = f.rgba[start..]
        .chunks_exact(4)
        .map(|p| 0.299 * f64::from(p[0]) + 0.587 * f64::from(p[1]) + 0.114 * f64::from(p[2]))
        .collect();
    let mean = lum.iter().sum::<f64>() / lum.len() as f64;
    (lum.iter().map(|l| (l - mean).powi(2)).sum::<f64>() / lum.len() as f64).sqrt()
}

/// The dive `topside record --sim --duration-s 20` flies without a script (see
/// crates/topside/src/cmd_record.rs: arm at 1 s, hold 3 m and 090° from 2 s, forward at
/// 40 % from 15 s, disarm at 19 s), flown through the real station on virtual time; the
/// camera follows the vehicle's depth and attitude with the lights off.
#[test]
fn the_builtin_20_s_dive_visibly_changes_the_picture_with_lights_off() {
    let _alone = crate::one_at_a_time();
    let (mut st, handle) = VirtualStation::new(RuntimeConfig {
        gamepad: false,
        ..RuntimeConfig::default()
    })
    .unwrap();
    let cam = SimCamera::new(SimScene::default(), CameraModel::default(), false).unwrap();
    let t0 = st.now_us();
    let mut frames: Vec<(f64, VideoFrame)> = Vec::new();
    for k in 0..=1000u64 {
        let t = k as f64 * 0.02;
        if (1.0..5.0).contains(&t) && k % 12 == 0 && !handle.snapshot().armed {
            handle.send(StationCommand::Arm);
        }
        if k == 100 {
            handle.send(StationCommand::Mode(ModeCommand::SetDepth { depth_m: 3.0 }));
            handle.send(StationCommand::Mode(ModeCommand::SetHeading {
                heading_deg: 90.0,
            }));
        }
        if (15.0..19.0).contains(&t) {
            handle.send(StationCommand::Sticks(PilotInput {
                surge: 0.4,
                yaw: 0.0,
                vertical: 0.0,
            }));
        }
        if k == 950 {
            handle.send(StationCommand::Disarm);
        }
        st.advance_to(t0 + k * 20_000).unwrap();
        if k % 50 == 0 {
            let s = handle.snapshot();
            let pose = CameraPose::from_degrees(
                0.0,
                0.0,
                s.depth_m.unwrap_or(0.0),
                s.roll_deg.unwrap_or(0.0),
                s.pitch_deg.unwrap_or(0.0),
                s.heading_deg.unwrap_or(0.0),
                0.0,
            );
            frames.push((t, cam.render(&pose, 0.0, k * 20_000_000, k)));
        }
    }
    let snap = handle.snapshot();
    assert!((snap.depth_m.unwrap() - 3.0).abs() < 0.5, "{snap:?}");
    let first = &frames.iter().find(|(t, _)| *t >= 2.0).unwrap().1;
    let last = &frames.last().unwrap().1;
    let change = first.mean_abs_diff(last).unwrap();
    assert!(
        change > 8.0,
        "start → end changes the picture by only {change:.1}/255"
    );
    // The seabed's grid and markers come into view in the lower part.
    let (s0, s1) = (lower_structure(first), lower_structure(last));
    assert!(
        s1 > 2.0 * s0 && s1 > 6.0,
        "seabed structure {s0:.1} → {s1:.1}"
    );
    // While it descends and turns (2–12 s) every second's picture is a new one.
    let moving: Vec<f64> = frames
        .windows(2)
        .filter(|w| w[0].0 >= 2.0 && w[1].0 <= 12.0)
        .map(|w| w[0].1.mean_abs_diff(&w[1].1).unwrap())
        .collect();
    assert!(moving.iter().all(|d| *d > 0.3), "{moving:?}");
    handle.shutdown();
}
