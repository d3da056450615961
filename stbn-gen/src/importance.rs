//! Images as densities: [`ImagePdf`], and the pixel sampler that draws stratified samples from
//! it by inverting its marginal and conditional CDFs.

use std::f64::consts::{PI, TAU};
use std::fmt;
#[cfg(feature = "images")]
use std::io::Cursor;
use std::path::{Path, PathBuf};

#[cfg(feature = "images")]
use image::{DynamicImage, ImageDecoder, ImageFormat, ImageReader};

/// Rec. 709 luminance weights of linear `(R, G, B)`.
#[cfg(feature = "images")]
const LUMINANCE_WEIGHTS: [f32; 3] = [0.2126, 0.7152, 0.0722];

/// An image's luminance as a density over `[0, 1)²` or over directions: the image of
/// [`SampleSpace::ImagePoints`](crate::SampleSpace::ImagePoints) and
/// [`SampleSpace::EnvironmentDirections`](crate::SampleSpace::EnvironmentDirections).
///
/// Valid by construction: at least one pixel, every luminance finite and `≥ 0`, and some
/// luminance positive.
///
/// # Luminance
///
/// `L = 0.2126 R + 0.7152 G + 0.0722 B` (Rec. 709 / sRGB primaries) of *linear* RGB.
/// Radiance `.hdr` files are linear already. PNG files (8 or 16 bits; gray, gray + alpha, RGB,
/// RGBA or palette) are taken as sRGB-encoded: each channel `c ∈ [0, 1]` is decoded with the sRGB
/// transfer function (`c / 12.92` up to 0.04045, else `((c + 0.055) / 1.055)^2.4`) before the
/// weights apply; a gray PNG's gray is decoded the same way. Alpha is ignored.
///
/// # Points: the image as a density on `[0, 1)²`
///
/// Pixel `(x, y)` (row 0 at the top) covers `[x/W, (x+1)/W) × [y/H, (y+1)/H)`. The density of a
/// point in it is `L(x, y) / mean(L)`: constant over the pixel, proportional to luminance, and
/// integrating to 1 over the square ([`ImagePdf::point_pdf`]).
///
/// # Directions: the image as a lat-long environment map
///
/// Texture coordinates `(u, v) ∈ [0, 1)²` map to `φ = 2πu` (azimuth) and `θ = πv` (polar angle from
/// `+Y`, so the top row is the sky's zenith), and the direction is
/// `(sin θ cos φ, cos θ, sin θ sin φ)` ([`ImagePdf::direction`]). Pixel `(x, y)` spans the solid
/// angle `Ω(y) = (2π / W) · (cos(πy/H) − cos(π(y+1)/H))`, small near the poles. Its sampling weight
/// is `L·Ω` and within the pixel directions are uniform in solid angle (φ uniform, `cos θ`
/// uniform), so the density per steradian is `L(x, y) / Σ L·Ω`: constant over each pixel,
/// proportional to luminance, and integrating to 1 over the sphere ([`ImagePdf::direction_pdf`]).
/// In `(u, v)` terms that is `p(u, v) / (2π² sin θ)`, with `p` the density over the map: the
/// Jacobian the reference SDK omits is included.
#[derive(Clone, Debug, PartialEq)]
pub struct ImagePdf {
    width: u32,
    height: u32,
    /// Row-major luminance, row 0 at the top.
    luminance: Vec<f32>,
    /// `Σ L / (W·H)`: normalises the density of points.
    mean_luminance: f64,
    /// `Σ L·Ω` over pixels, in luminance × steradians: normalises the density of directions.
    solid_angle_weighted_sum: f64,
}

impl ImagePdf {
    /// Largest number of pixels accepted (an 8192 × 4096 map), checked before decoding.
    pub const MAX_PIXELS: u64 = 1 << 25;

    /// An image of `width × height` luminance values, row-major with row 0 at the top.
    ///
    /// Errors if a size is 0, the pixel count is over [`ImagePdf::MAX_PIXELS`] or does not match
    /// `luminance.len()`, a value is NaN, infinite or negative (naming the first such pixel), or
    /// every value is 0.
    pub fn from_luminance(
        width: u32,
        height: u32,
        luminance: Vec<f32>,
    ) -> Result<ImagePdf, ImageError> {
        Self::build(None, width, height, luminance)
    }

