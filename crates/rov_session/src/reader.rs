//! Loading a session: [`open`] / [`Session`].
//!
//! # What is read
//!
//! Every message of the data section, in one linear pass over the file held in memory.
//! Chunks (uncompressed or zstd) are decompressed once (on up to 4 threads) and checked
//! against their CRC, then taken in file order;
//! messages outside chunks (other writers' unchunked files) are read too. When the file is
//! complete, the summary (statistics) is used first to size the tables and afterwards to
//! cross-check the message count, and the data-section CRC is verified.
//!
//! # Lazy decoding
//!
//! Opening indexes messages (time, topic, sequence, where the bytes are) but parses no
//! JSON: [`Session::records`] decodes one topic when asked, so opening a one-hour file costs
//! about the decompression of its chunks.
//!
//! # Damaged files
//!
//! * Not MCAP (empty, a PNG, text, random bytes): [`SessionError::NotMcap`].
//! * Cut short anywhere (a recording killed, a partial copy): every complete record before
//!   the cut is returned and [`Session::damage`] is [`Damage::Truncated`] with the byte
//!   offset of the first incomplete record. A chunk is all or nothing.
//! * A record that is complete but wrong (CRC mismatch, malformed body, unknown
//!   compression): reading stops there and reports [`Damage::Corrupt`]; every record
//!   before it is returned. Nothing is skipped silently.
//!
//! Lengths are checked against the bytes present before any allocation, and a chunk may
//! claim at most [`MAX_CHUNK_BYTES`] uncompressed.
//!
//! # Warnings
//!
//! [`Session::warnings`] lists what loaded but looks wrong: messages out of time order
//! (sorted), gaps in a topic, unknown topics (kept undecoded), a summary that disagrees
//! with the data, bytes after the end of the file.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;

use crate::error::{Result, SessionError, io_err};
use crate::record::{
    AutopilotRecord, Direction, EventRecord, JSON_ENCODING, LinkRecord, NavRecord, ObserverRecord,
    PilotRecord, Record, SessionInfo, StatusRecord, ThrustRecord, Topic, TruthRecord,
};
use crate::wire::{
    self, AttachmentData, ChannelDef, FOOTER_RECORD_LEN, MAGIC, MESSAGE_HEAD_LEN, SchemaDef, op,
};

/// Largest uncompressed chunk the reader accepts, bytes.
pub const MAX_CHUNK_BYTES: u64 = 256 << 20;

/// How a file is damaged.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Damage {
    /// The file ends inside a record, or without its footer.
    Truncated {
        /// Offset of the first byte that is not part of a complete record.
        at_byte: u64,
        /// Messages read before it.
        messages_recovered: u64,
    },
    /// A complete record is invalid; reading stopped there.
    Corrupt {
        /// Offset of the bad record.
        at_byte: u64,
        /// What is wrong.
        detail: String,
        /// Messages read before it.
        messages_recovered: u64,
    },
}

impl Damage {
    /// Offset of the first byte not recovered.
    pub fn at_byte(&self) -> u64 {
        match self {
            Damage::Truncated { at_byte, .. } | Damage::Corrupt { at_byte, .. } => *at_byte,
        }
    }

    /// Messages recovered before the damage.
    pub fn messages_recovered(&self) -> u64 {
        match self {
            Damage::Truncated {
                messages_recovered, ..
            }
            | Damage::Corrupt {
                messages_recovered, ..
            } => *messages_recovered,
        }
    }
}

impl std::fmt::Display for Damage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Damage::Truncated {
                at_byte,
                messages_recovered,
            } => write!(
                f,
                "truncated: the file ends inside a record or without its footer at byte {at_byte}; \
                 {messages_recovered} messages before it recovered"
            ),
            Damage::Corrupt {
                at_byte,
                detail,
                messages_recovered,
            } => write!(
                f,
                "corrupt record at byte {at_byte} ({detail}); reading stopped there; \
                 {messages_recovered} messages before it recovered"
            ),
        }
    }
}

/// Where a message's bytes are: buffer 0 is the file, buffer i > 0 is decompressed chunk i−1.
#[derive(Debug, Clone, Copy)]
struct Msg {
    t_ns: u64,
    off: u64,
    len: u32,
    buf: u32,
    sequence: u32,
    channel_id: u16,
    topic: u16,
}

/// One topic of a loaded session.
#[derive(Debug, Clone)]
struct TopicData {
    name: String,
    encoding: String,
    schema_name: Option<String>,
    known: Option<Topic>,
    /// Positions in time order.
    positions: Vec<u32>,
}

/// A topic's summary.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TopicSummary {
    /// Topic name.
    pub topic: String,
    /// Message encoding.
    pub encoding: String,
    /// Schema name, if any.
    pub schema_name: Option<String>,
    /// The known topic, or `None` for an unknown topic (kept undecoded).
    pub known: Option<Topic>,
    /// Messages.
    pub count: usize,
    /// First and last message time, ns.
    pub first_ns: u64,
    /// Last message time, ns.
    pub last_ns: u64,
}

/// A message of a loaded session, borrowed from it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MessageRef<'a> {
    /// Log time, ns (the writer's time base).
    pub t_ns: u64,
    /// Sequence number within its channel.
    pub sequence: u32,
    /// MCAP channel id.
    pub channel_id: u16,
    /// Topic name.
    pub topic: &'a str,
    /// The known topic, if it is one with the expected encoding.
    pub known: Option<Topic>,
    /// Message encoding.
    pub encoding: &'a str,
    /// The message bytes (JSON text or a raw frame).
    pub data: &'a [u8],
}

