//! The process plant model (seed 001 eq. 4–26): Fossen's 6-DOF equations of motion about
//! the body origin CO, with rigid-body and added mass, Coriolis–centripetal terms, linear
//! plus quadratic damping, restoring forces and an ocean current through the relative
//! velocity.
//!
//! Solved for the acceleration over ground, exactly as the Fossen reference README states:
//!
//! ```text
//! ν̇ = ν̇_c + M⁻¹ (τ + τ_ext − C_RB(ν_r) ν_r − C_A(ν_r) ν_r − D(ν_r) ν_r − g(η))
//! ν_r = ν − ν_c,  ν_c = [Rᵀ v_c^n ; 0],  ν̇_c = [−S(ν₂) Rᵀ v_c^n + Rᵀ v̇_c^n ; 0]
//! ```
//!
//! The Rᵀ v̇_c^n term is zero for a current that is constant in NED and carries the
//! change of a slowly varying (Gauss–Markov) current.
//!
//! Conventions: body origin CO = centre of buoyancy for the VideoRay models; the CG is
//! `cg_from_co_m` (5.59 mm below CO for the Pro 4). Mass, damping and added-mass
//! matrices are given with **positive** entries (M_A = −[X_u̇ …], D = −[X_u …]).
//! W and B are forces in newtons.

use nalgebra::{Matrix3, Vector3};

use crate::error::DynamicsError;
use crate::kinematics::{Attitude, QuatState, quat_state_dot, quat_state_rotation};
use crate::math::{
    Matrix6, Vector6, ang, coriolis_times_nu, h_matrix, lin, m2c, skew, stack, symmetrise,
};

/// The rigid body: mass, inertia about the CG and the CG position from CO.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidBody {
    /// Mass m, kg.
    pub mass_kg: f64,
    /// Inertia tensor I_g about the CG in body axes, kg m² (seed 001 eq. 9).
    pub inertia_cg_kgm2: Matrix3<f64>,
    /// r_g: CG from CO in body axes, m.
    pub cg_from_co_m: Vector3<f64>,
}

impl RigidBody {
    /// The inertia tensor of seed 001 eq. 9 from the moments I_x, I_y, I_z and the
    /// products of inertia I_xy, I_xz, I_yz (off-diagonal entries are −I_xy etc.).
    pub fn inertia_tensor(ix: f64, iy: f64, iz: f64, ixy: f64, ixz: f64, iyz: f64) -> Matrix3<f64> {
        Matrix3::new(ix, -ixy, -ixz, -ixy, iy, -iyz, -ixz, -iyz, iz)
    }

    /// M_RB^CG = diag(m I₃, I_g) (seed 001 eq. 8).
    pub fn mass_matrix_cg(&self) -> Matrix6 {
        let mut m = Matrix6::zeros();
        m.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(Matrix3::identity() * self.mass_kg));
        m.fixed_view_mut::<3, 3>(3, 3)
            .copy_from(&self.inertia_cg_kgm2);
        m
    }

    /// M_RB = Hᵀ(r_g) M_RB^CG H(r_g) about CO (seed 001 eq. 12).
    pub fn mass_matrix_co(&self) -> Matrix6 {
        let h = h_matrix(&self.cg_from_co_m);
        h.transpose() * self.mass_matrix_cg() * h
    }

    /// C_RB^CG(ω) = [[m S(ω), 0], [0, −S(I_g ω)]] (seed 001 eq. 10).
    pub fn coriolis_cg(&self, omega_body: &Vector3<f64>) -> Matrix6 {
        let mut c = Matrix6::zeros();
        c.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(skew(omega_body) * self.mass_kg));
        c.fixed_view_mut::<3, 3>(3, 3)
            .copy_from(&(-skew(&(self.inertia_cg_kgm2 * omega_body))));
        c
    }

    /// C_RB = Hᵀ(r_g) C_RB^CG H(r_g) about CO (seed 001 eq. 13). Its product with ν equals
    /// that of the Kirchhoff form `m2c(M_RB, ν)` used on the hot path.
    pub fn coriolis_co(&self, nu: &Vector6) -> Matrix6 {
        let h = h_matrix(&self.cg_from_co_m);
        h.transpose() * self.coriolis_cg(&ang(nu)) * h
    }
}

/// How the pitch/yaw Munk moments of C_A are treated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum MunkMoment {
    /// Keep every C_A entry (Fossen reference data; can make a bluff ROV statically
    /// unstable in pitch above ≈ 0.3 m/s, see parameters.md §4).
    Full,
    /// Zero C_A[4][0], C_A[4][3], C_A[5][0], C_A[5][1] (0-based row, column), exactly the
    /// entries Fossen's `remus100.py` zeroes ("Munk moments in pitch and yaw").
    #[default]
    Zeroed,
}

