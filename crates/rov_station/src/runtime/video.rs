//! The station's camera: the [`rov_video::VideoFeed`] a station runs, on threads of its
//! own, and the encoder that records it.
//!
//! * Live ([`StationVideo::start_live`]): the source `--video` or `[video] source` names
//!   ([`resolve_source`]): the simulator's camera, rendered at 25 fps of wall time from
//!   the simulated vehicle's latest truth and the lights and camera tilt of the last
//!   control block sent; or a GStreamer capture. Capture times are on the station clock
//!   (the telemetry's), so a recording's video and telemetry share one time base.
//! * Virtual time ([`StationVideo::virtual_sim`], `VirtualStation`): the simulator's
//!   camera rendered by the stepping thread every 40 ms of virtual time; while recording
//!   the frames are pushed to the encoder waiting for room (nothing is dropped on virtual
//!   time).
//! * Replay ([`StationVideo::replay`]): the frame on screen at the play-head, decoded on a
//!   worker from the last key frame (see [`crate::runtime::video_replay`]).
//!
//! Every variant shows its latest frame in one [`FrameSlot`] the GUI reads
//! (`newer_than`, a pointer swap). The control loop never waits for any of it: it only
//! starts and stops the recording encoder ([`StationVideo::begin_recording`]), whose
//! output goes to the recorder's queue without waiting ([`crate::runtime::recorder::VideoTap`]).
//! A source that fails to start leaves the station without video and says why
//! ([`VideoStatus::error`]); a source that stalls shows NO VIDEO with the frame's age
//! and reconnects (rov_video's [`CaptureState`]).

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use rov_types::params::{ConfigError, ParamFile};
use rov_video::{
    CameraModel, CameraPose, CaptureConfig, CaptureState, CaptureStats, Encoder, EncoderConfig,
    FrameSink, FrameSlot, SimCamera, SimFeed, SimScene, SourceSpec, TimeSource, VideoFeed,
    VideoFrame,
};

use crate::runtime::recorder::VideoTap;
use crate::runtime::{Connection, lock};

/// Frames per second of the simulator's camera (live and virtual time).
pub const SIM_FPS: u32 = 25;
/// How long finishing a recording waits for the encoder's last units (on the recording's
/// finisher thread, `runtime::finisher`, never the control thread).
pub(crate) const FINISH_TIMEOUT: Duration = Duration::from_secs(3);

/// The `[video]` table of the station configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct VideoSettings {
    /// The source (`auto`, `sim`, `none`, `test`, `v4l2:/dev/videoN`, a URI or a
    /// GStreamer pipeline); `auto`: the simulator's camera with the simulated vehicle,
    /// the first capture device with a serial port, else none.
    pub source: String,
    /// The simulator's seabed depth, m.
    pub sim_seabed_depth_m: f64,
    /// Draw each simulator frame's capture time into it (`rov_video::stamp`; replay
    /// tests read it back). Not a configuration key.
    pub sim_stamp_time: bool,
}

impl Default for VideoSettings {
    fn default() -> Self {
        Self {
            source: "auto".to_owned(),
            sim_seabed_depth_m: SimScene::default().seabed_depth_m,
            sim_stamp_time: false,
        }
    }
}

impl VideoSettings {
    /// No video at all (the runtime's default: tests and tools that do not ask for it).
    #[must_use]
    pub fn none() -> Self {
        Self {
            source: "none".to_owned(),
            ..Self::default()
        }
    }

    /// Reads `[video]` (every key optional; unknown keys refused).
    ///
    /// # Errors
    /// [`ConfigError`] naming the file, key, value and allowed range.
    pub fn from_param_file(f: &ParamFile) -> Result<Self, ConfigError> {
        let d = Self::default();
        let s = Self {
            source: f.string_or("video.source", &d.source)?,
            sim_seabed_depth_m: f.f64_or(
                "video.sim_seabed_depth_m",
                1.0..=200.0,
                d.sim_seabed_depth_m,
            )?,
            sim_stamp_time: false,
        };
        f.reject_unknown("video")?;
        Ok(s)
    }

    /// The `[video]` table as TOML.
    #[must_use]
    pub fn to_toml(&self) -> String {
        format!(
            "source = {}\nsim_seabed_depth_m = {:?}\n",
            toml_edit::Value::from(self.source.as_str()),
            self.sim_seabed_depth_m
        )
    }
}

