//! Generators and analysis for spatiotemporal blue-noise (STBN) masks.
//!
//! A mask is a `width × height × depth` volume: `depth` frames (slices) of `width × height`
//! pixels, read toroidally on every axis. Each generator family has one entry point, which takes
//! a spec (everything that determines the mask, bit for bit) and an [`Observer`] (progress
//! reports and the optimiser's energy trace; [`Observer::default()`] for none):
//!
//! | family | spec | entry point | mask |
//! | --- | --- | --- | --- |
//! | scalar STBN: void-and-cluster with an [`EnergyTopology`] | [`MaskSpec`] | [`generate`] | [`Volume`] |
//! | baselines to compare against | [`BaselineSpec`] | [`generate_baseline`] | [`Volume`] |
//! | vector STBN: a swap optimiser over [`SampleSpace`] values | [`VectorSpec`] | [`generate_vector`] | [`VectorVolume`] |
//! | filter-adapted (FAST) | [`FilterAdaptedSpec`] | [`generate_filter_adapted`] | [`Volume`] |
//! | filter-adapted vector | [`FilterAdaptedVectorSpec`] | [`generate_filter_adapted_vector`] | [`VectorVolume`] |
//!
//! Every generator is deterministic: equal specs give equal masks on every machine and for every
//! thread count, and [`GENERATOR_VERSION`] names the output. A spec out of range is refused
//! before anything is allocated, with an error that names the field.
//!
//! Four modules hold what is not a generator: [`analysis`] (spectral, histogram, filtered-error
//! and convergence measures of scalar fields), [`baselines`] (value-field baselines and the
//! comparison set the reports measure), [`export`] (grayscale PNG slices) and
//! [`file`](mod@file) (bounded reads of regular files). Encoding, compression and embedding live
//! in `stbn-build-support`; sampling in `stbn-runtime`.
//!
//! # Features
//!
//! The generators need none: a build script that generates masks compiles only them. All are
//! off by default.
//!
//! | feature | adds | dependencies |
//! | --- | --- | --- |
//! | `analysis` | the [`analysis`] module | `rustfft` |
//! | `images` | [`ImagePdf::load`] and [`ImagePdf::decode`] (PNG and Radiance `.hdr`); with `analysis`, the [`export`] module | `image`, `png` |
//!
//! # Scalar masks
//!
//! ```
//! use stbn_gen::{MaskSpec, Observer, generate};
//! let volume = generate(&MaskSpec::new(16, 16, 4, 7), Observer::default()).unwrap();
//! // Every slice is a permutation: exactly uniform values.
//! let mut slice = volume.slice(0).to_vec();
//! slice.sort_unstable();
//! assert!(slice.iter().enumerate().all(|(i, &r)| r as usize == i));
//! ```
//!
//! # Baselines
//!
//! ```
//! use stbn_gen::{BaselineKind, BaselineSpec, Observer, generate_baseline};
//! let spec = BaselineSpec::new(BaselineKind::GoldenRatio2D, 16, 16, 4, 7);
//! let volume = generate_baseline(&spec, Observer::default()).unwrap();
//! assert_eq!((volume.width(), volume.height(), volume.depth()), (16, 16, 4));
//! ```
//!
//! # Vector masks
//!
//! Each frame holds a stratified sample set of the spec's [`SampleSpace`], permuted to be blue
//! in space and time. The default budget is 64 swap passes
//! ([`VectorSpec::DEFAULT_SWAPS_PER_PIXEL`]) followed by 14 assignment passes
//! ([`VectorSpec::DEFAULT_ASSIGNMENT_PASSES`]).
//!
//! ```
//! use stbn_gen::{EnergyTrace, Observer, SampleSpace, VectorSpec, generate_vector};
//! let spec = VectorSpec::new(16, 16, 4, 7, SampleSpace::UnitVec2).with_swaps_per_pixel(2.0);
//! let mut trace = EnergyTrace::default();
//! let volume = generate_vector(&spec, Observer::default().with_trace(&mut trace)).unwrap();
//! assert_eq!(volume.value(3, 5, 1).len(), 2);
//! // The energy before the swaps, then after each of the 2 swap and 14 assignment passes.
//! assert_eq!(trace.points.len(), 1 + 2 + VectorSpec::DEFAULT_ASSIGNMENT_PASSES as usize);
//! assert!(trace.points.last().unwrap().energy < trace.points[0].energy);
//! ```
//!
//! # Filter-adapted masks
//!
//! Masks optimised for the filter that consumes them (EA's FAST), scalar or, with
//! [`FilterAdaptedSpec::with_space`], vector.
//!
//! ```
//! use stbn_gen::{FilterAdaptedSpec, Observer, SampleSpace};
//! let spec = FilterAdaptedSpec::new(16, 16, 8, 7).with_swaps_per_pixel(2.0);
//! let scalar = stbn_gen::generate_filter_adapted(&spec, Observer::default()).unwrap();
//! assert_eq!(scalar.depth(), 8);
//! let vector = spec.with_space(SampleSpace::Vec { dims: 2 });
//! let volume = stbn_gen::generate_filter_adapted_vector(&vector, Observer::default()).unwrap();
//! assert_eq!(volume.dims(), 2);
//! ```

