//! The converter the BlueROV2 tank CSVs were read with before the shipped log map
//! (config/maps/bluerov2_saabmarine_mex.toml) replaced it: kept here only as the reference
//! the map is compared with, sample for sample (tests/bluerov_map.rs).
//!
//! Converter for the real BlueROV2 tank data in `shared/real_data/bluerov2_saabmarine_mex/`
//! (pilot demands plus motion-capture pose and body velocities, about 10 Hz) to the
//! measurement CSV, so the lab can run on real data.
//!
//! The data set ships without a description; its conventions were read off the data:
//! z, w and the heave demand increase together (z up, heave demand positive = ascend), and
//! the yaw demand drives r with the same sign. The pose is therefore taken as a z-up
//! (ENU/FLU) frame and converted to the CSV's NED/FRD conventions:
//!
//! * depth = −z (m, down); north = x, east = −y;
//! * heading = −yaw, pitch = −pitch (nose up positive), roll = roll (degrees);
//! * body rates p, −q, −r and velocities u, −v, −w (deg/s, m/s).
//!
//! Inputs (not a Pro 4: a BlueROV2 Heavy has eight thrusters driven through a mixer):
//! the normalised surge demand s, yaw demand y and heave demand h (each −1..1) map to the
//! Pro 4's differential pair and vertical thruster as
//!
//! * port = 100·(s − y), starboard = 100·(s + y) (a positive yaw demand turns to port,
//!   counter-clockwise seen from above; on the Pro 4 the starboard thruster pushing harder
//!   does that), clamped to ±100 %;
//! * vertical = −100·h (the Pro 4's vertical command pushes down).
//!
//! The pitch, roll and sway demands have no Pro 4 counterpart and are dropped there (runs
//! that use them show as model failures of the Pro 4 models). A row whose demands are
//! missing keeps the previous command; rows whose time does not increase are skipped and
//! counted.
//!
//! # The vehicle's own command channels
//!
//! [`bluerov_to_series_inputs`] also keeps all six demands as body-axis command channels
//! (percent of full demand, FRD/NED sign conventions like the outputs) for a vehicle file
//! (`config/vehicles/bluerov2_heavy.toml`) to mix: the data's demands follow its z-up
//! (FLU) frame — surge forward, sway to port, heave up, roll starboard down, pitch nose
//! down, yaw counter-clockwise (read off the data: each demand drives the matching
//! velocity with its sign) — so
//!
//! * surge = 100·ch5, sway = −100·ch6, heave = −100·ch3 (down positive),
//! * roll = 100·ch2, pitch = −100·ch1 (nose up positive), yaw = −100·ch4 (clockwise
//!   positive).

use rov_dynamics::models::vehicle::{CommandChannel, Commands, N_COMMANDS};
use rov_types::measurement::{MeasurementRow, MeasurementSeries, OptionalChannel};

use rov_lab::LabError;

/// A converted BlueROV2 log: the Pro 4 view, the vehicle's own command channels and what
/// was dropped.
#[derive(Debug, Clone)]
pub struct BlueRovLog {
    /// The measurement series (Pro 4 command view).
    pub series: MeasurementSeries,
    /// Every command channel per row (Pro 4 view and the six body-axis demands), %.
    pub inputs: Vec<Commands>,
    /// Which channels are present.
    pub present: [bool; N_COMMANDS],
    /// Rows dropped because their time did not increase.
    pub dropped_rows: usize,
}

fn err(label: &str, detail: String) -> LabError {
    LabError::Data {
        run: label.into(),
        detail,
    }
}

/// Converts one BlueROV2 CSV (text) to a measurement series (the Pro 4 view).
#[allow(dead_code)]
pub fn bluerov_to_series(text: &str, label: &str) -> Result<MeasurementSeries, LabError> {
    bluerov_to_series_inputs(text, label).map(|b| b.series)
}

