//! Colours and text sizes: dark background, high-contrast instruments, setpoints green,
//! measurements white, predictions violet, alarms red, warnings amber.

use egui::{Color32, FontId};

use rov_station::runtime::Quality;

/// Instrument background.
pub const BG: Color32 = Color32::from_rgb(18, 22, 28);
/// Instrument frame.
pub const FRAME: Color32 = Color32::from_rgb(70, 78, 90);
/// Scale ticks and labels.
pub const SCALE: Color32 = Color32::from_rgb(200, 205, 212);
/// Measured values.
pub const VALUE: Color32 = Color32::WHITE;
/// Setpoints (as in the Greensea UI: setpoints green).
pub const SETPOINT: Color32 = Color32::from_rgb(60, 220, 90);
/// Observer estimates.
pub const ESTIMATE: Color32 = Color32::from_rgb(90, 170, 255);
/// Model prediction.
pub const PREDICTION: Color32 = Color32::from_rgb(200, 120, 255);
/// Thrust.
pub const THRUST: Color32 = Color32::from_rgb(255, 170, 40);
/// Vertical-speed trend.
pub const TREND: Color32 = Color32::from_rgb(0, 210, 220);
/// OK.
pub const GREEN: Color32 = Color32::from_rgb(40, 180, 70);
/// Watch.
pub const AMBER: Color32 = Color32::from_rgb(240, 170, 20);
/// Alarm.
pub const RED: Color32 = Color32::from_rgb(220, 40, 40);
/// Sky of the horizon.
pub const SKY: Color32 = Color32::from_rgb(40, 110, 190);
/// Ground of the horizon.
pub const GROUND: Color32 = Color32::from_rgb(120, 80, 40);
/// Replay badge.
pub const REPLAY: Color32 = Color32::from_rgb(250, 210, 40);
/// Dim text.
pub const DIM: Color32 = Color32::from_rgb(140, 146, 156);

/// Colour of a link quality.
#[must_use]
pub fn quality(q: Quality) -> Color32 {
    match q {
        Quality::Green => GREEN,
        Quality::Amber => AMBER,
        Quality::Red => RED,
    }
}

/// Big numerals on instruments.
#[must_use]
pub fn big() -> FontId {
    FontId::monospace(22.0)
}

/// Medium instrument labels.
#[must_use]
pub fn mid() -> FontId {
    FontId::monospace(15.0)
}

/// Small scale labels.
#[must_use]
pub fn small() -> FontId {
    FontId::monospace(12.0)
}

/// Applies the station's visuals to a context (dark, larger text).
pub fn apply(ctx: &egui::Context) {
    ctx.set_visuals(egui::Visuals::dark());
    ctx.all_styles_mut(|style| {
        use egui::{FontFamily, TextStyle};
        style.text_styles = [
            (
                TextStyle::Heading,
                FontId::new(20.0, FontFamily::Proportional),
            ),
            (TextStyle::Body, FontId::new(14.5, FontFamily::Proportional)),
            (
                TextStyle::Monospace,
                FontId::new(14.0, FontFamily::Monospace),
            ),
            (
                TextStyle::Button,
                FontId::new(14.5, FontFamily::Proportional),
            ),
            (
                TextStyle::Small,
                FontId::new(11.0, FontFamily::Proportional),
            ),
        ]
        .into();
        style.spacing.item_spacing = egui::vec2(6.0, 5.0);
        style.spacing.button_padding = egui::vec2(8.0, 4.0);
    });
}
