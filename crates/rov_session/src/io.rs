//! The reading side's only contact with the file system: a [`Source`] of bytes read at an
//! offset.
//!
//! Everything else of the reader (framing, the summary and chunk indexes, decompression,
//! the time-ordered merge) is written against `&dyn Source`, so the same code reads a file
//! on disk ([`FileSource`]) and bytes in memory ([`BytesSource`], used by tests and the fuzz
//! target). The writer ([`crate::writer`]) and recovery ([`crate::recover`]) create files.

use std::fs::File;
use std::path::Path;
use std::sync::Arc;

/// Random-access bytes of a session.
pub trait Source: Send + Sync + std::fmt::Debug {
    /// Length, bytes.
    fn len(&self) -> u64;

    /// Whether it is empty.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Fills `buf` from `offset`; an error when the range is not all there.
    fn read_exact_at(&self, offset: u64, buf: &mut [u8]) -> std::io::Result<()>;
}

/// A file opened for reading; reads at an offset without moving a shared cursor, so several
/// threads (a stream and its prefetcher) read it at once.
#[derive(Debug)]
pub struct FileSource {
    file: File,
    len: u64,
}

impl FileSource {
    /// Opens `path`.
    pub fn open(path: &Path) -> std::io::Result<Self> {
        let file = File::open(path)?;
        let len = file.metadata()?.len();
        Ok(Self { file, len })
    }
}

impl Source for FileSource {
    fn len(&self) -> u64 {
        self.len
    }

    fn read_exact_at(&self, offset: u64, buf: &mut [u8]) -> std::io::Result<()> {
        read_at_impl(&self.file, offset, buf)
    }
}

#[cfg(unix)]
fn read_at_impl(file: &File, offset: u64, buf: &mut [u8]) -> std::io::Result<()> {
    std::os::unix::fs::FileExt::read_exact_at(file, buf, offset)
}

#[cfg(windows)]
fn read_at_impl(file: &File, offset: u64, mut buf: &mut [u8]) -> std::io::Result<()> {
    let mut at = offset;
    while !buf.is_empty() {
        let n = std::os::windows::fs::FileExt::seek_read(file, buf, at)?;
        if n == 0 {
            return Err(std::io::ErrorKind::UnexpectedEof.into());
        }
        let rest = std::mem::take(&mut buf);
        buf = rest.get_mut(n..).ok_or(std::io::ErrorKind::UnexpectedEof)?;
        at += n as u64;
    }
    Ok(())
}

/// Bytes in memory.
#[derive(Debug, Clone)]
pub struct BytesSource(Arc<[u8]>);

impl BytesSource {
    /// Wraps bytes.
    pub fn new(bytes: impl Into<Arc<[u8]>>) -> Self {
        Self(bytes.into())
    }
}

impl Source for BytesSource {
    fn len(&self) -> u64 {
        self.0.len() as u64
    }

    fn read_exact_at(&self, offset: u64, buf: &mut [u8]) -> std::io::Result<()> {
        let start = usize::try_from(offset).map_err(|_| std::io::ErrorKind::UnexpectedEof)?;
        let end = start
            .checked_add(buf.len())
            .ok_or(std::io::ErrorKind::UnexpectedEof)?;
        let from = self
            .0
            .get(start..end)
            .ok_or(std::io::ErrorKind::UnexpectedEof)?;
        buf.copy_from_slice(from);
        Ok(())
    }
}

/// Reads `n` bytes at `offset` into a new buffer, or `None` when they are not all in the
/// source. The allocation is at most what the source holds, never what a length field
/// claims beyond it.
pub(crate) fn read_vec(src: &dyn Source, offset: u64, n: u64) -> std::io::Result<Option<Vec<u8>>> {
    let end = match offset.checked_add(n) {
        Some(e) if e <= src.len() => e,
        _ => return Ok(None),
    };
    let len = usize::try_from(end - offset).map_err(|_| std::io::ErrorKind::OutOfMemory)?;
    let mut buf = vec![0u8; len];
    src.read_exact_at(offset, &mut buf)?;
    Ok(Some(buf))
}

/// A forward reader over a source with a read-ahead buffer (the scan of a file without a
/// summary reads every byte once, in order).
#[derive(Debug)]
pub(crate) struct SeqReader<'a> {
    src: &'a dyn Source,
    /// Offset of `buf[0]` in the source.
    base: u64,
    buf: Vec<u8>,
    /// Read position within `buf`.
    pos: usize,
}

/// Read-ahead block, bytes.
const READ_AHEAD: usize = 1 << 20;

impl<'a> SeqReader<'a> {
    pub(crate) fn new(src: &'a dyn Source, at: u64) -> Self {
        Self {
            src,
            base: at,
            buf: Vec::new(),
            pos: 0,
        }
    }

    /// Current offset in the source.
    pub(crate) fn offset(&self) -> u64 {
        self.base + self.pos as u64
    }

    /// Bytes left in the source from the current offset.
    pub(crate) fn remaining(&self) -> u64 {
        self.src.len().saturating_sub(self.offset())
    }

    /// The next `n` bytes without consuming them, or `None` when the source ends first.
    pub(crate) fn peek(&mut self, n: usize) -> std::io::Result<Option<&[u8]>> {
        if (n as u64) > self.remaining() {
            return Ok(None);
        }
        if self.pos + n > self.buf.len() {
            self.refill(n)?;
        }
        Ok(self.buf.get(self.pos..self.pos + n))
    }

    /// Consumes the next `n` bytes and returns them, or `None` when the source ends first.
    pub(crate) fn take(&mut self, n: usize) -> std::io::Result<Option<&[u8]>> {
        if (n as u64) > self.remaining() {
            return Ok(None);
        }
        if self.pos + n > self.buf.len() {
            self.refill(n)?;
        }
        let start = self.pos;
        self.pos += n;
        Ok(self.buf.get(start..start + n))
    }

    /// Moves the read position to `offset` (forward or back).
    pub(crate) fn seek(&mut self, offset: u64) {
        if offset >= self.base && offset <= self.base + self.buf.len() as u64 {
            self.pos = (offset - self.base) as usize;
        } else {
            self.base = offset;
            self.buf.clear();
            self.pos = 0;
        }
    }

    /// Keeps the unread bytes and reads at least `need` bytes from the current position.
    fn refill(&mut self, need: usize) -> std::io::Result<()> {
        let at = self.offset();
        let want = need.max(READ_AHEAD) as u64;
        let n = want.min(self.src.len().saturating_sub(at));
        let n = usize::try_from(n).map_err(|_| std::io::ErrorKind::OutOfMemory)?;
        self.buf.clear();
        self.buf.resize(n, 0);
        self.src.read_exact_at(at, &mut self.buf)?;
        self.base = at;
        self.pos = 0;
        Ok(())
    }
}
