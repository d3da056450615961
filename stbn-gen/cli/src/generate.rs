//! `stbn-gen generate`: every mask of a manifest to PNG slices, KTX2 textures or `.stbn` blobs,
//! with a report.

use std::collections::BTreeSet;
use std::fs;
use std::path::Path;
use std::time::Instant;

use clap::ValueEnum;
use indicatif::ProgressBar;
use stbn_build_support::{Generated, Manifest, MaskEntry, Method, Recipe};
use stbn_gen::analysis::{Field, VectorField};
use stbn_gen::export::{PngDepth, write_slices_png};
use stbn_gen::{Progress, SampleSpace};
use stbn_runtime::{Encoding, PackedStbn, Space, ValueMap};

use crate::report::{self, Report};
use crate::staging::Staging;
use crate::{Result, ktx2, pairs, vector};

/// How `generate` writes each mask.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum OutputFormat {
    /// `<out>/<name>/<name>_<z>.png`: one PNG per frame, 8-bit for `Unorm8` masks, 16-bit
    /// otherwise; grayscale for scalar masks, RGBA for vector masks (values in R, G, B, the pdf
    /// or full scale in A), with a `<name>.json` sidecar that says how to decode the channels and
    /// holds the optimiser's energy trace.
    Png,
    /// `<out>/<name>.ktx2`: one KTX2 3D texture (depth = frames) whose texels are the mask's
    /// `.stbn` payload bytes (R8…R8G8B8A8_UNORM, R16…_UNORM or R32…_SFLOAT), plus the same
    /// `<name>.json` sidecar for vector masks.
    Ktx2,
    /// `<out>/<name>.stbn`: the blob `stbn-build-support` embeds for the entry (same bytes: its
    /// encoding and compression), to commit and embed without a build script with
    /// `stbn_runtime::include_stbn!` (`include_packed_stbn!` for a compressed mask).
    Stbn,
}

