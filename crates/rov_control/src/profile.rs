//! Tracking profiles: fixed, documented sequences of depth and heading changes that
//! `topside hold --profile` flies, so runs with different feedforward models compare on
//! the same moving references.
//!
//! A profile is a pure function of the time since the holds engaged (no clock, no I/O):
//! [`TrackingProfile::reference`] gives the smooth reference (position and rate) at `t_s`
//! relative to the start depth and heading. The station types that reference every tick
//! as a moving setpoint, and the tracking RMSE is measured against it, so the reference
//! is the same for every model.
//!
//! Every change is a *move*: `amount` over `duration_s` starting at `t0_s`, with a velocity
//! that rises and falls along a cubic smoothstep over `blend_s` at each end (constant in
//! between). The position is therefore twice continuously differentiable (acceleration
//! continuous, zero at both ends):
//!
//! * a **step** is a move with `blend_s = duration_s / 2` (no constant-rate part: a quick
//!   S-shaped change as fast as the controller's reference limits allow),
//! * a **ramp** is a move with a short blend and a long constant-rate part.
//!
//! ## `survey` (130 s)
//!
//! Offsets from the start (depth positive down; heading positive to starboard):
//!
//! | t (s) | depth | heading |
//! |---|---|---|
//! | 0–10 | hold | hold |
//! | 10–16 | step +1.0 m (down) | |
//! | 20–24 | | step +60° (starboard) |
//! | 30–50 | ramp +2.0 m (down, 0.11 m/s) | |
//! | 40–58 | | ramp −150° (port, 9.4°/s) |
//! | 62–70 | step −1.5 m (up) | |
//! | 72–76 | | step −60° (port) |
//! | 80–100 | ramp −1.5 m (up, 0.083 m/s) | |
//! | 84–104 | | ramp +150° (starboard, 8.3°/s) |
//! | 110–116 | step +1.0 m (down) | |
//! | 110–116 | | step +90° (starboard) |
//! | 116–130 | hold | hold |
//!
//! Depth offsets stay within 0…+3 m (never above the start depth); the final step (at
//! 110 s, +1 m and +90°) is the one `hold` reports step metrics for. Peak rates are
//! 0.375 m/s and 30°/s, peak accelerations 0.17 m/s² and 22.5°/s², inside the default
//! reference limits (0.4 m/s, 0.4 m/s², 40°/s, 60°/s²).

use crate::angle::wrap_deg_360;

/// One move of a channel: `amount` over `[t0_s, t0_s + duration_s]`, the velocity
/// blended in and out over `blend_s` (cubic smoothstep) at each end.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Move {
    /// Start time since engagement, s.
    pub t0_s: f64,
    /// Length of the move, s.
    pub duration_s: f64,
    /// Blend length at each end, s (`duration_s / 2` for a step).
    pub blend_s: f64,
    /// Change of position (m or degrees), signed.
    pub amount: f64,
}

/// The kind of a move, for documentation and tests.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MoveKind {
    /// A quick S-shaped change (no constant-rate part).
    Step,
    /// A constant-rate change with blended ends.
    Ramp,
}

impl Move {
    const fn step(t0_s: f64, duration_s: f64, amount: f64) -> Self {
        Self {
            t0_s,
            duration_s,
            blend_s: duration_s / 2.0,
            amount,
        }
    }

    const fn ramp(t0_s: f64, duration_s: f64, amount: f64) -> Self {
        Self {
            t0_s,
            duration_s,
            blend_s: RAMP_BLEND_S,
            amount,
        }
    }

    /// Step or ramp.
    pub fn kind(&self) -> MoveKind {
        if self.blend_s * 2.0 >= self.duration_s {
            MoveKind::Step
        } else {
            MoveKind::Ramp
        }
    }

    /// End time, s.
    pub fn t1_s(&self) -> f64 {
        self.t0_s + self.duration_s
    }

    /// Speed of the constant-rate part (signed; the peak rate of the move).
    pub fn peak_rate(&self) -> f64 {
        self.amount / (self.duration_s - self.blend_s)
    }

