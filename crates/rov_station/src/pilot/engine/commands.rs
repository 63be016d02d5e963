//! The engine's pilot commands.

use super::*;

impl Engine {
    /// One command. Commands for the world around the engine become [`Output`]s.
    pub(super) fn apply(&mut self, link: &mut Link, cmd: RuntimeCommand, now_us: u64) {
        match cmd {
            RuntimeCommand::Station(StationCommand::Sticks(p)) => {
                self.keyboard = Some(p);
                // Stale once more than the timeout old.
                let until = now_us.saturating_add(self.cfg.keyboard_timeout_us + 1);
                self.timers.set(Timer::KeyboardSticks, until);
            }
            RuntimeCommand::Station(c) => {
                let label = format!("{c:?}");
                match self.core.command(link, c, now_us) {
                    Ok(()) => {
                        if matches!(c, StationCommand::Disarm) {
                            self.arm = ArmHold::default();
                            self.arm_pad = ArmHold::default();
                        }
                        if matches!(c, StationCommand::Mode(_)) {
                            self.pipeline.view.last_refusal = None;
                        }
                    }
                    Err(e) => self.refuse(now_us, &label, e.to_string()),
                }
            }
            RuntimeCommand::ArmButton(b) => {
                self.arm.report(b, now_us);
                if self.arm.take_released_early() {
                    self.hint(ARM_HINT, now_us);
                }
            }
            RuntimeCommand::ToggleHold(axis) => {
                let m = if self.core.holding(axis) {
                    ModeCommand::Disengage(axis)
                } else {
                    ModeCommand::Engage(axis)
                };
                if let Err(e) = self.core.command(link, StationCommand::Mode(m), now_us) {
                    self.refuse(now_us, &format!("{m:?}"), e.to_string());
                }
            }
            RuntimeCommand::Gain(g) => {
                self.gain = match g {
                    GainCommand::Up => self.gain.up(),
                    GainCommand::Down => self.gain.down(),
                    GainCommand::Set(i) => Gain::with_index(i),
                };
            }
            RuntimeCommand::Camera(c) => match c {
                CameraCommand::Lights(x) if x.is_finite() => {
                    self.lights_pct = x.round().clamp(0.0, 100.0) as u8;
                }
                CameraCommand::Tilt(x) if x.is_finite() => {
                    self.tilt_deg = x.round().clamp(-90.0, 90.0) as i8;
                }
                CameraCommand::Focus(x) if x.is_finite() => {
                    self.focus_pct = x.round().clamp(-100.0, 100.0) as i8;
                }
                _ => {}
            },
            RuntimeCommand::Shaping(s) => self.shaping = s,
            RuntimeCommand::AckAlarm(k) => {
                self.alarms.acknowledge(k);
                self.alarms.list_into(&mut self.pipeline.view.alarms);
            }
            RuntimeCommand::AlarmLimits(c) => {
                self.alarms.set_config(c);
                self.pipeline.view.alarm_limits = c;
                self.event(
                    now_us,
                    "settings",
                    Severity::Info,
                    "alarm limits changed".into(),
                );
            }
            RuntimeCommand::ResetTurns => self.pipeline.reset_turns(),
            RuntimeCommand::Note(text) => {
                let n = self.dive.note();
                let text = format!("note {n}: {} ({})", text.trim(), self.where_now());
                self.event(now_us, "note", Severity::Info, text);
                self.pipeline.log_last_event();
            }
            RuntimeCommand::Marker => {
                let n = self.dive.marker();
                let text = format!("marker {n} ({})", self.where_now());
                self.event(now_us, "marker", Severity::Info, text);
                self.pipeline.log_last_event();
            }
            RuntimeCommand::Checklist(c) => self.checklist(link, c, now_us),
            RuntimeCommand::StartRecording(path) => {
                self.outputs.push_back(Output::StartRecording(path));
            }
            RuntimeCommand::StopRecording => self.outputs.push_back(Output::StopRecording),
            RuntimeCommand::FoxgloveLive(tap) => self.outputs.push_back(Output::FoxgloveLive(tap)),
            RuntimeCommand::Replay(_) => {}
            RuntimeCommand::PadMap(m) => {
                self.pipeline.view.pilot.pad_map = m.clone();
                self.cfg.pad_map = m;
            }
            RuntimeCommand::PadInput(st) => {
                self.virtual_pad = Some(st);
                let until = now_us.saturating_add(self.cfg.keyboard_timeout_us + 1);
                self.timers.set(Timer::VirtualPad, until);
            }
            RuntimeCommand::AutopilotModel { model, confirmed } => {
                self.autopilot_model(link, model, confirmed, now_us);
            }
            RuntimeCommand::InjectStall(d) => self.outputs.push_back(Output::Stall(d)),
            RuntimeCommand::InjectFault(spec) => self.outputs.push_back(Output::InjectFault(spec)),
            RuntimeCommand::Shutdown => self.outputs.push_back(Output::Shutdown),
        }
    }
}
