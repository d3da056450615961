//! Filter-adapted masks, after EA's FAST (*Filter-Adapted Spatiotemporal Sampling for Real-Time
//! Rendering*, 2024): masks optimised directly for the filter that will consume them, e.g. a
//! spatial Gaussian blur followed by a TAA-style exponential moving average, instead of for
//! STBN's separate spatial and temporal Gaussians. [`FilterAdaptedSpec`] describes the energy
//! and the generation.

mod filters;
pub(crate) mod optimizer;
#[cfg(test)]
mod tests;

pub use filters::{FilterCombination, SpatialFilter, TemporalFilter};

use std::fmt;

use rand::seq::SliceRandom;
use rayon::prelude::*;

use crate::rng::{self, keyed_rng};
use crate::space::SampleSpace;
use crate::spec::{MaskSpec, SpecError};
use crate::trace::{EnergyTrace, TracePoint};
use crate::vector::{InitialArrangement, arranged_start};
use crate::volume::Volume;
use crate::{Observer, VectorVolume, generate};
use filters::{Kernel, PairWeights, ScanKernel};
use optimizer::{CORE_RADIUS_SQUARED, Energy, Optimizer};

/// How two values interact in the energy of a filter-adapted mask.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ValueKernel {
    /// `−|a − b|` (FAST's kernel for real values): the expected filtered error of the mask
    /// thresholded at a uniform random level. Vector masks sum it over the ranks of projections
    /// onto a few directions ([`FilterAdaptedVectorSpec`]). Each proposal scans both pixels'
    /// footprints (once per direction).
    Distance,
    /// `a·b` of centred values (dot product for vectors): the squared filtered error of the
    /// values themselves (linear integrands). Any space; `O(1)` per proposal. From the same STBN
    /// start it raises the filtered error of thresholded scalar masks (BENCHMARKS.md).
    Product,
}

impl ValueKernel {
    /// A short lowercase name: `distance` or `product`.
    pub fn name(self) -> &'static str {
        match self {
            ValueKernel::Distance => "distance",
            ValueKernel::Product => "product",
        }
    }
}

