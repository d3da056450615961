//! Spectral and histogram quality measures of scalar masks.
//!
//! Every measure reads a [`Field`]: a borrowed `width × height × depth` array of values in
//! `[0, 1]`. Generated masks ([`crate::Volume::values`]), value-field baselines
//! ([`crate::baselines`]) and third-party masks ([`crate::export::read_slices_png`]) all fit.
//!
//! # Normalised power
//!
//! A *series* is one slice (2D, `n = width · height` samples) or one pixel's values over the
//! frames (1D, `n = depth` samples). With `x̄` its mean and `F(f) = Σₖ (xₖ − x̄) e^{−2πi f·k / n}`
//! its unnormalised DFT, the normalised power at a frequency `f` is
//!
//! ```text
//! P(f) = |F(f)|² / (n · s²),   s² = Σₖ (xₖ − x̄)² / (n − 1)   (the unbiased sample variance)
//! ```
//!
//! `P` is dimensionless: power relative to a flat spectrum of the same variance. `P(0) = 0` (the
//! mean is removed), and by Parseval the mean of `P` over the `n − 1` non-zero frequencies is
//! exactly 1 for every non-constant series; white noise has `E[P(f)] = 1` at every `f ≠ 0`. Blue
//! noise has `P ≪ 1` at low frequencies (and so `P > 1` at high ones).
//!
//! A constant series (variance 0, including every series of one sample) has no power at any
//! frequency: its `P` is defined as 0 everywhere. It still counts in the averages below, so a
//! constant field measures 0 on every band, never NaN.
//!
//! # Frequencies and the low band
//!
//! Frequencies are wrapped to signed integers `fx ∈ (−width/2, width/2]` (cycles per slice
//! width), likewise `fy`, and `ft ∈ (−depth/2, depth/2]` (cycles per `depth` frames). In cycles
//! per pixel (or per frame) that is `ν = (fx / width, fy / height)` and `ν = ft / depth`.
//!
//! The *low band* of an axis set with longest extent `L` is `0 < |ν| ≤ 1 / min(8, L)`: the lowest
//! eighth of the sampling rate (a quarter of the band up to Nyquist), the band where a blue-noise
//! mask is expected to have almost no power. For a square `s × s` slice it is the disc
//! `0 < √(fx² + fy²) ≤ s / 8`, over time `1 ≤ |ft| ≤ depth / 8`. Axes shorter than 8 widen the band
//! to their lowest non-zero frequency (`|ft| = 1` for `depth < 8`), so the band is empty only when
//! there is no non-zero frequency at all: a `1 × 1` slice, or `depth == 1`. The low-band measures
//! then return `None`.
//!
//! [`filtered_error()`] and [`convergence()`] measure what a renderer sees rather than a
//! spectrum; [`dft_xy_image`] and [`dft_xz_image`] give centred DFT magnitude images like the
//! paper's Fig. 5; [`slice_histogram_deviation`] and [`pixel_histogram_deviation`] how far each
//! frame's and each pixel's values are from uniform.
//!
//! # Filtered error
//!
//! EA's FAST *filtered error*: how much a mask's thresholded frames still vary after the filters a
//! renderer applies (a spatial Gaussian, then an exponential moving average over frames).
//!
//! For one Heaviside threshold `t ∈ [0, 1)` the binary image of frame `k` is
//! `bₖ(p) = [vₖ(p) < t]` (1 where the mask value is below `t`, else 0): the coverage a renderer
//! gets when it compares the mask with a shading value `t`. It is filtered in XY with a toroidal,
//! separable Gaussian `G_σ` (weights `exp(−i² / (2σ²))` for `|i| ≤ ⌈4σ⌉` pixels, normalised to
//! sum 1 per axis), then exponentially averaged over frames:
//!
//! ```text
//! h₀ = G_σ * b₀,   hₖ = α · (G_σ * bₖ) + (1 − α) · hₖ₋₁
//! ```
//!
//! The error of frame `k` is `hₖ` minus its spatial mean; its energy is the population spatial
//! variance `Var(hₖ) = Σₚ (hₖ(p) − h̄ₖ)² / (W·H)`. With `K` thresholds the curve is
//!
//! ```text
//! E(k) = √( Σₜ Var(hₖ) / K )
//! ```
//!
//! in units of coverage (a fraction of a pixel's area, dimensionless). Lower is better; a mask
//! that is blue in space *and* time lets both filters cancel more of the error.
//!
//! Thresholds are stratified and jittered per frame, as in EA's `scripts/temporal.py`: threshold
//! `s ∈ 0..K` uses `t = (s + uₛₖ) / K` at frame `k`, with `uₛₖ` uniform in `[0, 1)` from a
//! ChaCha8 stream seeded by [`FilteredErrorOptions::seed`].
//!
//! ## Expected value for white noise
//!
//! Independent uniform values give `Var(hₖ) ≈ t(1 − t) · (Σᵢ wᵢ²)² · cₖ` with `wᵢ` the 1D kernel
//! weights and `cₖ = (1 − α)^{2k} + α² (1 − (1 − α)^{2k}) / (1 − (1 − α)²)` the EMA's variance
//! gain. Averaged over `t` (`E[t(1 − t)] = 1/6`), with `Σ wᵢ² ≈ 1 / (2σ√π)` and `cₖ → α / (2 − α)`:
//! `E ≈ √(1/6 · 1/(4πσ²) · α/(2 − α)) = 0.0197` for σ = 1.3435, α = 0.1 (tested). EA publish
//! 0.0276 for white noise at 128×128×64, √2 times more; their STBN figure (0.0051) is best
//! compared as a ratio to white noise measured here with the same code.
//!
//! # Convergence
//!
//! Convergence of per-pixel integration (Wolfe et al. 2022, Fig. 4): each pixel estimates
//! `I = ∫₀¹ f(x) dx` from the mask values it sees over the frames as samples.
//!
//! Pixel `p` at sample `k ≥ 0` reads frame `zₖ = (start + k) mod depth` (toroidal
//! progressiveness: a sequence may start at any frame, and runs longer than `depth` wrap), so its
//! samples are `xₖ(p) = v(p, zₖ)`. Two estimators:
//!
//! ```text
//! Monte Carlo:  mₖ = (1 / (k + 1)) · Σⱼ₌₀..ₖ f(xⱼ)
//! EMA:          e₀ = f(x₀),   eₖ = α · f(xₖ) + (1 − α) · eₖ₋₁
//! ```
//!
//! and the error after `k + 1` samples is the root-mean-square over the `W·H` pixels,
//! `RMSE(k) = √( Σₚ (estimateₖ(p) − I)² / (W·H) )`, in the units of `f` (all integrands here are
//! dimensionless). White noise gives `σ_f / √(k + 1)` for Monte Carlo; a mask that is blue over
//! time converges faster. The EMA never converges (its error plateaus at about
//! `σ_f · √(α / (2 − α))` for white noise) but a blue-over-time mask lowers the plateau.
//!
//! # 2D convergence
//!
//! Convergence of per-pixel 2D integration (Wolfe et al. 2022, Fig. 6): each pixel estimates
//! `I = ∫∫_[0,1)² f(x, y) dx dy` from 2D samples it sees over the frames.
//!
//! The samples come from two [`Field`]s of the same size, one per coordinate: the two components
//! of a 2D vector mask, or one scalar mask read twice at different offsets (as a renderer that
//! needs two numbers per pixel would, see [`toroidal_shift`]), or two independent masks. Pixel
//! `p` at sample `k` reads frame `zₖ = (start + k) mod depth` of both, and the estimators and the
//! RMSE are those of [`convergence()`]: a Monte Carlo running mean and an EMA, the
//! root-mean-square error over the `W·H` pixels after each sample, in the units of `f`
//! (dimensionless here).
//!
//! A 2D integrand with an edge across both axes (the disc, the diagonal step) shows whether the
//! pairs are well spread in the plane, which two well-spread 1D sequences do not guarantee.
//!
//! # DFT images
//!
//! DFT magnitude images, like Wolfe et al. 2022, Fig. 5: what a mask's spectrum looks like in a
//! plane through the frequency volume.
//!
//! - **XY** ([`dft_xy_image`]): the 2D DFT of every slice (frame), averaged over slices: the
//!   spatial spectrum. Blue noise in space shows a dark disc around the centre.
//! - **XZ** ([`dft_xz_image`]): for every row `y`, the 2D DFT of the `width × depth` image
//!   `v(x, y, z)` (x across, frames down), averaged over rows: horizontal frequencies are spatial
//!   (cycles per slice width), vertical ones temporal (cycles per `depth` frames). A mask that is
//!   blue over time is dark along the vertical axis through the centre, one that is blue in space
//!   along the horizontal axis.
//!
//! Each transformed image `x` of `n` samples is normalised like the spectra of
//! [`spatial_power`]: its mean is removed and the squared magnitude divided by
//! `n · s²` (`s²` the unbiased sample variance), giving the normalised power `P(f)`. The image
//! holds the mean over slices (or rows) of the **normalised magnitude** `√P(f)`:
//! dimensionless, 0 at DC (the mean is removed) and about `√π / 2 ≈ 0.886` at every other
//! frequency for white noise (`P` is exponentially distributed with mean 1 there). A constant
//! image contributes 0 everywhere.
//!
//! Images are centred: the DC term is at pixel `(width / 2, height / 2)` and pixel `(i, j)`
//! holds the signed frequency `(i − width/2, j − height/2)` (cycles per image side), so the
//! Nyquist row and column (even sizes) are at index 0.
//!
//! # Histograms
//!
//! How far a mask's values are from uniform: per slice (what one frame thresholds to) and per
//! pixel (what one pixel's sequence of frames integrates with).
//!
//! - [`slice_histogram_deviation`]: the worst bin of any frame's histogram, relative to its
//!   expected count. Void-and-cluster masks of this crate measure 0 (every slice is a
//!   permutation of the rank grid).
//! - [`pixel_histogram_deviation`]: the mean over pixels of the Kolmogorov–Smirnov distance
//!   between the pixel's `D` values over the frames and the uniform distribution. Parameter-free
//!   (no bins, which `D` values could not fill): at least `1 / (2D)` (values exactly at the
//!   midpoints `(i + ½) / D`), about `0.87 / √D` for white noise, and in between for sequences that
//!   stratify over time.
//!
//! # Large fields
//!
//! Every measure holds a bounded amount of memory beside the field it reads, whatever the
//! field's size and the thread count: parallel tasks run in batches that fit 256 MiB
//! (partial sums are still added in task order, so the bits do not depend on the batches), and
//! two measures work on part of a large field, exactly and in the same units:
//!
//! - **Folded spectra.** A plane (a slice, or an x–frame plane of [`dft_xz_image`]) of more
//!   than [`MAX_SPECTRUM_PLANE`] pixels is folded before its DFT ([`spectrum_fold`]): values
//!   at `x mod (width / fx)` are summed, which on a periodic plane gives the DFT exactly at
//!   every `fx`-th frequency, so the spectra, low band and images are those of the whole plane
//!   on a coarser grid of frequencies. A 4096 × 4096 slice is measured on the 2048 × 2048 grid
//!   of every second frequency.
//! - **Windowed filtered error.** Frames of more than [`MAX_FILTERED_FRAME`] pixels average
//!   the filtered error over a window of at most 1024 pixels per axis
//!   ([`FilteredErrorOptions::window`]), whose pixels are blurred with their true neighbours
//!   from the whole frame.
//!
//! Below those sizes (spectra of frames up to 2048 × 2048 pixels, the filtered error of frames
//! up to 1024 × 1024) every figure is of the whole field.
//!
//! # Vector masks
//!
//! A vector mask ([`VectorField`]) is measured in its own space, not on its stored channels
//! (an octahedral channel is neither uniform nor linear in the direction it encodes):
//!
//! - **Components** ([`VectorField::components`]): each component of the decoded value (`x`,
//!   `y`, `z` of a direction, `u`, `v` of a point) as a scalar [`Field`]. Spectra, low bands, DFT
//!   images and the vector filtered error ([`filtered_error_vector`]) read these: they say whether
//!   neighbouring pixels and frames hold different values.
//! - **Stratum coordinates** ([`VectorField::stratum_coordinates`]): the inverse of the map that
//!   draws the space's values from the unit square (the same maps the generator uses): the
//!   component itself for `Vec`, the angle in turns for the circle, `((1 − z)/2, φ/2π)` on the
//!   sphere, `(1 − z, φ/2π)` on the uniform hemisphere, `(1 − z², φ/2π)` on the cosine hemisphere,
//!   and the row then column CDF of the image for image points and environment directions. They
//!   are uniform in `[0, 1]` exactly when the values follow the space's pdf, so the histogram
//!   measures of scalar masks apply to them unchanged ([`distribution_deviation`]): a cosine
//!   hemisphere with the right distribution measures as well as a uniform scalar mask.
//! - **Test functions** ([`TestFunction`]): a smooth function and one with an edge, on points
//!   or on directions, whose expectation under the space's pdf is known
//!   ([`TestFunction::expected`]). [`vector_convergence`] is [`convergence()`] for them: each
//!   pixel estimates the expectation from its values over the frames. The reference is white noise
//!   of the same distribution, [`VectorField::shuffled`]: the mask's own values shuffled over
//!   every pixel and frame.

