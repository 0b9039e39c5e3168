//! Figures of the experiments: line charts and orbit plots with plotters, written as SVG
//! (text as `<text>` elements, no font needed) and PNG (text rasterised with DejaVu Sans
//! embedded from the `dejavu` crate; no system fonts). Long series are thinned to a few
//! thousand points per curve ([`thin`], keeping each bin's extremes so error peaks survive).

use std::path::Path;
use std::sync::Once;

use plotters::coord::ranged1d::{AsRangedCoord, Ranged, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;

use super::CliResult;

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Style {
    /// A polyline through the points; a non-finite point breaks it (pen up).
    Line,
    /// A small dot at each point (orbits sampled at irregular phases).
    Dots,
    /// A large filled circle at each point (landmarks such as fixed points).
    Markers,
}

/// One curve.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// Abscissae.
    pub x: Vec<f64>,
    /// Ordinates.
    pub y: Vec<f64>,
    /// Colour index into [`PALETTE`].
    pub color: usize,
    /// Line or dots.
    pub style: Style,
}

/// One panel: axes, labels and curves.
#[derive(Clone, Debug)]
pub struct Chart {
    /// Panel title.
    pub title: String,
    /// x axis label.
    pub x_label: String,
    /// y axis label.
    pub y_label: String,
    /// Logarithmic y axis (values below the smallest positive one, e.g. exact zeros, are drawn
    /// at the bottom of the axis).
    pub log_y: bool,
    /// Equal scales on both axes (orbits).
    pub equal_aspect: bool,
    /// The curves.
    pub series: Vec<Series>,
}

/// Values up to this are "zero" on a logarithmic axis (left out of its range).
pub const LOG_FLOOR: f64 = 1e-17;

/// Colours of the methods: feedback (blue), projection (orange), splitting / Störmer–Verlet
/// (green, red), Euler / reference (purple, black).
pub const PALETTE: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(0, 0, 0),
];

impl Chart {
    /// A panel with no curves.
    pub fn new(title: &str, x_label: &str, y_label: &str, log_y: bool) -> Self {
        Chart {
            title: title.to_string(),
            x_label: x_label.to_string(),
            y_label: y_label.to_string(),
            log_y,
            equal_aspect: false,
            series: Vec::new(),
        }
    }

    /// Adds a curve.
    pub fn add(&mut self, label: &str, x: Vec<f64>, y: Vec<f64>, color: usize, style: Style) {
        self.series.push(Series {
            label: label.to_string(),
            x,
            y,
            color,
            style,
        });
    }
}

/// At most about `max` points of (x, y): the series is cut into max/2 bins and each bin
/// contributes its smallest and largest y (in x order), so oscillations and peaks stay visible.
pub fn thin(x: &[f64], y: &[f64], max: usize) -> (Vec<f64>, Vec<f64>) {
    let n = x.len().min(y.len());
    if n <= max || max < 4 {
        return (x[..n].to_vec(), y[..n].to_vec());
    }
    let bins = max / 2;
    let (mut tx, mut ty) = (Vec::with_capacity(max + 2), Vec::with_capacity(max + 2));
    for b in 0..bins {
        let (lo, hi) = (b * n / bins, ((b + 1) * n / bins).max(b * n / bins + 1));
        let (mut imin, mut imax) = (lo, lo);
        for i in lo..hi {
            if y[i] < y[imin] {
                imin = i;
            }
            if y[i] > y[imax] {
                imax = i;
            }
        }
        let (a, c) = if imin <= imax {
            (imin, imax)
        } else {
            (imax, imin)
        };
        tx.push(x[a]);
        ty.push(y[a]);
        if c != a {
            tx.push(x[c]);
            ty.push(y[c]);
        }
    }
    if tx.last() != Some(&x[n - 1]) {
        tx.push(x[n - 1]);
        ty.push(y[n - 1]);
    }
    (tx, ty)
}

/// Every k-th point, so that at most `max` remain (for dot plots of orbits).
pub fn decimate(x: &[f64], y: &[f64], max: usize) -> (Vec<f64>, Vec<f64>) {
    let n = x.len().min(y.len());
    let k = n.div_ceil(max.max(1)).max(1);
    (
        x[..n].iter().step_by(k).copied().collect(),
        y[..n].iter().step_by(k).copied().collect(),
    )
}

static FONT: Once = Once::new();

fn register_font() {
    FONT.call_once(|| {
        // DejaVu Sans is a valid TrueType font; registration cannot fail on it.
        let _ = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            dejavu::sans::regular(),
        );
    });
}

