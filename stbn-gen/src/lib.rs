//! Generators and analysis for spatiotemporal blue-noise (STBN) masks.
//!
//! Data flow: a [`MaskSpec`] (what to generate) → [`generate`] (void-and-cluster with an
//! [`EnergyTopology`]-shaped [`EnergyKernel`]) → a [`Volume`] of per-slice ranks. Encoding,
//! compression and embedding live in `stbn-build-support`; sampling in `stbn-runtime`.
//!
//! ```
//! use stbn_gen::{generate, MaskSpec};
//! let volume = generate(&MaskSpec::new(16, 16, 4, 7)).unwrap();
//! // Every slice is a permutation: exactly uniform values.
//! let mut slice = volume.slice(0).to_vec();
//! slice.sort_unstable();
//! assert!(slice.iter().enumerate().all(|(i, &r)| r as usize == i));
//! ```

pub mod analysis;
pub mod baselines;
pub mod export;
mod extremum;
mod fastmath;
pub mod filter_adapted;
pub mod importance;
pub mod kernel;
mod rng;
mod schedule;
pub mod space;
pub mod spec;
pub mod swap;
pub mod tellusim;
mod torus;
mod trace;
pub mod vector;
pub mod void_cluster;
pub mod volume;

pub use baselines::{BaselineKind, generate_baseline};
pub use filter_adapted::{
    FilterAdaptedSpec, FilterAdaptedSpecError, FilterCombination, SpatialFilter, TemporalFilter,
    ValueKernel, generate_filter_adapted, generate_filter_adapted_vector,
    generate_filter_adapted_with_trace,
};
pub use importance::{ImageError, ImagePdf};
pub use kernel::EnergyKernel;
pub use space::SampleSpace;
pub use spec::{EnergyTopology, MaskSpec, SpecError};
pub use vector::{
    EnergyTrace, InitialArrangement, TracePoint, VectorProgress, VectorSpec, VectorSpecError,
    VectorVolume, generate_vector, generate_vector_with_progress,
};
pub use void_cluster::Progress;
pub use volume::Volume;

/// Version of the generator's output: bumped whenever [`generate`], [`generate_vector`] or
/// [`generate_filter_adapted`] can return a different mask for an equal spec (an algorithm,
/// tie-break, kernel, arithmetic or RNG change). Caches of generated masks include it in their
/// keys; tests pin the output of reference specs to it. Version 2: the vector energy's value
/// factor is computed in single precision; 3: vector swap partners are the nearest in value of a
/// few candidates, in tiles of 16 pixels; 4: the default vector budget is 64 swap passes and 16
/// assignment passes (was 128 swap passes).
pub const GENERATOR_VERSION: u32 = 4;

/// Generates the scalar mask `spec` describes.
///
/// Deterministic: equal specs give equal volumes on every machine and for every thread count.
pub fn generate(spec: &MaskSpec) -> Result<Volume, SpecError> {
    generate_with_progress(spec, &mut |_| {})
}

/// [`generate`], calling `progress` as pixels get ranked.
pub fn generate_with_progress(
    spec: &MaskSpec,
    progress: &mut dyn FnMut(Progress),
) -> Result<Volume, SpecError> {
    spec.validate()?;
    let ranks = void_cluster::rank_pixels(spec, progress);
    Ok(Volume::from_global_ranks(
        spec.width,
        spec.height,
        spec.depth,
        &ranks,
    ))
}
