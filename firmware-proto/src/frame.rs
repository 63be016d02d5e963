//! Packet framing (protocol.md §3–5): sync pairs, header, XOR checks, extended
//! length, addressing and FLAGS semantics, and the frame encoders.
//!
//! ```text
//! normal:   SYNC1 SYNC2 NODE FLAGS ADDR LEN HC | payload (LEN bytes)            | TC
//! extended: SYNC1 SYNC2 NODE FLAGS ADDR FF  HC | LO HI XC | payload (LO|HI<<8) | TC
//! ```
//!
//! `HC` is the XOR of the six bytes before it, `XC = LO ^ HI`, and `TC` is the XOR
//! of every earlier byte, which always equals the XOR of the payload alone.

use core::fmt;

use crate::device::DeviceType;
use crate::error::{EncodeError, FrameError};

/// Sync pair of a request (host → device).
pub const SYNC_REQUEST: [u8; 2] = [0xFA, 0xAF];
/// Sync pair of a response (device → host).
pub const SYNC_RESPONSE: [u8; 2] = [0xFD, 0xDF];
/// Header length up to and including the header check.
pub const HEADER_LEN: usize = 7;
/// Header length of an extended-length frame (header + 2 length bytes + their check).
pub const EXT_HEADER_LEN: usize = 10;
/// LENGTH byte value that announces an extended length.
pub const EXTENDED_LENGTH_MARKER: u8 = 0xFF;
/// Largest payload of a normal frame (LENGTH 0..=254).
pub const MAX_NORMAL_PAYLOAD_LEN: usize = 254;
/// Cap on the extended length. Larger values are treated as corruption
/// ([`FrameError::Overlong`]); the one known use (config data) is 293 bytes.
pub const MAX_EXTENDED_PAYLOAD_LEN: usize = 1024;
/// Longest normal frame: 7 + 254 + 1 = 262 bytes.
pub const MAX_NORMAL_FRAME_LEN: usize = HEADER_LEN + MAX_NORMAL_PAYLOAD_LEN + 1;
/// Longest frame accepted by default: 7 (header) + 3 (extended length) + 1024
/// (payload) + 1 (total check) = 1035 bytes.
pub const MAX_FRAME_LEN: usize = EXT_HEADER_LEN + MAX_EXTENDED_PAYLOAD_LEN + 1;

/// XOR of all bytes (the protocol's header, extended-length and total checks).
/// An empty slice gives 0.
#[must_use]
pub fn xor_checksum(bytes: &[u8]) -> u8 {
    // Eight bytes at a time; XOR is associative, so fold the lanes at the end.
    let mut chunks = bytes.chunks_exact(8);
    let mut wide = 0u64;
    for chunk in &mut chunks {
        let mut lane = [0u8; 8];
        lane.copy_from_slice(chunk);
        wide ^= u64::from_le_bytes(lane);
    }
    let tail = chunks.remainder().iter().fold(0u8, |acc, b| acc ^ b);
    wide.to_le_bytes().iter().fold(tail, |acc, b| acc ^ b)
}

/// Well-known FLAGS values (protocol.md §5.2, §6.2).
pub mod flags {
    /// No response wanted.
    pub const NONE: u8 = 0x00;
    /// Device-specific reply 1: the Pro 4 answers with the 8-byte attitude block
    /// (ping / autodetect).
    pub const PING: u8 = 0x01;
    /// Device-specific reply 5: the 33-byte navigation + health block.
    pub const NAV: u8 = 0x05;
    /// CSR dump from ADDR to the end of the application region (0xEF); also
    /// reads the config data at 0xF7. Always the FLAGS of a dump reply.
    pub const DUMP: u8 = 0x80;
    /// Status block read: dump of 14 bytes (`0x80 | 14`) at 0x7A.
    pub const STATUS_DUMP: u8 = 0x8E;
}

/// Direction of a frame, given by its sync pair.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
pub enum Direction {
    /// Host → device, sync `FA AF`.
    Request,
    /// Device → host, sync `FD DF`.
    Response,
}

impl Direction {
    /// The two sync bytes.
    #[must_use]
    pub const fn sync(self) -> [u8; 2] {
        match self {
            Self::Request => SYNC_REQUEST,
            Self::Response => SYNC_RESPONSE,
        }
    }

