//! Camera video for the topside station: where the picture comes from, how it reaches the
//! screen without ever holding up control, and how it is recorded, replayed and exported.
//!
//! * [`source`]: [`SourceSpec`], the text of `--video SOURCE` (`sim`, `none`, `test`,
//!   `v4l2:/dev/videoN`, `rtsp://…`, `udp://…`, `file:///…`, a GStreamer pipeline).
//! * [`devices`]: [`list_capture_devices`] for the Connection tab (GStreamer's device
//!   monitor, V4L2).
//! * [`capture`]: [`Capture`], a GStreamer source on its own threads delivering RGBA
//!   frames with their capture time into a [`FrameSlot`] (latest frame, lock-free) and
//!   other [`FrameSink`]s; stats ([`CaptureStats`]: fps, frame age, latency, drops) and
//!   state ([`CaptureState`]: NO VIDEO within 1 s of a stall, reconnect with back-off).
//! * [`simcam`]: [`SimCamera`], the simulator's forward view rendered in code from the
//!   vehicle's pose (no GStreamer, no clock); [`simrun`]: [`SimCameraRunner`], the same
//!   on a thread at 25 fps of wall time, with the interface of a capture.
//! * [`stamp`]: the capture time drawn into a frame, machine-readable and for people.
//! * [`encoder`]: [`Encoder`], RGBA → H.264 Annex B access units (x264, zero latency, no
//!   B-frames, SPS/PPS with every key frame, a key frame at least every 2 s), on its own
//!   thread behind a bounded queue.
//! * [`annexb`]: [`AccessUnit`] and the structural check of recorded units.
//! * [`decoder`]: [`Decoder`] (units → RGBA) and [`FrameSeeker`] (the frame on screen at a
//!   time, decoding forward from a key frame) for replay and the model lab.
//! * [`export`]: [`export_mp4`], MP4 by passthrough or with the telemetry burned in, plus
//!   [`subtitles`]: the `.ass` file.
//!
//! # Threads and time
//! Nothing here runs on the caller's thread for longer than a pointer swap or a bounded
//! queue's `try_send`, except the synchronous [`Decoder`]/[`FrameSeeker`] (replay) and
//! [`export_mp4`] (a command). Capture times are on the caller's clock ([`TimeSource`]),
//! so video and telemetry share one time base. [`SimCamera`] reads no clock at all.
//!
//! # How to wire (phase 2)
//! **Station runtime** (`rov_station::runtime`):
//! 1. Parse `--video` / the config's `video.source` with [`SourceSpec::parse`]; the
//!    default is `sim` on the simulator, the first of [`list_capture_devices`] with
//!    `--port`, else `none`.
//! 2. Start it with [`VideoFeed::start`]`(&spec, CaptureConfig { clock:
//!    TimeSource::new(move || session_clock_ns()), ..Default::default() }, sim,
//!    vec![encoder_sink])`: a GStreamer [`Capture`] for real sources, a
//!    [`SimCameraRunner`] for `sim` (25 fps of wall time), nothing for `none`. `sim` is a
//!    [`SimFeed`]: `SimCamera::new(scene, CameraModel::default(), false)?` and a closure
//!    that reads the latest truth (`CameraPose::from_degrees(north, east, depth, roll,
//!    pitch, heading, tilt)`) and the lights % from the station. An error from `start`
//!    (bad pipeline, missing plugin) is shown in the Connection tab and the station opens
//!    without video; everything after that is a [`CaptureState`].
//! 3. Under `--fast` (`VirtualStation`) there is no wall time: call [`SimCamera::render`]
//!    every 40 ms of virtual time and [`Encoder::push_blocking`] the frame (nothing may be
//!    dropped on virtual time).
//! 4. Publish `feed.stats()` in the `StationView` (fps, latency p99,
//!    frame age, state label) next to the link figures.
//!
//! **GUI Fly tab**: keep the `Arc<FrameSlot>`; each frame call
//! `slot.newer_than(last_seq)` and upload only a new frame into the texture
//! (`egui::ColorImage::from_rgba_unmultiplied([w, h], &frame.rgba)`); draw the HUD over it.
//! When `!state.has_video()` draw `state.label()` and the frame age.
//!
//! **Recorder**: `Encoder::start(EncoderConfig::default(), move |au| ...)` where the
//! callback hands the unit to the recorder's queue (`try_send` live, counting a drop; the
//! callback runs on GStreamer's thread and must not wait), and give the encoder to the
//! feed as a sink (it implements [`FrameSink`]).
//! Each [`AccessUnit`] becomes one `/camera/video` message (`foxglove.CompressedVideo`:
//! `timestamp` = `pts_ns`, `frame_id` = "camera", `format` = "h264", `data` = the bytes)
//! at log time `pts_ns`. On stop, [`Encoder::finish`] flushes the last units.
//!
//! **Replay / model lab**: build an [`AuStore`] over the session's `/camera/video`
//! messages (index of time and key flag, read from the bytes by
//! [`AccessUnit::from_annex_b`]; units loaded lazily; a recovered file simply has fewer) and ask [`FrameSeeker::frame_at`] for the play-head time; put the frame in a
//! [`FrameSlot`] for the same Fly view.
//!
//! **Export** (`topside export FILE.mcap --video OUT.mp4 [--overlay]`): iterate the
//! session's units into [`export_mp4`] with subtitle lines made by
//! [`subtitles::lines_from_samples`] from [`subtitles::telemetry_text`] at ≥ 1 Hz.
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::indexing_slicing,
        clippy::panic
    )
)]

pub mod annexb;
pub mod capture;
pub mod decoder;
pub mod devices;
pub mod encoder;
pub mod error;
pub mod export;
pub mod feed;
pub mod frame;
pub mod gst_util;
pub mod simcam;
pub mod simrun;
pub mod source;
pub mod stamp;
pub mod stats;
pub mod subtitles;

pub use annexb::AccessUnit;
pub use capture::{Capture, CaptureConfig, OutputSize};
pub use decoder::{AuStore, Decoder, DecoderStats, FrameSeeker, IndexEntry};
pub use devices::{CaptureDevice, list_capture_devices};
pub use encoder::{Encoder, EncoderConfig, EncoderStats, SpeedPreset};
pub use error::VideoError;
pub use export::{ExportOptions, ExportSummary, export_mp4};
pub use feed::{SimFeed, VideoFeed};
pub use frame::{FrameSink, FrameSlot, TimeSource, VideoFrame};
pub use simcam::{CameraModel, CameraPose, SimCamera, SimScene};
pub use simrun::SimCameraRunner;
pub use source::SourceSpec;
pub use stats::{CaptureState, CaptureStats};
