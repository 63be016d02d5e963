//! The catalog effects' layer of a [`LabModel`]: their values, the body forces and
//! current they add to the base's dynamics, and the sensor model they put on its outputs.

use rov_dynamics::Vector6;
use rov_dynamics::kinematics::Attitude;
use rov_dynamics::models::{Channel, ModelState};
use rov_dynamics::process::CurrentSample;

use super::base::{BaseModel, on_base};
use super::{LabModel, PerThruster};
use crate::params::{Axis, Param};

/// Tether attachment point from the CO (body axes), m: behind the hull on its axis.
pub const TETHER_ATTACH_X_M: f64 = -0.2;

/// Number of thruster groups ([`crate::params::Thr::ALL`]).
pub const N_GROUPS: usize = 5;

/// Values of every effect parameter (off values when an effect is absent).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EffectValues {
    /// Reverse/forward thrust ratio per thruster group.
    pub reverse_ratio: [f64; N_GROUPS],
    /// Lag time constant, s.
    pub lag_tau_s: f64,
    /// Dead zone, fraction of full command.
    pub deadzone: f64,
    /// Power budget in Σ|u|³ units (three-thruster equivalents).
    pub power_max: f64,
    /// Horizontal line of action below CO, m.
    pub arm_zh_m: f64,
    /// Vertical thruster forward of CO, m.
    pub arm_xv_m: f64,
    /// Vertical thruster to starboard of CO, m.
    pub arm_yv_m: f64,
    /// A vehicle's non-vertical thrusters shifted forward, m.
    pub arm_xh_m: f64,
    /// A vehicle's non-vertical thrusters shifted to starboard, m.
    pub arm_yh_m: f64,
    /// Vertical reaction torque per N, m.
    pub torque_v_m: f64,
    /// Horizontal differential reaction roll torque per N, m.
    pub torque_h_m: f64,
    /// Trim for the depth kinematics (models without pitch), rad.
    pub trim_rad: f64,
    /// Reverse/forward quadratic drag ratio per axis.
    pub drag_ratio: [f64; 6],
    /// Current (north, east), m/s.
    pub current_ne_mps: [f64; 2],
    /// Tether pull (north, east), N.
    pub tether_ne_n: [f64; 2],
    /// Depth drift, m/s.
    pub depth_drift_mps: f64,
    /// Compass deviation (sin, cos), deg.
    pub compass_dev_deg: [f64; 2],
    /// Compass interference per unit |u| of a thruster group, deg.
    pub emi_deg: [f64; N_GROUPS],
    /// Roll bias, deg.
    pub bias_roll_deg: f64,
    /// Pitch bias, deg.
    pub bias_pitch_deg: f64,
}

impl Default for EffectValues {
    fn default() -> Self {
        Self {
            reverse_ratio: [1.0; N_GROUPS],
            lag_tau_s: 0.0,
            deadzone: 0.0,
            power_max: 3.0,
            arm_zh_m: 0.0,
            arm_xv_m: 0.0,
            arm_yv_m: 0.0,
            arm_xh_m: 0.0,
            arm_yh_m: 0.0,
            torque_v_m: 0.0,
            torque_h_m: 0.0,
            trim_rad: 0.0,
            drag_ratio: [1.0; 6],
            current_ne_mps: [0.0; 2],
            tether_ne_n: [0.0; 2],
            depth_drift_mps: 0.0,
            compass_dev_deg: [0.0; 2],
            emi_deg: [0.0; N_GROUPS],
            bias_roll_deg: 0.0,
            bias_pitch_deg: 0.0,
        }
    }
}

