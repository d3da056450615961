//! Baseline value fields to compare masks against: what a renderer uses when it has no
//! spatiotemporal blue noise.
//!
//! Every function returns a `width × height × depth` field of values in `[0, 1)`, index
//! `(z · height + y) · width + x`, ready for [`crate::analysis::Field::new`]:
//!
//! - [`white_noise`]: independent uniform values (seeded ChaCha8).
//! - [`golden_ratio_animated`]: one 2D blue-noise slice `v`, frame `z` reading
//!   `fract(v + z · φ⁻¹)` (φ⁻¹ = (√5 − 1)/2 ≈ 0.618): the common "animate blue noise with the golden
//!   ratio" trick. Each pixel's sequence is a 1D low-discrepancy (Kronecker) sequence.
//! - [`random_shift`]: `fract(v + rₖ)` with a random offset `rₖ` per frame (Tellusim's
//!   `RandomShift2D`): blue in space, white over time.
//!
//! The 2D blue noise comes from [`blue_noise_2d`] (a one-frame void-and-cluster mask).
//!
//! # Exact toroidal addition
//!
//! Values and offsets are added in 0.64 fixed point: `x ↦ ⌊x · 2⁶⁴⌋` as a `u64`, added with
//! wrapping (which is `fract` exactly), and mapped back by keeping the top 53 bits,
//! `(s >> 11) · 2⁻⁵³ ∈ [0, 1)`. The golden-ratio step is `z · ⌊2⁶⁴/φ⌉` in wrapping `u64`
//! arithmetic, exact for every frame: the only error is the constant's rounding, `z · 2⁻⁶⁵`
//! (`< 2⁻³³` for `z < 2³²`), where the `f64` product `z as f64 · φ⁻¹` already loses about
//! `z · 2⁻⁵³` to rounding *before* `fract` throws away the integer part.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::{MaskSpec, SpecError, generate};

/// `round(2⁶⁴ / φ)`: the golden-ratio step φ⁻¹ = 0.6180339887… in 0.64 fixed point.
pub const PHI_INV_FIXED: u64 = 0x9E37_79B9_7F4A_7C16;

/// `width · height · depth` independent uniform values in `[0, 1)` (53 random bits each) from a
/// ChaCha8 stream seeded with `seed`.
pub fn white_noise(width: usize, height: usize, depth: usize, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..width * height * depth)
        .map(|_| rng.random::<f64>())
        .collect()
}

/// One `width × height` slice of 2D blue noise: the values of the one-frame void-and-cluster
/// mask `generate(&MaskSpec::new(width, height, 1, seed))`, a permutation of
/// `(i + 0.5) / (width · height)`.
pub fn blue_noise_2d(width: u32, height: u32, seed: u64) -> Result<Vec<f64>, SpecError> {
    Ok(generate(&MaskSpec::new(width, height, 1, seed))?.values())
}

/// `fract(v + frame · φ⁻¹)` exactly in fixed point ([module docs](self)), for `v ∈ [0, 1)` and
/// any frame number. Values `≥ 1` or negative are reduced modulo 1 first (NaN maps to 0).
pub fn golden_ratio_shift(v: f64, frame: u64) -> f64 {
    from_fixed(to_fixed(v).wrapping_add(frame.wrapping_mul(PHI_INV_FIXED)))
}

/// `depth` frames of `base` (one slice) animated by the golden ratio: frame `z` holds
/// [`golden_ratio_shift`]`(v, z)` of every value `v` of `base`.
pub fn golden_ratio_animated(base: &[f64], depth: usize) -> Vec<f64> {
    (0..depth as u64)
        .flat_map(|z| base.iter().map(move |&v| golden_ratio_shift(v, z)))
        .collect()
}

/// `depth` frames of `base` (one slice), frame `z` holding `fract(v + r_z)` with `r_z` uniform in
/// `[0, 1)` (64 bits from a ChaCha8 stream seeded with `seed`), added exactly in fixed point.
pub fn random_shift(base: &[f64], depth: usize, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..depth)
        .flat_map(|_| {
            let shift: u64 = rng.random();
            base.iter()
                .map(move |&v| from_fixed(to_fixed(v).wrapping_add(shift)))
        })
        .collect()
}

/// One baseline of [`comparison`]: a name, what it is, and its values.
#[derive(Clone, Debug, PartialEq)]
pub struct Baseline {
    /// `white_noise`, `golden_ratio_2d` or `random_shift_2d`.
    pub name: &'static str,
    /// A short description for reports.
    pub kind: &'static str,
    /// `width · height · depth` values in `[0, 1)`, index `(z · height + y) · width + x`.
    pub values: Vec<f64>,
}

/// The three baselines at `width × height × depth`, all from `seed`: [`white_noise`], and
/// [`golden_ratio_animated`] and [`random_shift`] of [`blue_noise_2d`].
pub fn comparison(
    width: u32,
    height: u32,
    depth: u32,
    seed: u64,
) -> Result<Vec<Baseline>, SpecError> {
    let base = blue_noise_2d(width, height, seed)?;
    let depth = depth as usize;
    Ok(vec![
        Baseline {
            name: "white_noise",
            kind: "baseline: white noise",
            values: white_noise(width as usize, height as usize, depth, seed),
        },
        Baseline {
            name: "golden_ratio_2d",
            kind: "baseline: 2D blue noise + frame·φ⁻¹",
            values: golden_ratio_animated(&base, depth),
        },
        Baseline {
            name: "random_shift_2d",
            kind: "baseline: 2D blue noise + random shift per frame",
            values: random_shift(&base, depth, seed),
        },
    ])
}

