//! Fixed-step integrators.
//!
//! * [`rk4_step`]: classical 4-stage Runge–Kutta for any [`StateVector`] (the 12-state
//!   [η; ν] as `SVector<f64, 12>`, the 13-state quaternion path, or a model state with
//!   extra states such as [`crate::models::ModelState`]). The input is frozen over the step
//!   by the caller's closure.
//! * [`semi_implicit_euler_step`]: Fossen's main-loop scheme exactly as in the
//!   fossen_reference README: ν first, ν_{k+1} = ν_k + h ν̇(η_k, ν_k), then
//!   η_{k+1} = η_k + h J(η_k) ν_{k+1} (the **old** attitude matrices with the **new** ν).
//!
//! Nothing here allocates for fixed-size states.

use nalgebra::SVector;

use crate::kinematics::eta_dot;
use crate::math::Vector6;

/// A state that the integrators can advance.
pub trait StateVector: Clone {
    /// `self + h · d`.
    fn add_scaled(&self, d: &Self, h: f64) -> Self;

    /// `self + h/6 (k1 + 2 k2 + 2 k3 + k4)`.
    fn rk4_combine(&self, k1: &Self, k2: &Self, k3: &Self, k4: &Self, h: f64) -> Self {
        self.add_scaled(k1, h / 6.0)
            .add_scaled(k2, h / 3.0)
            .add_scaled(k3, h / 3.0)
            .add_scaled(k4, h / 6.0)
    }

    /// Whether every component is finite.
    fn all_finite(&self) -> bool;
}

impl<const N: usize> StateVector for SVector<f64, N> {
    #[inline]
    fn add_scaled(&self, d: &Self, h: f64) -> Self {
        self + d * h
    }

    #[inline]
    fn rk4_combine(&self, k1: &Self, k2: &Self, k3: &Self, k4: &Self, h: f64) -> Self {
        self + (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0)
    }

    #[inline]
    fn all_finite(&self) -> bool {
        self.iter().all(|x| x.is_finite())
    }
}

/// The 12-state [η; ν] as two 6-vectors, for models without extra states.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EtaNu {
    /// η = [x, y, z, φ, θ, ψ].
    pub eta: Vector6,
    /// ν = [u, v, w, p, q, r].
    pub nu: Vector6,
}

impl StateVector for EtaNu {
    #[inline]
    fn add_scaled(&self, d: &Self, h: f64) -> Self {
        Self {
            eta: self.eta + d.eta * h,
            nu: self.nu + d.nu * h,
        }
    }

    #[inline]
    fn rk4_combine(&self, k1: &Self, k2: &Self, k3: &Self, k4: &Self, h: f64) -> Self {
        let s = h / 6.0;
        Self {
            eta: self.eta + (k1.eta + k2.eta * 2.0 + k3.eta * 2.0 + k4.eta) * s,
            nu: self.nu + (k1.nu + k2.nu * 2.0 + k3.nu * 2.0 + k4.nu) * s,
        }
    }

    fn all_finite(&self) -> bool {
        self.eta.iter().chain(self.nu.iter()).all(|x| x.is_finite())
    }
}

/// One classical RK4 step of ẋ = f(t, x) from (t, x) with step h.
#[inline]
pub fn rk4_step<S, F>(mut f: F, t: f64, x: &S, h: f64) -> S
where
    S: StateVector,
    F: FnMut(f64, &S) -> S,
{
    let k1 = f(t, x);
    let k2 = f(t + 0.5 * h, &x.add_scaled(&k1, 0.5 * h));
    let k3 = f(t + 0.5 * h, &x.add_scaled(&k2, 0.5 * h));
    let k4 = f(t + h, &x.add_scaled(&k3, h));
    x.rk4_combine(&k1, &k2, &k3, &k4, h)
}

/// One explicit Euler step.
#[inline]
pub fn euler_step<S, F>(mut f: F, t: f64, x: &S, h: f64) -> S
where
    S: StateVector,
    F: FnMut(f64, &S) -> S,
{
    x.add_scaled(&f(t, x), h)
}

/// One step of Fossen's semi-implicit Euler on (η, ν) with ZYX Euler kinematics:
/// ν_{k+1} = ν_k + h ν̇(η_k, ν_k); η_{k+1} = η_k + h J(η_k) ν_{k+1}.
#[inline]
pub fn semi_implicit_euler_step<F>(
    nu_dot: F,
    eta: &Vector6,
    nu: &Vector6,
    h: f64,
) -> (Vector6, Vector6)
where
    F: FnOnce(&Vector6, &Vector6) -> Vector6,
{
    let nu_next = nu + nu_dot(eta, nu) * h;
    let eta_next = eta + eta_dot(eta, &nu_next) * h;
    (eta_next, nu_next)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector2;

    #[test]
    fn rk4_is_fourth_order_on_harmonic_oscillator() {
        let f = |_t: f64, x: &Vector2<f64>| Vector2::new(x[1], -x[0]);
        let err = |h: f64| {
            let n = (1.0 / h).round() as usize;
            let mut x = Vector2::new(1.0, 0.0);
            for k in 0..n {
                x = rk4_step(f, k as f64 * h, &x, h);
            }
            (x[0] - 1.0_f64.cos()).abs()
        };
        let ratio = err(0.1) / err(0.05);
        assert!((ratio - 16.0).abs() < 1.5, "ratio {ratio}");
    }

    #[test]
    fn semi_implicit_euler_uses_new_velocity() {
        let eta = Vector6::zeros();
        let nu = Vector6::zeros();
        let (eta1, nu1) = semi_implicit_euler_step(
            |_, _| Vector6::new(1.0, 0.0, 0.0, 0.0, 0.0, 0.0),
            &eta,
            &nu,
            0.1,
        );
        assert!((nu1[0] - 0.1).abs() < 1e-15);
        assert!((eta1[0] - 0.01).abs() < 1e-15, "position uses ν_(k+1)");
    }
}
