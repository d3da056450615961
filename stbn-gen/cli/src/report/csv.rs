//! The report's numbers as CSV files ([`Table::csv`]), one file per kind of figure, in long form
//! (one row per mask and point) so masks of different sizes share a file.
//!
//! | file | columns |
//! |---|---|
//! | `summary.csv` | one row per mask: every figure of the report's table |
//! | `filtered_error.csv` | `mask, frame, filtered_error` |
//! | `convergence.csv` | `mask, integrand, estimator, start_frame, samples, rmse` |
//! | `radial_spectrum.csv` | `mask, ring, cycles_per_pixel, normalised_power` |
//! | `temporal_spectrum.csv` | `mask, frequency, cycles_per_frame, normalised_power` |
//! | `convergence_past_depth.csv` | `mask, function, reading, frames, frames_per_depth, rmse, window_width, window_height, error_spatial_low_band` |
//! | `vector_components.csv` | `mask, space, component, spatial_low_band, temporal_low_band` (only with vector masks) |
//! | `vector_convergence.csv` | `mask, function, samples_from, estimator, samples, rmse` (only with vector masks) |
//!
//! Numbers are written with Rust's shortest round-trip formatting (every digit that the `f64`
//! holds); a figure that does not exist (e.g. the temporal low band of a single frame) is an
//! empty field.

use std::fs::OpenOptions;
use std::io::Write as _;
use std::path::Path;

use stbn_gen::analysis::{Integrand, radial_rings_per_cycle};

use super::{Estimator, Row, past_depth, summary_table};
use crate::Result;
use crate::output::{self, Cell, Column, Table};

/// The folder of the CSV files, relative to report.md.
pub const CSV_DIR: &str = "csv";

/// One CSV file: its name in [`CSV_DIR`], what a row is, and its table.
pub struct CsvFile {
    /// File name, e.g. `summary.csv`.
    pub name: &'static str,
    /// What one row holds, for the report's list of files.
    pub about: &'static str,
    /// The columns and rows.
    pub table: Table,
}

