//! [`LabModel`] as a [`VehicleModel`]: what `sim`, `hold` and the autopilot see.

use std::any::Any;

use rov_dynamics::Vector6;
use rov_dynamics::models::vehicle::MAX_THRUSTERS;
use rov_dynamics::models::{
    Channel, Environment, InitialConditions, ModelOutput, ModelState, ThrusterForces, VehicleModel,
};
use rov_dynamics::plant::{PathEffects, PlantDescription};
use rov_dynamics::process::CurrentSample;
use rov_dynamics::thrusters::{QuadraticThrustMap, ThrustPair, ThrustPct};

use super::{LabModel, MAX_SIGNALS};
use crate::terms::FILTER_TAUS_S;

impl LabModel {
    /// Extra states of the [`VehicleModel`] form: lags of the thrusters, then the filters.
    fn n_lag_states(&self) -> usize {
        if self.lag_on() { self.n_thr } else { 0 }
    }
}

impl VehicleModel for LabModel {
    fn name(&self) -> &str {
        &self.name
    }

    fn predicts(&self, ch: Channel) -> bool {
        self.predicts_channel(ch)
    }

    fn thruster_forces(&self, cmd: &ThrustPct, state: &ModelState) -> ThrusterForces {
        let c = Self::commands_of(cmd);
        let mut targets = self.thruster_targets(&c);
        if self.lag_on() {
            for (i, t) in targets.iter_mut().enumerate().take(self.n_thr) {
                *t = state.extra.get(i).copied().unwrap_or(*t);
            }
        }
        self.base.model().forces_record(&self.thrusts(&targets))
    }

    fn generalized_force(&self, forces: &ThrusterForces, state: &ModelState) -> Vector6 {
        let mut f = [0.0; MAX_THRUSTERS];
        f[0] = forces.port_n;
        f[1] = forces.starboard_n;
        f[2] = forces.vertical_n;
        self.base.model().tau_of_record(self, &f, state)
    }

    fn dynamics(&self, state: &ModelState, tau: &Vector6, current: &CurrentSample) -> ModelState {
        self.body_derivative(state, tau, current)
    }

    fn derivative(
        &self,
        time_s: f64,
        state: &ModelState,
        cmd: &ThrustPct,
        env: &Environment<'_>,
    ) -> ModelState {
        let c = Self::commands_of(cmd);
        let mut targets = self.thruster_targets(&c);
        let nl = self.n_lag_states();
        if nl > 0 {
            for (i, t) in targets.iter_mut().enumerate().take(nl) {
                *t = state.extra.get(i).copied().unwrap_or(*t);
            }
        }
        let f = self.thrusts(&targets);
        let signals = self.command_signals(&c);
        let mut filt = [0.0; 2 * MAX_SIGNALS];
        for (k, (ci, fk)) in self.filters.iter().enumerate() {
            let slot = *ci as usize * FILTER_TAUS_S.len() + *fk as usize;
            if let (Some(s), Some(x)) = (filt.get_mut(slot), state.extra.get(nl + k)) {
                *s = *x;
            }
        }
        let tau = self.thrust_tau(&f, state) + self.terms_tau(state, &signals, &filt);
        let tau = env.total_tau(&tau, time_s, &state.eta, &state.nu);
        let mut d = self.body_derivative(state, &tau, &env.current.at(time_s));
        self.extra_dynamics(time_s, state, cmd, &mut d);
        d
    }

    fn outputs(&self, time_s: f64, state: &ModelState) -> ModelOutput {
        let mut o = ModelOutput::from_state(time_s, state, |ch| self.predicts_channel(ch));
        if self.has_sensor_fx {
            let z = [0.0; MAX_THRUSTERS];
            if o.depth_m.is_some() {
                o.depth_m = Some(self.sensor_value(Channel::Depth, state, time_s, &z));
            }
            if o.heading_deg.is_some() {
                o.heading_deg = Some(self.sensor_value(Channel::Heading, state, time_s, &z));
            }
            if o.pitch_deg.is_some() {
                o.pitch_deg = Some(self.sensor_value(Channel::Pitch, state, time_s, &z));
            }
            if o.roll_deg.is_some() {
                o.roll_deg = Some(self.sensor_value(Channel::Roll, state, time_s, &z));
            }
        }
        o
    }

