//! The pilot's extra keys (issue 25 items 9, 10, 15): acknowledge alarms, lights, camera
//! tilt and setpoint nudges; the toast that confirms a marker or a note; and the offer to
//! record when the vehicle is armed unrecorded (item 13).
//!
//! Each key sends the same command as its button; the toast shows the station's own
//! event line (number, depth, heading, dive time), so it confirms what was recorded,
//! not what the GUI asked for.

use egui::{Align2, Color32, Key, RichText, Ui, vec2};
use rov_control::ModeCommand;
use rov_station::StationCommand;
use rov_station::runtime::{AlarmKind, CameraCommand, RuntimeCommand};

use crate::app::StationApp;
use crate::theme;

/// Lights step per `]` / `[` press, percent.
pub const LIGHTS_STEP_PCT: f64 = 10.0;
/// Camera tilt step per T / G press, degrees.
pub const TILT_STEP_DEG: f64 = 10.0;
/// Depth setpoint nudge per ↑ / ↓ press, metres (Shift: [`DEPTH_STEP_BIG_M`]).
pub const DEPTH_STEP_M: f64 = 0.1;
/// Depth setpoint nudge with Shift, metres.
pub const DEPTH_STEP_BIG_M: f64 = 1.0;
/// Heading setpoint nudge per ← / → press, degrees (Shift: [`HEADING_STEP_BIG_DEG`]).
pub const HEADING_STEP_DEG: f64 = 1.0;
/// Heading setpoint nudge with Shift, degrees.
pub const HEADING_STEP_BIG_DEG: f64 = 10.0;
/// The start of a toast's text (the default fonts have no check mark).
pub const TOAST_PREFIX: &str = "LOGGED  ";
/// How long a toast stays, seconds.
pub const TOAST_S: f64 = 3.0;

/// The keys of this module, for the F1 window (keys, what).
pub const KEYS: [(&str, &str); 5] = [
    ("K", "acknowledge the alarms"),
    ("[ / ]", "lights -/+ 10 %"),
    ("T / G", "camera tilt up / down 10°"),
    ("↑ / ↓", "depth setpoint -/+ 0.1 m (Shift 1 m)"),
    ("← / →", "heading setpoint -/+ 1° (Shift 10°)"),
];

/// Handles the keys (the caller has checked that no text field has the keyboard).
pub(crate) fn keys(app: &mut StationApp, ui: &Ui) {
    let (ack, dim, bright, up, down, shift) = ui.input(|i| {
        (
            i.key_pressed(Key::K),
            i.key_pressed(Key::OpenBracket),
            i.key_pressed(Key::CloseBracket),
            i.key_pressed(Key::T),
            i.key_pressed(Key::G),
            i.modifiers.shift,
        )
    });
    let (sp_up, sp_down, sp_left, sp_right) = ui.input(|i| {
        (
            i.key_pressed(Key::ArrowUp),
            i.key_pressed(Key::ArrowDown),
            i.key_pressed(Key::ArrowLeft),
            i.key_pressed(Key::ArrowRight),
        )
    });
    if ack {
        app.live_cmd(RuntimeCommand::AckAlarm(None::<AlarmKind>));
    }
    let cam = app.live_view.camera;
    if dim || bright {
        let d = if bright {
            LIGHTS_STEP_PCT
        } else {
            -LIGHTS_STEP_PCT
        };
        let pct = (cam.lights_pct + d).clamp(0.0, 100.0);
        app.live_cmd(RuntimeCommand::Camera(CameraCommand::Lights(pct)));
    }
    if up || down {
        let d = if up { TILT_STEP_DEG } else { -TILT_STEP_DEG };
        let deg = (cam.tilt_deg + d).clamp(-90.0, 90.0);
        app.live_cmd(RuntimeCommand::Camera(CameraCommand::Tilt(deg)));
    }
    let depth_step = if shift {
        DEPTH_STEP_BIG_M
    } else {
        DEPTH_STEP_M
    };
    let heading_step = if shift {
        HEADING_STEP_BIG_DEG
    } else {
        HEADING_STEP_DEG
    };
    // Depth is positive down: ↑ makes the setpoint shallower.
    let mut mode = |m: ModeCommand| app.live_cmd(RuntimeCommand::Station(StationCommand::Mode(m)));
    if sp_up {
        mode(ModeCommand::StepDepth {
            delta_m: -depth_step,
        });
    }
    if sp_down {
        mode(ModeCommand::StepDepth {
            delta_m: depth_step,
        });
    }
    if sp_left {
        mode(ModeCommand::StepHeading {
            delta_deg: -heading_step,
        });
    }
    if sp_right {
        mode(ModeCommand::StepHeading {
            delta_deg: heading_step,
        });
    }
}

