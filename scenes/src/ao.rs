//! Hemisphere visibility / ambient occlusion (the STBN paper's §6.2) on a [`Heightfield`], one
//! cosine-distributed direction per pixel per frame.
//!
//! # The estimator
//!
//! An orthographic camera looks straight down on the terrain; pixel `(x, y)` sees the surface
//! point `P` above `((x + ½) / W, (y + ½) / H)`, with normal `n` ([`Heightfield::normal`]). The
//! sample is a direction `d` in the hemisphere around +z, distributed with density `cos θ / π`;
//! it is turned into the world direction `w = d.x · t + d.y · b + d.z · n` with the
//! orthonormal basis `(t, b, n)` of Duff et al. (2017). The ray `P + s · w` is marched in `m`
//! steps to the AO radius `R`; at each step the clearance `c_k = q_k.z − h(q_k.xy)` gives a
//! soft visibility
//!
//! `V = min_k clamp(c_k / (κ · s_k), 0, 1)`
//!
//! (`κ` the penumbra slope: a ray passing closer to the terrain than `κ · s` is partly blocked).
//! `V` is continuous in `d`, unlike a binary hit test, so the ground truth's quadrature converges
//! quickly and the GPU agrees with the CPU to rounding. On open flat ground the AO is
//! `1 − κ²/3`. With cosine-distributed directions the cosine of the AO integral is in the pdf,
//! so the estimate is `V` itself: the pixel's value is `E[V]`, the cosine-weighted visible
//! fraction of the hemisphere.

use crate::heightfield::{self, Heightfield};
use crate::scene::{Scene, SceneInput, wgsl_f32};

/// The occlusion test's constants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AoParams {
    /// AO radius `R`: rays are marched this far (terrain units; the terrain is 1 wide).
    pub radius: f32,
    /// March steps `m` over the radius, `≥ 1`.
    pub steps: u32,
    /// Penumbra slope `κ > 0`.
    pub softness: f32,
    /// The ground truth integrates over a `truth_grid × truth_grid` midpoint grid of azimuth and
    /// `cos θ` (see [`Scene::ground_truth`]).
    pub truth_grid: u32,
}

impl Default for AoParams {
    /// Radius 0.15, 16 steps, softness 0.15, a 64 × 64 truth grid.
    fn default() -> Self {
        AoParams {
            radius: 0.15,
            steps: 16,
            softness: 0.15,
            truth_grid: 64,
        }
    }
}

/// The AO scene: terrain, constants and image size.
#[derive(Clone, Debug)]
pub struct AmbientOcclusion {
    terrain: Heightfield,
    params: AoParams,
    width: u32,
    height: u32,
}

impl AmbientOcclusion {
    /// A `width × height` top view of `terrain` under `params`.
    ///
    /// Panics if `params.steps` or `params.truth_grid` is 0, or `softness` or `radius` is not
    /// positive.
    pub fn new(width: u32, height: u32, terrain: Heightfield, params: AoParams) -> Self {
        assert!(params.steps > 0 && params.truth_grid > 0, "steps");
        assert!(
            params.softness > 0.0 && params.radius > 0.0,
            "softness and radius must be > 0"
        );
        AmbientOcclusion {
            terrain,
            params,
            width,
            height,
        }
    }

    /// [`Heightfield::town`]`(terrain_n, seed)` under [`AoParams::default`].
    pub fn standard(width: u32, height: u32, terrain_n: u32, seed: u64) -> Self {
        AmbientOcclusion::new(
            width,
            height,
            Heightfield::town(terrain_n, seed),
            AoParams::default(),
        )
    }

    fn point(&self, x: u32, y: u32) -> [f32; 2] {
        [
            (x as f32 + 0.5) / self.width as f32,
            (y as f32 + 0.5) / self.height as f32,
        ]
    }

    /// The estimator in `f64` for pixel `(x, y)` and the tangent-space direction `d`.
    pub fn visibility_f64(&self, x: u32, y: u32, d: [f64; 3]) -> f64 {
        let p = self.point(x, y).map(f64::from);
        let n = self.terrain.normal_f64(p);
        let a = -1.0 / (1.0 + n[2]);
        let b = n[0] * n[1] * a;
        let t = [1.0 + n[0] * n[0] * a, b, -n[0]];
        let bt = [b, 1.0 + n[1] * n[1] * a, -n[1]];
        let w: [f64; 3] = std::array::from_fn(|k| t[k] * d[0] + bt[k] * d[1] + n[k] * d[2]);
        let z0 = self.terrain.height_f64(p);
        let step = f64::from(self.params.radius) / f64::from(self.params.steps);
        let kappa = f64::from(self.params.softness);
        let mut visibility = 1.0f64;
        for k in 1..=self.params.steps {
            let s = f64::from(k) * step;
            let clearance =
                z0 + w[2] * s - self.terrain.height_f64([p[0] + w[0] * s, p[1] + w[1] * s]);
            visibility = visibility.min((clearance / (kappa * s)).clamp(0.0, 1.0));
        }
        visibility
    }
}

