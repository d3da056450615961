//! Void-and-cluster (Ulichney 1993) over a 3D volume with the energy of an
//! [`EnergyKernel`]: the scalar STBN generator of the paper's §4.1.
//!
//! The three phases, as in the paper:
//! 1. A random initial pattern of `initial_density · N` on pixels; repeatedly move the tightest
//!    cluster (max energy among on pixels) to the largest void (min energy among off pixels) until
//!    they are the same pixel.
//! 2. Rank: remove tightest clusters from a copy of that pattern (ranks count down from the
//!    pattern size), restore it, then add largest voids, ranking upwards.
//! 3. Past half, the paper inverts the pattern and removes the tightest clusters of the inverted
//!    one. The inverted energy of an off pixel is `kernel total − energy`, so its tightest cluster
//!    is our largest void: phase 3 is phase 2's void filling continued to the end, with no inversion.
//!
//! Energies are fixed-point integers in the high 32 bits of a `u64` key whose low 32 bits are the
//! pixel's priority: a seeded random permutation of `1..=N`. Comparing keys compares energies and
//! breaks exact ties by that permutation — deterministic, and without the directional bias a
//! lowest-index tie-break has (visible as streaks when σ is tiny and every energy ties).
//!
//! Phase 1 terminates: each move changes the pattern energy by `E(void) − E(cluster) ≤ 0` and, on a
//! tie, lowers the sum of on pixels' priorities, so the pair strictly decreases lexicographically.

use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

use crate::extremum::{Extremum, ExtremumTree, ON_BIT};
use crate::kernel::{EnergyKernel, TapVisitor, Weight};
use crate::observe::Observer;
use crate::spec::MaskSpec;

/// Volumes of at least this many pixels (4 MiB of energy words) load each splat's footprint
/// before updating it (see [`EnergyField::toggle`]). Measured on the 2-core VM (BENCHMARKS.md):
/// the first pass costs 7–12% of the CPU time at 64×64×32, 64×64×64 and 128×128×32, whose
/// energies mostly stay in cache; at 128×128×64 it measured from 4% slower to 17% faster with the
/// neighbours' load, at 128×128×128 14% faster and at 256×256×128 21–26% faster.
const TOUCH_FIRST_PIXELS: usize = 1 << 20;

/// Energy keys and on/off state of every pixel.
#[derive(Clone)]
pub(crate) struct EnergyField<'k> {
    kernel: &'k EnergyKernel,
    width: u32,
    height: u32,
    /// Energy in bits 0..31, on bit in bit 31 ([`ON_BIT`]). The kernel keeps energies below
    /// `2^31`, so they never carry into the on bit.
    energy: Vec<u32>,
    /// Tie-break priority of each pixel.
    priority: &'k [u32],
}

impl<'k> EnergyField<'k> {
    /// All pixels off, zero energy; priorities from `priorities` (a permutation of `1..=N`).
    pub(crate) fn new(kernel: &'k EnergyKernel, spec: &MaskSpec, priority: &'k [u32]) -> Self {
        EnergyField {
            kernel,
            width: spec.width,
            height: spec.height,
            energy: vec![0; priority.len()],
            priority,
        }
    }

    /// Whether pixel `i` is on.
    pub(crate) fn is_on(&self, i: usize) -> bool {
        self.energy[i] & ON_BIT != 0
    }

