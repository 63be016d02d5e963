//! The HUD instruments, painted every frame from the latest view: depth tape, heading
//! tape, artificial horizon, side-view pitch glyph, thruster bars, and the hold-to-arm
//! button.
//!
//! Instruments return what the pilot did with them (a dragged setpoint); they never hold
//! timers: the arm button only reports "held" each frame and the runtime times the hold.

use egui::{
    Align2, Color32, FontId, Pos2, Rect, Sense, Shape, Stroke, StrokeKind, Ui, Vec2, pos2, vec2,
};

use rov_types::angle::compass_text;

use crate::theme;

/// Whether instruments are drawn as an overlay on a picture (translucent backgrounds);
/// set by the Fly tab's main view for the widgets it draws over the video.
pub fn set_overlay(ui: &Ui, on: bool) {
    ui.data_mut(|d| d.insert_temp(egui::Id::unique("hud_overlay"), on));
}

fn overlay(ui: &Ui) -> bool {
    ui.data(|d| d.get_temp::<bool>(egui::Id::unique("hud_overlay")))
        .unwrap_or(false)
}

fn frame(ui: &Ui, rect: Rect) {
    let p = ui.painter();
    let fill = if overlay(ui) {
        Color32::from_black_alpha(110)
    } else {
        theme::BG
    };
    p.rect_filled(rect, 4.0, fill);
    p.rect_stroke(
        rect,
        4.0,
        Stroke::new(1.0, theme::FRAME),
        StrokeKind::Inside,
    );
}

fn fmt_opt(v: Option<f64>, digits: usize, unit: &str) -> String {
    v.map_or_else(|| "---".to_string(), |x| format!("{x:.digits$}{unit}"))
}

/// Marks an instrument whose data is stale (as aviation displays do): the instrument is
/// dimmed, crossed out in red and says NO DATA, so a frozen value cannot pass for a live
/// one.
pub fn stale_overlay(painter: &egui::Painter, rect: Rect) {
    painter.rect_filled(rect, 4.0, Color32::from_black_alpha(150));
    let r = rect.shrink(6.0);
    let red = Stroke::new(2.0, theme::RED.gamma_multiply(0.8));
    painter.line_segment([r.left_top(), r.right_bottom()], red);
    painter.line_segment([r.right_top(), r.left_bottom()], red);
    let plate = Rect::from_center_size(rect.center(), vec2(96.0_f32.min(rect.width()), 24.0));
    painter.rect_filled(plate, 3.0, Color32::BLACK);
    painter.rect_stroke(plate, 3.0, Stroke::new(1.5, theme::RED), StrokeKind::Inside);
    painter.text(
        plate.center(),
        Align2::CENTER_CENTER,
        "NO DATA",
        FontId::monospace(15.0),
        theme::RED,
    );
}

/// The accessible label of an instrument: its name, then its value or NO DATA.
fn a11y(name: &str, stale: bool, value: impl FnOnce() -> String) -> String {
    if stale {
        format!("{name}: NO DATA")
    } else {
        format!("{name}: {}", value())
    }
}

/// Depth tape inputs.
#[derive(Debug, Clone, Copy)]
pub struct DepthTape {
    /// Measured depth, m.
    pub depth_m: Option<f64>,
    /// Setpoint, m (None when not holding).
    pub setpoint_m: Option<f64>,
    /// Vertical thrust command, % (positive down).
    pub vertical_pct: f64,
    /// The hold is overridden by the stick.
    pub overridden: bool,
    /// Half range shown, m.
    pub half_range_m: f64,
    /// Vertical speed, m/s, positive down (None: unknown).
    pub heave_mps: Option<f64>,
    /// No current data: drawn dimmed with NO DATA.
    pub stale: bool,
    /// Show feet instead of metres.
    pub feet: bool,
}

/// The vertical-speed trend looks this far ahead, s.
pub const TREND_S: f64 = 6.0;

/// What the pilot did on the depth tape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TapeAction {
    /// Dragging: the setpoint under the pointer (preview).
    Dragging(f64),
    /// Released: set this setpoint.
    Set(f64),
}

