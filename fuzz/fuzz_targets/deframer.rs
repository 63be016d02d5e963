//! Fuzz the streaming deframer with arbitrary bytes, chunking and timing.
//!
//! Invariants checked (not just "no panic"):
//! * the events tile the input: contiguous offsets, every byte in exactly one
//!   frame or error span, nothing left buffered after `finish`;
//! * every delivered frame equals the input bytes at its offset, has an
//!   accepted direction, re-parses, and re-encodes to the same bytes;
//! * typed decoding never fails and agrees with the classifier;
//! * the counters add up (`bytes_in = frame_bytes + bytes_discarded`);
//! * when no inter-chunk gap exceeds the gap limit, the frames found equal those
//!   of a simple whole-buffer reference scan (drop one byte and rescan on any
//!   failure), whatever the chunking.
#![no_main]

use arbitrary::Arbitrary;
use firmware_proto::{
    Accept, Deframer, DeframerConfig, Event, Frame, Message, classify, encode_frame,
};
use libfuzzer_sys::fuzz_target;

#[derive(Debug, Arbitrary)]
struct Input {
    accept: Accept,
    gap_us: u16,
    /// (chunk length, time since the previous chunk in µs).
    chunks: Vec<(u8, u16)>,
    data: Vec<u8>,
}

/// Frames (offset, len) found by scanning the whole buffer: at each position a
/// valid frame is taken whole, anything else drops one byte.
fn reference_frames(data: &[u8], accept: Accept) -> Vec<(u64, u64)> {
    let mut frames = Vec::new();
    let mut pos = 0;
    while pos < data.len() {
        match Frame::parse(&data[pos..]) {
            Ok(f) => {
                if accept.accepts(f.direction()) {
                    frames.push((pos as u64, f.wire_len() as u64));
                }
                pos += f.wire_len();
            }
            // Bad sync, a failed check, an overlong length, or a candidate cut
            // off by the end of the input: drop one byte and rescan.
            Err(_) => pos += 1,
        }
    }
    frames
}

fuzz_target!(|input: Input| {
    let config = DeframerConfig::new(input.accept).with_gap_us(u64::from(input.gap_us));
    let mut d = Deframer::new(config);
    let data = &input.data[..];

    let mut spans: Vec<(u64, u64)> = Vec::new();
    let mut frames: Vec<(u64, u64)> = Vec::new();
    let mut check = |e: Event<'_>| match e {
        Event::Frame { frame, offset } => {
            let (o, n) = (offset as usize, frame.wire_len());
            assert_eq!(frame.as_bytes(), &data[o..o + n]);
            assert!(input.accept.accepts(frame.direction()));
            assert_eq!(Frame::parse(&data[o..]), Ok(frame));
            let mut buf = [0u8; 1100];
            let m = encode_frame(
                &frame.header(),
                frame.payload(),
                frame.length_field(),
                &mut buf,
            )
            .expect("a decoded frame re-encodes");
            assert_eq!(&buf[..m], frame.as_bytes());
            assert_eq!(Message::decode(&frame).kind(), classify(&frame));
            spans.push((offset, n as u64));
            frames.push((offset, n as u64));
        }
        Event::Error(err) => {
            assert!(err.len > 0);
            spans.push((err.offset, err.len));
        }
    };

    let mut now_us = 0u64;
    // The gap is measured from the last byte received, so empty chunks let
    // time accumulate.
    let mut last_rx_us = 0u64;
    let mut stalled = false;
    let mut rest = data;
    for &(len, dt) in &input.chunks {
        if rest.is_empty() {
            break;
        }
        now_us += u64::from(dt);
        stalled |= now_us - last_rx_us > config.gap_us;
        let (part, tail) = rest.split_at(usize::from(len).min(rest.len()));
        rest = tail;
        if !part.is_empty() {
            last_rx_us = now_us;
        }
        let mut part = part;
        while let Some(e) = d.feed(&mut part, now_us) {
            check(e);
        }
        assert!(part.is_empty());
    }
    d.push(rest, now_us, &mut check);
    while let Some(e) = d.finish() {
        check(e);
    }

    let mut pos = 0;
    for &(offset, len) in &spans {
        assert_eq!(offset, pos, "events are contiguous");
        pos += len;
    }
    assert_eq!(pos, data.len() as u64);
    assert_eq!(d.buffered_len(), 0);
    let c = d.counters();
    assert_eq!(c.bytes_in, data.len() as u64);
    assert_eq!(c.bytes_in, c.frame_bytes + c.bytes_discarded());
    assert_eq!(c.frames_ok, frames.len() as u64);

    if !stalled {
        assert_eq!(frames, reference_frames(data, input.accept));
    }
});