/// Generates every mask of `manifest` into `out` in `format` (see [`OutputFormat`]), prints a
/// summary line per mask and writes `<out>/report.md`. `swaps_per_pixel` replaces the budget of
/// every mask a swap optimiser makes (the vector kinds and `FilterAdapted`).
///
/// Checked before anything is generated: the manifest declares a mask, no mask is named like a
/// folder of the report ([`report::RESERVED_NAMES`]), `out` is a writable folder, and nothing in
/// `out` that this run would replace was written by anything but stbn-gen. Everything is written
/// into a staging folder and switched in at the end ([`Staging`]): an interrupted or failed run
/// leaves the previous output as it was, and files of `out` the run does not write are left
/// alone.
pub fn run(
    manifest: &Path,
    out: &Path,
    format: OutputFormat,
    swaps_per_pixel: Option<f64>,
) -> Result<()> {
    let manifest = Manifest::load(manifest)?;
    if manifest.masks().is_empty() {
        return Err(format!(
            "{}: the manifest declares no masks, so there is nothing to generate",
            manifest.path().display()
        )
        .into());
    }
    for (index, entry) in manifest.masks().iter().enumerate() {
        if let Some(reserved) = report::RESERVED_NAMES
            .iter()
            .find(|r| r.eq_ignore_ascii_case(&entry.name))
        {
            return Err(manifest
                .name_error(
                    index,
                    format!(
                        "is the name of the report's folder `{reserved}/` beside the masks; \
                         `generate` refuses it (rename the mask)"
                    ),
                )
                .into());
        }
    }
    let mut planned: BTreeSet<String> = Report::files().into_iter().collect();
    for entry in manifest.masks() {
        planned.extend(files(entry, format));
    }
    // Under `<out>`: `<name>/<name>_<frame>.png` and `<name>/<name>_trace.csv` (frames up to
    // 65536), or the report's `dft/<index>_<name>_xy.png` and fixed names.
    let longest = manifest
        .masks()
        .iter()
        .map(|entry| 2 * entry.name.len() + 24)
        .max()
        .unwrap_or(0)
        .max(100);
    let staging = Staging::new(out, &|name| planned.contains(name), longest)?;
    let dir = staging.dir();
    let mut report = Report::create(&dir)?;
    let mut point_sections = String::new();
    let mut references = pairs::References::new();
    for entry in manifest.masks() {
        let with_budget;
        let entry = match swaps_per_pixel {
            Some(budget) if matches!(entry.kind.method(), Method::Swap | Method::FilterAdapted) => {
                with_budget = MaskEntry {
                    swaps_per_pixel: budget,
                    ..entry.clone()
                };
                &with_budget
            }
            _ => entry,
        };
        let start = Instant::now();
        let (generated, blob) = make(entry)?;
        let seconds = start.elapsed().as_secs_f64();
        let mask_error = |e: &dyn std::fmt::Display| format!("mask {:?}: {e}", entry.name);
        let decoded = PackedStbn::from_bytes(&blob)
            .and_then(|packed| packed.decode())
            .map_err(|e| mask_error(&e))?;
        let mask = decoded.view();
        let (w, h, d) = (mask.width(), mask.height(), mask.depth());
        // Uniform points in [0, 1)² (and higher): the 2D integration section measures them.
        if mask.space() == Space::Vec
            && mask.header().value_map == ValueMap::Unit
            && mask.dims() >= 2
        {
            point_sections += &pairs::mask_section(
                &pairs::PointMask {
                    name: entry.name.clone(),
                    size: (w as usize, h as usize, d as usize),
                    xs: vector::channel_values(&mask, 0),
                    ys: vector::channel_values(&mask, 1),
                },
                &mut references,
            )?;
        }
        let kind = match (entry.kind.method(), entry.space) {
            (Method::VoidAndCluster(topology), _) => topology.name().to_owned(),
            (Method::FilterAdapted, Some(space)) => format!("{:?}({space:?})", entry.kind),
            _ => format!("{:?}", entry.kind),
        };
        let dir = dir.as_path();
        let name = &entry.name;
        match (format, &generated) {
            (OutputFormat::Png, Generated::Scalar(volume)) => {
                let values = volume.values();
                let field = Field::new(w as usize, h as usize, d as usize, &values)
                    .expect("a mask's values are a field");
                let depth = if entry.encoding == Encoding::Unorm8 {
                    PngDepth::Eight
                } else {
                    PngDepth::Sixteen
                };
                write_slices_png(&field, dir, name, depth)?;
            }
            (OutputFormat::Png, Generated::Vector { trace, .. }) => {
                let folder = dir.join(name);
                vector::write_png_slices(&mask, &folder, name)?;
                vector::write_sidecar(&mask, entry, trace, &folder)?;
                vector::write_trace(trace, &folder, name)?;
            }
            (OutputFormat::Ktx2, _) => {
                let file = ktx2::write(w, h, d, mask.channels(), entry.encoding, mask.data())
                    .map_err(|e| mask_error(&e))?;
                let path = dir.join(format!("{name}.ktx2"));
                fs::write(&path, file).map_err(|e| format!("writing {}: {e}", path.display()))?;
                if let Generated::Vector { trace, .. } = &generated {
                    vector::write_sidecar(&mask, entry, trace, dir)?;
                    vector::write_trace(trace, dir, name)?;
                }
            }
            (OutputFormat::Stbn, _) => {
                let path = dir.join(format!("{name}.stbn"));
                fs::write(&path, &blob).map_err(|e| format!("writing {}: {e}", path.display()))?;
                if stbn_build_support::encode::stored_uncompressed(&blob, entry.compression) {
                    errln!(
                        "warning: mask {:?}: `compression: {:?}` does not make this mask \
                         smaller, so {name}.stbn is written uncompressed ({} bytes); set \
                         `compression: None` to say so in the manifest",
                        name,
                        entry.compression,
                        blob.len()
                    );
                }
            }
        }
        // Both families are measured on their generated values: scalar masks as one field,
        // vector masks in their own space (decoded components, the space's pdf); past the
        // depth, on the encoded mask through the runtime.
        let size = (w as usize, h as usize, d as usize);
        let row = match &generated {
            Generated::Scalar(volume) => {
                let values = volume.values();
                let field = Field::new(size.0, size.1, size.2, &values)
                    .expect("a mask's values are a field");
                report.measure_encoded(name, &kind, Some(seconds), &field, &mask)?
            }
            Generated::Vector { volume, .. } => {
                let space = sample_space(entry).expect("a vector mask has a sample space");
                let field =
                    VectorField::new(&space, size, volume.values()).map_err(|e| mask_error(&e))?;
                report.measure_vector(name, &kind, Some(seconds), &field, &mask)?
            }
        };
        outln!("{}", row.summary());
    }
    let written_as = match format {
        OutputFormat::Png => "PNG slices `<name>/<name>_<frame>.png`",
        OutputFormat::Ktx2 => "KTX2 3D textures `<name>.ktx2`",
        OutputFormat::Stbn => "`.stbn` blobs `<name>.stbn` (for `stbn_runtime::include_stbn!`)",
    };
    let mut intro = format!(
        "Masks of `{}`, written as {written_as} next to this report. Vector masks are measured \
         in their own space (\"Vector masks in their own space\").",
        crate::output::line_text(&manifest.path().display().to_string())
    );
    if let Some(budget) = swaps_per_pixel {
        intro.push_str(&format!(
            " Every swap-optimised mask (vector kinds, `FilterAdapted`) ran {budget} swaps per \
             pixel (`--swaps-per-pixel`), not its manifest's budget."
        ));
    }
    if !point_sections.is_empty() {
        point_sections.insert_str(0, pairs::HEADING);
    }
    report.finish(&intro, &point_sections)?;
    staging.commit()?;
    outln!("report: {}", out.join("report.md").display());
    Ok(())
}

