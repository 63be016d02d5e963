//! Replay: the Replay tab opens a session; while a replay is open, a bar at the bottom of
//! every tab has play/pause, step, speed and the seek bar, and the top bar shows the
//! REPLAY badge. The instruments and plots show the replay; arming and the alarm bar
//! stay on the live station.

use egui::{RichText, Ui, vec2};
use rov_station::runtime::ReplayCommand;

use crate::app::StationApp;
use crate::theme;

/// Speeds offered.
pub const SPEEDS: [f64; 7] = [0.1, 0.25, 0.5, 1.0, 2.0, 5.0, 10.0];

fn mmss(t: f64) -> String {
    let s = t.max(0.0);
    // Hundredths: a 20 ms control tick (Step) always changes the reading.
    format!("{:02}:{:05.2}", (s / 60.0).floor() as u64, s % 60.0)
}

pub(crate) fn replay_bar(app: &mut StationApp, ui: &mut Ui) {
    let Some(r) = app.replay_view.replay.clone() else {
        return;
    };
    egui::Panel::bottom("replay_bar")
        .frame(
            egui::Frame::new()
                .fill(egui::Color32::from_rgb(48, 42, 12))
                .inner_margin(6.0),
        )
        .show(ui, |ui| {
            ui.horizontal(|ui| {
                ui.label(RichText::new("REPLAY").strong().color(theme::REPLAY));
                let play = if r.playing { "Pause" } else { "Play" };
                if ui
                    .add(egui::Button::new(play).min_size(vec2(80.0, 24.0)))
                    .clicked()
                {
                    app.replay_cmd(ReplayCommand::Toggle);
                }
                if ui
                    .button("Step back")
                    .on_hover_text("one control tick back (,)")
                    .clicked()
                {
                    app.replay_cmd(ReplayCommand::StepBack);
                }
                if ui
                    .button("Step")
                    .on_hover_text("one control tick forward (.)")
                    .clicked()
                {
                    app.replay_cmd(ReplayCommand::Step);
                }
                let mut speed = r.speed;
                egui::ComboBox::new("replay_speed", "speed")
                    .selected_text(format!("{speed}×"))
                    .width(70.0)
                    .show_ui(ui, |ui| {
                        for s in SPEEDS {
                            ui.selectable_value(&mut speed, s, format!("{s}×"));
                        }
                    });
                if (speed - r.speed).abs() > 1e-9 {
                    app.replay_cmd(ReplayCommand::Speed(speed));
                }
                ui.label(
                    RichText::new(format!("{} / {}", mmss(r.position_s), mmss(r.duration_s)))
                        .monospace(),
                );
                let mut pos = r.position_s;
                let w = (ui.available_width() - 170.0).max(100.0);
                ui.spacing_mut().slider_width = w;
                let resp = ui.add(
                    egui::Slider::new(&mut pos, 0.0..=r.duration_s.max(0.001))
                        .show_value(false)
                        .trailing_fill(true)
                        .text("seek"),
                );
                if resp.changed() {
                    app.replay_cmd(ReplayCommand::Seek(pos));
                }
                if ui.button("Back to live").clicked() {
                    app.close_replay();
                }
            });
        });
}

