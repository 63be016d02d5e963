//! Station alarms that latch until the pilot acknowledges them.
//!
//! Each alarm has a cause that the runtime evaluates every tick. When the cause appears
//! the alarm is raised (active, unacknowledged). It stays in the list after the cause
//! goes away until it is acknowledged; acknowledging an alarm whose cause is still
//! present keeps it listed (acknowledged, so the GUI stops flashing it) until the cause
//! clears. Thresholds have hysteresis so a value sitting on the limit does not chatter.
//!
//! These are the pilot's alarms; the link's own failsafe alarm (which gates thrust and
//! clears only by re-arming) is separate and unaffected by acknowledging.

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
    /// Tether voltage low.
    TetherVoltageLow,
    /// 12 V rail low.
    RailVoltageLow,
    /// Navigation telemetry older than the stale limit while the link is up, or the
    /// controller flags a depth or heading sensor as lost.
    SensorStale,
    /// The control tick ran late by more than three periods (watchdog sent neutral).
    ControlStall,
}

impl AlarmKind {
    /// Every alarm, in display priority order.
    pub const ALL: [AlarmKind; 7] = [
        AlarmKind::LinkLost,
        AlarmKind::ControlStall,
        AlarmKind::HumidityRising,
        AlarmKind::HumidityHigh,
        AlarmKind::TetherVoltageLow,
        AlarmKind::RailVoltageLow,
        AlarmKind::SensorStale,
    ];

    /// Short text for the pilot.
    #[must_use]
    pub const fn text(self) -> &'static str {
        match self {
            AlarmKind::LinkLost => "LINK LOST",
            AlarmKind::HumidityHigh => "HUMIDITY HIGH",
            AlarmKind::HumidityRising => "HUMIDITY RISING (LEAK?)",
            AlarmKind::TetherVoltageLow => "TETHER VOLTAGE LOW",
            AlarmKind::RailVoltageLow => "12 V LOW",
            AlarmKind::SensorStale => "SENSOR STALE",
            AlarmKind::ControlStall => "CONTROL STALL",
        }
    }

    /// Machine-readable name (session events).
    #[must_use]
    pub const fn key(self) -> &'static str {
        match self {
            AlarmKind::LinkLost => "link_lost",
            AlarmKind::HumidityHigh => "humidity_high",
            AlarmKind::HumidityRising => "humidity_rising",
            AlarmKind::TetherVoltageLow => "tether_voltage_low",
            AlarmKind::RailVoltageLow => "rail_voltage_low",
            AlarmKind::SensorStale => "sensor_stale",
            AlarmKind::ControlStall => "control_stall",
        }
    }
}

/// Thresholds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AlarmConfig {
    /// Humidity limit, %; clears below `limit − 3`.
    pub humidity_max_pct: f64,
    /// Humidity rate-of-rise limit, %/min (over a one-minute window).
    pub humidity_rise_pct_per_min: f64,
    /// Tether voltage limit, V; clears above `limit + 3`.
    pub tether_min_v: f64,
    /// 12 V rail limit, V; clears above `limit + 0.4`.
    pub rail_min_v: f64,
    /// Navigation telemetry older than this is stale, s.
    pub stale_after_s: f64,
}

impl Default for AlarmConfig {
    fn default() -> Self {
        Self {
            humidity_max_pct: 60.0,
            humidity_rise_pct_per_min: 2.0,
            tether_min_v: 60.0,
            rail_min_v: 11.0,
            stale_after_s: 1.0,
        }
    }
}

/// An alarm in the list.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AlarmState {
    /// Which.
    pub kind: AlarmKind,
    /// Raised at, station time s.
    pub raised_s: f64,
    /// The cause is present now.
    pub active: bool,
    /// The pilot acknowledged it.
    pub acknowledged: bool,
}

/// Alarm transitions for the event log.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AlarmChange {
    /// Raised.
    Raised(AlarmKind),
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
    /// Tether voltage, V.
    pub tether_v: Option<f64>,
    /// 12 V rail, V.
    pub rail_v: Option<f64>,
    /// Age of the last navigation reply, s (None: none yet).
    pub nav_age_s: Option<f64>,
    /// The controller flags a sensor as lost.
    pub sensor_fault: bool,
    /// The watchdog tripped since the last evaluation.
    pub control_stall: bool,
}

impl Alarms {
    /// With thresholds.
    #[must_use]
    pub fn new(cfg: AlarmConfig) -> Self {
        Self {
            cfg,
            ..Self::default()
        }
    }

