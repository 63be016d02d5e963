//! The link against the simulated vehicle over the in-memory, virtual-time pipe
//! (`rov_station::SimLink`): a 60 s control loop at 50 Hz with faults, the link-loss
//! failsafe (B1–B3), the onboard autopilot, and exact error accounting (A7).

use crate::driver as common;

use common::{DepthHold, assert_accounting, thrust, try_arm, vehicle};
use rov_driver::{
    Alarm, ExchangeKind, FailCause, Health, Link, LinkConfig, LinkEvent, Phase, is_neutral,
};
use rov_station::{SimApp, SimLink};
use rov_vehicle::{FaultConfig, Vehicle, WireTiming};

const S: u64 = 1_000_000;

/// Runs on until no request is in flight and no reply byte is pending, so the counters
/// can be compared exactly.
fn settle(sim: &mut SimLink, app: &mut impl SimApp) {
    for _ in 0..1000 {
        if !sim.link.in_flight() && !sim.vehicle.output_pending() {
            return;
        }
        let t = sim.now_us() + 500;
        sim.run_until(t, app).unwrap();
    }
    panic!("link never idle");
}

/// The pilot: depth hold on telemetry, re-arms whenever the link allows, records what
/// was sent.
struct Pilot {
    hold: DepthHold,
    depth_log: Vec<(u64, f64)>,
    sent: Vec<(u64, bool)>,
    telemetry: u64,
    alarms: Vec<(u64, Alarm)>,
    /// Last valid response when each alarm was raised.
    last_valid_at_alarm: Vec<u64>,
    states: Vec<(u64, Phase, Health)>,
    last_telemetry_us: u64,
    auto_rearm: bool,
    arm_times: Vec<u64>,
}

impl Pilot {
    fn new(target: f64, auto_rearm: bool) -> Self {
        Self {
            hold: DepthHold::new(target),
            depth_log: Vec::new(),
            sent: Vec::new(),
            telemetry: 0,
            alarms: Vec::new(),
            last_valid_at_alarm: Vec::new(),
            states: Vec::new(),
            last_telemetry_us: 0,
            auto_rearm,
            arm_times: Vec::new(),
        }
    }
}

impl SimApp for Pilot {
    fn on_event(&mut self, link: &mut Link, _v: &Vehicle, event: LinkEvent, _now: u64) {
        match event {
            LinkEvent::Telemetry(t) => {
                self.telemetry += 1;
                self.last_telemetry_us = t.time_us;
                let u = self.hold.update(&t);
                link.set_thrust(&thrust(u));
            }
            LinkEvent::ControlSent { time_us, block } => {
                self.sent.push((time_us, is_neutral(&block)))
            }
            LinkEvent::AlarmRaised { time_us, alarm } => {
                self.alarms.push((time_us, alarm));
                self.last_valid_at_alarm
                    .push(link.last_valid_response_us().unwrap_or(0));
            }
            LinkEvent::StateChanged {
                time_us,
                phase,
                health,
            } => self.states.push((time_us, phase, health)),
            _ => {}
        }
    }

    fn on_tick(&mut self, link: &mut Link, v: &mut Vehicle, now: u64) {
        self.depth_log.push((now, v.depth_m()));
        if self.auto_rearm && !link.failsafe().is_armed() {
            try_arm(link, now);
            if link.failsafe().is_armed() {
                self.arm_times.push(now);
                self.hold.reset();
            }
        }
    }
}

fn faults_all(seed: u64) -> FaultConfig {
    FaultConfig {
        seed,
        drop_reply: 0.02,
        bit_flip: 0.02,
        garbage: 0.05,
        fragment: 0.05,
        delay: 0.05,
        delay_us: (1_000, 15_000),
        corrupt_request: 0.01,
        dead_windows: vec![(20 * S, 21 * S + 500_000)],
        ..FaultConfig::default()
    }
}