    /// A tree of `extremum` over the current state.
    fn tree(&self, extremum: Extremum) -> ExtremumTree<'k> {
        ExtremumTree::new(extremum, &self.energy, self.priority)
    }

    /// Turns pixel `i` on or off, updating every affected key and the trees that track them.
    /// `i` must currently be in the other state.
    ///
    /// Turning a pixel on raises energies: that can only improve a max tree's members (and `i`
    /// joins it) and only worsen a min tree's (and `i` leaves it); turning off is the mirror
    /// image. Worsening costs one check per extremum-tree leaf a run of taps overlaps.
    ///
    /// In volumes of [`TOUCH_FIRST_PIXELS`] or more the splat is memory-bound (its ~25 runs are
    /// ~30 scattered cache lines), so a first pass only loads one word at each end of every run:
    /// those independent loads, a few hundred instructions in all, are in flight together, where
    /// the adding pass, ~50 instructions per run, kept only a few misses in flight.
    #[inline]
    pub(crate) fn toggle<const TREES: usize>(
        &mut self,
        i: usize,
        turn_on: bool,
        trees: [&mut ExtremumTree<'k>; TREES],
    ) {
        debug_assert_ne!(self.is_on(i), turn_on);
        let (w, h) = (self.width as usize, self.height as usize);
        let (x, y, z) = (i % w, (i / w) % h, i / (w * h));
        if self.energy.len() >= TOUCH_FIRST_PIXELS {
            // Bring the footprint's cache lines in together (see above).
            let mut touch = Touch {
                energy: &self.energy,
                sum: 0,
            };
            self.kernel
                .for_each_tap(x as u32, y as u32, z as u32, &mut touch);
            std::hint::black_box(touch.sum);
        }
        self.energy[i] ^= ON_BIT;
        let improves = trees
            .each_ref()
            .map(|t| (t.extremum() == Extremum::Max) == turn_on);
        let mut splat = Splat {
            energy: &mut self.energy,
            trees,
            improves,
            turn_on,
        };
        self.kernel
            .for_each_tap(x as u32, y as u32, z as u32, &mut splat);
    }

    /// The energy words' buffer, for reuse.
    fn into_energy(self) -> Vec<u32> {
        self.energy
    }

    /// The best member of `tree`.
    pub(crate) fn best(&self, tree: &mut ExtremumTree<'k>) -> Option<usize> {
        tree.best(&self.energy)
    }

    /// Energy of every pixel.
    #[cfg(test)]
    pub(crate) fn energies(&self) -> Vec<u32> {
        self.energy.iter().map(|e| e & !ON_BIT).collect()
    }

    /// Energies recomputed from scratch by splatting every on pixel.
    #[cfg(test)]
    pub(crate) fn recomputed_energies(&self) -> Vec<u32> {
        let (w, h) = (self.width as usize, self.height as usize);
        let mut energy = vec![0u64; self.energy.len()];
        for i in (0..self.energy.len()).filter(|&i| self.is_on(i)) {
            let (x, y, z) = (i % w, (i / w) % h, i / (w * h));
            self.kernel
                .for_each_tap(x as u32, y as u32, z as u32, &mut |j, weight| {
                    energy[j] += u64::from(weight)
                });
        }
        energy.into_iter().map(|e| e as u32).collect()
    }
}

/// The tap visitor of [`EnergyField::toggle`]: adds or removes one pixel's energy and tells the
/// trees.
struct Splat<'a, 'k, const TREES: usize> {
    energy: &'a mut [u32],
    trees: [&'a mut ExtremumTree<'k>; TREES],
    /// Per tree: whether this toggle can improve its members' keys.
    improves: [bool; TREES],
    turn_on: bool,
}

impl<const TREES: usize> TapVisitor for Splat<'_, '_, TREES> {
    #[inline(always)]
    fn visit(&mut self, j: usize, weight: Weight) {
        let e = if self.turn_on {
            self.energy[j] + weight
        } else {
            self.energy[j] - weight
        };
        self.energy[j] = e;
        for (tree, &improves) in self.trees.iter_mut().zip(&self.improves) {
            if !improves {
                tree.worsen(j);
            } else if (e & ON_BIT != 0) == self.turn_on {
                tree.update(j, e);
            }
        }
    }

    #[inline(always)]
    fn visit_run(&mut self, start: usize, weights: &[Weight]) {
        let energy = &mut self.energy[start..start + weights.len()];
        if self.turn_on {
            energy.iter_mut().zip(weights).for_each(|(e, &w)| *e += w);
        } else {
            energy.iter_mut().zip(weights).for_each(|(e, &w)| *e -= w);
        }
        for (tree, &improves) in self.trees.iter_mut().zip(&self.improves) {
            if !improves {
                // Members may only worsen, and the toggled pixel (touched by its own tap) leaves.
                tree.worsen_range(start, weights.len());
            } else {
                // Members (and the toggled pixel, which joins) may improve.
                for (at, &e) in energy.iter().enumerate() {
                    if (e & ON_BIT != 0) == self.turn_on {
                        tree.update(start + at, e);
                    }
                }
            }
        }
    }
}

/// The tap visitor that loads one word at each end of every run, so that the cache lines a splat
/// needs are requested together.
struct Touch<'a> {
    energy: &'a [u32],
    /// Folds the loaded words so they are not optimised away.
    sum: u32,
}

