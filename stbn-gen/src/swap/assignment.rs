//! Assignment passes ([module docs](super)): sets of pixels with similar values that do not
//! interact get the best permutation of their values.

use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

use super::energy::{SwapKernel, squared_distance, value_factors, weighted_sum};
use super::model::{CostModel, ModelScratch};
use super::pair::Scratch;
use super::region::{Region, region_indices};
use super::{PassPlan, TileResult};
use crate::schedule::Tile;

/// Largest set of an assignment pass.
pub const MAX_ASSIGNMENT: u32 = 16;

/// Pixels per set of the assignment passes [`crate::generate_vector`] runs.
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
/// major, `k ≤` [`MAX_ASSIGNMENT`], every cost finite): the Hungarian method with potentials,
/// O(k³).
/// Deterministic: of equal candidates it takes the lowest column, as a scan in column order
/// does. Sets of up to [`ASSIGNMENT_SET`] pixels run an 8-lane build, larger ones a 16-lane one.
fn min_cost_assignment(cost: &[f64], k: usize, out: &mut [usize]) {
    debug_assert!(
        cost.iter().all(|c| c.is_finite()),
        "non-finite assignment costs"
    );
    if k <= ASSIGNMENT_SET as usize {
        hungarian::<{ ASSIGNMENT_SET as usize }>(cost, k, out);
    } else {
        hungarian::<{ MAX_ASSIGNMENT as usize }>(cost, k, out);
    }
}

/// [`min_cost_assignment`] with the columns in `N ≥ k` lanes: each step of the search runs over
/// every lane with selects instead of a branch per column, and the potentials of the rows
/// travel with their columns, so nothing is looked up through the assignment. Lanes `k..N`
/// are never free. Each potential gets the same operations in the same order as in a scan of
/// the free columns, so the same result, bit for bit, in 11% less time for assignment passes
/// (BENCHMARKS.md, "Design decisions").
#[inline(always)]
fn hungarian<const N: usize>(cost: &[f64], k: usize, out: &mut [usize]) {
    assert!(k <= N && cost.len() == k * k && out.len() == k);
    let inf = f64::INFINITY;
    // Column potentials, the row each column holds (rows from 1; 0 for none), the potential
    // of that row, and the column the search reached each column from (0 for the start).
    let mut v = [0.0f64; N];
    let mut row_of = [0usize; N];
    let mut u_of = [0.0f64; N];
    let mut way = [0usize; N];
    for i in 1..=k {
        // Row `i` enters at the method's dummy column 0, with potential 0.
        let mut u_new = 0.0f64;
        let mut minv = [inf; N];
        let mut free: [bool; N] = core::array::from_fn(|l| l < k);
        let mut j0 = 0usize;
        loop {
            let (i0, u0) = if j0 == 0 {
                (i, u_new)
            } else {
                free[j0 - 1] = false;
                (row_of[j0 - 1], u_of[j0 - 1])
            };
            let row = &cost[(i0 - 1) * k..i0 * k];
            let mut delta = inf;
            for l in 0..N {
                let c = if l < k { row[l] } else { inf };
                let cur = c - u0 - v[l];
                let better = free[l] && cur < minv[l];
                minv[l] = if better { cur } else { minv[l] };
                way[l] = if better { j0 } else { way[l] };
                delta = if free[l] { delta.min(minv[l]) } else { delta };
            }
            // The lowest free column at the least reduced cost (one is free while a row is
            // unassigned, and its reduced cost is finite).
            let mut least = 0u32;
            for l in 0..N {
                least |= u32::from(free[l] && minv[l] == delta) << l;
            }
            let j1 = 1 + least.trailing_zeros() as usize;
            u_new += delta;
            for l in 0..N {
                u_of[l] = if free[l] { u_of[l] } else { u_of[l] + delta };
                v[l] = if free[l] { v[l] } else { v[l] - delta };
                minv[l] = if free[l] { minv[l] - delta } else { minv[l] };
            }
            j0 = j1;
            if row_of[j0 - 1] == 0 {
                break;
            }
        }
        // Augment along the path back to the dummy column: each column takes the row (and its
        // potential) of the column the search came from.
        loop {
            let j1 = way[j0 - 1];
            (row_of[j0 - 1], u_of[j0 - 1]) = if j1 == 0 {
                (i, u_new)
            } else {
                (row_of[j1 - 1], u_of[j1 - 1])
            };
            j0 = j1;
            if j0 == 0 {
                break;
            }
        }
    }
    for (l, &row) in row_of[..k].iter().enumerate() {
        out[row - 1] = l;
    }
}

