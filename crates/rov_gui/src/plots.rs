//! The Plots tab: depth, heading, pitch and roll against time, with the setpoints, the
//! observer estimate and the chosen model's prediction overlaid. Each series is decimated
//! to a min/max pair per pixel column over the visible window, so one hour of data costs
//! a linear scan of the window per frame and a few thousand vertices.

use egui::{Color32, RichText, Ui};
use egui_plot::{AxisHints, GridInput, GridMark, Line, Plot, PlotPoints};
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
    let mut plot = with_y_ticks(Plot::new(id))
        .height(height)
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
        plot = plot.y_axis_formatter(heading_tick_label);
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
    // One legend for the four plots (the same colours in each), above them, never over
    // the traces; the measured series is the last of each plot.
    let mut legend: Vec<(&str, Color32)> = Vec::new();
    for (_, series) in PLOTS {
        for (i, s) in series.iter().enumerate() {
            let name = if i + 1 == series.len() {
                "measured"
            } else {
                s.name
            };
            if !legend.iter().any(|(n, _)| *n == name) {
                legend.push((name, s.color));
            }
        }
    }
    legend_row(ui, legend.into_iter());
    let each = ((ui.available_height() - 12.0) / 4.0).max(80.0);
    for (name, series) in PLOTS {
        plot(ui, name, h, series, t0, t1, each - 6.0);
    }
}

/// Fewest and most labelled Y ticks a plot shows (issue 25 item 8).
pub const Y_TICKS: std::ops::RangeInclusive<usize> = 3..=5;

/// [`y_ticks`] with at most `max` ticks (at least 3 where the range allows it).
#[must_use]
pub fn y_ticks_at_most(lo: f64, hi: f64, max: usize) -> (f64, Vec<f64>) {
    let (step, t) = y_ticks(lo, hi);
    if t.len() <= max {
        return (step, t);
    }
    let (lo2, hi2) = if lo <= hi { (lo, hi) } else { (hi, lo) };
    let mut s = step;
    for m in [1.25, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0] {
        let st = step * m;
        let first = (lo2 / st).ceil() as i64;
        let last = (hi2 / st).floor() as i64;
        let t: Vec<f64> = (first..=last).map(|k| k as f64 * st).collect();
        if t.len() <= max && t.len() >= 3.min(max) {
            return (st, t);
        }
        s = st;
    }
    (s, t)
}

/// The Y ticks for a visible range `lo..hi`: multiples of a round step (1, 2, 2.5 or 5
/// times a power of ten), 3 to 5 of them inside the range where the range allows it;
/// (step, tick values).
#[must_use]
pub fn y_ticks(lo: f64, hi: f64) -> (f64, Vec<f64>) {
    let (lo, hi) = if lo <= hi { (lo, hi) } else { (hi, lo) };
    let span = hi - lo;
    if !span.is_finite() || span <= 0.0 {
        return (0.0, Vec::new());
    }
    let ticks = |step: f64| -> Vec<f64> {
        let first = (lo / step).ceil() as i64;
        let last = (hi / step).floor() as i64;
        (first..=last).map(|k| k as f64 * step).collect()
    };
    let decade = 10f64.powf((span / 10.0).log10().floor());
    // The roundest steps first; if they jump from more than 5 ticks straight to fewer
    // than 3, steps at most 1.5 times apart, which always land on 3 to 5: from a step
    // with 6 or more ticks (span >= 5 steps, < 7 if exactly 6) the next is at most 1.5
    // times coarser.
    for mults in [
        &[1.0, 2.0, 2.5, 5.0][..],
        &[1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0],
    ] {
        for k in 0..4 {
            for m in mults {
                let step = m * decade * 10f64.powi(k);
                let t = ticks(step);
                if Y_TICKS.contains(&t.len()) {
                    return (step, t);
                }
                if t.len() < *Y_TICKS.start() {
                    break;
                }
            }
        }
    }
    (span, vec![lo, hi])
}

/// A Y grid of [`y_ticks`] marks; 3 of them on a plot too short for 4 labels 20 px
/// apart (egui_plot's `base_step_size` is the value of its 8 px minimum grid spacing).
fn y_grid(input: GridInput) -> Vec<GridMark> {
    let (lo, hi) = input.bounds;
    let px = if input.base_step_size > 0.0 {
        (hi - lo).abs() / input.base_step_size * 8.0
    } else {
        0.0
    };
    let (step, mut ticks) = y_ticks(lo, hi);
    if px < 80.0 && ticks.len() > 3 {
        // Fewer, wider apart: the coarsest round step that still gives 3.
        let (s3, t3) = y_ticks_at_most(lo, hi, 3);
        if t3.len() == 3 {
            return t3
                .into_iter()
                .map(|value| GridMark {
                    value,
                    step_size: s3,
                })
                .collect();
        }
        ticks.truncate(5);
    }
    ticks
        .into_iter()
        .map(|value| GridMark {
            value,
            step_size: step,
        })
        .collect()
}

/// The decimals that write every multiple of `step` exactly: 1 → 0, 0.5 → 1, 2.5 → 1,
/// 0.25 → 2 (at most 6). egui_plot's default rounds `-log10(step)`, which gives 0.5 and
/// 2.5 no decimal: a depth axis read "0, 0, 1, 2" for ticks 0, 0.5, 1, 1.5.
#[must_use]
pub fn tick_decimals(step: f64) -> usize {
    if !(step.is_finite() && step > 0.0) {
        return 0;
    }
    (0..=6usize)
        .find(|&d| {
            let s = step * 10f64.powi(d as i32);
            (s - s.round()).abs() < 1e-6 * s.max(1.0)
        })
        .unwrap_or(6)
}