#[test]
fn control_loop_60s_virtual_with_faults() {
    let v = vehicle(faults_all(7), WireTiming::default());
    let link = Link::new(LinkConfig::default()).unwrap();
    let mut sim = SimLink::new(link, v, 20_000);
    let mut pilot = Pilot::new(2.0, true);
    sim.run_until(60 * S, &mut pilot).unwrap();
    settle(&mut sim, &mut pilot);

    let c = sim.link.counters();
    let f = *sim.vehicle.fault_counts();
    println!("counters {c:#?}\nfaults {f:#?}\nrtt {:?}", sim.link.rtt());
    // Enough of every fault to mean something.
    assert!(f.replies_dropped >= 20 && f.flipped_header >= 3 && f.flipped_total >= 20);
    assert!(f.garbage_bursts >= 50 && f.fragmented >= 50 && f.delayed >= 50);
    assert!(f.requests_corrupted >= 10 && f.requests_ignored_dead >= 10);
    assert_accounting(&c, &f, sim.vehicle.comm_errors());
    // The dead window cost the link exactly once, and the pilot re-armed after it.
    assert_eq!(c.link_losses, 1);
    assert_eq!(pilot.alarms.len(), 1);
    assert_eq!(pilot.arm_times.len(), 2, "{:?}", pilot.arm_times);
    // 50 Hz: about 3000 control frames in 60 s less the outage.
    let controls = pilot.sent.len();
    assert!((2500..=3000).contains(&controls), "{controls}");
    // The vehicle holds 2 m over the last 10 s.
    for &(t, d) in pilot.depth_log.iter().filter(|(t, _)| *t >= 50 * S) {
        assert!((d - 2.0).abs() < 0.1, "depth {d} at {t}");
    }
    let rtt = sim.link.rtt();
    assert!(rtt.max_ever_us >= f.delay_max_us, "{rtt:?}");
}

#[test]
fn garbage_bytes_are_counted_exactly() {
    let faults = FaultConfig {
        seed: 3,
        garbage: 0.3,
        fragment: 0.3,
        ..FaultConfig::default()
    };
    let link = Link::new(LinkConfig::default()).unwrap();
    let mut sim = SimLink::new(link, vehicle(faults, WireTiming::default()), 0);
    sim.run_until(10 * S, &mut ()).unwrap();
    settle(&mut sim, &mut ());
    let c = sim.link.counters();
    let f = *sim.vehicle.fault_counts();
    assert!(f.garbage_bursts > 100 && f.fragmented > 100);
    assert_eq!(c.deframer.garbage_bytes, f.garbage_bytes);
    assert_eq!(c.failed(), 0);
    assert_eq!(c.responses, c.requests);
    assert_accounting(&c, &f, sim.vehicle.comm_errors());
}