/// The live station's dive-log markers and notes, newest last.
pub(crate) fn log_lines(app: &StationApp) -> &[String] {
    &app.live_view.dive_log
}

/// Raises a toast when a new marker or note line appears, and paints the current one
/// for [`TOAST_S`] over the top of the picture, below the heading tape (not over it).
pub(crate) fn toast(app: &mut StationApp, ctx: &egui::Context) {
    let now = ctx.input(|i| i.time);
    let newest = log_lines(app).last().cloned();
    match &app.toast_seen {
        // The first frame of a connection: what is there already is not news.
        None => app.toast_seen = Some(newest),
        Some(seen) if *seen != newest => {
            if let Some(line) = &newest {
                app.toast = Some((line.clone(), now));
            }
            app.toast_seen = Some(newest);
        }
        Some(_) => {}
    }
    let Some((text, since)) = &app.toast else {
        return;
    };
    if now - since > TOAST_S {
        app.toast = None;
        return;
    }
    let text = format!("{TOAST_PREFIX}{text}");
    egui::Area::new(egui::Id::unique("toast"))
        .anchor(Align2::CENTER_TOP, vec2(0.0, 215.0))
        .interactable(false)
        .show(ctx, |ui| {
            egui::Frame::new()
                .fill(Color32::from_rgba_unmultiplied(20, 24, 30, 230))
                .stroke(egui::Stroke::new(1.0, theme::GREEN))
                .corner_radius(4.0)
                .inner_margin(8.0)
                .show(ui, |ui| {
                    ui.label(RichText::new(text).size(16.0).strong().color(theme::VALUE));
                });
        });
    ctx.request_repaint_after(std::time::Duration::from_millis(200));
}

/// Arming while not recording offers recording (as Cockpit does): a small window under
/// the alarm strip, over the picture (nothing moves), until the pilot answers, the
/// recording starts or the vehicle is disarmed.
pub(crate) fn record_offer(app: &mut StationApp, ctx: &egui::Context) {
    let armed = app.live_view.snapshot.armed;
    let recording = app.live_view.recording.path.is_some();
    if armed && !app.was_armed && !recording && app.live.is_some() {
        app.record_offer = true;
    }
    app.was_armed = armed;
    if !armed || recording {
        app.record_offer = false;
    }
    if !app.record_offer {
        return;
    }
    egui::Window::new("Armed: not recording")
        .id(egui::Id::unique("record_offer"))
        .collapsible(false)
        .resizable(false)
        .anchor(Align2::CENTER_TOP, vec2(0.0, 215.0))
        .show(ctx, |ui| {
            ui.label("This dive is not being recorded.");
            ui.horizontal(|ui| {
                if ui
                    .button(RichText::new("Record this dive").strong())
                    .clicked()
                {
                    let path = app.backend.recording_path();
                    app.live_cmd(RuntimeCommand::StartRecording(path));
                    app.record_offer = false;
                }
                if ui.button("Fly unrecorded").clicked() {
                    app.record_offer = false;
                }
            });
        });
}
