//! Quality measures of vector masks in their own space ([`analysis`] docs, "Vector masks").
//!
//! [`analysis`]: crate::analysis#vector-masks

use std::f64::consts::{PI, TAU};

use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::convergence::{Convergence, ConvergenceOptions, estimator_rmse};
use super::histogram::{pixel_histogram_deviation, slice_histogram_deviation};
use super::{Field, FieldError};
use crate::SampleSpace;
use crate::importance::ImagePdf;

/// Midpoints per axis of the grids [`TestFunction::expected`] integrates the analytic spaces on
/// (the sphere and hemispheres; the circle uses its square).
const GRID: usize = 2048;

/// Sub-samples per image pixel and axis, at most, when [`TestFunction::expected`] integrates
/// over an image's pixels (fewer for large images, at least 1).
const MAX_PIXEL_SUBSAMPLES: usize = 256;

/// A borrowed vector mask: `width × height × depth` values of [`SampleSpace::dims`] components
/// each (index `((z · height + y) · width + x) · dims + c`) and the space they were drawn from.
#[derive(Clone, Copy, Debug)]
pub struct VectorField<'a> {
    space: &'a SampleSpace,
    width: usize,
    height: usize,
    depth: usize,
    values: &'a [f32],
}

impl<'a> VectorField<'a> {
    /// Checks the shape and that every component is finite.
    pub fn new(
        space: &'a SampleSpace,
        (width, height, depth): (usize, usize, usize),
        values: &'a [f32],
    ) -> Result<VectorField<'a>, FieldError> {
        if width == 0 || height == 0 || depth == 0 {
            return Err(FieldError::EmptyAxis {
                width,
                height,
                depth,
            });
        }
        let expected = width
            .checked_mul(height)
            .and_then(|n| n.checked_mul(depth))
            .and_then(|n| n.checked_mul(space.dims()));
        if expected != Some(values.len()) {
            return Err(FieldError::LengthMismatch {
                width,
                height,
                depth,
                len: values.len() / space.dims().max(1),
            });
        }
        if let Some(index) = values.iter().position(|v| !v.is_finite()) {
            return Err(FieldError::ValueOutOfRange {
                index,
                value: f64::from(values[index]),
            });
        }
        Ok(VectorField {
            space,
            width,
            height,
            depth,
            values,
        })
    }

    /// The space the values were drawn from.
    pub fn space(&self) -> &'a SampleSpace {
        self.space
    }

    /// `(width, height, depth)`.
    pub fn size(&self) -> (usize, usize, usize) {
        (self.width, self.height, self.depth)
    }

    /// Every component, index `((z · height + y) · width + x) · dims + c`.
    pub fn values(&self) -> &'a [f32] {
        self.values
    }

    /// Each component of every value as a scalar field in `[0, 1]` (one `Vec` per component,
    /// index `(z · height + y) · width + x`): as stored for points in `[0, 1)` (`Vec`, image
    /// points), `(c + 1) / 2` for the components of unit vectors and directions. The map is
    /// affine, so spectra and low bands ([`spatial_low_band`](super::spatial_low_band)) of these
    /// fields are those of the components themselves.
    pub fn components(&self) -> Vec<Vec<f64>> {
        let dims = self.space.dims();
        let signed = !is_point_space(self.space);
        (0..dims)
            .map(|c| {
                self.values
                    .chunks_exact(dims)
                    .map(|v| {
                        let x = f64::from(v[c]);
                        let x = if signed { (x + 1.0) * 0.5 } else { x };
                        x.clamp(0.0, 1.0)
                    })
                    .collect()
            })
            .collect()
    }

    /// The stratum coordinates of every value ([module docs](crate::analysis#vector-masks)),
    /// one `Vec` per coordinate (index `(z · height + y) · width + x`), each in `[0, 1]`:
    /// uniform exactly when the values follow the space's pdf. `None` for
    /// [`SampleSpace::UnitVec1`], whose two values have no continuous coordinate.
    pub fn stratum_coordinates(&self) -> Option<Vec<Vec<f64>>> {
        let dims = self.space.dims();
        let values = self.values.chunks_exact(dims);
        let coordinates: Vec<Vec<f64>> = match self.space {
            SampleSpace::Vec { .. } => (0..dims)
                .map(|c| {
                    let values = self.values.chunks_exact(dims);
                    values.map(|v| f64::from(v[c]).clamp(0.0, 1.0)).collect()
                })
                .collect(),
            SampleSpace::UnitVec1 => return None,
            SampleSpace::UnitVec2 => vec![values.map(|v| turn(v[0], v[1])).collect()],
            SampleSpace::UnitVec3
            | SampleSpace::UniformHemisphere
            | SampleSpace::CosineHemisphere => {
                let height = |v: &[f32]| {
                    let [x, y, z] = [0, 1, 2].map(|c| f64::from(v[c]));
                    let a = match self.space {
                        SampleSpace::UnitVec3 => (1.0 - z) * 0.5,
                        SampleSpace::UniformHemisphere => 1.0 - z,
                        // z = √(1 − a): a = 1 − z² = x² + y² on the unit sphere.
                        _ => x * x + y * y,
                    };
                    a.clamp(0.0, 1.0)
                };
                let first = values.clone().map(height).collect();
                vec![first, values.map(|v| turn(v[0], v[1])).collect()]
            }
            SampleSpace::ImagePoints(image) => {
                let cdf = ImageCdf::points(image);
                let pairs: Vec<[f64; 2]> = values
                    .map(|v| {
                        let (u, v) = (f64::from(v[0]), f64::from(v[1]));
                        let (h, w) = (image.height() as usize, image.width() as usize);
                        let (y, fy) = split(v, h);
                        let (x, fx) = split(u, w);
                        cdf.strata(x, y, fx, fy)
                    })
                    .collect();
                unzip(&pairs)
            }
            SampleSpace::EnvironmentDirections(image) => {
                let cdf = ImageCdf::directions(image);
                let (w, h) = (image.width() as usize, image.height() as usize);
                let pairs: Vec<[f64; 2]> = values
                    .map(|v| {
                        let direction = [v[0], v[1], v[2]];
                        let Some([u, v]) = ImagePdf::direction_uv(direction) else {
                            return [0.0, 0.0];
                        };
                        let (x, fx) = split(u, w);
                        let (y, _) = split(v, h);
                        // Uniform in cos θ within a row's band is uniform in solid angle.
                        let (cos0, cos1) = band_cosines(y, h);
                        let cos_t = (PI * v).cos();
                        let fy = ((cos0 - cos_t) / (cos0 - cos1)).clamp(0.0, 1.0);
                        cdf.strata(x, y, fx, fy)
                    })
                    .collect();
                unzip(&pairs)
            }
        };
        Some(coordinates)
    }

    /// White noise of the same distribution: the values shuffled over every pixel and frame
    /// with a ChaCha8 stream seeded by `seed` (each value keeps its components together).
    pub fn shuffled(&self, seed: u64) -> Vec<f32> {
        let dims = self.space.dims();
        let mut order: Vec<usize> = (0..self.values.len() / dims).collect();
        order.shuffle(&mut ChaCha8Rng::seed_from_u64(seed));
        order
            .iter()
            .flat_map(|&i| &self.values[i * dims..(i + 1) * dims])
            .copied()
            .collect()
    }
}

