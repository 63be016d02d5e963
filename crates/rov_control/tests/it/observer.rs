//! Observer tests on synthetic truth (D1, D3, C2).

use crate::common::{Rng, rms};
use nalgebra::Matrix3;
use rov_control::{AxisDynamics, ChannelNoise, KalmanChannel, SampleOutcome};

fn noise(meas_std: f64) -> ChannelNoise {
    ChannelNoise {
        force_noise: 0.5,
        bias_noise: 0.05,
        bias_time_constant_s: 1000.0,
        meas_std,
        rate_meas_std: 0.01,
        gate_sigma: 5.0,
        reset_after_rejects: 25,
        manoeuvre_threshold: 1.5,
        manoeuvre_noise_factor: 30.0,
        init_vel_std: 0.5,
        init_bias_std: 5.0,
    }
}

/// Double integrator m·v̇ = u + b with a constant bias b, known input u, noisy samples.
struct Truth {
    m: f64,
    p: f64,
    v: f64,
    b: f64,
}

impl Truth {
    fn step(&mut self, u: f64, dt: f64) {
        let n = 20;
        let h = dt / n as f64;
        for _ in 0..n {
            self.v += (u + self.b) / self.m * h;
            self.p += self.v * h;
        }
    }
}

fn double_integrator() -> AxisDynamics {
    AxisDynamics {
        inertia: 11.1,
        damping_lin: 0.0,
        damping_quad: 0.0,
        static_load: 0.0,
    }
}

#[test]
fn estimate_beats_measurement_and_bias_converges() {
    let mut rng = Rng::new(1);
    let sigma = 0.03;
    let plant = double_integrator();
    let mut truth = Truth {
        m: plant.inertia,
        p: 5.0,
        v: 0.0,
        b: 1.5,
    };
    let mut kf = KalmanChannel::new(noise(sigma));
    let dt = 0.02;
    let (mut est_err, mut meas_err) = (Vec::new(), Vec::new());
    let mut bias_late = Vec::new();
    for k in 0..(300.0 / dt) as usize {
        let t = k as f64 * dt;
        // A known input that keeps the vehicle moving near its start: a PD toward 5 m
        // computed on the truth plus a sine (the observer only sees u).
        let u = -1.5 + 4.0 * (0.3 * t).sin() - 8.0 * (truth.p - 5.0) - 10.0 * truth.v;
        kf.predict(dt, u, &plant);
        truth.step(u, dt);
        let z = truth.p + sigma * rng.normal();
        kf.update_position(Some(z));
        if t > 30.0 {
            let e = kf.estimate().unwrap();
            est_err.push(e.pos - truth.p);
            meas_err.push(z - truth.p);
            if t > 200.0 {
                bias_late.push(e.bias);
            }
        }
    }
    let (re, rm) = (rms(&est_err), rms(&meas_err));
    assert!(re < 0.7 * rm, "estimate RMSE {re} vs measurement {rm}");
    let b_mean = bias_late.iter().sum::<f64>() / bias_late.len() as f64;
    assert!((b_mean - 1.5).abs() < 0.15, "bias {b_mean} vs 1.5");
}

#[test]
fn d3_single_10m_spike_is_gated() {
    let mut rng = Rng::new(2);
    let plant = AxisDynamics {
        inertia: 11.1,
        damping_lin: 4.8,
        damping_quad: 34.0,
        static_load: 0.0,
    };
    let mut kf = KalmanChannel::new(noise(0.01));
    let dt = 0.02;
    for _ in 0..1000 {
        kf.predict(dt, 0.0, &plant);
        kf.update_position(Some(5.0 + 0.01 * rng.normal()));
    }
    let before = kf.estimate().unwrap();
    let rejected_before = kf.stats().rejected;
    kf.predict(dt, 0.0, &plant);
    assert_eq!(kf.update_position(Some(15.0)), SampleOutcome::Rejected);
    assert_eq!(kf.stats().rejected, rejected_before + 1);
    let mut max_dev = (kf.estimate().unwrap().pos - before.pos).abs();
    for _ in 0..200 {
        kf.predict(dt, 0.0, &plant);
        kf.update_position(Some(5.0 + 0.01 * rng.normal()));
        max_dev = max_dev.max((kf.estimate().unwrap().pos - 5.0).abs());
    }
    assert!(max_dev < 0.05, "moved by {max_dev}");
}

