//! Decoded telemetry in the physics convention, and the link's events.

use firmware_proto::{ConfigData, ControlBlock, DeframeError, NavReply, StatusBlock};
use rov_types::conventions::WireConventions;

use crate::failsafe::Alarm;
use crate::stats::FailCause;

/// Phase of the link state machine (protocol.md §12.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Phase {
    /// Probing for the vehicle every search period.
    Searching,
    /// Reading the register image (and optionally the config data).
    Init,
    /// Control + navigation every cycle, the status block every N-th cycle.
    Running,
}

/// Health of the link (style B1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Health {
    /// The last exchange succeeded (or fewer than the degraded threshold failed).
    Connected,
    /// Several consecutive exchanges failed, but a valid response arrived within T_loss.
    Degraded,
    /// No valid response for T_loss, or none yet since start.
    Lost,
}

/// One navigation reply (FLAGS 0x05) in the physics convention (see
/// [`rov_types::conventions`]). The raw reply is kept alongside.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Telemetry {
    /// Arrival time of the reply's last byte, µs.
    pub time_us: u64,
    /// Round trip of this exchange, µs.
    pub rtt_us: u64,
    /// The wire values.
    pub raw: NavReply,
    /// Heading, degrees [0, 360).
    pub heading_deg: f64,
    /// Pitch, degrees, positive nose up.
    pub pitch_deg: f64,
    /// Roll, degrees, positive starboard down.
    pub roll_deg: f64,
    /// Pressure, mbar (absolute, as sent).
    pub pressure_mbar: f64,
    /// Depth from pressure with the configured tare, m, positive down.
    pub depth_m: f64,
    /// Yaw rate, rad/s (the "yaw acceleration" field ÷ 1000: a guess, protocol.md §6.2).
    pub yaw_rate_radps: f64,
    /// Pitch rate, rad/s (÷ 1000, sign as pitch).
    pub pitch_rate_radps: f64,
    /// Roll rate, rad/s (÷ 1000, sign as roll).
    pub roll_rate_radps: f64,
    /// Surge, sway, heave specific force, body axes, m/s² (÷ 1000, a guess).
    pub accel_body_mps2: [f64; 3],
    /// Raw magnetometer X, Y, Z, ADC units.
    pub mag_raw: [i16; 3],
    /// Attitude-sensor status (0 = OK).
    pub attitude_status: i16,
    /// Internal relative humidity, %.
    pub humidity_pct: f64,
    /// Water temperature, °C.
    pub water_temp_c: f64,
    /// Total power available, %.
    pub power_pct: u8,
}

impl Telemetry {
    /// Converts a navigation reply with `conv`.
    #[must_use]
    pub fn from_nav(nav: &NavReply, time_us: u64, rtt_us: u64, conv: &WireConventions) -> Self {
        let milli = |x: i16| f64::from(x) / 1000.0;
        Self {
            time_us,
            rtt_us,
            raw: *nav,
            heading_deg: conv.heading_deg_from_wire(nav.heading_deg_x10),
            pitch_deg: conv.pitch_deg_from_wire(nav.pitch_deg_x10),
            roll_deg: conv.roll_deg_from_wire(nav.roll_deg_x10),
            pressure_mbar: f64::from(nav.pressure_mbar),
            depth_m: conv.depth_m_from_wire(nav.pressure_mbar),
            yaw_rate_radps: milli(nav.yaw_accel_raw),
            pitch_rate_radps: conv.pitch_sign() * milli(nav.pitch_accel_raw),
            roll_rate_radps: conv.roll_sign() * milli(nav.roll_accel_raw),
            accel_body_mps2: [
                milli(nav.surge_accel_raw),
                milli(nav.sway_accel_raw),
                milli(nav.heave_accel_raw),
            ],
            mag_raw: [nav.mag_x_raw, nav.mag_y_raw, nav.mag_z_raw],
            attitude_status: nav.attitude_status,
            humidity_pct: f64::from(nav.humidity_pct),
            water_temp_c: nav.water_temp_c(),
            power_pct: nav.power_pct,
        }
    }
}

/// The status block (0x7A..0x87) with its values in SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StatusTelemetry {
    /// Arrival time, µs.
    pub time_us: u64,
    /// The wire values.
    pub raw: StatusBlock,
    /// Water temperature, °C.
    pub water_temp_c: f64,
    /// Tether voltage, V.
    pub tether_v: f64,
    /// 12 V rail voltage, V.
    pub rail_12v_v: f64,
    /// 12 V rail current, A.
    pub rail_12v_a: f64,
    /// Internal relative humidity, %.
    pub humidity_pct: f64,
    /// The vehicle's comm error count (CSR 0x86, wrapping).
    pub comm_errors: u16,
}

