//! Vector-mask output of `stbn-gen generate`: multi-channel PNG slices, a JSON sidecar that says
//! how to decode them, and the optimiser's energy trace as CSV.

use std::fmt::Write as _;
use std::fs;
use std::path::Path;

use rayon::prelude::*;
use serde::Serialize;
use stbn_build_support::{MaskEntry, Method};
use stbn_gen::EnergyTrace;
use stbn_runtime::{Encoding, Space, Stbn, ValueMap};

use crate::Result;

/// Creates `folder` and its parents; the error names it.
fn create_folder(folder: &Path) -> Result<()> {
    fs::create_dir_all(folder).map_err(|e| format!("cannot create {}: {e}", folder.display()))?;
    Ok(())
}

/// Writes `bytes` to `path` in one call whose every error is reported, naming the file.
fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    fs::write(path, bytes).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    Ok(())
}

/// Channel `c` of every voxel in index order, as the runtime samples it.
pub fn channel_values(mask: &Stbn<'_>, c: u32) -> Vec<f64> {
    let (w, h, d) = (mask.width(), mask.height(), mask.depth());
    let mut out = Vec::with_capacity(w as usize * h as usize * d as usize);
    for z in 0..d {
        for y in 0..h {
            for x in 0..w {
                out.push(f64::from(mask.sample_channel(x as i32, y as i32, z, c)));
            }
        }
    }
    out
}

/// Writes frame `z` of `mask` as `<folder>/<name>_<z>.png` for every frame, as the reference SDK
/// lays vector masks out: RGBA, with the stored value channels in R, G, B (unused ones 0) and the
/// stored pdf in A, or A at full scale where no pdf is stored (a four-component `Vec4` keeps its
/// fourth component in A). Channels hold the stored codes: `v · 0.5 + 0.5` for signed components
/// and the octahedral pair, `v` for unit-range ones, the pdf normalised to its min/max. Unorm8
/// masks give 8-bit PNGs with the stored bytes; Unorm16 16-bit PNGs with the stored codes; F32
/// masks 16-bit PNGs of `floor(u · 65536)` clamped to the range. Slices `<name>_<z>.png` with
/// `z ≥ depth` left by an earlier, deeper mask are removed.
pub fn write_png_slices(mask: &Stbn<'_>, folder: &Path, name: &str) -> Result<()> {
    create_folder(folder)?;
    let depth = mask.depth();
    let list_error = |e: std::io::Error| format!("cannot list {}: {e}", folder.display());
    for entry in fs::read_dir(folder).map_err(list_error)? {
        let path = entry.map_err(list_error)?.path();
        let stale = path
            .file_name()
            .and_then(|f| f.to_str())
            .and_then(|f| {
                f.strip_prefix(name)?
                    .strip_prefix('_')?
                    .strip_suffix(".png")
            })
            .and_then(|z| z.parse::<u32>().ok())
            .is_some_and(|z| z >= depth);
        if stale {
            fs::remove_file(&path).map_err(|e| format!("cannot remove {}: {e}", path.display()))?;
        }
    }
    let channels = usize::from(mask.channels());
    // Where each RGBA channel comes from: a stored channel, or a constant (0 or full scale).
    let pdf = mask.space().stores_pdf().then_some(channels - 1);
    let values = channels - usize::from(pdf.is_some());
    let source: [Option<usize>; 4] = [
        (values > 0).then_some(0),
        (values > 1).then_some(1),
        (values > 2).then_some(2),
        if values > 3 { Some(3) } else { pdf },
    ];
    let alpha_full = source[3].is_none();
    let bpe = mask.encoding().bytes_per_element();
    let frame_elements = mask.width() as usize * mask.height() as usize * channels;
    let sixteen = mask.encoding() != Encoding::Unorm8;
    // Frames are encoded in parallel, in memory, then written in order (so the first error, if
    // any, is the first frame's).
    let encode = |z: u32| -> std::result::Result<Vec<u8>, String> {
        let start = z as usize * frame_elements * bpe;
        let frame = &mask.data()[start..start + frame_elements * bpe];
        // The stored element `i` of this frame as a PNG sample (u8 or u16 code).
        let code = |i: usize| -> u16 {
            let e = &frame[i * bpe..(i + 1) * bpe];
            match mask.encoding() {
                Encoding::Unorm8 => u16::from(e[0]),
                Encoding::Unorm16 => u16::from_le_bytes([e[0], e[1]]),
                Encoding::F32 => {
                    let v = f32::from_le_bytes([e[0], e[1], e[2], e[3]]);
                    (f64::from(v) * 65536.0).floor().clamp(0.0, 65535.0) as u16
                }
            }
        };
        let full = if sixteen {
            u16::MAX
        } else {
            u16::from(u8::MAX)
        };
        let mut data =
            Vec::with_capacity(frame_elements / channels * 4 * if sixteen { 2 } else { 1 });
        for texel in 0..frame_elements / channels {
            for (slot, from) in source.iter().enumerate() {
                let q = match from {
                    Some(c) => code(texel * channels + c),
                    None if slot == 3 && alpha_full => full,
                    None => 0,
                };
                if sixteen {
                    data.extend_from_slice(&q.to_be_bytes()); // PNG samples are big-endian
                } else {
                    data.push(q as u8);
                }
            }
        }
        let encode_error = |e: png::EncodingError| {
            let path = folder.join(format!("{name}_{z}.png"));
            format!("cannot encode {}: {e}", path.display())
        };
        let mut encoded = Vec::new();
        let mut encoder = png::Encoder::new(&mut encoded, mask.width(), mask.height());
        encoder.set_color(png::ColorType::Rgba);
        encoder.set_depth(if sixteen {
            png::BitDepth::Sixteen
        } else {
            png::BitDepth::Eight
        });
        let mut writer = encoder.write_header().map_err(encode_error)?;
        writer.write_image_data(&data).map_err(encode_error)?;
        writer.finish().map_err(encode_error)?;
        Ok(encoded)
    };
    let frames: Vec<_> = (0..depth).into_par_iter().map(encode).collect();
    for (z, encoded) in frames.into_iter().enumerate() {
        // Written by one call that reports every error.
        write_file(&folder.join(format!("{name}_{z}.png")), &encoded?)?;
    }
    Ok(())
}

