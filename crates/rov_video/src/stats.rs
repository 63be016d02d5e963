//! Capture statistics: frame rate over the last second, capture-to-delivery latency
//! (last, median and 99th percentile of the last 256 frames), frames missed by the source
//! (gaps in its timestamps), and the state shown to the pilot.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

/// What a capture is doing. Only [`CaptureState::Running`] has a picture; every other
/// state is shown as NO VIDEO with its reason and the last frame's age.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CaptureState {
    /// The first attempt: the pipeline is starting, no frame yet.
    Starting,
    /// Frames are arriving.
    Running,
    /// The source was lost (stalled, ended, failed, unplugged); a retry follows after the
    /// back-off.
    NoVideo {
        /// Why, for the pilot.
        reason: String,
    },
    /// Retrying after a loss: the pipeline is rebuilt and waits for frames.
    Reconnecting {
        /// Retry number (1 = first retry).
        attempt: u32,
        /// The loss that caused it.
        reason: String,
    },
    /// Will not retry: bad pipeline, missing plugin or codec. The reason names it.
    Failed {
        /// Why.
        reason: String,
    },
    /// Stopped by the caller.
    Stopped,
}

impl CaptureState {
    /// `true` only while frames arrive.
    pub fn has_video(&self) -> bool {
        matches!(self, Self::Running)
    }

    /// A short text for the pilot: `VIDEO`, `STARTING`, `NO VIDEO: reason`, …
    pub fn label(&self) -> String {
        match self {
            Self::Starting => "STARTING VIDEO".to_owned(),
            Self::Running => "VIDEO".to_owned(),
            Self::NoVideo { reason } => format!("NO VIDEO: {reason}"),
            Self::Reconnecting { attempt, reason } => {
                format!("NO VIDEO: {reason} (reconnecting, attempt {attempt})")
            }
            Self::Failed { reason } => format!("NO VIDEO: {reason}"),
            Self::Stopped => "VIDEO OFF".to_owned(),
        }
    }
}

/// A snapshot of a capture's figures.
#[derive(Debug, Clone, PartialEq)]
pub struct CaptureStats {
    /// The state.
    pub state: CaptureState,
    /// Frames delivered since the start.
    pub frames: u64,
    /// Frames delivered in the last second (0 when stalled).
    pub fps: f64,
    /// Size of the last frame, px.
    pub frame_size_px: Option<(u32, u32)>,
    /// Capture time of the last frame, ns on the caller's clock.
    pub last_capture_ns: Option<u64>,
    /// Age of the last frame now, ms (what NO VIDEO shows).
    pub frame_age_ms: Option<f64>,
    /// Capture-to-delivery latency of the last frame, ms.
    pub latency_last_ms: Option<f64>,
    /// Median latency of the last 256 frames, ms.
    pub latency_p50_ms: Option<f64>,
    /// 99th percentile latency of the last 256 frames, ms.
    pub latency_p99_ms: Option<f64>,
    /// Median latency added by the station's path (the source's raw frame entering
    /// conversion → the slot), last 256 frames, ms.
    pub path_latency_p50_ms: Option<f64>,
    /// 99th percentile of the same, ms.
    pub path_latency_p99_ms: Option<f64>,
    /// Frames the source skipped (gaps in its timestamps longer than 1.5 frame periods).
    pub frames_missed: u64,
    /// Frames replaced in the latest-frame slot before the screen read them.
    pub frames_superseded: u64,
    /// Retries after losses.
    pub reconnects: u32,
    /// The last warning GStreamer posted, if any.
    pub last_warning: Option<String>,
}

const LATENCY_WINDOW: usize = 256;

/// Rolling figures, updated on the streaming thread under a short lock.
#[derive(Debug)]
pub(crate) struct Rolling {
    pub frames: u64,
    deliveries: VecDeque<Instant>,
    latencies_ms: VecDeque<f64>,
    path_ms: VecDeque<f64>,
    pub last_delivery: Option<Instant>,
    pub last_capture_ns: Option<u64>,
    pub frame_size_px: Option<(u32, u32)>,
    last_pts_ns: Option<u64>,
    pub frames_missed: u64,
    pub last_warning: Option<String>,
}

impl Rolling {
    pub fn new() -> Self {
        Self {
            frames: 0,
            deliveries: VecDeque::with_capacity(128),
            latencies_ms: VecDeque::with_capacity(LATENCY_WINDOW),
            path_ms: VecDeque::with_capacity(LATENCY_WINDOW),
            last_delivery: None,
            last_capture_ns: None,
            frame_size_px: None,
            last_pts_ns: None,
            frames_missed: 0,
            last_warning: None,
        }
    }

    /// Forgets the timestamp history (a new pipeline restarts its clock).
    pub fn new_stream(&mut self) {
        self.last_pts_ns = None;
    }

