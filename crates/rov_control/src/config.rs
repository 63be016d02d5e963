//! Controller configuration: defaults that tests and the station use, validation, and a
//! loader for the `[control]` section of `config/station.toml`.
//!
//! Internal units are SI with radians; the TOML keys carry their units, and heading keys
//! given in degrees are converted on load.

use rov_types::{ConfigError, ParamFile};

use crate::error::{ControlError, check_range};
use crate::feedforward::ModelChoice;
use crate::guard::GuardConfig;
use crate::observer::ChannelNoise;
use crate::pid::PidConfig;
use crate::pilot::{SurfaceTare, TARE_RANGE_MBAR};
use crate::reference::ReferenceConfig;

/// How the feedforward command is combined with the feedback (which works in force
/// through the control plant model's thrust map).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FeedforwardForce {
    /// The feedforward counts with the force its command (from the selected model's
    /// inverted thrust map) produces according to the control plant model: the selected
    /// model's thrust map really shapes what the vehicle gets (`as_produced`).
    #[default]
    AsProduced,
    /// The feedforward counts with the force the selected model intended; the sum is
    /// inverted with the control plant model's thrust map, so the selected model's own
    /// map only bounds the feedforward (`as_modelled`).
    AsModelled,
}

/// Settings of one held axis. Units: depth in m and N, heading in rad and N·m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisConfig {
    /// PID gains and limits (force or moment output).
    pub pid: PidConfig,
    /// Reference model limits.
    pub reference: ReferenceConfig,
    /// Observer channel noise and gating.
    pub observer: ChannelNoise,
    /// Stick magnitude below which the stick counts as centred (0..1).
    pub stick_deadband: f64,
    /// Thrust at full stick in manual or override, %.
    pub manual_max_pct: f64,
    /// A hold on this axis drops to manual (neutral, fault flag) when no usable sample
    /// has arrived for this long, s.
    pub sensor_timeout_s: f64,
}

/// The whole controller configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlConfig {
    /// Nominal control rate, Hz (the first tick uses 1/rate as its dt).
    pub rate_hz: f64,
    /// Longest dt a tick integrates, s (longer gaps are clamped and flagged).
    pub max_dt_s: f64,
    /// Depth axis.
    pub depth: AxisConfig,
    /// Heading axis.
    pub heading: AxisConfig,
    /// Surge at full stick, %.
    pub surge_max_pct: f64,
    /// Surge stick deadband (0..1).
    pub surge_deadband: f64,
    /// Which model supplies the feedforward (switchable at run time).
    pub feedforward_model: ModelChoice,
    /// The control plant model: the observer's inertia, damping and thrust map, the
    /// feedback's thrust-map inversion and the force limits (default model3).
    pub plant_model: ModelChoice,
    /// Feedforward on or off (the thrust-map inversion stays on either way).
    pub feedforward_enabled: bool,
    /// How the feedforward command joins the feedback force.
    pub feedforward_force: FeedforwardForce,
    /// Use the Kalman observer for feedback (else raw measurements, differentiated).
    pub observer_enabled: bool,
    /// Subtract the observer's bias estimate from the demand (disturbance feedforward).
    pub bias_compensation: bool,
    /// Output guard.
    pub guard: GuardConfig,
    /// Water density for pressure ↔ depth, kg/m³ (fresh 1000, sea 1025).
    pub water_density_kg_m3: f64,
    /// Where the surface pressure tare comes from.
    pub surface_tare: SurfaceTare,
    /// Plausible depth samples, m; anything outside is treated as missing.
    pub depth_valid_min_m: f64,
    /// Upper end of plausible depth samples, m.
    pub depth_valid_max_m: f64,
}