impl SwapKernel {
    /// `c(p, v_c) = Σ_n w f(‖v_c − Vn‖²)` for every value `v_c` of `values`: the energies pixel `p`
    /// would have holding each, from the values `neighbours` of its taps (in
    /// [`SwapKernel::for_each_neighbour`]'s order). Leaves each value's per-tap factors in
    /// `factors` (`taps` rounded up to whole [`FACTOR_LANES`](super::energy::FACTOR_LANES) per
    /// value, value-major), for the update of a kept permutation, and the energies in `costs`.
    #[inline(always)]
    fn pixel_costs<const D: usize, const L: usize>(
        &self,
        neighbours: &[[f32; D]],
        values: &[[f32; D]],
        (distances, factors): (&mut [f32], &mut [f32]),
        scratch: &Scratch,
        costs: &mut [f64],
    ) {
        let taps = scratch.taps;
        if taps == 0 {
            // A kernel with no taps (σ far below a pixel, or a 1 × 1 × 1 volume): no energy.
            costs.fill(0.0);
            return;
        }
        let padded = scratch.pixel_weight.len();
        let entries = values.len() * padded;
        for (row, value) in distances.chunks_exact_mut(padded).zip(values) {
            for (d, n) in row[..taps].iter_mut().zip(neighbours) {
                *d = squared_distance(value, n);
            }
            row[taps..].fill(0.0);
        }
        value_factors::<D, L>(
            &distances[..entries],
            &mut factors[..entries],
            self.inv_sigma_value_sq,
        );
        for (cost, row) in costs.iter_mut().zip(factors.chunks_exact(padded)) {
            *cost = weighted_sum(&scratch.pixel_weight, row);
        }
    }

