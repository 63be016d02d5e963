//! Station alarms with pilot-set limits, latched until the pilot acknowledges them.
//!
//! Each alarm has a cause that the runtime evaluates every control tick (never in a GUI
//! frame). The limit alarms (humidity level and rate of rise, maximum depth, tether
//! turns, tether and 12 V voltage, internal temperature) have two levels the pilot sets
//! in the station configuration (`[alarms]` of `config/station.toml`, or the Settings
//! page): a warning and an alarm. When a cause appears the alarm is raised (active,
//! unacknowledged); a warning that grows into an alarm is raised again. It stays in the
//! list after the cause goes away until it is acknowledged; acknowledging an alarm whose
//! cause is still present keeps it listed (acknowledged, so the GUI stops flashing it)
//! until the cause clears. Levels have hysteresis so a value on a limit does not
//! chatter.
//!
//! These are the pilot's alarms; the link's own failsafe alarm (which gates thrust and
//! clears only by re-arming) is separate and unaffected by acknowledging.

use rov_types::params::{ConfigError, ParamFile};
use serde::Serialize;

/// An alarm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
pub enum AlarmKind {
    /// No valid reply from the vehicle for the loss timeout.
    LinkLost,
    /// Internal humidity above its limit.
    HumidityHigh,
    /// Internal humidity rising fast (a leak).
    HumidityRising,
    /// Deeper than the depth limit.
    DepthMax,
    /// Too many tether turns.
    TetherTurns,
    /// Tether voltage low.
    TetherVoltageLow,
    /// 12 V rail low.
    RailVoltageLow,
    /// Internal temperature high.
    InternalTempHigh,
    /// Navigation telemetry older than the stale limit while the link is up, or the
    /// controller flags a depth or heading sensor as lost.
    SensorStale,
    /// The control tick ran late by more than three periods (watchdog sent neutral).
    ControlStall,
    /// The model watch found the vehicle changed during the dive (a thruster losing
    /// thrust, weight taken on, drag, a snag, a sensor fault); the words are in
    /// [`crate::runtime::view::WatchView`]. Latched for the rest of the dive (the
    /// vehicle stays changed); a new change raises it again.
    VehicleChanged,
}

impl AlarmKind {
    /// Every alarm, in display priority order.
    pub const ALL: [AlarmKind; 11] = [
        AlarmKind::LinkLost,
        AlarmKind::ControlStall,
        AlarmKind::VehicleChanged,
        AlarmKind::HumidityRising,
        AlarmKind::HumidityHigh,
        AlarmKind::DepthMax,
        AlarmKind::TetherVoltageLow,
        AlarmKind::RailVoltageLow,
        AlarmKind::InternalTempHigh,
        AlarmKind::TetherTurns,
        AlarmKind::SensorStale,
    ];

    /// Short text for the pilot.
    #[must_use]
    pub const fn text(self) -> &'static str {
        match self {
            AlarmKind::LinkLost => "LINK LOST",
            AlarmKind::HumidityHigh => "HUMIDITY HIGH",
            AlarmKind::HumidityRising => "HUMIDITY RISING (LEAK?)",
            AlarmKind::DepthMax => "DEPTH LIMIT",
            AlarmKind::TetherTurns => "TETHER TURNS",
            AlarmKind::TetherVoltageLow => "TETHER VOLTAGE LOW",
            AlarmKind::RailVoltageLow => "12 V LOW",
            AlarmKind::InternalTempHigh => "INTERNAL TEMP HIGH",
            AlarmKind::SensorStale => "SENSOR STALE",
            AlarmKind::ControlStall => "CONTROL STALL",
            AlarmKind::VehicleChanged => "VEHICLE CHANGED",
        }
    }

    /// Machine-readable name (session events).
    #[must_use]
    pub const fn key(self) -> &'static str {
        match self {
            AlarmKind::LinkLost => "link_lost",
            AlarmKind::HumidityHigh => "humidity_high",
            AlarmKind::HumidityRising => "humidity_rising",
            AlarmKind::DepthMax => "depth_max",
            AlarmKind::TetherTurns => "tether_turns",
            AlarmKind::TetherVoltageLow => "tether_voltage_low",
            AlarmKind::RailVoltageLow => "rail_voltage_low",
            AlarmKind::InternalTempHigh => "internal_temp_high",
            AlarmKind::SensorStale => "sensor_stale",
            AlarmKind::ControlStall => "control_stall",
            AlarmKind::VehicleChanged => "vehicle_changed",
        }
    }

    /// A limit on the low side (voltages): the value alarms below it.
    #[must_use]
    pub const fn is_low_limit(self) -> bool {
        matches!(
            self,
            AlarmKind::TetherVoltageLow | AlarmKind::RailVoltageLow
        )
    }

    /// The unit of the value a limit alarm watches.
    #[must_use]
    pub const fn unit(self) -> &'static str {
        match self {
            AlarmKind::HumidityHigh => "%",
            AlarmKind::HumidityRising => "%/min",
            AlarmKind::DepthMax => "m",
            AlarmKind::TetherTurns => "turns",
            AlarmKind::TetherVoltageLow | AlarmKind::RailVoltageLow => "V",
            AlarmKind::InternalTempHigh => "°C",
            AlarmKind::VehicleChanged => "noise floors",
            _ => "",
        }
    }
}