/// Everything that determines a scalar filter-adapted mask, bit for bit: equal specs give
/// identical masks on every machine and for every thread count
/// ([`generate_filter_adapted`](crate::generate_filter_adapted)). [`FilterAdaptedSpec::with_space`]
/// makes the spec of a vector mask.
///
/// The mask is optimised after EA's FAST (*Filter-Adapted Spatiotemporal Sampling for Real-Time
/// Rendering*, 2024) for the filter that will consume it, e.g. a spatial Gaussian blur followed by
/// a TAA-style exponential moving average: swaps within frames lower the expected error, after
/// the filters, of the mask thresholded at a uniform random level.
///
/// # The energy
///
/// A renderer that thresholds a mask (`[v < t]`, a stochastic decision) and then filters the
/// result with `f` sees, at each threshold, the error `Σ_p (Σ_q f(p − q)([v_q < t] − m_t))²`.
/// Expanding the square gives pair weights `g = f ⋆ f`, the filter's autocorrelation
/// ([`SpatialFilter`], [`TemporalFilter`], [`FilterCombination`]; wrapped toroidally onto the
/// mask's axes, each factor truncated at [`FilterAdaptedSpec::kernel_tolerance`] and scaled to
/// integers). Averaged over a uniform threshold `t`, the
/// pair term is `E_t[([a < t] − t)([b < t] − t)] = 1/3 − max(a, b) + (a² + b²)/2`, in which only
/// `−|a − b| / 2` couples the two values: swaps within a frame keep each frame's multiset, so the
/// rest is constant. So the expected filtered error of thresholded masks is, up to constants,
///
/// ```text
/// E = Σ_{x ≠ y} g(x − y) · (−|v(x) − v(y)|)
/// ```
///
/// which is FAST's energy for real values ([`ValueKernel::Distance`], the default).
/// [`crate::analysis::filtered_error`] measures exactly this error (with 256 stratified
/// thresholds), so with its Gaussian and EMA as the filters the optimiser minimises the expected
/// value of the project's own metric — with one difference: the generator wraps the EMA around
/// the mask's frames (a mask is read toroidally in time), while the metric starts its EMA at
/// frame 0, whose weight `(1 − α)^(frames − 1)` at the last frame is negligible for dozens of
/// frames but not for a handful. Vector masks use the same kernel on the ranks of their
/// projections onto a few directions ([`FilterAdaptedVectorSpec`]).
///
/// [`ValueKernel::Product`] instead uses `u(x)·u(y)` (centred values, dot product for vectors):
/// the squared error of the filtered values themselves, i.e. of linear integrands. Its deltas
/// cost `O(1)` instead of a footprint scan, but it is not the thresholded error: from the same
/// STBN start it *raises* the filtered error of scalar masks (BENCHMARKS.md).
///
/// # Generation
///
/// Each frame holds an exact stratified set — scalar frames a permutation of
/// `(i + 0.5) / (W·H)`, like every [`Volume`]; vector frames the stratified set of the
/// [`SampleSpace`] that a [`crate::VectorSpec`] with the same seed starts from — arranged as
/// [`InitialArrangement`] says (by default from the scalar STBN mask of the same size and seed).
/// A greedy optimiser then proposes swaps within frames and keeps those that lower `E`, with
/// exact integer deltas, for [`FilterAdaptedSpec::swaps_per_pixel`] proposals per pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct FilterAdaptedSpec {
    /// Pixels per row, `1..=`[`MaskSpec::MAX_AXIS`].
    pub width: u32,
    /// Rows per frame, `1..=`[`MaskSpec::MAX_AXIS`].
    pub height: u32,
    /// Frames, `1..=`[`MaskSpec::MAX_AXIS`].
    pub depth: u32,
    /// Seed of the initial arrangement (and of the scalar STBN mask it may start from) and of
    /// the swap proposals.
    pub seed: u64,
    /// The spatial filter the mask is optimised for. Default [`SpatialFilter::DEFAULT`]
    /// (Gaussian σ 1.3435 px, EA's setting).
    pub spatial_filter: SpatialFilter,
    /// The temporal filter. Default [`TemporalFilter::DEFAULT`] (EMA α 0.1).
    pub temporal_filter: TemporalFilter,
    /// How the two combine. Default [`FilterCombination::Product`].
    pub combination: FilterCombination,
    /// The value kernel. Default [`ValueKernel::Distance`].
    pub value_kernel: ValueKernel,
    /// Optimisation budget: swaps proposed per pixel, finite, in
    /// `0..=`[`FilterAdaptedSpec::MAX_SWAPS_PER_PIXEL`]. Each whole unit is one pass in which
    /// every pixel of every frame proposes one swap; a fractional part runs a partial last pass.
    /// 0 keeps the initial arrangement.
    pub swaps_per_pixel: f64,
    /// Each factor of the pair weights is truncated where it falls below this fraction of its
    /// peak, in `(0, 1)`. The default 5·10⁻³ keeps, for the default filters, spatial offsets up to
    /// 6 px (121 offsets) and every frame of a 64-frame mask.
    pub kernel_tolerance: f64,
    /// How each frame's values start. Default [`InitialArrangement::ScalarStbn`]: scalar masks
    /// start as the STBN mask of the same size and seed, vector masks as [`crate::VectorSpec`]
    /// arranges them.
    pub initial_arrangement: InitialArrangement,
}

impl FilterAdaptedSpec {
    /// Default budget in swaps proposed per pixel (BENCHMARKS.md has the curve).
    pub const DEFAULT_SWAPS_PER_PIXEL: f64 = 6.0;
    /// Largest σ of a Gaussian spatial filter, in lengths of the larger of `width` and `height`
    /// (but never below the default filter's 1.3435, so that slices of 2 pixels keep it).
    ///
    /// The filter's autocorrelation, which weighs the pairs, is a Gaussian of `√2 σ`; folded
    /// onto an axis of `n` pixels it is its mean plus harmonics, the first of relative amplitude
    /// `2·exp(−4π²σ²/n²)`: 1.0·10⁻⁴ at `σ = n/2`, 4·10⁻⁷ at `0.625 n`, where the integer weights
    /// (a total of 2²² over the slice: 1.5·10⁻⁵ of their mean per unit on 8×8) no longer resolve
    /// it. Beyond half the slice the pair weights are flat and every arrangement of a frame has
    /// the same energy (8×8 and 16×16 kept no swap from 0.625 n on,
    /// `tests/sigma_range.rs`). A temporal Gaussian needs no such bound: flat over time, the
    /// spatial filter still orders each frame.
    pub const MAX_GAUSSIAN_SIGMA_PER_LENGTH: f64 = 0.5;
    /// Default truncation of the pair weights.
    pub const DEFAULT_KERNEL_TOLERANCE: f64 = 5e-3;
    /// Largest budget accepted.
    pub const MAX_SWAPS_PER_PIXEL: f64 = 10_000.0;

