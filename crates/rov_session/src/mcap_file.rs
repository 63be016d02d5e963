//! [`McapFile`]: writes an MCAP file whose memory does not grow with its length.
//!
//! The `mcap` crate's writer keeps every chunk's index in memory until it writes the
//! summary (about 550 bytes per chunk: 7 MB per hour of station recording, 60 MB over an
//! 8-hour dive at four chunks a second). This writer appends each chunk index, encoded,
//! to an anonymous temporary file as the chunk is written and copies them into the
//! summary at the end; what it holds is the chunk being built, the schemas and channels,
//! and per-channel counts. The records are those of the MCAP specification (version 0),
//! encoded by [`crate::encode`]; the layout is the `mcap` crate's: schema and channel
//! records inside the first chunk that uses them, each chunk followed by its message
//! indexes, attachments and metadata at top level, then the data-end record with the data
//! section CRC, the summary (schemas, channels, statistics, chunk, attachment and metadata
//! indexes, summary offsets), the footer with the summary CRC. Tests read its files with
//! the `mcap` crate and the official Python reader.
//!
//! A chunk is built in memory and written whole by [`McapFile::flush`] (or when it
//! reaches the chunk size): a kill never leaves half a chunk behind.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Read, Seek as _, Write};
use std::path::Path;

use crate::encode::{self, AttachmentIndex, ChunkHead, ChunkIndex, Statistics};
use crate::wire::{MAGIC, op};

/// Writer settings.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct McapOptions {
    /// zstd-compress the chunks.
    pub compress: bool,
    /// Close a chunk once its records reach this size, bytes.
    pub chunk_size: usize,
    /// The header's library string.
    pub library: String,
}

/// What a finished file holds.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub(crate) struct McapStats {
    pub messages: u64,
    pub chunks: u32,
    /// Messages per channel.
    pub channel_counts: BTreeMap<u16, u64>,
}

#[derive(Debug)]
struct SchemaRec {
    name: String,
    encoding: String,
    data: Vec<u8>,
    written: bool,
}

#[derive(Debug)]
struct ChannelRec {
    schema_id: u16,
    topic: String,
    encoding: String,
    metadata: BTreeMap<String, String>,
    written: bool,
}

/// Where the chunk indexes wait for the summary.
#[derive(Debug)]
enum Spill {
    File(BufWriter<File>),
    /// No temporary file could be made: in memory (grows ~250 bytes per chunk).
    Memory(Vec<u8>),
}

/// The chunk being built.
#[derive(Debug, Default)]
struct OpenChunk {
    records: Vec<u8>,
    span: Option<(u64, u64)>,
    /// Per channel, (log time, offset in `records`) of its messages.
    index: Vec<(u16, Vec<(u64, u64)>)>,
}

/// An MCAP file being written; see the module docs.
pub(crate) struct McapFile {
    out: BufWriter<File>,
    pos: u64,
    data_crc: crc32fast::Hasher,
    spill: Spill,
    spill_len: u64,
    opts: McapOptions,
    schemas: Vec<SchemaRec>,
    channels: Vec<ChannelRec>,
    chunk: OpenChunk,
    scratch: Vec<u8>,
    compressed: Vec<u8>,
    zstd: Option<zstd::bulk::Compressor<'static>>,
    message_count: u64,
    channel_counts: BTreeMap<u16, u64>,
    span: Option<(u64, u64)>,
    chunk_count: u32,
    attachments: Vec<AttachmentIndex>,
    metadata: Vec<(u64, u64, String)>,
    finished: bool,
}

impl std::fmt::Debug for McapFile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McapFile")
            .field("pos", &self.pos)
            .field("messages", &self.message_count)
            .field("chunks", &self.chunk_count)
            .finish_non_exhaustive()
    }
}

fn other(e: impl std::fmt::Display) -> std::io::Error {
    std::io::Error::other(e.to_string())
}

impl McapFile {
    /// Writes the magic and the header to `file`.
    pub(crate) fn new(file: File, opts: McapOptions) -> std::io::Result<Self> {
        let spill = match tempfile::tempfile() {
            Ok(f) => Spill::File(BufWriter::with_capacity(64 * 1024, f)),
            Err(_) => Spill::Memory(Vec::new()),
        };
        let mut w = Self {
            out: BufWriter::with_capacity(256 * 1024, file),
            pos: 0,
            data_crc: crc32fast::Hasher::new(),
            spill,
            spill_len: 0,
            opts,
            schemas: Vec::new(),
            channels: Vec::new(),
            chunk: OpenChunk::default(),
            scratch: Vec::with_capacity(64 * 1024),
            compressed: Vec::new(),
            zstd: None,
            message_count: 0,
            channel_counts: BTreeMap::new(),
            span: None,
            chunk_count: 0,
            attachments: Vec::new(),
            metadata: Vec::new(),
            finished: false,
        };
        let mut head = MAGIC.to_vec();
        let library = w.opts.library.clone();
        encode::header(&mut head, "", &library);
        w.put_data(&head)?;
        Ok(w)
    }

