//! Small fixed-size linear-algebra helpers shared by the dynamics: the cross-product
//! matrix S(·), the transformation H(r), the Kirchhoff (m2c) Coriolis–centripetal matrix
//! and a matrix exponential for small discretisations.
//!
//! All types are fixed-size nalgebra types, so nothing here allocates.

use nalgebra::{Matrix3, SMatrix, Vector3};

/// 6-vector: generalized velocity ν, position/attitude η or force τ.
pub type Vector6 = nalgebra::Vector6<f64>;
/// 6×6 matrix: mass, Coriolis, damping, restoring.
pub type Matrix6 = nalgebra::Matrix6<f64>;

/// The skew-symmetric cross-product matrix: `skew(a) * b == a × b`.
#[inline]
pub fn skew(a: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

/// H(r) = [[I, Sᵀ(r)], [0, I]] (Fossen; seed 001 eq. 11): maps the generalized velocity
/// at the body origin CO to the velocity at the point r (given from CO in body axes).
pub fn h_matrix(r_from_co_m: &Vector3<f64>) -> Matrix6 {
    let mut h = Matrix6::identity();
    h.fixed_view_mut::<3, 3>(0, 3)
        .copy_from(&skew(r_from_co_m).transpose());
    h
}

/// Linear (first three) part of a 6-vector.
#[inline]
pub fn lin(v: &Vector6) -> Vector3<f64> {
    Vector3::new(v[0], v[1], v[2])
}

/// Angular (last three) part of a 6-vector.
#[inline]
pub fn ang(v: &Vector6) -> Vector3<f64> {
    Vector3::new(v[3], v[4], v[5])
}

/// Stacks two 3-vectors into a 6-vector.
#[inline]
pub fn stack(a: &Vector3<f64>, b: &Vector3<f64>) -> Vector6 {
    Vector6::new(a.x, a.y, a.z, b.x, b.y, b.z)
}

/// (M + Mᵀ)/2.
pub fn symmetrise(m: &Matrix6) -> Matrix6 {
    (m + m.transpose()) * 0.5
}

/// The Kirchhoff momenta of a (symmetrised) mass matrix: a = M11 ν1 + M12 ν2 and
/// b = M21 ν1 + M22 ν2.
#[inline]
pub fn kirchhoff_momenta(m_sym: &Matrix6, nu: &Vector6) -> (Vector3<f64>, Vector3<f64>) {
    let p = m_sym * nu;
    (lin(&p), ang(&p))
}

/// The Coriolis–centripetal matrix of a mass matrix in Kirchhoff form (Fossen's `m2c`;
/// seed 001 eq. 18–19): after symmetrising M, with a = M11 ν1 + M12 ν2 and
/// b = M21 ν1 + M22 ν2, C = [[0, −S(a)], [−S(a), −S(b)]]. It is skew-symmetric.
pub fn m2c(m: &Matrix6, nu: &Vector6) -> Matrix6 {
    let (a, b) = kirchhoff_momenta(&symmetrise(m), nu);
    let sa = skew(&a);
    let sb = skew(&b);
    let mut c = Matrix6::zeros();
    c.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-sa));
    c.fixed_view_mut::<3, 3>(3, 0).copy_from(&(-sa));
    c.fixed_view_mut::<3, 3>(3, 3).copy_from(&(-sb));
    c
}

/// C(ν)ν of [`m2c`] in vector form, for an already symmetrised mass matrix:
/// [ν2 × a ; ν1 × a + ν2 × b]. Equal to `m2c(m, nu) * nu` without forming C.
#[inline]
pub fn coriolis_times_nu(m_sym: &Matrix6, nu: &Vector6) -> Vector6 {
    let (a, b) = kirchhoff_momenta(m_sym, nu);
    let nu1 = lin(nu);
    let nu2 = ang(nu);
    stack(&nu2.cross(&a), &(nu1.cross(&a) + nu2.cross(&b)))
}