/// Writes `<stem>.svg` and `<stem>.png` in `dir` with the panels on a `rows × cols` grid,
/// each panel `panel_size` pixels.
pub fn write_figure(
    dir: &Path,
    stem: &str,
    panels: &[Chart],
    (rows, cols): (usize, usize),
    panel_size: (u32, u32),
) -> CliResult {
    register_font();
    let size = (panel_size.0 * cols as u32, panel_size.1 * rows as u32);
    let svg = dir.join(format!("{stem}.svg"));
    {
        let root = SVGBackend::new(&svg, size).into_drawing_area();
        draw_panels(&root, panels, rows, cols)?;
        root.present()
            .map_err(|e| format!("writing {}: {e}", svg.display()))?;
    }
    let png = dir.join(format!("{stem}.png"));
    let mut buf = vec![0u8; (size.0 * size.1 * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
        draw_panels(&root, panels, rows, cols)?;
        root.present()
            .map_err(|e| format!("drawing {}: {e}", png.display()))?;
    }
    write_png(&png, &buf, size)
}

fn write_png(path: &Path, rgb: &[u8], (w, h): (u32, u32)) -> CliResult {
    let file = std::fs::File::create(path)
        .map_err(|e| format!("cannot create {}: {e}", path.display()))?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w, h);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_compression(png::Compression::Best);
    let mut writer = enc.write_header()?;
    writer.write_image_data(rgb)?;
    writer.finish()?;
    Ok(())
}

fn draw_panels<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    panels: &[Chart],
    rows: usize,
    cols: usize,
) -> CliResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let areas = root.split_evenly((rows, cols));
    for (area, chart) in areas.iter().zip(panels) {
        draw_chart(area, chart)?;
    }
    Ok(())
}

/// The data range of all curves of a chart, padded; log10 of the y range for log axes.
fn ranges(chart: &Chart) -> ((f64, f64), (f64, f64)) {
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for s in &chart.series {
        for (&x, &y) in s.x.iter().zip(&s.y) {
            if !(x.is_finite() && y.is_finite()) {
                continue;
            }
            // exact zeros (t = 0) would stretch a log axis to the floor: leave them out of the
            // range; they are drawn at its bottom
            if chart.log_y && y <= LOG_FLOOR {
                x0 = x0.min(x);
                x1 = x1.max(x);
                continue;
            }
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
    }
    if !y0.is_finite() {
        y0 = if chart.log_y { 1e-16 } else { 0.0 };
        y1 = 1.0;
    }
    if !x0.is_finite() {
        return ((0.0, 1.0), (if chart.log_y { 1e-16 } else { 0.0 }, 1.0));
    }
    if x1 <= x0 {
        x1 = x0 + 1.0;
    }
    if chart.log_y {
        let (l0, l1) = (
            y0.log10().floor(),
            y1.log10().ceil().max(y0.log10().floor() + 1.0),
        );
        ((x0, x1), (10f64.powf(l0), 10f64.powf(l1)))
    } else {
        if y1 <= y0 {
            y1 = y0 + 1.0;
        }
        let pad = 0.05 * (y1 - y0);
        if chart.equal_aspect {
            let pad_x = 0.05 * (x1 - x0);
            ((x0 - pad_x, x1 + pad_x), (y0 - pad, y1 + pad))
        } else {
            ((x0, x1), (y0 - pad, y1 + pad))
        }
    }
}

fn draw_chart<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, chart: &Chart) -> CliResult
where
    DB::ErrorType: 'static,
{
    let ((x0, x1), (y0, y1)) = ranges(chart);
    let mut builder = ChartBuilder::on(area);
    builder
        .caption(&chart.title, ("sans-serif", 17))
        .margin(12)
        .x_label_area_size(38)
        .y_label_area_size(68);
    if chart.log_y {
        let ctx = builder
            .build_cartesian_2d(x0..x1, (y0..y1).log_scale())
            .map_err(|e| e.to_string())?;
        finish_chart(ctx, chart, y0, |v: &f64| format!("{v:.0e}"))
    } else {
        let (x0, x1, y0, y1) = if chart.equal_aspect {
            equalise(area, (x0, x1), (y0, y1))
        } else {
            (x0, x1, y0, y1)
        };
        let ctx = builder
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|e| e.to_string())?;
        finish_chart(ctx, chart, f64::NEG_INFINITY, |v: &f64| format!("{v:.3}"))
    }
}