    /// Creates (or truncates) `path`.
    pub(crate) fn create(path: &Path, opts: McapOptions) -> std::io::Result<Self> {
        Self::new(File::create(path)?, opts)
    }

    /// A second handle to the file (for `fdatasync` while the writer is busy).
    pub(crate) fn file_handle(&self) -> std::io::Result<File> {
        self.out.get_ref().try_clone()
    }

    /// Appends data-section bytes.
    fn put_data(&mut self, b: &[u8]) -> std::io::Result<()> {
        self.out.write_all(b)?;
        self.data_crc.update(b);
        self.pos += b.len() as u64;
        Ok(())
    }

    /// Registers a schema (an identical one is reused); its id (1..).
    pub(crate) fn add_schema(
        &mut self,
        name: &str,
        encoding: &str,
        data: &[u8],
    ) -> std::io::Result<u16> {
        if let Some(i) = self
            .schemas
            .iter()
            .position(|s| s.name == name && s.encoding == encoding && s.data == data)
        {
            return u16::try_from(i + 1).map_err(other);
        }
        let id =
            u16::try_from(self.schemas.len() + 1).map_err(|_| other("more than 65535 schemas"))?;
        self.schemas.push(SchemaRec {
            name: name.into(),
            encoding: encoding.into(),
            data: data.to_vec(),
            written: false,
        });
        Ok(id)
    }

    /// Registers a channel (an identical one is reused); its id (0..).
    pub(crate) fn add_channel(
        &mut self,
        schema_id: u16,
        topic: &str,
        encoding: &str,
        metadata: &BTreeMap<String, String>,
    ) -> std::io::Result<u16> {
        if schema_id != 0 && usize::from(schema_id) > self.schemas.len() {
            return Err(other(format!("unknown schema {schema_id}")));
        }
        if let Some(i) = self.channels.iter().position(|c| {
            c.schema_id == schema_id
                && c.topic == topic
                && c.encoding == encoding
                && c.metadata == *metadata
        }) {
            return u16::try_from(i).map_err(other);
        }
        let id =
            u16::try_from(self.channels.len()).map_err(|_| other("more than 65536 channels"))?;
        self.channels.push(ChannelRec {
            schema_id,
            topic: topic.into(),
            encoding: encoding.into(),
            metadata: metadata.clone(),
            written: false,
        });
        Ok(id)
    }

    /// Appends a message to the open chunk (its channel's definition first, the first
    /// time); closes the chunk when it reaches the chunk size.
    pub(crate) fn write_message(
        &mut self,
        channel_id: u16,
        sequence: u32,
        log_time: u64,
        publish_time: u64,
        data: &[u8],
    ) -> std::io::Result<()> {
        let Some(ch) = self.channels.get_mut(usize::from(channel_id)) else {
            return Err(other(format!("unknown channel {channel_id}")));
        };
        if !ch.written {
            ch.written = true;
            let sid = ch.schema_id;
            if sid != 0
                && let Some(s) = self.schemas.get_mut(usize::from(sid) - 1)
                && !s.written
            {
                s.written = true;
                encode::schema(&mut self.chunk.records, sid, &s.name, &s.encoding, &s.data);
            }
            if let Some(ch) = self.channels.get(usize::from(channel_id)) {
                encode::channel(
                    &mut self.chunk.records,
                    channel_id,
                    ch.schema_id,
                    &ch.topic,
                    &ch.encoding,
                    &ch.metadata,
                );
            }
        }
        let offset = self.chunk.records.len() as u64;
        encode::message(
            &mut self.chunk.records,
            channel_id,
            sequence,
            log_time,
            publish_time,
            data,
        );
        match self.chunk.index.iter_mut().find(|(c, _)| *c == channel_id) {
            Some((_, v)) => v.push((log_time, offset)),
            None => self
                .chunk
                .index
                .push((channel_id, vec![(log_time, offset)])),
        }
        let widen = |s: Option<(u64, u64)>| {
            Some(match s {
                None => (log_time, log_time),
                Some((a, b)) => (a.min(log_time), b.max(log_time)),
            })
        };
        self.chunk.span = widen(self.chunk.span);
        self.span = widen(self.span);
        self.message_count += 1;
        *self.channel_counts.entry(channel_id).or_insert(0) += 1;
        if self.chunk.records.len() >= self.opts.chunk_size {
            self.close_chunk()?;
        }
        Ok(())
    }