/// Whether `space` holds points in `[0, 1)^d` rather than unit vectors or directions.
fn is_point_space(space: &SampleSpace) -> bool {
    matches!(space, SampleSpace::Vec { .. } | SampleSpace::ImagePoints(_))
}

/// The angle of `(x, y)` in turns, in `[0, 1)`: `atan2(y, x) / 2π`, wrapped.
fn turn(x: f32, y: f32) -> f64 {
    let t = f64::from(y).atan2(f64::from(x)) / TAU;
    if t < 0.0 {
        (t + 1.0).min(1.0 - f64::EPSILON)
    } else {
        t
    }
}

/// `⌊t · n⌋` clamped to `0..n` and the fraction of `t · n` past it, in `[0, 1]`.
fn split(t: f64, n: usize) -> (usize, f64) {
    let scaled = t * n as f64;
    let i = (scaled.max(0.0) as usize).min(n - 1);
    (i, (scaled - i as f64).clamp(0.0, 1.0))
}

/// `cos θ` at the top and bottom of row `y` of a lat-long map of `height` rows (`θ = π v`).
fn band_cosines(y: usize, height: usize) -> (f64, f64) {
    let h = height as f64;
    ((PI * y as f64 / h).cos(), (PI * (y + 1) as f64 / h).cos())
}

