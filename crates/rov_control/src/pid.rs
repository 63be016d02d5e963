//! PID controller for one axis, in physical units (force in N for depth, moment in N·m
//! for heading).
//!
//! * **Derivative on the measurement.** The D term acts on the *rate error*
//!   `v_ref − v_meas`, where `v_meas` is the measured or estimated rate (the observer's
//!   velocity estimate, a gyro, or a differentiated measurement) and `v_ref` is the
//!   velocity of the smooth reference model. A setpoint step therefore never kicks the D
//!   term (the reference model is continuous); with the reference at rest this is exactly
//!   derivative on the measurement. The rate error passes a first-order low-pass filter
//!   (time constant [`PidConfig::derivative_filter_s`], discretised exactly for each dt).
//! * **Anti-windup by clamping.** `|I| ≤ i_max` always; while the output is saturated (by
//!   its limits or by the slew limit) the integrator may only move toward zero.
//! * **Output and slew limits.** The output is clamped to `[out_min, out_max]` and then
//!   moves by at most `slew_per_s · dt` per update.
//! * **Bumpless transfer.** [`Pid::engage`] makes the next output equal to the given
//!   current (manual) output by initialising the integrator, so engaging never steps the
//!   output; afterwards the slew limit bounds every step.
//!
//! No logging: each update returns a [`PidTerms`] diagnostics value.

use crate::error::{ControlError, check_range};

/// Gains and limits of one PID. Units follow the axis: error in m or rad, output in N or
/// N·m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PidConfig {
    /// Proportional gain (N/m or N·m/rad).
    pub kp: f64,
    /// Integral gain (N/(m·s) or N·m/(rad·s)).
    pub ki: f64,
    /// Derivative gain on the rate error (N·s/m or N·m·s/rad).
    pub kd: f64,
    /// Time constant of the first-order filter on the rate error, s (0 = no filter).
    pub derivative_filter_s: f64,
    /// Bound on the integrator's contribution to the output (N or N·m).
    pub i_max: f64,
    /// Lowest output (N or N·m); the controller also clamps this to what the thrusters
    /// can produce.
    pub out_min: f64,
    /// Highest output (N or N·m).
    pub out_max: f64,
    /// Largest output change per second (N/s or N·m/s).
    pub slew_per_s: f64,
}

impl PidConfig {
    /// Checks every field for finiteness and sign; `name` prefixes error keys.
    pub fn validate(&self, name: &str) -> Result<(), ControlError> {
        check_range(&format!("{name}.kp"), self.kp, 0.0, 1e6)?;
        check_range(&format!("{name}.ki"), self.ki, 0.0, 1e6)?;
        check_range(&format!("{name}.kd"), self.kd, 0.0, 1e6)?;
        check_range(
            &format!("{name}.derivative_filter_s"),
            self.derivative_filter_s,
            0.0,
            10.0,
        )?;
        check_range(&format!("{name}.i_max"), self.i_max, 0.0, 1e6)?;
        check_range(&format!("{name}.out_min"), self.out_min, -1e6, 0.0)?;
        check_range(&format!("{name}.out_max"), self.out_max, 0.0, 1e6)?;
        check_range(&format!("{name}.slew_per_s"), self.slew_per_s, 1e-6, 1e9)?;
        Ok(())
    }
}

/// The terms of one PID update (for display and logging by the caller).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PidTerms {
    /// Proportional term.
    pub p: f64,
    /// Integral term (the integrator state after this update).
    pub i: f64,
    /// Derivative term.
    pub d: f64,
    /// Feedforward passed in.
    pub ff: f64,
    /// The sum before limits.
    pub unlimited: f64,
    /// The output after the output and slew limits.
    pub output: f64,
    /// The output limits were active.
    pub saturated: bool,
    /// The slew limit was active.
    pub slew_limited: bool,
}

/// One axis' PID state.
#[derive(Debug, Clone)]
pub struct Pid {
    cfg: PidConfig,
    integral: f64,
    rate_error_filtered: f64,
    last_output: f64,
    /// Output to match on the next update (bumpless engage).
    pending_engage: Option<f64>,
    last_terms: PidTerms,
}