/// sin and cos of `x` for the hot path: Cody–Waite reduction by π/2 (two-part constant,
/// exact product for |n| < 2²⁰) and the fdlibm minimax kernels on [−π/4, π/4], accurate to
/// about one ulp (checked against `f64::sin_cos` in the tests). Arguments beyond
/// |x| = 5·10⁵ and non-finite ones fall back to `f64::sin_cos`. About 3× faster than the
/// libm call, which dominated the 6-DOF derivative.
#[inline]
pub fn sin_cos(x: f64) -> (f64, f64) {
    if x.is_nan() || x.abs() > 5.0e5 {
        return x.sin_cos();
    }
    let (t, y0, y1) = reduce_pio2(x);
    apply_quadrant(t, kernel_sin(y0, y1), kernel_cos(y0, y1))
}

/// Cody–Waite reduction by π/2 (two-part constant, exact product for |n| < 2²⁰): returns
/// t = x·2/π + 1.5·2⁵² (n = round(x·2/π) sits in its low mantissa bits; the 1.5·2⁵² trick
/// rounds to nearest, exact for |x·2/π| < 2⁵¹, where `f64::round` would be a library call)
/// and the reduced argument as head y0 and tail y1.
#[inline]
fn reduce_pio2(x: f64) -> (f64, f64, f64) {
    const PIO2_1: f64 = 1.5707963267341256;
    const PIO2_1T: f64 = 6.077100506506192e-11;
    const ROUND: f64 = 6_755_399_441_055_744.0;
    let t = x * std::f64::consts::FRAC_2_PI + ROUND;
    let n = t - ROUND;
    let r = x - n * PIO2_1;
    let w = n * PIO2_1T;
    let y0 = r - w;
    let y1 = (r - y0) - w;
    (t, y0, y1)
}

/// [`sin_cos`] of three angles at once (the ZYX Euler angles of every RK4 stage): the
/// same reduction and fdlibm kernels on four SIMD lanes (two SSE2 registers on x86_64,
/// the baseline of that target; the compiler did not vectorise the lane-by-lane form).
/// Packed add, subtract and multiply round exactly as the scalar ones, and every
/// expression keeps the scalar path's order, so the results are bit-identical to three
/// [`sin_cos`] calls (tested). Any argument outside the fast range falls back to the
/// scalar path.
#[inline]
pub fn sin_cos3(x: [f64; 3]) -> [(f64, f64); 3] {
    if !x.iter().all(|v| v.abs() <= 5.0e5) {
        return [sin_cos(x[0]), sin_cos(x[1]), sin_cos(x[2])];
    }
    let (t, s, c) = reduced_sin_cos4([x[0], x[1], x[2], 0.0]);
    [
        apply_quadrant(t[0], s[0], c[0]),
        apply_quadrant(t[1], s[1], c[1]),
        apply_quadrant(t[2], s[2], c[2]),
    ]
}

/// The reduction `t` of four angles and the kernels' sin and cos of their reduced
/// arguments (what [`sin_cos`] computes before [`apply_quadrant`]): [`reduce_pio2`],
/// [`kernel_sin`] and [`kernel_cos`] on four SIMD lanes, operation for operation in the
/// same order (no fused multiply-add), so each lane is bit-identical to the scalar
/// functions. (`wide` is already in the build through nalgebra's `simba`.)
#[inline]
fn reduced_sin_cos4(x: [f64; 4]) -> ([f64; 4], [f64; 4], [f64; 4]) {
    use wide::f64x4;
    const PIO2_1: f64 = 1.5707963267341256;
    const PIO2_1T: f64 = 6.077100506506192e-11;
    const ROUND: f64 = 6_755_399_441_055_744.0;
    let k = f64x4::splat;
    let x = f64x4::new(x);
    // reduce_pio2
    let t = x * k(std::f64::consts::FRAC_2_PI) + k(ROUND);
    let n = t - k(ROUND);
    let r = x - n * k(PIO2_1);
    let w = n * k(PIO2_1T);
    let y0 = r - w;
    let y1 = (r - y0) - w;
    // kernel_sin(y0, y1)
    let s = {
        const S1: f64 = -0.16666666666666632;
        const S2: f64 = 0.00833333333332249;
        const S3: f64 = -0.0001984126982985795;
        const S4: f64 = 2.7557313707070068e-06;
        const S5: f64 = -2.5050760253406863e-08;
        const S6: f64 = 1.58969099521155e-10;
        let (x, y) = (y0, y1);
        let z = x * x;
        let v = z * x;
        let z2 = z * z;
        let r = (k(S2) + z * k(S3)) + z2 * ((k(S4) + z * k(S5)) + z2 * k(S6));
        x - ((z * (k(0.5) * y - v * r) - y) - v * k(S1))
    };
    // kernel_cos(y0, y1)
    let c = {
        const C1: f64 = 0.0416666666666666;
        const C2: f64 = -0.001388888888887411;
        const C3: f64 = 2.480158728947673e-05;
        const C4: f64 = -2.7557314351390663e-07;
        const C5: f64 = 2.087572321298175e-09;
        const C6: f64 = -1.1359647557788195e-11;
        let (x, y) = (y0, y1);
        let z = x * x;
        let z2 = z * z;
        let r = z * ((k(C1) + z * k(C2)) + z2 * ((k(C3) + z * k(C4)) + z2 * (k(C5) + z * k(C6))));
        let hz = k(0.5) * z;
        let w = k(1.0) - hz;
        w + (((k(1.0) - w) - hz) + (z * r - x * y))
    };
    (t.to_array(), s.to_array(), c.to_array())
}

