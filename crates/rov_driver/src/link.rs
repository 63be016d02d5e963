//! The sans-IO link state machine: one request in flight on the half-duplex line.
//!
//! # Driving it
//!
//! ```text
//! loop {
//!     now = clock();
//!     link.handle_input(&received_bytes, now);   // whenever bytes arrive
//!     link.handle_timeout(now);                  // whenever next_timeout() has passed
//!     while let Some(frame) = link.poll_transmit(now) { transport.send(frame) }
//!     while let Some(event) = link.poll_event() { ... }
//!     sleep until link.next_timeout() or input arrives
//! }
//! ```
//!
//! Time is an argument (`now_us`, microseconds of any monotonic clock); the link never
//! reads a clock, never blocks and does no I/O, so the same code runs on a serial port,
//! a pty, an in-memory pipe and virtual time.
//!
//! # Behaviour (protocol.md §12.2, style B1/B2)
//!
//! * **SEARCHING**: a probe every `search_period_us` (250 ms). Before the first
//!   connection the probe is the ping (M1); after a loss it is a **neutral** control
//!   write with the navigation request (M2 with zero thrust, autopilots off), so the
//!   first thing a returning vehicle hears is "stop". A matching response → INIT (or
//!   RUNNING if INIT reads are off).
//! * **INIT**: the full register dump (M4) and optionally the config read, each retried
//!   `init_retries` times, then back to SEARCHING.
//! * **RUNNING**: the control block (gated by the [`Failsafe`]) with FLAGS 0x05 every
//!   `cycle_period_us`; after every `status_every`-th control exchange, one status-block
//!   read as an extra exchange; queued application requests go between cycles.
//! * Before each request the input is flushed. A response must match node, FLAGS
//!   (echoed, or ≥ 0x80 for reads), address, device type and length; anything else is
//!   counted as unexpected and the link keeps waiting until the timeout.
//! * Health: `degraded_after_failures` consecutive failures → Degraded; no valid
//!   response for `loss_timeout_us` → Lost: the exchange in flight is abandoned, the
//!   failsafe disarms and latches its alarm, the phase goes back to SEARCHING, and a
//!   neutral control frame is sent at once.
//! * The port vanished ([`Link::on_port_lost`], told by the I/O side when a read or
//!   write fails with [`TransportError::port_gone`](crate::TransportError::port_gone)):
//!   lost at once, without waiting for T_loss; the exchange in flight fails as
//!   [`FailCause::PortGone`]; nothing is sent until [`Link::on_port_opened`], after
//!   which the first frame is a neutral probe, sent at once. The failsafe stays latched:
//!   a re-opened port never re-arms.

use std::collections::VecDeque;

use firmware_proto::{
    ConfigData, ControlBlock, CsrRead, DeframeErrorKind, Deframer, DeframerConfig, Event, Frame,
    NavReply, Reboot, StatusBlock, csr, encode_request, flags,
};
use rov_types::conventions::PhysicsThrust;

use crate::config::LinkConfig;
use crate::error::{ArmError, ConfigError};
use crate::failsafe::{Failsafe, is_neutral};
use crate::stats::{FailCause, LinkCounters, RttStats, RttSummary};
use crate::telemetry::{
    ExchangeKind, Health, LinkEvent, Phase, Request, RequestId, RequestOutcome, StatusTelemetry,
    Telemetry,
};

/// What a matching response must look like.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Expect {
    /// Request FLAGS: echoed for device-specific requests; any ≥ 0x80 for reads.
    flags: u8,
    addr: u8,
    /// Exact payload length (type byte included), or any non-empty.
    payload_len: Option<usize>,
}

#[derive(Debug, Clone, Copy)]
struct InFlight {
    kind: ExchangeKind,
    sent_us: u64,
    deadline_us: u64,
    expect: Expect,
    /// The most specific failure seen so far.
    seen: Option<FailCause>,
    saw_bytes: bool,
}

/// A decoded matching response.
#[derive(Debug)]
enum Reply {
    Nav(NavReply),
    Ping,
    Status(StatusBlock),
    Registers { start: u8, data: Vec<u8> },
    Config(Box<ConfigData>),
}

#[derive(Debug)]
enum RxItem {
    Match {
        reply: Reply,
        bytes: Option<Vec<u8>>,
    },
    Unexpected {
        bytes: Option<Vec<u8>>,
    },
    Error(firmware_proto::DeframeError),
}

#[derive(Debug, Clone)]
struct Queued {
    id: RequestId,
    request: Request,
    attempts: u32,
}

/// The link state machine. See the [module documentation](self).
#[derive(Debug)]
pub struct Link {
    cfg: LinkConfig,
    rx: Deframer,
    last_rx_us: u64,
    rx_items: Vec<RxItem>,
    tx: Vec<u8>,
    phase: Phase,
    health: Health,
    ever_connected: bool,
    inflight: Option<InFlight>,
    /// SEARCHING / INIT: when the next probe or read may go.
    next_probe_us: u64,
    /// RUNNING: when the next control frame is due.
    next_cycle_us: u64,
    cycles: u64,
    status_due: bool,
    init_step: usize,
    init_attempts: u32,
    queue: VecDeque<Queued>,
    next_request_id: u64,
    command: ControlBlock,
    failsafe: Failsafe,
    last_valid_us: Option<u64>,
    consecutive_failures: u32,
    last_control_sent: Option<(u64, ControlBlock)>,
    events: VecDeque<LinkEvent>,
    counters: LinkCounters,
    rtt: RttStats,
    /// False between [`Link::on_port_lost`] and [`Link::on_port_opened`].
    port_open: bool,
}

