//! Frames and where they go: [`VideoFrame`] (RGBA pixels with the capture time), the
//! [`FrameSink`] trait every consumer implements, the lock-free [`FrameSlot`] that holds
//! the latest frame for the screen, and [`TimeSource`], the caller's clock.

use std::fmt;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use arc_swap::ArcSwapOption;

use crate::error::{Result, VideoError};

/// One video frame: tightly packed RGBA (4 bytes per pixel, rows top to bottom, no
/// padding) and its capture time on the caller's clock ([`TimeSource`]).
#[derive(Clone, PartialEq, Eq)]
pub struct VideoFrame {
    /// Width, px.
    pub width_px: u32,
    /// Height, px.
    pub height_px: u32,
    /// Capture time, ns on the caller's clock.
    pub capture_ns: u64,
    /// Sequence number from the producer (counts from 0; gaps mean frames not delivered).
    pub seq: u64,
    /// RGBA pixels, `width_px * height_px * 4` bytes.
    pub rgba: Vec<u8>,
}

impl fmt::Debug for VideoFrame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("VideoFrame")
            .field("width_px", &self.width_px)
            .field("height_px", &self.height_px)
            .field("capture_ns", &self.capture_ns)
            .field("seq", &self.seq)
            .field("rgba_bytes", &self.rgba.len())
            .finish()
    }
}

impl VideoFrame {
    /// A frame from its parts, checking the buffer size.
    ///
    /// # Errors
    /// [`VideoError::FrameSize`] if `rgba.len() != width × height × 4` or a side is 0.
    pub fn new(
        width_px: u32,
        height_px: u32,
        capture_ns: u64,
        seq: u64,
        rgba: Vec<u8>,
    ) -> Result<Self> {
        let expected = rgba_len(width_px, height_px);
        if expected == 0 || rgba.len() != expected {
            return Err(VideoError::FrameSize {
                width_px,
                height_px,
                len_bytes: rgba.len(),
                expected_bytes: expected,
            });
        }
        Ok(Self {
            width_px,
            height_px,
            capture_ns,
            seq,
            rgba,
        })
    }

    /// A black frame.
    pub fn black(width_px: u32, height_px: u32, capture_ns: u64) -> Self {
        let rgba = [0u8, 0, 0, 255].repeat(width_px as usize * height_px as usize);
        Self {
            width_px,
            height_px,
            capture_ns,
            seq: 0,
            rgba,
        }
    }

    /// The RGBA value at (x, y), `None` outside the frame.
    pub fn pixel(&self, x_px: u32, y_px: u32) -> Option<[u8; 4]> {
        if x_px >= self.width_px || y_px >= self.height_px {
            return None;
        }
        let i = (y_px as usize * self.width_px as usize + x_px as usize) * 4;
        let p = self.rgba.get(i..i + 4)?;
        Some([
            p.first().copied()?,
            p.get(1).copied()?,
            p.get(2).copied()?,
            p.get(3).copied()?,
        ])
    }

    /// Mean absolute difference of the RGB channels against another frame of the same
    /// size (0..255), `None` if the sizes differ. Used to tell whether the picture moved.
    pub fn mean_abs_diff(&self, other: &Self) -> Option<f64> {
        if self.width_px != other.width_px || self.height_px != other.height_px {
            return None;
        }
        let mut sum = 0u64;
        for (a, b) in self.rgba.chunks_exact(4).zip(other.rgba.chunks_exact(4)) {
            for (x, y) in a.iter().zip(b.iter()).take(3) {
                sum += u64::from(x.abs_diff(*y));
            }
        }
        let n = (self.width_px as u64 * self.height_px as u64 * 3).max(1);
        Some(sum as f64 / n as f64)
    }
}

/// Bytes of a tightly packed RGBA frame.
pub fn rgba_len(width_px: u32, height_px: u32) -> usize {
    width_px as usize * height_px as usize * 4
}

/// A consumer of frames. `push` is called on the producer's thread for every frame and
/// must return at once (store, or hand to a bounded queue and count a drop).
pub trait FrameSink: Send + Sync {
    /// Takes one frame.
    fn push(&self, frame: Arc<VideoFrame>);
}

/// The latest frame, for the screen: the producer replaces it, the consumer reads it;
/// neither ever waits (an atomic pointer swap). Frames replaced before anyone read them
/// are counted as superseded (the display dropped them, the recorder did not).
#[derive(Default)]
pub struct FrameSlot {
    latest: ArcSwapOption<VideoFrame>,
    stored: AtomicU64,
    taken_seq: AtomicU64,
    superseded: AtomicU64,
}

impl fmt::Debug for FrameSlot {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("FrameSlot")
            .field("stored", &self.stored.load(Ordering::Relaxed))
            .field("superseded", &self.superseded.load(Ordering::Relaxed))
            .finish()
    }
}

