//! [`Scene`]: what every demo scene provides to the CPU and GPU renderers.

/// What a scene consumes per pixel per frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SceneInput {
    /// One number `ξ ∈ [0, 1)` in `sample[0]`.
    Scalar,
    /// A unit direction in the hemisphere around +z, cosine-distributed (density `cos θ / π`),
    /// in `sample[0..3]`.
    Direction,
}

/// A scene rendered with one random sample per pixel per frame.
///
/// The CPU renderer calls [`shade`](Scene::shade); the GPU renderer compiles
/// [`wgsl`](Scene::wgsl) and binds [`gpu_data`](Scene::gpu_data). Both must compute the same
/// function with the same `f32` operations, so that their images agree to rounding.
pub trait Scene: Sync {
    /// A short lowercase name for directories and tables, e.g. `transparency_50`.
    fn name(&self) -> &str;

    /// One line saying what the scene is.
    fn description(&self) -> String;

    /// What the scene's samples are.
    fn input(&self) -> SceneInput;

    /// Image width in pixels.
    fn width(&self) -> u32;

    /// Image height in pixels.
    fn height(&self) -> u32;

    /// The one-sample estimate of pixel `(x, y)` (`x < width`, `y < height`) for `sample` (as
    /// [`input`](Scene::input) describes): linear radiance, in `[0, 1]` for the scenes of this
    /// crate.
    fn shade(&self, x: u32, y: u32, sample: [f32; 4]) -> f32;

    /// The converged image: every pixel's expectation of [`shade`](Scene::shade) over the
    /// sample's distribution, row-major, computed in `f64` (analytically or by quadrature; each
    /// scene documents how and how accurately).
    fn ground_truth(&self) -> Vec<f64>;

    /// WGSL defining `fn scene_shade(x: u32, y: u32, s: vec4<f32>) -> f32`, the GPU twin of
    /// [`shade`](Scene::shade). It may read the renderer-declared
    /// `var<storage, read> scene_data: array<f32>` holding [`gpu_data`](Scene::gpu_data), and
    /// must not declare bindings of its own.
    fn wgsl(&self) -> String;

    /// The contents of `scene_data` (at least one element).
    fn gpu_data(&self) -> Vec<f32>;
}

/// `value` as a WGSL `f32` expression that evaluates to exactly `value`: the shortest decimal
/// of `f64::from(value)`, which parses back to that `f64` (an exact copy of the `f32`), so the
/// shader's conversion to `f32` does not round.
///
/// Panics on NaN and infinities, which WGSL has no literal for.
pub fn wgsl_f32(value: f32) -> String {
    assert!(value.is_finite(), "WGSL has no literal for {value}");
    format!("f32({:?})", f64::from(value))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wgsl_literals_round_trip() {
        for v in [0.1f32, 30.0, 1e-7, -2.5, 0.0, 3.4e38] {
            let text = wgsl_f32(v);
            let inner = text.trim_start_matches("f32(").trim_end_matches(')');
            assert_eq!(inner.parse::<f64>().unwrap(), f64::from(v), "{text}");
            assert!(inner.contains('.') || inner.contains('e'), "{text}");
        }
    }
}
