//! Playback: play/pause, speed, seek and step on wall time given as an argument.

use crate::common::record;
use rov_session::{MAX_SPEED, MIN_SPEED, Playback, Session, WriterOptions, open};

fn session(ticks: u64) -> (tempfile::TempDir, Session) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.mcap");
    record(&path, ticks, WriterOptions::default());
    let s = open(&path).unwrap();
    (dir, s)
}

#[test]
fn plays_every_message_once_in_time_order_at_the_given_speed() {
    let (_d, s) = session(250); // 5 s
    let all: Vec<u64> = s.messages().map(|m| m.t_ns).collect();
    let mut p = Playback::new(s.clone());
    assert!(!p.is_playing());
    assert_eq!(p.speed(), 1.0);
    assert!(p.advance(1.0).is_empty(), "paused: nothing");
    p.play();
    let first = p.advance(0.1);
    assert!(!first.is_empty());
    assert!(first.iter().all(|m| m.t_ns < 100_000_000));
    assert_eq!(
        first.len(),
        all.iter().filter(|&&t| t < 100_000_000).count()
    );
    assert!((p.position_s() - 0.1).abs() < 1e-12);
    let mut seen: Vec<u64> = first.iter().map(|m| m.t_ns).collect();
    assert_eq!(p.set_speed(10.0), 10.0);
    let fast = p.advance(0.1); // 1 s of session time
    assert!((p.position_s() - 1.1).abs() < 1e-9);
    assert!(
        fast.iter()
            .all(|m| m.t_ns >= 100_000_000 && m.t_ns < 1_100_000_000)
    );
    seen.extend(fast.iter().map(|m| m.t_ns));
    while p.is_playing() {
        seen.extend(p.advance(0.016).iter().map(|m| m.t_ns));
    }
    assert!(p.at_end());
    assert_eq!(seen, all, "every message exactly once, in order");
    assert!((p.position_s() - p.duration_s()).abs() < 1e-12);
    assert!(p.advance(1.0).is_empty());
    assert_eq!(p.emitted(), all.len() as u64);
    p.play(); // from the end: starts over
    assert_eq!(p.emitted(), 0);
    assert_eq!(p.position_s(), 0.0);
    assert!(p.is_playing());
    assert_eq!(
        p.advance(0.01).first().map(|m| m.t_ns),
        all.first().copied()
    );
}

#[test]
fn speed_is_clamped() {
    let (_d, s) = session(10);
    let mut p = Playback::new(s);
    assert_eq!(p.set_speed(1000.0), MAX_SPEED);
    assert_eq!(p.set_speed(0.0), MIN_SPEED);
    assert_eq!(p.set_speed(-3.0), MIN_SPEED);
    assert_eq!(p.set_speed(f64::NAN), MIN_SPEED, "non-finite is ignored");
    assert_eq!(p.set_speed(2.5), 2.5);
    p.play();
    assert!(p.advance(f64::INFINITY).is_empty());
    assert!(p.advance(-1.0).is_empty());
}

#[test]
fn seek_and_step() {
    let (_d, s) = session(250);
    let all: Vec<u64> = s.messages().map(|m| m.t_ns).collect();
    let mut p = Playback::new(s.clone());
    p.seek(2.0);
    assert_eq!(p.position_s(), 2.0);
    assert!(p.advance(0.5).is_empty(), "seek does not start playback");
    // State at the new position: the latest message of each topic before it.
    let latest = p.latest_before();
    assert_eq!(latest.len(), s.topics().len());
    assert!(latest.iter().all(|m| m.t_ns < 2_000_000_000));
    assert!(latest.iter().any(|m| m.topic() == "/session/info"));
    let nav = latest
        .iter()
        .find(|m| m.topic() == "/telemetry/nav")
        .unwrap();
    assert_eq!(nav.t_ns, 1_986_000_000);
    // Step: one message at a time, pausing, position following the message.
    p.play();
    let a = p.step().unwrap().t_ns;
    assert!(!p.is_playing());
    assert_eq!(a, *all.iter().find(|&&t| t >= 2_000_000_000).unwrap());
    let b = p.step().unwrap().t_ns;
    assert!(b >= a);
    assert!((p.position_s() - (b as f64 * 1e-9)).abs() < 1e-9);
    // Play on from there: no message is repeated.
    p.play();
    let more = p.advance(0.02);
    assert!(!more.is_empty());
    assert!(more.iter().all(|m| m.t_ns >= b));
    assert_eq!(
        p.emitted() as usize,
        2 + more.len(),
        "every message once since the seek"
    );
    // Clamped seeks.
    p.seek(-5.0);
    assert_eq!((p.position_s(), p.emitted()), (0.0, 0));
    assert_eq!(p.step().map(|m| m.t_ns), all.first().copied());
    p.seek(1e9);
    assert_eq!(p.position_s(), p.duration_s());
    let last = p.step().unwrap();
    assert_eq!(
        Some(last.t_ns),
        s.end_ns(),
        "the last message is at the end position"
    );
    assert!(p.at_end());
    assert!(p.step().is_none());
    p.seek(f64::NAN);
    assert_eq!(p.position_s(), 0.0);
}

/// A long session plays and seeks chunk by chunk: only the chunks around the position are
/// read, and seeking far back and forth returns the same messages as a full read.
#[test]
fn seeks_read_only_what_they_need() {
    let (_d, s) = session(50 * 120); // 2 min, many chunks
    assert!(s.chunk_count() > 100, "{}", s.chunk_count());
    let all: Vec<u64> = s.messages().map(|m| m.t_ns).collect();
    let mut p = Playback::new(s.clone());
    for t in [100.0, 3.0, 77.7, 0.0, 119.0] {
        p.seek(t);
        p.play();
        let got: Vec<u64> = p.advance(0.5).iter().map(|m| m.t_ns).collect();
        let from = (t * 1e9) as u64;
        let want: Vec<u64> = all
            .iter()
            .copied()
            .filter(|&x| x >= from && (x as f64) < from as f64 + 0.5e9)
            .collect();
        assert_eq!(got, want, "seek to {t}");
    }
}
