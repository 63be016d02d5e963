//! The simulator core: a truth model stepped on virtual time at a fixed step,
//! deterministic for a given seed.
//!
//! Each step of length h (default 0.01 s, 100 Hz):
//!
//! 1. the ocean current advances (Gauss–Markov or constant); over the step it is linear
//!    in time between its values at both ends, so ν̇_c carries Rᵀ v̇_c;
//! 2. the truth model ([`VehicleModel`], model 3 by default) is integrated with one RK4
//!    step, the command held (zero-order hold), τ_ext from the external-force hook
//!    evaluated at every RK4 stage;
//! 3. a non-finite state stops the simulator with [`DynamicsError::NonFinite`];
//! 4. the sensors are sampled once at the new time (SI readings and the Pro 4 integer
//!    fields), using ν̇ evaluated with the command held during the step that just ended;
//!    a later [`Simulator::set_command`] updates the truth's ν̇ but not these readings
//!    (they were taken before the new command acts, as in the measurement CSV).
//!
//! Time is `step_index · h`, so it does not drift. The current and the sensors draw from
//! separate RNG streams derived from the seed, so turning sensor noise off does not change
//! the current.

use nalgebra::Vector3;
use rov_dynamics::current::{CurrentModel, CurrentRamp, OceanCurrent};
use rov_dynamics::kinematics::Attitude;
use rov_dynamics::models::{
    Environment, ExternalForce, InitialConditions, ModelState, VehicleModel, load_default_model,
};
use rov_dynamics::sensors::{SensorConfig, SensorReadings, SensorSuite};
use rov_dynamics::{DynamicsError, ThrustPct, Vector6};

use crate::error::SimError;
use crate::fault::{
    DragExtra, FaultForce, FaultSpec, FaultTau, SensorFaultState, apply_sensor_faults, drag_factor,
    probe_mass, thrust_loss_tau,
};
use crate::seabed::{Seabed, WaterSurface};

/// Simulator settings.
#[derive(Debug, Clone)]
pub struct SimConfig {
    /// Fixed step h, s (default 0.01 s = 100 Hz).
    pub step_s: f64,
    /// The truth model.
    pub model: Box<dyn VehicleModel>,
    /// The ocean current.
    pub current: CurrentModel,
    /// Sensor settings.
    pub sensors: SensorConfig,
    /// Turn sensor noise off (biases still apply).
    pub noiseless: bool,
    /// Initial conditions of the truth model.
    pub initial: InitialConditions,
    /// A seabed the vehicle rests on ([`Seabed`]); none (open water) by default.
    pub seabed: Option<Seabed>,
    /// The water's surface ([`WaterSurface`]); none (unbounded water) by default.
    pub surface: Option<WaterSurface>,
}

impl SimConfig {
    /// Model 3 from `config/models/model3.toml` (as shipped), 100 Hz, no current, default
    /// sensors with noise, at rest 1 m deep heading north.
    pub fn default_model3() -> Result<Self, SimError> {
        Ok(Self::with_model(load_default_model("model3")?))
    }

    /// Defaults with a given truth model.
    pub fn with_model(model: Box<dyn VehicleModel>) -> Self {
        Self {
            step_s: 0.01,
            model,
            current: CurrentModel::none(),
            sensors: SensorConfig::default(),
            noiseless: false,
            initial: InitialConditions::at_rest(1.0, 0.0),
            seabed: None,
            surface: None,
        }
    }
}

/// The true state at the current time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthState {
    /// Time, s.
    pub time_s: f64,
    /// Model state (η, ν, extra states).
    pub state: ModelState,
    /// ν̇ at this time with the held command, body, m/s² and rad/s².
    pub nu_dot: Vector6,
    /// Ocean current in NED, m/s.
    pub current_ned_mps: Vector3<f64>,
    /// τ of the thrusters for the held command, N and N m.
    pub tau_thrusters: Vector6,
}

/// A constant force in the earth frame applied at a body point, e.g. a taut tether:
/// τ = [Rᵀ F ; r × Rᵀ F].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TetherForce {
    /// Force in NED, N.
    pub force_ned_n: Vector3<f64>,
    /// Attachment point from CO in body axes, m.
    pub attach_body_m: Vector3<f64>,
}

