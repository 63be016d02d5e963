//! Topics and their typed records.
//!
//! Every JSON topic has one record struct (serde) and a JSON Schema (draft 2020-12,
//! schema encoding `jsonschema`, message encoding `json`) generated from the same field
//! list, so Foxglove and PlotJuggler show named, documented fields. The raw-frame topics
//! [`TOPIC_PRO4_TX`] and [`TOPIC_PRO4_RX`] carry the frame bytes with message encoding
//! [`RAW_ENCODING`] and no schema.
//!
//! Numbers: a non-finite `f64` is written as JSON `null` (JSON has no NaN) and read back as
//! NaN; an `Option<f64>` is `null` when absent. A field missing from a message (an older
//! writer) reads as NaN, `None`, 0, `false`, `""` or an empty list, so old files load.

use serde::de::{DeserializeOwned, Deserializer};
use serde::{Deserialize, Serialize};
use serde_json::{Value, json};

use crate::error::SessionError;

/// Raw frames sent to the vehicle.
pub const TOPIC_PRO4_TX: &str = "/pro4/tx";
/// Raw frames received from the vehicle.
pub const TOPIC_PRO4_RX: &str = "/pro4/rx";
/// Decoded navigation replies.
pub const TOPIC_NAV: &str = "/telemetry/nav";
/// Decoded status dumps.
pub const TOPIC_STATUS: &str = "/telemetry/status";
/// Thrust commands sent.
pub const TOPIC_THRUST: &str = "/command/thrust";
/// Pilot input (gamepad).
pub const TOPIC_PILOT: &str = "/pilot/input";
/// Autopilot modes and setpoints.
pub const TOPIC_AUTOPILOT: &str = "/autopilot/state";
/// Observer estimates.
pub const TOPIC_OBSERVER: &str = "/observer/state";
/// Link statistics.
pub const TOPIC_LINK: &str = "/link/stats";
/// Alarms and events.
pub const TOPIC_EVENTS: &str = "/events";
/// Simulator truth (simulated sessions only).
pub const TOPIC_TRUTH: &str = "/truth/state";
/// Session description, one message at the start.
pub const TOPIC_SESSION_INFO: &str = "/session/info";
/// The vehicle's pose as a `foxglove.FrameTransform` (world → vehicle), for the 3D panel.
pub const TOPIC_TRANSFORM: &str = "/tf";
/// The vehicle's pose as a `foxglove.PoseInFrame` in the world frame.
pub const TOPIC_POSE: &str = "/vehicle/pose";
/// The recent track as a `foxglove.PosesInFrame` in the world frame.
pub const TOPIC_TRACK: &str = "/vehicle/track";
/// Camera video as `foxglove.CompressedVideo` (H.264, Annex B, one access unit each).
pub const TOPIC_VIDEO: &str = "/camera/video";

/// Message encoding of the raw-frame topics (no schema; each message is one frame).
pub const RAW_ENCODING: &str = "vr-pro4";
/// Message encoding of the decoded topics.
pub const JSON_ENCODING: &str = "json";
/// Message (and schema) encoding of the Foxglove topics.
pub const PROTOBUF_ENCODING: &str = "protobuf";
/// Schema encoding of the decoded topics.
pub const JSON_SCHEMA_ENCODING: &str = "jsonschema";

/// The known topics.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Topic {
    /// [`TOPIC_PRO4_TX`].
    Pro4Tx,
    /// [`TOPIC_PRO4_RX`].
    Pro4Rx,
    /// [`TOPIC_NAV`].
    Nav,
    /// [`TOPIC_STATUS`].
    Status,
    /// [`TOPIC_THRUST`].
    Thrust,
    /// [`TOPIC_PILOT`].
    Pilot,
    /// [`TOPIC_AUTOPILOT`].
    Autopilot,
    /// [`TOPIC_OBSERVER`].
    Observer,
    /// [`TOPIC_LINK`].
    Link,
    /// [`TOPIC_EVENTS`].
    Events,
    /// [`TOPIC_TRUTH`].
    Truth,
    /// [`TOPIC_SESSION_INFO`].
    SessionInfo,
    /// [`TOPIC_TRANSFORM`].
    Transform,
    /// [`TOPIC_POSE`].
    Pose,
    /// [`TOPIC_TRACK`].
    Track,
    /// [`TOPIC_VIDEO`].
    Video,
}

