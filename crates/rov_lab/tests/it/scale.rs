//! The lab at the size of real work: every core with the same answer, progress by stage,
//! and a Cancel that stops a diagnosis.

use crate::common;

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::{Hidden, case_len};
use rov_lab::diagnose::{DiagnoseOptions, diagnose};
use rov_lab::lab::{compare, diagnose_json};
use rov_lab::progress::Progress;
use rov_lab::{BaseKind, LabError, LabModel, Run};

fn runs(seed: u64, hidden: &[Hidden], tl: f64, vl: f64) -> (Run, Run) {
    let (tr, va) = case_len(seed, hidden, tl, vl);
    (
        Run::from_series(&tr, "train.csv").unwrap(),
        Run::from_series(&va, "val.csv").unwrap(),
    )
}

fn diagnosis_json(tr: &Run, va: &Run, threads: usize) -> String {
    let m = LabModel::default_base(BaseKind::Model3).unwrap();
    let d = diagnose(
        &m,
        "model3",
        std::slice::from_ref(tr),
        std::slice::from_ref(va),
        &DiagnoseOptions {
            threads,
            ..Default::default()
        },
    )
    .unwrap();
    serde_json::to_string_pretty(&diagnose_json(&d)).unwrap()
}

#[test]
fn the_diagnosis_json_is_the_same_on_one_and_four_threads() {
    // A hidden lag: calibration, screening, confirmations and the term search all run.
    let (tr, va) = runs(5, &[Hidden::Lag(0.2)], 240.0, 120.0);
    let t = Instant::now();
    let one = diagnosis_json(&tr, &va, 1);
    let t1 = t.elapsed();
    let four = diagnosis_json(&tr, &va, 4);
    eprintln!(
        "diagnosis wall: 1 thread {:.2} s, 4 threads {:.2} s",
        t1.as_secs_f64(),
        (t.elapsed() - t1).as_secs_f64()
    );
    assert!(one.contains("\"findings\""), "{one}");
    if one != four {
        let at = one
            .lines()
            .zip(four.lines())
            .position(|(a, b)| a != b)
            .unwrap_or(0);
        let show = |s: &str| {
            s.lines()
                .skip(at.saturating_sub(3))
                .take(8)
                .collect::<Vec<_>>()
                .join("\n")
        };
        panic!(
            "1 and 4 threads differ at line {at}:\n{}\n---\n{}",
            show(&one),
            show(&four)
        );
    }
    // The comparison too (its effects are fitted: the LM's parallel Jacobian).
    let m = LabModel::default_base(BaseKind::Model3).unwrap();
    let effects = [rov_lab::EffectId::ThrusterLag];
    let c1 = compare(&m, "model3", std::slice::from_ref(&tr), &effects, 1).unwrap();
    let c4 = compare(&m, "model3", std::slice::from_ref(&tr), &effects, 4).unwrap();
    assert_eq!(
        serde_json::to_string(&c1).unwrap(),
        serde_json::to_string(&c4).unwrap()
    );
}

#[test]
fn leave_one_session_out_is_the_same_on_one_and_three_threads() {
    // Three sessions, each held out on its own worker.
    let sessions: Vec<Run> = (0..3)
        .map(|i| {
            let (tr, _) = case_len(30 + i, &[Hidden::Lag(0.2)], 120.0, 30.0);
            Run::from_series(&tr, &format!("s{i}.csv")).unwrap()
        })
        .collect();
    let m = LabModel::default_base(BaseKind::Model3).unwrap();
    let cv = |threads: usize| {
        let opts = rov_lab::lm::LmOptions {
            threads,
            max_iter: 4,
            ..Default::default()
        };
        let cv =
            rov_lab::cross_validate::leave_one_session_out(&m, &sessions, &opts, 20.0).unwrap();
        assert_eq!(cv.sessions.len(), 3);
        serde_json::to_string(&cv).unwrap()
    };
    assert_eq!(cv(1), cv(3));
}

