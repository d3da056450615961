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

/// A fixed-point weight: the real weight (peak 1) times the kernel's scale, which is chosen so the
/// weights sum below [`EnergyKernel::MAX_TOTAL`].
pub type Weight = u32;

/// Receives the taps of one splat: [`EnergyKernel::for_each_tap`] calls `visit(index, weight)`.
///
/// A trait rather than a closure so hot visitors can force inlining into both of the kernel's row
/// loops. Every `FnMut(usize, Weight)` is one.
pub trait TapVisitor {
    /// One tap: the pixel at `index` receives `weight`.
    fn visit(&mut self, index: usize, weight: Weight);
}

impl<F: FnMut(usize, Weight)> TapVisitor for F {
    #[inline(always)]
    fn visit(&mut self, index: usize, weight: Weight) {
        self(index, weight)
    }
}

/// Taps sharing one row offset `(dy, dz)`.
///
/// Offsets are the canonical representatives of their toroidal class, in
/// `(-size/2, size/2]`: the natural signed offsets when the kernel does not wrap onto itself, so
/// a target coordinate needs at most one wrap correction.
#[derive(Clone, Debug)]
struct KernelRow {
    dy: i32,
    dz: i32,
    /// `(dx, weight)`.
    taps: Vec<(i32, Weight)>,
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
    rows: Vec<KernelRow>,
    /// Smallest and largest `dx` of any tap: pixels with `x` in `-min_dx..width - max_dx` need no
    /// x wrapping.
    min_dx: i32,
    max_dx: i32,
    total: u64,
}

/// The representative of `offset mod size` in `(-size/2, size/2]`.
fn canonical(offset: i64, size: u32) -> i32 {
    let size = i64::from(size);
    let wrapped = offset.rem_euclid(size);
    (if wrapped > size / 2 {
        wrapped - size
    } else {
        wrapped
    }) as i32
}

/// Per-axis bound on enumerated offsets, in periods: beyond two periods every wrapped offset
/// already collects several images, and a σ that large gives a kernel flat to within the
/// tolerance anyway.
const MAX_PERIODS: i64 = 2;

impl EnergyKernel {
    /// Exclusive bound on the sum of all fixed-point weights.
    pub const MAX_TOTAL: u64 = 1 << 31;

    /// Builds the kernel for a validated spec.
    pub fn new(spec: &MaskSpec) -> EnergyKernel {
        let (w, h, d) = (spec.width, spec.height, spec.depth);
        // exp(-r²/2σ²) >= tol  <=>  r²/σ² <= 2 ln(1/tol)
        let cutoff = 2.0 * (1.0 / spec.kernel_tolerance).ln();
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

        let mut rows: BTreeMap<(i32, i32), Vec<(i32, Weight)>> = BTreeMap::new();
        let mut total = 0u64;
        for (&(dx, dy, dz), &v) in &folded {
            let weight = to_fixed(v, scale);
            total += weight;
            rows.entry((dz, dy))
                .or_default()
                .push((dx, weight as Weight));
        }
        let rows: Vec<KernelRow> = rows
            .into_iter()
            .map(|((dz, dy), taps)| KernelRow { dy, dz, taps })
            .collect();
        let dxs = || rows.iter().flat_map(|r| r.taps.iter().map(|&(dx, _)| dx));
        let (min_dx, max_dx) = (dxs().min().unwrap_or(0), dxs().max().unwrap_or(0));
        EnergyKernel {
            width: w,
            height: h,
            depth: d,
            rows,
            min_dx,
            max_dx,
            total,
        }
    }

    /// Number of distinct wrapped offsets a splat touches (the footprint).
    pub fn taps(&self) -> usize {
        self.rows.iter().map(|r| r.taps.len()).sum()
    }

    /// Sum of all fixed-point weights: the energy of a pixel when every pixel is on.
    pub fn total(&self) -> u64 {
        self.total
    }

    /// Calls `visit(index, weight)` for every pixel the pixel at `(x, y, z)` sends energy to,
    /// itself included. `index` is `(z * height + y) * width + x` after wrapping.
    ///
    /// `x < width`, `y < height`, `z < depth`.
    #[inline(always)]
    pub fn for_each_tap(&self, x: u32, y: u32, z: u32, visitor: &mut impl TapVisitor) {
        let wrap = |t: i32, size: u32| {
            if t < 0 {
                t + size as i32
            } else if t >= size as i32 {
                t - size as i32
            } else {
                t
            }
        };
        let (w, h, d) = (self.width, self.height, self.depth);
        let (x, y, z) = (x as i32, y as i32, z as i32);
        let interior = x + self.min_dx >= 0 && x + self.max_dx < w as i32;
        for row in &self.rows {
            let ty = wrap(y + row.dy, h);
            let tz = wrap(z + row.dz, d);
            let base = (tz as usize * h as usize + ty as usize) * w as usize;
            if interior {
                // No tap of this row leaves the row: plain offsets from the row's start.
                let origin = base + x as usize;
                for &(dx, weight) in &row.taps {
                    visitor.visit(origin.wrapping_add_signed(dx as isize), weight);
                }
            } else {
                for &(dx, weight) in &row.taps {
                    visitor.visit(base + wrap(x + dx, w) as usize, weight);
                }
            }
        }
    }
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
}
