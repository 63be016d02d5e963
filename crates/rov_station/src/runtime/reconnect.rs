//! The serial port's I/O with re-connection: a USB serial adapter that is unplugged
//! disappears as a device and may come back at another path.
//!
//! The serial port's two halves are wrapped (`wrap`) before the runtime's
//! `station-rx` and `station-tx` threads get them, so those threads do not change:
//!
//! * The source (`ReconnectingSource`, on `station-rx`) reads the port. A read that
//!   fails is classified ([`TransportError::port_gone`](rov_driver::TransportError::port_gone):
//!   EIO, ENXIO, ENODEV, end of file, hang-up; any other I/O error is reported as such)
//!   and the port is dropped. From then on each read drives the driver's clock-free
//!   [`Reconnect`] policy on the runtime clock: at each due attempt it opens the
//!   candidates (by-id name, last path, configured path, the other listed ports) and
//!   sends each a **neutral control write with the navigation request** (thrust 0,
//!   autopilots off, lights and camera as last sent); the first candidate on which the
//!   vehicle answers becomes the port. Reads return nothing meanwhile, never an error.
//! * The sink (`ReconnectingSink`, on `station-tx`) writes to the current port; with no
//!   port, frames are dropped (the link sends none while its port is closed; only the
//!   watchdog might). A failed write is handed to the source, which drops the port.
//! * The control thread gets a `PortEvent` for each change and the engine's
//!   `PortMonitor` tells the link ([`Link::on_port_lost`]: lost at once, failsafe neutral and latched;
//!   [`Link::on_port_opened`]: neutral probe at once, still disarmed), records the
//!   outage in the session's events (port lost with reason; a summary of the attempts
//!   every `summary_every_us`; reconnected at path P after T s with the attempts
//!   summarised), and shows "reconnecting (attempt n, next in t s)" and the path in
//!   [`LinkView::port`](crate::runtime::LinkView::port).
//!
//! A reconnection never re-arms: the link's failsafe stays latched until the pilot arms.

use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::sync::mpsc::SyncSender;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use firmware_proto::{NodeId, flags};
use rov_driver::{
    BY_ID_DIR, ByteSink, ByteSource, Candidate, CandidateSource, Link, OutageSummary, PRO4_BAUD,
    Reconnect, ReconnectConfig, ReconnectStatus, SerialTransport, SplitHalves, Transport,
    TransportError, by_id_name, probe_with,
};
use rov_session::Severity;

use crate::pilot::Engine;
use crate::pilot::view::{Source, StationView};
use crate::runtime::host::Host;
use crate::runtime::live::{Rx, watchdog_block};
use crate::runtime::{Connection, RuntimeConfig, RuntimeError, Shared, lock};

/// Lists the serial ports to scan while reconnecting.
pub type PortLister = Arc<dyn Fn() -> Vec<String> + Send + Sync>;

/// Re-connection settings of the live runtime (serial connections only).
#[derive(Clone)]
pub struct ReconnectSettings {
    /// Backoff schedule, probe timeout, scanning and summaries.
    pub policy: ReconnectConfig,
    /// Where the stable by-id names live (default `/dev/serial/by-id`).
    pub by_id_dir: PathBuf,
    /// The ports to scan (default: the ports the system lists, through `serialport`).
    pub ports: PortLister,
}

impl std::fmt::Debug for ReconnectSettings {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ReconnectSettings")
            .field("policy", &self.policy)
            .field("by_id_dir", &self.by_id_dir)
            .finish_non_exhaustive()
    }
}

/// The system's serial ports; an enumeration failure (or a panic inside the
/// enumeration library) lists nothing rather than stopping the port thread.
fn system_ports() -> Vec<String> {
    std::panic::catch_unwind(rov_driver::available_port_names)
        .ok()
        .and_then(Result::ok)
        .unwrap_or_default()
}

impl Default for ReconnectSettings {
    fn default() -> Self {
        Self {
            policy: ReconnectConfig::default(),
            by_id_dir: PathBuf::from(BY_ID_DIR),
            ports: Arc::new(system_ports),
        }
    }
}

pub use crate::pilot::view::PortView;

/// From the port thread to the control thread.
#[derive(Debug)]
pub(crate) enum PortEvent {
    /// The port failed and was dropped.
    Lost {
        path: String,
        reason: String,
        status: Option<ReconnectStatus>,
    },
    /// An attempt started or failed.
    Status(Option<ReconnectStatus>),
    /// A periodic summary of a long outage.
    Summary(OutageSummary),
    /// The vehicle answered on `path`; that is the port now.
    Reconnected {
        path: String,
        by_id: Option<String>,
        source: CandidateSource,
        summary: Option<OutageSummary>,
    },
}

