//! Vector masks: what to generate ([`VectorSpec`]), the generator ([`generate`]) and its output
//! ([`VectorVolume`]).
//!
//! Each slice starts as a stratified sample set of the [`SampleSpace`]
//! ([`SampleSpace::stratified_sampler`]), arranged as [`InitialArrangement`] says: by default
//! sorted along a Hilbert curve of value space and handed out in the rank order of a scalar STBN
//! mask, so similar values start far apart in space and time (for Vec2 and Vec3 each component,
//! for the cosine hemisphere each parameter, follows a scalar STBN mask of its own). The swap
//! optimiser ([`SwapOptimizer`]) then permutes the values within each slice to lower the
//! spatiotemporal energy of the paper's §4.2. A slice's multiset of values never changes, so
//! every frame on its own stays a stratified sample set of the space.

use std::fmt;

use rand::Rng;
use rayon::prelude::*;

use crate::kernel::{round_down_4, round_up_4, smallest_four_digit};
use crate::observe::Observer;
use crate::rng::{self, keyed_rng};
use crate::space::{SampleSpace, hilbert_key, unit_hilbert_key};
use crate::spec::{MaskSpec, SigmaRange, SpecError};
use crate::swap::energy::{keeps_unit_offset, value_factor_below_one};
use crate::swap::{ASSIGNMENT_SET, SwapConfig, SwapKernel, SwapOptimizer};
use crate::trace::{EnergyTrace, TracePoint};

/// How each frame's stratified values are arranged before a vector or filter-adapted mask is
/// optimised.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum InitialArrangement {
    /// A seeded random permutation per slice (white noise), as in the paper.
    Random,
    /// The values sorted along a Hilbert curve of value space and given to the pixels in the
    /// order of their per-slice rank in the scalar STBN mask `MaskSpec::new(width, height, depth,
    /// seed)` ([`crate::generate`]): for every threshold, the pixels holding values from one stretch of
    /// the curve (one region of value space) form a blue-noise set in space and time. A much
    /// better start than white noise for the price of one scalar mask (BENCHMARKS.md).
    ScalarStbn,
    /// Every parameter of the space's stratified set (the point of the unit square or cube each
    /// value corresponds to, area-preserving: both components of a `Vec2`, the angle of a
    /// `UnitVec2`, the concentric square of a sphere's or hemisphere's equal-area disc, the two
    /// coordinates of an image's sampler) takes its per-slice rank from its own scalar STBN mask:
    /// parameter 0 from `MaskSpec::new(width, height, depth, seed)` (the mask
    /// [`InitialArrangement::ScalarStbn`] uses), parameter `c` from one of a seed derived from
    /// `(seed, c)`; the values go to the pixels whose rank points are nearest along a Hilbert
    /// curve of the unit cube. So each parameter read alone starts close to a scalar STBN mask, in
    /// space and in time, and the pixels' sequences start far bluer than from one rank per pixel;
    /// the swap optimiser then draws all its partner candidates from the first pass
    /// (BENCHMARKS.md, "Design decisions"). Independent masks, not one mask at offsets: a mask
    /// read at an offset would tie one component to another at that offset (0.81 correlation
    /// after optimisation for the runtime's dimension-1 offset), which sample dimensions read
    /// there would inherit.
    ScalarStbnPerAxis,
}

impl InitialArrangement {
    /// The start [`VectorSpec::new`] picks for `space`: [`InitialArrangement::ScalarStbnPerAxis`]
    /// for [`SampleSpace::Vec`] masks of two and three components (each component is one
    /// parameter, so each starts close to a scalar STBN mask) and for the cosine hemisphere
    /// (lower report figures, temporal low band −12%; in the scenes crate up to 2% lower per-pixel
    /// ambient-occlusion error, blurred −2.4 to +1.4%), [`InitialArrangement::ScalarStbn`] for the
    /// rest. The per-axis start measured a higher filtered error on `Vec4`, and on the sphere and
    /// the uniform hemisphere lower low bands but up to 2% higher integration errors
    /// (BENCHMARKS.md, "Design decisions").
    pub fn default_for(space: &SampleSpace) -> InitialArrangement {
        match space {
            SampleSpace::Vec { dims: 2 | 3 } | SampleSpace::CosineHemisphere => {
                InitialArrangement::ScalarStbnPerAxis
            }
            _ => InitialArrangement::ScalarStbn,
        }
    }

