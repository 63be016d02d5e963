//! Issue 26 §3 ("honest on more of what it meets"), one short case per class fixed (so far: (a)); the
//! heavier table is tests/it/honesty_probe.rs (`#[ignore]`).
//!
//! * (a) A missing pitch moment ∝ the surge speed squared (tests/common
//!   `Hidden::PitchSpeedSq`, written into the truth's dynamics independently of the lab's
//!   term code): the term search tests the pitch DOF's own candidates and accepts a pitch
//!   term, instead of dropping them as the signature of a catalog effect that lives
//!   elsewhere (a thrust change's pitch moment through the thrusters' arm), and no term
//!   on another DOF is accepted in its place.
//!
//! Training 6 min, held-out 3 min at 20 Hz, model3 under test.

use crate::common;

use common::{Hidden, case_len};
use rov_lab::diagnose::{DiagnoseOptions, Diagnosis, diagnose};
use rov_lab::verdict::Verdict;
use rov_lab::{BaseKind, LabModel, Run};

fn run_case(seed: u64, hidden: &[Hidden], train_s: f64, val_s: f64) -> Diagnosis {
    let (tr, va) = case_len(seed, hidden, train_s, val_s);
    diagnose(
        &LabModel::default_base(BaseKind::Model3).unwrap(),
        "model3",
        &[Run::from_series(&tr, "train").unwrap()],
        &[Run::from_series(&va, "val").unwrap()],
        &DiagnoseOptions {
            threads: 2,
            ..Default::default()
        },
    )
    .unwrap()
}

fn describe(d: &Diagnosis) -> String {
    format!(
        "verdict {}; accepted {}; channels {}\n{}",
        d.verdict.name(),
        crate::honesty_probe::accepted(d).join(", "),
        crate::honesty_probe::ratios(d),
        d.summary
    )
}

#[test]
fn a_missing_pitch_moment_is_found_in_pitch() {
    let d = run_case(201, &[Hidden::PitchSpeedSq(0.04)], 360.0, 180.0);
    let text = describe(&d);
    // A pitch term carries it; nothing on another DOF, no catalog effect in its place.
    let pitch: Vec<_> = d.accepted_terms.iter().filter(|t| t.dof == 4).collect();
    assert!(!pitch.is_empty(), "no pitch term accepted: {text}");
    assert!(
        d.accepted_terms.iter().all(|t| t.dof == 4),
        "a term on another DOF: {text}"
    );
    for e in &d.accepted {
        let f = d.findings.iter().find(|f| f.effect == e.key()).unwrap();
        assert!(f.contained, "catalog effect {} accepted: {text}", e.key());
    }
    // The moment grows with forward speed, bow up: positive where u > 0.
    let names = d.final_model.command_names();
    let f = d
        .findings
        .iter()
        .find(|f| f.effect == pitch[0].id(&names))
        .unwrap();
    assert!(
        f.params["coefficient"].value > 0.0 && f.significant,
        "{text}"
    );
    // The pitch channel is brought near its floor (it was 3.0× before the term).
    let p = d.consistency.iter().find(|c| c.channel == "pitch").unwrap();
    assert!(
        p.ratio < 2.5,
        "pitch still {:.1}× its floor: {text}",
        p.ratio
    );
    // Honesty: no "adequate"/"explained" while a channel is far from its floor.
    if matches!(d.verdict, Verdict::Adequate | Verdict::Explained) {
        assert!(d.consistency.iter().all(|c| c.ratio <= 2.0), "{text}");
    }
}
