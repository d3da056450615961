//! Vector-mask output of `stbn-gen generate`: multi-channel PNG slices, a JSON sidecar that says
//! how to decode them, and the optimiser's energy trace as CSV.

use std::fs::{self, File};
use std::io::{self, BufWriter, Write as _};
use std::path::Path;

use serde::Serialize;
use stbn_build_support::MaskEntry;
use stbn_gen::EnergyTrace;
use stbn_runtime::{Encoding, Space, Stbn, ValueMap};

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

/// Writes frame `z` of `mask` as `<folder>/<name>_<z>.png` for every frame: gray, gray+alpha,
/// RGB or RGBA for 1–4 channels, holding the stored channels in order. Unorm8 masks give 8-bit
/// PNGs with the stored bytes; Unorm16 16-bit PNGs with the stored codes; F32 masks 16-bit PNGs
/// of `floor(v · 65536)` clamped to the range. Slices `<name>_<z>.png` with `z ≥ depth` left by
/// an earlier, deeper mask are removed.
pub fn write_png_slices(mask: &Stbn<'_>, folder: &Path, name: &str) -> io::Result<()> {
    fs::create_dir_all(folder)?;
    let depth = mask.depth();
    for entry in fs::read_dir(folder)? {
        let path = entry?.path();
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
            fs::remove_file(&path)?;
        }
    }
    let channels = usize::from(mask.channels());
    let color = [
        png::ColorType::Grayscale,
        png::ColorType::GrayscaleAlpha,
        png::ColorType::Rgb,
        png::ColorType::Rgba,
    ][channels - 1];
    let frame_elements = mask.width() as usize * mask.height() as usize * channels;
    let bpe = mask.encoding().bytes_per_element();
    for z in 0..depth {
        let start = z as usize * frame_elements * bpe;
        let frame = &mask.data()[start..start + frame_elements * bpe];
        let (bit_depth, data): (png::BitDepth, Vec<u8>) = match mask.encoding() {
            Encoding::Unorm8 => (png::BitDepth::Eight, frame.to_vec()),
            Encoding::Unorm16 => (
                png::BitDepth::Sixteen,
                // PNG samples are big-endian.
                frame.chunks_exact(2).flat_map(|q| [q[1], q[0]]).collect(),
            ),
            Encoding::F32 => (
                png::BitDepth::Sixteen,
                frame
                    .chunks_exact(4)
                    .flat_map(|v| {
                        let v = f32::from_le_bytes([v[0], v[1], v[2], v[3]]);
                        let q = (f64::from(v) * 65536.0).floor().clamp(0.0, 65535.0) as u16;
                        q.to_be_bytes()
                    })
                    .collect(),
            ),
        };
        let path = folder.join(format!("{name}_{z}.png"));
        let mut encoder = png::Encoder::new(
            BufWriter::new(File::create(&path)?),
            mask.width(),
            mask.height(),
        );
        encoder.set_color(color);
        encoder.set_depth(bit_depth);
        let mut writer = encoder.write_header().map_err(io::Error::other)?;
        writer.write_image_data(&data).map_err(io::Error::other)?;
        writer.finish().map_err(io::Error::other)?;
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
    sigma_image: f64,
    sigma_value: f64,
    swaps_per_pixel: f64,
    image: Option<String>,
    decode: String,
}

/// Writes `<folder>/<name>.json` describing `mask` (the encoded `entry`).
pub fn write_sidecar(mask: &Stbn<'_>, entry: &MaskEntry, folder: &Path) -> io::Result<()> {
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
        sigma_image: entry.sigma,
        sigma_value: entry.sigma_value,
        swaps_per_pixel: entry.swaps_per_pixel,
        image: entry.image.as_ref().map(|i| i.path.display().to_string()),
        decode: format!("{stored}; {values}{unit}{pdf}"),
    };
    fs::create_dir_all(folder)?;
    let json = serde_json::to_string_pretty(&sidecar).map_err(io::Error::other)?;
    fs::write(folder.join(format!("{}.json", entry.name)), json + "\n")
}

/// Writes `<folder>/<name>_trace.csv`: `swaps_attempted,swaps_accepted,energy` per pass.
pub fn write_trace(trace: &EnergyTrace, folder: &Path, name: &str) -> io::Result<()> {
    fs::create_dir_all(folder)?;
    let mut out = BufWriter::new(File::create(folder.join(format!("{name}_trace.csv")))?);
    writeln!(out, "swaps_attempted,swaps_accepted,energy")?;
    for p in &trace.points {
        writeln!(
            out,
            "{},{},{:e}",
            p.swaps_attempted, p.swaps_accepted, p.energy
        )?;
    }
    out.flush()
}