    /// Largest image file accepted, in bytes (320 MiB): a 16-bit RGBA PNG of
    /// [`ImagePdf::MAX_PIXELS`] pixels stored uncompressed, with room for its framing. Checked
    /// before the file is read.
    pub const MAX_FILE_BYTES: u64 = 320 << 20;

    /// Reads a `.png` or Radiance `.hdr` file (chosen by the extension, case-insensitive) and
    /// takes its luminance (see the type's docs): [`ImagePdf::read_file`], then
    /// [`ImagePdf::decode`].
    ///
    /// Errors name the file: it cannot be opened or decoded, its extension is neither, it is not
    /// a regular file or is larger than [`ImagePdf::MAX_FILE_BYTES`] (checked before reading), it
    /// is larger than [`ImagePdf::MAX_PIXELS`] (checked before decoding the pixels), or its
    /// luminance is invalid as in [`ImagePdf::from_luminance`].
    #[cfg(feature = "images")]
    pub fn load(path: &Path) -> Result<ImagePdf, ImageError> {
        format_of(path)?;
        Self::decode(path, &Self::read_file(path)?)
    }

    /// The bytes of the image file at `path`, read once: only a regular file (not a FIFO, device
    /// or folder) of at most [`ImagePdf::MAX_FILE_BYTES`] bytes, checked before reading.
    pub fn read_file(path: &Path) -> Result<Vec<u8>, ImageError> {
        crate::file::read_regular_file(path, Self::MAX_FILE_BYTES).map_err(|e| {
            ImageError::Unreadable {
                path: path.to_path_buf(),
                message: e.to_string(),
            }
        })
    }

    /// The pdf of the image file `path` whose contents are `bytes` (from
    /// [`ImagePdf::read_file`]); the extension picks the format, and errors name `path`, as in
    /// [`ImagePdf::load`].
    #[cfg(feature = "images")]
    pub fn decode(path: &Path, bytes: &[u8]) -> Result<ImagePdf, ImageError> {
        let owned = || path.to_path_buf();
        let format = format_of(path)?;
        let decode_error = |e: image::ImageError| match e {
            image::ImageError::Unsupported(detail) => ImageError::UnsupportedFormat {
                path: owned(),
                detail: detail.to_string(),
            },
            other => ImageError::Unreadable {
                path: owned(),
                message: other.to_string(),
            },
        };
        let decoder = ImageReader::with_format(Cursor::new(bytes), format)
            .into_decoder()
            .map_err(decode_error)?;
        let (width, height) = decoder.dimensions();
        check_size(Some(path), width, height)?;
        let image = DynamicImage::from_decoder(decoder).map_err(decode_error)?;
        let srgb = format == ImageFormat::Png;
        let decode = |c: f32| if srgb { srgb_to_linear(c) } else { c };
        let luminance: Vec<f32> = image
            .to_rgb32f()
            .pixels()
            .map(|p| {
                let [r, g, b] = p.0;
                let [wr, wg, wb] = LUMINANCE_WEIGHTS;
                wr * decode(r) + wg * decode(g) + wb * decode(b)
            })
            .collect();
        Self::build(Some(path), width, height, luminance)
    }

    fn build(
        path: Option<&Path>,
        width: u32,
        height: u32,
        luminance: Vec<f32>,
    ) -> Result<ImagePdf, ImageError> {
        check_size(path, width, height)?;
        let path = || path.map(Path::to_path_buf);
        if luminance.len() as u64 != u64::from(width) * u64::from(height) {
            return Err(ImageError::SizeMismatch {
                path: path(),
                width,
                height,
                values: luminance.len(),
            });
        }
        if let Some((i, &value)) = luminance
            .iter()
            .enumerate()
            .find(|(_, v)| !(v.is_finite() && **v >= 0.0))
        {
            let problem = if value.is_nan() {
                PixelProblem::NaN
            } else if value.is_infinite() {
                PixelProblem::Infinite
            } else {
                PixelProblem::Negative(value)
            };
            return Err(ImageError::BadPixel {
                path: path(),
                x: (i % width as usize) as u32,
                y: (i / width as usize) as u32,
                problem,
            });
        }
        let total: f64 = luminance.iter().map(|&l| f64::from(l)).sum();
        if total <= 0.0 {
            return Err(ImageError::AllZero { path: path() });
        }
        let mut weighted = 0.0;
        for (y, row) in luminance.chunks_exact(width as usize).enumerate() {
            let row_sum: f64 = row.iter().map(|&l| f64::from(l)).sum();
            weighted += row_sum * pixel_solid_angle(width, height, y as u32);
        }
        Ok(ImagePdf {
            width,
            height,
            mean_luminance: total / (f64::from(width) * f64::from(height)),
            solid_angle_weighted_sum: weighted,
            luminance,
        })
    }