/// The names `entry` gets in the output folder in `format` (a vector mask's sidecar and trace
/// beside its `.ktx2`; inside its folder as PNG slices).
fn files(entry: &MaskEntry, format: OutputFormat) -> Vec<String> {
    let name = &entry.name;
    match format {
        OutputFormat::Png => vec![name.clone()],
        OutputFormat::Ktx2 if sample_space(entry).is_some() => vec![
            format!("{name}.ktx2"),
            format!("{name}.json"),
            format!("{name}_trace.csv"),
        ],
        OutputFormat::Ktx2 => vec![format!("{name}.ktx2")],
        OutputFormat::Stbn => vec![format!("{name}.stbn")],
    }
}

/// The space the values of vector mask `entry` are drawn from; `None` for scalar masks.
fn sample_space(entry: &MaskEntry) -> Option<SampleSpace> {
    match entry.filter_adapted_spec() {
        Some((_, space)) => space,
        None => entry.vector_spec().map(|spec| spec.space),
    }
}

/// Generates `entry` and encodes it as build-support does ([`Recipe::encode`]), with a progress
/// bar (on a terminal) for void-and-cluster masks (pixels ranked) and swap-optimised ones (passes
/// done, fraction of the budget and time left); baselines show a spinner.
fn make(entry: &MaskEntry) -> Result<(Generated, Vec<u8>)> {
    let recipe = entry.recipe();
    let name = &entry.name;
    let passes_template =
        "{prefix} [{bar:40}] {percent:>3}% pass {msg} {elapsed_precise}, {eta} left";
    // The bar's length in progress steps and, for the swap optimisers, the steps per pass and the
    // passes, to show the pass a step count reaches as `done/passes`.
    let (bar, passes) = match &recipe {
        Recipe::VoidAndCluster(spec) => (
            report::bar(
                spec.pixels(),
                name,
                "{prefix} [{bar:40}] {percent:>3}% {elapsed_precise}, {eta} left",
            ),
            None,
        ),
        Recipe::Vector { spec, .. } => {
            // Quarter passes: the optimiser reports after each.
            let passes = spec.swaps_per_pixel.ceil() as u64 + u64::from(spec.assignment_passes);
            (
                report::bar(4 * passes, name, passes_template),
                Some((4, passes)),
            )
        }
        Recipe::FilterAdapted(recipe) => {
            let passes = recipe.spec().swaps_per_pixel.ceil() as u64;
            (
                report::bar(passes, name, passes_template),
                Some((1, passes)),
            )
        }
        Recipe::Baseline(..) => {
            let spinner = ProgressBar::new_spinner().with_style(
                indicatif::ProgressStyle::with_template("{prefix} {spinner} {elapsed_precise}")
                    .expect("the template is valid"),
            );
            spinner.set_prefix(name.clone());
            spinner.enable_steady_tick(std::time::Duration::from_millis(100));
            (spinner, None)
        }
    };
    if let Some((_, passes)) = passes {
        bar.set_message(format!("0/{passes}"));
    }
    let mut progress = |p: Progress| {
        bar.set_position(p.done);
        match passes {
            Some((1, passes)) => bar.set_message(format!("{}/{passes}", p.done)),
            Some((steps, passes)) => {
                bar.set_message(format!("{:.2}/{passes}", p.done as f64 / steps as f64));
            }
            None => {}
        }
    };
    let generated = recipe
        .generate_with_progress(&mut progress)
        .map_err(|e| format!("mask {name:?}: {e}"))?;
    bar.finish_and_clear();
    let blob = recipe.encode(&generated, entry.encoding, entry.compression);
    Ok((generated, blob))
}
