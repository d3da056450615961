//! PNG strips: images side by side (top row) above their magnified errors (bottom row), and
//! the DFT magnitude images of the errors side by side.

use std::fs::File;
use std::io::{self, BufWriter};
use std::path::Path;

use crate::compare::{Accumulation, Comparison};

/// Gap between tiles, in pixels.
const GAP: usize = 4;
/// Grey level of the gaps (sRGB code).
const GAP_LEVEL: u8 = 96;

/// The sRGB code (0–255) of a linear value, clamped to `[0, 1]` (the standard sRGB transfer
/// function, rounded).
pub fn srgb8(linear: f64) -> u8 {
    let v = linear.clamp(0.0, 1.0);
    let encoded = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (encoded * 255.0).round() as u8
}

/// Writes an 8-bit grayscale PNG of `tiles` (each `width × height`, row-major, linear values)
/// side by side with 4-pixel grey gaps, and below each tile `|tile − reference| · error_gain`.
/// Values are sRGB-encoded for display.
///
/// Panics if a tile or `reference` does not hold `width · height` values.
pub fn write_strip(
    path: &Path,
    width: usize,
    height: usize,
    tiles: &[Vec<f64>],
    reference: &[f64],
    error_gain: f64,
) -> io::Result<()> {
    let n = width * height;
    assert_eq!(reference.len(), n, "reference size");
    assert!(tiles.iter().all(|t| t.len() == n), "tile size");
    let out_w = strip_width(tiles.len(), width);
    let out_h = 2 * height + GAP;
    let mut pixels = vec![GAP_LEVEL; out_w * out_h];
    for (i, tile) in tiles.iter().enumerate() {
        let x0 = i * (width + GAP);
        for y in 0..height {
            for x in 0..width {
                let v = tile[y * width + x];
                pixels[y * out_w + x0 + x] = srgb8(v);
                let error = (v - reference[y * width + x]).abs() * error_gain;
                pixels[(height + GAP + y) * out_w + x0 + x] = srgb8(error);
            }
        }
    }
    write_gray8(path, out_w, out_h, &pixels)
}

/// Pixels across `count` tiles of `width` pixels with [`GAP`]s between them.
fn strip_width(count: usize, width: usize) -> usize {
    count * width + count.saturating_sub(1) * GAP
}

/// Writes `pixels` (`width × height` 8-bit grey levels as displayed, row-major) as a PNG tagged
/// sRGB.
fn write_gray8(path: &Path, width: usize, height: usize, pixels: &[u8]) -> io::Result<()> {
    let file = File::create(path)?;
    let mut encoder = png::Encoder::new(BufWriter::new(file), width as u32, height as u32);
    encoder.set_color(png::ColorType::Grayscale);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let mut writer = encoder.write_header().map_err(io::Error::other)?;
    writer.write_image_data(pixels).map_err(io::Error::other)?;
    writer.finish().map_err(io::Error::other)
}

/// Writes an 8-bit grayscale PNG of `tiles` (each `width × height` grey levels, row-major)
/// side by side with 4-pixel grey gaps.
///
/// Panics if a tile does not hold `width · height` levels.
pub fn write_tiles(path: &Path, width: usize, height: usize, tiles: &[Vec<u8>]) -> io::Result<()> {
    assert!(tiles.iter().all(|t| t.len() == width * height), "tile size");
    let out_w = strip_width(tiles.len(), width);
    let mut pixels = vec![GAP_LEVEL; out_w * height];
    for (i, tile) in tiles.iter().enumerate() {
        let x0 = i * (width + GAP);
        for (y, row) in tile.chunks_exact(width).enumerate() {
            pixels[y * out_w + x0..y * out_w + x0 + width].copy_from_slice(row);
        }
    }
    write_gray8(path, out_w, height, &pixels)
}

/// Error magnification of the strips' bottom rows.
pub const ERROR_GAIN: f64 = 4.0;

/// The file name of the strip of `accumulation` after `frames` frames.
pub fn strip_file_name(accumulation: Accumulation, frames: u32) -> String {
    format!("{}_{frames:02}_frames.png", accumulation.name())
}