/// Form of the linear damping term.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum DampingForm {
    /// D(ν_r) = D_l + D_q diag(|ν_r|) (seed 001 eq. 20, 22, 23).
    #[default]
    LinearQuadratic,
    /// D(ν_r) = D_l e^(−α ‖ν_r‖) + D_q diag(|ν_r|) (seed 001 eq. 21). ‖ν_r‖ is the
    /// translational relative speed √(u_r² + v_r² + w_r²) (as in Fossen's REMUS code;
    /// the 6-vector norm would mix units).
    Exponential {
        /// α, s/m.
        alpha_s_per_m: f64,
    },
}

/// Damping D(ν_r) with positive coefficients.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Damping {
    /// D_l (N s/m, N m s), a full matrix (usually diagonal).
    pub linear: Matrix6,
    /// Diagonal of D_q (N s²/m², N m s²).
    pub quadratic: Vector6,
    /// Linear-term form.
    pub form: DampingForm,
}

impl Damping {
    /// Diagonal linear and quadratic damping.
    pub fn diagonal(linear: Vector6, quadratic: Vector6) -> Self {
        Self {
            linear: Matrix6::from_diagonal(&linear),
            quadratic,
            form: DampingForm::LinearQuadratic,
        }
    }

    #[inline]
    fn linear_scale(&self, nu_r: &Vector6) -> f64 {
        match self.form {
            DampingForm::LinearQuadratic => 1.0,
            DampingForm::Exponential { alpha_s_per_m } => {
                let speed = (nu_r[0] * nu_r[0] + nu_r[1] * nu_r[1] + nu_r[2] * nu_r[2]).sqrt();
                (-alpha_s_per_m * speed).exp()
            }
        }
    }

    /// D(ν_r).
    pub fn matrix(&self, nu_r: &Vector6) -> Matrix6 {
        let mut d = self.linear * self.linear_scale(nu_r);
        for i in 0..6 {
            d[(i, i)] += self.quadratic[i] * nu_r[i].abs();
        }
        d
    }

    /// D(ν_r) ν_r without forming the matrix.
    #[inline]
    pub fn force(&self, nu_r: &Vector6) -> Vector6 {
        let mut f = self.linear * nu_r * self.linear_scale(nu_r);
        for i in 0..6 {
            f[i] += self.quadratic[i] * nu_r[i].abs() * nu_r[i];
        }
        f
    }
}

/// Hydrostatics: weight, buoyancy and where they act.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hydrostatics {
    /// W = m g, N.
    pub weight_n: f64,
    /// B = ρ g ∇, N.
    pub buoyancy_n: f64,
    /// r_g: CG from CO, m.
    pub cg_from_co_m: Vector3<f64>,
    /// r_b: CB from CO, m.
    pub cb_from_co_m: Vector3<f64>,
}

impl Hydrostatics {
    /// g(η) from the NED down axis in body coordinates k = Rᵀ e_z (see
    /// [`Attitude::down_in_body`]): g = −[(W − B) k ; (W r_g − B r_b) × k]. Written out
    /// this is Fossen's `gvect` (fossen_reference README), valid for any attitude.
    #[inline]
    pub fn restoring_from_down(&self, down_body: &Vector3<f64>) -> Vector6 {
        let f = down_body * (self.weight_n - self.buoyancy_n);
        let s = self.cg_from_co_m * self.weight_n - self.cb_from_co_m * self.buoyancy_n;
        let m = s.cross(down_body);
        -stack(&f, &m)
    }

    /// g(η) for ZYX Euler angles.
    pub fn restoring(&self, eta: &Vector6) -> Vector6 {
        self.restoring_from_down(&Attitude::from_eta(eta).down_in_body())
    }

    /// The linearisation G = ∂g/∂η at η = 0 (the control plant model's G, seed 001
    /// eq. 31–32), for general r_g, r_b, W and B. For r_g, r_b on the z axis and W = B it
    /// is diag(0, 0, 0, W·BG, W·BG, 0) with BG = z_g − z_b, i.e. Hᵀ G^CG H.
    pub fn linearized(&self) -> Matrix6 {
        let wb = self.weight_n - self.buoyancy_n;
        let s = self.cg_from_co_m * self.weight_n - self.cb_from_co_m * self.buoyancy_n;
        let mut g = Matrix6::zeros();
        g[(0, 4)] = wb;
        g[(1, 3)] = -wb;
        g[(3, 3)] = s.z;
        g[(4, 4)] = s.z;
        g[(5, 3)] = -s.x;
        g[(5, 4)] = -s.y;
        g
    }
}

/// The ocean current at one instant, in NED.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CurrentSample {
    /// v_c^n, m/s.
    pub vel_ned_mps: Vector3<f64>,
    /// v̇_c^n, m/s² (zero for a constant current).
    pub accel_ned_mps2: Vector3<f64>,
}