/// A message decoded by its topic.
#[derive(Debug, Clone, PartialEq)]
#[allow(clippy::large_enum_variant)]
pub enum Decoded<'a> {
    /// `/telemetry/nav`.
    Nav(NavRecord),
    /// `/telemetry/status`.
    Status(StatusRecord),
    /// `/command/thrust`.
    Thrust(ThrustRecord),
    /// `/pilot/input`.
    Pilot(PilotRecord),
    /// `/autopilot/state`.
    Autopilot(AutopilotRecord),
    /// `/observer/state`.
    Observer(ObserverRecord),
    /// `/link/stats`.
    Link(LinkRecord),
    /// `/events`.
    Event(EventRecord),
    /// `/truth/state`.
    Truth(TruthRecord),
    /// `/session/info`.
    Info(SessionInfo),
    /// A raw frame.
    Raw {
        /// Direction.
        direction: Direction,
        /// The frame.
        frame: &'a [u8],
    },
    /// An unknown topic with JSON messages.
    UnknownJson(serde_json::Value),
    /// An unknown topic with another encoding.
    UnknownBytes(&'a [u8]),
}

impl<'a> MessageRef<'a> {
    /// Decodes the message as a record type (its topic must be `T::TOPIC`).
    pub fn decode<T: Record>(&self) -> Result<T> {
        if self.known != Some(T::TOPIC) {
            return Err(SessionError::Decode {
                topic: self.topic.to_string(),
                sequence: self.sequence,
                t_ns: self.t_ns,
                detail: format!("not a {} message", T::TOPIC.name()),
            });
        }
        self.json()
    }

    fn json<T: DeserializeOwned>(&self) -> Result<T> {
        serde_json::from_slice(self.data).map_err(|e| SessionError::Decode {
            topic: self.topic.to_string(),
            sequence: self.sequence,
            t_ns: self.t_ns,
            detail: e.to_string(),
        })
    }

    /// Decodes the message by its topic; unknown topics come back as JSON or bytes.
    pub fn decode_any(&self) -> Result<Decoded<'a>> {
        Ok(match self.known {
            Some(Topic::Pro4Tx) => Decoded::Raw {
                direction: Direction::Tx,
                frame: self.data,
            },
            Some(Topic::Pro4Rx) => Decoded::Raw {
                direction: Direction::Rx,
                frame: self.data,
            },
            Some(Topic::Nav) => Decoded::Nav(self.json()?),
            Some(Topic::Status) => Decoded::Status(self.json()?),
            Some(Topic::Thrust) => Decoded::Thrust(self.json()?),
            Some(Topic::Pilot) => Decoded::Pilot(self.json()?),
            Some(Topic::Autopilot) => Decoded::Autopilot(self.json()?),
            Some(Topic::Observer) => Decoded::Observer(self.json()?),
            Some(Topic::Link) => Decoded::Link(self.json()?),
            Some(Topic::Events) => Decoded::Event(self.json()?),
            Some(Topic::Truth) => Decoded::Truth(self.json()?),
            Some(Topic::SessionInfo) => Decoded::Info(self.json()?),
            None if self.encoding == JSON_ENCODING => Decoded::UnknownJson(self.json()?),
            None => Decoded::UnknownBytes(self.data),
        })
    }
}

/// A loaded session. See the module docs.
#[derive(Debug)]
pub struct Session {
    source: PathBuf,
    file: Vec<u8>,
    chunks: Vec<Vec<u8>>,
    /// Messages in file order.
    msgs: Vec<Msg>,
    /// Time order: indices into `msgs`.
    order: Vec<u32>,
    topics: Vec<TopicData>,
    topic_by_name: HashMap<String, u16>,
    schemas: BTreeMap<u16, SchemaDef>,
    channels: BTreeMap<u16, ChannelDef>,
    attachments: Vec<AttachmentData>,
    metadata: Vec<(String, BTreeMap<String, String>)>,
    damage: Option<Damage>,
    /// What loaded but looks wrong (see the module docs).
    pub warnings: Vec<String>,
}

/// Opens a session file. See the module docs for damaged files.
pub fn open(path: impl AsRef<Path>) -> Result<Session> {
    Session::open(path)
}