    /// A short lowercase name: `random`, `scalar_stbn` or `scalar_stbn_per_axis`.
    pub fn name(self) -> &'static str {
        match self {
            InitialArrangement::Random => "random",
            InitialArrangement::ScalarStbn => "scalar_stbn",
            InitialArrangement::ScalarStbnPerAxis => "scalar_stbn_per_axis",
        }
    }
}

/// Everything that determines a vector STBN mask, bit for bit: equal specs give identical volumes
/// for every thread count ([`crate::generate_vector`]).
///
/// Each slice starts as a stratified sample set of [`VectorSpec::space`], arranged as
/// [`VectorSpec::initial_arrangement`] says; the swap optimiser then permutes the values within
/// each slice to lower the spatiotemporal energy of the paper's §4.2. A slice's multiset of
/// values never changes, so every frame on its own stays a stratified sample set of the space.
#[derive(Clone, Debug, PartialEq)]
pub struct VectorSpec {
    /// Pixels per row, `1..=`[`VectorSpec::MAX_AXIS`].
    pub width: u32,
    /// Rows per slice, `1..=`[`VectorSpec::MAX_AXIS`].
    pub height: u32,
    /// Slices (frames), `1..=`[`VectorSpec::MAX_AXIS`].
    pub depth: u32,
    /// Seed of the initial sample sets, their arrangement and the swap proposals.
    pub seed: u64,
    /// What each pixel holds.
    pub space: SampleSpace,
    /// σi of the energy `exp(−‖p−q‖²/σi² − ‖Vp−Vq‖^(d/3)/σs²)`, in pixels (and frames). The
    /// paper uses 1.9. Finite, and unless the volume is a single pixel, in
    /// [`VectorSpec::sigma_image_range`]: at least about 0.43 (at the default tolerance), at most
    /// [`VectorSpec::MAX_SIGMA_IMAGE_PER_LENGTH`] times the larger of `width` and `height`.
    pub sigma_image: f64,
    /// σs of the energy, in value units (the value term is `‖Vp−Vq‖^(d/3) / σs²`). The paper
    /// uses 1.0. Finite, `> 0`, at most [`VectorSpec::sigma_value_range`]'s bound (6501 for
    /// `Vec2`, 8191 for 3D directions); and large enough for the mask's value spacing, which the generator checks as
    /// it runs ([`crate::generate_vector`]).
    pub sigma_value: f64,
    /// Optimisation budget: swaps proposed per pixel, finite, in
    /// `0..=`[`VectorSpec::MAX_SWAPS_PER_PIXEL`]. Each whole unit is one pass in which every pixel
    /// proposes one swap; a fractional part runs a partial last pass. 0 swaps and 0 assignment
    /// passes keep the initial arrangement of the stratified sets.
    pub swaps_per_pixel: f64,
    /// Assignment passes run after the swap passes, in
    /// `0..=`[`VectorSpec::MAX_ASSIGNMENT_PASSES`]: in each, sets of up to 8 pixels with similar
    /// values that do not interact get the best permutation of their values (for values of at
    /// most two parameters, the best by a second-order model of each pixel's energy).
    /// One costs about as much as 2–3 swap passes (4 for `Vec4`), and late in a run gains more
    /// energy than they do; [`VectorSpec::DEFAULT_ASSIGNMENT_PASSES`] by default. 0 runs
    /// swaps only.
    pub assignment_passes: u32,
    /// Pair weights `exp(−‖p−q‖²/σi²)` below this are dropped, in `(0, 1)`. The default 5·10⁻³
    /// keeps offsets up to `σi √ln 200 = 2.3 σi` (4.4 pixels at σi 1.9: 56 same-slice and 8
    /// same-position neighbours).
    pub kernel_tolerance: f64,
    /// How the slices start ([`InitialArrangement::default_for`] the space by default).
    pub initial_arrangement: InitialArrangement,
}

