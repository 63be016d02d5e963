//! The published vectors of protocol_vectors.md, byte-exact both ways: encoding
//! from field values gives the bytes, decoding the bytes gives the field values.
//! Plus the corrupted cases C1–C6 with the "Recommended" behaviour.

use crate::common::{Ev, assert_counters_consistent, hex, run_chunked, v18};
use firmware_proto::msg::{CONFIG_PAYLOAD_LEN, HardwareConfig, VALID_APP_FLAG};
use firmware_proto::{
    BootloaderBlock, ConfigData, ControlBlock, CsrDump, CsrRead, DeframeErrorKind, Deframer,
    DeframerConfig, DeviceType, Direction, Frame, FrameError, Kind, LengthField, Message, NavReply,
    NodeId, Ping, PingReply, Reboot, StatusBlock, classify, encode_request, encode_response, flags,
};

/// Parses a whole vector: exactly one frame, nothing after it.
fn parse(bytes: &[u8]) -> Frame<'_> {
    let f = Frame::parse(bytes).unwrap();
    assert_eq!(f.wire_len(), bytes.len());
    assert_eq!(f.as_bytes(), bytes);
    f
}

fn header(f: &Frame<'_>) -> (Direction, u8, u8, u8, usize) {
    (
        f.direction(),
        f.node().0,
        f.flags(),
        f.addr(),
        f.payload_len(),
    )
}

fn encoded(write: impl FnOnce(&mut [u8]) -> usize) -> Vec<u8> {
    let mut buf = [0u8; 400];
    let n = write(&mut buf);
    buf[..n].to_vec()
}

#[test]
fn v1_ping_request() {
    let bytes = hex("FA AF 01 01 00 00 55 00");
    let f = parse(&bytes);
    assert_eq!(header(&f), (Direction::Request, 1, 0x01, 0x00, 0));
    assert_eq!(Message::decode(&f), Message::Ping);
    assert_eq!(Ping::from_frame(&f), Ok(Ping));
    assert_eq!(
        encoded(|b| Ping::encode_request(NodeId::ROV, b).unwrap()),
        bytes
    );
}

fn v2_fields() -> PingReply {
    PingReply {
        device_type: DeviceType::Pro4Rov,
        heading_deg_x10: 494,
        pitch_deg_x10: 37,
        roll_deg_x10: -30,
        pressure_mbar: 0,
    }
}

#[test]
fn v2_ping_reply() {
    let bytes = hex("FD DF 01 01 00 09 2B 01 EE 01 25 00 E2 FF 00 00 D6");
    let f = parse(&bytes);
    assert_eq!(header(&f), (Direction::Response, 1, 0x01, 0x00, 9));
    assert_eq!(f.device_type(), Some(DeviceType::Pro4Rov));
    let reply = PingReply::from_frame(&f).unwrap();
    assert_eq!(reply, v2_fields());
    assert_eq!(Message::decode(&f), Message::PingReply(reply));
    assert_eq!(reply.heading_deg(), 49.4);
    assert_eq!(reply.pitch_deg(), 3.7);
    assert_eq!(reply.roll_deg(), -3.0);
    assert_eq!(
        encoded(|b| v2_fields().encode_response(NodeId::ROV, b).unwrap()),
        bytes
    );
}

fn control(port: i16, stbd: i16, vert: i16, lights: u8, tilt: i8) -> ControlBlock {
    ControlBlock {
        port_pct: port,
        starboard_pct: stbd,
        vertical_pct: vert,
        lights_pct: lights,
        tilt_deg: tilt,
        ..ControlBlock::ALL_STOP
    }
}

fn check_control(hex_bytes: &str, block: ControlBlock) {
    let bytes = hex(hex_bytes);
    let f = parse(&bytes);
    assert_eq!(header(&f), (Direction::Request, 1, flags::NAV, 0x00, 15));
    assert_eq!(ControlBlock::from_frame(&f), Ok(block));
    assert_eq!(Message::decode(&f), Message::Control(block));
    assert_eq!(block.validate(), Ok(()));
    assert_eq!(
        encoded(|b| block.encode_request(NodeId::ROV, flags::NAV, b).unwrap()),
        bytes
    );
}