    /// A scalar spec with the default filters (EA's Gaussian σ 1.3435 × EMA α 0.1 product),
    /// budget and tolerance, starting from STBN.
    pub fn new(width: u32, height: u32, depth: u32, seed: u64) -> FilterAdaptedSpec {
        FilterAdaptedSpec {
            width,
            height,
            depth,
            seed,
            spatial_filter: SpatialFilter::DEFAULT,
            temporal_filter: TemporalFilter::DEFAULT,
            combination: FilterCombination::Product,
            value_kernel: ValueKernel::Distance,
            swaps_per_pixel: Self::DEFAULT_SWAPS_PER_PIXEL,
            kernel_tolerance: Self::DEFAULT_KERNEL_TOLERANCE,
            initial_arrangement: InitialArrangement::ScalarStbn,
        }
    }

    /// The same spec with another budget.
    pub fn with_swaps_per_pixel(mut self, swaps_per_pixel: f64) -> FilterAdaptedSpec {
        self.swaps_per_pixel = swaps_per_pixel;
        self
    }

    /// The same spec with other filters.
    pub fn with_filters(
        mut self,
        spatial: SpatialFilter,
        temporal: TemporalFilter,
        combination: FilterCombination,
    ) -> FilterAdaptedSpec {
        self.spatial_filter = spatial;
        self.temporal_filter = temporal;
        self.combination = combination;
        self
    }

    /// The same spec with another value kernel.
    pub fn with_value_kernel(mut self, value_kernel: ValueKernel) -> FilterAdaptedSpec {
        self.value_kernel = value_kernel;
        self
    }

    /// The spec of the vector mask of `space` with this spec's size, seed, filters, kernel,
    /// budget and start.
    pub fn with_space(self, space: SampleSpace) -> FilterAdaptedVectorSpec {
        FilterAdaptedVectorSpec {
            filter_adapted: self,
            space,
        }
    }

    /// Number of pixels of one frame.
    pub fn slice_pixels(&self) -> u64 {
        u64::from(self.width) * u64::from(self.height)
    }

    /// Number of pixels of the volume.
    pub fn pixels(&self) -> u64 {
        self.slice_pixels() * u64::from(self.depth)
    }

    /// Peak generator memory per pixel in bytes for values of `dims` components: the value index
    /// (4); for the distance energy 2 bytes per level channel (one per projection direction,
    /// `dims²` of them) plus the tiles' copies, about twice that again; for the product energy
    /// the integer components (4 each) and field (8 each, plus 16 while it is computed from
    /// scratch); before all that the scalar STBN mask's generator
    /// ([`MaskSpec::BYTES_PER_PIXEL`]) when the arrangement needs one, or one per parameter at
    /// once for [`InitialArrangement::ScalarStbnPerAxis`].
    fn bytes_per_pixel(&self, dims: usize) -> u64 {
        let dims = dims as u64;
        let optimiser = match self.value_kernel {
            ValueKernel::Distance => 4 + 6 * dims * dims,
            ValueKernel::Product => 4 + 12 * dims + 16,
        };
        match self.initial_arrangement {
            InitialArrangement::ScalarStbn => optimiser.max(MaskSpec::BYTES_PER_PIXEL + 4),
            // One scalar generator per parameter at once; a space has at most `dims` parameters.
            InitialArrangement::ScalarStbnPerAxis => {
                optimiser.max(MaskSpec::BYTES_PER_PIXEL * dims + 4)
            }
            InitialArrangement::Random => optimiser,
        }
    }

    /// Checks every field against its documented range for a scalar mask. Sizes are checked
    /// before anything is allocated, and an oversized request reports the memory it would take.
    pub fn validate(&self) -> Result<(), FilterAdaptedSpecError> {
        self.validate_dims(1)
    }

