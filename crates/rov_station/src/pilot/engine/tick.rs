//! The engine's control tick, in phases: the pilot's input, the controller, the
//! records, the events, the link, the alarms, the prediction, the dive log and the view.

use super::*;

/// What the records phase hands to the later phases of a tick.
struct TickRecords {
    thrust: ThrustRecord,
    pilot: PilotRecord,
    auto: AutopilotRecord,
    observer: ObserverRecord,
}

impl Engine {
    /// One control tick at `now_us`: returns what the controller commanded.
    pub fn tick(&mut self, link: &mut Link, now_us: u64) -> TickOutput {
        let t_s = now_us as f64 * 1e-6;
        let (raw, shaped, input) = self.pilot_phase(link, now_us);
        let out = self.core.tick(link, now_us);
        let test_thrust = self.thruster_test_tick(link, &raw, now_us);
        let dt_s = self
            .last_tick_us
            .map_or(0.0, |t| now_us.saturating_sub(t) as f64 * 1e-6);
        self.last_tick_us = Some(now_us);
        let recs = self.records_phase(link, &out, &raw, test_thrust);
        let armed = recs.pilot.armed;
        self.events_phase(
            armed,
            (recs.auto.depth_mode, recs.auto.heading_mode),
            now_us,
        );
        self.publish_records(recs, now_us);
        self.link_phase(link, t_s, now_us);
        let faults = out.diagnostics.faults;
        let sensor_fault = faults.depth_sensor_lost || faults.heading_sensor_lost;
        self.alarms_phase(link, sensor_fault, now_us);
        self.predict_phase(&out, t_s, dt_s);
        self.dive_phase(t_s, now_us);
        self.pipeline.set_time(t_s);
        self.pipeline
            .sensor_lost(faults.depth_sensor_lost, faults.heading_sensor_lost);
        self.view_phase(link, armed, (raw, shaped, input), now_us);
        let sample = self.pipeline.sample(t_s);
        self.pending.push(sample);
        out
    }

    /// Arming by holding a button, the sticks (shaped, gain, mapped onto the
    /// controller's deadband) and the lights and camera (they ride in the control block).
    fn pilot_phase(
        &mut self,
        link: &mut Link,
        now_us: u64,
    ) -> (PilotInput, PilotInput, &'static str) {
        let (raw, input) = self.pilot_input(link, now_us);
        let arm_gui = self.arm.poll(now_us);
        let arm_pad = self.arm_pad.poll(now_us);
        if self.arm.take_went_stale() || self.arm_pad.take_went_stale() {
            self.hint(ARM_STALE_HINT, now_us);
        }
        if (arm_gui || arm_pad) && !link.failsafe().is_armed() {
            match self.core.command(link, StationCommand::Arm, now_us) {
                Ok(()) => self.pipeline.view.last_refusal = None,
                Err(e) => self.refuse(now_us, "Arm", e.to_string()),
            }
        }
        let shaped = self.shaping.apply(&raw);
        let to_ctl = to_controller(&shaped, self.gain, &self.cfg.control);
        // Sticks are never refused (they only replace the pilot input).
        let _ = self
            .core
            .command(link, StationCommand::Sticks(to_ctl), now_us);
        let mut block: ControlBlock = *link.command();
        block.lights_pct = self.lights_pct;
        block.tilt_deg = self.tilt_deg;
        block.focus_pct = self.focus_pct;
        link.set_command(block);
        (raw, shaped, input)
    }

    /// The tick's records: thrust (the thruster test's while it runs), pilot, autopilot,
    /// observer.
    fn records_phase(
        &mut self,
        link: &Link,
        out: &TickOutput,
        raw: &PilotInput,
        test_thrust: Option<[f64; 3]>,
    ) -> TickRecords {
        let c = out.command;
        let cmd = *link.command();
        let [tp, ts, tv] =
            test_thrust.unwrap_or([c.port_pct(), c.starboard_pct(), c.vertical_pct()]);
        self.thrust_now_pct = [tp, ts, tv];
        let thrust = ThrustRecord {
            port_pct: tp,
            starboard_pct: ts,
            vertical_pct: tv,
            lights_pct: f64::from(cmd.lights_pct),
            tilt: f64::from(cmd.tilt_deg),
            focus: f64::from(cmd.focus_pct),
            depth_target_mbar: cmd.depth_target_mbar.map(f64::from),
            heading_target_deg: cmd.heading_target_deg.map(f64::from),
        };
        let pilot = PilotRecord {
            surge: raw.surge,
            yaw: raw.yaw,
            heave: raw.vertical,
            armed: link.failsafe().is_armed(),
            gain_pct: self.gain.pct(),
            buttons: held_names(self.pad_buttons),
        };
        TickRecords {
            thrust,
            pilot,
            auto: self.autopilot_record(),
            observer: observer_record(out),
        }
    }

