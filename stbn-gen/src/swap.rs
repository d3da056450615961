//! The swap optimiser of vector masks (paper §4.2, after Georgiev and Fajardo): pixels of one
//! slice exchange values whenever that lowers the mask's energy.
//!
//! # Energy
//!
//! Two pixels `p`, `q` interact when they share a slice (2D toroidal offset `(dx, dy)`) or a
//! position `(x, y)` (toroidal offset `dz` in frames). Their energy is
//!
//! ```text
//! E(p, q) = w(p − q) · exp(−‖Vp − Vq‖^(d/3) / σs²),   w(o) = exp(−‖o‖² / σi²)
//! ```
//!
//! with `d` the number of value components ([`crate::SampleSpace::dims`]) and `‖·‖` the
//! Euclidean norm, also for unit vectors and directions (the chord length `2 sin(angle/2)`, not the
//! angle). The mask's energy is the sum over unordered interacting pairs. Offsets whose weight
//! `exp(−‖o‖²/σi²)` is below `kernel_tolerance` are dropped (the value factor is at most 1, so
//! the pair energy is below it too); every toroidal image of an offset is summed into one weight
//! (so volumes smaller than the footprint stay exact: in a 2-pixel-wide slice the neighbours at
//! `dx = ±1` are the same pixel, with twice the weight), and offsets that wrap onto the pixel
//! itself are left out (a pixel's energy with itself does not change under swaps).
//!
//! # Exact local deltas
//!
//! Swapping `Vp` and `Vq` (same slice) changes only the pairs that contain `p` or `q`. Each pixel
//! keeps its energy `e(p)` (the sum of its pairs' energies; the mask's energy is `½ Σ e(p)`), so
//! a proposal evaluates only the pairs after the swap:
//! `ΔE = Σ_{n ∈ N(p)∖q} w f(‖Vq − Vn‖²) − (e(p) − w_pq f_pq)` plus the same for `q`, the pair
//! `(p, q)` excluded (its energy is symmetric, so the swap leaves it unchanged). A swap is kept
//! only when the delta is below `−margin`, where `margin = 10⁻¹¹ · Σ w` is far above the
//! rounding error of the `f64` sums: every accepted swap lowers the energy. An accepted swap then
//! updates `e` of both pixels and of every neighbour.
//!
//! The value factor `f` is, by definition, what one function computes in single precision from
//! the `f32` values (`value_factor`: a Taylor `exp` and Newton cube roots, within 5·10⁻⁷ of the
//! exact factor); weights and sums are `f64`. Every energy, cached or recomputed, goes through
//! it, so "lowers the energy" is exact for the energy the optimiser reports. It uses basic IEEE
//! operations only (no platform `libm`, so the same bits everywhere) and no branches, so the
//! loops over a footprint vectorise: 16 lanes per instruction on x86-64 CPUs with AVX-512, 8 with
//! AVX2 (detected at run time; the same operations in the same order, so the same bits as the
//! portable SSE2 build, tested).
//!
//! # Schedule
//!
//! A *pass* proposes, in every slice, one swap per pixel: the slice is cut into rectangular tiles
//! (about [`TILE_TARGET`] pixels wide, never less than twice the kernel's reach, at a seeded
//! random offset per pass), and the pixels of a tile propose in a seeded random order. A pixel
//! draws a few other pixels of its tile uniformly (with replacement; one in the first passes, up
//! to [`PARTNER_CANDIDATES`] later, see [`partner_candidates`]) and proposes a swap with the one
//! whose value is nearest its own. Tiles are coloured in
//! a 2 × 2 pattern; the tiles of one colour run in parallel. Two tiles of one colour are separated
//! by a whole tile, at least twice the reach wide, and a tile covers its columns in every slice,
//! so no tile reads a value another one writes, and the neighbour energies two tiles update are
//! distinct: the result is the same for any number of threads. Each tile draws from its own
//! ChaCha8 stream keyed by (seed, pass, tile), and the energy deltas are added in tile order.
//!
//! Why the nearest value of a few candidates: swaps that lower the energy are rare and mostly
//! between similar values. Counted over passes 64–128 of uniform proposals (64×64×32 Vec2), the
//! 4.7% of proposals whose values lay within 0.15 of each other made 77% of the accepted swaps;
//! for UnitVec3 the 5.5% within a chord of 0.5 made about 75%. Proposing the nearest of 16
//! candidates (in tiles of 16 rather than 8 pixels, so there are close values to find; the count
//! ramps up from 1 over the first 30 passes, see [`partner_candidates`]) did in 128 passes (37 s
//! at 128×128×64) what uniform partners did not reach in 1024 (267 s): Vec2 filtered error 0.00835
//! against 0.00845, component 0 spatial low band 0.0152 against 0.0194, energy within 0.02%
//! (BENCHMARKS.md, "Vector masks"). Tried and dropped: a window of neighbours in the Hilbert order
//! of the values (converged faster at first, stalled 0.2% higher), 32 or 64 candidates (no better
//! per pass, slower), partners nearer in space, proposals from the highest-energy pixels, a
//! screen on the nearest taps, and long-range partners.
//!
//! Session 6 looked for a move that shortens the tail, the part a much longer run still gains
//! (BENCHMARKS.md, "Vector masks"). All of these were run on 64×64×32 with seed 1 and throw-away
//! code. None beat the default's energy, or its filtered error, for the same time:
//! - **Partners picked by a linearised delta.** The delta was predicted as
//!   `(∇_a E − ∇_b E)·(vb − va)`, using the analytic gradient of every pixel's energy. The
//!   prediction correlates with the exact delta (r = 0.82). But it picked improving swaps no
//!   more often than the nearest value did. After 128 passes, out of the same 16 candidates:
//!   1.17% of proposals improved against 1.14%. Even the best of the 16 by exact delta improved
//!   only 1.26%. After 1024 passes the three were 0.13%, 0.13% and 0.14%. Improving swaps are
//!   scarce, not hidden among the candidates.
//! - **The nearest value in the whole tile.** After 128 passes, 17% of pixels have an improving
//!   partner somewhere in their 16 × 16 tile. 49% of those partners hold the value nearest the
//!   pixel's own, and 86% are among its 4 nearest. So, from pass 40 on, each proposal went to
//!   the nearest value of the tile, found by scanning it. At 128 passes this took 12.6 s
//!   against 5.5 s. Energy per pixel was 3.275579 against 3.275569 (Vec2) and 1.599803 against
//!   1.600739 (UnitVec3). Filtered error was 0.00839 against 0.00847 (Vec2) and 0.00940 against
//!   0.00946 (UnitVec3). The default's 256 passes took less time, 9.4 s, and did better still:
//!   3.273994 and 0.00837 (Vec2), 1.597559 and 0.00935 (UnitVec3).
//! - **A coarse phase first.** 16 or 32 passes at σi 2.7 or 3.5, which weights lower
//!   frequencies, then σi 1.9 for the rest of 128 passes. Filtered error stayed at 0.00846–0.00848
//!   (Vec2) and 0.00946–0.00950 (UnitVec3), the default's within noise. The energy per pixel
//!   ended higher: 3.27619–3.27645 against 3.27557.
//!
//! # Assignment passes
//!
//! [`crate::VectorSpec::assignment_passes`] of them (12 by default since GENERATOR_VERSION 4) run
//! after the swap passes. A move re-assigns the
//! values of up to [`ASSIGNMENT_SET`] pixels of one slice at once. The pixels hold similar
//! values and do not interact with each other (no offset between two of them is a tap), so
//! permuting their values changes the energy by `Σ_i c(p_i, v_π(i)) − Σ_i c(p_i, v_i)`, where
//! `c(p, v) = Σ_{n ∈ N(p)} w f(‖v − Vn‖²)`: the pixels' neighbours stay fixed, so the terms
//! separate, and the best of all k! permutations is a linear assignment problem, solved exactly
//! by the Hungarian method in O(k³) (`min_cost_assignment`). A pair swap is the case k = 2.
//! The best permutation is kept if it lowers the energy by more than `k` margins; the pixel
//! energies are updated as for a swap. Tiles are [`ASSIGNMENT_TILE_TARGET`] pixels wide and
//! coloured as for swaps, so the passes are deterministic for any thread count (tested).
//!
//! Why: after 128 swap passes (the default then), improving swaps are scarce (above), but
//! improving permutations of similar values are not. A session-6 probe (64×64×32, seed 1, f64 code,
//! cost counted in `c(p, v)` evaluations, two per swap proposal) reached the energy of the
//! default's next 128 swap passes for the cost of 32–40. In 16-pixel tiles the sets found few
//! similar values (16 passes: Vec2 energy per pixel 3.274653); in 32-pixel tiles, 3.272816,
//! below the 3.273994 of 128 more swap passes (BENCHMARKS.md, "Vector masks", has the
//! 128×128×64 figures). Session 7 measured how to split a budget between the two moves: 64 swap
//! passes first and then assignment passes did best for the time (BENCHMARKS.md, "Assignment
//! passes").

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering::Relaxed};