/// A Y tick's label: `value` with the decimals of its grid `step` ("-0.5", "2.5"), never
/// "-0".
#[must_use]
pub fn tick_label(value: f64, step: f64) -> String {
    let d = tick_decimals(step);
    // `+ 0.0` turns a −0 into 0.
    format!("{:.d$}", value + 0.0)
}

/// A heading tick's label: the compass angle in [0, 360) with the decimals of its step.
pub(crate) fn heading_tick_label(m: GridMark, _range: &std::ops::RangeInclusive<f64>) -> String {
    tick_label(rov_types::angle::wrap_deg_360(m.value), m.step_size)
}

/// A plot with 3–5 labelled Y ticks: the grid of [`y_ticks`] and labels drawn down to
/// 12 px apart (egui_plot's default hides labels closer than 20 px, which left short
/// plots with one label or none), each written with the decimals its step needs.
pub fn with_y_ticks(plot: Plot<'_>) -> Plot<'_> {
    plot.custom_y_axes(vec![
        AxisHints::new_y()
            .label_spacing(10.0..=12.0)
            .tick_label_font(egui::FontId::proportional(11.0))
            .formatter(|m, _| tick_label(m.value, m.step_size)),
    ])
    .y_grid_spacer(y_grid)
}

/// The legend as a row of coloured dots above the plot (never over the traces).
pub fn legend_row<'a>(ui: &mut Ui, items: impl Iterator<Item = (&'a str, Color32)>) {
    ui.horizontal(|ui| {
        ui.spacing_mut().item_spacing.x = 10.0;
        for (name, color) in items {
            crate::instruments::dot_label(ui, color, RichText::new(name).small());
        }
    });
}

#[cfg(test)]
mod tick_tests {
    use super::{Y_TICKS, y_ticks};

    #[test]
    fn three_to_five_ticks_on_any_range() {
        for (lo, hi) in [
            (0.0, 1.0),
            (-5.0, 5.0),
            (2.3, 3.4),
            (0.0, 0.07),
            (95.0, 118.0),
            (-180.0, 180.0),
            (0.0, 360.0),
            (1.234, 1.239),
            (-3.1, 47.9),
            (12.0, 13.0),
            (0.0, 110.0),
        ] {
            let (step, t) = y_ticks(lo, hi);
            assert!(
                Y_TICKS.contains(&t.len()),
                "{lo}..{hi}: step {step} gives {t:?}"
            );
            assert!(
                t.iter().all(|x| (lo - 1e-9..=hi + 1e-9).contains(x)),
                "{t:?}"
            );
        }
        // Every span from 0.01 to 1000 in small steps, at odd offsets.
        let mut span = 0.01;
        while span < 1000.0 {
            let lo = -0.37 * span;
            let (_, t) = y_ticks(lo, lo + span);
            assert!(Y_TICKS.contains(&t.len()), "span {span}: {t:?}");
            span *= 1.07;
        }
        // Short plots: at most 3, and at least 3 where the range allows it.
        let mut span = 0.01;
        while span < 1000.0 {
            let lo = 0.23 * span;
            let (_, t) = super::y_ticks_at_most(lo, lo + span, 3);
            assert!((2..=3).contains(&t.len()), "span {span}: {t:?}");
            span *= 1.11;
        }
        assert!(y_ticks(1.0, 1.0).1.is_empty());
        assert!(y_ticks(f64::NAN, 1.0).1.is_empty());
    }

    /// The labels of a plot's ticks are all different: a 0.5 m step wrote 0, 0.5, 1,
    /// 1.5 as "0, 0, 1, 2" (egui_plot's decimals from the rounded log of the step).
    #[test]
    fn tick_labels_are_distinct_and_exact() {
        use super::{tick_decimals, tick_label};
        assert_eq!(tick_label(0.5, 0.5), "0.5");
        assert_eq!(tick_label(-0.5, 0.5), "-0.5");
        assert_eq!(tick_label(1.5, 0.5), "1.5");
        assert_eq!(tick_label(2.5, 2.5), "2.5");
        assert_eq!(tick_label(0.25, 0.25), "0.25");
        assert_eq!(tick_label(3.0, 1.0), "3");
        assert_eq!(tick_label(-0.0, 1.0), "0");
        assert_eq!(tick_label(350.0, 5.0), "350");
        assert_eq!(tick_decimals(0.0), 0);
        assert_eq!(tick_decimals(f64::NAN), 0);
        let mut span = 0.01;
        while span < 1000.0 {
            for off in [-0.37, 0.0, 0.23, 3.1] {
                let lo = off * span;
                let (step, t) = y_ticks(lo, lo + span);
                let labels: Vec<String> = t.iter().map(|&v| tick_label(v, step)).collect();
                let mut uniq = labels.clone();
                uniq.dedup();
                assert_eq!(uniq, labels, "span {span} at {lo}: step {step}");
                for (v, l) in t.iter().zip(&labels) {
                    let back: f64 = l.parse().unwrap();
                    assert!((back - v).abs() < 1e-9 * v.abs().max(1.0), "{v} -> {l}");
                }
            }
            span *= 1.07;
        }
    }
}