impl CurrentSample {
    /// A constant horizontal current of speed `speed_mps` flowing towards `beta_rad`
    /// (from north, clockwise): v_c^n = V_c (cos β, sin β, 0).
    pub fn constant(speed_mps: f64, beta_rad: f64) -> Self {
        Self {
            vel_ned_mps: Vector3::new(speed_mps * beta_rad.cos(), speed_mps * beta_rad.sin(), 0.0),
            accel_ned_mps2: Vector3::zeros(),
        }
    }

    /// No current.
    pub fn none() -> Self {
        Self::default()
    }
}

/// All parameters of the process plant model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProcessParams {
    /// Rigid body (mass, inertia, CG).
    pub rigid_body: RigidBody,
    /// M_A, positive semi-definite, full 6×6 (symmetrised on use; seed 001 eq. 14).
    pub added_mass: Matrix6,
    /// Damping.
    pub damping: Damping,
    /// Weight, buoyancy, CG and CB.
    pub hydrostatics: Hydrostatics,
    /// Munk-moment treatment in C_A.
    pub munk: MunkMoment,
}

/// The process plant model with M, its inverse and the symmetrised matrices precomputed.
#[derive(Debug, Clone, PartialEq)]
pub struct ProcessModel {
    params: ProcessParams,
    m_rb: Matrix6,
    m_a_sym: Matrix6,
    m_sym: Matrix6,
    m_inv: Matrix6,
    /// Diagonal of D_l when D_l is diagonal (fast path).
    linear_damping_diag: Option<Vector6>,
    /// Diagonal of M_A when M_A is diagonal (fast path of the Munk correction).
    added_mass_diag: Option<Vector6>,
    /// W − B, N.
    net_weight_n: f64,
    /// W r_g − B r_b, N m (the restoring moment is this × the down axis).
    restoring_arm_nm: Vector3<f64>,
}

/// `m · v` for a 6×6 matrix, summed column by column in the order nalgebra's product uses.
#[inline]
fn mat6_mul(m: &Matrix6, v: &[f64; 6]) -> [f64; 6] {
    let c = &m.data.0;
    let mut out = [0.0; 6];
    for (i, o) in out.iter_mut().enumerate() {
        *o = c[0][i] * v[0]
            + c[1][i] * v[1]
            + c[2][i] * v[2]
            + c[3][i] * v[3]
            + c[4][i] * v[4]
            + c[5][i] * v[5];
    }
    out
}

fn diagonal_of(m: &Matrix6) -> Option<Vector6> {
    let off_diagonal_zero = (0..6).all(|i| (0..6).all(|j| i == j || m[(i, j)] == 0.0));
    off_diagonal_zero.then(|| m.diagonal())
}

impl ProcessModel {
    /// Precomputes M_RB, M = M_RB + M_A and M⁻¹. Fails if a parameter is non-finite or M
    /// is not symmetric positive definite.
    pub fn new(params: ProcessParams) -> Result<Self, DynamicsError> {
        let m_rb = params.rigid_body.mass_matrix_co();
        let m_a_sym = symmetrise(&params.added_mass);
        let m_sym = symmetrise(&(m_rb + m_a_sym));
        let finite = m_sym.iter().all(|x| x.is_finite())
            && params.damping.linear.iter().all(|x| x.is_finite())
            && params.damping.quadratic.iter().all(|x| x.is_finite())
            && params.hydrostatics.weight_n.is_finite()
            && params.hydrostatics.buoyancy_n.is_finite()
            && params
                .hydrostatics
                .cg_from_co_m
                .iter()
                .all(|x| x.is_finite())
            && params
                .hydrostatics
                .cb_from_co_m
                .iter()
                .all(|x| x.is_finite());
        if !finite {
            return Err(DynamicsError::InvalidParameter {
                what: "process plant model".into(),
                detail: "a mass, damping or hydrostatic parameter is not finite".into(),
            });
        }
        let chol =
            nalgebra::Cholesky::new(m_sym).ok_or_else(|| DynamicsError::InvalidParameter {
                what: "mass matrix M = M_RB + M_A".into(),
                detail: format!("not positive definite: {m_sym}"),
            })?;
        let m_inv = chol.inverse();
        let h = &params.hydrostatics;
        Ok(Self {
            net_weight_n: h.weight_n - h.buoyancy_n,
            restoring_arm_nm: h.cg_from_co_m * h.weight_n - h.cb_from_co_m * h.buoyancy_n,
            linear_damping_diag: diagonal_of(&params.damping.linear),
            added_mass_diag: diagonal_of(&m_a_sym),
            params,
            m_rb,
            m_a_sym,
            m_sym,
            m_inv,
        })
    }

    /// The parameters.
    pub fn params(&self) -> &ProcessParams {
        &self.params
    }

    /// M_RB about CO.
    pub fn m_rb(&self) -> &Matrix6 {
        &self.m_rb
    }

