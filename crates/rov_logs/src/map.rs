//! The log map: how a log's fields become the lab's signals and command channels.
//!
//! ```toml
//! format = "csv"          # csv | dataflash | tlog | ros1 | mcap; optional: detected from the log's first bytes
//! [time]
//! field = "time_s"        # csv column; dataflash "MSG.TimeUS" (every message's own time field);
//!                         # tlog "tlog.timestamp_us" (record time, the default) or "MESSAGE.field";
//!                         # ros1/mcap "@log_time" (default) or "/imu:header.stamp" (see rostopic)
//! scale = 1.0             # to seconds (default 1; 1e-6 for a DataFlash TimeUS or tlog µs)
//! [commands.thr1]         # a command channel of the vehicle file (any name)
//! field = "thr1_pwm_us"
//! pwm = [1100, 1500, 1900]   # µs at full reverse, neutral, full forward → −100..100 %
//! # or: scale = 100.0, offset = 0.0 (value · scale + offset, percent)
//! # or: terms = [{ field = "surge", scale = 100.0 }, { field = "yaw", scale = -100.0 }]
//! [signals]
//! depth_m = { field = "depth_m" }
//! pitch_deg = { field = "pitch", unit = "rad", scale = -1.0 }
//! heading_deg = { quaternion = ["qw", "qx", "qy", "qz"], frame = "enu" }
//! depth_m = { pressure_pa = "BARO[1].Press", density_kg_m3 = 1000.0 }
//! # ROS 1 bags and MCAP (ROS 2 bags): fields are "/topic:path"
//! yaw_rate_dps = { field = "/imu:angular_velocity.z", unit = "rad", frame = "flu" }
//! [commands.thr3]
//! field = "/mavros/rc/out:channels[2]"
//! ```
//!
//! A signal's value is computed in this order: the field (or the pressure, or the
//! quaternion's angle) → `unit = "rad"` to degrees (angles and rates) → `frame` to
//! NED/FRD → `· scale + offset`. `frame = "enu"` (or `"flu"`, the same axes: z up, y to
//! the left, ROS REP 103) flips depth, heave, sway, the pitch angle, pitch and yaw rates,
//! and turns an ENU yaw (from east, counter-clockwise) into a heading (90° − yaw); for a
//! quaternion it converts the whole rotation (ENU/FLU to NED/FRD) before taking angles.
//! Pressure to depth: (p·`pressure_scale` − `surface_pa`)/(`density_kg_m3`·9.80665), with
//! the density 1000 kg/m³ by default (fresh water, as ArduSub's `BARO_SPEC_GRAV` = 1) and
//! the surface pressure by default the first pressure sample (the vehicle at the surface
//! when logging starts — set `surface_pa` when it is not).
//!
//! A command is in percent, −100..100: a value outside is clamped and counted.

use std::collections::{BTreeMap, BTreeSet};

use crate::{Format, Log, LogError, ReadOptions, ReadReport, Series};

/// The lab's canonical signals, as the map's `[signals]` keys spell them.
pub const SIGNALS: [&str; 12] = [
    "depth_m",
    "heading_deg",
    "pitch_deg",
    "roll_deg",
    "roll_rate_dps",
    "pitch_rate_dps",
    "yaw_rate_dps",
    "surge_mps",
    "sway_mps",
    "heave_mps",
    "north_m",
    "east_m",
];

/// Standard gravity, m/s².
pub const G_M_S2: f64 = 9.80665;
/// Default `[time] merge_s`, s: a logger writes the messages of one control-loop pass
/// (ArduSub's 400 Hz loop: 2.5 ms) a few ms apart; samples within 10 ms of a row's first
/// time are one row (a 100 Hz signal still gets a row per sample). Set 0 to keep every
/// distinct time as its own row.
pub const DEFAULT_MERGE_S: f64 = 0.01;

/// Default water density for pressure → depth, kg/m³ (fresh water).
pub const DEFAULT_DENSITY_KG_M3: f64 = 1000.0;

/// Axes convention of a mapped field.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Frame {
    /// North-east-down world, forward-right-down body (the lab's own).
    Ned,
    /// East-north-up world, forward-left-up body (ROS REP 103).
    Enu,
}

