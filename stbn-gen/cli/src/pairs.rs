//! The report's 2D integration section (the paper's Fig. 6): a mask holding points in `[0, 1)²`
//! (`Vec2`…`Vec4`, `ImagePoints`) integrates 2D functions per pixel over frames, beside a scalar
//! STBN mask of the same size read at two offsets (what a renderer without vector masks does) and
//! beside pairs of white noise.

use std::collections::HashMap;
use std::collections::hash_map::Entry;
use std::fmt::Write as _;

use stbn_gen::analysis::{
    ConvergenceOptions, Field, FilteredErrorOptions, Integrand2D, convergence_2d,
    filtered_error_vector, toroidal_shift,
};
use stbn_gen::baselines::white_noise;
use stbn_gen::{EnergyTopology, MaskSpec, Observer};

use crate::Result;
use crate::output::{Cell, Column, Table};

/// The plastic number `g`: the R2 offset of dimension 1 is `fract(1/g, 1/g²)` of the mask size,
/// as `Stbn::dimension(1)` gives it.
const PLASTIC: f64 = 1.324_717_957_244_746;

/// One mask's 2D samples: components 0 and 1 of every pixel, in `[0, 1)`.
pub struct PointMask {
    /// The mask's name.
    pub name: String,
    /// `(width, height, depth)`.
    pub size: (usize, usize, usize),
    /// Component 0, voxels in index order.
    pub xs: Vec<f64>,
    /// Component 1.
    pub ys: Vec<f64>,
}

/// The section's heading and introduction (markdown); [`mask_section`] follows for each mask.
pub const HEADING: &str = "\n## 2D integration (points in [0, 1)²)\n\n\
     Each pixel integrates a 2D function over frames with the mask's (x, y) as samples \
     (Wolfe et al. 2022, Fig. 6): a disc of radius 0.4, a Gaussian of σ 0.2 and the step \
     x + y < 1. RMSE over pixels of the Monte Carlo mean / EMA (α 0.1) after n frames; \
     `filtered` is EA's filtered error with random half-spaces as thresholds, at the last \
     frame. References: scalar STBN of the same size read at (x, y) and at the R2 offset \
     (`dimension(1)`), and two independent white-noise masks. Lower is better.\n";

/// The two reference rows' cells (scalar STBN at two offsets, white pairs) per mask size, so that
/// point masks of one size measure them once per run.
pub type References = HashMap<(usize, usize, usize), [Vec<Cell>; 2]>;

/// Markdown for one mask of the section: RMSE of Monte Carlo and EMA (α 0.1) estimates after 4,
/// 16 and `depth` frames for each [`Integrand2D`], and the half-space filtered error at the last
/// frame, for the mask and for the two references (generated here with seed 1, or taken from
/// `references` when an earlier mask of this size measured them).
pub fn mask_section(mask: &PointMask, references: &mut References) -> Result<String> {
    let mut md = String::new();
    let (w, h, d) = mask.size;
    let frames: Vec<usize> = [4, 16, d]
        .into_iter()
        .filter(|&n| n <= d)
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    let mask_cells = match references.entry(mask.size) {
        Entry::Occupied(_) => figures(mask, (&mask.xs, &mask.ys), &frames)?,
        Entry::Vacant(slot) => {
            // The reference STBN mask generates on about one core (void-and-cluster is mostly
            // serial): the mask's own figures are measured beside it.
            let (stbn, mask_cells) = rayon::join(
                || {
                    stbn_gen::generate(
                        &MaskSpec::new(w as u32, h as u32, d as u32, 1)
                            .with_topology(EnergyTopology::Spatiotemporal),
                        Observer::default(),
                    )
                    .map_err(|e| format!("{}: reference STBN: {e}", mask.name))
                },
                || figures(mask, (&mask.xs, &mask.ys), &frames),
            );
            let stbn = stbn?.values();
            let (ox, oy) = (
                ((1.0 / PLASTIC) * w as f64) as usize,
                ((1.0 / (PLASTIC * PLASTIC)) * h as f64) as usize,
            );
            let shifted = toroidal_shift(&field(mask, &stbn)?, ox, oy);
            let white = (white_noise(w, h, d, 1), white_noise(w, h, d, 2));
            let measured = [
                figures(mask, (&stbn, &shifted), &frames)?,
                figures(mask, (&white.0, &white.1), &frames)?,
            ];
            slot.insert(measured);
            mask_cells?
        }
    };
    let [stbn_cells, white_cells] = references[&mask.size].clone();
    let rows = [
        (format!("`{}`", mask.name), mask_cells),
        ("scalar STBN, two offsets".to_owned(), stbn_cells),
        ("white pairs".to_owned(), white_cells),
    ];
    let mut columns = vec![
        Column::markdown_only("samples", false),
        Column::markdown_only("filtered", true),
    ];
    for integrand in Integrand2D::ALL {
        for n in &frames {
            columns.push(Column::markdown_only(
                &format!("{} MC@{n}", integrand.name()),
                true,
            ));
            columns.push(Column::markdown_only(&format!("EMA@{n}"), true));
        }
    }
    let mut table = Table::with_columns(columns);
    for (label, figures) in rows {
        let mut cells = vec![Cell::text(label)];
        cells.extend(figures);
        table.push(cells);
    }
    let _ = write!(
        md,
        "\n### `{}` ({w}×{h}×{d})\n\n{}",
        mask.name,
        table.markdown()
    );
    Ok(md)
}