    /// M_A (symmetrised).
    pub fn m_a(&self) -> &Matrix6 {
        &self.m_a_sym
    }

    /// M = M_RB + M_A (symmetrised).
    pub fn mass_matrix(&self) -> &Matrix6 {
        &self.m_sym
    }

    /// M⁻¹.
    pub fn mass_matrix_inv(&self) -> &Matrix6 {
        &self.m_inv
    }

    /// C_RB(ν) in Kirchhoff form (m2c of M_RB).
    pub fn coriolis_rb(&self, nu: &Vector6) -> Matrix6 {
        m2c(&self.m_rb, nu)
    }

    /// C_A(ν_r) in Kirchhoff form (seed 001 eq. 18), with the Munk option applied.
    pub fn coriolis_a(&self, nu_r: &Vector6) -> Matrix6 {
        let mut c = m2c(&self.m_a_sym, nu_r);
        if self.params.munk == MunkMoment::Zeroed {
            c[(4, 0)] = 0.0;
            c[(4, 3)] = 0.0;
            c[(5, 0)] = 0.0;
            c[(5, 1)] = 0.0;
        }
        c
    }

    /// C_RB(ν_r) ν_r + C_A(ν_r) ν_r in vector form (allocation-free).
    #[inline]
    pub fn coriolis_force(&self, nu_r: &Vector6) -> Vector6 {
        let mut f = coriolis_times_nu(&self.m_sym, nu_r);
        if self.params.munk == MunkMoment::Zeroed {
            // Remove the contribution of the zeroed C_A entries: C_A[4][0] = −a3,
            // C_A[4][3] = −b3, C_A[5][0] = a2, C_A[5][1] = −a1 with a = A11 ν1 + A12 ν2,
            // b = A21 ν1 + A22 ν2 of M_A.
            let p = match &self.added_mass_diag {
                Some(d) => d.component_mul(nu_r),
                None => self.m_a_sym * nu_r,
            };
            f[4] -= -p[2] * nu_r[0] - p[5] * nu_r[3];
            f[5] -= p[1] * nu_r[0] - p[0] * nu_r[1];
        }
        f
    }

    /// D(ν_r) ν_r.
    #[inline]
    pub fn damping_force(&self, nu_r: &Vector6) -> Vector6 {
        let d = &self.params.damping;
        match (&self.linear_damping_diag, d.form) {
            (Some(l), DampingForm::LinearQuadratic) => {
                Vector6::from_fn(|i, _| (l[i] + d.quadratic[i] * nu_r[i].abs()) * nu_r[i])
            }
            _ => d.force(nu_r),
        }
    }

    /// g(η).
    pub fn restoring(&self, eta: &Vector6) -> Vector6 {
        self.params.hydrostatics.restoring(eta)
    }

