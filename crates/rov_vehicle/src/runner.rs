//! The wall-time runner: the simulated vehicle in its own thread on one end of a byte
//! transport (a pty end, a serial port, a memory pipe), paced at the baud rate.
//!
//! A pseudo-terminal delivers bytes at once, so the runner itself honours the
//! vehicle's output schedule: it sleeps until each scheduled byte time and writes what
//! is due (with ~0.1 ms granularity), and it waits for requests with a read timeout that
//! ends at the next scheduled event.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use rov_sim::TruthState;
use rov_transport::{MonoClock, Transport, TransportError};

use crate::vehicle::{Vehicle, VehicleError};

/// Settings of the runner.
#[derive(Debug, Clone, Copy)]
pub struct RunnerConfig {
    /// Longest read wait when nothing is scheduled (default 2 ms: bounds how late the
    /// physics and the watchdog run, and the shutdown time).
    pub idle_wait: Duration,
    /// Keep going when the transport reports the other end closed (a pty whose slave is
    /// reopened later, e.g. by autodetect). Default false.
    pub tolerate_hangup: bool,
}

impl Default for RunnerConfig {
    fn default() -> Self {
        Self {
            idle_wait: Duration::from_millis(2),
            tolerate_hangup: false,
        }
    }
}

/// A vehicle running in a thread.
#[derive(Debug)]
pub struct VehicleRunner {
    stop: Arc<AtomicBool>,
    join: JoinHandle<Result<Vehicle, VehicleError>>,
}

impl VehicleRunner {
    /// Stops the thread and returns the vehicle for inspection.
    ///
    /// # Errors
    /// The error that ended the thread; [`VehicleError::Transport`] if it panicked.
    pub fn stop(self) -> Result<Vehicle, VehicleError> {
        self.stop.store(true, Ordering::Relaxed);
        self.join.join().unwrap_or_else(|_| {
            Err(VehicleError::Transport(TransportError::Unsupported(
                "vehicle thread panicked".into(),
            )))
        })
    }
}

/// The latest simulator truth of a running vehicle, for a station that records it
/// (`/truth/state` of simulated sessions). The runner refreshes it whenever its
/// simulation has advanced and the lock is free; a reader never blocks the vehicle.
pub type TruthTap = Arc<Mutex<Option<TruthState>>>;

/// Faults to inject into a running vehicle's simulator (issue 23: the station's Settings
/// page). Each spec's start time counts from when the runner takes it (`@0`: at once);
/// the runner drains it whenever the lock is free, so a writer never blocks the vehicle.
pub type FaultInbox = Arc<Mutex<Vec<rov_sim::FaultSpec>>>;

/// Moves the faults waiting in `inbox` into the vehicle (start times from now on the
/// vehicle's clock). Never waits for the lock.
pub fn take_faults(vehicle: &mut Vehicle, inbox: &FaultInbox) {
    if let Ok(mut waiting) = inbox.try_lock()
        && !waiting.is_empty()
    {
        let now_s = vehicle.sim().time_s();
        for mut f in waiting.drain(..) {
            f.start_s += now_s;
            vehicle.sim_mut().add_fault(f);
        }
    }
}

/// Runs `vehicle` on `transport` in a new thread; vehicle time 0 is now.
#[must_use]
pub fn spawn(vehicle: Vehicle, transport: Box<dyn Transport>, cfg: RunnerConfig) -> VehicleRunner {
    spawn_inner(vehicle, transport, cfg, None)
}

/// [`spawn`], publishing the simulator truth to `tap` as the vehicle runs.
#[must_use]
pub fn spawn_with_truth(
    vehicle: Vehicle,
    transport: Box<dyn Transport>,
    cfg: RunnerConfig,
    tap: TruthTap,
) -> VehicleRunner {
    spawn_inner(vehicle, transport, cfg, Some(tap))
}

