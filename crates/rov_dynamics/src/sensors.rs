//! Sensor models (seed 001 eq. 42–48) and the Pro 4's own telemetry fields.
//!
//! * IMU (eq. 42–44): accelerometer = specific force at the IMU position in body axes,
//!   f = v̇ + ω×v + ω̇×r + ω×(ω×r) − Rᵀ g^n (+ bias + noise), with g^n = (0, 0, g), so a
//!   level vehicle at rest reads (0, 0, −g). Gyroscope ω + bias + noise. Magnetometer
//!   Rᵀ m^n + bias + noise for a configurable earth field m^n in NED. The earth-rotation
//!   terms of eq. 42–43 are neglected: NED is treated as inertial (slow ROV, flat earth).
//! * DVL (eq. 45): R_db (v + ω × r_dvl) + noise, in the DVL frame.
//! * Transponder (eq. 46): p + R r_tp + noise, NED.
//! * Pressure gauge (eq. 47–48): p = p_atm + ρ g z_pg + noise with z_pg the gauge depth;
//!   depth from pressure (p − p_atm)/(ρ g). Defaults: fresh water ρ = 1000 kg/m³,
//!   p_atm = 1013.25 mbar, g = 9.81 m/s² (all configurable; sea water is ≈ 1025 kg/m³).
//! * Attitude sensor: the Pro 4 reports fused heading, pitch and roll; modelled as the
//!   true Euler angles plus white noise.
//!
//! [`Pro4Outputs`] converts the readings to the integer fields of the Pro 4 navigation
//! reply (protocol.md §6.2). **Sign assumption** (not confirmed by a capture): wire
//! pitch is positive nose up and wire roll positive starboard down, i.e. the same signs as
//! Fossen's θ and φ; [`Pro4OutputConfig::pitch_sign`] and `roll_sign` can flip them (the
//! driver will make the mapping configurable).
//!
//! Noise comes from a seeded `StdRng`; [`SensorSuite::noiseless`] turns noise off (biases
//! stay as configured).

use nalgebra::{Matrix3, Vector3};
use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, StandardNormal};

use crate::kinematics::Attitude;
use crate::math::{Vector6, ang, lin};

/// IMU configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImuConfig {
    /// IMU position from CO (body axes), m.
    pub position_m: Vector3<f64>,
    /// Accelerometer bias, m/s².
    pub accel_bias_mps2: Vector3<f64>,
    /// Accelerometer white-noise standard deviation per sample, m/s².
    pub accel_noise_std_mps2: f64,
    /// Gyroscope bias, rad/s.
    pub gyro_bias_radps: Vector3<f64>,
    /// Gyroscope noise standard deviation, rad/s.
    pub gyro_noise_std_radps: f64,
    /// Earth magnetic field in NED, µT.
    pub mag_field_ned_ut: Vector3<f64>,
    /// Magnetometer bias (hard iron), µT.
    pub mag_bias_ut: Vector3<f64>,
    /// Magnetometer noise standard deviation, µT.
    pub mag_noise_std_ut: f64,
}

impl Default for ImuConfig {
    fn default() -> Self {
        Self {
            position_m: Vector3::zeros(),
            accel_bias_mps2: Vector3::zeros(),
            accel_noise_std_mps2: 0.02,
            gyro_bias_radps: Vector3::zeros(),
            gyro_noise_std_radps: 0.002,
            // Estimate: mid-latitude field, 20 µT horizontal towards north, 44 µT down.
            mag_field_ned_ut: Vector3::new(20.0, 0.0, 44.0),
            mag_bias_ut: Vector3::zeros(),
            mag_noise_std_ut: 0.5,
        }
    }
}

/// DVL configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DvlConfig {
    /// DVL position from CO, m.
    pub position_m: Vector3<f64>,
    /// R_db: rotation from body to DVL axes.
    pub dvl_from_body: Matrix3<f64>,
    /// Noise standard deviation, m/s.
    pub noise_std_mps: f64,
}

impl Default for DvlConfig {
    fn default() -> Self {
        Self {
            position_m: Vector3::zeros(),
            dvl_from_body: Matrix3::identity(),
            noise_std_mps: 0.01,
        }
    }
}

/// Transponder (acoustic positioning) configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TransponderConfig {
    /// Transponder position from CO, m.
    pub position_m: Vector3<f64>,
    /// Noise standard deviation per NED axis, m.
    pub noise_std_m: f64,
}

impl Default for TransponderConfig {
    fn default() -> Self {
        Self {
            position_m: Vector3::zeros(),
            noise_std_m: 0.5,
        }
    }
}

