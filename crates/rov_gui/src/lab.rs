//! The Model lab tab (rov_lab): load a session (MCAP), a measurement CSV or a BlueROV2
//! tank CSV (read by the lab's one log loader, `rov_lab::loader`, as `topside lab` reads
//! it: gaps split it into runs, the data notes are the CLI's), pick a model, compare it
//! with the measurements (per-channel fit %), run the diagnosis, add a found effect, and
//! watch the error fall.
//!
//! Every lab computation (loading, comparison, diagnosis, refits) runs on a worker
//! thread; the GUI polls for the result and stays responsive. While it runs, the tab
//! shows the stage the lab reports ([`rov_lab::progress`]) and a Cancel that stops the
//! work within a simulation of each worker.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;
use std::sync::mpsc::{Receiver, channel};

use egui::{Color32, RichText, Ui};
use egui_plot::{Line, Plot, PlotPoints, Points};
use rov_lab::diagnose::{DiagnoseOptions, Diagnosis, Status, diagnose};
use rov_lab::evaluate::evaluate;
use rov_lab::lab::fit_with_effects;
use rov_lab::lm::LmOptions;
use rov_lab::progress::{Loading, Progress};
use rov_lab::{BaseKind, EffectId, LabError, LabModel, Run};

use crate::FileError;
use crate::app::StationApp;
pub use crate::lab_source::LabBase;
use crate::lab_source::typed_path;
use crate::theme;

/// One compared channel, in both of the lab's error views (as `lab compare` prints
/// them): the free run (the model alone from the start, what the error fall plots) and
/// multiple shooting (re-anchored on the measurement every
/// [`rov_lab::calibrate::SHOOTING_WINDOW_S`], what calibration fits).
#[derive(Debug, Clone)]
pub struct ComparedChannel {
    /// Channel name ("depth", "heading", ...).
    pub name: String,
    /// Measured samples.
    pub measured: Vec<f64>,
    /// The model's free-run prediction.
    pub predicted: Vec<f64>,
    /// Free-run fit %, if the channel is excited enough.
    pub fit_pct: Option<f64>,
    /// Free-run RMSE.
    pub rmse: f64,
    /// The model's multiple-shooting prediction.
    pub shooting: Vec<f64>,
    /// Multiple-shooting fit %, if the channel is excited enough.
    pub fit_pct_shooting: Option<f64>,
    /// Multiple-shooting RMSE.
    pub rmse_shooting: f64,
    /// The channel's noise floor (pooled over the runs), in its unit.
    pub noise: f64,
}

/// Which of the lab's two error views the tab plots.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ErrorView {
    /// The model alone from the start of each run.
    #[default]
    FreeRun,
    /// Re-anchored on the measurement every 20 s.
    Shooting,
}

impl ErrorView {
    /// The view's name on the tab.
    #[must_use]
    pub fn label(self) -> &'static str {
        match self {
            Self::FreeRun => "free run",
            Self::Shooting => "multiple shooting",
        }
    }
}

/// A model-versus-measured comparison.
#[derive(Debug, Clone, Default)]
pub struct Comparison {
    /// Model label.
    pub model: String,
    /// Which data: "whole run" or "held-out third" (the error fall's data).
    pub scope: String,
    /// Time, s.
    pub t: Vec<f64>,
    /// Channels.
    pub channels: Vec<ComparedChannel>,
}

/// Loaded data, read by the lab's one log loader ([`rov_lab::loader`], as `topside lab`
/// reads it): the log's runs (gaps split a log into several), and a training / held-out
/// split (the log's first two thirds of rows / last third, each part read into runs by
/// the same treatment) for the diagnosis.
#[derive(Debug, Clone)]
pub struct LabData {
    /// Label.
    pub name: String,
    /// Everything: the runs `topside lab` makes of the log.
    pub full: Arc<Vec<Run>>,
    /// Training part.
    pub train: Arc<Vec<Run>>,
    /// Held-out part.
    pub val: Arc<Vec<Run>>,
    /// Warnings while loading and what was done to the data, in words (the CLI's data
    /// notes).
    pub warnings: Vec<String>,
}

/// Samples and seconds of some runs.
fn extent(runs: &[Run]) -> (usize, f64) {
    (
        runs.iter().map(Run::len).sum(),
        runs.iter().map(Run::duration_s).sum(),
    )
}

/// Results from the worker.
#[derive(Debug)]
pub enum LabResult {
    /// Data loaded.
    Loaded(LabData),
    /// Comparison done.
    Compared(Comparison),
    /// Diagnosis done.
    Diagnosed(Box<Diagnosis>, Comparison),
    /// An effect added (or removed) and refitted; the comparison is on the held-out
    /// part, and the error-fall step is its RMSE.
    Added(Box<LabModel>, Comparison, String),
    /// Failure.
    Failed(String),
    /// The pilot cancelled the work (nothing changed).
    Cancelled(String),
}

/// Lab work running in the background.
#[derive(Debug)]
pub struct Busy {
    /// What it does ("diagnosing").
    pub label: String,
    /// Its progress and cancel switch.
    pub progress: Progress,
    rx: Receiver<LabResult>,
}

/// State of the lab tab.
#[derive(Debug)]
pub struct LabState {
    /// Source path (CSV or MCAP).
    pub path: String,
    /// Base model.
    pub kind: BaseKind,
    /// The current model (the calibrated base and added effects).
    pub model: Option<LabModel>,
    /// The data.
    pub data: Option<LabData>,
    /// The last comparison.
    pub comparison: Option<Comparison>,
    /// The last diagnosis.
    pub diagnosis: Option<Box<Diagnosis>>,
    /// Error fall: held-out RMSE per channel after each step.
    pub fall: Vec<(String, BTreeMap<String, f64>)>,
    /// Effects added by the pilot.
    pub added: Vec<EffectId>,
    /// Work in progress.
    pub busy: Option<Busy>,
    /// What the last cancelled work was (shown instead of an error).
    pub cancelled: Option<String>,
    /// Last error.
    pub error: Option<String>,
    /// The log map the next Load reads the data through (empty: none).
    pub map_path: String,
    /// A model file in place of the built-in base `kind` (empty: none).
    pub model_path: String,
    /// The base the current `model` was fitted from.
    model_base: Option<LabBase>,
    /// The error view the plots show (free run by default; the error fall is always
    /// the free run).
    pub view: ErrorView,
    /// Worker threads of the lab's work (default: every core but one, which is left to
    /// the station and the GUI).
    pub threads: usize,
}