/// The source `text` names for a station on `connection`: `auto` (or empty) is the
/// simulator's camera with the simulated vehicle, the first V4L2 capture device found
/// with a serial port, else `none`.
///
/// # Errors
/// The parser's [`rov_video::VideoError::BadSourceSpec`] (naming the text and what is
/// wrong).
pub fn resolve_source(
    text: &str,
    connection: &Connection,
) -> Result<SourceSpec, rov_video::VideoError> {
    let t = text.trim();
    if t.is_empty() || t.eq_ignore_ascii_case("auto") {
        return Ok(match connection {
            Connection::Sim => SourceSpec::Sim,
            Connection::Serial(_) => match rov_video::list_capture_devices() {
                Ok(d) => d.into_iter().next().map_or(SourceSpec::None, |d| d.spec),
                // `auto` means "a camera if there is one": none found is no error, but
                // a listing that failed is said (the station then runs without video).
                Err(e) => {
                    tracing::warn!("video source auto: cannot list capture devices: {e}");
                    SourceSpec::None
                }
            },
        });
    }
    SourceSpec::parse(t)
}

/// Why a recording has no video (it goes on without).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RecordVideoError {
    /// The encoder did not start (x264 missing, pipeline refused).
    #[error("recording without video: {0}")]
    Encoder(#[source] rov_video::VideoError),
    /// The thread that starts the encoder could not be started.
    #[error("cannot start the video encoder's thread: {0}")]
    Thread(#[source] std::io::Error),
}

/// What the GUI shows about the video (a copy).
#[derive(Debug, Clone, PartialEq)]
pub struct VideoStatus {
    /// The source as named (`sim`, `v4l2:/dev/video0`, …).
    pub source: String,
    /// Why the source did not start (the station runs without video).
    pub error: Option<String>,
    /// The feed's figures and state (`None` when no feed runs).
    pub stats: Option<CaptureStats>,
    /// Recording: frames the encoder dropped because its queue was full (live only).
    pub record_dropped: u64,
    /// Recording is encoding video now.
    pub recording: bool,
    /// Why the current recording has no video (the encoder did not start).
    pub record_error: Option<String>,
}

impl VideoStatus {
    /// The line a pilot reads when there is no picture: the source, the state and the
    /// frame's age ("NO VIDEO: no frame for 512 ms (reconnecting, attempt 2)").
    #[must_use]
    pub fn no_video_label(&self) -> Option<String> {
        if let Some(e) = &self.error {
            return Some(format!("NO VIDEO: {e}"));
        }
        let s = self.stats.as_ref()?;
        if s.state.has_video() {
            return None;
        }
        let age = s
            .frame_age_ms
            .map(|a| format!(" (last frame {:.1} s ago)", a / 1e3))
            .unwrap_or_default();
        Some(format!("{} [{}]{age}", s.state.label(), self.source))
    }
}

/// The sink the feed delivers to while recording: the encoder if one runs. Takes the
/// lock without waiting (a frame arriving while recording starts or stops is skipped).
#[derive(Default)]
struct RecordSink {
    encoder: Mutex<Option<Encoder>>,
    dropped: AtomicU64,
    /// Frames given to the encoder and units it delivered (virtual time waits for each
    /// frame's unit, so units reach the file in time order with the telemetry).
    pushed: AtomicU64,
    delivered: Arc<AtomicU64>,
    /// Recordings begun and ended so far: an encoder started on a helper thread is
    /// installed only if its recording is still the current one.
    generation: AtomicU64,
    /// Why the last recording's encoder did not start.
    error: Mutex<Option<String>>,
}

impl FrameSink for RecordSink {
    fn push(&self, frame: Arc<VideoFrame>) {
        if let Ok(g) = self.encoder.try_lock()
            && let Some(e) = g.as_ref()
            && !e.push(frame)
        {
            self.dropped.fetch_add(1, Ordering::Relaxed);
        }
    }
}

/// The simulator's camera on virtual time.
struct VirtualCamera {
    camera: SimCamera,
    next_ns: u64,
    seq: u64,
    frames: u64,
    last_ns: Option<u64>,
}

enum Kind {
    Live(Mutex<Option<VideoFeed>>),
    Virtual(Mutex<VirtualCamera>),
    Replay(crate::runtime::video_replay::ReplayVideo),
    Off,
}

/// The station's camera; see the [module docs](self).
pub struct StationVideo {
    source: String,
    error: Option<String>,
    kind: Kind,
    slot: Option<Arc<FrameSlot>>,
    record: Arc<RecordSink>,
    /// The clock of capture times, ns (virtual time: the last virtual tick).
    clock: TimeSource,
    virtual_now_ns: Arc<AtomicU64>,
}

impl std::fmt::Debug for StationVideo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StationVideo")
            .field("source", &self.source)
            .field("error", &self.error)
            .finish_non_exhaustive()
    }
}

