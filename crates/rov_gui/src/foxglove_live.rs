//! The Settings tab's "Foxglove live" section: the live Foxglove server's address, on/off,
//! and the clients connected. The server (`rov_station::runtime::foxglove_live`) belongs
//! to the app, not to a station: it survives re-connections, and every new live station
//! gets a tap on it. Save writes `[foxglove]` with the other settings.

use egui::{RichText, Ui};
use rov_station::runtime::foxglove_live::{ConfiguredLiveError, LiveServer, LiveStatus};
use rov_station::runtime::settings::FoxgloveSettings;
use rov_station::runtime::{RuntimeCommand, StationHandle};

use crate::app::StationApp;
use crate::theme;

/// The live server and its settings.
#[derive(Debug, Default)]
pub(crate) struct FoxgloveState {
    /// `[foxglove]` as edited.
    pub settings: FoxgloveSettings,
    /// The running server.
    pub server: Option<LiveServer>,
    /// Why the last start failed.
    pub error: Option<String>,
}

impl FoxgloveState {
    /// Starts serving on the configured address (the error is kept for the section).
    pub fn start(&mut self) {
        self.server = None;
        match LiveServer::start(&self.settings.ws) {
            Ok(s) => {
                self.server = Some(s);
                self.error = None;
            }
            Err(e) => self.error = Some(e.to_string()),
        }
    }

    /// Gives a live station a tap on the server (or tells it to stop serving).
    pub fn attach(&self, h: &StationHandle) {
        let tap = self.server.as_ref().and_then(|s| s.tap(h.now_us()));
        h.command(RuntimeCommand::FoxgloveLive(tap));
    }

    /// The server's status, while it runs.
    pub fn status(&self) -> Option<LiveStatus> {
        self.server.as_ref().map(LiveServer::status)
    }
}

/// The section, in the Settings tab's left column.
pub(crate) fn section(app: &mut StationApp, ui: &mut Ui) {
    ui.label(RichText::new("Foxglove live").strong().color(theme::SCALE));
    let mut serving = app.foxglove.server.is_some();
    ui.horizontal(|ui| {
        let l = ui.label("Address");
        ui.add_enabled(
            !serving,
            egui::TextEdit::singleline(&mut app.foxglove.settings.ws)
                .hint_text("127.0.0.1:8765")
                .desired_width(160.0),
        )
        .labelled_by(l.id);
        if ui.checkbox(&mut serving, "Serve").changed() {
            if serving {
                app.foxglove.start();
            } else {
                app.foxglove.server = None;
            }
            app.foxglove.settings.enabled = app.foxglove.server.is_some();
            if let Some(h) = &app.live {
                app.foxglove.attach(h);
            }
        }
    });
    match (app.foxglove.status(), &app.foxglove.error) {
        (Some(st), _) => {
            ui.label(
                RichText::new(format!(
                    "serving {} · {} client{} connected",
                    st.url(),
                    st.clients,
                    if st.clients == 1 { "" } else { "s" }
                ))
                .color(theme::GREEN),
            );
            ui.label(
                RichText::new(format!(
                    "{} messages sent, {} records dropped · in Foxglove: Open connection > Foxglove WebSocket > {}",
                    st.sent,
                    st.dropped,
                    st.url()
                ))
                .small()
                .color(theme::DIM),
            );
        }
        (None, Some(e)) => {
            ui.label(RichText::new(e.as_str()).color(theme::AMBER));
        }
        (None, None) => {
            ui.label(
                RichText::new("off: serves the station's channels to Foxglove while flying")
                    .small()
                    .color(theme::DIM),
            );
        }
    }
}

impl StationApp {
    /// The live Foxglove server's settings and the server started for them, or why it
    /// did not start (shown in the Settings tab).
    #[must_use]
    pub fn with_foxglove(
        mut self,
        settings: FoxgloveSettings,
        server: Result<Option<LiveServer>, ConfiguredLiveError>,
    ) -> Self {
        self.set_foxglove(settings, server);
        self
    }

    /// [`StationApp::with_foxglove`] on a running app (a server running before is
    /// stopped; the live station is given a tap on the new one).
    pub fn set_foxglove(
        &mut self,
        settings: FoxgloveSettings,
        server: Result<Option<LiveServer>, ConfiguredLiveError>,
    ) {
        self.foxglove.settings = settings;
        self.foxglove.server = None;
        match server {
            Ok(s) => {
                self.foxglove.server = s;
                self.foxglove.error = None;
            }
            Err(e) => self.foxglove.error = Some(e.to_string()),
        }
        if let Some(h) = &self.live {
            self.foxglove.attach(h);
        }
    }

    /// The live Foxglove server's status, while it runs.
    #[must_use]
    pub fn foxglove_status(&self) -> Option<LiveStatus> {
        self.foxglove.status()
    }

    /// Why the live Foxglove server did not start, if it did not.
    #[must_use]
    pub fn foxglove_error(&self) -> Option<&str> {
        self.foxglove.error.as_deref()
    }
}