mod convergence;
mod convergence2d;
mod dft;
mod filtered;
mod histogram;
mod vector;

pub use convergence::{
    Convergence, ConvergenceOptions, Integrand, RunningMean, convergence, running_mean,
};
pub use convergence2d::{Integrand2D, convergence_2d, toroidal_shift};
pub use dft::{SpectrumImage, dft_xy_image, dft_xz_image};
pub use filtered::{
    FilteredErrorOptions, MAX_FILTERED_FRAME, filtered_error, filtered_error_vector,
    gaussian_weights,
};
pub use histogram::{pixel_histogram_deviation, slice_histogram_deviation};
pub use vector::{
    DistributionDeviation, TestFunction, VectorField, distribution_deviation, vector_convergence,
};

use std::fmt;

use rayon::prelude::*;
use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};

/// A borrowed scalar field of `width × height × depth` values in `[0, 1]`, index
/// `(z · height + y) · width + x`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Field<'a> {
    width: usize,
    height: usize,
    depth: usize,
    values: &'a [f64],
}

impl<'a> Field<'a> {
    /// Checks the shape and that every value is in `[0, 1]` (NaN is rejected).
    pub fn new(
        width: usize,
        height: usize,
        depth: usize,
        values: &'a [f64],
    ) -> Result<Field<'a>, FieldError> {
        if width == 0 || height == 0 || depth == 0 {
            return Err(FieldError::EmptyAxis {
                width,
                height,
                depth,
            });
        }
        let expected = width.checked_mul(height).and_then(|n| n.checked_mul(depth));
        if expected != Some(values.len()) {
            return Err(FieldError::LengthMismatch {
                width,
                height,
                depth,
                len: values.len(),
            });
        }
        if let Some(index) = values.iter().position(|v| !(0.0..=1.0).contains(v)) {
            return Err(FieldError::ValueOutOfRange {
                index,
                value: values[index],
            });
        }
        Ok(Field {
            width,
            height,
            depth,
            values,
        })
    }

    /// Pixels per row.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Rows per slice.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Slices (frames).
    pub fn depth(&self) -> usize {
        self.depth
    }

    /// Pixels per slice, `width · height`.
    pub fn slice_pixels(&self) -> usize {
        self.width * self.height
    }

    /// Every value, index `(z · height + y) · width + x`.
    pub fn values(&self) -> &'a [f64] {
        self.values
    }

    /// The values of slice `z`, row-major. Panics if `z >= depth`.
    pub fn slice(&self, z: usize) -> &'a [f64] {
        let n = self.slice_pixels();
        &self.values[z * n..(z + 1) * n]
    }
}

