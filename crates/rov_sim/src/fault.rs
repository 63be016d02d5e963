//! Faults the simulated vehicle can suffer (issue 23): the `--fault SPEC` grammar.
//!
//! `SPEC = KIND[:TARGET][:SIZE]@T_S`, for example
//!
//! | spec | meaning |
//! |---|---|
//! | `thrust-loss:port:0.4@300` | the port thruster gives 60 % of its thrust from t = 300 s |
//! | `buoyancy:3@200` | the vehicle is 3 N heavier from t = 200 s (negative: lighter) |
//! | `drag:2.5@100` | hydrodynamic drag ×2.5 from t = 100 s |
//! | `snag:15@250` | a 15 N pull towards the dive's start point from t = 250 s |
//! | `depth-sensor:stuck@120` | the depth sensor repeats its last value from t = 120 s |
//! | `depth-sensor:jump:0.5@120` | the depth sensor reads 0.5 m deeper from t = 120 s |
//! | `compass:25@90` | a 25° heading disturbance from t = 90 s |
//!
//! Parsing is pure (no clock, no I/O); an error says where in the spec it went wrong
//! and what was allowed. `T_S` is seconds of the simulator's (virtual) time.

use std::fmt;

use nalgebra::Vector3;
use rov_dynamics::current::CurrentRamp;
use rov_dynamics::kinematics::Attitude;
use rov_dynamics::models::ExternalForce;
use rov_dynamics::models::{ModelState, VehicleModel};
use rov_dynamics::sensors::SensorReadings;
use rov_dynamics::{Matrix6, ThrustPct, ThrusterForces, Vector6};
use rov_types::angle::{wrap_2pi, wrap_deg_360};

/// Where a snag's pull acts, body axes from CO, m: 0.2 m behind CO, where the tether
/// leaves the vehicle (the same point as the lab's tether effect).
pub const SNAG_ATTACH_BODY_M: [f64; 3] = [-0.2, 0.0, 0.0];

/// One of the Pro 4's three thrusters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(usize)]
pub enum Thruster {
    /// Port (left) horizontal thruster.
    Port = 0,
    /// Starboard (right) horizontal thruster.
    Starboard,
    /// Vertical thruster.
    Vertical,
}

impl Thruster {
    /// The name used in specs and cause ids (`port`, `starboard`, `vertical`).
    pub fn name(self) -> &'static str {
        match self {
            Thruster::Port => "port",
            Thruster::Starboard => "starboard",
            Thruster::Vertical => "vertical",
        }
    }
}

/// How the depth sensor fails.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DepthSensorFault {
    /// Repeats the last reading before the fault.
    Stuck,
    /// Reads this many metres too deep (negative: too shallow).
    Jump {
        /// Offset added to the reading, m.
        offset_m: f64,
    },
}

/// What goes wrong.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FaultKind {
    /// A thruster loses this fraction (0..=1) of its thrust.
    ThrustLoss {
        /// Which thruster.
        thruster: Thruster,
        /// Fraction of thrust lost, 0..=1.
        fraction: f64,
    },
    /// The vehicle becomes heavier by this net force (negative: lighter), N.
    Buoyancy {
        /// Added weight, N (positive = heavier).
        heavier_n: f64,
    },
    /// Hydrodynamic drag multiplied by this factor (> 0).
    Drag {
        /// Drag factor.
        factor: f64,
    },
    /// A horizontal pull towards the dive's start point, N.
    Snag {
        /// Pull, N.
        force_n: f64,
    },
    /// Depth sensor failure.
    DepthSensor(DepthSensorFault),
    /// Compass disturbance, degrees added to the heading reading.
    Compass {
        /// Disturbance, deg.
        offset_deg: f64,
    },
}

/// A fault and when it starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaultSpec {
    /// What goes wrong.
    pub kind: FaultKind,
    /// Virtual time from which it applies, s.
    pub start_s: f64,
}

