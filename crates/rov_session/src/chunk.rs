//! Decoding one chunk record, or one run of top-level message records, into messages.
//!
//! Pure: bytes in, messages out (decompression is computation). The caller reads the
//! bytes ([`crate::io`]) and decides which chunks to decode ([`crate::stream`]).
//!
//! A chunk is all or nothing: it decompresses to exactly the size it claims, its CRC (when
//! non-zero) matches, and every record inside it frames and parses; otherwise decoding
//! fails with what is wrong and none of its messages is returned.

use std::sync::Arc;

use crate::wire::{self, ChannelDef, MESSAGE_HEAD_LEN, SchemaDef, op};

/// Largest uncompressed chunk the reader accepts, bytes.
pub const MAX_CHUNK_BYTES: u64 = 256 << 20;

/// Up to this size a decompression buffer is allocated at once from the size the chunk
/// claims; beyond it the buffer grows with the data actually decompressed, so a forged
/// size costs nothing.
const PREALLOCATE_MAX: u64 = 16 << 20;

/// Which channels a read wants (`None`: all).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(crate) struct ChannelFilter(Option<Vec<u16>>);

impl ChannelFilter {
    pub(crate) const ALL: ChannelFilter = ChannelFilter(None);

    /// Only these channels.
    pub(crate) fn only(mut ids: Vec<u16>) -> Self {
        ids.sort_unstable();
        ids.dedup();
        Self(Some(ids))
    }

    pub(crate) fn wants(&self, id: u16) -> bool {
        self.0
            .as_ref()
            .is_none_or(|ids| ids.binary_search(&id).is_ok())
    }

    /// Whether any of `ids` is wanted.
    pub(crate) fn wants_any(&self, ids: &[u16]) -> bool {
        match &self.0 {
            None => true,
            Some(w) => ids.iter().any(|i| w.binary_search(i).is_ok()),
        }
    }
}

/// Where one message's bytes are in a decoded buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Loc {
    pub t_ns: u64,
    pub sequence: u32,
    pub channel_id: u16,
    pub start: u32,
    pub len: u32,
}

/// A decoded chunk (or run of top-level messages).
#[derive(Debug, Default)]
pub(crate) struct Decoded {
    /// The uncompressed records.
    pub buf: Arc<[u8]>,
    /// The wanted messages, in file order.
    pub locs: Vec<Loc>,
    /// Messages of any channel.
    pub total: u64,
    /// Messages earlier than the message before them (file order, any channel).
    pub inversions: u64,
    /// The largest such step back, ns.
    pub worst_inversion_ns: u64,
    /// Earliest and latest message time (any channel); `None` without messages.
    pub span_ns: Option<(u64, u64)>,
    /// Schema and channel records found inside (a chunk may define its channels).
    pub schemas: Vec<SchemaDef>,
    pub channels: Vec<ChannelDef>,
    /// Messages per channel (any channel), in first-seen order.
    pub per_channel: Vec<(u16, u64)>,
}

impl Decoded {
    /// Sorts the wanted messages by time (stable: equal times keep file order).
    pub(crate) fn sort_by_time(&mut self) {
        if self.locs.windows(2).any(|w| match w {
            [a, b] => b.t_ns < a.t_ns,
            _ => false,
        }) {
            self.locs.sort_by_key(|l| l.t_ns);
        }
    }

    fn note_message(&mut self, h: &wire::MessageHead, last_t: &mut Option<u64>) {
        self.total += 1;
        if let Some(p) = *last_t
            && h.log_time < p
        {
            self.inversions += 1;
            self.worst_inversion_ns = self.worst_inversion_ns.max(p - h.log_time);
        }
        *last_t = Some(h.log_time);
        self.span_ns = Some(match self.span_ns {
            None => (h.log_time, h.log_time),
            Some((a, b)) => (a.min(h.log_time), b.max(h.log_time)),
        });
        match self
            .per_channel
            .iter_mut()
            .find(|(c, _)| *c == h.channel_id)
        {
            Some((_, n)) => *n += 1,
            None => self.per_channel.push((h.channel_id, 1)),
        }
    }
}

/// Reuses one zstd context across the chunks of a read.
#[derive(Default)]
pub(crate) struct Decompressors {
    zstd: Option<zstd::bulk::Decompressor<'static>>,
}

