//! Tellusim's layered blue noise ("Improved Blue Noise", Tellusim, 2022): a stack of 2D
//! void-and-cluster masks in which each layer starts from the previous one, so that consecutive
//! frames are correlated. A baseline to compare STBN against; see [`generate_layered`].
//!
//! # The algorithm, as Tellusim describes and publishes it
//!
//! Every layer is an ordinary 2D void-and-cluster mask of one `W × H` slice, with the energy of a
//! pixel `p` the sum over the on pixels `q` of the kernel
//!
//! ```text
//! k(d) = exp(−d² / σ²) + ε / (1 + d²)
//! ```
//!
//! where `d` is the toroidal distance between `p` and `q` in pixels (per axis the shorter way
//! round, `|dx| ≤ W/2`, `|dy| ≤ H/2`; one image of each offset, no folding). Note `/σ²`, not the
//! paper's `/(2σ²)`: Tellusim's σ 1.6 is the paper's σ 1.6/√2 ≈ 1.13. The `ε / (1 + d²)` tail
//! (ε = 0.01) never reaches zero, so the kernel covers the whole slice and is not truncated here:
//! every splat updates all `W·H` energies.
//!
//! 1. Layer 0's initial pattern is `round(density · W·H)` distinct random pixels. It is relaxed by
//!    up to that many iterations of "turn on the largest void, then turn off the tightest
//!    cluster" (stopping early once the two are the same pixel, after which nothing changes).
//! 2. Each layer ranks its initial pattern like void-and-cluster's phases 2 and 3: on a copy, the
//!    tightest clusters are removed one by one and get ranks `c − 1` down to 0 (`c` = pattern
//!    size); from the pattern itself, the largest voids are turned on one by one and get ranks
//!    `c` up to `W·H − 1`. (Tellusim inverts the image for the second half; the inverted
//!    pattern's tightest cluster is the original's largest void, so the order is the same.)
//! 3. The next layer's initial pattern is the previous layer's ranks flipped in X and Y,
//!    inverted and thresholded at the initial density: pixel `(x, y)` is on when the previous
//!    layer's pixel `(W − 1 − x, H − 1 − y)` has one of the `c` highest ranks. It is not relaxed
//!    (step 1 runs for layer 0 only).
//!
//! Each layer is a permutation of `0..W·H`, so the result is a [`Volume`] whose slices are
//! exactly uniform, like every mask of this crate.
//!
//! # Differences from Tellusim's GPU code
//!
//! - Energies are integers: each kernel weight is rounded to a multiple of `total / 2³¹`
//!   (`total` = the sum of all `W·H` weights), so every energy is exact and the results are the
//!   same on every machine. Tellusim convolves in `f32` with an FFT. At 128×128 and σ 1.6 the
//!   smallest tail weight is still a few hundred units.
//! - Ties (equal energies) are broken by a seeded random priority per pixel, not by the GPU's
//!   reduction order.
//! - Tellusim's initial pattern draws `density · W·H` pixels with replacement (a few collide);
//!   here exactly `round(density · W·H)` distinct pixels are on.
//!
//! # Cost
//!
//! A layer takes `W·H + c` splats and as many searches, each over all `W·H` pixels:
//! `O((W·H)² · D)` in all (BENCHMARKS.md has measured times). That is fine for the 64×64 and
//! 128×128 slices Tellusim recommends, and slow for 256×256 slices and above.

use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

use crate::{MaskSpec, SpecError, Volume};

/// Tellusim's recommended σ (pixels, their convention `exp(−d²/σ²)`) for 64×64×32 sequences.
pub(crate) const DEFAULT_SIGMA: f64 = 1.6;

/// Tellusim's weight ε of the kernel's `ε / (1 + d²)` tail.
pub(crate) const DEFAULT_EPSILON: f64 = 0.01;

/// The on bit of an energy word; the low 31 bits hold the energy.
const ON: u32 = 1 << 31;

/// The kernel weight at squared distance `distance_squared` (pixels²):
/// `exp(−d²/σ²) + ε / (1 + d²)`, dimensionless, `1 + ε` at `d = 0`.
fn kernel_weight(distance_squared: f64, sigma: f64, epsilon: f64) -> f64 {
    (-distance_squared / (sigma * sigma)).exp() + epsilon / (1.0 + distance_squared)
}