/// The JSON sidecar of a vector mask: what the channels hold and how to decode them.
#[derive(Serialize)]
struct Sidecar<'a> {
    name: &'a str,
    kind: String,
    size: [u32; 3],
    seed: u64,
    encoding: String,
    channels: u8,
    space: String,
    value_map: String,
    /// Components of one value after decoding (3 for octahedral).
    dims: u8,
    /// Index of the pdf channel, if the mask stores one.
    pdf_channel: Option<u8>,
    pdf_min: f32,
    pdf_max: f32,
    /// The swap optimiser's σi (absent for filter-adapted masks).
    #[serde(skip_serializing_if = "Option::is_none")]
    sigma_image: Option<f64>,
    /// The swap optimiser's σs (absent for filter-adapted masks).
    #[serde(skip_serializing_if = "Option::is_none")]
    sigma_value: Option<f64>,
    swaps_per_pixel: f64,
    /// Assignment passes after the swaps (absent for filter-adapted masks).
    #[serde(skip_serializing_if = "Option::is_none")]
    assignment_passes: Option<u32>,
    /// The filters a filter-adapted mask was optimised for (absent otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    filter: Option<String>,
    image: Option<String>,
    /// Where the PNG slices keep each channel.
    png_layout: String,
    decode: String,
    /// The optimiser's energy after each pass (also in `<name>_trace.csv`).
    trace: Vec<TraceRow>,
}

/// One pass of [`EnergyTrace`] in the sidecar.
#[derive(Serialize)]
struct TraceRow {
    swaps_attempted: u64,
    swaps_accepted: u64,
    energy: f64,
}

