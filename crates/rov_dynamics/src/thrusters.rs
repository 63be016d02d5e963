//! Thrusters: command → force maps, propeller models and geometry (force → τ).
//!
//! * [`QuadraticThrustMap`]: F = T_l u + T_q u|u| with u = percent / 100 (seed 000 eq. 21,
//!   read sign-preserving), with separate forward (u ≥ 0) and reverse (u < 0) pairs. The
//!   base models use equal pairs (project decision); the model lab sets reverse ≠ forward.
//! * [`LinearThrustMap`]: F = G · percent (seed 000 eq. 17).
//! * [`PropellerModel`]: F = ρ D⁴ (α₁ + α₂ u_a/(n D)) n|n| with n = a·u (seed 000 eq. 20).
//! * [`kt_first_quadrant`], [`kt_third_quadrant`], [`propeller_thrust_kt`]: the open-water
//!   K_T(J) polynomials of seed 001 eq. 38–41.
//! * [`ThrusterGeometry`]: position from CO and unit direction in body axes; τ = [F d; r × F d].
//!
//! Pro 4 layout (parameters.md, project decisions): port at (−0.13, −0.10, 0) and
//! starboard at (−0.13, +0.10, 0), both pointing +x; vertical at (0, 0, 0) pointing +z
//! (a positive command pushes the vehicle down). Port thrust above starboard thrust gives
//! N = −y·F > 0, a turn to starboard.

use nalgebra::{SMatrix, Vector3};

use crate::error::DynamicsError;
use crate::math::{Vector6, stack};

/// Thruster commands in percent, −100..100. Positive port/starboard push forward; positive
/// vertical pushes down.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ThrustPct {
    /// Port (left) horizontal thruster, %.
    pub port: f64,
    /// Starboard (right) horizontal thruster, %.
    pub starboard: f64,
    /// Vertical thruster, %; positive pushes down.
    pub vertical: f64,
}

impl ThrustPct {
    /// All thrusters off.
    pub const ZERO: Self = Self {
        port: 0.0,
        starboard: 0.0,
        vertical: 0.0,
    };

    /// From the three commands.
    pub const fn new(port: f64, starboard: f64, vertical: f64) -> Self {
        Self {
            port,
            starboard,
            vertical,
        }
    }

    /// Whether all three commands are finite.
    pub fn is_finite(&self) -> bool {
        self.port.is_finite() && self.starboard.is_finite() && self.vertical.is_finite()
    }

    /// Whether all three commands are finite and within −100..100 %.
    pub fn is_valid(&self) -> bool {
        [self.port, self.starboard, self.vertical]
            .iter()
            .all(|x| x.is_finite() && (-100.0..=100.0).contains(x))
    }

    /// Clamped to −100..100 % (non-finite commands become 0).
    pub fn saturated(&self) -> Self {
        let c = |x: f64| {
            if x.is_finite() {
                x.clamp(-100.0, 100.0)
            } else {
                0.0
            }
        };
        Self::new(c(self.port), c(self.starboard), c(self.vertical))
    }
}

/// Force of each thruster along its own direction, N.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ThrusterForces {
    /// Port, N.
    pub port_n: f64,
    /// Starboard, N.
    pub starboard_n: f64,
    /// Vertical, N.
    pub vertical_n: f64,
}

/// One (T_l, T_q) pair, N (force at |u| = 1 is T_l + T_q).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThrustPair {
    /// Linear coefficient T_l, N.
    pub linear_n: f64,
    /// Quadratic coefficient T_q, N.
    pub quadratic_n: f64,
}

/// F = T_l u + T_q u|u| with u = percent/100, forward pair for u ≥ 0, reverse for u < 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QuadraticThrustMap {
    /// Pair used for u ≥ 0.
    pub forward: ThrustPair,
    /// Pair used for u < 0 (magnitudes; the sign comes from u).
    pub reverse: ThrustPair,
}

impl QuadraticThrustMap {
    /// Equal pairs in both directions (the base models).
    pub fn symmetric(pair: ThrustPair) -> Self {
        Self {
            forward: pair,
            reverse: pair,
        }
    }

    /// A linear map `F = G·pct` (N per %) as the quadratic special case `T_l = 100·G`.
    pub fn linear(n_per_pct: f64) -> Self {
        Self::symmetric(ThrustPair {
            linear_n: 100.0 * n_per_pct,
            quadratic_n: 0.0,
        })
    }

