//! Pair swaps ([module docs](super)): the exact local delta of swapping two pixels' values, the
//! update when a swap is kept, and a tile's proposals.

use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

use super::energy::{
    FACTOR_LANES, SwapKernel, squared_distance, value_factor, value_factors, weighted_sum,
};
use super::region::{Region, region_indices};
use super::{PassPlan, TileResult};
use crate::rng::nearest_partner;
use crate::schedule::Tile;

/// Per-task buffers of one swap evaluation of pixels `a` and `b`: one entry per neighbour tap of
/// either pixel (`a`'s taps first, then `b`'s, each in the kernel's tap order), padded with
/// zeros to whole [`FACTOR_LANES`].
///
/// A proposal only fills `after`; the neighbours' indices and `before` are gathered again by
/// [`SwapKernel::apply`] for the few proposals that are accepted.
pub(super) struct Scratch {
    /// The neighbour's index (filled by `apply`).
    pub(super) index: Vec<usize>,
    /// Pair weight of each tap (the kernel's, the same for every pixel); 0 in the padding.
    pub(super) weight: Vec<f64>,
    /// One pixel's tap weights, padded with zeros to whole [`FACTOR_LANES`]: its length is that
    /// of a padded row of one pixel's factors, and sums over such a row have no remainder to add
    /// one by one.
    pub(super) pixel_weight: Vec<f64>,
    /// Squared distance from the neighbour's value to its centre's value before and after the
    /// swap (for `a`'s neighbours `‖va − n‖²` and `‖vb − n‖²`; for `b`'s the other way round).
    pub(super) before: Vec<f32>,
    pub(super) after: Vec<f32>,
    /// Value factors of `before` or `after` (computed 8 or 16 lanes wide); 0 for the pair
    /// `(a, b)`.
    pub(super) factor: Vec<f32>,
    /// `weight · value factor` after the swap, then the change of the neighbour's energy.
    pub(super) term: Vec<f64>,
    /// Taps of one pixel (`a`'s entries are `..taps`); all entries (the buffers hold that many
    /// rounded up to whole lanes).
    pub(super) taps: usize,
    pub(super) len: usize,
    /// The entries of the pair `(a, b)` (`b` among `a`'s taps, `a` among `b`'s), if they
    /// interact, and the pair's energy `w_ab f_ab` (0 if not), which the swap leaves unchanged.
    pub(super) pair: Option<(usize, usize)>,
    pub(super) pair_energy: f64,
}

