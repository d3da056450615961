//! Past the mask's depth, STBN read progressively keeps converging where plain `sample` repeats
//! the same frames, and its error image stays blue: after 1024 frames (64 passes through a
//! 16-frame mask) its running mean's RMSE is below that of white noise (a slice per frame) and
//! of wrapping STBN, and the low-band power of its error image is far below white noise's. CPU renderer; everything is
//! seeded, so the figures are exact for this code and only move when the generator, the scene,
//! the renderer or the progressive offsets change.

use stbn_runtime::Encoding;
use stbn_scenes::compare::{Accumulation, Backend, Comparison, Metric};
use stbn_scenes::noise::{NoiseKind, NoiseSpec, generate_past_depth};
use stbn_scenes::scene::Scene;
use stbn_scenes::transparency::{AlphaMode, Transparency};

/// 64 × 64 images over a 32 × 32 × 16 mask.
const IMAGE: u32 = 64;
const FRAMES: u32 = 1024;

#[test]
fn progressive_beats_wrap_and_white_and_stays_blue() {
    let spec = NoiseSpec {
        width: 32,
        height: 32,
        depth: 16,
        seed: 1,
        encoding: Encoding::Unorm16,
    };
    let masks = generate_past_depth(&spec, FRAMES).unwrap();
    let scene = Transparency::new(IMAGE, IMAGE, AlphaMode::Constant(0.5));
    let cmp = Comparison::run(&scene, &masks, &[16, FRAMES], Backend::Cpu).unwrap();
    let measure = |kind, metric, frames| {
        let value = cmp.error(kind, Accumulation::Mean, metric, frames).unwrap();
        eprintln!(
            "{} {:?} {} after {frames} frames: {value:.5}",
            scene.name(),
            kind,
            metric.name()
        );
        value
    };
    // Within the first pass through the depth the progressive view is the mask itself.
    for metric in Metric::ALL {
        assert_eq!(
            measure(NoiseKind::Stbn, metric, 16),
            measure(NoiseKind::StbnProgressive, metric, 16),
            "{metric:?}"
        );
    }
    let rmse = |kind| measure(kind, Metric::Rmse, FRAMES);
    let (white, wrap, progressive) = (
        rmse(NoiseKind::White),
        rmse(NoiseKind::Stbn),
        rmse(NoiseKind::StbnProgressive),
    );
    // Measured: 0.00304 against 0.02415 (wrap) and 0.01139 (white): ratios 0.126 and 0.267.
    assert!(
        progressive / wrap <= 0.13 && progressive / white <= 0.27,
        "RMSE after {FRAMES} frames: progressive {progressive:.5}, wrap {wrap:.5}, white {white:.5}"
    );
    let low_band = |kind| measure(kind, Metric::ErrorLowBand, FRAMES);
    let (white, progressive) = (
        low_band(NoiseKind::White),
        low_band(NoiseKind::StbnProgressive),
    );
    // Measured: 0.0499 against white noise's 0.970 (ratio 0.051).
    assert!(
        progressive <= 0.06 * white,
        "error low band after {FRAMES} frames: progressive {progressive:.3}, white {white:.3}"
    );
}
