//! The side panels: autopilot, health, link, camera, sticks; and the top bar's link pill
//! and recording control.

use egui::{Color32, RichText, Ui, vec2};
use rov_control::{Axis, ModeCommand, ModelChoice};
use rov_station::StationCommand;
use rov_station::runtime::{AxisModeView, CameraCommand, PadStatus, RuntimeCommand, StationView};
use rov_types::angle::compass_text;

use crate::app::StationApp;
use crate::instruments::{dot_label, group_title, stick_bar};
use crate::theme;

/// The start of a setpoint entry's error message.
const NOT_A_NUMBER: &str = "not a number: ";

fn opt(v: Option<f64>, digits: usize, unit: &str) -> String {
    v.map_or_else(|| "---".into(), |x| format!("{x:.digits$} {unit}"))
}

fn mode_cmd(app: &mut StationApp, m: ModeCommand) {
    app.live_cmd(RuntimeCommand::Station(StationCommand::Mode(m)));
}

fn axis_row(app: &mut StationApp, ui: &mut Ui, axis: Axis, v: &StationView, replay: bool) {
    let (name, av) = match axis {
        Axis::Depth => ("DEPTH", v.depth),
        Axis::Heading => ("HEADING", v.heading),
    };
    let mut name_id = None;
    ui.horizontal(|ui| {
        name_id = Some(
            ui.add_sized(
                vec2(64.0, 20.0),
                egui::Label::new(RichText::new(name).strong()),
            )
            .id,
        );
        let onboard = app.onboard;
        let engaged = av.mode != AxisModeView::Manual;
        let label = match av.mode {
            AxisModeView::Manual => "OFF",
            AxisModeView::Hold => "HOLD",
            AxisModeView::Onboard => "HOLD (onboard)",
        };
        let color = if !engaged {
            Color32::from_gray(60)
        } else if av.overridden {
            theme::AMBER
        } else {
            theme::GREEN
        };
        let b = egui::Button::new(RichText::new(label).strong().color(Color32::WHITE))
            .fill(color)
            .min_size(vec2(110.0, 24.0));
        let r = ui.add_enabled(!replay, b);
        if r.clicked() {
            let m = if engaged {
                ModeCommand::Disengage(axis)
            } else if onboard {
                ModeCommand::EngageVehicleAuto(axis)
            } else {
                ModeCommand::Engage(axis)
            };
            mode_cmd(app, m);
        }
        let sp = match axis {
            Axis::Depth => crate::settings::depth_text(av.setpoint, app.station.depth_unit, 2),
            Axis::Heading => av
                .setpoint
                .map_or("---".into(), |x| format!("{}°", compass_text(x))),
        };
        ui.label(
            RichText::new(sp)
                .monospace()
                .size(17.0)
                .color(theme::SETPOINT),
        );
        if av.overridden {
            ui.label(
                RichText::new("OVERRIDE")
                    .small()
                    .strong()
                    .color(theme::AMBER),
            );
        }
    });
    ui.add_enabled_ui(!replay, |ui| {
        ui.horizontal(|ui| {
            let steps: [(f64, &str); 4] = match axis {
                Axis::Depth => [(-1.0, "-1"), (-0.1, "-0.1"), (0.1, "+0.1"), (1.0, "+1")],
                Axis::Heading => [(-10.0, "-10"), (-1.0, "-1"), (1.0, "+1"), (10.0, "+10")],
            };
            for (d, label) in steps {
                if ui
                    .add(egui::Button::new(label).min_size(vec2(34.0, 20.0)))
                    .clicked()
                {
                    mode_cmd(
                        app,
                        match axis {
                            Axis::Depth => ModeCommand::StepDepth { delta_m: d },
                            Axis::Heading => ModeCommand::StepHeading { delta_deg: d },
                        },
                    );
                }
            }
            let feet = app.station.depth_unit == rov_station::runtime::settings::DepthUnit::Feet;
            let (text, hint) = match axis {
                Axis::Depth => (&mut app.depth_text, if feet { "ft" } else { "m" }),
                Axis::Heading => (&mut app.heading_text, "deg"),
            };
            let edit = egui::TextEdit::singleline(text)
                .hint_text(hint)
                .desired_width(54.0)
                .id_salt(("setpoint", name));
            let mut r = ui.add(edit);
            if let Some(id) = name_id {
                r = r.labelled_by(id);
            }
            let enter = r.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
            if ui.button("Go").clicked() || enter {
                let parsed = text.trim().replace(',', ".").parse::<f64>();
                match parsed {
                    Ok(x) if x.is_finite() => {
                        text.clear();
                        // A valid entry clears an earlier entry error (issue 25 item 10).
                        if app
                            .message
                            .as_deref()
                            .is_some_and(|m| m.starts_with(NOT_A_NUMBER))
                        {
                            app.message = None;
                        }
                        mode_cmd(
                            app,
                            match axis {
                                Axis::Depth => ModeCommand::SetDepth {
                                    depth_m: if feet {
                                        x / crate::settings::FT_PER_M
                                    } else {
                                        x
                                    },
                                },
                                Axis::Heading => ModeCommand::SetHeading { heading_deg: x },
                            },
                        );
                    }
                    _ => app.message = Some(format!("{NOT_A_NUMBER}{text:?}")),
                }
            }
        });
    });
}

