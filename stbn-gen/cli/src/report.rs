//! The quality figures of one mask ([`Row`]) and the `report.md` of several: a table, the
//! convergence figures of every integrand (within the depth, and past it for encoded masks),
//! PNG plots in `plots/`, DFT magnitude images in `dft/` and every number as CSV in `csv/`.

mod csv;
mod guide;
mod past_depth;
mod spectrum_images;
mod vector;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use indicatif::{ProgressBar, ProgressStyle};

use stbn_gen::analysis::{
    Convergence, ConvergenceOptions, Field, FilteredErrorOptions, Integrand, SpectrumImage,
    VectorField, convergence, dft_xy_image, dft_xz_image, filtered_error,
    pixel_histogram_deviation, radial_rings_per_cycle, radial_spectrum, slice_histogram_deviation,
    spatial_low_band, spectrum_fold, temporal_low_band, temporal_spectrum,
};

use stbn_runtime::Stbn;

use crate::Result;
use crate::output::{self, Axis, Cell, Chart, Column, Series, SeriesLabelPosition, Style, Table};
pub use past_depth::PastDepth;
pub use vector::VectorFigures;

/// Bins of the histogram-deviation column. 16 divides every power-of-two slice size from 16
/// pixels up and the 256 levels of 8-bit PNGs, so exactly uniform slices measure exactly 0.
pub const HISTOGRAM_BINS: usize = 16;

/// Samples per pixel of the convergence curves; masks with fewer frames wrap around.
pub const CONVERGENCE_SAMPLES: usize = 64;

/// The sample counts the tables report convergence at.
pub const CONVERGENCE_AT: [usize; 4] = [1, 4, 16, 64];

/// Mask names `generate` refuses: the report's folders beside the mask folders (compared without
/// case, for file systems that ignore it).
pub const RESERVED_NAMES: [&str; 3] = [PLOT_DIR, spectrum_images::DFT_DIR, csv::CSV_DIR];

/// One mask's figures and curves (a few kilobytes: its DFT images are written as they are
/// measured, not kept).
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// The mask's name.
    pub name: String,
    /// `(width, height, frames)`.
    pub size: (usize, usize, usize),
    /// How it was made: a generator topology, `png N-bit` for analysed slices, or a baseline.
    pub kind: String,
    /// Generation wall-clock time in seconds; `None` for analysed slices.
    pub seconds: Option<f64>,
    /// [`spatial_low_band`]: dimensionless, white noise ≈ 1; `None` for 1×1 frames. Vector
    /// masks: the mean over the decoded components ([`VectorFigures::components`]).
    pub spatial: Option<f64>,
    /// [`temporal_low_band`]: dimensionless, white noise ≈ 1; `None` for a single frame. Vector
    /// masks: the mean over the decoded components.
    pub temporal: Option<f64>,
    /// [`slice_histogram_deviation`] over [`HISTOGRAM_BINS`] bins: 0 = exactly uniform frames.
    /// Vector masks: the frame figure of [`stbn_gen::analysis::distribution_deviation`], 0 =
    /// every frame follows the space's pdf exactly.
    pub histogram: f64,
    /// [`pixel_histogram_deviation`]: mean Kolmogorov–Smirnov distance of each pixel's values
    /// over the frames from uniform; `1/(2·frames)` at best, about `0.87/√frames` for white
    /// noise. Vector masks: the pixel figure of
    /// [`stbn_gen::analysis::distribution_deviation`] (distance from the space's pdf).
    pub pixel_histogram: f64,
    /// [`radial_spectrum`]: normalised power per ring of radius `r` (cycles per longest side);
    /// vector masks: the mean over the decoded components.
    pub radial: Vec<f64>,
    /// [`temporal_spectrum`]: normalised power per temporal frequency (cycles per `frames`);
    /// vector masks: the mean over the decoded components.
    pub temporal_spectrum: Vec<f64>,
    /// [`filtered_error`] with EA's settings ([`FilteredErrorOptions::default`]) per frame;
    /// vector masks: [`filtered_error_vector`] of the decoded components.
    pub filtered: Vec<f64>,
    /// [`convergence()`] of each of [`Integrand::ALL`] over [`CONVERGENCE_SAMPLES`] samples from
    /// frame 0 (EMA α = 0.1), in that order. Empty for vector masks, whose values are not in
    /// `[0, 1)`: their test functions are in [`Row::vector`].
    pub convergence: Vec<Convergence>,
    /// The same started at frame `⌊frames / 3⌋` (toroidal progressiveness: a sequence may start
    /// anywhere and should converge just as fast). Empty for vector masks.
    pub convergence_late: Vec<Convergence>,
    /// The figures only a vector mask has; `None` for scalar masks.
    pub vector: Option<VectorFigures>,
    /// The running-mean error past the mask's depth, read through the runtime from the encoded
    /// mask ([`PastDepth`]); why it was not measured otherwise (analysed slices, or a vector
    /// space whose test functions do not apply to the encoded components).
    pub past_depth: std::result::Result<PastDepth, String>,
}

/// The DFT magnitude images of one mask: [`dft_xy_image`] (mean over the frames, `width ×
/// height`) and [`dft_xz_image`] (mean over the x–frame planes, `width × frames`), centred.
pub struct Spectra {
    /// XY.
    pub xy: SpectrumImage,
    /// XZ.
    pub xz: SpectrumImage,
}

/// The steps of [`Row::measure_with_progress`], in order, named for a progress bar.
const MEASURE_STEPS: [&str; 12] = [
    "spatial low band",
    "temporal low band",
    "histograms",
    "DFT XY",
    "DFT XZ",
    "radial spectrum",
    "temporal spectrum",
    "filtered error",
    "convergence",
    "convergence from frame ⌊frames/3⌋",
    "convergence past the depth",
    "done",
];

impl Row {
    /// Measures `field` (its DFT images too), without progress or an encoded mask.
    #[cfg(test)]
    pub fn measure(name: &str, kind: &str, seconds: Option<f64>, field: &Field) -> (Row, Spectra) {
        Self::measure_with_progress(name, kind, seconds, field, None, &mut |_, _| {})
    }