/// How serious.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
pub enum AlarmLevel {
    /// Watch it (amber).
    Warning,
    /// Act now (red).
    Alarm,
}

/// A warning and an alarm level. For a high limit the alarm level is above the warning
/// level; for a low limit (voltages) below it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Limit {
    /// Warning level.
    pub warn: f64,
    /// Alarm level.
    pub alarm: f64,
}

/// The pilot's limits.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AlarmConfig {
    /// Internal humidity, % (high).
    pub humidity_pct: Limit,
    /// Internal humidity rate of rise over one minute, %/min (high).
    pub humidity_rise_pct_per_min: Limit,
    /// Depth, m (high).
    pub depth_m: Limit,
    /// Tether turns either way (high).
    pub tether_turns: Limit,
    /// Tether voltage, V (low).
    pub tether_v: Limit,
    /// 12 V rail, V (low).
    pub rail_12v_v: Limit,
    /// Internal temperature, °C (high).
    pub internal_temp_c: Limit,
    /// Navigation telemetry older than this is stale, s.
    pub stale_after_s: f64,
}

impl Default for AlarmConfig {
    /// Defaults: humidity 45/60 % and 1/2 %/min (a sealed Pro 4 reads a steady 20-40 %);
    /// depth 250/290 m (the Pro 4 is rated to 305 m); tether turns 2/4; tether 66/60 V
    /// (about 75 V at no load); 12 V rail 11.5/11.0 V; internal temperature 50/60 °C.
    fn default() -> Self {
        Self {
            humidity_pct: Limit {
                warn: 45.0,
                alarm: 60.0,
            },
            humidity_rise_pct_per_min: Limit {
                warn: 1.0,
                alarm: 2.0,
            },
            depth_m: Limit {
                warn: 250.0,
                alarm: 290.0,
            },
            tether_turns: Limit {
                warn: 2.0,
                alarm: 4.0,
            },
            tether_v: Limit {
                warn: 66.0,
                alarm: 60.0,
            },
            rail_12v_v: Limit {
                warn: 11.5,
                alarm: 11.0,
            },
            internal_temp_c: Limit {
                warn: 50.0,
                alarm: 60.0,
            },
            stale_after_s: 1.0,
        }
    }
}

/// One limit's keys, range, direction and hysteresis.
struct LimitSpec {
    name: &'static str,
    unit: &'static str,
    range: (f64, f64),
    high: bool,
    hysteresis: f64,
    /// The hysteresis is at most this fraction of the threshold it applies to, so a
    /// limit set low (a 3 m depth limit in a tank) is not held a third of its value
    /// away (issue 25: "DEPTH LIMIT warning 2.5 m (limit 3.0)" with 1 m of hysteresis).
    hysteresis_frac: f64,
}

