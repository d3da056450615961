//! Convergence of per-pixel 1D integration over the frames, Monte Carlo and EMA ([`analysis`]
//! docs, "Convergence").
//!
//! [`analysis`]: crate::analysis#convergence

use rayon::prelude::*;

use super::Field;

/// A 1D integrand on `[0, 1)` with a known integral.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Integrand {
    /// `f(x) = x`, `∫₀¹ f = 1/2`. Smooth: the easy case.
    Ramp,
    /// `f(x) = 1 if x < 1/2 else 0`, `∫₀¹ f = 1/2`. A discontinuity, like a shadow edge.
    Step,
    /// `f(x) = sin(πx)`, `∫₀¹ f = 2/π`. Smooth and not monotonic: samples near 0 and near 1
    /// give the same value.
    Sine,
}

impl Integrand {
    /// Every integrand, in report order.
    pub const ALL: [Integrand; 3] = [Integrand::Ramp, Integrand::Step, Integrand::Sine];

    /// `f(x)`.
    pub fn eval(self, x: f64) -> f64 {
        match self {
            Integrand::Ramp => x,
            Integrand::Step => {
                if x < 0.5 {
                    1.0
                } else {
                    0.0
                }
            }
            Integrand::Sine => (std::f64::consts::PI * x).sin(),
        }
    }

    /// The exact `∫₀¹ f(x) dx`.
    pub fn integral(self) -> f64 {
        match self {
            Integrand::Ramp | Integrand::Step => 0.5,
            Integrand::Sine => 2.0 / std::f64::consts::PI,
        }
    }

    /// A lower-case name: `ramp`, `step` or `sine`.
    pub fn name(self) -> &'static str {
        match self {
            Integrand::Ramp => "ramp",
            Integrand::Step => "step",
            Integrand::Sine => "sine",
        }
    }
}

/// The parameters of [`convergence`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConvergenceOptions {
    /// Number of samples per pixel, `≥ 1`; more than `depth` wraps around the frames.
    pub samples: usize,
    /// Frame of the first sample (reduced modulo `depth`).
    pub start: usize,
    /// EMA weight of the newest sample, in `(0, 1]`. The paper: 0.1.
    pub alpha: f64,
}

impl ConvergenceOptions {
    /// `samples` samples from frame 0 with α = 0.1.
    pub fn new(samples: usize) -> ConvergenceOptions {
        ConvergenceOptions {
            samples,
            start: 0,
            alpha: 0.1,
        }
    }

    /// Starts at frame `start` instead.
    pub fn starting_at(self, start: usize) -> ConvergenceOptions {
        ConvergenceOptions { start, ..self }
    }
}

/// The error curves of [`convergence`]: entry `k` is the RMSE after `k + 1` samples.
#[derive(Clone, Debug, PartialEq)]
pub struct Convergence {
    /// Monte Carlo running mean.
    pub monte_carlo: Vec<f64>,
    /// Exponential moving average.
    pub ema: Vec<f64>,
}

/// The RMSE over pixels of both estimators of `integrand` after each sample ([`analysis`
/// docs](crate::analysis#convergence)).
///
/// Deterministic for any thread count (pixel chunks are summed in order). Panics if
/// `samples == 0` or `alpha ∉ (0, 1]`.
pub fn convergence(
    field: &Field,
    integrand: Integrand,
    options: ConvergenceOptions,
) -> Convergence {
    estimator_rmse(
        field.slice_pixels(),
        field.depth(),
        options,
        integrand.integral(),
        |z, pixels| {
            field.slice(z)[pixels]
                .iter()
                .map(move |&x| integrand.eval(x))
        },
    )
}