#[test]
fn v3_control_request() {
    check_control(
        "FA AF 01 05 00 0F 5E 32 00 CE FF 19 00 4B E2 00 00 00 FF FF FF FF B3",
        control(50, -50, 25, 75, -30),
    );
}

#[test]
fn v4_control_with_autopilot_targets() {
    check_control(
        "FA AF 01 05 00 0F 5E 64 00 64 00 00 00 00 00 00 00 00 E9 05 0E 01 E3",
        ControlBlock {
            depth_target_mbar: Some(1513),
            heading_target_deg: Some(270),
            ..control(100, 100, 0, 0, 0)
        },
    );
}

#[test]
fn cockpit_control_vertical_99() {
    check_control(
        "FA AF 01 05 00 0F 5E 00 00 00 00 63 00 00 00 00 00 00 FF FF FF FF 63",
        control(0, 0, 99, 0, 0),
    );
}

#[test]
fn v17_all_stop() {
    check_control(
        "FA AF 01 05 00 0F 5E 00 00 00 00 00 00 00 00 00 00 00 FF FF FF FF 00",
        ControlBlock::ALL_STOP,
    );
}

#[test]
fn v5_nav_request_without_write_is_raw() {
    let bytes = hex("FA AF 01 05 00 00 51 00");
    let f = parse(&bytes);
    assert_eq!(header(&f), (Direction::Request, 1, 0x05, 0x00, 0));
    assert_eq!(classify(&f), Kind::Raw);
    assert_eq!(
        encoded(|b| encode_request(NodeId::ROV, flags::NAV, 0, &[], b).unwrap()),
        bytes
    );
}

fn v6_fields() -> NavReply {
    NavReply {
        device_type: DeviceType::Pro4Rov,
        heading_deg_x10: 1234,
        pitch_deg_x10: -50,
        roll_deg_x10: 25,
        pressure_mbar: 1513,
        yaw_accel_raw: 0,
        pitch_accel_raw: -1,
        roll_accel_raw: 2,
        surge_accel_raw: 120,
        sway_accel_raw: -80,
        heave_accel_raw: -9810,
        mag_x_raw: 374,
        mag_y_raw: -699,
        mag_z_raw: 1953,
        attitude_status: 0,
        humidity_pct: 35,
        water_temp_c_x100: 1525,
        power_pct: 100,
    }
}

#[test]
fn v6_nav_reply() {
    let bytes = hex(
        "FD DF 01 05 00 22 04 01 D2 04 CE FF 19 00 E9 05 00 00 FF FF 02 00 78 00 B0 FF AE D9 \
         76 01 45 FD A1 07 00 00 23 00 F5 05 64 8F",
    );
    assert_eq!(bytes.len(), 42);
    let f = parse(&bytes);
    assert_eq!(header(&f), (Direction::Response, 1, flags::NAV, 0x00, 34));
    let nav = NavReply::from_frame(&f).unwrap();
    assert_eq!(nav, v6_fields());
    assert_eq!(Message::decode(&f), Message::Nav(nav));
    assert_eq!(nav.heading_deg(), 123.4);
    assert_eq!(nav.pitch_deg(), -5.0);
    assert_eq!(nav.roll_deg(), 2.5);
    assert_eq!(nav.water_temp_c(), 15.25);
    assert_eq!(
        encoded(|b| v6_fields().encode_response(NodeId::ROV, b).unwrap()),
        bytes
    );
}

