//! Kalman observer on the control plant model (seed 001 eq. 28–32) for the depth and the
//! heading channel.
//!
//! Each channel has the states position, velocity and bias, `x = [p, v, b]`:
//!
//! ```text
//! ṗ = v
//! m·v̇ = −d_eff·v + τ + b + w_f        (w_f: white force noise, PSD σ_f²)
//! ḃ = −b / T_b + w_b                   (first-order Markov bias, PSD σ_b²)
//! ```
//!
//! This is eq. 29–30 restricted to one degree of freedom: heave has no restoring
//! stiffness (G₃₃ = 0, eq. 31–32), yaw has none either (G₆₆ = 0); the bias, in the
//! axis' force units (N or N·m), absorbs net buoyancy, currents, tether pull and model
//! error. `τ` is the force the last command produces according to the selected model's
//! thrust map. `d_eff = d_l + d_q·|v̂|` is the damping secant at the current velocity
//! estimate (a quasi-LPV form of the model's quadratic drag; with `d_q = 0` it is exactly
//! the linear control plant model).
//!
//! **Discretisation.** For each actual dt the continuous model is discretised exactly up to
//! truncation: `Φ = e^{A·dt}` and `Ψ = ∫₀^dt e^{A·s} ds` by a 6th-order Taylor series with
//! scaling and squaring, and `Q_d = ∫₀^dt Φ(s) Q_c Φ(s)ᵀ ds` by a 3rd-order series on the
//! scaled step, doubled with `Q(2h) = Q(h) + Φ(h) Q(h) Φ(h)ᵀ`. So uneven dt (and long gaps)
//! are handled without a fixed rate.
//!
//! **Manoeuvre detection.** The process noise is tuned small for smooth estimates, which
//! would make the filter treat a sudden large disturbance (a snagged tether) as a run of
//! outliers. A running mean of the normalised position innovations detects a persistent
//! one-sided innovation; while it lasts, the force and bias noise are boosted and the gate
//! widened, so the estimate and the bias follow the vehicle (classical manoeuvre
//! detection with process-noise switching). A single outlier moves the mean by at most
//! `0.1 × gate` and never triggers it.
//!
//! **Robustness.** A missing sample or a non-finite one is the same thing: predict only,
//! and the filter state is bit-for-bit the same as for a dropout. Innovations beyond
//! `gate_sigma` standard deviations are rejected and counted; after
//! `reset_after_rejects` consecutive rejections the position is re-initialised to the
//! measurement (a genuine jump, e.g. a re-tare). Heading innovations are wrapped to ±π
//! and the heading estimate kept in `[0, 2π)`. The covariance update uses the Joseph form
//! and is re-symmetrised each step, so it stays symmetric positive semi-definite; its
//! trace is capped so a very long dropout cannot overflow it.

use nalgebra::{Matrix3, Vector3};

use crate::angle::{wrap_2pi, wrap_pi};
use crate::error::{ControlError, check_range};
use crate::feedforward::AxisDynamics;

/// Cap on the covariance trace (in the channel's squared units).
const TRACE_CAP: f64 = 1e8;
/// Weight of one position sample in the running mean of normalised innovations (a time
/// constant of about 10 samples, 0.2 s at 50 Hz).
const MANOEUVRE_WEIGHT: f64 = 0.1;

/// Noise and robustness settings of one channel, in the channel's SI units (m and N for
/// depth, rad and N·m for heading).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChannelNoise {
    /// Square root of the white force-noise PSD σ_f (N/√Hz or N·m/√Hz): unmodelled fast
    /// forces, including model error during manoeuvres.
    pub force_noise: f64,
    /// Square root of the bias-noise PSD σ_b (N/√s or N·m/√s): how fast the bias may
    /// wander.
    pub bias_noise: f64,
    /// Bias time constant T_b, s (large = nearly a random walk).
    pub bias_time_constant_s: f64,
    /// Standard deviation of a position measurement (m or rad).
    pub meas_std: f64,
    /// Standard deviation of a rate measurement (m/s or rad/s), for a gyro.
    pub rate_meas_std: f64,
    /// Innovation gate in standard deviations.
    pub gate_sigma: f64,
    /// Consecutive rejections after which the position is re-initialised.
    pub reset_after_rejects: u32,
    /// Manoeuvre detection: when the running mean of the normalised position innovations
    /// (clipped to the gate, weight 0.1 per sample) exceeds this magnitude, the model is
    /// off (a sudden disturbance), not the samples; 0 disables.
    pub manoeuvre_threshold: f64,
    /// While a manoeuvre is detected the force and bias noise are multiplied by this factor
    /// and the gate is widened four times, so the filter follows the vehicle instead of
    /// rejecting it (≥ 1).
    pub manoeuvre_noise_factor: f64,
    /// Initial velocity standard deviation (m/s or rad/s).
    pub init_vel_std: f64,
    /// Initial bias standard deviation (N or N·m).
    pub init_bias_std: f64,
}

