//! Baselines to compare masks against: what a renderer uses when it has no spatiotemporal blue
//! noise.
//!
//! # Baseline masks ([`crate::generate_baseline`])
//!
//! Each [`BaselineKind`] is generated as a [`Volume`] of per-slice ranks, like the masks of
//! [`crate::generate`], so it goes through the same encoder, embedding and analysis. Every slice
//! is a permutation of `0..W·H`: its values `(rank + ½) / (W·H)` are exactly uniform. A
//! [`BaselineSpec`] names the kind, size and seed; the crate root re-exports both types.
//!
//! - [`BaselineKind::White`]: a seeded random permutation per slice. White in space and time.
//! - [`BaselineKind::GoldenRatio2D`]: one 2D void-and-cluster slice (ranks `r₀`), frame `z`
//!   holding `r_z = (r₀ + s(z)) mod N` with `s(z) = ⌊z · φ⁻¹ · N⌋ mod N`
//!   ([`golden_ratio_rank_shift`], exact integer arithmetic, `N = W·H`, φ⁻¹ = (√5 − 1)/2). Its
//!   values are `fract(v₀ + z · φ⁻¹)` up to less than `1/N` (rounded down to the rank grid), so
//!   every slice stays exactly uniform: the common "animate blue noise with the golden ratio"
//!   trick, each pixel's sequence a 1D low-discrepancy (Kronecker) sequence.
//! - [`BaselineKind::RandomShift2D`]: the same slice shifted by a seeded random `s(z) ∈ 0..N` per
//!   frame: `fract(bn + per-frame random)` as Tellusim describes it. Blue in space, white over
//!   time.
//! - [`BaselineKind::TellusimLayered`]: Tellusim's layered void-and-cluster ("Improved Blue
//!   Noise", 2022): a stack of 2D void-and-cluster masks, each layer's initial pattern the
//!   previous layer's ranks flipped in X and Y and thresholded at the initial density, with the
//!   kernel `exp(−d²/σ²) + ε / (1 + d²)` (Tellusim's σ convention, ε = 0.01) over the whole slice
//!   in exact integers. `O((W·H)² · D)`: fine for the 64×64 and 128×128 slices Tellusim
//!   recommends, slow for 256×256 and above (BENCHMARKS.md has measured times).
//!
//! # Value fields
//!
//! These functions return `width × height × depth` values in `[0, 1)`, index
//! `(z · height + y) · width + x`, ready for [`crate::analysis::Field::new`], without the rank
//! grid: [`white_noise`] (independent uniform values, so slices are only uniform on average),
//! [`golden_ratio_animated`] and [`random_shift`] of one [`blue_noise_2d`] slice. [`comparison`]
//! generates every baseline mask a manifest can declare, as value fields.
//!
//! # Exact toroidal addition
//!
//! [`golden_ratio_shift`] adds values and offsets in 0.64 fixed point: `x ↦ ⌊x · 2⁶⁴⌋` as a
//! `u64`, added with wrapping (which is `fract` exactly), and mapped back by keeping the top 53
//! bits, `(s >> 11) · 2⁻⁵³ ∈ [0, 1)`. The golden-ratio step is `z · ⌊2⁶⁴/φ⌉` in wrapping `u64`
//! arithmetic, exact for every frame: the only error is the constant's rounding, `z · 2⁻⁶⁵`
//! (`< 2⁻³³` for `z < 2³²`), where the `f64` product `z as f64 · φ⁻¹` already loses about
//! `z · 2⁻⁵³` to rounding *before* `fract` throws away the integer part.
//! [`golden_ratio_rank_shift`] does the same with a 128-bit constant and an exact 192-bit
//! product, which is exact on the rank grid (see its docs).

use std::time::Instant;

use rand::seq::SliceRandom;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::{EnergyTopology, MaskSpec, Observer, Progress, SpecError, Volume, generate, tellusim};

