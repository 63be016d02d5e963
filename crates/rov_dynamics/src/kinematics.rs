//! Kinematics (seed 001 eq. 1 and 3): η̇ = J(η) ν with ZYX Euler angles, and a quaternion
//! alternative for attitudes near θ = ±90°.
//!
//! Frames (Fossen): NED {n} with x north, y east, z down; body {b} with x forward,
//! y starboard, z down. η = [x, y, z, φ, θ, ψ] holds the position of the body origin CO in
//! NED (m) and the ZYX Euler angles roll, pitch, yaw (rad; ψ is not wrapped).
//! ν = [u, v, w, p, q, r] is the body-fixed velocity of CO over ground (m/s, rad/s).
//!
//! **Euler path** ([`eta_dot`], [`j_matrix`]): R = Rz(ψ) Ry(θ) Rx(φ); T(φ, θ) maps body rates
//! to Euler-angle rates and is singular at cos θ = 0 (its entries grow without bound).
//!
//! **Quaternion path** ([`QuatPose`], [`quat_state_dot`]): the attitude is the unit
//! quaternion q = q_{n←b} with q̇ = ½ q ⊗ (0, ω), which has no singularity. Integrate the
//! 13-vector [p_ned; q (w, x, y, z); ν] with any integrator of [`crate::integrators`] and
//! call [`normalize_quat_state`] after each step. Convert with [`QuatPose::from_eta`] and
//! [`QuatPose::to_eta`]. Use this option when large pitch or roll must be supported.

use nalgebra::{Matrix3, Quaternion, SVector, UnitQuaternion, Vector3};

use crate::math::{Matrix6, Vector6, ang, lin, sin_cos3};

/// A ZYX Euler attitude with its sines and cosines computed once.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Attitude {
    /// sin φ, cos φ.
    pub sin_roll: f64,
    /// cos φ.
    pub cos_roll: f64,
    /// sin θ.
    pub sin_pitch: f64,
    /// cos θ.
    pub cos_pitch: f64,
    /// sin ψ.
    pub sin_yaw: f64,
    /// cos ψ.
    pub cos_yaw: f64,
}

impl Attitude {
    /// From roll φ, pitch θ, yaw ψ in radians.
    #[inline]
    pub fn new(roll_rad: f64, pitch_rad: f64, yaw_rad: f64) -> Self {
        let [
            (sin_roll, cos_roll),
            (sin_pitch, cos_pitch),
            (sin_yaw, cos_yaw),
        ] = sin_cos3([roll_rad, pitch_rad, yaw_rad]);
        Self {
            sin_roll,
            cos_roll,
            sin_pitch,
            cos_pitch,
            sin_yaw,
            cos_yaw,
        }
    }

    /// From the angles η[3..6].
    #[inline]
    pub fn from_eta(eta: &Vector6) -> Self {
        Self::new(eta[3], eta[4], eta[5])
    }

    /// R = Rz(ψ) Ry(θ) Rx(φ): rotates body vectors into NED (`v_ned = R v_body`).
    #[inline]
    pub fn ned_from_body(&self) -> Matrix3<f64> {
        let (sphi, cphi) = (self.sin_roll, self.cos_roll);
        let (sth, cth) = (self.sin_pitch, self.cos_pitch);
        let (spsi, cpsi) = (self.sin_yaw, self.cos_yaw);
        Matrix3::new(
            cpsi * cth,
            -spsi * cphi + cpsi * sth * sphi,
            spsi * sphi + cpsi * cphi * sth,
            spsi * cth,
            cpsi * cphi + sphi * sth * spsi,
            -cpsi * sphi + sth * spsi * cphi,
            -sth,
            cth * sphi,
            cth * cphi,
        )
    }

    /// T(φ, θ): Euler-angle rates from body rates, [φ̇, θ̇, ψ̇] = T [p, q, r].
    /// Singular at cos θ = 0 (entries become infinite or huge).
    #[inline]
    pub fn euler_rates_from_body_rates(&self) -> Matrix3<f64> {
        let (sphi, cphi) = (self.sin_roll, self.cos_roll);
        let inv_cth = 1.0 / self.cos_pitch;
        let tth = self.sin_pitch * inv_cth;
        Matrix3::new(
            1.0,
            sphi * tth,
            cphi * tth,
            0.0,
            cphi,
            -sphi,
            0.0,
            sphi * inv_cth,
            cphi * inv_cth,
        )
    }

    /// The NED down axis seen in the body frame, Rᵀ e_z = (−sin θ, cos θ sin φ, cos θ cos φ).
    /// Gravity acts along it; the restoring forces depend on the attitude only through it.
    #[inline]
    pub fn down_in_body(&self) -> Vector3<f64> {
        Vector3::new(
            -self.sin_pitch,
            self.cos_pitch * self.sin_roll,
            self.cos_pitch * self.cos_roll,
        )
    }
}