    /// `/autopilot/state` now; also notes which axes the pilot overrides.
    fn autopilot_record(&mut self) -> AutopilotRecord {
        let ctl = self.core.controller();
        let ds = ctl.axis_state(Axis::Depth);
        let hs = ctl.axis_state(Axis::Heading);
        self.overridden = (ds.overridden, hs.overridden);
        AutopilotRecord {
            depth_mode: axis_mode(ds.mode),
            heading_mode: axis_mode(hs.mode),
            depth_setpoint_m: ctl.depth_setpoint_m(),
            heading_setpoint_deg: ctl.heading_setpoint_deg(),
            // The model name is taken from the last record unless it changed (no
            // allocation per tick).
            feedforward_model: {
                let name = if ctl.feedforward_enabled() {
                    ctl.model_label()
                } else {
                    ""
                };
                if self.last_model_name != name {
                    name.clone_into(&mut self.last_model_name);
                }
                std::mem::take(&mut self.last_model_name)
            },
        }
    }

    /// Events: arming and mode changes.
    fn events_phase(&mut self, armed: bool, modes: (Mode, Mode), now_us: u64) {
        if armed != self.prev_armed {
            self.prev_armed = armed;
            let (kind, text) = if armed {
                ("armed", "ARMED")
            } else {
                ("disarmed", "disarmed")
            };
            self.event(now_us, kind, Severity::Info, text.into());
        }
        if modes != self.prev_modes {
            self.prev_modes = modes;
            let text = format!("depth {} / heading {}", modes.0.as_str(), modes.1.as_str());
            self.event(now_us, "autopilot", Severity::Info, text);
        }
    }

    /// The tick's records into the view and, when wanted, to the recorder.
    fn publish_records(&mut self, recs: TickRecords, now_us: u64) {
        let TickRecords {
            thrust,
            pilot,
            auto,
            observer,
        } = recs;
        self.pipeline.thrust(&thrust);
        self.pipeline.pilot(&pilot);
        self.pipeline.autopilot(&auto);
        self.pipeline.observer(&observer);
        self.record(|t| RecordItem::Thrust(t, thrust), now_us);
        self.record(|t| RecordItem::Pilot(t, pilot), now_us);
        if self.records_wanted() {
            let rec = auto.clone();
            self.record(|t| RecordItem::Autopilot(t, rec), now_us);
        }
        self.last_model_name = auto.feedforward_model;
        self.record(|t| RecordItem::Observer(t, observer), now_us);
    }

    /// Link statistics every [`LINK_RECORD_US`], and the link's health in the view at once.
    fn link_phase(&mut self, link: &mut Link, t_s: f64, now_us: u64) {
        let health = match link.health() {
            Health::Connected => "connected",
            Health::Degraded => "degraded",
            Health::Lost => "lost",
        };
        if self.timers.at(Timer::LinkRecord).is_none()
            || self.timers.reached(Timer::LinkRecord, now_us)
        {
            self.timers
                .set(Timer::LinkRecord, now_us.saturating_add(LINK_RECORD_US));
            let k = link.counters();
            let rtt = link.rtt();
            let lr = LinkRecord {
                state: link_state(health),
                exchanges: k.requests,
                timeouts: k.failed_timeout,
                sync_errors: k.deframer.garbage_bytes,
                header_errors: k.failed_header_check,
                total_errors: k.failed(),
                unexpected: k.unexpected_frames,
                rtt_p50_ms: rtt.p50_us as f64 * 1e-3,
                rtt_p99_ms: rtt.p99_us as f64 * 1e-3,
            };
            self.pipeline.link(t_s, &lr);
            self.record(|t| RecordItem::Link(t, lr), now_us);
        }
        if self.pipeline.view.link.health != health {
            self.pipeline.view.link.health = health.to_string();
            self.pipeline.view.snapshot.link_health = health.to_string();
        }
    }

    /// The alarms: evaluated on this tick's inputs; each change is an event.
    fn alarms_phase(&mut self, link: &Link, sensor_fault: bool, now_us: u64) {
        let stall = self.watchdog_trips != self.watchdog_seen;
        self.watchdog_seen = self.watchdog_trips;
        let s = self.last_status;
        let inputs = AlarmInputs {
            link_lost: link.health() == Health::Lost,
            ever_connected: self.ever_connected,
            humidity_pct: self.pipeline.view.health.humidity_pct,
            depth_m: self.pipeline.view.snapshot.depth_m,
            turns: Some(self.pipeline.view.turns),
            tether_v: s.map(|s| s.tether_v),
            rail_v: s.map(|s| s.rail_12v_v),
            internal_temp_c: s.and_then(internal_temp_c),
            nav_age_s: self
                .last_nav_us
                .map(|t| now_us.saturating_sub(t) as f64 * 1e-6),
            sensor_fault,
            control_stall: stall,
            vehicle_changed_noise: self.vehicle_changed_noise,
        };
        for change in self.alarms.evaluate(now_us as f64 * 1e-6, &inputs) {
            match change {
                AlarmChange::Raised(k, level) => {
                    let (sev, what) = match level {
                        AlarmLevel::Alarm => (Severity::Alarm, "ALARM"),
                        AlarmLevel::Warning => (Severity::Warning, "warning"),
                    };
                    self.event(now_us, k.key(), sev, format!("{} ({what})", k.text()));
                }
                AlarmChange::Cleared(k) => self.event(
                    now_us,
                    k.key(),
                    Severity::Info,
                    format!("{} cleared (acknowledge to remove)", k.text()),
                ),
            }
        }
    }