/// Why a fault spec does not parse: the spec, the character offset of the bad part,
/// and what was expected there.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("fault spec `{spec}` at character {offset}: {detail}")]
pub struct FaultSpecError {
    /// The whole spec as given.
    pub spec: String,
    /// Character offset (0-based) of the part that is wrong.
    pub offset: usize,
    /// What is wrong and what is allowed.
    pub detail: String,
}

/// The fault kinds, as written in specs.
pub const FAULT_KINDS: [&str; 6] = [
    "thrust-loss",
    "buoyancy",
    "drag",
    "snag",
    "depth-sensor",
    "compass",
];

/// Default jump of `depth-sensor:jump` without a size, m.
pub const DEFAULT_DEPTH_JUMP_M: f64 = 1.0;

impl FaultSpec {
    /// Parses `KIND[:TARGET][:SIZE]@T_S`.
    pub fn parse(spec: &str) -> Result<Self, FaultSpecError> {
        let err = |offset: usize, detail: String| FaultSpecError {
            spec: spec.to_string(),
            offset,
            detail,
        };
        let Some(at) = spec.rfind('@') else {
            return Err(err(
                spec.chars().count(),
                "missing `@T_S` (the start time in seconds)".into(),
            ));
        };
        let body = &spec[..at];
        let time_text = &spec[at + 1..];
        let time_off = spec[..at + 1].chars().count();
        let start_s = parse_number(time_text)
            .filter(|t| *t >= 0.0)
            .ok_or_else(|| {
                err(
                    time_off,
                    format!("start time `{time_text}` is not a number of seconds ≥ 0"),
                )
            })?;
        // Split the body into fields with their character offsets.
        let mut fields: Vec<(usize, &str)> = Vec::new();
        let mut off = 0usize;
        for part in body.split(':') {
            fields.push((off, part));
            off += part.chars().count() + 1;
        }
        let (kind_off, kind_text) = fields.first().copied().unwrap_or((0, ""));
        let rest = fields.get(1..).unwrap_or(&[]);
        let size = |idx: usize, what: &str, ok: &dyn Fn(f64) -> bool, range: &str| {
            let (o, t) = rest.get(idx).copied().ok_or_else(|| {
                err(
                    time_off.saturating_sub(1),
                    format!("`{kind_text}` needs a size ({what}, {range})"),
                )
            })?;
            parse_number(t)
                .filter(|v| ok(*v))
                .ok_or_else(|| err(o, format!("{what} `{t}` is not a number in {range}")))
        };
        let too_many = |n: usize| -> Result<(), FaultSpecError> {
            match rest.get(n) {
                Some((o, t)) => Err(err(
                    *o,
                    format!("unexpected field `{t}` (`{kind_text}` takes {n} field(s))"),
                )),
                None => Ok(()),
            }
        };
        let kind = match kind_text {
            "thrust-loss" => {
                let (o, t) = rest.first().copied().ok_or_else(|| {
                    err(
                        time_off.saturating_sub(1),
                        "`thrust-loss` needs a thruster (port, starboard, vertical)".into(),
                    )
                })?;
                let thruster = match t {
                    "port" => Thruster::Port,
                    "starboard" => Thruster::Starboard,
                    "vertical" => Thruster::Vertical,
                    _ => {
                        return Err(err(
                            o,
                            format!("thruster `{t}` is not one of port, starboard, vertical"),
                        ));
                    }
                };
                let fraction = size(1, "fraction lost", &|v| (0.0..=1.0).contains(&v), "0..=1")?;
                too_many(2)?;
                FaultKind::ThrustLoss { thruster, fraction }
            }
            "buoyancy" => {
                let heavier_n = size(0, "added weight in N", &|v| v.abs() <= 200.0, "-200..=200")?;
                too_many(1)?;
                FaultKind::Buoyancy { heavier_n }
            }
            "drag" => {
                let factor = size(0, "drag factor", &|v| v > 0.0 && v <= 20.0, "(0, 20]")?;
                too_many(1)?;
                FaultKind::Drag { factor }
            }
            "snag" => {
                let force_n = size(0, "pull in N", &|v| (0.0..=500.0).contains(&v), "0..=500")?;
                too_many(1)?;
                FaultKind::Snag { force_n }
            }
            "depth-sensor" => {
                let (o, t) = rest.first().copied().ok_or_else(|| {
                    err(
                        time_off.saturating_sub(1),
                        "`depth-sensor` needs a mode (stuck, jump)".into(),
                    )
                })?;
                match t {
                    "stuck" => {
                        too_many(1)?;
                        FaultKind::DepthSensor(DepthSensorFault::Stuck)
                    }
                    "jump" => {
                        let offset_m = if rest.get(1).is_some() {
                            size(1, "jump in m", &|v| v.abs() <= 100.0, "-100..=100")?
                        } else {
                            DEFAULT_DEPTH_JUMP_M
                        };
                        too_many(2)?;
                        FaultKind::DepthSensor(DepthSensorFault::Jump { offset_m })
                    }
                    _ => {
                        return Err(err(
                            o,
                            format!("depth-sensor mode `{t}` is not one of stuck, jump"),
                        ));
                    }
                }
            }
            "compass" => {
                let offset_deg =
                    size(0, "disturbance in deg", &|v| v.abs() <= 180.0, "-180..=180")?;
                too_many(1)?;
                FaultKind::Compass { offset_deg }
            }
            _ => {
                return Err(err(
                    kind_off,
                    format!(
                        "fault kind `{kind_text}` is not one of {}",
                        FAULT_KINDS.join(", ")
                    ),
                ));
            }
        };
        Ok(FaultSpec { kind, start_s })
    }