fn fail_cause_of(kind: DeframeErrorKind) -> FailCause {
    match kind {
        DeframeErrorKind::HeaderCheck => FailCause::HeaderCheck,
        DeframeErrorKind::ExtLengthCheck | DeframeErrorKind::Overlong => FailCause::ExtLength,
        DeframeErrorKind::TotalCheck => FailCause::TotalCheck,
        DeframeErrorKind::Stall | DeframeErrorKind::Truncated => FailCause::Stall,
        DeframeErrorKind::WrongDirection => FailCause::Unexpected,
        _ => FailCause::Sync,
    }
}

fn worse(a: Option<FailCause>, b: FailCause) -> FailCause {
    match a {
        Some(a) if a.rank() >= b.rank() => a,
        _ => b,
    }
}

/// Checks a frame against the request in flight and decodes it.
fn match_frame(frame: &Frame<'_>, inflight: &InFlight, cfg: &LinkConfig) -> Option<Reply> {
    let e = &inflight.expect;
    let flags_ok = if e.flags >= flags::DUMP {
        frame.flags() >= flags::DUMP
    } else {
        frame.flags() == e.flags
    };
    let type_ok = match cfg.device_type {
        Some(t) => frame.device_type() == Some(t),
        None => frame.payload_len() >= 1,
    };
    let len_ok = e.payload_len.is_none_or(|n| frame.payload_len() == n);
    if frame.node() != cfg.node || !flags_ok || frame.addr() != e.addr || !type_ok || !len_ok {
        return None;
    }
    match inflight.kind {
        ExchangeKind::Ping => Some(Reply::Ping),
        ExchangeKind::Control { .. } => NavReply::from_frame(frame).ok().map(Reply::Nav),
        ExchangeKind::Status => StatusBlock::from_frame(frame).ok().map(Reply::Status),
        ExchangeKind::InitConfig => ConfigData::from_frame(frame)
            .ok()
            .map(|c| Reply::Config(Box::new(c))),
        ExchangeKind::InitDump | ExchangeKind::Request(_) => {
            if e.addr == csr::CONFIG_DATA && e.flags == flags::DUMP {
                ConfigData::from_frame(frame)
                    .ok()
                    .map(|c| Reply::Config(Box::new(c)))
            } else {
                Some(Reply::Registers {
                    start: frame.addr(),
                    data: frame.data().to_vec(),
                })
            }
        }
    }
}

impl Link {
    /// A link in SEARCHING, health Lost (nothing heard yet), failsafe disarmed.
    ///
    /// # Errors
    /// [`ConfigError`] if a setting is out of range.
    pub fn new(cfg: LinkConfig) -> Result<Self, ConfigError> {
        cfg.validate()?;
        Ok(Self {
            rx: Deframer::new(DeframerConfig::host().with_gap_us(cfg.deframer_gap_us)),
            last_rx_us: 0,
            rx_items: Vec::new(),
            tx: Vec::with_capacity(160),
            phase: Phase::Searching,
            health: Health::Lost,
            ever_connected: false,
            inflight: None,
            next_probe_us: 0,
            next_cycle_us: 0,
            cycles: 0,
            status_due: false,
            init_step: 0,
            init_attempts: 0,
            queue: VecDeque::new(),
            next_request_id: 1,
            command: ControlBlock::ALL_STOP,
            failsafe: Failsafe::new(cfg.arm_min_healthy_us),
            last_valid_us: None,
            consecutive_failures: 0,
            last_control_sent: None,
            events: VecDeque::new(),
            counters: LinkCounters::default(),
            rtt: RttStats::new(cfg.rtt_window),
            port_open: true,
            cfg,
        })
    }

    // ---- application side ---------------------------------------------------------

    /// The configuration.
    #[must_use]
    pub const fn config(&self) -> &LinkConfig {
        &self.cfg
    }

    /// Switches the raw-frame events ([`LinkEvent::FrameTx`], [`LinkEvent::FrameRx`]) on
    /// or off (the station records frames only while a recording runs: each event holds
    /// a copy of the frame).
    pub fn set_record_frames(&mut self, on: bool) {
        self.cfg.record_frames = on;
    }

    /// Sets the command (wire level) sent from the next cycle on; the failsafe still
    /// gates it.
    pub fn set_command(&mut self, cmd: ControlBlock) {
        self.command = cmd;
    }

    /// Sets the thrust from physics-level percentages (positive vertical pushes down),
    /// converted with the configured [`WireConventions`](rov_types::conventions::WireConventions);
    /// the other fields of the command are kept.
    pub fn set_thrust(&mut self, thrust: &PhysicsThrust) {
        let [port, starboard, vertical] = self.cfg.conventions.thrust_to_wire(thrust);
        self.command.port_pct = port;
        self.command.starboard_pct = starboard;
        self.command.vertical_pct = vertical;
    }

