//! Issue 13's verdict points: the calibration's wording for a parameter the data cannot
//! identify, and effect-free closed-loop data judged at its noise floor.

use crate::common;

use common::case_len;
use rov_lab::calibrate::{AxisExcitation, axis_excitation, calibrate, calibration_notes};
use rov_lab::lm::LmOptions;
use rov_lab::params::{Axis, Param};
use rov_lab::{BaseKind, LabModel, Run};

/// A base parameter that ends at a bound of its range is unidentifiable when the data
/// does not excite its axis — not "a sign of a structural misfit"; on an excited axis it
/// still is one.
#[test]
fn a_bound_on_an_axis_the_data_does_not_excite_is_unidentifiable_not_a_misfit() {
    let (tr, _) = case_len(5, &[], 120.0, 60.0);
    let tr = Run::from_series(&tr, "train").unwrap();
    let runs = std::slice::from_ref(&tr);
    let m = LabModel::default_base(BaseKind::Model3).unwrap();
    let mut cal = calibrate(
        &m,
        runs,
        &LmOptions {
            max_iter: 3,
            threads: 1,
            ..Default::default()
        },
    )
    .unwrap();
    // The Pro 4 records depth, heading, pitch and roll: nothing measures sway, while the
    // heave axis moves.
    assert_eq!(
        axis_excitation(runs, Axis::Sway),
        AxisExcitation::Unmeasured
    );
    assert_eq!(axis_excitation(runs, Axis::Heave), AxisExcitation::Excited);
    let sway = Param::AddedMass(Axis::Sway);
    let heave = Param::DragLin(Axis::Heave);
    assert!(cal.params.contains(&sway) && cal.params.contains(&heave));
    cal.model = cal.model.with(&[sway, heave], &[0.0, 0.0]).unwrap();
    let notes = calibration_notes(&cal, runs);
    let note = |key: &str| {
        notes
            .iter()
            .find(|n| n.starts_with(key))
            .cloned()
            .unwrap_or_else(|| panic!("no note on {key}: {notes:?}"))
    };
    let s = note("added_mass_sway");
    assert!(s.contains("unidentifiable from this data"), "{s}");
    assert!(s.contains("sway axis"), "{s}");
    assert!(!s.contains("sign of a structural misfit"), "{s}");
    let h = note("drag_linear_heave");
    assert!(h.contains("sign of a structural misfit"), "{h}");
}

/// Design aid: diagnoses two exported station dives (`VERDICT_A`, `VERDICT_B`: CSVs from
/// `topside export --csv` of `topside record --sim --fast`) and prints the channel tests.
#[test]
#[ignore = "design aid: needs two exported dives; prints, asserts nothing"]
fn exp_station_dive() {
    let (Ok(a), Ok(b)) = (std::env::var("VERDICT_A"), std::env::var("VERDICT_B")) else {
        return;
    };
    let read =
        |p: &str| rov_lab::ingest::runs_from_text(&std::fs::read_to_string(p).unwrap(), p).unwrap();
    let (tr, va) = (read(&a), read(&b));
    let m = LabModel::default_base(BaseKind::Model3).unwrap();
    let t = std::time::Instant::now();
    let d = rov_lab::diagnose::diagnose(
        &m,
        "model3",
        &tr,
        &va,
        &rov_lab::diagnose::DiagnoseOptions {
            threads: 1,
            ..Default::default()
        },
    )
    .unwrap();
    println!("{:?}: {}", t.elapsed(), d.summary);
    for c in &d.consistency {
        println!(
            "  {:10} rmse {:.4} noise {:.4} spread {:.4} ratio {:.2} level {:.3}/{:.3} consistent {}",
            c.channel,
            c.rmse,
            c.noise,
            c.param_spread,
            c.ratio,
            c.level,
            c.level_critical,
            c.consistent
        );
    }
    for n in &d.calibration_notes {
        println!("  note: {n}");
    }
}

