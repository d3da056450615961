//! STBN's error after 64 frames is lower than white noise's on every scene (vector STBN's than
//! white vectors' on the AO scene), by the margin these
//! small configurations measured (CPU renderer; everything is seeded, so the figures are exact
//! for this code and only move when the generator, the scene or the renderer changes).

use stbn_runtime::Encoding;
use stbn_scenes::ao::{AmbientOcclusion, AoParams};
use stbn_scenes::cloud::{Cloud, CloudParams};
use stbn_scenes::compare::{Accumulation, Backend, Comparison, Metric};
use stbn_scenes::density::DensityGrid;
use stbn_scenes::heightfield::Heightfield;
use stbn_scenes::noise::{NoiseKind, NoiseMask, NoiseSpec};
use stbn_scenes::scene::Scene;
use stbn_scenes::transparency::{AlphaMode, Transparency};

/// 64 × 64 images over a 32 × 32 × 32 mask (so the 64 frames run through it twice).
const IMAGE: u32 = 64;
const FRAMES: u32 = 64;

/// `stbn` and `white` generated at 32 × 32 × 32.
fn masks(stbn: NoiseKind, white: NoiseKind) -> Vec<NoiseMask> {
    let spec = NoiseSpec {
        width: 32,
        height: 32,
        depth: 32,
        seed: 1,
        encoding: Encoding::Unorm16,
    };
    [white, stbn]
        .iter()
        .map(|&k| NoiseMask::generate(k, &spec).unwrap())
        .collect()
}

/// `error(stbn) / error(white)` after [`FRAMES`] frames, per RMSE metric and accumulation, in
/// the order of [`Metric::Rmse`], [`Metric::BlurredRmse`] × [`Accumulation::ALL`].
fn ratios(scene: &dyn Scene, stbn: NoiseKind, white: NoiseKind) -> Vec<f64> {
    let cmp = Comparison::run(scene, &masks(stbn, white), &[FRAMES], Backend::Cpu).unwrap();
    let mut out = Vec::new();
    for metric in [Metric::Rmse, Metric::BlurredRmse] {
        for accumulation in Accumulation::ALL {
            let stbn = cmp.error(stbn, accumulation, metric, FRAMES).unwrap();
            let white = cmp.error(white, accumulation, metric, FRAMES).unwrap();
            eprintln!(
                "{} {} {}: STBN {stbn:.5}, white {white:.5}, ratio {:.3}",
                scene.name(),
                metric.name(),
                accumulation.name(),
                stbn / white
            );
            out.push(stbn / white);
        }
    }
    out
}

/// Asserts each ratio is at most its bound (the measured ratio, rounded up at the second
/// decimal).
fn assert_at_most(scene: &str, ratios: &[f64], bounds: [f64; 4]) {
    for ((ratio, bound), what) in ratios.iter().zip(bounds).zip([
        "RMSE, EMA",
        "RMSE, mean",
        "blurred RMSE, EMA",
        "blurred RMSE, mean",
    ]) {
        assert!(
            *ratio <= bound,
            "{scene} {what}: STBN/white = {ratio:.3}, expected <= {bound}"
        );
    }
}

#[test]
fn transparency_half() {
    let scene = Transparency::new(IMAGE, IMAGE, AlphaMode::Constant(0.5));
    // Measured: 0.373, 0.266, 0.186, 0.153.
    assert_at_most(
        scene.name(),
        &ratios(&scene, NoiseKind::Stbn, NoiseKind::White),
        [0.38, 0.27, 0.19, 0.16],
    );
}

#[test]
fn transparency_ramp() {
    let scene = Transparency::new(IMAGE, IMAGE, AlphaMode::Ramp);
    // Measured: 0.453, 0.345, 0.261, 0.252.
    assert_at_most(
        scene.name(),
        &ratios(&scene, NoiseKind::Stbn, NoiseKind::White),
        [0.46, 0.35, 0.27, 0.26],
    );
}

#[test]
fn cloud() {
    let params = CloudParams {
        view_steps: 32,
        shadow_steps: 16,
        ..CloudParams::default()
    };
    let scene = Cloud::new(IMAGE, IMAGE, DensityGrid::cloud(32, 1), params);
    // Measured: 0.471, 0.378, 0.267, 0.297 (encoder version 2; 0.283 blurred-mean before it).
    assert_at_most(
        scene.name(),
        &ratios(&scene, NoiseKind::Stbn, NoiseKind::White),
        [0.48, 0.38, 0.27, 0.30],
    );
}

#[test]
fn ambient_occlusion() {
    let params = AoParams {
        steps: 8,
        truth_grid: 32,
        ..AoParams::default()
    };
    let scene = AmbientOcclusion::new(IMAGE, IMAGE, Heightfield::town(64, 1), params);
    let ratios = ratios(&scene, NoiseKind::StbnVectors, NoiseKind::WhiteVectors);
    // Measured: 0.698, 0.656, 0.658, 0.617 (GENERATOR_VERSION 11, default budget). The ratios
    // vary with the seed more than between recent versions: over seeds 1–5 their means are
    // 0.701, 0.656, 0.632, 0.611 (blurred: 0.576–0.658); version 10 (the cosine hemisphere's
    // Hilbert-order start) measured 0.708, 0.666, 0.627, 0.605 (0.586–0.659), version 9 0.710,
    // 0.667, 0.628, 0.615 (0.570–0.653), version 6 0.716, 0.673, 0.636, 0.606 (0.573–0.643).
    assert_at_most(scene.name(), &ratios, [0.70, 0.66, 0.66, 0.62]);
}
