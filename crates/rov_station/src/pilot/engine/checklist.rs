//! The pre-dive checklist of the engine: its items, the thruster test and the automatic checks.

use super::*;

/// "Zero depth here" accepts a depth reading within this of 0, m. A vehicle floating at
/// the surface reads about its own half height (0.11 m for the Pro 4) plus the day's
/// air-pressure change since the last zero (±30 mbar, ±0.3 m); anything deeper is a
/// vehicle under water, whose zero would offset every depth of the dive. It was 2 m, so
/// the simulated vehicle's start at 1 m was accepted as the surface (issue 25).
pub(crate) const ZERO_DEPTH_WINDOW_M: f64 = 0.5;

impl Engine {
    /// "at 12.3 m, heading 090°, dive 03:12" for notes and markers.
    pub(super) fn where_now(&self) -> String {
        let s = &self.pipeline.view.snapshot;
        let d = s
            .depth_m
            .map_or_else(|| "depth ---".into(), |d| format!("at {d:.1} m"));
        let h = s.heading_deg.map_or_else(
            || "heading ---".into(),
            |h| format!("heading {}°", rov_types::angle::compass_text(h)),
        );
        let t = self.dive.view().dive_s as u64;
        format!("{d}, {h}, dive {:02}:{:02}", t / 60, t % 60)
    }

    pub(super) fn set_item(&mut self, item: Item, status: ItemStatus, detail: String) {
        if let Some(i) = self.pipeline.view.checklist.item_mut(item) {
            i.status = status;
            i.detail = detail;
        }
    }

    pub(super) fn checklist(&mut self, link: &mut Link, c: ChecklistCommand, now_us: u64) {
        let t_s = now_us as f64 * 1e-6;
        match c {
            ChecklistCommand::CompassOk | ChecklistCommand::CompassBad => {
                let h = self.pipeline.view.snapshot.heading_deg;
                let hs = h.map_or_else(
                    || "---".into(),
                    |h| format!("{}°", rov_types::angle::compass_text(h)),
                );
                let (st, d) = match (c, h) {
                    (_, None) => (ItemStatus::Fail, "no heading from the vehicle".to_string()),
                    (ChecklistCommand::CompassOk, Some(_)) => (
                        ItemStatus::Pass,
                        format!("heading {hs} matches the known bearing"),
                    ),
                    _ => (ItemStatus::Fail, format!("heading {hs} does not match")),
                };
                self.set_item(Item::Compass, st, d);
            }
            ChecklistCommand::ZeroDepth => {
                let depth = self.pipeline.view.snapshot.depth_m;
                match (self.last_pressure_mbar, depth) {
                    (Some(p), Some(d)) if d.abs() < ZERO_DEPTH_WINDOW_M => {
                        let was = link.config().conventions.surface_pressure_mbar;
                        // The controller first: a pressure it refuses changes neither
                        // (the link's depth and the autopilot's target must agree).
                        let cmd =
                            StationCommand::Mode(ModeCommand::SetSurfaceTare { pressure_mbar: p });
                        if let Err(e) = self.core.command(link, cmd, now_us) {
                            let text = format!(
                                "depth not zeroed: surface pressure {p:.0} mbar refused ({e}); still {was:.0} mbar"
                            );
                            self.event(now_us, "depth_zero", Severity::Warning, text.clone());
                            self.set_item(Item::DepthZero, ItemStatus::Fail, text);
                            return;
                        }
                        link.set_surface_pressure_mbar(p);
                        let text = format!(
                            "depth zeroed: surface pressure {p:.0} mbar (was {was:.0}; depth read {d:+.2} m)"
                        );
                        self.event(now_us, "depth_zero", Severity::Info, text.clone());
                        self.set_item(Item::DepthZero, ItemStatus::Pass, text);
                    }
                    (_, Some(d)) => self.set_item(
                        Item::DepthZero,
                        ItemStatus::Fail,
                        format!(
                            "not at the surface (depth reads {d:.2} m, more than \
                             {ZERO_DEPTH_WINDOW_M} m from 0): surface the vehicle, then zero"
                        ),
                    ),
                    _ => self.set_item(
                        Item::DepthZero,
                        ItemStatus::Fail,
                        "no pressure reading".into(),
                    ),
                }
            }
            ChecklistCommand::StartThrusterTest => {
                if !link.failsafe().is_armed() {
                    self.set_item(
                        Item::Thrusters,
                        ItemStatus::Fail,
                        "arm first (the test drives each thruster for 1 s)".into(),
                    );
                    return;
                }
                // Holds off: the test commands the thrusters itself.
                for axis in [Axis::Depth, Axis::Heading] {
                    if self.core.holding(axis) {
                        let m = StationCommand::Mode(ModeCommand::Disengage(axis));
                        // Disengaging is never refused (no arming or range check).
                        let _ = self.core.command(link, m, now_us);
                    }
                }
                let idle = self.last_status.map(|s| s.rail_12v_a);
                let mut test = ThrusterTest {
                    started_s: t_s,
                    ..ThrusterTest::default()
                };
                for r in &mut test.results {
                    r.idle_a = idle;
                }
                self.thruster_test = Some(test);
                self.test_pct = [0.0; 3];
                self.set_item(Item::Thrusters, ItemStatus::Running, "running".into());
                self.event(
                    now_us,
                    "checklist",
                    Severity::Info,
                    "thruster test started".into(),
                );
            }
            ChecklistCommand::AbortThrusterTest => {
                self.end_thruster_test(now_us, Some("stopped by the pilot"))
            }
            ChecklistCommand::Record => self.record_checklist(now_us),
        }
    }

