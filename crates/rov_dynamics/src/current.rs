//! Ocean current (seed 001 eq. 33–37): constant, or a first-order Gauss–Markov process
//! for the speed V_c, the vertical angle α_c and the direction β_c, driven by a seeded
//! deterministic RNG.
//!
//! Velocity in NED (eq. 33): v_c^n = R_y(α_c)ᵀ R_z(−β_c)ᵀ [V_c, 0, 0]ᵀ
//! = V_c (cos α_c cos β_c, sin β_c, sin α_c cos β_c). β_c is the direction the water flows
//! towards, from north, clockwise; α_c > 0 tilts the flow downwards.
//!
//! Gauss–Markov (eq. 34–36): ẋ + μ (x − x̄) = w with white noise w of intensity σ
//! (units per √s). x̄ = 0 is the equation exactly as written in the seed; a non-zero
//! mean lets a direction wander around a prevailing value. Discretised with
//! Euler–Maruyama: x_{k+1} = x_k − h μ (x_k − x̄) + σ √h n_k, n_k ~ N(0, 1). The speed is
//! clamped to [V_min, V_max] after every step. The time step is an argument.
//!
//! RNG: `rand::rngs::StdRng` seeded with `seed_from_u64`, deterministic for a given seed
//! and build (the rand crate does not promise the same stream across its major versions).

use nalgebra::Vector3;
use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, StandardNormal};

use crate::error::DynamicsError;
use crate::process::CurrentSample;

/// One first-order Gauss–Markov channel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GaussMarkovChannel {
    /// Initial value.
    pub initial: f64,
    /// μ ≥ 0, 1/s (0 gives a random walk).
    pub mu_per_s: f64,
    /// Mean x̄ the process reverts to (0 = the seed's equation literally).
    pub mean: f64,
    /// Noise intensity σ ≥ 0, units/√s.
    pub sigma: f64,
}

impl GaussMarkovChannel {
    /// A channel that stays at `value`.
    pub fn fixed(value: f64) -> Self {
        Self {
            initial: value,
            mu_per_s: 0.0,
            mean: value,
            sigma: 0.0,
        }
    }
}

/// The current model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CurrentModel {
    /// A current constant in NED.
    Constant {
        /// V_c, m/s.
        speed_mps: f64,
        /// α_c, rad.
        vertical_angle_rad: f64,
        /// β_c, rad.
        direction_rad: f64,
    },
    /// Gauss–Markov speed and angles.
    GaussMarkov {
        /// V_c channel, m/s.
        speed: GaussMarkovChannel,
        /// Speed limits [V_min, V_max], m/s.
        speed_limits_mps: (f64, f64),
        /// α_c channel, rad.
        vertical_angle: GaussMarkovChannel,
        /// β_c channel, rad.
        direction: GaussMarkovChannel,
    },
}

impl CurrentModel {
    /// No current.
    pub fn none() -> Self {
        Self::Constant {
            speed_mps: 0.0,
            vertical_angle_rad: 0.0,
            direction_rad: 0.0,
        }
    }
}

/// v_c^n from speed and angles (eq. 33).
pub fn current_velocity_ned(
    speed_mps: f64,
    vertical_angle_rad: f64,
    direction_rad: f64,
) -> Vector3<f64> {
    let (sa, ca) = vertical_angle_rad.sin_cos();
    let (sb, cb) = direction_rad.sin_cos();
    Vector3::new(speed_mps * ca * cb, speed_mps * sb, speed_mps * sa * cb)
}

/// A running ocean current.
#[derive(Debug, Clone)]
pub struct OceanCurrent {
    model: CurrentModel,
    speed_mps: f64,
    vertical_angle_rad: f64,
    direction_rad: f64,
    rng: StdRng,
}

impl OceanCurrent {
    /// Starts the model; `seed` drives the Gauss–Markov noise.
    pub fn new(model: CurrentModel, seed: u64) -> Result<Self, DynamicsError> {
        let bad = |detail: String| DynamicsError::InvalidParameter {
            what: "ocean current".into(),
            detail,
        };
        let (speed, alpha, beta) = match model {
            CurrentModel::Constant {
                speed_mps,
                vertical_angle_rad,
                direction_rad,
            } => (speed_mps, vertical_angle_rad, direction_rad),
            CurrentModel::GaussMarkov {
                speed,
                speed_limits_mps: (lo, hi),
                vertical_angle,
                direction,
            } => {
                for (name, ch) in [
                    ("speed", speed),
                    ("vertical angle", vertical_angle),
                    ("direction", direction),
                ] {
                    let ok = [ch.initial, ch.mu_per_s, ch.mean, ch.sigma]
                        .iter()
                        .all(|x| x.is_finite())
                        && ch.mu_per_s >= 0.0
                        && ch.sigma >= 0.0;
                    if !ok {
                        return Err(bad(format!(
                            "{name} channel {ch:?} needs finite values, mu >= 0, sigma >= 0"
                        )));
                    }
                }
                if !(lo.is_finite() && hi.is_finite() && 0.0 <= lo && lo <= hi) {
                    return Err(bad(format!(
                        "speed limits ({lo}, {hi}) need 0 <= V_min <= V_max"
                    )));
                }
                (
                    speed.initial.clamp(lo, hi),
                    vertical_angle.initial,
                    direction.initial,
                )
            }
        };
        if !(speed.is_finite() && alpha.is_finite() && beta.is_finite()) {
            return Err(bad(format!(
                "speed {speed}, angles {alpha}, {beta} must be finite"
            )));
        }
        Ok(Self {
            model,
            speed_mps: speed,
            vertical_angle_rad: alpha,
            direction_rad: beta,
            rng: StdRng::seed_from_u64(seed),
        })
    }

