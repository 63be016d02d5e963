//! Named scalar parameters of a lab model: the base parameters that calibration frees,
//! the contained-effect parameters that a refit frees, and every catalog effect's own
//! parameters. Each has a key (used in JSON and in saved models), a unit, bounds, the
//! value that turns its effect off, and a typical magnitude used to probe sensitivities.

use rov_dynamics::models::Channel;
use serde::Serialize;

use crate::catalog::EffectId;

/// A thruster group (the Pro 4's port, starboard and vertical thrusters, or a vehicle
/// file's groups): the unit of thrust calibration and of per-thruster effects.
pub use rov_dynamics::models::vehicle::ThrusterGroup as Thr;

/// A body degree of freedom (Fossen order).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Axis {
    /// u.
    Surge,
    /// v.
    Sway,
    /// w.
    Heave,
    /// p.
    Roll,
    /// q.
    Pitch,
    /// r.
    Yaw,
}

impl Axis {
    /// All six, in Fossen order.
    pub const ALL: [Axis; 6] = [
        Axis::Surge,
        Axis::Sway,
        Axis::Heave,
        Axis::Roll,
        Axis::Pitch,
        Axis::Yaw,
    ];

    /// Index 0..6.
    pub fn index(self) -> usize {
        self as usize
    }

    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Axis::Surge => "surge",
            Axis::Sway => "sway",
            Axis::Heave => "heave",
            Axis::Roll => "roll",
            Axis::Pitch => "pitch",
            Axis::Yaw => "yaw",
        }
    }

    fn rotational(self) -> bool {
        matches!(self, Axis::Roll | Axis::Pitch | Axis::Yaw)
    }
}

/// A scalar parameter of a lab model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Param {
    /// Scale of a thruster's linear thrust coefficient (calibration).
    ThrustLin(Thr),
    /// Scale of a thruster's quadratic thrust coefficient (calibration).
    ThrustQuad(Thr),
    /// Linear damping coefficient, positive (calibration).
    DragLin(Axis),
    /// Quadratic damping coefficient, positive (calibration).
    DragQuad(Axis),
    /// model3: CG below the CO, m (restoring stiffness; calibration).
    CgZ,
    /// W − B, N (model1: effect term; model2/3: contained, refit).
    NetWeight,
    /// model3: CG forward of the CO, m (contained restoring offset).
    CgX,
    /// model3: CG to starboard of the CO, m (contained restoring offset).
    CgY,
    /// Added mass / inertia on an axis (contained), kg or kg m².
    AddedMass(Axis),
    /// Reverse/forward thrust ratio of a thruster.
    ReverseRatio(Thr),
    /// Thruster lag time constant, s.
    LagTau,
    /// Dead zone as a fraction of full command.
    Deadzone,
    /// Power budget in units of Σ|u|³ (3 = never limits).
    PowerMax,
    /// Horizontal thrusters' line of action below the CO, m.
    ArmZh,
    /// Vertical thruster forward of the CO, m.
    ArmXv,
    /// Vertical thruster to starboard of the CO, m.
    ArmYv,
    /// A vehicle file's non-vertical thrusters shifted forward, m (their resultant's line
    /// of action: sway thrust then turns the vehicle).
    ArmXh,
    /// A vehicle file's non-vertical thrusters shifted to starboard, m (surge thrust then
    /// turns the vehicle).
    ArmYh,
    /// Vertical propeller reaction torque per newton of thrust, m.
    TorqueV,
    /// Horizontal propellers' reaction roll torque per newton of differential thrust, m.
    TorqueH,
    /// Trim angle for the depth kinematics of models without pitch, deg.
    TrimDeg,
    /// Reverse/forward quadratic drag ratio on an axis.
    DragRatio(Axis),
    /// Current towards north, m/s.
    CurrentN,
    /// Current towards east, m/s.
    CurrentE,
    /// Tether pull towards north, N.
    TetherN,
    /// Tether pull towards east, N.
    TetherE,
    /// Depth reading drift, m/s.
    DepthDrift,
    /// Compass deviation a (· sin ψ), deg.
    CompassSin,
    /// Compass deviation b (· cos ψ), deg.
    CompassCos,
    /// Compass interference per unit |u| of a thruster, deg.
    Emi(Thr),
    /// Roll reading offset, deg.
    BiasRoll,
    /// Pitch reading offset, deg.
    BiasPitch,
    /// Gain on every command channel before a vehicle file's mixer (a pilot gain
    /// setting; calibrated when the file documents its uncertainty).
    CommandGain,
    /// Coefficient of discovered term i, normalised: N (or N m, `true` = rotational DOF)
    /// at the term's typical regressor size (see [`crate::terms::Term`]).
    TermCoef(u8, bool),
}