/// [`spawn_with_truth`], also taking faults to inject from `faults`.
#[must_use]
pub fn spawn_with_taps(
    vehicle: Vehicle,
    transport: Box<dyn Transport>,
    cfg: RunnerConfig,
    tap: TruthTap,
    faults: FaultInbox,
) -> VehicleRunner {
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    let join =
        std::thread::spawn(move || run(vehicle, transport, &flag, cfg, Some(&tap), Some(&faults)));
    VehicleRunner { stop, join }
}

fn spawn_inner(
    vehicle: Vehicle,
    transport: Box<dyn Transport>,
    cfg: RunnerConfig,
    tap: Option<TruthTap>,
) -> VehicleRunner {
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    let join = std::thread::spawn(move || run(vehicle, transport, &flag, cfg, tap.as_ref(), None));
    VehicleRunner { stop, join }
}

fn run(
    mut vehicle: Vehicle,
    mut transport: Box<dyn Transport>,
    stop: &AtomicBool,
    cfg: RunnerConfig,
    tap: Option<&TruthTap>,
    faults: Option<&FaultInbox>,
) -> Result<Vehicle, VehicleError> {
    let clock = MonoClock::new();
    let mut buf = vec![0u8; 4096];
    let mut out = Vec::with_capacity(512);
    let idle_us = u64::try_from(cfg.idle_wait.as_micros()).unwrap_or(2_000);
    let mut published_s = f64::NEG_INFINITY;
    while !stop.load(Ordering::Relaxed) {
        let now = clock.now_us();
        if let Some(inbox) = faults {
            take_faults(&mut vehicle, inbox);
        }
        vehicle.advance_to(now)?;
        if let Some(tap) = tap {
            let truth = vehicle.sim().truth();
            if truth.time_s > published_s
                && let Ok(mut slot) = tap.try_lock()
            {
                *slot = Some(*truth);
                published_s = truth.time_s;
            }
        }
        out.clear();
        if vehicle.poll_output(now, &mut out) > 0 {
            transport.send(&out)?;
        }
        // Scheduled work: the next batch of reply bytes (up to BATCH bytes, so the last
        // byte of a reply is never late by more than the wake-up precision) or the end
        // of a request. Half duplex: no input is expected meanwhile.
        let output = vehicle.output_due_nth(BATCH);
        let request = vehicle.next_request_due();
        let target = match (output, request) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
        let now = clock.now_us();
        if let Some(target) = target
            && target.saturating_sub(now) <= idle_us
        {
            sleep_until(&clock, target);
            let n = poll_input(transport.as_mut(), &mut buf, Duration::ZERO, cfg)?;
            if n > 0 {
                vehicle.handle_input(buf.get(..n).unwrap_or_default(), clock.now_us());
            }
            continue;
        }
        let wait_us = target
            .map_or(idle_us, |t| t.saturating_sub(now))
            .min(idle_us);
        let n = poll_input(
            transport.as_mut(),
            &mut buf,
            Duration::from_micros(wait_us),
            cfg,
        )?;
        if n > 0 {
            vehicle.handle_input(buf.get(..n).unwrap_or_default(), clock.now_us());
        }
    }
    Ok(vehicle)
}

/// Reply bytes written per wake-up at most (8 bytes ≈ 0.7 ms at 115200).
const BATCH: usize = 8;

/// Sleeps to `target_us`: the OS sleep for all but the last ~120 µs, then yields in a
/// loop, so timer slack does not make the final byte of a reply late.
fn sleep_until(clock: &MonoClock, target_us: u64) {
    let now = clock.now_us();
    if target_us > now + 150 {
        std::thread::sleep(Duration::from_micros(target_us - now - 120));
    }
    while clock.now_us() < target_us {
        std::thread::yield_now();
    }
}

fn poll_input(
    transport: &mut dyn Transport,
    buf: &mut [u8],
    wait: Duration,
    cfg: RunnerConfig,
) -> Result<usize, VehicleError> {
    match transport.recv(buf, wait) {
        Ok(n) => Ok(n),
        Err(e) if cfg.tolerate_hangup => {
            let _ = e;
            std::thread::sleep(wait.max(Duration::from_millis(1)));
            Ok(0)
        }
        Err(e) => Err(e.into()),
    }
}
