//! The energy of vector masks ([module docs](super)): the truncated pair weights
//! ([`SwapKernel`]), the value factor every energy goes through, and energies from scratch.

use std::array::from_fn;
use std::collections::BTreeMap;

use rayon::prelude::*;

use super::SwapConfig;
use crate::fastmath::{exp_neg, exp_neg_f32_lanes, inverse_cbrt_f32_lanes};
use crate::torus::canonical;

/// Independent partial sums of [`weighted_sum`], so the additions' latency does not bound its
/// loop (four did: two dependent chains of 2-lane additions in the AVX2 build).
const LANES: usize = 16;

/// Padding of the neighbour buffers: the value factor loop runs whole chunks of this many
/// entries (`f32` lanes of an AVX-512 register, two AVX2 ones).
pub(super) const FACTOR_LANES: usize = 16;

/// `‖v‖^(D/3)` of `N` vectors with squared norms `s`, for `D` value components, in single
/// precision.
#[inline(always)]
fn distance_power<const D: usize, const N: usize>(s: [f32; N]) -> [f32; N] {
    match D {
        // s^(1/6) = √s · s^(−1/3)
        1 => {
            let r = inverse_cbrt_f32_lanes(s);
            from_fn(|i| s[i].sqrt() * r[i])
        }
        // s^(1/3) = s · (s^(−1/3))²
        2 => {
            let r = inverse_cbrt_f32_lanes(s);
            from_fn(|i| (s[i] * r[i]) * r[i])
        }
        3 => s.map(f32::sqrt),
        // s^(2/3) = s · s^(−1/3)
        _ => {
            let r = inverse_cbrt_f32_lanes(s);
            from_fn(|i| s[i] * r[i])
        }
    }
}

/// The value factor `exp(−x)`, `x = ‖a − b‖^(D/3) / σs²`, from `s = ‖a − b‖²` (computed in `f32`
/// from the `f32` values, components in order), to a relative `4·10⁻⁴ · max(1, x)` for `x ≤ 86`
/// (beyond, it is `e^−87`): the cube root's error sets it; three components (no cube root) come
/// within 1.1·10⁻⁵.
///
/// This function *is* the energy's value term: every energy, cached or recomputed, goes through
/// it, so they agree to the rounding of the `f64` sums. Single precision evaluates 8 lanes per
/// AVX2 instruction instead of 4; together with a shorter polynomial (version 4's degree 7) that
/// made the optimiser about 1.4× faster than an `f64` version with a degree-9 polynomial
/// (64×64×32 Vec2, 16 swaps per pixel, AVX2, two runs each: 0.61–0.64 s against 0.88–0.89 s;
/// `f64` with [`exp_neg`]'s degree 12 and four Newton steps took 1.06 s). The loop over it is
/// bound by its number of operations, so the factor is no more accurate than the masks need
/// ([`crate::fastmath`]).
#[inline(always)]
pub(super) fn value_factor<const D: usize>(s: f32, inv_sigma_value_sq: f32) -> f32 {
    value_factor_lanes::<D, 1>([s], inv_sigma_value_sq)[0]
}

/// [`value_factor`] of `N` squared distances, each step for all lanes before the next.
#[inline(always)]
fn value_factor_lanes<const D: usize, const N: usize>(
    s: [f32; N],
    inv_sigma_value_sq: f32,
) -> [f32; N] {
    exp_neg_f32_lanes(value_argument_lanes::<D, N>(s, inv_sigma_value_sq))
}

/// The argument `x = ‖a − b‖^(D/3) / σs²` of the value factor `exp(−x)` of `N` squared
/// distances.
#[inline(always)]
fn value_argument_lanes<const D: usize, const N: usize>(
    s: [f32; N],
    inv_sigma_value_sq: f32,
) -> [f32; N] {
    distance_power::<D, N>(s).map(|x| x * inv_sigma_value_sq)
}