impl AxisConfig {
    /// Default depth settings (tuned against the 6-DOF simulator, model3 truth).
    pub fn default_depth() -> Self {
        AxisConfig {
            // kp 60 N/m and kd 25 N s/m on ~11 kg (mass + heave added mass): ζ ≈ 0.48 at
            // ωn ≈ 2.3 rad/s before the hydrodynamic damping. The former 130 / 20 gave
            // ζ ≈ 0.26 at 3.4 rad/s, a resonance that depth noise kept ringing at a steady
            // hold (tests/it/depth_hold_chatter.rs). Steps and profiles are carried by the
            // reference model and the feedforward, so their settling, overshoot and
            // tracking did not move (tests/it/hold_acceptance.rs); feedback alone (no
            // feedforward) tracks a ramp about twice as loosely as before.
            pid: PidConfig {
                kp: 60.0,
                ki: 8.0,
                kd: 25.0,
                derivative_filter_s: 0.1,
                i_max: 5.0,
                out_min: -10.0,
                out_max: 10.0,
                slew_per_s: 100.0,
            },
            reference: ReferenceConfig {
                natural_freq_rad_s: 2.0,
                vel_max: 0.4,
                acc_max: 0.4,
            },
            // Observer bandwidth matched to the pressure sensor: meas_std is 1.5 mbar of
            // gauge noise (1.53 cm in fresh water; the lab's noisy-depth figure), and the
            // force noise (unmodelled heave force) is 0.1 N/√Hz. With 0.5 N/√Hz and 1 cm
            // the estimate followed the noise, P and D passed it on, and the thrust map's
            // inverse (steepest near zero force) turned it into a vertical command of
            // 20–30 % RMS reversing several times a second at a steady hold
            // (tests/it/depth_hold_chatter.rs). Slow unmodelled loads are the bias state's
            // job. Not lower: the force noise is also the room left for an imperfect
            // plant model, and at 0.05 N/√Hz a lab-calibrated model2 as the control plant
            // tracked worse than no feedforward (topside/tests/it/model_loop.rs).
            observer: ChannelNoise {
                force_noise: 0.1,
                bias_noise: 0.05,
                bias_time_constant_s: 600.0,
                meas_std: 0.015,
                rate_meas_std: 0.05,
                gate_sigma: 5.0,
                reset_after_rejects: 25,
                manoeuvre_threshold: 1.5,
                manoeuvre_noise_factor: 30.0,
                init_vel_std: 0.2,
                init_bias_std: 3.0,
            },
            stick_deadband: 0.05,
            manual_max_pct: 100.0,
            sensor_timeout_s: 1.0,
        }
    }

    /// Default heading settings (tuned against the 6-DOF simulator, model3 truth).
    pub fn default_heading() -> Self {
        AxisConfig {
            pid: PidConfig {
                kp: 5.0,
                ki: 5.0,
                kd: 1.3,
                derivative_filter_s: 0.05,
                i_max: 1.5,
                out_min: -3.4,
                out_max: 3.4,
                slew_per_s: 30.0,
            },
            reference: ReferenceConfig {
                natural_freq_rad_s: 3.0,
                vel_max: 40f64.to_radians(),
                acc_max: 60f64.to_radians(),
            },
            observer: ChannelNoise {
                force_noise: 0.02,
                bias_noise: 0.005,
                bias_time_constant_s: 600.0,
                meas_std: 0.5f64.to_radians(),
                rate_meas_std: 0.5f64.to_radians(),
                gate_sigma: 5.0,
                reset_after_rejects: 25,
                manoeuvre_threshold: 1.5,
                manoeuvre_noise_factor: 30.0,
                init_vel_std: 10f64.to_radians(),
                init_bias_std: 0.3,
            },
            stick_deadband: 0.05,
            manual_max_pct: 60.0,
            sensor_timeout_s: 1.0,
        }
    }

