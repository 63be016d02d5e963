//! The model watch on the Settings tab (issue 23): what the watch says (running,
//! learning, its alerts in words), and, with the built-in simulated vehicle, faults to
//! inject for training. The GUI only renders the view and sends
//! [`RuntimeCommand::InjectFault`]; the spec goes through the one `--fault` grammar
//! ([`FaultSpec::parse`]).

use egui::{RichText, Ui};
use rov_station::runtime::{FaultSpec, RuntimeCommand, Source};

use crate::app::StationApp;
use crate::theme;

/// The fault kinds the form offers, with their size's unit and default (the issue's
/// sizes).
const KINDS: [(&str, &str, f64); 6] = [
    ("thrust-loss", "fraction lost", 0.4),
    ("buoyancy", "N heavier", 3.0),
    ("drag", "× drag", 2.5),
    ("snag", "N pull", 15.0),
    ("depth-sensor", "m jump (0: stuck)", 0.0),
    ("compass", "° off", 25.0),
];

const THRUSTERS: [&str; 3] = ["port", "starboard", "vertical"];

/// "Open in lab" takes this much of the recording before an alert, s.
const OPEN_BEFORE_S: f64 = 120.0;
/// ... and this much after it (or to the end of the recording so far), s.
const OPEN_AFTER_S: f64 = 60.0;

/// The fault form's state.
#[derive(Debug, Clone, PartialEq)]
pub struct FaultForm {
    kind: usize,
    thruster: usize,
    size: f64,
}

impl Default for FaultForm {
    fn default() -> Self {
        Self {
            kind: 0,
            thruster: 0,
            size: KINDS[0].2,
        }
    }
}

impl FaultForm {
    /// The `--fault` spec of the form, starting at once.
    #[must_use]
    pub fn spec(&self) -> String {
        let (kind, _, _) = KINDS.get(self.kind).copied().unwrap_or(KINDS[0]);
        match kind {
            "thrust-loss" => format!(
                "thrust-loss:{}:{}@0",
                THRUSTERS.get(self.thruster).copied().unwrap_or("port"),
                self.size
            ),
            "depth-sensor" if self.size == 0.0 => "depth-sensor:stuck@0".into(),
            "depth-sensor" => format!("depth-sensor:jump:{}@0", self.size),
            k => format!("{k}:{}@0", self.size),
        }
    }
}

/// The section (right column of the Settings tab): one line saying what the watch
/// says, opening onto its alerts and the fault form (closed by default, so the tab still
/// fits a 1024×600 window).
pub(crate) fn section(app: &mut StationApp, ui: &mut Ui) {
    let w = app.live_view.watch.clone();
    let changes = w.alerts.iter().filter(|a| a.kind == "change").count();
    let state = match (&w.off_reason, w.running) {
        (Some(r), _) => format!("off ({r})"),
        (None, true) if changes > 0 => format!("{changes} change(s)"),
        (None, true) => "watching".into(),
        (None, false) => "waiting for readings".into(),
    };
    egui::CollapsingHeader::new(
        RichText::new(format!("Model watch: {state}"))
            .strong()
            .color(theme::SCALE),
    )
    .id_salt("model_watch")
    .default_open(false)
    .show(ui, |ui| body(app, ui, &w));
}