/// J(η) = diag(R, T) (seed 001 eq. 1).
pub fn j_matrix(eta: &Vector6) -> Matrix6 {
    let att = Attitude::from_eta(eta);
    let mut j = Matrix6::zeros();
    j.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&att.ned_from_body());
    j.fixed_view_mut::<3, 3>(3, 3)
        .copy_from(&att.euler_rates_from_body_rates());
    j
}

/// η̇ = J(η) ν for a precomputed attitude.
#[inline]
pub fn eta_dot_with(att: &Attitude, nu: &Vector6) -> Vector6 {
    let p = att.ned_from_body() * lin(nu);
    let e = att.euler_rates_from_body_rates() * ang(nu);
    Vector6::new(p.x, p.y, p.z, e.x, e.y, e.z)
}

/// η̇ = J(η) ν.
#[inline]
pub fn eta_dot(eta: &Vector6, nu: &Vector6) -> Vector6 {
    eta_dot_with(&Attitude::from_eta(eta), nu)
}

/// ZYX Euler angles (roll, pitch, yaw) of a rotation matrix R = Rz Ry Rx. The yaw is
/// returned in (−π, π]; at θ = ±90° roll and yaw are not unique (roll is set from the
/// remaining freedom so that the returned angles still reproduce R).
pub fn euler_from_rotation(r: &Matrix3<f64>) -> (f64, f64, f64) {
    let pitch = (-r[(2, 0)]).clamp(-1.0, 1.0).asin();
    let roll = r[(2, 1)].atan2(r[(2, 2)]);
    let yaw = r[(1, 0)].atan2(r[(0, 0)]);
    if (r[(2, 1)].abs() + r[(2, 2)].abs()) < 1e-12 {
        // Gimbal lock: choose yaw = 0 and put the rotation into roll.
        let roll = if pitch > 0.0 {
            r[(0, 1)].atan2(r[(1, 1)])
        } else {
            (-r[(0, 1)]).atan2(r[(1, 1)])
        };
        return (roll, pitch, 0.0);
    }
    (roll, pitch, yaw)
}

/// Wraps `angle` to the branch nearest to `reference` (both rad).
pub fn unwrap_near(angle: f64, reference: f64) -> f64 {
    let two_pi = std::f64::consts::TAU;
    angle + two_pi * ((reference - angle) / two_pi).round()
}

/// Position and quaternion attitude of the body origin CO.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QuatPose {
    /// CO position in NED, m.
    pub pos_ned_m: Vector3<f64>,
    /// Rotation from body to NED (q_{n←b}).
    pub ned_from_body: UnitQuaternion<f64>,
}

impl QuatPose {
    /// From η with ZYX Euler angles.
    pub fn from_eta(eta: &Vector6) -> Self {
        Self {
            pos_ned_m: lin(eta),
            ned_from_body: UnitQuaternion::from_euler_angles(eta[3], eta[4], eta[5]),
        }
    }

    /// To η; the yaw is unwrapped to the branch nearest `yaw_hint_rad`.
    pub fn to_eta(&self, yaw_hint_rad: f64) -> Vector6 {
        let r = self.ned_from_body.to_rotation_matrix().into_inner();
        let (roll, pitch, yaw) = euler_from_rotation(&r);
        let p = self.pos_ned_m;
        Vector6::new(p.x, p.y, p.z, roll, pitch, unwrap_near(yaw, yaw_hint_rad))
    }
}

/// The 13-state of the quaternion path: [p_ned (3); q (w, x, y, z); ν (6)].
pub type QuatState = SVector<f64, 13>;

/// Packs a pose and velocity into a [`QuatState`].
pub fn quat_state(pose: &QuatPose, nu: &Vector6) -> QuatState {
    let q = pose.ned_from_body.quaternion();
    let mut x = QuatState::zeros();
    x[0] = pose.pos_ned_m.x;
    x[1] = pose.pos_ned_m.y;
    x[2] = pose.pos_ned_m.z;
    x[3] = q.w;
    x[4] = q.i;
    x[5] = q.j;
    x[6] = q.k;
    x.fixed_rows_mut::<6>(7).copy_from(nu);
    x
}

/// Unpacks a [`QuatState`] (the quaternion is normalised on the way).
pub fn unpack_quat_state(x: &QuatState) -> (QuatPose, Vector6) {
    let q = UnitQuaternion::from_quaternion(Quaternion::new(x[3], x[4], x[5], x[6]));
    let pose = QuatPose {
        pos_ned_m: Vector3::new(x[0], x[1], x[2]),
        ned_from_body: q,
    };
    (pose, x.fixed_rows::<6>(7).into_owned())
}

/// Renormalises the quaternion part of a [`QuatState`] (call after every step).
pub fn normalize_quat_state(x: &mut QuatState) {
    let n = (x[3] * x[3] + x[4] * x[4] + x[5] * x[5] + x[6] * x[6]).sqrt();
    if n > 0.0 && n.is_finite() {
        for i in 3..7 {
            x[i] /= n;
        }
    }
}