/// Tellusim's layered blue noise at the size, seed and initial density of `spec`, with σ =
/// `spec.sigma_xy` **in Tellusim's convention** (`exp(−d²/σ²)`, default [`DEFAULT_SIGMA`]) and
/// tail weight `epsilon` (default [`DEFAULT_EPSILON`]). See the [module docs](self).
///
/// `spec.sigma_z`, `spec.topology` and `spec.kernel_tolerance` are not used. Deterministic:
/// the layers are generated one after the other, and within a layer the only concurrency is
/// ranking the initial pattern beside the void filling, which share nothing mutable.
/// `layers_done` is called with the number of layers ranked after each layer.
///
/// Errors if `spec` is invalid ([`MaskSpec::validate`]). Panics if `epsilon` is negative or not
/// finite.
pub(crate) fn generate_layered(
    spec: &MaskSpec,
    epsilon: f64,
    layers_done: &mut dyn FnMut(u64),
) -> Result<Volume, SpecError> {
    spec.validate()?;
    assert!(
        epsilon.is_finite() && epsilon >= 0.0,
        "epsilon {epsilon} must be finite and >= 0"
    );
    let (w, h) = (spec.width as usize, spec.height as usize);
    let n = w * h;
    let kernel = LayerKernel::new(w, h, spec.sigma_xy, epsilon);
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
    let mut priority: Vec<u32> = (1..=n as u32).collect();
    priority.shuffle(&mut rng);
    let mut order: Vec<usize> = (0..n).collect();
    order.shuffle(&mut rng);
    let ones = ((spec.initial_density * n as f64).round() as usize).clamp(1, n);
    let mut pattern = vec![false; n];
    for &i in &order[..ones] {
        pattern[i] = true;
    }

    let mut ranks = Vec::with_capacity(n * spec.depth as usize);
    for layer in 0..spec.depth {
        let mut field = LayerField::new(&kernel, &priority, &pattern);
        if layer == 0 && ones < n {
            field.relax(ones);
        }
        let slice = field.rank(ones);
        // Next layer: the `ones` highest ranks, flipped in X and Y.
        for (i, on) in pattern.iter_mut().enumerate() {
            *on = slice[n - 1 - i] as usize >= n - ones;
        }
        ranks.extend_from_slice(&slice);
        layers_done(u64::from(layer) + 1);
    }
    Ok(Volume::from_global_ranks(
        spec.width,
        spec.height,
        spec.depth,
        &ranks,
    ))
}

/// The integer kernel of one `w × h` slice: entry `(dx, dy)` (offsets modulo the size) is
/// `round(k(d) · scale)` with `scale = (2³¹ − 2²⁴) / Σ k`, so any sum of distinct entries stays
/// below 2³¹ (rounding adds at most `w·h / 2 ≤ 2²³`).
struct LayerKernel {
    width: usize,
    height: usize,
    /// Row `dy` twice over (`2 · width` entries per row): the weights of a target row at offsets
    /// `x − qx` for every `x` are the contiguous run starting at `width − qx`.
    doubled_rows: Vec<u32>,
}

impl LayerKernel {
    fn new(width: usize, height: usize, sigma: f64, epsilon: f64) -> LayerKernel {
        let shortest = |d: usize, len: usize| d.min(len - d) as f64;
        let weights: Vec<f64> = (0..height)
            .flat_map(|dy| {
                (0..width).map(move |dx| {
                    let (x, y) = (shortest(dx, width), shortest(dy, height));
                    kernel_weight(x * x + y * y, sigma, epsilon)
                })
            })
            .collect();
        // Sum in index order: the same total on every machine.
        let total: f64 = weights.iter().sum();
        let scale = f64::from((1u32 << 31) - (1 << 24)) / total;
        let mut doubled_rows = Vec::with_capacity(2 * width * height);
        for row in weights.chunks_exact(width) {
            let integers: Vec<u32> = row.iter().map(|k| (k * scale).round() as u32).collect();
            doubled_rows.extend_from_slice(&integers);
            doubled_rows.extend_from_slice(&integers);
        }
        LayerKernel {
            width,
            height,
            doubled_rows,
        }
    }

    /// Adds (`on`) or subtracts the kernel centred on pixel `source` to every energy of `words`;
    /// returns the smallest and the largest word afterwards (found in the same pass, which
    /// vectorises, instead of a second one).
    fn splat(&self, words: &mut [u32], source: usize, on: bool) -> (u32, u32) {
        let (w, h) = (self.width, self.height);
        let (qx, qy) = (source % w, source / w);
        let (mut least, mut most) = (u32::MAX, 0);
        for (y, row) in words.chunks_exact_mut(w).enumerate() {
            let dy = (y + h - qy) % h;
            let start = dy * 2 * w + (w - qx);
            let weights = &self.doubled_rows[start..start + w];
            for (e, k) in row.iter_mut().zip(weights) {
                *e = if on { *e + k } else { *e - k };
                least = least.min(*e);
                most = most.max(*e);
            }
        }
        (least, most)
    }
}