/// The sink half of the current port, shared by the port and tx threads.
#[derive(Default)]
struct Slot {
    sink: Option<Box<dyn ByteSink>>,
    write_error: Option<String>,
}

/// The reading half of a serial port that is re-opened when it vanishes.
pub(crate) struct ReconnectingSource {
    current: Option<Box<dyn ByteSource>>,
    policy: Reconnect,
    settings: ReconnectSettings,
    node: NodeId,
    slot: Arc<Mutex<Slot>>,
    events: SyncSender<Rx>,
    shared: Arc<Shared>,
}

/// The writing half: writes to whatever port is open, never fails.
pub(crate) struct ReconnectingSink {
    slot: Arc<Mutex<Slot>>,
}

/// What happened to a candidate.
fn why_failed(e: &TransportError) -> String {
    match e.port_gone() {
        Some(cause) => format!("gone ({cause})"),
        None => e.to_string(),
    }
}

/// Why a candidate port is not the vehicle; its text is the key the outage summary
/// counts failures by ("no answer" ×12).
#[derive(Debug, thiserror::Error)]
enum ProbeFailure {
    /// The device path does not exist.
    #[error("not present")]
    NotPresent,
    /// The port cannot be opened, or the probe's write or read failed.
    #[error("{}", why_failed(.0))]
    Transport(#[from] TransportError),
    /// A vehicle answered, with another node ID.
    #[error("answered as node {0}")]
    WrongNode(u8),
    /// Nothing answered within the probe timeout.
    #[error("no answer")]
    NoAnswer,
}

/// The reason text of a failed read or write.
fn loss_reason(e: &TransportError) -> String {
    match e {
        TransportError::Gone { cause, detail, .. } => format!("port gone ({cause}): {detail}"),
        TransportError::Closed { .. } => "port gone (closed)".to_string(),
        other => format!("I/O error, not a vanished device: {other}"),
    }
}

/// The probe: a neutral control write with the navigation request, keeping the lights
/// and camera of the last frame sent, so the first thing a returning vehicle hears is
/// "stop" (protocol.md §12.2, "on reconnect").
fn probe_frame(shared: &Shared, node: NodeId) -> Vec<u8> {
    let mut frame = vec![0u8; 32];
    let n = watchdog_block(shared.watchdog_kept.load(Ordering::Relaxed))
        .encode_request(node, flags::NAV, &mut frame)
        .unwrap_or(0);
    frame.truncate(n);
    frame
}

impl ReconnectingSource {
    fn send(&self, ev: PortEvent) {
        // The control thread has stopped if this fails; the rx loop ends on its own.
        let _ = self.events.send(Rx::Port(ev));
    }

    fn now_us(&self) -> u64 {
        self.shared.clock.now_us()
    }

    /// Drops the port and starts looking for it.
    fn lose(&mut self, reason: String) {
        self.current = None;
        *lock(&self.slot) = Slot::default();
        let path = self.policy.last_path().to_string();
        self.policy.lost(self.now_us(), &reason);
        let status = self.policy.status();
        self.send(PortEvent::Lost {
            path,
            reason,
            status,
        });
    }

    /// Opens and probes one candidate.
    fn try_candidate(&self, c: &Candidate) -> Result<SerialTransport, ProbeFailure> {
        if !Path::new(&c.path).exists() {
            return Err(ProbeFailure::NotPresent);
        }
        let mut port = SerialTransport::open(&c.path, PRO4_BAUD)?;
        let timeout = Duration::from_micros(self.policy.config().probe_timeout_us);
        let frame = probe_frame(&self.shared, self.node);
        match probe_with(&mut port, &frame, timeout)? {
            Some(reply) if reply.node == self.node => Ok(port),
            Some(reply) => Err(ProbeFailure::WrongNode(reply.node.0)),
            None => Err(ProbeFailure::NoAnswer),
        }
    }