impl Session {
    /// Opens a session file. See the module docs for damaged files.
    pub fn open(path: impl AsRef<Path>) -> Result<Session> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(io_err(path, "read"))?;
        Self::from_bytes(bytes, path)
    }

    /// Loads a session from bytes; `label` names it in errors.
    pub fn from_bytes(bytes: Vec<u8>, label: impl AsRef<Path>) -> Result<Session> {
        let label = label.as_ref().to_path_buf();
        check_magic(&bytes, &label)?;
        let mut l = Loader::default();
        l.load(&bytes);
        Ok(l.into_session(bytes, label))
    }

    /// The file (or label) the session came from.
    pub fn source(&self) -> &Path {
        &self.source
    }

    /// How the file is damaged, `None` when it is complete and intact.
    pub fn damage(&self) -> Option<&Damage> {
        self.damage.as_ref()
    }

    /// Whether the file is complete and intact.
    pub fn is_complete(&self) -> bool {
        self.damage.is_none()
    }

    /// Size of the file, bytes.
    pub fn file_len(&self) -> u64 {
        self.file.len() as u64
    }

    /// Number of messages.
    pub fn len(&self) -> usize {
        self.msgs.len()
    }

    /// Whether there are no messages.
    pub fn is_empty(&self) -> bool {
        self.msgs.is_empty()
    }

    fn msg_at(&self, pos: usize) -> Option<&Msg> {
        let i = *self.order.get(pos)? as usize;
        self.msgs.get(i)
    }

    /// Time of the first message (time order), ns.
    pub fn start_ns(&self) -> Option<u64> {
        self.msg_at(0).map(|m| m.t_ns)
    }

    /// Time of the last message (time order), ns.
    pub fn end_ns(&self) -> Option<u64> {
        self.msg_at(self.order.len().saturating_sub(1))
            .map(|m| m.t_ns)
    }

    /// From the first to the last message, s.
    pub fn duration_s(&self) -> f64 {
        match (self.start_ns(), self.end_ns()) {
            (Some(a), Some(b)) => b.saturating_sub(a) as f64 * 1e-9,
            _ => 0.0,
        }
    }

    fn make_ref(&self, m: &Msg) -> MessageRef<'_> {
        let buf: &[u8] = if m.buf == 0 {
            &self.file
        } else {
            self.chunks
                .get(m.buf as usize - 1)
                .map_or(&[][..], Vec::as_slice)
        };
        let start = usize::try_from(m.off).unwrap_or(usize::MAX);
        let data = buf
            .get(start..start.saturating_add(m.len as usize))
            .unwrap_or(&[]);
        let (topic, encoding, known) = match self.topics.get(m.topic as usize) {
            Some(t) => (t.name.as_str(), t.encoding.as_str(), t.known),
            None => ("", "", None),
        };
        MessageRef {
            t_ns: m.t_ns,
            sequence: m.sequence,
            channel_id: m.channel_id,
            topic,
            known,
            encoding,
            data,
        }
    }

    /// The message at a position in time order.
    pub fn message(&self, pos: usize) -> Option<MessageRef<'_>> {
        self.msg_at(pos).map(|m| self.make_ref(m))
    }

    /// Every message in time order (stable: equal times keep file order).
    pub fn messages(&self) -> impl Iterator<Item = MessageRef<'_>> + '_ {
        self.order
            .iter()
            .filter_map(|&i| self.msgs.get(i as usize))
            .map(|m| self.make_ref(m))
    }

    /// Every message in file order.
    pub fn messages_in_file_order(&self) -> impl Iterator<Item = MessageRef<'_>> + '_ {
        self.msgs.iter().map(|m| self.make_ref(m))
    }

    /// Message times in time order, ns (for playback).
    pub(crate) fn time_at(&self, pos: usize) -> Option<u64> {
        self.msg_at(pos).map(|m| m.t_ns)
    }

    /// First time-order position whose time is ≥ `t_ns`.
    pub(crate) fn lower_bound(&self, t_ns: u64) -> usize {
        let (mut lo, mut hi) = (0usize, self.order.len());
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            if self.time_at(mid).is_some_and(|t| t < t_ns) {
                lo = mid + 1;
            } else {
                hi = mid;
            }
        }
        lo
    }

    /// The topics, sorted by name.
    pub fn topics(&self) -> Vec<TopicSummary> {
        let mut out: Vec<TopicSummary> = self
            .topics
            .iter()
            .map(|t| {
                let time = |p: Option<&u32>| p.and_then(|&p| self.time_at(p as usize)).unwrap_or(0);
                TopicSummary {
                    topic: t.name.clone(),
                    encoding: t.encoding.clone(),
                    schema_name: t.schema_name.clone(),
                    known: t.known,
                    count: t.positions.len(),
                    first_ns: time(t.positions.first()),
                    last_ns: time(t.positions.last()),
                }
            })
            .collect();
        out.sort_by(|a, b| a.topic.cmp(&b.topic));
        out
    }

    /// Topics that are not known (kept undecoded).
    pub fn unknown_topics(&self) -> Vec<&str> {
        self.topics
            .iter()
            .filter(|t| t.known.is_none())
            .map(|t| t.name.as_str())
            .collect()
    }

    /// Messages on a topic.
    pub fn count(&self, topic: &str) -> usize {
        self.topic_by_name
            .get(topic)
            .and_then(|&i| self.topics.get(i as usize))
            .map_or(0, |t| t.positions.len())
    }

    /// Time-order positions of one topic's messages.
    pub(crate) fn topic_positions(&self, topic: &str) -> &[u32] {
        self.topic_by_name
            .get(topic)
            .and_then(|&i| self.topics.get(i as usize))
            .map_or(&[], |t| t.positions.as_slice())
    }

    /// The messages of one topic, in time order.
    pub fn topic_messages<'s>(&'s self, topic: &str) -> impl Iterator<Item = MessageRef<'s>> + 's {
        self.topic_positions(topic)
            .iter()
            .filter_map(move |&p| self.message(p as usize))
    }

    /// Decodes every message of `T`'s topic, in time order, as (time ns, record). Only this
    /// topic's JSON is parsed.
    pub fn records<T: Record>(&self) -> Result<Vec<(u64, T)>> {
        let name = T::TOPIC.name();
        if let Some(t) = self
            .topic_by_name
            .get(name)
            .and_then(|&i| self.topics.get(i as usize))
            && t.known.is_none()
        {
            return Err(SessionError::WrongEncoding {
                topic: name.into(),
                found: t.encoding.clone(),
                expected: T::TOPIC.encoding(),
            });
        }
        self.topic_messages(name)
            .map(|m| Ok((m.t_ns, m.json::<T>()?)))
            .collect()
    }

    /// The raw frames of one direction, in time order.
    pub fn raw_frames(&self, direction: Direction) -> impl Iterator<Item = (u64, &[u8])> + '_ {
        self.topic_messages(direction.topic().name())
            .filter(|m| m.known.is_some())
            .map(|m| (m.t_ns, m.data))
    }

    /// The first `/session/info` message, if any decodes.
    pub fn info(&self) -> Option<SessionInfo> {
        self.topic_messages(Topic::SessionInfo.name())
            .find_map(|m| m.decode::<SessionInfo>().ok())
    }

    /// The attachments (the writer stores `config.toml`).
    pub fn attachments(&self) -> &[AttachmentData] {
        &self.attachments
    }

    /// The metadata records (the writer stores `session`).
    pub fn metadata(&self) -> &[(String, BTreeMap<String, String>)] {
        &self.metadata
    }

    /// The configuration text: the `config.toml` attachment, else `/session/info`.
    pub fn config_toml(&self) -> Option<String> {
        self.attachments
            .iter()
            .find(|a| a.name == "config.toml")
            .and_then(|a| String::from_utf8(a.data.clone()).ok())
            .or_else(|| self.info().map(|i| i.config_toml))
    }

    /// The schema records, by id.
    pub fn schemas(&self) -> &BTreeMap<u16, SchemaDef> {
        &self.schemas
    }

    /// The channel records, by id.
    pub fn channels(&self) -> &BTreeMap<u16, ChannelDef> {
        &self.channels
    }
}

