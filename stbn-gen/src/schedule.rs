//! The tile schedule both swap optimisers run their passes on: deterministic parallel passes
//! for any number of threads.
//!
//! A pass cuts every frame into rectangular tiles ([`Layout::tiles`]) at a seeded random offset,
//! about [`Layout::target`] pixels wide and never narrower than twice the optimiser's reach. A
//! tile covers its columns in every frame, or, where the layout asks for it
//! ([`Layout::target_frames`]), in a run of about that many frames, never fewer than twice the
//! reach along time. Tiles are coloured in a 2 × 2 pattern (2 × 2 × 2 when frames are cut too)
//! and the colours run one after the other; the tiles of one colour run in parallel
//! ([`run_pass`]), each on private copies of its *region* (the tile widened by the reach on
//! every side), and their outcomes are written back in tile order after the colour. Each tile
//! draws from its own ChaCha8 stream keyed by (seed, pass, tile).
//!
//! Why this is deterministic: two tiles of one colour are separated by a whole tile, at least
//! twice the reach wide, along some axis, so their regions never overlap, and a tile's moves
//! read and write only its region. So each tile's outcome is a function of the state before its
//! colour, and writing the outcomes back in tile order gives the same state whatever ran where.
//!
//! Why frames are cut: a small mask has few tiles per colour in a frame (a 64 × 64 frame in
//! 32-pixel tiles has one), so its passes would run on one core; runs of frames multiply the
//! tiles of a colour by half the runs, so more cores find work.
//!
//! Why private copies: each tile owns its region outright (`&mut`, no atomics, no `unsafe`), and
//! a region (a few tens of kilobytes) stays in cache while its tile runs.

use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use crate::rng::{Streams, keyed_rng};

/// An optimiser whose passes [`run_pass`] schedules.
///
/// Invariant: [`TileOptimizer::run_tile`] reads only the tile's region as it was before the
/// tile's colour, and [`TileOptimizer::write_back`] changes only that region. Tiles of one
/// colour have disjoint regions, so none reads what another writes, and the outcome of a pass is
/// the same for every number of threads.
pub(crate) trait TileOptimizer: Sync {
    /// What every tile of one pass needs besides its coordinates and random stream.
    type Plan: Sync;
    /// One tile's work: its region's private copies after its moves, and its totals.
    type Outcome: Send;

    /// Runs the moves of `tile` on private copies of its region, drawing from `rng`.
    fn run_tile(&self, tile: &Tile, rng: ChaCha8Rng, plan: &Self::Plan) -> Self::Outcome;

    /// Writes `tile`'s outcome back into the optimiser's state and adds up its totals.
    fn write_back(&mut self, tile: &Tile, outcome: Self::Outcome);
}

/// The random keys of one pass: its grid offset draws from `keyed_rng(seed, streams.grid, pass,
/// 0)`, tile `t` from `keyed_rng(seed, streams.tile, pass, t.id)`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PassKey {
    /// The mask's seed.
    pub seed: u64,
    /// The optimiser's stream tags.
    pub streams: Streams,
    /// The pass number, from 0.
    pub pass: u64,
}

/// One pass: the tiles of `layout` at the pass's offset, colour by colour, the tiles of a colour
/// in parallel, their outcomes written back in tile order. Calls `after_colour` four times, after
/// each quarter of the colours (one colour, or two where frames are cut), so progress counts
/// quarter passes either way.
pub(crate) fn run_pass<O: TileOptimizer>(
    optimizer: &mut O,
    layout: &Layout,
    key: PassKey,
    plan: &O::Plan,
    after_colour: &mut dyn FnMut(&O),
) {
    let tiles = layout.tiles(key);
    let colours = if tiles.iter().any(|t| t.colour >= 4) {
        8
    } else {
        4
    };
    let per_quarter = colours / 4;
    for colour in 0..colours {
        let batch: Vec<&Tile> = tiles.iter().filter(|t| t.colour == colour).collect();
        let outcomes: Vec<O::Outcome> = {
            let optimizer = &*optimizer;
            batch
                .par_iter()
                .map(|tile| {
                    let rng = keyed_rng(key.seed, key.streams.tile, key.pass, tile.id);
                    optimizer.run_tile(tile, rng, plan)
                })
                .collect()
        };
        for (tile, outcome) in batch.into_iter().zip(outcomes) {
            optimizer.write_back(tile, outcome);
        }
        if (colour + 1) % per_quarter == 0 {
            after_colour(optimizer);
        }
    }
}

