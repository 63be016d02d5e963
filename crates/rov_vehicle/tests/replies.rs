//! Every reply kind answered byte-exactly (protocol.md §5–7, §12.3), addressing rules,
//! bad requests, reboot and wire timing.

use firmware_proto::{
    ControlBlock, CsrRead, DeviceType, NavReply, NodeId, Ping, PingReply, Reboot, StatusBlock, csr,
    encode_request, encode_response, flags,
};
use rov_vehicle::{FaultConfig, Vehicle, VehicleConfig, WireTiming, sim_config_data};

fn vehicle(timing: WireTiming) -> Vehicle {
    let cfg = VehicleConfig {
        timing,
        faults: FaultConfig::none(),
        ..VehicleConfig::default()
    };
    Vehicle::with_model3(cfg, 1).unwrap()
}

fn instant() -> WireTiming {
    WireTiming {
        paced: false,
        turnaround_us: 0,
        ..WireTiming::default()
    }
}

/// Sends `req` at `t` and returns everything the vehicle answers by `t + 1 s`... but
/// without running the simulator past `t` before the reply is built.
fn exchange(v: &mut Vehicle, req: &[u8], t: u64) -> Vec<u8> {
    v.handle_input(req, t);
    v.advance_to(t).unwrap();
    let mut out = Vec::new();
    v.poll_output(t + 1_000_000, &mut out);
    out
}

fn i16_at(img: &[u8; 256], a: u8) -> i16 {
    i16::from_le_bytes([img[a as usize], img[a as usize + 1]])
}

fn expected_nav(img: &[u8; 256]) -> NavReply {
    NavReply {
        device_type: DeviceType::Pro4Rov,
        heading_deg_x10: i16_at(img, csr::HEADING),
        pitch_deg_x10: i16_at(img, csr::PITCH),
        roll_deg_x10: i16_at(img, csr::ROLL),
        pressure_mbar: i16_at(img, csr::PRESSURE),
        yaw_accel_raw: i16_at(img, csr::YAW_ACCEL),
        pitch_accel_raw: i16_at(img, csr::PITCH_ACCEL),
        roll_accel_raw: i16_at(img, csr::ROLL_ACCEL),
        surge_accel_raw: i16_at(img, csr::SURGE_ACCEL),
        sway_accel_raw: i16_at(img, csr::SWAY_ACCEL),
        heave_accel_raw: i16_at(img, csr::HEAVE_ACCEL),
        mag_x_raw: i16_at(img, csr::MAG_X),
        mag_y_raw: i16_at(img, csr::MAG_Y),
        mag_z_raw: i16_at(img, csr::MAG_Z),
        attitude_status: i16_at(img, csr::ATTITUDE_STATUS),
        humidity_pct: i16_at(img, csr::HUMIDITY),
        water_temp_c_x100: i16_at(img, csr::WATER_TEMP),
        power_pct: img[csr::POWER_AVAILABLE as usize],
    }
}

#[test]
fn ping_reply_is_byte_exact() {
    let mut v = vehicle(instant());
    let mut req = [0u8; 8];
    Ping::encode_request(NodeId::ROV, &mut req).unwrap();
    let got = exchange(&mut v, &req, 0);
    let img = v.registers();
    let reply = PingReply {
        device_type: DeviceType::Pro4Rov,
        heading_deg_x10: i16_at(img, csr::HEADING),
        pitch_deg_x10: i16_at(img, csr::PITCH),
        roll_deg_x10: i16_at(img, csr::ROLL),
        pressure_mbar: i16_at(img, csr::PRESSURE),
    };
    let mut want = [0u8; 17];
    reply.encode_response(NodeId::ROV, &mut want).unwrap();
    assert_eq!(got, want);
    // 1 m deep at the start: absolute pressure ≈ 1013.25 + 98.1 mbar.
    assert!(
        (1105..=1118).contains(&reply.pressure_mbar),
        "{}",
        reply.pressure_mbar
    );
}

#[test]
fn control_write_then_nav_reply_is_byte_exact() {
    let mut v = vehicle(instant());
    let cmd = ControlBlock {
        port_pct: 10,
        starboard_pct: -10,
        vertical_pct: 5,
        lights_pct: 40,
        ..ControlBlock::ALL_STOP
    };
    let mut req = [0u8; 23];
    cmd.encode_request(NodeId::ROV, flags::NAV, &mut req)
        .unwrap();
    let got = exchange(&mut v, &req, 0);
    let img = *v.registers();
    // The write was applied first.
    assert_eq!(&img[0..15], &cmd.to_bytes());
    let mut want = [0u8; 42];
    expected_nav(&img).encode_response_check(&mut want);
    assert_eq!(got, want);
    assert_eq!(&got[..8], &[0xFD, 0xDF, 0x01, 0x05, 0x00, 0x22, 0x04, 0x01]);
}

trait EncodeNav {
    fn encode_response_check(&self, out: &mut [u8; 42]);
}