/// `round(2⁶⁴ / φ)`: the golden-ratio step φ⁻¹ = 0.6180339887… in 0.64 fixed point.
const PHI_INV_FIXED: u64 = 0x9E37_79B9_7F4A_7C16;

/// `round(2¹²⁸ / φ)`: φ⁻¹ in 0.128 fixed point, for [`golden_ratio_rank_shift`].
const PHI_INV_FIXED_128: u128 = 0x9E37_79B9_7F4A_7C15_F39C_C060_5CED_C834;

/// Which baseline mask a [`BaselineSpec`] asks for ([module docs](self)). The names match the
/// manifest's kinds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BaselineKind {
    /// A seeded random permutation of ranks per slice: white in space and time.
    White,
    /// One 2D blue-noise slice animated by the golden ratio, `fract(v + z · φ⁻¹)` on the rank
    /// grid: blue in space, a low-discrepancy sequence per pixel over time.
    GoldenRatio2D,
    /// One 2D blue-noise slice shifted by a random offset per frame, `fract(v + r_z)` on the rank
    /// grid: blue in space, white over time.
    RandomShift2D,
    /// Tellusim's layered void-and-cluster ([module docs](self)): each layer seeded from the
    /// previous one flipped in X and Y.
    TellusimLayered,
}

impl BaselineKind {
    /// Every kind, in report order.
    pub const ALL: [BaselineKind; 4] = [
        BaselineKind::White,
        BaselineKind::GoldenRatio2D,
        BaselineKind::RandomShift2D,
        BaselineKind::TellusimLayered,
    ];

    /// A short lowercase name, stable for file names and reports: `white_noise`,
    /// `golden_ratio_2d`, `random_shift_2d` or `tellusim_layered`.
    pub fn name(self) -> &'static str {
        match self {
            BaselineKind::White => "white_noise",
            BaselineKind::GoldenRatio2D => "golden_ratio_2d",
            BaselineKind::RandomShift2D => "random_shift_2d",
            BaselineKind::TellusimLayered => "tellusim_layered",
        }
    }

    /// A short description for reports.
    pub fn description(self) -> &'static str {
        match self {
            BaselineKind::White => "baseline: white noise",
            BaselineKind::GoldenRatio2D => "baseline: 2D blue noise + frame·φ⁻¹",
            BaselineKind::RandomShift2D => "baseline: 2D blue noise + random shift per frame",
            BaselineKind::TellusimLayered => "baseline: Tellusim layered void-and-cluster",
        }
    }

    /// The σ this kind reads from [`MaskSpec::sigma_xy`] by default, in pixels: the paper's 1.9
    /// (`exp(−d²/(2σ²))`) for the 2D blue-noise slice of the animated kinds, Tellusim's 1.6 in
    /// their convention (`exp(−d²/σ²)`) for [`BaselineKind::TellusimLayered`]. [`White`] reads
    /// no σ (1.9 is returned so that its spec stays valid).
    ///
    /// [`White`]: BaselineKind::White
    pub fn default_sigma(self) -> f64 {
        match self {
            BaselineKind::TellusimLayered => tellusim::DEFAULT_SIGMA,
            _ => MaskSpec::DEFAULT_SIGMA,
        }
    }
}

/// Everything that determines a baseline mask, bit for bit: equal specs give identical masks for
/// every thread count ([`generate_baseline`](crate::generate_baseline)).
#[derive(Clone, Debug, PartialEq)]
pub struct BaselineSpec {
    /// Which baseline.
    pub kind: BaselineKind,
    /// The size and seed, and what else `kind` reads (its other fields are ignored):
    /// [`BaselineKind::White`] nothing; [`BaselineKind::GoldenRatio2D`] and
    /// [`BaselineKind::RandomShift2D`] make their slice with its σ, density and tolerance
    /// ([`EnergyTopology::Independent2D`], depth 1); [`BaselineKind::TellusimLayered`] reads
    /// `sigma_xy` in Tellusim's convention (`exp(−d²/σ²)`) and the density. Every field must be
    /// in its range ([`MaskSpec::validate`]), read or not.
    pub mask: MaskSpec,
}

