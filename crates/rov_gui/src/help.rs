//! F1 or ?: every key and gamepad binding in one window (the gamepad part is the map in
//! force, so it follows the pilot's settings).

use egui::{RichText, vec2};
use rov_station::runtime::pad::{PadButton, PadMap};

use crate::app::StationApp;
use crate::theme;

/// The keyboard bindings: (keys, what).
pub const KEYS: [(&str, &str); 17] = [
    ("Space (hold 1 s)", "arm"),
    ("Esc", "disarm"),
    ("W / S", "forward / astern"),
    ("A / D", "turn left / right"),
    ("R / F", "rise / dive"),
    ("1 2 3 4", "thrust gain 25 / 50 / 75 / 100 %"),
    ("H", "depth hold on/off"),
    ("J", "heading hold on/off"),
    ("M", "dive-log marker"),
    ("N", "type a dive-log note (Enter records it)"),
    ("V", "camera view / instruments only"),
    ("O", "camera: hide / show the HUD"),
    (", / .", "replay: one control tick back / forward"),
    ("drag a tape", "set the depth or heading setpoint"),
    ("F1 or ?", "this window"),
    ("Enter", "in a setpoint field: go there"),
    (
        "Tab",
        "move between fields (every page works from the keyboard)",
    ),
];

/// The help window's width where the screen allows it: both columns side by side.
const HELP_W: f32 = 960.0;

pub(crate) fn help_window(app: &mut StationApp, ctx: &egui::Context) {
    if !app.help_open {
        return;
    }
    let map = app.live_view.pilot.pad_map.clone();
    let mut open = true;
    // Never taller or wider than the window (it was clipped at the bottom at 1024×600,
    // issue 25 item 4): the contents scroll instead.
    let screen = ctx.content_rect();
    egui::Window::new("Keys and buttons")
        .open(&mut open)
        .collapsible(false)
        .anchor(egui::Align2::CENTER_CENTER, vec2(0.0, 0.0))
        .default_size(vec2(HELP_W.min(screen.width() - 40.0), 460.0))
        .max_width((screen.width() - 40.0).max(200.0))
        .max_height((screen.height() - 80.0).max(200.0))
        .show(ctx, |ui| {
            egui::ScrollArea::both().show(ui, |ui| {
                // Two columns, each as wide as its own text, side by side: halves of the
                // window let the keyboard's long lines run into the gamepad column at
                // 1024×600 (issue 25 item 4); a window too narrow for both scrolls.
                ui.horizontal_top(|ui| {
                    ui.vertical(keyboard_column);
                    ui.add_space(8.0);
                    ui.separator();
                    ui.vertical(|ui| gamepad_column(ui, &map));
                });
            });
        });
    if !open {
        app.help_open = false;
    }
}

fn keyboard_column(ui: &mut egui::Ui) {
    ui.label(RichText::new("Keyboard").strong().color(theme::SCALE));
    egui::Grid::new("help_keys").striped(true).show(ui, |ui| {
        for &(k, what) in KEYS.iter().chain(&crate::pilot_keys::KEYS) {
            ui.label(RichText::new(k).monospace());
            ui.label(what);
            ui.end_row();
        }
    });
}

fn gamepad_column(ui: &mut egui::Ui, map: &PadMap) {
    ui.label(RichText::new("Gamepad").strong().color(theme::SCALE));
    ui.label(format!(
        "surge: {}   yaw: {}   vertical: {} (up rises)",
        map.surge.key(),
        map.yaw.key(),
        map.vertical.key()
    ));
    let shift = map.shift.map_or("none", PadButton::key);
    egui::Grid::new("help_pad").striped(true).show(ui, |ui| {
        ui.label(RichText::new("button").small().color(theme::DIM));
        ui.label(RichText::new("press").small().color(theme::DIM));
        ui.label(
            RichText::new(format!("with {shift} held"))
                .small()
                .color(theme::DIM),
        );
        ui.end_row();
        for b in PadButton::ALL {
            let n = map.action(b, false);
            let s = map.action(b, true);
            if n.is_none() && s.is_none() {
                continue;
            }
            ui.label(RichText::new(b.key()).monospace());
            ui.label(n.map_or("", |a| a.text()));
            ui.label(s.map_or("", |a| a.text()));
            ui.end_row();
        }
    });
}