impl LimitSpec {
    /// The hysteresis (in the limit's unit) about `threshold`.
    fn hysteresis_at(&self, threshold: f64) -> f64 {
        self.hysteresis.min(self.hysteresis_frac * threshold.abs())
    }
}

const SPECS: [LimitSpec; 7] = [
    LimitSpec {
        name: "humidity",
        unit: "pct",
        range: (0.0, 100.0),
        high: true,
        hysteresis: 3.0,
        hysteresis_frac: 1.0,
    },
    LimitSpec {
        name: "humidity_rise",
        unit: "pct_per_min",
        range: (0.0, 100.0),
        high: true,
        hysteresis: 0.3,
        hysteresis_frac: 1.0,
    },
    LimitSpec {
        name: "depth",
        unit: "m",
        range: (0.0, 1000.0),
        high: true,
        // 1 m at the default 250 m; 5 % of a low limit (0.15 m at 3 m): more than the
        // pressure sensor's noise (1.5 cm) and a hold's ripple, well inside the limit.
        hysteresis: 1.0,
        hysteresis_frac: 0.05,
    },
    LimitSpec {
        name: "tether_turns",
        unit: "",
        range: (0.0, 100.0),
        high: true,
        hysteresis: 0.25,
        hysteresis_frac: 1.0,
    },
    LimitSpec {
        name: "tether",
        unit: "v",
        range: (0.0, 400.0),
        high: false,
        hysteresis: 3.0,
        hysteresis_frac: 1.0,
    },
    LimitSpec {
        name: "rail_12v",
        unit: "v",
        range: (0.0, 30.0),
        high: false,
        hysteresis: 0.4,
        hysteresis_frac: 1.0,
    },
    LimitSpec {
        name: "internal_temp",
        unit: "c",
        range: (-40.0, 150.0),
        high: true,
        hysteresis: 2.0,
        hysteresis_frac: 1.0,
    },
];

impl AlarmConfig {
    fn limits(&self) -> [Limit; 7] {
        [
            self.humidity_pct,
            self.humidity_rise_pct_per_min,
            self.depth_m,
            self.tether_turns,
            self.tether_v,
            self.rail_12v_v,
            self.internal_temp_c,
        ]
    }

    fn limits_mut(&mut self) -> [&mut Limit; 7] {
        [
            &mut self.humidity_pct,
            &mut self.humidity_rise_pct_per_min,
            &mut self.depth_m,
            &mut self.tether_turns,
            &mut self.tether_v,
            &mut self.rail_12v_v,
            &mut self.internal_temp_c,
        ]
    }

    /// The TOML key of a limit level under `[alarms]`, e.g. `depth_warn_m`.
    fn key(spec: &LimitSpec, level: &str) -> String {
        if spec.unit.is_empty() {
            format!("{}_{level}", spec.name)
        } else {
            format!("{}_{level}_{}", spec.name, spec.unit)
        }
    }

    /// Reads `[alarms]` (every key optional, the defaults above otherwise). Every error
    /// names the file, the key, the value and the allowed range; a warning level on the
    /// wrong side of its alarm level is refused too, and unknown keys are rejected.
    ///
    /// # Errors
    /// [`ConfigError`] as above.
    pub fn from_param_file(f: &ParamFile) -> Result<Self, ConfigError> {
        let mut cfg = Self::default();
        for (spec, limit) in SPECS.iter().zip(cfg.limits_mut()) {
            let range = spec.range.0..=spec.range.1;
            let wk = format!("alarms.{}", Self::key(spec, "warn"));
            let ak = format!("alarms.{}", Self::key(spec, "alarm"));
            limit.warn = f.f64_or(&wk, range.clone(), limit.warn)?;
            limit.alarm = f.f64_or(&ak, range, limit.alarm)?;
            let ordered = if spec.high {
                limit.warn <= limit.alarm
            } else {
                limit.warn >= limit.alarm
            };
            if !ordered {
                return Err(ConfigError::OutOfRange {
                    file: f.file().to_string(),
                    key: wk,
                    value: format!("{}", limit.warn),
                    allowed: format!(
                        "{} {ak} = {} (the warning comes before the alarm)",
                        if spec.high { "at most" } else { "at least" },
                        limit.alarm
                    ),
                });
            }
        }
        cfg.stale_after_s = f.f64_or("alarms.stale_after_s", 0.1..=60.0, cfg.stale_after_s)?;
        f.reject_unknown("alarms")?;
        Ok(cfg)
    }