pub(crate) fn replay_tab(app: &mut StationApp, ui: &mut Ui) {
    ui.heading("Replay a session");
    ui.label(
        RichText::new(
            "Opens an MCAP session (a truncated recording too) and plays it through the same \
             view as the live station. Arming and alarms stay on the live vehicle.",
        )
        .color(theme::DIM),
    );
    ui.horizontal(|ui| {
        let l = ui.label("File");
        ui.add(
            egui::TextEdit::singleline(&mut app.replay_path)
                .desired_width(520.0)
                .hint_text("path/to/session.mcap"),
        )
        .labelled_by(l.id);
        if ui.button("Browse…").clicked()
            && let Some(p) = app.backend.pick_file("Open a session", &["mcap"])
        {
            app.replay_path = p.display().to_string();
            app.open_replay(&p);
        }
        if ui.button("Open").clicked() {
            let p = app.replay_path.clone();
            app.open_replay_text(&p);
        }
        if app.replay.is_some() && ui.button("Close replay").clicked() {
            app.close_replay();
        }
    });
    let last = app
        .live_view
        .recording
        .last_file
        .clone()
        .or_else(|| app.last_recording().cloned());
    if let Some(last) = last
        && ui
            .button(format!(
                "Open the last recording ({})",
                last.file_name()
                    .map_or_else(String::new, |n| n.to_string_lossy().into_owned())
            ))
            .clicked()
    {
        app.replay_path = last.display().to_string();
        app.open_replay(&last);
    }
    if app.replay.is_none() {
        ui.separator();
        session_list(app, ui);
        return;
    }
    if let Some(r) = app
        .replay_view
        .replay
        .clone()
        .filter(|_| app.replay.is_some())
    {
        ui.separator();
        egui::Grid::new("replay_info")
            .num_columns(2)
            .show(ui, |ui| {
                ui.label("File");
                let name = match &app.replay_view.source {
                    rov_station::runtime::Source::Replay(p) => p
                        .file_name()
                        .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
                    other => format!("{other:?}"),
                };
                ui.label(name);
                ui.end_row();
                ui.label("Duration");
                ui.label(format!("{:.2} s", r.duration_s));
                ui.end_row();
                ui.label("Messages");
                ui.label(format!("{}", r.messages));
                ui.end_row();
            });
        for w in &r.warnings {
            ui.label(RichText::new(format!("warning: {w}")).color(theme::AMBER));
        }
        ui.separator();
        // The session's camera beside its events, and the session list under them: the
        // browser stays reachable while a replay is open (issue 25 item 12).
        let video = crate::video::shown_video(app);
        let avail = ui.available_size();
        let right_w = if video.is_some() {
            (avail.x * 0.45).clamp(240.0, 640.0)
        } else {
            0.0
        };
        ui.horizontal_top(|ui| {
            ui.vertical(|ui| {
                ui.set_width((avail.x - right_w - 12.0).max(200.0));
                ui.set_max_height(avail.y * 0.55);
                events_index(app, ui, &r);
            });
            if let Some(video) = video {
                ui.vertical(|ui| {
                    let h = right_w * 9.0 / 16.0;
                    let (rect, _) = ui.allocate_exact_size(vec2(right_w, h), egui::Sense::hover());
                    let status = video.status();
                    app.video_pane.paint(ui, rect, &video, &status);
                });
            }
        });
        ui.separator();
        egui::CollapsingHeader::new("Sessions in the recordings folder")
            .default_open(true)
            .show(ui, |ui| session_list(app, ui));
    }
}

/// Every event of the session, clickable: a click moves the play head there.
fn events_index(app: &mut StationApp, ui: &mut Ui, r: &rov_station::runtime::ReplayView) {
    ui.label(RichText::new(format!("Events ({}): click to jump", r.index.len())).strong());
    let mut seek = None;
    let now = r.position_s;
    let current = r.index.iter().rposition(|e| e.t_s <= now + 1e-6);
    egui::ScrollArea::vertical()
        .id_salt("replay_events")
        .auto_shrink([false, true])
        .show(ui, |ui| {
            for (i, e) in r.index.iter().enumerate() {
                let color = match e.severity {
                    rov_session::Severity::Alarm => theme::RED,
                    rov_session::Severity::Warning => theme::AMBER,
                    rov_session::Severity::Info => theme::SCALE,
                };
                let text = RichText::new(format!("{}  {:<10} {}", mmss(e.t_s), e.kind, e.text))
                    .monospace()
                    .small()
                    .color(color);
                if ui.selectable_label(current == Some(i), text).clicked() {
                    seek = Some(e.t_s);
                }
            }
        });
    if let Some(t) = seek {
        app.replay_cmd(ReplayCommand::Seek(t));
    }
}