impl AmbientOcclusion {
    /// Pixel `(x, y)`'s `∫ V(d) cos θ / π dω` by the midpoint rule on a `grid²` grid of azimuth
    /// `φ` and `z = cos θ`: with `dω = dφ dz`, the integral is `∫∫ V · 2z · dz · dφ / 2π`, so
    /// direction `(φ_i, z_j)` has weight `2 z_j / grid²` (the weights sum to exactly 1). Unlike
    /// the `(u1, u2)` map, `z` resolves the horizon, where the penumbra is.
    pub fn expected_visibility(&self, x: u32, y: u32, grid: u32) -> f64 {
        self.integrate(x, y, &truth_directions(grid))
    }

    fn integrate(&self, x: u32, y: u32, directions: &[([f64; 3], f64)]) -> f64 {
        directions
            .iter()
            .map(|&(d, weight)| weight * self.visibility_f64(x, y, d))
            .sum()
    }
}

/// The directions and weights of [`AmbientOcclusion::expected_visibility`]'s grid.
fn truth_directions(grid: u32) -> Vec<([f64; 3], f64)> {
    let cell = 1.0 / f64::from(grid);
    (0..grid * grid)
        .map(|k| {
            let phi = std::f64::consts::TAU * (f64::from(k % grid) + 0.5) * cell;
            let z = (f64::from(k / grid) + 0.5) * cell;
            let r = (1.0 - z * z).sqrt();
            ([r * phi.cos(), r * phi.sin(), z], 2.0 * z * cell * cell)
        })
        .collect()
}

impl Scene for AmbientOcclusion {
    fn name(&self) -> &str {
        "ao"
    }

    fn description(&self) -> String {
        format!(
            "ambient occlusion of a {n}×{n} heightfield seen from above: one cosine-distributed \
             direction per pixel per frame, soft visibility marched {steps} steps to radius {r} \
             (penumbra slope {k})",
            n = self.terrain.n(),
            steps = self.params.steps,
            r = self.params.radius,
            k = self.params.softness,
        )
    }

    fn input(&self) -> SceneInput {
        SceneInput::Direction
    }

    fn width(&self) -> u32 {
        self.width
    }

    fn height(&self) -> u32 {
        self.height
    }

    fn shade(&self, x: u32, y: u32, sample: [f32; 4]) -> f32 {
        let p = self.point(x, y);
        let n = self.terrain.normal(p);
        let a = -1.0 / (1.0 + n[2]);
        let b = n[0] * n[1] * a;
        let t = [1.0 + n[0] * n[0] * a, b, -n[0]];
        let bt = [b, 1.0 + n[1] * n[1] * a, -n[1]];
        let w: [f32; 3] =
            std::array::from_fn(|k| t[k] * sample[0] + bt[k] * sample[1] + n[k] * sample[2]);
        let z0 = self.terrain.height(p);
        let step = self.params.radius / self.params.steps as f32;
        let kappa = self.params.softness;
        let mut visibility = 1.0f32;
        for k in 1..=self.params.steps {
            let s = k as f32 * step;
            let clearance = z0 + w[2] * s - self.terrain.height([p[0] + w[0] * s, p[1] + w[1] * s]);
            visibility = visibility.min((clearance / (kappa * s)).clamp(0.0, 1.0));
        }
        visibility
    }

    /// Per pixel, [`AmbientOcclusion::expected_visibility`] on a `truth_grid²` grid.
    fn ground_truth(&self) -> Vec<f64> {
        use rayon::prelude::*;
        let directions = truth_directions(self.params.truth_grid);
        (0..self.width * self.height)
            .into_par_iter()
            .map(|pixel| self.integrate(pixel % self.width, pixel / self.width, &directions))
            .collect()
    }