/// Where a signal's raw value comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum Source {
    /// One field.
    Field(String),
    /// A pressure field, Pa after `scale_to_pa`, turned into depth.
    Pressure {
        /// The field.
        field: String,
        /// Factor to Pa.
        scale_to_pa: f64,
        /// Water density, kg/m³.
        density_kg_m3: f64,
        /// Pressure at the surface, Pa (`None`: the first sample).
        surface_pa: Option<f64>,
    },
    /// A quaternion's fields, w x y z.
    Quaternion([String; 4]),
}

/// How one signal is computed.
#[derive(Debug, Clone, PartialEq)]
pub struct SignalSpec {
    /// Canonical name.
    pub name: String,
    /// Raw value.
    pub source: Source,
    /// The field is in radians (angles, rates).
    pub radians: bool,
    /// The field's axes.
    pub frame: Frame,
    /// Scale after conversion.
    pub scale: f64,
    /// Offset after scaling.
    pub offset: f64,
}

/// How one command channel is computed.
#[derive(Debug, Clone, PartialEq)]
pub struct CommandSpec {
    /// Channel name (a vehicle file's command channel).
    pub name: String,
    /// Fields and their factors, summed (one field: factor `scale`).
    pub terms: Vec<(String, f64)>,
    /// PWM µs at full reverse, neutral and full forward (applied to the field first).
    pub pwm: Option<[f64; 3]>,
    /// Offset, percent.
    pub offset: f64,
}

/// A parsed log map.
#[derive(Debug, Clone, PartialEq)]
pub struct LogMap {
    /// The map's label (file name), for messages.
    pub label: String,
    /// The log format (`None`: detected).
    pub format: Option<Format>,
    /// The time field.
    pub time_field: Option<String>,
    /// Factor to seconds.
    pub time_scale: Option<f64>,
    /// Measurement times closer than this (s) after a row's first time share that row
    /// (`[time] merge_s`, default [`DEFAULT_MERGE_S`]).
    pub merge_s: f64,
    /// Command channels, in the map's order.
    pub commands: Vec<CommandSpec>,
    /// Signals.
    pub signals: Vec<SignalSpec>,
}

fn map_err(file: &str, key: &str, value: impl std::fmt::Display, detail: &str) -> LogError {
    LogError::Map {
        file: file.into(),
        key: key.into(),
        value: value.to_string(),
        detail: detail.into(),
    }
}

fn num(file: &str, key: &str, v: &toml::Value) -> Result<f64, LogError> {
    let x = match v {
        toml::Value::Float(f) => *f,
        toml::Value::Integer(i) => *i as f64,
        other => return Err(map_err(file, key, other, "expected a number")),
    };
    if !x.is_finite() {
        return Err(map_err(file, key, v, "expected a finite number"));
    }
    Ok(x)
}

fn string(file: &str, key: &str, v: &toml::Value) -> Result<String, LogError> {
    match v {
        toml::Value::String(s) if !s.trim().is_empty() => Ok(s.clone()),
        other => Err(map_err(
            file,
            key,
            other,
            "expected a field name (a non-empty string)",
        )),
    }
}

fn table<'a>(file: &str, key: &str, v: &'a toml::Value) -> Result<&'a toml::Table, LogError> {
    v.as_table()
        .ok_or_else(|| map_err(file, key, v, "expected a table"))
}

fn check_keys(file: &str, key: &str, t: &toml::Table, allowed: &[&str]) -> Result<(), LogError> {
    for (k, v) in t {
        if !allowed.contains(&k.as_str()) {
            return Err(map_err(
                file,
                &join(key, k),
                v,
                &format!("unknown key; allowed: {}", allowed.join(", ")),
            ));
        }
    }
    Ok(())
}

fn join(a: &str, b: &str) -> String {
    if a.is_empty() {
        b.to_string()
    } else {
        format!("{a}.{b}")
    }
}

