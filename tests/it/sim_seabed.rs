//! The simulated vehicle meets the seabed its camera shows (issue 25, item 6).
//!
//! The station's simulated Pro 4 dived to 8 m through the 6 m seabed of its own camera
//! picture, whose renderer clamps the camera above the bottom, so below it the picture
//! froze. Now the simulator carries the same seabed (`rov_sim::Seabed`, from
//! `[video] sim_seabed_depth_m`) with a spring–damper contact at the hull's lowest point.

use rov_control::PilotInput;
use rov_station::StationCommand;
use rov_station::runtime::{RuntimeConfig, VirtualStation};

/// The depth of the hull's lowest corner (box 0.375 × 0.289 m, bottom 0.11 m below the
/// origin) for a true state.
fn lowest_corner_m(eta: &[f64]) -> f64 {
    let (phi, theta) = (eta[3], eta[4]);
    eta[2]
        + 0.1875 * theta.sin().abs()
        + 0.1445 * (theta.cos() * phi.sin()).abs()
        + 0.11 * theta.cos() * phi.cos()
}

/// Full dive stick for `secs` after arming; the deepest true depth of the hull's lowest
/// corner and the true depth and heave speed of the body origin at the end.
fn dive(seabed_m: Option<f64>, secs: f64, surge: f64) -> (f64, f64, f64) {
    let mut cfg = RuntimeConfig {
        gamepad: false,
        ..RuntimeConfig::default()
    };
    if let Some(d) = seabed_m {
        cfg.video.sim_seabed_depth_m = d;
    }
    let (mut st, handle) = VirtualStation::new(cfg).unwrap();
    let t0 = st.now_us();
    let mut deepest = f64::NEG_INFINITY;
    let ticks = ((secs + 2.0) * 50.0) as u64;
    for k in 0..=ticks {
        let t = k as f64 * 0.02;
        if t < 2.0 && k % 10 == 0 && !handle.snapshot().armed {
            handle.send(StationCommand::Arm);
        }
        if t >= 2.0 {
            handle.send(StationCommand::Sticks(PilotInput {
                surge,
                yaw: 0.0,
                vertical: 1.0,
            }));
        }
        st.advance_to(t0 + k * 20_000).unwrap();
        deepest = deepest.max(lowest_corner_m(
            st.vehicle().sim().truth().state.eta.as_slice(),
        ));
    }
    assert!(handle.snapshot().armed, "the station never armed");
    let s = st.vehicle().sim().truth().state;
    (deepest, s.eta[2], s.nu[2])
}

#[test]
fn full_dive_stick_lands_on_the_default_seabed_and_stays_there() {
    let bed = rov_sim::Seabed::at_depth(6.0);
    // 40 s of full down from the surface reaches the bottom.
    let (deepest, end, w) = dive(None, 40.0, 0.0);
    eprintln!(
        "seabed 6 m: lowest corner {deepest:.3} m, origin at the end {end:.3} m, w {w:.3} m/s"
    );
    // On the bottom: the hull pressed in by under 1.5 cm with full thrust; the body
    // origin rests hull_bottom above the bed and stops.
    assert!(deepest < bed.depth_m + 0.015, "deepest {deepest:.3}");
    assert!(end > bed.resting_depth_m() - 0.01, "end {end:.3}");
    assert!(w.abs() < 0.01, "still moving {w:.3} m/s");
    // Driving full forward along the bottom: nothing goes through.
    let (deepest, _, _) = dive(None, 40.0, 1.0);
    eprintln!("surging on the bottom: lowest corner {deepest:.3} m");
    assert!(
        deepest < bed.depth_m + 0.02,
        "surging: deepest {deepest:.3}"
    );
}

#[test]
fn the_configured_seabed_is_the_one_the_vehicle_meets() {
    // A deeper configured seabed: the vehicle passes 6 m.
    let (deepest, _, _) = dive(Some(9.0), 40.0, 0.0);
    assert!(deepest > 7.0, "deepest {deepest:.3}");
    assert!(deepest < 9.015, "deepest {deepest:.3}");
}