impl ExternalForce for TetherForce {
    fn tau_body(&self, _time_s: f64, eta: &Vector6, _nu: &Vector6) -> Vector6 {
        let f_body = Attitude::from_eta(eta).ned_from_body().transpose() * self.force_ned_n;
        let m = self.attach_body_m.cross(&f_body);
        Vector6::new(f_body.x, f_body.y, f_body.z, m.x, m.y, m.z)
    }
}

/// Any closure τ_ext(t, η, ν) as an external force.
pub struct FnForce<F>(pub F);

impl<F> std::fmt::Debug for FnForce<F> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("FnForce(..)")
    }
}

impl<F> ExternalForce for FnForce<F>
where
    F: Fn(f64, &Vector6, &Vector6) -> Vector6 + Send + Sync,
{
    fn tau_body(&self, time_s: f64, eta: &Vector6, nu: &Vector6) -> Vector6 {
        (self.0)(time_s, eta, nu)
    }
}

/// The external-force hook plus the seabed's contact, as one τ_ext.
#[derive(Debug)]
struct Contact<'a> {
    user: Option<&'a dyn ExternalForce>,
    seabed: Option<Seabed>,
    surface: Option<WaterSurface>,
}

impl<'a> Contact<'a> {
    /// The hook alone when there is no seabed or surface (bit-identical to a simulator
    /// without them).
    fn as_external(&'a self) -> Option<&'a dyn ExternalForce> {
        if self.seabed.is_none() && self.surface.is_none() {
            self.user
        } else {
            Some(self)
        }
    }
}

impl ExternalForce for Contact<'_> {
    fn tau_body(&self, time_s: f64, eta: &Vector6, nu: &Vector6) -> Vector6 {
        let user = self
            .user
            .map_or_else(Vector6::zeros, |f| f.tau_body(time_s, eta, nu));
        let bed = self
            .seabed
            .map_or_else(Vector6::zeros, |b| b.tau_body(time_s, eta, nu));
        let top = self
            .surface
            .map_or_else(Vector6::zeros, |s| s.tau_body(time_s, eta, nu));
        user + bed + top
    }
}

/// SplitMix64: derives independent RNG seeds from the user's seed.
fn splitmix64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = x;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The simulator.
#[derive(Debug)]
pub struct Simulator {
    model: Box<dyn VehicleModel>,
    step_s: f64,
    step_index: u64,
    command: ThrustPct,
    current: OceanCurrent,
    current_ramp: CurrentRamp,
    sensors: SensorSuite,
    external: Option<Box<dyn ExternalForce>>,
    seabed: Option<Seabed>,
    surface: Option<WaterSurface>,
    truth: TruthState,
    readings: SensorReadings,
    /// Injected faults (issue 23) with the dive's start point.
    faults: FaultForce,
    sensor_faults: SensorFaultState,
}