use rand::seq::SliceRandom;
use rand::{Rng, RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use crate::vector::{TracePoint, VectorSpec};

/// Preferred tile side in pixels (tiles are never narrower than twice the kernel's reach): 16
/// gives [`PARTNER_CANDIDATES`] 255 pixels to choose from and still 4 tiles per colour at
/// 64 × 64, enough for the two cores here.
pub const TILE_TARGET: u32 = 16;

/// Candidates a proposing pixel draws from its tile once the optimiser is under way; it proposes
/// the one whose value is nearest its own ([module docs](self)). Pass `p` draws
/// `min(1 + p / 2, PARTNER_CANDIDATES)` ([`partner_candidates`]): a uniform partner first.
pub const PARTNER_CANDIDATES: u32 = 16;

/// The candidates pass `pass` draws per proposal: one more every two passes, up to `cap`.
///
/// Early passes make the large moves a poor start needs, later ones the fine ones. From white
/// noise (32×32×16 Vec1, 16 passes) 16 candidates from the first pass left the spatial low band
/// at 0.397 against 0.071 for uniform partners; the ramp reached 0.069. From the default start it
/// also ends lower than 16 from the first pass (64×64×32, 128 passes: Vec2 3.27557 against
/// 3.27619, UnitVec3 1.60074 against 1.60173).
pub fn partner_candidates(pass: u64, cap: u32) -> u32 {
    (1 + pass / 2).min(u64::from(cap.max(1))) as u32
}

/// Partial sums of [`lane_sum`] (`f64` lanes of an AVX2 register).
const LANES: usize = 4;

/// Padding of the neighbour buffers: the value factor loop runs whole chunks of this many
/// entries (`f32` lanes of an AVX-512 register, two AVX2 ones).
const FACTOR_LANES: usize = 16;

/// Domain tags that keep the random streams of one seed apart.
pub(crate) mod stream {
    /// Initial stratified values, one stream per slice.
    pub const INIT: u64 = 1;
    /// Tile grid offsets of a pass.
    pub const GRID: u64 = 2;
    /// Swap proposals of one tile of one pass.
    pub const TILE: u64 = 3;
}

/// A ChaCha8 generator keyed by `(seed, domain, a, b)`: distinct keys give independent streams.
pub(crate) fn keyed_rng(seed: u64, domain: u64, a: u64, b: u64) -> ChaCha8Rng {
    let mut key = [0u8; 32];
    for (chunk, word) in key.chunks_exact_mut(8).zip([seed, domain, a, b]) {
        chunk.copy_from_slice(&word.to_le_bytes());
    }
    ChaCha8Rng::from_seed(key)
}

/// `e^−x` for `x ≥ 0` (`+∞` allowed), to within a few units in the last place; results below
/// `e^−708` come out as `e^−708` (≈ 3·10⁻³⁰⁸). Basic IEEE operations only, so bit-identical on
/// every platform, and branch-free, so loops over it vectorise.
#[inline(always)]
pub fn exp_neg(x: f64) -> f64 {
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

/// `e^−x` in single precision for `x ≥ 0` (`+∞` allowed), relative error below 2·10⁻⁷; results
/// below `e^−87` come out as `e^−87` (≈ 1.6·10⁻³⁸). [`exp_neg`]'s method in `f32`: a Taylor
/// polynomial of degree 7 on the reduced argument `|t| ≤ ln2/2` (truncation 6·10⁻⁹).
#[inline(always)]
fn exp_neg_f32(x: f32) -> f32 {
    const LOG2_E: f32 = std::f32::consts::LOG2_E;
    // ln 2 split so that k · LN2_HI is exact for |k| < 2^8.
    const LN2_HI: f32 = 0.693_359_4;
    const LN2_LO: f32 = -2.121_944_4e-4;
    // 1.5 · 2^23: adding it rounds to an integer held in the low mantissa bits.
    const ROUND: f32 = 12_582_912.0;
    let x = x.min(87.0);
    let shifted = x * LOG2_E + ROUND;
    let k = shifted - ROUND;
    let t = -((x - k * LN2_HI) - k * LN2_LO);
    let mut p = 1.0 / 5_040.0;
    p = p * t + 1.0 / 720.0;
    p = p * t + 1.0 / 120.0;
    p = p * t + 1.0 / 24.0;
    p = p * t + 1.0 / 6.0;
    p = p * t + 0.5;
    p = p * t + 1.0;
    p = p * t + 1.0;
    // 2^−k from the integer in the low bits of `shifted` (0 ≤ k ≤ 126).
    let k_int = shifted.to_bits() & 0xff;
    p * f32::from_bits((127 - k_int) << 23)
}

/// `s^(−1/3)` in single precision for `s > 0` (huge but finite for `s = 0`), relative error
/// below 3·10⁻⁷. A first guess from the bits of `s` (off by at most 3.5%), then three steps of
/// Newton's iteration `r ← r (4 − s r³) / 3` (error `e ↦ 2e²`: 3.5% → 2.4·10⁻³ → 1.2·10⁻⁵ →
/// rounding).
#[inline(always)]
fn inverse_cbrt_f32(s: f32) -> f32 {
    // The exponent field of s^(−1/3) is about (4/3)·127 − bits(s)/3 (in units of 2^23), with the
    // division by 3 as a widening multiply.
    let third = ((u64::from(s.to_bits()) * 0xAAAA_AAAB) >> 33) as u32;
    let mut r = f32::from_bits(0x54a2_32abu32.wrapping_sub(third));
    for _ in 0..3 {
        let sr3 = ((s * r) * r) * r;
        r = r * (4.0 - sr3) * (1.0 / 3.0);
    }
    r
}

/// `‖v‖^(D/3)` of a vector with squared norm `s`, for `D` value components, in single precision.
#[inline(always)]
fn distance_power<const D: usize>(s: f32) -> f32 {
    match D {
        // s^(1/6) = √s · s^(−1/3)
        1 => s.sqrt() * inverse_cbrt_f32(s),
        // s^(1/3) = s · (s^(−1/3))²
        2 => {
            let r = inverse_cbrt_f32(s);
            (s * r) * r
        }
        3 => s.sqrt(),
        // s^(2/3) = s · s^(−1/3)
        _ => s * inverse_cbrt_f32(s),
    }
}

/// The value factor `exp(−x)`, `x = ‖a − b‖^(D/3) / σs²`, from `s = ‖a − b‖²` (computed in `f32`
/// from the `f32` values, components in order), to a relative `5·10⁻⁷ · max(1, x)`.
///
/// This function *is* the energy's value term: every energy, cached or recomputed, goes through
/// it, so they agree to the rounding of the `f64` sums. Single precision evaluates 8 lanes per
/// AVX2 instruction instead of 4; together with the shorter polynomial that made the optimiser
/// about 1.4× faster than an `f64` version with a degree-9 polynomial (64×64×32 Vec2, 16 swaps
/// per pixel, AVX2, two runs each: 0.61–0.64 s against 0.88–0.89 s; `f64` with [`exp_neg`]'s
/// degree 12 and four Newton steps took 1.06 s).
#[inline(always)]
fn value_factor<const D: usize>(s: f32, inv_sigma_value_sq: f32) -> f32 {
    exp_neg_f32(distance_power::<D>(s) * inv_sigma_value_sq)
}

/// The representative of `offset mod size` in `(−size/2, size/2]`.
fn canonical(offset: i64, size: u32) -> i32 {
    let size = i64::from(size);
    let wrapped = offset.rem_euclid(size);
    (if wrapped > size / 2 {
        wrapped - size
    } else {
        wrapped
    }) as i32
}

/// The truncated, folded pair weights of one [`VectorSpec`] and the value factor's parameters.
#[derive(Clone, Debug)]
pub struct SwapKernel {
    width: u32,
    height: u32,
    depth: u32,
    dims: usize,
    /// Same-slice neighbours: canonical `(dx, dy)` (never `(0, 0)`), weight.
    spatial: Vec<(i32, i32, f64)>,
    /// `dy · width + dx` of each spatial tap, for pixels away from the slice edges.
    spatial_step: Vec<isize>,
    /// Same-position neighbours: canonical `dz` (never 0), weight.
    temporal: Vec<(i32, f64)>,
    /// Per slice `z`, the index step to each temporal neighbour (`slice_pixels · (z' − z)`).
    temporal_step: Vec<Vec<isize>>,
    /// Extremes of the spatial taps' `dx` and `dy`.
    dx_range: (i32, i32),
    dy_range: (i32, i32),
    /// The spatial tap of each offset in those ranges (row `dy`, column `dx`), `u32::MAX` where
    /// there is none.
    tap_at_offset: Vec<u32>,
    /// `1/σs²` in single precision, as [`value_factor`] takes it.
    inv_sigma_value_sq: f32,
    /// Deltas must be below `−margin` for a swap to be accepted.
    margin: f64,
}

impl SwapKernel {
    /// The kernel of a [validated](VectorSpec::validate) spec.
    pub fn new(spec: &VectorSpec) -> SwapKernel {
        let (w, h, d) = (spec.width, spec.height, spec.depth);
        let tol = spec.kernel_tolerance;
        let inv_si = 1.0 / (spec.sigma_image * spec.sigma_image);
        // exp(−r²/σi²) ≥ tol ⇔ r ≤ σi √ln(1/tol); enumerate one pixel further and let exp_neg
        // decide, at most two periods per axis.
        let bound = (spec.sigma_image * (1.0 / tol).ln().sqrt()).ceil() + 1.0;
        let reach = |size: u32| -> i64 {
            let cap = 2 * i64::from(size);
            if bound >= cap as f64 {
                cap
            } else {
                bound as i64
            }
        };
        let (rx, ry, rz) = (reach(w), reach(h), reach(d));
        let weight = |r2: i64| {
            let e = exp_neg(r2 as f64 * inv_si);
            (e >= tol).then_some(e)
        };
        let mut spatial: BTreeMap<(i32, i32), f64> = BTreeMap::new();
        for dy in -ry..=ry {
            for dx in -rx..=rx {
                if let Some(e) = weight(dx * dx + dy * dy) {
                    let key = (canonical(dx, w), canonical(dy, h));
                    if key != (0, 0) {
                        *spatial.entry(key).or_insert(0.0) += e;
                    }
                }
            }
        }
        let mut temporal: BTreeMap<i32, f64> = BTreeMap::new();
        for dz in -rz..=rz {
            if let Some(e) = weight(dz * dz) {
                let key = canonical(dz, d);
                if key != 0 {
                    *temporal.entry(key).or_insert(0.0) += e;
                }
            }
        }
        let spatial: Vec<(i32, i32, f64)> = spatial
            .into_iter()
            .map(|((dx, dy), e)| (dx, dy, e))
            .collect();
        let temporal: Vec<(i32, f64)> = temporal.into_iter().collect();
        let slice = w as isize * h as isize;
        let spatial_step = spatial
            .iter()
            .map(|&(dx, dy, _)| dy as isize * w as isize + dx as isize)
            .collect();
        let temporal_step = (0..d as i64)
            .map(|z| {
                temporal
                    .iter()
                    .map(|&(dz, _)| {
                        ((z + i64::from(dz)).rem_euclid(i64::from(d)) - z) as isize * slice
                    })
                    .collect()
            })
            .collect();
        let range = |f: fn(&(i32, i32, f64)) -> i32| {
            let it = || spatial.iter().map(f);
            (it().min().unwrap_or(0), it().max().unwrap_or(0))
        };
        let total: f64 =
            spatial.iter().map(|t| t.2).sum::<f64>() + temporal.iter().map(|t| t.1).sum::<f64>();
        let (dx_range, dy_range) = (range(|t| t.0), range(|t| t.1));
        let columns = (dx_range.1 - dx_range.0 + 1) as usize;
        let mut tap_at_offset = vec![u32::MAX; columns * (dy_range.1 - dy_range.0 + 1) as usize];
        for (k, &(dx, dy, _)) in spatial.iter().enumerate() {
            let cell = (dy - dy_range.0) as usize * columns + (dx - dx_range.0) as usize;
            tap_at_offset[cell] = k as u32;
        }
        SwapKernel {
            width: w,
            height: h,
            depth: d,
            dims: spec.space.dims(),
            dx_range,
            dy_range,
            tap_at_offset,
            spatial_step,
            temporal_step,
            spatial,
            temporal,
            inv_sigma_value_sq: (1.0 / (spec.sigma_value * spec.sigma_value)) as f32,
            margin: 1e-11 * total,
        }
    }

    /// Same-slice neighbours of a pixel (distinct pixels, itself excluded).
    pub fn spatial_taps(&self) -> usize {
        self.spatial.len()
    }

    /// Same-position neighbours of a pixel in other slices.
    pub fn temporal_taps(&self) -> usize {
        self.temporal.len()
    }

    /// Largest `|dx|` and `|dy|` of a spatial tap, in pixels.
    pub fn reach(&self) -> (u32, u32) {
        (
            self.dx_range
                .0
                .unsigned_abs()
                .max(self.dx_range.1.unsigned_abs()),
            self.dy_range
                .0
                .unsigned_abs()
                .max(self.dy_range.1.unsigned_abs()),
        )
    }

    fn slice_pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// The mask's energy computed from scratch: `½ Σ_p e(p)` over the
    /// [pixel energies](SwapKernel::pixel_energies), summed per slice in parallel and then in
    /// slice order (deterministic).
    ///
    /// Panics if `values.len()` is not `width · height · depth · dims`.
    pub fn energy(&self, values: &[f32]) -> f64 {
        let slice = self.slice_pixels();
        let per_slice: Vec<f64> = self
            .pixel_energies(values)
            .par_chunks(slice)
            .map(|e| e.iter().sum::<f64>())
            .collect();
        0.5 * per_slice.iter().sum::<f64>()
    }

    /// Every pixel's energy from scratch: `e(p) = Σ_neighbours w · value factor`, index
    /// `(z · height + y) · width + x`. Each pair's energy appears in both its pixels' energies.
    ///
    /// Panics if `values.len()` is not `width · height · depth · dims`.
    pub fn pixel_energies(&self, values: &[f32]) -> Vec<f64> {
        assert_eq!(
            values.len(),
            self.slice_pixels() * self.depth as usize * self.dims,
            "value count must match the size"
        );
        match self.dims {
            1 => self.pixel_energies_d::<1>(values),
            2 => self.pixel_energies_d::<2>(values),
            3 => self.pixel_energies_d::<3>(values),
            _ => self.pixel_energies_d::<4>(values),
        }
    }

    fn pixel_energies_d<const D: usize>(&self, values: &[f32]) -> Vec<f64> {
        let (w, h) = (self.width as i64, self.height as i64);
        let slice = self.slice_pixels();
        let value = |i: usize| -> [f32; D] { std::array::from_fn(|c| values[i * D + c]) };
        let mut energies = vec![0.0; slice * self.depth as usize];
        energies
            .par_chunks_mut(slice)
            .enumerate()
            .for_each(|(z, out)| {
                for y in 0..h {
                    for x in 0..w {
                        let p = z * slice + (y * w + x) as usize;
                        let vp = value(p);
                        let pair = |n: usize| {
                            let vn = value(n);
                            f64::from(value_factor::<D>(
                                squared_distance(&vp, &vn),
                                self.inv_sigma_value_sq,
                            ))
                        };
                        let mut sum = 0.0;
                        for &(dx, dy, wt) in &self.spatial {
                            let nx = (x + i64::from(dx)).rem_euclid(w);
                            let ny = (y + i64::from(dy)).rem_euclid(h);
                            sum += wt * pair(z * slice + (ny * w + nx) as usize);
                        }
                        for (&(_, wt), &step) in self.temporal.iter().zip(&self.temporal_step[z]) {
                            sum += wt * pair((p as isize + step) as usize);
                        }
                        out[(y * w + x) as usize] = sum;
                    }
                }
            });
        energies
    }
}

/// Per-task buffers of one swap evaluation of pixels `a` and `b`: one entry per neighbour tap of
/// either pixel (`a`'s taps first, then `b`'s, each in the kernel's tap order), padded with
/// zeros to whole [`FACTOR_LANES`].
///
/// A proposal only fills `after`; the neighbours' indices and `before` are gathered again by
/// [`SwapKernel::apply`] for the few proposals that are accepted.
struct Scratch {
    /// The neighbour's index (filled by `apply`).
    index: Vec<usize>,
    /// Pair weight of each tap (the kernel's, the same for every pixel); 0 in the padding.
    weight: Vec<f64>,
    /// Squared distance from the neighbour's value to its centre's value before and after the
    /// swap (for `a`'s neighbours `‖va − n‖²` and `‖vb − n‖²`; for `b`'s the other way round).
    before: Vec<f32>,
    after: Vec<f32>,
    /// Value factors of `before` or `after` (computed 8 or 16 lanes wide); 0 for the pair
    /// `(a, b)`.
    factor: Vec<f32>,
    /// `weight · value factor` after the swap, then the change of the neighbour's energy.
    term: Vec<f64>,
    /// Taps of one pixel (`a`'s entries are `..taps`); all entries (the buffers hold that many
    /// rounded up to whole lanes).
    taps: usize,
    len: usize,
    /// The entries of the pair `(a, b)` (`b` among `a`'s taps, `a` among `b`'s), if they
    /// interact, and the pair's energy `w_ab f_ab` (0 if not), which the swap leaves unchanged.
    pair: Option<(usize, usize)>,
    pair_energy: f64,
}

impl Scratch {
    fn new(kernel: &SwapKernel) -> Scratch {
        let taps = kernel.spatial.len() + kernel.temporal.len();
        let len = 2 * taps;
        let padded = len.div_ceil(FACTOR_LANES) * FACTOR_LANES;
        let mut weight: Vec<f64> = kernel
            .spatial
            .iter()
            .map(|t| t.2)
            .chain(kernel.temporal.iter().map(|t| t.1))
            .collect();
        weight.extend_from_within(..);
        weight.resize(padded, 0.0);
        Scratch {
            index: vec![0; padded],
            weight,
            before: vec![0.0; padded],
            after: vec![0.0; padded],
            factor: vec![0.0; padded],
            term: vec![0.0; padded],
            taps,
            len,
            pair: None,
            pair_energy: 0.0,
        }
    }

    /// Sets the value factors of the pair `(a, b)` to 0: its energy is the same before and after
    /// the swap, so it stays out of both pixels' sums.
    #[inline(always)]
    fn drop_pair_factors(&mut self) {
        if let Some((ka, kb)) = self.pair {
            self.factor[ka] = 0.0;
            self.factor[kb] = 0.0;
        }
    }

    /// `term = weight · factor` over every entry, padding included.
    #[inline(always)]
    fn weigh(&mut self) {
        let entries = self.weight.iter().zip(&self.factor);
        for (term, (&w, &f)) in self.term.iter_mut().zip(entries) {
            *term = w * f64::from(f);
        }
    }
}

/// The values and pixel energies the tiles share (see the [module docs](self)).
///
/// Invariant (what [`Shared::value`]'s plain reads rely on): no pixel is written by one thread
/// while another reads or writes it. The tile colouring guarantees it during a pass; anything
/// that runs tiles concurrently must keep it. Writes are relaxed atomic stores (plain stores
/// once compiled), which make that sharing expressible; the hot reads of values are plain
/// loads.
struct Shared<'s> {
    /// `f32` bits, index `pixel · dims + c`.
    values: &'s [AtomicU32],
    /// `f64` bits of each pixel's energy `e(p)`.
    energy: &'s [AtomicU64],
}

impl Shared<'_> {
    /// The value of `pixel`, read with plain (not atomic) loads: atomic ones, even relaxed,
    /// keep the compiler from unrolling and scheduling the optimiser's hot loops. Plain loads
    /// made whole runs 4–12% faster (64×64×32, 32 swaps/px, one thread, AVX-512, eight
    /// alternating runs, medians: Vec2 2.25 → 2.15 s, UnitVec3 2.15 → 1.9 s; the VM's speed
    /// drifts from one set of runs to the next, so compare figures within a set only).
    #[inline(always)]
    fn value<const D: usize>(&self, pixel: usize) -> [f32; D] {
        std::array::from_fn(|c| {
            let bits = self.values[pixel * D + c].as_ptr();
            // SAFETY: `bits` points to a live `u32` (a bounds-checked element). No other thread
            // writes it now. In a pass, a tile reads only its own pixels and their neighbours,
            // which the tile colouring (module docs, `tiles_along`) keeps away from every pixel
            // another tile of its colour writes, and the colour phases are joined one after the
            // other. Outside passes (`swap_delta`, `try_swap`) the `Shared` is built from
            // `&self` or `&mut self`, so no other thread holds the values. A plain read that
            // races with no write is defined, even though the writes are atomic.
            f32::from_bits(unsafe { bits.read() })
        })
    }

    #[inline(always)]
    fn swap_values<const D: usize>(&self, a: usize, b: usize) {
        for c in 0..D {
            let (ia, ib) = (a * D + c, b * D + c);
            let va = self.values[ia].load(Relaxed);
            self.values[ia].store(self.values[ib].load(Relaxed), Relaxed);
            self.values[ib].store(va, Relaxed);
        }
    }

    #[inline(always)]
    fn energy(&self, pixel: usize) -> f64 {
        f64::from_bits(self.energy[pixel].load(Relaxed))
    }

    #[inline(always)]
    fn set_energy(&self, pixel: usize, e: f64) {
        self.energy[pixel].store(e.to_bits(), Relaxed);
    }
}

