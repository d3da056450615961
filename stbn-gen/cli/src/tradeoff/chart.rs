//! The trade-off plots: one or more series of points joined by lines, each point optionally
//! labelled, on linear or log axes whose ranges follow the data. RGB PNGs drawn with `plotters`
//! into a buffer and encoded with `png`, like the report's plots.
//!
//! Text needs a TrueType font, found as the report's plots find theirs ([`font_available`]);
//! without one the plot is drawn without text, and tradeoff.md states what each axis and colour is
//! either way. Series colours are the report's [`PALETTE`].

use std::path::Path;

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::Result;
use crate::report::plots::{PALETTE, draw_axis_titles, font_available, write_rgb_png};

/// Plot size in pixels.
pub const SIZE: (u32, u32) = (720, 440);

/// One axis: its title (with units) and whether it is logarithmic.
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    /// Drawn when a font is available.
    pub title: String,
    /// Plot `log₁₀` of the values; points with a value `≤ 0` on a log axis are left out.
    pub log: bool,
}

impl Axis {
    /// A linear axis.
    pub fn linear(title: &str) -> Axis {
        Axis {
            title: title.to_owned(),
            log: false,
        }
    }

    /// A log axis.
    pub fn log(title: &str) -> Axis {
        Axis {
            title: title.to_owned(),
            log: true,
        }
    }

    /// The plotted coordinate of `v`, `None` if a log axis cannot show it.
    fn map(&self, v: f64) -> Option<f64> {
        if !v.is_finite() {
            None
        } else if self.log {
            (v > 0.0).then(|| v.log10())
        } else {
            Some(v)
        }
    }