impl Simulator {
    /// Starts at t = 0 with all thrusters off.
    pub fn new(config: SimConfig, seed: u64) -> Result<Self, SimError> {
        if !(config.step_s.is_finite() && config.step_s > 0.0 && config.step_s <= 1.0) {
            return Err(SimError::InvalidInput {
                detail: format!("step_s = {} must be within (0, 1] s", config.step_s),
            });
        }
        if let Some(b) = config.seabed
            && !b.is_valid()
        {
            return Err(SimError::InvalidInput {
                detail: format!("seabed {b:?}: every value must be finite, depth > 0"),
            });
        }
        if let Some(w) = config.surface
            && !w.is_valid()
        {
            return Err(SimError::InvalidInput {
                detail: format!("surface {w:?}: every value must be finite and >= 0"),
            });
        }
        let current = OceanCurrent::new(config.current, splitmix64(seed ^ 0x0C0F_FEE0))?;
        let sensors = if config.noiseless {
            SensorSuite::noiseless(config.sensors)
        } else {
            SensorSuite::new(config.sensors, splitmix64(seed ^ 0x5E45_0125))
        };
        let state = config.model.initial_state(&config.initial);
        if !state.is_finite() {
            return Err(DynamicsError::NonFinite {
                time_s: 0.0,
                state: format!(
                    "initial eta = {:?}, nu = {:?}",
                    state.eta.as_slice(),
                    state.nu.as_slice()
                ),
            }
            .into());
        }
        let v0 = current.velocity_ned();
        let mut sim = Self {
            model: config.model,
            step_s: config.step_s,
            step_index: 0,
            command: ThrustPct::ZERO,
            current_ramp: CurrentRamp::between(0.0, config.step_s, v0, v0),
            current,
            sensors,
            external: None,
            faults: FaultForce {
                faults: Vec::new(),
                start_ne_m: [state.eta[0], state.eta[1]],
            },
            sensor_faults: SensorFaultState::default(),
            seabed: config.seabed,
            surface: config.surface,
            truth: TruthState {
                time_s: 0.0,
                state,
                nu_dot: Vector6::zeros(),
                current_ned_mps: v0,
                tau_thrusters: Vector6::zeros(),
            },
            readings: SensorReadings {
                time_s: 0.0,
                accel_body_mps2: Vector3::zeros(),
                gyro_body_radps: Vector3::zeros(),
                mag_body_ut: Vector3::zeros(),
                dvl_mps: Vector3::zeros(),
                transponder_ned_m: Vector3::zeros(),
                pressure_mbar: 0.0,
                depth_from_pressure_m: 0.0,
                heading_rad: 0.0,
                pitch_rad: 0.0,
                roll_rad: 0.0,
                pro4: Default::default(),
            },
        };
        sim.refresh_truth();
        sim.sample_sensors();
        Ok(sim)
    }

    /// Current virtual time, s.
    pub fn time_s(&self) -> f64 {
        self.truth.time_s
    }

    /// The fixed step, s.
    pub fn step_s(&self) -> f64 {
        self.step_s
    }

    /// The truth model.
    pub fn model(&self) -> &dyn VehicleModel {
        self.model.as_ref()
    }

    /// The command being held.
    pub fn command(&self) -> ThrustPct {
        self.command
    }

    /// Sets the command held from now on. Commands are saturated to −100..100 %;
    /// a non-finite command is rejected (the previous one stays).
    pub fn set_command(&mut self, cmd: ThrustPct) -> Result<(), SimError> {
        if !cmd.is_finite() {
            return Err(SimError::InvalidInput {
                detail: format!("thrust command {cmd:?} is not finite"),
            });
        }
        self.command = cmd.saturated();
        self.refresh_truth();
        Ok(())
    }

    /// Installs (or removes) the external-force hook τ_ext(t, η, ν).
    pub fn set_external_force(&mut self, force: Option<Box<dyn ExternalForce>>) {
        self.external = force;
        self.refresh_truth();
    }

    /// Replaces the injected faults (each applies from its own start time, on this
    /// simulator's virtual time). A snag pulls towards the position at t = 0.
    pub fn set_faults(&mut self, faults: Vec<FaultSpec>) {
        self.faults.faults = faults;
        self.refresh_truth();
    }

    /// Adds one fault (e.g. injected live from the station's Settings).
    pub fn add_fault(&mut self, fault: FaultSpec) {
        self.faults.faults.push(fault);
        self.refresh_truth();
    }

    /// The injected faults.
    pub fn faults(&self) -> &[FaultSpec] {
        &self.faults.faults
    }