impl BaselineSpec {
    /// `kind` at `width × height × depth` pixels from `seed`, with the kind's
    /// [`default_sigma`](BaselineKind::default_sigma) and [`MaskSpec::new`]'s other defaults.
    pub fn new(kind: BaselineKind, width: u32, height: u32, depth: u32, seed: u64) -> BaselineSpec {
        BaselineSpec {
            kind,
            mask: MaskSpec::new(width, height, depth, seed).with_sigma(kind.default_sigma()),
        }
    }

    /// Checks every field of [`BaselineSpec::mask`] against its documented range
    /// ([`MaskSpec::validate`]).
    pub fn validate(&self) -> Result<(), SpecError> {
        self.mask.validate()
    }
}

/// The baseline mask `spec` describes ([`crate::generate_baseline`]), reporting pixels ranked to
/// `observer`.
pub(crate) fn generate_baseline(
    spec: &BaselineSpec,
    observer: &mut Observer<'_>,
) -> Result<Volume, SpecError> {
    spec.validate()?;
    let (kind, spec) = (spec.kind, &spec.mask);
    let (w, h, d) = (spec.width, spec.height, spec.depth);
    let n = spec.slice_pixels();
    let total = spec.pixels();
    observer.report(0, total);
    let ranks: Vec<u32> = match kind {
        BaselineKind::TellusimLayered => {
            return tellusim::generate_layered(spec, tellusim::DEFAULT_EPSILON, &mut |layers| {
                observer.report(layers * n, total)
            });
        }
        BaselineKind::White => {
            let mut rng = stream(spec.seed, Stream::White);
            let mut slice: Vec<u32> = (0..n as u32).collect();
            let mut ranks = Vec::with_capacity(total as usize);
            for z in 0..u64::from(d) {
                slice.shuffle(&mut rng);
                ranks.extend_from_slice(&slice);
                observer.report((z + 1) * n, total);
            }
            ranks
        }
        BaselineKind::GoldenRatio2D | BaselineKind::RandomShift2D => {
            // Ranking a pixel of the slice ranks it in every frame.
            let mut slice_progress = |p: Progress| observer.report(p.done * u64::from(d), total);
            let slice_observer = Observer::default().with_progress(&mut slice_progress);
            let base = generate(
                &MaskSpec {
                    depth: 1,
                    topology: EnergyTopology::Independent2D,
                    ..spec.clone()
                },
                slice_observer,
            )?;
            let shifts: Vec<u64> = if kind == BaselineKind::GoldenRatio2D {
                (0..u64::from(d))
                    .map(|z| golden_ratio_rank_shift(z, n))
                    .collect()
            } else {
                let mut rng = stream(spec.seed, Stream::RandomShift);
                (0..d).map(|_| rng.random_range(0..n)).collect()
            };
            shifts
                .iter()
                .flat_map(|&shift| {
                    base.ranks()
                        .iter()
                        .map(move |&r| ((u64::from(r) + shift) % n) as u32)
                })
                .collect()
        }
    };
    Ok(Volume::from_global_ranks(w, h, d, &ranks))
}

