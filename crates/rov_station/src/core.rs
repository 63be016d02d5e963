//! The station's logic, independent of how bytes move and how time passes.
//!
//! [`StationCore`] sits between the [`Link`] (bytes ↔ telemetry and commands) and the
//! [`Controller`] (one pure control tick). It turns link events into measurements, runs a
//! control tick at a fixed period, hands the guarded thrust (or the vehicle's own
//! auto-depth/heading targets) to the link, and applies pilot commands. The same core
//! runs on virtual time (the `hold` command, tests, `record --fast`) and in the real-time
//! runtime; control and safety never run inside a GUI frame.
//!
//! Safety wiring:
//! * the link's failsafe gates every frame (neutral until armed, neutral on link loss,
//!   re-arm needed after a loss);
//! * on link loss or disarm the core also drops both holds to manual
//!   ([`Controller::failsafe_neutral`]), so nothing winds up behind a neutral link;
//! * holds can only be engaged while armed.

use rov_control::{
    Axis, ControlConfig, ControlError, Controller, Measurements, ModeCommand, ModelSet, PilotInput,
    TickOutput, heading_rate_from_body_rates,
};
use rov_driver::{ArmError, Health, Link, LinkEvent, StatusTelemetry, Telemetry};
use rov_types::conventions::PhysicsThrust;
use serde::Serialize;

/// A command from the pilot (GUI, gamepad, script or CLI).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StationCommand {
    /// Arm (the link refuses until its link has been healthy long enough).
    Arm,
    /// Disarm: neutral thrust, holds off.
    Disarm,
    /// Stick positions, −1..1 each.
    Sticks(PilotInput),
    /// A hold, setpoint or feedforward command.
    Mode(ModeCommand),
}