/// B1/B2/B3: a dead link → lost within T_loss, neutral frames within T_loss + P of the
/// last valid response, alarm latched; after the link returns thrust stays neutral until
/// the pilot re-arms.
#[test]
fn failsafe_on_link_loss_latches_until_rearm() {
    let dead = (8 * S, 10 * S);
    let faults = FaultConfig {
        dead_windows: vec![dead],
        ..FaultConfig::default()
    };
    let link = Link::new(LinkConfig::default()).unwrap();
    let mut sim = SimLink::new(link, vehicle(faults, WireTiming::default()), 20_000);
    let mut pilot = Pilot::new(2.5, false);
    sim.run_until(S, &mut pilot).unwrap();
    // Armed after 1 s of healthy link.
    sim.run_until(1_500_000, &mut pilot).unwrap();
    sim.link.arm(sim.now_us()).unwrap();
    sim.run_until(dead.0, &mut pilot).unwrap();
    assert!(
        !pilot.sent.last().unwrap().1,
        "thrust flowing before the outage"
    );
    sim.run_until(dead.1 + 2 * S, &mut pilot).unwrap();
    let last_valid = pilot.last_valid_at_alarm[0];

    let cfg = *sim.link.config();
    let lost_at = pilot
        .states
        .iter()
        .find(|s| s.2 == Health::Lost)
        .map(|s| s.0)
        .unwrap();
    assert_eq!(lost_at, last_valid + cfg.loss_timeout_us);
    let degraded_at = pilot
        .states
        .iter()
        .find(|s| s.2 == Health::Degraded)
        .map(|s| s.0)
        .unwrap();
    assert!(degraded_at < lost_at);
    // B2: first neutral frame after the last valid response within T_loss + P.
    let first_neutral = pilot
        .sent
        .iter()
        .find(|(t, n)| *t > last_valid && *n)
        .map(|s| s.0)
        .unwrap();
    assert!(first_neutral - last_valid <= cfg.loss_timeout_us + cfg.cycle_period_us);
    // Every frame after the loss is neutral (no re-arm yet).
    assert!(pilot.sent.iter().filter(|s| s.0 >= lost_at).all(|s| s.1));
    assert_eq!(pilot.alarms, vec![(lost_at, Alarm::LinkLost)]);
    // Link back, alarm still latched, vehicle thrust zero.
    assert_eq!(
        (sim.link.phase(), sim.link.health()),
        (Phase::Running, Health::Connected)
    );
    let alarm = sim.link.failsafe().alarm().copied().unwrap();
    assert!(!alarm.cause_active);
    assert!(!sim.link.failsafe().is_armed());
    let cmd = sim.vehicle.plant_command();
    assert_eq!((cmd.port, cmd.starboard, cmd.vertical), (0.0, 0.0, 0.0));
    // Re-arm: the alarm clears and thrust flows again.
    sim.link.arm(sim.now_us()).unwrap();
    assert!(sim.link.failsafe().alarm().is_none());
    let n = pilot.sent.len();
    sim.run_until(dead.1 + 3 * S, &mut pilot).unwrap();
    assert!(pilot.sent[n..].iter().any(|s| !s.1));
    // During the outage the vehicle's own watchdog stopped the thrusters after 1 s.
    assert_eq!(sim.vehicle.counts().watchdog_trips, 1);
}

/// B2 over many randomized outages: the first neutral frame always leaves within
/// T_loss + P of the last valid response.
#[test]
fn neutral_within_t_loss_plus_p_randomized() {
    let mut worst = 0;
    for trial in 0..40u64 {
        let start = 2 * S + (trial * 7_919) % 20_000 + trial * 1_013;
        let faults = FaultConfig {
            seed: trial,
            drop_reply: 0.05,
            delay: 0.2,
            delay_us: (0, 30_000),
            dead_windows: vec![(start, start + S)],
            ..FaultConfig::default()
        };
        let cfg = LinkConfig {
            arm_min_healthy_us: 0,
            ..LinkConfig::default()
        };
        let link = Link::new(cfg).unwrap();
        let mut sim = SimLink::new(link, vehicle(faults, WireTiming::default()), 20_000);
        let mut pilot = Pilot::new(2.0, true);
        sim.run_until(start, &mut pilot).unwrap();
        pilot.auto_rearm = false;
        sim.run_until(start + S, &mut pilot).unwrap();
        assert_eq!(pilot.alarms.len(), 1, "trial {trial}");
        let last_valid = pilot.last_valid_at_alarm[0];
        assert_eq!(pilot.alarms[0].0, last_valid + 500_000);
        let first_neutral = pilot
            .sent
            .iter()
            .find(|(t, n)| *t > last_valid && *n)
            .map(|s| s.0)
            .unwrap();
        let d = first_neutral - last_valid;
        worst = worst.max(d);
        assert!(d <= 520_000, "trial {trial}: {d} µs");
    }
    println!("worst first-neutral delay after the last valid response: {worst} µs");
}

