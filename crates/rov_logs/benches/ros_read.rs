//! Reading the ROS fixtures (rosbags-written; 300 IMU messages and 720 others): three
//! mapped fields (the map's case: other topics not decoded, other fields skipped by size)
//! against every field (the missing-field listing). Throughput in bytes of log per second.

use std::collections::BTreeSet;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use rov_logs::{ReadOptions, read};

fn fixture(name: &str) -> Vec<u8> {
    std::fs::read(format!(
        "{}/tests/fixtures/{name}",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap_or_default()
}

fn bench(c: &mut Criterion) {
    let three: BTreeSet<String> = [
        "/imu:angular_velocity.z",
        "/odom:twist.twist.linear.x",
        "/rc_out:channels[2]",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    for name in ["ros1.bag", "ros1_lz4.bag", "ros2.mcap"] {
        let bytes = fixture(name);
        let mut g = c.benchmark_group(name);
        g.throughput(Throughput::Bytes(bytes.len() as u64));
        for (what, only) in [("three_fields", Some(three.clone())), ("all_fields", None)] {
            let opts = ReadOptions {
                time_field: Some("/imu:header.stamp".into()),
                time_scale: None,
                only,
            };
            g.bench_function(what, |b| b.iter(|| read(&bytes, None, name, &opts)));
        }
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
