//! Capture through real GStreamer pipelines: the test source, a UDP camera in another
//! process that is killed and restarted, files with a size change, bad inputs, and
//! consumers that stall.

use std::process::Command;
use std::sync::Arc;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use crate::common::rtp::{free_udp_port, udp_sender};
use crate::common::{Recorder, encode, sim_camera, wait_for};
use rov_video::simcam::CameraPose;
use rov_video::{
    Capture, CaptureConfig, CaptureState, Encoder, EncoderConfig, FrameSink, OutputSize,
    SourceSpec, TimeSource, VideoError,
};

fn spec(s: &str) -> SourceSpec {
    SourceSpec::parse(s).unwrap()
}

#[test]
fn test_source_delivers_640x480_at_25_fps_with_capture_times() {
    let clock = TimeSource::monotonic();
    let rec = Arc::new(Recorder::default());
    let cap = Capture::start(
        &spec("test"),
        CaptureConfig {
            clock: clock.clone(),
            ..CaptureConfig::default()
        },
        vec![rec.clone() as Arc<dyn FrameSink>],
    )
    .unwrap();
    let first = cap.wait_first_frame(Duration::from_secs(10)).unwrap();
    assert_eq!((first.width_px, first.height_px), (640, 480));
    std::thread::sleep(Duration::from_millis(2500));
    let stats = cap.stats();
    assert_eq!(stats.state, CaptureState::Running);
    assert_eq!(stats.frame_size_px, Some((640, 480)));
    assert!((18.0..=30.0).contains(&stats.fps), "fps {}", stats.fps);
    assert!(stats.latency_p99_ms.is_some());
    assert!(stats.frame_age_ms.unwrap() < 500.0, "{stats:?}");
    let frames = rec.frames.lock().unwrap().clone();
    // Rate from the capture times: 25 fps means 40 ms apart.
    let n = frames.len();
    assert!(n >= 45, "{n} frames in ~2.5 s");
    let span_s = (frames[n - 1].2 - frames[0].2) as f64 * 1e-9;
    let rate = (n - 1) as f64 / span_s;
    assert!((20.0..=30.0).contains(&rate), "rate {rate}");
    assert!(
        frames
            .windows(2)
            .all(|w| w[1].2 > w[0].2 && w[1].3 == w[0].3 + 1)
    );
    assert!(frames.iter().all(|f| (f.0, f.1) == (640, 480)));
    // Capture times are on our clock, a little before now.
    let now = clock.now_ns();
    assert!(frames[n - 1].2 <= now && now - frames[n - 1].2 < 1_000_000_000);
    // The running clock drawn by timeoverlay changes the picture.
    let a = cap.latest().unwrap();
    std::thread::sleep(Duration::from_millis(1100));
    let b = cap.latest().unwrap();
    assert!(a.mean_abs_diff(&b).unwrap() > 0.01);
    cap.stop();
}

#[test]
fn killed_udp_camera_shows_no_video_within_1_s_and_reconnects() {
    let port = free_udp_port();
    let mut sender = udp_sender(port);
    let cap = Capture::start(
        &spec(&format!("udp://127.0.0.1:{port}")),
        CaptureConfig::default(),
        vec![],
    )
    .unwrap();
    let started = wait_for(Duration::from_secs(15), || cap.state().has_video());
    assert!(started.is_some(), "never ran: {:?}", cap.stats());
    std::thread::sleep(Duration::from_millis(500));
    let before = cap.stats().frames;
    assert!(before > 5);

    sender.kill().unwrap();
    sender.wait().unwrap();
    let killed = Instant::now();
    let lost = wait_for(Duration::from_secs(3), || !cap.state().has_video());
    let lost = lost.expect("the capture never noticed the source was killed");
    assert!(lost < Duration::from_secs(1), "NO VIDEO after {lost:?}");
    let st = cap.stats();
    assert!(st.state.label().starts_with("NO VIDEO"), "{:?}", st.state);
    assert!(st.frame_age_ms.unwrap() >= 400.0, "{st:?}");
    std::thread::sleep(Duration::from_millis(1000));
    assert!(!cap.state().has_video());
    assert!(killed.elapsed() > Duration::from_secs(1));

    // The camera comes back: the capture finds it again.
    let mut sender = udp_sender(port);
    let back = wait_for(Duration::from_secs(15), || cap.state().has_video());
    sender.kill().unwrap();
    let _ = sender.wait();
    assert!(back.is_some(), "did not reconnect: {:?}", cap.stats());
    let st = cap.stats();
    assert!(st.reconnects >= 1);
    assert!(st.frames > before);
    cap.stop();
}

