//! The Settings tab: units, the serial port and baud rate, the recordings folder and
//! recording on connection, the simulated link's fault rate, the alarm limits, the video
//! settings (see `video_settings`) and the live Foxglove server ([`crate::foxglove_live`]).
//! Apply sends the alarm limits to the live station; Save writes `[alarms]`, `[station]`
//! and `[foxglove]` into the station configuration
//! (`rov_station::runtime::settings::save`, which keeps the rest of the file).

use egui::{RichText, Ui, vec2};
use rov_station::runtime::settings::{BAUDS, DepthUnit, StationSettings, TempUnit};
use rov_station::runtime::{AlarmConfig, Limit, RuntimeCommand};

use crate::app::StationApp;
use crate::theme;

/// Feet per metre.
pub const FT_PER_M: f64 = 1.0 / 0.3048;

/// A depth in the chosen unit, with the unit.
#[must_use]
pub fn depth_text(depth_m: Option<f64>, unit: DepthUnit, digits: usize) -> String {
    match (depth_m, unit) {
        (None, DepthUnit::Metres) => "--- m".into(),
        (None, DepthUnit::Feet) => "--- ft".into(),
        (Some(d), DepthUnit::Metres) => format!("{d:.digits$} m"),
        (Some(d), DepthUnit::Feet) => format!("{:.digits$} ft", d * FT_PER_M),
    }
}

/// A temperature in the chosen unit, with the unit.
#[must_use]
pub fn temp_text(temp_c: Option<f64>, unit: TempUnit) -> String {
    match (temp_c, unit) {
        (None, _) => "---".into(),
        (Some(t), TempUnit::Celsius) => format!("{t:.1} °C"),
        (Some(t), TempUnit::Fahrenheit) => format!("{:.1} °F", t * 9.0 / 5.0 + 32.0),
    }
}

fn limit_row(ui: &mut Ui, name: &str, unit: &str, l: &mut Limit, max: f64, speed: f64) {
    let label = ui.label(name);
    ui.add(
        egui::DragValue::new(&mut l.warn)
            .range(0.0..=max)
            .speed(speed)
            .suffix(format!(" {unit}")),
    )
    .labelled_by(label.id);
    ui.add(
        egui::DragValue::new(&mut l.alarm)
            .range(0.0..=max)
            .speed(speed)
            .suffix(format!(" {unit}")),
    )
    .labelled_by(label.id);
    ui.end_row();
}

fn alarm_limits(ui: &mut Ui, a: &mut AlarmConfig) {
    egui::Grid::new("alarm_limits")
        .num_columns(3)
        .spacing(vec2(12.0, 4.0))
        .show(ui, |ui| {
            ui.label("");
            ui.label(RichText::new("warning").color(theme::AMBER));
            ui.label(RichText::new("alarm").color(theme::RED));
            ui.end_row();
            limit_row(ui, "Humidity", "%", &mut a.humidity_pct, 100.0, 0.5);
            limit_row(
                ui,
                "Humidity rise",
                "%/min",
                &mut a.humidity_rise_pct_per_min,
                100.0,
                0.1,
            );
            limit_row(ui, "Max depth", "m", &mut a.depth_m, 1000.0, 1.0);
            limit_row(ui, "Tether turns", "turns", &mut a.tether_turns, 100.0, 0.1);
            limit_row(ui, "Tether voltage (low)", "V", &mut a.tether_v, 400.0, 0.5);
            limit_row(ui, "12 V rail (low)", "V", &mut a.rail_12v_v, 30.0, 0.1);
            limit_row(
                ui,
                "Internal temp",
                "°C",
                &mut a.internal_temp_c,
                150.0,
                0.5,
            );
        });
}

/// Whether the warning level comes before the alarm level for every limit.
fn limits_ordered(a: &AlarmConfig) -> Option<&'static str> {
    let high = [
        (a.humidity_pct, "humidity"),
        (a.humidity_rise_pct_per_min, "humidity rise"),
        (a.depth_m, "max depth"),
        (a.tether_turns, "tether turns"),
        (a.internal_temp_c, "internal temp"),
    ];
    for (l, name) in high {
        if l.warn > l.alarm {
            return Some(name);
        }
    }
    for (l, name) in [(a.tether_v, "tether voltage"), (a.rail_12v_v, "12 V rail")] {
        if l.warn < l.alarm {
            return Some(name);
        }
    }
    None
}

