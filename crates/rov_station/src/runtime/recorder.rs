//! The recorder: a thread that writes session records through `rov_session`'s
//! [`SessionWriter`], fed by a bounded queue (overflow counted, never blocking the control
//! loop). The writer's flush and fsync run on this thread, so disk latency never delays
//! a control tick. The thread also flushes on a 100 ms wall timer, so a recording whose
//! message stream stops (link lost) still loses at most 0.1 s when killed.
//!
//! **Time order.** The camera's access units reach the recorder after the encoder's
//! latency (~0.1–0.5 s) stamped with their capture time, while telemetry arrives
//! stamped at its tick, so written as they came every unit was earlier than the
//! telemetry before it (issue 25: thousands of "earlier than the message before them"
//! per session). The thread holds items for [`REORDER_WINDOW_NS`] in a time-ordered
//! buffer and writes them in time order; an item later than that (a stalled encoder) is
//! written when it comes, and the file's reader reports it. The buffer is drained when
//! the recording stops; a killed process loses at most the window plus the flush
//! interval.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, SyncSender, TrySendError, sync_channel};
use std::thread::JoinHandle;
use std::time::Duration;

use rov_session::{SessionInfo, SessionWriter, WriteSummary};

pub use crate::pilot::record::RecordItem;

/// How long the recorder holds items to write them in time order, ns (above the video
/// encoder's latency on a loaded laptop).
pub const REORDER_WINDOW_NS: u64 = 2_000_000_000;

/// An item waiting in the reorder buffer, ordered by (time, arrival) reversed so that
/// the heap's top is the earliest.
#[derive(Debug)]
struct Pending {
    t_ns: u64,
    seq: u64,
    item: RecordItem,
}

impl PartialEq for Pending {
    fn eq(&self, other: &Self) -> bool {
        (self.t_ns, self.seq) == (other.t_ns, other.seq)
    }
}
impl Eq for Pending {}
impl PartialOrd for Pending {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Pending {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        (other.t_ns, other.seq).cmp(&(self.t_ns, self.seq))
    }
}

/// Items in time order: [`Reorder::push`] returns those older than the newest time seen
/// minus the window, earliest first (items of equal time keep their arrival order).
#[derive(Debug)]
pub(crate) struct Reorder {
    heap: std::collections::BinaryHeap<Pending>,
    newest_ns: u64,
    seq: u64,
    window_ns: u64,
}

impl Reorder {
    pub(crate) fn new(window_ns: u64) -> Self {
        Self {
            heap: std::collections::BinaryHeap::new(),
            newest_ns: 0,
            seq: 0,
            window_ns,
        }
    }

    /// Adds an item; returns the items now due, in time order.
    pub(crate) fn push(&mut self, item: RecordItem) -> Vec<RecordItem> {
        let t_ns = item.t_ns();
        self.newest_ns = self.newest_ns.max(t_ns);
        self.heap.push(Pending {
            t_ns,
            seq: self.seq,
            item,
        });
        self.seq += 1;
        let due = self.newest_ns.saturating_sub(self.window_ns);
        let mut out = Vec::new();
        while self.heap.peek().is_some_and(|p| p.t_ns <= due) {
            if let Some(p) = self.heap.pop() {
                out.push(p.item);
            }
        }
        out
    }

    /// Everything still held, in time order.
    pub(crate) fn drain(&mut self) -> Vec<RecordItem> {
        let mut out = Vec::with_capacity(self.heap.len());
        while let Some(p) = self.heap.pop() {
            out.push(p.item);
        }
        out
    }
}

/// Queue capacity, items (about 1.5 s of everything at 50 Hz).
pub const QUEUE_CAPACITY: usize = 4096;

#[derive(Debug, Default)]
struct Counters {
    queued: AtomicU64,
    written: AtomicU64,
    dropped: AtomicU64,
    failed: AtomicBool,
    /// Video units refused by the writer (malformed, too large): skipped, the
    /// recording goes on.
    video_skipped: AtomicU64,
}

/// The recorder's input for the video encoder's access units (they arrive on
/// GStreamer's thread, not the control thread). Live: never waits (a full queue drops
/// the unit, counted); virtual time: waits. Recording time = capture time (station clock)
/// − the recording's start. Once the recording stops, units are ignored.
#[derive(Debug, Clone)]
pub struct VideoTap {
    tx: Arc<std::sync::Mutex<Option<SyncSender<RecordItem>>>>,
    started_ns: u64,
    blocking: bool,
    counters: Arc<Counters>,
    /// The live Foxglove server's tap when one was attached as the recording started: each
    /// unit is also offered to it (a non-blocking copy, on the encoder's thread).
    live: Option<crate::runtime::foxglove_live::LiveTap>,
}

