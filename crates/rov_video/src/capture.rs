//! Capture: a GStreamer source running on its own threads, delivering RGBA frames with
//! their capture time into the latest-frame slot and any other [`FrameSink`]s.
//!
//! # Threads
//! * GStreamer's streaming thread converts each frame (`videoconvert`, `videoscale` to the
//!   output size, RGBA), copies it out, stamps the capture time and hands it to the sinks
//!   (the slot swaps a pointer; an encoder queues it or counts a drop). It never waits
//!   for a consumer.
//! * A supervisor thread (`rov-video-capture`) builds the pipeline, watches the bus and
//!   the time since the last frame, tears the pipeline down when the source is lost and
//!   rebuilds it with back-off (250 ms doubling to 4 s, reset by a frame).
//!
//! # Losing and finding the source
//! No frame for [`CaptureConfig::stall_timeout`] (500 ms) while running, an error on the
//! bus (device unplugged, network source gone), the end of a file, or no first frame
//! within [`CaptureConfig::start_timeout`] (5 s): the state becomes
//! [`CaptureState::NoVideo`] with the reason, then [`CaptureState::Reconnecting`] while the
//! pipeline is rebuilt; frames arriving again make it [`CaptureState::Running`]. A
//! missing element or codec, or a pipeline that does not parse, is
//! [`CaptureState::Failed`] (or an error from [`Capture::start`]): retrying cannot help.
//!
//! # Capture time
//! A frame's capture time is the caller's clock ([`TimeSource`]) at delivery minus the
//! time the frame spent in the pipeline: the pipeline clock now minus the buffer's
//! timestamp in clock time (V4L2 stamps buffers at capture, network sources at arrival).
//! That difference is also the capture-to-delivery latency in the stats.
//!
//! # Frame size
//! [`OutputSize::Fixed`] (default 640×480) scales every source to that size, keeping the
//! aspect ratio with black borders, so a size change mid-stream is invisible downstream;
//! [`OutputSize::Native`] delivers the source's size, and each frame carries its own.

use std::collections::VecDeque;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc;
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use gstreamer as gst;
use gstreamer::prelude::*;
use gstreamer_app as gst_app;
use gstreamer_video as gst_video;

use crate::error::{Result, VideoError};
use crate::frame::{FrameSink, FrameSlot, TimeSource, VideoFrame};
use crate::gst_util;
use crate::source::SourceSpec;
use crate::stamp;
use crate::stats::{CaptureState, CaptureStats, Rolling, snapshot};

const SINK_NAME: &str = "rov_video_sink";
/// The first element of the station's path (after the source's own elements).
const CONVERT_NAME: &str = "rov_video_convert";
/// Frames whose entry time into the station's path is remembered.
const ARRIVALS: usize = 64;
const POLL: Duration = Duration::from_millis(25);
/// A buffer that claims to have spent longer than this in the pipeline has a bogus
/// timestamp: its latency is taken as 0.
const MAX_PLAUSIBLE_DELAY_NS: u64 = 5_000_000_000;

/// The size of delivered frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputSize {
    /// Scale to this size (aspect ratio kept with black borders).
    Fixed {
        /// Width, px.
        width_px: u32,
        /// Height, px.
        height_px: u32,
    },
    /// The source's own size (may change mid-stream).
    Native,
}

impl Default for OutputSize {
    fn default() -> Self {
        Self::Fixed {
            width_px: 640,
            height_px: 480,
        }
    }
}

/// Capture settings; `Default` is what the station uses.
#[derive(Debug, Clone)]
pub struct CaptureConfig {
    /// Frame size delivered.
    pub output: OutputSize,
    /// Frame rate of the `test` source, frames/s.
    pub test_fps: u32,
    /// No frame for this long while running = lost.
    pub stall_timeout: Duration,
    /// No first frame within this long after (re)starting = lost.
    pub start_timeout: Duration,
    /// First retry delay.
    pub backoff_min: Duration,
    /// Longest retry delay.
    pub backoff_max: Duration,
    /// The caller's clock for capture times.
    pub clock: TimeSource,
    /// Draw the capture time into each frame ([`crate::stamp`]).
    pub stamp_time: bool,
}