    /// The plotted range of `values` (mapped coordinates) and the grid lines in data units: a
    /// log axis spans whole decades with lines at 1, 2, 5 × 10ᵏ; a linear one pads the data by
    /// 5% and puts lines at a round step.
    fn range(&self, mapped: &[f64]) -> ((f64, f64), Vec<f64>) {
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

/// One series: points joined in order, with optional per-point labels.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Series {
    /// For the legend.
    pub name: String,
    /// `(x, y)` in data units.
    pub points: Vec<(f64, f64)>,
    /// Empty, or one label per point, drawn beside it (empty labels are not drawn).
    pub labels: Vec<String>,
    /// Points only, not joined by lines.
    pub scatter: bool,
}

/// A plot.
#[derive(Clone, Debug, PartialEq)]
pub struct Chart {
    /// Drawn above the plot.
    pub title: String,
    /// Horizontal axis.
    pub x: Axis,
    /// Vertical axis.
    pub y: Axis,
    /// Series `i` in [`PALETTE`]`[i]`.
    pub series: Vec<Series>,
    /// Where the legend goes (a corner the data leaves free).
    pub legend: SeriesLabelPosition,
}

impl Chart {
    /// The caption tradeoff.md puts under the plot: title, axes and colours.
    pub fn caption(&self) -> String {
        let scale = |a: &Axis| if a.log { "log scale" } else { "linear" };
        let colours: Vec<String> = self
            .series
            .iter()
            .enumerate()
            .map(|(i, s)| format!("{} = {}", PALETTE[i % PALETTE.len()].0, s.name))
            .collect();
        let note = if self.x.log || self.y.log {
            " Values ≤ 0 (e.g. an exact encoding's zero error) cannot sit on a log axis and are \
             left out."
        } else {
            ""
        };
        format!(
            "**{}.** x: {} ({}); y: {} ({}); {}.{note}",
            self.title,
            self.x.title,
            scale(&self.x),
            self.y.title,
            scale(&self.y),
            colours.join(", ")
        )
    }
}

/// Draws `chart` and writes it to `path` as an RGB PNG of [`SIZE`].
pub fn write(chart: &Chart, path: &Path) -> Result<()> {
    let pixels = render(chart, font_available())
        .map_err(|e| format!("cannot draw {}: {e}", path.display()))?;
    write_rgb_png(&pixels, SIZE, path)
}

type Points = Vec<(f64, f64, Option<String>)>;

/// The RGB pixels of `chart`; `text` draws the title, tick labels, axis titles, point labels and
/// legend (it needs a registered font).
fn render(chart: &Chart, text: bool) -> std::result::Result<Vec<u8>, Box<dyn std::error::Error>> {
    let mapped: Vec<Points> = chart
        .series
        .iter()
        .map(|s| {
            s.points
                .iter()
                .enumerate()
                .filter_map(|(i, &(x, y))| {
                    let label = s.labels.get(i).cloned();
                    Some((chart.x.map(x)?, chart.y.map(y)?, label))
                })
                .collect()
        })
        .collect();
    let xs: Vec<f64> = mapped.iter().flatten().map(|p| p.0).collect();
    let ys: Vec<f64> = mapped.iter().flatten().map(|p| p.1).collect();
    let ((x0, x1), x_grid) = chart.x.range(&xs);
    let ((y0, y1), y_grid) = chart.y.range(&ys);
    let mut pixels = vec![0u8; SIZE.0 as usize * SIZE.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, SIZE).into_drawing_area();
        root.fill(&WHITE)?;
        let mut builder = ChartBuilder::on(&root);
        builder.margin(14);
        if text {
            builder
                .caption(&chart.title, ("sans-serif", 18))
                .x_label_area_size(44)
                .y_label_area_size(70);
        }
        let mut plot = builder.build_cartesian_2d(x0..x1, y0..y1)?;
        let grey = RGBColor(220, 220, 220);
        let to = |axis: &Axis, v: f64| if axis.log { v.log10() } else { v };
        for &x in &x_grid {
            let x = to(&chart.x, x);
            plot.draw_series(LineSeries::new([(x, y0), (x, y1)], grey))?;
        }
        for &y in &y_grid {
            let y = to(&chart.y, y);
            plot.draw_series(LineSeries::new([(x0, y), (x1, y)], grey))?;
        }
        let corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)];
        plot.draw_series(LineSeries::new(corners, BLACK))?;
        for (i, points) in mapped.iter().enumerate() {
            let colour = PALETTE[i % PALETTE.len()].1;
            let line = points.iter().map(|p| (p.0, p.1));
            let line: Vec<(f64, f64)> = if chart.series[i].scatter {
                line.take(1).collect()
            } else {
                line.collect()
            };
            let drawn = plot.draw_series(LineSeries::new(line, colour.stroke_width(2)))?;
            if text {
                drawn
                    .label(chart.series[i].name.as_str())
                    .legend(move |(x, y)| {
                        PathElement::new([(x, y), (x + 16, y)], colour.stroke_width(2))
                    });
            }
            plot.draw_series(
                points
                    .iter()
                    .map(|p| Circle::new((p.0, p.1), 3, colour.filled())),
            )?;
        }
        if text {
            let font = ("sans-serif", 13).into_font().color(&BLACK);
            let small = ("sans-serif", 11).into_font().color(&RGBColor(60, 60, 60));
            for points in &mapped {
                for (x, y, label) in points {
                    if let Some(label) = label.as_ref().filter(|l| !l.is_empty()) {
                        let (px, py) = plot.backend_coord(&(*x, *y));
                        let style = small.pos(Pos::new(HPos::Left, VPos::Bottom));
                        root.draw(&Text::new(label.as_str(), (px + 4, py - 3), style))?;
                    }
                }
            }
            let tick = |axis: &Axis, v: f64| {
                if axis.log {
                    crate::tradeoff::table::significant(v, 1)
                } else {
                    crate::tradeoff::table::significant(v, 3)
                }
            };
            let labelled =
                |axis: &Axis, v: f64| !axis.log || (v.log10() - v.log10().round()).abs() < 1e-9;
            for &x in x_grid.iter().filter(|&&x| labelled(&chart.x, x)) {
                let (px, py) = plot.backend_coord(&(to(&chart.x, x), y0));
                let style = font.pos(Pos::new(HPos::Center, VPos::Top));
                root.draw(&Text::new(tick(&chart.x, x), (px, py + 6), style))?;
            }
            for &y in y_grid.iter().filter(|&&y| labelled(&chart.y, y)) {
                let (px, py) = plot.backend_coord(&(x0, to(&chart.y, y)));
                let style = font.pos(Pos::new(HPos::Right, VPos::Center));
                root.draw(&Text::new(tick(&chart.y, y), (px - 6, py), style))?;
            }
            draw_axis_titles(
                &root,
                &font,
                (plot.backend_coord(&(x0, y0)), plot.backend_coord(&(x1, y1))),
                (&chart.x.title, &chart.y.title),
                10,
            )?;
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

    fn chart(log: bool) -> Chart {
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
                    scatter: false,
                },
                Series {
                    name: "b".to_owned(),
                    points: vec![(2.0, 0.3), (50.0, 0.1)],
                    labels: Vec::new(),
                    scatter: true,
                },
                Series::default(),
            ],
            legend: SeriesLabelPosition::UpperRight,
        }
    }

    #[test]
    fn log_axes_span_decades_and_drop_non_positive_values() {
        let axis = Axis::log("x");
        assert_eq!(axis.map(0.0), None);
        let ((a, b), grid) = axis.range(&[0.3f64.log10(), 20f64.log10()]);
        assert_eq!((a, b), (-1.0, 2.0));
        assert_eq!(grid.first(), Some(&0.1));
        assert!((grid.last().unwrap() - 100.0).abs() < 1e-9);
        let ((low, high), grid) = Axis::linear("y").range(&[0.0, 1.0]);
        assert!(low < 0.0 && high > 1.0);
        assert_eq!(grid, vec![0.0, 0.2, 0.4, 0.6000000000000001, 0.8, 1.0]);
        assert_eq!(nice_step(0.13), 0.2);
    }

    #[test]
    fn draws_points_in_the_series_colour_with_or_without_text() {
        let count = |pixels: &[u8], i: usize| {
            let c = PALETTE[i].1;
            pixels
                .chunks_exact(3)
                .filter(|p| *p == [c.0, c.1, c.2])
                .count()
        };
        for text in [false, font_available()] {
            let pixels = render(&chart(true), text).unwrap();
            // A line through two points and its markers: hundreds of pixels.
            assert!(count(&pixels, 0) > 200, "{}", count(&pixels, 0));
            // Two markers of radius 3 and no line between them (a line would add ~580 pixels; the
            // legend adds a short sample line when text is on).
            let scatter = count(&pixels, 1);
            assert!(scatter > 20 && scatter < 200, "{scatter}");
        }
        // A linear y axis keeps the point at 0.
        assert!(render(&chart(false), false).is_ok());
        let caption = chart(true).caption();
        assert!(
            caption.contains("x: x (log scale); y: y (log scale); blue = a, orange = b, green = ."),
            "{caption}"
        );
    }
}