    fn validate(&self, name: &str) -> Result<(), ControlError> {
        self.pid.validate(&format!("{name}.pid"))?;
        self.reference.validate(&format!("{name}.reference"))?;
        self.observer.validate(&format!("{name}.observer"))?;
        check_range(
            &format!("{name}.stick_deadband"),
            self.stick_deadband,
            0.0,
            0.9,
        )?;
        check_range(
            &format!("{name}.manual_max_pct"),
            self.manual_max_pct,
            0.0,
            100.0,
        )?;
        check_range(
            &format!("{name}.sensor_timeout_s"),
            self.sensor_timeout_s,
            0.01,
            60.0,
        )?;
        Ok(())
    }
}

impl Default for ControlConfig {
    fn default() -> Self {
        ControlConfig {
            rate_hz: 50.0,
            max_dt_s: 1.0,
            depth: AxisConfig::default_depth(),
            heading: AxisConfig::default_heading(),
            surge_max_pct: 100.0,
            surge_deadband: 0.05,
            feedforward_model: ModelChoice::Model3,
            plant_model: ModelChoice::Model3,
            feedforward_enabled: true,
            feedforward_force: FeedforwardForce::AsProduced,
            observer_enabled: true,
            bias_compensation: true,
            guard: GuardConfig {
                max_pct: 100.0,
                max_step_pct: 10.0,
            },
            water_density_kg_m3: 1000.0,
            surface_tare: SurfaceTare::AtConnection,
            depth_valid_min_m: -5.0,
            depth_valid_max_m: 400.0,
        }
    }
}

impl ControlConfig {
    /// Checks every field (finite, in range, consistent).
    pub fn validate(&self) -> Result<(), ControlError> {
        check_range("rate_hz", self.rate_hz, 1.0, 1000.0)?;
        check_range("max_dt_s", self.max_dt_s, 1.0 / self.rate_hz, 10.0)?;
        self.depth.validate("depth")?;
        self.heading.validate("heading")?;
        check_range("surge_max_pct", self.surge_max_pct, 0.0, 100.0)?;
        check_range("surge_deadband", self.surge_deadband, 0.0, 0.9)?;
        self.guard.validate("guard")?;
        check_range(
            "water_density_kg_m3",
            self.water_density_kg_m3,
            900.0,
            1100.0,
        )?;
        if let SurfaceTare::Configured(p) = self.surface_tare {
            check_range(
                "surface_pressure_mbar",
                p,
                TARE_RANGE_MBAR.0,
                TARE_RANGE_MBAR.1,
            )?;
        }
        check_range("depth_valid_min_m", self.depth_valid_min_m, -100.0, 0.0)?;
        check_range("depth_valid_max_m", self.depth_valid_max_m, 1.0, 11_000.0)?;
        Ok(())
    }

