//! The filters a filter-adapted mask is optimised for, and the integer pair weights built from
//! their autocorrelations.
//!
//! # From filters to pair weights
//!
//! A filter `f` (spatial `f_xy = f_x ⊗ f_y`, temporal `f_t`) applied to a mask's values `v`
//! leaves the error `Σ_p (Σ_q f(p − q)(v_q − m))²`, which expands to
//! `Σ_{q,r} g(q − r)(v_q − m)(v_r − m)` with `g = f ⋆ f`, the filter's autocorrelation. Each 1D
//! filter is first wrapped onto its axis (toroidally: tap `i` lands on `i mod size`, so a filter
//! wider than the mask is folded, never cut), then autocorrelated circularly, so `g` is defined
//! for every toroidal offset exactly once and `Σ g = (Σ f)² = 1` per factor before truncation.
//!
//! - [`FilterCombination::Product`]: `g(Δxy, Δt) = g_xy(Δxy) · g_t(Δt)`, the full 3D filter a
//!   renderer applies when it blurs every frame and then accumulates frames.
//! - [`FilterCombination::Separate`]: `g = w · g_xy(Δxy)·[Δt = 0] + (1 − w) · g_t(Δt)·[Δxy = 0]`,
//!   the STBN-like energy: pixels interact only within a frame or along their own history.
//!
//! # Truncation and fixed point
//!
//! Each factor is truncated on its own: spatial offsets where `g_xy < tolerance · g_xy(0)` and
//! temporal offsets where `g_t < tolerance · g_t(0)` are dropped (autocorrelations peak at 0),
//! and the kept weights are renormalised and scaled to integers, so every sum the optimiser
//! forms is an exact integer:
//!
//! - for the distance value kernel, spatial weights summing to about 2²² (`i64`) and temporal
//!   weights summing to about 2¹⁴ (`i16`), so that a window of temporal weights times `i16`
//!   levels below 2¹⁴ sums exactly in `i32` and every footprint sum stays below 2⁵⁰ in `i64`;
//! - for the product value kernel, weights whose total times the largest value magnitude `U`
//!   is at most 2⁵¹ (the two factors of a product split the bits), so the optimiser can keep
//!   its field in `f64`, where integer sums below 2⁵³ are exact in any order.

use std::fmt;

use crate::fastmath::exp_neg;
use crate::torus::canonical;

/// The spatial filter a mask is optimised for, applied separably along x and y.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SpatialFilter {
    /// Gaussian of standard deviation `sigma` pixels (finite, in `(0,`
    /// [`SpatialFilter::MAX_SIGMA`]`]`): per axis, weights `exp(−i²/(2σ²))` for `|i| ≤ ⌈4σ⌉`,
    /// normalised, exactly the blur of [`crate::analysis::filtered_error`].
    Gaussian {
        /// Standard deviation in pixels.
        sigma: f64,
    },
    /// A box of `size × size` pixels (`size` in `1..=`[`SpatialFilter::MAX_SIZE`]), FAST's
    /// `Box <Size>`. A mask refuses a size that is a multiple of both its width and height: such
    /// a box folds flat over the wrapped slice.
    Box {
        /// Width of the box in pixels.
        size: u32,
    },
    /// Binomial weights `C(order, k) / 2^order`, `order + 1` taps per axis (`order` in
    /// `1..=`[`SpatialFilter::MAX_ORDER`]): 2 is the 3×3 filter `[1 2 1]/4 ⊗ [1 2 1]/4`, FAST's
    /// `Binomial <N>`. Its σ is `√order / 2`; a mask refuses an order above the square of its
    /// larger side (σ past half the slice, where a Gaussian folds flat too).
    Binomial {
        /// `N` of `C(N, k)`.
        order: u32,
    },
}

impl SpatialFilter {
    /// EA's FAST setting and the σ [`crate::analysis::filtered_error`] measures with.
    pub const DEFAULT: SpatialFilter = SpatialFilter::Gaussian { sigma: 1.3435 };
    /// Largest Gaussian σ in pixels (the filter has `2⌈4σ⌉ + 1` taps per axis).
    pub const MAX_SIGMA: f64 = 4096.0;
    /// Largest box size in pixels.
    pub const MAX_SIZE: u32 = 1 << 16;
    /// Largest binomial order.
    pub const MAX_ORDER: u32 = 256;

    /// The 1D weights (summing to 1) along one axis.
    pub(crate) fn taps(&self) -> Vec<f64> {
        match *self {
            SpatialFilter::Gaussian { sigma } => gaussian(sigma),
            SpatialFilter::Box { size } => vec![1.0 / f64::from(size); size as usize],
            SpatialFilter::Binomial { order } => binomial(order),
        }
    }

