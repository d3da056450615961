//! The greedy swap optimiser of filter-adapted masks: exact integer energies and deltas, tiles
//! coloured 2 × 2 for deterministic parallel passes.
//!
//! # Energies
//!
//! Every pixel `x` holds a value and the kernel gives integer pair weights `g`; the energy is a
//! sum over ordered pairs `x ≠ y` of `g(x − y) · K(x, y)`, with one of two value kernels:
//!
//! - **Distance**: `K = −Σ_c |v_c(x) − v_c(y)|` with `v_c` the integer level (below 2¹⁴) of
//!   channel `c`: a scalar's rank, or a vector's projection ranks ([`super`]). Per channel,
//!   swapping the values `a = v(p)` and `b = v(q)` of two pixels of one frame changes the energy
//!   by exactly
//!
//!   ```text
//!   ΔE = 4 (s · Σ_r (g(p − r) − g(q − r)) · clamp(v(r) − lo, 0, len) + (g(0) − g(p − q)) · len)
//!   ```
//!
//!   with `lo = min(a, b)`, `len = |a − b|`, `s = sign(b − a)` and `r` over both footprints, the
//!   two pixels included (derived from `|a − v| − |b − v| = 2 clamp(v − lo, 0, len) − len` and
//!   `Σ_r g(p − r) = Σ_r g(q − r)`); a swap's delta is the sum over channels. Only neighbours
//!   whose levels lie between `a` and `b` contribute anything but a constant. Each delta scans
//!   both footprints: levels are kept per pixel column over all frames, so the temporal taps of
//!   one spatial tap are one contiguous run of `i16`, summed exactly in `i32` (vectorised), then
//!   multiplied by the spatial weight in `i64`. A proposal is *screened* first: its delta over
//!   the spatial taps of the 3 × 3 neighbourhood (all frames; about a tenth of the work at the
//!   default filters) must be below `screen · Σ_c len_c · Σ g`, or the proposal is dropped
//!   without scanning the rest. The screen only decides which proposals get a full, exact
//!   evaluation; a swap is kept only when its exact delta is negative.
//!
//! - **Product** (any space): `K = u(x)·u(y)`, the dot product of integer vectors. The optimiser
//!   keeps `φ_c(x) = Σ_y g(x − y) u_c(y)` (the origin included), and
//!   `ΔE = 2 δ·(φ(p) − φ(q)) + 2 |δ|² (g(0) − g(p − q))` with `δ = u(q) − u(p)`, an `O(dims)`
//!   evaluation; an accepted swap then adds `g(· − p) δ` to `φ` and subtracts `g(· − q) δ`.
//!   `φ` is held in `f64`, but the kernel's bound keeps every product and sum an integer below
//!   2⁵³, where `f64` arithmetic is exact (and vectorises).
//!
//! All deltas and energies are exact integers (`i128`), so the running energy equals a
//! from-scratch recomputation bit for bit after any number of swaps, in any order.
//!
//! # Schedule
//!
//! A pass proposes, in every frame, one swap per pixel. Frames are cut into tiles about
//! `Optimizer::TILE_TARGET` pixels wide (never narrower than twice the kernel's spatial reach)
//! at a seeded random offset per pass, and the tiles run on the crate's tile schedule, as the
//! vector swap optimiser's do: coloured 2 × 2, the tiles of one colour in parallel, each on
//! private copies of its value indices and of the energy's state over its region (the tile
//! widened by the reach, every frame: levels for the distance energy, `φ` for the product),
//! written back after the colour, each drawing from its own ChaCha8 stream keyed by (seed, pass,
//! tile). Nothing depends on the number of threads (tested). In a tile, each pixel proposes a
//! swap, in a seeded random order: for the distance energy with the pixel whose levels are
//! nearest its own among [`PARTNER_CANDIDATES`] drawn from the tile (swaps between similar values
//! are the ones that pay once the start is STBN, as for vector masks), for the product with a
//! uniformly drawn one.

use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::filters::{Kernel, ScanKernel};
#[cfg(test)]
use crate::rng::keyed_rng;
use crate::rng::{self, nearest_partner};
use crate::schedule::{self, Layout, PassKey, SpanStart, Tile, TileOptimizer};
use crate::swap::Build;

/// Spatial taps with `Δx² + Δy² ≤ CORE_RADIUS_SQUARED` (the pixel and its 8 neighbours, times
/// every temporal tap) form the screening core. Cores of radius √2, 2 and √8 reach the same
/// filtered error per pass at 128×128×64 (with uniform partners); the smallest costs the least.
pub(crate) const CORE_RADIUS_SQUARED: i32 = 2;

/// Candidates a proposing pixel draws from its tile (distance energy); it proposes the one whose
/// levels are nearest its own (least `Σ_c |a_c − b_c|`), as the vector swap optimiser does. At
/// 128×128×64 (seeds 1–3), 6 passes with 32 candidates beat 64 passes of uniform partners on
/// every figure of the report in under a third of the time; 16 candidates need 8 passes, 64 reach
/// lower spatial low bands but not a lower filtered error per second (BENCHMARKS.md).
pub(crate) const PARTNER_CANDIDATES: u32 = 32;

/// Most level channels of the distance energy: the 16 projection directions of 4D values.
pub(crate) const MAX_CHANNELS: usize = 16;

