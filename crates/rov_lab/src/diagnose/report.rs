//! The diagnosis report: findings (evidence cards), statuses, baselines.

use std::collections::BTreeMap;

use crate::calibrate::{FittedParam, View};
use crate::catalog::EffectId;
use crate::evaluate::Evaluation;
use crate::model::LabModel;
use crate::params::Param;
use crate::verdict::{ChannelTest, Unexplained, Verdict};

use super::*;

/// Status of a finding.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Accepted: significant on held-out data.
    Significant,
    /// Significant but indistinguishable from another candidate on this data.
    Ambiguous,
    /// Fitted in simulation; did not pass the held-out tests.
    NotSignificant,
    /// Screened only; too little evidence to confirm.
    Screened,
    /// The data cannot excite it.
    NotTestable,
    /// The model cannot represent it.
    NotApplicable,
    /// Already in the model; its parameters are calibrated or fixed as documented.
    Contained,
}

/// A parameter in a report.
#[derive(Debug, Clone, Serialize)]
pub struct ParamReport {
    /// Value (display unit).
    pub value: f64,
    /// Standard deviation (display unit), if known.
    pub std: Option<f64>,
    /// Display unit.
    pub unit: String,
    /// 95 % confidence interval (value ± 1.96 std, from the fit's covariance), if known.
    pub ci95: Option<[f64; 2]>,
}

impl ParamReport {
    /// A report with its 95 % interval from the standard deviation.
    pub fn new(value: f64, std: Option<f64>, unit: String) -> Self {
        let std = std.filter(|s| s.is_finite());
        ParamReport {
            value,
            std,
            unit,
            ci95: std.map(|s| [value - 1.96 * s, value + 1.96 * s]),
        }
    }
}

/// One effect's evidence card.
#[derive(Debug, Clone, Serialize)]
pub struct Finding {
    /// Effect ID.
    pub effect: String,
    /// Whether it was accepted.
    pub significant: bool,
    /// Status.
    pub status: Status,
    /// Whether the base model already contains it (a refit, not an addition).
    pub contained: bool,
    /// Channels it explains.
    pub channels: Vec<String>,
    /// Error view of `validation_rmse_reduction_pct`: "shooting" (multiple shooting) or
    /// "free_run", whichever shows the finding's home channels falling more. Every
    /// candidate is judged on both views alike.
    pub view: String,
    /// Held-out RMSE reduction per predicted channel in `view`, %.
    pub validation_rmse_reduction_pct: BTreeMap<String, f64>,
    /// Held-out free-run RMSE reduction per predicted channel, %.
    pub validation_rmse_reduction_pct_free_run: BTreeMap<String, f64>,
    /// Held-out multiple-shooting RMSE reduction per predicted channel, %.
    pub validation_rmse_reduction_pct_shooting: BTreeMap<String, f64>,
    /// Fitted parameters.
    pub params: BTreeMap<String, ParamReport>,
    /// Plain explanation.
    pub explanation: String,
    /// Training ΔBIC (effective sample size), if fitted or screened.
    pub delta_bic: Option<f64>,
    /// Evidence score (held-out noise-normalised RMSE reduction summed over channels).
    pub score: f64,
    /// Effects it cannot be told apart from on this data.
    pub ambiguous_with: Vec<String>,
    /// The experiment that would separate it from those.
    pub separating_experiment: Option<String>,
    /// Greedy round in which it was evaluated (1-based; 0 = not evaluated).
    pub round: usize,
    /// "catalog" for a catalog effect, "discovered" for a term found outside the catalog.
    pub kind: String,
    /// A discovered term's formula and DOF in words (`None` for catalog effects).
    pub term: Option<String>,
    /// What known physics a discovered term resembles (`None` for catalog effects).
    pub resembles: Option<String>,
    /// Channels the finding makes clearly worse in either view, with what that suggests.
    pub conflicts: Vec<String>,
}

