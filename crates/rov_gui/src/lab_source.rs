//! What the Model lab works on besides the data file: an optional **log map** (any log a
//! map describes: another vehicle's ArduSub DataFlash or tlog, a ROS bag, a CSV with its
//! own columns, read as `topside lab --map MAP.toml` reads it) and an optional **model
//! file** (a vehicle definition, a base-model file or a saved extended model, in place
//! of the built-in bases), so that a log of a vehicle that is not a Pro 4 is compared
//! with its own vehicle file on its own command channels.

use std::path::{Path, PathBuf};

use egui::{RichText, Ui};
use rov_lab::{BaseKind, LabModel};

use crate::FileError;
use crate::app::StationApp;
use crate::theme;

/// The model the lab starts from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LabBase {
    /// One of the built-in bases (model1, model2, model3).
    Builtin(BaseKind),
    /// A model file: vehicle definition, base-model file or saved extended model.
    File(PathBuf),
}

impl LabBase {
    /// Its name in the lab's labels and the diagnosis ("model3", "bluerov2_heavy.toml").
    #[must_use]
    pub fn label(&self) -> String {
        match self {
            Self::Builtin(k) => k.name().to_string(),
            Self::File(p) => p
                .file_name()
                .map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into()),
        }
    }

    /// `c` headed with this base's name: a model file's name in place of its kind
    /// ("bluerov2_heavy.toml+tether", not "vehicle+tether"); a built-in base unchanged.
    #[must_use]
    pub fn relabel(&self, mut c: crate::lab::Comparison) -> crate::lab::Comparison {
        if let Self::File(_) = self {
            let effects = c
                .model
                .split_once('+')
                .map(|(_, e)| format!("+{e}"))
                .unwrap_or_default();
            c.model = format!("{}{effects}", self.label());
        }
        c
    }

    /// The model, through the lab's one loader (a file's errors name file, key, value).
    ///
    /// # Errors
    /// The file cannot be read or is not a model.
    pub fn load(&self) -> Result<LabModel, FileError> {
        match self {
            Self::Builtin(k) => Ok(LabModel::default_base(*k)?),
            Self::File(p) => crate::autopilot_model::read_model_file(p),
        }
    }
}

/// A path typed in a field: `None` when the field is empty.
#[must_use]
pub fn typed_path(field: &str) -> Option<PathBuf> {
    let t = field.trim();
    (!t.is_empty()).then(|| PathBuf::from(t))
}

/// The row under the data field: the log map and the model file, each a field with
/// Browse and a clear button. Changing the model file drops the lab's current model (it
/// was fitted from the other base).
pub(crate) fn source_row(app: &mut StationApp, ui: &mut Ui) {
    let mut pick: Option<(bool, &'static str, &'static [&'static str])> = None;
    let lab = &mut app.lab;
    let model_before = lab.model_path.clone();
    ui.horizontal(|ui| {
        let l = ui.label("Log map");
        ui.add(
            egui::TextEdit::singleline(&mut lab.map_path)
                .desired_width(200.0)
                .hint_text("none: CSV or session as it is"),
        )
        .labelled_by(l.id)
        .on_hover_text(
            "A log map (TOML) reads another vehicle's log: DataFlash, tlog, ROS bag, CSV \
             with its own columns (README, \"Logs of other vehicles\"). Applies at the next Load.",
        );
        if ui
            .small_button("…")
            .on_hover_text("Browse for a log map")
            .clicked()
        {
            pick = Some((true, "Open a log map", &["toml"]));
        }
        ui.separator();
        let l = ui.label("Model file");
        ui.add(
            egui::TextEdit::singleline(&mut lab.model_path)
                .desired_width(200.0)
                .hint_text("none: the built-in base"),
        )
        .labelled_by(l.id)
        .on_hover_text(
            "A vehicle file (topside vehicle new), a base-model file or a saved lab model, \
             in place of the built-in base",
        );
        if ui
            .small_button("…")
            .on_hover_text("Browse for a model file")
            .clicked()
        {
            pick = Some((false, "Open a model or vehicle file", &["toml"]));
        }
    });
    if let Some((is_map, title, ext)) = pick
        && let Some(p) = app.backend.pick_file(title, ext)
    {
        let field = if is_map {
            &mut app.lab.map_path
        } else {
            &mut app.lab.model_path
        };
        *field = p.display().to_string();
    }
    let lab = &mut app.lab;
    if lab.model_path != model_before {
        lab.model = None;
    }
    if let Some(note) = source_note(&lab.base(), typed_path(&lab.map_path).as_deref()) {
        ui.label(RichText::new(note).small().color(theme::DIM));
    }
}

/// One line saying what the lab reads and fits when either choice is made.
fn source_note(base: &LabBase, map: Option<&Path>) -> Option<String> {
    let map_name = |p: &Path| {
        p.file_name()
            .map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into())
    };
    match (base, map) {
        (LabBase::Builtin(_), None) => None,
        (LabBase::Builtin(k), Some(m)) => Some(format!(
            "the log is read through {}; compared with the built-in {} (its commands must be \
             port, starboard and vertical)",
            map_name(m),
            k.name()
        )),
        (b @ LabBase::File(_), None) => Some(format!(
            "model: {} (the model file, in place of the base)",
            b.label()
        )),
        (b @ LabBase::File(_), Some(m)) => Some(format!(
            "the log is read through {}; model: {} on its own command channels",
            map_name(m),
            b.label()
        )),
    }
}
