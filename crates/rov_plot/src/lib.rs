//! Small, dependable PNG charts for the simulator's paper figures and the model lab.
//!
//! A [`Figure`] is a column of [`Panel`]s sharing a width. A panel holds line series
//! (NaN values break a line: a missing sample is drawn as a gap, never as a jump) or bars.
//! Axes scale automatically to "nice" ticks. Text uses the Ubuntu-Light font that egui
//! ships, embedded in the binary, so a figure renders the same everywhere.

pub mod measurement;

use ab_glyph::{Font, FontRef, PxScale, ScaleFont};
use tiny_skia::{Color, LineCap, Paint, PathBuilder, Pixmap, Rect, Stroke, StrokeDash, Transform};

/// An RGB colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rgb(pub u8, pub u8, pub u8);

impl Rgb {
    /// Measured data.
    pub const BLUE: Rgb = Rgb(31, 119, 180);
    /// Second data set.
    pub const LIGHT_BLUE: Rgb = Rgb(120, 180, 230);
    /// Inputs.
    pub const RED: Rgb = Rgb(214, 39, 40);
    /// Model 1, as in the paper's figures.
    pub const PURPLE: Rgb = Rgb(148, 103, 189);
    /// Model 2.
    pub const GREEN: Rgb = Rgb(44, 160, 44);
    /// Model 3.
    pub const BLACK: Rgb = Rgb(20, 20, 20);
    /// Neutral.
    pub const GREY: Rgb = Rgb(127, 127, 127);
    /// Highlight.
    pub const ORANGE: Rgb = Rgb(255, 127, 14);

    fn color(self) -> Color {
        Color::from_rgba8(self.0, self.1, self.2, 255)
    }
}

/// How a series is stroked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LineStyle {
    /// Continuous.
    Solid,
    /// Dashed.
    Dashed,
}

/// One line on a panel.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// (x, y) points in drawing order; a non-finite y breaks the line.
    pub points: Vec<(f64, f64)>,
    /// Colour.
    pub color: Rgb,
    /// Stroke style.
    pub style: LineStyle,
    /// Stroke width, px.
    pub width_px: f32,
}

impl Series {
    /// A solid 1.5 px series.
    pub fn new(name: impl Into<String>, points: Vec<(f64, f64)>, color: Rgb) -> Self {
        Self {
            name: name.into(),
            points,
            color,
            style: LineStyle::Solid,
            width_px: 1.5,
        }
    }

    /// The same series, dashed.
    pub fn dashed(mut self) -> Self {
        self.style = LineStyle::Dashed;
        self
    }
}

/// What a panel shows.
#[derive(Debug, Clone)]
pub enum Content {
    /// Line series against a numeric x axis.
    Lines(Vec<Series>),
    /// Labelled bars (for example an error-fall chart).
    Bars {
        /// One label per bar.
        labels: Vec<String>,
        /// One value per bar.
        values: Vec<f64>,
        /// Bar colour.
        color: Rgb,
    },
}

/// One chart in a figure.
#[derive(Debug, Clone)]
pub struct Panel {
    /// Title drawn above the chart.
    pub title: String,
    /// Label of the x axis.
    pub x_label: String,
    /// Label of the y axis.
    pub y_label: String,
    /// What is drawn.
    pub content: Content,
}

impl Panel {
    /// A panel of line series.
    pub fn lines(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
        series: Vec<Series>,
    ) -> Self {
        Self {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            content: Content::Lines(series),
        }
    }
}

/// A column of panels rendered to one PNG.
#[derive(Debug, Clone)]
pub struct Figure {
    /// Title over the whole figure.
    pub title: String,
    /// Width, px.
    pub width_px: u32,
    /// Height of each panel, px.
    pub panel_height_px: u32,
    /// The panels, top to bottom.
    pub panels: Vec<Panel>,
}

/// Why a figure could not be rendered.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlotError {
    /// The requested size is zero or too large.
    #[error("figure size {width}x{height} px is not drawable (1..=8000 each)")]
    Size {
        /// Width, px.
        width: u32,
        /// Height, px.
        height: u32,
    },
    /// The embedded font could not be parsed (a build problem).
    #[error("embedded font failed to load")]
    Font,
    /// PNG encoding failed.
    #[error("PNG encoding failed: {0}")]
    Encode(String),
}

const TITLE_H: f32 = 34.0;
const MARGIN_L: f32 = 72.0;
const MARGIN_R: f32 = 150.0;
const MARGIN_T: f32 = 26.0;
const MARGIN_B: f32 = 40.0;

struct Canvas<'f> {
    pixmap: Pixmap,
    font: FontRef<'f>,
}

