//! SVG plots with plotters: lines and markers, linear or logarithmic axes, legends.
//!
//! Every method has one colour and one dash pattern in every figure (see [`MethodStyle`]),
//! and the legend is placed where it covers no plotted point: the first corner or side of
//! the plot area whose box (in pixels) meets no plotted point or line segment, or, when
//! none is free, below the plot area. [`write_svg`] returns the resulting [`Layout`] (the
//! legend box and every plotted point in SVG pixels) so that callers and tests can check it.

use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
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
    /// Extra markers drawn on top of the series (e.g. the step ends of a dense curve).
    pub markers: Vec<(f64, f64)>,
    /// Colour of a group ([`GROUPS`], cycled): series that belong together (an ensemble's
    /// ellipse and the filter's at the same time) share one, instead of the method's
    /// colour or the next free one.
    pub group: Option<usize>,
    /// Dash and gap in pixels, instead of the method's pattern (`Some((0, 0))`: solid).
    pub dash: Option<(u32, u32)>,
    /// Line width in pixels, instead of 2 (3 for the exact flow).
    pub width: Option<u32>,
    /// Opacity of the line (1: opaque), so that a line drawn over it stays visible.
    pub opacity: f64,
    /// Marker radius in pixels, instead of [`MARKER_R`].
    pub marker_radius: Option<i32>,
    /// Markers drawn as open rings (a point that others may sit on stays visible).
    pub ring: bool,
}

impl Series {
    pub fn new(label: impl Into<String>, points: Vec<(f64, f64)>, style: Style) -> Self {
        Series {
            label: label.into(),
            points,
            style,
            markers: Vec::new(),
            group: None,
            dash: None,
            width: None,
            opacity: 1.0,
            marker_radius: None,
            ring: false,
        }
    }
    /// Mark these points (e.g. the ends of the steps) on the series' curve.
    pub fn with_markers(mut self, markers: Vec<(f64, f64)>) -> Self {
        self.markers = markers;
        self
    }
    /// Draw in the colour of group `k` (series of one group share one colour).
    pub fn group(mut self, k: usize) -> Self {
        self.group = Some(k);
        self
    }
    /// Dash `on` pixels, gap `off` pixels (`(0, 0)`: solid).
    pub fn dashed(mut self, on: u32, off: u32) -> Self {
        self.dash = Some((on, off));
        self
    }
    /// Line width in pixels.
    pub fn width(mut self, w: u32) -> Self {
        self.width = Some(w);
        self
    }
    /// Line opacity in (0, 1].
    pub fn opacity(mut self, o: f64) -> Self {
        self.opacity = o;
        self
    }
    /// Markers of radius `r` pixels, open rings when `ring`.
    pub fn marker(mut self, r: i32, ring: bool) -> Self {
        self.marker_radius = Some(r);
        self.ring = ring;
        self
    }
}

/// Preferred legend side (right-hand side); it is only a preference: the legend goes to the
/// first position, starting with this one, where it covers no plotted point.
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
    /// Preferred legend position (upper right unless told otherwise).
    pub legend: Legend,
    /// The y axis grows downwards (matrix rows: row 1 at the top); the data keep their
    /// values and the ticks show them.
    pub flip_y: bool,
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
            flip_y: false,
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
    /// Rows downwards: the y axis grows from top to bottom (a matrix's row index).
    pub fn flip_y(mut self) -> Self {
        self.flip_y = true;
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

/// The integration methods, recognised from a series label, each with one fixed look.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MethodStyle {
    /// Black solid line (markers at the step ends when given).
    Exact,
    /// Red solid line.
    Euler,
    /// Green dotted line.
    ImplicitEuler,
    /// Blue dashed line (RK45 and its DP5 stability boundary).
    Rk45,
    /// Purple long-dashed line (variable-order BDF/NDF).
    Bdf,
    /// Brown short-dashed line (Rosenbrock Rodas5P).
    Rodas5P,
    /// Pink dash-dotted line (RK45 ⇄ BDF switching).
    Auto,
}