impl DepthTape {
    /// Draws the tape in `size`; drag vertically on it to choose a setpoint. Right of
    /// the scale, the vertical thrust command (labelled); under the depth box the
    /// vertical speed, and along the scale its trend: where the vehicle will be in
    /// [`TREND_S`] at this speed.
    pub fn show(&self, ui: &mut Ui, size: Vec2, drag: Option<f64>) -> Option<TapeAction> {
        let (resp, painter) = ui.allocate_painter(size, Sense::drag());
        let label = a11y("depth tape", self.stale, || {
            format!(
                "{} m, {}, vertical thrust {:+.0} %",
                fmt_opt(self.depth_m, 2, ""),
                vertical_speed_text(self.heave_mps),
                self.vertical_pct
            )
        });
        resp.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Slider, true, &label));
        let rect = resp.rect;
        frame(ui, rect);
        let tape = depth_scale(rect);
        let bar = Rect::from_min_max(
            pos2(rect.max.x - DEPTH_BAR_W - 4.0, tape.min.y),
            pos2(rect.max.x - 4.0, tape.max.y),
        );
        // Display unit: k display units per metre.
        let (k, unit) = if self.feet {
            (crate::settings::FT_PER_M, "ft")
        } else {
            (1.0, "m")
        };
        // Headers at the two ends of the row: "THR" right-aligned over its bar, never
        // reaching into the tape's header (issue 25 item 4).
        painter.text(
            pos2(tape.min.x + 4.0, rect.min.y + 11.0),
            Align2::LEFT_CENTER,
            format!("DEPTH {unit}"),
            theme::small(),
            theme::SCALE,
        );
        painter.text(
            pos2(rect.max.x - 3.0, rect.min.y + 11.0),
            Align2::RIGHT_CENTER,
            "THR",
            theme::small(),
            theme::THRUST,
        );
        let centre_m = self.depth_m.unwrap_or(0.0);
        let half = self.half_range_m.max(0.5);
        let px_per_m = tape.height() / (2.0 * half as f32);
        let y_of = |d: f64| tape.center().y + ((d - centre_m) as f32) * px_per_m;
        let d_of = |y: f32| centre_m + f64::from((y - tape.center().y) / px_per_m);
        let clip = painter.with_clip_rect(tape);
        // Ticks every 0.5 m (labels every metre), or every 2 ft (labels every 4 ft).
        let step = if self.feet { 2.0 } else { 0.5 };
        let first = ((centre_m - half) * k / step).floor() as i64;
        let last = ((centre_m + half) * k / step).ceil() as i64;
        for i in first..=last {
            let shown = i as f64 * step;
            let d = shown / k;
            let y = y_of(d);
            let major = i % 2 == 0;
            let len = if major { 14.0 } else { 8.0 };
            clip.line_segment(
                [pos2(tape.min.x, y), pos2(tape.min.x + len, y)],
                Stroke::new(1.0, theme::SCALE),
            );
            if major {
                clip.text(
                    pos2(tape.min.x + 18.0, y),
                    Align2::LEFT_CENTER,
                    format!("{shown:.0}"),
                    theme::small(),
                    theme::SCALE,
                );
            }
        }
        // Surface line.
        let ys = y_of(0.0);
        if tape.y_range().contains(ys) {
            clip.line_segment(
                [pos2(tape.min.x, ys), pos2(tape.max.x, ys)],
                Stroke::new(2.0, theme::ESTIMATE),
            );
        }
        // Trend: a bar along the scale from now to TREND_S ahead.
        if let (Some(w), false) = (self.heave_mps, self.stale) {
            let y0 = tape.center().y;
            let y1 = y_of(centre_m + w * TREND_S).clamp(tape.min.y, tape.max.y);
            if (y1 - y0).abs() > 2.0 {
                let x = tape.min.x + 3.0;
                clip.line_segment([pos2(x, y0), pos2(x, y1)], Stroke::new(4.0, theme::TREND));
                let dir = if y1 > y0 { 1.0 } else { -1.0 };
                clip.add(Shape::convex_polygon(
                    vec![
                        pos2(x, y1 + dir * 6.0),
                        pos2(x - 5.0, y1 - dir * 2.0),
                        pos2(x + 5.0, y1 - dir * 2.0),
                    ],
                    theme::TREND,
                    Stroke::NONE,
                ));
            }
        }
        // Current depth box, and the vertical speed under it.
        let boxr = depth_box(tape);
        painter.rect_filled(boxr, 3.0, Color32::BLACK);
        painter.rect_stroke(
            boxr,
            3.0,
            Stroke::new(1.5, theme::VALUE),
            StrokeKind::Inside,
        );
        painter.text(
            boxr.center(),
            Align2::CENTER_CENTER,
            fmt_opt(
                self.depth_m.filter(|_| !self.stale).map(|d| d * k),
                if self.feet { 1 } else { 2 },
                "",
            ),
            theme::big(),
            theme::VALUE,
        );
        let vs = Rect::from_min_max(
            pos2(rect.min.x + 4.0, rect.min.y + 22.0),
            pos2(tape.max.x, rect.min.y + 40.0),
        );
        painter.rect_filled(vs, 3.0, Color32::from_black_alpha(200));
        let vs_text = match self.heave_mps.filter(|_| !self.stale) {
            Some(w) if w.abs() >= 0.005 => {
                format!(
                    "VS {} {:.2} m/s",
                    if w > 0.0 { "dn" } else { "up" },
                    w.abs()
                )
            }
            Some(_) => "VS 0.00 m/s".to_string(),
            None => "VS --- m/s".to_string(),
        };
        painter.text(
            vs.center(),
            Align2::CENTER_CENTER,
            vs_text,
            theme::small(),
            theme::TREND,
        );
        // Setpoint bug (clamped to the tape edge with an arrow when off scale).
        let sp = drag.or(self.setpoint_m);
        if let Some(sp) = sp {
            let y = y_of(sp).clamp(tape.min.y + 6.0, tape.max.y - 6.0);
            let x = tape.max.x - 2.0;
            let color = if self.overridden {
                theme::AMBER
            } else {
                theme::SETPOINT
            };
            painter.add(Shape::convex_polygon(
                vec![pos2(x, y), pos2(x - 12.0, y - 7.0), pos2(x - 12.0, y + 7.0)],
                color,
                Stroke::NONE,
            ));
            painter.line_segment(
                [pos2(tape.min.x, y), pos2(x, y)],
                Stroke::new(1.0, color.gamma_multiply(0.6)),
            );
            // The number on a plate beside the bug, moved off the value box when the
            // setpoint is near the depth (it covered the box's top, issue 25 item 4).
            let plate = depth_setpoint_plate(tape, y);
            painter.rect_filled(plate, 2.0, Color32::from_black_alpha(200));
            painter.text(
                pos2(plate.max.x - 2.0, plate.center().y),
                Align2::RIGHT_CENTER,
                format!("{:.1}", sp * k),
                theme::small(),
                color,
            );
        }
        // Vertical thrust bar: from the centre, down for positive (dive).
        painter.rect_filled(bar, 2.0, Color32::from_gray(35));
        let v = (self.vertical_pct.clamp(-100.0, 100.0) / 100.0) as f32;
        let yc = bar.center().y;
        let y1 = yc + v * bar.height() / 2.0;
        let fill = Rect::from_min_max(pos2(bar.min.x, yc.min(y1)), pos2(bar.max.x, yc.max(y1)));
        painter.rect_filled(fill, 1.0, theme::THRUST);
        painter.line_segment(
            [pos2(bar.min.x - 2.0, yc), pos2(bar.max.x + 2.0, yc)],
            Stroke::new(1.0, theme::SCALE),
        );
        painter.text(
            pos2(rect.max.x - 4.0, rect.max.y - 3.0),
            Align2::RIGHT_BOTTOM,
            format!("thr {:+.0} %", self.vertical_pct),
            theme::small(),
            theme::THRUST,
        );
        if self.stale {
            stale_overlay(&painter, tape);
        }

        let pointer = resp
            .interact_pointer_pos()
            .filter(|p| tape.expand(4.0).contains(*p));
        if resp.drag_stopped() {
            return drag.map(TapeAction::Set);
        }
        if resp.dragged() {
            return pointer.map(|p| TapeAction::Dragging(d_of(p.y).max(0.0)));
        }
        None
    }
}

