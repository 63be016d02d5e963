//! Seed 000's open-loop experiments as timed step schedules.
//!
//! The paper gives the structure of its experiments (figures 4–9) but not the exact
//! timing; the schedules below use 5 s holds and a 2 s quiet start, which is our choice.
//! Positive vertical pushes down; "yaw +L" means port +L %, starboard −L % (a turn to
//! starboard).

use rov_dynamics::ThrustPct;

use crate::error::SimError;
use crate::series::{Schedule, ScheduleStep};

/// A named experiment.
#[derive(Debug, Clone, PartialEq)]
pub struct Experiment {
    /// Short name (file-name safe).
    pub name: &'static str,
    /// What it reproduces.
    pub description: &'static str,
    /// The thrust schedule.
    pub schedule: Schedule,
}

const HOLD_S: f64 = 5.0;
const QUIET_S: f64 = 2.0;

fn heave(pct: f64) -> ThrustPct {
    ThrustPct::new(0.0, 0.0, pct)
}

fn yaw(pct: f64) -> ThrustPct {
    ThrustPct::new(pct, -pct, 0.0)
}

/// +L, 0, −L, 0 for each level, after a quiet start.
fn alternating(levels: &[f64], cmd: fn(f64) -> ThrustPct) -> Result<Schedule, SimError> {
    let mut holds = vec![(QUIET_S, ThrustPct::ZERO)];
    for &l in levels {
        holds.push((HOLD_S, cmd(l)));
        holds.push((HOLD_S, ThrustPct::ZERO));
        holds.push((HOLD_S, cmd(-l)));
        holds.push((HOLD_S, ThrustPct::ZERO));
    }
    Schedule::from_holds(&holds)
}

/// Heave steps at 30, 60, 90 % in both directions (fig. 4).
pub fn heave_steps() -> Result<Experiment, SimError> {
    Ok(Experiment {
        name: "heave_steps",
        description: "Top thruster +-30, +-60, +-90 % in turns, 5 s holds separated by 5 s at zero (seed 000 fig. 4: depth and heading)",
        schedule: alternating(&[30.0, 60.0, 90.0], heave)?,
    })
}

/// Heave steps at ±60 % (fig. 5).
pub fn heave_60() -> Result<Experiment, SimError> {
    Ok(Experiment {
        name: "heave_60",
        description: "Top thruster +-60 % twice, 5 s holds (seed 000 fig. 5: depth, pitch and roll coupling)",
        schedule: alternating(&[60.0, 60.0], heave)?,
    })
}

/// Yaw steps (differential rear thrust) at 30, 60, 90 % (fig. 6).
pub fn yaw_steps() -> Result<Experiment, SimError> {
    Ok(Experiment {
        name: "yaw_steps",
        description: "Rear thrusters differential (port +L, starboard -L) at +-30, +-60, +-90 %, 5 s holds (seed 000 fig. 6: depth and heading)",
        schedule: alternating(&[30.0, 60.0, 90.0], yaw)?,
    })
}

/// Yaw steps at ±60 % (fig. 7).
pub fn yaw_60() -> Result<Experiment, SimError> {
    Ok(Experiment {
        name: "yaw_60",
        description: "Rear thrusters differential +-60 % twice, 5 s holds (seed 000 fig. 7: heading, pitch and roll coupling)",
        schedule: alternating(&[60.0, 60.0], yaw)?,
    })
}

/// Top and rear thrusters together at 60 %, overlapping steps (fig. 8 and 9).
pub fn combined_60() -> Result<Experiment, SimError> {
    let step = |t_s: f64, port: f64, starboard: f64, vertical: f64| ScheduleStep {
        t_s,
        command: ThrustPct::new(port, starboard, vertical),
    };
    let steps = vec![
        step(0.0, 0.0, 0.0, 0.0),
        step(2.0, 0.0, 0.0, 60.0),
        step(4.5, 60.0, -60.0, 60.0),
        step(7.0, 60.0, -60.0, 0.0),
        step(9.5, 0.0, 0.0, 0.0),
        step(12.0, 0.0, 0.0, -60.0),
        step(14.5, -60.0, 60.0, -60.0),
        step(17.0, -60.0, 60.0, 0.0),
        step(19.5, 0.0, 0.0, 0.0),
        step(22.0, 0.0, 0.0, 60.0),
        step(24.5, -60.0, 60.0, 60.0),
        step(27.0, -60.0, 60.0, 0.0),
        step(29.5, 0.0, 0.0, 0.0),
        step(32.0, 0.0, 0.0, -60.0),
        step(34.5, 60.0, -60.0, -60.0),
        step(37.0, 60.0, -60.0, 0.0),
        step(39.5, 0.0, 0.0, 0.0),
    ];
    Ok(Experiment {
        name: "combined_60",
        description: "Top thruster +-60 % and rear differential +-60 % in overlapping 5 s steps, all four sign combinations (seed 000 fig. 8 and 9: depth, pitch, heading, roll)",
        schedule: Schedule::new(steps, 42.0)?,
    })
}

/// All experiments, in figure order.
pub fn experiments() -> Result<Vec<Experiment>, SimError> {
    Ok(vec![
        heave_steps()?,
        heave_60()?,
        yaw_steps()?,
        yaw_60()?,
        combined_60()?,
    ])
}