/// Kinematic part of the quaternion path: returns (ṗ_ned, q̇) for the quaternion
/// components (w, x, y, z) in `q_wxyz` and body velocity ν: ṗ = R(q) ν1, q̇ = ½ q ⊗ (0, ω).
/// `q_wxyz` need not be exactly unit (R is built from the normalised quaternion).
pub fn quat_kinematics(q_wxyz: &[f64; 4], nu: &Vector6) -> (Vector3<f64>, [f64; 4]) {
    let [w, x, y, z] = *q_wxyz;
    let n2 = w * w + x * x + y * y + z * z;
    let s = if n2 > 0.0 { 2.0 / n2 } else { 0.0 };
    // Rotation matrix of the (normalised) quaternion.
    let r = Matrix3::new(
        1.0 - s * (y * y + z * z),
        s * (x * y - w * z),
        s * (x * z + w * y),
        s * (x * y + w * z),
        1.0 - s * (x * x + z * z),
        s * (y * z - w * x),
        s * (x * z - w * y),
        s * (y * z + w * x),
        1.0 - s * (x * x + y * y),
    );
    let p_dot = r * lin(nu);
    let (p, q, rr) = (nu[3], nu[4], nu[5]);
    let q_dot = [
        0.5 * (-x * p - y * q - z * rr),
        0.5 * (w * p + y * rr - z * q),
        0.5 * (w * q + z * p - x * rr),
        0.5 * (w * rr + x * q - y * p),
    ];
    (p_dot, q_dot)
}

/// Rotation matrix R_{n←b} of the quaternion part of a [`QuatState`].
pub fn quat_state_rotation(x: &QuatState) -> Matrix3<f64> {
    let (pose, _) = unpack_quat_state(x);
    pose.ned_from_body.to_rotation_matrix().into_inner()
}

/// Derivative of a [`QuatState`] given the body acceleration ν̇ (from any kinetics).
pub fn quat_state_dot(x: &QuatState, nu_dot: &Vector6) -> QuatState {
    let nu: Vector6 = x.fixed_rows::<6>(7).into_owned();
    let (p_dot, q_dot) = quat_kinematics(&[x[3], x[4], x[5], x[6]], &nu);
    let mut d = QuatState::zeros();
    d[0] = p_dot.x;
    d[1] = p_dot.y;
    d[2] = p_dot.z;
    d[3] = q_dot[0];
    d[4] = q_dot[1];
    d[5] = q_dot[2];
    d[6] = q_dot[3];
    d.fixed_rows_mut::<6>(7).copy_from(nu_dot);
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_is_orthonormal_and_matches_quaternion() {
        for &(phi, th, psi) in &[(0.2, -0.15, 0.3), (1.0, 1.2, -2.0), (-2.5, 0.4, 3.0)] {
            let att = Attitude::new(phi, th, psi);
            let r = att.ned_from_body();
            assert!((r * r.transpose() - Matrix3::identity()).norm() < 1e-14);
            assert!((r.determinant() - 1.0).abs() < 1e-14);
            let q = UnitQuaternion::from_euler_angles(phi, th, psi);
            assert!((q.to_rotation_matrix().into_inner() - r).norm() < 1e-14);
            assert!((r.transpose() * Vector3::z() - att.down_in_body()).norm() < 1e-15);
            let (a, b, c) = euler_from_rotation(&r);
            assert!((a - phi).abs() < 1e-12 && (b - th).abs() < 1e-12);
            assert!((unwrap_near(c, psi) - psi).abs() < 1e-12);
        }
    }

    #[test]
    fn j_translational_block_is_orthogonal() {
        let eta = Vector6::new(1.0, 2.0, 3.0, 0.3, -0.4, 2.0);
        let j = j_matrix(&eta);
        let r = j.fixed_view::<3, 3>(0, 0).into_owned();
        assert!((r.transpose() * r - Matrix3::identity()).norm() < 1e-14);
        // T at zero roll/pitch is the identity.
        let t = Attitude::new(0.0, 0.0, 1.0).euler_rates_from_body_rates();
        assert!((t - Matrix3::identity()).norm() < 1e-15);
    }

    #[test]
    fn euler_rates_match_quaternion_derivative() {
        // Finite-difference check of T against the quaternion kinematics.
        let (phi, th, psi) = (0.3, -0.5, 1.1);
        let nu = Vector6::new(0.0, 0.0, 0.0, 0.4, -0.2, 0.7);
        let att = Attitude::new(phi, th, psi);
        let e_dot = att.euler_rates_from_body_rates() * ang(&nu);
        let q = UnitQuaternion::from_euler_angles(phi, th, psi);
        let qq = q.quaternion();
        let (_, qd) = quat_kinematics(&[qq.w, qq.i, qq.j, qq.k], &nu);
        let h = 1e-6;
        let q2 = UnitQuaternion::from_quaternion(Quaternion::new(
            qq.w + h * qd[0],
            qq.i + h * qd[1],
            qq.j + h * qd[2],
            qq.k + h * qd[3],
        ));
        let (a, b, c) = q2.euler_angles();
        let fd = Vector3::new((a - phi) / h, (b - th) / h, (c - psi) / h);
        assert!((fd - e_dot).norm() < 1e-5, "{fd} vs {e_dot}");
    }
}