impl ChannelNoise {
    /// Checks the fields; `name` prefixes error keys.
    pub fn validate(&self, name: &str) -> Result<(), ControlError> {
        check_range(&format!("{name}.force_noise"), self.force_noise, 1e-9, 1e4)?;
        check_range(&format!("{name}.bias_noise"), self.bias_noise, 0.0, 1e4)?;
        check_range(
            &format!("{name}.bias_time_constant_s"),
            self.bias_time_constant_s,
            1.0,
            1e7,
        )?;
        check_range(&format!("{name}.meas_std"), self.meas_std, 1e-9, 1e3)?;
        check_range(
            &format!("{name}.rate_meas_std"),
            self.rate_meas_std,
            1e-9,
            1e3,
        )?;
        check_range(&format!("{name}.gate_sigma"), self.gate_sigma, 1.0, 1e3)?;
        check_range(
            &format!("{name}.reset_after_rejects"),
            f64::from(self.reset_after_rejects),
            1.0,
            1e6,
        )?;
        check_range(
            &format!("{name}.manoeuvre_threshold"),
            self.manoeuvre_threshold,
            0.0,
            100.0,
        )?;
        check_range(
            &format!("{name}.manoeuvre_noise_factor"),
            self.manoeuvre_noise_factor,
            1.0,
            1e4,
        )?;
        check_range(&format!("{name}.init_vel_std"), self.init_vel_std, 0.0, 1e3)?;
        check_range(
            &format!("{name}.init_bias_std"),
            self.init_bias_std,
            0.0,
            1e4,
        )?;
        Ok(())
    }
}

/// What happened to one sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SampleOutcome {
    /// No sample this tick, or a non-finite one (the same thing): predict only.
    #[default]
    Missing,
    /// The first valid sample: the channel was initialised from it.
    Initialised,
    /// Used in the update.
    Accepted,
    /// Rejected by the innovation gate (counted).
    Rejected,
    /// Accepted after too many consecutive rejections: position re-initialised.
    Reset,
}

/// Counters of one channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ChannelStats {
    /// Samples used.
    pub accepted: u64,
    /// Samples rejected by the gate.
    pub rejected: u64,
    /// Ticks without a (finite) sample.
    pub missing: u64,
    /// Position re-initialisations after consecutive rejections.
    pub resets: u64,
    /// Manoeuvres detected (onsets).
    pub manoeuvres: u64,
}

/// Estimate of one channel.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ChannelEstimate {
    /// Position (depth m, or heading rad in `[0, 2π)`).
    pub pos: f64,
    /// Velocity (m/s or rad/s).
    pub vel: f64,
    /// Bias force (N, positive down) or moment (N·m, positive to starboard).
    pub bias: f64,
    /// Standard deviation of the position (m or rad).
    pub pos_std: f64,
}

/// One Kalman channel (position, velocity, bias).
#[derive(Debug, Clone)]
pub struct KalmanChannel {
    noise: ChannelNoise,
    angle: bool,
    initialised: bool,
    x: Vector3<f64>,
    p: Matrix3<f64>,
    consecutive_rejects: u32,
    /// Running mean of the clipped normalised position innovations.
    innovation_mean: f64,
    manoeuvring: bool,
    stats: ChannelStats,
}

/// Discretisation of `ẋ = A x + B u` with process noise `Q_c` over `dt`.
struct Discrete {
    phi: Matrix3<f64>,
    psi: Matrix3<f64>,
    qd: Matrix3<f64>,
}

