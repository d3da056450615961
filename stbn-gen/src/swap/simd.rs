//! The tile loop compiled for the widest vector instructions the CPU has: AVX-512, AVX2 or the
//! portable x86-64 baseline (SSE2), chosen at run time. The builds differ only in how wide the
//! footprint loops run, never in the result (tested bit for bit).

use rand_chacha::ChaCha8Rng;

use super::energy::{FACTOR_LANES, SwapKernel};
use super::region::Region;
use super::{PassPlan, TileResult};
use crate::schedule::Tile;

/// A build of a tile loop.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Build {
    /// The portable x86-64 baseline (SSE2), or whatever the target has elsewhere.
    Portable,
    /// Compiled with AVX2 enabled.
    Avx2,
    /// Compiled with AVX-512F (and, for the filter-adapted scans, AVX-512BW) enabled; picked only
    /// where the CPU has both.
    Avx512,
}

/// The environment variable that caps the tile loop's build, for measuring a narrower machine
/// class on a wider one: `avx2` or `sse2` (any other value, or none, leaves the widest the CPU
/// has). Read once per process. All builds give the same bits, so it changes only the speed.
const SIMD_CAP_VARIABLE: &str = "STBN_SWAP_SIMD";

/// The widest build of the tile loops (this module's and the filter-adapted optimiser's) this CPU
/// runs, capped by [`SIMD_CAP_VARIABLE`]; decided once per process.
pub(crate) fn widest_build() -> Build {
    static CHOSEN: std::sync::OnceLock<Build> = std::sync::OnceLock::new();
    *CHOSEN.get_or_init(|| {
        let cap = match std::env::var(SIMD_CAP_VARIABLE).as_deref() {
            Ok("sse2") => Build::Portable,
            Ok("avx2") => Build::Avx2,
            _ => Build::Avx512,
        };
        #[cfg(target_arch = "x86_64")]
        {
            if cap == Build::Avx512
                && std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("avx512bw")
            {
                return Build::Avx512;
            }
            if cap != Build::Portable && std::arch::is_x86_feature_detected!("avx2") {
                return Build::Avx2;
            }
        }
        let _ = cap;
        Build::Portable
    })
}

impl SwapKernel {
    /// [`SwapKernel::run_tile`] for this kernel's value dimension, compiled for AVX-512 or AVX2
    /// where the CPU has it. Those builds only widen the vector loops (16 or 8 `f32` lanes
    /// instead of SSE2's 4) and perform the same IEEE operations in the same order (Rust never
    /// fuses a multiply and an add), so all give identical bits (tested). 64×64×32, 64 swap
    /// passes, two threads on a Zen 4 EPYC: Vec2 2.2–2.3 s (SSE2), 1.7 s (AVX2), 1.6 s
    /// (AVX-512); UnitVec3 1.9, 1.6 and 1.5 s.
    pub(super) fn run_tile_fastest(
        &self,
        region: &mut Region,
        tile: &Tile,
        rng: ChaCha8Rng,
        plan: &PassPlan,
    ) -> TileResult {
        match widest_build() {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `widest_build` picks AVX-512 only where the CPU has AVX-512F, all that
            // `run_tile_avx512` requires.
            Build::Avx512 => unsafe { self.run_tile_avx512(region, tile, rng, plan) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `widest_build` picks AVX2 only where the CPU has it, all that
            // `run_tile_avx2` requires.
            Build::Avx2 => unsafe { self.run_tile_avx2(region, tile, rng, plan) },
            _ => self.run_tile_dims::<FACTOR_LANES>(region, tile, rng, plan),
        }
    }

    /// [`SwapKernel::run_tile_dims`] compiled with AVX-512F enabled.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn run_tile_avx512(
        &self,
        region: &mut Region,
        tile: &Tile,
        rng: ChaCha8Rng,
        plan: &PassPlan,
    ) -> TileResult {
        self.run_tile_dims::<1>(region, tile, rng, plan)
    }

    /// [`SwapKernel::run_tile_dims`] compiled with AVX2 enabled.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn run_tile_avx2(
        &self,
        region: &mut Region,
        tile: &Tile,
        rng: ChaCha8Rng,
        plan: &PassPlan,
    ) -> TileResult {
        self.run_tile_dims::<FACTOR_LANES>(region, tile, rng, plan)
    }

    /// [`SwapKernel::run_tile`] for this kernel's value dimension, evaluating value factors `L`
    /// lanes a step at a time ([`super::energy::value_factors`]).
    #[inline(always)]
    fn run_tile_dims<const L: usize>(
        &self,
        region: &mut Region,
        tile: &Tile,
        rng: ChaCha8Rng,
        plan: &PassPlan,
    ) -> TileResult {
        match self.dims {
            1 => self.run_tile::<1, L>(region, tile, rng, plan),
            2 => self.run_tile::<2, L>(region, tile, rng, plan),
            3 => self.run_tile::<3, L>(region, tile, rng, plan),
            _ => self.run_tile::<4, L>(region, tile, rng, plan),
        }
    }

    /// The moves of one tile: swaps, or assignments for an assignment pass.
    #[inline(always)]
    fn run_tile<const D: usize, const L: usize>(
        &self,
        region: &mut Region,
        tile: &Tile,
        rng: ChaCha8Rng,
        plan: &PassPlan,
    ) -> TileResult {
        if plan.assignment >= 2 {
            self.run_tile_assignment::<D, L>(region, tile, rng, plan)
        } else {
            self.run_tile_swaps::<D, L>(region, tile, rng, plan)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::VectorSpec;
    use crate::rng::keyed_rng;
    use crate::swap::{PARTNER_CANDIDATES, SwapOptimizer};

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
        let mut builds = vec![Build::Avx2];
        if std::arch::is_x86_feature_detected!("avx512f") {
            builds.push(Build::Avx512);
        }
        // Runs `tile` of pass `pass` on a copy of its region, as a pass would, and writes the
        // copy back.
        let run = |build: Build, o: &mut SwapOptimizer, tile: &Tile, pass: u64, plan: &PassPlan| {
            let mut region = o.state.tile_copy(&o.kernel, tile);
            let rng = keyed_rng(5, crate::rng::VECTOR.tile, pass, tile.id);
            let result = match build {
                Build::Portable => {
                    o.kernel
                        .run_tile_dims::<FACTOR_LANES>(&mut region, tile, rng, plan)
                }
                // SAFETY: the CPU has AVX2 (asserted above).
                Build::Avx2 => unsafe { o.kernel.run_tile_avx2(&mut region, tile, rng, plan) },
                // SAFETY: only pushed where the CPU has AVX-512F.
                Build::Avx512 => unsafe { o.kernel.run_tile_avx512(&mut region, tile, rng, plan) },
            };
            o.state.write_back(&o.kernel, tile, &region);
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
            let start = crate::generate_vector(&spec, crate::Observer::default())
                .unwrap()
                .values()
                .to_vec();
            // One tile over the whole slice (interior pixels and wrapping ones): no other tile
            // runs beside it.
            let tile = Tile {
                x0: 3,
                y0: 5,
                rx0: 3,
                ry0: 5,
                ..Tile::whole(16, 12, 6)
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
}
