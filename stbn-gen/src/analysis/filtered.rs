//! EA's FAST filtered error of thresholded frames after a spatial Gaussian and an exponential
//! moving average ([`analysis`] docs, "Filtered error").
//!
//! [`analysis`]: crate::analysis#filtered-error

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::{Field, FieldError};

/// The parameters of [`filtered_error`]. [`Default`] is EA's published setting.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilteredErrorOptions {
    /// Number `K ≥ 1` of Heaviside thresholds (strata of `[0, 1)`). EA: 256.
    pub thresholds: usize,
    /// Spatial Gaussian standard deviation in pixels, `> 0`. EA: 1.3435.
    pub sigma: f64,
    /// EMA weight of the newest frame, in `(0, 1]` (1 = no temporal filtering). EA: 0.1.
    pub alpha: f64,
    /// Seed of the threshold jitter.
    pub seed: u64,
}

impl FilteredErrorOptions {
    /// EA's number of thresholds.
    pub const THRESHOLDS: usize = 256;
    /// EA's spatial σ in pixels.
    pub const SIGMA: f64 = 1.3435;
    /// EA's EMA weight.
    pub const ALPHA: f64 = 0.1;
}

impl Default for FilteredErrorOptions {
    fn default() -> FilteredErrorOptions {
        FilteredErrorOptions {
            thresholds: Self::THRESHOLDS,
            sigma: Self::SIGMA,
            alpha: Self::ALPHA,
            seed: 0,
        }
    }
}

/// The filtered error `E(k)` of every frame `k ∈ 0..depth` ([module docs](crate::analysis#filtered-error)); the headline
/// figure is the last entry.
///
/// Dimensionless (coverage), `≥ 0`; 0 for a constant field. The thresholds run in parallel and
/// their variances are summed in threshold order, so the result is bit-for-bit the same for any
/// thread count. Cost: `K · W · H · D · (2⌈4σ⌉ + 1) · 2` multiply-adds.
///
/// Panics if `thresholds == 0`, `sigma` is not finite and positive, or `alpha ∉ (0, 1]`.
pub fn filtered_error(field: &Field, options: FilteredErrorOptions) -> Vec<f64> {
    let FilteredErrorOptions {
        thresholds,
        sigma,
        alpha,
        ..
    } = options;
    assert!(thresholds > 0, "at least one threshold");
    assert!(
        sigma.is_finite() && sigma > 0.0,
        "sigma {sigma} must be > 0"
    );
    assert!(
        alpha > 0.0 && alpha <= 1.0,
        "alpha {alpha} must be in (0, 1]"
    );
    windowed_error(field, options, &Frame::new(field, &options))
}

/// [`filtered_error`] over the window of `frame` (checked options).
fn windowed_error(field: &Field, options: FilteredErrorOptions, frame: &Frame) -> Vec<f64> {
    let FilteredErrorOptions {
        thresholds,
        sigma,
        alpha,
        seed,
    } = options;
    let depth = field.depth();
    let kernel = gaussian_weights(sigma);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let task_bytes = frame.task_bytes(1, depth);
    in_batches(thresholds, depth, task_bytes, |strata| {
        // Row s: the thresholds of stratum s at every frame (the one stream, batch after batch).
        let levels: Vec<f64> = (strata.start * depth..strata.end * depth)
            .map(|i| ((i / depth) as f64 + rng.random::<f64>()) / thresholds as f64)
            .collect();
        levels
            .par_chunks(depth * LANES)
            .flat_map_iter(|levels| {
                let strata: Vec<&[f64]> = levels.chunks(depth).collect();
                let mut window = Vec::new();
                let lanes = binary_variances(frame, depth, &kernel, alpha, |z, binary| {
                    // Lanes past the last stratum repeat it; their variances are dropped.
                    let t: [f64; LANES] =
                        std::array::from_fn(|l| strata[l.min(strata.len() - 1)][z]);
                    let values = frame.values(field.slice(z), &mut window);
                    for (b, &v) in binary.iter_mut().zip(values) {
                        *b = t.map(|t| if v < t { 1.0 } else { 0.0 });
                    }
                });
                stratum_variances(lanes, strata.len())
            })
            .collect()
    })
}

/// Frames whose pixels number more than this are measured on a window of at most
/// [`FilteredErrorOptions::WINDOW_SIDE`] pixels per axis ([`FilteredErrorOptions::window`]).
pub const MAX_FILTERED_FRAME: usize = 1 << 20;

impl FilteredErrorOptions {
    /// The longest side of the window larger frames are measured on.
    pub const WINDOW_SIDE: usize = 1024;

