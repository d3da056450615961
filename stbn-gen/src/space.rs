//! Sample spaces of vector masks: [`SampleSpace`] and the stratified sample set each slice starts
//! from.

use std::sync::Arc;

use rand::seq::SliceRandom;
use rand::{Rng, RngExt};
use rand_chacha::ChaCha8Rng;

use crate::importance::{ImagePdf, PixelSampler};

/// The set the values of a vector mask are drawn from, and with which density.
///
/// Two spaces are equal when their kind and (for image spaces) their images are equal.
///
/// # Conventions
///
/// - [`SampleSpace::Vec`]: `dims` components, each in `[0, 1)`.
/// - [`SampleSpace::UnitVec1`]: one component, `+1` or `−1`.
/// - [`SampleSpace::UnitVec2`]: `(cos φ, sin φ)`.
/// - [`SampleSpace::UnitVec3`]: `(x, y, z)` on the unit sphere.
/// - [`SampleSpace::UniformHemisphere`] and [`SampleSpace::CosineHemisphere`]: `(x, y, z)` on the
///   unit sphere with `z ≥ 0`: the hemisphere around `+Z` (tangent-space convention).
/// - [`SampleSpace::ImagePoints`]: `(u, v)` in `[0, 1)²`, `u` along image rows (left to right),
///   `v` down the image (row 0 is the top row): pixel `(⌊u·W⌋, ⌊v·H⌋)`.
/// - [`SampleSpace::EnvironmentDirections`]: unit `(x, y, z)` with `+Y` up, from a lat-long map
///   ([`ImagePdf::direction`] has the mapping).
///
/// # Stratified slices
///
/// Each slice of a vector mask holds one sample set of `W·H` values, drawn from a seeded stream
/// per slice and then only permuted by the optimiser. The set starts from a low-discrepancy set
/// of the unit square or hypercube (the rank-1 lattice of the generalised golden ratio, `R_d`,
/// for up to two components, the Halton sequence for three and four) under a random toroidal
/// shift, *latinised*: every component is replaced by `(rank + jitter) / n`, where `rank` is the point's rank in that
/// component and `jitter` uniform in `[0, 1)`. So each component is exactly stratified (one value
/// in each interval `[i/n, (i+1)/n)`) while the points keep the lattice's joint spread. The
/// spaces other than [`SampleSpace::Vec`] map these points through an area-preserving map (polar
/// coordinates in `z` or `z²`, or the inverse CDF of an image), so the strata stay equal-area on
/// the circle, sphere, hemisphere or image.
#[derive(Clone, Debug, PartialEq)]
pub enum SampleSpace {
    /// Uniform in `[0, 1)^dims`, `dims` in `1..=4`. Density 1.
    Vec {
        /// Components per value, `1..=4`.
        dims: u8,
    },
    /// `+1` or `−1`, stored as one component, each with probability ½ (half of each slice's
    /// values are `+1`; an odd pixel count gives one extra value of a seeded random sign).
    UnitVec1,
    /// Uniform on the unit circle, density `1/(2π)` per radian.
    UnitVec2,
    /// Uniform on the unit sphere, density `1/(4π)` per steradian.
    UnitVec3,
    /// Uniform on the hemisphere `z ≥ 0`, density `1/(2π)` per steradian.
    UniformHemisphere,
    /// Cosine-weighted on the hemisphere `z ≥ 0`, density `cos θ / π = z / π` per steradian.
    CosineHemisphere,
    /// Points in `[0, 1)²` with density proportional to the image's luminance: `L(pixel) /
    /// mean(L)` with respect to area in `[0, 1)²` (so it integrates to 1), constant over each
    /// image pixel.
    ImagePoints(Arc<ImagePdf>),
    /// Unit directions (`+Y` up) distributed by a lat-long environment map: density per steradian
    /// proportional to the luminance of the pixel the direction falls in, `L(pixel) / Σ L·Ω`,
    /// where `Ω` is each pixel's solid angle (so the `sin θ` Jacobian of the lat-long mapping is
    /// included).
    EnvironmentDirections(Arc<ImagePdf>),
}