pub(crate) fn autopilot_panel(app: &mut StationApp, ui: &mut Ui) {
    let (v, _) = app.shown();
    let v = v.clone();
    let replay = app.replay.is_some();
    ui.horizontal(|ui| {
        group_title(ui, "AUTOPILOT");
        ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
            ui.add_enabled_ui(!replay, |ui| {
                ui.selectable_value(&mut app.onboard, true, "Onboard");
                ui.selectable_value(&mut app.onboard, false, "Topside");
            });
        });
    });
    axis_row(app, ui, Axis::Depth, &v, replay);
    axis_row(app, ui, Axis::Heading, &v, replay);
    ui.add_enabled_ui(!replay, |ui| {
        ui.horizontal(|ui| {
            let mut ff = v.feedforward;
            if ui.checkbox(&mut ff, "Feedforward").changed() {
                mode_cmd(app, ModeCommand::SetFeedforward(ff));
            }
            let mut model = v.model;
            // The model the autopilot uses: a shipped one, or a model file's name (the
            // full path in the tooltip).
            let shown = if v.model_label.is_empty() {
                model.name().to_string()
            } else {
                std::path::Path::new(&v.model_label)
                    .file_name()
                    .map_or_else(
                        || v.model_label.clone(),
                        |n| n.to_string_lossy().into_owned(),
                    )
            };
            // The shipped models, then the models folder's files (picking one loads it
            // and sends it; the station refuses it while armed or when it is invalid).
            let mut file: Option<std::path::PathBuf> = None;
            let mut pick_shipped = false;
            let mut rescan = false;
            egui::ComboBox::new("model", "model")
                .selected_text(shown.clone())
                .width(90.0)
                .show_ui(ui, |ui| {
                    for m in ModelChoice::ALL {
                        let on = v.model_label.is_empty() || v.model_label == m.name();
                        if ui.selectable_label(on && m == v.model, m.name()).clicked() {
                            model = m;
                            pick_shipped = true;
                        }
                    }
                    if app.models.dir.is_some() {
                        ui.separator();
                        for f in &app.models.files {
                            let name = f
                                .file_name()
                                .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
                            let r = ui.selectable_label(name == shown, &name);
                            if r.on_hover_text(f.display().to_string()).clicked() {
                                file = Some(f.clone());
                            }
                        }
                        if app.models.files.is_empty() {
                            ui.label(RichText::new("(no model files)").small().color(theme::DIM));
                        }
                        rescan = ui.button("Rescan models folder").clicked();
                    }
                });
            if pick_shipped {
                mode_cmd(app, ModeCommand::SelectModel(model));
            }
            if rescan {
                app.models.rescan();
            }
            if let Some(f) = file {
                app.send_autopilot_model(crate::autopilot_model::load_file(&f), false);
            }
        });
        app.model_switch.show(ui);
        if let Some(e) = &app.models.error {
            ui.label(RichText::new(e).small().color(theme::RED));
        }
    });
    ui.label(
        RichText::new("Centre the stick to hold, move it to override, release to latch; drag the tapes or type to set.")
            .small()
            .color(theme::DIM),
    );
}

fn level(x: Option<f64>, warn: impl Fn(f64) -> bool, alarm: impl Fn(f64) -> bool) -> Color32 {
    match x {
        None => theme::DIM,
        Some(x) if alarm(x) => theme::RED,
        Some(x) if warn(x) => theme::AMBER,
        Some(_) => theme::GREEN,
    }
}