impl EffectValues {
    /// An effect parameter's value (`None` for the base's parameters, thrust scales and
    /// term coefficients).
    pub(super) fn get(&self, p: Param) -> Option<f64> {
        Some(match p {
            Param::ReverseRatio(t) => self.reverse_ratio[t.index()],
            Param::LagTau => self.lag_tau_s,
            Param::Deadzone => self.deadzone,
            Param::PowerMax => self.power_max,
            Param::ArmZh => self.arm_zh_m,
            Param::ArmXv => self.arm_xv_m,
            Param::ArmYv => self.arm_yv_m,
            Param::ArmXh => self.arm_xh_m,
            Param::ArmYh => self.arm_yh_m,
            Param::TorqueV => self.torque_v_m,
            Param::TorqueH => self.torque_h_m,
            Param::TrimDeg => self.trim_rad.to_degrees(),
            Param::DragRatio(a) => self.drag_ratio[a.index()],
            Param::CurrentN => self.current_ne_mps[0],
            Param::CurrentE => self.current_ne_mps[1],
            Param::TetherN => self.tether_ne_n[0],
            Param::TetherE => self.tether_ne_n[1],
            Param::DepthDrift => self.depth_drift_mps,
            Param::CompassSin => self.compass_dev_deg[0],
            Param::CompassCos => self.compass_dev_deg[1],
            Param::Emi(t) => self.emi_deg[t.index()],
            Param::BiasRoll => self.bias_roll_deg,
            Param::BiasPitch => self.bias_pitch_deg,
            _ => return None,
        })
    }

    /// Sets an effect parameter (others are left alone).
    pub(super) fn set(&mut self, p: Param, v: f64) {
        match p {
            Param::ReverseRatio(t) => self.reverse_ratio[t.index()] = v,
            Param::LagTau => self.lag_tau_s = v,
            Param::Deadzone => self.deadzone = v,
            Param::PowerMax => self.power_max = v,
            Param::ArmZh => self.arm_zh_m = v,
            Param::ArmXv => self.arm_xv_m = v,
            Param::ArmYv => self.arm_yv_m = v,
            Param::ArmXh => self.arm_xh_m = v,
            Param::ArmYh => self.arm_yh_m = v,
            Param::TorqueV => self.torque_v_m = v,
            Param::TorqueH => self.torque_h_m = v,
            Param::TrimDeg => self.trim_rad = v.to_radians(),
            Param::DragRatio(a) => self.drag_ratio[a.index()] = v,
            Param::CurrentN => self.current_ne_mps[0] = v,
            Param::CurrentE => self.current_ne_mps[1] = v,
            Param::TetherN => self.tether_ne_n[0] = v,
            Param::TetherE => self.tether_ne_n[1] = v,
            Param::DepthDrift => self.depth_drift_mps = v,
            Param::CompassSin => self.compass_dev_deg[0] = v,
            Param::CompassCos => self.compass_dev_deg[1] = v,
            Param::Emi(t) => self.emi_deg[t.index()] = v,
            Param::BiasRoll => self.bias_roll_deg = v,
            Param::BiasPitch => self.bias_pitch_deg = v,
            _ => {}
        }
    }

    /// Whether any sensor effect is non-zero.
    pub(super) fn any_sensor(&self) -> bool {
        self.depth_drift_mps != 0.0
            || self.compass_dev_deg != [0.0; 2]
            || self.emi_deg != [0.0; N_GROUPS]
            || self.bias_roll_deg != 0.0
            || self.bias_pitch_deg != 0.0
    }

    /// Whether any body-force effect is non-zero (tether, asymmetric drag).
    pub(super) fn any_body(&self) -> bool {
        self.tether_ne_n != [0.0; 2] || self.drag_ratio != [1.0; 6]
    }
}

impl LabModel {
    /// The effect values.
    pub fn effect_values(&self) -> &EffectValues {
        &self.fx
    }

    /// Whether any extra body force (effects, the base's lab-carried force, terms) is on.
    #[inline]
    pub(super) fn has_body_effects(&self) -> bool {
        self.has_body_fx
    }