impl std::fmt::Debug for Decompressors {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Decompressors").finish_non_exhaustive()
    }
}

/// A first buffer size: what the chunk claims, but no more than [`PREALLOCATE_MAX`] or
/// eight times its compressed size (the buffer grows if the data really is larger).
fn initial_capacity(claimed: u64, compressed: usize) -> usize {
    let by_input = (compressed as u64).saturating_mul(8).max(64 << 10);
    usize::try_from(claimed.min(PREALLOCATE_MAX).min(by_input)).unwrap_or(0)
}

/// Reads a decoder to its end, at most `size + 1` bytes, growing with the data.
fn read_capped(mut r: impl std::io::Read, size: u64, cap0: usize) -> std::io::Result<Vec<u8>> {
    let mut out = Vec::with_capacity(cap0);
    std::io::Read::read_to_end(&mut std::io::Read::take(&mut r, size + 1), &mut out)?;
    Ok(out)
}

/// Decompresses a chunk's records and checks their CRC. `None`: the chunk is uncompressed
/// and its records are read in place.
pub(crate) fn chunk_content(
    c: &wire::ChunkRec<'_>,
    dec: &mut Decompressors,
) -> Result<Option<Vec<u8>>, String> {
    if c.uncompressed_size > MAX_CHUNK_BYTES {
        return Err(format!(
            "chunk claims {} bytes uncompressed, more than the {} byte limit",
            c.uncompressed_size, MAX_CHUNK_BYTES
        ));
    }
    let size = c.uncompressed_size;
    let out = match c.compression {
        "" => {
            if c.records.len() as u64 != size {
                return Err(format!(
                    "uncompressed chunk holds {} bytes but claims {size}",
                    c.records.len()
                ));
            }
            None
        }
        "zstd" => {
            let out = if size <= PREALLOCATE_MAX {
                let d = match &mut dec.zstd {
                    Some(d) => d,
                    None => dec
                        .zstd
                        .insert(zstd::bulk::Decompressor::new().map_err(|e| format!("zstd: {e}"))?),
                };
                let mut out = Vec::with_capacity(size as usize);
                d.decompress_to_buffer(c.records, &mut out)
                    .map_err(|e| format!("zstd chunk does not decompress: {e}"))?;
                out
            } else {
                let z = zstd::stream::read::Decoder::with_buffer(c.records)
                    .map_err(|e| format!("zstd: {e}"))?;
                read_capped(z, size, initial_capacity(size, c.records.len()))
                    .map_err(|e| format!("zstd chunk does not decompress: {e}"))?
            };
            if out.len() as u64 != size {
                return Err(format!(
                    "zstd chunk decompresses to {} bytes but claims {size}",
                    out.len()
                ));
            }
            Some(out)
        }
        "lz4" => {
            let d = lz4::Decoder::new(c.records)
                .map_err(|e| format!("lz4 chunk does not decompress: {e}"))?;
            let out = read_capped(d, size, initial_capacity(size, c.records.len()))
                .map_err(|e| format!("lz4 chunk does not decompress: {e}"))?;
            if out.len() as u64 != size {
                return Err(format!(
                    "lz4 chunk decompresses to {} bytes but claims {size}",
                    out.len()
                ));
            }
            Some(out)
        }
        other => return Err(format!("unknown chunk compression {other:?}")),
    };
    let content: &[u8] = out.as_deref().unwrap_or(c.records);
    if c.uncompressed_crc != 0 && crc32fast::hash(content) != c.uncompressed_crc {
        return Err("chunk CRC mismatch (the chunk's content was altered)".into());
    }
    Ok(out)
}