    /// Position offset and rate of this move at `t_s` (0 before, `amount` after).
    pub fn at(&self, t_s: f64) -> (f64, f64) {
        let (tt, b, d) = (t_s - self.t0_s, self.blend_s, self.duration_s);
        if tt.is_nan() || tt <= 0.0 {
            return (0.0, 0.0);
        }
        if tt >= d {
            return (self.amount, 0.0);
        }
        let v = self.peak_rate();
        // Blend in: velocity v·s(u), s(u) = 3u² − 2u³; ∫ s = b·(u³ − u⁴/2).
        let blend_pos = |u: f64| b * (u.powi(3) - 0.5 * u.powi(4));
        let smooth = |u: f64| 3.0 * u * u - 2.0 * u.powi(3);
        if tt < b {
            let u = tt / b;
            (v * blend_pos(u), v * smooth(u))
        } else if tt <= d - b {
            (v * (0.5 * b + (tt - b)), v)
        } else {
            // Blend out, mirrored: remaining distance from the end.
            let u = (d - tt) / b;
            (self.amount - v * blend_pos(u), v * smooth(u))
        }
    }
}

/// Blend length at each end of a ramp, s.
const RAMP_BLEND_S: f64 = 2.0;

const SURVEY_DEPTH: [Move; 5] = [
    Move::step(10.0, 6.0, 1.0),
    Move::ramp(30.0, 20.0, 2.0),
    Move::step(62.0, 8.0, -1.5),
    Move::ramp(80.0, 20.0, -1.5),
    Move::step(110.0, 6.0, 1.0),
];

const SURVEY_HEADING: [Move; 5] = [
    Move::step(20.0, 4.0, 60.0),
    Move::ramp(40.0, 18.0, -150.0),
    Move::step(72.0, 4.0, -60.0),
    Move::ramp(84.0, 20.0, 150.0),
    Move::step(110.0, 6.0, 90.0),
];

/// The smooth reference of a profile at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProfilePoint {
    /// Depth, m (positive down).
    pub depth_m: f64,
    /// Depth rate, m/s.
    pub depth_rate_m_s: f64,
    /// Heading, degrees in `[0, 360)`.
    pub heading_deg: f64,
    /// Heading rate, degrees/s.
    pub heading_rate_deg_s: f64,
}

/// A fixed tracking profile.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrackingProfile {
    /// Steps and ramps in both directions on depth and heading, 130 s (see the module
    /// documentation for the table).
    Survey,
}

impl TrackingProfile {
    /// Total length, s (the run always flies all of it).
    pub fn duration_s(&self) -> f64 {
        match self {
            Self::Survey => 130.0,
        }
    }

    /// The depth moves (offsets in m).
    pub fn depth_moves(&self) -> &'static [Move] {
        match self {
            Self::Survey => &SURVEY_DEPTH,
        }
    }

    /// The heading moves (offsets in degrees).
    pub fn heading_moves(&self) -> &'static [Move] {
        match self {
            Self::Survey => &SURVEY_HEADING,
        }
    }

    /// Start time of the last step on both channels, s: step metrics are reported for
    /// that step (from there to the end of the run).
    pub fn final_step_t0_s(&self) -> f64 {
        match self {
            Self::Survey => 110.0,
        }
    }

    /// Depth and heading offsets (m, degrees; heading not wrapped) and their rates at
    /// `t_s` since engagement.
    pub fn offsets(&self, t_s: f64) -> ProfilePoint {
        let sum = |moves: &[Move]| {
            moves.iter().fold((0.0, 0.0), |(p, v), m| {
                let (pm, vm) = m.at(t_s);
                (p + pm, v + vm)
            })
        };
        let (d, dv) = sum(self.depth_moves());
        let (h, hv) = sum(self.heading_moves());
        ProfilePoint {
            depth_m: d,
            depth_rate_m_s: dv,
            heading_deg: h,
            heading_rate_deg_s: hv,
        }
    }

    /// The smooth reference at `t_s` since engagement, starting from `start_depth_m` and
    /// `start_heading_deg` (heading wrapped to `[0, 360)`).
    pub fn reference(&self, t_s: f64, start_depth_m: f64, start_heading_deg: f64) -> ProfilePoint {
        let o = self.offsets(t_s);
        ProfilePoint {
            depth_m: start_depth_m + o.depth_m,
            heading_deg: wrap_deg_360(start_heading_deg + o.heading_deg),
            ..o
        }
    }

    /// The deepest offset below the start the profile reaches, m (for range checks).
    pub fn max_depth_offset_m(&self) -> f64 {
        match self {
            Self::Survey => 3.0,
        }
    }
}