    /// State-dependent extra body forces of the effects (not the terms).
    #[inline]
    pub(super) fn extra_tau(&self, state: &ModelState) -> Vector6 {
        let x = &self.fx;
        let mut tau = Vector6::zeros();
        if !self.has_body_fx {
            return tau;
        }
        let heave_n = on_base!(&self.base, b => b.lab_heave_force_n());
        if heave_n != 0.0 {
            tau[2] += heave_n;
        }
        if x.tether_ne_n != [0.0; 2] {
            let att = Attitude::from_eta(&state.eta);
            let f_ned = nalgebra::Vector3::new(x.tether_ne_n[0], x.tether_ne_n[1], 0.0);
            let fb = att.ned_from_body().transpose() * f_ned;
            let r = nalgebra::Vector3::new(TETHER_ATTACH_X_M, 0.0, 0.0);
            let m = r.cross(&fb);
            tau[0] += fb.x;
            tau[1] += fb.y;
            tau[2] += fb.z;
            tau[3] += m.x;
            tau[4] += m.y;
            tau[5] += m.z;
        }
        for (i, ratio) in x.drag_ratio.iter().enumerate() {
            if *ratio != 1.0 {
                let v = state.nu[i];
                if v < 0.0 {
                    let dq = self.drag(Axis::ALL.get(i).copied().unwrap_or(Axis::Yaw)).1;
                    tau[i] += (ratio - 1.0) * dq * v * v * self.drag_tau_factor[i];
                }
            }
        }
        tau
    }

    /// The water current with the `current` effect's.
    #[inline]
    pub(super) fn effect_current(&self, current: &CurrentSample) -> CurrentSample {
        let c = self.fx.current_ne_mps;
        if c == [0.0; 2] {
            *current
        } else {
            let mut s = *current;
            s.vel_ned_mps.x += c[0];
            s.vel_ned_mps.y += c[1];
            s
        }
    }

    /// Whether any sensor effect is non-zero.
    pub fn has_sensor_effects(&self) -> bool {
        self.has_sensor_fx
    }

    /// The measured value of a channel: the state seen through the sensor effects.
    /// `t_rel_s` counts from the start of the run; `prev` holds the thruster commands (%)
    /// acting just before the sample (for thruster interference on the compass).
    #[inline]
    pub fn sensor_value(
        &self,
        ch: Channel,
        state: &ModelState,
        t_rel_s: f64,
        prev: &PerThruster,
    ) -> f64 {
        let v = ch.value(state);
        if !self.has_sensor_fx {
            return v;
        }
        let f = &self.fx;
        match ch {
            Channel::Depth => v + f.depth_drift_mps * t_rel_s,
            Channel::Heading => v + self.heading_offset_deg(state.eta[5], prev),
            Channel::Pitch => v + f.bias_pitch_deg,
            Channel::Roll => v + f.bias_roll_deg,
            _ => v,
        }
    }

    /// The compass reading's offset (deviation and thruster interference) at a heading
    /// under the thruster commands (%) acting just before the sample, deg.
    #[inline]
    pub(crate) fn heading_offset_deg(&self, psi_rad: f64, prev: &PerThruster) -> f64 {
        let f = &self.fx;
        // Without deviation the sin/cos terms are zeros (skipped: the same sum).
        let mut off = if f.compass_dev_deg == [0.0; 2] {
            0.0
        } else {
            let (s, c) = psi_rad.sin_cos();
            f.compass_dev_deg[0] * s + f.compass_dev_deg[1] * c
        };
        for (i, u) in prev.iter().enumerate().take(self.n_thr) {
            let e = f.emi_deg[self.thruster_group(i).index()];
            if e != 0.0 {
                off += e * (u * 0.01).abs();
            }
        }
        off
    }

    /// Inverts the sensor model of a channel: the state value (deg or m) that reads `y`.
    pub fn sensor_inverse(&self, ch: Channel, y: f64, t_rel_s: f64, prev: &PerThruster) -> f64 {
        if !self.has_sensor_fx {
            return y;
        }
        let f = &self.fx;
        match ch {
            Channel::Depth => y - f.depth_drift_mps * t_rel_s,
            Channel::Heading => {
                let mut psi = y;
                for _ in 0..8 {
                    psi = y - self.heading_offset_deg(psi.to_radians(), prev);
                }
                psi
            }
            Channel::Pitch => y - f.bias_pitch_deg,
            Channel::Roll => y - f.bias_roll_deg,
            _ => y,
        }
    }
}
