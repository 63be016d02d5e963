//! The link survives the hardware: the whole live station runtime
//! (`Connection::Serial`) on a real pseudo-terminal, a simulated Pro 4 on the other end,
//! and the pty destroyed mid-flight (an unplugged USB adapter) and recreated at the same
//! path, at another path found through a by-id link, and at another path found by
//! probing the listed ports.
//!
//! The simulated vehicle keeps running through the outage (it is the adapter that goes
//! away, not the vehicle): it sits on an in-memory pipe, and a "cable" relays bytes
//! between that pipe and whatever pty master is plugged in. Unplugging closes the pty
//! master, so the station's end reads as a vanished device; replugging makes a new pty
//! pair and points a symlink at its slave, the way udev's `/dev/serial/by-id` links and
//! socat's `link=` names work.
//!
//! Every wait is on a condition with a generous timeout; the figures are measured and
//! printed (`cargo test -p rov_station --test it serial_reconnect:: -- --nocapture`).
#![cfg(unix)]

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use firmware_proto::{ControlBlock, Deframer, Event, Frame};
use rov_control::PilotInput;
use rov_driver::{ByteSink, ByteSource, ReconnectConfig, SerialTransport, Transport, memory_pair};
use rov_session::{Direction, EventRecord, NavRecord, PilotRecord, Severity, ThrustRecord};
use rov_station::runtime::{AlarmKind, ReconnectSettings, Source};
use rov_station::{Connection, Runtime, RuntimeConfig, StationCommand, StationHandle, StationView};
use rov_vehicle::{RunnerConfig, Vehicle, VehicleConfig, VehicleRunner, runner};

/// One scenario at a time: each drives real-time threads on a 2-core machine.
static SERIAL: Mutex<()> = Mutex::new(());

/// The generous timeout of every wait, s.
const WAIT_S: f64 = 20.0;

fn tmp_dir(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("serial_reconnect")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("dev")).unwrap();
    std::fs::create_dir_all(dir.join("by-id")).unwrap();
    dir
}

/// Points `link` at `target`, atomically (a new link renamed over the old one).
fn point(link: &Path, target: &Path) {
    let tmp = link.with_extension("new");
    let _ = std::fs::remove_file(&tmp);
    std::os::unix::fs::symlink(target, &tmp).unwrap();
    std::fs::rename(&tmp, link).unwrap();
}

fn s(p: &Path) -> String {
    p.to_str().unwrap().to_string()
}

/// What reached the vehicle, in order, with the test's marks in between.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Seen {
    Control(ControlBlock),
    OtherRequest,
    Mark(&'static str),
}

/// The simulated Pro 4 behind a pluggable cable.
struct Cable {
    /// Every request that reached the vehicle.
    seen: Arc<Mutex<Vec<Seen>>>,
    /// Pty source halves for the upstream relay (`None` = unplug); acknowledged.
    plug_tx: Sender<Option<Box<dyn ByteSource>>>,
    ack_rx: Receiver<()>,
    /// The pty sink half for the downstream relay.
    sink: Arc<Mutex<Option<Box<dyn ByteSink>>>>,
    /// The slave end the pair was made with (kept open so the master never sees a
    /// hang-up of its own before the station opens the slave by name).
    pair_slave: Option<SerialTransport>,
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<()>>,
    vehicle: Option<VehicleRunner>,
}