fn check_magic(bytes: &[u8], label: &Path) -> Result<()> {
    let not = |detail: String| SessionError::NotMcap {
        path: label.to_path_buf(),
        detail,
    };
    if bytes.is_empty() {
        return Err(not("the file is empty (0 bytes)".into()));
    }
    let head = bytes.get(..MAGIC.len()).unwrap_or(bytes);
    if MAGIC.starts_with(head) {
        // A prefix of the magic (a file cut in its first 8 bytes) loads as truncated.
        return Ok(());
    }
    if head.get(..5) == MAGIC.get(..5) {
        return Err(not(format!(
            "MCAP magic with unsupported version byte {:#04x}",
            head.get(5).copied().unwrap_or(0)
        )));
    }
    let what = if head.starts_with(&[0x89, b'P', b'N', b'G']) {
        "a PNG image".to_string()
    } else if head.starts_with(b"PK\x03\x04") {
        "a ZIP archive".to_string()
    } else if head.starts_with(&[0x1f, 0x8b]) {
        "a gzip file".to_string()
    } else if head.starts_with(&[0x28, 0xb5, 0x2f, 0xfd]) {
        "a zstd-compressed file (decompress it first)".to_string()
    } else if head.starts_with(b"#ROSBAG") {
        "a ROS 1 bag".to_string()
    } else if bytes
        .iter()
        .take(256)
        .all(|b| b.is_ascii_graphic() || b.is_ascii_whitespace())
    {
        let first_line: String = bytes
            .iter()
            .take(60)
            .take_while(|b| **b != b'\n')
            .map(|&b| b as char)
            .collect();
        format!("a text file (starts with {first_line:?})")
    } else {
        format!("unknown content (first bytes {:02x?})", head)
    };
    Err(not(format!(
        "{what}; an MCAP file starts with \\x89MCAP0\\r\\n"
    )))
}

/// Schemas and channels of one chunk, committed only when the whole chunk is good.
#[derive(Default)]
struct Pending {
    schemas: Vec<SchemaDef>,
    channels: Vec<ChannelDef>,
}

/// "No topic" in [`Loader::channel_topic`].
const NO_TOPIC: u16 = u16::MAX;

struct Loader {
    chunks: Vec<Vec<u8>>,
    msgs: Vec<Msg>,
    schemas: BTreeMap<u16, SchemaDef>,
    channels: BTreeMap<u16, ChannelDef>,
    /// Channel id → topic index ([`NO_TOPIC`] when undefined).
    channel_topic: Vec<u16>,
    topics: Vec<TopicData>,
    topic_by_name: HashMap<String, u16>,
    attachments: Vec<AttachmentData>,
    metadata: Vec<(String, BTreeMap<String, String>)>,
    damage: Option<Damage>,
    warnings: Vec<String>,
    unknown_records: BTreeMap<u8, u64>,
}

impl Default for Loader {
    fn default() -> Self {
        Self {
            chunks: Vec::new(),
            msgs: Vec::new(),
            schemas: BTreeMap::new(),
            channels: BTreeMap::new(),
            channel_topic: vec![NO_TOPIC; usize::from(u16::MAX) + 1],
            topics: Vec::new(),
            topic_by_name: HashMap::new(),
            attachments: Vec::new(),
            metadata: Vec::new(),
            damage: None,
            warnings: Vec::new(),
            unknown_records: BTreeMap::new(),
        }
    }
}

/// What the summary says, when the file has a valid one.
struct SummaryHint {
    summary_start: usize,
    stats: Option<wire::Stats>,
    /// Where the chunk indexes say the chunks start, sorted.
    chunk_offsets: Vec<u64>,
}

/// Whether the file ends with a well-framed footer and the end magic.
fn footer_ok(file: &[u8]) -> bool {
    let len = file.len();
    let Some(footer_pos) = len.checked_sub(MAGIC.len() + FOOTER_RECORD_LEN) else {
        return false;
    };
    footer_pos >= MAGIC.len()
        && file.get(len - MAGIC.len()..) == Some(&MAGIC[..])
        && wire::frame(file, footer_pos)
            .is_some_and(|f| f.opcode == op::FOOTER && f.end == len - MAGIC.len())
}