/// Static facts about a parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamMeta {
    /// Lower bound.
    pub lo: f64,
    /// Upper bound.
    pub hi: f64,
    /// Typical magnitude of a change (finite differences, probing, scaling).
    pub scale: f64,
    /// Unit.
    pub unit: &'static str,
}

impl Param {
    /// Key used in JSON and saved models.
    pub fn key(self) -> String {
        match self {
            Param::ThrustLin(t) => format!("thrust_linear_scale_{}", t.name()),
            Param::ThrustQuad(t) => format!("thrust_quadratic_scale_{}", t.name()),
            Param::DragLin(a) => format!("drag_linear_{}", a.name()),
            Param::DragQuad(a) => format!("drag_quadratic_{}", a.name()),
            Param::CgZ => "cg_z_m".into(),
            Param::NetWeight => "net_weight_n".into(),
            Param::CgX => "cg_x_m".into(),
            Param::CgY => "cg_y_m".into(),
            Param::AddedMass(a) => format!("added_mass_{}", a.name()),
            Param::ReverseRatio(t) => format!("reverse_ratio_{}", t.name()),
            Param::LagTau => "lag_time_constant_s".into(),
            Param::Deadzone => "deadzone_fraction".into(),
            Param::PowerMax => "power_max".into(),
            Param::ArmZh => "horizontal_arm_z_m".into(),
            Param::ArmXv => "vertical_arm_x_m".into(),
            Param::ArmYv => "vertical_arm_y_m".into(),
            Param::ArmXh => "horizontal_arm_x_m".into(),
            Param::ArmYh => "horizontal_arm_y_m".into(),
            Param::TorqueV => "torque_vertical_m".into(),
            Param::TorqueH => "torque_horizontal_m".into(),
            Param::TrimDeg => "trim_deg".into(),
            Param::DragRatio(a) => format!("drag_ratio_{}", a.name()),
            Param::CurrentN => "current_north_mps".into(),
            Param::CurrentE => "current_east_mps".into(),
            Param::TetherN => "tether_north_n".into(),
            Param::TetherE => "tether_east_n".into(),
            Param::DepthDrift => "depth_drift_mps".into(),
            Param::CompassSin => "compass_sin_deg".into(),
            Param::CompassCos => "compass_cos_deg".into(),
            Param::Emi(t) => format!("compass_interference_{}_deg", t.name()),
            Param::BiasRoll => "roll_bias_deg".into(),
            Param::BiasPitch => "pitch_bias_deg".into(),
            Param::CommandGain => "command_gain".into(),
            Param::TermCoef(i, _) => format!("term_{i}_coefficient"),
        }
    }

    /// Every parameter (for parsing keys).
    pub fn all() -> Vec<Param> {
        let mut v = Vec::new();
        for t in Thr::ALL {
            v.push(Param::ThrustLin(t));
            v.push(Param::ThrustQuad(t));
            v.push(Param::ReverseRatio(t));
            v.push(Param::Emi(t));
        }
        for a in [
            Axis::Surge,
            Axis::Sway,
            Axis::Heave,
            Axis::Roll,
            Axis::Pitch,
            Axis::Yaw,
        ] {
            v.push(Param::DragLin(a));
            v.push(Param::DragQuad(a));
            v.push(Param::AddedMass(a));
            v.push(Param::DragRatio(a));
        }
        v.extend([
            Param::CgZ,
            Param::NetWeight,
            Param::CgX,
            Param::CgY,
            Param::LagTau,
            Param::Deadzone,
            Param::PowerMax,
            Param::ArmZh,
            Param::ArmXv,
            Param::ArmYv,
            Param::ArmXh,
            Param::ArmYh,
            Param::TorqueV,
            Param::TorqueH,
            Param::TrimDeg,
            Param::CurrentN,
            Param::CurrentE,
            Param::TetherN,
            Param::TetherE,
            Param::DepthDrift,
            Param::CompassSin,
            Param::CompassCos,
            Param::BiasRoll,
            Param::BiasPitch,
            Param::CommandGain,
        ]);
        v
    }