    /// Force for a command in percent (not clamped: the simulator's hot path; the
    /// command is limited upstream).
    #[inline]
    pub fn force_n(&self, pct: f64) -> f64 {
        let u = pct * 0.01;
        let p = if u >= 0.0 { self.forward } else { self.reverse };
        p.linear_n * u + p.quadratic_n * u * u.abs()
    }

    /// Force for a command in percent clamped to ±100; a non-finite command gives 0.
    pub fn force_n_clamped(&self, pct: f64) -> f64 {
        if pct.is_finite() {
            self.force_n(pct.clamp(-100.0, 100.0))
        } else {
            0.0
        }
    }

    /// The inverse map: the command (%) that produces force `f_n`, inverted per sign
    /// (forward pair for `f_n ≥ 0`, reverse pair below). A force beyond the map's reach
    /// saturates at ±100 % and says so; a non-finite force gives 0 % (saturated). Never NaN.
    pub fn inverse(&self, f_n: f64) -> ThrustInverse {
        if !f_n.is_finite() {
            return ThrustInverse {
                pct: 0.0,
                saturated: true,
            };
        }
        let (pair, sign) = if f_n >= 0.0 {
            (self.forward, 1.0)
        } else {
            (self.reverse, -1.0)
        };
        let u = invert_quadratic(pair.linear_n, pair.quadratic_n, f_n.abs());
        let pct = sign * 100.0 * u;
        let within = pct.is_finite() && pct.abs() <= 100.0;
        // A map that produces no force this way cannot meet any demand but zero.
        let dead = f_n != 0.0 && pair.linear_n + pair.quadratic_n <= 0.0;
        ThrustInverse {
            pct: if within { pct } else { sign * 100.0 },
            saturated: !within || dead,
        }
    }

    /// [`QuadraticThrustMap::inverse`]'s command alone.
    pub fn pct_for_force(&self, f_n: f64) -> f64 {
        self.inverse(f_n).pct
    }

    /// The same map with every coefficient multiplied by `k` (≥ 0).
    pub fn scaled(&self, k: f64) -> Self {
        let s = |p: ThrustPair| ThrustPair {
            linear_n: k * p.linear_n,
            quadratic_n: k * p.quadratic_n,
        };
        Self {
            forward: s(self.forward),
            reverse: s(self.reverse),
        }
    }

    /// The map of a differential pair, `port` at +u and `starboard` at −u: the force
    /// difference `F_port(u) − F_starboard(−u)` as a function of u.
    pub fn differential(port: &Self, starboard: &Self) -> Self {
        let add = |a: ThrustPair, b: ThrustPair| ThrustPair {
            linear_n: a.linear_n + b.linear_n,
            quadratic_n: a.quadratic_n + b.quadratic_n,
        };
        Self {
            forward: add(port.forward, starboard.reverse),
            reverse: add(port.reverse, starboard.forward),
        }
    }
}

/// The result of inverting a thrust map.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThrustInverse {
    /// The command, %, within ±100 and finite.
    pub pct: f64,
    /// The demand was beyond the map's reach (or not finite), so `pct` is the limit.
    pub saturated: bool,
}

/// Inverts `F = a·u + b·u²` for `F ≥ 0`, `u ≥ 0` (a, b ≥ 0); 0 when both are zero.
fn invert_quadratic(a: f64, b: f64, f: f64) -> f64 {
    let den = a + (a * a + 4.0 * b * f).sqrt();
    if den > 0.0 { 2.0 * f / den } else { 0.0 }
}

/// F = G · percent (seed 000 eq. 17).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearThrustMap {
    /// Gain G, N per %.
    pub gain_n_per_pct: f64,
}

/// A per-thruster command → force map.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ThrustMap {
    /// Quadratic (seed 000 eq. 21).
    Quadratic(QuadraticThrustMap),
    /// Linear (seed 000 eq. 17).
    Linear(LinearThrustMap),
}

impl ThrustMap {
    /// Force for a command in percent, N.
    #[inline]
    pub fn force_n(&self, pct: f64) -> f64 {
        match self {
            ThrustMap::Quadratic(q) => q.force_n(pct),
            ThrustMap::Linear(l) => l.gain_n_per_pct * pct,
        }
    }

    /// The same map in the quadratic form (a linear map is `T_l = 100·G`, `T_q = 0`),
    /// which has the inverse.
    pub fn as_quadratic(&self) -> QuadraticThrustMap {
        match self {
            ThrustMap::Quadratic(q) => *q,
            ThrustMap::Linear(l) => QuadraticThrustMap::linear(l.gain_n_per_pct),
        }
    }
}

/// Thruster position and direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThrusterGeometry {
    position_m: Vector3<f64>,
    direction: Vector3<f64>,
}