    /// `None` if the parameters are in range, else the problem.
    pub(crate) fn check(&self) -> Option<String> {
        match *self {
            SpatialFilter::Gaussian { sigma } => check_gaussian(sigma, Self::MAX_SIGMA),
            SpatialFilter::Box { size } => check_box(size, Self::MAX_SIZE),
            SpatialFilter::Binomial { order } => {
                (!(1..=Self::MAX_ORDER).contains(&order)).then(|| {
                    format!(
                        "Binomial order is {order}; it must be in 1..={}",
                        Self::MAX_ORDER
                    )
                })
            }
        }
    }
}

/// The problem with a Gaussian filter's `sigma`, if it is not in `[`[`MIN_GAUSSIAN_SIGMA`]`,
/// max]`.
fn check_gaussian(sigma: f64, max: f64) -> Option<String> {
    (!(sigma >= MIN_GAUSSIAN_SIGMA && sigma <= max)).then(|| {
        format!(
            "Gaussian sigma is {}; it must be in [{MIN_GAUSSIAN_SIGMA:e}, {max}] (below, \
             1/(2σ²) overflows and the filter's weights are not a Gaussian's)",
            crate::spec::compact_number(sigma)
        )
    })
}

/// Smallest Gaussian filter σ, in pixels or frames: below about 7.5·10⁻¹⁵⁵ the weights'
/// `1/(2σ²)` overflows, the centre weight becomes `e^−708` like the others and the filter a
/// three-tap box. Every σ below about 0.2 gives the same filter (the pixel alone) anyway.
pub(crate) const MIN_GAUSSIAN_SIGMA: f64 = 1e-150;

/// The problem with a box filter's `size`, if it is not in `1..=max`.
fn check_box(size: u32, max: u32) -> Option<String> {
    (!(1..=max).contains(&size)).then(|| format!("Box size is {size}; it must be in 1..={max}"))
}

impl fmt::Display for SpatialFilter {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SpatialFilter::Gaussian { sigma } => write!(f, "Gaussian σ {sigma} px"),
            SpatialFilter::Box { size } => write!(f, "box {size}×{size} px"),
            SpatialFilter::Binomial { order } => {
                write!(f, "binomial {0}×{0} px (order {order})", order + 1)
            }
        }
    }
}

/// The temporal filter a mask is optimised for, applied to each pixel's sequence of values.
/// Filters are wrapped over the mask's depth (a mask is read toroidally in time too).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TemporalFilter {
    /// Gaussian of standard deviation `sigma` frames (finite, in `(0,`
    /// [`TemporalFilter::MAX_SIGMA`]`]`), weights `exp(−k²/(2σ²))` for `|k| ≤ ⌈4σ⌉`.
    Gaussian {
        /// Standard deviation in frames.
        sigma: f64,
    },
    /// A moving average over `size` frames (`1..=`[`TemporalFilter::MAX_SIZE`]): Monte Carlo
    /// accumulation over a window.
    Box {
        /// Frames averaged.
        size: u32,
    },
    /// The exponential moving average `hₖ = α vₖ + (1 − α) hₖ₋₁` of TAA, with an unbounded
    /// history: weights `α(1 − α)^k` for `k ≥ 0` frames back, wrapped over the depth. `alpha`
    /// in `[`[`TemporalFilter::MIN_ALPHA`]`, 1]` (1 = no temporal filtering). What
    /// [`crate::analysis::filtered_error`] applies after its first frames.
    Exponential {
        /// Weight of the newest frame.
        alpha: f64,
    },
    /// FAST's exponential filter with a random history length (their β): the history starts
    /// `m` frames back, `m ∈ 1..=depth` drawn with probability `∝ β(1 − β)^(m−1)`, and the
    /// oldest frame keeps the weight the EMA gives its first frame, `(1 − α)^(m−1)` (the
    /// others `α(1 − α)^k`); the pair weights are the expectation over `m` of each history's
    /// autocorrelation. Models TAA whose history gets rejected now and then. `alpha` in
    /// `[`[`TemporalFilter::MIN_ALPHA`]`, 1]`, `beta` in `[`[`TemporalFilter::MIN_BETA`]`, 1]`
    /// (1 = every history one frame long: no temporal filtering). Building it takes
    /// `O(min(depth, 37/β)²)` operations.
    ExponentialHistory {
        /// Weight of the newest frame.
        alpha: f64,
        /// Probability that the history is cut at each older frame.
        beta: f64,
    },
}

impl TemporalFilter {
    /// The EMA weight [`crate::analysis::filtered_error`] measures with.
    pub const DEFAULT: TemporalFilter = TemporalFilter::Exponential { alpha: 0.1 };
    /// Largest Gaussian σ in frames.
    pub const MAX_SIGMA: f64 = 4096.0;
    /// Largest box length in frames.
    pub const MAX_SIZE: u32 = 1 << 16;
    /// Smallest EMA weight.
    pub const MIN_ALPHA: f64 = 1e-3;
    /// Smallest history-cut probability.
    pub const MIN_BETA: f64 = 1e-3;

