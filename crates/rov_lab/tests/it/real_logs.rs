//! Real-log treatment (issue 13, part 4) on logs from the test generator: a closed-loop
//! dive (depth and heading autopilot on the measured outputs) sampled with jittered
//! intervals, with isolated depth and heading spikes and a 3-second gap. The artefacts
//! (the messy CSVs) are written to `$CARGO_TARGET_TMPDIR/real_logs/` for the CLI and a look.

use crate::common;

use common::{closed_loop_run, mess_up};
use rov_dynamics::models::Channel;
use rov_lab::diagnose::{DiagnoseOptions, diagnose};
use rov_lab::ingest::{runs_from_text, treatment_sentences};
use rov_lab::{BaseKind, LabModel};

fn artefact(name: &str, text: &str) -> std::path::PathBuf {
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("real_logs");
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn a_messy_closed_loop_dive_is_treated_and_every_treatment_reported() {
    let mut train = closed_loop_run(5, 5, &[], 420.0);
    let mut val = closed_loop_run(5, 6, &[], 240.0);
    mess_up(&mut train, 1, 2, 3, Some((200.0, 3.0)));
    mess_up(&mut val, 2, 1, 2, None);
    let (tr_text, va_text) = (train.to_csv(), val.to_csv());
    artefact("closed_loop_messy_train.csv", &tr_text);
    artefact("closed_loop_messy_val.csv", &va_text);

    let tr = runs_from_text(&tr_text, "train.csv").unwrap();
    let va = runs_from_text(&va_text, "val.csv").unwrap();
    // The gap splits the training log in two; the held-out log stays whole.
    assert_eq!(
        tr.len(),
        2,
        "{:?}",
        tr.iter().map(|r| r.len()).collect::<Vec<_>>()
    );
    assert_eq!(va.len(), 1);
    assert_eq!(tr[0].treatment.gaps.len(), 1);
    let (t_before, len) = tr[0].treatment.gaps[0];
    assert!(
        (199.0..201.0).contains(&t_before) && (2.9..3.2).contains(&len),
        "{t_before} {len}"
    );
    // Real intervals: the runs keep the jitter (40–60 ms) instead of a nominal rate.
    let (_, dt_min, dt_max) = tr[0].treatment.dt_median_min_max_s;
    assert!(dt_min < 0.045 && dt_max > 0.055, "{dt_min} {dt_max}");
    let ts = &tr[0].t;
    assert!(ts.windows(2).any(|w| (w[1] - w[0] - 0.04).abs() < 1e-6));
    assert!(ts.windows(2).any(|w| (w[1] - w[0] - 0.06).abs() < 1e-6));
    // Every injected spike is found, and nothing else is called one.
    let spikes = |runs: &[rov_lab::Run], ch: Channel| -> usize {
        let i = rov_lab::data::ch_index(ch);
        runs.iter().map(|r| r.treatment.spikes[i]).sum()
    };
    assert_eq!(spikes(&tr, Channel::Depth), 2);
    assert_eq!(spikes(&tr, Channel::Heading), 3);
    assert_eq!(spikes(&va, Channel::Depth), 1);
    assert_eq!(spikes(&va, Channel::Heading), 2);
    let total: usize = tr
        .iter()
        .chain(&va)
        .map(|r| r.treatment.total_spikes())
        .sum();
    assert_eq!(total, 8);
    // The autopilot is recognised: its commands follow the measured outputs.
    for r in tr.iter().chain(&va) {
        assert!(r.treatment.closed_loop(), "{}", r.name);
    }
    // Said in words.
    let words = treatment_sentences(&tr).join(" ");
    assert!(words.contains("spike"), "{words}");
    assert!(words.contains("gap"), "{words}");
    assert!(words.contains("closed"), "{words}");

    // The diagnosis runs on it, says the data was closed-loop and what was done, and the
    // spikes do not reach the metrics: the truth is the (perturbed) base, so no channel
    // is far from its noise floor after calibration.
    let m = LabModel::default_base(BaseKind::Model3).unwrap();
    let d = diagnose(
        &m,
        "model3",
        &tr,
        &va,
        &DiagnoseOptions {
            threads: 2,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(d.closed_loop);
    let notes = d.data_notes.join(" ");
    assert!(notes.contains("spike") && notes.contains("gap"), "{notes}");
    for (ch, b) in &d.baseline {
        if ch == "depth" || ch == "heading" {
            assert!(
                b.rmse_shooting < 3.0 * b.noise,
                "{ch}: RMSE {} noise {} — spikes in the metrics? {}",
                b.rmse_shooting,
                b.noise,
                d.summary
            );
        }
    }
    assert!(
        d.accepted.is_empty() && d.accepted_terms.is_empty(),
        "{}",
        d.summary
    );
    // The spiked channels pass the verdict's consistency test: their spikes are out of
    // the metrics. (The verdict itself may still call roll and pitch rate 1.2-1.3 noise
    // floors off here: the truth's perturbed, uncalibrated roll/pitch parameters show
    // during this autopilot's 50 degree pitch excursions; see the issue-13 report.)
    for c in &d.consistency {
        if c.channel == "depth" || c.channel == "heading" {
            assert!(c.consistent, "{c:?}");
        }
    }
    assert!(d.unexplained.iter().all(|u| u.ratio < 2.0), "{}", d.summary);
}

#[test]
#[ignore = "design aid: prints the closed-loop detector's view of the generator; asserts nothing"]
fn exp_closed_loop_links() {
    let s = closed_loop_run(5, 5, &[], 240.0);
    let r = runs_from_text(&s.to_csv(), "x").unwrap();
    for run in &r {
        println!("{:?}", rov_lab::ingest::feedback_links(run));
        println!("{:?}", run.treatment.spikes);
    }
}

#[test]
#[ignore = "design aid"]
fn exp_spike_debug() {
    let clean = closed_loop_run(5, 6, &[], 240.0);
    let mut val = clean.clone();
    mess_up(&mut val, 2, 1, 2, None);
    for (k, (a, b)) in clean.rows.iter().zip(&val.rows).enumerate() {
        if a.heading_deg != b.heading_deg || a.depth_m != b.depth_m {
            let lo = k.saturating_sub(3);
            let h: Vec<String> = val.rows[lo..k + 4]
                .iter()
                .map(|r| {
                    format!(
                        "{:.2}/{:.0}/p{:.0}/r{:.0}",
                        r.heading_deg,
                        r.optional[0].unwrap_or(0.0),
                        r.pitch_deg,
                        r.roll_deg
                    )
                })
                .collect();
            println!("row {k}: {}", h.join(" "));
        }
    }
    let r = runs_from_text(&val.to_csv(), "x").unwrap();
    println!("{:?}", r[0].treatment.spikes);
    let pmax = clean
        .rows
        .iter()
        .map(|r| r.pitch_deg.abs())
        .fold(0.0, f64::max);
    let umax = clean
        .rows
        .iter()
        .filter_map(|r| r.optional[3])
        .fold(0.0, f64::max);
    println!("max |pitch| {pmax:.1} deg, max surge {umax:.2} m/s");
}
