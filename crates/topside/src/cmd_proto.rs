//! `topside proto`: decode Pro 4 tether-protocol frames from hex, or encode a
//! control request.
//!
//! `topside proto decode HEX...` prints one JSON object per line: for each frame
//! `{"direction","node","flags","addr","len","kind","fields"}`, and for each
//! stretch of bytes that is not a valid frame `{"error","offset"}` (offset in
//! bytes within that argument). The exit status is 1 if no frame was decoded.
//!
//! `kind` follows [`firmware_proto::classify`]: requests are `reboot` (write of
//! `DE AD` at 0xFE), `control` (15 bytes at 0x00, any FLAGS), `ping` (FLAGS 0x01,
//! no payload), `csr_read` (FLAGS ≥ 0x80, no payload), else `raw` (e.g. the
//! nav-only request FLAGS 0x05 without payload). Responses are `nav` (FLAGS 0x05,
//! addr 0, 34 bytes), `ping_reply` (FLAGS 0x01, addr 0, 9 bytes), `status` (dump
//! at 0x7A, 15 bytes), `config` (dump at 0xF7, 293 bytes), other dumps
//! (FLAGS ≥ 0x80) `csr_dump`, else `raw`.
//!
//! `topside proto encode control ...` prints the request frame as uppercase hex.

use std::io::Write;
use std::process::ExitCode;

use anyhow::Context;
use clap::{Args, Subcommand};
use firmware_proto::msg::ascii_text;
use firmware_proto::{
    ConfigData, ControlBlock, CsrDump, CsrRead, DeframeErrorKind, Deframer, DeframerConfig, Event,
    Frame, Message, NavReply, NodeId, PingReply, StatusBlock,
};
use serde::Serialize;

/// Arguments of `topside proto`.
#[derive(Debug, Args)]
pub struct ProtoArgs {
    #[command(subcommand)]
    command: ProtoCommand,
}

#[derive(Debug, Subcommand)]
enum ProtoCommand {
    /// Decode frames given in hex; print one JSON object per frame or bad stretch.
    Decode(DecodeArgs),
    /// Encode a request frame; print it as uppercase hex.
    Encode(EncodeArgs),
}

/// `topside proto decode HEX...`
#[derive(Debug, Args)]
struct DecodeArgs {
    /// Bytes in hex, one or more frames per argument; spaces allowed.
    #[arg(required = true, value_name = "HEX")]
    hex: Vec<String>,
}

/// `topside proto encode MESSAGE ...`
#[derive(Debug, Args)]
struct EncodeArgs {
    #[command(subcommand)]
    message: EncodeMessage,
}

#[derive(Debug, Subcommand)]
enum EncodeMessage {
    /// The control request: 15-byte control block written to CSR 0x00.
    #[command(allow_negative_numbers = true)]
    Control(ControlArgs),
}

/// `topside proto encode control ...`
#[derive(Debug, Args)]
struct ControlArgs {
    /// Port thruster, percent of power (−100..100).
    #[arg(long, value_parser = clap::value_parser!(i16).range(-100..=100))]
    port_pct: i16,
    /// Starboard thruster, percent of power (−100..100).
    #[arg(long, value_parser = clap::value_parser!(i16).range(-100..=100))]
    starboard_pct: i16,
    /// Vertical thruster, percent of power (−100..100).
    #[arg(long, value_parser = clap::value_parser!(i16).range(-100..=100))]
    vertical_pct: i16,
    /// Main lights, percent (0..100).
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u8).range(0..=100))]
    lights_pct: u8,
    /// Camera tilt, roughly degrees (−90..90).
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(i8).range(-90..=90))]
    tilt: i8,
    /// Camera focus, percent of the focal range (−100..100).
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(i8).range(-100..=100))]
    focus: i8,
    /// Auto-depth target in mbar (0..65534); off when omitted.
    #[arg(long, value_parser = clap::value_parser!(u16).range(0..=65_534))]
    depth_target_mbar: Option<u16>,
    /// Auto-heading target in whole degrees (0..359); off when omitted.
    #[arg(long, value_parser = clap::value_parser!(u16).range(0..=359))]
    heading_target_deg: Option<u16>,
    /// FLAGS: the reply asked for (5 = navigation reply, 0 = none).
    #[arg(long, default_value_t = 5)]
    flags: u8,
    /// Destination node ID (1 = the ROV).
    #[arg(long, default_value_t = 1)]
    node: u8,
}

pub fn run(args: ProtoArgs) -> anyhow::Result<ExitCode> {
    match args.command {
        ProtoCommand::Decode(args) => decode(&args),
        ProtoCommand::Encode(EncodeArgs {
            message: EncodeMessage::Control(args),
        }) => encode_control(&args),
    }
}

