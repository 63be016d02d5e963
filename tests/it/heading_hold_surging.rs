//! Heading and depth hold while the pilot drives full ahead (issue 25, item 5).
//!
//! Flown in the station at 300° with the forward stick full, the heading hunted ±3° at
//! about 2–4 Hz and the picture pitched ±2–3° (scripted through `topside record --sim
//! --fast`, 60 s of full forward at the default gain: pitch RMS 1.37° about its mean
//! against 0.20° at rest, heading RMS 0.70° against 0.51°; the port and starboard
//! commands swung 25 ↔ 75 % every 0.27 s).
//!
//! Cause: the allocation added the heading loop's differential demand in percent to the
//! surge common mode, while the thrust map is quadratic. A differential of `d` % about
//! 50 % of surge produces ~10× the moment the loop's thrust-map inversion (made about
//! zero surge) intended for small `d`, so the loop gain multiplied with the forward
//! stick and the hold limit-cycled against the 10 %/tick output slew limit; the vertical
//! loop, coupled through the pitch Munk moment at speed, followed. The fix allocates in
//! force (`rov_control::allocate_in_force`): the moment asked for is the moment
//! produced at any surge.
//!
//! Here: the whole station on virtual time (`VirtualStation`: mock link, the simulated
//! Pro 4 with its sensors and telemetry delay; the controller alone on the simulator
//! does not limit-cycle, the link's delay is part of it), truth figures over 45..90 s,
//! full forward stick from 30 s at gain steps 50 % and 75 %. Measured (gain 50 %):
//! before, truth heading RMS 0.50° (rest 0.05°), port command ripple 17.7 % RMS, pitch
//! 1.46° RMS; after, heading 0.09°, port ripple 0.29 %.
//!
//! **The pitch at speed: a worsening pinned knowingly.** With the heading steady, a
//! slower depth–pitch cycle at speed remains (period ~2.8 s, pitch ±4.7°, depth ±2 cm,
//! vertical ±25 %): at gain 50 % pitch RMS 1.46° before the fix, 2.97° after (the
//! heading's chatter had broken it up); at gain 75 % 0.38°. Mechanism, measured here
//! ([`pitch_at_speed_by_munk_treatment`], `--ignored`; truth over 45..90 s, full forward):
//!
//! | simulated vehicle, gain 50 % (u 0.70 m/s) | pitch RMS | depth RMS | vertical RMS |
//! |---|---|---|---|
//! | model3 as shipped (half Munk moment), depth hold on | 2.97° | 1.3 cm | 18.8 % |
//! | the same, depth hold off (vertical 0) | 0.05° | — | 0 |
//! | model3 with the whole Munk moment, depth hold on | 16.1°, hold lost | 44 cm | — |
//!
//! (gain 75 %, u 1.34 m/s: 0.38°, 0.26 cm, 8.2 %; depth hold off 0.23°; whole Munk
//! moment 11.6°, hold lost.) So the cycle is closed by the depth loop through the truth
//! model's pitch coupling: vertical thrust gives heave speed `w`, model3's half Munk
//! moment (−A11·u·w, `tests/it/pitch_at_speed.rs`) pitches the vehicle, and flying at
//! `u` with pitch θ moves the depth by u·sin θ, which the depth loop answers.
//!
//! Decision: **no change to the depth loop.** The coupling that closes the cycle is the
//! part of model3 that `pitch_at_speed.rs` already names as its defect (half of a Munk
//! moment, with the opposite sign of the physical one, against a 5.6 mm BG); the
//! physical treatment loses the vehicle outright at these speeds, and a real Pro 4 flies
//! level at 1 m/s on its hull's lift, which model3 lacks. Neither sign is a vehicle's,
//! so a feed-forward of the u·sin θ depth rate (with a u the Pro 4 does not measure: no
//! DVL) or a gain schedule tuned against it would be tuned to the simulator, and with
//! the physical sign the same feed-forward would push the wrong way. The depth hold
//! itself holds: 1.3 cm RMS at 0.70 m/s. The fix belongs to model3's pitch axis
//! (rov_dynamics, config/models), which moves every figure pinned to model3. The tests
//! below pin the cycle's mechanism and bound it, so a change to the model or to the
//! depth loop shows here.

use rov_control::{ModeCommand, ModelSet, PilotInput, ThrustDemand, allocate, allocate_in_force};
use rov_station::StationCommand;
use rov_station::runtime::{RuntimeConfig, VirtualStation};

const HEADING_DEG: f64 = 300.0;