impl Cable {
    fn new() -> Self {
        let (station_side, vehicle_side) = memory_pair();
        let vehicle = Vehicle::with_model3(VehicleConfig::default(), 7).unwrap();
        let vehicle = runner::spawn(
            vehicle,
            Box::new(vehicle_side),
            RunnerConfig {
                tolerate_hangup: true,
                ..RunnerConfig::default()
            },
        );
        let (mut from_vehicle, mut to_vehicle) = Box::new(station_side).split().unwrap();
        let stop = Arc::new(AtomicBool::new(false));
        let sink: Arc<Mutex<Option<Box<dyn ByteSink>>>> = Arc::new(Mutex::new(None));
        let (plug_tx, plug_rx) = channel::<Option<Box<dyn ByteSource>>>();
        let (ack_tx, ack_rx) = channel();
        let seen = Arc::new(Mutex::new(Vec::new()));
        let mut threads = Vec::new();
        // Upstream: pty master → vehicle, decoding what passes.
        {
            let stop = Arc::clone(&stop);
            let seen = Arc::clone(&seen);
            threads.push(std::thread::spawn(move || {
                let mut src: Option<Box<dyn ByteSource>> = None;
                let mut buf = vec![0u8; 4096];
                let mut rx = Deframer::vehicle();
                let t0 = Instant::now();
                while !stop.load(Ordering::Relaxed) {
                    while let Ok(p) = plug_rx.try_recv() {
                        src = p;
                        let _ = ack_tx.send(());
                    }
                    match src.as_mut() {
                        Some(s) => match s.recv(&mut buf, Duration::from_millis(2)) {
                            Ok(0) => {}
                            Ok(n) => {
                                to_vehicle.send(&buf[..n]).unwrap();
                                let mut input = &buf[..n];
                                let now = t0.elapsed().as_micros() as u64;
                                while let Some(ev) = rx.feed(&mut input, now) {
                                    if let Event::Frame { frame, .. } = ev {
                                        let got = ControlBlock::from_frame(&frame)
                                            .map_or(Seen::OtherRequest, Seen::Control);
                                        seen.lock().unwrap().push(got);
                                    }
                                }
                            }
                            // The station side closed for a moment (it re-opens by
                            // name): wait for it.
                            Err(_) => std::thread::sleep(Duration::from_millis(2)),
                        },
                        None => std::thread::sleep(Duration::from_millis(2)),
                    }
                }
            }));
        }
        // Downstream: vehicle → pty master (dropped on the floor while unplugged).
        {
            let stop = Arc::clone(&stop);
            let sink = Arc::clone(&sink);
            threads.push(std::thread::spawn(move || {
                let mut buf = vec![0u8; 4096];
                while !stop.load(Ordering::Relaxed) {
                    let n = from_vehicle
                        .recv(&mut buf, Duration::from_millis(2))
                        .unwrap();
                    if n > 0
                        && let Some(s) = sink.lock().unwrap().as_mut()
                    {
                        let _ = s.send(&buf[..n]);
                    }
                }
            }));
        }
        Self {
            seen,
            plug_tx,
            ack_rx,
            sink,
            pair_slave: None,
            stop,
            threads,
            vehicle: Some(vehicle),
        }
    }

    /// A new pty pair with the vehicle on its master; returns the slave's path.
    fn plug(&mut self) -> String {
        let (master, slave, pts) = SerialTransport::pty_pair().unwrap();
        let (src, sink) = Box::new(master).split().unwrap();
        *self.sink.lock().unwrap() = Some(sink);
        self.plug_tx.send(Some(src)).unwrap();
        self.ack_rx.recv_timeout(Duration::from_secs(5)).unwrap();
        self.pair_slave = Some(slave);
        pts
    }

    fn mark(&self, what: &'static str) {
        self.seen.lock().unwrap().push(Seen::Mark(what));
    }

    /// The requests seen between two marks (`None`: the start or the end).
    fn between(&self, from: Option<&'static str>, to: Option<&'static str>) -> Vec<Seen> {
        let seen = self.seen.lock().unwrap();
        let start = from.map_or(0, |m| {
            seen.iter().position(|s| *s == Seen::Mark(m)).unwrap() + 1
        });
        let end = to.map_or(seen.len(), |m| {
            seen.iter().position(|s| *s == Seen::Mark(m)).unwrap()
        });
        seen[start..end].to_vec()
    }

    /// Destroys the pty pair: both master halves and the pair's slave handle are closed
    /// when this returns, so the device node is gone and the station's end is hung up.
    fn unplug(&mut self) {
        *self.sink.lock().unwrap() = None;
        self.plug_tx.send(None).unwrap();
        self.ack_rx.recv_timeout(Duration::from_secs(5)).unwrap();
        self.pair_slave = None;
    }
}

impl Drop for Cable {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
        if let Some(v) = self.vehicle.take() {
            let _ = v.stop();
        }
    }
}

/// The pilot holds the stick forward the whole time (the keyboard stream must be
/// refreshed within 300 ms).
fn pilot(h: &Arc<StationHandle>, stop: &Arc<AtomicBool>) -> JoinHandle<()> {
    let h = Arc::clone(h);
    let stop = Arc::clone(stop);
    std::thread::spawn(move || {
        while !stop.load(Ordering::Relaxed) {
            h.send(StationCommand::Sticks(PilotInput {
                surge: 0.6,
                yaw: 0.0,
                vertical: 0.0,
            }));
            std::thread::sleep(Duration::from_millis(50));
        }
    })
}