impl VideoTap {
    /// The same tap that also serves each unit live on `/camera/video`.
    #[must_use]
    pub fn with_live(mut self, live: Option<crate::runtime::foxglove_live::LiveTap>) -> Self {
        self.live = live;
        self
    }

    /// Queues one access unit whose `pts_ns` is on the station clock.
    pub fn send(&self, au: rov_video::AccessUnit) {
        let t = au.pts_ns.saturating_sub(self.started_ns);
        let pts_us = au.pts_ns / 1000;
        let item = RecordItem::Video(t, au.key_frame, au.data);
        if let Some(l) = &self.live {
            l.send(pts_us, &item);
        }
        let g = self
            .tx
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let Some(tx) = g.as_ref() else {
            return;
        };
        let ok = if self.blocking {
            tx.send(item).is_ok()
        } else {
            tx.try_send(item).is_ok()
        };
        let c = if ok {
            &self.counters.queued
        } else {
            &self.counters.dropped
        };
        c.fetch_add(1, Ordering::Relaxed);
    }
}

/// A running recorder.
#[derive(Debug)]
pub struct Recorder {
    path: PathBuf,
    tx: Option<SyncSender<RecordItem>>,
    /// The video encoder's way in (emptied on stop, so the writer thread ends).
    video_tx: Arc<std::sync::Mutex<Option<SyncSender<RecordItem>>>>,
    counters: Arc<Counters>,
    error: Arc<std::sync::Mutex<Option<String>>>,
    join: Option<JoinHandle<Result<WriteSummary, RecorderError>>>,
    started_us: u64,
    blocking: bool,
}

impl Recorder {
    /// Creates the file (header written and synced) and starts the thread. `started_us`
    /// is the station time of the recording's t = 0.
    ///
    /// # Errors
    /// [`RecorderError`]: the folder or the file cannot be created, or the thread
    /// cannot start.
    pub fn start(
        path: &Path,
        info: &SessionInfo,
        started_us: u64,
        blocking: bool,
    ) -> Result<Self, RecorderError> {
        // The folder is made here, where its failure can be said (a read-only disk, a
        // file where the folder should be), not dropped while the file is named.
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|source| RecorderError::CreateDir {
                dir: dir.to_path_buf(),
                source,
            })?;
        }
        let writer = SessionWriter::create(path, info, 0)?;
        let (tx, rx) = sync_channel(QUEUE_CAPACITY);
        let counters = Arc::new(Counters::default());
        let error = Arc::new(std::sync::Mutex::new(None));
        let c = Arc::clone(&counters);
        let e = Arc::clone(&error);
        let join = std::thread::Builder::new()
            .name("station-recorder".into())
            .spawn(move || {
                // Started by the control thread: not at its real-time priority.
                crate::runtime::priority::normal_current();
                run(writer, &rx, &c, &e)
            })
            .map_err(RecorderError::Thread)?;
        Ok(Self {
            path: path.to_path_buf(),
            video_tx: Arc::new(std::sync::Mutex::new(Some(tx.clone()))),
            tx: Some(tx),
            counters,
            error,
            join: Some(join),
            started_us,
            blocking,
        })
    }

    /// The file.
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Station time of t = 0, µs.
    #[must_use]
    pub const fn started_us(&self) -> u64 {
        self.started_us
    }

    /// Recording time of a station time, ns.
    #[must_use]
    pub const fn t_ns(&self, now_us: u64) -> u64 {
        now_us.saturating_sub(self.started_us).saturating_mul(1000)
    }

    /// The way in for the video encoder's access units (see [`VideoTap`]).
    #[must_use]
    pub fn video_tap(&self) -> VideoTap {
        VideoTap {
            tx: Arc::clone(&self.video_tx),
            started_ns: self.started_us.saturating_mul(1000),
            blocking: self.blocking,
            counters: Arc::clone(&self.counters),
            live: None,
        }
    }

    /// Video units the writer refused (malformed or too large), skipped.
    #[must_use]
    pub fn video_skipped(&self) -> u64 {
        self.counters.video_skipped.load(Ordering::Relaxed)
    }

    fn close_video(&self) {
        *self
            .video_tx
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner) = None;
    }

    /// Queues an item; a full queue drops it (counted).
    pub fn send(&self, item: RecordItem) {
        if let Some(tx) = &self.tx {
            if self.blocking {
                // Virtual time: wait for the writer rather than lose a message.
                let counter = match tx.send(item) {
                    Ok(()) => &self.counters.queued,
                    Err(_) => &self.counters.dropped,
                };
                counter.fetch_add(1, Ordering::Relaxed);
                return;
            }
            match tx.try_send(item) {
                Ok(()) => {
                    self.counters.queued.fetch_add(1, Ordering::Relaxed);
                }
                Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => {
                    self.counters.dropped.fetch_add(1, Ordering::Relaxed);
                }
            }
        }
    }

    /// Items queued so far (deterministic for a given run, unlike `written`).
    #[must_use]
    pub fn queued(&self) -> u64 {
        self.counters.queued.load(Ordering::Relaxed)
    }

    /// Messages written so far.
    #[must_use]
    pub fn written(&self) -> u64 {
        self.counters.written.load(Ordering::Relaxed)
    }

    /// Items dropped so far.
    #[must_use]
    pub fn dropped(&self) -> u64 {
        self.counters.dropped.load(Ordering::Relaxed)
    }

    /// The last error, if writing failed.
    #[must_use]
    pub fn error(&self) -> Option<String> {
        if !self.counters.failed.load(Ordering::Relaxed) {
            return None;
        }
        crate::runtime::lock(&self.error).clone()
    }

    /// Stops: drains the queue, writes the summary and syncs.
    ///
    /// # Errors
    /// The writer's error ([`RecorderError::Session`]), or the thread panicked.
    pub fn stop(mut self) -> Result<WriteSummary, RecorderError> {
        self.tx = None;
        self.close_video();
        match self.join.take() {
            Some(j) => j.join().unwrap_or(Err(RecorderError::Panicked)),
            None => Err(RecorderError::AlreadyStopped),
        }
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        self.tx = None;
        self.close_video();
        if let Some(j) = self.join.take() {
            // Dropped without `stop` (an error path of the caller, or a test): the file
            // is finished as far as it can be, and nobody is left to hear how it went;
            // its reader recovers a file without its summary.
            if let Ok(Err(e)) | Err(e) = j.join().map_err(|_| RecorderError::Panicked) {
                tracing::warn!(path = %self.path.display(), "recording dropped unfinished: {e}");
            }
        }
    }
}

