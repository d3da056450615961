//! [`Heightfield`]: a terrain over the unit square on a grid, with the bilinear height and the
//! normal the AO scene uses on the CPU (`f32` and `f64`) and the GPU ([`WGSL`]).

use crate::procedural;

/// An `n × n` grid of heights over `[0, 1]²`: texel `(i, j)` holds the height at its centre
/// `((i + ½) / n, (j + ½) / n)`, index `j · n + i`. Heights are in the same units as the square's
/// side (a height of 0.1 is a tenth of the terrain's width).
#[derive(Clone, Debug, PartialEq)]
pub struct Heightfield {
    n: u32,
    heights: Vec<f32>,
}

/// WGSL for [`Heightfield::height`] and [`Heightfield::normal`]: `fn terrain_height(p: vec2<f32>)
/// -> f32` and `fn terrain_normal(p: vec2<f32>) -> vec3<f32>`, reading the grid from
/// `scene_data` at index 0. Needs a `const TERRAIN_N: u32` (the grid's `n`) in front.
pub const WGSL: &str = "
fn terrain_texel(i: u32, j: u32) -> f32 {
    return scene_data[j * TERRAIN_N + i];
}

fn terrain_height(p: vec2<f32>) -> f32 {
    let nf = f32(TERRAIN_N);
    let u = clamp(p * nf - vec2<f32>(0.5), vec2<f32>(0.0), vec2<f32>(nf - 1.0));
    let i = min(vec2<u32>(floor(u)), vec2<u32>(TERRAIN_N - 2u));
    let f = u - vec2<f32>(i);
    let h0 = terrain_texel(i.x, i.y) + (terrain_texel(i.x + 1u, i.y) - terrain_texel(i.x, i.y)) * f.x;
    let h1 = terrain_texel(i.x, i.y + 1u) + (terrain_texel(i.x + 1u, i.y + 1u) - terrain_texel(i.x, i.y + 1u)) * f.x;
    return h0 + (h1 - h0) * f.y;
}

fn terrain_normal(p: vec2<f32>) -> vec3<f32> {
    let e = 1.0 / f32(TERRAIN_N);
    let half_n = 0.5 * f32(TERRAIN_N);
    let gx = (terrain_height(vec2<f32>(p.x + e, p.y)) - terrain_height(vec2<f32>(p.x - e, p.y))) * half_n;
    let gy = (terrain_height(vec2<f32>(p.x, p.y + e)) - terrain_height(vec2<f32>(p.x, p.y - e))) * half_n;
    let v = vec3<f32>(-gx, -gy, 1.0);
    return v / sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
}
";

impl Heightfield {
    /// A grid from its heights; panics unless `n ≥ 2`, `heights.len() == n²` and every height is
    /// finite.
    pub fn from_heights(n: u32, heights: Vec<f32>) -> Heightfield {
        assert!(n >= 2, "a bilinear grid needs n >= 2");
        assert_eq!(heights.len(), (n as usize).pow(2), "height count vs n²");
        assert!(
            heights.iter().all(|h| h.is_finite()),
            "heights must be finite"
        );
        Heightfield { n, heights }
    }

    /// A town seen from above: a 5 × 5 grid of blocks (squares 0.14 wide with corners rounded
    /// to 0.02, streets 0.06 wide between them) on rolling ground (four octaves of value noise,
    /// amplitude 0.03). Each block's height is `0.04 + 0.14 · r` with `r` uniform from `seed`;
    /// blocks with `r < 0.15` are left empty (squares). Edges are smoothed over about two texels.
    /// Heights lie in `[0, 0.18]`.
    pub fn town(n: u32, seed: u64) -> Heightfield {
        const BLOCKS: i64 = 5;
        const HALF_SIZE: f64 = 0.07;
        const CORNER: f64 = 0.02;
        let nf = f64::from(n);
        let edge = 2.0 / nf;
        let cell = 1.0 / BLOCKS as f64;
        let mut heights = Vec::with_capacity((n as usize).pow(2));
        for j in 0..n {
            for i in 0..n {
                let (x, y) = ((f64::from(i) + 0.5) / nf, (f64::from(j) + 0.5) / nf);
                let mut h = 0.03 * procedural::fbm([x, y, 0.5], seed, 6.0, 4);
                let (bx, by) = ((x / cell).floor(), (y / cell).floor());
                let r = procedural::lattice([bx as i64, by as i64, BLOCKS], seed);
                if r >= 0.15 {
                    // Signed distance to the rounded square, negative inside.
                    let (cx, cy) = ((bx + 0.5) * cell, (by + 0.5) * cell);
                    let q = [
                        (x - cx).abs() - (HALF_SIZE - CORNER),
                        (y - cy).abs() - (HALF_SIZE - CORNER),
                    ];
                    let outside = (q[0].max(0.0).powi(2) + q[1].max(0.0).powi(2)).sqrt();
                    let d = outside + q[0].max(q[1]).min(0.0) - CORNER;
                    let t = (0.5 - d / edge).clamp(0.0, 1.0);
                    h = h.max((0.04 + 0.14 * r) * t * t * (3.0 - 2.0 * t));
                }
                heights.push(h as f32);
            }
        }
        Heightfield::from_heights(n, heights)
    }

    /// Texels per axis.
    pub fn n(&self) -> u32 {
        self.n
    }

    /// The heights, index `j · n + i`.
    pub fn heights(&self) -> &[f32] {
        &self.heights
    }

    fn texel(&self, i: u32, j: u32) -> f32 {
        self.heights[(j * self.n + i) as usize]
    }

