//! What `report` and `tradeoff` write besides their prose: tables of figures ([`Table`], as
//! markdown and as CSV), line charts ([`Chart`], as PNG) and the file writing both need.
//!
//! A [`Table`] holds every figure twice ([`Cell`]): exact for CSV (every digit an `f64` holds,
//! empty when missing) and rounded for markdown (`n/a` when missing). A [`Chart`] draws series
//! of `(x, y)` points on linear or log axes, with ranges fixed or following the data.

mod chart;
mod table;

use std::fs;
use std::path::Path;

pub use chart::{Axis, Chart, Series, SeriesLabelPosition, Style, colour_name};
pub use table::{Cell, Column, Table, line_text, significant};

use crate::Result;

/// Creates `dir` and its parents.
pub fn create_dir(dir: &Path) -> Result<()> {
    fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()).into())
}

/// Writes `text` to `path`.
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    fs::write(path, text).map_err(|e| format!("cannot write {}: {e}", path.display()).into())
}

/// Writes row-major 8-bit `pixels` of `(width, height)` to `path` as a PNG of `color`
/// (`Grayscale`: one byte a pixel, `Rgb`: three).
pub fn write_png(
    path: &Path,
    (width, height): (usize, usize),
    color: png::ColorType,
    pixels: &[u8],
) -> Result<()> {
    let failed = |e: &dyn std::fmt::Display| format!("cannot write {}: {e}", path.display());
    let side = |n: usize| u32::try_from(n).map_err(|e| failed(&e));
    // Encoded in memory, then written by one call that reports every error (a buffered file
    // drops the error of its last flush).
    let mut encoded = Vec::new();
    let mut encoder = png::Encoder::new(&mut encoded, side(width)?, side(height)?);
    encoder.set_color(color);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().map_err(|e| failed(&e))?;
    writer.write_image_data(pixels).map_err(|e| failed(&e))?;
    writer.finish().map_err(|e| failed(&e))?;
    fs::write(path, encoded).map_err(|e| failed(&e))?;
    Ok(())
}