fn discretise(a: &Matrix3<f64>, qc: &Matrix3<f64>, dt: f64) -> Discrete {
    // Infinity norm of A·dt decides the number of halvings.
    let mut norm = 0.0_f64;
    for r in 0..3 {
        let row = a.row(r);
        norm = norm.max(row.iter().map(|v| v.abs()).sum::<f64>());
    }
    let mut s = 0u32;
    let mut scaled = norm * dt;
    while scaled > 0.125 && s < 200 {
        scaled *= 0.5;
        s += 1;
    }
    let h = dt * 0.5_f64.powi(s as i32);
    let ah = a * h;
    let eye = Matrix3::identity();
    // Φ = Σ (Ah)^k / k!,  Ψ = h Σ (Ah)^k / (k+1)!
    let mut term = eye;
    let mut phi = eye;
    let mut psi_sum = eye;
    let mut fact_k = 1.0;
    for k in 1..=6u32 {
        term *= ah;
        fact_k *= f64::from(k);
        phi += term / fact_k;
        psi_sum += term / (fact_k * f64::from(k + 1));
    }
    let mut psi = psi_sum * h;
    let aq = a * qc;
    let aqat = aq * a.transpose();
    let a2q = a * aq;
    let mut qd = qc * h
        + (aq + aq.transpose()) * (h * h / 2.0)
        + (a2q + aqat * 2.0 + a2q.transpose()) * (h * h * h / 6.0);
    for _ in 0..s {
        qd += phi * qd * phi.transpose();
        psi += phi * psi;
        phi *= phi;
    }
    qd = (qd + qd.transpose()) * 0.5;
    Discrete { phi, psi, qd }
}

impl KalmanChannel {
    /// A linear (depth) channel, uninitialised until the first valid sample.
    pub fn new(noise: ChannelNoise) -> Self {
        Self::build(noise, false)
    }

    /// An angle (heading, rad) channel.
    pub fn new_angle(noise: ChannelNoise) -> Self {
        Self::build(noise, true)
    }

    fn build(noise: ChannelNoise, angle: bool) -> Self {
        Self {
            noise,
            angle,
            initialised: false,
            x: Vector3::zeros(),
            p: Matrix3::zeros(),
            consecutive_rejects: 0,
            innovation_mean: 0.0,
            manoeuvring: false,
            stats: ChannelStats::default(),
        }
    }

    /// The noise settings.
    pub fn noise(&self) -> &ChannelNoise {
        &self.noise
    }

    /// Replaces the noise settings, keeping the state.
    pub fn set_noise(&mut self, noise: ChannelNoise) {
        self.noise = noise;
    }

    /// Whether a valid sample has initialised the channel.
    pub fn is_initialised(&self) -> bool {
        self.initialised
    }

    /// The estimate, or `None` before initialisation.
    pub fn estimate(&self) -> Option<ChannelEstimate> {
        self.initialised.then(|| ChannelEstimate {
            pos: self.x.x,
            vel: self.x.y,
            bias: self.x.z,
            pos_std: self.p.m11.max(0.0).sqrt(),
        })
    }

    /// The state vector `[pos, vel, bias]`.
    pub fn state(&self) -> Vector3<f64> {
        self.x
    }

    /// The covariance of `[pos, vel, bias]`.
    pub fn covariance(&self) -> Matrix3<f64> {
        self.p
    }

    /// Counters.
    pub fn stats(&self) -> ChannelStats {
        self.stats
    }

    /// Forgets everything (back to uninitialised); counters are kept.
    pub fn reset(&mut self) {
        self.initialised = false;
        self.x = Vector3::zeros();
        self.p = Matrix3::zeros();
        self.consecutive_rejects = 0;
        self.innovation_mean = 0.0;
        self.manoeuvring = false;
    }

    /// Whether a manoeuvre (a disturbance the model did not expect) is being tracked.
    pub fn is_manoeuvring(&self) -> bool {
        self.manoeuvring
    }