pub(crate) fn settings_tab(app: &mut StationApp, ui: &mut Ui) {
    let armed = app.live_view.snapshot.armed;
    let target = app.config_target();
    crate::layout::scroll(app, ui, "settings_scroll", |app, ui| {
        let mut choose_folder = false;
        ui.columns(2, |cols| {
            let [left, right] = cols else { return };
            let s: &mut StationSettings = &mut app.station;
            left.label(RichText::new("Units").strong().color(theme::SCALE));
            left.horizontal(|ui| {
                ui.label("Depth");
                ui.radio_value(&mut s.depth_unit, DepthUnit::Metres, "m");
                ui.radio_value(&mut s.depth_unit, DepthUnit::Feet, "ft");
                ui.label("Temperature");
                ui.radio_value(&mut s.temp_unit, TempUnit::Celsius, "°C");
                ui.radio_value(&mut s.temp_unit, TempUnit::Fahrenheit, "°F");
            });
            left.separator();
            left.label(
                RichText::new("Vehicle connection")
                    .strong()
                    .color(theme::SCALE),
            );
            left.add_enabled_ui(!armed, |ui| {
                ui.horizontal(|ui| {
                    let l = ui.label("Serial port");
                    ui.add(
                        egui::TextEdit::singleline(&mut s.serial_port)
                            .hint_text("/dev/ttyUSB0 (empty: simulator)")
                            .desired_width(200.0),
                    )
                    .labelled_by(l.id);
                });
                ui.horizontal(|ui| {
                    egui::ComboBox::new("baud", "Baud")
                        .selected_text(s.baud.to_string())
                        .show_ui(ui, |ui| {
                            for b in BAUDS {
                                ui.selectable_value(&mut s.baud, b, b.to_string());
                            }
                        });
                    ui.label(
                        RichText::new("(the Pro 4 talks 115200)")
                            .small()
                            .color(theme::DIM),
                    );
                });
                ui.horizontal(|ui| {
                    let l = ui.label("Simulated link errors");
                    ui.add(
                        egui::DragValue::new(&mut s.sim_link_errors_pct)
                            .range(0.0..=50.0)
                            .speed(0.1)
                            .suffix(" %"),
                    )
                    .labelled_by(l.id);
                });
            });
            left.separator();
            left.label(RichText::new("Recordings").strong().color(theme::SCALE));
            left.horizontal(|ui| {
                let l = ui.label("Folder");
                let mut dir = s.recordings_dir.display().to_string();
                if ui
                    .add(egui::TextEdit::singleline(&mut dir).desired_width(220.0))
                    .labelled_by(l.id)
                    .changed()
                {
                    s.recordings_dir = dir.into();
                }
                choose_folder = ui.button("Choose…").clicked();
            });
            left.checkbox(&mut s.record_on_connect, "Record every new connection");
            left.separator();
            crate::video_settings::video_section(
                left,
                &mut app.video_settings,
                &target,
                &mut app.message,
            );

            // The right column holds the alarm limits and the live server, so the whole
            // tab fits a 1024×600 window without scrolling.
            right.label(RichText::new("Alarm limits").strong().color(theme::SCALE));
            alarm_limits(right, &mut app.alarm_limits);
            let bad = limits_ordered(&app.alarm_limits);
            if let Some(name) = bad {
                right.label(
                    RichText::new(format!("{name}: the warning must come before the alarm"))
                        .color(theme::AMBER),
                );
            }
            right.horizontal(|ui| {
                if ui
                    .add_enabled(bad.is_none(), egui::Button::new("Apply"))
                    .clicked()
                {
                    app.record_on_connect = app.station.record_on_connect;
                    let c = app.alarm_limits;
                    app.live_cmd(RuntimeCommand::AlarmLimits(c));
                    app.message = Some("alarm limits applied to this dive".into());
                }
                let target = app.config_target();
                if ui
                    .add_enabled(
                        bad.is_none(),
                        egui::Button::new(format!("Save to {}", target.display())),
                    )
                    .clicked()
                {
                    app.record_on_connect = app.station.record_on_connect;
                    let c = app.alarm_limits;
                    app.live_cmd(RuntimeCommand::AlarmLimits(c));
                    app.message = Some(
                        match rov_station::runtime::settings::save(&target, &c, &app.station)
                            .and_then(|()| {
                                rov_station::runtime::settings::save_foxglove(
                                    &target,
                                    &app.foxglove.settings,
                                )
                            }) {
                            Ok(()) => format!("settings saved to {}", target.display()),
                            Err(e) => format!("cannot save: {e}"),
                        },
                    );
                }
            });
            right.separator();
            crate::foxglove_live::section(app, right);
            right.separator();
            crate::watch_page::section(app, right);
        });
        if choose_folder && let Some(d) = app.backend.pick_folder("Recordings folder") {
            app.station.recordings_dir = d;
        }
    });
}
