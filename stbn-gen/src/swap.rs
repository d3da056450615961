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

use rand::seq::SliceRandom;

use rayon::prelude::*;

use rand_chacha::ChaCha8Rng;

use crate::fastmath::{exp_neg, exp_neg_f32, inverse_cbrt_f32};
use crate::rng::{self, other_index};
use crate::schedule::{self, Layout, PassKey, SpanStart, Tile, TileOptimizer};
use crate::torus::{canonical, wrap};
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

/// The truncated, folded pair weights of one [`VectorSpec`] and the value factor's parameters.
#[derive(Clone, Debug)]
pub struct SwapKernel {
    width: u32,
    height: u32,
    depth: u32,
    dims: usize,
    /// Same-slice neighbours: canonical `(dx, dy)` (never `(0, 0)`), weight.
    spatial: Vec<(i32, i32, f64)>,
    /// Same-position neighbours: canonical `dz` (never 0), weight.
    temporal: Vec<(i32, f64)>,
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

    /// The index steps to every tap's neighbour in a block of `width × height` pixels per slice
    /// and the kernel's depth.
    fn steps(&self, width: u32, height: u32) -> Steps {
        let depth = i64::from(self.depth);
        let slice = width as isize * height as isize;
        Steps {
            width,
            height,
            spatial: self
                .spatial
                .iter()
                .map(|&(dx, dy, _)| dy as isize * width as isize + dx as isize)
                .collect(),
            temporal: (0..depth)
                .flat_map(|z| {
                    self.temporal.iter().map(move |&(dz, _)| {
                        ((z + i64::from(dz)).rem_euclid(depth) - z) as isize * slice
                    })
                })
                .collect(),
        }
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
        let steps = self.steps(self.width, self.height);
        let taps = self.temporal.len();
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
                        let temporal_steps = &steps.temporal[z * taps..(z + 1) * taps];
                        for (&(_, wt), &step) in self.temporal.iter().zip(temporal_steps) {
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

/// Index steps from a pixel to its neighbours in a block of pixels: `width × height` per slice,
/// every slice (the volume, or a tile's region).
struct Steps {
    /// Pixels per row and rows per slice of the block.
    width: u32,
    height: u32,
    /// `dy · width + dx` of each spatial tap, for pixels whose taps stay inside the block.
    spatial: Vec<isize>,
    /// From slice `z`, the step to each temporal neighbour, `width · height · (z' − z)`: index
    /// `z · temporal taps + k`.
    temporal: Vec<isize>,
}

/// Values and pixel energies of a block of pixels: the whole volume (the optimiser's state) or a
/// tile's private copy of its region ([`crate::schedule`]), indexed as its [`Steps`] say.
struct Region {
    steps: Steps,
    /// `f32` components, index `pixel · dims + c`, pixel `(z · height + y) · width + x`.
    values: Vec<f32>,
    /// Each pixel's energy `e(p)`.
    energy: Vec<f64>,
}

impl Region {
    /// The value of `pixel`.
    #[inline(always)]
    fn value<const D: usize>(&self, pixel: usize) -> [f32; D] {
        value_at::<D>(&self.values, pixel)
    }

    /// Index of pixel `(x, y)` of slice `z`.
    #[inline(always)]
    fn index(&self, (x, y): (u32, u32), z: u32) -> usize {
        let (w, h) = (self.steps.width as usize, self.steps.height as usize);
        (z as usize * h + y as usize) * w + x as usize
    }
}

/// The value of `pixel` in `values` (`D` components per pixel).
#[inline(always)]
fn value_at<const D: usize>(values: &[f32], pixel: usize) -> [f32; D] {
    std::array::from_fn(|c| values[pixel * D + c])
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
    /// Whether every spatial tap of pixel `(x, y)` lies inside the block of `steps` without
    /// wrapping (in a tile's region, every pixel of the tile along an axis the region does not
    /// span).
    #[inline(always)]
    fn is_interior(&self, steps: &Steps, x: u32, y: u32) -> bool {
        let (xi, yi) = (x as i32, y as i32);
        xi + self.dx_range.0 >= 0
            && xi + self.dx_range.1 < steps.width as i32
            && yi + self.dy_range.0 >= 0
            && yi + self.dy_range.1 < steps.height as i32
    }

    /// Calls `visit(k, n)` for each neighbour `n` of pixel `(x, y)` of slice `z` (index
    /// `centre`) in the block of `steps`, `k` its tap number: the spatial taps in the kernel's
    /// order, then the temporal ones. Taps that leave the block wrap around it (only where it
    /// spans an axis of the volume).
    #[inline(always)]
    fn for_each_neighbour(
        &self,
        steps: &Steps,
        (x, y, z): (u32, u32, u32),
        centre: usize,
        mut visit: impl FnMut(usize, usize),
    ) {
        if self.is_interior(steps, x, y) {
            for (k, &step) in steps.spatial.iter().enumerate() {
                visit(k, (centre as isize + step) as usize);
            }
        } else {
            let (xi, yi) = (x as i32, y as i32);
            let width = steps.width as usize;
            let row0 = centre - (y as usize * width + x as usize);
            for (k, &(dx, dy, _)) in self.spatial.iter().enumerate() {
                let nx = wrap(xi + dx, steps.width) as usize;
                let ny = wrap(yi + dy, steps.height) as usize;
                visit(k, row0 + ny * width + nx);
            }
        }
        let first = self.spatial.len();
        for (k, &step) in self.temporal_steps(steps, z).iter().enumerate() {
            visit(first + k, (centre as isize + step) as usize);
        }
    }

    /// The steps to the temporal neighbours of a pixel of slice `z`.
    #[inline(always)]
    fn temporal_steps<'s>(&self, steps: &'s Steps, z: u32) -> &'s [isize] {
        let taps = self.temporal.len();
        &steps.temporal[z as usize * taps..(z as usize + 1) * taps]
    }

    /// `out[k] = ‖value − Vn‖²` for each neighbour `n` (tap `k`) of pixel `(x, y)` of slice `z`:
    /// [`SwapKernel::for_each_neighbour`]'s taps in its order (tested), with the interior case
    /// written out, which the compiler turns into a tighter loop than the closure (64×64×32, 32
    /// swaps per pixel, one thread, six alternating runs, medians: Vec2 2.3 s against 2.55 s).
    #[inline(always)]
    fn gather<const D: usize>(
        &self,
        region: &Region,
        at: (u32, u32, u32),
        centre: usize,
        value: &[f32; D],
        out: &mut [f32],
    ) {
        let (x, y, z) = at;
        let steps = &region.steps;
        if self.is_interior(steps, x, y) {
            for (o, &step) in out.iter_mut().zip(&steps.spatial) {
                let n = centre.wrapping_add_signed(step);
                *o = squared_distance(value, &region.value::<D>(n));
            }
            let first = self.spatial.len();
            for (k, &step) in self.temporal_steps(steps, z).iter().enumerate() {
                let n = centre.wrapping_add_signed(step);
                out[first + k] = squared_distance(value, &region.value::<D>(n));
            }
            return;
        }
        self.for_each_neighbour(steps, at, centre, |k, n| {
            out[k] = squared_distance(value, &region.value::<D>(n));
        });
    }

    /// The spatial tap from pixel `from` to pixel `to` of the same slice, if they interact.
    /// Coordinates are in the volume or in one tile's region: the offset is taken modulo the
    /// volume, which a region either spans or holds without wrapping.
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

    /// The exact energy change of swapping the values of pixels `a` and `b` of slice `z` of
    /// `region`, from the cached energies `e(a)`, `e(b)` and the pair energies after the swap.
    /// Leaves in `scratch` what [`SwapKernel::apply`] needs. Returns the delta and the two
    /// indices.
    ///
    /// `ΔE = Σ_{n ∈ N(a)∖b} w f(‖vb − vn‖²) − (e(a) − w_ab f_ab)` plus the same for `b`: the
    /// pairs of `a` and of `b` change, except the pair `(a, b)` (energy `w_ab f_ab`, symmetric).
    #[inline(always)]
    fn delta<const D: usize>(
        &self,
        region: &Region,
        z: u32,
        a: (u32, u32),
        b: (u32, u32),
        scratch: &mut Scratch,
    ) -> (f64, usize, usize) {
        let ia = region.index(a, z);
        let ib = region.index(b, z);
        let va = region.value::<D>(ia);
        let vb = region.value::<D>(ib);
        if ia == ib || va == vb {
            return (0.0, ia, ib);
        }
        let taps = scratch.taps;
        let (after_a, after_b) = scratch.after.split_at_mut(taps);
        self.gather::<D>(region, (a.0, a.1, z), ia, &vb, after_a);
        self.gather::<D>(region, (b.0, b.1, z), ib, &va, after_b);
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
        let delta = after - (region.energy[ia] + region.energy[ib]) + 2.0 * scratch.pair_energy;
        (delta, ia, ib)
    }

    /// Performs the swap of pixels `a` and `b` of slice `z` (indices `ia`, `ib`) that
    /// [`SwapKernel::delta`] just evaluated (with `scratch` as it left it): swaps the values and
    /// updates the energies of `a`, `b` and every neighbour.
    #[inline(always)]
    fn apply<const D: usize>(
        &self,
        region: &mut Region,
        z: u32,
        (a, b): ((u32, u32), (u32, u32)),
        (ia, ib): (usize, usize),
        scratch: &mut Scratch,
    ) {
        let (taps, count) = (scratch.taps, scratch.len);
        let e_a = lane_sum(&scratch.term[..taps]);
        let e_b = lane_sum(&scratch.term[taps..count]);
        let (va, vb) = (region.value::<D>(ia), region.value::<D>(ib));
        for (centre, at, value, first) in [(ia, a, &va, 0), (ib, b, &vb, taps)] {
            let (index, before) = (&mut scratch.index, &mut scratch.before);
            self.for_each_neighbour(&region.steps, (at.0, at.1, z), centre, |k, n| {
                index[first + k] = n;
                before[first + k] = squared_distance(value, &region.value::<D>(n));
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
                region.energy[scratch.index[k]] += scratch.term[k];
            }
        }
        region.energy[ia] = e_a + scratch.pair_energy;
        region.energy[ib] = e_b + scratch.pair_energy;
        for c in 0..D {
            region.values.swap(ia * D + c, ib * D + c);
        }
    }

    /// Swaps `a` and `b` of slice `z` if that lowers the energy by more than the margin; returns
    /// the (negative) delta of an accepted swap.
    #[inline(always)]
    fn attempt<const D: usize>(
        &self,
        region: &mut Region,
        z: u32,
        a: (u32, u32),
        b: (u32, u32),
        scratch: &mut Scratch,
    ) -> Option<f64> {
        let (delta, ia, ib) = self.delta::<D>(region, z, a, b, scratch);
        if delta < -self.margin {
            self.apply::<D>(region, z, (a, b), (ia, ib), scratch);
            Some(delta)
        } else {
            None
        }
    }
}

/// What every tile of one pass needs besides its coordinates and random stream.
pub(crate) struct PassPlan {
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

/// One tile's private copy of its region after its moves, and its totals.
pub(crate) struct TileOutcome {
    region: Region,
    result: TileResult,
}

/// The optimiser's state: the values and pixel energies, the running energy and counters.
pub struct SwapOptimizer {
    kernel: SwapKernel,
    /// The whole volume: the values and each pixel's energy `e(p)`
    /// ([`SwapKernel::pixel_energies`]), kept up to date by every accepted swap.
    state: Region,
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
            state: Region {
                steps: kernel.steps(kernel.width, kernel.height),
                values,
                energy: pixel_energy,
            },
            kernel,
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
        self.kernel.energy(&self.state.values)
    }

    /// The largest difference between a cached pixel energy and its value computed from
    /// scratch: the rounding the incremental updates have accumulated.
    pub fn pixel_energy_drift(&self) -> f64 {
        let exact = self.kernel.pixel_energies(&self.state.values);
        exact
            .iter()
            .zip(&self.state.energy)
            .map(|(&e, &cached)| (e - cached).abs())
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
        self.state.values.clone()
    }

    /// The current values.
    pub fn into_values(self) -> Vec<f32> {
        self.state.values
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
        let (k, state) = (&self.kernel, &self.state);
        let mut scratch = Scratch::new(k);
        match k.dims {
            1 => k.delta::<1>(state, z, a, b, &mut scratch).0,
            2 => k.delta::<2>(state, z, a, b, &mut scratch).0,
            3 => k.delta::<3>(state, z, a, b, &mut scratch).0,
            _ => k.delta::<4>(state, z, a, b, &mut scratch).0,
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
            let (k, state) = (&self.kernel, &mut self.state);
            let mut scratch = Scratch::new(k);
            match k.dims {
                1 => k.attempt::<1>(state, z, a, b, &mut scratch),
                2 => k.attempt::<2>(state, z, a, b, &mut scratch),
                3 => k.attempt::<3>(state, z, a, b, &mut scratch),
                _ => k.attempt::<4>(state, z, a, b, &mut scratch),
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
        let pass = self.passes;
        self.passes += 1;
        let layout = Layout {
            width: self.kernel.width,
            height: self.kernel.height,
            reach: self.kernel.reach(),
            target: tile_target,
            span_start: SpanStart::PassOffset,
        };
        let key = PassKey {
            seed: self.seed,
            streams: rng::VECTOR,
            pass,
        };
        let plan = PassPlan {
            fraction: fraction.clamp(0.0, 1.0),
            partner_candidates: partner_candidates(pass, self.partner_candidates),
            assignment,
        };
        schedule::run_pass(self, &layout, key, &plan, after_colour);
        TracePoint {
            swaps_attempted: self.attempted,
            swaps_accepted: self.accepted,
            energy: self.energy,
        }
    }

    /// A private copy of `tile`'s region of the state.
    fn extract(&self, tile: &Tile) -> Region {
        let dims = self.kernel.dims;
        let pixels = (tile.rw * tile.rh * self.kernel.depth) as usize;
        let mut values = Vec::with_capacity(pixels * dims);
        let mut energy = Vec::with_capacity(pixels);
        tile.region_runs(self.kernel.size(), |from, _, len| {
            values.extend_from_slice(&self.state.values[from * dims..(from + len) * dims]);
            energy.extend_from_slice(&self.state.energy[from..from + len]);
        });
        Region {
            steps: self.kernel.steps(tile.rw, tile.rh),
            values,
            energy,
        }
    }

    /// Writes a tile's copy of its region back: the values of the tile's pixels (the only ones
    /// its moves change) and the energies of the whole region.
    fn write_back_region(&mut self, tile: &Tile, region: &Region) {
        let dims = self.kernel.dims;
        let state = &mut self.state;
        tile.tile_runs(self.kernel.size(), |to, from, len| {
            state.values[to * dims..(to + len) * dims]
                .copy_from_slice(&region.values[from * dims..(from + len) * dims]);
        });
        tile.region_runs(self.kernel.size(), |to, from, len| {
            state.energy[to..to + len].copy_from_slice(&region.energy[from..from + len]);
        });
    }
}

impl TileOptimizer for SwapOptimizer {
    type Plan = PassPlan;
    type Outcome = TileOutcome;

    fn run_tile(&self, tile: &Tile, rng: ChaCha8Rng, plan: &PassPlan) -> TileOutcome {
        let mut region = self.extract(tile);
        let result = self.kernel.run_tile_fastest(&mut region, tile, rng, plan);
        TileOutcome { region, result }
    }

    fn write_back(&mut self, tile: &Tile, outcome: TileOutcome) {
        self.write_back_region(tile, &outcome.region);
        self.attempted += outcome.result.attempted;
        self.accepted += outcome.result.accepted;
        self.energy += outcome.result.delta;
    }
}

impl SwapKernel {
    /// The volume's width, height and depth.
    fn size(&self) -> (u32, u32, u32) {
        (self.width, self.height, self.depth)
    }

    /// [`SwapKernel::run_tile`] for this kernel's value dimension, compiled for AVX-512 or AVX2
    /// where the CPU has it. Those builds only widen the vector loops (16 or 8 `f32` lanes
    /// instead of SSE2's 4) and perform the same IEEE operations in the same order (Rust never
    /// fuses a multiply and an add), so all give identical bits (tested). AVX2 was 1.3–1.45×
    /// faster than SSE2 (64×64×32, 32 swaps per pixel: Vec2 1.16–1.20 s against 1.67–1.72 s,
    /// UnitVec3 0.94 s against 1.22–1.27 s); AVX-512 is 7–16% faster again (same size, one
    /// thread, four alternating runs, medians: Vec2 3.35 → 2.8 s, UnitVec3 2.7 → 2.5 s).
    fn run_tile_fastest(
        &self,
        region: &mut Region,
        tile: &Tile,
        rng: ChaCha8Rng,
        plan: &PassPlan,
    ) -> TileResult {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: `run_tile_avx512` only requires AVX-512F, which the CPU was just checked to
            // have.
            return unsafe { self.run_tile_avx512(region, tile, rng, plan) };
        }
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: `run_tile_avx2` only requires AVX2, which the CPU was just checked to have.
            return unsafe { self.run_tile_avx2(region, tile, rng, plan) };
        }
        self.run_tile_dims(region, tile, rng, plan)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn run_tile_avx512(
        &self,
        region: &mut Region,
        tile: &Tile,
        rng: ChaCha8Rng,
        plan: &PassPlan,
    ) -> TileResult {
        self.run_tile_dims(region, tile, rng, plan)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn run_tile_avx2(
        &self,
        region: &mut Region,
        tile: &Tile,
        rng: ChaCha8Rng,
        plan: &PassPlan,
    ) -> TileResult {
        self.run_tile_dims(region, tile, rng, plan)
    }

    #[inline(always)]
    fn run_tile_dims(
        &self,
        region: &mut Region,
        tile: &Tile,
        rng: ChaCha8Rng,
        plan: &PassPlan,
    ) -> TileResult {
        match self.dims {
            1 => self.run_tile::<1>(region, tile, rng, plan),
            2 => self.run_tile::<2>(region, tile, rng, plan),
            3 => self.run_tile::<3>(region, tile, rng, plan),
            _ => self.run_tile::<4>(region, tile, rng, plan),
        }
    }

    /// Proposes the swaps of one tile of one pass in every slice.
    #[inline(always)]
    fn run_tile<const D: usize>(
        &self,
        region: &mut Region,
        tile: &Tile,
        mut rng: ChaCha8Rng,
        plan: &PassPlan,
    ) -> TileResult {
        if plan.assignment >= 2 {
            return self.run_tile_assignment::<D>(region, tile, rng, plan);
        }
        let mut result = TileResult::default();
        let n = tile.pixels();
        if n < 2 {
            return result;
        }
        let mut scratch = Scratch::new(self);
        let count = ((plan.fraction * f64::from(n)).round() as usize).min(n as usize);
        let mut order: Vec<u32> = (0..n).collect();
        let pixel = |i: u32| tile.local(i);
        let in_slice = region_indices(tile);
        let slice = (tile.rw * tile.rh) as usize;
        for z in 0..self.depth {
            let base = z as usize * slice;
            order.shuffle(&mut rng);
            for &i in &order[..count] {
                let mut draw = || other_index(&mut rng, i, n);
                // The candidate whose value is nearest but not equal (swapping equal values
                // changes nothing, and spaces like ±1 have many), the first of equals.
                let mut j = draw();
                if plan.partner_candidates > 1 {
                    let value = region.value::<D>(base + in_slice[i as usize]);
                    let distance = |j: u32| {
                        let d = squared_distance(
                            &value,
                            &region.value::<D>(base + in_slice[j as usize]),
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
                if let Some(delta) = self.attempt::<D>(region, z, pixel(i), pixel(j), &mut scratch)
                {
                    result.accepted += 1;
                    result.delta += delta;
                }
            }
        }
        result
    }
}

/// Each pixel of `tile` (row by row) as an index within a slice of its region.
fn region_indices(tile: &Tile) -> Vec<usize> {
    (0..tile.pixels())
        .map(|i| {
            let (x, y) = tile.local(i);
            y as usize * tile.rw as usize + x as usize
        })
        .collect()
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
        region: &mut Region,
        tile: &Tile,
        mut rng: ChaCha8Rng,
        plan: &PassPlan,
    ) -> TileResult {
        let mut result = TileResult::default();
        let n = tile.pixels();
        if n < 2 {
            return result;
        }
        let k_max = plan.assignment as usize;
        let mut scratch = Scratch::new(self);
        let pixel = |i: u32| tile.local(i);
        let in_slice = region_indices(tile);
        let slice = (tile.rw * tile.rh) as usize;
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
            let base = z as usize * slice;
            order.shuffle(&mut rng);
            tile_values.clear();
            tile_values.extend(in_slice.iter().map(|&p| region.value::<D>(base + p)));
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
                    self.for_each_neighbour(&region.steps, (x, y, z), centre, |t, n| {
                        neighbours[t] = region.value::<D>(n);
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
                    let Region {
                        steps,
                        values,
                        energy,
                    } = &mut *region;
                    self.for_each_neighbour(steps, (x, y, z), centre, |t, nb| {
                        let vn = value_at::<D>(values, nb);
                        let change = weights[t]
                            * (f64::from(value_factor::<D>(squared_distance(&to, &vn), inv))
                                - f64::from(value_factor::<D>(squared_distance(&from, &vn), inv)));
                        energy[nb] += change;
                    });
                    energy[centre] = cost[r * k + perm[r]];
                }
                for (r, &i) in set.iter().enumerate() {
                    let to = old[perm[r]];
                    tile_values[i as usize] = to;
                    let centre = base + in_slice[i as usize];
                    region.values[centre * D..(centre + 1) * D].copy_from_slice(&to);
                }
            }
        }
        result
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::keyed_rng;
    use rand::RngExt;

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
        // Runs `tile` of pass `pass` on a copy of its region, as a pass would, and writes the
        // copy back.
        let run = |build: Build, o: &mut SwapOptimizer, tile: &Tile, pass: u64, plan: &PassPlan| {
            let mut region = o.extract(tile);
            let rng = keyed_rng(5, crate::rng::VECTOR.tile, pass, tile.id);
            let result = match build {
                Build::Portable => o.kernel.run_tile_dims(&mut region, tile, rng, plan),
                // SAFETY: the CPU has AVX2 (asserted above).
                Build::Avx2 => unsafe { o.kernel.run_tile_avx2(&mut region, tile, rng, plan) },
                // SAFETY: only pushed where the CPU has AVX-512F.
                Build::Avx512 => unsafe { o.kernel.run_tile_avx512(&mut region, tile, rng, plan) },
            };
            o.write_back_region(tile, &region);
            result
        };
        let bits = |o: &SwapOptimizer| -> (Vec<u32>, Vec<u64>) {
            (
                o.state.values.iter().map(|v| v.to_bits()).collect(),
                o.state.energy.iter().map(|e| e.to_bits()).collect(),
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
                rx0: 3,
                ry0: 5,
                ..Tile::whole(16, 12)
            };
            let mut portable = SwapOptimizer::new(&spec, start.clone());
            let mut simd: Vec<SwapOptimizer> = builds
                .iter()
                .map(|_| SwapOptimizer::new(&spec, start.clone()))
                .collect();
            // Three swap passes, then two assignment passes of up to 4 pixels per set.
            for pass in 0..5 {
                let plan = PassPlan {
                    fraction: 1.0,
                    partner_candidates: PARTNER_CANDIDATES,
                    assignment: if pass < 3 { 0 } else { 4 },
                };
                let a = run(Build::Portable, &mut portable, &tile, pass, &plan);
                assert!(a.accepted > 0, "{space:?}: no swap accepted");
                for (&build, o) in builds.iter().zip(&mut simd) {
                    let b = run(build, o, &tile, pass, &plan);
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
            let (k, state) = (&o.kernel, &o.state);
            let taps = k.spatial.len() + k.temporal.len();
            let probe = [0.25f32, -0.5];
            for z in 0..d {
                for y in 0..h {
                    for x in 0..w {
                        let centre = ((z * h + y) * w + x) as usize;
                        let mut fast = vec![f32::NAN; taps];
                        k.gather::<2>(state, (x, y, z), centre, &probe, &mut fast);
                        let mut each = vec![f32::NAN; taps];
                        k.for_each_neighbour(&state.steps, (x, y, z), centre, |t, n| {
                            each[t] = squared_distance(&probe, &state.value::<2>(n));
                        });
                        let bits = |v: &[f32]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
                        assert_eq!(bits(&fast), bits(&each), "{w}×{h}×{d} at ({x}, {y}, {z})");
                    }
                }
            }
        }
    }
}
