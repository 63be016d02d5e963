//! Layout checks: which controls a frame clipped.
//!
//! egui records every widget's full rectangle and its rectangle after clipping by the
//! enclosing panel (`WidgetRect::rect` and `interact_rect`). A control whose clipped
//! rectangle is smaller than its full one is cut off, unless it sits in a scroll area
//! that clips it on purpose (scrolled out of view). The station's scroll areas go
//! through [`scroll`], which records their viewports for this check. The check runs
//! in the GUI tests at 1024×600 and 1920×1080 and in the real window under Xvfb (the
//! screenshot hook writes the result next to the PNG).

use egui::{Rect, Ui};
use serde::Serialize;

use crate::app::StationApp;

/// What the last frame laid out, for the checks.
#[derive(Debug, Clone, Default)]
pub struct LayoutAudit {
    /// The Fly tab's main view, when the Fly tab was shown.
    pub main_rect: Option<Rect>,
    /// The viewports of the scroll areas drawn this frame.
    pub scroll_viewports: Vec<Rect>,
    /// Each scroll area's id and how much of its content did not fit its viewport,
    /// points (0 when all of it shows without scrolling).
    pub scroll_hidden: Vec<(String, f32)>,
}

/// A control cut off by the layout.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ClippedWidget {
    /// The widget's label (empty when it has none).
    pub label: String,
    /// Its full rectangle, points: [x0, y0, x1, y1].
    pub rect: [f32; 4],
    /// What is visible of it.
    pub visible: [f32; 4],
}

fn corners(r: Rect) -> [f32; 4] {
    [r.min.x, r.min.y, r.max.x, r.max.y]
}

/// A vertical scroll area over the station's side panels, recorded for the check.
pub fn scroll<R>(
    app: &mut StationApp,
    ui: &mut Ui,
    id: &str,
    add: impl FnOnce(&mut StationApp, &mut Ui) -> R,
) -> R {
    let out = egui::ScrollArea::vertical()
        .id_salt(id)
        .auto_shrink([false, true])
        .show(ui, |ui| add(app, ui));
    app.layout.scroll_viewports.push(out.inner_rect);
    let hidden = (out.content_size.y - out.inner_rect.height()).max(0.0);
    app.layout.scroll_hidden.push((id.to_owned(), hidden));
    out.inner
}

/// The interactive controls (buttons, fields, sliders, tapes) that the last frame cut
/// off, ignoring those clipped only vertically inside a recorded scroll viewport and
/// those entirely outside the window (never shown). `tolerance` points of overhang are
/// allowed (anti-aliasing, rounding).
#[must_use]
pub fn clipped_widgets(
    ctx: &egui::Context,
    audit: &LayoutAudit,
    tolerance: f32,
) -> Vec<ClippedWidget> {
    let screen = ctx.content_rect();
    let mut out = Vec::new();
    ctx.viewport(|vp| {
        let widgets = &vp.prev_pass.widgets;
        for (_, list) in widgets.layers() {
            for w in list {
                if !(w.sense.senses_click() || w.sense.senses_drag()) {
                    continue;
                }
                let (r, v) = (w.rect, w.interact_rect);
                if !r.is_positive() || !r.intersects(screen) {
                    continue;
                }
                let cut_x = v.min.x > r.min.x + tolerance || v.max.x < r.max.x - tolerance;
                let cut_y = v.min.y > r.min.y + tolerance || v.max.y < r.max.y - tolerance;
                if !cut_x && !cut_y {
                    continue;
                }
                // Clipped only vertically by a scroll viewport it belongs to (scrolled
                // out of view, on purpose).
                let scrolled = !cut_x
                    && audit
                        .scroll_viewports
                        .iter()
                        .any(|s| s.min.x - tolerance <= r.min.x && r.max.x <= s.max.x + tolerance);
                if scrolled {
                    continue;
                }
                let label = widgets
                    .info(w.id)
                    .and_then(|i| i.label.clone())
                    .unwrap_or_default();
                out.push(ClippedWidget {
                    label,
                    rect: corners(r),
                    visible: corners(v),
                });
            }
        }
    });
    out
}
