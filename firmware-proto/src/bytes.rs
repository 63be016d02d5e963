//! Bounds-checked little-endian readers and writers (no indexing, no panics).

/// Reads little-endian values from the front of a slice. Every read returns
/// `None` once the slice is exhausted.
pub(crate) struct Reader<'a> {
    rest: &'a [u8],
}

impl<'a> Reader<'a> {
    pub(crate) const fn new(bytes: &'a [u8]) -> Self {
        Self { rest: bytes }
    }

    pub(crate) fn array<const K: usize>(&mut self) -> Option<[u8; K]> {
        let (head, tail) = self.rest.split_first_chunk::<K>()?;
        self.rest = tail;
        Some(*head)
    }

    pub(crate) fn u8(&mut self) -> Option<u8> {
        self.array::<1>().map(|[b]| b)
    }

    pub(crate) fn i8(&mut self) -> Option<i8> {
        self.array::<1>().map(i8::from_le_bytes)
    }

    pub(crate) fn u16(&mut self) -> Option<u16> {
        self.array::<2>().map(u16::from_le_bytes)
    }

    pub(crate) fn i16(&mut self) -> Option<i16> {
        self.array::<2>().map(i16::from_le_bytes)
    }

    pub(crate) fn u32(&mut self) -> Option<u32> {
        self.array::<4>().map(u32::from_le_bytes)
    }

    pub(crate) fn is_empty(&self) -> bool {
        self.rest.is_empty()
    }
}

/// Writes bytes into a slice; a write that does not fit sets `overflow` and
/// writes nothing.
pub(crate) struct Writer<'a> {
    buf: &'a mut [u8],
    pos: usize,
    overflow: bool,
}

impl<'a> Writer<'a> {
    pub(crate) fn new(buf: &'a mut [u8]) -> Self {
        Self {
            buf,
            pos: 0,
            overflow: false,
        }
    }

    pub(crate) fn put(&mut self, bytes: &[u8]) {
        let end = self.pos.saturating_add(bytes.len());
        match self.buf.get_mut(self.pos..end) {
            Some(dst) => {
                dst.copy_from_slice(bytes);
                self.pos = end;
            }
            None => self.overflow = true,
        }
    }

    pub(crate) fn u8(&mut self, v: u8) {
        self.put(&[v]);
    }

    pub(crate) fn i8(&mut self, v: i8) {
        self.put(&v.to_le_bytes());
    }

    pub(crate) fn u16(&mut self, v: u16) {
        self.put(&v.to_le_bytes());
    }

    pub(crate) fn i16(&mut self, v: i16) {
        self.put(&v.to_le_bytes());
    }

    pub(crate) fn u32(&mut self, v: u32) {
        self.put(&v.to_le_bytes());
    }

    /// Number of bytes written, or `None` if any write did not fit.
    pub(crate) fn finish(self) -> Option<usize> {
        (!self.overflow).then_some(self.pos)
    }
}

/// Encodes into a fixed-size array whose size the caller has matched to the
/// message layout; the debug assertion checks that the layout filled it exactly.
pub(crate) fn fill<const N: usize>(write: impl FnOnce(&mut Writer<'_>)) -> [u8; N] {
    let mut out = [0u8; N];
    let mut w = Writer::new(&mut out);
    write(&mut w);
    let written = w.finish();
    debug_assert_eq!(written, Some(N), "message layout does not fill its array");
    out
}