impl MethodStyle {
    /// The method a label names, if any: "exact…", "RK45"/"rk45"/"DP5", "implicit Euler"/
    /// "implicit-euler", "explicit Euler"/"euler"/"… Euler h = …".
    ///
    /// ```
    /// use reckon_cli::plot::MethodStyle;
    /// assert_eq!(MethodStyle::of("rk45 (slope 5.01)"), Some(MethodStyle::Rk45));
    /// assert_eq!(MethodStyle::of("implicit-euler"), Some(MethodStyle::ImplicitEuler));
    /// assert_eq!(MethodStyle::of("explicit Euler h = 0.1"), Some(MethodStyle::Euler));
    /// assert_eq!(MethodStyle::of("bdf"), Some(MethodStyle::Bdf));
    /// assert_eq!(MethodStyle::of("rodas5p"), Some(MethodStyle::Rodas5P));
    /// assert_eq!(MethodStyle::of("auto (rk45 ⇄ bdf)"), Some(MethodStyle::Auto));
    /// assert_eq!(MethodStyle::of("true path"), None);
    /// ```
    pub fn of(label: &str) -> Option<MethodStyle> {
        let l = label.to_lowercase().replace('-', " ");
        let first = l.split_whitespace().next().unwrap_or("");
        if first == "exact" {
            Some(MethodStyle::Exact)
        } else if first == "auto" {
            Some(MethodStyle::Auto)
        } else if first.starts_with("bdf") {
            Some(MethodStyle::Bdf)
        } else if first.starts_with("rodas") {
            Some(MethodStyle::Rodas5P)
        } else if l.contains("rk45") || first == "dp5" || l.contains("dopri") {
            Some(MethodStyle::Rk45)
        } else if l.contains("implicit euler") {
            Some(MethodStyle::ImplicitEuler)
        } else if l.contains("explicit euler") || first == "euler" || l.contains("euler h") {
            Some(MethodStyle::Euler)
        } else {
            None
        }
    }
    fn color(self) -> RGBColor {
        match self {
            MethodStyle::Exact => RGBColor(0, 0, 0),
            MethodStyle::Euler => RGBColor(214, 39, 40),
            MethodStyle::ImplicitEuler => RGBColor(44, 160, 44),
            MethodStyle::Rk45 => RGBColor(31, 119, 180),
            MethodStyle::Bdf => RGBColor(148, 103, 189),
            MethodStyle::Rodas5P => RGBColor(140, 86, 75),
            MethodStyle::Auto => RGBColor(227, 119, 194),
        }
    }
    /// Dash and gap in pixels (`None`: solid).
    fn dash(self) -> Option<(u32, u32)> {
        match self {
            MethodStyle::Exact | MethodStyle::Euler => None,
            MethodStyle::ImplicitEuler => Some((3, 4)),
            MethodStyle::Rk45 => Some((10, 5)),
            MethodStyle::Bdf => Some((16, 6)),
            MethodStyle::Rodas5P => Some((5, 3)),
            MethodStyle::Auto => Some((12, 3)),
        }
    }
}

/// Colours of series that are not methods (none of the method colours).
const OTHERS: [RGBColor; 8] = [
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
    RGBColor(188, 189, 34),
    RGBColor(127, 127, 127),
    RGBColor(0, 95, 115),
    RGBColor(255, 187, 120),
    RGBColor(0, 0, 128),
    RGBColor(128, 128, 0),
];

/// Colours of groups ([`Series::group`]): the Okabe–Ito palette, told apart with any
/// colour vision; black last.
pub const GROUPS: [RGBColor; 7] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(0, 0, 0),
];

/// The report's figure size in SVG pixels (a legend that finds no free place inside the
/// plot goes below it and makes the figure taller).
pub const FIGURE: (u32, u32) = (640, 480);

/// Font sizes in SVG pixels, chosen against [`FIGURE`]'s width: a phone 420 px wide shows
/// a 640 px figure about 394 px wide, where 16.5 px text reads at 10.2 CSS px.
pub const TICK_PX: f64 = 16.5;
pub const DESC_PX: f64 = 17.5;
pub const TITLE_PX: f64 = 19.5;
pub const LEGEND_PX: f64 = 16.5;
/// The size to give plotters for text of at least `px` SVG pixels: its SVG backend writes
/// a font of size `s` as `s / 1.24` px, truncating `s` to an integer for axis labels.
fn font(px: f64) -> f64 {
    (px * 1.24).ceil()
}
const LEGEND_ROW: i32 = 24;
const MARKER_R: i32 = 4;