    /// Sets the onboard autopilot targets from physics values (depth in m, heading in
    /// degrees); `None` turns an autopilot off.
    pub fn set_auto_targets(&mut self, depth_m: Option<f64>, heading_deg: Option<f64>) {
        let c = &self.cfg.conventions;
        self.command.depth_target_mbar = depth_m.and_then(|d| c.depth_target_mbar(d));
        self.command.heading_target_deg = heading_deg.and_then(|h| c.heading_target_deg(h));
    }

    /// Sets the surface-pressure tare used for depth (e.g. from a reading at the
    /// surface).
    pub fn set_surface_pressure_mbar(&mut self, mbar: f64) {
        if mbar.is_finite() {
            self.cfg.conventions.surface_pressure_mbar = mbar;
        }
    }

    /// The command as set by the application (before gating).
    #[must_use]
    pub const fn command(&self) -> &ControlBlock {
        &self.command
    }

    /// The last control frame sent: (time, block on the wire).
    #[must_use]
    pub const fn last_control_sent(&self) -> Option<(u64, ControlBlock)> {
        self.last_control_sent
    }

    /// Arms: thrust passes through from the next frame on. Clears a latched alarm.
    ///
    /// # Errors
    /// [`ArmError`] if the link is not connected or not yet healthy long enough.
    pub fn arm(&mut self, now_us: u64) -> Result<(), ArmError> {
        let alarm = self.failsafe.alarm().map(|a| a.alarm);
        self.failsafe.arm(now_us)?;
        if let Some(alarm) = alarm {
            self.push_event(LinkEvent::AlarmCleared {
                time_us: now_us,
                alarm,
            });
        }
        Ok(())
    }

    /// Disarms: neutral thrust from the next frame on.
    pub fn disarm(&mut self) {
        self.failsafe.disarm();
    }

    /// The failsafe (arming state and latched alarm).
    #[must_use]
    pub const fn failsafe(&self) -> &Failsafe {
        &self.failsafe
    }

    /// Queues an application request; it goes between control cycles in RUNNING.
    pub fn request(&mut self, request: Request) -> RequestId {
        let id = RequestId(self.next_request_id);
        self.next_request_id += 1;
        self.queue.push_back(Queued {
            id,
            request,
            attempts: 0,
        });
        id
    }

    /// The phase.
    #[must_use]
    pub const fn phase(&self) -> Phase {
        self.phase
    }

    /// The health.
    #[must_use]
    pub const fn health(&self) -> Health {
        self.health
    }

    /// Time of the last valid matching response, µs.
    #[must_use]
    pub const fn last_valid_response_us(&self) -> Option<u64> {
        self.last_valid_us
    }

    /// Whether a request is waiting for its response.
    #[must_use]
    pub const fn in_flight(&self) -> bool {
        self.inflight.is_some()
    }

    /// Whether the port is open (false between [`Link::on_port_lost`] and
    /// [`Link::on_port_opened`]).
    #[must_use]
    pub const fn port_open(&self) -> bool {
        self.port_open
    }

    /// The port vanished at `now_us` (an unplugged adapter, a closed pty): the link is
    /// lost at once (the failsafe disarms and latches, as after T_loss), the exchange in
    /// flight fails as [`FailCause::PortGone`], partial input is dropped, and nothing is
    /// sent until [`Link::on_port_opened`]. A second call before that does nothing.
    pub fn on_port_lost(&mut self, now_us: u64) {
        if !self.port_open {
            return;
        }
        self.port_open = false;
        self.counters.port_losses += 1;
        self.counters.flushed_bytes += self.rx.reset() as u64;
        if let Some(f) = self.inflight.take() {
            self.fail(f.kind, FailCause::PortGone, now_us);
        }
        if self.health != Health::Lost {
            self.lose(now_us);
        } else {
            // Searching or never connected: stay lost, but restart any INIT sequence.
            self.failsafe.disarm();
            if self.phase != Phase::Searching {
                self.phase = Phase::Searching;
                self.state_changed(now_us);
            }
        }
    }

    /// A port is open again at `now_us` (the same device or another one the vehicle
    /// answered on): the link probes at once with a neutral control write (or the ping
    /// if it never connected) and connects as usual. The failsafe stays disarmed and its
    /// alarm latched until the pilot re-arms.
    pub fn on_port_opened(&mut self, now_us: u64) {
        if self.port_open {
            return;
        }
        self.port_open = true;
        self.counters.flushed_bytes += self.rx.reset() as u64;
        self.next_probe_us = now_us;
    }

    /// The counters (deframer counters included).
    #[must_use]
    pub fn counters(&self) -> LinkCounters {
        LinkCounters {
            deframer: *self.rx.counters(),
            ..self.counters
        }
    }

    /// Round-trip statistics over the window.
    pub fn rtt(&mut self) -> RttSummary {
        self.rtt.summary()
    }

    /// The next event, oldest first.
    pub fn poll_event(&mut self) -> Option<LinkEvent> {
        self.events.pop_front()
    }

    // ---- I/O side ---------------------------------------------------------------------

    /// Bytes received at `now_us` (any chunking).
    pub fn handle_input(&mut self, bytes: &[u8], now_us: u64) {
        if bytes.is_empty() || !self.port_open {
            return;
        }
        if let Some(f) = self.inflight.as_mut() {
            f.saw_bytes = true;
        }
        self.last_rx_us = now_us;
        self.deframe(bytes, now_us);
        self.update(now_us);
    }