    /// The pixels of each `width × height` frame whose filtered error is averaged:
    /// `(window width, window height)` at the frame's origin. The whole frame up to
    /// [`MAX_FILTERED_FRAME`] pixels; beyond it, each axis longer than
    /// [`FilteredErrorOptions::WINDOW_SIDE`] is cut to that many pixels (an axis that would keep
    /// fewer than the blur's radius on each side stays whole). Window pixels are blurred with
    /// their true toroidal neighbours from the whole frame, so each one holds exactly the
    /// value the whole-frame computation gives it; only the mean and variance are over the
    /// window. Vector thresholds select their fraction of the window and the blur's margin.
    pub fn window(&self, width: usize, height: usize) -> (usize, usize) {
        let radius = gaussian_weights_radius(self.sigma);
        let cut = |len: usize| {
            if width * height > MAX_FILTERED_FRAME
                && len > Self::WINDOW_SIDE
                && Self::WINDOW_SIDE.saturating_add(radius.saturating_mul(2)) < len
            {
                Self::WINDOW_SIDE
            } else {
                len
            }
        };
        (cut(width), cut(height))
    }
}

/// The part of a frame [`binary_variances`] blurs and measures: a `w × h` buffer of field
/// pixels (`xs[i]`, `ys[j]`), the window of [`FilteredErrorOptions::window`] with a margin of
/// the blur's radius on each cut axis, and the window inside it (columns `x0..x1`, rows
/// `y0..y1`). The whole frame, in order, when nothing is cut.
struct Frame {
    field_width: usize,
    w: usize,
    h: usize,
    xs: Vec<usize>,
    ys: Vec<usize>,
    x0: usize,
    x1: usize,
    y0: usize,
    y1: usize,
    whole: bool,
}

impl Frame {
    /// The frame of [`FilteredErrorOptions::window`].
    fn new(field: &Field, options: &FilteredErrorOptions) -> Frame {
        let window = options.window(field.width(), field.height());
        Frame::with_window(field, gaussian_weights_radius(options.sigma), window)
    }

    /// The window `(ww, wh)` at the origin of `field`'s frames, with a margin of `radius` on
    /// each axis it cuts.
    fn with_window(field: &Field, radius: usize, (ww, wh): (usize, usize)) -> Frame {
        let (fw, fh) = (field.width(), field.height());
        // A cut axis: the window and `radius` pixels on each side, wrapping around the frame.
        let axis = |len: usize, window: usize| -> (Vec<usize>, usize, usize) {
            if window == len {
                ((0..len).collect(), 0, len)
            } else {
                let indices = (0..window + 2 * radius)
                    .map(|i| (i + len - radius % len) % len)
                    .collect();
                (indices, radius, radius + window)
            }
        };
        let (xs, x0, x1) = axis(fw, ww);
        let (ys, y0, y1) = axis(fh, wh);
        Frame {
            field_width: fw,
            w: xs.len(),
            h: ys.len(),
            whole: (ww, wh) == (fw, fh),
            xs,
            ys,
            x0,
            x1,
            y0,
            y1,
        }
    }

    /// Pixels whose mean and variance are taken.
    fn measured(&self) -> usize {
        (self.x1 - self.x0) * (self.y1 - self.y0)
    }

    /// The buffer's values of frame `z` of `field`: the slice itself for a whole frame, else
    /// gathered into `window`.
    fn values<'s>(&self, slice: &'s [f64], window: &'s mut Vec<f64>) -> &'s [f64] {
        if self.whole {
            return slice;
        }
        window.clear();
        for &y in &self.ys {
            let row = &slice[y * self.field_width..(y + 1) * self.field_width];
            window.extend(self.xs.iter().map(|&x| row[x]));
        }
        window
    }

    /// About the bytes one task of `LANES` strata of a field with `components` components and
    /// `depth` frames holds: three buffers of [`LANES`] `f64` per pixel (binary, blur scratch,
    /// EMA), a gathered window per component, for vectors the selection's keys and the
    /// projection, and the strata's draws and variance curves.
    fn task_bytes(&self, components: usize, depth: usize) -> usize {
        let n = self.w * self.h;
        let vector = if components > 1 { 24 * n } else { 0 };
        let per_pixel = 3 * 8 * LANES * n + 8 * components * n + vector;
        per_pixel + 8 * LANES * (self.w + self.h) + 8 * LANES * depth * (components + 3)
    }
}

/// `⌈4σ⌉`, the radius of [`gaussian_weights`].
fn gaussian_weights_radius(sigma: f64) -> usize {
    (4.0 * sigma).ceil() as usize
}

/// `sqrt(Σ_s Var_s(k) / K)` per frame `k` over `thresholds` strata, run in batches of whole
/// groups of [`LANES`] strata that fit [`MEMORY_BUDGET`](super::MEMORY_BUDGET) at `task_bytes`
/// per group: `batch(strata)` returns each stratum's variance curve, and the curves are added in
/// stratum order, so the result does not depend on the batches or the thread count.
fn in_batches(
    thresholds: usize,
    depth: usize,
    task_bytes: usize,
    mut batch: impl FnMut(std::ops::Range<usize>) -> Vec<Vec<f64>>,
) -> Vec<f64> {
    let strata_per_batch = super::batch_size(task_bytes) * LANES;
    let mut sum = vec![0.0; depth];
    for first in (0..thresholds).step_by(strata_per_batch) {
        for part in batch(first..(first + strata_per_batch).min(thresholds)) {
            sum.iter_mut().zip(&part).for_each(|(s, v)| *s += v);
        }
    }
    sum.iter().map(|s| (s / thresholds as f64).sqrt()).collect()
}