fn write_item(w: &mut SessionWriter, item: &RecordItem) -> rov_session::Result<()> {
    match item {
        RecordItem::Raw(d, t, bytes) => w.write_raw(*d, *t, bytes),
        RecordItem::Nav(t, r) => w.write(*t, r),
        RecordItem::Status(t, r) => w.write(*t, r),
        RecordItem::Thrust(t, r) => w.write(*t, r),
        RecordItem::Pilot(t, r) => w.write(*t, r),
        RecordItem::Autopilot(t, r) => w.write(*t, r),
        RecordItem::Observer(t, r) => w.write(*t, r),
        RecordItem::Link(t, r) => w.write(*t, r),
        RecordItem::Event(t, r) => w.write(*t, r),
        RecordItem::Truth(t, r) => w.write(*t, r),
        RecordItem::Video(t, key, data) => w.write_video(*t, data, *key),
    }
}

fn run(
    mut w: SessionWriter,
    rx: &Receiver<RecordItem>,
    counters: &Counters,
    error: &std::sync::Mutex<Option<String>>,
) -> Result<WriteSummary, RecorderError> {
    let fail = |e: String| {
        counters.failed.store(true, Ordering::Relaxed);
        *crate::runtime::lock(error) = Some(e);
    };
    let write = |w: &mut SessionWriter, item: RecordItem| {
        // Once writing failed the file is not extended (the error is shown).
        if counters.failed.load(Ordering::Relaxed) {
            return;
        }
        match write_item(w, &item) {
            Ok(()) => {
                counters.written.fetch_add(1, Ordering::Relaxed);
            }
            // A unit the writer refuses is skipped: the telemetry goes on.
            Err(
                rov_session::SessionError::Video { .. }
                | rov_session::SessionError::MessageTooLarge { .. },
            ) if matches!(item, RecordItem::Video(..)) => {
                counters.video_skipped.fetch_add(1, Ordering::Relaxed);
            }
            Err(e) => fail(e.to_string()),
        }
    };
    let mut order = Reorder::new(REORDER_WINDOW_NS);
    loop {
        match rx.recv_timeout(Duration::from_millis(100)) {
            Ok(item) => {
                for due in order.push(item) {
                    write(&mut w, due);
                }
            }
            Err(RecvTimeoutError::Timeout) => {
                if let Err(e) = w.flush() {
                    fail(e.to_string());
                }
            }
            Err(RecvTimeoutError::Disconnected) => break,
        }
    }
    for item in order.drain() {
        write(&mut w, item);
    }
    Ok(w.finish()?)
}