impl VectorSpec {
    /// σi the paper uses.
    pub const DEFAULT_SIGMA_IMAGE: f64 = 1.9;
    /// σs the paper uses.
    pub const DEFAULT_SIGMA_VALUE: f64 = 1.0;
    /// Default budget in swaps proposed per pixel, run before
    /// [`VectorSpec::DEFAULT_ASSIGNMENT_PASSES`] assignment passes. Together they make Vec2 and
    /// UnitVec3 at 128×128×64 in 18–20 s on two cores running the AVX2 build, with FAST's
    /// filtered error 0.7% above that of 1024 swaps alone (3.3–4 min on AVX-512). BENCHMARKS.md
    /// ("Vector masks") has the curve, the times and the quality per budget, and what a much
    /// longer run still gains.
    pub const DEFAULT_SWAPS_PER_PIXEL: f64 = 64.0;
    /// Default number of assignment passes after the swaps. After 64 swap passes, assignment
    /// passes lower the energy and the filtered error more than the same time spent on swaps
    /// (BENCHMARKS.md, "Assignment passes and budgets").
    pub const DEFAULT_ASSIGNMENT_PASSES: u32 = 14;
    /// Default kernel truncation.
    pub const DEFAULT_KERNEL_TOLERANCE: f64 = 5e-3;
    /// Largest budget accepted.
    pub const MAX_SWAPS_PER_PIXEL: f64 = 10_000.0;
    /// Largest number of assignment passes accepted.
    pub const MAX_ASSIGNMENT_PASSES: u32 = 1000;
    /// Largest extent of one axis.
    pub const MAX_AXIS: u32 = MaskSpec::MAX_AXIS;
    /// Largest σi accepted, in lengths of the larger of `width` and `height`.
    ///
    /// The pair weight `exp(−d²/σi²)` is a Gaussian of σ `σi/√2`; wrapped onto an axis of `n`
    /// pixels it is its mean plus harmonics, the first of relative amplitude `2·exp(−π²σi²/n²)`.
    /// At `σi = 1.7 n` a swap's energy change through that variation (two pixels' taps, each
    /// pair counted twice) is at most `4 · 2·exp(−π²·1.7²)` ≈ 3.3·10⁻¹² of the kernel's total
    /// weight, below the margin a swap must beat (10⁻¹¹ of it). Beyond it the weights are flat
    /// over the slice: the energy no longer tells one arrangement of a slice from another, only
    /// which values share a pixel over time, at a footprint of the whole slice per pixel.
    pub const MAX_SIGMA_IMAGE_PER_LENGTH: f64 = 1.7;
    /// Largest number of pixels of one slice.
    pub const MAX_SLICE_PIXELS: u64 = MaskSpec::MAX_SLICE_PIXELS;
    /// Largest number of pixels of a volume.
    pub const MAX_PIXELS: u64 = MaskSpec::MAX_PIXELS;

    /// A spec with the paper's σs, the default budget and tolerance.
    pub fn new(width: u32, height: u32, depth: u32, seed: u64, space: SampleSpace) -> VectorSpec {
        VectorSpec {
            width,
            height,
            depth,
            seed,
            initial_arrangement: InitialArrangement::default_for(&space),
            space,
            sigma_image: Self::DEFAULT_SIGMA_IMAGE,
            sigma_value: Self::DEFAULT_SIGMA_VALUE,
            swaps_per_pixel: Self::DEFAULT_SWAPS_PER_PIXEL,
            assignment_passes: Self::DEFAULT_ASSIGNMENT_PASSES,
            kernel_tolerance: Self::DEFAULT_KERNEL_TOLERANCE,
        }
    }

    /// The same spec with another budget.
    pub fn with_swaps_per_pixel(mut self, swaps_per_pixel: f64) -> VectorSpec {
        self.swaps_per_pixel = swaps_per_pixel;
        self
    }

    /// The same spec with `passes` assignment passes after the swaps.
    pub fn with_assignment_passes(mut self, passes: u32) -> VectorSpec {
        self.assignment_passes = passes;
        self
    }

    /// The same spec with no budget at all (no swaps, no assignment passes):
    /// [`crate::generate_vector`] then returns the initial arrangement of the stratified sets,
    /// the start the optimiser would improve on.
    pub fn unoptimised(self) -> VectorSpec {
        self.with_swaps_per_pixel(0.0).with_assignment_passes(0)
    }

    /// Number of pixels of one slice.
    pub fn slice_pixels(&self) -> u64 {
        u64::from(self.width) * u64::from(self.height)
    }

    /// Number of pixels of the volume.
    pub fn pixels(&self) -> u64 {
        self.slice_pixels() * u64::from(self.depth)
    }

