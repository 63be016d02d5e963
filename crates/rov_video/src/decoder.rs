//! Decoder for replay: access units → RGBA frames, and [`FrameSeeker`], which answers
//! "which frame was on screen at time t" by decoding forward from the key frame before t.
//!
//! `appsrc → h264parse → avdec_h264 (one thread: no frame delay) → videoconvert → appsink`.
//! [`Decoder::decode`] is synchronous: it pushes one access unit and waits for its picture.
//! A unit that fails the structural check ([`crate::annexb::check`]) is skipped without
//! reaching GStreamer; one the decoder rejects (corrupt slice data) yields no picture
//! (`output-corrupt=false`) and is counted after a short wait. Neither stops decoding.

use std::sync::Arc;
use std::time::{Duration, Instant};

use gstreamer as gst;
use gstreamer::prelude::*;
use gstreamer_app as gst_app;

use crate::annexb::{self, AccessUnit};
use crate::error::{Result, VideoError};
use crate::frame::VideoFrame;
use crate::gst_util;

const CONTEXT: &str = "video decoder";
const DESCRIPTION: &str = "appsrc name=src format=time is-live=false do-timestamp=false \
    caps=video/x-h264,stream-format=byte-stream,alignment=au \
    ! h264parse ! avdec_h264 max-threads=1 output-corrupt=false max-errors=-1 \
    ! videoconvert ! video/x-raw,format=RGBA ! appsink name=sink sync=false enable-last-sample=false";

/// A decoder's figures.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DecoderStats {
    /// Pictures decoded.
    pub decoded: u64,
    /// Units skipped by the structural check (truncated, garbled).
    pub malformed: u64,
    /// Units the decoder produced no picture for (corrupt data, missing references).
    pub no_picture: u64,
    /// Restarts (seeks back, or jumps ahead past a key frame).
    pub resets: u64,
}

/// A synchronous H.264 decoder; see the [module docs](self).
pub struct Decoder {
    pipeline: gst::Pipeline,
    src: gst_app::AppSrc,
    sink: gst_app::AppSink,
    picture_timeout: Duration,
    stats: DecoderStats,
    seq: u64,
}

impl std::fmt::Debug for Decoder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Decoder")
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

impl Decoder {
    /// A decoder. `picture_timeout` is how long to wait for a picture before counting a
    /// unit as undecodable (500 ms is plenty: a 640×480 picture decodes in a few ms).
    ///
    /// # Errors
    /// [`VideoError::MissingPlugin`] (avdec_h264 is in gstreamer1.0-libav, h264parse in
    /// gstreamer1.0-plugins-bad), [`VideoError::Pipeline`] if it cannot start.
    pub fn new(picture_timeout: Duration) -> Result<Self> {
        gst_util::require_elements(
            CONTEXT,
            &[
                "appsrc",
                "h264parse",
                "avdec_h264",
                "videoconvert",
                "appsink",
            ],
        )?;
        let pipeline = gst_util::parse_pipeline(CONTEXT, DESCRIPTION)?;
        let src = gst_util::by_name(CONTEXT, &pipeline, "src")?;
        let sink = gst_util::by_name(CONTEXT, &pipeline, "sink")?;
        gst_util::set_state(CONTEXT, &pipeline, gst::State::Playing)?;
        Ok(Self {
            pipeline,
            src,
            sink,
            picture_timeout,
            stats: DecoderStats::default(),
            seq: 0,
        })
    }

    /// The figures so far.
    pub fn stats(&self) -> DecoderStats {
        self.stats
    }

    /// Forgets all pictures (before decoding from another key frame).
    ///
    /// # Errors
    /// [`VideoError::Pipeline`] if the pipeline does not restart.
    pub fn reset(&mut self) -> Result<()> {
        self.stats.resets += 1;
        gst_util::set_state(CONTEXT, &self.pipeline, gst::State::Ready)?;
        gst_util::set_state(CONTEXT, &self.pipeline, gst::State::Playing)?;
        Ok(())
    }

    /// Decodes one access unit; `Ok(None)` if it gave no picture (skipped and counted).
    /// The frame's `capture_ns` is the unit's `pts_ns`.
    ///
    /// # Errors
    /// [`VideoError::Pipeline`] if the pipeline itself failed (not for bad data).
    pub fn decode(&mut self, au: &AccessUnit) -> Result<Option<VideoFrame>> {
        if annexb::check(&au.data).is_err() {
            self.stats.malformed += 1;
            return Ok(None);
        }
        let mut buffer = gst::Buffer::from_slice(au.data.clone());
        if let Some(b) = buffer.get_mut() {
            b.set_pts(gst::ClockTime::from_nseconds(au.pts_ns));
            b.set_dts(gst::ClockTime::from_nseconds(au.pts_ns));
            if !au.key_frame {
                b.set_flags(gst::BufferFlags::DELTA_UNIT);
            }
        }
        if self.src.push_buffer(buffer).is_err() {
            // The pipeline stopped (e.g. a flow error): restart it once and report.
            let reason = gst_util::bus_error_now(&self.pipeline)
                .unwrap_or_else(|| "the decoder refused data".to_owned());
            self.reset()?;
            return Err(VideoError::Pipeline {
                context: CONTEXT.to_owned(),
                reason,
            });
        }
        let deadline = Instant::now() + self.picture_timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let wait = left.min(Duration::from_millis(20));
            if let Some(sample) = self
                .sink
                .try_pull_sample(gst::ClockTime::from_nseconds(gst_util::nanos(wait)))
            {
                let Some(frame) = self.frame_of(&sample) else {
                    continue;
                };
                // A late picture of an earlier unit: keep waiting for ours.
                if frame.capture_ns < au.pts_ns {
                    continue;
                }
                self.stats.decoded += 1;
                return Ok(Some(frame));
            }
            if let Some(err) = self.decoder_complained() {
                let _ = err;
                self.stats.no_picture += 1;
                return Ok(None);
            }
            if left.is_zero() {
                self.stats.no_picture += 1;
                return Ok(None);
            }
        }
    }

    /// A warning or error from the decoder (it rejected the unit).
    fn decoder_complained(&self) -> Option<String> {
        let bus = self.pipeline.bus()?;
        let mut found = None;
        while let Some(msg) =
            bus.pop_filtered(&[gst::MessageType::Warning, gst::MessageType::Error])
        {
            match msg.view() {
                gst::MessageView::Warning(w) => found = Some(w.error().to_string()),
                gst::MessageView::Error(e) => found = Some(gst_util::describe_error(e)),
                _ => {}
            }
        }
        found
    }

    fn frame_of(&mut self, sample: &gst::Sample) -> Option<VideoFrame> {
        let pts = sample.buffer()?.pts()?.nseconds();
        let (w, h, rgba) = gst_util::rgba_of_sample(sample)?;
        let seq = self.seq;
        self.seq += 1;
        VideoFrame::new(w, h, pts, seq, rgba).ok()
    }
}