    /// Whether the fault applies at virtual time `t_s`.
    pub fn active_at(&self, t_s: f64) -> bool {
        t_s >= self.start_s
    }
}

impl std::str::FromStr for FaultSpec {
    type Err = FaultSpecError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        FaultSpec::parse(s)
    }
}

impl fmt::Display for FaultSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.kind {
            FaultKind::ThrustLoss { thruster, fraction } => {
                write!(f, "thrust-loss:{}:{fraction}", thruster.name())?
            }
            FaultKind::Buoyancy { heavier_n } => write!(f, "buoyancy:{heavier_n}")?,
            FaultKind::Drag { factor } => write!(f, "drag:{factor}")?,
            FaultKind::Snag { force_n } => write!(f, "snag:{force_n}")?,
            FaultKind::DepthSensor(DepthSensorFault::Stuck) => write!(f, "depth-sensor:stuck")?,
            FaultKind::DepthSensor(DepthSensorFault::Jump { offset_m }) => {
                write!(f, "depth-sensor:jump:{offset_m}")?
            }
            FaultKind::Compass { offset_deg } => write!(f, "compass:{offset_deg}")?,
        }
        write!(f, "@{}", self.start_s)
    }
}

/// The force faults (`buoyancy`, `snag`) as an external force on the truth model, each
/// from its start time. Added weight acts at the origin CO (no moment: where it sits is
/// unknown). A snag pulls on the tether, which leaves the Pro 4 at its rear: it acts at
/// [`SNAG_ATTACH_BODY_M`], the point the lab's tether effect uses
/// (`rov_lab::model::TETHER_ATTACH_X_M`), so a pull across the vehicle also turns it.
#[derive(Debug, Clone, PartialEq)]
pub struct FaultForce {
    /// The faults (only `buoyancy` and `snag` act here; the others are ignored).
    pub faults: Vec<FaultSpec>,
    /// The dive's start point in NED (north, east), m: where a snag pulls towards.
    pub start_ne_m: [f64; 2],
}

impl FaultForce {
    /// The NED forces of the active force faults at `t_s` with the vehicle at `eta`, N:
    /// (added weight at CO, snag pull at [`SNAG_ATTACH_BODY_M`]).
    pub fn forces_ned_n(&self, t_s: f64, eta: &Vector6) -> (Vector3<f64>, Vector3<f64>) {
        let mut weight = Vector3::zeros();
        let mut snag = Vector3::zeros();
        for fault in self.faults.iter().filter(|f| f.active_at(t_s)) {
            match fault.kind {
                FaultKind::Buoyancy { heavier_n } => weight.z += heavier_n,
                FaultKind::Snag { force_n } => {
                    let dn = self.start_ne_m[0] - eta[0];
                    let de = self.start_ne_m[1] - eta[1];
                    let dist_m = dn.hypot(de);
                    if dist_m > 1e-6 {
                        snag.x += force_n * dn / dist_m;
                        snag.y += force_n * de / dist_m;
                    }
                }
                _ => {}
            }
        }
        (weight, snag)
    }