    /// Bilinear height at `p` (outside the square the edge texels extend). The `f32` operations
    /// of [`WGSL`]'s `terrain_height`, in order.
    pub fn height(&self, p: [f32; 2]) -> f32 {
        let nf = self.n as f32;
        let u = p.map(|c| (c * nf - 0.5).clamp(0.0, nf - 1.0));
        let i = u.map(|c| (c.floor() as u32).min(self.n - 2));
        let f = [u[0] - i[0] as f32, u[1] - i[1] as f32];
        let h0 =
            self.texel(i[0], i[1]) + (self.texel(i[0] + 1, i[1]) - self.texel(i[0], i[1])) * f[0];
        let h1 = self.texel(i[0], i[1] + 1)
            + (self.texel(i[0] + 1, i[1] + 1) - self.texel(i[0], i[1] + 1)) * f[0];
        h0 + (h1 - h0) * f[1]
    }

    /// The unit normal at `p` from central differences one texel apart: `(−∂h/∂x, −∂h/∂y, 1)`
    /// normalised. The operations of [`WGSL`]'s `terrain_normal`.
    pub fn normal(&self, p: [f32; 2]) -> [f32; 3] {
        let e = 1.0 / self.n as f32;
        let half_n = 0.5 * self.n as f32;
        let gx = (self.height([p[0] + e, p[1]]) - self.height([p[0] - e, p[1]])) * half_n;
        let gy = (self.height([p[0], p[1] + e]) - self.height([p[0], p[1] - e])) * half_n;
        let v = [-gx, -gy, 1.0f32];
        let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        v.map(|c| c / len)
    }

    /// [`height`](Self::height) in `f64`.
    pub fn height_f64(&self, p: [f64; 2]) -> f64 {
        let nf = f64::from(self.n);
        let u = p.map(|c| (c * nf - 0.5).clamp(0.0, nf - 1.0));
        let i = u.map(|c| (c.floor() as u32).min(self.n - 2));
        let f = [u[0] - f64::from(i[0]), u[1] - f64::from(i[1])];
        let t = |di: u32, dj: u32| f64::from(self.texel(i[0] + di, i[1] + dj));
        let h0 = t(0, 0) + (t(1, 0) - t(0, 0)) * f[0];
        let h1 = t(0, 1) + (t(1, 1) - t(0, 1)) * f[0];
        h0 + (h1 - h0) * f[1]
    }

    /// [`normal`](Self::normal) in `f64`.
    pub fn normal_f64(&self, p: [f64; 2]) -> [f64; 3] {
        let e = 1.0 / f64::from(self.n);
        let half_n = 0.5 * f64::from(self.n);
        let gx = (self.height_f64([p[0] + e, p[1]]) - self.height_f64([p[0] - e, p[1]])) * half_n;
        let gy = (self.height_f64([p[0], p[1] + e]) - self.height_f64([p[0], p[1] - e])) * half_n;
        let len = (gx * gx + gy * gy + 1.0).sqrt();
        [-gx / len, -gy / len, 1.0 / len]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bilinear_reproduces_planes_and_their_normals() {
        // h = 0.1 x + 0.2 y is reproduced exactly by bilinear interpolation inside the grid.
        let n = 8u32;
        let heights = (0..64)
            .map(|k| {
                let (i, j) = (k % 8, k / 8);
                (0.1 * (i as f64 + 0.5) / 8.0 + 0.2 * (j as f64 + 0.5) / 8.0) as f32
            })
            .collect();
        let field = Heightfield::from_heights(n, heights);
        let p = [0.43f32, 0.61];
        assert!((field.height(p) - (0.1 * 0.43 + 0.2 * 0.61)).abs() < 1e-6);
        let normal = field.normal(p);
        let len = (1.0f32 + 0.01 + 0.04).sqrt();
        let expected = [-0.1 / len, -0.2 / len, 1.0 / len];
        assert!(
            (0..3).all(|k| (normal[k] - expected[k]).abs() < 1e-5),
            "{normal:?}"
        );
        let n64 = field.normal_f64([0.43, 0.61]);
        assert!((0..3).all(|k| (n64[k] - f64::from(expected[k])).abs() < 1e-6));
        assert!((field.height_f64([0.43, 0.61]) - f64::from(field.height(p))).abs() < 1e-6);
    }

    #[test]
    fn town_is_deterministic_and_in_range() {
        let town = Heightfield::town(64, 3);
        assert_eq!(town, Heightfield::town(64, 3));
        assert_ne!(town, Heightfield::town(64, 4));
        // Block tops are flat at 0.04 + 0.14 r; street crossings hold only the ground.
        let mut blocks = 0;
        for (bx, by) in [(0, 0), (1, 2), (2, 2), (4, 3), (3, 1)] {
            let r = procedural::lattice([bx, by, 5], 3);
            let centre = [(bx as f32 + 0.5) * 0.2, (by as f32 + 0.5) * 0.2];
            if r >= 0.15 {
                assert!((town.height(centre) - (0.04 + 0.14 * r) as f32).abs() < 1e-6);
                blocks += 1;
            }
        }
        assert!(blocks >= 3);
        assert!(town.height([0.4, 0.6]) < 0.03);
        let (lo, hi) = town
            .heights()
            .iter()
            .fold((f32::MAX, f32::MIN), |(lo, hi), &h| (lo.min(h), hi.max(h)));
        assert!((0.0..0.03).contains(&lo), "lowest {lo}");
        assert!(hi > 0.1 && hi <= 0.18, "highest {hi}");
    }
}
