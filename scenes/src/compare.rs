//! [`Comparison`]: one scene rendered with every noise source, and the RMSE of each against the
//! scene's ground truth.

use stbn_gen::analysis::{Field, SpectrumImage, dft_xy_image, spatial_low_band};
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
    /// Where the error sits in frequency: the mean normalised power of the error image
    /// (image − ground truth) in the spatial low band `0 < |f| ≤ size / 8`, as
    /// [`stbn_gen::analysis::spatial_low_band`] defines it for a mask slice. Dimensionless:
    /// about 1 for white error, near 0 for blue error; independent of the error's size.
    ErrorLowBand,
}

/// σ of [`Metric::BlurredRmse`]'s Gaussian in pixels: 1.3435, the spatial σ of EA's FAST
/// filtered-error metric.
pub const BLUR_SIGMA: f64 = 1.3435;

impl Metric {
    /// Every metric, in table order.
    pub const ALL: [Metric; 3] = [Metric::Rmse, Metric::BlurredRmse, Metric::ErrorLowBand];

    /// A short lowercase name for CSV rows.
    pub fn name(self) -> &'static str {
        match self {
            Metric::Rmse => "rmse",
            Metric::BlurredRmse => "blurred_rmse",
            Metric::ErrorLowBand => "error_low_band",
        }
    }

    /// A label for table headers.
    pub fn label(self) -> &'static str {
        match self {
            Metric::Rmse => "RMSE",
            Metric::BlurredRmse => "RMSE after a Gaussian blur (σ 1.3435 px)",
            Metric::ErrorLowBand => "Error image's low-band power (0 < |f| ≤ size/8, white = 1)",
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
            let (order, mode) = (mask.kind.frame_order(), mask.kind.sample_mode());
            let images = match &gpu {
                Some(renderer) => renderer.render(&noise, order, mode, checkpoints)?,
                None => render_cpu(scene, &noise, order, mode, checkpoints),
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

    /// `kind`'s `accumulation` image after `frames` frames, if that run and checkpoint exist.
    fn image(&self, kind: NoiseKind, accumulation: Accumulation, frames: u32) -> Option<&[f32]> {
        let checkpoint = self
            .run_of(kind)?
            .checkpoints
            .iter()
            .find(|c| c.frames == frames)?;
        Some(accumulation.image(checkpoint))
    }

    /// The `metric` error of `kind`'s `accumulation` image after `frames` frames against the
    /// ground truth, if that run and checkpoint exist (and, for [`Metric::ErrorLowBand`], the
    /// image is larger than 1 × 1).
    pub fn error(
        &self,
        kind: NoiseKind,
        accumulation: Accumulation,
        metric: Metric,
        frames: u32,
    ) -> Option<f64> {
        let image = self.image(kind, accumulation, frames)?;
        match metric {
            Metric::Rmse => Some(rmse(image, &self.ground_truth)),
            Metric::BlurredRmse => {
                let blur = |p: &[f64]| gaussian_blur(p, self.width, self.height, BLUR_SIGMA);
                let image: Vec<f64> = image.iter().map(|&v| f64::from(v)).collect();
                Some(rmse_f64(&blur(&image), &blur(&self.ground_truth)))
            }
            Metric::ErrorLowBand => {
                let error = self.error_field_values(image);
                spatial_low_band(&self.error_field(&error))
            }
        }
    }

    /// The centred DFT magnitude image ([`dft_xy_image`]) of `kind`'s `accumulation` error
    /// image after `frames` frames, if that run and checkpoint exist: `width × height`
    /// magnitudes normalised like a mask slice's (white error about 0.89 everywhere, blue error
    /// dark around the centre).
    pub fn error_spectrum(
        &self,
        kind: NoiseKind,
        accumulation: Accumulation,
        frames: u32,
    ) -> Option<SpectrumImage> {
        let image = self.image(kind, accumulation, frames)?;
        let error = self.error_field_values(image);
        Some(dft_xy_image(&self.error_field(&error)))
    }

    /// `image − ground truth` mapped affinely onto `[0, 1]` (minimum to 0, maximum to 1; all 0
    /// for a constant error), the value range a [`Field`] takes. The normalised spectra divide
    /// by the variance after removing the mean, so the map leaves them unchanged.
    fn error_field_values(&self, image: &[f32]) -> Vec<f64> {
        let error: Vec<f64> = image
            .iter()
            .zip(&self.ground_truth)
            .map(|(&v, &truth)| f64::from(v) - truth)
            .collect();
        let min = error.iter().copied().fold(f64::INFINITY, f64::min);
        let max = error.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let range = if max > min { max - min } else { 1.0 };
        error.iter().map(|e| (e - min) / range).collect()
    }

    /// `values` ([`error_field_values`](Self::error_field_values)) as a one-slice field.
    fn error_field<'v>(&self, values: &'v [f64]) -> Field<'v> {
        Field::new(self.width as usize, self.height as usize, 1, values)
            .expect("the error image has the comparison's size and values in [0, 1]")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::Image;

    /// A 16 × 16 comparison with ground truth 0.5 and one white-noise run whose mean image
    /// after 1 frame is `0.5 + error(x, y)`.
    fn comparison(error: impl Fn(u32, u32) -> f32) -> Comparison {
        let n = 16;
        let pixels = (0..n * n).map(|i| 0.5 + error(i % n, i / n)).collect();
        let image = Image::from_pixels(n, n, pixels);
        Comparison {
            scene: "toy".into(),
            description: "a toy".into(),
            width: n,
            height: n,
            ground_truth: vec![0.5; (n * n) as usize],
            runs: vec![NoiseRun {
                kind: NoiseKind::White,
                checkpoints: vec![Checkpoint {
                    frames: 1,
                    ema: image.clone(),
                    mean: image,
                }],
            }],
        }
    }

    fn low_band(cmp: &Comparison) -> f64 {
        cmp.error(
            NoiseKind::White,
            Accumulation::Mean,
            Metric::ErrorLowBand,
            1,
        )
        .unwrap()
    }

    #[test]
    fn error_low_band_sees_where_the_error_sits_not_its_size() {
        // A checkerboard has all its power at Nyquist, outside the low band.
        let checker = |x: u32, y: u32| if (x + y).is_multiple_of(2) { 0.1 } else { -0.1 };
        assert!(low_band(&comparison(checker)) < 1e-12);
        // One cycle across the image: all its power sits at |f| = 1, inside the band.
        let wave = |x: u32, _| (std::f32::consts::TAU * x as f32 / 16.0).cos() * 0.1;
        let smooth = low_band(&comparison(wave));
        assert!(smooth > 10.0, "{smooth}");
        // Scaling or shifting the error leaves the normalised power unchanged.
        let scaled = low_band(&comparison(|x, y| 0.3 * wave(x, y) + 0.05));
        assert!((scaled / smooth - 1.0).abs() < 1e-4, "{scaled} vs {smooth}");
        // A constant error has no power anywhere.
        assert_eq!(low_band(&comparison(|_, _| 0.2)), 0.0);
        let spectrum = comparison(wave)
            .error_spectrum(NoiseKind::White, Accumulation::Mean, 1)
            .unwrap();
        assert_eq!((spectrum.width, spectrum.height), (16, 16));
        assert!(spectrum.at(1, 0) > 1.0 && spectrum.at(3, 5) < 1e-6);
    }
}
