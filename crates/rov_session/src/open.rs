//! Opening a session: through the summary when the file is complete, otherwise by a scan.
//!
//! # Through the summary (a complete file)
//!
//! The footer points at the summary section; when its CRC holds, the statistics, schemas,
//! channels, chunk indexes, attachment and metadata indexes are read from it and nothing
//! else: no chunk is decompressed, so opening costs the summary (about 3 % of the file)
//! whatever the length of the recording. The chunk indexes are checked for consistency
//! (inside the data section, not overlapping, as many as the statistics count); a chunk
//! whose content turns out bad is found when a read reaches it ([`crate::stream`]).
//!
//! # By a scan (no valid summary: a recording killed, a partial copy, another writer)
//!
//! Every record of the data section is read once, in order, with bounded memory (one chunk
//! at a time): chunks are decompressed and checked and their messages counted, nothing is
//! kept but the index. The scan stops at the first record that does not fit (the file is
//! [`Damage::Truncated`] there) or is invalid ([`Damage::Corrupt`]); everything before it
//! is readable.

use std::path::Path;

use crate::chunk::{self, ChannelFilter, Decompressors, MAX_CHUNK_BYTES};
use crate::error::{Result, SessionError};
use crate::index::{ChunkInfo, Index, Kind};
use crate::io::{SeqReader, Source, read_vec};
use crate::message::Damage;
use crate::wire::AttachmentData;
use crate::wire::{self, FOOTER_RECORD_LEN, MAGIC, RECORD_HEADER_LEN, op};

/// A summary section larger than this is not read (the file is scanned instead).
const MAX_SUMMARY_BYTES: u64 = 1 << 30;
/// Attachments larger than this are skipped with a warning.
const MAX_ATTACHMENT_BYTES: u64 = 64 << 20;
/// A chunk record may be this much larger than the largest accepted content.
const MAX_CHUNK_RECORD: u64 = MAX_CHUNK_BYTES + (1 << 20);
/// A run of top-level messages is cut into parts of about this size.
const LOOSE_RUN_BYTES: u64 = 1 << 20;

/// What opening found.
#[derive(Debug, Default)]
pub(crate) struct Opened {
    pub index: Index,
    pub attachments: Vec<AttachmentData>,
    pub metadata: Vec<(String, std::collections::BTreeMap<String, String>)>,
    pub message_count: u64,
    pub damage: Option<Damage>,
    pub warnings: Vec<String>,
    /// Opened through the summary (chunks not yet checked).
    pub indexed: bool,
}

