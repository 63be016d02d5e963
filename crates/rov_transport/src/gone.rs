//! What a vanished port looks like.
//!
//! A USB serial adapter that is unplugged takes its device node with it; the open file
//! descriptor stays, and every read or write on it fails. A pseudo-terminal whose other
//! end closed behaves the same way. These errors mean "the port is gone, open it again
//! (maybe at another path)": they are not frame errors, and no amount of waiting on the
//! same descriptor brings the vehicle back. [`classify_io_error`] tells them apart from
//! other I/O errors; the serial transport reports them as
//! [`TransportError::Gone`](crate::TransportError::Gone).
//!
//! What each platform returns (errno values are the same on Linux and macOS):
//!
//! * Linux, USB adapter unplugged or pty master closed: `poll` reports `POLLHUP`
//!   (serialport turns that into [`io::ErrorKind::BrokenPipe`]), `read` returns `EIO`,
//!   or `read` returns 0 bytes (end of file) on a hung-up tty.
//! * macOS and the BSDs: `ENXIO`, whose text there is "Device not configured".
//! * `ENODEV` from some USB serial drivers while the device is being removed.
//!
//! serialport re-creates its `io::Error`s from a kind and a text, which drops the errno,
//! so the text is checked as well as the raw code.

use std::fmt;
use std::io;

/// Why a port is considered gone.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum PortGone {
    /// `EIO`: input/output error on a hung-up terminal.
    Eio,
    /// `ENXIO`: "No such device or address" (Linux), "Device not configured" (macOS).
    Enxio,
    /// `ENODEV`: no such device.
    NoDevice,
    /// A read returned end of file although the port was readable.
    Eof,
    /// The other end hung up (`POLLHUP`, `EPIPE`, connection reset or aborted).
    Hangup,
    /// The other end of an in-memory pipe closed.
    Closed,
}

impl PortGone {
    /// Short name (the errno name where there is one).
    #[must_use]
    pub const fn as_str(self) -> &'static str {
        match self {
            Self::Eio => "EIO",
            Self::Enxio => "ENXIO",
            Self::NoDevice => "ENODEV",
            Self::Eof => "end of file",
            Self::Hangup => "hang-up",
            Self::Closed => "closed",
        }
    }
}

impl fmt::Display for PortGone {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// errno values shared by Linux, macOS and the BSDs.
#[cfg(unix)]
mod errno {
    pub const EIO: i32 = 5;
    pub const ENXIO: i32 = 6;
    pub const ENODEV: i32 = 19;
    pub const EPIPE: i32 = 32;
}

/// Whether an I/O error from a port means the device went away; `None` for any other
/// error (which the caller reports as a plain I/O error). Timeouts and interrupted calls
/// are not errors here: the transports turn them into "nothing received" first.
#[must_use]
pub fn classify_io_error(e: &io::Error) -> Option<PortGone> {
    #[cfg(unix)]
    if let Some(code) = e.raw_os_error() {
        match code {
            errno::EIO => return Some(PortGone::Eio),
            errno::ENXIO => return Some(PortGone::Enxio),
            errno::ENODEV => return Some(PortGone::NoDevice),
            errno::EPIPE => return Some(PortGone::Hangup),
            _ => {}
        }
    }
    match e.kind() {
        io::ErrorKind::BrokenPipe
        | io::ErrorKind::ConnectionReset
        | io::ErrorKind::ConnectionAborted
        | io::ErrorKind::NotConnected => return Some(PortGone::Hangup),
        io::ErrorKind::UnexpectedEof => return Some(PortGone::Eof),
        _ => {}
    }
    let text = e.to_string().to_lowercase();
    if text.contains("input/output error") || text.contains("i/o error") {
        Some(PortGone::Eio)
    } else if text.contains("no such device or address") || text.contains("device not configured") {
        Some(PortGone::Enxio)
    } else if text.contains("no such device") {
        Some(PortGone::NoDevice)
    } else if text.contains("broken pipe") {
        Some(PortGone::Hangup)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[cfg(unix)]
    #[test]
    fn raw_errno_values() {
        let c = |code| classify_io_error(&io::Error::from_raw_os_error(code));
        assert_eq!(c(5), Some(PortGone::Eio));
        assert_eq!(c(6), Some(PortGone::Enxio));
        assert_eq!(c(19), Some(PortGone::NoDevice));
        assert_eq!(c(32), Some(PortGone::Hangup));
        // EACCES, EBUSY, EAGAIN: not "gone".
        assert_eq!(c(13), None);
        assert_eq!(c(16), None);
        assert_eq!(c(11), None);
    }

    /// The shapes serialport produces: its errors lose the errno and keep kind + text.
    #[test]
    fn serialport_shaped_errors() {
        let e = |kind, text: &str| classify_io_error(&io::Error::new(kind, text.to_string()));
        // poll: POLLHUP / POLLNVAL.
        assert_eq!(
            e(io::ErrorKind::BrokenPipe, "Broken pipe"),
            Some(PortGone::Hangup)
        );
        // poll: any other revents, and read's EIO, via nix's description.
        assert_eq!(e(io::ErrorKind::Other, "I/O error"), Some(PortGone::Eio));
        assert_eq!(
            e(io::ErrorKind::Other, "Input/output error"),
            Some(PortGone::Eio)
        );
        assert_eq!(
            e(io::ErrorKind::Other, "No such device or address"),
            Some(PortGone::Enxio)
        );
        assert_eq!(
            e(io::ErrorKind::Other, "Device not configured"),
            Some(PortGone::Enxio)
        );
        assert_eq!(
            e(io::ErrorKind::Other, "No such device"),
            Some(PortGone::NoDevice)
        );
        assert_eq!(e(io::ErrorKind::UnexpectedEof, "eof"), Some(PortGone::Eof));
        // Not gone: permission, busy, invalid settings, unknown.
        assert_eq!(
            e(io::ErrorKind::PermissionDenied, "Permission denied"),
            None
        );
        assert_eq!(e(io::ErrorKind::InvalidInput, "bad baud rate"), None);
        assert_eq!(e(io::ErrorKind::Other, "Device or resource busy"), None);
    }
}