/// Why [`Field::new`] rejected its arguments.
#[derive(Clone, Debug, PartialEq)]
pub enum FieldError {
    /// An axis has extent 0.
    EmptyAxis {
        /// Given width.
        width: usize,
        /// Given height.
        height: usize,
        /// Given depth.
        depth: usize,
    },
    /// `values.len()` is not `width · height · depth`.
    LengthMismatch {
        /// Given width.
        width: usize,
        /// Given height.
        height: usize,
        /// Given depth.
        depth: usize,
        /// Number of values given.
        len: usize,
    },
    /// A value is outside `[0, 1]` or NaN.
    ValueOutOfRange {
        /// Index of the first such value.
        index: usize,
        /// The value.
        value: f64,
    },
    /// Two fields that must have one size differ: (width, height, depth) of each.
    Mismatch {
        /// Size of the first field.
        first: (usize, usize, usize),
        /// Size of the second field.
        second: (usize, usize, usize),
    },
}

impl fmt::Display for FieldError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FieldError::EmptyAxis {
                width,
                height,
                depth,
            } => write!(f, "field size {width}x{height}x{depth} has an empty axis"),
            FieldError::LengthMismatch {
                width,
                height,
                depth,
                len,
            } => write!(
                f,
                "field size {width}x{height}x{depth} needs {} values, got {len}",
                (*width as u128) * (*height as u128) * (*depth as u128)
            ),
            FieldError::ValueOutOfRange { index, value } => {
                write!(f, "value {value} at index {index} is outside [0, 1]")
            }
            FieldError::Mismatch { first, second } => write!(
                f,
                "fields of sizes {}x{}x{} and {}x{}x{} must have the same size",
                first.0, first.1, first.2, second.0, second.1, second.2
            ),
        }
    }
}