impl EncodeNav for NavReply {
    fn encode_response_check(&self, out: &mut [u8; 42]) {
        let n = encode_response(
            NodeId::ROV,
            flags::NAV,
            0,
            DeviceType::Pro4Rov,
            &self.to_payload()[1..],
            out,
        )
        .unwrap();
        assert_eq!(n, 42);
    }
}

#[test]
fn status_block_is_byte_exact_and_carries_comm_errors() {
    let mut v = vehicle(instant());
    // One request with a bad total check first.
    let mut bad = [0u8; 8];
    Ping::encode_request(NodeId::ROV, &mut bad).unwrap();
    bad[7] ^= 0x01;
    assert!(exchange(&mut v, &bad, 0).is_empty());
    let mut req = [0u8; 8];
    CsrRead::STATUS
        .encode_request(NodeId::ROV, &mut req)
        .unwrap();
    assert_eq!(req, [0xFA, 0xAF, 0x01, 0x8E, 0x7A, 0x00, 0xA0, 0x00]);
    let got = exchange(&mut v, &req, 1000);
    let img = v.registers();
    let status = StatusBlock::from_payload(&[&[1u8][..], &img[0x7A..0x88]].concat()).unwrap();
    assert_eq!(status.comm_errors, 1);
    assert!((7400..=7552).contains(&status.tether_v_x100));
    assert_eq!(status.rail_12v_v_x100, 1219);
    let mut want = [0u8; 23];
    status.encode_response(NodeId::ROV, &mut want).unwrap();
    assert_eq!(got, want);
}

#[test]
fn full_dump_is_byte_exact() {
    let mut v = vehicle(instant());
    let mut req = [0u8; 8];
    CsrRead::FULL.encode_request(NodeId::ROV, &mut req).unwrap();
    let got = exchange(&mut v, &req, 0);
    assert_eq!(got.len(), 249);
    let mut want = vec![0u8; 249];
    encode_response(
        NodeId::ROV,
        0x80,
        0,
        DeviceType::Pro4Rov,
        &v.registers()[..240],
        &mut want,
    )
    .unwrap();
    assert_eq!(got, want);
    assert_eq!(&got[..7], &[0xFD, 0xDF, 0x01, 0x80, 0x00, 0xF1, 0x52]);
    // Defaults of the image: targets off, power 100, firmware 2.6.6.
    assert_eq!(&got[8 + 0x0B..8 + 0x0F], &[0xFF; 4]);
    assert_eq!(&got[8 + 0xEB..8 + 0xEE], &[2, 6, 6]);
    // A short read: 2 bytes of heading (V9).
    let got = exchange(
        &mut v,
        &[0xFA, 0xAF, 0x01, 0x82, 0x68, 0x00, 0xBE, 0x00],
        10,
    );
    let mut want = [0u8; 11];
    encode_response(
        NodeId::ROV,
        0x80,
        0x68,
        DeviceType::Pro4Rov,
        &v.registers()[0x68..0x6A],
        &mut want,
    )
    .unwrap();
    assert_eq!(got, want);
}

#[test]
fn config_read_is_the_extended_reply() {
    let mut v = vehicle(instant());
    let req = [0xFA, 0xAF, 0x01, 0x80, 0xF7, 0x00, 0x23, 0x00];
    let got = exchange(&mut v, &req, 0);
    let mut want = vec![0u8; 304];
    sim_config_data()
        .encode_response(NodeId::ROV, &mut want)
        .unwrap();
    assert_eq!(got, want);
    assert_eq!(
        &got[..10],
        &[0xFD, 0xDF, 0x01, 0x80, 0xF7, 0xFF, 0xAB, 0x25, 0x01, 0x24]
    );
}

#[test]
fn reboot_resets_the_image_and_says_nothing() {
    let mut v = vehicle(instant());
    let cmd = ControlBlock {
        vertical_pct: 30,
        depth_target_mbar: Some(1200),
        ..ControlBlock::ALL_STOP
    };
    let mut req = [0u8; 23];
    cmd.encode_request(NodeId::ROV, flags::NONE, &mut req)
        .unwrap();
    assert!(exchange(&mut v, &req, 0).is_empty());
    let mut bad = req;
    bad[10] ^= 4;
    exchange(&mut v, &bad, 10);
    assert_eq!(v.comm_errors(), 1);
    assert_eq!(&v.registers()[..15], &cmd.to_bytes());
    v.advance_to(50_000).unwrap();
    assert!(v.plant_command().vertical.abs() > 0.0);
    let mut rb = [0u8; 10];
    Reboot::encode_request(NodeId::ROV, &mut rb).unwrap();
    assert_eq!(
        rb,
        [0xFA, 0xAF, 0x01, 0x00, 0xFE, 0x02, 0xA8, 0xDE, 0xAD, 0x73]
    );
    assert!(exchange(&mut v, &rb, 60_000).is_empty());
    assert_eq!(v.counts().reboots, 1);
    assert_eq!(v.comm_errors(), 0);
    assert_eq!(&v.registers()[..0x5F], &csr::DEFAULT_IMAGE[..0x5F]);
    assert_eq!(&v.registers()[0xF0..], &csr::DEFAULT_IMAGE[0xF0..]);
    v.advance_to(100_000).unwrap();
    assert_eq!(v.plant_command().vertical, 0.0);
}