impl Canvas<'_> {
    fn text(&mut self, s: &str, x: f32, y: f32, size: f32, color: Rgb, align: f32) {
        // align: 0 = left, 0.5 = centre, 1 = right; y is the baseline.
        let scaled = self.font.as_scaled(PxScale::from(size));
        let width: f32 = s
            .chars()
            .map(|c| scaled.h_advance(scaled.glyph_id(c)))
            .sum();
        let mut pen = x - align * width;
        let w = self.pixmap.width() as i32;
        let h = self.pixmap.height() as i32;
        let data = self.pixmap.data_mut();
        for c in s.chars() {
            let id = scaled.glyph_id(c);
            let glyph = id.with_scale_and_position(PxScale::from(size), ab_glyph::point(pen, y));
            pen += scaled.h_advance(id);
            if let Some(outlined) = self.font.outline_glyph(glyph) {
                let bounds = outlined.px_bounds();
                outlined.draw(|gx, gy, coverage| {
                    let px = bounds.min.x as i32 + gx as i32;
                    let py = bounds.min.y as i32 + gy as i32;
                    if px < 0 || py < 0 || px >= w || py >= h {
                        return;
                    }
                    let idx = ((py * w + px) * 4) as usize;
                    if let Some(p) = data.get_mut(idx..idx + 4) {
                        let a = coverage.clamp(0.0, 1.0);
                        for (ch, target) in p.iter_mut().zip([color.0, color.1, color.2]) {
                            *ch =
                                (f32::from(*ch) * (1.0 - a) + f32::from(target) * a).round() as u8;
                        }
                        p[3] = 255;
                    }
                });
            }
        }
    }

    fn line(&mut self, pts: &[(f32, f32)], color: Rgb, width: f32, dashed: bool) {
        if pts.len() < 2 {
            return;
        }
        let mut pb = PathBuilder::new();
        let mut iter = pts.iter();
        if let Some(&(x, y)) = iter.next() {
            pb.move_to(x, y);
        }
        for &(x, y) in iter {
            pb.line_to(x, y);
        }
        let Some(path) = pb.finish() else { return };
        let mut paint = Paint::default();
        paint.set_color(color.color());
        paint.anti_alias = true;
        let mut stroke = Stroke {
            width,
            line_cap: LineCap::Round,
            ..Stroke::default()
        };
        if dashed {
            stroke.dash = StrokeDash::new(vec![6.0, 4.0], 0.0);
        }
        self.pixmap
            .stroke_path(&path, &paint, &stroke, Transform::identity(), None);
    }

    fn rect(&mut self, x: f32, y: f32, w: f32, h: f32, color: Rgb) {
        if let Some(r) = Rect::from_xywh(x, y, w.max(0.5), h.max(0.5)) {
            let mut paint = Paint::default();
            paint.set_color(color.color());
            self.pixmap
                .fill_rect(r, &paint, Transform::identity(), None);
        }
    }
}

/// "Nice" tick positions covering [lo, hi].
fn nice_ticks(lo: f64, hi: f64, target: usize) -> (f64, f64, Vec<f64>) {
    let span = (hi - lo).abs().max(1e-12);
    let raw = span / target.max(1) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let start = (lo / step).floor() * step;
    let end = (hi / step).ceil() * step;
    let mut ticks = Vec::new();
    let mut t = start;
    while t <= end + step * 1e-6 && ticks.len() < 50 {
        ticks.push(if t.abs() < step * 1e-9 { 0.0 } else { t });
        t += step;
    }
    (start, end, ticks)
}

