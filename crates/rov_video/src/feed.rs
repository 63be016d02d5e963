//! [`VideoFeed`]: one handle for whatever `--video` names, so the station wires a single
//! type: a GStreamer [`Capture`], the simulator's camera ([`SimCameraRunner`]), or nothing.
//! All three give the same slot, stats and state.

use std::sync::Arc;

use crate::capture::{Capture, CaptureConfig};
use crate::error::{Result, VideoError};
use crate::frame::{FrameSink, FrameSlot, VideoFrame};
use crate::simcam::SimCamera;
use crate::simrun::{PoseFn, SimCameraRunner};
use crate::source::SourceSpec;
use crate::stats::{CaptureState, CaptureStats};

/// The simulator's side of a `sim` feed: the renderer, its rate and where the pose comes
/// from.
pub struct SimFeed {
    /// The renderer.
    pub camera: SimCamera,
    /// Frames per second of wall time (25 for the station).
    pub fps: u32,
    /// The pose and lights to render.
    pub pose: Box<PoseFn>,
}

impl std::fmt::Debug for SimFeed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SimFeed")
            .field("fps", &self.fps)
            .finish_non_exhaustive()
    }
}

/// A running video source of any kind.
#[derive(Debug)]
pub enum VideoFeed {
    /// `none`.
    Off,
    /// A GStreamer source.
    Camera(Capture),
    /// The simulator's camera.
    Sim(SimCameraRunner),
}

impl VideoFeed {
    /// Starts the source a spec names. `sim` needs `sim` (the simulated vehicle's pose);
    /// the other sources ignore it. Frames go to the feed's slot and to `sinks` (e.g. the
    /// recording encoder).
    ///
    /// # Errors
    /// As [`Capture::start`] and [`SimCameraRunner::start`];
    /// [`VideoError::BadSourceSpec`] for `sim` without a simulated vehicle.
    pub fn start(
        spec: &SourceSpec,
        config: CaptureConfig,
        sim: Option<SimFeed>,
        sinks: Vec<Arc<dyn FrameSink>>,
    ) -> Result<Self> {
        match spec {
            SourceSpec::None => Ok(Self::Off),
            SourceSpec::Sim => {
                let s = sim.ok_or_else(|| VideoError::BadSourceSpec {
                    spec: spec.to_string(),
                    reason: "the simulator's camera needs the simulated vehicle (use test, a device or a URI with a real vehicle)".to_owned(),
                })?;
                Ok(Self::Sim(SimCameraRunner::start(
                    s.camera,
                    s.fps,
                    config.clock,
                    s.pose,
                    sinks,
                )?))
            }
            _ => Ok(Self::Camera(Capture::start(spec, config, sinks)?)),
        }
    }

    /// The latest-frame slot (`None` when off).
    pub fn slot(&self) -> Option<Arc<FrameSlot>> {
        match self {
            Self::Off => None,
            Self::Camera(c) => Some(c.slot()),
            Self::Sim(s) => Some(s.slot()),
        }
    }

    /// The latest frame.
    pub fn latest(&self) -> Option<Arc<VideoFrame>> {
        self.slot().and_then(|s| s.latest())
    }

    /// The figures (`state` is [`CaptureState::Stopped`] when off).
    pub fn stats(&self) -> CaptureStats {
        match self {
            Self::Off => CaptureStats {
                state: CaptureState::Stopped,
                frames: 0,
                fps: 0.0,
                frame_size_px: None,
                last_capture_ns: None,
                frame_age_ms: None,
                latency_last_ms: None,
                latency_p50_ms: None,
                latency_p99_ms: None,
                path_latency_p50_ms: None,
                path_latency_p99_ms: None,
                frames_missed: 0,
                frames_superseded: 0,
                reconnects: 0,
                last_warning: None,
            },
            Self::Camera(c) => c.stats(),
            Self::Sim(s) => s.stats(),
        }
    }

    /// Stops the source.
    pub fn stop(self) {
        match self {
            Self::Off => {}
            Self::Camera(c) => c.stop(),
            Self::Sim(s) => s.stop(),
        }
    }
}