/// Pairs as two coordinate vectors.
fn unzip(pairs: &[[f64; 2]]) -> Vec<Vec<f64>> {
    vec![
        pairs.iter().map(|p| p[0]).collect(),
        pairs.iter().map(|p| p[1]).collect(),
    ]
}

/// The cumulative weights of an image's pixels, as the generator's stratified map inverts them:
/// rows first (coordinate `a`), then the columns of a row (coordinate `b`).
struct ImageCdf {
    width: usize,
    /// `height + 1` cumulative row weights, starting at 0.
    rows: Vec<f64>,
    /// Per row, `width + 1` cumulative pixel weights, starting at 0.
    columns: Vec<f64>,
}

impl ImageCdf {
    /// Weights `L` (points: density ∝ luminance per area).
    fn points(image: &ImagePdf) -> ImageCdf {
        ImageCdf::new(image, |_| 1.0)
    }

    /// Weights `L · Ω` (directions: density ∝ luminance per steradian; `Ω` of a row is
    /// proportional to the difference of its band's cosines).
    fn directions(image: &ImagePdf) -> ImageCdf {
        let h = image.height() as usize;
        ImageCdf::new(image, |y| {
            let (cos0, cos1) = band_cosines(y, h);
            cos0 - cos1
        })
    }

    fn new(image: &ImagePdf, row_weight: impl Fn(usize) -> f64) -> ImageCdf {
        let (w, h) = (image.width() as usize, image.height() as usize);
        let luminance = image.luminance();
        let mut rows = Vec::with_capacity(h + 1);
        let mut columns = Vec::with_capacity((w + 1) * h);
        rows.push(0.0);
        for y in 0..h {
            let scale = row_weight(y);
            let mut sum = 0.0;
            columns.push(0.0);
            for &l in &luminance[y * w..(y + 1) * w] {
                sum += f64::from(l) * scale;
                columns.push(sum);
            }
            rows.push(rows[y] + sum);
        }
        ImageCdf {
            width: w,
            rows,
            columns,
        }
    }

    /// The weight of pixel `(x, y)` over the total.
    fn mass(&self, x: usize, y: usize) -> f64 {
        let row = &self.columns[y * (self.width + 1)..];
        (row[x + 1] - row[x]) / self.rows[self.rows.len() - 1]
    }

    /// The stratum coordinates `(a, b)` of fractional position `(fx, fy)` in pixel `(x, y)`.
    fn strata(&self, x: usize, y: usize, fx: f64, fy: f64) -> [f64; 2] {
        let total = self.rows[self.rows.len() - 1];
        let a = (self.rows[y] + fy * (self.rows[y + 1] - self.rows[y])) / total;
        let row = &self.columns[y * (self.width + 1)..(y + 1) * (self.width + 1)];
        let row_total = row[self.width];
        let b = if row_total > 0.0 {
            (row[x] + fx * (row[x + 1] - row[x])) / row_total
        } else {
            fx
        };
        [a.clamp(0.0, 1.0), b.clamp(0.0, 1.0)]
    }
}