/// Where things landed in an SVG, in its pixels (origin top left).
#[derive(Debug, Clone, serde::Serialize)]
pub struct Layout {
    /// File name (set by the caller that knows it; empty otherwise).
    pub file: String,
    pub width: u32,
    pub height: u32,
    pub log_x: bool,
    pub log_y: bool,
    /// Plot area `[left, top, right, bottom]`.
    pub plot_area: [i32; 4],
    /// Legend box `[left, top, right, bottom]` (`None`: no legend).
    pub legend: Option<[i32; 4]>,
    /// The legend is below the plot area (no free position inside it).
    pub legend_outside: bool,
    pub series: Vec<SeriesLayout>,
}

/// One series as drawn, in SVG pixels.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SeriesLayout {
    pub label: String,
    /// Its colour as the SVG writes it (`#RRGGBB`), for lines and markers alike.
    pub color: String,
    /// Consecutive points are joined by lines (`Line`, `LinePoints`).
    pub joined: bool,
    /// Points are joined in pairs (`Segments`).
    pub pairs: bool,
    /// Marker radius in pixels (0: no markers).
    pub marker_radius: i32,
    pub points: Vec<(i32, i32)>,
    pub markers: Vec<(i32, i32)>,
}

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

/// The data ranges of `plot` (with a 5 % margin on linear axes, whole decades on log ones).
fn ranges(plot: &Plot) -> ((f64, f64), (f64, f64)) {
    let all = || plot.series.iter().flat_map(|s| s.points.iter().chain(&s.markers));
    (
        range(all().map(|p| p.0), plot.log_x),
        range(all().map(|p| p.1), plot.log_y),
    )
}

/// Chart margins (pixels): must match the `ChartBuilder` settings in `draw`.
const MARGIN: u32 = 14;
const X_AREA: u32 = 66;
const Y_AREA: u32 = 92;

/// The title broken at spaces into lines that fit `width` pixels (0.5 em a character).
fn title_lines(title: &str, width: u32) -> Vec<String> {
    let per_line = ((width.saturating_sub(2 * MARGIN)) as f64 / (0.5 * TITLE_PX)).max(10.0) as usize;
    let mut lines: Vec<String> = Vec::new();
    for w in title.split_whitespace() {
        match lines.last_mut() {
            Some(l) if l.chars().count() + 1 + w.chars().count() <= per_line => {
                l.push(' ');
                l.push_str(w);
            }
            _ => lines.push(w.to_string()),
        }
    }
    lines
}

/// Height of the title block for a canvas `width` pixels wide.
fn caption_height(plot: &Plot, width: u32) -> u32 {
    let n = title_lines(&plot.title, width).len() as u32;
    if n == 0 {
        0
    } else {
        10 + n * (TITLE_PX * 1.25).ceil() as u32
    }
}

/// The canvas for an equal-aspect plot: `size` narrowed (or made lower) so that the plot
/// area has the data's aspect ratio, the axes spanning the data and their margin and no
/// more; never below half of `size` nor narrower than the legend.
fn fit_canvas(plot: &Plot, size: (u32, u32)) -> (u32, u32) {
    if !plot.equal_aspect || plot.log_x || plot.log_y {
        return size;
    }
    let ((x0, x1), (y0, y1)) = ranges(plot);
    let (xs, ys) = (x1 - x0, y1 - y0);
    if !(xs > 0.0 && ys > 0.0) {
        return size;
    }
    let mut out = size;
    // the title may wrap differently on a narrower canvas: settle it in two rounds
    for _ in 0..2 {
        let cap = caption_height(plot, out.0);
        let w = size.0.saturating_sub(2 * MARGIN + Y_AREA).max(1) as f64;
        let h = size.1.saturating_sub(2 * MARGIN + X_AREA + cap).max(1) as f64;
        out = if xs / ys < w / h {
            let min = (legend_size(plot).0 as u32 + 2 * MARGIN).max(size.0 / 2);
            let need = size.0 as f64 - (w - h * xs / ys);
            ((need.ceil() as u32).max(min).min(size.0), size.1)
        } else {
            let need = size.1 as f64 - (h - w * ys / xs);
            (size.0, (need.ceil() as u32).max(size.1 / 2).min(size.1))
        };
    }
    out
}

