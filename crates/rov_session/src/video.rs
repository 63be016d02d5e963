//! Reading camera video: the frames of a time range, in time order, and the key frame a
//! decoder starts from to show the picture at a time.
//!
//! A `/camera/video` message that does not decode as a `foxglove.CompressedVideo` with
//! H.264 Annex B data is skipped and counted ([`VideoStats`]); the stream goes on. A
//! damaged chunk ends the read as any read ([`crate::stream`]).

use crate::foxglove::{VideoFrame, decode_video};
use crate::record::Topic;
use crate::session::Session;
use crate::stream::{Messages, ReadOptions};

/// What a video read returned and skipped.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct VideoStats {
    /// Frames returned.
    pub frames: u64,
    /// Key frames among them.
    pub key_frames: u64,
    /// Messages skipped because they do not decode.
    pub skipped: u64,
    /// Why the first skipped message was skipped.
    pub first_error: Option<String>,
}

/// Video frames in time order; corrupted messages skipped and counted.
#[derive(Debug)]
pub struct VideoFrames {
    messages: Messages,
    stats: VideoStats,
}

impl VideoFrames {
    /// What was returned and skipped so far.
    pub fn stats(&self) -> &VideoStats {
        &self.stats
    }

    /// The underlying read (its damage and report).
    pub fn messages(&self) -> &Messages {
        &self.messages
    }
}

impl Iterator for VideoFrames {
    type Item = VideoFrame;

    fn next(&mut self) -> Option<VideoFrame> {
        loop {
            let m = self.messages.next()?;
            match decode_video(m.t_ns, m.data()) {
                Ok(f) => {
                    self.stats.frames += 1;
                    self.stats.key_frames += u64::from(f.key_frame);
                    return Some(f);
                }
                Err(e) => {
                    self.stats.skipped += 1;
                    if self.stats.first_error.is_none() {
                        self.stats.first_error =
                            Some(format!("{} at t = {} ns: {e}", Topic::Video.name(), m.t_ns));
                    }
                }
            }
        }
    }
}

impl Session {
    /// The video frames with `start_ns <= t <= end_ns`, in time order.
    pub fn video(&self, start_ns: u64, end_ns: u64) -> VideoFrames {
        VideoFrames {
            messages: self
                .read(ReadOptions::topics(&[Topic::Video.name()]).between(start_ns, end_ns)),
            stats: VideoStats::default(),
        }
    }

    /// The last key frame at or before `t_ns` (a decoder starts there to show the picture
    /// at `t_ns`); reads backwards only as far as it has to.
    pub fn video_key_frame_at_or_before(&self, t_ns: u64) -> Option<VideoFrame> {
        let m = self.last_where(Topic::Video.name(), t_ns.saturating_add(1), |m| {
            decode_video(m.t_ns, m.data()).is_ok_and(|f| f.key_frame)
        })?;
        decode_video(m.t_ns, m.data()).ok()
    }

    /// The frames a decoder needs to show the picture at `t_ns`: from the key frame at or
    /// before it through `t_ns`, then on to `end_ns`.
    pub fn video_from_key_frame(&self, t_ns: u64, end_ns: u64) -> VideoFrames {
        let start = self
            .video_key_frame_at_or_before(t_ns)
            .map_or(t_ns, |k| k.t_ns);
        self.video(start, end_ns)
    }
}