    /// The `[alarms]` table as TOML text (the keys [`AlarmConfig::from_param_file`]
    /// reads).
    #[must_use]
    pub fn to_toml(&self) -> String {
        let mut out = String::new();
        for (spec, l) in SPECS.iter().zip(self.limits()) {
            out.push_str(&format!("{} = {:?}\n", Self::key(spec, "warn"), l.warn));
            out.push_str(&format!("{} = {:?}\n", Self::key(spec, "alarm"), l.alarm));
        }
        out.push_str(&format!("stale_after_s = {:?}\n", self.stale_after_s));
        out
    }
}

/// An alarm in the list.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AlarmState {
    /// Which.
    pub kind: AlarmKind,
    /// How serious (the highest level while active).
    pub level: AlarmLevel,
    /// Raised at, station time s.
    pub raised_s: f64,
    /// The cause is present now.
    pub active: bool,
    /// The pilot acknowledged it.
    pub acknowledged: bool,
    /// The watched value when last evaluated (limit alarms).
    pub value: Option<f64>,
    /// The limit crossed (limit alarms).
    pub limit: Option<f64>,
    /// Where the level held now lets go (the limit less its hysteresis; limit alarms
    /// while active).
    pub clears_at: Option<f64>,
}

impl AlarmState {
    /// The pilot's line for it, every number with its unit: "DEPTH LIMIT warning 2.95 m
    /// (limit 3.00 m, clears below 2.85 m)".
    #[must_use]
    pub fn describe(&self) -> String {
        let level = match self.level {
            AlarmLevel::Alarm => "",
            AlarmLevel::Warning => " warning",
        };
        let unit = self.kind.unit();
        let sp = if unit.is_empty() { "" } else { " " };
        let value = match (self.value, self.limit) {
            (Some(v), Some(l)) => {
                let clears = match self.clears_at.filter(|_| self.active) {
                    Some(c) => {
                        let side = if self.kind.is_low_limit() {
                            "above"
                        } else {
                            "below"
                        };
                        format!(", clears {side} {c:.2}{sp}{unit}")
                    }
                    None => String::new(),
                };
                format!(" {v:.2}{sp}{unit} (limit {l:.2}{sp}{unit}{clears})")
            }
            (Some(v), None) => format!(" {v:.2}{sp}{unit}"),
            _ => String::new(),
        };
        let state = if self.active { "" } else { " (cleared)" };
        format!("{}{level}{value}{state}", self.kind.text())
    }
}

/// Alarm transitions for the event log.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AlarmChange {
    /// Raised (or grown from a warning into an alarm).
    Raised(AlarmKind, AlarmLevel),
    /// Cause gone (still latched until acknowledged).
    Cleared(AlarmKind),
}

/// The alarm list.
#[derive(Debug, Clone, Default)]
pub struct Alarms {
    list: Vec<AlarmState>,
    cfg: AlarmConfig,
    humidity: std::collections::VecDeque<(f64, f64)>,
    humidity_rate: Option<f64>,
}

/// Inputs of one evaluation.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AlarmInputs {
    /// Link lost now.
    pub link_lost: bool,
    /// The link has been connected at least once (before that, "lost" is "not yet").
    pub ever_connected: bool,
    /// Humidity, %.
    pub humidity_pct: Option<f64>,
    /// Depth, m.
    pub depth_m: Option<f64>,
    /// Tether turns since the last reset.
    pub turns: Option<f64>,
    /// Tether voltage, V.
    pub tether_v: Option<f64>,
    /// 12 V rail, V.
    pub rail_v: Option<f64>,
    /// Internal temperature, °C.
    pub internal_temp_c: Option<f64>,
    /// Age of the last navigation reply, s (None: none yet).
    pub nav_age_s: Option<f64>,
    /// The controller flags a sensor as lost.
    pub sensor_fault: bool,
    /// The watchdog tripped since the last evaluation.
    pub control_stall: bool,
    /// The model watch's latest change, its size in noise floors (None: no change).
    pub vehicle_changed_noise: Option<f64>,
}

