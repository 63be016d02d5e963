//! Issue 14, "In the GUI": the autopilot's model chosen from the autopilot panel's list
//! (shipped models and the models folder's files) and from the Model lab ("Use for
//! autopilot"), refused while armed unless the pilot holds the confirm button.

use crate::common;

use common::{FRAME_S, rig, tmp};
use rov_gui::Tab;
use rov_gui::autopilot_model::SwitchResult;
use rov_lab::{BaseKind, LabModel};

fn result(r: &common::Rig) -> Option<SwitchResult> {
    r.harness.state().model_switch_result().cloned()
}

/// A model file placed in the models folder is offered in the autopilot panel's list;
/// picking it makes it the autopilot's model (the Fly tab names it).
#[test]
fn the_models_folder_lists_a_file_and_picking_it_switches_the_autopilot() {
    let dir = tmp("models_folder");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let shipped = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../config/models/model2.toml"
    );
    std::fs::copy(shipped, dir.join("learned_gui.toml")).unwrap();
    std::fs::write(dir.join("notes.txt"), "not a model").unwrap();
    std::fs::write(dir.join("broken.toml"), "base = \"model9\"\n").unwrap();

    let mut r = rig("models_folder.mcap");
    r.harness.state_mut().set_models_dir(Some(dir.clone()));
    let files = r.harness.state().model_files().to_vec();
    assert_eq!(
        files,
        vec![dir.join("broken.toml"), dir.join("learned_gui.toml")],
        "only *.toml files, sorted"
    );
    r.run(1.0);
    let before = r.view().model_label;
    assert!(!before.contains("learned_gui"), "{before}");
    assert!(!r.has_label_containing("learned_gui.toml"));

    // Open the list: the shipped models and the file.
    r.click("model");
    for m in ["model1", "model2", "model3", "learned_gui.toml"] {
        assert!(r.has_label_containing(m), "{m} not offered");
    }
    r.snapshot("autopilot_model_list");
    // A file that is not a model is refused with its name; the model stays.
    r.click("broken.toml");
    r.run(0.3);
    assert_eq!(r.view().model_label, before);
    assert!(
        matches!(result(&r), Some(SwitchResult::Refused(ref t)) if t.contains("broken.toml")),
        "{:?}",
        result(&r)
    );
    r.click("model");
    r.click("learned_gui.toml");
    r.run(0.3);
    let label = r.view().model_label;
    assert!(label.ends_with("learned_gui.toml"), "{label}");
    assert!(
        matches!(result(&r), Some(SwitchResult::Accepted(ref t)) if t.contains("learned_gui")),
        "{:?}",
        result(&r)
    );
    // The Fly tab names the model in use (the panel shows the file name).
    assert!(r.has_label_containing("learned_gui.toml"));
    std::fs::remove_dir_all(&dir).unwrap();
}

fn lab_rig(name: &str) -> common::Rig {
    let mut r = rig(name);
    r.run(1.0);
    let lab = r.harness.state_mut().lab_mut();
    lab.kind = BaseKind::Model2;
    lab.model = Some(LabModel::default_base(BaseKind::Model2).unwrap());
    r
}

/// Disarmed, "Use for autopilot" makes the lab's model the autopilot's model.
#[test]
fn use_for_autopilot_while_disarmed_switches_the_model() {
    let mut r = lab_rig("use_disarmed.mcap");
    let before = r.view().model_label;
    assert_ne!(before, "lab model2");
    r.harness.state_mut().set_tab(Tab::Lab);
    r.run(FRAME_S);
    r.click("Use for autopilot");
    r.run(0.3);
    assert_eq!(r.view().model_label, "lab model2");
    assert!(
        matches!(result(&r), Some(SwitchResult::Accepted(_))),
        "{:?}",
        result(&r)
    );
    assert!(r.has_label_containing("accepted: autopilot model: lab model2"));
    // The Fly tab's autopilot panel names it.
    r.harness.state_mut().set_tab(Tab::Fly);
    r.run(FRAME_S);
    assert!(r.has_label_containing("lab model2"));
}

/// Armed, a plain click is refused (the model stays) and holding the confirm button
/// for a second switches it; a short hold does not.
#[test]
fn use_for_autopilot_while_armed_needs_hold_to_confirm() {
    let mut r = lab_rig("use_armed.mcap");
    r.arm();
    let before = r.view().model_label;
    r.harness.state_mut().set_tab(Tab::Lab);
    r.run(FRAME_S);
    r.click("Use for autopilot");
    r.run(0.3);
    assert!(r.view().snapshot.armed);
    assert_eq!(r.view().model_label, before, "a plain click while armed");
    assert!(
        matches!(result(&r), Some(SwitchResult::Refused(ref t)) if t.contains("armed")),
        "{:?}",
        result(&r)
    );
    // A short hold does nothing.
    let p = r.centre("HOLD TO CONFIRM");
    r.press(p, true);
    r.run(0.4);
    r.press(p, false);
    r.run(0.3);
    assert_eq!(r.view().model_label, before, "a 0.4 s hold");
    // A full hold confirms.
    r.press(p, true);
    r.run(0.6);
    r.snapshot_here("lab_hold_to_confirm");
    r.run(0.6);
    r.press(p, false);
    r.run(0.3);
    assert_eq!(r.view().model_label, "lab model2");
    assert!(r.view().snapshot.armed, "the switch does not disarm");
    assert!(
        matches!(result(&r), Some(SwitchResult::Accepted(_))),
        "{:?}",
        result(&r)
    );
}
