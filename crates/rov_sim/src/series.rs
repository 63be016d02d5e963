//! Timed thrust schedules, and runs that produce measurement series: the simulator's
//! truth through its sensors ([`run_schedule`]) and a model's prediction over the same
//! inputs ([`predict_inputs`], [`predict_schedule`], [`predict_measured`]).
//!
//! All series follow the measurement-CSV conventions of `rov_types::measurement`: row k
//! holds the command held from t_k and the measurements taken at t_k before it acts.
//! Heading is continuous (not wrapped). Channels a model does not predict are NaN; every
//! optional column is present.

use rov_dynamics::ThrustPct;
use rov_dynamics::models::{
    Environment, InitialConditions, ModelOutput, VehicleModel, simulate_in,
};
use rov_dynamics::sensors::SensorReadings;
use rov_types::measurement::{MeasurementRow, MeasurementSeries, OptionalChannel};

use crate::error::SimError;
use crate::simulator::{SimConfig, Simulator};

/// A command that takes effect at `t_s` and is held until the next step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScheduleStep {
    /// Start time, s.
    pub t_s: f64,
    /// Command held from `t_s`.
    pub command: ThrustPct,
}

/// A list of timed thrust steps (zero before the first step) and an end time.
#[derive(Debug, Clone, PartialEq)]
pub struct Schedule {
    steps: Vec<ScheduleStep>,
    end_s: f64,
}

impl Schedule {
    /// Steps must have finite, strictly increasing times within [0, end_s] and valid
    /// commands (−100..100 %).
    pub fn new(steps: Vec<ScheduleStep>, end_s: f64) -> Result<Self, SimError> {
        if !(end_s.is_finite() && end_s > 0.0) {
            return Err(SimError::InvalidInput {
                detail: format!("schedule end {end_s} s must be finite and > 0"),
            });
        }
        let mut previous = f64::NEG_INFINITY;
        for (i, s) in steps.iter().enumerate() {
            if !(s.t_s.is_finite() && s.t_s >= 0.0 && s.t_s <= end_s && s.t_s > previous) {
                return Err(SimError::InvalidInput {
                    detail: format!(
                        "schedule step {i} at t = {} s must increase and lie within 0..={end_s} s",
                        s.t_s
                    ),
                });
            }
            if !s.command.is_valid() {
                return Err(SimError::InvalidInput {
                    detail: format!(
                        "schedule step {i}: command {:?} must be within -100..=100 %",
                        s.command
                    ),
                });
            }
            previous = s.t_s;
        }
        Ok(Self { steps, end_s })
    }

    /// Consecutive holds from t = 0: each `(duration_s, command)` follows the previous one.
    pub fn from_holds(holds: &[(f64, ThrustPct)]) -> Result<Self, SimError> {
        let mut t = 0.0;
        let mut steps = Vec::with_capacity(holds.len());
        for (d, cmd) in holds {
            steps.push(ScheduleStep {
                t_s: t,
                command: *cmd,
            });
            t += d;
        }
        Self::new(steps, t)
    }

    /// The steps.
    pub fn steps(&self) -> &[ScheduleStep] {
        &self.steps
    }

    /// End time, s.
    pub fn end_s(&self) -> f64 {
        self.end_s
    }

    /// The command held at `t_s` (a step at exactly `t_s` is already in effect).
    pub fn command_at(&self, t_s: f64) -> ThrustPct {
        let eps = 1e-9;
        self.steps
            .iter()
            .take_while(|s| s.t_s <= t_s + eps)
            .last()
            .map_or(ThrustPct::ZERO, |s| s.command)
    }

    /// Inputs (t_k, command) at t_k = k · period for k = 0 ..= floor(end/period).
    pub fn sample(&self, period_s: f64) -> Result<Vec<(f64, ThrustPct)>, SimError> {
        if !(period_s.is_finite() && period_s > 0.0) {
            return Err(SimError::InvalidInput {
                detail: format!("sample period {period_s} s must be finite and > 0"),
            });
        }
        let n = (self.end_s / period_s + 1e-9).floor() as u64;
        Ok((0..=n)
            .map(|k| {
                let t = k as f64 * period_s;
                (t, self.command_at(t))
            })
            .collect())
    }
}