/// Width of the depth tape's vertical-thrust bar, points.
const DEPTH_BAR_W: f32 = 16.0;

/// The scale of a depth tape drawn in `rect`: under the header and vertical-speed rows,
/// left of the vertical-thrust bar.
#[must_use]
pub fn depth_scale(rect: Rect) -> Rect {
    Rect::from_min_max(
        rect.min + vec2(2.0, 44.0),
        pos2(rect.max.x - DEPTH_BAR_W - 8.0, rect.max.y - 18.0),
    )
}

/// The current-depth value box at the middle of the depth tape's scale `tape`.
#[must_use]
pub fn depth_box(tape: Rect) -> Rect {
    let c = tape.center();
    Rect::from_center_size(pos2(c.x + 4.0, c.y), vec2(tape.width() - 8.0, 26.0))
}

/// The depth setpoint's number plate for a setpoint bug at height `y` on the scale
/// `tape`: just above the bug's line, left of its arrow; when that would cover the value
/// box, above the box whichever side of the middle the bug is (a held depth jitters about
/// its setpoint: the plate must not hop across the box), below it only on a scale too
/// short for that; always on the scale.
#[must_use]
pub fn depth_setpoint_plate(tape: Rect, y: f32) -> Rect {
    let size = vec2(40.0, 14.0);
    let right = tape.max.x - 14.0;
    let b = depth_box(tape);
    let at = |bottom: f32| Rect::from_min_size(pos2(right - size.x, bottom - size.y), size);
    let mut r = at(y - 3.0);
    if r.intersects(b.expand(1.0)) {
        r = at(b.min.y - 3.0);
        if r.min.y < tape.min.y {
            r = at(b.max.y + 3.0 + size.y);
        }
    }
    let dy = if r.min.y < tape.min.y {
        tape.min.y - r.min.y
    } else if r.max.y > tape.max.y {
        tape.max.y - r.max.y
    } else {
        0.0
    };
    r.translate(vec2(0.0, dy))
}

/// "descending 0.25 m/s", "ascending ...", "level" or "vertical speed unknown".
pub fn vertical_speed_text(heave_mps: Option<f64>) -> String {
    match heave_mps {
        Some(w) if w >= 0.005 => format!("descending {w:.2} m/s"),
        Some(w) if w <= -0.005 => format!("ascending {:.2} m/s", -w),
        Some(_) => "level 0.00 m/s".into(),
        None => "vertical speed --- m/s".into(),
    }
}

/// Half the width of the heading tape's value box, points.
const HEADING_BOX_HALF_W: f32 = 31.0;

/// The heading value box at the top centre of the heading tape's scale `tape`.
#[must_use]
pub fn heading_box(tape: Rect) -> Rect {
    Rect::from_center_size(
        pos2(tape.center().x, tape.min.y + 10.0),
        vec2(2.0 * HEADING_BOX_HALF_W, 22.0),
    )
}

/// The band of the heading tape's numerals (their text, bottom at 16 px above the
/// scale's bottom edge, `theme::mid` high).
#[must_use]
pub fn heading_numeral_band(tape: Rect) -> Rect {
    Rect::from_min_max(
        pos2(tape.min.x, tape.max.y - 16.0 - 16.0),
        pos2(tape.max.x, tape.max.y - 16.0),
    )
}