/// One layer's binary pattern and energies: word `i` is pixel `i`'s energy, with bit 31 set
/// when the pixel is on. Off words are below 2³¹ and on words at or above it, so the largest
/// void is the smallest word and the tightest cluster the largest.
#[derive(Clone)]
struct LayerField<'a> {
    kernel: &'a LayerKernel,
    priority: &'a [u32],
    words: Vec<u32>,
    /// The smallest word: the largest void's (while any pixel is off).
    least: u32,
    /// The largest word: the tightest cluster's (while any pixel is on).
    most: u32,
}

impl<'a> LayerField<'a> {
    /// The energies of `pattern` (`true` = on).
    fn new(kernel: &'a LayerKernel, priority: &'a [u32], pattern: &[bool]) -> LayerField<'a> {
        let mut field = LayerField {
            kernel,
            priority,
            words: vec![0; pattern.len()],
            least: 0,
            most: 0,
        };
        for (i, _) in pattern.iter().enumerate().filter(|(_, on)| **on) {
            field.toggle(i);
        }
        field
    }

    /// Turns pixel `i` on if it is off and off if it is on, updating every energy.
    fn toggle(&mut self, i: usize) {
        let on = self.words[i] & ON == 0;
        self.words[i] ^= ON;
        (self.least, self.most) = self.kernel.splat(&mut self.words, i, on);
    }

    /// The largest void: the off pixel of lowest energy, ties to the lowest priority. The
    /// caller guarantees an off pixel exists.
    fn largest_void(&self) -> usize {
        debug_assert!(self.least & ON == 0, "no off pixel");
        self.tie_break(self.least, |a, b| a < b)
    }

    /// The tightest cluster: the on pixel of highest energy, ties to the highest priority. The
    /// caller guarantees an on pixel exists.
    fn tightest_cluster(&self) -> usize {
        debug_assert!(self.most & ON != 0, "no on pixel");
        self.tie_break(self.most, |a, b| a > b)
    }

    /// The pixel holding `word` whose priority `better` prefers.
    fn tie_break(&self, word: u32, better: impl Fn(u32, u32) -> bool) -> usize {
        /// Words compared per chunk: the comparison of a chunk vectorises, and only chunks that
        /// hold `word` are looked at pixel by pixel.
        const CHUNK: usize = 64;
        let mut best: Option<usize> = None;
        for (c, chunk) in self.words.chunks(CHUNK).enumerate() {
            let found = chunk
                .iter()
                .fold(0u32, |any, &w| any | u32::from(w == word));
            if found == 0 {
                continue;
            }
            for (k, _) in chunk.iter().enumerate().filter(|(_, w)| **w == word) {
                let i = c * CHUNK + k;
                if best.is_none_or(|b| better(self.priority[i], self.priority[b])) {
                    best = Some(i);
                }
            }
        }
        best.expect("the word was found")
    }

    /// Layer 0's relaxation: up to `iterations` times, turn the largest void on and the
    /// tightest cluster off, stopping once they are the same pixel.
    fn relax(&mut self, iterations: usize) {
        for _ in 0..iterations {
            let void = self.largest_void();
            self.toggle(void);
            let cluster = self.tightest_cluster();
            self.toggle(cluster);
            if cluster == void {
                break;
            }
        }
    }

    /// Ranks every pixel `0..W·H`, starting from this pattern of `ones` on pixels.
    fn rank(self, ones: usize) -> Vec<u32> {
        let n = self.words.len();
        let mut ranks = vec![0u32; n];
        let mut pattern = self.clone();
        let mut filling = self;
        let (removed, ()) = rayon::join(
            || {
                (0..ones)
                    .map(|_| {
                        let cluster = pattern.tightest_cluster();
                        pattern.toggle(cluster);
                        cluster
                    })
                    .collect::<Vec<usize>>()
            },
            || {
                for rank in ones..n {
                    let void = filling.largest_void();
                    ranks[void] = rank as u32;
                    if rank + 1 < n {
                        filling.toggle(void);
                    }
                }
            },
        );
        for (k, &pixel) in removed.iter().enumerate() {
            ranks[pixel] = (ones - 1 - k) as u32;
        }
        ranks
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(w: u32, h: u32, d: u32, seed: u64) -> MaskSpec {
        MaskSpec::new(w, h, d, seed).with_sigma(DEFAULT_SIGMA)
    }

    #[test]
    fn kernel_has_the_documented_shape() {
        assert_eq!(kernel_weight(0.0, 1.6, 0.01), 1.01);
        let at_2 = kernel_weight(4.0, 1.6, 0.01);
        assert!((at_2 - ((-4.0f64 / 2.56).exp() + 0.002)).abs() < 1e-15);
        // Far away only the tail is left.
        assert!((kernel_weight(400.0, 1.6, 0.01) - 0.01 / 401.0).abs() < 1e-15);
        // Integer kernel: symmetric under negating the offset, peak at 0, total below 2³¹.
        let (w, h) = (6, 5);
        let kernel = LayerKernel::new(w, h, 1.6, 0.01);
        let weight = |dx: usize, dy: usize| kernel.doubled_rows[dy * 2 * w + dx];
        let mut total = 0u64;
        for dy in 0..h {
            for dx in 0..w {
                assert_eq!(weight(dx, dy), weight((w - dx) % w, (h - dy) % h));
                assert_eq!(weight(dx, dy), kernel.doubled_rows[dy * 2 * w + w + dx]);
                assert!(weight(dx, dy) <= weight(0, 0));
                total += u64::from(weight(dx, dy));
            }
        }
        assert!(total < 1 << 31);
        // The tail keeps the farthest offset (3, 2) well above zero.
        assert!(weight(3, 2) > 1000, "{}", weight(3, 2));
    }

    #[test]
    fn splats_match_a_direct_sum() {
        let (w, h) = (7, 4);
        let kernel = LayerKernel::new(w, h, 1.6, 0.01);
        let priority: Vec<u32> = (1..=(w * h) as u32).collect();
        let pattern: Vec<bool> = (0..w * h).map(|i| i % 5 == 1 || i == 27).collect();
        let mut field = LayerField::new(&kernel, &priority, &pattern);
        // Toggle a few pixels back and forth; the words must equal a from-scratch sum.
        for i in [3, 27, 3, 0, 13] {
            field.toggle(i);
        }
        let mut on = pattern.clone();
        for i in [3, 27, 3, 0, 13] {
            on[i] = !on[i];
        }
        for p in 0..w * h {
            let (px, py) = (p % w, p / w);
            let mut energy = 0u32;
            for q in (0..w * h).filter(|&q| on[q]) {
                let (dx, dy) = ((px + w - q % w) % w, (py + h - q / w) % h);
                energy += kernel.doubled_rows[dy * 2 * w + dx];
            }
            let expected = energy | if on[p] { ON } else { 0 };
            assert_eq!(field.words[p], expected, "pixel {p}");
        }
    }

    #[test]
    fn every_layer_is_a_permutation_and_the_seed_decides() {
        for (w, h, d) in [(1, 1, 2), (2, 3, 3), (16, 16, 4), (13, 7, 3)] {
            let volume = generate_layered(&spec(w, h, d, 3), DEFAULT_EPSILON, &mut |_| {}).unwrap();
            for z in 0..d {
                let mut slice = volume.slice(z).to_vec();
                slice.sort_unstable();
                assert!(slice.iter().enumerate().all(|(i, &r)| r as usize == i));
            }
        }
        let a = generate_layered(&spec(16, 16, 3, 1), DEFAULT_EPSILON, &mut |_| {}).unwrap();
        assert_eq!(
            a,
            generate_layered(&spec(16, 16, 3, 1), DEFAULT_EPSILON, &mut |_| {}).unwrap()
        );
        assert_ne!(
            a,
            generate_layered(&spec(16, 16, 3, 2), DEFAULT_EPSILON, &mut |_| {}).unwrap()
        );
        assert!(generate_layered(&spec(0, 16, 3, 1), DEFAULT_EPSILON, &mut |_| {}).is_err());
    }

    #[test]
    fn each_layer_starts_from_the_previous_one_flipped() {
        // The lowest ranks of layer z + 1 are exactly the pixels whose flipped partner held the
        // highest ranks of layer z: the initial pattern is ranked first (ranks 0..c).
        let (w, h) = (16usize, 12usize);
        let n = w * h;
        let s = spec(w as u32, h as u32, 4, 9);
        let ones = (s.initial_density * n as f64).round() as usize;
        let volume = generate_layered(&s, DEFAULT_EPSILON, &mut |_| {}).unwrap();
        for z in 0..3 {
            let (this, next) = (volume.slice(z), volume.slice(z + 1));
            for i in 0..n {
                let high_before = this[n - 1 - i] as usize >= n - ones;
                let low_after = (next[i] as usize) < ones;
                assert_eq!(high_before, low_after, "layer {z} pixel {i}");
            }
        }
    }
}
