//! What the report measures of a vector mask in its own space ([`stbn_gen::analysis`] docs,
//! "Vector masks"): spectra and low bands of each decoded component, the distribution of the
//! values against the space's pdf, and the convergence of test functions beside white noise of
//! the same distribution.

use std::fmt::Write as _;

use stbn_gen::SampleSpace;
use stbn_gen::analysis::{
    Convergence, ConvergenceOptions, DistributionDeviation, Field, FilteredErrorOptions,
    SpectrumImage, TestFunction, VectorField, dft_xy_image, dft_xz_image, distribution_deviation,
    filtered_error_vector, radial_spectrum, spatial_low_band, temporal_low_band, temporal_spectrum,
    vector_convergence,
};

use stbn_runtime::Stbn;

use super::{CONVERGENCE_SAMPLES, Estimator, Figure, HISTOGRAM_BINS, Row, Spectra, at_samples};
use crate::output::{self, Axis, Cell, Chart, Column, Series, SeriesLabelPosition, Style, Table};

/// The seed of the shuffle that makes white noise of a mask's own values.
const WHITE_SEED: u64 = 1;

/// The sample count the convergence ratio to white noise is read at.
pub const RATIO_AT: usize = 16;

/// The figures only a vector mask has.
#[derive(Clone, Debug, PartialEq)]
pub struct VectorFigures {
    /// The space, [`SampleSpace::name`] (e.g. `cosine_hemisphere`).
    pub space: &'static str,
    /// The low bands of each decoded component.
    pub components: Vec<ComponentBands>,
    /// [`distribution_deviation`] of white noise of the same distribution (the mask's values
    /// shuffled over pixels and frames): the reference for [`Row::histogram`] and
    /// [`Row::pixel_histogram`].
    pub white: DistributionDeviation,
    /// Each [`TestFunction`], in the order of [`TestFunction::ALL`].
    pub tests: Vec<TestCurves>,
}

/// The low bands of one decoded component (dimensionless, white noise = 1).
#[derive(Clone, Debug, PartialEq)]
pub struct ComponentBands {
    /// `x`, `y`, `z`, `w` (`u`, `v` for image points).
    pub name: &'static str,
    /// [`spatial_low_band`] of the component.
    pub spatial: Option<f64>,
    /// [`temporal_low_band`] of the component.
    pub temporal: Option<f64>,
}

/// The convergence of one test function, for the mask and for white noise of its distribution.
#[derive(Clone, Debug, PartialEq)]
pub struct TestCurves {
    /// The function.
    pub function: TestFunction,
    /// [`TestFunction::describe`] in the mask's space.
    pub about: &'static str,
    /// [`vector_convergence`] of the mask over [`CONVERGENCE_SAMPLES`] samples from frame 0.
    pub mask: Convergence,
    /// The same for the shuffled values.
    pub white: Convergence,
}

impl TestCurves {
    /// The mask's Monte Carlo RMSE over white noise's after `n` samples (white noise = 1, lower
    /// is better); `None` past the curves or when white noise's error is 0.
    pub fn ratio(&self, n: usize) -> Option<f64> {
        let (ours, white) = (
            self.mask.monte_carlo.get(n - 1)?,
            self.white.monte_carlo.get(n - 1)?,
        );
        (*white > 0.0).then(|| ours / white)
    }
}

impl VectorFigures {
    /// The largest [`TestCurves::ratio`] at [`RATIO_AT`] samples over the test functions: how
    /// the mask integrates its worst function.
    pub fn worst_ratio(&self) -> Option<f64> {
        self.tests
            .iter()
            .filter_map(|t| t.ratio(RATIO_AT))
            .fold(None, |worst, r| Some(worst.map_or(r, |w: f64| w.max(r))))
    }
}

/// The steps of [`measure`], in order, named for a progress bar.
pub const STEPS: [&str; 8] = [
    "low bands per component",
    "distribution against the pdf",
    "DFT images",
    "spectra",
    "filtered error",
    "test functions",
    "convergence past the depth",
    "done",
];