/// The heading setpoint's number plate for a setpoint bug at `x` on the scale `tape`:
/// in the top row beside the value box, never over the numerals or the box.
#[must_use]
pub fn setpoint_plate(tape: Rect, x: f32) -> Rect {
    let size = vec2(30.0, 15.0);
    let b = heading_box(tape);
    let mut cx = x.clamp(tape.min.x + size.x / 2.0, tape.max.x - size.x / 2.0);
    if (cx - b.center().x).abs() < HEADING_BOX_HALF_W + size.x / 2.0 + 2.0 {
        let side = if cx >= b.center().x { 1.0 } else { -1.0 };
        cx = b.center().x + side * (HEADING_BOX_HALF_W + size.x / 2.0 + 2.0);
    }
    Rect::from_center_size(pos2(cx, tape.min.y + 9.0), size)
}

/// The scale of a heading tape drawn in `rect` (the turns counter takes the right end).
#[must_use]
pub fn heading_scale(rect: Rect) -> Rect {
    Rect::from_min_max(
        rect.min + vec2(4.0, 4.0),
        pos2(rect.max.x - HEADING_TURNS_W, rect.max.y - 4.0),
    )
}

/// Width of the heading tape's turns counter, points.
const HEADING_TURNS_W: f32 = 110.0;

/// Heading tape inputs.
#[derive(Debug, Clone, Copy)]
pub struct HeadingTape {
    /// Heading, degrees.
    pub heading_deg: Option<f64>,
    /// Setpoint, degrees.
    pub setpoint_deg: Option<f64>,
    /// The hold is overridden.
    pub overridden: bool,
    /// Tether turns.
    pub turns: f64,
    /// No current data: drawn dimmed with NO DATA.
    pub stale: bool,
}

impl HeadingTape {
    /// Draws the tape; drag horizontally to choose a heading setpoint.
    pub fn show(&self, ui: &mut Ui, size: Vec2, drag: Option<f64>) -> Option<TapeAction> {
        let (resp, painter) = ui.allocate_painter(size, Sense::drag());
        let label = a11y("heading tape", self.stale, || {
            format!(
                "{}, turns {:+.1}",
                self.heading_deg
                    .map_or("---".into(), |h| format!("{}°", compass_text(h))),
                self.turns
            )
        });
        resp.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Slider, true, &label));
        let rect = resp.rect;
        frame(ui, rect);
        let turns_w = HEADING_TURNS_W;
        let tape = heading_scale(rect);
        let h = self.heading_deg.unwrap_or(0.0);
        let half = 60.0;
        let px_per_deg = tape.width() / (2.0 * half as f32);
        let x_of =
            |d: f64| tape.center().x + (rov_types::angle::wrap_deg_180(d - h) as f32) * px_per_deg;
        let d_of = |x: f32| (h + f64::from((x - tape.center().x) / px_per_deg)).rem_euclid(360.0);
        let clip = painter.with_clip_rect(tape);
        let first = ((h - half) / 5.0).floor() as i64;
        let last = ((h + half) / 5.0).ceil() as i64;
        for k in first..=last {
            let d = (k as f64 * 5.0).rem_euclid(360.0);
            let x = x_of(d);
            let major = k.rem_euclid(2) == 0;
            let len = if major { 12.0 } else { 6.0 };
            clip.line_segment(
                [pos2(x, tape.max.y), pos2(x, tape.max.y - len)],
                Stroke::new(1.0, theme::SCALE),
            );
            if k.rem_euclid(6) == 0 {
                let label = match d.round() as i64 {
                    0 => "N".to_string(),
                    90 => "E".to_string(),
                    180 => "S".to_string(),
                    270 => "W".to_string(),
                    x => format!("{x:03}"),
                };
                // Skip labels that would be cut at the ends.
                if x > tape.min.x + 18.0 && x < tape.max.x - 18.0 {
                    clip.text(
                        pos2(x, tape.max.y - 16.0),
                        Align2::CENTER_BOTTOM,
                        label,
                        theme::mid(),
                        theme::SCALE,
                    );
                }
            }
        }
        if let Some(sp) = drag.or(self.setpoint_deg) {
            let x = x_of(sp).clamp(tape.min.x + 6.0, tape.max.x - 6.0);
            let color = if self.overridden {
                theme::AMBER
            } else {
                theme::SETPOINT
            };
            painter.add(Shape::convex_polygon(
                vec![
                    pos2(x, tape.max.y - 2.0),
                    pos2(x - 8.0, tape.max.y - 14.0),
                    pos2(x + 8.0, tape.max.y - 14.0),
                ],
                color,
                Stroke::NONE,
            ));
            // The setpoint's number sits in the top row, above the numerals (it covered
            // them, issue 25 item 4), moved beside the heading box when it would hide it.
            let plate = setpoint_plate(tape, x);
            painter.rect_filled(plate, 2.0, Color32::from_black_alpha(220));
            painter.text(
                plate.center(),
                Align2::CENTER_CENTER,
                compass_text(sp),
                theme::small(),
                color,
            );
        }
        // Lubber line and value.
        let c = tape.center();
        painter.line_segment(
            [pos2(c.x, tape.min.y + 16.0), pos2(c.x, tape.max.y)],
            Stroke::new(2.0, theme::VALUE),
        );
        let boxr = heading_box(tape);
        painter.rect_filled(boxr, 3.0, Color32::BLACK);
        painter.rect_stroke(
            boxr,
            3.0,
            Stroke::new(1.5, theme::VALUE),
            StrokeKind::Inside,
        );
        let hv = self
            .heading_deg
            .filter(|_| !self.stale)
            .map_or("---".into(), |x| format!("{}°", compass_text(x)));
        painter.text(
            boxr.center(),
            Align2::CENTER_CENTER,
            hv,
            theme::mid(),
            theme::VALUE,
        );
        // Tether turns.
        let tr = Rect::from_min_max(
            pos2(rect.max.x - turns_w + 6.0, rect.min.y + 4.0),
            rect.max - vec2(4.0, 4.0),
        );
        // No "-0.0".
        let t = if self.turns.abs() < 0.05 {
            0.0
        } else {
            self.turns
        };
        let color = if t.abs() >= 4.0 {
            theme::RED
        } else if t.abs() >= 2.0 {
            theme::AMBER
        } else {
            theme::VALUE
        };
        painter.text(
            pos2(tr.center().x, tr.min.y + 2.0),
            Align2::CENTER_TOP,
            "TETHER TURNS",
            theme::small(),
            theme::SCALE,
        );
        painter.text(
            pos2(tr.center().x, tr.max.y - 2.0),
            Align2::CENTER_BOTTOM,
            format!("{t:+.1}"),
            theme::big(),
            color,
        );
        if self.stale {
            stale_overlay(&painter, tape);
        }

        let pointer = resp.interact_pointer_pos();
        if resp.drag_stopped() {
            return drag.map(TapeAction::Set);
        }
        if resp.dragged() {
            return pointer.map(|p| TapeAction::Dragging(d_of(p.x).round()));
        }
        None
    }
}