/// Write `plot` as an SVG file of `size` pixels (taller when the legend must go below the
/// plot; narrower or lower when an equal-aspect plot's data need less); returns where the
/// legend and the points landed.
pub fn write_svg(plot: &Plot, path: &Path, size: (u32, u32)) -> Result<Layout, Box<dyn Error>> {
    let (svg, mut layout) = render(plot, size)?;
    std::fs::write(path, svg).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    layout.file = path
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    Ok(layout)
}

/// Render `plot` to an SVG string and its layout: where the plot area, the legend and
/// every plotted point landed, in SVG pixels. The legend goes to the first position inside
/// the plot area that meets no point or line, else below it (the SVG grows taller). An
/// equal-aspect plot gets a canvas fitted to its data (see `fit_canvas`): a tall square's
/// figure is narrower, its x axis spanning the data.
///
/// ```
/// use reckon_cli::plot::{render, Plot, Series, Style};
/// // a diagonal through the upper-right corner, where the legend would go by default
/// let plot = Plot::new("diagonal", "x", "y")
///     .with(Series::new("exact flow", (0..=100).map(|k| (k as f64, k as f64)).collect(), Style::Line));
/// let (svg, layout) = render(&plot, (820, 560)).unwrap();
/// assert!(svg.contains("<svg"));
/// let lg = layout.legend.unwrap();
/// let covered = |p: &(i32, i32)| p.0 >= lg[0] && p.0 <= lg[2] && p.1 >= lg[1] && p.1 <= lg[3];
/// assert!(!layout.series[0].points.iter().any(covered));
/// assert!(!layout.legend_outside && layout.series[0].points.len() > 50);
/// // a 1 × 2 rectangle with equal axes: the canvas is narrowed, not the x axis widened
/// let tall = Plot::new("tall", "x", "y").equal().with(Series::new(
///     "path",
///     vec![(0.0, 0.0), (1.0, 0.0), (1.0, 2.0), (0.0, 2.0), (0.0, 0.0)],
///     Style::Line,
/// ));
/// let (_, layout) = render(&tall, (640, 480)).unwrap();
/// assert!(layout.width <= 320, "{}", layout.width); // half the width asked, the least given
/// let xs: Vec<i32> = layout.series[0].points.iter().map(|p| p.0).collect();
/// let span = xs.iter().max().unwrap() - xs.iter().min().unwrap();
/// let area = layout.plot_area[2] - layout.plot_area[0];
/// assert!(span as f64 > 0.7 * area as f64, "{span} of {area}"); // on 640 px: 0.3
/// ```
pub fn render(plot: &Plot, size: (u32, u32)) -> Result<(String, Layout), Box<dyn Error>> {
    let size = fit_canvas(plot, size);
    // first pass: is there a free position inside the plot area?
    let (svg, layout) = render_with(plot, size, 0)?;
    if !layout.legend_outside {
        return Ok((svg, layout));
    }
    let extra = legend_size(plot).1 as u32 + 24;
    render_with(plot, size, extra)
}