impl SampleSpace {
    /// Components of one value: `Vec { dims }` → `dims`, [`SampleSpace::UnitVec1`] → 1,
    /// [`SampleSpace::UnitVec2`] and [`SampleSpace::ImagePoints`] → 2, the sphere, hemispheres and
    /// environment directions → 3.
    pub fn dims(&self) -> usize {
        match self {
            SampleSpace::Vec { dims } => usize::from(*dims),
            SampleSpace::UnitVec1 => 1,
            SampleSpace::UnitVec2 | SampleSpace::ImagePoints(_) => 2,
            SampleSpace::UnitVec3
            | SampleSpace::UniformHemisphere
            | SampleSpace::CosineHemisphere
            | SampleSpace::EnvironmentDirections(_) => 3,
        }
    }

    /// An upper bound on the squared distance between two values of the space: `dims` for
    /// points of the unit cube (`Vec`, `ImagePoints`), 4 for signs and unit directions
    /// (antipodes).
    pub(crate) fn largest_squared_distance(&self) -> f32 {
        match self {
            SampleSpace::Vec { dims } => f32::from(*dims),
            SampleSpace::ImagePoints(_) => 2.0,
            _ => 4.0,
        }
    }

    /// Parameters of each value: the dimension of the unit cube its stratified sets correspond to
    /// ([`StratifiedSampler::slice_with_parameters`]): `dims` for [`SampleSpace::Vec`], 1 for the
    /// sign of `UnitVec1` and the angle of `UnitVec2`, 2 for spheres, hemispheres and images.
    pub(crate) fn parameters(&self) -> usize {
        match self {
            SampleSpace::Vec { dims } => usize::from(*dims),
            SampleSpace::UnitVec1 | SampleSpace::UnitVec2 => 1,
            _ => 2,
        }
    }

    /// A stable lowercase name for file names, reports and sidecars: `vec1` … `vec4`, `unitvec1`,
    /// `unitvec2`, `unitvec3`, `uniform_hemisphere`, `cosine_hemisphere`, `image_points`,
    /// `environment`. `Vec` with an out-of-range `dims` is `vec_invalid`.
    pub fn name(&self) -> &'static str {
        match self {
            SampleSpace::Vec { dims: 1 } => "vec1",
            SampleSpace::Vec { dims: 2 } => "vec2",
            SampleSpace::Vec { dims: 3 } => "vec3",
            SampleSpace::Vec { dims: 4 } => "vec4",
            SampleSpace::Vec { .. } => "vec_invalid",
            SampleSpace::UnitVec1 => "unitvec1",
            SampleSpace::UnitVec2 => "unitvec2",
            SampleSpace::UnitVec3 => "unitvec3",
            SampleSpace::UniformHemisphere => "uniform_hemisphere",
            SampleSpace::CosineHemisphere => "cosine_hemisphere",
            SampleSpace::ImagePoints(_) => "image_points",
            SampleSpace::EnvironmentDirections(_) => "environment",
        }
    }

    /// Whether the space is usable: `Vec { dims }` needs `dims` in `1..=4`; every other space is.
    pub fn is_valid(&self) -> bool {
        !matches!(self, SampleSpace::Vec { dims } if !(1..=4).contains(dims))
    }

    /// The density the values were drawn from, at `value` (`dims()` components):
    ///
    /// - `Vec`: 1 inside `[0, 1)^dims`, else 0.
    /// - `UnitVec1`: probability ½ for `±1` (a probability mass, not a density), else 0.
    /// - `UnitVec2`: `1/(2π)` per radian; `UnitVec3`: `1/(4π)` per steradian (the value is assumed
    ///   to be on the circle or sphere; its norm is not checked).
    /// - `UniformHemisphere`: `1/(2π)` per steradian where `z ≥ 0`, else 0.
    /// - `CosineHemisphere`: `z/π` per steradian where `z ≥ 0`, else 0.
    /// - `ImagePoints`: [`ImagePdf::point_pdf`]; `EnvironmentDirections`:
    ///   [`ImagePdf::direction_pdf`].
    ///
    /// Panics if `value` has fewer than `dims()` components.
    pub fn pdf(&self, value: &[f32]) -> f32 {
        use std::f32::consts::PI;
        let value = &value[..self.dims()];
        match self {
            SampleSpace::Vec { .. } => {
                if value.iter().all(|&c| (0.0..1.0).contains(&c)) {
                    1.0
                } else {
                    0.0
                }
            }
            SampleSpace::UnitVec1 => {
                if value[0].abs() == 1.0 {
                    0.5
                } else {
                    0.0
                }
            }
            SampleSpace::UnitVec2 => 0.5 / PI,
            SampleSpace::UnitVec3 => 0.25 / PI,
            SampleSpace::UniformHemisphere => {
                if value[2] >= 0.0 {
                    0.5 / PI
                } else {
                    0.0
                }
            }
            SampleSpace::CosineHemisphere => value[2].max(0.0) / PI,
            SampleSpace::ImagePoints(image) => image.point_pdf([value[0], value[1]]),
            SampleSpace::EnvironmentDirections(image) => {
                image.direction_pdf([value[0], value[1], value[2]])
            }
        }
    }

    /// Whether masks of this space store a pdf channel: true only for the two image spaces (the
    /// others' densities follow from the value, see [`SampleSpace::pdf`]).
    pub fn stores_pdf(&self) -> bool {
        matches!(
            self,
            SampleSpace::ImagePoints(_) | SampleSpace::EnvironmentDirections(_)
        )
    }

    /// This space prepared for drawing stratified slices: the image spaces build their CDFs
    /// here, once. Panics if the space is not [valid](SampleSpace::is_valid).
    pub(crate) fn stratified_sampler(&self) -> StratifiedSampler<'_> {
        assert!(self.is_valid(), "invalid sample space {self:?}");
        let pixels = match self {
            SampleSpace::ImagePoints(image) => Some(image.point_sampler()),
            SampleSpace::EnvironmentDirections(image) => Some(image.direction_sampler()),
            _ => None,
        };
        StratifiedSampler {
            space: self,
            pixels,
        }
    }
}