#[test]
fn a_diagnosis_reports_its_stages_and_stops_when_cancelled() {
    let (tr, va) = runs(6, &[Hidden::Lag(0.2)], 240.0, 120.0);
    let seen: Arc<Mutex<Vec<String>>> = Arc::default();
    let s2 = Arc::clone(&seen);
    let progress = Progress::with_sink(move |s| {
        let mut v = s2.lock().unwrap();
        if v.last() != Some(&s.name) {
            v.push(s.name.clone());
        }
    });
    let p = progress.clone();
    let worker = std::thread::spawn(move || {
        let m = LabModel::default_base(BaseKind::Model3).unwrap();
        let out = p.run(|| {
            diagnose(
                &m,
                "model3",
                std::slice::from_ref(&tr),
                std::slice::from_ref(&va),
                &DiagnoseOptions {
                    threads: 2,
                    ..Default::default()
                },
            )
        });
        (out.map(|d| d.summary), Instant::now())
    });
    // Wait for the candidates' confirmation (after calibration and screening), then cancel.
    let t0 = Instant::now();
    while progress.latest().is_none_or(|s| s.name != "confirming") {
        assert!(
            t0.elapsed() < Duration::from_secs(300) && !worker.is_finished(),
            "no confirmation stage: {:?}",
            seen.lock().unwrap()
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    let cancelled_at = Instant::now();
    progress.cancel();
    let (out, ended_at) = worker.join().unwrap();
    assert_eq!(out, Err(LabError::Cancelled));
    let stop = ended_at.duration_since(cancelled_at);
    eprintln!("stopped {:.0} ms after Cancel", stop.as_secs_f64() * 1e3);
    // The acceptance is one second on the release build; a loaded test machine gets slack.
    assert!(stop < Duration::from_secs(3), "{stop:?}");
    let seen = seen.lock().unwrap().clone();
    for stage in ["calibrating", "screening", "confirming"] {
        assert!(seen.iter().any(|s| s == stage), "{stage}: {seen:?}");
    }
}

/// Resident and peak memory of this process, MB (Linux; `None` elsewhere).
fn rss_mb() -> Option<(f64, f64)> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let field = |k: &str| -> Option<f64> {
        let l = s.lines().find(|l| l.starts_with(k))?;
        let kb: f64 = l.split_whitespace().nth(1)?.parse().ok()?;
        Some(kb / 1024.0)
    };
    Some((field("VmRSS:")?, field("VmHWM:")?))
}

/// Where a long diagnosis spends its memory and time, by stage: `LAB_TRAIN_MIN` minutes
/// of training and a third of that held out (default 60), 20 Hz, a hidden lag.
/// `cargo test -p rov_lab --test it scale::exp_memory_by_stage -- --ignored --nocapture`
#[test]
#[ignore = "experiment: minutes of work and gigabytes"]
fn exp_memory_by_stage() {
    let minutes: f64 = std::env::var("LAB_TRAIN_MIN")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(60.0);
    let (tr, va) = runs(9, &[Hidden::Lag(0.2)], minutes * 60.0, minutes * 20.0);
    let before = rss_mb().unwrap_or_default();
    let t0 = Instant::now();
    // (stage, start s, peak RSS MB during it): a sampler thread reads the RSS every 10 ms
    // and charges it to the stage in progress (progress events alone miss the peaks
    // between them).
    let log: Arc<Mutex<Vec<(String, f64, f64)>>> = Arc::default();
    let l2 = Arc::clone(&log);
    let progress = Progress::with_sink(move |s| {
        let mut v = l2.lock().unwrap();
        let (rss, _) = rss_mb().unwrap_or_default();
        match v.last_mut() {
            Some(last) if last.0 == s.name => last.2 = last.2.max(rss),
            _ => v.push((s.name.clone(), t0.elapsed().as_secs_f64(), rss)),
        }
    });
    let done = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let sampler = {
        let (log, done) = (Arc::clone(&log), Arc::clone(&done));
        std::thread::spawn(move || {
            while !done.load(std::sync::atomic::Ordering::Relaxed) {
                let (rss, _) = rss_mb().unwrap_or_default();
                if let Some(last) = log.lock().unwrap().last_mut() {
                    last.2 = last.2.max(rss);
                }
                std::thread::sleep(Duration::from_millis(10));
            }
        })
    };
    let m = LabModel::default_base(BaseKind::Model3).unwrap();
    let d = progress
        .run(|| {
            diagnose(
                &m,
                "model3",
                std::slice::from_ref(&tr),
                std::slice::from_ref(&va),
                &DiagnoseOptions::default(),
            )
        })
        .unwrap();
    done.store(true, std::sync::atomic::Ordering::Relaxed);
    sampler.join().unwrap();
    let after = rss_mb().unwrap_or_default();
    eprintln!(
        "{minutes} min + {:.0} min: {:.1} s wall, RSS before {:.0} MB, peak {:.0} MB; {}",
        minutes / 3.0,
        t0.elapsed().as_secs_f64(),
        before.0,
        after.1,
        d.summary
    );
    for (name, at, rss) in log.lock().unwrap().iter() {
        eprintln!("  {at:7.1} s  peak {rss:6.0} MB  {name}");
    }
}