fn render_with(plot: &Plot, size: (u32, u32), below: u32) -> Result<(String, Layout), Box<dyn Error>> {
    // a flipped y axis: the data negated, the ticks printed negated back
    let flipped;
    let plot = if plot.flip_y {
        let mut p = plot.clone();
        for s in &mut p.series {
            for q in s.points.iter_mut().chain(s.markers.iter_mut()) {
                q.1 = -q.1;
            }
        }
        flipped = p;
        &flipped
    } else {
        plot
    };
    let ((mut x0, mut x1), (mut y0, mut y1)) = ranges(plot);
    let cap = caption_height(plot, size.0);
    if plot.equal_aspect && !plot.log_x && !plot.log_y {
        // widen the narrower range so one unit is as long on both axes
        let w = size.0.saturating_sub(2 * MARGIN + Y_AREA).max(1) as f64;
        let h = size.1.saturating_sub(2 * MARGIN + X_AREA + cap).max(1) as f64;
        let scale = ((x1 - x0) / w).max((y1 - y0) / h);
        let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
        (x0, x1) = (cx - 0.5 * scale * w, cx + 0.5 * scale * w);
        (y0, y1) = (cy - 0.5 * scale * h, cy + 0.5 * scale * h);
    }
    let mut buf = String::new();
    let layout = {
        let root = SVGBackend::with_string(&mut buf, (size.0, size.1 + below)).into_drawing_area();
        root.fill(&WHITE)?;
        let (top, _) = root.split_vertically(size.1);
        let (title, top) = top.split_vertically(cap);
        let title_font = ("sans-serif", font(TITLE_PX))
            .into_font()
            .color(&BLACK)
            .pos(Pos::new(HPos::Center, VPos::Top));
        for (k, line) in title_lines(&plot.title, size.0).into_iter().enumerate() {
            let y = 8 + k as i32 * (TITLE_PX * 1.25).ceil() as i32;
            title.draw(&Text::new(line, (size.0 as i32 / 2, y), title_font.clone()))?;
        }
        let (xs, ys) = (x1 - x0, y1 - y0);
        let flip = plot.flip_y;
        let mut layout = match (plot.log_x, plot.log_y) {
            (false, false) => draw(plot, &root, &top, x0..x1, y0..y1, (xs, ys, flip), below > 0)?,
            (true, true) => draw(
                plot,
                &root,
                &top,
                (x0..x1).log_scale(),
                (y0..y1).log_scale(),
                (0.0, 0.0, false),
                below > 0,
            )?,
            (false, true) => draw(
                plot,
                &root,
                &top,
                x0..x1,
                (y0..y1).log_scale(),
                (xs, 0.0, false),
                below > 0,
            )?,
            (true, false) => draw(
                plot,
                &root,
                &top,
                (x0..x1).log_scale(),
                y0..y1,
                (0.0, ys, flip),
                below > 0,
            )?,
        };
        root.present()?;
        layout.width = size.0;
        layout.height = size.1 + below;
        layout.log_x = plot.log_x;
        layout.log_y = plot.log_y;
        layout
    };
    Ok((buf, layout))
}

/// Legend box size in pixels (a conservative text-width estimate: 0.56 em per character).
fn legend_size(plot: &Plot) -> (i32, i32) {
    let labels: Vec<&Series> = plot.series.iter().filter(|s| !s.label.is_empty()).collect();
    let text = labels
        .iter()
        .map(|s| (s.label.chars().count() as f64 * 0.56 * LEGEND_PX).ceil() as i32)
        .max()
        .unwrap_or(0);
    (10 + 34 + 8 + text + 10, 8 + LEGEND_ROW * labels.len() as i32 + 4)
}

/// How series `i` is drawn: colour, dash (`None`: solid), line width, marker radius.
fn pen(plot: &Plot, i: usize) -> (RGBColor, Option<(u32, u32)>, u32, i32) {
    let s = &plot.series[i];
    let method = MethodStyle::of(&s.label);
    let (color, dash) = match (s.group, method) {
        (Some(k), _) => (GROUPS[k % GROUPS.len()], None),
        (None, Some(m)) => (m.color(), m.dash()),
        (None, None) => {
            let k = plot.series[..i]
                .iter()
                .filter(|s| s.group.is_none() && MethodStyle::of(&s.label).is_none())
                .count();
            (OTHERS[k % OTHERS.len()], None)
        }
    };
    let dash = match s.dash {
        Some((0, _)) => None,
        Some(d) => Some(d),
        None => dash,
    };
    let width = s
        .width
        .unwrap_or(if method == Some(MethodStyle::Exact) { 3 } else { 2 });
    (color, dash, width, s.marker_radius.unwrap_or(MARKER_R))
}

/// `#RRGGBB`, as plotters writes a colour into the SVG.
fn hex(c: RGBColor) -> String {
    format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2)
}