    /// Time update over `dt_s` with the force `input` (N or N·m) applied during the
    /// interval and the axis dynamics `plant`. Does nothing before initialisation, for
    /// `dt_s <= 0` or for non-finite arguments.
    pub fn predict(&mut self, dt_s: f64, input: f64, plant: &AxisDynamics) {
        if !(self.initialised && dt_s.is_finite() && dt_s > 0.0 && input.is_finite()) {
            return;
        }
        let m = plant.inertia;
        if !(m.is_finite() && m > 0.0) {
            return;
        }
        let d_eff = plant.damping_lin + plant.damping_quad * self.x.y.abs();
        let d_eff = if d_eff.is_finite() {
            d_eff.clamp(0.0, 1e4)
        } else {
            0.0
        };
        let c = 1.0 / self.noise.bias_time_constant_s;
        #[rustfmt::skip]
        let a = Matrix3::new(
            0.0, 1.0, 0.0,
            0.0, -d_eff / m, 1.0 / m,
            0.0, 0.0, -c,
        );
        let boost = if self.manoeuvring {
            self.noise.manoeuvre_noise_factor
        } else {
            1.0
        };
        let qf = boost * self.noise.force_noise / m;
        let qb = boost * self.noise.bias_noise;
        let qc = Matrix3::from_diagonal(&Vector3::new(0.0, qf * qf, qb * qb));
        let disc = discretise(&a, &qc, dt_s);
        let b = Vector3::new(0.0, 1.0 / m, 0.0);
        let x_new = disc.phi * self.x + disc.psi * b * input;
        let mut p_new = disc.phi * self.p * disc.phi.transpose() + disc.qd;
        p_new = (p_new + p_new.transpose()) * 0.5;
        let trace = p_new.trace();
        if trace > TRACE_CAP {
            p_new *= TRACE_CAP / trace;
        }
        if x_new.iter().all(|v| v.is_finite()) && p_new.iter().all(|v| v.is_finite()) {
            self.x = x_new;
            if self.angle {
                self.x.x = wrap_2pi(self.x.x);
            }
            self.p = p_new;
        }
    }

    /// Measurement update with a position sample (m, or rad for headings). `None` and
    /// non-finite values are a missing sample.
    pub fn update_position(&mut self, z: Option<f64>) -> SampleOutcome {
        let Some(z) = z.filter(|v| v.is_finite()) else {
            self.stats.missing += 1;
            return SampleOutcome::Missing;
        };
        let z = if self.angle { wrap_2pi(z) } else { z };
        if !self.initialised {
            let r = self.noise.meas_std * self.noise.meas_std;
            let v0 = self.noise.init_vel_std * self.noise.init_vel_std;
            let b0 = self.noise.init_bias_std * self.noise.init_bias_std;
            self.x = Vector3::new(z, 0.0, 0.0);
            self.p = Matrix3::from_diagonal(&Vector3::new(r, v0, b0));
            self.initialised = true;
            self.consecutive_rejects = 0;
            self.stats.accepted += 1;
            return SampleOutcome::Initialised;
        }
        let innovation = if self.angle {
            wrap_pi(z - self.x.x)
        } else {
            z - self.x.x
        };
        let r = self.noise.meas_std * self.noise.meas_std;
        self.track_manoeuvre(innovation, r);
        let gate_scale = if self.manoeuvring { 4.0 } else { 1.0 };
        match self.scalar_update(0, innovation, r, gate_scale) {
            SampleOutcome::Rejected
                if self.consecutive_rejects >= self.noise.reset_after_rejects =>
            {
                // A persistent jump (or a filter that has lost track): re-initialise the
                // position from the sample and reopen the velocity and bias covariance,
                // keeping their values as the best guess.
                self.x.x = z;
                let v0 = self.noise.init_vel_std * self.noise.init_vel_std;
                let b0 = self.noise.init_bias_std * self.noise.init_bias_std;
                self.p = Matrix3::from_diagonal(&Vector3::new(r, v0, b0));
                self.consecutive_rejects = 0;
                self.stats.resets += 1;
                self.stats.rejected = self.stats.rejected.saturating_sub(1);
                self.stats.accepted += 1;
                SampleOutcome::Reset
            }
            other => other,
        }
    }

    /// Measurement update with a rate sample (m/s, or rad/s from a gyro). Missing or
    /// non-finite samples are ignored (and not counted: the position sample counts).
    pub fn update_rate(&mut self, z: Option<f64>) -> SampleOutcome {
        let Some(z) = z.filter(|v| v.is_finite()) else {
            return SampleOutcome::Missing;
        };
        if !self.initialised {
            return SampleOutcome::Missing;
        }
        let r = self.noise.rate_meas_std * self.noise.rate_meas_std;
        let innovation = z - self.x.y;
        let gate_scale = if self.manoeuvring { 4.0 } else { 1.0 };
        self.scalar_update(1, innovation, r, gate_scale)
    }