impl Default for LabState {
    fn default() -> Self {
        Self {
            path: String::new(),
            kind: BaseKind::Model3,
            model: None,
            data: None,
            comparison: None,
            diagnosis: None,
            fall: Vec::new(),
            added: Vec::new(),
            busy: None,
            cancelled: None,
            error: None,
            view: ErrorView::FreeRun,
            map_path: String::new(),
            model_path: String::new(),
            model_base: None,
            threads: rov_lab::par::default_threads().saturating_sub(1).max(1),
        }
    }
}

/// Loads a CSV or an MCAP session into lab runs.
///
/// # Errors
/// [`FileError`] when the file cannot be read or has too little data.
pub fn load(path: &Path) -> Result<LabData, FileError> {
    load_window(path, None)
}

/// [`load`], keeping only the rows of `window` (s from the log's start) when given: the
/// stretch around a model-watch alert ("Open in lab").
///
/// # Errors
/// [`FileError`] when the file cannot be read or the window holds too little data.
pub fn load_window(path: &Path, window: Option<(f64, f64)>) -> Result<LabData, FileError> {
    load_log(path, None, window)
}

/// [`load_window`], or through the log map `map` (a TOML file) any log the map describes
/// (CSV/TSV, ArduSub DataFlash, tlog, ROS bags, MCAP with CDR messages), read by the lab's
/// one loader as `topside lab --map MAP.toml` reads it (`rov_lab::loader`).
///
/// # Errors
/// [`FileError`] when the log or the map cannot be read, the map does not parse or the
/// log does not read through it, or the window holds too little data.
pub fn load_log(
    path: &Path,
    map: Option<&Path>,
    window: Option<(f64, f64)>,
) -> Result<LabData, FileError> {
    let name = path
        .file_name()
        .map_or_else(|| "data".to_string(), |n| n.to_string_lossy().into_owned());
    let name = match window {
        Some((a, b)) => format!("{name} [{a:.0}–{b:.0} s]"),
        None => name,
    };
    let is_mcap = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mcap"));
    let read = |p: &Path| {
        std::fs::read(p).map_err(|source| FileError::Read {
            path: p.to_path_buf(),
            source,
        })
    };
    let (log, mut warnings) = if let Some(map_path) = map {
        // Not counted: the whole file is read and parsed at once.
        let _stage = Loading::start(&name, 0);
        let map_text = String::from_utf8_lossy(&read(map_path)?).into_owned();
        let bytes = read(path)?;
        let map_label = map_path.display().to_string();
        let log = rov_lab::loader::read_with_map_text(&bytes, &map_text, &map_label, &name)?;
        (log, Vec::new())
    } else if is_mcap {
        // Streamed, and decimated when long (rov_lab::stream), as `topside lab` reads it.
        let session = rov_session::open(path)?;
        let nav = session.count(rov_session::Topic::Nav.name());
        let mut stream = rov_lab::stream::LogStream::new(&name, nav);
        // Reading is a stage of its own on the tab, and Cancel stops it within a few
        // thousand rows.
        let mut loading = Loading::start(&name, nav);
        let done = rov_session::measurements_until(&session, &mut |_, row| {
            stream.push(row);
            loading.row()
        })?
        .ok_or(LabError::Cancelled)?;
        (stream.finish_log(done.present), done.warnings)
    } else {
        let _stage = Loading::start(&name, 0);
        let bytes = read(path)?;
        let log = rov_lab::loader::read_bytes(&bytes, &name)?;
        (log, Vec::new())
    };
    let log = match window {
        Some((from_s, to_s)) => log.window(from_s, to_s, &name),
        None => log,
    };
    let cut = log.len() * 2 / 3;
    let runs = rov_lab::loader::LoadedLog::runs;
    let full = runs(&log)?;
    let train = runs(&log.rows(0..cut, &format!("{name} (training)")))?;
    let val = runs(&log.rows(cut..log.len(), &format!("{name} (held out)")))?;
    warnings.extend(rov_lab::ingest::treatment_sentences(&full));
    Ok(LabData {
        name,
        full: Arc::new(full),
        train: Arc::new(train),
        val: Arc::new(val),
        warnings,
    })
}

/// Compares a model with runs (free run).
///
/// # Errors
/// The lab's error.
pub fn compare(model: &LabModel, runs: &[Run]) -> Result<Comparison, LabError> {
    compare_on(model, runs, WHOLE_RUN)
}

