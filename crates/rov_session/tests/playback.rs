//! Playback: play/pause, speed, seek and step on wall time given as an argument.

mod common;

use std::sync::Arc;

use common::record;
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
    let mut p = Playback::new(&s);
    assert!(!p.is_playing());
    assert_eq!(p.speed(), 1.0);
    assert!(p.advance_messages(1.0).is_empty(), "paused: nothing");
    p.play();
    let first = p.advance_messages(0.1);
    assert!(!first.is_empty());
    assert!(first.iter().all(|m| m.t_ns < 100_000_000));
    assert_eq!(
        first.len(),
        all.iter().filter(|&&t| t < 100_000_000).count()
    );
    assert!((p.position_s() - 0.1).abs() < 1e-12);
    let mut seen: Vec<u64> = first.iter().map(|m| m.t_ns).collect();
    assert_eq!(p.set_speed(10.0), 10.0);
    let fast = p.advance_messages(0.1); // 1 s of session time
    assert!((p.position_s() - 1.1).abs() < 1e-9);
    assert!(
        fast.iter()
            .all(|m| m.t_ns >= 100_000_000 && m.t_ns < 1_100_000_000)
    );
    seen.extend(fast.iter().map(|m| m.t_ns));
    while p.is_playing() {
        seen.extend(p.advance_messages(0.016).iter().map(|m| m.t_ns));
    }
    assert!(p.at_end());
    assert_eq!(seen, all, "every message exactly once, in order");
    assert!((p.position_s() - p.duration_s()).abs() < 1e-12);
    assert!(p.advance(1.0).is_empty());
    p.play(); // from the end: starts over
    assert_eq!(p.cursor(), 0);
    assert!(p.is_playing());
}

#[test]
fn speed_is_clamped() {
    let (_d, s) = session(10);
    let mut p = Playback::new(&s);
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
    let s = Arc::new(s);
    let mut p = Playback::new(Arc::clone(&s));
    p.seek(2.0);
    assert_eq!(p.position_s(), 2.0);
    let next = s.message(p.cursor()).unwrap();
    assert!(next.t_ns >= 2_000_000_000);
    assert!(s.message(p.cursor() - 1).unwrap().t_ns < 2_000_000_000);
    assert!(p.advance(0.5).is_empty(), "seek does not start playback");
    // State at the new position: the latest message of each topic before it.
    let latest = p.latest_before();
    assert_eq!(latest.len(), s.topics().len());
    assert!(latest.iter().all(|m| m.t_ns < 2_000_000_000));
    assert!(latest.iter().any(|m| m.topic == "/session/info"));
    let nav = latest.iter().find(|m| m.topic == "/telemetry/nav").unwrap();
    assert_eq!(nav.t_ns, 1_986_000_000);
    // Step: one message at a time, pausing, position following the message.
    p.play();
    let a = s.message(p.step().unwrap()).unwrap().t_ns;
    assert!(!p.is_playing());
    assert_eq!(a, next.t_ns);
    let b = s.message(p.step().unwrap()).unwrap().t_ns;
    assert!(b >= a);
    assert!((p.position_s() - (b as f64 * 1e-9)).abs() < 1e-9);
    // Play on from there: no message is repeated.
    p.play();
    let more = p.advance(0.02);
    assert!(!more.is_empty());
    assert!(p.messages(more).iter().all(|m| m.t_ns >= b));
    // Clamped seeks.
    p.seek(-5.0);
    assert_eq!((p.position_s(), p.cursor()), (0.0, 0));
    p.seek(1e9);
    assert_eq!(p.position_s(), p.duration_s());
    let last = s.message(p.step().unwrap()).unwrap();
    assert_eq!(
        Some(last.t_ns),
        s.end_ns(),
        "the last message is at the end position"
    );
    assert!(p.at_end());
    assert!(p.step().is_none());
    p.seek(f64::NAN);
    assert_eq!(p.cursor(), 0);
}