    /// ν̇ given the rotation R = R_{n←b} and the down axis k = Rᵀ e_z. Works for Euler or
    /// quaternion attitudes. `tau` already includes τ_ext.
    ///
    /// This is the hot path of every simulation, written out in scalars: the same terms
    /// as [`ProcessModel::coriolis_force`], [`ProcessModel::damping_force`] and
    /// [`Hydrostatics::restoring_from_down`] (the tests compare them), without the
    /// temporaries of the vector form.
    #[inline]
    pub fn nu_dot_with_rotation(
        &self,
        ned_from_body: &Matrix3<f64>,
        down_body: &Vector3<f64>,
        nu: &Vector6,
        tau: &Vector6,
        current: &CurrentSample,
    ) -> Vector6 {
        // Column j of R is rm[j]; row i of Rᵀ is column i of R.
        let rm = &ned_from_body.data.0;
        let [u, v, w, p, q, r] = nu.data.0[0];
        let vn = &current.vel_ned_mps;
        let an = &current.accel_ned_mps2;
        let dot_col = |j: usize, x: &Vector3<f64>| rm[j][0] * x.x + rm[j][1] * x.y + rm[j][2] * x.z;
        // ν_c = [Rᵀ v_c^n ; 0] and its derivative −S(ω) Rᵀ v_c^n (+ Rᵀ v̇_c^n). In still
        // water both are zeros, known before the attitude's trigonometry is: the kinetics
        // below then need not wait for it (the same numbers, up to the sign of a zero).
        let still = *vn == Vector3::zeros() && *an == Vector3::zeros();
        let (vc, vc_dot) = if still {
            ([0.0; 3], [0.0; 3])
        } else {
            let vc = [dot_col(0, vn), dot_col(1, vn), dot_col(2, vn)];
            let mut vc_dot = [
                vc[1] * r - vc[2] * q,
                vc[2] * p - vc[0] * r,
                vc[0] * q - vc[1] * p,
            ];
            if an.x != 0.0 || an.y != 0.0 || an.z != 0.0 {
                for (i, d) in vc_dot.iter_mut().enumerate() {
                    *d += dot_col(i, an);
                }
            }
            (vc, vc_dot)
        };
        let nu_r = [u - vc[0], v - vc[1], w - vc[2], p, q, r];

        // Kirchhoff Coriolis C(ν_r)ν_r = [ω × a ; ν₁ × a + ω × b], (a, b) = M ν_r.
        let [a0, a1, a2, b0, b1, b2] = mat6_mul(&self.m_sym, &nu_r);
        let [ur, vr, wr, ..] = nu_r;
        let mut cor = [
            q * a2 - r * a1,
            r * a0 - p * a2,
            p * a1 - q * a0,
            (vr * a2 - wr * a1) + (q * b2 - r * b1),
            (wr * a0 - ur * a2) + (r * b0 - p * b2),
            (ur * a1 - vr * a0) + (p * b1 - q * b0),
        ];
        if self.params.munk == MunkMoment::Zeroed {
            // Remove the zeroed C_A entries' contribution: C_A[4][0] = −a3,
            // C_A[4][3] = −b3, C_A[5][0] = a2, C_A[5][1] = −a1 with (a, b) = M_A ν_r.
            let pa = match &self.added_mass_diag {
                Some(d) => [
                    d[0] * ur,
                    d[1] * vr,
                    d[2] * wr,
                    d[3] * p,
                    d[4] * q,
                    d[5] * r,
                ],
                None => mat6_mul(&self.m_a_sym, &nu_r),
            };
            cor[4] -= -pa[2] * ur - pa[5] * p;
            cor[5] -= pa[1] * ur - pa[0] * vr;
        }

        let damp = self.damping_force(&Vector6::from(nu_r));

        // g(η) = −[(W − B) k ; (W r_g − B r_b) × k].
        let k = down_body;
        let wb = self.net_weight_n;
        let sa = &self.restoring_arm_nm;
        let g = [
            -(k.x * wb),
            -(k.y * wb),
            -(k.z * wb),
            -(sa.y * k.z - sa.z * k.y),
            -(sa.z * k.x - sa.x * k.z),
            -(sa.x * k.y - sa.y * k.x),
        ];

        let mut rhs = [0.0; 6];
        for (i, x) in rhs.iter_mut().enumerate() {
            *x = tau[i] - cor[i] - damp[i] - g[i];
        }
        let acc = mat6_mul(&self.m_inv, &rhs);
        Vector6::new(
            vc_dot[0] + acc[0],
            vc_dot[1] + acc[1],
            vc_dot[2] + acc[2],
            acc[3],
            acc[4],
            acc[5],
        )
    }

    /// ν̇ for ZYX Euler angles η.
    pub fn nu_dot(
        &self,
        eta: &Vector6,
        nu: &Vector6,
        tau: &Vector6,
        current: &CurrentSample,
    ) -> Vector6 {
        let att = Attitude::from_eta(eta);
        self.nu_dot_with_rotation(&att.ned_from_body(), &att.down_in_body(), nu, tau, current)
    }

    /// (η̇, ν̇) with the trigonometry computed once: the hot path of the 12-state model.
    #[inline]
    pub fn state_derivative(
        &self,
        eta: &Vector6,
        nu: &Vector6,
        tau: &Vector6,
        current: &CurrentSample,
    ) -> (Vector6, Vector6) {
        let att = Attitude::from_eta(eta);
        let r = att.ned_from_body();
        let p_dot = r * lin(nu);
        let angles_dot = att.euler_rates_from_body_rates() * ang(nu);
        let eta_dot = stack(&p_dot, &angles_dot);
        let down = Vector3::new(r[(2, 0)], r[(2, 1)], r[(2, 2)]);
        let nu_dot = self.nu_dot_with_rotation(&r, &down, nu, tau, current);
        (eta_dot, nu_dot)
    }

    /// Derivative of the quaternion 13-state [p_ned; q; ν] (see [`crate::kinematics`]):
    /// the same kinetics with the attitude taken from the quaternion, valid at any pitch.
    pub fn quat_state_derivative(
        &self,
        x: &QuatState,
        tau: &Vector6,
        current: &CurrentSample,
    ) -> QuatState {
        let r = quat_state_rotation(x);
        let down = Vector3::new(r[(2, 0)], r[(2, 1)], r[(2, 2)]);
        let nu: Vector6 = x.fixed_rows::<6>(7).into_owned();
        let nu_dot = self.nu_dot_with_rotation(&r, &down, &nu, tau, current);
        quat_state_dot(x, &nu_dot)
    }