/// The latest pose and lights for the simulator's camera.
pub type PoseSource = Box<dyn Fn() -> Option<(CameraPose, f64)> + Send + 'static>;

/// The camera pose of the simulated vehicle's truth with a camera tilt, degrees.
#[must_use]
pub fn pose_of_truth(t: &rov_sim::TruthState, tilt_deg: f64) -> CameraPose {
    let r = crate::pilot::truth_record(t);
    CameraPose::from_degrees(
        r.north_m,
        r.east_m,
        r.depth_m,
        r.roll_deg,
        r.pitch_deg,
        r.heading_deg,
        tilt_deg,
    )
}

fn sim_camera(settings: &VideoSettings) -> Result<SimCamera, rov_video::VideoError> {
    let scene = SimScene {
        seabed_depth_m: settings.sim_seabed_depth_m,
        ..SimScene::default()
    };
    SimCamera::new(scene, CameraModel::default(), settings.sim_stamp_time)
}

impl StationVideo {
    fn new(source: String, kind: Kind, slot: Option<Arc<FrameSlot>>, clock: TimeSource) -> Self {
        Self {
            source,
            error: None,
            kind,
            slot,
            record: Arc::new(RecordSink::default()),
            clock,
            virtual_now_ns: Arc::new(AtomicU64::new(0)),
        }
    }

    /// No video.
    #[must_use]
    pub fn off() -> Self {
        Self::new("none".into(), Kind::Off, None, TimeSource::monotonic())
    }

    /// A station without video because its source failed: the message names the source
    /// and what is missing.
    #[must_use]
    pub fn failed(source: &str, error: String) -> Self {
        let mut v = Self::new(source.to_owned(), Kind::Off, None, TimeSource::monotonic());
        v.error = Some(error);
        v
    }

    /// Starts a live source. `now_ns` is the station clock; `pose` gives the simulated
    /// vehicle's pose and lights (the `sim` source only). Never fails: a source that does
    /// not start gives a station without video and the reason ([`VideoStatus::error`]).
    #[must_use]
    pub fn start_live(
        settings: &VideoSettings,
        connection: &Connection,
        now_ns: impl Fn() -> u64 + Send + Sync + 'static,
        pose: Option<PoseSource>,
    ) -> Self {
        let spec = match resolve_source(&settings.source, connection) {
            Ok(s) => s,
            Err(e) => return Self::failed(&settings.source, e.to_string()),
        };
        let label = spec.to_string();
        if spec == SourceSpec::None {
            return Self::off();
        }
        let clock = TimeSource::new(now_ns);
        let sim = match (&spec, pose) {
            (SourceSpec::Sim, Some(p)) => match sim_camera(settings) {
                Ok(camera) => Some(SimFeed {
                    camera,
                    fps: SIM_FPS,
                    pose: p,
                }),
                Err(e) => return Self::failed(&label, format!("video source {label}: {e}")),
            },
            _ => None,
        };
        let record = Arc::new(RecordSink::default());
        let sink: Arc<dyn FrameSink> = Arc::clone(&record) as Arc<dyn FrameSink>;
        let config = CaptureConfig {
            clock: clock.clone(),
            ..CaptureConfig::default()
        };
        match VideoFeed::start(&spec, config, sim, vec![sink]) {
            Ok(feed) => {
                let slot = feed.slot();
                let mut v = Self::new(label, Kind::Live(Mutex::new(Some(feed))), slot, clock);
                v.record = record;
                v
            }
            Err(e) => Self::failed(&label, format!("video source {label}: {e}")),
        }
    }