/// Measures the vector mask `field` as mask `name`, and `encoded`, the mask it was encoded to,
/// past its depth with the test functions of its space, calling `progress(step, name)` before
/// each of [`STEPS`].
pub fn measure(
    name: &str,
    kind: &str,
    seconds: Option<f64>,
    field: &VectorField,
    encoded: &Stbn<'_>,
    progress: &mut dyn FnMut(usize, &'static str),
) -> (Row, Spectra) {
    let mut step = 0;
    let mut next = || {
        progress(step, STEPS[step]);
        step += 1;
    };
    let (w, h, d) = field.size();
    let space = field.space();
    next();
    let values = field.components();
    let components: Vec<Field> = values
        .iter()
        .map(|c| Field::new(w, h, d, c).expect("components are mapped to [0, 1]"))
        .collect();
    let names = component_names(space);
    let bands: Vec<ComponentBands> = components
        .iter()
        .zip(names)
        .map(|(c, &name)| ComponentBands {
            name,
            spatial: spatial_low_band(c),
            temporal: temporal_low_band(c),
        })
        .collect();
    next();
    let shuffled = field.shuffled(WHITE_SEED);
    let white_field =
        VectorField::new(space, (w, h, d), &shuffled).expect("a shuffle keeps the shape");
    let distribution = distribution_deviation(field, HISTOGRAM_BINS);
    let white = distribution_deviation(&white_field, HISTOGRAM_BINS);
    next();
    let xy = mean_image(components.iter().map(dft_xy_image));
    let xz = mean_image(components.iter().map(dft_xz_image));
    next();
    let radial = mean_curve(components.iter().map(radial_spectrum));
    let temporal = mean_curve(components.iter().map(temporal_spectrum));
    next();
    let filtered = filtered_error_vector(&components, FilteredErrorOptions::default())
        .expect("components share one size");
    next();
    let options = ConvergenceOptions::new(CONVERGENCE_SAMPLES);
    let tests = TestFunction::ALL
        .iter()
        .map(|&function| {
            let exact = function.expected(space);
            TestCurves {
                function,
                about: function.describe(space),
                mask: vector_convergence(field, function, exact, options),
                white: vector_convergence(&white_field, function, exact, options),
            }
        })
        .collect();
    next();
    let past_depth = super::past_depth::measure_vector(encoded, space);
    next();
    let mean_band = |band: fn(&ComponentBands) -> Option<f64>| {
        let known: Vec<f64> = bands.iter().filter_map(band).collect();
        (!known.is_empty()).then(|| known.iter().sum::<f64>() / known.len() as f64)
    };
    let row = Row {
        name: name.to_owned(),
        size: (w, h, d),
        kind: kind.to_owned(),
        seconds,
        spatial: mean_band(|b| b.spatial),
        temporal: mean_band(|b| b.temporal),
        histogram: distribution.frame,
        pixel_histogram: distribution.pixel,
        radial,
        temporal_spectrum: temporal,
        filtered,
        convergence: Vec::new(),
        convergence_late: Vec::new(),
        vector: Some(VectorFigures {
            space: space.name(),
            components: bands,
            white,
            tests,
        }),
        past_depth,
    };
    (row, Spectra { xy, xz })
}

/// The names of `space`'s components.
fn component_names(space: &SampleSpace) -> &'static [&'static str] {
    match space {
        SampleSpace::ImagePoints(_) => &["u", "v"],
        _ => &["x", "y", "z", "w"][..space.dims()],
    }
}

/// The pixel-wise mean of images of one size.
fn mean_image(images: impl Iterator<Item = SpectrumImage>) -> SpectrumImage {
    let images: Vec<SpectrumImage> = images.collect();
    let mut mean = images[0].clone();
    for image in &images[1..] {
        mean.values
            .iter_mut()
            .zip(&image.values)
            .for_each(|(m, v)| *m += v);
    }
    let n = images.len() as f64;
    mean.values.iter_mut().for_each(|m| *m /= n);
    mean
}

/// The entry-wise mean of curves of one length.
fn mean_curve(curves: impl Iterator<Item = Vec<f64>>) -> Vec<f64> {
    let curves: Vec<Vec<f64>> = curves.collect();
    let n = curves.len() as f64;
    (0..curves[0].len())
        .map(|i| curves.iter().map(|c| c[i]).sum::<f64>() / n)
        .collect()
}

/// The file of `row`'s convergence plot (row `index` of the report).
fn plot_file(index: usize, row: &Row) -> String {
    let [xy, _] = super::dft_files(index, row);
    let stem = xy.trim_end_matches("_xy.png");
    format!("vector_{stem}.png")
}

/// One plot per vector mask: the Monte Carlo RMSE of each test function for the mask and for
/// white noise of its distribution.
pub fn figures(rows: &[Row]) -> Vec<Figure> {
    let mut figures = Vec::new();
    for (index, row) in rows.iter().enumerate() {
        let Some(vector) = &row.vector else { continue };
        let series = vector
            .tests
            .iter()
            .flat_map(|t| {
                let curve = |name: String, c: &[f64]| Series {
                    name,
                    points: c
                        .iter()
                        .enumerate()
                        .map(|(k, &e)| ((k + 1) as f64, e))
                        .collect(),
                    labels: Vec::new(),
                    style: Style::Line,
                };
                [
                    curve(
                        format!("{}: {}", t.function.name(), output::line_text(&row.name)),
                        &t.mask.monte_carlo,
                    ),
                    curve(
                        format!("{}: white noise, same distribution", t.function.name()),
                        &t.white.monte_carlo,
                    ),
                ]
            })
            .collect();
        figures.push(Figure {
            file: plot_file(index, row),
            chart: Chart {
                title: format!(
                    "Test functions, {} ({}), Monte Carlo",
                    output::line_text(&row.name),
                    vector.space
                ),
                x: Axis::log_decades("samples", 0, 2),
                y: Axis::log_decades("RMSE over pixels", -3, 0),
                series,
                legend: SeriesLabelPosition::LowerLeft,
                reference: None,
            },
            axes: "x: samples, log scale 1 to 100; y: RMSE of the per-pixel estimate of the \
                   function's expectation, log scale 0.001 to 1. Each function twice: the mask, \
                   then white noise of the same distribution (its values shuffled); the mask \
                   should lie below.",
        });
    }
    figures
}