fn wait_for(h: &StationHandle, what: &str, f: impl Fn(&StationView) -> bool) -> StationView {
    let t0 = Instant::now();
    loop {
        let v = h.view();
        if f(&v) {
            return v;
        }
        assert!(
            t0.elapsed().as_secs_f64() < WAIT_S,
            "timed out waiting for {what}: {:#?}",
            v.link
        );
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// Arms: once the link has been connected for the 1 s it needs, the pilot presses arm
/// (again every 250 ms until it takes).
fn arm(h: &StationHandle) {
    let t0 = Instant::now();
    wait_for(h, "a connected link", |v| v.link.health == "connected");
    let connected = h.now_us();
    while h.now_us() < connected + 1_000_000 {
        std::thread::sleep(Duration::from_millis(10));
    }
    while !h.view().snapshot.armed {
        assert!(
            t0.elapsed().as_secs_f64() < WAIT_S,
            "arming: {:#?}",
            h.view()
        );
        h.send(StationCommand::Arm);
        std::thread::sleep(Duration::from_millis(250));
    }
}

/// How the vehicle comes back.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Comeback {
    /// A new pty behind the same (re-pointed) path.
    SamePath,
    /// A new pty at another path; the by-id link is re-pointed to it; no scanning.
    ById,
    /// A new pty at another path, found by probing the listed ports (a silent port
    /// listed first answers nothing).
    Scan,
}

struct Figures {
    detect_ms: f64,
    failsafe_ms: f64,
    reconnect_ms: f64,
    connected_ms: f64,
    outage_s: f64,
}

/// One scenario: connect, arm, thrust; unplug mid-flight; wait 1.2 s; plug back as
/// `comeback` says; reconnect; stay disarmed; re-arm; thrust; check the recording.
fn scenario(name: &str, comeback: Comeback) -> Figures {
    let _serial = SERIAL
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = tmp_dir(name);
    let dev = dir.join("dev");
    let by_id_dir = dir.join("by-id");
    let port0 = dev.join("ttyUSB0");
    let by_id = by_id_dir.join("usb-FTDI_FT232R_USB_UART_A50285BI-if00-port0");

    let mut cable = Cable::new();
    let pts = cable.plug();
    point(&port0, Path::new(&pts));
    if comeback == Comeback::ById {
        point(&by_id, Path::new("../dev/ttyUSB0"));
    }
    let listed = dev.clone();
    let settings = ReconnectSettings {
        policy: ReconnectConfig {
            scan_other_ports: comeback != Comeback::ById,
            summary_every_us: 500_000,
            ..ReconnectConfig::default()
        },
        by_id_dir: by_id_dir.clone(),
        ports: Arc::new(move || {
            let mut v: Vec<String> = std::fs::read_dir(&listed)
                .map(|d| d.filter_map(|e| e.ok().map(|e| s(&e.path()))).collect())
                .unwrap_or_default();
            v.retain(|p| !p.ends_with(".new"));
            v.sort();
            v
        }),
    };
    let cfg = RuntimeConfig {
        connection: Connection::Serial(s(&port0)),
        gamepad: false,
        reconnect: settings,
        ..RuntimeConfig::default()
    };
    let h = Arc::new(Runtime::start(cfg).unwrap());
    let session_path = dir.join("session.mcap");
    assert!(h.start_recording(&session_path));
    let stop_pilot = Arc::new(AtomicBool::new(false));
    let pilot_thread = pilot(&h, &stop_pilot);

    // Connected at the configured path; by-id resolved at connect time.
    let v = wait_for(&h, "the first connection", |v| {
        v.link.health == "connected" && v.recording.path.is_some()
    });
    let port = v.link.port.clone().unwrap();
    assert_eq!(port.path, s(&port0));
    assert_eq!(port.state, "open");
    if comeback == Comeback::ById {
        assert_eq!(port.by_id.as_deref(), Some(s(&by_id).as_str()));
    } else {
        assert_eq!(port.by_id, None);
    }
    arm(&h);
    let v = wait_for(&h, "thrust", |v| v.snapshot.thrust.port_pct > 10.0);
    let started_us = ((v.snapshot.time_s - v.recording.elapsed_s) * 1e6).round() as u64;
    std::thread::sleep(Duration::from_millis(300));

    // Unplug mid-flight (armed, full control traffic).
    assert!(h.view().snapshot.armed);
    // The loss happens during unplug(); measured from its start (an upper bound).
    let t_unplug = h.now_us();
    cable.unplug();
    cable.mark("unplugged");
    let v = wait_for(&h, "the loss", |v| {
        !v.snapshot.armed && v.link.port.as_ref().is_some_and(|p| p.reconnecting)
    });
    let seen_ms = (h.now_us() - t_unplug) as f64 * 1e-3;
    assert_eq!(v.link.health, "lost");
    assert_eq!(v.snapshot.thrust.port_pct, 0.0);
    assert!(
        v.alarms
            .iter()
            .any(|a| a.kind == AlarmKind::LinkLost && a.active),
        "{:?}",
        v.alarms
    );
    assert_eq!(v.snapshot.alarm.as_deref(), Some("LinkLost"));
    let p = v.link.port.clone().unwrap();
    assert!(p.state.starts_with("reconnecting (attempt "), "{}", p.state);
    assert!(p.reason.as_deref().unwrap().contains("port gone"), "{p:?}");
    assert_eq!(p.losses, 1);
    // The pilot sees the attempts count up with the backoff.
    let v = wait_for(&h, "attempt 3", |v| {
        v.link.port.as_ref().is_some_and(|p| p.attempt >= 3)
    });
    let p = v.link.port.clone().unwrap();
    println!("{name}: GUI shows \"{}\" for {}", p.state, p.path);

    // The pty is gone for 1.2 s, then comes back.
    while h.now_us() < t_unplug + 1_200_000 {
        std::thread::sleep(Duration::from_millis(5));
    }
    let new_pts = cable.plug();
    cable.mark("replugged");
    let mut silent_pty = None;
    let expect_path = match comeback {
        Comeback::SamePath => {
            point(&port0, Path::new(&new_pts));
            s(&port0)
        }
        Comeback::ById => {
            let port1 = dev.join("ttyUSB1");
            std::fs::remove_file(&port0).unwrap();
            point(&port1, Path::new(&new_pts));
            point(&by_id, Path::new("../dev/ttyUSB1"));
            // The by-id candidate is opened; the view shows the device it resolves to.
            new_pts.clone()
        }
        Comeback::Scan => {
            // A silent port that sorts first (nothing answers on it), then the vehicle.
            let (m, sl, silent) = SerialTransport::pty_pair().unwrap();
            point(&dev.join("ttyACM0"), Path::new(&silent));
            silent_pty = Some((m, sl));
            let port1 = dev.join("ttyUSB1");
            std::fs::remove_file(&port0).unwrap();
            point(&port1, Path::new(&new_pts));
            s(&port1)
        }
    };
    let t_plug = h.now_us();
    let v = wait_for(&h, "the reconnection", |v| {
        v.link.port.as_ref().is_some_and(|p| !p.reconnecting)
    });
    let reopened_ms = (h.now_us() - t_plug) as f64 * 1e-3;
    assert_eq!(v.link.port.as_ref().unwrap().path, expect_path);
    assert_eq!(v.source, Source::Serial(expect_path.clone()));
    let v = wait_for(&h, "the link", |v| v.link.health == "connected");
    let connected_ms = (h.now_us() - t_plug) as f64 * 1e-3;
    let t_connected = h.now_us();
    // Stays disarmed and neutral with the stick held forward, well past the 1 s the
    // link needs before it may be armed.
    assert!(!v.snapshot.armed);
    while h.now_us() < t_connected + 1_500_000 {
        let v = h.view();
        assert!(!v.snapshot.armed, "re-armed by itself");
        assert_eq!(v.snapshot.thrust.port_pct, 0.0);
        std::thread::sleep(Duration::from_millis(10));
    }
    assert_eq!(h.view().snapshot.alarm.as_deref(), Some("LinkLost"));
    // An arm attempt is required, and works.
    cable.mark("arming");
    let t_arm = h.now_us();
    arm(&h);
    wait_for(&h, "thrust again", |v| v.snapshot.thrust.port_pct > 10.0);
    assert_eq!(h.view().snapshot.alarm, None);
    std::thread::sleep(Duration::from_millis(500));
    stop_pilot.store(true, Ordering::Relaxed);
    pilot_thread.join().unwrap();
    h.stop_recording();
    // Stopped, then saved on its finisher thread.
    wait_for(&h, "the recording to finish", |v| {
        v.recording.path.is_none() && v.recording.finishing.is_empty()
    });
    let v = h.view();
    assert_eq!(v.recording.error, None);
    assert_eq!(v.recording.dropped, 0);
    let handle = Arc::try_unwrap(h).unwrap();
    handle.shutdown();

    // ---- what the vehicle heard ---------------------------------------------------
    let thrusting = |c: &ControlBlock| c.port_pct != 0 || c.starboard_pct != 0;
    let before = cable.between(None, Some("unplugged"));
    assert!(
        before
            .iter()
            .any(|s| matches!(s, Seen::Control(c) if thrusting(c)))
    );
    assert!(
        cable
            .between(Some("unplugged"), Some("replugged"))
            .is_empty()
    );
    let back = cable.between(Some("replugged"), Some("arming"));
    // The first thing the returning vehicle heard was a neutral control write (the
    // station's probe), and everything until the pilot armed again was neutral.
    assert!(
        matches!(back.first(), Some(Seen::Control(c)) if rov_driver::is_neutral(c)),
        "{:?}",
        back.first()
    );
    let controls = back
        .iter()
        .filter(|s| matches!(s, Seen::Control(_)))
        .count();
    assert!(controls > 50, "{controls}");
    assert!(
        back.iter()
            .all(|s| !matches!(s, Seen::Control(c) if !rov_driver::is_neutral(c)))
    );
    let after = cable.between(Some("arming"), None);
    assert!(
        after
            .iter()
            .any(|s| matches!(s, Seen::Control(c) if thrusting(c)))
    );
    drop(cable);
    drop(silent_pty);

    // ---- the recording ------------------------------------------------------------
    let session = rov_session::open(&session_path).unwrap();
    assert!(session.is_complete(), "{:?}", session.damage());
    let us = |t_ns: u64| started_us + t_ns / 1000;
    let events = session.records::<EventRecord>().unwrap();
    for (t, e) in &events {
        println!(
            "{name}: event {:9.3} s {:?} {}: {}",
            us(*t) as f64 * 1e-6,
            e.severity,
            e.kind,
            e.text
        );
    }
    let at = |kind: &str| -> Vec<(u64, &EventRecord)> {
        events
            .iter()
            .filter(|(_, e)| e.kind == kind)
            .map(|(t, e)| (us(*t), e))
            .collect()
    };
    let lost = at("port_lost");
    assert_eq!(lost.len(), 1, "one port loss");
    let (t_lost, e) = lost[0];
    assert!(
        e.text.contains(&s(&port0)) && e.text.contains("port gone"),
        "{}",
        e.text
    );
    let (t_failsafe, _) = *at("failsafe").last().unwrap();
    let link_lost: Vec<(u64, &EventRecord)> = at("link_lost")
        .into_iter()
        .filter(|(_, e)| e.severity == Severity::Alarm)
        .collect();
    assert_eq!(link_lost.len(), 1);
    let detect_ms = t_lost.saturating_sub(t_unplug) as f64 * 1e-3;
    let failsafe_ms = t_failsafe.saturating_sub(t_unplug) as f64 * 1e-3;
    assert!(t_failsafe >= t_lost);
    assert!(
        failsafe_ms <= 500.0,
        "failsafe {failsafe_ms} ms after the unplug"
    );
    assert!(link_lost[0].0.saturating_sub(t_unplug) <= 500_000);
    assert!(
        seen_ms <= 500.0,
        "the view showed the loss after {seen_ms} ms"
    );
    // The attempts were summarised during the outage and at the reconnection.
    assert!(!at("port_reconnecting").is_empty());
    let rec = at("port_reconnected");
    assert_eq!(rec.len(), 1);
    let (t_rec, e) = rec[0];
    assert!(
        e.text
            .starts_with(&format!("reconnected at {expect_path} (")),
        "{}",
        e.text
    );
    assert!(
        e.text.contains(" s after the loss; ") && e.text.contains(" attempts: "),
        "{}",
        e.text
    );
    assert!(e.text.contains("not present"), "{}", e.text);
    if comeback == Comeback::Scan {
        assert!(e.text.contains("ttyACM0: no answer"), "{}", e.text);
    }
    if comeback == Comeback::ById {
        assert!(e.text.contains("by-id"), "{}", e.text);
    }
    let outage_s = (t_rec - t_lost) as f64 * 1e-6;
    let reconnect_ms = t_rec.saturating_sub(t_plug) as f64 * 1e-3;

    // Telemetry before and after, none in between.
    let nav = session.records::<NavRecord>().unwrap();
    assert!(nav.iter().filter(|(t, _)| us(*t) < t_unplug).count() > 20);
    assert!(nav.iter().filter(|(t, _)| us(*t) > t_rec).count() > 20);
    assert_eq!(
        nav.iter()
            .filter(|(t, _)| us(*t) > t_lost && us(*t) < t_rec)
            .count(),
        0
    );
    // The controller kept ticking through the outage; thrust neutral from the
    // failsafe until the re-arm, and the recorded pilot disarmed.
    let thrust = session.records::<ThrustRecord>().unwrap();
    let outage_ticks: Vec<&ThrustRecord> = thrust
        .iter()
        .filter(|(t, _)| us(*t) > t_failsafe && us(*t) < t_arm)
        .map(|(_, r)| r)
        .collect();
    assert!(
        outage_ticks.len() as f64 > 0.9 * (t_arm - t_failsafe) as f64 / 20_000.0,
        "{} ticks",
        outage_ticks.len()
    );
    assert!(
        outage_ticks
            .iter()
            .all(|r| r.port_pct == 0.0 && r.starboard_pct == 0.0 && r.vertical_pct == 0.0)
    );
    assert!(
        thrust
            .iter()
            .any(|(t, r)| us(*t) > t_arm && r.port_pct > 10.0)
    );
    let pilot = session.records::<PilotRecord>().unwrap();
    let outage_pilot: Vec<&PilotRecord> = pilot
        .iter()
        .filter(|(t, _)| us(*t) > t_failsafe && us(*t) < t_arm)
        .map(|(_, p)| p)
        .collect();
    assert!(outage_pilot.iter().all(|p| !p.armed));
    // The stick was held forward meanwhile (a starved pilot thread may miss a refresh).
    let held = outage_pilot.iter().filter(|p| p.surge > 0.5).count();
    assert!(
        held * 10 >= outage_pilot.len() * 9,
        "{held} of {}",
        outage_pilot.len()
    );
    // Every control frame that left between the loss and the re-arm was neutral;
    // none left while the port was gone.
    let mut neutral = 0;
    for (t, bytes) in session.raw_frames(Direction::Tx) {
        let t = us(t);
        if t <= t_lost || t >= t_arm {
            continue;
        }
        assert!(t >= t_rec, "a frame at {t} µs while the port was gone");
        let frame = Frame::parse(&bytes).unwrap();
        if let Ok(c) = ControlBlock::from_frame(&frame) {
            assert!(rov_driver::is_neutral(&c), "{c:?}");
            neutral += 1;
        }
    }
    assert!(neutral > 50, "{neutral} neutral frames after reconnection");

    let f = Figures {
        detect_ms,
        failsafe_ms,
        reconnect_ms,
        connected_ms,
        outage_s,
    };
    println!(
        "{name}: port lost {:.1} ms after the unplug (view {seen_ms:.1} ms), failsafe at \
         {:.1} ms; reconnected {:.1} ms after the pty reappeared (view {reopened_ms:.1} ms), \
         link connected at {:.1} ms; outage {:.2} s",
        f.detect_ms, f.failsafe_ms, f.reconnect_ms, f.connected_ms, f.outage_s
    );
    f
}

#[test]
fn pty_destroyed_and_recreated_at_the_same_path() {
    let _alone = crate::one_at_a_time();
    let f = scenario("same_path", Comeback::SamePath);
    // Attempts at +0.25, +0.75, +1.75 s: the pty is back at 1.2 s, found at 1.75 s.
    assert!(f.reconnect_ms <= 2_500.0, "{}", f.reconnect_ms);
}

#[test]
fn pty_recreated_at_another_path_found_by_id() {
    let _alone = crate::one_at_a_time();
    let f = scenario("by_id", Comeback::ById);
    assert!(f.reconnect_ms <= 2_500.0, "{}", f.reconnect_ms);
}

#[test]
fn pty_recreated_at_another_path_found_by_probing() {
    let _alone = crate::one_at_a_time();
    let f = scenario("scan", Comeback::Scan);
    // Probing pings each candidate; on a loaded machine (CI at load average 10) one ping
    // can go unanswered in its window and the next attempt comes 1 s later by the backoff.
    assert!(f.reconnect_ms <= 4_500.0, "{}", f.reconnect_ms);
}