/// [`compare`] with a label for the data compared. The fit and RMSE are pooled over the
/// runs; the plotted lines follow the runs one after the other, broken between them.
///
/// # Errors
/// The lab's error.
pub fn compare_on(model: &LabModel, runs: &[Run], scope: &str) -> Result<Comparison, LabError> {
    let eval = evaluate(model, runs)?;
    // The runs' samples one after the other, a missing sample between two runs (the
    // plotted line breaks there).
    let joined = |per_run: &dyn Fn(usize, &Run) -> Option<Vec<f64>>| -> Vec<f64> {
        let mut out = Vec::new();
        for (i, run) in runs.iter().enumerate() {
            if i > 0 {
                out.push(f64::NAN);
            }
            match per_run(i, run) {
                Some(v) if v.len() == run.len() => out.extend(v),
                _ => out.extend(std::iter::repeat_n(f64::NAN, run.len())),
            }
        }
        out
    };
    let mut channels = Vec::new();
    for (key, ce) in &eval.channels {
        let measured = joined(&|_, run| run.y.get(key.0).and_then(Clone::clone));
        let prediction = |view: &[rov_lab::sim::Prediction]| {
            joined(&|i, _| {
                view.get(i)
                    .and_then(|p| p.y.get(key.0))
                    .and_then(|v| v.as_deref().cloned())
            })
        };
        channels.push(ComparedChannel {
            name: key.name().to_string(),
            measured,
            predicted: prediction(&eval.free_run),
            fit_pct: ce.free_run.fit_pct,
            rmse: ce.free_run.rmse,
            shooting: prediction(&eval.shooting),
            fit_pct_shooting: ce.shooting.fit_pct,
            rmse_shooting: ce.shooting.rmse,
            noise: ce.noise,
        });
    }
    let mut t = Vec::new();
    for (i, run) in runs.iter().enumerate() {
        if i > 0 {
            t.push(run.t.first().copied().unwrap_or(f64::NAN));
        }
        t.extend_from_slice(&run.t);
    }
    Ok(Comparison {
        model: model_label(model),
        scope: scope.to_string(),
        t,
        channels,
    })
}

impl Comparison {
    /// The free-run RMSE per channel (what the error fall plots).
    #[must_use]
    pub fn rmse(&self) -> BTreeMap<String, f64> {
        self.channels
            .iter()
            .map(|c| (c.name.clone(), c.rmse))
            .collect()
    }
}

/// The held-out part's label.
pub const HELD_OUT: &str = "held-out third";

/// The label of a comparison on all the data.
pub const WHOLE_RUN: &str = "whole run";

fn model_label(m: &LabModel) -> String {
    let mut s = m.kind().name().to_string();
    for e in m.active_effects() {
        s.push('+');
        s.push_str(e.key());
    }
    s
}

impl LabState {
    pub(crate) fn poll(&mut self) {
        let Some(busy) = &self.busy else {
            return;
        };
        let r = match busy.rx.try_recv() {
            Ok(r) => r,
            Err(std::sync::mpsc::TryRecvError::Empty) => return,
            Err(std::sync::mpsc::TryRecvError::Disconnected) => {
                LabResult::Failed(format!("{}: the lab worker stopped", busy.label))
            }
        };
        self.busy = None;
        match r {
            LabResult::Loaded(d) => {
                self.data = Some(d);
                self.comparison = None;
                self.diagnosis = None;
                self.fall.clear();
                self.added.clear();
                self.model = None;
                self.error = None;
            }
            LabResult::Compared(c) => self.comparison = Some(c),
            LabResult::Diagnosed(d, c) => {
                // The chart starts at the calibrated base; each "Add effect" (or
                // "Remove") adds a step. Every step is the RMSE of the comparison shown
                // above it: the same view (free run) on the same data (held-out third).
                // The diagnosis's own greedy additions are in its findings.
                self.fall = vec![("calibrated base".to_string(), c.rmse())];
                self.model = Some(d.calibrated.clone());
                self.model_base = Some(self.base());
                self.added.clear();
                self.diagnosis = Some(d);
                self.comparison = Some(c);
            }
            LabResult::Added(m, c, label) => {
                self.added = m.active_effects().to_vec();
                self.fall.push((label, c.rmse()));
                self.model = Some(*m);
                self.comparison = Some(c);
            }
            LabResult::Failed(e) => self.error = Some(e),
            LabResult::Cancelled(what) => self.cancelled = Some(what),
        }
    }

    /// The model the lab starts from: the model file when one is named, else the
    /// built-in base.
    #[must_use]
    pub fn base(&self) -> LabBase {
        typed_path(&self.model_path).map_or(LabBase::Builtin(self.kind), LabBase::File)
    }

    /// Asks the running work to stop (its result is dropped; nothing changes).
    pub fn cancel(&mut self) {
        if let Some(b) = &self.busy {
            b.progress.cancel();
        }
    }

    /// Whether the worker is busy.
    #[must_use]
    pub fn is_busy(&self) -> bool {
        self.busy.is_some()
    }

    fn spawn(&mut self, label: &str, job: impl FnOnce() -> LabResult + Send + 'static) {
        self.start_job(label, move |_| job());
    }

    /// Runs `job` on a worker thread with a fresh [`Progress`] current (the lab's stages
    /// show on the tab; Cancel cancels it). A cancelled job's result is dropped.
    pub fn start_job(
        &mut self,
        label: &str,
        job: impl FnOnce(&Progress) -> LabResult + Send + 'static,
    ) {
        let (tx, rx) = channel();
        let progress = Progress::new();
        let p = progress.clone();
        let what = label.to_string();
        let spawned = std::thread::Builder::new()
            .name("lab-worker".into())
            .spawn(move || {
                let r = p.run(|| Ok(job(&p))).unwrap_or(LabResult::Cancelled(what));
                // The lab page has gone (app closing) if this fails: nobody waits.
                let _ = tx.send(r);
            });
        match spawned {
            Ok(_) => {
                self.busy = Some(Busy {
                    label: label.to_string(),
                    progress,
                    rx,
                });
                self.error = None;
                self.cancelled = None;
            }
            Err(e) => self.error = Some(format!("cannot start the lab worker: {e}")),
        }
    }

    /// Loads a file in the background.
    pub fn start_load(&mut self, path: &Path) {
        self.start_load_window(path, None);
    }

    /// Loads a window of a file (s from its start) in the background.
    pub fn start_load_window(&mut self, path: &Path, window: Option<(f64, f64)>) {
        let p = path.to_path_buf();
        let map = typed_path(&self.map_path);
        self.spawn("loading", move || {
            match load_log(&p, map.as_deref(), window) {
                Ok(d) => LabResult::Loaded(d),
                Err(e) => LabResult::Failed(e.to_string()),
            }
        });
    }