    /// Current speed V_c, m/s.
    pub fn speed_mps(&self) -> f64 {
        self.speed_mps
    }

    /// α_c, rad.
    pub fn vertical_angle_rad(&self) -> f64 {
        self.vertical_angle_rad
    }

    /// β_c, rad.
    pub fn direction_rad(&self) -> f64 {
        self.direction_rad
    }

    /// v_c^n now.
    pub fn velocity_ned(&self) -> Vector3<f64> {
        current_velocity_ned(self.speed_mps, self.vertical_angle_rad, self.direction_rad)
    }

    /// Advances the process by `dt_s` (a no-op for a constant current).
    pub fn step(&mut self, dt_s: f64) {
        if let CurrentModel::GaussMarkov {
            speed,
            speed_limits_mps: (lo, hi),
            vertical_angle,
            direction,
        } = self.model
        {
            let sq = dt_s.max(0.0).sqrt();
            let advance = |x: f64, ch: &GaussMarkovChannel, rng: &mut StdRng| {
                let n: f64 = StandardNormal.sample(rng);
                x - dt_s * ch.mu_per_s * (x - ch.mean) + ch.sigma * sq * n
            };
            self.speed_mps = advance(self.speed_mps, &speed, &mut self.rng).clamp(lo, hi);
            self.vertical_angle_rad =
                advance(self.vertical_angle_rad, &vertical_angle, &mut self.rng);
            self.direction_rad = advance(self.direction_rad, &direction, &mut self.rng);
        }
    }
}

/// The current over one integration step: linear in time from `start` at `t0_s` with a
/// constant rate, so ν over ground stays continuous and ν̇_c carries Rᵀ v̇_c.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CurrentRamp {
    /// Start time, s.
    pub t0_s: f64,
    /// v_c^n at `t0_s`, m/s.
    pub start_ned_mps: Vector3<f64>,
    /// v̇_c^n over the step, m/s².
    pub rate_ned_mps2: Vector3<f64>,
}

impl CurrentRamp {
    /// A constant current.
    pub fn constant(sample: &CurrentSample) -> Self {
        Self {
            t0_s: 0.0,
            start_ned_mps: sample.vel_ned_mps,
            rate_ned_mps2: sample.accel_ned_mps2,
        }
    }

    /// From v_c at both ends of a step of length `dt_s` starting at `t0_s`.
    pub fn between(t0_s: f64, dt_s: f64, start: Vector3<f64>, end: Vector3<f64>) -> Self {
        let rate = if dt_s > 0.0 {
            (end - start) / dt_s
        } else {
            Vector3::zeros()
        };
        Self {
            t0_s,
            start_ned_mps: start,
            rate_ned_mps2: rate,
        }
    }

    /// The current at time `t_s`.
    #[inline]
    pub fn at(&self, t_s: f64) -> CurrentSample {
        CurrentSample {
            vel_ned_mps: self.start_ned_mps + self.rate_ned_mps2 * (t_s - self.t0_s),
            accel_ned_mps2: self.rate_ned_mps2,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eq33_direction_and_vertical_angle() {
        let v = current_velocity_ned(0.5, 0.0, std::f64::consts::FRAC_PI_2);
        assert!((v - Vector3::new(0.0, 0.5, 0.0)).norm() < 1e-15);
        let v = current_velocity_ned(1.0, 0.1, 0.0);
        assert!((v - Vector3::new(0.1_f64.cos(), 0.0, 0.1_f64.sin())).norm() < 1e-15);
    }

    #[test]
    fn gauss_markov_is_deterministic_and_clamped() {
        let model = CurrentModel::GaussMarkov {
            speed: GaussMarkovChannel {
                initial: 0.2,
                mu_per_s: 0.01,
                mean: 0.0,
                sigma: 0.2,
            },
            speed_limits_mps: (0.0, 0.3),
            vertical_angle: GaussMarkovChannel::fixed(0.0),
            direction: GaussMarkovChannel {
                initial: 1.0,
                mu_per_s: 0.0,
                mean: 0.0,
                sigma: 0.05,
            },
        };
        let run = |seed| {
            let mut c = OceanCurrent::new(model, seed).unwrap();
            let mut out = Vec::new();
            for _ in 0..2000 {
                c.step(0.01);
                assert!((0.0..=0.3).contains(&c.speed_mps()));
                out.push(c.velocity_ned());
            }
            out
        };
        assert_eq!(run(7), run(7));
        assert_ne!(run(7), run(8));
        let v = run(3);
        assert!(
            v.iter().any(|x| (x - v[0]).norm() > 1e-3),
            "the process moves"
        );
    }
}