/// Pressure gauge configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PressureConfig {
    /// Gauge position from CO, m.
    pub position_m: Vector3<f64>,
    /// Noise standard deviation, mbar.
    pub noise_std_mbar: f64,
}

impl Default for PressureConfig {
    fn default() -> Self {
        Self {
            position_m: Vector3::zeros(),
            noise_std_mbar: 0.5,
        }
    }
}

/// Fused attitude output (heading, pitch, roll) noise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AttitudeSensorConfig {
    /// Heading noise standard deviation, deg.
    pub heading_noise_std_deg: f64,
    /// Pitch noise standard deviation, deg.
    pub pitch_noise_std_deg: f64,
    /// Roll noise standard deviation, deg.
    pub roll_noise_std_deg: f64,
}

impl Default for AttitudeSensorConfig {
    fn default() -> Self {
        Self {
            heading_noise_std_deg: 0.5,
            pitch_noise_std_deg: 0.2,
            roll_noise_std_deg: 0.2,
        }
    }
}

/// Conversion to the Pro 4's integer telemetry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pro4OutputConfig {
    /// Raw magnetometer counts per µT (estimate: an HMC5883-class part at its ±1.3 Ga
    /// range, 1090 LSB/G = 10.9 LSB/µT).
    pub mag_counts_per_ut: f64,
    /// Water temperature reported, °C.
    pub water_temperature_c: f64,
    /// Internal relative humidity reported, %.
    pub humidity_pct: f64,
    /// Total power available reported, %.
    pub power_available_pct: u8,
    /// Wire pitch = `pitch_sign` · θ (+1: positive nose up, the default assumption).
    pub pitch_sign: f64,
    /// Wire roll = `roll_sign` · φ (+1: positive starboard down, the default assumption).
    pub roll_sign: f64,
}

impl Default for Pro4OutputConfig {
    fn default() -> Self {
        Self {
            mag_counts_per_ut: 10.9,
            water_temperature_c: 15.0,
            humidity_pct: 30.0,
            power_available_pct: 100,
            pitch_sign: 1.0,
            roll_sign: 1.0,
        }
    }
}

/// All sensor settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorConfig {
    /// Gravity g, m/s².
    pub gravity_mps2: f64,
    /// Water density ρ, kg/m³ (default fresh water, 1000).
    pub water_density_kgpm3: f64,
    /// Atmospheric pressure at the surface, mbar (default 1013.25).
    pub atmospheric_pressure_mbar: f64,
    /// IMU.
    pub imu: ImuConfig,
    /// DVL.
    pub dvl: DvlConfig,
    /// Transponder.
    pub transponder: TransponderConfig,
    /// Pressure gauge.
    pub pressure: PressureConfig,
    /// Attitude output.
    pub attitude: AttitudeSensorConfig,
    /// Pro 4 integer outputs.
    pub pro4: Pro4OutputConfig,
}

impl Default for SensorConfig {
    fn default() -> Self {
        Self {
            gravity_mps2: 9.81,
            water_density_kgpm3: 1000.0,
            atmospheric_pressure_mbar: 1013.25,
            imu: ImuConfig::default(),
            dvl: DvlConfig::default(),
            transponder: TransponderConfig::default(),
            pressure: PressureConfig::default(),
            attitude: AttitudeSensorConfig::default(),
            pro4: Pro4OutputConfig::default(),
        }
    }
}

/// One set of sensor readings in SI units, plus the Pro 4 integer fields.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorReadings {
    /// Sample time, s.
    pub time_s: f64,
    /// Accelerometer: specific force at the IMU, body axes, m/s².
    pub accel_body_mps2: Vector3<f64>,
    /// Gyroscope: body rates (p, q, r), rad/s.
    pub gyro_body_radps: Vector3<f64>,
    /// Magnetometer, body axes, µT.
    pub mag_body_ut: Vector3<f64>,
    /// DVL velocity in DVL axes, m/s.
    pub dvl_mps: Vector3<f64>,
    /// Transponder position, NED, m.
    pub transponder_ned_m: Vector3<f64>,
    /// Absolute pressure at the gauge, mbar.
    pub pressure_mbar: f64,
    /// Gauge depth computed from the pressure, m.
    pub depth_from_pressure_m: f64,
    /// Heading ψ, rad (continuous, not wrapped).
    pub heading_rad: f64,
    /// Pitch θ, rad (positive nose up).
    pub pitch_rad: f64,
    /// Roll φ, rad (positive starboard down).
    pub roll_rad: f64,
    /// The same readings as Pro 4 telemetry integers.
    pub pro4: Pro4Outputs,
}

