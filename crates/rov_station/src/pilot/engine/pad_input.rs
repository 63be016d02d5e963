//! The engine's pilot input: the gamepad (or a virtual pad), its button actions and the
//! choice between pad and GUI sticks.

use super::*;

impl Engine {
    /// The pad this tick: the gamepad thread's, or a virtual pad's (tests), mapped with
    /// the pilot's map. Buttons act on their press (the shift layer while the shift
    /// button is held); the arm button is timed like the GUI's.
    pub(super) fn pad_input(&mut self, link: &mut Link, now_us: u64) -> Option<PilotInput> {
        // The slot is taken out for the borrow checker and put back below (no copy).
        let slot = std::mem::take(&mut self.pad_slot);
        let (state, raw, live) = {
            let fresh = now_us.saturating_sub(slot.heartbeat_us) <= PAD_STALE_US;
            match self.virtual_pad {
                Some(st) if self.timers.running(Timer::VirtualPad, now_us) => {
                    if !self.virtual_centred && virtual_centred(&st) {
                        self.virtual_centred = true;
                    }
                    let live = self.virtual_centred;
                    let status = if live {
                        PadStatus::Connected("virtual pad".into())
                    } else {
                        PadStatus::WaitingForCentre("virtual pad".into())
                    };
                    if self.pipeline.view.pilot.pad != status {
                        self.pipeline.view.pilot.pad = status;
                    }
                    (if live { st } else { PadState::default() }, st, live)
                }
                _ => {
                    if self.virtual_pad.take().is_some() {
                        self.virtual_centred = false;
                        self.timers.clear(Timer::VirtualPad);
                    }
                    let status = if fresh || matches!(slot.status, PadStatus::Off) {
                        &slot.status
                    } else {
                        &STALE_PAD
                    };
                    if self.pipeline.view.pilot.pad != *status {
                        self.pipeline.view.pilot.pad = status.clone();
                    }
                    let live = slot.live && fresh;
                    (
                        if live {
                            slot.state
                        } else {
                            PadState::default()
                        },
                        if fresh { slot.raw } else { PadState::default() },
                        live,
                    )
                }
            }
        };
        self.pad_slot = slot;
        self.pipeline.view.pilot.pad_raw = raw;
        let map = &self.cfg.pad_map;
        let shift = map.shift.is_some_and(|b| state.held(b));
        self.pipeline.view.pilot.shift = shift;
        // Arm: held (in the current layer) and timed by the runtime.
        let arm_held = PadButton::ALL
            .iter()
            .any(|b| state.held(*b) && map.action(*b, shift) == Some(Action::Arm));
        self.arm_pad.report(arm_held, now_us);
        if self.arm_pad.take_released_early() {
            self.hint(ARM_HINT, now_us);
        }
        let pressed = state.buttons & !self.pad_buttons;
        self.pad_buttons = state.buttons;
        if pressed != 0 {
            let actions: Vec<Action> = PadButton::ALL
                .iter()
                .filter(|b| pressed & b.bit() != 0)
                .filter_map(|b| self.cfg.pad_map.action(*b, shift))
                .collect();
            for a in actions {
                self.pad_action(link, a, now_us);
            }
        }
        live.then(|| PilotInput {
            surge: state.axis(self.cfg.pad_map.surge),
            yaw: state.axis(self.cfg.pad_map.yaw),
            // Stick up rises; positive vertical dives.
            vertical: -state.axis(self.cfg.pad_map.vertical),
        })
    }

    /// A gamepad button's function.
    pub(super) fn pad_action(&mut self, link: &mut Link, a: Action, now_us: u64) {
        let cmd = match a {
            Action::Arm => return, // timed in pad_input
            Action::Disarm => RuntimeCommand::Station(StationCommand::Disarm),
            Action::DepthHold => RuntimeCommand::ToggleHold(Axis::Depth),
            Action::HeadingHold => RuntimeCommand::ToggleHold(Axis::Heading),
            Action::GainUp => RuntimeCommand::Gain(GainCommand::Up),
            Action::GainDown => RuntimeCommand::Gain(GainCommand::Down),
            Action::LightsUp => {
                RuntimeCommand::Camera(CameraCommand::Lights(f64::from(self.lights_pct) + 10.0))
            }
            Action::LightsDown => {
                RuntimeCommand::Camera(CameraCommand::Lights(f64::from(self.lights_pct) - 10.0))
            }
            Action::TiltUp => {
                RuntimeCommand::Camera(CameraCommand::Tilt(f64::from(self.tilt_deg) + 10.0))
            }
            Action::TiltDown => {
                RuntimeCommand::Camera(CameraCommand::Tilt(f64::from(self.tilt_deg) - 10.0))
            }
            Action::TiltCentre => RuntimeCommand::Camera(CameraCommand::Tilt(0.0)),
            Action::Record => {
                if self.recording() {
                    self.outputs.push_back(Output::StopRecording);
                } else if let Some(dir) = self.cfg.recordings_dir.clone() {
                    self.outputs.push_back(Output::StartRecordingIn(dir));
                }
                return;
            }
            Action::Marker => RuntimeCommand::Marker,
            Action::AckAlarms => RuntimeCommand::AckAlarm(None),
            Action::ResetTurns => RuntimeCommand::ResetTurns,
        };
        self.apply(link, cmd, now_us);
    }

    pub(super) fn pilot_input(
        &mut self,
        link: &mut Link,
        now_us: u64,
    ) -> (PilotInput, &'static str) {
        let pad = self.pad_input(link, now_us);
        let kb = self
            .keyboard
            .filter(|_| self.timers.running(Timer::KeyboardSticks, now_us));
        let pick = |a: f64, b: f64| if b.abs() > a.abs() { b } else { a };
        match (pad, kb) {
            (Some(p), Some(k)) => (
                PilotInput {
                    surge: pick(p.surge, k.surge),
                    yaw: pick(p.yaw, k.yaw),
                    vertical: pick(p.vertical, k.vertical),
                },
                "gamepad+keyboard",
            ),
            (Some(p), None) => (p, "gamepad"),
            (None, Some(k)) => (k, "keyboard"),
            (None, None) => (PilotInput::default(), "none"),
        }
    }
}