/// A table of `columns` with one row per item of `rows`.
fn long_table<const N: usize>(
    columns: [&'static str; N],
    rows: impl IntoIterator<Item = [Cell; N]>,
) -> Table {
    let mut table = Table::with_columns(columns.map(Column::csv_only));
    for row in rows {
        table.push(row.into());
    }
    table
}

/// Whether `rows` hold a vector mask, whose files [`files`] then adds.
pub fn has_vector(rows: &[Row]) -> bool {
    rows.iter().any(|row| row.vector.is_some())
}

/// Every CSV file of `rows` ([module docs](self)), with the vector masks' files when `vector`.
pub fn files(rows: &[Row], vector: bool) -> Vec<CsvFile> {
    let name = |row: &Row| Cell::text(&row.name);
    let filtered = rows.iter().flat_map(|row| {
        let frames = row.filtered.iter().enumerate();
        frames.map(|(k, &e)| [name(row), Cell::int(k as u64), Cell::fixed(e, 5)])
    });
    let mut convergence = Vec::new();
    for row in rows.iter().filter(|row| row.vector.is_none()) {
        for integrand in Integrand::ALL {
            let starts = [
                (0, row.curves(integrand)),
                (row.size.2 / 3, row.curves_late(integrand)),
            ];
            for estimator in Estimator::ALL {
                for (start, curves) in starts {
                    for (k, &e) in estimator.curve(curves).iter().enumerate() {
                        convergence.push([
                            name(row),
                            Cell::text(integrand.name()),
                            Cell::text(estimator.label()),
                            Cell::int(start as u64),
                            Cell::int(k as u64 + 1),
                            Cell::fixed(e, 4),
                        ]);
                    }
                }
            }
        }
    }
    let radial = rows.iter().flat_map(|row| {
        let long = radial_rings_per_cycle(row.size.0, row.size.1) as f64;
        let rings = row.radial.iter().enumerate();
        rings.map(move |(r, &p)| {
            let frequency = Cell::fixed(r as f64 / long, 4);
            [name(row), Cell::int(r as u64), frequency, Cell::fixed(p, 4)]
        })
    });
    let temporal = rows.iter().flat_map(|row| {
        let frames = row.size.2 as f64;
        let bins = row.temporal_spectrum.iter().enumerate();
        bins.map(move |(f, &p)| {
            let frequency = Cell::fixed(f as f64 / frames, 4);
            [name(row), Cell::int(f as u64), frequency, Cell::fixed(p, 4)]
        })
    });
    let mut files = vec![
        CsvFile {
            name: "summary.csv",
            about: "one row per mask: size, generation seconds, low bands, histogram \
                    deviations, last-frame filtered error, step-integrand RMSE",
            table: summary_table(rows),
        },
        CsvFile {
            name: "filtered_error.csv",
            about: "FAST filtered error per mask and frame",
            table: long_table(["mask", "frame", "filtered_error"], filtered),
        },
        CsvFile {
            name: "convergence.csv",
            about: "RMSE per mask, integrand, estimator (MC or EMA), start frame and number of \
                    samples",
            table: long_table(
                [
                    "mask",
                    "integrand",
                    "estimator",
                    "start_frame",
                    "samples",
                    "rmse",
                ],
                convergence,
            ),
        },
        CsvFile {
            name: "radial_spectrum.csv",
            about: "radially averaged spatial power per mask and ring (ring r at r / longest \
                    side cycles per pixel)",
            table: long_table(
                ["mask", "ring", "cycles_per_pixel", "normalised_power"],
                radial,
            ),
        },
        CsvFile {
            name: "temporal_spectrum.csv",
            about: "per-pixel temporal power per mask and frequency (cycles per sequence and \
                    per frame)",
            table: long_table(
                ["mask", "frequency", "cycles_per_frame", "normalised_power"],
                temporal,
            ),
        },
        CsvFile {
            name: "convergence_past_depth.csv",
            about: "running-mean RMSE past the depth per encoded mask, function, reading (wrap, \
                    progressive or white), and frame count, with the measured window; the \
                    error image's spatial low band at the last count",
            table: long_table(
                past_depth::CSV_COLUMNS,
                rows.iter().flat_map(past_depth::csv_rows),
            ),
        },
    ];
    if vector {
        files.extend(vector_files(rows));
    }
    files
}

/// The files only vector masks have: low bands per component, and the test functions'
/// convergence for the mask and for white noise of its distribution.
fn vector_files(rows: &[Row]) -> [CsvFile; 2] {
    let name = |row: &Row| Cell::text(&row.name);
    let mut components = Vec::new();
    let mut convergence = Vec::new();
    for row in rows {
        let Some(vector) = &row.vector else { continue };
        for c in &vector.components {
            components.push([
                name(row),
                Cell::text(vector.space),
                Cell::text(c.name),
                Cell::opt_fixed(c.spatial, 4),
                Cell::opt_fixed(c.temporal, 4),
            ]);
        }
        for t in &vector.tests {
            for (source, curves) in [("mask", &t.mask), ("white_noise", &t.white)] {
                for estimator in Estimator::ALL {
                    for (k, &e) in estimator.curve(curves).iter().enumerate() {
                        convergence.push([
                            name(row),
                            Cell::text(t.function.name()),
                            Cell::text(source),
                            Cell::text(estimator.label()),
                            Cell::int(k as u64 + 1),
                            Cell::fixed(e, 4),
                        ]);
                    }
                }
            }
        }
    }
    [
        CsvFile {
            name: "vector_components.csv",
            about: "low bands of each decoded component of each vector mask",
            table: long_table(
                [
                    "mask",
                    "space",
                    "component",
                    "spatial_low_band",
                    "temporal_low_band",
                ],
                components,
            ),
        },
        CsvFile {
            name: "vector_convergence.csv",
            about: "RMSE per vector mask, test function, samples from (the mask or white noise \
                    of its distribution), estimator and number of samples",
            table: long_table(
                [
                    "mask",
                    "function",
                    "samples_from",
                    "estimator",
                    "samples",
                    "rmse",
                ],
                convergence,
            ),
        },
    ]
}

/// Writes every CSV file of `rows` into `<out>/`[`CSV_DIR`] (creating it), one mask at a time:
/// the cells of a file (768 convergence rows per mask) are never all in memory at once.
pub fn write(out: &Path, rows: &[Row]) -> Result<()> {
    let dir = out.join(CSV_DIR);
    output::create_dir(&dir)?;
    let vector = has_vector(rows);
    let mut outputs = Vec::new();
    for file in files(&[], vector) {
        let path = dir.join(file.name);
        // The table of no mask is the header line.
        output::write_text(&path, &file.table.csv())?;
        let opened = OpenOptions::new().append(true).open(&path);
        outputs.push((
            opened.map_err(|e| format!("cannot write {}: {e}", path.display()))?,
            path,
        ));
    }
    for row in rows {
        let files = files(std::slice::from_ref(row), vector);
        for (file, (handle, path)) in files.iter().zip(&mut outputs) {
            let text = file.table.csv();
            let body = text.split_once('\n').map_or("", |(_, body)| body);
            handle
                .write_all(body.as_bytes())
                .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        }
    }
    Ok(())
}
