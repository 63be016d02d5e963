//! Shared helpers of the session tests: a deterministic dive with every topic, and the
//! official Python MCAP reader.
#![allow(dead_code)]

use std::path::Path;
use std::process::Command;

use rov_session::{
    AutopilotRecord, Direction, EventRecord, LinkRecord, LinkState, Mode, NavRecord,
    ObserverRecord, PilotRecord, SessionInfo, SessionWriter, Severity, StatusRecord, ThrustRecord,
    TruthRecord, WriterOptions,
};

pub const TICK_NS: u64 = 20_000_000;

pub fn info() -> SessionInfo {
    SessionInfo {
        vehicle: "sim".into(),
        software_version: "topside test".into(),
        started_unix_s: 1_750_000_000.25,
        config_toml: "[link]\nport = \"sim\"\nperiod_ms = 20\n".into(),
    }
}

/// Everything recorded in one 50 Hz tick (some topics only every n-th tick).
#[derive(Debug, Clone, PartialEq)]
pub struct Tick {
    pub t_ns: u64,
    pub tx: Vec<u8>,
    pub rx: Vec<u8>,
    pub nav: NavRecord,
    pub thrust: ThrustRecord,
    pub pilot: PilotRecord,
    pub autopilot: AutopilotRecord,
    pub observer: ObserverRecord,
    pub truth: TruthRecord,
    pub status: Option<StatusRecord>,
    pub link: Option<LinkRecord>,
    pub event: Option<EventRecord>,
}

pub fn tick(k: u64) -> Tick {
    let t = k as f64 * 0.02;
    let t_ns = k * TICK_NS;
    let depth = 5.0 + 2.0 * (0.05 * t).sin();
    let heading = (30.0 + 7.0 * t).rem_euclid(360.0);
    let port = (40.0 * (0.3 * t).sin()).round();
    let nav = NavRecord {
        heading_deg: heading,
        pitch_deg: 2.0 * (0.7 * t).sin(),
        roll_deg: -1.5 * (0.4 * t).cos(),
        pressure_mbar: Some(1013.25 + depth * 100.5),
        depth_m: depth,
        yaw_rate_dps: Some(7.0 + 0.1 * (t).sin()),
        pitch_rate_dps: Some(1.4 * (0.7 * t).cos()),
        roll_rate_dps: Some(0.6 * (0.4 * t).sin()),
        surge_accel_mps2: Some(0.01 * k as f64 % 0.3),
        sway_accel_mps2: Some(-0.02),
        heave_accel_mps2: Some(9.81),
        mag_x: Some(374.0),
        mag_y: Some(-699.0),
        mag_z: Some(1953.0),
        attitude_status: Some(k % 3),
        humidity_pct: Some(35.0),
        water_temp_c: Some(15.25),
        power_pct: Some(100.0),
    };
    let thrust = ThrustRecord {
        port_pct: port,
        starboard_pct: -port / 2.0,
        vertical_pct: (20.0 * (0.05 * t).cos()).round(),
        lights_pct: 50.0,
        tilt: 0.0,
        focus: 0.0,
        depth_target_mbar: k.is_multiple_of(2).then_some(1515.0),
        heading_target_deg: None,
    };
    let pilot = PilotRecord {
        surge: (0.3 * t).sin(),
        yaw: 0.1,
        heave: -0.2,
        armed: k > 10,
        gain_pct: 60.0,
        buttons: if k.is_multiple_of(100) {
            vec!["a".into(), "lb".into()]
        } else {
            vec![]
        },
    };
    let autopilot = AutopilotRecord {
        depth_mode: if k % 1000 < 500 {
            Mode::Hold
        } else {
            Mode::Manual
        },
        heading_mode: Mode::Onboard,
        depth_setpoint_m: Some(5.0),
        heading_setpoint_deg: None,
        feedforward_model: "model3".into(),
    };
    let observer = ObserverRecord {
        depth_m: depth + 0.01,
        heave_mps: 0.1 * (0.05 * t).cos(),
        depth_bias: 0.02,
        heading_deg: heading,
        yaw_rate_dps: 7.0,
        heading_bias: -0.1,
        depth_var: 1e-4,
        heading_var: 0.25,
    };
    let truth = TruthRecord {
        north_m: 0.1 * t,
        east_m: -0.05 * t,
        depth_m: depth,
        roll_deg: nav.roll_deg,
        pitch_deg: nav.pitch_deg,
        heading_deg: heading,
        u_mps: 0.3,
        v_mps: 0.01,
        w_mps: 0.1 * (0.05 * t).cos(),
        p_dps: 0.0,
        q_dps: 0.0,
        r_dps: 7.0,
    };
    let status = k.is_multiple_of(50).then_some(StatusRecord {
        water_temp_c: 15.25,
        tether_v: 340.0 - (k / 50) as f64 * 0.01,
        rail_12v_v: 12.1,
        rail_12v_ma: 850.0,
        humidity_pct: 35.0,
        comm_errors: k / 500,
    });
    let link = (k % 50 == 25).then_some(LinkRecord {
        state: LinkState::Connected,
        exchanges: k,
        timeouts: k / 1000,
        sync_errors: 0,
        header_errors: 0,
        total_errors: k / 1000,
        unexpected: 0,
        rtt_p50_ms: 6.5,
        rtt_p99_ms: 11.0,
    });
    let event = (k % 500 == 7).then(|| EventRecord {
        kind: "depth_hold".into(),
        severity: Severity::Info,
        text: format!("depth hold engaged, setpoint 5.0 m (tick {k})"),
    });
    let tx = {
        let mut f = vec![0xFA, 0xAF, 0x01, 0x05, 0x00, 0x0F];
        f.extend((0..17).map(|i| (k as u8).wrapping_add(i)));
        f
    };
    let rx = {
        let mut f = vec![0xFD, 0xDF, 0x01, 0x05, 0x00, 0x22];
        f.extend((0..36).map(|i| (k as u8).wrapping_mul(3).wrapping_add(i)));
        f
    };
    Tick {
        t_ns,
        tx,
        rx,
        nav,
        thrust,
        pilot,
        autopilot,
        observer,
        truth,
        status,
        link,
        event,
    }
}