    /// Writes the open chunk, its message indexes and (to the spill) its chunk index.
    fn close_chunk(&mut self) -> std::io::Result<()> {
        if self.chunk.records.is_empty() {
            return Ok(());
        }
        let records = std::mem::take(&mut self.chunk.records);
        let uncompressed_crc = crc32fast::hash(&records);
        let compression = if self.opts.compress { "zstd" } else { "" };
        let body: &[u8] = if self.opts.compress {
            let z = match &mut self.zstd {
                Some(z) => z,
                None => self
                    .zstd
                    .insert(zstd::bulk::Compressor::new(0).map_err(other)?),
            };
            self.compressed.clear();
            self.compressed
                .reserve(zstd::zstd_safe::compress_bound(records.len()));
            z.compress_to_buffer(&records, &mut self.compressed)
                .map_err(other)?;
            &self.compressed
        } else {
            &records
        };
        let (start_ns, end_ns) = self.chunk.span.unwrap_or((0, 0));
        self.scratch.clear();
        let chunk_offset = self.pos;
        let chunk_length = encode::chunk(
            &mut self.scratch,
            &ChunkHead {
                start_ns,
                end_ns,
                uncompressed_size: records.len() as u64,
                uncompressed_crc,
                compression,
            },
            body,
        ) as u64;
        let compressed_size = body.len() as u64;
        let mut offsets: Vec<(u16, u64)> = Vec::with_capacity(self.chunk.index.len());
        let mut index = std::mem::take(&mut self.chunk.index);
        index.sort_by_key(|(c, _)| *c);
        let mut at = chunk_offset + chunk_length;
        for (c, entries) in &index {
            offsets.push((*c, at));
            at += encode::message_index(&mut self.scratch, *c, entries) as u64;
        }
        let message_index_length = at - chunk_offset - chunk_length;
        let bytes = std::mem::take(&mut self.scratch);
        let res = self.put_data(&bytes);
        self.scratch = bytes;
        res?;
        let mut ci = Vec::with_capacity(64 + offsets.len() * 10);
        encode::chunk_index(
            &mut ci,
            &ChunkIndex {
                start_ns,
                end_ns,
                chunk_offset,
                chunk_length,
                message_index_offsets: &offsets,
                message_index_length,
                compression,
                compressed_size,
                uncompressed_size: records.len() as u64,
            },
        );
        match &mut self.spill {
            Spill::File(f) => f.write_all(&ci)?,
            Spill::Memory(v) => v.extend_from_slice(&ci),
        }
        self.spill_len += ci.len() as u64;
        self.chunk_count += 1;
        // Keep the buffers' capacity for the next chunk.
        let mut records = records;
        records.clear();
        self.chunk.records = records;
        self.chunk.span = None;
        Ok(())
    }

    /// Writes an attachment (closing the open chunk first).
    pub(crate) fn attach(
        &mut self,
        log_time: u64,
        create_time: u64,
        name: &str,
        media_type: &str,
        data: &[u8],
    ) -> std::io::Result<()> {
        self.close_chunk()?;
        let mut b = Vec::with_capacity(64 + data.len());
        let length =
            encode::attachment(&mut b, log_time, create_time, name, media_type, data) as u64;
        self.attachments.push(AttachmentIndex {
            offset: self.pos,
            length,
            log_time,
            create_time,
            data_size: data.len() as u64,
            name: name.into(),
            media_type: media_type.into(),
        });
        self.put_data(&b)
    }

    /// Writes a metadata record (closing the open chunk first).
    pub(crate) fn write_metadata(
        &mut self,
        name: &str,
        map: &BTreeMap<String, String>,
    ) -> std::io::Result<()> {
        self.close_chunk()?;
        let mut b = Vec::new();
        let length = encode::metadata(&mut b, name, map) as u64;
        self.metadata.push((self.pos, length, name.into()));
        self.put_data(&b)
    }

    /// Closes the open chunk and hands everything written so far to the OS.
    pub(crate) fn flush(&mut self) -> std::io::Result<()> {
        self.close_chunk()?;
        self.out.flush()
    }

    /// Whether [`McapFile::finish`] has run.
    pub(crate) fn is_finished(&self) -> bool {
        self.finished
    }