    fn validate_dims(&self, dims: usize) -> Result<(), FilterAdaptedSpecError> {
        for (field, value) in [
            ("width", self.width),
            ("height", self.height),
            ("depth", self.depth),
        ] {
            if value == 0 || value > MaskSpec::MAX_AXIS {
                return Err(SpecError::AxisOutOfRange { field, value }.into());
            }
        }
        if self.slice_pixels() > MaskSpec::MAX_SLICE_PIXELS || self.pixels() > MaskSpec::MAX_PIXELS
        {
            return Err(SpecError::TooLarge {
                width: self.width,
                height: self.height,
                depth: self.depth,
                bytes_needed: self.pixels() * self.bytes_per_pixel(dims),
            }
            .into());
        }
        let filters = [
            ("spatial_filter", self.spatial_filter.check()),
            ("temporal_filter", self.temporal_filter.check()),
            ("filter_combination", self.combination.check()),
        ];
        for (field, problem) in filters {
            if let Some(message) = problem {
                return Err(FilterAdaptedSpecError::Filter { field, message });
            }
        }
        let slice_length = self.width.max(self.height);
        let default_sigma = match SpatialFilter::DEFAULT {
            SpatialFilter::Gaussian { sigma } => sigma,
            _ => 0.0,
        };
        let max =
            (Self::MAX_GAUSSIAN_SIGMA_PER_LENGTH * f64::from(slice_length)).max(default_sigma);
        // Spatial filters that fold flat over the wrapped slice: a Gaussian wider than `max`, a
        // binomial wider than the same bound (its σ is √order / 2), a box a whole number of
        // periods long on both axes. A slice of one pixel has nothing to arrange.
        let flat = match self.spatial_filter {
            _ if slice_length < 2 => None,
            SpatialFilter::Gaussian { sigma } if sigma > max => Some(format!(
                "Gaussian sigma is {}; for this mask it must be in [{:e}, {max}] (half the \
                 slice's {slice_length} pixels, or the default {default_sigma}): a wider \
                 Gaussian folds flat over the wrapped slice, and no arrangement of a frame \
                 filters better than another",
                crate::spec::compact_number(sigma),
                filters::MIN_GAUSSIAN_SIGMA
            )),
            SpatialFilter::Binomial { order }
                if u64::from(order) > Self::max_binomial_order(slice_length) =>
            {
                Some(format!(
                    "Binomial order is {order}; for this mask it must be in 1..={} (σ = √order / 2 \
                     up to half the slice's {slice_length} pixels): a wider binomial folds flat \
                     over the wrapped slice, and no arrangement of a frame filters better than \
                     another",
                    Self::max_binomial_order(slice_length)
                ))
            }
            SpatialFilter::Box { size } if size % self.width == 0 && size % self.height == 0 => {
                Some(format!(
                    "Box size is {size}; for this mask it must be in 1..={} and not a multiple \
                     of both the slice's width {} and height {}: such a box folds flat over the \
                     wrapped slice, and no arrangement of a frame filters better than another",
                    SpatialFilter::MAX_SIZE,
                    self.width,
                    self.height
                ))
            }
            _ => None,
        };
        if let Some(message) = flat {
            return Err(FilterAdaptedSpecError::Filter {
                field: "spatial_filter",
                message,
            });
        }
        if !(self.kernel_tolerance > 0.0 && self.kernel_tolerance < 1.0) {
            return Err(SpecError::InvalidTolerance(self.kernel_tolerance).into());
        }
        if !(0.0..=Self::MAX_SWAPS_PER_PIXEL).contains(&self.swaps_per_pixel) {
            return Err(FilterAdaptedSpecError::InvalidBudget(self.swaps_per_pixel));
        }
        Ok(())
    }

    /// The largest binomial order whose σ, `√order / 2`, is within
    /// [`MAX_GAUSSIAN_SIGMA_PER_LENGTH`](Self::MAX_GAUSSIAN_SIGMA_PER_LENGTH) of a slice of
    /// `slice_length` pixels: `slice_length²`.
    fn max_binomial_order(slice_length: u32) -> u64 {
        let sigma = Self::MAX_GAUSSIAN_SIGMA_PER_LENGTH * f64::from(slice_length);
        (4.0 * sigma * sigma) as u64
    }

