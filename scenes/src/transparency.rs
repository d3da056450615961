//! Stochastic transparency (the NVIDIA STBN blog's Figure 3): one partly transparent layer over
//! black, drawn with a binary alpha test. A pixel shows the layer's colour when `ξ < α` and black
//! otherwise, so its expectation is exactly `α · colour`.

use crate::scene::{Scene, SceneInput};

/// Where the layer's coverage comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AlphaMode {
    /// The same α everywhere, in `[0, 1]` (the blog's figure uses 0.5).
    Constant(f32),
    /// A horizontal ramp: α = `(x + 0.5) / width`, from almost 0 at the left edge to almost 1 at
    /// the right, so every coverage level appears in one image.
    Ramp,
}

/// The layer: a colour texture and an alpha texture over a black background.
#[derive(Clone, Debug, PartialEq)]
pub struct Transparency {
    name: String,
    mode: AlphaMode,
    width: u32,
    height: u32,
    /// Layer colour per pixel, row-major, linear in `[0, 1]`.
    color: Vec<f32>,
    /// Layer coverage per pixel, row-major, in `[0, 1]`.
    alpha: Vec<f32>,
}

impl Transparency {
    /// A `width × height` layer with coverage `mode`. Its colour is a procedural texture: soft
    /// diagonal stripes between 0.35 and 1.0 (so the alpha noise, not the texture, dominates
    /// the error).
    pub fn new(width: u32, height: u32, mode: AlphaMode) -> Transparency {
        let name = match mode {
            AlphaMode::Constant(a) => format!("transparency_{}", (a * 100.0).round() as u32),
            AlphaMode::Ramp => "transparency_ramp".to_owned(),
        };
        let mut color = Vec::with_capacity(width as usize * height as usize);
        let mut alpha = Vec::with_capacity(color.capacity());
        for y in 0..height {
            for x in 0..width {
                let u = (f64::from(x) + 0.5) / f64::from(width);
                let v = (f64::from(y) + 0.5) / f64::from(height);
                let stripes = (std::f64::consts::TAU * 3.0 * (u + v)).cos();
                color.push((0.675 + 0.325 * stripes) as f32);
                alpha.push(match mode {
                    AlphaMode::Constant(a) => a,
                    AlphaMode::Ramp => u as f32,
                });
            }
        }
        Transparency {
            name,
            mode,
            width,
            height,
            color,
            alpha,
        }
    }

    /// The coverage mode.
    pub fn mode(&self) -> AlphaMode {
        self.mode
    }
}

impl Scene for Transparency {
    fn name(&self) -> &str {
        &self.name
    }

    fn description(&self) -> String {
        match self.mode {
            AlphaMode::Constant(a) => format!(
                "stochastic transparency: a striped layer at alpha {a} over black, binary alpha test `xi < alpha`"
            ),
            AlphaMode::Ramp => "stochastic transparency: a striped layer whose alpha ramps from 0 (left) to 1 (right) over black, binary alpha test `xi < alpha`".to_owned(),
        }
    }

    fn input(&self) -> SceneInput {
        SceneInput::Scalar
    }

    fn width(&self) -> u32 {
        self.width
    }

    fn height(&self) -> u32 {
        self.height
    }

    fn shade(&self, x: u32, y: u32, sample: [f32; 4]) -> f32 {
        let i = y as usize * self.width as usize + x as usize;
        if sample[0] < self.alpha[i] {
            self.color[i]
        } else {
            0.0
        }
    }

    /// Exactly `α · colour` per pixel (`P(ξ < α) = α` for uniform ξ).
    fn ground_truth(&self) -> Vec<f64> {
        self.color
            .iter()
            .zip(&self.alpha)
            .map(|(&c, &a)| f64::from(c) * f64::from(a))
            .collect()
    }

    fn wgsl(&self) -> String {
        format!(
            "
// scene_data: colour per pixel, then alpha per pixel (row-major).
fn scene_shade(x: u32, y: u32, s: vec4<f32>) -> f32 {{
    let i = y * {width}u + x;
    return select(0.0, scene_data[i], s.x < scene_data[i + {pixels}u]);
}}
",
            width = self.width,
            pixels = self.width * self.height,
        )
    }

    fn gpu_data(&self) -> Vec<f32> {
        let mut data = self.color.clone();
        data.extend_from_slice(&self.alpha);
        data
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn binary_alpha_test_averages_to_the_ground_truth() {
        // Over an exactly uniform set of ξ, the fraction below α is α up to 1/n.
        let scene = Transparency::new(16, 4, AlphaMode::Ramp);
        let truth = scene.ground_truth();
        let n = 4096;
        for (y, x) in [(0, 0), (1, 7), (3, 15)] {
            let mean = (0..n)
                .map(|i| {
                    let xi = ((i as f64 + 0.5) / n as f64) as f32;
                    f64::from(scene.shade(x, y, [xi, 0.0, 0.0, 0.0]))
                })
                .sum::<f64>()
                / n as f64;
            assert!((mean - truth[(y * 16 + x) as usize]).abs() <= 1.0 / n as f64);
        }
    }

    #[test]
    fn names_and_ranges() {
        let half = Transparency::new(8, 8, AlphaMode::Constant(0.5));
        assert_eq!(half.name(), "transparency_50");
        assert_eq!(
            Transparency::new(8, 8, AlphaMode::Ramp).name(),
            "transparency_ramp"
        );
        assert!(half.color.iter().all(|c| (0.35..=1.0).contains(c)));
        assert_eq!(half.gpu_data().len(), 128);
        assert_eq!(half.shade(3, 3, [0.4999, 0.0, 0.0, 0.0]), half.color[27]);
        assert_eq!(half.shade(3, 3, [0.5, 0.0, 0.0, 0.0]), 0.0);
    }
}