#![warn(missing_docs)]
#![cfg_attr(docsrs, feature(doc_cfg))]

#[cfg(feature = "analysis")]
pub mod analysis;
pub mod baselines;
#[cfg(all(feature = "analysis", feature = "images"))]
pub mod export;
mod extremum;
mod fastmath;
pub mod file;
mod filter_adapted;
mod importance;
mod kernel;
mod observe;
mod rng;
mod schedule;
mod space;
mod spec;
mod swap;
mod tellusim;
mod torus;
mod trace;
mod vector;
mod void_cluster;
mod volume;

pub use baselines::{BaselineKind, BaselineSpec};
pub use filter_adapted::{
    FilterAdaptedSpec, FilterAdaptedSpecError, FilterAdaptedVectorSpec, FilterCombination,
    SpatialFilter, TemporalFilter, ValueKernel,
};
pub use importance::{ImageError, ImagePdf, PixelProblem};
pub use observe::{Observer, Progress};
pub use space::SampleSpace;
pub use spec::{EnergyTopology, MaskSpec, SigmaRange, SpecError, compact_number};
pub use trace::{EnergyTrace, TracePoint};
pub use vector::{InitialArrangement, VectorSpec, VectorSpecError, VectorVolume};
pub use volume::Volume;

/// The version of the generators' output. It names the mask every entry point returns for a
/// given spec, and changes whenever one of them can return a different mask for an equal spec:
/// an algorithm, tie-break, kernel, arithmetic, RNG or default-budget change. Caches of
/// generated masks include it in their keys; tests pin the output of reference specs to it.
pub const GENERATOR_VERSION: u32 = 11;

/// Generates the scalar STBN mask `spec` describes: void-and-cluster over the energy of
/// `spec.topology`. [`Progress`] counts pixels ranked; the trace is empty.
///
/// Deterministic: equal specs give equal volumes on every machine and for every thread count.
///
/// ```
/// use stbn_gen::{EnergyTopology, MaskSpec, Observer, generate};
/// let spec = MaskSpec::new(16, 16, 8, 3).with_topology(EnergyTopology::Independent2D);
/// let volume = generate(&spec, Observer::default()).unwrap();
/// assert!(volume.values().iter().all(|&v| 0.0 < v && v < 1.0));
/// assert!(generate(&MaskSpec::new(0, 16, 8, 3), Observer::default()).is_err());
/// ```
///
/// # Errors
/// [`SpecError`] if a field of `spec` is out of range ([`MaskSpec::validate`]).
pub fn generate(spec: &MaskSpec, mut observer: Observer<'_>) -> Result<Volume, SpecError> {
    spec.validate()?;
    let ranks = void_cluster::rank_pixels(spec, &mut observer);
    observer.finish(EnergyTrace::default());
    Ok(Volume::from_global_ranks(
        spec.width,
        spec.height,
        spec.depth,
        &ranks,
    ))
}

/// Generates the baseline mask `spec` describes ([`baselines`] says what each
/// [`BaselineKind`] is). [`Progress`] counts pixels ranked; the trace is empty.
///
/// Deterministic: equal specs give equal volumes on every machine and for every thread count.
///
/// ```
/// use stbn_gen::{BaselineKind, BaselineSpec, Observer, generate_baseline};
/// let spec = BaselineSpec::new(BaselineKind::White, 8, 8, 2, 5);
/// let volume = generate_baseline(&spec, Observer::default()).unwrap();
/// // A white-noise mask is still a permutation per slice.
/// let mut slice = volume.slice(1).to_vec();
/// slice.sort_unstable();
/// assert_eq!(slice, (0..64).collect::<Vec<u32>>());
/// ```
///
/// # Errors
/// [`SpecError`] if a field of `spec.mask` is out of range ([`BaselineSpec::validate`]).
pub fn generate_baseline(
    spec: &BaselineSpec,
    mut observer: Observer<'_>,
) -> Result<Volume, SpecError> {
    let volume = baselines::generate_baseline(spec, &mut observer)?;
    observer.finish(EnergyTrace::default());
    Ok(volume)
}