impl TapVisitor for Touch<'_> {
    #[inline(always)]
    fn visit(&mut self, j: usize, _: Weight) {
        self.sum ^= self.energy[j];
    }

    #[inline(always)]
    fn visit_run(&mut self, start: usize, weights: &[Weight]) {
        self.sum ^= self.energy[start] ^ self.energy[start + weights.len() - 1];
    }
}

/// Seeded random permutation of `1..=n` (tie-break priorities) and the initial on pixels.
fn seeded_start(spec: &MaskSpec) -> (Vec<u32>, Vec<u32>) {
    let n = spec.pixels() as usize;
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
    let mut priorities: Vec<u32> = (1..=n as u32).collect();
    priorities.shuffle(&mut rng);
    let mut order: Vec<u32> = (0..n as u32).collect();
    order.shuffle(&mut rng);
    let ones = ((spec.initial_density * n as f64).round() as usize).clamp(1, n);
    order.truncate(ones);
    order.shrink_to_fit();
    (priorities, order)
}

/// Ranks every pixel of the volume `0..N` in void-and-cluster order (global, not per slice).
///
/// `spec` must be valid ([`MaskSpec::validate`]). `observer` hears pixels ranked of the volume's
/// every few thousand ranks.
pub(crate) fn rank_pixels(spec: &MaskSpec, observer: &mut Observer<'_>) -> Vec<u32> {
    let kernel = EnergyKernel::new(spec);
    let n = spec.pixels() as usize;
    let (priorities, initial) = seeded_start(spec);
    let mut field = EnergyField::new(&kernel, spec, &priorities);
    // Phases 2b and 3 append each filled void (sequential stores) instead of a random store per
    // step; the ranks are scattered once at the end.
    let mut fill_order: Vec<u32> = Vec::new();
    let mut report = |ranked: usize| observer.report(ranked as u64, n as u64);

    // Phase 1: initial pattern, then move clusters into voids until stable.
    for &i in &initial {
        field.toggle(i as usize, true, []);
    }
    let ones = initial.len();
    {
        let mut clusters = field.tree(Extremum::Max);
        let mut voids = field.tree(Extremum::Min);
        loop {
            let cluster = field
                .best(&mut clusters)
                .expect("the pattern has on pixels");
            field.toggle(cluster, false, [&mut clusters, &mut voids]);
            let void = field.best(&mut voids).expect("the removed pixel is off");
            field.toggle(void, true, [&mut clusters, &mut voids]);
            if void == cluster {
                break;
            }
        }
    }
    report(0);

    // Phase 2a ranks the initial pattern by removing its tightest clusters; phases 2b and 3 fill
    // the largest voids of the same pattern until every pixel is on. Both start from the phase-1
    // state and share nothing mutable, so they run concurrently and deterministically.
    let mut pattern = field.clone();
    let mut removal_order = Vec::new();
    rayon::in_place_scope(|scope| {
        scope.spawn(|_| {
            let mut clusters = pattern.tree(Extremum::Max);
            removal_order.reserve_exact(ones);
            for _ in 0..ones {
                let cluster = pattern.best(&mut clusters).expect("pattern pixels remain");
                removal_order.push(cluster as u32);
                pattern.toggle(cluster, false, [&mut clusters]);
            }
        });
        let mut voids = field.tree(Extremum::Min);
        fill_order.reserve_exact(n - ones);
        for rank in ones..n {
            let void = field.best(&mut voids).expect("off pixels remain");
            fill_order.push(void as u32);
            field.toggle(void, true, [&mut voids]);
            if rank % 8192 == 0 {
                report(rank);
            }
        }
    });
    drop(pattern);
    // Every pixel gets a rank below, so the energy words' buffer can hold them.
    let mut ranks = field.into_energy();
    for (filled, &pixel) in fill_order.iter().enumerate() {
        ranks[pixel as usize] = (ones + filled) as u32;
    }
    for (removed, &pixel) in removal_order.iter().enumerate() {
        ranks[pixel as usize] = (ones - 1 - removed) as u32;
    }
    report(n);
    ranks
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::EnergyTopology;

    #[test]
    fn ranks_are_a_permutation() {
        for spec in [
            MaskSpec::new(1, 1, 1, 0),
            MaskSpec::new(2, 2, 2, 1),
            MaskSpec::new(17, 31, 5, 2),
            MaskSpec::new(16, 16, 8, 3).with_topology(EnergyTopology::Isotropic3D),
            MaskSpec::new(8, 8, 4, 4).with_sigma(0.05),
            MaskSpec::new(8, 8, 4, 5).with_sigma(1000.0),
        ] {
            let mut ranks = rank_pixels(&spec, &mut Observer::default());
            ranks.sort_unstable();
            assert!(
                ranks.iter().enumerate().all(|(i, &r)| r as usize == i),
                "{spec:?}"
            );
        }
    }

    fn assert_permutation(ranks: &[u32], what: &str) {
        let mut sorted = ranks.to_vec();
        sorted.sort_unstable();
        assert!(
            sorted.iter().enumerate().all(|(i, &r)| r as usize == i),
            "{what}: ranks are not a permutation"
        );
    }

    #[test]
    fn degenerate_and_lopsided_shapes_rank_every_pixel() {
        for (w, h, d) in [
            (1, 37, 1),
            (37, 1, 1),
            (1, 1, 37),
            (64, 64, 1),
            (1024, 2, 2),
            (2, 2, 512),
            (3, 1, 200),
        ] {
            let spec = MaskSpec::new(w, h, d, 5);
            assert_permutation(
                &rank_pixels(&spec, &mut Observer::default()),
                &format!("{w}x{h}x{d}"),
            );
        }
    }

    #[test]
    fn tiny_sigma_ties_have_no_directional_bias() {
        // At σ 0.05 every off-pixel energy ties at zero, so the order is the tie-break alone. An
        // index-order tie-break would rank pixels by position; the seeded permutation must not.
        let (w, h, d) = (64u32, 64u32, 4u32);
        let ranks = rank_pixels(
            &MaskSpec::new(w, h, d, 3).with_sigma(0.05),
            &mut Observer::default(),
        );
        let n = ranks.len() as f64;
        let mean = |pick: &dyn Fn(usize) -> bool| {
            let chosen: Vec<f64> = (0..ranks.len())
                .filter(|&i| pick(i))
                .map(|i| f64::from(ranks[i]) / n)
                .collect();
            chosen.iter().sum::<f64>() / chosen.len() as f64
        };
        let (w, h) = (w as usize, h as usize);
        // Halves by x, by y and by frame all average rank ≈ 0.5 (σ of such a mean ≈ 0.004).
        for (axis, pick) in [
            (
                "x",
                Box::new(|i: usize| i % w < w / 2) as Box<dyn Fn(usize) -> bool>,
            ),
            ("y", Box::new(|i: usize| (i / w) % h < h / 2)),
            ("frame", Box::new(|i: usize| i / (w * h) < 2)),
        ] {
            let m = mean(&*pick);
            assert!((m - 0.5).abs() < 0.02, "{axis}: first half mean rank {m}");
        }
    }

    #[test]
    fn energy_bookkeeping_is_exact_after_many_toggles() {
        // 24×20×12 has centres that splat without wrapping, centres that wrap only in z and
        // centres that wrap in x or y.
        let spec = MaskSpec::new(24, 20, 12, 9);
        let kernel = EnergyKernel::new(&spec);
        let (priorities, _) = seeded_start(&spec);
        let mut field = EnergyField::new(&kernel, &spec, &priorities);
        let mut voids = field.tree(Extremum::Min);
        let mut clusters = field.tree(Extremum::Max);
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut order: Vec<usize> = (0..field.energy.len()).collect();
        let scan = |field: &EnergyField, on: bool| {
            let keys = (0..field.energy.len())
                .filter(|&i| field.is_on(i) == on)
                .map(|i| (field.energy[i], priorities[i], i));
            let best = if on { keys.max() } else { keys.min() };
            best.map(|(_, _, i)| i)
        };
        for round in 0..40 {
            order.shuffle(&mut rng);
            for &i in &order[..order.len() / 3] {
                let turn_on = !field.is_on(i);
                field.toggle(i, turn_on, [&mut voids, &mut clusters]);
            }
            assert_eq!(
                field.energies(),
                field.recomputed_energies(),
                "round {round}"
            );
            // And the trees agree with scans.
            assert_eq!(field.best(&mut voids), scan(&field, false), "round {round}");
            assert_eq!(
                field.best(&mut clusters),
                scan(&field, true),
                "round {round}"
            );
        }
    }

    /// FNV-1a over the ranks' little-endian bytes: a digest stable across Rust releases.
    fn digest(ranks: &[u32]) -> u64 {
        ranks
            .iter()
            .flat_map(|r| r.to_le_bytes())
            .fold(0xcbf2_9ce4_8422_2325, |h, b| {
                (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
            })
    }

    #[test]
    fn output_is_pinned_to_the_generator_version() {
        // If this fails, the generator's output changed: bump `GENERATOR_VERSION` (so caches
        // regenerate) and record the new digest here.
        // Versions 2 to 5 and 7 to 11 changed only vector masks, version 6 only filter-adapted ones.
        let pinned: [(u32, u64); 11] = [
            (1, 0x6631_db07_e621_fb21),
            (2, 0x6631_db07_e621_fb21),
            (3, 0x6631_db07_e621_fb21),
            (4, 0x6631_db07_e621_fb21),
            (5, 0x6631_db07_e621_fb21),
            (6, 0x6631_db07_e621_fb21),
            (7, 0x6631_db07_e621_fb21),
            (8, 0x6631_db07_e621_fb21),
            (9, 0x6631_db07_e621_fb21),
            (10, 0x6631_db07_e621_fb21),
            (11, 0x6631_db07_e621_fb21),
        ];
        let spec = MaskSpec {
            kernel_tolerance: 1e-3,
            ..MaskSpec::new(32, 32, 16, 2026)
        };
        let ranks = rank_pixels(&spec, &mut Observer::default());
        let expected = pinned
            .iter()
            .find(|(version, _)| *version == crate::GENERATOR_VERSION)
            .map(|&(_, digest)| digest);
        assert_eq!(
            Some(digest(&ranks)),
            expected,
            "digest {:#018x}",
            digest(&ranks)
        );
    }

    #[test]
    fn identical_for_any_thread_count() {
        let spec = MaskSpec::new(32, 24, 12, 21);
        let with_threads = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| rank_pixels(&spec, &mut Observer::default()))
        };
        let one = with_threads(1);
        assert_eq!(one, with_threads(2));
        assert_eq!(one, with_threads(3));
    }

    #[test]
    fn same_seed_same_ranks_other_seed_other_ranks() {
        let spec = MaskSpec::new(16, 16, 4, 11);
        let a = rank_pixels(&spec, &mut Observer::default());
        assert_eq!(a, rank_pixels(&spec, &mut Observer::default()));
        let b = rank_pixels(&MaskSpec { seed: 12, ..spec }, &mut Observer::default());
        assert_ne!(a, b);
    }

    #[cfg(feature = "analysis")]
    #[test]
    fn reranking_slices_costs_almost_no_blueness() {
        use crate::Volume;
        use crate::analysis::{Field, spatial_low_band, temporal_low_band};
        let (w, h, d) = (64, 64, 32);
        let bands = |values: &[f64]| {
            let field = Field::new(w as usize, h as usize, d as usize, values).unwrap();
            (
                spatial_low_band(&field).unwrap(),
                temporal_low_band(&field).unwrap(),
            )
        };
        let ranks = rank_pixels(&MaskSpec::new(w, h, d, 7), &mut Observer::default());
        let n = ranks.len() as f64;
        let global: Vec<f64> = ranks.iter().map(|&r| f64::from(r) / n).collect();
        let reranked = Volume::from_global_ranks(w, h, d, &ranks).values();
        let (global_spatial, global_temporal) = bands(&global);
        let (spatial, temporal) = bands(&reranked);
        eprintln!(
            "global ranks: spatial {global_spatial:.6}, temporal {global_temporal:.6}; \
             re-ranked: spatial {spatial:.6}, temporal {temporal:.6}"
        );
        // Measured 0.044762 before and 0.044779 after: every slice takes an almost even share of
        // each global rank range, so re-ranking hardly moves any value.
        assert!(global_temporal < 0.15, "{global_temporal}");
        assert!(
            (temporal - global_temporal).abs() < 0.1 * global_temporal,
            "{global_temporal} → {temporal}"
        );
        assert!(
            (spatial - global_spatial).abs() < 0.1 * global_spatial,
            "{global_spatial} → {spatial}"
        );
    }
}