/// `Σ x` with four interleaved partial sums (a fixed order: deterministic).
#[inline(always)]
fn lane_sum(x: &[f64]) -> f64 {
    let mut lanes = [0.0f64; LANES];
    let chunks = x.chunks_exact(LANES);
    let rest = chunks.remainder();
    for chunk in chunks {
        for (lane, &t) in lanes.iter_mut().zip(chunk) {
            *lane += t;
        }
    }
    rest.iter()
        .fold((lanes[0] + lanes[1]) + (lanes[2] + lanes[3]), |s, &t| s + t)
}

/// `‖a − b‖²` in single precision, components in order: the value distance every energy uses
/// (`(a − b)² = (b − a)²` exactly, so it is symmetric).
#[inline(always)]
fn squared_distance<const D: usize>(a: &[f32; D], b: &[f32; D]) -> f32 {
    let mut s = 0.0;
    for c in 0..D {
        s += (a[c] - b[c]) * (a[c] - b[c]);
    }
    s
}

/// `factor[k] = value_factor(distance[k])` over whole chunks of [`FACTOR_LANES`] (the buffers
/// are padded), so the loop runs one AVX-512 instruction per 16 entries, or AVX2 per 8.
#[inline(always)]
fn value_factors<const D: usize>(distance: &[f32], factor: &mut [f32], inv_sigma_value_sq: f32) {
    for (f, &s) in factor.iter_mut().zip(distance) {
        *f = value_factor::<D>(s, inv_sigma_value_sq);
    }
}

