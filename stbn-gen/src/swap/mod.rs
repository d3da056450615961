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
//! the `f32` values (`value_factor`: a polynomial `exp` and a cube root from one second-order
//! step, within 4·10⁻⁴ of the exact factor); weights and sums are `f64`. Every energy, cached or
//! recomputed, goes through it, so "lowers the energy" is exact for the energy the optimiser
//! reports. It uses basic IEEE operations only (no platform `libm`, so the same bits everywhere)
//! and no branches, so the loops over a footprint vectorise: 16 lanes per instruction on x86-64
//! CPUs with AVX-512, 8 with AVX2 (detected at run time; the same operations in the same order,
//! so the same bits as the portable SSE2 build, tested).
//!
//! # Schedule
//!
//! A *pass* proposes, in every slice, one swap per pixel. Slices are cut into tiles about
//! [`TILE_TARGET`] pixels wide (never narrower than twice the kernel's reach), and the frames
//! into runs of about [`TILE_FRAMES`] (never fewer than twice the temporal reach; all frames
//! when the mask is too short for two runs), at a seeded random offset per pass, and the tiles
//! run on the crate's tile schedule: coloured 2 × 2 × 2, the tiles of one colour in parallel,
//! each on a private copy of its region (the tile widened by the reach on every axis) written
//! back after the colour, each drawing from its own ChaCha8 stream keyed by (seed, pass,
//! tile). The result is the same for any number of threads (tested). In a tile,
//! pixels propose in a seeded random order; a pixel draws a few other pixels of its tile
//! uniformly (with replacement; one in the first passes, up to [`PARTNER_CANDIDATES`] later, see
//! [`partner_candidates`]) and proposes a swap with the one whose value is nearest its own.
//!
//! Why the nearest value of a few candidates: swaps that lower the energy are rare and mostly
//! between similar values (among uniform proposals late in a run, the 5% between close values make
//! about three quarters of the accepted swaps), so proposals go to the nearest value of a few
//! candidates, in tiles wide enough to hold close values. In 128 passes that reaches a lower
//! filtered error than uniform partners reach in 1024. BENCHMARKS.md ("Design decisions") has the
//! figures and the alternatives measured against it.
//!
//! # Assignment passes
//!
//! [`crate::VectorSpec::assignment_passes`] of them run after the swap passes. A move
//! re-assigns the values of up to [`ASSIGNMENT_SET`] pixels of one slice at once. The pixels
//! hold similar values and do not interact with each other (no offset between two of them is a
//! tap), so permuting their values changes the energy by
//! `Σ_i c(p_i, v_π(i)) − Σ_i c(p_i, v_i)`, where `c(p, v) = Σ_{n ∈ N(p)} w f(‖v − Vn‖²)`: the
//! pixels' neighbours stay fixed, so the terms separate, and the best of all k! permutations is a
//! linear assignment problem, solved by the Hungarian method in O(k³). A pair swap is the case
//! k = 2. Where values have at most two parameters (every space but `Vec3` and `Vec4`), the
//! costs it is solved on are not the k² exact energies but each pixel's second-order model of
//! `c(p, ·)` around its own value (`model`), built from the same per-tap factors as `c(p, v_p)`;
//! the chosen permutation's energies are then computed exactly (one row per moved pixel).
//! Either way the permutation is kept only if its exact change is below `k` margins; the pixel
//! energies are updated as for a swap. Tiles are [`ASSIGNMENT_TILE_TARGET`] pixels wide and run
//! on the same schedule, so the passes are deterministic for any thread count (tested).
//!
//! Why: once the swap passes have run, improving swaps are scarce, but improving permutations of
//! similar values are not, and an assignment pass lowers the energy and the filtered error more
//! than the same time spent on swaps. The model picks permutations almost as good as the exact
//! costs' from at most 16 rows of factors (8 models, one row per moved pixel) instead of 64; in
//! 3- and 4-dimensional spaces similar values lie further apart and it is not good enough.
//! BENCHMARKS.md ("Vector masks", "Design decisions") has the figures and the split of the
//! default budget between the two moves.
//!
//! # Modules
//!
//! - `energy`: the pair weights ([`SwapKernel`]), the value factor, energies from scratch.
//! - `region`: the blocks of pixels a pass works on (the volume, or a tile's copy of its
//!   region) and the neighbours of a pixel in one.
//! - `pair`: exact swap deltas, the update of a kept swap, and a tile's proposals.
//! - `assignment`: the Hungarian method and a tile's assignment moves.
//! - `model`: the second-order model of a pixel's energy that ranks an assignment's permutations.
//! - `simd`: the tile loop compiled for AVX-512, AVX2 or the portable baseline.