    /// Compares the chosen base model with the data in the background.
    pub fn start_compare(&mut self) {
        let Some(d) = &self.data else {
            self.error = Some("load data first".into());
            return;
        };
        let run = Arc::clone(&d.full);
        let base = self.base();
        let current = self
            .model
            .clone()
            .filter(|_| self.model_base.as_ref() == Some(&base));
        // Say which numbers these are: Diagnose scores a calibrated model on the held-out
        // third, Compare the model as it is on the whole run (issue 25 item 14).
        let scope = if current.is_some() {
            format!("{WHOLE_RUN}, the lab's current model")
        } else {
            format!("{WHOLE_RUN}, shipped parameters (not calibrated)")
        };
        self.spawn("comparing", move || {
            let m = match current.map_or_else(|| base.load(), Ok) {
                Ok(m) => m,
                Err(e) => return LabResult::Failed(e.to_string()),
            };
            match compare_on(&m, &run, &scope) {
                Ok(c) => LabResult::Compared(base.relabel(c)),
                Err(e) => LabResult::Failed(e.to_string()),
            }
        });
    }

    /// Runs the diagnosis in the background.
    pub fn start_diagnose(&mut self) {
        let Some(d) = &self.data else {
            self.error = Some("load data first".into());
            return;
        };
        let (train, val) = (Arc::clone(&d.train), Arc::clone(&d.val));
        let choice = self.base();
        let threads = self.threads.max(1);
        self.spawn("diagnosing", move || {
            let base = match choice.load() {
                Ok(m) => m,
                Err(e) => return LabResult::Failed(e.to_string()),
            };
            let opts = DiagnoseOptions {
                threads,
                ..DiagnoseOptions::default()
            };
            let diag = match diagnose(&base, &choice.label(), &train, &val, &opts) {
                Ok(d) => d,
                Err(e) => return LabResult::Failed(e.to_string()),
            };
            match compare_on(&diag.calibrated, &val, HELD_OUT) {
                Ok(c) => LabResult::Diagnosed(Box::new(diag), choice.relabel(c)),
                Err(e) => LabResult::Failed(e.to_string()),
            }
        });
    }

    /// Adds an effect to the current model, refits on the training data and compares on
    /// the held-out part, in the background.
    pub fn start_add_effect(&mut self, e: EffectId) {
        let mut effects = self.added.clone();
        if !effects.contains(&e) {
            effects.push(e);
        }
        self.start_refit(effects, format!("+{}", e.key()));
    }

    /// Removes an added effect: refits the calibrated base with the remaining effects,
    /// in the background.
    pub fn start_remove_effect(&mut self, e: EffectId) {
        let effects: Vec<EffectId> = self.added.iter().copied().filter(|x| *x != e).collect();
        self.start_refit(effects, format!("-{}", e.key()));
    }

    /// Refits the diagnosis's calibrated base with `effects` (the same refit as
    /// `topside lab add`: each effect's parameters start at the better of off and their
    /// probe value, then are fitted jointly with the base) and compares on the held-out
    /// part.
    fn start_refit(&mut self, effects: Vec<EffectId>, label: String) {
        let (Some(d), Some(diag)) = (&self.data, &self.diagnosis) else {
            self.error = Some("run the diagnosis first".into());
            return;
        };
        let (train, val) = (Arc::clone(&d.train), Arc::clone(&d.val));
        let base = diag.calibrated.clone();
        let threads = self.threads.max(1);
        self.spawn("refitting", move || {
            let opts = LmOptions {
                max_iter: 8,
                threads,
                ..LmOptions::default()
            };
            let fitted = if effects.is_empty() {
                base
            } else {
                match fit_with_effects(&base, &train, &effects, &opts) {
                    Ok((m, _)) => m,
                    Err(err) => return LabResult::Failed(err.to_string()),
                }
            };
            match compare_on(&fitted, &val, HELD_OUT) {
                Ok(c) => LabResult::Added(Box::new(fitted), c, label),
                Err(err) => LabResult::Failed(err.to_string()),
            }
        });
    }
}

/// The running work: what it does, the lab's stage with a bar when it is counted, and
/// Cancel. Whether Cancel was clicked.
fn busy_row(ui: &mut Ui, b: &Busy) -> bool {
    ui.spinner();
    if b.progress.is_cancelled() {
        ui.label(RichText::new(format!("{}: cancelling…", b.label)).color(theme::AMBER));
        return false;
    }
    let stage = b.progress.latest();
    let text = match &stage {
        Some(s) => format!("{}: {s}", b.label),
        None => format!("{}…", b.label),
    };
    ui.label(RichText::new(text).color(theme::AMBER));
    if let Some(s) = stage.filter(|s| s.total > 0) {
        ui.add(
            egui::ProgressBar::new(s.done as f32 / s.total as f32)
                .desired_width(120.0)
                .desired_height(10.0),
        );
    }
    ui.button("Cancel").clicked()
}

fn status_badge(s: Status) -> (&'static str, Color32) {
    match s {
        Status::Significant => ("SIGNIFICANT", theme::GREEN),
        Status::Ambiguous => ("AMBIGUOUS", theme::AMBER),
        Status::NotSignificant => ("not significant", theme::DIM),
        Status::Screened => ("screened", theme::DIM),
        Status::NotTestable => ("not testable", theme::DIM),
        Status::NotApplicable => ("not applicable", theme::DIM),
        Status::Contained => ("in the model", theme::ESTIMATE),
    }
}

