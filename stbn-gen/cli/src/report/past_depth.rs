//! "Convergence past the depth": how a mask's per-pixel running mean keeps converging after
//! `depth · {1, 2, 4, …, 32}` frames when it is read plainly (wrapping in time), progressively
//! ([`stbn_runtime::Stbn::progressive`]) and, for reference, as white noise of its distribution
//! ([`crate::past_depth`]), and how blue the error image of each is after the last count.

use std::fmt::Write as _;

use rayon::prelude::*;
use stbn_gen::SampleSpace;
use stbn_gen::analysis::{Integrand, TestFunction, image_low_band};
use stbn_runtime::{Stbn, VectorSample};

use super::{Figure, Row};
use crate::output::{self, Axis, Cell, Chart, Column, Series, SeriesLabelPosition, Style, Table};
use crate::past_depth::{DEPTH_MULTIPLES, Reading, frame_counts, running_mean_of, window};

/// The plot's file in the report's `plots/`.
pub const PLOT_FILE: &str = "convergence_past_depth.png";

/// The convergence past the depth of one encoded mask.
#[derive(Clone, Debug, PartialEq)]
pub struct PastDepth {
    /// The encoded mask's `(width, height, depth)`.
    pub size: (usize, usize, usize),
    /// The measured window at the frames' origin, `(width, height)` in pixels
    /// ([`crate::past_depth::window`]).
    pub window: (usize, usize),
    /// The frame counts measured at ([`frame_counts`]).
    pub frames: Vec<usize>,
    /// Each function of the mask's values: [`Integrand::ALL`] for scalar masks,
    /// [`TestFunction::ALL`] in the mask's space for vector masks.
    pub functions: Vec<FunctionCurves>,
}

/// The curves of one function, one per [`Reading`].
#[derive(Clone, Debug, PartialEq)]
pub struct FunctionCurves {
    /// `ramp`, `step`, `sine` ([`Integrand::name`]) or `smooth`, `edge`
    /// ([`TestFunction::name`]).
    pub name: &'static str,
    /// The discontinuous one (`step`, `edge`): the function the plot draws.
    pub plotted: bool,
    /// In the order of [`Reading::ALL`].
    pub readings: Vec<ReadingCurve>,
}

/// One reading's running-mean error.
#[derive(Clone, Debug, PartialEq)]
pub struct ReadingCurve {
    /// RMSE over the window's pixels of the running mean against the exact value, after each
    /// count of [`PastDepth::frames`]; same units as the function (values in `[0, 1]`).
    pub rmse: Vec<f64>,
    /// [`spatial_low_band`] of the error image after the last count (dimensionless, white
    /// noise ≈ 1, lower = bluer); `None` for a one-pixel window, and for an error image whose
    /// RMSE is below [`EXACT`] (no error to have a spectrum: rounding noise only).
    pub low_band: Option<f64>,
}

/// An RMSE below this is an exact estimate (values in `[0, 1]`: far below any quantisation step
/// of the encodings), whose error image has no spectrum to measure.
const EXACT: f64 = 1e-12;

/// Why a mask has no figures past the depth, for masks `analyze` measures (PNG slices and
/// baselines are not encoded masks the runtime samples).
pub const NOT_ENCODED: &str = "analysed slices and baselines are not encoded masks";

/// A function of a sample ([`VectorSample`]) with its exact expectation.
struct Function<'a> {
    name: &'static str,
    plotted: bool,
    exact: f64,
    eval: Box<dyn Fn(&VectorSample) -> f64 + Sync + 'a>,
}

/// The figures of a scalar mask: each of [`Integrand::ALL`] of the sampled value; an error
/// (saying why) for a mask too deep to measure ([`frame_counts`]).
pub fn measure_scalar(mask: &Stbn<'_>) -> Result<PastDepth, String> {
    let functions = Integrand::ALL
        .iter()
        .map(|&integrand| Function {
            name: integrand.name(),
            plotted: integrand == Integrand::Step,
            exact: integrand.integral(),
            eval: Box::new(move |s: &VectorSample| integrand.eval(f64::from(s.value.x))),
        })
        .collect();
    measure(mask, functions)
}

/// The figures of a vector mask of `space`: each of [`TestFunction::ALL`] of the sampled vector,
/// against [`TestFunction::expected`]. An error (saying why) when the encoded mask's components
/// are not the space's, so the test functions do not apply, or it is too deep to measure.
pub fn measure_vector(mask: &Stbn<'_>, space: &SampleSpace) -> Result<PastDepth, String> {
    let dims = usize::from(mask.dims());
    if dims != space.dims() || dims > 4 {
        return Err(format!(
            "the encoded mask has {dims} components and the space {} has {}, so its test \
             functions do not apply",
            space.name(),
            space.dims()
        ));
    }
    let functions = TestFunction::ALL
        .iter()
        .map(|&function| Function {
            name: function.name(),
            plotted: function == TestFunction::Edge,
            exact: function.expected(space),
            eval: Box::new(move |s: &VectorSample| function.eval(space, &s.value.to_array())),
        })
        .collect();
    measure(mask, functions)
}

