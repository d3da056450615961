//! [`Recipe`]: everything that determines a mask's blob, and how to make it.
//!
//! A [`MaskEntry`] names a kind and its parameters; its recipe is the generator input
//! ([`MaskSpec`], [`VectorSpec`] or [`FilterAdaptedSpec`]), the baseline or topology that
//! consumes it, and for vector masks the blob layout. The cache keys blobs by the recipe's
//! canonical description; the encoder and the CLI generate from it.

use stbn_gen::{
    BaselineKind, BaselineSpec, EnergyTrace, FilterAdaptedSpec, FilterAdaptedSpecError, MaskSpec,
    Observer, Progress, SampleSpace, VectorSpec, VectorSpecError, VectorVolume, Volume,
};
use stbn_runtime::{Compression, Encoding};

use crate::encode::{Layout, encode_vector, encode_volume};
use crate::manifest::{MaskEntry, Method};

/// What to generate for one mask.
#[derive(Clone, Debug)]
pub enum Recipe {
    /// Void-and-cluster over the spec's topology.
    VoidAndCluster(MaskSpec),
    /// A baseline generator, from the spec's size, seed and (where it uses them) σ, density and
    /// tolerance.
    Baseline(BaselineKind, MaskSpec),
    /// The swap optimiser.
    Vector {
        /// The optimiser's input (space, size, seed, σs, budget).
        spec: VectorSpec,
        /// How the result is stored.
        layout: Layout,
        /// BLAKE3 of the image file of image spaces.
        image_hash: Option<blake3::Hash>,
    },
    /// The filter-adapted optimiser.
    FilterAdapted(FilterAdaptedRecipe),
}

/// A validated filter-adapted recipe: a [`FilterAdaptedSpec`], the vector space (`None`:
/// scalar) and the blob layout. Built only by [`FilterAdaptedRecipe::new`], so generating it
/// cannot fail.
#[derive(Clone, Debug)]
pub struct FilterAdaptedRecipe {
    spec: FilterAdaptedSpec,
    space: Option<SampleSpace>,
    layout: Layout,
}

impl FilterAdaptedRecipe {
    /// Checks `spec` for a scalar mask (`space` `None`) or a vector mask of `space` (3D unit
    /// spaces stored octahedrally when `octahedral`).
    ///
    /// # Errors
    /// The spec's [`FilterAdaptedSpecError`].
    pub fn new(
        spec: FilterAdaptedSpec,
        space: Option<SampleSpace>,
        octahedral: bool,
    ) -> Result<FilterAdaptedRecipe, FilterAdaptedSpecError> {
        match &space {
            Some(space) => spec.clone().with_space(space.clone()).validate()?,
            None => spec.validate()?,
        }
        let layout = space
            .as_ref()
            .map_or(Layout::SCALAR, |space| Layout::new(space, octahedral));
        Ok(FilterAdaptedRecipe {
            spec,
            space,
            layout,
        })
    }

    /// The optimiser's input.
    pub fn spec(&self) -> &FilterAdaptedSpec {
        &self.spec
    }

    /// The vector space, `None` for a scalar mask.
    pub fn space(&self) -> Option<&SampleSpace> {
        self.space.as_ref()
    }
}

/// A generated mask before encoding.
#[derive(Clone, Debug)]
pub enum Generated {
    /// Per-slice ranks of a scalar mask.
    Scalar(Volume),
    /// A vector mask and the optimiser's energy trace.
    Vector {
        /// The values (and pdfs).
        volume: VectorVolume,
        /// Energy after each optimiser pass.
        trace: EnergyTrace,
    },
}

impl MaskEntry {
    /// This mask's recipe.
    pub fn recipe(&self) -> Recipe {
        match self.kind.method() {
            Method::VoidAndCluster(_) => Recipe::VoidAndCluster(self.spec()),
            Method::Baseline(kind) => Recipe::Baseline(kind, self.spec()),
            Method::Swap => {
                let spec = self
                    .vector_spec()
                    .expect("a parsed vector entry has its sample space (and image)");
                Recipe::Vector {
                    layout: Layout::new(&spec.space, self.octahedral),
                    spec,
                    image_hash: self.image.as_ref().map(|image| image.hash),
                }
            }
            Method::FilterAdapted => {
                let (spec, space) = self
                    .filter_adapted_spec()
                    .expect("a FilterAdapted entry has a filter-adapted spec");
                Recipe::FilterAdapted(
                    FilterAdaptedRecipe::new(spec, space, self.octahedral)
                        .expect("a parsed entry's spec is valid"),
                )
            }
        }
    }
}

