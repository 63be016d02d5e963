//! [`Session`]: an open session file. Opening reads the index only ([`crate::open`]); the
//! messages are read by streams ([`crate::stream`]).
//!
//! # Damaged files
//!
//! * Not MCAP (empty, a PNG, text, random bytes): [`SessionError::NotMcap`].
//! * Cut short anywhere (a recording killed, a partial copy): opening scans the file;
//!   every complete record before the cut is readable and [`Session::damage`] is
//!   [`Damage::Truncated`] with the byte offset of the first incomplete record. A chunk is
//!   all or nothing.
//! * A record that is complete but wrong (CRC mismatch, malformed body, unknown
//!   compression): in a file without a summary, the scan stops there and reports
//!   [`Damage::Corrupt`]; in a complete file, the read that reaches the chunk stops there
//!   and the session reports it from then on. Every record before it is returned. Nothing
//!   is skipped silently. [`Session::check`] reads everything (as recovery does).
//!
//! Lengths are checked against the bytes present before any allocation, and a chunk may
//! claim at most [`crate::MAX_CHUNK_BYTES`] uncompressed.
//!
//! # Warnings
//!
//! [`Session::warnings`] lists what opening found wrong (unknown topics kept undecoded, a
//! summary that disagrees with the data or fails its CRC, bytes after the end of the
//! file); [`crate::ReadReport::warnings`] adds what a complete read finds (messages out of
//! time order, which reads return sorted; gaps in a topic).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use crate::error::{Result, SessionError, io_err};
use crate::index::Index;
use crate::io::{BytesSource, FileSource, Source};
use crate::message::{Damage, Message, TopicSummary};
use crate::open::{Opened, check_magic, open_source};
use crate::record::{Direction, Record, SessionInfo, Topic};
use crate::stream::{Messages, ReadOptions, ReadReport};
use crate::wire::{AttachmentData, ChannelDef, SchemaDef};

/// What every clone of a session shares.
#[derive(Debug)]
pub(crate) struct Inner {
    pub label: PathBuf,
    pub src: Box<dyn Source>,
    pub index: Index,
    pub attachments: Vec<AttachmentData>,
    pub metadata: Vec<(String, BTreeMap<String, String>)>,
    pub message_count: u64,
    pub open_damage: Option<Damage>,
    pub warnings: Vec<String>,
    pub indexed: bool,
    /// The first damage a read found (lowest offset).
    pub read_damage: Mutex<Option<Damage>>,
}

impl Inner {
    /// Remembers damage a read found (the one at the lowest offset wins).
    pub(crate) fn note_damage(&self, d: &Damage) {
        if let Ok(mut g) = self.read_damage.lock()
            && g.as_ref().is_none_or(|old| d.at_byte() < old.at_byte())
        {
            *g = Some(d.clone());
        }
    }
}

/// An open session: its index, and reads of its messages. Cloning is cheap (shared).
#[derive(Debug, Clone)]
pub struct Session {
    inner: Arc<Inner>,
}

/// Opens a session file; see [`Session::open`].
pub fn open(path: impl AsRef<Path>) -> Result<Session> {
    Session::open(path)
}

impl Session {
    /// Opens a session file: through its summary when it is complete (no message is read),
    /// otherwise by a scan that finds where it is damaged.
    pub fn open(path: impl AsRef<Path>) -> Result<Session> {
        let path = path.as_ref();
        let src = FileSource::open(path).map_err(io_err(path, "read"))?;
        Self::from_source(Box::new(src), path, false)
    }

    /// Opens a session file by reading every record (the summary is only cross-checked):
    /// what recovery does. Slower; finds damage anywhere at once.
    pub fn open_scanned(path: impl AsRef<Path>) -> Result<Session> {
        let path = path.as_ref();
        let src = FileSource::open(path).map_err(io_err(path, "read"))?;
        Self::from_source(Box::new(src), path, true)
    }

    /// Opens a session held in memory; `label` names it in errors.
    pub fn from_bytes(bytes: Vec<u8>, label: impl AsRef<Path>) -> Result<Session> {
        Self::from_source(Box::new(BytesSource::new(bytes)), label, false)
    }

    /// [`Session::from_bytes`], scanning every record.
    pub fn from_bytes_scanned(bytes: Vec<u8>, label: impl AsRef<Path>) -> Result<Session> {
        Self::from_source(Box::new(BytesSource::new(bytes)), label, true)
    }

    /// Opens any source of bytes.
    pub fn from_source(
        src: Box<dyn Source>,
        label: impl AsRef<Path>,
        scan: bool,
    ) -> Result<Session> {
        let label = label.as_ref().to_path_buf();
        check_magic(src.as_ref(), &label)?;
        let Opened {
            index,
            attachments,
            metadata,
            message_count,
            damage,
            warnings,
            indexed,
        } = open_source(src.as_ref(), scan);
        Ok(Session {
            inner: Arc::new(Inner {
                label,
                src,
                index,
                attachments,
                metadata,
                message_count,
                open_damage: damage,
                warnings,
                indexed,
                read_damage: Mutex::new(None),
            }),
        })
    }

