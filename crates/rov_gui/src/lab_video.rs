//! The Model lab's camera frame: for a run loaded from a session (`.mcap`), the picture
//! at a chosen time, decoded on a worker (`rov_station::runtime::video_replay`), so the
//! engineer sees what the vehicle saw where a channel misbehaves.

use std::sync::Arc;

use egui::{RichText, Ui};
use rov_station::runtime::video_replay::ReplayVideo;
use rov_video::VideoFrame;

use crate::app::StationApp;
use crate::theme;

/// The lab's video state.
#[derive(Default)]
pub struct LabVideo {
    /// The session whose video is open.
    path: String,
    player: Option<ReplayVideo>,
    start_ns: u64,
    duration_s: f64,
    /// The chosen time, s since the session start.
    pub t_s: f64,
    error: Option<String>,
    texture: Option<(egui::TextureHandle, Arc<VideoFrame>)>,
}

impl std::fmt::Debug for LabVideo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LabVideo")
            .field("path", &self.path)
            .field("t_s", &self.t_s)
            .finish_non_exhaustive()
    }
}

impl LabVideo {
    fn open(&mut self, path: &str) {
        self.path = path.to_owned();
        self.player = None;
        self.error = None;
        self.texture = None;
        self.t_s = 0.0;
        match rov_session::open(std::path::Path::new(path)) {
            Ok(s) => {
                self.start_ns = s.start_ns().unwrap_or(0);
                self.duration_s = s.duration_s();
                match ReplayVideo::start(s) {
                    Ok(p) => self.player = p,
                    Err(e) => {
                        self.error = Some(format!("cannot start the replay video thread: {e}"));
                    }
                }
            }
            Err(e) => self.error = Some(e.to_string()),
        }
    }

    /// Asks for the frame at `t_s` (s since the session start).
    pub fn request(&self, t_s: f64) {
        if let Some(p) = &self.player {
            p.request(
                self.start_ns
                    .saturating_add((t_s.max(0.0) * 1e9).round() as u64),
            );
        }
    }
}

/// The lab's camera row and picture (sessions with video only).
pub(crate) fn panel(app: &mut StationApp, ui: &mut Ui) {
    let Some(data) = &app.lab.data else {
        return;
    };
    let path = app.lab.path.trim().to_owned();
    if !path.to_ascii_lowercase().ends_with(".mcap") {
        return;
    }
    let _ = data;
    let lv = &mut app.lab_video;
    if lv.path != path {
        lv.open(&path);
        lv.request(0.0);
    }
    if let Some(e) = &lv.error {
        ui.label(
            RichText::new(format!("camera: {e}"))
                .small()
                .color(theme::AMBER),
        );
        return;
    }
    let Some(player) = &lv.player else {
        ui.label(
            RichText::new("this session has no camera video")
                .small()
                .color(theme::DIM),
        );
        return;
    };
    let slot = player.slot();
    ui.horizontal(|ui| {
        let l = ui.label("Camera at");
        let r = ui
            .add(
                egui::Slider::new(&mut lv.t_s, 0.0..=lv.duration_s.max(0.0))
                    .suffix(" s")
                    .step_by(0.04),
            )
            .labelled_by(l.id);
        if r.changed() {
            let t = lv.t_s;
            lv.request(t);
        }
    });
    if let Some(f) = slot.latest() {
        let new = lv.texture.as_ref().is_none_or(|(_, s)| !Arc::ptr_eq(s, &f));
        if new {
            let image = egui::ColorImage::from_rgba_unmultiplied(
                [f.width_px as usize, f.height_px as usize],
                &f.rgba,
            );
            let tex = ui
                .ctx()
                .load_texture("lab_camera", image, egui::TextureOptions::LINEAR);
            lv.texture = Some((tex, Arc::clone(&f)));
        }
    }
    if let Some((t, f)) = &lv.texture {
        let w = 320.0;
        let h = w * f.height_px as f32 / f.width_px.max(1) as f32;
        ui.image((t.id(), egui::vec2(w, h)));
        ui.label(
            RichText::new(format!(
                "frame captured at {:.2} s",
                f.capture_ns.saturating_sub(lv.start_ns) as f64 * 1e-9
            ))
            .small()
            .color(theme::DIM),
        );
    }
}