/// The energy's value kernel and its state.
pub(crate) enum Energy {
    /// `−Σ_c |a_c − b_c|` of integer levels.
    Distance {
        kernel: ScanKernel,
        /// Level channels per value, `1..=`[`MAX_CHANNELS`].
        dims: usize,
        /// The levels (`< 2¹⁴`) of each value, index `((z · slice) + i) · dims + c`.
        levels: Vec<i16>,
        /// Per term, the number of leading spatial taps in the screening core.
        core: Vec<usize>,
        /// Screening threshold in units of `len · Σ g`; `None` disables screening.
        screen: Option<f64>,
    },
    /// The dot product of integer vectors.
    Product {
        kernel: Kernel,
        dims: usize,
        /// Integer components, index `((z · slice) + i) · dims + c`.
        table: Vec<i32>,
        /// `φ_c(x)`, index `c · pixels + x`: integers, exact in `f64`.
        phi: Vec<f64>,
    },
}

/// A rectangle of columns (every frame) of the distance energy's levels: `cols[((c · rh + y) ·
/// rw + x) · 2·depth + k]` holds component `c` of frame `k mod depth`, so any window of up to
/// `depth` frames from any start is contiguous.
pub(crate) struct Columns {
    cols: Vec<i16>,
    rw: usize,
    rh: usize,
    wrap_x: bool,
    wrap_y: bool,
    depth: usize,
}

impl Columns {
    #[inline(always)]
    fn offset(&self, c: usize, (x, y): (usize, usize)) -> usize {
        ((c * self.rh + y) * self.rw + x) * 2 * self.depth
    }

    #[inline(always)]
    fn column(&self, c: usize, x: usize, y: usize) -> &[i16] {
        let k = self.offset(c, (x, y));
        &self.cols[k..k + 2 * self.depth]
    }

    fn set(&mut self, c: usize, at: (usize, usize), z: usize, level: i16) {
        let k = self.offset(c, at);
        self.cols[k + z] = level;
        self.cols[k + z + self.depth] = level;
    }

    fn get(&self, c: usize, at: (usize, usize), z: usize) -> i16 {
        self.cols[self.offset(c, at) + z]
    }
}

/// `Σ_t T[t] · (clamp(v[t] − lo, 0, len) − half)`, exact in `i32` for `|T| ≤ 2¹⁴`, `ΣT ≤ 2¹⁴` and
/// levels below 2¹⁴. Written so the compiler vectorises it (`pmaddwd`).
#[inline(always)]
fn window_dot(t: &[i16], v: &[i16], lo: i16, len: i16, half: i16) -> i32 {
    let mut acc = 0i32;
    for (&a, &b) in t.iter().zip(v) {
        let c = b.wrapping_sub(lo).max(0).min(len).wrapping_sub(half);
        acc = acc.wrapping_add(i32::from(a).wrapping_mul(i32::from(c)));
    }
    acc
}

/// `Σ_r g(p − r) · clamp(v_c(r) − lo, 0, len)` over the spatial taps `taps(term)` of every term,
/// for component `c` of pixel `(px, py)` (region coordinates) of frame `z`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn scan(
    kernel: &ScanKernel,
    columns: &Columns,
    c: usize,
    taps: impl Fn(usize) -> std::ops::Range<usize>,
    z: usize,
    (px, py): (usize, usize),
    lo: i16,
    len: i16,
) -> i64 {
    let half = len >> 1;
    let d = columns.depth as i64;
    let mut total = 0i64;
    for (k, term) in kernel.terms.iter().enumerate() {
        let start = (z as i64 + i64::from(term.t0)).rem_euclid(d) as usize;
        let window = term.temporal.len();
        let offset = i64::from(half) * term.temporal_sum;
        for &(dx, dy, s) in &term.spatial[taps(k)] {
            let x = px as i64 + i64::from(dx);
            let y = py as i64 + i64::from(dy);
            let x = if columns.wrap_x {
                x.rem_euclid(columns.rw as i64)
            } else {
                x
            } as usize;
            let y = if columns.wrap_y {
                y.rem_euclid(columns.rh as i64)
            } else {
                y
            } as usize;
            let col = &columns.column(c, x, y)[start..start + window];
            let acc = window_dot(&term.temporal, col, lo, len, half);
            total += s * (i64::from(acc) + offset);
        }
    }
    total
}

/// `φ_c(x) += sign · step_c · g(x − p)` for every `x` in the footprint of pixel `p` (region
/// coordinates) of frame `z`, in a region `rw × rh` of `φ` (layout `((c · depth + z) · rh + y) ·
/// rw + x`).
#[allow(clippy::too_many_arguments)]
fn splat(
    kernel: &Kernel,
    phi: &mut [f64],
    (rw, rh, wrap_x, wrap_y): (usize, usize, bool, bool),
    z: usize,
    (px, py): (usize, usize),
    step: &[i64],
    sign: f64,
) {
    let depth = kernel.depth as usize;
    let plane = depth * rh * rw;
    for (c, &s) in step.iter().enumerate() {
        if s == 0 {
            continue;
        }
        let s = sign * s as f64;
        for term in &kernel.terms {
            for &(dz, t) in &term.temporal {
                let zz = (z as i64 + i64::from(dz)).rem_euclid(depth as i64) as usize;
                let coef = s * t;
                let frame = c * plane + zz * rh * rw;
                for row in &term.rows {
                    let y = py as i64 + i64::from(row.dy);
                    let y = if wrap_y { y.rem_euclid(rh as i64) } else { y } as usize;
                    let line = &mut phi[frame + y * rw..frame + (y + 1) * rw];
                    let x = px as i64 + i64::from(row.dx0);
                    let len = row.weights.len();
                    if !wrap_x {
                        let x = x as usize;
                        for (f, &g) in line[x..x + len].iter_mut().zip(&row.weights) {
                            *f += coef * g;
                        }
                    } else {
                        let x = x.rem_euclid(rw as i64) as usize;
                        let first = len.min(rw - x);
                        for (f, &g) in line[x..x + first].iter_mut().zip(&row.weights) {
                            *f += coef * g;
                        }
                        for (f, &g) in line[..len - first].iter_mut().zip(&row.weights[first..]) {
                            *f += coef * g;
                        }
                    }
                }
            }
        }
    }
}