    /// The truncated pair weights of the spec's filters on its axes.
    fn pair_weights(&self) -> PairWeights {
        PairWeights::new(
            (self.width, self.height, self.depth),
            self.spatial_filter,
            self.temporal_filter,
            self.combination,
            self.kernel_tolerance,
        )
    }

    /// Distinct `(Δx, Δy, Δt)` offsets with a nonzero pair weight (the origin included): the
    /// footprint a distance proposal scans twice. Panics if the spec is invalid.
    pub fn kernel_taps(&self) -> usize {
        self.validate().expect("a valid spec");
        ScanKernel::new(&self.pair_weights()).weights().len()
    }
}

/// The spec of a filter-adapted vector mask: a [`FilterAdaptedSpec`] and the space its values
/// come from ([`generate_filter_adapted_vector`](crate::generate_filter_adapted_vector)). Equal
/// specs give identical masks for every thread count.
///
/// Each frame holds the stratified set of `space` that a [`crate::VectorSpec`] of the same size,
/// seed and start begins with, and keeps it exactly. With [`ValueKernel::Distance`] each value is
/// projected onto fixed directions (the axes and, for two or more components, the diagonals
/// `(e_i ± e_j)/√2` of every pair of axes: 4 directions in 2D, 9 in 3D, 16 in 4D) and the value
/// kernel is `−Σ_u |r_u(a) − r_u(b)|`, with `r_u` the rank of the projection onto `u` within its
/// frame (as a level below 2¹⁴, like scalar ranks): per direction, the expected error of a
/// half-space threshold `⟨v, u⟩ < t` that holds a uniform random fraction of the frame, as the
/// scalar energy is for `v < t`. Summed over directions it approximates FAST's Euclidean kernel
/// (all half-spaces) with exact integer scans, one per direction per proposal.
#[derive(Clone, Debug, PartialEq)]
pub struct FilterAdaptedVectorSpec {
    /// Size, seed, filters, value kernel, budget, tolerance and start.
    pub filter_adapted: FilterAdaptedSpec,
    /// What each pixel holds.
    pub space: SampleSpace,
}

impl FilterAdaptedVectorSpec {
    /// Checks the space (`SampleSpace::Vec` needs `dims` in `1..=4`) and every field of
    /// [`FilterAdaptedVectorSpec::filter_adapted`] against its documented range. Sizes are
    /// checked before anything is allocated, and an oversized request reports the memory it
    /// would take.
    pub fn validate(&self) -> Result<(), FilterAdaptedSpecError> {
        if let SampleSpace::Vec { dims } = self.space
            && !self.space.is_valid()
        {
            return Err(FilterAdaptedSpecError::InvalidDims(dims));
        }
        self.filter_adapted.validate_dims(self.space.dims())
    }
}

/// A [`FilterAdaptedSpec`] field out of range, or a space the generator does not take. `Display`
/// names the field.
#[derive(Clone, Debug, PartialEq)]
pub enum FilterAdaptedSpecError {
    /// A size or tolerance error shared with [`MaskSpec`] (fields `width`, `height`, `depth`,
    /// `size`, `kernel_tolerance`).
    Spec(SpecError),
    /// A filter parameter out of range: `field` is `spatial_filter`, `temporal_filter` or
    /// `filter_combination`.
    Filter {
        /// The spec field.
        field: &'static str,
        /// What is wrong, with the allowed range.
        message: String,
    },
    /// `swaps_per_pixel` is NaN, negative or above [`FilterAdaptedSpec::MAX_SWAPS_PER_PIXEL`].
    InvalidBudget(f64),
    /// `SampleSpace::Vec` with `dims` outside `1..=4`.
    InvalidDims(u8),
}

impl From<SpecError> for FilterAdaptedSpecError {
    fn from(e: SpecError) -> Self {
        FilterAdaptedSpecError::Spec(e)
    }
}

impl fmt::Display for FilterAdaptedSpecError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FilterAdaptedSpecError::Spec(e) => e.fmt(f),
            FilterAdaptedSpecError::Filter { field, message } => write!(f, "`{field}`: {message}"),
            FilterAdaptedSpecError::InvalidBudget(value) => write!(
                f,
                "`swaps_per_pixel` is {value}; it must be in 0..={}",
                FilterAdaptedSpec::MAX_SWAPS_PER_PIXEL
            ),
            FilterAdaptedSpecError::InvalidDims(dims) => {
                write!(f, "`dims` of `Vec` is {dims}; it must be in 1..=4")
            }
        }
    }
}

