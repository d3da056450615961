//! The report's numbers as CSV files (RFC 4180: comma-separated, a header row, fields quoted
//! when they hold a comma, quote or line break, `\r\n`-free `\n` line ends), one file per kind
//! of figure, in long form (one row per mask and point) so masks of different sizes share a
//! file.
//!
//! | file | columns |
//! |---|---|
//! | `summary.csv` | one row per mask: every figure of the report's table |
//! | `filtered_error.csv` | `mask, frame, filtered_error` |
//! | `convergence.csv` | `mask, integrand, estimator, start_frame, samples, rmse` |
//! | `radial_spectrum.csv` | `mask, ring, cycles_per_pixel, normalised_power` |
//! | `temporal_spectrum.csv` | `mask, frequency, cycles_per_frame, normalised_power` |
//!
//! Numbers are written with Rust's shortest round-trip formatting (every digit that the `f64`
//! holds); a figure that does not exist (e.g. the temporal low band of a single frame) is an
//! empty field.

use std::fs;
use std::path::{Path, PathBuf};

use stbn_gen::analysis::Integrand;

use super::{Estimator, Row};
use crate::Result;

/// The folder of the CSV files, relative to report.md.
pub const CSV_DIR: &str = "csv";

/// One CSV file: its name in [`CSV_DIR`], what a row is, its header and rows.
pub struct Table {
    /// File name, e.g. `summary.csv`.
    pub file: &'static str,
    /// What one row holds, for the report's list of files.
    pub about: &'static str,
    /// Column names.
    pub header: Vec<&'static str>,
    /// Rows of fields, each as long as the header.
    pub rows: Vec<Vec<String>>,
}

impl Table {
    /// The file's text: header and rows, quoted where needed, one line each.
    pub fn text(&self) -> String {
        let line = |fields: &mut dyn Iterator<Item = &str>| {
            let quoted: Vec<String> = fields.map(quote).collect();
            quoted.join(",") + "\n"
        };
        let mut text = line(&mut self.header.iter().copied());
        for row in &self.rows {
            debug_assert_eq!(row.len(), self.header.len());
            text.push_str(&line(&mut row.iter().map(String::as_str)));
        }
        text
    }
}