/// Tiles along an axis of `size` pixels: an even count whose tiles are all at least `2 · reach`
/// wide, near `size / target`; 1 when the axis is too short for two. Two tiles of one colour are
/// then separated by at least twice the reach, so their regions do not overlap.
pub(crate) fn tiles_along(size: u32, reach: u32, target: u32) -> u32 {
    let max_tiles = size / (2 * reach).max(1);
    let want = (size / target.max(1)).max(2).min(max_tiles);
    if want >= 2 { want & !1 } else { 1 }
}

/// Where a tile that spans a whole axis (one tile along it) starts. The two optimisers differ
/// here, and each keeps its choice: it decides which pixel a tile's index `i` is, so changing it
/// changes their masks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum SpanStart {
    /// At the pass's offset, like every other tile (the vector swap optimiser).
    PassOffset,
    /// At 0 (the filter-adapted optimiser).
    Origin,
}

/// How an optimiser cuts its frames into tiles.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Layout {
    /// Pixels per row.
    pub width: u32,
    /// Rows per frame.
    pub height: u32,
    /// How far, in pixels along x and y, a move at one pixel reads or writes around it.
    pub reach: (u32, u32),
    /// Preferred tile side in pixels.
    pub target: u32,
    /// Frames of the volume.
    pub depth: u32,
    /// How far, in frames, a move at one pixel reads or writes around it.
    pub reach_frames: u32,
    /// Preferred frames per tile; 0: every tile covers every frame.
    pub target_frames: u32,
    /// Where a tile spanning a whole axis starts.
    pub span_start: SpanStart,
}

impl Layout {
    /// The tiles of the pass `key` says, run by run of frames, row by row (`id` =
    /// `(tz · ny + ty) · nx + tx`), coloured `(tx mod 2) + 2 (ty mod 2) + 4 (tz mod 2)`. The
    /// grid's offset is drawn from the pass's grid stream, x first, then y, then (where frames
    /// are cut) z.
    pub(crate) fn tiles(&self, key: PassKey) -> Vec<Tile> {
        let (w, h, d) = (self.width, self.height, self.depth);
        let mut grid_rng = keyed_rng(key.seed, key.streams.grid, key.pass, 0);
        let (ox, oy) = (grid_rng.random_range(0..w), grid_rng.random_range(0..h));
        let (nx, ny) = (
            tiles_along(w, self.reach.0, self.target),
            tiles_along(h, self.reach.1, self.target),
        );
        let nz = match self.target_frames {
            0 => 1,
            target => tiles_along(d, self.reach_frames, target),
        };
        let oz = if nz > 1 {
            grid_rng.random_range(0..d)
        } else {
            0
        };
        let mut tiles = Vec::with_capacity((nx * ny * nz) as usize);
        for (tz, ty, tx) in
            (0..nz).flat_map(|tz| (0..ny).flat_map(move |ty| (0..nx).map(move |tx| (tz, ty, tx))))
        {
            let x = self.axis(tx, nx, w, ox, self.reach.0);
            let y = self.axis(ty, ny, h, oy, self.reach.1);
            let z = if nz > 1 {
                self.axis(tz, nz, d, oz, self.reach_frames)
            } else {
                Span::whole(0, d)
            };
            tiles.push(Tile {
                x0: x.start,
                y0: y.start,
                w: x.len,
                h: y.len,
                rx0: x.region_start,
                ry0: y.region_start,
                rw: x.region_len,
                rh: y.region_len,
                inset_x: x.inset,
                inset_y: y.inset,
                wrap_x: x.wraps,
                wrap_y: y.wraps,
                z0: z.start,
                d: z.len,
                rz0: z.region_start,
                rd: z.region_len,
                inset_z: z.inset,
                wrap_z: z.wraps,
                colour: ((tx % 2) + 2 * (ty % 2) + 4 * (tz % 2)) as u8,
                id: (u64::from(tz) * u64::from(ny) + u64::from(ty)) * u64::from(nx) + u64::from(tx),
            });
        }
        tiles
    }

    /// Tile `i` of `n` along an axis of `size` pixels, the grid shifted by `offset`.
    fn axis(&self, i: u32, n: u32, size: u32, offset: u32, reach: u32) -> Span {
        if n == 1 {
            let start = match self.span_start {
                SpanStart::PassOffset => offset,
                SpanStart::Origin => 0,
            };
            return Span::whole(start, size);
        }
        let bound = |i: u32| (u64::from(i) * u64::from(size) / u64::from(n)) as u32;
        let start = (offset + bound(i)) % size;
        let len = bound(i + 1) - bound(i);
        Span {
            start,
            len,
            region_start: (start + size - reach) % size,
            region_len: len + 2 * reach,
            inset: reach,
            wraps: false,
        }
    }
}