impl std::error::Error for FilterAdaptedSpecError {}

/// The levels the distance energy compares: the rank itself for frames of up to 2¹⁴ pixels,
/// else `⌊rank · 2¹⁴ / n⌋` (2¹⁴ equal-sized groups of neighbouring ranks, whose order within a
/// group the energy then ignores).
fn distance_levels(n: usize) -> Vec<i16> {
    (0..n as u64)
        .map(|r| {
            if n <= 1 << 14 {
                r as i16
            } else {
                ((r << 14) / n as u64) as i16
            }
        })
        .collect()
}

/// The product energy's integers for ranks `0..n`: `2r + 1 − n` (centred, odd), scaled down to
/// magnitudes below 2¹⁵ (rounded) for frames of more than 2¹⁵ pixels.
fn centred_ranks(n: usize) -> Vec<i32> {
    let scale = (f64::from(1u32 << 15) / n as f64).min(1.0);
    (0..n)
        .map(|r| ((2.0 * r as f64 + 1.0 - n as f64) * scale).round() as i32)
        .collect()
}

/// The distance energy of `weights` over `levels` (`((z · slice) + i) · dims + c`, each below
/// 2¹⁴), with the default screening; and the trace's unit (weights normalised, levels / 2¹⁴).
fn distance_energy(weights: &PairWeights, levels: Vec<i16>, dims: usize) -> (Energy, f64) {
    let kernel = ScanKernel::new(weights);
    let (w, h, d) = weights.size;
    let unit = kernel.scale() * f64::from(w) * f64::from(h) * f64::from(d) * 16384.0;
    let core = kernel
        .terms
        .iter()
        .map(|t| {
            t.spatial
                .iter()
                .take_while(|s| s.0 * s.0 + s.1 * s.1 <= CORE_RADIUS_SQUARED)
                .count()
        })
        .collect();
    let energy = Energy::Distance {
        kernel,
        dims,
        levels,
        core,
        screen: Some(SCREEN),
    };
    (energy, unit)
}

/// The product energy of `weights` over `table` (`((z · slice) + i) · dims + c`); and the
/// trace's unit (weights normalised, integers / `value_scale`).
fn product_energy(
    weights: &PairWeights,
    table: Vec<i32>,
    dims: usize,
    value_scale: f64,
) -> (Energy, f64) {
    let max = table.iter().map(|u| u.unsigned_abs()).max().unwrap_or(0);
    let kernel = Kernel::new(weights, u64::from(max));
    let (w, h, d) = weights.size;
    let unit =
        kernel.scale * f64::from(w) * f64::from(h) * f64::from(d) * value_scale * value_scale;
    let energy = Energy::Product {
        kernel,
        dims,
        table,
        phi: Vec::new(),
    };
    (energy, unit)
}

/// The scalar energy of `spec`'s value kernel for frames of `n` pixels (values by rank).
fn scalar_energy(spec: &FilterAdaptedSpec, n: usize) -> (Energy, f64) {
    let weights = spec.pair_weights();
    let frames = spec.depth as usize;
    match spec.value_kernel {
        ValueKernel::Distance => {
            let one = distance_levels(n);
            distance_energy(&weights, one.repeat(frames), 1)
        }
        ValueKernel::Product => {
            let one = centred_ranks(n);
            let scale = n.min(1 << 15) as f64;
            product_energy(&weights, one.repeat(frames), 1, scale)
        }
    }
}

/// Runs the budget of `spec` on `optimizer`, reporting each pass to `observer` and recording the
/// energy (divided by `unit`) after each.
fn optimise(
    spec: &FilterAdaptedSpec,
    optimizer: &mut Optimizer,
    unit: f64,
    observer: &mut Observer<'_>,
) -> EnergyTrace {
    let point = |o: &Optimizer| TracePoint {
        swaps_attempted: o.swaps_attempted(),
        swaps_accepted: o.swaps_accepted(),
        energy: o.energy() as f64 / unit,
    };
    let mut trace = EnergyTrace {
        points: vec![point(optimizer)],
    };
    let passes = spec.swaps_per_pixel.ceil() as u64;
    observer.report(0, passes);
    for pass in 0..passes {
        optimizer.run_pass((spec.swaps_per_pixel - pass as f64).min(1.0));
        trace.points.push(point(optimizer));
        observer.report(pass + 1, passes);
    }
    trace
}