#[test]
fn multicast_and_broadcast_apply_writes_without_reply() {
    let mut v = vehicle(instant());
    for (node, lights) in [(0xFFu8, 11u8), (0x80, 22)] {
        let cmd = ControlBlock {
            lights_pct: lights,
            ..ControlBlock::ALL_STOP
        };
        let mut req = [0u8; 23];
        cmd.encode_request(NodeId(node), flags::NAV, &mut req)
            .unwrap();
        assert!(exchange(&mut v, &req, 0).is_empty(), "node {node:#x}");
        assert_eq!(v.registers()[csr::LIGHTS as usize], lights);
    }
    // Another unicast node and another group: ignored entirely.
    for node in [0x02u8, 0x85] {
        let cmd = ControlBlock {
            lights_pct: 99,
            ..ControlBlock::ALL_STOP
        };
        let mut req = [0u8; 23];
        cmd.encode_request(NodeId(node), flags::NAV, &mut req)
            .unwrap();
        assert!(exchange(&mut v, &req, 0).is_empty());
        assert_eq!(v.registers()[csr::LIGHTS as usize], 22);
    }
    let c = v.counts();
    assert_eq!((c.broadcast, c.multicast, c.other_node), (1, 1, 2));
}

#[test]
fn bad_checksums_get_no_reply_and_bump_0x86() {
    let mut v = vehicle(instant());
    // C1 of the vectors: payload bit flipped.
    let c1 = [
        0xFA, 0xAF, 0x01, 0x05, 0x00, 0x0F, 0x5E, 0x32, 0x01, 0xCE, 0xFF, 0x19, 0x00, 0x4B, 0xE2,
        0x00, 0x00, 0x00, 0xFF, 0xFF, 0xFF, 0xFF, 0xB3,
    ];
    assert!(exchange(&mut v, &c1, 0).is_empty());
    let mut hc = [0xFA, 0xAF, 0x01, 0x01, 0x00, 0x00, 0x55, 0x00];
    hc[6] = 0x56;
    assert!(exchange(&mut v, &hc, 100).is_empty());
    assert_eq!(v.comm_errors(), 2);
    assert_eq!(&v.registers()[0x86..0x88], &[2, 0]);
    assert_eq!(
        &v.registers()[..15],
        &csr::DEFAULT_IMAGE[..15],
        "no write applied"
    );
    // Unimplemented FLAGS: silence, not an error.
    let mut req = [0u8; 8];
    encode_request(NodeId::ROV, 0x06, 0, &[], &mut req).unwrap();
    assert!(exchange(&mut v, &req, 200).is_empty());
    encode_request(NodeId::ROV, 0x7F, 0, &[], &mut req).unwrap();
    assert!(exchange(&mut v, &req, 300).is_empty());
    assert_eq!(v.counts().unimplemented_flags, 2);
    assert_eq!(v.comm_errors(), 2);
}

#[test]
fn replies_are_paced_at_the_baud_rate_after_the_turnaround() {
    let mut v = vehicle(WireTiming::default());
    let mut req = [0u8; 23];
    ControlBlock::ALL_STOP
        .encode_request(NodeId::ROV, flags::NAV, &mut req)
        .unwrap();
    v.handle_input(&req, 0);
    // The request needs 23 × 86.8 µs = 1997 µs on the wire; nothing before that.
    assert_eq!(v.next_wakeup(), Some(1997));
    v.advance_to(1996).unwrap();
    assert!(!v.output_pending());
    v.advance_to(1997).unwrap();
    // First byte complete after turnaround (1 ms) + one byte time.
    assert_eq!(v.next_wakeup(), Some(1997 + 1000 + 87));
    let mut out = Vec::new();
    v.poll_output(1997 + 1000 + 86, &mut out);
    assert!(out.is_empty());
    v.poll_output(1997 + 1000 + 3646, &mut out);
    assert_eq!(out.len(), 42);
    assert!(!v.output_pending());
}

#[test]
fn watchdog_neutralises_after_one_second() {
    let mut v = vehicle(instant());
    let cmd = ControlBlock {
        port_pct: 50,
        starboard_pct: 50,
        ..ControlBlock::ALL_STOP
    };
    let mut req = [0u8; 23];
    cmd.encode_request(NodeId::ROV, flags::NONE, &mut req)
        .unwrap();
    exchange(&mut v, &req, 0);
    v.advance_to(990_000).unwrap();
    assert_eq!(v.plant_command().port, 50.0);
    v.advance_to(1_020_000).unwrap();
    assert_eq!(v.plant_command().port, 0.0);
    assert!(v.watchdog_tripped());
    assert_eq!(v.counts().watchdog_trips, 1);
}