    /// Peak generator memory per pixel in bytes: during optimisation the values (4 bytes per
    /// component, converted in place to and from the volume's) and each pixel's cached energy
    /// (8), plus the private copies the tiles of one colour make of their regions (about 60%
    /// more of both at the default σi), and the scalar mask's ranks or the pdf channel (4);
    /// before it, the scalar mask's generator ([`MaskSpec::BYTES_PER_PIXEL`]) if the arrangement
    /// needs one, or one per parameter at once for [`InitialArrangement::ScalarStbnPerAxis`].
    pub fn bytes_per_pixel(&self) -> u64 {
        let optimiser = (4 * self.space.dims() as u64 + 8) * 8 / 5 + 4;
        match self.initial_arrangement {
            InitialArrangement::ScalarStbn => optimiser.max(MaskSpec::BYTES_PER_PIXEL + 4),
            InitialArrangement::ScalarStbnPerAxis => {
                optimiser.max(MaskSpec::BYTES_PER_PIXEL * self.space.parameters() as u64)
            }
            InitialArrangement::Random => optimiser,
        }
    }

    /// The σi `sigma_image` must lie in: `None` for a volume of one pixel (no pairs) and where
    /// `kernel_tolerance` is not in `(0, 1)` ([`VectorSpec::validate`] refuses it).
    ///
    /// Below `min` the weight `exp(−1/σi²)` of the nearest neighbour falls under
    /// `kernel_tolerance` (about `1/√ln(1/kernel_tolerance)`, 0.4345 at the default 5·10⁻³; the
    /// check is the kernel's own arithmetic): no pixel has a neighbour and no swap changes the
    /// energy. Above `max` ([`VectorSpec::MAX_SIGMA_IMAGE_PER_LENGTH`] times the larger of
    /// `width` and `height`, infinite for slices of one pixel) the weights are flat over the
    /// slice.
    pub fn sigma_image_range(&self) -> Option<SigmaRange> {
        let tolerance = self.kernel_tolerance;
        if !(tolerance > 0.0 && tolerance < 1.0) {
            return None;
        }
        let min = smallest_four_digit(1.0 / (1.0 / tolerance).ln().sqrt(), |sigma| {
            keeps_unit_offset(sigma, tolerance)
        });
        let slice_length = self.width.max(self.height);
        let max = if slice_length >= 2 {
            round_down_4(Self::MAX_SIGMA_IMAGE_PER_LENGTH * f64::from(slice_length))
        } else {
            f64::INFINITY
        };
        (self.pixels() > 1).then_some(SigmaRange { min, max })
    }

    /// The σs `sigma_value` must lie in, `(0, max]`: above `max` the value factor
    /// `exp(−x)` of the space's largest distance rounds to 1 in single precision (where the
    /// optimiser evaluates it; `x` below about 3·10⁻⁸), so every factor is 1 and every
    /// arrangement has the same energy. `max` is 5792 to 9195 by space (6501 for `Vec2`, 8191
    /// for 3D directions); the check is the factor's own arithmetic, and `max` is found by
    /// bisection on it (rounded down to four significant digits).
    ///
    /// How small σs may be depends on how closely the mask's values are spaced, which depends on
    /// its size: the generator checks that as it runs ([`crate::generate_vector`]).
    pub fn sigma_value_range(&self) -> SigmaRange {
        let (dims, s) = (self.space.dims(), self.space.largest_squared_distance());
        let distinguishes = |sigma: f64| value_factor_below_one(dims, s, sigma);
        // distinguishes(1) holds for every space; bisect in log space between 1 and 1e30.
        let (mut low, mut high) = (0.0f64, 30.0f64);
        for _ in 0..80 {
            let mid = 0.5 * (low + high);
            if distinguishes(10f64.powf(mid)) {
                low = mid;
            } else {
                high = mid;
            }
        }
        let mut max = round_down_4(10f64.powf(low));
        while !distinguishes(max) {
            max = round_down_4(max * (1.0 - 1e-4));
        }
        SigmaRange { min: 0.0, max }
    }

