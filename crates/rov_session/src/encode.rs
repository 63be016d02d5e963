//! Encoding MCAP records (spec version 0) into byte buffers. Pure: the file writer
//! ([`crate::mcap_file`]) decides where the bytes go. Mirror of [`crate::wire`].

use std::collections::BTreeMap;

use crate::wire::op;

/// Little-endian appends with the MCAP string, bytes and map layouts.
pub(crate) trait Put {
    fn u8(&mut self, x: u8);
    fn u16(&mut self, x: u16);
    fn u32(&mut self, x: u32);
    fn u64(&mut self, x: u64);
    /// A u32-length-prefixed string (or bytes).
    fn str(&mut self, s: &[u8]);
    /// A map<string, string> (u32 byte length, then pairs).
    fn string_map(&mut self, m: &BTreeMap<String, String>);
    /// A map<u16, u64> (u32 byte length, then pairs).
    fn u16_u64_map(&mut self, m: &[(u16, u64)]);
}

impl Put for Vec<u8> {
    fn u8(&mut self, x: u8) {
        self.push(x);
    }
    fn u16(&mut self, x: u16) {
        self.extend_from_slice(&x.to_le_bytes());
    }
    fn u32(&mut self, x: u32) {
        self.extend_from_slice(&x.to_le_bytes());
    }
    fn u64(&mut self, x: u64) {
        self.extend_from_slice(&x.to_le_bytes());
    }
    fn str(&mut self, s: &[u8]) {
        self.u32(s.len() as u32);
        self.extend_from_slice(s);
    }
    fn string_map(&mut self, m: &BTreeMap<String, String>) {
        let len: usize = m.iter().map(|(k, v)| 8 + k.len() + v.len()).sum();
        self.u32(len as u32);
        for (k, v) in m {
            self.str(k.as_bytes());
            self.str(v.as_bytes());
        }
    }
    fn u16_u64_map(&mut self, m: &[(u16, u64)]) {
        self.u32((m.len() * 10) as u32);
        for (k, v) in m {
            self.u16(*k);
            self.u64(*v);
        }
    }
}

/// Appends a record: opcode, length placeholder, the body written by `body`, then the
/// length patched in. Returns the record's length (header included).
pub(crate) fn record(out: &mut Vec<u8>, opcode: u8, body: impl FnOnce(&mut Vec<u8>)) -> usize {
    let start = out.len();
    out.u8(opcode);
    out.u64(0);
    body(out);
    let len = (out.len() - start - 9) as u64;
    if let Some(slot) = out.get_mut(start + 1..start + 9) {
        slot.copy_from_slice(&len.to_le_bytes());
    }
    out.len() - start
}

pub(crate) fn header(out: &mut Vec<u8>, profile: &str, library: &str) {
    record(out, op::HEADER, |b| {
        b.str(profile.as_bytes());
        b.str(library.as_bytes());
    });
}

pub(crate) fn schema(out: &mut Vec<u8>, id: u16, name: &str, encoding: &str, data: &[u8]) {
    record(out, op::SCHEMA, |b| {
        b.u16(id);
        b.str(name.as_bytes());
        b.str(encoding.as_bytes());
        b.str(data);
    });
}

pub(crate) fn channel(
    out: &mut Vec<u8>,
    id: u16,
    schema_id: u16,
    topic: &str,
    encoding: &str,
    metadata: &BTreeMap<String, String>,
) {
    record(out, op::CHANNEL, |b| {
        b.u16(id);
        b.u16(schema_id);
        b.str(topic.as_bytes());
        b.str(encoding.as_bytes());
        b.string_map(metadata);
    });
}

/// A message record; returns the record's length.
pub(crate) fn message(
    out: &mut Vec<u8>,
    channel_id: u16,
    sequence: u32,
    log_time: u64,
    publish_time: u64,
    data: &[u8],
) -> usize {
    record(out, op::MESSAGE, |b| {
        b.u16(channel_id);
        b.u32(sequence);
        b.u64(log_time);
        b.u64(publish_time);
        b.extend_from_slice(data);
    })
}

/// The fixed part of a chunk record before its records: (start, end, uncompressed size,
/// uncompressed CRC, compression, records length).
pub(crate) struct ChunkHead<'a> {
    pub start_ns: u64,
    pub end_ns: u64,
    pub uncompressed_size: u64,
    pub uncompressed_crc: u32,
    pub compression: &'a str,
}

/// A chunk record around `records` (already compressed as `head.compression` says).
pub(crate) fn chunk(out: &mut Vec<u8>, head: &ChunkHead<'_>, records: &[u8]) -> usize {
    record(out, op::CHUNK, |b| {
        b.u64(head.start_ns);
        b.u64(head.end_ns);
        b.u64(head.uncompressed_size);
        b.u32(head.uncompressed_crc);
        b.str(head.compression.as_bytes());
        b.u64(records.len() as u64);
        b.extend_from_slice(records);
    })
}

/// A message index record: (log time, offset in the uncompressed chunk) per message.
pub(crate) fn message_index(out: &mut Vec<u8>, channel_id: u16, entries: &[(u64, u64)]) -> usize {
    record(out, op::MESSAGE_INDEX, |b| {
        b.u16(channel_id);
        b.u32((entries.len() * 16) as u32);
        for (t, off) in entries {
            b.u64(*t);
            b.u64(*off);
        }
    })
}

/// A chunk index record.
pub(crate) struct ChunkIndex<'a> {
    pub start_ns: u64,
    pub end_ns: u64,
    pub chunk_offset: u64,
    pub chunk_length: u64,
    pub message_index_offsets: &'a [(u16, u64)],
    pub message_index_length: u64,
    pub compression: &'a str,
    pub compressed_size: u64,
    pub uncompressed_size: u64,
}