/// Maps the kernels' (sin, cos) of the reduced argument to the full angle using
/// q = n mod 4 from the low mantissa bits of t (two's complement for n < 0).
#[inline]
fn apply_quadrant(t: f64, s: f64, c: f64) -> (f64, f64) {
    let q = t.to_bits() & 3;
    let (s, c) = if q & 1 == 0 { (s, c) } else { (c, -s) };
    let flip = (q & 2) << 62;
    (
        f64::from_bits(s.to_bits() ^ flip),
        f64::from_bits(c.to_bits() ^ flip),
    )
}

/// fdlibm `__kernel_sin` for |x| ≤ π/4 with tail y.
#[inline]
fn kernel_sin(x: f64, y: f64) -> f64 {
    const S1: f64 = -0.16666666666666632;
    const S2: f64 = 0.00833333333332249;
    const S3: f64 = -0.0001984126982985795;
    const S4: f64 = 2.7557313707070068e-06;
    const S5: f64 = -2.5050760253406863e-08;
    const S6: f64 = 1.58969099521155e-10;
    let z = x * x;
    let v = z * x;
    // Estrin's scheme: fdlibm's polynomial with a shorter dependency chain than Horner's.
    let z2 = z * z;
    let r = (S2 + z * S3) + z2 * ((S4 + z * S5) + z2 * S6);
    x - ((z * (0.5 * y - v * r) - y) - v * S1)
}

/// fdlibm `__kernel_cos` for |x| ≤ π/4 with tail y.
#[inline]
fn kernel_cos(x: f64, y: f64) -> f64 {
    const C1: f64 = 0.0416666666666666;
    const C2: f64 = -0.001388888888887411;
    const C3: f64 = 2.480158728947673e-05;
    const C4: f64 = -2.7557314351390663e-07;
    const C5: f64 = 2.087572321298175e-09;
    const C6: f64 = -1.1359647557788195e-11;
    let z = x * x;
    let z2 = z * z;
    let r = z * ((C1 + z * C2) + z2 * ((C3 + z * C4) + z2 * (C5 + z * C6)));
    let hz = 0.5 * z;
    let w = 1.0 - hz;
    w + (((1.0 - w) - hz) + (z * r - x * y))
}