pub(crate) fn lab_tab(app: &mut StationApp, ui: &mut Ui) {
    let browse = ui
        .horizontal(|ui| {
            ui.label(RichText::new("Model lab").strong().color(theme::SCALE));
            ui.button("Browse…").clicked()
        })
        .inner;
    if browse
        && let Some(p) = app
            .backend
            .pick_file("Open measurements or a session", &["csv", "mcap"])
    {
        app.lab.path = p.display().to_string();
        app.lab.start_load(&p);
    }
    let lab = &mut app.lab;
    ui.horizontal(|ui| {
        let l = ui.label("Data (CSV or MCAP)");
        ui.add(
            egui::TextEdit::singleline(&mut lab.path)
                .desired_width(360.0)
                .hint_text("measurements.csv"),
        )
        .labelled_by(l.id);
        let busy = lab.is_busy();
        if ui.add_enabled(!busy, egui::Button::new("Load")).clicked() {
            if lab.path.trim().is_empty() {
                lab.error = Some(
                    "no file chosen: type the path of a CSV or a session (.mcap), or use Browse"
                        .into(),
                );
            } else {
                let p = std::path::PathBuf::from(lab.path.trim());
                lab.start_load(&p);
            }
        }
        if let Some(last) = app.live_view.recording.last_file.clone()
            && ui
                .add_enabled(!busy, egui::Button::new("Last recording"))
                .clicked()
        {
            lab.path = last.display().to_string();
            lab.start_load(&last);
        }
        ui.separator();
        let before = lab.kind;
        let builtin = typed_path(&lab.model_path).is_none();
        ui.add_enabled_ui(builtin, |ui| {
            egui::ComboBox::new("lab_model", "model")
                .selected_text(if builtin {
                    lab.kind.name().to_string()
                } else {
                    "file".to_string()
                })
                .show_ui(ui, |ui| {
                    for k in [BaseKind::Model1, BaseKind::Model2, BaseKind::Model3] {
                        ui.selectable_value(&mut lab.kind, k, k.name());
                    }
                });
        });
        if lab.kind != before {
            lab.model = None;
        }
        let ready = lab.data.is_some() && !busy;
        if ui
            .add_enabled(ready, egui::Button::new("Compare"))
            .clicked()
        {
            lab.start_compare();
        }
        if ui
            .add_enabled(ready, egui::Button::new("Diagnose"))
            .clicked()
        {
            lab.start_diagnose();
        }
    });
    crate::lab_source::source_row(app, ui);
    let lab = &mut app.lab;
    // The running work on a line of its own (the controls' row is full).
    let mut cancel = false;
    if let Some(b) = &lab.busy {
        ui.horizontal(|ui| cancel = busy_row(ui, b));
    }
    if cancel {
        lab.cancel();
    }
    if let Some(what) = &lab.cancelled {
        ui.label(
            RichText::new(format!("{what} cancelled: nothing changed"))
                .small()
                .color(theme::DIM),
        );
    }
    if let Some(d) = &lab.data {
        let ((n, full_s), (_, train_s), (_, val_s)) =
            (extent(&d.full), extent(&d.train), extent(&d.val));
        let pieces = match d.full.len() {
            1 => String::new(),
            k => format!(" in {k} runs (gaps split the log)"),
        };
        ui.label(
            RichText::new(format!(
                "{}: {n} samples, {full_s:.1} s{pieces} (training {train_s:.1} s, held out {val_s:.1} s)",
                d.name
            ))
            .small()
            .color(theme::DIM),
        );
        for w in d.warnings.iter().take(4) {
            ui.label(
                RichText::new(format!("data: {w}"))
                    .small()
                    .color(theme::AMBER),
            );
        }
    }
    if let Some(e) = &lab.error {
        ui.label(RichText::new(e).color(theme::RED));
    }
    let lab = &mut app.lab;
    ui.separator();
    let mut add: Option<EffectId> = None;
    let mut remove: Option<EffectId> = None;
    egui::Panel::right("lab_findings")
        .exact_size(430.0)
        .resizable(false)
        .show(ui, |ui| {
            ui.label(RichText::new("DIAGNOSIS").strong());
            let Some(diag) = &lab.diagnosis else {
                ui.label(
                    RichText::new("Run the diagnosis to see which effect the model misses.")
                        .color(theme::DIM),
                );
                return;
            };
            ui.label(RichText::new(&diag.summary).strong());
            verdict_in_words(ui, diag);
            egui::ScrollArea::vertical()
                .id_salt("findings")
                .max_height(ui.available_height() - 200.0)
                .show(ui, |ui| {
                    for f in diag.findings.iter().filter(|f| {
                        !matches!(f.status, Status::NotApplicable | Status::NotTestable)
                    }) {
                        egui::Frame::group(ui.style()).show(ui, |ui| {
                            ui.set_width(ui.available_width());
                            ui.horizontal(|ui| {
                                ui.label(RichText::new(&f.effect).strong().size(15.0));
                                let (b, c) = status_badge(f.status);
                                ui.label(RichText::new(b).small().strong().color(c));
                                let effect = EffectId::parse(&f.effect);
                                let already = effect.is_some_and(|e| lab.added.contains(&e));
                                let can = effect.is_some() && !f.contained && !lab.is_busy();
                                ui.with_layout(
                                    egui::Layout::right_to_left(egui::Align::Center),
                                    |ui| {
                                        let label = if f.contained {
                                            "In the model"
                                        } else if already {
                                            "Remove"
                                        } else {
                                            "Add effect"
                                        };
                                        if ui.add_enabled(can, egui::Button::new(label)).clicked() {
                                            if already {
                                                remove = effect;
                                            } else {
                                                add = effect;
                                            }
                                        }
                                    },
                                );
                            });
                            let red: Vec<String> = MAIN_CHANNELS
                                .iter()
                                .filter_map(|k| {
                                    f.validation_rmse_reduction_pct
                                        .get(*k)
                                        .map(|v| format!("{k} {} %", signed_pct(-v)))
                                })
                                .collect();
                            if !red.is_empty() {
                                ui.label(
                                    RichText::new(format!(
                                        "held-out RMSE change ({}): {}",
                                        f.view,
                                        red.join(", ")
                                    ))
                                    .small(),
                                );
                            }
                            ui.label(RichText::new(&f.explanation).small().color(theme::SCALE));
                            if let Some(s) = &f.separating_experiment {
                                ui.label(
                                    RichText::new(format!("to tell apart: {s}"))
                                        .small()
                                        .color(theme::AMBER),
                                );
                            }
                        });
                    }
                });
            ui.separator();
            ui.label(
                RichText::new("ERROR FALL (held-out third, free-run RMSE, % of the base)").strong(),
            );
            error_fall(ui, &lab.fall);
        });
    if let Some(e) = add {
        lab.start_add_effect(e);
    }
    if let Some(e) = remove {
        lab.start_remove_effect(e);
    }
    // The rest scrolls (issue 25 item 7): the autopilot row, the camera frame and the
    // plots, each plot at least MIN_PLOT_H tall, so a camera frame or a short window
    // never squeezes them to slivers.
    let view_h = ui.available_height();
    crate::layout::scroll(app, ui, "lab_scroll", |app, ui| {
        use_for_autopilot(app, ui);
        crate::lab_video::panel(app, ui);
        comparison_plots(ui, app.lab.comparison.as_ref(), &mut app.lab.view, view_h);
    });
}