    /// Direction of a sync pair; `None` for anything else, mixed pairs
    /// (`FA DF`, `FD AF`) included.
    #[must_use]
    pub const fn from_sync(sync1: u8, sync2: u8) -> Option<Self> {
        match (sync1, sync2) {
            (0xFA, 0xAF) => Some(Self::Request),
            (0xFD, 0xDF) => Some(Self::Response),
            _ => None,
        }
    }

    /// `"request"` or `"response"`.
    #[must_use]
    pub const fn as_str(self) -> &'static str {
        match self {
            Self::Request => "request",
            Self::Response => "response",
        }
    }
}

impl fmt::Display for Direction {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// NODE ID byte (protocol.md §5.1). In a request it is the destination, in a
/// response the responder's own ID.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(transparent))]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
pub struct NodeId(pub u8);

/// How a [`NodeId`] addresses the bus.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Addressing {
    /// 0x00–0x7F: one device (0x00 is legal but clashes with Futaba servos).
    Unicast(u8),
    /// 0x80–0xFE: every device of `group` (= ID & 0x7F). Devices do not reply.
    Multicast {
        /// Group number 0x00–0x7E.
        group: u8,
    },
    /// 0xFF: every device. Devices do not reply.
    Broadcast,
}

impl NodeId {
    /// The Pro 4 ROV itself.
    pub const ROV: Self = Self(0x01);
    /// The Pro 4 manipulator.
    pub const MANIPULATOR: Self = Self(0x42);
    /// Broadcast to every device.
    pub const BROADCAST: Self = Self(0xFF);

    /// Multicast ID of a group (`0x80 | group`); group 0x7F gives [`Self::BROADCAST`].
    #[must_use]
    pub const fn multicast(group: u8) -> Self {
        Self(0x80 | (group & 0x7F))
    }

    /// How this ID addresses the bus.
    #[must_use]
    pub const fn addressing(self) -> Addressing {
        match self.0 {
            0xFF => Addressing::Broadcast,
            id if id & 0x80 != 0 => Addressing::Multicast { group: id & 0x7F },
            id => Addressing::Unicast(id),
        }
    }

    /// True for 0x00–0x7F. Only unicast requests are answered.
    #[must_use]
    pub const fn is_unicast(self) -> bool {
        self.0 & 0x80 == 0
    }
}

impl From<u8> for NodeId {
    fn from(id: u8) -> Self {
        Self(id)
    }
}

impl fmt::Display for NodeId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:#04X}", self.0)
    }
}

/// What a request's FLAGS byte asks for (protocol.md §5.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RequestFlags {
    /// 0x00: no response.
    NoReply,
    /// 0x01–0x7F: device-specific response of this type (Pro 4: 0x01 ping
    /// attitude block, 0x05 navigation block).
    DeviceSpecific(u8),
    /// 0x80: dump from ADDR to the end of the application region (0xEF);
    /// by convention also the config-data read at 0xF7.
    DumpToAppEnd,
    /// 0x81–0xFF: dump of exactly `count` (= FLAGS & 0x7F) bytes from ADDR.
    Dump {
        /// Number of register bytes, 1..=127.
        count: u8,
    },
}

impl RequestFlags {
    /// Interprets a FLAGS byte (never fails).
    #[must_use]
    pub const fn from_byte(b: u8) -> Self {
        match b {
            0x00 => Self::NoReply,
            0x01..=0x7F => Self::DeviceSpecific(b),
            0x80 => Self::DumpToAppEnd,
            _ => Self::Dump { count: b & 0x7F },
        }
    }

    /// The FLAGS byte. Out-of-range contents are masked to 7 bits
    /// (`DeviceSpecific(0)` and `Dump { count: 0 }` therefore give 0x00 and 0x80).
    #[must_use]
    pub const fn to_byte(self) -> u8 {
        match self {
            Self::NoReply => 0x00,
            Self::DeviceSpecific(t) => t & 0x7F,
            Self::DumpToAppEnd => 0x80,
            Self::Dump { count } => 0x80 | (count & 0x7F),
        }
    }

    /// True for the CSR-dump forms (FLAGS ≥ 0x80).
    #[must_use]
    pub const fn is_dump(self) -> bool {
        matches!(self, Self::DumpToAppEnd | Self::Dump { .. })
    }

