//! `stbn-gen generate`: every mask of a manifest to PNG slices or KTX2 textures, with a report.

use std::fs;
use std::path::Path;
use std::time::Instant;

use clap::ValueEnum;
use indicatif::{ProgressBar, ProgressStyle};
use stbn_build_support::Manifest;
use stbn_build_support::encode::encode_payload;
use stbn_gen::analysis::Field;
use stbn_gen::export::{PngDepth, write_slices_png};
use stbn_runtime::Encoding;

use crate::report::{self, Row};
use crate::{Result, ktx2};

/// How `generate` writes each mask.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum OutputFormat {
    /// `<out>/<name>/<name>_<z>.png`: one grayscale PNG per frame, 8-bit for `Unorm8` masks,
    /// 16-bit otherwise.
    Png,
    /// `<out>/<name>.ktx2`: one KTX2 3D texture (depth = frames) whose texels are the mask's
    /// `.stbn` payload bytes (R8_UNORM, R16_UNORM or R32_SFLOAT).
    Ktx2,
}

/// Generates every mask of `manifest` into `out` in `format` (see [`OutputFormat`]), prints a
/// summary line per mask and writes `<out>/report.md`.
pub fn run(manifest: &Path, out: &Path, format: OutputFormat) -> Result<()> {
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
        match format {
            OutputFormat::Png => {
                let depth = if entry.encoding == Encoding::Unorm8 {
                    PngDepth::Eight
                } else {
                    PngDepth::Sixteen
                };
                write_slices_png(&field, out, &entry.name, depth)?;
            }
            OutputFormat::Ktx2 => {
                let payload = encode_payload(&volume, entry.encoding);
                let file = ktx2::write(w, h, d, entry.encoding, &payload)
                    .map_err(|e| format!("mask {:?}: {e}", entry.name))?;
                fs::create_dir_all(out).map_err(|e| format!("creating {}: {e}", out.display()))?;
                let path = out.join(format!("{}.ktx2", entry.name));
                fs::write(&path, file).map_err(|e| format!("writing {}: {e}", path.display()))?;
            }
        }
        let row = Row::measure(&entry.name, spec.topology.name(), Some(seconds), &field);
        println!("{}", row.summary());
        rows.push(row);
    }
    let written = match format {
        OutputFormat::Png => "PNG slices `<name>/<name>_<frame>.png`",
        OutputFormat::Ktx2 => "KTX2 3D textures `<name>.ktx2`",
    };
    let intro = format!(
        "Masks of `{}`, written as {written} next to this report.",
        manifest.path().display()
    );
    let path = report::write(out, &intro, &rows)?;
    println!("report: {}", path.display());
    Ok(())
}
