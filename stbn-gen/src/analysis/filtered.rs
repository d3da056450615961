//! EA's FAST filtered error of thresholded frames after a spatial Gaussian and an exponential
//! moving average ([`analysis`] docs, "Filtered error").
//!
//! [`analysis`]: crate::analysis#filtered-error

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::{Field, FieldError};

/// The parameters of [`filtered_error`]. [`Default`] is EA's published setting.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilteredErrorOptions {
    /// Number `K ≥ 1` of Heaviside thresholds (strata of `[0, 1)`). EA: 256.
    pub thresholds: usize,
    /// Spatial Gaussian standard deviation in pixels, `> 0`. EA: 1.3435.
    pub sigma: f64,
    /// EMA weight of the newest frame, in `(0, 1]` (1 = no temporal filtering). EA: 0.1.
    pub alpha: f64,
    /// Seed of the threshold jitter.
    pub seed: u64,
}

impl FilteredErrorOptions {
    /// EA's number of thresholds.
    pub const THRESHOLDS: usize = 256;
    /// EA's spatial σ in pixels.
    pub const SIGMA: f64 = 1.3435;
    /// EA's EMA weight.
    pub const ALPHA: f64 = 0.1;
}

impl Default for FilteredErrorOptions {
    fn default() -> FilteredErrorOptions {
        FilteredErrorOptions {
            thresholds: Self::THRESHOLDS,
            sigma: Self::SIGMA,
            alpha: Self::ALPHA,
            seed: 0,
        }
    }
}

/// The filtered error `E(k)` of every frame `k ∈ 0..depth` ([module docs](crate::analysis#filtered-error)); the headline
/// figure is the last entry.
///
/// Dimensionless (coverage), `≥ 0`; 0 for a constant field. The thresholds run in parallel and
/// their variances are summed in threshold order, so the result is bit-for-bit the same for any
/// thread count. Cost: `K · W · H · D · (2⌈4σ⌉ + 1) · 2` multiply-adds.
///
/// Panics if `thresholds == 0`, `sigma` is not finite and positive, or `alpha ∉ (0, 1]`.
pub fn filtered_error(field: &Field, options: FilteredErrorOptions) -> Vec<f64> {
    let FilteredErrorOptions {
        thresholds,
        sigma,
        alpha,
        seed,
    } = options;
    assert!(thresholds > 0, "at least one threshold");
    assert!(
        sigma.is_finite() && sigma > 0.0,
        "sigma {sigma} must be > 0"
    );
    assert!(
        alpha > 0.0 && alpha <= 1.0,
        "alpha {alpha} must be in (0, 1]"
    );
    let depth = field.depth();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    // Row s: the thresholds of stratum s at every frame.
    let levels: Vec<f64> = (0..thresholds * depth)
        .map(|i| ((i / depth) as f64 + rng.random::<f64>()) / thresholds as f64)
        .collect();
    let kernel = gaussian_weights(sigma);
    let variances: Vec<Vec<f64>> = levels
        .par_chunks(depth)
        .map(|levels| threshold_variances(field, levels, &kernel, alpha))
        .collect();
    let mut sum = vec![0.0; depth];
    for part in &variances {
        sum.iter_mut().zip(part).for_each(|(s, v)| *s += v);
    }
    sum.iter().map(|s| (s / thresholds as f64).sqrt()).collect()
}