impl Default for CaptureConfig {
    fn default() -> Self {
        Self {
            output: OutputSize::default(),
            test_fps: 25,
            stall_timeout: Duration::from_millis(500),
            start_timeout: Duration::from_secs(5),
            backoff_min: Duration::from_millis(250),
            backoff_max: Duration::from_secs(4),
            clock: TimeSource::default(),
            stamp_time: false,
        }
    }
}

impl CaptureConfig {
    fn validate(&self) -> Result<()> {
        if let OutputSize::Fixed {
            width_px,
            height_px,
        } = self.output
            && !((16..=4096).contains(&width_px) && (16..=4096).contains(&height_px))
        {
            return Err(VideoError::InvalidConfig {
                field: "output size",
                value: format!("{width_px}×{height_px}"),
                allowed: "16..=4096 px per side",
            });
        }
        if !(1..=240).contains(&self.test_fps) {
            return Err(VideoError::InvalidConfig {
                field: "test_fps",
                value: self.test_fps.to_string(),
                allowed: "1..=240 frames/s",
            });
        }
        let ms = |d: Duration| d.as_millis().to_string();
        if !(Duration::from_millis(50)..=Duration::from_secs(60)).contains(&self.stall_timeout) {
            return Err(VideoError::InvalidConfig {
                field: "stall_timeout",
                value: ms(self.stall_timeout),
                allowed: "50..=60000 ms",
            });
        }
        if !(Duration::from_millis(100)..=Duration::from_secs(120)).contains(&self.start_timeout) {
            return Err(VideoError::InvalidConfig {
                field: "start_timeout",
                value: ms(self.start_timeout),
                allowed: "100..=120000 ms",
            });
        }
        if self.backoff_min.is_zero() || self.backoff_max < self.backoff_min {
            return Err(VideoError::InvalidConfig {
                field: "backoff_min/backoff_max",
                value: format!("{}/{}", ms(self.backoff_min), ms(self.backoff_max)),
                allowed: "0 < backoff_min <= backoff_max",
            });
        }
        Ok(())
    }
}

/// What the streaming thread and the supervisor share.
struct Shared {
    context: String,
    config: CaptureConfig,
    slot: Arc<FrameSlot>,
    sinks: Vec<Arc<dyn FrameSink>>,
    seq: AtomicU64,
    rolling: Mutex<Rolling>,
    /// When each raw frame (by its timestamp) entered the station's path.
    arrivals: Mutex<VecDeque<(u64, Instant)>>,
    state: Mutex<CaptureState>,
    reconnects: AtomicU64,
    stop: AtomicBool,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

impl Shared {
    fn set_state(&self, s: CaptureState) {
        *lock(&self.state) = s;
    }
}

/// A running capture. Dropping it stops it (waiting at most 2 s for GStreamer).
pub struct Capture {
    shared: Arc<Shared>,
    thread: Option<JoinHandle<()>>,
    done: mpsc::Receiver<()>,
}

impl std::fmt::Debug for Capture {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Capture")
            .field("source", &self.shared.context)
            .field("state", &*lock(&self.shared.state))
            .finish_non_exhaustive()
    }
}

fn appsink_tail(output: OutputSize) -> String {
    let caps = match output {
        OutputSize::Fixed {
            width_px,
            height_px,
        } => format!(
            "videoscale add-borders=true ! video/x-raw,format=RGBA,width={width_px},height={height_px},pixel-aspect-ratio=1/1"
        ),
        OutputSize::Native => "video/x-raw,format=RGBA".to_owned(),
    };
    format!(
        "videoconvert name={CONVERT_NAME} ! {caps} ! appsink name={SINK_NAME} sync=false max-buffers=1 drop=true enable-last-sample=false"
    )
}