/// Draws the artificial horizon (pitch ladder, roll scale) in `size`; when
/// `stale`, dimmed and crossed out with NO DATA (never a level horizon from no data).
pub fn horizon(
    ui: &mut Ui,
    size: Vec2,
    pitch_deg: Option<f64>,
    roll_deg: Option<f64>,
    stale: bool,
) {
    let (rect, resp) = ui.allocate_exact_size(size, Sense::hover());
    let label = a11y("horizon", stale, || {
        format!(
            "pitch {}, roll {}",
            fmt_opt(pitch_deg, 1, "°"),
            fmt_opt(roll_deg, 1, "°")
        )
    });
    resp.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Image, true, &label));
    if overlay(ui) {
        horizon_hud(ui, rect, pitch_deg, roll_deg, stale);
        return;
    }
    frame(ui, rect);
    let inner = rect.shrink(6.0);
    let painter = ui.painter().with_clip_rect(inner);
    let c = inner.center();
    let pitch = pitch_deg.unwrap_or(0.0) as f32;
    let roll = roll_deg.unwrap_or(0.0).to_radians() as f32;
    let px_per_deg = inner.height() / 60.0;
    // Horizon line through c + offset, rotated by −roll (starboard down rolls the
    // horizon anticlockwise as seen by the pilot).
    let rot = |v: Vec2| -> Vec2 {
        let (s, co) = (-roll).sin_cos();
        vec2(v.x * co - v.y * s, v.x * s + v.y * co)
    };
    let off = pitch * px_per_deg;
    let big = inner.width().max(inner.height()) * 2.0;
    let p = |x: f32, y: f32| c + rot(vec2(x, y + off));
    // Sky and ground as two big rotated quads (over a picture: the horizon line only).
    if !overlay(ui) {
        painter.add(Shape::convex_polygon(
            vec![
                p(-big, -2.0 * big),
                p(big, -2.0 * big),
                p(big, 0.0),
                p(-big, 0.0),
            ],
            theme::SKY,
            Stroke::NONE,
        ));
        painter.add(Shape::convex_polygon(
            vec![
                p(-big, 0.0),
                p(big, 0.0),
                p(big, 2.0 * big),
                p(-big, 2.0 * big),
            ],
            theme::GROUND,
            Stroke::NONE,
        ));
    }
    painter.line_segment(
        [p(-big, 0.0), p(big, 0.0)],
        Stroke::new(2.0, Color32::WHITE),
    );
    for k in [-30i32, -20, -10, 10, 20, 30] {
        let y = -(k as f32) * px_per_deg;
        let w = if k % 20 == 0 { 50.0 } else { 30.0 };
        painter.line_segment([p(-w, y), p(w, y)], Stroke::new(1.0, Color32::WHITE));
        painter.text(
            p(w + 12.0, y),
            Align2::CENTER_CENTER,
            format!("{}", k.abs()),
            theme::small(),
            Color32::WHITE,
        );
    }
    // Fixed vehicle symbol.
    let sym = Stroke::new(3.0, Color32::YELLOW);
    painter.line_segment([c - vec2(60.0, 0.0), c - vec2(20.0, 0.0)], sym);
    painter.line_segment([c + vec2(20.0, 0.0), c + vec2(60.0, 0.0)], sym);
    painter.circle_filled(c, 4.0, Color32::YELLOW);
    // Roll scale.
    let r = inner.width().min(inner.height()) * 0.45;
    for a in [
        -60.0f32, -45.0, -30.0, -20.0, -10.0, 0.0, 10.0, 20.0, 30.0, 45.0, 60.0,
    ] {
        let t = (a - 90.0).to_radians();
        let dir = vec2(t.cos(), t.sin());
        let len = if a == 0.0 || a.abs() == 30.0 || a.abs() == 60.0 {
            12.0
        } else {
            7.0
        };
        painter.line_segment(
            [c + dir * r, c + dir * (r - len)],
            Stroke::new(1.5, Color32::WHITE),
        );
    }
    let t = -roll - std::f32::consts::FRAC_PI_2;
    let dir = vec2(t.cos(), t.sin());
    let tip = c + dir * (r - 14.0);
    let n = vec2(-dir.y, dir.x);
    painter.add(Shape::convex_polygon(
        vec![tip, tip - dir * 12.0 + n * 7.0, tip - dir * 12.0 - n * 7.0],
        Color32::YELLOW,
        Stroke::NONE,
    ));
    let text = format!(
        "P {}  R {}",
        fmt_opt(pitch_deg, 1, "°"),
        fmt_opt(roll_deg, 1, "°")
    );
    let tb = Rect::from_center_size(pos2(c.x, inner.max.y - 14.0), vec2(150.0, 22.0));
    painter.rect_filled(tb, 3.0, Color32::from_black_alpha(170));
    painter.text(
        tb.center(),
        Align2::CENTER_CENTER,
        text,
        theme::mid(),
        Color32::WHITE,
    );
    if stale {
        stale_overlay(&painter, inner);
    }
}