    /// Checks every field against its documented range. Sizes are checked before anything is
    /// allocated, and an oversized request reports the memory it would have taken.
    pub fn validate(&self) -> Result<(), VectorSpecError> {
        for (field, value) in [
            ("width", self.width),
            ("height", self.height),
            ("depth", self.depth),
        ] {
            if value == 0 || value > Self::MAX_AXIS {
                return Err(SpecError::AxisOutOfRange { field, value }.into());
            }
        }
        if let SampleSpace::Vec { dims } = self.space
            && !self.space.is_valid()
        {
            return Err(VectorSpecError::InvalidDims(dims));
        }
        if self.slice_pixels() > Self::MAX_SLICE_PIXELS || self.pixels() > Self::MAX_PIXELS {
            return Err(VectorSpecError::TooLarge {
                width: self.width,
                height: self.height,
                depth: self.depth,
                bytes_needed: self.pixels() * self.bytes_per_pixel(),
            });
        }
        for (field, value) in [
            ("sigma_image", self.sigma_image),
            ("sigma_value", self.sigma_value),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(SpecError::InvalidSigma { field, value }.into());
            }
        }
        if !(self.kernel_tolerance > 0.0 && self.kernel_tolerance < 1.0) {
            return Err(SpecError::InvalidTolerance(self.kernel_tolerance).into());
        }
        if let Some(range) = self.sigma_image_range() {
            let value = self.sigma_image;
            let reason = if !keeps_unit_offset(value, self.kernel_tolerance) {
                Some(format!(
                    "below {} the nearest neighbour's weight exp(−1/σ²) falls under \
                     `kernel_tolerance` {}, so no pixel has a neighbour and no swap changes the \
                     energy",
                    range.min, self.kernel_tolerance
                ))
            } else if value > range.max {
                Some(format!(
                    "above {} ({} times the slice's {} pixels) the weights are flat over the \
                     wrapped slice to below the margin a swap must beat, so the energy tells no \
                     arrangement of a slice from another",
                    range.max,
                    Self::MAX_SIGMA_IMAGE_PER_LENGTH,
                    self.width.max(self.height)
                ))
            } else {
                None
            };
            if let Some(reason) = reason {
                return Err(SpecError::SigmaOutOfRange {
                    field: "sigma_image",
                    value,
                    range,
                    reason,
                }
                .into());
            }
        }
        let range = self.sigma_value_range();
        if self.sigma_value > range.max {
            return Err(SpecError::SigmaOutOfRange {
                field: "sigma_value",
                value: self.sigma_value,
                range,
                reason: format!(
                    "above {} the value factor exp(−‖Δv‖^(d/3)/σs²) of even the farthest values \
                     of {} rounds to 1 in single precision, so every arrangement has the same \
                     energy",
                    range.max,
                    self.space.name()
                ),
            }
            .into());
        }
        if !(0.0..=Self::MAX_SWAPS_PER_PIXEL).contains(&self.swaps_per_pixel) {
            return Err(VectorSpecError::InvalidBudget(self.swaps_per_pixel));
        }
        if self.assignment_passes > Self::MAX_ASSIGNMENT_PASSES {
            return Err(VectorSpecError::InvalidAssignmentPasses(
                self.assignment_passes,
            ));
        }
        Ok(())
    }
}

/// A [`VectorSpec`] field outside its range. `Display` names the field and the allowed range.
#[derive(Clone, Debug, PartialEq)]
pub enum VectorSpecError {
    /// A size, σ or tolerance error shared with scalar masks (field names as in [`VectorSpec`]).
    Spec(SpecError),
    /// `SampleSpace::Vec` with `dims` outside `1..=4`.
    InvalidDims(u8),
    /// The slice or the volume has more pixels than the generator accepts.
    TooLarge {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
        /// Requested depth.
        depth: u32,
        /// Generator memory the request would have needed, in bytes.
        bytes_needed: u64,
    },
    /// `swaps_per_pixel` is NaN, negative or above [`VectorSpec::MAX_SWAPS_PER_PIXEL`].
    InvalidBudget(f64),
    /// `assignment_passes` is above [`VectorSpec::MAX_ASSIGNMENT_PASSES`].
    InvalidAssignmentPasses(u32),
}

impl From<&VectorSpec> for SwapConfig {
    fn from(spec: &VectorSpec) -> SwapConfig {
        SwapConfig {
            width: spec.width,
            height: spec.height,
            depth: spec.depth,
            dims: spec.space.dims(),
            parameters: spec.space.parameters(),
            seed: spec.seed,
            sigma_image: spec.sigma_image,
            sigma_value: spec.sigma_value,
            kernel_tolerance: spec.kernel_tolerance,
        }
    }
}

impl From<SpecError> for VectorSpecError {
    fn from(e: SpecError) -> Self {
        VectorSpecError::Spec(e)
    }
}