    /// Measures `field` (its DFT images too), and `encoded`, the mask `field` was encoded to,
    /// past its depth ([`PastDepth`]; not measured without it), calling `progress(step, name)`
    /// before each of its steps and `progress(steps, "done")` at the end (steps of
    /// [`MEASURE_STEPS`]).
    fn measure_with_progress(
        name: &str,
        kind: &str,
        seconds: Option<f64>,
        field: &Field,
        encoded: Option<&Stbn<'_>>,
        progress: &mut dyn FnMut(usize, &'static str),
    ) -> (Row, Spectra) {
        let mut step = 0;
        let mut next = || {
            progress(step, MEASURE_STEPS[step]);
            step += 1;
        };
        next();
        let spatial = spatial_low_band(field);
        next();
        let temporal = temporal_low_band(field);
        next();
        let histogram = slice_histogram_deviation(field, HISTOGRAM_BINS);
        let pixel_histogram = pixel_histogram_deviation(field);
        next();
        let xy = dft_xy_image(field);
        next();
        let xz = dft_xz_image(field);
        next();
        let radial = radial_spectrum(field);
        next();
        let temporal_spectrum = temporal_spectrum(field);
        next();
        let filtered = filtered_error(field, FilteredErrorOptions::default());
        next();
        let convergence = converge(field, 0);
        next();
        let convergence_late = converge(field, field.depth() / 3);
        next();
        let past_depth = encoded.map_or_else(
            || Err(past_depth::NOT_ENCODED.to_owned()),
            past_depth::measure_scalar,
        );
        next();
        let row = Row {
            name: name.to_owned(),
            size: (field.width(), field.height(), field.depth()),
            kind: kind.to_owned(),
            seconds,
            spatial,
            temporal,
            histogram,
            pixel_histogram,
            radial,
            temporal_spectrum,
            filtered,
            convergence,
            convergence_late,
            vector: None,
            past_depth,
        };
        (row, Spectra { xy, xz })
    }

    /// The filtered error of the last frame: the headline figure.
    pub fn filtered_last(&self) -> f64 {
        *self
            .filtered
            .last()
            .expect("a field has at least one frame")
    }

    /// One line for the terminal.
    pub fn summary(&self) -> String {
        let time = self
            .seconds
            .map(|s| format!(" in {s:.2} s"))
            .unwrap_or_default();
        format!(
            "{}: {} {}{time}; low band (white noise = 1): spatial {}, temporal {}; \
             filtered error {:.5}",
            output::line_text(&self.name),
            size(self.size),
            self.kind,
            band(self.spatial),
            band(self.temporal),
            self.filtered_last(),
        )
    }

    /// The curves of `integrand` from frame 0.
    fn curves(&self, integrand: Integrand) -> &Convergence {
        &self.convergence[integrand_index(integrand)]
    }

    /// The curves of `integrand` from frame `⌊frames / 3⌋`.
    fn curves_late(&self, integrand: Integrand) -> &Convergence {
        &self.convergence_late[integrand_index(integrand)]
    }
}

/// [`convergence()`] of each of [`Integrand::ALL`] over [`CONVERGENCE_SAMPLES`] samples from
/// frame `start`, EMA α = 0.1.
fn converge(field: &Field, start: usize) -> Vec<Convergence> {
    let options = ConvergenceOptions::new(CONVERGENCE_SAMPLES).starting_at(start);
    Integrand::ALL
        .iter()
        .map(|&f| convergence(field, f, options))
        .collect()
}

/// The position of `integrand` in [`Integrand::ALL`].
fn integrand_index(integrand: Integrand) -> usize {
    Integrand::ALL
        .iter()
        .position(|&f| f == integrand)
        .expect("ALL holds every integrand")
}

/// A report being written into a folder: each mask is measured and its DFT images written as
/// it comes ([`Report::measure`]), so only its figures are kept; [`Report::finish`] writes the
/// plots, the CSV files and `report.md`.
pub struct Report {
    out: PathBuf,
    rows: Vec<Row>,
}

impl Report {
    /// A report in `out` (created, with its `plots/` and `dft/` folders).
    pub fn create(out: &Path) -> Result<Report> {
        for dir in [out.join(PLOT_DIR), out.join(spectrum_images::DFT_DIR)] {
            output::create_dir(&dir)?;
        }
        Ok(Report {
            out: out.to_owned(),
            rows: Vec::new(),
        })
    }

    /// Measures `field` as mask `name` with a progress bar (on a terminal), writes its DFT
    /// images and keeps its figures; returns them. Not encoded, it has no figures past the
    /// depth ([`Report::measure_encoded`]).
    pub fn measure(
        &mut self,
        name: &str,
        kind: &str,
        seconds: Option<f64>,
        field: &Field,
    ) -> Result<&Row> {
        self.measure_scalar(name, kind, seconds, field, None)
    }

    /// [`Report::measure`] of a generated scalar mask whose values are `field` and whose
    /// encoded bytes are `encoded`: read past its depth through the runtime ([`PastDepth`]).
    pub fn measure_encoded(
        &mut self,
        name: &str,
        kind: &str,
        seconds: Option<f64>,
        field: &Field,
        encoded: &Stbn<'_>,
    ) -> Result<&Row> {
        self.measure_scalar(name, kind, seconds, field, Some(encoded))
    }

    /// [`Report::measure`], with the figures past the depth when `encoded`.
    fn measure_scalar(
        &mut self,
        name: &str,
        kind: &str,
        seconds: Option<f64>,
        field: &Field,
        encoded: Option<&Stbn<'_>>,
    ) -> Result<&Row> {
        let (row, spectra) = with_measure_bar(name, MEASURE_STEPS.len(), |progress| {
            Row::measure_with_progress(name, kind, seconds, field, encoded, progress)
        });
        self.push(row, &spectra)?;
        Ok(self.rows.last().expect("a row was pushed"))
    }

    /// [`Report::measure_encoded`] for a vector mask, measured in its own space
    /// ([`VectorFigures`]), and past its depth through `encoded` with its space's test
    /// functions.
    pub fn measure_vector(
        &mut self,
        name: &str,
        kind: &str,
        seconds: Option<f64>,
        field: &VectorField,
        encoded: &Stbn<'_>,
    ) -> Result<&Row> {
        let (row, spectra) = with_measure_bar(name, vector::STEPS.len(), |progress| {
            vector::measure(name, kind, seconds, field, encoded, progress)
        });
        self.push(row, &spectra)?;
        Ok(self.rows.last().expect("a row was pushed"))
    }

    /// Adds a measured mask: writes its DFT images and keeps `row`.
    pub fn push(&mut self, row: Row, spectra: &Spectra) -> Result<()> {
        let dft_dir = self.out.join(spectrum_images::DFT_DIR);
        let [xy, xz] = dft_files(self.rows.len(), &row);
        spectrum_images::write(&spectra.xy, &dft_dir.join(xy))?;
        spectrum_images::write(&spectra.xz, &dft_dir.join(xz))?;
        self.rows.push(row);
        Ok(())
    }

