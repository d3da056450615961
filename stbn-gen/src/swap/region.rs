//! Blocks of pixels the optimiser works on, the whole volume or a tile's private copy of its
//! region ([`crate::schedule`]), and the neighbours of a pixel in one.

use super::energy::{SwapKernel, squared_distance};
use crate::schedule::Tile;
use crate::torus::{canonical, wrap};

/// Index steps from a pixel to its neighbours in a block of pixels: `width × height` per slice,
/// every slice of the volume or a tile's region.
pub(super) struct Steps {
    /// Pixels per row of the block.
    pub(super) width: u32,
    /// Rows per slice of the block.
    pub(super) height: u32,
    /// `dy · width + dx` of each spatial tap, for pixels whose taps stay inside the block.
    pub(super) spatial: Vec<isize>,
    /// From slice `z`, the step to each temporal neighbour, `width · height · (z' − z)`: index
    /// `z · temporal taps + k`.
    pub(super) temporal: Vec<isize>,
}

/// Values and pixel energies of a block of pixels: the whole volume (the optimiser's state) or a
/// tile's private copy of its region ([`crate::schedule`]), indexed as its [`Steps`] say.
pub(super) struct Region {
    /// The block's size and the neighbour steps in it.
    pub(super) steps: Steps,
    /// `f32` components, index `pixel · dims + c`, pixel `(z · height + y) · width + x`.
    pub(super) values: Vec<f32>,
    /// Each pixel's energy `e(p)`.
    pub(super) energy: Vec<f64>,
}

impl Region {
    /// The value of `pixel`.
    #[inline(always)]
    pub(super) fn value<const D: usize>(&self, pixel: usize) -> [f32; D] {
        value_at::<D>(&self.values, pixel)
    }

    /// Index of pixel `(x, y)` of slice `z`.
    #[inline(always)]
    pub(super) fn index(&self, (x, y): (u32, u32), z: u32) -> usize {
        let (w, h) = (self.steps.width as usize, self.steps.height as usize);
        (z as usize * h + y as usize) * w + x as usize
    }
}

/// The value of `pixel` in `values` (`D` components per pixel).
#[inline(always)]
pub(super) fn value_at<const D: usize>(values: &[f32], pixel: usize) -> [f32; D] {
    values.as_chunks::<D>().0[pixel]
}

impl Region {
    /// A private copy of `tile`'s region of this whole-volume state.
    pub(super) fn tile_copy(&self, kernel: &SwapKernel, tile: &Tile) -> Region {
        let dims = kernel.dims;
        let pixels = (tile.rw * tile.rh * tile.rd) as usize;
        let mut values = Vec::with_capacity(pixels * dims);
        let mut energy = Vec::with_capacity(pixels);
        tile.region_runs(kernel.size(), |from, _, len| {
            values.extend_from_slice(&self.values[from * dims..(from + len) * dims]);
            energy.extend_from_slice(&self.energy[from..from + len]);
        });
        Region {
            steps: kernel.steps((tile.rw, tile.rh, tile.rd), tile.wrap_z),
            values,
            energy,
        }
    }

    /// Writes `copy`, a tile's copy of its region after its moves, back into this whole-volume
    /// state: the values of the tile's pixels (the only ones its moves change) and the energies
    /// of the whole region.
    pub(super) fn write_back(&mut self, kernel: &SwapKernel, tile: &Tile, copy: &Region) {
        let dims = kernel.dims;
        tile.tile_runs(kernel.size(), |to, from, len| {
            self.values[to * dims..(to + len) * dims]
                .copy_from_slice(&copy.values[from * dims..(from + len) * dims]);
        });
        tile.region_runs(kernel.size(), |to, from, len| {
            self.energy[to..to + len].copy_from_slice(&copy.energy[from..from + len]);
        });
    }
}

