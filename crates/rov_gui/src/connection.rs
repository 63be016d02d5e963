//! The Connection tab: simulator or a serial port; the port list; autodetect by ping (in
//! the background); connect (only while disarmed); the camera's capture devices.

use std::sync::mpsc::Receiver;

use egui::{RichText, Ui};
use rov_station::runtime::Connection;

use crate::app::{AutodetectResult, StationApp};
use crate::theme;

/// State of the Connection tab.
#[derive(Debug, Default)]
pub struct ConnectionState {
    /// Serial (true) or simulator.
    pub serial: bool,
    /// The port path.
    pub port: String,
    /// Ports listed.
    pub ports: Vec<String>,
    /// Autodetect running.
    pub pending: Option<Receiver<AutodetectResult>>,
    /// Last autodetect result.
    pub result: Option<AutodetectResult>,
}

impl ConnectionState {
    pub(crate) fn poll(&mut self) {
        let Some(rx) = &self.pending else { return };
        let r = match rx.try_recv() {
            Ok(r) => r,
            Err(std::sync::mpsc::TryRecvError::Empty) => return,
            // The search ended without an answer (its thread panicked): say so rather
            // than spin forever.
            Err(std::sync::mpsc::TryRecvError::Disconnected) => crate::AutodetectResult {
                found: None,
                tried: vec![(
                    "autodetect".into(),
                    Some("the search stopped without an answer".into()),
                )],
            },
        };
        if let Some(p) = &r.found {
            self.port.clone_from(p);
            self.serial = true;
        }
        self.result = Some(r);
        self.pending = None;
    }
}

pub(crate) fn connection_tab(app: &mut StationApp, ui: &mut Ui) {
    ui.heading("Vehicle connection");
    let armed = app.live_view.snapshot.armed;
    ui.horizontal(|ui| {
        ui.radio_value(&mut app.conn.serial, false, "Simulated Pro 4");
        ui.radio_value(&mut app.conn.serial, true, "Serial port (115200 8N1)");
    });
    ui.horizontal(|ui| {
        ui.label("Port");
        ui.add(
            egui::TextEdit::singleline(&mut app.conn.port)
                .desired_width(260.0)
                .hint_text("/dev/ttyUSB0"),
        );
        if ui.button("Refresh list").clicked() {
            app.conn.ports = app.backend.ports();
        }
        let busy = app.conn.pending.is_some();
        if ui
            .add_enabled(!busy, egui::Button::new("Autodetect (ping)"))
            .clicked()
        {
            let ports = if app.conn.ports.is_empty() {
                app.backend.ports()
            } else {
                app.conn.ports.clone()
            };
            app.conn.ports.clone_from(&ports);
            app.conn.pending = Some(app.backend.autodetect(ports));
        }
        if busy {
            ui.spinner();
        }
    });
    if !app.conn.ports.is_empty() {
        ui.horizontal_wrapped(|ui| {
            ui.label("Ports:");
            for p in app.conn.ports.clone() {
                if ui.selectable_label(app.conn.port == p, &p).clicked() {
                    app.conn.port = p;
                    app.conn.serial = true;
                }
            }
        });
    }
    if let Some(r) = &app.conn.result {
        match &r.found {
            Some(p) => {
                ui.label(RichText::new(format!("Pro 4 answered on {p}")).color(theme::GREEN))
            }
            None => ui.label(RichText::new("no vehicle answered the ping").color(theme::AMBER)),
        };
        for (p, why) in &r.tried {
            ui.label(
                RichText::new(format!("  {p}: {}", why.as_deref().unwrap_or("answered")))
                    .small()
                    .color(theme::DIM),
            );
        }
    }
    ui.separator();
    ui.horizontal(|ui| {
        let label = if app.conn.serial {
            format!("Connect to {}", app.conn.port.trim())
        } else {
            "Connect to the simulator".into()
        };
        let ok = !armed && (!app.conn.serial || !app.conn.port.trim().is_empty());
        if ui.add_enabled(ok, egui::Button::new(label)).clicked() {
            let c = if app.conn.serial {
                Connection::Serial(app.conn.port.trim().to_string())
            } else {
                Connection::Sim
            };
            // Drop the old station first (its port is released).
            app.set_live(None);
            match app.backend.connect(&c) {
                Ok(h) => {
                    app.set_live(Some(h));
                    app.message = None;
                }
                Err(e) => app.message = Some(format!("cannot connect: {e}")),
            }
        }
        if armed {
            ui.label(RichText::new("disarm to change the connection").color(theme::AMBER));
        }
    });
    ui.label(format!("Now: {:?}", app.live_view.source));
    crate::video_settings::devices(app, ui);
}
