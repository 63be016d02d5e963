//! The Gamepad tab: the pad (or the keyboard) as the runtime sees it, raw and shaped;
//! per-axis assignment, deadband, expo, invert and scale; the button map with its shift
//! layer; Apply (to the running station) and Save (to `[gamepad]` of the station
//! configuration). Locked while armed.

use egui::{RichText, Ui, vec2};
use rov_station::runtime::pad::{Action, PadAxis, PadButton};
use rov_station::runtime::{AxisShaping, RuntimeCommand};

use crate::app::StationApp;
use crate::instruments::stick_bar;
use crate::theme;

fn axis_combo(ui: &mut Ui, id: &str, label: &str, a: &mut PadAxis) {
    egui::ComboBox::new(id, label)
        .selected_text(a.key())
        .width(90.0)
        .show_ui(ui, |ui| {
            for x in PadAxis::ALL {
                ui.selectable_value(a, x, x.key());
            }
        });
}

fn action_combo(
    ui: &mut Ui,
    id: String,
    name: egui::Id,
    current: Option<Action>,
) -> Option<Option<Action>> {
    let mut sel = current;
    egui::ComboBox::new(id, "")
        .selected_text(sel.map_or("-", Action::key))
        .width(120.0)
        .show_ui(ui, |ui| {
            ui.selectable_value(&mut sel, None, "-");
            for a in Action::ALL {
                ui.selectable_value(&mut sel, Some(a), a.key());
            }
        })
        .response
        .labelled_by(name);
    (sel != current).then_some(sel)
}

fn set(list: &mut Vec<(PadButton, Action)>, b: PadButton, a: Option<Action>) {
    list.retain(|(x, _)| *x != b);
    if let Some(a) = a {
        list.push((b, a));
        list.sort_by_key(|(x, _)| *x);
    }
}

fn shaping_row(ui: &mut Ui, name: &str, s: &mut AxisShaping) {
    let l = ui.label(name);
    ui.add(
        egui::DragValue::new(&mut s.deadband)
            .range(0.0..=0.5)
            .speed(0.01)
            .prefix("deadband "),
    )
    .labelled_by(l.id);
    ui.add(
        egui::DragValue::new(&mut s.expo)
            .range(0.0..=1.0)
            .speed(0.01)
            .prefix("expo "),
    )
    .labelled_by(l.id);
    ui.add(
        egui::DragValue::new(&mut s.scale)
            .range(0.1..=1.0)
            .speed(0.01)
            .prefix("scale "),
    )
    .labelled_by(l.id);
    ui.checkbox(&mut s.invert, "invert");
    ui.end_row();
}

