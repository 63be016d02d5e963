//! An in-memory, wall-time byte pipe (two channels). For the virtual-time pipe between
//! the driver's `Link` and a simulated vehicle see `rov_station::sim_link`.

use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, channel};
use std::time::Duration;

use crate::{ByteSink, ByteSource, SplitHalves, Transport, TransportError};

/// Receiving half of a memory pipe.
#[derive(Debug)]
pub struct MemoryRx {
    rx: Receiver<Vec<u8>>,
    pending: Vec<u8>,
    name: String,
}

/// Sending half of a memory pipe.
#[derive(Debug, Clone)]
pub struct MemoryTx {
    tx: Sender<Vec<u8>>,
    name: String,
}

/// One end of an in-memory duplex pipe.
#[derive(Debug)]
pub struct MemoryTransport {
    rx: MemoryRx,
    tx: MemoryTx,
}

/// Two connected ends: bytes sent on one are received on the other.
#[must_use]
pub fn memory_pair() -> (MemoryTransport, MemoryTransport) {
    let (a_tx, b_rx) = channel();
    let (b_tx, a_rx) = channel();
    let end = |rx, tx, name: &str| MemoryTransport {
        rx: MemoryRx {
            rx,
            pending: Vec::new(),
            name: name.to_string(),
        },
        tx: MemoryTx {
            tx,
            name: name.to_string(),
        },
    };
    (end(a_rx, a_tx, "memory:a"), end(b_rx, b_tx, "memory:b"))
}

impl ByteSource for MemoryRx {
    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, TransportError> {
        if self.pending.is_empty() {
            match self.rx.recv_timeout(timeout) {
                Ok(bytes) => self.pending = bytes,
                Err(RecvTimeoutError::Timeout) => return Ok(0),
                Err(RecvTimeoutError::Disconnected) => {
                    return Err(TransportError::Closed {
                        port: self.name.clone(),
                    });
                }
            }
        }
        // Take whatever else is already queued, so one recv sees a burst.
        while self.pending.len() < buf.len() {
            match self.rx.try_recv() {
                Ok(more) => self.pending.extend_from_slice(&more),
                Err(_) => break,
            }
        }
        let n = self.pending.len().min(buf.len());
        if let (Some(dst), Some(src)) = (buf.get_mut(..n), self.pending.get(..n)) {
            dst.copy_from_slice(src);
        }
        self.pending.drain(..n);
        Ok(n)
    }
}

impl ByteSink for MemoryTx {
    fn send(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        self.tx
            .send(bytes.to_vec())
            .map_err(|_| TransportError::Closed {
                port: self.name.clone(),
            })
    }
}

impl ByteSource for MemoryTransport {
    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, TransportError> {
        self.rx.recv(buf, timeout)
    }
}

impl ByteSink for MemoryTransport {
    fn send(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        self.tx.send(bytes)
    }
}

impl Transport for MemoryTransport {
    fn name(&self) -> String {
        self.tx.name.clone()
    }

    fn split(self: Box<Self>) -> Result<SplitHalves, TransportError> {
        Ok((Box::new(self.rx), Box::new(self.tx)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_cross_and_close_is_reported() {
        let (mut a, mut b) = memory_pair();
        a.send(&[1, 2, 3]).unwrap();
        a.send(&[4]).unwrap();
        let mut buf = [0u8; 2];
        assert_eq!(b.recv(&mut buf, Duration::from_millis(10)).unwrap(), 2);
        assert_eq!(buf, [1, 2]);
        let mut buf = [0u8; 8];
        assert_eq!(b.recv(&mut buf, Duration::from_millis(10)).unwrap(), 2);
        assert_eq!(&buf[..2], &[3, 4]);
        assert_eq!(b.recv(&mut buf, Duration::from_millis(1)).unwrap(), 0);
        drop(a);
        assert!(matches!(
            b.recv(&mut buf, Duration::from_millis(1)),
            Err(TransportError::Closed { .. })
        ));
    }
}
