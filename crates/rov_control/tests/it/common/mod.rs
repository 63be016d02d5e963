//! Shared helpers of the integration tests: a small deterministic RNG, step-response
//! metrics and a 1-DOF heave/yaw plant.
#![allow(dead_code)]

use rov_control::PlantModel;
use rov_control::angle::wrap_deg_180;

/// SplitMix64 with Box–Muller normals (deterministic, no dependencies).
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed ^ 0x9E37_79B9_7F4A_7C15)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Standard normal.
    pub fn normal(&mut self) -> f64 {
        let u1 = self.uniform().max(1e-300);
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

/// Step-response figures, computed on the true values.
#[derive(Debug, Clone, Copy)]
pub struct StepMetrics {
    /// From the start until the value enters the band and stays; None if never.
    pub settle_s: Option<f64>,
    /// Largest excursion past the target in the direction of the step (units of the
    /// axis), ≥ 0.
    pub overshoot: f64,
    /// Mean absolute error over the last `window_s`.
    pub steady_error: f64,
    /// RMS error over the whole run.
    pub rmse: f64,
}

/// Metrics of a step from `start` to `target` (angles in degrees if `angle`).
pub fn step_metrics(
    t: &[f64],
    truth: &[f64],
    start: f64,
    target: f64,
    band: f64,
    window_s: f64,
    angle: bool,
) -> StepMetrics {
    let err = |v: f64| {
        if angle {
            wrap_deg_180(v - target)
        } else {
            v - target
        }
    };
    let dir = if angle {
        wrap_deg_180(target - start).signum()
    } else {
        (target - start).signum()
    };
    let mut last_out: Option<usize> = None;
    let mut overshoot = 0.0_f64;
    let mut sq = 0.0;
    for (k, &v) in truth.iter().enumerate() {
        let e = err(v);
        if e.abs() > band {
            last_out = Some(k);
        }
        overshoot = overshoot.max(e * dir);
        sq += e * e;
    }
    let settle_s = match last_out {
        None => Some(0.0),
        Some(k) if k + 1 < t.len() => Some(t[k + 1] - t[0]),
        Some(_) => None,
    };
    let t_end = *t.last().unwrap();
    let window: Vec<f64> = t
        .iter()
        .zip(truth)
        .filter(|(tt, _)| **tt >= t_end - window_s)
        .map(|(_, v)| err(*v).abs())
        .collect();
    StepMetrics {
        settle_s,
        overshoot,
        steady_error: window.iter().sum::<f64>() / window.len() as f64,
        rmse: (sq / truth.len() as f64).sqrt(),
    }
}

/// RMS of a slice.
pub fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

/// A decoupled heave + yaw plant with a model's parameters (for quick loop checks
/// without the 6-DOF simulator).
#[derive(Debug, Clone)]
pub struct AxisPlant {
    pub model: PlantModel,
    pub depth_m: f64,
    pub w_mps: f64,
    pub heading_rad: f64,
    pub r_rad_s: f64,
    /// Constant external heave force (N, down) and yaw moment (N·m).
    pub heave_disturbance_n: f64,
    pub yaw_disturbance_nm: f64,
}

impl AxisPlant {
    pub fn new(model: PlantModel, depth_m: f64, heading_deg: f64) -> Self {
        AxisPlant {
            model,
            depth_m,
            w_mps: 0.0,
            heading_rad: heading_deg.to_radians(),
            r_rad_s: 0.0,
            heave_disturbance_n: 0.0,
            yaw_disturbance_nm: 0.0,
        }
    }

    /// Advances by `dt` with the thruster commands held (1 ms Euler sub-steps).
    pub fn step(&mut self, port_pct: f64, stbd_pct: f64, vert_pct: f64, dt: f64) {
        use rov_control::FeedforwardModel;
        let m = &self.model;
        let fz =
            m.vertical_force_for_pct(vert_pct) + self.heave_disturbance_n + m.heave.static_load;
        let n = m.yaw_moment_for_pct(port_pct, stbd_pct) + self.yaw_disturbance_nm;
        let steps = (dt / 0.001).round().max(1.0) as usize;
        let h = dt / steps as f64;
        for _ in 0..steps {
            let h_ax = &m.heave;
            let wdot = (fz
                - (h_ax.damping_lin + h_ax.damping_quad * self.w_mps.abs()) * self.w_mps)
                / h_ax.inertia;
            let y_ax = &m.yaw;
            let rdot = (n
                - (y_ax.damping_lin + y_ax.damping_quad * self.r_rad_s.abs()) * self.r_rad_s)
                / y_ax.inertia;
            self.w_mps += wdot * h;
            self.r_rad_s += rdot * h;
            self.depth_m += self.w_mps * h;
            self.heading_rad += self.r_rad_s * h;
        }
    }

    pub fn heading_deg(&self) -> f64 {
        rov_control::angle::wrap_deg_360(self.heading_rad.to_degrees())
    }
}

pub mod sim6;
