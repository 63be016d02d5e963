//! Soak on virtual time: hours of a dive through the whole station (`VirtualStation`: the
//! simulated Pro 4 behind the real link, the control loop, failsafes, recorder thread and
//! session writer), with the resident memory sampled every simulated interval, the
//! control ticks counted, and the finished session read back complete.
//!
//! `soak_twenty_minutes` runs in CI. `soak_eight_hours` is the 8-hour figure
//! (about four minutes here); run it with
//! `cargo test --release -p rov_station --test it soak:: -- --ignored --nocapture`.

use std::path::Path;
use std::time::Instant;

use rov_control::ModeCommand;
use rov_station::StationCommand;
use rov_station::runtime::{RuntimeConfig, StationHandle, VirtualStation};

/// A file in the system's temporary directory, unique to this process.
fn scratch(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("rov_station_soak_{}_{name}", std::process::id()))
}

/// Resident set size of this process, kB (Linux; 0 elsewhere).
fn rss_kb() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmRSS:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|v| v.parse().ok())
        })
        .unwrap_or(0)
}

/// What a soak measured.
struct Soak {
    /// (simulated hours, RSS kB) at each sample.
    rss: Vec<(f64, u64)>,
    ticks: u64,
    expected_ticks: u64,
    missed: u64,
    late_ticks: u64,
    dropped: u64,
    wall_s: f64,
}

/// Arms, then flies a pattern that keeps everything moving: depth and heading holds with
/// a new setpoint every 5 minutes.
fn pilot(h: &StationHandle, t_s: f64, last_arm: &mut f64) {
    if !h.snapshot().armed && t_s - *last_arm >= 0.25 {
        *last_arm = t_s;
        h.send(StationCommand::Arm);
    }
    let period = 300.0;
    let k = (t_s / period).floor();
    if (t_s - k * period) < 0.02 {
        let depth_m = 2.0 + (k % 4.0);
        let heading_deg = (k * 70.0) % 360.0;
        h.send(StationCommand::Mode(ModeCommand::SetDepth { depth_m }));
        h.send(StationCommand::Mode(ModeCommand::SetHeading {
            heading_deg,
        }));
    }
}

fn soak(path: &Path, hours: f64, sample_every_s: f64) -> Soak {
    let cfg = RuntimeConfig {
        gamepad: false,
        ..RuntimeConfig::default()
    };
    let (mut st, h) = VirtualStation::new(cfg).unwrap();
    h.start_recording(path);
    let wall = Instant::now();
    let period_us = h.tick_stats().period_us;
    let t0_us = st.now_us();
    let end_s = hours * 3600.0;
    let mut rss = vec![(0.0, rss_kb())];
    let mut last_arm = f64::NEG_INFINITY;
    let mut next_sample = sample_every_s;
    let ticks0 = h.tick_stats().ticks;
    let mut t_s = 0.0;
    while t_s < end_s {
        pilot(&h, t_s, &mut last_arm);
        t_s += 0.02;
        st.advance_to(t0_us + (t_s * 1e6).round() as u64).unwrap();
        if t_s >= next_sample - 1e-9 {
            next_sample += sample_every_s;
            rss.push((t_s / 3600.0, rss_kb()));
        }
    }
    let stats = h.tick_stats();
    h.send(StationCommand::Disarm);
    st.advance(0.1).unwrap();
    let dropped = h.view().recording.dropped;
    st.finish();
    h.shutdown();
    Soak {
        rss,
        ticks: stats.ticks - ticks0,
        expected_ticks: (end_s * 1e6 / period_us as f64).round() as u64,
        missed: stats.missed,
        late_ticks: stats.late_ticks,
        dropped,
        wall_s: wall.elapsed().as_secs_f64(),
    }
}

/// The finished session: complete, every chunk good, nav at the control rate without a gap,
/// the pose topics there.
fn check_session(path: &Path, hours: f64) {
    let s = rov_session::open(path).unwrap();
    assert!(s.is_complete(), "{:?}", s.damage());
    assert!(
        s.is_indexed(),
        "a finished recording opens through its summary"
    );
    let nav = s.count("/telemetry/nav") as f64;
    let expected = hours * 3600.0 * 50.0;
    assert!(
        (nav - expected).abs() < 100.0,
        "{nav} nav records for {expected} ticks"
    );
    assert!(s.count("/tf") as f64 > hours * 3600.0 * 9.0);
    let report = s.check();
    assert!(report.damage.is_none(), "{:?}", report.damage);
    assert_eq!(report.messages, s.len() as u64);
    for w in &report.warnings {
        assert!(
            !w.contains("/telemetry/nav") && !w.contains("/command/thrust"),
            "{w}"
        );
    }
}

fn print(s: &Soak, hours: f64) {
    eprintln!(
        "soak {hours} h: {} ticks of {} expected, {} missed, {} late, {} recorder drops, {:.1} s wall",
        s.ticks, s.expected_ticks, s.missed, s.late_ticks, s.dropped, s.wall_s
    );
    for (h, kb) in &s.rss {
        eprintln!("  t = {h:5.2} h  RSS {:7.1} MB", *kb as f64 / 1024.0);
    }
}

fn assert_soak(s: &Soak, max_growth_kb: u64) {
    assert_eq!(s.missed, 0, "missed ticks");
    assert_eq!(s.late_ticks, 0, "late ticks");
    // Both ends of the interval tick.
    assert!(
        s.ticks.abs_diff(s.expected_ticks) <= 2,
        "{} ticks, {} expected",
        s.ticks,
        s.expected_ticks
    );
    assert_eq!(s.dropped, 0, "the recorder dropped messages");
    // Memory is flat once the first interval has filled the bounded buffers.
    let base = s.rss.get(1).map_or(0, |r| r.1);
    let last = s.rss.last().map_or(0, |r| r.1);
    assert!(
        last <= base + max_growth_kb,
        "RSS grew from {base} kB to {last} kB"
    );
}

#[test]
fn soak_twenty_minutes() {
    let _alone = crate::one_at_a_time();
    let path = scratch("soak20.mcap");
    let hours = 20.0 / 60.0;
    let s = soak(&path, hours, 300.0);
    print(&s, hours);
    check_session(&path, hours);
    assert_soak(&s, 8 * 1024);
    let _ = std::fs::remove_file(&path);
}

#[test]
#[ignore = "8 hours of virtual time: minutes of wall time; run with --ignored --nocapture"]
fn soak_eight_hours() {
    let _alone = crate::one_at_a_time();
    let path = scratch("soak8h.mcap");
    let s = soak(&path, 8.0, 3600.0);
    print(&s, 8.0);
    let size = std::fs::metadata(&path).map_or(0, |m| m.len());
    eprintln!("  session file {:.0} MB", size as f64 / 1e6);
    check_session(&path, 8.0);
    assert_soak(&s, 10 * 1024);
    let _ = std::fs::remove_file(&path);
}
