//! The wall-clock driver of the live host: control, rx, tx and watchdog threads (see
//! the parent module docs).

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::sync::mpsc::{Receiver, RecvTimeoutError, SyncSender, TryRecvError, sync_channel};
use std::time::Duration;

use firmware_proto::{ControlBlock, NodeId, flags};
use rov_control::ModelSet;
use rov_driver::{
    ByteSink, ByteSource, Link, MonoClock, PRO4_BAUD, SerialTransport, Transport, memory_pair,
};
use rov_vehicle::runner::TruthTap;
use rov_vehicle::{RunnerConfig, VehicleRunner};

use crate::pilot::view::Source;
use crate::runtime::host::{Followup, Host};
use crate::runtime::priority::{RT_CONTROL, RT_LINK, RT_WATCHDOG};
use crate::runtime::{
    Connection, RuntimeCommand, RuntimeConfig, RuntimeError, Shared, StationHandle,
    command_channel, lock, spawn_named, spawn_raised,
};

/// Byte chunks queued from the rx thread to the control thread.
const RX_CAPACITY: usize = 1024;
/// Frames queued to the tx thread.
const TX_CAPACITY: usize = 64;
/// The control thread wakes this early for a tick and spins the rest, µs.
const SPIN_US: u64 = 1_000;

// The large variant is the common one; boxing it would allocate for every chunk.
#[allow(clippy::large_enum_variant)]
pub(crate) enum Rx {
    Bytes(Chunk, u64),
    Failed(String),
    /// Serial port lost, re-connection progress, reconnected (see `reconnect`).
    Port(crate::runtime::reconnect::PortEvent),
}

/// Bytes in a fixed buffer: what moves between the I/O threads and the control thread
/// without touching the allocator (a received chunk, or one frame to send: the longest
/// Pro 4 frame is 7 + 255 + 1 bytes).
#[derive(Clone, Copy)]
pub(crate) struct Chunk {
    len: usize,
    buf: [u8; CHUNK],
}

/// Capacity of a [`Chunk`], bytes.
const CHUNK: usize = 272;

impl Chunk {
    /// Up to [`CHUNK`] bytes of `b` (the rest is the caller's).
    fn from_slice(b: &[u8]) -> Self {
        let mut c = Self {
            len: b.len().min(CHUNK),
            buf: [0; CHUNK],
        };
        if let (Some(dst), Some(src)) = (c.buf.get_mut(..c.len), b.get(..c.len)) {
            dst.copy_from_slice(src);
        }
        c
    }

    /// The bytes.
    pub(crate) fn bytes(&self) -> &[u8] {
        self.buf.get(..self.len).unwrap_or_default()
    }
}

