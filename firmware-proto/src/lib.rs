#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::indexing_slicing,
        clippy::panic
    )
)]
//! VideoRay Pro 4 tether protocol ("PRO4", XOR variant): framing, checksums, a
//! streaming deframer and typed messages.
//!
//! The crate is sans-IO: it takes byte slices and timestamps in and gives frames,
//! events and bytes out. It never reads a clock, never blocks and never allocates:
//! it is `#![no_std]` without `alloc` in every feature combination, so nothing in
//! it can touch the heap. No input byte sequence can make it panic (clippy's
//! `unwrap_used`, `expect_used`, `indexing_slicing` and `panic` are denied).
//!
//! # Layers
//!
//! * [`frame`]: the packet format. [`Frame`] is a checked, borrowed view of one
//!   packet; [`encode_request`], [`encode_response`], [`encode_response_extended`]
//!   and [`encode_frame`] write packets into a caller-provided buffer.
//! * [`deframer`]: [`Deframer`] turns a byte stream that arrives in chunks of any
//!   size into frames and typed errors, resynchronising after corruption.
//! * [`msg`]: typed messages ([`ControlBlock`], [`NavReply`], [`PingReply`],
//!   [`StatusBlock`], [`CsrRead`], [`CsrDump`], [`ConfigData`], [`Reboot`], [`Ping`]).
//! * [`classify`](mod@classify): [`classify()`] and [`Message::decode`] turn any frame into a
//!   [`Kind`] / typed [`Message`] and never fail (unknown shapes are `Raw`).
//! * [`csr`]: the register map (addresses and scaling).
//!
//! # Host-side example
//!
//! ```
//! use firmware_proto::{ControlBlock, Deframer, Event, Message, NodeId, flags};
//!
//! // Each tick: encode the control request into a stack buffer.
//! let command = ControlBlock { port_pct: 50, starboard_pct: -50, ..ControlBlock::ALL_STOP };
//! let mut tx = [0u8; 32];
//! let n = command.encode_request(NodeId::ROV, flags::NAV, &mut tx)?;
//! assert_eq!(n, 23);
//!
//! // Feed received bytes into a host-mode deframer (accepts responses only).
//! let mut rx = Deframer::host();
//! let bytes: &[u8] = &[0xFD, 0xDF, 0x01, 0x01, 0x00, 0x09, 0x2B, 0x01, 0xEE, 0x01, 0x25,
//!                      0x00, 0xE2, 0xFF, 0x00, 0x00, 0xD6];
//! let now_us = 1_000;
//! rx.push(bytes, now_us, |event| {
//!     if let Event::Frame { frame, .. } = event {
//!         if let Message::PingReply(reply) = Message::decode(&frame) {
//!             assert_eq!(reply.heading_deg(), 49.4);
//!         }
//!     }
//! });
//! assert_eq!(rx.counters().frames_ok, 1);
//! # Ok::<(), firmware_proto::EncodeError>(())
//! ```
#![no_std]
#![warn(missing_docs)]

// The `arbitrary` derive expands to `std::` paths (it keeps a thread-local
// recursion counter); that feature is for fuzzing hosts only.
#[cfg(feature = "arbitrary")]
extern crate std;

mod bytes;
pub mod classify;
pub mod csr;
pub mod deframer;
pub mod device;
pub mod error;
pub mod frame;
pub mod msg;

pub use classify::{Kind, Message, classify};
pub use deframer::{
    Accept, Counters, DEFAULT_CAPACITY, DEFAULT_GAP_US, DeframeError, DeframeErrorKind, Deframer,
    DeframerConfig, Event,
};
pub use device::DeviceType;
pub use error::{DecodeError, EncodeError, FrameError, RangeError};
pub use frame::{
    Addressing, Direction, Frame, Header, LengthField, MAX_EXTENDED_PAYLOAD_LEN, MAX_FRAME_LEN,
    MAX_NORMAL_FRAME_LEN, MAX_NORMAL_PAYLOAD_LEN, NodeId, RequestFlags, encode_frame,
    encode_request, encode_response, encode_response_extended, flags, frame_len, xor_checksum,
};
pub use msg::{
    BootloaderBlock, ConfigData, ControlBlock, CsrDump, CsrRead, HardwareConfig, NavReply, Ping,
    PingReply, Reboot, StatusBlock,
};