impl std::error::Error for FieldError {}

/// Most pixels of one plane (a slice, or one x–frame plane of [`dft_xz_image`]) whose 2D
/// spectrum is taken at every frequency. A larger plane is folded first ([`spectrum_fold`]), so
/// one plane's transform holds at most 64 MiB of complex values: the spectra of a 4096 × 4096
/// slice cost what a 2048 × 2048 one does.
pub const MAX_SPECTRUM_PLANE: usize = 1 << 22;

/// How a `width × height` plane is folded before its 2D DFT: factors `(fx, fy)` dividing
/// `width` and `height`, `(1, 1)` for planes of at most [`MAX_SPECTRUM_PLANE`] pixels.
///
/// Folding sums the values at `x mod (width / fx)`, `y mod (height / fy)`; on a periodic plane
/// the DFT of the folded plane is **exactly** the DFT of the whole plane at every `fx`-th
/// frequency along x and every `fy`-th along y (no leakage, unlike a crop), so the spectra of
/// a folded plane are those of the whole plane on a coarser grid of frequencies. The longer
/// remaining axis is folded by its smallest prime factor until the plane fits.
pub fn spectrum_fold(width: usize, height: usize) -> (usize, usize) {
    let (mut fx, mut fy) = (1, 1);
    while (width / fx) * (height / fy) > MAX_SPECTRUM_PLANE {
        if width / fx >= height / fy {
            fx *= smallest_factor(width / fx);
        } else {
            fy *= smallest_factor(height / fy);
        }
    }
    (fx, fy)
}

/// The smallest prime factor of `n ≥ 2`.
fn smallest_factor(n: usize) -> usize {
    (2..)
        .take_while(|f| f * f <= n)
        .find(|f| n.is_multiple_of(*f))
        .unwrap_or(n)
}

/// [`spatial_low_band`] of one image of any finite values, row-major `width × height`: e.g. an
/// error image (estimate − exact), whose values are signed. Normalised power does not change
/// under an affine map of the values, so the image is mapped onto `[0, 1]` by its minimum and
/// maximum first (a constant image measures 0). `None` for a `1 × 1` image, and when `values`
/// is not `width × height` finite values.
pub fn image_low_band(width: usize, height: usize, values: &[f64]) -> Option<f64> {
    let (min, max) = values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    if !(min.is_finite() && max.is_finite()) {
        return None;
    }
    let range = if max > min { max - min } else { 1.0 };
    let mapped: Vec<f64> = values
        .iter()
        .map(|v| ((v - min) / range).clamp(0.0, 1.0))
        .collect();
    spatial_low_band(&Field::new(width, height, 1, &mapped).ok()?)
}

/// Mean normalised power ([module docs](self)) over the spatial low band, averaged over slices.
///
/// Dimensionless, `≥ 0`: about 1 for white noise, near 0 for a mask that is blue within each
/// slice. `None` for `1 × 1` slices (no non-zero spatial frequency). Slices over
/// [`MAX_SPECTRUM_PLANE`] pixels average the band's frequencies on the grid of
/// [`spectrum_fold`].
pub fn spatial_low_band(field: &Field) -> Option<f64> {
    let (w, h) = (field.width, field.height);
    let (fold_x, fold_y) = spectrum_fold(w, h);
    let (gw, gh) = (w / fold_x, h / fold_y);
    let power = spatial_power(field);
    // |ν| ≤ 1/m  ⇔  m² · ((fx·h)² + (fy·w)²) ≤ (w·h)², exact in integers (the values fit in memory, so
    // w·h < 2^61 and every term stays below 2^128).
    let m = 8.min(w.max(h)) as u128;
    let limit = ((w * h) as u128).pow(2);
    let mut sum = 0.0;
    let mut count = 0usize;
    for fy in 0..gh {
        let sy = (wrapped(fy, gh).unsigned_abs() * fold_y) as u128 * w as u128;
        for fx in 0..gw {
            let sx = (wrapped(fx, gw).unsigned_abs() * fold_x) as u128 * h as u128;
            let r2 = sx * sx + sy * sy;
            if r2 > 0 && m * m * r2 <= limit {
                sum += power[fy * gw + fx];
                count += 1;
            }
        }
    }
    (count > 0).then(|| sum / count as f64)
}