impl Span {
    /// One tile over a whole axis of `size` pixels, from pixel `start` (the region wraps).
    fn whole(start: u32, size: u32) -> Span {
        Span {
            start,
            len: size,
            region_start: start,
            region_len: size,
            inset: 0,
            wraps: true,
        }
    }
}

/// One tile along one axis.
struct Span {
    /// The tile's first pixel.
    start: u32,
    /// The tile's length in pixels.
    len: u32,
    /// The region's first pixel.
    region_start: u32,
    /// The region's length in pixels.
    region_len: u32,
    /// The tile's first pixel within its region.
    inset: u32,
    /// Whether the region spans the axis (and offsets wrap around it).
    wraps: bool,
}

/// One tile of a pass: columns `x0..x0 + w` and rows `y0..y0 + h` (both modulo the frame) in
/// frames `z0..z0 + d` (modulo the depth), and its region: columns `rx0..rx0 + rw`, rows
/// `ry0..ry0 + rh` and frames `rz0..rz0 + rd`, the tile widened by the reach on each side, or
/// the whole axis where one tile spans it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Tile {
    /// First column of the tile.
    pub x0: u32,
    /// First row of the tile.
    pub y0: u32,
    /// The tile's width in pixels.
    pub w: u32,
    /// The tile's height in pixels.
    pub h: u32,
    /// First column of the region.
    pub rx0: u32,
    /// First row of the region.
    pub ry0: u32,
    /// The region's width in pixels.
    pub rw: u32,
    /// The region's height in pixels.
    pub rh: u32,
    /// The tile's first column within its region: the reach, or 0 where the region spans x.
    pub inset_x: u32,
    /// The tile's first row within its region: the reach, or 0 where the region spans y.
    pub inset_y: u32,
    /// The region spans x (one tile along it): offsets wrap around it.
    pub wrap_x: bool,
    /// The region spans y: offsets wrap around it.
    pub wrap_y: bool,
    /// First frame of the tile.
    pub z0: u32,
    /// The tile's frames.
    pub d: u32,
    /// First frame of the region.
    pub rz0: u32,
    /// The region's frames.
    pub rd: u32,
    /// The tile's first frame within its region: the reach along time, or 0 where the region
    /// spans every frame.
    pub inset_z: u32,
    /// The region spans every frame: offsets in time wrap around it.
    pub wrap_z: bool,
    /// Colour, `0..8`: tiles of one colour run in parallel.
    pub colour: u8,
    /// Index in the pass's grid, row by row: keys the tile's random stream.
    pub id: u64,
}

impl Tile {
    /// One tile over the whole `width × height × depth` volume, its region wrapping on every
    /// axis.
    #[cfg(test)]
    pub(crate) fn whole(width: u32, height: u32, depth: u32) -> Tile {
        Tile {
            x0: 0,
            y0: 0,
            w: width,
            h: height,
            rx0: 0,
            ry0: 0,
            rw: width,
            rh: height,
            inset_x: 0,
            inset_y: 0,
            wrap_x: true,
            wrap_y: true,
            z0: 0,
            d: depth,
            rz0: 0,
            rd: depth,
            inset_z: 0,
            wrap_z: true,
            colour: 0,
            id: 0,
        }
    }

    /// Pixels of the tile in one frame.
    #[inline(always)]
    pub(crate) fn pixels(&self) -> u32 {
        self.w * self.h
    }

    /// Region coordinates of tile pixel `i` (row by row).
    #[inline(always)]
    pub(crate) fn local(&self, i: u32) -> (u32, u32) {
        (i % self.w + self.inset_x, i / self.w + self.inset_y)
    }

    /// Calls `run(volume, region, len)` for each run of `len` pixels of the region that is
    /// contiguous in a `width × height × depth` volume, in region order (frame, row, column):
    /// `volume` is the index of its first pixel in the volume (`(z · height + y) · width + x`),
    /// `region` in the region (`(z · rh + y) · rw + x`, `z` the frame within the region).
    pub(crate) fn region_runs(&self, size: (u32, u32, u32), run: impl FnMut(usize, usize, usize)) {
        let rect = (self.rx0, self.ry0, self.rw, self.rh);
        self.runs(rect, (self.rz0, self.rd), (0, 0, 0), size, run);
    }

    /// [`Tile::region_runs`] for the tile's own pixels: `region` is the index of the run's first
    /// pixel in the region.
    pub(crate) fn tile_runs(&self, size: (u32, u32, u32), run: impl FnMut(usize, usize, usize)) {
        let rect = (self.x0, self.y0, self.w, self.h);
        let inset = (self.inset_x, self.inset_y, self.inset_z);
        self.runs(rect, (self.z0, self.d), inset, size, run);
    }