/// The vehicle's own auto-depth and auto-heading (ours, see rov_vehicle::autopilot):
/// targets written through the control block take the vehicle there.
#[test]
fn onboard_auto_depth_and_heading_reach_targets() {
    let cfg = LinkConfig {
        arm_min_healthy_us: 0,
        ..LinkConfig::default()
    };
    let link = Link::new(cfg).unwrap();
    let mut sim = SimLink::new(link, vehicle(FaultConfig::none(), WireTiming::default()), 0);
    sim.run_until(100_000, &mut ()).unwrap();
    sim.link.arm(sim.now_us()).unwrap();
    sim.link.set_auto_targets(Some(2.0), Some(90.0));
    let target = sim.link.command().depth_target_mbar.unwrap();
    assert_eq!(target, 1209); // 1013.25 + 2 m × 98.1 mbar/m, rounded
    sim.run_until(40 * S, &mut ()).unwrap();
    let depth = sim.vehicle.depth_m();
    let heading = sim.vehicle.heading_deg();
    assert!((depth - 2.0).abs() < 0.1, "depth {depth}");
    assert!((heading - 90.0).abs() < 3.0, "heading {heading}");
    // Off again: the vertical thrust goes back to the pilot's (zero).
    sim.link.set_auto_targets(None, None);
    sim.run_until(41 * S, &mut ()).unwrap();
    assert_eq!(sim.vehicle.plant_command().vertical, 0.0);
}

/// Status every 10th cycle, the INIT dump, and application requests with retries.
#[test]
fn init_dump_status_and_requests() {
    let faults = FaultConfig {
        seed: 11,
        drop_reply: 0.3,
        ..FaultConfig::default()
    };
    let cfg = LinkConfig {
        init_config: true,
        ..LinkConfig::default()
    };
    let link = Link::new(cfg).unwrap();
    let mut sim = SimLink::new(link, vehicle(faults, WireTiming::default()), 0);
    struct Rec(Vec<LinkEvent>);
    impl SimApp for Rec {
        fn on_event(&mut self, _l: &mut Link, _v: &Vehicle, e: LinkEvent, _n: u64) {
            self.0.push(e);
        }
    }
    let mut rec = Rec(Vec::new());
    sim.run_until(2 * S, &mut rec).unwrap();
    let id = sim.link.request(rov_driver::Request::WriteRegisters {
        addr: 0x13,
        data: vec![80],
    });
    let id2 = sim.link.request(rov_driver::Request::ReadRegisters {
        start: 0xEB,
        count: 3,
    });
    sim.run_until(5 * S, &mut rec).unwrap();
    let image = rec.0.iter().find_map(|e| match e {
        LinkEvent::RegisterImage { start, data, .. } => Some((*start, data.len())),
        _ => None,
    });
    assert_eq!(image, Some((0, 240)));
    assert!(rec.0.iter().any(
        |e| matches!(e, LinkEvent::Config { config, .. } if config.bootloader.is_app_valid())
    ));
    let statuses = rec
        .0
        .iter()
        .filter(|e| matches!(e, LinkEvent::Status(_)))
        .count();
    let telemetry = rec
        .0
        .iter()
        .filter(|e| matches!(e, LinkEvent::Telemetry(_)))
        .count();
    assert!(
        statuses * 10 >= telemetry / 2 && statuses * 10 <= telemetry + 10,
        "{statuses} {telemetry}"
    );
    let done: Vec<_> = rec
        .0
        .iter()
        .filter_map(|e| match e {
            LinkEvent::RequestDone { id, outcome, .. } => Some((*id, outcome.clone())),
            _ => None,
        })
        .collect();
    assert_eq!(
        done,
        vec![
            (
                id,
                rov_driver::RequestOutcome::Registers {
                    start: 0x13,
                    data: vec![80]
                }
            ),
            (
                id2,
                rov_driver::RequestOutcome::Registers {
                    start: 0xEB,
                    data: vec![2, 6, 6]
                }
            ),
        ]
    );
    assert_eq!(sim.vehicle.registers()[0x13], 80);
    assert!(sim.link.counters().retries > 0 || sim.link.counters().failed_timeout > 0);
    // Failures seen by kind.
    assert!(rec.0.iter().any(|e| matches!(
        e,
        LinkEvent::ExchangeFailed {
            kind: ExchangeKind::Control { .. },
            cause: FailCause::Timeout,
            ..
        }
    )));
}