mod assignment;
pub(crate) mod energy;
mod model;
mod pair;
mod region;
mod simd;
#[cfg(test)]
mod tests;

pub use assignment::{ASSIGNMENT_SET, ASSIGNMENT_TILE_TARGET, MAX_ASSIGNMENT};
#[cfg(test)]
use energy::FACTOR_LANES;
pub use energy::SwapKernel;
pub(crate) use simd::{Build, widest_build};

use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use crate::rng;
use crate::schedule::{self, Layout, PassKey, SpanStart, Tile, TileOptimizer};
use crate::trace::TracePoint;
#[cfg(test)]
use pair::Scratch;
use region::Region;

/// What the swap optimiser needs of a vector mask's spec: the volume's size, the value
/// dimension, the energy's parameters and the seed. A `&`[`crate::VectorSpec`] converts into it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SwapConfig {
    /// Pixels per row.
    pub width: u32,
    /// Rows per slice.
    pub height: u32,
    /// Slices.
    pub depth: u32,
    /// Components per value, `1..=4`.
    pub dims: usize,
    /// Parameters per value ([`crate::SampleSpace`]'s intrinsic dimension), `1..=dims`.
    pub parameters: usize,
    /// Seed of the tile grids and the proposals.
    pub seed: u64,
    /// σi in pixels (and frames), finite, `> 0`.
    pub sigma_image: f64,
    /// σs in value units, finite, `> 0`.
    pub sigma_value: f64,
    /// Pair weights below this are dropped, in `(0, 1)`.
    pub kernel_tolerance: f64,
}

/// Preferred tile side in pixels (tiles are never narrower than twice the kernel's reach): 16
/// gives [`PARTNER_CANDIDATES`] 255 pixels to choose from and still 4 tiles per colour at
/// 64 × 64, enough for the two cores here.
pub const TILE_TARGET: u32 = 16;

/// Preferred frames per tile of both moves (never fewer than twice the reach along time): 8
/// cuts a 32-frame mask into four runs, two per colour, so even a 64 × 64 × 32 mask's
/// assignment passes (one 32-pixel tile per colour in a frame) keep two cores busy.
pub const TILE_FRAMES: u32 = 8;

/// Candidates a proposing pixel draws from its tile once the optimiser is under way; it proposes
/// the one whose value is nearest its own ([module docs](self)). Pass `p` draws
/// `min(1 + p / 2, PARTNER_CANDIDATES)` ([`partner_candidates`]): a uniform partner first,
/// unless the start is already close ([`crate::InitialArrangement::ScalarStbnPerAxis`]).
pub const PARTNER_CANDIDATES: u32 = 16;