/// Draws stratified sample sets of one [`SampleSpace`] ([`SampleSpace::stratified_sampler`]).
pub(crate) struct StratifiedSampler<'a> {
    space: &'a SampleSpace,
    /// The image spaces' CDFs.
    pixels: Option<PixelSampler>,
}

impl StratifiedSampler<'_> {
    /// `count` values (`count · dims()` components, value `i` at `i·dims()..`) forming one
    /// stratified sample set of the space ([`SampleSpace`]'s docs), in a random order: the initial
    /// state of one slice. Deterministic for a given `rng` state.
    pub(crate) fn slice(&self, count: usize, rng: &mut ChaCha8Rng) -> Vec<f32> {
        let (mut values, _) = self.slice_with_parameters(count, rng);
        shuffle_values(&mut values, self.space.dims(), rng);
        values
    }

    /// The values [`StratifiedSampler::slice`] shuffles, in the lattice's order, and the point
    /// of `[0, 1]^`[`parameters`](SampleSpace::parameters) each corresponds to, one-to-one
    /// and area-preserving (value `i` from parameters `i·parameters()..`): the lattice point it
    /// is mapped from, but for spheres and hemispheres the concentric square of their disc
    /// ([`disc_squares`]), and for `UnitVec1` `(i + ½)/count`, the `+1`s first.
    pub(crate) fn slice_with_parameters(
        &self,
        count: usize,
        rng: &mut ChaCha8Rng,
    ) -> (Vec<f32>, Vec<f64>) {
        let space = self.space;
        let mut values: Vec<f32> = Vec::with_capacity(count * space.dims());
        let parameters = match (space, &self.pixels) {
            (SampleSpace::Vec { dims }, _) => {
                let points = latinised_lattice(count, usize::from(*dims), rng);
                values.extend(points.iter().map(|&c| below_one(c)));
                points
            }
            (SampleSpace::UnitVec1, _) => {
                let odd_sign = if rng.next_u32() & 1 == 0 { 1.0 } else { -1.0 };
                values.extend((0..count).map(|i| {
                    if 2 * i + 1 == count {
                        odd_sign
                    } else if i < count / 2 {
                        1.0
                    } else {
                        -1.0
                    }
                }));
                (0..count)
                    .map(|i| (i as f64 + 0.5) / count as f64)
                    .collect()
            }
            (SampleSpace::UnitVec2, _) => {
                let angles = latinised_lattice(count, 1, rng);
                for &a in &angles {
                    let (sin, cos) = (std::f64::consts::TAU * a).sin_cos();
                    values.extend([cos as f32, sin as f32]);
                }
                angles
            }
            (SampleSpace::UnitVec3 | SampleSpace::UniformHemisphere, _) => {
                let sphere = *space == SampleSpace::UnitVec3;
                let points = latinised_lattice(count, 2, rng);
                for ab in points.chunks_exact(2) {
                    // Archimedes: z uniform in [−1, 1] (or (0, 1]) is uniform in area.
                    let z = if sphere {
                        1.0 - 2.0 * ab[0]
                    } else {
                        1.0 - ab[0]
                    };
                    values.extend(unit_from_z_phi(z, ab[1]));
                }
                disc_squares(&points)
            }
            (SampleSpace::CosineHemisphere, _) => {
                let points = latinised_lattice(count, 2, rng);
                for ab in points.chunks_exact(2) {
                    // Malley: uniform in the unit disc (r² = a), lifted to the hemisphere.
                    values.extend(unit_from_z_phi((1.0 - ab[0]).sqrt(), ab[1]));
                }
                disc_squares(&points)
            }
            (SampleSpace::ImagePoints(image), Some(sampler)) => {
                let points = latinised_lattice(count, 2, rng);
                for ab in points.chunks_exact(2) {
                    values.extend(image.sample_point(sampler, ab[0], ab[1]));
                }
                points
            }
            (SampleSpace::EnvironmentDirections(image), Some(sampler)) => {
                let points = latinised_lattice(count, 2, rng);
                for ab in points.chunks_exact(2) {
                    values.extend(image.sample_direction(sampler, ab[0], ab[1]));
                }
                points
            }
            (SampleSpace::ImagePoints(_) | SampleSpace::EnvironmentDirections(_), None) => {
                unreachable!("image spaces get their sampler in stratified_sampler")
            }
        };
        debug_assert_eq!(parameters.len(), count * space.parameters());
        (values, parameters)
    }
}