    /// `None` if the parameters are in range, else the problem.
    pub(crate) fn check(&self) -> Option<String> {
        let unit = |name: &str, value: f64, min: f64| {
            (!(value >= min && value <= 1.0))
                .then(|| format!("{name} is {value}; it must be in [{min}, 1]"))
        };
        match *self {
            TemporalFilter::Gaussian { sigma } => check_gaussian(sigma, Self::MAX_SIGMA),
            TemporalFilter::Box { size } => check_box(size, Self::MAX_SIZE),
            TemporalFilter::Exponential { alpha } => {
                unit("Exponential alpha", alpha, Self::MIN_ALPHA)
            }
            TemporalFilter::ExponentialHistory { alpha, beta } => {
                unit("ExponentialHistory alpha", alpha, Self::MIN_ALPHA)
                    .or_else(|| unit("ExponentialHistory beta", beta, Self::MIN_BETA))
            }
        }
    }

    /// The circular autocorrelation of the filter wrapped over `depth` frames: entry `Δ` is the
    /// pair weight of frames `Δ` apart (mod `depth`); the entries sum to 1.
    pub(crate) fn autocorrelation(&self, depth: u32) -> Vec<f64> {
        let d = depth as usize;
        match *self {
            TemporalFilter::Gaussian { sigma } => {
                circular_autocorrelation(&fold(&gaussian(sigma), d))
            }
            TemporalFilter::Box { size } => {
                circular_autocorrelation(&fold(&vec![1.0 / f64::from(size); size as usize], d))
            }
            TemporalFilter::Exponential { alpha } => exponential(alpha, d),
            TemporalFilter::ExponentialHistory { alpha, beta } => {
                exponential_history(alpha, beta, d)
            }
        }
    }
}

impl fmt::Display for TemporalFilter {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TemporalFilter::Gaussian { sigma } => write!(f, "Gaussian σ {sigma} frames"),
            TemporalFilter::Box { size } => write!(f, "box {size} frames"),
            TemporalFilter::Exponential { alpha } => write!(f, "exponential α {alpha}"),
            TemporalFilter::ExponentialHistory { alpha, beta } => {
                write!(f, "exponential α {alpha}, random history β {beta}")
            }
        }
    }
}

/// How the spatial and temporal filters combine into the pair weights `g` of
/// [`FilterAdaptedSpec`](crate::FilterAdaptedSpec)'s energy, `g_xy` and `g_t` being the
/// filters' autocorrelations.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FilterCombination {
    /// The 3D product filter `g_xy · g_t`: every pair of pixels within the spatial footprint
    /// interacts across frames. FAST's "product"; what a blur followed by an EMA sees.
    Product,
    /// `spatial_weight · g_xy` within a frame plus `(1 − spatial_weight) · g_t` along each pixel's
    /// history, `spatial_weight` in `[0, 1]`. FAST's "separate" (STBN-like).
    Separate {
        /// Share of the spatial term.
        spatial_weight: f64,
    },
}

impl FilterCombination {
    /// `None` if the parameters are in range, else the problem.
    pub(crate) fn check(&self) -> Option<String> {
        match *self {
            FilterCombination::Product => None,
            FilterCombination::Separate { spatial_weight } => (!(0.0..=1.0)
                .contains(&spatial_weight))
            .then(|| format!("Separate spatial_weight is {spatial_weight}; it must be in [0, 1]")),
        }
    }
}

impl fmt::Display for FilterCombination {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FilterCombination::Product => write!(f, "product"),
            FilterCombination::Separate { spatial_weight } => {
                write!(f, "separate (spatial weight {spatial_weight})")
            }
        }
    }
}

/// Normalised Gaussian weights `exp(−i²/(2σ²))`, `|i| ≤ ⌈4σ⌉`.
fn gaussian(sigma: f64) -> Vec<f64> {
    let radius = (4.0 * sigma).ceil() as i64;
    let inv = 1.0 / (2.0 * sigma * sigma);
    let weights: Vec<f64> = (-radius..=radius)
        .map(|i| exp_neg((i * i) as f64 * inv))
        .collect();
    normalised(weights)
}

/// `C(order, k) / 2^order` for `k ∈ 0..=order`, by repeated convolution with `[½, ½]`.
fn binomial(order: u32) -> Vec<f64> {
    let mut weights = vec![1.0];
    for _ in 0..order {
        let mut next = vec![0.0; weights.len() + 1];
        for (k, w) in weights.iter().enumerate() {
            next[k] += 0.5 * w;
            next[k + 1] += 0.5 * w;
        }
        weights = next;
    }
    weights
}

fn normalised(weights: Vec<f64>) -> Vec<f64> {
    let total: f64 = weights.iter().sum();
    weights.into_iter().map(|w| w / total).collect()
}

/// The taps wrapped onto an axis of `len` entries: tap `i` adds to entry `i mod len`.
pub(crate) fn fold(taps: &[f64], len: usize) -> Vec<f64> {
    let mut out = vec![0.0; len];
    for (i, &t) in taps.iter().enumerate() {
        out[i % len] += t;
    }
    out
}

