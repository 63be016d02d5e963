//! Reference model (setpoint prefilter): turns a setpoint that may jump into a smooth
//! desired trajectory — position, velocity and acceleration — that respects velocity and
//! acceleration limits, for the feedforward and the PID.
//!
//! Structure: a cascade that is a third-order, critically damped filter (triple pole at
//! `−ω`) while no limit is active, with saturations between the stages:
//!
//! ```text
//! e      = setpoint − x_d                         (wrapped to ±π for headings)
//! v_t    = sign(e)·min(ω/3·|e|, √(2·a_brake·|e|), v_max)
//! a_cmd  = clamp(ω·(v_t − v_d), ±a_max)
//! a_d   ← first-order lag of a_cmd with time constant 1/(3ω)   (bounded jerk)
//! v_d   ← clamp(v_d + a_d·h, ±v_max);   x_d ← x_d + v_d·h
//! ```
//!
//! With `k = ω/3`, `k_v = ω`, `τ = 1/(3ω)` the linear part has the characteristic
//! polynomial `(s + ω)³`. The square-root braking law (with `a_brake` = 70 % of `a_max`)
//! starts the deceleration early enough that large steps arrive without overshoot.
//! Integration is semi-implicit Euler in sub-steps of at most 20 ms, so any dt is handled.
//! The heading version works on the wrapped error, so it always turns the short way, and
//! keeps its position in `[0, 2π)`.

use crate::angle::{wrap_2pi, wrap_pi};
use crate::error::{ControlError, check_range};

/// Largest integration sub-step, s.
const MAX_SUBSTEP_S: f64 = 0.02;
/// At most this many sub-steps per call (longer gaps are integrated coarsely).
const MAX_SUBSTEPS: usize = 100;
/// Braking deceleration as a fraction of the acceleration limit.
const BRAKE_FRACTION: f64 = 0.7;

/// Limits and bandwidth of a reference model. Units follow the axis (m or rad).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReferenceConfig {
    /// Bandwidth ω of the linear part, rad/s.
    pub natural_freq_rad_s: f64,
    /// Velocity limit (m/s or rad/s).
    pub vel_max: f64,
    /// Acceleration limit (m/s² or rad/s²).
    pub acc_max: f64,
}

impl ReferenceConfig {
    /// Checks the fields; `name` prefixes error keys.
    pub fn validate(&self, name: &str) -> Result<(), ControlError> {
        check_range(
            &format!("{name}.natural_freq_rad_s"),
            self.natural_freq_rad_s,
            0.01,
            100.0,
        )?;
        check_range(&format!("{name}.vel_max"), self.vel_max, 1e-4, 100.0)?;
        check_range(&format!("{name}.acc_max"), self.acc_max, 1e-4, 1000.0)?;
        Ok(())
    }
}

/// Desired position, velocity and acceleration (m, m/s, m/s² or rad, rad/s, rad/s²).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ReferenceState {
    /// Desired position (depth m, or heading rad in `[0, 2π)`).
    pub pos: f64,
    /// Desired velocity.
    pub vel: f64,
    /// Desired acceleration.
    pub acc: f64,
}

/// A reference model for one axis.
#[derive(Debug, Clone)]
pub struct ReferenceModel {
    cfg: ReferenceConfig,
    angle: bool,
    state: ReferenceState,
}

impl ReferenceModel {
    /// A linear-axis (depth) reference model at rest at 0.
    pub fn new(cfg: ReferenceConfig) -> Self {
        Self {
            cfg,
            angle: false,
            state: ReferenceState::default(),
        }
    }