    /// Writes the plots in `plots/`, the CSV files in `csv/` and `report.md`, with `intro`
    /// above the figures and `sections` (markdown) at the end; returns the report's path.
    pub fn finish(self, intro: &str, sections: &str) -> Result<PathBuf> {
        let mut figures = figures(&self.rows);
        figures.extend(vector::figures(&self.rows));
        figures.extend(past_depth::figure(&self.rows));
        let bar = bar(
            figures.len() as u64 + 2,
            "report: writing",
            "{prefix} [{bar:30}] {pos}/{len} files {elapsed_precise}",
        );
        let plot_dir = self.out.join(PLOT_DIR);
        for Figure { file, chart, .. } in figures {
            chart.write_png(&plot_dir.join(file))?;
            bar.inc(1);
        }
        csv::write(&self.out, &self.rows)?;
        bar.inc(1);
        let path = self.out.join("report.md");
        output::write_text(&path, &(markdown(intro, &self.rows) + sections))?;
        bar.finish_and_clear();
        Ok(path)
    }

    /// The names of what the report writes in its folder, report.md last.
    pub fn files() -> [String; 4] {
        [
            PLOT_DIR,
            spectrum_images::DFT_DIR,
            csv::CSV_DIR,
            "report.md",
        ]
        .map(str::to_owned)
    }
}

/// Runs `measure` of `steps` named steps (the last one `done`) under a progress bar (on a
/// terminal) for mask `name`.
fn with_measure_bar<T>(
    name: &str,
    steps: usize,
    measure: impl FnOnce(&mut dyn FnMut(usize, &'static str)) -> T,
) -> T {
    let bar = bar(
        steps as u64 - 1,
        &format!("{name}: measuring"),
        "{prefix} [{bar:30}] {pos}/{len} {msg} {elapsed_precise}",
    );
    bar.enable_steady_tick(std::time::Duration::from_millis(200));
    let measured = measure(&mut |step, what| {
        bar.set_position(step as u64);
        bar.set_message(what);
    });
    bar.finish_and_clear();
    measured
}

/// A progress bar of `len` steps with `template` and `prefix`, drawn only on a terminal.
pub fn bar(len: u64, prefix: &str, template: &str) -> ProgressBar {
    ProgressBar::new(len)
        .with_style(
            ProgressStyle::with_template(template)
                .expect("the template is valid")
                .progress_chars("=> "),
        )
        .with_prefix(prefix.to_owned())
}

/// The XY and XZ image files of `rows[index]` in [`spectrum_images::DFT_DIR`]:
/// `<index>_<name>_xy.png` and `…_xz.png`, the name reduced to ASCII letters, digits, `-` and `_`
/// (the index keeps them unique).
fn dft_files(index: usize, row: &Row) -> [String; 2] {
    let name: String = row
        .name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect();
    ["xy", "xz"].map(|plane| format!("{index:02}_{name}_{plane}.png"))
}

/// The folder of the plots, relative to report.md.
const PLOT_DIR: &str = "plots";

/// One plot of the report: its file in [`PLOT_DIR`], what it draws, and the caption describing
/// its axes.
struct Figure {
    file: String,
    chart: Chart,
    axes: &'static str,
}

impl Figure {
    /// The figure in a report section: the chart's caption, the axes, and the image.
    fn markdown(&self) -> String {
        format!(
            "\n{} {}\n\n![{}]({PLOT_DIR}/{})\n",
            self.chart.caption(),
            self.axes,
            self.chart.title.replace(['[', ']'], "_"),
            self.file
        )
    }
}

/// Every plot of the report. Series `i` is `rows[i]`.
fn figures(rows: &[Row]) -> Vec<Figure> {
    let plot = |title: &str, x, y, legend, points: Vec<Vec<(f64, f64)>>, reference| Chart {
        title: title.to_owned(),
        x,
        y,
        series: rows
            .iter()
            .zip(points)
            .map(|(row, points)| Series {
                name: output::line_text(&row.name),
                points,
                labels: Vec::new(),
                style: Style::Line,
            })
            .collect(),
        legend,
        reference,
    };
    let power = || Axis::linear_range("normalised power (white noise = 1)", 0.0, 2.5, 0.5);
    // Radial: ring r of a slice whose longest side is L sits at r / L cycles per pixel (L of the
    // folded grid for slices too large to transform whole: `radial_rings_per_cycle`). Rings
    // beyond L / 2 hold only the corners of the frequency square, and DC is 0 by definition
    // (the mean is removed): both left out, as is DC of the temporal spectrum.
    let radial = rows
        .iter()
        .map(|row| {
            let long = radial_rings_per_cycle(row.size.0, row.size.1);
            let points = row.radial.iter().enumerate().take(long / 2 + 1).skip(1);
            points.map(|(r, &p)| (r as f64 / long as f64, p)).collect()
        })
        .collect();
    let temporal = rows
        .iter()
        .map(|row| {
            let frames = row.size.2 as f64;
            let points = row.temporal_spectrum.iter().enumerate().skip(1);
            points.map(|(f, &p)| (f as f64 / frames, p)).collect()
        })
        .collect();
    let filtered = rows
        .iter()
        .map(|row| {
            let points = row.filtered.iter().enumerate();
            points.map(|(k, &e)| (k as f64, e)).collect()
        })
        .collect();
    let longest = rows.iter().map(|row| row.size.2).max().unwrap_or(1) as f64;
    let mut all = vec![
        Figure {
            file: "radial.png".to_owned(),
            chart: plot(
                "Radial spatial spectrum",
                Axis::linear_range("radial frequency (cycles per pixel)", 0.0, 0.5, 0.0625),
                power(),
                SeriesLabelPosition::UpperLeft,
                radial,
                Some(1.0),
            ),
            axes: "x: radial frequency 0 to 0.5 cycles per pixel, grid every 1/16; y: normalised \
                   power 0 to 2.5, grid every 0.5; black line: white noise (1). Blue noise starts \
                   near 0 and rises past 1.",
        },
        Figure {
            file: "temporal.png".to_owned(),
            chart: plot(
                "Temporal spectrum",
                Axis::linear_range("temporal frequency (cycles per frame)", 0.0, 0.5, 0.0625),
                power(),
                SeriesLabelPosition::UpperLeft,
                temporal,
                Some(1.0),
            ),
            axes: "x: temporal frequency 0 to 0.5 cycles per frame, grid every 1/16; y: \
                   normalised power 0 to 2.5, grid every 0.5; black line: white noise (1).",
        },
        Figure {
            file: "filtered_error.png".to_owned(),
            chart: plot(
                "Filtered error per frame",
                Axis::linear_range("frame", 0.0, longest, (longest / 8.0).max(1.0)),
                Axis::log_decades("filtered error (coverage)", -3, -1),
                SeriesLabelPosition::UpperRight,
                filtered,
                None,
            ),
            axes: "x: frame, grid every eighth of the longest mask; y: filtered error, log scale \
                   0.001 to 0.1, grid at 1, 2, 5 × 10ᵏ.",
        },
    ];
    for integrand in Integrand::ALL {
        for estimator in Estimator::ALL {
            // Vector masks have no curve here (their test functions have their own plots), but
            // keep their series, empty, so every plot gives a mask the same colour.
            let series = rows
                .iter()
                .map(|row| {
                    if row.vector.is_some() {
                        return Vec::new();
                    }
                    // Up to the mask's depth: past it a pixel's sequence repeats its frames,
                    // and the curve would jump where it wraps.
                    let curve = estimator.curve(row.curves(integrand)).iter().enumerate();
                    let depth = row.size.2;
                    curve
                        .take(depth)
                        .map(|(k, &e)| ((k + 1) as f64, e))
                        .collect()
                })
                .collect();
            let title = format!(
                "Convergence, {} integrand, {}",
                integrand.name(),
                estimator.title()
            );
            all.push(Figure {
                file: estimator.plot_file(integrand),
                chart: plot(
                    &title,
                    Axis::log_decades("samples", 0, 2),
                    Axis::log_decades("RMSE over pixels", -3, 0),
                    SeriesLabelPosition::LowerLeft,
                    series,
                    None,
                ),
                axes: "x: samples, log scale 1 to 100, grid at 1, 2, 5 × 10ᵏ; y: RMSE, log scale \
                       0.001 to 1, grid at 1, 2, 5 × 10ᵏ. Each scalar mask's curve ends at its \
                       depth, where its frames start to repeat; vector masks are judged by their \
                       test functions instead.",
            });
        }
    }
    all
}

/// The two estimators of a [`Convergence`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Estimator {
    MonteCarlo,
    Ema,
}

impl Estimator {
    const ALL: [Estimator; 2] = [Estimator::MonteCarlo, Estimator::Ema];

    /// Its error curve.
    fn curve(self, convergence: &Convergence) -> &[f64] {
        match self {
            Estimator::MonteCarlo => &convergence.monte_carlo,
            Estimator::Ema => &convergence.ema,
        }
    }

    /// Short label: `MC` or `EMA`.
    fn label(self) -> &'static str {
        match self {
            Estimator::MonteCarlo => "MC",
            Estimator::Ema => "EMA",
        }
    }

    /// Full name for captions.
    fn title(self) -> &'static str {
        match self {
            Estimator::MonteCarlo => "Monte Carlo",
            Estimator::Ema => "EMA",
        }
    }