/// Strata whose frames are blurred and averaged together, one per `f64` lane of
/// [`binary_variances`]: every stratum's arithmetic is its own, in its own order (the same bits
/// as one stratum at a time), and the lanes turn the blur's and the sums' loops into vector
/// instructions (and, with the AVX2 build of [`binary_variances`], one lane per `f64` of a
/// register). 128×128×64 fields, 2 cores (`cargo bench -p stbn-gen --features analysis --bench
/// analysis`): one stratum at a time 1.65 s, four in lanes 0.48 s (vector thresholds: 2.41 s
/// against 0.95 s); eight lanes measured 0.50 s (1.00 s).
const LANES: usize = 4;

/// Per-stratum variance curves from [`binary_variances`]' per-frame lanes: the first `strata`
/// lanes, each as one curve over the frames.
fn stratum_variances(lanes: Vec<[f64; LANES]>, strata: usize) -> Vec<Vec<f64>> {
    (0..strata)
        .map(|l| lanes.iter().map(|v| v[l]).collect())
        .collect()
}

/// The filtered error of a vector mask: [`filtered_error`] with random half-spaces for
/// thresholds (FAST's vector case).
///
/// `components[c]` holds component `c` of every pixel (`d = components.len() ≥ 1` fields of one
/// size; any range). For stratum `s ∈ 0..K` at frame `k`, a direction `n` uniform on the unit
/// sphere of `ℝᵈ` (always `+1` for `d = 1`) and a fraction `q = (s + u) / K` (`u` uniform in `[0, 1)`) are drawn; the
/// binary image is 1 at the `⌊q · W·H⌋` pixels whose projection `n · v(p)` is smallest (ties by
/// pixel index), i.e. the pixels on one side of a hyperplane that holds a fraction `q` of the
/// frame's values. That fraction being exact makes the figure comparable across sample spaces
/// (unit vectors, points ∝ an image) and, for `d = 1`, with [`filtered_error`] on masks with exact
/// frame histograms (which sets `round(q · W·H)` pixels, so the two differ by at most one pixel per
/// threshold). The blur, EMA and RMS are those of [`filtered_error`]; the result is
/// dimensionless coverage, one entry per frame, the same for any thread count.
///
/// Errors if the fields differ in size; panics on the options [`filtered_error`] panics on or on
/// an empty `components`.
pub fn filtered_error_vector(
    components: &[Field],
    options: FilteredErrorOptions,
) -> Result<Vec<f64>, FieldError> {
    let FilteredErrorOptions {
        thresholds,
        sigma,
        alpha,
        seed,
    } = options;
    assert!(!components.is_empty(), "at least one component");
    assert!(thresholds > 0, "at least one threshold");
    assert!(
        sigma.is_finite() && sigma > 0.0,
        "sigma {sigma} must be > 0"
    );
    assert!(
        alpha > 0.0 && alpha <= 1.0,
        "alpha {alpha} must be in (0, 1]"
    );
    let field = &components[0];
    let size = |f: &Field| (f.width(), f.height(), f.depth());
    if let Some(other) = components.iter().find(|f| size(f) != size(field)) {
        return Err(FieldError::Mismatch {
            first: size(field),
            second: size(other),
        });
    }
    let (depth, d) = (field.depth(), components.len());
    let kernel = gaussian_weights(sigma);
    let frame = Frame::new(field, &options);
    let n = frame.w * frame.h;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let task_bytes = frame.task_bytes(d + 1, depth);
    Ok(in_batches(thresholds, depth, task_bytes, |strata| {
        // Per (stratum, frame): the fraction q, then the d direction components (the one
        // stream, batch after batch).
        let draws: Vec<f64> = (strata.start * depth..strata.end * depth)
            .flat_map(|i| {
                let q = ((i / depth) as f64 + rng.random::<f64>()) / thresholds as f64;
                let direction = unit_direction(&mut rng, d);
                std::iter::once(q).chain(direction)
            })
            .collect();
        draws
            .par_chunks(depth * (d + 1) * LANES)
            .flat_map_iter(|draws| {
                let strata: Vec<&[f64]> = draws.chunks(depth * (d + 1)).collect();
                let mut order: Vec<(u64, u32)> = Vec::with_capacity(n);
                let mut projection = vec![0.0; n];
                let mut windows = vec![Vec::new(); d];
                let lanes = binary_variances(&frame, depth, &kernel, alpha, |z, binary| {
                    let slices: Vec<&[f64]> = components
                        .iter()
                        .zip(&mut windows)
                        .map(|(c, window)| frame.values(c.slice(z), window))
                        .collect();
                    binary.fill([0.0; LANES]);
                    for l in 0..LANES {
                        // Lanes past the last stratum repeat it; their variances are dropped.
                        let draws = strata[l.min(strata.len() - 1)];
                        let (q, direction) = (draws[z * (d + 1)], &draws[z * (d + 1) + 1..][..d]);
                        // n · v(p), components in order from −0.0 (as `Iterator::sum` adds them).
                        projection.fill(-0.0);
                        for (c, &nc) in slices.iter().zip(direction) {
                            for (s, &v) in projection.iter_mut().zip(*c) {
                                *s += v * nc;
                            }
                        }
                        order.clear();
                        order.extend(
                            (0..n as u32)
                                .zip(&projection)
                                .map(|(p, &s)| (total_order_key(s), p)),
                        );
                        let below = ((q * n as f64) as usize).min(n);
                        if below > 0 {
                            order.select_nth_unstable(below - 1);
                            for &(_, p) in &order[..below] {
                                binary[p as usize][l] = 1.0;
                            }
                        }
                    }
                });
                stratum_variances(lanes, strata.len())
            })
            .collect()
    }))
}