/// A raw H.264 file whose picture size changes half way, made by our encoder.
fn size_change_file(dir: &std::path::Path) -> std::path::PathBuf {
    let big = sim_camera(320, 240);
    let small = sim_camera(160, 120);
    let pose = CameraPose {
        down_m: 3.0,
        ..CameraPose::default()
    };
    let frames = (0..40u64).map(|i| {
        let cam = if i < 20 { &big } else { &small };
        let p = CameraPose {
            yaw_rad: i as f64 * 0.02,
            ..pose
        };
        cam.render(&p, 0.0, i * 40_000_000, i)
    });
    let aus = encode(frames, EncoderConfig::default());
    assert_eq!(aus.len(), 40);
    let path = dir.join("size_change.h264");
    let bytes: Vec<u8> = aus.iter().flat_map(|a| a.data.iter().copied()).collect();
    std::fs::write(&path, bytes).unwrap();
    path
}

#[test]
fn file_source_follows_a_size_change_natively_and_scaled() {
    let dir = tempfile::tempdir().unwrap();
    let path = size_change_file(dir.path());
    let uri = format!("file://{}", path.display());
    for (output, expect) in [
        (OutputSize::Native, vec![(320, 240), (160, 120)]),
        (OutputSize::default(), vec![(640, 480)]),
    ] {
        let rec = Arc::new(Recorder::default());
        let cap = Capture::start(
            &spec(&uri),
            CaptureConfig {
                output,
                ..CaptureConfig::default()
            },
            vec![rec.clone() as Arc<dyn FrameSink>],
        )
        .unwrap();
        let ended = wait_for(
            Duration::from_secs(20),
            || matches!(cap.state(), CaptureState::NoVideo { ref reason } if reason == "end of stream"),
        );
        let st = cap.stats();
        cap.stop();
        assert!(ended.is_some(), "the file never ended: {st:?}");
        let frames = rec.frames.lock().unwrap().clone();
        assert!(frames.len() >= 36, "{} frames", frames.len());
        let mut sizes: Vec<(u32, u32)> = frames.iter().map(|f| (f.0, f.1)).collect();
        sizes.dedup();
        assert_eq!(sizes, expect, "{output:?}");
    }
}

