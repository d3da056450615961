//! The energy kernel: which pixels a turned-on pixel sends energy to, and how much, in exact
//! fixed-point integers.
//!
//! Weights are `exp(-d²/(2σ²))` (paper eq. 4) over toroidal offsets, truncated where they fall
//! below `kernel_tolerance`, summed over every toroidal image of an offset (so tiny volumes and
//! huge σ stay exact rather than double-counting or missing wrapped neighbours), then scaled to
//! integers. Integer energies add and subtract exactly: after any number of splat on/off steps the
//! energy field equals a from-scratch recomputation bit for bit.

use std::collections::BTreeMap;

use crate::spec::{EnergyTopology, MaskSpec};
use crate::torus::{canonical, wrap};

/// A fixed-point weight: the real weight (peak 1) times the kernel's scale, which is chosen so the
/// weights sum below [`EnergyKernel::MAX_TOTAL`].
pub type Weight = u32;

/// Receives the taps of one splat: [`EnergyKernel::for_each_tap`] calls `visit_run(start,
/// weights)` for each run of taps that are consecutive in memory and `visit(index, weight)` for
/// each lone tap; the default `visit_run` calls `visit` for each of its taps.
///
/// A trait rather than a closure so hot visitors can force inlining into both of the kernel's row
/// loops, and can handle a whole run at once (a vectorised add, one check per extremum-tree leaf
/// instead of one per tap). Every `FnMut(usize, Weight)` is one.
pub trait TapVisitor {
    /// One tap: the pixel at `index` receives `weight`.
    fn visit(&mut self, index: usize, weight: Weight);

    /// `weights.len()` taps on consecutive pixels: the pixel at `start + k` receives `weights[k]`.
    /// The run never crosses the end of an image row.
    #[inline(always)]
    fn visit_run(&mut self, start: usize, weights: &[Weight]) {
        for (k, &weight) in weights.iter().enumerate() {
            self.visit(start + k, weight);
        }
    }
}

impl<F: FnMut(usize, Weight)> TapVisitor for F {
    #[inline(always)]
    fn visit(&mut self, index: usize, weight: Weight) {
        self(index, weight)
    }
}

/// A run of taps with consecutive `dx` sharing one row offset `(dy, dz)`: offsets
/// `(dx + k, dy, dz)` receive `weights[first + k]` for `k < len`.
///
/// Offsets are the canonical representatives of their toroidal class, in
/// `(-size/2, size/2]`: the natural signed offsets when the kernel does not wrap onto itself, so
/// a target coordinate needs at most one wrap correction. A run has at most `width` taps (its
/// offsets are distinct modulo `width`), so it wraps around a row at most once.
#[derive(Clone, Copy, Debug)]
struct KernelRun {
    dx: i32,
    dy: i32,
    dz: i32,
    /// `(dz · height + dy) · width + dx`: the index offset of the run's first tap when no
    /// coordinate wraps.
    offset: isize,
    /// `dy · width + dx`: the offset within the target slice when x and y do not wrap.
    slice_offset: isize,
    /// First weight in [`EnergyKernel::weights`].
    first: u32,
    /// Number of taps, `>= 1`.
    len: u32,
}

/// The truncated, wrapped, fixed-point kernel of one [`MaskSpec`].
///
/// Invariant: the sum of all weights is below [`EnergyKernel::MAX_TOTAL`] (`2^31`), so the energy
/// of any pixel (a sum of at most one contribution per tap) fits 31 bits even with every pixel
/// turned on.
#[derive(Clone, Debug)]
pub struct EnergyKernel {
    width: u32,
    height: u32,
    depth: u32,
    /// Runs of two taps or more, in `(dz, dy, dx)` order.
    runs: Vec<KernelRun>,
    /// Runs of a single tap (the temporal column of the spatiotemporal kernel): visited one by
    /// one, without a run's loop.
    single_taps: Vec<KernelRun>,
    /// The runs' weights, run after run.
    weights: Vec<Weight>,
    /// Smallest and largest `dx` of any tap: pixels with `x` in `-min_dx..width - max_dx` need no
    /// x wrapping.
    min_dx: i32,
    max_dx: i32,
    /// The same for `dy` and `dz`: pixels inside all three ranges splat at fixed index offsets.
    min_dy: i32,
    max_dy: i32,
    min_dz: i32,
    max_dz: i32,
}

/// Per-axis bound on enumerated offsets, in periods: beyond two periods every wrapped offset
/// already collects several images, and a σ that large gives a kernel flat to within the
/// tolerance anyway.
const MAX_PERIODS: i64 = 2;

