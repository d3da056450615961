//! Line charts as 8-bit RGB PNGs of [`SIZE`]: series of `(x, y)` points, joined by lines, marked,
//! or both, on linear or log axes whose ranges are fixed or follow the data. Drawn with
//! `plotters` into a buffer and encoded with `png`.
//!
//! Text (title, tick labels, axis titles, point labels, legend) needs a TrueType font, and no
//! font ships with the tool: [`Chart::write_png`] uses the file named by `$STBN_PLOT_FONT`, else
//! the first of [`FONT_PATHS`] that loads, and draws the chart without any text when none does
//! (the documents that show a chart state its axes and colours either way). Log axes plot
//! `log₁₀` of the value.
//!
//! A series whose curve lies on an earlier one's ([`COINCIDENT`]) would hide it. It is drawn
//! dashed instead, the dashes of each such series at its own phase, so the colours alternate
//! along the shared curve; its legend entry and the caption name the series it lies on.

use std::fs;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::prelude::*;
use plotters::style::register_font;
use plotters::style::text_anchor::{HPos, Pos, VPos};

pub use plotters::chart::SeriesLabelPosition;

use super::table::significant;
use crate::Result;

/// Chart size in pixels.
const SIZE: (u32, u32) = (720, 440);

/// Blank pixels around the plot area (and the title and labels when there is text).
const MARGIN: u32 = 12;

/// Two series coincide when they have the same number of plotted points and every pair of
/// points is within this fraction of the plotted range on both axes (about 3 pixels).
const COINCIDENT: f64 = 0.004;

/// Length in pixels of one dash of a coincident series.
const DASH: f64 = 10.0;

/// Series colours with their names for captions; series `i` uses entry `i % len`. Sixteen, so
/// that a chart of five masks read three ways names each series by a colour of its own.
const PALETTE: [(&str, RGBColor); 16] = [
    ("blue", RGBColor(31, 119, 180)),
    ("orange", RGBColor(255, 127, 14)),
    ("green", RGBColor(44, 160, 44)),
    ("red", RGBColor(214, 39, 40)),
    ("purple", RGBColor(148, 103, 189)),
    ("brown", RGBColor(140, 86, 75)),
    ("pink", RGBColor(227, 119, 194)),
    ("grey", RGBColor(127, 127, 127)),
    ("olive", RGBColor(188, 189, 34)),
    ("cyan", RGBColor(23, 190, 207)),
    ("navy", RGBColor(31, 31, 122)),
    ("teal", RGBColor(0, 128, 128)),
    ("maroon", RGBColor(128, 0, 0)),
    ("magenta", RGBColor(204, 0, 204)),
    ("gold", RGBColor(204, 163, 0)),
    ("slate", RGBColor(112, 128, 144)),
];

/// The name of the colour series `series` is drawn in (`blue`, `orange`, …).
pub fn colour_name(series: usize) -> &'static str {
    PALETTE[series % PALETTE.len()].0
}

/// Fonts tried for the charts' text after `$STBN_PLOT_FONT`: DejaVu Sans and Liberation Sans
/// where Linux distributions install them, then Arial on macOS and Windows.
const FONT_PATHS: [&str; 6] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu-sans-fonts/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/System/Library/Fonts/Supplemental/Arial.ttf",
    "C:\\Windows\\Fonts\\arial.ttf",
];

/// Whether a font for the charts' text is registered (tried once per process; see the module
/// docs). The font's bytes stay loaded for the life of the process.
fn font_available() -> bool {
    static AVAILABLE: OnceLock<bool> = OnceLock::new();
    *AVAILABLE.get_or_init(|| {
        let chosen = std::env::var_os("STBN_PLOT_FONT").map(PathBuf::from);
        chosen
            .into_iter()
            .chain(FONT_PATHS.iter().map(PathBuf::from))
            .filter_map(|path| fs::read(path).ok())
            .any(|bytes| {
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                register_font("sans-serif", FontStyle::Normal, bytes).is_ok()
            })
    })
}