/// The fields of the Pro 4 navigation reply (protocol.md §6.2), ready for the mock vehicle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Pro4Outputs {
    /// Heading ×10, 0..=3599.
    pub heading_deci_deg: i16,
    /// Pitch ×10 (sign: see [`Pro4OutputConfig::pitch_sign`]).
    pub pitch_deci_deg: i16,
    /// Roll ×10 (sign: see [`Pro4OutputConfig::roll_sign`]).
    pub roll_deci_deg: i16,
    /// Absolute pressure, mbar (int16 on the wire; saturates at 32767 ≈ 317 m).
    pub pressure_mbar: i16,
    /// "Yaw acceleration" field: yaw rate r ×1000, rad/s.
    pub yaw_rate_milli_radps: i16,
    /// "Pitch acceleration" field: pitch rate q ×1000, rad/s.
    pub pitch_rate_milli_radps: i16,
    /// "Roll acceleration" field: roll rate p ×1000, rad/s.
    pub roll_rate_milli_radps: i16,
    /// Surge specific force ×1000, m/s².
    pub surge_accel_milli_mps2: i16,
    /// Sway specific force ×1000, m/s².
    pub sway_accel_milli_mps2: i16,
    /// Heave specific force ×1000, m/s² (≈ −9810 when level).
    pub heave_accel_milli_mps2: i16,
    /// Raw magnetometer X, ADC counts.
    pub mag_x_raw: i16,
    /// Raw magnetometer Y, ADC counts.
    pub mag_y_raw: i16,
    /// Raw magnetometer Z, ADC counts.
    pub mag_z_raw: i16,
    /// Attitude-sensor status, 0 = OK.
    pub attitude_status: i16,
    /// Internal relative humidity, %.
    pub humidity_pct: i16,
    /// Water temperature ×100, °C.
    pub water_temperature_centi_c: i16,
    /// Total power available, %.
    pub power_available_pct: u8,
}

/// Rounds and saturates to i16 (NaN gives 0).
pub fn saturate_i16(x: f64) -> i16 {
    if x.is_nan() {
        0
    } else {
        x.round().clamp(f64::from(i16::MIN), f64::from(i16::MAX)) as i16
    }
}

impl Pro4Outputs {
    /// Converts SI readings.
    pub fn from_readings(r: &SensorReadings, cfg: &Pro4OutputConfig) -> Self {
        let heading_deg = r.heading_rad.to_degrees().rem_euclid(360.0);
        let mut heading = (heading_deg * 10.0).round();
        if heading >= 3600.0 {
            heading -= 3600.0;
        }
        let mag = r.mag_body_ut * cfg.mag_counts_per_ut;
        Self {
            heading_deci_deg: saturate_i16(heading),
            pitch_deci_deg: saturate_i16(cfg.pitch_sign * r.pitch_rad.to_degrees() * 10.0),
            roll_deci_deg: saturate_i16(cfg.roll_sign * r.roll_rad.to_degrees() * 10.0),
            pressure_mbar: saturate_i16(r.pressure_mbar),
            yaw_rate_milli_radps: saturate_i16(r.gyro_body_radps.z * 1000.0),
            pitch_rate_milli_radps: saturate_i16(r.gyro_body_radps.y * 1000.0),
            roll_rate_milli_radps: saturate_i16(r.gyro_body_radps.x * 1000.0),
            surge_accel_milli_mps2: saturate_i16(r.accel_body_mps2.x * 1000.0),
            sway_accel_milli_mps2: saturate_i16(r.accel_body_mps2.y * 1000.0),
            heave_accel_milli_mps2: saturate_i16(r.accel_body_mps2.z * 1000.0),
            mag_x_raw: saturate_i16(mag.x),
            mag_y_raw: saturate_i16(mag.y),
            mag_z_raw: saturate_i16(mag.z),
            attitude_status: 0,
            humidity_pct: saturate_i16(cfg.humidity_pct),
            water_temperature_centi_c: saturate_i16(cfg.water_temperature_c * 100.0),
            power_available_pct: cfg.power_available_pct,
        }
    }
}

/// Noise-free measurement functions (seed 001 eq. 42–48).
impl SensorConfig {
    /// Specific force at the IMU in body axes (eq. 42 without earth rate, bias, noise).
    pub fn specific_force_body(
        &self,
        eta: &Vector6,
        nu: &Vector6,
        nu_dot: &Vector6,
    ) -> Vector3<f64> {
        let att = Attitude::from_eta(eta);
        let (v, w) = (lin(nu), ang(nu));
        let (v_dot, w_dot) = (lin(nu_dot), ang(nu_dot));
        let r = self.imu.position_m;
        let accel = v_dot + w.cross(&v) + w_dot.cross(&r) + w.cross(&w.cross(&r));
        accel - att.down_in_body() * self.gravity_mps2
    }