impl ThrusterGeometry {
    /// `position_from_co_m` in body axes; `direction` must have unit length (±1e-3).
    pub fn new(
        position_from_co_m: Vector3<f64>,
        direction: Vector3<f64>,
    ) -> Result<Self, DynamicsError> {
        let n = direction.norm();
        if !(position_from_co_m.iter().all(|x| x.is_finite())
            && n.is_finite()
            && (n - 1.0).abs() <= 1e-3)
        {
            return Err(DynamicsError::InvalidParameter {
                what: "thruster geometry".into(),
                detail: format!(
                    "position {position_from_co_m:?} must be finite and direction {direction:?} a unit vector (norm {n})"
                ),
            });
        }
        Ok(Self {
            position_m: position_from_co_m,
            direction: direction / n,
        })
    }

    /// Position from CO, m.
    pub fn position_m(&self) -> Vector3<f64> {
        self.position_m
    }

    /// Unit direction.
    pub fn direction(&self) -> Vector3<f64> {
        self.direction
    }

    /// τ of a force `force_n` along the direction: [F d ; r × F d].
    #[inline]
    pub fn tau(&self, force_n: f64) -> Vector6 {
        let f = self.direction * force_n;
        stack(&f, &self.position_m.cross(&f))
    }
}

/// The Pro 4 port thruster geometry.
pub fn pro4_port_geometry() -> ThrusterGeometry {
    ThrusterGeometry {
        position_m: Vector3::new(-0.13, -0.10, 0.0),
        direction: Vector3::x(),
    }
}

/// The Pro 4 starboard thruster geometry.
pub fn pro4_starboard_geometry() -> ThrusterGeometry {
    ThrusterGeometry {
        position_m: Vector3::new(-0.13, 0.10, 0.0),
        direction: Vector3::x(),
    }
}

/// The Pro 4 vertical thruster geometry (pushes down for positive force).
pub fn pro4_vertical_geometry() -> ThrusterGeometry {
    ThrusterGeometry {
        position_m: Vector3::zeros(),
        direction: Vector3::z(),
    }
}

/// One thruster: map and geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Thruster {
    /// Command → force.
    pub map: ThrustMap,
    /// Where and along which axis the force acts.
    pub geometry: ThrusterGeometry,
}

/// The three Pro 4 thrusters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThrusterSet {
    /// Port horizontal.
    pub port: Thruster,
    /// Starboard horizontal.
    pub starboard: Thruster,
    /// Vertical.
    pub vertical: Thruster,
}

impl ThrusterSet {
    /// Stage (a): per-thruster forces.
    #[inline]
    pub fn forces(&self, cmd: &ThrustPct) -> ThrusterForces {
        ThrusterForces {
            port_n: self.port.map.force_n(cmd.port),
            starboard_n: self.starboard.map.force_n(cmd.starboard),
            vertical_n: self.vertical.map.force_n(cmd.vertical),
        }
    }

    /// The 6×3 allocation matrix B with τ = B (F_port, F_starboard, F_vertical)ᵀ; column i
    /// is [d_i ; r_i × d_i].
    pub fn allocation_matrix(&self) -> SMatrix<f64, 6, 3> {
        let mut b = SMatrix::<f64, 6, 3>::zeros();
        for (i, t) in [&self.port, &self.starboard, &self.vertical]
            .iter()
            .enumerate()
        {
            b.set_column(i, &t.geometry.tau(1.0));
        }
        b
    }

    /// Stage (b): τ from the forces.
    #[inline]
    pub fn tau(&self, f: &ThrusterForces) -> Vector6 {
        self.port.geometry.tau(f.port_n)
            + self.starboard.geometry.tau(f.starboard_n)
            + self.vertical.geometry.tau(f.vertical_n)
    }
}

/// Propeller thrust with advance speed (seed 000 eq. 20):
/// F = ρ D⁴ (α₁ + α₂ u_a/(n D)) n|n| = ρ D⁴ (α₁ n|n| + α₂ u_a |n| / D), which is finite at
/// n = 0. The rotation speed follows the command linearly, n = a · u (u = percent/100).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PropellerModel {
    /// Water density ρ, kg/m³.
    pub water_density_kgpm3: f64,
    /// Propeller diameter D, m.
    pub diameter_m: f64,
    /// α₁ (dimensionless).
    pub alpha1: f64,
    /// α₂ (dimensionless, usually negative: thrust falls with advance speed).
    pub alpha2: f64,
    /// a: rotation speed at full command, rev/s.
    pub max_rps: f64,
}