impl Pid {
    /// A PID at rest (zero integrator, zero output). The config is assumed validated.
    pub fn new(cfg: PidConfig) -> Self {
        Self {
            cfg,
            integral: 0.0,
            rate_error_filtered: 0.0,
            last_output: 0.0,
            pending_engage: None,
            last_terms: PidTerms::default(),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &PidConfig {
        &self.cfg
    }

    /// Replaces the gains and limits, keeping the state (the integrator is re-clamped).
    pub fn set_config(&mut self, cfg: PidConfig) {
        self.cfg = cfg;
        self.integral = self.integral.clamp(-cfg.i_max, cfg.i_max);
    }

    /// Narrows the output limits to `[out_min, out_max]` intersected with the configured
    /// ones (used for what the thrusters can actually produce). Non-finite values are
    /// ignored.
    pub fn effective_limits(&self, out_min: f64, out_max: f64) -> (f64, f64) {
        let lo = if out_min.is_finite() {
            out_min.max(self.cfg.out_min)
        } else {
            self.cfg.out_min
        };
        let hi = if out_max.is_finite() {
            out_max.min(self.cfg.out_max)
        } else {
            self.cfg.out_max
        };
        if lo <= hi { (lo, hi) } else { (0.0, 0.0) }
    }

    /// Zero integrator, filter and output.
    pub fn reset(&mut self) {
        self.integral = 0.0;
        self.rate_error_filtered = 0.0;
        self.last_output = 0.0;
        self.pending_engage = None;
        self.last_terms = PidTerms::default();
    }

    /// The integrator state.
    pub fn integral(&self) -> f64 {
        self.integral
    }

    /// The last output.
    pub fn last_output(&self) -> f64 {
        self.last_output
    }

    /// The terms of the last update.
    pub fn last_terms(&self) -> PidTerms {
        self.last_terms
    }

    /// Bumpless engage: the next [`Pid::update`] initialises the integrator so that its
    /// output equals `current_output` (the manual command in the same units), and the slew
    /// limit starts from there. The integrator is still bounded by `i_max`. The derivative
    /// filter restarts from the next rate error. A non-finite value engages from zero.
    pub fn engage(&mut self, current_output: f64) {
        let out = if current_output.is_finite() {
            current_output
        } else {
            0.0
        };
        self.pending_engage = Some(out);
        self.last_output = out;
    }

    /// One update. `error` = reference − measurement (already wrapped for angles);
    /// `rate_error` = reference rate − measured rate; `feedforward` is added before the
    /// limits; `(out_min, out_max)` narrow the configured limits for this update. A
    /// non-finite input or `dt_s <= 0` leaves the state unchanged and repeats the last
    /// output.
    pub fn update(
        &mut self,
        error: f64,
        rate_error: f64,
        feedforward: f64,
        dt_s: f64,
        out_min: f64,
        out_max: f64,
    ) -> PidTerms {
        let inputs_ok = error.is_finite() && rate_error.is_finite() && feedforward.is_finite();
        if !(inputs_ok && dt_s.is_finite() && dt_s > 0.0) {
            let mut t = self.last_terms;
            t.output = self.last_output;
            return t;
        }
        let c = self.cfg;
        let (lo, hi) = self.effective_limits(out_min, out_max);
        let p = c.kp * error;
        let engaging = self.pending_engage.take();
        if engaging.is_some() {
            self.rate_error_filtered = rate_error;
        } else if c.derivative_filter_s > 0.0 {
            let alpha = -(-dt_s / c.derivative_filter_s).exp_m1();
            self.rate_error_filtered += alpha * (rate_error - self.rate_error_filtered);
        } else {
            self.rate_error_filtered = rate_error;
        }
        let d = c.kd * self.rate_error_filtered;
        if let Some(target) = engaging {
            self.integral = (target - feedforward - p - d).clamp(-c.i_max, c.i_max);
        }
        // Candidate integrator step, then conditional acceptance (clamping anti-windup).
        let candidate = (self.integral + c.ki * error * dt_s).clamp(-c.i_max, c.i_max);
        let step_max = c.slew_per_s * dt_s;
        let limits_of = |i: f64, last: f64| {
            let raw = feedforward + p + i + d;
            let limited = raw.clamp(lo, hi);
            let slewed = limited.clamp(last - step_max, last + step_max);
            (raw, limited, slewed)
        };
        let (raw_c, lim_c, slew_c) = limits_of(candidate, self.last_output);
        let saturated_c = raw_c != lim_c || lim_c != slew_c;
        if !saturated_c || candidate.abs() <= self.integral.abs() {
            self.integral = candidate;
        }
        // Keep |I| within i_max also after a config change.
        self.integral = self.integral.clamp(-c.i_max, c.i_max);
        let (raw, limited, slewed) = limits_of(self.integral, self.last_output);
        let output = if slewed.is_finite() {
            slewed
        } else {
            self.last_output
        };
        self.last_output = output;
        let terms = PidTerms {
            p,
            i: self.integral,
            d,
            ff: feedforward,
            unlimited: raw,
            output,
            saturated: raw != limited,
            slew_limited: limited != slewed,
        };
        self.last_terms = terms;
        terms
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg() -> PidConfig {
        PidConfig {
            kp: 20.0,
            ki: 5.0,
            kd: 15.0,
            derivative_filter_s: 0.05,
            i_max: 6.0,
            out_min: -10.0,
            out_max: 10.0,
            slew_per_s: 50.0,
        }
    }

    /// Depth plant with a hard floor: a heavy mass with drag that cannot go below the
    /// floor (the "unreachable setpoint" of C4).
    struct FloorPlant {
        z: f64,
        w: f64,
        floor_m: f64,
    }

    impl FloorPlant {
        fn step(&mut self, force_n: f64, dt: f64) {
            let m = 11.0;
            let acc = (force_n - 4.8 * self.w - 34.0 * self.w.abs() * self.w) / m;
            self.w += acc * dt;
            self.z += self.w * dt;
            if self.z > self.floor_m {
                self.z = self.floor_m;
                self.w = self.w.min(0.0);
            }
        }
    }

    /// Runs the loop toward `target` until the output becomes negative; returns the time.
    fn time_to_negative(pid: &mut Pid, plant: &mut FloorPlant, target: f64) -> f64 {
        let dt = 0.02;
        for k in 0..20_000 {
            let t = pid.update(
                target - plant.z,
                -plant.w,
                0.0,
                dt,
                f64::NEG_INFINITY,
                f64::INFINITY,
            );
            if t.output < 0.0 {
                return k as f64 * dt;
            }
            plant.step(t.output, dt);
        }
        f64::INFINITY
    }

    /// C4: 60 s against an unreachable setpoint, then reversal.
    #[test]
    fn c4_anti_windup_reversal_within_1_5x_of_fresh() {
        let dt = 0.02;
        let mut wound = Pid::new(cfg());
        let mut plant = FloorPlant {
            z: 9.0,
            w: 0.0,
            floor_m: 10.0,
        };
        for _ in 0..(60.0 / dt) as usize {
            let t = wound.update(
                50.0 - plant.z,
                -plant.w,
                0.0,
                dt,
                f64::NEG_INFINITY,
                f64::INFINITY,
            );
            assert!(t.i.abs() <= cfg().i_max + 1e-12);
            plant.step(t.output, dt);
        }
        assert!((plant.z - 10.0).abs() < 1e-9, "sits on the floor");
        assert_eq!(wound.last_output(), cfg().out_max);
        // The same controller and plant, but starting from a zero integrator.
        let mut fresh = wound.clone();
        fresh.integral = 0.0;
        let mut plant2 = FloorPlant {
            z: plant.z,
            w: plant.w,
            floor_m: 10.0,
        };
        let t_wound = time_to_negative(&mut wound, &mut plant, 5.0);
        let t_fresh = time_to_negative(&mut fresh, &mut plant2, 5.0);
        assert!(t_wound.is_finite() && t_fresh.is_finite());
        assert!(
            t_wound <= 1.5 * t_fresh + 1e-9,
            "wound {t_wound} s vs fresh {t_fresh} s"
        );
    }

    #[test]
    fn integrator_moves_only_toward_zero_while_saturated() {
        let mut pid = Pid::new(PidConfig {
            slew_per_s: 1e9,
            ..cfg()
        });
        // Pre-load a negative integrator, then saturate high with a large positive error.
        for _ in 0..100 {
            pid.update(-0.1, 0.0, 0.0, 0.02, -1e9, 1e9);
        }
        let before = pid.integral();
        assert!(before < 0.0);
        let mut last = before;
        for _ in 0..500 {
            let t = pid.update(5.0, 0.0, 0.0, 0.02, -1e9, 1e9);
            assert!(t.saturated);
            assert!(t.i.abs() <= last.abs() + 1e-12, "{} -> {}", last, t.i);
            last = t.i;
        }
    }

    #[test]
    fn slew_limit_bounds_every_step() {
        let mut pid = Pid::new(cfg());
        let dt = 0.02;
        let mut last = 0.0;
        for k in 0..500 {
            let err = if (k / 50) % 2 == 0 { 3.0 } else { -3.0 };
            let t = pid.update(err, 0.0, 0.0, dt, f64::NEG_INFINITY, f64::INFINITY);
            assert!((t.output - last).abs() <= cfg().slew_per_s * dt + 1e-9);
            assert!(t.output <= 10.0 && t.output >= -10.0);
            last = t.output;
        }
    }

    #[test]
    fn c5_bumpless_engage_matches_manual_output() {
        let mut pid = Pid::new(cfg());
        pid.engage(4.0);
        let t = pid.update(0.3, -0.1, 1.0, 0.02, -10.0, 10.0);
        // Output equals the manual command up to one integrator step.
        assert!(
            (t.output - 4.0).abs() <= cfg().ki * 0.3 * 0.02 + 1e-9,
            "{t:?}"
        );
        let mut last = t.output;
        for _ in 0..200 {
            let t = pid.update(0.3, 0.0, 1.0, 0.02, -10.0, 10.0);
            assert!((t.output - last).abs() <= cfg().slew_per_s * 0.02 + 1e-9);
            last = t.output;
        }
    }

    #[test]
    fn bad_inputs_leave_state_unchanged() {
        let mut pid = Pid::new(cfg());
        pid.update(0.5, 0.0, 0.0, 0.02, -10.0, 10.0);
        let i = pid.integral();
        let o = pid.last_output();
        for (e, r, f, dt) in [
            (f64::NAN, 0.0, 0.0, 0.02),
            (0.1, f64::INFINITY, 0.0, 0.02),
            (0.1, 0.0, f64::NEG_INFINITY, 0.02),
            (0.1, 0.0, 0.0, 0.0),
            (0.1, 0.0, 0.0, f64::NAN),
        ] {
            let t = pid.update(e, r, f, dt, -10.0, 10.0);
            assert_eq!(t.output.to_bits(), o.to_bits());
            assert_eq!(pid.integral().to_bits(), i.to_bits());
        }
    }
}
