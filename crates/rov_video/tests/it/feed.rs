//! One handle for every kind of source: the simulator's camera at 25 fps of wall time
//! following a moving pose, a GStreamer test source, and none; device listing.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use rov_video::simcam::{CameraModel, CameraPose, SimCamera, SimScene};
use rov_video::{
    CaptureConfig, CaptureState, FrameSink, SimFeed, SourceSpec, VideoFeed, VideoFrame,
    list_capture_devices,
};

struct Count(AtomicU64);

impl FrameSink for Count {
    fn push(&self, _f: Arc<VideoFrame>) {
        self.0.fetch_add(1, Ordering::Relaxed);
    }
}

#[test]
fn sim_feed_renders_the_moving_pose_at_25_fps() {
    let calls = Arc::new(AtomicU64::new(0));
    let c = Arc::clone(&calls);
    let sim = SimFeed {
        camera: SimCamera::new(SimScene::default(), CameraModel::default(), true).unwrap(),
        fps: 25,
        pose: Box::new(move || {
            // The vehicle turns 45° per rendered frame.
            let k = c.fetch_add(1, Ordering::Relaxed) as f64;
            Some((
                CameraPose::from_degrees(0.0, 0.0, 4.0, 0.0, 0.0, 45.0 * k, -30.0),
                0.0,
            ))
        }),
    };
    let count = Arc::new(Count(AtomicU64::new(0)));
    let feed = VideoFeed::start(
        &SourceSpec::Sim,
        CaptureConfig::default(),
        Some(sim),
        vec![count.clone() as Arc<dyn FrameSink>],
    )
    .unwrap();
    std::thread::sleep(Duration::from_millis(200));
    let a = feed.latest().unwrap();
    std::thread::sleep(Duration::from_millis(1800));
    let b = feed.latest().unwrap();
    let st = feed.stats();
    assert_eq!(st.state, CaptureState::Running);
    assert!((20.0..=26.0).contains(&st.fps), "{st:?}");
    assert_eq!(st.frame_size_px, Some((640, 480)));
    // The runner reports its render time as the latency (its cost is benchmarked).
    assert!(st.latency_p99_ms.is_some_and(|ms| ms > 0.0), "{st:?}");
    assert!(b.seq > a.seq + 35 && b.capture_ns > a.capture_ns);
    assert!(a.mean_abs_diff(&b).unwrap() > 0.5);
    assert_eq!(rov_video::stamp::read_time(&b), Some(b.capture_ns));
    assert!(count.0.load(Ordering::Relaxed) >= 40);
    feed.stop();
}

#[test]
fn test_and_none_feeds_and_sim_without_a_vehicle() {
    let feed = VideoFeed::start(&SourceSpec::Test, CaptureConfig::default(), None, vec![]).unwrap();
    let VideoFeed::Camera(cap) = &feed else {
        panic!("{feed:?}")
    };
    cap.wait_first_frame(Duration::from_secs(10)).unwrap();
    assert!(feed.slot().unwrap().latest().is_some());
    feed.stop();
    let off = VideoFeed::start(&SourceSpec::None, CaptureConfig::default(), None, vec![]).unwrap();
    assert!(off.slot().is_none() && off.latest().is_none());
    assert_eq!(off.stats().state.label(), "VIDEO OFF");
    let e = VideoFeed::start(&SourceSpec::Sim, CaptureConfig::default(), None, vec![]).unwrap_err();
    assert!(e.to_string().contains("needs the simulated vehicle"), "{e}");
}

#[test]
fn device_listing_runs_without_devices() {
    // This machine has no capture device: the list is empty, not an error. Where there
    // are devices, each has a /dev node and a spec that parses back.
    let devices = list_capture_devices().unwrap();
    for d in &devices {
        assert!(d.path.starts_with("/dev/"), "{d:?}");
        assert_eq!(SourceSpec::parse(&d.spec.to_string()).unwrap(), d.spec);
    }
    let has_nodes = std::fs::read_dir("/dev").unwrap().any(|e| {
        e.unwrap()
            .file_name()
            .to_string_lossy()
            .starts_with("video")
    });
    if !has_nodes {
        assert!(devices.is_empty(), "{devices:?}");
    }
}