    /// The file of its convergence plot of `integrand`, e.g. `convergence_step_mc.png`.
    fn plot_file(self, integrand: Integrand) -> String {
        let short = self.label().to_lowercase();
        format!("convergence_{}_{short}.png", integrand.name())
    }
}

/// The figures of every mask, one row each: the report's table and `summary.csv`. The table
/// shows the size as `w×h×frames` and the step-integrand RMSE at every count of
/// [`CONVERGENCE_AT`] in one column per estimator; the CSV file has the size's three numbers and
/// a column per count.
fn summary_table(rows: &[Row]) -> Table {
    let at = CONVERGENCE_AT.map(|n| n.to_string()).join("/");
    let mut columns = vec![
        Column::both("mask", "mask", false),
        Column::markdown_only("size", false),
        Column::both("kind", "kind", false),
        Column::csv_only("width"),
        Column::csv_only("height"),
        Column::csv_only("frames"),
        Column::both("seconds", "seconds", true),
        Column::both(
            "spatial_low_band",
            "spatial low band (white = 1, lower = bluer)",
            true,
        ),
        Column::both(
            "temporal_low_band",
            "temporal low band (white = 1, lower = bluer)",
            true,
        ),
        Column::both(
            "slice_histogram_deviation",
            "frame histogram deviation (0 = exact)",
            true,
        ),
        Column::both(
            "pixel_histogram_deviation",
            "pixel histogram deviation (lower = better)",
            true,
        ),
        Column::both(
            "filtered_error_last",
            "filtered error (coverage, white ≈ 0.020, lower = better)",
            true,
        ),
    ];
    for estimator in Estimator::ALL {
        let label = estimator.label();
        let csv = CONVERGENCE_AT.map(|n| format!("step_{}_rmse_{n}", label.to_lowercase()));
        columns.extend(csv.iter().map(|name| Column::csv_only(name)));
        let white = match estimator {
            Estimator::MonteCarlo => "white 0.5/√n",
            Estimator::Ema => "white ≈ 0.115",
        };
        columns.push(Column::markdown_only(
            &format!("step {label} RMSE at {at} ({white}, lower = better)"),
            true,
        ));
    }
    columns.push(Column::both("space", "space", false));
    columns.push(Column::both(
        "test_function_ratio_to_white",
        &format!(
            "test functions' error ÷ white noise's at {} samples (white = 1, lower = better)",
            vector::RATIO_AT
        ),
        true,
    ));
    let mut table = Table::with_columns(columns);
    for row in rows {
        let (width, height, frames) = row.size;
        let mut cells = vec![
            Cell::name(&row.name),
            Cell::text(size(row.size)),
            Cell::text(&row.kind),
            Cell::int(width as u64),
            Cell::int(height as u64),
            Cell::int(frames as u64),
            Cell::opt_fixed(row.seconds, 2),
            Cell::opt_fixed(row.spatial, 4),
            Cell::opt_fixed(row.temporal, 4),
            Cell::fixed(row.histogram, 4),
            Cell::fixed(row.pixel_histogram, 4),
            Cell::fixed(row.filtered_last(), 5),
        ];
        for estimator in Estimator::ALL {
            match &row.vector {
                None => {
                    let curve = estimator.curve(row.curves(Integrand::Step));
                    let at = CONVERGENCE_AT.map(|n| curve.get(n - 1).copied());
                    cells.extend(at.map(|e| Cell::opt_fixed(e, 4)));
                    cells.push(Cell::text(at_samples(curve)));
                }
                Some(_) => {
                    cells.extend(CONVERGENCE_AT.map(|_| Cell::missing()));
                    cells.push(Cell::missing());
                }
            }
        }
        let vector = row.vector.as_ref();
        cells.push(Cell::text(vector.map_or("scalar", |v| v.space)));
        cells.push(Cell::opt_fixed(vector.and_then(|v| v.worst_ratio()), 2));
        table.push(cells);
    }
    table
}