    /// Updates the running mean of the normalised position innovations and the
    /// manoeuvre flag (with hysteresis: on above the threshold, off below half of it).
    fn track_manoeuvre(&mut self, innovation: f64, r: f64) {
        let thr = self.noise.manoeuvre_threshold;
        let s = self.p.m11 + r;
        if thr <= 0.0 || !(s > 0.0 && innovation.is_finite()) {
            return;
        }
        let g = self.noise.gate_sigma;
        let nu = (innovation / s.sqrt()).clamp(-g, g);
        self.innovation_mean += MANOEUVRE_WEIGHT * (nu - self.innovation_mean);
        let level = self.innovation_mean.abs();
        if !self.manoeuvring && level > thr {
            self.manoeuvring = true;
            self.stats.manoeuvres += 1;
        } else if self.manoeuvring && level < 0.5 * thr {
            self.manoeuvring = false;
        }
    }

    /// Scalar Kalman update of state `i` with `innovation` and variance `r`, gated at
    /// `gate_scale` times the configured gate; Joseph form.
    fn scalar_update(
        &mut self,
        i: usize,
        innovation: f64,
        r: f64,
        gate_scale: f64,
    ) -> SampleOutcome {
        let Some(&p_ii) = self.p.get((i, i)) else {
            return SampleOutcome::Missing;
        };
        let s = p_ii + r;
        let gate = self.noise.gate_sigma * gate_scale;
        if !(innovation.is_finite() && s.is_finite() && s > 0.0)
            || innovation * innovation > gate * gate * s
        {
            self.stats.rejected += 1;
            self.consecutive_rejects = self.consecutive_rejects.saturating_add(1);
            return SampleOutcome::Rejected;
        }
        let k: Vector3<f64> = self.p.column(i) / s;
        let mut h = nalgebra::RowVector3::zeros();
        if let Some(hi) = h.get_mut(i) {
            *hi = 1.0;
        }
        let ikh = Matrix3::identity() - k * h;
        let p_new = ikh * self.p * ikh.transpose() + k * k.transpose() * r;
        let x_new = self.x + k * innovation;
        if !(x_new.iter().all(|v| v.is_finite()) && p_new.iter().all(|v| v.is_finite())) {
            self.stats.rejected += 1;
            self.consecutive_rejects = self.consecutive_rejects.saturating_add(1);
            return SampleOutcome::Rejected;
        }
        self.x = x_new;
        if self.angle {
            self.x.x = wrap_2pi(self.x.x);
        }
        self.p = (p_new + p_new.transpose()) * 0.5;
        self.consecutive_rejects = 0;
        self.stats.accepted += 1;
        SampleOutcome::Accepted
    }
}

/// The depth and heading channels together.
#[derive(Debug, Clone)]
pub struct Observer {
    /// Depth channel: m, m/s, N (positive down).
    pub depth: KalmanChannel,
    /// Heading channel: rad, rad/s, N·m (positive to starboard).
    pub heading: KalmanChannel,
}