impl Topic {
    /// Every known topic.
    pub const ALL: [Topic; 16] = [
        Topic::Pro4Tx,
        Topic::Pro4Rx,
        Topic::Nav,
        Topic::Status,
        Topic::Thrust,
        Topic::Pilot,
        Topic::Autopilot,
        Topic::Observer,
        Topic::Link,
        Topic::Events,
        Topic::Truth,
        Topic::SessionInfo,
        Topic::Transform,
        Topic::Pose,
        Topic::Track,
        Topic::Video,
    ];

    /// The topic name.
    pub const fn name(self) -> &'static str {
        match self {
            Topic::Pro4Tx => TOPIC_PRO4_TX,
            Topic::Pro4Rx => TOPIC_PRO4_RX,
            Topic::Nav => TOPIC_NAV,
            Topic::Status => TOPIC_STATUS,
            Topic::Thrust => TOPIC_THRUST,
            Topic::Pilot => TOPIC_PILOT,
            Topic::Autopilot => TOPIC_AUTOPILOT,
            Topic::Observer => TOPIC_OBSERVER,
            Topic::Link => TOPIC_LINK,
            Topic::Events => TOPIC_EVENTS,
            Topic::Truth => TOPIC_TRUTH,
            Topic::SessionInfo => TOPIC_SESSION_INFO,
            Topic::Transform => TOPIC_TRANSFORM,
            Topic::Pose => TOPIC_POSE,
            Topic::Track => TOPIC_TRACK,
            Topic::Video => TOPIC_VIDEO,
        }
    }

    /// The known topic of a name.
    pub fn from_name(name: &str) -> Option<Topic> {
        Topic::ALL.into_iter().find(|t| t.name() == name)
    }

    /// Whether the topic carries raw frames (encoding [`RAW_ENCODING`]).
    pub const fn is_raw(self) -> bool {
        matches!(self, Topic::Pro4Tx | Topic::Pro4Rx)
    }

    /// Whether the topic carries a Foxglove protobuf schema (encoding [`PROTOBUF_ENCODING`]).
    pub const fn is_foxglove(self) -> bool {
        matches!(
            self,
            Topic::Transform | Topic::Pose | Topic::Track | Topic::Video
        )
    }

    /// Whether the topic carries one of the JSON records of this module.
    pub const fn is_json(self) -> bool {
        !self.is_raw() && !self.is_foxglove()
    }

    /// The message encoding of the topic.
    pub const fn encoding(self) -> &'static str {
        if self.is_raw() {
            RAW_ENCODING
        } else if self.is_foxglove() {
            PROTOBUF_ENCODING
        } else {
            JSON_ENCODING
        }
    }

    /// Dense index (0..16), for per-topic tables.
    pub const fn index(self) -> usize {
        self as usize
    }
}

/// Direction of a raw frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Direction {
    /// Topside to vehicle ([`TOPIC_PRO4_TX`]).
    Tx,
    /// Vehicle to topside ([`TOPIC_PRO4_RX`]).
    Rx,
}

impl Direction {
    /// The topic of this direction.
    pub const fn topic(self) -> Topic {
        match self {
            Direction::Tx => Topic::Pro4Tx,
            Direction::Rx => Topic::Pro4Rx,
        }
    }
}

/// One value of a record field, for the CSV export.
#[derive(Debug, Clone, PartialEq)]
pub enum Cell {
    /// A number (NaN when not available).
    Num(f64),
    /// An integer.
    Int(u64),
    /// A flag (written as 1 or 0).
    Bool(bool),
    /// Text (written with commas and line breaks replaced).
    Text(String),
    /// No value (empty cell).
    Missing,
}

/// A type usable as a record field: its JSON Schema, its value when missing from a
/// message, its lenient decoding and its CSV cell.
pub trait Field: Sized {
    /// The JSON Schema of the field (without description).
    fn json_schema() -> Value;
    /// The value when the key is absent from a message.
    fn missing() -> Self;
    /// Decodes the field (`null` is NaN for `f64`).
    fn decode<'de, D: Deserializer<'de>>(d: D) -> Result<Self, D::Error>;
    /// The CSV cell of the value.
    fn cell(&self) -> Cell;
}