    /// Magnetometer field in body axes (eq. 44 without bias and noise).
    pub fn mag_body_ut(&self, eta: &Vector6) -> Vector3<f64> {
        Attitude::from_eta(eta).ned_from_body().transpose() * self.imu.mag_field_ned_ut
    }

    /// DVL velocity in DVL axes (eq. 45 without noise).
    pub fn dvl_mps(&self, nu: &Vector6) -> Vector3<f64> {
        self.dvl.dvl_from_body * (lin(nu) + ang(nu).cross(&self.dvl.position_m))
    }

    /// Transponder position in NED (eq. 46 without noise).
    pub fn transponder_ned_m(&self, eta: &Vector6) -> Vector3<f64> {
        lin(eta) + Attitude::from_eta(eta).ned_from_body() * self.transponder.position_m
    }

    /// Gauge depth z_pg (eq. 48).
    pub fn gauge_depth_m(&self, eta: &Vector6) -> f64 {
        eta[2] + (Attitude::from_eta(eta).ned_from_body() * self.pressure.position_m).z
    }

    /// Absolute pressure at depth `depth_m`, mbar (eq. 47 without noise).
    pub fn pressure_mbar_at(&self, depth_m: f64) -> f64 {
        self.atmospheric_pressure_mbar
            + self.water_density_kgpm3 * self.gravity_mps2 * depth_m * 0.01
    }

    /// Depth from an absolute pressure, m: (p − p_atm)/(ρ g).
    pub fn depth_from_pressure_m(&self, pressure_mbar: f64) -> f64 {
        (pressure_mbar - self.atmospheric_pressure_mbar) * 100.0
            / (self.water_density_kgpm3 * self.gravity_mps2)
    }
}

/// The sensors with their noise generator.
#[derive(Debug, Clone)]
pub struct SensorSuite {
    config: SensorConfig,
    rng: StdRng,
    noiseless: bool,
}

impl SensorSuite {
    /// Sensors with noise from `seed`.
    pub fn new(config: SensorConfig, seed: u64) -> Self {
        Self {
            config,
            rng: StdRng::seed_from_u64(seed),
            noiseless: false,
        }
    }

