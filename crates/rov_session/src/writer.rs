//! [`SessionWriter`]: records a session to an MCAP file that survives being killed.
//!
//! # Layout
//!
//! An MCAP file (spec version 0) with small **chunks**, zstd-compressed by default, written
//! by [`crate::mcap_file`] (memory flat however long the recording). Each chunk carries a
//! CRC of its content, so the reader detects a damaged chunk instead of returning altered
//! values. Schemas and channels are registered lazily, on the first
//! message of a topic. At creation the writer stores the configuration as the attachment
//! `config.toml`, a metadata record `session` (vehicle, software version, start time) and
//! one `/session/info` message.
//!
//! # Timestamps
//!
//! The writer never reads a clock: every call takes the message time `t_ns` (u64
//! nanoseconds) from the caller. Use one time base per file, either nanoseconds since the
//! session start (what the station does; `/session/info` then sits at 0) or nanoseconds
//! since the Unix epoch. Times need not be monotonic (the reader sorts and warns).
//!
//! # Crash safety (the guarantee)
//!
//! Messages first go to an in-memory chunk. [`SessionWriter::flush`] closes the chunk,
//! compresses it and hands it, whole, to the OS (`write(2)` through a 256 KiB buffer that
//! the flush empties); a chunk never reaches the file half-built.
//! [`SessionWriter::write`] calls [`SessionWriter::flush_if_due`] with the message's time,
//! which flushes once `flush_interval` (default 250 ms) of session time has passed since
//! the last flush, and calls `fdatasync` once `sync_interval` (default 1 s) has passed since
//! the last sync. So:
//!
//! * after SIGKILL (or a panic that aborts) the file holds every message written up to the
//!   last flush: at most `flush_interval` of session time (plus the messages of the current
//!   tick) is lost, as long as messages keep arriving. A caller whose stream can stop
//!   (link lost) calls [`SessionWriter::flush`] on a wall-clock timer as well;
//! * after power loss at most `sync_interval` plus `flush_interval` is lost (what the
//!   filesystem keeps of unsynced data is up to it);
//! * [`SessionWriter::finish`] writes the summary (indexes, statistics) and syncs. A
//!   dropped writer also writes the summary, best effort, but does not sync.
//!
//! A file cut short anywhere loads with every complete chunk before the cut
//! ([`crate::open`]); [`crate::recover`] turns it into a complete file.
//!
//! # Bounds
//!
//! A message larger than `max_message_bytes` (default 1 MiB; video access units:
//! `max_video_message_bytes`, default 8 MiB) is refused with
//! [`SessionError::MessageTooLarge`]: JSON encoding stops at the cap, so an oversized
//! record costs no more than the cap in memory.
//!
//! # Foxglove topics
//!
//! Every `/telemetry/nav` record also gives the vehicle's pose ([`crate::foxglove`]): a
//! `foxglove.FrameTransform` on `/tf` and a `foxglove.PoseInFrame` on `/vehicle/pose` at
//! most every `pose_interval_ns` (default 100 ms), north and east from the latest
//! `/truth/state` (simulated vehicle) or 0, and the recent track on `/vehicle/track`.
//! [`SessionWriter::write_video`] records camera video as `foxglove.CompressedVideo`.

use std::collections::BTreeMap;
use std::fs::File;
use std::path::{Path, PathBuf};

use crate::error::{Result, SessionError, io_err};
use crate::foxglove::{self, PoseMessages, PoseTopics, VehiclePose};
use crate::mcap_file::{McapFile, McapOptions};
use crate::record::{Direction, NavRecord, Record, SessionInfo, Topic, TruthRecord, encode_json};

/// Nanoseconds per millisecond.
const MS: u64 = 1_000_000;

/// Writer settings.
#[derive(Debug, Clone, PartialEq)]
pub struct WriterOptions {
    /// Close the chunk and hand it to the OS once this much session time has passed since
    /// the last flush, ns (default 250 ms). Shorter loses less to a kill but makes more,
    /// smaller chunks: at 100 ms a one-hour file is ~30 % larger and opens ~2× slower.
    pub flush_interval_ns: u64,
    /// `fdatasync` once this much session time has passed since the last sync, ns
    /// (default 1 s).
    pub sync_interval_ns: u64,
    /// Largest message accepted, bytes (default 1 MiB).
    pub max_message_bytes: usize,
    /// zstd-compress the chunks (default true).
    pub compress: bool,
    /// Largest video access unit accepted, bytes (default 8 MiB).
    pub max_video_message_bytes: usize,
    /// Write the pose topics at most this often, ns of session time (default 100 ms);
    /// `u64::MAX`: no pose topics.
    pub pose_interval_ns: u64,
}

