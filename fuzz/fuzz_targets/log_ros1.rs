//! Fuzz the ROS 1 bag reader: arbitrary bytes, and the start of a real bag (written by
//! rosbags: bag header, a chunk with connections and messages) truncated, bit-flipped,
//! with bytes inserted and with 4-byte words overwritten (forged lengths and counts).
//! Invariants (not just "no panic"): every field's times increase strictly and are
//! finite, its values are finite; a read of only some fields gives exactly the series the
//! read of all fields gives for them (selective decoding agrees with decoding all), with
//! both time spellings.
#![no_main]

#[path = "log_ros_common.rs"]
mod log_common;

use libfuzzer_sys::fuzz_target;

const SEED: &[u8] = include_bytes!("../../crates/rov_logs/tests/fixtures/ros1.bag");

fuzz_target!(|input: log_common::Input| {
    log_common::run(&input, &SEED[..SEED.len().min(12 * 1024)], rov_logs::Format::Ros1);
});