/// Per-channel baseline numbers.
#[derive(Debug, Clone, Serialize)]
pub struct BaselineChannel {
    /// Fit % (multiple shooting), `None` for low excitation.
    pub fit_pct: Option<f64>,
    /// RMSE (multiple shooting).
    pub rmse_shooting: f64,
    /// Fit % (free run).
    pub fit_pct_free_run: Option<f64>,
    /// RMSE (free run).
    pub rmse_free_run: f64,
    /// Noise floor estimated from the data.
    pub noise: f64,
}

/// Held-out RMSE per channel in both views.
#[derive(Debug, Clone, Default, Serialize)]
pub struct RmseMaps {
    /// Multiple shooting.
    pub shooting: BTreeMap<String, f64>,
    /// Free run.
    pub free_run: BTreeMap<String, f64>,
}

/// Result of [`diagnose`].
#[derive(Debug, Clone)]
pub struct Diagnosis {
    /// Model name as given.
    pub model: String,
    /// Calibrated base on the held-out runs.
    pub baseline: BTreeMap<String, BaselineChannel>,
    /// Channels the model does not predict (measured in the data).
    pub not_predicted: Vec<String>,
    /// Calibration parameters.
    pub calibration: Vec<FittedParam>,
    /// Findings, best first.
    pub findings: Vec<Finding>,
    /// Accepted effects, in order.
    pub accepted: Vec<EffectId>,
    /// The calibrated base.
    pub calibrated: LabModel,
    /// The calibrated base plus the accepted effects, refitted.
    pub final_model: LabModel,
    /// Held-out RMSE per channel after each accepted addition (first = base).
    pub error_fall: Vec<(String, RmseMaps)>,
    /// One-line summary ("nothing significant", "found …").
    pub summary: String,
    /// Discovered terms accepted, in order.
    pub accepted_terms: Vec<crate::terms::Term>,
    /// The verdict (see [`crate::verdict`]).
    pub verdict: Verdict,
    /// The consistency test of every channel for the final model.
    pub consistency: Vec<ChannelTest>,
    /// The same for the calibrated base.
    pub consistency_base: Vec<ChannelTest>,
    /// Channels still inconsistent, with where their misfit lives.
    pub unexplained: Vec<Unexplained>,
    /// What was done to the data, in words.
    pub data_notes: Vec<String>,
    /// Whether the data is closed-loop (judged on multiple shooting only).
    pub closed_loop: bool,
    /// Calibration parameters at a bound or along an unidentifiable direction, in words.
    pub calibration_notes: Vec<String>,
    /// What the term search saw besides its findings.
    pub search_notes: Vec<String>,
}

impl Finding {
    /// The conflicts in one line for the text report: the channels made worse and by how
    /// much in which view, without the per-channel reasoning (that stays in
    /// [`Finding::conflicts`], i.e. in the JSON). `None` without conflicts.
    ///
    /// Each conflict starts "<channel> gets <views>;" ([`super::judging`]); the part
    /// before the first ';' is kept.
    pub fn conflict_summary(&self) -> Option<String> {
        if self.conflicts.is_empty() {
            return None;
        }
        let parts: Vec<&str> = self
            .conflicts
            .iter()
            .map(|c| c.split(';').next().unwrap_or(c).trim())
            .collect();
        let blocking = self
            .conflicts
            .iter()
            .filter(|c| c.contains("this blocks the finding"))
            .count();
        Some(format!(
            "{} channel{} worse ({}){}; a trade between channels usually means a base-structure problem (details: --json, findings[].conflicts)",
            parts.len(),
            if parts.len() == 1 { "" } else { "s" },
            parts.join("; "),
            if blocking > 0 {
                format!(", {blocking} blocking")
            } else {
                String::new()
            }
        ))
    }