    /// Records one delivered frame.
    pub fn record(
        &mut self,
        now: Instant,
        capture_ns: u64,
        latency_ms: f64,
        size_px: (u32, u32),
        pts_ns: Option<u64>,
        period_ns: Option<u64>,
    ) {
        self.frames += 1;
        self.last_delivery = Some(now);
        self.last_capture_ns = Some(capture_ns);
        self.frame_size_px = Some(size_px);
        self.deliveries.push_back(now);
        while self
            .deliveries
            .front()
            .is_some_and(|t| now.duration_since(*t) > Duration::from_secs(1))
        {
            self.deliveries.pop_front();
        }
        if self.latencies_ms.len() == LATENCY_WINDOW {
            self.latencies_ms.pop_front();
        }
        self.latencies_ms.push_back(latency_ms);
        if let (Some(pts), Some(period)) = (pts_ns, period_ns.filter(|p| *p > 0)) {
            if let Some(last) = self.last_pts_ns
                && pts > last
            {
                let gap = pts - last;
                if gap * 2 > period * 3 {
                    let periods = (gap + period / 2) / period;
                    self.frames_missed += periods.saturating_sub(1);
                }
            }
            self.last_pts_ns = Some(pts);
        }
    }

    pub fn fps(&self, now: Instant) -> f64 {
        self.deliveries
            .iter()
            .filter(|t| now.duration_since(**t) <= Duration::from_secs(1))
            .count() as f64
    }

    /// Records the latency the station's path added to the last frame.
    pub fn record_path(&mut self, ms: f64) {
        if self.path_ms.len() == LATENCY_WINDOW {
            self.path_ms.pop_front();
        }
        self.path_ms.push_back(ms);
    }

    pub fn latency(&self) -> (Option<f64>, Option<f64>, Option<f64>) {
        let last = self.latencies_ms.back().copied();
        let (p50, p99) = quantiles(&self.latencies_ms);
        (last, p50, p99)
    }

    pub fn path_latency(&self) -> (Option<f64>, Option<f64>) {
        quantiles(&self.path_ms)
    }
}

fn quantiles(window: &VecDeque<f64>) -> (Option<f64>, Option<f64>) {
    let mut v: Vec<f64> = window.iter().copied().collect();
    v.sort_by(f64::total_cmp);
    (percentile(&v, 0.5), percentile(&v, 0.99))
}

/// A [`CaptureStats`] from the rolling figures (`now_ns` on the caller's clock).
pub(crate) fn snapshot(
    state: CaptureState,
    r: &Rolling,
    now_ns: u64,
    frames_superseded: u64,
    reconnects: u32,
) -> CaptureStats {
    let (latency_last_ms, latency_p50_ms, latency_p99_ms) = r.latency();
    let (path_latency_p50_ms, path_latency_p99_ms) = r.path_latency();
    CaptureStats {
        state,
        frames: r.frames,
        fps: r.fps(Instant::now()),
        frame_size_px: r.frame_size_px,
        last_capture_ns: r.last_capture_ns,
        frame_age_ms: r
            .last_capture_ns
            .map(|t| now_ns.saturating_sub(t) as f64 * 1e-6),
        latency_last_ms,
        latency_p50_ms,
        latency_p99_ms,
        path_latency_p50_ms,
        path_latency_p99_ms,
        frames_missed: r.frames_missed,
        frames_superseded,
        reconnects,
        last_warning: r.last_warning.clone(),
    }
}

/// The p-quantile of sorted values (nearest rank).
pub fn percentile(sorted: &[f64], p: f64) -> Option<f64> {
    if sorted.is_empty() {
        return None;
    }
    let rank = ((p.clamp(0.0, 1.0) * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len());
    sorted.get(rank - 1).copied()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaps_count_missed_frames() {
        let mut r = Rolling::new();
        let t0 = Instant::now();
        let p = 40_000_000;
        for (i, k) in [0u64, 1, 2, 5, 6, 8].iter().enumerate() {
            r.record(
                t0 + Duration::from_millis(40 * i as u64),
                0,
                1.0,
                (640, 480),
                Some(k * p),
                Some(p),
            );
        }
        // 2 → 5 misses 3 and 4; 6 → 8 misses 7.
        assert_eq!(r.frames_missed, 3);
        assert_eq!(r.frames, 6);
        assert_eq!(r.fps(t0 + Duration::from_millis(200)), 6.0);
        assert_eq!(r.fps(t0 + Duration::from_secs(3)), 0.0);
    }

    #[test]
    fn percentiles() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        assert_eq!(percentile(&v, 0.99), Some(99.0));
        assert_eq!(percentile(&v, 0.5), Some(50.0));
        assert_eq!(percentile(&[], 0.5), None);
        let mut r = Rolling::new();
        for i in 0..300 {
            r.record(Instant::now(), 0, f64::from(i), (1, 1), None, None);
        }
        let (last, p50, p99) = r.latency();
        assert_eq!(last, Some(299.0));
        // Only the last 256 (44..=299) count.
        assert_eq!(p50, Some(171.0));
        assert_eq!(p99, Some(297.0));
    }

    #[test]
    fn labels() {
        assert!(CaptureState::Running.has_video());
        assert!(!CaptureState::Starting.has_video());
        let s = CaptureState::Reconnecting {
            attempt: 2,
            reason: "stalled".into(),
        };
        assert_eq!(s.label(), "NO VIDEO: stalled (reconnecting, attempt 2)");
    }
}