// ---------------------------------------------------------------------------
// encode
// ---------------------------------------------------------------------------

fn encode_control(args: &ControlArgs) -> anyhow::Result<ExitCode> {
    let block = ControlBlock {
        port_pct: args.port_pct,
        starboard_pct: args.starboard_pct,
        vertical_pct: args.vertical_pct,
        lights_pct: args.lights_pct,
        tilt_deg: args.tilt,
        focus_pct: args.focus,
        camera_control: 0,
        camera_buttons: 0,
        depth_target_mbar: args.depth_target_mbar,
        heading_target_deg: args.heading_target_deg,
    };
    // clap already enforced the ranges; this keeps the two in step.
    block.validate()?;
    let mut buf = [0u8; 32];
    let n = block.encode_request(NodeId(args.node), args.flags, &mut buf)?;
    let frame = buf
        .get(..n)
        .context("encoder returned a length past its buffer")?;
    let mut out = std::io::stdout().lock();
    writeln!(out, "{}", hex_upper(frame))?;
    Ok(ExitCode::SUCCESS)
}

/// Uppercase hex with single spaces: `FA AF 01`.
fn hex_upper(bytes: &[u8]) -> String {
    let mut s = String::with_capacity(bytes.len() * 3);
    for (i, b) in bytes.iter().enumerate() {
        if i > 0 {
            s.push(' ');
        }
        s.push_str(&format!("{b:02X}"));
    }
    s
}

// ---------------------------------------------------------------------------
// decode
// ---------------------------------------------------------------------------

/// Parses hex digits, ignoring whitespace. On failure returns a message and the
/// byte offset where the bad digit falls.
fn parse_hex(text: &str) -> Result<Vec<u8>, (String, usize)> {
    let mut bytes = Vec::with_capacity(text.len() / 2);
    let mut high: Option<u8> = None;
    for c in text.chars().filter(|c| !c.is_whitespace()) {
        let Some(nibble) = c.to_digit(16).and_then(|d| u8::try_from(d).ok()) else {
            return Err((format!("invalid hex digit {c:?}"), bytes.len()));
        };
        match high.take() {
            Some(h) => bytes.push(h << 4 | nibble),
            None => high = Some(nibble),
        }
    }
    if high.is_some() {
        return Err(("odd number of hex digits".to_owned(), bytes.len()));
    }
    Ok(bytes)
}

/// One output line.
#[derive(Debug, Serialize)]
#[serde(untagged)]
enum Line {
    Frame(FrameLine),
    Error { error: String, offset: u64 },
}

#[derive(Debug, Serialize)]
struct FrameLine {
    direction: &'static str,
    node: u8,
    flags: u8,
    addr: u8,
    len: usize,
    kind: &'static str,
    fields: Fields,
}

#[derive(Debug, Serialize)]
#[serde(untagged)]
enum Fields {
    Control(ControlFields),
    Nav(NavFields),
    PingReply(PingReplyFields),
    CsrRead(CsrReadFields),
    CsrDump(CsrDumpFields),
    Status(StatusFields),
    Config(Box<ConfigFields>),
    Empty(Empty),
    Raw(RawFields),
}

#[derive(Debug, Serialize)]
struct Empty {}

#[derive(Debug, Serialize)]
struct ControlFields {
    port_pct: i16,
    starboard_pct: i16,
    vertical_pct: i16,
    lights_pct: u8,
    tilt: i8,
    focus: i8,
    camera_control: u8,
    camera_buttons: u8,
    depth_target_mbar: Option<u16>,
    heading_target_deg: Option<u16>,
}

#[derive(Debug, Serialize)]
struct NavFields {
    heading_deg: f64,
    pitch_deg: f64,
    roll_deg: f64,
    pressure_mbar: i16,
    yaw_accel_raw: i16,
    pitch_accel_raw: i16,
    roll_accel_raw: i16,
    surge_accel_raw: i16,
    sway_accel_raw: i16,
    heave_accel_raw: i16,
    mag_x: i16,
    mag_y: i16,
    mag_z: i16,
    attitude_status: i16,
    humidity_pct: i16,
    water_temp_c: f64,
    power_pct: u8,
}

#[derive(Debug, Serialize)]
struct PingReplyFields {
    heading_deg: f64,
    pitch_deg: f64,
    roll_deg: f64,
    pressure_mbar: i16,
}

#[derive(Debug, Serialize)]
struct CsrReadFields {
    start: u8,
    /// Register bytes asked for; null for special registers (e.g. the config read).
    count: Option<usize>,
}