impl Recipe {
    /// Generates the mask. Deterministic: equal recipes give equal results for any thread count.
    ///
    /// # Errors
    /// The generator's, if the spec is out of range (a parsed manifest never is); scalar errors
    /// come as [`VectorSpecError::Spec`].
    pub fn generate(&self) -> Result<Generated, VectorSpecError> {
        self.generate_with_progress(&mut |_| {})
    }

    /// [`generate`](Self::generate), calling `progress` on the calling thread as the generator
    /// advances, in the steps [`Progress`] lists for it (pixels ranked by void and cluster,
    /// quarter passes of the vector swap optimiser, passes of the filter-adapted one). The result
    /// does not depend on `progress`.
    ///
    /// # Errors
    /// As [`generate`](Self::generate).
    pub fn generate_with_progress(
        &self,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<Generated, VectorSpecError> {
        let observer = Observer::default().with_progress(progress);
        Ok(match self {
            Recipe::VoidAndCluster(spec) => Generated::Scalar(stbn_gen::generate(spec, observer)?),
            Recipe::Baseline(kind, spec) => {
                let spec = BaselineSpec {
                    kind: *kind,
                    mask: spec.clone(),
                };
                Generated::Scalar(stbn_gen::generate_baseline(&spec, observer)?)
            }
            Recipe::Vector { spec, .. } => {
                let mut trace = EnergyTrace::default();
                let volume = stbn_gen::generate_vector(spec, observer.with_trace(&mut trace))?;
                Generated::Vector { volume, trace }
            }
            Recipe::FilterAdapted(recipe) => {
                let valid = "FilterAdaptedRecipe::new checked the spec";
                match &recipe.space {
                    None => Generated::Scalar(
                        stbn_gen::generate_filter_adapted(&recipe.spec, observer).expect(valid),
                    ),
                    Some(space) => {
                        let spec = recipe.spec.clone().with_space(space.clone());
                        let mut trace = EnergyTrace::default();
                        let volume = stbn_gen::generate_filter_adapted_vector(
                            &spec,
                            observer.with_trace(&mut trace),
                        )
                        .expect(valid);
                        Generated::Vector { volume, trace }
                    }
                }
            }
        })
    }

    /// `generated` (what this recipe generated) as a complete `.stbn` blob with `encoding` and
    /// `compression`: the bytes [`embed`](crate::embed) writes for a manifest entry and
    /// `stbn-gen generate --format stbn` writes for it.
    pub fn encode(
        &self,
        generated: &Generated,
        encoding: Encoding,
        compression: Compression,
    ) -> Vec<u8> {
        match generated {
            Generated::Scalar(volume) => encode_volume(volume, encoding, compression),
            Generated::Vector { volume, .. } => {
                encode_vector(volume, self.layout(), encoding, compression)
            }
        }
    }

    /// Generates the mask and encodes it as a complete `.stbn` blob
    /// ([`generate`](Self::generate), then [`encode`](Self::encode)).
    ///
    /// # Errors
    /// As [`generate`](Self::generate).
    pub fn make(
        &self,
        encoding: Encoding,
        compression: Compression,
    ) -> Result<(Generated, Vec<u8>), VectorSpecError> {
        let generated = self.generate()?;
        let blob = self.encode(&generated, encoding, compression);
        Ok((generated, blob))
    }

    /// `(width, height, depth)` of the mask, in pixels, pixels and frames.
    pub fn size(&self) -> (u32, u32, u32) {
        match self {
            Recipe::VoidAndCluster(spec) | Recipe::Baseline(_, spec) => {
                (spec.width, spec.height, spec.depth)
            }
            Recipe::Vector { spec, .. } => (spec.width, spec.height, spec.depth),
            Recipe::FilterAdapted(recipe) => {
                (recipe.spec.width, recipe.spec.height, recipe.spec.depth)
            }
        }
    }

    /// How the blob stores the mask: channels, space and value map its header must have.
    pub fn layout(&self) -> Layout {
        match self {
            Recipe::Vector { layout, .. } => *layout,
            Recipe::FilterAdapted(recipe) => recipe.layout,
            _ => Layout::SCALAR,
        }
    }

    /// One line per input, floats as exact bit patterns: the text the cache key hashes (without
    /// the encoding, compression and versions, which the cache adds).
    pub fn canonical_description(&self) -> String {
        match self {
            Recipe::VoidAndCluster(spec) => format!("method=void_and_cluster\n{}", scalar(spec)),
            Recipe::Baseline(kind, spec) => {
                format!("method=baseline\nbaseline={kind:?}\n{}", scalar(spec))
            }
            Recipe::Vector {
                spec,
                layout,
                image_hash,
            } => {
                format!(
                    "method=swap\nspace={}\nwidth={}\nheight={}\ndepth={}\nseed={}\n\
                 sigma_image={:016x}\nsigma_value={:016x}\nswaps_per_pixel={:016x}\n\
                 assignment_passes={}\nkernel_tolerance={:016x}\nlayout={:?}/{:?}/{}\nimage={}\n",
                    spec.space.name(),
                    spec.width,
                    spec.height,
                    spec.depth,
                    spec.seed,
                    spec.sigma_image.to_bits(),
                    spec.sigma_value.to_bits(),
                    spec.swaps_per_pixel.to_bits(),
                    spec.assignment_passes,
                    spec.kernel_tolerance.to_bits(),
                    layout.space,
                    layout.value_map,
                    layout.channels,
                    image_hash.map_or_else(|| "none".to_owned(), |h| h.to_hex().to_string()),
                )
            }
            Recipe::FilterAdapted(recipe) => filter_adapted(recipe),
        }
    }
}

/// The canonical description of a filter-adapted recipe: every spec field, floats as bits.
fn filter_adapted(recipe: &FilterAdaptedRecipe) -> String {
    use stbn_gen::{FilterCombination, SpatialFilter, TemporalFilter};
    let FilterAdaptedSpec {
        width,
        height,
        depth,
        seed,
        spatial_filter,
        temporal_filter,
        combination,
        value_kernel,
        swaps_per_pixel,
        kernel_tolerance,
        initial_arrangement,
    } = &recipe.spec;
    let bits = |v: f64| format!("{:016x}", v.to_bits());
    let spatial = match *spatial_filter {
        SpatialFilter::Gaussian { sigma } => format!("gaussian/{}", bits(sigma)),
        SpatialFilter::Box { size } => format!("box/{size}"),
        SpatialFilter::Binomial { order } => format!("binomial/{order}"),
    };
    let temporal = match *temporal_filter {
        TemporalFilter::Gaussian { sigma } => format!("gaussian/{}", bits(sigma)),
        TemporalFilter::Box { size } => format!("box/{size}"),
        TemporalFilter::Exponential { alpha } => format!("exponential/{}", bits(alpha)),
        TemporalFilter::ExponentialHistory { alpha, beta } => {
            format!("exponential_history/{}/{}", bits(alpha), bits(beta))
        }
    };
    let combination = match *combination {
        FilterCombination::Product => "product".to_owned(),
        FilterCombination::Separate { spatial_weight } => {
            format!("separate/{}", bits(spatial_weight))
        }
    };
    let layout = recipe.layout;
    format!(
        "method=filter_adapted\nspace={}\nwidth={width}\nheight={height}\ndepth={depth}\n\
         seed={seed}\nspatial_filter={spatial}\ntemporal_filter={temporal}\n\
         filter_combination={combination}\nvalue_kernel={}\nswaps_per_pixel={}\n\
         kernel_tolerance={}\ninitial_arrangement={}\nlayout={:?}/{:?}/{}\n",
        recipe.space.as_ref().map_or("scalar", SampleSpace::name),
        value_kernel.name(),
        bits(*swaps_per_pixel),
        bits(*kernel_tolerance),
        initial_arrangement.name(),
        layout.space,
        layout.value_map,
        layout.channels,
    )
}

/// The scalar spec's lines of a canonical description.
fn scalar(spec: &MaskSpec) -> String {
    let MaskSpec {
        width,
        height,
        depth,
        seed,
        sigma_xy,
        sigma_z,
        initial_density,
        topology,
        kernel_tolerance,
    } = spec;
    format!(
        "width={width}\nheight={height}\ndepth={depth}\nseed={seed}\n\
         sigma_xy={:016x}\nsigma_z={:016x}\ninitial_density={:016x}\nkernel_tolerance={:016x}\n\
         topology={}\n",
        sigma_xy.to_bits(),
        sigma_z.to_bits(),
        initial_density.to_bits(),
        kernel_tolerance.to_bits(),
        topology.name(),
    )
}
