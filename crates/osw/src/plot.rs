//! Line charts as PNG and SVG (plotters): one function for every plot osw writes — error
//! against frame time (`osw report`), bytes per frame (`osw bandwidth`), latency per frame
//! (`osw latency`), and log-log panels side by side (`osw scale`).

use anyhow::{Context, bail};
use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

/// One curve: points in data units, optionally a label at each point (e.g. tau).
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    pub point_labels: Vec<String>,
    /// Drawn thick and black over the others (e.g. a Pareto front).
    pub bold: bool,
}

pub struct Chart<'a> {
    pub title: &'a str,
    pub x: &'a str,
    pub y: &'a str,
    pub series: Vec<Series>,
}

/// plotters draws text with a font registered by name; DejaVu comes with Debian
/// (fonts-dejavu-core, installed by scripts/setup.sh). `OSW_FONT` names another file (the GPU
/// bundle brings its own).
const FONTS: [&str; 3] =
    ["/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf", "/usr/share/fonts/dejavu/DejaVuSans.ttf", "/usr/share/fonts/TTF/DejaVuSans.ttf"];

fn register_font() -> anyhow::Result<()> {
    static DONE: OnceLock<Result<(), String>> = OnceLock::new();
    DONE.get_or_init(|| {
        let given = std::env::var("OSW_FONT").ok();
        let path = given
            .as_deref()
            .or_else(|| FONTS.into_iter().find(|p| Path::new(p).exists()))
            .ok_or("no DejaVuSans.ttf found: apt-get install fonts-dejavu-core, or set OSW_FONT")?;
        let bytes = std::fs::read(path).map_err(|e| format!("{path}: {e}"))?;
        plotters::style::register_font("sans-serif", FontStyle::Normal, Box::leak(bytes.into_boxed_slice()))
            .map_err(|_| format!("{path}: not a font plotters can read"))
    })
    .clone()
    .map_err(anyhow::Error::msg)
}

/// Which axes are logarithmic.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Axes {
    Linear,
    /// Times that span decades (the modes of a report) on x.
    LogX,
    LogLog,
}

/// Writes the chart to `stem.png` and `stem.svg`.
pub fn write(chart: &Chart, stem: &Path) -> anyhow::Result<()> {
    write_panels(std::slice::from_ref(chart), Axes::Linear, stem)
}

/// Writes the chart with a logarithmic x axis to `stem.png` and `stem.svg`.
pub fn write_log_x(chart: &Chart, stem: &Path) -> anyhow::Result<()> {
    write_panels(std::slice::from_ref(chart), Axes::LogX, stem)
}

/// Writes the charts side by side, both axes logarithmic, to `stem.png` and `stem.svg`.
pub fn write_log_log(charts: &[Chart], stem: &Path) -> anyhow::Result<()> {
    write_panels(charts, Axes::LogLog, stem)
}

fn write_panels(charts: &[Chart], log: Axes, stem: &Path) -> anyhow::Result<()> {
    register_font()?;
    let (png, svg) = (stem.with_extension("png"), stem.with_extension("svg"));
    let size = (1000 * charts.len() as u32, 650);
    draw_all(BitMapBackend::new(&png, size).into_drawing_area(), charts, log).with_context(|| format!("drawing {}", png.display()))?;
    draw_all(SVGBackend::new(&svg, size).into_drawing_area(), charts, log).with_context(|| format!("drawing {}", svg.display()))?;
    Ok(())
}

fn draw_all<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, charts: &[Chart], log: Axes) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow::anyhow!("{e:?}");
    root.fill(&WHITE).map_err(err)?;
    for (area, c) in root.split_evenly((1, charts.len())).iter().zip(charts) {
        if c.series.iter().all(|s| s.points.is_empty()) {
            bail!("{}: nothing to plot", c.title);
        }
        let xs = c.series.iter().flat_map(|s| s.points.iter().map(|p| p.0));
        let ys = c.series.iter().flat_map(|s| s.points.iter().map(|p| p.1));
        match log {
            Axes::Linear => draw(area, c, range(xs), range(ys))?,
            Axes::LogX => draw(area, c, log_range(xs).log_scale(), range(ys))?,
            Axes::LogLog => draw(area, c, log_range(xs).log_scale(), log_range(ys).log_scale())?,
        }
    }
    root.present().map_err(err)?;
    Ok(())
}

