//! Unit tests of the diagnosis's helpers (kinematic check, bounded least squares,
//! structural weights, plausibility bounds).

use super::*;
use crate::calibrate::structural_scales;
use nalgebra::{DMatrix, DVector};
use rov_types::measurement::{MeasurementRow, MeasurementSeries, OptionalChannel};

/// A 60 s run whose vehicle heaves sinusoidally; the depth reading optionally drifts.
fn heaving_run(drift_mps: f64) -> Run {
    let mut x = 987654321u64;
    let mut noise = || {
        x = x
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let rows: Vec<MeasurementRow> = (0..1200)
        .map(|k| {
            let t = k as f64 * 0.05;
            let w = 0.2 * (0.3 * t).sin();
            let z = 2.0 + 0.2 / 0.3 * (1.0 - (0.3 * t).cos());
            let mut row = MeasurementRow {
                time_s: t,
                vertical_pct: if (0.3 * t).sin() > 0.0 { 50.0 } else { -50.0 },
                depth_m: z + drift_mps * t + 0.005 * noise(),
                heading_deg: 10.0,
                ..Default::default()
            };
            row.set(OptionalChannel::HeaveMps, Some(w + 0.01 * noise()));
            row
        })
        .collect();
    let mut present = [false; 8];
    present[OptionalChannel::HeaveMps as usize] = true;
    Run::from_series(
        &MeasurementSeries {
            rows,
            present,
            ..Default::default()
        },
        "heave",
    )
    .unwrap()
}

#[test]
fn kinematic_check_tells_a_drifting_reading_from_real_motion() {
    let rate = 0.002;
    let offset = |run: &Run, k: usize| rate * (run.t[k] - run.t[0]);
    // The measured heave integrates to the depth change: no sensor drift.
    let (b0, se0) = kinematic_ratio(&[heaving_run(0.0)], Channel::Depth, offset).unwrap();
    assert!(
        b0.abs() < 0.1 && !kinematic_consistent(b0, se0),
        "{b0} ± {se0}"
    );
    // The reading drifts away from the integrated heave at the fitted rate.
    let (b1, se1) = kinematic_ratio(&[heaving_run(rate)], Channel::Depth, offset).unwrap();
    assert!(
        (b1 - 1.0).abs() < 0.1 && kinematic_consistent(b1, se1),
        "{b1} ± {se1}"
    );
    // Without a rate channel there is nothing to check.
    assert!(kinematic_ratio(&[heaving_run(0.0)], Channel::Heading, offset).is_none());
}

#[test]
fn bounded_least_squares_holds_a_pinned_column_at_zero() {
    // r0 + a·c1 + b·c2: the unconstrained fit wants a = −1, b = 2.
    let c1 = DVector::from_vec(vec![1.0, 0.0, 1.0, 0.0]);
    let c2 = DVector::from_vec(vec![0.0, 1.0, 0.0, 1.0]);
    let r0 = -(c1.scale(-1.0) + c2.scale(2.0));
    let m = DMatrix::from_columns(&[c1, c2]);
    let (_, x) = bounded_ls(&r0, &m, &[0, 0]).unwrap();
    assert!(
        (x[0] + 1.0).abs() < 1e-6 && (x[1] - 2.0).abs() < 1e-6,
        "{x:?}"
    );
    // Column 1 at its lower bound may only grow: held at zero, column 2 unchanged.
    let (res, x) = bounded_ls(&r0, &m, &[1, 0]).unwrap();
    assert!(x[0] == 0.0 && (x[1] - 2.0).abs() < 1e-6, "{x:?}");
    assert!((res.norm_squared() - 2.0).abs() < 1e-6);
}

#[test]
fn structural_scales_keep_noise_weights_near_the_floor() {
    let run = heaving_run(0.0);
    let i = crate::data::ch_index(Channel::Depth);
    let sigma = run.noise[i];
    let mut misfit = crate::calibrate::NOISE_ONLY;
    misfit[i] = 1.5 * sigma;
    assert_eq!(
        structural_scales(std::slice::from_ref(&run), &misfit)[i],
        0.0
    );
    misfit[i] = 10.0 * sigma;
    let s = structural_scales(std::slice::from_ref(&run), &misfit)[i];
    assert!((s - 9.0 * sigma).abs() < 1e-12, "{s} vs {sigma}");
}

#[test]
fn only_plausibility_bounds_pin_an_effect() {
    assert!(Param::LagTau.bound_is_physical(false));
    assert!(!Param::LagTau.bound_is_physical(true));
    assert!(!Param::DepthDrift.bound_is_physical(true));
    assert!(!Param::ReverseRatio(crate::params::Thr::Vertical).bound_is_physical(false));
    assert!(Param::PowerMax.bound_is_physical(true));
}