impl StatusTelemetry {
    /// Converts a status block.
    #[must_use]
    pub fn from_block(raw: &StatusBlock, time_us: u64) -> Self {
        Self {
            time_us,
            raw: *raw,
            water_temp_c: raw.water_temp_c(),
            tether_v: raw.tether_v(),
            rail_12v_v: raw.rail_12v_v(),
            rail_12v_a: f64::from(raw.rail_12v_ma) / 1000.0,
            humidity_pct: f64::from(raw.humidity_pct),
            comm_errors: raw.comm_errors,
        }
    }
}

/// Identifies an application request ([`Link::request`](crate::Link::request)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct RequestId(pub u64);

/// An application request, sent between control cycles with retries.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Request {
    /// Read `count` (1..=127) registers from `start` (FLAGS 0x80 | count).
    ReadRegisters {
        /// First register.
        start: u8,
        /// Number of registers, 1..=127.
        count: u8,
    },
    /// Read the application region 0x00..=0xEF (FLAGS 0x80 at 0).
    ReadAll,
    /// Read the configuration data at 0xF7 (extended-length reply).
    ReadConfig,
    /// Write 1..=127 bytes at `addr`, reading them back in the same exchange (FLAGS
    /// 0x80 | len), so the write is confirmed.
    WriteRegisters {
        /// First register.
        addr: u8,
        /// Bytes to write.
        data: Vec<u8>,
    },
    /// Reboot (0xDEAD to 0xFE, FLAGS 0: the vehicle does not answer).
    Reboot,
}

/// Result of an application request.
#[derive(Debug, Clone, PartialEq)]
pub enum RequestOutcome {
    /// Registers read (or read back after a write).
    Registers {
        /// First register.
        start: u8,
        /// Their values.
        data: Vec<u8>,
    },
    /// The configuration data.
    Config(Box<ConfigData>),
    /// Sent; no reply expected (reboot).
    Sent,
    /// Every attempt failed; the cause of the last one.
    Failed(FailCause),
    /// The request was malformed (e.g. a write longer than 127 bytes).
    Rejected,
}

/// What an exchange was for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ExchangeKind {
    /// Ping (SEARCHING before the first connection).
    Ping,
    /// Control write + navigation reply. `neutral` if the frame carried no thrust.
    Control {
        /// Whether the frame was neutral.
        neutral: bool,
    },
    /// Status block read.
    Status,
    /// INIT full register dump.
    InitDump,
    /// INIT config read.
    InitConfig,
    /// Application request.
    Request(RequestId),
}

/// Events out of the link. Drain them with [`Link::poll_event`](crate::Link::poll_event).
#[derive(Debug, Clone, PartialEq)]
pub enum LinkEvent {
    /// Phase or health changed.
    StateChanged {
        /// When, µs.
        time_us: u64,
        /// New phase.
        phase: Phase,
        /// New health.
        health: Health,
    },
    /// A navigation reply.
    Telemetry(Telemetry),
    /// A status block.
    Status(StatusTelemetry),
    /// Registers read in INIT (the application region from 0x00).
    RegisterImage {
        /// When, µs.
        time_us: u64,
        /// First register.
        start: u8,
        /// Values.
        data: Vec<u8>,
    },
    /// Configuration data read in INIT.
    Config {
        /// When, µs.
        time_us: u64,
        /// The data.
        config: Box<ConfigData>,
    },
    /// An application request finished.
    RequestDone {
        /// When, µs.
        time_us: u64,
        /// Which.
        id: RequestId,
        /// Result.
        outcome: RequestOutcome,
    },
    /// An exchange failed (counted in [`LinkCounters`](crate::LinkCounters)).
    ExchangeFailed {
        /// When, µs.
        time_us: u64,
        /// What it was for.
        kind: ExchangeKind,
        /// Why.
        cause: FailCause,
    },
    /// A failsafe alarm was raised (it latches until re-arm).
    AlarmRaised {
        /// When, µs.
        time_us: u64,
        /// Which.
        alarm: Alarm,
    },
    /// The latched alarm was cleared by arming.
    AlarmCleared {
        /// When, µs.
        time_us: u64,
        /// Which.
        alarm: Alarm,
    },
    /// A control frame left (the gated command actually sent).
    ControlSent {
        /// When, µs.
        time_us: u64,
        /// The block on the wire.
        block: ControlBlock,
    },
    /// A frame handed to the transport (when recording is on).
    FrameTx {
        /// When, µs.
        time_us: u64,
        /// The bytes.
        bytes: Vec<u8>,
    },
    /// A valid frame received (when recording is on).
    FrameRx {
        /// When, µs.
        time_us: u64,
        /// The bytes.
        bytes: Vec<u8>,
    },
    /// Bytes the deframer dropped.
    RxError {
        /// When, µs.
        time_us: u64,
        /// What.
        error: DeframeError,
    },
}