    /// The runs of the rectangle `rect` (first column and row, width and height) of the
    /// frames `z0..z0 + d` of the volume, placed at `inset` in the region.
    fn runs(
        &self,
        (x0, y0, w, h): (u32, u32, u32, u32),
        (z0, d): (u32, u32),
        (inset_x, inset_y, inset_z): (u32, u32, u32),
        (width, height, depth): (u32, u32, u32),
        mut run: impl FnMut(usize, usize, usize),
    ) {
        let (x0, w, width) = (x0 as usize, w as usize, width as usize);
        let (rw, rh) = (self.rw as usize, self.rh as usize);
        let first = w.min(width - x0);
        for lz in 0..d as usize {
            let z = (z0 as usize + lz) % depth as usize;
            for ly in 0..h as usize {
                let y = (y0 as usize + ly) % height as usize;
                let row = (z * height as usize + y) * width;
                let local =
                    ((lz + inset_z as usize) * rh + ly + inset_y as usize) * rw + inset_x as usize;
                run(row + x0, local, first);
                if first < w {
                    run(row, local + first, w - first);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiles_keep_same_colour_apart() {
        // The vector swap optimiser's and the filter-adapted optimiser's targets.
        let targets = [
            crate::swap::TILE_TARGET,
            crate::swap::ASSIGNMENT_TILE_TARGET,
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

    /// Every voxel lies in exactly one tile; a tile's region holds the tile widened by the
    /// reach (or the whole axis); the regions of one colour's tiles are disjoint. With frames
    /// whole and cut into runs.
    #[test]
    fn tiles_cover_each_voxel_once_and_regions_of_a_colour_are_disjoint() {
        let cases = [
            (64, 48, 3, (4, 4), 0, 0),
            (9, 40, 2, (2, 3), 0, 0),
            (5, 3, 1, (1, 0), 0, 0),
            (64, 48, 32, (4, 4), 4, 8),
            (9, 40, 19, (2, 3), 2, 4),
            (24, 24, 7, (3, 3), 2, 4),
        ];
        for span_start in [SpanStart::PassOffset, SpanStart::Origin] {
            for (width, height, depth, reach, reach_frames, target_frames) in cases {
                let layout = Layout {
                    width,
                    height,
                    reach,
                    target: 16,
                    depth,
                    reach_frames,
                    target_frames,
                    span_start,
                };
                let voxels = (width * height * depth) as usize;
                let index = |x: u32, y: u32, z: u32| ((z * height + y) * width + x) as usize;
                for pass in 0..6 {
                    let key = PassKey {
                        seed: 3,
                        streams: crate::rng::VECTOR,
                        pass,
                    };
                    let mut owner = vec![0u32; voxels];
                    let mut region_colour = vec![[0u32; 8]; voxels];
                    let tiles = layout.tiles(key);
                    if target_frames > 0 && depth >= 4 * reach_frames {
                        assert!(tiles.iter().any(|t| !t.wrap_z), "frames are cut");
                    }
                    for tile in tiles {
                        for lz in tile.inset_z..tile.inset_z + tile.d {
                            assert!(lz < tile.rd);
                            if !tile.wrap_z {
                                assert!(lz >= reach_frames && lz + reach_frames < tile.rd);
                            }
                            let z = (tile.rz0 + lz) % depth;
                            assert_eq!(z, (tile.z0 + lz - tile.inset_z) % depth);
                            for i in 0..tile.pixels() {
                                let (lx, ly) = tile.local(i);
                                assert!(lx < tile.rw && ly < tile.rh);
                                let x = (tile.rx0 + lx) % width;
                                let y = (tile.ry0 + ly) % height;
                                assert_eq!(x, (tile.x0 + i % tile.w) % width);
                                assert_eq!(y, (tile.y0 + i / tile.w) % height);
                                if !tile.wrap_x {
                                    assert!(lx >= reach.0 && lx + reach.0 < tile.rw);
                                }
                                if !tile.wrap_y {
                                    assert!(ly >= reach.1 && ly + reach.1 < tile.rh);
                                }
                                owner[index(x, y, z)] += 1;
                            }
                        }
                        for lz in 0..tile.rd {
                            for ly in 0..tile.rh {
                                for lx in 0..tile.rw {
                                    let x = (tile.rx0 + lx) % width;
                                    let y = (tile.ry0 + ly) % height;
                                    let z = (tile.rz0 + lz) % depth;
                                    region_colour[index(x, y, z)][tile.colour as usize] += 1;
                                }
                            }
                        }
                    }
                    let case = format!("{width}x{height}x{depth} {reach:?} {reach_frames}");
                    assert!(owner.iter().all(|&n| n == 1), "{case}");
                    assert!(region_colour.iter().flatten().all(|&n| n <= 1), "{case}");
                }
            }
        }
    }
}