    /// Mechanical energy 0.5 νᵀMν − W z_CG + B z_CB (z down), conserved when D = 0, τ = 0
    /// and there is no current.
    pub fn energy(&self, eta: &Vector6, nu: &Vector6) -> f64 {
        let att = Attitude::from_eta(eta);
        let r = att.ned_from_body();
        let h = &self.params.hydrostatics;
        let z_cg = eta[2] + (r * h.cg_from_co_m).z;
        let z_cb = eta[2] + (r * h.cb_from_co_m).z;
        0.5 * nu.dot(&(self.m_sym * nu)) - h.weight_n * z_cg + h.buoyancy_n * z_cb
    }

    /// ν_c = [Rᵀ v_c^n ; 0] for an Euler attitude.
    pub fn current_in_body(eta: &Vector6, current: &CurrentSample) -> Vector6 {
        let r = Attitude::from_eta(eta).ned_from_body();
        stack(&(r.transpose() * current.vel_ned_mps), &Vector3::zeros())
    }
}

/// Relative velocity ν_r = ν − ν_c (seed 001 eq. 5–7).
pub fn relative_velocity(eta: &Vector6, nu: &Vector6, current: &CurrentSample) -> Vector6 {
    nu - ProcessModel::current_in_body(eta, current)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reference_params(munk: MunkMoment) -> ProcessParams {
        let rb = RigidBody {
            mass_kg: 6.1,
            inertia_cg_kgm2: RigidBody::inertia_tensor(0.068, 0.097, 0.114, 0.0, 0.0, 0.0),
            cg_from_co_m: Vector3::new(0.0, 0.0, 0.00559),
        };
        ProcessParams {
            rigid_body: rb,
            added_mass: Matrix6::from_diagonal(&Vector6::new(2.5, 3.0, 2.7, 0.02, 0.03, 0.03)),
            damping: Damping::diagonal(
                Vector6::new(1.0, 4.0, 5.0, 0.05, 0.08, 0.2),
                Vector6::new(4.5, 25.0, 20.0, 0.1, 0.2, 0.35),
            ),
            hydrostatics: Hydrostatics {
                weight_n: 59.841,
                buoyancy_n: 60.341,
                cg_from_co_m: rb.cg_from_co_m,
                cb_from_co_m: Vector3::zeros(),
            },
            munk,
        }
    }

    #[test]
    fn m_rb_matches_fossen_reference_mrb_co() {
        let pm = ProcessModel::new(reference_params(MunkMoment::Full)).unwrap();
        let expected = [
            [6.1, 0.0, 0.0, 0.0, 0.034099, 0.0],
            [0.0, 6.1, 0.0, -0.034099, 0.0, 0.0],
            [0.0, 0.0, 6.1, 0.0, 0.0, 0.0],
            [0.0, -0.034099, 0.0, 0.06819061341, 0.0, 0.0],
            [0.034099, 0.0, 0.0, 0.0, 0.09719061341, 0.0],
            [0.0, 0.0, 0.0, 0.0, 0.0, 0.114],
        ];
        for (i, row) in expected.iter().enumerate() {
            for (j, x) in row.iter().enumerate() {
                assert!((pm.m_rb()[(i, j)] - x).abs() < 1e-15, "M_RB[{i}][{j}]");
            }
        }
        assert!((pm.mass_matrix()[(0, 0)] - 8.6).abs() < 1e-15);
        assert!((pm.mass_matrix_inv() * pm.mass_matrix() - Matrix6::identity()).norm() < 1e-13);
    }

    #[test]
    fn coriolis_matrices_are_skew_symmetric_and_forms_agree() {
        let mut p = reference_params(MunkMoment::Full);
        p.rigid_body.inertia_cg_kgm2 =
            RigidBody::inertia_tensor(0.068, 0.097, 0.114, 0.004, -0.006, 0.002);
        p.rigid_body.cg_from_co_m = Vector3::new(0.01, -0.004, 0.00559);
        p.added_mass[(0, 4)] = 0.1;
        p.added_mass[(4, 0)] = 0.1;
        let pm = ProcessModel::new(p).unwrap();
        let nu = Vector6::new(0.4, -0.2, 0.15, 0.3, -0.5, 0.8);
        let crb = pm.coriolis_rb(&nu);
        let ca = pm.coriolis_a(&nu);
        assert!((crb + crb.transpose()).norm() < 1e-14);
        assert!((ca + ca.transpose()).norm() < 1e-14);
        // Eq. 13 (H-transformed CG form) gives the same C_RB ν as the Kirchhoff form.
        let via_h = p.rigid_body.coriolis_co(&nu);
        assert!((via_h + via_h.transpose()).norm() < 1e-14);
        assert!((via_h * nu - crb * nu).norm() < 1e-14);
        assert!(((crb + ca) * nu - pm.coriolis_force(&nu)).norm() < 1e-14);
    }

    #[test]
    fn munk_zeroing_removes_exactly_the_remus_entries() {
        let pm = ProcessModel::new(reference_params(MunkMoment::Zeroed)).unwrap();
        let full = ProcessModel::new(reference_params(MunkMoment::Full)).unwrap();
        let nu = Vector6::new(0.7, 0.2, -0.3, 0.1, 0.2, -0.4);
        let ca = pm.coriolis_a(&nu);
        for (i, j) in [(4, 0), (4, 3), (5, 0), (5, 1)] {
            assert_eq!(ca[(i, j)], 0.0);
        }
        let vec_form = pm.coriolis_force(&nu);
        let mat_form = (pm.coriolis_rb(&nu) + ca) * nu;
        assert!((vec_form - mat_form).norm() < 1e-14);
        assert!((full.coriolis_force(&nu) - vec_form).norm() > 1e-3);
    }

    #[test]
    fn restoring_matches_gvect_and_linearisation() {
        let mut p = reference_params(MunkMoment::Full);
        p.hydrostatics.cg_from_co_m = Vector3::new(0.02, -0.01, 0.00559);
        p.hydrostatics.cb_from_co_m = Vector3::new(-0.01, 0.003, -0.002);
        let h = p.hydrostatics;
        let (w, b) = (h.weight_n, h.buoyancy_n);
        let (xg, yg, zg) = (h.cg_from_co_m.x, h.cg_from_co_m.y, h.cg_from_co_m.z);
        let (xb, yb, zb) = (h.cb_from_co_m.x, h.cb_from_co_m.y, h.cb_from_co_m.z);
        let (phi, th) = (0.3_f64, -0.2_f64);
        let eta = Vector6::new(0.0, 0.0, 1.0, phi, th, 0.7);
        let (sth, cth, sphi, cphi) = (th.sin(), th.cos(), phi.sin(), phi.cos());
        let gvect = Vector6::new(
            (w - b) * sth,
            -(w - b) * cth * sphi,
            -(w - b) * cth * cphi,
            -(yg * w - yb * b) * cth * cphi + (zg * w - zb * b) * cth * sphi,
            (zg * w - zb * b) * sth + (xg * w - xb * b) * cth * cphi,
            -(xg * w - xb * b) * cth * sphi - (yg * w - yb * b) * sth,
        );
        assert!((h.restoring(&eta) - gvect).norm() < 1e-13);
        // G is the Jacobian of g at η = 0 (finite differences).
        let g_lin = h.linearized();
        let eps = 1e-7;
        for j in 0..6 {
            let mut e1 = Vector6::zeros();
            e1[j] = eps;
            let col = (h.restoring(&e1) - h.restoring(&(-e1))) / (2.0 * eps);
            for i in 0..6 {
                assert!((col[i] - g_lin[(i, j)]).abs() < 1e-6, "G[{i}][{j}]");
            }
        }
    }

    #[test]
    fn exponential_damping_fades_the_linear_term_with_speed() {
        let mut p = reference_params(MunkMoment::Full);
        let nu = Vector6::new(0.8, 0.0, 0.0, 0.0, 0.0, 0.0);
        let lq = p.damping.force(&nu)[0];
        p.damping.form = DampingForm::Exponential { alpha_s_per_m: 2.0 };
        let ex = p.damping.force(&nu)[0];
        assert!((lq - (1.0 * 0.8 + 4.5 * 0.64)).abs() < 1e-12);
        assert!((ex - (1.0 * 0.8 * (-1.6_f64).exp() + 4.5 * 0.64)).abs() < 1e-12);
        let pm = ProcessModel::new(p).unwrap();
        assert!((pm.damping_force(&nu)[0] - ex).abs() < 1e-15);
        assert!((p.damping.matrix(&nu) * nu - p.damping.force(&nu)).norm() < 1e-14);
    }

    #[test]
    fn property_8_1_rigid_body_with_irrotational_current() {
        // M_RB ν̇ + C_RB(ν) ν = M_RB ν̇_r + C_RB(ν_r) ν_r for a current constant in NED.
        let pm = ProcessModel::new(reference_params(MunkMoment::Full)).unwrap();
        let current = CurrentSample::constant(0.3, 0.7);
        let eta = Vector6::new(0.0, 0.0, 1.0, 0.2, -0.1, 0.5);
        let nu = Vector6::new(0.5, -0.1, 0.2, 0.3, -0.2, 0.6);
        let tau = Vector6::new(3.0, 1.0, -2.0, 0.1, 0.05, 0.2);
        let nu_dot = pm.nu_dot(&eta, &nu, &tau, &current);
        let att = Attitude::from_eta(&eta);
        let vc_b = att.ned_from_body().transpose() * current.vel_ned_mps;
        let nu_c = stack(&vc_b, &Vector3::zeros());
        let nu_c_dot = stack(&(-ang(&nu).cross(&vc_b)), &Vector3::zeros());
        let nu_r = nu - nu_c;
        let nu_r_dot = nu_dot - nu_c_dot;
        let lhs = pm.m_rb() * nu_dot + pm.coriolis_rb(&nu) * nu;
        let rhs = pm.m_rb() * nu_r_dot + pm.coriolis_rb(&nu_r) * nu_r;
        assert!((lhs - rhs).norm() < 1e-12, "{lhs} vs {rhs}");
    }
}