/// `⌊frame · φ⁻¹ · n⌋ mod n`: the golden-ratio rank rotation of frame `frame` for slices of `n`
/// pixels, in `0..n`. Equivalently `⌊fract(frame · φ⁻¹) · n⌋`, so rotating ranks by it and
/// reading values `(rank + ½)/n` gives `fract(v + frame · φ⁻¹)` rounded down to the rank grid.
///
/// Computed as `f = frame · round(2¹²⁸/φ)` in wrapping `u128` arithmetic (the 0.128 fixed-point
/// fraction, off by at most `frame · 2⁻¹²⁹`) and `⌊f · n / 2¹²⁸⌋` with an exact 192-bit
/// product. φ is badly approximable (`|q·φ⁻¹ − p| > 1/(3q)` for every integer `q > 0`), so for
/// `frame · n < 2⁶⁰` — every `u32` frame of every slice up to 2²⁴ pixels, far beyond what the
/// constant's error could flip — the result equals the exact `⌊frame · n · φ⁻¹⌋ mod n`; the tests
/// check it against an integer-square-root computation. Panics if `n == 0`.
pub fn golden_ratio_rank_shift(frame: u64, n: u64) -> u64 {
    assert!(n > 0, "a slice has at least one pixel");
    let fraction = u128::from(frame).wrapping_mul(PHI_INV_FIXED_128);
    let (high, low) = (fraction >> 64, fraction & u128::from(u64::MAX));
    let n = u128::from(n);
    // fraction · n = high · n · 2⁶⁴ + low · n; the top bits are (high · n + ⌊low · n / 2⁶⁴⌋) / 2⁶⁴.
    ((high * n + ((low * n) >> 64)) >> 64) as u64
}

/// The independent random streams the baselines draw from one seed.
#[derive(Clone, Copy)]
enum Stream {
    White = 1,
    RandomShift = 2,
}

/// ChaCha8 seeded with `seed`, on its own stream for each use.
fn stream(seed: u64, which: Stream) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(which as u64);
    rng
}

/// `width · height · depth` independent uniform values in `[0, 1)` (53 random bits each) from a
/// ChaCha8 stream seeded with `seed`.
pub fn white_noise(width: usize, height: usize, depth: usize, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..width * height * depth)
        .map(|_| rng.random::<f64>())
        .collect()
}

