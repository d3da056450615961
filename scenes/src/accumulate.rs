//! Temporal accumulation of one-sample-per-pixel frames: an exponential moving average (what TAA
//! does) and the plain running mean (what offline Monte Carlo does), computed with the very
//! `f32` operations the GPU shader uses ([`WGSL`]), so that both paths agree.

use crate::image::Image;

/// The EMA blend weight of the newest frame: `ema ← ema + α · (v − ema)` with α = 0.1, the
/// value the NVIDIA blog and the STBN paper use.
pub const EMA_ALPHA: f32 = 0.1;

/// The shader side of [`Accumulator::add_frame`]: `accumulate(history, v, frame, alpha)` returns
/// the new `(ema, mean)` pair for one pixel. `frame` counts from 0; frame 0 starts both
/// averages at `v`.
pub const WGSL: &str = "
fn accumulate(history: vec2<f32>, v: f32, frame: u32, alpha: f32) -> vec2<f32> {
    if frame == 0u {
        return vec2<f32>(v, v);
    }
    let ema = history.x + alpha * (v - history.x);
    let mean = history.y + (v - history.y) / f32(frame + 1u);
    return vec2<f32>(ema, mean);
}
";

/// An EMA and a running mean over frames, per pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Accumulator {
    /// Exponential moving average with weight [`EMA_ALPHA`] (the first frame starts it).
    pub ema: Image,
    /// Mean of all frames so far.
    pub mean: Image,
    /// Frames added so far.
    pub frames: u32,
}

impl Accumulator {
    /// An empty accumulator for `width × height` frames.
    pub fn new(width: u32, height: u32) -> Accumulator {
        Accumulator {
            ema: Image::zeros(width, height),
            mean: Image::zeros(width, height),
            frames: 0,
        }
    }

    /// Adds one frame (`width · height` values, row-major).
    ///
    /// Panics if `frame` has the wrong length.
    pub fn add_frame(&mut self, frame: &[f32]) {
        assert_eq!(frame.len(), self.ema.pixels.len(), "frame size");
        let n = self.frames;
        for ((ema, mean), &v) in self
            .ema
            .pixels
            .iter_mut()
            .zip(&mut self.mean.pixels)
            .zip(frame)
        {
            (*ema, *mean) = accumulate(*ema, *mean, v, n);
        }
        self.frames += 1;
    }
}

/// One pixel's `(ema, mean)` after adding `v` as frame number `frame` (from 0); the CPU twin of
/// [`WGSL`]'s `accumulate`.
pub fn accumulate(ema: f32, mean: f32, v: f32, frame: u32) -> (f32, f32) {
    if frame == 0 {
        return (v, v);
    }
    (
        ema + EMA_ALPHA * (v - ema),
        mean + (v - mean) / (frame + 1) as f32,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_frame_starts_both_averages() {
        let mut acc = Accumulator::new(2, 1);
        acc.add_frame(&[0.25, 1.0]);
        assert_eq!(acc.ema.pixels, [0.25, 1.0]);
        assert_eq!(acc.mean.pixels, [0.25, 1.0]);
        assert_eq!(acc.frames, 1);
    }

    #[test]
    fn running_mean_and_ema_follow_their_definitions() {
        let mut acc = Accumulator::new(1, 1);
        let values = [1.0f32, 0.0, 0.0, 1.0, 1.0, 0.0, 1.0, 1.0];
        let mut ema = f64::from(values[0]);
        for (i, &v) in values.iter().enumerate() {
            acc.add_frame(&[v]);
            if i > 0 {
                ema = 0.9 * ema + 0.1 * f64::from(v);
            }
            let mean = values[..=i].iter().map(|&v| f64::from(v)).sum::<f64>() / (i + 1) as f64;
            assert!(
                (f64::from(acc.mean.pixels[0]) - mean).abs() < 1e-6,
                "frame {i}"
            );
            assert!(
                (f64::from(acc.ema.pixels[0]) - ema).abs() < 1e-6,
                "frame {i}"
            );
        }
    }
}