/// `A[Δ] = Σ_i f[i] · f[(i + Δ) mod len]` for `Δ ∈ 0..len`.
pub(crate) fn circular_autocorrelation(f: &[f64]) -> Vec<f64> {
    let len = f.len();
    let nonzero: Vec<(usize, f64)> = f
        .iter()
        .copied()
        .enumerate()
        .filter(|&(_, v)| v != 0.0)
        .collect();
    (0..len)
        .map(|lag| nonzero.iter().map(|&(i, v)| v * f[(i + lag) % len]).sum())
        .collect()
}

/// `r^k` for `k ∈ 0..=n`, by repeated multiplication (the same bits on every platform).
fn powers(r: f64, n: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(n + 1);
    let mut p = 1.0;
    for _ in 0..=n {
        out.push(p);
        p *= r;
    }
    out
}

/// The circular autocorrelation of the EMA weights `α rᵏ` (`r = 1 − α`, `k ≥ 0`) wrapped over
/// `d` frames. The wrapped weights are `ê_j = α r^j / (1 − r^d)`, and summing the two geometric
/// series of `Σ_j ê_j ê_{(j+Δ) mod d}` gives `α² (r^Δ + r^(d−Δ)) / ((1 − r²)(1 − r^d))`.
fn exponential(alpha: f64, d: usize) -> Vec<f64> {
    let r = 1.0 - alpha;
    let pw = powers(r, d);
    let scale = alpha * alpha / ((1.0 - r * r) * (1.0 - pw[d]));
    (0..d).map(|lag| scale * (pw[lag] + pw[d - lag])).collect()
}

/// FAST's EMA with a random history length ([`TemporalFilter::ExponentialHistory`]), wrapped
/// over `d` frames. For a history of `m` frames the weights are `f_i = α rⁱ` for `i < m − 1` and
/// `f_{m−1} = r^(m−1)` (`r = 1 − α`, summing to 1); writing `f_{m−1} = α r^(m−1) + r^m`, its
/// autocorrelation is, for lags `1 ≤ j < m`,
/// `A_m(j) = α² r^j (1 − r^(2(m−j))) / (1 − r²) + α r^(2m−1−j)`, and
/// `A_m(0) = α² (1 − r^(2m)) / (1 − r²) + 2α r^(2m−1) + r^(2m)`. Lags `±j` are wrapped mod `d`
/// and weighted by `P(m) = β(1 − β)^(m−1) / (1 − (1 − β)^d)`; histories whose `P(m)` is below
/// `10⁻¹⁶ · P(1)` are left out.
fn exponential_history(alpha: f64, beta: f64, d: usize) -> Vec<f64> {
    let r = 1.0 - alpha;
    let keep = 1.0 - beta;
    // (1 − β)^(m−1) < 1e-16 beyond this many histories (and never more than d).
    let longest = if keep > 0.0 {
        ((1e-16f64.ln() / keep.ln()).ceil() as usize).clamp(1, d)
    } else {
        1
    };
    let pr = powers(r, 2 * longest + 1);
    let pk = powers(keep, d);
    let norm = beta / (1.0 - pk[d]);
    let geometric = |n: usize| {
        // Σ_{i<n} r^(2i) = (1 − r^(2n)) / (1 − r²); n terms of 1 when r = 1 cannot happen (α > 0).
        (1.0 - pr[2 * n]) / (1.0 - r * r)
    };
    let mut out = vec![0.0; d];
    for m in 1..=longest {
        let p = norm * pk[m - 1];
        let a0 = alpha * alpha * geometric(m) + 2.0 * alpha * pr[2 * m - 1] + pr[2 * m];
        out[0] += p * a0;
        for j in 1..m {
            let a = alpha * alpha * pr[j] * geometric(m - j) + alpha * pr[2 * m - 1 - j];
            out[j % d] += p * a;
            out[(d - j % d) % d] += p * a;
        }
    }
    // The left-out histories' probability mass, restored so the weights sum to 1.
    let total: f64 = out.iter().sum();
    out.iter().map(|w| w / total).collect()
}

/// The filters' autocorrelations on a mask's axes, truncated ([module docs](self)) and
/// normalised to sum 1 per factor: the real pair weights before they become integers.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct PairWeights {
    pub size: (u32, u32, u32),
    /// Kept spatial offsets (canonical `Δx`, `Δy`) and weights, nearest first (then by `Δy`,
    /// `Δx`), each toroidal offset once.
    pub spatial: Vec<(i32, i32, f64)>,
    /// Kept temporal offsets (canonical `Δt`, ascending) and weights.
    pub temporal: Vec<(i32, f64)>,
    pub combination: FilterCombination,
}

