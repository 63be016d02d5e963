//! Helpers shared by the integration tests: hex parsing, the published vectors
//! and an owned copy of deframer events.
#![allow(dead_code)]

use firmware_proto::{DeframeErrorKind, Deframer, Event};

/// Parses space-separated hex ("FA AF 01").
pub fn hex(s: &str) -> Vec<u8> {
    s.split_whitespace()
        .map(|b| u8::from_str_radix(b, 16).unwrap())
        .collect()
}

/// Vector V18: the 304-byte configuration reply, as written in
/// protocol_vectors.md (bytes 0..=42 given, zeros up to the total check 0xED).
pub fn v18() -> Vec<u8> {
    let mut v = hex(
        "FD DF 01 80 F7 FF AB 25 01 24 01 01 00 01 00 4A 31 34 34 36 31 \
                     00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 60 0D F0 0D",
    );
    assert_eq!(v.len(), 43);
    v.resize(303, 0);
    v.push(0xED);
    v
}

/// Every published vector (name, bytes), requests and responses.
pub fn vectors() -> Vec<(&'static str, Vec<u8>)> {
    vec![
        ("V1", hex("FA AF 01 01 00 00 55 00")),
        (
            "V2",
            hex("FD DF 01 01 00 09 2B 01 EE 01 25 00 E2 FF 00 00 D6"),
        ),
        (
            "V3",
            hex("FA AF 01 05 00 0F 5E 32 00 CE FF 19 00 4B E2 00 00 00 FF FF FF FF B3"),
        ),
        (
            "V4",
            hex("FA AF 01 05 00 0F 5E 64 00 64 00 00 00 00 00 00 00 00 E9 05 0E 01 E3"),
        ),
        ("V5", hex("FA AF 01 05 00 00 51 00")),
        (
            "V6",
            hex(
                "FD DF 01 05 00 22 04 01 D2 04 CE FF 19 00 E9 05 00 00 FF FF 02 00 78 00 B0 FF AE D9 76 01 45 FD A1 07 00 00 23 00 F5 05 64 8F",
            ),
        ),
        (
            "S2nav",
            hex(
                "FD DF 01 05 00 22 04 01 ED 01 25 00 E2 FF 00 00 FF FF 00 00 00 00 67 02 FE 01 B5 DC 76 01 45 FD A1 07 00 00 30 00 56 04 64 49",
            ),
        ),
        ("V7", hex("FA AF 01 8E 7A 00 A0 00")),
        (
            "V8",
            hex("FD DF 01 80 7A 0F D6 01 F5 05 80 1D C3 04 81 01 00 00 31 00 03 00 19"),
        ),
        ("V9", hex("FA AF 01 82 68 00 BE 00")),
        ("V10", hex("FD DF 01 80 68 03 C8 01 D2 04 D7")),
        ("V11", hex("FA AF 01 80 00 00 D4 00")),
        ("V12", hex("FA AF 01 80 F7 00 23 00")),
        ("V13", hex("FA AF 01 00 0D 02 5B 5A 00 5A")),
        ("V14", hex("FA AF 01 00 FE 02 A8 DE AD 73")),
        (
            "V15",
            hex("FA AF 42 00 F0 08 EF 35 49 00 00 00 00 03 00 7F"),
        ),
        ("V16", hex("FA AF 01 01 F0 02 A7 CA 02 C8")),
        (
            "V17",
            hex("FA AF 01 05 00 0F 5E 00 00 00 00 00 00 00 00 00 00 00 FF FF FF FF 00"),
        ),
        ("V18", v18()),
    ]
}

/// Owned copy of an [`Event`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Ev {
    Frame {
        offset: u64,
        bytes: Vec<u8>,
    },
    Error {
        kind: DeframeErrorKind,
        offset: u64,
        len: u64,
    },
}

impl Ev {
    pub fn from_event(e: Event<'_>) -> Self {
        match e {
            Event::Frame { frame, offset } => Ev::Frame {
                offset,
                bytes: frame.as_bytes().to_vec(),
            },
            Event::Error(err) => Ev::Error {
                kind: err.kind,
                offset: err.offset,
                len: err.len,
            },
        }
    }

    pub fn frame(offset: u64, bytes: &[u8]) -> Self {
        Ev::Frame {
            offset,
            bytes: bytes.to_vec(),
        }
    }

    pub fn error(kind: DeframeErrorKind, offset: u64, len: u64) -> Self {
        Ev::Error { kind, offset, len }
    }
}

/// Feeds `input` in chunks of `chunk` bytes (all at time 0), then finishes.
pub fn run_chunked<const N: usize>(d: &mut Deframer<N>, input: &[u8], chunk: usize) -> Vec<Ev> {
    let mut out = Vec::new();
    for part in input.chunks(chunk.max(1)) {
        d.push(part, 0, |e| out.push(Ev::from_event(e)));
    }
    while let Some(e) = d.finish() {
        out.push(Ev::from_event(e));
    }
    out
}

/// Checks the counter invariant.
pub fn assert_counters_consistent<const N: usize>(d: &Deframer<N>) {
    let c = d.counters();
    assert_eq!(
        c.bytes_in,
        c.frame_bytes + c.bytes_discarded() + d.buffered_len() as u64,
        "{c:?}"
    );
}