/// The report's section on vector masks: per-component low bands, distribution, and test
/// functions beside white noise; empty when no row is a vector mask.
pub fn section(text: &mut String, rows: &[Row]) {
    if rows.iter().all(|row| row.vector.is_none()) {
        return;
    }
    text.push_str(
        "\n## Vector masks in their own space\n\n\
         A vector mask is measured on its decoded values, not on its stored channels: the \
         components of each direction or point, and the *stratum coordinates* that map the \
         space's pdf to the uniform square (`(1 − z², φ/2π)` on the cosine hemisphere, \
         `((1 − z)/2, φ/2π)` on the sphere, the image's CDF for image spaces, the components \
         themselves for `Vec`). Its frame and pixel histogram deviations in the table above are \
         those of the stratum coordinates: 0 = every frame follows the pdf exactly, whatever the \
         pdf. Its low bands there are the mean over the components below.\n\n",
    );
    let mut table = Table::with_columns([
        Column::markdown_only("mask", false),
        Column::markdown_only("space", false),
        Column::markdown_only("component", false),
        Column::markdown_only("spatial low band (white = 1, lower = bluer)", true),
        Column::markdown_only("temporal low band (white = 1, lower = bluer)", true),
    ]);
    for row in rows {
        let Some(vector) = &row.vector else { continue };
        for c in &vector.components {
            table.push(vec![
                Cell::name(&row.name),
                Cell::text(vector.space),
                Cell::text(c.name),
                Cell::opt_fixed(c.spatial, 4),
                Cell::opt_fixed(c.temporal, 4),
            ]);
        }
    }
    text.push_str(&table.markdown());
    text.push_str(
        "\n**Distribution against the pdf**, beside white noise of the same distribution (the \
         mask's own values shuffled over pixels and frames). Frame: the worst relative deviation \
         of a frame's 16-bin histogram of a stratum coordinate (0 = exact). Pixel: the mean \
         Kolmogorov–Smirnov distance of each pixel's values over the frames from the pdf \
         (1/(2·frames) at best; lower is better).\n\n",
    );
    let mut table = Table::with_columns([
        Column::markdown_only("mask", false),
        Column::markdown_only("frame deviation (0 = exact)", true),
        Column::markdown_only("white noise", true),
        Column::markdown_only("pixel deviation (lower = better)", true),
        Column::markdown_only("white noise", true),
    ]);
    for row in rows {
        let Some(vector) = &row.vector else { continue };
        table.push(vec![
            Cell::name(&row.name),
            Cell::fixed(row.histogram, 4),
            Cell::fixed(vector.white.frame, 4),
            Cell::fixed(row.pixel_histogram, 4),
            Cell::fixed(vector.white.pixel, 4),
        ]);
    }
    text.push_str(&table.markdown());
    let at = super::CONVERGENCE_AT.map(|n| n.to_string()).join("/");
    let _ = write!(
        text,
        "\n**Test functions.** Each pixel estimates the expectation of a function under the \
         space's pdf from its values over the frames (one per frame from frame 0, wrapping \
         after the last), as a running mean (Monte Carlo); RMSE over pixels after {at} samples, \
         for the mask and for white noise of the same distribution, and their ratio at \
         {RATIO_AT} samples (white noise = 1, lower is better).\n\n"
    );
    let mut table = Table::with_columns([
        Column::markdown_only("mask", false),
        Column::markdown_only("function", false),
        Column::markdown_only(&format!("mask MC RMSE at {at}"), true),
        Column::markdown_only(&format!("white noise MC RMSE at {at}"), true),
        Column::markdown_only(
            &format!("ratio at {RATIO_AT} (white = 1, lower = better)"),
            true,
        ),
    ]);
    for row in rows {
        let Some(vector) = &row.vector else { continue };
        for t in &vector.tests {
            table.push(vec![
                Cell::name(&row.name),
                Cell::text(format!("{}: {}", t.function.name(), t.about)),
                Cell::text(at_samples(Estimator::MonteCarlo.curve(&t.mask))),
                Cell::text(at_samples(Estimator::MonteCarlo.curve(&t.white))),
                Cell::opt_fixed(t.ratio(RATIO_AT), 2),
            ]);
        }
    }
    text.push_str(&table.markdown());
    for figure in figures(rows) {
        text.push_str(&figure.markdown());
    }
}