    /// Lets time pass: response timeouts, link loss, stalled partial frames.
    pub fn handle_timeout(&mut self, now_us: u64) {
        self.update(now_us);
    }

    /// When [`Link::handle_timeout`] / [`Link::poll_transmit`] next has work, µs (may be
    /// in the past: then at once).
    #[must_use]
    pub fn next_timeout(&self) -> Option<u64> {
        if !self.port_open {
            // Nothing to send and nothing to receive until the port is back.
            return None;
        }
        let mut t: Option<u64> = None;
        let mut min = |x: u64| t = Some(t.map_or(x, |t| t.min(x)));
        match &self.inflight {
            Some(f) => min(f.deadline_us),
            None => match self.phase {
                Phase::Searching | Phase::Init => min(self.next_probe_us),
                Phase::Running => {
                    if self.extra_pending() {
                        min(self.next_probe_us);
                    } else {
                        min(self.next_cycle_us);
                    }
                }
            },
        }
        if self.health != Health::Lost
            && let Some(last) = self.last_valid_us
        {
            min(last.saturating_add(self.cfg.loss_timeout_us));
        }
        if self.rx.buffered_len() > 0 {
            min(self.last_rx_us + self.cfg.deframer_gap_us + 1);
        }
        t
    }

    /// The next frame to send at `now_us`, if one is due; the caller writes it to the
    /// transport. Returns `None` while a request is in flight or the port is closed.
    pub fn poll_transmit(&mut self, now_us: u64) -> Option<&[u8]> {
        self.update(now_us);
        if self.inflight.is_some() || !self.port_open {
            return None;
        }
        let (kind, timeout_us, expect, len) = self.build_next(now_us)?;
        self.counters.flushed_bytes += self.rx.reset() as u64;
        self.counters.requests += 1;
        if let Some(expect) = expect {
            self.inflight = Some(InFlight {
                kind,
                sent_us: now_us,
                deadline_us: now_us + timeout_us,
                expect,
                seen: None,
                saw_bytes: false,
            });
        }
        if self.cfg.record_frames {
            let bytes = self.tx.get(..len).unwrap_or_default().to_vec();
            self.push_event(LinkEvent::FrameTx {
                time_us: now_us,
                bytes,
            });
        }
        self.tx.get(..len)
    }

    // ---- internals ----------------------------------------------------------------------

    fn extra_pending(&self) -> bool {
        self.status_due || !self.queue.is_empty()
    }

    fn push_event(&mut self, event: LinkEvent) {
        if self.events.len() >= self.cfg.event_capacity {
            self.events.pop_front();
            self.counters.events_dropped += 1;
        }
        self.events.push_back(event);
    }

    fn state_changed(&mut self, now_us: u64) {
        self.push_event(LinkEvent::StateChanged {
            time_us: now_us,
            phase: self.phase,
            health: self.health,
        });
    }

    /// Encodes a request into `self.tx`. Returns (kind, timeout, expected reply or
    /// `None` for no reply, length).
    fn encode(&mut self, flags: u8, addr: u8, payload: &[u8]) -> Option<usize> {
        self.tx.resize(payload.len() + 8, 0);
        encode_request(self.cfg.node, flags, addr, payload, &mut self.tx).ok()
    }

    #[allow(clippy::type_complexity)]
    fn build_next(&mut self, now_us: u64) -> Option<(ExchangeKind, u64, Option<Expect>, usize)> {
        let short = self.cfg.response_timeout_us;
        let long = self.cfg.dump_timeout_us;
        match self.phase {
            Phase::Searching => {
                if now_us < self.next_probe_us {
                    return None;
                }
                self.next_probe_us = now_us + self.cfg.search_period_us;
                if self.ever_connected {
                    self.build_control(now_us, true)
                } else {
                    let len = self.encode(flags::PING, 0, &[])?;
                    let expect = Expect {
                        flags: flags::PING,
                        addr: 0,
                        payload_len: None,
                    };
                    Some((ExchangeKind::Ping, short, Some(expect), len))
                }
            }
            Phase::Init => {
                if now_us < self.next_probe_us {
                    return None;
                }
                let read = match self.init_steps().get(self.init_step) {
                    Some(ExchangeKind::InitConfig) => (ExchangeKind::InitConfig, CsrRead::CONFIG),
                    _ => (ExchangeKind::InitDump, CsrRead::FULL),
                };
                let len = self.encode(read.1.flags, read.1.start, &[])?;
                let payload_len = read.1.count().map(|n| n + 1);
                let expect = Expect {
                    flags: read.1.flags,
                    addr: read.1.start,
                    payload_len,
                };
                Some((read.0, long, Some(expect), len))
            }
            Phase::Running => {
                let control_due = now_us >= self.next_cycle_us;
                if !control_due && self.status_due {
                    self.status_due = false;
                    let read = CsrRead::STATUS;
                    let len = self.encode(read.flags, read.start, &[])?;
                    let expect = Expect {
                        flags: read.flags,
                        addr: read.start,
                        payload_len: Some(firmware_proto::msg::STATUS_PAYLOAD_LEN),
                    };
                    return Some((ExchangeKind::Status, long, Some(expect), len));
                }
                if !control_due && !self.queue.is_empty() {
                    return self.build_request(now_us);
                }
                if !control_due {
                    return None;
                }
                let period = self.cfg.cycle_period_us;
                self.next_cycle_us = if now_us >= self.next_cycle_us + period {
                    now_us + period
                } else {
                    self.next_cycle_us + period
                };
                self.cycles += 1;
                if self.cfg.status_every > 0
                    && self.cycles.is_multiple_of(u64::from(self.cfg.status_every))
                {
                    self.status_due = true;
                }
                self.build_control(now_us, false)
            }
        }
    }