/// `2 ln(1/tolerance)`: the largest `d²/σ²` whose weight `exp(−d²/(2σ²))` survives truncation.
fn cutoff(tolerance: f64) -> f64 {
    2.0 * (1.0 / tolerance).ln()
}

/// Whether the kernel of σ `sigma` (pixels or frames) at truncation `tolerance` keeps the offset
/// 1 along its axis: the two tests [`EnergyKernel::new`] makes of that offset, the same
/// arithmetic (it is enumerated, and its weight is above the tolerance). Without it a pixel sends
/// energy to no neighbour along the axis, and every arrangement there has the same energy.
pub(crate) fn keeps_unit_offset(sigma: f64, tolerance: f64) -> bool {
    let cutoff = cutoff(tolerance);
    (sigma * cutoff.sqrt()).floor() >= 1.0 && 1.0 / (sigma * sigma) <= cutoff
}

/// The smallest σ [`keeps_unit_offset`] accepts at `tolerance`, rounded up to four significant
/// digits (so the figure a message shows is itself accepted): about `1/√(2 ln(1/tolerance))`,
/// 0.3072 at the default 5·10⁻³.
///
/// # Panics
/// If `tolerance` is not in `(0, 1)` (no σ qualifies; [`crate::MaskSpec::validate`] checks it first).
pub(crate) fn smallest_sigma(tolerance: f64) -> f64 {
    assert!(
        tolerance > 0.0 && tolerance < 1.0,
        "kernel tolerance {tolerance} is not in (0, 1)"
    );
    smallest_four_digit(1.0 / cutoff(tolerance).sqrt(), |sigma| {
        keeps_unit_offset(sigma, tolerance)
    })
}

/// The smallest four-significant-digit figure from `estimate` up that `accepts`: `estimate`
/// rounded up, then stepped up a digit at a time (a figure a message shows is then itself
/// accepted). `accepts` must hold from some figure on.
pub(crate) fn smallest_four_digit(estimate: f64, accepts: impl Fn(f64) -> bool) -> f64 {
    let mut shown = round_up_4(estimate);
    while !accepts(shown) {
        shown = round_up_4(shown * (1.0 + 1e-4));
    }
    shown
}

/// `x > 0` rounded down to four significant digits (a product that lands a rounding error
/// below a four-digit figure, like 1.7 · 6, counts as that figure).
pub(crate) fn round_down_4(x: f64) -> f64 {
    round_4(x, f64::floor)
}

/// `x > 0` rounded up to four significant digits (a product that lands a rounding error above
/// a four-digit figure counts as that figure).
pub(crate) fn round_up_4(x: f64) -> f64 {
    round_4(x, f64::ceil)
}

/// `x` to four significant digits by `direction` (`floor` or `ceil`) of its scaled digits,
/// snapping to the nearest figure within 10⁻⁹ of it.
fn round_4(x: f64, direction: fn(f64) -> f64) -> f64 {
    // Dividing by an exact power of ten rounds correctly, so the result prints with four digits.
    let digits = 3 - x.log10().floor() as i32;
    let scale = 10f64.powi(digits.abs());
    let scaled = if digits >= 0 { x * scale } else { x / scale };
    let nearest = scaled.round();
    let figure = if (scaled - nearest).abs() <= 1e-9 * nearest {
        nearest
    } else {
        direction(scaled)
    };
    if digits >= 0 {
        figure / scale
    } else {
        figure * scale
    }
}

impl EnergyKernel {
    /// Exclusive bound on the sum of all fixed-point weights.
    pub const MAX_TOTAL: u64 = 1 << 31;