#[cfg(test)]
mod scalar_path_tests {
    use super::*;
    use crate::kinematics::Attitude;

    /// ν̇ assembled from the vector-form terms, as the module docs write it.
    fn nu_dot_vector_form(
        pm: &ProcessModel,
        att: &Attitude,
        nu: &Vector6,
        tau: &Vector6,
        current: &CurrentSample,
    ) -> Vector6 {
        let r = att.ned_from_body();
        let rt = r.transpose();
        let vc = rt * current.vel_ned_mps;
        let vc_dot = -ang(nu).cross(&vc) + rt * current.accel_ned_mps2;
        let nu_r = nu - stack(&vc, &Vector3::zeros());
        let rhs = tau
            - pm.coriolis_force(&nu_r)
            - pm.damping_force(&nu_r)
            - pm.params()
                .hydrostatics
                .restoring_from_down(&att.down_in_body());
        stack(&vc_dot, &Vector3::zeros()) + pm.mass_matrix_inv() * rhs
    }

    fn params(full_matrices: bool, munk: MunkMoment, form: DampingForm) -> ProcessParams {
        let rb = RigidBody {
            mass_kg: 6.1,
            inertia_cg_kgm2: RigidBody::inertia_tensor(0.068, 0.097, 0.114, 0.003, -0.002, 0.001),
            cg_from_co_m: Vector3::new(0.002, -0.001, 0.00559),
        };
        let mut added = Matrix6::from_diagonal(&Vector6::new(2.5, 3.0, 2.7, 0.02, 0.03, 0.03));
        let mut linear = Matrix6::from_diagonal(&Vector6::new(1.0, 4.0, 5.0, 0.05, 0.08, 0.2));
        if full_matrices {
            added[(0, 4)] = 0.1;
            added[(4, 0)] = 0.1;
            added[(1, 5)] = -0.05;
            added[(5, 1)] = -0.05;
            linear[(0, 2)] = 0.3;
            linear[(5, 1)] = -0.2;
        }
        ProcessParams {
            rigid_body: rb,
            added_mass: added,
            damping: Damping {
                linear,
                quadratic: Vector6::new(4.5, 25.0, 20.0, 0.1, 0.2, 0.35),
                form,
            },
            hydrostatics: Hydrostatics {
                weight_n: 59.841,
                buoyancy_n: 60.341,
                cg_from_co_m: rb.cg_from_co_m,
                cb_from_co_m: Vector3::new(0.001, 0.0005, -0.002),
            },
            munk,
        }
    }

