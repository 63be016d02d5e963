//! Encoder: RGBA frames → H.264 Annex B access units, on its own thread.
//!
//! `appsrc → videoconvert → x264enc → h264parse → appsink`, with
//! * `tune=zerolatency` (no look-ahead, no frame delay) and `bframes=0`: pictures come out
//!   in capture order, one access unit per frame, as a live station needs;
//! * a key frame at least every [`EncoderConfig::key_interval`] (2 s) **of capture
//!   time**: x264's `key-int-max` covers the nominal rate and the input thread forces a
//!   key unit when a slower source would stretch the interval;
//! * `h264parse config-interval=-1`: SPS and PPS in front of every key frame, so any key
//!   frame starts a decoder (seeking in replay, a recovered file);
//! * constant bit rate [`EncoderConfig::bitrate_kbit_s`] (1500 kbit/s by default: one hour
//!   is 675 MB, under the 1 GB per hour of the issue at any content).
//!
//! # Never blocking the caller
//! [`Encoder::push`] puts the frame in a bounded queue ([`EncoderConfig::queue_frames`])
//! and returns at once; a full queue drops the frame and counts it. The input thread feeds
//! GStreamer (it may wait there, nobody else does). Access units are handed to the
//! caller's callback on GStreamer's output thread, with the frame's capture time as
//! `pts_ns`. [`Encoder::push_blocking`] waits for room instead, for virtual-time recording
//! where nothing may be lost.
//!
//! A frame size change is followed: the input caps change, x264 starts a new sequence
//! with a key frame and new SPS/PPS.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, SyncSender, TrySendError};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use gstreamer as gst;
use gstreamer::prelude::*;
use gstreamer_app as gst_app;
use gstreamer_video as gst_video;

use crate::annexb::AccessUnit;
use crate::error::{Result, VideoError};
use crate::frame::{FrameSink, VideoFrame};
use crate::gst_util;

const CONTEXT: &str = "video encoder";

/// x264's speed/quality trade-off (faster = less CPU, more bits for the same quality).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SpeedPreset {
    /// Least CPU.
    Ultrafast,
    /// The default: about half of `veryfast`'s CPU at 640×480.
    #[default]
    Superfast,
    /// Better quality per bit.
    Veryfast,
    /// Better still.
    Faster,
}

impl SpeedPreset {
    fn name(self) -> &'static str {
        match self {
            Self::Ultrafast => "ultrafast",
            Self::Superfast => "superfast",
            Self::Veryfast => "veryfast",
            Self::Faster => "faster",
        }
    }
}

/// Encoder settings; `Default` is what recording uses.
#[derive(Debug, Clone, PartialEq)]
pub struct EncoderConfig {
    /// Target bit rate, kbit/s (100..=20000). 1500 → 675 MB per hour.
    pub bitrate_kbit_s: u32,
    /// Nominal frame rate (for x264's rate control and key interval), frames/s (1..=120).
    pub nominal_fps: u32,
    /// Longest time between key frames (0.2..=10 s).
    pub key_interval: Duration,
    /// Frames waiting for the encoder before new ones are dropped (1..=250).
    pub queue_frames: usize,
    /// Speed preset.
    pub speed_preset: SpeedPreset,
}

impl Default for EncoderConfig {
    fn default() -> Self {
        Self {
            bitrate_kbit_s: 1500,
            nominal_fps: 25,
            key_interval: Duration::from_secs(2),
            queue_frames: 8,
            speed_preset: SpeedPreset::default(),
        }
    }
}

impl EncoderConfig {
    fn validate(&self) -> Result<()> {
        if !(100..=20_000).contains(&self.bitrate_kbit_s) {
            return Err(VideoError::InvalidConfig {
                field: "bitrate_kbit_s",
                value: self.bitrate_kbit_s.to_string(),
                allowed: "100..=20000 kbit/s",
            });
        }
        if !(1..=120).contains(&self.nominal_fps) {
            return Err(VideoError::InvalidConfig {
                field: "nominal_fps",
                value: self.nominal_fps.to_string(),
                allowed: "1..=120 frames/s",
            });
        }
        if !(Duration::from_millis(200)..=Duration::from_secs(10)).contains(&self.key_interval) {
            return Err(VideoError::InvalidConfig {
                field: "key_interval",
                value: format!("{} ms", self.key_interval.as_millis()),
                allowed: "200..=10000 ms",
            });
        }
        if !(1..=250).contains(&self.queue_frames) {
            return Err(VideoError::InvalidConfig {
                field: "queue_frames",
                value: self.queue_frames.to_string(),
                allowed: "1..=250",
            });
        }
        Ok(())
    }