    /// The total NED force of the active force faults, N.
    pub fn force_ned_n(&self, t_s: f64, eta: &Vector6) -> Vector3<f64> {
        let (w, s) = self.forces_ned_n(t_s, eta);
        w + s
    }
}

impl ExternalForce for FaultForce {
    fn tau_body(&self, time_s: f64, eta: &Vector6, _nu: &Vector6) -> Vector6 {
        let (weight, snag) = self.forces_ned_n(time_s, eta);
        let body_from_ned = Attitude::from_eta(eta).ned_from_body().transpose();
        let f = body_from_ned * (weight + snag);
        let r = Vector3::from(SNAG_ATTACH_BODY_M);
        let m = r.cross(&(body_from_ned * snag));
        Vector6::new(f.x, f.y, f.z, m.x, m.y, m.z)
    }
}

/// The fault force τ_ext over one simulator step: the user's external force, the force
/// faults ([`FaultForce`]), the thrust lost by `thrust-loss` faults (constant over the
/// step, like the command) and the extra drag of a `drag` fault.
///
/// `drag:K` multiplies the model's hydrodynamic damping and Coriolis force of the motion
/// through the water by K: the extra force is (K−1)·M·(ν̇(ν) − ν̇(ν_c)) with τ = 0, where
/// ν_c is the body velocity of the water (zero relative velocity) and M is recovered from
/// the model's response to unit forces (so any model, also a lab-learned one, gets it).
#[derive(Debug)]
pub(crate) struct FaultTau<'a> {
    pub user: Option<&'a dyn ExternalForce>,
    pub force: &'a FaultForce,
    pub thrust_loss_tau: Vector6,
    /// (K − 1, M, the model and the current) of an active drag fault.
    pub drag: Option<DragExtra<'a>>,
}

/// What a drag fault needs to compute its force.
#[derive(Debug)]
pub(crate) struct DragExtra<'a> {
    pub extra_factor: f64,
    pub mass: Matrix6,
    pub model: &'a dyn VehicleModel,
    pub current: CurrentRamp,
}

impl DragExtra<'_> {
    fn tau(&self, time_s: f64, eta: &Vector6, nu: &Vector6) -> Vector6 {
        let current = self.current.at(time_s);
        let att = Attitude::from_eta(eta);
        let vc_body = att.ned_from_body().transpose() * current.vel_ned_mps;
        let mut nu_c = *nu;
        nu_c[0] = vc_body.x;
        nu_c[1] = vc_body.y;
        nu_c[2] = vc_body.z;
        for k in 3..6 {
            nu_c[k] = 0.0;
        }
        let zero = Vector6::zeros();
        let a = self
            .model
            .dynamics(&ModelState::new(*eta, *nu), &zero, &current)
            .nu;
        let a0 = self
            .model
            .dynamics(&ModelState::new(*eta, nu_c), &zero, &current)
            .nu;
        self.mass * (a - a0) * self.extra_factor
    }
}

/// The mass matrix M of `model` at `state` from its response to unit forces (the
/// pseudo-inverse of the columns of M⁻¹, so DOFs the model does not move get zero).
pub(crate) fn probe_mass(model: &dyn VehicleModel, state: &ModelState) -> Matrix6 {
    let still = CurrentRamp::default().at(0.0);
    let base = model.dynamics(state, &Vector6::zeros(), &still).nu;
    let mut m_inv = Matrix6::zeros();
    for j in 0..6 {
        let mut e = Vector6::zeros();
        e[j] = 1.0;
        let col = model.dynamics(state, &e, &still).nu - base;
        m_inv.set_column(j, &col);
    }
    m_inv
        .pseudo_inverse(1e-9)
        .unwrap_or_else(|_| Matrix6::zeros())
}