/// Snap values that are rounding noise relative to the axis span to 0, then shorten.
fn tick(v: f64, span: f64) -> String {
    if span > 0.0 && v.abs() < 1e-9 * span {
        "0".into()
    } else {
        short(v)
    }
}

/// Pairs of points (`Segments`) joined into polylines where an end of one meets an end of
/// another (within 1e-9 of the larger span), so that a dash pattern runs along the curve.
fn chains(pts: &[(f64, f64)]) -> Vec<Vec<(f64, f64)>> {
    use std::collections::HashMap;
    let segs: Vec<[(f64, f64); 2]> = pts.chunks_exact(2).map(|c| [c[0], c[1]]).collect();
    let (mut lo, mut hi) = ((f64::INFINITY, f64::INFINITY), (f64::NEG_INFINITY, f64::NEG_INFINITY));
    for p in pts {
        lo = (lo.0.min(p.0), lo.1.min(p.1));
        hi = (hi.0.max(p.0), hi.1.max(p.1));
    }
    let tol = 1e-9 * (hi.0 - lo.0).max(hi.1 - lo.1).max(f64::MIN_POSITIVE);
    let key = |p: (f64, f64)| (((p.0 - lo.0) / tol).round() as i64, ((p.1 - lo.1) / tol).round() as i64);
    let mut ends: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
    for (k, s) in segs.iter().enumerate() {
        for p in s {
            ends.entry(key(*p)).or_default().push(k);
        }
    }
    let mut used = vec![false; segs.len()];
    // the unused segment with an end within one key of `p`, and its other end
    let mut next = |p: (f64, f64), used: &mut Vec<bool>| -> Option<(f64, f64)> {
        let (kx, ky) = key(p);
        for dx in -1..=1 {
            for dy in -1..=1 {
                if let Some(list) = ends.get_mut(&(kx + dx, ky + dy)) {
                    while let Some(&k) = list.last() {
                        if used[k] {
                            list.pop();
                            continue;
                        }
                        used[k] = true;
                        let s = segs[k];
                        return Some(if key(s[0]) == (kx + dx, ky + dy) { s[1] } else { s[0] });
                    }
                }
            }
        }
        None
    };
    let mut out = Vec::new();
    for k in 0..segs.len() {
        if used[k] {
            continue;
        }
        used[k] = true;
        let mut fwd = vec![segs[k][0], segs[k][1]];
        while let Some(q) = next(*fwd.last().unwrap_or(&segs[k][1]), &mut used) {
            fwd.push(q);
        }
        let mut back = Vec::new();
        while let Some(q) = next(*back.last().unwrap_or(&segs[k][0]), &mut used) {
            back.push(q);
        }
        back.reverse();
        back.extend(fwd);
        out.push(back);
    }
    out
}