pub(crate) fn start(cfg: RuntimeConfig, models: ModelSet) -> Result<StationHandle, RuntimeError> {
    let period_us = cfg.period_us();
    let clock = MonoClock::new();
    let shared = Arc::new(Shared::new(period_us, clock));
    let (cmd_tx, cmd_rx) = command_channel();
    let mut link_cfg = cfg.link;
    // Raw frames are recorded only while a recording runs (the host switches them).
    link_cfg.record_frames = false;
    let link = Link::new(link_cfg)?;
    let node = link.config().node;

    // Transport (and the simulated vehicle on the other end in sim mode).
    let mut truth_tap: Option<TruthTap> = None;
    let mut fault_inbox: Option<rov_vehicle::runner::FaultInbox> = None;
    let (transport, source, vehicle): (Box<dyn Transport>, Source, Option<VehicleRunner>) =
        match &cfg.connection {
            Connection::Sim => {
                let (station_end, vehicle_end) = memory_pair();
                let vehicle = crate::runtime::sim::sim_vehicle(&cfg)?;
                let tap = TruthTap::default();
                let inbox = rov_vehicle::runner::FaultInbox::default();
                fault_inbox = Some(std::sync::Arc::clone(&inbox));
                // The simulated vehicle stands for hardware at the other end of the
                // tether: its thread gets the link threads' priority (a thread inherits
                // its creator's scheduling, so it is created from a raised helper), or a
                // busy GUI would delay its replies and fake a poor link.
                let t = Arc::clone(&tap);
                let (back, runner_rx) = std::sync::mpsc::channel();
                let helper = spawn_named("station-vehicle-spawn", {
                    let shared = Arc::clone(&shared);
                    move || {
                        let g = crate::runtime::priority::raise_current(RT_LINK);
                        lock(&shared.priorities).push(("station-vehicle (sim)".into(), g));
                        let runner = rov_vehicle::runner::spawn_with_taps(
                            vehicle,
                            Box::new(vehicle_end),
                            RunnerConfig::default(),
                            t,
                            inbox,
                        );
                        // The receiver waits below (after the join): it cannot have hung up.
                        let _ = back.send(runner);
                    }
                })?;
                // A helper that panicked sent nothing: the `recv` below says so.
                let _ = helper.join();
                let runner = runner_rx
                    .recv()
                    .map_err(|_| RuntimeError::VehicleDidNotStart)?;
                truth_tap = Some(tap);
                (Box::new(station_end), Source::Sim, Some(runner))
            }
            Connection::Serial(path) => {
                let port = SerialTransport::open(path, PRO4_BAUD)?;
                (Box::new(port), Source::Serial(path.clone()), None)
            }
        };
    let (source_half, sink_half) = transport.split()?;
    let mut host = Host::new(cfg.clone(), models, Arc::clone(&shared), source)?;
    // The camera on threads of its own (see `video`); the sim camera follows the truth
    // and the lights and tilt of the last control frame sent.
    let video = Arc::new(crate::runtime::video::StationVideo::start_live(
        &cfg.video,
        &cfg.connection,
        {
            let clock = shared.clock;
            move || clock.now_us().saturating_mul(1000)
        },
        truth_tap
            .clone()
            .map(|tap| sim_pose(tap, Arc::clone(&shared))),
    ));
    host.attach_video(Arc::clone(&video));
    if let Some(inbox) = fault_inbox {
        host.attach_fault_inbox(inbox);
    }
    if let Some(tap) = truth_tap {
        host.attach_truth_tap(tap);
    }

    let (rx_tx, rx_rx) = sync_channel::<Rx>(RX_CAPACITY);
    let (tx_tx, tx_rx) = sync_channel::<Chunk>(TX_CAPACITY);
    // A serial port that vanishes is looked for again (see `reconnect`).
    let (source_half, sink_half) = crate::runtime::reconnect::wrap(
        &cfg,
        node,
        (source_half, sink_half),
        &rx_tx,
        &shared,
        &mut host,
    )?;
    let mut threads = Vec::new();
    {
        let shared = Arc::clone(&shared);
        threads.push(spawn_raised(
            "station-rx",
            RT_LINK,
            &shared.clone(),
            move || {
                rx_loop(source_half, &rx_tx, &shared);
            },
        )?);
    }
    {
        let shared = Arc::clone(&shared);
        threads.push(spawn_raised(
            "station-tx",
            RT_LINK,
            &shared.clone(),
            move || {
                tx_loop(sink_half, &tx_rx, &shared);
            },
        )?);
    }
    {
        let shared = Arc::clone(&shared);
        let tx = tx_tx.clone();
        threads.push(spawn_raised(
            "station-watchdog",
            RT_WATCHDOG,
            &shared.clone(),
            move || {
                watchdog_loop(&shared, &tx, node, period_us);
            },
        )?);
    }
    #[cfg(feature = "gamepad")]
    if cfg.gamepad {
        let shared = Arc::clone(&shared);
        threads.push(spawn_named("station-gamepad", move || {
            crate::runtime::gamepad::run(&shared);
        })?);
    }
    {
        let shared = Arc::clone(&shared);
        threads.push(spawn_raised(
            "station-control",
            RT_CONTROL,
            &shared.clone(),
            move || {
                control_loop(host, link, &rx_rx, &tx_tx, &cmd_rx, &shared, period_us);
                shared.running.store(false, Ordering::Relaxed);
                if let Some(v) = vehicle
                    && let Err(e) = v.stop()
                {
                    tracing::warn!("the simulated vehicle stopped with an error: {e}");
                }
            },
        )?);
    }
    Ok(StationHandle::new(shared, cmd_tx, threads).with_video(video))
}