/// A tile's private copies: its value indices (`(z · h + y) · w + x`, tile-local) and the region
/// state of the energy.
struct Work {
    /// Per tile pixel, the index of its value in its frame's values.
    perm: Vec<u32>,
    /// The energy's state over the tile's region.
    region: Region,
}

/// The energy's state over a tile's region.
enum Region {
    /// The levels ([`Columns`]).
    Distance(Columns),
    /// `φ` over the region ([`splat`]'s layout).
    Product(Vec<f64>),
}

/// One tile's copies after its swaps, and its totals.
pub(crate) struct TileOutcome {
    /// The tile's copies after its swaps.
    work: Work,
    /// The tile's totals.
    result: TileResult,
}

/// Totals of one tile's work.
#[derive(Default)]
struct TileResult {
    /// Swaps proposed.
    attempted: u64,
    /// Proposals evaluated in full (past the screen).
    screened: u64,
    /// Swaps kept.
    accepted: u64,
    /// The kept swaps' exact energy change.
    delta: i128,
}

/// The optimiser's state ([module docs](self)).
pub(crate) struct Optimizer {
    energy_state: Energy,
    width: usize,
    height: usize,
    depth: usize,
    reach: (u32, u32),
    /// Per pixel, the index of its value in its frame's values.
    perm: Vec<u32>,
    seed: u64,
    passes: u64,
    attempted: u64,
    screened: u64,
    accepted: u64,
    /// Energy relative to the start (distance) or absolute (product).
    energy: i128,
    /// Candidates per proposal of the distance energy ([`PARTNER_CANDIDATES`]; 1: uniform).
    partner_candidates: u32,
}

impl Optimizer {
    /// Preferred tile side in pixels. Tiles of 32 reach the same filtered error per pass at
    /// 128×128×64 (with uniform partners, BENCHMARKS.md).
    pub const TILE_TARGET: u32 = 16;

    /// An optimiser over `perm` (per pixel, the index of its value in its frame) for `energy`, of
    /// a `width × height × depth` mask.
    pub fn new(
        energy: Energy,
        (width, height, depth): (u32, u32, u32),
        perm: Vec<u32>,
        seed: u64,
    ) -> Self {
        let (width, height, depth) = (width as usize, height as usize, depth as usize);
        assert_eq!(perm.len(), width * height * depth, "one index per pixel");
        let reach = match &energy {
            Energy::Distance { kernel, dims, .. } => {
                assert!((1..=MAX_CHANNELS).contains(dims), "{dims} level channels");
                kernel.reach
            }
            Energy::Product { kernel, .. } => kernel.reach,
        };
        let mut optimizer = Optimizer {
            energy_state: energy,
            width,
            height,
            depth,
            reach,
            perm,
            seed,
            passes: 0,
            attempted: 0,
            screened: 0,
            accepted: 0,
            energy: 0,
            partner_candidates: PARTNER_CANDIDATES,
        };
        if let Energy::Product { .. } = optimizer.energy_state {
            let phi = optimizer.field_from_scratch();
            optimizer.energy = optimizer.product_energy(&phi);
            if let Energy::Product { phi: kept, .. } = &mut optimizer.energy_state {
                *kept = phi;
            }
        }
        optimizer
    }

    /// The same optimiser drawing `count` partner candidates per proposal (1: a uniform
    /// partner). For experiments; the default is [`PARTNER_CANDIDATES`].
    #[cfg(test)]
    pub fn with_partner_candidates(mut self, count: u32) -> Self {
        self.partner_candidates = count.max(1);
        self
    }

    fn slice(&self) -> usize {
        self.width * self.height
    }

    fn pixels(&self) -> usize {
        self.slice() * self.depth
    }

    /// Per pixel, the index of its value in its frame's values.
    pub fn perm(&self) -> &[u32] {
        &self.perm
    }

    /// Consumes the optimiser, returning [`Optimizer::perm`].
    pub fn into_perm(self) -> Vec<u32> {
        self.perm
    }

    /// The running energy: the product energy, or the distance energy relative to the start;
    /// every accepted swap adds its exact delta.
    pub fn energy(&self) -> i128 {
        self.energy
    }

    /// Swaps proposed so far.
    pub fn swaps_attempted(&self) -> u64 {
        self.attempted
    }

    /// Proposals that passed the screen (distance) so far; every proposal for the product.
    #[cfg(test)]
    pub fn swaps_screened(&self) -> u64 {
        self.screened
    }

    /// Swaps kept so far.
    pub fn swaps_accepted(&self) -> u64 {
        self.accepted
    }