/// serde `default` helper: the missing value of a field type.
pub(crate) fn missing<T: Field>() -> T {
    T::missing()
}

/// serde `deserialize_with` helper: the lenient decoding of a field type.
pub(crate) fn decode_field<'de, D: Deserializer<'de>, T: Field>(d: D) -> Result<T, D::Error> {
    T::decode(d)
}

impl Field for f64 {
    fn json_schema() -> Value {
        json!({"type": ["number", "null"]})
    }
    fn missing() -> Self {
        f64::NAN
    }
    fn decode<'de, D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
    }
    fn cell(&self) -> Cell {
        Cell::Num(*self)
    }
}

impl Field for Option<f64> {
    fn json_schema() -> Value {
        json!({"type": ["number", "null"]})
    }
    fn missing() -> Self {
        None
    }
    fn decode<'de, D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Option::<f64>::deserialize(d)
    }
    fn cell(&self) -> Cell {
        self.map_or(Cell::Missing, Cell::Num)
    }
}

impl Field for u64 {
    fn json_schema() -> Value {
        json!({"type": "integer", "minimum": 0})
    }
    fn missing() -> Self {
        0
    }
    fn decode<'de, D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        u64::deserialize(d)
    }
    fn cell(&self) -> Cell {
        Cell::Int(*self)
    }
}

impl Field for Option<u64> {
    fn json_schema() -> Value {
        json!({"type": ["integer", "null"], "minimum": 0})
    }
    fn missing() -> Self {
        None
    }
    fn decode<'de, D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Option::<u64>::deserialize(d)
    }
    fn cell(&self) -> Cell {
        self.map_or(Cell::Missing, Cell::Int)
    }
}

impl Field for bool {
    fn json_schema() -> Value {
        json!({"type": "boolean"})
    }
    fn missing() -> Self {
        false
    }
    fn decode<'de, D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        bool::deserialize(d)
    }
    fn cell(&self) -> Cell {
        Cell::Bool(*self)
    }
}

impl Field for String {
    fn json_schema() -> Value {
        json!({"type": "string"})
    }
    fn missing() -> Self {
        String::new()
    }
    fn decode<'de, D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        String::deserialize(d)
    }
    fn cell(&self) -> Cell {
        Cell::Text(self.clone())
    }
}

impl Field for Vec<String> {
    fn json_schema() -> Value {
        json!({"type": "array", "items": {"type": "string"}})
    }
    fn missing() -> Self {
        Vec::new()
    }
    fn decode<'de, D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Vec::<String>::deserialize(d)
    }
    fn cell(&self) -> Cell {
        Cell::Text(self.join("|"))
    }
}

