//! The correctly rounded `f32` square root that unit-vector decoding normalises with.
//!
//! `core` has no `f32::sqrt` (not on the crate's MSRV, not on today's stable), so each target
//! with a square-root instruction reaches it through `core::arch`: SSE's `sqrtss` on x86 and
//! x86-64, NEON's `fsqrt` on AArch64. IEEE 754 requires a correctly rounded square root, so
//! every such CPU returns the same bits, and LLVM vectorises loops over it (the row fills take
//! 4 voxels per `sqrtps`). Every other target computes the same correctly rounded value in
//! software (`sqrt_in_software`, compiled only there and in tests), so a mask decodes to the
//! same bits on every target.
//!
//! The `unsafe` here has a measured reason: against a plain-`f32` reciprocal-square-root
//! iteration (within 1 ulp, about 13 dependent operations, no `unsafe`), per-sample unit-vector
//! reads are 1.37–1.43× faster and the row fills 1.12–1.14× (1080p frames of octahedral and
//! signed unit-vector masks on an AVX2 Zen 3; BENCHMARKS.md, "Design decisions").

/// `sqrt(d)`, correctly rounded as IEEE 754 requires: `+0` for `+0`, `+inf` for `+inf`, NaN
/// for NaN or negative `d`.
#[cfg(all(
    any(target_arch = "x86_64", target_arch = "x86"),
    target_feature = "sse"
))]
#[inline(always)]
#[allow(unsafe_code)]
pub(crate) fn sqrt(d: f32) -> f32 {
    #[cfg(target_arch = "x86")]
    use core::arch::x86::{_mm_cvtss_f32, _mm_set_ss, _mm_sqrt_ss};
    #[cfg(target_arch = "x86_64")]
    use core::arch::x86_64::{_mm_cvtss_f32, _mm_set_ss, _mm_sqrt_ss};
    // SAFETY: the three intrinsics need SSE, which `target_feature = "sse"` says every CPU this
    // is compiled for has; they take and return values and touch no memory.
    unsafe { _mm_cvtss_f32(_mm_sqrt_ss(_mm_set_ss(d))) }
}

/// `sqrt(d)`, correctly rounded as IEEE 754 requires (see the x86 version).
#[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
#[inline(always)]
#[allow(unsafe_code)]
pub(crate) fn sqrt(d: f32) -> f32 {
    use core::arch::aarch64::{vdup_n_f32, vget_lane_f32, vsqrt_f32};
    // SAFETY: the three intrinsics need NEON, which `target_feature = "neon"` says every CPU
    // this is compiled for has; they take and return values and touch no memory.
    unsafe { vget_lane_f32::<0>(vsqrt_f32(vdup_n_f32(d))) }
}

/// `sqrt(d)`, correctly rounded as IEEE 754 requires (see the x86 version), in software.
#[cfg(not(any(
    all(
        any(target_arch = "x86_64", target_arch = "x86"),
        target_feature = "sse"
    ),
    all(target_arch = "aarch64", target_feature = "neon"),
)))]
#[inline(always)]
pub(crate) fn sqrt(d: f32) -> f32 {
    sqrt_in_software(d)
}

/// IEEE 754's correctly rounded `sqrt(d)` in plain `f64` arithmetic, for targets without the
/// instruction (and, in the tests, checked against it).
///
/// A reciprocal-square-root estimate (relative error below 3.5%) and four Newton steps give
/// `sqrt(d)` within about `1e-15` relative, far inside half an `f32` ulp (`3e-8`), so its
/// rounding to `f32` is the right value or a neighbour. One exact test then picks: the midpoints
/// between that value and its neighbours have 25 significant bits, so they and their squares
/// (50 bits) are exact in `f64`, and `sqrt(d)` is never exactly a midpoint.
#[cfg(any(
    test,
    not(any(
        all(
            any(target_arch = "x86_64", target_arch = "x86"),
            target_feature = "sse"
        ),
        all(target_arch = "aarch64", target_feature = "neon"),
    ))
))]
pub(crate) fn sqrt_in_software(d: f32) -> f32 {
    if !(d > 0.0 && d < f32::INFINITY) {
        // ±0 and +inf are their own roots; NaN and negative numbers have none.
        return if d == 0.0 || d == f32::INFINITY {
            d
        } else {
            f32::NAN
        };
    }
    // Every positive finite f32 (subnormals included) is a normal f64.
    let x = f64::from(d);
    let mut y = f64::from_bits(0x5FE6_EB50_C7B5_37A9 - (x.to_bits() >> 1));
    for _ in 0..4 {
        y *= 1.5 - 0.5 * x * y * y;
    }
    let root = (x * y) as f32;
    // `root` is a normal f32 between 2^-75 and 2^64, so both neighbours are finite and positive.
    let up = f32::from_bits(root.to_bits() + 1);
    let down = f32::from_bits(root.to_bits() - 1);
    let mid_up = (f64::from(root) + f64::from(up)) * 0.5;
    let mid_down = (f64::from(root) + f64::from(down)) * 0.5;
    if mid_up * mid_up < x {
        up
    } else if mid_down * mid_down > x {
        down
    } else {
        root
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::{sqrt, sqrt_in_software};

    /// The correctly rounded root: rounding the `f64` root to `f32` cannot round twice wrongly,
    /// since `f64` has more than `2 * 24 + 2` significant bits.
    fn reference(d: f32) -> f32 {
        f64::from(d).sqrt() as f32
    }

    #[test]
    fn both_roots_are_correctly_rounded_for_every_significand() {
        // [1, 4) holds every significand with both exponent parities: every root's rounding
        // case.
        for bits in 1.0f32.to_bits()..4.0f32.to_bits() {
            let d = f32::from_bits(bits);
            let want = reference(d).to_bits();
            assert_eq!(sqrt(d).to_bits(), want, "{d:e}");
            assert_eq!(sqrt_in_software(d).to_bits(), want, "{d:e}");
        }
    }

    #[test]
    fn both_roots_are_correctly_rounded_over_the_whole_range() {
        let patterns = (1..f32::INFINITY.to_bits()).step_by(4093);
        let specials = [0.0, -0.0, f32::MIN_POSITIVE, f32::MAX, f32::INFINITY, 1e-45];
        for d in patterns.map(f32::from_bits).chain(specials) {
            let want = reference(d).to_bits();
            assert_eq!(sqrt(d).to_bits(), want, "{d:e}");
            assert_eq!(sqrt_in_software(d).to_bits(), want, "{d:e}");
        }
        for d in [-1.0, -0.5e-40, f32::NEG_INFINITY, f32::NAN] {
            assert!(sqrt(d).is_nan() && sqrt_in_software(d).is_nan(), "{d}");
        }
    }
}