    /// The prediction: the autopilot's own model (a custom plant when one is set) run
    /// ahead from the observer's estimate under the thrust commanded.
    fn predict_phase(&mut self, out: &TickOutput, t_s: f64, dt_s: f64) {
        let (w, r) = self.pipeline.observer_rates();
        let snap = &self.pipeline.view.snapshot;
        let anchor = Anchor {
            depth_m: snap.depth_estimate_m.or(snap.depth_m),
            w_mps: w,
            heading_deg: snap.heading_estimate_deg.or(snap.heading_deg),
            r_rad_s: r,
        };
        let ctl = self.core.controller();
        let model = match ctl.custom_plant() {
            Some(p) => p,
            None => self.models.get(ctl.model()),
        };
        if self.pipeline.view.model_label != ctl.model_label() {
            ctl.model_label()
                .clone_into(&mut self.pipeline.view.model_label);
        }
        let c = out.command;
        self.pipeline.view.prediction = self.predictor.step(
            model,
            t_s,
            dt_s,
            &anchor,
            [c.port_pct(), c.starboard_pct(), c.vertical_pct()],
        );
    }

    /// The dive log (a dive starts and ends with depth) and the checklist's automatic items.
    fn dive_phase(&mut self, t_s: f64, now_us: u64) {
        match self.dive.update(t_s, self.pipeline.view.snapshot.depth_m) {
            Some(DiveEvent::Started) => {
                let n = self.dive.view().dives;
                self.event(
                    now_us,
                    "dive_start",
                    Severity::Info,
                    format!("dive {n} started"),
                );
            }
            Some(DiveEvent::Ended {
                dive_s,
                max_depth_m,
            }) => {
                let n = self.dive.view().dives;
                let t = dive_s as u64;
                let text = format!(
                    "dive {n} ended: {:02}:{:02}, deepest {max_depth_m:.1} m",
                    t / 60,
                    t % 60
                );
                self.event(now_us, "dive_end", Severity::Info, text);
            }
            None => {}
        }
        self.pipeline.view.dive = self.dive.view();
        self.auto_items();
    }

    /// The view: hint expiry, arming, overrides, alarms, the pilot's input, recording.
    fn view_phase(
        &mut self,
        link: &Link,
        armed: bool,
        (raw, shaped, input): (PilotInput, PilotInput, &'static str),
        now_us: u64,
    ) {
        if self.timers.reached(Timer::Hint, now_us) {
            self.timers.clear(Timer::Hint);
            self.pipeline.view.hint = None;
        }
        let v = &mut self.pipeline.view;
        v.snapshot.armed = armed;
        v.snapshot.alarm = link.failsafe().alarm().map(|a| format!("{:?}", a.alarm));
        v.depth.overridden = self.overridden.0 && v.depth.mode != AxisModeView::Manual;
        v.heading.overridden = self.overridden.1 && v.heading.mode != AxisModeView::Manual;
        v.health.humidity_rate_pct_per_min = self.alarms.humidity_rate_pct_per_min();
        self.alarms.list_into(&mut v.alarms);
        v.pilot.raw = raw.into();
        v.pilot.shaped = shaped.into();
        v.pilot.gain_pct = self.gain.pct();
        v.pilot.gain_index = self.gain.index();
        v.pilot.arm_progress = self.arm.progress(now_us).max(self.arm_pad.progress(now_us));
        if v.pilot.input != input {
            input.clone_into(&mut v.pilot.input);
        }
        v.recording.elapsed_s = self
            .recording_started_us
            .map_or(0.0, |t| now_us.saturating_sub(t) as f64 * 1e-6);
    }
}

/// `/observer/state` from the controller's estimates (NaN where an axis has none).
fn observer_record(out: &TickOutput) -> ObserverRecord {
    let de = out.diagnostics.depth.estimate;
    let he = out.diagnostics.heading.estimate;
    ObserverRecord {
        depth_m: de.map_or(f64::NAN, |e| e.pos),
        heave_mps: de.map_or(f64::NAN, |e| e.vel),
        depth_bias: de.map_or(f64::NAN, |e| e.bias),
        heading_deg: he.map_or(f64::NAN, |e| e.pos.to_degrees()),
        yaw_rate_dps: he.map_or(f64::NAN, |e| e.vel.to_degrees()),
        heading_bias: he.map_or(f64::NAN, |e| e.bias),
        depth_var: de.map_or(f64::NAN, |e| e.pos_std * e.pos_std),
        heading_var: he.map_or(f64::NAN, |e| (e.pos_std.to_degrees()).powi(2)),
    }
}