/// Bits per axis of [`hilbert_key`].
const HILBERT_BITS: u32 = 16;

/// The position of `value` (`space.dims()` components) along a Hilbert curve through the
/// space's bounding box (`[0, 1)^d` for `Vec` and image points, `[−1, 1]^d` for unit vectors and
/// directions), 16 bits per axis. Values close along the curve are close in value space, so
/// sorting a sample set by this key and handing it out in the order of a scalar blue-noise mask's
/// ranks places similar values far apart.
pub(crate) fn hilbert_key(space: &SampleSpace, value: &[f32]) -> u64 {
    let (lo, hi) = match space {
        SampleSpace::Vec { .. } | SampleSpace::ImagePoints(_) => (0.0, 1.0),
        _ => (-1.0, 1.0),
    };
    let mut unit = [0.0f64; 4];
    for (t, &v) in unit.iter_mut().zip(&value[..space.dims()]) {
        *t = (f64::from(v) - lo) / (hi - lo);
    }
    unit_hilbert_key(&unit[..space.dims()])
}

/// The position of the point `unit` of `[0, 1]^d` (`d ≤ 4`, coordinates clamped to the cube)
/// along a Hilbert curve through it, 16 bits per axis.
pub(crate) fn unit_hilbert_key(unit: &[f64]) -> u64 {
    let scale = f64::from(1u32 << HILBERT_BITS);
    let mut axes = [0u32; 4];
    for (axis, &t) in axes.iter_mut().zip(unit) {
        *axis = (t * scale).clamp(0.0, scale - 1.0) as u32;
    }
    hilbert_index(&mut axes[..unit.len()], HILBERT_BITS)
}

/// The Hilbert index of the point `axes` (each `< 2^bits`, `dims · bits ≤ 64`): Skilling's
/// transform of the axes into the "transposed" index (J. Skilling, *Programming the Hilbert
/// curve*, AIP Conf. Proc. 707, 2004), whose bits are then interleaved, most significant first.
fn hilbert_index(axes: &mut [u32], bits: u32) -> u64 {
    let n = axes.len();
    let top = 1u32 << (bits - 1);
    // Undo the excess work of the curve's reflections and rotations.
    let mut q = top;
    while q > 1 {
        let p = q - 1;
        for i in 0..n {
            if axes[i] & q != 0 {
                axes[0] ^= p;
            } else {
                let t = (axes[0] ^ axes[i]) & p;
                axes[0] ^= t;
                axes[i] ^= t;
            }
        }
        q >>= 1;
    }
    // Gray encode.
    for i in 1..n {
        axes[i] ^= axes[i - 1];
    }
    let mut t = 0;
    let mut q = top;
    while q > 1 {
        if axes[n - 1] & q != 0 {
            t ^= q - 1;
        }
        q >>= 1;
    }
    for axis in axes.iter_mut() {
        *axis ^= t;
    }
    let mut index = 0u64;
    for bit in (0..bits).rev() {
        for &axis in axes.iter() {
            index = (index << 1) | u64::from((axis >> bit) & 1);
        }
    }
    index
}