fn summary_hint(file: &[u8], warnings: &mut Vec<String>) -> Option<SummaryHint> {
    let len = file.len();
    if len < MAGIC.len() * 2 + FOOTER_RECORD_LEN || file.get(len - MAGIC.len()..)? != MAGIC {
        return None;
    }
    let footer_pos = len - MAGIC.len() - FOOTER_RECORD_LEN;
    let f = wire::frame(file, footer_pos)?;
    if f.opcode != op::FOOTER || f.end != len - MAGIC.len() {
        return None;
    }
    let footer = wire::footer(f.body)?;
    if footer.summary_start == 0 {
        return None;
    }
    let summary_start = usize::try_from(footer.summary_start).ok()?;
    if summary_start < MAGIC.len() || summary_start > footer_pos {
        warnings.push(format!(
            "the footer's summary offset {summary_start} is out of range; summary ignored"
        ));
        return None;
    }
    if footer.summary_crc != 0 {
        // CRC of the summary section through the footer's summary_offset_start field.
        let covered = file.get(summary_start..f.body_start + 16)?;
        if crc32fast::hash(covered) != footer.summary_crc {
            warnings.push("the summary section fails its CRC; summary ignored".into());
            return None;
        }
    }
    let mut stats = None;
    let mut chunk_offsets = Vec::new();
    let mut pos = summary_start;
    while pos < footer_pos {
        let r = wire::frame(file, pos)?;
        if r.opcode == op::STATISTICS {
            stats = wire::statistics(r.body);
        }
        if r.opcode == op::CHUNK_INDEX {
            // message_start_time, message_end_time, then chunk_start_offset.
            let mut rd = wire::Rd::new(r.body);
            let offset = rd.u64().and_then(|_| rd.u64()).and_then(|_| rd.u64());
            chunk_offsets.push(offset?);
        }
        pos = r.end;
    }
    chunk_offsets.sort_unstable();
    Some(SummaryHint {
        summary_start,
        stats,
        chunk_offsets,
    })
}