impl SwapKernel {
    /// Whether every spatial tap of pixel `(x, y)` lies inside the slice without wrapping.
    #[inline(always)]
    fn is_interior(&self, x: u32, y: u32) -> bool {
        let (xi, yi) = (x as i32, y as i32);
        xi + self.dx_range.0 >= 0
            && xi + self.dx_range.1 < self.width as i32
            && yi + self.dy_range.0 >= 0
            && yi + self.dy_range.1 < self.height as i32
    }

    /// Calls `visit(k, n)` for each neighbour `n` of pixel `(x, y)` of slice `z` (index
    /// `centre`), `k` its tap number: the spatial taps in the kernel's order, then the temporal
    /// ones.
    #[inline(always)]
    fn for_each_neighbour(
        &self,
        (x, y, z): (u32, u32, u32),
        centre: usize,
        mut visit: impl FnMut(usize, usize),
    ) {
        if self.is_interior(x, y) {
            for (k, &step) in self.spatial_step.iter().enumerate() {
                visit(k, (centre as isize + step) as usize);
            }
        } else {
            let wrap = |t: i32, size: i32| {
                if t < 0 {
                    t + size
                } else if t >= size {
                    t - size
                } else {
                    t
                }
            };
            let (xi, yi) = (x as i32, y as i32);
            let (w, h) = (self.width as i32, self.height as i32);
            let row0 = centre - (y as usize * self.width as usize + x as usize);
            for (k, &(dx, dy, _)) in self.spatial.iter().enumerate() {
                let nx = wrap(xi + dx, w) as usize;
                let ny = wrap(yi + dy, h) as usize;
                visit(k, row0 + ny * self.width as usize + nx);
            }
        }
        let first = self.spatial.len();
        for (k, &step) in self.temporal_step[z as usize].iter().enumerate() {
            visit(first + k, (centre as isize + step) as usize);
        }
    }

    /// `out[k] = ‖value − Vn‖²` for each neighbour `n` (tap `k`) of pixel `(x, y)` of slice `z`:
    /// [`SwapKernel::for_each_neighbour`]'s taps in its order (tested), with the interior case
    /// written out, which the compiler turns into a tighter loop than the closure (64×64×32, 32
    /// swaps per pixel, one thread, six alternating runs, medians: Vec2 2.3 s against 2.55 s).
    #[inline(always)]
    fn gather<const D: usize>(
        &self,
        shared: &Shared,
        at: (u32, u32, u32),
        centre: usize,
        value: &[f32; D],
        out: &mut [f32],
    ) {
        let (x, y, z) = at;
        if self.is_interior(x, y) {
            for (o, &step) in out.iter_mut().zip(&self.spatial_step) {
                let n = centre.wrapping_add_signed(step);
                *o = squared_distance(value, &shared.value::<D>(n));
            }
            let first = self.spatial.len();
            for (k, &step) in self.temporal_step[z as usize].iter().enumerate() {
                let n = centre.wrapping_add_signed(step);
                out[first + k] = squared_distance(value, &shared.value::<D>(n));
            }
            return;
        }
        self.for_each_neighbour(at, centre, |k, n| {
            out[k] = squared_distance(value, &shared.value::<D>(n));
        });
    }

    /// The spatial tap from pixel `from` to pixel `to` of the same slice, if they interact.
    #[inline(always)]
    fn spatial_tap(&self, from: (u32, u32), to: (u32, u32)) -> Option<usize> {
        let dx = canonical(i64::from(to.0) - i64::from(from.0), self.width);
        let dy = canonical(i64::from(to.1) - i64::from(from.1), self.height);
        let ((x0, x1), (y0, y1)) = (self.dx_range, self.dy_range);
        if dx < x0 || dx > x1 || dy < y0 || dy > y1 {
            return None;
        }
        let cell = (dy - y0) as usize * (x1 - x0 + 1) as usize + (dx - x0) as usize;
        let tap = self.tap_at_offset[cell];
        (tap != u32::MAX).then_some(tap as usize)
    }

    /// The exact energy change of swapping the values of pixels `a` and `b` of slice `z`, from
    /// the cached energies `e(a)`, `e(b)` and the pair energies after the swap. Leaves in
    /// `scratch` what [`SwapKernel::apply`] needs. Returns the delta and the two indices.
    ///
    /// `ΔE = Σ_{n ∈ N(a)∖b} w f(‖vb − vn‖²) − (e(a) − w_ab f_ab)` plus the same for `b`: the
    /// pairs of `a` and of `b` change, except the pair `(a, b)` (energy `w_ab f_ab`, symmetric).
    #[inline(always)]
    fn delta<const D: usize>(
        &self,
        shared: &Shared,
        z: u32,
        a: (u32, u32),
        b: (u32, u32),
        scratch: &mut Scratch,
    ) -> (f64, usize, usize) {
        let base = z as usize * self.slice_pixels();
        let ia = base + a.1 as usize * self.width as usize + a.0 as usize;
        let ib = base + b.1 as usize * self.width as usize + b.0 as usize;
        let va = shared.value::<D>(ia);
        let vb = shared.value::<D>(ib);
        if ia == ib || va == vb {
            return (0.0, ia, ib);
        }
        let taps = scratch.taps;
        let (after_a, after_b) = scratch.after.split_at_mut(taps);
        self.gather::<D>(shared, (a.0, a.1, z), ia, &vb, after_a);
        self.gather::<D>(shared, (b.0, b.1, z), ib, &va, after_b);
        let inv = self.inv_sigma_value_sq;
        value_factors::<D>(&scratch.after, &mut scratch.factor, inv);
        scratch.pair = self
            .spatial_tap(a, b)
            .zip(self.spatial_tap(b, a))
            .map(|(ka, kb)| (ka, taps + kb));
        scratch.drop_pair_factors();
        scratch.weigh();
        let after = lane_sum(&scratch.term[..scratch.len]);
        scratch.pair_energy = match scratch.pair {
            Some((_, kb)) => {
                scratch.weight[kb] * f64::from(value_factor::<D>(squared_distance(&va, &vb), inv))
            }
            None => 0.0,
        };
        let delta = after - (shared.energy(ia) + shared.energy(ib)) + 2.0 * scratch.pair_energy;
        (delta, ia, ib)
    }

    /// Performs the swap of pixels `a` and `b` of slice `z` (indices `ia`, `ib`) that
    /// [`SwapKernel::delta`] just evaluated (with `scratch` as it left it): swaps the values and
    /// updates the energies of `a`, `b` and every neighbour.
    #[inline(always)]
    fn apply<const D: usize>(
        &self,
        shared: &Shared,
        z: u32,
        (a, b): ((u32, u32), (u32, u32)),
        (ia, ib): (usize, usize),
        scratch: &mut Scratch,
    ) {
        let (taps, count) = (scratch.taps, scratch.len);
        let e_a = lane_sum(&scratch.term[..taps]);
        let e_b = lane_sum(&scratch.term[taps..count]);
        let (va, vb) = (shared.value::<D>(ia), shared.value::<D>(ib));
        for (centre, at, value, first) in [(ia, a, &va, 0), (ib, b, &vb, taps)] {
            let (index, before) = (&mut scratch.index, &mut scratch.before);
            self.for_each_neighbour((at.0, at.1, z), centre, |k, n| {
                index[first + k] = n;
                before[first + k] = squared_distance(value, &shared.value::<D>(n));
            });
        }
        value_factors::<D>(
            &scratch.before,
            &mut scratch.factor,
            self.inv_sigma_value_sq,
        );
        scratch.drop_pair_factors();
        let entries = scratch.weight.iter().zip(&scratch.factor);
        for (term, (&w, &f)) in scratch.term.iter_mut().zip(entries) {
            *term -= w * f64::from(f);
        }
        let (ka, kb) = scratch.pair.unwrap_or((usize::MAX, usize::MAX));
        for k in 0..count {
            if k != ka && k != kb {
                let n = scratch.index[k];
                shared.set_energy(n, shared.energy(n) + scratch.term[k]);
            }
        }
        shared.set_energy(ia, e_a + scratch.pair_energy);
        shared.set_energy(ib, e_b + scratch.pair_energy);
        shared.swap_values::<D>(ia, ib);
    }