/// How far a vector mask's values are from its space's pdf, per frame and per pixel over the
/// frames ([`distribution_deviation`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DistributionDeviation {
    /// The largest relative deviation of any frame's histogram from the pdf: [`slice_histogram_deviation`]
    /// of each stratum coordinate, the worst coordinate. 0 = every frame holds exactly its share
    /// of each of `bins` equal-probability bands.
    pub frame: f64,
    /// The Kolmogorov–Smirnov distance of each pixel's values over the frames from the pdf:
    /// [`pixel_histogram_deviation`] of each stratum coordinate, averaged over coordinates.
    /// `1/(2·frames)` at best, about `0.87/√frames` for white noise.
    pub pixel: f64,
}

/// How far the values of `field` are from its space's pdf ([module docs](crate::analysis#vector-masks)):
/// the histogram measures of scalar masks, on the stratum coordinates. [`SampleSpace::UnitVec1`]
/// counts its two values instead: the frame figure is the largest `|count(+1) − n/2| / (n/2)`
/// over frames of `n` pixels, the pixel figure the mean over pixels of `|share of +1 − ½|`
/// (the Kolmogorov–Smirnov distance from the two-point law; 0 at best for an even number of
/// frames, about `0.40/√frames` for white noise). Panics if `bins == 0`.
pub fn distribution_deviation(field: &VectorField, bins: usize) -> DistributionDeviation {
    let (w, h, d) = field.size();
    let Some(coordinates) = field.stratum_coordinates() else {
        let n = w * h;
        let plus = |z: usize, p: usize| field.values[z * n + p] > 0.0;
        let frame = (0..d)
            .map(|z| {
                let count = (0..n).filter(|&p| plus(z, p)).count() as f64;
                (count - n as f64 / 2.0).abs() / (n as f64 / 2.0)
            })
            .fold(0.0, f64::max);
        let pixel = (0..n)
            .map(|p| {
                let share = (0..d).filter(|&z| plus(z, p)).count() as f64 / d as f64;
                (share - 0.5).abs()
            })
            .sum::<f64>()
            / n as f64;
        return DistributionDeviation { frame, pixel };
    };
    let fields: Vec<Field> = coordinates
        .iter()
        .map(|c| Field::new(w, h, d, c).expect("stratum coordinates are in [0, 1]"))
        .collect();
    DistributionDeviation {
        frame: fields
            .iter()
            .map(|f| slice_histogram_deviation(f, bins))
            .fold(0.0, f64::max),
        pixel: fields.iter().map(pixel_histogram_deviation).sum::<f64>() / fields.len() as f64,
    }
}

/// A test function on the values of a vector mask whose expectation under the space's pdf is
/// known ([module docs](crate::analysis#vector-masks)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TestFunction {
    /// Smooth. Points in `[0, 1)^d`: `Π sin(π vᶜ)`. Unit vectors and directions `ω` (padded to
    /// 3D with zeros): the lobe `exp(4 (ω · n − 1))` around `n = (0.3, 0.2, 0.93)` normalised,
    /// like light from a soft, bright region.
    Smooth,
    /// An edge. Points: `1` where `Σ vᶜ < d / 2`, else `0`. Unit vectors and directions: `1`
    /// where `ω · m > 0` for `m = (0.8, 0.3, 0.5)` normalised, like a shadowing wall tilted
    /// across the hemisphere.
    Edge,
}

impl TestFunction {
    /// Both functions, in report order.
    pub const ALL: [TestFunction; 2] = [TestFunction::Smooth, TestFunction::Edge];