    /// One attempt over the candidates; true if the vehicle answered on one of them.
    fn attempt(&mut self, candidates: &[Candidate]) -> bool {
        for c in candidates {
            if !self.shared.running.load(Ordering::Relaxed) {
                return false;
            }
            let port = match self.try_candidate(c) {
                Ok(p) => p,
                Err(why) => {
                    self.policy.candidate_failed(c, &why.to_string());
                    continue;
                }
            };
            let (source, sink) = match Box::new(port).split() {
                Ok(halves) => halves,
                Err(e) => {
                    self.policy.candidate_failed(c, &why_failed(&e));
                    continue;
                }
            };
            *lock(&self.slot) = Slot {
                sink: Some(sink),
                write_error: None,
            };
            self.current = Some(source);
            // Found through its by-id name: show (and try first next time, after the
            // by-id name) the device it resolves to; otherwise keep the name that
            // worked, and look up its by-id name now.
            let (path, by_id) = if c.source == CandidateSource::ById {
                let device = std::fs::canonicalize(&c.path)
                    .map_or_else(|_| c.path.clone(), |d| d.to_string_lossy().into_owned());
                (device, Some(c.path.clone()))
            } else {
                (
                    c.path.clone(),
                    by_id_name(&c.path, &self.settings.by_id_dir),
                )
            };
            let summary = self.policy.reconnected(self.now_us(), &path, by_id.clone());
            self.send(PortEvent::Reconnected {
                path,
                by_id,
                source: c.source,
                summary,
            });
            return true;
        }
        false
    }

    /// While the port is gone: waits up to `timeout` for the next attempt, or runs it.
    fn reconnect_step(&mut self, timeout: Duration) {
        let now = self.now_us();
        if let Some(s) = self.policy.due_summary(now) {
            self.send(PortEvent::Summary(s));
        }
        let available = if self.policy.config().scan_other_ports {
            (self.settings.ports)()
        } else {
            Vec::new()
        };
        let Some(candidates) = self.policy.start_attempt(now, &available) else {
            let timeout_us = u64::try_from(timeout.as_micros()).unwrap_or(u64::MAX);
            let wait_us = self
                .policy
                .next_attempt_us()
                .map_or(timeout_us, |t| t.saturating_sub(now))
                .clamp(1_000, timeout_us.max(1_000));
            std::thread::sleep(Duration::from_micros(wait_us));
            return;
        };
        self.send(PortEvent::Status(self.policy.status()));
        if !self.attempt(&candidates) {
            self.policy.attempt_failed(self.now_us());
            self.send(PortEvent::Status(self.policy.status()));
        }
    }
}

impl ByteSource for ReconnectingSource {
    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, TransportError> {
        let Some(src) = self.current.as_mut() else {
            self.reconnect_step(timeout);
            return Ok(0);
        };
        match src.recv(buf, timeout) {
            Ok(0) => {
                let failed = lock(&self.slot).write_error.take();
                if let Some(reason) = failed {
                    self.lose(reason);
                }
                Ok(0)
            }
            Ok(n) => Ok(n),
            Err(e) => {
                self.lose(loss_reason(&e));
                Ok(0)
            }
        }
    }
}

impl ByteSink for ReconnectingSink {
    fn send(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        let mut s = lock(&self.slot);
        let failed = s.sink.as_mut().and_then(|sink| sink.send(bytes).err());
        if let Some(e) = failed {
            // The source drops the port on its next wake-up (≤ one read timeout).
            s.sink = None;
            s.write_error = Some(loss_reason(&e));
        }
        Ok(())
    }
}

/// For a serial connection: wraps the port's halves so that a vanished port is looked
/// for again, and gives the engine its [`PortMonitor`]. Other connections pass through.
///
/// # Errors
/// [`RuntimeError::Link`] if the re-connection settings are refused.
pub(crate) fn wrap(
    cfg: &RuntimeConfig,
    node: NodeId,
    (source, sink): SplitHalves,
    events: &SyncSender<Rx>,
    shared: &Arc<Shared>,
    engine: &mut Host,
) -> Result<SplitHalves, RuntimeError> {
    let Connection::Serial(path) = &cfg.connection else {
        return Ok((source, sink));
    };
    let settings = &cfg.reconnect;
    let by_id = by_id_name(path, &settings.by_id_dir);
    let policy = Reconnect::new(settings.policy, path, by_id.clone())?;
    let slot = Arc::new(Mutex::new(Slot {
        sink: Some(sink),
        write_error: None,
    }));
    engine.port = Some(PortMonitor {
        path: path.clone(),
        by_id,
        status: None,
        losses: 0,
    });
    let source = ReconnectingSource {
        current: Some(source),
        policy,
        settings: settings.clone(),
        node,
        slot: Arc::clone(&slot),
        events: events.clone(),
        shared: Arc::clone(shared),
    };
    Ok((Box::new(source), Box::new(ReconnectingSink { slot })))
}

/// The control thread's side: applies [`PortEvent`]s to the link, the session's events
/// and the view.
#[derive(Debug)]
pub(crate) struct PortMonitor {
    path: String,
    by_id: Option<String>,
    status: Option<ReconnectStatus>,
    losses: u64,
}

impl Host {
    /// A port event from the serial port's reader (nothing happens without a port).
    pub(crate) fn on_port_event(&mut self, ev: PortEvent, link: &mut Link, now_us: u64) {
        if let Some(mut port) = self.port.take() {
            port.on_event(ev, self.engine_mut(), link, now_us);
            self.port = Some(port);
        }
        self.flush(link, now_us);
    }