/// One axis: its title (with units), linear or logarithmic, and either a fixed range with its
/// grid lines or a range that follows the data.
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    /// What it measures, with units (drawn when a font is available).
    title: String,
    /// Plot `log₁₀` of the values.
    log: bool,
    /// `((low, high), grid lines)` in data units; `None`: both follow the data.
    fixed: Option<((f64, f64), Vec<f64>)>,
}

impl Axis {
    /// A linear axis over the data, padded by 5%, with grid lines at a round step.
    pub fn linear(title: &str) -> Axis {
        Axis {
            title: title.to_owned(),
            log: false,
            fixed: None,
        }
    }

    /// A log axis over the whole decades the data reaches, with grid lines at 1, 2, 5 × 10ᵏ.
    /// Values `≤ 0` cannot sit on it and are left out.
    pub fn log(title: &str) -> Axis {
        Axis {
            title: title.to_owned(),
            log: true,
            fixed: None,
        }
    }

    /// A linear axis from `low` to `high` (`low < high`) with a grid line every `step`; values
    /// outside are drawn at its edge.
    pub fn linear_range(title: &str, low: f64, high: f64, step: f64) -> Axis {
        let lines = ((high - low) / step).round() as usize;
        let grid = (0..=lines).map(|i| low + i as f64 * step).collect();
        Axis {
            fixed: Some(((low, high), grid)),
            ..Axis::linear(title)
        }
    }

    /// A log axis over the decades `10^low ..= 10^high` with grid lines at 1, 2 and 5 × 10ᵏ;
    /// values outside (and values `≤ 0`) are drawn at its edge.
    pub fn log_decades(title: &str, low: i32, high: i32) -> Axis {
        let top = 10f64.powi(high);
        let grid = (low..=high)
            .flat_map(|k| [1.0, 2.0, 5.0].map(|m| m * 10f64.powi(k)))
            .filter(|&v| v <= top)
            .collect();
        Axis {
            fixed: Some(((10f64.powi(low), top), grid)),
            ..Axis::log(title)
        }
    }

    /// The plotted coordinate of the value `v`: `log₁₀ v` on a log axis, `v` on a linear one.
    fn coordinate(&self, v: f64) -> f64 {
        if self.log { v.log10() } else { v }
    }

    /// The plotted coordinate of the data value `v`, `None` if the axis leaves it out: a fixed
    /// axis clamps to its range (`NaN` to its low end), one following the data leaves out what
    /// it cannot show (non-finite values, values `≤ 0` on a log axis).
    fn map(&self, v: f64) -> Option<f64> {
        match &self.fixed {
            Some(((low, high), _)) => {
                let (low, high) = (self.coordinate(*low), self.coordinate(*high));
                let v = self.coordinate(v);
                Some(if v.is_nan() { low } else { v.clamp(low, high) })
            }
            None if !v.is_finite() || (self.log && v <= 0.0) => None,
            None => Some(self.coordinate(v)),
        }
    }

    /// The plotted range given the plotted coordinates of the data, `mapped`, and the grid lines
    /// in data units: a fixed axis's own; a log axis following the data spans whole decades with
    /// lines at 1, 2, 5 × 10ᵏ, a linear one pads the data by 5% and puts lines at a round step.
    fn layout(&self, mapped: &[f64]) -> ((f64, f64), Vec<f64>) {
        if let Some(((low, high), grid)) = &self.fixed {
            return (
                (self.coordinate(*low), self.coordinate(*high)),
                grid.clone(),
            );
        }
        let low = mapped.iter().copied().fold(f64::INFINITY, f64::min);
        let high = mapped.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let (low, high) = if low.is_finite() {
            (low, high)
        } else {
            (0.0, 1.0)
        };
        if self.log {
            let (a, b) = (low.floor(), high.ceil().max(low.floor() + 1.0));
            let grid = (a as i32..=b as i32)
                .flat_map(|k| [1.0, 2.0, 5.0].map(|m| m * 10f64.powi(k)))
                .filter(|v| v.log10() <= b + 1e-9)
                .collect();
            ((a, b), grid)
        } else {
            let span = if high > low {
                high - low
            } else {
                low.abs().max(1.0)
            };
            let (low, high) = (low - 0.05 * span, high + 0.05 * span);
            let step = nice_step((high - low) / 6.0);
            let first = (low / step).ceil() as i64;
            let last = (high / step).floor() as i64;
            let grid = (first..=last).map(|i| i as f64 * step).collect();
            ((low, high), grid)
        }
    }