/// The file name of the error spectra of `accumulation` after `frames` frames.
pub fn spectrum_file_name(accumulation: Accumulation, frames: u32) -> String {
    format!(
        "error_spectrum_{}_{frames:02}_frames.png",
        accumulation.name()
    )
}

/// Writes one strip per accumulation and checkpoint into `dir` (named by
/// [`strip_file_name`]): the ground truth, then every run in order, above their errors
/// magnified [`ERROR_GAIN`] times; and per accumulation, at the last checkpoint, the centred
/// DFT magnitude image of every run's error ([`Comparison::error_spectrum`], grey levels of
/// [`stbn_gen::analysis::SpectrumImage::to_gray8`]: white error a flat mid-dark grey, blue
/// error black around the centre) side by side in run order (named by
/// [`spectrum_file_name`]). Returns the file names.
pub fn write_strips(dir: &Path, cmp: &Comparison) -> io::Result<Vec<String>> {
    let mut names = Vec::new();
    for accumulation in Accumulation::ALL {
        for (i, frames) in cmp.frame_counts().into_iter().enumerate() {
            let mut tiles = vec![cmp.ground_truth.clone()];
            for run in &cmp.runs {
                let image = accumulation.image(&run.checkpoints[i]);
                tiles.push(image.iter().map(|&v| f64::from(v)).collect());
            }
            let name = strip_file_name(accumulation, frames);
            write_strip(
                &dir.join(&name),
                cmp.width as usize,
                cmp.height as usize,
                &tiles,
                &cmp.ground_truth,
                ERROR_GAIN,
            )?;
            names.push(name);
        }
        if let Some(&frames) = cmp.frame_counts().last() {
            let spectra: Vec<_> = cmp
                .runs
                .iter()
                .map(|run| {
                    cmp.error_spectrum(run.kind, accumulation, frames)
                        .expect("every run has every checkpoint")
                })
                .collect();
            let (width, height) = (spectra[0].width, spectra[0].height);
            let tiles: Vec<Vec<u8>> = spectra.iter().map(|s| s.to_gray8()).collect();
            let name = spectrum_file_name(accumulation, frames);
            write_tiles(&dir.join(&name), width, height, &tiles)?;
            names.push(name);
        }
    }
    Ok(names)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_endpoints_and_midpoint() {
        assert_eq!(srgb8(0.0), 0);
        assert_eq!(srgb8(1.0), 255);
        assert_eq!(srgb8(2.0), 255);
        assert_eq!(srgb8(-1.0), 0);
        // Linear 0.5 is sRGB 1.055 · 0.5^(1/2.4) − 0.055 = 0.73536, code 187.5 → 188.
        assert_eq!(srgb8(0.5), 188);
        // The linear segment: 0.003 · 12.92 · 255 = 9.88.
        assert_eq!(srgb8(0.003), 10);
    }

    #[test]
    fn strip_layout_reads_back() {
        let dir = std::env::temp_dir().join(format!("stbn-scenes-strip-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("s.png");
        let reference = vec![0.5; 6];
        let tiles = vec![vec![0.0; 6], vec![1.0; 6]];
        write_strip(&path, 3, 2, &tiles, &reference, 2.0).unwrap();
        let decoder = png::Decoder::new(std::io::BufReader::new(File::open(&path).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (3 + 4 + 3, 2 + 4 + 2));
        let at = |x: usize, y: usize| buf[y * 10 + x];
        assert_eq!(at(0, 0), 0); // tile 0
        assert_eq!(at(3, 0), GAP_LEVEL); // gap
        assert_eq!(at(7, 1), 255); // tile 1
        assert_eq!(at(0, 6), 255); // |0 − 0.5| · 2 = 1
        let path = dir.join("t.png");
        write_tiles(&path, 2, 1, &[vec![1, 2], vec![3, 4], vec![5, 6]]).unwrap();
        let decoder = png::Decoder::new(std::io::BufReader::new(File::open(&path).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (2 + 4 + 2 + 4 + 2, 1));
        let gap = [GAP_LEVEL; 4];
        assert_eq!(
            buf[..14],
            [[1, 2].as_slice(), &gap, &[3, 4], &gap, &[5, 6]].concat()
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