#[test]
fn s2_published_nav_reply_reproduced() {
    let fields = NavReply {
        device_type: DeviceType::Pro4Rov,
        heading_deg_x10: 493,
        pitch_deg_x10: 37,
        roll_deg_x10: -30,
        pressure_mbar: 0,
        yaw_accel_raw: -1,
        pitch_accel_raw: 0,
        roll_accel_raw: 0,
        surge_accel_raw: 615,
        sway_accel_raw: 510,
        heave_accel_raw: -9035,
        mag_x_raw: 374,
        mag_y_raw: -699,
        mag_z_raw: 1953,
        attitude_status: 0,
        humidity_pct: 48,
        water_temp_c_x100: 1110,
        power_pct: 100,
    };
    let bytes = hex(
        "FD DF 01 05 00 22 04 01 ED 01 25 00 E2 FF 00 00 FF FF 00 00 00 00 67 02 FE 01 B5 DC \
         76 01 45 FD A1 07 00 00 30 00 56 04 64 49",
    );
    assert_eq!(
        encoded(|b| fields.encode_response(NodeId::ROV, b).unwrap()),
        bytes
    );
    let f = parse(&bytes);
    assert_eq!(Message::decode(&f), Message::Nav(fields));
    assert_eq!(fields.water_temp_c(), 11.1);
}