impl LogMap {
    /// Parses a map (TOML text); `label` names the file in errors.
    pub fn parse(text: &str, label: &str) -> Result<Self, LogError> {
        let f = label;
        let root: toml::Table = text.parse().map_err(|e: toml::de::Error| LogError::Map {
            file: f.into(),
            key: "(syntax)".into(),
            value: String::new(),
            detail: e.to_string().trim().to_string(),
        })?;
        check_keys(f, "", &root, &["format", "time", "commands", "signals"])?;
        let format = match root.get("format") {
            None => None,
            Some(v) => {
                let s = string(f, "format", v)?;
                Some(Format::parse(&s).ok_or_else(|| {
                    map_err(
                        f,
                        "format",
                        v,
                        &format!("unknown format; allowed: {}", Format::NAMES.join(" | ")),
                    )
                })?)
            }
        };
        let (mut time_field, mut time_scale) = (None, None);
        let mut merge_s = DEFAULT_MERGE_S;
        if let Some(v) = root.get("time") {
            let t = table(f, "time", v)?;
            check_keys(f, "time", t, &["field", "scale", "merge_s"])?;
            if let Some(v) = t.get("merge_s") {
                let x = num(f, "time.merge_s", v)?;
                if !(0.0..=1.0).contains(&x) {
                    return Err(map_err(
                        f,
                        "time.merge_s",
                        v,
                        "must be 0..1 s (measurement times closer than this share a row)",
                    ));
                }
                merge_s = x;
            }
            if let Some(v) = t.get("field") {
                time_field = Some(string(f, "time.field", v)?);
            }
            if let Some(v) = t.get("scale") {
                let x = num(f, "time.scale", v)?;
                if x <= 0.0 {
                    return Err(map_err(
                        f,
                        "time.scale",
                        v,
                        "must be > 0 (factor to seconds)",
                    ));
                }
                time_scale = Some(x);
            }
        }
        let mut commands = Vec::new();
        if let Some(v) = root.get("commands") {
            for (name, spec) in table(f, "commands", v)? {
                commands.push(parse_command(f, name, spec)?);
            }
        }
        let mut signals = Vec::new();
        if let Some(v) = root.get("signals") {
            for (name, spec) in table(f, "signals", v)? {
                signals.push(parse_signal(f, name, spec)?);
            }
        }
        if commands.is_empty() && signals.is_empty() {
            return Err(map_err(
                f,
                "commands/signals",
                "(none)",
                "a map needs at least one [commands.NAME] or [signals] entry",
            ));
        }
        Ok(Self {
            label: label.into(),
            format,
            time_field,
            time_scale,
            merge_s,
            commands,
            signals,
        })
    }

    /// Every field the map reads.
    pub fn fields(&self) -> BTreeSet<String> {
        let mut out = BTreeSet::new();
        for c in &self.commands {
            out.extend(c.terms.iter().map(|(f, _)| f.clone()));
        }
        for s in &self.signals {
            match &s.source {
                Source::Field(x) | Source::Pressure { field: x, .. } => {
                    out.insert(x.clone());
                }
                Source::Quaternion(q) => out.extend(q.iter().cloned()),
            }
        }
        out
    }

    /// The reader options this map asks for (its time field, only its fields).
    pub fn read_options(&self) -> ReadOptions {
        ReadOptions {
            time_field: self.time_field.clone(),
            time_scale: self.time_scale,
            only: Some(self.fields()),
        }
    }

    /// Reads a log with this map and applies it.
    pub fn read_apply(&self, bytes: &[u8], log_label: &str) -> Result<MappedLog, LogError> {
        let log = crate::read(bytes, self.format, log_label, &self.read_options())?;
        // Names of everything the log has, for the missing-field message.
        let present = || -> Vec<String> {
            let all = crate::read(
                bytes,
                self.format,
                log_label,
                &ReadOptions {
                    only: None,
                    ..self.read_options()
                },
            );
            all.map(|l| l.fields.into_keys().collect())
                .unwrap_or_default()
        };
        self.apply_with(&log, log_label, present)
    }

    /// Applies the map to a log read with all its fields.
    pub fn apply(&self, log: &Log, log_label: &str) -> Result<MappedLog, LogError> {
        self.apply_with(log, log_label, || log.fields.keys().cloned().collect())
    }