    /// Sensors without noise (biases still apply).
    pub fn noiseless(config: SensorConfig) -> Self {
        Self {
            config,
            rng: StdRng::seed_from_u64(0),
            noiseless: true,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &SensorConfig {
        &self.config
    }

    fn n(&mut self, std: f64) -> f64 {
        if self.noiseless || std == 0.0 {
            return 0.0;
        }
        let z: f64 = StandardNormal.sample(&mut self.rng);
        std * z
    }

    fn n3(&mut self, std: f64) -> Vector3<f64> {
        let x = self.n(std);
        let y = self.n(std);
        let z = self.n(std);
        Vector3::new(x, y, z)
    }

    /// Measures state (η, ν) with acceleration ν̇ at time `time_s`.
    pub fn measure(
        &mut self,
        time_s: f64,
        eta: &Vector6,
        nu: &Vector6,
        nu_dot: &Vector6,
    ) -> SensorReadings {
        let c = self.config;
        let accel = c.specific_force_body(eta, nu, nu_dot)
            + c.imu.accel_bias_mps2
            + self.n3(c.imu.accel_noise_std_mps2);
        let gyro = ang(nu) + c.imu.gyro_bias_radps + self.n3(c.imu.gyro_noise_std_radps);
        let mag = c.mag_body_ut(eta) + c.imu.mag_bias_ut + self.n3(c.imu.mag_noise_std_ut);
        let dvl = c.dvl_mps(nu) + self.n3(c.dvl.noise_std_mps);
        let tp = c.transponder_ned_m(eta) + self.n3(c.transponder.noise_std_m);
        let pressure = c.pressure_mbar_at(c.gauge_depth_m(eta)) + self.n(c.pressure.noise_std_mbar);
        let heading = eta[5] + self.n(c.attitude.heading_noise_std_deg.to_radians());
        let pitch = eta[4] + self.n(c.attitude.pitch_noise_std_deg.to_radians());
        let roll = eta[3] + self.n(c.attitude.roll_noise_std_deg.to_radians());
        let mut r = SensorReadings {
            time_s,
            accel_body_mps2: accel,
            gyro_body_radps: gyro,
            mag_body_ut: mag,
            dvl_mps: dvl,
            transponder_ned_m: tp,
            pressure_mbar: pressure,
            depth_from_pressure_m: c.depth_from_pressure_m(pressure),
            heading_rad: heading,
            pitch_rad: pitch,
            roll_rad: roll,
            pro4: Pro4Outputs::default(),
        };
        r.pro4 = Pro4Outputs::from_readings(&r, &c.pro4);
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn level_at_rest_reads_minus_g_and_pro4_heave_minus_9810() {
        let mut s = SensorSuite::noiseless(SensorConfig::default());
        let eta = Vector6::new(0.0, 0.0, 2.0, 0.0, 0.0, 0.0);
        let r = s.measure(0.0, &eta, &Vector6::zeros(), &Vector6::zeros());
        assert!((r.accel_body_mps2 - Vector3::new(0.0, 0.0, -9.81)).norm() < 1e-12);
        assert_eq!(r.pro4.heave_accel_milli_mps2, -9810);
        assert!((r.depth_from_pressure_m - 2.0).abs() < 1e-12);
        assert_eq!(r.pro4.pressure_mbar, (1013.25_f64 + 196.2).round() as i16);
        assert_eq!(r.pro4.heading_deci_deg, 0);
        assert_eq!(r.pro4.water_temperature_centi_c, 1500);
    }

    #[test]
    fn pitch_nose_up_gives_positive_wire_pitch_and_forward_gravity_component() {
        let mut s = SensorSuite::noiseless(SensorConfig::default());
        let eta = Vector6::new(0.0, 0.0, 1.0, -0.1, 0.2, -0.5);
        let r = s.measure(0.0, &eta, &Vector6::zeros(), &Vector6::zeros());
        assert_eq!(
            r.pro4.pitch_deci_deg,
            saturate_i16(0.2_f64.to_degrees() * 10.0)
        );
        assert_eq!(
            r.pro4.roll_deci_deg,
            saturate_i16(-0.1_f64.to_degrees() * 10.0)
        );
        // Nose up: the accelerometer's x axis sees +g sin θ.
        assert!((r.accel_body_mps2.x - 9.81 * 0.2_f64.sin()).abs() < 1e-12);
        // Heading wraps into 0..3599.
        let expected = ((-0.5_f64).to_degrees().rem_euclid(360.0) * 10.0).round() as i16;
        assert_eq!(r.pro4.heading_deci_deg, expected);
        assert!((0..3600).contains(&r.pro4.heading_deci_deg));
    }

    #[test]
    fn lever_arms_and_rates() {
        let mut cfg = SensorConfig::default();
        cfg.imu.position_m = Vector3::new(0.1, 0.0, 0.0);
        cfg.dvl.position_m = Vector3::new(0.0, 0.0, 0.1);
        cfg.pressure.position_m = Vector3::new(0.2, 0.0, 0.0);
        let mut s = SensorSuite::noiseless(cfg);
        let eta = Vector6::new(0.0, 0.0, 1.0, 0.0, 0.1, 0.0);
        let nu = Vector6::new(0.5, 0.0, 0.0, 0.0, 0.0, 1.0);
        let r = s.measure(0.0, &eta, &nu, &Vector6::zeros());
        // Centripetal acceleration at r = 0.1 m with r = 1 rad/s points to the centre.
        let expected_x = -0.1 - 9.81 * (-(0.1_f64).sin());
        assert!((r.accel_body_mps2.x - expected_x).abs() < 1e-12);
        assert_eq!(r.pro4.yaw_rate_milli_radps, 1000);
        // DVL at (0,0,0.1) with yaw rate only: ω × r = 0.
        assert!((r.dvl_mps - Vector3::new(0.5, 0.0, 0.0)).norm() < 1e-15);
        // Gauge 0.2 m forward, nose up 0.1 rad: shallower by 0.2 sin 0.1.
        assert!((r.depth_from_pressure_m - (1.0 - 0.2 * 0.1_f64.sin())).abs() < 1e-12);
    }

    #[test]
    fn noise_is_seeded_and_deterministic() {
        let eta = Vector6::new(0.0, 0.0, 1.0, 0.0, 0.0, 0.3);
        let run = |seed| {
            let mut s = SensorSuite::new(SensorConfig::default(), seed);
            (0..10)
                .map(|k| {
                    s.measure(k as f64, &eta, &Vector6::zeros(), &Vector6::zeros())
                        .pressure_mbar
                })
                .collect::<Vec<_>>()
        };
        assert_eq!(run(1), run(1));
        assert_ne!(run(1), run(2));
    }
}
