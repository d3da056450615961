//! Elementary functions built from basic IEEE operations only: no platform `libm`, so the same
//! bits on every platform, and no branches, so loops over them vectorise. The generators' energies
//! go through them wherever a result must be reproducible bit for bit.

use std::array::from_fn;

/// `e^−x` for `x ≥ 0` (`+∞` allowed), to within a few units in the last place; results below
/// `e^−708` come out as `e^−708` (≈ 3·10⁻³⁰⁸). Basic IEEE operations only, so bit-identical on
/// every platform, and branch-free, so loops over it vectorise.
#[inline(always)]
pub(crate) fn exp_neg(x: f64) -> f64 {
    const LOG2_E: f64 = std::f64::consts::LOG2_E;
    // ln 2 split so that k · LN2_HI is exact for |k| < 2^11.
    const LN2_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000);
    const LN2_LO: f64 = f64::from_bits(0x3dea_39ef_3579_3c76);
    // 1.5 · 2^52: adding it rounds to an integer held in the low mantissa bits.
    const ROUND: f64 = 6_755_399_441_055_744.0;
    let x = x.min(708.0);
    let shifted = x * LOG2_E + ROUND;
    let k = shifted - ROUND;
    // e^−x = 2^−k · e^−r with r = x − k ln 2 in [−ln2/2, ln2/2].
    let r = (x - k * LN2_HI) - k * LN2_LO;
    let t = -r;
    // Taylor series of e^t to degree 12: error below 2·10⁻¹⁶ relative for |t| ≤ 0.35.
    let mut p = 1.0 / 479_001_600.0;
    p = p * t + 1.0 / 39_916_800.0;
    p = p * t + 1.0 / 3_628_800.0;
    p = p * t + 1.0 / 362_880.0;
    p = p * t + 1.0 / 40_320.0;
    p = p * t + 1.0 / 5_040.0;
    p = p * t + 1.0 / 720.0;
    p = p * t + 1.0 / 120.0;
    p = p * t + 1.0 / 24.0;
    p = p * t + 1.0 / 6.0;
    p = p * t + 0.5;
    p = p * t + 1.0;
    p = p * t + 1.0;
    // 2^−k from the integer in the low bits of `shifted` (0 ≤ k ≤ 1022).
    let k_int = shifted.to_bits() & 0x7ff;
    p * f64::from_bits((1023 - k_int) << 52)
}

/// `e^−x` in single precision for `x ≥ 0` (`+∞` allowed), relative error below 6·10⁻⁶ (tested up
/// to `x = 86`); results below `e^−87` come out as `e^−87` (≈ 1.6·10⁻³⁸). As `2^−y`, `y = x log₂e`
/// rounded to single precision: `2^−k` from the bits of the nearest integer `k`, times a Taylor
/// polynomial of degree 5 for `2^f`, `f = k − y` in `[−½, ½]` (truncation `(½ ln 2)⁶/6! =
/// 2.4·10⁻⁶`, 3.4·10⁻⁶ relative at `f = −½`). One multiplication reduces the argument and
/// degree 5 suffices, where a series of `e^t` after a two-constant `ln 2` reduction needs degree
/// 7 for 2·10⁻⁷; with two Newton steps for the cube root instead of three, the Vec2 value factor
/// takes 1.4 instead of 2.2 ns per entry (an AVX2 loop over 128 entries; BENCHMARKS.md, "Design
/// decisions").
///
/// Evaluated for `N` lanes one step at a time: the same operations per lane (the same bits for
/// any `N`), but `N / 8` independent AVX2 chains in flight instead of one, where the chain's
/// latency and not the number of operations bounds a loop over it.
#[inline(always)]
pub(crate) fn exp_neg_f32_lanes<const N: usize>(x: [f32; N]) -> [f32; N] {
    // 1.5 · 2^23: adding it rounds to an integer held in the low mantissa bits.
    const ROUND: f32 = 12_582_912.0;
    let y = x.map(|x| x.min(87.0) * std::f32::consts::LOG2_E);
    let shifted = y.map(|y| y + ROUND);
    let f: [f32; N] = from_fn(|i| (shifted[i] - ROUND) - y[i]);
    // (ln 2)^n / n!
    let mut p = [1.333_355_8e-3; N];
    for c in [
        9.618_129e-3,
        5.550_411e-2,
        0.240_226_5,
        std::f32::consts::LN_2,
        1.0,
    ] {
        p = from_fn(|i| p[i] * f[i] + c);
    }
    // 2^−k from the integer in the low bits of `shifted` (0 ≤ k ≤ 126).
    from_fn(|i| p[i] * f32::from_bits((127 - (shifted[i].to_bits() & 0xff)) << 23))
}