    /// Parses a key.
    pub fn from_key(key: &str) -> Option<Param> {
        Self::all().into_iter().find(|p| p.key() == key)
    }

    /// Bounds, scale and unit.
    pub fn meta(self) -> ParamMeta {
        let m = |lo: f64, hi: f64, scale: f64, unit: &'static str| ParamMeta {
            lo,
            hi,
            scale,
            unit,
        };
        match self {
            Param::ThrustLin(_) => m(0.0, 6.0, 0.1, "-"),
            Param::ThrustQuad(_) => m(0.1, 6.0, 0.05, "-"),
            Param::DragLin(a) if a.rotational() => m(0.0, 5.0, 0.01, "N m s"),
            Param::DragLin(_) => m(0.0, 200.0, 0.5, "N s/m"),
            Param::DragQuad(a) if a.rotational() => m(0.0, 20.0, 0.05, "N m s^2"),
            Param::DragQuad(_) => m(0.0, 400.0, 2.0, "N s^2/m^2"),
            Param::CgZ => m(0.0005, 0.05, 0.0005, "m"),
            Param::NetWeight => m(-6.0, 6.0, 0.2, "N"),
            Param::CgX | Param::CgY => m(-0.03, 0.03, 0.001, "m"),
            Param::AddedMass(a) if a.rotational() => m(0.0, 1.0, 0.005, "kg m^2"),
            Param::AddedMass(_) => m(0.0, 40.0, 0.5, "kg"),
            Param::ReverseRatio(_) => m(0.2, 1.6, 0.05, "-"),
            Param::LagTau => m(0.0, 2.0, 0.05, "s"),
            Param::Deadzone => m(0.0, 0.45, 0.03, "-"),
            Param::PowerMax => m(0.03, 3.0, 0.05, "-"),
            Param::ArmZh | Param::ArmXv | Param::ArmYv | Param::ArmXh | Param::ArmYh => {
                m(-0.1, 0.1, 0.005, "m")
            }
            Param::TorqueV | Param::TorqueH => m(-0.05, 0.05, 0.001, "m"),
            Param::TrimDeg => m(-20.0, 20.0, 1.0, "deg"),
            Param::DragRatio(_) => m(0.4, 2.5, 0.1, "-"),
            Param::CurrentN | Param::CurrentE => m(-1.0, 1.0, 0.03, "m/s"),
            Param::TetherN | Param::TetherE => m(-10.0, 10.0, 0.3, "N"),
            Param::DepthDrift => m(-0.01, 0.01, 2e-4, "m/s"),
            Param::CompassSin | Param::CompassCos => m(-30.0, 30.0, 1.0, "deg"),
            Param::Emi(_) => m(-30.0, 30.0, 1.0, "deg"),
            Param::BiasRoll | Param::BiasPitch => m(-15.0, 15.0, 0.3, "deg"),
            // The vehicle file's own range for `[commands] gain`.
            Param::CommandGain => m(0.01, 10.0, 0.02, "-"),
            Param::TermCoef(_, false) => m(-200.0, 200.0, 0.05, "N"),
            Param::TermCoef(_, true) => m(-20.0, 20.0, 0.005, "N m"),
        }
    }

    /// Whether a bound is a physical limit rather than a plausibility limit (`upper`
    /// selects the bound). A fit may legitimately end at a physical limit — a lag of 0 s,
    /// no dead zone, a power budget that never binds, a thrust line at the edge of the
    /// hull — but a fit pinned at a plausibility limit (a 60 cm/min depth drift, a
    /// reverse thrust ratio of 0.2) stands in for some other effect.
    pub fn bound_is_physical(self, upper: bool) -> bool {
        match self {
            Param::LagTau | Param::Deadzone => !upper,
            Param::PowerMax => upper,
            // ±0.1 m is about half the hull (0.375 × 0.289 × 0.223 m): a thrust line
            // cannot lie outside the vehicle.
            Param::ArmZh | Param::ArmXv | Param::ArmYv | Param::ArmXh | Param::ArmYh => true,
            Param::ThrustLin(_) | Param::DragLin(_) | Param::DragQuad(_) => !upper,
            Param::AddedMass(_) => !upper,
            _ => false,
        }
    }

    /// The value at which an effect parameter has no effect (`None` for base
    /// parameters, whose value comes from the model).
    pub fn off_value(self) -> Option<f64> {
        match self {
            Param::ReverseRatio(_) | Param::DragRatio(_) => Some(1.0),
            Param::PowerMax => Some(3.0),
            Param::ThrustLin(_)
            | Param::ThrustQuad(_)
            | Param::DragLin(_)
            | Param::DragQuad(_)
            | Param::CgZ
            | Param::AddedMass(_)
            | Param::CommandGain => None,
            Param::NetWeight | Param::CgX | Param::CgY => None,
            _ => Some(0.0),
        }
    }

    /// A typical non-trivial value used to probe an effect's signature.
    pub fn probe_value(self) -> f64 {
        match self {
            Param::ReverseRatio(_) => 0.8,
            Param::LagTau => 0.15,
            Param::Deadzone => 0.15,
            Param::PowerMax => 0.5,
            Param::ArmZh | Param::ArmXv | Param::ArmYv | Param::ArmXh | Param::ArmYh => 0.01,
            Param::TorqueV | Param::TorqueH => 0.002,
            Param::NetWeight => 0.5,
            Param::CgX | Param::CgY => 0.002,
            Param::TrimDeg => 3.0,
            Param::DragRatio(_) => 1.3,
            Param::CurrentN | Param::CurrentE => 0.1,
            Param::TetherN | Param::TetherE => 1.0,
            Param::DepthDrift => 5e-4,
            Param::CompassSin | Param::CompassCos => 3.0,
            Param::Emi(_) => 5.0,
            Param::BiasRoll | Param::BiasPitch => 1.0,
            Param::TermCoef(_, r) => {
                if r {
                    0.05
                } else {
                    0.5
                }
            }
            _ => self.meta().scale,
        }
    }

    /// The channels where this effect parameter's own signature lives (`None` for base
    /// parameters and parameters that act on every thruster axis).
    pub fn home_channels(self) -> Option<&'static [Channel]> {
        use Channel::*;
        Some(match self {
            Param::ReverseRatio(Thr::Vertical) | Param::DragRatio(Axis::Heave) => &[Depth, Heave],
            Param::ReverseRatio(_) => &[Heading, YawRate, Surge],
            Param::TorqueV
            | Param::DragRatio(Axis::Yaw)
            | Param::CompassSin
            | Param::CompassCos
            | Param::ArmXh
            | Param::ArmYh
            | Param::Emi(_) => &[Heading, YawRate],
            Param::TorqueH | Param::ArmYv | Param::CgY | Param::BiasRoll => &[Roll, RollRate],
            Param::ArmZh | Param::ArmXv | Param::CgX | Param::BiasPitch => &[Pitch, PitchRate],
            _ => return None,
        })
    }

    /// Extra starting values tried for a parameter whose cost has kinks (a budget that
    /// binds only above some demand, a dead zone, a lag): one start per value.
    pub fn start_spread(self) -> &'static [f64] {
        match self {
            Param::PowerMax => &[0.3, 0.6, 1.0, 1.5],
            Param::Deadzone => &[0.05, 0.12, 0.2],
            Param::LagTau => &[0.1, 0.3],
            _ => &[],
        }
    }

    /// Value shown to people (unit conversions for readability) and its unit.
    pub fn display(self, value: f64) -> (f64, &'static str) {
        match self {
            Param::DepthDrift => (value * 6000.0, "cm/min"),
            Param::ArmZh
            | Param::ArmXv
            | Param::ArmYv
            | Param::ArmXh
            | Param::ArmYh
            | Param::TorqueV
            | Param::TorqueH
            | Param::CgX
            | Param::CgY
            | Param::CgZ => (value * 1000.0, "mm"),
            Param::Deadzone => (value * 100.0, "%"),
            _ => (value, self.meta().unit),
        }
    }
}