    fn apply_with(
        &self,
        log: &Log,
        log_label: &str,
        present: impl Fn() -> Vec<String>,
    ) -> Result<MappedLog, LogError> {
        let get = |key: &str, field: &str| -> Result<&Series, LogError> {
            log.fields.get(field).ok_or_else(|| LogError::MissingField {
                file: self.label.clone(),
                key: key.into(),
                field: field.into(),
                log: log_label.into(),
                present: present(),
            })
        };
        let mut out = MappedLog {
            report: log.report.clone(),
            merge_s: self.merge_s,
            ..Default::default()
        };
        for c in &self.commands {
            let key = format!("commands.{}", c.name);
            let mut series: Vec<&Series> = Vec::new();
            for (field, _) in &c.terms {
                series.push(get(&key, field)?);
            }
            let Some(first) = series.first() else {
                continue;
            };
            let mut s = Series::default();
            let mut clamped = 0usize;
            let mut cursors = vec![0usize; series.len()];
            for (k, t) in first.t_s.iter().enumerate() {
                let mut sum = 0.0;
                let mut ok = true;
                for (j, ((_, factor), ser)) in c.terms.iter().zip(&series).enumerate() {
                    let raw = if j == 0 {
                        first.v.get(k).copied()
                    } else {
                        hold_at(ser, *t, &mut cursors[j])
                    };
                    let Some(raw) = raw else {
                        ok = false;
                        break;
                    };
                    let x = match c.pwm {
                        Some(p) => pwm_pct(raw, p),
                        None => raw,
                    };
                    sum += x * factor;
                }
                if !ok {
                    continue;
                }
                let v = sum + c.offset;
                if !v.is_finite() {
                    continue;
                }
                let cl = v.clamp(-100.0, 100.0);
                if cl != v {
                    clamped += 1;
                }
                s.t_s.push(*t);
                s.v.push(cl);
            }
            if clamped > 0 {
                out.clamped.insert(c.name.clone(), clamped);
            }
            out.commands.insert(c.name.clone(), s);
        }
        for sig in &self.signals {
            let key = format!("signals.{}", sig.name);
            let raw: Series = match &sig.source {
                Source::Field(f) => get(&key, f)?.clone(),
                Source::Pressure {
                    field,
                    scale_to_pa,
                    density_kg_m3,
                    surface_pa,
                } => {
                    let p = get(&key, field)?;
                    let p0 = surface_pa.or_else(|| p.v.first().map(|x| x * scale_to_pa));
                    let mut s = Series::default();
                    if let Some(p0) = p0 {
                        for (t, v) in p.t_s.iter().zip(&p.v) {
                            s.push(*t, (v * scale_to_pa - p0) / (density_kg_m3 * G_M_S2));
                        }
                    }
                    s
                }
                Source::Quaternion(q) => {
                    let parts = [
                        get(&key, &q[0])?,
                        get(&key, &q[1])?,
                        get(&key, &q[2])?,
                        get(&key, &q[3])?,
                    ];
                    quaternion_angle(&parts, &sig.name, sig.frame)
                }
            };
            let quaternion = matches!(sig.source, Source::Quaternion(_));
            let mut s = Series::default();
            for (t, v) in raw.t_s.iter().zip(&raw.v) {
                let mut x = *v;
                if sig.radians && !quaternion {
                    x = x.to_degrees();
                }
                if !quaternion {
                    x = to_ned(&sig.name, sig.frame, x);
                }
                x = x * sig.scale + sig.offset;
                if x.is_finite() {
                    s.push(*t, x);
                }
            }
            out.signals.insert(sig.name.clone(), s);
        }
        Ok(out)
    }
}

/// The value of a series held from its last sample at or before `t` (a cursor that only
/// moves forward makes a pass over increasing times linear).
fn hold_at(s: &Series, t: f64, cursor: &mut usize) -> Option<f64> {
    while s.t_s.get(*cursor + 1).is_some_and(|x| *x <= t) {
        *cursor += 1;
    }
    match s.t_s.get(*cursor) {
        Some(x) if *x <= t => s.v.get(*cursor).copied(),
        _ => None,
    }
}

/// PWM µs to percent with the reverse and forward halves scaled separately.
pub fn pwm_pct(us: f64, [lo, mid, hi]: [f64; 3]) -> f64 {
    if us >= mid {
        100.0 * (us - mid) / (hi - mid)
    } else {
        100.0 * (us - mid) / (mid - lo)
    }
}

/// A scalar signal from ENU/FLU to NED/FRD (module docs).
fn to_ned(name: &str, frame: Frame, x: f64) -> f64 {
    if frame == Frame::Ned {
        return x;
    }
    match name {
        "depth_m" | "heave_mps" | "sway_mps" | "pitch_deg" | "pitch_rate_dps" | "yaw_rate_dps" => {
            -x
        }
        "heading_deg" => 90.0 - x,
        _ => x,
    }
}

