//! E2 crash survival with a real child process killed by SIGKILL mid-recording.
//!
//! The child is this test binary re-run with `ROV_SESSION_SIGKILL_CHILD=PATH`: it records
//! every topic at 50 Hz of wall time and prints `TICK k t_ns` once a tick has been handed
//! to the writer. The parent kills it (`Child::kill` is SIGKILL on Unix) at a random time,
//! then checks that the file loads with at most the last 0.5 s of reported ticks missing,
//! that what loads is a gap-free prefix, and that `recover` writes a file the official
//! Python reader opens.

use crate::common;

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::common::{python_read, tick, write_tick};
use rov_session::{Damage, NavRecord, SessionWriter, open, recover};

const CHILD_ENV: &str = "ROV_SESSION_SIGKILL_CHILD";

/// Not a test on its own: the body of the child process (returns at once otherwise).
#[test]
fn sigkill_child_recorder() {
    let Ok(path) = std::env::var(CHILD_ENV) else {
        return;
    };
    let start = Instant::now();
    let mut w = SessionWriter::create(&path, &common::info(), 0).expect("create");
    for k in 0u64.. {
        let due = start + Duration::from_millis(20 * k);
        if let Some(wait) = due.checked_duration_since(Instant::now()) {
            std::thread::sleep(wait);
        }
        let mut tk = tick(k);
        tk.t_ns = start.elapsed().as_nanos() as u64;
        write_tick(&mut w, &tk).expect("write");
        // The nav message of this tick is at t_ns + 6 ms (see write_tick).
        println!("TICK {k} {}", tk.t_ns + 6_000_000);
    }
}

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
}

#[test]
fn sigkill_loses_at_most_half_a_second() {
    let seed = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_nanos() as u64
        | 1;
    eprintln!("sigkill test seed {seed}");
    let mut rng = Rng(seed);
    let exe = std::env::current_exe().unwrap();
    let dir = tempfile::tempdir().unwrap();
    for run in 0..4 {
        let path = dir.path().join(format!("killed-{run}.mcap"));
        let mut child = Command::new(&exe)
            .args([
                "sigkill::sigkill_child_recorder",
                "--exact",
                "--nocapture",
                "--test-threads=1",
            ])
            .env(CHILD_ENV, &path)
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let stdout = child.stdout.take().unwrap();
        let reader = std::thread::spawn(move || {
            BufReader::new(stdout)
                .lines()
                .map_while(Result::ok)
                .filter_map(|l| {
                    // libtest may print "test NAME ... " on the same line first.
                    let at = l.find("TICK ")?;
                    let mut it = l.get(at + 5..)?.split(' ');
                    let k: u64 = it.next()?.parse().ok()?;
                    let t: u64 = it.next()?.parse().ok()?;
                    Some((k, t))
                })
                .collect::<Vec<_>>()
        });
        let kill_after = Duration::from_millis(600 + rng.next() % 1400);
        std::thread::sleep(kill_after);
        child.kill().unwrap();
        child.wait().unwrap();
        let reported = reader.join().unwrap();
        assert!(
            reported.len() > 10,
            "run {run}: the child reported only {} ticks",
            reported.len()
        );
        let &(last_k, last_t) = reported.last().unwrap();

        let s = open(&path).unwrap();
        assert!(
            matches!(s.damage(), Some(Damage::Truncated { .. })),
            "run {run}: a killed recording has no footer: {:?}",
            s.damage()
        );
        let nav = s.records::<NavRecord>().unwrap();
        // Gap-free prefix of the ticks, each exactly as written.
        for (k, (_, rec)) in nav.iter().enumerate() {
            assert_eq!(*rec, tick(k as u64).nav, "run {run}: tick {k}");
        }
        let recovered_t = nav.last().map_or(0, |(t, _)| *t);
        for &(k, t) in &reported {
            if t + 500_000_000 <= last_t {
                assert!(
                    (k as usize) < nav.len(),
                    "run {run}: tick {k} at {t} ns reported but lost"
                );
            }
        }
        let lost_s = (last_t.saturating_sub(recovered_t)) as f64 * 1e-9;
        eprintln!(
            "run {run}: killed after {kill_after:?}; reported {} ticks (last {last_k}), recovered {}; \
             lost the last {lost_s:.3} s",
            reported.len(),
            nav.len()
        );
        assert!(lost_s <= 0.5, "run {run}: lost {lost_s} s");

        let report = recover(&path).unwrap();
        assert_eq!(report.messages_recovered, s.len() as u64);
        let again = open(&report.output).unwrap();
        assert!(again.is_complete());
        assert_eq!(again.len(), s.len());
        let py = python_read(&report.output);
        assert_eq!(py["counts"]["/telemetry/nav"], nav.len() as u64);
        assert_eq!(py["summary_messages"], s.len() as u64);
    }
}