/// Every table of `rows` ([module docs](self)).
pub fn tables(rows: &[Row]) -> Vec<Table> {
    let number = |v: f64| format!("{v}");
    let optional = |v: Option<f64>| v.map(number).unwrap_or_default();
    let summary = rows
        .iter()
        .map(|row| {
            let step = row.curves(Integrand::Step);
            let mut fields = vec![
                row.name.clone(),
                row.kind.clone(),
                row.size.0.to_string(),
                row.size.1.to_string(),
                row.size.2.to_string(),
                optional(row.seconds),
                optional(row.spatial),
                optional(row.temporal),
                number(row.histogram),
                number(row.pixel_histogram),
                number(row.filtered_last()),
            ];
            for curve in [&step.monte_carlo, &step.ema] {
                fields.extend(
                    super::CONVERGENCE_AT
                        .map(|n| curve.get(n - 1).copied().map(number).unwrap_or_default()),
                );
            }
            fields
        })
        .collect();
    let filtered = rows
        .iter()
        .flat_map(|row| {
            let frames = row.filtered.iter().enumerate();
            frames.map(|(k, &e)| vec![row.name.clone(), k.to_string(), number(e)])
        })
        .collect();
    let mut convergence = Vec::new();
    for row in rows {
        for integrand in Integrand::ALL {
            let starts = [
                (0, row.curves(integrand)),
                (row.size.2 / 3, row.curves_late(integrand)),
            ];
            for estimator in Estimator::ALL {
                for (start, curves) in starts {
                    for (k, &e) in estimator.curve(curves).iter().enumerate() {
                        convergence.push(vec![
                            row.name.clone(),
                            integrand.name().to_owned(),
                            estimator.label().to_owned(),
                            start.to_string(),
                            (k + 1).to_string(),
                            number(e),
                        ]);
                    }
                }
            }
        }
    }
    let radial = rows
        .iter()
        .flat_map(|row| {
            let long = row.size.0.max(row.size.1) as f64;
            let rings = row.radial.iter().enumerate();
            rings.map(move |(r, &p)| {
                let name = row.name.clone();
                vec![name, r.to_string(), number(r as f64 / long), number(p)]
            })
        })
        .collect();
    let temporal = rows
        .iter()
        .flat_map(|row| {
            let frames = row.size.2 as f64;
            let bins = row.temporal_spectrum.iter().enumerate();
            bins.map(move |(f, &p)| {
                let name = row.name.clone();
                vec![name, f.to_string(), number(f as f64 / frames), number(p)]
            })
        })
        .collect();
    vec![
        Table {
            file: "summary.csv",
            about: "one row per mask: size, generation seconds, low bands, histogram \
                    deviations, last-frame filtered error, step-integrand RMSE",
            header: vec![
                "mask",
                "kind",
                "width",
                "height",
                "frames",
                "seconds",
                "spatial_low_band",
                "temporal_low_band",
                "slice_histogram_deviation",
                "pixel_histogram_deviation",
                "filtered_error_last",
                "step_mc_rmse_1",
                "step_mc_rmse_4",
                "step_mc_rmse_16",
                "step_mc_rmse_64",
                "step_ema_rmse_1",
                "step_ema_rmse_4",
                "step_ema_rmse_16",
                "step_ema_rmse_64",
            ],
            rows: summary,
        },
        Table {
            file: "filtered_error.csv",
            about: "FAST filtered error per mask and frame",
            header: vec!["mask", "frame", "filtered_error"],
            rows: filtered,
        },
        Table {
            file: "convergence.csv",
            about: "RMSE per mask, integrand, estimator (MC or EMA), start frame and number of \
                    samples",
            header: vec![
                "mask",
                "integrand",
                "estimator",
                "start_frame",
                "samples",
                "rmse",
            ],
            rows: convergence,
        },
        Table {
            file: "radial_spectrum.csv",
            about: "radially averaged spatial power per mask and ring (ring r at r / longest \
                    side cycles per pixel)",
            header: vec!["mask", "ring", "cycles_per_pixel", "normalised_power"],
            rows: radial,
        },
        Table {
            file: "temporal_spectrum.csv",
            about: "per-pixel temporal power per mask and frequency (cycles per sequence and \
                    per frame)",
            header: vec!["mask", "frequency", "cycles_per_frame", "normalised_power"],
            rows: temporal,
        },
    ]
}

/// Writes every table of `rows` into `<out>/`[`CSV_DIR`] (creating it) and returns them with
/// their paths.
pub fn write(out: &Path, rows: &[Row]) -> Result<Vec<(PathBuf, Table)>> {
    let dir = out.join(CSV_DIR);
    fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    tables(rows)
        .into_iter()
        .map(|table| {
            let path = dir.join(table.file);
            fs::write(&path, table.text())
                .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
            Ok((path, table))
        })
        .collect()
}

/// `field` as one CSV field: quoted (inner quotes doubled) when it holds a comma, a quote or a
/// line break.
pub(crate) fn quote(field: &str) -> String {
    if field.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", field.replace('"', "\"\""))
    } else {
        field.to_owned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_are_quoted_only_when_needed() {
        assert_eq!(quote("stbn_64"), "stbn_64");
        assert_eq!(quote("a,b"), "\"a,b\"");
        assert_eq!(quote("say \"hi\""), "\"say \"\"hi\"\"\"");
        let table = Table {
            file: "t.csv",
            about: "",
            header: vec!["mask", "value"],
            rows: vec![vec!["a,b".to_owned(), "0.5".to_owned()]],
        };
        assert_eq!(table.text(), "mask,value\n\"a,b\",0.5\n");
    }
}