/// Generates the vector STBN mask `spec` describes: each frame a stratified sample set of
/// `spec.space`, permuted by the swap optimiser of the paper's §4.2. [`Progress`] counts quarter
/// passes; the trace has the energy before the first pass and after each.
///
/// Deterministic: equal specs give equal volumes and traces for every thread count.
///
/// ```
/// use stbn_gen::{Observer, SampleSpace, VectorSpec, generate_vector};
/// let spec = VectorSpec::new(16, 16, 4, 1, SampleSpace::UnitVec3).with_swaps_per_pixel(1.0);
/// let volume = generate_vector(&spec, Observer::default()).unwrap();
/// let [x, y, z] = volume.value(0, 0, 0) else { unreachable!() };
/// assert!((x * x + y * y + z * z - 1.0).abs() < 1e-5);
/// ```
///
/// # Errors
/// [`VectorSpecError`] if a field of `spec` is out of range ([`VectorSpec::validate`]).
pub fn generate_vector(
    spec: &VectorSpec,
    observer: Observer<'_>,
) -> Result<VectorVolume, VectorSpecError> {
    vector::generate(spec, observer)
}

/// Generates the scalar filter-adapted mask `spec` describes: every frame a permutation of the
/// ranks `0..width·height`, swapped to lower the expected error after `spec`'s filters.
/// [`Progress`] counts passes; the trace has the energy before the first pass and after each
/// (per pixel, relative to the start for [`ValueKernel::Distance`]).
///
/// Deterministic: equal specs give equal volumes on every machine and for every thread count.
///
/// ```
/// use stbn_gen::{FilterAdaptedSpec, Observer, generate_filter_adapted};
/// let spec = FilterAdaptedSpec::new(16, 16, 8, 7).with_swaps_per_pixel(2.0);
/// let volume = generate_filter_adapted(&spec, Observer::default()).unwrap();
/// let mut slice = volume.slice(3).to_vec();
/// slice.sort_unstable();
/// assert!(slice.iter().enumerate().all(|(i, &r)| r as usize == i));
/// ```
///
/// # Errors
/// [`FilterAdaptedSpecError`] if a field of `spec` is out of range
/// ([`FilterAdaptedSpec::validate`]).
pub fn generate_filter_adapted(
    spec: &FilterAdaptedSpec,
    observer: Observer<'_>,
) -> Result<Volume, FilterAdaptedSpecError> {
    filter_adapted::generate_scalar(spec, observer)
}

/// Generates the filter-adapted vector mask `spec` describes: every frame the stratified set of
/// `spec.space` a [`VectorSpec`] of the same size and seed starts from, permuted to lower the
/// expected error after the filters. [`Progress`] counts passes; the trace is as for
/// [`generate_filter_adapted`].
///
/// Deterministic: equal specs give equal volumes and traces for every thread count.
///
/// ```
/// use stbn_gen::{FilterAdaptedSpec, Observer, SampleSpace, generate_filter_adapted_vector};
/// let spec = FilterAdaptedSpec::new(16, 16, 8, 7)
///     .with_swaps_per_pixel(1.0)
///     .with_space(SampleSpace::CosineHemisphere);
/// let volume = generate_filter_adapted_vector(&spec, Observer::default()).unwrap();
/// // Directions on the hemisphere around +Z.
/// assert!(volume.values().chunks_exact(3).all(|v| v[2] >= 0.0));
/// ```
///
/// # Errors
/// [`FilterAdaptedSpecError`] if a field of `spec` is out of range
/// ([`FilterAdaptedVectorSpec::validate`]).
pub fn generate_filter_adapted_vector(
    spec: &FilterAdaptedVectorSpec,
    observer: Observer<'_>,
) -> Result<VectorVolume, FilterAdaptedSpecError> {
    filter_adapted::generate_vector(spec, observer)
}
