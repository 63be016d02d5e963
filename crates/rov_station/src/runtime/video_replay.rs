//! The recorded video of a session at a time: [`SessionVideo`] (the frame on screen at
//! `t`, decoded from the last key frame with `rov_video::FrameSeeker`) and
//! [`ReplayVideo`], the same on a worker thread following the replay's play-head.
//!
//! A session of hours holds far too much video to load: only one group of pictures (a
//! key frame and the units up to the next, at most 2 s with the station's encoder) is in
//! memory at a time, read through `rov_session`'s streaming video API. Playing forward
//! inside the group decodes only the new units; leaving it (playing on, or a seek) loads
//! the group of the new time.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use rov_session::Session;
use rov_video::{
    AccessUnit, CaptureState, CaptureStats, FrameSeeker, FrameSlot, VideoError, VideoFeed,
    VideoFrame,
};

use crate::runtime::lock;

/// Units read at most for one group (a broken encoder without key frames must not fill
/// the memory): 30 s at 25 fps.
const MAX_GROUP_UNITS: usize = 750;

struct Group {
    key_ns: u64,
    /// Time of the next key frame (exclusive end), `u64::MAX` at the end of the video.
    end_ns: u64,
    units: Vec<AccessUnit>,
    seeker: FrameSeeker,
}

/// The frame on screen at a time of a recorded session; see the [module docs](self).
pub struct SessionVideo {
    session: Session,
    group: Option<Group>,
    /// Units read so far.
    pub units_read: u64,
    /// Groups loaded so far (seeks and group changes).
    pub groups_loaded: u64,
}

impl std::fmt::Debug for SessionVideo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SessionVideo")
            .field("units_read", &self.units_read)
            .field("groups_loaded", &self.groups_loaded)
            .finish_non_exhaustive()
    }
}

impl SessionVideo {
    /// The video of `session`, or `None` if it holds none.
    #[must_use]
    pub fn new(session: Session) -> Option<Self> {
        session.video(0, u64::MAX).next()?;
        Some(Self {
            session,
            group: None,
            units_read: 0,
            groups_loaded: 0,
        })
    }

    /// The frame that was on screen at `t_ns` (session time): the picture of the last
    /// unit at or before it. `None` before the first key frame.
    ///
    /// # Errors
    /// The decoder's error (GStreamer's avdec_h264 missing or failing).
    pub fn frame_at(&mut self, t_ns: u64) -> Result<Option<Arc<VideoFrame>>, VideoError> {
        let inside = self
            .group
            .as_ref()
            .is_some_and(|g| g.key_ns <= t_ns && t_ns < g.end_ns);
        if !inside {
            let Some(key) = self.session.video_key_frame_at_or_before(t_ns) else {
                return Ok(None);
            };
            let mut units = Vec::new();
            let mut end_ns = u64::MAX;
            for f in self.session.video(key.t_ns, u64::MAX) {
                if f.key_frame && f.t_ns > key.t_ns {
                    end_ns = f.t_ns;
                    break;
                }
                units.push(AccessUnit::from_annex_b(f.t_ns, f.data.to_vec()));
                if units.len() >= MAX_GROUP_UNITS {
                    end_ns = f.t_ns.saturating_add(1);
                    break;
                }
            }
            self.units_read += units.len() as u64;
            self.groups_loaded += 1;
            // A new seeker per group: its unit indices belong to its store.
            self.group = Some(Group {
                key_ns: key.t_ns,
                end_ns,
                units,
                seeker: FrameSeeker::new()?,
            });
        }
        match self.group.as_mut() {
            Some(g) => g.seeker.frame_at(&mut g.units, t_ns),
            None => Ok(None),
        }
    }
}

#[derive(Default)]
struct Request {
    t_ns: Option<u64>,
    stop: bool,
}

struct Inner {
    request: Mutex<Request>,
    wake: Condvar,
    slot: Arc<FrameSlot>,
    state: Mutex<(CaptureState, u64, Option<u64>)>,
    busy: AtomicBool,
}