/// The Monte Carlo and EMA error curves ([module docs](crate::analysis#convergence)) of `pixels` pixels over frames
/// `0..depth`, where `samples(z, range)` yields `f` at frame `z` for the pixels in `range`, and
/// `exact` is the integral. Shared by [`convergence`] and
/// [`convergence_2d`](super::convergence2d::convergence_2d). Pixel chunks run in parallel and
/// are summed in order: the same bits for any thread count.
pub(super) fn estimator_rmse<I: Iterator<Item = f64>>(
    pixels: usize,
    depth: usize,
    options: ConvergenceOptions,
    exact: f64,
    samples: impl Fn(usize, std::ops::Range<usize>) -> I + Sync,
) -> Convergence {
    /// Pixels per parallel task.
    const CHUNK: usize = 1024;
    let ConvergenceOptions {
        samples: count,
        start,
        alpha,
    } = options;
    assert!(count > 0, "at least one sample");
    assert!(
        alpha > 0.0 && alpha <= 1.0,
        "alpha {alpha} must be in (0, 1]"
    );
    let n = pixels;
    let starts: Vec<usize> = (0..n).step_by(CHUNK).collect();
    let parts: Vec<Vec<f64>> = starts
        .into_par_iter()
        .map(|first| {
            let pixels = first..(first + CHUNK).min(n);
            let mut mean = vec![0.0; pixels.len()];
            let mut ema = vec![0.0; pixels.len()];
            // Squared errors: Monte Carlo in 0..count, EMA in count..2·count.
            let mut squares = vec![0.0; 2 * count];
            for k in 0..count {
                let values = samples((start + k) % depth, pixels.clone());
                let weight = 1.0 / (k + 1) as f64;
                let (mut mc, mut exp) = (0.0, 0.0);
                for ((m, e), f) in mean.iter_mut().zip(&mut ema).zip(values) {
                    *m += (f - *m) * weight;
                    *e = if k == 0 {
                        f
                    } else {
                        alpha * f + (1.0 - alpha) * *e
                    };
                    mc += (*m - exact) * (*m - exact);
                    exp += (*e - exact) * (*e - exact);
                }
                squares[k] = mc;
                squares[count + k] = exp;
            }
            squares
        })
        .collect();
    let mut total = vec![0.0; 2 * count];
    for part in &parts {
        total.iter_mut().zip(part).for_each(|(t, p)| *t += p);
    }
    let rmse: Vec<f64> = total.iter().map(|s| (s / n as f64).sqrt()).collect();
    Convergence {
        monte_carlo: rmse[..count].to_vec(),
        ema: rmse[count..].to_vec(),
    }
}

/// The per-pixel running mean of a sequence read frame by frame, measured at chosen frame
/// counts: [`running_mean`]'s result.
#[derive(Clone, Debug, PartialEq)]
pub struct RunningMean {
    /// The frame counts measured at, as given: strictly increasing, each `≥ 1`.
    pub frames: Vec<usize>,
    /// RMSE over pixels of the running mean against the exact value after each of `frames`.
    pub rmse: Vec<f64>,
    /// The error image `mean − exact` after the last of `frames`, row-major, `width × height`
    /// (one slice for [`Field::new`], e.g. to measure [`spatial_low_band`](super::spatial_low_band)
    /// of the error).
    pub error: Vec<f64>,
}

