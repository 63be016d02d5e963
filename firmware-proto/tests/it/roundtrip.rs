//! Round-trip properties (requirement A2): for every message type, encode →
//! deframe (random chunking) → decode gives back the original, and every frame
//! re-encodes to the same bytes.

use firmware_proto::msg::{CONFIG_TEXT_LEN, HardwareConfig};
use firmware_proto::{
    BootloaderBlock, ConfigData, ControlBlock, CsrDump, CsrRead, Deframer, DeframerConfig,
    DeviceType, Direction, Event, Frame, Header, LengthField, Message, NavReply, NodeId, Ping,
    PingReply, Reboot, StatusBlock, encode_frame, frame_len,
};
use proptest::prelude::*;

/// Feeds `bytes` in chunks of `chunk` and returns the single frame's bytes and
/// its decoded message, checked to re-encode identically.
fn deframe_one(bytes: &[u8], chunk: usize, check: impl FnOnce(Message<'_>)) {
    let mut d = Deframer::new(DeframerConfig::default());
    let mut frames = 0;
    let mut check = Some(check);
    for part in bytes.chunks(chunk) {
        d.push(part, 0, |e| match e {
            Event::Frame { frame, offset } => {
                frames += 1;
                assert_eq!(offset, 0);
                assert_eq!(frame.as_bytes(), bytes);
                assert_reencodes(&frame);
                if let Some(check) = check.take() {
                    check(Message::decode(&frame));
                }
            }
            Event::Error(err) => panic!("unexpected {err}"),
        });
    }
    assert_eq!(frames, 1);
    assert_eq!(d.buffered_len(), 0);
}

/// Canonical form: a decoded frame re-encodes to exactly its own bytes.
fn assert_reencodes(frame: &Frame<'_>) {
    let mut buf = vec![0u8; frame.wire_len()];
    let n = encode_frame(
        &frame.header(),
        frame.payload(),
        frame.length_field(),
        &mut buf,
    )
    .unwrap();
    assert_eq!(&buf[..n], frame.as_bytes());
}

fn encode(f: impl FnOnce(&mut [u8]) -> usize) -> Vec<u8> {
    let mut buf = vec![0u8; 1100];
    let n = f(&mut buf);
    buf.truncate(n);
    buf
}

fn device_type() -> impl Strategy<Value = DeviceType> {
    any::<u8>().prop_map(DeviceType::from_byte)
}

fn target() -> impl Strategy<Value = Option<u16>> {
    prop_oneof![Just(None), (0u16..=65_534).prop_map(Some)]
}

prop_compose! {
    fn control_block()(
        port_pct in any::<i16>(), starboard_pct in any::<i16>(), vertical_pct in any::<i16>(),
        lights_pct in any::<u8>(), tilt_deg in any::<i8>(), focus_pct in any::<i8>(),
        camera_control in any::<u8>(), camera_buttons in any::<u8>(),
        depth_target_mbar in target(), heading_target_deg in target(),
    ) -> ControlBlock {
        ControlBlock {
            port_pct, starboard_pct, vertical_pct, lights_pct, tilt_deg, focus_pct,
            camera_control, camera_buttons, depth_target_mbar, heading_target_deg,
        }
    }
}

prop_compose! {
    fn nav_reply()(
        device_type in device_type(),
        a in any::<[i16; 8]>(),
        b in any::<[i16; 8]>(),
        power_pct in any::<u8>(),
    ) -> NavReply {
        NavReply {
            device_type,
            heading_deg_x10: a[0], pitch_deg_x10: a[1], roll_deg_x10: a[2], pressure_mbar: a[3],
            yaw_accel_raw: a[4], pitch_accel_raw: a[5], roll_accel_raw: a[6],
            surge_accel_raw: a[7], sway_accel_raw: b[0], heave_accel_raw: b[1],
            mag_x_raw: b[2], mag_y_raw: b[3], mag_z_raw: b[4], attitude_status: b[5],
            humidity_pct: b[6], water_temp_c_x100: b[7], power_pct,
        }
    }
}

prop_compose! {
    fn ping_reply()(device_type in device_type(), v in any::<[i16; 4]>()) -> PingReply {
        PingReply {
            device_type,
            heading_deg_x10: v[0], pitch_deg_x10: v[1], roll_deg_x10: v[2], pressure_mbar: v[3],
        }
    }
}

prop_compose! {
    fn status_block()(
        device_type in device_type(), water in any::<i16>(), v in any::<[u16; 5]>(),
        t in any::<[u8; 2]>(),
    ) -> StatusBlock {
        StatusBlock {
            device_type, water_temp_c_x100: water, tether_v_x100: v[0], rail_12v_v_x100: v[1],
            rail_12v_ma: v[2], internal_temp_cpu_raw: t[0], internal_temp_power_raw: t[1],
            humidity_pct: v[3], comm_errors: v[4],
        }
    }
}

fn text() -> impl Strategy<Value = [u8; CONFIG_TEXT_LEN]> {
    any::<[u8; CONFIG_TEXT_LEN]>()
}

prop_compose! {
    fn config_data()(
        device_type in device_type(),
        version in any::<u16>(), dev in any::<u16>(), serial in any::<[u8; 16]>(),
        reserved in any::<[u8; 8]>(), valid_app_flag in any::<u32>(),
        structure_version in any::<u32>(),
        t0 in text(), t1 in text(), t2 in text(), t3 in text(),
        t4 in text(), t5 in text(), t6 in text(), t7 in text(),
    ) -> ConfigData {
        ConfigData {
            device_type,
            bootloader: BootloaderBlock { version, device_type: dev, serial, reserved, valid_app_flag },
            hardware: HardwareConfig {
                structure_version, cpu_board: t0, power_board: t1, depth_board: t2,
                camera_io_board: t3, camera: t4, lights: t5, horizontal_thrusters: t6,
                vertical_thrusters: t7,
            },
        }
    }
}

fn node() -> impl Strategy<Value = NodeId> {
    any::<u8>().prop_map(NodeId)
}

proptest! {
    #[test]
    fn control_round_trips(block in control_block(), node in node(), flags in any::<u8>(), chunk in 1usize..40) {
        let bytes = encode(|b| block.encode_request(node, flags, b).unwrap());
        prop_assert_eq!(bytes.len(), 23);
        prop_assert_eq!(ControlBlock::from_bytes(&block.to_bytes()), Ok(block));
        deframe_one(&bytes, chunk, |m| assert_eq!(m, Message::Control(block)));
    }

    #[test]
    fn nav_round_trips(nav in nav_reply(), node in node(), chunk in 1usize..50) {
        let bytes = encode(|b| nav.encode_response(node, b).unwrap());
        prop_assert_eq!(bytes.len(), 42);
        deframe_one(&bytes, chunk, |m| assert_eq!(m, Message::Nav(nav)));
        // Scaled accessors stay in range.
        prop_assert!((0.0..360.0).contains(&nav.heading_deg()));
    }

    #[test]
    fn ping_and_reply_round_trip(reply in ping_reply(), node in node(), chunk in 1usize..20) {
        let bytes = encode(|b| Ping::encode_request(node, b).unwrap());
        deframe_one(&bytes, chunk, |m| assert_eq!(m, Message::Ping));
        let bytes = encode(|b| reply.encode_response(node, b).unwrap());
        prop_assert_eq!(bytes.len(), 17);
        deframe_one(&bytes, chunk, |m| assert_eq!(m, Message::PingReply(reply)));
    }

    #[test]
    fn status_round_trips(status in status_block(), node in node(), chunk in 1usize..30) {
        let bytes = encode(|b| CsrRead::STATUS.encode_request(node, b).unwrap());
        deframe_one(&bytes, chunk, |m| assert_eq!(m, Message::CsrRead(CsrRead::STATUS)));
        let bytes = encode(|b| status.encode_response(node, b).unwrap());
        deframe_one(&bytes, chunk, |m| assert_eq!(m, Message::Status(status)));
    }

    #[test]
    fn csr_read_round_trips(start in any::<u8>(), flags in 0x80u8..=0xFF, node in node()) {
        let read = CsrRead { start, flags };
        let bytes = encode(|b| read.encode_request(node, b).unwrap());
        deframe_one(&bytes, 3, |m| assert_eq!(m, Message::CsrRead(read)));
    }

    #[test]
    fn dump_round_trips(
        device_type in device_type(), start in any::<u8>(),
        data in proptest::collection::vec(any::<u8>(), 0..=253), node in node(), chunk in 1usize..300,
    ) {
        let dump = CsrDump { device_type, start, data: &data };
        let bytes = encode(|b| dump.encode_response(node, b).unwrap());
        prop_assert_eq!(bytes.len(), data.len() + 9);
        deframe_one(&bytes, chunk, |m| match m {
            // The status and config shapes are typed more precisely.
            Message::Status(s) => assert_eq!(&s.to_payload()[1..], &data[..]),
            Message::CsrDump(d) => assert_eq!(d, dump),
            other => panic!("{other:?}"),
        });
    }

    #[test]
    fn config_round_trips(cfg in config_data(), node in node(), chunk in 1usize..400) {
        let bytes = encode(|b| cfg.encode_response(node, b).unwrap());
        prop_assert_eq!(bytes.len(), 304);
        deframe_one(&bytes, chunk, |m| assert_eq!(m, Message::Config(cfg)));
    }

    #[test]
    fn reboot_round_trips(node in node()) {
        let bytes = encode(|b| Reboot::encode_request(node, b).unwrap());
        deframe_one(&bytes, 1, |m| assert_eq!(m, Message::Reboot));
    }

    /// Any header, any payload length (normal 0..=254, extended 0..=1024):
    /// the encoded length is predicted, and the frame comes back unchanged.
    #[test]
    fn any_frame_round_trips(
        request in any::<bool>(), node in node(), flags in any::<u8>(), addr in any::<u8>(),
        extended in any::<bool>(), len in 0usize..=1024, seed in any::<u8>(), chunk in 1usize..2000,
    ) {
        let length = if extended { LengthField::Extended } else { LengthField::Normal };
        let len = if extended { len } else { len % 255 };
        let payload: Vec<u8> = (0..len).map(|i| (i as u8).wrapping_mul(31).wrapping_add(seed)).collect();
        let header = Header {
            direction: if request { Direction::Request } else { Direction::Response },
            node, flags, addr,
        };
        let bytes = encode(|b| encode_frame(&header, &payload, length, b).unwrap());
        prop_assert_eq!(bytes.len(), frame_len(len, length));
        let frame = Frame::parse(&bytes).unwrap();
        prop_assert_eq!(frame.header(), header);
        prop_assert_eq!(frame.payload(), &payload[..]);
        prop_assert_eq!(frame.length_field(), length);
        deframe_one(&bytes, chunk, |m| {
            // Classification never fails and agrees with the typed decoder.
            assert_eq!(m.kind(), firmware_proto::classify(&frame));
        });
    }
}