fn fmt_tick(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if !(1e-3..1e4).contains(&a) {
        format!("{v:.1e}")
    } else if (v - v.round()).abs() < 1e-9 {
        format!("{v:.0}")
    } else {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

impl Figure {
    /// A figure with the default size (1000 px wide, 240 px per panel).
    pub fn new(title: impl Into<String>, panels: Vec<Panel>) -> Self {
        Self {
            title: title.into(),
            width_px: 1000,
            panel_height_px: 240,
            panels,
        }
    }

    /// Renders the figure to PNG bytes.
    pub fn render_png(&self) -> Result<Vec<u8>, PlotError> {
        let height = TITLE_H as u32
            + self
                .panel_height_px
                .saturating_mul(self.panels.len().max(1) as u32);
        if self.width_px == 0 || self.width_px > 8000 || height > 8000 || self.panel_height_px < 80
        {
            return Err(PlotError::Size {
                width: self.width_px,
                height,
            });
        }
        let pixmap = Pixmap::new(self.width_px, height).ok_or(PlotError::Size {
            width: self.width_px,
            height,
        })?;
        let font = FontRef::try_from_slice(epaint_default_fonts::UBUNTU_LIGHT)
            .map_err(|_| PlotError::Font)?;
        let mut c = Canvas { pixmap, font };
        c.pixmap.fill(Color::WHITE);
        c.text(
            &self.title,
            self.width_px as f32 / 2.0,
            24.0,
            20.0,
            Rgb::BLACK,
            0.5,
        );
        for (i, panel) in self.panels.iter().enumerate() {
            let top = TITLE_H + (i as u32 * self.panel_height_px) as f32;
            draw_panel(
                &mut c,
                panel,
                top,
                self.width_px as f32,
                self.panel_height_px as f32,
            );
        }
        c.pixmap
            .encode_png()
            .map_err(|e| PlotError::Encode(e.to_string()))
    }
}

fn draw_panel(c: &mut Canvas<'_>, panel: &Panel, top: f32, width: f32, height: f32) {
    let x0 = MARGIN_L;
    let x1 = width - MARGIN_R;
    let y0 = top + MARGIN_T;
    let y1 = top + height - MARGIN_B;
    c.text(
        &panel.title,
        (x0 + x1) / 2.0,
        top + 18.0,
        15.0,
        Rgb::BLACK,
        0.5,
    );
    match &panel.content {
        Content::Lines(series) => draw_lines(c, panel, series, (x0, x1, y0, y1)),
        Content::Bars {
            labels,
            values,
            color,
        } => draw_bars(c, panel, labels, values, *color, (x0, x1, y0, y1)),
    }
    // frame
    c.line(
        &[(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)],
        Rgb::GREY,
        1.0,
        false,
    );
    c.text(
        &panel.x_label,
        (x0 + x1) / 2.0,
        y1 + 34.0,
        13.0,
        Rgb::BLACK,
        0.5,
    );
    c.text(&panel.y_label, 4.0, y0 - 6.0, 12.0, Rgb::BLACK, 0.0);
}

fn y_axis(c: &mut Canvas<'_>, lo: f64, hi: f64, area: (f32, f32, f32, f32)) -> (f64, f64) {
    let (x0, x1, y0, y1) = area;
    let (ylo, yhi, yticks) = nice_ticks(lo, hi, 5);
    for t in &yticks {
        let py = y1 - ((t - ylo) / (yhi - ylo).max(1e-12)) as f32 * (y1 - y0);
        c.line(&[(x0, py), (x1, py)], Rgb(225, 225, 225), 1.0, false);
        c.text(&fmt_tick(*t), x0 - 6.0, py + 4.0, 12.0, Rgb::BLACK, 1.0);
    }
    (ylo, yhi)
}

fn draw_lines(c: &mut Canvas<'_>, _panel: &Panel, series: &[Series], area: (f32, f32, f32, f32)) {
    let (x0, x1, y0, y1) = area;
    let finite = series
        .iter()
        .flat_map(|s| s.points.iter())
        .filter(|(x, y)| x.is_finite() && y.is_finite());
    let (mut xmin, mut xmax, mut ymin, mut ymax) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in finite {
        xmin = xmin.min(x);
        xmax = xmax.max(x);
        ymin = ymin.min(y);
        ymax = ymax.max(y);
    }
    if xmin > xmax {
        (xmin, xmax, ymin, ymax) = (0.0, 1.0, 0.0, 1.0);
    }
    if (ymax - ymin).abs() < 1e-9 {
        ymin -= 1.0;
        ymax += 1.0;
    }
    let (ylo, yhi) = y_axis(c, ymin, ymax, area);
    let (xlo, xhi, xticks) = nice_ticks(xmin, xmax, 10);
    let sx = |x: f64| x0 + ((x - xlo) / (xhi - xlo).max(1e-12)) as f32 * (x1 - x0);
    let sy = |y: f64| y1 - ((y - ylo) / (yhi - ylo).max(1e-12)) as f32 * (y1 - y0);
    for t in &xticks {
        let px = sx(*t);
        c.line(&[(px, y0), (px, y1)], Rgb(235, 235, 235), 1.0, false);
        c.text(&fmt_tick(*t), px, y1 + 16.0, 12.0, Rgb::BLACK, 0.5);
    }
    for s in series {
        let mut run: Vec<(f32, f32)> = Vec::with_capacity(s.points.len());
        for &(x, y) in &s.points {
            if x.is_finite() && y.is_finite() {
                run.push((sx(x), sy(y)));
            } else {
                c.line(&run, s.color, s.width_px, s.style == LineStyle::Dashed);
                run.clear();
            }
        }
        c.line(&run, s.color, s.width_px, s.style == LineStyle::Dashed);
    }
    // legend in the right margin, so it never hides data
    let mut ly = y0 + 10.0;
    for s in series.iter().filter(|s| !s.name.is_empty()) {
        let lx = x1 + 10.0;
        c.line(
            &[(lx, ly - 4.0), (lx + 22.0, ly - 4.0)],
            s.color,
            2.5,
            s.style == LineStyle::Dashed,
        );
        c.text(&s.name, lx + 28.0, ly, 12.0, Rgb::BLACK, 0.0);
        ly += 15.0;
    }
}

fn draw_bars(
    c: &mut Canvas<'_>,
    _panel: &Panel,
    labels: &[String],
    values: &[f64],
    color: Rgb,
    area: (f32, f32, f32, f32),
) {
    let (x0, x1, y0, y1) = area;
    let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    let ymin = finite.iter().copied().fold(0.0_f64, f64::min);
    let ymax = finite
        .iter()
        .copied()
        .fold(0.0_f64, f64::max)
        .max(ymin + 1e-9);
    let (ylo, yhi) = y_axis(c, ymin, ymax, area);
    let sy = |y: f64| y1 - ((y - ylo) / (yhi - ylo).max(1e-12)) as f32 * (y1 - y0);
    let n = values.len().max(1) as f32;
    let slot = (x1 - x0) / n;
    for (i, (label, v)) in labels.iter().zip(values).enumerate() {
        let cx = x0 + slot * (i as f32 + 0.5);
        if v.is_finite() {
            let (a, b) = (sy(0.0_f64.max(ylo)), sy(*v));
            c.rect(cx - slot * 0.3, a.min(b), slot * 0.6, (a - b).abs(), color);
            c.text(
                &fmt_tick((v * 100.0).round() / 100.0),
                cx,
                a.min(b) - 4.0,
                11.0,
                Rgb::BLACK,
                0.5,
            );
        }
        c.text(label, cx, y1 + 16.0, 11.0, Rgb::BLACK, 0.5);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decode_size(png: &[u8]) -> (u32, u32) {
        let pm = Pixmap::decode_png(png).unwrap();
        (pm.width(), pm.height())
    }

    #[test]
    fn renders_lines_with_gaps_and_text() {
        let pts: Vec<(f64, f64)> = (0..200)
            .map(|i| {
                let t = i as f64 * 0.1;
                (
                    t,
                    if (50..60).contains(&i) {
                        f64::NAN
                    } else {
                        t.sin()
                    },
                )
            })
            .collect();
        let fig = Figure::new(
            "test figure",
            vec![
                Panel::lines(
                    "sine",
                    "time [s]",
                    "y",
                    vec![Series::new("sin", pts, Rgb::BLUE)],
                ),
                Panel {
                    title: "bars".into(),
                    x_label: String::new(),
                    y_label: "rmse".into(),
                    content: Content::Bars {
                        labels: vec!["a".into(), "b".into()],
                        values: vec![1.0, 0.4],
                        color: Rgb::GREEN,
                    },
                },
            ],
        );
        let png = fig.render_png().unwrap();
        if let Ok(dir) = std::env::var("ROV_PLOT_DUMP") {
            std::fs::write(format!("{dir}/rov_plot_test.png"), &png).unwrap();
        }
        assert_eq!(decode_size(&png), (1000, 34 + 480));
        let pm = Pixmap::decode_png(&png).unwrap();
        // Something blue was drawn (the series) and something dark (text).
        let blue = pm
            .pixels()
            .iter()
            .filter(|p| p.blue() > 150 && p.red() < 80)
            .count();
        let dark = pm
            .pixels()
            .iter()
            .filter(|p| p.red() < 60 && p.green() < 60 && p.blue() < 60)
            .count();
        assert!(blue > 500, "series pixels: {blue}");
        assert!(dark > 100, "text pixels: {dark}");
    }

    #[test]
    fn empty_and_degenerate_inputs_render() {
        let fig = Figure::new(
            "empty",
            vec![Panel::lines(
                "none",
                "x",
                "y",
                vec![Series::new("flat", vec![(0.0, 1.0), (1.0, 1.0)], Rgb::RED)],
            )],
        );
        assert!(fig.render_png().is_ok());
        let bad = Figure { width_px: 0, ..fig };
        assert!(matches!(bad.render_png(), Err(PlotError::Size { .. })));
    }

    #[test]
    fn ticks_are_nice() {
        let (lo, hi, t) = nice_ticks(0.03, 9.7, 5);
        assert_eq!((lo, hi), (0.0, 10.0));
        assert_eq!(t, vec![0.0, 2.0, 4.0, 6.0, 8.0, 10.0]);
        assert_eq!(fmt_tick(2.5), "2.5");
        assert_eq!(fmt_tick(-40.0), "-40");
    }
}