    /// Pixels per row.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Rows.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Luminance, row-major with row 0 at the top (`width · height` values, finite, `≥ 0`).
    pub fn luminance(&self) -> &[f32] {
        &self.luminance
    }

    fn lum(&self, x: u32, y: u32) -> f64 {
        f64::from(self.luminance[y as usize * self.width as usize + x as usize])
    }

    /// The density of points at `(u, v)` with respect to area in `[0, 1)²`: `L / mean(L)` of
    /// the pixel `(⌊u·W⌋, ⌊v·H⌋)`; 0 outside the square (or for NaN).
    pub fn point_pdf(&self, [u, v]: [f32; 2]) -> f32 {
        if !((0.0..1.0).contains(&u) && (0.0..1.0).contains(&v)) {
            return 0.0;
        }
        let (x, y) = self.point_pixel([u, v]);
        (self.lum(x, y) / self.mean_luminance) as f32
    }

    /// The pixel a point in `[0, 1)²` falls in.
    fn point_pixel(&self, [u, v]: [f32; 2]) -> (u32, u32) {
        (
            cell(f64::from(u), self.width),
            cell(f64::from(v), self.height),
        )
    }

    /// The density of directions at `direction` (need not be normalised; `+Y` up), per
    /// steradian: `L / Σ L·Ω` of the pixel it falls in; 0 for a zero or non-finite vector.
    pub fn direction_pdf(&self, direction: [f32; 3]) -> f32 {
        match self.direction_pixel(direction) {
            Some((x, y)) => (self.lum(x, y) / self.solid_angle_weighted_sum) as f32,
            None => 0.0,
        }
    }

    /// The direction of texture coordinates `(u, v)`: `φ = 2πu`, `θ = πv`,
    /// `(sin θ cos φ, cos θ, sin θ sin φ)`.
    pub fn direction(u: f64, v: f64) -> [f64; 3] {
        let (sin_t, cos_t) = (PI * v).sin_cos();
        let (sin_p, cos_p) = (TAU * u).sin_cos();
        [sin_t * cos_p, cos_t, sin_t * sin_p]
    }

    /// The texture coordinates `(u, v) ∈ [0, 1]²` of a direction (inverse of
    /// [`ImagePdf::direction`]; `u` is 0 on the poles). `None` for a zero or non-finite vector.
    pub fn direction_uv([x, y, z]: [f32; 3]) -> Option<[f64; 2]> {
        let (x, y, z) = (f64::from(x), f64::from(y), f64::from(z));
        let norm = (x * x + y * y + z * z).sqrt();
        if !(norm.is_finite() && norm > 0.0) {
            return None;
        }
        let theta = (y / norm).clamp(-1.0, 1.0).acos();
        let mut phi = z.atan2(x);
        if phi < 0.0 {
            phi += TAU;
        }
        Some([phi / TAU, theta / PI])
    }

    fn direction_pixel(&self, direction: [f32; 3]) -> Option<(u32, u32)> {
        let [u, v] = Self::direction_uv(direction)?;
        Some((cell(u, self.width), cell(v, self.height)))
    }

    /// Sampler of pixels with weight `L`.
    pub(crate) fn point_sampler(&self) -> PixelSampler {
        PixelSampler::new(self.width, self.height, |x, y| self.lum(x, y))
    }

    /// Sampler of pixels with weight `L·Ω`.
    pub(crate) fn direction_sampler(&self) -> PixelSampler {
        let omega: Vec<f64> = (0..self.height)
            .map(|y| pixel_solid_angle(self.width, self.height, y))
            .collect();
        PixelSampler::new(self.width, self.height, |x, y| {
            self.lum(x, y) * omega[y as usize]
        })
    }

