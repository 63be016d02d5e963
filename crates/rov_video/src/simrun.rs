//! [`SimCameraRunner`]: the simulator's camera on its own thread at a fixed rate of wall
//! time, delivering into the same [`FrameSlot`] and [`FrameSink`]s as a real capture and
//! reporting the same [`CaptureStats`]. For virtual time, call
//! [`SimCamera::render`](crate::simcam::SimCamera::render) directly instead.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crate::error::{Result, VideoError};
use crate::frame::{FrameSink, FrameSlot, TimeSource, VideoFrame};
use crate::simcam::{CameraPose, SimCamera};
use crate::stats::{CaptureState, CaptureStats, Rolling, snapshot};

/// The pose and lights (%) to render, or `None` while the simulator has no pose yet.
pub type PoseFn = dyn Fn() -> Option<(CameraPose, f64)> + Send + 'static;

struct Shared {
    slot: Arc<FrameSlot>,
    rolling: Mutex<Rolling>,
    state: Mutex<CaptureState>,
    stop: AtomicBool,
    clock: TimeSource,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// The simulator's camera running at a fixed rate; see the [module docs](self).
pub struct SimCameraRunner {
    shared: Arc<Shared>,
    thread: Option<JoinHandle<()>>,
}

impl std::fmt::Debug for SimCameraRunner {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SimCameraRunner")
            .field("state", &*lock(&self.shared.state))
            .finish_non_exhaustive()
    }
}

impl SimCameraRunner {
    /// Starts rendering `fps` frames per second (1..=60) of wall time. Each frame's capture
    /// time is `clock` at the start of its rendering.
    ///
    /// # Errors
    /// [`VideoError::InvalidConfig`] for a rate out of range, [`VideoError::Pipeline`] if
    /// the thread cannot start.
    pub fn start(
        camera: SimCamera,
        fps: u32,
        clock: TimeSource,
        pose: Box<PoseFn>,
        sinks: Vec<Arc<dyn FrameSink>>,
    ) -> Result<Self> {
        if !(1..=60).contains(&fps) {
            return Err(VideoError::InvalidConfig {
                field: "sim camera fps",
                value: fps.to_string(),
                allowed: "1..=60 frames/s",
            });
        }
        let shared = Arc::new(Shared {
            slot: FrameSlot::new(),
            rolling: Mutex::new(Rolling::new()),
            state: Mutex::new(CaptureState::Starting),
            stop: AtomicBool::new(false),
            clock,
        });
        let s = Arc::clone(&shared);
        let thread = std::thread::Builder::new()
            .name("rov-video-simcam".to_owned())
            .spawn(move || run(&s, &camera, fps, pose.as_ref(), &sinks))
            .map_err(|e| VideoError::Pipeline {
                context: "simulator camera".to_owned(),
                reason: format!("cannot start its thread: {e}"),
            })?;
        Ok(Self {
            shared,
            thread: Some(thread),
        })
    }

    /// The latest-frame slot.
    pub fn slot(&self) -> Arc<FrameSlot> {
        Arc::clone(&self.shared.slot)
    }

    /// The latest frame.
    pub fn latest(&self) -> Option<Arc<VideoFrame>> {
        self.shared.slot.latest()
    }

    /// The figures now (latency = rendering time).
    pub fn stats(&self) -> CaptureStats {
        let state = lock(&self.shared.state).clone();
        let now = self.shared.clock.now_ns();
        let r = lock(&self.shared.rolling);
        snapshot(state, &r, now, self.shared.slot.superseded(), 0)
    }

    /// Stops and joins the thread (it stops within one frame period).
    pub fn stop(mut self) {
        self.shutdown();
    }

    fn shutdown(&mut self) {
        self.shared.stop.store(true, Ordering::Release);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        *lock(&self.shared.state) = CaptureState::Stopped;
    }
}

impl Drop for SimCameraRunner {
    fn drop(&mut self) {
        self.shutdown();
    }
}

fn run(shared: &Shared, camera: &SimCamera, fps: u32, pose: &PoseFn, sinks: &[Arc<dyn FrameSink>]) {
    let period = Duration::from_secs(1) / fps;
    let period_ns = u64::try_from(period.as_nanos()).unwrap_or(u64::MAX);
    let mut next = Instant::now();
    let mut seq = 0u64;
    let mut tick = 0u64;
    while !shared.stop.load(Ordering::Acquire) {
        let now = Instant::now();
        if now < next {
            std::thread::sleep((next - now).min(Duration::from_millis(50)));
            continue;
        }
        // Ticks missed while rendering or descheduled are skipped, not caught up.
        let late = u64::try_from((now - next).as_nanos() / period.as_nanos().max(1)).unwrap_or(0);
        next += period * u32::try_from(late + 1).unwrap_or(1);
        tick += late + 1;
        let Some((p, lights_pct)) = pose() else {
            *lock(&shared.state) = CaptureState::NoVideo {
                reason: "the simulator has no pose yet".to_owned(),
            };
            continue;
        };
        let t_ns = shared.clock.now_ns();
        let started = Instant::now();
        let frame = Arc::new(camera.render(&p, lights_pct, t_ns, seq));
        seq += 1;
        let render_ms = started.elapsed().as_secs_f64() * 1e3;
        {
            let mut r = lock(&shared.rolling);
            r.record(
                Instant::now(),
                t_ns,
                render_ms,
                (frame.width_px, frame.height_px),
                Some(tick * period_ns),
                Some(period_ns),
            );
        }
        shared.slot.store(Arc::clone(&frame));
        for s in sinks {
            s.push(Arc::clone(&frame));
        }
        let mut st = lock(&shared.state);
        if !st.has_video() {
            *st = CaptureState::Running;
        }
    }
}
