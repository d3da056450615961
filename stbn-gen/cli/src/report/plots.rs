//! Line plots of the report's curves as 8-bit RGB PNGs, drawn with `plotters` into a buffer and
//! encoded with `png`.
//!
//! Text (title, tick labels, axis titles, legend) needs a TrueType font, and no font ships with
//! the tool: [`write()`] uses the file named by `$STBN_PLOT_FONT`, else the first of
//! [`FONT_PATHS`] that loads, and draws the plot without any text when none does (report.md
//! states every plot's axes, ranges, grid lines and colours either way). Log axes plot `log₁₀` of
//! the value; values outside an axis range are clamped to its edge.

use std::fs::{self, File};
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::prelude::*;
use plotters::style::register_font;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::Result;

/// Plot size in pixels.
pub const SIZE: (u32, u32) = (640, 400);

/// Series colours with their names for the legend; series `i` uses entry `i % len`.
pub const PALETTE: [(&str, RGBColor); 8] = [
    ("blue", RGBColor(31, 119, 180)),
    ("orange", RGBColor(255, 127, 14)),
    ("green", RGBColor(44, 160, 44)),
    ("red", RGBColor(214, 39, 40)),
    ("purple", RGBColor(148, 103, 189)),
    ("brown", RGBColor(140, 86, 75)),
    ("pink", RGBColor(227, 119, 194)),
    ("grey", RGBColor(127, 127, 127)),
];

/// Fonts tried for the plots' text after `$STBN_PLOT_FONT`: DejaVu Sans and Liberation Sans
/// where Linux distributions install them, then Arial on macOS and Windows.
pub const FONT_PATHS: [&str; 6] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu-sans-fonts/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/System/Library/Fonts/Supplemental/Arial.ttf",
    "C:\\Windows\\Fonts\\arial.ttf",
];

/// Whether a font for the plots' text is registered (tried once per process; see the module
/// docs). The font's bytes stay loaded for the life of the process.
pub fn font_available() -> bool {
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

/// One axis: `range` in data units, linear or logarithmic, with grid lines at `grid`.
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    /// What it measures, with units (drawn when a font is available).
    pub title: String,
    /// `(low, high)`, `low < high` (both `> 0` on a log axis).
    pub range: (f64, f64),
    /// Plot `log₁₀` of the values.
    pub log: bool,
    /// Grid-line positions in data units.
    pub grid: Vec<f64>,
}

impl Axis {
    /// A linear axis titled `title` from `low` to `high` with a grid line every `step`.
    pub fn linear(title: &str, low: f64, high: f64, step: f64) -> Axis {
        let lines = ((high - low) / step).round() as usize;
        Axis {
            title: title.to_owned(),
            range: (low, high),
            log: false,
            grid: (0..=lines).map(|i| low + i as f64 * step).collect(),
        }
    }

    /// A log axis titled `title` over the decades `10^low ..= 10^high`, grid lines at 1, 2 and
    /// 5 × 10ᵏ.
    pub fn decades(title: &str, low: i32, high: i32) -> Axis {
        Axis {
            title: title.to_owned(),
            range: (10f64.powi(low), 10f64.powi(high)),
            log: true,
            grid: (low..=high)
                .flat_map(|k| [1.0, 2.0, 5.0].map(|m| m * 10f64.powi(k)))
                .filter(|&v| v <= 10f64.powi(high))
                .collect(),
        }
    }

    /// The plotted coordinate of `v`, clamped to the range.
    fn map(&self, v: f64) -> f64 {
        let (low, high) = self.plotted();
        let v = if self.log { v.log10() } else { v };
        if v.is_nan() { low } else { v.clamp(low, high) }
    }

    /// The grid lines that get a tick label: all of a linear axis, the decades of a log one.
    fn labelled(&self) -> impl Iterator<Item = f64> + '_ {
        self.grid
            .iter()
            .copied()
            .filter(|v| !self.log || (v.log10() - v.log10().round()).abs() < 1e-9)
    }

    /// The range in plotted coordinates.
    fn plotted(&self) -> (f64, f64) {
        if self.log {
            (self.range.0.log10(), self.range.1.log10())
        } else {
            self.range
        }
    }
}