/// The colour of a value against a pilot's limit: above it (`high`) or below it.
fn against(x: Option<f64>, l: rov_station::runtime::Limit, high: bool) -> Color32 {
    if high {
        level(x, |v| v >= l.warn, |v| v >= l.alarm)
    } else {
        level(x, |v| v <= l.warn, |v| v <= l.alarm)
    }
}

pub(crate) fn health_panel(app: &StationApp, ui: &mut Ui) {
    let v = app.shown().0;
    let h = &v.health;
    let lim = &v.alarm_limits;
    let tu = app.station.temp_unit;
    group_title(ui, "HEALTH");
    egui::Grid::new("health")
        .num_columns(2)
        .spacing(vec2(10.0, 3.0))
        .show(ui, |ui| {
            let rate = h
                .humidity_rate_pct_per_min
                .map_or(String::new(), |r| format!("  ({r:+.1} %/min)"));
            let hc = against(h.humidity_pct, lim.humidity_pct, true);
            let rc = against(
                h.humidity_rate_pct_per_min,
                lim.humidity_rise_pct_per_min,
                true,
            );
            let color = if rc == theme::RED || hc == theme::RED {
                theme::RED
            } else if rc == theme::AMBER || hc == theme::AMBER {
                theme::AMBER
            } else {
                hc
            };
            dot_label(ui, color, "Humidity");
            ui.label(RichText::new(format!("{}{rate}", opt(h.humidity_pct, 1, "%"))).monospace());
            ui.end_row();
            dot_label(
                ui,
                level(h.water_temp_c, |x| x > 35.0, |_| false),
                "Water temp",
            );
            ui.label(RichText::new(crate::settings::temp_text(h.water_temp_c, tu)).monospace());
            ui.end_row();
            dot_label(
                ui,
                against(h.internal_temp_c, lim.internal_temp_c, true),
                "Internal temp",
            );
            ui.label(
                RichText::new(h.internal_temp_c.map_or_else(
                    || "not reported".into(),
                    |t| crate::settings::temp_text(Some(t), tu),
                ))
                .monospace(),
            );
            ui.end_row();
            dot_label(ui, against(h.tether_v, lim.tether_v, false), "Tether");
            ui.label(RichText::new(opt(h.tether_v, 1, "V")).monospace());
            ui.end_row();
            dot_label(ui, against(h.rail_v, lim.rail_12v_v, false), "12 V rail");
            ui.label(
                RichText::new(format!(
                    "{}  {}",
                    opt(h.rail_v, 2, "V"),
                    opt(h.rail_a, 2, "A")
                ))
                .monospace(),
            );
            ui.end_row();
            let t = &v.tick;
            let late_ms = t.p99_late_us as f64 * 1e-3;
            let tick_color = if t.missed > 0 || t.watchdog_trips > 0 {
                theme::RED
            } else if late_ms > 5.0 {
                theme::AMBER
            } else if t.ticks == 0 {
                theme::DIM
            } else {
                theme::GREEN
            };
            dot_label(ui, tick_color, "Control loop");
            ui.label(
                RichText::new(format!("{} missed, p99 {late_ms:.1} ms", t.missed)).monospace(),
            )
            .on_hover_text(format!(
                "{} ticks, late max {:.1} ms, watchdog trips {}; a tick is missed when it \
                 starts 20 ms or more late. Thread priority: {}",
                t.ticks,
                t.max_late_us as f64 * 1e-3,
                t.watchdog_trips,
                if v.control_priority.is_empty() {
                    "-"
                } else {
                    v.control_priority.as_str()
                }
            ));
            ui.end_row();
            dot_label(ui, level(h.power_w, |x| x > 250.0, |_| false), "Power");
            ui.label(
                RichText::new(format!(
                    "{}  {}",
                    opt(h.power_w, 1, "W"),
                    h.power_pct.map_or(String::new(), |p| format!("({p:.0} %)"))
                ))
                .monospace(),
            );
            ui.end_row();
        });
}