    fn build_control(
        &mut self,
        now_us: u64,
        force_neutral: bool,
    ) -> Option<(ExchangeKind, u64, Option<Expect>, usize)> {
        let block = if force_neutral {
            crate::failsafe::neutral(&self.command)
        } else {
            self.failsafe.gate(&self.command)
        };
        self.tx.resize(32, 0);
        let len = block
            .encode_request(self.cfg.node, flags::NAV, &mut self.tx)
            .ok()?;
        self.last_control_sent = Some((now_us, block));
        self.push_event(LinkEvent::ControlSent {
            time_us: now_us,
            block,
        });
        let expect = Expect {
            flags: flags::NAV,
            addr: 0,
            payload_len: Some(firmware_proto::msg::NAV_PAYLOAD_LEN),
        };
        Some((
            ExchangeKind::Control {
                neutral: is_neutral(&block),
            },
            self.cfg.response_timeout_us,
            Some(expect),
            len,
        ))
    }

    fn build_request(&mut self, now_us: u64) -> Option<(ExchangeKind, u64, Option<Expect>, usize)> {
        let q = self.queue.front()?.clone();
        let kind = ExchangeKind::Request(q.id);
        let long = self.cfg.dump_timeout_us;
        let (flags, addr, payload, payload_len): (u8, u8, Vec<u8>, Option<usize>) = match &q.request
        {
            Request::ReadRegisters { start, count } if (1..=0x7F).contains(count) => {
                (0x80 | count, *start, Vec::new(), None)
            }
            Request::ReadAll => (flags::DUMP, 0, Vec::new(), Some(csr::APP_REGION_LEN + 1)),
            Request::ReadConfig => (
                flags::DUMP,
                csr::CONFIG_DATA,
                Vec::new(),
                Some(firmware_proto::msg::CONFIG_PAYLOAD_LEN),
            ),
            Request::WriteRegisters { addr, data } if (1..=0x7F).contains(&data.len()) => {
                (0x80 | data.len() as u8, *addr, data.clone(), None)
            }
            Request::Reboot => {
                self.queue.pop_front();
                self.tx.resize(16, 0);
                let len = Reboot::encode_request(self.cfg.node, &mut self.tx).ok()?;
                self.push_event(LinkEvent::RequestDone {
                    time_us: now_us,
                    id: q.id,
                    outcome: RequestOutcome::Sent,
                });
                return Some((kind, 0, None, len));
            }
            _ => {
                self.queue.pop_front();
                self.push_event(LinkEvent::RequestDone {
                    time_us: now_us,
                    id: q.id,
                    outcome: RequestOutcome::Rejected,
                });
                return None;
            }
        };
        let payload_len = payload_len.or_else(|| Some(usize::from(flags & 0x7F) + 1));
        let len = self.encode(flags, addr, &payload)?;
        let expect = Expect {
            flags,
            addr,
            payload_len,
        };
        Some((kind, long, Some(expect), len))
    }

    fn init_steps(&self) -> Vec<ExchangeKind> {
        let mut steps = Vec::with_capacity(2);
        if self.cfg.init_dump {
            steps.push(ExchangeKind::InitDump);
        }
        if self.cfg.init_config {
            steps.push(ExchangeKind::InitConfig);
        }
        steps
    }

    fn deframe(&mut self, mut input: &[u8], now_us: u64) {
        let record = self.cfg.record_frames;
        while let Some(event) = self.rx.feed(&mut input, now_us) {
            let item = match event {
                Event::Frame { frame, .. } => {
                    let bytes = record.then(|| frame.as_bytes().to_vec());
                    match self
                        .inflight
                        .as_ref()
                        .and_then(|f| match_frame(&frame, f, &self.cfg))
                    {
                        Some(reply) => RxItem::Match { reply, bytes },
                        None => RxItem::Unexpected { bytes },
                    }
                }
                Event::Error(e) => RxItem::Error(e),
            };
            self.rx_items.push(item);
        }
        // Taken for the loop and put back after it, so its memory is reused (no
        // allocation per received frame).
        let mut items = std::mem::take(&mut self.rx_items);
        for item in items.drain(..) {
            match item {
                RxItem::Error(error) => {
                    if let Some(f) = self.inflight.as_mut() {
                        f.seen = Some(worse(f.seen, fail_cause_of(error.kind)));
                    }
                    self.push_event(LinkEvent::RxError {
                        time_us: now_us,
                        error,
                    });
                }
                RxItem::Unexpected { bytes } => {
                    self.counters.unexpected_frames += 1;
                    if let Some(f) = self.inflight.as_mut() {
                        f.seen = Some(worse(f.seen, FailCause::Unexpected));
                    }
                    if let Some(bytes) = bytes {
                        self.push_event(LinkEvent::FrameRx {
                            time_us: now_us,
                            bytes,
                        });
                    }
                }
                RxItem::Match { reply, bytes } => {
                    if let Some(bytes) = bytes {
                        self.push_event(LinkEvent::FrameRx {
                            time_us: now_us,
                            bytes,
                        });
                    }
                    self.complete(reply, now_us);
                }
            }
        }
        if self.rx_items.is_empty() {
            self.rx_items = items;
        }
    }