const MODEL3: &str = include_str!("../../config/models/model3.toml");

/// RMS about the mean of truth pitch and the RMS of the truth heading error, deg.
#[derive(Debug, Clone, Copy)]
struct Wag {
    pitch_rms_deg: f64,
    heading_rms_deg: f64,
    /// Port command RMS about its mean, %.
    port_rms_pct: f64,
    /// Vertical command RMS about its mean, %.
    #[allow(dead_code, reason = "a figure printed for the module docs")]
    vertical_rms_pct: f64,
    /// Truth depth RMS about its mean, m.
    depth_rms_m: f64,
    /// Mean truth surge speed, m/s.
    #[allow(dead_code, reason = "a figure printed for the module docs")]
    surge_mps: f64,
}

fn rms_about_mean(v: &[f64]) -> f64 {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / n).sqrt()
}

/// The whole station on virtual time (mock link, simulated Pro 4 with its sensors and
/// telemetry delay, default gain step 50 %): depth hold 3 m and heading hold 300° from
/// 2 s, the surge stick at `surge` from 30 s on; scored over 45..90 s on the truth.
fn fly(surge: f64, gain_index: usize) -> Wag {
    fly_vehicle(surge, gain_index, None, true)
}

/// [`fly`] with the simulated vehicle's model3 Munk-moment treatment `munk` (`None`: as
/// shipped, `"zeroed"`), and with or without the depth hold.
fn fly_vehicle(surge: f64, gain_index: usize, munk: Option<&str>, depth_hold: bool) -> Wag {
    let sim_vehicle = munk.map(|m| {
        let text = MODEL3.replace(
            "munk_moment = \"zeroed\"",
            &format!("munk_moment = \"{m}\""),
        );
        rov_station::VehicleDynamics {
            label: format!("model3 munk {m}"),
            model: rov_dynamics::models::load_model("model3", &text, "model3.toml").unwrap(),
        }
    });
    let (mut st, handle) = VirtualStation::new(RuntimeConfig {
        gamepad: false,
        gain_index,
        sim_vehicle,
        ..RuntimeConfig::default()
    })
    .unwrap();
    let t0 = st.now_us();
    let (mut pitch, mut heading, mut port) = (Vec::new(), Vec::new(), Vec::new());
    let (mut vertical, mut depth, mut u) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..=4500u64 {
        let t = k as f64 * 0.02;
        if t < 2.0 && k % 10 == 0 && !handle.snapshot().armed {
            handle.send(StationCommand::Arm);
        }
        if k == 100 && depth_hold {
            handle.send(StationCommand::Mode(ModeCommand::SetDepth { depth_m: 3.0 }));
        }
        if k == 100 {
            handle.send(StationCommand::Mode(ModeCommand::SetHeading {
                heading_deg: HEADING_DEG,
            }));
        }
        if t >= 30.0 {
            handle.send(StationCommand::Sticks(PilotInput {
                surge,
                ..PilotInput::default()
            }));
        }
        st.advance_to(t0 + k * 20_000).unwrap();
        if t >= 45.0 {
            let s = st.vehicle().sim().truth().state;
            pitch.push(s.eta[4].to_degrees());
            heading.push(rov_types::angle::wrap_deg_180(
                s.eta[5].to_degrees() - HEADING_DEG,
            ));
            port.push(handle.snapshot().thrust.port_pct);
            vertical.push(handle.snapshot().thrust.vertical_pct);
            depth.push(s.eta[2]);
            u.push(s.nu[0]);
        }
    }
    assert!(handle.snapshot().armed);
    let n = heading.len() as f64;
    Wag {
        pitch_rms_deg: rms_about_mean(&pitch),
        heading_rms_deg: (heading.iter().map(|e| e * e).sum::<f64>() / n).sqrt(),
        port_rms_pct: rms_about_mean(&port),
        vertical_rms_pct: rms_about_mean(&vertical),
        depth_rms_m: rms_about_mean(&depth),
        surge_mps: u.iter().sum::<f64>() / u.len() as f64,
    }
}