/// The least height of a lab plot, points (with its title and legend).
pub const MIN_PLOT_H: f32 = 150.0;

/// The lab's model as the autopilot's feedforward and observer model: a click while
/// disarmed; while armed the station refuses a plain click and the pilot holds the
/// confirm button for [`crate::autopilot_model::CONFIRM_HOLD_S`].
fn use_for_autopilot(app: &mut StationApp, ui: &mut Ui) {
    let Some(m) = app.lab.model.as_ref() else {
        return;
    };
    let label = format!("lab {}", model_label(m));
    let armed = app.live_view.snapshot.armed;
    let mut send: Option<bool> = None;
    ui.horizontal(|ui| {
        if ui
            .add_enabled(app.live.is_some(), egui::Button::new("Use for autopilot"))
            .on_hover_text(format!(
                "make {label} the autopilot's feedforward and observer model"
            ))
            .clicked()
        {
            send = Some(false);
        }
        if armed {
            let progress = app.model_switch.confirm_held_s / crate::autopilot_model::CONFIRM_HOLD_S;
            let held = crate::instruments::hold_button(
                ui,
                "HOLD TO CONFIRM",
                egui::vec2(160.0, 26.0),
                progress,
            );
            let dt = f64::from(ui.input(|i| i.stable_dt));
            if held {
                ui.ctx().request_repaint();
            }
            if app.model_switch.confirm_hold(held, dt) {
                send = Some(true);
            }
        }
        if ui
            .button("Save model…")
            .on_hover_text("the lab's model as a model file (TOML) the autopilot and sim can load")
            .clicked()
        {
            save_model(app);
        }
        ui.label(
            RichText::new(format!("autopilot uses: {}", app.live_view.model_label))
                .small()
                .color(theme::SCALE),
        );
        app.model_switch.show(ui);
    });
    let unconfirmed = unconfirmed_effects(&app.lab);
    if !unconfirmed.is_empty() {
        let list: Vec<String> = unconfirmed
            .iter()
            .map(|(e, why)| format!("{e} ({why})"))
            .collect();
        ui.label(
            RichText::new(format!(
                "Note: this model carries effects the lab did not rate significant: {}. \
                 Use for autopilot takes them as they are.",
                list.join(", ")
            ))
            .small()
            .color(theme::AMBER),
        );
    }
    if send.is_some() && !unconfirmed.is_empty() {
        let keys: Vec<&str> = unconfirmed.iter().map(|(e, _)| e.as_str()).collect();
        app.message = Some(format!(
            "autopilot model includes effects not rated significant: {}",
            keys.join(", ")
        ));
    }
    if let Some(confirmed) = send
        && let Some(m) = app.lab.model.as_ref()
    {
        let plant =
            rov_station::AutopilotModel::from_vehicle_model(&label, m).map_err(FileError::from);
        app.send_autopilot_model(plant, confirmed);
    }
}

/// A percentage change, whole, signed: "-12", "+3", and "0" for anything that rounds to
/// zero (no "-0" for a change of -0.3 %).
#[must_use]
pub fn signed_pct(x: f64) -> String {
    let r = x.round();
    if r == 0.0 || !r.is_finite() {
        if r.is_nan() { "---".into() } else { "0".into() }
    } else {
        format!("{r:+.0}")
    }
}

/// The effects of the lab's model the diagnosis did not rate significant, with the
/// rating ("not significant", "AMBIGUOUS"...).
fn unconfirmed_effects(lab: &LabState) -> Vec<(String, &'static str)> {
    let (Some(m), Some(d)) = (&lab.model, &lab.diagnosis) else {
        return Vec::new();
    };
    m.active_effects()
        .iter()
        .filter_map(|e| {
            let f = d
                .findings
                .iter()
                .find(|f| EffectId::parse(&f.effect) == Some(*e))?;
            (f.status != Status::Significant && !f.contained)
                .then(|| (e.key().to_string(), status_badge(f.status).0))
        })
        .collect()
}

/// Save model…: the lab's model as a saved-model TOML where the pilot chooses.
fn save_model(app: &mut StationApp) {
    let Some(m) = app.lab.model.as_ref() else {
        return;
    };
    let name = format!("lab-{}.toml", model_label(m).replace(['+', ' '], "_"));
    let Some(path) = app.backend.save_file("Save the lab's model", &name) else {
        return;
    };
    let note = format!("saved from the station's model lab: {}", model_label(m));
    let text = rov_lab::persist::save_extended_model(m, &note);
    app.message = Some(match std::fs::write(&path, text) {
        Ok(()) => format!("model saved: {}", path.display()),
        Err(e) => format!("model not saved: {}: {e}", path.display()),
    });
}

