//! PNG figures of the lab (the CLI writes them; the GUI will show them): measured
//! against model, residuals over time, residuals binned by command, residual
//! autocorrelation and input cross-correlation with bounds, and the error-fall chart.

use rov_dynamics::models::Channel;
use rov_plot::measurement::comparison_figure;
use rov_plot::{Content, Figure, Panel, Rgb, Series};
use rov_types::measurement::{MeasurementRow, MeasurementSeries};

use crate::LabError;
use crate::analysis::ChannelFailure;
use crate::data::{Run, ch_name, ch_unit};
use crate::lab::ErrorFallStep;
use crate::metrics::residuals;
use crate::sim::Prediction;

/// A rendered plot: file name and PNG bytes.
pub type Png = (String, Vec<u8>);

fn render(name: &str, fig: &Figure) -> Result<Png, LabError> {
    let bytes = fig.render_png().map_err(|e| LabError::Plot {
        name: name.into(),
        detail: e.to_string(),
    })?;
    Ok((name.to_string(), bytes))
}

/// The measured run as a measurement series (heading unwrapped).
pub fn measured_series(run: &Run) -> MeasurementSeries {
    let get = |ch: Channel, k: usize| run.channel(ch).map_or(f64::NAN, |v| v[k]);
    MeasurementSeries {
        rows: (0..run.len())
            .map(|k| MeasurementRow {
                time_s: run.t[k],
                port_pct: run.cmd[k].port,
                starboard_pct: run.cmd[k].starboard,
                vertical_pct: run.cmd[k].vertical,
                depth_m: get(Channel::Depth, k),
                heading_deg: get(Channel::Heading, k),
                pitch_deg: get(Channel::Pitch, k),
                roll_deg: get(Channel::Roll, k),
                optional: [None; 8],
            })
            .collect(),
        ..Default::default()
    }
}

/// A prediction as a measurement series (NaN where not predicted).
pub fn prediction_series(run: &Run, pred: &Prediction) -> MeasurementSeries {
    let get = |ch: Channel, k: usize| pred.channel(ch).map_or(f64::NAN, |v| v[k]);
    MeasurementSeries {
        rows: (0..run.len())
            .map(|k| MeasurementRow {
                time_s: run.t[k],
                port_pct: run.cmd[k].port,
                starboard_pct: run.cmd[k].starboard,
                vertical_pct: run.cmd[k].vertical,
                depth_m: get(Channel::Depth, k),
                heading_deg: get(Channel::Heading, k),
                pitch_deg: get(Channel::Pitch, k),
                roll_deg: get(Channel::Roll, k),
                optional: [None; 8],
            })
            .collect(),
        ..Default::default()
    }
}