/// The full capture pipeline description for a source.
///
/// # Errors
/// [`VideoError::BadSourceSpec`] for `sim` and `none` (not GStreamer sources).
pub fn capture_description(spec: &SourceSpec, config: &CaptureConfig) -> Result<String> {
    let test_size = match config.output {
        OutputSize::Fixed {
            width_px,
            height_px,
        } => (width_px, height_px),
        OutputSize::Native => (640, 480),
    };
    let src = spec
        .gst_description(test_size, config.test_fps)
        .ok_or_else(|| VideoError::BadSourceSpec {
            spec: spec.to_string(),
            reason: "not a GStreamer source (the simulator's camera is rendered by SimCamera; `none` has no video)".to_owned(),
        })?;
    Ok(format!("{src} ! {}", appsink_tail(config.output)))
}

impl Capture {
    /// Starts capturing from a source into a new latest-frame slot and the given sinks.
    /// Returns at once; frames arrive on GStreamer's threads.
    ///
    /// # Errors
    /// [`VideoError::BadSourceSpec`] for `sim`/`none`, [`VideoError::InvalidConfig`],
    /// [`VideoError::MissingPlugin`] naming an element that is not installed and its
    /// package, [`VideoError::BadPipeline`] for a description that does not parse. A device
    /// that is absent or a source that delivers nothing is not an error here: the capture
    /// shows NO VIDEO with the reason and keeps retrying.
    pub fn start(
        spec: &SourceSpec,
        config: CaptureConfig,
        sinks: Vec<Arc<dyn FrameSink>>,
    ) -> Result<Self> {
        config.validate()?;
        let context = format!("video source `{spec}`");
        let description = capture_description(spec, &config)?;
        let mut needed: Vec<&str> = spec.required_elements().to_vec();
        needed.extend(["videoconvert", "videoscale", "appsink"]);
        gst_util::require_elements(&context, &needed)?;
        // Parse once now, so a bad description is an error of `start`, not a state.
        drop(gst_util::parse_pipeline(&context, &description)?);

        let shared = Arc::new(Shared {
            context,
            config,
            slot: FrameSlot::new(),
            sinks,
            seq: AtomicU64::new(0),
            rolling: Mutex::new(Rolling::new()),
            arrivals: Mutex::new(VecDeque::with_capacity(ARRIVALS)),
            state: Mutex::new(CaptureState::Starting),
            reconnects: AtomicU64::new(0),
            stop: AtomicBool::new(false),
        });
        let (done_tx, done) = mpsc::channel();
        let sup = Arc::clone(&shared);
        let spec = spec.clone();
        let thread = std::thread::Builder::new()
            .name("rov-video-capture".to_owned())
            .spawn(move || {
                supervise(&sup, &spec, &description);
                let _ = done_tx.send(());
            })
            .map_err(|e| VideoError::Pipeline {
                context: shared.context.clone(),
                reason: format!("cannot start the capture thread: {e}"),
            })?;
        Ok(Self {
            shared,
            thread: Some(thread),
            done,
        })
    }

    /// The latest-frame slot (share it with the renderer).
    pub fn slot(&self) -> Arc<FrameSlot> {
        Arc::clone(&self.shared.slot)
    }

    /// The latest frame, if any.
    pub fn latest(&self) -> Option<Arc<VideoFrame>> {
        self.shared.slot.latest()
    }

    /// The state now.
    pub fn state(&self) -> CaptureState {
        lock(&self.shared.state).clone()
    }

    /// The figures now (frame age is computed against the caller's clock).
    pub fn stats(&self) -> CaptureStats {
        let state = self.state();
        let now_ns = self.shared.config.clock.now_ns();
        let r = lock(&self.shared.rolling);
        snapshot(
            state,
            &r,
            now_ns,
            self.shared.slot.superseded(),
            u32::try_from(self.shared.reconnects.load(Ordering::Relaxed)).unwrap_or(u32::MAX),
        )
    }