/// Checks the first bytes: an MCAP file, or a prefix of its magic (a file cut at once).
pub(crate) fn check_magic(src: &dyn Source, label: &Path) -> Result<()> {
    let not = |detail: String| SessionError::NotMcap {
        path: label.to_path_buf(),
        detail,
    };
    let n = src.len().min(256);
    let head = read_vec(src, 0, n)
        .map_err(crate::error::io_err(label, "read"))?
        .unwrap_or_default();
    if head.is_empty() {
        return Err(not("the file is empty (0 bytes)".into()));
    }
    let magic_part = head.get(..MAGIC.len()).unwrap_or(&head);
    if MAGIC.starts_with(magic_part) {
        return Ok(());
    }
    if magic_part.get(..5) == MAGIC.get(..5) {
        return Err(not(format!(
            "MCAP magic with unsupported version byte {:#04x}",
            magic_part.get(5).copied().unwrap_or(0)
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
    } else if head
        .iter()
        .all(|b| b.is_ascii_graphic() || b.is_ascii_whitespace())
    {
        let first_line: String = head
            .iter()
            .take(60)
            .take_while(|b| **b != b'\n')
            .map(|&b| b as char)
            .collect();
        format!("a text file (starts with {first_line:?})")
    } else {
        format!("unknown content (first bytes {:02x?})", magic_part)
    };
    Err(not(format!(
        "{what}; an MCAP file starts with \\x89MCAP0\\r\\n"
    )))
}

/// What the footer and summary say, read before deciding how to open.
#[derive(Debug, Default)]
struct SummaryRead {
    /// Offset of the summary section (when the footer names a valid one).
    summary_start: Option<u64>,
    stats: Option<wire::Stats>,
    /// Chunk offsets listed by the chunk indexes, sorted.
    chunk_offsets: Vec<u64>,
    /// The complete index, when the summary is usable on its own.
    indexed: Option<Opened>,
}

fn io_detail(e: std::io::Error) -> String {
    format!("read failed: {e}")
}

/// Whether the source ends with a well-framed footer and the end magic.
fn footer_ok(src: &dyn Source) -> bool {
    let len = src.len();
    let Some(footer_pos) = len.checked_sub((MAGIC.len() + FOOTER_RECORD_LEN) as u64) else {
        return false;
    };
    if footer_pos < MAGIC.len() as u64 {
        return false;
    }
    let Ok(Some(tail)) = read_vec(src, footer_pos, (MAGIC.len() + FOOTER_RECORD_LEN) as u64) else {
        return false;
    };
    tail.get(FOOTER_RECORD_LEN..) == Some(&MAGIC[..])
        && wire::frame(&tail, 0)
            .is_some_and(|f| f.opcode == op::FOOTER && f.end == FOOTER_RECORD_LEN)
}

/// Reads the footer and the summary. Never fails: what cannot be used is a warning.
fn read_summary(src: &dyn Source, warnings: &mut Vec<String>) -> SummaryRead {
    let mut out = SummaryRead::default();
    let len = src.len();
    if len < (MAGIC.len() * 2 + FOOTER_RECORD_LEN) as u64 || !footer_ok(src) {
        return out;
    }
    let footer_pos = len - (MAGIC.len() + FOOTER_RECORD_LEN) as u64;
    let Ok(Some(fbytes)) = read_vec(src, footer_pos, FOOTER_RECORD_LEN as u64) else {
        return out;
    };
    let Some(footer) = wire::frame(&fbytes, 0).and_then(|f| wire::footer(f.body)) else {
        return out;
    };
    if footer.summary_start == 0 {
        return out;
    }
    let summary_start = footer.summary_start;
    if summary_start < MAGIC.len() as u64 || summary_start > footer_pos {
        warnings.push(format!(
            "the footer's summary offset {summary_start} is out of range; summary ignored"
        ));
        return out;
    }
    let summary_len = footer_pos - summary_start;
    if summary_len > MAX_SUMMARY_BYTES {
        warnings.push(format!(
            "the summary section is {summary_len} bytes, more than the {MAX_SUMMARY_BYTES} read; the file is scanned"
        ));
        return out;
    }
    out.summary_start = Some(summary_start);
    let mut rd = SeqReader::new(src, summary_start);
    let mut hasher = crc32fast::Hasher::new();
    let mut notes = Vec::new();
    let p = parse_summary(
        src,
        &mut rd,
        footer_pos,
        &mut hasher,
        summary_start,
        &mut notes,
    );
    // The summary CRC covers the summary section and the footer up to its CRC field.
    hasher.update(fbytes.get(..RECORD_HEADER_LEN + 16).unwrap_or(&[]));
    if footer.summary_crc != 0 && hasher.finalize() != footer.summary_crc {
        warnings.push("the summary section fails its CRC; summary ignored".into());
        out.summary_start = None;
        return out;
    }
    warnings.append(&mut notes);
    out.stats = p.stats;
    out.chunk_offsets = p.chunk_offsets;
    out.indexed = p.opened.map(|b| *b);
    out.chunk_offsets.sort_unstable();
    out
}

#[derive(Debug, Default)]
struct ParsedSummary {
    stats: Option<wire::Stats>,
    chunk_offsets: Vec<u64>,
    /// The index, when the summary stands on its own.
    opened: Option<Box<Opened>>,
}

/// Parses the summary records read from `rd` up to `end` (each one hashed into `hasher`
/// for the summary CRC). Without `opened`, the rest is a hint for the scan.
fn parse_summary(
    src: &dyn Source,
    rd: &mut SeqReader<'_>,
    end: u64,
    hasher: &mut crc32fast::Hasher,
    summary_start: u64,
    warnings: &mut Vec<String>,
) -> ParsedSummary {
    let mut p = ParsedSummary::default();
    let mut index = Index::default();
    let mut chunk_indexes: Vec<wire::ChunkIndexRec> = Vec::new();
    let mut chans: Vec<u16> = Vec::new();
    let mut attachment_at = Vec::new();
    let mut metadata_at = Vec::new();
    let mut malformed = None;
    while rd.offset() < end {
        let pos = rd.offset() - summary_start;
        let total = match rd.peek(RECORD_HEADER_LEN) {
            Ok(Some(h)) => {
                let mut hr = wire::Rd::new(h);
                hr.u8();
                hr.u64()
                    .and_then(|n| n.checked_add(RECORD_HEADER_LEN as u64))
                    .filter(|t| *t <= end - rd.offset())
            }
            _ => None,
        };
        let Some(rec) = total
            .and_then(|t| usize::try_from(t).ok())
            .and_then(|t| rd.take(t).ok().flatten())
        else {
            malformed = Some(format!("a record cut short at summary byte {pos}"));
            break;
        };
        hasher.update(rec);
        let Some(r) = wire::frame(rec, 0) else {
            malformed = Some(format!("a record cut short at summary byte {pos}"));
            break;
        };
        let ok = match r.opcode {
            op::SCHEMA => wire::schema(r.body).filter(|s| s.id != 0).map(|s| {
                index.add_schema(s);
            }),
            op::CHANNEL => wire::channel(r.body).map(|c| {
                index.add_channel(c);
            }),
            op::CHUNK_INDEX => {
                let a = chans.len();
                wire::chunk_index(r.body, &mut chans).map(|mut c| {
                    p.chunk_offsets.push(c.chunk_offset);
                    c.chans = (a as u32, chans.len() as u32);
                    chunk_indexes.push(c);
                })
            }
            op::ATTACHMENT_INDEX => wire::index_target(r.body).map(|t| attachment_at.push(t)),
            op::METADATA_INDEX => wire::index_target(r.body).map(|t| metadata_at.push(t)),
            op::STATISTICS => wire::statistics(r.body).map(|s| p.stats = Some(s)),
            _ => Some(()),
        };
        if ok.is_none() {
            malformed = Some(format!(
                "a malformed record (opcode {:#04x}) at summary byte {pos}",
                r.opcode
            ));
            break;
        }
    }
    if let Some(m) = malformed {
        // The rest of the summary still counts towards its CRC.
        while rd.offset() < end {
            let n = (end - rd.offset()).min(1 << 20) as usize;
            match rd.take(n) {
                Ok(Some(b)) => hasher.update(b),
                _ => break,
            }
        }
        warnings.push(format!("the summary section has {m}; the file is scanned"));
        return p;
    }
    let Some(stats) = p.stats.clone() else {
        // Another writer's file without statistics: counts come from a scan.
        return p;
    };
    if stats.chunk_count as usize != chunk_indexes.len()
        || (stats.message_count > 0 && chunk_indexes.is_empty())
    {
        if !chunk_indexes.is_empty() {
            warnings.push(format!(
                "the summary counts {} chunks but indexes {}; the file is scanned",
                stats.chunk_count,
                chunk_indexes.len()
            ));
        }
        return p;
    }
    // The data section ends with a data-end record right before the summary.
    let data_end_ok = summary_start
        .checked_sub(13)
        .and_then(|at| read_vec(src, at, 13).ok().flatten())
        .is_some_and(|b| {
            b.first() == Some(&op::DATA_END) && b.get(1..9) == Some(&[4, 0, 0, 0, 0, 0, 0, 0])
        });
    if !data_end_ok {
        warnings.push("no data-end record before the summary section; the file is scanned".into());
        return p;
    }
    let data_end = summary_start - 13;
    chunk_indexes.sort_by_key(|c| c.chunk_offset);
    let mut prev_end = MAGIC.len() as u64;
    for c in &chunk_indexes {
        let end = c.chunk_offset.checked_add(c.chunk_length);
        let bad = c.chunk_offset < prev_end
            || c.chunk_length < RECORD_HEADER_LEN as u64
            || end.is_none_or(|e| e > data_end)
            || c.chunk_length > MAX_CHUNK_RECORD
            || c.start_ns > c.end_ns;
        if bad {
            warnings.push(format!(
                "the chunk index for byte {} does not fit the data section; the file is scanned",
                c.chunk_offset
            ));
            return p;
        }
        prev_end = end.unwrap_or(u64::MAX);
    }
    for ch in index.channels.values() {
        if ch.schema_id != 0 && !index.schemas.contains_key(&ch.schema_id) {
            warnings.push(format!(
                "channel {} ({}) names unknown schema {}; the file is scanned",
                ch.id, ch.topic, ch.schema_id
            ));
            return p;
        }
    }
    // Chunks that overlap in time are valid MCAP and normal for a live recording with
    // video (its access units reach the writer tens of ms after the telemetry of the same
    // moment); the reader merges by time, so they are not reported as a warning.
    for c in &chunk_indexes {
        let ids: Vec<(u16, Option<u64>)> = chans
            .get(c.chans.0 as usize..c.chans.1 as usize)
            .unwrap_or(&[])
            .iter()
            .map(|&k| (k, None))
            .collect();
        index.push_chunk(
            ChunkInfo {
                kind: Kind::Chunk,
                offset: c.chunk_offset,
                len: c.chunk_length,
                start_ns: c.start_ns,
                end_ns: c.end_ns,
                chans: (0, 0),
                messages: None,
            },
            &ids,
        );
    }
    drop(chans);
    index.channel_counts = stats.channel_message_counts.clone();
    index.span_ns = (stats.message_count > 0).then_some((stats.start_ns, stats.end_ns));
    index.finish();
    let mut opened = Opened {
        message_count: stats.message_count,
        indexed: true,
        ..Opened::default()
    };
    for (off, len) in attachment_at {
        if len > MAX_ATTACHMENT_BYTES {
            opened.warnings.push(format!(
                "the attachment at byte {off} is {len} bytes; skipped (more than {MAX_ATTACHMENT_BYTES})"
            ));
            continue;
        }
        let rec = read_vec(src, off, len).ok().flatten();
        let parsed = rec.as_deref().and_then(|b| wire::frame(b, 0)).map(|f| {
            if f.opcode == op::ATTACHMENT {
                wire::attachment(f.body)
            } else {
                Err("the attachment index points at another record")
            }
        });
        match parsed {
            Some(Ok(a)) => opened.attachments.push(a),
            Some(Err(e)) => opened
                .warnings
                .push(format!("attachment at byte {off}: {e}; skipped")),
            None => opened
                .warnings
                .push(format!("attachment at byte {off} cannot be read; skipped")),
        }
    }
    for (off, len) in metadata_at {
        let m = read_vec(src, off, len.min(MAX_ATTACHMENT_BYTES))
            .ok()
            .flatten()
            .and_then(|b| {
                wire::frame(&b, 0)
                    .filter(|f| f.opcode == op::METADATA)
                    .and_then(|f| wire::metadata(f.body))
            });
        match m {
            Some(m) => opened.metadata.push(m),
            None => opened.warnings.push(format!(
                "metadata record at byte {off} cannot be read; skipped"
            )),
        }
    }
    opened.warnings.extend(index.unknown_topic_warnings());
    opened.index = index;
    p.opened = Some(Box::new(opened));
    p
}

/// Opens a source: through the summary when it is usable (unless `scan`), else by a scan.
pub(crate) fn open_source(src: &dyn Source, scan: bool) -> Opened {
    let mut warnings = Vec::new();
    if src.len() < MAGIC.len() as u64 {
        return Opened {
            damage: Some(Damage::Truncated {
                at_byte: 0,
                messages_recovered: 0,
            }),
            ..Opened::default()
        };
    }
    let mut s = read_summary(src, &mut warnings);
    if !scan && let Some(mut o) = s.indexed.take() {
        warnings.append(&mut o.warnings);
        o.warnings = warnings;
        return o;
    }
    let mut o = Scanner::new(src, &s).run();
    warnings.append(&mut o.warnings);
    o.warnings = warnings;
    o
}

/// How a scan ended.
enum End {
    Complete,
    Truncated(u64),
    Corrupt(u64, String),
}

/// The scan of a file without a usable summary; see the module docs.
struct Scanner<'a> {
    src: &'a dyn Source,
    hint: &'a SummaryRead,
    o: Opened,
    dec: Decompressors,
    hasher: crc32fast::Hasher,
    unknown_records: std::collections::BTreeMap<u8, u64>,
    seen_chunk: bool,
    /// The open run of top-level messages: (offset, end, start, end time, per channel).
    loose: Option<LooseRun>,
    /// (chunk offset, messages before it), for the summary cross-check.
    taken: Vec<(u64, u64)>,
}

struct LooseRun {
    offset: u64,
    end: u64,
    span: (u64, u64),
    per_channel: Vec<(u16, u64)>,
    messages: u64,
}

impl<'a> Scanner<'a> {
    fn new(src: &'a dyn Source, hint: &'a SummaryRead) -> Self {
        Self {
            src,
            hint,
            o: Opened::default(),
            dec: Decompressors::default(),
            hasher: crc32fast::Hasher::new(),
            unknown_records: std::collections::BTreeMap::new(),
            seen_chunk: false,
            loose: None,
            taken: Vec::new(),
        }
    }

    fn in_summary(&self, pos: u64) -> bool {
        self.hint.summary_start.is_some_and(|s| pos >= s)
    }

    fn run(mut self) -> Opened {
        let end = self.scan();
        self.close_loose();
        let complete = matches!(end, End::Complete);
        match end {
            End::Complete => {}
            End::Truncated(at) => {
                self.o.damage = Some(Damage::Truncated {
                    at_byte: at,
                    messages_recovered: self.o.message_count,
                })
            }
            End::Corrupt(at, detail) => self.corrupt(at, detail),
        }
        if complete && self.o.damage.is_none() {
            // Every chunk the summary lists must have been read as a chunk; the first one
            // missing (a damaged record header) ends the trustworthy prefix.
            let missing = self
                .hint
                .chunk_offsets
                .iter()
                .find(|o| self.taken.binary_search_by_key(*o, |t| t.0).is_err())
                .copied();
            if let Some(at) = missing {
                self.truncate_after(at);
                let detail = format!(
                    "the summary lists a chunk at byte {at} that the data section does not hold"
                );
                self.corrupt(at, detail);
            }
        }
        for (opcode, n) in std::mem::take(&mut self.unknown_records) {
            self.o.warnings.push(format!(
                "{n} records with unknown opcode {opcode:#04x} skipped"
            ));
        }
        if complete
            && self.o.damage.is_none()
            && let Some(stats) = &self.hint.stats
            && stats.message_count != self.o.message_count
        {
            self.o.warnings.push(format!(
                "the summary counts {} messages, the data section holds {}",
                stats.message_count, self.o.message_count
            ));
        }
        self.o.index.span_ns = self
            .o
            .index
            .chunks
            .iter()
            .filter(|c| c.messages != Some(0))
            .fold(None, |acc, c| {
                Some(match acc {
                    None => (c.start_ns, c.end_ns),
                    Some((a, b)) => (a.min(c.start_ns), b.max(c.end_ns)),
                })
            });
        self.o.index.finish();
        let unknown = self.o.index.unknown_topic_warnings();
        self.o.warnings.extend(unknown);
        self.o
    }

    fn corrupt(&mut self, at: u64, detail: String) {
        self.o.damage = Some(Damage::Corrupt {
            at_byte: at,
            detail,
            messages_recovered: self.o.message_count,
        });
    }

    /// Forgets every chunk after `at` (the summary cross-check failed there).
    fn truncate_after(&mut self, at: u64) {
        let ix = &mut self.o.index;
        let keep = ix.chunks.iter().take_while(|c| c.offset <= at).count();
        let chans_end = ix
            .chunks
            .get(keep)
            .map_or(ix.chunk_channels.len(), |c| c.chans.0 as usize);
        let dropped: Vec<(u16, u64)> = ix
            .chunk_channels
            .iter()
            .copied()
            .zip(ix.chunk_channel_counts.iter().copied())
            .skip(chans_end)
            .collect();
        for (c, n) in dropped {
            if let Some(v) = ix.channel_counts.get_mut(&c) {
                *v = v.saturating_sub(n);
            }
            self.o.message_count = self.o.message_count.saturating_sub(n);
        }
        ix.chunks.truncate(keep);
        ix.chunk_channels.truncate(chans_end);
        ix.chunk_channel_counts.truncate(chans_end);
    }

    fn close_loose(&mut self) {
        if let Some(r) = self.loose.take() {
            let chans: Vec<(u16, Option<u64>)> =
                r.per_channel.iter().map(|&(c, n)| (c, Some(n))).collect();
            self.o.index.push_chunk(
                ChunkInfo {
                    kind: Kind::Loose,
                    offset: r.offset,
                    len: r.end - r.offset,
                    start_ns: r.span.0,
                    end_ns: r.span.1,
                    chans: (0, 0),
                    messages: Some(r.messages),
                },
                &chans,
            );
        }
    }

    fn scan(&mut self) -> End {
        let len = self.src.len();
        let mut rd = SeqReader::new(self.src, 0);
        match rd.take(MAGIC.len()) {
            Ok(Some(m)) => self.hasher.update(m),
            Ok(None) => return End::Truncated(0),
            Err(e) => return End::Corrupt(0, io_detail(e)),
        }
        let mut in_summary = false;
        loop {
            let pos = rd.offset();
            if pos == len {
                return End::Truncated(pos);
            }
            let header = match rd.peek(RECORD_HEADER_LEN) {
                Ok(Some(h)) => h,
                Ok(None) => return End::Truncated(pos),
                Err(e) => return End::Corrupt(pos, io_detail(e)),
            };
            let mut hr = wire::Rd::new(header);
            let (Some(opcode), Some(body_len)) = (hr.u8(), hr.u64()) else {
                return End::Truncated(pos);
            };
            let total = match body_len.checked_add(RECORD_HEADER_LEN as u64) {
                Some(t) if t <= rd.remaining() => t,
                _ => return End::Truncated(pos),
            };
            let end = pos + total;
            if self.in_summary(pos) {
                in_summary = true;
            }
            if opcode != op::MESSAGE {
                self.close_loose();
            }
            let res = match opcode {
                op::FOOTER => {
                    rd.seek(end);
                    let tail = rd.remaining();
                    if tail < MAGIC.len() as u64 {
                        return End::Truncated(end);
                    }
                    match rd.peek(MAGIC.len()) {
                        Ok(Some(m)) if m == MAGIC => {}
                        Ok(_) => {
                            return End::Corrupt(
                                end,
                                "the footer is not followed by the MCAP end magic".into(),
                            );
                        }
                        Err(e) => return End::Corrupt(end, io_detail(e)),
                    }
                    if tail > MAGIC.len() as u64 {
                        self.o.warnings.push(format!(
                            "{} bytes after the end magic ignored",
                            tail - MAGIC.len() as u64
                        ));
                    }
                    return End::Complete;
                }
                op::DATA_END => {
                    if self.hint.summary_start.is_some_and(|s| s != end) {
                        return End::Corrupt(
                            pos,
                            "a data-end record where the summary says the data goes on".into(),
                        );
                    }
                    let crc = match rd.take(total as usize) {
                        Ok(Some(b)) => b
                            .get(RECORD_HEADER_LEN..)
                            .and_then(|body| wire::Rd::new(body).u32())
                            .unwrap_or(0),
                        Ok(None) => return End::Truncated(pos),
                        Err(e) => return End::Corrupt(pos, io_detail(e)),
                    };
                    in_summary = true;
                    if crc != 0 && self.hasher.clone().finalize() != crc {
                        self.o.warnings.push(
                            "the data section fails its CRC: bytes outside the CRC-checked chunks \
                             (e.g. indexes, unchunked messages) were altered"
                                .into(),
                        );
                    }
                    if footer_ok(self.src) {
                        // The data is complete and the file ends properly: the summary
                        // between here and the footer is only an index.
                        return End::Complete;
                    }
                    Ok(())
                }
                _ if in_summary => {
                    rd.seek(end);
                    Ok(())
                }
                op::CHUNK => self.chunk(&mut rd, pos, total),
                op::MESSAGE => self.loose_message(&mut rd, pos, total),
                op::HEADER | op::SCHEMA | op::CHANNEL | op::ATTACHMENT | op::METADATA => {
                    self.top_record(&mut rd, opcode, pos, total)
                }
                op::MESSAGE_INDEX
                | op::CHUNK_INDEX
                | op::ATTACHMENT_INDEX
                | op::METADATA_INDEX
                | op::STATISTICS
                | op::SUMMARY_OFFSET => self.skip_hashed(&mut rd, total),
                other => {
                    *self.unknown_records.entry(other).or_insert(0) += 1;
                    self.skip_hashed(&mut rd, total)
                }
            };
            if let Err(e) = res {
                return e;
            }
            if rd.offset() != end {
                rd.seek(end);
            }
        }
    }

    /// Consumes `total` bytes, hashing them for the data-section CRC, in blocks.
    fn skip_hashed(&mut self, rd: &mut SeqReader<'_>, total: u64) -> Result<(), End> {
        let mut left = total;
        while left > 0 {
            let at = rd.offset();
            let n = left.min(1 << 20) as usize;
            match rd.take(n) {
                Ok(Some(b)) => self.hasher.update(b),
                Ok(None) => return Err(End::Truncated(at)),
                Err(e) => return Err(End::Corrupt(at, io_detail(e))),
            }
            left -= n as u64;
        }
        Ok(())
    }

    fn take_record(
        &mut self,
        rd: &mut SeqReader<'_>,
        pos: u64,
        total: u64,
    ) -> Result<Vec<u8>, End> {
        let n = usize::try_from(total).map_err(|_| End::Corrupt(pos, "record too large".into()))?;
        match rd.take(n) {
            Ok(Some(b)) => {
                self.hasher.update(b);
                Ok(b.to_vec())
            }
            Ok(None) => Err(End::Truncated(pos)),
            Err(e) => Err(End::Corrupt(pos, io_detail(e))),
        }
    }

    fn chunk(&mut self, rd: &mut SeqReader<'_>, pos: u64, total: u64) -> Result<(), End> {
        if total > MAX_CHUNK_RECORD {
            return Err(End::Corrupt(
                pos,
                format!(
                    "chunk record of {total} bytes is larger than the {MAX_CHUNK_RECORD} byte limit"
                ),
            ));
        }
        let record = self.take_record(rd, pos, total)?;
        let nothing = ChannelFilter::only(Vec::new());
        let d = chunk::decode_chunk_record(record, &nothing, true, &mut self.dec)
            .map_err(|e| End::Corrupt(pos, e))?;
        // Schemas and channels inside count only when the whole chunk is good.
        let mut schemas = self.o.index.schemas.clone();
        for s in &d.schemas {
            schemas.entry(s.id).or_insert_with(|| s.clone());
        }
        for c in &d.channels {
            if c.schema_id != 0 && !schemas.contains_key(&c.schema_id) {
                return Err(End::Corrupt(
                    pos,
                    format!(
                        "channel {} ({}) names unknown schema {}",
                        c.id, c.topic, c.schema_id
                    ),
                ));
            }
        }
        for (id, _) in &d.per_channel {
            let defined =
                self.o.index.channels.contains_key(id) || d.channels.iter().any(|c| c.id == *id);
            if !defined {
                return Err(End::Corrupt(
                    pos,
                    format!("message on undefined channel {id}"),
                ));
            }
        }
        for s in d.schemas {
            if self.o.index.add_schema(s.clone()) {
                self.o.warnings.push(format!(
                    "schema {} redefined differently; the first kept",
                    s.id
                ));
            }
        }
        for c in d.channels {
            let id = c.id;
            if self.o.index.add_channel(c) {
                self.o.warnings.push(format!(
                    "channel {id} redefined differently; the first kept"
                ));
            }
        }
        self.seen_chunk = true;
        self.taken.push((pos, self.o.message_count));
        self.o.message_count += d.total;
        for (c, n) in &d.per_channel {
            *self.o.index.channel_counts.entry(*c).or_insert(0) += n;
        }
        let (start_ns, end_ns) = d.span_ns.unwrap_or((0, 0));
        let chans: Vec<(u16, Option<u64>)> =
            d.per_channel.iter().map(|&(c, n)| (c, Some(n))).collect();
        self.o.index.push_chunk(
            ChunkInfo {
                kind: Kind::Chunk,
                offset: pos,
                len: total,
                start_ns,
                end_ns,
                chans: (0, 0),
                messages: Some(d.total),
            },
            &chans,
        );
        Ok(())
    }

    fn loose_message(&mut self, rd: &mut SeqReader<'_>, pos: u64, total: u64) -> Result<(), End> {
        let chunked = self.seen_chunk || !self.hint.chunk_offsets.is_empty();
        if chunked {
            return Err(End::Corrupt(
                pos,
                "a message record outside the chunks of a chunked file (a damaged record header)"
                    .into(),
            ));
        }
        let record = self.take_record(rd, pos, total)?;
        let h = record
            .get(RECORD_HEADER_LEN..)
            .and_then(wire::message_head)
            .ok_or_else(|| End::Corrupt(pos, "malformed message record".into()))?;
        if !self.o.index.channels.contains_key(&h.channel_id) {
            return Err(End::Corrupt(
                pos,
                format!("message on undefined channel {}", h.channel_id),
            ));
        }
        let end = pos + total;
        let t = h.log_time;
        let run = match &mut self.loose {
            Some(r) if r.end == pos && end - r.offset <= LOOSE_RUN_BYTES => r,
            _ => {
                self.close_loose();
                self.loose.insert(LooseRun {
                    offset: pos,
                    end: pos,
                    span: (t, t),
                    per_channel: Vec::new(),
                    messages: 0,
                })
            }
        };
        run.end = end;
        run.span = (run.span.0.min(t), run.span.1.max(t));
        run.messages += 1;
        match run.per_channel.iter_mut().find(|(c, _)| *c == h.channel_id) {
            Some((_, n)) => *n += 1,
            None => run.per_channel.push((h.channel_id, 1)),
        }
        self.o.message_count += 1;
        *self.o.index.channel_counts.entry(h.channel_id).or_insert(0) += 1;
        Ok(())
    }

    fn top_record(
        &mut self,
        rd: &mut SeqReader<'_>,
        opcode: u8,
        pos: u64,
        total: u64,
    ) -> Result<(), End> {
        if opcode == op::ATTACHMENT && total > MAX_ATTACHMENT_BYTES {
            self.o.warnings.push(format!(
                "the attachment at byte {pos} is {total} bytes; skipped (more than {MAX_ATTACHMENT_BYTES})"
            ));
            return self.skip_hashed(rd, total);
        }
        let record = self.take_record(rd, pos, total)?;
        let body = record.get(RECORD_HEADER_LEN..).unwrap_or(&[]);
        let bad = |what: &str| End::Corrupt(pos, format!("malformed {what} record"));
        match opcode {
            op::HEADER => {
                let mut r = wire::Rd::new(body);
                r.str().and_then(|_| r.str()).ok_or_else(|| bad("header"))?;
            }
            op::SCHEMA => {
                let s = wire::schema(body).ok_or_else(|| bad("schema"))?;
                if s.id == 0 {
                    return Err(End::Corrupt(pos, "schema record with id 0".into()));
                }
                let id = s.id;
                if self.o.index.add_schema(s) {
                    self.o
                        .warnings
                        .push(format!("schema {id} redefined differently; the first kept"));
                }
            }
            op::CHANNEL => {
                let c = wire::channel(body).ok_or_else(|| bad("channel"))?;
                if c.schema_id != 0 && !self.o.index.schemas.contains_key(&c.schema_id) {
                    return Err(End::Corrupt(
                        pos,
                        format!(
                            "channel {} ({}) names unknown schema {}",
                            c.id, c.topic, c.schema_id
                        ),
                    ));
                }
                let id = c.id;
                if self.o.index.add_channel(c) {
                    self.o.warnings.push(format!(
                        "channel {id} redefined differently; the first kept"
                    ));
                }
            }
            op::ATTACHMENT => {
                let a = wire::attachment(body).map_err(|e| End::Corrupt(pos, e.to_string()))?;
                self.o.attachments.push(a);
            }
            _ => {
                let m = wire::metadata(body).ok_or_else(|| bad("metadata"))?;
                self.o.metadata.push(m);
            }
        }
        Ok(())
    }
}