/// [`SessionVideo`] on a worker: the replay asks for the play-head's time
/// ([`ReplayVideo::request`], never waiting), the worker decodes the latest request and
/// stores the frame in the slot the Fly view shows.
pub struct ReplayVideo {
    inner: Arc<Inner>,
    thread: Option<JoinHandle<()>>,
}

impl std::fmt::Debug for ReplayVideo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ReplayVideo").finish_non_exhaustive()
    }
}

impl ReplayVideo {
    /// Starts the worker; `None` if the session has no video.
    ///
    /// # Errors
    /// The OS error if the worker thread cannot start.
    pub fn start(session: Session) -> std::io::Result<Option<Self>> {
        let Some(mut video) = SessionVideo::new(session) else {
            return Ok(None);
        };
        let inner = Arc::new(Inner {
            request: Mutex::new(Request::default()),
            wake: Condvar::new(),
            slot: FrameSlot::new(),
            state: Mutex::new((CaptureState::Starting, 0, None)),
            busy: AtomicBool::new(false),
        });
        let w = Arc::clone(&inner);
        let thread = std::thread::Builder::new()
            .name("station-replay-video".into())
            .spawn(move || {
                crate::runtime::priority::normal_current();
                worker(&w, &mut video);
            })?;
        Ok(Some(Self {
            inner,
            thread: Some(thread),
        }))
    }

    /// Asks for the frame at `t_ns` (replaces an older request not yet served).
    pub fn request(&self, t_ns: u64) {
        let mut r = lock(&self.inner.request);
        if r.t_ns != Some(t_ns) {
            r.t_ns = Some(t_ns);
            self.inner.wake.notify_one();
        }
    }

    /// The slot the frames go to.
    #[must_use]
    pub fn slot(&self) -> Arc<FrameSlot> {
        Arc::clone(&self.inner.slot)
    }

    /// Whether the worker is decoding a request now.
    #[must_use]
    pub fn busy(&self) -> bool {
        self.inner.busy.load(Ordering::Relaxed)
    }

    /// State and counts in the form of a capture's.
    #[must_use]
    pub fn stats(&self) -> CaptureStats {
        let (state, frames, last) = lock(&self.inner.state).clone();
        CaptureStats {
            state,
            frames,
            last_capture_ns: last,
            ..VideoFeed::Off.stats()
        }
    }
}

impl Drop for ReplayVideo {
    fn drop(&mut self) {
        lock(&self.inner.request).stop = true;
        self.inner.wake.notify_one();
        if let Some(t) = self.thread.take() {
            crate::runtime::join_or_warn(t);
        }
    }
}

fn worker(inner: &Inner, video: &mut SessionVideo) {
    // The capture time shown; frames get a sequence of their own (a seek back decodes
    // older frames, and the screen uploads each new one once).
    let mut shown: Option<u64> = None;
    let mut seq = 0u64;
    loop {
        let t = {
            let mut r = lock(&inner.request);
            loop {
                if r.stop {
                    return;
                }
                if let Some(t) = r.t_ns.take() {
                    break t;
                }
                r = inner
                    .wake
                    .wait_timeout(r, Duration::from_millis(200))
                    .map_or_else(|p| p.into_inner().0, |(g, _)| g);
            }
        };
        inner.busy.store(true, Ordering::Relaxed);
        let result = video.frame_at(t);
        let mut st = lock(&inner.state);
        match result {
            Ok(Some(f)) => {
                st.0 = CaptureState::Running;
                if shown != Some(f.capture_ns) {
                    st.1 += 1;
                    st.2 = Some(f.capture_ns);
                    shown = Some(f.capture_ns);
                    let mut frame = Arc::unwrap_or_clone(f);
                    seq += 1;
                    frame.seq = seq;
                    inner.slot.store(Arc::new(frame));
                }
            }
            Ok(None) => {
                st.0 = CaptureState::NoVideo {
                    reason: "no recorded video at this time".into(),
                };
                inner.slot.clear();
                shown = None;
            }
            Err(e) => {
                st.0 = CaptureState::Failed {
                    reason: format!("recorded video: {e}"),
                };
            }
        }
        drop(st);
        inner.busy.store(false, Ordering::Relaxed);
    }
}