/// `Σ weight[k] · factor[k]` (the factor widened to `f64`) over the shorter of the two, with
/// [`LANES`] interleaved partial sums added pairwise at the end, then the entries past the last
/// whole chunk in order (a fixed order: deterministic): the energy of one pixel's taps.
#[inline(always)]
pub(super) fn weighted_sum(weight: &[f64], factor: &[f32]) -> f64 {
    let len = weight.len().min(factor.len());
    let (weight, factor) = (&weight[..len], &factor[..len]);
    let mut lanes = [0.0f64; LANES];
    let (weight_chunks, weight_rest) = weight.as_chunks::<LANES>();
    let (factor_chunks, factor_rest) = factor.as_chunks::<LANES>();
    for (w, f) in weight_chunks.iter().zip(factor_chunks) {
        accumulate(&mut lanes, w, f);
    }
    let rest = weight_rest.iter().zip(factor_rest);
    rest.fold(lanes_total(lanes), |s, (&w, &f)| s + w * f64::from(f))
}

/// `lanes[i] += weight[i] · factor[i]`, the factor widened to `f64`.
#[inline(always)]
fn accumulate(lanes: &mut [f64; LANES], weight: &[f64; LANES], factor: &[f32; LANES]) {
    for ((lane, &w), &f) in lanes.iter_mut().zip(weight).zip(factor) {
        *lane += w * f64::from(f);
    }
}

/// The sum of [`LANES`] partial sums, added pairwise (a fixed order).
#[inline(always)]
fn lanes_total(mut lanes: [f64; LANES]) -> f64 {
    let mut width = LANES / 2;
    while width > 0 {
        for i in 0..width {
            lanes[i] += lanes[i + width];
        }
        width /= 2;
    }
    lanes[0]
}

/// `‖a − b‖²` in single precision, components in order: the value distance every energy uses
/// (`(a − b)² = (b − a)²` exactly, so it is symmetric).
#[inline(always)]
pub(super) fn squared_distance<const D: usize>(a: &[f32; D], b: &[f32; D]) -> f32 {
    // From the first square, not from 0.0 + it: the same bits (a square is never −0), one
    // addition fewer.
    let mut s = (a[0] - b[0]) * (a[0] - b[0]);
    for c in 1..D {
        s += (a[c] - b[c]) * (a[c] - b[c]);
    }
    s
}

/// `factor[k] = value_factor(distance[k])` over whole chunks of [`FACTOR_LANES`] (the buffers
/// are padded). With `L = 1`, entry by entry, a loop the compiler widens to one vector per
/// iteration: one AVX-512 instruction per step for 16 entries. With `L > 1` (dividing
/// [`FACTOR_LANES`]), `L` entries a step at a time ([`value_factor_lanes`]): two independent
/// AVX2 instructions per step for 16, where the chain's latency, not the number of operations,
/// bounds the loop (64×64×32, 64 swap passes, AVX2: Vec2 2.1 → 1.7 s; SSE2 2.7 → 2.2 s; the
/// AVX-512 build compiles 16-lane arrays to shuffles and is faster entry by entry). The same
/// operations per entry either way: the same bits.
#[inline(always)]
pub(super) fn value_factors<const D: usize, const L: usize>(
    distance: &[f32],
    factor: &mut [f32],
    inv_sigma_value_sq: f32,
) {
    const { assert!(L >= 1 && FACTOR_LANES.is_multiple_of(L)) };
    if L == 1 {
        for (f, &s) in factor.iter_mut().zip(distance) {
            *f = value_factor::<D>(s, inv_sigma_value_sq);
        }
        return;
    }
    let (factor, _) = factor.as_chunks_mut::<L>();
    let (distance, _) = distance.as_chunks::<L>();
    for (f, &s) in factor.iter_mut().zip(distance) {
        *f = value_factor_lanes::<D, L>(s, inv_sigma_value_sq);
    }
}

/// [`value_factors`], also leaving each entry's argument `x` (the factor is `exp(−x)`) in
/// `argument`: the same operations for the factors, so the same bits.
#[inline(always)]
pub(super) fn value_factors_and_arguments<const D: usize, const L: usize>(
    distance: &[f32],
    (factor, argument): (&mut [f32], &mut [f32]),
    inv_sigma_value_sq: f32,
) {
    const { assert!(L >= 1 && FACTOR_LANES.is_multiple_of(L)) };
    let (factor, _) = factor.as_chunks_mut::<L>();
    let (argument, _) = argument.as_chunks_mut::<L>();
    let (distance, _) = distance.as_chunks::<L>();
    for ((f, x), &s) in factor.iter_mut().zip(argument.iter_mut()).zip(distance) {
        *x = value_argument_lanes::<D, L>(s, inv_sigma_value_sq);
        *f = exp_neg_f32_lanes(*x);
    }
}

