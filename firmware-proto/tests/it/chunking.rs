//! Chunking invariance (requirement A3): every vector, alone and in a mixed
//! stream with garbage, gives the same events at every chunk size 1..=len, byte
//! by byte with realistic timestamps, and through the pull API.

use crate::common::{Ev, assert_counters_consistent, hex, run_chunked, vectors};
use firmware_proto::{DeframeErrorKind, Deframer, DeframerConfig, Event, Frame, Kind, classify};

fn both() -> Deframer {
    Deframer::new(DeframerConfig::default())
}

#[test]
fn every_vector_at_every_chunk_size() {
    for (name, bytes) in vectors() {
        let whole = run_chunked(&mut both(), &bytes, bytes.len());
        assert_eq!(whole, vec![Ev::frame(0, &bytes)], "{name}");
        for chunk in 1..=bytes.len() {
            let mut d = both();
            assert_eq!(
                run_chunked(&mut d, &bytes, chunk),
                whole,
                "{name} chunk {chunk}"
            );
            assert_counters_consistent(&d);
            assert_eq!(d.counters().frames_ok, 1);
        }
    }
}

/// All vectors back to back, with line noise, stray sync bytes and a truncated
/// frame between them.
fn mixed_stream() -> (Vec<u8>, Vec<(u64, Vec<u8>)>) {
    let noise = [
        hex("00 13 FA 00 55"),
        hex("FA"),
        hex("FD FD"),
        hex("FA DF 01 05 00 00 21 00"),
        hex("FA AF 01 05 00 0F 5E 32 00 CE FF 19"),
        Vec::new(),
    ];
    let mut stream = Vec::new();
    let mut frames = Vec::new();
    for (i, (_, bytes)) in vectors().into_iter().enumerate() {
        stream.extend_from_slice(&noise[i % noise.len()]);
        frames.push((stream.len() as u64, bytes.clone()));
        stream.extend_from_slice(&bytes);
    }
    (stream, frames)
}

#[test]
fn mixed_stream_at_every_chunk_size() {
    let (stream, expected) = mixed_stream();
    let whole = run_chunked(&mut both(), &stream, stream.len());
    let delivered: Vec<(u64, Vec<u8>)> = whole
        .iter()
        .filter_map(|e| match e {
            Ev::Frame { offset, bytes } => Some((*offset, bytes.clone())),
            Ev::Error { .. } => None,
        })
        .collect();
    assert_eq!(delivered, expected, "every vector is found after the noise");
    for chunk in 1..=stream.len() {
        let mut d = both();
        assert_eq!(run_chunked(&mut d, &stream, chunk), whole, "chunk {chunk}");
        assert_counters_consistent(&d);
        assert_eq!(d.buffered_len(), 0);
    }
}

#[test]
fn byte_by_byte_at_line_rate_never_stalls() {
    let (stream, expected) = mixed_stream();
    let mut d = both();
    let mut frames = Vec::new();
    let mut stalls = 0;
    for (i, &b) in stream.iter().enumerate() {
        // 115200 baud 8N1: 86.8 µs per byte.
        let now_us = i as u64 * 87;
        d.push(&[b], now_us, |e| match e {
            Event::Frame { frame, offset } => frames.push((offset, frame.as_bytes().to_vec())),
            Event::Error(err) => stalls += u32::from(err.kind == DeframeErrorKind::Stall),
        });
    }
    assert_eq!(stalls, 0);
    assert_eq!(frames, expected);
}

#[test]
fn pull_api_with_random_splits_matches_push() {
    let (stream, _) = mixed_stream();
    let whole = run_chunked(&mut both(), &stream, stream.len());
    // A fixed pseudo-random sequence of split sizes 1..=128.
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    for _ in 0..200 {
        let mut d = both();
        let mut out = Vec::new();
        let mut rest: &[u8] = &stream;
        while !rest.is_empty() {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let n = (1 + state % 128) as usize;
            let (mut chunk, tail) = rest.split_at(n.min(rest.len()));
            rest = tail;
            while let Some(e) = d.feed(&mut chunk, 0) {
                out.push(Ev::from_event(e));
            }
            assert!(
                chunk.is_empty(),
                "feed returns None only when input is used up"
            );
        }
        while let Some(e) = d.finish() {
            out.push(Ev::from_event(e));
        }
        assert_eq!(out, whole);
    }
}

#[test]
fn frames_borrowed_from_the_deframer_classify_like_parsed_ones() {
    for (name, bytes) in vectors() {
        let expected = classify(&Frame::parse(&bytes).unwrap());
        let mut d = both();
        let mut kinds = Vec::new();
        d.push(&bytes, 0, |e| {
            if let Event::Frame { frame, .. } = e {
                kinds.push(classify(&frame));
            }
        });
        assert_eq!(kinds, vec![expected], "{name}");
        let _: Kind = expected;
    }
}
