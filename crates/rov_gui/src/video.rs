//! The camera picture in the Fly tab's main view, live or replayed.
//!
//! The frames come from the station's [`StationVideo`] slot (a pointer swap: the GUI never
//! waits for the capture, the decoder or the control thread). A frame is uploaded into
//! the texture once, when it is new; the time from its capture to that upload is the
//! capture-to-screen latency shown beside the link figures. Without a picture (source
//! stalled, unplugged, failed) the last frame is dimmed and NO VIDEO is written over it
//! with the reason and the frame's age. A status strip (REC, link, video, alarms) sits at
//! the bottom, on dark backplates so it stays legible on a bright picture.

use std::collections::VecDeque;
use std::sync::Arc;

use egui::{Align2, Color32, FontId, Rect, Ui, pos2, vec2};
use rov_station::runtime::video::{StationVideo, VideoStatus};
use rov_station::runtime::{AlarmLevel, StationView};
use rov_video::VideoFrame;

use crate::app::StationApp;
use crate::theme;

/// Capture-to-screen latencies kept for the percentiles.
const LATENCY_WINDOW: usize = 256;

/// The texture and the figures of the shown video.
#[derive(Default)]
pub struct VideoPane {
    texture: Option<egui::TextureHandle>,
    shown: Option<Arc<VideoFrame>>,
    latency_ms: VecDeque<f64>,
    uploads: u64,
}

impl std::fmt::Debug for VideoPane {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("VideoPane")
            .field("uploads", &self.uploads)
            .finish_non_exhaustive()
    }
}

impl VideoPane {
    /// Uploads the slot's frame if it is new; returns the frame shown.
    pub fn update(&mut self, ctx: &egui::Context, video: &StationVideo) -> Option<Arc<VideoFrame>> {
        let latest = video.slot().and_then(|s| s.latest());
        match (&latest, &self.shown) {
            (Some(f), Some(s)) if Arc::ptr_eq(f, s) => {}
            (Some(f), _) => {
                let image = egui::ColorImage::from_rgba_unmultiplied(
                    [f.width_px as usize, f.height_px as usize],
                    &f.rgba,
                );
                match &mut self.texture {
                    Some(t) => t.set(image, egui::TextureOptions::LINEAR),
                    None => {
                        self.texture =
                            Some(ctx.load_texture("camera", image, egui::TextureOptions::LINEAR));
                    }
                }
                if video.is_live() {
                    let ms = video.now_ns().saturating_sub(f.capture_ns) as f64 * 1e-6;
                    if self.latency_ms.len() == LATENCY_WINDOW {
                        self.latency_ms.pop_front();
                    }
                    self.latency_ms.push_back(ms);
                }
                self.uploads += 1;
                self.shown = Some(Arc::clone(f));
            }
            (None, _) => {
                self.shown = None;
            }
        }
        self.shown.clone()
    }

    /// Frames uploaded so far.
    #[must_use]
    pub const fn uploads(&self) -> u64 {
        self.uploads
    }

    /// The frame on screen.
    #[must_use]
    pub fn shown(&self) -> Option<&Arc<VideoFrame>> {
        self.shown.as_ref()
    }

    /// Capture-to-screen latency (capture → texture upload), ms: median and 99th
    /// percentile of the last 256 frames.
    #[must_use]
    pub fn latency_ms(&self) -> Option<(f64, f64)> {
        if self.latency_ms.is_empty() {
            return None;
        }
        let mut v: Vec<f64> = self.latency_ms.iter().copied().collect();
        v.sort_by(f64::total_cmp);
        let at = |p: f64| {
            let i = ((v.len() - 1) as f64 * p).round() as usize;
            v.get(i).copied().unwrap_or(f64::NAN)
        };
        Some((at(0.5), at(0.99)))
    }

    /// Paints the picture (letterboxed into `rect`) and, without video, NO VIDEO.
    pub fn paint(&mut self, ui: &Ui, rect: Rect, video: &StationVideo, status: &VideoStatus) {
        let p = ui.painter_at(rect);
        p.rect_filled(rect, 0.0, Color32::BLACK);
        let shown = self.update(ui.ctx(), video);
        let label = status.no_video_label();
        if let (Some(f), Some(t)) = (&shown, &self.texture) {
            let aspect = f.width_px as f32 / f.height_px.max(1) as f32;
            let (w, h) = if rect.width() / rect.height().max(1.0) > aspect {
                (rect.height() * aspect, rect.height())
            } else {
                (rect.width(), rect.width() / aspect)
            };
            let img = Rect::from_center_size(rect.center(), vec2(w, h));
            let tint = if label.is_some() {
                Color32::from_gray(90)
            } else {
                Color32::WHITE
            };
            p.image(
                t.id(),
                img,
                Rect::from_min_max(pos2(0.0, 0.0), pos2(1.0, 1.0)),
                tint,
            );
        }
        if let Some(text) = label {
            plate(
                &p,
                rect.center(),
                Align2::CENTER_CENTER,
                &text,
                FontId::proportional(20.0),
                theme::AMBER,
            );
        }
    }
}

