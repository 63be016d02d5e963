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
//! Mapping (standard layout): left stick Y = surge, left stick X = yaw, right stick Y =
//! vertical (push down to dive). Start held ~1 s = arm; Select (Back) = disarm (one
//! action); North = toggle depth hold; West = toggle heading hold; right/left bumper =
//! gain up/down; d-pad up/down = camera tilt ±10°; d-pad right/left = lights ±10 %;
//! East = acknowledge all alarms.

use std::sync::atomic::Ordering;
use std::sync::mpsc::SyncSender;
use std::time::Duration;

use gilrs::{Axis as PadAxis, Button, EventType, Gilrs};
use rov_control::{Axis, PilotInput};

use crate::core::StationCommand;
use crate::runtime::view::PadStatus;
use crate::runtime::{CameraCommand, GainCommand, RuntimeCommand, Shared, lock};

/// Sticks inside this radius count as centred for the reconnect rule.
const CENTRE: f64 = 0.1;

fn sticks(pad: &gilrs::Gamepad<'_>) -> PilotInput {
    let v = |a: PadAxis| f64::from(pad.value(a));
    PilotInput {
        surge: v(PadAxis::LeftStickY),
        yaw: v(PadAxis::LeftStickX),
        // gilrs: stick up is +1; pushing the right stick down dives.
        vertical: -v(PadAxis::RightStickY),
    }
}

fn button_names(pad: &gilrs::Gamepad<'_>) -> Vec<String> {
    const NAMED: [(Button, &str); 10] = [
        (Button::Start, "start"),
        (Button::Select, "select"),
        (Button::North, "north"),
        (Button::West, "west"),
        (Button::East, "east"),
        (Button::South, "south"),
        (Button::LeftTrigger, "lb"),
        (Button::RightTrigger, "rb"),
        (Button::DPadUp, "up"),
        (Button::DPadDown, "down"),
    ];
    NAMED
        .iter()
        .filter(|(b, _)| pad.is_pressed(*b))
        .map(|(_, n)| (*n).to_string())
        .collect()
}

/// Runs until the runtime stops.
pub(crate) fn run(shared: &Shared, cmds: &SyncSender<RuntimeCommand>) {
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
    let mut centred = false;
    let mut tilt = 0.0f64;
    let mut lights = 0.0f64;
    let send = |c: RuntimeCommand| {
        // A full queue drops the button press (counted by the handle's counter).
        if cmds.try_send(c).is_err() {
            shared.commands_dropped.fetch_add(1, Ordering::Relaxed);
        }
    };
    while shared.running.load(Ordering::Relaxed) {
        while let Some(ev) = gilrs.next_event() {
            match ev.event {
                EventType::Connected if active.is_none() => {
                    active = Some(ev.id);
                    centred = false;
                }
                EventType::Disconnected if active == Some(ev.id) => {
                    active = None;
                    centred = false;
                }
                EventType::ButtonPressed(b, _) if active == Some(ev.id) && centred => match b {
                    Button::Select => send(RuntimeCommand::Station(StationCommand::Disarm)),
                    Button::North => send(RuntimeCommand::ToggleHold(Axis::Depth)),
                    Button::West => send(RuntimeCommand::ToggleHold(Axis::Heading)),
                    Button::East => send(RuntimeCommand::AckAlarm(None)),
                    Button::RightTrigger => send(RuntimeCommand::Gain(GainCommand::Up)),
                    Button::LeftTrigger => send(RuntimeCommand::Gain(GainCommand::Down)),
                    Button::DPadUp | Button::DPadDown => {
                        let d = if b == Button::DPadUp { 10.0 } else { -10.0 };
                        tilt = (tilt + d).clamp(-90.0, 90.0);
                        send(RuntimeCommand::Camera(CameraCommand::Tilt(tilt)));
                    }
                    Button::DPadRight | Button::DPadLeft => {
                        let d = if b == Button::DPadRight { 10.0 } else { -10.0 };
                        lights = (lights + d).clamp(0.0, 100.0);
                        send(RuntimeCommand::Camera(CameraCommand::Lights(lights)));
                    }
                    _ => {}
                },
                _ => {}
            }
        }
        if active.is_none() {
            active = gilrs.gamepads().next().map(|(id, _)| id);
            centred = false;
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
                    let raw = sticks(&pad);
                    if !centred
                        && raw.surge.abs() < CENTRE
                        && raw.yaw.abs() < CENTRE
                        && raw.vertical.abs() < CENTRE
                    {
                        centred = true;
                    }
                    let name = pad.name().to_string();
                    s.live = centred;
                    s.sticks = if centred { raw } else { PilotInput::default() };
                    s.buttons = button_names(&pad);
                    s.arm_held = centred && pad.is_pressed(Button::Start);
                    s.status = if centred {
                        PadStatus::Connected(name)
                    } else {
                        PadStatus::WaitingForCentre(name)
                    };
                }
                None => {
                    s.live = false;
                    s.sticks = PilotInput::default();
                    s.buttons.clear();
                    s.arm_held = false;
                    s.status = PadStatus::NoPad;
                }
            }
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}