    /// A lower-case name: `smooth` or `edge`.
    pub fn name(self) -> &'static str {
        match self {
            TestFunction::Smooth => "smooth",
            TestFunction::Edge => "edge",
        }
    }

    /// What the function is in `space`, for a report (a formula in words).
    pub fn describe(self, space: &SampleSpace) -> &'static str {
        match (self, is_point_space(space)) {
            (TestFunction::Smooth, true) => "Π sin(π vᶜ) over the components",
            (TestFunction::Edge, true) => "[Σ vᶜ < d/2] (a diagonal edge)",
            (TestFunction::Smooth, false) => "exp(4 (ω·n − 1)), a smooth lobe around a tilted n",
            (TestFunction::Edge, false) => "[ω·m > 0], a tilted half-space (a shadow edge)",
        }
    }

    /// The function at `value` (`space.dims()` components).
    pub fn eval(self, space: &SampleSpace, value: &[f32]) -> f64 {
        let value = &value[..space.dims()];
        if is_point_space(space) {
            return match self {
                TestFunction::Smooth => value.iter().map(|&c| (PI * f64::from(c)).sin()).product(),
                TestFunction::Edge => {
                    let sum: f64 = value.iter().map(|&c| f64::from(c)).sum();
                    f64::from(u8::from(sum < value.len() as f64 / 2.0))
                }
            };
        }
        let mut omega = [0.0; 3];
        for (o, &c) in omega.iter_mut().zip(value) {
            *o = f64::from(c);
        }
        self.on_direction(omega)
    }

    /// The function of a direction (unit or not; only its dot products are used).
    fn on_direction(self, omega: [f64; 3]) -> f64 {
        let dot = |a: [f64; 3]| {
            let norm = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
            (omega[0] * a[0] + omega[1] * a[1] + omega[2] * a[2]) / norm
        };
        match self {
            TestFunction::Smooth => (4.0 * (dot([0.3, 0.2, 0.93]) - 1.0)).exp(),
            TestFunction::Edge => f64::from(u8::from(dot([0.8, 0.3, 0.5]) > 0.0)),
        }
    }

    /// The expectation of the function under `space`'s pdf: exact for `Vec` (`(2/π)^d` and ½)
    /// and `UnitVec1`; otherwise a midpoint rule, on a `2048 × 2048` grid of stratum
    /// coordinates for the sphere and hemispheres (`2048²` points of the circle for `UnitVec2`),
    /// and over the pixels of the image (`2048²` sub-samples in all, at least one per pixel and at most
    /// 256 × 256) for image spaces.
    /// Accurate to about 10⁻⁶ for the smooth function and 10⁻³ for the edge, far below the
    /// errors the report shows.
    pub fn expected(self, space: &SampleSpace) -> f64 {
        match space {
            SampleSpace::Vec { dims } => match self {
                TestFunction::Smooth => (2.0 / PI).powi(i32::from(*dims)),
                TestFunction::Edge => 0.5,
            },
            SampleSpace::UnitVec1 => {
                0.5 * (self.on_direction([1.0, 0.0, 0.0]) + self.on_direction([-1.0, 0.0, 0.0]))
            }
            SampleSpace::UnitVec2 => {
                let n = GRID * GRID;
                (0..n)
                    .into_par_iter()
                    .map(|i| {
                        let (sin, cos) = (TAU * (i as f64 + 0.5) / n as f64).sin_cos();
                        self.on_direction([cos, sin, 0.0])
                    })
                    .sum::<f64>()
                    / n as f64
            }
            SampleSpace::UnitVec3
            | SampleSpace::UniformHemisphere
            | SampleSpace::CosineHemisphere => {
                let sum: f64 = (0..GRID)
                    .into_par_iter()
                    .map(|i| {
                        let a = (i as f64 + 0.5) / GRID as f64;
                        let z = match space {
                            SampleSpace::UnitVec3 => 1.0 - 2.0 * a,
                            SampleSpace::UniformHemisphere => 1.0 - a,
                            _ => (1.0 - a).sqrt(),
                        };
                        let r = (1.0 - z * z).max(0.0).sqrt();
                        (0..GRID)
                            .map(|j| {
                                let (sin, cos) = (TAU * (j as f64 + 0.5) / GRID as f64).sin_cos();
                                self.on_direction([r * cos, r * sin, z])
                            })
                            .sum::<f64>()
                    })
                    .sum();
                sum / (GRID * GRID) as f64
            }
            SampleSpace::ImagePoints(image) => {
                let (w, h) = (image.width() as usize, image.height() as usize);
                let cdf = ImageCdf::points(image);
                self.over_pixels(&cdf, w, h, |x, y, fx, fy| {
                    let (u, v) = ((x as f64 + fx) / w as f64, (y as f64 + fy) / h as f64);
                    self.eval(space, &[u as f32, v as f32])
                })
            }
            SampleSpace::EnvironmentDirections(image) => {
                let (w, h) = (image.width() as usize, image.height() as usize);
                let cdf = ImageCdf::directions(image);
                self.over_pixels(&cdf, w, h, |x, y, fx, fy| {
                    let (cos0, cos1) = band_cosines(y, h);
                    let theta = (cos0 + fy * (cos1 - cos0)).clamp(-1.0, 1.0).acos();
                    let u = (x as f64 + fx) / w as f64;
                    self.on_direction(ImagePdf::direction(u, theta / PI))
                })
            }
        }
    }

    /// `Σ mass(x, y) · mean of f(x, y, fx, fy)` over a `k × k` midpoint grid of fractional
    /// positions in each pixel.
    fn over_pixels(
        self,
        cdf: &ImageCdf,
        width: usize,
        height: usize,
        f: impl Fn(usize, usize, f64, f64) -> f64 + Sync,
    ) -> f64 {
        let budget = (GRID * GRID) / (width * height).max(1);
        let k = ((budget as f64).sqrt() as usize).clamp(1, MAX_PIXEL_SUBSAMPLES);
        (0..height)
            .into_par_iter()
            .map(|y| {
                (0..width)
                    .map(|x| {
                        let mass = cdf.mass(x, y);
                        if mass == 0.0 {
                            return 0.0;
                        }
                        let mut sum = 0.0;
                        for i in 0..k {
                            for j in 0..k {
                                let fx = (i as f64 + 0.5) / k as f64;
                                let fy = (j as f64 + 0.5) / k as f64;
                                sum += f(x, y, fx, fy);
                            }
                        }
                        mass * sum / (k * k) as f64
                    })
                    .sum::<f64>()
            })
            .sum()
    }
}