/// Writes `<folder>/<name>.json` describing `mask` (the encoded `entry`) and the energy `trace`
/// of its optimisation.
pub fn write_sidecar(
    mask: &Stbn<'_>,
    entry: &MaskEntry,
    trace: &EnergyTrace,
    folder: &Path,
) -> Result<()> {
    let header = mask.header();
    let stored = match header.encoding {
        Encoding::Unorm8 => "stored unit value u = (q + 0.5) / 256 for byte q",
        Encoding::Unorm16 => "stored unit value u = (q + 0.5) / 65536 for 16-bit code q",
        Encoding::F32 => "stored unit value u = the f32 as stored",
    };
    let values = match header.value_map {
        ValueMap::Unit => "value component = u".to_owned(),
        ValueMap::Signed => "value component = 2u - 1".to_owned(),
        ValueMap::Octahedral => "channels 0 and 1 hold e = 2u - 1, the octahedral map of a unit \
                                 3D vector (Cigolle et al. 2014); decode with \
                                 stbn_runtime::octahedral_decode or stbn_octahedral in WGSL"
            .to_owned(),
    };
    let unit = if header.space.is_unit() && header.value_map == ValueMap::Signed {
        "; normalise the decoded vector"
    } else {
        ""
    };
    let pdf = if header.space.stores_pdf() {
        "; the last channel is the pdf, stored full-range: pdf = pdf_min + t (pdf_max - \
         pdf_min) with t = q / (2^bits - 1) (F32: t as stored)"
            .to_owned()
    } else {
        match header.space {
            Space::CosineHemisphere => "; pdf = z / pi per steradian (not stored)".to_owned(),
            Space::UniformHemisphere => "; pdf = 1 / (2 pi) per steradian (not stored)".to_owned(),
            Space::UnitVec if header.dims() == 3 => {
                "; pdf = 1 / (4 pi) per steradian (not stored)".to_owned()
            }
            _ => "; uniform pdf (not stored)".to_owned(),
        }
    };
    let filter_adapted = entry.kind.method() == Method::FilterAdapted;
    let sidecar = Sidecar {
        name: &entry.name,
        kind: format!("{:?}", entry.kind),
        size: [header.width, header.height, header.depth],
        seed: entry.seed,
        encoding: format!("{:?}", header.encoding),
        channels: header.channels,
        space: format!("{:?}", header.space),
        value_map: format!("{:?}", header.value_map),
        dims: header.dims(),
        pdf_channel: header.space.stores_pdf().then(|| header.channels - 1),
        pdf_min: header.pdf_min,
        pdf_max: header.pdf_max,
        sigma_image: (!filter_adapted).then_some(entry.sigma),
        sigma_value: (!filter_adapted).then_some(entry.sigma_value),
        swaps_per_pixel: entry.swaps_per_pixel,
        assignment_passes: (!filter_adapted).then_some(entry.assignment_passes),
        filter: filter_adapted.then(|| {
            format!(
                "spatial {:?}, temporal {:?}, combination {:?}",
                entry.spatial_filter, entry.temporal_filter, entry.filter_combination
            )
        }),
        image: entry.image.as_ref().map(|i| i.path.display().to_string()),
        png_layout: png_layout(header.channels, header.space.stores_pdf()),
        decode: format!("{stored}; {values}{unit}{pdf}"),
        trace: trace
            .points
            .iter()
            .map(|p| TraceRow {
                swaps_attempted: p.swaps_attempted,
                swaps_accepted: p.swaps_accepted,
                energy: p.energy,
            })
            .collect(),
    };
    create_folder(folder)?;
    let json = serde_json::to_string_pretty(&sidecar).expect("the sidecar serialises");
    write_file(
        &folder.join(format!("{}.json", entry.name)),
        (json + "\n").as_bytes(),
    )
}

/// Which stored channel each RGBA channel of a PNG slice holds ([`write_png_slices`]).
fn png_layout(channels: u8, stores_pdf: bool) -> String {
    let values = channels - u8::from(stores_pdf);
    let rgb: Vec<String> = (0..3)
        .map(|c| {
            if c < values {
                format!("channel {c}")
            } else {
                "0".to_owned()
            }
        })
        .collect();
    let alpha = if values > 3 {
        "channel 3".to_owned()
    } else if stores_pdf {
        format!("channel {} (pdf)", channels - 1)
    } else {
        "full scale".to_owned()
    };
    format!("R: {}, G: {}, B: {}, A: {alpha}", rgb[0], rgb[1], rgb[2])
}

/// Writes `<folder>/<name>_trace.csv`: `swaps_attempted,swaps_accepted,energy` per pass.
pub fn write_trace(trace: &EnergyTrace, folder: &Path, name: &str) -> Result<()> {
    create_folder(folder)?;
    let mut csv = String::from("swaps_attempted,swaps_accepted,energy\n");
    for p in &trace.points {
        writeln!(
            csv,
            "{},{},{:e}",
            p.swaps_attempted, p.swaps_accepted, p.energy
        )
        .expect("String");
    }
    write_file(&folder.join(format!("{name}_trace.csv")), csv.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[cfg(target_os = "linux")]
    #[test]
    fn a_full_disk_is_an_error_naming_the_file() {
        let error = write_file(Path::new("/dev/full"), b"slice").unwrap_err();
        let message = error.to_string();
        assert!(message.starts_with("cannot write /dev/full: "), "{message}");
    }
}
