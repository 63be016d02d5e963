//! The chosen model's prediction, for the plots: the model's heave and yaw dynamics
//! driven open loop by the thrust actually commanded, re-anchored to the measurement
//! every [`HORIZON_S`]. Within each window the gap between the prediction and the
//! measurement shows how well the model knows the vehicle (the lab quantifies it).

use rov_control::{FeedforwardModel, PlantModel};

/// Prediction window: the model runs open loop this long, then restarts from the
/// measurement, s.
pub const HORIZON_S: f64 = 10.0;

/// Open-loop predictor of depth and heading.
#[derive(Debug, Clone, Default)]
pub struct Predictor {
    anchor_s: Option<f64>,
    depth_m: f64,
    w_mps: f64,
    heading_deg: f64,
    r_rad_s: f64,
}

/// What the predictor starts from at a re-anchor.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Anchor {
    /// Depth, m.
    pub depth_m: Option<f64>,
    /// Heave velocity, m/s (positive down).
    pub w_mps: Option<f64>,
    /// Heading, degrees.
    pub heading_deg: Option<f64>,
    /// Yaw rate, rad/s.
    pub r_rad_s: Option<f64>,
}

impl Predictor {
    /// Restarts at the next step.
    pub fn reset(&mut self) {
        self.anchor_s = None;
    }

    /// One step of `dt_s` at time `t_s` with the commanded thrust (physics convention,
    /// %): returns the predicted (depth m, heading deg), or None until anchored.
    pub fn step(
        &mut self,
        model: &PlantModel,
        t_s: f64,
        dt_s: f64,
        anchor: &Anchor,
        thrust_pct: [f64; 3],
    ) -> Option<(f64, f64)> {
        let due = self
            .anchor_s
            .is_none_or(|a| t_s - a >= HORIZON_S || t_s < a);
        if due {
            let (Some(d), Some(h)) = (anchor.depth_m, anchor.heading_deg) else {
                self.anchor_s = None;
                return None;
            };
            self.anchor_s = Some(t_s);
            self.depth_m = d;
            self.w_mps = anchor.w_mps.filter(|v| v.is_finite()).unwrap_or(0.0);
            self.heading_deg = h;
            self.r_rad_s = anchor.r_rad_s.filter(|v| v.is_finite()).unwrap_or(0.0);
            return Some((self.depth_m, self.heading_deg));
        }
        let dt = if dt_s.is_finite() {
            dt_s.clamp(0.0, 0.2)
        } else {
            0.0
        };
        let [port, starboard, vertical] = thrust_pct;
        // Semi-implicit Euler in a few sub-steps (stable for the models' time constants).
        let n = 4;
        let h = dt / f64::from(n);
        for _ in 0..n {
            let hv = &model.heave;
            let f = model.vertical_force_for_pct(vertical) + hv.static_load;
            let wdot = (f - (hv.damping_lin + hv.damping_quad * self.w_mps.abs()) * self.w_mps)
                / hv.inertia;
            self.w_mps += wdot * h;
            self.depth_m += self.w_mps * h;
            let yv = &model.yaw;
            let m = model.yaw_moment_for_pct(port, starboard) + yv.static_load;
            let rdot = (m - (yv.damping_lin + yv.damping_quad * self.r_rad_s.abs()) * self.r_rad_s)
                / yv.inertia;
            self.r_rad_s += rdot * h;
            self.heading_deg = (self.heading_deg + self.r_rad_s.to_degrees() * h).rem_euclid(360.0);
        }
        if !(self.depth_m.is_finite() && self.heading_deg.is_finite()) {
            self.anchor_s = None;
            return None;
        }
        Some((self.depth_m, self.heading_deg))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rov_control::ModelChoice;

    #[test]
    fn neutral_thrust_keeps_heading_and_full_down_thrust_sinks() {
        let model = PlantModel::load_default(ModelChoice::Model3).unwrap();
        let mut p = Predictor::default();
        let a = Anchor {
            depth_m: Some(5.0),
            heading_deg: Some(90.0),
            ..Anchor::default()
        };
        assert_eq!(p.step(&model, 0.0, 0.02, &a, [0.0; 3]), Some((5.0, 90.0)));
        let mut last = (5.0, 90.0);
        for k in 1..100 {
            last = p
                .step(&model, f64::from(k) * 0.02, 0.02, &a, [0.0, 0.0, 100.0])
                .unwrap();
        }
        assert!(last.0 > 5.1, "{last:?}");
        assert!((last.1 - 90.0).abs() < 1e-9);
        // Re-anchors after the horizon.
        assert_eq!(
            p.step(&model, HORIZON_S + 0.5, 0.02, &a, [0.0; 3]),
            Some((5.0, 90.0))
        );
    }
}
