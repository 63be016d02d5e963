//! The Plots tab: depth, heading, pitch and roll against time, with the setpoints, the
//! observer estimate and the chosen model's prediction overlaid. Each series is decimated
//! to a min/max pair per pixel column over the visible window, so one hour of data costs
//! a linear scan of the window per frame and a few thousand vertices.

use egui::{Color32, Ui};
use egui_plot::{Corner, Legend, Line, Plot, PlotPoints};
use rov_station::runtime::{Channel, History, decimate_min_max};

use crate::app::StationApp;
use crate::theme;

/// Plot windows offered, s (`f64::INFINITY`: everything).
pub const WINDOWS: [(f64, &str); 6] = [
    (30.0, "30 s"),
    (120.0, "2 min"),
    (600.0, "10 min"),
    (1800.0, "30 min"),
    (3600.0, "1 h"),
    (f64::INFINITY, "all"),
];

/// A series of a plot.
#[derive(Debug, Clone, Copy)]
pub struct Series {
    /// Legend name.
    pub name: &'static str,
    /// Channel.
    pub channel: Channel,
    /// Colour.
    pub color: Color32,
    /// Line width.
    pub width: f32,
}

/// The four plots: (title, series drawn in order, measured last so it is on top).
pub const PLOTS: [(&str, &[Series]); 4] = [
    (
        "depth m",
        &[
            Series {
                name: "setpoint",
                channel: Channel::DepthSetpoint,
                color: theme::SETPOINT,
                width: 1.5,
            },
            Series {
                name: "model",
                channel: Channel::DepthPrediction,
                color: theme::PREDICTION,
                width: 1.0,
            },
            Series {
                name: "estimate",
                channel: Channel::DepthEstimate,
                color: theme::ESTIMATE,
                width: 1.0,
            },
            Series {
                name: "depth",
                channel: Channel::Depth,
                color: theme::VALUE,
                width: 1.5,
            },
        ],
    ),
    (
        "heading °",
        &[
            Series {
                name: "setpoint",
                channel: Channel::HeadingSetpoint,
                color: theme::SETPOINT,
                width: 1.5,
            },
            Series {
                name: "model",
                channel: Channel::HeadingPrediction,
                color: theme::PREDICTION,
                width: 1.0,
            },
            Series {
                name: "estimate",
                channel: Channel::HeadingEstimate,
                color: theme::ESTIMATE,
                width: 1.0,
            },
            Series {
                name: "heading",
                channel: Channel::Heading,
                color: theme::VALUE,
                width: 1.5,
            },
        ],
    ),
    (
        "pitch °",
        &[Series {
            name: "pitch",
            channel: Channel::Pitch,
            color: theme::VALUE,
            width: 1.5,
        }],
    ),
    (
        "roll °",
        &[Series {
            name: "roll",
            channel: Channel::Roll,
            color: theme::VALUE,
            width: 1.5,
        }],
    ),
];

/// The visible window of a history ending at its last sample.
#[must_use]
pub fn window(h: &History, window_s: f64) -> Option<(f64, f64)> {
    let (t0, t1) = h.time_span()?;
    let start = if window_s.is_finite() {
        (t1 - window_s).max(t0)
    } else {
        t0
    };
    Some((start, t1))
}

/// Decimated line segments of one series: split where an angle wraps (a jump over
/// 180°), so heading lines do not cross the plot at north.
#[must_use]
pub fn series_points(
    h: &History,
    ch: Channel,
    t0: f64,
    t1: f64,
    buckets: usize,
    wrap_ref: Option<f64>,
) -> Vec<Vec<[f64; 2]>> {
    let range = h.range(t0, t1);
    let mut pts = decimate_min_max(h.times(), h.column(ch), range, buckets);
    // Angles are drawn within ±180° of the reference (the latest heading), so a vehicle
    // pointing north does not draw lines across the whole plot.
    if let (true, Some(r)) = (ch.wraps(), wrap_ref) {
        for p in &mut pts {
            p[1] = rov_types::angle::nearest_deg(p[1], r);
        }
    }
    if pts.is_empty() {
        return Vec::new();
    }
    let mut out = vec![Vec::with_capacity(pts.len())];
    let mut prev: Option<[f64; 2]> = None;
    // Break at NaN markers (no data, hold off) and where an angle wraps.
    for p in pts {
        if p[1].is_nan() {
            out.push(Vec::new());
            prev = None;
            continue;
        }
        if let Some(q) = prev
            && ch.wraps()
            && (p[1] - q[1]).abs() > 180.0
        {
            out.push(Vec::new());
        }
        if let Some(last) = out.last_mut() {
            last.push(p);
        }
        prev = Some(p);
    }
    out.retain(|s| !s.is_empty());
    out
}