/// A plot: axes, one curve per series (colour [`PALETTE`]`[i]`) and an optional dark horizontal
/// reference line (e.g. white noise at power 1).
#[derive(Clone, Debug, PartialEq)]
pub struct Plot {
    /// Drawn above the plot when a font is available.
    pub title: String,
    /// Series names for the legend, drawn at `legend` when a font is available.
    pub names: Vec<String>,
    /// Where the legend goes.
    pub legend: SeriesLabelPosition,
    /// Horizontal axis.
    pub x: Axis,
    /// Vertical axis.
    pub y: Axis,
    /// `(x, y)` points of each series, in data units. Empty series are skipped.
    pub series: Vec<Vec<(f64, f64)>>,
    /// `y` of the reference line.
    pub reference: Option<f64>,
}

/// Draws `plot` (with text if [`font_available`]) and writes it to `path` as an RGB PNG of
/// [`SIZE`].
pub fn write(plot: &Plot, path: &Path) -> Result<()> {
    let pixels = render(plot, font_available())
        .map_err(|e| format!("cannot draw {}: {e}", path.display()))?;
    write_rgb_png(&pixels, SIZE, path)
}

/// Writes row-major 8-bit RGB `pixels` of `(width, height)` to `path` as a PNG.
pub fn write_rgb_png(pixels: &[u8], (width, height): (u32, u32), path: &Path) -> Result<()> {
    let failed = |e: &dyn std::fmt::Display| format!("cannot write {}: {e}", path.display());
    let file = File::create(path).map_err(|e| failed(&e))?;
    let mut encoder = png::Encoder::new(BufWriter::new(file), width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().map_err(|e| failed(&e))?;
    writer.write_image_data(pixels).map_err(|e| failed(&e))?;
    writer.finish().map_err(|e| failed(&e))?;
    Ok(())
}

/// Draws the x-axis title centred 24 pixels below the plot area and the y-axis title rotated,
/// `y_title_left` pixels from the image's left edge; `((left, bottom), (right, top))` are the
/// plot area's bottom-left and top-right corners in pixels. Shared with the trade study's charts.
pub(crate) fn draw_axis_titles(
    root: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
    font: &TextStyle<'_>,
    ((left, bottom), (right, top)): ((i32, i32), (i32, i32)),
    (x_title, y_title): (&str, &str),
    y_title_left: i32,
) -> std::result::Result<(), Box<dyn std::error::Error>> {
    let below = font.pos(Pos::new(HPos::Center, VPos::Top));
    root.draw(&Text::new(
        x_title,
        ((left + right) / 2, bottom + 24),
        below,
    ))?;
    let rotated = font
        .transform(FontTransform::Rotate270)
        .pos(Pos::new(HPos::Center, VPos::Top));
    root.draw(&Text::new(
        y_title,
        (y_title_left, (top + bottom) / 2),
        rotated,
    ))?;
    Ok(())
}

/// The RGB pixels of `plot`, row-major; `text` draws the title, ticks, axis titles and legend
/// (it needs a registered font).
fn render(plot: &Plot, text: bool) -> std::result::Result<Vec<u8>, Box<dyn std::error::Error>> {
    let mut pixels = vec![0u8; SIZE.0 as usize * SIZE.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, SIZE).into_drawing_area();
        root.fill(&WHITE)?;
        let (x0, x1) = plot.x.plotted();
        let (y0, y1) = plot.y.plotted();
        let mut builder = ChartBuilder::on(&root);
        builder.margin(12);
        if text {
            builder
                .caption(&plot.title, ("sans-serif", 18))
                .x_label_area_size(44)
                .y_label_area_size(64);
        }
        let mut chart = builder.build_cartesian_2d(x0..x1, y0..y1)?;
        let grid = RGBColor(220, 220, 220);
        for &x in &plot.x.grid {
            let x = plot.x.map(x);
            chart.draw_series(LineSeries::new([(x, y0), (x, y1)], grid))?;
        }
        for &y in &plot.y.grid {
            let y = plot.y.map(y);
            chart.draw_series(LineSeries::new([(x0, y), (x1, y)], grid))?;
        }
        // The frame.
        let corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)];
        chart.draw_series(LineSeries::new(corners, BLACK))?;
        if let Some(y) = plot.reference {
            let y = plot.y.map(y);
            chart.draw_series(LineSeries::new([(x0, y), (x1, y)], BLACK.stroke_width(2)))?;
        }
        for (i, points) in plot.series.iter().enumerate() {
            let colour = PALETTE[i % PALETTE.len()].1;
            let mapped = points.iter().map(|&(x, y)| (plot.x.map(x), plot.y.map(y)));
            let drawn = chart.draw_series(LineSeries::new(mapped, colour.stroke_width(2)))?;
            if let Some(name) = plot.names.get(i).filter(|_| text) {
                drawn.label(name).legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 16, y)], colour.stroke_width(2))
                });
            }
        }
        if text {
            let tick = |v: f64, log: bool| {
                let v = if log {
                    10f64.powf(v.log10().round())
                } else {
                    v
                };
                format!("{v}")
            };
            let font = ("sans-serif", 13).into_font().color(&BLACK);
            for x in plot.x.labelled() {
                let (px, py) = chart.backend_coord(&(plot.x.map(x), y0));
                let style = font.pos(Pos::new(HPos::Center, VPos::Top));
                root.draw(&Text::new(tick(x, plot.x.log), (px, py + 6), style))?;
            }
            for y in plot.y.labelled() {
                let (px, py) = chart.backend_coord(&(x0, plot.y.map(y)));
                let style = font.pos(Pos::new(HPos::Right, VPos::Center));
                root.draw(&Text::new(tick(y, plot.y.log), (px - 6, py), style))?;
            }
            draw_axis_titles(
                &root,
                &font,
                (
                    chart.backend_coord(&(x0, y0)),
                    chart.backend_coord(&(x1, y1)),
                ),
                (&plot.x.title, &plot.y.title),
                14,
            )?;
            chart
                .configure_series_labels()
                .position(plot.legend.clone())
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

    /// An empty series and a flat one at 0.25, with a reference line at 0.75.
    fn flat_plot() -> Plot {
        Plot {
            title: "Flat".to_owned(),
            names: vec!["empty".to_owned(), "flat".to_owned()],
            legend: SeriesLabelPosition::UpperRight,
            x: Axis::linear("x", 0.0, 1.0, 0.5),
            y: Axis::linear("y", 0.0, 1.0, 0.5),
            series: vec![vec![], vec![(0.0, 0.25), (1.0, 0.25)]],
            reference: Some(0.75),
        }
    }

    #[test]
    fn text_goes_around_the_plot_only_when_asked() {
        let dark = |pixels: &[u8], rows: std::ops::Range<u32>| {
            rows.flat_map(|y| (0..SIZE.0).map(move |x| (x, y)))
                .any(|(x, y)| pixel(pixels, x, y).iter().all(|&c| c < 100))
        };
        // Without text the top margin (12 px) stays white; the title would go there.
        let plain = render(&flat_plot(), false).unwrap();
        assert!(!dark(&plain, 0..10));
        if !font_available() {
            eprintln!("no font found (set STBN_PLOT_FONT): the labelled rendering is untested");
            return;
        }
        let labelled = render(&flat_plot(), true).unwrap();
        assert!(dark(&labelled, 0..30), "no title");
        assert!(
            dark(&labelled, SIZE.1 - 40..SIZE.1 - 12),
            "no tick labels or axis title"
        );
    }

    #[test]
    fn axes_map_and_clamp() {
        let log = Axis::decades("", -3, -1);
        assert_eq!(log.grid.len(), 7); // 1, 2, 5 × 10⁻³, 10⁻²; 10⁻¹
        assert_eq!(log.labelled().count(), 3);
        assert_eq!(Axis::linear("", 0.0, 1.0, 0.25).labelled().count(), 5);
        assert!((log.map(0.01) + 2.0).abs() < 1e-12);
        assert_eq!(log.map(0.0), -3.0); // log₁₀ 0 = −∞, clamped
        assert_eq!(log.map(5.0), -1.0);
        let linear = Axis::linear("", 0.0, 0.5, 0.125);
        assert_eq!(linear.grid, vec![0.0, 0.125, 0.25, 0.375, 0.5]);
        assert_eq!(linear.map(f64::NAN), 0.0);
    }

    #[test]
    fn a_horizontal_series_is_drawn_in_its_colour_at_its_height() {
        let plot = flat_plot();
        let pixels = render(&plot, false).unwrap();
        // The plot area spans the margins: 12 px on each side.
        let (top, bottom) = (12.0, (SIZE.1 - 12) as f64);
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
}