    /// The point of `[0, 1)²` at stratum coordinates `(a, b) ∈ [0, 1)²` of `sampler` (from
    /// [`ImagePdf::point_sampler`]): uniform `(a, b)` give points with density
    /// [`ImagePdf::point_pdf`], and the map preserves stratification.
    pub(crate) fn sample_point(&self, sampler: &PixelSampler, a: f64, b: f64) -> [f32; 2] {
        let (x, y, fx, fy) = sampler.invert(a, b);
        settle(fx, fy, (x, y), |fx, fy| {
            let point = [
                ((f64::from(x) + fx) / f64::from(self.width)) as f32,
                ((f64::from(y) + fy) / f64::from(self.height)) as f32,
            ];
            let inside = point.iter().all(|c| (0.0..1.0).contains(c));
            (point, inside.then(|| self.point_pixel(point)))
        })
    }

    /// The direction at stratum coordinates `(a, b) ∈ [0, 1)²` of `sampler` (from
    /// [`ImagePdf::direction_sampler`]): uniform `(a, b)` give directions with density
    /// [`ImagePdf::direction_pdf`].
    pub(crate) fn sample_direction(&self, sampler: &PixelSampler, a: f64, b: f64) -> [f32; 3] {
        let (x, y, fx, fy) = sampler.invert(a, b);
        let h = f64::from(self.height);
        let (cos0, cos1) = (
            (PI * f64::from(y) / h).cos(),
            (PI * f64::from(y + 1) / h).cos(),
        );
        settle(fx, fy, (x, y), |fx, fy| {
            // Uniform in cos θ within the row's band: uniform in solid angle.
            let cos_t = cos0 + fy * (cos1 - cos0);
            let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
            let (sin_p, cos_p) = (TAU * (f64::from(x) + fx) / f64::from(self.width)).sin_cos();
            let direction = [(sin_t * cos_p) as f32, cos_t as f32, (sin_t * sin_p) as f32];
            (direction, self.direction_pixel(direction))
        })
    }
}

/// The `f32` sample `make(fx, fy)` for fractional position `(fx, fy)` within pixel `want`, moved
/// towards the pixel's centre if rounding to `f32` put it in another pixel (`make` returns the
/// sample and the pixel it falls in), so a sample's looked-up density is always that of the pixel
/// it was drawn from. Only samples within about 10⁻⁷ of a pixel edge move, by at most half a pixel.
fn settle<T>(
    fx: f64,
    fy: f64,
    want: (u32, u32),
    make: impl Fn(f64, f64) -> (T, Option<(u32, u32)>),
) -> T {
    let (sample, pixel) = make(fx, fy);
    if pixel == Some(want) {
        return sample;
    }
    let margin = 1e-3;
    let (sample, pixel) = make(
        fx.clamp(margin, 1.0 - margin),
        fy.clamp(margin, 1.0 - margin),
    );
    if pixel == Some(want) {
        return sample;
    }
    make(0.5, 0.5).0
}

/// `⌊t · size⌋` clamped to `0..size`.
fn cell(t: f64, size: u32) -> u32 {
    ((t * f64::from(size)).max(0.0) as u32).min(size - 1)
}

/// Solid angle of one pixel of row `y` of a `width × height` lat-long map, in steradians:
/// `(2π/W)(cos(πy/H) − cos(π(y+1)/H))`, written as `2 sin(mid) sin(half)` to stay accurate at the
/// poles.
fn pixel_solid_angle(width: u32, height: u32, y: u32) -> f64 {
    let h = f64::from(height);
    let mid = PI * (f64::from(y) + 0.5) / h;
    let half = PI * 0.5 / h;
    TAU / f64::from(width) * 2.0 * mid.sin() * half.sin()
}

/// The sRGB transfer function's inverse: encoded `c ∈ [0, 1]` to linear.
#[cfg(feature = "images")]
fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.040_45 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// The format of `path`, from its extension: `.png` or `.hdr` (any case).
#[cfg(feature = "images")]
fn format_of(path: &Path) -> Result<ImageFormat, ImageError> {
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match extension.as_deref() {
        Some("png") => Ok(ImageFormat::Png),
        Some("hdr") => Ok(ImageFormat::Hdr),
        _ => Err(ImageError::UnsupportedFormat {
            path: path.to_path_buf(),
            detail: "the file name must end in .png or .hdr".to_string(),
        }),
    }
}