fn all_optional_present() -> [bool; 8] {
    [true; 8]
}

/// A measurement row from sensor readings (depth from the pressure gauge; heading, pitch,
/// roll from the attitude sensor; rates from the gyro; body velocity from the DVL with
/// eq. 45 solved for ν₁; north/east from the transponder with eq. 46 solved for the
/// position, both using the measured attitude and rates).
pub fn row_from_readings(
    r: &SensorReadings,
    cmd: &ThrustPct,
    sensors: &rov_dynamics::sensors::SensorConfig,
) -> MeasurementRow {
    let att = rov_dynamics::kinematics::Attitude::new(r.roll_rad, r.pitch_rad, r.heading_rad);
    let v_body = sensors.dvl.dvl_from_body.transpose() * r.dvl_mps
        - r.gyro_body_radps.cross(&sensors.dvl.position_m);
    let p_ned = r.transponder_ned_m - att.ned_from_body() * sensors.transponder.position_m;
    let mut row = MeasurementRow {
        time_s: r.time_s,
        port_pct: cmd.port,
        starboard_pct: cmd.starboard,
        vertical_pct: cmd.vertical,
        depth_m: r.depth_from_pressure_m,
        heading_deg: r.heading_rad.to_degrees(),
        pitch_deg: r.pitch_rad.to_degrees(),
        roll_deg: r.roll_rad.to_degrees(),
        optional: [None; 8],
    };
    row.set(
        OptionalChannel::YawRateDps,
        Some(r.gyro_body_radps.z.to_degrees()),
    );
    row.set(
        OptionalChannel::PitchRateDps,
        Some(r.gyro_body_radps.y.to_degrees()),
    );
    row.set(
        OptionalChannel::RollRateDps,
        Some(r.gyro_body_radps.x.to_degrees()),
    );
    row.set(OptionalChannel::SurgeMps, Some(v_body.x));
    row.set(OptionalChannel::SwayMps, Some(v_body.y));
    row.set(OptionalChannel::HeaveMps, Some(v_body.z));
    row.set(OptionalChannel::NorthM, Some(p_ned.x));
    row.set(OptionalChannel::EastM, Some(p_ned.y));
    row
}

/// A measurement row from model outputs; channels the model does not predict are NaN.
pub fn row_from_output(o: &ModelOutput, cmd: &ThrustPct) -> MeasurementRow {
    let nan = f64::NAN;
    let mut row = MeasurementRow {
        time_s: o.time_s,
        port_pct: cmd.port,
        starboard_pct: cmd.starboard,
        vertical_pct: cmd.vertical,
        depth_m: o.depth_m.unwrap_or(nan),
        heading_deg: o.heading_deg.unwrap_or(nan),
        pitch_deg: o.pitch_deg.unwrap_or(nan),
        roll_deg: o.roll_deg.unwrap_or(nan),
        optional: [None; 8],
    };
    let opt = |x: Option<f64>| Some(x.unwrap_or(nan));
    row.set(OptionalChannel::YawRateDps, opt(o.yaw_rate_dps));
    row.set(OptionalChannel::PitchRateDps, opt(o.pitch_rate_dps));
    row.set(OptionalChannel::RollRateDps, opt(o.roll_rate_dps));
    row.set(OptionalChannel::SurgeMps, opt(o.surge_mps));
    row.set(OptionalChannel::SwayMps, opt(o.sway_mps));
    row.set(OptionalChannel::HeaveMps, opt(o.heave_mps));
    row.set(OptionalChannel::NorthM, opt(o.north_m));
    row.set(OptionalChannel::EastM, opt(o.east_m));
    row
}