impl Default for WriterOptions {
    fn default() -> Self {
        Self {
            flush_interval_ns: 250 * MS,
            sync_interval_ns: 1_000 * MS,
            max_message_bytes: 1 << 20,
            compress: true,
            max_video_message_bytes: 8 << 20,
            pose_interval_ns: 100 * MS,
        }
    }
}

/// What [`SessionWriter::finish`] reports.
#[derive(Debug, Clone, PartialEq)]
pub struct WriteSummary {
    /// The file.
    pub path: PathBuf,
    /// Messages written (including `/session/info`).
    pub messages: u64,
    /// Messages per topic name.
    pub per_topic: BTreeMap<String, u64>,
    /// Chunks written.
    pub chunks: u32,
}

/// Records a session. See the module docs for the layout and the crash-safety guarantee.
pub struct SessionWriter {
    path: PathBuf,
    mcap: McapFile,
    sync_handle: File,
    opts: WriterOptions,
    channels: [Option<u16>; Topic::ALL.len()],
    sequences: [u32; Topic::ALL.len()],
    scratch: Vec<u8>,
    last_flush_ns: u64,
    last_sync_ns: u64,
    unsynced: bool,
    messages: u64,
    /// The pose topics derived from the navigation and truth records.
    poses: PoseTopics,
}

impl std::fmt::Debug for SessionWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SessionWriter")
            .field("path", &self.path)
            .field("messages", &self.messages)
            .field("opts", &self.opts)
            .finish_non_exhaustive()
    }
}

impl SessionWriter {
    /// Creates (or truncates) `path` with default options and writes the session header:
    /// attachment `config.toml`, metadata `session` and a `/session/info` message at `t_ns`.
    /// The header is flushed and synced before this returns.
    pub fn create(path: impl AsRef<Path>, info: &SessionInfo, t_ns: u64) -> Result<Self> {
        Self::create_with(path, info, t_ns, WriterOptions::default())
    }

    /// [`SessionWriter::create`] with options.
    pub fn create_with(
        path: impl AsRef<Path>,
        info: &SessionInfo,
        t_ns: u64,
        opts: WriterOptions,
    ) -> Result<Self> {
        let path = path.as_ref().to_path_buf();
        let mcap = McapFile::create(
            &path,
            McapOptions {
                compress: opts.compress,
                chunk_size: 1 << 20,
                library: format!("topside rov_session {}", env!("CARGO_PKG_VERSION")),
            },
        )
        .map_err(io_err(&path, "create"))?;
        let sync_handle = mcap
            .file_handle()
            .map_err(io_err(&path, "open a second handle to"))?;
        let mut w = Self {
            path,
            mcap,
            sync_handle,
            channels: [None; Topic::ALL.len()],
            sequences: [0; Topic::ALL.len()],
            scratch: Vec::with_capacity(4096),
            last_flush_ns: t_ns,
            last_sync_ns: t_ns,
            unsynced: true,
            messages: 0,
            poses: PoseTopics::new(opts.pose_interval_ns),
            opts,
        };
        let started_ns = if info.started_unix_s.is_finite() && info.started_unix_s > 0.0 {
            (info.started_unix_s * 1e9) as u64
        } else {
            0
        };
        let metadata = BTreeMap::from([
            ("vehicle".to_string(), info.vehicle.clone()),
            (
                "software_version".to_string(),
                info.software_version.clone(),
            ),
            (
                "started_unix_s".to_string(),
                format!("{}", info.started_unix_s),
            ),
        ]);
        let res = w
            .mcap
            .attach(
                t_ns,
                started_ns,
                "config.toml",
                "application/toml",
                info.config_toml.as_bytes(),
            )
            .and_then(|()| w.mcap.write_metadata("session", &metadata));
        res.map_err(io_err(&w.path, "write"))?;
        w.write(t_ns, info)?;
        w.sync()?;
        Ok(w)
    }

