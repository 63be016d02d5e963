//! A vehicle definition file (`config/vehicles/`, [`rov_dynamics::models::vehicle`]): its
//! own thrusters (positions, directions, curves, lags), command channels and mixer, and
//! Fossen's equations in the DOFs its structure frees.

use rov_dynamics::Vector6;
use rov_dynamics::kinematics::{QuatState, unpack_quat_state};
use rov_dynamics::models::vehicle::{
    ChannelTable, CommandChannel, Commands, MAX_THRUSTERS, Structure, VehicleDef, VehicleDynamics,
};
use rov_dynamics::models::{Channel, ModelState, ThrusterForces};
use rov_dynamics::process::CurrentSample;

use super::{BaseKind, BaseModel, ThrustScales};
use crate::LabError;
use crate::catalog::EffectId;
use crate::model::{LabModel, MAX_SIGNALS, PerThruster, Signals};
use crate::params::{Axis, Documented, Param, Thr};

pub(super) const NAME: &str = "vehicle";
/// A vehicle file may have pitch and roll (its structure decides, see
/// [`VehicleBase::has_attitude`]).
pub(super) const HAS_ATTITUDE: bool = true;

/// Effects a vehicle file contains whatever its structure.
pub(super) fn contains(e: EffectId) -> bool {
    super::six_dof_contains(e)
}

/// Effects no vehicle file can represent.
pub(super) fn not_applicable(e: EffectId) -> Option<&'static str> {
    match e {
        EffectId::PropellerTorque => Some(
            "its parameters are the Pro 4's vertical and horizontal thruster torques; a vehicle file has its own thruster layout",
        ),
        _ => None,
    }
}

/// The calibration set without a file (a file's own: [`VehicleBase::calibration_params`]).
pub(super) fn calibration_params() -> Vec<Param> {
    super::pro4_calibration_params(true, &[])
}

/// A vehicle-file base: the definition (with calibrated process parameters) and its
/// precomputed dynamics.
#[derive(Debug, Clone)]
pub(in crate::model) struct VehicleBase {
    def: VehicleDef,
    dynm: VehicleDynamics,
    /// The command channels some thruster mixes ([`VehicleDef::channels`]), kept so the
    /// simulators' inner loops do not rebuild the list.
    chans: Vec<CommandChannel>,
    n_thr: usize,
    groups: [Thr; MAX_THRUSTERS],
}

impl VehicleBase {
    pub fn from_text(text: &str, label: &str) -> Result<Self, LabError> {
        let def = VehicleDef::parse(text, label)?;
        let dynm = VehicleDynamics::new(&def).map_err(|e| LabError::Model {
            detail: format!("{label}: {e}"),
        })?;
        let n_thr = def.thrusters.len().min(MAX_THRUSTERS);
        let mut groups = [Thr::Horizontal; MAX_THRUSTERS];
        for (g, t) in groups.iter_mut().zip(&def.thrusters) {
            *g = t.group;
        }
        Ok(Self {
            chans: def.channels(),
            def,
            dynm,
            n_thr,
            groups,
        })
    }

    fn six_dof(&self) -> bool {
        self.def.structure == Structure::Fossen6
    }

    fn has_group(&self, g: Thr) -> bool {
        self.groups[..self.n_thr].contains(&g)
    }

    fn has_non_vertical(&self) -> bool {
        self.groups[..self.n_thr]
            .iter()
            .any(|g| *g != Thr::Vertical)
    }

    fn has_quadratic(&self, g: Thr) -> bool {
        self.def
            .thrusters
            .iter()
            .any(|t| t.group == g && t.forward.is_quadratic())
    }
}

impl BaseModel for VehicleBase {
    fn kind(&self) -> BaseKind {
        BaseKind::Vehicle
    }

    fn name(&self) -> &str {
        &self.def.name
    }

    fn vehicle(&self) -> Option<&VehicleDef> {
        Some(&self.def)
    }