fn safe(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// Measured against one or more predictions of a run.
pub fn comparison_png(
    run: &Run,
    predictions: &[(&str, &Prediction)],
    tag: &str,
) -> Result<Png, LabError> {
    let measured = measured_series(run);
    let series: Vec<(String, MeasurementSeries)> = predictions
        .iter()
        .map(|(n, p)| (n.to_string(), prediction_series(run, p)))
        .collect();
    let refs: Vec<(&str, &MeasurementSeries)> =
        series.iter().map(|(n, s)| (n.as_str(), s)).collect();
    let fig = comparison_figure(&format!("{} — {tag}", run.name), &measured, &refs);
    render(
        &format!("{}_{}_compare.png", safe(&run.name), safe(tag)),
        &fig,
    )
}

/// Residuals over time per channel, one line per prediction.
pub fn residual_png(
    run: &Run,
    predictions: &[(&str, &Prediction)],
    tag: &str,
) -> Result<Png, LabError> {
    let colors = [Rgb::PURPLE, Rgb::GREEN, Rgb::BLACK, Rgb::ORANGE];
    let mut panels = Vec::new();
    for ch in Channel::ALL {
        let mut lines = Vec::new();
        for ((name, p), color) in predictions.iter().zip(colors.iter().cycle()) {
            if let Some(e) = residuals(run, p, ch) {
                let pts: Vec<(f64, f64)> = run.t.iter().copied().zip(e).collect();
                lines.push(Series::new(*name, pts, *color));
            }
        }
        if !lines.is_empty() {
            panels.push(Panel::lines(
                format!("{} residual (model − measured)", ch_name(ch)),
                "time [s]",
                format!("[{}]", ch_unit(ch)),
                lines,
            ));
        }
    }
    let fig = Figure::new(format!("{} — residuals, {tag}", run.name), panels);
    render(
        &format!("{}_{}_residuals.png", safe(&run.name), safe(tag)),
        &fig,
    )
}

/// Residual means binned by command (one bar panel per channel) and correlations.
pub fn failure_pngs(failures: &[ChannelFailure], tag: &str) -> Result<Vec<Png>, LabError> {
    let mut out = Vec::new();
    let mut bar_panels = Vec::new();
    let mut corr_panels = Vec::new();
    for f in failures {
        bar_panels.push(Panel {
            title: format!("{} residual mean by command (model − measured)", f.channel),
            x_label: "command bin".into(),
            y_label: "mean residual".into(),
            content: Content::Bars {
                labels: f.by_command.iter().map(|b| b.label.clone()).collect(),
                values: f.by_command.iter().map(|b| b.mean).collect(),
                color: Rgb::BLUE,
            },
        });
        bar_panels.push(Panel {
            title: format!("{} residual mean by segment type", f.channel),
            x_label: "segment".into(),
            y_label: "mean residual".into(),
            content: Content::Bars {
                labels: f.by_segment.iter().map(|b| b.label.clone()).collect(),
                values: f.by_segment.iter().map(|b| b.mean).collect(),
                color: Rgb::ORANGE,
            },
        });
        let lag_pts = |c: &crate::analysis::Correlation| -> Vec<(f64, f64)> {
            c.lags
                .iter()
                .zip(&c.values)
                .map(|(l, v)| (*l as f64, *v))
                .collect()
        };
        let mut lines = vec![Series::new(
            "autocorrelation",
            lag_pts(&f.autocorrelation),
            Rgb::BLACK,
        )];
        let colors = [Rgb::RED, Rgb::GREEN, Rgb::PURPLE];
        for (c, color) in f.cross_correlation.iter().zip(colors) {
            lines.push(Series::new(format!("× {}", c.with), lag_pts(c), color));
        }
        let l = f.cross_correlation.first().map_or(10, |c| c.lags.len() / 2) as f64;
        let b = f
            .cross_correlation
            .iter()
            .map(|c| c.bound)
            .fold(f.autocorrelation.bound, f64::max);
        lines.push(Series::new("99 % bound", vec![(-l, b), (l, b)], Rgb::GREY).dashed());
        lines.push(Series::new("", vec![(-l, -b), (l, -b)], Rgb::GREY).dashed());
        corr_panels.push(Panel::lines(
            format!("{} residual correlations (lag > 0: input leads)", f.channel),
            "lag [samples]",
            "correlation",
            lines,
        ));
    }
    if !bar_panels.is_empty() {
        out.push(render(
            &format!("{}_binned.png", safe(tag)),
            &Figure::new(format!("Residuals binned — {tag}"), bar_panels),
        )?);
        out.push(render(
            &format!("{}_correlation.png", safe(tag)),
            &Figure::new(
                format!("Residual whiteness and independence — {tag}"),
                corr_panels,
            ),
        )?);
    }
    Ok(out)
}

/// Error-fall chart: held-out RMSE per channel across successive additions, normalised by
/// the calibrated base's RMSE (1 = base).
pub fn error_fall_png(steps: &[ErrorFallStep], tag: &str) -> Result<Png, LabError> {
    let mut panels = Vec::new();
    let Some(first) = steps.first() else {
        return render(
            &format!("{}_error_fall.png", safe(tag)),
            &Figure::new("Error fall (no steps)", vec![]),
        );
    };
    for ch in first.rmse.keys() {
        let base = first.rmse.get(ch).copied().unwrap_or(1.0).max(1e-300);
        panels.push(Panel {
            title: format!("{ch}: held-out RMSE relative to the calibrated base"),
            x_label: "model".into(),
            y_label: "RMSE / base".into(),
            content: Content::Bars {
                labels: steps.iter().map(|s| s.label.clone()).collect(),
                values: steps
                    .iter()
                    .map(|s| s.rmse.get(ch).copied().unwrap_or(f64::NAN) / base)
                    .collect(),
                color: Rgb::GREEN,
            },
        });
    }
    render(
        &format!("{}_error_fall.png", safe(tag)),
        &Figure::new(format!("Error fall — {tag}"), panels),
    )
}