/// Half-width of the clear centre of the HUD horizon, points: no line, ladder or plate
/// crosses the middle of the picture, where the pilot looks for the target.
pub const HUD_CLEAR_HALF_W: f32 = 90.0;

/// The horizon over a picture (as QGroundControl's and Cockpit's HUDs do): no
/// backplate and no tint, a thin horizon line and pitch ladder broken across the clear
/// centre, the vehicle symbol as two short wings beside it, the roll pointer on a short
/// arc at the top edge, and the pitch/roll readout as small text at the bottom edge.
fn horizon_hud(ui: &Ui, rect: Rect, pitch_deg: Option<f64>, roll_deg: Option<f64>, stale: bool) {
    let inner = rect.shrink(6.0);
    let painter = ui.painter().with_clip_rect(inner);
    let c = inner.center();
    let ink = Color32::from_white_alpha(200);
    let shadow = Color32::from_black_alpha(120);
    let pitch = pitch_deg.unwrap_or(0.0) as f32;
    let roll = roll_deg.unwrap_or(0.0).to_radians() as f32;
    let px_per_deg = inner.height() / 60.0;
    let (s, co) = (-roll).sin_cos();
    let p = |x: f32, y: f32| {
        c + vec2(
            x * co - (y + pitch * px_per_deg) * s,
            x * s + (y + pitch * px_per_deg) * co,
        )
    };
    let gap = HUD_CLEAR_HALF_W.min(inner.width() * 0.25);
    let reach = (inner.width() * 0.45).max(gap + 40.0);
    // A one-pixel dark edge keeps the thin lines readable over a bright seabed.
    let line = |a: Pos2, b: Pos2, w: f32| {
        painter.line_segment(
            [a + vec2(1.0, 1.0), b + vec2(1.0, 1.0)],
            Stroke::new(w, shadow),
        );
        painter.line_segment([a, b], Stroke::new(w, ink));
    };
    if pitch_deg.is_some() && !stale {
        line(p(-reach, 0.0), p(-gap, 0.0), 1.5);
        line(p(gap, 0.0), p(reach, 0.0), 1.5);
        for k in [-20i32, -10, 10, 20] {
            let y = -(k as f32) * px_per_deg;
            let w = if k % 20 == 0 { 34.0 } else { 22.0 };
            line(p(-gap - w, y), p(-gap, y), 1.0);
            line(p(gap, y), p(gap + w, y), 1.0);
            painter.text(
                p(gap + w + 12.0, y),
                Align2::CENTER_CENTER,
                format!("{}", k.abs()),
                theme::small(),
                ink,
            );
        }
    }
    // Fixed vehicle symbol: two short wings outside the clear centre and a small dot.
    let sym = Stroke::new(2.0, Color32::YELLOW);
    painter.line_segment([c - vec2(gap + 30.0, 0.0), c - vec2(gap - 6.0, 0.0)], sym);
    painter.line_segment([c + vec2(gap - 6.0, 0.0), c + vec2(gap + 30.0, 0.0)], sym);
    painter.circle_filled(c, 2.0, Color32::YELLOW);
    // Roll: a short arc of ticks along the top edge and a pointer.
    let r = inner.height() * 0.5 - 4.0;
    let top = pos2(c.x, inner.min.y + 4.0 + r);
    for a in [-30.0f32, -20.0, -10.0, 0.0, 10.0, 20.0, 30.0] {
        let t = (a - 90.0).to_radians();
        let dir = vec2(t.cos(), t.sin());
        let len = if a == 0.0 || a.abs() == 30.0 {
            9.0
        } else {
            5.0
        };
        painter.line_segment(
            [top + dir * r, top + dir * (r - len)],
            Stroke::new(1.0, ink),
        );
    }
    if roll_deg.is_some() && !stale {
        let t = -roll - std::f32::consts::FRAC_PI_2;
        let dir = vec2(t.cos(), t.sin());
        let tip = top + dir * (r - 10.0);
        let n = vec2(-dir.y, dir.x);
        painter.add(Shape::convex_polygon(
            vec![tip, tip - dir * 9.0 + n * 5.0, tip - dir * 9.0 - n * 5.0],
            Color32::YELLOW,
            Stroke::NONE,
        ));
    }
    let text = format!(
        "P {}  R {}",
        fmt_opt(pitch_deg, 1, "°"),
        fmt_opt(roll_deg, 1, "°")
    );
    let at = pos2(c.x, inner.max.y - 4.0);
    painter.text(
        at + vec2(1.0, 1.0),
        Align2::CENTER_BOTTOM,
        &text,
        theme::small(),
        Color32::BLACK,
    );
    painter.text(
        at,
        Align2::CENTER_BOTTOM,
        text,
        theme::small(),
        Color32::WHITE,
    );
    if stale {
        // Over a picture, NO DATA without darkening the whole picture.
        let plate = Rect::from_center_size(c - vec2(0.0, 40.0), vec2(96.0, 24.0));
        painter.rect_filled(plate, 3.0, Color32::BLACK);
        painter.rect_stroke(plate, 3.0, Stroke::new(1.5, theme::RED), StrokeKind::Inside);
        painter.text(
            plate.center(),
            Align2::CENTER_CENTER,
            "NO DATA",
            FontId::monospace(15.0),
            theme::RED,
        );
    }
}

