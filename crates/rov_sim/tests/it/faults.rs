//! Each fault of `--fault` (issue 23) does its physics in the simulated vehicle, on
//! virtual time, and nothing before its start.

use rov_dynamics::ThrustPct;
use rov_sim::{FaultSpec, SimConfig, Simulator};

fn sim(faults: &[&str]) -> Simulator {
    let mut cfg = SimConfig::default_model3().unwrap();
    cfg.noiseless = true;
    let mut s = Simulator::new(cfg, 7).unwrap();
    s.set_faults(
        faults
            .iter()
            .map(|f| FaultSpec::parse(f).unwrap())
            .collect(),
    );
    s
}

fn fly(s: &mut Simulator, cmd: ThrustPct, until_s: f64) {
    s.set_command(cmd).unwrap();
    s.advance_to(until_s).unwrap();
}

const FORWARD: ThrustPct = ThrustPct {
    port: 60.0,
    starboard: 60.0,
    vertical: 0.0,
};

#[test]
fn no_fault_and_a_future_fault_change_nothing() {
    let mut a = sim(&[]);
    let mut b = sim(&["drag:3@100", "thrust-loss:port:0.5@100", "compass:20@100"]);
    let mut c = {
        let mut cfg = SimConfig::default_model3().unwrap();
        cfg.noiseless = true;
        Simulator::new(cfg, 7).unwrap()
    };
    for s in [&mut a, &mut b, &mut c] {
        fly(s, FORWARD, 20.0);
    }
    assert_eq!(a.truth().state, c.truth().state);
    assert_eq!(b.truth().state, c.truth().state);
    assert_eq!(b.sensors(), c.sensors());
}

#[test]
fn thrust_loss_weakens_one_thruster_and_turns_the_vehicle() {
    let mut base = sim(&[]);
    let mut lost = sim(&["thrust-loss:port:0.4@5"]);
    for s in [&mut base, &mut lost] {
        fly(s, FORWARD, 4.0);
    }
    assert_eq!(base.truth().tau_thrusters, lost.truth().tau_thrusters);
    for s in [&mut base, &mut lost] {
        fly(s, FORWARD, 30.0);
    }
    // Surge force is (0.6 + 1) / 2 of the healthy one with a symmetric allocation.
    let ratio = lost.truth().tau_thrusters[0] / base.truth().tau_thrusters[0];
    assert!((ratio - 0.8).abs() < 1e-9, "surge ratio {ratio}");
    // The weak port side makes the vehicle yaw to port (negative r, heading falls).
    assert!(base.truth().state.nu[5].abs() < 1e-6);
    assert!(lost.truth().tau_thrusters[5] < 0.0);
    assert!(
        lost.truth().state.eta[5] < -0.2,
        "{}",
        lost.truth().state.eta[5]
    );
}

#[test]
fn buoyancy_makes_the_vehicle_sink() {
    let mut base = sim(&[]);
    let mut heavy = sim(&["buoyancy:3@2"]);
    for s in [&mut base, &mut heavy] {
        fly(s, ThrustPct::ZERO, 30.0);
    }
    let extra_m = heavy.truth().state.eta[2] - base.truth().state.eta[2];
    assert!(extra_m > 0.5, "sank only {extra_m} m more");
    // The depth sensor sees it too.
    assert!(heavy.sensors().depth_from_pressure_m > base.sensors().depth_from_pressure_m + 0.5);
    let light = {
        let mut s = sim(&["buoyancy:-3@2"]);
        fly(&mut s, ThrustPct::ZERO, 30.0);
        s
    };
    assert!(light.truth().state.eta[2] < base.truth().state.eta[2] - 0.5);
}

#[test]
fn drag_slows_the_vehicle() {
    let mut base = sim(&[]);
    let mut draggy = sim(&["drag:2.5@0"]);
    for s in [&mut base, &mut draggy] {
        fly(s, FORWARD, 40.0);
    }
    let u0 = base.truth().state.nu[0];
    let u1 = draggy.truth().state.nu[0];
    // Between linear (1/2.5) and quadratic (1/√2.5) drag.
    let ratio = u1 / u0;
    assert!(
        u0 > 0.1 && (0.38..0.66).contains(&ratio),
        "u {u0} → {u1}, ratio {ratio}"
    );
}

#[test]
fn snag_pulls_towards_the_start_point() {
    let mut base = sim(&[]);
    let mut snagged = sim(&["snag:15@10"]);
    for s in [&mut base, &mut snagged] {
        fly(s, FORWARD, 9.9);
    }
    assert_eq!(base.truth().state, snagged.truth().state);
    for s in [&mut base, &mut snagged] {
        fly(s, FORWARD, 40.0);
    }
    let x0 = base.truth().state.eta[0];
    let x1 = snagged.truth().state.eta[0];
    assert!(
        x1 < x0 - 1.0,
        "snag did not hold the vehicle back: {x0} vs {x1}"
    );
    assert!(snagged.truth().state.nu[0] < base.truth().state.nu[0]);
}

#[test]
fn depth_sensor_sticks_while_the_vehicle_dives() {
    let mut s = sim(&["depth-sensor:stuck@5"]);
    let down = ThrustPct {
        port: 0.0,
        starboard: 0.0,
        vertical: 60.0,
    };
    fly(&mut s, down, 5.0);
    let held = s.sensors().depth_from_pressure_m;
    let held_field = s.sensors().pro4.pressure_mbar;
    fly(&mut s, down, 20.0);
    assert_eq!(s.sensors().depth_from_pressure_m, held);
    assert_eq!(s.sensors().pro4.pressure_mbar, held_field);
    assert!(
        s.truth().state.eta[2] > held + 1.0,
        "the vehicle went on diving"
    );

    let mut j = sim(&["depth-sensor:jump:0.5@5"]);
    fly(&mut j, ThrustPct::ZERO, 6.0);
    let err = j.sensors().depth_from_pressure_m - j.truth().state.eta[2];
    assert!((err - 0.5).abs() < 0.05, "jump reads {err} m off");
}

#[test]
fn compass_reads_off_by_the_disturbance() {
    let mut s = sim(&["compass:25@3"]);
    fly(&mut s, ThrustPct::ZERO, 2.0);
    let before = s.sensors().heading_rad.to_degrees();
    fly(&mut s, ThrustPct::ZERO, 4.0);
    let after = s.sensors().heading_rad.to_degrees();
    let diff = rov_types::angle::wrap_deg_180(after - before);
    assert!((diff - 25.0).abs() < 0.5, "heading moved {diff}°");
    // The vehicle itself did not turn.
    assert!(s.truth().state.eta[5].abs() < 1e-3);
}