impl Alarms {
    /// With limits.
    #[must_use]
    pub fn new(cfg: AlarmConfig) -> Self {
        Self {
            cfg,
            ..Self::default()
        }
    }

    /// New limits (take effect at the next evaluation).
    pub fn set_config(&mut self, cfg: AlarmConfig) {
        self.cfg = cfg;
    }

    /// The limits in force.
    #[must_use]
    pub const fn config(&self) -> &AlarmConfig {
        &self.cfg
    }

    /// The list, in display priority order (unacknowledged first, alarms before
    /// warnings).
    #[must_use]
    pub fn list(&self) -> Vec<AlarmState> {
        let mut l = self.list.clone();
        l.sort_by_key(|a| {
            (
                a.acknowledged,
                std::cmp::Reverse(a.level),
                AlarmKind::ALL.iter().position(|k| *k == a.kind),
            )
        });
        l
    }

    /// Writes the list into `out` (reusing its memory).
    pub fn list_into(&self, out: &mut Vec<AlarmState>) {
        out.clear();
        out.extend_from_slice(&self.list);
        out.sort_by_key(|a| {
            (
                a.acknowledged,
                std::cmp::Reverse(a.level),
                AlarmKind::ALL.iter().position(|k| *k == a.kind),
            )
        });
    }

    /// Whether an alarm is listed and not acknowledged.
    #[must_use]
    pub fn unacknowledged(&self) -> usize {
        self.list.iter().filter(|a| !a.acknowledged).count()
    }

    /// Humidity rate of rise over the last minute, %/min.
    #[must_use]
    pub const fn humidity_rate_pct_per_min(&self) -> Option<f64> {
        self.humidity_rate
    }

    /// Acknowledges one alarm (`None`: all). Alarms whose cause is gone disappear.
    pub fn acknowledge(&mut self, kind: Option<AlarmKind>) {
        for a in &mut self.list {
            if kind.is_none_or(|k| k == a.kind) {
                a.acknowledged = true;
            }
        }
        self.list.retain(|a| a.active || !a.acknowledged);
    }

    fn level_of(&self, kind: AlarmKind) -> Option<AlarmLevel> {
        self.list
            .iter()
            .find(|a| a.kind == kind && a.active)
            .map(|a| a.level)
    }

    /// Sets a cause: `level` None means absent.
    fn set(
        &mut self,
        kind: AlarmKind,
        level: Option<AlarmLevel>,
        value: Option<f64>,
        limit: Option<f64>,
        now_s: f64,
        out: &mut Vec<AlarmChange>,
    ) {
        match (self.list.iter_mut().find(|a| a.kind == kind), level) {
            (Some(a), Some(l)) => {
                if !a.active || l > a.level {
                    a.acknowledged = false;
                    a.raised_s = now_s;
                    out.push(AlarmChange::Raised(kind, l));
                }
                a.active = true;
                a.level = l;
                a.value = value;
                a.limit = limit;
            }
            (Some(a), None) => {
                if a.active {
                    a.active = false;
                    out.push(AlarmChange::Cleared(kind));
                }
                a.value = value;
            }
            (None, Some(l)) => {
                self.list.push(AlarmState {
                    kind,
                    level: l,
                    raised_s: now_s,
                    active: true,
                    acknowledged: false,
                    value,
                    limit,
                    clears_at: None,
                });
                out.push(AlarmChange::Raised(kind, l));
            }
            (None, None) => {}
        }
        self.list.retain(|a| a.active || !a.acknowledged);
    }