    /// The file (or label) the session came from.
    pub fn source(&self) -> &Path {
        &self.inner.label
    }

    /// Whether it was opened through its summary (chunks checked when read).
    pub fn is_indexed(&self) -> bool {
        self.inner.indexed
    }

    /// How the file is damaged, as far as known: found when opening, or by a read since.
    /// `None` when no damage has been found.
    pub fn damage(&self) -> Option<Damage> {
        let read = self.inner.read_damage.lock().ok().and_then(|g| g.clone());
        match (&self.inner.open_damage, read) {
            (Some(o), Some(r)) if r.at_byte() < o.at_byte() => Some(r),
            (Some(o), _) => Some(o.clone()),
            (None, r) => r,
        }
    }

    /// Whether no damage has been found.
    pub fn is_complete(&self) -> bool {
        self.damage().is_none()
    }

    /// What opening found wrong (see the module docs).
    pub fn warnings(&self) -> &[String] {
        &self.inner.warnings
    }

    /// Size of the file, bytes.
    pub fn file_len(&self) -> u64 {
        self.inner.src.len()
    }

    /// Number of messages (from the statistics, or counted by the scan).
    pub fn len(&self) -> usize {
        usize::try_from(self.inner.message_count).unwrap_or(usize::MAX)
    }

    /// Whether there are no messages.
    pub fn is_empty(&self) -> bool {
        self.inner.message_count == 0
    }

    /// Number of chunks (and runs of unchunked messages).
    pub fn chunk_count(&self) -> usize {
        self.inner.index.chunks.len()
    }

    /// Time of the first message, ns.
    pub fn start_ns(&self) -> Option<u64> {
        self.inner.index.span_ns.map(|s| s.0)
    }

    /// Time of the last message, ns.
    pub fn end_ns(&self) -> Option<u64> {
        self.inner.index.span_ns.map(|s| s.1)
    }

    /// From the first to the last message, s.
    pub fn duration_s(&self) -> f64 {
        match self.inner.index.span_ns {
            Some((a, b)) => b.saturating_sub(a) as f64 * 1e-9,
            None => 0.0,
        }
    }

    /// The topics, sorted by name.
    pub fn topics(&self) -> Vec<TopicSummary> {
        self.inner.index.topic_summaries()
    }

    /// Topics that are not known (kept undecoded).
    pub fn unknown_topics(&self) -> Vec<&str> {
        self.inner
            .index
            .topics
            .iter()
            .filter(|t| t.known.is_none())
            .map(|t| t.name.as_str())
            .collect()
    }

    /// Messages on a topic.
    pub fn count(&self, topic: &str) -> usize {
        let n = self
            .inner
            .index
            .topic_by_name
            .get(topic)
            .map_or(0, |&t| self.inner.index.topic_count(t));
        usize::try_from(n).unwrap_or(usize::MAX)
    }

    /// A read; see [`crate::stream`].
    pub fn read(&self, opts: ReadOptions) -> Messages {
        Messages::new(Arc::clone(&self.inner), opts)
    }

    /// Every message in time order (equal times keep file order).
    pub fn messages(&self) -> Messages {
        self.read(ReadOptions::all())
    }

    /// Every message in file order.
    pub fn messages_in_file_order(&self) -> Messages {
        self.read(ReadOptions {
            file_order: true,
            ..ReadOptions::all()
        })
    }

    /// The messages of one topic, in time order.
    pub fn topic_messages(&self, topic: &str) -> Messages {
        self.read(ReadOptions::topics(&[topic]))
    }

    /// Reads every message and reports what the read found (damage anywhere, messages out
    /// of order, gaps).
    pub fn check(&self) -> ReadReport {
        let mut m = self.messages_in_file_order();
        for _ in m.by_ref() {}
        let mut r = m.report();
        if r.damage.is_none() {
            r.damage = self.damage();
        }
        r
    }

    fn check_encoding<T: Record>(&self) -> Result<()> {
        let name = T::TOPIC.name();
        if let Some(t) = self
            .inner
            .index
            .topic_by_name
            .get(name)
            .and_then(|&i| self.inner.index.topics.get(i))
            && t.known.is_none()
        {
            return Err(SessionError::WrongEncoding {
                topic: name.into(),
                found: t.encoding.clone(),
                expected: T::TOPIC.encoding(),
            });
        }
        Ok(())
    }

    /// The records of `T`'s topic, decoded one by one as the stream reaches them, in time
    /// order.
    pub fn record_stream<T: Record>(
        &self,
    ) -> Result<impl Iterator<Item = Result<(u64, T)>> + use<T>> {
        self.check_encoding::<T>()?;
        Ok(self
            .topic_messages(T::TOPIC.name())
            .map(|m| m.as_ref().json::<T>().map(|r| (m.t_ns, r))))
    }

    /// Every record of `T`'s topic, in time order (held in memory: for short sessions and
    /// tests; long ones use [`Session::record_stream`]).
    pub fn records<T: Record>(&self) -> Result<Vec<(u64, T)>> {
        self.record_stream::<T>()?.collect()
    }