/// Draws the side view of the vehicle pitched by `pitch_deg` (nose to the right).
pub fn pitch_glyph(ui: &mut Ui, size: Vec2, pitch_deg: Option<f64>, stale: bool) {
    let (rect, resp) = ui.allocate_exact_size(size, Sense::hover());
    let label = a11y("pitch glyph", stale, || fmt_opt(pitch_deg, 1, "°"));
    resp.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Image, true, &label));
    frame(ui, rect);
    let painter = ui.painter().with_clip_rect(rect.shrink(2.0));
    let c = rect.center() + vec2(0.0, 6.0);
    painter.text(
        pos2(rect.center().x, rect.min.y + 4.0),
        Align2::CENTER_TOP,
        "PITCH (side)",
        theme::small(),
        theme::SCALE,
    );
    painter.line_segment(
        [pos2(rect.min.x + 6.0, c.y), pos2(rect.max.x - 6.0, c.y)],
        Stroke::new(1.0, theme::FRAME),
    );
    let a = -(pitch_deg.unwrap_or(0.0) as f32).to_radians();
    let (s, co) = a.sin_cos();
    let rot = |v: Vec2| c + vec2(v.x * co - v.y * s, v.x * s + v.y * co);
    let w = (rect.width() * 0.32).min(60.0);
    let h = w * 0.45;
    // Body with a sloped nose (the Pro 4's camera dome at the front).
    let body = vec![
        rot(vec2(-w, -h / 2.0)),
        rot(vec2(w * 0.7, -h / 2.0)),
        rot(vec2(w, 0.0)),
        rot(vec2(w * 0.7, h / 2.0)),
        rot(vec2(-w, h / 2.0)),
    ];
    painter.add(Shape::convex_polygon(
        body,
        Color32::from_rgb(230, 200, 40),
        Stroke::new(1.0, Color32::BLACK),
    ));
    painter.circle_filled(
        rot(vec2(w * 0.78, 0.0)),
        h * 0.22,
        Color32::from_rgb(30, 30, 30),
    );
    painter.text(
        pos2(rect.center().x, rect.max.y - 4.0),
        Align2::CENTER_BOTTOM,
        fmt_opt(pitch_deg, 1, "°"),
        theme::mid(),
        theme::VALUE,
    );
    if stale {
        stale_overlay(&painter, rect.shrink(2.0));
    }
}

