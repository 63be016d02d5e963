//! The one model engine: how every tool loads a model and compares it with data.
//!
//! * Loading: [`load_model`] turns a model identity ([`rov_types::model_id::ModelId`]:
//!   `model1`, `model2`, `model3` or `FILE.toml`) into a [`LabModel`] — a shipped base, a
//!   base-model or vehicle-definition file, or an extended model the lab saved (effects
//!   and discovered terms, [`crate::persist`]). The caller reads the file (this crate
//!   does no I/O) and passes its text.
//! * Simulating against data: [`crate::sim::simulate_run`] (the measurement-CSV timing
//!   rule, RK4 sub-steps of at most [`crate::sim::DT_MAX_S`], re-initialisation from the
//!   measurements at the view's resets). [`predict`] is that for a [`View`].
//! * Fit per channel: [`fit_runs`], the free-run view pooled over runs with
//!   [`crate::metrics::pooled_metrics`] (fit % and RMSE from [`rov_types::fit`], the
//!   lab's noise-floor gate on fit %). `lab compare`'s `pooled.free_run`, `replay --model`'s
//!   `fit` and the station's replay overlay therefore give the same numbers for the same
//!   model and data.

use rov_dynamics::models::Channel;
use rov_types::angle::wrap_deg_360;
use rov_types::measurement::MeasurementSeries;
use rov_types::model_id::ModelId;

use crate::LabError;
use crate::calibrate::View;
use crate::data::Run;
use crate::metrics::pooled_metrics;
use crate::model::LabModel;
use crate::sim::{Prediction, simulate_run};

/// Loads a model: a shipped base by name, or a model file's `text` (base-model file,
/// vehicle definition or saved extended model; named by the id's path in errors). The
/// lab's one model loader: the CLI, the station, the GUI and the autopilot's model all
/// load through it (a [`LabModel`] is a [`rov_dynamics::models::VehicleModel`]; box it
/// where a `Box<dyn VehicleModel>` is needed).
///
/// A file id without its text is refused ([`LabError::SavedModel`]): the caller reads
/// the file.
pub fn load_model(id: &ModelId, text: Option<&str>) -> Result<LabModel, LabError> {
    match id {
        ModelId::Base(b) => LabModel::default_base((*b).into()),
        ModelId::File(path) => {
            let label = path.display().to_string();
            let text = text.ok_or_else(|| LabError::SavedModel {
                file: label.clone(),
                detail: "the model file's text was not read".into(),
            })?;
            crate::persist::parse_model_file(text, &label)
        }
    }
}

/// A model's prediction of a run in one error view.
pub fn predict(model: &LabModel, run: &Run, view: View) -> Result<Prediction, LabError> {
    simulate_run(model, run, &view.resets(run))
}

/// The fit of one measured channel.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ChannelFit {
    /// The channel.
    #[serde(skip)]
    pub channel: Channel,
    /// Whether the model predicts it (if not, the numbers are empty).
    pub predicted: bool,
    /// Samples compared (both finite), over all runs.
    pub samples: usize,
    /// Fit %, pooled over the runs (`None` when the measurement barely moves: the
    /// noise-floor gate of [`crate::metrics`]).
    pub fit_pct: Option<f64>,
    /// RMSE in the channel's unit (m, degrees, m/s, deg/s).
    pub rmse: Option<f64>,
}

/// Free-run fit of a model on runs, per channel that any run measures (in
/// [`Channel::ALL`] order); channels the model does not predict are listed with
/// `predicted: false`.
pub fn fit_runs(model: &LabModel, runs: &[Run]) -> Result<Vec<ChannelFit>, LabError> {
    let preds = runs
        .iter()
        .map(|r| predict(model, r, View::FreeRun))
        .collect::<Result<Vec<_>, _>>()?;
    let items: Vec<(&Run, &Prediction)> = runs.iter().zip(&preds).collect();
    Ok(Channel::ALL
        .iter()
        .copied()
        .filter(|c| runs.iter().any(|r| r.has(*c)))
        .map(|channel| {
            let predicted = model.predicts_channel(channel);
            let m = predicted.then(|| pooled_metrics(&items, channel)).flatten();
            ChannelFit {
                channel,
                predicted,
                samples: m.map_or(0, |m| m.n),
                fit_pct: m.and_then(|m| m.fit_pct),
                rmse: m.map(|m| m.rmse),
            }
        })
        .collect())
}