/// The simulator camera's pose and lights: the vehicle thread's latest truth, the
/// camera tilt and lights of the last control frame sent (never waits for the control
/// thread; the truth lock is held for a copy).
fn sim_pose(tap: TruthTap, shared: Arc<Shared>) -> crate::runtime::video::PoseSource {
    Box::new(move || {
        let truth = (*tap.lock().ok()?)?;
        let sent = watchdog_block(shared.watchdog_kept.load(Ordering::Relaxed));
        Some((
            crate::runtime::video::pose_of_truth(&truth, f64::from(sent.tilt_deg)),
            f64::from(sent.lights_pct),
        ))
    })
}

fn rx_loop(mut source: Box<dyn ByteSource>, out: &SyncSender<Rx>, shared: &Shared) {
    let mut buf = vec![0u8; 4096];
    while shared.running.load(Ordering::Relaxed) {
        match source.recv(&mut buf, Duration::from_millis(20)) {
            Ok(0) => {}
            Ok(n) => {
                let t = shared.clock.now_us();
                // A full queue means the control thread is stalled; wait for it rather
                // than lose bytes (the watchdog covers the stall).
                for part in buf.get(..n).unwrap_or_default().chunks(CHUNK) {
                    if out.send(Rx::Bytes(Chunk::from_slice(part), t)).is_err() {
                        return;
                    }
                }
            }
            Err(e) => {
                // The control thread has stopped if this fails (shutdown).
                let _ = out.send(Rx::Failed(e.to_string()));
                return;
            }
        }
    }
}

