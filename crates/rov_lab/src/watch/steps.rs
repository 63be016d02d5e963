//! Sensor consistency: a reading that moves in a way the vehicle cannot.
//!
//! The short-window prediction re-initialises each window from the readings, so a
//! reading that jumps to a new offset and stays there shows only in the windows that
//! straddle the jump. This test looks at the readings themselves, row by row:
//! - **heading**: the change of the compass over [`SPAN_S`] against the change the gyro
//!   says (ψ̇ = (q sin φ + r cos φ)/cos θ, integrated); the two agree up to noise and
//!   the compass's lag, whatever the vehicle does;
//! - **depth**: the change from one reading to the next against what the vehicle can do
//!   (no vertical speed above [`MAX_HEAVE_MPS`]).
//!
//! The baseline learns the largest disagreement of the dive's calm first minute (its
//! 99th percentile); afterwards a disagreement above [`FACTOR`] times that (and above an
//! absolute least, [`MIN_HEADING_DEG`] and [`MIN_DEPTH_M`]) is a step of the sensor.

use std::collections::VecDeque;

use rov_types::measurement::MeasurementRow;

use crate::data::wrap180;

/// Span over which the reading's change is compared, s.
pub(crate) const SPAN_S: f64 = 1.0;
/// Fastest vertical speed a small ROV reaches, m/s.
pub(crate) const MAX_HEAVE_MPS: f64 = 1.5;
/// A step is this many times the baseline's 99th percentile.
pub(crate) const FACTOR: f64 = 3.0;
/// Least heading step reported, degrees.
pub(crate) const MIN_HEADING_DEG: f64 = 5.0;
/// Least depth step reported beyond the possible motion, m.
pub(crate) const MIN_DEPTH_M: f64 = 0.2;

#[derive(Debug, Clone, Copy)]
struct Sample {
    t_s: f64,
    heading_deg: f64,
    /// Heading rate from the gyro, deg/s (NaN when absent).
    psi_dot_dps: f64,
    depth_m: f64,
}

/// A sensor step found: channel (0 depth, 1 heading), time, size (m or degrees).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Step {
    pub channel: usize,
    pub t_s: f64,
    pub size: f64,
}

/// The running test.
#[derive(Debug, Clone, Default)]
pub(crate) struct Steps {
    window: VecDeque<Sample>,
    learn: [Vec<f64>; 2],
    limit: [Option<f64>; 2],
}

impl Steps {
    /// Ends the baseline: the limits from what was seen.
    pub fn end_baseline(&mut self) {
        for (i, mins) in [MIN_DEPTH_M, MIN_HEADING_DEG].into_iter().enumerate() {
            let v = &mut self.learn[i];
            if v.len() < 20 {
                continue;
            }
            v.sort_by(f64::total_cmp);
            let q99 = v
                .get((v.len() as f64 * 0.99) as usize)
                .copied()
                .unwrap_or(0.0);
            self.limit[i] = Some((FACTOR * q99).max(mins));
            v.clear();
        }
    }

    /// Forgets the history (a gap in the log).
    pub fn reset(&mut self) {
        self.window.clear();
    }

    /// Takes channel `i` out of the test (its sensor is known bad).
    pub fn disable(&mut self, i: usize) {
        if let Some(l) = self.limit.get_mut(i) {
            *l = None;
        }
    }

    /// Takes a row; returns a step when the readings moved as the vehicle cannot.
    pub fn push(&mut self, r: &MeasurementRow, learning: bool) -> Option<Step> {
        let s = Sample {
            t_s: r.time_s,
            heading_deg: r.heading_deg,
            psi_dot_dps: psi_dot_dps(r),
            depth_m: r.depth_m,
        };
        let prev = self.window.back().copied();
        self.window.push_back(s);
        while self
            .window
            .front()
            .is_some_and(|f| f.t_s < s.t_s - SPAN_S - 1e-9)
        {
            self.window.pop_front();
        }
        let first = *self.window.front()?;
        let span = s.t_s - first.t_s;
        if span < 0.5 * SPAN_S {
            return None;
        }
        // Heading: compass change minus the gyro's (trapezoids over the window).
        let mut gyro = 0.0;
        let mut have_gyro = true;
        for (a, b) in self.window.iter().zip(self.window.iter().skip(1)) {
            let m = 0.5 * (a.psi_dot_dps + b.psi_dot_dps) * (b.t_s - a.t_s);
            if m.is_finite() {
                gyro += m;
            } else {
                have_gyro = false;
            }
        }
        let dh = wrap180(s.heading_deg - first.heading_deg) - gyro;
        // Depth: from one reading to the next (a jump is instantaneous; a drift is the
        // stuck/shooting tests' business).
        let dd = prev.map_or(0.0, |p| {
            (s.depth_m - p.depth_m).abs() - MAX_HEAVE_MPS * (s.t_s - p.t_s)
        });
        let ds = [dd.max(0.0), dh];
        let ok = [true, have_gyro];
        let mut found = None;
        for i in 0..2 {
            let (Some(d), true) = (ds.get(i).copied(), ok[i]) else {
                continue;
            };
            if !d.is_finite() {
                continue;
            }
            if learning {
                self.learn[i].push(d.abs());
            } else if let Some(l) = self.limit[i]
                && d.abs() > l
                && found.is_none()
            {
                let size = if i == 0 {
                    prev.map_or(0.0, |p| s.depth_m - p.depth_m)
                } else {
                    dh
                };
                found = Some(Step {
                    channel: i,
                    t_s: s.t_s,
                    size,
                });
            }
        }
        if found.is_some() {
            // One step is reported once: the window starts again after it.
            self.window.clear();
            self.window.push_back(s);
        }
        found
    }
}

