//! [`Comparison`]: one scene rendered with every noise source, and the RMSE of each against the
//! scene's ground truth.

use stbn_runtime::gpu::GpuError;

use crate::gpu::{GpuContext, GpuSceneRenderer};
use crate::image::{gaussian_blur, rmse, rmse_f64};
use crate::noise::{NoiseKind, NoiseMask};
use crate::render::{Checkpoint, render_cpu};
use crate::scene::Scene;

/// Where the frames are rendered.
#[derive(Clone, Copy)]
pub enum Backend<'a> {
    /// [`render_cpu`].
    Cpu,
    /// [`GpuSceneRenderer`] on this device.
    Gpu(&'a GpuContext),
}

/// Which temporal accumulation an image comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Accumulation {
    /// Exponential moving average, α = [`crate::accumulate::EMA_ALPHA`].
    Ema,
    /// Running mean of all frames so far.
    Mean,
}

impl Accumulation {
    /// Both, in table order.
    pub const ALL: [Accumulation; 2] = [Accumulation::Ema, Accumulation::Mean];

    /// A short lowercase name for file names and CSV rows.
    pub fn name(self) -> &'static str {
        match self {
            Accumulation::Ema => "ema",
            Accumulation::Mean => "mean",
        }
    }

    /// The image of `checkpoint` this accumulation refers to.
    pub fn image(self, checkpoint: &Checkpoint) -> &[f32] {
        match self {
            Accumulation::Ema => &checkpoint.ema.pixels,
            Accumulation::Mean => &checkpoint.mean.pixels,
        }
    }
}

/// How an accumulated image's error against the ground truth is measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Metric {
    /// Plain per-pixel RMSE.
    Rmse,
    /// RMSE after blurring both the image and the ground truth with a Gaussian of
    /// [`BLUR_SIGMA`] pixels ([`gaussian_blur`]): the error left after a spatial filter, where
    /// blue noise's high-frequency error mostly cancels.
    BlurredRmse,
}

/// σ of [`Metric::BlurredRmse`]'s Gaussian in pixels: 1.3435, the spatial σ of EA's FAST
/// filtered-error metric.
pub const BLUR_SIGMA: f64 = 1.3435;

impl Metric {
    /// Both, in table order.
    pub const ALL: [Metric; 2] = [Metric::Rmse, Metric::BlurredRmse];

    /// A short lowercase name for CSV rows.
    pub fn name(self) -> &'static str {
        match self {
            Metric::Rmse => "rmse",
            Metric::BlurredRmse => "blurred_rmse",
        }
    }

    /// A label for table headers.
    pub fn label(self) -> &'static str {
        match self {
            Metric::Rmse => "RMSE",
            Metric::BlurredRmse => "RMSE after a Gaussian blur (σ 1.3435 px)",
        }
    }
}

/// One noise source's accumulated images.
#[derive(Clone, Debug, PartialEq)]
pub struct NoiseRun {
    /// The source.
    pub kind: NoiseKind,
    /// Its images at each checkpoint, in increasing frame order.
    pub checkpoints: Vec<Checkpoint>,
}

/// A scene rendered with several noise sources, and its ground truth.
#[derive(Clone, Debug, PartialEq)]
pub struct Comparison {
    /// [`Scene::name`].
    pub scene: String,
    /// [`Scene::description`].
    pub description: String,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// [`Scene::ground_truth`].
    pub ground_truth: Vec<f64>,
    /// One run per mask, in the masks' order.
    pub runs: Vec<NoiseRun>,
}

impl Comparison {
    /// Renders `scene` with every mask of `masks` on `backend`, keeping the images after each
    /// of `checkpoints` frames (strictly increasing, from 1), and computes the ground truth.
    ///
    /// Panics if a mask's samples are not what the scene takes ([`Scene::input`]).
    ///
    /// # Errors
    /// A mask too large for the device's 3D textures.
    pub fn run(
        scene: &dyn Scene,
        masks: &[NoiseMask],
        checkpoints: &[u32],
        backend: Backend<'_>,
    ) -> Result<Comparison, GpuError> {
        let gpu = match backend {
            Backend::Gpu(ctx) => Some(GpuSceneRenderer::new(ctx, scene)),
            Backend::Cpu => None,
        };
        let mut runs = Vec::with_capacity(masks.len());
        for mask in masks {
            assert_eq!(
                mask.kind.input(),
                scene.input(),
                "{:?} does not feed {}",
                mask.kind,
                scene.name()
            );
            let noise = mask.view();
            let mode = mask.kind.sample_mode();
            let images = match &gpu {
                Some(renderer) => renderer.render(&noise, mode, checkpoints)?,
                None => render_cpu(scene, &noise, mode, checkpoints),
            };
            runs.push(NoiseRun {
                kind: mask.kind,
                checkpoints: images,
            });
        }
        Ok(Comparison {
            scene: scene.name().to_owned(),
            description: scene.description(),
            width: scene.width(),
            height: scene.height(),
            ground_truth: scene.ground_truth(),
            runs,
        })
    }

    /// The checkpoint frame counts (those of the first run).
    pub fn frame_counts(&self) -> Vec<u32> {
        self.runs
            .first()
            .map(|r| r.checkpoints.iter().map(|c| c.frames).collect())
            .unwrap_or_default()
    }

    /// The run of `kind`, if it was rendered.
    pub fn run_of(&self, kind: NoiseKind) -> Option<&NoiseRun> {
        self.runs.iter().find(|r| r.kind == kind)
    }

    /// RMSE against the ground truth of `kind`'s `accumulation` image after `frames` frames, if
    /// that run and checkpoint exist.
    pub fn rmse(&self, kind: NoiseKind, accumulation: Accumulation, frames: u32) -> Option<f64> {
        self.error(kind, accumulation, Metric::Rmse, frames)
    }

    /// The `metric` error of `kind`'s `accumulation` image after `frames` frames against the
    /// ground truth, if that run and checkpoint exist.
    pub fn error(
        &self,
        kind: NoiseKind,
        accumulation: Accumulation,
        metric: Metric,
        frames: u32,
    ) -> Option<f64> {
        let checkpoint = self
            .run_of(kind)?
            .checkpoints
            .iter()
            .find(|c| c.frames == frames)?;
        let image = accumulation.image(checkpoint);
        Some(match metric {
            Metric::Rmse => rmse(image, &self.ground_truth),
            Metric::BlurredRmse => {
                let blur = |p: &[f64]| gaussian_blur(p, self.width, self.height, BLUR_SIGMA);
                let image: Vec<f64> = image.iter().map(|&v| f64::from(v)).collect();
                rmse_f64(&blur(&image), &blur(&self.ground_truth))
            }
        })
    }
}