    /// Waits (up to `timeout`) for a frame; for a CLI that wants to report a bad source at
    /// once instead of showing NO VIDEO.
    ///
    /// # Errors
    /// [`VideoError::Pipeline`] with the reason if the capture failed or lost the source,
    /// [`VideoError::Timeout`] if nothing came.
    pub fn wait_first_frame(&self, timeout: Duration) -> Result<Arc<VideoFrame>> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(f) = self.latest() {
                return Ok(f);
            }
            match self.state() {
                CaptureState::Failed { reason }
                | CaptureState::NoVideo { reason }
                | CaptureState::Reconnecting { reason, .. } => {
                    return Err(VideoError::Pipeline {
                        context: self.shared.context.clone(),
                        reason,
                    });
                }
                _ => {}
            }
            if Instant::now() >= deadline {
                return Err(VideoError::Timeout {
                    context: self.shared.context.clone(),
                    what: "no frame".to_owned(),
                    waited_ms: u64::try_from(timeout.as_millis()).unwrap_or(u64::MAX),
                });
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// Stops the capture and waits (at most 2 s) for GStreamer to let go of the source.
    pub fn stop(mut self) {
        self.shutdown();
    }

    fn shutdown(&mut self) {
        self.shared.stop.store(true, Ordering::Release);
        let Some(t) = self.thread.take() else {
            return;
        };
        if self.done.recv_timeout(Duration::from_secs(2)).is_ok() {
            let _ = t.join();
        }
        // Otherwise the thread is left to finish on its own: never block the caller.
    }
}

impl Drop for Capture {
    fn drop(&mut self) {
        self.shutdown();
    }
}

enum Outcome {
    Stopped,
    Lost { reason: String, had_frames: bool },
    Fatal(String),
}

fn supervise(shared: &Arc<Shared>, spec: &SourceSpec, description: &str) {
    let cfg = &shared.config;
    let mut backoff = cfg.backoff_min;
    let mut attempt = 0u32;
    loop {
        if shared.stop.load(Ordering::Acquire) {
            break;
        }
        match run_once(shared, spec, description) {
            Outcome::Stopped => break,
            Outcome::Fatal(reason) => {
                shared.set_state(CaptureState::Failed { reason });
                return;
            }
            Outcome::Lost { reason, had_frames } => {
                if had_frames {
                    backoff = cfg.backoff_min;
                }
                shared.set_state(CaptureState::NoVideo {
                    reason: reason.clone(),
                });
                let until = Instant::now() + backoff;
                while Instant::now() < until {
                    if shared.stop.load(Ordering::Acquire) {
                        shared.set_state(CaptureState::Stopped);
                        return;
                    }
                    std::thread::sleep(POLL);
                }
                backoff = (backoff * 2).min(cfg.backoff_max);
                attempt = attempt.saturating_add(1);
                shared.reconnects.fetch_add(1, Ordering::Relaxed);
                shared.set_state(CaptureState::Reconnecting { attempt, reason });
            }
        }
    }
    shared.set_state(CaptureState::Stopped);
}

/// Runs one pipeline until it stops delivering.
fn run_once(shared: &Arc<Shared>, spec: &SourceSpec, description: &str) -> Outcome {
    let ctx = &shared.context;
    if let SourceSpec::V4l2 { device } = spec
        && !Path::new(device).exists()
    {
        return Outcome::Lost {
            reason: format!("no capture device at {}", device.display()),
            had_frames: false,
        };
    }
    let pipeline = match gst_util::parse_pipeline(ctx, description) {
        Ok(p) => p,
        Err(e) => return Outcome::Fatal(e.to_string()),
    };
    let sink: gst_app::AppSink = match gst_util::by_name(ctx, &pipeline, SINK_NAME) {
        Ok(s) => s,
        Err(e) => return Outcome::Fatal(e.to_string()),
    };
    // Note when each raw frame enters the station's path (for the added latency).
    if let Some(pad) = pipeline
        .by_name(CONVERT_NAME)
        .and_then(|c| c.static_pad("sink"))
    {
        let probe = Arc::clone(shared);
        pad.add_probe(gst::PadProbeType::BUFFER, move |_, info| {
            if let Some(pts) = info.buffer().and_then(|b| b.pts()) {
                let mut a = lock(&probe.arrivals);
                if a.len() == ARRIVALS {
                    a.pop_front();
                }
                a.push_back((pts.nseconds(), Instant::now()));
            }
            gst::PadProbeReturn::Ok
        });
    }
    lock(&shared.rolling).new_stream();
    let frames_before = lock(&shared.rolling).frames;
    let cb = Arc::clone(shared);
    sink.set_callbacks(
        gst_app::AppSinkCallbacks::builder()
            .new_sample(move |s| on_sample(&cb, s))
            .build(),
    );
    let outcome = watch(shared, &pipeline, &sink, frames_before);
    let _ = pipeline.set_state(gst::State::Null);
    outcome
}

fn watch(
    shared: &Arc<Shared>,
    pipeline: &gst::Pipeline,
    sink: &gst_app::AppSink,
    frames_before: u64,
) -> Outcome {
    let cfg = &shared.config;
    let ctx = &shared.context;
    let started = Instant::now();
    // PAUSED first: a live source (camera, network, test) answers "no preroll" and its
    // frames are delivered as they come; a file prerolls and is played at its own pace
    // (the sink synchronises to the clock).
    let start = pipeline.set_state(gst::State::Paused).and_then(|paused| {
        sink.set_sync(paused != gst::StateChangeSuccess::NoPreroll);
        pipeline.set_state(gst::State::Playing)
    });
    if start.is_err() {
        let reason = gst_util::bus_error_now(pipeline)
            .unwrap_or_else(|| "the source refused to start".to_owned());
        return lost_or_fatal(reason, false);
    }
    let Some(bus) = pipeline.bus() else {
        return Outcome::Fatal(format!("{ctx}: the pipeline has no bus"));
    };
    let mut missing_plugin: Option<String> = None;
    loop {
        if shared.stop.load(Ordering::Acquire) {
            return Outcome::Stopped;
        }
        let frames = lock(&shared.rolling).frames - frames_before;
        let had_frames = frames > 0;
        while let Some(msg) = bus.pop() {
            match msg.view() {
                gst::MessageView::Error(e) => {
                    let mut reason = gst_util::describe_error(e);
                    if let Some(m) = &missing_plugin {
                        return Outcome::Fatal(format!("{m} is not installed ({reason})"));
                    }
                    if reason.contains("not-negotiated") || reason.contains("not negotiate") {
                        reason.push_str("; the source's format cannot be converted");
                    }
                    return lost_or_fatal(reason, had_frames);
                }
                gst::MessageView::Eos(_) => {
                    return Outcome::Lost {
                        reason: "end of stream".to_owned(),
                        had_frames,
                    };
                }
                gst::MessageView::Warning(w) => {
                    lock(&shared.rolling).last_warning = Some(format!(
                        "{}: {}",
                        w.src().map(|s| s.name().to_string()).unwrap_or_default(),
                        w.error()
                    ));
                }
                _ => {
                    if let Some(m) = gst_util::describe_missing_plugin(&msg) {
                        missing_plugin = Some(m);
                    }
                }
            }
        }
        let last = lock(&shared.rolling).last_delivery;
        if had_frames {
            let since = last.map_or(Duration::ZERO, |t| t.elapsed());
            if since > cfg.stall_timeout {
                return Outcome::Lost {
                    reason: format!("no frame for {} ms", since.as_millis()),
                    had_frames,
                };
            }
            if !matches!(*lock(&shared.state), CaptureState::Running) {
                shared.set_state(CaptureState::Running);
            }
        } else if started.elapsed() > cfg.start_timeout {
            return Outcome::Lost {
                reason: match missing_plugin {
                    Some(m) => format!("{m} is not installed"),
                    None => format!("no frame within {} ms", cfg.start_timeout.as_millis()),
                },
                had_frames: false,
            };
        }
        std::thread::sleep(POLL);
    }
}

fn lost_or_fatal(reason: String, had_frames: bool) -> Outcome {
    // A decoder or element that is not installed will not appear by retrying.
    if reason.contains("is not installed")
        || (reason.contains("missing") && reason.contains("plug-in"))
    {
        Outcome::Fatal(reason)
    } else {
        Outcome::Lost { reason, had_frames }
    }
}

/// The streaming thread's work for one frame. Returns `Ok` even when a frame cannot be
/// read (it is skipped): a bad frame must not stop the source.
fn on_sample(
    shared: &Arc<Shared>,
    sink: &gst_app::AppSink,
) -> Result<gst::FlowSuccess, gst::FlowError> {
    let sample = sink.pull_sample().map_err(|_| gst::FlowError::Eos)?;
    let now_ns = shared.config.clock.now_ns();
    let delivered = Instant::now();
    let Some(frame) = frame_from_sample(&sample, sink, now_ns, shared) else {
        return Ok(gst::FlowSuccess::Ok);
    };
    let (frame, latency_ns, pts_ns, period_ns) = frame;
    let frame = Arc::new(frame);
    let entered = pts_ns.and_then(|p| {
        lock(&shared.arrivals)
            .iter()
            .rev()
            .find(|(t, _)| *t == p)
            .map(|(_, at)| *at)
    });
    lock(&shared.rolling).record(
        delivered,
        frame.capture_ns,
        latency_ns as f64 * 1e-6,
        (frame.width_px, frame.height_px),
        pts_ns,
        period_ns,
    );
    shared.slot.store(Arc::clone(&frame));
    if let Some(at) = entered {
        lock(&shared.rolling).record_path(at.elapsed().as_secs_f64() * 1e3);
    }
    for s in &shared.sinks {
        s.push(Arc::clone(&frame));
    }
    Ok(gst::FlowSuccess::Ok)
}

type Delivered = (VideoFrame, u64, Option<u64>, Option<u64>);

fn frame_from_sample(
    sample: &gst::Sample,
    sink: &gst_app::AppSink,
    now_ns: u64,
    shared: &Shared,
) -> Option<Delivered> {
    let (w, h, rgba) = gst_util::rgba_of_sample(sample)?;
    let info = gst_video::VideoInfo::from_caps(sample.caps()?).ok()?;
    let buffer = sample.buffer()?;
    // Time spent in the pipeline: clock now − the buffer's capture time in clock time.
    let pts = buffer.pts();
    let delay_ns = (|| {
        let seg = sample.segment()?.downcast_ref::<gst::ClockTime>()?;
        let running = seg.to_running_time(pts?)?;
        let clock = sink.clock()?;
        let base = sink.base_time()?;
        clock
            .time()
            .nseconds()
            .checked_sub((base + running).nseconds())
    })()
    .filter(|d| *d <= MAX_PLAUSIBLE_DELAY_NS)
    .unwrap_or(0);
    let period_ns = {
        let fps = info.fps();
        (fps.numer() > 0 && fps.denom() > 0)
            .then(|| 1_000_000_000u64 * fps.denom() as u64 / fps.numer() as u64)
    };
    let capture_ns = now_ns.saturating_sub(delay_ns);
    let seq = shared.seq.fetch_add(1, Ordering::Relaxed);
    let mut frame = VideoFrame::new(w, h, capture_ns, seq, rgba).ok()?;
    if shared.config.stamp_time {
        stamp::stamp_time(&mut frame, capture_ns);
    }
    Some((frame, delay_ns, pts.map(|p| p.nseconds()), period_ns))
}