    /// Reads the `[control]` section of a parsed station file. Absent keys take the
    /// defaults; unknown keys under `control` are rejected; every error names the file,
    /// the key, the value and the allowed range.
    pub fn from_param_file(f: &ParamFile) -> Result<Self, ConfigError> {
        let d = ControlConfig::default();
        let tare_mode = f.choice(
            "control.surface_tare",
            &["at_connection", "configured"],
            Some("at_connection"),
        )?;
        let tare_mbar = f.f64_or(
            "control.surface_pressure_mbar",
            TARE_RANGE_MBAR.0..=TARE_RANGE_MBAR.1,
            1013.25,
        )?;
        let model = f.choice(
            "control.feedforward_model",
            &["model1", "model2", "model3"],
            Some("model3"),
        )?;
        let plant = f.choice(
            "control.plant_model",
            &["model1", "model2", "model3"],
            Some("model3"),
        )?;
        let ff_force = f.choice(
            "control.feedforward_force",
            &["as_produced", "as_modelled"],
            Some("as_produced"),
        )?;
        let rate_hz = f.f64_or("control.rate_hz", 1.0..=1000.0, d.rate_hz)?;
        let cfg = ControlConfig {
            rate_hz,
            max_dt_s: f.f64_or("control.max_dt_s", 0.001..=10.0, d.max_dt_s)?,
            depth: read_axis(f, "control.depth", &d.depth, false)?,
            heading: read_axis(f, "control.heading", &d.heading, true)?,
            surge_max_pct: f.f64_or("control.surge_max_pct", 0.0..=100.0, d.surge_max_pct)?,
            surge_deadband: f.f64_or("control.surge_deadband", 0.0..=0.9, d.surge_deadband)?,
            feedforward_model: ModelChoice::from_name(&model).unwrap_or_default(),
            plant_model: ModelChoice::from_name(&plant).unwrap_or_default(),
            feedforward_force: if ff_force == "as_modelled" {
                FeedforwardForce::AsModelled
            } else {
                FeedforwardForce::AsProduced
            },
            feedforward_enabled: f.bool_or("control.feedforward", d.feedforward_enabled)?,
            observer_enabled: f.bool_or("control.observer", d.observer_enabled)?,
            bias_compensation: f.bool_or("control.bias_compensation", d.bias_compensation)?,
            guard: GuardConfig {
                max_pct: f.f64_or("control.guard.max_pct", 0.0..=100.0, d.guard.max_pct)?,
                max_step_pct: f.f64_or(
                    "control.guard.max_step_pct_per_tick",
                    0.01..=200.0,
                    d.guard.max_step_pct,
                )?,
            },
            water_density_kg_m3: f.f64_or(
                "control.water_density_kg_m3",
                900.0..=1100.0,
                d.water_density_kg_m3,
            )?,
            surface_tare: if tare_mode == "configured" {
                SurfaceTare::Configured(tare_mbar)
            } else {
                SurfaceTare::AtConnection
            },
            depth_valid_min_m: f.f64_or(
                "control.depth_valid_min_m",
                -100.0..=0.0,
                d.depth_valid_min_m,
            )?,
            depth_valid_max_m: f.f64_or(
                "control.depth_valid_max_m",
                1.0..=11_000.0,
                d.depth_valid_max_m,
            )?,
        };
        f.reject_unknown("control")?;
        cfg.validate().map_err(|e| ConfigError::Inconsistent {
            file: f.file().to_string(),
            message: e.to_string(),
        })?;
        Ok(cfg)
    }

    /// Parses `text` (a whole station file) and reads its `[control]` section.
    pub fn from_toml_str(text: &str, file_label: &str) -> Result<Self, ConfigError> {
        let f = ParamFile::parse(text, file_label, false)?;
        Self::from_param_file(&f)
    }
}