impl PropellerModel {
    /// Thrust at rotation speed `n_rps` and advance speed `advance_mps`, N.
    #[inline]
    pub fn thrust_n(&self, n_rps: f64, advance_mps: f64) -> f64 {
        let d = self.diameter_m;
        self.water_density_kgpm3
            * d.powi(4)
            * (self.alpha1 * n_rps * n_rps.abs() + self.alpha2 * advance_mps * n_rps.abs() / d)
    }

    /// Thrust for a command in percent and an advance speed.
    pub fn thrust_from_command_n(&self, pct: f64, advance_mps: f64) -> f64 {
        self.thrust_n(self.max_rps * pct * 0.01, advance_mps)
    }
}

/// K_T(J) in the first quadrant (forward rotation), seed 001 eq. 40 (Minerva ROV propeller):
/// 0.5 J³ − 0.66 J² − 0.25 J + 0.24.
#[inline]
pub fn kt_first_quadrant(j: f64) -> f64 {
    ((0.5 * j - 0.66) * j - 0.25) * j + 0.24
}

/// K_T(J) in the third quadrant (reverse rotation), seed 001 eq. 41:
/// 0.025 J³ − 0.28 J² − 0.17 J − 0.15.
#[inline]
pub fn kt_third_quadrant(j: f64) -> f64 {
    ((0.025 * j - 0.28) * j - 0.17) * j - 0.15
}

/// f = K_T(J) ρ D⁴ n² with J = V_a/(n D) (seed 001 eq. 38–39): the first-quadrant
/// polynomial for n > 0, the third-quadrant one for n < 0 (where V_a < 0 gives J > 0), and
/// 0 at n = 0. Outside the fitted quadrants (n and V_a of opposite signs) the polynomials
/// are extrapolated; treat those values as rough.
pub fn propeller_thrust_kt(
    n_rps: f64,
    advance_mps: f64,
    water_density_kgpm3: f64,
    diameter_m: f64,
) -> f64 {
    if n_rps == 0.0 {
        return 0.0;
    }
    let j = advance_mps / (n_rps * diameter_m);
    let kt = if n_rps > 0.0 {
        kt_first_quadrant(j)
    } else {
        kt_third_quadrant(j)
    };
    kt * water_density_kgpm3 * diameter_m.powi(4) * n_rps * n_rps
}

#[cfg(test)]
mod tests {
    use super::*;

    fn asymmetric() -> QuadraticThrustMap {
        QuadraticThrustMap {
            forward: ThrustPair {
                linear_n: 1.7,
                quadratic_n: 15.3,
            },
            reverse: ThrustPair {
                linear_n: 0.7,
                quadratic_n: 6.0,
            },
        }
    }

    #[test]
    fn inverse_round_trips_per_sign() {
        let m = asymmetric();
        for k in -200..=200 {
            let pct = f64::from(k) * 0.5;
            let f = m.force_n(pct);
            let inv = m.inverse(f);
            assert!((inv.pct - pct).abs() < 1e-9, "{pct} -> {f} -> {inv:?}");
            assert!(!inv.saturated, "{pct}");
            assert_eq!(m.force_n_clamped(pct), f);
        }
        // The linear special case and the enum's quadratic form agree with the enum.
        let lin = ThrustMap::Linear(LinearThrustMap {
            gain_n_per_pct: 0.07,
        });
        for pct in [-100.0, -3.0, 0.0, 42.0, 100.0] {
            let q = lin.as_quadratic();
            assert!((q.force_n(pct) - lin.force_n(pct)).abs() < 1e-12);
            assert!((q.pct_for_force(lin.force_n(pct)) - pct).abs() < 1e-9);
        }
    }