/// The roll, pitch or heading (deg) of quaternion samples taken at the same times.
fn quaternion_angle(parts: &[&Series; 4], name: &str, frame: Frame) -> Series {
    let mut out = Series::default();
    let [w, x, y, z] = parts;
    let (mut cx, mut cy, mut cz) = (0usize, 0usize, 0usize);
    for (t, qw) in w.t_s.iter().zip(&w.v) {
        let at = |s: &Series, c: &mut usize| -> Option<f64> {
            while s.t_s.get(*c).is_some_and(|v| v < t) {
                *c += 1;
            }
            (s.t_s.get(*c) == Some(t))
                .then(|| s.v.get(*c).copied())
                .flatten()
        };
        let (Some(qx), Some(qy), Some(qz)) = (at(x, &mut cx), at(y, &mut cy), at(z, &mut cz))
        else {
            continue;
        };
        let n = (qw * qw + qx * qx + qy * qy + qz * qz).sqrt();
        if n.is_nan() || n <= 1e-9 {
            continue;
        }
        let (a, b, c, d) = (qw / n, qx / n, qy / n, qz / n);
        // Rotation matrix (frame from body).
        let mut r = [
            [
                1.0 - 2.0 * (c * c + d * d),
                2.0 * (b * c - a * d),
                2.0 * (b * d + a * c),
            ],
            [
                2.0 * (b * c + a * d),
                1.0 - 2.0 * (b * b + d * d),
                2.0 * (c * d - a * b),
            ],
            [
                2.0 * (b * d - a * c),
                2.0 * (c * d + a * b),
                1.0 - 2.0 * (b * b + c * c),
            ],
        ];
        if frame == Frame::Enu {
            // NED from ENU swaps x and y and negates z (rows); FLU from FRD negates y and
            // z (columns).
            let e = r;
            r = [
                [e[1][0], -e[1][1], -e[1][2]],
                [e[0][0], -e[0][1], -e[0][2]],
                [-e[2][0], e[2][1], e[2][2]],
            ];
        }
        let v = match name {
            "roll_deg" => r[2][1].atan2(r[2][2]).to_degrees(),
            "pitch_deg" => (-r[2][0]).clamp(-1.0, 1.0).asin().to_degrees(),
            _ => r[1][0].atan2(r[0][0]).to_degrees(),
        };
        out.push(*t, v);
    }
    out
}

fn parse_command(f: &str, name: &str, spec: &toml::Value) -> Result<CommandSpec, LogError> {
    let key = format!("commands.{name}");
    let t = table(f, &key, spec)?;
    check_keys(f, &key, t, &["field", "pwm", "scale", "offset", "terms"])?;
    let scale = match t.get("scale") {
        Some(v) => num(f, &join(&key, "scale"), v)?,
        None => 1.0,
    };
    let offset = match t.get("offset") {
        Some(v) => num(f, &join(&key, "offset"), v)?,
        None => 0.0,
    };
    let pwm = match t.get("pwm") {
        None => None,
        Some(v) => {
            let k = join(&key, "pwm");
            let a = v
                .as_array()
                .filter(|a| a.len() == 3)
                .ok_or_else(|| map_err(f, &k, v, "expected [reverse, neutral, forward] in µs"))?;
            let p = [num(f, &k, &a[0])?, num(f, &k, &a[1])?, num(f, &k, &a[2])?];
            if !(p[0] < p[1] && p[1] < p[2]) {
                return Err(map_err(
                    f,
                    &k,
                    v,
                    "needs reverse < neutral < forward (flip a thruster with scale = -1.0)",
                ));
            }
            Some(p)
        }
    };
    let terms = match (t.get("field"), t.get("terms")) {
        (Some(v), None) => vec![(string(f, &join(&key, "field"), v)?, scale)],
        (None, Some(v)) => {
            let k = join(&key, "terms");
            let arr = v
                .as_array()
                .filter(|a| !a.is_empty())
                .ok_or_else(|| map_err(f, &k, v, "expected [{ field = \"…\", scale = … }, …]"))?;
            let mut out = Vec::new();
            for (i, item) in arr.iter().enumerate() {
                let ki = format!("{k}[{i}]");
                let it = table(f, &ki, item)?;
                check_keys(f, &ki, it, &["field", "scale"])?;
                let field = it
                    .get("field")
                    .ok_or_else(|| map_err(f, &ki, item, "needs `field`"))
                    .and_then(|v| string(f, &join(&ki, "field"), v))?;
                let s = match it.get("scale") {
                    Some(v) => num(f, &join(&ki, "scale"), v)?,
                    None => 1.0,
                };
                out.push((field, s * scale));
            }
            out
        }
        (Some(_), Some(v)) => {
            return Err(map_err(
                f,
                &join(&key, "terms"),
                v,
                "give `field` or `terms`, not both",
            ));
        }
        (None, None) => {
            return Err(map_err(f, &key, spec, "needs `field` (or `terms`)"));
        }
    };
    Ok(CommandSpec {
        name: name.into(),
        terms,
        pwm,
        offset,
    })
}

