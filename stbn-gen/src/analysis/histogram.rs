//! How far a mask's values are from uniform, per slice and per pixel ([`analysis`] docs,
//! "Histograms").
//!
//! [`analysis`]: crate::analysis#histograms

use rayon::prelude::*;

use super::Field;

/// The largest relative deviation of any slice's histogram from uniform.
///
/// Each slice's values are counted in `bins` equal bins of `[0, 1]` (value `v` goes to bin
/// `min(⌊v · bins⌋, bins − 1)`); with `e = width · height / bins` the expected count, the result
/// is `max |count − e| / e` over all slices and bins. Dimensionless, `≥ 0`: 0 for an exactly
/// uniform histogram (every slice of a [`crate::Volume`] when `bins` divides its slice size), 0.5
/// when some bin holds half again (or half less than) its share. Panics if `bins == 0`.
pub fn slice_histogram_deviation(field: &Field, bins: usize) -> f64 {
    assert!(bins > 0, "a histogram needs at least one bin");
    let expected = field.slice_pixels() as f64 / bins as f64;
    (0..field.depth())
        .into_par_iter()
        .map(|z| {
            let mut counts = vec![0usize; bins];
            for &v in field.slice(z) {
                counts[((v * bins as f64) as usize).min(bins - 1)] += 1;
            }
            counts
                .iter()
                .map(|&c| (c as f64 - expected).abs() / expected)
                .fold(0.0, f64::max)
        })
        .reduce(|| 0.0, f64::max)
}

/// The mean over pixels of the Kolmogorov–Smirnov distance of each pixel's values over the
/// frames from the uniform distribution on `[0, 1]` ([module docs](crate::analysis#histograms)).
///
/// For a pixel with sorted values `x₁ ≤ … ≤ x_D` the distance is
/// `max over i of max(i/D − xᵢ, xᵢ − (i − 1)/D)`: the largest gap between its empirical CDF
/// and the uniform CDF `F(x) = x`. Dimensionless, in `[1/(2D), 1]`: `1/(2D)` when the values sit
/// at the midpoints of `D` equal strata (perfect stratification over time), `0.87/√D` expected
/// for independent uniform values (Kolmogorov's limit `√(π/2) · ln 2 / √D`; slightly more for
/// small `D`), 1 − `x` for a pixel whose values are all `x`. Deterministic for any thread count
/// (pixel chunks are summed in order).
pub fn pixel_histogram_deviation(field: &Field) -> f64 {
    /// Pixels per parallel task.
    const CHUNK: usize = 1024;
    let (n, d) = (field.slice_pixels(), field.depth());
    let values = field.values();
    let starts: Vec<usize> = (0..n).step_by(CHUNK).collect();
    let sums: Vec<f64> = starts
        .into_par_iter()
        .map(|start| {
            let mut series = vec![0.0; d];
            (start..(start + CHUNK).min(n))
                .map(|p| {
                    for (z, s) in series.iter_mut().enumerate() {
                        *s = values[z * n + p];
                    }
                    series.sort_unstable_by(f64::total_cmp);
                    ks_distance(&series)
                })
                .sum::<f64>()
        })
        .collect();
    sums.iter().sum::<f64>() / n as f64
}

/// The Kolmogorov–Smirnov distance of the sorted sample `sorted` from the uniform distribution.
fn ks_distance(sorted: &[f64]) -> f64 {
    let d = sorted.len() as f64;
    sorted
        .iter()
        .enumerate()
        .map(|(i, &x)| ((i + 1) as f64 / d - x).max(x - i as f64 / d))
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn histogram_deviation_measures_the_worst_bin() {
        let uniform: Vec<f64> = (0..16).map(|i| (i as f64 + 0.5) / 16.0).collect();
        let field = Field::new(4, 4, 1, &uniform).unwrap();
        assert_eq!(slice_histogram_deviation(&field, 4), 0.0);
        assert_eq!(slice_histogram_deviation(&field, 16), 0.0);
        // Second slice: one value moved from bin 0 to bin 3 → counts 3,4,4,5 of 4 expected.
        let mut two = uniform.clone();
        two.extend(&uniform);
        two[16] = 1.0;
        let field = Field::new(4, 4, 2, &two).unwrap();
        assert_eq!(slice_histogram_deviation(&field, 4), 0.25);
    }

    #[test]
    fn pixel_deviation_is_the_ks_distance_of_each_pixel() {
        // Two pixels, four frames: pixel 0 at the stratum midpoints (distance 1/8), pixel 1
        // always 0.3 (empirical CDF jumps 0 → 1 at 0.3: distance 0.7).
        let mut values = Vec::new();
        for v in [0.625, 0.125, 0.875, 0.375] {
            values.extend([v, 0.3]);
        }
        let field = Field::new(2, 1, 4, &values).unwrap();
        let expected = (0.125 + 0.7) / 2.0;
        assert!((pixel_histogram_deviation(&field) - expected).abs() < 1e-15);
        assert_eq!(ks_distance(&[0.5]), 0.5);
        assert!((ks_distance(&[0.0, 0.1]) - 0.9).abs() < 1e-15);
    }
}
