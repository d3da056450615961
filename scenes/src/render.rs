//! The CPU renderer: frame after frame, one noise value per pixel from a view of an [`Stbn`]
//! mask, one [`Scene::shade`] per pixel, accumulated by [`Accumulator`].

use rayon::prelude::*;
use stbn_runtime::{OffsetStbn, Stbn};

use crate::accumulate::Accumulator;
use crate::image::Image;
use crate::sample::{FrameOrder, SampleMode, pixel_sample};
use crate::scene::Scene;

/// The accumulated images after a number of frames.
#[derive(Clone, Debug, PartialEq)]
pub struct Checkpoint {
    /// Frames accumulated (`≥ 1`).
    pub frames: u32,
    /// The EMA ([`crate::accumulate::EMA_ALPHA`]) after `frames` frames.
    pub ema: Image,
    /// The mean of the first `frames` frames.
    pub mean: Image,
}

/// Checks that `checkpoints` is non-empty, strictly increasing and starts at `≥ 1`; returns the
/// last (the number of frames to render), or what is wrong with them.
pub fn frames_to_render(checkpoints: &[u32]) -> Result<u32, String> {
    match checkpoints {
        [] => Err("no checkpoints".to_owned()),
        [0, ..] => Err(format!(
            "checkpoints {checkpoints:?} must start at >= 1 frame"
        )),
        _ if checkpoints.windows(2).any(|w| w[0] >= w[1]) => {
            Err(format!("checkpoints {checkpoints:?} must increase"))
        }
        [.., last] => Ok(*last),
    }
}

/// One frame of `scene`: pixel `(x, y)` shaded with its [`pixel_sample`] of `noise` (a view of
/// the mask, [`FrameOrder::view`]) under `mode` at `frame` (the mask tiles the image
/// toroidally). Rows are shaded in parallel; the result does not depend on the thread count.
pub fn render_frame(
    scene: &dyn Scene,
    noise: OffsetStbn<'_>,
    mode: SampleMode,
    frame: u32,
) -> Vec<f32> {
    let width = scene.width() as usize;
    let mut pixels = vec![0.0f32; width * scene.height() as usize];
    pixels
        .par_chunks_mut(width)
        .enumerate()
        .for_each(|(y, row)| {
            if mode == SampleMode::Scalar {
                // The runtime's row fill: the same values as `sample`, faster.
                noise.fill_row(0, y as i32, frame, row);
                for (x, value) in row.iter_mut().enumerate() {
                    *value = scene.shade(x as u32, y as u32, [*value, 0.0, 0.0, 0.0]);
                }
            } else {
                for (x, value) in row.iter_mut().enumerate() {
                    let sample = pixel_sample(noise, mode, x as i32, y as i32, frame);
                    *value = scene.shade(x as u32, y as u32, sample);
                }
            }
        });
    pixels
}

/// Renders frames `0..last checkpoint` of `scene` with `noise` read in `order` under `mode` on
/// the CPU and returns the accumulated images at each checkpoint (frame counts, strictly
/// increasing, from 1; panics otherwise, see [`frames_to_render`]).
pub fn render_cpu(
    scene: &dyn Scene,
    noise: &Stbn<'_>,
    order: FrameOrder,
    mode: SampleMode,
    checkpoints: &[u32],
) -> Vec<Checkpoint> {
    let frames = frames_to_render(checkpoints).unwrap_or_else(|e| panic!("{e}"));
    let view = order.view(noise);
    let mut acc = Accumulator::new(scene.width(), scene.height());
    let mut out = Vec::with_capacity(checkpoints.len());
    for frame in 0..frames {
        acc.add_frame(&render_frame(scene, view, mode, frame));
        if checkpoints.contains(&acc.frames) {
            out.push(Checkpoint {
                frames: acc.frames,
                ema: acc.ema.clone(),
                mean: acc.mean.clone(),
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noise::{NoiseKind, NoiseMask, NoiseSpec};
    use crate::transparency::{AlphaMode, Transparency};
    use stbn_runtime::Encoding;

    #[test]
    fn checkpoints_hold_the_accumulated_frames() {
        let spec = NoiseSpec {
            width: 4,
            height: 4,
            depth: 4,
            seed: 1,
            encoding: Encoding::F32,
        };
        let mask = NoiseMask::generate(NoiseKind::White, &spec).unwrap();
        let noise = mask.view();
        // 6 × 5 image over a 4 × 4 mask: the mask tiles.
        let scene = Transparency::new(6, 5, AlphaMode::Constant(0.5));
        let mode = SampleMode::Scalar;
        let checkpoints = render_cpu(&scene, &noise, FrameOrder::Wrap, mode, &[1, 3]);
        assert_eq!(checkpoints.len(), 2);
        let frames: Vec<Vec<f32>> = (0..3)
            .map(|f| render_frame(&scene, (&noise).into(), mode, f))
            .collect();
        assert_eq!(checkpoints[0].mean.pixels, frames[0]);
        assert_eq!(checkpoints[0].ema.pixels, frames[0]);
        // Pixel (5, 4) reads mask texel (1, 0).
        let xi = noise.sample(1, 0, 2);
        assert_eq!(frames[2][4 * 6 + 5], scene.shade(5, 4, [xi, 0.0, 0.0, 0.0]));
        assert_eq!(
            pixel_sample((&noise).into(), mode, 5, 4, 2),
            [xi, 0.0, 0.0, 0.0]
        );
        let mut acc = Accumulator::new(6, 5);
        for f in &frames {
            acc.add_frame(f);
        }
        assert_eq!(checkpoints[1].ema, acc.ema);
        assert_eq!(checkpoints[1].mean, acc.mean);
    }

    #[test]
    fn progressive_frames_past_the_depth_read_the_shifted_mask() {
        let spec = NoiseSpec {
            width: 4,
            height: 4,
            depth: 4,
            seed: 2,
            encoding: Encoding::F32,
        };
        let mask = NoiseMask::generate(NoiseKind::Stbn, &spec).unwrap();
        let noise = mask.view();
        let scene = Transparency::new(6, 5, AlphaMode::Ramp);
        let mode = SampleMode::Scalar;
        let render = |order| render_cpu(&scene, &noise, order, mode, &[4, 11]);
        let (wrap, progressive) = (render(FrameOrder::Wrap), render(FrameOrder::Progressive));
        // The first pass through the depth is the mask itself ...
        assert_eq!(wrap[0], progressive[0]);
        // ... and later passes read it at the pass's offset: frame 10 (pass 2) at pixel (5, 4).
        let view = noise.progressive();
        let offset = view.sample_offset_at(10);
        assert_ne!(offset, view.sample_offset_at(2));
        let xi = noise.sample(5 + offset.x, 4 + offset.y, 10);
        let frame = render_frame(&scene, view, mode, 10);
        assert_eq!(frame[4 * 6 + 5], scene.shade(5, 4, [xi, 0.0, 0.0, 0.0]));
        assert_eq!(pixel_sample(view, mode, 5, 4, 10), [xi, 0.0, 0.0, 0.0]);
        assert_ne!(wrap[1], progressive[1]);
    }

    #[test]
    fn checkpoints_must_increase_from_one() {
        assert_eq!(frames_to_render(&[1, 4, 1024]), Ok(1024));
        assert!(frames_to_render(&[4, 4]).unwrap_err().contains("increase"));
        assert!(frames_to_render(&[0, 4]).unwrap_err().contains(">= 1"));
        assert!(frames_to_render(&[]).is_err());
    }
}