    /// Builds the kernel for a validated spec.
    pub fn new(spec: &MaskSpec) -> EnergyKernel {
        let (w, h, d) = (spec.width, spec.height, spec.depth);
        // exp(-r²/2σ²) >= tol  <=>  r²/σ² <= 2 ln(1/tol)
        let cutoff = cutoff(spec.kernel_tolerance);
        let reach = |sigma: f64, size: u32| -> i64 {
            let r = (sigma * cutoff.sqrt()).floor();
            let cap = MAX_PERIODS * i64::from(size);
            if r >= cap as f64 { cap } else { r as i64 }
        };
        let (rx, ry, rz) = (
            reach(spec.sigma_xy, w),
            reach(spec.sigma_xy, h),
            reach(spec.sigma_z, d),
        );
        let inv_xy = 1.0 / (spec.sigma_xy * spec.sigma_xy);
        let inv_z = 1.0 / (spec.sigma_z * spec.sigma_z);

        // Real-valued weights, folded onto wrapped offsets.
        let mut folded: BTreeMap<(i32, i32, i32), f64> = BTreeMap::new();
        let mut add = |dx: i64, dy: i64, dz: i64, q: f64| {
            if q <= cutoff {
                let key = (canonical(dx, w), canonical(dy, h), canonical(dz, d));
                *folded.entry(key).or_insert(0.0) += (-0.5 * q).exp();
            }
        };
        let slice_taps = |add: &mut dyn FnMut(i64, i64, i64, f64)| {
            for dy in -ry..=ry {
                for dx in -rx..=rx {
                    add(dx, dy, 0, (dx * dx + dy * dy) as f64 * inv_xy);
                }
            }
        };
        match spec.topology {
            EnergyTopology::Independent2D => slice_taps(&mut add),
            EnergyTopology::Spatiotemporal => {
                slice_taps(&mut add);
                for dz in (-rz..=rz).filter(|&dz| dz != 0) {
                    add(0, 0, dz, (dz * dz) as f64 * inv_z);
                }
            }
            EnergyTopology::Isotropic3D => {
                for dz in -rz..=rz {
                    for dy in -ry..=ry {
                        for dx in -rx..=rx {
                            let q = (dx * dx + dy * dy) as f64 * inv_xy + (dz * dz) as f64 * inv_z;
                            add(dx, dy, dz, q);
                        }
                    }
                }
            }
        }

        // Largest scale whose rounded weights sum below MAX_TOTAL.
        let real_total: f64 = folded.values().sum();
        let mut scale = ((Self::MAX_TOTAL - 1) as f64 / real_total).floor() * 0.999_999;
        let to_fixed = |v: f64, scale: f64| (v * scale).round().max(1.0) as u64;
        loop {
            let total: u64 = folded.values().map(|&v| to_fixed(v, scale)).sum();
            if total < Self::MAX_TOTAL {
                break;
            }
            scale *= 0.99;
        }

        // `folded` iterates in (dx, dy, dz) order: regroup by row, then split each row into runs
        // of consecutive dx.
        let mut rows: BTreeMap<(i32, i32), Vec<(i32, Weight)>> = BTreeMap::new();
        for (&(dx, dy, dz), &v) in &folded {
            let weight = to_fixed(v, scale);
            rows.entry((dz, dy))
                .or_default()
                .push((dx, weight as Weight));
        }
        let mut runs: Vec<KernelRun> = Vec::new();
        let mut weights: Vec<Weight> = Vec::new();
        for ((dz, dy), taps) in rows {
            for (k, &(dx, weight)) in taps.iter().enumerate() {
                let extends = k > 0 && taps[k - 1].0 + 1 == dx;
                match runs.last_mut() {
                    Some(run) if extends => run.len += 1,
                    _ => runs.push(KernelRun {
                        dx,
                        dy,
                        dz,
                        offset: (dz as isize * h as isize + dy as isize) * w as isize + dx as isize,
                        slice_offset: dy as isize * w as isize + dx as isize,
                        first: weights.len() as u32,
                        len: 1,
                    }),
                }
                weights.push(weight);
            }
        }
        let (single_taps, runs): (Vec<KernelRun>, Vec<KernelRun>) =
            runs.into_iter().partition(|run| run.len == 1);
        let all = || runs.iter().chain(&single_taps);
        let min_dx = all().map(|r| r.dx).min().unwrap_or(0);
        let max_dx = all().map(|r| r.dx + r.len as i32 - 1).max().unwrap_or(0);
        let extent = |axis: fn(&KernelRun) -> i32| {
            let values = || all().map(axis);
            (values().min().unwrap_or(0), values().max().unwrap_or(0))
        };
        let ((min_dy, max_dy), (min_dz, max_dz)) = (extent(|r| r.dy), extent(|r| r.dz));
        EnergyKernel {
            width: w,
            height: h,
            depth: d,
            runs,
            single_taps,
            weights,
            min_dx,
            max_dx,
            min_dy,
            max_dy,
            min_dz,
            max_dz,
        }
    }

    /// Number of distinct wrapped offsets a splat touches (the footprint).
    pub fn taps(&self) -> usize {
        self.weights.len()
    }

    /// Sum of all fixed-point weights: the energy of a pixel when every pixel is on.
    #[cfg(test)]
    fn total(&self) -> u64 {
        self.weights.iter().map(|&w| u64::from(w)).sum()
    }

