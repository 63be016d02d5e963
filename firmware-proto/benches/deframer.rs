//! Deframer throughput on mixed Pro 4 traffic with 1 % corrupted bytes.
//!
//! The traffic is what a bus monitor sees in Cockpit's primary mode: control
//! requests (23 B) and navigation replies (42 B), with a status read/reply pair
//! and a full CSR dump (8 B + 249 B) now and then, plus the config reply once.
//! One byte in a hundred is then replaced by a random value.
//!
//! The measured loop is the hot path a link task runs: a `Deframer` on the
//! stack, `push` with a callback, frames borrowed from the deframer's fixed
//! buffer and classified in place. The crate is `no_std` without `alloc`, so
//! nothing in the loop can allocate.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use firmware_proto::{
    ConfigData, ControlBlock, CsrDump, CsrRead, Deframer, DeframerConfig, DeviceType, Event,
    NavReply, NodeId, StatusBlock, classify, csr, flags,
};

/// Simple deterministic PRNG (xorshift64*).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
}

fn append(out: &mut Vec<u8>, write: impl FnOnce(&mut [u8]) -> usize) {
    let mut buf = [0u8; 400];
    let n = write(&mut buf);
    out.extend_from_slice(&buf[..n]);
}

/// About `target_len` bytes of mixed traffic, 1 % of bytes corrupted.
fn traffic(target_len: usize) -> (Vec<u8>, usize) {
    let mut rng = Rng(0x1234_5678_9ABC_DEF1);
    let mut out = Vec::with_capacity(target_len + 400);
    let image = csr::DEFAULT_IMAGE;
    let mut frames = 0;
    let mut nav = NavReply {
        device_type: DeviceType::Pro4Rov,
        heading_deg_x10: 0,
        pitch_deg_x10: 0,
        roll_deg_x10: 0,
        pressure_mbar: 1013,
        yaw_accel_raw: 0,
        pitch_accel_raw: 0,
        roll_accel_raw: 0,
        surge_accel_raw: 0,
        sway_accel_raw: 0,
        heave_accel_raw: -9040,
        mag_x_raw: 374,
        mag_y_raw: -699,
        mag_z_raw: 1953,
        attitude_status: 0,
        humidity_pct: 35,
        water_temp_c_x100: 1525,
        power_pct: 100,
    };
    let status = StatusBlock {
        device_type: DeviceType::Pro4Rov,
        water_temp_c_x100: 1525,
        tether_v_x100: 7552,
        rail_12v_v_x100: 1219,
        rail_12v_ma: 385,
        internal_temp_cpu_raw: 0,
        internal_temp_power_raw: 0,
        humidity_pct: 49,
        comm_errors: 3,
    };
    let config = ConfigData {
        device_type: DeviceType::Pro4Rov,
        bootloader: firmware_proto::BootloaderBlock {
            version: 1,
            device_type: 1,
            serial: *b"J14461\0\0\0\0\0\0\0\0\0\0",
            reserved: [0; 8],
            valid_app_flag: firmware_proto::msg::VALID_APP_FLAG,
        },
        hardware: firmware_proto::HardwareConfig::EMPTY,
    };
    append(&mut out, |b| {
        config.encode_response(NodeId::ROV, b).unwrap()
    });
    frames += 1;
    let mut cycle = 0u32;
    while out.len() < target_len {
        cycle += 1;
        let r = rng.next();
        let command = ControlBlock {
            port_pct: (r % 201) as i16 - 100,
            starboard_pct: ((r >> 8) % 201) as i16 - 100,
            vertical_pct: ((r >> 16) % 201) as i16 - 100,
            lights_pct: ((r >> 24) % 101) as u8,
            ..ControlBlock::ALL_STOP
        };
        if cycle.is_multiple_of(10) {
            append(&mut out, |b| {
                CsrRead::STATUS.encode_request(NodeId::ROV, b).unwrap()
            });
            append(&mut out, |b| {
                status.encode_response(NodeId::ROV, b).unwrap()
            });
        } else if cycle.is_multiple_of(25) {
            append(&mut out, |b| {
                CsrRead::FULL.encode_request(NodeId::ROV, b).unwrap()
            });
            let dump = CsrDump {
                device_type: DeviceType::Pro4Rov,
                start: 0,
                data: &image[..csr::APP_REGION_LEN],
            };
            append(&mut out, |b| dump.encode_response(NodeId::ROV, b).unwrap());
        } else {
            append(&mut out, |b| {
                command.encode_request(NodeId::ROV, flags::NAV, b).unwrap()
            });
            nav.heading_deg_x10 = ((r >> 32) % 3600) as i16;
            append(&mut out, |b| nav.encode_response(NodeId::ROV, b).unwrap());
        }
        frames += 2;
    }
    for _ in 0..out.len() / 100 {
        let i = (rng.next() % out.len() as u64) as usize;
        out[i] = rng.next() as u8;
    }
    (out, frames)
}

fn bench(c: &mut Criterion) {
    let (data, frames) = traffic(1 << 20);
    // Sanity check outside the timed loop: most frames survive 1 % corruption.
    let mut d = Deframer::new(DeframerConfig::default());
    d.push(&data, 0, |_| {});
    let ok = d.counters().frames_ok;
    assert!(ok as usize > frames / 2, "{ok} of {frames} frames");
    eprintln!(
        "traffic: {} bytes, {frames} frames sent, {ok} delivered, counters {:?}",
        data.len(),
        d.counters()
    );

    let mut group = c.benchmark_group("deframer");
    group.throughput(Throughput::Bytes(data.len() as u64));
    for chunk in [64usize, 4096] {
        group.bench_function(format!("mixed_1pct_corrupt_chunk{chunk}"), |b| {
            b.iter(|| {
                let mut d = Deframer::new(DeframerConfig::default());
                let mut kinds = 0usize;
                for (i, part) in data.chunks(chunk).enumerate() {
                    d.push(black_box(part), i as u64 * 100, |e| {
                        if let Event::Frame { frame, .. } = e {
                            kinds += classify(&frame) as usize;
                        }
                    });
                }
                black_box((kinds, d.counters().frames_ok))
            });
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