/// Decodes a whole chunk record (opcode, length, body) read from the file.
///
/// `keep_defs`: return the schema and channel records found inside (the scan needs them;
/// a read through the summary already knows every channel).
pub(crate) fn decode_chunk_record(
    record: Vec<u8>,
    want: &ChannelFilter,
    keep_defs: bool,
    dec: &mut Decompressors,
) -> Result<Decoded, String> {
    let framed = wire::frame(&record, 0).ok_or("chunk record cut short")?;
    if framed.opcode != op::CHUNK || framed.end != record.len() {
        return Err(format!(
            "no chunk record here (opcode {:#04x}, {} of {} bytes framed)",
            framed.opcode,
            framed.end,
            record.len()
        ));
    }
    let c = wire::chunk(framed.body).ok_or("malformed chunk record")?;
    let content = chunk_content(&c, dec)?;
    let mut d = Decoded::default();
    let buf: Arc<[u8]> = match content {
        Some(v) => Arc::from(v),
        None => Arc::from(c.records),
    };
    parse_records(&buf, want, keep_defs, true, &mut d)?;
    d.buf = buf;
    Ok(d)
}

/// Decodes a run of top-level records (other writers' unchunked messages).
pub(crate) fn decode_loose_run(bytes: Vec<u8>, want: &ChannelFilter) -> Result<Decoded, String> {
    let buf: Arc<[u8]> = Arc::from(bytes);
    let mut d = Decoded::default();
    parse_records(&buf, want, false, false, &mut d)?;
    d.buf = buf;
    Ok(d)
}

/// Walks the records of `content`: messages (wanted ones located), schema and channel
/// records (kept when asked). `in_chunk`: only schema, channel and message records (and
/// private opcodes ≥ 0x80) may appear.
fn parse_records(
    content: &[u8],
    want: &ChannelFilter,
    keep_defs: bool,
    in_chunk: bool,
    d: &mut Decoded,
) -> Result<(), String> {
    let mut pos = 0usize;
    let mut last_t = None;
    while pos < content.len() {
        let Some(r) = wire::frame(content, pos) else {
            return Err(format!("record cut short inside the chunk at {pos}"));
        };
        match r.opcode {
            op::MESSAGE => {
                let h = wire::message_head(r.body).ok_or("malformed message record")?;
                d.note_message(&h, &mut last_t);
                if want.wants(h.channel_id) {
                    let start = r.body_start + MESSAGE_HEAD_LEN;
                    let len = r.end - start;
                    d.locs.push(Loc {
                        t_ns: h.log_time,
                        sequence: h.sequence,
                        channel_id: h.channel_id,
                        start: u32::try_from(start).map_err(|_| "chunk too large")?,
                        len: u32::try_from(len).map_err(|_| "message too large")?,
                    });
                }
            }
            op::SCHEMA => {
                let s = wire::schema(r.body).ok_or("malformed schema record")?;
                if s.id == 0 {
                    return Err("schema record with id 0".into());
                }
                if keep_defs {
                    d.schemas.push(s);
                }
            }
            op::CHANNEL => {
                let c = wire::channel(r.body).ok_or("malformed channel record")?;
                if keep_defs {
                    d.channels.push(c);
                }
            }
            other if other >= 0x80 => {}
            other if in_chunk => {
                return Err(format!("record with opcode {other:#04x} inside a chunk"));
            }
            _ => {}
        }
        pos = r.end;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn filters() {
        let f = ChannelFilter::only(vec![3, 1, 3]);
        assert!(f.wants(1) && f.wants(3) && !f.wants(2));
        assert!(f.wants_any(&[2, 3]) && !f.wants_any(&[2, 4]));
        assert!(ChannelFilter::ALL.wants(9));
    }

    #[test]
    fn forged_sizes_are_refused_or_cost_only_the_data() {
        let mut dec = Decompressors::default();
        let huge = wire::ChunkRec {
            uncompressed_size: MAX_CHUNK_BYTES + 1,
            uncompressed_crc: 0,
            compression: "zstd",
            records: &[1, 2, 3],
        };
        assert!(
            chunk_content(&huge, &mut dec)
                .unwrap_err()
                .contains("limit")
        );
        let big = wire::ChunkRec {
            uncompressed_size: MAX_CHUNK_BYTES,
            ..huge
        };
        assert!(chunk_content(&big, &mut dec).is_err());
        let lz = wire::ChunkRec {
            compression: "lz4",
            ..big
        };
        assert!(chunk_content(&lz, &mut dec).is_err());
        let other = wire::ChunkRec {
            compression: "brotli",
            uncompressed_size: 3,
            ..huge
        };
        assert!(
            chunk_content(&other, &mut dec)
                .unwrap_err()
                .contains("brotli")
        );
    }
}