/// Widens one of the ranges so that a unit has the same length on both axes.
fn equalise<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
) -> (f64, f64, f64, f64) {
    let (w, h) = area.dim_in_pixel();
    let (w, h) = ((w as f64 - 90.0).max(10.0), (h as f64 - 80.0).max(10.0));
    let (sx, sy) = ((x1 - x0) / w, (y1 - y0) / h);
    if sx > sy {
        let c = 0.5 * (y0 + y1);
        let half = 0.5 * sx * h;
        (x0, x1, c - half, c + half)
    } else {
        let c = 0.5 * (x0 + x1);
        let half = 0.5 * sy * w;
        (c - half, c + half, y0, y1)
    }
}

fn finish_chart<'a, DB, Y>(
    mut ctx: ChartContext<'a, DB, Cartesian2d<RangedCoordf64, Y>>,
    chart: &Chart,
    y_floor: f64,
    y_fmt: impl Fn(&f64) -> String,
) -> CliResult
where
    DB: DrawingBackend + 'a,
    DB::ErrorType: 'static,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
    std::ops::Range<f64>: AsRangedCoord<CoordDescType = RangedCoordf64>,
{
    ctx.configure_mesh()
        .x_desc(chart.x_label.as_str())
        .y_desc(chart.y_label.as_str())
        .y_label_formatter(&y_fmt)
        // ten significant digits (0.30000000000000004 is written 0.3), and round-off zeros 0
        .x_label_formatter(&|v: &f64| {
            let r: f64 = format!("{v:.9e}").parse().unwrap_or(*v);
            format!("{}", if r.abs() < 1e-12 { 0.0 } else { r })
        })
        .label_style(("sans-serif", 12))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(|e| e.to_string())?;
    for s in &chart.series {
        let color = PALETTE[s.color % PALETTE.len()];
        let point = move |(&x, &y): (&f64, &f64)| (x, y.max(y_floor));
        let finite = |(x, y): &(&f64, &f64)| x.is_finite() && y.is_finite();
        let anno = match s.style {
            // a non-finite point lifts the pen: each finite run is its own polyline
            Style::Line => {
                let pts: Vec<Option<(f64, f64)>> =
                    s.x.iter()
                        .zip(&s.y)
                        .map(|p| finite(&p).then(|| point(p)))
                        .collect();
                let mut runs = pts.split(Option::is_none).filter(|run| !run.is_empty());
                let first = runs.next().unwrap_or_default();
                for run in runs {
                    ctx.draw_series(LineSeries::new(
                        run.iter().flatten().copied(),
                        color.stroke_width(1),
                    ))
                    .map_err(|e| e.to_string())?;
                }
                // the labelled run last: its legend entry borrows the chart
                ctx.draw_series(LineSeries::new(
                    first.iter().flatten().copied(),
                    color.stroke_width(1),
                ))
                .map_err(|e| e.to_string())?
            }
            Style::Dots => ctx
                .draw_series(
                    s.x.iter()
                        .zip(&s.y)
                        .filter(finite)
                        .map(|p| Circle::new(point(p), 1, color.filled())),
                )
                .map_err(|e| e.to_string())?,
            Style::Markers => ctx
                .draw_series(
                    s.x.iter()
                        .zip(&s.y)
                        .filter(finite)
                        .map(|p| Circle::new(point(p), 4, color.filled())),
                )
                .map_err(|e| e.to_string())?,
        };
        if !s.label.is_empty() {
            anno.label(s.label.as_str()).legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
            });
        }
    }
    if chart.series.iter().any(|s| !s.label.is_empty()) {
        ctx.configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(180, 180, 180))
            .label_font(("sans-serif", 12))
            .position(SeriesLabelPosition::UpperLeft)
            .draw()
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// Writes `<stem>.svg` and `<stem>.png` in `dir`: a heat map of `cells` (x, y, value), each
/// drawn as a rectangle of the grid's spacing in a colour from dark blue (`range.0` and below)
/// to yellow (`range.1` and above), grey where the value is not finite; a colour bar on the
/// right is labelled `label`.
pub fn write_heat_map(
    dir: &Path,
    stem: &str,
    title: &str,
    (x_label, y_label): (&str, &str),
    label: &str,
    cells: &[(f64, f64, f64)],
    range: (f64, f64),
) -> CliResult {
    register_font();
    let size = (820u32, 700u32);
    let svg = dir.join(format!("{stem}.svg"));
    let map = HeatMap {
        title,
        x_label,
        y_label,
        label,
        cells,
        range,
    };
    {
        let root = SVGBackend::new(&svg, size).into_drawing_area();
        map.draw(&root)?;
        root.present()
            .map_err(|e| format!("writing {}: {e}", svg.display()))?;
    }
    let png = dir.join(format!("{stem}.png"));
    let mut buf = vec![0u8; (size.0 * size.1 * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
        map.draw(&root)?;
        root.present()
            .map_err(|e| format!("drawing {}: {e}", png.display()))?;
    }
    write_png(&png, &buf, size)
}

struct HeatMap<'a> {
    title: &'a str,
    x_label: &'a str,
    y_label: &'a str,
    label: &'a str,
    cells: &'a [(f64, f64, f64)],
    range: (f64, f64),
}

