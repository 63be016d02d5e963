//! Bounds-checked little-endian reading of MCAP record bodies.
//!
//! The reader parses untrusted files with this instead of the `mcap` crate's parser: every
//! length is checked against the bytes actually present before anything is allocated, and
//! every failure is a value, never a panic.

use std::collections::BTreeMap;

/// The MCAP magic (spec version 0).
pub(crate) const MAGIC: [u8; 8] = [0x89, b'M', b'C', b'A', b'P', b'0', b'\r', b'\n'];

/// Record opcodes.
pub(crate) mod op {
    pub const HEADER: u8 = 0x01;
    pub const FOOTER: u8 = 0x02;
    pub const SCHEMA: u8 = 0x03;
    pub const CHANNEL: u8 = 0x04;
    pub const MESSAGE: u8 = 0x05;
    pub const CHUNK: u8 = 0x06;
    pub const MESSAGE_INDEX: u8 = 0x07;
    pub const CHUNK_INDEX: u8 = 0x08;
    pub const ATTACHMENT: u8 = 0x09;
    pub const ATTACHMENT_INDEX: u8 = 0x0A;
    pub const STATISTICS: u8 = 0x0B;
    pub const METADATA: u8 = 0x0C;
    pub const METADATA_INDEX: u8 = 0x0D;
    pub const SUMMARY_OFFSET: u8 = 0x0E;
    pub const DATA_END: u8 = 0x0F;
}

/// Opcode (1) + length (8).
pub(crate) const RECORD_HEADER_LEN: usize = 9;
/// Footer record: opcode, length 20, summary_start, summary_offset_start, summary_crc.
pub(crate) const FOOTER_RECORD_LEN: usize = RECORD_HEADER_LEN + 20;

/// A cursor over a record body.
#[derive(Debug, Clone)]
pub(crate) struct Rd<'a> {
    buf: &'a [u8],
    pos: usize,
}

impl<'a> Rd<'a> {
    pub(crate) fn new(buf: &'a [u8]) -> Self {
        Self { buf, pos: 0 }
    }

    pub(crate) fn pos(&self) -> usize {
        self.pos
    }

    pub(crate) fn remaining(&self) -> usize {
        self.buf.len().saturating_sub(self.pos)
    }

    pub(crate) fn bytes(&mut self, n: usize) -> Option<&'a [u8]> {
        let end = self.pos.checked_add(n)?;
        let out = self.buf.get(self.pos..end)?;
        self.pos = end;
        Some(out)
    }

    fn array<const N: usize>(&mut self) -> Option<[u8; N]> {
        self.bytes(N)?.try_into().ok()
    }

    pub(crate) fn u8(&mut self) -> Option<u8> {
        self.array::<1>().map(|[b]| b)
    }

    pub(crate) fn u16(&mut self) -> Option<u16> {
        self.array().map(u16::from_le_bytes)
    }

    pub(crate) fn u32(&mut self) -> Option<u32> {
        self.array().map(u32::from_le_bytes)
    }

    pub(crate) fn u64(&mut self) -> Option<u64> {
        self.array().map(u64::from_le_bytes)
    }

    /// A u32-length-prefixed UTF-8 string.
    pub(crate) fn str(&mut self) -> Option<&'a str> {
        let n = usize::try_from(self.u32()?).ok()?;
        std::str::from_utf8(self.bytes(n)?).ok()
    }

    /// u32-length-prefixed bytes.
    pub(crate) fn bytes32(&mut self) -> Option<&'a [u8]> {
        let n = usize::try_from(self.u32()?).ok()?;
        self.bytes(n)
    }

    /// u64-length-prefixed bytes.
    pub(crate) fn bytes64(&mut self) -> Option<&'a [u8]> {
        let n = usize::try_from(self.u64()?).ok()?;
        self.bytes(n)
    }

    /// A map<string, string> (u32 byte length, then key/value pairs).
    pub(crate) fn string_map(&mut self) -> Option<BTreeMap<String, String>> {
        let mut inner = Rd::new(self.bytes32()?);
        let mut out = BTreeMap::new();
        while inner.remaining() > 0 {
            let k = inner.str()?;
            let v = inner.str()?;
            out.insert(k.to_string(), v.to_string());
        }
        Some(out)
    }

    /// A map<u16, u64> (u32 byte length, then pairs).
    pub(crate) fn u16_u64_map(&mut self) -> Option<BTreeMap<u16, u64>> {
        let mut inner = Rd::new(self.bytes32()?);
        let mut out = BTreeMap::new();
        while inner.remaining() > 0 {
            let k = inner.u16()?;
            let v = inner.u64()?;
            out.insert(k, v);
        }
        Some(out)
    }
}