/// The filtered error of a vector mask: [`filtered_error`] with random half-spaces for
/// thresholds (FAST's vector case).
///
/// `components[c]` holds component `c` of every pixel (`d = components.len() ≥ 1` fields of one
/// size; any range). For stratum `s ∈ 0..K` at frame `k`, a direction `n` uniform on the unit
/// sphere of `ℝᵈ` (always `+1` for `d = 1`) and a fraction `q = (s + u) / K` (`u` uniform in `[0, 1)`) are drawn; the
/// binary image is 1 at the `⌊q · W·H⌋` pixels whose projection `n · v(p)` is smallest (ties by
/// pixel index), i.e. the pixels on one side of a hyperplane that holds a fraction `q` of the
/// frame's values. That fraction being exact makes the figure comparable across sample spaces
/// (unit vectors, points ∝ an image) and, for `d = 1`, with [`filtered_error`] on masks with exact
/// frame histograms (which sets `round(q · W·H)` pixels, so the two differ by at most one pixel per
/// threshold). The blur, EMA and RMS are those of [`filtered_error`]; the result is
/// dimensionless coverage, one entry per frame, the same for any thread count.
///
/// Errors if the fields differ in size; panics on the options [`filtered_error`] panics on or on
/// an empty `components`.
pub fn filtered_error_vector(
    components: &[Field],
    options: FilteredErrorOptions,
) -> Result<Vec<f64>, FieldError> {
    let FilteredErrorOptions {
        thresholds,
        sigma,
        alpha,
        seed,
    } = options;
    assert!(!components.is_empty(), "at least one component");
    assert!(thresholds > 0, "at least one threshold");
    assert!(
        sigma.is_finite() && sigma > 0.0,
        "sigma {sigma} must be > 0"
    );
    assert!(
        alpha > 0.0 && alpha <= 1.0,
        "alpha {alpha} must be in (0, 1]"
    );
    let field = &components[0];
    let size = |f: &Field| (f.width(), f.height(), f.depth());
    if let Some(other) = components.iter().find(|f| size(f) != size(field)) {
        return Err(FieldError::Mismatch {
            first: size(field),
            second: size(other),
        });
    }
    let (depth, n, d) = (field.depth(), field.slice_pixels(), components.len());
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    // Per (stratum, frame): the fraction q, then the d direction components.
    let draws: Vec<f64> = (0..thresholds * depth)
        .flat_map(|i| {
            let q = ((i / depth) as f64 + rng.random::<f64>()) / thresholds as f64;
            let direction = unit_direction(&mut rng, d);
            std::iter::once(q).chain(direction)
        })
        .collect();
    let kernel = gaussian_weights(sigma);
    let variances: Vec<Vec<f64>> = draws
        .par_chunks(depth * (d + 1))
        .map(|draws| {
            let mut order: Vec<(f64, u32)> = Vec::with_capacity(n);
            binary_variances(field, &kernel, alpha, |z, binary| {
                let (q, direction) = (draws[z * (d + 1)], &draws[z * (d + 1) + 1..][..d]);
                order.clear();
                order.extend((0..n).map(|p| {
                    let projection: f64 = components
                        .iter()
                        .zip(direction)
                        .map(|(c, nc)| c.slice(z)[p] * nc)
                        .sum();
                    (projection, p as u32)
                }));
                let below = ((q * n as f64) as usize).min(n);
                binary.fill(0.0);
                if below > 0 {
                    order.select_nth_unstable_by(below - 1, |a, b| {
                        a.0.total_cmp(&b.0).then(a.1.cmp(&b.1))
                    });
                    for &(_, p) in &order[..below] {
                        binary[p as usize] = 1.0;
                    }
                }
            })
        })
        .collect();
    let mut sum = vec![0.0; depth];
    for part in &variances {
        sum.iter_mut().zip(part).for_each(|(s, v)| *s += v);
    }
    Ok(sum.iter().map(|s| (s / thresholds as f64).sqrt()).collect())
}

