//! model3 (Mai et al. 2017): Fossen's 6-DOF equations of the Pro 4 (`rov_dynamics`'
//! process model), with its quadratic thrust maps.

use rov_dynamics::Vector6;
use rov_dynamics::models::{Model3, ModelState, VehicleModel};
use rov_dynamics::process::CurrentSample;
use rov_dynamics::thrusters::ThrustMap;

use super::{BaseKind, BaseModel};
use crate::LabError;
use crate::catalog::EffectId;
use crate::model::LabModel;
use crate::params::{Axis, Param};

pub(super) const NAME: &str = "model3";
pub(super) const HAS_ATTITUDE: bool = true;

/// Effects model3 contains.
pub(super) fn contains(e: EffectId) -> bool {
    super::six_dof_contains(e)
}

/// Effects model3 cannot represent (none: it has every DOF).
pub(super) fn not_applicable(_e: EffectId) -> Option<&'static str> {
    None
}

/// What calibration frees: the Pro 4 set plus roll and pitch damping, the CG height and
/// the sway, roll and pitch added mass.
pub(super) fn calibration_params() -> Vec<Param> {
    // Sway, roll and pitch added mass shape the 6-DOF coupling (heel and yaw in turns);
    // they are not scale-ambiguous like heave and yaw, which stay fixed.
    super::pro4_calibration_params(
        true,
        &[
            Param::DragLin(Axis::Roll),
            Param::DragLin(Axis::Pitch),
            Param::CgZ,
            Param::AddedMass(Axis::Sway),
            Param::AddedMass(Axis::Roll),
            Param::AddedMass(Axis::Pitch),
        ],
    )
}

fn thrust_coefs(map: &ThrustMap) -> (f64, f64) {
    match map {
        ThrustMap::Quadratic(q) => (q.forward.linear_n, q.forward.quadratic_n),
        ThrustMap::Linear(l) => (l.gain_n_per_pct * 100.0, 0.0),
    }
}

/// model3 with the base file's thrust pairs.
#[derive(Debug, Clone)]
pub(in crate::model) struct Model3Base {
    model: Model3,
    pairs: [(f64, f64); 3],
}

impl Model3Base {
    pub fn from_text(text: &str, label: &str) -> Result<Self, LabError> {
        let model: Model3 = super::load_pro4(BaseKind::Model3, text, label)?;
        let t = &model.params().thrusters;
        let pairs = [
            thrust_coefs(&t.port.map),
            thrust_coefs(&t.starboard.map),
            thrust_coefs(&t.vertical.map),
        ];
        Ok(Self { model, pairs })
    }
}

impl BaseModel for Model3Base {
    fn kind(&self) -> BaseKind {
        BaseKind::Model3
    }

    fn rov_model(&self) -> Option<&dyn VehicleModel> {
        Some(&self.model)
    }

    fn thrust_pairs(&self) -> &[(f64, f64)] {
        &self.pairs
    }

    fn weight_n(&self) -> f64 {
        self.model.params().process.hydrostatics.weight_n
    }

    fn nu_active(&self) -> [bool; 6] {
        [true; 6]
    }

    fn applicable(&self, p: Param) -> bool {
        super::pro4_applicable(p, true, true)
    }

    fn get(&self, p: Param) -> Option<f64> {
        super::process_get(&self.model.params().process, p)
    }

    fn drag(&self, a: Axis) -> (f64, f64) {
        super::process_drag(&self.model.params().process, a)
    }

    fn set_many(&mut self, pv: &[(Param, f64)]) -> Result<(), LabError> {
        let mut q = *self.model.params();
        for (p, v) in pv {
            super::process_set(&mut q.process, *p, *v);
        }
        self.model = Model3::new(q).map_err(super::model_error)?;
        Ok(())
    }

    #[inline]
    fn eta_nu_derivative(
        &self,
        lab: &LabModel,
        eta: &Vector6,
        nu: &Vector6,
        tau_thrust: &Vector6,
        current: &CurrentSample,
    ) -> (Vector6, Vector6) {
        let tau = super::with_body_effects(lab, tau_thrust, || ModelState::new(*eta, *nu));
        self.model
            .process()
            .state_derivative(eta, nu, &tau, &lab.effect_current(current))
    }
}