    pub(super) fn record_checklist(&mut self, now_us: u64) {
        let c = &self.pipeline.view.checklist;
        let all = c.passed() == Item::ALL.len();
        let text = c.summary();
        self.pipeline.view.checklist.recorded = true;
        let sev = if all {
            Severity::Info
        } else {
            Severity::Warning
        };
        self.event(now_us, "checklist", sev, text);
    }

    pub(super) fn end_thruster_test(&mut self, now_us: u64, aborted: Option<&str>) {
        let Some(test) = self.thruster_test.take() else {
            return;
        };
        self.test_pct = [0.0; 3];
        self.pipeline.view.checklist.test_running = None;
        self.pipeline.view.checklist.thrusters = test.results;
        let detail = thruster_detail(&test.results);
        let (st, text) = match aborted {
            Some(why) => (ItemStatus::Fail, format!("aborted ({why}); {detail}")),
            None => {
                let dead: Vec<&str> = THRUSTERS
                    .iter()
                    .zip(&test.results)
                    .filter(|(_, r)| !r.drew_current())
                    .map(|(n, _)| *n)
                    .collect();
                if dead.is_empty() {
                    (ItemStatus::Pass, detail)
                } else {
                    (
                        ItemStatus::Fail,
                        format!("no current rise on {}; {detail}", dead.join(", ")),
                    )
                }
            }
        };
        self.event(
            now_us,
            "checklist",
            Severity::Info,
            format!("thruster test: {text}"),
        );
        self.set_item(Item::Thrusters, st, text);
    }

    /// The thruster test's command for this tick (after the controller's), or None.
    pub(super) fn thruster_test_tick(
        &mut self,
        link: &mut Link,
        raw: &PilotInput,
        now_us: u64,
    ) -> Option<[f64; 3]> {
        let test = self.thruster_test?;
        let t_s = now_us as f64 * 1e-6;
        let abort = if !link.failsafe().is_armed() {
            Some("disarmed")
        } else if link.health() == Health::Lost {
            Some("link lost")
        } else if raw.surge.abs() > 0.2 || raw.yaw.abs() > 0.2 || raw.vertical.abs() > 0.2 {
            Some("stick moved")
        } else {
            None
        };
        if abort.is_some() {
            self.end_thruster_test(now_us, abort);
            return None;
        }
        let Some((target, running)) = test.command(t_s) else {
            self.end_thruster_test(now_us, None);
            return None;
        };
        // Ramp at the output guard's default rate (10 % a tick).
        for (p, t) in self.test_pct.iter_mut().zip(target) {
            *p += (t - *p).clamp(-10.0, 10.0);
        }
        let pct = self.test_pct;
        link.set_thrust(&PhysicsThrust {
            port_pct: pct[0],
            starboard_pct: pct[1],
            vertical_pct: pct[2],
        });
        let current = self.last_status.map(|s| s.rail_12v_a);
        if let Some(t) = self.thruster_test.as_mut()
            && let Some(i) = running
            && let Some(r) = t.results.get_mut(i)
        {
            r.commanded_pct = r.commanded_pct.max(pct.get(i).copied().unwrap_or(0.0));
            if let Some(a) = current {
                r.peak_a = Some(r.peak_a.map_or(a, |p: f64| p.max(a)));
            }
        }
        if let Some(t) = &self.thruster_test {
            self.pipeline.view.checklist.thrusters = t.results;
        }
        self.pipeline.view.checklist.test_running = Some(running);
        Some(pct)
    }

    /// The items the station checks by itself: leak and recording.
    pub(super) fn auto_items(&mut self) {
        if self.pipeline.view.checklist.recorded {
            return;
        }
        let lim = self.alarms.config();
        let h = self.pipeline.view.health.humidity_pct;
        let rate = self.alarms.humidity_rate_pct_per_min();
        // Only when something shown changes (no text formatted per tick).
        let key = (
            u8::from(h.is_some()) + 2 * u8::from(rate.is_some()),
            h.map_or(0, |h| (h * 10.0).round() as i64),
            rate.map_or(0, |r| (r * 10.0).round() as i64),
            self.pipeline.view.recording.path.is_some(),
        );
        if self.auto_key == Some(key) {
            return;
        }
        self.auto_key = Some(key);
        let (st, d) = match h {
            None => (
                ItemStatus::Pending,
                "waiting for the humidity reading".to_string(),
            ),
            Some(h) if h >= lim.humidity_pct.warn => (
                ItemStatus::Fail,
                format!(
                    "humidity {h:.1} % at or above {:.0} %",
                    lim.humidity_pct.warn
                ),
            ),
            Some(h) => match rate {
                Some(r) if r >= lim.humidity_rise_pct_per_min.warn => (
                    ItemStatus::Fail,
                    format!("humidity {h:.1} % rising {r:+.1} %/min"),
                ),
                Some(r) => (
                    ItemStatus::Pass,
                    format!("humidity {h:.1} %, {r:+.1} %/min"),
                ),
                None => (
                    ItemStatus::Pass,
                    format!("humidity {h:.1} % (rate after 10 s)"),
                ),
            },
        };
        self.set_item(Item::Leak, st, d);
        let rec = match &self.pipeline.view.recording.path {
            Some(p) => (
                ItemStatus::Pass,
                p.file_name()
                    .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
            ),
            None => (ItemStatus::Fail, "not recording".to_string()),
        };
        self.set_item(Item::Recording, rec.0, rec.1);
    }
}