    /// `φ` of the current values from scratch (product energy; empty for the distance energy):
    /// per term, a spatial convolution of each frame, then a temporal one.
    pub fn field_from_scratch(&self) -> Vec<f64> {
        let Energy::Product {
            kernel,
            dims,
            table,
            ..
        } = &self.energy_state
        else {
            return Vec::new();
        };
        let (w, h, d, dims) = (self.width, self.height, self.depth, *dims);
        let slice = self.slice();
        let pixels = self.pixels();
        let mut phi = vec![0.0; dims * pixels];
        for (c, out) in phi.chunks_mut(pixels).enumerate() {
            let values: Vec<f64> = (0..pixels)
                .map(|x| f64::from(table[((x / slice) * slice + self.perm[x] as usize) * dims + c]))
                .collect();
            for term in &kernel.terms {
                // ψ_z = S ∗ u_z, circular in x and y.
                let mut psi = vec![0.0; pixels];
                psi.par_chunks_mut(slice)
                    .zip(values.par_chunks(slice))
                    .for_each(|(dst, src)| {
                        for row in &term.rows {
                            for y in 0..h {
                                let sy =
                                    (y as i64 + i64::from(row.dy)).rem_euclid(h as i64) as usize;
                                let src_row = &src[sy * w..(sy + 1) * w];
                                let dst_row = &mut dst[y * w..(y + 1) * w];
                                for (i, &s) in row.weights.iter().enumerate() {
                                    if s == 0.0 {
                                        continue;
                                    }
                                    let dx = (i64::from(row.dx0) + i as i64).rem_euclid(w as i64)
                                        as usize;
                                    // dst[x] += s · src[(x + dx) mod w], in two runs.
                                    let (head, tail) = dst_row.split_at_mut(w - dx);
                                    for (t, &v) in head.iter_mut().zip(&src_row[dx..]) {
                                        *t += s * v;
                                    }
                                    for (t, &v) in tail.iter_mut().zip(&src_row[..dx]) {
                                        *t += s * v;
                                    }
                                }
                            }
                        }
                    });
                // φ_z += Σ_Δt T(Δt) ψ_{z+Δt}.
                out.par_chunks_mut(slice).enumerate().for_each(|(z, dst)| {
                    for &(dz, t) in &term.temporal {
                        let sz = (z as i64 + i64::from(dz)).rem_euclid(d as i64) as usize;
                        for (o, &p) in dst.iter_mut().zip(&psi[sz * slice..(sz + 1) * slice]) {
                            *o += t * p;
                        }
                    }
                });
            }
        }
        phi
    }

    /// `Σ_x u(x)·φ(x) − g(0) Σ_x |u(x)|²` for the field `phi` of the current values.
    fn product_energy(&self, phi: &[f64]) -> i128 {
        let Energy::Product {
            kernel,
            dims,
            table,
            ..
        } = &self.energy_state
        else {
            unreachable!("product energy of a product optimiser");
        };
        let g0 = i128::from(kernel.same_frame.get(0, 0));
        let (slice, pixels, dims) = (self.slice(), self.pixels(), *dims);
        (0..self.depth)
            .into_par_iter()
            .map(|z| {
                let mut sum = 0i128;
                for x in z * slice..(z + 1) * slice {
                    for c in 0..dims {
                        let u = i128::from(table[(z * slice + self.perm[x] as usize) * dims + c]);
                        sum += u * i128::from(phi[c * pixels + x] as i64) - g0 * u * u;
                    }
                }
                sum
            })
            .sum()
    }

    /// The energy of the current values computed from scratch, absolute: `O(pixels · taps)`
    /// for the distance energy (where [`Optimizer::energy`] is relative to the start).
    #[cfg(test)]
    pub fn recompute_energy(&self) -> i128 {
        match &self.energy_state {
            Energy::Product { .. } => self.product_energy(&self.field_from_scratch()),
            Energy::Distance { kernel, dims, .. } => {
                let columns = self.whole_columns();
                let (w, h) = (self.width, self.height);
                let all = |k: usize| 0..kernel.terms[k].spatial.len();
                let top = (1i16 << 14) - 1;
                (0..self.depth)
                    .into_par_iter()
                    .map(|z| {
                        let mut sum = 0i128;
                        for c in 0..*dims {
                            for y in 0..h {
                                for x in 0..w {
                                    // Σ g |v_p − v_r| = v_p Σg + Σ g v_r − 2 Σ g min(v_p, v_r).
                                    let v = columns.get(c, (x, y), z);
                                    let values = scan(kernel, &columns, c, all, z, (x, y), 0, top);
                                    let mins = scan(kernel, &columns, c, all, z, (x, y), 0, v);
                                    sum -= i128::from(v) * i128::from(kernel.total)
                                        + i128::from(values)
                                        - 2 * i128::from(mins);
                                }
                            }
                        }
                        sum
                    })
                    .sum()
            }
        }
    }

    /// Whether the kept `φ` equals a from-scratch computation exactly (always true for the
    /// distance energy, which keeps no field).
    #[cfg(test)]
    pub fn field_is_exact(&self) -> bool {
        match &self.energy_state {
            Energy::Product { phi, .. } => self.field_from_scratch() == *phi,
            Energy::Distance { .. } => true,
        }
    }

    /// The levels of the whole volume as [`Columns`] wrapping on both axes.
    #[cfg(test)]
    fn whole_columns(&self) -> Columns {
        let tile = Tile::whole(self.width as u32, self.height as u32, self.depth as u32);
        match self.extract(&tile).region {
            Region::Distance(columns) => columns,
            Region::Product(_) => unreachable!("distance energy"),
        }
    }