/// A top-level record of the data section, framed in the first pass.
enum Item<'a> {
    Record(wire::Framed<'a>, usize),
    /// A chunk (decoded in parallel, committed in order).
    Chunk(wire::Framed<'a>, usize),
}

/// How the first pass ended.
enum End {
    /// Footer and end magic found.
    Complete,
    /// Records stop fitting at this offset.
    Truncated(usize),
    /// A bad record at this offset.
    Corrupt(usize, String),
}

/// A chunk's content: `None` for an uncompressed chunk (read in place), or the
/// decompressed bytes.
type ChunkContent = Result<Option<Vec<u8>>, String>;

/// Decompresses a chunk and checks its CRC (runs on worker threads).
fn decode_chunk(
    dec: &mut Option<zstd::bulk::Decompressor<'static>>,
    r: &wire::Framed<'_>,
) -> ChunkContent {
    let c = wire::chunk(r.body).ok_or("malformed chunk record")?;
    if c.uncompressed_size > MAX_CHUNK_BYTES {
        return Err(format!(
            "chunk claims {} bytes uncompressed, more than the {} byte limit",
            c.uncompressed_size, MAX_CHUNK_BYTES
        ));
    }
    let size = c.uncompressed_size as usize;
    let decompressed = match c.compression {
        "" => {
            if c.records.len() != size {
                return Err(format!(
                    "uncompressed chunk holds {} bytes but claims {}",
                    c.records.len(),
                    size
                ));
            }
            None
        }
        "zstd" => {
            let d = match dec {
                Some(d) => d,
                None => {
                    dec.insert(zstd::bulk::Decompressor::new().map_err(|e| format!("zstd: {e}"))?)
                }
            };
            let mut out = Vec::with_capacity(size);
            let n = d
                .decompress_to_buffer(c.records, &mut out)
                .map_err(|e| format!("zstd chunk does not decompress: {e}"))?;
            if n != size {
                return Err(format!(
                    "zstd chunk decompresses to {n} bytes but claims {size}"
                ));
            }
            Some(out)
        }
        "lz4" => {
            let mut out = vec![0u8; size];
            let mut d = lz4::Decoder::new(c.records)
                .map_err(|e| format!("lz4 chunk does not decompress: {e}"))?;
            std::io::Read::read_exact(&mut d, &mut out).map_err(|e| {
                format!("lz4 chunk does not decompress to the {size} bytes it claims: {e}")
            })?;
            let mut extra = [0u8; 1];
            if std::io::Read::read(&mut d, &mut extra).map_err(|e| format!("lz4 chunk: {e}"))? != 0
            {
                return Err(format!(
                    "lz4 chunk decompresses to more than the {size} bytes it claims"
                ));
            }
            Some(out)
        }
        other => return Err(format!("unknown chunk compression {other:?}")),
    };
    let content: &[u8] = decompressed.as_deref().unwrap_or(c.records);
    if c.uncompressed_crc != 0 && crc32fast::hash(content) != c.uncompressed_crc {
        return Err("chunk CRC mismatch (the chunk's content was altered)".into());
    }
    Ok(decompressed)
}

/// Decodes every chunk, on up to 4 threads.
fn decode_chunks(chunks: &[wire::Framed<'_>]) -> Vec<ChunkContent> {
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .clamp(1, 4);
    if threads == 1 || chunks.len() < 16 {
        let mut dec = None;
        return chunks.iter().map(|c| decode_chunk(&mut dec, c)).collect();
    }
    let per = chunks.len().div_ceil(threads);
    std::thread::scope(|scope| {
        let handles: Vec<_> = chunks
            .chunks(per)
            .map(|part| {
                scope.spawn(move || {
                    let mut dec = None;
                    part.iter()
                        .map(|c| decode_chunk(&mut dec, c))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        let mut out = Vec::with_capacity(chunks.len());
        for (h, part) in handles.into_iter().zip(chunks.chunks(per)) {
            match h.join() {
                Ok(mut v) => out.append(&mut v),
                // A worker cannot panic (no panicking code), but stay total.
                Err(_) => out.extend(
                    part.iter()
                        .map(|_| Err("chunk decoder thread failed".to_string())),
                ),
            }
        }
        out
    })
}

impl Loader {
    fn damage_truncated(&mut self, at: usize) {
        self.damage = Some(Damage::Truncated {
            at_byte: at as u64,
            messages_recovered: self.msgs.len() as u64,
        });
    }

    fn damage_corrupt(&mut self, at: usize, detail: String) {
        self.damage = Some(Damage::Corrupt {
            at_byte: at as u64,
            detail,
            messages_recovered: self.msgs.len() as u64,
        });
    }

    /// First pass: frame the data section. Stops at the footer, at the first record that
    /// does not fit, or at a bad footer.
    fn frame_all<'a>(
        &mut self,
        file: &'a [u8],
        hint: Option<&SummaryHint>,
    ) -> (Vec<Item<'a>>, Vec<wire::Framed<'a>>, End) {
        let mut items = Vec::new();
        let mut chunks = Vec::new();
        let mut pos = MAGIC.len();
        let mut in_summary = false;
        loop {
            if pos == file.len() {
                return (items, chunks, End::Truncated(pos));
            }
            let Some(r) = wire::frame(file, pos) else {
                return (items, chunks, End::Truncated(pos));
            };
            if hint.is_some_and(|h| pos >= h.summary_start) {
                in_summary = true;
            }
            match r.opcode {
                op::FOOTER => {
                    let tail = file.get(r.end..).unwrap_or(&[]);
                    if tail.len() < MAGIC.len() {
                        return (items, chunks, End::Truncated(r.end));
                    }
                    if tail.get(..MAGIC.len()) != Some(&MAGIC[..]) {
                        let detail = "the footer is not followed by the MCAP end magic".to_string();
                        return (items, chunks, End::Corrupt(r.end, detail));
                    }
                    if tail.len() > MAGIC.len() {
                        self.warnings.push(format!(
                            "{} bytes after the end magic ignored",
                            tail.len() - MAGIC.len()
                        ));
                    }
                    return (items, chunks, End::Complete);
                }
                op::DATA_END => {
                    if hint.is_some_and(|h| h.summary_start != r.end) {
                        let detail =
                            "a data-end record where the summary says the data goes on".to_string();
                        return (items, chunks, End::Corrupt(pos, detail));
                    }
                    in_summary = true;
                    let crc = wire::Rd::new(r.body).u32().unwrap_or(0);
                    if crc != 0 && file.get(..pos).is_some_and(|d| crc32fast::hash(d) != crc) {
                        self.warnings.push(
                            "the data section fails its CRC: bytes outside the CRC-checked chunks \
                             (e.g. indexes, unchunked messages) were altered"
                                .into(),
                        );
                    }
                    if footer_ok(file) {
                        // The data is complete and the file ends properly: the summary
                        // between here and the footer is only an index.
                        return (items, chunks, End::Complete);
                    }
                }
                _ if in_summary => {}
                op::CHUNK => {
                    items.push(Item::Chunk(r, pos));
                    chunks.push(r);
                }
                op::HEADER
                | op::SCHEMA
                | op::CHANNEL
                | op::MESSAGE
                | op::ATTACHMENT
                | op::METADATA => {
                    items.push(Item::Record(r, pos));
                }
                op::MESSAGE_INDEX
                | op::CHUNK_INDEX
                | op::ATTACHMENT_INDEX
                | op::METADATA_INDEX
                | op::STATISTICS
                | op::SUMMARY_OFFSET => {}
                other => *self.unknown_records.entry(other).or_insert(0) += 1,
            }
            pos = r.end;
        }
    }

    fn load(&mut self, file: &[u8]) {
        if file.len() < MAGIC.len() {
            self.damage_truncated(0);
            return;
        }
        let hint = summary_hint(file, &mut self.warnings);
        if let Some(s) = hint.as_ref().and_then(|h| h.stats.as_ref()) {
            // Sizing only; capped so a bad count cannot force a huge allocation.
            self.msgs
                .reserve(usize::try_from(s.message_count.min(1 << 26)).unwrap_or(0));
            self.chunks.reserve(s.chunk_count.min(1 << 20) as usize);
        }
        let (items, chunk_records, end) = self.frame_all(file, hint.as_ref());
        let mut decoded = decode_chunks(&chunk_records).into_iter();
        // Writers that chunk put every message in a chunk: a bare message record in such a
        // file is a damaged header (e.g. a message index whose opcode flipped).
        let chunked =
            !chunk_records.is_empty() || hint.as_ref().is_some_and(|h| !h.chunk_offsets.is_empty());
        // (record offset, messages before it) of every chunk taken.
        let mut taken: Vec<(u64, usize)> = Vec::with_capacity(chunk_records.len());
        for item in items {
            let res = match item {
                Item::Chunk(r, pos) => {
                    taken.push((pos as u64, self.msgs.len()));
                    let content = decoded
                        .next()
                        .unwrap_or_else(|| Err("chunk not decoded".into()));
                    content
                        .and_then(|c| self.chunk(&r, c))
                        .map_err(|e| (pos, e))
                }
                Item::Record(r, pos) if r.opcode == op::MESSAGE && chunked => Err((
                    pos,
                    "a message record outside the chunks of a chunked file (a damaged record header)".to_string(),
                )),
                Item::Record(r, pos) => self.record(&r).map_err(|e| (pos, e)),
            };
            if let Err((pos, detail)) = res {
                self.damage_corrupt(pos, detail);
                return;
            }
        }
        let complete = matches!(end, End::Complete);
        if complete && let Some(h) = &hint {
            // Every chunk the summary lists must have been read as a chunk; the first one
            // missing (a damaged record header) ends the trustworthy prefix.
            let missing = h
                .chunk_offsets
                .iter()
                .find(|o| taken.binary_search_by_key(*o, |t| t.0).is_err());
            if let Some(&at) = missing {
                let keep = taken
                    .iter()
                    .find(|t| t.0 > at)
                    .map_or(self.msgs.len(), |t| t.1);
                self.msgs.truncate(keep);
                let detail = format!(
                    "the summary lists a chunk at byte {at} that the data section does not hold"
                );
                self.damage_corrupt(at as usize, detail);
                return;
            }
        }
        match end {
            End::Complete => {}
            End::Truncated(at) => self.damage_truncated(at),
            End::Corrupt(at, detail) => self.damage_corrupt(at, detail),
        }
        for (opcode, n) in std::mem::take(&mut self.unknown_records) {
            self.warnings.push(format!(
                "{n} records with unknown opcode {opcode:#04x} skipped"
            ));
        }
        if let (true, Some(stats)) = (complete, hint.and_then(|h| h.stats))
            && stats.message_count != self.msgs.len() as u64
        {
            self.warnings.push(format!(
                "the summary counts {} messages, the data section holds {}",
                stats.message_count,
                self.msgs.len()
            ));
        }
    }

    /// A top-level record other than a chunk.
    fn record(&mut self, r: &wire::Framed<'_>) -> Result<(), String> {
        match r.opcode {
            op::HEADER => {
                let mut rd = wire::Rd::new(r.body);
                rd.str()
                    .and_then(|_| rd.str())
                    .ok_or("malformed header record")?;
            }
            op::ATTACHMENT => self.attachments.push(wire::attachment(r.body)?),
            op::METADATA => self
                .metadata
                .push(wire::metadata(r.body).ok_or("malformed metadata record")?),
            _ => {
                let mut p = Pending::default();
                let mark = self.msgs.len();
                let res = self
                    .inner_record(&mut p, r.opcode, r.body, 0, r.body_start as u64)
                    .and_then(|()| self.commit(p, mark, None));
                if res.is_err() {
                    self.msgs.truncate(mark);
                }
                res?;
            }
        }
        Ok(())
    }

    /// A chunk whose content was decoded (and CRC-checked) by [`decode_chunk`]: all its
    /// records or none.
    fn chunk(&mut self, r: &wire::Framed<'_>, decompressed: Option<Vec<u8>>) -> Result<(), String> {
        let c = wire::chunk(r.body).ok_or("malformed chunk record")?;
        let content: &[u8] = decompressed.as_deref().unwrap_or(c.records);
        let (buf, base) = match &decompressed {
            Some(_) => (self.chunks.len() as u32 + 1, 0u64),
            None => (0, (r.body_start + c.records_start) as u64),
        };
        let mut p = Pending::default();
        let mark = self.msgs.len();
        let mut pos = 0usize;
        let mut res = Ok(());
        while pos < content.len() {
            let Some(inner) = wire::frame(content, pos) else {
                res = Err(format!("record cut short inside the chunk at {pos}"));
                break;
            };
            res = match inner.opcode {
                op::SCHEMA | op::CHANNEL | op::MESSAGE => self.inner_record(
                    &mut p,
                    inner.opcode,
                    inner.body,
                    buf,
                    base + inner.body_start as u64,
                ),
                other if other >= 0x80 => Ok(()),
                other => Err(format!("record with opcode {other:#04x} inside a chunk")),
            };
            if res.is_err() {
                break;
            }
            pos = inner.end;
        }
        let res = res.and_then(|()| self.commit(p, mark, decompressed));
        if res.is_err() {
            self.msgs.truncate(mark);
        }
        res
    }

    /// Parses a schema or channel record into `p`, or a message into `self.msgs` (undone by
    /// the caller when the chunk turns out bad).
    fn inner_record(
        &mut self,
        p: &mut Pending,
        opcode: u8,
        body: &[u8],
        buf: u32,
        body_off: u64,
    ) -> Result<(), String> {
        match opcode {
            op::SCHEMA => {
                let s = wire::schema(body).ok_or("malformed schema record")?;
                if s.id == 0 {
                    return Err("schema record with id 0".into());
                }
                p.schemas.push(s);
            }
            op::CHANNEL => {
                let c = wire::channel(body).ok_or("malformed channel record")?;
                let schema_known = c.schema_id == 0
                    || self.schemas.contains_key(&c.schema_id)
                    || p.schemas.iter().any(|s| s.id == c.schema_id);
                if !schema_known {
                    return Err(format!(
                        "channel {} ({}) names unknown schema {}",
                        c.id, c.topic, c.schema_id
                    ));
                }
                p.channels.push(c);
            }
            _ => {
                let h = wire::message_head(body).ok_or("malformed message record")?;
                let topic = self
                    .channel_topic
                    .get(usize::from(h.channel_id))
                    .copied()
                    .unwrap_or(NO_TOPIC);
                if topic == NO_TOPIC && !p.channels.iter().any(|c| c.id == h.channel_id) {
                    return Err(format!("message on undefined channel {}", h.channel_id));
                }
                let len = u32::try_from(body.len() - MESSAGE_HEAD_LEN)
                    .map_err(|_| "message too large")?;
                self.msgs.push(Msg {
                    t_ns: h.log_time,
                    off: body_off + MESSAGE_HEAD_LEN as u64,
                    len,
                    buf,
                    sequence: h.sequence,
                    channel_id: h.channel_id,
                    topic,
                });
            }
        }
        Ok(())
    }

    /// Makes a good chunk's schemas and channels visible and resolves the topics of its
    /// messages (from `mark` on) that name channels defined in the same chunk.
    fn commit(&mut self, p: Pending, mark: usize, chunk: Option<Vec<u8>>) -> Result<(), String> {
        let new_channels = !p.channels.is_empty();
        for s in p.schemas {
            match self.schemas.get(&s.id) {
                Some(old) if *old != s => {
                    self.warnings.push(format!(
                        "schema {} redefined differently; the first kept",
                        s.id
                    ));
                }
                Some(_) => {}
                None => {
                    self.schemas.insert(s.id, s);
                }
            }
        }
        for c in p.channels {
            match self.channels.get(&c.id) {
                Some(old) if *old != c => {
                    self.warnings.push(format!(
                        "channel {} redefined differently; the first kept",
                        c.id
                    ));
                }
                Some(_) => {}
                None => {
                    let topic = self.topic_index(&c);
                    if let Some(slot) = self.channel_topic.get_mut(usize::from(c.id)) {
                        *slot = topic;
                    }
                    self.channels.insert(c.id, c);
                }
            }
        }
        if new_channels {
            let table = &self.channel_topic;
            for m in self
                .msgs
                .iter_mut()
                .skip(mark)
                .filter(|m| m.topic == NO_TOPIC)
            {
                m.topic = table
                    .get(usize::from(m.channel_id))
                    .copied()
                    .unwrap_or(NO_TOPIC);
                if m.topic == NO_TOPIC {
                    return Err(format!("message on undefined channel {}", m.channel_id));
                }
            }
        }
        if let Some(c) = chunk {
            self.chunks.push(c);
        }
        Ok(())
    }

    fn topic_index(&mut self, c: &ChannelDef) -> u16 {
        if let Some(&i) = self.topic_by_name.get(&c.topic) {
            return i;
        }
        let known = Topic::from_name(&c.topic).filter(|t| t.encoding() == c.encoding);
        let schema_name = self.schemas.get(&c.schema_id).map(|s| s.name.clone());
        let i = u16::try_from(self.topics.len()).unwrap_or(u16::MAX);
        self.topics.push(TopicData {
            name: c.topic.clone(),
            encoding: c.encoding.clone(),
            schema_name,
            known,
            positions: Vec::new(),
        });
        self.topic_by_name.insert(c.topic.clone(), i);
        i
    }

    fn into_session(mut self, file: Vec<u8>, source: PathBuf) -> Session {
        // Time order.
        let mut backwards = 0usize;
        let mut worst = 0u64;
        for w in self.msgs.windows(2) {
            if let [a, b] = w
                && b.t_ns < a.t_ns
            {
                backwards += 1;
                worst = worst.max(a.t_ns - b.t_ns);
            }
        }
        let mut order: Vec<u32> = (0..self.msgs.len() as u32).collect();
        if backwards > 0 {
            order.sort_by_key(|&i| self.msgs.get(i as usize).map_or(0, |m| m.t_ns));
            self.warnings.push(format!(
                "{backwards} messages are earlier than the message before them in the file \
                 (by up to {:.3} s); messages sorted by time",
                worst as f64 * 1e-9
            ));
        }
        for (pos, &i) in order.iter().enumerate() {
            if let Some(t) = self
                .msgs
                .get(i as usize)
                .and_then(|m| self.topics.get_mut(m.topic as usize))
            {
                t.positions.push(pos as u32);
            }
        }
        let time_at = |pos: u32| -> u64 {
            order
                .get(pos as usize)
                .and_then(|&i| self.msgs.get(i as usize))
                .map_or(0, |m| m.t_ns)
        };
        for t in &self.topics {
            if t.known.is_none() {
                let why = match Topic::from_name(&t.name) {
                    Some(k) => format!(
                        "encoding {:?} where {:?} is expected",
                        t.encoding,
                        k.encoding()
                    ),
                    None => format!("encoding {:?}", t.encoding),
                };
                self.warnings.push(format!(
                    "unknown topic {} ({} messages, {why}) kept undecoded",
                    t.name,
                    t.positions.len()
                ));
            }
            // Gaps: an interval longer than 1 s and 10× the topic's median interval.
            if t.positions.len() >= 3 {
                let mut dts: Vec<u64> = t
                    .positions
                    .windows(2)
                    .filter_map(|w| match w {
                        [a, b] => Some(time_at(*b).saturating_sub(time_at(*a))),
                        _ => None,
                    })
                    .collect();
                let gaps_input = dts.clone();
                let mid = dts.len() / 2;
                let median = *dts.select_nth_unstable(mid).1;
                let limit = median.saturating_mul(10).max(1_000_000_000);
                let big: Vec<(usize, u64)> = gaps_input
                    .iter()
                    .copied()
                    .enumerate()
                    .filter(|(_, dt)| *dt > limit)
                    .collect();
                if let Some(&(k, longest)) = big.iter().max_by_key(|(_, dt)| *dt) {
                    let at = t.positions.get(k).map_or(0, |&p| time_at(p));
                    self.warnings.push(format!(
                        "{}: {} gap(s) longer than {:.3} s; the longest is {:.3} s after t = {:.3} s",
                        t.name,
                        big.len(),
                        limit as f64 * 1e-9,
                        longest as f64 * 1e-9,
                        at as f64 * 1e-9
                    ));
                }
            }
        }
        Session {
            source,
            file,
            chunks: self.chunks,
            msgs: self.msgs,
            order,
            topics: self.topics,
            topic_by_name: self.topic_by_name,
            schemas: self.schemas,
            channels: self.channels,
            attachments: self.attachments,
            metadata: self.metadata,
            damage: self.damage,
            warnings: self.warnings,
        }
    }
}