    /// Evaluates a limit: the level now, with hysteresis from the level it had.
    fn limit(
        &mut self,
        kind: AlarmKind,
        spec: usize,
        value: Option<f64>,
        now_s: f64,
        out: &mut Vec<AlarmChange>,
    ) {
        let Some(v) = value.filter(|v| v.is_finite()) else {
            return;
        };
        let (Some(s), Some(l)) = (SPECS.get(spec), self.cfg.limits().get(spec).copied()) else {
            return;
        };
        let was = self.level_of(kind);
        // Past a level: v beyond it; once there, it holds until v is back by the
        // hysteresis.
        let past = |threshold: f64, held: bool| {
            let t = if held {
                if s.high {
                    threshold - s.hysteresis_at(threshold)
                } else {
                    threshold + s.hysteresis_at(threshold)
                }
            } else {
                threshold
            };
            if s.high { v >= t } else { v <= t }
        };
        let level = if past(l.alarm, was == Some(AlarmLevel::Alarm)) {
            Some(AlarmLevel::Alarm)
        } else if past(l.warn, was.is_some()) {
            Some(AlarmLevel::Warning)
        } else {
            None
        };
        let limit = match level {
            Some(AlarmLevel::Alarm) => Some(l.alarm),
            Some(AlarmLevel::Warning) => Some(l.warn),
            None => None,
        };
        self.set(kind, level, Some(v), limit, now_s, out);
        let clears_at = limit.map(|t| {
            let h = s.hysteresis_at(t);
            if s.high { t - h } else { t + h }
        });
        if let Some(a) = self.list.iter_mut().find(|a| a.kind == kind) {
            a.clears_at = clears_at;
        }
    }

    /// Evaluates the causes at `now_s`; returns the transitions.
    pub fn evaluate(&mut self, now_s: f64, i: &AlarmInputs) -> Vec<AlarmChange> {
        let mut out = Vec::new();
        let on = |b: bool| b.then_some(AlarmLevel::Alarm);
        self.set(
            AlarmKind::LinkLost,
            on(i.link_lost && i.ever_connected),
            None,
            None,
            now_s,
            &mut out,
        );
        if let Some(h) = i.humidity_pct.filter(|h| h.is_finite()) {
            self.limit(AlarmKind::HumidityHigh, 0, Some(h), now_s, &mut out);
            // Rate over a one-minute window, sampled at most once a second.
            if self.humidity.back().is_none_or(|(t, _)| now_s - t >= 1.0) {
                self.humidity.push_back((now_s, h));
            }
            while self.humidity.front().is_some_and(|(t, _)| now_s - t > 60.0) {
                self.humidity.pop_front();
            }
            self.humidity_rate = match (self.humidity.front(), self.humidity.back()) {
                (Some((t0, h0)), Some((t1, h1))) if t1 - t0 >= 10.0 => {
                    Some((h1 - h0) / (t1 - t0) * 60.0)
                }
                _ => None,
            };
            let rate = self.humidity_rate;
            self.limit(AlarmKind::HumidityRising, 1, rate, now_s, &mut out);
        }
        self.limit(AlarmKind::DepthMax, 2, i.depth_m, now_s, &mut out);
        self.limit(
            AlarmKind::TetherTurns,
            3,
            i.turns.map(f64::abs),
            now_s,
            &mut out,
        );
        self.limit(AlarmKind::TetherVoltageLow, 4, i.tether_v, now_s, &mut out);
        self.limit(AlarmKind::RailVoltageLow, 5, i.rail_v, now_s, &mut out);
        self.limit(
            AlarmKind::InternalTempHigh,
            6,
            i.internal_temp_c,
            now_s,
            &mut out,
        );
        let stale = !i.link_lost
            && i.ever_connected
            && (i.nav_age_s.is_some_and(|a| a > self.cfg.stale_after_s) || i.sensor_fault);
        self.set(
            AlarmKind::SensorStale,
            on(stale),
            None,
            None,
            now_s,
            &mut out,
        );
        self.set(
            AlarmKind::ControlStall,
            on(i.control_stall),
            None,
            None,
            now_s,
            &mut out,
        );
        self.set(
            AlarmKind::VehicleChanged,
            i.vehicle_changed_noise.map(|_| AlarmLevel::Warning),
            i.vehicle_changed_noise,
            None,
            now_s,
            &mut out,
        );
        out
    }