    #[cfg(test)]
    fn index(&self, z: u32, (x, y): (u32, u32)) -> usize {
        assert!(
            (x as usize) < self.width && (y as usize) < self.height && (z as usize) < self.depth,
            "pixel ({x}, {y}, {z}) is outside the volume"
        );
        (z as usize * self.height + y as usize) * self.width + x as usize
    }

    /// The exact energy change of swapping the values of pixels `a` and `b` (`(x, y)`) of frame
    /// `z`. Panics outside the volume.
    #[cfg(test)]
    pub fn swap_delta(&self, z: u32, a: (u32, u32), b: (u32, u32)) -> i128 {
        let (ia, ib) = (self.index(z, a), self.index(z, b));
        let (a, b) = ((a.0 as usize, a.1 as usize), (b.0 as usize, b.1 as usize));
        let z = z as usize;
        match &self.energy_state {
            Energy::Product { phi, .. } => {
                let pixels = self.pixels();
                let (pa, pb) = (self.perm[ia], self.perm[ib]);
                self.product_delta(
                    z,
                    pa,
                    pb,
                    |c| (phi[c * pixels + ia] as i64, phi[c * pixels + ib] as i64),
                    (b.0 as i64 - a.0 as i64, b.1 as i64 - a.1 as i64),
                )
            }
            Energy::Distance { .. } => self
                .distance_delta(&self.whole_columns(), z, a, b, None)
                .unwrap_or(0),
        }
    }

    /// Swaps the values of pixels `a` and `b` of frame `z` if that lowers the energy, counting
    /// one attempt; returns the accepted delta. Panics outside the volume.
    #[cfg(test)]
    pub fn try_swap(&mut self, z: u32, a: (u32, u32), b: (u32, u32)) -> Option<i128> {
        let delta = self.swap_delta(z, a, b);
        self.attempted += 1;
        self.screened += 1;
        if delta >= 0 {
            return None;
        }
        let (ia, ib) = (self.index(z, a), self.index(z, b));
        let (w, h) = (self.width, self.height);
        if let Energy::Product {
            kernel,
            dims,
            table,
            phi,
        } = &mut self.energy_state
        {
            let base = z as usize * w * h;
            let step: Vec<i64> = (0..*dims)
                .map(|c| {
                    i64::from(table[(base + self.perm[ib] as usize) * *dims + c])
                        - i64::from(table[(base + self.perm[ia] as usize) * *dims + c])
                })
                .collect();
            let view = (w, h, true, true);
            let (a, b) = ((a.0 as usize, a.1 as usize), (b.0 as usize, b.1 as usize));
            splat(kernel, phi, view, z as usize, a, &step, 1.0);
            splat(kernel, phi, view, z as usize, b, &step, -1.0);
        }
        self.perm.swap(ia, ib);
        self.accepted += 1;
        self.energy += delta;
        Some(delta)
    }

    /// `ΔE` of swapping value indices `pa` and `pb` of frame `z` at pixels whose `φ` components
    /// are `phi(c) = (φ_c(p), φ_c(q))`, `(dx, dy)` apart (product energy).
    #[inline(always)]
    fn product_delta(
        &self,
        z: usize,
        pa: u32,
        pb: u32,
        phi: impl Fn(usize) -> (i64, i64),
        (dx, dy): (i64, i64),
    ) -> i128 {
        let Energy::Product {
            kernel,
            dims,
            table,
            ..
        } = &self.energy_state
        else {
            unreachable!("product delta of a product optimiser");
        };
        let base = z * self.slice();
        let (ka, kb) = ((base + pa as usize) * dims, (base + pb as usize) * dims);
        let mut linear = 0i128;
        let mut square = 0i128;
        for c in 0..*dims {
            let d = i128::from(table[kb + c]) - i128::from(table[ka + c]);
            let (fp, fq) = phi(c);
            linear += d * i128::from(fp - fq);
            square += d * d;
        }
        if square == 0 {
            return 0;
        }
        let g = i128::from(kernel.same_frame.get(0, 0) - kernel.same_frame.get(dx, dy));
        2 * linear + 2 * square * g
    }