    /// Number of register bytes a dump starting at `start` returns.
    ///
    /// `None` if this is not a dump, or for `DumpToAppEnd` above the application
    /// region (ADDR ≥ 0xF0): those special registers answer in their own way,
    /// e.g. 0xF7 with the extended config reply ([`ConfigData`](crate::ConfigData)).
    /// A `Dump { count }` running past 0xFF is not shortened here.
    #[must_use]
    pub const fn dump_len(self, start: u8) -> Option<usize> {
        match self {
            Self::DumpToAppEnd if start <= crate::csr::APP_REGION_END => {
                Some(crate::csr::APP_REGION_END as usize + 1 - start as usize)
            }
            Self::Dump { count } => Some(count as usize),
            _ => None,
        }
    }
}

impl From<u8> for RequestFlags {
    fn from(b: u8) -> Self {
        Self::from_byte(b)
    }
}

/// The addressing part of a header: everything except the length field.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
pub struct Header {
    /// Request or response (sync pair).
    pub direction: Direction,
    /// NODE ID.
    pub node: NodeId,
    /// FLAGS.
    pub flags: u8,
    /// CSR ADDRESS.
    pub addr: u8,
}

impl Header {
    /// A request header.
    #[must_use]
    pub const fn request(node: NodeId, flags: u8, addr: u8) -> Self {
        Self {
            direction: Direction::Request,
            node,
            flags,
            addr,
        }
    }

    /// A response header.
    #[must_use]
    pub const fn response(node: NodeId, flags: u8, addr: u8) -> Self {
        Self {
            direction: Direction::Response,
            node,
            flags,
            addr,
        }
    }
}

/// Which length field a frame uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
pub enum LengthField {
    /// LENGTH byte 0..=254.
    Normal,
    /// LENGTH 0xFF followed by a 16-bit length and its check.
    Extended,
}

impl LengthField {
    /// Header length for this form (7 or 10).
    #[must_use]
    pub const fn header_len(self) -> usize {
        match self {
            Self::Normal => HEADER_LEN,
            Self::Extended => EXT_HEADER_LEN,
        }
    }

    /// Largest payload the encoders accept for this form.
    #[must_use]
    pub const fn max_payload_len(self) -> usize {
        match self {
            Self::Normal => MAX_NORMAL_PAYLOAD_LEN,
            Self::Extended => MAX_EXTENDED_PAYLOAD_LEN,
        }
    }
}

/// Encoded size of a frame with `payload_len` payload bytes.
#[must_use]
pub const fn frame_len(payload_len: usize, length: LengthField) -> usize {
    length.header_len() + payload_len + 1
}

/// A checked frame borrowed from a byte buffer: sync pair, both XOR checks and
/// (for extended frames) the length check have passed.
///
/// For a response, `payload()[0]` is the device-type byte
/// ([`Frame::device_type`]) and [`Frame::data`] is the rest.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frame<'a> {
    bytes: &'a [u8],
    payload: &'a [u8],
    header: Header,
    length: LengthField,
}

/// Header fields of a frame found at the start of a buffer, without borrowing it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct FrameInfo {
    pub(crate) header: Header,
    pub(crate) length: LengthField,
    pub(crate) payload_len: usize,
}

impl FrameInfo {
    pub(crate) const fn wire_len(&self) -> usize {
        frame_len(self.payload_len, self.length)
    }
}

