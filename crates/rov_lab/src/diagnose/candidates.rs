//! Which catalog effects are candidates for a model and data: applicable, testable with
//! the data's channels and excitation, or already contained in the base.

use rov_dynamics::models::Channel;

use crate::calibrate::{differential_used, excited, group_used};
use crate::catalog::EffectId;
use crate::data::{Run, SegmentKind};
use crate::model::LabModel;
use crate::params::{Axis, Param, Thr, effect_params};

use super::*;

#[derive(Debug, Clone)]
pub(super) struct Candidate {
    pub(super) effect: EffectId,
    pub(super) params: Vec<Param>,
    pub(super) contained: bool,
}

pub(super) enum Availability {
    Candidate(Candidate),
    NotApplicable(String),
    NotTestable(String),
    Contained(String),
}

pub(super) fn any_cmd(runs: &[Run], f: impl Fn(&rov_dynamics::ThrustPct) -> bool) -> bool {
    runs.iter().any(|r| r.cmd.iter().any(&f))
}

pub(super) fn measured(model: &LabModel, runs: &[Run], ch: Channel) -> bool {
    model.predicts_channel(ch) && runs.iter().any(|r| r.has(ch))
}

/// Whether a parameter is excited by the data (beyond [`excited`]'s base rules).
pub(super) fn effect_param_testable(model: &LabModel, runs: &[Run], p: Param) -> bool {
    let depth = measured(model, runs, Channel::Depth) || measured(model, runs, Channel::Heave);
    let heading =
        measured(model, runs, Channel::Heading) || measured(model, runs, Channel::YawRate);
    let pitch = measured(model, runs, Channel::Pitch) || measured(model, runs, Channel::PitchRate);
    let roll = measured(model, runs, Channel::Roll) || measured(model, runs, Channel::RollRate);
    let surge = measured(model, runs, Channel::Surge);
    let on = |x: f64| x.abs() >= 5.0;
    match p {
        Param::ReverseRatio(t) => {
            group_used(model, runs, t, true)
                && match t {
                    Thr::Vertical => depth,
                    _ => heading || surge,
                }
        }
        Param::LagTau => runs.iter().any(|r| r.segments.len() > 2) && (depth || heading),
        Param::Deadzone => Thr::ALL.iter().any(|g| group_used(model, runs, *g, false)),
        Param::PowerMax => {
            let n = model.n_thrusters();
            runs.iter().any(|r| {
                r.inputs.iter().any(|c| {
                    let t = model.thruster_targets(c);
                    t[..n].iter().filter(|x| on(**x)).count() >= 2
                })
            })
        }
        Param::ArmZh => pitch && any_cmd(runs, |c| on(c.port) && on(c.starboard)),
        Param::ArmXv => pitch && any_cmd(runs, |c| on(c.vertical)),
        Param::ArmYv => roll && any_cmd(runs, |c| on(c.vertical)),
        Param::TorqueV => heading && any_cmd(runs, |c| on(c.vertical)),
        Param::TorqueH => roll && any_cmd(runs, |c| on(c.port - c.starboard)),
        Param::NetWeight => depth,
        Param::CgX => pitch,
        Param::CgY => roll,
        Param::TrimDeg => {
            depth
                && runs
                    .iter()
                    .any(|r| r.segments.iter().any(|s| s.kind == SegmentKind::Surge))
        }
        Param::DragRatio(Axis::Heave) => depth && group_used(model, runs, Thr::Vertical, true),
        Param::DragRatio(Axis::Yaw) => heading && differential_used(model, runs),
        Param::DragRatio(_) => false,
        Param::CurrentN | Param::CurrentE => {
            measured(model, runs, Channel::North)
                || measured(model, runs, Channel::East)
                || measured(model, runs, Channel::Surge)
                || measured(model, runs, Channel::Sway)
        }
        Param::TetherN | Param::TetherE => heading,
        Param::DepthDrift => measured(model, runs, Channel::Depth),
        Param::CompassSin | Param::CompassCos => measured(model, runs, Channel::Heading),
        Param::Emi(t) => {
            measured(model, runs, Channel::Heading) && group_used(model, runs, t, false)
        }
        Param::BiasRoll => measured(model, runs, Channel::Roll),
        Param::BiasPitch => measured(model, runs, Channel::Pitch),
        Param::AddedMass(_) => depth || heading,
        _ => excited(model, runs, p),
    }
}

pub(super) fn availability(model: &LabModel, runs: &[Run], e: EffectId) -> Availability {
    if let Some(reason) = model.not_applicable(e) {
        return Availability::NotApplicable(format!(
            "not testable with {}: {reason}",
            model.base_name()
        ));
    }
    match e {
        EffectId::Coriolis => {
            return Availability::Contained(format!(
                "{} already contains it; its coefficients follow from the mass, added mass and CG",
                model.base_name()
            ));
        }
        EffectId::AddedMass => {
            return Availability::Contained(format!(
                "{} already contains it; with motion data only, added mass, thrust gain and damping are determined up to a common scale, so it is kept fixed and the calibration's thrust and damping carry the scale",
                model.base_name()
            ));
        }
        EffectId::PitchDepthCoupling if model.contains(e) => {
            return Availability::Contained(
                "model3's 6-DOF kinematics already carry it; a trim angle shows up as restoring-offset"
                    .into(),
            );
        }
        _ => {}
    }
    let params: Vec<Param> = effect_params(e)
        .into_iter()
        .filter(|p| model.applicable(*p) && effect_param_testable(model, runs, *p))
        .collect();
    if params.is_empty() {
        let why = match e {
            EffectId::Current => "not testable with this data: a constant current only shows in earth-fixed position (north/east) or body velocity (surge/sway), and the data has none of them; depth, heading, pitch and roll cannot reveal it".to_string(),
            _ => format!("not testable with this data: it needs {}", e.info().needs),
        };
        return Availability::NotTestable(why);
    }
    Availability::Candidate(Candidate {
        effect: e,
        params,
        contained: model.contains(e),
    })
}

pub(super) fn probe_value(model: &LabModel, runs: &[Run], p: Param) -> f64 {
    if p == Param::PowerMax {
        // Below the largest combined demand in the data.
        let mut dmax: f64 = 0.0;
        for r in runs {
            for c in &r.cmd {
                let d = (c.port * 0.01).abs().powi(3)
                    + (c.starboard * 0.01).abs().powi(3)
                    + (c.vertical * 0.01).abs().powi(3);
                dmax = dmax.max(d);
            }
        }
        return (0.6 * dmax).max(0.05);
    }
    let cur = model.get(p).or_else(|| p.off_value()).unwrap_or(0.0);
    match p.off_value() {
        Some(off) => cur + (p.probe_value() - off),
        None => cur + p.meta().scale * 4.0,
    }
}

pub(super) fn candidates_of(
    model: &LabModel,
    train: &[Run],
    skip: &[EffectId],
) -> (Vec<Candidate>, Vec<Finding>) {
    let mut cands = Vec::new();
    let mut other = Vec::new();
    for e in EffectId::ALL {
        if skip.contains(&e) {
            continue;
        }
        let blank = |status: Status, expl: String, contained: bool| {
            Finding::blank(e, status, expl, contained)
        };
        match availability(model, train, e) {
            Availability::Candidate(c) => cands.push(c),
            Availability::NotApplicable(s) => other.push(blank(Status::NotApplicable, s, false)),
            Availability::NotTestable(s) => {
                other.push(blank(Status::NotTestable, s, model.contains(e)))
            }
            Availability::Contained(s) => other.push(blank(Status::Contained, s, true)),
        }
    }
    (cands, other)
}