/// The channels the lab's summaries show (when the data has them).
const MAIN_CHANNELS: [&str; 5] = ["depth", "heading", "pitch", "roll", "yaw_rate"];

fn error_fall(ui: &mut Ui, fall: &[(String, BTreeMap<String, f64>)]) {
    if fall.is_empty() {
        ui.label(RichText::new("no steps yet").color(theme::DIM));
        return;
    }
    let channels: Vec<&str> = MAIN_CHANNELS
        .iter()
        .copied()
        .filter(|c| fall.iter().any(|(_, m)| m.contains_key(*c)))
        .collect();
    let steps: Vec<String> = fall
        .iter()
        .enumerate()
        .map(|(i, (l, _))| format!("{i}: {l}"))
        .collect();
    ui.label(RichText::new(steps.join("   ")).small().color(theme::DIM));
    let colors = [
        theme::VALUE,
        theme::ESTIMATE,
        theme::PREDICTION,
        theme::SETPOINT,
        theme::THRUST,
        theme::AMBER,
    ];
    ui.horizontal_wrapped(|ui| {
        for (k, ch) in channels.iter().enumerate() {
            crate::instruments::dot_label(ui, colors[k % colors.len()], RichText::new(*ch).small());
        }
    });
    crate::plots::with_y_ticks(Plot::new("error_fall"))
        .height(140.0)
        .allow_drag(false)
        .allow_zoom(false)
        .allow_scroll(false)
        .include_y(0.0)
        .include_y(110.0)
        .y_axis_label("% of base")
        .x_axis_formatter(|m, _| {
            let i = m.value.round();
            if (m.value - i).abs() < 1e-6 && i >= 0.0 {
                format!("{i:.0}")
            } else {
                String::new()
            }
        })
        .show(ui, |p| {
            for (k, ch) in channels.iter().enumerate() {
                // Normalised to the first step so channels of different units share an axis.
                let first = fall
                    .first()
                    .and_then(|(_, m)| m.get(*ch))
                    .copied()
                    .unwrap_or(1.0);
                let pts: Vec<[f64; 2]> = fall
                    .iter()
                    .enumerate()
                    .filter_map(|(i, (_, m))| {
                        m.get(*ch)
                            .map(|v| [i as f64, if first > 0.0 { 100.0 * v / first } else { 0.0 }])
                    })
                    .collect();
                let color = colors[k % colors.len()];
                p.line(
                    Line::new(format!("{ch} %"), PlotPoints::new(pts.clone()))
                        .color(color)
                        .width(2.0),
                );
                p.points(
                    Points::new(format!("{ch} %"), PlotPoints::new(pts))
                        .color(color)
                        .radius(3.5),
                );
            }
        });
}

/// The unit of a lab channel.
#[must_use]
pub fn channel_unit(name: &str) -> &'static str {
    match name {
        "depth" | "north" | "east" => "m",
        "heading" | "pitch" | "roll" => "°",
        "yaw_rate" | "pitch_rate" | "roll_rate" => "°/s",
        "surge" | "sway" | "heave" => "m/s",
        _ => "",
    }
}

/// Line segments of a plot, each a list of (t, y) points.
pub type Segments = Vec<Vec<[f64; 2]>>;

/// The plotted lines of a compared channel: (measured, model) segments. Headings are
/// unwrapped sample by sample (`rov_types::angle::nearest_deg` against the previous
/// sample, the first one within ±180° of the measured run's circular mean), so a turn
/// through north is a continuous line, not a jump across the whole axis that flattens
/// everything else; the axis labels read as compass degrees. Segments break only at
/// missing samples. `step` thins the samples to about two per pixel.
#[must_use]
pub fn channel_lines(
    t: &[f64],
    ch: &ComparedChannel,
    view: ErrorView,
    step: usize,
) -> (Segments, Segments) {
    let wraps = ch.name == "heading";
    let reference = if wraps {
        let (s, c) = ch
            .measured
            .iter()
            .filter(|x| x.is_finite())
            .fold((0.0, 0.0), |(s, c), x| {
                (s + x.to_radians().sin(), c + x.to_radians().cos())
            });
        s.atan2(c).to_degrees()
    } else {
        0.0
    };
    let lines = |ys: &[f64]| {
        let mut out: Segments = vec![Vec::new()];
        let mut prev: Option<f64> = None;
        for (x, y) in t.iter().zip(ys).step_by(step.max(1)) {
            if !y.is_finite() {
                out.push(Vec::new());
                continue;
            }
            let y = if wraps {
                rov_types::angle::nearest_deg(*y, prev.unwrap_or(reference))
            } else {
                *y
            };
            if let Some(l) = out.last_mut() {
                l.push([*x, y]);
            }
            prev = Some(y);
        }
        out.retain(|l| !l.is_empty());
        out
    };
    let model = match view {
        ErrorView::FreeRun => &ch.predicted,
        ErrorView::Shooting => &ch.shooting,
    };
    (lines(&ch.measured), lines(model))
}

/// The headline of a compared channel: the plotted view's fit and RMSE with units (or why
/// there is no fit), then the other view's RMSE and the noise floor, so both views and
/// the floor they are judged against are on one line.
#[must_use]
pub fn channel_title(ch: &ComparedChannel, view: ErrorView) -> String {
    let unit = channel_unit(&ch.name);
    let (fit, rmse, other, other_rmse) = match view {
        ErrorView::FreeRun => (ch.fit_pct, ch.rmse, ErrorView::Shooting, ch.rmse_shooting),
        ErrorView::Shooting => (
            ch.fit_pct_shooting,
            ch.rmse_shooting,
            ErrorView::FreeRun,
            ch.rmse,
        ),
    };
    let fit = fit.map_or_else(
        || "fit n/a (not excited above 3x its noise)".to_string(),
        |f| format!("fit {f:.1} %"),
    );
    format!(
        "{}: {fit}, RMSE {rmse:.3} {unit} · {} RMSE {other_rmse:.3} {unit} · noise {:.3} {unit}",
        ch.name,
        other.label(),
        ch.noise
    )
}

