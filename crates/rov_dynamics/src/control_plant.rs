//! The control plant model (seed 001 eq. 28–32): the low-speed linear model a Kalman
//! observer uses.
//!
//! ```text
//! η̇ = J(η) ν
//! M ν̇ + D ν + G η = τ + Jᵀ(η) b
//! ḃ = −T_b⁻¹ b + w_b
//! ```
//!
//! M = M_RB + M_A (constant), D the linear damping only, G the linearised restoring matrix
//! ([`crate::process::Hydrostatics::linearized`], equal to Hᵀ G^CG H for CG and CB on the
//! z axis), b a bias in NED (it absorbs current, tether pull, net buoyancy and unmodelled
//! forces) with time constants T_b (∞ gives a random walk).
//!
//! Two decoupled three-state channels for the observer, with small angles (J ≈ I) and the
//! diagonal entries m = M[i][i], d = D[i][i]:
//!
//! * depth: x = (z, w, b_z), input τ_Z (N): ż = w, m ẇ = −d w + τ_Z + b_z, ḃ_z = −b_z/T_bz;
//! * heading: x = (ψ, r, b_ψ), input τ_N (N m): ψ̇ = r, m ṙ = −d r + τ_N + b_ψ, ḃ_ψ = −b_ψ/T_bψ.
//!
//! [`ChannelModel::discretize`] gives the exact zero-order-hold discretisation
//! (A_d = e^{A h}, B_d = ∫₀ʰ e^{A s} ds B, both from one matrix exponential of the
//! augmented matrix) and the process-noise covariance by Van Loan's method.

use nalgebra::{Matrix3, SMatrix, Vector3};

use crate::error::DynamicsError;
use crate::kinematics::{Attitude, eta_dot};
use crate::math::{Matrix6, Vector6, ang, expm, lin, stack};
use crate::process::ProcessModel;

/// Time derivatives of the control plant model (without the noise w_b).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlPlantDerivative {
    /// η̇.
    pub eta_dot: Vector6,
    /// ν̇.
    pub nu_dot: Vector6,
    /// ḃ (NED).
    pub bias_dot: Vector6,
}

/// The control plant model.
#[derive(Debug, Clone, PartialEq)]
pub struct ControlPlantModel {
    m: Matrix6,
    m_inv: Matrix6,
    d: Matrix6,
    g: Matrix6,
    bias_time_constants_s: Vector6,
}

impl ControlPlantModel {
    /// From M (symmetric positive definite), D, G and the bias time constants T_b (s, > 0;
    /// `f64::INFINITY` for a random-walk bias).
    pub fn new(
        m: Matrix6,
        d: Matrix6,
        g: Matrix6,
        bias_time_constants_s: Vector6,
    ) -> Result<Self, DynamicsError> {
        let bad = |detail: String| DynamicsError::InvalidParameter {
            what: "control plant model".into(),
            detail,
        };
        if !(m
            .iter()
            .chain(d.iter())
            .chain(g.iter())
            .all(|x| x.is_finite()))
        {
            return Err(bad("M, D and G must be finite".into()));
        }
        if !bias_time_constants_s
            .iter()
            .all(|t| *t > 0.0 && !t.is_nan())
        {
            return Err(bad(format!(
                "bias time constants {bias_time_constants_s:?} must be > 0"
            )));
        }
        let m_inv = nalgebra::Cholesky::new(m)
            .ok_or_else(|| bad("M is not symmetric positive definite".into()))?
            .inverse();
        Ok(Self {
            m,
            m_inv,
            d,
            g,
            bias_time_constants_s,
        })
    }

    /// From a process plant model: its M, the linear part of its damping and the
    /// linearisation of its restoring forces.
    pub fn from_process(
        process: &ProcessModel,
        bias_time_constants_s: Vector6,
    ) -> Result<Self, DynamicsError> {
        let p = process.params();
        Self::new(
            *process.mass_matrix(),
            p.damping.linear,
            p.hydrostatics.linearized(),
            bias_time_constants_s,
        )
    }

    /// M.
    pub fn mass_matrix(&self) -> &Matrix6 {
        &self.m
    }

    /// D (linear).
    pub fn damping(&self) -> &Matrix6 {
        &self.d
    }

