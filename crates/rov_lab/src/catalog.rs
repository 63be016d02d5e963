//! The catalog of candidate effects (modellab.md §3): 17 fixed IDs, each with its physical
//! term, parameters, signature, what data it needs, and which base models already
//! contain it.
//!
//! # Containment (decided here, shown by `topside lab models`)
//!
//! | effect | model1 | model2 | model3 |
//! |---|---|---|---|
//! | `added-mass` | contained (α, β inertia factors) | contained (X_u̇, Z_ẇ, N_ṙ) | contained (M_A) |
//! | `net-buoyancy` | — | contained (W, B) | contained (W, B) |
//! | `coriolis` | not applicable (no sway/roll/pitch) | contained (C(ν), inert without v, p, q) | contained (C_RB, C_A) |
//! | `restoring-offset` | not applicable (no roll/pitch) | not applicable | contained (r_g in g(η)) |
//! | `pitch-depth-coupling` | — | — | contained (6-DOF kinematics; the trim comes from `restoring-offset`) |
//!
//! A contained effect is never *added*: diagnosing it means *refitting* the base
//! parameters that carry it (W − B, the CG offsets, the added masses), reported with
//! `contained: true`. Added masses are kept fixed during calibration because thrust gain,
//! damping and inertia are determined only up to a common scale by motion data.

use rov_dynamics::models::Channel;
use serde::Serialize;

/// The 17 effect IDs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
pub enum EffectId {
    /// A1: reverse thrust differs from forward thrust (per thruster).
    ThrustAsymmetry,
    /// A2: first-order thruster lag.
    ThrusterLag,
    /// A3: dead zone around zero command.
    ThrusterDeadzone,
    /// A4: shared power limit (combined thrusters underperform).
    PowerLimit,
    /// A5: thruster lines of action off the CO (pitch/roll moments).
    ThrusterMomentArm,
    /// A6: propeller reaction torque.
    PropellerTorque,
    /// H1: weight differs from buoyancy.
    NetBuoyancy,
    /// H2: CG/CB offsets (trim).
    RestoringOffset,
    /// H3: depth rate picks up surge through the trim angle.
    PitchDepthCoupling,
    /// H4: Coriolis/centripetal coupling.
    Coriolis,
    /// H5: added mass.
    AddedMass,
    /// H6: direction-asymmetric drag.
    DragForm,
    /// H7: constant ocean current.
    Current,
    /// H8: tether pull.
    Tether,
    /// M1: depth sensor drift.
    DepthSensorDrift,
    /// M2: compass deviation and thruster interference.
    CompassDeviation,
    /// M3: attitude sensor mounting bias.
    AttitudeBias,
}

/// Where an effect acts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EffectGroup {
    /// Thrusters.
    Actuator,
    /// Rigid body, hydrodynamics, environment.
    BodyEnvironment,
    /// Sensors (output equation).
    Sensor,
}

/// Static description of one catalog entry.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct EffectInfo {
    /// The effect.
    #[serde(skip)]
    pub id: EffectId,
    /// Fixed ID string, e.g. `thrust-asymmetry`.
    pub key: &'static str,
    /// modellab.md code (A1 … M3).
    pub code: &'static str,
    /// Group.
    pub group: EffectGroup,
    /// The physical term.
    pub term: &'static str,
    /// What the residual looks like.
    pub signature: &'static str,
    /// What the data must contain.
    pub needs: &'static str,
    /// The channels where its signature lives first (its "home": where it must show to
    /// count as found, and which keep their noise weights in its fits).
    #[serde(skip)]
    pub home: &'static [Channel],
    /// The error view its parameters are fitted in (every effect is judged on both).
    #[serde(skip)]
    pub fit_view: FitView,
    /// The held-out view(s) whose gain makes it found.
    #[serde(skip)]
    pub judged_in: JudgedIn,
}

/// The held-out view(s) an effect must improve to be found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum JudgedIn {
    /// Both multiple shooting and free run: every dynamic effect (a gain in one view only
    /// is that view's artefact).
    BothViews,
    /// The free run alone (open-loop data): an effect whose signature only shows when
    /// the model is not re-anchored to the measurement (a slow sensor drift, which every
    /// re-initialised window removes).
    FreeRun,
}

/// The error view an effect is fitted in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FitView {
    /// Multiple shooting (re-initialised windows): every dynamic effect.
    Shooting,
    /// Free run: slow sensor drift, which re-initialisation would remove.
    FreeRun,
}