    #[test]
    fn scalar_nu_dot_equals_the_vector_form_terms() {
        let current = CurrentSample {
            vel_ned_mps: Vector3::new(0.3, -0.2, 0.05),
            accel_ned_mps2: Vector3::new(0.01, 0.02, -0.005),
        };
        let states = [
            (
                Vector6::new(1.0, 2.0, 5.0, 0.1, -0.2, 2.5),
                Vector6::new(0.6, -0.2, 0.1, 0.3, -0.1, 0.4),
            ),
            (
                Vector6::new(0.0, 0.0, 1.0, -1.2, 1.1, -7.0),
                Vector6::new(-0.4, 0.5, -0.3, -0.8, 0.6, -1.1),
            ),
        ];
        let tau = Vector6::new(12.0, -3.0, 7.0, 0.4, -0.2, 1.5);
        let mut cases = 0;
        for full in [false, true] {
            for munk in [MunkMoment::Full, MunkMoment::Zeroed] {
                for form in [
                    DampingForm::LinearQuadratic,
                    DampingForm::Exponential { alpha_s_per_m: 2.0 },
                ] {
                    let pm = ProcessModel::new(params(full, munk, form)).unwrap();
                    for (eta, nu) in &states {
                        let att = Attitude::from_eta(eta);
                        let got = pm.nu_dot_with_rotation(
                            &att.ned_from_body(),
                            &att.down_in_body(),
                            nu,
                            &tau,
                            &current,
                        );
                        let want = nu_dot_vector_form(&pm, &att, nu, &tau, &current);
                        let err = (got - want).norm();
                        assert!(
                            err <= 1e-12 * (1.0 + want.norm()),
                            "full {full}, {munk:?}, {form:?}: {got} vs {want}"
                        );
                        let (_, nu_dot) = pm.state_derivative(eta, nu, &tau, &current);
                        assert_eq!(nu_dot, got);
                        cases += 1;
                    }
                }
            }
        }
        assert_eq!(cases, 16);
    }
}