/// The running mean over frames of a `width × height` image of per-pixel values produced by
/// `frame(f, out)` (`out[y · width + x]` is pixel `(x, y)`'s value at frame `f`, for `f` in
/// `0..last`), compared with `exact` after each count in `frames`.
///
/// Unlike [`convergence`], which reads a field's own `depth` frames (wrapping past them), the
/// source is any sequence: a runtime view read past its depth, a baseline, white noise. The
/// frames are read in order, once; `out` is reset to 0 before each call. Sums are taken in
/// frame order per pixel, so the result does not depend on threads.
///
/// # Panics
/// If `width` or `height` is 0, `frames` is empty, not strictly increasing, starts at 0 or
/// exceeds 2³² (frame indices are `u32`).
pub fn running_mean(
    width: usize,
    height: usize,
    frames: &[usize],
    exact: f64,
    mut frame: impl FnMut(u32, &mut [f64]),
) -> RunningMean {
    assert!(width > 0 && height > 0, "an image has at least one pixel");
    assert!(
        !frames.is_empty() && frames[0] >= 1,
        "measure after at least one frame"
    );
    assert!(
        frames.windows(2).all(|w| w[0] < w[1]),
        "frame counts must increase: {frames:?}"
    );
    let last = *frames.last().expect("not empty");
    assert!(
        last as u64 <= 1 << 32,
        "{last} frames exceed the u32 frame indices"
    );
    let pixels = width * height;
    let mut sums = vec![0.0f64; pixels];
    let mut values = vec![0.0f64; pixels];
    let mut rmse = Vec::with_capacity(frames.len());
    let mut next = frames.iter().peekable();
    for f in 0..last {
        values.fill(0.0);
        // `f < last <= 2^32`, so it fits in u32.
        frame(f as u32, &mut values);
        sums.iter_mut().zip(&values).for_each(|(s, v)| *s += v);
        if next.peek() == Some(&&(f + 1)) {
            next.next();
            let n = (f + 1) as f64;
            let squares: f64 = sums.iter().map(|s| (s / n - exact).powi(2)).sum();
            rmse.push((squares / pixels as f64).sqrt());
        }
    }
    let n = last as f64;
    RunningMean {
        frames: frames.to_vec(),
        rmse,
        error: sums.iter().map(|s| s / n - exact).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn running_mean_follows_its_definition() {
        // Pixel i sees i, then 1 - i, alternating: its mean is exact after every even count.
        let width = 3;
        let values = [0.0, 0.25, 1.0];
        let result = running_mean(width, 1, &[1, 2, 3, 4], 0.5, |f, out| {
            for (o, v) in out.iter_mut().zip(values) {
                *o = if f % 2 == 0 { v } else { 1.0 - v };
            }
        });
        let first = ((0.25f64 + 0.0625 + 0.25) / 3.0).sqrt();
        assert_eq!(result.frames, [1, 2, 3, 4]);
        assert!((result.rmse[0] - first).abs() < 1e-15);
        assert_eq!(result.rmse[1], 0.0);
        assert_eq!(result.rmse[3], 0.0);
        // After 3 frames pixel i's mean is (2 v + (1 - v)) / 3 = (1 + v) / 3.
        let third: Vec<f64> = values.iter().map(|v| (1.0 + v) / 3.0 - 0.5).collect();
        let expected = (third.iter().map(|e| e * e).sum::<f64>() / 3.0).sqrt();
        assert!((result.rmse[2] - expected).abs() < 1e-15);
        assert!(result.error.iter().all(|&e| e == 0.0));
    }

    #[test]
    #[should_panic(expected = "frame counts must increase")]
    fn running_mean_refuses_unordered_counts() {
        running_mean(1, 1, &[4, 2], 0.5, |_, _| {});
    }

    #[test]
    fn integrals_match_a_midpoint_rule() {
        for integrand in Integrand::ALL {
            let n = 1 << 16;
            let sum: f64 = (0..n)
                .map(|i| integrand.eval((i as f64 + 0.5) / n as f64))
                .sum();
            let estimate = sum / n as f64;
            assert!(
                (estimate - integrand.integral()).abs() < 1e-6,
                "{}: {estimate}",
                integrand.name()
            );
        }
    }

    #[test]
    fn stratified_sequences_have_exact_errors() {
        // One pixel, 4 frames with values 0.125, 0.625, 0.375, 0.875 (a stratified sequence).
        let values = [0.125, 0.625, 0.375, 0.875];
        let field = Field::new(1, 1, 4, &values).unwrap();
        let curve = convergence(&field, Integrand::Ramp, ConvergenceOptions::new(4));
        // Running means 0.125, 0.375, 0.375, 0.5: errors 0.375, 0.125, 0.125, 0.
        assert_eq!(curve.monte_carlo, vec![0.375, 0.125, 0.125, 0.0]);
        // EMA with α = 0.1: 0.125, 0.175, 0.195, 0.263.
        let mut e = 0.125;
        let mut expected = vec![0.375];
        for &x in &values[1..] {
            e = 0.1 * x + 0.9 * e;
            expected.push((e - 0.5f64).abs());
        }
        for (a, b) in curve.ema.iter().zip(&expected) {
            assert!((a - b).abs() < 1e-15, "{a} vs {b}");
        }
        // Starting at frame 3 and wrapping: 0.875, 0.125, 0.625, 0.375 → means 0.875, 0.5, …
        let shifted = convergence(
            &field,
            Integrand::Step,
            ConvergenceOptions::new(5).starting_at(3),
        );
        // Step values 0, 1, 0, 1, 0: means 0, 0.5, 1/3, 0.5, 0.4.
        let means = [0.0, 0.5, 1.0 / 3.0, 0.5, 0.4];
        for (a, m) in shifted.monte_carlo.iter().zip(means) {
            assert!((a - (m - 0.5f64).abs()).abs() < 1e-15);
        }
    }
}