/// Whether the pair weight `exp(−d²/σi²)` of σi `sigma_image` at distance 1 survives the
/// truncation at `tolerance`: the test [`SwapKernel::new`] makes of each tap, the same
/// arithmetic. Without it a pixel has no neighbour and no swap changes the energy.
pub(crate) fn keeps_unit_offset(sigma_image: f64, tolerance: f64) -> bool {
    let inv_si = 1.0 / (sigma_image * sigma_image);
    exp_neg(inv_si) >= tolerance
}

/// Whether the value factor ([`value_factor`]) of two values `dims` components each, at squared
/// distance `s`, with σs `sigma_value`, is below 1: where it is 1 at the space's largest
/// distance, it is 1 for every pair (the factor falls with the distance), and every arrangement
/// has the same energy.
pub(crate) fn value_factor_below_one(dims: usize, s: f32, sigma_value: f64) -> bool {
    let inv = (1.0 / (sigma_value * sigma_value)) as f32;
    let factor = match dims {
        1 => value_factor::<1>(s, inv),
        2 => value_factor::<2>(s, inv),
        3 => value_factor::<3>(s, inv),
        _ => value_factor::<4>(s, inv),
    };
    factor < 1.0
}

/// The truncated, folded pair weights of one vector mask's energy and the value factor's
/// parameters.
#[derive(Clone, Debug)]
pub struct SwapKernel {
    /// Pixels per row of the volume.
    pub(super) width: u32,
    /// Rows per slice.
    pub(super) height: u32,
    /// Slices.
    pub(super) depth: u32,
    /// Components per value, `1..=4`.
    pub(super) dims: usize,
    /// Same-slice neighbours: canonical `(dx, dy)` (never `(0, 0)`), weight.
    pub(super) spatial: Vec<(i32, i32, f64)>,
    /// Same-position neighbours: canonical `dz` (never 0), weight.
    pub(super) temporal: Vec<(i32, f64)>,
    /// Extremes of the spatial taps' `dx`.
    pub(super) dx_range: (i32, i32),
    /// Extremes of the spatial taps' `dy`.
    pub(super) dy_range: (i32, i32),
    /// The spatial tap of each offset in those ranges (row `dy`, column `dx`), `u32::MAX` where
    /// there is none.
    pub(super) tap_at_offset: Vec<u32>,
    /// `1/σs²` in single precision, as [`value_factor`] takes it.
    pub(super) inv_sigma_value_sq: f32,
    /// Deltas must be below `−margin` for a swap to be accepted.
    pub(super) margin: f64,
    /// Whether assignment passes rank permutations by each pixel's [`CostModel`](super::model)
    /// (values with at most two parameters) instead of exact energies.
    pub(super) modelled_assignment: bool,
}

impl SwapKernel {
    /// The kernel of `config`, which must come from a [validated](crate::VectorSpec::validate)
    /// spec (a `&VectorSpec` converts into one).
    pub fn new(config: impl Into<SwapConfig>) -> SwapKernel {
        let config = config.into();
        let (w, h, d) = (config.width, config.height, config.depth);
        let tol = config.kernel_tolerance;
        let inv_si = 1.0 / (config.sigma_image * config.sigma_image);
        // exp(−r²/σi²) ≥ tol ⇔ r ≤ σi √ln(1/tol); enumerate one pixel further and let exp_neg
        // decide, at most two periods per axis.
        let bound = (config.sigma_image * (1.0 / tol).ln().sqrt()).ceil() + 1.0;
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
        let (dx_range, dy_range) = (range(|t| t.0), range(|t| t.1));
        let columns = (dx_range.1 - dx_range.0 + 1) as usize;
        let mut tap_at_offset = vec![u32::MAX; columns * (dy_range.1 - dy_range.0 + 1) as usize];
        for (k, &(dx, dy, _)) in spatial.iter().enumerate() {
            let cell = (dy - dy_range.0) as usize * columns + (dx - dx_range.0) as usize;
            tap_at_offset[cell] = k as u32;
        }
        let mut kernel = SwapKernel {
            width: w,
            height: h,
            depth: d,
            dims: config.dims,
            dx_range,
            dy_range,
            tap_at_offset,
            spatial,
            temporal,
            inv_sigma_value_sq: (1.0 / (config.sigma_value * config.sigma_value)) as f32,
            margin: 0.0,
            modelled_assignment: config.parameters <= 2,
        };
        kernel.margin = Self::MARGIN * kernel.total_weight();
        kernel
    }