fn tx_loop(mut sink: Box<dyn ByteSink>, input: &Receiver<Chunk>, shared: &Shared) {
    while shared.running.load(Ordering::Relaxed) {
        match input.recv_timeout(Duration::from_millis(50)) {
            Ok(frame) => {
                if sink.send(frame.bytes()).is_err() {
                    return;
                }
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => return,
        }
    }
}

/// G2: no tick completed within three periods → neutral frames every period until the
/// ticks resume.
/// What the watchdog keeps of the last control frame sent, packed for an atomic: lights,
/// camera tilt, focus and camera control, plus a "valid" bit. A stalled station zeroes
/// thrust and both autopilots but must not switch the lights off or move the camera: the
/// pilot needs the picture to recover.
pub(crate) fn pack_kept(cmd: &ControlBlock) -> u64 {
    (1 << 32)
        | u64::from(cmd.lights_pct)
        | u64::from(cmd.tilt_deg.to_ne_bytes()[0]) << 8
        | u64::from(cmd.focus_pct.to_ne_bytes()[0]) << 16
        | u64::from(cmd.camera_control) << 24
}

/// The watchdog's neutral command: [`ControlBlock::ALL_STOP`] with the kept lights and
/// camera (none kept yet: all stop).
pub(crate) fn watchdog_block(kept: u64) -> ControlBlock {
    if kept >> 32 == 0 {
        return ControlBlock::ALL_STOP;
    }
    let [lights, tilt, focus, camera, ..] = kept.to_le_bytes();
    ControlBlock {
        lights_pct: lights,
        tilt_deg: i8::from_ne_bytes([tilt]),
        focus_pct: i8::from_ne_bytes([focus]),
        camera_control: camera,
        ..ControlBlock::ALL_STOP
    }
}

/// The encoded watchdog frame for the kept camera state.
pub(crate) fn watchdog_frame(kept: u64, node: NodeId) -> Chunk {
    let mut frame = [0u8; 32];
    let n = watchdog_block(kept)
        .encode_request(node, flags::NONE, &mut frame)
        .unwrap_or(0);
    Chunk::from_slice(frame.get(..n).unwrap_or_default())
}

fn watchdog_loop(shared: &Shared, tx: &SyncSender<Chunk>, node: NodeId, period_us: u64) {
    let poll = Duration::from_micros((period_us / 4).max(500));
    let mut tripped = false;
    let mut last_sent = 0u64;
    while shared.running.load(Ordering::Relaxed) {
        std::thread::sleep(poll);
        let last = shared.last_tick_us.load(Ordering::Relaxed);
        if last == 0 {
            continue; // not started yet
        }
        let now = shared.clock.now_us();
        if now.saturating_sub(last) > 3 * period_us {
            if !tripped {
                tripped = true;
                shared.watchdog_trips.fetch_add(1, Ordering::Relaxed);
                last_sent = 0;
            }
            if now.saturating_sub(last_sent) >= period_us
                && tx
                    .try_send(watchdog_frame(
                        shared.watchdog_kept.load(Ordering::Relaxed),
                        node,
                    ))
                    .is_ok()
            {
                if last_sent == 0 {
                    shared
                        .watchdog_max_gap_us
                        .fetch_max(now.saturating_sub(last), Ordering::Relaxed);
                }
                shared.watchdog_frames.fetch_add(1, Ordering::Relaxed);
                last_sent = now;
            }
        } else {
            tripped = false;
        }
    }
}

fn control_loop(
    mut host: Host,
    mut link: Link,
    rx: &Receiver<Rx>,
    tx: &SyncSender<Chunk>,
    cmds: &Receiver<RuntimeCommand>,
    shared: &Shared,
    period_us: u64,
) {
    let clock = shared.clock;
    let mut next_tick = clock.now_us();
    let mut transport_error: Option<String> = None;
    loop {
        let stop = measured(shared, || {
            // Wait for bytes or the next deadline. The control tick's wake-up is asked for
            // SPIN_US early and the rest is spun, so scheduler wake-up latency does not make
            // the tick late.
            let now = clock.now_us();
            let link_due = link.next_timeout().unwrap_or(u64::MAX);
            let due = link_due.min(next_tick.saturating_sub(SPIN_US));
            if due > now {
                match rx.recv_timeout(Duration::from_micros(due - now)) {
                    Ok(Rx::Bytes(b, t)) => link.handle_input(b.bytes(), t),
                    Ok(Rx::Failed(e)) => transport_error = Some(e),
                    Ok(Rx::Port(ev)) => host.on_port_event(ev, &mut link, clock.now_us()),
                    Err(RecvTimeoutError::Timeout) => {}
                    Err(RecvTimeoutError::Disconnected) => {
                        transport_error.get_or_insert_with(|| "transport closed".into());
                    }
                }
            }
            loop {
                match rx.try_recv() {
                    Ok(Rx::Bytes(b, t)) => link.handle_input(b.bytes(), t),
                    Ok(Rx::Failed(e)) => transport_error = Some(e),
                    Ok(Rx::Port(ev)) => host.on_port_event(ev, &mut link, clock.now_us()),
                    Err(TryRecvError::Empty | TryRecvError::Disconnected) => break,
                }
            }
            if let Some(e) = transport_error.take() {
                let now = clock.now_us();
                let line = format!("{:7.1} s  ALARM: transport failed: {e}", now as f64 * 1e-6);
                host.note(&mut link, line, now);
            }
            let now = clock.now_us();
            link.handle_timeout(now);
            pump(&mut host, &mut link, tx, now);

            // Commands.
            let mut stop = false;
            loop {
                match cmds.try_recv() {
                    Ok(c) => match timed(clock, period_us, c.name(), || {
                        host.apply(&mut link, c, clock.now_us())
                    }) {
                        Followup::None => {}
                        Followup::Shutdown => stop = true,
                        Followup::Stall(d) => std::thread::sleep(d),
                    },
                    Err(TryRecvError::Empty) => break,
                    Err(TryRecvError::Disconnected) => {
                        stop = true;
                        break;
                    }
                }
            }
            if stop || !shared.running.load(Ordering::Relaxed) {
                return true;
            }

            // The control tick, on its deadline.
            let mut now = clock.now_us();
            if now < next_tick && next_tick - now <= SPIN_US {
                while now < next_tick {
                    std::hint::spin_loop();
                    now = clock.now_us();
                }
            }
            if now >= next_tick {
                timed(clock, period_us, "the control tick", || {
                    host.tick(&mut link, now)
                });
                host.publish_port(now);
                pump(&mut host, &mut link, tx, now);
                host.record_tapped_truth(&mut link, now);
                let stats = {
                    let mut t = lock(&shared.ticks);
                    t.record(next_tick, now);
                    next_tick += period_us;
                    if now >= next_tick {
                        // More than a period late: skip the lost deadlines (counted as
                        // missed: they never start) and keep the grid t0 + k·P.
                        let behind = (now - next_tick) / period_us + 1;
                        t.add_missed(behind);
                        next_tick += behind * period_us;
                    }
                    t.set_watchdog(
                        shared.watchdog_trips.load(Ordering::Relaxed),
                        shared.watchdog_frames.load(Ordering::Relaxed),
                        shared.watchdog_max_gap_us.load(Ordering::Relaxed),
                    );
                    t.stats()
                };
                if let Some((_, sent)) = link.last_control_sent() {
                    shared
                        .watchdog_kept
                        .store(pack_kept(&sent), Ordering::Relaxed);
                }
                shared.last_tick_us.store(clock.now_us(), Ordering::Relaxed);
                host.publish(Some(stats));
            }
            false
        });
        if stop {
            break;
        }
    }
    // Neutral on the way out, then finish the recording.
    link.disarm();
    let now = clock.now_us();
    if let Some(f) = link.poll_transmit(now) {
        // Best effort on the way out: the vehicle's own timeout stops it anyway.
        let _ = tx.try_send(Chunk::from_slice(f));
    }
    host.finish(&mut link, now);
    host.publish(None);
}

/// Runs one wake-up of the control thread. In this crate's tests it also counts the
/// heap allocations the wake-up made (allocation-counter, per thread), for the
/// steady-state test: control and link work stay off the allocator.
#[cfg(test)]
fn measured(shared: &Shared, f: impl FnOnce() -> bool) -> bool {
    let mut stop = false;
    let info = allocation_counter::measure(|| stop = f());
    shared
        .test_allocations
        .fetch_add(info.count_total, Ordering::Relaxed);
    shared.test_wakeups.fetch_add(1, Ordering::Relaxed);
    stop
}

#[cfg(not(test))]
fn measured(_shared: &Shared, f: impl FnOnce() -> bool) -> bool {
    f()
}

/// Runs `f` on the control thread and says (a warning naming `what`) when it took longer
/// than a control period: whatever holds up the control loop is named in the log.
fn timed<T>(clock: MonoClock, period_us: u64, what: &str, f: impl FnOnce() -> T) -> T {
    let t0 = clock.now_us();
    let out = f();
    let took_us = clock.now_us().saturating_sub(t0);
    if took_us > period_us {
        tracing::warn!(
            "control thread: {what} took {:.1} ms (a control period is {:.1} ms)",
            took_us as f64 * 1e-3,
            period_us as f64 * 1e-3
        );
    }
    out
}

/// Hands due frames to the tx thread and feeds the link's events to the host.
fn pump(host: &mut Host, link: &mut Link, tx: &SyncSender<Chunk>, now: u64) {
    while let Some(frame) = link.poll_transmit(now) {
        // The tx queue holds 64 frames; a full queue means the port is stuck.
        let _ = tx.try_send(Chunk::from_slice(frame));
    }
    while let Some(ev) = link.poll_event() {
        host.on_event(link, &ev, now);
    }
}