    /// The fault force τ_ext at `t_s` for the state and command now, if any fault is set.
    fn fault_tau<'a>(
        &'a self,
        t_s: f64,
        ramp: CurrentRamp,
        user: Option<&'a dyn ExternalForce>,
    ) -> Option<FaultTau<'a>> {
        if self.faults.faults.is_empty() {
            return None;
        }
        let model = self.model.as_ref();
        let state = &self.truth.state;
        let k = drag_factor(&self.faults.faults, t_s);
        Some(FaultTau {
            user,
            force: &self.faults,
            thrust_loss_tau: thrust_loss_tau(&self.faults.faults, t_s, model, &self.command, state),
            drag: (k != 1.0).then(|| DragExtra {
                extra_factor: k - 1.0,
                mass: probe_mass(model, state),
                model,
                current: ramp,
            }),
        })
    }

    /// The true state now.
    pub fn truth(&self) -> &TruthState {
        &self.truth
    }

    /// The sensor readings at the current time (sampled once per step, so reading them
    /// does not consume random numbers).
    pub fn sensors(&self) -> SensorReadings {
        self.readings
    }

    /// Advances one step.
    pub fn step(&mut self) -> Result<(), SimError> {
        let h = self.step_s;
        let t0 = self.truth.time_s;
        let v0 = self.current.velocity_ned();
        self.current.step(h);
        let v1 = self.current.velocity_ned();
        self.current_ramp = CurrentRamp::between(t0, h, v0, v1);
        let contact = Contact {
            user: self.external.as_deref(),
            seabed: self.seabed,
            surface: self.surface,
        };
        // The faults (if any) wrap the contact forces and the user's hook.
        let fault_tau = self.fault_tau(t0, self.current_ramp, contact.as_external());
        let env = Environment {
            current: self.current_ramp,
            external: match &fault_tau {
                Some(f) => Some(f as &dyn ExternalForce),
                None => contact.as_external(),
            },
        };
        let model = self.model.as_ref();
        let cmd = self.command;
        let next = model.rk4_step(t0, &self.truth.state, &cmd, &env, h);
        let t1 = (self.step_index + 1) as f64 * h;
        if !next.is_finite() {
            return Err(DynamicsError::NonFinite {
                time_s: t1,
                state: format!(
                    "{} truth eta = {:?}, nu = {:?} (command {:?})",
                    model.name(),
                    next.eta.as_slice(),
                    next.nu.as_slice(),
                    cmd
                ),
            }
            .into());
        }
        self.step_index += 1;
        self.truth.time_s = t1;
        self.truth.state = next;
        self.refresh_truth();
        self.sample_sensors();
        Ok(())
    }

    /// Steps until the time reaches `t_s` (to the nearest step; no-op if `t_s` is not
    /// ahead).
    pub fn advance_to(&mut self, t_s: f64) -> Result<(), SimError> {
        if !t_s.is_finite() {
            return Err(SimError::InvalidInput {
                detail: format!("advance_to({t_s}): time must be finite"),
            });
        }
        while (self.step_index + 1) as f64 * self.step_s <= t_s + 1e-9 * self.step_s {
            self.step()?;
        }
        Ok(())
    }

    /// Recomputes ν̇ and τ at the current time, state and command.
    fn refresh_truth(&mut self) {
        let t = self.truth.time_s;
        let ramp = CurrentRamp {
            t0_s: t,
            start_ned_mps: self.current.velocity_ned(),
            rate_ned_mps2: self.current_ramp.rate_ned_mps2,
        };
        let contact = Contact {
            user: self.external.as_deref(),
            seabed: self.seabed,
            surface: self.surface,
        };
        // The faults (if any) wrap the contact forces and the user's hook.
        let fault_tau = self.fault_tau(t, ramp, contact.as_external());
        let env = Environment {
            current: ramp,
            external: match &fault_tau {
                Some(f) => Some(f as &dyn ExternalForce),
                None => contact.as_external(),
            },
        };
        let s = self.truth.state;
        let d = self.model.derivative(t, &s, &self.command, &env);
        let forces = self.model.thruster_forces(&self.command, &s);
        let lost = fault_tau
            .as_ref()
            .map_or_else(Vector6::zeros, |f| f.thrust_loss_tau);
        self.truth.nu_dot = d.nu;
        self.truth.current_ned_mps = ramp.start_ned_mps;
        self.truth.tau_thrusters = self.model.generalized_force(&forces, &s) + lost;
    }

    /// Samples the sensors once for the current step (the only place noise is drawn).
    fn sample_sensors(&mut self) {
        let s = self.truth.state;
        self.readings = self
            .sensors
            .measure(self.truth.time_s, &s.eta, &s.nu, &self.truth.nu_dot);
        if !self.faults.faults.is_empty() {
            let c = self.sensors.config();
            let mbar_per_m = c.water_density_kgpm3 * c.gravity_mps2 * 0.01;
            apply_sensor_faults(
                &self.faults.faults,
                &mut self.sensor_faults,
                &mut self.readings,
                mbar_per_m,
            );
        }
    }
}