#[test]
fn surging_at_full_stick_the_heading_holds_as_at_rest_and_the_depth_within_2_cm() {
    // Gain steps 50 % (the default) and 75 % (the pilot's report), full forward stick.
    for gain in [1, 2] {
        let rest = fly(0.0, gain);
        let w = fly(1.0, gain);
        eprintln!("gain step {gain}: rest {rest:?}\n        full forward: {w:?}");
        // The truth heading at speed within 2x of rest, or 0.1°, whichever is larger, plus
        // 0.05° (at rest it is ~0.05°: the compass noise the loop sees; the limit cycle
        // was 0.50° at gain 50 %; now 0.09°, 0.12° at gain 75 %).
        assert!(
            w.heading_rms_deg < (2.0 * rest.heading_rms_deg).max(0.1) + 0.05,
            "gain {gain}: {w:?} vs rest {rest:?}"
        );
        // No thruster hunting: the port command ripples by a few % (was 17.7 % RMS, now
        // 0.29 %).
        assert!(w.port_rms_pct < 2.0, "gain {gain}: {w:?}");
        // The depth hold holds at speed (1.3 cm RMS at gain 50 %, 0.26 cm at 75 %).
        assert!(w.depth_rms_m < 0.02, "gain {gain}: {w:?}");
        // A WORSENING, pinned knowingly (module docs): the depth-pitch cycle through
        // model3's half Munk moment, 1.46° before the fix at gain 50 %, 2.97° now. It is
        // bounded here so that it cannot grow unnoticed.
        assert!(w.pitch_rms_deg < 3.5, "gain {gain}: {w:?}");
    }
}

#[test]
fn the_pitch_cycle_at_speed_is_closed_by_the_depth_loop_through_the_truth_model() {
    // Gain 50 %, full forward, on model3 as shipped: with the depth hold the cycle is
    // there; with the vertical thruster idle the pitch is steady. If this fails, the
    // model's pitch axis or the depth loop changed: revisit the module docs' decision.
    let held = fly_vehicle(1.0, 1, None, true);
    let free = fly_vehicle(1.0, 1, None, false);
    eprintln!("depth hold: {held:?}\nno depth hold: {free:?}");
    assert!(free.pitch_rms_deg < 0.2, "{free:?}");
    assert!(held.pitch_rms_deg > 1.0, "{held:?}");
}

#[test]
fn a_differential_in_force_produces_the_moment_the_loop_asked_for_at_any_surge() {
    let plant = ModelSet::load_default()
        .unwrap()
        .get(rov_control::ModelChoice::Model3)
        .clone();
    use rov_control::FeedforwardModel;
    for yaw_pct in [-30.0, -5.0, 2.0, 10.0] {
        let wanted = plant.yaw_moment_for_pct(yaw_pct, -yaw_pct);
        for surge_pct in [0.0, 30.0, 50.0, 75.0, -50.0] {
            let d = ThrustDemand {
                surge_pct,
                yaw_pct,
                vertical_pct: 0.0,
            };
            let a = allocate_in_force(d, 100.0, &plant);
            let got = plant.yaw_moment_for_pct(a.port_pct, a.starboard_pct);
            assert!(
                (got - wanted).abs() < 1e-6,
                "yaw {yaw_pct} % surge {surge_pct} %: {got} N m vs {wanted}"
            );
            // The percent allocation's error this replaces (the loop gain it multiplied).
            let p = allocate(d, 100.0);
            let old = plant.yaw_moment_for_pct(p.port_pct, p.starboard_pct);
            if surge_pct == 50.0 && yaw_pct == 2.0 {
                assert!(old > 5.0 * wanted, "{old} vs {wanted}");
            }
        }
    }
    // Saturation keeps the moment and lowers the surge.
    let a = allocate_in_force(
        ThrustDemand {
            surge_pct: 95.0,
            yaw_pct: 30.0,
            vertical_pct: 0.0,
        },
        100.0,
        &plant,
    );
    let wanted = plant.yaw_moment_for_pct(30.0, -30.0);
    assert!(a.surge_reduced && a.port_pct <= 100.0 && a.starboard_pct <= 100.0);
    assert!((plant.yaw_moment_for_pct(a.port_pct, a.starboard_pct) - wanted).abs() < 1e-6);
}

/// The figures behind the module docs' pitch table (`--ignored --nocapture`): full
/// forward at both gain steps on the shipped model3 (half Munk moment) with and without
/// the depth hold, and on model3 with the whole Munk moment.
#[test]
#[ignore = "measurement: prints the pitch at speed per Munk treatment (about 10 s)"]
fn pitch_at_speed_by_munk_treatment() {
    for (munk, depth_hold) in [("zeroed", true), ("zeroed", false), ("full", true)] {
        for gain in [1, 2] {
            let w = fly_vehicle(1.0, gain, Some(munk), depth_hold);
            eprintln!("munk {munk} depth hold {depth_hold} gain step {gain}: {w:?}");
        }
    }
}
