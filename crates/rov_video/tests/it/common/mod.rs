//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use rov_video::simcam::{CameraModel, SimCamera, SimScene};
use rov_video::{AccessUnit, Encoder, EncoderConfig, FrameSink, VideoFrame};

/// The RTP sender (shared with rov_station's video test).
pub mod rtp;

/// The simulator's camera at another picture size (default scene, no stamp).
pub fn sim_camera(width_px: u32, height_px: u32) -> SimCamera {
    let model = CameraModel {
        width_px,
        height_px,
        hfov_deg: 75.0,
    };
    SimCamera::new(SimScene::default(), model, false).unwrap()
}

/// A sink that keeps every frame's size, time and sequence number.
#[derive(Default)]
pub struct Recorder {
    pub frames: Mutex<Vec<(u32, u32, u64, u64)>>,
}

impl FrameSink for Recorder {
    fn push(&self, f: Arc<VideoFrame>) {
        self.frames
            .lock()
            .unwrap()
            .push((f.width_px, f.height_px, f.capture_ns, f.seq));
    }
}

/// Polls `cond` every 10 ms until it holds or `timeout` passes; returns the time taken.
pub fn wait_for(timeout: Duration, mut cond: impl FnMut() -> bool) -> Option<Duration> {
    let t0 = Instant::now();
    while t0.elapsed() < timeout {
        if cond() {
            return Some(t0.elapsed());
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    None
}

/// Encodes frames (pushed without dropping) and returns the access units.
pub fn encode(
    frames: impl IntoIterator<Item = VideoFrame>,
    config: EncoderConfig,
) -> Vec<AccessUnit> {
    let out = Arc::new(Mutex::new(Vec::new()));
    let o = Arc::clone(&out);
    let enc = Encoder::start(config, move |au| o.lock().unwrap().push(au)).unwrap();
    for f in frames {
        enc.push_blocking(Arc::new(f)).unwrap();
    }
    let stats = enc.finish(Duration::from_secs(60)).unwrap();
    assert_eq!(stats.frames_dropped, 0);
    out.lock().unwrap().clone()
}

/// `ffprobe -show_format -show_streams` (and packets when asked) as JSON.
pub fn ffprobe(path: &Path, packets: bool) -> serde_json::Value {
    let mut args = vec![
        "-v",
        "error",
        "-print_format",
        "json",
        "-show_format",
        "-show_streams",
    ];
    if packets {
        args.push("-show_packets");
    }
    let out = Command::new("ffprobe")
        .args(&args)
        .arg(path)
        .output()
        .expect("ffprobe (ffmpeg) must be installed");
    assert!(
        out.status.success(),
        "ffprobe failed on {}: {}",
        path.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

/// One frame of a video file as RGBA, through ffmpeg (an independent decoder).
pub fn ffmpeg_frame(path: &Path, index: u32, w: u32, h: u32) -> VideoFrame {
    let out = Command::new("ffmpeg")
        .args(["-v", "error", "-i"])
        .arg(path)
        .args([
            "-vf",
            &format!("select=eq(n\\,{index})"),
            "-frames:v",
            "1",
            "-f",
            "rawvideo",
            "-pix_fmt",
            "rgba",
            "-",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    VideoFrame::new(w, h, 0, 0, out.stdout).unwrap()
}

/// Writes a frame as a PNG through ffmpeg (for looking at test pictures).
pub fn save_png(frame: &VideoFrame, path: &Path) {
    use std::io::Write;
    let mut child = Command::new("ffmpeg")
        .args([
            "-v", "error", "-y", "-f", "rawvideo", "-pix_fmt", "rgba", "-s",
        ])
        .arg(format!("{}x{}", frame.width_px, frame.height_px))
        .args(["-i", "-"])
        .arg(path)
        .stdin(Stdio::piped())
        .spawn()
        .unwrap();
    child.stdin.take().unwrap().write_all(&frame.rgba).unwrap();
    assert!(child.wait().unwrap().success());
}
