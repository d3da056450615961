//! `stbn-gen generate`: every mask of a manifest to PNG slices, with a report.

use std::path::Path;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use stbn_build_support::Manifest;
use stbn_gen::analysis::Field;
use stbn_gen::export::{PngDepth, write_slices_png};
use stbn_runtime::Encoding;

use crate::Result;
use crate::report::{self, Row};

/// Generates every mask of `manifest` into `<out>/<name>/<name>_<z>.png` (8-bit for `Unorm8`,
/// 16-bit otherwise), prints a summary line per mask and writes `<out>/report.md`.
pub fn run(manifest: &Path, out: &Path) -> Result<()> {
    let manifest = Manifest::load(manifest)?;
    let mut rows = Vec::with_capacity(manifest.masks().len());
    for entry in manifest.masks() {
        let spec = entry.spec();
        let bar = ProgressBar::new(spec.pixels())
            .with_style(
                ProgressStyle::with_template(
                    "{prefix} [{bar:40}] {percent:>3}% {elapsed_precise}, {eta} left",
                )
                .expect("the template is valid")
                .progress_chars("=> "),
            )
            .with_prefix(entry.name.clone());
        let start = Instant::now();
        let volume = stbn_gen::generate_with_progress(&spec, &mut |p| bar.set_position(p.ranked))
            .map_err(|e| format!("mask {:?}: {e}", entry.name))?;
        let seconds = start.elapsed().as_secs_f64();
        bar.finish_and_clear();

        let values = volume.values();
        let (w, h, d) = (volume.width(), volume.height(), volume.depth());
        let field = Field::new(w as usize, h as usize, d as usize, &values)
            .expect("a volume's values are a field");
        let depth = if entry.encoding == Encoding::Unorm8 {
            PngDepth::Eight
        } else {
            PngDepth::Sixteen
        };
        write_slices_png(&field, out, &entry.name, depth)?;
        let row = Row::measure(&entry.name, spec.topology.name(), Some(seconds), &field);
        println!("{}", row.summary());
        rows.push(row);
    }
    let intro = format!(
        "Masks of `{}`, written as PNG slices `<name>/<name>_<frame>.png` next to this report.",
        manifest.path().display()
    );
    let path = report::write(out, &intro, &rows)?;
    println!("report: {}", path.display());
    Ok(())
}