impl PairWeights {
    pub(crate) fn new(
        size: (u32, u32, u32),
        spatial: SpatialFilter,
        temporal: TemporalFilter,
        combination: FilterCombination,
        tolerance: f64,
    ) -> PairWeights {
        let (width, height, depth) = size;
        let taps = spatial.taps();
        let ax = circular_autocorrelation(&fold(&taps, width as usize));
        let ay = circular_autocorrelation(&fold(&taps, height as usize));
        let peak = ax[0] * ay[0];
        let mut kept = Vec::new();
        for (ly, &wy) in ay.iter().enumerate() {
            for (lx, &wx) in ax.iter().enumerate() {
                if wx * wy >= tolerance * peak {
                    kept.push((
                        canonical(lx as i64, ax.len() as u32),
                        canonical(ly as i64, ay.len() as u32),
                        wx * wy,
                    ));
                }
            }
        }
        let total: f64 = kept.iter().map(|t| t.2).sum();
        kept.iter_mut().for_each(|t| t.2 /= total);
        kept.sort_by_key(|&(dx, dy, _)| (dx * dx + dy * dy, dy, dx));
        let at = temporal.autocorrelation(depth);
        let mut times: Vec<(i32, f64)> = at
            .iter()
            .enumerate()
            .filter(|&(_, &w)| w >= tolerance * at[0])
            .map(|(l, &w)| (canonical(l as i64, at.len() as u32), w))
            .collect();
        let total: f64 = times.iter().map(|t| t.1).sum();
        times.iter_mut().for_each(|t| t.1 /= total);
        times.sort_by_key(|t| t.0);
        PairWeights {
            size,
            spatial: kept,
            temporal: times,
            combination,
        }
    }

    /// The spatial weights as integers summing to about `scale` (zeros dropped).
    fn spatial_integers(&self, scale: f64) -> Vec<(i32, i32, i64)> {
        self.spatial
            .iter()
            .map(|&(dx, dy, w)| (dx, dy, (w * scale).round() as i64))
            .filter(|t| t.2 != 0)
            .collect()
    }

    /// The temporal weights as integers summing to about `scale` (zeros dropped).
    fn temporal_integers(&self, scale: f64) -> Vec<(i32, i64)> {
        self.temporal
            .iter()
            .map(|&(dz, w)| (dz, (w * scale).round() as i64))
            .filter(|t| t.1 != 0)
            .collect()
    }

    /// `(spatial scale, temporal scale)` of each term for a nominal total `2^bits`: the product's
    /// factors split the bits, `spatial_bits` going to the spatial factor; the separate sum's
    /// spatial term keeps all of them for its share `w`, the temporal term likewise.
    fn terms(&self, bits: u32, spatial_bits: u32) -> Vec<IntegerTerm> {
        let pow = |b: u32| 2f64.powi(b as i32);
        match self.combination {
            FilterCombination::Product => vec![(
                self.spatial_integers(pow(spatial_bits)),
                self.temporal_integers(pow(bits - spatial_bits)),
            )],
            FilterCombination::Separate { spatial_weight } => {
                let mut terms = Vec::new();
                // Spatial term: S · 2^(bits − spatial_bits) at Δt = 0 only; temporal term:
                // 2^spatial_bits at the origin only, times T.
                if spatial_weight > 0.0 {
                    terms.push((
                        self.spatial_integers(spatial_weight * pow(spatial_bits)),
                        vec![(0, 1i64 << (bits - spatial_bits))],
                    ));
                }
                if spatial_weight < 1.0 {
                    terms.push((
                        vec![(0, 0, 1i64 << spatial_bits)],
                        self.temporal_integers((1.0 - spatial_weight) * pow(bits - spatial_bits)),
                    ));
                }
                terms
            }
        }
    }
}

/// One separable term as integers: spatial taps `(Δx, Δy, S)` and temporal taps `(Δt, T)`.
type IntegerTerm = (Vec<(i32, i32, i64)>, Vec<(i32, i64)>);

/// The toroidal pair weights of pixels of one frame, `Σ_terms S(Δx, Δy) · T(0)`, for lookups by
/// any offset.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct SameFrame {
    width: u32,
    height: u32,
    reach: (u32, u32),
    /// Row-major from `(−reach.0, −reach.1)`.
    weights: Vec<i64>,
}

impl SameFrame {
    fn new(width: u32, height: u32, taps: impl Iterator<Item = (i32, i32, i64)> + Clone) -> Self {
        let reach = taps.clone().fold((0u32, 0u32), |(rx, ry), (dx, dy, _)| {
            (rx.max(dx.unsigned_abs()), ry.max(dy.unsigned_abs()))
        });
        let side = 2 * reach.0 as usize + 1;
        let mut weights = vec![0i64; side * (2 * reach.1 as usize + 1)];
        for (dx, dy, g) in taps {
            weights[(dy + reach.1 as i32) as usize * side + (dx + reach.0 as i32) as usize] += g;
        }
        SameFrame {
            width,
            height,
            reach,
            weights,
        }
    }