fn body(app: &mut StationApp, ui: &mut Ui, w: &rov_station::runtime::view::WatchView) {
    ui.label(
        RichText::new(format!(
            "{} readings compared with the model{}",
            w.rows,
            if w.dropped_rows > 0 {
                format!(", {} dropped (the watch fell behind)", w.dropped_rows)
            } else {
                String::new()
            }
        ))
        .color(theme::DIM),
    );
    if w.alerts.is_empty() {
        ui.label("The vehicle behaves like its model.");
    }
    // The recording's start on the station's clock: an alert's window in the session.
    let rec = &app.live_view.recording;
    let rec_start_s = rec
        .path
        .as_ref()
        .map(|p| (p.clone(), app.live_view.snapshot.time_s - rec.elapsed_s));
    for (k, a) in w.alerts.iter().rev().take(4).enumerate() {
        let (tag, color) = if a.kind == "change" {
            ("CHANGE", theme::AMBER)
        } else {
            ("MISMATCH", theme::DIM)
        };
        ui.horizontal(|ui| {
            ui.label(
                RichText::new(format!(
                    "{tag} {} T+{:.0} s: {} ({:.1} noise floors)",
                    a.channel, a.since_s, a.words, a.size_noise
                ))
                .color(color),
            );
            // Two minutes before the alert and one after, from the recording so far.
            if let Some((path, start_s)) = &rec_start_s {
                let from_s = (a.since_s - start_s - OPEN_BEFORE_S).max(0.0);
                let to_s = a.since_s - start_s + OPEN_AFTER_S;
                if to_s > 0.0
                    && ui
                        .button("Open in lab")
                        .on_hover_text(format!(
                            "the recording from {from_s:.0} s to {to_s:.0} s into the Model lab tab"
                        ))
                        .clicked()
                {
                    app.lab.path = path.display().to_string();
                    app.lab.start_load_window(path, Some((from_s, to_s)));
                    app.tab = crate::app::Tab::Lab;
                    app.message = Some(format!("alert {} opened in the lab", k + 1));
                }
            }
        });
    }
    if app.live_view.source != Source::Sim {
        return;
    }
    ui.add_space(4.0);
    ui.label(RichText::new("Simulated faults (training)").strong());
    let f = &mut app.fault_form;
    ui.horizontal(|ui| {
        let before = f.kind;
        egui::ComboBox::new("fault_kind", "Fault")
            .selected_text(KINDS.get(f.kind).map_or("", |k| k.0))
            .show_ui(ui, |ui| {
                for (i, k) in KINDS.iter().enumerate() {
                    ui.selectable_value(&mut f.kind, i, k.0);
                }
            });
        if f.kind != before {
            f.size = KINDS.get(f.kind).map_or(0.0, |k| k.2);
        }
        if f.kind == 0 {
            egui::ComboBox::new("fault_thruster", "Thruster")
                .selected_text(THRUSTERS.get(f.thruster).copied().unwrap_or(""))
                .show_ui(ui, |ui| {
                    for (i, t) in THRUSTERS.iter().enumerate() {
                        ui.selectable_value(&mut f.thruster, i, *t);
                    }
                });
        }
        let unit = KINDS.get(f.kind).map_or("", |k| k.1);
        let l = ui.label("size");
        ui.add(
            egui::DragValue::new(&mut f.size)
                .speed(0.05)
                .range(-100.0..=100.0),
        )
        .labelled_by(l.id);
        ui.label(unit);
    });
    let spec = f.spec();
    match FaultSpec::parse(&spec) {
        Ok(parsed) => {
            if ui.button(format!("Inject now ({spec})")).clicked() {
                app.live_cmd(RuntimeCommand::InjectFault(parsed));
                app.message = Some(format!("fault injected: {spec}"));
            }
        }
        Err(e) => {
            ui.label(RichText::new(e.to_string()).color(theme::AMBER));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_form_choice_is_a_spec_the_fault_grammar_takes() {
        for (kind, k) in KINDS.iter().enumerate() {
            for thruster in 0..THRUSTERS.len() {
                let f = FaultForm {
                    kind,
                    thruster,
                    size: k.2,
                };
                let spec = f.spec();
                let parsed = FaultSpec::parse(&spec).unwrap_or_else(|e| panic!("{spec}: {e}"));
                assert_eq!(parsed.start_s, 0.0, "{spec}");
            }
        }
        let jump = FaultForm {
            kind: 4,
            thruster: 0,
            size: 0.5,
        };
        assert_eq!(jump.spec(), "depth-sensor:jump:0.5@0");
    }
}
