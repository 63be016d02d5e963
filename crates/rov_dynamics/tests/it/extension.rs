//! The pipeline is extensible: a model-lab style wrapper adds a first-order thruster lag
//! (three extra states) to a base model by overriding stage (a) and the extra dynamics,
//! delegating everything else.

use std::any::Any;

use rov_dynamics::control_plant::ControlPlantModel;
use rov_dynamics::models::{
    Channel, Environment, InitialConditions, Model3, ModelState, ThrusterForces, VehicleModel,
    advance, load_default_model,
};
use rov_dynamics::process::CurrentSample;
use rov_dynamics::{ThrustPct, Vector6};

#[derive(Debug, Clone)]
struct ThrusterLag {
    base: Box<dyn VehicleModel>,
    time_constant_s: f64,
}

impl VehicleModel for ThrusterLag {
    fn name(&self) -> &str {
        "model3+thruster-lag"
    }
    fn predicts(&self, ch: Channel) -> bool {
        self.base.predicts(ch)
    }
    fn thruster_forces(&self, _cmd: &ThrustPct, state: &ModelState) -> ThrusterForces {
        let lagged = ThrustPct::new(state.extra[0], state.extra[1], state.extra[2]);
        self.base.thruster_forces(&lagged, state)
    }
    fn generalized_force(&self, forces: &ThrusterForces, state: &ModelState) -> Vector6 {
        self.base.generalized_force(forces, state)
    }
    fn dynamics(&self, state: &ModelState, tau: &Vector6, current: &CurrentSample) -> ModelState {
        self.base.dynamics(state, tau, current)
    }
    fn n_extra_states(&self) -> usize {
        3
    }
    fn extra_dynamics(&self, _t: f64, state: &ModelState, cmd: &ThrustPct, deriv: &mut ModelState) {
        let target = [cmd.port, cmd.starboard, cmd.vertical];
        for (i, u) in target.iter().enumerate() {
            deriv.extra[i] = (u - state.extra[i]) / self.time_constant_s;
        }
    }
    fn clone_box(&self) -> Box<dyn VehicleModel> {
        Box::new(self.clone())
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
}

#[test]
fn thruster_lag_extension_delays_the_response_with_the_same_steady_state() {
    let base = load_default_model("model3").unwrap();
    let lagged = ThrusterLag {
        base: base.clone(),
        time_constant_s: 0.5,
    };
    let cmd = ThrustPct::new(0.0, 0.0, 80.0);
    let x0 = base.initial_state(&InitialConditions::at_rest(2.0, 0.0));
    let env = Environment::calm();
    let early_base = advance(base.as_ref(), &x0, 0.0, 0.3, &cmd, 0.01, &env).unwrap();
    let early_lag = advance(&lagged, &x0, 0.0, 0.3, &cmd, 0.01, &env).unwrap();
    assert!(
        early_lag.nu[2] < 0.5 * early_base.nu[2],
        "lag slows the start"
    );
    assert!((early_lag.extra[2] - 80.0 * (1.0 - (-0.3_f64 / 0.5).exp())).abs() < 1e-6);
    let late_base = advance(base.as_ref(), &x0, 0.0, 30.0, &cmd, 0.01, &env).unwrap();
    let late_lag = advance(&lagged, &x0, 0.0, 30.0, &cmd, 0.01, &env).unwrap();
    assert!((late_lag.nu[2] - late_base.nu[2]).abs() < 1e-6);
}

#[test]
fn control_plant_model_from_model3() {
    let base = load_default_model("model3").unwrap();
    let m3 = base.as_any().downcast_ref::<Model3>().unwrap();
    let cpm = ControlPlantModel::from_process(m3.process(), Vector6::repeat(300.0)).unwrap();
    // G = diag(0, 0, 0, W BG, W BG, 0) for the neutral Pro 4 with BG = 5.59 mm.
    let w_bg = 6.1 * 9.81 * 0.00559;
    assert!((cpm.restoring()[(3, 3)] - w_bg).abs() < 1e-12);
    assert!((cpm.restoring()[(4, 4)] - w_bg).abs() < 1e-12);
    assert!(
        cpm.restoring()[(2, 2)] == 0.0,
        "no heave stiffness when submerged"
    );
    let depth = cpm.depth_channel();
    assert!((depth.a[(1, 1)] + 4.8 / (6.1 + 5.0)).abs() < 1e-12);
    assert!((depth.b[1] - 1.0 / 11.1).abs() < 1e-12);
    let heading = cpm
        .heading_channel()
        .discretize(0.02, &nalgebra::Vector3::new(0.0, 1e-4, 1e-6))
        .unwrap();
    assert!((heading.a[(0, 1)] - 0.02).abs() < 1e-3, "psi integrates r");
    assert!(heading.q[(2, 2)] > 0.0);
}