/// Data bounds with a margin; a flat or empty range gets a unit width.
fn range(v: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = v.filter(|x| x.is_finite()).fold((f64::MAX, f64::MIN), |(l, h), x| (l.min(x), h.max(x)));
    if lo > hi {
        return 0.0..1.0;
    }
    let pad = if hi > lo { (hi - lo) * 0.05 } else { 0.5 };
    (lo.min(0.0).max(lo - pad))..(hi + pad)
}

/// An axis label: 1.5K, 20M, 1B for large values, else up to three significant digits.
fn compact(v: f64) -> String {
    let (scaled, unit) = match v.abs() {
        a if a >= 1e9 => (v / 1e9, "B"),
        a if a >= 1e6 => (v / 1e6, "M"),
        a if a >= 1e4 => (v / 1e3, "K"),
        _ => (v, ""),
    };
    let digits = if scaled.abs() >= 100.0 || scaled == scaled.round() {
        0
    } else if scaled.abs() >= 10.0 {
        1
    } else {
        2
    };
    format!("{scaled:.digits$}{unit}")
}

/// Positive data bounds with a margin of a fifth of a decade each side.
fn log_range(v: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = v.filter(|x| x.is_finite() && *x > 0.0).fold((f64::MAX, f64::MIN), |(l, h), x| (l.min(x), h.max(x)));
    if lo > hi { 1.0..10.0 } else { lo / 1.6..hi * 1.6 }
}

fn draw<DB: DrawingBackend, X: AsRangedCoord<Value = f64>, Y: AsRangedCoord<Value = f64>>(
    root: &DrawingArea<DB, Shift>,
    c: &Chart,
    xs: X,
    ys: Y,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
    X::CoordDescType: ValueFormatter<f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow::anyhow!("{e:?}");
    let mut chart = ChartBuilder::on(root)
        .caption(c.title, ("sans-serif", 24))
        .margin(20)
        .x_label_area_size(50)
        .y_label_area_size(80)
        .build_cartesian_2d(xs, ys)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc(c.x)
        .y_desc(c.y)
        .x_label_formatter(&|v| compact(*v))
        .y_label_formatter(&|v| compact(*v))
        .label_style(("sans-serif", 15))
        .draw()
        .map_err(err)?;
    // A series keeps its colour by its place in the list, also when another panel of the
    // same figure has nothing to show for it.
    for (i, s) in c.series.iter().enumerate().filter(|(_, s)| !s.points.is_empty()) {
        let (color, width) = if s.bold { (BLACK.to_rgba(), 4) } else { (Palette99::pick(i).to_rgba(), 2) };
        chart
            .draw_series(LineSeries::new(s.points.iter().copied(), color.stroke_width(width)))
            .map_err(err)?
            .label(&s.name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(width)));
        if !s.point_labels.is_empty() {
            // Each series' labels at their own height, above or below its points, so that
            // series whose points lie close (prev and the switch) do not print theirs over
            // each other.
            let above = [-16, 6, -30, 20][i % 4];
            chart
                .draw_series(s.points.iter().zip(&s.point_labels).map(|(&p, l)| {
                    EmptyElement::at(p) + Circle::new((0, 0), 4, color.filled()) + Text::new(l.clone(), (6, above), ("sans-serif", 14))
                }))
                .map_err(err)?;
        }
    }
    chart
        .configure_series_labels()
        .label_font(("sans-serif", 16))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(err)?;
    Ok(())
}