    /// The weight of two pixels of one frame `(dx, dy)` apart (any integers).
    pub(crate) fn get(&self, dx: i64, dy: i64) -> i64 {
        let dx = canonical(dx, self.width);
        let dy = canonical(dy, self.height);
        let (rx, ry) = (self.reach.0 as i32, self.reach.1 as i32);
        if dx.abs() > rx || dy.abs() > ry {
            return 0;
        }
        self.weights[((dy + ry) * (2 * rx + 1) + dx + rx) as usize]
    }
}

/// One row of a spatial pattern: offsets `(dx0 + i, dy)` with integer weights `weights[i]`.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Row {
    pub dy: i32,
    pub dx0: i32,
    /// Integers (possibly 0), exact in `f64`.
    pub weights: Vec<f64>,
}

/// One separable term `S(Δxy) · T(Δt)` of a [`Kernel`].
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Term {
    /// The spatial factor, rows of canonical offsets (each toroidal offset once).
    pub rows: Vec<Row>,
    /// The temporal factor: canonical `Δt` and integer weight.
    pub temporal: Vec<(i32, f64)>,
}

/// The integer pair weights `g(Δx, Δy, Δt) = Σ_terms S(Δx, Δy) · T(Δt)` of the product value
/// kernel, laid out for splatting into `φ` ([module docs](self)).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Kernel {
    pub width: u32,
    pub height: u32,
    pub depth: u32,
    pub terms: Vec<Term>,
    /// Largest `|dx|`, `|dy|` of any spatial offset.
    pub reach: (u32, u32),
    pub same_frame: SameFrame,
    /// `Σ g` over every offset, the origin included.
    pub total: i64,
    /// The real weights are `g / scale`.
    pub scale: f64,
}

impl Kernel {
    /// The kernel of `weights` for integer values of magnitude up to `max_value`: scaled so that
    /// `max_value · Σ g ≤ 2⁵¹`.
    pub(crate) fn new(weights: &PairWeights, max_value: u64) -> Kernel {
        let (width, height, depth) = weights.size;
        let value_bits = 64 - max_value.max(1).leading_zeros();
        let bits = 51 - value_bits;
        let terms: Vec<Term> = weights
            .terms(bits, bits / 2)
            .into_iter()
            .map(|(spatial, temporal)| Term {
                rows: rows(&spatial),
                temporal: temporal.iter().map(|&(dz, t)| (dz, t as f64)).collect(),
            })
            .collect();
        let reach = reach(terms.iter().flat_map(|t| {
            t.rows
                .iter()
                .flat_map(|r| [(r.dx0, r.dy), (r.dx0 + r.weights.len() as i32 - 1, r.dy)])
        }));
        let mut flat = Vec::new();
        let mut total = 0i64;
        for term in &terms {
            let t_sum: i64 = term.temporal.iter().map(|&(_, t)| t as i64).sum();
            let t0 = term
                .temporal
                .iter()
                .find(|t| t.0 == 0)
                .map_or(0, |t| t.1 as i64);
            for row in &term.rows {
                for (i, &s) in row.weights.iter().enumerate() {
                    flat.push((row.dx0 + i as i32, row.dy, s as i64 * t0));
                    total += s as i64 * t_sum;
                }
            }
        }
        Kernel {
            width,
            height,
            depth,
            terms,
            reach,
            same_frame: SameFrame::new(width, height, flat.into_iter()),
            total,
            scale: 2f64.powi(bits as i32),
        }
    }

    /// Every nonzero weight: `((Δx, Δy, Δt), g)` with canonical offsets, sorted, each once.
    #[cfg(test)]
    pub fn weights(&self) -> Vec<((i32, i32, i32), i64)> {
        let mut all: Vec<((i32, i32, i32), i64)> = Vec::new();
        for term in &self.terms {
            for row in &term.rows {
                for (i, &s) in row.weights.iter().enumerate() {
                    for &(dz, t) in &term.temporal {
                        if s != 0.0 && t != 0.0 {
                            all.push(((row.dx0 + i as i32, row.dy, dz), s as i64 * t as i64));
                        }
                    }
                }
            }
        }
        merge(all)
    }
}

/// Sorts `(offset, g)` pairs and adds the weights of equal offsets.
fn merge(mut all: Vec<((i32, i32, i32), i64)>) -> Vec<((i32, i32, i32), i64)> {
    all.sort_unstable();
    let mut merged: Vec<((i32, i32, i32), i64)> = Vec::with_capacity(all.len());
    for (offset, g) in all {
        match merged.last_mut() {
            Some((last, sum)) if *last == offset => *sum += g,
            _ => merged.push((offset, g)),
        }
    }
    merged
}

/// Largest `|dx|` and `|dy|` of `offsets`.
fn reach(offsets: impl Iterator<Item = (i32, i32)>) -> (u32, u32) {
    offsets.fold((0, 0), |(rx, ry), (dx, dy)| {
        (rx.max(dx.unsigned_abs()), ry.max(dy.unsigned_abs()))
    })
}

