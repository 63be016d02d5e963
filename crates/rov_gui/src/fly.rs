//! The Fly tab: the instruments in the middle, the autopilot, health, link, camera and
//! stick panels on the right.

use egui::{Ui, vec2};
use rov_control::ModeCommand;
use rov_station::StationCommand;
use rov_station::runtime::RuntimeCommand;

use crate::app::StationApp;
use crate::instruments::{self, DepthTape, HeadingTape, TapeAction};

/// Width of the control column.
pub const SIDE_WIDTH: f32 = 340.0;

pub(crate) fn fly(app: &mut StationApp, ui: &mut Ui) {
    egui::Panel::right("fly_side")
        .exact_size(SIDE_WIDTH)
        .resizable(false)
        .show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| {
                crate::panels::autopilot_panel(app, ui);
                ui.separator();
                crate::panels::health_panel(app, ui);
                ui.separator();
                crate::panels::link_panel(app, ui);
                ui.separator();
                crate::panels::camera_panel(app, ui);
                ui.separator();
                crate::panels::sticks_panel(app, ui);
            });
        });
    egui::CentralPanel::default().show(ui, |ui| instruments_area(app, ui));
}

fn instruments_area(app: &mut StationApp, ui: &mut Ui) {
    let v = app.shown().0.clone();
    let avail = ui.available_size();
    let replay = app.replay.is_some();
    ui.horizontal_top(|ui| {
        // Depth tape with the vertical thrust bar.
        let tape = DepthTape {
            depth_m: v.snapshot.depth_m,
            setpoint_m: v.depth.setpoint,
            vertical_pct: v.snapshot.thrust.vertical_pct,
            overridden: v.depth.overridden,
            half_range_m: 5.0,
        };
        match tape.show(ui, vec2(140.0, avail.y - 8.0), app.depth_drag) {
            Some(TapeAction::Dragging(d)) if !replay => app.depth_drag = Some(d),
            Some(TapeAction::Set(d)) if !replay => {
                app.depth_drag = None;
                app.live_cmd(RuntimeCommand::Station(StationCommand::Mode(
                    ModeCommand::SetDepth { depth_m: d },
                )));
            }
            _ => {}
        }
        ui.vertical(|ui| {
            let w = ui.available_width();
            let ht = HeadingTape {
                heading_deg: v.snapshot.heading_deg,
                setpoint_deg: v.heading.setpoint,
                overridden: v.heading.overridden,
                turns: v.turns,
            };
            match ht.show(ui, vec2(w, 66.0), app.heading_drag) {
                Some(TapeAction::Dragging(d)) if !replay => app.heading_drag = Some(d),
                Some(TapeAction::Set(d)) if !replay => {
                    app.heading_drag = None;
                    app.live_cmd(RuntimeCommand::Station(StationCommand::Mode(
                        ModeCommand::SetHeading { heading_deg: d },
                    )));
                }
                _ => {}
            }
            let rest_h = ui.available_height() - 8.0;
            ui.horizontal_top(|ui| {
                let side = (w - 190.0).min(rest_h).max(120.0);
                instruments::horizon(ui, side, v.snapshot.pitch_deg, v.snapshot.roll_deg);
                ui.vertical(|ui| {
                    instruments::pitch_glyph(ui, vec2(180.0, 120.0), v.snapshot.pitch_deg);
                    let th = v.snapshot.thrust;
                    let h = (side - 126.0).max(120.0);
                    instruments::thruster_bars(
                        ui,
                        vec2(180.0, h),
                        th.port_pct,
                        th.starboard_pct,
                        th.vertical_pct,
                    );
                });
            });
        });
    });
}
