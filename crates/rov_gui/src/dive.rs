//! The dive log panel (Fly tab: dive timer, deepest point, markers and notes by hotkey)
//! and the Pre-dive tab (the checklist, with the thruster test behind a confirmation).
//! The timer, the checklist and the test run in the runtime; these panels show them and
//! send commands.

use egui::{RichText, Ui, vec2};
use rov_station::runtime::dive::{ItemStatus, TEST_ON_S, TEST_PCT, THRUSTERS};
use rov_station::runtime::{ChecklistCommand, RuntimeCommand};

use crate::app::StationApp;
use crate::instruments::{dot_label, group_title};
use crate::theme;

/// Markers and notes listed in the dive panel (the newest).
const LOG_ROWS: usize = 3;

fn mmss(s: f64) -> String {
    let t = s.max(0.0) as u64;
    format!("{:02}:{:02}", t / 60, t % 60)
}

/// The dive log in the Fly tab's side panel.
pub(crate) fn dive_panel(app: &mut StationApp, ui: &mut Ui) {
    let d = app.shown().0.dive;
    let replay = app.replay.is_some();
    ui.horizontal(|ui| {
        group_title(ui, "DIVE");
        let (text, color) = if d.diving {
            (
                format!("{}  deepest {:.1} m", mmss(d.dive_s), d.max_depth_m),
                theme::VALUE,
            )
        } else if d.dives > 0 {
            (
                format!("last {}  deepest {:.1} m", mmss(d.dive_s), d.max_depth_m),
                theme::DIM,
            )
        } else {
            ("at the surface".to_string(), theme::DIM)
        };
        ui.label(RichText::new(text).monospace().color(color));
    });
    ui.add_enabled_ui(!replay && app.live.is_some(), |ui| {
        ui.horizontal(|ui| {
            if ui
                .button(format!("Marker (M) #{}", d.markers + 1))
                .on_hover_text("a numbered marker with depth and heading, in the recording")
                .clicked()
            {
                app.live_cmd(RuntimeCommand::Marker);
            }
            let l = ui.label("Note (N)");
            let r = ui.add(
                egui::TextEdit::singleline(&mut app.note_text)
                    .id(egui::Id::unique("dive_note"))
                    .hint_text("type, Enter")
                    .desired_width(130.0),
            );
            let r = r.labelled_by(l.id);
            if app.focus_note {
                r.request_focus();
                app.focus_note = false;
            }
            if r.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter)) {
                let text = app.note_text.trim().to_string();
                if !text.is_empty() {
                    app.live_cmd(RuntimeCommand::Note(text));
                    app.note_text.clear();
                }
            }
        });
    });
    // The last markers and notes, in a block of fixed height (the panels under it do
    // not move when one is added).
    let lines = crate::pilot_keys::log_lines(app).to_vec();
    let row_h = ui.text_style_height(&egui::TextStyle::Monospace) + ui.spacing().item_spacing.y;
    let block_h = LOG_ROWS as f32 * row_h;
    let w = ui.available_width();
    ui.allocate_ui(vec2(w, block_h), |ui| {
        ui.set_min_height(block_h);
        ui.set_max_height(block_h);
        if lines.is_empty() {
            ui.label(
                RichText::new("no markers or notes yet (M, N)")
                    .small()
                    .color(theme::DIM),
            );
        }
        let skip = lines.len().saturating_sub(LOG_ROWS);
        for l in lines.iter().skip(skip) {
            ui.add(egui::Label::new(RichText::new(l).small().monospace()).truncate())
                .on_hover_text(l);
        }
    });
}

fn status(s: ItemStatus) -> (egui::Color32, &'static str) {
    match s {
        ItemStatus::Pending => (theme::DIM, "to do"),
        ItemStatus::Running => (theme::AMBER, "running"),
        ItemStatus::Pass => (theme::GREEN, "pass"),
        ItemStatus::Fail => (theme::RED, "FAIL"),
    }
}