    /// Swaps `a` and `b` of slice `z` if that lowers the energy by more than the margin; returns
    /// the (negative) delta of an accepted swap.
    #[inline(always)]
    fn attempt<const D: usize>(
        &self,
        shared: &Shared,
        z: u32,
        a: (u32, u32),
        b: (u32, u32),
        scratch: &mut Scratch,
    ) -> Option<f64> {
        let (delta, ia, ib) = self.delta::<D>(shared, z, a, b, scratch);
        if delta < -self.margin {
            self.apply::<D>(shared, z, (a, b), (ia, ib), scratch);
            Some(delta)
        } else {
            None
        }
    }
}

/// One tile of a pass: columns `x0..x0 + w` and rows `y0..y0 + h` (both mod the slice size) in
/// every slice.
#[derive(Clone, Copy, Debug)]
struct Tile {
    x0: u32,
    y0: u32,
    w: u32,
    h: u32,
    colour: u8,
    id: u64,
}

impl Tile {
    /// Pixel `i` of the tile (row by row), as `(x, y)` in a `width × height` slice.
    #[inline(always)]
    fn pixel(&self, i: u32, width: u32, height: u32) -> (u32, u32) {
        (
            (self.x0 + i % self.w) % width,
            (self.y0 + i / self.w) % height,
        )
    }

    /// Each tile pixel's index within its `width × height` slice, in [`Tile::pixel`]'s order.
    fn slice_indices(&self, width: u32, height: u32) -> Vec<usize> {
        (0..self.w * self.h)
            .map(|i| {
                let (x, y) = self.pixel(i, width, height);
                y as usize * width as usize + x as usize
            })
            .collect()
    }
}

/// A uniform index in `0..n` other than `i` (`n ≥ 2`), from one `u32` of `rng` (multiply-shift,
/// bias below 2⁻¹⁶ for the tile sizes here). Shared with the filter-adapted optimiser, whose
/// partners are drawn the same way.
#[inline(always)]
pub(crate) fn other_index(rng: &mut ChaCha8Rng, i: u32, n: u32) -> u32 {
    let j = ((u64::from(rng.next_u32()) * u64::from(n - 1)) >> 32) as u32;
    if j >= i { j + 1 } else { j }
}

/// Tiles along an axis of `size` pixels: an even count whose tiles are all at least `2 · reach`
/// wide, near `size / target`; 1 when the axis is too short for two. Two tiles of one colour are
/// then separated by more than twice the reach: neither reads a pixel the other writes, and the
/// neighbours whose energies they update (within the reach of a swapped pixel) are distinct.
/// Shared with the filter-adapted optimiser, whose tiles follow the same rule.
pub(crate) fn tiles_along(size: u32, reach: u32, target: u32) -> u32 {
    let max_tiles = size / (2 * reach).max(1);
    let want = (size / target.max(1)).max(2).min(max_tiles);
    if want >= 2 { want & !1 } else { 1 }
}

/// What every tile of one pass needs besides its own coordinates.
struct PassPlan {
    seed: u64,
    pass: u64,
    /// Share of each tile's pixels that propose, in `[0, 1]`.
    fraction: f64,
    /// Candidates per proposal in this pass ([`partner_candidates`]).
    partner_candidates: u32,
    /// 0 for a swap pass; `k ≥ 2` for an assignment pass over sets of `k` pixels.
    assignment: u32,
}

/// Totals of one tile's work.
#[derive(Clone, Copy, Default)]
struct TileResult {
    attempted: u64,
    accepted: u64,
    delta: f64,
}

/// The optimiser's state: the values and pixel energies (shared between the tiles of one colour,
/// see the [module docs](self)), the running energy and counters.
pub struct SwapOptimizer {
    kernel: SwapKernel,
    /// `f32` bits, index `pixel · dims + c`.
    values: Vec<AtomicU32>,
    /// `f64` bits of each pixel's energy `e(p)` ([`SwapKernel::pixel_energies`]), kept up to date
    /// by every accepted swap.
    pixel_energy: Vec<AtomicU64>,
    seed: u64,
    passes: u64,
    energy: f64,
    attempted: u64,
    accepted: u64,
    tile_target: u32,
    partner_candidates: u32,
}

impl SwapOptimizer {
    /// An optimiser over `values` (`width · height · depth · dims` components, index
    /// `pixel · dims + c`) with the energy of a [validated](VectorSpec::validate) `spec`.
    ///
    /// Panics if the value count does not match the spec.
    pub fn new(spec: &VectorSpec, values: Vec<f32>) -> SwapOptimizer {
        let kernel = SwapKernel::new(spec);
        let pixel_energy = kernel.pixel_energies(&values);
        let slice = kernel.slice_pixels();
        let per_slice: Vec<f64> = pixel_energy
            .par_chunks(slice)
            .map(|e| e.iter().sum::<f64>())
            .collect();
        let energy = 0.5 * per_slice.iter().sum::<f64>();
        SwapOptimizer {
            kernel,
            values: values
                .into_iter()
                .map(|v| AtomicU32::new(v.to_bits()))
                .collect(),
            pixel_energy: pixel_energy
                .into_iter()
                .map(|e| AtomicU64::new(e.to_bits()))
                .collect(),
            seed: spec.seed,
            passes: 0,
            energy,
            attempted: 0,
            accepted: 0,
            tile_target: TILE_TARGET,
            partner_candidates: PARTNER_CANDIDATES,
        }
    }

    /// The same optimiser with another preferred tile side (partners are drawn within a tile,
    /// so this also sets how far a swap can move a value in one pass). For experiments; the
    /// default is [`TILE_TARGET`].
    pub fn with_tile_target(mut self, pixels: u32) -> SwapOptimizer {
        self.tile_target = pixels.max(1);
        self
    }

    /// The same optimiser drawing at most `count` partner candidates per proposal (1: a uniform
    /// partner). For experiments; the default is [`PARTNER_CANDIDATES`].
    pub fn with_partner_candidates(mut self, count: u32) -> SwapOptimizer {
        self.partner_candidates = count.max(1);
        self
    }

    /// The energy kernel.
    pub fn kernel(&self) -> &SwapKernel {
        &self.kernel
    }

    /// The running energy: the initial energy plus every accepted swap's delta.
    pub fn energy(&self) -> f64 {
        self.energy
    }

    /// The energy of the current values computed from scratch ([`SwapKernel::energy`]).
    pub fn recompute_energy(&self) -> f64 {
        self.kernel.energy(&self.values())
    }

    /// The largest difference between a cached pixel energy and its value computed from
    /// scratch: the rounding the incremental updates have accumulated.
    pub fn pixel_energy_drift(&self) -> f64 {
        let exact = self.kernel.pixel_energies(&self.values());
        exact
            .iter()
            .zip(&self.pixel_energy)
            .map(|(&e, cached)| (e - f64::from_bits(cached.load(Relaxed))).abs())
            .fold(0.0, f64::max)
    }

    /// Swaps proposed so far.
    pub fn swaps_attempted(&self) -> u64 {
        self.attempted
    }

    /// Swaps kept so far.
    pub fn swaps_accepted(&self) -> u64 {
        self.accepted
    }

    /// A copy of the current values.
    pub fn values(&self) -> Vec<f32> {
        self.values
            .iter()
            .map(|a| f32::from_bits(a.load(Relaxed)))
            .collect()
    }

    /// The current values.
    pub fn into_values(self) -> Vec<f32> {
        self.values
            .into_iter()
            .map(|a| f32::from_bits(a.into_inner()))
            .collect()
    }