/// Home channels of the thruster effects: the axes the thrusters drive (surge when
/// measured: a weak reverse thrust surges the vehicle in differential turns).
const THRUST_HOME: &[Channel] = &[
    Channel::Depth,
    Channel::Heading,
    Channel::Heave,
    Channel::YawRate,
    Channel::Surge,
];
const ATTITUDE_HOME: &[Channel] = &[
    Channel::Pitch,
    Channel::Roll,
    Channel::PitchRate,
    Channel::RollRate,
];
const HEADING_HOME: &[Channel] = &[Channel::Heading, Channel::YawRate];
const DEPTH_HOME: &[Channel] = &[Channel::Depth, Channel::Heave];
const POSITION_HOME: &[Channel] = &[Channel::North, Channel::East, Channel::Surge, Channel::Sway];

/// Experiments that separate two effects with similar signatures (modellab.md §3.4),
/// one row per pair.
const SEPARATING: &[(EffectId, EffectId, &str)] = &[
    (
        EffectId::ThrustAsymmetry,
        EffectId::NetBuoyancy,
        "zero-thrust hovers between the up and down vertical steps",
    ),
    (
        EffectId::ThrustAsymmetry,
        EffectId::DragForm,
        "steps from rest and cut-offs at speed, in both directions",
    ),
    (
        EffectId::NetBuoyancy,
        EffectId::DepthSensorDrift,
        "a recording at rest at a known depth (or at the surface) at the start and at the end",
    ),
    (
        EffectId::PitchDepthCoupling,
        EffectId::NetBuoyancy,
        "pure surge runs in both directions and pure vertical runs",
    ),
    (
        EffectId::PitchDepthCoupling,
        EffectId::ThrustAsymmetry,
        "pure surge runs in both directions and pure vertical runs",
    ),
    (
        EffectId::PitchDepthCoupling,
        EffectId::DepthSensorDrift,
        "pure surge runs in both directions and pure vertical runs",
    ),
    (
        EffectId::ThrusterLag,
        EffectId::AddedMass,
        "a higher sample rate and fast on/off pulses",
    ),
    (
        EffectId::ThrusterLag,
        EffectId::ThrusterDeadzone,
        "a higher sample rate and fast on/off pulses",
    ),
    (
        EffectId::ThrusterMomentArm,
        EffectId::RestoringOffset,
        "pitch and roll at rest compared with pitch and roll during up and down vertical steps",
    ),
    (
        EffectId::ThrusterMomentArm,
        EffectId::AttitudeBias,
        "pitch and roll at rest compared with pitch and roll during up and down vertical steps",
    ),
    (
        EffectId::PropellerTorque,
        EffectId::Tether,
        "vertical steps at several headings, a slack versus a taut tether, and a rate-gyro log",
    ),
    (
        EffectId::PropellerTorque,
        EffectId::CompassDeviation,
        "vertical steps at several headings, a slack versus a taut tether, and a rate-gyro log",
    ),
    (
        EffectId::Tether,
        EffectId::CompassDeviation,
        "vertical steps at several headings, a slack versus a taut tether, and a rate-gyro log",
    ),
    (
        EffectId::PropellerTorque,
        EffectId::Coriolis,
        "spinning in place versus turning while moving",
    ),
    (
        EffectId::Current,
        EffectId::Tether,
        "runs at different distances and headings",
    ),
    (
        EffectId::PowerLimit,
        EffectId::Coriolis,
        "combined steps at low and high speed, and single steps at the same levels",
    ),
    (
        EffectId::PowerLimit,
        EffectId::ThrustAsymmetry,
        "combined steps at low and high speed, and single steps at the same levels",
    ),
    (
        EffectId::RestoringOffset,
        EffectId::AttitudeBias,
        "attitude logged with the vehicle levelled in a known state, and surge runs in both directions",
    ),
];

/// The experiment that separates two effects (modellab.md §3.4).
pub fn separating_experiment(a: EffectId, b: EffectId) -> String {
    SEPARATING
        .iter()
        .find(|(x, y, _)| (*x == a && *y == b) || (*x == b && *y == a))
        .map(|(_, _, s)| *s)
        .unwrap_or("steps that excite one effect and not the other (see the catalog's needs)")
        .to_string()
}

