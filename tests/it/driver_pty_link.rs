//! The link over a real pseudo-terminal pair in wall time, the simulated vehicle in a
//! thread on the other end, paced at 115200 baud: the control loop with faults, the
//! autodetect by ping, and the tokio runner.
#![cfg(unix)]

use crate::driver as common;

use std::ops::ControlFlow;
use std::time::{Duration, Instant};

use common::{DepthHold, assert_accounting, thrust, try_arm, vehicle};
use firmware_proto::NodeId;
use rov_driver::{
    ByteSink, ByteSource, Health, Link, LinkConfig, LinkEvent, MonoClock, Phase, RunnerOptions,
    SerialTransport, autodetect, is_neutral, memory_pair, run_blocking,
};
use rov_vehicle::{FaultConfig, RunnerConfig, WireTiming, runner};

const S: u64 = 1_000_000;

/// ≥ 5 s of wall time over a pty: 50 Hz depth hold with drops, bit flips, garbage,
/// fragmentation, delay, corrupted requests and a dead period.
#[test]
fn control_loop_over_pty_with_faults() {
    let (master, mut slave, _path) = SerialTransport::pty_pair().unwrap();
    let faults = FaultConfig {
        seed: 5,
        drop_reply: 0.02,
        bit_flip: 0.02,
        garbage: 0.05,
        fragment: 0.05,
        delay: 0.05,
        delay_us: (1_000, 8_000),
        corrupt_request: 0.01,
        dead_windows: vec![(1_500_000, 2_200_000)],
        ..FaultConfig::default()
    };
    let v = vehicle(faults, WireTiming::default());
    let vehicle_thread = runner::spawn(v, Box::new(master), RunnerConfig::default());

    // Generous response timeouts and deframer gap: a busy machine must not turn
    // scheduling jitter into timeouts or stalled partial frames that no fault caused (the
    // accounting below is exact). The injected fragment gaps are at most 2 ms, far below
    // the 90 ms gap, so every fragmented reply must still be reassembled; CI under load
    // (load average 8) saw the vehicle thread preempted for up to 107 ms between two
    // fragments, which the default 10 ms gap counts as stalls.
    let cfg = LinkConfig {
        response_timeout_us: 100_000,
        deframer_gap_us: 90_000,
        dump_timeout_us: 150_000,
        arm_min_healthy_us: 300_000,
        ..LinkConfig::default()
    };
    let mut link = Link::new(cfg).unwrap();
    let clock = MonoClock::new();
    let mut hold = DepthHold::new(2.0);
    let mut losses = 0;
    let mut neutral_after_loss_ok = true;
    let mut lost = false;
    let mut last_depth = 0.0;
    let mut depth_log = Vec::new();
    let end_us = 8 * S;
    run_blocking(
        &mut link,
        &mut slave,
        &clock,
        Duration::from_millis(5),
        |link, now| {
            while let Some(ev) = link.poll_event() {
                match ev {
                    LinkEvent::Telemetry(t) => {
                        last_depth = t.depth_m;
                        depth_log.push((t.time_us, t.depth_m));
                        let u = hold.update(&t);
                        link.set_thrust(&thrust(u));
                    }
                    LinkEvent::AlarmRaised { .. } => {
                        losses += 1;
                        lost = true;
                    }
                    LinkEvent::ControlSent { block, .. }
                        if lost && !link.failsafe().is_armed() && !is_neutral(&block) =>
                    {
                        neutral_after_loss_ok = false;
                    }
                    _ => {}
                }
            }
            if !link.failsafe().is_armed() {
                try_arm(link, now);
                if link.failsafe().is_armed() {
                    lost = false;
                    hold.reset();
                }
            }
            // Finish when the time is up and the line is idle.
            if now >= end_us && !link.in_flight() {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        },
    )
    .unwrap();
    // Let any reply in the vehicle's schedule drain before stopping it.
    std::thread::sleep(Duration::from_millis(100));
    let v = vehicle_thread.stop().unwrap();
    let c = link.counters();
    let f = *v.fault_counts();
    println!("counters {c:#?}\nfaults {f:#?}\nrtt {:?}", link.rtt());
    assert!(f.replies_dropped > 0 && f.flipped() > 0 && f.garbage_bursts > 0);
    assert!(f.fragmented > 0 && f.delayed > 0 && f.requests_ignored_dead > 0);
    assert_accounting(&c, &f, v.comm_errors());
    assert_eq!(losses, 1);
    assert!(neutral_after_loss_ok);
    let recent: Vec<f64> = depth_log
        .iter()
        .filter(|(t, _)| *t + S >= clock.now_us().min(end_us + S))
        .map(|d| d.1)
        .collect();
    assert!(!recent.is_empty());
    for d in &recent {
        assert!(
            (d - 2.0).abs() < 0.1,
            "telemetry depth {d} (last {last_depth})"
        );
    }
    assert!(
        (v.depth_m() - 2.0).abs() < 0.1,
        "true depth {}",
        v.depth_m()
    );
}

/// Autodetect by ping (protocol.md §7) over a pty: the vehicle on the master, the slave
/// found by its path among candidates that do not answer or do not exist.
#[test]
fn autodetect_finds_the_vehicle_on_a_pty() {
    let (master, _slave, path) = SerialTransport::pty_pair().unwrap();
    let (silent_master, _silent_slave, silent_path) = SerialTransport::pty_pair().unwrap();
    let v = vehicle(FaultConfig::none(), WireTiming::default());
    let vehicle_thread = runner::spawn(v, Box::new(master), RunnerConfig::default());
    let candidates = vec![
        "/dev/this-port-does-not-exist".to_string(),
        silent_path.clone(),
        path.clone(),
    ];
    // 1 s per candidate: the vehicle thread shares 2 cores with the other tests (300 ms
    // once missed the reply under load).
    let report = autodetect(&candidates, NodeId::ROV, Duration::from_secs(1));
    let found = report.found.expect("vehicle found");
    assert_eq!(found.port, path);
    assert_eq!((found.node, found.flags), (NodeId::ROV, 0x01));
    assert_eq!(found.frame.len(), 17);
    assert_eq!(report.tried.len(), 3);
    assert!(report.tried[0].1.is_some() && report.tried[1].1.as_deref() == Some("no response"));
    drop(silent_master);
    let v = vehicle_thread.stop().unwrap();
    assert_eq!(v.counts().unicast, 1);
}

/// The tokio runner drives the link over a memory pipe to a paced vehicle thread:
/// connect, arm after the healthy time, thrust reaches the plant, snapshot, shutdown.
#[test]
fn tokio_runner_over_memory_pipe() {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_time()
        .build()
        .unwrap();
    let (a, b) = memory_pair();
    let v = vehicle(FaultConfig::none(), WireTiming::default());
    let tolerant = RunnerConfig {
        tolerate_hangup: true,
        ..RunnerConfig::default()
    };
    let vehicle_thread = runner::spawn(v, Box::new(b), tolerant);
    let snapshot = rt.block_on(async {
        let cfg = LinkConfig {
            arm_min_healthy_us: 200_000,
            ..LinkConfig::default()
        };
        let mut handle = rov_driver::spawn(
            Link::new(cfg).unwrap(),
            Box::new(a),
            RunnerOptions::default(),
        )
        .unwrap();
        let start = Instant::now();
        let mut running_at = None;
        let mut telemetry = 0;
        while start.elapsed() < Duration::from_millis(1500) {
            let ev = tokio::time::timeout(Duration::from_millis(100), handle.next_event()).await;
            match ev {
                Ok(Some(LinkEvent::StateChanged {
                    phase: Phase::Running,
                    health: Health::Connected,
                    ..
                })) => running_at = Some(Instant::now()),
                Ok(Some(LinkEvent::Telemetry(_))) => telemetry += 1,
                _ => {}
            }
            if let Some(t) = running_at
                && t.elapsed() > Duration::from_millis(300)
                && !handle.snapshot().await.unwrap().armed
            {
                handle.arm().await.unwrap();
                handle.set_thrust(thrust(40.0)).unwrap();
            }
        }
        assert!(telemetry > 40, "{telemetry}");
        let snap = handle.snapshot().await.unwrap();
        assert!(snap.armed);
        handle.shutdown().await.unwrap()
    });
    let v = vehicle_thread.stop().unwrap();
    assert_eq!(snapshot.phase, Phase::Running);
    assert!(snapshot.counters.failed() <= 2, "{:?}", snapshot.counters);
    assert!(snapshot.rtt.p50_us >= 5_000, "{:?}", snapshot.rtt);
    assert_eq!(v.plant_command().vertical, 40.0);
}

/// A pty whose other end closed reads and writes as "port gone" (not as a timeout, not
/// as a frame error), the way an unplugged USB adapter does.
#[test]
fn vanished_pty_reads_as_port_gone() {
    let (master, pair_slave, path) = SerialTransport::pty_pair().unwrap();
    // The station opens the slave by its path, as it opens a real port.
    let mut port = SerialTransport::open(&path, rov_driver::PRO4_BAUD).unwrap();
    drop(pair_slave);
    let mut buf = [0u8; 64];
    assert_eq!(port.recv(&mut buf, Duration::from_millis(20)).unwrap(), 0);
    let t0 = Instant::now();
    drop(master);
    let err = port
        .recv(&mut buf, Duration::from_millis(500))
        .expect_err("read after the master closed");
    let elapsed = t0.elapsed();
    println!("read after close: {err} after {elapsed:?}");
    assert!(err.port_gone().is_some(), "{err:?}");
    assert!(elapsed < Duration::from_millis(100), "{elapsed:?}");
    let err = port.send(&[0xFA, 0xAF]).expect_err("write after close");
    println!("write after close: {err}");
    assert!(err.port_gone().is_some(), "{err:?}");
    // The device node is gone with the master.
    assert!(SerialTransport::open(&path, rov_driver::PRO4_BAUD).is_err());
}