    /// Writes the port's state into the view (call after each tick).
    pub(crate) fn publish_port(&mut self, now_us: u64) {
        if let Some(port) = self.port.take() {
            port.publish(self.engine_mut().view_mut(), now_us);
            self.port = Some(port);
        }
    }
}

impl PortMonitor {
    fn on_event(&mut self, ev: PortEvent, engine: &mut Engine, link: &mut Link, now_us: u64) {
        match ev {
            PortEvent::Lost {
                path,
                reason,
                status,
            } => {
                link.on_port_lost(now_us);
                self.losses += 1;
                self.status = status;
                engine.event(
                    now_us,
                    "port_lost",
                    Severity::Alarm,
                    format!("serial port {path} lost: {reason}; thrust neutral, reconnecting"),
                );
            }
            PortEvent::Status(s) => self.status = s,
            PortEvent::Summary(s) => engine.event(
                now_us,
                "port_reconnecting",
                Severity::Warning,
                format!("still reconnecting: {s}"),
            ),
            PortEvent::Reconnected {
                path,
                by_id,
                source,
                summary,
            } => {
                link.on_port_opened(now_us);
                self.status = None;
                path.clone_into(&mut self.path);
                self.by_id = by_id;
                engine.view_mut().source = Source::Serial(path.clone());
                let via = match (&self.by_id, source) {
                    (Some(b), CandidateSource::ById) => format!("by-id {b}"),
                    _ => source.as_str().to_string(),
                };
                engine.event(
                    now_us,
                    "port_reconnected",
                    Severity::Warning,
                    match &summary {
                        Some(s) => format!(
                            "reconnected at {path} ({via}) {:.2} s after the loss; {}; \
                             disarmed until the pilot re-arms",
                            s.duration_us as f64 * 1e-6,
                            s.attempts_text()
                        ),
                        None => {
                            format!(
                                "reconnected at {path} ({via}); disarmed until the pilot re-arms"
                            )
                        }
                    },
                );
            }
        }
    }

    /// Writes the port's state into the view at `now_us`.
    fn publish(&self, view: &mut StationView, now_us: u64) {
        let s = self.status.as_ref();
        view.link.port = Some(PortView {
            path: self.path.clone(),
            by_id: self.by_id.clone(),
            state: s.map_or_else(|| "open".to_string(), |s| s.describe(now_us)),
            reconnecting: s.is_some(),
            attempt: s.map_or(0, |s| s.attempt),
            next_attempt_in_s: s
                .and_then(|s| s.next_attempt_us)
                .map(|t| t.saturating_sub(now_us) as f64 * 1e-6),
            lost_for_s: s.map(|s| now_us.saturating_sub(s.lost_us) as f64 * 1e-6),
            reason: s.map(|s| s.reason.clone()),
            losses: self.losses,
        });
    }
}

#[cfg(test)]
mod probe_failure_tests {
    use super::*;

    /// The failure's text is the outage summary's key ("/dev/ttyUSB1: no answer" ×12):
    /// the same words as before the type, a vanished port shortened to its cause.
    #[test]
    fn probe_failures_read_as_the_outage_summary_counts_them() {
        assert_eq!(ProbeFailure::NotPresent.to_string(), "not present");
        assert_eq!(ProbeFailure::NoAnswer.to_string(), "no answer");
        assert_eq!(ProbeFailure::WrongNode(3).to_string(), "answered as node 3");
        let gone = ProbeFailure::from(TransportError::Closed {
            port: "/dev/pts/9".into(),
        });
        assert_eq!(gone.to_string(), "gone (closed)");
        let io = ProbeFailure::from(TransportError::Io {
            port: "/dev/pts/9".into(),
            source: std::io::Error::other("boom"),
        });
        assert_eq!(io.to_string(), "/dev/pts/9: I/O error: boom");
        assert!(std::error::Error::source(&io).is_some());
    }
}