    fn io_err(&self, action: &'static str) -> impl FnOnce(std::io::Error) -> SessionError + use<> {
        let path = self.path.clone();
        move |source| SessionError::Io {
            path,
            action,
            source,
        }
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Messages written so far.
    pub fn messages_written(&self) -> u64 {
        self.messages
    }

    /// The options in force.
    pub fn options(&self) -> &WriterOptions {
        &self.opts
    }

    fn channel(&mut self, topic: Topic) -> Result<u16> {
        if let Some(Some(id)) = self.channels.get(topic.index()) {
            return Ok(*id);
        }
        let schema = foxglove::channel_schema(topic);
        let schema_id = if schema.name.is_empty() {
            0
        } else {
            self.mcap
                .add_schema(&schema.name, &schema.encoding, &schema.data)
                .map_err(self.io_err("write"))?
        };
        let id = self
            .mcap
            .add_channel(schema_id, topic.name(), topic.encoding(), &BTreeMap::new())
            .map_err(self.io_err("write"))?;
        if let Some(slot) = self.channels.get_mut(topic.index()) {
            *slot = Some(id);
        }
        Ok(id)
    }

    fn put(&mut self, topic: Topic, t_ns: u64, from_scratch: Option<&[u8]>) -> Result<()> {
        let channel_id = self.channel(topic)?;
        let sequence = self.sequences.get(topic.index()).copied().unwrap_or(0);
        let data = from_scratch.unwrap_or(&self.scratch);
        self.mcap
            .write_message(channel_id, sequence, t_ns, t_ns, data)
            .map_err(io_err(&self.path, "write"))?;
        if let Some(s) = self.sequences.get_mut(topic.index()) {
            *s = s.wrapping_add(1);
        }
        self.messages += 1;
        self.flush_if_due(t_ns)?;
        Ok(())
    }

    /// Writes a record on its topic at `t_ns`, then [`SessionWriter::flush_if_due`].
    pub fn write<T: Record>(&mut self, t_ns: u64, record: &T) -> Result<()> {
        encode_json(record, self.opts.max_message_bytes, &mut self.scratch)?;
        self.put(T::TOPIC, t_ns, None)?;
        let any: &dyn std::any::Any = record;
        if let Some(t) = any.downcast_ref::<TruthRecord>() {
            self.poses.truth(t_ns, t);
        } else if let Some(nav) = any.downcast_ref::<NavRecord>()
            && let Some(m) = self.poses.nav(t_ns, nav)
        {
            self.put_pose(&m)?;
        }
        Ok(())
    }

    /// Writes a pose: `/tf`, `/vehicle/pose`, and `/vehicle/track` when one is due (see
    /// [`crate::foxglove`]). The writer calls this itself for every navigation record; call
    /// it directly only for poses from another source.
    pub fn write_pose(&mut self, p: &VehiclePose) -> Result<()> {
        let m = self.poses.pose(p);
        self.put_pose(&m)
    }

    fn put_pose(&mut self, m: &PoseMessages) -> Result<()> {
        let t_ns = m.pose.t_ns;
        self.put(Topic::Transform, t_ns, Some(&m.transform))?;
        self.put(Topic::Pose, t_ns, Some(&m.pose_in_frame))?;
        if let Some(track) = &m.track
            && track.len() <= self.opts.max_message_bytes
        {
            self.put(Topic::Track, t_ns, Some(track))?;
        }
        Ok(())
    }

    /// Records one H.264 access unit (Annex B) captured at `t_ns` on `/camera/video` as a
    /// `foxglove.CompressedVideo`. A key frame must carry SPS, PPS and an IDR slice; an
    /// access unit not flagged as a key frame must not hold an IDR slice
    /// ([`SessionError::Video`] otherwise, nothing written).
    pub fn write_video(&mut self, t_ns: u64, access_unit: &[u8], key_frame: bool) -> Result<()> {
        let topic = Topic::Video;
        if access_unit.len() > self.opts.max_video_message_bytes {
            return Err(SessionError::MessageTooLarge {
                topic: topic.name().into(),
                len: access_unit.len(),
                max: self.opts.max_video_message_bytes,
            });
        }
        foxglove::check_access_unit(access_unit, key_frame).map_err(|source| {
            SessionError::Video {
                topic: topic.name().into(),
                source,
            }
        })?;
        let bytes = foxglove::encode(&foxglove::video_message(t_ns, access_unit));
        self.put(topic, t_ns, Some(&bytes))
    }

    /// Writes a raw frame (the frame's bytes, nothing else) at `t_ns`, then
    /// [`SessionWriter::flush_if_due`].
    pub fn write_raw(&mut self, direction: Direction, t_ns: u64, frame: &[u8]) -> Result<()> {
        let topic = direction.topic();
        if frame.len() > self.opts.max_message_bytes {
            return Err(SessionError::MessageTooLarge {
                topic: topic.name().into(),
                len: frame.len(),
                max: self.opts.max_message_bytes,
            });
        }
        self.put(topic, t_ns, Some(frame))
    }

    /// Flushes when `flush_interval` has passed since the last flush driven by this
    /// function (or when time went backwards), and syncs when `sync_interval` has passed
    /// since the last sync. Returns whether it flushed.
    pub fn flush_if_due(&mut self, t_ns: u64) -> Result<bool> {
        let due =
            t_ns < self.last_flush_ns || t_ns - self.last_flush_ns >= self.opts.flush_interval_ns;
        if !due {
            return Ok(false);
        }
        self.flush()?;
        self.last_flush_ns = t_ns;
        if t_ns < self.last_sync_ns || t_ns - self.last_sync_ns >= self.opts.sync_interval_ns {
            self.sync_data()?;
            self.last_sync_ns = t_ns;
        }
        Ok(true)
    }

    /// Closes the current chunk and hands everything written so far to the OS. After this
    /// returns, a SIGKILL loses nothing written before the call.
    pub fn flush(&mut self) -> Result<()> {
        self.mcap.flush().map_err(self.io_err("write"))?;
        self.unsynced = true;
        Ok(())
    }

    fn sync_data(&mut self) -> Result<()> {
        if self.unsynced {
            self.sync_handle
                .sync_data()
                .map_err(io_err(&self.path, "fdatasync"))?;
            self.unsynced = false;
        }
        Ok(())
    }

    /// [`SessionWriter::flush`], then `fdatasync`: after this returns, a power loss loses
    /// nothing written before the call.
    pub fn sync(&mut self) -> Result<()> {
        self.flush()?;
        self.sync_data()
    }

    /// Writes the summary section (statistics, chunk and message indexes) and the footer,
    /// and syncs the file.
    pub fn finish(mut self) -> Result<WriteSummary> {
        let stats = self
            .mcap
            .finish()
            .map_err(self.io_err("write the summary of"))?;
        self.sync_handle
            .sync_all()
            .map_err(io_err(&self.path, "fsync"))?;
        let mut per_topic = BTreeMap::new();
        for (id, n) in &stats.channel_counts {
            if let Some(topic) = self.mcap.topic(*id) {
                *per_topic.entry(topic.to_string()).or_insert(0) += n;
            }
        }
        Ok(WriteSummary {
            path: self.path.clone(),
            messages: self.messages,
            per_topic,
            chunks: stats.chunks,
        })
    }
}

impl Drop for SessionWriter {
    /// A writer dropped without [`SessionWriter::finish`] still writes the summary, best
    /// effort, without syncing.
    fn drop(&mut self) {
        if !self.mcap.is_finished() {
            let _ = self.mcap.finish();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::{NavRecord, PilotRecord};

    fn info() -> SessionInfo {
        SessionInfo {
            vehicle: "sim".into(),
            software_version: "test".into(),
            started_unix_s: 1.7e9,
            config_toml: "a = 1\n".into(),
        }
    }

    #[test]
    fn oversized_messages_are_refused_and_the_file_stays_usable() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.mcap");
        let opts = WriterOptions {
            max_message_bytes: 600,
            ..WriterOptions::default()
        };
        let mut w = SessionWriter::create_with(&path, &info(), 0, opts).unwrap();
        let big = PilotRecord {
            buttons: vec!["x".repeat(1000)],
            ..PilotRecord::default()
        };
        let e = w.write(1, &big).unwrap_err();
        assert!(
            matches!(e, SessionError::MessageTooLarge { max: 600, .. }),
            "{e}"
        );
        let e = w.write_raw(Direction::Rx, 2, &[0u8; 601]).unwrap_err();
        assert!(
            matches!(e, SessionError::MessageTooLarge { len: 601, .. }),
            "{e}"
        );
        w.write(3, &NavRecord::default()).unwrap();
        let s = w.finish().unwrap();
        assert_eq!(s.messages, 2);
        assert_eq!(s.per_topic.get("/telemetry/nav"), Some(&1));
    }

    #[test]
    fn flushes_follow_session_time() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.mcap");
        let mut w = SessionWriter::create(&path, &info(), 0).unwrap();
        let len0 = std::fs::metadata(&path).unwrap().len();
        w.write(10 * MS, &NavRecord::default()).unwrap();
        assert_eq!(
            std::fs::metadata(&path).unwrap().len(),
            len0,
            "not due yet: stays in memory"
        );
        w.write(250 * MS, &NavRecord::default()).unwrap();
        assert!(
            std::fs::metadata(&path).unwrap().len() > len0,
            "due: handed to the OS"
        );
        assert!(!w.flush_if_due(300 * MS).unwrap());
        assert!(
            w.flush_if_due(50 * MS).unwrap(),
            "time went backwards: flush"
        );
        w.finish().unwrap();
    }
}