impl std::str::FromStr for TrackingProfile {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "survey" => Ok(Self::Survey),
            other => Err(format!("unknown profile {other:?} (known: survey)")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const P: TrackingProfile = TrackingProfile::Survey;

    fn samples(dt: f64) -> impl Iterator<Item = f64> {
        (0..=((P.duration_s() / dt) as usize)).map(move |k| k as f64 * dt)
    }

    #[test]
    fn survey_is_long_enough_and_ends_settled() {
        assert!(P.duration_s() >= 120.0);
        let last = P
            .depth_moves()
            .iter()
            .chain(P.heading_moves())
            .map(Move::t1_s)
            .fold(0.0, f64::max);
        assert!(
            last + 10.0 <= P.duration_s(),
            "at least 10 s of hold after the last move"
        );
        let o = P.offsets(P.duration_s());
        assert_eq!((o.depth_rate_m_s, o.heading_rate_deg_s), (0.0, 0.0));
        assert!((o.depth_m - 1.0).abs() < 1e-12 && (o.heading_deg - 90.0).abs() < 1e-12);
    }

    #[test]
    fn both_channels_have_steps_and_ramps_in_both_directions() {
        for moves in [P.depth_moves(), P.heading_moves()] {
            for kind in [MoveKind::Step, MoveKind::Ramp] {
                for sign in [1.0, -1.0] {
                    assert!(
                        moves
                            .iter()
                            .any(|m| m.kind() == kind && m.amount * sign > 0.0),
                        "{kind:?} with sign {sign} in {moves:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn reference_is_continuous_and_its_rate_is_the_derivative() {
        let dt = 1e-3;
        let mut prev = P.offsets(0.0);
        let (mut max_jump_d, mut max_jump_h) = (0.0_f64, 0.0_f64);
        for t in samples(dt).skip(1) {
            let o = P.offsets(t);
            // Position changes by at most the peak rate times dt (no jumps).
            max_jump_d = max_jump_d.max((o.depth_m - prev.depth_m).abs());
            max_jump_h = max_jump_h.max((o.heading_deg - prev.heading_deg).abs());
            // The rate is the derivative (central difference) and itself continuous.
            let fd = (P.offsets(t + 1e-6).depth_m - P.offsets(t - 1e-6).depth_m) / 2e-6;
            let fh = (P.offsets(t + 1e-6).heading_deg - P.offsets(t - 1e-6).heading_deg) / 2e-6;
            assert!((fd - o.depth_rate_m_s).abs() < 1e-5, "t {t}: {fd} vs {o:?}");
            assert!(
                (fh - o.heading_rate_deg_s).abs() < 1e-3,
                "t {t}: {fh} vs {o:?}"
            );
            assert!(
                (o.depth_rate_m_s - prev.depth_rate_m_s).abs() < 1e-3,
                "t {t}"
            );
            assert!(
                (o.heading_rate_deg_s - prev.heading_rate_deg_s).abs() < 0.05,
                "t {t}"
            );
            prev = o;
        }
        assert!(max_jump_d <= 0.4 * dt + 1e-12, "{max_jump_d}");
        assert!(max_jump_h <= 30.0 * dt + 1e-9, "{max_jump_h}");
    }

    #[test]
    fn rates_and_accelerations_stay_inside_the_reference_limits() {
        let defaults = crate::ControlConfig::default();
        let (dv, da) = (
            defaults.depth.reference.vel_max,
            defaults.depth.reference.acc_max,
        );
        let (hv, ha) = (
            defaults.heading.reference.vel_max.to_degrees(),
            defaults.heading.reference.acc_max.to_degrees(),
        );
        let dt = 0.01;
        for t in samples(dt) {
            let (a, b) = (P.offsets(t), P.offsets(t + dt));
            assert!(a.depth_rate_m_s.abs() <= dv, "t {t}: {a:?}");
            assert!(a.heading_rate_deg_s.abs() <= hv, "t {t}: {a:?}");
            assert!(
                ((b.depth_rate_m_s - a.depth_rate_m_s) / dt).abs() <= da,
                "t {t}"
            );
            assert!(
                ((b.heading_rate_deg_s - a.heading_rate_deg_s) / dt).abs() <= ha,
                "t {t}"
            );
        }
    }

    #[test]
    fn depth_never_rises_above_the_start_and_heading_wraps() {
        for t in samples(0.05) {
            let o = P.offsets(t);
            assert!(o.depth_m >= -1e-12 && o.depth_m <= P.max_depth_offset_m() + 1e-12);
            let r = P.reference(t, 0.0, 350.0);
            assert!((0.0..360.0).contains(&r.heading_deg), "{r:?}");
        }
        // Before engagement and exactly at the start: the start values, at rest.
        let r = P.reference(-1.0, 5.0, 10.0);
        assert_eq!(
            (r.depth_m, r.heading_deg, r.depth_rate_m_s),
            (5.0, 10.0, 0.0)
        );
        assert_eq!("survey".parse::<TrackingProfile>(), Ok(P));
        assert!("zigzag".parse::<TrackingProfile>().is_err());
    }
}
