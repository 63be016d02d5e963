//! The shipped `config/station.toml` loads and matches the built-in defaults.

use rov_control::ControlConfig;

const STATION: &str = include_str!("../../../../config/station.toml");

#[test]
fn shipped_station_file_equals_defaults() {
    let c = ControlConfig::from_toml_str(STATION, "config/station.toml").unwrap();
    let d = ControlConfig::default();
    // Degree keys round-trip through to_radians, so compare with a tolerance.
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * a.abs().max(1.0);
    assert_eq!(c.depth, d.depth);
    assert_eq!(c.heading.pid, d.heading.pid);
    assert!(close(
        c.heading.reference.vel_max,
        d.heading.reference.vel_max
    ));
    assert!(close(
        c.heading.reference.acc_max,
        d.heading.reference.acc_max
    ));
    assert!(close(
        c.heading.observer.meas_std,
        d.heading.observer.meas_std
    ));
    assert!(close(
        c.heading.observer.rate_meas_std,
        d.heading.observer.rate_meas_std
    ));
    assert!(close(
        c.heading.observer.init_vel_std,
        d.heading.observer.init_vel_std
    ));
    assert_eq!(
        c.heading.observer.force_noise,
        d.heading.observer.force_noise
    );
    assert_eq!(
        (
            c.rate_hz,
            c.feedforward_model,
            c.plant_model,
            c.guard,
            c.water_density_kg_m3,
            c.surface_tare
        ),
        (
            d.rate_hz,
            d.feedforward_model,
            d.plant_model,
            d.guard,
            d.water_density_kg_m3,
            d.surface_tare
        )
    );
    assert_eq!(
        (
            c.feedforward_enabled,
            c.observer_enabled,
            c.bias_compensation,
            c.feedforward_force
        ),
        (
            d.feedforward_enabled,
            d.observer_enabled,
            d.bias_compensation,
            d.feedforward_force
        )
    );
}

#[test]
fn configured_tare_and_sea_water() {
    let text = "[control]\nsurface_tare = \"configured\"\nsurface_pressure_mbar = 1009.0\nwater_density_kg_m3 = 1025.0\nfeedforward_model = \"model2\"\n";
    let c = ControlConfig::from_toml_str(text, "s.toml").unwrap();
    assert_eq!(c.surface_tare, rov_control::SurfaceTare::Configured(1009.0));
    assert_eq!(c.water_density_kg_m3, 1025.0);
    assert_eq!(c.feedforward_model, rov_control::ModelChoice::Model2);
    let e = ControlConfig::from_toml_str("[control]\nwater_density_kg_m3 = 1500\n", "s.toml")
        .unwrap_err();
    assert_eq!(
        e.to_string(),
        "s.toml: key control.water_density_kg_m3 = 1500 is out of range (allowed 900..=1100)"
    );
}