/// `⌊fract(v) · 2⁶⁴⌋`; exact for every `v ∈ [2⁻¹¹, 1)` (their ulp is at least 2⁻⁶⁴).
fn to_fixed(v: f64) -> u64 {
    // `as` saturates: fract(v) < 1 keeps the product below 2⁶⁴, NaN gives 0.
    (v.rem_euclid(1.0) * 2f64.powi(64)) as u64
}

/// The top 53 bits of a 0.64 fixed-point value, as an `f64` in `[0, 1)`.
fn from_fixed(s: u64) -> f64 {
    (s >> 11) as f64 * 2f64.powi(-53)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `round(2¹²⁸ / φ)`: φ⁻¹ to 128 bits, for the exact reference.
    const PHI_INV_128: u128 = 0x9E37_79B9_7F4A_7C15_F39C_C060_5CED_C834;

    /// `fract(v + n · φ⁻¹)` with φ⁻¹ to 128 bits: error `< n · 2⁻¹²⁸ + 2⁻¹²⁸`.
    fn reference(v: f64, n: u64) -> f64 {
        let v = (v * 2f64.powi(64)) as u128;
        let s = (v << 64).wrapping_add((n as u128).wrapping_mul(PHI_INV_128));
        (s >> 64) as f64 * 2f64.powi(-64)
    }

    #[test]
    fn fixed_point_constant_is_the_rounded_golden_ratio() {
        assert_eq!(PHI_INV_FIXED, (PHI_INV_128 >> 64) as u64 + 1); // the next bit is 1: round up
        let phi_inv = (5f64.sqrt() - 1.0) / 2.0;
        assert!((PHI_INV_FIXED as f64 * 2f64.powi(-64) - phi_inv).abs() < 1e-16);
    }

    #[test]
    fn golden_ratio_shift_is_exact_at_any_frame() {
        let phi_inv = (5f64.sqrt() - 1.0) / 2.0;
        for v in [0.0, 0.25, 0.123_456_789, 0.999_999] {
            for frame in [1u64, 2, 1000, 1 << 31, (1 << 32) - 1, 1 << 40] {
                let exact = reference(v, frame);
                let fixed = golden_ratio_shift(v, frame);
                // Constant rounding n · 2⁻⁶⁵ plus output truncation 2⁻⁵³.
                let bound = frame as f64 * 2f64.powi(-65) + 2f64.powi(-52);
                let circular = |a: f64, b: f64| (a - b).abs().min(1.0 - (a - b).abs());
                assert!(
                    circular(fixed, exact) <= bound,
                    "v {v} frame {frame}: {fixed} vs {exact}"
                );
                if frame == 1 << 31 && v == 0.25 {
                    // The naive f64 formula is visibly off here; the fixed-point one is not.
                    let naive = (v + frame as f64 * phi_inv).fract();
                    assert!(circular(naive, exact) > 1e-8, "{naive} vs {exact}");
                    assert!(circular(fixed, exact) < 1e-9);
                }
            }
        }
        assert_eq!(golden_ratio_shift(0.25, 0), 0.25);
        assert_eq!(golden_ratio_shift(1.25, 0), 0.25);
    }

    #[test]
    fn baselines_have_the_documented_shape_and_range() {
        let base = [0.0, 0.5, 0.75, 0.999];
        let animated = golden_ratio_animated(&base, 3);
        assert_eq!(animated.len(), 12);
        assert_eq!(&animated[..4], &base);
        assert!(animated.iter().all(|v| (0.0..1.0).contains(v)));
        let shifted = random_shift(&base, 5, 3);
        assert_eq!(shifted.len(), 20);
        assert!(shifted.iter().all(|v| (0.0..1.0).contains(v)));
        // Each frame is one rotation of the base: differences mod 1 are preserved.
        for frame in shifted.chunks_exact(4) {
            let d = (frame[1] - frame[0]).rem_euclid(1.0);
            assert!((d - 0.5).abs() < 1e-15, "{frame:?}");
        }
        assert_eq!(random_shift(&base, 5, 3), shifted);
        assert_ne!(random_shift(&base, 5, 4), shifted);
        let white = white_noise(4, 3, 2, 9);
        assert_eq!(white.len(), 24);
        assert!(white.iter().all(|v| (0.0..1.0).contains(v)));
        assert_eq!(white, white_noise(4, 3, 2, 9));
    }

    #[test]
    fn comparison_has_three_full_fields() {
        let set = comparison(8, 4, 3, 5).unwrap();
        let names: Vec<&str> = set.iter().map(|b| b.name).collect();
        assert_eq!(names, ["white_noise", "golden_ratio_2d", "random_shift_2d"]);
        assert!(set.iter().all(|b| b.values.len() == 96));
        // Frame 0 of the golden-ratio baseline is the 2D blue noise itself.
        assert_eq!(&set[1].values[..32], &blue_noise_2d(8, 4, 5).unwrap()[..]);
        assert!(comparison(8, 4, 3, 5).unwrap() == set);
    }

    #[test]
    fn blue_noise_2d_is_one_exactly_uniform_slice() {
        let mut slice = blue_noise_2d(8, 4, 1).unwrap();
        assert_eq!(slice.len(), 32);
        slice.sort_by(f64::total_cmp);
        assert!(
            slice
                .iter()
                .enumerate()
                .all(|(i, &v)| v == (i as f64 + 0.5) / 32.0)
        );
        assert!(blue_noise_2d(0, 4, 1).is_err());
    }
}