#[allow(clippy::too_many_arguments)]
fn draw<X, Y>(
    plot: &Plot,
    root: &DrawingArea<SVGBackend<'_>, Shift>,
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    xr: X,
    yr: Y,
    spans: (f64, f64, bool),
    outside: bool,
) -> Result<Layout, Box<dyn Error>>
where
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let mut chart = ChartBuilder::on(area)
        .margin(MARGIN)
        .margin_top(4)
        .x_label_area_size(X_AREA)
        .y_label_area_size(Y_AREA)
        .build_cartesian_2d(xr, yr)?;
    let (xs, ys, flip) = spans;
    let xf = move |v: &f64| tick(*v, xs);
    let yf = move |v: &f64| tick(if flip { -*v } else { *v }, ys);
    chart
        .configure_mesh()
        .x_desc(plot.x_label.as_str())
        .y_desc(plot.y_label.as_str())
        .x_label_formatter(&xf)
        .y_label_formatter(&yf)
        .label_style(("sans-serif", font(TICK_PX)))
        .axis_desc_style(("sans-serif", font(DESC_PX)))
        .x_labels(7)
        .y_labels(8)
        .light_line_style(RGBColor(238, 238, 238))
        .draw()?;
    let mut series_layout = Vec::new();
    for (i, s) in plot.series.iter().enumerate() {
        let (color, dash, width, radius) = pen(plot, i);
        let ok = |p: &(f64, f64)| {
            p.0.is_finite() && p.1.is_finite() && (!plot.log_x || p.0 > 0.0) && (!plot.log_y || p.1 > 0.0)
        };
        let pts: Vec<(f64, f64)> = s.points.iter().copied().filter(ok).collect();
        let markers: Vec<(f64, f64)> = s.markers.iter().copied().filter(ok).collect();
        let line = color.mix(s.opacity.clamp(0.05, 1.0)).stroke_width(width);
        let joined = matches!(s.style, Style::Line | Style::LinePoints);
        let polylines = if joined {
            vec![pts.clone()]
        } else if s.style == Style::Segments {
            match dash {
                None => pts.chunks_exact(2).map(|c| c.to_vec()).collect(),
                Some(_) => chains(&pts),
            }
        } else {
            Vec::new()
        };
        for pl in polylines {
            match dash {
                None => {
                    chart.draw_series(LineSeries::new(pl, line))?;
                }
                Some((on, off)) => {
                    chart.draw_series(DashedLineSeries::new(pl, on, off, line))?;
                }
            }
        }
        let mark = |p: &(f64, f64)| {
            if s.ring {
                Circle::new(*p, radius, color.stroke_width(2))
            } else {
                Circle::new(*p, radius, color.filled())
            }
        };
        let dots = matches!(s.style, Style::Points | Style::LinePoints);
        if dots {
            chart.draw_series(pts.iter().map(mark))?;
        }
        chart.draw_series(markers.iter().map(mark))?;
        let px = |v: &[(f64, f64)]| v.iter().map(|p| chart.backend_coord(p)).collect::<Vec<_>>();
        let mut points = px(&pts);
        if s.style != Style::Segments {
            // consecutive points on the same pixel add nothing to the record
            points.dedup();
        }
        series_layout.push(SeriesLayout {
            label: s.label.clone(),
            color: hex(color),
            joined,
            pairs: s.style == Style::Segments,
            marker_radius: if dots || !markers.is_empty() { radius } else { 0 },
            points,
            markers: px(&markers),
        });
    }
    let (xr, yr) = chart.plotting_area().get_pixel_range();
    let pa = [xr.start, yr.start, xr.end, yr.end];
    let mut layout = Layout {
        file: String::new(),
        width: 0,
        height: 0,
        log_x: false,
        log_y: false,
        plot_area: pa,
        legend: None,
        legend_outside: false,
        series: series_layout,
    };
    if plot.series.iter().all(|s| s.label.is_empty()) {
        return Ok(layout);
    }
    let (w, h) = legend_size(plot);
    let pad = 10;
    let (l, r, c) = (pa[0] + pad, pa[2] - pad - w, (pa[0] + pa[2] - w) / 2);
    let (t, b, m) = (pa[1] + pad, pa[3] - pad - h, (pa[1] + pa[3] - h) / 2);
    let right = match plot.legend {
        Legend::Upper => [(r, t), (r, m), (r, b)],
        Legend::Middle => [(r, m), (r, t), (r, b)],
        Legend::Lower => [(r, b), (r, m), (r, t)],
    };
    let candidates = right.into_iter().chain([(l, t), (l, b), (c, t), (c, b), (l, m)]);
    let mut place = None;
    if !outside {
        for (x, y) in candidates {
            let rect = [x, y, x + w, y + h];
            if x >= pa[0] && y >= pa[1] && rect[2] <= pa[2] && rect[3] <= pa[3] && !covers(&rect, &layout.series) {
                place = Some(rect);
                break;
            }
        }
    }
    let rect = match place {
        Some(r) => r,
        None => {
            layout.legend_outside = true;
            // centred on the canvas (the plot area sits right of the y labels)
            let y = pa[3] + X_AREA as i32 + 12;
            let x = ((root.dim_in_pixel().0 as i32 - w) / 2).max(4);
            [x, y, x + w, y + h]
        }
    };
    layout.legend = Some(rect);
    if !outside && place.is_none() {
        // first pass: the caller renders again with room below
        return Ok(layout);
    }
    root.draw(&Rectangle::new(
        [(rect[0], rect[1]), (rect[2], rect[3])],
        WHITE.filled(),
    ))?;
    root.draw(&Rectangle::new(
        [(rect[0], rect[1]), (rect[2], rect[3])],
        RGBColor(90, 90, 90).stroke_width(1),
    ))?;
    let font = ("sans-serif", font(LEGEND_PX))
        .into_font()
        .color(&BLACK)
        .pos(Pos::new(HPos::Left, VPos::Center));
    let mut row = 0;
    for (i, s) in plot.series.iter().enumerate() {
        if s.label.is_empty() {
            continue;
        }
        let (color, dash, width, radius) = pen(plot, i);
        let y = rect[1] + 8 + LEGEND_ROW * row + LEGEND_ROW / 2;
        let (x0, x1) = (rect[0] + 10, rect[0] + 10 + 34);
        let style = color.mix(s.opacity.clamp(0.05, 1.0)).stroke_width(width);
        let joined = !matches!(s.style, Style::Points);
        if joined {
            match dash {
                None => root.draw(&PathElement::new(vec![(x0, y), (x1, y)], style))?,
                Some((on, off)) => {
                    let mut x = x0;
                    while x < x1 {
                        let e = (x + on as i32).min(x1);
                        root.draw(&PathElement::new(vec![(x, y), (e, y)], style))?;
                        x = e + off as i32;
                    }
                }
            }
        }
        if !joined || s.style == Style::LinePoints || !s.markers.is_empty() {
            let c = ((x0 + x1) / 2, y);
            if s.ring {
                root.draw(&Circle::new(c, radius, color.stroke_width(2)))?;
            } else {
                root.draw(&Circle::new(c, radius, color.filled()))?;
            }
        }
        root.draw(&Text::new(s.label.clone(), (x1 + 8, y), font.clone()))?;
        row += 1;
    }
    Ok(layout)
}