#[test]
fn bad_sources_give_clear_errors_and_no_panic() {
    // A missing element is named with the package to install.
    let e = Capture::start(
        &spec("nosuchcamerasrc ! videoconvert"),
        CaptureConfig::default(),
        vec![],
    )
    .unwrap_err();
    assert!(matches!(e, VideoError::MissingPlugin { .. }), "{e}");
    assert!(
        e.to_string().contains("`nosuchcamerasrc` is not installed"),
        "{e}"
    );
    // A description that does not parse.
    let e = Capture::start(
        &spec("videotestsrc ! ! videoconvert"),
        CaptureConfig::default(),
        vec![],
    )
    .unwrap_err();
    assert!(matches!(e, VideoError::BadPipeline { .. }), "{e}");
    assert!(e.to_string().contains("videotestsrc ! !"), "{e}");
    // Not a GStreamer source.
    let e = Capture::start(&SourceSpec::Sim, CaptureConfig::default(), vec![]).unwrap_err();
    assert!(e.to_string().contains("`sim`"), "{e}");
    // A bad setting.
    let e = Capture::start(
        &SourceSpec::Test,
        CaptureConfig {
            output: OutputSize::Fixed {
                width_px: 0,
                height_px: 480,
            },
            ..CaptureConfig::default()
        },
        vec![],
    )
    .unwrap_err();
    assert!(e.to_string().contains("output size"), "{e}");

    // An absent device: NO VIDEO naming it, retried (it may be plugged in later).
    let cap = Capture::start(&spec("v4l2:/dev/video97"), CaptureConfig::default(), vec![]).unwrap();
    assert!(
        wait_for(Duration::from_secs(1), || !matches!(
            cap.state(),
            CaptureState::Starting
        ))
        .is_some()
    );
    let label = cap.state().label();
    assert!(
        label.contains("no capture device at /dev/video97"),
        "{label}"
    );
    assert!(wait_for(Duration::from_secs(3), || cap.stats().reconnects >= 2).is_some());
    cap.stop();

    // A file that is not video.
    let dir = tempfile::tempdir().unwrap();
    let junk = dir.path().join("junk.bin");
    std::fs::write(
        &junk,
        (0..4000u32)
            .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
            .collect::<Vec<u8>>(),
    )
    .unwrap();
    let cap = Capture::start(
        &spec(&format!("file://{}", junk.display())),
        CaptureConfig::default(),
        vec![],
    )
    .unwrap();
    assert!(
        wait_for(Duration::from_secs(5), || !matches!(
            cap.state(),
            CaptureState::Starting
        ))
        .is_some()
    );
    let label = cap.state().label();
    assert!(label.contains("type of stream"), "{label}");
    cap.stop();

    // A codec that is not installed: an MP4 whose video track has a codec nobody decodes
    // (the fourcc patched to `zzzz`).
    let mp4 = dir.path().join("h264.mp4");
    let ok = Command::new("gst-launch-1.0")
        .args([
            "-q",
            "videotestsrc",
            "num-buffers=10",
            "!",
            "video/x-raw,format=I420,width=160,height=120",
            "!",
            "x264enc",
            "!",
            "mp4mux",
            "!",
            "filesink",
        ])
        .arg(format!("location={}", mp4.display()))
        .status()
        .unwrap();
    assert!(ok.success());
    let bytes = std::fs::read(&mp4).unwrap();
    let at = bytes.windows(4).position(|w| w == b"avc1").unwrap();
    let mut patched = bytes.clone();
    patched[at..at + 4].copy_from_slice(b"zzzz");
    let unknown = dir.path().join("unknown_codec.mp4");
    std::fs::write(&unknown, patched).unwrap();
    let cap = Capture::start(
        &spec(&format!("file://{}", unknown.display())),
        CaptureConfig::default(),
        vec![],
    )
    .unwrap();
    assert!(
        wait_for(Duration::from_secs(5), || matches!(
            cap.state(),
            CaptureState::Failed { .. }
        ))
        .is_some(),
        "{:?}",
        cap.state()
    );
    let label = cap.state().label();
    assert!(
        label.contains("Missing decoder: video/x-gst-fourcc-zzzz is not installed"),
        "{label}"
    );
    cap.stop();

    // A source that delivers nothing: a UDP port nobody sends to.
    let port = free_udp_port();
    let cap = Capture::start(
        &spec(&format!("udp://127.0.0.1:{port}")),
        CaptureConfig {
            start_timeout: Duration::from_millis(500),
            ..CaptureConfig::default()
        },
        vec![],
    )
    .unwrap();
    assert!(
        wait_for(Duration::from_secs(3), || matches!(
            cap.state(),
            CaptureState::NoVideo { .. } | CaptureState::Reconnecting { .. }
        ))
        .is_some()
    );
    let label = cap.state().label();
    assert!(label.contains("no frame within 500 ms"), "{label}");
    let e = cap
        .wait_first_frame(Duration::from_millis(100))
        .unwrap_err();
    assert!(
        e.to_string().contains(&format!("udp://127.0.0.1:{port}")),
        "{e}"
    );
    cap.stop();
}

/// An encoder whose output never drains (its callback blocks) behind a capture, and a
/// screen that holds a frame for 2 s: the capture keeps its rate and the slot stays fresh.
#[test]
fn stalled_consumers_never_block_the_capture() {
    let (release_tx, release_rx) = mpsc::channel::<()>();
    let release_rx = std::sync::Mutex::new(release_rx);
    let encoder = Arc::new(
        Encoder::start(
            EncoderConfig {
                queue_frames: 4,
                ..EncoderConfig::default()
            },
            move |_au| {
                // The recorder is stuck.
                let _ = release_rx.lock().unwrap().recv();
            },
        )
        .unwrap(),
    );
    let cap = Capture::start(
        &spec("test"),
        CaptureConfig::default(),
        vec![encoder.clone() as Arc<dyn FrameSink>],
    )
    .unwrap();
    cap.wait_first_frame(Duration::from_secs(10)).unwrap();
    let slot = cap.slot();
    // The screen grabs a frame and hangs on to it for 2 s.
    let held = slot.latest().unwrap();
    let frames_before = cap.stats().frames;
    std::thread::sleep(Duration::from_secs(2));
    let st = cap.stats();
    let delivered = st.frames - frames_before;
    assert!(
        delivered >= 35,
        "only {delivered} frames in 2 s with stalled consumers"
    );
    assert!(st.frame_age_ms.unwrap() < 300.0, "{st:?}");
    assert!(slot.latest().unwrap().seq > held.seq + 30);
    // The encoder dropped what it could not take, and said so.
    let es = encoder.stats();
    assert!(es.frames_dropped > 20, "{es:?}");
    // Pushing into the stalled encoder returns at once.
    let t0 = Instant::now();
    for _ in 0..200 {
        encoder.push(held.clone());
    }
    assert!(
        t0.elapsed() < Duration::from_millis(200),
        "push blocked: {:?}",
        t0.elapsed()
    );
    cap.stop();
    drop(release_tx);
}
