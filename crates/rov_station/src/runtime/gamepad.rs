//! The gamepad (gilrs, with hotplug), polled every 5 ms on its own thread.
//!
//! The pad is a *stream with a liveness flag*, never a "last value":
//!
//! * the thread stamps a heartbeat on every poll; the control loop treats sticks with a
//!   heartbeat older than 100 ms as centred (a stuck input thread means neutral);
//! * on disconnect the sticks go to centre at once;
//! * after a (re)connect the sticks count only once all three have been seen inside
//!   the centre zone (a pad that reconnects with a stick deflected, or reports a stale
//!   value, cannot drive the vehicle).
//!
//! This thread only reports the raw axes and buttons ([`PadState`]); the control tick
//! maps them with the pilot's [`PadMap`](crate::pilot::pad::PadMap) (axes, buttons,
//! shift layer), so a virtual pad takes the same path.

use std::sync::atomic::Ordering;
use std::time::Duration;

use gilrs::{Axis as GAxis, Button, EventType, Gilrs};

use crate::pilot::pad::{PadButton, PadState};
use crate::pilot::view::PadStatus;
use crate::runtime::{Shared, lock};

/// Sticks inside this radius count as centred for the reconnect rule.
const CENTRE: f64 = 0.1;

fn state(pad: &gilrs::Gamepad<'_>) -> PadState {
    let v = |a: GAxis| f64::from(pad.value(a));
    let mut st = PadState {
        axes: [
            v(GAxis::LeftStickX),
            v(GAxis::LeftStickY),
            v(GAxis::RightStickX),
            v(GAxis::RightStickY),
            v(GAxis::LeftZ),
            v(GAxis::RightZ),
        ],
        buttons: 0,
    };
    const NAMED: [(Button, PadButton); 16] = [
        (Button::South, PadButton::South),
        (Button::East, PadButton::East),
        (Button::North, PadButton::North),
        (Button::West, PadButton::West),
        (Button::LeftTrigger, PadButton::LeftBumper),
        (Button::RightTrigger, PadButton::RightBumper),
        (Button::LeftTrigger2, PadButton::LeftTrigger),
        (Button::RightTrigger2, PadButton::RightTrigger),
        (Button::Select, PadButton::Select),
        (Button::Start, PadButton::Start),
        (Button::LeftThumb, PadButton::LeftThumb),
        (Button::RightThumb, PadButton::RightThumb),
        (Button::DPadUp, PadButton::DPadUp),
        (Button::DPadDown, PadButton::DPadDown),
        (Button::DPadLeft, PadButton::DPadLeft),
        (Button::DPadRight, PadButton::DPadRight),
    ];
    for (g, b) in NAMED {
        if pad.is_pressed(g) {
            st.buttons |= b.bit();
        }
    }
    st
}

/// Sticks inside the centre zone on every axis.
fn centred(st: &PadState) -> bool {
    st.axes.iter().take(4).all(|x| x.abs() < CENTRE)
}

/// Runs until the runtime stops.
pub(crate) fn run(shared: &Shared) {
    let mut gilrs = match Gilrs::new() {
        Ok(g) => g,
        Err(e) => {
            let mut s = lock(&shared.pad);
            s.status = PadStatus::Unavailable(e.to_string());
            s.live = false;
            return;
        }
    };
    let mut active: Option<gilrs::GamepadId> = None;
    let mut is_centred = false;
    while shared.running.load(Ordering::Relaxed) {
        while let Some(ev) = gilrs.next_event() {
            match ev.event {
                EventType::Connected if active.is_none() => {
                    active = Some(ev.id);
                    is_centred = false;
                }
                EventType::Disconnected if active == Some(ev.id) => {
                    active = None;
                    is_centred = false;
                }
                _ => {}
            }
        }
        if active.is_none() {
            active = gilrs.gamepads().next().map(|(id, _)| id);
            is_centred = false;
        }
        let now = shared.clock.now_us();
        {
            let mut s = lock(&shared.pad);
            s.heartbeat_us = now;
            match active
                .map(|id| gilrs.gamepad(id))
                .filter(|p| p.is_connected())
            {
                Some(pad) => {
                    let raw = state(&pad);
                    if !is_centred && centred(&raw) {
                        is_centred = true;
                    }
                    let name = pad.name().to_string();
                    s.live = is_centred;
                    s.raw = raw;
                    s.state = if is_centred { raw } else { PadState::default() };
                    s.status = if is_centred {
                        PadStatus::Connected(name)
                    } else {
                        PadStatus::WaitingForCentre(name)
                    };
                }
                None => {
                    s.live = false;
                    s.state = PadState::default();
                    s.raw = PadState::default();
                    s.status = PadStatus::NoPad;
                }
            }
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}
