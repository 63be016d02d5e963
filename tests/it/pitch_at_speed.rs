//! Why model3 pitches to 40–60° under the station's depth autopilot at surge stick 0.3
//! (found by the lab's closed-loop generator, `rov_lab/tests/common::closed_loop_run`:
//! truth model3 perturbed ±20 %, 1.5 mbar pressure noise: max |pitch| 59.8° in 420 s; the
//! same loop on nominal model3 with noise-free depth still reaches 43.6°, so neither the
//! perturbation nor the noise is the cause).
//!
//! Finding: **the model, not the controller.** The Pro 4 has no pitch actuator; the
//! autopilot only moves the vertical thruster, which sits on the vertical line through
//! CO and CG and exerts no pitch moment. What pitches the vehicle is model3's C_A with
//! Fossen's `remus100.py` zeroing (`munk_moment = "zeroed"`): zeroing C_A[4][0] removes
//! the −A33·u·w half of the pitch Munk moment and leaves the +A11·u·w half (C_A[4][2]),
//! so a vehicle moving forward at u while heaving at w feels a pitch moment −A11·u·w
//! (on the right-hand side), the same size as the physical Munk moment (A33 − A11 =
//! A11 = 2.5 kg here) with the opposite sign. Against it stands only W·BG·sin θ with BG
//! = 5.59 mm (0.33 N m at most): at u = 0.25 m/s and w = −0.27 m/s (a 1.5 m depth step
//! at full vertical thrust) the moment is 0.17 N m, enough for ~30° quasi-statically and
//! more with the overshoot of a 0.15 kg m² pitch inertia. For a slender AUV (small A11)
//! the leftover is negligible, which is why Fossen's code can zero the pair; for the
//! box-like Pro 4 (A11 = 0.4 of the displaced mass) it is not. With the full C_A the
//! vehicle pitches as far the other way (and is statically unstable above ~0.4 m/s).
//!
//! Both signs come from a modelling shortcut (half of a Munk moment kept, or a whole one
//! with nothing from the hull's lift to balance it) acting on a tiny BG, not from
//! anything the autopilot does. The project has no Pro 4 data at speed to compare with
//! (the paper's hovering steps pitch the stand-in vehicle −10°/+5° at ±60 % vertical,
//! `topside sim paper`; the real logs are a BlueROV2's), but tens of degrees from a
//! 0.25 m/s climb would make a Pro 4 unusable as a camera platform, which it is not.
//! So the defect is in model3's pitch axis (the C_A
//! treatment and the small BG, both from the paper and its CAD), not in rov_control.
//! The autopilot needs no change. The model is left as published here: changing it
//! moves every figure pinned to model3 (the paper reproduction, hold and lab figures)
//! and belongs to rov_dynamics and config/models. A consistent choice would zero
//! C_A[4][2] with C_A[4][0] (no u·w pitch coupling at all) or keep both with a fitted
//! hull lift term. This file pins the mechanism so that a model change shows here:
//! facts on the simulator alone (open loop), then the finding reproduced with the
//! station's controller.

use rov_control::{ControlConfig, Controller, Measurements, ModeCommand, ModelSet, PilotInput};
use rov_dynamics::models::{InitialConditions, load_model};
use rov_dynamics::thrusters::ThrustPct;
use rov_sim::{SimConfig, Simulator};

const MODEL3: &str = include_str!("../../config/models/model3.toml");

fn sim(munk: &str) -> Simulator {
    let zeroed = "munk_moment = \"zeroed\"";
    assert!(
        MODEL3.contains(zeroed),
        "model3.toml's munk_moment line moved"
    );
    let text = MODEL3.replace(zeroed, &format!("munk_moment = \"{munk}\""));
    let model = load_model("model3", &text, "model3.toml").unwrap();
    let mut cfg = SimConfig::with_model(model);
    cfg.initial = InitialConditions::at_rest(5.0, 0.0);
    Simulator::new(cfg, 1).unwrap()
}

/// Open loop: horizontal thrust `surge_pct` on both, and `vertical_pct` from 20 to 22 s
/// (negative: up). Returns the pitch (deg) of largest magnitude from 20 s on, the body
/// u there, and the body w of largest magnitude from 20 s on.
fn open_loop(munk: &str, surge_pct: f64, vertical_pct: f64) -> (f64, f64, f64) {
    let mut s = sim(munk);
    let mut worst = (0.0f64, 0.0, 0.0);
    let mut w_peak = 0.0f64;
    while s.time_s() < 30.0 {
        let t = s.time_s();
        let v = if (20.0..22.0).contains(&t) {
            vertical_pct
        } else {
            0.0
        };
        s.set_command(ThrustPct::new(surge_pct, surge_pct, v))
            .unwrap();
        s.step().unwrap();
        let st = &s.truth().state;
        let pitch = st.eta[4].to_degrees();
        if t >= 20.0 && pitch.abs() >= worst.0.abs() {
            worst = (pitch, st.nu[0], 0.0);
        }
        if t >= 20.0 && st.nu[2].abs() > w_peak.abs() {
            w_peak = st.nu[2];
        }
    }
    (worst.0, worst.1, w_peak)
}