/// Mean normalised power ([module docs](self)) over the temporal low band
/// `1 ≤ ft ≤ max(depth / 8, 1)`, averaged over pixels.
///
/// Dimensionless, `≥ 0`: about 1 for white noise over time, near 0 for a mask whose pixels are
/// blue over time. With `depth < 8` the band is the single lowest frequency `ft = 1` (for
/// `depth == 2` that is also Nyquist, so the measure only tells whether consecutive frames tend to
/// alternate). `None` when `depth == 1`.
pub fn temporal_low_band(field: &Field) -> Option<f64> {
    let spectrum = temporal_spectrum(field);
    let top = (field.depth / 8).max(1);
    (field.depth > 1).then(|| spectrum[1..=top].iter().sum::<f64>() / top as f64)
}

/// The mean normalised spatial power of every frequency, averaged over slices.
///
/// `width · height` values, index `fy · width + fx` with unwrapped DFT indices `fx ∈ 0..width`,
/// `fy ∈ 0..height` (so DC is at index 0, not centred). Dimensionless; the DC entry is 0. For a
/// field with no constant slice the mean of the non-DC entries is exactly 1 (up to rounding).
///
/// Slices over [`MAX_SPECTRUM_PLANE`] pixels are folded by `(fx, fy) =`
/// [`spectrum_fold`]: the result is then `(width / fx) · (height / fy)` values, entry
/// `i · (width / fx) + j` holding the power at frequency `(j · fx, i · fy)`, exactly.
pub fn spatial_power(field: &Field) -> Vec<f64> {
    let (w, h, d) = (field.width, field.height, field.depth);
    let (fold_x, fold_y) = spectrum_fold(w, h);
    let (gw, gh) = (w / fold_x, h / fold_y);
    let n = gw * gh;
    let mut planner = FftPlanner::<f64>::new();
    let fft_x = planner.plan_fft_forward(gw);
    let fft_y = planner.plan_fft_forward(gh);
    let chunk = d.div_ceil(TASKS);
    let mut sum = sum_tasks_in_order(d.div_ceil(chunk), PLANE_TASK_BYTES * n, n, |task| {
        let mut sum = vec![0.0; n];
        for z in task * chunk..((task + 1) * chunk).min(d) {
            let slice = field.slice(z);
            let row = |y: usize| &slice[y * w..(y + 1) * w];
            add_plane_spectrum(
                &row,
                (w, h),
                (fold_x, fold_y),
                (&*fft_x, &*fft_y),
                &mut sum,
                |p| p,
            );
        }
        sum
    });
    let depth = d as f64;
    sum.iter_mut().for_each(|p| *p /= depth);
    sum
}

/// The spatial power of [`spatial_power`] averaged over rings of equal radial frequency.
///
/// Entry `r` is the mean over the frequencies with `round(L · |ν|) == r`, where `L = max(width,
/// height)` and `|ν|` is in cycles per pixel ([module docs](self)): for a square slice, the ring
/// `r − ½ ≤ √(fx² + fy²) < r + ½`. Entries run from `r = 0` (DC, always 0) to the corner
/// frequency `round(L · |ν|max)`, about `0.71 · L`; rings beyond `L / 2` hold only the corners.
/// Dimensionless; white noise gives about 1 at every `r > 0`. Every ring holds at least one
/// frequency. Slices over [`MAX_SPECTRUM_PLANE`] pixels use the grid of [`spectrum_fold`], and
/// `L` is then [`radial_rings_per_cycle`], the longer side of that grid.
pub fn radial_spectrum(field: &Field) -> Vec<f64> {
    let (w, h) = (field.width, field.height);
    let (fold_x, fold_y) = spectrum_fold(w, h);
    let (gw, gh) = (w / fold_x, h / fold_y);
    let power = spatial_power(field);
    let long = gw.max(gh) as f64;
    let radius = |fx: usize, fy: usize| {
        let nx = wrapped(fx, gw) as f64 / gw as f64;
        let ny = wrapped(fy, gh) as f64 / gh as f64;
        (long * nx.hypot(ny)).round() as usize
    };
    let rings = radius(gw / 2, gh / 2) + 1;
    let mut sum = vec![0.0; rings];
    let mut count = vec![0usize; rings];
    for fy in 0..gh {
        for fx in 0..gw {
            let r = radius(fx, fy);
            sum[r] += power[fy * gw + fx];
            count[r] += 1;
        }
    }
    sum.iter().zip(&count).map(|(s, &c)| s / c as f64).collect()
}

/// `L` of [`radial_spectrum`] for `width × height` slices: ring `r` is at `r / L` cycles per
/// pixel. `max(width, height)`, or the longer side of the folded grid ([`spectrum_fold`]).
pub fn radial_rings_per_cycle(width: usize, height: usize) -> usize {
    let (fold_x, fold_y) = spectrum_fold(width, height);
    (width / fold_x).max(height / fold_y)
}