    /// G.
    pub fn restoring(&self) -> &Matrix6 {
        &self.g
    }

    /// Bias time constants T_b, s.
    pub fn bias_time_constants_s(&self) -> &Vector6 {
        &self.bias_time_constants_s
    }

    /// η̇, ν̇ and ḃ for the state (η, ν, b) and input τ (w_b = 0; add noise outside).
    pub fn derivatives(
        &self,
        eta: &Vector6,
        nu: &Vector6,
        bias_ned: &Vector6,
        tau: &Vector6,
    ) -> ControlPlantDerivative {
        let att = Attitude::from_eta(eta);
        let jt_b = stack(
            &(att.ned_from_body().transpose() * lin(bias_ned)),
            &(att.euler_rates_from_body_rates().transpose() * ang(bias_ned)),
        );
        let nu_dot = self.m_inv * (tau + jt_b - self.d * nu - self.g * eta);
        let bias_dot = Vector6::from_fn(|i, _| -bias_ned[i] / self.bias_time_constants_s[i]);
        ControlPlantDerivative {
            eta_dot: eta_dot(eta, nu),
            nu_dot,
            bias_dot,
        }
    }

    fn channel(&self, i: usize, name: &'static str) -> ChannelModel {
        let m = self.m[(i, i)];
        let d = self.d[(i, i)];
        let t_b = self.bias_time_constants_s[i];
        ChannelModel {
            name,
            a: Matrix3::new(0.0, 1.0, 0.0, 0.0, -d / m, 1.0 / m, 0.0, 0.0, -1.0 / t_b),
            b: Vector3::new(0.0, 1.0 / m, 0.0),
        }
    }

    /// Depth channel (z, w, b_z); input τ_Z in N.
    pub fn depth_channel(&self) -> ChannelModel {
        self.channel(2, "depth")
    }

    /// Heading channel (ψ, r, b_ψ); input τ_N in N m.
    pub fn heading_channel(&self) -> ChannelModel {
        self.channel(5, "heading")
    }
}

/// A continuous three-state channel ẋ = A x + B u.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChannelModel {
    /// "depth" or "heading".
    pub name: &'static str,
    /// A (continuous).
    pub a: Matrix3<f64>,
    /// B (continuous).
    pub b: Vector3<f64>,
}

/// A discretised channel: x_{k+1} = A x_k + B u_k + w_k, w_k ~ N(0, Q).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiscreteChannel {
    /// Step, s.
    pub dt_s: f64,
    /// A_d.
    pub a: Matrix3<f64>,
    /// B_d.
    pub b: Vector3<f64>,
    /// Q_d.
    pub q: Matrix3<f64>,
}

