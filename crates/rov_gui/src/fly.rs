//! The Fly tab: the main view in the middle, the autopilot, health, link, camera and
//! stick panels on the right (scrolling when the window is short).
//!
//! The central area is one replaceable *main view*: by default the instrument layout
//! (depth tape, heading tape, horizon, pitch glyph, thrust bars). A [`MainView`] (the
//! camera picture, issue 12) can take the area instead; the instruments are then drawn
//! as a HUD over it with translucent backgrounds ([`instruments::set_overlay`]), and
//! the V key switches back to the instrument-only layout.

use egui::{Rect, Ui, UiBuilder, pos2, vec2};
use rov_control::ModeCommand;
use rov_station::StationCommand;
use rov_station::runtime::{RuntimeCommand, StationView};

use crate::app::StationApp;
use crate::instruments::{self, DepthTape, HeadingTape, TapeAction};

/// Width of the control column (between these, a share of the window).
pub const SIDE_WIDTH_MIN: f32 = 300.0;
/// Widest control column.
pub const SIDE_WIDTH_MAX: f32 = 380.0;

/// What fills the Fly tab's central area instead of the instrument layout (the camera
/// picture): painted first, with the instruments drawn over it.
pub trait MainView {
    /// Paints the view into `rect` for the station state `view`.
    fn paint(&mut self, ui: &mut Ui, rect: Rect, view: &StationView);
    /// A short name for the help and the layout toggle ("camera").
    fn name(&self) -> &str;
}