    /// The list, in display priority order (unacknowledged first).
    #[must_use]
    pub fn list(&self) -> Vec<AlarmState> {
        let mut l = self.list.clone();
        l.sort_by_key(|a| {
            (
                a.acknowledged,
                AlarmKind::ALL.iter().position(|k| *k == a.kind),
            )
        });
        l
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

    fn is_active(&self, kind: AlarmKind) -> bool {
        self.list.iter().any(|a| a.kind == kind && a.active)
    }

    fn set(&mut self, kind: AlarmKind, cause: bool, now_s: f64, out: &mut Vec<AlarmChange>) {
        match self.list.iter_mut().find(|a| a.kind == kind) {
            Some(a) => {
                if cause && !a.active {
                    a.active = true;
                    a.acknowledged = false;
                    a.raised_s = now_s;
                    out.push(AlarmChange::Raised(kind));
                } else if !cause && a.active {
                    a.active = false;
                    out.push(AlarmChange::Cleared(kind));
                }
            }
            None if cause => {
                self.list.push(AlarmState {
                    kind,
                    raised_s: now_s,
                    active: true,
                    acknowledged: false,
                });
                out.push(AlarmChange::Raised(kind));
            }
            None => {}
        }
        self.list.retain(|a| a.active || !a.acknowledged);
    }

    /// Evaluates the causes at `now_s`; returns the transitions.
    pub fn evaluate(&mut self, now_s: f64, i: &AlarmInputs) -> Vec<AlarmChange> {
        let mut out = Vec::new();
        let c = self.cfg;
        self.set(
            AlarmKind::LinkLost,
            i.link_lost && i.ever_connected,
            now_s,
            &mut out,
        );
        if let Some(h) = i.humidity_pct.filter(|h| h.is_finite()) {
            let was = self.is_active(AlarmKind::HumidityHigh);
            let high = if was {
                h > c.humidity_max_pct - 3.0
            } else {
                h > c.humidity_max_pct
            };
            self.set(AlarmKind::HumidityHigh, high, now_s, &mut out);
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
            let rising = self
                .humidity_rate
                .is_some_and(|r| r > c.humidity_rise_pct_per_min);
            self.set(AlarmKind::HumidityRising, rising, now_s, &mut out);
        }
        if let Some(v) = i.tether_v.filter(|v| v.is_finite()) {
            let was = self.is_active(AlarmKind::TetherVoltageLow);
            let low = if was {
                v < c.tether_min_v + 3.0
            } else {
                v < c.tether_min_v
            };
            self.set(AlarmKind::TetherVoltageLow, low, now_s, &mut out);
        }
        if let Some(v) = i.rail_v.filter(|v| v.is_finite()) {
            let was = self.is_active(AlarmKind::RailVoltageLow);
            let low = if was {
                v < c.rail_min_v + 0.4
            } else {
                v < c.rail_min_v
            };
            self.set(AlarmKind::RailVoltageLow, low, now_s, &mut out);
        }
        let stale = !i.link_lost
            && i.ever_connected
            && (i.nav_age_s.is_some_and(|a| a > c.stale_after_s) || i.sensor_fault);
        self.set(AlarmKind::SensorStale, stale, now_s, &mut out);
        self.set(AlarmKind::ControlStall, i.control_stall, now_s, &mut out);
        out
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
            vec![AlarmChange::Raised(AlarmKind::LinkLost)]
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
    fn voltage_has_hysteresis_and_humidity_rate_is_per_minute() {
        let mut a = Alarms::new(AlarmConfig::default());
        let mut i = AlarmInputs {
            ever_connected: true,
            tether_v: Some(59.0),
            ..AlarmInputs::default()
        };
        a.evaluate(0.0, &i);
        i.tether_v = Some(61.0);
        assert!(a.evaluate(1.0, &i).is_empty(), "inside the hysteresis band");
        i.tether_v = Some(64.0);
        assert_eq!(
            a.evaluate(2.0, &i),
            vec![AlarmChange::Cleared(AlarmKind::TetherVoltageLow)]
        );
        let mut b = Alarms::new(AlarmConfig::default());
        let mut raised = false;
        for s in 0..40 {
            let j = AlarmInputs {
                ever_connected: true,
                humidity_pct: Some(30.0 + 0.1 * f64::from(s)),
                ..AlarmInputs::default()
            };
            raised |= b
                .evaluate(f64::from(s), &j)
                .contains(&AlarmChange::Raised(AlarmKind::HumidityRising));
        }
        assert!((b.humidity_rate_pct_per_min().unwrap() - 6.0).abs() < 1e-6);
        assert!(raised);
    }
}