    /// Whether the grid line at `v` gets a tick label: every line of a linear axis, the decades
    /// of a log one.
    fn labelled(&self, v: f64) -> bool {
        !self.log || (v.log10() - v.log10().round()).abs() < 1e-9
    }

    /// The tick label of the grid line at `v`: a decade of a log axis with one significant
    /// digit (`0.01`, `1e6`), a linear axis's value without trailing zeros.
    fn tick(&self, v: f64) -> String {
        if self.log {
            significant(10f64.powf(v.log10().round()), 1)
        } else {
            let text = significant(v, 6);
            let (mantissa, exponent) = text.split_at(text.find('e').unwrap_or(text.len()));
            let mantissa = if mantissa.contains('.') {
                mantissa.trim_end_matches('0').trim_end_matches('.')
            } else {
                mantissa
            };
            format!("{mantissa}{exponent}")
        }
    }

    /// `log scale` or `linear`, for captions.
    fn scale(&self) -> &'static str {
        if self.log { "log scale" } else { "linear" }
    }
}

/// The smallest of 1, 2, 5 × 10ᵏ at least `rough`.
fn nice_step(rough: f64) -> f64 {
    let k = rough.log10().floor();
    let base = 10f64.powf(k);
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * base)
        .find(|&s| s >= rough)
        .unwrap_or(10.0 * base)
}

/// How a series is drawn.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Style {
    /// Points joined in order by a line, no markers (dense curves).
    Line,
    /// Points marked and joined in order by a line.
    #[default]
    LineAndPoints,
    /// Points marked only.
    Points,
}

/// One series: its points, with optional per-point labels.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Series {
    /// For the legend and the caption.
    pub name: String,
    /// `(x, y)` in data units.
    pub points: Vec<(f64, f64)>,
    /// Empty, or one label per point, drawn beside it (empty labels are not drawn).
    pub labels: Vec<String>,
    /// How it is drawn.
    pub style: Style,
}

/// A chart: axes, series `i` in colour [`colour_name`]`(i)`, and an optional black horizontal
/// reference line.
#[derive(Clone, Debug, PartialEq)]
pub struct Chart {
    /// Drawn above the plot.
    pub title: String,
    /// Horizontal axis.
    pub x: Axis,
    /// Vertical axis.
    pub y: Axis,
    /// The series, drawn in order. Empty series draw nothing and have no legend entry, but keep
    /// their place in the palette.
    pub series: Vec<Series>,
    /// Where the legend goes (a corner the data leaves free).
    pub legend: SeriesLabelPosition,
    /// `y` of the reference line (e.g. white noise at power 1), in data units.
    pub reference: Option<f64>,
}

impl Chart {
    /// A caption for the chart: title, axes and colours.
    pub fn caption(&self) -> String {
        let lies_on = self.coincident();
        let colours: Vec<String> = self
            .series
            .iter()
            .enumerate()
            .map(|(i, s)| match lies_on[i] {
                Some(j) => format!(
                    "{} = {} (same curve as {}: drawn dashed over it)",
                    colour_name(i),
                    s.name,
                    colour_name(j)
                ),
                None => format!("{} = {}", colour_name(i), s.name),
            })
            .collect();
        let drops = |a: &Axis| a.log && a.fixed.is_none();
        let note = if drops(&self.x) || drops(&self.y) {
            " Values ≤ 0 (e.g. an exact encoding's zero error) cannot sit on a log axis and are \
             left out."
        } else {
            ""
        };
        format!(
            "**{}.** x: {} ({}); y: {} ({}); {}.{note}",
            self.title,
            self.x.title,
            self.x.scale(),
            self.y.title,
            self.y.scale(),
            colours.join(", ")
        )
    }

