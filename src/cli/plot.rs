//! SVG plots with plotters: lines and markers, linear or logarithmic axes, legends.

use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;
use std::error::Error;
use std::path::Path;

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Style {
    Line,
    Points,
    LinePoints,
    /// Independent segments (pairs of points), e.g. a contour.
    Segments,
}

/// One labelled data series.
#[derive(Debug, Clone)]
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
    pub style: Style,
}

impl Series {
    pub fn new(label: impl Into<String>, points: Vec<(f64, f64)>, style: Style) -> Self {
        Series {
            label: label.into(),
            points,
            style,
        }
    }
}

/// Legend placement, on the right-hand side.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Legend {
    Upper,
    Middle,
    Lower,
}

/// A 2-D plot.
#[derive(Debug, Clone)]
pub struct Plot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub log_x: bool,
    pub log_y: bool,
    /// Same scale on both axes (trajectories, stability regions).
    pub equal_aspect: bool,
    /// Where the legend goes (upper right unless a curve lives there).
    pub legend: Legend,
    pub series: Vec<Series>,
}

impl Plot {
    pub fn new(title: impl Into<String>, x_label: impl Into<String>, y_label: impl Into<String>) -> Self {
        Plot {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            log_x: false,
            log_y: false,
            equal_aspect: false,
            legend: Legend::Upper,
            series: Vec::new(),
        }
    }
    pub fn log_log(mut self) -> Self {
        self.log_x = true;
        self.log_y = true;
        self
    }
    pub fn log_y(mut self) -> Self {
        self.log_y = true;
        self
    }
    pub fn equal(mut self) -> Self {
        self.equal_aspect = true;
        self
    }
    pub fn legend_at(mut self, pos: Legend) -> Self {
        self.legend = pos;
        self
    }
    pub fn with(mut self, s: Series) -> Self {
        self.series.push(s);
        self
    }
}

const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

fn range(vals: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in vals.filter(|v| v.is_finite() && (!log || *v > 0.0)) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return if log { (0.1, 10.0) } else { (-1.0, 1.0) };
    }
    if log {
        let (l, h) = (lo.log10().floor(), hi.log10().ceil().max(lo.log10().floor() + 1.0));
        (10f64.powf(l), 10f64.powf(h))
    } else {
        let pad = if hi > lo {
            0.05 * (hi - lo)
        } else {
            0.5 * lo.abs().max(1.0)
        };
        (lo - pad, hi + pad)
    }
}

/// Write `plot` as an SVG file of `size` pixels.
pub fn write_svg(plot: &Plot, path: &Path, size: (u32, u32)) -> Result<(), Box<dyn Error>> {
    let (mut x0, mut x1) = range(
        plot.series.iter().flat_map(|s| s.points.iter().map(|p| p.0)),
        plot.log_x,
    );
    let (mut y0, mut y1) = range(
        plot.series.iter().flat_map(|s| s.points.iter().map(|p| p.1)),
        plot.log_y,
    );
    if plot.equal_aspect && !plot.log_x && !plot.log_y {
        // widen the narrower range so one unit is as long on both axes
        let (w, h) = ((size.0 - 140) as f64, (size.1 - 110) as f64);
        let scale = ((x1 - x0) / w).max((y1 - y0) / h);
        let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
        (x0, x1) = (cx - 0.5 * scale * w, cx + 0.5 * scale * w);
        (y0, y1) = (cy - 0.5 * scale * h, cy + 0.5 * scale * h);
    }
    let root = SVGBackend::new(path, size).into_drawing_area();
    root.fill(&WHITE)?;
    match (plot.log_x, plot.log_y) {
        (false, false) => draw(plot, &root, x0..x1, y0..y1)?,
        (true, true) => draw(plot, &root, (x0..x1).log_scale(), (y0..y1).log_scale())?,
        (false, true) => draw(plot, &root, x0..x1, (y0..y1).log_scale())?,
        (true, false) => draw(plot, &root, (x0..x1).log_scale(), y0..y1)?,
    }
    root.present()?;
    Ok(())
}

fn draw<X, Y>(plot: &Plot, root: &DrawingArea<SVGBackend<'_>, Shift>, xr: X, yr: Y) -> Result<(), Box<dyn Error>>
where
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let mut chart = ChartBuilder::on(root)
        .caption(&plot.title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(75)
        .build_cartesian_2d(xr, yr)?;
    chart
        .configure_mesh()
        .x_desc(plot.x_label.as_str())
        .y_desc(plot.y_label.as_str())
        .x_label_formatter(&|v| short(*v))
        .y_label_formatter(&|v| short(*v))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()?;
    for (i, s) in plot.series.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|p| p.0.is_finite() && p.1.is_finite() && (!plot.log_x || p.0 > 0.0) && (!plot.log_y || p.1 > 0.0))
            .collect();
        let anno = match s.style {
            Style::Line => chart.draw_series(LineSeries::new(pts, color.stroke_width(2)))?,
            Style::Points => chart.draw_series(pts.into_iter().map(|p| Circle::new(p, 3, color.filled())))?,
            Style::LinePoints => {
                chart.draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))?;
                chart.draw_series(pts.into_iter().map(|p| Circle::new(p, 3, color.filled())))?
            }
            Style::Segments => chart.draw_series(
                pts.chunks_exact(2)
                    .map(|c| PathElement::new(vec![c[0], c[1]], color.stroke_width(2))),
            )?,
        };
        if !s.label.is_empty() {
            anno.label(s.label.as_str())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(3)));
        }
    }
    if plot.series.iter().any(|s| !s.label.is_empty()) {
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(match plot.legend {
                Legend::Upper => SeriesLabelPosition::UpperRight,
                Legend::Middle => SeriesLabelPosition::MiddleRight,
                Legend::Lower => SeriesLabelPosition::LowerRight,
            })
            .draw()?;
    }
    Ok(())
}

fn short(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() >= 1e4 || v.abs() < 1e-2 {
        format!("{v:.0e}")
    } else {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}