pub(crate) fn link_panel(app: &StationApp, ui: &mut Ui) {
    let v = app.shown().0;
    let l = &v.link;
    ui.horizontal(|ui| {
        group_title(ui, "LINK");
        dot_label(
            ui,
            theme::quality(l.quality),
            RichText::new(&l.health).strong(),
        );
    });
    egui::Grid::new("link")
        .num_columns(2)
        .spacing(vec2(10.0, 2.0))
        .show(ui, |ui| {
            ui.label("Round trip");
            ui.label(
                RichText::new(format!(
                    "{} (p99 {})",
                    opt(l.rtt_p50_ms, 1, "ms"),
                    opt(l.rtt_p99_ms, 1, "ms")
                ))
                .monospace(),
            );
            ui.end_row();
            ui.label("Exchange rate");
            ui.label(RichText::new(opt(l.exchange_hz, 1, "/s")).monospace());
            ui.end_row();
            ui.label("Errors");
            ui.label(
                RichText::new(format!(
                    "{}  ({} total)",
                    opt(l.error_pct, 1, "%"),
                    l.errors
                ))
                .monospace(),
            );
            ui.end_row();
            ui.label("Last good frame");
            ui.label(RichText::new(opt(l.last_good_age_s, 2, "s ago")).monospace());
            ui.end_row();
            crate::video::link_rows(app, ui);
            if let Some(p) = &l.port {
                ui.label("Port");
                ui.label(RichText::new(&p.path).monospace());
                ui.end_row();
                ui.label("");
                let color = if p.reconnecting {
                    theme::RED
                } else {
                    theme::DIM
                };
                ui.label(RichText::new(&p.state).monospace().color(color));
                ui.end_row();
            }
        });
}

pub(crate) fn link_pill(ui: &mut Ui, v: &StationView) {
    let l = &v.link;
    let color = theme::quality(l.quality);
    ui.vertical(|ui| {
        ui.horizontal(|ui| {
            let (rect, _) = ui.allocate_exact_size(vec2(14.0, 14.0), egui::Sense::hover());
            ui.painter().circle_filled(rect.center(), 7.0, color);
            ui.label(
                RichText::new(format!("LINK {}", l.health.to_uppercase()))
                    .strong()
                    .color(color),
            );
        });
        // A vanished serial port: the pilot sees that it is being looked for.
        if let Some(p) = l.port.as_ref().filter(|p| p.reconnecting) {
            ui.label(RichText::new(&p.state).monospace().small().color(color));
            return;
        }
        ui.label(
            RichText::new(format!(
                "{} · {} · err {} · {}",
                l.rtt_p50_ms
                    .map_or("--- ms".into(), |x| format!("{x:.0} ms")),
                l.exchange_hz.map_or("--/s".into(), |x| format!("{x:.0}/s")),
                l.error_pct.map_or("--%".into(), |x| format!("{x:.1}%")),
                l.last_good_age_s
                    .map_or("age ---".into(), |x| format!("age {x:.2}s")),
            ))
            .monospace()
            .small(),
        );
    });
}

pub(crate) fn recording_control(app: &mut StationApp, ui: &mut Ui) {
    let r = app.live_view.recording.clone();
    let recording = r.path.is_some();
    let text = if recording { "STOP REC" } else { "REC" };
    let b = egui::Button::new(RichText::new(text).strong().color(Color32::WHITE))
        .fill(if recording {
            theme::RED
        } else {
            Color32::from_gray(60)
        })
        .min_size(vec2(96.0, 30.0));
    if ui.add_enabled(app.live.is_some(), b).clicked() {
        if recording {
            app.live_cmd(RuntimeCommand::StopRecording);
        } else {
            let path = app.backend.recording_path();
            app.live_cmd(RuntimeCommand::StartRecording(path));
        }
    }
    ui.vertical(|ui| {
        match &r.path {
            Some(p) => {
                let secs = r.elapsed_s as u64;
                ui.label(
                    RichText::new(format!("REC {:02}:{:02}", secs / 60, secs % 60))
                        .strong()
                        .color(theme::RED),
                );
                let name = p
                    .file_name()
                    .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
                ui.label(RichText::new(format!("{name} · {} msgs", r.messages)).small());
            }
            None => {
                ui.label(RichText::new("NOT RECORDING").strong().color(theme::AMBER));
                if r.finishing.is_empty()
                    && let Some(p) = &r.last_file
                {
                    let name = p
                        .file_name()
                        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
                    ui.label(
                        RichText::new(format!("saved: {name}"))
                            .small()
                            .color(theme::DIM),
                    );
                }
            }
        }
        // Stopped recordings still being written out (the station's finisher threads).
        for p in &r.finishing {
            let name = p
                .file_name()
                .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
            ui.label(
                RichText::new(format!("saving {name}…"))
                    .small()
                    .color(theme::AMBER),
            );
        }
        if let Some(e) = &r.error {
            ui.label(RichText::new(e).small().color(theme::AMBER));
        }
        if r.dropped > 0 {
            ui.label(
                RichText::new(format!("{} dropped", r.dropped))
                    .small()
                    .color(theme::AMBER),
            );
        }
    });
}