    /// Calls `visitor` for every pixel the pixel at `(x, y, z)` sends energy to, itself included:
    /// one [`TapVisitor::visit_run`] per run of consecutive pixels and one [`TapVisitor::visit`]
    /// per lone tap, in no particular order. An index is `(z * height + y) * width + x` after
    /// wrapping.
    ///
    /// Centres whose footprint wraps on no axis (most of a large volume) get each run's index as a
    /// fixed offset from their own; near the first and last frames only z is wrapped.
    ///
    /// `x < width`, `y < height`, `z < depth`.
    #[inline(always)]
    pub fn for_each_tap(&self, x: u32, y: u32, z: u32, visitor: &mut impl TapVisitor) {
        let (w, h, d) = (self.width, self.height, self.depth);
        let (x, y, z) = (x as i32, y as i32, z as i32);
        let inside = |t: i32, min: i32, max: i32, size: u32| t + min >= 0 && t + max < size as i32;
        let slice = h as usize * w as usize;
        let centre = y as usize * w as usize + x as usize;
        let wraps =
            if !inside(x, self.min_dx, self.max_dx, w) || !inside(y, self.min_dy, self.max_dy, h) {
                Wraps::Any
            } else if inside(z, self.min_dz, self.max_dz, d) {
                Wraps::None
            } else {
                Wraps::OnlyZ
            };
        // The index of a run's first tap, wrapped.
        let start = |run: &KernelRun| match wraps {
            // Fixed offsets from the centre's index.
            Wraps::None => (z as usize * slice + centre).wrapping_add_signed(run.offset),
            Wraps::OnlyZ => (wrap(z + run.dz, d) as usize * slice + centre)
                .wrapping_add_signed(run.slice_offset),
            Wraps::Any => {
                let (tx, ty, tz) = (
                    wrap(x + run.dx, w),
                    wrap(y + run.dy, h),
                    wrap(z + run.dz, d),
                );
                (tz as usize * h as usize + ty as usize) * w as usize + tx as usize
            }
        };
        for run in &self.runs {
            let weights = &self.weights[run.first as usize..][..run.len as usize];
            let start = start(run);
            if wraps == Wraps::Any {
                // A run wraps around its row at most once: it is at most `w` long and starts in
                // `(-w/2, 3w/2)`.
                let row_left = w as usize - start % w as usize;
                if weights.len() > row_left {
                    let (before_wrap, after_wrap) = weights.split_at(row_left);
                    visitor.visit_run(start, before_wrap);
                    visitor.visit_run(start + row_left - w as usize, after_wrap);
                    continue;
                }
            }
            visitor.visit_run(start, weights);
        }
        for tap in &self.single_taps {
            visitor.visit(start(tap), self.weights[tap.first as usize]);
        }
    }
}