    /// Writes the data-end record, the summary and the footer, and flushes (no fsync).
    pub(crate) fn finish(&mut self) -> std::io::Result<McapStats> {
        if self.finished {
            return Err(other("the file is already finished"));
        }
        self.close_chunk()?;
        let mut b = Vec::new();
        encode::data_end(&mut b, self.data_crc.clone().finalize());
        self.put_data(&b)?;
        self.finished = true;
        let summary_start = self.pos;
        let mut crc = crc32fast::Hasher::new();
        let mut groups: Vec<(u8, u64, u64)> = Vec::new();
        // Schemas and channels.
        let mut b = Vec::new();
        for (i, s) in self.schemas.iter().enumerate() {
            encode::schema(&mut b, (i + 1) as u16, &s.name, &s.encoding, &s.data);
        }
        let schemas_len = b.len() as u64;
        for (i, c) in self.channels.iter().enumerate() {
            encode::channel(
                &mut b,
                i as u16,
                c.schema_id,
                &c.topic,
                &c.encoding,
                &c.metadata,
            );
        }
        let channels_len = b.len() as u64 - schemas_len;
        let mut at = summary_start;
        if schemas_len > 0 {
            groups.push((op::SCHEMA, at, schemas_len));
        }
        at += schemas_len;
        if channels_len > 0 {
            groups.push((op::CHANNEL, at, channels_len));
        }
        at += channels_len;
        let counts: Vec<(u16, u64)> = self.channel_counts.iter().map(|(&c, &n)| (c, n)).collect();
        let (start_ns, end_ns) = self.span.unwrap_or((0, 0));
        let before = b.len();
        encode::statistics(
            &mut b,
            &Statistics {
                message_count: self.message_count,
                schema_count: self.schemas.len() as u16,
                channel_count: self.channels.len() as u32,
                attachment_count: self.attachments.len() as u32,
                metadata_count: self.metadata.len() as u32,
                chunk_count: self.chunk_count,
                start_ns,
                end_ns,
                channel_message_counts: &counts,
            },
        );
        groups.push((op::STATISTICS, at, (b.len() - before) as u64));
        at += (b.len() - before) as u64;
        self.put_summary(&b, &mut crc)?;
        // Chunk indexes, from the spill.
        if self.spill_len > 0 {
            groups.push((op::CHUNK_INDEX, at, self.spill_len));
            at += self.spill_len;
        }
        match std::mem::replace(&mut self.spill, Spill::Memory(Vec::new())) {
            Spill::File(f) => {
                let mut file = f.into_inner().map_err(|e| e.into_error())?;
                file.rewind()?;
                let mut buf = vec![0u8; 256 * 1024];
                loop {
                    let n = file.read(&mut buf)?;
                    if n == 0 {
                        break;
                    }
                    let part = buf.get(..n).unwrap_or(&[]);
                    self.out.write_all(part)?;
                    crc.update(part);
                    self.pos += n as u64;
                }
            }
            Spill::Memory(v) => self.put_summary(&v, &mut crc)?,
        }
        // Attachment and metadata indexes.
        let mut b = Vec::new();
        for a in &self.attachments {
            encode::attachment_index(&mut b, a);
        }
        if !b.is_empty() {
            groups.push((op::ATTACHMENT_INDEX, at, b.len() as u64));
            at += b.len() as u64;
        }
        let before = b.len();
        for (off, len, name) in &self.metadata {
            encode::metadata_index(&mut b, *off, *len, name);
        }
        if b.len() > before {
            groups.push((op::METADATA_INDEX, at, (b.len() - before) as u64));
            at += (b.len() - before) as u64;
        }
        let summary_offset_start = at;
        for (opcode, start, len) in &groups {
            encode::summary_offset(&mut b, *opcode, *start, *len);
        }
        let mut footer = Vec::new();
        encode::footer_head(&mut footer, summary_start, summary_offset_start);
        b.extend_from_slice(&footer);
        self.put_summary(&b, &mut crc)?;
        let mut tail = crc.finalize().to_le_bytes().to_vec();
        tail.extend_from_slice(&MAGIC);
        self.out.write_all(&tail)?;
        self.pos += tail.len() as u64;
        self.out.flush()?;
        Ok(McapStats {
            messages: self.message_count,
            chunks: self.chunk_count,
            channel_counts: self.channel_counts.clone(),
        })
    }

    fn put_summary(&mut self, b: &[u8], crc: &mut crc32fast::Hasher) -> std::io::Result<()> {
        self.out.write_all(b)?;
        crc.update(b);
        self.pos += b.len() as u64;
        Ok(())
    }

    /// The channel's topic.
    pub(crate) fn topic(&self, channel_id: u16) -> Option<&str> {
        self.channels
            .get(usize::from(channel_id))
            .map(|c| c.topic.as_str())
    }

    /// The file, after [`McapFile::finish`] (its buffer flushed).
    pub(crate) fn into_file(self) -> std::io::Result<File> {
        self.out.into_inner().map_err(|e| e.into_error())
    }
}