/// How well a Pro 4 base parameter is known (parameters.md), for calibration priors and
/// the verdict's parameter uncertainty: `Rel(σ/|value|)` or `Abs(σ)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Documented {
    /// Relative standard deviation.
    Rel(f64),
    /// Absolute standard deviation (parameter units).
    Abs(f64),
}

/// The documented uncertainty of a Pro 4 base parameter (`None` for effect parameters,
/// which have no prior: "off" is a hypothesis, not a belief).
///
/// | parameter | σ | basis (shared/reference/parameters.md) |
/// |---|---|---|
/// | thrust scales | 30 % | §1: full thrust "~17 N (range 15–20)" horizontal, "~10 N (8–12)" vertical; the 10 % linear share is an estimate |
/// | damping | 50 % | §1.1–4: Pro III coefficients scaled by a frontal-area ratio, estimates |
/// | added mass | 50 % | §3–4: fractions of the displaced mass for a box-like body, estimates |
/// | CG height | 30 % | §4: 5.59 mm from CAD; ballast trim moves it |
/// | CG x, y | 3 mm | §1: ballast trims the vehicle near level |
/// | W − B | 0.5 N | §3: B between 59.8 and 60.3 N for W = 59.8 N |
pub fn documented_pro4(p: Param) -> Option<Documented> {
    Some(match p {
        Param::ThrustLin(_) | Param::ThrustQuad(_) => Documented::Rel(0.3),
        Param::DragLin(_) | Param::DragQuad(_) => Documented::Rel(0.5),
        Param::AddedMass(_) => Documented::Rel(0.5),
        Param::CgZ => Documented::Rel(0.3),
        Param::CgX | Param::CgY => Documented::Abs(0.003),
        Param::NetWeight => Documented::Abs(0.5),
        _ => return None,
    })
}

