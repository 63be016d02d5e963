//! The simulated vehicle's onboard auto-depth and auto-heading (CSR 0x0B / 0x0D).
//!
//! **This loop is ours.** VideoRay does not document the Pro 4's internal autopilot
//! (its gains live at CSR 0x26–0x35, its terms at 0xB4–0xC3, but neither the control law
//! nor its rate is published), so this is a plain PID of our own on the simulated
//! sensors, tuned for the model-3 Pro 4, good enough for tests to command a depth or a
//! heading through the wire protocol. It does not claim to behave like the real vehicle.
//!
//! * Depth: error in metres from the pressure gauge (target mbar − measured mbar, ×
//!   100/(ρ g)); derivative from a low-pass-filtered depth rate; the output is the
//!   vertical thrust (physics: positive pushes down) and replaces the pilot's vertical
//!   command while the target is set.
//! * Heading: shortest-way error in degrees; derivative on the gyro yaw rate; the
//!   output is a differential thrust added to port and subtracted from starboard around
//!   the pilot's mean horizontal command.
//! * Integrators are clamped, and only integrate while the output is not saturated.

/// Gains and limits of one axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisGains {
    /// Proportional, % per unit of error (m or deg).
    pub kp: f64,
    /// Integral, % per unit·s.
    pub ki: f64,
    /// Derivative on the measured rate, % per unit/s.
    pub kd: f64,
    /// Integrator contribution limit, %.
    pub i_limit_pct: f64,
    /// Output limit, %.
    pub out_limit_pct: f64,
}

/// Settings of the onboard autopilot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AutopilotConfig {
    /// Depth axis (units: m).
    pub depth: AxisGains,
    /// Heading axis (units: deg).
    pub heading: AxisGains,
    /// Time constant of the depth and depth-rate filters, s.
    pub depth_filter_s: f64,
}

impl Default for AutopilotConfig {
    fn default() -> Self {
        Self {
            depth: AxisGains {
                kp: 120.0,
                ki: 15.0,
                kd: 150.0,
                i_limit_pct: 60.0,
                out_limit_pct: 100.0,
            },
            heading: AxisGains {
                kp: 1.2,
                ki: 0.05,
                kd: 0.6,
                i_limit_pct: 20.0,
                out_limit_pct: 60.0,
            },
            depth_filter_s: 0.15,
        }
    }
}

/// One PID axis.
#[derive(Debug, Clone, Copy, Default)]
struct Axis {
    integral: f64,
    active: bool,
}

impl Axis {
    fn update(&mut self, g: &AxisGains, error: f64, rate: f64, dt: f64) -> f64 {
        if !self.active {
            self.active = true;
            self.integral = 0.0;
        }
        let unsat = g.kp * error + g.ki * self.integral - g.kd * rate;
        let out = unsat.clamp(-g.out_limit_pct, g.out_limit_pct);
        // Conditional integration: only while not pushing further into saturation.
        if unsat == out || unsat.signum() != error.signum() {
            self.integral += error * dt;
            if g.ki > 0.0 {
                let lim = g.i_limit_pct / g.ki;
                self.integral = self.integral.clamp(-lim, lim);
            }
        }
        if out.is_finite() { out } else { 0.0 }
    }
}

/// The onboard autopilot state.
#[derive(Debug, Clone)]
pub struct Autopilot {
    cfg: AutopilotConfig,
    depth: Axis,
    heading: Axis,
    depth_f: Option<f64>,
    depth_rate_f: f64,
}

impl Autopilot {
    /// Idle.
    #[must_use]
    pub fn new(cfg: AutopilotConfig) -> Self {
        Self {
            cfg,
            depth: Axis::default(),
            heading: Axis::default(),
            depth_f: None,
            depth_rate_f: 0.0,
        }
    }

    /// Feeds the measured depth every step (keeps the filters warm).
    pub fn observe_depth(&mut self, depth_m: f64, dt: f64) {
        if !depth_m.is_finite() || dt <= 0.0 {
            return;
        }
        let tau = self.cfg.depth_filter_s.max(dt);
        let a = dt / (tau + dt);
        match self.depth_f {
            None => self.depth_f = Some(depth_m),
            Some(prev) => {
                let next = prev + a * (depth_m - prev);
                let rate = (next - prev) / dt;
                self.depth_rate_f += a * (rate - self.depth_rate_f);
                self.depth_f = Some(next);
            }
        }
    }

    /// Vertical thrust, % (positive pushes down), towards `target_depth_m`.
    pub fn depth_output(&mut self, target_depth_m: f64, depth_m: f64, dt: f64) -> f64 {
        let error = target_depth_m - depth_m;
        self.depth
            .update(&self.cfg.depth, error, self.depth_rate_f, dt)
    }

    /// Differential thrust, % (port +, starboard −), towards `target_deg`.
    pub fn heading_output(
        &mut self,
        target_deg: f64,
        heading_deg: f64,
        yaw_rate_dps: f64,
        dt: f64,
    ) -> f64 {
        let error = rov_types::angle::wrap_deg_180(target_deg - heading_deg);
        self.heading
            .update(&self.cfg.heading, error, yaw_rate_dps, dt)
    }

    /// Depth autopilot off (its integrator restarts on the next engage).
    pub fn release_depth(&mut self) {
        self.depth.active = false;
    }

    /// Heading autopilot off.
    pub fn release_heading(&mut self) {
        self.heading.active = false;
    }

    /// Both off and filters cleared (reboot).
    pub fn reset(&mut self) {
        *self = Self::new(self.cfg);
    }
}
