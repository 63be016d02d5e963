//! The tokio runner (feature `tokio`). It keeps the transport's blocking calls off the
//! runtime: a reader thread timestamps incoming bytes and passes them through a channel,
//! a writer thread writes outgoing frames; the task itself only drives the sans-IO link
//! with `tokio::time` deadlines and serves the application's handle.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use firmware_proto::ControlBlock;
use rov_types::conventions::PhysicsThrust;
use tokio::sync::{mpsc, oneshot};
use tokio::task::JoinHandle;

use super::MonoClock;
use crate::error::{ArmError, DriverError, TransportError};
use crate::failsafe::LatchedAlarm;
use crate::link::Link;
use crate::stats::{LinkCounters, RttSummary};
use crate::telemetry::{Health, LinkEvent, Phase, Request, RequestId};
use crate::transport::Transport;

/// A snapshot of the link for displays.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinkSnapshot {
    /// When, µs of the runner's clock.
    pub time_us: u64,
    /// Phase.
    pub phase: Phase,
    /// Health.
    pub health: Health,
    /// Armed.
    pub armed: bool,
    /// Latched alarm.
    pub alarm: Option<LatchedAlarm>,
    /// Counters.
    pub counters: LinkCounters,
    /// Round trips.
    pub rtt: RttSummary,
    /// Events the handle's queue could not take.
    pub events_dropped: u64,
}

enum Ctl {
    Command(ControlBlock),
    Thrust(PhysicsThrust),
    Targets(Option<f64>, Option<f64>),
    Arm(oneshot::Sender<Result<(), ArmError>>),
    Disarm,
    Request(Request, oneshot::Sender<RequestId>),
    Snapshot(oneshot::Sender<LinkSnapshot>),
    Shutdown,
}

enum Rx {
    Bytes(Vec<u8>, u64),
    Failed(TransportError),
}

/// Settings of the tokio runner.
#[derive(Debug, Clone, Copy)]
pub struct RunnerOptions {
    /// Capacity of the event channel to the application; events beyond it are dropped
    /// and counted (default 1024).
    pub event_capacity: usize,
    /// Read timeout of the reader thread (default 20 ms; bounds the shutdown time).
    pub read_timeout: Duration,
}

impl Default for RunnerOptions {
    fn default() -> Self {
        Self {
            event_capacity: 1024,
            read_timeout: Duration::from_millis(20),
        }
    }
}

/// The application's handle on a link running in a tokio task.
#[derive(Debug)]
pub struct LinkHandle {
    ctl: mpsc::UnboundedSender<Ctl>,
    events: mpsc::Receiver<LinkEvent>,
    task: JoinHandle<Result<LinkSnapshot, DriverError>>,
}

impl std::fmt::Debug for Ctl {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Ctl")
    }
}

impl LinkHandle {
    fn send(&self, ctl: Ctl) -> Result<(), DriverError> {
        self.ctl.send(ctl).map_err(|_| DriverError::RunnerStopped)
    }

    /// Sets the wire-level command.
    ///
    /// # Errors
    /// [`DriverError::RunnerStopped`] if the task has ended.
    pub fn set_command(&self, cmd: ControlBlock) -> Result<(), DriverError> {
        self.send(Ctl::Command(cmd))
    }

    /// Sets physics-level thrust.
    ///
    /// # Errors
    /// [`DriverError::RunnerStopped`] if the task has ended.
    pub fn set_thrust(&self, thrust: PhysicsThrust) -> Result<(), DriverError> {
        self.send(Ctl::Thrust(thrust))
    }

    /// Sets the onboard autopilot targets (depth m, heading deg; `None` = off).
    ///
    /// # Errors
    /// [`DriverError::RunnerStopped`] if the task has ended.
    pub fn set_auto_targets(
        &self,
        depth_m: Option<f64>,
        heading_deg: Option<f64>,
    ) -> Result<(), DriverError> {
        self.send(Ctl::Targets(depth_m, heading_deg))
    }

    /// Arms.
    ///
    /// # Errors
    /// [`DriverError::Arm`] if refused, [`DriverError::RunnerStopped`] if the task ended.
    pub async fn arm(&self) -> Result<(), DriverError> {
        let (tx, rx) = oneshot::channel();
        self.send(Ctl::Arm(tx))?;
        rx.await
            .map_err(|_| DriverError::RunnerStopped)?
            .map_err(DriverError::from)
    }

    /// Disarms.
    ///
    /// # Errors
    /// [`DriverError::RunnerStopped`] if the task has ended.
    pub fn disarm(&self) -> Result<(), DriverError> {
        self.send(Ctl::Disarm)
    }

    /// Queues an application request.
    ///
    /// # Errors
    /// [`DriverError::RunnerStopped`] if the task has ended.
    pub async fn request(&self, request: Request) -> Result<RequestId, DriverError> {
        let (tx, rx) = oneshot::channel();
        self.send(Ctl::Request(request, tx))?;
        rx.await.map_err(|_| DriverError::RunnerStopped)
    }

    /// A snapshot of state, counters and latency.
    ///
    /// # Errors
    /// [`DriverError::RunnerStopped`] if the task has ended.
    pub async fn snapshot(&self) -> Result<LinkSnapshot, DriverError> {
        let (tx, rx) = oneshot::channel();
        self.send(Ctl::Snapshot(tx))?;
        rx.await.map_err(|_| DriverError::RunnerStopped)
    }

    /// The next event; `None` once the task has ended and the queue is empty.
    pub async fn next_event(&mut self) -> Option<LinkEvent> {
        self.events.recv().await
    }