/// Why a recording could not start or be finished.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RecorderError {
    /// The recordings folder does not exist and cannot be made.
    #[error("cannot create the folder {}: {source}", dir.display())]
    CreateDir {
        /// The folder.
        dir: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// The session writer failed (create, write, summary, sync); names the file.
    #[error(transparent)]
    Session(#[from] rov_session::SessionError),
    /// The recorder thread could not be started.
    #[error("cannot start the recorder thread: {0}")]
    Thread(#[source] std::io::Error),
    /// The recorder thread panicked.
    #[error("recorder thread panicked")]
    Panicked,
    /// `stop` after the thread was already joined.
    #[error("recorder already stopped")]
    AlreadyStopped,
    /// The recording's finisher thread panicked.
    #[error("the recording's finisher thread panicked")]
    FinisherPanicked,
    /// The same recording was handed to two finishers (cannot happen; reported, not a
    /// panic).
    #[error("recording handed to two finishers")]
    FinishedTwice,
}

#[cfg(test)]
mod order_tests {
    use super::*;
    use rov_session::Direction;

    fn ev(t: u64) -> RecordItem {
        RecordItem::Raw(Direction::Rx, t, vec![0])
    }

    #[test]
    fn late_video_is_written_in_time_order() {
        // Telemetry every 20 ms; each video unit arrives 300 ms after its capture time.
        let mut r = Reorder::new(REORDER_WINDOW_NS);
        let (mut out, mut pushed) = (Vec::new(), 0);
        for k in 0..500u64 {
            let t = k * 20_000_000;
            out.extend(r.push(ev(t)));
            pushed += 1;
            if k % 2 == 0 && t >= 300_000_000 {
                out.extend(r.push(RecordItem::Video(t - 300_000_000, false, vec![1])));
                pushed += 1;
            }
        }
        out.extend(r.drain());
        assert_eq!(out.len(), pushed);
        assert!(out.windows(2).all(|w| w[0].t_ns() <= w[1].t_ns()));
        // Equal times keep their arrival order.
        let mut r = Reorder::new(0);
        let mut a = r.push(RecordItem::Raw(Direction::Tx, 5, vec![]));
        a.extend(r.push(RecordItem::Raw(Direction::Rx, 5, vec![])));
        a.extend(r.drain());
        assert!(matches!(a[0], RecordItem::Raw(Direction::Tx, ..)));
    }
}

#[cfg(test)]
mod folder_tests {
    use super::*;

    fn info() -> SessionInfo {
        SessionInfo {
            vehicle: "sim".into(),
            software_version: "test".into(),
            started_unix_s: 0.0,
            config_toml: String::new(),
        }
    }

    #[test]
    fn the_folder_is_made_and_a_folder_that_cannot_be_is_named() {
        let root = tempfile::tempdir().unwrap();
        // A folder that does not exist yet is made.
        let p = root.path().join("a/b/session.mcap");
        let r = Recorder::start(&p, &info(), 0, true).unwrap();
        drop(r);
        assert!(root.path().join("a/b").is_dir());
        // A file where the folder should be: the error names the folder and why.
        std::fs::write(root.path().join("file"), b"x").unwrap();
        let bad = root.path().join("file/sub/session.mcap");
        let e = Recorder::start(&bad, &info(), 0, true).err().unwrap();
        assert!(
            matches!(&e, RecorderError::CreateDir { dir, .. } if dir == &root.path().join("file/sub")),
            "{e:?}"
        );
        let text = e.to_string();
        assert!(
            text.contains("cannot create the folder") && text.contains("file/sub"),
            "{text}"
        );
        assert!(std::error::Error::source(&e).is_some());
        // A file that cannot be created (a folder is in its place): the writer's
        // error, naming the file, is kept as it is.
        let taken = root.path().join("taken.mcap");
        std::fs::create_dir(&taken).unwrap();
        let e = Recorder::start(&taken, &info(), 0, true).err().unwrap();
        assert!(
            matches!(&e, RecorderError::Session(rov_session::SessionError::Io { path, .. }) if path == &taken),
            "{e:?}"
        );
    }
}