impl Scratch {
    pub(super) fn new(kernel: &SwapKernel) -> Scratch {
        let taps = kernel.spatial.len() + kernel.temporal.len();
        let len = 2 * taps;
        let padded = len.div_ceil(FACTOR_LANES) * FACTOR_LANES;
        let mut weight: Vec<f64> = kernel
            .spatial
            .iter()
            .map(|t| t.2)
            .chain(kernel.temporal.iter().map(|t| t.1))
            .collect();
        let mut pixel_weight = weight.clone();
        pixel_weight.resize(taps.div_ceil(FACTOR_LANES) * FACTOR_LANES, 0.0);
        weight.extend_from_within(..);
        weight.resize(padded, 0.0);
        Scratch {
            index: vec![0; padded],
            weight,
            pixel_weight,
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

impl SwapKernel {
    /// The exact energy change of swapping the values of pixels `a` and `b` of slice `z` of
    /// `region`, from the cached energies `e(a)`, `e(b)` and the pair energies after the swap.
    /// Leaves in `scratch` what [`SwapKernel::apply`] needs. Returns the delta and the two
    /// indices.
    ///
    /// `ΔE = Σ_{n ∈ N(a)∖b} w f(‖vb − vn‖²) − (e(a) − w_ab f_ab)` plus the same for `b`: the
    /// pairs of `a` and of `b` change, except the pair `(a, b)` (energy `w_ab f_ab`, symmetric).
    #[inline(always)]
    pub(super) fn delta<const D: usize, const L: usize>(
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
        value_factors::<D, L>(&scratch.after, &mut scratch.factor, inv);
        scratch.pair = self
            .spatial_tap(a, b)
            .zip(self.spatial_tap(b, a))
            .map(|(ka, kb)| (ka, taps + kb));
        scratch.drop_pair_factors();
        // Over the padding too (weight 0): whole chunks only.
        let after = weighted_sum(&scratch.weight, &scratch.factor);
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
    fn apply<const D: usize, const L: usize>(
        &self,
        region: &mut Region,
        z: u32,
        (a, b): ((u32, u32), (u32, u32)),
        (ia, ib): (usize, usize),
        scratch: &mut Scratch,
    ) {
        let (taps, count) = (scratch.taps, scratch.len);
        let e_a = weighted_sum(&scratch.weight[..taps], &scratch.factor);
        let e_b = weighted_sum(&scratch.weight[taps..count], &scratch.factor[taps..]);
        scratch.weigh();
        let (va, vb) = (region.value::<D>(ia), region.value::<D>(ib));
        for (centre, at, value, first) in [(ia, a, &va, 0), (ib, b, &vb, taps)] {
            let (index, before) = (&mut scratch.index, &mut scratch.before);
            self.for_each_neighbour(&region.steps, (at.0, at.1, z), centre, |k, n| {
                index[first + k] = n;
                before[first + k] = squared_distance(value, &region.value::<D>(n));
            });
        }
        value_factors::<D, L>(
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
    pub(super) fn attempt<const D: usize, const L: usize>(
        &self,
        region: &mut Region,
        z: u32,
        a: (u32, u32),
        b: (u32, u32),
        scratch: &mut Scratch,
    ) -> Option<f64> {
        let (delta, ia, ib) = self.delta::<D, L>(region, z, a, b, scratch);
        if delta < -self.margin {
            self.apply::<D, L>(region, z, (a, b), (ia, ib), scratch);
            Some(delta)
        } else {
            None
        }
    }
}

/// The pixel that tile pixel `i` proposes a swap with: of `candidates` other tile pixels drawn
/// uniformly ([`nearest_partner`]), the one whose value is nearest but not equal to `i`'s
/// (swapping equal values changes nothing, and spaces like ±1 have many), the first of equals.
/// The tile's pixel `t` holds `values[base + in_slice[t]]`.
///
/// Out of line: inlined into the tile loop, its loop reloaded its pointers from the stack every
/// candidate (64×64×32 Vec2, 64 swap passes, one thread, AVX2 build, alternating runs: 3.5 →
/// 3.4 s).
#[inline(never)]
fn partner<const D: usize>(
    rng: &mut ChaCha8Rng,
    i: u32,
    n: u32,
    candidates: u32,
    (values, in_slice, base): (&[[f32; D]], &[usize], usize),
) -> u32 {
    let value = values[base + in_slice[i as usize]];
    nearest_partner(rng, i, n, candidates, |j| {
        let d = squared_distance(&value, &values[base + in_slice[j as usize]]);
        if d > 0.0 { d } else { f32::INFINITY }
    })
}

impl SwapKernel {
    /// Proposes the swaps of one tile of one pass in every slice.
    #[inline(always)]
    pub(super) fn run_tile_swaps<const D: usize, const L: usize>(
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
        let mut scratch = Scratch::new(self);
        let count = ((plan.fraction * f64::from(n)).round() as usize).min(n as usize);
        let mut order: Vec<u32> = (0..n).collect();
        let pixel = |i: u32| tile.local(i);
        let in_slice = region_indices(tile);
        let slice = (tile.rw * tile.rh) as usize;
        for z in tile.inset_z..tile.inset_z + tile.d {
            let base = z as usize * slice;
            order.shuffle(&mut rng);
            for &i in &order[..count] {
                let values = region.values.as_chunks::<D>().0;
                let slice_pixels = (values, &in_slice[..], base);
                let j = partner(&mut rng, i, n, plan.partner_candidates, slice_pixels);
                result.attempted += 1;
                if let Some(delta) =
                    self.attempt::<D, L>(region, z, pixel(i), pixel(j), &mut scratch)
                {
                    result.accepted += 1;
                    result.delta += delta;
                }
            }
        }
        result
    }
}