    /// The sum of every pair weight (spatial and temporal taps), dimensionless: a pixel's energy
    /// if every value factor were 1.
    pub fn total_weight(&self) -> f64 {
        self.spatial.iter().map(|t| t.2).sum::<f64>()
            + self.temporal.iter().map(|t| t.1).sum::<f64>()
    }

    /// The value factors' mean over the interacting pairs of a mask of energy `energy`
    /// ([`SwapOptimizer::energy`](super::SwapOptimizer::energy)): `energy / (½ · pixels ·`
    /// [`total_weight`](SwapKernel::total_weight)`)`, in `[e^−87, 1]`; `None` without pairs.
    pub fn mean_value_factor(&self, energy: f64) -> Option<f64> {
        let pixels = self.slice_pixels() as f64 * f64::from(self.depth);
        let pairs = 0.5 * pixels * self.total_weight();
        (pairs > 0.0).then(|| energy / pairs)
    }

    /// The energy change a swap must beat to be accepted, relative to
    /// [`total_weight`](SwapKernel::total_weight).
    pub const MARGIN: f64 = 1e-11;

    /// Largest `|dz|` of a temporal tap, in frames.
    pub fn reach_frames(&self) -> u32 {
        self.temporal
            .iter()
            .map(|t| t.0.unsigned_abs())
            .max()
            .unwrap_or(0)
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

    /// Pixels per slice.
    pub(super) fn slice_pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// The volume's width, height and depth.
    pub(super) fn size(&self) -> (u32, u32, u32) {
        (self.width, self.height, self.depth)
    }

    /// The mask's energy computed from scratch: `½ Σ_p e(p)` over the
    /// [pixel energies](SwapKernel::pixel_energies), summed per slice in parallel and then in
    /// slice order (deterministic).
    ///
    /// Panics if `values.len()` is not `width · height · depth · dims`.
    #[cfg(test)]
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

    /// [`SwapKernel::pixel_energies`] for `D` value components.
    fn pixel_energies_d<const D: usize>(&self, values: &[f32]) -> Vec<f64> {
        let (w, h) = (self.width as i64, self.height as i64);
        let slice = self.slice_pixels();
        let value = |i: usize| -> [f32; D] { std::array::from_fn(|c| values[i * D + c]) };
        let steps = self.steps(self.size(), true);
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

#[cfg(test)]
mod tests {
    use super::*;

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
                    worst < 4e-4,
                    "worst relative error {worst} at 1/σ² {inv_sigma_sq}"
                );
            }
        }
        assert_eq!(value_factor::<2>(0.0, 1.0), 1.0);
        assert_eq!(distance_power::<1, 1>([0.0]), [0.0]);
        assert_eq!(distance_power::<4, 1>([0.0]), [0.0]);
    }

    /// The 16-lane steps give every entry the bits of the entry-by-entry loop.
    #[test]
    fn value_factors_in_lanes_match_entry_by_entry() {
        fn check<const D: usize>() {
            let distance: Vec<f32> = (0..4 * FACTOR_LANES)
                .map(|i| (i as f32 * 0.37).powi(3) * 1e-2 + if i % 7 == 0 { 0.0 } else { 1e-30 })
                .collect();
            let (mut stepped, mut single) = (vec![0.0; distance.len()], vec![0.0; distance.len()]);
            value_factors::<D, FACTOR_LANES>(&distance, &mut stepped, 0.7);
            value_factors::<D, 1>(&distance, &mut single, 0.7);
            let bits = |v: &[f32]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&stepped), bits(&single), "D = {D}");
        }
        check::<1>();
        check::<2>();
        check::<3>();
        check::<4>();
    }
}