fn check_size(path: Option<&Path>, width: u32, height: u32) -> Result<(), ImageError> {
    let pixels = u64::from(width) * u64::from(height);
    if pixels == 0 || pixels > ImagePdf::MAX_PIXELS {
        return Err(ImageError::BadSize {
            path: path.map(Path::to_path_buf),
            width,
            height,
        });
    }
    Ok(())
}

/// A piecewise-constant distribution over the pixels of an image, inverted continuously: the
/// marginal CDF over rows, then the conditional CDF over the columns of the chosen row.
pub(crate) struct PixelSampler {
    width: usize,
    /// `height + 1` cumulative row weights, starting at 0.
    row_cdf: Vec<f64>,
    /// Per row, `width + 1` cumulative pixel weights, starting at 0.
    column_cdf: Vec<f64>,
}

impl PixelSampler {
    fn new(width: u32, height: u32, weight: impl Fn(u32, u32) -> f64) -> PixelSampler {
        let w = width as usize;
        let mut column_cdf = Vec::with_capacity((w + 1) * height as usize);
        let mut row_cdf = Vec::with_capacity(height as usize + 1);
        row_cdf.push(0.0);
        for y in 0..height {
            let mut sum = 0.0;
            column_cdf.push(0.0);
            for x in 0..width {
                sum += weight(x, y);
                column_cdf.push(sum);
            }
            row_cdf.push(row_cdf[y as usize] + sum);
        }
        PixelSampler {
            width: w,
            row_cdf,
            column_cdf,
        }
    }

    /// The pixel `(x, y)` and the fractional position `(fx, fy) ∈ [0, 1)²` within it of
    /// stratum coordinates `(a, b) ∈ [0, 1)²`: `a` picks the row and `fy`, `b` the column and
    /// `fx`. Never returns a pixel of weight 0.
    fn invert(&self, a: f64, b: f64) -> (u32, u32, f64, f64) {
        let (y, fy) = invert_cdf(&self.row_cdf, a);
        let row = &self.column_cdf[y * (self.width + 1)..(y + 1) * (self.width + 1)];
        let (x, fx) = invert_cdf(row, b);
        (x as u32, y as u32, fx, fy)
    }
}

/// Index `i` with `cdf[i] ≤ t·total < cdf[i+1]` and the fraction of the way through that bin, for
/// a non-decreasing `cdf` starting at 0 with a positive total. Rounding never selects an empty
/// bin: `t·total` at or past the total falls in the last non-empty bin.
fn invert_cdf(cdf: &[f64], t: f64) -> (usize, f64) {
    let total = cdf[cdf.len() - 1];
    let target = t * total;
    let bins = cdf.len() - 1;
    let mut i = cdf[1..].partition_point(|&c| c <= target);
    if i >= bins {
        i = (0..bins)
            .rev()
            .find(|&k| cdf[k + 1] > cdf[k])
            .expect("a positive total has a non-empty bin");
    }
    let width = cdf[i + 1] - cdf[i];
    let fraction = ((target - cdf[i]) / width).clamp(0.0, 1.0 - f64::EPSILON / 2.0);
    (i, fraction)
}

/// What is wrong with one pixel's luminance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PixelProblem {
    /// Not a number.
    NaN,
    /// Positive or negative infinity.
    Infinite,
    /// Below zero (the value).
    Negative(f32),
}

