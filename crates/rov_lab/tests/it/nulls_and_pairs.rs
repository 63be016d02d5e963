//! Effect-free runs report nothing significant; two hidden effects are both found, the
//! larger first; the planar models find `pitch-depth-coupling`; a structurally wrong base
//! on effect-free closed-loop dives names nothing and says its structure is the problem.

use crate::common;

use common::{Hidden, case_len, closed_loop_run, mess_up, planar_trim_case};
use rov_lab::diagnose::{DiagnoseOptions, diagnose};
use rov_lab::{BaseKind, LabModel, Run};

fn run_diag(kind: BaseKind, tr: Run, va: Run) -> rov_lab::diagnose::Diagnosis {
    let m = LabModel::default_base(kind).unwrap();
    diagnose(
        &m,
        kind.name(),
        &[tr],
        &[va],
        &DiagnoseOptions {
            threads: 1,
            ..Default::default()
        },
    )
    .unwrap()
}

fn null_seeds(seeds: std::ops::Range<u64>) {
    for seed in seeds {
        let (tr, va) = case_len(seed, &[], 360.0, 180.0);
        let d = run_diag(
            BaseKind::Model3,
            Run::from_series(&tr, "train").unwrap(),
            Run::from_series(&va, "val").unwrap(),
        );
        assert!(
            d.accepted.is_empty(),
            "seed {seed}: effect-free data reported {:?}: {}",
            d.accepted,
            d.findings[0].explanation
        );
        assert!(
            d.findings.iter().all(|f| !f.significant),
            "seed {seed}: {:?}",
            d.findings
                .iter()
                .filter(|f| f.significant)
                .map(|f| format!("{}: {}", f.effect, f.explanation))
                .collect::<Vec<_>>()
        );
        // Nor a term from outside the catalog.
        assert!(
            d.accepted_terms.is_empty(),
            "seed {seed}: effect-free data gained terms {:?}",
            d.accepted_terms
        );
        assert!(d.summary.starts_with("nothing significant"));
    }
}

#[test]
fn effect_free_runs_report_nothing_significant_a() {
    null_seeds(100..104);
}

#[test]
fn effect_free_runs_report_nothing_significant_b() {
    null_seeds(104..108);
}

#[test]
fn two_effects_are_both_found_larger_first() {
    let (tr, va) = case_len(
        31,
        &[Hidden::AsymVertical(0.55), Hidden::TorqueV(0.0012)],
        360.0,
        180.0,
    );
    let d = run_diag(
        BaseKind::Model3,
        Run::from_series(&tr, "train").unwrap(),
        Run::from_series(&va, "val").unwrap(),
    );
    let keys: Vec<&str> = d.accepted.iter().map(|e| e.key()).collect();
    assert!(
        keys.len() >= 2 && keys[0] == "thrust-asymmetry" && keys[1] == "propeller-torque",
        "{keys:?}: {:?}",
        d.findings
            .iter()
            .take(3)
            .map(|f| &f.explanation)
            .collect::<Vec<_>>()
    );
    assert!(d.findings[0].significant && d.findings[1].significant);
    assert!(d.findings[0].score > d.findings[1].score);
    assert_eq!(d.error_fall.len(), keys.len() + 1);
}

#[test]
fn planar_model_finds_pitch_depth_coupling() {
    for (trim, min_red) in [(4.0, 30.0), (8.0, 50.0)] {
        let (tr, va) = planar_trim_case(41, trim, 360.0, 180.0);
        let d = run_diag(
            BaseKind::Model1,
            Run::from_series(&tr, "train").unwrap(),
            Run::from_series(&va, "val").unwrap(),
        );
        let f = &d.findings[0];
        assert_eq!(
            f.effect, "pitch-depth-coupling",
            "trim {trim}: {}",
            f.explanation
        );
        assert!(f.significant, "{}", f.explanation);
        assert!(
            f.validation_rmse_reduction_pct["depth"] >= min_red,
            "{:?}",
            f.validation_rmse_reduction_pct
        );
        let p = f.params["trim_deg"].value;
        assert!((p - trim).abs() <= 0.35 * trim, "trim {trim} fitted {p}");
    }
}

/// Probe case 8: the planar model2 on model3's effect-free closed-loop dives (messy logs,
/// the autopilot in the loop). After calibration the base misses six channels by 2.5–14
/// noise floors, so any catalog effect can buy some of them with another: a dead zone
/// cut depth and surge by half while making heading and yaw rate 21–35 % worse, and was
/// accepted because the gain outweighed the loss. On a base that stays structurally
/// inadequate with the finding granted, such a trade is refused, and the report says the
/// base is the problem.
#[test]
fn a_structurally_wrong_base_trades_no_channel_for_a_false_finding() {
    let mut tr = closed_loop_run(68, 68, &[], 420.0);
    let mut va = closed_loop_run(68, 69, &[], 240.0);
    mess_up(&mut tr, 75, 3, 2, Some((150.0, 2.5)));
    mess_up(&mut va, 76, 2, 3, None);
    let tr = rov_lab::ingest::runs_from_text(&tr.to_csv(), "train.csv").unwrap();
    let va = rov_lab::ingest::runs_from_text(&va.to_csv(), "val.csv").unwrap();
    let m = LabModel::default_base(BaseKind::Model2).unwrap();
    let d = diagnose(
        &m,
        "model2",
        &tr,
        &va,
        &DiagnoseOptions {
            threads: 2,
            ..Default::default()
        },
    )
    .unwrap();
    // No finding is bought with another channel: whatever is accepted on this base makes
    // no held-out channel worse by more than the judge's own margin. (Since the heading
    // hold allocates in force, model3's closed-loop dives here leave a depth residual that
    // a cubic heave damping term reduces by ~40 % on the held-out run with nothing made
    // worse: accepted, and qualified by the structural note asserted below. It stands in
    // for model2's linear vertical thrust map against model3's quadratic one.)
    let traded: Vec<String> = d
        .findings
        .iter()
        .filter(|f| f.significant)
        .filter(|f| {
            f.validation_rmse_reduction_pct
                .values()
                .any(|r| *r < -100.0 * rov_lab::diagnose::MAX_WORSE)
        })
        .map(|f| format!("{}: {:?}", f.effect, f.validation_rmse_reduction_pct))
        .collect();
    assert!(traded.is_empty(), "accepted trades {traded:?}");
    assert!(
        d.accepted.is_empty(),
        "no catalog effect is hidden, yet accepted {:?}",
        d.accepted
    );
    if !d.accepted_terms.is_empty() {
        assert!(
            d.summary.contains("before effects can be named reliably"),
            "a term accepted on a structurally inadequate base is qualified: {}",
            d.summary
        );
    }
    assert_eq!(
        d.verdict,
        rov_lab::verdict::Verdict::Unexplained,
        "{}",
        d.summary
    );
    assert!(
        d.summary.contains("structurally inadequate"),
        "the summary must say the base is the problem: {}",
        d.summary
    );
    // A trade refused for the base is reported as such on its card (the rule itself is
    // unit-tested in `diagnose::judging`; on this dive the dead zone's trade is refused by
    // the ordinary rule, as a channel made worse beyond the base's misfit).
    let refused: Vec<&rov_lab::diagnose::Finding> = d
        .findings
        .iter()
        .filter(|f| {
            f.conflicts
                .iter()
                .any(|c| c.contains("the base is structurally inadequate"))
        })
        .collect();
    assert!(
        refused
            .iter()
            .all(|f| !f.significant && f.explanation.contains("structurally inadequate")),
        "{:?}",
        refused.iter().map(|f| &f.explanation).collect::<Vec<_>>()
    );
}