impl fmt::Display for VectorSpecError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            VectorSpecError::Spec(e) => e.fmt(f),
            VectorSpecError::InvalidDims(dims) => {
                write!(f, "`dims` of `Vec` is {dims}; it must be in 1..=4")
            }
            VectorSpecError::TooLarge {
                width,
                height,
                depth,
                bytes_needed,
            } => write!(
                f,
                "`size` {width}x{height}x{depth} is too large: generating it would take about \
                 {:.1} GiB; the limits are {} pixels per slice and {} pixels per volume",
                *bytes_needed as f64 / f64::from(1u32 << 30),
                VectorSpec::MAX_SLICE_PIXELS,
                VectorSpec::MAX_PIXELS,
            ),
            VectorSpecError::InvalidBudget(value) => write!(
                f,
                "`swaps_per_pixel` is {value}; it must be in 0..={}",
                VectorSpec::MAX_SWAPS_PER_PIXEL
            ),
            VectorSpecError::InvalidAssignmentPasses(value) => write!(
                f,
                "`assignment_passes` is {value}; it must be in 0..={}",
                VectorSpec::MAX_ASSIGNMENT_PASSES
            ),
        }
    }
}

impl std::error::Error for VectorSpecError {}

/// A generated vector mask: `width × height × depth` values of `dims` components each, and the
/// density of each value where the space stores one.
#[derive(Clone, Debug, PartialEq)]
pub struct VectorVolume {
    width: u32,
    height: u32,
    depth: u32,
    dims: usize,
    values: Vec<f32>,
    pdf: Option<Vec<f32>>,
}

impl VectorVolume {
    /// The volume of `values` (index `((z · height + y) · width + x) · dims + c`, `dims` =
    /// [`SampleSpace::dims`]) drawn from `space`, with each value's pdf where the space stores
    /// one. For the generators of this crate (the swap and filter-adapted optimisers).
    pub(crate) fn new(
        (width, height, depth): (u32, u32, u32),
        space: &SampleSpace,
        values: Vec<f32>,
    ) -> VectorVolume {
        let dims = space.dims();
        debug_assert_eq!(
            values.len(),
            width as usize * height as usize * depth as usize * dims
        );
        let pdf = space
            .stores_pdf()
            .then(|| values.par_chunks(dims).map(|v| space.pdf(v)).collect());
        VectorVolume {
            width,
            height,
            depth,
            dims,
            values,
            pdf,
        }
    }

    /// Pixels per row.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Rows per slice.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Slices (frames).
    pub fn depth(&self) -> u32 {
        self.depth
    }

    /// Components per value ([`SampleSpace::dims`]).
    pub fn dims(&self) -> usize {
        self.dims
    }

    /// Pixels of one slice.
    pub fn slice_pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Every component, index `((z · height + y) · width + x) · dims + c`.
    pub fn values(&self) -> &[f32] {
        &self.values
    }

    /// The value of pixel `(x, y)` of slice `z` (`dims` components). Panics outside the volume.
    pub fn value(&self, x: u32, y: u32, z: u32) -> &[f32] {
        assert!(
            x < self.width && y < self.height && z < self.depth,
            "outside the volume"
        );
        let i = (z as usize * self.height as usize + y as usize) * self.width as usize + x as usize;
        &self.values[i * self.dims..(i + 1) * self.dims]
    }

    /// The values of slice `z` (`width · height · dims` components). Panics if `z >= depth`.
    pub fn slice_values(&self, z: u32) -> &[f32] {
        assert!(z < self.depth, "slice {z} of {}", self.depth);
        let n = self.slice_pixels() * self.dims;
        &self.values[z as usize * n..(z as usize + 1) * n]
    }

    /// Per pixel, the density the value was drawn from ([`SampleSpace::pdf`] of the value),
    /// index `(z · height + y) · width + x`: `Some` exactly when the space
    /// [stores a pdf](SampleSpace::stores_pdf).
    pub fn pdf(&self) -> Option<&[f32]> {
        self.pdf.as_deref()
    }
}

