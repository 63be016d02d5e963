//! Normal flight on the simulated vehicle raises no nuisance alarm (issue 25, item 9):
//! full forward with a hold, then everything at once (all three thrusters at full), at
//! the default alarm limits.

use rov_control::{ModeCommand, PilotInput};
use rov_station::StationCommand;
use rov_station::runtime::{RuntimeConfig, VirtualStation};

#[test]
fn full_thrust_on_the_simulated_vehicle_raises_no_alarm_at_default_limits() {
    // Gain step 100 %: the sticks give full thrust.
    let (mut st, handle) = VirtualStation::new(RuntimeConfig {
        gamepad: false,
        gain_index: 3,
        ..RuntimeConfig::default()
    })
    .unwrap();
    let t0 = st.now_us();
    let mut lowest_tether_v = f64::INFINITY;
    for k in 0..=2000u64 {
        let t = k as f64 * 0.02;
        if t < 2.0 && k % 10 == 0 && !handle.snapshot().armed {
            handle.send(StationCommand::Arm);
        }
        if k == 100 {
            handle.send(StationCommand::Mode(ModeCommand::SetDepth { depth_m: 2.0 }));
        }
        if t >= 3.0 {
            // 3..20 s full forward under the depth hold; 20..40 s full on all three
            // (full rise: the vehicle floats at the surface). A full turn for long winds
            // the tether (TETHER TURNS, a real alarm), so no yaw here.
            let all = t >= 20.0;
            handle.send(StationCommand::Sticks(PilotInput {
                surge: 1.0,
                yaw: 0.0,
                vertical: if all { -1.0 } else { 0.0 },
            }));
        }
        st.advance_to(t0 + k * 20_000).unwrap();
        let v = handle.view();
        if let Some(tv) = v.snapshot.tether_v {
            lowest_tether_v = lowest_tether_v.min(tv);
        }
        let up: Vec<String> = v.alarms.iter().map(|a| a.describe()).collect();
        assert!(up.is_empty(), "t = {t:.2} s: {up:?}");
    }
    assert!(handle.snapshot().armed);
    eprintln!("lowest tether voltage {lowest_tether_v:.2} V");
    assert!(
        lowest_tether_v.is_finite() && lowest_tether_v < 74.0,
        "{lowest_tether_v}"
    );
}