    fn thrusters(&self) -> (usize, [Thr; MAX_THRUSTERS]) {
        (self.n_thr, self.groups)
    }

    fn weight_n(&self) -> f64 {
        self.def.process.hydrostatics.weight_n
    }

    fn has_attitude(&self) -> bool {
        self.six_dof()
    }

    fn nu_active(&self) -> [bool; 6] {
        self.def.structure.active()
    }

    fn predicts(&self, ch: Channel) -> bool {
        let a = self.def.structure.active();
        match ch {
            Channel::Pitch | Channel::PitchRate => a[4],
            Channel::Roll | Channel::RollRate => a[3],
            Channel::Sway => a[1],
            _ => true,
        }
    }

    fn uses_quaternion(&self) -> bool {
        // A 6-DOF vehicle file: tank vehicles roll over and pitch past 80°.
        self.six_dof()
    }

    /// Whether the file documents its thruster positions as uncertain, so that the
    /// calibration refits the thrust lines (the moment arms become base parameters).
    fn arms_calibrated(&self) -> bool {
        self.def.uncertainty.thruster_position_m > 0.0 && self.six_dof()
    }

    fn contains(&self, e: EffectId) -> bool {
        match e {
            EffectId::ThrusterMomentArm => self.arms_calibrated(),
            EffectId::PitchDepthCoupling | EffectId::RestoringOffset => {
                self.has_attitude() && contains(e)
            }
            _ => contains(e),
        }
    }