/// τ of the thrust lost by the active `thrust-loss` faults at `t_s` (the thrusters'
/// forces scaled by the fraction lost, through the model's allocation, which is linear).
pub(crate) fn thrust_loss_tau(
    faults: &[FaultSpec],
    t_s: f64,
    model: &dyn VehicleModel,
    cmd: &ThrustPct,
    state: &ModelState,
) -> Vector6 {
    let mut kept = [1.0f64; 3];
    for f in faults.iter().filter(|f| f.active_at(t_s)) {
        if let FaultKind::ThrustLoss { thruster, fraction } = f.kind {
            let i = thruster as usize;
            if let Some(k) = kept.get_mut(i) {
                *k *= 1.0 - fraction;
            }
        }
    }
    if kept.iter().all(|k| *k == 1.0) {
        return Vector6::zeros();
    }
    let forces = model.thruster_forces(cmd, state);
    let lost = ThrusterForces {
        port_n: forces.port_n * (1.0 - kept[0]),
        starboard_n: forces.starboard_n * (1.0 - kept[1]),
        vertical_n: forces.vertical_n * (1.0 - kept[2]),
    };
    -model.generalized_force(&lost, state)
}

/// The drag factor of the active `drag` faults at `t_s` (their product; 1 without one).
pub fn drag_factor(faults: &[FaultSpec], t_s: f64) -> f64 {
    faults
        .iter()
        .filter(|f| f.active_at(t_s))
        .filter_map(|f| match f.kind {
            FaultKind::Drag { factor } => Some(factor),
            _ => None,
        })
        .product()
}

impl ExternalForce for FaultTau<'_> {
    fn tau_body(&self, time_s: f64, eta: &Vector6, nu: &Vector6) -> Vector6 {
        let mut tau = self.force.tau_body(time_s, eta, nu) + self.thrust_loss_tau;
        if let Some(user) = self.user {
            tau += user.tau_body(time_s, eta, nu);
        }
        if let Some(d) = &self.drag {
            tau += d.tau(time_s, eta, nu);
        }
        tau
    }
}

/// What the sensor faults remember between samples (the reading a stuck sensor repeats).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SensorFaultState {
    /// Depth from pressure, absolute pressure (SI) and the Pro 4 pressure field held by a
    /// stuck depth sensor.
    held_depth: Option<(f64, f64, i16)>,
}

/// Applies the active sensor faults (`depth-sensor`, `compass`) at the readings' time to
/// `readings`, which the sensors have just produced. `mbar_per_m` converts a depth jump
/// into pressure (ρ g / 100 of the sensor settings). The compass disturbance is added to
/// the heading output (SI and the Pro 4 field); the raw magnetometer is left as measured
/// (a choice: the Pro 4's heading is what the station reads).
pub fn apply_sensor_faults(
    faults: &[FaultSpec],
    state: &mut SensorFaultState,
    readings: &mut SensorReadings,
    mbar_per_m: f64,
) {
    let t_s = readings.time_s;
    for fault in faults.iter().filter(|f| f.active_at(t_s)) {
        match fault.kind {
            FaultKind::DepthSensor(DepthSensorFault::Stuck) => {
                let held = *state.held_depth.get_or_insert((
                    readings.depth_from_pressure_m,
                    readings.pressure_mbar,
                    readings.pro4.pressure_mbar,
                ));
                readings.depth_from_pressure_m = held.0;
                readings.pressure_mbar = held.1;
                readings.pro4.pressure_mbar = held.2;
            }
            FaultKind::DepthSensor(DepthSensorFault::Jump { offset_m }) => {
                readings.depth_from_pressure_m += offset_m;
                readings.pressure_mbar += offset_m * mbar_per_m;
                readings.pro4.pressure_mbar = readings
                    .pressure_mbar
                    .round()
                    .clamp(f64::from(i16::MIN), f64::from(i16::MAX))
                    as i16;
            }
            FaultKind::Compass { offset_deg } => {
                readings.heading_rad = wrap_2pi(readings.heading_rad + offset_deg.to_radians());
                let deci = (wrap_deg_360(readings.heading_rad.to_degrees()) * 10.0).round();
                readings.pro4.heading_deci_deg = (deci as i16).rem_euclid(3600);
            }
            _ => {}
        }
    }
}

