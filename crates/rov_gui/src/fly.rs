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
                // Lights and tilt right under the autopilot: both in view at 1280×800
                // without scrolling (issue 25 item 15).
                crate::panels::autopilot_panel(app, ui);
                ui.separator();
                crate::panels::camera_panel(app, ui);
                ui.separator();
                crate::dive::dive_panel(app, ui);
                ui.separator();
                crate::panels::health_panel(app, ui);
                ui.separator();
                crate::panels::link_panel(app, ui);
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

/// Where the HUD's parts go over a picture in `rect` (issue 25 items 1, 4, 15): none of
/// them overlaps another at the window sizes the station supports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HudLayout {
    /// The heading tape, along the top right of the depth tape.
    pub top: Rect,
    /// The depth tape, down the left edge.
    pub left: Rect,
    /// The horizon and ladder, in the middle.
    pub mid: Rect,
    /// The thrust box, bottom right above the status strip.
    pub bars: Rect,
    /// The camera-tilt indicator, right edge between the heading tape and thrust box.
    pub tilt: Rect,
    /// The status strip's chips (REC, link, video, alarms) along the bottom, right of
    /// the depth tape.
    pub status: Rect,
}

/// Height of the HUD's status strip, points.
pub const HUD_STATUS_H: f32 = 30.0;

/// The HUD's layout over a picture filling `rect`.
#[must_use]
pub fn hud_layout(rect: Rect) -> HudLayout {
    let m = 6.0;
    let tape_w = 130.0;
    let tilt_w = 56.0;
    let top = Rect::from_min_size(
        rect.min + vec2(tape_w + 2.0 * m, m),
        vec2((rect.width() - tape_w - 3.0 * m).max(100.0), 60.0),
    );
    let left = Rect::from_min_size(
        rect.min + vec2(m, m),
        vec2(tape_w, (rect.height() - 2.0 * m).max(100.0)),
    );
    // The chips start right of the depth tape.
    let status = Rect::from_min_max(
        pos2(left.max.x + 2.0 * m, rect.max.y - HUD_STATUS_H),
        rect.max,
    );
    // The thrust box sits above the status strip so no chip covers the thrust values.
    let bars = Rect::from_min_max(
        pos2(
            rect.max.x - 150.0 - m,
            (status.min.y - m - 200.0).max(top.max.y + 120.0),
        ),
        pos2(rect.max.x - m, status.min.y - m),
    );
    let tilt = Rect::from_min_max(
        pos2(rect.max.x - tilt_w - m, top.max.y + m),
        pos2(rect.max.x - m, bars.min.y - m),
    );
    let mid = Rect::from_min_max(
        pos2(left.max.x + m, top.max.y + m),
        pos2(tilt.min.x.min(bars.min.x) - m, status.min.y - m),
    );
    HudLayout {
        top,
        left,
        mid,
        bars,
        tilt,
        status,
    }
}

/// The instruments over a picture: heading tape along the top, depth tape on the left,
/// the horizon line across the middle, thrust bars bottom right.
fn hud_overlay(app: &mut StationApp, ui: &mut Ui, rect: Rect, v: &StationView) {
    if app.hud_hidden {
        return;
    }
    let HudLayout {
        top,
        left,
        mid,
        bars,
        tilt,
        ..
    } = hud_layout(rect);
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
    tilt_indicator(ui, tilt, v.camera.tilt_deg);
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

/// Camera tilt range drawn by [`tilt_indicator`], degrees either side of level.
const TILT_RANGE_DEG: f64 = 90.0;

/// The camera tilt over the picture: a thin vertical scale (up is the camera looking
/// up), a marker at the tilt and its value in degrees; no backplate, a dark outline
/// keeps it legible over a bright seabed.
fn tilt_indicator(ui: &Ui, rect: Rect, tilt_deg: f64) {
    use egui::{Align2, FontId, Stroke};
    let p = ui.painter_at(rect);
    let x = rect.max.x - 8.0;
    let (y0, y1) = (rect.min.y + 22.0, rect.max.y - 4.0);
    if y1 <= y0 {
        return;
    }
    let y_of = |deg: f64| {
        let f = ((TILT_RANGE_DEG - deg.clamp(-TILT_RANGE_DEG, TILT_RANGE_DEG))
            / (2.0 * TILT_RANGE_DEG)) as f32;
        y0 + f * (y1 - y0)
    };
    let shadow = Stroke::new(3.0, egui::Color32::from_black_alpha(140));
    let line = Stroke::new(1.0, crate::theme::SCALE);
    for s in [shadow, line] {
        p.line_segment([pos2(x, y0), pos2(x, y1)], s);
        for deg in [-90.0, -45.0, 0.0, 45.0, 90.0] {
            let len = if deg == 0.0 { 10.0 } else { 6.0 };
            let y = y_of(deg);
            p.line_segment([pos2(x - len, y), pos2(x, y)], s);
        }
    }
    let y = y_of(tilt_deg);
    let tri = vec![
        pos2(x - 2.0, y),
        pos2(x - 12.0, y - 5.0),
        pos2(x - 12.0, y + 5.0),
    ];
    p.add(egui::Shape::convex_polygon(
        tri,
        crate::theme::THRUST,
        Stroke::new(1.0, egui::Color32::BLACK),
    ));
    let text = format!("TILT {tilt_deg:+.0}°");
    let font = FontId::monospace(12.0);
    let at = pos2(rect.max.x, rect.min.y + 2.0);
    // The value is wider than the scale's strip ("TILT -20°"): drawn over the HUD, not
    // clipped to the strip (clipped, its first letter was cut off).
    let p = ui.painter();
    p.text(
        at + vec2(1.0, 1.0),
        Align2::RIGHT_TOP,
        &text,
        font.clone(),
        egui::Color32::BLACK,
    );
    p.text(at, Align2::RIGHT_TOP, text, font, crate::theme::THRUST);
}