/// The Pre-dive tab.
pub(crate) fn predive_tab(app: &mut StationApp, ui: &mut Ui) {
    let v = app.live_view.clone();
    let c = &v.checklist;
    let armed = v.snapshot.armed;
    ui.heading("Pre-dive checklist");
    ui.label(
        RichText::new(
            "Leak and recording are checked by the station; the compass, the thruster test and \
             the depth zero need you. The result is recorded in the session.",
        )
        .color(theme::DIM),
    );
    ui.separator();
    egui::Grid::new("checklist")
        .num_columns(3)
        .spacing(vec2(14.0, 10.0))
        .show(ui, |ui| {
            for (item, iv) in rov_station::runtime::dive::Item::ALL.iter().zip(&c.items) {
                let (color, text) = status(iv.status);
                dot_label(ui, color, RichText::new(item.name()).strong());
                ui.label(RichText::new(text).strong().color(color));
                ui.vertical(|ui| {
                    // One line always (blank until there is a result, truncated with
                    // the whole text on hover), so a result never moves the buttons
                    // under it (issue 25 item 2).
                    let detail = if iv.detail.is_empty() {
                        " "
                    } else {
                        &iv.detail
                    };
                    ui.add(egui::Label::new(RichText::new(detail).small()).truncate())
                        .on_hover_text(detail);
                    match item {
                        rov_station::runtime::dive::Item::Compass => {
                            // 000–359, never 360 (issue 25 item 11).
                            let h = v.snapshot.heading_deg.map_or_else(
                                || "---".into(),
                                |h| format!("{}°", rov_types::angle::compass_text(h)),
                            );
                            ui.horizontal(|ui| {
                                ui.label(format!(
                                    "Point the vehicle at a known bearing; the compass reads {h}."
                                ));
                                if ui.button("Heading is right").clicked() {
                                    app.live_cmd(RuntimeCommand::Checklist(
                                        ChecklistCommand::CompassOk,
                                    ));
                                }
                                if ui.button("Heading is wrong").clicked() {
                                    app.live_cmd(RuntimeCommand::Checklist(
                                        ChecklistCommand::CompassBad,
                                    ));
                                }
                            });
                        }
                        rov_station::runtime::dive::Item::DepthZero => {
                            ui.horizontal(|ui| {
                                ui.label(format!(
                                    "With the vehicle at the surface (depth reads {}).",
                                    crate::settings::depth_text(
                                        v.snapshot.depth_m,
                                        app.station.depth_unit,
                                        2
                                    )
                                ));
                                if ui.button("Zero depth here").clicked() {
                                    app.live_cmd(RuntimeCommand::Checklist(
                                        ChecklistCommand::ZeroDepth,
                                    ));
                                }
                            });
                        }
                        rov_station::runtime::dive::Item::Thrusters => {
                            thruster_controls(app, ui, &v, armed);
                        }
                        _ => {}
                    }
                });
                ui.end_row();
            }
        });
    ui.separator();
    ui.horizontal(|ui| {
        ui.label(
            RichText::new(format!("{}/5 passed", c.passed()))
                .strong()
                .size(17.0),
        );
        if ui.button("Record the result in the session").clicked() {
            app.live_cmd(RuntimeCommand::Checklist(ChecklistCommand::Record));
        }
        if c.recorded {
            ui.label(RichText::new("recorded").color(theme::GREEN));
        }
    });
}

fn thruster_controls(
    app: &mut StationApp,
    ui: &mut Ui,
    v: &rov_station::runtime::StationView,
    armed: bool,
) {
    let c = &v.checklist;
    if let Some(running) = c.test_running {
        let which = running
            .and_then(|i| THRUSTERS.get(i))
            .copied()
            .unwrap_or("pause");
        ui.horizontal(|ui| {
            ui.label(RichText::new(format!("running: {which}")).color(theme::AMBER));
            if ui.button("STOP test").clicked() {
                app.live_cmd(RuntimeCommand::Checklist(
                    ChecklistCommand::AbortThrusterTest,
                ));
            }
        });
    } else if app.confirm_thruster_test {
        ui.horizontal(|ui| {
            ui.label(
                RichText::new(format!(
                    "Each thruster runs {TEST_ON_S:.0} s at {TEST_PCT:.0} %: keep hands and tether clear."
                ))
                .color(theme::AMBER),
            );
            if ui.button("Start the test").clicked() {
                app.confirm_thruster_test = false;
                app.live_cmd(RuntimeCommand::Checklist(ChecklistCommand::StartThrusterTest));
            }
            if ui.button("Cancel").clicked() {
                app.confirm_thruster_test = false;
            }
        });
    } else {
        ui.horizontal(|ui| {
            if ui
                .add_enabled(armed, egui::Button::new("Run thruster test"))
                .clicked()
            {
                app.confirm_thruster_test = true;
            }
            if !armed {
                ui.label(RichText::new("arm first").small().color(theme::DIM));
            }
        });
    }
    // The columns are 12 V rail currents (amps), before and while each thruster runs;
    // the pass rule is the station's (`ThrusterResult::drew_current`).
    egui::Grid::new("thruster_results")
        .num_columns(5)
        .show(ui, |ui| {
            for h in [
                "thruster",
                "thrust",
                "12 V current before",
                "12 V current running",
                "result",
            ] {
                ui.label(RichText::new(h).small().color(theme::DIM));
            }
            ui.end_row();
            let a = |x: Option<f64>| x.map_or_else(|| "---".into(), |v| format!("{v:.2} A"));
            for (n, r) in THRUSTERS.iter().zip(&c.thrusters) {
                ui.label(*n);
                ui.label(format!("{:+.0} %", r.commanded_pct));
                ui.label(a(r.idle_a));
                ui.label(a(r.peak_a));
                let (text, color) = match (r.idle_a, r.peak_a) {
                    (Some(_), Some(_)) if r.drew_current() => ("pass", theme::GREEN),
                    (Some(_), Some(_)) => ("FAIL", theme::RED),
                    _ => ("---", theme::DIM),
                };
                ui.label(RichText::new(text).strong().color(color));
                ui.end_row();
            }
        });
    ui.label(
        RichText::new("pass: the 12 V current rises by at least 0.1 A while the thruster runs")
            .small()
            .color(theme::DIM),
    );
}
