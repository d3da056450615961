//! Dithers a gray ramp to black and white with a spatiotemporal blue-noise mask, frame after
//! frame, on the CPU, and shows that the mean of the frames converges to the ramp faster than
//! with 2D blue noise drawn independently for each frame.
//!
//! Each frame thresholds the ramp against the mask's values at that frame: a pixel is white
//! where the ramp is brighter than the mask. A single frame is blue-noise dithering; the mean of
//! the frames, what a temporal accumulation (TAA) shows, tends to the ramp itself. The masks are
//! the statics this package's `build.rs` embeds from `assets.ron`: `SCALAR_64` (STBN, 64×64×32,
//! sampled in place) and `BLUE2D_64` (independent 2D blue noise per frame, a `PackedStbn`
//! decoded once: declared Deflate-compressed, stored uncompressed because Deflate does not
//! shrink 8-bit frames). Both tile the image: sampling wraps around on every axis.
//!
//! Run: `cargo run --example cpu_dither [-- <out dir>]` (default `out/cpu_dither`).
//!
//! Writes `ramp.png` (the source), `frame_0.png` … `frame_3.png` (single dithered frames) and
//! `mean_32.png` (the mean of 32 frames), all 256×64 8-bit grayscale, and prints the RMSE of the
//! mean of the first n frames against the ramp, in gray levels of 1/255, for both masks.

use std::error::Error;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use stbn_demo::masks::{BLUE2D_64, SCALAR_64};
use stbn_runtime::Stbn;

/// Image size in pixels.
const WIDTH: u32 = 256;
const HEIGHT: u32 = 64;
/// Frames dithered: one period of the masks' 32 frames.
const FRAMES: u32 = 32;

fn main() -> Result<(), Box<dyn Error>> {
    let out = std::env::args_os()
        .nth(1)
        .map_or_else(|| PathBuf::from("out/cpu_dither"), PathBuf::from);
    std::fs::create_dir_all(&out)?;

    // Black to white from left to right: the pixel centre's x / WIDTH, in (0, 1).
    let ramp: Vec<f32> = (0..HEIGHT)
        .flat_map(|_| (0..WIDTH).map(|x| (x as f32 + 0.5) / WIDTH as f32))
        .collect();
    write_png(&out.join("ramp.png"), &ramp)?;

    let blue2d_decoded = BLUE2D_64.decode()?;
    let masks: [&Stbn<'_>; 2] = [&SCALAR_64, &blue2d_decoded.view()];
    let mut sums = [vec![0.0f32; ramp.len()], vec![0.0f32; ramp.len()]];

    println!("RMSE of the mean of n frames against the ramp, in gray levels (1/255):");
    println!("{:>3}  {:>6}  {:>14}", "n", "STBN", "2D blue noise");
    for frame in 0..FRAMES {
        for (m, (mask, sum)) in masks.iter().zip(&mut sums).enumerate() {
            let dithered = dither(mask, &ramp, frame);
            if m == 0 && frame < 4 {
                write_png(&out.join(format!("frame_{frame}.png")), &dithered)?;
            }
            sum.iter_mut().zip(&dithered).for_each(|(s, d)| *s += d);
        }
        let n = frame + 1;
        if n.is_power_of_two() {
            let [stbn, blue2d] = sums
                .each_ref()
                .map(|sum| rmse(&mean(sum, n), &ramp) * 255.0);
            println!("{n:>3}  {stbn:>6.1}  {blue2d:>14.1}");
        }
    }
    write_png(
        &out.join(format!("mean_{FRAMES}.png")),
        &mean(&sums[0], FRAMES),
    )?;
    println!("wrote {}", out.display());
    Ok(())
}

/// One frame of `source` (WIDTH × HEIGHT values in [0, 1]) thresholded by `mask`: 1 where the
/// source is above the mask's value at that pixel and frame, else 0.
fn dither(mask: &Stbn<'_>, source: &[f32], frame: u32) -> Vec<f32> {
    (0..HEIGHT as i32)
        .flat_map(|y| (0..WIDTH as i32).map(move |x| (x, y)))
        .zip(source)
        .map(|((x, y), &value)| f32::from(u8::from(value > mask.sample(x, y, frame))))
        .collect()
}

/// `sum / n` per pixel.
fn mean(sum: &[f32], n: u32) -> Vec<f32> {
    sum.iter().map(|s| s / n as f32).collect()
}

/// Root-mean-square difference of two images of values in [0, 1].
fn rmse(a: &[f32], b: &[f32]) -> f32 {
    let squares: f32 = a.iter().zip(b).map(|(a, b)| (a - b) * (a - b)).sum();
    (squares / a.len() as f32).sqrt()
}

/// Writes a WIDTH × HEIGHT image of values in [0, 1] as an 8-bit grayscale PNG.
fn write_png(path: &Path, values: &[f32]) -> Result<(), Box<dyn Error>> {
    let mut encoder = png::Encoder::new(BufWriter::new(File::create(path)?), WIDTH, HEIGHT);
    encoder.set_color(png::ColorType::Grayscale);
    encoder.set_depth(png::BitDepth::Eight);
    let pixels: Vec<u8> = values.iter().map(|v| (v * 255.0).round() as u8).collect();
    encoder.write_header()?.write_image_data(&pixels)?;
    Ok(())
}
