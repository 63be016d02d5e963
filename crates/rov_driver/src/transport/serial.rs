//! The real serial port (115200 8N1, no flow control) through `serialport` without
//! libudev, pseudo-terminal pairs for tests, port enumeration and autodetect by ping
//! (protocol.md §7).

use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;

use firmware_proto::NodeId;
use serialport::{DataBits, FlowControl, Parity, SerialPort, StopBits};

use super::PortGone;
use super::probe::{ProbeReply, probe};
use super::{ByteSink, ByteSource, SplitHalves, Transport};
use crate::error::TransportError;

/// The Pro 4's line rate.
pub const PRO4_BAUD: u32 = 115_200;

/// A serial port (or one end of a pty pair).
pub struct SerialTransport {
    port: Box<dyn SerialPort>,
    name: String,
    timeout: Duration,
}

impl std::fmt::Debug for SerialTransport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SerialTransport")
            .field("name", &self.name)
            .finish_non_exhaustive()
    }
}

fn io_err(port: &str, source: io::Error) -> TransportError {
    TransportError::from_io(port, source)
}

fn serial_err(port: &str, source: serialport::Error) -> TransportError {
    TransportError::Serial {
        port: port.to_string(),
        source: Box::new(source),
    }
}

impl SerialTransport {
    /// Opens `path` at `baud`, 8 data bits, no parity, 1 stop bit, no flow control.
    ///
    /// # Errors
    /// [`TransportError::Serial`] if the port cannot be opened or configured.
    pub fn open(path: &str, baud: u32) -> Result<Self, TransportError> {
        let timeout = Duration::from_millis(10);
        let port = serialport::new(path, baud)
            .data_bits(DataBits::Eight)
            .parity(Parity::None)
            .stop_bits(StopBits::One)
            .flow_control(FlowControl::None)
            .timeout(timeout)
            .open()
            .map_err(|e| serial_err(path, e))?;
        Ok(Self {
            port,
            name: path.to_string(),
            timeout,
        })
    }

    /// Wraps an already open port.
    #[must_use]
    pub fn from_port(port: Box<dyn SerialPort>) -> Self {
        let name = port.name().unwrap_or_else(|| "serial".to_string());
        let timeout = port.timeout();
        Self {
            port,
            name,
            timeout,
        }
    }

    /// A pseudo-terminal pair (openpty): `(master, slave, slave_path)`. Bytes written on
    /// one end are read on the other, with no baud-rate pacing. The slave path can be
    /// opened again by name (e.g. by [`autodetect`]).
    ///
    /// # Errors
    /// [`TransportError::Serial`] if no pty is available.
    #[cfg(unix)]
    pub fn pty_pair() -> Result<(Self, Self, String), TransportError> {
        let (master, slave) = serialport::TTYPort::pair().map_err(|e| serial_err("pty", e))?;
        let slave_path = slave.name().unwrap_or_default();
        let mut master = Self::from_port(Box::new(master));
        master.name = format!("pty master of {slave_path}");
        let slave = Self::from_port(Box::new(slave));
        Ok((master, slave, slave_path))
    }

    /// Discards unread input.
    ///
    /// # Errors
    /// [`TransportError::Serial`] on failure.
    pub fn clear_input(&mut self) -> Result<(), TransportError> {
        self.port
            .clear(serialport::ClearBuffer::Input)
            .map_err(|e| serial_err(&self.name, e))
    }
}

fn recv_port(
    port: &mut dyn SerialPort,
    current: &mut Duration,
    name: &str,
    buf: &mut [u8],
    timeout: Duration,
) -> Result<usize, TransportError> {
    if *current != timeout {
        port.set_timeout(timeout).map_err(|e| serial_err(name, e))?;
        *current = timeout;
    }
    match port.read(buf) {
        // serialport reads only after poll reported the port readable (a timeout is an
        // error), so zero bytes into a non-empty buffer is end of file: a hung-up tty.
        Ok(0) if !buf.is_empty() => Err(TransportError::Gone {
            port: name.to_string(),
            cause: PortGone::Eof,
            detail: "read returned end of file".into(),
        }),
        Ok(n) => Ok(n),
        Err(e)
            if matches!(
                e.kind(),
                io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted
            ) =>
        {
            Ok(0)
        }
        Err(e) => Err(io_err(name, e)),
    }
}

impl ByteSource for SerialTransport {
    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, TransportError> {
        recv_port(
            self.port.as_mut(),
            &mut self.timeout,
            &self.name,
            buf,
            timeout,
        )
    }
}

impl ByteSink for SerialTransport {
    fn send(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        self.port
            .write_all(bytes)
            .map_err(|e| io_err(&self.name, e))
    }
}

struct SerialHalf {
    port: Box<dyn SerialPort>,
    name: String,
    timeout: Duration,
}

impl ByteSource for SerialHalf {
    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, TransportError> {
        recv_port(
            self.port.as_mut(),
            &mut self.timeout,
            &self.name,
            buf,
            timeout,
        )
    }
}

impl ByteSink for SerialHalf {
    fn send(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        self.port
            .write_all(bytes)
            .map_err(|e| io_err(&self.name, e))
    }
}

impl Transport for SerialTransport {
    fn name(&self) -> String {
        self.name.clone()
    }