/// Reads one axis. Heading keys for angles are in degrees (converted to rad); gains are
/// per radian.
fn read_axis(
    f: &ParamFile,
    base: &str,
    d: &AxisConfig,
    heading: bool,
) -> Result<AxisConfig, ConfigError> {
    let k = |name: &str| format!("{base}.{name}");
    let (force, pos) = if heading { ("nm", "rad") } else { ("n", "m") };
    let deg = |x: f64| x.to_degrees();
    let rad = |x: f64| x.to_radians();
    let pid = PidConfig {
        kp: f.f64_or(&k(&format!("kp_{force}_per_{pos}")), 0.0..=1e6, d.pid.kp)?,
        ki: f.f64_or(&k(&format!("ki_{force}_per_{pos}_s")), 0.0..=1e6, d.pid.ki)?,
        kd: f.f64_or(&k(&format!("kd_{force}_s_per_{pos}")), 0.0..=1e6, d.pid.kd)?,
        derivative_filter_s: f.f64_or(
            &k("derivative_filter_s"),
            0.0..=10.0,
            d.pid.derivative_filter_s,
        )?,
        i_max: f.f64_or(&k(&format!("i_max_{force}")), 0.0..=1e6, d.pid.i_max)?,
        out_min: d.pid.out_min,
        out_max: d.pid.out_max,
        slew_per_s: f.f64_or(
            &k(&format!("slew_{force}_per_s")),
            1e-6..=1e9,
            d.pid.slew_per_s,
        )?,
    };
    // Heading output limits are symmetric; depth has separate up and down limits.
    let pid = if heading {
        let lim = f.f64_or(&k("out_max_nm"), 0.0..=1e6, d.pid.out_max)?;
        PidConfig {
            out_min: -lim,
            out_max: lim,
            ..pid
        }
    } else {
        PidConfig {
            out_min: -f.f64_or(&k("out_max_up_n"), 0.0..=1e6, -d.pid.out_min)?,
            out_max: f.f64_or(&k("out_max_down_n"), 0.0..=1e6, d.pid.out_max)?,
            ..pid
        }
    };
    let reference = if heading {
        ReferenceConfig {
            natural_freq_rad_s: f.f64_or(
                &k("reference.natural_freq_rad_s"),
                0.01..=100.0,
                d.reference.natural_freq_rad_s,
            )?,
            vel_max: rad(f.f64_or(
                &k("reference.vel_max_deg_s"),
                0.01..=720.0,
                deg(d.reference.vel_max),
            )?),
            acc_max: rad(f.f64_or(
                &k("reference.acc_max_deg_s2"),
                0.01..=7200.0,
                deg(d.reference.acc_max),
            )?),
        }
    } else {
        ReferenceConfig {
            natural_freq_rad_s: f.f64_or(
                &k("reference.natural_freq_rad_s"),
                0.01..=100.0,
                d.reference.natural_freq_rad_s,
            )?,
            vel_max: f.f64_or(
                &k("reference.vel_max_m_s"),
                0.001..=10.0,
                d.reference.vel_max,
            )?,
            acc_max: f.f64_or(
                &k("reference.acc_max_m_s2"),
                0.001..=100.0,
                d.reference.acc_max,
            )?,
        }
    };
    let o = &d.observer;
    let observer = if heading {
        ChannelNoise {
            force_noise: f.f64_or(
                &k("observer.moment_noise_nm_per_sqrt_hz"),
                1e-9..=1e4,
                o.force_noise,
            )?,
            bias_noise: f.f64_or(
                &k("observer.bias_noise_nm_per_sqrt_s"),
                0.0..=1e4,
                o.bias_noise,
            )?,
            bias_time_constant_s: f.f64_or(
                &k("observer.bias_time_constant_s"),
                1.0..=1e7,
                o.bias_time_constant_s,
            )?,
            meas_std: rad(f.f64_or(&k("observer.meas_std_deg"), 1e-6..=90.0, deg(o.meas_std))?),
            rate_meas_std: rad(f.f64_or(
                &k("observer.rate_meas_std_deg_s"),
                1e-6..=1000.0,
                deg(o.rate_meas_std),
            )?),
            gate_sigma: f.f64_or(&k("observer.gate_sigma"), 1.0..=1e3, o.gate_sigma)?,
            reset_after_rejects: f
                .f64_or(
                    &k("observer.reset_after_rejects"),
                    1.0..=1e6,
                    f64::from(o.reset_after_rejects),
                )?
                .round() as u32,
            manoeuvre_threshold: f.f64_or(
                &k("observer.manoeuvre_threshold"),
                0.0..=100.0,
                o.manoeuvre_threshold,
            )?,
            manoeuvre_noise_factor: f.f64_or(
                &k("observer.manoeuvre_noise_factor"),
                1.0..=1e4,
                o.manoeuvre_noise_factor,
            )?,
            init_vel_std: rad(f.f64_or(
                &k("observer.init_rate_std_deg_s"),
                0.0..=1e4,
                deg(o.init_vel_std),
            )?),
            init_bias_std: f.f64_or(&k("observer.init_bias_std_nm"), 0.0..=1e4, o.init_bias_std)?,
        }
    } else {
        ChannelNoise {
            force_noise: f.f64_or(
                &k("observer.force_noise_n_per_sqrt_hz"),
                1e-9..=1e4,
                o.force_noise,
            )?,
            bias_noise: f.f64_or(
                &k("observer.bias_noise_n_per_sqrt_s"),
                0.0..=1e4,
                o.bias_noise,
            )?,
            bias_time_constant_s: f.f64_or(
                &k("observer.bias_time_constant_s"),
                1.0..=1e7,
                o.bias_time_constant_s,
            )?,
            meas_std: f.f64_or(&k("observer.meas_std_m"), 1e-9..=1e3, o.meas_std)?,
            rate_meas_std: f.f64_or(
                &k("observer.rate_meas_std_m_s"),
                1e-9..=1e3,
                o.rate_meas_std,
            )?,
            gate_sigma: f.f64_or(&k("observer.gate_sigma"), 1.0..=1e3, o.gate_sigma)?,
            reset_after_rejects: f
                .f64_or(
                    &k("observer.reset_after_rejects"),
                    1.0..=1e6,
                    f64::from(o.reset_after_rejects),
                )?
                .round() as u32,
            manoeuvre_threshold: f.f64_or(
                &k("observer.manoeuvre_threshold"),
                0.0..=100.0,
                o.manoeuvre_threshold,
            )?,
            manoeuvre_noise_factor: f.f64_or(
                &k("observer.manoeuvre_noise_factor"),
                1.0..=1e4,
                o.manoeuvre_noise_factor,
            )?,
            init_vel_std: f.f64_or(&k("observer.init_vel_std_m_s"), 0.0..=1e3, o.init_vel_std)?,
            init_bias_std: f.f64_or(&k("observer.init_bias_std_n"), 0.0..=1e4, o.init_bias_std)?,
        }
    };
    Ok(AxisConfig {
        pid,
        reference,
        observer,
        stick_deadband: f.f64_or(&k("stick_deadband"), 0.0..=0.9, d.stick_deadband)?,
        manual_max_pct: f.f64_or(&k("manual_max_pct"), 0.0..=100.0, d.manual_max_pct)?,
        sensor_timeout_s: f.f64_or(&k("sensor_timeout_s"), 0.01..=60.0, d.sensor_timeout_s)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid() {
        ControlConfig::default().validate().unwrap();
    }

    #[test]
    fn empty_section_gives_defaults() {
        let c = ControlConfig::from_toml_str("[control]\n", "station.toml").unwrap();
        let d = ControlConfig::default();
        assert_eq!(c.depth.pid, d.depth.pid);
        assert_eq!(c.feedforward_model, d.feedforward_model);
        assert!((c.heading.reference.vel_max - d.heading.reference.vel_max).abs() < 1e-12);
        assert!((c.heading.observer.meas_std - d.heading.observer.meas_std).abs() < 1e-15);
    }

    #[test]
    fn errors_name_file_key_value_and_range() {
        let e =
            ControlConfig::from_toml_str("[control.depth]\nkp_n_per_m = -3.0\n", "station.toml")
                .unwrap_err();
        assert_eq!(
            e.to_string(),
            "station.toml: key control.depth.kp_n_per_m = -3 is out of range (allowed 0..=1000000)"
        );
        let e =
            ControlConfig::from_toml_str("[control]\nfeedforward_model = \"model9\"\n", "s.toml")
                .unwrap_err();
        assert!(e.to_string().contains("control.feedforward_model"), "{e}");
        let e =
            ControlConfig::from_toml_str("[control.heading]\nkp = 1.0\n", "s.toml").unwrap_err();
        assert!(
            e.to_string()
                .contains("control.heading.kp is not a known setting"),
            "{e}"
        );
        let e =
            ControlConfig::from_toml_str("[control]\nrate_hz = 50.0\nmax_dt_s = 0.001\n", "s.toml")
                .unwrap_err();
        assert!(e.to_string().contains("max_dt_s"), "{e}");
    }
}