    /// The raw frames of one direction, in time order.
    pub fn raw_frames(&self, direction: Direction) -> impl Iterator<Item = (u64, Vec<u8>)> + use<> {
        self.topic_messages(direction.topic().name())
            .filter(|m| m.known().is_some())
            .map(|m| (m.t_ns, m.data().to_vec()))
    }

    /// The last message of a topic strictly before `t_ns`, reading only the chunks that
    /// can hold it (backwards from `t_ns`).
    pub fn last_before(&self, topic: &str, t_ns: u64) -> Option<Message> {
        self.last_where(topic, t_ns, |_| true)
    }

    /// The last message of a topic strictly before `t_ns` that `pred` accepts, reading
    /// chunks backwards from `t_ns` until one is found.
    pub fn last_where(
        &self,
        topic: &str,
        t_ns: u64,
        pred: impl Fn(&Message) -> bool,
    ) -> Option<Message> {
        let ix = &self.inner.index;
        let ids = ix.channels_of_topic(topic);
        if ids.is_empty() || t_ns == 0 {
            return None;
        }
        let filter = crate::chunk::ChannelFilter::only(ids);
        // Candidate chunks: hold the topic and start before t, latest start first.
        let mut cands: Vec<u32> = ix
            .by_time
            .iter()
            .copied()
            .filter(|&i| {
                ix.chunks.get(i as usize).is_some_and(|c| {
                    c.start_ns < t_ns
                        && c.messages != Some(0)
                        && filter.wants_any(ix.channels_of(c))
                })
            })
            .collect();
        cands.reverse();
        // The latest end among the candidates from k on: no message there is later.
        let mut max_end_from: Vec<u64> = cands
            .iter()
            .map(|&i| ix.chunks.get(i as usize).map_or(0, |c| c.end_ns))
            .collect();
        for k in (0..max_end_from.len().saturating_sub(1)).rev() {
            let later = max_end_from.get(k + 1).copied().unwrap_or(0);
            if let Some(v) = max_end_from.get_mut(k) {
                *v = (*v).max(later);
            }
        }
        let mut best: Option<Message> = None;
        let mut dec = crate::chunk::Decompressors::default();
        for (k, ci) in cands.into_iter().enumerate() {
            let Some(c) = ix.chunks.get(ci as usize) else {
                continue;
            };
            let reachable = max_end_from.get(k).copied().unwrap_or(0).min(t_ns - 1);
            if best.as_ref().is_some_and(|b| b.t_ns >= reachable) {
                break;
            }
            let d = match crate::stream::decode_chunk_at(&self.inner, ci, &filter, true, &mut dec) {
                Ok(d) => d,
                Err(detail) => {
                    self.inner.note_damage(&Damage::Corrupt {
                        at_byte: c.offset,
                        detail,
                        messages_recovered: 0,
                    });
                    continue;
                }
            };
            let hit = d.locs.iter().rev().filter(|l| l.t_ns < t_ns).find_map(|l| {
                let topic = ix.topic_of_channel(l.channel_id)?;
                let m = Message {
                    t_ns: l.t_ns,
                    sequence: l.sequence,
                    channel_id: l.channel_id,
                    topic: Arc::clone(topic),
                    data: crate::message::Payload::new(
                        Arc::clone(&d.buf),
                        l.start as usize,
                        l.len as usize,
                    ),
                };
                pred(&m).then_some(m)
            });
            if let Some(m) = hit
                && best.as_ref().is_none_or(|b| m.t_ns >= b.t_ns)
            {
                best = Some(m);
            }
        }
        best
    }

    /// For each topic, its last message strictly before `t_ns`, in time order (the state at
    /// a position after a seek).
    pub fn latest_before(&self, t_ns: u64) -> Vec<Message> {
        let mut out: Vec<Message> = self
            .inner
            .index
            .topics
            .iter()
            .filter_map(|t| self.last_before(&t.name, t_ns))
            .collect();
        out.sort_by_key(|m| m.t_ns);
        out
    }

    /// The first `/session/info` message, if any decodes.
    pub fn info(&self) -> Option<SessionInfo> {
        self.topic_messages(Topic::SessionInfo.name())
            .find_map(|m| m.decode::<SessionInfo>().ok())
    }

    /// The attachments (the writer stores `config.toml`).
    pub fn attachments(&self) -> &[AttachmentData] {
        &self.inner.attachments
    }

    /// The metadata records (the writer stores `session`).
    pub fn metadata(&self) -> &[(String, BTreeMap<String, String>)] {
        &self.inner.metadata
    }

    /// The configuration text: the `config.toml` attachment, else `/session/info`.
    pub fn config_toml(&self) -> Option<String> {
        self.inner
            .attachments
            .iter()
            .find(|a| a.name == "config.toml")
            .and_then(|a| String::from_utf8(a.data.clone()).ok())
            .or_else(|| self.info().map(|i| i.config_toml))
    }

    /// The schema records, by id.
    pub fn schemas(&self) -> &BTreeMap<u16, SchemaDef> {
        &self.inner.index.schemas
    }

    /// The channel records, by id.
    pub fn channels(&self) -> &BTreeMap<u16, ChannelDef> {
        &self.inner.index.channels
    }
}
