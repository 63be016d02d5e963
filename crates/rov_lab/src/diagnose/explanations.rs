//! Plain-language explanations of findings.

use crate::catalog::EffectId;
use crate::model::LabModel;
use crate::params::{Axis, Param, Thr};

use super::*;

/// A fraction as a whole percentage.
pub(super) fn fmt_pct(x: f64) -> String {
    format!("{:.0} %", x * 100.0)
}

/// Plain-language explanation of a confirmed finding.
pub(super) fn explain(c: &Confirmed, j: &Judgement, model: &LabModel) -> String {
    let v = |p: Param| c.fit.model.get(p).unwrap_or(0.0);
    let home = c.subject.home();
    let pick = |only_home: bool| {
        j.explained
            .iter()
            .filter(|(k, _)| !only_home || home.contains(&k.channel()))
            .max_by(|a, b| a.1.total_cmp(b.1))
            .map(|(k, f)| (k.name(), *f))
    };
    let (main_ch, frac) = pick(true).or_else(|| pick(false)).unwrap_or(("", 0.0));
    let tail = if main_ch.is_empty() {
        String::new()
    } else {
        format!(" explains {} of the {main_ch} residual", fmt_pct(frac))
    };
    let mm = |x: f64| format!("{:.0} mm", x * 1000.0);
    let effect = match c.subject {
        Subject::Effect(e) => e,
        Subject::Term(t) => return super::discovery::explain_term(c, &t, model, &tail),
    };
    match effect {
        EffectId::ThrustAsymmetry => {
            let mut parts = Vec::new();
            for t in Thr::ALL {
                if c.params.contains(&Param::ReverseRatio(t)) {
                    let r = v(Param::ReverseRatio(t));
                    if (r - 1.0).abs() > 0.03 {
                        parts.push(format!("{} {:.0} %", t.name(), r * 100.0));
                    }
                }
            }
            format!(
                "equal and opposite steps reach different speeds; reverse thrust at {} of forward{tail}",
                if parts.is_empty() {
                    "≈100 %".into()
                } else {
                    parts.join(", ")
                }
            )
        }
        EffectId::ThrusterLag => format!(
            "the response trails every command change and the model leads the data at step onsets; a thruster lag of {:.2} s{tail}",
            v(Param::LagTau)
        ),
        EffectId::ThrusterDeadzone => format!(
            "the lowest command levels deliver far less than the model expects while high levels fit; a dead zone of {:.0} % of full command{tail}",
            v(Param::Deadzone) * 100.0
        ),
        EffectId::PowerLimit => format!(
            "single-thruster steps fit but combined manoeuvres are weaker; a shared power budget of Σ|u|³ = {:.2} (thrust scaled down when exceeded){tail}",
            v(Param::PowerMax)
        ),
        EffectId::ThrusterMomentArm => {
            let xv = v(Param::ArmXv);
            let zh = v(Param::ArmZh);
            let yv = v(Param::ArmYv);
            let mut s = Vec::new();
            if xv.abs() >= 0.001 {
                s.push(format!(
                    "pitch follows vertical thrust with the command's sign; a vertical-thruster moment arm of {} ({} of the CO)",
                    mm(xv.abs()),
                    if xv > 0.0 { "forward" } else { "aft" }
                ));
            }
            if zh.abs() >= 0.001 {
                s.push(format!(
                    "pitch follows surge thrust; the horizontal thrusters act {} {} the CO",
                    mm(zh.abs()),
                    if zh > 0.0 { "below" } else { "above" }
                ));
            }
            if yv.abs() >= 0.001 {
                s.push(format!(
                    "roll follows vertical thrust; the vertical thruster sits {} to {}",
                    mm(yv.abs()),
                    if yv > 0.0 { "starboard" } else { "port" }
                ));
            }
            format!("{}{tail}", s.join("; "))
        }
        EffectId::PropellerTorque => {
            let cv = v(Param::TorqueV);
            let full = model
                .forces(&rov_dynamics::ThrustPct::new(0.0, 0.0, 100.0))
                .vertical_n;
            format!(
                "heading turns whenever the vertical thruster runs, with the command's sign and whatever the heading; a reaction torque of {:.2} mm per newton ({:.3} N m at full vertical thrust){tail}",
                cv * 1000.0,
                cv * full
            )
        }
        EffectId::NetBuoyancy => {
            let wb = v(Param::NetWeight);
            format!(
                "depth drifts at zero vertical thrust, the same way whatever the thrust sign; the vehicle is {} by {:.2} N ({:.1} % of its weight){}{tail}",
                if wb > 0.0 { "heavy" } else { "light" },
                wb.abs(),
                wb.abs() / 59.8 * 100.0,
                if c.contained {
                    "; refitted W − B, which the model already has"
                } else {
                    ""
                }
            )
        }
        EffectId::RestoringOffset => {
            let x = v(Param::CgX);
            let y = v(Param::CgY);
            let zg = c.fit.model.get(Param::CgZ).unwrap_or(0.0056).max(1e-4);
            let trim = (-x / zg).atan().to_degrees();
            let heel = (y / zg).atan().to_degrees();
            format!(
                "the vehicle rests trimmed {:.1}° nose {} and heeled {:.1}° to {} at zero thrust; the CG sits {} {} and {} to {} of the CB (refitted CG offset, which model3 already has){tail}",
                trim.abs(),
                if trim >= 0.0 { "up" } else { "down" },
                heel.abs(),
                if heel >= 0.0 { "starboard" } else { "port" },
                mm(x.abs()),
                if x >= 0.0 { "forward" } else { "aft" },
                mm(y.abs()),
                if y >= 0.0 { "starboard" } else { "port" }
            )
        }
        EffectId::PitchDepthCoupling => format!(
            "depth changes during surge runs with the surge direction; a trim of {:.1}° couples surge speed into depth{tail}",
            v(Param::TrimDeg)
        ),
        EffectId::DragForm => {
            let rh = v(Param::DragRatio(Axis::Heave));
            let ry = v(Param::DragRatio(Axis::Yaw));
            format!(
                "steady speeds differ between directions while accelerations from rest agree; quadratic drag moving up is {:.2}× that moving down, turning to port {:.2}× that to starboard{tail}",
                rh, ry
            )
        }
        EffectId::Current => {
            let (n, e) = (v(Param::CurrentN), v(Param::CurrentE));
            format!(
                "the vehicle drifts over ground independent of heading and thrust; a current of {:.2} m/s towards {:.0}°{tail}",
                n.hypot(e),
                e.atan2(n).to_degrees().rem_euclid(360.0)
            )
        }
        EffectId::Tether => {
            let (n, e) = (v(Param::TetherN), v(Param::TetherE));
            format!(
                "heading weathervanes at zero thrust and the pull depends on heading; a tether pull of {:.2} N towards {:.0}° at 0.2 m behind the CO{tail}",
                n.hypot(e),
                e.atan2(n).to_degrees().rem_euclid(360.0)
            )
        }
        EffectId::DepthSensorDrift => format!(
            "depth drifts linearly from the start of the run regardless of thrust, with no matching heave acceleration; the depth reading drifts {:.1} cm/min{tail}",
            v(Param::DepthDrift) * 6000.0
        ),
        EffectId::CompassDeviation => {
            let mut s = Vec::new();
            for t in Thr::ALL {
                if c.params.contains(&Param::Emi(t)) {
                    let e = v(Param::Emi(t));
                    if e.abs() >= 0.3 {
                        s.push(format!("{:.1}° at full {} thrust", e, t.name()));
                    }
                }
            }
            let dev = v(Param::CompassSin).hypot(v(Param::CompassCos));
            format!(
                "heading jumps when thrusters switch, with no turning phase, and its error varies with heading; compass interference {}{}{tail}",
                if s.is_empty() {
                    "negligible".into()
                } else {
                    s.join(", ")
                },
                if dev >= 0.3 {
                    format!(" and a deviation of {dev:.1}° amplitude")
                } else {
                    String::new()
                }
            )
        }
        EffectId::AttitudeBias => format!(
            "pitch and roll read offset with no matching motion; mounting biases of {:.1}° in pitch and {:.1}° in roll{tail}",
            v(Param::BiasPitch),
            v(Param::BiasRoll)
        ),
        EffectId::AddedMass | EffectId::Coriolis => format!("refitted{tail}"),
    }
}
