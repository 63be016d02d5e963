//! Re-simulation: the recorded thrust commands drive a vehicle model, giving
//! model-versus-measured traces and a per-channel fit.
//!
//! The measured series is the session's measurement rows ([`crate::csv::measurements`],
//! same timing rule as the CSV export). The model starts from the first row whose depth,
//! heading, pitch and roll are all finite (earlier rows are dropped with a warning) and is
//! run with [`rov_dynamics::simulate`] (RK4 sub-steps of at most
//! [`ResimOptions::dt_max_s`]).
//!
//! Fit per channel, over the samples where both traces are finite:
//! fit % = 100 · (1 − ‖y − ŷ‖ / ‖y − ȳ‖) and RMSE = √(mean (y − ŷ)²) ([`rov_types::fit`]). For heading the
//! measured trace is unwrapped first (ȳ and ‖y − ȳ‖ use it) and the error y − ŷ is wrapped
//! to ±180°. A channel the model does not predict is reported with `predicted: false`.

use rov_dynamics::{Channel, InitialConditions, ModelOutput, ThrustPct, VehicleModel, simulate};
use rov_types::angle::wrap_deg_180;
use rov_types::fit::{ErrorKind, fit};
use rov_types::measurement::{MeasurementRow, MeasurementSeries};

use crate::error::{Result, SessionError};
use crate::session::Session;

/// Re-simulation settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResimOptions {
    /// Longest RK4 sub-step, s (default 0.02).
    pub dt_max_s: f64,
}

impl Default for ResimOptions {
    fn default() -> Self {
        Self { dt_max_s: 0.02 }
    }
}

/// Fit of one channel.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelFit {
    /// The channel.
    pub channel: Channel,
    /// Its measurement-CSV column name (e.g. `depth_m`).
    pub name: &'static str,
    /// Whether the model predicts it (if not, the other fields are empty).
    pub predicted: bool,
    /// Samples compared (both finite).
    pub samples: usize,
    /// Fit, % (100 is perfect; `None` when the measured trace is constant or empty).
    pub fit_pct: Option<f64>,
    /// RMSE in the channel's unit (m, degrees, …).
    pub rmse: Option<f64>,
}

/// Model-versus-measured traces and fits.
#[derive(Debug, Clone, PartialEq)]
pub struct Resimulation {
    /// Model name.
    pub model: String,
    /// The measured series.
    pub measured: MeasurementSeries,
    /// The model's series: same times and commands; NaN in channels it does not predict.
    pub predicted: MeasurementSeries,
    /// Fits: depth, heading, pitch, roll, then every optional channel the session measured.
    pub fits: Vec<ChannelFit>,
    /// Warnings (from building the measured series and from the run).
    pub warnings: Vec<String>,
}

/// Re-simulates a session through `model`.
pub fn resimulate(
    session: &Session,
    model: &dyn VehicleModel,
    opts: &ResimOptions,
) -> Result<Resimulation> {
    let (series, _, warnings) = crate::csv::measurements(session)?;
    let mut r = resimulate_series(series, model, opts)?;
    let mut all = warnings;
    all.append(&mut r.warnings);
    r.warnings = all;
    Ok(r)
}

fn row_value(row: &MeasurementRow, ch: Channel) -> Option<f64> {
    match ch {
        Channel::Depth => Some(row.depth_m),
        Channel::Heading => Some(row.heading_deg),
        Channel::Pitch => Some(row.pitch_deg),
        Channel::Roll => Some(row.roll_deg),
        other => other.optional_column().and_then(|c| row.get(c)),
    }
}

fn channel_name(ch: Channel) -> &'static str {
    match ch {
        Channel::Depth => "depth_m",
        Channel::Heading => "heading_deg",
        Channel::Pitch => "pitch_deg",
        Channel::Roll => "roll_deg",
        Channel::Surge => "surge_mps",
        Channel::Sway => "sway_mps",
        Channel::Heave => "heave_mps",
        Channel::RollRate => "roll_rate_dps",
        Channel::PitchRate => "pitch_rate_dps",
        Channel::YawRate => "yaw_rate_dps",
        Channel::North => "north_m",
        Channel::East => "east_m",
    }
}

/// Re-simulates a measured series through `model`.
pub fn resimulate_series(
    mut measured: MeasurementSeries,
    model: &dyn VehicleModel,
    opts: &ResimOptions,
) -> Result<Resimulation> {
    let mut warnings = Vec::new();
    let start = measured
        .rows
        .iter()
        .position(|r| [r.depth_m, r.heading_deg, r.pitch_deg, r.roll_deg].iter().all(|x| x.is_finite()))
        .ok_or_else(|| {
            SessionError::Unusable(
                "no measurement row has finite depth, heading, pitch and roll to start the model from".into(),
            )
        })?;
    if start > 0 {
        warnings.push(format!(
            "the first {start} rows lack depth, heading, pitch or roll; the model starts at row {start}"
        ));
        measured.rows.drain(..start);
    }
    let first = measured
        .rows
        .first()
        .ok_or_else(|| SessionError::Unusable("no measurement rows".into()))?;
    let ic = InitialConditions::from_row(first)?;
    let x0 = model.initial_state(&ic);
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
    let outputs = simulate(model, &x0, &inputs, opts.dt_max_s)?;
    let predicted = predicted_series(&measured, &outputs, model);
    let mut channels = vec![
        Channel::Depth,
        Channel::Heading,
        Channel::Pitch,
        Channel::Roll,
    ];
    for ch in Channel::ALL {
        if let Some(col) = ch.optional_column()
            && measured.present.get(col as usize).copied().unwrap_or(false)
        {
            channels.push(ch);
        }
    }
    let fits = channels
        .into_iter()
        .map(|ch| fit_channel(ch, &measured, &outputs, model.predicts(ch)))
        .collect();
    Ok(Resimulation {
        model: model.name().to_string(),
        measured,
        predicted,
        fits,
        warnings,
    })
}