    /// An event if one is queued.
    pub fn try_event(&mut self) -> Option<LinkEvent> {
        self.events.try_recv().ok()
    }

    /// Stops the task and returns the final snapshot.
    ///
    /// # Errors
    /// The error that ended the task, or [`DriverError::RunnerStopped`] if it panicked.
    pub async fn shutdown(self) -> Result<LinkSnapshot, DriverError> {
        let _ = self.ctl.send(Ctl::Shutdown);
        drop(self.events);
        self.task.await.map_err(|_| DriverError::RunnerStopped)?
    }
}

fn snapshot(link: &mut Link, now_us: u64, dropped: u64) -> LinkSnapshot {
    LinkSnapshot {
        time_us: now_us,
        phase: link.phase(),
        health: link.health(),
        armed: link.failsafe().is_armed(),
        alarm: link.failsafe().alarm().copied(),
        counters: link.counters(),
        rtt: link.rtt(),
        events_dropped: dropped,
    }
}

/// Spawns the link on the current tokio runtime over `transport` (a serial port, a pty
/// end, a memory pipe). Must be called from within a runtime.
///
/// A transport error ends the task with that error; the link's failsafe has already
/// made every frame after loss neutral, and reconnecting (with backoff) is the
/// station's job.
///
/// # Errors
/// [`DriverError::Transport`] if the transport cannot be split for the I/O threads.
pub fn spawn(
    mut link: Link,
    transport: Box<dyn Transport>,
    options: RunnerOptions,
) -> Result<LinkHandle, DriverError> {
    let (mut source, mut sink) = transport.split()?;
    let clock = MonoClock::new();
    let stop = Arc::new(AtomicBool::new(false));
    let (rx_tx, mut rx_rx) = mpsc::channel::<Rx>(256);
    let (wr_tx, wr_rx) = std::sync::mpsc::channel::<Vec<u8>>();
    let (ctl_tx, mut ctl_rx) = mpsc::unbounded_channel::<Ctl>();
    let (ev_tx, ev_rx) = mpsc::channel::<LinkEvent>(options.event_capacity.max(1));

    let reader_stop = Arc::clone(&stop);
    let reader_tx = rx_tx.clone();
    let read_timeout = options.read_timeout;
    std::thread::Builder::new()
        .name("rov-link-reader".into())
        .spawn(move || {
            let mut buf = vec![0u8; 4096];
            while !reader_stop.load(Ordering::Relaxed) {
                match source.recv(&mut buf, read_timeout) {
                    Ok(0) => {}
                    Ok(n) => {
                        let bytes = buf.get(..n).unwrap_or_default().to_vec();
                        if reader_tx
                            .blocking_send(Rx::Bytes(bytes, clock.now_us()))
                            .is_err()
                        {
                            break;
                        }
                    }
                    Err(e) => {
                        let _ = reader_tx.blocking_send(Rx::Failed(e));
                        break;
                    }
                }
            }
        })
        .map_err(|e| TransportError::Io {
            port: "reader thread".into(),
            source: e,
        })?;
    std::thread::Builder::new()
        .name("rov-link-writer".into())
        .spawn(move || {
            while let Ok(frame) = wr_rx.recv() {
                if let Err(e) = sink.send(&frame) {
                    let _ = rx_tx.blocking_send(Rx::Failed(e));
                    break;
                }
            }
        })
        .map_err(|e| TransportError::Io {
            port: "writer thread".into(),
            source: e,
        })?;

    let task = tokio::spawn(async move {
        let mut dropped = 0u64;
        let result = loop {
            let now = clock.now_us();
            link.handle_timeout(now);
            let mut writer_gone = false;
            while let Some(frame) = link.poll_transmit(now) {
                writer_gone |= wr_tx.send(frame.to_vec()).is_err();
            }
            if writer_gone {
                break Err(DriverError::RunnerStopped);
            }
            while let Some(ev) = link.poll_event() {
                if ev_tx.try_send(ev).is_err() {
                    dropped += 1;
                }
            }
            let deadline = link
                .next_timeout()
                .map_or(Instant::now() + Duration::from_millis(100), |t| {
                    clock.instant_at(t)
                });
            tokio::select! {
                msg = rx_rx.recv() => match msg {
                    Some(Rx::Bytes(bytes, t)) => link.handle_input(&bytes, t),
                    Some(Rx::Failed(e)) => break Err(DriverError::from(e)),
                    None => break Err(DriverError::RunnerStopped),
                },
                ctl = ctl_rx.recv() => match ctl {
                    Some(Ctl::Command(c)) => link.set_command(c),
                    Some(Ctl::Thrust(t)) => link.set_thrust(&t),
                    Some(Ctl::Targets(d, h)) => link.set_auto_targets(d, h),
                    Some(Ctl::Arm(reply)) => {
                        let _ = reply.send(link.arm(clock.now_us()));
                    }
                    Some(Ctl::Disarm) => link.disarm(),
                    Some(Ctl::Request(r, reply)) => {
                        let _ = reply.send(link.request(r));
                    }
                    Some(Ctl::Snapshot(reply)) => {
                        let _ = reply.send(snapshot(&mut link, clock.now_us(), dropped));
                    }
                    Some(Ctl::Shutdown) | None => {
                        break Ok(snapshot(&mut link, clock.now_us(), dropped));
                    }
                },
                () = tokio::time::sleep_until(deadline.into()) => {}
            }
        };
        stop.store(true, Ordering::Relaxed);
        result
    });
    Ok(LinkHandle {
        ctl: ctl_tx,
        events: ev_rx,
        task,
    })
}