fn parse_signal(f: &str, name: &str, spec: &toml::Value) -> Result<SignalSpec, LogError> {
    let key = format!("signals.{name}");
    if !SIGNALS.contains(&name) {
        return Err(map_err(
            f,
            &key,
            spec,
            &format!("unknown signal; allowed: {}", SIGNALS.join(" ")),
        ));
    }
    let t = table(f, &key, spec)?;
    check_keys(
        f,
        &key,
        t,
        &[
            "field",
            "scale",
            "offset",
            "unit",
            "frame",
            "pressure_pa",
            "pressure_scale",
            "density_kg_m3",
            "surface_pa",
            "quaternion",
        ],
    )?;
    let g = |k: &str, d: f64| -> Result<f64, LogError> {
        t.get(k).map_or(Ok(d), |v| num(f, &join(&key, k), v))
    };
    let scale = g("scale", 1.0)?;
    let offset = g("offset", 0.0)?;
    let radians = match t.get("unit") {
        None => false,
        Some(v) => match v.as_str() {
            Some("rad") | Some("rad/s") => true,
            Some("deg") | Some("deg/s") | Some("m") | Some("m/s") => false,
            _ => {
                return Err(map_err(
                    f,
                    &join(&key, "unit"),
                    v,
                    "allowed: rad, rad/s (converted to degrees), deg, deg/s, m, m/s",
                ));
            }
        },
    };
    let frame = match t.get("frame") {
        None => Frame::Ned,
        Some(v) => match v.as_str().map(str::to_ascii_lowercase).as_deref() {
            Some("ned") | Some("frd") => Frame::Ned,
            Some("enu") | Some("flu") => Frame::Enu,
            _ => {
                return Err(map_err(
                    f,
                    &join(&key, "frame"),
                    v,
                    "allowed: ned, frd, enu, flu",
                ));
            }
        },
    };
    let source = match (t.get("field"), t.get("pressure_pa"), t.get("quaternion")) {
        (Some(v), None, None) => Source::Field(string(f, &join(&key, "field"), v)?),
        (None, Some(v), None) => {
            if name != "depth_m" {
                return Err(map_err(
                    f,
                    &join(&key, "pressure_pa"),
                    v,
                    "only depth_m comes from a pressure",
                ));
            }
            let density = g("density_kg_m3", DEFAULT_DENSITY_KG_M3)?;
            if !(500.0..=2000.0).contains(&density) {
                return Err(map_err(
                    f,
                    &join(&key, "density_kg_m3"),
                    density,
                    "allowed 500..2000 kg/m³ (fresh water 997-1000, sea water about 1025)",
                ));
            }
            let scale_to_pa = g("pressure_scale", 1.0)?;
            if scale_to_pa <= 0.0 {
                return Err(map_err(
                    f,
                    &join(&key, "pressure_scale"),
                    scale_to_pa,
                    "must be > 0 (factor to Pa)",
                ));
            }
            Source::Pressure {
                field: string(f, &join(&key, "pressure_pa"), v)?,
                scale_to_pa,
                density_kg_m3: density,
                surface_pa: t
                    .get("surface_pa")
                    .map(|v| num(f, &join(&key, "surface_pa"), v))
                    .transpose()?,
            }
        }
        (None, None, Some(v)) => {
            let k = join(&key, "quaternion");
            if !matches!(name, "roll_deg" | "pitch_deg" | "heading_deg") {
                return Err(map_err(
                    f,
                    &k,
                    v,
                    "a quaternion gives roll_deg, pitch_deg or heading_deg",
                ));
            }
            let a = v
                .as_array()
                .filter(|a| a.len() == 4)
                .ok_or_else(|| map_err(f, &k, v, "expected four field names [w, x, y, z]"))?;
            Source::Quaternion([
                string(f, &k, &a[0])?,
                string(f, &k, &a[1])?,
                string(f, &k, &a[2])?,
                string(f, &k, &a[3])?,
            ])
        }
        (None, None, None) => {
            return Err(map_err(
                f,
                &key,
                spec,
                "needs `field`, `pressure_pa` or `quaternion`",
            ));
        }
        _ => {
            return Err(map_err(
                f,
                &key,
                spec,
                "give one of `field`, `pressure_pa`, `quaternion`",
            ));
        }
    };
    Ok(SignalSpec {
        name: name.into(),
        source,
        radians,
        frame,
        scale,
        offset,
    })
}