/// A model's depth and heading along a measured series (see [`predict_series`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SeriesPrediction {
    /// The series' times of the predicted samples, s (rows the lab keeps: a gap splits
    /// the series into runs, pieces too short for the lab are left out).
    pub time_s: Vec<f64>,
    /// Predicted depth, m (NaN where the run has no depth).
    pub depth_m: Vec<f64>,
    /// Predicted heading, degrees [0, 360) (NaN where the run has no heading).
    pub heading_deg: Vec<f64>,
}

/// A model's prediction along a measured series: the series read into runs like the lab
/// reads a session ([`crate::ingest::series_runs`]), each simulated by
/// [`crate::sim::simulate_run`] re-anchored to the measurement every `horizon_s` (the
/// k-step view, k = horizon / the run's median sample period).
pub fn predict_series(
    model: &LabModel,
    series: &MeasurementSeries,
    label: &str,
    horizon_s: f64,
) -> Result<SeriesPrediction, LabError> {
    let runs = crate::ingest::series_runs(series, label, None)?;
    let mut out = SeriesPrediction::default();
    for run in &runs {
        let dt = run.median_dt().max(1e-3);
        let k = if horizon_s.is_finite() && horizon_s > 0.0 {
            ((horizon_s / dt).round() as usize).max(1)
        } else {
            usize::MAX
        };
        let p = predict(model, run, View::KStep(k))?;
        let n = run.len();
        let chan = |ch: Channel| p.channel(ch).filter(|v| v.len() == n);
        let (depth, heading) = (chan(Channel::Depth), chan(Channel::Heading));
        for i in 0..n {
            out.time_s.push(run.t[i]);
            out.depth_m
                .push(depth.and_then(|v| v.get(i)).copied().unwrap_or(f64::NAN));
            out.heading_deg.push(
                heading
                    .and_then(|v| v.get(i))
                    .map_or(f64::NAN, |h| wrap_deg_360(*h)),
            );
        }
    }
    Ok(out)
}