pub(crate) fn gamepad_tab(app: &mut StationApp, ui: &mut Ui) {
    let v = app.live_view.clone();
    let armed = v.snapshot.armed;
    crate::layout::scroll(app, ui, "gamepad_scroll", |app, ui| {
        ui.horizontal(|ui| {
            ui.heading("Gamepad");
            ui.label(RichText::new(crate::panels::pad_text(&v.pilot.pad)).color(theme::SCALE));
            ui.label(
                RichText::new(format!("input now: {}", v.pilot.input))
                    .small()
                    .color(theme::DIM),
            );
        });
        if armed {
            ui.label(
                RichText::new("Disarm to change the map (locked while armed).").color(theme::AMBER),
            );
        }
        ui.columns(2, |cols| {
            let [left, right] = cols else { return };
            left.label(RichText::new("Sticks: raw and shaped (pad or keyboard)").strong());
            let p = &v.pilot;
            stick_bar(left, "surge", p.raw.surge, p.shaped.surge);
            stick_bar(left, "yaw", p.raw.yaw, p.shaped.yaw);
            stick_bar(left, "vertical", p.raw.vertical, p.shaped.vertical);
            left.add_space(4.0);
            left.add_enabled_ui(!armed, |ui| {
                ui.horizontal(|ui| {
                    axis_combo(ui, "surge_axis", "surge", &mut app.pad_map.surge);
                    axis_combo(ui, "yaw_axis", "yaw", &mut app.pad_map.yaw);
                    axis_combo(ui, "vertical_axis", "vertical", &mut app.pad_map.vertical);
                });
                egui::Grid::new("pad_shaping")
                    .num_columns(5)
                    .show(ui, |ui| {
                        shaping_row(ui, "surge", &mut app.shaping.surge);
                        shaping_row(ui, "yaw", &mut app.shaping.yaw);
                        shaping_row(ui, "vertical", &mut app.shaping.vertical);
                    });
            });
            left.add_space(4.0);
            left.label(RichText::new("Raw pad").strong());
            let raw = v.pilot.pad_raw;
            left.label(
                RichText::new(
                    PadAxis::ALL
                        .iter()
                        .map(|a| format!("{} {:+.2}", a.key(), raw.axis(*a)))
                        .collect::<Vec<_>>()
                        .join("  "),
                )
                .monospace()
                .small(),
            );
            let held: Vec<&str> = PadButton::ALL
                .iter()
                .filter(|b| raw.held(**b))
                .map(|b| b.key())
                .collect();
            left.label(
                RichText::new(format!(
                    "held: {}{}",
                    if held.is_empty() {
                        "-".into()
                    } else {
                        held.join(", ")
                    },
                    if v.pilot.shift { "  (SHIFT)" } else { "" }
                ))
                .monospace()
                .small(),
            );
            left.add_space(6.0);
            left.label(RichText::new("Keyboard").strong());
            for (k, what) in crate::help::KEYS.iter().take(11) {
                left.label(RichText::new(format!("{k:<18} {what}")).monospace().small());
            }

            right.label(RichText::new("Buttons (press / with shift held)").strong());
            right.add_enabled_ui(!armed, |ui| {
                let mut shift = app.pad_map.shift;
                egui::ComboBox::new("shift_button", "shift button")
                    .selected_text(shift.map_or("none", PadButton::key))
                    .show_ui(ui, |ui| {
                        ui.selectable_value(&mut shift, None, "none");
                        for b in PadButton::ALL {
                            ui.selectable_value(&mut shift, Some(b), b.key());
                        }
                    });
                app.pad_map.shift = shift;
                egui::Grid::new("pad_buttons")
                    .num_columns(3)
                    .spacing(vec2(8.0, 2.0))
                    .show(ui, |ui| {
                        for b in PadButton::ALL {
                            if Some(b) == app.pad_map.shift {
                                continue;
                            }
                            let name = ui.label(RichText::new(b.key()).monospace()).id;
                            let n = app.pad_map.action(b, false);
                            if let Some(a) = action_combo(ui, format!("pad_{}", b.key()), name, n) {
                                set(&mut app.pad_map.buttons, b, a);
                            }
                            let s = app.pad_map.action(b, true);
                            if let Some(a) =
                                action_combo(ui, format!("pad_shift_{}", b.key()), name, s)
                            {
                                set(&mut app.pad_map.shifted, b, a);
                            }
                            ui.end_row();
                        }
                    });
            });
            right.horizontal(|ui| {
                if ui
                    .add_enabled(!armed, egui::Button::new("Apply map"))
                    .clicked()
                {
                    app.live_cmd(RuntimeCommand::PadMap(app.pad_map.clone()));
                    app.live_cmd(RuntimeCommand::Shaping(app.shaping));
                    app.message = Some("gamepad map applied".into());
                }
                let target = app.config_target();
                if ui
                    .add_enabled(
                        !armed,
                        egui::Button::new(format!("Save to {}", target.display())),
                    )
                    .clicked()
                {
                    app.live_cmd(RuntimeCommand::PadMap(app.pad_map.clone()));
                    app.live_cmd(RuntimeCommand::Shaping(app.shaping));
                    app.message = Some(
                        match rov_station::runtime::settings::save_gamepad(
                            &target,
                            &app.pad_map,
                            &app.shaping,
                        ) {
                            Ok(()) => format!("gamepad map saved to {}", target.display()),
                            Err(e) => format!("cannot save: {e}"),
                        },
                    );
                }
            });
        });
    });
}