    /// `ΔE` of swapping the levels of region pixels `a` and `b` of frame `z` (distance energy);
    /// with `screen = Some(τ)`, `None` if the core's delta is at least `τ · Σ_c len_c · Σ g` (the
    /// proposal is dropped unevaluated). `Some(0)` for equal values.
    #[inline(always)]
    fn distance_delta(
        &self,
        columns: &Columns,
        z: usize,
        a: (usize, usize),
        b: (usize, usize),
        screen: Option<f64>,
    ) -> Option<i128> {
        let Energy::Distance {
            kernel, core, dims, ..
        } = &self.energy_state
        else {
            unreachable!("distance delta of a distance optimiser");
        };
        let pair = i128::from(
            kernel.same_frame.get(0, 0)
                - kernel
                    .same_frame
                    .get(b.0 as i64 - a.0 as i64, b.1 as i64 - a.1 as i64),
        );
        let near = |k: usize| 0..core[k];
        let far = |k: usize| core[k]..kernel.terms[k].spatial.len();
        // Per channel: (sign, lo, len), len 0 where the levels are equal.
        let mut parts = [(0i128, 0i16, 0i16); MAX_CHANNELS];
        let mut total_len = 0i128;
        for (c, part) in parts.iter_mut().enumerate().take(*dims) {
            let (va, vb) = (columns.get(c, a, z), columns.get(c, b, z));
            *part = (if vb > va { 1 } else { -1 }, va.min(vb), (va - vb).abs());
            total_len += i128::from(part.2);
        }
        if total_len == 0 {
            return Some(0);
        }
        // A function rather than a closure so that it inlines into the SIMD builds of the tile
        // loop (a closure called twice is compiled once, for the baseline).
        #[inline(always)]
        fn sum(
            (kernel, columns, parts): (&ScanKernel, &Columns, &[(i128, i16, i16)]),
            taps: &dyn Fn(usize) -> std::ops::Range<usize>,
            z: usize,
            (a, b): ((usize, usize), (usize, usize)),
        ) -> i128 {
            let mut total = 0i128;
            for (c, &(sign, lo, len)) in parts.iter().enumerate() {
                if len != 0 {
                    total += sign
                        * (i128::from(scan(kernel, columns, c, taps, z, a, lo, len))
                            - i128::from(scan(kernel, columns, c, taps, z, b, lo, len)));
                }
            }
            total
        }
        let state = (kernel, columns, &parts[..*dims]);
        let core_sum = sum(state, &near, z, (a, b));
        if let Some(tau) = screen {
            let core_delta = 4 * (core_sum + pair * total_len);
            if core_delta as f64 >= tau * total_len as f64 * kernel.total as f64 {
                return None;
            }
        }
        let rest = sum(state, &far, z, (a, b));
        Some(4 * (core_sum + rest + pair * total_len))
    }

    /// One pass ([module docs](self)): in every frame each pixel proposes one swap, or, with
    /// `fraction < 1`, the first `round(fraction · n)` pixels of each tile's random order do.
    pub fn run_pass(&mut self, fraction: f64) {
        let layout = Layout {
            width: self.width as u32,
            height: self.height as u32,
            reach: self.reach,
            target: Self::TILE_TARGET,
            depth: self.depth as u32,
            reach_frames: 0,
            target_frames: 0,
            span_start: SpanStart::Origin,
        };
        let key = PassKey {
            seed: self.seed,
            streams: rng::FILTER_ADAPTED,
            pass: self.passes,
        };
        self.passes += 1;
        let plan = fraction.clamp(0.0, 1.0);
        schedule::run_pass(self, &layout, key, &plan, &mut |_| {});
    }

    /// The tile's private copies ([`Work`]).
    fn extract(&self, tile: &Tile) -> Work {
        let (w, h, d) = (self.width, self.height, self.depth);
        let [x0, y0, tw, th, rx0, ry0, rw, rh] = tile_extents(tile);
        let mut perm = Vec::with_capacity(tw * th * d);
        for z in 0..d {
            for ty in 0..th {
                let row = (z * h + (y0 + ty) % h) * w;
                perm.extend((0..tw).map(|tx| self.perm[row + (x0 + tx) % w]));
            }
        }
        let region = match &self.energy_state {
            Energy::Distance { levels, dims, .. } => {
                let slice = self.slice();
                let mut cols = vec![0i16; dims * rw * rh * 2 * d];
                for (k, col) in cols.chunks_exact_mut(2 * d).enumerate() {
                    let (c, k) = (k / (rw * rh), k % (rw * rh));
                    let y = (ry0 + k / rw) % h;
                    let x = (rx0 + k % rw) % w;
                    for z in 0..d {
                        let index = self.perm[(z * h + y) * w + x] as usize;
                        let level = levels[(z * slice + index) * dims + c];
                        col[z] = level;
                        col[z + d] = level;
                    }
                }
                Region::Distance(Columns {
                    cols,
                    rw,
                    rh,
                    wrap_x: tile.wrap_x,
                    wrap_y: tile.wrap_y,
                    depth: d,
                })
            }
            Energy::Product { phi, dims, .. } => {
                let pixels = self.pixels();
                let mut out = Vec::with_capacity(dims * d * rh * rw);
                for c in 0..*dims {
                    for z in 0..d {
                        for ly in 0..rh {
                            let row = c * pixels + (z * h + (ry0 + ly) % h) * w;
                            let first = rw.min(w - rx0);
                            out.extend_from_slice(&phi[row + rx0..row + rx0 + first]);
                            out.extend_from_slice(&phi[row..row + (rw - first)]);
                        }
                    }
                }
                Region::Product(out)
            }
        };
        Work { perm, region }
    }

    /// Writes a tile's copies back ([`Optimizer::extract`]'s layouts).
    fn write_back_work(&mut self, tile: &Tile, work: &Work) {
        let (w, h, d) = (self.width, self.height, self.depth);
        let [x0, y0, tw, th, rx0, ry0, rw, rh] = tile_extents(tile);
        let mut k = 0;
        for z in 0..d {
            for ty in 0..th {
                let row = (z * h + (y0 + ty) % h) * w;
                for tx in 0..tw {
                    self.perm[row + (x0 + tx) % w] = work.perm[k];
                    k += 1;
                }
            }
        }
        let pixels = self.pixels();
        if let (Energy::Product { phi, dims, .. }, Region::Product(region)) =
            (&mut self.energy_state, &work.region)
        {
            let mut k = 0;
            for c in 0..*dims {
                for z in 0..d {
                    for ly in 0..rh {
                        let row = c * pixels + (z * h + (ry0 + ly) % h) * w;
                        let first = rw.min(w - rx0);
                        phi[row + rx0..row + rx0 + first].copy_from_slice(&region[k..k + first]);
                        phi[row..row + (rw - first)].copy_from_slice(&region[k + first..k + rw]);
                        k += rw;
                    }
                }
            }
        }
    }