/// A key whose unsigned order is `f64::total_cmp`'s order of `x`: the sign bit flipped for
/// positive values, every bit for negative ones.
fn total_order_key(x: f64) -> u64 {
    let bits = x.to_bits();
    if bits >> 63 == 0 {
        bits | 1 << 63
    } else {
        !bits
    }
}

/// A direction uniform on the unit sphere of `ℝᵈ`: `d` normal deviates (Box–Muller), normalised;
/// `(1)` for `d = 1`, whose only directions are ±1 and give the same thresholds up to which side
/// is 1.
fn unit_direction(rng: &mut ChaCha8Rng, d: usize) -> Vec<f64> {
    if d == 1 {
        return vec![1.0];
    }
    loop {
        let mut v: Vec<f64> = (0..d)
            .map(|_| {
                let (u1, u2) = (1.0 - rng.random::<f64>(), rng.random::<f64>());
                (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
            })
            .collect();
        let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if norm > 1e-12 {
            v.iter_mut().for_each(|x| *x /= norm);
            return v;
        }
    }
}

/// The normalised 1D Gaussian `wᵢ ∝ exp(−i² / (2σ²))`, `i ∈ −r..=r` with `r = ⌈4σ⌉`; entry
/// `i + r`.
pub fn gaussian_weights(sigma: f64) -> Vec<f64> {
    let radius = (4.0 * sigma).ceil() as isize;
    let weights: Vec<f64> = (-radius..=radius)
        .map(|i| (-((i * i) as f64) / (2.0 * sigma * sigma)).exp())
        .collect();
    let total: f64 = weights.iter().sum();
    weights.iter().map(|w| w / total).collect()
}

/// Convolves the `w × h` image `image` toroidally with `kernel` (odd length, centred) along x,
/// then along y, calling `emit(&mut out[p], value)` for each pixel `p` in order; `scratch` holds
/// the x pass. All three have `w · h` entries of [`LANES`] independent images. Each value is
/// `Σⱼ kernel[j] · input` in tap order, lane by lane, from `−0.0` along x (what `Iterator::sum`
/// starts from) and from `+0.0` along y.
#[inline(always)]
fn blur_toroidal(
    image: &[[f64; LANES]],
    w: usize,
    h: usize,
    kernel: &[f64],
    scratch: &mut [[f64; LANES]],
    out: &mut [[f64; LANES]],
    mut emit: impl FnMut(&mut [f64; LANES], [f64; LANES]),
) {
    let radius = kernel.len() / 2;
    // Input coordinate of tap j for output coordinate c: (c + j − r) mod len, any r (also
    // r ≥ len), as an index table over c + j.
    let wrapped = |len: usize| -> Vec<usize> {
        (0..len + 2 * radius)
            .map(|i| (i + len * radius - radius) % len)
            .collect()
    };
    // Along x: each row padded toroidally, so that tap j of outputs c.. reads from c + j on.
    let wrapped_x = wrapped(w);
    let mut padded = vec![[0.0; LANES]; wrapped_x.len()];
    for (row, dst) in image.chunks_exact(w).zip(scratch.chunks_exact_mut(w)) {
        for (p, &x) in padded.iter_mut().zip(&wrapped_x) {
            *p = row[x];
        }
        convolve(dst, kernel, -0.0, |j| &padded[j..j + w], |d, v| *d = v);
    }
    // Along y from +0.0: tap j of row y reads row (y + j − r) mod h.
    let wrapped_y = wrapped(h);
    for (y, dst) in out.chunks_exact_mut(w).enumerate() {
        let rows = &wrapped_y[y..y + kernel.len()];
        let tap = |j: usize| &scratch[rows[j] * w..(rows[j] + 1) * w];
        convolve(dst, kernel, 0.0, tap, &mut emit);
    }
}

/// `emit(&mut out[c], (…(start + kernel[0] · tap(0)[c]) + …) + kernel[t] · tap(t)[c])` for each
/// `c` in order, the sums lane by lane, tap by tap in order (`tap(j)` as long as `out`). Each
/// sum is a chain of dependent additions, so [`CHAINS`] outputs are summed side by side (the same
/// operations per output, their latencies overlapped).
#[inline(always)]
fn convolve<'a>(
    out: &mut [[f64; LANES]],
    kernel: &[f64],
    start: f64,
    tap: impl Fn(usize) -> &'a [[f64; LANES]],
    mut emit: impl FnMut(&mut [f64; LANES], [f64; LANES]),
) {
    let whole = out.len() / CHAINS * CHAINS;
    let (grouped, rest) = out.split_at_mut(whole);
    for (g, group) in grouped.chunks_exact_mut(CHAINS).enumerate() {
        let mut sums = [[start; LANES]; CHAINS];
        for (j, &k) in kernel.iter().enumerate() {
            let inputs = &tap(j)[g * CHAINS..(g + 1) * CHAINS];
            for (sum, input) in sums.iter_mut().zip(inputs) {
                for (s, v) in sum.iter_mut().zip(input) {
                    *s += k * v;
                }
            }
        }
        for (o, sum) in group.iter_mut().zip(sums) {
            emit(o, sum);
        }
    }
    for (i, o) in rest.iter_mut().enumerate() {
        let mut sum = [start; LANES];
        for (j, &k) in kernel.iter().enumerate() {
            for (s, v) in sum.iter_mut().zip(tap(j)[whole + i]) {
                *s += k * v;
            }
        }
        emit(o, sum);
    }
}