/// A finite number, or `None`.
fn parse_number(text: &str) -> Option<f64> {
    text.trim().parse::<f64>().ok().filter(|v| v.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_issue_examples() {
        let cases = [
            (
                "thrust-loss:port:0.4@300",
                FaultKind::ThrustLoss {
                    thruster: Thruster::Port,
                    fraction: 0.4,
                },
                300.0,
            ),
            (
                "buoyancy:3@200",
                FaultKind::Buoyancy { heavier_n: 3.0 },
                200.0,
            ),
            ("drag:2.5@100", FaultKind::Drag { factor: 2.5 }, 100.0),
            ("snag:15@250", FaultKind::Snag { force_n: 15.0 }, 250.0),
            (
                "depth-sensor:stuck@120",
                FaultKind::DepthSensor(DepthSensorFault::Stuck),
                120.0,
            ),
            (
                "compass:25@90",
                FaultKind::Compass { offset_deg: 25.0 },
                90.0,
            ),
        ];
        for (spec, kind, start_s) in cases {
            let f = FaultSpec::parse(spec).unwrap();
            assert_eq!(f, FaultSpec { kind, start_s }, "{spec}");
            // Display reads back to the same fault.
            assert_eq!(FaultSpec::parse(&f.to_string()).unwrap(), f);
        }
    }

    #[test]
    fn depth_jump_has_a_default_and_a_size() {
        assert_eq!(
            FaultSpec::parse("depth-sensor:jump@5").unwrap().kind,
            FaultKind::DepthSensor(DepthSensorFault::Jump {
                offset_m: DEFAULT_DEPTH_JUMP_M
            })
        );
        assert_eq!(
            FaultSpec::parse("depth-sensor:jump:-0.5@5").unwrap().kind,
            FaultKind::DepthSensor(DepthSensorFault::Jump { offset_m: -0.5 })
        );
    }

    #[test]
    fn errors_are_located() {
        let e = FaultSpec::parse("thrust-loss:port:0.4").unwrap_err();
        assert!(e.detail.contains("@T_S"), "{e}");
        assert_eq!(e.offset, 20);
        let e = FaultSpec::parse("thrust-loss:aft:0.4@3").unwrap_err();
        assert_eq!(e.offset, 12, "{e}");
        assert!(e.detail.contains("port, starboard, vertical"));
        let e = FaultSpec::parse("thrust-loss:port:1.5@3").unwrap_err();
        assert_eq!(e.offset, 17, "{e}");
        assert!(e.detail.contains("0..=1"));
        let e = FaultSpec::parse("wobble:3@3").unwrap_err();
        assert_eq!(e.offset, 0);
        assert!(e.detail.contains("compass"));
        let e = FaultSpec::parse("drag:2@soon").unwrap_err();
        assert_eq!(e.offset, 7);
        let e = FaultSpec::parse("drag:2:3@1").unwrap_err();
        assert_eq!(e.offset, 7, "{e}");
        let e = FaultSpec::parse("buoyancy@1").unwrap_err();
        assert!(e.detail.contains("needs a size"), "{e}");
        let e = FaultSpec::parse("drag:NaN@1").unwrap_err();
        assert_eq!(e.offset, 5);
        let e = FaultSpec::parse("compass:10@-1").unwrap_err();
        assert_eq!(e.offset, 11);
        // The message names the spec.
        assert!(e.to_string().contains("compass:10@-1"));
    }

    #[test]
    fn bad_input_never_panics() {
        for s in [
            "",
            "@",
            ":",
            "::@",
            "@@",
            "é:é@é",
            "thrust-loss@1",
            "depth-sensor:@1",
        ] {
            assert!(FaultSpec::parse(s).is_err(), "{s}");
        }
    }

    #[test]
    fn active_from_its_start() {
        let f = FaultSpec::parse("drag:2@10").unwrap();
        assert!(!f.active_at(9.99));
        assert!(f.active_at(10.0));
    }
    #[test]
    fn buoyancy_pushes_down_and_snag_pulls_home() {
        let ff = FaultForce {
            faults: vec![
                FaultSpec::parse("buoyancy:3@10").unwrap(),
                FaultSpec::parse("snag:15@20").unwrap(),
            ],
            start_ne_m: [0.0, 0.0],
        };
        // Vehicle 3 m north, 4 m east, heading east (yaw 90°).
        let eta = Vector6::new(3.0, 4.0, 5.0, 0.0, 0.0, std::f64::consts::FRAC_PI_2);
        assert_eq!(ff.tau_body(5.0, &eta, &Vector6::zeros()), Vector6::zeros());
        let t = ff.tau_body(15.0, &eta, &Vector6::zeros());
        assert!((t[2] - 3.0).abs() < 1e-12 && t[0].abs() < 1e-12, "{t:?}");
        let f = ff.force_ned_n(25.0, &eta);
        assert!(
            (f.x + 9.0).abs() < 1e-12 && (f.y + 12.0).abs() < 1e-12,
            "{f:?}"
        );
        // In body axes (facing east) the pull home is mostly backwards and to port.
        let t = ff.tau_body(25.0, &eta, &Vector6::zeros());
        assert!(
            (t[0] + 12.0).abs() < 1e-9 && (t[1] - 9.0).abs() < 1e-9,
            "{t:?}"
        );
        // At the start point a snag has no direction and gives no force.
        let home = Vector6::new(0.0, 0.0, 5.0, 0.0, 0.0, 0.0);
        assert!((ff.force_ned_n(25.0, &home).x).abs() < 1e-12);
    }
    #[test]
    fn depth_sensor_sticks_or_jumps_and_compass_turns() {
        let mut r = SensorReadings {
            time_s: 0.0,
            accel_body_mps2: Vector3::zeros(),
            gyro_body_radps: Vector3::zeros(),
            mag_body_ut: Vector3::zeros(),
            dvl_mps: Vector3::zeros(),
            transponder_ned_m: Vector3::zeros(),
            pressure_mbar: 1113.25,
            depth_from_pressure_m: 1.0,
            heading_rad: 350f64.to_radians(),
            pitch_rad: 0.0,
            roll_rad: 0.0,
            pro4: Default::default(),
        };
        let stuck = [FaultSpec::parse("depth-sensor:stuck@1").unwrap()];
        let mut st = SensorFaultState::default();
        let mut a = r;
        apply_sensor_faults(&stuck, &mut st, &mut a, 98.1);
        assert_eq!(a, r, "not active before its start");
        r.time_s = 1.0;
        let mut a = r;
        apply_sensor_faults(&stuck, &mut st, &mut a, 98.1);
        r.time_s = 2.0;
        r.depth_from_pressure_m = 3.0;
        r.pressure_mbar = 1307.55;
        let mut b = r;
        apply_sensor_faults(&stuck, &mut st, &mut b, 98.1);
        assert_eq!(b.depth_from_pressure_m, 1.0, "stuck at the onset value");
        assert_eq!(b.pressure_mbar, 1113.25);

        let jump = [FaultSpec::parse("depth-sensor:jump:0.5@0").unwrap()];
        let mut c = r;
        apply_sensor_faults(&jump, &mut SensorFaultState::default(), &mut c, 98.1);
        assert!((c.depth_from_pressure_m - 3.5).abs() < 1e-12);
        assert!((c.pressure_mbar - (1307.55 + 49.05)).abs() < 1e-9);
        assert_eq!(c.pro4.pressure_mbar, 1357);

        let compass = [FaultSpec::parse("compass:25@0").unwrap()];
        let mut d = r;
        apply_sensor_faults(&compass, &mut SensorFaultState::default(), &mut d, 98.1);
        assert!(
            (d.heading_rad.to_degrees() - 15.0).abs() < 1e-9,
            "wraps past north"
        );
        assert_eq!(d.pro4.heading_deci_deg, 150);
    }
}