    fn shared(&self) -> Shared<'_> {
        Shared {
            values: &self.values,
            energy: &self.pixel_energy,
        }
    }

    fn check_pixel(&self, (x, y): (u32, u32), z: u32) {
        assert!(
            x < self.kernel.width && y < self.kernel.height && z < self.kernel.depth,
            "pixel ({x}, {y}, {z}) is outside the volume"
        );
    }

    /// The exact energy change swapping the values of pixels `a` and `b` (`(x, y)`) of slice
    /// `z` would make, computed locally. Panics if a pixel is outside the volume.
    pub fn swap_delta(&self, z: u32, a: (u32, u32), b: (u32, u32)) -> f64 {
        self.check_pixel(a, z);
        self.check_pixel(b, z);
        let (k, shared) = (&self.kernel, self.shared());
        let mut scratch = Scratch::new(k);
        match k.dims {
            1 => k.delta::<1>(&shared, z, a, b, &mut scratch).0,
            2 => k.delta::<2>(&shared, z, a, b, &mut scratch).0,
            3 => k.delta::<3>(&shared, z, a, b, &mut scratch).0,
            _ => k.delta::<4>(&shared, z, a, b, &mut scratch).0,
        }
    }

    /// Swaps the values of pixels `a` and `b` of slice `z` if that lowers the energy (by more than
    /// the rounding margin of the [module docs](self)), counting one attempt. Returns the
    /// accepted swap's delta (negative), `None` if the values stay. Panics if a pixel is outside
    /// the volume.
    pub fn try_swap(&mut self, z: u32, a: (u32, u32), b: (u32, u32)) -> Option<f64> {
        self.check_pixel(a, z);
        self.check_pixel(b, z);
        let result = {
            let (k, shared) = (&self.kernel, self.shared());
            let mut scratch = Scratch::new(k);
            match k.dims {
                1 => k.attempt::<1>(&shared, z, a, b, &mut scratch),
                2 => k.attempt::<2>(&shared, z, a, b, &mut scratch),
                3 => k.attempt::<3>(&shared, z, a, b, &mut scratch),
                _ => k.attempt::<4>(&shared, z, a, b, &mut scratch),
            }
        };
        self.attempted += 1;
        if let Some(delta) = result {
            self.accepted += 1;
            self.energy += delta;
        }
        result
    }

    /// One pass ([module docs](self)): every pixel of every slice proposes one swap, or, with
    /// `fraction < 1`, the first `round(fraction · n)` pixels of each tile's random order do.
    /// Calls `after_colour` after each of the four colour phases. Returns the totals after the
    /// pass.
    pub fn run_pass(&mut self, fraction: f64, after_colour: &mut dyn FnMut(&Self)) -> TracePoint {
        self.run_pass_with(fraction, 0, self.tile_target, after_colour)
    }

    /// An assignment pass ([module docs](self)): in tiles about [`ASSIGNMENT_TILE_TARGET`]
    /// pixels wide, coloured like a swap pass's, each slice makes `⌈n / k⌉` moves (`n` the
    /// tile's pixels; `k` clamped to `2..=`[`MAX_ASSIGNMENT`]). A move takes a random anchor
    /// pixel of the tile, then, nearest value first among the `ASSIGNMENT_SHORTLIST` (256)
    /// values nearest the anchor's (ties by position in the tile), up to `k` pixels that
    /// interact with no other pixel of the set. Their energies then separate,
    /// `c(p, v) = Σ_n w f(‖v − Vn‖²)` summed over the set, and the permutation of their values
    /// with the least sum (`min_cost_assignment`) is kept if it lowers the energy by more than
    /// `k` margins.
    /// Counts each move as one attempted (and maybe accepted) swap. Calls `after_colour` after
    /// each colour phase.
    pub fn run_assignment_pass(
        &mut self,
        k: u32,
        after_colour: &mut dyn FnMut(&Self),
    ) -> TracePoint {
        let k = k.clamp(2, MAX_ASSIGNMENT);
        self.run_pass_with(1.0, k, ASSIGNMENT_TILE_TARGET, after_colour)
    }

    /// One pass in tiles about `tile_target` pixels wide: swaps (`assignment` 0) or an
    /// assignment pass over sets of up to `assignment` pixels.
    fn run_pass_with(
        &mut self,
        fraction: f64,
        assignment: u32,
        tile_target: u32,
        after_colour: &mut dyn FnMut(&Self),
    ) -> TracePoint {
        let (w, h) = (self.kernel.width, self.kernel.height);
        let (rx, ry) = self.kernel.reach();
        let pass = self.passes;
        self.passes += 1;
        let mut grid_rng = keyed_rng(self.seed, stream::GRID, pass, 0);
        let (ox, oy) = (grid_rng.random_range(0..w), grid_rng.random_range(0..h));
        let (nx, ny) = (
            tiles_along(w, rx, tile_target),
            tiles_along(h, ry, tile_target),
        );
        let bound =
            |i: u32, n: u32, size: u32| (u64::from(i) * u64::from(size) / u64::from(n)) as u32;
        let mut tiles = Vec::with_capacity((nx * ny) as usize);
        for ty in 0..ny {
            for tx in 0..nx {
                tiles.push(Tile {
                    x0: (ox + bound(tx, nx, w)) % w,
                    y0: (oy + bound(ty, ny, h)) % h,
                    w: bound(tx + 1, nx, w) - bound(tx, nx, w),
                    h: bound(ty + 1, ny, h) - bound(ty, ny, h),
                    colour: ((tx % 2) + 2 * (ty % 2)) as u8,
                    id: u64::from(ty) * u64::from(nx) + u64::from(tx),
                });
            }
        }
        let fraction = fraction.clamp(0.0, 1.0);
        for colour in 0..4 {
            let batch: Vec<Tile> = tiles
                .iter()
                .copied()
                .filter(|t| t.colour == colour)
                .collect();
            let plan = PassPlan {
                seed: self.seed,
                pass,
                fraction,
                partner_candidates: partner_candidates(pass, self.partner_candidates),
                assignment,
            };
            let results: Vec<TileResult> = {
                let (kernel, shared) = (&self.kernel, self.shared());
                batch
                    .par_iter()
                    .map(|tile| kernel.run_tile_fastest(&shared, tile, &plan))
                    .collect()
            };
            for r in results {
                self.attempted += r.attempted;
                self.accepted += r.accepted;
                self.energy += r.delta;
            }
            after_colour(self);
        }
        TracePoint {
            swaps_attempted: self.attempted,
            swaps_accepted: self.accepted,
            energy: self.energy,
        }
    }
}

impl SwapKernel {
    /// [`SwapKernel::run_tile`] for this kernel's value dimension, compiled for AVX-512 or AVX2
    /// where the CPU has it. Those builds only widen the vector loops (16 or 8 `f32` lanes
    /// instead of SSE2's 4) and perform the same IEEE operations in the same order (Rust never
    /// fuses a multiply and an add), so all give identical bits (tested). AVX2 was 1.3–1.45×
    /// faster than SSE2 (64×64×32, 32 swaps per pixel: Vec2 1.16–1.20 s against 1.67–1.72 s,
    /// UnitVec3 0.94 s against 1.22–1.27 s); AVX-512 is 7–16% faster again (same size, one
    /// thread, four alternating runs, medians: Vec2 3.35 → 2.8 s, UnitVec3 2.7 → 2.5 s; a set
    /// of runs earlier than [`Shared::value`]'s, on a slower phase of the VM).
    fn run_tile_fastest(&self, shared: &Shared, tile: &Tile, plan: &PassPlan) -> TileResult {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: `run_tile_avx512` only requires AVX-512F, which the CPU was just checked to
            // have.
            return unsafe { self.run_tile_avx512(shared, tile, plan) };
        }
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: `run_tile_avx2` only requires AVX2, which the CPU was just checked to have.
            return unsafe { self.run_tile_avx2(shared, tile, plan) };
        }
        self.run_tile_dims(shared, tile, plan)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn run_tile_avx512(&self, shared: &Shared, tile: &Tile, plan: &PassPlan) -> TileResult {
        self.run_tile_dims(shared, tile, plan)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn run_tile_avx2(&self, shared: &Shared, tile: &Tile, plan: &PassPlan) -> TileResult {
        self.run_tile_dims(shared, tile, plan)
    }

    #[inline(always)]
    fn run_tile_dims(&self, shared: &Shared, tile: &Tile, plan: &PassPlan) -> TileResult {
        match self.dims {
            1 => self.run_tile::<1>(shared, tile, plan),
            2 => self.run_tile::<2>(shared, tile, plan),
            3 => self.run_tile::<3>(shared, tile, plan),
            _ => self.run_tile::<4>(shared, tile, plan),
        }
    }

    /// Proposes the swaps of one tile of one pass in every slice.
    #[inline(always)]
    fn run_tile<const D: usize>(
        &self,
        shared: &Shared,
        tile: &Tile,
        plan: &PassPlan,
    ) -> TileResult {
        if plan.assignment >= 2 {
            return self.run_tile_assignment::<D>(shared, tile, plan);
        }
        let mut result = TileResult::default();
        let n = tile.w * tile.h;
        if n < 2 {
            return result;
        }
        let mut rng = keyed_rng(plan.seed, stream::TILE, plan.pass, tile.id);
        let mut scratch = Scratch::new(self);
        let count = ((plan.fraction * f64::from(n)).round() as usize).min(n as usize);
        let mut order: Vec<u32> = (0..n).collect();
        let pixel = |i: u32| tile.pixel(i, self.width, self.height);
        let in_slice = tile.slice_indices(self.width, self.height);
        for z in 0..self.depth {
            let base = z as usize * self.slice_pixels();
            order.shuffle(&mut rng);
            for &i in &order[..count] {
                let mut draw = || other_index(&mut rng, i, n);
                // The candidate whose value is nearest but not equal (swapping equal values
                // changes nothing, and spaces like ±1 have many), the first of equals.
                let mut j = draw();
                if plan.partner_candidates > 1 {
                    let value = shared.value::<D>(base + in_slice[i as usize]);
                    let distance = |j: u32| {
                        let d = squared_distance(
                            &value,
                            &shared.value::<D>(base + in_slice[j as usize]),
                        );
                        if d > 0.0 { d } else { f32::INFINITY }
                    };
                    let mut nearest = distance(j);
                    for _ in 1..plan.partner_candidates {
                        let candidate = draw();
                        let d = distance(candidate);
                        if d < nearest {
                            (j, nearest) = (candidate, d);
                        }
                    }
                }
                result.attempted += 1;
                if let Some(delta) = self.attempt::<D>(shared, z, pixel(i), pixel(j), &mut scratch)
                {
                    result.accepted += 1;
                    result.delta += delta;
                }
            }
        }
        result
    }
}

/// Largest set of an assignment pass.
pub const MAX_ASSIGNMENT: u32 = 16;

/// Pixels per set of the assignment passes [`crate::vector::generate_vector`] runs.
pub const ASSIGNMENT_SET: u32 = 8;

/// Preferred tile side of assignment passes, in pixels: sets of [`ASSIGNMENT_SET`] pixels that
/// do not interact need room to find similar values (in 16-pixel tiles, 16 passes of 8-pixel
/// sets lowered the 64×64×32 Vec2 energy to 3.274653; in 32-pixel tiles, to 3.272816).
pub const ASSIGNMENT_TILE_TARGET: u32 = 32;

/// Values nearest the anchor's that a set is chosen from, at most.
const ASSIGNMENT_SHORTLIST: usize = 256;

/// Values nearest the anchor's sorted before the rest of the shortlist (most sets fill from them).
const ASSIGNMENT_FIRST_LOOK: usize = 32;

