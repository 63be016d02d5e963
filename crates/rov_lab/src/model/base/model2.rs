//! model2 (Arnesen 2016): Fossen's equations in surge, heave and yaw, with linear thrust
//! gains (no quadratic thrust part to calibrate).

use rov_dynamics::models::{Model2, VehicleModel};

use super::{BaseKind, BaseModel, PLANAR_NU};
use crate::LabError;
use crate::catalog::EffectId;
use crate::params::{Axis, Param};

pub(super) const NAME: &str = "model2";
pub(super) const HAS_ATTITUDE: bool = false;

/// Effects model2 contains.
pub(super) fn contains(e: EffectId) -> bool {
    matches!(
        e,
        EffectId::AddedMass | EffectId::NetBuoyancy | EffectId::Coriolis
    )
}

/// Effects model2 cannot represent.
pub(super) fn not_applicable(e: EffectId) -> Option<&'static str> {
    super::pro4_planar_not_applicable(e)
}

/// What calibration frees (no quadratic thrust scales: the gains are linear).
pub(super) fn calibration_params() -> Vec<Param> {
    super::pro4_calibration_params(false, &[])
}

/// model2 with the base file's thrust gains as (linear, quadratic) pairs.
#[derive(Debug, Clone)]
pub(in crate::model) struct Model2Base {
    model: Model2,
    pairs: [(f64, f64); 3],
}

impl Model2Base {
    pub fn from_text(text: &str, label: &str) -> Result<Self, LabError> {
        let model: Model2 = super::load_pro4(BaseKind::Model2, text, label)?;
        let p = model.params();
        let pairs = [
            (p.g1_n_per_pct * 100.0, 0.0),
            (p.g1_n_per_pct * 100.0, 0.0),
            (p.g2_n_per_pct * 100.0, 0.0),
        ];
        Ok(Self { model, pairs })
    }
}

impl BaseModel for Model2Base {
    fn kind(&self) -> BaseKind {
        BaseKind::Model2
    }

    fn rov_model(&self) -> Option<&dyn VehicleModel> {
        Some(&self.model)
    }

    fn thrust_pairs(&self) -> &[(f64, f64)] {
        &self.pairs
    }

    fn weight_n(&self) -> f64 {
        self.model.params().weight_n
    }

    fn nu_active(&self) -> [bool; 6] {
        PLANAR_NU
    }

    fn applicable(&self, p: Param) -> bool {
        super::pro4_applicable(p, false, false)
    }

    fn get(&self, p: Param) -> Option<f64> {
        let q = self.model.params();
        match p {
            Param::DragLin(a) => Some(self.drag(a).0),
            Param::DragQuad(a) => Some(self.drag(a).1),
            Param::NetWeight => Some(q.weight_n - q.buoyancy_n),
            Param::AddedMass(a) => match a {
                Axis::Surge => Some(-q.x_udot_kg),
                Axis::Heave => Some(-q.z_wdot_kg),
                Axis::Yaw => Some(-q.n_rdot_kgm2),
                _ => None,
            },
            _ => None,
        }
    }

    fn drag(&self, a: Axis) -> (f64, f64) {
        let p = self.model.params();
        match a {
            Axis::Surge => (-p.x_u, -p.x_uu),
            Axis::Heave => (-p.z_w, -p.z_ww),
            _ => (-p.n_r, -p.n_rr),
        }
    }

    fn set_many(&mut self, pv: &[(Param, f64)]) -> Result<(), LabError> {
        let mut q = *self.model.params();
        for (p, v) in pv {
            let v = *v;
            match p {
                Param::DragLin(a) | Param::DragQuad(a) => {
                    let slot = match (a, matches!(p, Param::DragLin(_))) {
                        (Axis::Surge, true) => &mut q.x_u,
                        (Axis::Surge, false) => &mut q.x_uu,
                        (Axis::Heave, true) => &mut q.z_w,
                        (Axis::Heave, false) => &mut q.z_ww,
                        (_, true) => &mut q.n_r,
                        (_, false) => &mut q.n_rr,
                    };
                    *slot = -v;
                }
                Param::NetWeight => q.buoyancy_n = q.weight_n - v,
                Param::AddedMass(a) => match a {
                    Axis::Surge => q.x_udot_kg = -v,
                    Axis::Heave => q.z_wdot_kg = -v,
                    _ => q.n_rdot_kgm2 = -v,
                },
                _ => {}
            }
        }
        self.model = Model2::new(q);
        Ok(())
    }
}