/// Text on a dark backplate (legible on a bright picture).
fn plate(
    p: &egui::Painter,
    at: egui::Pos2,
    align: Align2,
    text: &str,
    font: FontId,
    color: Color32,
) -> Rect {
    let galley = p.layout_no_wrap(text.to_owned(), font, color);
    let r = align.anchor_size(at, galley.size()).expand2(vec2(8.0, 4.0));
    p.rect_filled(r, 4.0, Color32::from_black_alpha(170));
    p.galley(r.min + vec2(8.0, 4.0), galley, color);
    r
}

/// The video of what the GUI shows (the replay's while replaying, else the live one's).
pub(crate) fn shown_video(app: &StationApp) -> Option<Arc<StationVideo>> {
    let h = app.replay.as_ref().or(app.live.as_ref())?;
    h.video().filter(|v| v.is_on()).cloned()
}

/// The status strip over the picture: the active alarms, REC, link and video.
pub(crate) fn status_strip(
    ui: &Ui,
    rect: Rect,
    v: &StationView,
    status: &VideoStatus,
    latency: Option<(f64, f64)>,
) {
    let p = ui.painter_at(rect);
    let font = FontId::monospace(14.0);
    let mut x = crate::fly::hud_layout(rect).status.min.x;
    let y = rect.max.y - 8.0;
    let mut put = |text: String, color: Color32| {
        let r = plate(
            &p,
            pos2(x, y),
            Align2::LEFT_BOTTOM,
            &text,
            font.clone(),
            color,
        );
        x = r.max.x + 6.0;
    };
    // The active alarms first: on a narrow picture the strip is clipped at the right,
    // and at 1024×600 it cut "VEHICLE CHANGED" to "VEHICLE CHAN" (issue 25's flights).
    for a in v.alarms.iter().filter(|a| a.active).take(3) {
        let color = match a.level {
            AlarmLevel::Alarm => theme::RED,
            AlarmLevel::Warning => theme::AMBER,
        };
        put(a.kind.text().to_uppercase(), color);
    }
    if v.recording.path.is_some() {
        put(format!("● REC {:.0} s", v.recording.elapsed_s), theme::RED);
    }
    put(
        format!(
            "LINK {}{}",
            v.link.health,
            v.link
                .rtt_p50_ms
                .map(|r| format!(" {r:.0} ms"))
                .unwrap_or_default()
        ),
        theme::quality(v.link.quality),
    );
    if let Some(s) = &status.stats {
        let lat = latency
            .map(|(_, p99)| format!(" {p99:.0} ms"))
            .unwrap_or_default();
        let color = if s.state.has_video() {
            theme::VALUE
        } else {
            theme::AMBER
        };
        put(format!("VIDEO {:.0} fps{lat}", s.fps), color);
    }
}

/// The video rows of the link panel: rate, size, latency, state.
pub(crate) fn link_rows(app: &StationApp, ui: &mut Ui) {
    let Some(video) = shown_video(app) else {
        return;
    };
    let s = video.status();
    ui.label("Video");
    let text = match &s.stats {
        Some(st) => format!(
            "{:.1} fps{}",
            st.fps,
            st.frame_size_px
                .map(|(w, h)| format!("  {w}×{h}"))
                .unwrap_or_default()
        ),
        None => "off".to_owned(),
    };
    ui.label(egui::RichText::new(text).monospace());
    ui.end_row();
    if let Some((p50, p99)) = app.video_pane.latency_ms() {
        ui.label("Capture to screen");
        ui.label(egui::RichText::new(format!("{p50:.0} ms (p99 {p99:.0} ms)")).monospace());
        ui.end_row();
    }
    if let Some(label) = s.no_video_label() {
        ui.label("");
        ui.label(egui::RichText::new(label).small().color(theme::AMBER));
        ui.end_row();
    }
}