    fn not_applicable(&self, e: EffectId) -> Option<&'static str> {
        if let Some(r) = not_applicable(e) {
            return Some(r);
        }
        if self.has_attitude() {
            return None;
        }
        match e {
            EffectId::RestoringOffset | EffectId::AttitudeBias | EffectId::ThrusterMomentArm => {
                Some(
                    "it acts on pitch and roll, which this vehicle's structure locks (use structure = \"fossen6\")",
                )
            }
            _ => None,
        }
    }

    fn calibration_params(&self) -> Vec<Param> {
        let def = &self.def;
        let mut out = Vec::new();
        for g in def.groups() {
            out.push(Param::ThrustLin(g));
            if self.has_quadratic(g) {
                out.push(Param::ThrustQuad(g));
            }
        }
        let active = def.structure.active();
        for a in Axis::ALL {
            if active[a.index()] {
                out.push(Param::DragLin(a));
                out.push(Param::DragQuad(a));
            }
        }
        if self.six_dof() {
            out.push(Param::CgZ);
            out.push(Param::AddedMass(Axis::Sway));
            out.push(Param::AddedMass(Axis::Roll));
            out.push(Param::AddedMass(Axis::Pitch));
        }
        // The gain setting, when the file says it is not known (it scales every command
        // before the mixer and the non-linear thrust curves).
        if def.uncertainty.command_gain > 0.0 {
            out.push(Param::CommandGain);
        }
        if self.arms_calibrated() {
            for p in [
                Param::ArmZh,
                Param::ArmXv,
                Param::ArmYv,
                Param::ArmXh,
                Param::ArmYh,
            ] {
                if self.applicable(p) {
                    out.push(p);
                }
            }
        }
        out
    }

    fn applicable(&self, p: Param) -> bool {
        let active = self.def.structure.active();
        let six = self.six_dof();
        match p {
            Param::ThrustLin(g) | Param::ReverseRatio(g) | Param::Emi(g) => self.has_group(g),
            Param::ThrustQuad(g) => self.has_quadratic(g),
            Param::DragLin(a) | Param::DragQuad(a) | Param::AddedMass(a) => active[a.index()],
            Param::DragRatio(a) => active[a.index()],
            Param::CgZ | Param::CgX | Param::CgY | Param::BiasRoll | Param::BiasPitch => six,
            // A vehicle's moment arms shift its thrusters from the file's positions: the
            // non-vertical thrusters' height, the vertical ones' x and y.
            Param::ArmZh => six && self.has_non_vertical(),
            Param::ArmXv | Param::ArmYv => six && self.has_group(Thr::Vertical),
            Param::ArmXh | Param::ArmYh => six && self.has_non_vertical(),
            Param::TorqueV | Param::TorqueH => false,
            Param::TrimDeg => !active[4],
            _ => true,
        }
    }

    /// The file's `[uncertainty]` table.
    fn documented(&self, p: Param) -> Option<Documented> {
        let u = &self.def.uncertainty;
        Some(match p {
            Param::ThrustLin(_) | Param::ThrustQuad(_) => Documented::Rel(u.thrust_gain_rel),
            Param::DragLin(_) | Param::DragQuad(_) => Documented::Rel(u.damping_rel),
            Param::AddedMass(_) => Documented::Rel(u.added_mass_rel),
            Param::CgX | Param::CgY | Param::CgZ => Documented::Abs(u.cg_m),
            Param::NetWeight => Documented::Abs(u.net_weight_n),
            Param::CommandGain if u.command_gain > 0.0 => Documented::Abs(u.command_gain),
            _ => return None,
        })
    }

    fn arms_sigma_m(&self) -> Option<f64> {
        Some(self.def.uncertainty.thruster_position_m)
    }

    fn get(&self, p: Param) -> Option<f64> {
        match p {
            Param::CommandGain => Some(self.def.command_gain),
            _ => super::process_get(&self.def.process, p),
        }
    }

    fn drag(&self, a: Axis) -> (f64, f64) {
        super::process_drag(&self.def.process, a)
    }

    fn set_many(&mut self, pv: &[(Param, f64)]) -> Result<(), LabError> {
        let mut q = self.def.process;
        for (p, v) in pv {
            match p {
                Param::CommandGain => self.def.command_gain = *v,
                _ => super::process_set(&mut q, *p, *v),
            }
        }
        let dynm = VehicleDynamics::with_process(&self.def, q).map_err(super::model_error)?;
        self.def.process = q;
        self.dynm = dynm;
        Ok(())
    }

    fn command_channels(&self) -> &[CommandChannel] {
        &self.chans
    }

    fn channel_table(&self) -> &ChannelTable {
        &self.def.channel_table
    }

    fn command_names(&self) -> Vec<&str> {
        self.chans
            .iter()
            .take(MAX_SIGNALS)
            .map(|c| self.def.channel_table.name(*c).unwrap_or("?"))
            .collect()
    }

    #[inline]
    fn command_signals(&self, c: &Commands) -> Signals {
        let mut out = [0.0; MAX_SIGNALS];
        for (o, ch) in out.iter_mut().zip(&self.chans) {
            *o = c.get(ch.index()).copied().unwrap_or(0.0) * 0.01;
        }
        out
    }

    /// The file's mixer.
    #[inline]
    fn thruster_targets(&self, c: &Commands) -> PerThruster {
        let mut out = [0.0; MAX_THRUSTERS];
        let u = self.def.thruster_commands(c);
        for (o, x) in out.iter_mut().zip(u) {
            *o = x * 100.0;
        }
        out
    }

    /// A vehicle file documents no command resolution.
    fn command_resolution_pct(&self) -> Option<f64> {
        None
    }

    fn add_thruster_lags(&self, taus: &mut PerThruster) {
        for (o, t) in taus.iter_mut().zip(&self.def.thrusters) {
            *o += t.lag_s;
        }
    }

    #[inline]
    fn thrust_n(&self, i: usize, pct: f64, s: ThrustScales) -> f64 {
        use rov_dynamics::models::vehicle::ThrustCurve;
        let Some(t) = self.def.thrusters.get(i) else {
            return 0.0;
        };
        match (t.forward, t.reverse) {
            (ThrustCurve::Quadratic(f), ThrustCurve::Quadratic(r)) => s.map(f, r).force_n(pct),
            _ => {
                // A tabulated curve is not quadratic: interpolated in its table.
                let u = pct * 0.01;
                let curve = if u >= 0.0 { &t.forward } else { &t.reverse };
                let (a, b) = curve.parts(u.abs());
                let f = u.signum() * (s.lin * a + s.quad * b);
                if u < 0.0 { f * s.reverse_ratio } else { f }
            }
        }
    }

    /// The file's allocation, plus the moment of thrusters moved by the calibrated arms.
    #[inline]
    fn thrust_tau(&self, lab: &LabModel, f: &PerThruster, _state: &ModelState) -> Vector6 {
        let mut tau = self.dynm.tau(f);
        let x = lab.effect_values();
        if x.arm_zh_m != 0.0
            || x.arm_xv_m != 0.0
            || x.arm_yv_m != 0.0
            || x.arm_xh_m != 0.0
            || x.arm_yh_m != 0.0
        {
            // Moving a thruster by Δr adds Δr × F d to the moment.
            for (i, fi) in f.iter().enumerate().take(self.n_thr) {
                if *fi == 0.0 {
                    continue;
                }
                let d = self.dynm.column(i);
                let dr = if self.groups.get(i) == Some(&Thr::Vertical) {
                    nalgebra::Vector3::new(x.arm_xv_m, x.arm_yv_m, 0.0)
                } else {
                    nalgebra::Vector3::new(x.arm_xh_m, x.arm_yh_m, x.arm_zh_m)
                };
                let m = dr.cross(&nalgebra::Vector3::new(d[0], d[1], d[2])) * *fi;
                tau[3] += m.x;
                tau[4] += m.y;
                tau[5] += m.z;
            }
        }
        tau
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
        let st = ModelState::new(*eta, *nu);
        let tau = tau_thrust + lab.extra_tau(&st);
        let (mut ed, nd) = self
            .dynm
            .state_derivative(eta, nu, &tau, &lab.effect_current(current));
        let trim_rad = lab.effect_values().trim_rad;
        if trim_rad != 0.0 && !self.def.structure.active()[4] {
            let (s, c) = trim_rad.sin_cos();
            ed[2] = nu[2] * c - nu[0] * s;
        }
        (ed, nd)
    }

    fn body_derivative(
        &self,
        lab: &LabModel,
        state: &ModelState,
        tau_thrust: &Vector6,
        current: &CurrentSample,
    ) -> ModelState {
        let (eta, nu) = self.eta_nu_derivative(lab, &state.eta, &state.nu, tau_thrust, current);
        ModelState::new(eta, nu)
    }

    #[inline]
    fn quat_derivative(
        &self,
        lab: &LabModel,
        x: &QuatState,
        tau_thrust: &Vector6,
        current: &CurrentSample,
        yaw_hint_rad: f64,
    ) -> Option<QuatState> {
        let tau = super::with_body_effects(lab, tau_thrust, || {
            let (pose, nu) = unpack_quat_state(x);
            ModelState::new(pose.to_eta(yaw_hint_rad), nu)
        });
        Some(
            self.dynm
                .process()
                .quat_state_derivative(x, &tau, &lab.effect_current(current)),
        )
    }

    /// Group totals for the record (the exact τ comes from `derivative`).
    fn forces_record(&self, f: &PerThruster) -> ThrusterForces {
        let mut out = ThrusterForces::default();
        for (i, fi) in f.iter().enumerate().take(self.n_thr) {
            match self.groups.get(i) {
                Some(Thr::Port) => out.port_n += fi,
                Some(Thr::Starboard) => out.starboard_n += fi,
                Some(Thr::Vertical) => out.vertical_n += fi,
                _ => {}
            }
        }
        out
    }

    /// A vehicle's τ does not come from the three-group record.
    fn tau_of_record(&self, _lab: &LabModel, _f: &PerThruster, _state: &ModelState) -> Vector6 {
        Vector6::zeros()
    }
}