    /// [`Optimizer::run_tile_work`] compiled for the widest vector instructions the CPU has
    /// ([`crate::swap::widest_build`]): the level scans are integer sums, so every build gives
    /// the same result.
    fn run_tile_fastest(
        &self,
        tile: &Tile,
        work: &mut Work,
        rng: ChaCha8Rng,
        fraction: f64,
    ) -> TileResult {
        match crate::swap::widest_build() {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `widest_build` picks AVX-512 only where the CPU has AVX-512F and AVX-512BW,
            // all that `run_tile_avx512` requires.
            Build::Avx512 => unsafe { self.run_tile_avx512(tile, work, rng, fraction) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `widest_build` picks AVX2 only where the CPU has it, all that
            // `run_tile_avx2` requires.
            Build::Avx2 => unsafe { self.run_tile_avx2(tile, work, rng, fraction) },
            _ => self.run_tile_work(tile, work, rng, fraction),
        }
    }

    /// [`Optimizer::run_tile_work`] compiled with AVX-512F and AVX-512BW enabled.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512bw")]
    fn run_tile_avx512(
        &self,
        tile: &Tile,
        work: &mut Work,
        rng: ChaCha8Rng,
        fraction: f64,
    ) -> TileResult {
        self.run_tile_work(tile, work, rng, fraction)
    }

    /// [`Optimizer::run_tile_work`] compiled with AVX2 enabled.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn run_tile_avx2(
        &self,
        tile: &Tile,
        work: &mut Work,
        rng: ChaCha8Rng,
        fraction: f64,
    ) -> TileResult {
        self.run_tile_work(tile, work, rng, fraction)
    }

    /// Proposes the swaps of one tile of one pass in every frame, on the tile's copies.
    #[inline(always)]
    fn run_tile_work(
        &self,
        tile: &Tile,
        work: &mut Work,
        mut rng: ChaCha8Rng,
        fraction: f64,
    ) -> TileResult {
        let mut result = TileResult::default();
        let [_, _, tw, th, _, _, rw, rh] = tile_extents(tile);
        let n = tw * th;
        if n < 2 {
            return result;
        }
        let count = ((fraction * n as f64).round() as usize).min(n);
        let mut order: Vec<u32> = (0..n as u32).collect();
        let screen = match &self.energy_state {
            Energy::Distance { screen, .. } => *screen,
            Energy::Product { .. } => None,
        };
        let mut step = Vec::new();
        for z in 0..self.depth {
            order.shuffle(&mut rng);
            let base = z * n;
            for &i in &order[..count] {
                let j = match (&work.region, &self.energy_state) {
                    // The candidate whose levels are nearest but not equal (an equal swap
                    // changes nothing), the first of equals.
                    (Region::Distance(columns), Energy::Distance { dims, .. }) => {
                        let a = local(tile, i as usize);
                        let mut own = [0i32; MAX_CHANNELS];
                        for (c, level) in own.iter_mut().enumerate().take(*dims) {
                            *level = i32::from(columns.get(c, a, z));
                        }
                        nearest_partner(&mut rng, i, n as u32, self.partner_candidates, |j| {
                            let b = local(tile, j as usize);
                            let d: i32 = own[..*dims]
                                .iter()
                                .enumerate()
                                .map(|(c, &level)| (level - i32::from(columns.get(c, b, z))).abs())
                                .sum();
                            if d > 0 { d } else { i32::MAX }
                        })
                    }
                    // The product energy keeps uniform partners among the other n − 1 pixels
                    // (nearest ones are measured for the distance energy only).
                    _ => nearest_partner(&mut rng, i, n as u32, 1, |_| 0),
                };
                let (i, j) = (i as usize, j as usize);
                result.attempted += 1;
                let a = local(tile, i);
                let b = local(tile, j);
                let (pa, pb) = (work.perm[base + i], work.perm[base + j]);
                let delta = match &work.region {
                    Region::Distance(columns) => {
                        match self.distance_delta(columns, z, a, b, screen) {
                            Some(delta) => delta,
                            None => continue,
                        }
                    }
                    Region::Product(phi) => {
                        let plane = self.depth * rh * rw;
                        let (ka, kb) = ((z * rh + a.1) * rw + a.0, (z * rh + b.1) * rw + b.0);
                        self.product_delta(
                            z,
                            pa,
                            pb,
                            |c| (phi[c * plane + ka] as i64, phi[c * plane + kb] as i64),
                            (b.0 as i64 - a.0 as i64, b.1 as i64 - a.1 as i64),
                        )
                    }
                };
                result.screened += 1;
                if delta >= 0 {
                    continue;
                }
                match (&mut work.region, &self.energy_state) {
                    (Region::Distance(columns), Energy::Distance { dims, .. }) => {
                        for c in 0..*dims {
                            let (la, lb) = (columns.get(c, a, z), columns.get(c, b, z));
                            columns.set(c, a, z, lb);
                            columns.set(c, b, z, la);
                        }
                    }
                    (
                        Region::Product(phi),
                        Energy::Product {
                            kernel,
                            dims,
                            table,
                            ..
                        },
                    ) => {
                        let slice = z * self.slice();
                        step.clear();
                        step.extend((0..*dims).map(|c| {
                            i64::from(table[(slice + pb as usize) * dims + c])
                                - i64::from(table[(slice + pa as usize) * dims + c])
                        }));
                        let view = (rw, rh, tile.wrap_x, tile.wrap_y);
                        splat(kernel, phi, view, z, a, &step, 1.0);
                        splat(kernel, phi, view, z, b, &step, -1.0);
                    }
                    (Region::Product(_), Energy::Distance { .. })
                    | (Region::Distance(_), Energy::Product { .. }) => {
                        unreachable!("regions match the energy")
                    }
                }
                work.perm.swap(base + i, base + j);
                result.accepted += 1;
                result.delta += delta;
            }
        }
        result
    }
}