    /// The simulator's camera on virtual time (frames made by [`StationVideo::virtual_tick`]).
    /// `sim` (or `auto`) renders; `none` is off; any other source is refused with a
    /// message (a capture runs on wall time).
    #[must_use]
    pub fn virtual_sim(settings: &VideoSettings) -> Self {
        match resolve_source(&settings.source, &Connection::Sim) {
            Ok(SourceSpec::Sim) => {}
            Ok(SourceSpec::None) => return Self::off(),
            Ok(other) => {
                return Self::failed(
                    &other.to_string(),
                    format!(
                        "video source {other}: a capture runs on wall time; on virtual time (--fast) only sim or none"
                    ),
                );
            }
            Err(e) => return Self::failed(&settings.source, e.to_string()),
        }
        let camera = match sim_camera(settings) {
            Ok(c) => c,
            Err(e) => return Self::failed("sim", format!("video source sim: {e}")),
        };
        let now = Arc::new(AtomicU64::new(0));
        let n = Arc::clone(&now);
        let mut v = Self::new(
            "sim".into(),
            Kind::Virtual(Mutex::new(VirtualCamera {
                camera,
                next_ns: 0,
                seq: 0,
                frames: 0,
                last_ns: None,
            })),
            Some(FrameSlot::new()),
            TimeSource::new(move || n.load(Ordering::Relaxed)),
        );
        v.virtual_now_ns = now;
        v
    }

    /// The recorded video of a session, shown at the play-head by a decoding worker.
    #[must_use]
    pub fn replay(session: rov_session::Session) -> Self {
        match crate::runtime::video_replay::ReplayVideo::start(session) {
            Ok(Some(r)) => {
                let slot = Some(r.slot());
                Self::new(
                    "session".into(),
                    Kind::Replay(r),
                    slot,
                    TimeSource::monotonic(),
                )
            }
            Ok(None) => Self::off(),
            Err(e) => Self::failed(
                "session",
                format!("recorded video: cannot start the replay video thread: {e}"),
            ),
        }
    }

    /// Virtual time: renders a frame if one is due at `now_us` (every 40 ms), shows it and
    /// encodes it while recording (waiting for the encoder: nothing is dropped).
    pub fn virtual_tick(
        &self,
        truth: &rov_sim::TruthState,
        lights_pct: f64,
        tilt_deg: f64,
        now_us: u64,
    ) {
        let Kind::Virtual(m) = &self.kind else {
            return;
        };
        let now_ns = now_us.saturating_mul(1000);
        self.virtual_now_ns.store(now_ns, Ordering::Relaxed);
        let mut cam = lock(m);
        if now_ns < cam.next_ns {
            return;
        }
        let period_ns = 1_000_000_000 / u64::from(SIM_FPS);
        // The grid k · 40 ms from the first frame.
        cam.next_ns = if cam.next_ns == 0 {
            now_ns + period_ns
        } else {
            cam.next_ns + period_ns * ((now_ns - cam.next_ns) / period_ns + 1)
        };
        let frame = Arc::new(cam.camera.render(
            &pose_of_truth(truth, tilt_deg),
            lights_pct,
            now_ns,
            cam.seq,
        ));
        cam.seq += 1;
        cam.frames += 1;
        cam.last_ns = Some(now_ns);
        drop(cam);
        if let Some(s) = &self.slot {
            s.store(Arc::clone(&frame));
        }
        let r = &self.record;
        if let Some(e) = lock(&r.encoder).as_ref() {
            if e.push_blocking(frame).is_err() {
                r.dropped.fetch_add(1, Ordering::Relaxed);
                return;
            }
            let pushed = r.pushed.fetch_add(1, Ordering::Relaxed) + 1;
            // x264 at zero latency gives one unit per frame: wait for it (bounded).
            let until = std::time::Instant::now() + Duration::from_secs(2);
            while r.delivered.load(Ordering::Acquire) < pushed && std::time::Instant::now() < until
            {
                std::thread::sleep(Duration::from_micros(200));
            }
        }
    }

    /// The play-head moved (replay): show the frame on screen at `t_ns` (session time).
    pub fn show_at(&self, t_ns: u64) {
        if let Kind::Replay(r) = &self.kind {
            r.request(t_ns);
        }
    }

    /// The latest-frame slot (`None` without video).
    #[must_use]
    pub fn slot(&self) -> Option<Arc<FrameSlot>> {
        self.slot.clone()
    }

    /// The clock of capture times now, ns (for capture-to-screen latency).
    #[must_use]
    pub fn now_ns(&self) -> u64 {
        self.clock.now_ns()
    }

    /// A live source (capture times on the station clock: the capture-to-screen latency
    /// means something).
    #[must_use]
    pub fn is_live(&self) -> bool {
        matches!(self.kind, Kind::Live(_))
    }

    /// Whether there is a picture to show (or a reason there is none): the Fly tab's
    /// main view is the video.
    #[must_use]
    pub fn is_on(&self) -> bool {
        self.slot.is_some() || self.error.is_some()
    }

