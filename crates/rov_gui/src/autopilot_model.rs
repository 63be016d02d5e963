//! Choosing the autopilot's model from the GUI: the models folder (the `*.toml` model
//! files next to the user's station settings, scanned when the folder is set and on
//! Rescan, never per frame), loading a file or the lab's model into an autopilot plant,
//! sending [`RuntimeCommand::AutopilotModel`], the hold-to-confirm while armed, and what
//! the station answered (accepted / refused and why, read from its event list).

use std::path::{Path, PathBuf};

use rov_station::AutopilotModel;

use crate::FileError;
use rov_station::runtime::{RuntimeCommand, StationView};

/// How long the confirm button must be held while armed, s (as long as hold-to-arm).
pub const CONFIRM_HOLD_S: f64 = 1.0;

/// The model files found in the models folder.
#[derive(Debug, Clone, Default)]
pub struct ModelsFolder {
    /// The folder (`None`: no folder; the list offers the shipped models only).
    pub dir: Option<PathBuf>,
    /// `*.toml` files in it, sorted by name.
    pub files: Vec<PathBuf>,
    /// Why the last scan failed (a missing folder is not an error: it is empty).
    pub error: Option<String>,
}

impl ModelsFolder {
    /// Scans `dir` now (at start or on the pilot's Rescan).
    #[must_use]
    pub fn scan(dir: Option<PathBuf>) -> Self {
        let mut f = Self {
            dir,
            ..Self::default()
        };
        f.rescan();
        f
    }

    /// Lists the folder's `*.toml` files again.
    pub fn rescan(&mut self) {
        self.files.clear();
        self.error = None;
        let Some(dir) = &self.dir else { return };
        match std::fs::read_dir(dir) {
            Ok(rd) => {
                self.files = rd
                    .filter_map(Result::ok)
                    .map(|e| e.path())
                    .filter(|p| p.is_file() && p.extension().is_some_and(|x| x == "toml"))
                    .collect();
                self.files.sort();
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => self.error = Some(format!("{}: {e}", dir.display())),
        }
    }
}

/// A model file as the autopilot's plant (the lab's loader: errors name the file, key,
/// value and allowed range).
///
/// # Errors
/// The file cannot be read, is not a model, or has no valid heave/yaw plant.
pub fn load_file(path: &Path) -> Result<AutopilotModel, FileError> {
    let model = read_model_file(path)?;
    Ok(AutopilotModel::from_vehicle_model(
        &path.display().to_string(),
        &model,
    )?)
}

/// A model file (a vehicle definition, a base-model file or a saved extended model)
/// through the lab's one loader, as every `--model FILE.toml` reads it.
///
/// # Errors
/// The file cannot be read or is not a model (the error names file, key, value).
pub fn read_model_file(path: &Path) -> Result<rov_lab::LabModel, FileError> {
    let text = std::fs::read_to_string(path).map_err(|source| FileError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let id = rov_types::ModelId::File(path.to_path_buf());
    Ok(rov_lab::load_model(&id, Some(&text))?)
}

/// The station's answer to the last model change.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SwitchResult {
    /// Sent, no answer yet.
    Waiting(String),
    /// The autopilot uses the model (the station's event text).
    Accepted(String),
    /// Refused, with the station's reason (or the loader's error).
    Refused(String),
}

/// A model change in flight and its answer.
#[derive(Debug, Default)]
pub struct ModelSwitch {
    /// The newest event line when the command was sent (answers come after it).
    after: Option<Option<String>>,
    /// The last answer.
    pub result: Option<SwitchResult>,
    /// Seconds the confirm button has been held.
    pub confirm_held_s: f64,
}

impl ModelSwitch {
    /// Sends the command (or records why nothing could be sent).
    pub fn send(
        &mut self,
        app_cmd: impl FnOnce(RuntimeCommand),
        view: &StationView,
        model: Result<AutopilotModel, FileError>,
        confirmed: bool,
    ) {
        match model {
            Ok(m) => {
                self.after = Some(view.events.last().cloned());
                self.result = Some(SwitchResult::Waiting(m.label.clone()));
                app_cmd(RuntimeCommand::AutopilotModel {
                    model: Some(Box::new(m)),
                    confirmed,
                });
            }
            Err(e) => {
                self.after = None;
                self.result = Some(SwitchResult::Refused(e.to_string()));
            }
        }
    }

    /// Picks the station's answer out of the events that came after the command.
    pub fn poll(&mut self, view: &StationView) {
        let Some(after) = &self.after else { return };
        let start = after
            .as_ref()
            .and_then(|a| view.events.iter().rposition(|e| e == a))
            .map_or(0, |i| i + 1);
        let Some(line) = view
            .events
            .iter()
            .skip(start)
            .find(|e| e.contains("autopilot model"))
        else {
            return;
        };
        // Drop the "   12.3 s  warning: " prefix.
        let text = line
            .split_once(" s  ")
            .map_or(line.as_str(), |(_, t)| t)
            .trim_start_matches("warning: ")
            .to_string();
        self.result = Some(if text.contains("refused") {
            SwitchResult::Refused(text)
        } else {
            SwitchResult::Accepted(text)
        });
        self.after = None;
    }

    /// Times the confirm button (egui's frame time, not the clock); true once when the
    /// hold is long enough.
    pub fn confirm_hold(&mut self, held: bool, dt_s: f64) -> bool {
        if !held {
            self.confirm_held_s = 0.0;
            return false;
        }
        self.confirm_held_s += dt_s;
        if self.confirm_held_s >= CONFIRM_HOLD_S {
            self.confirm_held_s = 0.0;
            return true;
        }
        false
    }

    /// Shows the last answer.
    pub fn show(&self, ui: &mut egui::Ui) {
        let (text, color) = match &self.result {
            None => return,
            Some(SwitchResult::Waiting(l)) => (format!("sent: {l}"), crate::theme::DIM),
            Some(SwitchResult::Accepted(t)) => (format!("accepted: {t}"), crate::theme::GREEN),
            Some(SwitchResult::Refused(t)) if t.contains("refused") => {
                (t.clone(), crate::theme::RED)
            }
            Some(SwitchResult::Refused(t)) => (format!("refused: {t}"), crate::theme::RED),
        };
        ui.label(egui::RichText::new(text).small().color(color));
    }
}