/// The cells of one row after its label: the half-space filtered error at the last frame, then
/// Monte Carlo and EMA errors at each of `frames` for each [`Integrand2D`], of the samples
/// `(xs, ys)`.
fn figures(
    mask: &PointMask,
    (xs, ys): (&[f64], &[f64]),
    frames: &[usize],
) -> std::result::Result<Vec<Cell>, String> {
    let d = mask.size.2;
    let error = |e: &dyn std::fmt::Display| format!("{}: {e}", mask.name);
    let as_field = |values| field(mask, values).map_err(|e| e.to_string());
    let (xs, ys) = (as_field(xs)?, as_field(ys)?);
    let filtered =
        filtered_error_vector(&[xs, ys], FilteredErrorOptions::default()).map_err(|e| error(&e))?;
    let mut cells = vec![Cell::fixed(filtered[d - 1], 5)];
    for integrand in Integrand2D::ALL {
        let curve = convergence_2d(&xs, &ys, integrand, ConvergenceOptions::new(d))
            .map_err(|e| error(&e))?;
        for &n in frames {
            cells.push(Cell::fixed(curve.monte_carlo[n - 1], 4));
            cells.push(Cell::fixed(curve.ema[n - 1], 4));
        }
    }
    Ok(cells)
}

/// `values` as a field of `mask`'s size.
fn field<'a>(mask: &PointMask, values: &'a [f64]) -> Result<Field<'a>> {
    let (w, h, d) = mask.size;
    Ok(Field::new(w, h, d, values).map_err(|e| format!("{}: {e}", mask.name))?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_section_has_a_row_per_sample_source_and_a_column_per_integrand_and_frame() {
        let (w, h, d) = (8, 8, 4);
        let xs = white_noise(w, h, d, 11);
        let ys = white_noise(w, h, d, 12);
        let md = HEADING.to_owned()
            + &mask_section(
                &PointMask {
                    name: "pts".into(),
                    size: (w, h, d),
                    xs,
                    ys,
                },
                &mut References::new(),
            )
            .unwrap();
        let table: Vec<&str> = md.lines().filter(|l| l.starts_with('|')).collect();
        assert_eq!(table.len(), 5, "{md}"); // header, rule, three rows
        // Depth 4: frames {4} only; 3 integrands × (MC, EMA) + label + filtered.
        assert_eq!(table[0].matches('|').count(), 1 + 2 + 6, "{}", table[0]);
        assert!(table[2].starts_with("| `pts` |"));
        let cells: Vec<f64> = table[3]
            .split('|')
            .skip(2)
            .filter_map(|c| c.trim().parse().ok())
            .collect();
        assert_eq!(cells.len(), 7);
        assert!(
            cells.iter().all(|c| c.is_finite() && *c >= 0.0),
            "{cells:?}"
        );
    }

    #[test]
    fn masks_of_one_size_share_the_reference_rows() {
        let (w, h, d) = (8, 8, 4);
        let mask = |name: &str, seed| PointMask {
            name: name.into(),
            size: (w, h, d),
            xs: white_noise(w, h, d, seed),
            ys: white_noise(w, h, d, seed + 1),
        };
        let rows = |md: &str| -> Vec<String> {
            md.lines()
                .filter(|l| l.starts_with('|'))
                .skip(2)
                .map(str::to_owned)
                .collect()
        };
        let mut references = References::new();
        let first = rows(&mask_section(&mask("a", 11), &mut references).unwrap());
        assert_eq!(references.len(), 1);
        let second = rows(&mask_section(&mask("b", 21), &mut references).unwrap());
        assert_ne!(first[0], second[0], "each mask's own row is its own");
        assert_eq!(first[1..], second[1..], "the references are the same");
        // A size already measured takes its rows from `references`, not from new references.
        let cells = references[&(w, h, d)][0].len();
        let marker = vec![Cell::text("taken from the cache"); cells];
        references.insert((w, h, d), [marker.clone(), marker]);
        let third = rows(&mask_section(&mask("c", 31), &mut references).unwrap());
        assert!(third[1].contains("taken from the cache"), "{third:?}");
        assert!(third[2].contains("taken from the cache"), "{third:?}");
    }
}