/// The parameters an effect adds (or, for a contained effect, refits). The list is the
/// full set; [`crate::diagnose`] drops those the data cannot excite.
pub fn effect_params(effect: EffectId) -> Vec<Param> {
    match effect {
        EffectId::ThrustAsymmetry => Thr::ALL.iter().map(|t| Param::ReverseRatio(*t)).collect(),
        EffectId::ThrusterLag => vec![Param::LagTau],
        EffectId::ThrusterDeadzone => vec![Param::Deadzone],
        EffectId::PowerLimit => vec![Param::PowerMax],
        EffectId::ThrusterMomentArm => vec![Param::ArmZh, Param::ArmXv, Param::ArmYv],
        EffectId::PropellerTorque => vec![Param::TorqueV, Param::TorqueH],
        EffectId::NetBuoyancy => vec![Param::NetWeight],
        EffectId::RestoringOffset => vec![Param::CgX, Param::CgY],
        EffectId::PitchDepthCoupling => vec![Param::TrimDeg],
        EffectId::Coriolis => vec![],
        EffectId::AddedMass => vec![Param::AddedMass(Axis::Heave), Param::AddedMass(Axis::Yaw)],
        EffectId::DragForm => vec![Param::DragRatio(Axis::Heave), Param::DragRatio(Axis::Yaw)],
        EffectId::Current => vec![Param::CurrentN, Param::CurrentE],
        EffectId::Tether => vec![Param::TetherN, Param::TetherE],
        EffectId::DepthSensorDrift => vec![Param::DepthDrift],
        EffectId::CompassDeviation => {
            let mut v = vec![Param::CompassSin, Param::CompassCos];
            v.extend(Thr::ALL.iter().map(|t| Param::Emi(*t)));
            v
        }
        EffectId::AttitudeBias => vec![Param::BiasRoll, Param::BiasPitch],
    }
}

/// Base parameters acting on the axes of some channels.
pub fn axis_params_of(chans: &[Channel]) -> Vec<Param> {
    let mut v = Vec::new();
    for ch in chans {
        let ps: &[Param] = match ch {
            Channel::Depth | Channel::Heave => &[
                Param::ThrustLin(Thr::Vertical),
                Param::ThrustQuad(Thr::Vertical),
                Param::DragLin(Axis::Heave),
                Param::DragQuad(Axis::Heave),
            ],
            Channel::Heading | Channel::YawRate => &[
                Param::ThrustLin(Thr::Port),
                Param::ThrustQuad(Thr::Port),
                Param::ThrustLin(Thr::Starboard),
                Param::ThrustQuad(Thr::Starboard),
                Param::DragLin(Axis::Yaw),
                Param::DragQuad(Axis::Yaw),
            ],
            Channel::Pitch | Channel::PitchRate => &[Param::DragLin(Axis::Pitch), Param::CgZ],
            Channel::Roll | Channel::RollRate => &[Param::DragLin(Axis::Roll), Param::CgZ],
            _ => &[],
        };
        for p in ps {
            if !v.contains(p) {
                v.push(*p);
            }
        }
    }
    v
}