    fn split(self: Box<Self>) -> Result<SplitHalves, TransportError> {
        let clone = self
            .port
            .try_clone()
            .map_err(|e| serial_err(&self.name, e))?;
        let writer = SerialHalf {
            timeout: clone.timeout(),
            port: clone,
            name: self.name.clone(),
        };
        let reader = SerialHalf {
            port: self.port,
            name: self.name,
            timeout: self.timeout,
        };
        Ok((Box::new(reader), Box::new(writer)))
    }
}

/// Names of the serial ports the system lists (`serialport::available_ports`, without
/// libudev: sysfs on Linux).
///
/// # Errors
/// [`TransportError::Serial`] if enumeration fails.
pub fn available_port_names() -> Result<Vec<String>, TransportError> {
    serialport::available_ports()
        .map(|ports| ports.into_iter().map(|p| p.port_name).collect())
        .map_err(|e| serial_err("enumeration", e))
}

/// Where udev keeps the stable names of USB serial ports on Linux
/// (`usb-<vendor>_<product>_<serial>-if<NN>-port<N>`, symlinks to `../../ttyUSBn`).
pub const BY_ID_DIR: &str = "/dev/serial/by-id";

/// The stable by-id name of the port at `path`: the entry of `dir` (normally
/// [`BY_ID_DIR`]) that resolves to the same device as `path`, symlinks followed on both
/// sides; `path` itself if it already is an entry of `dir`. `None` when there is none
/// (no udev, not a USB adapter, a pty) or `path` does not resolve.
#[must_use]
pub fn by_id_name(path: &str, dir: &Path) -> Option<String> {
    let p = Path::new(path);
    if p.parent() == Some(dir) {
        return Some(path.to_string());
    }
    let device = std::fs::canonicalize(p).ok()?;
    let mut names: Vec<PathBuf> = std::fs::read_dir(dir)
        .ok()?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    names.sort();
    names
        .into_iter()
        .find(|n| std::fs::canonicalize(n).is_ok_and(|d| d == device))
        .map(|n| n.to_string_lossy().into_owned())
}

/// What autodetect found on each candidate port.
#[derive(Debug)]
pub struct AutodetectReport {
    /// The first port that answered.
    pub found: Option<ProbeReply>,
    /// Every port tried, with the reason it was not chosen (`None` = it answered).
    pub tried: Vec<(String, Option<String>)>,
}

/// Tries each candidate port in turn (115200 8N1): sends the ping and stops at the first
/// port with any well-formed response. Ports that fail to open are skipped and reported.
#[must_use]
pub fn autodetect(candidates: &[String], node: NodeId, timeout: Duration) -> AutodetectReport {
    let mut tried = Vec::with_capacity(candidates.len());
    for path in candidates {
        let mut port = match SerialTransport::open(path, PRO4_BAUD) {
            Ok(p) => p,
            Err(e) => {
                tried.push((path.clone(), Some(e.to_string())));
                continue;
            }
        };
        match probe(&mut port, node, timeout) {
            Ok(Some(reply)) => {
                tried.push((path.clone(), None));
                return AutodetectReport {
                    found: Some(ProbeReply {
                        port: path.clone(),
                        ..reply
                    }),
                    tried,
                };
            }
            Ok(None) => tried.push((path.clone(), Some("no response".to_string()))),
            Err(e) => tried.push((path.clone(), Some(e.to_string()))),
        }
    }
    AutodetectReport { found: None, tried }
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;

    /// A udev-like tree in a temporary directory: `dev/ttyUSB0`, `dev/ttyUSB1` (plain
    /// files standing in for device nodes) and `by-id/usb-A` → `../dev/ttyUSB1`.
    #[test]
    fn by_id_name_follows_links_on_both_sides() {
        let root = std::env::temp_dir().join(format!("rov_driver_by_id_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let dev = root.join("dev");
        let by_id = root.join("by-id");
        std::fs::create_dir_all(&dev).unwrap();
        std::fs::create_dir_all(&by_id).unwrap();
        std::fs::write(dev.join("ttyUSB0"), b"").unwrap();
        std::fs::write(dev.join("ttyUSB1"), b"").unwrap();
        std::os::unix::fs::symlink("../dev/ttyUSB1", by_id.join("usb-A")).unwrap();
        // An alias of ttyUSB1 (like socat's link=) resolves too.
        std::os::unix::fs::symlink(dev.join("ttyUSB1"), root.join("alias")).unwrap();
        let s = |p: &Path| p.to_str().unwrap().to_string();
        let want = Some(s(&by_id.join("usb-A")));
        assert_eq!(by_id_name(&s(&dev.join("ttyUSB1")), &by_id), want);
        assert_eq!(by_id_name(&s(&root.join("alias")), &by_id), want);
        assert_eq!(by_id_name(&s(&by_id.join("usb-A")), &by_id), want);
        assert_eq!(by_id_name(&s(&dev.join("ttyUSB0")), &by_id), None);
        assert_eq!(by_id_name(&s(&dev.join("missing")), &by_id), None);
        assert_eq!(
            by_id_name(&s(&dev.join("ttyUSB1")), &root.join("no-such-dir")),
            None
        );
        std::fs::remove_dir_all(&root).unwrap();
    }
}