/// `(√(1 − z²) cos 2πb, √(1 − z²) sin 2πb, z)` as `f32`, for `z` in `[−1, 1]`, `b` in `[0, 1)`.
fn unit_from_z_phi(z: f64, b: f64) -> [f32; 3] {
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (sin, cos) = (std::f64::consts::TAU * b).sin_cos();
    [(r * cos) as f32, (r * sin) as f32, z as f32]
}

/// The parameters of sphere and hemisphere values drawn from the lattice `points` (`(a, b)`
/// pairs): the point of the unit square that the concentric map takes to the disc point at
/// radius `√a`, angle `2πb`, where `(a, b)` maps area-preservingly to the disc (Malley's disc of
/// the cosine hemisphere; Lambert's azimuthal projection of the sphere and uniform hemisphere,
/// about +Z). The square's axes follow the disc's `x` and `y`, so on hemispheres they follow
/// the values' first two components.
fn disc_squares(points: &[f64]) -> Vec<f64> {
    points
        .chunks_exact(2)
        .flat_map(|ab| concentric_square(ab[0].sqrt(), std::f64::consts::TAU * ab[1]))
        .collect()
}

/// The point of `[0, 1]²` that Shirley and Chiu's concentric map takes to the disc point at
/// radius `r` and angle `phi`: the map is equal-area, so a uniform disc gives a uniform square,
/// and its axes follow the disc's `x` and `y`.
fn concentric_square(r: f64, phi: f64) -> [f64; 2] {
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    // φ in [−π/4, 7π/4).
    let phi = phi.rem_euclid(2.0 * PI);
    let phi = if phi >= 7.0 * FRAC_PI_4 {
        phi - 2.0 * PI
    } else {
        phi
    };
    let (a, b) = if phi < FRAC_PI_4 {
        (r, phi / FRAC_PI_4 * r)
    } else if phi < 3.0 * FRAC_PI_4 {
        (-(phi - FRAC_PI_2) / FRAC_PI_4 * r, r)
    } else if phi < 5.0 * FRAC_PI_4 {
        (-r, -(phi - PI) / FRAC_PI_4 * r)
    } else {
        ((phi - 3.0 * FRAC_PI_2) / FRAC_PI_4 * r, -r)
    };
    [(a + 1.0) * 0.5, (b + 1.0) * 0.5]
}

/// `x` as `f32`, kept below 1 (an `x` just below 1 would round up to 1.0).
fn below_one(x: f64) -> f32 {
    (x as f32).min(1.0 - f32::EPSILON / 2.0)
}

/// Shuffles the `values.len() / dims` values of `dims` components each (Fisher–Yates).
fn shuffle_values(values: &mut [f32], dims: usize, rng: &mut ChaCha8Rng) {
    let count = values.len() / dims;
    if dims == 1 {
        values.shuffle(rng);
        return;
    }
    for i in (1..count).rev() {
        let j = rng.random_range(0..=i);
        for c in 0..dims {
            values.swap(i * dims + c, j * dims + c);
        }
    }
}

/// The generalised golden ratio of dimension `d`: the positive root of `x^(d+1) = x + 1`
/// (φ for `d = 1`). Its powers `φ_d^−(c+1)` are the `R_d` lattice's generators.
fn generalised_golden_ratio(d: usize) -> f64 {
    let mut x: f64 = 2.0;
    for _ in 0..64 {
        x = (1.0 + x).powf(1.0 / (d as f64 + 1.0));
    }
    x
}

/// The radical inverse of `k` in base `base`: its digits mirrored about the radix point.
fn radical_inverse(mut k: u64, base: u64) -> f64 {
    let inv = 1.0 / base as f64;
    let (mut scale, mut x) = (inv, 0.0);
    while k > 0 {
        x += (k % base) as f64 * scale;
        k /= base;
        scale *= inv;
    }
    x
}

