//! `stbn-gen analyze`: the report for folders of PNG slices, optionally beside baseline fields.

use std::fs;
use std::path::{Path, PathBuf};
use std::time::Instant;

use stbn_gen::analysis::Field;
use stbn_gen::baselines::comparison;
use stbn_gen::export::read_slices_png;
use stbn_gen::{FilterAdaptedSpec, MaskSpec, Observer, generate, generate_filter_adapted};

use crate::Result;
use crate::report::Report;
use crate::staging::{self, Staging};

/// Reads every folder of `<name>_<z>.png` slices in `dirs`, prints a summary line per mask and
/// writes `<out>/report.md`. With `baseline_seed`, also generates and measures every baseline
/// mask of [`comparison`] (white noise, independent 2D and isotropic 3D blue noise, golden-ratio
/// and random-shift animated 2D blue noise, Tellusim's layered blue noise; the same masks a
/// manifest can declare, from that seed) at each distinct size of the analysed masks, as extra
/// rows named `<baseline>_<w>x<h>x<d>`, followed by the STBN mask (`Scalar`) and the
/// filter-adapted mask (`FilterAdapted` with its defaults: optimised for the filter the
/// filtered-error column applies) of that size and seed.
///
/// Before anything is read: each folder's slices start at 0 and the report's file names after
/// them fit file-name limits ([`check_slices`]), `out` is a writable folder and holds nothing
/// stbn-gen did not write where the report goes. The report is written into a staging folder and
/// switched in at the end ([`Staging`]). Folders of colour slices
/// whose channels differ (only red is read) and slices that hold one value (they measure as
/// perfect) are warned about on stderr and in the report.
pub fn run(dirs: &[PathBuf], out: &Path, baseline_seed: Option<u64>) -> Result<()> {
    for (index, dir) in dirs.iter().enumerate() {
        check_slices(dir, index)?;
    }
    let planned = Report::files();
    let staging = Staging::new(out, &|name| planned.iter().any(|p| p == name), 300)?;
    let mut report = Report::create(&staging.dir())?;
    let mut sizes = Vec::with_capacity(dirs.len());
    let mut warnings = Vec::new();
    for dir in dirs {
        let stack = read_slices_png(dir)?;
        if let Some(z) = stack.colour_slice() {
            warnings.push(format!(
                "{}: slice {z} (and maybe others) is a colour image whose green or blue differ \
                 from red; only the red channel is analysed",
                dir.display()
            ));
        }
        let field = stack.field();
        if stack.constant_slices() > 0 {
            warnings.push(format!(
                "{}: {} of {} slices hold a single value; they measure as perfectly uniform and \
                 say nothing about blue noise",
                dir.display(),
                stack.constant_slices(),
                field.depth()
            ));
        }
        let kind = format!("png {}-bit", stack.bit_depth().bits());
        let row = report.measure(stack.name(), &kind, None, &field)?;
        outln!("{}", row.summary());
        sizes.push(row.size);
    }
    for warning in &warnings {
        errln!("warning: {warning}");
    }
    let folders: Vec<String> = dirs
        .iter()
        .map(|dir| format!("`{}`", crate::output::line_text(&dir.display().to_string())))
        .collect();
    let mut intro = format!("PNG slices analysed from {}.", folders.join(", "));
    for warning in &warnings {
        intro.push_str(&format!("\n\n**Warning:** {warning}."));
    }
    if let Some(seed) = baseline_seed {
        sizes.sort_unstable();
        sizes.dedup();
        for (w, h, d) in sizes {
            let too_large = || format!("no baselines at {w}x{h}x{d}: too large");
            let axis = |n: usize| u32::try_from(n).map_err(|_| too_large());
            let set = comparison(axis(w)?, axis(h)?, axis(d)?, seed)
                .map_err(|e| format!("baselines at {w}x{h}x{d}: {e}"))?;
            for baseline in set {
                let field =
                    Field::new(w, h, d, &baseline.values).expect("baselines are valid fields");
                let name = format!("{}_{w}x{h}x{d}", baseline.name);
                let row = report.measure(&name, baseline.kind, Some(baseline.seconds), &field)?;
                outln!("{}", row.summary());
            }
            let (wu, hu, du) = (axis(w)?, axis(h)?, axis(d)?);
            let start = Instant::now();
            let stbn = generate(&MaskSpec::new(wu, hu, du, seed), Observer::default())
                .map_err(|e| format!("STBN at {w}x{h}x{d}: {e}"))?;
            let stbn_seconds = start.elapsed().as_secs_f64();
            let start = Instant::now();
            let spec = FilterAdaptedSpec::new(wu, hu, du, seed);
            let adapted = generate_filter_adapted(&spec, Observer::default())
                .map_err(|e| format!("filter-adapted mask at {w}x{h}x{d}: {e}"))?;
            let adapted_seconds = start.elapsed().as_secs_f64();
            for (name, kind, seconds, volume) in [
                ("stbn", "spatiotemporal", stbn_seconds, stbn),
                ("filter_adapted", "FilterAdapted", adapted_seconds, adapted),
            ] {
                let values = volume.values();
                let field = Field::new(w, h, d, &values).expect("masks are valid fields");
                let name = format!("{name}_{w}x{h}x{d}");
                let row = report.measure(&name, kind, Some(seconds), &field)?;
                outln!("{}", row.summary());
            }
        }
        intro.push_str(&format!(
            " Baselines (seed {seed}) at the same sizes, generated as masks with exactly uniform \
             frames: `white_noise`, a random permutation per frame; `blue_2d`, independent 2D \
             blue noise per frame; `blue_3d`, isotropic 3D blue noise; `golden_ratio_2d`, one 2D \
             blue-noise frame animated by the golden ratio, fract(v + frame·φ⁻¹) on the rank \
             grid; `random_shift_2d`, the same frame shifted by a random offset per frame, \
             fract(v + r_frame); `tellusim_layered`, Tellusim's layered void-and-cluster (each \
             frame seeded from the previous one flipped in x and y, kernel exp(−d²/σ²) + \
             0.01/(1 + d²), σ = 1.6). For reference, the masks a manifest's `Scalar` and \
             `FilterAdapted` kinds make with their defaults: `stbn`, spatiotemporal blue noise \
             (void-and-cluster, Gaussian σ 1.9 within frames and along each pixel's frames); \
             `filter_adapted`, the same mask then optimised ({} swaps per pixel) for the \
             product of the Gaussian σ 1.3435 blur and the EMA α 0.1 that the filtered-error \
             column applies (EA's FAST), wrapped around the mask's frames: with dozens of frames \
             it leads that column, trading some of STBN's low-band blue-ness for it (with a \
             handful, the column's EMA start at frame 0, which the wrapped filter does not \
             model, dominates and STBN can stay ahead).",
            FilterAdaptedSpec::DEFAULT_SWAPS_PER_PIXEL
        ));
    }
    report.finish(&intro, "")?;
    staging.commit()?;
    outln!("report: {}", out.join("report.md").display());
    Ok(())
}