/// Writes one tick in the order the station would (frames, decoded reply, command, …).
pub fn write_tick(w: &mut SessionWriter, tk: &Tick) -> rov_session::Result<()> {
    let t = tk.t_ns;
    w.write_raw(Direction::Tx, t, &tk.tx)?;
    w.write_raw(Direction::Rx, t + 6_000_000, &tk.rx)?;
    w.write(t + 6_000_000, &tk.nav)?;
    w.write(t + 6_000_000, &tk.truth)?;
    w.write(t + 6_100_000, &tk.observer)?;
    w.write(t + 6_100_000, &tk.pilot)?;
    w.write(t + 6_100_000, &tk.autopilot)?;
    w.write(t + 6_200_000, &tk.thrust)?;
    if let Some(s) = &tk.status {
        w.write(t + 7_000_000, s)?;
    }
    if let Some(l) = &tk.link {
        w.write(t + 7_000_000, l)?;
    }
    if let Some(e) = &tk.event {
        w.write(t + 7_000_000, e)?;
    }
    Ok(())
}

/// Records `ticks` ticks to `path` and finishes the file.
pub fn record(path: &Path, ticks: u64, opts: WriterOptions) -> Vec<Tick> {
    let mut w = SessionWriter::create_with(path, &info(), 0, opts).expect("create");
    let all: Vec<Tick> = (0..ticks).map(tick).collect();
    for tk in &all {
        write_tick(&mut w, tk).expect("write");
    }
    w.finish().expect("finish");
    all
}

/// Runs the official Python `mcap` reader on a file: JSON with the count per topic, the
/// first nav message and the schema encoding of each topic.
pub fn python_read(path: &Path) -> serde_json::Value {
    let probe = Command::new("python3").args(["-c", "import mcap"]).output();
    match probe {
        Ok(o) if o.status.success() => {}
        Ok(o) => panic!(
            "the official Python MCAP reader is missing ({}); run scripts/setup.sh \
             (it runs `python3 -m pip install mcap`)",
            String::from_utf8_lossy(&o.stderr).trim()
        ),
        Err(e) => panic!("python3 is not available ({e}); run scripts/setup.sh"),
    }
    let script = r#"
import collections, json, sys
from mcap.reader import make_reader
counts = collections.Counter()
encodings = {}
first = {}
with open(sys.argv[1], "rb") as f:
    reader = make_reader(f, validate_crcs=True)
    summary = reader.get_summary()
    for schema, channel, message in reader.iter_messages():
        counts[channel.topic] += 1
        encodings[channel.topic] = [channel.message_encoding, schema.encoding if schema else ""]
        if channel.topic not in first and channel.message_encoding == "json":
            first[channel.topic] = json.loads(message.data)
    attachments = [a.name for a in reader.iter_attachments()]
    metadata = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
print(json.dumps({
    "counts": counts,
    "encodings": encodings,
    "first": first,
    "attachments": attachments,
    "metadata": metadata,
    "summary_messages": summary.statistics.message_count if summary and summary.statistics else None,
}))
"#;
    python_json(script, path)
}

/// Runs a Python script on a file; its stdout as JSON.
pub fn python_json(script: &str, path: &Path) -> serde_json::Value {
    let out = Command::new("python3")
        .args(["-c", script])
        .arg(path)
        .output()
        .expect("run python3");
    assert!(
        out.status.success(),
        "the Python mcap reader failed on {} (scripts/setup.sh installs mcap and \
         mcap-protobuf-support):\n{}",
        path.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("python output is JSON")
}