/// The mean normalised power of every pixel's series over the frames, per temporal frequency.
///
/// `depth / 2 + 1` values, entry `ft` for `ft ∈ 0..=depth/2` (cycles per `depth` frames; the
/// negative frequencies mirror these). Dimensionless; entry 0 is 0, and white noise gives about 1
/// elsewhere.
pub fn temporal_spectrum(field: &Field) -> Vec<f64> {
    let (d, n) = (field.depth, field.slice_pixels());
    let bins = d / 2 + 1;
    // Pixels whose series one task transforms together: 1024 up to 1024 frames (16 MiB), fewer
    // for longer series so a task's buffer stays at 16 MiB.
    let chunk = if d <= 1024 { 1024 } else { (1 << 20) / d };
    let fft = FftPlanner::<f64>::new().plan_fft_forward(d);
    let task_bytes = 16 * chunk * d + 16 * bins;
    let sum = sum_tasks_in_order(n.div_ceil(chunk), task_bytes, bins, |task| {
        let start = task * chunk;
        let pixels = chunk.min(n - start);
        let mut buffer = Vec::with_capacity(pixels * d);
        for p in start..start + pixels {
            buffer.extend((0..d).map(|z| Complex::new(field.values[z * n + p], 0.0)));
        }
        let mut sum = vec![0.0; bins];
        for series in buffer.chunks_exact_mut(d) {
            if let Some(scale) = normalise(series) {
                fft.process(series);
                for (s, c) in sum.iter_mut().zip(&series[..bins]).skip(1) {
                    *s += c.norm_sqr() * scale;
                }
            }
        }
        sum
    });
    sum.into_iter().map(|s| s / n as f64).collect()
}

/// Most parallel tasks [`spatial_power`] and the [`dft`] images split their planes into.
const TASKS: usize = 16;

/// Bytes per (folded) plane pixel one task of [`spatial_power`] or the [`dft`] images holds:
/// the transform's two complex buffers (32), its sum and the sum handed back (16).
const PLANE_TASK_BYTES: usize = 48;

/// Bytes the tasks of one measure may hold at once (their buffers and the partial sums waiting
/// to be added): more tasks wait for the next batch, so a measure's memory does not grow with
/// the thread count. Every task of the masks the report usually sees fits in one batch.
pub(crate) const MEMORY_BUDGET: usize = 256 << 20;

/// The element-wise sum of `task(0) … task(tasks − 1)` (each `len` values, holding about
/// `task_bytes` while it runs), added in task order whatever the thread count, so every measure
/// is bit-for-bit reproducible. Tasks run in parallel in batches of at most
/// [`MEMORY_BUDGET`] / `task_bytes` (at least one).
fn sum_tasks_in_order(
    tasks: usize,
    task_bytes: usize,
    len: usize,
    task: impl Fn(usize) -> Vec<f64> + Sync + Send,
) -> Vec<f64> {
    let batch = batch_size(task_bytes);
    let mut sum = vec![0.0; len];
    for first in (0..tasks).step_by(batch) {
        let parts: Vec<Vec<f64>> = (first..(first + batch).min(tasks))
            .into_par_iter()
            .map(&task)
            .collect();
        for part in &parts {
            sum.iter_mut().zip(part).for_each(|(s, p)| *s += p);
        }
    }
    sum
}

/// Tasks of `task_bytes` each that fit in [`MEMORY_BUDGET`] at once, at least one.
pub(crate) fn batch_size(task_bytes: usize) -> usize {
    (MEMORY_BUDGET / task_bytes.max(1)).max(1)
}

/// The signed frequency of DFT index `f` of an axis of length `len`, in `(−len/2, len/2]`.
fn wrapped(f: usize, len: usize) -> isize {
    if f <= len / 2 {
        f as isize
    } else {
        f as isize - len as isize
    }
}

/// Removes the mean of `series` (real parts) and returns the factor turning `|F(f)|²` into the
/// normalised power `P(f)`: `(n − 1) / (n · Σ(x − x̄)²)`. `None` for a constant series.
fn normalise(series: &mut [Complex<f64>]) -> Option<f64> {
    let first = series[0].re;
    if series.iter().all(|c| c.re == first) {
        return None;
    }
    let n = series.len() as f64;
    let mean = series.iter().map(|c| c.re).sum::<f64>() / n;
    let mut squares = 0.0;
    for c in series.iter_mut() {
        c.re -= mean;
        squares += c.re * c.re;
    }
    (squares > 0.0).then(|| (n - 1.0) / (n * squares))
}