/// The RMSE over pixels of the Monte Carlo and EMA estimates of the expectation of `function`
/// under the space's pdf, `exact` ([`TestFunction::expected`], passed in so a caller measuring
/// several masks of one space computes it once), with each pixel's values over the frames as
/// samples ([`convergence`](super::convergence()) docs; same estimators and wrap-around).
/// Deterministic for any thread count. Panics if `samples == 0` or `alpha ∉ (0, 1]`.
pub fn vector_convergence(
    field: &VectorField,
    function: TestFunction,
    exact: f64,
    options: ConvergenceOptions,
) -> Convergence {
    let (w, h, d) = field.size();
    let dims = field.space.dims();
    let n = w * h;
    estimator_rmse(n, d, options, exact, |z, pixels| {
        let slice = &field.values[z * n * dims..(z + 1) * n * dims];
        slice[pixels.start * dims..pixels.end * dims]
            .chunks_exact(dims)
            .map(move |v| function.eval(field.space, v))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Observer, VectorSpec, generate_vector};

    /// Every value of a 16 × 16 × 16 mask of `space`, generated with a small budget.
    fn mask(space: SampleSpace) -> (SampleSpace, Vec<f32>) {
        let spec = VectorSpec::new(16, 16, 16, 3, space.clone()).with_swaps_per_pixel(16.0);
        let volume = generate_vector(&spec, Observer::default()).unwrap();
        (space, volume.values().to_vec())
    }

    #[test]
    fn stratum_coordinates_invert_the_generators_maps() {
        // Each slice of a generated mask is a latinised set: every coordinate of every frame
        // holds one value in each of the n strata, so 16 bins of 256 values are exact.
        for space in [
            SampleSpace::Vec { dims: 2 },
            SampleSpace::UnitVec2,
            SampleSpace::UnitVec3,
            SampleSpace::UniformHemisphere,
            SampleSpace::CosineHemisphere,
        ] {
            let (space, values) = mask(space);
            let field = VectorField::new(&space, (16, 16, 16), &values).unwrap();
            let deviation = distribution_deviation(&field, 16);
            assert!(deviation.frame < 0.07, "{space:?}: {deviation:?}");
        }
    }

    #[test]
    fn a_generated_cosine_hemisphere_beats_white_noise_of_its_distribution() {
        let (space, values) = mask(SampleSpace::CosineHemisphere);
        let field = VectorField::new(&space, (16, 16, 16), &values).unwrap();
        let shuffled = field.shuffled(1);
        let white = VectorField::new(&space, (16, 16, 16), &shuffled).unwrap();
        let (mask_dev, white_dev) = (
            distribution_deviation(&field, 16),
            distribution_deviation(&white, 16),
        );
        // White noise: about 0.87/√16 = 0.22 per pixel, and frames off by tens of percent; the
        // mask's frames are exact and its pixels' sequences closer to the pdf.
        assert_eq!(mask_dev.frame, 0.0);
        assert!(
            mask_dev.pixel < 0.85 * white_dev.pixel,
            "{mask_dev:?} {white_dev:?}"
        );
        assert!(white_dev.frame > 0.2, "{white_dev:?}");
        for function in TestFunction::ALL {
            let exact = function.expected(&space);
            let options = ConvergenceOptions::new(16);
            let ours = vector_convergence(&field, function, exact, options).monte_carlo[15];
            let theirs = vector_convergence(&white, function, exact, options).monte_carlo[15];
            assert!(
                ours < 0.7 * theirs,
                "{}: {ours} vs {theirs}",
                function.name()
            );
        }
    }

    #[test]
    fn expectations_match_closed_forms() {
        // Uniform sphere: a half-space through the centre holds half the directions, and
        // E[exp(4(cos θ − 1))] = ½ ∫₋₁¹ e^(4(c − 1)) dc = (1 − e⁻⁸) / 8.
        let sphere = SampleSpace::UnitVec3;
        assert!((TestFunction::Edge.expected(&sphere) - 0.5).abs() < 1e-3);
        let lobe = (1.0 - (-8.0f64).exp()) / 8.0;
        assert!((TestFunction::Smooth.expected(&sphere) - lobe).abs() < 1e-6);
        let circle = SampleSpace::UnitVec2;
        assert!((TestFunction::Edge.expected(&circle) - 0.5).abs() < 1e-6);
        assert_eq!(TestFunction::Edge.expected(&SampleSpace::UnitVec1), 0.5);
        // A constant image: image points are uniform, so they match Vec2's closed forms.
        let flat = ImagePdf::from_luminance(4, 4, vec![1.0; 16]).unwrap();
        let points = SampleSpace::ImagePoints(std::sync::Arc::new(flat.clone()));
        for f in TestFunction::ALL {
            let vec2 = f.expected(&SampleSpace::Vec { dims: 2 });
            assert!((f.expected(&points) - vec2).abs() < 1e-3, "{}", f.name());
        }
        // A constant environment: uniform directions, as the sphere.
        let env = SampleSpace::EnvironmentDirections(std::sync::Arc::new(flat));
        for f in TestFunction::ALL {
            let uniform = f.expected(&sphere);
            assert!((f.expected(&env) - uniform).abs() < 2e-3, "{}", f.name());
        }
    }

    #[test]
    fn unit_vec1_counts_signs() {
        // Two pixels, two frames: pixel 0 alternates (share ½), pixel 1 is always +1.
        let space = SampleSpace::UnitVec1;
        let values = [1.0, 1.0, -1.0, 1.0];
        let field = VectorField::new(&space, (2, 1, 2), &values).unwrap();
        let deviation = distribution_deviation(&field, 16);
        assert_eq!(deviation.frame, 1.0); // frame 0 is all +1
        assert_eq!(deviation.pixel, 0.25); // (0 + ½) / 2
    }

    #[test]
    fn shapes_and_non_finite_values_are_refused() {
        let space = SampleSpace::UnitVec2;
        assert!(VectorField::new(&space, (2, 1, 1), &[1.0, 0.0, 0.0]).is_err());
        assert!(VectorField::new(&space, (1, 1, 1), &[f32::NAN, 0.0]).is_err());
        assert!(VectorField::new(&space, (0, 1, 1), &[]).is_err());
    }
}