impl SeriesPrediction {
    /// The prediction at the sample at or before `t_s` (not more than `max_age_s` before).
    pub fn at(&self, t_s: f64, max_age_s: f64) -> Option<(f64, f64)> {
        let i = self
            .time_s
            .partition_point(|t| *t <= t_s + 1e-9)
            .checked_sub(1)?;
        let t = *self.time_s.get(i)?;
        if t_s - t > max_age_s {
            return None;
        }
        let (d, h) = (*self.depth_m.get(i)?, *self.heading_deg.get(i)?);
        (d.is_finite() && h.is_finite()).then_some((d, h))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::BaseKind;
    use rov_types::model_id::BaseModel;

    #[test]
    fn loads_bases_and_files_through_the_model_identity() {
        for b in BaseModel::ALL {
            let m = load_model(&ModelId::Base(b), None).unwrap();
            assert_eq!(m.kind(), BaseKind::from(b));
        }
        let id: ModelId = "learned.toml".parse().unwrap();
        let e = load_model(&id, None).unwrap_err();
        assert!(e.to_string().contains("learned.toml"), "{e}");
        let text = rov_dynamics::models::default_model_text("model2").unwrap();
        let m = load_model(&id, Some(text)).unwrap();
        assert_eq!(m.kind(), BaseKind::Model2);
        let e = load_model(&id, Some("model = \"model9\"")).unwrap_err();
        assert!(e.to_string().contains("model9"), "{e}");
    }

    /// A run "measured" by model3 with a step on each thruster.
    fn run_of(m: &LabModel) -> Run {
        use rov_types::measurement::MeasurementRow;
        let rows: Vec<MeasurementRow> = (0..600)
            .map(|k| MeasurementRow {
                time_s: f64::from(k) * 0.05,
                port_pct: if k >= 100 { 50.0 } else { 0.0 },
                starboard_pct: if k >= 300 { 70.0 } else { 0.0 },
                vertical_pct: if k >= 200 { -40.0 } else { 0.0 },
                depth_m: 2.0,
                heading_deg: 350.0,
                ..Default::default()
            })
            .collect();
        let base = Run::from_series(
            &MeasurementSeries {
                rows: rows.clone(),
                ..Default::default()
            },
            "gen",
        )
        .unwrap();
        let p = simulate_run(m, &base, &[0]).unwrap();
        let rows: Vec<MeasurementRow> = rows
            .into_iter()
            .enumerate()
            .map(|(k, mut r)| {
                r.depth_m = p.channel(Channel::Depth).unwrap()[k] + 0.01 * (k as f64).sin();
                r.heading_deg = wrap_deg_360(p.channel(Channel::Heading).unwrap()[k]);
                r.pitch_deg = p.channel(Channel::Pitch).unwrap()[k];
                r.roll_deg = p.channel(Channel::Roll).unwrap()[k];
                r
            })
            .collect();
        Run::from_series(
            &MeasurementSeries {
                rows,
                ..Default::default()
            },
            "measured",
        )
        .unwrap()
    }

    #[test]
    fn the_fit_is_lab_compares_free_run_and_rov_types_fit() {
        let m3 = LabModel::default_base(BaseKind::Model3).unwrap();
        let m1 = LabModel::default_base(BaseKind::Model1).unwrap();
        let runs = vec![run_of(&m3)];
        for m in [&m3, &m1] {
            let fits = fit_runs(m, &runs).unwrap();
            let report = crate::lab::compare(m, "m", &runs, &[], 1).unwrap();
            let pooled = &report.pooled["free_run"].channels;
            for f in &fits {
                let name = crate::data::ch_name(f.channel);
                match pooled.get(name) {
                    Some(c) => {
                        assert!(f.predicted);
                        assert_eq!(
                            (f.fit_pct, f.rmse, f.samples),
                            (c.fit_pct, Some(c.rmse), c.n)
                        );
                    }
                    None => assert!(!f.predicted && f.rmse.is_none(), "{f:?}"),
                }
            }
            // The core numbers are rov_types::fit's on the (measured, predicted) pairs.
            let pred = predict(m, &runs[0], View::FreeRun).unwrap();
            let y = runs[0].channel(Channel::Depth).unwrap();
            let pairs: Vec<(f64, f64)> = y
                .iter()
                .copied()
                .zip(pred.channel(Channel::Depth).unwrap().iter().copied())
                .collect();
            let core = rov_types::fit::fit(&pairs, rov_types::fit::ErrorKind::Linear);
            let d = fits.iter().find(|f| f.channel == Channel::Depth).unwrap();
            assert_eq!((d.rmse, d.fit_pct), (core.rmse, core.fit_pct));
        }
        // model3 fits its own run (up to the added ripple); model1 has no pitch or roll.
        let f3 = fit_runs(&m3, &runs).unwrap();
        assert!(f3[0].fit_pct.unwrap() > 90.0, "{f3:?}");
        let f1 = fit_runs(&m1, &runs).unwrap();
        assert!(
            f1.iter()
                .any(|f| f.channel == Channel::Pitch && !f.predicted)
        );
    }

    #[test]
    fn predict_series_reanchors_every_horizon_and_wraps_heading() {
        let m3 = LabModel::default_base(BaseKind::Model3).unwrap();
        let m1 = LabModel::default_base(BaseKind::Model1).unwrap();
        let run = run_of(&m3);
        let series = MeasurementSeries {
            rows: (0..run.len())
                .map(|k| rov_types::measurement::MeasurementRow {
                    time_s: run.t[k],
                    port_pct: run.cmd[k].port,
                    starboard_pct: run.cmd[k].starboard,
                    vertical_pct: run.cmd[k].vertical,
                    depth_m: run.channel(Channel::Depth).unwrap()[k],
                    heading_deg: wrap_deg_360(run.channel(Channel::Heading).unwrap()[k]),
                    pitch_deg: run.channel(Channel::Pitch).unwrap()[k],
                    roll_deg: run.channel(Channel::Roll).unwrap()[k],
                    ..Default::default()
                })
                .collect(),
            ..Default::default()
        };
        let p = predict_series(&m1, &series, "s", 10.0).unwrap();
        assert_eq!(p.time_s.len(), series.rows.len());
        assert!(p.heading_deg.iter().all(|h| (0.0..360.0).contains(h)));
        // The same as the k-step view of the engine (k = 10 s / 0.05 s).
        let runs = crate::ingest::series_runs(&series, "s", None).unwrap();
        let k = predict(&m1, &runs[0], View::KStep(200)).unwrap();
        assert_eq!(p.depth_m, k.channel(Channel::Depth).unwrap());
        // Re-anchored at 10 s: the prediction there starts from the measurement again.
        let at10 = p.at(10.0, 0.5).unwrap();
        assert!((at10.0 - series.rows[200].depth_m).abs() < 0.02, "{at10:?}");
        assert_eq!(p.at(-1.0, 0.5), None);
    }
}
