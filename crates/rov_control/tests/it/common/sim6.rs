//! The 6-DOF truth for closed-loop tests: rov_sim's [`Simulator`] with model3's shipped
//! nominal parameters (Munk moments zeroed, the parameter file's documented default) at
//! 100 Hz, its sensor suite with noise, and the Pro 4's integer telemetry (heading,
//! pitch and roll ×10, integer mbar pressure, rates in milli-rad/s) turned into
//! measurements as the station does.

use nalgebra::Vector3;
use rov_control::{Measurements, ThrustCommand};
use rov_dynamics::ThrustPct;
use rov_dynamics::current::CurrentModel;
use rov_dynamics::models::{ExternalForce, InitialConditions};
use rov_sim::{SimConfig, Simulator, TetherForce};

/// A disturbance of the acceptance list.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Disturbance {
    /// Calm water.
    None,
    /// A constant 0.3 m/s current flowing toward north.
    Current,
    /// A 0.8 N horizontal pull toward azimuth 135°, fixed in the earth frame, applied at
    /// (−0.20, 0, −0.08) m from CO.
    Tether,
}

/// Surface pressure used as the tare, mbar (the sensor suite's atmosphere).
pub const TARE_MBAR: f64 = 1013.25;

fn tether() -> TetherForce {
    let az = 135f64.to_radians();
    TetherForce {
        force_ned_n: Vector3::new(az.cos(), az.sin(), 0.0) * 0.8,
        attach_body_m: Vector3::new(-0.20, 0.0, -0.08),
    }
}

/// The simulated vehicle.
pub struct Sim6 {
    sim: Simulator,
    disturbance: Disturbance,
    /// Feed the gyro-derived heading rate to the controller.
    pub use_gyro: bool,
}

impl Sim6 {
    pub fn new(depth_m: f64, heading_deg: f64, disturbance: Disturbance, seed: u64) -> Self {
        let mut cfg = SimConfig::default_model3().expect("model3 loads");
        cfg.initial = InitialConditions::at_rest(depth_m, heading_deg);
        if disturbance == Disturbance::Current {
            cfg.current = CurrentModel::Constant {
                speed_mps: 0.3,
                vertical_angle_rad: 0.0,
                direction_rad: 0.0,
            };
        }
        let mut sim = Simulator::new(cfg, seed).expect("simulator starts");
        if disturbance == Disturbance::Tether {
            sim.set_external_force(Some(Box::new(tether())));
        }
        Sim6 {
            sim,
            disturbance,
            use_gyro: false,
        }
    }

    /// Also feed the gyro's heading rate to the controller.
    pub fn with_gyro(mut self, on: bool) -> Self {
        self.use_gyro = on;
        self
    }

    /// Holds `cmd` for `dt_s`.
    pub fn step(&mut self, cmd: &ThrustCommand, dt_s: f64) {
        let pct = ThrustPct::new(cmd.port_pct(), cmd.starboard_pct(), cmd.vertical_pct());
        self.sim.set_command(pct).expect("finite command");
        let t = self.sim.time_s() + dt_s;
        self.sim.advance_to(t).expect("finite truth");
    }

    /// The tether's yaw moment at the current state, N·m (0 without the tether).
    pub fn tether_yaw_moment_nm(&self) -> f64 {
        if self.disturbance != Disturbance::Tether {
            return 0.0;
        }
        let s = self.sim.truth().state;
        tether().tau_body(self.sim.time_s(), &s.eta, &s.nu)[5]
    }

    /// True depth of CO, m.
    pub fn depth_m(&self) -> f64 {
        self.sim.truth().state.eta[2]
    }

    /// True heading, degrees 0..360.
    pub fn heading_deg(&self) -> f64 {
        rov_control::angle::wrap_deg_360(self.sim.truth().state.eta[5].to_degrees())
    }

    /// The Pro 4's telemetry as the station would turn it into measurements.
    pub fn measure(&mut self) -> Measurements {
        let p = self.sim.sensors().pro4;
        Measurements {
            depth_m: Some(rov_control::depth_m_from_mbar(
                f64::from(p.pressure_mbar),
                TARE_MBAR,
                1000.0,
            )),
            heading_deg: Some(f64::from(p.heading_deci_deg) / 10.0),
            // The station's conversion: body rates (milli-rad/s) and attitude (deci-degrees)
            // to the heading rate.
            yaw_rate_rad_s: if self.use_gyro {
                rov_control::heading_rate_from_body_rates(
                    f64::from(p.pitch_rate_milli_radps) / 1000.0,
                    f64::from(p.yaw_rate_milli_radps) / 1000.0,
                    (f64::from(p.roll_deci_deg) / 10.0).to_radians(),
                    (f64::from(p.pitch_deci_deg) / 10.0).to_radians(),
                )
            } else {
                None
            },
        }
    }
}