/// One framed record: opcode, body, and where it starts and ends in its buffer.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Framed<'a> {
    pub opcode: u8,
    pub body: &'a [u8],
    /// Offset of the body within the buffer.
    pub body_start: usize,
    /// Offset just past the record.
    pub end: usize,
}

/// Frames the record at `pos`; `None` when it does not fit in `buf` (cut short).
pub(crate) fn frame(buf: &[u8], pos: usize) -> Option<Framed<'_>> {
    let mut r = Rd::new(buf.get(pos..)?);
    let opcode = r.u8()?;
    let len = usize::try_from(r.u64()?).ok()?;
    let body_start = pos.checked_add(RECORD_HEADER_LEN)?;
    let end = body_start.checked_add(len)?;
    let body = buf.get(body_start..end)?;
    Some(Framed {
        opcode,
        body,
        body_start,
        end,
    })
}

/// The fixed part of a message record.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct MessageHead {
    pub channel_id: u16,
    pub sequence: u32,
    pub log_time: u64,
}

/// Length of a message record's fixed part.
pub(crate) const MESSAGE_HEAD_LEN: usize = 2 + 4 + 8 + 8;

pub(crate) fn message_head(body: &[u8]) -> Option<MessageHead> {
    let mut r = Rd::new(body);
    let channel_id = r.u16()?;
    let sequence = r.u32()?;
    let log_time = r.u64()?;
    let _publish_time = r.u64()?;
    Some(MessageHead {
        channel_id,
        sequence,
        log_time,
    })
}

/// A schema record.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SchemaDef {
    /// Schema id (1..).
    pub id: u16,
    /// Name, e.g. `topside.TelemetryNav`.
    pub name: String,
    /// Schema encoding, e.g. `jsonschema`.
    pub encoding: String,
    /// Schema text.
    pub data: Vec<u8>,
}

pub(crate) fn schema(body: &[u8]) -> Option<SchemaDef> {
    let mut r = Rd::new(body);
    let id = r.u16()?;
    let name = r.str()?.to_string();
    let encoding = r.str()?.to_string();
    let data = r.bytes32()?.to_vec();
    Some(SchemaDef {
        id,
        name,
        encoding,
        data,
    })
}

/// A channel record.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChannelDef {
    /// Channel id.
    pub id: u16,
    /// Schema id, 0 for none.
    pub schema_id: u16,
    /// Topic name.
    pub topic: String,
    /// Message encoding.
    pub encoding: String,
    /// Channel metadata.
    pub metadata: BTreeMap<String, String>,
}

pub(crate) fn channel(body: &[u8]) -> Option<ChannelDef> {
    let mut r = Rd::new(body);
    let id = r.u16()?;
    let schema_id = r.u16()?;
    let topic = r.str()?.to_string();
    let encoding = r.str()?.to_string();
    let metadata = r.string_map()?;
    Some(ChannelDef {
        id,
        schema_id,
        topic,
        encoding,
        metadata,
    })
}

/// A chunk record's header and its (possibly compressed) records.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ChunkRec<'a> {
    pub uncompressed_size: u64,
    pub uncompressed_crc: u32,
    pub compression: &'a str,
    pub records: &'a [u8],
}

pub(crate) fn chunk(body: &[u8]) -> Option<ChunkRec<'_>> {
    let mut r = Rd::new(body);
    let _start_ns = r.u64()?;
    let _end_ns = r.u64()?;
    let uncompressed_size = r.u64()?;
    let uncompressed_crc = r.u32()?;
    let compression = r.str()?;
    let n = usize::try_from(r.u64()?).ok()?;
    let records = r.bytes(n)?;
    Some(ChunkRec {
        uncompressed_size,
        uncompressed_crc,
        compression,
        records,
    })
}

/// A chunk index record (summary section); its channels go to a shared list.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct ChunkIndexRec {
    pub start_ns: u64,
    pub end_ns: u64,
    pub chunk_offset: u64,
    pub chunk_length: u64,
    /// Range of the shared channel list holding this chunk's channels.
    pub chans: (u32, u32),
}

/// Parses a chunk index; its channel ids (the keys of its message index offsets) are
/// appended to `channels`.
pub(crate) fn chunk_index(body: &[u8], channels: &mut Vec<u16>) -> Option<ChunkIndexRec> {
    let mut r = Rd::new(body);
    let start_ns = r.u64()?;
    let end_ns = r.u64()?;
    let chunk_offset = r.u64()?;
    let chunk_length = r.u64()?;
    let mut offsets = Rd::new(r.bytes32()?);
    let mark = channels.len();
    while offsets.remaining() > 0 {
        let (Some(id), Some(_)) = (offsets.u16(), offsets.u64()) else {
            channels.truncate(mark);
            return None;
        };
        channels.push(id);
    }
    let _message_index_length = r.u64()?;
    let _compression = r.str()?;
    let _compressed_size = r.u64()?;
    let _uncompressed_size = r.u64()?;
    Some(ChunkIndexRec {
        start_ns,
        end_ns,
        chunk_offset,
        chunk_length,
        chans: (0, 0),
    })
}