/// The heading rate the gyro gives, deg/s: (q sin φ + r cos φ)/cos θ.
/// How far the compass moved beyond what the gyro says, degrees, from `from_s` to the
/// last row: the compass's change (unwrapped row to row) minus the integral of the
/// gyro's heading rate (trapezoids). About zero whatever the vehicle does when both
/// sensors are right; the size of a compass fault (a jump, or the motion a stuck compass
/// missed) when the compass is wrong. `None` without a gyro or with fewer than two rows.
pub(crate) fn compass_minus_gyro_deg(rows: &[MeasurementRow], from_s: f64) -> Option<f64> {
    let mut d = 0.0;
    let mut n = 0usize;
    let after = rows.iter().filter(|r| r.time_s >= from_s);
    for (a, b) in after.clone().zip(after.skip(1)) {
        let gyro = 0.5 * (psi_dot_dps(a) + psi_dot_dps(b)) * (b.time_s - a.time_s);
        let compass = wrap180(b.heading_deg - a.heading_deg);
        if !(gyro.is_finite() && compass.is_finite()) {
            return None;
        }
        d += compass - gyro;
        n += 1;
    }
    (n > 0).then_some(d)
}

fn psi_dot_dps(r: &MeasurementRow) -> f64 {
    let (Some(Some(yaw)), Some(Some(pitch_rate))) = (r.optional.first(), r.optional.get(1)) else {
        return f64::NAN;
    };
    let (phi, theta) = (r.roll_deg.to_radians(), r.pitch_deg.to_radians());
    if theta.cos().abs() < 0.2 {
        return f64::NAN;
    }
    (pitch_rate * phi.sin() + yaw * phi.cos()) / theta.cos()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(t: f64, heading: f64, r_dps: f64, depth: f64) -> MeasurementRow {
        let mut row = MeasurementRow {
            time_s: t,
            depth_m: depth,
            heading_deg: heading,
            ..Default::default()
        };
        row.optional[0] = Some(r_dps);
        row.optional[1] = Some(0.0);
        row.optional[2] = Some(0.0);
        row
    }

    #[test]
    fn a_turn_the_gyro_sees_is_no_step_but_a_compass_jump_is() {
        let mut s = Steps::default();
        let mut t = 0.0;
        // Baseline: turning at 20 deg/s, small noise.
        for k in 0..600 {
            let noise = if k % 2 == 0 { 0.2 } else { -0.2 };
            assert!(s.push(&row(t, 20.0 * t + noise, 20.0, 3.0), true).is_none());
            t += 0.1;
        }
        s.end_baseline();
        // A fast turn, measured by both: nothing.
        let h0 = 20.0 * t;
        for k in 0..50 {
            let h = h0 + 40.0 * 0.1 * k as f64;
            assert!(s.push(&row(t, h, 40.0, 3.0), false).is_none(), "{k}");
            t += 0.1;
        }
        // The compass jumps 25° with no rotation.
        let h1 = h0 + 40.0 * 0.1 * 49.0;
        let mut got = None;
        for _ in 0..20 {
            if let Some(st) = s.push(&row(t, h1 + 25.0, 0.0, 3.0), false) {
                got.get_or_insert(st);
            }
            t += 0.1;
        }
        let st = got.expect("a compass jump");
        assert_eq!(st.channel, 1);
        // The gyro stops within the step (trapezoid of 40 and 0 deg/s over 0.1 s: 2°).
        assert!((st.size - 25.0).abs() < 3.0, "{st:?}");
        // A depth jump of 1 m in a sample is one too.
        let mut got = None;
        for _ in 0..20 {
            if let Some(st) = s.push(&row(t, h1 + 25.0, 0.0, 4.0), false) {
                got.get_or_insert(st);
            }
            t += 0.1;
        }
        assert_eq!(got.map(|g| g.channel), Some(0));
    }

    #[test]
    fn the_compass_against_the_gyro_is_zero_for_a_real_turn_and_the_fault_for_a_bad_compass() {
        // A turn through north at 30 deg/s for 10 s, seen by both: ~0.
        let turn: Vec<MeasurementRow> = (0..=100)
            .map(|k| {
                let t = 0.1 * k as f64;
                row(t, (350.0 + 30.0 * t).rem_euclid(360.0), 30.0, 3.0)
            })
            .collect();
        let d = compass_minus_gyro_deg(&turn, 0.0).unwrap();
        assert!(d.abs() < 1e-6, "{d}");
        // The same turn with the compass stuck from 4 s: it missed the 180° turned since.
        let stuck: Vec<MeasurementRow> = turn
            .iter()
            .map(|r| {
                let mut r = *r;
                if r.time_s > 4.0 {
                    r.heading_deg = (350.0 + 30.0 * 4.0f64).rem_euclid(360.0);
                }
                r
            })
            .collect();
        let d = compass_minus_gyro_deg(&stuck, 4.0).unwrap();
        assert!((d + 180.0).abs() < 1.0, "{d}");
        // A held heading with a 25° jump of the compass at 5 s.
        let jump: Vec<MeasurementRow> = (0..=100)
            .map(|k| {
                let t = 0.1 * k as f64;
                row(t, if t > 5.0 { 125.0 } else { 100.0 }, 0.0, 3.0)
            })
            .collect();
        let d = compass_minus_gyro_deg(&jump, 3.0).unwrap();
        assert!((d - 25.0).abs() < 1e-9, "{d}");
        // No gyro: no answer.
        let mut blind = jump.clone();
        for r in &mut blind {
            r.optional[0] = None;
        }
        assert_eq!(compass_minus_gyro_deg(&blind, 3.0), None);
    }
}