    /// A finding with nothing evaluated yet.
    pub(super) fn blank(
        effect: EffectId,
        status: Status,
        explanation: String,
        contained: bool,
    ) -> Self {
        Finding {
            effect: effect.key().into(),
            significant: false,
            status,
            contained,
            channels: vec![],
            view: String::new(),
            validation_rmse_reduction_pct: BTreeMap::new(),
            validation_rmse_reduction_pct_free_run: BTreeMap::new(),
            validation_rmse_reduction_pct_shooting: BTreeMap::new(),
            params: BTreeMap::new(),
            explanation,
            delta_bic: None,
            score: 0.0,
            ambiguous_with: vec![],
            separating_experiment: None,
            round: 0,
            kind: "catalog".into(),
            term: None,
            resembles: None,
            conflicts: vec![],
        }
    }

    /// A blank finding for a discovered term.
    pub(super) fn blank_term(t: &crate::terms::Term, cmd_names: &[&str]) -> Self {
        let mut f = Self::blank(EffectId::AddedMass, Status::Screened, String::new(), false);
        f.effect = t.id(cmd_names);
        f.kind = "discovered".into();
        f.term = Some(format!(
            "{} ∝ {}",
            crate::terms::DOF_FORCE
                .get(t.dof as usize)
                .copied()
                .unwrap_or("force"),
            t.kind.formula(cmd_names)
        ));
        f.resembles = Some(super::discovery::resemblance(t).to_string());
        f
    }
}

pub(super) fn param_reports(c: &Confirmed) -> BTreeMap<String, ParamReport> {
    let mut out = BTreeMap::new();
    for p in &c.params {
        if let Some(i) = c.fit.params.iter().position(|x| x == p)
            && let Some(f) = c.fit.fitted.get(i)
        {
            if let (Param::TermCoef(..), Subject::Term(t)) = (p, c.subject) {
                // A term's coefficient in physical units (per unit of its regressor), and
                // the force at the regressor's typical size.
                let s = t.scale.max(1e-300);
                out.insert(
                    "coefficient".into(),
                    ParamReport::new(
                        t.coef,
                        Some(f.std / s),
                        format!("{} per {}", t.force_unit(), t.kind.regressor_unit()),
                    ),
                );
                out.insert(
                    "force_at_typical_size".into(),
                    ParamReport::new(t.coef * t.scale, Some(f.std), t.force_unit().into()),
                );
                continue;
            }
            out.insert(
                f.key.clone(),
                ParamReport::new(f.value, Some(f.std), f.unit.clone()),
            );
        }
    }
    out
}

pub(super) fn view_name(v: View) -> &'static str {
    match v {
        View::FreeRun => "free_run",
        View::Shooting(_) => "shooting",
        View::KStep(_) => "k_step",
    }
}

pub(super) fn rmse_map(e: &Evaluation) -> RmseMaps {
    RmseMaps {
        shooting: e
            .channels
            .iter()
            .map(|(k, c)| (k.name().to_string(), c.shooting.rmse))
            .collect(),
        free_run: e
            .channels
            .iter()
            .map(|(k, c)| (k.name().to_string(), c.free_run.rmse))
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conflict_summary_is_one_line_naming_each_channel() {
        let mut f = Finding::blank(
            EffectId::AddedMass,
            Status::NotSignificant,
            String::new(),
            false,
        );
        assert_eq!(f.conflict_summary(), None);
        f.conflicts = vec![
            "depth gets shooting RMSE +40 %; this blocks the finding — long reasoning".into(),
            "roll gets free-run RMSE +12 %; tolerated because …".into(),
        ];
        let s = f.conflict_summary().unwrap_or_default();
        assert!(!s.contains('\n'), "{s}");
        assert!(
            s.starts_with(
                "2 channels worse (depth gets shooting RMSE +40 %; roll gets free-run RMSE +12 %)"
            ),
            "{s}"
        );
        assert!(s.contains("1 blocking"), "{s}");
        assert!(
            !s.contains("long reasoning") && !s.contains("tolerated"),
            "{s}"
        );
    }
}