fn comparison_plots(ui: &mut Ui, c: Option<&Comparison>, view: &mut ErrorView, view_h: f32) {
    let Some(c) = c else {
        ui.label(
            RichText::new("Compare or diagnose to see the model against the measurements.")
                .color(theme::DIM),
        );
        return;
    };
    let which = if c.scope == HELD_OUT {
        "DIAGNOSE: calibrated on the first two thirds, scored on the held-out third".to_string()
    } else {
        format!("COMPARE: {}", c.scope)
    };
    ui.horizontal(|ui| {
        ui.label(RichText::new(format!("MODEL {} VS MEASURED,", c.model)).strong());
        for v in [ErrorView::FreeRun, ErrorView::Shooting] {
            ui.selectable_value(view, v, v.label())
                .on_hover_text(match v {
                    ErrorView::FreeRun => "the model alone from the start of each run",
                    ErrorView::Shooting => {
                        "the model re-anchored on the measurement every 20 s (what calibration fits)"
                    }
                });
        }
    });
    ui.label(RichText::new(which).small().strong().color(theme::AMBER));
    let shown: Vec<&ComparedChannel> = c
        .channels
        .iter()
        .filter(|ch| ["depth", "heading", "pitch", "roll"].contains(&ch.name.as_str()))
        .collect();
    let n = shown.len().max(1) as f32;
    let each = ((view_h - 60.0) / n).max(MIN_PLOT_H);
    let width = ui.available_width().max(100.0) as usize;
    for ch in shown {
        let step = (c.t.len() / (2 * width)).max(1);
        let (meas, pred) = channel_lines(&c.t, ch, *view, step);
        ui.horizontal(|ui| {
            ui.label(RichText::new(channel_title(ch, *view)).small().strong());
            ui.add_space(12.0);
            crate::plots::legend_row(
                ui,
                [("measured", theme::VALUE), ("model", theme::PREDICTION)].into_iter(),
            );
        });
        let unit = channel_unit(&ch.name);
        let mut plot = crate::plots::with_y_ticks(Plot::new(("lab_cmp", ch.name.as_str())))
            .height(each - 24.0)
            .allow_drag(false)
            .allow_zoom(false)
            .allow_scroll(false)
            .link_axis(egui::Id::unique("lab_x"), [true, false])
            .x_axis_label("time s")
            .y_axis_label(format!("{} {unit}", ch.name))
            .y_axis_min_width(44.0);
        if ch.name == "depth" {
            // Depth grows downwards, as under water.
            plot = plot.invert_y(true);
        }
        if ch.name == "heading" {
            plot = plot.y_axis_formatter(crate::plots::heading_tick_label);
        }
        plot.show(ui, |p| {
            for seg in meas {
                p.line(
                    Line::new("measured", PlotPoints::new(seg))
                        .color(theme::VALUE)
                        .width(1.5)
                        .allow_band(false),
                );
            }
            for seg in pred {
                p.line(
                    Line::new("model", PlotPoints::new(seg))
                        .color(theme::PREDICTION)
                        .width(1.5)
                        .allow_band(false),
                );
            }
        });
        ui.add_space(2.0);
    }
}

/// The diagnosis's verdict and its unexplained channels, in words (issue 13): "adequate",
/// "explained by the findings", or which channels are still far from their noise floor and
/// where their misfit lives.
fn verdict_in_words(ui: &mut Ui, diag: &Diagnosis) {
    use rov_lab::verdict::Verdict;
    let (text, color) = match diag.verdict {
        Verdict::Adequate => (
            "Verdict: adequate — every channel is within sensor noise and parameter uncertainty."
                .to_string(),
            theme::GREEN,
        ),
        Verdict::Explained => (
            "Verdict: explained — with the accepted findings every channel is within noise."
                .to_string(),
            theme::GREEN,
        ),
        Verdict::Unexplained => (
            format!(
                "Verdict: unexplained — {} still beyond noise and parameter uncertainty.",
                diag.unexplained
                    .iter()
                    .map(|u| u.channel.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            theme::AMBER,
        ),
    };
    ui.label(RichText::new(text).strong().color(color));
    // One short line; where each misfit lives and what it correlates with on hover (the
    // findings below keep their room).
    if !diag.unexplained.is_empty() {
        let short: Vec<String> = diag
            .unexplained
            .iter()
            .map(|u| format!("{} {:.1}×", u.channel, u.ratio))
            .collect();
        let all: Vec<&str> = diag
            .unexplained
            .iter()
            .map(|u| u.description.as_str())
            .collect();
        ui.label(
            RichText::new(format!(
                "RMSE / noise floor: {} (hover for where the misfit lives)",
                short.join(", ")
            ))
            .small(),
        )
        .on_hover_text(all.join("\n\n"));
    }
    if diag.closed_loop {
        ui.label(RichText::new("The data was recorded in closed loop.").small());
    }
}

#[cfg(test)]
mod wording_tests {
    use super::signed_pct;

    /// Issue 25 item 14: no "-0 %".
    #[test]
    fn no_negative_zero_percent() {
        assert_eq!(signed_pct(-0.3), "0");
        assert_eq!(signed_pct(0.4), "0");
        assert_eq!(signed_pct(-0.0), "0");
        assert_eq!(signed_pct(-12.4), "-12");
        assert_eq!(signed_pct(3.6), "+4");
        assert_eq!(signed_pct(f64::NAN), "---");
    }
}