pub(crate) fn fly(app: &mut StationApp, ui: &mut Ui) {
    let side = (ui.available_width() * 0.3).clamp(SIDE_WIDTH_MIN, SIDE_WIDTH_MAX);
    egui::Panel::right("fly_side")
        .exact_size(side)
        .resizable(false)
        .show(ui, |ui| {
            crate::layout::scroll(app, ui, "fly_side_scroll", |app, ui| {
                crate::panels::autopilot_panel(app, ui);
                ui.separator();
                crate::dive::dive_panel(app, ui);
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
    egui::CentralPanel::default().show(ui, |ui| main_area(app, ui));
}

/// The central area: the main view with the HUD over it, or the instrument layout.
fn main_area(app: &mut StationApp, ui: &mut Ui) {
    let rect = ui.available_rect_before_wrap();
    app.layout.main_rect = Some(rect);
    let v = app.shown().0.clone();
    let video = crate::video::shown_video(app);
    let picture = !app.instruments_only && (app.main_view.is_some() || video.is_some());
    if let (true, Some(mv)) = (picture, app.main_view.as_mut()) {
        mv.paint(ui, rect, &v);
        instruments::set_overlay(ui, true);
        hud_overlay(app, ui, rect, &v);
        instruments::set_overlay(ui, false);
    } else if let (true, Some(video)) = (picture, video) {
        // The camera: the picture, the HUD over it, the status strip on backplates.
        let status = video.status();
        app.video_pane.paint(ui, rect, &video, &status);
        instruments::set_overlay(ui, true);
        hud_overlay(app, ui, rect, &v);
        instruments::set_overlay(ui, false);
        let latency = app.video_pane.latency_ms();
        crate::video::status_strip(ui, rect, &v, &status, latency);
    } else {
        instrument_layout(app, ui, &v);
    }
}

fn depth_tape(app: &mut StationApp, ui: &mut Ui, v: &StationView, size: egui::Vec2) {
    let replay = app.replay.is_some();
    let tape = DepthTape {
        depth_m: v.snapshot.depth_m,
        setpoint_m: v.depth.setpoint,
        vertical_pct: v.snapshot.thrust.vertical_pct,
        overridden: v.depth.overridden,
        half_range_m: 5.0,
        heave_mps: v.heave_mps,
        stale: v.stale.depth,
        feet: app.station.depth_unit == rov_station::runtime::settings::DepthUnit::Feet,
    };
    match tape.show(ui, size, app.depth_drag) {
        Some(TapeAction::Dragging(d)) if !replay => app.depth_drag = Some(d),
        Some(TapeAction::Set(d)) if !replay => {
            app.depth_drag = None;
            app.live_cmd(RuntimeCommand::Station(StationCommand::Mode(
                ModeCommand::SetDepth { depth_m: d },
            )));
        }
        _ => {}
    }
}

fn heading_tape(app: &mut StationApp, ui: &mut Ui, v: &StationView, size: egui::Vec2) {
    let replay = app.replay.is_some();
    let ht = HeadingTape {
        heading_deg: v.snapshot.heading_deg,
        setpoint_deg: v.heading.setpoint,
        overridden: v.heading.overridden,
        turns: v.turns,
        stale: v.stale.heading,
    };
    match ht.show(ui, size, app.heading_drag) {
        Some(TapeAction::Dragging(d)) if !replay => app.heading_drag = Some(d),
        Some(TapeAction::Set(d)) if !replay => {
            app.heading_drag = None;
            app.live_cmd(RuntimeCommand::Station(StationCommand::Mode(
                ModeCommand::SetHeading { heading_deg: d },
            )));
        }
        _ => {}
    }
}

/// Width of the pitch-glyph and thrust column.
const COLUMN_W: f32 = 180.0;

/// The instrument-only layout: depth tape left, heading tape on top, horizon filling the
/// rest, pitch glyph and thrust bars in a column on the right. Every size follows the
/// area, so nothing is clipped at 1024×600 and no band stays empty at 1920×1080.
fn instrument_layout(app: &mut StationApp, ui: &mut Ui, v: &StationView) {
    let avail = ui.available_size();
    let tape_w = (avail.x * 0.16).clamp(130.0, 170.0);
    ui.horizontal_top(|ui| {
        depth_tape(app, ui, v, vec2(tape_w, avail.y - 4.0));
        ui.vertical(|ui| {
            let w = ui.available_width();
            heading_tape(app, ui, v, vec2(w, 66.0));
            let rest_h = (ui.available_height() - 4.0).max(160.0);
            ui.horizontal_top(|ui| {
                let col = COLUMN_W.min(w * 0.3);
                let hz_w = (w - col - ui.spacing().item_spacing.x).max(160.0);
                instruments::horizon(
                    ui,
                    vec2(hz_w, rest_h),
                    v.snapshot.pitch_deg,
                    v.snapshot.roll_deg,
                    v.stale.attitude,
                );
                ui.vertical(|ui| {
                    let glyph_h = (rest_h * 0.3).clamp(90.0, 140.0);
                    instruments::pitch_glyph(
                        ui,
                        vec2(col, glyph_h),
                        v.snapshot.pitch_deg,
                        v.stale.attitude,
                    );
                    let th = v.snapshot.thrust;
                    let h = (rest_h - glyph_h - ui.spacing().item_spacing.y).max(100.0);
                    instruments::thruster_bars(
                        ui,
                        vec2(col, h),
                        th.port_pct,
                        th.starboard_pct,
                        th.vertical_pct,
                    );
                });
            });
        });
    });
}

/// The instruments over a picture: heading tape along the top, depth tape on the left,
/// the horizon line across the middle, thrust bars bottom right.
fn hud_overlay(app: &mut StationApp, ui: &mut Ui, rect: Rect, v: &StationView) {
    let m = 6.0;
    let tape_w = 130.0;
    let top = Rect::from_min_size(
        rect.min + vec2(tape_w + 2.0 * m, m),
        vec2((rect.width() - tape_w - 3.0 * m).max(100.0), 60.0),
    );
    let left = Rect::from_min_size(
        rect.min + vec2(m, m),
        vec2(tape_w, (rect.height() - 2.0 * m).max(100.0)),
    );
    // The bottom 30 px stay free for the status strip (REC, link, video, alarms): the
    // thrust box sits above it so no chip covers the thrust values.
    let bars = Rect::from_min_max(
        pos2(rect.max.x - 150.0 - m, rect.max.y - 200.0 - m),
        rect.max - vec2(m, m + 30.0),
    );
    if app.hud_hidden {
        return;
    }
    // The bottom 30 px stay free for the status strip (REC, link, video, alarms).
    let mid = Rect::from_min_max(
        pos2(left.max.x + m, top.max.y + m),
        pos2(bars.min.x - m, rect.max.y - m - 30.0),
    );
    ui.scope_builder(UiBuilder::new().max_rect(top), |ui| {
        heading_tape(app, ui, v, top.size());
    });
    ui.scope_builder(UiBuilder::new().max_rect(left), |ui| {
        depth_tape(app, ui, v, left.size());
    });
    ui.scope_builder(UiBuilder::new().max_rect(mid), |ui| {
        instruments::horizon(
            ui,
            mid.size(),
            v.snapshot.pitch_deg,
            v.snapshot.roll_deg,
            v.stale.attitude,
        );
    });
    ui.scope_builder(UiBuilder::new().max_rect(bars), |ui| {
        let th = v.snapshot.thrust;
        instruments::thruster_bars(
            ui,
            bars.size(),
            th.port_pct,
            th.starboard_pct,
            th.vertical_pct,
        );
    });
}