/// Outputs [`convolve`] sums side by side: 8 measured 0.48 s against 0.55 s for 4 (the
/// [`LANES`] benchmark).
const CHAINS: usize = 8;

/// `Var(hₖ)` for every frame of `field`'s size and each of [`LANES`] strata, where
/// `binarize(k, b)` writes frame `k`'s binary images into `b` (`W·H` entries, each lane 0 or 1).
///
/// Compiled with AVX2 too, picked at run time where the CPU has it: 4 lanes per instruction
/// instead of SSE2's 2, the same IEEE operations in the same order (Rust never fuses a multiply
/// and an add), so the same bits. The analysis bench, Zen 4, 2 cores, both builds in one sitting:
/// 0.72–0.73 s (SSE2) against 0.46 s, with half-spaces 1.21–1.24 s against 0.94–0.95 s.
fn binary_variances(
    frame: &Frame,
    depth: usize,
    kernel: &[f64],
    alpha: f64,
    binarize: impl FnMut(usize, &mut [[f64; LANES]]),
) -> Vec<[f64; LANES]> {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU runs AVX2 code (checked just above), all that
        // `binary_variances_avx2` requires.
        return unsafe { binary_variances_avx2(frame, depth, kernel, alpha, binarize) };
    }
    binary_variances_portable(frame, depth, kernel, alpha, binarize)
}

/// [`binary_variances`] compiled with AVX2 enabled.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn binary_variances_avx2(
    frame: &Frame,
    depth: usize,
    kernel: &[f64],
    alpha: f64,
    binarize: impl FnMut(usize, &mut [[f64; LANES]]),
) -> Vec<[f64; LANES]> {
    binary_variances_portable(frame, depth, kernel, alpha, binarize)
}