/// Adds `map(P(f))` of the normalised 2D power `P` of one `w × h` plane (row `y` is `row(y)`,
/// `w` values) to `sum`, leaving DC alone; a constant plane adds nothing. Folded by
/// `(fx, fy)` ([`spectrum_fold`]): `sum` and the transforms `(fft_x, fft_y)` are then of the
/// `(w / fx) × (h / fy)` grid, index `j · (w / fx) + i` for grid frequency `(i, j)`.
fn add_plane_spectrum<'a>(
    row: &dyn Fn(usize) -> &'a [f64],
    (w, h): (usize, usize),
    (fold_x, fold_y): (usize, usize),
    (fft_x, fft_y): (&dyn Fft<f64>, &dyn Fft<f64>),
    sum: &mut [f64],
    map: impl Fn(f64) -> f64,
) {
    let (gw, gh) = (w / fold_x, h / fold_y);
    let (rows, scale) = if (fold_x, fold_y) == (1, 1) {
        let mut rows: Vec<Complex<f64>> = (0..h)
            .flat_map(|y| row(y).iter().map(|&v| Complex::new(v, 0.0)))
            .collect();
        let Some(scale) = normalise(&mut rows) else {
            return;
        };
        (rows, scale)
    } else {
        // The mean and variance of the whole plane, then its values less the mean, folded.
        let first = row(0)[0];
        if (0..h).all(|y| row(y).iter().all(|&v| v == first)) {
            return;
        }
        let n = (w * h) as f64;
        let mean = (0..h).map(|y| row(y).iter().sum::<f64>()).sum::<f64>() / n;
        let mut squares = 0.0;
        let mut rows = vec![Complex::default(); gw * gh];
        for y in 0..h {
            let folded = &mut rows[(y % gh) * gw..(y % gh + 1) * gw];
            for (x, &v) in row(y).iter().enumerate() {
                let c = v - mean;
                squares += c * c;
                folded[x % gw].re += c;
            }
        }
        if squares <= 0.0 {
            return;
        }
        (rows, (n - 1.0) / (n * squares))
    };
    let mut rows = rows;
    fft_x.process(&mut rows);
    // Transpose so every column is contiguous, then transform the columns.
    let mut columns = vec![Complex::default(); gw * gh];
    for (y, row) in rows.chunks_exact(gw).enumerate() {
        for (x, &c) in row.iter().enumerate() {
            columns[x * gh + y] = c;
        }
    }
    drop(rows);
    fft_y.process(&mut columns);
    for (fx, column) in columns.chunks_exact(gh).enumerate() {
        for (fy, c) in column.iter().enumerate() {
            if fx != 0 || fy != 0 {
                sum[fy * gw + fx] += map(c.norm_sqr() * scale);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic pseudo-random value in `[0, 1)` (SplitMix64).
    fn noise(seed: u64, len: usize) -> Vec<f64> {
        let mut state = seed;
        (0..len)
            .map(|_| {
                state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
                let mut z = state;
                z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
                z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
                (z ^ (z >> 31)) as f64 / 2f64.powi(64)
            })
            .collect()
    }

    #[test]
    fn field_rejects_bad_shapes_and_values() {
        let values = [0.5; 8];
        assert!(Field::new(2, 2, 2, &values).is_ok());
        assert!(matches!(
            Field::new(0, 2, 2, &values),
            Err(FieldError::EmptyAxis { .. })
        ));
        assert!(matches!(
            Field::new(2, 2, 3, &values),
            Err(FieldError::LengthMismatch { len: 8, .. })
        ));
        let bad = [0.5, 0.5, f64::NAN, 0.5];
        assert_eq!(
            Field::new(2, 2, 1, &bad).unwrap_err().to_string(),
            "value NaN at index 2 is outside [0, 1]"
        );
        assert!(Field::new(2, 2, 1, &[0.0, 1.0, 1.5, 0.0]).is_err());
    }

    #[test]
    fn parseval_makes_the_mean_non_dc_power_one() {
        // Odd, non-square sizes exercise the wrapping and the mixed-radix FFTs.
        let (w, h, d) = (13, 6, 5);
        let values = noise(3, w * h * d);
        let field = Field::new(w, h, d, &values).unwrap();
        let power = spatial_power(&field);
        assert_eq!(power[0], 0.0);
        let mean = power[1..].iter().sum::<f64>() / (w * h - 1) as f64;
        assert!((mean - 1.0).abs() < 1e-12, "{mean}");
        // Temporal: d = 5 has the non-DC frequencies ±1, ±2, so the mean of bins 1 and 2 is 1.
        let temporal = temporal_spectrum(&field);
        assert_eq!(temporal.len(), 3);
        assert_eq!(temporal[0], 0.0);
        assert!(((temporal[1] + temporal[2]) / 2.0 - 1.0).abs() < 1e-12);
    }

    #[test]
    fn normalisation_matches_a_direct_dft() {
        let series = [0.1, 0.7, 0.3, 0.9, 0.2, 0.4];
        let n = series.len();
        let mean = series.iter().sum::<f64>() / n as f64;
        let variance = series.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        let field = Field::new(1, 1, n, &series).unwrap();
        let spectrum = temporal_spectrum(&field);
        for (f, &p) in spectrum.iter().enumerate().skip(1) {
            let (mut re, mut im) = (0.0, 0.0);
            for (k, x) in series.iter().enumerate() {
                let angle = -2.0 * std::f64::consts::PI * (f * k) as f64 / n as f64;
                re += (x - mean) * angle.cos();
                im += (x - mean) * angle.sin();
            }
            let direct = (re * re + im * im) / (n as f64 * variance);
            assert!((p - direct).abs() < 1e-12, "f {f}: {p} vs {direct}");
        }
    }

    #[test]
    fn image_low_band_is_the_low_band_of_the_image_mapped_onto_the_unit_interval() {
        let (w, h) = (16, 8);
        let values: Vec<f64> = (0..w * h)
            .map(|i| ((i * 37 % 101) as f64 / 50.0 - 1.0) * 1e-3)
            .collect();
        let (lo, hi) = (-1e-3, 1e-3);
        let unit: Vec<f64> = values.iter().map(|v| (v - lo) / (hi - lo)).collect();
        let direct = spatial_low_band(&Field::new(w, h, 1, &unit).unwrap()).unwrap();
        let mapped = image_low_band(w, h, &values).unwrap();
        assert!((direct - mapped).abs() < 1e-9, "{direct} vs {mapped}");
        assert_eq!(image_low_band(w, h, &vec![0.25; w * h]), Some(0.0));
        assert_eq!(image_low_band(1, 1, &[0.5]), None);
        assert_eq!(image_low_band(2, 1, &[0.5, f64::NAN]), None);
        assert_eq!(image_low_band(2, 2, &[0.5]), None);
    }

    #[test]
    fn low_band_covers_the_documented_frequencies() {
        // A unit impulse at one frequency pair, via a cosine: power only at ±(fx, fy).
        let (w, h) = (64, 64);
        let slice_with = |fx: usize, fy: usize| -> Vec<f64> {
            (0..w * h)
                .map(|i| {
                    let (x, y) = ((i % w) as f64, (i / w) as f64);
                    let phase = 2.0
                        * std::f64::consts::PI
                        * (fx as f64 * x / w as f64 + fy as f64 * y / h as f64);
                    0.5 + 0.4 * phase.cos()
                })
                .collect()
        };
        // (8, 0) is on the band edge (radius 8 = 64 / 8); (6, 6) is at radius 8.49, outside.
        for (fx, fy, inside) in [
            (8, 0, true),
            (1, 0, true),
            (5, 6, true),
            (6, 6, false),
            (9, 0, false),
        ] {
            let values = slice_with(fx, fy);
            let band = spatial_low_band(&Field::new(w, h, 1, &values).unwrap()).unwrap();
            assert_eq!(band > 0.5, inside, "({fx}, {fy}): {band}");
        }
    }

    #[test]
    fn degenerate_axes_have_no_band() {
        let values = noise(1, 6);
        let column = Field::new(1, 1, 6, &values).unwrap();
        assert_eq!(spatial_low_band(&column), None);
        // depth 6 < 8: the band is ft = 1 alone.
        let expected = temporal_spectrum(&column)[1];
        assert_eq!(temporal_low_band(&column), Some(expected));
        let image = Field::new(3, 2, 1, &values).unwrap();
        assert_eq!(temporal_low_band(&image), None);
        assert!(spatial_low_band(&image).is_some());
        assert_eq!(temporal_spectrum(&image), vec![0.0]);
    }

    #[test]
    fn radial_rings_are_never_empty() {
        for (w, h) in [(64, 2), (7, 5), (1, 9), (16, 16), (3, 40)] {
            let values = noise(w as u64, w * h);
            let field = Field::new(w, h, 1, &values).unwrap();
            let rings = radial_spectrum(&field);
            assert_eq!(rings[0], 0.0);
            assert!(
                rings[1..].iter().all(|p| p.is_finite() && *p > 0.0),
                "{w}x{h}: {rings:?}"
            );
        }
    }

    #[test]
    fn a_folded_plane_has_the_whole_spectrum_at_every_fold_th_frequency() {
        let (w, h) = (12, 18);
        let values = noise(5, w * h);
        let row = |y: usize| &values[y * w..(y + 1) * w];
        let spectrum = |fold: (usize, usize)| {
            let (gw, gh) = (w / fold.0, h / fold.1);
            let mut planner = FftPlanner::<f64>::new();
            let ffts = (planner.plan_fft_forward(gw), planner.plan_fft_forward(gh));
            let mut sum = vec![0.0; gw * gh];
            add_plane_spectrum(&row, (w, h), fold, (&*ffts.0, &*ffts.1), &mut sum, |p| p);
            sum
        };
        let whole = spectrum((1, 1));
        for fold in [(2, 3), (4, 1), (1, 9), (12, 2)] {
            let gw = w / fold.0;
            let folded = spectrum(fold);
            for (i, &p) in folded.iter().enumerate() {
                let (fx, fy) = (i % gw * fold.0, i / gw * fold.1);
                let exact = whole[fy * w + fx];
                assert!(
                    (p - exact).abs() < 1e-12,
                    "{fold:?} ({fx}, {fy}): {p} vs {exact}"
                );
            }
        }
        // A constant plane adds nothing, folded or not.
        let flat = vec![0.25; w * h];
        let flat_row = |y: usize| &flat[y * w..(y + 1) * w];
        let mut planner = FftPlanner::<f64>::new();
        let ffts = (planner.plan_fft_forward(6), planner.plan_fft_forward(6));
        let mut sum = vec![0.0; 36];
        add_plane_spectrum(
            &flat_row,
            (w, h),
            (2, 3),
            (&*ffts.0, &*ffts.1),
            &mut sum,
            |p| p,
        );
        assert!(sum.iter().all(|&p| p == 0.0));
    }

    #[test]
    fn bounded_batches_add_in_task_order() {
        // One task per batch or all at once: the same bits.
        let task = |t: usize| vec![0.1 * t as f64, 1.0 / (t + 3) as f64];
        let all = sum_tasks_in_order(37, 1, 2, task);
        let one_by_one = sum_tasks_in_order(37, MEMORY_BUDGET, 2, task);
        assert_eq!(batch_size(MEMORY_BUDGET), 1);
        assert!(batch_size(1) >= 37);
        assert_eq!(all, one_by_one);
        let mut expected = vec![0.0; 2];
        for t in 0..37 {
            expected.iter_mut().zip(task(t)).for_each(|(s, p)| *s += p);
        }
        assert_eq!(all, expected);
    }

    #[test]
    fn results_do_not_depend_on_the_thread_count() {
        let values = noise(9, 48 * 48 * 40);
        let field = Field::new(48, 48, 40, &values).unwrap();
        let measure = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| (spatial_power(&field), temporal_spectrum(&field)))
        };
        let one = measure(1);
        for threads in [2, 3, 7] {
            assert!(measure(threads) == one, "{threads} threads");
        }
    }
}