/// Which coordinates of a splat's taps may wrap around the volume.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Wraps {
    /// None: every tap is at a fixed index offset from the centre.
    None,
    /// Only z (the centre is near the first or last frame).
    OnlyZ,
    /// Any coordinate.
    Any,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn weight_at(kernel: &EnergyKernel, x: u32, y: u32, z: u32) -> u64 {
        let (w, h) = (kernel.width as usize, kernel.height as usize);
        let mut found = 0;
        kernel.for_each_tap(0, 0, 0, &mut |i, wt| {
            if i == (z as usize * h + y as usize) * w + x as usize {
                found += u64::from(wt);
            }
        });
        found
    }

    #[test]
    fn spatiotemporal_footprint_is_slice_plus_column() {
        let kernel = EnergyKernel::new(&MaskSpec::new(32, 32, 16, 0));
        // No energy off the slice unless on the column.
        assert_eq!(weight_at(&kernel, 1, 0, 1), 0);
        assert!(weight_at(&kernel, 0, 0, 1) > 0);
        assert!(weight_at(&kernel, 1, 0, 0) > 0);
        // Symmetric and wrapped.
        assert_eq!(weight_at(&kernel, 1, 0, 0), weight_at(&kernel, 31, 0, 0));
        assert_eq!(weight_at(&kernel, 0, 0, 2), weight_at(&kernel, 0, 0, 14));
        // exp(-1/(2·1.9²)) relative to the peak.
        let ratio = weight_at(&kernel, 1, 0, 0) as f64 / weight_at(&kernel, 0, 0, 0) as f64;
        assert!((ratio - (-1.0f64 / (2.0 * 1.9 * 1.9)).exp()).abs() < 1e-6);
    }

    #[test]
    fn independent_2d_has_no_column() {
        let spec = MaskSpec::new(16, 16, 8, 0).with_topology(EnergyTopology::Independent2D);
        let kernel = EnergyKernel::new(&spec);
        assert_eq!(weight_at(&kernel, 0, 0, 1), 0);
    }

    #[test]
    fn isotropic_reaches_diagonals() {
        let spec = MaskSpec::new(16, 16, 8, 0).with_topology(EnergyTopology::Isotropic3D);
        let kernel = EnergyKernel::new(&spec);
        assert!(weight_at(&kernel, 1, 1, 1) > 0);
    }

    #[test]
    fn tiny_volume_folds_all_images_onto_itself() {
        let kernel = EnergyKernel::new(&MaskSpec::new(1, 1, 1, 0));
        assert_eq!(kernel.taps(), 1);
        assert!(kernel.total() < EnergyKernel::MAX_TOTAL);
    }

    #[test]
    fn extreme_sigmas_stay_in_range() {
        for sigma in [0.05, 1000.0] {
            let kernel = EnergyKernel::new(&MaskSpec::new(8, 8, 4, 0).with_sigma(sigma));
            assert!(kernel.total() < EnergyKernel::MAX_TOTAL, "σ {sigma}");
            assert!(kernel.taps() >= 1);
        }
        // Tiny σ: only the pixel itself.
        assert_eq!(
            EnergyKernel::new(&MaskSpec::new(8, 8, 4, 0).with_sigma(0.05)).taps(),
            1
        );
        // Huge σ: every pixel of the slice and column, nearly flat.
        let flat = EnergyKernel::new(&MaskSpec::new(8, 8, 4, 0).with_sigma(1000.0));
        assert_eq!(flat.taps(), 64 + 3);
    }

    /// Records every tap of a splat, checking that runs stay within one image row.
    struct Recorder {
        width: usize,
        taps: Vec<(usize, Weight)>,
    }

    impl TapVisitor for Recorder {
        fn visit(&mut self, index: usize, weight: Weight) {
            self.taps.push((index, weight));
        }

        fn visit_run(&mut self, start: usize, weights: &[Weight]) {
            assert!(!weights.is_empty(), "empty run at {start}");
            assert!(
                start % self.width + weights.len() <= self.width,
                "run of {} at {start} crosses a row end",
                weights.len()
            );
            for (k, &weight) in weights.iter().enumerate() {
                self.visit(start + k, weight);
            }
        }
    }

    #[test]
    fn every_centre_gets_the_same_footprint_translated() {
        // Sizes where some centres splat without wrapping, some wrap only in z, and some wrap in
        // x or y; and tiny sizes where the kernel folds onto itself.
        for spec in [
            MaskSpec::new(24, 20, 16, 0),
            MaskSpec::new(19, 17, 6, 0),
            MaskSpec::new(5, 3, 7, 0),
            MaskSpec::new(1, 37, 3, 0),
            MaskSpec::new(16, 14, 18, 0).with_topology(EnergyTopology::Isotropic3D),
            MaskSpec::new(20, 20, 4, 0).with_topology(EnergyTopology::Independent2D),
        ] {
            let kernel = EnergyKernel::new(&spec);
            let (w, h, d) = (
                spec.width as usize,
                spec.height as usize,
                spec.depth as usize,
            );
            let splat = |x: usize, y: usize, z: usize| {
                let mut recorder = Recorder {
                    width: w,
                    taps: Vec::new(),
                };
                kernel.for_each_tap(x as u32, y as u32, z as u32, &mut recorder);
                recorder.taps.sort_unstable();
                recorder.taps
            };
            let origin = splat(0, 0, 0);
            assert_eq!(origin.len(), kernel.taps(), "{spec:?}");
            for z in 0..d {
                for y in 0..h {
                    for x in 0..w {
                        let mut expected: Vec<(usize, Weight)> = origin
                            .iter()
                            .map(|&(i, weight)| {
                                let (ox, oy, oz) = (i % w, i / w % h, i / (w * h));
                                let (tx, ty, tz) = ((ox + x) % w, (oy + y) % h, (oz + z) % d);
                                ((tz * h + ty) * w + tx, weight)
                            })
                            .collect();
                        expected.sort_unstable();
                        assert_eq!(splat(x, y, z), expected, "{spec:?} at ({x}, {y}, {z})");
                    }
                }
            }
        }
    }
}