/// Longest file name common file systems allow, in bytes.
const MAX_FILE_NAME: usize = 255;

/// Refuses, before anything is decoded, a folder of `<name>_<z>.png` slices (the `index`th
/// analysed) whose first slice is not slice 0 (naming the missing ones), or whose name is too
/// long for the report's `dft/<index>_<name>_xy.png` images. Everything else about the slices is
/// checked as they are read.
fn check_slices(dir: &Path, index: usize) -> Result<()> {
    // A folder that cannot be listed is reported by the reader.
    let Ok(entries) = fs::read_dir(dir) else {
        return Ok(());
    };
    let mut first: Option<(usize, String, PathBuf)> = None;
    for entry in entries.flatten() {
        let path = entry.path();
        if !path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("png"))
        {
            continue;
        }
        let Some((prefix, z)) = path
            .file_stem()
            .and_then(|s| s.to_str())
            .and_then(|s| s.rsplit_once('_'))
        else {
            continue;
        };
        if z.is_empty() || !z.bytes().all(|b| b.is_ascii_digit()) {
            continue;
        }
        let Ok(z) = z.parse::<usize>() else {
            continue;
        };
        if first.as_ref().is_some_and(|f| f.0 <= z) {
            continue;
        }
        first = Some((z, prefix.to_owned(), path));
    }
    let Some((z, name, path)) = first else {
        return Ok(());
    };
    let shown_name = staging::bounded(&name, 60);
    if z > 0 {
        let missing = if z == 1 {
            "slice 0 is".to_owned()
        } else {
            format!("slices 0–{} are", z - 1)
        };
        return Err(format!(
            "{}: {missing} missing: the first slice of `{shown_name}` is {} (a mask's slices \
             are numbered from 0)",
            staging::shown(dir),
            staging::shown(&path)
        )
        .into());
    }
    // `<index, at least 2 digits>_<name, one byte a character>_xy.png`.
    let fixed = index.to_string().len().max(2) + "_".len() + "_xy.png".len();
    let length = name.chars().count();
    if fixed + length > MAX_FILE_NAME {
        return Err(format!(
            "{}: the slice name `{shown_name}` is {length} characters long; the report names \
             files after it (`dft/{index:02}_<name>_xy.png`), so at most {} fit the \
             {MAX_FILE_NAME}-byte limit on file names (rename the slices)",
            staging::shown(dir),
            MAX_FILE_NAME - fixed
        )
        .into());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use stbn_gen::export::{PngDepth, write_slices_png};
    use stbn_gen::{EnergyTopology, MaskSpec};

    use super::*;

    #[test]
    fn baselines_appear_beside_the_analysed_masks() {
        let dir = tempfile::tempdir().unwrap();
        let mut folders = Vec::new();
        for (name, topology) in [
            ("stbn", EnergyTopology::Spatiotemporal),
            ("blue2d", EnergyTopology::Independent2D),
        ] {
            let spec = MaskSpec::new(16, 16, 8, 1).with_topology(topology);
            let values = generate(&spec, Observer::default()).unwrap().values();
            let field = Field::new(16, 16, 8, &values).unwrap();
            write_slices_png(&field, dir.path(), name, PngDepth::Eight).unwrap();
            folders.push(dir.path().join(name));
        }
        let out = dir.path().join("report");
        run(&folders, &out, Some(3)).unwrap();
        let text = fs::read_to_string(out.join("report.md")).unwrap();
        // The first cell of every line of the first table (the DFT table repeats the names).
        let names: Vec<&str> = text
            .lines()
            .skip_while(|l| !l.starts_with('|'))
            .take_while(|l| l.starts_with('|'))
            .filter_map(|l| l.strip_prefix("| ")?.split(" |").next())
            .collect();
        assert_eq!(
            names,
            [
                "mask",
                "stbn",
                "blue2d",
                "white_noise_16x16x8",
                "blue_2d_16x16x8",
                "blue_3d_16x16x8",
                "golden_ratio_2d_16x16x8",
                "random_shift_2d_16x16x8",
                "tellusim_layered_16x16x8",
                "stbn_16x16x8",
                "filter_adapted_16x16x8"
            ],
            "{text}"
        );
        assert!(text.contains("Baselines (seed 3)"));
        // Without a seed: the masks alone.
        run(&folders, &out, None).unwrap();
        let text = fs::read_to_string(out.join("report.md")).unwrap();
        assert!(!text.contains("white_noise"));
    }
}