/// One `width × height` slice of 2D blue noise: the values of the one-frame void-and-cluster
/// mask of `MaskSpec::new(width, height, 1, seed)` ([`crate::generate`]), a permutation of
/// `(i + 0.5) / (width · height)`.
///
/// # Errors
/// [`SpecError`] if a size is out of range ([`MaskSpec::validate`]).
pub fn blue_noise_2d(width: u32, height: u32, seed: u64) -> Result<Vec<f64>, SpecError> {
    Ok(generate(&MaskSpec::new(width, height, 1, seed), Observer::default())?.values())
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

/// One field of [`comparison`]: a name, what it is, its values and how long it took.
#[derive(Clone, Debug, PartialEq)]
pub struct Baseline {
    /// [`BaselineKind::name`], or `blue_2d` / `blue_3d` for the topology baselines.
    pub name: &'static str,
    /// A short description for reports.
    pub kind: &'static str,
    /// `width · height · depth` values in `(0, 1)`, index `(z · height + y) · width + x`: the
    /// [`Volume::values`] of the mask.
    pub values: Vec<f64>,
    /// Wall-clock seconds its generation took (the only part of a baseline that varies between
    /// runs).
    pub seconds: f64,
}

/// Every baseline mask a manifest can declare, at `width × height × depth` from `seed`, in this
/// order: `white_noise`, `blue_2d` (independent 2D blue noise per frame,
/// [`EnergyTopology::Independent2D`]), `blue_3d` (isotropic 3D blue noise,
/// [`EnergyTopology::Isotropic3D`]), then `golden_ratio_2d`, `random_shift_2d` and
/// `tellusim_layered` (the masks of [`BaselineSpec::new`]). The topology baselines use
/// [`MaskSpec::new`]'s defaults.
///
/// Cost: dominated by `tellusim_layered` (`O((W·H)² · D)`, about 10 s at 128×128×64) and
/// `blue_3d`.
///
/// # Errors
/// [`SpecError`] if a size is out of range ([`MaskSpec::validate`]).
pub fn comparison(
    width: u32,
    height: u32,
    depth: u32,
    seed: u64,
) -> Result<Vec<Baseline>, SpecError> {
    let spec = |topology| MaskSpec::new(width, height, depth, seed).with_topology(topology);
    let baseline = |kind| {
        let spec = BaselineSpec::new(kind, width, height, depth, seed);
        generate_baseline(&spec, &mut Observer::default())
    };
    let timed = |name, kind, make: &dyn Fn() -> Result<Volume, SpecError>| {
        let start = Instant::now();
        let volume = make()?;
        Ok(Baseline {
            name,
            kind,
            values: volume.values(),
            seconds: start.elapsed().as_secs_f64(),
        })
    };
    let mut set = vec![
        timed(
            BaselineKind::White.name(),
            BaselineKind::White.description(),
            &|| baseline(BaselineKind::White),
        )?,
        timed(
            "blue_2d",
            "baseline: independent 2D blue noise per frame",
            &|| generate(&spec(EnergyTopology::Independent2D), Observer::default()),
        )?,
        timed("blue_3d", "baseline: isotropic 3D blue noise", &|| {
            generate(&spec(EnergyTopology::Isotropic3D), Observer::default())
        })?,
    ];
    for &kind in &BaselineKind::ALL[1..] {
        set.push(timed(kind.name(), kind.description(), &|| baseline(kind))?);
    }
    Ok(set)
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

    /// `fract(v + n · φ⁻¹)` with φ⁻¹ to 128 bits: error `< n · 2⁻¹²⁸ + 2⁻¹²⁸`.
    fn reference(v: f64, n: u64) -> f64 {
        let v = (v * 2f64.powi(64)) as u128;
        let s = (v << 64).wrapping_add((n as u128).wrapping_mul(PHI_INV_FIXED_128));
        (s >> 64) as f64 * 2f64.powi(-64)
    }

    #[test]
    fn fixed_point_constant_is_the_rounded_golden_ratio() {
        assert_eq!(PHI_INV_FIXED, (PHI_INV_FIXED_128 >> 64) as u64 + 1); // the next bit is 1: round up
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
    fn comparison_has_every_baseline_in_full() {
        let set = comparison(8, 4, 3, 5).unwrap();
        let names: Vec<&str> = set.iter().map(|b| b.name).collect();
        assert_eq!(
            names,
            [
                "white_noise",
                "blue_2d",
                "blue_3d",
                "golden_ratio_2d",
                "random_shift_2d",
                "tellusim_layered"
            ]
        );
        assert!(set.iter().all(|b| b.values.len() == 96));
        // Frame 0 of the golden-ratio baseline is its 2D blue-noise slice itself.
        let slice = generate(
            &MaskSpec::new(8, 4, 1, 5).with_topology(EnergyTopology::Independent2D),
            Observer::default(),
        )
        .unwrap()
        .values();
        assert_eq!(&set[3].values[..32], &slice[..]);
        // Equal values on a second run; only the timings differ.
        let again = comparison(8, 4, 3, 5).unwrap();
        assert!(set.iter().zip(&again).all(|(a, b)| a.values == b.values));
    }

    /// `⌊frame · n · φ⁻¹⌋ mod n` exactly: with `a = frame · n`, `⌊a√5⌋ = isqrt(5a²)` and
    /// `⌊a · (√5 − 1)/2⌋ = ⌊(⌊a√5⌋ − a) / 2⌋` (`a√5` is irrational for `a > 0`). Needs `5a² < 2¹²⁸`.
    fn exact_rank_shift(frame: u64, n: u64) -> u64 {
        let a = u128::from(frame) * u128::from(n);
        let root = (5 * a * a).isqrt();
        (((root - a) / 2) % u128::from(n)) as u64
    }

    #[test]
    fn rank_shift_equals_the_integer_square_root_reference() {
        let mut frames: Vec<u64> = vec![
            0,
            1,
            2,
            3,
            63,
            1000,
            1 << 31,
            (1 << 31) + 1,
            u32::MAX as u64,
        ];
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        frames.extend((0..2000).map(|_| rng.random_range(0..1u64 << 32)));
        for n in [1u64, 2, 3, 4096, 12_345, 16_384, 1 << 24] {
            for &frame in &frames {
                assert_eq!(
                    golden_ratio_rank_shift(frame, n),
                    exact_rank_shift(frame, n),
                    "frame {frame}, n {n}"
                );
            }
        }
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