/// Every reading of every function of `mask` over its window: the curves run in parallel, each
/// deterministic, so the figures do not depend on threads. An error for a mask deeper than the
/// frames one curve reads at most.
fn measure(mask: &Stbn<'_>, functions: Vec<Function<'_>>) -> Result<PastDepth, String> {
    let (w, h, d) = (
        mask.width() as usize,
        mask.height() as usize,
        mask.depth() as usize,
    );
    let window = window(w, h, d);
    let frames = frame_counts(d);
    if frames.is_empty() {
        return Err(format!(
            "its {d} frames are more than the 2²⁵ frames a curve reads at most"
        ));
    }
    let jobs: Vec<(usize, Reading)> = (0..functions.len())
        .flat_map(|f| Reading::ALL.map(|r| (f, r)))
        .collect();
    let curves: Vec<ReadingCurve> = jobs
        .par_iter()
        .map(|&(f, reading)| {
            let function = &functions[f];
            let mean = running_mean_of(mask, reading, window, &frames, function.exact, |s| {
                (function.eval)(s)
            });
            let exact = mean.rmse.last().is_some_and(|&e| e < EXACT);
            ReadingCurve {
                low_band: image_low_band(window.0, window.1, &mean.error).filter(|_| !exact),
                rmse: mean.rmse,
            }
        })
        .collect();
    let mut curves = curves.into_iter();
    Ok(PastDepth {
        size: (w, h, d),
        window,
        frames,
        functions: functions
            .iter()
            .map(|f| FunctionCurves {
                name: f.name,
                plotted: f.plotted,
                readings: curves.by_ref().take(Reading::ALL.len()).collect(),
            })
            .collect(),
    })
}

/// The report's section: what is measured, then per mask a table of RMSE by frame count and
/// reading, the low bands of the error images and the plot; a line for each mask not measured.
pub fn section(text: &mut String, rows: &[Row]) {
    let last = DEPTH_MULTIPLES[DEPTH_MULTIPLES.len() - 1];
    let multiples = DEPTH_MULTIPLES.map(|m| m.to_string()).join(", ");
    let _ = write!(
        text,
        "\n## Convergence past the depth\n\n\
         A renderer that accumulates more frames than a mask has reads it past its depth. Each \
         pixel's running mean of a function of its samples is measured after depth · \
         {{{multiples}}} frames, as the RMSE over pixels against the exact expectation, for \
         three readings of the encoded mask (through `stbn_runtime`, the bytes a user embeds): \
         **wrap**, plain `sample`, which repeats the mask's frames, so its error stops falling at \
         the depth; **progressive**, `Stbn::progressive()`, which reads every later pass through \
         the depth shifted by an R2 offset, so a pixel keeps meeting new values; **white**, white \
         noise of the mask's own distribution (every pixel and frame draws a voxel of the mask \
         at random, by a keyed hash of pixel and frame: independent draws of the encoded \
         values). Functions: ramp, step and sine of scalar values (\"Convergence\"); the test \
         functions of vector masks' spaces (\"Vector masks in their own space\"). Masks larger \
         than {side}×{side} pixels a frame are measured over their top-left {side}×{side} \
         pixels (masks deeper than 64 frames over a smaller square, so that a curve reads at \
         most 2²⁵ pixel-frames); each mask's line says what was measured. Under each table: the \
         spatial low band of the error image (mean − exact, per pixel) after {last} · depth \
         frames, white noise = 1, lower = bluer: the error a progressive mask leaves should \
         stay blue (n/a: a one-pixel window, or an exact estimate, whose error has no \
         spectrum).\n",
        side = crate::past_depth::WINDOW_SIDE,
    );
    for row in rows {
        let name = output::line_text(&row.name);
        let figures = match &row.past_depth {
            Ok(figures) => figures,
            Err(why) => {
                let _ = writeln!(text, "\n- `{name}`: not measured: {why}.");
                continue;
            }
        };
        let (w, h, d) = figures.size;
        let window = if figures.window == (w, h) {
            format!("all {w}×{h} pixels")
        } else {
            format!(
                "the top-left {}×{} pixels of {w}×{h}",
                figures.window.0, figures.window.1
            )
        };
        let _ = write!(
            text,
            "\n**`{name}`** ({}, depth {d}): RMSE over {window}.\n\n",
            super::size(figures.size)
        );
        let mut columns = vec![
            Column::markdown_only("frames", true),
            Column::markdown_only("× depth", true),
        ];
        for function in &figures.functions {
            for reading in Reading::ALL {
                columns.push(Column::markdown_only(
                    &format!("{}: {}", function.name, reading.name()),
                    true,
                ));
            }
        }
        let mut table = Table::with_columns(columns);
        for (k, &frames) in figures.frames.iter().enumerate() {
            let mut cells = vec![Cell::int(frames as u64), Cell::int((frames / d) as u64)];
            for function in &figures.functions {
                cells.extend(function.readings.iter().map(|r| Cell::sig(r.rmse[k], 3)));
            }
            table.push(cells);
        }
        text.push_str(&table.markdown());
        let after = figures.frames.last().copied().unwrap_or(0);
        let bands: Vec<String> = figures
            .functions
            .iter()
            .map(|function| {
                let readings: Vec<String> = Reading::ALL
                    .iter()
                    .zip(&function.readings)
                    .map(|(reading, curve)| {
                        let band = curve
                            .low_band
                            .map_or("n/a".to_owned(), |b| format!("{b:.2}"));
                        format!("{} {band}", reading.name())
                    })
                    .collect();
                format!("{}: {}", function.name, readings.join(", "))
            })
            .collect();
        let _ = writeln!(
            text,
            "\nSpatial low band of the error image after {after} frames (white = 1, lower = \
             bluer): {}.",
            bands.join("; ")
        );
    }
    if let Some(figure) = figure(rows) {
        text.push_str(&figure.markdown());
    }
}