/// The recordings folder as a list; see [`crate::sessions`].
fn session_list(app: &mut StationApp, ui: &mut Ui) {
    let dir = app.backend.recordings_dir();
    let known = app.recordings().len();
    if (app.browser.dir != dir || app.browser_seen != known) && !app.browser.busy() {
        app.browser_seen = known;
        app.browser.refresh(&dir);
    }
    // The button comes first so that it stays in place whatever the folder's length.
    ui.horizontal(|ui| {
        if ui.button("Refresh").clicked() {
            app.browser.refresh(&dir);
        }
        if ui
            .add_enabled(!app.browser.importing(), egui::Button::new("Import a log…"))
            .on_hover_text(
                "Another vehicle's log as a session in this folder: pick the log, then its \
                 log map (cancel for a measurement CSV)",
            )
            .clicked()
            && let Some(log) = app.backend.pick_file(
                "Import a log (DataFlash .BIN, tlog, ROS bag, MCAP, CSV)",
                &["bin", "BIN", "tlog", "bag", "mcap", "csv", "tsv", "txt"],
            )
        {
            let map = app
                .backend
                .pick_file("Its log map (cancel: none)", &["toml"]);
            app.browser.start_import(log, map, &dir);
        }
        if app.browser.importing() {
            ui.spinner();
            ui.label(RichText::new("importing…").color(theme::AMBER));
        }
        if app.browser.busy() {
            ui.spinner();
        }
        ui.label(RichText::new(format!("Recordings in {}", dir.display())).strong());
    });
    if let Some(e) = &app.browser.error {
        ui.label(RichText::new(e).color(theme::AMBER));
    }
    // The import's line is always there (empty before any), so that the list does not
    // move under the pointer when an import ends.
    let (color, note) = match &app.browser.import_note {
        Some((true, n)) => (theme::DIM, n.as_str()),
        Some((false, n)) => (theme::AMBER, n.as_str()),
        None => (theme::DIM, " "),
    };
    ui.label(RichText::new(note).small().color(color));
    let entries = app.browser.entries.clone();
    if entries.is_empty() && !app.browser.busy() {
        ui.label(RichText::new("no recordings yet").color(theme::DIM));
        return;
    }
    let mut action: Option<(usize, u8)> = None;
    egui::ScrollArea::vertical()
        .id_salt("session_list")
        .auto_shrink([false, true])
        .show(ui, |ui| {
            egui::Grid::new("sessions")
                .num_columns(7)
                .striped(true)
                .spacing(vec2(12.0, 4.0))
                .show(ui, |ui| {
                    for h in [
                        "date (UTC)",
                        "duration",
                        "size",
                        "vehicle",
                        "notes",
                        "file",
                        "",
                    ] {
                        ui.label(RichText::new(h).small().color(theme::DIM));
                    }
                    ui.end_row();
                    for (i, s) in entries.iter().enumerate() {
                        ui.label(crate::sessions::utc_text(s.started_unix_s));
                        ui.label(mmss(s.duration_s));
                        ui.label(format!("{:.1} MB", s.size_bytes as f64 / 1e6));
                        ui.label(&s.vehicle);
                        let notes = match (s.notes.first(), s.notes.len(), s.markers) {
                            (Some(n), k, m) => format!("{n}{}", extra(k, m)),
                            (None, _, 0) => String::new(),
                            (None, _, m) => format!("{m} markers"),
                        };
                        ui.label(RichText::new(notes).small());
                        let name = s
                            .path
                            .file_name()
                            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
                        let state = match (&s.error, s.complete) {
                            (Some(e), _) => format!("{name} (unreadable: {e})"),
                            (None, false) => format!("{name} (truncated)"),
                            (None, true) => name,
                        };
                        ui.label(RichText::new(state).small().monospace());
                        ui.horizontal(|ui| {
                            if ui.button("Replay").clicked() {
                                action = Some((i, 0));
                            }
                            if ui.button("Export CSV").clicked() {
                                action = Some((i, 1));
                            }
                            if ui.button("To lab").clicked() {
                                action = Some((i, 2));
                            }
                        });
                        ui.end_row();
                    }
                });
        });
    let Some((i, what)) = action else { return };
    let Some(s) = entries.get(i) else { return };
    match what {
        0 => {
            app.replay_path = s.path.display().to_string();
            let p = s.path.clone();
            app.open_replay(&p);
        }
        1 => {
            let default = s.path.with_extension("csv");
            let name = default.file_name().map_or_else(
                || "session.csv".into(),
                |n| n.to_string_lossy().into_owned(),
            );
            // Without a dialog (none on this desktop, or cancelled) the CSV goes next
            // to the session.
            let out = app
                .backend
                .save_file("Export the session as CSV", &name)
                .unwrap_or(default);
            app.message = Some(
                crate::sessions::export_csv(&s.path, &out)
                    .unwrap_or_else(|e| format!("cannot export: {e}")),
            );
        }
        _ => {
            app.lab.path = s.path.display().to_string();
            app.lab.start_load(&s.path);
            app.tab = crate::app::Tab::Lab;
        }
    }
}

fn extra(notes: usize, markers: usize) -> String {
    let mut s = String::new();
    if notes > 1 {
        s.push_str(&format!(" (+{} notes)", notes - 1));
    }
    if markers > 0 {
        s.push_str(&format!(", {markers} markers"));
    }
    s
}