    /// The pipeline description.
    fn description(&self) -> String {
        let key_int = (self.key_interval.as_secs_f64() * f64::from(self.nominal_fps))
            .floor()
            .max(1.0) as u32;
        format!(
            "appsrc name=src format=time is-live=false do-timestamp=false block=true max-bytes=8000000 \
             ! videoconvert ! video/x-raw,format=I420 \
             ! x264enc name=enc tune=zerolatency speed-preset={} bitrate={} key-int-max={key_int} bframes=0 \
               byte-stream=true insert-vui=true vbv-buf-capacity=1000 \
             ! h264parse config-interval=-1 ! video/x-h264,stream-format=byte-stream,alignment=au \
             ! appsink name=sink sync=false enable-last-sample=false",
            self.speed_preset.name(),
            self.bitrate_kbit_s,
        )
    }
}

/// An encoder's figures.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct EncoderStats {
    /// Frames accepted into the queue.
    pub frames_in: u64,
    /// Frames dropped because the queue was full (or the encoder had stopped).
    pub frames_dropped: u64,
    /// Access units delivered.
    pub access_units: u64,
    /// Key frames among them.
    pub key_frames: u64,
    /// Bytes delivered.
    pub bytes: u64,
    /// The error that stopped the encoder, if any.
    pub error: Option<String>,
}

#[derive(Default)]
struct Counters {
    frames_in: AtomicU64,
    frames_dropped: AtomicU64,
    access_units: AtomicU64,
    key_frames: AtomicU64,
    bytes: AtomicU64,
    error: Mutex<Option<String>>,
    stopped: AtomicBool,
}

impl Counters {
    fn fail(&self, reason: String) {
        let mut e = self
            .error
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if e.is_none() {
            *e = Some(reason);
        }
        self.stopped.store(true, Ordering::Release);
    }

    fn snapshot(&self) -> EncoderStats {
        EncoderStats {
            frames_in: self.frames_in.load(Ordering::Relaxed),
            frames_dropped: self.frames_dropped.load(Ordering::Relaxed),
            access_units: self.access_units.load(Ordering::Relaxed),
            key_frames: self.key_frames.load(Ordering::Relaxed),
            bytes: self.bytes.load(Ordering::Relaxed),
            error: self
                .error
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner)
                .clone(),
        }
    }
}

enum Msg {
    Frame(Arc<VideoFrame>),
    Finish,
}

/// A running encoder; see the [module docs](self).
pub struct Encoder {
    tx: SyncSender<Msg>,
    counters: Arc<Counters>,
    thread: Option<JoinHandle<()>>,
    done: Mutex<Receiver<()>>,
}

impl std::fmt::Debug for Encoder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Encoder")
            .field("stats", &self.counters.snapshot())
            .finish_non_exhaustive()
    }
}

/// A frame's pixels handed to GStreamer without a copy.
struct FrameBytes(Arc<VideoFrame>);

impl AsRef<[u8]> for FrameBytes {
    fn as_ref(&self) -> &[u8] {
        &self.0.rgba
    }
}