    /// Forgets an alarm so its cause, still present, raises it anew at the next
    /// evaluation (a second change of the vehicle is news).
    pub fn reraise(&mut self, kind: AlarmKind) {
        self.list.retain(|a| a.kind != kind);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn alarms_latch_until_acknowledged() {
        let mut a = Alarms::new(AlarmConfig::default());
        let mut i = AlarmInputs {
            ever_connected: true,
            link_lost: true,
            ..AlarmInputs::default()
        };
        assert_eq!(
            a.evaluate(1.0, &i),
            vec![AlarmChange::Raised(AlarmKind::LinkLost, AlarmLevel::Alarm)]
        );
        i.link_lost = false;
        assert_eq!(
            a.evaluate(2.0, &i),
            vec![AlarmChange::Cleared(AlarmKind::LinkLost)]
        );
        // Still listed (latched) after the cause cleared.
        assert_eq!(a.list().len(), 1);
        assert!(!a.list()[0].active);
        a.acknowledge(None);
        assert!(a.list().is_empty());
        // Acknowledged while active: stays listed until the cause clears.
        i.link_lost = true;
        a.evaluate(3.0, &i);
        a.acknowledge(Some(AlarmKind::LinkLost));
        assert_eq!(a.list().len(), 1);
        assert_eq!(a.unacknowledged(), 0);
        i.link_lost = false;
        a.evaluate(4.0, &i);
        assert!(a.list().is_empty());
    }

    #[test]
    fn a_low_depth_limit_lets_go_close_to_its_level_and_says_where() {
        // A tank's 3 m warning: 1 m of hysteresis held the warning at 2.5 m ("DEPTH
        // LIMIT warning 2.5 m (limit 3.0)"); now 5 % of the level, 0.15 m.
        let mut a = Alarms::new(AlarmConfig {
            depth_m: Limit {
                warn: 3.0,
                alarm: 3.5,
            },
            ..AlarmConfig::default()
        });
        let depth = |d: f64| AlarmInputs {
            ever_connected: true,
            depth_m: Some(d),
            ..AlarmInputs::default()
        };
        a.evaluate(0.0, &depth(3.05));
        let w = a.list()[0];
        assert_eq!(w.level, AlarmLevel::Warning);
        assert_eq!(
            w.describe(),
            "DEPTH LIMIT warning 3.05 m (limit 3.00 m, clears below 2.85 m)"
        );
        a.evaluate(1.0, &depth(2.9));
        assert!(a.list()[0].active, "inside the band: held");
        a.evaluate(2.0, &depth(2.5));
        assert!(!a.list()[0].active, "2.5 m is well clear of a 3 m limit");
        assert_eq!(
            a.list()[0].describe(),
            "DEPTH LIMIT warning 2.50 m (limit 3.00 m) (cleared)"
        );
        // The default 250 m limit keeps its 1 m.
        let mut a = Alarms::new(AlarmConfig::default());
        a.evaluate(0.0, &depth(251.0));
        a.evaluate(1.0, &depth(249.2));
        assert!(a.list()[0].active);
        assert_eq!(a.list()[0].clears_at, Some(249.0));
        // Voltages clear above.
        let mut a = Alarms::new(AlarmConfig::default());
        a.evaluate(
            0.0,
            &AlarmInputs {
                ever_connected: true,
                tether_v: Some(65.0),
                ..AlarmInputs::default()
            },
        );
        assert!(
            a.list()[0].describe().contains("clears above 69.00 V"),
            "{}",
            a.list()[0].describe()
        );
    }

    #[test]
    fn limits_warn_then_alarm_with_hysteresis() {
        let mut a = Alarms::new(AlarmConfig::default());
        let mut i = AlarmInputs {
            ever_connected: true,
            tether_v: Some(65.0),
            ..AlarmInputs::default()
        };
        assert_eq!(
            a.evaluate(0.0, &i),
            vec![AlarmChange::Raised(
                AlarmKind::TetherVoltageLow,
                AlarmLevel::Warning
            )]
        );
        a.acknowledge(None);
        // Growing into an alarm raises it again (unacknowledged).
        i.tether_v = Some(59.0);
        assert_eq!(
            a.evaluate(1.0, &i),
            vec![AlarmChange::Raised(
                AlarmKind::TetherVoltageLow,
                AlarmLevel::Alarm
            )]
        );
        assert_eq!(a.unacknowledged(), 1);
        let s = a.list()[0];
        assert_eq!((s.value, s.limit), (Some(59.0), Some(60.0)));
        // Inside the 3 V hysteresis band: still an alarm.
        i.tether_v = Some(61.0);
        assert!(a.evaluate(2.0, &i).is_empty());
        assert_eq!(a.list()[0].level, AlarmLevel::Alarm);
        // Back to a warning, then clear.
        i.tether_v = Some(64.0);
        a.evaluate(3.0, &i);
        assert_eq!(a.list()[0].level, AlarmLevel::Warning);
        i.tether_v = Some(70.0);
        assert_eq!(
            a.evaluate(4.0, &i),
            vec![AlarmChange::Cleared(AlarmKind::TetherVoltageLow)]
        );
        // Depth and turns (either way).
        let mut b = Alarms::new(AlarmConfig::default());
        let j = AlarmInputs {
            depth_m: Some(291.0),
            turns: Some(-2.5),
            ..AlarmInputs::default()
        };
        let ch = b.evaluate(0.0, &j);
        assert!(ch.contains(&AlarmChange::Raised(AlarmKind::DepthMax, AlarmLevel::Alarm)));
        assert!(ch.contains(&AlarmChange::Raised(
            AlarmKind::TetherTurns,
            AlarmLevel::Warning
        )));
    }

    #[test]
    fn humidity_rate_is_per_minute() {
        let mut b = Alarms::new(AlarmConfig::default());
        let mut raised = false;
        for s in 0..40 {
            let j = AlarmInputs {
                ever_connected: true,
                humidity_pct: Some(30.0 + 0.1 * f64::from(s)),
                ..AlarmInputs::default()
            };
            raised |= b.evaluate(f64::from(s), &j).contains(&AlarmChange::Raised(
                AlarmKind::HumidityRising,
                AlarmLevel::Alarm,
            ));
        }
        assert!((b.humidity_rate_pct_per_min().unwrap() - 6.0).abs() < 1e-6);
        assert!(raised);
    }

    #[test]
    fn config_reads_limits_and_names_file_key_value_range() {
        let text = "[alarms]\ndepth_warn_m = 40.0\ndepth_alarm_m = 50\ntether_turns_alarm = 3.0\n";
        let f = ParamFile::parse(text, "config/station.toml", false).unwrap();
        let c = AlarmConfig::from_param_file(&f).unwrap();
        assert_eq!(
            c.depth_m,
            Limit {
                warn: 40.0,
                alarm: 50.0
            }
        );
        assert_eq!(c.tether_turns.alarm, 3.0);
        assert_eq!(c.humidity_pct, AlarmConfig::default().humidity_pct);
        // Round trip through the writer.
        let back = format!("[alarms]\n{}", c.to_toml());
        let g = ParamFile::parse(&back, "x", false).unwrap();
        assert_eq!(AlarmConfig::from_param_file(&g).unwrap(), c);

        let err = |t: &str| {
            let f = ParamFile::parse(t, "config/station.toml", false).unwrap();
            AlarmConfig::from_param_file(&f).unwrap_err().to_string()
        };
        let e = err("[alarms]\nhumidity_alarm_pct = 140\n");
        assert!(
            e.contains("config/station.toml")
                && e.contains("alarms.humidity_alarm_pct")
                && e.contains("140")
                && e.contains("0..=100"),
            "{e}"
        );
        let e = err("[alarms]\ntether_warn_v = 50.0\n");
        assert!(
            e.contains("alarms.tether_warn_v") && e.contains("50") && e.contains("at least"),
            "{e}"
        );
        let e = err("[alarms]\ndepth_max_m = 3\n");
        assert!(
            e.contains("alarms.depth_max_m") && e.contains("depth_warn_m"),
            "{e}"
        );
    }
}