fn assert_sym_psd(p: &Matrix3<f64>, step: usize) {
    let asym = (p - p.transpose()).abs().max();
    assert!(
        asym <= 1e-12 * p.abs().max().max(1.0),
        "step {step}: asymmetric {asym}"
    );
    let eig = p.symmetric_eigen().eigenvalues;
    assert!(
        eig.min() >= -1e-9,
        "step {step}: min eigenvalue {} of {p}",
        eig.min()
    );
}

/// D1: 10⁵ random steps (uneven dt, dropouts, NaN, outliers, wild inputs).
#[test]
fn d1_covariance_stays_symmetric_psd() {
    let mut rng = Rng::new(3);
    let depth_plant = AxisDynamics {
        inertia: 11.1,
        damping_lin: 4.8,
        damping_quad: 34.0,
        static_load: 0.0,
    };
    let yaw_plant = AxisDynamics {
        inertia: 0.149,
        damping_lin: 0.04,
        damping_quad: 0.8,
        static_load: 0.0,
    };
    let mut depth = KalmanChannel::new(noise(0.01));
    let mut heading = KalmanChannel::new_angle(noise(0.01));
    let mut z = 3.0;
    for step in 0..100_000 {
        let dt = match rng.uniform() {
            x if x < 0.8 => 0.02,
            x if x < 0.95 => 0.001 + 0.2 * rng.uniform(),
            _ => 3.0 * rng.uniform(),
        };
        let u = 20.0 * (rng.uniform() - 0.5);
        depth.predict(dt, u, &depth_plant);
        heading.predict(dt, 0.2 * u, &yaw_plant);
        z += 0.05 * rng.normal();
        let sample = match rng.uniform() {
            x if x < 0.1 => None,
            x if x < 0.13 => Some(f64::NAN),
            x if x < 0.16 => Some(z + 100.0 * rng.normal()),
            x if x < 0.17 => Some(f64::INFINITY),
            _ => Some(z + 0.01 * rng.normal()),
        };
        depth.update_position(sample);
        heading.update_position(sample.map(|s| s * 0.7));
        if rng.uniform() < 0.3 {
            heading.update_rate(Some(0.1 * rng.normal()));
        }
        assert_sym_psd(&depth.covariance(), step);
        assert_sym_psd(&heading.covariance(), step);
        assert!(depth.state().iter().all(|v| v.is_finite()));
        assert!(heading.state().iter().all(|v| v.is_finite()));
    }
    assert!(depth.stats().rejected > 0 && depth.stats().missing > 0);
}

/// Uneven dt: the same truth sampled at irregular times is still tracked.
#[test]
fn uneven_dt_tracking() {
    let mut rng = Rng::new(4);
    let plant = double_integrator();
    let mut truth = Truth {
        m: plant.inertia,
        p: 0.0,
        v: 0.0,
        b: 0.0,
    };
    let mut kf = KalmanChannel::new(noise(0.01));
    let mut errs = Vec::new();
    let mut t = 0.0_f64;
    while t < 120.0 {
        let dt = 0.005 + 0.1 * rng.uniform();
        let u = 3.0 * (0.5 * t).sin();
        kf.predict(dt, u, &plant);
        truth.step(u, dt);
        t += dt;
        kf.update_position(Some(truth.p + 0.01 * rng.normal()));
        if t > 20.0 {
            errs.push(kf.estimate().unwrap().pos - truth.p);
        }
    }
    assert!(rms(&errs) < 0.01, "{}", rms(&errs));
}