/// The candidates pass `pass` draws per proposal: with `ramp`, one more every two passes, up to
/// `cap`; without, `cap` from the first pass.
///
/// Early passes make the large moves a poor start needs, later ones the fine ones. From white
/// noise (32×32×16 Vec1, 16 passes) 16 candidates from the first pass left the spatial low band
/// at 0.397 against 0.071 for uniform partners; the ramp reached 0.069. From the Hilbert-order
/// start ([`crate::InitialArrangement::ScalarStbn`]) it also ends lower than 16 from the first
/// pass (64×64×32, 128 passes: Vec2 3.27557 against 3.27619, UnitVec3 1.60074 against 1.60173).
/// The per-axis start is close enough that uniform partners only undo it: BENCHMARKS.md ("Design
/// decisions").
pub fn partner_candidates(pass: u64, cap: u32, ramp: bool) -> u32 {
    let cap = cap.max(1);
    if ramp {
        (1 + pass / 2).min(u64::from(cap)) as u32
    } else {
        cap
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
    /// Moves proposed (swaps, or assignment sets).
    attempted: u64,
    /// Moves kept.
    accepted: u64,
    /// The kept moves' energy change, summed in the order they were made.
    delta: f64,
}

/// One tile's private copy of its region after its moves, and its totals.
pub(crate) struct TileOutcome {
    /// The region's values and pixel energies after the tile's moves.
    region: Region,
    /// The tile's totals.
    result: TileResult,
}

/// The optimiser's state: the values and pixel energies, the running energy and counters.
pub struct SwapOptimizer {
    /// The energy's weights and parameters.
    kernel: SwapKernel,
    /// The whole volume: the values and each pixel's energy `e(p)`
    /// ([`SwapKernel::pixel_energies`]), kept up to date by every accepted swap.
    state: Region,
    /// Seed of the tile grids and proposals.
    seed: u64,
    /// Passes run so far (swap and assignment passes): numbers the next pass's random streams.
    passes: u64,
    /// The running energy ([`SwapOptimizer::energy`]).
    energy: f64,
    /// Moves proposed so far.
    attempted: u64,
    /// Moves kept so far.
    accepted: u64,
    /// Most partner candidates a proposal draws.
    partner_candidates: u32,
    /// Whether the candidates ramp up from one ([`partner_candidates`]).
    partner_ramp: bool,
}

impl SwapOptimizer {
    /// An optimiser over `values` (`width · height · depth · dims` components, index
    /// `pixel · dims + c`) with the energy of `config`, which must come from a
    /// [validated](crate::VectorSpec::validate) spec (a `&VectorSpec` converts into one).
    ///
    /// Panics if the value count does not match the size.
    pub fn new(config: impl Into<SwapConfig>, values: Vec<f32>) -> SwapOptimizer {
        let config = config.into();
        let kernel = SwapKernel::new(config);
        let pixel_energy = kernel.pixel_energies(&values);
        let slice = kernel.slice_pixels();
        let per_slice: Vec<f64> = pixel_energy
            .par_chunks(slice)
            .map(|e| e.iter().sum::<f64>())
            .collect();
        let energy = 0.5 * per_slice.iter().sum::<f64>();
        SwapOptimizer {
            state: Region {
                steps: kernel.steps(kernel.size(), true),
                values,
                energy: pixel_energy,
            },
            kernel,
            seed: config.seed,
            passes: 0,
            energy,
            attempted: 0,
            accepted: 0,
            partner_candidates: PARTNER_CANDIDATES,
            partner_ramp: true,
        }
    }

    /// The same optimiser drawing [`PARTNER_CANDIDATES`] from the first pass, for a start that
    /// needs no large moves ([`partner_candidates`]).
    pub fn without_partner_ramp(mut self) -> SwapOptimizer {
        self.partner_ramp = false;
        self
    }

    /// The same optimiser drawing at most `count` partner candidates per proposal (1: a uniform
    /// partner). For experiments; the default is [`PARTNER_CANDIDATES`].
    #[cfg(test)]
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
    #[cfg(test)]
    pub fn recompute_energy(&self) -> f64 {
        self.kernel.energy(&self.state.values)
    }

    /// The largest difference between a cached pixel energy and its value computed from
    /// scratch: the rounding the incremental updates have accumulated.
    #[cfg(test)]
    pub fn pixel_energy_drift(&self) -> f64 {
        let exact = self.kernel.pixel_energies(&self.state.values);
        exact
            .iter()
            .zip(&self.state.energy)
            .map(|(&e, &cached)| (e - cached).abs())
            .fold(0.0, f64::max)
    }

    /// Swaps proposed so far.
    #[cfg(test)]
    pub fn swaps_attempted(&self) -> u64 {
        self.attempted
    }

    /// Swaps kept so far.
    #[cfg(test)]
    pub fn swaps_accepted(&self) -> u64 {
        self.accepted
    }

    /// A copy of the current values.
    #[cfg(test)]
    pub fn values(&self) -> Vec<f32> {
        self.state.values.clone()
    }

    /// The current values.
    pub fn into_values(self) -> Vec<f32> {
        self.state.values
    }

    /// Panics if pixel `(x, y)` of slice `z` is outside the volume.
    #[cfg(test)]
    fn check_pixel(&self, (x, y): (u32, u32), z: u32) {
        assert!(
            x < self.kernel.width && y < self.kernel.height && z < self.kernel.depth,
            "pixel ({x}, {y}, {z}) is outside the volume"
        );
    }

    /// The exact energy change swapping the values of pixels `a` and `b` (`(x, y)`) of slice
    /// `z` would make, computed locally. Panics if a pixel is outside the volume.
    #[cfg(test)]
    pub fn swap_delta(&self, z: u32, a: (u32, u32), b: (u32, u32)) -> f64 {
        self.check_pixel(a, z);
        self.check_pixel(b, z);
        let (k, state) = (&self.kernel, &self.state);
        let mut scratch = Scratch::new(k);
        match k.dims {
            1 => k.delta::<1, FACTOR_LANES>(state, z, a, b, &mut scratch).0,
            2 => k.delta::<2, FACTOR_LANES>(state, z, a, b, &mut scratch).0,
            3 => k.delta::<3, FACTOR_LANES>(state, z, a, b, &mut scratch).0,
            _ => k.delta::<4, FACTOR_LANES>(state, z, a, b, &mut scratch).0,
        }
    }

    /// Swaps the values of pixels `a` and `b` of slice `z` if that lowers the energy (by more than
    /// the rounding margin of the [module docs](self)), counting one attempt. Returns the
    /// accepted swap's delta (negative), `None` if the values stay. Panics if a pixel is outside
    /// the volume.
    #[cfg(test)]
    pub fn try_swap(&mut self, z: u32, a: (u32, u32), b: (u32, u32)) -> Option<f64> {
        self.check_pixel(a, z);
        self.check_pixel(b, z);
        let result = {
            let (k, state) = (&self.kernel, &mut self.state);
            let mut scratch = Scratch::new(k);
            match k.dims {
                1 => k.attempt::<1, FACTOR_LANES>(state, z, a, b, &mut scratch),
                2 => k.attempt::<2, FACTOR_LANES>(state, z, a, b, &mut scratch),
                3 => k.attempt::<3, FACTOR_LANES>(state, z, a, b, &mut scratch),
                _ => k.attempt::<4, FACTOR_LANES>(state, z, a, b, &mut scratch),
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
    /// Calls `after_colour` after each quarter of the pass's colour phases. Returns the totals
    /// after the pass.
    pub fn run_pass(&mut self, fraction: f64, after_colour: &mut dyn FnMut(&Self)) -> TracePoint {
        self.run_pass_with(fraction, 0, TILE_TARGET, after_colour)
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
    /// each quarter of the pass's colour phases.
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
            depth: self.kernel.depth,
            reach_frames: self.kernel.reach_frames(),
            target_frames: TILE_FRAMES,
            span_start: SpanStart::PassOffset,
        };
        let key = PassKey {
            seed: self.seed,
            streams: rng::VECTOR,
            pass,
        };
        let plan = PassPlan {
            fraction: fraction.clamp(0.0, 1.0),
            partner_candidates: partner_candidates(
                pass,
                self.partner_candidates,
                self.partner_ramp,
            ),
            assignment,
        };
        schedule::run_pass(self, &layout, key, &plan, after_colour);
        TracePoint {
            swaps_attempted: self.attempted,
            swaps_accepted: self.accepted,
            energy: self.energy,
        }
    }
}

impl TileOptimizer for SwapOptimizer {
    type Plan = PassPlan;
    type Outcome = TileOutcome;

    fn run_tile(&self, tile: &Tile, rng: ChaCha8Rng, plan: &PassPlan) -> TileOutcome {
        let mut region = self.state.tile_copy(&self.kernel, tile);
        let result = self.kernel.run_tile_fastest(&mut region, tile, rng, plan);
        TileOutcome { region, result }
    }

    fn write_back(&mut self, tile: &Tile, outcome: TileOutcome) {
        self.state.write_back(&self.kernel, tile, &outcome.region);
        self.attempted += outcome.result.attempted;
        self.accepted += outcome.result.accepted;
        self.energy += outcome.result.delta;
    }
}
