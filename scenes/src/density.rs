//! [`DensityGrid`]: a procedural cloud's density on a voxel grid over the unit cube, with the
//! trilinear lookup the cloud scene uses on the CPU (`f32` and `f64`) and the GPU ([`WGSL`]).

use crate::procedural;

/// A cubic grid of `n³` densities over `[0, 1]³`: voxel `(i, j, k)` holds the density at its
/// centre `((i + 0.5) / n, (j + 0.5) / n, (k + 0.5) / n)`, index `(k · n + j) · n + i`.
/// Densities are `≥ 0` and dimensionless (the scene multiplies them by its extinction).
#[derive(Clone, Debug, PartialEq)]
pub struct DensityGrid {
    n: u32,
    values: Vec<f32>,
}

/// WGSL for [`DensityGrid::density`]: `fn cloud_density(p: vec3<f32>) -> f32`, reading the grid
/// from `scene_data` starting at index 0. Needs a `const GRID_N: u32` (the grid's `n`) in front.
pub const WGSL: &str = "
fn cloud_voxel(i: u32, j: u32, k: u32) -> f32 {
    return scene_data[(k * GRID_N + j) * GRID_N + i];
}

fn cloud_density(p: vec3<f32>) -> f32 {
    let nf = f32(GRID_N);
    let u = clamp(p * nf - vec3<f32>(0.5), vec3<f32>(0.0), vec3<f32>(nf - 1.0));
    let i = min(vec3<u32>(floor(u)), vec3<u32>(GRID_N - 2u));
    let f = u - vec3<f32>(i);
    let c00 = cloud_voxel(i.x, i.y, i.z) + (cloud_voxel(i.x + 1u, i.y, i.z) - cloud_voxel(i.x, i.y, i.z)) * f.x;
    let c10 = cloud_voxel(i.x, i.y + 1u, i.z) + (cloud_voxel(i.x + 1u, i.y + 1u, i.z) - cloud_voxel(i.x, i.y + 1u, i.z)) * f.x;
    let c01 = cloud_voxel(i.x, i.y, i.z + 1u) + (cloud_voxel(i.x + 1u, i.y, i.z + 1u) - cloud_voxel(i.x, i.y, i.z + 1u)) * f.x;
    let c11 = cloud_voxel(i.x, i.y + 1u, i.z + 1u) + (cloud_voxel(i.x + 1u, i.y + 1u, i.z + 1u) - cloud_voxel(i.x, i.y + 1u, i.z + 1u)) * f.x;
    let c0 = c00 + (c10 - c00) * f.y;
    let c1 = c01 + (c11 - c01) * f.y;
    return c0 + (c1 - c0) * f.z;
}
";

impl DensityGrid {
    /// A grid from its values; panics unless `n ≥ 2` and `values.len() == n³`, or if a value is
    /// negative or not finite.
    pub fn from_values(n: u32, values: Vec<f32>) -> DensityGrid {
        assert!(n >= 2, "a trilinear grid needs n >= 2");
        assert_eq!(values.len(), (n as usize).pow(3), "value count vs n³");
        assert!(
            values.iter().all(|v| v.is_finite() && *v >= 0.0),
            "densities must be finite and >= 0"
        );
        DensityGrid { n, values }
    }