#[derive(Debug, Serialize)]
struct CsrDumpFields {
    start: u8,
    count: usize,
    bytes: String,
}

#[derive(Debug, Serialize)]
struct StatusFields {
    water_temp_c: f64,
    tether_v: f64,
    rail_12v_v: f64,
    rail_12v_ma: u16,
    internal_temp_cpu: u8,
    internal_temp_power: u8,
    humidity_pct: u16,
    comm_errors: u16,
}

#[derive(Debug, Serialize)]
struct ConfigFields {
    serial: String,
    bootloader_version: u16,
    device_type: u16,
    valid_app: bool,
    structure_version: u32,
    cpu_board: String,
    power_board: String,
    depth_board: String,
    camera_io_board: String,
    camera: String,
    lights: String,
    horizontal_thrusters: String,
    vertical_thrusters: String,
}

#[derive(Debug, Serialize)]
struct RawFields {
    payload: String,
}

/// A NUL-padded ASCII field as text (lossy if it is not UTF-8).
fn text(field: &[u8]) -> String {
    match ascii_text(field) {
        Some(s) => s.to_owned(),
        None => {
            let end = field.iter().position(|&b| b == 0).unwrap_or(field.len());
            String::from_utf8_lossy(field.get(..end).unwrap_or_default()).into_owned()
        }
    }
}

fn control_fields(c: &ControlBlock) -> Fields {
    Fields::Control(ControlFields {
        port_pct: c.port_pct,
        starboard_pct: c.starboard_pct,
        vertical_pct: c.vertical_pct,
        lights_pct: c.lights_pct,
        tilt: c.tilt_deg,
        focus: c.focus_pct,
        camera_control: c.camera_control,
        camera_buttons: c.camera_buttons,
        depth_target_mbar: c.depth_target_mbar,
        heading_target_deg: c.heading_target_deg,
    })
}

fn nav_fields(n: &NavReply) -> Fields {
    Fields::Nav(NavFields {
        heading_deg: n.heading_deg(),
        pitch_deg: n.pitch_deg(),
        roll_deg: n.roll_deg(),
        pressure_mbar: n.pressure_mbar,
        yaw_accel_raw: n.yaw_accel_raw,
        pitch_accel_raw: n.pitch_accel_raw,
        roll_accel_raw: n.roll_accel_raw,
        surge_accel_raw: n.surge_accel_raw,
        sway_accel_raw: n.sway_accel_raw,
        heave_accel_raw: n.heave_accel_raw,
        mag_x: n.mag_x_raw,
        mag_y: n.mag_y_raw,
        mag_z: n.mag_z_raw,
        attitude_status: n.attitude_status,
        humidity_pct: n.humidity_pct,
        water_temp_c: n.water_temp_c(),
        power_pct: n.power_pct,
    })
}

fn ping_reply_fields(p: &PingReply) -> Fields {
    Fields::PingReply(PingReplyFields {
        heading_deg: p.heading_deg(),
        pitch_deg: p.pitch_deg(),
        roll_deg: p.roll_deg(),
        pressure_mbar: p.pressure_mbar,
    })
}

fn csr_read_fields(r: &CsrRead) -> Fields {
    Fields::CsrRead(CsrReadFields {
        start: r.start,
        count: r.count(),
    })
}

fn csr_dump_fields(d: &CsrDump<'_>) -> Fields {
    Fields::CsrDump(CsrDumpFields {
        start: d.start,
        count: d.data.len(),
        bytes: hex_upper(d.data),
    })
}

fn status_fields(s: &StatusBlock) -> Fields {
    Fields::Status(StatusFields {
        water_temp_c: s.water_temp_c(),
        tether_v: s.tether_v(),
        rail_12v_v: s.rail_12v_v(),
        rail_12v_ma: s.rail_12v_ma,
        internal_temp_cpu: s.internal_temp_cpu_raw,
        internal_temp_power: s.internal_temp_power_raw,
        humidity_pct: s.humidity_pct,
        comm_errors: s.comm_errors,
    })
}

fn config_fields(c: &ConfigData) -> Fields {
    let h = &c.hardware;
    Fields::Config(Box::new(ConfigFields {
        serial: text(&c.bootloader.serial),
        bootloader_version: c.bootloader.version,
        device_type: c.bootloader.device_type,
        valid_app: c.bootloader.is_app_valid(),
        structure_version: h.structure_version,
        cpu_board: text(&h.cpu_board),
        power_board: text(&h.power_board),
        depth_board: text(&h.depth_board),
        camera_io_board: text(&h.camera_io_board),
        camera: text(&h.camera),
        lights: text(&h.lights),
        horizontal_thrusters: text(&h.horizontal_thrusters),
        vertical_thrusters: text(&h.vertical_thrusters),
    }))
}