/// A direction uniform on the unit sphere of `ℝᵈ`: `d` normal deviates (Box–Muller), normalised;
/// `(1)` for `d = 1`, whose only directions are ±1 and give the same thresholds up to which side
/// is 1.
fn unit_direction(rng: &mut ChaCha8Rng, d: usize) -> Vec<f64> {
    if d == 1 {
        return vec![1.0];
    }
    loop {
        let mut v: Vec<f64> = (0..d)
            .map(|_| {
                let (u1, u2) = (1.0 - rng.random::<f64>(), rng.random::<f64>());
                (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
            })
            .collect();
        let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if norm > 1e-12 {
            v.iter_mut().for_each(|x| *x /= norm);
            return v;
        }
    }
}

/// The normalised 1D Gaussian `wᵢ ∝ exp(−i² / (2σ²))`, `i ∈ −r..=r` with `r = ⌈4σ⌉`; entry
/// `i + r`.
pub fn gaussian_weights(sigma: f64) -> Vec<f64> {
    let radius = (4.0 * sigma).ceil() as isize;
    let weights: Vec<f64> = (-radius..=radius)
        .map(|i| (-((i * i) as f64) / (2.0 * sigma * sigma)).exp())
        .collect();
    let total: f64 = weights.iter().sum();
    weights.iter().map(|w| w / total).collect()
}

/// Convolves the `w × h` image `image` toroidally with `kernel` (odd length, centred) along x,
/// then along y, into `out`; `scratch` holds the x pass. All three have `w · h` entries.
fn blur_toroidal(
    image: &[f64],
    w: usize,
    h: usize,
    kernel: &[f64],
    scratch: &mut [f64],
    out: &mut [f64],
) {
    let radius = kernel.len() / 2;
    // Source index of tap j for output coordinate c: (c + j − r) mod len, any r (also r ≥ len).
    let taps = |len: usize| -> Vec<usize> {
        (0..len)
            .flat_map(|c| (0..kernel.len()).map(move |j| (c + j + len * radius - radius) % len))
            .collect()
    };
    let xs = taps(w);
    for (row, dst) in image.chunks_exact(w).zip(scratch.chunks_exact_mut(w)) {
        for (d, src) in dst.iter_mut().zip(xs.chunks_exact(kernel.len())) {
            *d = kernel.iter().zip(src).map(|(k, &x)| k * row[x]).sum();
        }
    }
    let ys = taps(h);
    for (dst, src) in out.chunks_exact_mut(w).zip(ys.chunks_exact(kernel.len())) {
        dst.fill(0.0);
        for (k, &y) in kernel.iter().zip(src) {
            let row = &scratch[y * w..(y + 1) * w];
            dst.iter_mut().zip(row).for_each(|(d, r)| *d += k * r);
        }
    }
}

/// `Var(hₖ)` for every frame of one stratum, whose threshold at frame `k` is `levels[k]`.
fn threshold_variances(field: &Field, levels: &[f64], kernel: &[f64], alpha: f64) -> Vec<f64> {
    binary_variances(field, kernel, alpha, |z, binary| {
        let t = levels[z];
        for (b, &v) in binary.iter_mut().zip(field.slice(z)) {
            *b = if v < t { 1.0 } else { 0.0 };
        }
    })
}

/// `Var(hₖ)` for every frame of `field`'s size, where `binarize(k, b)` writes frame `k`'s binary
/// image into `b` (`W·H` entries, each 0 or 1).
fn binary_variances(
    field: &Field,
    kernel: &[f64],
    alpha: f64,
    mut binarize: impl FnMut(usize, &mut [f64]),
) -> Vec<f64> {
    let (w, h) = (field.width(), field.height());
    let n = w * h;
    let mut binary = vec![0.0; n];
    let mut scratch = vec![0.0; n];
    let mut filtered = vec![0.0; n];
    let mut ema = vec![0.0; n];
    (0..field.depth())
        .map(|z| {
            binarize(z, &mut binary);
            blur_toroidal(&binary, w, h, kernel, &mut scratch, &mut filtered);
            if z == 0 {
                ema.copy_from_slice(&filtered);
            } else {
                ema.iter_mut()
                    .zip(&filtered)
                    .for_each(|(e, f)| *e = alpha * f + (1.0 - alpha) * *e);
            }
            let mean = ema.iter().sum::<f64>() / n as f64;
            ema.iter().map(|e| (e - mean) * (e - mean)).sum::<f64>() / n as f64
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_are_normalised_and_cover_four_sigma() {
        let weights = gaussian_weights(1.3435);
        assert_eq!(weights.len(), 13); // ⌈5.374⌉ = 6 each side
        assert!((weights.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        assert!(weights.windows(2).take(6).all(|p| p[0] < p[1]));
        assert_eq!(weights[0], weights[12]);
        // Σ w² ≈ 1 / (2σ√π) for σ well above a pixel.
        let squares: f64 = weights.iter().map(|w| w * w).sum();
        let continuous = 1.0 / (2.0 * 1.3435 * std::f64::consts::PI.sqrt());
        assert!((squares / continuous - 1.0).abs() < 1e-3, "{squares}");
    }

    #[test]
    fn blur_of_an_impulse_is_the_wrapped_kernel() {
        // 5 × 3 image, kernel radius 2 (longer than the 3-pixel column: taps wrap twice).
        let (w, h) = (5, 3);
        let kernel = [0.1, 0.2, 0.4, 0.2, 0.1];
        let mut image = vec![0.0; w * h];
        image[w] = 1.0; // (0, 1)
        let (mut scratch, mut out) = (vec![0.0; w * h], vec![0.0; w * h]);
        blur_toroidal(&image, w, h, &kernel, &mut scratch, &mut out);
        // Along y (h = 3): offsets −2..=2 land on rows 2, 0, 1, 2, 0 → row weights.
        let wy = |y: usize| match y {
            0 => 0.2 + 0.1, // offsets −1 and +2
            1 => 0.4,
            _ => 0.1 + 0.2, // offsets −2 and +1
        };
        let wx = |x: usize| match x {
            0 => 0.4,
            1 | 4 => 0.2,
            _ => 0.1,
        };
        for y in 0..h {
            for x in 0..w {
                let expected = wx(x) * wy(y);
                assert!((out[y * w + x] - expected).abs() < 1e-15, "({x}, {y})");
            }
        }
        assert!((out.iter().sum::<f64>() - 1.0).abs() < 1e-15);
    }

    #[test]
    fn constant_stripe_and_ema_fields_measure_exactly() {
        // A constant field thresholds to a constant image at every t: no error anywhere (up to
        // the rounding of the blur, which need not return exactly 1 for an all-ones image).
        let values = vec![0.4; 8 * 8 * 3];
        let field = Field::new(8, 8, 3, &values).unwrap();
        let error = filtered_error(&field, FilteredErrorOptions::default());
        assert_eq!(error.len(), 3);
        assert!(error.iter().all(|&e| e < 1e-12), "{error:?}");
        // Half the pixels 0, half 0.99, in columns: any t in (0, 0.99] gives vertical stripes
        // that the x blur cannot flatten fully; alpha 1 = no history.
        let stripes: Vec<f64> = (0..16)
            .map(|i| if i % 2 == 0 { 0.0 } else { 0.99 })
            .collect();
        let field = Field::new(4, 4, 1, &stripes).unwrap();
        let options = FilteredErrorOptions {
            thresholds: 64,
            alpha: 1.0,
            ..FilteredErrorOptions::default()
        };
        let kernel = gaussian_weights(FilteredErrorOptions::SIGMA);
        // Period-2 stripes keep the kernel's response at Nyquist: Σ (−1)^i wᵢ.
        let gain: f64 = kernel
            .iter()
            .enumerate()
            .map(|(i, w)| if i % 2 == 0 { *w } else { -*w })
            .sum::<f64>()
            .abs();
        // Thresholds above 0.99 (64 · 0.01 = 0.64 of a stratum) see an all-ones image.
        let covered: f64 = 0.99 * 64.0;
        let expected = (0.25 * gain * gain * covered.floor() / 64.0).sqrt();
        let measured = filtered_error(&field, options)[0];
        // The partial stratum 63 adds between 0 and 1/64 of the stripe variance.
        let most = (0.25 * gain * gain * covered.ceil() / 64.0).sqrt();
        assert!(
            measured >= expected - 1e-15 && measured <= most + 1e-15,
            "{expected} ≤ {measured} ≤ {most}"
        );
        // Add a frame of zeros (all ones for every t > 0): the EMA keeps (1 − α) of the stripes,
        // h₁ = α · 1 + (1 − α) · h₀, so E(1) = (1 − α) · E(0) exactly (up to rounding).
        let mut two = stripes.clone();
        two.extend([0.0; 16]);
        let field = Field::new(4, 4, 2, &two).unwrap();
        let alpha = 0.3;
        let curve = filtered_error(&field, FilteredErrorOptions { alpha, ..options });
        assert!(
            (curve[1] - (1.0 - alpha) * curve[0]).abs() < 1e-12,
            "{curve:?}"
        );
    }

    #[test]
    fn vector_thresholds_hold_exact_fractions_and_match_the_scalar_figure_in_1d() {
        // A permutation per frame (exact histogram): for d = 1 the half-space threshold at
        // fraction q picks the same pixels as v < t for t = q up to the jitter of one level.
        let (w, h, d) = (16, 16, 4);
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut values = Vec::new();
        for _ in 0..d {
            let mut frame: Vec<f64> = (0..w * h)
                .map(|i| (i as f64 + 0.5) / (w * h) as f64)
                .collect();
            for i in (1..frame.len()).rev() {
                frame.swap(i, rng.random_range(0..=i));
            }
            values.extend(frame);
        }
        let field = Field::new(w, h, d, &values).unwrap();
        let options = FilteredErrorOptions::default();
        let scalar = filtered_error(&field, options);
        let vector = filtered_error_vector(std::slice::from_ref(&field), options).unwrap();
        for (s, v) in scalar.iter().zip(&vector) {
            assert!((s - v).abs() < 0.02 * s, "{scalar:?} vs {vector:?}");
        }
        // Two components: white 2D vectors measure near the white-noise expectation, a constant
        // pair (all pixels on one side of every hyperplane... or split by index ties) is finite.
        let other: Vec<f64> = values.iter().rev().copied().collect();
        let second = Field::new(w, h, d, &other).unwrap();
        let pair = filtered_error_vector(&[field, second], options).unwrap();
        assert_eq!(pair.len(), d);
        assert!(pair.iter().all(|e| e.is_finite() && *e > 0.0), "{pair:?}");
    }

    #[test]
    fn vector_fields_of_different_sizes_are_an_error() {
        let a = Field::new(2, 2, 1, &[0.1; 4]).unwrap();
        let b = Field::new(4, 1, 1, &[0.1; 4]).unwrap();
        assert!(filtered_error_vector(&[a, b], FilteredErrorOptions::default()).is_err());
    }

    #[test]
    fn directions_are_unit_and_cover_both_signs() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let dirs: Vec<Vec<f64>> = (0..200).map(|_| unit_direction(&mut rng, 3)).collect();
        for v in &dirs {
            assert!((v.iter().map(|x| x * x).sum::<f64>() - 1.0).abs() < 1e-12);
        }
        for c in 0..3 {
            let mean = dirs.iter().map(|v| v[c]).sum::<f64>() / 200.0;
            assert!(mean.abs() < 0.15, "component {c} mean {mean}");
        }
    }
}
