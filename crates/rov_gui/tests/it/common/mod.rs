//! The GUI test rig shared by the test files: an app on a `VirtualStation` (the real
//! engine on virtual time, seeded) behind an ordinary `StationHandle`; the test is the
//! clock, so every frame is deterministic. New connections made from the GUI start more
//! virtual stations, stepped with the first.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, channel};
use std::sync::{Arc, Mutex};

use egui::{Event, Modifiers, PointerButton, Pos2, vec2};
use egui_kittest::Harness;
use egui_kittest::kittest::{NodeT, Queryable};
use rov_gui::{AutodetectResult, Backend, StationApp};
use rov_station::runtime::{
    Connection, RuntimeConfig, RuntimeError, StationHandle, StationView, VirtualReplay,
    VirtualStation,
};

/// Station frames per GUI frame: 50 ms of virtual time.
pub const FRAME_S: f64 = 0.05;

#[derive(Default, Clone)]
pub struct Shared {
    pub replays: Arc<Mutex<Vec<VirtualReplay>>>,
    pub stations: Arc<Mutex<Vec<VirtualStation>>>,
    pub recordings: Arc<Mutex<u32>>,
    /// What the file dialogs answer next (None: cancelled).
    pub dialog: Arc<Mutex<Option<PathBuf>>>,
    /// Answers of the dialogs after `dialog`'s, in order (a flow that opens two dialogs);
    /// when both are empty a dialog is cancelled.
    pub dialogs: Arc<Mutex<std::collections::VecDeque<Option<PathBuf>>>>,
}

pub struct TestBackend {
    pub shared: Shared,
    pub rec: PathBuf,
}

pub fn config() -> RuntimeConfig {
    RuntimeConfig {
        gamepad: false,
        ..RuntimeConfig::default()
    }
}

impl Backend for TestBackend {
    fn connect(&mut self, c: &Connection) -> Result<StationHandle, RuntimeError> {
        match c {
            Connection::Sim => {
                let (st, h) = VirtualStation::new(config())?;
                self.shared.stations.lock().unwrap().push(st);
                Ok(h)
            }
            Connection::Serial(p) => Err(RuntimeError::Transport(
                rov_driver::TransportError::Unsupported(format!(
                    "{p}: no serial ports in this test"
                )),
            )),
        }
    }

    fn open_replay(&mut self, path: &Path) -> Result<StationHandle, RuntimeError> {
        let (r, h) = VirtualReplay::open(path)?;
        self.shared.replays.lock().unwrap().push(r);
        Ok(h)
    }

    fn ports(&mut self) -> Vec<String> {
        vec!["/dev/ttyUSB0".into(), "/dev/ttyS0".into()]
    }

    fn autodetect(&mut self, ports: Vec<String>) -> Receiver<AutodetectResult> {
        let (tx, rx) = channel();
        let _ = tx.send(AutodetectResult {
            found: None,
            tried: ports
                .into_iter()
                .map(|p| (p, Some("no response".into())))
                .collect(),
        });
        rx
    }

    fn recordings_dir(&self) -> PathBuf {
        self.rec.parent().unwrap().to_path_buf()
    }

    fn pick_file(&mut self, _title: &str, _ext: &[&str]) -> Option<PathBuf> {
        let first = self.shared.dialog.lock().unwrap().take();
        first.or_else(|| self.shared.dialogs.lock().unwrap().pop_front().flatten())
    }

    fn save_file(&mut self, _title: &str, _name: &str) -> Option<PathBuf> {
        self.shared.dialog.lock().unwrap().take()
    }

    fn pick_folder(&mut self, _title: &str) -> Option<PathBuf> {
        self.shared.dialog.lock().unwrap().take()
    }

    fn recording_path(&mut self) -> PathBuf {
        // The first recording takes the rig's name, later ones a numbered name.
        let mut n = self.shared.recordings.lock().unwrap();
        *n += 1;
        if *n == 1 {
            self.rec.clone()
        } else {
            let stem = self.rec.file_stem().unwrap().to_string_lossy().into_owned();
            self.rec.with_file_name(format!("{stem}-{n}.mcap"))
        }
    }
}