/// A log through its map: each command channel and signal as its own timestamped series.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MappedLog {
    /// Command channels, percent.
    pub commands: BTreeMap<String, Series>,
    /// Canonical signals (NED/FRD, degrees, metres).
    pub signals: BTreeMap<String, Series>,
    /// Command samples clamped to ±100 %, per channel.
    pub clamped: BTreeMap<String, usize>,
    /// What the reader met.
    pub report: ReadReport,
    /// The map's `[time] merge_s`.
    pub merge_s: f64,
}

/// The lab's table of a mapped log: one row per measurement time.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LabTable {
    /// Row times, s: the times at which some signal was measured (times within the map's
    /// `merge_s` after a row's first time share that row), from the first time at which
    /// every command channel has a sample.
    pub t_s: Vec<f64>,
    /// Each signal at the row times (NaN where it was not measured at that time).
    pub signals: BTreeMap<String, Vec<f64>>,
    /// Each command channel held from its last sample at or before the end of the row's
    /// merge window (row time + `merge_s`: a command logged in the same pass counts).
    pub commands: BTreeMap<String, Vec<f64>>,
    /// Measurement times dropped because some command had no sample yet.
    pub rows_before_commands: usize,
}

impl MappedLog {
    /// The report in words: the reader's, and the clamped commands.
    pub fn sentences(&self) -> Vec<String> {
        let mut out = self.report.sentences();
        for (c, n) in &self.clamped {
            out.push(format!("command {c}: {n} sample(s) outside ±100 % clamped"));
        }
        out
    }

    /// The lab's table: rows at the measurement times (never an invented measurement),
    /// commands resampled by zero-order hold. Rows before every command has its first
    /// sample are dropped (a command is not invented either) and counted.
    pub fn lab_table(&self) -> LabTable {
        let mut times: Vec<f64> = self
            .signals
            .values()
            .flat_map(|s| s.t_s.iter().copied())
            .collect();
        times.sort_by(f64::total_cmp);
        times.dedup();
        // Rows: a time more than merge_s after the current row's first time starts a row.
        let mut rows: Vec<f64> = Vec::with_capacity(times.len());
        for t in times {
            if rows.last().is_none_or(|r| t - r > self.merge_s) {
                rows.push(t);
            }
        }
        let start = self
            .commands
            .values()
            .map(|s| s.t_s.first().copied().unwrap_or(f64::INFINITY))
            .fold(f64::NEG_INFINITY, f64::max);
        // A row whose samples began up to merge_s before the last command's first sample
        // keeps it (the command's first sample belongs to that pass of the logger).
        let before = rows
            .iter()
            .take_while(|t| **t + self.merge_s < start)
            .count();
        let times: Vec<f64> = rows.split_off(before.min(rows.len()));
        let mut table = LabTable {
            rows_before_commands: before,
            ..Default::default()
        };
        for (name, s) in &self.signals {
            let mut col = vec![f64::NAN; times.len()];
            let mut k = 0usize;
            for (t, v) in s.t_s.iter().zip(&s.v) {
                // The row of this sample: the last row starting at or before it.
                while times.get(k + 1).is_some_and(|x| x <= t) {
                    k += 1;
                }
                let Some(row_t) = times.get(k) else { break };
                // Before the first row, or after the row's merge window: no row.
                if t < row_t || *t - row_t > self.merge_s {
                    continue;
                }
                // One sample per signal and row: the first.
                if let Some(c) = col.get_mut(k)
                    && c.is_nan()
                {
                    *c = *v;
                }
            }
            table.signals.insert(name.clone(), col);
        }
        for (name, s) in &self.commands {
            let mut cursor = 0usize;
            let col: Vec<f64> = times
                .iter()
                .map(|t| hold_at(s, *t + self.merge_s, &mut cursor).unwrap_or(f64::NAN))
                .collect();
            table.commands.insert(name.clone(), col);
        }
        table.t_s = times;
        table
    }
}