/// Runs `schedule` on a simulator built from `config` and `seed`, recording a row every
/// `sample_period_s` (a whole multiple of the simulator step) from t = 0 to the end.
/// Commands change at simulator step boundaries (a step time that is not on the grid
/// takes effect at the next step). Use `config.noiseless` for a noise-free series.
pub fn run_schedule(
    config: SimConfig,
    seed: u64,
    schedule: &Schedule,
    sample_period_s: f64,
) -> Result<MeasurementSeries, SimError> {
    let sensors = config.sensors;
    let mut sim = Simulator::new(config, seed)?;
    run_schedule_on(&mut sim, &sensors, schedule, sample_period_s)
}

/// [`run_schedule`] on an existing simulator (e.g. one with an external force installed),
/// starting at its current time; `sensors` must be the simulator's sensor settings.
pub fn run_schedule_on(
    sim: &mut Simulator,
    sensors: &rov_dynamics::sensors::SensorConfig,
    schedule: &Schedule,
    sample_period_s: f64,
) -> Result<MeasurementSeries, SimError> {
    let h = sim.step_s();
    let ratio = sample_period_s / h;
    if !(ratio.is_finite() && ratio >= 1.0 - 1e-9 && (ratio - ratio.round()).abs() < 1e-6) {
        return Err(SimError::InvalidInput {
            detail: format!(
                "sample period {sample_period_s} s must be a whole multiple of the simulator step {h} s"
            ),
        });
    }
    let decimation = ratio.round() as u64;
    let t_start = sim.time_s();
    let n_steps = ((schedule.end_s() / h) + 1e-9).floor() as u64;
    let mut series = MeasurementSeries {
        present: all_optional_present(),
        ..Default::default()
    };
    for k in 0..=n_steps {
        let t_rel = k as f64 * h;
        let cmd = schedule.command_at(t_rel);
        if k % decimation == 0 {
            let mut row = row_from_readings(&sim.sensors(), &cmd, sensors);
            row.time_s = t_start + t_rel;
            series.rows.push(row);
        }
        if k == n_steps {
            break;
        }
        sim.set_command(cmd)?;
        sim.step()?;
    }
    Ok(series)
}

/// A model's prediction over timed inputs as a measurement series.
pub fn predict_inputs(
    model: &dyn VehicleModel,
    initial: &InitialConditions,
    inputs: &[(f64, ThrustPct)],
    dt_max_s: f64,
) -> Result<MeasurementSeries, SimError> {
    let x0 = model.initial_state(initial);
    let outputs = simulate_in(model, &x0, inputs, dt_max_s, &Environment::calm())?;
    Ok(MeasurementSeries {
        rows: outputs
            .iter()
            .zip(inputs)
            .map(|(o, (_, cmd))| row_from_output(o, cmd))
            .collect(),
        present: all_optional_present(),
        warnings: Vec::new(),
    })
}

/// A model's prediction of a schedule sampled every `sample_period_s`.
pub fn predict_schedule(
    model: &dyn VehicleModel,
    initial: &InitialConditions,
    schedule: &Schedule,
    sample_period_s: f64,
    dt_max_s: f64,
) -> Result<MeasurementSeries, SimError> {
    predict_inputs(model, initial, &schedule.sample(sample_period_s)?, dt_max_s)
}

/// A model's free-run prediction over a measured series: the commands of its rows, the
/// initial state from its first row.
pub fn predict_measured(
    model: &dyn VehicleModel,
    measured: &MeasurementSeries,
    dt_max_s: f64,
) -> Result<MeasurementSeries, SimError> {
    let Some(first) = measured.rows.first() else {
        return Ok(MeasurementSeries::default());
    };
    let ic = InitialConditions::from_row(first)?;
    let inputs: Vec<(f64, ThrustPct)> = measured
        .rows
        .iter()
        .map(|r| {
            (
                r.time_s,
                ThrustPct::new(r.port_pct, r.starboard_pct, r.vertical_pct),
            )
        })
        .collect();
    predict_inputs(model, &ic, &inputs, dt_max_s)
}