#[test]
fn v7_v8_status_read_and_reply() {
    let req = hex("FA AF 01 8E 7A 00 A0 00");
    let f = parse(&req);
    assert_eq!(header(&f), (Direction::Request, 1, 0x8E, 0x7A, 0));
    assert_eq!(Message::decode(&f), Message::CsrRead(CsrRead::STATUS));
    assert_eq!(CsrRead::STATUS.count(), Some(14));
    assert_eq!(
        encoded(|b| CsrRead::STATUS.encode_request(NodeId::ROV, b).unwrap()),
        req
    );

    let fields = StatusBlock {
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
    let reply = hex("FD DF 01 80 7A 0F D6 01 F5 05 80 1D C3 04 81 01 00 00 31 00 03 00 19");
    let f = parse(&reply);
    assert_eq!(header(&f), (Direction::Response, 1, 0x80, 0x7A, 15));
    assert_eq!(StatusBlock::from_frame(&f), Ok(fields));
    assert_eq!(Message::decode(&f), Message::Status(fields));
    assert_eq!(fields.tether_v(), 75.52);
    assert_eq!(fields.rail_12v_v(), 12.19);
    assert_eq!(fields.water_temp_c(), 15.25);
    assert_eq!(
        encoded(|b| fields.encode_response(NodeId::ROV, b).unwrap()),
        reply
    );
    // The same reply built by a vehicle from its register image.
    assert_eq!(
        encoded(|b| encode_response(
            NodeId::ROV,
            0x80,
            0x7A,
            DeviceType::Pro4Rov,
            &reply[8..22],
            b
        )
        .unwrap()),
        reply
    );
}

#[test]
fn v9_v10_single_register_read() {
    let req = hex("FA AF 01 82 68 00 BE 00");
    let f = parse(&req);
    let read = CsrRead::range(0x68, 2).unwrap();
    assert_eq!(Message::decode(&f), Message::CsrRead(read));
    assert_eq!(read.count(), Some(2));
    assert_eq!(
        encoded(|b| read.encode_request(NodeId::ROV, b).unwrap()),
        req
    );

    let reply = hex("FD DF 01 80 68 03 C8 01 D2 04 D7");
    let f = parse(&reply);
    let dump = CsrDump {
        device_type: DeviceType::Pro4Rov,
        start: 0x68,
        data: &[0xD2, 0x04],
    };
    assert_eq!(Message::decode(&f), Message::CsrDump(dump));
    assert_eq!(dump.i16_at(firmware_proto::csr::HEADING), Some(1234));
    assert_eq!(
        encoded(|b| dump.encode_response(NodeId::ROV, b).unwrap()),
        reply
    );
}

#[test]
fn v11_full_dump_request_and_249_byte_reply() {
    let req = hex("FA AF 01 80 00 00 D4 00");
    let f = parse(&req);
    assert_eq!(Message::decode(&f), Message::CsrRead(CsrRead::FULL));
    assert_eq!(CsrRead::FULL.count(), Some(240));
    assert_eq!(
        encoded(|b| CsrRead::FULL.encode_request(NodeId::ROV, b).unwrap()),
        req
    );

    let image = firmware_proto::csr::DEFAULT_IMAGE;
    let dump = CsrDump {
        device_type: DeviceType::Pro4Rov,
        start: 0,
        data: &image[..240],
    };
    let reply = encoded(|b| dump.encode_response(NodeId::ROV, b).unwrap());
    assert_eq!(reply.len(), 249);
    assert_eq!(&reply[..8], &hex("FD DF 01 80 00 F1 52 01")[..]);
    let f = parse(&reply);
    let Message::CsrDump(decoded) = Message::decode(&f) else {
        panic!("not a dump")
    };
    assert!(decoded.is_full());
    assert_eq!(decoded, dump);
    assert_eq!(
        decoded.u16_at(firmware_proto::csr::AUTO_DEPTH_TARGET),
        Some(0xFFFF)
    );
}

#[test]
fn v12_config_read_request() {
    let req = hex("FA AF 01 80 F7 00 23 00");
    let f = parse(&req);
    assert_eq!(Message::decode(&f), Message::CsrRead(CsrRead::CONFIG));
    assert_eq!(CsrRead::CONFIG.count(), None);
    assert_eq!(
        encoded(|b| CsrRead::CONFIG.encode_request(NodeId::ROV, b).unwrap()),
        req
    );
}

#[test]
fn v13_v15_v16_writes_are_raw() {
    let v13 = hex("FA AF 01 00 0D 02 5B 5A 00 5A");
    let f = parse(&v13);
    assert_eq!(header(&f), (Direction::Request, 1, 0x00, 0x0D, 2));
    assert_eq!(f.payload(), &[0x5A, 0x00]);
    assert_eq!(classify(&f), Kind::Raw);
    assert_eq!(
        encoded(|b| encode_request(NodeId::ROV, 0, 0x0D, &90u16.to_le_bytes(), b).unwrap()),
        v13
    );

    let manip = [0x35, 0x49, 0, 0, 0, 0, 0x03, 0];
    let v15 = hex("FA AF 42 00 F0 08 EF 35 49 00 00 00 00 03 00 7F");
    let f = parse(&v15);
    assert_eq!(f.node(), NodeId::MANIPULATOR);
    assert_eq!(classify(&f), Kind::Raw);
    assert_eq!(
        encoded(|b| encode_request(NodeId::MANIPULATOR, 0, 0xF0, &manip, b).unwrap()),
        v15
    );
    // Close (02) and stop (00) change only the command byte and the total check.
    for (cmd, tc) in [(0x02, 0x7E), (0x00, 0x7C)] {
        let mut payload = manip;
        payload[6] = cmd;
        let bytes = encoded(|b| encode_request(NodeId::MANIPULATOR, 0, 0xF0, &payload, b).unwrap());
        assert_eq!(*bytes.last().unwrap(), tc);
    }

    let v16 = hex("FA AF 01 01 F0 02 A7 CA 02 C8");
    let f = parse(&v16);
    assert_eq!(classify(&f), Kind::Raw);
    assert_eq!(
        encoded(|b| encode_request(NodeId::ROV, 0x01, 0xF0, &[0xCA, 0x02], b).unwrap()),
        v16
    );
}

#[test]
fn v14_reboot() {
    let bytes = hex("FA AF 01 00 FE 02 A8 DE AD 73");
    let f = parse(&bytes);
    assert_eq!(header(&f), (Direction::Request, 1, 0x00, 0xFE, 2));
    assert_eq!(Reboot::from_frame(&f), Ok(Reboot));
    assert_eq!(Message::decode(&f), Message::Reboot);
    assert_eq!(
        encoded(|b| Reboot::encode_request(NodeId::ROV, b).unwrap()),
        bytes
    );
}

fn v18_fields() -> ConfigData {
    let mut serial = [0u8; 16];
    serial[..6].copy_from_slice(b"J14461");
    ConfigData {
        device_type: DeviceType::Pro4Rov,
        bootloader: BootloaderBlock {
            version: 1,
            device_type: 1,
            serial,
            reserved: [0; 8],
            valid_app_flag: VALID_APP_FLAG,
        },
        hardware: HardwareConfig::EMPTY,
    }
}

#[test]
fn v18_extended_config_reply() {
    let bytes = v18();
    assert_eq!(bytes.len(), 304);
    let f = parse(&bytes);
    assert!(f.is_extended());
    assert_eq!(f.length_field(), LengthField::Extended);
    assert_eq!(header(&f), (Direction::Response, 1, 0x80, 0xF7, 293));
    assert_eq!(CONFIG_PAYLOAD_LEN, 0x0125);
    let cfg = ConfigData::from_frame(&f).unwrap();
    assert_eq!(cfg, v18_fields());
    assert_eq!(cfg.bootloader.serial_str(), Some("J14461"));
    assert!(cfg.bootloader.is_app_valid());
    assert_eq!(Message::decode(&f), Message::Config(cfg));
    assert_eq!(
        encoded(|b| v18_fields().encode_response(NodeId::ROV, b).unwrap()),
        bytes
    );
    // The reference C parser has no extended length; ours must not need it in the
    // normal path either: a 7-byte header with LENGTH 0xFF needs 3 more bytes.
    assert_eq!(
        Frame::parse(&bytes[..7]),
        Err(FrameError::Incomplete { needed: 10 })
    );
    assert_eq!(
        Frame::parse(&bytes[..303]),
        Err(FrameError::Incomplete { needed: 304 })
    );
}

#[test]
fn extended_length_check_and_cap() {
    let mut bytes = v18();
    bytes[9] ^= 0x01;
    assert_eq!(
        Frame::parse(&bytes),
        Err(FrameError::ExtLengthCheck {
            computed: 0x24,
            received: 0x25
        })
    );
    // EXT LEN 0x0401 = 1025 > 1024 with a valid check.
    let over = hex("FD DF 01 80 F7 FF AB 01 04 05");
    assert_eq!(
        Frame::parse(&over),
        Err(FrameError::Overlong {
            len: 1025,
            max: 1024
        })
    );
    let mut d = Deframer::host();
    let events = run_chunked(&mut d, &over, over.len());
    assert_eq!(events[0], Ev::error(DeframeErrorKind::Overlong, 0, 1));
    assert_eq!(d.counters().overlong, 1);
}

// ---------------------------------------------------------------------------
// Corrupted inputs (protocol_vectors.md, "Recommended" column)
// ---------------------------------------------------------------------------

const V5: &str = "FA AF 01 05 00 00 51 00";

fn vehicle_events(bytes: &[u8]) -> (Vec<Ev>, Deframer) {
    let mut d = Deframer::vehicle();
    let events = run_chunked(&mut d, bytes, bytes.len());
    assert_counters_consistent(&d);
    (events, d)
}

#[test]
fn c1_payload_bit_flip_is_dropped() {
    let bytes = hex("FA AF 01 05 00 0F 5E 32 01 CE FF 19 00 4B E2 00 00 00 FF FF FF FF B3");
    let (events, d) = vehicle_events(&bytes);
    assert_eq!(
        events,
        vec![
            Ev::error(DeframeErrorKind::TotalCheck, 0, 1),
            Ev::error(DeframeErrorKind::BadSync, 1, 22),
        ]
    );
    assert_eq!(d.counters().frames_ok, 0);
    assert_eq!(d.counters().total_check, 1);
    assert!(matches!(
        Frame::parse(&bytes),
        Err(FrameError::TotalCheck { received: 0xB3, .. })
    ));
}

#[test]
fn c2_bad_header_check_is_dropped() {
    let bytes = hex("FA AF 01 05 00 0F A1 32 00 CE FF 19 00 4B E2 00 00 00 FF FF FF FF B3");
    let (events, d) = vehicle_events(&bytes);
    assert_eq!(
        events,
        vec![
            Ev::error(DeframeErrorKind::HeaderCheck, 0, 1),
            Ev::error(DeframeErrorKind::BadSync, 1, 22),
        ]
    );
    assert_eq!(d.counters().header_check, 1);
    assert_eq!(d.counters().garbage_bytes, 22);
}

#[test]
fn c3_noise_then_good_frame() {
    let bytes = hex(&format!("00 13 FA 00 55 {V5}"));
    let (events, _) = vehicle_events(&bytes);
    assert_eq!(
        events,
        vec![
            Ev::error(DeframeErrorKind::BadSync, 0, 5),
            Ev::frame(5, &hex(V5)),
        ]
    );
}

#[test]
fn c4_stray_sync_byte_before_frame() {
    let bytes = hex(&format!("FA {V5}"));
    let (events, _) = vehicle_events(&bytes);
    assert_eq!(
        events,
        vec![
            Ev::error(DeframeErrorKind::BadSync, 0, 1),
            Ev::frame(1, &hex(V5)),
        ]
    );
}

const C5_FRAGMENT: &str = "FA AF 01 05 00 0F 5E 32 00 CE FF 19";

#[test]
fn c5_truncated_packet_then_two_good_ones() {
    let bytes = hex(&format!("{C5_FRAGMENT} {V5} {V5}"));
    let (events, d) = vehicle_events(&bytes);
    assert_eq!(
        events,
        vec![
            Ev::error(DeframeErrorKind::TotalCheck, 0, 1),
            Ev::error(DeframeErrorKind::BadSync, 1, 11),
            Ev::frame(12, &hex(V5)),
            Ev::frame(20, &hex(V5)),
        ]
    );
    assert_eq!(d.counters().frames_ok, 2);
}

#[test]
fn c5_with_gap_timeout_discards_fragment_sooner() {
    let mut d = Deframer::vehicle();
    let mut events = Vec::new();
    d.push(&hex(C5_FRAGMENT), 1_000, |e| events.push(Ev::from_event(e)));
    assert!(events.is_empty());
    // 87 µs per byte at 115200 baud: the next bytes arrive 20 ms later.
    d.push(&hex(&format!("{V5} {V5}")), 21_000, |e| {
        events.push(Ev::from_event(e))
    });
    assert_eq!(
        events,
        vec![
            Ev::error(DeframeErrorKind::Stall, 0, 1),
            Ev::error(DeframeErrorKind::BadSync, 1, 11),
            Ev::frame(12, &hex(V5)),
            Ev::frame(20, &hex(V5)),
        ]
    );
    assert_eq!(d.counters().stall, 1);
    assert_counters_consistent(&d);
}

#[test]
fn c6_mixed_sync_pair_is_rejected() {
    let bytes = hex("FA DF 01 05 00 00 21 00");
    assert_eq!(Frame::parse(&bytes), Err(FrameError::BadSync));
    let mut d = Deframer::new(DeframerConfig::default());
    let events = run_chunked(&mut d, &bytes, 1);
    assert_eq!(events, vec![Ev::error(DeframeErrorKind::BadSync, 0, 8)]);
    let fd_af = hex("FD AF 01 05 00 00 56 00");
    let mut d = Deframer::default();
    assert_eq!(
        run_chunked(&mut d, &fd_af, 3),
        vec![Ev::error(DeframeErrorKind::BadSync, 0, 8)]
    );
}

#[test]
fn wrong_direction_frames_are_counted_not_delivered() {
    let v3 = hex("FA AF 01 05 00 0F 5E 32 00 CE FF 19 00 4B E2 00 00 00 FF FF FF FF B3");
    let v2 = hex("FD DF 01 01 00 09 2B 01 EE 01 25 00 E2 FF 00 00 D6");
    let both = [v3.clone(), v2.clone()].concat();

    let mut host = Deframer::host();
    assert_eq!(
        run_chunked(&mut host, &both, 5),
        vec![
            Ev::error(DeframeErrorKind::WrongDirection, 0, 23),
            Ev::frame(23, &v2),
        ]
    );
    assert_eq!(host.counters().wrong_direction, 1);
    assert_eq!(host.counters().wrong_direction_bytes, 23);

    let mut vehicle = Deframer::vehicle();
    assert_eq!(
        run_chunked(&mut vehicle, &both, 7),
        vec![
            Ev::frame(0, &v3),
            Ev::error(DeframeErrorKind::WrongDirection, 23, 17),
        ]
    );
    assert_counters_consistent(&vehicle);
}