impl ChannelModel {
    /// Zero-order-hold discretisation for step `dt_s`; `noise_psd` is the diagonal
    /// continuous white-noise intensity on each state (units²/s), e.g. (0, σ_w², σ_b²).
    pub fn discretize(
        &self,
        dt_s: f64,
        noise_psd: &Vector3<f64>,
    ) -> Result<DiscreteChannel, DynamicsError> {
        if !(dt_s.is_finite() && dt_s > 0.0 && noise_psd.iter().all(|q| q.is_finite() && *q >= 0.0))
        {
            return Err(DynamicsError::InvalidInput {
                detail: format!(
                    "discretisation needs dt > 0 (got {dt_s}) and noise PSD >= 0 (got {noise_psd:?})"
                ),
            });
        }
        let mut aug = SMatrix::<f64, 4, 4>::zeros();
        aug.fixed_view_mut::<3, 3>(0, 0).copy_from(&(self.a * dt_s));
        aug.fixed_view_mut::<3, 1>(0, 3).copy_from(&(self.b * dt_s));
        let e = expm(&aug);
        let a_d: Matrix3<f64> = e.fixed_view::<3, 3>(0, 0).into_owned();
        let b_d: Vector3<f64> = e.fixed_view::<3, 1>(0, 3).into_owned();
        // Van Loan.
        let mut vl = SMatrix::<f64, 6, 6>::zeros();
        vl.fixed_view_mut::<3, 3>(0, 0).copy_from(&(-self.a * dt_s));
        vl.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&(Matrix3::from_diagonal(noise_psd) * dt_s));
        vl.fixed_view_mut::<3, 3>(3, 3)
            .copy_from(&(self.a.transpose() * dt_s));
        let ev = expm(&vl);
        let phi_t: Matrix3<f64> = ev.fixed_view::<3, 3>(3, 3).into_owned();
        let q = phi_t.transpose() * ev.fixed_view::<3, 3>(0, 3).into_owned();
        let q = (q + q.transpose()) * 0.5;
        Ok(DiscreteChannel {
            dt_s,
            a: a_d,
            b: b_d,
            q,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrators::rk4_step;

    fn plant() -> ControlPlantModel {
        let m = Matrix6::from_diagonal(&Vector6::new(8.6, 9.1, 11.1, 0.1, 0.15, 0.149));
        let d = Matrix6::from_diagonal(&Vector6::new(1.0, 4.0, 4.8, 0.05, 0.08, 0.04));
        let mut g = Matrix6::zeros();
        g[(3, 3)] = 0.3345;
        g[(4, 4)] = 0.3345;
        ControlPlantModel::new(m, d, g, Vector6::repeat(300.0)).unwrap()
    }

    #[test]
    fn zoh_discretisation_matches_continuous_simulation() {
        let ch = plant().depth_channel();
        let dt = 0.1;
        let disc = ch.discretize(dt, &Vector3::zeros()).unwrap();
        let x0 = Vector3::new(1.0, 0.2, 0.5);
        let u = 3.0;
        let mut x = x0;
        let h = dt / 200.0;
        for k in 0..200 {
            x = rk4_step(
                |_, s: &Vector3<f64>| ch.a * s + ch.b * u,
                k as f64 * h,
                &x,
                h,
            );
        }
        let xd = disc.a * x0 + disc.b * u;
        assert!((x - xd).norm() < 1e-12, "{x} vs {xd}");
        assert!(disc.q.norm() == 0.0);
    }

    #[test]
    fn van_loan_q_is_symmetric_psd_and_first_order_correct() {
        let ch = plant().heading_channel();
        let psd = Vector3::new(0.0, 1e-3, 1e-5);
        let dt = 1e-3;
        let disc = ch.discretize(dt, &psd).unwrap();
        assert!((disc.q - disc.q.transpose()).norm() == 0.0);
        let eig = disc.q.symmetric_eigenvalues();
        assert!(eig.iter().all(|e| *e >= -1e-18));
        // For small dt, Q ≈ Q_c dt.
        assert!((disc.q[(1, 1)] - psd[1] * dt).abs() < 1e-3 * psd[1] * dt);
    }

    #[test]
    fn derivatives_follow_the_linear_equations() {
        let p = plant();
        let eta = Vector6::new(0.0, 0.0, 1.0, 0.1, -0.05, 0.0);
        let nu = Vector6::new(0.1, 0.0, 0.2, 0.0, 0.0, 0.1);
        let b = Vector6::new(0.0, 0.0, 0.5, 0.0, 0.0, 0.0);
        let tau = Vector6::new(1.0, 0.0, 2.0, 0.0, 0.0, 0.05);
        let d = p.derivatives(&eta, &nu, &b, &tau);
        let att = Attitude::from_eta(&eta);
        let jt_b = att.ned_from_body().transpose() * lin(&b);
        let expected_w = (tau[2] + jt_b.z - 4.8 * 0.2) / 11.1;
        assert!((d.nu_dot[2] - expected_w).abs() < 1e-14);
        assert!((d.nu_dot[3] - (-0.3345 * 0.1) / 0.1).abs() < 1e-12);
        assert!((d.bias_dot[2] + 0.5 / 300.0).abs() < 1e-15);
        let rw = ControlPlantModel::new(
            *p.mass_matrix(),
            *p.damping(),
            *p.restoring(),
            Vector6::repeat(f64::INFINITY),
        )
        .unwrap();
        assert_eq!(
            rw.derivatives(&eta, &nu, &b, &tau).bias_dot,
            Vector6::zeros()
        );
        assert_eq!(rw.depth_channel().a[(2, 2)], 0.0);
    }
}
