//! Shared parameter-file readers for the model loaders.

use nalgebra::Vector3;
use rov_types::{ConfigError, ParamFile};

use crate::math::Vector6;
use crate::thrusters::{QuadraticThrustMap, ThrustPair, ThrusterGeometry};

/// Allowed range of a thrust coefficient, N.
pub(crate) const THRUST_COEFF_N: std::ops::RangeInclusive<f64> = 0.0..=200.0;

pub(crate) fn vec3(
    pf: &ParamFile,
    key: &str,
    range: std::ops::RangeInclusive<f64>,
) -> Result<Vector3<f64>, ConfigError> {
    let [x, y, z] = pf.array::<3>(key, range)?;
    Ok(Vector3::new(x, y, z))
}

pub(crate) fn vec6(
    pf: &ParamFile,
    key: &str,
    range: std::ops::RangeInclusive<f64>,
) -> Result<Vector6, ConfigError> {
    let a = pf.array::<6>(key, range)?;
    Ok(Vector6::from_column_slice(&a))
}

/// `{prefix}.forward_linear_n`, `forward_quadratic_n`, `reverse_linear_n`,
/// `reverse_quadratic_n`: F = T_l u + T_q u|u|.
pub(crate) fn quadratic_map(
    pf: &ParamFile,
    prefix: &str,
) -> Result<QuadraticThrustMap, ConfigError> {
    let pair = |dir: &str| -> Result<ThrustPair, ConfigError> {
        Ok(ThrustPair {
            linear_n: pf.f64(&format!("{prefix}.{dir}_linear_n"), THRUST_COEFF_N)?,
            quadratic_n: pf.f64(&format!("{prefix}.{dir}_quadratic_n"), THRUST_COEFF_N)?,
        })
    };
    Ok(QuadraticThrustMap {
        forward: pair("forward")?,
        reverse: pair("reverse")?,
    })
}

/// `{prefix}.position_m` (from CO, m) and `{prefix}.direction` (unit vector).
pub(crate) fn geometry(pf: &ParamFile, prefix: &str) -> Result<ThrusterGeometry, ConfigError> {
    let pos = vec3(pf, &format!("{prefix}.position_m"), -1.0..=1.0)?;
    let key = format!("{prefix}.direction");
    let dir = vec3(pf, &key, -1.0..=1.0)?;
    ThrusterGeometry::new(pos, dir).map_err(|_| ConfigError::OutOfRange {
        file: pf.file().to_string(),
        key,
        value: format!("[{}, {}, {}] (norm {})", dir.x, dir.y, dir.z, dir.norm()),
        allowed: "a unit vector (norm 1 ± 0.001)".into(),
    })
}