fn frame_line(frame: &Frame<'_>) -> FrameLine {
    let message = Message::decode(frame);
    let fields = match &message {
        Message::Control(c) => control_fields(c),
        Message::Nav(n) => nav_fields(n),
        Message::PingReply(p) => ping_reply_fields(p),
        Message::CsrRead(r) => csr_read_fields(r),
        Message::CsrDump(d) => csr_dump_fields(d),
        Message::Status(s) => status_fields(s),
        Message::Config(c) => config_fields(c),
        Message::Ping | Message::Reboot => Fields::Empty(Empty {}),
        Message::Raw => Fields::Raw(RawFields {
            payload: hex_upper(frame.payload()),
        }),
    };
    FrameLine {
        direction: frame.direction().as_str(),
        node: frame.node().0,
        flags: frame.flags(),
        addr: frame.addr(),
        len: frame.payload_len(),
        kind: message.kind().as_str(),
        fields,
    }
}

/// A run of dropped bytes, merged across consecutive deframer errors.
struct BadStretch {
    first: DeframeErrorKind,
    offset: u64,
    len: u64,
}

impl BadStretch {
    fn line(&self) -> Line {
        let plural = if self.len == 1 { "" } else { "s" };
        Line::Error {
            error: format!("{}; {} byte{plural} skipped", self.first, self.len),
            offset: self.offset,
        }
    }
}

/// Decodes one argument's bytes into output lines; returns the number of frames.
fn decode_bytes(bytes: &[u8], lines: &mut Vec<Line>) -> usize {
    let mut deframer = Deframer::new(DeframerConfig::default());
    let mut stretch: Option<BadStretch> = None;
    let mut frames = 0;
    let mut on_event = |event: Event<'_>, lines: &mut Vec<Line>| match event {
        Event::Frame { frame, .. } => {
            if let Some(s) = stretch.take() {
                lines.push(s.line());
            }
            lines.push(Line::Frame(frame_line(&frame)));
            frames += 1;
        }
        Event::Error(err) => match &mut stretch {
            Some(s) if s.offset + s.len == err.offset => s.len += err.len,
            _ => {
                if let Some(s) = stretch.replace(BadStretch {
                    first: err.kind,
                    offset: err.offset,
                    len: err.len,
                }) {
                    lines.push(s.line());
                }
            }
        },
    };
    // All bytes arrive at once: no stall can occur.
    deframer.push(bytes, 0, |e| on_event(e, lines));
    while let Some(e) = deframer.finish() {
        on_event(e, lines);
    }
    if let Some(s) = stretch.take() {
        lines.push(s.line());
    }
    frames
}

fn decode(args: &DecodeArgs) -> anyhow::Result<ExitCode> {
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    let mut frames = 0;
    for arg in &args.hex {
        let mut lines = Vec::new();
        match parse_hex(arg) {
            Ok(bytes) => frames += decode_bytes(&bytes, &mut lines),
            Err((error, offset)) => lines.push(Line::Error {
                error,
                offset: offset as u64,
            }),
        }
        for line in &lines {
            serde_json::to_writer(&mut out, line)?;
            out.write_all(b"\n")?;
        }
    }
    out.flush()?;
    Ok(if frames == 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hex_parsing() {
        assert_eq!(parse_hex("fa AF\t01"), Ok(vec![0xFA, 0xAF, 0x01]));
        assert_eq!(parse_hex(""), Ok(vec![]));
        assert_eq!(
            parse_hex("FA AG"),
            Err(("invalid hex digit 'G'".to_owned(), 1))
        );
        assert_eq!(
            parse_hex("FAA"),
            Err(("odd number of hex digits".to_owned(), 1))
        );
        assert_eq!(hex_upper(&[0xFA, 0x0F]), "FA 0F");
    }

    #[test]
    fn adjacent_errors_merge_into_one_stretch() {
        // C2: a header-check failure followed by 22 bytes of garbage.
        let bytes =
            parse_hex("FA AF 01 05 00 0F A1 32 00 CE FF 19 00 4B E2 00 00 00 FF FF FF FF B3")
                .unwrap();
        let mut lines = Vec::new();
        assert_eq!(decode_bytes(&bytes, &mut lines), 0);
        let json: Vec<String> = lines
            .iter()
            .map(|l| serde_json::to_string(l).unwrap())
            .collect();
        assert_eq!(
            json,
            [r#"{"error":"header check mismatch; 23 bytes skipped","offset":0}"#]
        );
    }
}
