//! Fuzz the MCAP (ROS 2 bag) reader: arbitrary bytes, and the start of a real ROS 2 bag
//! (written by rosbags: header, a chunk with schemas, channels and CDR messages) truncated,
//! bit-flipped, with bytes inserted and with 4-byte words overwritten (forged lengths and
//! counts). Invariants as in `log_ros1`.
#![no_main]

#[path = "log_ros_common.rs"]
mod log_common;

use libfuzzer_sys::fuzz_target;

const SEED: &[u8] = include_bytes!("../../crates/rov_logs/tests/fixtures/ros2.mcap");

fuzz_target!(|input: log_common::Input| {
    log_common::run(&input, &SEED[..SEED.len().min(12 * 1024)], rov_logs::Format::Mcap);
});