impl TileOptimizer for Optimizer {
    /// The share of each tile's pixels that propose, in `[0, 1]`.
    type Plan = f64;
    type Outcome = TileOutcome;

    fn run_tile(&self, tile: &Tile, rng: ChaCha8Rng, fraction: &f64) -> TileOutcome {
        let mut work = self.extract(tile);
        let result = self.run_tile_fastest(tile, &mut work, rng, *fraction);
        TileOutcome { work, result }
    }

    fn write_back(&mut self, tile: &Tile, TileOutcome { work, result }: TileOutcome) {
        self.write_back_work(tile, &work);
        self.attempted += result.attempted;
        self.screened += result.screened;
        self.accepted += result.accepted;
        self.energy += result.delta;
    }
}

/// A tile's first column and row, size, its region's first column and row and size, as indices.
fn tile_extents(tile: &Tile) -> [usize; 8] {
    [
        tile.x0, tile.y0, tile.w, tile.h, tile.rx0, tile.ry0, tile.rw, tile.rh,
    ]
    .map(|v| v as usize)
}

/// Region coordinates of tile pixel `i` ([`Tile::local`]) as indices.
#[inline(always)]
fn local(tile: &Tile, i: usize) -> (usize, usize) {
    let (x, y) = tile.local(i as u32);
    (x as usize, y as usize)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The AVX2 and AVX-512 builds of the tile loop give the same permutation and totals as the
    /// portable one (AVX-512 where the CPU has it).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn simd_and_portable_tile_loops_agree() {
        use crate::filter_adapted::{FilterAdaptedSpec, scalar_energy};
        assert!(
            std::arch::is_x86_feature_detected!("avx2"),
            "this test needs an x86-64 CPU with AVX2 to compare the builds"
        );
        let mut builds = vec![Build::Avx2];
        if std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512bw")
        {
            builds.push(Build::Avx512);
        }
        let spec = FilterAdaptedSpec::new(24, 20, 12, 3);
        let n = spec.slice_pixels() as u32;
        // Each frame a permutation: a multiplier coprime with 480.
        let ranks: Vec<u32> = (0..spec.depth)
            .flat_map(|z| (0..n).map(move |i| (i * 7 + z * 31) % n))
            .collect();
        let optimizer = || {
            let (energy, _) = scalar_energy(&spec, n as usize);
            Optimizer::new(energy, (24, 20, 12), ranks.clone(), spec.seed)
        };
        let tile = Tile {
            x0: 3,
            y0: 5,
            rx0: 3,
            ry0: 5,
            ..Tile::whole(24, 20, spec.depth)
        };
        let mut portable = optimizer();
        let mut simd: Vec<Optimizer> = builds.iter().map(|_| optimizer()).collect();
        for pass in 0..3 {
            let rng = || keyed_rng(spec.seed, rng::FILTER_ADAPTED.tile, pass, tile.id);
            let mut work = portable.extract(&tile);
            let a = portable.run_tile_work(&tile, &mut work, rng(), 1.0);
            portable.write_back_work(&tile, &work);
            assert!(a.accepted > 0, "no swap accepted");
            for (&build, o) in builds.iter().zip(&mut simd) {
                let mut work = o.extract(&tile);
                let b = match build {
                    // SAFETY: the CPU has AVX2 (asserted above).
                    Build::Avx2 => unsafe { o.run_tile_avx2(&tile, &mut work, rng(), 1.0) },
                    // SAFETY: only pushed where the CPU has AVX-512F and AVX-512BW.
                    _ => unsafe { o.run_tile_avx512(&tile, &mut work, rng(), 1.0) },
                };
                o.write_back_work(&tile, &work);
                assert_eq!(
                    (a.attempted, a.screened, a.accepted, a.delta),
                    (b.attempted, b.screened, b.accepted, b.delta),
                    "{build:?}"
                );
            }
        }
        for o in &simd {
            assert_eq!(portable.perm(), o.perm());
        }
    }

    #[test]
    fn window_dot_is_exact() {
        // Weights summing to at most 2^14, levels below 2^14: the documented range.
        let t: Vec<i16> = (0..70).map(|i| ((i * 977) % 460) as i16).collect();
        assert!(t.iter().map(|&w| i32::from(w)).sum::<i32>() <= 1 << 14);
        let v: Vec<i16> = (0..70).map(|i| ((i * 7919) % 16384) as i16).collect();
        for (lo, len) in [(0, 16383), (5000, 3), (100, 9000), (16000, 383), (7, 0)] {
            let half = len >> 1;
            let exact: i64 = t
                .iter()
                .zip(&v)
                .map(|(&a, &b)| {
                    i64::from(a) * (i64::from((b - lo).clamp(0, len)) - i64::from(half))
                })
                .sum();
            assert_eq!(i64::from(window_dot(&t, &v, lo, len, half)), exact);
        }
    }
}