fn predicted_series(
    measured: &MeasurementSeries,
    outputs: &[ModelOutput],
    model: &dyn VehicleModel,
) -> MeasurementSeries {
    let mut present = [false; 8];
    for ch in Channel::ALL {
        if let Some(col) = ch.optional_column()
            && let Some(p) = present.get_mut(col as usize)
        {
            *p = model.predicts(ch);
        }
    }
    let rows = measured
        .rows
        .iter()
        .zip(outputs)
        .map(|(m, o)| {
            let mut row = MeasurementRow {
                time_s: m.time_s,
                port_pct: m.port_pct,
                starboard_pct: m.starboard_pct,
                vertical_pct: m.vertical_pct,
                depth_m: o.depth_m.unwrap_or(f64::NAN),
                heading_deg: o.heading_deg.unwrap_or(f64::NAN),
                pitch_deg: o.pitch_deg.unwrap_or(f64::NAN),
                roll_deg: o.roll_deg.unwrap_or(f64::NAN),
                optional: [None; 8],
            };
            for ch in Channel::ALL {
                if let Some(col) = ch.optional_column()
                    && model.predicts(ch)
                {
                    row.set(col, o.get(ch));
                }
            }
            row
        })
        .collect();
    MeasurementSeries {
        rows,
        present,
        warnings: Vec::new(),
    }
}

fn fit_channel(
    ch: Channel,
    measured: &MeasurementSeries,
    outputs: &[ModelOutput],
    predicted: bool,
) -> ChannelFit {
    let empty = ChannelFit {
        channel: ch,
        name: channel_name(ch),
        predicted,
        samples: 0,
        fit_pct: None,
        rmse: None,
    };
    if !predicted {
        return empty;
    }
    let heading = ch == Channel::Heading;
    // Measured trace (heading unwrapped) paired with the prediction.
    let mut pairs: Vec<(f64, f64)> = Vec::with_capacity(measured.rows.len());
    let mut unwrap_prev: Option<(f64, f64)> = None; // (raw, unwrapped)
    for (row, out) in measured.rows.iter().zip(outputs) {
        let (Some(y), Some(yh)) = (row_value(row, ch), out.get(ch)) else {
            continue;
        };
        if !(y.is_finite() && yh.is_finite()) {
            continue;
        }
        let y = if heading {
            let u = match unwrap_prev {
                Some((raw, un)) => un + wrap_deg_180(y - raw),
                None => y,
            };
            unwrap_prev = Some((y, u));
            u
        } else {
            y
        };
        pairs.push((y, yh));
    }
    let f = fit(&pairs, ErrorKind::angular_if(heading));
    ChannelFit {
        samples: f.samples,
        fit_pct: f.fit_pct,
        rmse: f.rmse,
        ..empty
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wraps_with_the_signed_convention() {
        // The unwrapping and the heading error use [−180, 180).
        assert_eq!(wrap_deg_180(190.0), -170.0);
        assert_eq!(wrap_deg_180(180.0), -180.0);
    }

    #[test]
    fn perfect_prediction_fits_100() {
        let rows: Vec<MeasurementRow> = (0..10)
            .map(|k| MeasurementRow {
                time_s: k as f64,
                depth_m: k as f64,
                heading_deg: 350.0 + 5.0 * k as f64,
                ..MeasurementRow::default()
            })
            .map(|mut r| {
                r.heading_deg = r.heading_deg.rem_euclid(360.0);
                r
            })
            .collect();
        let outs: Vec<ModelOutput> = (0..10)
            .map(|k| ModelOutput {
                time_s: k as f64,
                depth_m: Some(k as f64),
                heading_deg: Some(350.0 + 5.0 * k as f64),
                ..ModelOutput::default()
            })
            .collect();
        let m = MeasurementSeries {
            rows,
            ..MeasurementSeries::default()
        };
        let d = fit_channel(Channel::Depth, &m, &outs, true);
        assert_eq!(d.fit_pct, Some(100.0));
        assert_eq!(d.rmse, Some(0.0));
        let h = fit_channel(Channel::Heading, &m, &outs, true);
        assert!((h.fit_pct.unwrap() - 100.0).abs() < 1e-9, "{h:?}");
        assert!(h.rmse.unwrap() < 1e-9);
        let p = fit_channel(Channel::Pitch, &m, &outs, false);
        assert!(!p.predicted && p.fit_pct.is_none());
    }
}
