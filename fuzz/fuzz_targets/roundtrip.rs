//! Fuzz the typed codecs: any message encodes to a frame that parses, is
//! classified as its own kind and decodes to the same message.
#![no_main]

use arbitrary::Arbitrary;
use firmware_proto::{
    ConfigData, ControlBlock, CsrDump, CsrRead, Frame, Message, NavReply, NodeId, PingReply,
    StatusBlock,
};
use libfuzzer_sys::fuzz_target;

#[derive(Debug, Arbitrary)]
#[allow(clippy::large_enum_variant)] // built once per run; size is irrelevant
enum Input<'a> {
    Control(ControlBlock, NodeId, u8),
    Nav(NavReply, NodeId),
    PingReply(PingReply, NodeId),
    Status(StatusBlock, NodeId),
    Config(ConfigData, NodeId),
    Dump(CsrDump<'a>, NodeId),
    Read(CsrRead, NodeId),
}

fuzz_target!(|input: Input<'_>| {
    let mut buf = [0u8; 1100];
    let (n, expected) = match input {
        Input::Control(mut c, node, flags) => {
            // 0xFFFF means "off" on the wire, so Some(0xFFFF) decodes as None.
            c.depth_target_mbar = c.depth_target_mbar.filter(|&v| v != 0xFFFF);
            c.heading_target_deg = c.heading_target_deg.filter(|&v| v != 0xFFFF);
            (
                c.encode_request(node, flags, &mut buf).unwrap(),
                Message::Control(c),
            )
        }
        Input::Nav(m, node) => (m.encode_response(node, &mut buf).unwrap(), Message::Nav(m)),
        Input::PingReply(m, node) => (
            m.encode_response(node, &mut buf).unwrap(),
            Message::PingReply(m),
        ),
        Input::Status(m, node) => (
            m.encode_response(node, &mut buf).unwrap(),
            Message::Status(m),
        ),
        Input::Config(m, node) => (
            m.encode_response(node, &mut buf).unwrap(),
            Message::Config(m),
        ),
        Input::Dump(m, node) => match m.encode_response(node, &mut buf) {
            Ok(n) => (n, Message::CsrDump(m)),
            Err(_) => {
                assert!(m.data.len() > 253);
                return;
            }
        },
        Input::Read(mut m, node) => {
            m.flags |= 0x80;
            (
                m.encode_request(node, &mut buf).unwrap(),
                Message::CsrRead(m),
            )
        }
    };
    let frame = Frame::parse(&buf[..n]).unwrap();
    assert_eq!(frame.wire_len(), n);
    match (Message::decode(&frame), expected) {
        // A dump that happens to have the status or config shape is typed as such.
        (Message::Status(s), Message::CsrDump(d)) => assert_eq!(&s.to_payload()[1..], d.data),
        (Message::Config(c), Message::CsrDump(d)) => assert_eq!(&c.to_payload()[1..], d.data),
        (got, expected) => assert_eq!(got, expected),
    }
});