/// [`binary_variances`] for the target's baseline, inlined into the AVX2 build.
#[inline(always)]
fn binary_variances_portable(
    frame: &Frame,
    depth: usize,
    kernel: &[f64],
    alpha: f64,
    mut binarize: impl FnMut(usize, &mut [[f64; LANES]]),
) -> Vec<[f64; LANES]> {
    let (w, h) = (frame.w, frame.h);
    let n = w * h;
    let mut binary = vec![[0.0; LANES]; n];
    let mut scratch = vec![[0.0; LANES]; n];
    let mut ema = vec![[0.0; LANES]; n];
    let measured = frame.measured() as f64;
    // A plain loop, not an iterator chain: a closure handed to `map` is compiled out of line,
    // without the AVX2 build's features.
    let mut variances = Vec::with_capacity(depth);
    for z in 0..depth {
        binarize(z, &mut binary);
        // Each blurred value goes into the EMA, and the window's EMA into the mean's sum (over
        // its pixels in pixel order, lane by lane, from −0.0 like `Iterator::sum`): straight
        // from the blur when the window is the whole frame.
        let mut mean = [-0.0; LANES];
        let update = |e: &mut [f64; LANES], f: [f64; LANES]| {
            for (e, f) in e.iter_mut().zip(f) {
                *e = if z == 0 {
                    f
                } else {
                    alpha * f + (1.0 - alpha) * *e
                };
            }
        };
        if frame.whole {
            blur_toroidal(&binary, w, h, kernel, &mut scratch, &mut ema, |e, f| {
                update(e, f);
                for (m, e) in mean.iter_mut().zip(e) {
                    *m += *e;
                }
            });
        } else {
            blur_toroidal(&binary, w, h, kernel, &mut scratch, &mut ema, update);
            for row in ema[frame.y0 * w..frame.y1 * w].chunks_exact(w) {
                for e in &row[frame.x0..frame.x1] {
                    for (m, e) in mean.iter_mut().zip(e) {
                        *m += *e;
                    }
                }
            }
        }
        let mean = mean.map(|s| s / measured);
        let mut variance = [-0.0; LANES];
        for row in ema[frame.y0 * w..frame.y1 * w].chunks_exact(w) {
            for e in &row[frame.x0..frame.x1] {
                for ((v, e), m) in variance.iter_mut().zip(e).zip(mean) {
                    *v += (e - m) * (e - m);
                }
            }
        }
        variances.push(variance.map(|s| s / measured));
    }
    variances
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The filtered errors one stratum at a time, in the plainest order: each blur output a
    /// `sum` over an index table, each frame's mean and variance a `sum` over the pixels of the
    /// window `(ww, wh)` at the origin (the whole frame: `(width, height)`).
    fn one_stratum_at_a_time(
        field: &Field,
        options: FilteredErrorOptions,
        (ww, wh): (usize, usize),
        binarize: impl Fn(usize, usize, &mut [f64]),
    ) -> Vec<f64> {
        let (w, h, depth) = (field.width(), field.height(), field.depth());
        let n = w * h;
        let kernel = gaussian_weights(options.sigma);
        let r = kernel.len() / 2;
        let taps = |len: usize, c: usize| -> Vec<usize> {
            (0..kernel.len())
                .map(|j| (c + j + len * r - r) % len)
                .collect()
        };
        let mut sum = vec![0.0; depth];
        for s in 0..options.thresholds {
            let mut ema = vec![0.0; n];
            for (z, total) in sum.iter_mut().enumerate() {
                let mut binary = vec![0.0; n];
                binarize(s, z, &mut binary);
                let mut blurred_x = vec![0.0; n];
                for y in 0..h {
                    for x in 0..w {
                        blurred_x[y * w + x] = kernel
                            .iter()
                            .zip(taps(w, x))
                            .map(|(k, i)| k * binary[y * w + i])
                            .sum();
                    }
                }
                let mut filtered = vec![0.0; n];
                for y in 0..h {
                    for (k, i) in kernel.iter().zip(taps(h, y)) {
                        for x in 0..w {
                            filtered[y * w + x] += k * blurred_x[i * w + x];
                        }
                    }
                }
                for (e, f) in ema.iter_mut().zip(&filtered) {
                    *e = if z == 0 {
                        *f
                    } else {
                        options.alpha * f + (1.0 - options.alpha) * *e
                    };
                }
                let window = || (0..wh).flat_map(|y| &ema[y * w..y * w + ww]);
                let count = (ww * wh) as f64;
                let mean = window().sum::<f64>() / count;
                *total += window().map(|e| (e - mean) * (e - mean)).sum::<f64>() / count;
            }
        }
        sum.iter()
            .map(|s| (s / options.thresholds as f64).sqrt())
            .collect()
    }

    #[test]
    fn strata_in_lanes_give_the_bits_of_one_stratum_at_a_time() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        // Whole and partial groups of lanes, a kernel wider than the image, a single pixel.
        for (w, h, d, thresholds) in [
            (32, 16, 8, 256),
            (5, 3, 4, 7),
            (24, 20, 6, 37),
            (1, 1, 3, 5),
        ] {
            let values: Vec<f64> = (0..w * h * d).map(|_| rng.random()).collect();
            let field = Field::new(w, h, d, &values).unwrap();
            let options = FilteredErrorOptions {
                thresholds,
                seed: 9,
                ..FilteredErrorOptions::default()
            };
            // The thresholds `filtered_error` draws.
            let mut levels = ChaCha8Rng::seed_from_u64(options.seed);
            let levels: Vec<f64> = (0..thresholds * d)
                .map(|i| ((i / d) as f64 + levels.random::<f64>()) / thresholds as f64)
                .collect();
            let binarize = |s: usize, z: usize, binary: &mut [f64]| {
                for (b, &v) in binary.iter_mut().zip(field.slice(z)) {
                    *b = if v < levels[s * d + z] { 1.0 } else { 0.0 };
                }
            };
            let expected = one_stratum_at_a_time(&field, options, (w, h), binarize);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(
                bits(&filtered_error(&field, options)),
                bits(&expected),
                "{w}x{h}x{d}, {thresholds} thresholds"
            );
            // Half-space thresholds of 2D values: the draws `filtered_error_vector` makes.
            let other: Vec<f64> = (0..w * h * d).map(|_| rng.random()).collect();
            let second = Field::new(w, h, d, &other).unwrap();
            let mut draws = ChaCha8Rng::seed_from_u64(options.seed);
            let draws: Vec<(f64, Vec<f64>)> = (0..thresholds * d)
                .map(|i| {
                    let q = ((i / d) as f64 + draws.random::<f64>()) / thresholds as f64;
                    (q, unit_direction(&mut draws, 2))
                })
                .collect();
            let expected = one_stratum_at_a_time(&field, options, (w, h), |s, z, binary| {
                let (q, direction) = &draws[s * d + z];
                let projection =
                    |p: usize| field.slice(z)[p] * direction[0] + second.slice(z)[p] * direction[1];
                let mut order: Vec<usize> = (0..w * h).collect();
                order.sort_by(|&a, &b| projection(a).total_cmp(&projection(b)).then(a.cmp(&b)));
                let below = ((q * (w * h) as f64) as usize).min(w * h);
                binary.fill(0.0);
                for &p in &order[..below] {
                    binary[p] = 1.0;
                }
            });
            let vector = filtered_error_vector(&[field, second], options).unwrap();
            assert_eq!(bits(&vector), bits(&expected), "{w}x{h}x{d}, vector");
        }
    }

    #[test]
    fn a_window_measures_its_pixels_with_their_whole_frame_neighbours() {
        let (w, h, d) = (40, 30, 3);
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let values: Vec<f64> = (0..w * h * d).map(|_| rng.random()).collect();
        let field = Field::new(w, h, d, &values).unwrap();
        let options = FilteredErrorOptions {
            thresholds: 9,
            seed: 4,
            ..FilteredErrorOptions::default()
        };
        let mut levels = ChaCha8Rng::seed_from_u64(options.seed);
        let levels: Vec<f64> = (0..options.thresholds * d)
            .map(|i| ((i / d) as f64 + levels.random::<f64>()) / options.thresholds as f64)
            .collect();
        let radius = gaussian_weights_radius(options.sigma);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        // x cut, y whole; x whole, y cut; both cut.
        for window in [(16, 30), (40, 10), (12, 9)] {
            let frame = Frame::with_window(&field, radius, window);
            assert!(!frame.whole);
            let expected = one_stratum_at_a_time(&field, options, window, |s, z, binary| {
                for (b, &v) in binary.iter_mut().zip(field.slice(z)) {
                    *b = if v < levels[s * d + z] { 1.0 } else { 0.0 };
                }
            });
            assert_eq!(
                bits(&windowed_error(&field, options, &frame)),
                bits(&expected),
                "{window:?}"
            );
        }
    }

    #[test]
    fn weights_are_normalised_and_cover_four_sigma() {
        let weights = gaussian_weights(1.3435);
        assert_eq!(weights.len(), 13); // ⌈5.374⌉ = 6 each side
        assert!((weights.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        assert!(weights.windows(2).take(6).all(|p| p[0] < p[1]));
        assert_eq!(weights[0], weights[12]);
        // Σ w² ≈ 1 / (2σ√π) for σ well above a pixel.
        let squares: f64 = weights.iter().map(|w| w * w).sum();
        let continuous = 1.0 / (2.0 * 1.3435 * std::f64::consts::PI.sqrt());
        assert!((squares / continuous - 1.0).abs() < 1e-3, "{squares}");
    }

    #[test]
    fn blur_of_an_impulse_is_the_wrapped_kernel() {
        // 5 × 3 image, kernel radius 2 (longer than the 3-pixel column: taps wrap twice).
        let (w, h) = (5, 3);
        let kernel = [0.1, 0.2, 0.4, 0.2, 0.1];
        let mut image = vec![[0.0; LANES]; w * h];
        image[w] = [1.0; LANES]; // (0, 1)
        image[w][1] = 0.0; // one lane empty: the lanes are independent
        let (mut scratch, mut out) = (image.clone(), image.clone());
        blur_toroidal(&image, w, h, &kernel, &mut scratch, &mut out, |o, v| *o = v);
        assert!(out.iter().all(|v| v[1] == 0.0));
        let out: Vec<f64> = out.iter().map(|v| v[0]).collect();
        // Along y (h = 3): offsets −2..=2 land on rows 2, 0, 1, 2, 0 → row weights.
        let wy = |y: usize| match y {
            0 => 0.2 + 0.1, // offsets −1 and +2
            1 => 0.4,
            _ => 0.1 + 0.2, // offsets −2 and +1
        };
        let wx = |x: usize| match x {
            0 => 0.4,
            1 | 4 => 0.2,
            _ => 0.1,
        };
        for y in 0..h {
            for x in 0..w {
                let expected = wx(x) * wy(y);
                assert!((out[y * w + x] - expected).abs() < 1e-15, "({x}, {y})");
            }
        }
        assert!((out.iter().sum::<f64>() - 1.0).abs() < 1e-15);
    }

    #[test]
    fn constant_stripe_and_ema_fields_measure_exactly() {
        // A constant field thresholds to a constant image at every t: no error anywhere (up to
        // the rounding of the blur, which need not return exactly 1 for an all-ones image).
        let values = vec![0.4; 8 * 8 * 3];
        let field = Field::new(8, 8, 3, &values).unwrap();
        let error = filtered_error(&field, FilteredErrorOptions::default());
        assert_eq!(error.len(), 3);
        assert!(error.iter().all(|&e| e < 1e-12), "{error:?}");
        // Half the pixels 0, half 0.99, in columns: any t in (0, 0.99] gives vertical stripes
        // that the x blur cannot flatten fully; alpha 1 = no history.
        let stripes: Vec<f64> = (0..16)
            .map(|i| if i % 2 == 0 { 0.0 } else { 0.99 })
            .collect();
        let field = Field::new(4, 4, 1, &stripes).unwrap();
        let options = FilteredErrorOptions {
            thresholds: 64,
            alpha: 1.0,
            ..FilteredErrorOptions::default()
        };
        let kernel = gaussian_weights(FilteredErrorOptions::SIGMA);
        // Period-2 stripes keep the kernel's response at Nyquist: Σ (−1)^i wᵢ.
        let gain: f64 = kernel
            .iter()
            .enumerate()
            .map(|(i, w)| if i % 2 == 0 { *w } else { -*w })
            .sum::<f64>()
            .abs();
        // Thresholds above 0.99 (64 · 0.01 = 0.64 of a stratum) see an all-ones image.
        let covered: f64 = 0.99 * 64.0;
        let expected = (0.25 * gain * gain * covered.floor() / 64.0).sqrt();
        let measured = filtered_error(&field, options)[0];
        // The partial stratum 63 adds between 0 and 1/64 of the stripe variance.
        let most = (0.25 * gain * gain * covered.ceil() / 64.0).sqrt();
        assert!(
            measured >= expected - 1e-15 && measured <= most + 1e-15,
            "{expected} ≤ {measured} ≤ {most}"
        );
        // Add a frame of zeros (all ones for every t > 0): the EMA keeps (1 − α) of the stripes,
        // h₁ = α · 1 + (1 − α) · h₀, so E(1) = (1 − α) · E(0) exactly (up to rounding).
        let mut two = stripes.clone();
        two.extend([0.0; 16]);
        let field = Field::new(4, 4, 2, &two).unwrap();
        let alpha = 0.3;
        let curve = filtered_error(&field, FilteredErrorOptions { alpha, ..options });
        assert!(
            (curve[1] - (1.0 - alpha) * curve[0]).abs() < 1e-12,
            "{curve:?}"
        );
    }

    #[test]
    fn vector_thresholds_hold_exact_fractions_and_match_the_scalar_figure_in_1d() {
        // A permutation per frame (exact histogram): for d = 1 the half-space threshold at
        // fraction q picks the same pixels as v < t for t = q up to the jitter of one level.
        let (w, h, d) = (16, 16, 4);
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut values = Vec::new();
        for _ in 0..d {
            let mut frame: Vec<f64> = (0..w * h)
                .map(|i| (i as f64 + 0.5) / (w * h) as f64)
                .collect();
            for i in (1..frame.len()).rev() {
                frame.swap(i, rng.random_range(0..=i));
            }
            values.extend(frame);
        }
        let field = Field::new(w, h, d, &values).unwrap();
        let options = FilteredErrorOptions::default();
        let scalar = filtered_error(&field, options);
        let vector = filtered_error_vector(std::slice::from_ref(&field), options).unwrap();
        for (s, v) in scalar.iter().zip(&vector) {
            assert!((s - v).abs() < 0.02 * s, "{scalar:?} vs {vector:?}");
        }
        // Two components: white 2D vectors measure near the white-noise expectation, a constant
        // pair (all pixels on one side of every hyperplane... or split by index ties) is finite.
        let other: Vec<f64> = values.iter().rev().copied().collect();
        let second = Field::new(w, h, d, &other).unwrap();
        let pair = filtered_error_vector(&[field, second], options).unwrap();
        assert_eq!(pair.len(), d);
        assert!(pair.iter().all(|e| e.is_finite() && *e > 0.0), "{pair:?}");
    }

    #[test]
    fn vector_fields_of_different_sizes_are_an_error() {
        let a = Field::new(2, 2, 1, &[0.1; 4]).unwrap();
        let b = Field::new(4, 1, 1, &[0.1; 4]).unwrap();
        assert!(filtered_error_vector(&[a, b], FilteredErrorOptions::default()).is_err());
    }

    #[test]
    fn directions_are_unit_and_cover_both_signs() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let dirs: Vec<Vec<f64>> = (0..200).map(|_| unit_direction(&mut rng, 3)).collect();
        for v in &dirs {
            assert!((v.iter().map(|x| x * x).sum::<f64>() - 1.0).abs() < 1e-12);
        }
        for c in 0..3 {
            let mean = dirs.iter().map(|v| v[c]).sum::<f64>() / 200.0;
            assert!(mean.abs() < 0.15, "component {c} mean {mean}");
        }
    }
}