impl EffectId {
    /// All 17, in catalog order.
    pub const ALL: [EffectId; 17] = [
        EffectId::ThrustAsymmetry,
        EffectId::ThrusterLag,
        EffectId::ThrusterDeadzone,
        EffectId::PowerLimit,
        EffectId::ThrusterMomentArm,
        EffectId::PropellerTorque,
        EffectId::NetBuoyancy,
        EffectId::RestoringOffset,
        EffectId::PitchDepthCoupling,
        EffectId::Coriolis,
        EffectId::AddedMass,
        EffectId::DragForm,
        EffectId::Current,
        EffectId::Tether,
        EffectId::DepthSensorDrift,
        EffectId::CompassDeviation,
        EffectId::AttitudeBias,
    ];

    /// The fixed ID string.
    pub fn key(self) -> &'static str {
        self.info().key
    }

    /// Index in [`EffectId::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }

    /// Parses an ID string.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.iter().copied().find(|e| e.key() == s.trim())
    }

    /// The channels where the effect's signature lives first.
    pub fn home_channels(self) -> &'static [Channel] {
        self.info().home
    }

    /// The catalog entry.
    pub fn info(self) -> EffectInfo {
        use EffectGroup::*;
        let (key, code, group, term, signature, needs) = match self {
            EffectId::ThrustAsymmetry => (
                "thrust-asymmetry",
                "A1",
                Actuator,
                "reverse thrust scaled per thruster: F_i = ρ_i F_i(u) for u < 0 (ρ = reverse/forward ratio)",
                "residual binned by command sign has opposite-sign means; equal and opposite steps reach different speeds; depth drifts only while the vertical thruster runs, in one direction",
                "steps of both signs on the thruster (depth for vertical, heading for port/starboard single-thruster steps)",
            ),
            EffectId::ThrusterLag => (
                "thruster-lag",
                "A2",
                Actuator,
                "first-order lag on each thruster's command, ȧ = (u − a)/τ, thrust F(a); exact discrete update on the held command",
                "residual at every command change, opposite to the change, zero in steady state; the model leads the data at step onsets",
                "step edges sampled at ≥ 5/τ",
            ),
            EffectId::ThrusterDeadzone => (
                "thruster-deadzone",
                "A3",
                Actuator,
                "no thrust below |u| = u₀, thrust from the shifted command above it: F(sign(u)·(|u| − u₀)/(1 − u₀))",
                "residual concentrated at the lowest command level, opposite to the command; little at 60/90 %",
                "steps at low and high levels",
            ),
            EffectId::PowerLimit => (
                "power-limit",
                "A4",
                Actuator,
                "all thrusts scaled by min(1, P_max / Σ|u_j|³) (shared power budget)",
                "single-thruster steps fit, combined manoeuvres are over-predicted",
                "combined and single steps at the same levels",
            ),
            EffectId::ThrusterMomentArm => (
                "thruster-moment-arm",
                "A5",
                Actuator,
                "r × F of thrusters off the CO: pitch M = z_h (T_P + T_S) − x_v T_V, roll K = y_v T_V",
                "pitch (roll) follows thrust with the command's sign",
                "pitch/roll measurements and a model that predicts them (model3)",
            ),
            EffectId::PropellerTorque => (
                "propeller-torque",
                "A6",
                Actuator,
                "reaction torque about the thruster axis: yaw N = c_QV T_V; roll K = c_QH (T_P − T_S)",
                "yaw acceleration whenever the vertical thruster runs, sign following u_V, independent of heading",
                "vertical steps with heading (the roll part needs roll and model3)",
            ),
            EffectId::NetBuoyancy => (
                "net-buoyancy",
                "H1",
                BodyEnvironment,
                "body force (W − B)·[−sin θ, cos θ sin φ, cos θ cos φ]",
                "depth drift at zero vertical thrust, same direction whatever the thrust sign, drag-limited",
                "zero-thrust hover segments",
            ),
            EffectId::RestoringOffset => (
                "restoring-offset",
                "H2",
                BodyEnvironment,
                "restoring moments of a CG off the vertical through the CB: trim moments x_g W, y_g W",
                "static pitch/roll trim at zero thrust",
                "pitch/roll measurements and model3",
            ),
            EffectId::PitchDepthCoupling => (
                "pitch-depth-coupling",
                "H3",
                BodyEnvironment,
                "kinematic coupling ż = −u sin θ + w cos θ with a trim angle θ₀ (for models without pitch)",
                "depth changes during pure surge runs, sign following the surge direction",
                "surge segments (combined port+starboard steps) with depth",
            ),
            EffectId::Coriolis => (
                "coriolis",
                "H4",
                BodyEnvironment,
                "C_RB(ν)ν + C_A(ν_r)ν_r: heel into turns at speed, pitch at surge step edges",
                "roll residual ∝ u·r; pitch transients at surge edges",
                "combined surge + yaw segments, attitude, and a model with sway/roll/pitch states",
            ),
            EffectId::AddedMass => (
                "added-mass",
                "H5",
                BodyEnvironment,
                "−M_A ν̇",
                "time-constant mismatch at step on and coast-down, steady state unaffected",
                "transients; only identifiable up to the common scale of thrust, damping and inertia",
            ),
            EffectId::DragForm => (
                "drag-form",
                "H6",
                BodyEnvironment,
                "direction-asymmetric quadratic drag: d_q scaled by ρ_d for negative velocity (heave up, yaw to port)",
                "steady speeds differ between directions while initial accelerations agree; coast-downs differ",
                "on- and off-steps of both signs",
            ),
            EffectId::Current => (
                "current",
                "H7",
                BodyEnvironment,
                "relative velocity ν_r = ν − [Rᵀ v_c; 0] with a constant current v_c (north, east)",
                "earth-fixed drift independent of heading and thrust",
                "earth-fixed position (north/east) or body velocity (surge/sway); not testable on depth/heading/pitch/roll alone",
            ),
            EffectId::Tether => (
                "tether",
                "H8",
                BodyEnvironment,
                "constant horizontal earth-frame pull F_t (north, east) at x_t = −0.2 m behind the CO: body force Rᵀ F_t, moment r_t × Rᵀ F_t",
                "yaw at zero yaw command that depends on heading (weathervaning), persists at zero thrust",
                "heading variety",
            ),
            EffectId::DepthSensorDrift => (
                "depth-sensor-drift",
                "M1",
                Sensor,
                "y_z = z + ḃ_z·(t − t₀): linear drift of the pressure-depth reading",
                "linear depth drift from the start of the run, regardless of thrust, with no matching heave acceleration",
                "long runs (the drift shows in the free-run view)",
            ),
            EffectId::CompassDeviation => (
                "compass-deviation",
                "M2",
                Sensor,
                "y_ψ = ψ + a sin ψ + b cos ψ + Σ e_i |u_i| (hard-iron deviation and thruster interference)",
                "heading steps synchronous with thrust on/off with no acceleration phase",
                "thrust on/off steps; heading variety for the deviation",
            ),
            EffectId::AttitudeBias => (
                "attitude-bias",
                "M3",
                Sensor,
                "y_θ = θ + b_θ, y_φ = φ + b_φ (mounting offsets)",
                "constant pitch/roll offset that no depth or heading motion accompanies",
                "pitch/roll measurements and model3",
            ),
        };
        use EffectId::*;
        let home = match self {
            ThrusterMomentArm | RestoringOffset | AttitudeBias | Coriolis => ATTITUDE_HOME,
            PropellerTorque | Tether | CompassDeviation => HEADING_HOME,
            NetBuoyancy | PitchDepthCoupling | DepthSensorDrift => DEPTH_HOME,
            Current => POSITION_HOME,
            ThrustAsymmetry | ThrusterLag | ThrusterDeadzone | PowerLimit | AddedMass
            | DragForm => THRUST_HOME,
        };
        let fit_view = match self {
            DepthSensorDrift => FitView::FreeRun,
            _ => FitView::Shooting,
        };
        let judged_in = match self {
            DepthSensorDrift => JudgedIn::FreeRun,
            _ => JudgedIn::BothViews,
        };
        EffectInfo {
            id: self,
            key,
            code,
            group,
            term,
            signature,
            needs,
            home,
            fit_view,
            judged_in,
        }
    }
}

impl std::fmt::Display for EffectId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.key())
    }
}

/// Parses a comma-separated list of effect IDs.
pub fn parse_effect_list(s: &str) -> Result<Vec<EffectId>, crate::LabError> {
    let mut out = Vec::new();
    for part in s.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let id = EffectId::parse(part).ok_or_else(|| crate::LabError::UnknownEffect {
            name: part.to_string(),
        })?;
        if !out.contains(&id) {
            out.push(id);
        }
    }
    Ok(out)
}