/// Checks the frame at the start of `bytes` (trailing bytes are ignored).
///
/// Errors are reported as early as the available bytes allow: a bad first byte
/// or sync pair before anything else, then the header check, the extended-length
/// check and cap, and `Incomplete` only when the checks so far passed.
pub(crate) fn parse_info(bytes: &[u8], max_ext_len: usize) -> Result<FrameInfo, FrameError> {
    let Some((&sync1, rest)) = bytes.split_first() else {
        return Err(FrameError::Incomplete { needed: HEADER_LEN });
    };
    if sync1 != SYNC_REQUEST[0] && sync1 != SYNC_RESPONSE[0] {
        return Err(FrameError::BadSync);
    }
    let Some(&sync2) = rest.first() else {
        return Err(FrameError::Incomplete { needed: HEADER_LEN });
    };
    let Some(direction) = Direction::from_sync(sync1, sync2) else {
        return Err(FrameError::BadSync);
    };
    let Some(&[_, _, node, flags, addr, len, check]) = bytes.first_chunk::<HEADER_LEN>() else {
        return Err(FrameError::Incomplete { needed: HEADER_LEN });
    };
    let computed = sync1 ^ sync2 ^ node ^ flags ^ addr ^ len;
    if computed != check {
        return Err(FrameError::HeaderCheck {
            computed,
            received: check,
        });
    }
    let (length, payload_len) = if len == EXTENDED_LENGTH_MARKER {
        let Some(&[.., lo, hi, ext_check]) = bytes.first_chunk::<EXT_HEADER_LEN>() else {
            return Err(FrameError::Incomplete {
                needed: EXT_HEADER_LEN,
            });
        };
        if lo ^ hi != ext_check {
            return Err(FrameError::ExtLengthCheck {
                computed: lo ^ hi,
                received: ext_check,
            });
        }
        let ext_len = usize::from(u16::from_le_bytes([lo, hi]));
        if ext_len > max_ext_len {
            return Err(FrameError::Overlong {
                len: ext_len,
                max: max_ext_len,
            });
        }
        (LengthField::Extended, ext_len)
    } else {
        (LengthField::Normal, usize::from(len))
    };
    let info = FrameInfo {
        header: Header {
            direction,
            node: NodeId(node),
            flags,
            addr,
        },
        length,
        payload_len,
    };
    let total = info.wire_len();
    let Some(frame_bytes) = bytes.get(..total) else {
        return Err(FrameError::Incomplete { needed: total });
    };
    let (received, body) = match frame_bytes.split_last() {
        Some((&tc, body)) => (tc, body),
        None => return Err(FrameError::Incomplete { needed: total }),
    };
    let computed = xor_checksum(body.get(length.header_len()..).unwrap_or_default());
    if computed != received {
        return Err(FrameError::TotalCheck { computed, received });
    }
    Ok(info)
}

impl<'a> Frame<'a> {
    /// Checks the frame at the start of `bytes`, with the default extended-length
    /// cap [`MAX_EXTENDED_PAYLOAD_LEN`]. Bytes after the frame are ignored; the
    /// frame's size is [`Frame::wire_len`].
    ///
    /// # Errors
    /// [`FrameError`] if the bytes do not start with a complete valid frame.
    pub fn parse(bytes: &'a [u8]) -> Result<Self, FrameError> {
        Self::parse_with_cap(bytes, MAX_EXTENDED_PAYLOAD_LEN)
    }

    /// As [`Frame::parse`] with an explicit extended-length cap.
    ///
    /// # Errors
    /// [`FrameError`] if the bytes do not start with a complete valid frame.
    pub fn parse_with_cap(bytes: &'a [u8], max_ext_len: usize) -> Result<Self, FrameError> {
        let info = parse_info(bytes, max_ext_len)?;
        Ok(Self::from_info(bytes, &info))
    }

    /// Builds the view from an already-checked prefix of `bytes`.
    pub(crate) fn from_info(bytes: &'a [u8], info: &FrameInfo) -> Self {
        let wire = bytes.get(..info.wire_len()).unwrap_or(bytes);
        let start = info.length.header_len();
        let payload = wire
            .get(start..start + info.payload_len)
            .unwrap_or_default();
        Self {
            bytes: wire,
            payload,
            header: info.header,
            length: info.length,
        }
    }

    /// The header fields.
    #[must_use]
    pub const fn header(&self) -> Header {
        self.header
    }

    /// Request or response.
    #[must_use]
    pub const fn direction(&self) -> Direction {
        self.header.direction
    }

    /// NODE ID (destination of a request, sender of a response).
    #[must_use]
    pub const fn node(&self) -> NodeId {
        self.header.node
    }

    /// FLAGS byte.
    #[must_use]
    pub const fn flags(&self) -> u8 {
        self.header.flags
    }

    /// FLAGS interpreted as a request's reply selection.
    #[must_use]
    pub const fn request_flags(&self) -> RequestFlags {
        RequestFlags::from_byte(self.header.flags)
    }

    /// CSR ADDRESS.
    #[must_use]
    pub const fn addr(&self) -> u8 {
        self.header.addr
    }

    /// Normal or extended length field.
    #[must_use]
    pub const fn length_field(&self) -> LengthField {
        self.length
    }

    /// True for an extended-length frame.
    #[must_use]
    pub const fn is_extended(&self) -> bool {
        matches!(self.length, LengthField::Extended)
    }

