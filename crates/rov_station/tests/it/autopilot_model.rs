//! The station's autopilot model: set from the configuration (`--model FILE`,
//! `[autopilot] model`), changed at run time (the GUI's "Use for autopilot"), refused
//! while armed unless confirmed, and a bad plant leaves the previous model in place.

use rov_control::{ModelChoice, PlantModel};
use rov_station::AutopilotModel;
use rov_station::runtime::{RuntimeCommand, RuntimeConfig, StationHandle, VirtualStation};

fn weak_reverse(label: &str) -> AutopilotModel {
    let mut plant = PlantModel::load_default(ModelChoice::Model3).unwrap();
    plant.vertical.reverse.linear_n *= 0.5;
    plant.vertical.reverse.quadratic_n *= 0.5;
    plant.vertical_path.lag_tau_s = 0.3;
    AutopilotModel {
        label: label.into(),
        plant,
    }
}

fn set(h: &StationHandle, model: Option<AutopilotModel>, confirmed: bool) {
    h.command(RuntimeCommand::AutopilotModel {
        model: model.map(Box::new),
        confirmed,
    });
}

#[test]
fn the_autopilot_model_is_configured_changed_and_kept_on_a_bad_one() {
    let _alone = crate::one_at_a_time();
    let cfg = RuntimeConfig {
        gamepad: false,
        autopilot_model: Some(weak_reverse("learned.toml")),
        ..RuntimeConfig::default()
    };
    let (mut st, h) = VirtualStation::new(cfg).unwrap();
    st.advance(2.0).unwrap();
    assert_eq!(h.view().model_label, "learned.toml");

    // A plant that does not validate: refused, the previous model stays.
    let mut bad = weak_reverse("bad.toml");
    bad.plant.heave.inertia = f64::NAN;
    set(&h, Some(bad), false);
    st.advance(0.2).unwrap();
    let v = h.view();
    assert_eq!(v.model_label, "learned.toml");
    let refusal = v.last_refusal.unwrap_or_default();
    assert!(refusal.contains("heave.inertia"), "{refusal}");

    // Back to the configured shipped model, then a file again.
    set(&h, None, false);
    st.advance(0.2).unwrap();
    assert_eq!(h.view().model_label, "model3");
    set(&h, Some(weak_reverse("other.toml")), false);
    st.advance(0.2).unwrap();
    assert_eq!(h.view().model_label, "other.toml");

    // Armed: refused unless confirmed.
    for _ in 0..12 {
        h.command(RuntimeCommand::ArmButton(true));
        st.advance(0.1).unwrap();
    }
    h.command(RuntimeCommand::ArmButton(false));
    st.advance(0.1).unwrap();
    assert!(h.view().snapshot.armed);
    set(&h, Some(weak_reverse("while-armed.toml")), false);
    st.advance(0.2).unwrap();
    let v = h.view();
    assert_eq!(v.model_label, "other.toml");
    assert!(v.last_refusal.unwrap_or_default().contains("armed"));
    set(&h, Some(weak_reverse("confirmed.toml")), true);
    st.advance(0.2).unwrap();
    assert_eq!(h.view().model_label, "confirmed.toml");
}