/// Why a command was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CommandError {
    /// The link refused to arm (its text already says "cannot arm").
    #[error("{0}")]
    Arm(#[from] ArmError),
    /// The controller refused the command.
    #[error("{0}")]
    Control(#[from] ControlError),
    /// Holds need an armed vehicle.
    #[error("engage a hold only while armed")]
    NotArmed,
}

/// What the GUI and the recorder see of the station after each tick.
#[derive(Debug, Default, Serialize)]
pub struct Snapshot {
    /// Station time, s.
    pub time_s: f64,
    /// Armed (the link's failsafe lets thrust through).
    pub armed: bool,
    /// Link health: "connected", "degraded" or "lost".
    pub link_health: String,
    /// Latest telemetry (physics convention).
    pub depth_m: Option<f64>,
    /// Heading, degrees [0, 360).
    pub heading_deg: Option<f64>,
    /// Pitch, degrees, nose up.
    pub pitch_deg: Option<f64>,
    /// Roll, degrees, starboard down.
    pub roll_deg: Option<f64>,
    /// Observer depth estimate, m.
    pub depth_estimate_m: Option<f64>,
    /// Observer heading estimate, degrees.
    pub heading_estimate_deg: Option<f64>,
    /// Depth setpoint while holding, m.
    pub depth_setpoint_m: Option<f64>,
    /// Heading setpoint while holding, degrees.
    pub heading_setpoint_deg: Option<f64>,
    /// The guarded command of the last tick.
    pub thrust: PhysicsThrust,
    /// Humidity, %.
    pub humidity_pct: Option<f64>,
    /// Water temperature, °C.
    pub water_temp_c: Option<f64>,
    /// Tether voltage, V.
    pub tether_v: Option<f64>,
    /// Latched alarm text, if any.
    pub alarm: Option<String>,
}

/// The station logic; see the module docs.
#[derive(Debug)]
pub struct StationCore {
    controller: Controller,
    pilot: PilotInput,
    pending: Measurements,
    last_telemetry: Option<Telemetry>,
    last_status: Option<StatusTelemetry>,
    last_output: Option<TickOutput>,
    health: Option<Health>,
    snapshot: Snapshot,
}

impl StationCore {
    /// A core with the given control configuration and feedforward models.
    pub fn new(cfg: ControlConfig, models: ModelSet) -> Result<Self, ControlError> {
        Ok(Self {
            controller: Controller::new(cfg, models)?,
            pilot: PilotInput::default(),
            pending: Measurements::default(),
            last_telemetry: None,
            last_status: None,
            last_output: None,
            health: None,
            snapshot: Snapshot::default(),
        })
    }

    /// The controller (read-only).
    pub fn controller(&self) -> &Controller {
        &self.controller
    }

    /// The output of the last tick.
    pub fn last_output(&self) -> Option<&TickOutput> {
        self.last_output.as_ref()
    }

    /// Uses a custom plant (any model's) under `label` for the autopilot's feedforward,
    /// observer and feedback ([`Controller::set_plant`]); a plant that does not validate
    /// is refused and the previous model stays.
    pub fn set_plant(
        &mut self,
        label: &str,
        plant: rov_control::PlantModel,
    ) -> Result<(), ControlError> {
        self.controller.set_plant(label, plant)
    }

    /// A controller command that needs no link (model selection, feedforward switch).
    pub fn controller_command(
        &mut self,
        cmd: rov_control::ModeCommand,
    ) -> Result<(), ControlError> {
        self.controller.command(cmd)
    }

    /// The latest telemetry.
    pub fn last_telemetry(&self) -> Option<&Telemetry> {
        self.last_telemetry.as_ref()
    }

    /// The snapshot after the last tick.
    pub fn snapshot(&self) -> &Snapshot {
        &self.snapshot
    }

    /// Feeds one link event.
    pub fn on_event(&mut self, link: &mut Link, event: &LinkEvent) {
        match event {
            LinkEvent::Telemetry(t) => {
                // Each sample reaches the controller exactly once; a tick without a new
                // sample is a missing sample (the observer predicts only).
                // The gyro gives body rates; the heading channel needs the Euler heading
                // rate, which differs from r whenever the vehicle is pitched or rolled.
                let heading_rate = heading_rate_from_body_rates(
                    t.pitch_rate_radps,
                    t.yaw_rate_radps,
                    t.roll_deg.to_radians(),
                    t.pitch_deg.to_radians(),
                );
                self.pending = Measurements {
                    depth_m: Some(t.depth_m),
                    heading_deg: Some(t.heading_deg),
                    yaw_rate_rad_s: heading_rate,
                };
                self.last_telemetry = Some(*t);
            }
            LinkEvent::Status(s) => self.last_status = Some(*s),
            LinkEvent::StateChanged { health, .. } => {
                // Tare the depth target conversion at each (re)connection, as the
                // controller's onboard-autopilot targets (CSR 0x0B, mbar) need it.
                if *health == Health::Connected && self.health != Some(Health::Connected) {
                    let tare = link.config().conventions.surface_pressure_mbar;
                    if let Err(e) = self.controller.command(ModeCommand::SetSurfaceTare {
                        pressure_mbar: tare,
                    }) {
                        // The autopilot keeps its previous tare; its vehicle depth
                        // target may then be off by the difference.
                        tracing::warn!(
                            "surface pressure {tare} mbar of the link refused by the controller: {e}"
                        );
                    }
                }
                if *health == Health::Lost && self.health != Some(Health::Lost) {
                    self.controller.failsafe_neutral();
                    link.set_thrust(&PhysicsThrust::NEUTRAL);
                    link.set_auto_targets(None, None);
                }
                self.health = Some(*health);
            }
            _ => {}
        }
    }

    /// Applies a pilot command.
    pub fn command(
        &mut self,
        link: &mut Link,
        cmd: StationCommand,
        now_us: u64,
    ) -> Result<(), CommandError> {
        match cmd {
            StationCommand::Arm => link.arm(now_us)?,
            StationCommand::Disarm => {
                link.disarm();
                self.controller.failsafe_neutral();
            }
            StationCommand::Sticks(p) => self.pilot = p,
            StationCommand::Mode(m) => {
                let engages = matches!(
                    m,
                    ModeCommand::Engage(_)
                        | ModeCommand::EngageVehicleAuto(_)
                        | ModeCommand::SetDepth { .. }
                        | ModeCommand::SetHeading { .. }
                );
                if engages && !link.failsafe().is_armed() {
                    return Err(CommandError::NotArmed);
                }
                self.controller.command(m)?;
            }
        }
        Ok(())
    }

    /// One control tick at `now_us`: controller → link command. Call at a fixed period.
    pub fn tick(&mut self, link: &mut Link, now_us: u64) -> TickOutput {
        let t_s = now_us as f64 * 1e-6;
        let meas = std::mem::take(&mut self.pending);
        let armed = link.failsafe().is_armed();
        let pilot = if armed {
            self.pilot
        } else {
            PilotInput::default()
        };
        let out = self.controller.tick(t_s, &meas, &pilot);
        let cmd = out.command;
        link.set_thrust(&PhysicsThrust {
            port_pct: cmd.port_pct(),
            starboard_pct: cmd.starboard_pct(),
            vertical_pct: cmd.vertical_pct(),
        });
        let targets = out.vehicle_targets;
        let depth_target_m = targets
            .depth_mbar
            .and_then(|mbar| self.controller.depth_m_from_pressure(f64::from(mbar)));
        link.set_auto_targets(depth_target_m, targets.heading_deg.map(f64::from));
        self.update_snapshot(link, t_s, &out);
        self.last_output = Some(out);
        out
    }

    fn update_snapshot(&mut self, link: &Link, t_s: f64, out: &TickOutput) {
        let t = self.last_telemetry.as_ref();
        let s = self.last_status.as_ref();
        let d = &out.diagnostics;
        let health = match self.health {
            Some(Health::Connected) => "connected",
            Some(Health::Degraded) => "degraded",
            _ => "lost",
        };
        // The text fields are reused (no allocation per tick).
        let mut link_health = std::mem::take(&mut self.snapshot.link_health);
        if link_health != health {
            health.clone_into(&mut link_health);
        }
        let alarm = match link.failsafe().alarm() {
            Some(a) => {
                let text = format!("{a:?}");
                match self.snapshot.alarm.take() {
                    Some(old) if old == text => Some(old),
                    _ => Some(text),
                }
            }
            None => None,
        };
        self.snapshot = Snapshot {
            time_s: t_s,
            armed: link.failsafe().is_armed(),
            link_health,
            depth_m: t.map(|t| t.depth_m),
            heading_deg: t.map(|t| t.heading_deg),
            pitch_deg: t.map(|t| t.pitch_deg),
            roll_deg: t.map(|t| t.roll_deg),
            depth_estimate_m: d.depth_estimate_m(),
            heading_estimate_deg: d.heading_estimate_deg(),
            depth_setpoint_m: d.depth_setpoint_m(),
            heading_setpoint_deg: d.heading_setpoint_deg(),
            thrust: PhysicsThrust {
                port_pct: out.command.port_pct(),
                starboard_pct: out.command.starboard_pct(),
                vertical_pct: out.command.vertical_pct(),
            },
            humidity_pct: t.map(|t| t.humidity_pct),
            water_temp_c: t.map(|t| t.water_temp_c),
            tether_v: s.map(|s| s.tether_v),
            alarm,
        };
    }

    /// Whether a hold is engaged on `axis`.
    pub fn holding(&self, axis: Axis) -> bool {
        !matches!(
            self.controller.axis_state(axis).mode,
            rov_control::AxisMode::Manual
        )
    }
}

crate::clone_fields!(Snapshot {
    time_s,
    armed,
    link_health,
    depth_m,
    heading_deg,
    pitch_deg,
    roll_deg,
    depth_estimate_m,
    heading_estimate_deg,
    depth_setpoint_m,
    heading_setpoint_deg,
    thrust,
    humidity_pct,
    water_temp_c,
    tether_v,
    alarm
});