#[test]
fn forward_speed_alone_or_heave_alone_barely_pitches_model3() {
    let (cruise, u, _) = open_loop("zeroed", 30.0, 0.0);
    assert!(u > 0.2, "cruising at {u} m/s");
    assert!(cruise.abs() < 3.0, "cruise alone pitches {cruise:.1}°");
    let (heave, _, w) = open_loop("zeroed", 0.0, -60.0);
    assert!(w < -0.1, "rising at {w} m/s");
    assert!(heave.abs() < 3.0, "heave alone pitches {heave:.1}°");
}

#[test]
fn rising_at_speed_pitches_nose_up_from_the_leftover_added_mass_term() {
    // Forward at 30 % and up at 60 % for 2 s: nose up by tens of degrees.
    let (pitch, u, w) = open_loop("zeroed", 30.0, -60.0);
    eprintln!("zeroed C_A: peak pitch {pitch:.1}° (u {u:.2} m/s there; peak w {w:.2} m/s)");
    assert!(pitch > 15.0, "peak pitch {pitch:.1}°");
    // Diving at speed pitches nose down: the moment's sign follows u·w.
    let (down, _, _) = open_loop("zeroed", 30.0, 60.0);
    assert!(down < -15.0, "diving at speed: {down:.1}°");
    // The physical Munk moment (full C_A) turns the other way: the zeroing's leftover
    // half has the opposite sign of the whole.
    let (full, _, _) = open_loop("full", 30.0, -60.0);
    eprintln!("full C_A: peak pitch {full:.1}°");
    assert!(full < -10.0, "full C_A: {full:.1}°");
}

/// The station's autopilot (default configuration, noise-free depth): the depth step
/// the lab's generator makes, with the pilot's surge stick at 0 and at 0.3. Returns
/// the largest |pitch| after the step, deg.
fn autopilot_depth_step(surge_stick: f64) -> f64 {
    let mut s = sim("zeroed");
    let mut ctl =
        Controller::new(ControlConfig::default(), ModelSet::load_default().unwrap()).unwrap();
    let pilot = PilotInput {
        surge: surge_stick,
        ..PilotInput::default()
    };
    let at = |s: &Simulator| {
        let st = s.truth().state;
        Measurements {
            depth_m: Some(st.eta[2]),
            heading_deg: Some(st.eta[5].to_degrees()),
            yaw_rate_rad_s: Some(st.nu[5]),
        }
    };
    // The first tick gives the controller its measurements; holds need them.
    ctl.tick(0.0, &at(&s), &pilot);
    ctl.command(ModeCommand::SetDepth { depth_m: 5.0 }).unwrap();
    ctl.command(ModeCommand::SetHeading { heading_deg: 0.0 })
        .unwrap();
    let mut stepped = false;
    let mut worst = 0.0f64;
    while s.time_s() < 40.0 {
        let t = s.time_s();
        if t >= 20.0 && !stepped {
            ctl.command(ModeCommand::SetDepth { depth_m: 3.5 }).unwrap();
            stepped = true;
        }
        let c = ctl.tick(t, &at(&s), &pilot).command;
        s.set_command(ThrustPct::new(
            c.port_pct(),
            c.starboard_pct(),
            c.vertical_pct(),
        ))
        .unwrap();
        // 50 Hz control on the 100 Hz simulator.
        s.step().unwrap();
        s.step().unwrap();
        if t >= 20.0 {
            worst = worst.max(s.truth().state.eta[4].to_degrees().abs());
        }
    }
    worst
}

#[test]
fn the_station_autopilot_reproduces_the_finding_only_at_speed() {
    let still = autopilot_depth_step(0.0);
    let cruising = autopilot_depth_step(0.3);
    eprintln!(
        "1.5 m depth step under the autopilot: max |pitch| {still:.1}° at surge 0, {cruising:.1}° at surge 0.3"
    );
    assert!(still < 5.0, "surge 0: {still:.1}°");
    assert!(cruising > 20.0, "surge 0.3: {cruising:.1}°");
}