/// The scalar mask `spec` describes ([`crate::generate_filter_adapted`]).
///
/// The trace's energies are per pixel, with the pair weights normalised to sum 1 per factor and
/// values in `[0, 1)` (distance) or `[−1, 1)` (product); for the distance kernel they are
/// relative to the initial arrangement (its absolute energy would cost a full footprint scan of
/// every pixel), for the product kernel absolute.
pub(crate) fn generate_scalar(
    spec: &FilterAdaptedSpec,
    mut observer: Observer<'_>,
) -> Result<Volume, FilterAdaptedSpecError> {
    spec.validate()?;
    let (w, h, d) = (spec.width, spec.height, spec.depth);
    let n = spec.slice_pixels() as usize;
    let perm: Vec<u32> = match spec.initial_arrangement {
        // One value per pixel: one axis, so both arrangements are the scalar mask's ranks.
        InitialArrangement::ScalarStbn | InitialArrangement::ScalarStbnPerAxis => {
            generate(&MaskSpec::new(w, h, d, spec.seed), Observer::default())?
                .ranks()
                .to_vec()
        }
        InitialArrangement::Random => {
            let mut perm = vec![0u32; n * d as usize];
            perm.par_chunks_mut(n).enumerate().for_each(|(z, slice)| {
                slice
                    .iter_mut()
                    .enumerate()
                    .for_each(|(i, r)| *r = i as u32);
                slice.shuffle(&mut keyed_rng(
                    spec.seed,
                    rng::FILTER_ADAPTED.init,
                    z as u64,
                    0,
                ));
            });
            perm
        }
    };
    let (energy, unit) = scalar_energy(spec, n);
    let mut optimizer = Optimizer::new(energy, (w, h, d), perm, spec.seed);
    let trace = optimise(spec, &mut optimizer, unit, &mut observer);
    observer.finish(trace);
    Ok(Volume::from_global_ranks(w, h, d, optimizer.perm()))
}

/// The screening threshold of distance proposals, in units of `len · Σ g` (see [`optimizer`]).
/// Measured at 128×128×64 from STBN with uniform partners (BENCHMARKS.md): thresholds from
/// 3·10⁻⁴ to 3·10⁻³, or no screening at all, reach the same filtered error within 3·10⁻⁵ after 32
/// passes; 10⁻³ and 3·10⁻⁴ cost about the same time, 3·10⁻³ a third more, no screening five times
/// as much.
const SCREEN: f64 = 1e-3;

/// Whether the space's components lie in `[0, 1)` (else in `[−1, 1]`).
fn unit_interval(space: &SampleSpace) -> bool {
    matches!(space, SampleSpace::Vec { .. } | SampleSpace::ImagePoints(_))
}

/// The product energy's integer for a vector component: `[0, 1)` spaces store
/// `round((v − ½) · 2¹⁵)`, unit spaces (components in `[−1, 1]`) `round(v · 2¹⁴)`; magnitudes at
/// most 2¹⁴ either way, so the integers are `2¹⁴ ×` the component in `[−1, 1]` units.
fn vector_integer(space: &SampleSpace, v: f32) -> i32 {
    if unit_interval(space) {
        ((f64::from(v) - 0.5) * 32768.0).round() as i32
    } else {
        (f64::from(v) * 16384.0).round() as i32
    }
}

/// Unit directions the distance energy of `dims`-component values projects onto: the axes, and
/// for two or more components the diagonals `(e_i ± e_j)/√2` of every pair of axes (4 directions
/// in 2D, 9 in 3D, 16 in 4D). The mean of `|⟨a − b, u⟩|` over all directions is proportional to
/// `‖a − b‖` (Crofton); these few approximate it.
fn projection_directions(dims: usize) -> Vec<Vec<f64>> {
    let mut out: Vec<Vec<f64>> = (0..dims)
        .map(|i| (0..dims).map(|k| if k == i { 1.0 } else { 0.0 }).collect())
        .collect();
    let r = std::f64::consts::FRAC_1_SQRT_2;
    for i in 0..dims {
        for j in i + 1..dims {
            for sign in [1.0, -1.0] {
                out.push(
                    (0..dims)
                        .map(|k| {
                            if k == i {
                                r
                            } else if k == j {
                                sign * r
                            } else {
                                0.0
                            }
                        })
                        .collect(),
                );
            }
        }
    }
    out
}