pub(crate) fn camera_panel(app: &mut StationApp, ui: &mut Ui) {
    let c = app.shown().0.camera;
    let replay = app.replay.is_some();
    group_title(ui, "LIGHTS & CAMERA");
    ui.add_enabled_ui(!replay, |ui| {
        let mut lights = c.lights_pct;
        if ui
            .add(
                egui::Slider::new(&mut lights, 0.0..=100.0)
                    .step_by(5.0)
                    .text("lights %"),
            )
            .changed()
        {
            app.live_cmd(RuntimeCommand::Camera(CameraCommand::Lights(lights)));
        }
        let mut tilt = c.tilt_deg;
        if ui
            .add(
                egui::Slider::new(&mut tilt, -90.0..=90.0)
                    .step_by(5.0)
                    .text("camera tilt °"),
            )
            .changed()
        {
            app.live_cmd(RuntimeCommand::Camera(CameraCommand::Tilt(tilt)));
        }
        let mut focus = c.focus_pct;
        if ui
            .add(
                egui::Slider::new(&mut focus, -100.0..=100.0)
                    .step_by(5.0)
                    .text("focus %"),
            )
            .changed()
        {
            app.live_cmd(RuntimeCommand::Camera(CameraCommand::Focus(focus)));
        }
    });
}

pub(crate) fn pad_text(p: &PadStatus) -> String {
    match p {
        PadStatus::Off => "gamepad: off".into(),
        PadStatus::Unavailable(e) => format!("gamepad unavailable: {e}"),
        PadStatus::NoPad => {
            "gamepad: none (keyboard W/S A/D R/F, hold Space to arm, Esc disarms)".into()
        }
        PadStatus::Connected(n) => format!("gamepad: {n}"),
        PadStatus::WaitingForCentre(n) => format!("gamepad {n}: centre the sticks"),
        PadStatus::Stale => "gamepad thread not responding: sticks centred".into(),
    }
}

pub(crate) fn sticks_panel(app: &mut StationApp, ui: &mut Ui) {
    let v = app.live_view.clone();
    ui.horizontal(|ui| {
        group_title(ui, "STICKS");
        ui.label(
            RichText::new(format!("input: {}", v.pilot.input))
                .small()
                .color(theme::DIM),
        );
    });
    let p = &v.pilot;
    stick_bar(ui, "surge", p.raw.surge, p.shaped.surge);
    stick_bar(ui, "yaw", p.raw.yaw, p.shaped.yaw);
    stick_bar(ui, "vertical", p.raw.vertical, p.shaped.vertical);
    ui.label(
        RichText::new("Deadband, expo, scale and the button map: Gamepad tab.")
            .small()
            .color(theme::DIM),
    );
}

#[cfg(test)]
mod tests {
    use egui_kittest::kittest::Queryable;
    use rov_station::runtime::{LinkView, PortView, Quality};

    use super::*;

    /// The top bar's link pill while a vanished serial port is being looked for: the
    /// re-connection state replaces the link statistics.
    #[test]
    fn link_pill_shows_the_reconnection() {
        let view = StationView {
            link: LinkView {
                health: "lost".into(),
                quality: Quality::Red,
                port: Some(PortView {
                    path: "/dev/ttyUSB0".into(),
                    by_id: None,
                    state: "reconnecting (attempt 3, next in 1.0 s)".into(),
                    reconnecting: true,
                    attempt: 3,
                    next_attempt_in_s: Some(1.0),
                    lost_for_s: Some(0.8),
                    reason: Some("port gone (hang-up): Broken pipe".into()),
                    losses: 1,
                }),
                ..LinkView::default()
            },
            ..StationView::default()
        };
        let mut harness = egui_kittest::Harness::builder()
            .with_size(vec2(300.0, 60.0))
            .build_ui(|ui| link_pill(ui, &view));
        harness.run();
        // Found by its text (panics if absent).
        let _ = harness.get_by_label("reconnecting (attempt 3, next in 1.0 s)");
        harness.snapshot("link_reconnecting");
    }
}