/// The report: heading, `intro`, the table, what its columns mean, the convergence figures of
/// every integrand and the plots.
fn markdown(intro: &str, rows: &[Row]) -> String {
    let at = CONVERGENCE_AT.map(|n| n.to_string()).join("/");
    let mut text = format!(
        "# Blue-noise mask report\n\n{intro}\n\n{}\n{}\n{}\n## Figures\n\n{}",
        guide::reading_guide(),
        guide::verdicts(rows),
        guide::which_mask(),
        summary_table(rows).markdown()
    );
    text.push_str(&format!(
        "\n\
Columns:\n\n\
- **size**: width × height × frames (pixels, pixels, frames).\n\
- **kind**: the energy a generated mask was made with (`spatiotemporal`: blue in space and over \
time; `independent2d`: an independent 2D blue-noise mask per frame; `isotropic3d`: 3D blue noise; \
`FilterAdapted`: optimised for a spatial and a temporal filter, by default the ones the filtered \
error applies), `png N-bit` for analysed slice files, or `baseline …` for a comparison field.\n\
- **seconds**: wall-clock generation time (n/a for analysed files).\n\
- **spatial low band**: each frame's 2D power spectrum with the mean removed, divided by what \
white noise of the same variance would have, averaged over the low frequencies 0 < |ν| ≤ 1/8 \
cycles per pixel (radius ≤ width/8 for square frames), then over frames. **White noise = 1**; \
blue noise is far below 1. n/a for 1×1 frames.\n\
- **temporal low band**: the same for every pixel's values over the frames, over the \
frequencies 1 ≤ f ≤ frames/8 cycles per sequence (just f = 1 below 8 frames), averaged over \
pixels. **White noise = 1**; a mask that is blue over time is far below 1, one that is white \
over time (`independent2d`) about 1. n/a for a single frame.\n\
- **frame histogram deviation**: the largest relative deviation of any frame's \
{HISTOGRAM_BINS}-bin histogram of values from uniform, |count − expected| / expected. 0 = every \
frame exactly uniform (void-and-cluster ranks always are, and so is every baseline here, white \
noise included: they are built on ranks); independent uniform values measure about 0.2 over 32 \
frames of 64×64.\n\
- **pixel histogram deviation**: how far each pixel's values over the frames are from uniform: \
the Kolmogorov–Smirnov distance (largest gap between the empirical and the uniform CDF) of each \
pixel's sequence, averaged over pixels. 1/(2·frames) at best (values at the midpoints of equal \
strata), about 0.87/√frames for white noise (0.11 at 64 frames); lower means each pixel's \
sequence covers [0, 1) more evenly over time.\n\
- **space** and **test functions' error ÷ white noise's**: vector masks only (see \"Vector \
masks in their own space\"): the space their values are drawn from, and the largest ratio, over \
its test functions, of the mask's Monte Carlo error to that of white noise of the same \
distribution after {ratio_at} samples. White noise = 1; lower is better.\n\
- **filtered error**: EA's FAST metric at the last frame. For 256 stratified thresholds t, each \
frame is binarised (value < t), blurred with a toroidal Gaussian of σ = 1.3435 px, averaged over \
frames with an EMA (α = 0.1); the figure is √(mean over t of the spatial variance), in units of \
coverage. Lower is better; white noise measures about 0.020 (expected √(1/6 · 1/(4πσ²) · \
α/(2 − α)) = 0.0197).\n\
- **step MC / EMA RMSE**: every pixel estimates ∫₀¹ [x < ½] dx = ½ from its values over the \
frames (from frame 0, wrapping after the last), as a running mean (Monte Carlo) or an EMA \
(α = 0.1); the root-mean-square error over pixels after {at} samples. White noise: 0.5/√n for \
Monte Carlo, a plateau of 0.5·√(α/(2 − α)) = 0.115 for the EMA. n/a for vector masks, whose \
values are not in [0, 1).\n\n\
Vector masks are measured on their decoded values: low bands, spectra, DFT images and the \
filtered error (with random half-spaces as thresholds) of each component, averaged over the \
components; histogram deviations of their stratum coordinates, against the space's pdf. \
Figures of generated masks are measured on the exact values (ranks for scalar masks), before \
encoding and PNG quantisation; those of analysed files on the decoded samples, \
(sample + ½) / 2^bits.\n",
        ratio_at = vector::RATIO_AT,
    ));
    partial_section(&mut text, rows);
    vector::section(&mut text, rows);
    convergence_section(&mut text, rows);
    past_depth::section(&mut text, rows);
    plot_section(&mut text, rows);
    dft_section(&mut text, rows);
    csv_section(&mut text, rows);
    text
}

/// What was measured of each mask too large to measure whole ([`partial_measures`]), if any.
fn partial_section(text: &mut String, rows: &[Row]) {
    let lines: Vec<String> = rows
        .iter()
        .filter_map(|row| {
            let what = partial_measures(row.size)?;
            Some(format!(
                "- `{}` ({}): {what}.\n",
                output::line_text(&row.name),
                size(row.size)
            ))
        })
        .collect();
    if lines.is_empty() {
        return;
    }
    text.push_str(
        "\n## Masks measured in part\n\n\
         Large masks are measured in bounded memory: frames (and x–frame planes) of more \
         than 2²² pixels are folded before their DFT, which gives the spectrum exactly at every \
         k-th frequency of each folded axis (no crop, no leakage); the filtered error of frames \
         of more than 2²⁰ pixels is averaged over a window at the frame's origin whose pixels \
         are blurred with their true neighbours in the whole frame. Every other figure is of \
         the whole mask.\n\n",
    );
    text.extend(lines);
}

