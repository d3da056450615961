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

/// Arguments of [`exp_neg_f32_lanes`] from this on (and NaN) give its clamped result `e^−87`,
/// which does not change with the argument.
pub(crate) const EXP_NEG_F32_CLAMP: f32 = 87.0;

/// `e^−x` in single precision for `x ≥ 0` (`+∞` allowed), relative error below 1.1·10⁻⁵ (tested
/// up to `x = 86`); results below `e^−87` come out as `e^−87` (≈ 1.6·10⁻³⁸). As `2^−y`, `y = x
/// log₂e` rounded to single precision: `2^−k` from the bits of the nearest integer `k`, times a
/// quartic for `2^f`, `f = k − y` in `[−½, ½]`, exact at `f = 0`, that interpolates `2^f` at the
/// four Chebyshev nodes of `(2^f − 1) / f` (7·10⁻⁶ relative; Taylor's degree 5, one multiply-add
/// more: 3.4·10⁻⁶). A cubic (2·10⁻⁴) measured the same report figures but a worse
/// ambient-occlusion scene, over five seeds (BENCHMARKS.md, "Design decisions").
///
/// Evaluated for `N` lanes one step at a time: the same operations per lane (the same bits for
/// any `N`), but `N / 8` independent AVX2 chains in flight instead of one, where the chain's
/// latency and not the number of operations bounds a loop over it.
#[inline(always)]
pub(crate) fn exp_neg_f32_lanes<const N: usize>(x: [f32; N]) -> [f32; N] {
    // 1.5 · 2^23: adding it rounds to an integer held in the low mantissa bits.
    const ROUND: f32 = 12_582_912.0;
    let y = x.map(|x| x.min(EXP_NEG_F32_CLAMP) * std::f32::consts::LOG2_E);
    let shifted = y.map(|y| y + ROUND);
    let f: [f32; N] = from_fn(|i| (shifted[i] - ROUND) - y[i]);
    // Interpolating (2^f − 1) / f at the Chebyshev nodes of [−½, ½], in single precision.
    let mut p = [0.009_656_711; N];
    for c in [0.055_838_283, 0.240_225_3, 0.693_136_75, 1.0] {
        p = from_fn(|i| p[i] * f[i] + c);
    }
    // 2^−k from the integer in the low bits of `shifted` (0 ≤ k ≤ 126).
    from_fn(|i| p[i] * f32::from_bits((127 - (shifted[i].to_bits() & 0xff)) << 23))
}

/// `s^(−1/3)` in single precision for `s > 0` (huge but finite for `s = 0`), relative error
/// below 2.1·10⁻⁴. A first guess from the bits of `s` (off by at most 3.5%), then one
/// second-order step: with `ε = 1 − s r³`, `r (1 + ε/3 + 2ε²/9)`, three operations more than a
/// Newton step and three fewer than two of them. One Newton step (2.4·10⁻³, with a cubic `exp`)
/// measured a 0.2% higher Vec2 filtered error; with this step the 128×128×64 figures stay
/// within the seeds' spread of those of two Newton steps (1.2·10⁻⁵) (BENCHMARKS.md, "Vector
/// masks" and "Design decisions").
/// Evaluated for `N` lanes one step at a time, as [`exp_neg_f32_lanes`].
#[inline(always)]
pub(crate) fn inverse_cbrt_f32_lanes<const N: usize>(s: [f32; N]) -> [f32; N] {
    // The exponent field of s^(−1/3) is about (4/3)·127 − bits(s)/3 (in units of 2^23), with the
    // division by 3 as a widening multiply.
    let r = s.map(|s| {
        let third = ((u64::from(s.to_bits()) * 0xAAAA_AAAB) >> 33) as u32;
        f32::from_bits(0x54a2_32abu32.wrapping_sub(third))
    });
    // s r³ = 1 − ε, and s^(−1/3) = r (1 − ε)^(−1/3) = r (1 + ε/3 + 2ε²/9 + …).
    let e: [f32; N] = from_fn(|i| 1.0 - ((s[i] * r[i]) * r[i]) * r[i]);
    from_fn(|i| r[i] * (1.0 + e[i] * (1.0 / 3.0 + e[i] * (2.0 / 9.0))))
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
        assert!(worst_exp < 1.1e-5, "exp: worst relative error {worst_exp}");
        assert!(
            worst_cbrt < 2.1e-4,
            "cube root: worst relative error {worst_cbrt}"
        );
        assert_eq!(exp_neg_f32_lanes([0.0])[0], 1.0);
        assert!(exp_neg_f32_lanes([f32::INFINITY])[0] < 1e-37);
        assert!(inverse_cbrt_f32_lanes([0.0])[0].is_finite());
    }
}