/// Converts one BlueROV2 CSV (text) to a measurement series with the vehicle's own
/// command channels.
pub fn bluerov_to_series_inputs(text: &str, label: &str) -> Result<BlueRovLog, LabError> {
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let header: Vec<&str> = lines
        .next()
        .ok_or_else(|| err(label, "empty file".into()))?
        .split(',')
        .map(str::trim)
        .collect();
    let col = |name: &str| -> Result<usize, LabError> {
        header
            .iter()
            .position(|h| *h == name)
            .ok_or_else(|| err(label, format!("column {name} is missing")))
    };
    let idx = [
        col("t")?,
        col("x")?,
        col("y")?,
        col("z")?,
        col("roll")?,
        col("pitch")?,
        col("yaw")?,
        col("u")?,
        col("v")?,
        col("w")?,
        col("p")?,
        col("q")?,
        col("r")?,
        col("ch3_heave")?,
        col("ch4_yaw")?,
        col("ch5_surge")?,
        col("ch1_pitch")?,
        col("ch2_roll")?,
        col("ch6_sway")?,
    ];
    let mut series = MeasurementSeries {
        present: [true; 8],
        ..Default::default()
    };
    let mut prev_cmd = (0.0, 0.0, 0.0);
    let mut prev_extra = (0.0, 0.0, 0.0);
    let mut last_t = f64::NEG_INFINITY;
    let mut inputs: Vec<Commands> = Vec::new();
    let mut dropped_rows = 0usize;
    for line in lines {
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        let get = |i: usize| -> f64 {
            cells
                .get(i)
                .and_then(|c| c.parse::<f64>().ok())
                .unwrap_or(f64::NAN)
        };
        let v: Vec<f64> = idx.iter().map(|i| get(*i)).collect();
        let t = v[0];
        if !t.is_finite() {
            continue;
        }
        if t <= last_t {
            dropped_rows += 1;
            continue;
        }
        last_t = t;
        let (h, y, s) = (v[13], v[14], v[15]);
        if h.is_finite() && y.is_finite() && s.is_finite() {
            prev_cmd = (h, y, s);
        }
        let (pi, ro, sw) = (v[16], v[17], v[18]);
        if pi.is_finite() && ro.is_finite() && sw.is_finite() {
            prev_extra = (pi, ro, sw);
        }
        let (h, y, s) = prev_cmd;
        let (pi, ro, sw) = prev_extra;
        let clamp = |x: f64| (x * 100.0).clamp(-100.0, 100.0);
        let mut row = MeasurementRow {
            time_s: t,
            port_pct: clamp(s - y),
            starboard_pct: clamp(s + y),
            vertical_pct: clamp(-h),
            depth_m: -v[3],
            heading_deg: -v[6].to_degrees(),
            pitch_deg: -v[5].to_degrees(),
            roll_deg: v[4].to_degrees(),
            optional: [None; 8],
        };
        let opt = |x: f64| x.is_finite().then_some(x);
        row.set(OptionalChannel::NorthM, opt(v[1]));
        row.set(OptionalChannel::EastM, opt(-v[2]));
        row.set(OptionalChannel::SurgeMps, opt(v[7]));
        row.set(OptionalChannel::SwayMps, opt(-v[8]));
        row.set(OptionalChannel::HeaveMps, opt(-v[9]));
        row.set(OptionalChannel::RollRateDps, opt(v[10].to_degrees()));
        row.set(OptionalChannel::PitchRateDps, opt(-v[11].to_degrees()));
        row.set(OptionalChannel::YawRateDps, opt(-v[12].to_degrees()));
        let mut c = rov_lab::data::commands_of_pct(&rov_dynamics::ThrustPct::new(
            row.port_pct,
            row.starboard_pct,
            row.vertical_pct,
        ));
        let pct = |x: f64| (x * 100.0).clamp(-100.0, 100.0);
        c[CommandChannel::SURGE.index()] = pct(s);
        c[CommandChannel::SWAY.index()] = pct(-sw);
        c[CommandChannel::HEAVE.index()] = pct(-h);
        c[CommandChannel::ROLL.index()] = pct(ro);
        c[CommandChannel::PITCH.index()] = pct(-pi);
        c[CommandChannel::YAW.index()] = pct(-y);
        inputs.push(c);
        series.rows.push(row);
    }
    if series.rows.len() < 10 {
        return Err(err(
            label,
            format!("only {} usable rows", series.rows.len()),
        ));
    }
    let mut present = [true; N_COMMANDS];
    present[CommandChannel::LATERAL.index()] = false;
    Ok(BlueRovLog {
        series,
        inputs,
        present,
        dropped_rows,
    })
}