/// An image that cannot serve as a density. `Display` names the file (or "the luminance image"
/// for [`ImagePdf::from_luminance`]) and, for a bad pixel, its `(x, y)` (row 0 at the top) and
/// what is wrong.
#[derive(Clone, Debug, PartialEq)]
pub enum ImageError {
    /// The file is missing, cannot be read, or its contents do not decode.
    Unreadable {
        /// The file.
        path: PathBuf,
        /// What the operating system or the decoder said.
        message: String,
    },
    /// The file is neither PNG nor Radiance HDR, or uses a variant the decoder does not support.
    UnsupportedFormat {
        /// The file.
        path: PathBuf,
        /// What is unsupported.
        detail: String,
    },
    /// The image has no pixels or more than [`ImagePdf::MAX_PIXELS`].
    BadSize {
        /// The file, if any.
        path: Option<PathBuf>,
        /// Its width in pixels.
        width: u32,
        /// Its height in pixels.
        height: u32,
    },
    /// The number of luminance values is not `width · height`.
    SizeMismatch {
        /// The file, if any.
        path: Option<PathBuf>,
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
        /// Values given.
        values: usize,
    },
    /// A pixel's luminance is NaN, infinite or negative (the first such pixel in row order).
    BadPixel {
        /// The file, if any.
        path: Option<PathBuf>,
        /// Column, from the left.
        x: u32,
        /// Row, from the top.
        y: u32,
        /// What is wrong.
        problem: PixelProblem,
    },
    /// Every pixel's luminance is zero: there is nothing to sample.
    AllZero {
        /// The file, if any.
        path: Option<PathBuf>,
    },
}

/// "image `path`" or "the luminance image".
struct Source<'a>(Option<&'a Path>);

impl fmt::Display for Source<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Some(path) => write!(f, "image `{}`", path.display()),
            None => write!(f, "the luminance image"),
        }
    }
}

impl fmt::Display for ImageError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ImageError::Unreadable { path, message } => write!(
                f,
                "{} is missing or unreadable: {message}",
                Source(Some(path))
            ),
            ImageError::UnsupportedFormat { path, detail } => write!(
                f,
                "{} has an unsupported format: {detail}",
                Source(Some(path))
            ),
            ImageError::BadSize {
                path,
                width,
                height,
            } => write!(
                f,
                "{} is {width}x{height} pixels; it must have between 1 and {} pixels",
                Source(path.as_deref()),
                ImagePdf::MAX_PIXELS
            ),
            ImageError::SizeMismatch {
                path,
                width,
                height,
                values,
            } => write!(
                f,
                "{} is {width}x{height} pixels but has {values} luminance values",
                Source(path.as_deref())
            ),
            ImageError::BadPixel {
                path,
                x,
                y,
                problem,
            } => {
                let what = match problem {
                    PixelProblem::NaN => "NaN".to_string(),
                    PixelProblem::Infinite => "infinite".to_string(),
                    PixelProblem::Negative(v) => format!("negative ({v})"),
                };
                write!(
                    f,
                    "{}: the luminance of pixel ({x}, {y}) is {what}; it must be finite and >= 0",
                    Source(path.as_deref())
                )
            }
            ImageError::AllZero { path } => write!(
                f,
                "{} has zero luminance everywhere: there is nothing to importance-sample",
                Source(path.as_deref())
            ),
        }
    }
}

impl std::error::Error for ImageError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cdf_inversion_skips_empty_bins() {
        let cdf = [0.0, 0.0, 2.0, 2.0, 3.0, 3.0];
        assert_eq!(invert_cdf(&cdf, 0.0), (1, 0.0));
        assert_eq!(invert_cdf(&cdf, 0.5), (1, 0.75));
        assert_eq!(invert_cdf(&cdf, 2.0 / 3.0).0, 3);
        // At or past the total: the last non-empty bin.
        assert_eq!(invert_cdf(&cdf, 1.0).0, 3);
    }

    #[test]
    fn solid_angles_cover_the_sphere() {
        let (w, h) = (7, 5);
        let total: f64 = (0..h)
            .map(|y| pixel_solid_angle(w, h, y) * f64::from(w))
            .sum();
        assert!((total - 4.0 * PI).abs() < 1e-12, "{total}");
    }

    #[test]
    fn direction_round_trip() {
        for (u, v) in [(0.1, 0.2), (0.9, 0.7), (0.5, 0.5), (0.0, 0.99)] {
            let d = ImagePdf::direction(u, v);
            let [u2, v2] = ImagePdf::direction_uv(d.map(|c| c as f32)).unwrap();
            assert!(
                (u - u2).abs() < 1e-6 && (v - v2).abs() < 1e-6,
                "{u} {v} → {u2} {v2}"
            );
        }
        assert_eq!(ImagePdf::direction(0.0, 0.0)[1], 1.0, "+Y is up");
    }

    #[cfg(feature = "images")]
    #[test]
    fn srgb_decoding_endpoints() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_to_linear(0.5) - 0.214).abs() < 1e-3);
    }
}