    #[test]
    fn inverse_saturates_and_never_returns_nan() {
        let m = asymmetric();
        let up = m.inverse(50.0);
        assert_eq!((up.pct, up.saturated), (100.0, true));
        let down = m.inverse(-50.0);
        assert_eq!((down.pct, down.saturated), (-100.0, true));
        for f in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let inv = m.inverse(f);
            assert_eq!((inv.pct, inv.saturated), (0.0, true), "{f}");
        }
        assert_eq!(m.force_n_clamped(f64::NAN), 0.0);
        assert_eq!(m.force_n_clamped(250.0), m.force_n(100.0));
        // A map with a dead reverse direction: any reverse demand saturates, finitely.
        let dead = QuadraticThrustMap {
            reverse: ThrustPair {
                linear_n: 0.0,
                quadratic_n: 0.0,
            },
            ..m
        };
        for f in [-1e300, -1.0, -1e-300, f64::MAX, f64::MIN_POSITIVE] {
            let inv = dead.inverse(f);
            assert!(
                inv.pct.is_finite() && inv.pct.abs() <= 100.0,
                "{f} -> {inv:?}"
            );
        }
        assert!(dead.inverse(-1.0).saturated);
        assert_eq!(dead.inverse(0.0).pct, 0.0);
    }

    #[test]
    fn differential_and_scaled_maps() {
        let (p, s) = (asymmetric(), asymmetric().scaled(0.5));
        let d = QuadraticThrustMap::differential(&p, &s);
        for pct in [-100.0, -40.0, 0.0, 30.0, 100.0] {
            let want = p.force_n(pct) - s.force_n(-pct);
            assert!((d.force_n(pct) - want).abs() < 1e-12, "{pct}");
        }
        assert!((s.force_n(100.0) - 8.5).abs() < 1e-12);
    }

    fn pro4_set(pair: ThrustPair) -> ThrusterSet {
        let map = ThrustMap::Quadratic(QuadraticThrustMap::symmetric(pair));
        ThrusterSet {
            port: Thruster {
                map,
                geometry: pro4_port_geometry(),
            },
            starboard: Thruster {
                map,
                geometry: pro4_starboard_geometry(),
            },
            vertical: Thruster {
                map,
                geometry: pro4_vertical_geometry(),
            },
        }
    }

    #[test]
    fn quadratic_map_is_sign_preserving_with_separate_reverse_pair() {
        let m = asymmetric();
        assert!((m.force_n(100.0) - 17.0).abs() < 1e-12);
        assert!((m.force_n(-100.0) + 6.7).abs() < 1e-12);
        assert!((m.force_n(50.0) - (0.85 + 15.3 * 0.25)).abs() < 1e-12);
        assert_eq!(m.force_n(0.0), 0.0);
    }

    #[test]
    fn geometry_signs_port_above_starboard_turns_to_starboard() {
        let set = pro4_set(ThrustPair {
            linear_n: 1.7,
            quadratic_n: 15.3,
        });
        let tau = set.tau(&set.forces(&ThrustPct::new(60.0, 20.0, 0.0)));
        assert!(tau[5] > 0.0, "positive yaw moment, got {tau}");
        assert!(tau[0] > 0.0);
        assert!(
            tau[3].abs() < 1e-15 && tau[4].abs() < 1e-15,
            "no roll/pitch from z = 0 thrusters"
        );
        let f = set.forces(&ThrustPct::new(60.0, 20.0, 0.0));
        assert!((tau[5] - 0.10 * (f.port_n - f.starboard_n)).abs() < 1e-14);
        // Vertical thruster pushes down and makes no moment about CO.
        let tau = set.tau(&set.forces(&ThrustPct::new(0.0, 0.0, 50.0)));
        assert!(tau[2] > 0.0 && tau.fixed_rows::<3>(3).norm() == 0.0);
    }

    #[test]
    fn kt_polynomials_match_seed_coefficients() {
        assert!((kt_first_quadrant(0.0) - 0.24).abs() < 1e-15);
        assert!((kt_third_quadrant(0.0) + 0.15).abs() < 1e-15);
        assert!((kt_first_quadrant(0.5) - 0.0125).abs() < 1e-15);
        assert!((kt_third_quadrant(1.0) - (0.025 - 0.28 - 0.17 - 0.15)).abs() < 1e-15);
        // Bollard pull: f = K_T(0) ρ D⁴ n², negative for reverse rotation.
        let f = propeller_thrust_kt(20.0, 0.0, 1000.0, 0.1);
        assert!((f - 0.24 * 1000.0 * 1e-4 * 400.0).abs() < 1e-9);
        assert!(propeller_thrust_kt(-20.0, 0.0, 1000.0, 0.1) < 0.0);
        assert_eq!(propeller_thrust_kt(0.0, 1.0, 1000.0, 0.1), 0.0);
    }

    #[test]
    fn advance_speed_reduces_thrust() {
        let p = PropellerModel {
            water_density_kgpm3: 1000.0,
            diameter_m: 0.1,
            alpha1: 0.24,
            alpha2: -0.3,
            max_rps: 40.0,
        };
        let still = p.thrust_from_command_n(100.0, 0.0);
        let moving = p.thrust_from_command_n(100.0, 1.0);
        assert!(still > moving && moving > 0.0);
        assert_eq!(p.thrust_n(0.0, 1.0), 0.0);
    }
}