/// The GUI's synthetic case (crates/rov_gui/tests/it/gui.rs): model3 in the simulator with
/// the vertical thruster 25 mm forward of the CO, stepped thrust of both signs, 180 s at
/// 10 Hz, split two thirds / one third as the lab tab splits it.
fn gui_case() -> (Run, Run) {
    use rov_dynamics::models::{Model3, load_default_model};
    use rov_dynamics::thrusters::{ThrustPct, ThrusterGeometry};
    let base = load_default_model("model3").unwrap();
    let mut p = *base.as_any().downcast_ref::<Model3>().unwrap().params();
    let g = p.thrusters.vertical.geometry;
    let pos = g.position_m();
    p.thrusters.vertical.geometry =
        ThrusterGeometry::new(nalgebra::Vector3::new(0.025, pos.y, pos.z), g.direction()).unwrap();
    let mut cfg = rov_sim::SimConfig::with_model(Box::new(Model3::new(p).unwrap()));
    cfg.initial = rov_dynamics::InitialConditions::at_rest(3.0, 0.0);
    let mut sim = rov_sim::Simulator::new(cfg, 7).unwrap();
    let block: Vec<(f64, ThrustPct)> = vec![
        (5.0, ThrustPct::new(0.0, 0.0, 0.0)),
        (8.0, ThrustPct::new(0.0, 0.0, 40.0)),
        (8.0, ThrustPct::new(0.0, 0.0, -40.0)),
        (8.0, ThrustPct::new(30.0, -30.0, 0.0)),
        (8.0, ThrustPct::new(-30.0, 30.0, 0.0)),
        (8.0, ThrustPct::new(0.0, 0.0, 60.0)),
        (8.0, ThrustPct::new(40.0, 40.0, -20.0)),
        (8.0, ThrustPct::new(0.0, 0.0, -60.0)),
        (8.0, ThrustPct::new(20.0, -20.0, 30.0)),
        (8.0, ThrustPct::new(0.0, 0.0, 0.0)),
        (8.0, ThrustPct::new(-20.0, 20.0, -30.0)),
    ];
    let mut holds = block.clone();
    holds.extend(block.iter().map(|(d, c)| {
        (
            *d,
            ThrustPct::new(c.port * 0.7, c.starboard * 0.7, c.vertical * 0.7),
        )
    }));
    let schedule = rov_sim::Schedule::from_holds(&holds).unwrap();
    let sensors = rov_dynamics::sensors::SensorConfig::default();
    let series = rov_sim::run_schedule_on(&mut sim, &sensors, &schedule, 0.1).unwrap();
    let cut = series.rows.len() * 2 / 3;
    let (mut a, mut b) = (series.clone(), series);
    a.rows.truncate(cut);
    b.rows.drain(..cut);
    (
        Run::from_series(&a, "train").unwrap(),
        Run::from_series(&b, "held out").unwrap(),
    )
}

/// Issue 13 §5: a finding that makes another excited channel worse beyond its noise in
/// either view is never accepted silently. In the GUI's synthetic case the moment arm is
/// the hidden truth and is found; every channel it leaves worse beyond its noise in one
/// view is among its conflicts, and an accepted finding's conflict is in the summary.
#[test]
fn a_finding_that_worsens_another_channel_is_reported_as_a_conflict() {
    let (tr, va) = gui_case();
    let m = LabModel::default_base(BaseKind::Model3).unwrap();
    let d = rov_lab::diagnose::diagnose(
        &m,
        "model3",
        std::slice::from_ref(&tr),
        std::slice::from_ref(&va),
        &rov_lab::diagnose::DiagnoseOptions {
            threads: 2,
            ..Default::default()
        },
    )
    .unwrap();
    eprintln!("{}", d.summary);
    let f = &d.findings[0];
    assert_eq!(f.effect, "thruster-moment-arm", "{}", d.summary);
    eprintln!(
        "shooting {:?}\nfree run {:?}\nconflicts {:?}",
        f.validation_rmse_reduction_pct_shooting,
        f.validation_rmse_reduction_pct_free_run,
        f.conflicts
    );
    let mut any = false;
    for (ch, b) in &d.baseline {
        for (view, red, rmse_base) in [
            (
                "multiple-shooting",
                &f.validation_rmse_reduction_pct_shooting,
                b.rmse_shooting,
            ),
            (
                "free run",
                &f.validation_rmse_reduction_pct_free_run,
                b.rmse_free_run,
            ),
        ] {
            let Some(r) = red.get(ch) else { continue };
            let after = rmse_base * (1.0 - r / 100.0);
            // Worse by more than 5 % and by more than the noise floor itself: whatever
            // the prediction change, that is beyond noise.
            if *r < -5.0 && after - rmse_base > b.noise && after > 1.3 * b.noise {
                any = true;
                assert!(
                    f.conflicts
                        .iter()
                        .any(|c| c.starts_with(ch.as_str()) && c.contains(view)),
                    "{ch} {r:.0} % in the {view} view, not among the conflicts {:?}",
                    f.conflicts
                );
            }
        }
    }
    if f.significant && !f.conflicts.is_empty() {
        assert!(
            d.summary.contains("accepted with a conflict"),
            "{}",
            d.summary
        );
    }
    eprintln!("a channel worse beyond its noise: {any}");
}