/// Spatial taps as rows of contiguous `Δx` runs (gaps filled with zeros).
fn rows(taps: &[(i32, i32, i64)]) -> Vec<Row> {
    let mut sorted = taps.to_vec();
    sorted.sort_unstable_by_key(|&(dx, dy, _)| (dy, dx));
    let mut out: Vec<Row> = Vec::new();
    for (dx, dy, w) in sorted {
        match out.last_mut() {
            Some(row) if row.dy == dy => {
                let end = row.dx0 + row.weights.len() as i32;
                row.weights
                    .extend(std::iter::repeat_n(0.0, (dx - end) as usize));
                row.weights.push(w as f64);
            }
            _ => out.push(Row {
                dy,
                dx0: dx,
                weights: vec![w as f64],
            }),
        }
    }
    out
}

/// One separable term of a [`ScanKernel`].
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ScanTerm {
    /// Spatial taps `(Δx, Δy, S)`, nearest first.
    pub spatial: Vec<(i32, i32, i64)>,
    /// `Δt` of the first temporal weight.
    pub t0: i32,
    /// Temporal weights for `Δt = t0, t0 + 1, …` (zeros inside the window kept), each at most
    /// `2^`[`ScanKernel::TEMPORAL_BITS`] and summing to at most that.
    pub temporal: Vec<i16>,
    /// `Σ temporal`.
    pub temporal_sum: i64,
}

/// The integer pair weights of the distance value kernel, laid out for scanning footprints:
/// per term, spatial taps `S` (`i64`, nominal total `2^`[`ScanKernel::SPATIAL_BITS`]) and a
/// window of temporal weights `T` (`i16`, nominal total `2^`[`ScanKernel::TEMPORAL_BITS`]), so
/// that `Σ_t T · v` over `i16` values of magnitude below 2¹³ is an exact `i32` and every full sum
/// an exact `i64` below 2⁵⁰.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ScanKernel {
    pub width: u32,
    pub height: u32,
    pub depth: u32,
    pub terms: Vec<ScanTerm>,
    pub reach: (u32, u32),
    pub same_frame: SameFrame,
    /// `Σ g` over every offset, the origin included.
    pub total: i64,
}

impl ScanKernel {
    /// Nominal total of the spatial weights (`log2`).
    pub const SPATIAL_BITS: u32 = 22;
    /// Nominal total of the temporal weights (`log2`).
    pub const TEMPORAL_BITS: u32 = 14;

    pub(crate) fn new(weights: &PairWeights) -> ScanKernel {
        let (width, height, depth) = weights.size;
        let bits = Self::SPATIAL_BITS + Self::TEMPORAL_BITS;
        let terms: Vec<ScanTerm> = weights
            .terms(bits, Self::SPATIAL_BITS)
            .into_iter()
            .map(|(spatial, temporal)| {
                let t0 = temporal.first().map_or(0, |t| t.0);
                let t1 = temporal.last().map_or(0, |t| t.0);
                let mut window = vec![0i16; (t1 - t0 + 1) as usize];
                for &(dz, t) in &temporal {
                    window[(dz - t0) as usize] =
                        i16::try_from(t).expect("temporal weights fit i16");
                }
                ScanTerm {
                    spatial,
                    t0,
                    temporal_sum: temporal.iter().map(|t| t.1).sum(),
                    temporal: window,
                }
            })
            .collect();
        let reach = reach(
            terms
                .iter()
                .flat_map(|t| t.spatial.iter().map(|s| (s.0, s.1))),
        );
        let mut flat = Vec::new();
        let mut total = 0;
        for term in &terms {
            let t0 = usize::try_from(-term.t0)
                .ok()
                .and_then(|i| term.temporal.get(i))
                .map_or(0, |&t| i64::from(t));
            for &(dx, dy, s) in &term.spatial {
                flat.push((dx, dy, s * t0));
                total += s * term.temporal_sum;
            }
        }
        ScanKernel {
            width,
            height,
            depth,
            terms,
            reach,
            same_frame: SameFrame::new(width, height, flat.into_iter()),
            total,
        }
    }

    /// The real weights are `g / scale`.
    pub fn scale(&self) -> f64 {
        2f64.powi((Self::SPATIAL_BITS + Self::TEMPORAL_BITS) as i32)
    }