/// The permutation `out` (row `i` gets column `out[i]`) of least total `cost` (`k × k`, row
/// major): the Hungarian method with potentials, O(k³). Deterministic.
fn min_cost_assignment(cost: &[f64], k: usize, out: &mut [usize]) {
    let inf = f64::INFINITY;
    let mut u = vec![0.0; k + 1];
    let mut v = vec![0.0; k + 1];
    let mut p = vec![0usize; k + 1];
    let mut way = vec![0usize; k + 1];
    let mut minv = vec![inf; k + 1];
    let mut used = vec![false; k + 1];
    for i in 1..=k {
        p[0] = i;
        let mut j0 = 0;
        minv.fill(inf);
        used.fill(false);
        loop {
            used[j0] = true;
            let i0 = p[j0];
            let mut delta = inf;
            let mut j1 = 0;
            for j in 1..=k {
                if !used[j] {
                    let cur = cost[(i0 - 1) * k + j - 1] - u[i0] - v[j];
                    if cur < minv[j] {
                        minv[j] = cur;
                        way[j] = j0;
                    }
                    if minv[j] < delta {
                        delta = minv[j];
                        j1 = j;
                    }
                }
            }
            for j in 0..=k {
                if used[j] {
                    u[p[j]] += delta;
                    v[j] -= delta;
                } else {
                    minv[j] -= delta;
                }
            }
            j0 = j1;
            if p[j0] == 0 {
                break;
            }
        }
        loop {
            let j1 = way[j0];
            p[j0] = p[j1];
            j0 = j1;
            if j0 == 0 {
                break;
            }
        }
    }
    for j in 1..=k {
        out[p[j] - 1] = j - 1;
    }
}

impl SwapKernel {
    /// `c(p, v) = Σ_n w f(‖v − Vn‖²)`, the energy pixel `p` would have holding `value`, from the
    /// values `neighbours` of its taps (in [`SwapKernel::for_each_neighbour`]'s order).
    #[inline(always)]
    fn pixel_cost<const D: usize>(
        &self,
        neighbours: &[[f32; D]],
        value: &[f32; D],
        scratch: &mut Scratch,
    ) -> f64 {
        let taps = scratch.taps;
        let padded = taps.div_ceil(FACTOR_LANES) * FACTOR_LANES;
        for (d, n) in scratch.after[..taps].iter_mut().zip(neighbours) {
            *d = squared_distance(value, n);
        }
        scratch.after[taps..padded].fill(0.0);
        value_factors::<D>(
            &scratch.after[..padded],
            &mut scratch.factor[..padded],
            self.inv_sigma_value_sq,
        );
        let entries = scratch.weight[..taps].iter().zip(&scratch.factor[..taps]);
        for (term, (&w, &f)) in scratch.term.iter_mut().zip(entries) {
            *term = w * f64::from(f);
        }
        lane_sum(&scratch.term[..taps])
    }