/// The vector mask `spec` describes ([`crate::generate_vector`]), reporting quarter passes (a
/// quarter of the tile colours each) to `observer` and handing it the energy before the first pass and after
/// each.
pub(crate) fn generate(
    spec: &VectorSpec,
    mut observer: Observer<'_>,
) -> Result<VectorVolume, VectorSpecError> {
    spec.validate()?;
    let size = (spec.width, spec.height, spec.depth);
    let values = arranged_start(size, spec.seed, &spec.space, spec.initial_arrangement)?;
    let mut optimizer = SwapOptimizer::new(spec, values);
    if spec.initial_arrangement == InitialArrangement::ScalarStbnPerAxis {
        optimizer = optimizer.without_partner_ramp();
    }
    let start_energy = optimizer.energy();
    let mut trace = EnergyTrace {
        points: vec![TracePoint {
            swaps_attempted: 0,
            swaps_accepted: 0,
            energy: start_energy,
        }],
    };
    // ⌈swaps_per_pixel⌉ swap passes (the last one partial), then the assignment passes, each
    // reported in quarters.
    let swap_passes = spec.swaps_per_pixel.ceil() as u64;
    let passes = swap_passes + u64::from(spec.assignment_passes);
    let quarters = 4 * passes;
    observer.report(0, quarters);
    for pass in 0..passes {
        let mut done = 4 * pass;
        let mut report = |_: &SwapOptimizer| {
            done += 1;
            observer.report(done, quarters);
        };
        let point = if pass < swap_passes {
            let fraction = (spec.swaps_per_pixel - pass as f64).min(1.0);
            optimizer.run_pass(fraction, &mut report)
        } else {
            optimizer.run_assignment_pass(ASSIGNMENT_SET, &mut report)
        };
        if pass == 0 && point.swaps_accepted == 0 && point.swaps_attempted > 0 {
            underflow_check(spec, optimizer.kernel(), start_energy)?;
        }
        trace.points.push(point);
    }
    observer.finish(trace);
    Ok(VectorVolume::new(
        size,
        &spec.space,
        optimizer.into_values(),
    ))
}

/// After a first pass that kept no move: an error naming `sigma_value` if the value factors
/// underflow, so that no arrangement's energy differs from another's by the margin a move must
/// beat.
///
/// The value factor `exp(−‖Δv‖^(d/3)/σs²)` of a pair is below 10⁻¹¹ once its argument passes
/// `ln 10¹¹` ≈ 25.3 (and clamped to `e^−87` from 87 on). Whether the mask's pairs get there
/// depends on how closely its values are spaced, so on its size: the check is made on the run
/// itself. If the factors' mean over the interacting pairs of the start is below
/// [`SwapKernel::MARGIN`] (relative to the kernel's weight, the margin's own scale) and the pass
/// kept nothing, the value term has underflowed. The message estimates the smallest σs that
/// keeps neighbouring values in range from the values' spacing: `n` values of `p` parameters
/// spread over a diameter `D` lie about `D · n^(−1/p)` apart.
fn underflow_check(
    spec: &VectorSpec,
    kernel: &SwapKernel,
    start_energy: f64,
) -> Result<(), VectorSpecError> {
    let Some(mean) = kernel.mean_value_factor(start_energy) else {
        return Ok(());
    };
    if mean >= SwapKernel::MARGIN {
        return Ok(());
    }
    let diameter = f64::from(spec.space.largest_squared_distance()).sqrt();
    let parameters = spec.space.parameters() as f64;
    let spacing = diameter * (spec.slice_pixels() as f64).powf(-1.0 / parameters);
    let power = spec.space.dims() as f64 / 3.0;
    let estimate = (spacing.powf(power) / (1.0 / SwapKernel::MARGIN).ln()).sqrt();
    let max = spec.sigma_value_range().max;
    Err(SpecError::SigmaOutOfRange {
        field: "sigma_value",
        value: spec.sigma_value,
        range: SigmaRange {
            min: round_up_4(estimate).min(max),
            max,
        },
        reason: format!(
            "the first pass kept no swap: the value factors exp(−‖Δv‖^(d/3)/σs²) of the mask's \
             interacting pairs average {mean:.1e}, below the margin a swap must beat, so every \
             arrangement has the same energy (the lower bound is an estimate from this size's \
             value spacing, about {spacing:.2e})"
        ),
    }
    .into())
}