/// Offset and length of a record named by an attachment or metadata index.
pub(crate) fn index_target(body: &[u8]) -> Option<(u64, u64)> {
    let mut r = Rd::new(body);
    Some((r.u64()?, r.u64()?))
}

/// An attachment.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AttachmentData {
    /// Log time, ns.
    pub log_time: u64,
    /// Creation time, ns.
    pub create_time: u64,
    /// Name, e.g. `config.toml`.
    pub name: String,
    /// Media type.
    pub media_type: String,
    /// Content.
    pub data: Vec<u8>,
}

/// Parses an attachment and checks its CRC (when non-zero).
pub(crate) fn attachment(body: &[u8]) -> Result<AttachmentData, &'static str> {
    let bad = "attachment record is malformed";
    let mut r = Rd::new(body);
    let log_time = r.u64().ok_or(bad)?;
    let create_time = r.u64().ok_or(bad)?;
    let name = r.str().ok_or(bad)?.to_string();
    let media_type = r.str().ok_or(bad)?.to_string();
    let data = r.bytes64().ok_or(bad)?;
    let covered = body.get(..r.pos()).ok_or(bad)?;
    let crc = r.u32().ok_or(bad)?;
    if crc != 0 && crc32fast::hash(covered) != crc {
        return Err("attachment CRC mismatch");
    }
    Ok(AttachmentData {
        log_time,
        create_time,
        name,
        media_type,
        data: data.to_vec(),
    })
}

/// Parses a metadata record.
pub(crate) fn metadata(body: &[u8]) -> Option<(String, BTreeMap<String, String>)> {
    let mut r = Rd::new(body);
    let name = r.str()?.to_string();
    let map = r.string_map()?;
    Some((name, map))
}

/// The statistics record (the fields the reader uses).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub(crate) struct Stats {
    pub message_count: u64,
    pub chunk_count: u32,
    pub start_ns: u64,
    pub end_ns: u64,
    pub channel_message_counts: BTreeMap<u16, u64>,
}

pub(crate) fn statistics(body: &[u8]) -> Option<Stats> {
    let mut r = Rd::new(body);
    let message_count = r.u64()?;
    let _schema_count = r.u16()?;
    let _channel_count = r.u32()?;
    let _attachment_count = r.u32()?;
    let _metadata_count = r.u32()?;
    let chunk_count = r.u32()?;
    let start_ns = r.u64()?;
    let end_ns = r.u64()?;
    let channel_message_counts = r.u16_u64_map()?;
    Some(Stats {
        message_count,
        chunk_count,
        start_ns,
        end_ns,
        channel_message_counts,
    })
}

/// The footer fields the reader uses: summary start and the summary CRC.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Footer {
    pub summary_start: u64,
    pub summary_crc: u32,
}

pub(crate) fn footer(body: &[u8]) -> Option<Footer> {
    let mut r = Rd::new(body);
    let summary_start = r.u64()?;
    let _summary_offset_start = r.u64()?;
    let summary_crc = r.u32()?;
    Some(Footer {
        summary_start,
        summary_crc,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_input_is_none_not_a_panic() {
        assert_eq!(Rd::new(&[1]).u16(), None);
        assert_eq!(Rd::new(&[5, 0, 0, 0, b'a']).str(), None);
        assert_eq!(Rd::new(&[0xFF, 0xFF, 0xFF, 0xFF]).bytes32(), None);
        assert!(frame(&[6, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF], 0).is_none());
        assert!(frame(&[6, 1, 0, 0, 0, 0, 0, 0, 0], 0).is_none());
        assert!(frame(&[6, 1, 0, 0, 0, 0, 0, 0, 0, 42], 0).is_some());
        assert!(frame(&[], 3).is_none());
        assert!(channel(&[1, 0, 0, 0, 9, 0, 0, 0]).is_none());
        assert!(attachment(&[0; 10]).is_err());
        assert!(statistics(&[0; 3]).is_none());
    }

    #[test]
    fn maps_parse() {
        let mut body = Vec::new();
        let pair = |b: &mut Vec<u8>, s: &str| {
            b.extend_from_slice(&(s.len() as u32).to_le_bytes());
            b.extend_from_slice(s.as_bytes());
        };
        let mut inner = Vec::new();
        pair(&mut inner, "k");
        pair(&mut inner, "v");
        body.extend_from_slice(&(inner.len() as u32).to_le_bytes());
        body.extend_from_slice(&inner);
        let m = Rd::new(&body).string_map().unwrap();
        assert_eq!(m.get("k").map(String::as_str), Some("v"));
        body.truncate(body.len() - 1);
        assert!(Rd::new(&body).string_map().is_none());
    }
}