    /// An angle (heading, rad) reference model at rest at 0; works on the wrapped error.
    pub fn new_angle(cfg: ReferenceConfig) -> Self {
        Self {
            cfg,
            angle: true,
            state: ReferenceState::default(),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &ReferenceConfig {
        &self.cfg
    }

    /// Replaces the limits, keeping the state.
    pub fn set_config(&mut self, cfg: ReferenceConfig) {
        self.cfg = cfg;
    }

    /// The current desired state.
    pub fn state(&self) -> ReferenceState {
        self.state
    }

    /// Restarts from position `pos` moving at `vel` (clamped to the limit), zero
    /// acceleration. Non-finite values are replaced by zero.
    pub fn reset(&mut self, pos: f64, vel: f64) {
        let pos = if pos.is_finite() { pos } else { 0.0 };
        let vel = if vel.is_finite() {
            vel.clamp(-self.cfg.vel_max, self.cfg.vel_max)
        } else {
            0.0
        };
        self.state = ReferenceState {
            pos: if self.angle { wrap_2pi(pos) } else { pos },
            vel,
            acc: 0.0,
        };
    }

    /// Distance needed to stop from velocity `vel` with the braking deceleration (signed:
    /// the direction of motion). Used to latch a setpoint where the vehicle will stop.
    pub fn stopping_distance(&self, vel: f64) -> f64 {
        if !vel.is_finite() {
            return 0.0;
        }
        let v = vel.clamp(-self.cfg.vel_max, self.cfg.vel_max);
        v * v.abs() / (2.0 * BRAKE_FRACTION * self.cfg.acc_max)
    }

    /// Advances by `dt_s` toward `setpoint` and returns the new desired state. A
    /// non-finite setpoint or dt leaves the state unchanged.
    pub fn step(&mut self, setpoint: f64, dt_s: f64) -> ReferenceState {
        self.step_moving(setpoint, 0.0, dt_s)
    }

    /// Like [`ReferenceModel::step`] for a setpoint that moves at `setpoint_rate` (m/s or
    /// rad/s; `setpoint` is its value at the end of the step): the rate is fed through
    /// to the velocity target, `v_t = rate + sign(e)·min(…)`, so a ramp is followed
    /// without the filter's steady lag. A non-finite rate counts as 0.
    pub fn step_moving(&mut self, setpoint: f64, setpoint_rate: f64, dt_s: f64) -> ReferenceState {
        if !(setpoint.is_finite() && dt_s.is_finite() && dt_s > 0.0) {
            return self.state;
        }
        let rate = if setpoint_rate.is_finite() {
            setpoint_rate.clamp(-self.cfg.vel_max, self.cfg.vel_max)
        } else {
            0.0
        };
        let n = ((dt_s / MAX_SUBSTEP_S).ceil() as usize).clamp(1, MAX_SUBSTEPS);
        let h = dt_s / n as f64;
        let c = self.cfg;
        let omega = c.natural_freq_rad_s;
        let k = omega / 3.0;
        let a_brake = BRAKE_FRACTION * c.acc_max;
        let lag = -(-h * 3.0 * omega).exp_m1();
        let mut s = self.state;
        for i in 0..n {
            // The moving setpoint at the start of this sub-step.
            let sp_i = setpoint - rate * (dt_s - i as f64 * h);
            let e = if self.angle {
                wrap_pi(sp_i - s.pos)
            } else {
                sp_i - s.pos
            };
            let v_mag = (k * e.abs())
                .min((2.0 * a_brake * e.abs()).sqrt())
                .min(c.vel_max);
            let v_t = (rate + v_mag.copysign(e)).clamp(-c.vel_max, c.vel_max);
            let a_cmd = (omega * (v_t - s.vel)).clamp(-c.acc_max, c.acc_max);
            s.acc += lag * (a_cmd - s.acc);
            let v_new = s.vel + s.acc * h;
            if v_new > c.vel_max {
                s.vel = c.vel_max;
                s.acc = s.acc.min(0.0);
            } else if v_new < -c.vel_max {
                s.vel = -c.vel_max;
                s.acc = s.acc.max(0.0);
            } else {
                s.vel = v_new;
            }
            s.pos += s.vel * h;
            if self.angle {
                s.pos = wrap_2pi(s.pos);
            }
        }
        if s.pos.is_finite() && s.vel.is_finite() && s.acc.is_finite() {
            self.state = s;
        }
        self.state
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn depth_cfg() -> ReferenceConfig {
        ReferenceConfig {
            natural_freq_rad_s: 1.5,
            vel_max: 0.35,
            acc_max: 0.3,
        }
    }

    #[test]
    fn respects_limits_and_converges_without_overshoot() {
        for step in [0.01, 0.3, 2.0, -5.0, 40.0] {
            let mut r = ReferenceModel::new(depth_cfg());
            let dt = 0.02;
            let mut max_past = 0.0_f64;
            for _ in 0..(200.0 / dt) as usize {
                let s = r.step(step, dt);
                assert!(s.vel.abs() <= depth_cfg().vel_max + 1e-12, "{s:?}");
                assert!(s.acc.abs() <= depth_cfg().acc_max + 1e-12, "{s:?}");
                let past: f64 = (s.pos - step) * step.signum();
                max_past = max_past.max(past);
            }
            let s = r.state();
            assert!((s.pos - step).abs() < 1e-6, "step {step}: {s:?}");
            assert!(s.vel.abs() < 1e-6);
            assert!(
                max_past <= 0.005 * step.abs() + 1e-9,
                "step {step} overshoot {max_past}"
            );
        }
    }

    #[test]
    fn uneven_dt_is_handled() {
        let mut r = ReferenceModel::new(depth_cfg());
        let mut t = 0.0;
        let mut k = 0u64;
        while t < 60.0 {
            let dt = [0.001, 0.02, 0.5, 0.013, 2.0][(k % 5) as usize];
            let s = r.step(3.0, dt);
            assert!(s.vel.abs() <= 0.35 + 1e-12 && s.acc.abs() <= 0.3 + 1e-12);
            t += dt;
            k += 1;
        }
        assert!((r.state().pos - 3.0).abs() < 1e-3);
    }

    #[test]
    fn heading_goes_the_short_way() {
        let cfg = ReferenceConfig {
            natural_freq_rad_s: 3.0,
            vel_max: 0.7,
            acc_max: 1.0,
        };
        let mut r = ReferenceModel::new_angle(cfg);
        r.reset(359f64.to_radians(), 0.0);
        let target = 1f64.to_radians();
        let mut min_vel = 0.0_f64;
        for _ in 0..500 {
            let s = r.step(target, 0.02);
            min_vel = min_vel.min(s.vel);
            assert!((0.0..2.0 * PI).contains(&s.pos));
        }
        assert!(min_vel >= 0.0, "never turns to port");
        assert!(wrap_pi(r.state().pos - target).abs() < 1e-6);
    }

    #[test]
    fn ramp_setpoint_is_tracked_at_its_rate() {
        let mut r = ReferenceModel::new(depth_cfg());
        let dt = 0.02;
        for k in 0..1500 {
            r.step(0.2 * k as f64 * dt, dt);
        }
        assert!((r.state().vel - 0.2).abs() < 1e-3);
    }

    #[test]
    fn moving_setpoint_is_tracked_without_lag() {
        let mut r = ReferenceModel::new(depth_cfg());
        let dt = 0.02;
        let mut max_lag = 0.0_f64;
        for k in 0..1500 {
            // The setpoint passed is its value at the end of the step.
            let t = (k + 1) as f64 * dt;
            let s = r.step_moving(0.2 * t, 0.2, dt);
            assert!(s.vel.abs() <= 0.35 + 1e-12 && s.acc.abs() <= 0.3 + 1e-12);
            if t > 15.0 {
                max_lag = max_lag.max((0.2 * t - s.pos).abs());
            }
        }
        assert!(max_lag < 1e-3, "lag {max_lag}");
    }

    #[test]
    fn bad_input_keeps_state() {
        let mut r = ReferenceModel::new(depth_cfg());
        r.step(1.0, 0.5);
        let s = r.state();
        assert_eq!(r.step(f64::NAN, 0.02), s);
        assert_eq!(r.step(1.0, f64::INFINITY), s);
        assert_eq!(r.step(1.0, -1.0), s);
        assert!(r.stopping_distance(0.35) > 0.0 && r.stopping_distance(-0.35) < 0.0);
    }
}