/// Defines a string enum field: serde lower-case names, a JSON Schema `enum`, a default.
macro_rules! string_enum {
    (
        $(#[doc = $doc:literal])*
        $name:ident { $( $(#[doc = $vdoc:literal])* $variant:ident = $text:literal ),+ $(,)? } default $default:ident
    ) => {
        $(#[doc = $doc])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
        pub enum $name {
            $(
                $(#[doc = $vdoc])*
                #[serde(rename = $text)]
                $variant,
            )+
        }

        impl Default for $name {
            fn default() -> Self {
                $name::$default
            }
        }

        impl $name {
            /// Every value.
            pub const ALL: &'static [$name] = &[$($name::$variant),+];

            /// The text written to the file.
            pub const fn as_str(self) -> &'static str {
                match self {
                    $($name::$variant => $text,)+
                }
            }
        }

        impl Field for $name {
            fn json_schema() -> Value {
                json!({"type": "string", "enum": [$($text),+]})
            }
            fn missing() -> Self {
                $name::$default
            }
            fn decode<'de, D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                $name::deserialize(d)
            }
            fn cell(&self) -> Cell {
                Cell::Text(self.as_str().to_string())
            }
        }
    };
}

string_enum! {
    /// Mode of an autopilot channel.
    Mode {
        /// The pilot flies this axis.
        Manual = "manual",
        /// The topside controller holds the setpoint.
        Hold = "hold",
        /// The vehicle's own (onboard) controller holds the setpoint.
        Onboard = "onboard",
    } default Manual
}

string_enum! {
    /// Link health.
    LinkState {
        /// Replies arrive in time.
        Connected = "connected",
        /// Replies are late or lost now and then.
        Degraded = "degraded",
        /// No reply for longer than the loss timeout.
        Lost = "lost",
    } default Connected
}

string_enum! {
    /// Severity of an event.
    Severity {
        /// For the log.
        Info = "info",
        /// Needs attention.
        Warning = "warning",
        /// Needs action now.
        Alarm = "alarm",
    } default Info
}

/// A typed record of a JSON topic.
pub trait Record:
    Serialize + DeserializeOwned + Clone + std::fmt::Debug + PartialEq + 'static
{
    /// The topic.
    const TOPIC: Topic;
    /// The schema name (e.g. `topside.TelemetryNav`).
    const SCHEMA_NAME: &'static str;
    /// The field names, in schema order.
    const FIELDS: &'static [&'static str];
    /// The JSON Schema (draft 2020-12) of the record.
    fn json_schema() -> Value;
    /// The CSV cells of the record, in [`Record::FIELDS`] order.
    fn cells(&self) -> Vec<Cell>;
}

/// A `Write` into a `Vec` that refuses to grow past a cap.
struct CappedBuf<'a> {
    buf: &'a mut Vec<u8>,
    cap: usize,
    overflow: bool,
}

impl std::io::Write for CappedBuf<'_> {
    fn write(&mut self, data: &[u8]) -> std::io::Result<usize> {
        if self.buf.len().saturating_add(data.len()) > self.cap {
            self.overflow = true;
            return Err(std::io::Error::other("message size cap reached"));
        }
        self.buf.extend_from_slice(data);
        Ok(data.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// Encodes a record as its topic's JSON message into `out` (cleared first): the one
/// encoding of the JSON topics, used by the session writer and the live server alike.
/// Encoding stops at `max_bytes`, so an oversized record costs no more than the cap.
///
/// # Errors
/// [`SessionError::MessageTooLarge`] past the cap (`out` is then emptied and shrunk),
/// [`SessionError::Encode`] if serde refuses the record.
pub fn encode_json<T: Record>(
    record: &T,
    max_bytes: usize,
    out: &mut Vec<u8>,
) -> Result<(), SessionError> {
    out.clear();
    let mut sink = CappedBuf {
        buf: out,
        cap: max_bytes,
        overflow: false,
    };
    let res = serde_json::to_writer(&mut sink, record);
    if sink.overflow {
        out.clear();
        out.shrink_to(4096);
        return Err(SessionError::MessageTooLarge {
            topic: T::TOPIC.name().into(),
            len: max_bytes.saturating_add(1),
            max: max_bytes,
        });
    }
    res.map_err(|e| SessionError::Encode {
        topic: T::TOPIC.name().into(),
        detail: e.to_string(),
    })
}

/// Defines a record struct with its serde attributes, schema and CSV cells.
macro_rules! record {
    (
        $(#[doc = $doc:literal])*
        $name:ident : $topic:ident, $schema:literal {
            $( $(#[doc = $fdoc:literal])+ $field:ident : $ty:ty ),+ $(,)?
        }
    ) => {
        $(#[doc = $doc])*
        #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
        pub struct $name {
            $(
                $(#[doc = $fdoc])+
                #[serde(default = "crate::record::missing", deserialize_with = "crate::record::decode_field")]
                pub $field: $ty,
            )+
        }

        impl Default for $name {
            fn default() -> Self {
                Self { $($field: <$ty as Field>::missing(),)+ }
            }
        }

        impl Record for $name {
            const TOPIC: Topic = Topic::$topic;
            const SCHEMA_NAME: &'static str = $schema;
            const FIELDS: &'static [&'static str] = &[$(stringify!($field)),+];

            fn json_schema() -> Value {
                let mut props = serde_json::Map::new();
                $(
                    let mut s = <$ty as Field>::json_schema();
                    if let Value::Object(o) = &mut s {
                        let text: Vec<&str> = vec![$($fdoc.trim()),+];
                        o.insert("description".into(), Value::String(text.join(" ")));
                    }
                    props.insert(stringify!($field).into(), s);
                )+
                let doc: Vec<&str> = vec![$($doc.trim()),*];
                json!({
                    "$schema": "https://json-schema.org/draft/2020-12/schema",
                    "title": $schema,
                    "description": doc.join(" "),
                    "type": "object",
                    "properties": Value::Object(props),
                    "required": [$(stringify!($field)),+],
                })
            }

            fn cells(&self) -> Vec<Cell> {
                vec![$(Field::cell(&self.$field)),+]
            }
        }
    };
}

record! {
    /// A decoded navigation reply in physical units (`/telemetry/nav`).
    NavRecord: Nav, "topside.TelemetryNav" {
        /// Heading, degrees (0..360, clockwise from north).
        heading_deg: f64,
        /// Pitch, degrees, positive nose up.
        pitch_deg: f64,
        /// Roll, degrees, positive starboard down.
        roll_deg: f64,
        /// Pressure, mbar (absolute).
        pressure_mbar: Option<f64>,
        /// Depth, m, positive down.
        depth_m: f64,
        /// Body yaw rate r, deg/s.
        yaw_rate_dps: Option<f64>,
        /// Body pitch rate q, deg/s.
        pitch_rate_dps: Option<f64>,
        /// Body roll rate p, deg/s.
        roll_rate_dps: Option<f64>,
        /// Surge acceleration, m/s².
        surge_accel_mps2: Option<f64>,
        /// Sway acceleration, m/s².
        sway_accel_mps2: Option<f64>,
        /// Heave acceleration, m/s².
        heave_accel_mps2: Option<f64>,
        /// Magnetometer x, raw counts.
        mag_x: Option<f64>,
        /// Magnetometer y, raw counts.
        mag_y: Option<f64>,
        /// Magnetometer z, raw counts.
        mag_z: Option<f64>,
        /// Attitude sensor status bits.
        attitude_status: Option<u64>,
        /// Internal relative humidity, %.
        humidity_pct: Option<f64>,
        /// Water temperature, °C.
        water_temp_c: Option<f64>,
        /// Power level, %.
        power_pct: Option<f64>,
    }
}

record! {
    /// A decoded status dump (`/telemetry/status`).
    StatusRecord: Status, "topside.TelemetryStatus" {
        /// Water temperature, °C.
        water_temp_c: f64,
        /// Tether voltage at the vehicle, V.
        tether_v: f64,
        /// 12 V rail voltage, V.
        rail_12v_v: f64,
        /// 12 V rail current, mA.
        rail_12v_ma: f64,
        /// Internal relative humidity, %.
        humidity_pct: f64,
        /// Communication errors counted by the vehicle.
        comm_errors: u64,
    }
}

record! {
    /// A thrust command sent to the vehicle (`/command/thrust`).
    ThrustRecord: Thrust, "topside.CommandThrust" {
        /// Port thruster, % (−100..100).
        port_pct: f64,
        /// Starboard thruster, % (−100..100).
        starboard_pct: f64,
        /// Vertical thruster, % (−100..100); positive pushes down.
        vertical_pct: f64,
        /// Lights, % (0..100).
        lights_pct: f64,
        /// Camera tilt command.
        tilt: f64,
        /// Camera focus command.
        focus: f64,
        /// Onboard depth-hold target, mbar (absent: onboard depth hold off).
        depth_target_mbar: Option<f64>,
        /// Onboard heading-hold target, degrees (absent: onboard heading hold off).
        heading_target_deg: Option<f64>,
    }
}

record! {
    /// Pilot input (`/pilot/input`).
    PilotRecord: Pilot, "topside.PilotInput" {
        /// Surge stick, −1..1.
        surge: f64,
        /// Yaw stick, −1..1.
        yaw: f64,
        /// Heave stick, −1..1 (positive down).
        heave: f64,
        /// Whether the thrusters are armed.
        armed: bool,
        /// Gain, %.
        gain_pct: f64,
        /// Buttons held, by name.
        buttons: Vec<String>,
    }
}

record! {
    /// Autopilot modes and setpoints (`/autopilot/state`).
    AutopilotRecord: Autopilot, "topside.AutopilotState" {
        /// Depth channel mode.
        depth_mode: Mode,
        /// Heading channel mode.
        heading_mode: Mode,
        /// Depth setpoint, m (absent when not holding).
        depth_setpoint_m: Option<f64>,
        /// Heading setpoint, degrees (absent when not holding).
        heading_setpoint_deg: Option<f64>,
        /// Name of the feed-forward model in use (empty: none).
        feedforward_model: String,
    }
}

record! {
    /// Observer estimates (`/observer/state`).
    ObserverRecord: Observer, "topside.ObserverState" {
        /// Estimated depth, m.
        depth_m: f64,
        /// Estimated heave velocity, m/s.
        heave_mps: f64,
        /// Estimated depth-channel bias.
        depth_bias: f64,
        /// Estimated heading, degrees.
        heading_deg: f64,
        /// Estimated yaw rate, deg/s.
        yaw_rate_dps: f64,
        /// Estimated heading-channel bias.
        heading_bias: f64,
        /// Depth estimate variance, m².
        depth_var: f64,
        /// Heading estimate variance, deg².
        heading_var: f64,
    }
}

record! {
    /// Link statistics (`/link/stats`).
    LinkRecord: Link, "topside.LinkStats" {
        /// Link health.
        state: LinkState,
        /// Request/reply exchanges so far.
        exchanges: u64,
        /// Replies that did not arrive in time.
        timeouts: u64,
        /// Bytes skipped while looking for a frame start.
        sync_errors: u64,
        /// Frames with a bad header checksum.
        header_errors: u64,
        /// All errors.
        total_errors: u64,
        /// Replies that were not expected.
        unexpected: u64,
        /// Median round-trip time, ms.
        rtt_p50_ms: f64,
        /// 99th-percentile round-trip time, ms.
        rtt_p99_ms: f64,
    }
}

record! {
    /// An alarm or event (`/events`).
    EventRecord: Events, "topside.Event" {
        /// Machine-readable kind (e.g. `link_lost`).
        kind: String,
        /// Severity.
        severity: Severity,
        /// Text for the pilot.
        text: String,
    }
}

record! {
    /// Simulator truth (`/truth/state`, simulated sessions only). NaN where unknown.
    TruthRecord: Truth, "topside.TruthState" {
        /// North position, m.
        north_m: f64,
        /// East position, m.
        east_m: f64,
        /// Depth, m, positive down.
        depth_m: f64,
        /// Roll, degrees.
        roll_deg: f64,
        /// Pitch, degrees.
        pitch_deg: f64,
        /// Heading, degrees.
        heading_deg: f64,
        /// Surge velocity u, m/s.
        u_mps: f64,
        /// Sway velocity v, m/s.
        v_mps: f64,
        /// Heave velocity w, m/s.
        w_mps: f64,
        /// Roll rate p, deg/s.
        p_dps: f64,
        /// Pitch rate q, deg/s.
        q_dps: f64,
        /// Yaw rate r, deg/s.
        r_dps: f64,
    }
}

record! {
    /// Session description (`/session/info`), one message at the start.
    SessionInfo: SessionInfo, "topside.SessionInfo" {
        /// `sim`, `serial:PATH` or `import`.
        vehicle: String,
        /// Version of the software that recorded the session.
        software_version: String,
        /// Wall-clock start of the session, seconds since the Unix epoch.
        started_unix_s: f64,
        /// The configuration used, as TOML text.
        config_toml: String,
    }
}

/// The JSON Schema text of a JSON topic, `None` for the raw and Foxglove topics (see
/// [`crate::foxglove::channel_schema`] for every topic).
pub fn schema_of(topic: Topic) -> Option<(&'static str, Value)> {
    Some(match topic {
        Topic::Pro4Tx | Topic::Pro4Rx => return None,
        Topic::Transform | Topic::Pose | Topic::Track | Topic::Video => return None,
        Topic::Nav => (NavRecord::SCHEMA_NAME, NavRecord::json_schema()),
        Topic::Status => (StatusRecord::SCHEMA_NAME, StatusRecord::json_schema()),
        Topic::Thrust => (ThrustRecord::SCHEMA_NAME, ThrustRecord::json_schema()),
        Topic::Pilot => (PilotRecord::SCHEMA_NAME, PilotRecord::json_schema()),
        Topic::Autopilot => (AutopilotRecord::SCHEMA_NAME, AutopilotRecord::json_schema()),
        Topic::Observer => (ObserverRecord::SCHEMA_NAME, ObserverRecord::json_schema()),
        Topic::Link => (LinkRecord::SCHEMA_NAME, LinkRecord::json_schema()),
        Topic::Events => (EventRecord::SCHEMA_NAME, EventRecord::json_schema()),
        Topic::Truth => (TruthRecord::SCHEMA_NAME, TruthRecord::json_schema()),
        Topic::SessionInfo => (SessionInfo::SCHEMA_NAME, SessionInfo::json_schema()),
    })
}

/// The field names of a JSON topic (empty for the raw and Foxglove topics).
pub fn fields_of(topic: Topic) -> &'static [&'static str] {
    match topic {
        Topic::Pro4Tx | Topic::Pro4Rx => &[],
        Topic::Transform | Topic::Pose | Topic::Track | Topic::Video => &[],
        Topic::Nav => NavRecord::FIELDS,
        Topic::Status => StatusRecord::FIELDS,
        Topic::Thrust => ThrustRecord::FIELDS,
        Topic::Pilot => PilotRecord::FIELDS,
        Topic::Autopilot => AutopilotRecord::FIELDS,
        Topic::Observer => ObserverRecord::FIELDS,
        Topic::Link => LinkRecord::FIELDS,
        Topic::Events => EventRecord::FIELDS,
        Topic::Truth => TruthRecord::FIELDS,
        Topic::SessionInfo => SessionInfo::FIELDS,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nan_is_null_and_back() {
        let nav = NavRecord {
            depth_m: f64::NAN,
            heading_deg: 10.0,
            ..NavRecord::default()
        };
        let text = serde_json::to_string(&nav).unwrap();
        assert!(text.contains("\"depth_m\":null"), "{text}");
        let back: NavRecord = serde_json::from_str(&text).unwrap();
        assert!(back.depth_m.is_nan());
        assert_eq!(back.heading_deg, 10.0);
        assert_eq!(back.yaw_rate_dps, None);
    }

    #[test]
    fn missing_fields_take_their_missing_value() {
        let back: ThrustRecord = serde_json::from_str(r#"{"port_pct": 5}"#).unwrap();
        assert_eq!(back.port_pct, 5.0);
        assert!(back.starboard_pct.is_nan());
        assert_eq!(back.depth_target_mbar, None);
        let ap: AutopilotRecord = serde_json::from_str(r#"{"depth_mode":"hold"}"#).unwrap();
        assert_eq!(ap.depth_mode, Mode::Hold);
        assert_eq!(ap.heading_mode, Mode::Manual);
        assert!(serde_json::from_str::<AutopilotRecord>(r#"{"depth_mode":"auto"}"#).is_err());
    }

    #[test]
    fn schemas_name_every_field_with_a_description() {
        for topic in Topic::ALL {
            let Some((name, schema)) = schema_of(topic) else {
                assert!(!topic.is_json());
                continue;
            };
            assert!(name.starts_with("topside."));
            let props = schema["properties"].as_object().unwrap();
            assert_eq!(props.len(), fields_of(topic).len(), "{name}");
            for f in fields_of(topic) {
                assert!(
                    !props[*f]["description"].as_str().unwrap().is_empty(),
                    "{name}.{f}"
                );
            }
            assert_eq!(schema["type"], "object");
        }
        assert_eq!(
            LinkRecord::json_schema()["properties"]["state"]["enum"],
            json!(["connected", "degraded", "lost"])
        );
    }

    #[test]
    fn topic_names_round_trip() {
        for t in Topic::ALL {
            assert_eq!(Topic::from_name(t.name()), Some(t));
            assert_eq!(Topic::ALL[t.index()], t);
        }
        assert_eq!(Topic::from_name("/nope"), None);
    }
}