impl Observer {
    /// Both channels, uninitialised.
    pub fn new(depth: ChannelNoise, heading: ChannelNoise) -> Self {
        Self {
            depth: KalmanChannel::new(depth),
            heading: KalmanChannel::new_angle(heading),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plant() -> AxisDynamics {
        AxisDynamics {
            inertia: 11.1,
            damping_lin: 4.8,
            damping_quad: 34.0,
            static_load: 0.0,
        }
    }

    fn noise() -> ChannelNoise {
        ChannelNoise {
            force_noise: 1.0,
            bias_noise: 0.2,
            bias_time_constant_s: 600.0,
            meas_std: 0.01,
            rate_meas_std: 0.01,
            gate_sigma: 5.0,
            reset_after_rejects: 25,
            manoeuvre_threshold: 1.5,
            manoeuvre_noise_factor: 30.0,
            init_vel_std: 0.5,
            init_bias_std: 5.0,
        }
    }

    #[test]
    fn discretisation_matches_closed_form_double_integrator() {
        // A with no damping and no bias decay: Φ = [[1, dt, dt²/2m], [0, 1, dt/m], [0, 0, 1]].
        let m = 2.0;
        #[rustfmt::skip]
        let a = Matrix3::new(0.0, 1.0, 0.0, 0.0, 0.0, 1.0 / m, 0.0, 0.0, 0.0);
        let q = 0.3;
        let qc = Matrix3::from_diagonal(&Vector3::new(0.0, q, 0.0));
        for dt in [0.001, 0.02, 0.7, 5.0, 100.0] {
            let d = discretise(&a, &qc, dt);
            assert!((d.phi.m12 - dt).abs() < 1e-9 * dt.max(1.0));
            assert!((d.phi.m13 - dt * dt / (2.0 * m)).abs() < 1e-9 * (dt * dt).max(1.0));
            assert!((d.psi.m12 - dt * dt / 2.0).abs() < 1e-9 * (dt * dt).max(1.0));
            // White-noise acceleration: Q = q [[dt³/3, dt²/2], [dt²/2, dt]].
            assert!((d.qd.m11 - q * dt.powi(3) / 3.0).abs() < 1e-9 * dt.powi(3).max(1.0));
            assert!((d.qd.m12 - q * dt * dt / 2.0).abs() < 1e-9 * (dt * dt).max(1.0));
            assert!((d.qd.m22 - q * dt).abs() < 1e-9 * dt.max(1.0));
        }
    }

    #[test]
    fn discretisation_of_damped_velocity() {
        let (m, d) = (11.1, 4.8);
        #[rustfmt::skip]
        let a = Matrix3::new(0.0, 1.0, 0.0, 0.0, -d / m, 1.0 / m, 0.0, 0.0, -0.01);
        for dt in [0.02, 1.3, 30.0] {
            let disc = discretise(&a, &Matrix3::zeros(), dt);
            assert!((disc.phi.m22 - (-d / m * dt).exp()).abs() < 1e-9);
            assert!((disc.phi.m33 - (-0.01 * dt).exp()).abs() < 1e-9);
            assert!((disc.psi.m22 - (1.0 - (-d / m * dt).exp()) * m / d).abs() < 1e-8);
        }
    }

    #[test]
    fn nan_is_a_dropout_bit_for_bit() {
        let mut a = KalmanChannel::new(noise());
        let mut b = KalmanChannel::new(noise());
        let pl = plant();
        for k in 0..200 {
            let z = 0.01 * k as f64;
            let (za, zb) = if k % 7 == 3 {
                (Some(f64::NAN), None)
            } else {
                (Some(z), Some(z))
            };
            a.predict(0.02, 1.0, &pl);
            b.predict(0.02, 1.0, &pl);
            assert_eq!(a.update_position(za), b.update_position(zb));
            for (x, y) in a.state().iter().zip(b.state().iter()) {
                assert_eq!(x.to_bits(), y.to_bits());
            }
            for (x, y) in a.covariance().iter().zip(b.covariance().iter()) {
                assert_eq!(x.to_bits(), y.to_bits());
            }
        }
        assert_eq!(a.stats(), b.stats());
    }

    #[test]
    fn persistent_jump_is_accepted_after_reset_count() {
        let mut c = KalmanChannel::new(noise());
        let pl = plant();
        c.update_position(Some(5.0));
        for _ in 0..100 {
            c.predict(0.02, 0.0, &pl);
            c.update_position(Some(5.0));
        }
        let mut outcomes = Vec::new();
        for _ in 0..30 {
            c.predict(0.02, 0.0, &pl);
            outcomes.push(c.update_position(Some(8.0)));
        }
        // Followed after at most `reset_after_rejects` samples (by the manoeuvre logic or
        // the reset), never ignored.
        assert!(
            outcomes
                .iter()
                .any(|o| matches!(o, SampleOutcome::Reset | SampleOutcome::Accepted)),
            "{outcomes:?}"
        );
        assert!((c.estimate().unwrap().pos - 8.0).abs() < 0.05);
    }

    #[test]
    fn heading_innovation_is_wrapped() {
        let mut c = KalmanChannel::new_angle(ChannelNoise {
            meas_std: 0.005,
            ..noise()
        });
        let pl = AxisDynamics {
            inertia: 0.15,
            damping_lin: 0.04,
            damping_quad: 0.8,
            static_load: 0.0,
        };
        c.update_position(Some(359.5f64.to_radians()));
        for k in 0..100 {
            c.predict(0.02, 0.0, &pl);
            let z = if k % 2 == 0 { 0.5f64 } else { 359.5 };
            assert_ne!(
                c.update_position(Some(z.to_radians())),
                SampleOutcome::Rejected
            );
        }
        let e = c.estimate().unwrap();
        assert!(wrap_pi(e.pos).abs() < 1f64.to_radians(), "{e:?}");
    }
}
