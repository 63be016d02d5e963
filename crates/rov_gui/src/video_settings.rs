//! The camera's settings: the Settings tab's Video section (the source, the simulator's
//! seabed) and the Connection tab's list of V4L2 capture devices. Both save `[video]` into
//! the station configuration (`rov_station::runtime::settings::save_video`); the source
//! applies from the next connection.

use std::path::Path;

use egui::{RichText, Ui};
use rov_station::runtime::settings::save_video;
use rov_station::runtime::video::VideoSettings;

use crate::app::StationApp;
use crate::theme;

/// The choices offered besides the devices and free text.
const PRESETS: [(&str, &str); 4] = [
    (
        "auto",
        "auto (sim camera with the simulator, first capture device with a port)",
    ),
    ("sim", "simulator camera"),
    ("test", "GStreamer test pattern"),
    ("none", "no video"),
];

/// The Settings tab's Video section.
pub(crate) fn video_section(
    ui: &mut Ui,
    video: &mut VideoSettings,
    target: &Path,
    message: &mut Option<String>,
) {
    ui.label(RichText::new("Video").strong().color(theme::SCALE));
    ui.horizontal(|ui| {
        egui::ComboBox::new("video_source", "Source")
            .selected_text(video.source.clone())
            .show_ui(ui, |ui| {
                for (key, text) in PRESETS {
                    ui.selectable_value(&mut video.source, key.to_owned(), text);
                }
            });
    });
    ui.horizontal(|ui| {
        let l = ui.label("Device, URI or pipeline");
        ui.add(
            egui::TextEdit::singleline(&mut video.source)
                .hint_text("v4l2:/dev/video0, rtsp://…, udp://:5600, file:///…")
                .desired_width(240.0),
        )
        .labelled_by(l.id);
    });
    ui.horizontal(|ui| {
        let l = ui.label("Simulator seabed");
        ui.add(
            egui::DragValue::new(&mut video.sim_seabed_depth_m)
                .range(1.0..=200.0)
                .speed(0.5)
                .suffix(" m"),
        )
        .labelled_by(l.id);
    });
    let check = rov_station::runtime::video::resolve_source(
        &video.source,
        &rov_station::runtime::Connection::Sim,
    );
    if let Err(e) = &check {
        ui.label(RichText::new(e.to_string()).small().color(theme::AMBER));
    }
    ui.horizontal(|ui| {
        if ui
            .add_enabled(check.is_ok(), egui::Button::new("Save video settings"))
            .clicked()
        {
            *message = Some(match save_video(target, video) {
                Ok(()) => format!(
                    "video settings saved to {}; they apply from the next connection",
                    target.display()
                ),
                Err(e) => format!("cannot save: {e}"),
            });
        }
        ui.label(
            RichText::new("applies from the next connection (Connection tab)")
                .small()
                .color(theme::DIM),
        );
    });
}

/// The Connection tab's capture devices: listed on demand (GStreamer's device monitor);
/// choosing one makes it the source and saves it in the configuration.
pub(crate) fn devices(app: &mut StationApp, ui: &mut Ui) {
    ui.separator();
    ui.heading("Camera");
    ui.horizontal(|ui| {
        ui.label(format!("Source: {}", app.video_settings.source));
        if ui.button("List capture devices").clicked() || app.capture_devices.is_none() {
            app.capture_devices = Some(rov_video::list_capture_devices());
        }
    });
    if let Some(v) = crate::video::shown_video(app) {
        let s = v.status();
        let text = s.no_video_label().unwrap_or_else(|| {
            format!(
                "{}: {:.1} fps",
                s.source,
                s.stats.as_ref().map_or(0.0, |x| x.fps)
            )
        });
        ui.label(RichText::new(text).small().color(theme::DIM));
    }
    let mut chosen = None;
    match &app.capture_devices {
        Some(Ok(list)) if list.is_empty() => {
            ui.label(
                RichText::new("no V4L2 capture device found (is the frame grabber plugged in, and are you in the video group?)")
                    .color(theme::DIM),
            );
        }
        Some(Ok(list)) => {
            for d in list {
                let spec = d.spec.to_string();
                ui.horizontal(|ui| {
                    let selected = app.video_settings.source == spec;
                    if ui
                        .selectable_label(selected, format!("{} ({})", d.name, d.path.display()))
                        .clicked()
                    {
                        chosen = Some(spec.clone());
                    }
                    if !d.formats.is_empty() {
                        ui.label(
                            RichText::new(d.formats.join(", "))
                                .small()
                                .color(theme::DIM),
                        );
                    }
                });
            }
        }
        Some(Err(e)) => {
            ui.label(RichText::new(format!("cannot list devices: {e}")).color(theme::AMBER));
        }
        None => {}
    }
    if let Some(spec) = chosen {
        app.video_settings.source = spec;
        let target = app.config_target();
        app.message = Some(match save_video(&target, &app.video_settings) {
            Ok(()) => format!(
                "camera {} chosen and saved to {}; it starts with the next connection",
                app.video_settings.source,
                target.display()
            ),
            Err(e) => format!("cannot save the camera choice: {e}"),
        });
    }
}
