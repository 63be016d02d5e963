//! Probing a transport for a vehicle: send one request, wait for any well-formed
//! response (protocol.md §7 step 1: any valid response means a vehicle). Used by
//! autodetect and by re-connection; works on any [`Transport`].

use std::time::{Duration, Instant};

use firmware_proto::{Deframer, DeviceType, Event, NodeId, Ping};

use super::Transport;
use crate::error::TransportError;

/// A well-formed response to a probe.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ProbeReply {
    /// The port it came from.
    pub port: String,
    /// Responder's node ID.
    pub node: NodeId,
    /// Response FLAGS.
    pub flags: u8,
    /// Responder's device type.
    pub device_type: Option<DeviceType>,
    /// Request to reply.
    pub rtt: Duration,
    /// The reply frame.
    pub frame: Vec<u8>,
}

/// Sends the ping (`FA AF node 01 00 00 HC 00`) and waits up to `timeout` for any
/// well-formed response (protocol.md §7 step 1: any valid response means a vehicle).
///
/// # Errors
/// [`TransportError`] if the transport fails.
pub fn probe(
    transport: &mut dyn Transport,
    node: NodeId,
    timeout: Duration,
) -> Result<Option<ProbeReply>, TransportError> {
    let mut ping = [0u8; 8];
    let n = Ping::encode_request(node, &mut ping).unwrap_or(0);
    probe_with(transport, ping.get(..n).unwrap_or_default(), timeout)
}

/// Sends `request` (an encoded request frame) and waits up to `timeout` for the first
/// well-formed response frame (host-side deframer: requests and noise are skipped).
///
/// # Errors
/// [`TransportError`] if the transport fails.
pub fn probe_with(
    transport: &mut dyn Transport,
    request: &[u8],
    timeout: Duration,
) -> Result<Option<ProbeReply>, TransportError> {
    let start = Instant::now();
    transport.send(request)?;
    let mut rx = Deframer::host();
    let mut buf = [0u8; 512];
    loop {
        let elapsed = start.elapsed();
        let Some(left) = timeout.checked_sub(elapsed) else {
            return Ok(None);
        };
        let got = transport.recv(&mut buf, left.min(Duration::from_millis(20)))?;
        let mut input = buf.get(..got).unwrap_or_default();
        let now_us = u64::try_from(start.elapsed().as_micros()).unwrap_or(u64::MAX);
        while let Some(event) = rx.feed(&mut input, now_us) {
            if let Event::Frame { frame, .. } = event {
                return Ok(Some(ProbeReply {
                    port: transport.name(),
                    node: frame.node(),
                    flags: frame.flags(),
                    device_type: frame.device_type(),
                    rtt: start.elapsed(),
                    frame: frame.as_bytes().to_vec(),
                }));
            }
        }
    }
}