    /// The payload (for a response including the device-type byte).
    #[must_use]
    pub const fn payload(&self) -> &'a [u8] {
        self.payload
    }

    /// Payload length: LENGTH, or the extended length.
    #[must_use]
    pub const fn payload_len(&self) -> usize {
        self.payload.len()
    }

    /// The whole frame as it was on the wire.
    #[must_use]
    pub const fn as_bytes(&self) -> &'a [u8] {
        self.bytes
    }

    /// Frame size on the wire.
    #[must_use]
    pub const fn wire_len(&self) -> usize {
        self.bytes.len()
    }

    /// Device type of a response (payload byte 0); `None` for a request or an
    /// empty response payload.
    #[must_use]
    pub fn device_type(&self) -> Option<DeviceType> {
        match self.header.direction {
            Direction::Response => self.payload.first().copied().map(DeviceType::from_byte),
            Direction::Request => None,
        }
    }

    /// The data of the frame: a request's whole payload, or a response's payload
    /// after the device-type byte.
    #[must_use]
    pub fn data(&self) -> &'a [u8] {
        match self.header.direction {
            Direction::Request => self.payload,
            Direction::Response => self.payload.get(1..).unwrap_or_default(),
        }
    }
}

/// Writes one frame: header (normal or extended), `prefix` then `data` as the
/// payload, total check.
fn encode_parts(
    header: &Header,
    length: LengthField,
    prefix: Option<u8>,
    data: &[u8],
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    let payload_len = data.len() + usize::from(prefix.is_some());
    let max = length.max_payload_len();
    if payload_len > max {
        return Err(EncodeError::PayloadTooLong {
            len: payload_len,
            max,
        });
    }
    let needed = frame_len(payload_len, length);
    let available = out.len();
    let Some(out) = out.get_mut(..needed) else {
        return Err(EncodeError::BufferTooSmall { needed, available });
    };
    let [sync1, sync2] = header.direction.sync();
    let len_byte = match length {
        LengthField::Normal => u8::try_from(payload_len).unwrap_or(EXTENDED_LENGTH_MARKER),
        LengthField::Extended => EXTENDED_LENGTH_MARKER,
    };
    let head = [
        sync1,
        sync2,
        header.node.0,
        header.flags,
        header.addr,
        len_byte,
    ];
    let mut w = crate::bytes::Writer::new(out);
    w.put(&head);
    w.u8(xor_checksum(&head));
    if let LengthField::Extended = length {
        let [lo, hi] = u16::try_from(payload_len).unwrap_or(u16::MAX).to_le_bytes();
        w.put(&[lo, hi, lo ^ hi]);
    }
    let mut check = xor_checksum(data);
    if let Some(p) = prefix {
        w.u8(p);
        check ^= p;
    }
    w.put(data);
    w.u8(check);
    match w.finish() {
        Some(n) => {
            debug_assert_eq!(n, needed);
            Ok(n)
        }
        None => Err(EncodeError::BufferTooSmall { needed, available }),
    }
}

/// Encodes a frame with an arbitrary header and payload (a response's payload
/// must then include the device-type byte). Returns the frame length.
///
/// # Errors
/// [`EncodeError::PayloadTooLong`] if the payload exceeds
/// [`LengthField::max_payload_len`]; [`EncodeError::BufferTooSmall`] if `out` is
/// shorter than [`frame_len`].
pub fn encode_frame(
    header: &Header,
    payload: &[u8],
    length: LengthField,
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    encode_parts(header, length, None, payload, out)
}

/// Encodes a request that writes `payload` at `addr` (empty for a pure read)
/// and asks for the reply selected by `flags`. Returns the frame length.
///
/// # Errors
/// As [`encode_frame`] with a normal length field (payload ≤ 254 bytes).
pub fn encode_request(
    node: NodeId,
    flags: u8,
    addr: u8,
    payload: &[u8],
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    encode_parts(
        &Header::request(node, flags, addr),
        LengthField::Normal,
        None,
        payload,
        out,
    )
}