impl SwapKernel {
    /// The index steps to every tap's neighbour in a block of `width × height` pixels per slice
    /// and `depth` slices: the volume's depth, wrapping (`wraps`), or a tile's run of frames
    /// widened by the reach along time, whose tile frames have every temporal neighbour inside.
    pub(super) fn steps(&self, (width, height, depth): (u32, u32, u32), wraps: bool) -> Steps {
        let depth = i64::from(depth);
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
                        let to = z + i64::from(dz);
                        let to = if wraps { to.rem_euclid(depth) } else { to };
                        (to - z) as isize * slice
                    })
                })
                .collect(),
        }
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
    pub(super) fn for_each_neighbour(
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
    pub(super) fn gather<const D: usize>(
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
            let values = region.values.as_chunks::<D>().0;
            let (spatial, temporal) = out.split_at_mut(self.spatial.len());
            gather_steps(values, centre, &steps.spatial, value, spatial);
            gather_steps(
                values,
                centre,
                self.temporal_steps(steps, z),
                value,
                temporal,
            );
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
    pub(super) fn spatial_tap(&self, from: (u32, u32), to: (u32, u32)) -> Option<usize> {
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
}

/// `out[k] = ‖value − values[centre + steps[k]]‖²` over the shorter of `steps` and `out`, the
/// same operations as [`squared_distance`] one tap at a time (the same bits).
///
/// Out of line, four taps a step: inlined into the tile loop, the loop reloaded its pointers
/// from the stack every tap; in steps of four the compiler packs the four distances into one
/// vector (64×64×32 Vec2, 64 swap passes, one thread, AVX2 build, alternating runs: 3.4–3.8 →
/// 3.2–3.3 s, with [`super::pair`]'s out-of-line partner choice).
#[inline(never)]
fn gather_steps<const D: usize>(
    values: &[[f32; D]],
    centre: usize,
    steps: &[isize],
    value: &[f32; D],
    out: &mut [f32],
) {
    let len = out.len().min(steps.len());
    let (out, steps) = (&mut out[..len], &steps[..len]);
    let (out4, out_rest) = out.as_chunks_mut::<4>();
    let (steps4, steps_rest) = steps.as_chunks::<4>();
    for (o, st) in out4.iter_mut().zip(steps4) {
        // One bounds check per tap, not per component.
        let v: [[f32; D]; 4] = std::array::from_fn(|t| values[centre.wrapping_add_signed(st[t])]);
        *o = std::array::from_fn(|t| squared_distance(value, &v[t]));
    }
    for (o, &step) in out_rest.iter_mut().zip(steps_rest) {
        *o = squared_distance(value, &values[centre.wrapping_add_signed(step)]);
    }
}

/// Each pixel of `tile` (row by row) as an index within a slice of its region.
pub(super) fn region_indices(tile: &Tile) -> Vec<usize> {
    (0..tile.pixels())
        .map(|i| {
            let (x, y) = tile.local(i);
            y as usize * tile.rw as usize + x as usize
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::VectorSpec;
    use crate::swap::SwapOptimizer;

    /// `gather`'s written-out interior loop lists the same taps in the same order as
    /// `for_each_neighbour` (which `apply` uses), for interior, edge and folded pixels.
    #[test]
    fn gather_and_for_each_neighbour_agree() {
        use crate::SampleSpace;
        for (w, h, d) in [(20, 18, 5), (9, 10, 3), (3, 2, 2), (1, 7, 4)] {
            let spec = VectorSpec::new(w, h, d, 3, SampleSpace::Vec { dims: 2 });
            let start =
                crate::generate_vector(&spec.clone().unoptimised(), crate::Observer::default())
                    .unwrap()
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

    /// In a tile's copy of its region, every tile pixel has the neighbours it has in the volume,
    /// tap for tap, and two tile pixels interact through the same tap; the copy written back
    /// unchanged leaves the volume as it was.
    #[test]
    fn a_region_copy_has_the_volume_neighbours() {
        use crate::SampleSpace;
        use crate::rng::VECTOR;
        use crate::schedule::{Layout, PassKey, SpanStart};
        for (w, h, d) in [(40, 36, 3), (20, 9, 2), (7, 5, 2), (20, 18, 19)] {
            let spec = VectorSpec::new(w, h, d, 3, SampleSpace::Vec { dims: 2 });
            let start =
                crate::generate_vector(&spec.clone().unoptimised(), crate::Observer::default())
                    .unwrap()
                    .values()
                    .to_vec();
            let mut o = SwapOptimizer::new(&spec, start.clone());
            let k = &o.kernel;
            let cases = [
                (8, 0, SpanStart::PassOffset),
                (16, 0, SpanStart::Origin),
                (8, 8, SpanStart::PassOffset),
            ];
            for (target, target_frames, span_start) in cases {
                let layout = Layout {
                    width: w,
                    height: h,
                    reach: k.reach(),
                    target,
                    depth: d,
                    reach_frames: k.reach_frames(),
                    target_frames,
                    span_start,
                };
                for pass in 0..3 {
                    let key = PassKey {
                        seed: 3,
                        streams: VECTOR,
                        pass,
                    };
                    let tiles = layout.tiles(key);
                    if target_frames > 0 && d >= 4 * k.reach_frames() {
                        assert!(tiles.iter().any(|t| !t.wrap_z), "frames are cut");
                    }
                    for tile in tiles {
                        let copy = o.state.tile_copy(k, &tile);
                        // Region index to volume index.
                        let to_volume = |r: usize| {
                            let (rw, rh) = (tile.rw as usize, tile.rh as usize);
                            let (z, y, x) = (r / (rw * rh), r / rw % rh, r % rw);
                            let gx = (tile.rx0 as usize + x) % w as usize;
                            let gy = (tile.ry0 as usize + y) % h as usize;
                            let gz = (tile.rz0 as usize + z) % d as usize;
                            (gz * h as usize + gy) * w as usize + gx
                        };
                        let global = |(x, y): (u32, u32)| ((tile.rx0 + x) % w, (tile.ry0 + y) % h);
                        for z in tile.inset_z..tile.inset_z + tile.d {
                            let gz = (tile.rz0 + z) % d;
                            for i in 0..tile.pixels() {
                                let local = tile.local(i);
                                let centre = copy.index(local, z);
                                let mut seen = Vec::new();
                                k.for_each_neighbour(
                                    &copy.steps,
                                    (local.0, local.1, z),
                                    centre,
                                    |t, n| seen.push((t, to_volume(n))),
                                );
                                let g = global(local);
                                let mut expected = Vec::new();
                                k.for_each_neighbour(
                                    &o.state.steps,
                                    (g.0, g.1, gz),
                                    o.state.index(g, gz),
                                    |t, n| expected.push((t, n)),
                                );
                                assert_eq!(seen, expected, "{w}x{h}x{d} {tile:?} pixel {i}");
                                assert_eq!(to_volume(centre), o.state.index(g, gz));
                                for j in 0..tile.pixels() {
                                    let other = tile.local(j);
                                    assert_eq!(
                                        k.spatial_tap(local, other),
                                        k.spatial_tap(g, global(other))
                                    );
                                }
                            }
                        }
                        o.state.write_back(k, &tile, &copy);
                    }
                }
            }
            assert_eq!(o.values(), start);
        }
    }
}