/// Each slice's stratified set of `space` (one random stream per slice), arranged as
/// `arrangement` says: the start of every vector mask, of the swap optimiser
/// ([`generate`]) and of the filter-adapted one
/// ([`crate::generate_filter_adapted_vector`]) alike. Index `((z · height + y) · width + x) ·
/// dims + c`.
pub(crate) fn arranged_start(
    (width, height, depth): (u32, u32, u32),
    seed: u64,
    space: &SampleSpace,
    arrangement: InitialArrangement,
) -> Result<Vec<f32>, SpecError> {
    let dims = space.dims();
    let n = width as usize * height as usize;
    let sampler = space.stratified_sampler();
    let mask = |seed| {
        crate::generate(
            &MaskSpec::new(width, height, depth, seed),
            crate::Observer::default(),
        )
    };
    // One mask per parameter for the per-axis start, the first shared with the Hilbert-order one.
    let masks = match arrangement {
        InitialArrangement::Random => Vec::new(),
        InitialArrangement::ScalarStbn => vec![mask(seed)?],
        // In parallel: the scalar generator keeps about one core busy.
        InitialArrangement::ScalarStbnPerAxis => (0..space.parameters())
            .into_par_iter()
            .map(|c| mask(axis_seed(seed, c)))
            .collect::<Result<_, _>>()?,
    };
    let mut values = vec![0.0f32; n * depth as usize * dims];
    values
        .par_chunks_mut(n * dims)
        .enumerate()
        .for_each(|(z, slice)| {
            let mut rng = keyed_rng(seed, rng::VECTOR.init, z as u64, 0);
            match arrangement {
                InitialArrangement::Random => slice.copy_from_slice(&sampler.slice(n, &mut rng)),
                InitialArrangement::ScalarStbn => {
                    let set = sampler.slice(n, &mut rng);
                    // Sorted along the Hilbert curve, handed out in the scalar mask's rank order.
                    let mut order: Vec<(u64, u32)> = set
                        .chunks_exact(dims)
                        .enumerate()
                        .map(|(i, v)| (hilbert_key(space, v), i as u32))
                        .collect();
                    order.sort_unstable();
                    for (pixel, &rank) in masks[0].slice(z as u32).iter().enumerate() {
                        let from = order[rank as usize].1 as usize * dims;
                        slice[pixel * dims..(pixel + 1) * dims]
                            .copy_from_slice(&set[from..from + dims]);
                    }
                }
                InitialArrangement::ScalarStbnPerAxis => {
                    // Rank points and parameters both sorted along the unit cube's Hilbert
                    // curve, matched in that order.
                    let (set, parameters) = sampler.slice_with_parameters(n, &mut rng);
                    let ranks: Vec<&[u32]> = masks.iter().map(|m| m.slice(z as u32)).collect();
                    let targets = per_axis_targets(&ranks);
                    let mut order: Vec<(u64, u32)> = parameters
                        .chunks_exact(ranks.len())
                        .enumerate()
                        .map(|(i, u)| (unit_hilbert_key(u), i as u32))
                        .collect();
                    order.sort_unstable();
                    for (&(_, pixel), &(_, from)) in targets.iter().zip(&order) {
                        let (pixel, from) = (pixel as usize * dims, from as usize * dims);
                        slice[pixel..pixel + dims].copy_from_slice(&set[from..from + dims]);
                    }
                }
            }
        });
    Ok(values)
}

/// The seed of parameter `c`'s scalar mask in [`InitialArrangement::ScalarStbnPerAxis`]: `seed`
/// itself for `c = 0`, else the first word of the vector start's stream keyed `(u64::MAX, c)`
/// (no frame's key).
fn axis_seed(seed: u64, c: usize) -> u64 {
    if c == 0 {
        seed
    } else {
        keyed_rng(seed, rng::VECTOR.init, u64::MAX, c as u64).next_u64()
    }
}

/// Each pixel's rank point of [`InitialArrangement::ScalarStbnPerAxis`] as `(Hilbert key,
/// pixel)`, sorted: coordinate `c` is `(rank + ½) / n` in `ranks[c]`, parameter `c`'s mask's
/// slice of `n` pixels.
fn per_axis_targets(ranks: &[&[u32]]) -> Vec<(u64, u32)> {
    let n = ranks[0].len();
    let inv = 1.0 / n as f64;
    let mut targets: Vec<(u64, u32)> = (0..n)
        .map(|p| {
            let mut point = [0.0f64; 4];
            for (t, axis) in point.iter_mut().zip(ranks) {
                *t = (f64::from(axis[p]) + 0.5) * inv;
            }
            (unit_hilbert_key(&point[..ranks.len()]), p as u32)
        })
        .collect();
    targets.sort_unstable();
    targets
}