/// Encodes a normal-length response: `device_type` byte then `data` (so LENGTH
/// is `1 + data.len()`, at most 254). Returns the frame length.
///
/// Use FLAGS echoed and `addr` 0 for device-specific replies, FLAGS 0x80 and the
/// start address for dumps (protocol.md §5.3).
///
/// # Errors
/// As [`encode_frame`].
pub fn encode_response(
    node: NodeId,
    flags: u8,
    addr: u8,
    device_type: DeviceType,
    data: &[u8],
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    encode_parts(
        &Header::response(node, flags, addr),
        LengthField::Normal,
        Some(device_type.to_byte()),
        data,
        out,
    )
}

/// Encodes an extended-length response (LENGTH 0xFF): `device_type` byte then
/// `data`, at most [`MAX_EXTENDED_PAYLOAD_LEN`] bytes together. Returns the frame
/// length.
///
/// # Errors
/// As [`encode_frame`].
pub fn encode_response_extended(
    node: NodeId,
    flags: u8,
    addr: u8,
    device_type: DeviceType,
    data: &[u8],
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    encode_parts(
        &Header::response(node, flags, addr),
        LengthField::Extended,
        Some(device_type.to_byte()),
        data,
        out,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn xor_matches_bytewise_fold_for_all_lengths() {
        let data: [u8; 40] = core::array::from_fn(|i| (i as u8).wrapping_mul(37) ^ 0x5A);
        for len in 0..=data.len() {
            let slow = data[..len].iter().fold(0u8, |a, b| a ^ b);
            assert_eq!(xor_checksum(&data[..len]), slow, "len {len}");
        }
    }

    #[test]
    fn request_flags_cover_every_byte() {
        for b in 0..=u8::MAX {
            assert_eq!(RequestFlags::from_byte(b).to_byte(), b);
        }
        assert_eq!(RequestFlags::from_byte(0x80).dump_len(0), Some(240));
        assert_eq!(RequestFlags::from_byte(0x80).dump_len(0xEF), Some(1));
        assert_eq!(RequestFlags::from_byte(0x80).dump_len(0xF7), None);
        assert_eq!(RequestFlags::from_byte(0x8E).dump_len(0x7A), Some(14));
        assert_eq!(RequestFlags::from_byte(0x05).dump_len(0), None);
    }

    #[test]
    fn node_addressing() {
        assert_eq!(NodeId::ROV.addressing(), Addressing::Unicast(1));
        assert_eq!(
            NodeId(0x81).addressing(),
            Addressing::Multicast { group: 1 }
        );
        assert_eq!(NodeId(0xFF).addressing(), Addressing::Broadcast);
        assert_eq!(NodeId::multicast(0x7F), NodeId::BROADCAST);
        assert!(NodeId(0x7F).is_unicast());
        assert!(!NodeId(0x80).is_unicast());
    }

    #[test]
    fn encoders_reject_small_buffers_and_long_payloads() {
        let mut out = [0u8; 7];
        assert_eq!(
            encode_request(NodeId::ROV, 1, 0, &[], &mut out),
            Err(EncodeError::BufferTooSmall {
                needed: 8,
                available: 7
            })
        );
        let long = [0u8; 255];
        let mut big = [0u8; 300];
        assert_eq!(
            encode_request(NodeId::ROV, 0, 0, &long, &mut big),
            Err(EncodeError::PayloadTooLong { len: 255, max: 254 })
        );
        assert_eq!(
            encode_response(
                NodeId::ROV,
                0x80,
                0,
                DeviceType::Pro4Rov,
                &long[..254],
                &mut big
            ),
            Err(EncodeError::PayloadTooLong { len: 255, max: 254 })
        );
    }

    #[test]
    fn parse_reports_earliest_error() {
        assert_eq!(Frame::parse(&[]), Err(FrameError::Incomplete { needed: 7 }));
        assert_eq!(Frame::parse(&[0x00]), Err(FrameError::BadSync));
        assert_eq!(
            Frame::parse(&[0xFA]),
            Err(FrameError::Incomplete { needed: 7 })
        );
        assert_eq!(Frame::parse(&[0xFA, 0xDF]), Err(FrameError::BadSync));
        assert_eq!(
            Frame::parse(&[0xFA, 0xAF, 1, 1, 0, 0, 0x54]),
            Err(FrameError::HeaderCheck {
                computed: 0x55,
                received: 0x54
            })
        );
        assert_eq!(
            Frame::parse(&[0xFA, 0xAF, 1, 1, 0, 0, 0x55]),
            Err(FrameError::Incomplete { needed: 8 })
        );
    }
}