/// Matrix exponential of a small square matrix by scaling and squaring with a Taylor
/// series (converged to machine precision for the ‖A‖ ≤ 0.5 scaled matrix). Used to
/// discretise the control plant model; N is small (≤ 8), so the cost is negligible.
pub fn expm<const N: usize>(a: &SMatrix<f64, N, N>) -> SMatrix<f64, N, N> {
    let norm = a.iter().fold(0.0_f64, |m, x| m.max(x.abs())) * N as f64;
    let mut squarings = 0_i32;
    let mut scale = 1.0;
    while norm * scale > 0.5 && squarings < 64 {
        scale *= 0.5;
        squarings += 1;
    }
    let x = a * scale;
    let mut term = SMatrix::<f64, N, N>::identity();
    let mut sum = term;
    for k in 1..=20 {
        term = term * x / k as f64;
        sum += term;
        if term.iter().all(|t| t.abs() < 1e-18) {
            break;
        }
    }
    for _ in 0..squarings {
        sum = sum * sum;
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn skew_is_cross_product() {
        let a = Vector3::new(1.0, -2.0, 0.5);
        let b = Vector3::new(0.3, 0.7, -1.1);
        assert!((skew(&a) * b - a.cross(&b)).norm() < 1e-15);
        assert!((skew(&a) + skew(&a).transpose()).norm() == 0.0);
    }

    #[test]
    fn m2c_is_skew_symmetric_and_matches_vector_form() {
        let mut m = Matrix6::from_fn(|i, j| 0.1 * (i as f64 + 1.0) * (j as f64 + 2.0).sqrt());
        m += Matrix6::identity() * 5.0;
        let nu = Vector6::new(0.5, -0.2, 0.1, 0.3, -0.4, 0.7);
        let c = m2c(&m, &nu);
        assert!((c + c.transpose()).norm() < 1e-14);
        let v = coriolis_times_nu(&symmetrise(&m), &nu);
        assert!((c * nu - v).norm() < 1e-14);
        // Skew symmetry means C(ν)ν does no work.
        assert!(nu.dot(&v).abs() < 1e-14);
    }

    #[test]
    fn fast_sin_cos_matches_libm() {
        let mut worst: f64 = 0.0;
        let mut x = -2000.0_f64;
        while x < 2000.0 {
            let (s, c) = sin_cos(x);
            let (s0, c0) = x.sin_cos();
            worst = worst.max((s - s0).abs()).max((c - c0).abs());
            x += 0.001_234_567;
        }
        for x in [
            0.0,
            -0.0,
            1e-300,
            std::f64::consts::FRAC_PI_2,
            std::f64::consts::PI,
            -std::f64::consts::FRAC_PI_4,
            4.9e5,
        ] {
            let (s, c) = sin_cos(x);
            let (s0, c0) = x.sin_cos();
            worst = worst.max((s - s0).abs()).max((c - c0).abs());
        }
        assert!(worst < 4.5e-16, "worst abs difference {worst}");
        assert!(sin_cos(f64::NAN).0.is_nan());
        assert_eq!(sin_cos(1e7), 1e7_f64.sin_cos());
    }

    #[test]
    fn sin_cos3_equals_three_scalar_calls() {
        let mut x = -3000.0_f64;
        while x < 3000.0 {
            let a = [x, -0.37 * x, 1.0 - x * 0.011];
            let got = sin_cos3(a);
            for (g, v) in got.iter().zip(a) {
                let want = sin_cos(v);
                assert_eq!(g.0.to_bits(), want.0.to_bits(), "sin {v}");
                assert_eq!(g.1.to_bits(), want.1.to_bits(), "cos {v}");
            }
            x += 0.000_987_654_3;
        }
        let got = sin_cos3([0.3, 7.0e5, f64::NAN]);
        assert_eq!(got[0], sin_cos(0.3));
        assert_eq!(got[1], 7.0e5_f64.sin_cos());
        assert!(got[2].0.is_nan() && got[2].1.is_nan());
        let zero = sin_cos3([-0.0, 0.0, std::f64::consts::PI]);
        assert_eq!(zero[0].0.to_bits(), (-0.0_f64).to_bits());
        assert_eq!(zero[2], sin_cos(std::f64::consts::PI));
    }

    #[test]
    fn expm_of_diagonal_and_nilpotent() {
        let a = nalgebra::Matrix2::new(-1.0, 0.0, 0.0, 2.0);
        let e = expm(&a);
        assert!((e[(0, 0)] - (-1.0_f64).exp()).abs() < 1e-14);
        assert!((e[(1, 1)] - 2.0_f64.exp()).abs() < 1e-13);
        let n = nalgebra::Matrix2::new(0.0, 3.0, 0.0, 0.0);
        let e = expm(&n);
        assert!((e - nalgebra::Matrix2::new(1.0, 3.0, 0.0, 1.0)).norm() < 1e-15);
    }
}