    /// Every nonzero weight: `((Δx, Δy, Δt), g)` with canonical offsets, sorted, each once.
    pub fn weights(&self) -> Vec<((i32, i32, i32), i64)> {
        let mut all = Vec::new();
        for term in &self.terms {
            for &(dx, dy, s) in &term.spatial {
                for (k, &t) in term.temporal.iter().enumerate() {
                    if t != 0 {
                        let dz = canonical(i64::from(term.t0) + k as i64, self.depth);
                        all.push(((dx, dy, dz), s * i64::from(t)));
                    }
                }
            }
        }
        merge(all)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The non-wrapped autocorrelation of `f`, lag `j ≥ 0`.
    fn autocorrelation(f: &[f64], j: usize) -> f64 {
        (0..f.len().saturating_sub(j))
            .map(|i| f[i] * f[i + j])
            .sum()
    }

    #[test]
    fn exponential_closed_form_matches_the_wrapped_sum() {
        for (alpha, d) in [(0.1, 64), (0.5, 7), (1.0, 5), (0.3, 1), (0.02, 16)] {
            let r: f64 = 1.0 - alpha;
            // Wrap 200 periods of the infinite EMA by brute force.
            let taps: Vec<f64> = (0..200 * d).map(|k| alpha * r.powi(k as i32)).collect();
            let brute = circular_autocorrelation(&fold(&taps, d));
            let closed = exponential(alpha, d);
            for (b, c) in brute.iter().zip(&closed) {
                assert!(
                    (b - c).abs() < 1e-12,
                    "α {alpha} d {d}: {brute:?} {closed:?}"
                );
            }
            assert!((closed.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn history_closed_form_matches_the_brute_force_mixture() {
        for (alpha, beta, d) in [
            (0.1f64, 0.1f64, 64),
            (0.4, 0.25, 9),
            (0.2, 1.0, 6),
            (1.0, 0.5, 4),
        ] {
            let r: f64 = 1.0 - alpha;
            let mut brute = vec![0.0; d];
            let norm: f64 = (1..=d)
                .map(|m| beta * (1.0 - beta).powi(m as i32 - 1))
                .sum();
            for m in 1..=d {
                let p = beta * (1.0 - beta).powi(m as i32 - 1) / norm;
                let f: Vec<f64> = (0..m)
                    .map(|i| {
                        if i + 1 < m {
                            alpha * r.powi(i as i32)
                        } else {
                            r.powi(i as i32)
                        }
                    })
                    .collect();
                assert!((f.iter().sum::<f64>() - 1.0).abs() < 1e-12);
                for j in 0..m {
                    let a = autocorrelation(&f, j);
                    brute[j % d] += p * a;
                    if j > 0 {
                        brute[(d - j % d) % d] += p * a;
                    }
                }
            }
            let closed = exponential_history(alpha, beta, d);
            for (b, c) in brute.iter().zip(&closed) {
                assert!(
                    (b - c).abs() < 1e-12,
                    "α {alpha} β {beta}: {brute:?} {closed:?}"
                );
            }
        }
    }

    #[test]
    fn binomial_and_box_weights() {
        assert_eq!(binomial(2), vec![0.25, 0.5, 0.25]);
        assert_eq!(binomial(1), vec![0.5, 0.5]);
        // The box's autocorrelation is a triangle.
        let a = circular_autocorrelation(&fold(&[1.0 / 3.0; 3], 16));
        assert!((a[0] - 3.0 / 9.0).abs() < 1e-15 && (a[2] - 1.0 / 9.0).abs() < 1e-15);
        assert!((a[15] - 2.0 / 9.0).abs() < 1e-15 && a[3] == 0.0);
    }

    #[test]
    fn kernels_are_symmetric_and_sum_to_their_scale() {
        for combination in [
            FilterCombination::Product,
            FilterCombination::Separate {
                spatial_weight: 0.3,
            },
        ] {
            for size in [(16, 16, 8), (5, 3, 2), (1, 1, 1), (64, 32, 16)] {
                let pair = PairWeights::new(
                    size,
                    SpatialFilter::DEFAULT,
                    TemporalFilter::DEFAULT,
                    combination,
                    5e-3,
                );
                let kernel = Kernel::new(&pair, 1 << 14);
                let scan = ScanKernel::new(&pair);
                for (weights, total, scale, same) in [
                    (
                        kernel.weights(),
                        kernel.total,
                        kernel.scale,
                        &kernel.same_frame,
                    ),
                    (scan.weights(), scan.total, scan.scale(), &scan.same_frame),
                ] {
                    let lookup = |o: (i32, i32, i32)| {
                        weights
                            .binary_search_by_key(&o, |w| w.0)
                            .map_or(0, |i| weights[i].1)
                    };
                    let canon = |v: i32, n: u32| canonical(i64::from(v), n);
                    for &((dx, dy, dz), g) in &weights {
                        let mirror = (canon(-dx, size.0), canon(-dy, size.1), canon(-dz, size.2));
                        assert_eq!(
                            lookup(mirror),
                            g,
                            "{size:?} {combination:?} ({dx}, {dy}, {dz})"
                        );
                        if dz == 0 {
                            assert_eq!(same.get(i64::from(dx), i64::from(dy)), g);
                        }
                    }
                    let sum: i64 = weights.iter().map(|w| w.1).sum();
                    assert_eq!(sum, total);
                    let ratio = total as f64 / scale;
                    assert!((ratio - 1.0).abs() < 1e-3, "{size:?} {ratio}");
                }
                assert!((1u64 << 14) as f64 * kernel.total as f64 <= 2f64.powi(51) * 1.001);
            }
        }
    }
}