impl Drop for Decoder {
    fn drop(&mut self) {
        let _ = self.pipeline.set_state(gst::State::Null);
    }
}

/// One entry of a video index: the time and kind of an access unit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IndexEntry {
    /// Capture time, ns.
    pub pts_ns: u64,
    /// Key frame.
    pub key_frame: bool,
}

/// Recorded access units, in time order, loaded one at a time (a session of an hour is
/// too big to hold: the index is small, the units stay in the file).
pub trait AuStore {
    /// Number of units.
    fn len(&self) -> usize;
    /// `true` when empty.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Time and kind of unit `i`.
    fn entry(&self, i: usize) -> Option<IndexEntry>;
    /// Unit `i`, `None` if it cannot be read (counted as malformed by the seeker).
    fn load(&mut self, i: usize) -> Option<AccessUnit>;
}

impl AuStore for Vec<AccessUnit> {
    fn len(&self) -> usize {
        <[AccessUnit]>::len(self)
    }
    fn entry(&self, i: usize) -> Option<IndexEntry> {
        self.get(i).map(|a| IndexEntry {
            pts_ns: a.pts_ns,
            key_frame: a.key_frame,
        })
    }
    fn load(&mut self, i: usize) -> Option<AccessUnit> {
        self.get(i).cloned()
    }
}

/// The frame on screen at a time: decodes forward from the last key frame at or before
/// it, reusing the decoder's state when playing forward. See [`FrameSeeker::frame_at`].
#[derive(Debug)]
pub struct FrameSeeker {
    decoder: Decoder,
    /// Index of the last unit fed to the decoder.
    position: Option<usize>,
    /// The last picture and the unit it came from.
    last: Option<(usize, Arc<VideoFrame>)>,
}

impl FrameSeeker {
    /// A seeker with its own decoder.
    ///
    /// # Errors
    /// As [`Decoder::new`].
    pub fn new() -> Result<Self> {
        Ok(Self {
            decoder: Decoder::new(Duration::from_millis(500))?,
            position: None,
            last: None,
        })
    }

    /// The decoder's figures.
    pub fn stats(&self) -> DecoderStats {
        self.decoder.stats()
    }

    /// The frame that was on screen at `t_ns`: the picture of the last unit with
    /// `pts_ns ≤ t_ns` (or, if that unit is corrupt, the last good picture before it).
    /// `None` before the first unit or when nothing decodes.
    ///
    /// Cost: playing forward decodes only the new units; a seek back, or forward past a
    /// later key frame, restarts at the key frame (at most 2 s of units with our
    /// encoder).
    ///
    /// # Errors
    /// [`VideoError::Pipeline`] if the decoder pipeline fails.
    pub fn frame_at(
        &mut self,
        store: &mut dyn AuStore,
        t_ns: u64,
    ) -> Result<Option<Arc<VideoFrame>>> {
        let n = store.len();
        // Last unit at or before t (binary search on the index).
        let (mut lo, mut hi) = (0usize, n);
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            match store.entry(mid) {
                Some(e) if e.pts_ns <= t_ns => lo = mid + 1,
                _ => hi = mid,
            }
        }
        let Some(target) = lo.checked_sub(1) else {
            return Ok(None);
        };
        if self.position == Some(target) {
            return Ok(self.last.as_ref().map(|(_, f)| Arc::clone(f)));
        }
        let key = (0..=target)
            .rev()
            .find(|&i| store.entry(i).is_some_and(|e| e.key_frame));
        let Some(key) = key else {
            return Ok(None); // nothing decodable before t
        };
        let start = match self.position {
            Some(p) if p < target && p >= key => p + 1,
            _ => {
                if self.position.is_some() {
                    self.decoder.reset()?;
                }
                self.last = None;
                key
            }
        };
        for i in start..=target {
            self.position = Some(i);
            let Some(au) = store.load(i) else {
                self.decoder.stats.malformed += 1;
                continue;
            };
            if let Some(frame) = self.decoder.decode(&au)? {
                self.last = Some((i, Arc::new(frame)));
            }
        }
        Ok(self.last.as_ref().map(|(_, f)| Arc::clone(f)))
    }
}