/// Each frame's stratified set of `space` in pixel order as `spec` arranges it
/// ([`arranged_start`], the start of every vector mask), and the energy of `spec`'s value kernel
/// over it with the trace's unit.
fn vector_setup(
    spec: &FilterAdaptedSpec,
    space: &SampleSpace,
) -> Result<(Vec<f32>, Energy, f64), FilterAdaptedSpecError> {
    let dims = space.dims();
    let (w, h, d) = (spec.width, spec.height, spec.depth);
    let n = spec.slice_pixels() as usize;
    let values = arranged_start((w, h, d), spec.seed, space, spec.initial_arrangement)?;
    let weights = spec.pair_weights();
    let (energy, unit) = match spec.value_kernel {
        ValueKernel::Distance => {
            let directions = projection_directions(dims);
            let k = directions.len();
            let mut levels = vec![0i16; n * d as usize * k];
            let rank_levels = distance_levels(n);
            levels
                .par_chunks_mut(n * k)
                .zip(values.par_chunks(n * dims))
                .for_each(|(out, frame)| {
                    for (j, direction) in directions.iter().enumerate() {
                        // The rank of each value's projection within its frame; equal
                        // projections share the level of their middle rank.
                        let mut order: Vec<(f64, u32)> = frame
                            .chunks_exact(dims)
                            .enumerate()
                            .map(|(i, v)| {
                                let p = v.iter().zip(direction).map(|(&c, &u)| f64::from(c) * u);
                                (p.sum(), i as u32)
                            })
                            .collect();
                        order.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                        let mut first = 0;
                        while first < order.len() {
                            let mut last = first;
                            while last + 1 < order.len() && order[last + 1].0 == order[first].0 {
                                last += 1;
                            }
                            let level = rank_levels[(first + last) / 2];
                            for &(_, i) in &order[first..=last] {
                                out[i as usize * k + j] = level;
                            }
                            first = last + 1;
                        }
                    }
                });
            distance_energy(&weights, levels, k)
        }
        ValueKernel::Product => {
            let table = values.iter().map(|&v| vector_integer(space, v)).collect();
            product_energy(&weights, table, dims, 16384.0)
        }
    };
    Ok((values, energy, unit))
}

/// The vector mask `spec` describes ([`crate::generate_filter_adapted_vector`]), with the trace's
/// energies per pixel as [`generate_scalar`] reports them (components as levels / 2¹⁴ for the
/// distance kernel, as `[−1, 1]` values for the product).
pub(crate) fn generate_vector(
    spec: &FilterAdaptedVectorSpec,
    mut observer: Observer<'_>,
) -> Result<VectorVolume, FilterAdaptedSpecError> {
    spec.validate()?;
    let (space, spec) = (&spec.space, &spec.filter_adapted);
    let dims = space.dims();
    let (w, h, d) = (spec.width, spec.height, spec.depth);
    let n = spec.slice_pixels() as usize;
    let (values, energy, unit) = vector_setup(spec, space)?;
    let perm: Vec<u32> = (0..d as usize).flat_map(|_| 0..n as u32).collect();
    let mut optimizer = Optimizer::new(energy, (w, h, d), perm, spec.seed);
    let trace = optimise(spec, &mut optimizer, unit, &mut observer);
    let perm = optimizer.into_perm();
    let mut out = vec![0.0f32; values.len()];
    out.par_chunks_mut(n * dims)
        .zip(values.par_chunks(n * dims))
        .zip(perm.par_chunks(n))
        .for_each(|((dst, src), perm)| {
            for (pixel, &i) in perm.iter().enumerate() {
                let i = i as usize;
                dst[pixel * dims..(pixel + 1) * dims]
                    .copy_from_slice(&src[i * dims..(i + 1) * dims]);
            }
        });
    observer.finish(trace);
    Ok(VectorVolume::new((w, h, d), space, out))
}