    /// One tile of an assignment pass ([`super::SwapOptimizer::run_assignment_pass`]).
    #[inline(always)]
    pub(super) fn run_tile_assignment<const D: usize, const L: usize>(
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
        let scratch = Scratch::new(self);
        let pixel = |i: u32| tile.local(i);
        let in_slice = region_indices(tile);
        let slice = (tile.rw * tile.rh) as usize;
        let mut order: Vec<u32> = (0..n).collect();
        let mut near: Vec<u64> = Vec::with_capacity(n as usize);
        let mut close = vec![0u64; n as usize];
        let mut set: Vec<u32> = Vec::with_capacity(k_max);
        let mut cost = vec![0.0f64; k_max * k_max];
        let mut perm = vec![0usize; k_max];
        let mut tile_values: Vec<[f32; D]> = Vec::with_capacity(n as usize);
        // Per set pixel: its neighbours' values and indices, its energy with its own value and
        // with the value it takes, and its factors against each tap for each value
        // (`padded` per value; with the model, only its own and the one it takes).
        let padded = scratch.pixel_weight.len();
        let taps = scratch.taps;
        let weight32: Vec<f32> = scratch.pixel_weight.iter().map(|&w| w as f32).collect();
        let mut neighbours = vec![[0.0f32; D]; k_max * taps];
        let mut neighbour_index = vec![0usize; k_max * taps];
        let mut model_scratch = ModelScratch::new(padded, D);
        let mut factors = vec![0.0f32; k_max * k_max * padded];
        let slot = |r: usize, c: usize| (r * k_max + c) * padded..(r * k_max + c + 1) * padded;
        let mut distances = vec![0.0f32; k_max * padded];
        let mut own_energy = vec![0.0f64; k_max];
        let mut new_energy = vec![0.0f64; k_max];
        let mut set_values: Vec<[f32; D]> = Vec::with_capacity(k_max);
        let shortlist = ASSIGNMENT_SHORTLIST.min(n as usize);
        let moves = (n as usize).div_ceil(k_max);
        for z in tile.inset_z..tile.inset_z + tile.d {
            let base = z as usize * slice;
            order.shuffle(&mut rng);
            // Squared distance from an anchor's value within which to look for the nearest
            // values first (a speed-up only: the shortlist is the same for any reach).
            let mut reach = f32::INFINITY;
            tile_values.clear();
            tile_values.extend(in_slice.iter().map(|&p| region.value::<D>(base + p)));
            for &anchor in &order[..moves] {
                // The shortlist: the tile's values nearest the anchor's, nearest first (ties by
                // position in the tile), then greedily the ones that interact with none chosen.
                // Keys are `distance bits << 32 | position`: one integer comparison orders them
                // (distances are never negative, so their bits order as they do).
                let target = tile_values[anchor as usize];
                near.clear();
                near.extend(tile_values.iter().enumerate().map(|(j, v)| {
                    u64::from(squared_distance(&target, v).to_bits()) << 32 | j as u64
                }));
                // Most sets fill from the first few nearest, so those are selected and sorted
                // first, and the rest of the shortlist only when the set is still short: the
                // same order as sorting the whole shortlist. The first few are selected from
                // the keys within `reach` (distance bits at most its bits), packed into `close`
                // without a branch, when at least that many are (then they are the first few of
                // all), else from all.
                let first = ASSIGNMENT_FIRST_LOOK.min(near.len());
                let bound = u64::from(reach.to_bits()) << 32 | u64::from(u32::MAX);
                let mut within = 0;
                for &key in &near {
                    close[within] = key;
                    within += usize::from(key <= bound);
                }
                let from_close = within >= first;
                let candidates = if from_close {
                    &mut close[..within]
                } else {
                    &mut near[..]
                };
                if first < candidates.len() {
                    candidates.select_nth_unstable(first - 1);
                }
                candidates[..first].sort_unstable();
                // The next move's reach: twice this anchor's `first`-th squared distance.
                reach = 2.0 * f32::from_bits((candidates[first - 1] >> 32) as u32);
                set.clear();
                let take = |candidates: &[u64], set: &mut Vec<u32>| {
                    for &key in candidates {
                        let j = key as u32;
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
                take(&candidates[..first], &mut set);
                if set.len() < k_max && first < shortlist {
                    if from_close {
                        near.select_nth_unstable(first - 1);
                    }
                    let rest = &mut near[first..];
                    let more = (shortlist - first).min(rest.len());
                    if more < rest.len() {
                        rest.select_nth_unstable(more - 1);
                    }
                    rest[..more].sort_unstable();
                    take(&rest[..more], &mut set);
                }
                let k = set.len();
                if k < 2 {
                    continue;
                }
                // Each pixel's neighbour values are read once. Its energy with each of the set's
                // values is computed exactly, or, where values have at most two parameters,
                // predicted by its model ([`CostModel`]); the permutation of least cost is then
                // judged on exact energies.
                set_values.clear();
                set_values.extend(set.iter().map(|&j| tile_values[j as usize]));
                for (r, &i) in set.iter().enumerate() {
                    let (x, y) = pixel(i);
                    let centre = base + in_slice[i as usize];
                    let rows = r * taps..(r + 1) * taps;
                    let (values, index) =
                        (&mut neighbours[rows.clone()], &mut neighbour_index[rows]);
                    self.for_each_neighbour(&region.steps, (x, y, z), centre, |t, n| {
                        values[t] = region.value::<D>(n);
                        index[t] = n;
                    });
                    let row = &mut cost[r * k..(r + 1) * k];
                    if self.modelled_assignment {
                        let model = CostModel::build::<L>(
                            set_values[r],
                            values,
                            (&scratch.pixel_weight, &weight32),
                            self.inv_sigma_value_sq,
                            &mut factors[slot(r, r)],
                            &mut model_scratch,
                        );
                        own_energy[r] = model.energy;
                        for (cost, value) in row.iter_mut().zip(&set_values) {
                            *cost = model.predict(value);
                        }
                    } else {
                        let all = slot(r, 0).start..slot(r, k).start;
                        let buffers = (&mut distances[..], &mut factors[all]);
                        self.pixel_costs::<D, L>(values, &set_values, buffers, &scratch, row);
                        own_energy[r] = row[r];
                    }
                }
                min_cost_assignment(&cost[..k * k], k, &mut perm[..k]);
                result.attempted += 1;
                if perm[..k].iter().enumerate().all(|(r, &c)| r == c) {
                    continue;
                }
                // The exact change: each moved pixel's energy with its new value, less its own.
                let mut delta = 0.0;
                for r in (0..k).filter(|&r| perm[r] != r) {
                    new_energy[r] = if self.modelled_assignment {
                        let buffers = (&mut distances[..], &mut factors[slot(r, perm[r])]);
                        let (values, to) = (&neighbours[r * taps..(r + 1) * taps], perm[r]);
                        let mut energy = [0.0];
                        let value = &set_values[to..to + 1];
                        self.pixel_costs::<D, L>(values, value, buffers, &scratch, &mut energy);
                        energy[0]
                    } else {
                        cost[r * k + perm[r]]
                    };
                    delta += new_energy[r] - own_energy[r];
                }
                if delta >= -self.margin * k as f64 {
                    continue;
                }
                result.accepted += 1;
                result.delta += delta;
                // The neighbours' energies change by `w (f(to) − f(from))` per tap: both
                // factors are at hand (the set's pixels do not interact, so their neighbours
                // keep their values).
                for (r, &i) in set.iter().enumerate() {
                    if perm[r] == r {
                        continue;
                    }
                    let from = &factors[slot(r, r)][..taps];
                    let to = &factors[slot(r, perm[r])][..taps];
                    let index = &neighbour_index[r * taps..(r + 1) * taps];
                    for (t, &nb) in index.iter().enumerate() {
                        region.energy[nb] +=
                            scratch.weight[t] * (f64::from(to[t]) - f64::from(from[t]));
                    }
                    let centre = base + in_slice[i as usize];
                    region.energy[centre] = new_energy[r];
                }
                for (r, &i) in set.iter().enumerate() {
                    let to = set_values[perm[r]];
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
    use crate::VectorSpec;
    use crate::rng::keyed_rng;
    use crate::swap::SwapOptimizer;
    use rand::RngExt;

    /// The Hungarian method finds a permutation of least cost: checked against the least total
    /// over every permutation (a dynamic programme over subsets of columns) of random `k × k`
    /// matrices, `k` up to 16 (both lane widths), with ties (costs on a coarse grid); and the
    /// 8- and 16-lane builds pick the same permutation.
    #[test]
    fn min_cost_assignment_is_optimal() {
        // Least total over permutations: best[mask] for the first popcount(mask) rows taking
        // the columns of `mask`.
        fn least_total(cost: &[f64], k: usize) -> f64 {
            let mut best = vec![f64::INFINITY; 1 << k];
            best[0] = 0.0;
            for mask in 0..1usize << k {
                let row = mask.count_ones() as usize;
                if row == k || best[mask].is_infinite() {
                    continue;
                }
                for col in (0..k).filter(|c| mask & 1 << c == 0) {
                    let next = mask | 1 << col;
                    best[next] = best[next].min(best[mask] + cost[row * k + col]);
                }
            }
            best[(1 << k) - 1]
        }
        let mut rng = keyed_rng(3, 0, 0, 0);
        for k in 1..=16 {
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
                let best = least_total(&cost, k);
                assert!(
                    total(&perm) <= best + 1e-12,
                    "k {k}: {} > {best}",
                    total(&perm)
                );
                if k <= ASSIGNMENT_SET as usize {
                    let mut wide = vec![0; k];
                    hungarian::<{ MAX_ASSIGNMENT as usize }>(&cost, k, &mut wide);
                    assert_eq!(wide, perm, "k {k}: the lane widths disagree");
                }
            }
        }
    }

    /// A kernel without taps (σi far below a pixel, which validation refuses) has no energy:
    /// assignment passes keep every value where it is and report no change.
    #[test]
    fn assignment_passes_without_taps_change_nothing() {
        use crate::SampleSpace;
        let valid = VectorSpec::new(40, 36, 2, 4, SampleSpace::Vec { dims: 2 }).unoptimised();
        let start = crate::generate_vector(&valid, crate::Observer::default())
            .unwrap()
            .values()
            .to_vec();
        let spec = VectorSpec {
            sigma_image: 0.05,
            ..valid
        };
        let mut o = SwapOptimizer::new(&spec, start.clone());
        assert_eq!(o.kernel().spatial.len() + o.kernel().temporal.len(), 0);
        o.run_assignment_pass(ASSIGNMENT_SET, &mut |_| {});
        assert_eq!(o.values(), start);
        assert_eq!((o.energy(), o.swaps_accepted()), (0.0, 0));
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
                let start = crate::generate_vector(&spec, crate::Observer::default())
                    .unwrap()
                    .values()
                    .to_vec();
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
                let sorted = |v: &[f32]| crate::swap::tests::multiset(v, dims);
                let end = o.values();
                for z in 0..d as usize {
                    let range = z * slice..(z + 1) * slice;
                    assert_eq!(sorted(&start[range.clone()]), sorted(&end[range]));
                }
            }
        }
    }
}