    /// One tile of an assignment pass ([`SwapOptimizer::run_assignment_pass`]).
    #[inline(always)]
    fn run_tile_assignment<const D: usize>(
        &self,
        shared: &Shared,
        tile: &Tile,
        plan: &PassPlan,
    ) -> TileResult {
        let mut result = TileResult::default();
        let n = tile.w * tile.h;
        if n < 2 {
            return result;
        }
        let k_max = plan.assignment as usize;
        let mut rng = keyed_rng(plan.seed, stream::TILE, plan.pass, tile.id);
        let mut scratch = Scratch::new(self);
        let pixel = |i: u32| tile.pixel(i, self.width, self.height);
        let in_slice = tile.slice_indices(self.width, self.height);
        let mut order: Vec<u32> = (0..n).collect();
        let mut near: Vec<(u32, u32)> = Vec::with_capacity(n as usize);
        let mut set: Vec<u32> = Vec::with_capacity(k_max);
        let mut cost = vec![0.0f64; k_max * k_max];
        let mut perm = vec![0usize; k_max];
        let mut tile_values: Vec<[f32; D]> = Vec::with_capacity(n as usize);
        let mut neighbours = vec![[0.0f32; D]; scratch.taps];
        // The set's values before a kept permutation.
        let mut old: Vec<[f32; D]> = Vec::with_capacity(k_max);
        let shortlist = ASSIGNMENT_SHORTLIST.min(n as usize);
        let moves = (n as usize).div_ceil(k_max);
        for z in 0..self.depth {
            let base = z as usize * self.slice_pixels();
            order.shuffle(&mut rng);
            tile_values.clear();
            tile_values.extend(in_slice.iter().map(|&p| shared.value::<D>(base + p)));
            for &anchor in &order[..moves] {
                // The shortlist: the tile's values nearest the anchor's, nearest first (ties by
                // position in the tile), then greedily the ones that interact with none chosen.
                let target = tile_values[anchor as usize];
                near.clear();
                near.extend(
                    tile_values
                        .iter()
                        .enumerate()
                        .map(|(j, v)| (squared_distance(&target, v).to_bits(), j as u32)),
                );
                if shortlist < near.len() {
                    near.select_nth_unstable(shortlist - 1);
                    near.truncate(shortlist);
                }
                // Most sets fill from the first few nearest, so those are sorted first and the
                // rest only when the set is still short: the same order as sorting them all.
                let first = ASSIGNMENT_FIRST_LOOK.min(near.len());
                if first < near.len() {
                    near.select_nth_unstable(first - 1);
                }
                near[..first].sort_unstable();
                set.clear();
                let take = |candidates: &[(u32, u32)], set: &mut Vec<u32>| {
                    for &(_, j) in candidates {
                        let pj = pixel(j);
                        if set
                            .iter()
                            .all(|&a| a != j && self.spatial_tap(pixel(a), pj).is_none())
                        {
                            set.push(j);
                            if set.len() == k_max {
                                break;
                            }
                        }
                    }
                };
                take(&near[..first], &mut set);
                if set.len() < k_max && first < near.len() {
                    near[first..].sort_unstable();
                    take(&near[first..], &mut set);
                }
                let k = set.len();
                if k < 2 {
                    continue;
                }
                // Each pixel's neighbour values are read once and costed against every value.
                for (r, &i) in set.iter().enumerate() {
                    let (x, y) = pixel(i);
                    let centre = base + in_slice[i as usize];
                    self.for_each_neighbour((x, y, z), centre, |t, n| {
                        neighbours[t] = shared.value::<D>(n);
                    });
                    for (c, &j) in set.iter().enumerate() {
                        cost[r * k + c] = self.pixel_cost::<D>(
                            &neighbours,
                            &tile_values[j as usize],
                            &mut scratch,
                        );
                    }
                }
                min_cost_assignment(&cost[..k * k], k, &mut perm[..k]);
                let before: f64 = (0..k).map(|r| cost[r * k + r]).sum();
                let after: f64 = (0..k).map(|r| cost[r * k + perm[r]]).sum();
                result.attempted += 1;
                let delta = after - before;
                if delta >= -self.margin * k as f64 {
                    continue;
                }
                result.accepted += 1;
                result.delta += delta;
                old.clear();
                old.extend(set.iter().map(|&i| tile_values[i as usize]));
                for (r, &i) in set.iter().enumerate() {
                    if perm[r] == r {
                        continue;
                    }
                    let (from, to) = (old[r], old[perm[r]]);
                    let (x, y) = pixel(i);
                    let centre = base + in_slice[i as usize];
                    let inv = self.inv_sigma_value_sq;
                    let weights = &scratch.weight;
                    self.for_each_neighbour((x, y, z), centre, |t, nb| {
                        let vn = shared.value::<D>(nb);
                        let change = weights[t]
                            * (f64::from(value_factor::<D>(squared_distance(&to, &vn), inv))
                                - f64::from(value_factor::<D>(squared_distance(&from, &vn), inv)));
                        shared.set_energy(nb, shared.energy(nb) + change);
                    });
                    shared.set_energy(centre, cost[r * k + perm[r]]);
                }
                for (r, &i) in set.iter().enumerate() {
                    let to = old[perm[r]];
                    tile_values[i as usize] = to;
                    let centre = base + in_slice[i as usize];
                    for (c, &bits) in to.iter().enumerate() {
                        shared.values[centre * D + c].store(bits.to_bits(), Relaxed);
                    }
                }
            }
        }
        result
    }
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
            worst_exp = worst_exp.max((f64::from(exp_neg_f32(x)) - exact).abs() / exact);
            let s = (i + 1) as f32 * 2.3e-5;
            for s in [s, s * 1e-20, s * 1e20] {
                let exact = f64::from(s).powf(-1.0 / 3.0);
                let got = f64::from(inverse_cbrt_f32(s));
                worst_cbrt = worst_cbrt.max((got - exact).abs() / exact);
            }
        }
        assert!(worst_exp < 2e-7, "exp: worst relative error {worst_exp}");
        assert!(
            worst_cbrt < 3e-7,
            "cube root: worst relative error {worst_cbrt}"
        );
        assert_eq!(exp_neg_f32(0.0), 1.0);
        assert!(exp_neg_f32(f32::INFINITY) < 1e-37);
        assert!(inverse_cbrt_f32(0.0).is_finite());
    }

    #[test]
    fn value_factor_matches_std() {
        fn check<const D: usize>(inv_sigma_sq: f32) -> f64 {
            let mut worst: f64 = 0.0;
            for i in 0..100_000 {
                // Squared distances over every space's range (unit vectors: up to 4), and tiny.
                let s = i as f32 * 4e-5;
                for s in [s, s * 1e-30] {
                    // The exponent's relative error becomes an absolute one in the logarithm.
                    let exponent =
                        f64::from(s).sqrt().powf(D as f64 / 3.0) * f64::from(inv_sigma_sq);
                    let exact = (-exponent).exp();
                    let got = f64::from(value_factor::<D>(s, inv_sigma_sq));
                    worst = worst.max((got - exact).abs() / exact / exponent.max(1.0));
                }
            }
            worst
        }
        for inv_sigma_sq in [1.0, 0.01, 20.0] {
            for worst in [
                check::<1>(inv_sigma_sq),
                check::<2>(inv_sigma_sq),
                check::<3>(inv_sigma_sq),
                check::<4>(inv_sigma_sq),
            ] {
                assert!(
                    worst < 5e-7,
                    "worst relative error {worst} at 1/σ² {inv_sigma_sq}"
                );
            }
        }
        assert_eq!(value_factor::<2>(0.0, 1.0), 1.0);
        assert_eq!(distance_power::<1>(0.0), 0.0);
        assert_eq!(distance_power::<4>(0.0), 0.0);
    }

    /// The AVX2 and AVX-512 builds of the tile loop and the portable one give the same values,
    /// energies and counts, bit for bit, for every value dimension. AVX2 must be there; the
    /// AVX-512 build is compared where the CPU has it.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn simd_and_portable_tile_loops_agree_bit_for_bit() {
        use crate::SampleSpace;
        assert!(
            std::arch::is_x86_feature_detected!("avx2"),
            "this test needs an x86-64 CPU with AVX2 to compare the builds"
        );
        #[derive(Clone, Copy, Debug)]
        enum Build {
            Portable,
            Avx2,
            Avx512,
        }
        let mut builds = vec![Build::Avx2];
        if std::arch::is_x86_feature_detected!("avx512f") {
            builds.push(Build::Avx512);
        }
        let run = |build: Build, o: &SwapOptimizer, tile: &Tile, plan: &PassPlan| match build {
            Build::Portable => o.kernel.run_tile_dims(&o.shared(), tile, plan),
            // SAFETY: the CPU has AVX2 (asserted above).
            Build::Avx2 => unsafe { o.kernel.run_tile_avx2(&o.shared(), tile, plan) },
            // SAFETY: only pushed where the CPU has AVX-512F.
            Build::Avx512 => unsafe { o.kernel.run_tile_avx512(&o.shared(), tile, plan) },
        };
        let bits = |o: &SwapOptimizer| -> (Vec<u32>, Vec<u64>) {
            (
                o.values.iter().map(|v| v.load(Relaxed)).collect(),
                o.pixel_energy.iter().map(|e| e.load(Relaxed)).collect(),
            )
        };
        let spaces = [
            SampleSpace::Vec { dims: 1 },
            SampleSpace::UnitVec2,
            SampleSpace::UnitVec3,
            SampleSpace::Vec { dims: 4 },
        ];
        for space in spaces {
            let spec = VectorSpec::new(16, 12, 6, 5, space.clone()).unoptimised();
            let start = crate::generate_vector(&spec).unwrap().0.values().to_vec();
            // One tile over the whole slice (interior pixels and wrapping ones): no other tile
            // runs beside it.
            let tile = Tile {
                x0: 3,
                y0: 5,
                w: 16,
                h: 12,
                colour: 0,
                id: 0,
            };
            let portable = SwapOptimizer::new(&spec, start.clone());
            let simd: Vec<SwapOptimizer> = builds
                .iter()
                .map(|_| SwapOptimizer::new(&spec, start.clone()))
                .collect();
            // Three swap passes, then two assignment passes of up to 4 pixels per set.
            for pass in 0..5 {
                let plan = PassPlan {
                    seed: 5,
                    pass,
                    fraction: 1.0,
                    partner_candidates: PARTNER_CANDIDATES,
                    assignment: if pass < 3 { 0 } else { 4 },
                };
                let a = run(Build::Portable, &portable, &tile, &plan);
                assert!(a.accepted > 0, "{space:?}: no swap accepted");
                for (&build, o) in builds.iter().zip(&simd) {
                    let b = run(build, o, &tile, &plan);
                    assert_eq!((a.attempted, a.accepted), (b.attempted, b.accepted));
                    assert_eq!(a.delta.to_bits(), b.delta.to_bits(), "{space:?} {build:?}");
                }
            }
            for (&build, o) in builds.iter().zip(&simd) {
                assert_eq!(bits(&portable), bits(o), "{space:?} {build:?}");
            }
        }
    }

    /// The Hungarian method finds a permutation of least cost: checked against every
    /// permutation of random `k × k` matrices, `k` up to 6, with ties (costs on a coarse grid).
    #[test]
    fn min_cost_assignment_is_optimal() {
        fn permutations(k: usize) -> Vec<Vec<usize>> {
            if k == 0 {
                return vec![vec![]];
            }
            let mut all = Vec::new();
            for p in permutations(k - 1) {
                for at in 0..k {
                    let mut q = p.clone();
                    q.insert(at, k - 1);
                    all.push(q);
                }
            }
            all
        }
        let mut rng = keyed_rng(3, 0, 0, 0);
        for k in 1..=6 {
            for round in 0..40 {
                let cost: Vec<f64> = (0..k * k)
                    .map(|_| {
                        let x = rng.random_range(0.0..1.0f64);
                        if round % 2 == 0 { (x * 4.0).floor() } else { x }
                    })
                    .collect();
                let mut perm = vec![0; k];
                min_cost_assignment(&cost, k, &mut perm);
                let total = |p: &[usize]| (0..k).map(|r| cost[r * k + p[r]]).sum::<f64>();
                let mut sorted = perm.clone();
                sorted.sort_unstable();
                assert_eq!(sorted, (0..k).collect::<Vec<_>>(), "not a permutation");
                let best = permutations(k)
                    .iter()
                    .map(|p| total(p))
                    .fold(f64::INFINITY, f64::min);
                assert!(
                    total(&perm) <= best + 1e-12,
                    "k {k}: {} > {best}",
                    total(&perm)
                );
            }
        }
    }

    /// Assignment passes lower the energy, keep the running energy and every cached pixel
    /// energy equal to their values from scratch, and keep each slice's multiset of values.
    #[test]
    fn assignment_passes_are_exact_and_keep_each_slice() {
        use crate::SampleSpace;
        let spaces = [
            SampleSpace::Vec { dims: 1 },
            SampleSpace::Vec { dims: 2 },
            SampleSpace::UnitVec3,
            SampleSpace::Vec { dims: 4 },
        ];
        for space in spaces {
            for (w, h, d) in [(72, 64, 3), (20, 18, 2), (5, 4, 2)] {
                let spec = VectorSpec::new(w, h, d, 9, space.clone()).with_swaps_per_pixel(2.0);
                let start = crate::generate_vector(&spec).unwrap().0.values().to_vec();
                let mut o = SwapOptimizer::new(&spec, start.clone());
                let before = o.energy();
                for _ in 0..3 {
                    o.run_assignment_pass(ASSIGNMENT_SET, &mut |_| {});
                }
                let exact = o.recompute_energy();
                assert!(
                    (o.energy() - exact).abs() <= 1e-10 * exact,
                    "{space:?} {w}x{h}x{d}: running {} against {exact}",
                    o.energy()
                );
                assert!(o.pixel_energy_drift() <= 1e-10 * exact);
                if w >= 20 {
                    assert!(
                        o.swaps_accepted() > 0,
                        "{space:?} {w}x{h}x{d}: nothing kept"
                    );
                    assert!(exact < before, "{space:?} {w}x{h}x{d}: {exact} >= {before}");
                }
                let dims = space.dims();
                let slice = (w * h) as usize * dims;
                let sorted = |v: &[f32]| {
                    let mut bits: Vec<Vec<u32>> = v
                        .chunks(dims)
                        .map(|c| c.iter().map(|x| x.to_bits()).collect())
                        .collect();
                    bits.sort_unstable();
                    bits
                };
                let end = o.values();
                for z in 0..d as usize {
                    let range = z * slice..(z + 1) * slice;
                    assert_eq!(sorted(&start[range.clone()]), sorted(&end[range]));
                }
            }
        }
    }

    /// `gather`'s written-out interior loop lists the same taps in the same order as
    /// `for_each_neighbour` (which `apply` uses), for interior, edge and folded pixels.
    #[test]
    fn gather_and_for_each_neighbour_agree() {
        use crate::SampleSpace;
        for (w, h, d) in [(20, 18, 5), (9, 10, 3), (3, 2, 2), (1, 7, 4)] {
            let spec = VectorSpec::new(w, h, d, 3, SampleSpace::Vec { dims: 2 });
            let start = crate::generate_vector(&spec.clone().unoptimised())
                .unwrap()
                .0
                .values()
                .to_vec();
            let o = SwapOptimizer::new(&spec, start);
            let (k, shared) = (&o.kernel, o.shared());
            let taps = k.spatial.len() + k.temporal.len();
            let probe = [0.25f32, -0.5];
            for z in 0..d {
                for y in 0..h {
                    for x in 0..w {
                        let centre = ((z * h + y) * w + x) as usize;
                        let mut fast = vec![f32::NAN; taps];
                        k.gather::<2>(&shared, (x, y, z), centre, &probe, &mut fast);
                        let mut each = vec![f32::NAN; taps];
                        k.for_each_neighbour((x, y, z), centre, |t, n| {
                            each[t] = squared_distance(&probe, &shared.value::<2>(n));
                        });
                        let bits = |v: &[f32]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
                        assert_eq!(bits(&fast), bits(&each), "{w}×{h}×{d} at ({x}, {y}, {z})");
                    }
                }
            }
        }
    }

    #[test]
    fn tiles_keep_same_colour_apart() {
        // This optimiser's target and the filter-adapted optimiser's.
        let targets = [
            TILE_TARGET,
            crate::filter_adapted::optimizer::Optimizer::TILE_TARGET,
        ];
        for target in targets {
            for size in 1..100 {
                for reach in 0..8 {
                    let n = tiles_along(size, reach, target);
                    assert!(n == 1 || n.is_multiple_of(2));
                    if n > 1 {
                        assert!(size / n >= 2 * reach, "{size} {reach} {n}");
                    }
                }
            }
        }
    }
}