    fn n_extra_states(&self) -> usize {
        (self.n_lag_states() + self.filters.len()).min(rov_dynamics::models::MAX_EXTRA_STATES)
    }

    fn extra_dynamics(&self, _t: f64, state: &ModelState, cmd: &ThrustPct, deriv: &mut ModelState) {
        let c = Self::commands_of(cmd);
        let nl = self.n_lag_states();
        if nl > 0 {
            let taus = self.lag_taus();
            let targets = self.thruster_targets(&c);
            for i in 0..nl.min(rov_dynamics::models::MAX_EXTRA_STATES) {
                let tau = taus[i].max(1e-4);
                deriv.extra[i] = (targets[i] - state.extra[i]) / tau;
            }
        }
        let signals = self.command_signals(&c);
        for (k, (ci, fk)) in self.filters.iter().enumerate() {
            let slot = nl + k;
            let tau = FILTER_TAUS_S.get(*fk as usize).copied().unwrap_or(1.0);
            if let (Some(d), Some(x), Some(u)) = (
                deriv.extra.get_mut(slot),
                state.extra.get(slot),
                signals.get(*ci as usize),
            ) {
                *d = (u - x) / tau;
            }
        }
    }

    fn initial_state(&self, ic: &InitialConditions) -> ModelState {
        self.restrict_state(ic.to_state())
    }

    /// The base's heave and yaw reduction (with calibrated damping, added mass and
    /// buoyancy) and this model's thrust path: the calibrated per-thruster maps with the
    /// reverse ratio of the asymmetry effect, the dead zone, the lags, and the vertical
    /// thruster's reaction torque on yaw. The power limit, asymmetric drag, tether,
    /// current and discovered terms are not part of the reduction (the observer's bias
    /// takes what they leave). `None` for vehicle-file bases (N thrusters).
    fn plant(&self) -> Option<PlantDescription> {
        let mut d = self.base.model().plant()?;
        let taus = self.lag_taus();
        let mut maps = [d.port, d.starboard, d.vertical];
        let mut paths = [PathEffects::default(); 3];
        let mut gains = [0.0; 3];
        for (i, (map, path)) in maps.iter_mut().zip(paths.iter_mut()).enumerate() {
            let (cl, cq) = self.base.model().thrust_pair(i);
            // The base map's geometry factor (axis force per newton of this thruster).
            let base_n = cl + cq;
            let k = if base_n > 0.0 {
                (map.forward.linear_n + map.forward.quadratic_n) / base_n
            } else {
                0.0
            };
            let g = self.thruster_group(i).index();
            let forward = ThrustPair {
                linear_n: self.thrust_lin[g] * cl,
                quadratic_n: self.thrust_quad[g] * cq,
            };
            let r = self.fx.reverse_ratio[g];
            let reverse = ThrustPair {
                linear_n: r * forward.linear_n,
                quadratic_n: r * forward.quadratic_n,
            };
            *map = QuadraticThrustMap { forward, reverse }.scaled(k);
            *path = PathEffects {
                dead_zone: self.fx.deadzone,
                lag_tau_s: taus.get(i).copied().unwrap_or(0.0),
            };
            gains[i] = k;
        }
        let [port, starboard, vertical] = maps;
        d.port = port;
        d.starboard = starboard;
        d.vertical = vertical;
        [d.port_path, d.starboard_path, d.vertical_path] = paths;
        d.yaw_per_heave_m = if gains[2] > 0.0 {
            self.fx.torque_v_m / gains[2]
        } else {
            0.0
        };
        d.name = self.name.clone();
        Some(d)
    }

    fn clone_box(&self) -> Box<dyn VehicleModel> {
        Box::new(self.clone())
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}