    /// For each series, the first earlier series whose curve it lies on ([`COINCIDENT`]), if
    /// any. Empty series lie on none.
    pub fn coincident(&self) -> Vec<Option<usize>> {
        let plotted = Plotted::of(self);
        let span = |(low, high): (f64, f64)| (high - low).abs().max(f64::MIN_POSITIVE);
        let (sx, sy) = (span(plotted.x.0), span(plotted.y.0));
        let same = |a: &Mapped, b: &Mapped| {
            !a.is_empty()
                && a.len() == b.len()
                && a.iter().zip(b).all(|(p, q)| {
                    (p.0 - q.0).abs() <= COINCIDENT * sx && (p.1 - q.1).abs() <= COINCIDENT * sy
                })
        };
        let mut lies_on: Vec<Option<usize>> = Vec::with_capacity(self.series.len());
        for (i, points) in plotted.mapped.iter().enumerate() {
            let first = (0..i)
                .find(|&j| same(points, &plotted.mapped[j]))
                .map(|j| lies_on[j].unwrap_or(j));
            lies_on.push(first);
        }
        lies_on
    }

    /// Draws the chart (with text if a font is available) and writes it to `path` as an RGB PNG
    /// of [`SIZE`].
    pub fn write_png(&self, path: &Path) -> Result<()> {
        let pixels = render(self, font_available())
            .map_err(|e| format!("cannot draw {}: {e}", path.display()))?;
        let size = (SIZE.0 as usize, SIZE.1 as usize);
        super::write_png(path, size, png::ColorType::Rgb, &pixels)
    }
}

/// A series' points in plotted coordinates, each with its label.
type Mapped<'a> = Vec<(f64, f64, Option<&'a str>)>;

/// A chart's series in plotted coordinates and its axes' plotted ranges and grid lines.
struct Plotted<'a> {
    mapped: Vec<Mapped<'a>>,
    x: ((f64, f64), Vec<f64>),
    y: ((f64, f64), Vec<f64>),
}

impl Plotted<'_> {
    fn of(chart: &Chart) -> Plotted<'_> {
        let mapped: Vec<Mapped> = chart
            .series
            .iter()
            .map(|s| {
                let labels = s
                    .labels
                    .iter()
                    .map(|l| Some(l.as_str()))
                    .chain(std::iter::repeat(None));
                let points = s.points.iter().zip(labels);
                let mapped = points
                    .filter_map(|(&(x, y), label)| Some((chart.x.map(x)?, chart.y.map(y)?, label)));
                mapped.collect()
            })
            .collect();
        let xs: Vec<f64> = mapped.iter().flatten().map(|p| p.0).collect();
        let ys: Vec<f64> = mapped.iter().flatten().map(|p| p.1).collect();
        Plotted {
            x: chart.x.layout(&xs),
            y: chart.y.layout(&ys),
            mapped,
        }
    }
}

/// The pieces of the polyline `points` (pixels) where the distance along it, modulo `period`,
/// is in `from..to`: the dashes of one phase.
fn dashes(points: &[(i32, i32)], period: f64, from: f64, to: f64) -> Vec<[(i32, i32); 2]> {
    let mut pieces = Vec::new();
    let mut travelled = 0.0;
    for pair in points.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        let (dx, dy) = (f64::from(b.0 - a.0), f64::from(b.1 - a.1));
        let length = dx.hypot(dy);
        let at = |s: f64| {
            let t = if length > 0.0 {
                (s - travelled) / length
            } else {
                0.0
            };
            (
                (f64::from(a.0) + t * dx).round() as i32,
                (f64::from(a.1) + t * dy).round() as i32,
            )
        };
        let end = travelled + length;
        let mut start = (travelled / period).floor() * period + from;
        while start < end {
            let (lo, hi) = (start.max(travelled), (start + to - from).min(end));
            if hi > lo {
                pieces.push([at(lo), at(hi)]);
            }
            start += period;
        }
        travelled = end;
    }
    pieces
}