/// `s^(−1/3)` in single precision for `s > 0` (huge but finite for `s = 0`), relative error
/// below 1.5·10⁻⁵. A first guess from the bits of `s` (off by at most 3.5%), then two steps of
/// Newton's iteration `r ← r (4 − s r³) / 3` (error `e ↦ 2e²`: 3.5% → 2.4·10⁻³ → 1.2·10⁻⁵).
/// Evaluated for `N` lanes one step at a time, as [`exp_neg_f32_lanes`].
#[inline(always)]
pub(crate) fn inverse_cbrt_f32_lanes<const N: usize>(s: [f32; N]) -> [f32; N] {
    // The exponent field of s^(−1/3) is about (4/3)·127 − bits(s)/3 (in units of 2^23), with the
    // division by 3 as a widening multiply.
    let mut r = s.map(|s| {
        let third = ((u64::from(s.to_bits()) * 0xAAAA_AAAB) >> 33) as u32;
        f32::from_bits(0x54a2_32abu32.wrapping_sub(third))
    });
    for _ in 0..2 {
        let sr3: [f32; N] = from_fn(|i| ((s[i] * r[i]) * r[i]) * r[i]);
        r = from_fn(|i| r[i] * (4.0 - sr3[i]) * (1.0 / 3.0));
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp_neg_matches_std() {
        let mut worst: f64 = 0.0;
        // Up to 707 (beyond 708 the result is clamped to e^−708 by design).
        for i in 0..191_000 {
            let x = i as f64 * 0.0037;
            let rel = (exp_neg(x) - (-x).exp()).abs() / (-x).exp();
            worst = worst.max(rel);
        }
        assert!(worst < 1e-15, "worst relative error {worst}");
        assert_eq!(exp_neg(0.0), 1.0);
        assert!(exp_neg(f64::INFINITY) < 1e-300);
    }

    #[test]
    fn single_precision_exp_and_cube_root_match_std() {
        let (mut worst_exp, mut worst_cbrt): (f64, f64) = (0.0, 0.0);
        for i in 0..200_000 {
            // exp: up to 86 (beyond 87 the result is clamped by design).
            let x = i as f32 * 4.3e-4;
            let exact = (-f64::from(x)).exp();
            worst_exp = worst_exp.max((f64::from(exp_neg_f32_lanes([x])[0]) - exact).abs() / exact);
            let s = (i + 1) as f32 * 2.3e-5;
            for s in [s, s * 1e-20, s * 1e20] {
                let exact = f64::from(s).powf(-1.0 / 3.0);
                let got = f64::from(inverse_cbrt_f32_lanes([s])[0]);
                worst_cbrt = worst_cbrt.max((got - exact).abs() / exact);
            }
        }
        assert!(worst_exp < 6e-6, "exp: worst relative error {worst_exp}");
        assert!(
            worst_cbrt < 1.5e-5,
            "cube root: worst relative error {worst_cbrt}"
        );
        assert_eq!(exp_neg_f32_lanes([0.0])[0], 1.0);
        assert!(exp_neg_f32_lanes([f32::INFINITY])[0] < 1e-37);
        assert!(inverse_cbrt_f32_lanes([0.0])[0].is_finite());
    }
}