impl Encoder {
    /// Starts an encoder. `on_access_unit` receives every access unit, in order, on
    /// GStreamer's output thread (keep it short: hand the unit to a channel).
    ///
    /// # Errors
    /// [`VideoError::InvalidConfig`], [`VideoError::MissingPlugin`] (x264enc is in
    /// gstreamer1.0-plugins-ugly), [`VideoError::Pipeline`] if the pipeline cannot start.
    pub fn start(
        config: EncoderConfig,
        on_access_unit: impl FnMut(AccessUnit) + Send + 'static,
    ) -> Result<Self> {
        config.validate()?;
        gst_util::require_elements(
            CONTEXT,
            &["appsrc", "videoconvert", "x264enc", "h264parse", "appsink"],
        )?;
        let pipeline = gst_util::parse_pipeline(CONTEXT, &config.description())?;
        let src: gst_app::AppSrc = gst_util::by_name(CONTEXT, &pipeline, "src")?;
        let sink: gst_app::AppSink = gst_util::by_name(CONTEXT, &pipeline, "sink")?;
        let counters = Arc::new(Counters::default());
        // Capture time of the first frame: GStreamer times count from it.
        let origin_ns = Arc::new(AtomicU64::new(0));

        let out_counters = Arc::clone(&counters);
        let out_origin = Arc::clone(&origin_ns);
        let mut on_au = on_access_unit;
        sink.set_callbacks(
            gst_app::AppSinkCallbacks::builder()
                .new_sample(move |s| {
                    let sample = s.pull_sample().map_err(|_| gst::FlowError::Eos)?;
                    if let Some(buf) = sample.buffer()
                        && let Ok(map) = buf.map_readable()
                    {
                        let key_frame = !buf.flags().contains(gst::BufferFlags::DELTA_UNIT);
                        // x264enc shifts its output times (room for a DTS before the PTS);
                        // the running time undoes the shift: it is the input's time.
                        let running = buf.pts().and_then(|p| {
                            sample
                                .segment()
                                .and_then(|seg| seg.downcast_ref::<gst::ClockTime>())
                                .and_then(|seg| seg.to_running_time(p))
                                .or(Some(p))
                        });
                        let pts_ns = out_origin.load(Ordering::Acquire)
                            + running.map_or(0, |p| p.nseconds());
                        out_counters.access_units.fetch_add(1, Ordering::Relaxed);
                        out_counters
                            .bytes
                            .fetch_add(map.size() as u64, Ordering::Relaxed);
                        if key_frame {
                            out_counters.key_frames.fetch_add(1, Ordering::Relaxed);
                        }
                        on_au(AccessUnit {
                            pts_ns,
                            key_frame,
                            data: map.as_slice().to_vec(),
                        });
                    }
                    Ok(gst::FlowSuccess::Ok)
                })
                .build(),
        );
        gst_util::set_state(CONTEXT, &pipeline, gst::State::Playing)?;

        let (tx, rx) = mpsc::sync_channel(config.queue_frames);
        let (done_tx, done) = mpsc::channel();
        let in_counters = Arc::clone(&counters);
        let thread = std::thread::Builder::new()
            .name("rov-video-encode".to_owned())
            .spawn(move || {
                let mut input = Input {
                    src,
                    pipeline,
                    counters: in_counters,
                    origin_ns,
                    config,
                    started: false,
                    last_pts_ns: None,
                    last_key_ns: None,
                    size: None,
                };
                input.run(&rx);
                let _ = input.pipeline.set_state(gst::State::Null);
                input.counters.stopped.store(true, Ordering::Release);
                let _ = done_tx.send(());
            })
            .map_err(|e| VideoError::Pipeline {
                context: CONTEXT.to_owned(),
                reason: format!("cannot start the encoder thread: {e}"),
            })?;
        Ok(Self {
            tx,
            counters,
            thread: Some(thread),
            done: Mutex::new(done),
        })
    }

    /// Queues a frame without waiting; `false` if it was dropped (queue full or encoder
    /// stopped; counted in the stats).
    pub fn push(&self, frame: Arc<VideoFrame>) -> bool {
        if self.counters.stopped.load(Ordering::Acquire) {
            self.counters.frames_dropped.fetch_add(1, Ordering::Relaxed);
            return false;
        }
        match self.tx.try_send(Msg::Frame(frame)) {
            Ok(()) => {
                self.counters.frames_in.fetch_add(1, Ordering::Relaxed);
                true
            }
            Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => {
                self.counters.frames_dropped.fetch_add(1, Ordering::Relaxed);
                false
            }
        }
    }

    /// Queues a frame, waiting for room (virtual-time recording, export).
    ///
    /// # Errors
    /// [`VideoError::Stopped`] if the encoder has stopped (its error is in the reason).
    pub fn push_blocking(&self, frame: Arc<VideoFrame>) -> Result<()> {
        if !self.counters.stopped.load(Ordering::Acquire) && self.tx.send(Msg::Frame(frame)).is_ok()
        {
            self.counters.frames_in.fetch_add(1, Ordering::Relaxed);
            return Ok(());
        }
        Err(VideoError::Stopped {
            context: CONTEXT,
            reason: self
                .counters
                .snapshot()
                .error
                .unwrap_or_else(|| "finished".to_owned()),
        })
    }

    /// The figures now.
    pub fn stats(&self) -> EncoderStats {
        self.counters.snapshot()
    }

    /// Encodes what is queued, delivers the last access units and stops (waiting at most
    /// `timeout`).
    ///
    /// # Errors
    /// [`VideoError::Timeout`] if the encoder did not finish in time, [`VideoError::Stopped`]
    /// if it had failed (with its error).
    pub fn finish(mut self, timeout: Duration) -> Result<EncoderStats> {
        let _ = self.tx.send(Msg::Finish);
        let finished = self
            .done
            .lock()
            .map(|d| d.recv_timeout(timeout).is_ok())
            .unwrap_or(false);
        if !finished {
            return Err(VideoError::Timeout {
                context: CONTEXT.to_owned(),
                what: "the encoder did not finish".to_owned(),
                waited_ms: u64::try_from(timeout.as_millis()).unwrap_or(u64::MAX),
            });
        }
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        let stats = self.counters.snapshot();
        match &stats.error {
            Some(e) => Err(VideoError::Stopped {
                context: CONTEXT,
                reason: e.clone(),
            }),
            None => Ok(stats),
        }
    }
}