impl FrameSlot {
    /// An empty slot.
    pub fn new() -> Arc<Self> {
        Arc::new(Self::default())
    }

    /// Stores a frame (never waits).
    pub fn store(&self, frame: Arc<VideoFrame>) {
        let n = self.stored.fetch_add(1, Ordering::AcqRel) + 1;
        // `taken_seq` holds the store count at the last read; anything stored since then
        // and now replaced was never seen.
        let taken = self.taken_seq.load(Ordering::Acquire);
        if n >= 2 && taken < n - 1 {
            self.superseded.fetch_add(1, Ordering::Relaxed);
        }
        self.latest.store(Some(frame));
    }

    /// The latest frame, if any (never waits). Reading twice gives the same frame.
    pub fn latest(&self) -> Option<Arc<VideoFrame>> {
        let f = self.latest.load_full();
        self.taken_seq
            .fetch_max(self.stored.load(Ordering::Acquire), Ordering::AcqRel);
        f
    }

    /// The latest frame only if it is newer than `seq_after` (by its `seq`), so a
    /// renderer uploads each frame once.
    pub fn newer_than(&self, seq_after: Option<u64>) -> Option<Arc<VideoFrame>> {
        let f = self.latest()?;
        match seq_after {
            Some(s) if f.seq <= s => None,
            _ => Some(f),
        }
    }

    /// Empties the slot (e.g. when the source changes).
    pub fn clear(&self) {
        self.latest.store(None);
    }

    /// Frames stored so far.
    pub fn stored(&self) -> u64 {
        self.stored.load(Ordering::Relaxed)
    }

    /// Frames replaced before any reader saw them.
    pub fn superseded(&self) -> u64 {
        self.superseded.load(Ordering::Relaxed)
    }
}

impl FrameSink for FrameSlot {
    fn push(&self, frame: Arc<VideoFrame>) {
        self.store(frame);
    }
}

/// The caller's clock in nanoseconds: capture times, frame ages and latencies are on it.
/// The station passes its session clock so frames and telemetry share one time base.
#[derive(Clone)]
pub struct TimeSource(Arc<dyn Fn() -> u64 + Send + Sync>);

impl fmt::Debug for TimeSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "TimeSource(now = {} ns)", self.now_ns())
    }
}

impl TimeSource {
    /// A clock from a function returning ns (must be monotonic).
    pub fn new(now_ns: impl Fn() -> u64 + Send + Sync + 'static) -> Self {
        Self(Arc::new(now_ns))
    }

    /// A monotonic clock counting from now.
    pub fn monotonic() -> Self {
        let t0 = Instant::now();
        Self::new(move || crate::gst_util::nanos(t0.elapsed()))
    }

    /// The current time, ns.
    pub fn now_ns(&self) -> u64 {
        (self.0)()
    }
}

impl Default for TimeSource {
    fn default() -> Self {
        Self::monotonic()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(seq: u64) -> Arc<VideoFrame> {
        let mut f = VideoFrame::black(4, 2, seq * 40_000_000);
        f.seq = seq;
        Arc::new(f)
    }

    #[test]
    fn new_checks_the_buffer() {
        let e = VideoFrame::new(4, 2, 0, 0, vec![0; 31])
            .unwrap_err()
            .to_string();
        assert!(e.contains("31 bytes, expected 32"), "{e}");
        assert!(VideoFrame::new(0, 2, 0, 0, vec![]).is_err());
        assert!(VideoFrame::new(4, 2, 0, 0, vec![0; 32]).is_ok());
    }

    #[test]
    fn slot_counts_superseded_frames() {
        let slot = FrameSlot::new();
        assert!(slot.latest().is_none());
        slot.store(frame(0));
        assert_eq!(slot.latest().unwrap().seq, 0);
        slot.store(frame(1)); // 0 was seen: not superseded
        slot.store(frame(2)); // 1 never seen
        slot.store(frame(3)); // 2 never seen
        assert_eq!(slot.superseded(), 2);
        assert_eq!(slot.latest().unwrap().seq, 3);
        assert!(slot.newer_than(Some(3)).is_none());
        assert_eq!(slot.newer_than(Some(2)).unwrap().seq, 3);
        assert_eq!(slot.stored(), 4);
    }

    #[test]
    fn pixel_and_difference() {
        let a = VideoFrame::black(4, 2, 0);
        let mut b = a.clone();
        b.rgba[0] = 255;
        assert_eq!(a.pixel(0, 0), Some([0, 0, 0, 255]));
        assert_eq!(b.pixel(0, 0), Some([255, 0, 0, 255]));
        assert_eq!(a.pixel(4, 0), None);
        let d = a.mean_abs_diff(&b).unwrap();
        assert!((d - 255.0 / 24.0).abs() < 1e-9);
        assert!(a.mean_abs_diff(&VideoFrame::black(2, 2, 0)).is_none());
    }
}