    fn update(&mut self, now_us: u64) {
        // A partial frame that stalled: let the deframer abandon it.
        if self.rx.buffered_len() > 0
            && now_us > self.last_rx_us.saturating_add(self.cfg.deframer_gap_us)
        {
            self.deframe(&[], now_us);
        }
        if let Some(f) = self.inflight
            && now_us >= f.deadline_us
        {
            let cause = f.seen.unwrap_or(if f.saw_bytes {
                FailCause::Sync
            } else {
                FailCause::Timeout
            });
            self.inflight = None;
            self.fail(f.kind, cause, now_us);
        }
        if self.health != Health::Lost
            && let Some(last) = self.last_valid_us
            && now_us >= last.saturating_add(self.cfg.loss_timeout_us)
        {
            self.lose(now_us);
        }
    }

    fn lose(&mut self, now_us: u64) {
        self.health = Health::Lost;
        self.phase = Phase::Searching;
        self.counters.link_losses += 1;
        if let Some(f) = self.inflight.take() {
            let cause = f.seen.unwrap_or(if f.saw_bytes {
                FailCause::Sync
            } else {
                FailCause::Timeout
            });
            self.fail(f.kind, cause, now_us);
        }
        if self.failsafe.on_link_lost(now_us) {
            self.push_event(LinkEvent::AlarmRaised {
                time_us: now_us,
                alarm: crate::failsafe::Alarm::LinkLost,
            });
        }
        self.status_due = false;
        self.init_step = 0;
        self.init_attempts = 0;
        self.next_probe_us = now_us;
        self.state_changed(now_us);
    }

    fn fail(&mut self, kind: ExchangeKind, cause: FailCause, now_us: u64) {
        self.counters.count_failure(cause);
        self.push_event(LinkEvent::ExchangeFailed {
            time_us: now_us,
            kind,
            cause,
        });
        self.consecutive_failures = self.consecutive_failures.saturating_add(1);
        if self.health == Health::Connected
            && self.consecutive_failures >= self.cfg.degraded_after_failures
        {
            self.health = Health::Degraded;
            self.failsafe.on_link_degraded();
            self.state_changed(now_us);
        }
        match kind {
            ExchangeKind::InitDump | ExchangeKind::InitConfig => {
                self.init_attempts += 1;
                if self.init_attempts > self.cfg.init_retries {
                    self.phase = Phase::Searching;
                    self.init_step = 0;
                    self.init_attempts = 0;
                    self.state_changed(now_us);
                } else {
                    self.counters.retries += 1;
                }
                self.next_probe_us = now_us;
            }
            ExchangeKind::Request(id) => {
                let retry = match self.queue.front_mut() {
                    Some(q) if q.id == id => {
                        q.attempts += 1;
                        q.attempts <= self.cfg.request_retries
                    }
                    _ => false,
                };
                if retry {
                    self.counters.retries += 1;
                } else {
                    self.queue.pop_front();
                    self.push_event(LinkEvent::RequestDone {
                        time_us: now_us,
                        id,
                        outcome: RequestOutcome::Failed(cause),
                    });
                }
            }
            ExchangeKind::Ping | ExchangeKind::Control { .. } | ExchangeKind::Status => {}
        }
    }

    fn complete(&mut self, reply: Reply, now_us: u64) {
        let Some(f) = self.inflight.take() else {
            return;
        };
        let rtt_us = now_us.saturating_sub(f.sent_us);
        self.rtt.push(rtt_us);
        self.counters.responses += 1;
        self.last_valid_us = Some(now_us);
        self.consecutive_failures = 0;
        let mut changed = false;
        if self.health != Health::Connected {
            self.health = Health::Connected;
            changed = true;
        }
        self.failsafe.on_link_connected(now_us);
        if self.phase == Phase::Searching {
            self.ever_connected = true;
            self.init_step = 0;
            self.init_attempts = 0;
            self.phase = if self.init_steps().is_empty() {
                self.enter_running(now_us);
                Phase::Running
            } else {
                Phase::Init
            };
            self.next_probe_us = now_us;
            changed = true;
        }
        if changed {
            self.state_changed(now_us);
        }
        match (f.kind, reply) {
            (_, Reply::Nav(nav)) => {
                let t = Telemetry::from_nav(&nav, now_us, rtt_us, &self.cfg.conventions);
                self.push_event(LinkEvent::Telemetry(t));
            }
            (_, Reply::Status(s)) => {
                self.push_event(LinkEvent::Status(StatusTelemetry::from_block(&s, now_us)));
            }
            (ExchangeKind::Request(id), reply) => {
                self.queue.pop_front();
                let outcome = match reply {
                    Reply::Registers { start, data } => RequestOutcome::Registers { start, data },
                    Reply::Config(c) => RequestOutcome::Config(c),
                    _ => RequestOutcome::Sent,
                };
                self.push_event(LinkEvent::RequestDone {
                    time_us: now_us,
                    id,
                    outcome,
                });
            }
            (ExchangeKind::InitDump | ExchangeKind::InitConfig, reply) => {
                match reply {
                    Reply::Registers { start, data } => self.push_event(LinkEvent::RegisterImage {
                        time_us: now_us,
                        start,
                        data,
                    }),
                    Reply::Config(config) => self.push_event(LinkEvent::Config {
                        time_us: now_us,
                        config,
                    }),
                    _ => {}
                }
                self.init_step += 1;
                self.init_attempts = 0;
                self.next_probe_us = now_us;
                if self.init_step >= self.init_steps().len() {
                    self.phase = Phase::Running;
                    self.enter_running(now_us);
                    self.state_changed(now_us);
                }
            }
            (_, Reply::Ping | Reply::Registers { .. } | Reply::Config(_)) => {}
        }
        if self.phase == Phase::Running {
            // Extra exchanges (status, requests) go right away, before the next cycle.
            self.next_probe_us = now_us;
        }
    }