/// Draws thruster command bars (port, starboard, vertical), each −100..100 %.
pub fn thruster_bars(ui: &mut Ui, size: Vec2, port: f64, starboard: f64, vertical: f64) {
    let (rect, resp) = ui.allocate_exact_size(size, Sense::hover());
    let label = format!(
        "thrust command: port {port:+.0} %, starboard {starboard:+.0} %, vertical {vertical:+.0} %"
    );
    resp.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Image, true, &label));
    frame(ui, rect);
    let painter = ui.painter();
    painter.text(
        pos2(rect.center().x, rect.min.y + 4.0),
        Align2::CENTER_TOP,
        "THRUST COMMAND %",
        theme::small(),
        theme::SCALE,
    );
    let names = ["PORT", "STBD", "VERT"];
    let vals = [port, starboard, vertical];
    let n = names.len() as f32;
    let w = (rect.width() - 16.0) / n;
    let top = rect.min.y + 22.0;
    let bottom = rect.max.y - 36.0;
    for (i, (name, v)) in names.iter().zip(vals).enumerate() {
        let x0 = rect.min.x + 8.0 + w * i as f32;
        let bar = Rect::from_min_max(pos2(x0 + w * 0.3, top), pos2(x0 + w * 0.7, bottom));
        painter.rect_filled(bar, 2.0, Color32::from_gray(35));
        let yc = bar.center().y;
        let f = (v.clamp(-100.0, 100.0) / 100.0) as f32;
        // Forward (or down for the vertical) up the bar.
        let y1 = yc - f * bar.height() / 2.0;
        let fill = Rect::from_min_max(pos2(bar.min.x, yc.min(y1)), pos2(bar.max.x, yc.max(y1)));
        let color = if v.abs() >= 99.5 {
            theme::RED
        } else {
            theme::THRUST
        };
        painter.rect_filled(fill, 1.0, color);
        painter.line_segment(
            [pos2(bar.min.x - 3.0, yc), pos2(bar.max.x + 3.0, yc)],
            Stroke::new(1.0, theme::SCALE),
        );
        painter.text(
            pos2(bar.center().x, bottom + 3.0),
            Align2::CENTER_TOP,
            *name,
            theme::small(),
            theme::SCALE,
        );
        painter.text(
            pos2(bar.center().x, rect.max.y - 3.0),
            Align2::CENTER_BOTTOM,
            format!("{v:+.0}"),
            theme::mid(),
            theme::VALUE,
        );
    }
}

/// The hold-to-arm / disarm control. Returns (arm button held this frame, disarm
/// clicked). The arm button shows the runtime's hold progress as a filling bar.
pub fn arm_control(ui: &mut Ui, armed: bool, progress: f64) -> (bool, bool) {
    if armed {
        let b = egui::Button::new(
            egui::RichText::new("DISARM")
                .size(20.0)
                .strong()
                .color(Color32::WHITE),
        )
        .fill(theme::RED)
        .min_size(vec2(150.0, 38.0));
        let r = ui.add(b);
        return (false, r.clicked());
    }
    (
        hold_button(ui, "HOLD TO ARM", vec2(150.0, 38.0), progress),
        false,
    )
}

/// A press-and-hold button (hold to arm, hold to confirm): true while the pointer holds
/// it; `progress` (0..1, timed by the caller) fills it.
pub fn hold_button(ui: &mut Ui, text: &str, size: egui::Vec2, progress: f64) -> bool {
    let (rect, resp) = ui.allocate_exact_size(size, Sense::click_and_drag());
    let held = resp.is_pointer_button_down_on();
    let p = ui.painter();
    p.rect_filled(rect, 4.0, Color32::from_rgb(50, 56, 64));
    let f = progress.clamp(0.0, 1.0) as f32;
    if f > 0.0 {
        let fill = Rect::from_min_max(rect.min, pos2(rect.min.x + rect.width() * f, rect.max.y));
        p.rect_filled(fill, 4.0, theme::AMBER);
    }
    p.rect_stroke(
        rect,
        4.0,
        Stroke::new(1.5, theme::AMBER),
        StrokeKind::Inside,
    );
    p.text(
        rect.center(),
        Align2::CENTER_CENTER,
        text,
        egui::FontId::proportional((size.y * 0.45).min(17.0)),
        Color32::WHITE,
    );
    resp.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Button, true, text));
    held
}

/// A horizontal bar for a stick value (−1..1) with a label.
pub fn stick_bar(ui: &mut Ui, label: &str, raw: f64, shaped: f64) {
    ui.horizontal(|ui| {
        ui.add_sized(
            vec2(56.0, 16.0),
            egui::Label::new(egui::RichText::new(label).small()),
        );
        let (rect, _) = ui.allocate_exact_size(vec2(150.0, 14.0), Sense::hover());
        let p = ui.painter();
        p.rect_filled(rect, 2.0, Color32::from_gray(35));
        let xc = rect.center().x;
        let draw = |v: f64, color: Color32, h: f32| {
            let x1 = xc + (v.clamp(-1.0, 1.0) as f32) * rect.width() / 2.0;
            let r = Rect::from_min_max(
                pos2(xc.min(x1), rect.center().y - h / 2.0),
                pos2(xc.max(x1), rect.center().y + h / 2.0),
            );
            p.rect_filled(r, 1.0, color);
        };
        draw(raw, theme::DIM, 12.0);
        draw(shaped, theme::THRUST, 6.0);
        p.line_segment(
            [pos2(xc, rect.min.y), pos2(xc, rect.max.y)],
            Stroke::new(1.0, theme::SCALE),
        );
        ui.label(
            egui::RichText::new(format!("{raw:+.2} -> {shaped:+.2}"))
                .monospace()
                .small(),
        );
    });
}

/// A coloured status dot followed by text.
pub fn dot_label(ui: &mut Ui, color: Color32, text: impl Into<egui::WidgetText>) {
    ui.horizontal(|ui| {
        let (rect, _) = ui.allocate_exact_size(vec2(12.0, 12.0), Sense::hover());
        ui.painter().circle_filled(rect.center(), 5.5, color);
        ui.label(text);
    });
}

/// Draws a simple framed heading for an instrument group.
pub fn group_title(ui: &mut Ui, text: &str) {
    ui.label(egui::RichText::new(text).strong().color(theme::SCALE));
}