/// The RGB pixels of `chart`, row-major; `text` draws the title, tick labels, axis titles, point
/// labels and legend (it needs a registered font).
fn render(chart: &Chart, text: bool) -> std::result::Result<Vec<u8>, Box<dyn std::error::Error>> {
    let Plotted {
        mapped,
        x: ((x0, x1), x_grid),
        y: ((y0, y1), y_grid),
    } = Plotted::of(chart);
    let lies_on = chart.coincident();
    let mut pixels = vec![0u8; SIZE.0 as usize * SIZE.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, SIZE).into_drawing_area();
        root.fill(&WHITE)?;
        let mut builder = ChartBuilder::on(&root);
        builder.margin(MARGIN);
        if text {
            builder
                .caption(&chart.title, ("sans-serif", 18))
                .x_label_area_size(44)
                .y_label_area_size(70);
        }
        let mut plot = builder.build_cartesian_2d(x0..x1, y0..y1)?;
        let grey = RGBColor(220, 220, 220);
        for &x in &x_grid {
            let x = chart.x.coordinate(x);
            plot.draw_series(LineSeries::new([(x, y0), (x, y1)], grey))?;
        }
        for &y in &y_grid {
            let y = chart.y.coordinate(y);
            plot.draw_series(LineSeries::new([(x0, y), (x1, y)], grey))?;
        }
        // The frame.
        let corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)];
        plot.draw_series(LineSeries::new(corners, BLACK))?;
        if let Some(y) = chart.reference.and_then(|y| chart.y.map(y)) {
            plot.draw_series(LineSeries::new([(x0, y), (x1, y)], BLACK.stroke_width(2)))?;
        }
        for (i, (series, points)) in chart.series.iter().zip(&mapped).enumerate() {
            let colour = PALETTE[i % PALETTE.len()].1;
            let line = points.iter().map(|p| (p.0, p.1));
            // A marked-only series draws a line through its first point alone: nothing to see,
            // but the legend entry hangs on it. So does a series drawn dashed over the curve it
            // lies on.
            let dashed = lies_on[i].filter(|_| series.style != Style::Points);
            let line: Vec<(f64, f64)> = if series.style == Style::Points || dashed.is_some() {
                line.take(1).collect()
            } else {
                line.collect()
            };
            // The group: the first series (solid) and every series lying on it, in order; this
            // one's dashes take its own share of each period.
            let pieces = match dashed {
                Some(first) => {
                    let group: Vec<usize> = (0..chart.series.len())
                        .filter(|&k| k == first || lies_on[k] == Some(first))
                        .collect();
                    let rank = group.iter().position(|&k| k == i).expect("in its group") as f64;
                    let pixels: Vec<(i32, i32)> = points
                        .iter()
                        .map(|p| plot.backend_coord(&(p.0, p.1)))
                        .collect();
                    let period = DASH * group.len() as f64;
                    dashes(&pixels, period, rank * DASH, (rank + 1.0) * DASH)
                }
                None => Vec::new(),
            };
            for piece in pieces {
                root.draw(&PathElement::new(piece, colour.stroke_width(2)))?;
            }
            let drawn = plot.draw_series(LineSeries::new(line, colour.stroke_width(2)))?;
            // An empty series keeps its colour (the same mask has the same colour in every
            // plot) but gets no legend entry: the legend names only what is drawn.
            if text && !points.is_empty() {
                let label = match lies_on[i] {
                    Some(j) => format!("{} (= {})", series.name, chart.series[j].name),
                    None => series.name.clone(),
                };
                drawn.label(label).legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 16, y)], colour.stroke_width(2))
                });
            }
            if series.style != Style::Line {
                let markers = points
                    .iter()
                    .map(|p| Circle::new((p.0, p.1), 3, colour.filled()));
                plot.draw_series(markers)?;
            }
        }
        if text {
            let font = ("sans-serif", 13).into_font().color(&BLACK);
            let small = ("sans-serif", 11).into_font().color(&RGBColor(60, 60, 60));
            for (x, y, label) in mapped.iter().flatten() {
                if let Some(label) = label.filter(|l| !l.is_empty()) {
                    let (px, py) = plot.backend_coord(&(*x, *y));
                    let style = small.pos(Pos::new(HPos::Left, VPos::Bottom));
                    root.draw(&Text::new(label, (px + 4, py - 3), style))?;
                }
            }
            for &x in x_grid.iter().filter(|&&x| chart.x.labelled(x)) {
                let (px, py) = plot.backend_coord(&(chart.x.coordinate(x), y0));
                let style = font.pos(Pos::new(HPos::Center, VPos::Top));
                let tick = chart.x.tick(x);
                // A label centred on a line at the right edge would run past the image: it
                // moves left just enough to fit, so the last decade stays readable.
                let (width, _) = root.estimate_text_size(&tick, &style)?;
                let px = px.min(SIZE.0 as i32 - 3 - (width as i32 + 1) / 2);
                root.draw(&Text::new(tick, (px, py + 6), style))?;
            }
            for &y in y_grid.iter().filter(|&&y| chart.y.labelled(y)) {
                let (px, py) = plot.backend_coord(&(x0, chart.y.coordinate(y)));
                let style = font.pos(Pos::new(HPos::Right, VPos::Center));
                root.draw(&Text::new(chart.y.tick(y), (px - 6, py), style))?;
            }
            // Axis titles: x centred below the tick labels, y rotated at the left edge.
            let (left, bottom) = plot.backend_coord(&(x0, y0));
            let (right, top) = plot.backend_coord(&(x1, y1));
            let below = font.pos(Pos::new(HPos::Center, VPos::Top));
            let x_title = ((left + right) / 2, bottom + 24);
            root.draw(&Text::new(chart.x.title.as_str(), x_title, below))?;
            let rotated = font
                .transform(FontTransform::Rotate270)
                .pos(Pos::new(HPos::Center, VPos::Top));
            let y_title = (10, (top + bottom) / 2);
            root.draw(&Text::new(chart.y.title.as_str(), y_title, rotated))?;
            plot.configure_series_labels()
                .position(chart.legend.clone())
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(("sans-serif", 12))
                .draw()?;
        }
        root.present()?;
    }
    Ok(pixels)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pixel(pixels: &[u8], x: u32, y: u32) -> [u8; 3] {
        let i = (y * SIZE.0 + x) as usize * 3;
        [pixels[i], pixels[i + 1], pixels[i + 2]]
    }

    /// The pixels of series `i`'s colour.
    fn count(pixels: &[u8], i: usize) -> usize {
        let c = PALETTE[i].1;
        pixels
            .chunks_exact(3)
            .filter(|p| *p == [c.0, c.1, c.2])
            .count()
    }

    /// An empty series and a flat line at 0.25, with a reference line at 0.75, on fixed axes.
    fn flat_chart() -> Chart {
        let line = |name: &str, points| Series {
            name: name.to_owned(),
            points,
            style: Style::Line,
            ..Series::default()
        };
        Chart {
            title: "Flat".to_owned(),
            x: Axis::linear_range("x", 0.0, 1.0, 0.5),
            y: Axis::linear_range("y", 0.0, 1.0, 0.5),
            series: vec![
                line("empty", vec![]),
                line("flat", vec![(0.0, 0.25), (1.0, 0.25)]),
            ],
            legend: SeriesLabelPosition::UpperRight,
            reference: Some(0.75),
        }
    }

    /// Three series on axes following the data: marked points joined by lines (one at y = 0),
    /// marked points only, and an empty one.
    fn marked_chart(log: bool) -> Chart {
        Chart {
            title: "t".to_owned(),
            x: Axis::log("x"),
            y: if log {
                Axis::log("y")
            } else {
                Axis::linear("y")
            },
            series: vec![
                Series {
                    name: "a".to_owned(),
                    points: vec![(1.0, 0.5), (10.0, 0.25), (100.0, 0.0)],
                    labels: vec!["p".to_owned(), "q".to_owned(), "r".to_owned()],
                    style: Style::LineAndPoints,
                },
                Series {
                    name: "b".to_owned(),
                    points: vec![(2.0, 0.3), (50.0, 0.1)],
                    labels: Vec::new(),
                    style: Style::Points,
                },
                Series::default(),
            ],
            legend: SeriesLabelPosition::UpperRight,
            reference: None,
        }
    }

    #[test]
    fn text_goes_around_the_plot_only_when_asked() {
        let dark = |pixels: &[u8], rows: std::ops::Range<u32>| {
            rows.flat_map(|y| (0..SIZE.0).map(move |x| (x, y)))
                .any(|(x, y)| pixel(pixels, x, y).iter().all(|&c| c < 100))
        };
        // Without text the top margin stays white; the title would go there.
        let plain = render(&flat_chart(), false).unwrap();
        assert!(!dark(&plain, 0..MARGIN - 2));
        if !font_available() {
            eprintln!("no font found (set STBN_PLOT_FONT): the labelled rendering is untested");
            return;
        }
        let labelled = render(&flat_chart(), true).unwrap();
        assert!(dark(&labelled, 0..30), "no title");
        assert!(
            dark(&labelled, SIZE.1 - 40..SIZE.1 - MARGIN),
            "no tick labels or axis title"
        );
    }

    #[test]
    fn the_last_x_tick_label_fits_in_the_image() {
        if !font_available() {
            eprintln!("no font found (set STBN_PLOT_FONT): tick label placement is untested");
            return;
        }
        // The x axis ends on a labelled decade (1000) at the plot's right edge, MARGIN pixels
        // from the image's: centred there, its label would run past the image.
        let mut chart = marked_chart(true);
        chart.series[0].points = vec![(1.0, 0.5), (1000.0, 0.25)];
        chart.series[0].labels.clear();
        let pixels = render(&chart, true).unwrap();
        // The tick labels sit in the 44 pixels below the plot.
        let bottom = SIZE.1 - MARGIN - 44;
        let dark = |x: u32| {
            (bottom + 2..bottom + 24).any(|y| pixel(&pixels, x, y).iter().all(|&c| c < 128))
        };
        assert!(
            !dark(SIZE.0 - 1) && !dark(SIZE.0 - 2),
            "a label reaches the image's edge"
        );
        assert!(
            (SIZE.0 - 40..SIZE.0 - 2).any(dark),
            "no label under the last decade"
        );
    }

    #[test]
    fn axes_map_and_clamp() {
        let log = Axis::log_decades("", -3, -1);
        let grid = log.layout(&[]).1;
        assert_eq!(grid.len(), 7); // 1, 2, 5 × 10⁻³, 10⁻²; 10⁻¹
        assert_eq!(grid.iter().filter(|&&v| log.labelled(v)).count(), 3);
        let quarters = Axis::linear_range("", 0.0, 1.0, 0.25);
        let grid = quarters.layout(&[]).1;
        assert_eq!(grid.iter().filter(|&&v| quarters.labelled(v)).count(), 5);
        assert!((log.map(0.01).unwrap() + 2.0).abs() < 1e-12);
        assert_eq!(log.map(0.0), Some(-3.0)); // log₁₀ 0 = −∞, clamped
        assert_eq!(log.map(5.0), Some(-1.0));
        let linear = Axis::linear_range("", 0.0, 0.5, 0.125);
        assert_eq!(
            linear.layout(&[5.0]),
            ((0.0, 0.5), vec![0.0, 0.125, 0.25, 0.375, 0.5])
        );
        assert_eq!(linear.map(f64::NAN), Some(0.0));
    }

    #[test]
    fn log_axes_span_decades_and_drop_non_positive_values() {
        let axis = Axis::log("x");
        assert_eq!(axis.map(0.0), None);
        let ((a, b), grid) = axis.layout(&[0.3f64.log10(), 20f64.log10()]);
        assert_eq!((a, b), (-1.0, 2.0));
        assert_eq!(grid.first(), Some(&0.1));
        assert!((grid.last().unwrap() - 100.0).abs() < 1e-9);
        let ((low, high), grid) = Axis::linear("y").layout(&[0.0, 1.0]);
        assert!(low < 0.0 && high > 1.0);
        assert_eq!(grid, vec![0.0, 0.2, 0.4, 0.6000000000000001, 0.8, 1.0]);
        assert_eq!(nice_step(0.13), 0.2);
    }

    #[test]
    fn ticks_name_decades_and_drop_trailing_zeros() {
        let linear = Axis::linear("");
        assert_eq!(linear.tick(0.6000000000000001), "0.6");
        assert_eq!(linear.tick(0.1875), "0.1875");
        assert_eq!(linear.tick(16.0), "16");
        assert_eq!(linear.tick(0.0), "0");
        assert_eq!(linear.tick(2.5e-5), "2.5e-5");
        let log = Axis::log("");
        assert_eq!(log.tick(0.001), "0.001");
        assert_eq!(log.tick(1e7), "1e7");
    }

    #[test]
    fn a_horizontal_series_is_drawn_in_its_colour_at_its_height() {
        let pixels = render(&flat_chart(), false).unwrap();
        // Without text the plot area spans the image but for the margins.
        let (top, bottom) = (MARGIN as f64, (SIZE.1 - MARGIN) as f64);
        let row = |v: f64| (bottom - v * (bottom - top)).round() as u32;
        let column = SIZE.0 / 3;
        // Series 1 (series 0 is empty) uses the second palette colour.
        let orange = PALETTE[1].1;
        let found = (row(0.25) - 2..=row(0.25) + 2)
            .any(|y| pixel(&pixels, column, y) == [orange.0, orange.1, orange.2]);
        assert!(found, "no orange near row {}", row(0.25));
        let black = (row(0.75) - 2..=row(0.75) + 2).any(|y| pixel(&pixels, column, y) == [0, 0, 0]);
        assert!(black);
        assert_eq!(pixel(&pixels, column, row(0.5) + 20), [255, 255, 255]);
    }

    #[test]
    fn identical_curves_stay_visible_and_are_named() {
        let curve: Vec<(f64, f64)> = (0..50).map(|k| (k as f64 / 49.0, 0.5)).collect();
        let line = |name: &str, points: Vec<(f64, f64)>| Series {
            name: name.to_owned(),
            points,
            style: Style::Line,
            ..Series::default()
        };
        let mut chart = flat_chart();
        chart.series = vec![
            line("a", curve.clone()),
            line("b", curve.clone()),
            line("c", curve.iter().map(|&(x, y)| (x, y + 0.001)).collect()),
            line("d", curve.iter().map(|&(x, y)| (x, y - 0.3)).collect()),
        ];
        assert_eq!(chart.coincident(), vec![None, Some(0), Some(0), None]);
        let pixels = render(&chart, false).unwrap();
        // The three coincident series share the curve: each keeps about a third of it (a
        // drawn-over series would keep none); the fourth is apart and whole.
        let (a, b, c, d) = (
            count(&pixels, 0),
            count(&pixels, 1),
            count(&pixels, 2),
            count(&pixels, 3),
        );
        assert!(a > d / 5 && b > d / 5 && c > d / 5, "{a} {b} {c} {d}");
        let caption = chart.caption();
        assert!(
            caption.contains("orange = b (same curve as blue: drawn dashed over it)"),
            "{caption}"
        );
        assert!(caption.contains("red = d."), "{caption}");
    }

    #[test]
    fn draws_points_in_the_series_colour_with_or_without_text() {
        for text in [false, font_available()] {
            let pixels = render(&marked_chart(true), text).unwrap();
            // A line through two points and its markers: hundreds of pixels.
            assert!(count(&pixels, 0) > 200, "{}", count(&pixels, 0));
            // Two markers of radius 3 and no line between them (a line would add ~580 pixels; the
            // legend adds a short sample line when text is on).
            let scatter = count(&pixels, 1);
            assert!(scatter > 20 && scatter < 200, "{scatter}");
        }
        // A linear y axis keeps the point at 0.
        assert!(render(&marked_chart(false), false).is_ok());
        let caption = marked_chart(true).caption();
        assert!(
            caption.contains("x: x (log scale); y: y (log scale); blue = a, orange = b, green = ."),
            "{caption}"
        );
        assert!(caption.contains("Values ≤ 0"), "{caption}");
        assert!(!flat_chart().caption().contains("Values ≤ 0"));
    }
}