/// The plot: the RMSE of each measured mask's discontinuous function (step, edge) against
/// frames ÷ depth, log–log, one series per mask and reading with a non-zero error; `None` when
/// there is none.
pub fn figure(rows: &[Row]) -> Option<Figure> {
    let mut series = Vec::new();
    for row in rows {
        let Ok(figures) = &row.past_depth else {
            continue;
        };
        let depth = figures.size.2 as f64;
        let Some(function) = figures.functions.iter().find(|f| f.plotted) else {
            continue;
        };
        for (reading, curve) in Reading::ALL.iter().zip(&function.readings) {
            // A log axis cannot show an exact (zero) error: such points are left out, and a
            // series with none left is not drawn or named.
            let points: Vec<(f64, f64)> = figures
                .frames
                .iter()
                .zip(&curve.rmse)
                .filter(|&(_, &e)| e > 0.0)
                .map(|(&n, &e)| (n as f64 / depth, e))
                .collect();
            if points.is_empty() {
                continue;
            }
            series.push(Series {
                name: format!("{} {}", output::line_text(&row.name), reading.name()),
                points,
                labels: Vec::new(),
                style: Style::LineAndPoints,
            });
        }
    }
    if series.is_empty() {
        return None;
    }
    Some(Figure {
        file: PLOT_FILE.to_owned(),
        chart: Chart {
            title: "Convergence past the depth: step (scalar) or edge (vector), Monte Carlo"
                .to_owned(),
            x: Axis::log_decades("frames ÷ mask depth", 0, 4),
            y: Axis::log("RMSE over pixels"),
            series,
            // The data end at 32 × depth, within the left 40% of the axis: the legend goes right.
            legend: SeriesLabelPosition::UpperRight,
            reference: None,
        },
        axes: "Each mask's step (scalar) or edge (vector) function, read three ways: wrap stays \
               flat past 1 × depth, white noise falls as 1/√frames, a progressive mask keeps \
               falling.",
    })
}

/// The CSV rows of `row` for `convergence_past_depth.csv`: mask, function, reading, frames,
/// frames ÷ depth, RMSE, window width and height, and the error image's spatial low band (at
/// the last count only).
pub fn csv_rows(row: &Row) -> Vec<[Cell; 9]> {
    let Ok(figures) = &row.past_depth else {
        return Vec::new();
    };
    let last = figures.frames.len().saturating_sub(1);
    let mut rows = Vec::new();
    for function in &figures.functions {
        for (reading, curve) in Reading::ALL.iter().zip(&function.readings) {
            for (k, (&frames, &rmse)) in figures.frames.iter().zip(&curve.rmse).enumerate() {
                rows.push([
                    Cell::text(&row.name),
                    Cell::text(function.name),
                    Cell::text(reading.name()),
                    Cell::int(frames as u64),
                    Cell::int((frames / figures.size.2) as u64),
                    Cell::sig(rmse, 4),
                    Cell::int(figures.window.0 as u64),
                    Cell::int(figures.window.1 as u64),
                    if k == last {
                        Cell::opt_fixed(curve.low_band, 4)
                    } else {
                        Cell::missing()
                    },
                ]);
            }
        }
    }
    rows
}

/// The columns of [`csv_rows`].
pub const CSV_COLUMNS: [&str; 9] = [
    "mask",
    "function",
    "reading",
    "frames",
    "frames_per_depth",
    "rmse",
    "window_width",
    "window_height",
    "error_spatial_low_band",
];