pub(crate) fn chunk_index(out: &mut Vec<u8>, c: &ChunkIndex<'_>) {
    record(out, op::CHUNK_INDEX, |b| {
        b.u64(c.start_ns);
        b.u64(c.end_ns);
        b.u64(c.chunk_offset);
        b.u64(c.chunk_length);
        b.u16_u64_map(c.message_index_offsets);
        b.u64(c.message_index_length);
        b.str(c.compression.as_bytes());
        b.u64(c.compressed_size);
        b.u64(c.uncompressed_size);
    });
}

/// An attachment record with its CRC; returns its length.
pub(crate) fn attachment(
    out: &mut Vec<u8>,
    log_time: u64,
    create_time: u64,
    name: &str,
    media_type: &str,
    data: &[u8],
) -> usize {
    record(out, op::ATTACHMENT, |b| {
        let start = b.len();
        b.u64(log_time);
        b.u64(create_time);
        b.str(name.as_bytes());
        b.str(media_type.as_bytes());
        b.u64(data.len() as u64);
        b.extend_from_slice(data);
        let crc = crc32fast::hash(b.get(start..).unwrap_or(&[]));
        b.u32(crc);
    })
}

/// An attachment index record.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct AttachmentIndex {
    pub offset: u64,
    pub length: u64,
    pub log_time: u64,
    pub create_time: u64,
    pub data_size: u64,
    pub name: String,
    pub media_type: String,
}

pub(crate) fn attachment_index(out: &mut Vec<u8>, a: &AttachmentIndex) {
    record(out, op::ATTACHMENT_INDEX, |b| {
        b.u64(a.offset);
        b.u64(a.length);
        b.u64(a.log_time);
        b.u64(a.create_time);
        b.u64(a.data_size);
        b.str(a.name.as_bytes());
        b.str(a.media_type.as_bytes());
    });
}

/// A metadata record; returns its length.
pub(crate) fn metadata(out: &mut Vec<u8>, name: &str, map: &BTreeMap<String, String>) -> usize {
    record(out, op::METADATA, |b| {
        b.str(name.as_bytes());
        b.string_map(map);
    })
}

pub(crate) fn metadata_index(out: &mut Vec<u8>, offset: u64, length: u64, name: &str) {
    record(out, op::METADATA_INDEX, |b| {
        b.u64(offset);
        b.u64(length);
        b.str(name.as_bytes());
    });
}

/// The statistics record.
pub(crate) struct Statistics<'a> {
    pub message_count: u64,
    pub schema_count: u16,
    pub channel_count: u32,
    pub attachment_count: u32,
    pub metadata_count: u32,
    pub chunk_count: u32,
    pub start_ns: u64,
    pub end_ns: u64,
    pub channel_message_counts: &'a [(u16, u64)],
}

pub(crate) fn statistics(out: &mut Vec<u8>, s: &Statistics<'_>) {
    record(out, op::STATISTICS, |b| {
        b.u64(s.message_count);
        b.u16(s.schema_count);
        b.u32(s.channel_count);
        b.u32(s.attachment_count);
        b.u32(s.metadata_count);
        b.u32(s.chunk_count);
        b.u64(s.start_ns);
        b.u64(s.end_ns);
        b.u16_u64_map(s.channel_message_counts);
    });
}

pub(crate) fn summary_offset(out: &mut Vec<u8>, opcode: u8, start: u64, length: u64) {
    record(out, op::SUMMARY_OFFSET, |b| {
        b.u8(opcode);
        b.u64(start);
        b.u64(length);
    });
}

pub(crate) fn data_end(out: &mut Vec<u8>, crc: u32) {
    record(out, op::DATA_END, |b| b.u32(crc));
}

/// The footer's opcode, length and offsets: the part the summary CRC covers.
pub(crate) fn footer_head(out: &mut Vec<u8>, summary_start: u64, summary_offset_start: u64) {
    out.u8(op::FOOTER);
    out.u64(20);
    out.u64(summary_start);
    out.u64(summary_offset_start);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wire;

    #[test]
    fn records_parse_back() {
        let mut b = Vec::new();
        schema(&mut b, 3, "n", "jsonschema", b"{}");
        let f = wire::frame(&b, 0).unwrap();
        let s = wire::schema(f.body).unwrap();
        assert_eq!(
            (s.id, s.name.as_str(), s.data.as_slice()),
            (3, "n", &b"{}"[..])
        );
        let mut b = Vec::new();
        let meta = BTreeMap::from([("k".to_string(), "v".to_string())]);
        channel(&mut b, 7, 3, "/t", "json", &meta);
        let c = wire::channel(wire::frame(&b, 0).unwrap().body).unwrap();
        assert_eq!((c.id, c.schema_id, c.topic.as_str()), (7, 3, "/t"));
        assert_eq!(c.metadata, meta);
        let mut b = Vec::new();
        attachment(&mut b, 1, 2, "config.toml", "application/toml", b"a = 1");
        let a = wire::attachment(wire::frame(&b, 0).unwrap().body).unwrap();
        assert_eq!(a.data, b"a = 1");
        let mut b = Vec::new();
        let mut chans = Vec::new();
        chunk_index(
            &mut b,
            &ChunkIndex {
                start_ns: 5,
                end_ns: 9,
                chunk_offset: 100,
                chunk_length: 50,
                message_index_offsets: &[(1, 150), (2, 180)],
                message_index_length: 60,
                compression: "zstd",
                compressed_size: 20,
                uncompressed_size: 40,
            },
        );
        let ci = wire::chunk_index(wire::frame(&b, 0).unwrap().body, &mut chans).unwrap();
        assert_eq!((ci.chunk_offset, ci.chunk_length, ci.end_ns), (100, 50, 9));
        assert_eq!(chans, [1, 2]);
    }
}