/// Draws one plot of `height`, over `[t0, t1]`.
pub fn plot(ui: &mut Ui, id: &str, h: &History, series: &[Series], t0: f64, t1: f64, height: f32) {
    let width_px = ui.available_width().max(100.0);
    // A min/max pair per two pixel columns: the envelope stays exact at screen
    // resolution and the vertex count stays bounded whatever the window holds.
    let buckets = ((width_px / 2.0) as usize).max(50);
    let link = egui::Id::unique("plots_x");
    let last = |ch: Channel| {
        let r = h.range(t0, t1);
        h.column(ch)
            .get(r)
            .and_then(|v| v.iter().rev().find(|x| x.is_finite()))
            .map(|x| f64::from(*x))
    };
    let first = series.first().map(|s| s.channel);
    let is_depth = first == Some(Channel::DepthSetpoint);
    let is_heading = first == Some(Channel::HeadingSetpoint);
    let wrap_ref = if is_heading {
        last(Channel::Heading)
    } else {
        None
    };
    let mut plot = Plot::new(id)
        .height(height)
        .legend(Legend::default().position(Corner::LeftTop))
        .link_axis(link, [true, false])
        .link_cursor(link, [true, false])
        .allow_drag(false)
        .allow_zoom(false)
        .allow_scroll(false)
        .allow_boxed_zoom(false)
        .include_x(t0)
        .include_x(t1)
        .y_axis_label(id)
        .y_axis_min_width(44.0);
    if is_depth {
        // Depth grows downwards on screen, as under water; at least 1 m shown.
        plot = plot.invert_y(true);
        if let Some(d) = last(Channel::Depth) {
            plot = plot.include_y(d - 0.5).include_y(d + 0.5);
        }
    } else if is_heading {
        if let Some(r) = wrap_ref {
            plot = plot.include_y(r - 10.0).include_y(r + 10.0);
        }
        plot = plot.y_axis_formatter(|m, _| format!("{:.0}", m.value.rem_euclid(360.0)));
    } else {
        // Attitude: at least ±5°, so sensor noise does not fill the plot.
        plot = plot.include_y(-5.0).include_y(5.0);
    }
    plot.show(ui, |p| {
        for s in series {
            for seg in series_points(h, s.channel, t0, t1, buckets, wrap_ref) {
                p.line(
                    Line::new(s.name, PlotPoints::new(seg))
                        .color(s.color)
                        .width(s.width)
                        // egui_plot merges points closer than a pixel into a "band"
                        // and interpolates between bands: a decimated setpoint step
                        // followed by its far end became a filled wedge. The series
                        // are already decimated to the pixel columns here.
                        .allow_band(false),
                );
            }
        }
    });
}

pub(crate) fn plots_tab(app: &mut StationApp, ui: &mut Ui) {
    ui.horizontal(|ui| {
        ui.label("Window");
        for (w, name) in WINDOWS {
            ui.selectable_value(&mut app.plot_window_s, w, name);
        }
        let (_, h) = app.shown();
        ui.label(
            egui::RichText::new(format!(
                "{} samples held{}",
                h.len(),
                if h.lost() > 0 {
                    format!(", {} lost", h.lost())
                } else {
                    String::new()
                }
            ))
            .small()
            .color(theme::DIM),
        );
    });
    let (_, h) = app.shown();
    let Some((t0, t1)) = window(h, app.plot_window_s) else {
        ui.label("no data yet");
        return;
    };
    let each = ((ui.available_height() - 12.0) / 4.0).max(80.0);
    for (name, series) in PLOTS {
        plot(ui, name, h, series, t0, t1, each - 6.0);
    }
}