    fn enter_running(&mut self, now_us: u64) {
        self.next_cycle_us = now_us;
        self.status_due = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use firmware_proto::{DeviceType, NodeId, PingReply, encode_response};

    fn nav_reply(pressure: i16) -> Vec<u8> {
        let nav = NavReply {
            device_type: DeviceType::Pro4Rov,
            heading_deg_x10: 900,
            pitch_deg_x10: 10,
            roll_deg_x10: -20,
            pressure_mbar: pressure,
            yaw_accel_raw: 0,
            pitch_accel_raw: 0,
            roll_accel_raw: 0,
            surge_accel_raw: 0,
            sway_accel_raw: 0,
            heave_accel_raw: -9810,
            mag_x_raw: 0,
            mag_y_raw: 0,
            mag_z_raw: 0,
            attitude_status: 0,
            humidity_pct: 30,
            water_temp_c_x100: 1500,
            power_pct: 100,
        };
        let mut out = [0u8; 64];
        let n = encode_response(
            NodeId::ROV,
            flags::NAV,
            0,
            DeviceType::Pro4Rov,
            nav.to_payload().get(1..).unwrap(),
            &mut out,
        )
        .unwrap();
        out[..n].to_vec()
    }

    fn ping_reply() -> Vec<u8> {
        let p = PingReply {
            device_type: DeviceType::Pro4Rov,
            heading_deg_x10: 0,
            pitch_deg_x10: 0,
            roll_deg_x10: 0,
            pressure_mbar: 1013,
        };
        let mut out = [0u8; 32];
        let n = p.encode_response(NodeId::ROV, &mut out).unwrap();
        out[..n].to_vec()
    }

    fn cfg() -> LinkConfig {
        LinkConfig {
            init_dump: false,
            status_every: 0,
            arm_min_healthy_us: 0,
            record_frames: false,
            ..LinkConfig::default()
        }
    }

    #[test]
    fn searching_pings_then_runs_and_matches_nav() {
        let mut link = Link::new(cfg()).unwrap();
        let f = link.poll_transmit(0).unwrap().to_vec();
        assert_eq!(f, [0xFA, 0xAF, 0x01, 0x01, 0x00, 0x00, 0x55, 0x00]);
        assert!(link.poll_transmit(1000).is_none());
        link.handle_input(&ping_reply(), 3000);
        assert_eq!(
            (link.phase(), link.health()),
            (Phase::Running, Health::Connected)
        );
        let f = link.poll_transmit(3000).unwrap().to_vec();
        assert_eq!(f.len(), 23);
        assert_eq!(&f[..7], &[0xFA, 0xAF, 0x01, 0x05, 0x00, 0x0F, 0x5E]);
        link.handle_input(&nav_reply(1213), 9000);
        let mut got = None;
        while let Some(e) = link.poll_event() {
            if let LinkEvent::Telemetry(t) = e {
                got = Some(t);
            }
        }
        let t = got.unwrap();
        assert_eq!(t.rtt_us, 6000);
        assert!((t.depth_m - (1213.0 - 1013.25) * 100.0 / 9810.0).abs() < 1e-9);
        assert_eq!(t.heading_deg, 90.0);
        // Next control frame waits for the cycle.
        assert!(link.poll_transmit(22_999).is_none());
        assert!(link.poll_transmit(23_000).is_some());
    }

    /// A link connected at 1 ms (ping answered), armed, commanding 50/50/20 %.
    fn armed_link() -> Link {
        let mut link = Link::new(cfg()).unwrap();
        link.poll_transmit(0).unwrap();
        link.handle_input(&ping_reply(), 1000);
        link.set_thrust(&PhysicsThrust {
            port_pct: 50.0,
            starboard_pct: 50.0,
            vertical_pct: 20.0,
        });
        link.arm(1000).unwrap();
        link
    }

    #[test]
    fn timeout_degrades_then_loses_and_sends_neutral() {
        let mut link = armed_link();
        let f = link.poll_transmit(1000).unwrap().to_vec();
        assert_eq!(&f[7..9], &[50, 0]);
        let mut t = 1000;
        // No more replies.
        while t < 1_000_000 {
            t += 1000;
            link.handle_timeout(t);
            let _ = link.poll_transmit(t);
            if link.health() == Health::Lost {
                break;
            }
        }
        assert_eq!(t, 501_000);
        assert!(!link.failsafe().is_armed());
        let (sent_at, block) = link.last_control_sent().unwrap();
        assert_eq!(sent_at, 501_000);
        assert!(is_neutral(&block));
        let c = link.counters();
        assert_eq!(c.failed_timeout, c.requests - 2);
        assert_eq!(c.link_losses, 1);
    }

    #[test]
    fn corrupted_reply_is_a_total_check_failure() {
        let mut link = Link::new(cfg()).unwrap();
        link.poll_transmit(0).unwrap();
        link.handle_input(&ping_reply(), 1000);
        link.poll_transmit(1000).unwrap();
        let mut r = nav_reply(1100);
        r[20] ^= 0x10;
        link.handle_input(&r, 5000);
        link.handle_timeout(51_000);
        let c = link.counters();
        assert_eq!((c.failed_total_check, c.failed(), c.responses), (1, 1, 1));
        assert_eq!(c.deframer.total_check, 1);
    }

    #[test]
    fn unexpected_frame_keeps_waiting() {
        let mut link = Link::new(cfg()).unwrap();
        link.poll_transmit(0).unwrap();
        link.handle_input(&ping_reply(), 1000);
        link.poll_transmit(1000).unwrap();
        link.handle_input(&ping_reply(), 2000);
        assert!(link.in_flight());
        link.handle_input(&nav_reply(1100), 3000);
        assert!(!link.in_flight());
        let c = link.counters();
        assert_eq!((c.unexpected_frames, c.failed(), c.responses), (1, 0, 2));
    }

    #[test]
    fn port_lost_loses_at_once_and_port_opened_probes_neutral_at_once() {
        let mut link = armed_link();
        link.poll_transmit(1000).unwrap();
        link.handle_input(&nav_reply(1100), 6000);
        link.poll_transmit(21_000).unwrap();
        while link.poll_event().is_some() {}
        // The port vanishes with a control exchange in flight, long before T_loss.
        link.on_port_lost(25_000);
        assert_eq!(
            (link.phase(), link.health(), link.port_open()),
            (Phase::Searching, Health::Lost, false)
        );
        assert!(!link.failsafe().is_armed());
        assert!(link.failsafe().alarm().is_some_and(|a| a.cause_active));
        let events: Vec<LinkEvent> = std::iter::from_fn(|| link.poll_event()).collect();
        assert!(events.iter().any(|e| matches!(
            e,
            LinkEvent::ExchangeFailed {
                cause: FailCause::PortGone,
                ..
            }
        )));
        assert!(events.iter().any(|e| matches!(
            e,
            LinkEvent::AlarmRaised {
                time_us: 25_000,
                ..
            }
        )));
        let c = link.counters();
        assert_eq!(
            (c.failed_port_gone, c.port_losses, c.link_losses),
            (1, 1, 1)
        );
        assert_eq!(c.failed_timeout, 0);
        assert_eq!(c.responses + c.failed(), c.requests);
        // Nothing goes out and nothing times out while the port is closed; late bytes
        // from the old port are ignored.
        assert_eq!(link.next_timeout(), None);
        for t in (30_000..3_000_000).step_by(10_000) {
            link.handle_timeout(t);
            assert!(link.poll_transmit(t).is_none());
        }
        link.handle_input(&nav_reply(1100), 3_000_000);
        assert_eq!(link.counters().requests, c.requests);
        link.on_port_lost(3_000_001);
        assert_eq!(link.counters().port_losses, 1);
        // Re-opened: a neutral probe leaves at once; the link connects but stays
        // disarmed with the alarm latched until the pilot re-arms.
        link.on_port_opened(3_100_000);
        assert_eq!(link.next_timeout(), Some(3_100_000));
        let f = link.poll_transmit(3_100_000).unwrap().to_vec();
        assert_eq!(&f[3..4], &[flags::NAV]);
        let (_, block) = link.last_control_sent().unwrap();
        assert!(is_neutral(&block));
        link.handle_input(&nav_reply(1100), 3_106_000);
        assert_eq!(
            (link.phase(), link.health()),
            (Phase::Running, Health::Connected)
        );
        assert!(!link.failsafe().is_armed());
        assert!(link.failsafe().alarm().is_some_and(|a| !a.cause_active));
        link.poll_transmit(3_106_000).unwrap();
        let (_, block) = link.last_control_sent().unwrap();
        assert!(is_neutral(&block), "thrust stays neutral until re-armed");
        link.arm(3_200_000).unwrap();
        assert!(link.failsafe().alarm().is_none());
    }

    #[test]
    fn port_lost_before_any_connection_raises_nothing() {
        let mut link = Link::new(cfg()).unwrap();
        link.poll_transmit(0).unwrap();
        link.on_port_lost(10_000);
        assert!(link.failsafe().alarm().is_none());
        assert_eq!(link.counters().failed_port_gone, 1);
        link.on_port_opened(20_000);
        // Never connected: the probe is still the ping.
        let f = link.poll_transmit(20_000).unwrap().to_vec();
        assert_eq!(f, [0xFA, 0xAF, 0x01, 0x01, 0x00, 0x00, 0x55, 0x00]);
    }
}