/// `count` points of `[0, 1)^dims` (`count · dims` coordinates, point `k` at `k·dims..`): a
/// low-discrepancy set under a random toroidal shift, latinised ([`SampleSpace`]'s docs): in every
/// component, the point of rank `r` gets `(r + jitter) / count`. The set is the `R_d` lattice
/// `fract(s + k·α)` for one and two components (the best 2D spread of the candidates measured)
/// and the Halton sequence in bases 2, 3, 5, 7 for three and four (the `R_3` and `R_4` lattices
/// have poorly spread 2D projections).
pub(crate) fn latinised_lattice(count: usize, dims: usize, rng: &mut ChaCha8Rng) -> Vec<f64> {
    let g = generalised_golden_ratio(dims);
    let mut points = vec![0.0f64; count * dims];
    let mut order: Vec<u32> = (0..count as u32).collect();
    let mut lattice = vec![0.0f64; count];
    for c in 0..dims {
        let shift: f64 = rng.random();
        if dims <= 2 {
            let alpha = g.powi(-(c as i32 + 1)).fract();
            for (k, x) in lattice.iter_mut().enumerate() {
                *x = (shift + k as f64 * alpha).fract();
            }
        } else {
            let base = [2, 3, 5, 7][c];
            for (k, x) in lattice.iter_mut().enumerate() {
                *x = (shift + radical_inverse(k as u64, base)).fract();
            }
        }
        order.sort_unstable_by(|&i, &j| lattice[i as usize].total_cmp(&lattice[j as usize]));
        for (rank, &k) in order.iter().enumerate() {
            let jitter: f64 = rng.random();
            points[k as usize * dims + c] = (rank as f64 + jitter) / count as f64;
        }
    }
    points
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn latinised_lattice_is_stratified_per_component() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for dims in 1..=4 {
            let n = 257;
            let points = latinised_lattice(n, dims, &mut rng);
            for c in 0..dims {
                let mut strata: Vec<usize> = (0..n)
                    .map(|k| (points[k * dims + c] * n as f64) as usize)
                    .collect();
                strata.sort_unstable();
                assert_eq!(
                    strata,
                    (0..n).collect::<Vec<_>>(),
                    "dims {dims}, component {c}"
                );
            }
        }
    }

    /// `concentric_square` inverts Shirley and Chiu's concentric map (square `[−1, 1]²` to the
    /// unit disc, equal-area), checked on a grid of the square including its axes and diagonals.
    #[test]
    fn concentric_square_inverts_the_concentric_map() {
        use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};
        let to_disc = |a: f64, b: f64| -> (f64, f64) {
            if a == 0.0 && b == 0.0 {
                (0.0, 0.0)
            } else if a.abs() > b.abs() {
                (a, FRAC_PI_4 * (b / a))
            } else {
                (b, FRAC_PI_2 - FRAC_PI_4 * (a / b))
            }
        };
        for i in 0..=40 {
            for j in 0..=40 {
                let (a, b) = (i as f64 / 20.0 - 1.0, j as f64 / 20.0 - 1.0);
                // The map's signed radius and angle, as a disc point's radius and angle.
                let (r, phi) = to_disc(a, b);
                let (r, phi) = if r < 0.0 {
                    (-r, phi + std::f64::consts::PI)
                } else {
                    (r, phi)
                };
                let [u, v] = concentric_square(r, phi);
                if r > 0.0 {
                    assert!(
                        (u - (a + 1.0) / 2.0).abs() < 1e-12 && (v - (b + 1.0) / 2.0).abs() < 1e-12,
                        "({a}, {b}) -> r {r}, φ {phi} -> ({u}, {v})"
                    );
                } else {
                    assert_eq!([u, v], [0.5, 0.5]);
                }
            }
        }
    }

    #[test]
    fn hilbert_curve_steps_to_a_neighbour() {
        // Along the curve, consecutive cells are adjacent: one axis changes by exactly 1.
        for dims in 1..=4usize {
            let bits = 3;
            let cells = 1usize << (bits * dims as u32);
            let mut by_index = vec![[0u32; 4]; cells];
            for cell in 0..cells {
                let mut axes = [0u32; 4];
                for (d, axis) in axes.iter_mut().enumerate().take(dims) {
                    *axis = ((cell >> (bits as usize * d)) & ((1 << bits) - 1)) as u32;
                }
                let mut work = axes;
                let index = hilbert_index(&mut work[..dims], bits) as usize;
                by_index[index] = axes;
            }
            for pair in by_index.windows(2) {
                let steps: u32 = (0..dims).map(|d| pair[0][d].abs_diff(pair[1][d])).sum();
                assert_eq!(steps, 1, "dims {dims}: {:?} → {:?}", pair[0], pair[1]);
            }
        }
    }

    #[test]
    fn golden_ratios() {
        assert!((generalised_golden_ratio(1) - 1.618_033_988_749_895).abs() < 1e-12);
        assert!((generalised_golden_ratio(2) - 1.324_717_957_244_746).abs() < 1e-12);
    }
}