pub struct Rig {
    pub st: VirtualStation,
    pub harness: Harness<'static, StationApp>,
    pub shared: Shared,
}

pub fn tmp(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("rov_gui_tests");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

pub fn rig(rec_name: &str) -> Rig {
    rig_sized(rec_name, vec2(1280.0, 800.0))
}

pub fn rig_sized(rec_name: &str, size: egui::Vec2) -> Rig {
    rig_config(rec_name, size, config())
}

/// A rig on a station of the given configuration (e.g. with the sim camera).
pub fn rig_config(rec_name: &str, size: egui::Vec2, cfg: RuntimeConfig) -> Rig {
    let (st, handle) = VirtualStation::new(cfg).unwrap();
    let shared = Shared::default();
    let rec = tmp(rec_name);
    let _ = std::fs::create_dir_all(rec.parent().unwrap());
    let _ = std::fs::remove_file(&rec);
    let backend = TestBackend {
        shared: shared.clone(),
        rec,
    };
    let app = StationApp::new(Box::new(backend), Some(handle));
    let harness = Harness::builder()
        .with_size(size)
        .with_step_dt(FRAME_S as f32)
        .build_ui_state(|ui, app: &mut StationApp| app.ui(ui), app);
    Rig {
        st,
        harness,
        shared,
    }
}

impl Rig {
    /// Advances the station and the GUI by `secs` in frames of 50 ms.
    pub fn run(&mut self, secs: f64) {
        let n = (secs / FRAME_S).round() as usize;
        // GUI frame first (it sends the commands of this frame), then the station.
        for _ in 0..n.max(1) {
            self.harness.step();
            self.st.advance(FRAME_S).unwrap();
            for s in self.shared.stations.lock().unwrap().iter_mut() {
                s.advance(FRAME_S).unwrap();
            }
            for r in self.shared.replays.lock().unwrap().iter_mut() {
                r.advance(FRAME_S);
            }
        }
        // One more frame so the GUI shows the latest state.
        self.harness.step();
    }

    pub fn view(&self) -> StationView {
        self.harness.state().live_view().clone()
    }

    pub fn click(&mut self, label: &str) {
        self.click_nth(label, 0);
    }

    /// Hovers for a frame, then clicks (a click right after the pointer left the window
    /// is not taken by egui).
    pub fn click_nth(&mut self, label: &str, n: usize) {
        let node = self.harness.get_all_by_label(label).nth(n);
        let node = node.unwrap_or_else(|| panic!("no {label:?} #{n}"));
        node.hover();
        self.harness.step();
        self.harness.get_all_by_label(label).nth(n).unwrap().click();
        self.run(FRAME_S);
    }

    /// Clicks the first widget whose label contains `text`.
    pub fn click_containing(&mut self, text: &str) {
        let node = self.harness.query_all_by_label_contains(text).next();
        let node = node.unwrap_or_else(|| panic!("no label containing {text:?}"));
        node.hover();
        self.harness.step();
        self.harness
            .query_all_by_label_contains(text)
            .next()
            .unwrap()
            .click();
        self.run(FRAME_S);
    }

    /// Whether some widget's label contains `text`.
    pub fn has_label_containing(&self, text: &str) -> bool {
        self.harness
            .query_all_by_label_contains(text)
            .next()
            .is_some()
    }

    /// Labels containing `text`.
    pub fn labels_containing(&self, text: &str) -> Vec<String> {
        self.harness
            .query_all_by_label_contains(text)
            .map(|n| {
                let node = n.accesskit_node();
                node.label()
                    .filter(|l| !l.is_empty())
                    .or_else(|| node.value())
                    .unwrap_or_default()
            })
            .collect()
    }

    pub fn centre(&self, label: &str) -> Pos2 {
        self.harness.get_by_label(label).rect().center()
    }

    pub fn press(&mut self, pos: Pos2, pressed: bool) {
        self.harness.event(Event::PointerMoved(pos));
        self.harness.event(Event::PointerButton {
            pos,
            button: PointerButton::Primary,
            pressed,
            modifiers: Modifiers::default(),
        });
    }

    /// Hold to arm with the mouse: press, 1.2 s of frames, release.
    pub fn arm(&mut self) {
        let p = self.centre("HOLD TO ARM");
        self.press(p, true);
        self.run(0.5);
        assert!(
            self.view().pilot.arm_progress > 0.3,
            "{:?}",
            self.view().pilot
        );
        assert!(!self.view().snapshot.armed);
        self.run(0.7);
        self.press(p, false);
        self.run(0.1);
        assert!(self.view().snapshot.armed, "{:#?}", self.view());
    }

    /// Snapshot with the pointer where it is (e.g. holding a button).
    pub fn snapshot_here(&mut self, name: &str) {
        self.harness.snapshot(name);
    }

    /// Snapshot with a region masked (machine-dependent text such as a path).
    pub fn snapshot_masked(&mut self, name: &str, rect: egui::Rect) {
        self.harness.event(Event::PointerGone);
        self.harness.step();
        self.harness.mask(rect);
        self.harness.snapshot(name);
    }

    pub fn snapshot(&mut self, name: &str) {
        // Park the pointer outside the window so no hover effect is captured.
        self.harness.event(Event::PointerGone);
        self.harness.step();
        for r in self.volatile_rects() {
            self.harness.mask(r);
        }
        self.harness.snapshot(name);
    }

    /// What depends on the machine or the wall clock: the session browser's folder and
    /// dates (masked in snapshots).
    pub fn volatile_rects(&self) -> Vec<egui::Rect> {
        let mut out: Vec<egui::Rect> = self
            .harness
            .query_all_by_label_contains("20")
            .filter(|n| {
                let node = n.accesskit_node();
                let l = node
                    .label()
                    .filter(|l| !l.is_empty())
                    .or_else(|| node.value());
                l.is_some_and(|l| l.len() == 16 && l.as_bytes().get(4) == Some(&b'-'))
            })
            .map(|n| n.rect())
            .collect();
        // To the right edge: a folder's width depends on where the repository is checked
        // out, so a mask of the label's own width would not match. An import's line names
        // the map's path.
        for text in ["Recordings in", "read through the log map"] {
            out.extend(self.harness.query_all_by_label_contains(text).map(|n| {
                let r = n.rect();
                egui::Rect::from_min_max(r.min, egui::pos2(r.min.x + 4000.0, r.max.y))
            }));
        }
        out
    }

    /// Types into the text field labelled `label`.
    pub fn type_into(&mut self, label: &str, text: &str) {
        let field = self
            .harness
            .query_all(
                egui_kittest::kittest::By::new()
                    .label(label)
                    .role(egui::Role::TextInput),
            )
            .next()
            .unwrap_or_else(|| panic!("no text field {label:?}"))
            .rect()
            .center();
        self.harness.event(Event::PointerMoved(field));
        self.press(field, true);
        self.press(field, false);
        self.run(FRAME_S);
        self.harness.event(Event::Text(text.into()));
        self.run(FRAME_S);
    }

    /// The message line of the app.
    pub fn message(&self) -> Option<String> {
        self.harness.state().message().map(str::to_string)
    }
}

/// Counts pixels within `tol` of a colour inside `rect` (logical points, scale 1).
pub fn count_colour(img: &image::RgbaImage, rect: egui::Rect, rgb: [u8; 3], tol: i32) -> usize {
    let mut n = 0;
    for y in rect.min.y.max(0.0) as u32..(rect.max.y as u32).min(img.height()) {
        for x in rect.min.x.max(0.0) as u32..(rect.max.x as u32).min(img.width()) {
            let p = img.get_pixel(x, y).0;
            if (0..3).all(|i| (i32::from(p[i]) - i32::from(rgb[i])).abs() <= tol) {
                n += 1;
            }
        }
    }
    n
}