/// Which figures of a `(width, height, frames)` mask are measured on part of it (the bounds of
/// [`stbn_gen::analysis`]: [`spectrum_fold`], [`FilteredErrorOptions::window`]), in words;
/// `None` when every figure is of the whole mask.
fn partial_measures((w, h, d): (usize, usize, usize)) -> Option<String> {
    let grid = |(a, b): (usize, usize), (fa, fb): (usize, usize), axes: [&str; 2]| {
        let every = |f: usize, axis: &str| match f {
            1 => format!("every {axis} frequency"),
            2 => format!("every 2nd {axis} frequency"),
            3 => format!("every 3rd {axis} frequency"),
            f => format!("every {f}th {axis} frequency"),
        };
        format!(
            "the {}×{} grid of {} and {}",
            a / fa,
            b / fb,
            every(fa, axes[0]),
            every(fb, axes[1])
        )
    };
    let mut parts = Vec::new();
    let xy = spectrum_fold(w, h);
    if xy != (1, 1) {
        parts.push(format!(
            "spatial low band, radial spectrum and XY image on {}",
            grid((w, h), xy, ["x", "y"])
        ));
    }
    let xz = spectrum_fold(w, d);
    if xz != (1, 1) {
        parts.push(format!(
            "XZ image on {}",
            grid((w, d), xz, ["x", "temporal"])
        ));
    }
    let window = FilteredErrorOptions::default().window(w, h);
    if window != (w, h) {
        parts.push(format!(
            "filtered error over the {}×{} pixels at each frame's origin",
            window.0, window.1
        ));
    }
    (!parts.is_empty()).then(|| parts.join("; "))
}

/// The DFT magnitude images of every mask, as a table of XY and XZ images.
fn dft_section(text: &mut String, rows: &[Row]) {
    text.push_str(&format!(
        "\n## DFT magnitude images\n\n\
         Like the paper's Fig. 5. **XY**: the 2D DFT magnitude of every frame (mean removed, \
         normalised by the frame's variance so white noise has mean power 1), averaged over \
         frames; horizontal = x frequency, vertical = y frequency. **XZ**: the 2D DFT magnitude \
         of each x–frame plane (one per row y), averaged over rows; horizontal = x frequency, \
         vertical = temporal frequency. DC (0 by construction) is at the centre, Nyquist at the \
         edges. Grey level = magnitude on one linear scale for every mask: black 0, white \
         {full} and above; white noise is a flat grey of level ≈ 113 (mean magnitude √π/2 ≈ \
         0.89). Blue noise in space is black around the centre of XY; a mask blue over time is \
         black along the horizontal line through the centre of XZ. Images are enlarged by \
         whole pixels to at least {side} pixels. Each line: the mask, its XY image (x → , \
         y ↓), its XZ image (x → , time ↓).\n\n",
        full = SpectrumImage::GRAY_FULL_SCALE,
        side = spectrum_images::MIN_SIDE,
    ));
    for (i, row) in rows.iter().enumerate() {
        let [xy, xz] = dft_files(i, row);
        let dir = spectrum_images::DFT_DIR;
        writeln!(
            text,
            "- `{}`: ![XY]({dir}/{xy}) ![XZ]({dir}/{xz})",
            output::line_text(&row.name)
        )
        .expect("String");
    }
}

/// The list of CSV files, linked.
fn csv_section(text: &mut String, rows: &[Row]) {
    text.push_str(
        "\n## Numbers as CSV\n\n\
         Every figure and curve above, one header row each, one row per mask and point:\n\n",
    );
    // The columns do not depend on the masks: the tables of no mask name them.
    for file in csv::files(&[], csv::has_vector(rows)) {
        writeln!(
            text,
            "- [`{name}`]({dir}/{name}): {about}; columns {columns}.",
            name = file.name,
            dir = csv::CSV_DIR,
            about = file.about,
            columns = file.table.csv_header().collect::<Vec<_>>().join(", "),
        )
        .expect("String");
    }
}

/// The convergence figures of every integrand, as an aligned text block.
fn convergence_section(text: &mut String, rows: &[Row]) {
    let names: Vec<String> = rows
        .iter()
        .map(|row| output::line_text(&row.name))
        .collect();
    let width = names
        .iter()
        .map(|name| name.chars().count())
        .max()
        .unwrap_or(4)
        .max(4);
    let at = CONVERGENCE_AT.map(|n| format!("{n:>7}")).join("");
    text.push_str(
        "\n## Convergence\n\n\
         RMSE over pixels of the per-pixel estimate of ∫₀¹ f after n samples (one per frame from \
         frame `start`, wrapping after the last), for the ramp f(x) = x (∫ = ½), the step \
         f(x) = [x < ½] (∫ = ½) and the sine f(x) = sin(πx) (∫ = 2/π); Monte Carlo running mean \
         and EMA (α = 0.1). Each mask is measured from frame 0 and from frame ⌊frames/3⌋: a mask \
         that is blue over time converges as fast from any start. Scalar masks only: vector \
         masks integrate their own test functions (\"Vector masks in their own space\").\n\n\
         ```text\n",
    );
    writeln!(text, "{:width$}  integrand  estimator  start{at}", "mask").expect("String");
    for (row, name) in rows.iter().zip(&names) {
        if row.vector.is_some() {
            continue;
        }
        for integrand in Integrand::ALL {
            let starts = [
                (0, row.curves(integrand)),
                (row.size.2 / 3, row.curves_late(integrand)),
            ];
            for (estimator, (start, curves)) in Estimator::ALL
                .into_iter()
                .flat_map(|e| starts.map(|s| (e, s)))
            {
                let curve = estimator.curve(curves);
                let figures: String = CONVERGENCE_AT
                    .iter()
                    .map(|&n| {
                        curve
                            .get(n - 1)
                            .map_or("    n/a".to_owned(), |e| format!("{e:7.4}"))
                    })
                    .collect();
                writeln!(
                    text,
                    "{:width$}  {:9}  {:9}  {start:5}{figures}",
                    name,
                    integrand.name(),
                    estimator.label(),
                )
                .expect("String");
            }
        }
    }
    text.push_str("```\n");
}

/// The plots, with their axes and the colour legend.
fn plot_section(text: &mut String, rows: &[Row]) {
    text.push_str("\n## Plots\n\nColours: ");
    let legend: Vec<String> = rows
        .iter()
        .enumerate()
        .map(|(i, row)| {
            let name = output::line_text(&row.name);
            format!("{} = {name}", output::colour_name(i))
        })
        .collect();
    text.push_str(&legend.join(", "));
    text.push_str(
        ". Titles, tick labels and legends are drawn only where a TrueType font was found \
         (`$STBN_PLOT_FONT` or a system font); the axes are stated under each plot either way. \
         A curve that lies on an earlier one is drawn dashed over it, so both colours show; the \
         text under the plot names them. Vector masks have no curve in the convergence plots \
         of the scalar integrands.\n",
    );
    for Figure { file, chart, axes } in figures(rows) {
        let title = &chart.title;
        let lies_on = chart.coincident();
        let same: Vec<String> = lies_on
            .iter()
            .enumerate()
            .filter_map(|(i, j)| {
                let j = (*j)?;
                Some(format!(
                    "{} (`{}`) lies on {} (`{}`)",
                    output::colour_name(i),
                    output::line_text(&rows[i].name),
                    output::colour_name(j),
                    output::line_text(&rows[j].name)
                ))
            })
            .collect();
        let same = if same.is_empty() {
            String::new()
        } else {
            format!(" Same curve, drawn dashed: {}.", same.join("; "))
        };
        // Brackets would end the image's alt text early.
        let alt = title.replace(['[', ']'], "");
        write!(
            text,
            "\n**{title}.** {axes}{same}\n\n![{alt}]({PLOT_DIR}/{file})\n"
        )
        .expect("String");
    }
}