    /// The figures and state now.
    #[must_use]
    pub fn status(&self) -> VideoStatus {
        let stats = match &self.kind {
            Kind::Live(f) => lock(f).as_ref().map(VideoFeed::stats),
            Kind::Virtual(m) => {
                let c = lock(m);
                let now = self.virtual_now_ns.load(Ordering::Relaxed);
                Some(CaptureStats {
                    state: if c.frames > 0 {
                        CaptureState::Running
                    } else {
                        CaptureState::Starting
                    },
                    frames: c.frames,
                    fps: f64::from(SIM_FPS),
                    frame_size_px: Some((c.camera.model().width_px, c.camera.model().height_px)),
                    last_capture_ns: c.last_ns,
                    frame_age_ms: c.last_ns.map(|t| now.saturating_sub(t) as f64 * 1e-6),
                    ..VideoFeed::Off.stats()
                })
            }
            Kind::Replay(r) => Some(r.stats()),
            Kind::Off => None,
        };
        VideoStatus {
            source: self.source.clone(),
            error: self.error.clone(),
            stats,
            record_dropped: self.record.dropped.load(Ordering::Relaxed),
            recording: lock(&self.record.encoder).is_some(),
            record_error: lock(&self.record.error).clone(),
        }
    }

    /// Starts encoding for a recording: every access unit goes to `tap` (the recorder's
    /// queue). Live, the encoder's GStreamer pipeline is built on a helper thread (tens
    /// of ms the control thread must not spend; the first frames of the recording come
    /// once it runs); on virtual time it is built here, so no frame is missed. Nothing to
    /// do without video.
    ///
    /// # Errors
    /// [`RecordVideoError`]: the encoder did not start (x264 missing, pipeline refused)
    /// on virtual time; live, the same ends in [`VideoStatus::record_error`]. The
    /// recording goes on without video.
    pub fn begin_recording(&self, tap: VideoTap) -> Result<bool, RecordVideoError> {
        if !matches!(self.kind, Kind::Live(_) | Kind::Virtual(_)) || self.slot.is_none() {
            return Ok(false);
        }
        let record = Arc::clone(&self.record);
        let generation = record.generation.fetch_add(1, Ordering::AcqRel) + 1;
        record.pushed.store(0, Ordering::Relaxed);
        record.delivered.store(0, Ordering::Relaxed);
        record.dropped.store(0, Ordering::Relaxed);
        *lock(&record.error) = None;
        let start = move || -> Result<(), RecordVideoError> {
            let delivered = Arc::clone(&record.delivered);
            let enc = Encoder::start(EncoderConfig::default(), move |au| {
                tap.send(au);
                delivered.fetch_add(1, Ordering::Release);
            })
            .map_err(RecordVideoError::Encoder)?;
            let mut slot = lock(&record.encoder);
            // A recording that ended meanwhile drops the new encoder unused.
            if record.generation.load(Ordering::Acquire) == generation
                && let Some(old) = slot.replace(enc)
                && let Err(e) = old.finish(FINISH_TIMEOUT)
            {
                // An encoder left from an earlier start of this recording: its units
                // went to the same file; say if its end was lost.
                tracing::warn!("video recording: the replaced encoder did not finish: {e}");
            }
            Ok(())
        };
        if matches!(self.kind, Kind::Virtual(_)) {
            start()?;
        } else {
            let record = Arc::clone(&self.record);
            std::thread::Builder::new()
                .name("station-video-encoder-start".into())
                .spawn(move || {
                    // Started by the control thread: neither this thread nor the
                    // encoder's GStreamer threads it creates run at its real-time priority.
                    crate::runtime::priority::normal_current();
                    if let Err(e) = start() {
                        *lock(&record.error) = Some(e.to_string());
                    }
                })
                .map_err(RecordVideoError::Thread)?;
        }
        Ok(true)
    }

    /// Ends the recording's encoding without waiting: the encoder is handed back to be
    /// finished elsewhere (its last units still go to the recording's tap; see
    /// `runtime::finisher`). `None` when nothing was encoding. An encoder still being
    /// built for this recording is dropped unused when it arrives.
    pub fn detach_recording(&self) -> Option<Encoder> {
        self.record.generation.fetch_add(1, Ordering::AcqRel);
        lock(&self.record.encoder).take()
    }

    /// Stops the source (also on drop).
    pub fn stop(&self) {
        if let Kind::Live(f) = &self.kind
            && let Some(feed) = lock(f).take()
        {
            feed.stop();
        }
    }
}

impl Drop for StationVideo {
    fn drop(&mut self) {
        self.stop();
    }
}