    /// A cumulus-like cloud: eight overlapping Gaussian lobes (a flat-bottomed heap in the middle
    /// of the cube, envelope capped at 1.2) scaled by `1 + 3 · (fbm − ½)` with three octaves of
    /// value noise from `seed`, then shifted down by 0.35, doubled and clamped at 0, so that the
    /// edges are ragged and the cube's faces are empty. Densities lie in `[0, 5.3]`.
    pub fn cloud(n: u32, seed: u64) -> DensityGrid {
        // (centre x, y, z, radius, weight); y points up.
        const LOBES: [(f64, f64, f64, f64, f64); 8] = [
            (0.50, 0.40, 0.50, 0.17, 1.0),
            (0.30, 0.38, 0.52, 0.12, 0.9),
            (0.70, 0.39, 0.47, 0.13, 0.9),
            (0.40, 0.55, 0.50, 0.11, 0.9),
            (0.58, 0.58, 0.53, 0.12, 0.9),
            (0.49, 0.70, 0.50, 0.08, 0.8),
            (0.20, 0.33, 0.48, 0.07, 0.8),
            (0.79, 0.49, 0.50, 0.08, 0.8),
        ];
        let nf = f64::from(n);
        let mut values = Vec::with_capacity((n as usize).pow(3));
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let p = [
                        (f64::from(i) + 0.5) / nf,
                        (f64::from(j) + 0.5) / nf,
                        (f64::from(k) + 0.5) / nf,
                    ];
                    let shape: f64 = LOBES
                        .iter()
                        .map(|&(cx, cy, cz, r, w)| {
                            let d2 =
                                (p[0] - cx).powi(2) + (p[1] - cy).powi(2) + (p[2] - cz).powi(2);
                            w * (-d2 / (2.0 * r * r)).exp()
                        })
                        .sum::<f64>()
                        .min(1.2);
                    // Flatten the bottom: fade out below y = 0.32.
                    let floor = ((p[1] - 0.24) / 0.08).clamp(0.0, 1.0);
                    let detail = procedural::fbm(p, seed, 5.0, 3);
                    let density = (shape * floor * (1.0 + 3.0 * (detail - 0.5)) - 0.35) * 2.0;
                    values.push(density.max(0.0) as f32);
                }
            }
        }
        DensityGrid::from_values(n, values)
    }

    /// Voxels per axis.
    pub fn n(&self) -> u32 {
        self.n
    }

    /// The voxel values, index `(k · n + j) · n + i`.
    pub fn values(&self) -> &[f32] {
        &self.values
    }

    fn voxel(&self, i: u32, j: u32, k: u32) -> f32 {
        self.values[((k * self.n + j) * self.n + i) as usize]
    }

    /// Trilinear density at `p` (unit-cube coordinates; outside the cube the edge voxels are
    /// extended). The `f32` operations are those of [`WGSL`]'s `cloud_density`, in order.
    pub fn density(&self, p: [f32; 3]) -> f32 {
        let nf = self.n as f32;
        let u = p.map(|c| (c * nf - 0.5).clamp(0.0, nf - 1.0));
        let i = u.map(|c| (c.floor() as u32).min(self.n - 2));
        let f = [u[0] - i[0] as f32, u[1] - i[1] as f32, u[2] - i[2] as f32];
        let lerp_x = |j: u32, k: u32| {
            let a = self.voxel(i[0], j, k);
            a + (self.voxel(i[0] + 1, j, k) - a) * f[0]
        };
        let c00 = lerp_x(i[1], i[2]);
        let c10 = lerp_x(i[1] + 1, i[2]);
        let c01 = lerp_x(i[1], i[2] + 1);
        let c11 = lerp_x(i[1] + 1, i[2] + 1);
        let c0 = c00 + (c10 - c00) * f[1];
        let c1 = c01 + (c11 - c01) * f[1];
        c0 + (c1 - c0) * f[2]
    }

    /// [`density`](Self::density) in `f64` (for the ground truth).
    pub fn density_f64(&self, p: [f64; 3]) -> f64 {
        let nf = f64::from(self.n);
        let u = p.map(|c| (c * nf - 0.5).clamp(0.0, nf - 1.0));
        let i = u.map(|c| (c.floor() as u32).min(self.n - 2));
        let f = [
            u[0] - f64::from(i[0]),
            u[1] - f64::from(i[1]),
            u[2] - f64::from(i[2]),
        ];
        let v = |di: u32, dj: u32, dk: u32| f64::from(self.voxel(i[0] + di, i[1] + dj, i[2] + dk));
        let lerp_x = |dj: u32, dk: u32| v(0, dj, dk) + (v(1, dj, dk) - v(0, dj, dk)) * f[0];
        let c0 = lerp_x(0, 0) + (lerp_x(1, 0) - lerp_x(0, 0)) * f[1];
        let c1 = lerp_x(0, 1) + (lerp_x(1, 1) - lerp_x(0, 1)) * f[1];
        c0 + (c1 - c0) * f[2]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trilinear_reproduces_voxel_centres_and_linear_fields() {
        let n = 4u32;
        // A linear field v = i + 2j + 3k is reproduced exactly by trilinear interpolation.
        let values: Vec<f32> = (0..64)
            .map(|idx| {
                let (i, j, k) = (idx % 4, idx / 4 % 4, idx / 16);
                (i + 2 * j + 3 * k) as f32
            })
            .collect();
        let grid = DensityGrid::from_values(n, values);
        assert_eq!(grid.density([0.125, 0.375, 0.625]), 0.0 + 2.0 + 6.0);
        let p = [0.3f32, 0.55, 0.8];
        let expected = |c: f32| c * 4.0 - 0.5;
        let linear = expected(p[0]) + 2.0 * expected(p[1]) + 3.0 * expected(p[2]);
        assert!((grid.density(p) - linear).abs() < 1e-5);
        let p64 = p.map(f64::from);
        assert!((grid.density_f64(p64) - f64::from(grid.density(p))).abs() < 1e-5);
        // Outside the cube the edge value is held.
        assert_eq!(grid.density([-1.0, 0.125, 0.125]), 0.0);
    }

    #[test]
    fn cloud_is_deterministic_bounded_and_empty_at_the_faces() {
        let grid = DensityGrid::cloud(24, 5);
        assert_eq!(grid, DensityGrid::cloud(24, 5));
        assert_ne!(grid, DensityGrid::cloud(24, 6));
        let max = grid.values().iter().copied().fold(0.0, f32::max);
        assert!(max > 1.0 && max <= 5.3, "peak density {max}");
        let n = grid.n();
        for a in 0..n {
            for b in 0..n {
                for face in [
                    (0, a, b),
                    (n - 1, a, b),
                    (a, 0, b),
                    (a, n - 1, b),
                    (a, b, 0),
                    (a, b, n - 1),
                ] {
                    assert_eq!(grid.voxel(face.0, face.1, face.2), 0.0, "{face:?}");
                }
            }
        }
    }
}
