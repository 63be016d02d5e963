//! Figures built from measurement series: measured traces against model predictions.

use rov_types::measurement::MeasurementSeries;

use crate::{Figure, Panel, Rgb, Series};

/// Colours used for predictions, in order (the paper's figures use purple, green and black
/// for models 1, 2 and 3).
pub const PREDICTION_COLORS: [Rgb; 6] = [
    Rgb::PURPLE,
    Rgb::GREEN,
    Rgb::BLACK,
    Rgb::ORANGE,
    Rgb::GREY,
    Rgb::LIGHT_BLUE,
];

/// Unwraps a heading trace (degrees) so that plots show no 360° jumps; NaN stays NaN.
pub fn unwrap_deg(values: impl IntoIterator<Item = f64>) -> Vec<f64> {
    let mut out = Vec::new();
    let mut offset = 0.0;
    let mut prev: Option<f64> = None;
    for v in values {
        if !v.is_finite() {
            out.push(f64::NAN);
            continue;
        }
        if let Some(p) = prev {
            let d = v - p;
            if d > 180.0 {
                offset -= 360.0;
            } else if d < -180.0 {
                offset += 360.0;
            }
        }
        prev = Some(v);
        out.push(v + offset);
    }
    out
}

fn channel(
    series: &MeasurementSeries,
    pick: fn(&rov_types::MeasurementRow) -> f64,
    unwrap: bool,
) -> Vec<(f64, f64)> {
    let t: Vec<f64> = series.rows.iter().map(|r| r.time_s).collect();
    let raw: Vec<f64> = series.rows.iter().map(pick).collect();
    let v = if unwrap { unwrap_deg(raw) } else { raw };
    t.into_iter().zip(v).collect()
}

/// A figure with the thrust inputs, then depth, heading, pitch and roll: the measured trace
/// in blue and each prediction in its colour. A prediction whose channel is all NaN (the
/// model does not predict it) is left out of that panel and named in the panel title.
pub fn comparison_figure(
    title: &str,
    measured: &MeasurementSeries,
    predictions: &[(&str, &MeasurementSeries)],
) -> Figure {
    let inputs = Panel::lines(
        "thruster commands",
        "time [s]",
        "thrust [%]",
        vec![
            Series::new("port", channel(measured, |r| r.port_pct, false), Rgb::RED),
            Series::new(
                "starboard",
                channel(measured, |r| r.starboard_pct, false),
                Rgb::ORANGE,
            )
            .dashed(),
            Series::new(
                "vertical",
                channel(measured, |r| r.vertical_pct, false),
                Rgb::BLUE,
            ),
        ],
    );
    type Pick = fn(&rov_types::MeasurementRow) -> f64;
    let chans: [(&str, &str, Pick, bool); 4] = [
        ("depth", "depth [m] (down)", |r| r.depth_m, false),
        ("heading", "heading [deg]", |r| r.heading_deg, true),
        ("pitch", "pitch [deg] (nose up)", |r| r.pitch_deg, false),
        ("roll", "roll [deg] (stbd down)", |r| r.roll_deg, false),
    ];
    let mut panels = vec![inputs];
    for (name, ylabel, pick, unwrap) in chans {
        let mut lines = vec![Series::new(
            "measured",
            channel(measured, pick, unwrap),
            Rgb::BLUE,
        )];
        let mut silent = Vec::new();
        for ((label, pred), color) in predictions.iter().zip(PREDICTION_COLORS.iter().cycle()) {
            let pts = channel(pred, pick, unwrap);
            if pts.iter().all(|(_, y)| !y.is_finite()) {
                silent.push(*label);
                continue;
            }
            // Predictions often coincide; draw the first one wide and later ones thinner
            // or dashed so that an overlap still shows both colours.
            let i = lines.len() - 1;
            let mut s = Series::new(*label, pts, *color);
            s.width_px = if i == 0 { 3.0 } else { 1.4 };
            if i >= 2 {
                s = s.dashed();
            }
            lines.push(s);
        }
        let panel_title = if silent.is_empty() {
            name.to_string()
        } else {
            format!("{name} (not predicted by {})", silent.join(", "))
        };
        panels.push(Panel::lines(panel_title, "time [s]", ylabel, lines));
    }
    let mut fig = Figure::new(title, panels);
    fig.panel_height_px = 210;
    fig
}

#[cfg(test)]
mod tests {
    use super::*;
    use rov_types::MeasurementRow;

    #[test]
    fn unwraps_heading() {
        let u = unwrap_deg([350.0, 355.0, 2.0, 8.0, f64::NAN, 10.0, 340.0]);
        assert_eq!(&u[..4], &[350.0, 355.0, 362.0, 368.0]);
        assert!(u[4].is_nan());
        assert_eq!(u[5], 370.0);
        assert_eq!(
            u[6], 340.0,
            "10 -> 340 is a 30 degree turn back across north"
        );
    }

    #[test]
    fn comparison_names_unpredicted_channels() {
        let rows: Vec<MeasurementRow> = (0..50)
            .map(|i| MeasurementRow {
                time_s: i as f64 * 0.1,
                depth_m: 1.0 + i as f64 * 0.01,
                ..Default::default()
            })
            .collect();
        let measured = MeasurementSeries {
            rows: rows.clone(),
            ..Default::default()
        };
        let pred_rows = rows
            .iter()
            .map(|r| MeasurementRow {
                pitch_deg: f64::NAN,
                roll_deg: f64::NAN,
                ..*r
            })
            .collect();
        let pred = MeasurementSeries {
            rows: pred_rows,
            ..Default::default()
        };
        let fig = comparison_figure("t", &measured, &[("model1", &pred)]);
        assert_eq!(fig.panels.len(), 5);
        assert_eq!(fig.panels[3].title, "pitch (not predicted by model1)");
        assert_eq!(fig.panels[1].title, "depth");
        assert!(fig.render_png().is_ok());
    }
}