/// Whether `rect` (with a 3-pixel margin) meets a plotted point, marker or line segment.
fn covers(rect: &[i32; 4], series: &[SeriesLayout]) -> bool {
    series.iter().any(|s| {
        let m = 3 + s.marker_radius;
        let grown = [rect[0] - m, rect[1] - m, rect[2] + m, rect[3] + m];
        let inside = |p: &(i32, i32)| p.0 >= grown[0] && p.0 <= grown[2] && p.1 >= grown[1] && p.1 <= grown[3];
        if s.points.iter().chain(&s.markers).any(inside) {
            return true;
        }
        let grown = [rect[0] - 3, rect[1] - 3, rect[2] + 3, rect[3] + 3];
        if s.joined {
            s.points.windows(2).any(|w| segment_meets(w[0], w[1], &grown))
        } else if s.pairs {
            s.points.chunks_exact(2).any(|w| segment_meets(w[0], w[1], &grown))
        } else {
            false
        }
    })
}

/// Whether the segment a–b meets the rectangle `[l, t, r, b]` (Liang–Barsky clipping).
fn segment_meets(a: (i32, i32), b: (i32, i32), rect: &[i32; 4]) -> bool {
    let (x0, y0) = (a.0 as f64, a.1 as f64);
    let (dx, dy) = (b.0 as f64 - x0, b.1 as f64 - y0);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-dx, x0 - rect[0] as f64),
        (dx, rect[2] as f64 - x0),
        (-dy, y0 - rect[1] as f64),
        (dy, rect[3] as f64 - y0),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return false;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
            if t0 > t1 {
                return false;
            }
        }
    }
    true
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_snap_rounding_noise_to_zero() {
        assert_eq!(tick(-6e-17, 0.45), "0");
        assert_eq!(tick(-0.05, 0.45), "-0.05");
        assert_eq!(tick(1e-5, 1e-4), "1e-5");
    }

    #[test]
    fn segment_through_a_box_meets_it() {
        let r = [10, 10, 20, 20];
        assert!(segment_meets((0, 15), (30, 15), &r));
        assert!(!segment_meets((0, 0), (30, 5), &r));
        assert!(segment_meets((12, 12), (13, 13), &r));
        assert!(!segment_meets((0, 30), (9, 0), &r));
    }
}
