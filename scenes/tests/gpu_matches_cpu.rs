//! The wgpu renderer and the CPU renderer produce the same accumulated images, on a real
//! Vulkan adapter (lavapipe on a machine without a GPU). A missing adapter fails the test with
//! the package to install; it never skips.

use stbn_runtime::Encoding;
use stbn_scenes::ao::{AmbientOcclusion, AoParams};
use stbn_scenes::cloud::{Cloud, CloudParams};
use stbn_scenes::density::DensityGrid;
use stbn_scenes::gpu::{GpuContext, GpuSceneRenderer};
use stbn_scenes::heightfield::Heightfield;
use stbn_scenes::image::max_abs_diff;
use stbn_scenes::noise::{NoiseKind, NoiseMask, NoiseSpec};
use stbn_scenes::render::render_cpu;
use stbn_scenes::sample::{FrameOrder, SampleMode};
use stbn_scenes::scene::Scene;
use stbn_scenes::transparency::{AlphaMode, Transparency};

/// Frame counts compared; 20 frames are 2.5 passes through the 8-frame masks, so the
/// progressive source reads three epochs.
const CHECKPOINTS: [u32; 3] = [1, 4, 20];

fn vulkan() -> GpuContext {
    GpuContext::new(wgpu::Backends::VULKAN).unwrap_or_else(|e| panic!("{e}"))
}

fn masks(kinds: &[NoiseKind], encoding: Encoding) -> Vec<NoiseMask> {
    let spec = NoiseSpec {
        width: 16,
        height: 16,
        depth: 8,
        seed: 11,
        encoding,
    };
    kinds
        .iter()
        .map(|&k| NoiseMask::generate(k, &spec).unwrap())
        .collect()
}

const SCALAR: [NoiseKind; 3] = [
    NoiseKind::White,
    NoiseKind::Stbn,
    NoiseKind::StbnProgressive,
];

/// The largest difference between GPU and CPU EMA and mean images over every checkpoint and
/// mask.
fn worst_difference(ctx: &GpuContext, scene: &dyn Scene, masks: &[NoiseMask]) -> f32 {
    let renderer = GpuSceneRenderer::new(ctx, scene);
    let mut worst = 0.0f32;
    for mask in masks {
        let noise = mask.view();
        let (order, mode) = (mask.kind.frame_order(), mask.kind.sample_mode());
        let gpu = renderer.render(&noise, order, mode, &CHECKPOINTS).unwrap();
        let cpu = render_cpu(scene, &noise, order, mode, &CHECKPOINTS);
        assert_eq!(gpu.len(), cpu.len());
        for (g, c) in gpu.iter().zip(&cpu) {
            assert_eq!(g.frames, c.frames);
            worst = worst
                .max(max_abs_diff(&g.ema.pixels, &c.ema.pixels))
                .max(max_abs_diff(&g.mean.pixels, &c.mean.pixels));
        }
        // The images are not trivially equal: they vary over the frame.
        let last = &cpu.last().unwrap().ema.pixels;
        assert!(last.iter().any(|&v| v != last[0]));
    }
    let kinds: Vec<&str> = masks.iter().map(|m| m.kind.name()).collect();
    eprintln!(
        "{} with {kinds:?} on {}: max |GPU − CPU| = {worst:e}",
        scene.name(),
        ctx.adapter
    );
    worst
}

#[test]
fn transparency_agrees() {
    let ctx = vulkan();
    // 20 × 13: not a multiple of the 8 × 8 workgroup, and wider than the 16 × 16 mask.
    for mode in [AlphaMode::Constant(0.5), AlphaMode::Ramp] {
        let scene = Transparency::new(20, 13, mode);
        for encoding in [Encoding::Unorm8, Encoding::Unorm16, Encoding::F32] {
            // The alpha test compares bit-identical values; only the averages' rounding (e.g. a
            // fused multiply-add on the device) could differ.
            let worst = worst_difference(&ctx, &scene, &masks(&SCALAR, encoding));
            assert!(worst <= 1e-6, "{mode:?} {encoding:?}: {worst}");
        }
    }
}

#[test]
fn cloud_agrees() {
    let ctx = vulkan();
    let params = CloudParams {
        view_steps: 24,
        shadow_steps: 12,
        ..CloudParams::default()
    };
    let scene = Cloud::new(27, 21, DensityGrid::cloud(16, 2), params);
    // exp, log and the shader's float contraction may round differently from the CPU; the
    // collision depth is continuous in ξ, so that moves the samples by rounding only (measured
    // on lavapipe: 3.5e-6). Only a ξ within rounding of the escape threshold could flip a
    // sample between sky and cloud and cost up to ~0.1 · 0.7 in one EMA pixel.
    let worst = worst_difference(&ctx, &scene, &masks(&SCALAR, Encoding::Unorm16));
    assert!(worst <= 1e-4, "cloud: {worst}");
}

#[test]
fn ao_agrees() {
    let ctx = vulkan();
    let params = AoParams {
        steps: 8,
        ..AoParams::default()
    };
    let scene = AmbientOcclusion::new(23, 19, Heightfield::town(32, 3), params);
    // Every direction source: octahedral vector masks (8- and 16-bit) and scalar pairs through
    // the cosine map (sin, cos and sqrt on the device). The soft visibility is continuous in
    // the direction, so rounding moves the result by rounding only.
    for encoding in [Encoding::Unorm8, Encoding::Unorm16] {
        let worst = worst_difference(&ctx, &scene, &masks(&NoiseKind::DIRECTIONS, encoding));
        assert!(worst <= 1e-4, "ao {encoding:?}: {worst}");
    }
}

#[test]
fn progressive_reads_new_values_past_the_depth_on_the_gpu() {
    let ctx = vulkan();
    let scene = Transparency::new(20, 13, AlphaMode::Ramp);
    let renderer = GpuSceneRenderer::new(&ctx, &scene);
    let mask = &masks(&[NoiseKind::Stbn], Encoding::Unorm16)[0];
    let noise = mask.view();
    let render = |order| {
        renderer
            .render(&noise, order, SampleMode::Scalar, &CHECKPOINTS)
            .unwrap()
    };
    let (wrap, progressive) = (render(FrameOrder::Wrap), render(FrameOrder::Progressive));
    // Within the first pass the two orders read the same frames; past it they do not.
    assert_eq!(wrap[1], progressive[1]);
    assert_ne!(wrap[2].mean, progressive[2].mean);
}