impl HeatMap<'_> {
    /// A colour from a viridis-like ramp for s ∈ [0, 1].
    fn colour(s: f64) -> RGBColor {
        const STOPS: [(f64, [f64; 3]); 5] = [
            (0.0, [68.0, 1.0, 84.0]),
            (0.25, [59.0, 82.0, 139.0]),
            (0.5, [33.0, 145.0, 140.0]),
            (0.75, [94.0, 201.0, 98.0]),
            (1.0, [253.0, 231.0, 37.0]),
        ];
        let s = s.clamp(0.0, 1.0);
        let k = STOPS.iter().position(|&(p, _)| p >= s).unwrap_or(4).max(1);
        let ((p0, c0), (p1, c1)) = (STOPS[k - 1], STOPS[k]);
        let f = (s - p0) / (p1 - p0);
        let c = |i: usize| (c0[i] + f * (c1[i] - c0[i])).round() as u8;
        RGBColor(c(0), c(1), c(2))
    }

    fn value_colour(&self, v: f64) -> RGBColor {
        if !v.is_finite() {
            return RGBColor(170, 170, 170);
        }
        let (lo, hi) = self.range;
        Self::colour(if hi > lo { (v - lo) / (hi - lo) } else { 0.5 })
    }

    /// The grid's spacing along one axis: the smallest positive gap between distinct values.
    fn spacing(values: impl Iterator<Item = f64>) -> f64 {
        let mut v: Vec<f64> = values.collect();
        v.sort_by(f64::total_cmp);
        v.dedup();
        v.windows(2)
            .map(|w| w[1] - w[0])
            .filter(|d| *d > 0.0)
            .fold(f64::INFINITY, f64::min)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> CliResult
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let (main, bar) = root.split_horizontally(700);
        let dx = Self::spacing(self.cells.iter().map(|c| c.0));
        let dy = Self::spacing(self.cells.iter().map(|c| c.1));
        let (dx, dy) = (
            if dx.is_finite() { dx } else { 1.0 },
            if dy.is_finite() { dy } else { 1.0 },
        );
        let lo_hi = |f: fn(&(f64, f64, f64)) -> f64| {
            self.cells
                .iter()
                .map(f)
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                    (a.min(v), b.max(v))
                })
        };
        let (x0, x1) = lo_hi(|c| c.0);
        let (y0, y1) = lo_hi(|c| c.1);
        if !(x0.is_finite() && y0.is_finite()) {
            return Err("the map has no points".into());
        }
        let mut chart = ChartBuilder::on(&main)
            .caption(self.title, ("sans-serif", 17))
            .margin(12)
            .x_label_area_size(38)
            .y_label_area_size(60)
            .build_cartesian_2d(
                (x0 - dx / 2.0)..(x1 + dx / 2.0),
                (y0 - dy / 2.0)..(y1 + dy / 2.0),
            )
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(self.x_label)
            .y_desc(self.y_label)
            .label_style(("sans-serif", 13))
            .draw()
            .map_err(|e| e.to_string())?;
        chart
            .draw_series(self.cells.iter().map(|&(x, y, v)| {
                Rectangle::new(
                    [(x - dx / 2.0, y - dy / 2.0), (x + dx / 2.0, y + dy / 2.0)],
                    self.value_colour(v).filled(),
                )
            }))
            .map_err(|e| e.to_string())?;
        // the colour bar
        let (lo, hi) = self.range;
        let mut bar_chart = ChartBuilder::on(&bar)
            .margin_top(40)
            .margin_bottom(50)
            .margin_right(10)
            .y_label_area_size(50)
            .caption(self.label, ("sans-serif", 14))
            .build_cartesian_2d(0.0..1.0, lo..hi.max(lo + f64::EPSILON))
            .map_err(|e| e.to_string())?;
        bar_chart
            .configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .label_style(("sans-serif", 12))
            .draw()
            .map_err(|e| e.to_string())?;
        let steps = 100;
        bar_chart
            .draw_series((0..steps).map(|k| {
                let a = lo + (hi - lo) * k as f64 / steps as f64;
                let b = lo + (hi - lo) * (k + 1) as f64 / steps as f64;
                Rectangle::new(
                    [(0.0, a), (1.0, b)],
                    Self::colour((k as f64 + 0.5) / steps as f64).filled(),
                )
            }))
            .map_err(|e| e.to_string())?;
        Ok(())
    }
}
