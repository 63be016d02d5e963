//! model1 (Enevoldsen et al. 2018): decoupled surge, heave and yaw. Its thrust factors α
//! scale the lab's body forces into its equations; it has no buoyancy of its own, so the
//! lab carries its net weight W − B as a body force (the `net-buoyancy` effect).

use rov_dynamics::models::{Model1, VehicleModel};
use rov_dynamics::plant::PlantDescription;

use super::{BaseKind, BaseModel, PLANAR_NU};
use crate::LabError;
use crate::catalog::EffectId;
use crate::params::{Axis, Param};

pub(super) const NAME: &str = "model1";
pub(super) const HAS_ATTITUDE: bool = false;

/// Effects model1 contains.
pub(super) fn contains(e: EffectId) -> bool {
    matches!(e, EffectId::AddedMass)
}

/// Effects model1 cannot represent.
pub(super) fn not_applicable(e: EffectId) -> Option<&'static str> {
    super::pro4_planar_not_applicable(e)
}

/// What calibration frees.
pub(super) fn calibration_params() -> Vec<Param> {
    super::pro4_calibration_params(true, &[])
}

/// model1 with the base file's thrust pairs and the lab's net weight.
#[derive(Debug, Clone)]
pub(in crate::model) struct Model1Base {
    model: Model1,
    /// (linear, quadratic) forward thrust per thruster, N.
    pairs: [(f64, f64); 3],
    /// W − B carried by the lab, N.
    net_weight_n: f64,
}

impl Model1Base {
    pub fn from_text(text: &str, label: &str) -> Result<Self, LabError> {
        let model: Model1 = super::load_pro4(BaseKind::Model1, text, label)?;
        let p = model.params();
        let f = |q: &rov_dynamics::thrusters::QuadraticThrustMap| {
            (q.forward.linear_n, q.forward.quadratic_n)
        };
        let pairs = [f(&p.port), f(&p.starboard), f(&p.vertical)];
        Ok(Self {
            model,
            pairs,
            net_weight_n: 0.0,
        })
    }

    fn added_mass(&self, a: Axis) -> Option<f64> {
        let p = self.model.params();
        let (beta, inertia) = match a {
            Axis::Surge => (p.beta[0], p.mass_kg),
            Axis::Heave => (p.beta[1], p.mass_kg),
            Axis::Yaw => (p.beta[2], p.yaw_inertia_kgm2),
            _ => return None,
        };
        Some(inertia / beta - inertia)
    }
}

impl BaseModel for Model1Base {
    fn kind(&self) -> BaseKind {
        BaseKind::Model1
    }

    fn rov_model(&self) -> Option<&dyn VehicleModel> {
        Some(&self.model)
    }

    fn thrust_pairs(&self) -> &[(f64, f64)] {
        &self.pairs
    }

    fn drag_tau_factor(&self) -> [f64; 6] {
        let a = self.model.params().alpha;
        let mut f = [1.0; 6];
        f[0] = 1.0 / a[0];
        f[2] = 1.0 / a[1];
        f[5] = 1.0 / a[2];
        f
    }

    fn weight_n(&self) -> f64 {
        self.model.params().mass_kg * 9.81
    }

    fn nu_active(&self) -> [bool; 6] {
        PLANAR_NU
    }

    fn applicable(&self, p: Param) -> bool {
        super::pro4_applicable(p, false, true)
    }

    fn get(&self, p: Param) -> Option<f64> {
        match p {
            Param::DragLin(a) => Some(self.drag(a).0),
            Param::DragQuad(a) => Some(self.drag(a).1),
            Param::NetWeight => Some(self.net_weight_n),
            Param::AddedMass(a) => self.added_mass(a),
            _ => None,
        }
    }

    fn drag(&self, a: Axis) -> (f64, f64) {
        let p = self.model.params();
        let d = match a {
            Axis::Surge => p.surge_drag,
            Axis::Heave => p.heave_drag,
            _ => p.yaw_drag,
        };
        (d.linear, d.quadratic)
    }

    fn set_many(&mut self, pv: &[(Param, f64)]) -> Result<(), LabError> {
        let mut q = *self.model.params();
        for (p, v) in pv {
            let v = *v;
            match p {
                Param::DragLin(a) | Param::DragQuad(a) => {
                    let d = match a {
                        Axis::Surge => &mut q.surge_drag,
                        Axis::Heave => &mut q.heave_drag,
                        _ => &mut q.yaw_drag,
                    };
                    if matches!(p, Param::DragLin(_)) {
                        d.linear = v;
                    } else {
                        d.quadratic = v;
                    }
                }
                Param::NetWeight => self.net_weight_n = v,
                Param::AddedMass(a) => {
                    let (k, inertia) = match a {
                        Axis::Surge => (0, q.mass_kg),
                        Axis::Heave => (1, q.mass_kg),
                        _ => (2, q.yaw_inertia_kgm2),
                    };
                    q.beta[k] = inertia / (inertia + v);
                }
                _ => {}
            }
        }
        self.model = Model1::new(q);
        Ok(())
    }

    fn lab_heave_force_n(&self) -> f64 {
        self.net_weight_n
    }

    fn plant(&self) -> Option<PlantDescription> {
        let mut d = self.model.plant()?;
        d.heave.static_load += self.net_weight_n;
        Some(d)
    }
}
