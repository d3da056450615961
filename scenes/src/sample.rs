//! How a pixel's sample is read from a mask: which slice at each frame ([`FrameOrder`]) and how
//! its values become the sample ([`SampleMode`]), on the CPU ([`pixel_sample`]) and in WGSL
//! ([`wgsl_pixel_sample`]), with the same `f32` operations on both sides.

use stbn_runtime::{OffsetStbn, Stbn, ValueMap};

use crate::scene::SceneInput;

/// Which mask slice frame `t` reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FrameOrder {
    /// Slice `t mod depth` ([`Stbn::sample`]): the mask's sequence repeats every `depth`
    /// frames.
    Wrap,
    /// The mask read through [`Stbn::progressive`]: slice `t mod depth`, shifted toroidally in
    /// x and y by the R2 offset of pass `t / depth` (none for the first `depth` frames).
    Progressive,
}

impl FrameOrder {
    /// The view of `mask` that reads its frames in this order (on the GPU, its
    /// [`stbn_runtime::gpu::MaskUniform`]).
    pub fn view<'m>(self, mask: &'m Stbn<'_>) -> OffsetStbn<'m> {
        match self {
            FrameOrder::Wrap => mask.into(),
            FrameOrder::Progressive => mask.progressive(),
        }
    }
}

/// How a pixel turns a mask into its sample `[f32; 4]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SampleMode {
    /// The scalar value `u`: `[u, 0, 0, 0]`.
    Scalar,
    /// Dimensions 0 and 1 of a scalar mask (`sample` and `dimension(1).sample`, the runtime's R2
    /// offset) mapped by [`cosine_direction`]: `[x, y, z, 0]`.
    CosinePair,
    /// The unit direction a vector mask stores (octahedral or signed): `[x, y, z, 0]`.
    Direction,
}

impl SampleMode {
    /// What the samples are.
    pub fn input(self) -> SceneInput {
        match self {
            SampleMode::Scalar => SceneInput::Scalar,
            SampleMode::CosinePair | SampleMode::Direction => SceneInput::Direction,
        }
    }
}

/// The cosine-weighted hemisphere direction (around +z) of `(u1, u2) ∈ [0, 1)²`:
/// `φ = 2π u1`, `r = √u2`, `(r cos φ, r sin φ, √(1 − u2))` (Malley's method; density
/// `cos θ / π` per steradian for uniform `(u1, u2)`). The operations of [`WGSL_COSINE`].
pub fn cosine_direction(u1: f32, u2: f32) -> [f32; 3] {
    let phi = std::f32::consts::TAU * u1;
    let r = u2.sqrt();
    [r * phi.cos(), r * phi.sin(), (1.0 - u2).max(0.0).sqrt()]
}

/// [`cosine_direction`] in `f64` (for ground truths).
pub fn cosine_direction_f64(u1: f64, u2: f64) -> [f64; 3] {
    let phi = std::f64::consts::TAU * u1;
    let r = u2.sqrt();
    [r * phi.cos(), r * phi.sin(), (1.0 - u2).max(0.0).sqrt()]
}

/// WGSL for [`cosine_direction`]: `fn cosine_direction(u1: f32, u2: f32) -> vec3<f32>`.
pub const WGSL_COSINE: &str = "
fn cosine_direction(u1: f32, u2: f32) -> vec3<f32> {
    let phi = 6.2831855 * u1;
    let r = sqrt(u2);
    return vec3<f32>(r * cos(phi), r * sin(phi), sqrt(max(1.0 - u2, 0.0)));
}
";

/// Pixel `(x, y)`'s sample at `frame` under `mode`, read through `noise` (a view of the mask,
/// [`FrameOrder::view`]; the mask tiles the image toroidally).
pub fn pixel_sample(
    noise: OffsetStbn<'_>,
    mode: SampleMode,
    x: i32,
    y: i32,
    frame: u32,
) -> [f32; 4] {
    match mode {
        SampleMode::Scalar => [noise.sample(x, y, frame), 0.0, 0.0, 0.0],
        SampleMode::CosinePair => {
            let u2 = noise.dimension(1).sample(x, y, frame);
            let [a, b, c] = cosine_direction(noise.sample(x, y, frame), u2);
            [a, b, c, 0.0]
        }
        SampleMode::Direction => noise.sample_vector(x, y, frame).value.to_array(),
    }
}

/// WGSL defining `fn pixel_sample(x: i32, y: i32, frame: u32) -> vec4<f32>`, the shader twin of
/// [`pixel_sample`] for `mode` and a mask with `value_map`. It reads the bindings `noise`
/// (`texture_3d<f32>`) and `noise_dim0` (`StbnMask`, the uniform of the view), and for
/// [`SampleMode::CosinePair`] `noise_dim1` (`StbnMask`, the uniform of the view's
/// `dimension(1)`).
pub fn wgsl_pixel_sample(mode: SampleMode, value_map: ValueMap) -> String {
    let body = match (mode, value_map) {
        (SampleMode::Scalar, _) => "return vec4<f32>(s.x, 0.0, 0.0, 0.0);",
        (SampleMode::CosinePair, _) => {
            "let u2 = stbn_sample_3d(noise, noise_dim1, x, y, frame).x;
    return vec4<f32>(cosine_direction(s.x, u2), 0.0);"
        }
        (SampleMode::Direction, ValueMap::Octahedral) => {
            "return vec4<f32>(stbn_octahedral(s.xy), 0.0);"
        }
        (SampleMode::Direction, _) => "return vec4<f32>(normalize(stbn_signed(s).xyz), 0.0);",
    };
    format!(
        "{WGSL_COSINE}
fn pixel_sample(x: i32, y: i32, frame: u32) -> vec4<f32> {{
    let s = stbn_sample_3d(noise, noise_dim0, x, y, frame);
    {body}
}}
"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cosine_directions_are_unit_and_cosine_distributed() {
        // Midpoint grid over (u1, u2): E[z] = 2/3 and E[z²] = 1/2 under cos θ / π.
        let n = 200;
        let (mut ez, mut ez2) = (0.0f64, 0.0f64);
        for i in 0..n {
            for j in 0..n {
                let u = |k: i32| (f64::from(k) + 0.5) / f64::from(n);
                let d = cosine_direction(u(i) as f32, u(j) as f32);
                let len = d.iter().map(|c| c * c).sum::<f32>().sqrt();
                assert!((len - 1.0).abs() < 1e-6);
                ez += f64::from(d[2]);
                ez2 += f64::from(d[2] * d[2]);
            }
        }
        let count = f64::from(n * n);
        assert!((ez / count - 2.0 / 3.0).abs() < 1e-4);
        assert!((ez2 / count - 0.5).abs() < 1e-4);
        let a = cosine_direction(0.3, 0.7);
        let b = cosine_direction_f64(0.3, 0.7);
        assert!((0..3).all(|k| (f64::from(a[k]) - b[k]).abs() < 1e-6));
    }

    #[test]
    fn wgsl_constant_is_tau() {
        assert_eq!("6.2831855".parse::<f32>().unwrap(), std::f32::consts::TAU);
    }
}