    fn wgsl(&self) -> String {
        format!(
            "
const TERRAIN_N: u32 = {n}u;
{terrain}
fn scene_shade(x: u32, y: u32, s: vec4<f32>) -> f32 {{
    let p = vec2<f32>((f32(x) + 0.5) / f32({width}u), (f32(y) + 0.5) / f32({height}u));
    let n = terrain_normal(p);
    let a = -1.0 / (1.0 + n.z);
    let b = n.x * n.y * a;
    let t = vec3<f32>(1.0 + n.x * n.x * a, b, -n.x);
    let bt = vec3<f32>(b, 1.0 + n.y * n.y * a, -n.y);
    let w = vec3<f32>(
        t.x * s.x + bt.x * s.y + n.x * s.z,
        t.y * s.x + bt.y * s.y + n.y * s.z,
        t.z * s.x + bt.z * s.y + n.z * s.z,
    );
    let z0 = terrain_height(p);
    let step = {radius} / f32({steps}u);
    var visibility = 1.0;
    for (var k = 1u; k <= {steps}u; k++) {{
        let d = f32(k) * step;
        let clearance = z0 + w.z * d - terrain_height(vec2<f32>(p.x + w.x * d, p.y + w.y * d));
        visibility = min(visibility, clamp(clearance / ({kappa} * d), 0.0, 1.0));
    }}
    return visibility;
}}
",
            n = self.terrain.n(),
            terrain = heightfield::WGSL,
            width = self.width,
            height = self.height,
            radius = wgsl_f32(self.params.radius),
            steps = self.params.steps,
            kappa = wgsl_f32(self.params.softness),
        )
    }

    fn gpu_data(&self) -> Vec<f32> {
        self.terrain.heights().to_vec()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sample::cosine_direction_f64;

    fn small() -> AmbientOcclusion {
        AmbientOcclusion::standard(32, 32, 32, 1)
    }

    #[test]
    fn flat_open_ground_matches_the_closed_form() {
        let flat = Heightfield::from_heights(4, vec![0.0; 16]);
        let params = AoParams::default();
        let scene = AmbientOcclusion::new(4, 4, flat, params);
        let kappa = f64::from(params.softness);
        let exact = 1.0 - kappa * kappa / 3.0;
        // Measured: 0.99237 vs 0.99250 (the midpoint rule at the penumbra's kink).
        for v in scene.ground_truth() {
            assert!((v - exact).abs() < 2e-4, "{v} vs {exact}");
        }
        // Straight up is fully visible, a grazing direction partly.
        assert_eq!(scene.shade(1, 1, [0.0, 0.0, 1.0, 0.0]), 1.0);
        let grazing = scene.shade(1, 1, [0.99, 0.0, 0.1411, 0.0]);
        assert!((grazing - 0.1411 / 0.15).abs() < 1e-3, "{grazing}");
    }

    #[test]
    fn ground_truth_matches_a_finer_grid() {
        // The demo's configuration (256 × 256 over a 128² terrain), on a spread of pixels.
        let scene = AmbientOcclusion::standard(256, 256, 128, 1);
        let grid = AoParams::default().truth_grid;
        let (mut worst, mut sum2, mut count) = (0.0f64, 0.0f64, 0);
        for y in (3..256).step_by(71) {
            for x in (5..256).step_by(83) {
                let coarse = scene.expected_visibility(x, y, grid);
                let fine = scene.expected_visibility(x, y, 3 * grid);
                worst = worst.max((coarse - fine).abs());
                sum2 += (coarse - fine).powi(2);
                count += 1;
            }
        }
        let rms = (sum2 / f64::from(count)).sqrt();
        // Measured on these 12 pixels: worst 1.56e-3, rms 6.2e-4 (64² vs 192²; over 35 pixels
        // rms 4.9e-4).
        assert!(worst < 2e-3 && rms < 7e-4, "worst {worst}, rms {rms}");
    }

    #[test]
    fn f32_estimator_follows_the_f64_one() {
        let scene = small();
        for (x, y) in [(8, 9), (16, 14), (25, 27), (4, 28)] {
            for (u1, u2) in [(0.1, 0.2), (0.5, 0.9), (0.8, 0.5), (0.33, 0.05)] {
                let d = cosine_direction_f64(u1, u2);
                let sample = [d[0] as f32, d[1] as f32, d[2] as f32, 0.0];
                let a = f64::from(scene.shade(x, y, sample));
                let b = scene.visibility_f64(x, y, d);
                assert!((a - b).abs() < 1e-4, "({x}, {y}) {d:?}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn occluded_pixels_are_darker() {
        let scene = AmbientOcclusion::standard(200, 200, 100, 1);
        // Town block (1, 1) stands (seed 1 gives it r >= 0.15): the street beside its wall is
        // darker than the middle of its roof, which sees the open sky.
        assert!(crate::procedural::lattice([1, 1, 5], 1) >= 0.15);
        let roof = scene.expected_visibility(60, 60, 32);
        let street = scene.expected_visibility(60, 82, 32);
        assert!(street < roof - 0.2, "street {street}, roof {roof}");
        assert!(roof > 0.95 && street > 0.0);
    }
}