/// `curve` after each of [`CONVERGENCE_AT`] samples, `a / b / c / d` with 4 decimals.
fn at_samples(curve: &[f64]) -> String {
    CONVERGENCE_AT
        .map(|n| {
            curve
                .get(n - 1)
                .map_or("n/a".to_owned(), |e| format!("{e:.4}"))
        })
        .join(" / ")
}

fn size((width, height, depth): (usize, usize, usize)) -> String {
    format!("{width}×{height}×{depth}")
}

fn band(value: Option<f64>) -> String {
    value.map_or("n/a".to_owned(), |v| format!("{v:.4}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs;

    fn ramp_field() -> Vec<f64> {
        (0..64 * 4)
            .map(|i| ((i * 37) % 256) as f64 / 256.0)
            .collect()
    }

    fn row(name: &str, seconds: Option<f64>, temporal: Option<f64>) -> Row {
        let values = ramp_field();
        let field = Field::new(8, 8, 4, &values).unwrap();
        Row {
            name: name.to_owned(),
            size: (64, 32, 1),
            kind: "png 8-bit".to_owned(),
            seconds,
            spatial: Some(0.00123456),
            temporal,
            histogram: 0.0,
            pixel_histogram: 0.25,
            filtered: vec![0.5, 0.012345],
            ..Row::measure(name, "png 8-bit", seconds, &field).0
        }
    }

    #[test]
    fn convergence_curves_end_at_the_mask_depth_and_vector_masks_draw_none() {
        let values = ramp_field();
        let field = Field::new(8, 8, 4, &values).unwrap();
        let scalar = Row::measure("scalar", "png 8-bit", None, &field).0;
        let vector = Row {
            vector: Some(VectorFigures {
                space: "vec2",
                components: Vec::new(),
                white: stbn_gen::analysis::DistributionDeviation {
                    frame: 0.0,
                    pixel: 0.0,
                },
                tests: Vec::new(),
            }),
            ..Row::measure("vector", "Vec2", None, &field).0
        };
        let figures = figures(&[scalar, vector]);
        let convergence: Vec<&Figure> = figures
            .iter()
            .filter(|f| f.file.starts_with("convergence_"))
            .collect();
        assert!(!convergence.is_empty());
        for figure in convergence {
            let series = &figure.chart.series;
            // Four frames, four samples: no point past the depth, where the frames repeat.
            assert_eq!(series[0].points.len(), 4, "{}", figure.file);
            assert!(series[1].points.is_empty(), "{}", figure.file);
        }
    }

    #[test]
    fn table_rows_show_missing_figures_as_n_a_and_escape_pipes() {
        let text = markdown(
            "Intro.",
            &[
                row("a|b", None, None),
                row("scalar", Some(1.234), Some(0.5)),
            ],
        );
        // The reading guide, the verdicts and the advice on kinds come first, then the table.
        assert!(
            text.starts_with("# Blue-noise mask report\n\nIntro.\n\n## How to read this report\n")
        );
        let order = [
            "## Verdict\n",
            "## Which mask to pick\n",
            "## Figures\n\n| mask |",
        ];
        let at: Vec<usize> = order.iter().map(|h| text.find(h).expect(h)).collect();
        assert!(at.windows(2).all(|w| w[0] < w[1]), "{text}");
        assert!(text.contains("- `scalar` (png 8-bit): "), "{text}");
        assert!(
            text.contains(
                "| a\\|b | 64×32×1 | png 8-bit | n/a | 0.0012 | n/a | 0.0000 | 0.2500 | 0.01235 |"
            ),
            "{text}"
        );
        assert!(
            text.contains("| scalar | 64×32×1 | png 8-bit | 1.23 | 0.0012 | 0.5000 | 0.0000 |")
        );
        assert!(text.contains("**White noise = 1**"));
        // The first sample of the step is 0 or 1 everywhere: error exactly ½.
        assert!(text.contains("| 0.5000 / "), "{text}");
        assert!(text.contains("![Filtered error per frame](plots/filtered_error.png)"));
        assert!(text.contains("blue = a|b, orange = scalar."));
        // DFT images per mask, file names reduced to safe characters, and the CSV list.
        assert!(text.contains("- `a|b`: ![XY](dft/00_a_b_xy.png) ![XZ](dft/00_a_b_xz.png)\n"));
        assert!(text.contains("- [`convergence.csv`](csv/convergence.csv): "));
        // Every integrand and estimator has a line per mask; 4 frames wrap up to 64 samples.
        let lines = text.lines().filter(|l| l.starts_with("scalar ")).count();
        assert_eq!(lines, 12, "{text}");
    }

    #[test]
    fn a_name_with_line_breaks_and_pipes_stays_one_row_and_one_line() {
        let evil = "two\nlines | and `ticks`\r\u{1b}[31m";
        let text = markdown(
            "Intro.",
            &[row(evil, None, None), row("scalar", None, None)],
        );
        let shown = "two\\nlines | and 'ticks'\\r\\u{1b}[31m";
        // The figures table: heading, rule and one row per mask, each a single line.
        let table = &text[text.find("## Figures\n\n").unwrap()..];
        let rows: Vec<&str> = table
            .lines()
            .skip(2)
            .take_while(|l| l.starts_with('|'))
            .collect();
        assert_eq!(rows.len(), 2 + 2, "{table}");
        let escaped = shown.replace('|', "\\|");
        assert!(
            rows[2].starts_with(&format!("| {escaped} | 64×32×1 |")),
            "{}",
            rows[2]
        );
        // Verdicts, DFT list, legend and convergence block: the escaped name, never a raw break.
        assert!(
            text.contains(&format!("- `{shown}` (png 8-bit): ")),
            "{text}"
        );
        assert!(text.contains(&format!("- `{shown}`: ![XY]")), "{text}");
        assert!(
            text.contains(&format!("blue = {shown}, orange = scalar.")),
            "{text}"
        );
        let block = text.lines().filter(|l| l.starts_with(shown)).count();
        assert_eq!(block, 12, "{text}");
        assert!(!text.contains('\r') && !text.contains('\u{1b}'));
        assert!(!text.lines().any(|l| l.starts_with("lines")), "{text}");
    }

    #[test]
    fn masks_too_large_to_measure_whole_say_what_was_measured() {
        assert_eq!(partial_measures((256, 256, 128)), None);
        assert_eq!(partial_measures((1024, 1024, 64)), None);
        assert_eq!(
            partial_measures((4096, 4096, 4)).unwrap(),
            "spatial low band, radial spectrum and XY image on the 2048×2048 grid of every 2nd \
             x frequency and every 2nd y frequency; filtered error over the 1024×1024 pixels at \
             each frame's origin"
        );
        assert_eq!(
            partial_measures((65536, 1, 1024)).unwrap(),
            "XZ image on the 4096×1024 grid of every 16th x frequency and every temporal \
             frequency"
        );
        let large = Row {
            size: (4096, 4096, 4),
            ..row("big", None, None)
        };
        let text = markdown("Intro.", &[row("small", None, None), large]);
        assert!(text.contains("\n## Masks measured in part\n"), "{text}");
        assert!(
            text.contains("- `big` (4096×4096×4): spatial low band"),
            "{text}"
        );
        assert!(!text.contains("- `small` (64×32×1)"), "{text}");
        let small = markdown("Intro.", &[row("small", None, None)]);
        assert!(!small.contains("measured in part"));
    }

    #[test]
    fn summary_names_mask_size_time_bands_and_filtered_error() {
        assert_eq!(
            row("scalar", Some(0.5), Some(0.04)).summary(),
            "scalar: 64×32×1 png 8-bit in 0.50 s; low band (white noise = 1): spatial 0.0012, \
             temporal 0.0400; filtered error 0.01235"
        );
        assert!(row("x", None, None).summary().contains("temporal n/a;"));
    }

    #[test]
    fn measure_reads_the_field() {
        let values: Vec<f64> = (0..64).map(|i| (i as f64 + 0.5) / 64.0).collect();
        let field = Field::new(8, 8, 1, &values).unwrap();
        let (row, spectra) = Row::measure("ramp", "png 8-bit", None, &field);
        assert_eq!((spectra.xy.width, spectra.xy.height), (8, 8));
        assert_eq!((spectra.xz.width, spectra.xz.height), (8, 1));
        assert_eq!(row.size, (8, 8, 1));
        assert_eq!(row.temporal, None);
        assert_eq!(row.histogram, 0.0);
        // A ramp along the rows is all low frequency: far above white.
        assert!(row.spatial.unwrap() > 1.0);
        assert_eq!(row.filtered.len(), 1);
        assert_eq!(row.convergence.len(), Integrand::ALL.len());
        // One frame: every sample repeats it, so the Monte Carlo error never changes.
        let step = row.curves(Integrand::Step);
        assert_eq!(step.monte_carlo.len(), CONVERGENCE_SAMPLES);
        assert!(step.monte_carlo.iter().all(|&e| e == step.monte_carlo[0]));
    }

    #[test]
    fn write_creates_the_report_and_every_linked_file() {
        let dir = tempfile::tempdir().unwrap();
        // `b` is measured past its depth, as an encoded 4×2×2 mask.
        let ranks: Vec<u32> = (0..16).collect();
        let blob = stbn_build_support::encode::encode_volume(
            &stbn_gen::Volume::from_global_ranks(4, 2, 2, &ranks),
            stbn_runtime::Encoding::Unorm8,
            stbn_runtime::Compression::None,
        );
        let encoded = Stbn::from_bytes(&blob).unwrap();
        let rows = [
            row("a", None, None),
            Row {
                past_depth: past_depth::measure_scalar(&encoded),
                ..row("b", Some(1.0), Some(0.3))
            },
        ];
        let values = ramp_field();
        let (_, spectra) = Row::measure("x", "", None, &Field::new(8, 8, 4, &values).unwrap());
        let mut report = Report::create(dir.path()).unwrap();
        for row in &rows {
            report.push(row.clone(), &spectra).unwrap();
        }
        let path = report.finish("Intro.", "").unwrap();
        let text = fs::read_to_string(path).unwrap();
        // Every `](target)` of the report: plots, DFT images and CSV files.
        let links: Vec<&str> = text
            .split("](")
            .skip(1)
            .map(|rest| &rest[..rest.find(')').unwrap()])
            .collect();
        let count = |ext: &str| links.iter().filter(|l| l.ends_with(ext)).count();
        // The plots of every mask, the convergence plots, a DFT pair per mask and the one plot
        // past the depth.
        assert_eq!(
            count(".png"),
            3 + 2 * Integrand::ALL.len() + 2 * rows.len() + 1
        );
        assert_eq!(count(".csv"), 6);
        assert!(
            text.contains("\n- `a`: not measured: analysed slices and baselines are not encoded"),
            "{text}"
        );
        assert!(
            text.contains("\n**`b`** (4×2×2, depth 2): RMSE over all 4×2 pixels."),
            "{text}"
        );
        for link in links {
            let bytes = fs::read(dir.path().join(link)).unwrap();
            if link.ends_with(".png") {
                assert!(bytes.starts_with(b"\x89PNG"), "{link}");
            } else {
                assert!(bytes.starts_with(b"mask,"), "{link}");
            }
        }
        // The CSV files hold every point: 2 frames of filtered error per mask, 64 samples of
        // each integrand, estimator and start per mask.
        let lines = |file: &str| {
            let text = fs::read_to_string(dir.path().join("csv").join(file)).unwrap();
            text.lines().count()
        };
        assert_eq!(lines("summary.csv"), 1 + rows.len());
        // `b` only: 3 integrands, 3 readings, 6 frame counts.
        assert_eq!(lines("convergence_past_depth.csv"), 1 + 3 * 3 * 6);
        assert_eq!(lines("filtered_error.csv"), 1 + 2 * rows.len());
        assert_eq!(
            lines("convergence.csv"),
            1 + rows.len() * Integrand::ALL.len() * 2 * 2 * CONVERGENCE_SAMPLES
        );
        let summary = fs::read_to_string(dir.path().join("csv/summary.csv")).unwrap();
        let a = summary.lines().nth(1).unwrap();
        assert!(
            a.starts_with("a,png 8-bit,64,32,1,,0.00123456,,0,0.25,0.012345,0.5,"),
            "{a}"
        );
    }
}