impl Drop for Encoder {
    fn drop(&mut self) {
        if self.thread.is_some() {
            // Ask the thread to finish; do not wait for it.
            let _ = self.tx.try_send(Msg::Finish);
        }
    }
}

impl FrameSink for Encoder {
    fn push(&self, frame: Arc<VideoFrame>) {
        let _ = Encoder::push(self, frame);
    }
}

/// The input thread's state.
struct Input {
    src: gst_app::AppSrc,
    pipeline: gst::Pipeline,
    counters: Arc<Counters>,
    origin_ns: Arc<AtomicU64>,
    config: EncoderConfig,
    started: bool,
    last_pts_ns: Option<u64>,
    last_key_ns: Option<u64>,
    size: Option<(u32, u32)>,
}

impl Input {
    fn run(&mut self, rx: &Receiver<Msg>) {
        while let Ok(msg) = rx.recv() {
            if let Some(err) = gst_util::bus_error_now(&self.pipeline) {
                self.counters.fail(err);
                return;
            }
            match msg {
                Msg::Frame(f) => {
                    if let Err(e) = self.encode(f) {
                        self.counters.fail(e);
                        return;
                    }
                }
                Msg::Finish => break,
            }
        }
        if self.started {
            let _ = self.src.end_of_stream();
            if let Err(e) = gst_util::wait_eos(CONTEXT, &self.pipeline, Duration::from_secs(30)) {
                self.counters.fail(e.to_string());
            }
        }
    }

    fn encode(&mut self, frame: Arc<VideoFrame>) -> Result<(), String> {
        let expected = crate::frame::rgba_len(frame.width_px, frame.height_px);
        if expected == 0 || frame.rgba.len() != expected {
            // A malformed frame is skipped and counted, never fed to GStreamer.
            self.counters.frames_dropped.fetch_add(1, Ordering::Relaxed);
            return Ok(());
        }
        if !self.started {
            self.origin_ns.store(frame.capture_ns, Ordering::Release);
            self.started = true;
        }
        let origin = self.origin_ns.load(Ordering::Acquire);
        // Strictly increasing times (a repeated or earlier capture time moves 1 µs on).
        let mut pts = frame.capture_ns.saturating_sub(origin);
        if let Some(last) = self.last_pts_ns
            && pts <= last
        {
            pts = last + 1_000;
        }
        self.last_pts_ns = Some(pts);
        let size = (frame.width_px, frame.height_px);
        if self.size != Some(size) {
            let caps = gst_video::VideoInfo::builder(gst_video::VideoFormat::Rgba, size.0, size.1)
                .fps(gst::Fraction::new(
                    i32::try_from(self.config.nominal_fps).unwrap_or(25),
                    1,
                ))
                .build()
                .and_then(|i| i.to_caps())
                .map_err(|e| format!("frame size {}×{}: {e}", size.0, size.1))?;
            self.src.set_caps(Some(&caps));
            self.size = Some(size);
            self.last_key_ns = Some(pts); // a new sequence starts with a key frame
        }
        // Force a key frame when the capture-time interval would exceed the limit (a source
        // slower than the nominal rate); a frame period of margin.
        let interval = u64::try_from(self.config.key_interval.as_nanos()).unwrap_or(u64::MAX);
        let margin = 1_000_000_000 / u64::from(self.config.nominal_fps.max(1));
        match self.last_key_ns {
            Some(k) if pts.saturating_sub(k) + margin < interval => {}
            _ => {
                let ev = gst_video::DownstreamForceKeyUnitEvent::builder()
                    .timestamp(gst::ClockTime::from_nseconds(pts))
                    .all_headers(true)
                    .build();
                let _ = self.src.send_event(ev);
                self.last_key_ns = Some(pts);
            }
        }
        let mut buffer = gst::Buffer::from_slice(FrameBytes(frame));
        if let Some(b) = buffer.get_mut() {
            b.set_pts(gst::ClockTime::from_nseconds(pts));
        }
        self.src.push_buffer(buffer).map(|_| ()).map_err(|e| {
            gst_util::bus_error_now(&self.pipeline)
                .unwrap_or_else(|| format!("the encoder refused a frame: {e:?}"))
        })
    }
}
