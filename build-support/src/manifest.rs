//! The `assets.ron` manifest: which masks to generate and how to store them.
//!
//! ```ron
//! (
//!     masks: [
//!         (
//!             name: "scalar_64",      // ASCII Rust identifier; becomes the static SCALAR_64
//!             kind: Scalar,           // see MaskKind
//!             size: (64, 64, 32),     // (width, height, frames)
//!             seed: 7,
//!             sigma: 1.9,             // optional, default 1.9 (Tellusim's convention and 1.6 for TellusimLayered)
//!             sigma_time: 1.9,        // optional, default = sigma (void-and-cluster kinds)
//!             density: 0.1,           // optional, default 0.1, in (0, 0.5] (void-and-cluster kinds)
//!             kernel_tolerance: 5e-3, // optional, default 5e-3, in (0, 1)
//!             encoding: Unorm8,       // Unorm8 | Unorm16 | F32
//!             compression: Lz4,       // optional: None (default) | Lz4 | Deflate | Palette
//!         ),
//!         (
//!             name: "taa_blur",
//!             kind: FilterAdapted,    // optimised for the filter that consumes it (EA's FAST)
//!             size: (128, 128, 64),
//!             seed: 3,
//!             // optional: Gaussian(σ px) | Box(size) | Binomial(order)
//!             spatial_filter: Gaussian(1.3435),
//!             // optional: Exponential(α) | ExponentialHistory(α, β) | Gaussian(σ) | Box(frames)
//!             temporal_filter: Exponential(0.1),
//!             filter_combination: Product, // optional: Product | Separate(spatial weight)
//!             space: Vec2,            // optional: a vector mask of this vector kind's space
//!             swaps_per_pixel: 6.0,   // optional, the optimiser's budget
//!             encoding: Unorm8,
//!         ),
//!         (
//!             name: "sky_dirs",
//!             kind: EnvironmentMap,   // a vector kind (swap optimiser)
//!             size: (128, 128, 64),
//!             seed: 1,
//!             image: "sky.hdr",       // image kinds only; relative to the manifest
//!             sigma_value: 1.0,       // optional, σs of the value term
//!             swaps_per_pixel: 8.0,   // optional, the optimiser's budget
//!             assignment_passes: 12,  // optional, exact k-pixel passes after the swaps
//!             octahedral: true,       // optional, 3D unit kinds: store 2 octahedral channels (default)
//!             encoding: Unorm16,
//!         ),
//!     ],
//! )
//! ```
//!
//! Unknown fields are errors, and so are fields that do not apply to the mask's kind (`density`
//! on a vector mask, `image` on a scalar one, a filter on anything but `FilterAdapted`). Optional fields may also be written `Some(…)`.
//! Every error names the file, line, column and field ([`ManifestError`]), and a misspelt field
//! or variant name comes with the closest valid one; image files are read and checked (NaN,
//! infinite, negative or all-zero luminance) while the manifest is parsed, which needs the
//! crate's `images` feature.

use stbn_gen::compact_number as number;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use ron::error::SpannedError;
use ron::extensions::Extensions;
use serde::Deserialize;
use stbn_gen::{
    BaselineKind, EnergyTopology, FilterAdaptedSpec, FilterAdaptedSpecError, FilterCombination,
    ImagePdf, MaskSpec, SampleSpace, SpatialFilter, SpecError, TemporalFilter, VectorSpec,
    VectorSpecError,
};
use stbn_runtime::{Compression, Encoding};

use crate::quote::{self, compact_numbers, excerpt, quoted, shorten_quoted};
use crate::source::{Located, MaskSource, Pos, SourceMap, Unclosed};
use crate::{Error, ManifestError};

/// What a mask holds and how it is generated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Deserialize)]
pub enum MaskKind {
    /// Spatiotemporal blue noise (the STBN paper's scalar mask): blue within every frame and over
    /// time at every pixel. [`EnergyTopology::Spatiotemporal`].
    Scalar,
    /// An independent 2D blue-noise mask per frame (white over time).
    /// [`EnergyTopology::Independent2D`].
    Blue2D,
    /// Isotropic 3D blue noise over (x, y, frame). [`EnergyTopology::Isotropic3D`].
    Blue3D,
    /// White noise with exactly uniform frames (a random permutation per frame). A baseline.
    White,
    /// One 2D blue-noise frame animated by the golden ratio, `fract(v + frame·φ⁻¹)`, as an exact
    /// integer rank rotation. A baseline.
    GoldenRatio2D,
    /// One 2D blue-noise frame shifted by a random offset per frame, `fract(v + r_frame)`. A
    /// baseline (as Tellusim describes it).
    RandomShift2D,
    /// Tellusim's layered void-and-cluster: each frame seeded from the previous one flipped in X
    /// and Y. A baseline.
    TellusimLayered,
    /// Uniform scalars in `[0, 1)`, optimised by the swap algorithm (the paper's "Vec1").
    Vec1,
    /// Uniform 2D vectors in `[0, 1)²`.
    Vec2,
    /// Uniform 3D vectors in `[0, 1)³`.
    Vec3,
    /// Uniform 4D vectors in `[0, 1)⁴`.
    Vec4,
    /// `±1` ("Unit Vec1").
    UnitVec1,
    /// Uniform unit vectors on the circle.
    UnitVec2,
    /// Uniform unit vectors on the sphere.
    UnitVec3,
    /// Uniform directions on the hemisphere `z ≥ 0`.
    UniformHemisphere,
    /// Cosine-weighted directions on the hemisphere `z ≥ 0` (pdf `z/π`).
    CosineHemisphere,
    /// Points in `[0, 1)²` importance-sampled from an image's luminance (field `image`); the pdf
    /// is stored in a channel.
    ImagePoints,
    /// Directions importance-sampled from a latitude-longitude environment map (field `image`),
    /// pdf per steradian stored in a channel.
    EnvironmentMap,
    /// Optimised for the filter that will consume it (EA's FAST): fields `spatial_filter`,
    /// `temporal_filter`, `filter_combination` (default: EA's Gaussian σ 1.3435 × EMA α 0.1
    /// product, the filter `filtered_error` measures). Scalar by default, with the thresholded
    /// filtered error as its energy; `space: Vec2` (any vector kind without an image) makes a
    /// vector mask of that space with the linear (dot product) energy.
    /// [`stbn_gen::FilterAdaptedSpec`].
    FilterAdapted,
}

/// How a [`MaskKind`] is generated, which decides the fields that apply to it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Void-and-cluster with this energy topology ([`stbn_gen::generate`]).
    VoidAndCluster(EnergyTopology),
    /// A baseline generator ([`stbn_gen::generate_baseline`]).
    Baseline(BaselineKind),
    /// The swap optimiser over vector values ([`stbn_gen::generate_vector`]).
    Swap,
    /// The filter-adapted optimiser ([`stbn_gen::generate_filter_adapted`],
    /// [`stbn_gen::generate_filter_adapted_vector`]).
    FilterAdapted,
}

impl MaskKind {
    /// How masks of this kind are generated.
    pub fn method(self) -> Method {
        match self {
            MaskKind::Scalar => Method::VoidAndCluster(EnergyTopology::Spatiotemporal),
            MaskKind::Blue2D => Method::VoidAndCluster(EnergyTopology::Independent2D),
            MaskKind::Blue3D => Method::VoidAndCluster(EnergyTopology::Isotropic3D),
            MaskKind::White => Method::Baseline(BaselineKind::White),
            MaskKind::GoldenRatio2D => Method::Baseline(BaselineKind::GoldenRatio2D),
            MaskKind::RandomShift2D => Method::Baseline(BaselineKind::RandomShift2D),
            MaskKind::TellusimLayered => Method::Baseline(BaselineKind::TellusimLayered),
            MaskKind::FilterAdapted => Method::FilterAdapted,
            _ => Method::Swap,
        }
    }

    /// `true` for the two kinds that need an `image`.
    pub fn needs_image(self) -> bool {
        matches!(self, MaskKind::ImagePoints | MaskKind::EnvironmentMap)
    }

    /// `true` for kinds of 3D unit vectors, which may be stored octahedrally.
    pub fn is_direction3(self) -> bool {
        matches!(
            self,
            MaskKind::UnitVec3
                | MaskKind::UniformHemisphere
                | MaskKind::CosineHemisphere
                | MaskKind::EnvironmentMap
        )
    }

    /// The sample space of a vector kind, `None` for scalar kinds; `image` is the loaded image of
    /// the image kinds (they return `None` without one).
    pub fn sample_space(self, image: Option<&Arc<ImagePdf>>) -> Option<SampleSpace> {
        Some(match self {
            MaskKind::Vec1 => SampleSpace::Vec { dims: 1 },
            MaskKind::Vec2 => SampleSpace::Vec { dims: 2 },
            MaskKind::Vec3 => SampleSpace::Vec { dims: 3 },
            MaskKind::Vec4 => SampleSpace::Vec { dims: 4 },
            MaskKind::UnitVec1 => SampleSpace::UnitVec1,
            MaskKind::UnitVec2 => SampleSpace::UnitVec2,
            MaskKind::UnitVec3 => SampleSpace::UnitVec3,
            MaskKind::UniformHemisphere => SampleSpace::UniformHemisphere,
            MaskKind::CosineHemisphere => SampleSpace::CosineHemisphere,
            MaskKind::ImagePoints => SampleSpace::ImagePoints(image?.clone()),
            MaskKind::EnvironmentMap => SampleSpace::EnvironmentDirections(image?.clone()),
            _ => return None,
        })
    }

    /// A one-line description for generated documentation.
    pub fn description(self) -> &'static str {
        match self {
            MaskKind::Scalar => "spatiotemporal blue noise, blue in space and over time",
            MaskKind::Blue2D => "independent 2D blue noise per frame, white over time",
            MaskKind::Blue3D => "isotropic 3D blue noise over x, y and frames",
            MaskKind::White => "white noise with exactly uniform frames (baseline)",
            MaskKind::GoldenRatio2D => "2D blue noise animated by the golden ratio (baseline)",
            MaskKind::RandomShift2D => "2D blue noise shifted randomly per frame (baseline)",
            MaskKind::TellusimLayered => "Tellusim's layered void-and-cluster (baseline)",
            MaskKind::Vec1 => "spatiotemporal blue-noise scalars from the swap optimiser",
            MaskKind::Vec2 => "spatiotemporal blue-noise 2D vectors in [0, 1)²",
            MaskKind::Vec3 => "spatiotemporal blue-noise 3D vectors in [0, 1)³",
            MaskKind::Vec4 => "spatiotemporal blue-noise 4D vectors in [0, 1)⁴",
            MaskKind::UnitVec1 => "spatiotemporal blue-noise signs (±1)",
            MaskKind::UnitVec2 => "spatiotemporal blue-noise unit vectors on the circle",
            MaskKind::UnitVec3 => "spatiotemporal blue-noise unit vectors on the sphere",
            MaskKind::UniformHemisphere => {
                "spatiotemporal blue-noise uniform hemisphere directions"
            }
            MaskKind::CosineHemisphere => {
                "spatiotemporal blue-noise cosine-weighted hemisphere directions"
            }
            MaskKind::ImagePoints => {
                "spatiotemporal blue-noise points importance-sampled from an image"
            }
            MaskKind::EnvironmentMap => {
                "spatiotemporal blue-noise directions importance-sampled from an environment map"
            }
            MaskKind::FilterAdapted => "optimised for a spatial and a temporal filter (FAST)",
        }
    }
}

/// An image a mask is importance-sampled from, loaded and checked while the manifest is parsed.
#[derive(Clone, Debug)]
pub struct ImageSource {
    /// The file, resolved against the manifest's directory.
    pub path: PathBuf,
    /// BLAKE3 of the file's bytes, part of the cache key.
    pub hash: blake3::Hash,
    /// The luminance pdf built from it.
    pub pdf: Arc<ImagePdf>,
}

impl PartialEq for ImageSource {
    /// Equal files: same path and content (the pdf follows from the content).
    fn eq(&self, other: &Self) -> bool {
        self.path == other.path && self.hash == other.hash
    }
}

/// One validated mask of the manifest, with defaults filled in.
#[derive(Clone, Debug, PartialEq)]
pub struct MaskEntry {
    /// ASCII Rust identifier, not a keyword; unique in the manifest even after upper-casing.
    pub name: String,
    /// The energy the mask is generated with.
    pub kind: MaskKind,
    /// `(width, height, frames)` in pixels, pixels and frames; each in
    /// `1..=`[`MaskSpec::MAX_AXIS`], within [`MaskSpec::MAX_SLICE_PIXELS`] per frame and
    /// [`MaskSpec::MAX_PIXELS`] in all.
    pub size: (u32, u32, u32),
    /// Generator seed.
    pub seed: u64,
    /// Spatial Gaussian σ in pixels, finite and `> 0` (default [`MaskSpec::DEFAULT_SIGMA`]).
    pub sigma: f64,
    /// Temporal Gaussian σ in frames, finite and `> 0` (default: `sigma`).
    pub sigma_time: f64,
    /// Initial pattern density in `(0, 0.5]` (default [`MaskSpec::DEFAULT_DENSITY`]).
    pub density: f64,
    /// Kernel truncation tolerance in `(0, 1)` (default [`MaskSpec::DEFAULT_KERNEL_TOLERANCE`]).
    pub kernel_tolerance: f64,
    /// Vector kinds: σs of the value term of the swap energy (default [`VectorSpec`]'s).
    pub sigma_value: f64,
    /// Vector kinds: the swap optimiser's budget in attempted swaps per pixel (default
    /// [`VectorSpec`]'s).
    pub swaps_per_pixel: f64,
    /// Vector kinds: assignment passes after the swaps (default [`VectorSpec`]'s; see
    /// [`VectorSpec::assignment_passes`]).
    pub assignment_passes: u32,
    /// Image kinds: the image the values are importance-sampled from.
    pub image: Option<ImageSource>,
    /// 3D unit-vector kinds: store two octahedral channels instead of three signed ones
    /// (default `true`).
    pub octahedral: bool,
    /// `FilterAdapted`: the spatial filter (default [`SpatialFilter::DEFAULT`]).
    pub spatial_filter: SpatialFilter,
    /// `FilterAdapted`: the temporal filter (default [`TemporalFilter::DEFAULT`]).
    pub temporal_filter: TemporalFilter,
    /// `FilterAdapted`: how the filters combine (default [`FilterCombination::Product`]).
    pub filter_combination: FilterCombination,
    /// `FilterAdapted`: the vector kind whose space the mask holds (`None`: scalar).
    pub space: Option<MaskKind>,
    /// How values are stored.
    pub encoding: Encoding,
    /// How the payload is compressed (default [`Compression::None`]).
    pub compression: Compression,
}

impl MaskEntry {
    /// The void-and-cluster parameters of this mask: what scalar kinds are generated from (the
    /// 2D base mask for baselines). For vector kinds only the size and seed carry over; see
    /// [`vector_spec`](Self::vector_spec).
    pub fn spec(&self) -> MaskSpec {
        MaskSpec {
            width: self.size.0,
            height: self.size.1,
            depth: self.size.2,
            seed: self.seed,
            sigma_xy: self.sigma,
            sigma_z: self.sigma_time,
            initial_density: self.density,
            topology: match self.kind.method() {
                Method::VoidAndCluster(topology) => topology,
                _ => EnergyTopology::Independent2D,
            },
            kernel_tolerance: self.kernel_tolerance,
        }
    }

    /// The filter-adapted optimiser's input and the vector space (`None`: scalar) of
    /// `FilterAdapted` masks; `None` for other kinds.
    pub fn filter_adapted_spec(&self) -> Option<(FilterAdaptedSpec, Option<SampleSpace>)> {
        if self.kind != MaskKind::FilterAdapted {
            return None;
        }
        let space = self.space.and_then(|kind| kind.sample_space(None));
        let mut spec = FilterAdaptedSpec::new(self.size.0, self.size.1, self.size.2, self.seed)
            .with_filters(
                self.spatial_filter,
                self.temporal_filter,
                self.filter_combination,
            )
            .with_swaps_per_pixel(self.swaps_per_pixel);
        spec.kernel_tolerance = self.kernel_tolerance;
        Some((spec, space))
    }

    /// The swap optimiser's input for vector kinds; `None` for scalar kinds.
    pub fn vector_spec(&self) -> Option<VectorSpec> {
        let space = self
            .kind
            .sample_space(self.image.as_ref().map(|image| &image.pdf))?;
        let mut spec = VectorSpec::new(self.size.0, self.size.1, self.size.2, self.seed, space);
        spec.sigma_image = self.sigma;
        spec.sigma_value = self.sigma_value;
        spec.swaps_per_pixel = self.swaps_per_pixel;
        spec.assignment_passes = self.assignment_passes;
        spec.kernel_tolerance = self.kernel_tolerance;
        Some(spec)
    }

    /// The name of the generated static: `name` in upper case (`scalar_64` → `SCALAR_64`).
    pub fn static_name(&self) -> String {
        self.name.to_ascii_uppercase()
    }
}

/// A parsed and validated manifest.
#[derive(Clone, Debug, PartialEq)]
pub struct Manifest {
    path: PathBuf,
    masks: Vec<MaskEntry>,
    /// Where each mask's `name` value starts.
    name_positions: Vec<Pos>,
}

impl Manifest {
    /// Largest manifest file [`load`](Self::load) reads, in bytes (16 MiB); checked before
    /// reading.
    pub const MAX_FILE_BYTES: u64 = 16 << 20;

    /// Most masks one manifest may declare. Each becomes a static and a cache entry, and
    /// `stbn-gen generate` keeps a few kilobytes of figures per mask for its report.
    pub const MAX_MASKS: usize = 1024;

    /// Longest mask name, in characters (ASCII). Every file named after a mask stays within the
    /// 255-byte file-name limit of common file systems: `<name>_<frame>.png` (frames up to
    /// 65536), `<name>_trace.csv`, `<name>.stbn` and the report's `<index>_<name>_xy.png`.
    pub const MAX_NAME_LEN: usize = 128;

    /// Reads and parses the manifest at `path`.
    ///
    /// Only a regular file of at most [`Manifest::MAX_FILE_BYTES`] bytes is read (a FIFO or
    /// device is refused before reading), in one read.
    ///
    /// # Errors
    /// [`Error::Io`] if the file cannot be read, is not a regular file, is too large or is not
    /// UTF-8; [`Error::Manifest`] as for [`parse`](Self::parse).
    pub fn load(path: impl AsRef<Path>) -> Result<Manifest, Error> {
        let path = path.as_ref();
        let read_error = |e| Error::io("read the manifest", path, e);
        let bytes =
            stbn_gen::file::read_regular_file(path, Self::MAX_FILE_BYTES).map_err(read_error)?;
        let text = String::from_utf8(bytes).map_err(|e| {
            let at = e.utf8_error().valid_up_to();
            read_error(std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!("it is not UTF-8 text (invalid byte at offset {at})"),
            ))
        })?;
        Ok(Manifest::parse(&text, path)?)
    }

    /// An error about mask `index`'s `name`, located where the name is written: for checks that
    /// a user of the manifest adds (names a tool reserves, say).
    ///
    /// # Panics
    /// If `index` is not a mask of the manifest.
    pub fn name_error(&self, index: usize, message: impl Into<String>) -> ManifestError {
        let pos = self.name_positions[index];
        ManifestError {
            path: self.path.clone().into(),
            line: pos.line,
            column: pos.col,
            mask_index: Some(index),
            mask_name: Some(self.masks[index].name.clone()),
            field: Some("name".to_owned()),
            message: message.into(),
        }
    }

    /// Parses and validates manifest `text`; `path` is only used in error messages.
    ///
    /// # Errors
    /// Text longer than [`Manifest::MAX_FILE_BYTES`] is refused before it is parsed. Otherwise
    /// the first problem in document order: a syntax or type error, an unknown or missing field,
    /// more than [`Manifest::MAX_MASKS`] masks, a name that is not an ASCII Rust identifier (or
    /// is a keyword, or is longer than [`Manifest::MAX_NAME_LEN`]), a name that duplicates an
    /// earlier one (compared in upper case), or a value out of range. A leading UTF-8 byte-order
    /// mark is skipped (lines and columns count as an editor shows them, without it).
    pub fn parse(text: &str, path: impl AsRef<Path>) -> Result<Manifest, ManifestError> {
        if text.len() as u64 > Self::MAX_FILE_BYTES {
            return Err(ManifestError {
                path: path.as_ref().into(),
                line: 1,
                column: 1,
                mask_index: None,
                mask_name: None,
                field: None,
                message: format!(
                    "the manifest is {} bytes; at most {} bytes ({} MiB) are read",
                    text.len(),
                    Self::MAX_FILE_BYTES,
                    Self::MAX_FILE_BYTES >> 20
                ),
            });
        }
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let source = Source {
            text,
            path: path.as_ref(),
            map: SourceMap::scan(text),
        };
        let raw: RawManifest = ron::Options::default()
            .with_default_extension(Extensions::IMPLICIT_SOME)
            .from_str(text)
            .map_err(|e| source.ron_error(&e))?;
        if raw.masks.len() > Self::MAX_MASKS {
            let pos = source.map.masks.get(Self::MAX_MASKS).map_or(
                Pos {
                    offset: 0,
                    line: 1,
                    col: 1,
                },
                |m| m.start,
            );
            return Err(ManifestError {
                path: source.path.into(),
                line: pos.line,
                column: pos.col,
                mask_index: Some(Self::MAX_MASKS),
                mask_name: raw.masks[Self::MAX_MASKS].name.clone().into(),
                field: None,
                message: format!(
                    "the manifest declares {} masks; at most {} are allowed (split it)",
                    raw.masks.len(),
                    Self::MAX_MASKS
                ),
            });
        }
        let mut masks = Vec::with_capacity(raw.masks.len());
        let mut statics: HashMap<String, usize> = HashMap::new();
        let base_dir = path.as_ref().parent().unwrap_or(Path::new(""));
        for (index, raw) in raw.masks.into_iter().enumerate() {
            let mut entry = raw.resolve();
            let field_error = |field: &str, message: String| {
                source.field_error(index, &entry.name, field, message)
            };
            check_identifier(&entry.name).map_err(|m| field_error("name", m))?;
            if let Some(field) = raw
                .written_fields()
                .into_iter()
                .find(|field| !applies(entry.kind, field))
            {
                return Err(field_error(
                    field,
                    format!(
                        "does not apply to {:?} masks (it applies to {})",
                        entry.kind,
                        applies_to(field)
                    ),
                ));
            }
            match (&raw.image, entry.kind.needs_image()) {
                (None, true) => {
                    return Err(field_error(
                        "image",
                        format!(
                            "missing: {:?} masks are importance-sampled from an image; add \
                             `image: \"path/to/file.hdr\"` (PNG or Radiance .hdr, relative to \
                             the manifest)",
                            entry.kind
                        ),
                    ));
                }
                (Some(file), true) => {
                    let image = load_image(&base_dir.join(file))
                        .map_err(|message| field_error("image", message))?;
                    entry.image = Some(image);
                }
                // A written `image` on another kind was refused above.
                _ => {}
            }
            if let Some(&first) = statics.get(&entry.static_name()) {
                let other: &MaskEntry = &masks[first];
                let line = source.field_pos(first, "name").line;
                return Err(field_error(
                    "name",
                    format!(
                        "duplicates mask {:?} (line {line}): both would become the static {}",
                        other.name,
                        entry.static_name()
                    ),
                ));
            }
            if let Some(space) = entry.space
                && space.sample_space(None).is_none()
            {
                return Err(field_error(
                    "space",
                    format!(
                        "{space:?} is not a vector kind without an image; use one of {}",
                        FILTER_ADAPTED_SPACES
                    ),
                ));
            }
            if entry.kind == MaskKind::FilterAdapted
                && raw.octahedral.is_some()
                && !entry.space.is_some_and(MaskKind::is_direction3)
            {
                return Err(field_error(
                    "octahedral",
                    "applies to FilterAdapted masks only with a 3D unit `space` (UnitVec3, \
                     UniformHemisphere or CosineHemisphere)"
                        .to_owned(),
                ));
            }
            if let Some((spec, space)) = entry.filter_adapted_spec() {
                let validated = match space {
                    Some(space) => spec.clone().with_space(space).validate(),
                    None => spec.validate(),
                };
                if let Err(e) = validated {
                    let (field, message) = match &e {
                        FilterAdaptedSpecError::Spec(e) => spec_error_field(e, false),
                        FilterAdaptedSpecError::Filter { field, message } => {
                            (*field, compact_numbers(message, number).into_owned())
                        }
                        FilterAdaptedSpecError::InvalidBudget(value) => (
                            "swaps_per_pixel",
                            format!(
                                "must be in 0..={} (got {})",
                                FilterAdaptedSpec::MAX_SWAPS_PER_PIXEL,
                                number(*value)
                            ),
                        ),
                        // Every space a manifest names is valid; keep the message if that changes.
                        FilterAdaptedSpecError::InvalidDims(_) => ("space", e.to_string()),
                    };
                    return Err(field_error(field, message));
                }
                statics.insert(entry.static_name(), index);
                masks.push(entry);
                continue;
            }
            let validated = match entry.vector_spec() {
                Some(vector) => vector.validate(),
                None => entry.spec().validate().map_err(VectorSpecError::Spec),
            };
            if let Err(e) = validated {
                let (field, message) = match &e {
                    VectorSpecError::Spec(e) => spec_error_field(e, raw.sigma_time.is_some()),
                    VectorSpecError::TooLarge { .. } => ("size", e.to_string()),
                    VectorSpecError::InvalidBudget(value) => (
                        "swaps_per_pixel",
                        format!(
                            "must be in 0..={} (got {})",
                            VectorSpec::MAX_SWAPS_PER_PIXEL,
                            number(*value)
                        ),
                    ),
                    VectorSpecError::InvalidAssignmentPasses(value) => (
                        "assignment_passes",
                        format!(
                            "must be in 0..={} (got {value})",
                            VectorSpec::MAX_ASSIGNMENT_PASSES
                        ),
                    ),
                    // Every Vec kind has 1..=4 dimensions; keep the message if that changes.
                    VectorSpecError::InvalidDims(_) => ("kind", e.to_string()),
                };
                return Err(field_error(field, message));
            }
            statics.insert(entry.static_name(), index);
            masks.push(entry);
        }
        let name_positions = (0..masks.len())
            .map(|index| source.field_pos(index, "name"))
            .collect();
        Ok(Manifest {
            path: path.as_ref().to_owned(),
            masks,
            name_positions,
        })
    }

    /// The manifest's path, as given to [`load`](Self::load) or [`parse`](Self::parse).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The masks in manifest order.
    pub fn masks(&self) -> &[MaskEntry] {
        &self.masks
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename = "Manifest")]
struct RawManifest {
    masks: Vec<RawMask>,
}

#[derive(Clone, Deserialize)]
#[serde(deny_unknown_fields, rename = "Mask")]
struct RawMask {
    name: String,
    kind: MaskKind,
    size: (u32, u32, u32),
    seed: u64,
    #[serde(default)]
    sigma: Option<f64>,
    #[serde(default)]
    sigma_time: Option<f64>,
    #[serde(default)]
    density: Option<f64>,
    #[serde(default)]
    kernel_tolerance: Option<f64>,
    #[serde(default)]
    sigma_value: Option<f64>,
    #[serde(default)]
    swaps_per_pixel: Option<f64>,
    #[serde(default)]
    assignment_passes: Option<u32>,
    #[serde(default)]
    image: Option<String>,
    #[serde(default)]
    octahedral: Option<bool>,
    #[serde(default)]
    spatial_filter: Option<RawSpatialFilter>,
    #[serde(default)]
    temporal_filter: Option<RawTemporalFilter>,
    #[serde(default)]
    filter_combination: Option<RawCombination>,
    #[serde(default)]
    space: Option<MaskKind>,
    #[serde(with = "EncodingDef")]
    encoding: Encoding,
    #[serde(default = "no_compression", with = "CompressionDef")]
    compression: Compression,
}

impl RawMask {
    /// The optional fields this entry writes.
    fn written_fields(&self) -> Vec<&'static str> {
        [
            ("sigma", self.sigma.is_some()),
            ("sigma_time", self.sigma_time.is_some()),
            ("density", self.density.is_some()),
            ("kernel_tolerance", self.kernel_tolerance.is_some()),
            ("sigma_value", self.sigma_value.is_some()),
            ("swaps_per_pixel", self.swaps_per_pixel.is_some()),
            ("assignment_passes", self.assignment_passes.is_some()),
            ("image", self.image.is_some()),
            ("octahedral", self.octahedral.is_some()),
            ("spatial_filter", self.spatial_filter.is_some()),
            ("temporal_filter", self.temporal_filter.is_some()),
            ("filter_combination", self.filter_combination.is_some()),
            ("space", self.space.is_some()),
        ]
        .into_iter()
        .filter_map(|(field, written)| written.then_some(field))
        .collect()
    }

    /// The entry with defaults filled in (the image is loaded by the caller).
    fn resolve(&self) -> MaskEntry {
        let default_sigma = match self.kind.method() {
            Method::Baseline(kind) => kind.default_sigma(),
            _ => MaskSpec::DEFAULT_SIGMA,
        };
        let sigma = self.sigma.unwrap_or(default_sigma);
        let vector_defaults = VectorSpec::new(1, 1, 1, 0, SampleSpace::Vec { dims: 1 });
        let default_swaps = match self.kind {
            MaskKind::FilterAdapted => FilterAdaptedSpec::DEFAULT_SWAPS_PER_PIXEL,
            _ => vector_defaults.swaps_per_pixel,
        };
        MaskEntry {
            name: self.name.clone(),
            kind: self.kind,
            size: self.size,
            seed: self.seed,
            sigma,
            sigma_time: self.sigma_time.unwrap_or(sigma),
            density: self.density.unwrap_or(MaskSpec::DEFAULT_DENSITY),
            kernel_tolerance: self
                .kernel_tolerance
                .unwrap_or(MaskSpec::DEFAULT_KERNEL_TOLERANCE),
            sigma_value: self.sigma_value.unwrap_or(vector_defaults.sigma_value),
            swaps_per_pixel: self.swaps_per_pixel.unwrap_or(default_swaps),
            assignment_passes: self
                .assignment_passes
                .unwrap_or(vector_defaults.assignment_passes),
            image: None,
            octahedral: self.octahedral.unwrap_or(true),
            spatial_filter: self
                .spatial_filter
                .map_or(SpatialFilter::DEFAULT, RawSpatialFilter::resolve),
            temporal_filter: self
                .temporal_filter
                .map_or(TemporalFilter::DEFAULT, RawTemporalFilter::resolve),
            filter_combination: self
                .filter_combination
                .map_or(FilterCombination::Product, RawCombination::resolve),
            space: self.space,
            encoding: self.encoding,
            compression: self.compression,
        }
    }
}

fn no_compression() -> Compression {
    Compression::None
}

/// The values `space` takes, for messages.
const FILTER_ADAPTED_SPACES: &str = "`Vec1`, `Vec2`, `Vec3`, `Vec4`, `UnitVec1`, `UnitVec2`, \
     `UnitVec3`, `UniformHemisphere`, `CosineHemisphere`";

/// `spatial_filter` as written: `Gaussian(σ)`, `Box(size)` or `Binomial(order)`.
#[derive(Clone, Copy, Deserialize)]
#[serde(rename = "SpatialFilter")]
enum RawSpatialFilter {
    Gaussian(f64),
    Box(u32),
    Binomial(u32),
}

impl RawSpatialFilter {
    fn resolve(self) -> SpatialFilter {
        match self {
            RawSpatialFilter::Gaussian(sigma) => SpatialFilter::Gaussian { sigma },
            RawSpatialFilter::Box(size) => SpatialFilter::Box { size },
            RawSpatialFilter::Binomial(order) => SpatialFilter::Binomial { order },
        }
    }
}

/// `temporal_filter` as written: `Gaussian(σ)`, `Box(frames)`, `Exponential(α)` or
/// `ExponentialHistory(α, β)`.
#[derive(Clone, Copy, Deserialize)]
#[serde(rename = "TemporalFilter")]
enum RawTemporalFilter {
    Gaussian(f64),
    Box(u32),
    Exponential(f64),
    ExponentialHistory(f64, f64),
}

impl RawTemporalFilter {
    fn resolve(self) -> TemporalFilter {
        match self {
            RawTemporalFilter::Gaussian(sigma) => TemporalFilter::Gaussian { sigma },
            RawTemporalFilter::Box(size) => TemporalFilter::Box { size },
            RawTemporalFilter::Exponential(alpha) => TemporalFilter::Exponential { alpha },
            RawTemporalFilter::ExponentialHistory(alpha, beta) => {
                TemporalFilter::ExponentialHistory { alpha, beta }
            }
        }
    }
}

/// `filter_combination` as written: `Product` or `Separate(spatial_weight)`.
#[derive(Clone, Copy, Deserialize)]
#[serde(rename = "FilterCombination")]
enum RawCombination {
    Product,
    Separate(f64),
}

impl RawCombination {
    fn resolve(self) -> FilterCombination {
        match self {
            RawCombination::Product => FilterCombination::Product,
            RawCombination::Separate(spatial_weight) => {
                FilterCombination::Separate { spatial_weight }
            }
        }
    }
}

/// Whether the optional `field` applies to masks of `kind`.
fn applies(kind: MaskKind, field: &str) -> bool {
    match (kind.method(), field) {
        (Method::VoidAndCluster(_), "sigma" | "sigma_time" | "density" | "kernel_tolerance") => {
            true
        }
        (
            Method::Baseline(BaselineKind::GoldenRatio2D | BaselineKind::RandomShift2D),
            "sigma" | "density" | "kernel_tolerance",
        ) => true,
        (Method::Baseline(BaselineKind::TellusimLayered), "sigma" | "density") => true,
        (
            Method::Swap,
            "sigma" | "sigma_value" | "swaps_per_pixel" | "assignment_passes" | "kernel_tolerance",
        ) => true,
        (Method::Swap, "image") => kind.needs_image(),
        (Method::Swap, "octahedral") => kind.is_direction3(),
        (
            Method::FilterAdapted,
            "spatial_filter" | "temporal_filter" | "filter_combination" | "space"
            | "swaps_per_pixel" | "kernel_tolerance" | "octahedral",
        ) => true,
        _ => false,
    }
}

/// The kinds an optional field applies to, for error messages.
fn applies_to(field: &str) -> &'static str {
    match field {
        "sigma" => "every kind but White and FilterAdapted",
        "sigma_time" => "Scalar, Blue2D and Blue3D",
        "density" => "Scalar, Blue2D, Blue3D, GoldenRatio2D, RandomShift2D and TellusimLayered",
        "kernel_tolerance" => {
            "Scalar, Blue2D, Blue3D, GoldenRatio2D, RandomShift2D, the vector kinds and \
             FilterAdapted"
        }
        "sigma_value" => "the vector kinds (Vec1 … EnvironmentMap)",
        "swaps_per_pixel" => "the vector kinds (Vec1 … EnvironmentMap) and FilterAdapted",
        "assignment_passes" => "the vector kinds (Vec1 … EnvironmentMap)",
        "image" => "ImagePoints and EnvironmentMap",
        "octahedral" => {
            "UnitVec3, UniformHemisphere, CosineHemisphere, EnvironmentMap and FilterAdapted \
             with such a `space`"
        }
        "spatial_filter" | "temporal_filter" | "filter_combination" | "space" => "FilterAdapted",
        _ => "no kind",
    }
}

/// Reads (once: a regular file within [`ImagePdf::MAX_FILE_BYTES`]) and checks the image at
/// `path`; the error message names the file.
#[cfg(feature = "images")]
fn load_image(path: &Path) -> Result<ImageSource, String> {
    let shown = path.display().to_string();
    let bytes = stbn_gen::file::read_regular_file(path, ImagePdf::MAX_FILE_BYTES)
        .map_err(|e| format!("cannot read {}: {e}", excerpt(&shown)))?;
    let pdf = ImagePdf::decode(path, &bytes)
        .map_err(|e| e.to_string().replace(&shown, &excerpt(&shown)))?;
    Ok(ImageSource {
        path: path.to_owned(),
        hash: blake3::hash(&bytes),
        pdf: Arc::new(pdf),
    })
}

/// Without the `images` feature no image is read: the error says which feature to enable.
#[cfg(not(feature = "images"))]
fn load_image(path: &Path) -> Result<ImageSource, String> {
    Err(format!(
        "reading {} needs the `images` feature of stbn-build-support; enable it where the \
         build script depends on it: `stbn-build-support = {{ version = \"{}\", features = \
         [\"images\"] }}` under `[build-dependencies]`",
        excerpt(&path.display().to_string()),
        env!("CARGO_PKG_VERSION")
    ))
}

/// Deserialises [`stbn_runtime::Encoding`], which has no serde support of its own.
#[derive(Deserialize)]
#[serde(remote = "Encoding", rename = "Encoding")]
enum EncodingDef {
    Unorm8,
    Unorm16,
    F32,
}

/// Deserialises [`stbn_runtime::Compression`].
#[derive(Deserialize)]
#[serde(remote = "Compression", rename = "Compression")]
enum CompressionDef {
    None,
    Lz4,
    Deflate,
    Palette,
}

/// Strict and reserved keywords of Rust 2024 (a mask name must not be one).
const KEYWORDS: &[&str] = &[
    "abstract", "as", "async", "await", "become", "box", "break", "const", "continue", "crate",
    "do", "dyn", "else", "enum", "extern", "false", "final", "fn", "for", "gen", "if", "impl",
    "in", "let", "loop", "macro", "match", "mod", "move", "mut", "override", "priv", "pub", "ref",
    "return", "self", "Self", "static", "struct", "super", "trait", "true", "try", "type",
    "typeof", "unsafe", "unsized", "use", "virtual", "where", "while", "yield",
];

/// Checks that `name` is an ASCII Rust identifier, not a keyword, and at most
/// [`Manifest::MAX_NAME_LEN`] characters long.
fn check_identifier(name: &str) -> Result<(), String> {
    let mut chars = name.chars();
    let identifier = name != "_"
        && chars
            .next()
            .is_some_and(|c| c == '_' || c.is_ascii_alphabetic())
        && chars.all(|c| c == '_' || c.is_ascii_alphanumeric());
    if !identifier {
        Err(format!(
            "{} is not a Rust identifier: use ASCII letters, digits and `_`, \
             not starting with a digit (the name becomes a static and a file name)",
            quoted(name)
        ))
    } else if KEYWORDS.contains(&name) {
        Err(format!("{name:?} is a Rust keyword"))
    } else if name.len() > Manifest::MAX_NAME_LEN {
        Err(format!(
            "is {} characters long; at most {} are allowed (the name becomes file names, which \
             file systems limit to 255 bytes)",
            name.len(),
            Manifest::MAX_NAME_LEN
        ))
    } else {
        Ok(())
    }
}

/// The manifest field a [`SpecError`] is about, and the message to show there.
fn spec_error_field(error: &SpecError, has_sigma_time: bool) -> (&'static str, String) {
    match error {
        SpecError::AxisOutOfRange { field, value } => {
            let axis = match *field {
                "width" => "width (first element)",
                "height" => "height (second element)",
                _ => "frames (third element)",
            };
            (
                "size",
                format!(
                    "{axis} is {value}; it must be in 1..={}",
                    MaskSpec::MAX_AXIS
                ),
            )
        }
        SpecError::TooLarge { .. } => ("size", error.to_string()),
        SpecError::InvalidSigma { field, value } => (
            sigma_field(field, has_sigma_time),
            format!("must be finite and > 0 (got {})", number(*value)),
        ),
        SpecError::SigmaTooSmall { field, value } => (
            sigma_field(field, has_sigma_time),
            format!(
                "must be at least {:e} (got {}): below it 1/σ² overflows and the kernel loses \
                 its centre pixel (at the default tolerance, any σ below about 0.3 already gives \
                 a kernel of the pixel alone)",
                MaskSpec::MIN_SIGMA,
                number(*value)
            ),
        ),
        SpecError::SigmaOutOfRange {
            field,
            value,
            range,
            reason,
        } => (
            sigma_field(field, has_sigma_time),
            format!(
                "must be {range} for this mask (got {}): {reason}",
                number(*value)
            ),
        ),
        SpecError::InvalidDensity(value) => (
            "density",
            format!("must be in (0, 0.5] (got {})", number(*value)),
        ),
        SpecError::InvalidTolerance(value) => (
            "kernel_tolerance",
            format!("must be in (0, 1) (got {})", number(*value)),
        ),
    }
}

/// The manifest field of the spec's σ field `field`.
fn sigma_field(field: &str, has_sigma_time: bool) -> &'static str {
    match field {
        "sigma_z" if has_sigma_time => "sigma_time",
        "sigma_value" => "sigma_value",
        _ => "sigma",
    }
}

/// The manifest text and what is known about where things are in it.
struct Source<'a> {
    text: &'a str,
    path: &'a Path,
    map: SourceMap,
}

impl Source<'_> {
    /// Where mask `index`'s `field` value starts; the entry's start if the field is not written,
    /// the start of the text if the entry cannot be found.
    fn field_pos(&self, index: usize, field: &str) -> Pos {
        let entry = self.map.masks.get(index);
        entry
            .and_then(|m| m.field(field))
            .map(|f| f.value)
            .or(entry.map(|m| m.start))
            .unwrap_or(Pos {
                offset: 0,
                line: 1,
                col: 1,
            })
    }

    /// An error in a parsed mask's field.
    fn field_error(&self, index: usize, name: &str, field: &str, message: String) -> ManifestError {
        let pos = self.field_pos(index, field);
        ManifestError {
            path: self.path.into(),
            line: pos.line,
            column: pos.col,
            mask_index: Some(index),
            mask_name: Some(name.to_owned()),
            field: Some(field.to_owned()),
            message,
        }
    }

    /// A ron error, completed with the mask and field it is in.
    fn ron_error(&self, error: &SpannedError) -> ManifestError {
        use ron::Error as E;

        // ron may point at the blank before the offending token; step onto the token.
        let token_at = |at: ron::error::Position| {
            let offset = self.map.offset_of(self.text, at.line, at.col);
            self.map.next_token(self.text, offset)
        };
        let mut start = token_at(error.span.start);
        // A text that stops inside a bracket: ron's complaint about what it expected next (an
        // opening `(` for a `Mask`, say) is about text that is not there. Said at the end.
        let at_end = start.offset == self.text.len()
            || (token_at(error.span.end).offset == self.text.len() && expects_more(&error.code));
        let unclosed = at_end.then(|| SourceMap::unclosed(self.text)).flatten();
        if unclosed.is_some() {
            start = self.map.next_token(self.text, self.text.len());
        }
        let (mut line, mut column, offset) = (start.line, start.col, start.offset);
        let located = self.map.locate(offset);
        let entry = located.and_then(|l| self.map.masks.get(l.mask));
        let mut field_index = located.and_then(|l| l.field);
        let (field, message) = if let Some(unclosed) = unclosed {
            (
                entry
                    .zip(field_index)
                    .map(|(entry, i)| entry.fields[i].name.clone()),
                self.ends_early(unclosed),
            )
        } else {
            match &error.code {
                E::NoSuchStructField {
                    expected, found, ..
                } => (
                    Some(found.clone()),
                    format!(
                        "unknown field; expected one of {}{}",
                        backticked(expected),
                        did_you_mean(found, expected)
                    ),
                ),
                E::MissingStructField { field, .. } => (
                    Some((*field).to_owned()),
                    "missing; this field has no default".to_owned(),
                ),
                E::DuplicateStructField { field, .. } => {
                    (Some((*field).to_owned()), "given more than once".to_owned())
                }
                code => {
                    // ron reports a missing comma at the start of the next field: the field that
                    // lacks it is the previous one, and the comma belongs right after its value.
                    if let (E::ExpectedComma, Some(entry), Some(i)) = (code, entry, field_index)
                        && i > 0
                        && entry.fields[i].key.offset == offset
                    {
                        field_index = Some(i - 1);
                        let end = entry.fields[i - 1].value_end;
                        (line, column) = (end.line, end.col);
                    }
                    let field = entry
                        .zip(field_index)
                        .map(|(entry, i)| entry.fields[i].name.clone());
                    let ron_message = lowercase_first(&shorten_quoted(&code.to_string()));
                    // ron reads `1.5` for an integer as `1` followed by a stray `.5`.
                    let fraction = match (code, entry, field_index) {
                        (E::ExpectedComma, Some(entry), Some(i))
                            if entry.fields[i].value.offset < offset
                                && self.text[offset..].starts_with(['.', 'e', 'E'])
                                && self.text[..offset].ends_with(|c: char| c.is_ascii_digit()) =>
                        {
                            let field = &entry.fields[i];
                            self.text.get(field.value.offset..field.value_end.offset)
                        }
                        _ => None,
                    };
                    let integer_range = match code {
                        E::IntegerOutOfBounds => field.as_deref().and_then(|f| {
                            integer_range(f, self.written_variant(entry, field_index))
                        }),
                        _ => None,
                    };
                    let message = if (line, column) != (start.line, start.col) {
                        "expected `,` after this field's value".to_owned()
                    } else if let Some(value) = fraction {
                        format!(
                            "expected an integer (this field takes whole numbers), found {}",
                            quote::backticked(value)
                        )
                    } else if let Some(range) = integer_range {
                        let (written, sign) = integer_at(self.text, offset);
                        // Point at the sign ron steps over.
                        column -= sign;
                        format!("{range} (got {})", excerpt(written))
                    } else if let (false, Some(variants)) = (
                        matches!(code, E::NoSuchEnumVariant { .. }),
                        field.as_deref().and_then(enum_variants),
                    ) {
                        format!("expected one of {variants} ({ron_message})")
                    } else if let E::NoSuchEnumVariant {
                        expected, found, ..
                    } = code
                    {
                        format!("{ron_message}{}", did_you_mean(found, expected))
                    } else {
                        ron_message
                    };
                    (field, message)
                }
            }
        };
        ManifestError {
            path: self.path.into(),
            line,
            column,
            mask_index: located.map(|l| l.mask),
            mask_name: entry.and_then(|m| m.name.clone()),
            field,
            message,
        }
    }

    /// The message for a text that ends with `unclosed` still open.
    fn ends_early(&self, unclosed: Unclosed) -> String {
        let Unclosed { bracket, pos } = unclosed;
        let of = if Some(pos) == self.map.list_start {
            " of the `masks` list".to_owned()
        } else {
            match self.map.locate(pos.offset) {
                Some(Located { mask, field: None }) if bracket == '(' => {
                    format!(" of mask entry #{}", mask + 1)
                }
                _ => String::new(),
            }
        };
        format!(
            "the file ends early: the `{bracket}`{of} at line {}, column {} is never closed",
            pos.line, pos.col
        )
    }

    /// The variant name a field's value starts with (`Box` of `Box(70000)`), if any.
    fn written_variant(&self, entry: Option<&MaskSource>, field: Option<usize>) -> Option<&str> {
        let field = entry?.fields.get(field?)?;
        let value = self.text.get(field.value.offset..field.value_end.offset)?;
        let end = value
            .find(|c: char| !(c == '_' || c.is_ascii_alphanumeric()))
            .unwrap_or(value.len());
        Some(&value[..end])
    }
}

/// What an out-of-bounds integer in `field` must be, for the fields that hold integers;
/// `variant` is the filter variant the value is written in (`Box`, `Binomial`).
fn integer_range(field: &str, variant: Option<&str>) -> Option<String> {
    Some(match (field, variant) {
        ("seed", _) => format!("must be in 0..={}", u64::MAX),
        ("size", _) => format!("each element must be in 1..={}", MaskSpec::MAX_AXIS),
        ("assignment_passes", _) => {
            format!("must be in 0..={}", VectorSpec::MAX_ASSIGNMENT_PASSES)
        }
        ("spatial_filter", Some("Box")) => {
            format!("Box size must be in 1..={}", SpatialFilter::MAX_SIZE)
        }
        ("spatial_filter", Some("Binomial")) => {
            format!("Binomial order must be in 1..={}", SpatialFilter::MAX_ORDER)
        }
        ("temporal_filter", Some("Box")) => {
            format!("Box size must be in 1..={}", TemporalFilter::MAX_SIZE)
        }
        _ => return None,
    })
}

/// The integer as written at byte `offset` of `text`, its sign included, and the length of a sign
/// just before `offset` (ron points past it).
fn integer_at(text: &str, offset: usize) -> (&str, usize) {
    let sign = usize::from(text[..offset].ends_with(['-', '+']));
    let end = text[offset..]
        .find(|c: char| !(c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '+')))
        .map_or(text.len(), |i| offset + i);
    (&text[offset - sign..end], sign)
}

/// Whether ron's `code` says that more text was expected: at the end of the text, the text ended
/// too early.
fn expects_more(code: &ron::Error) -> bool {
    use ron::Error as E;
    matches!(
        code,
        E::Eof
            | E::ExpectedArray
            | E::ExpectedArrayEnd
            | E::ExpectedBoolean
            | E::ExpectedComma
            | E::ExpectedChar
            | E::ExpectedFloat
            | E::ExpectedInteger
            | E::ExpectedOption
            | E::ExpectedOptionEnd
            | E::ExpectedMap
            | E::ExpectedMapColon
            | E::ExpectedMapEnd
            | E::ExpectedStructLike
            | E::ExpectedNamedStructLike(_)
            | E::ExpectedStructLikeEnd
            | E::ExpectedUnit
            | E::ExpectedString
            | E::ExpectedStringEnd
            | E::ExpectedIdentifier
    )
}

/// The values of the enum-valued field `field`, for messages about malformed values.
fn enum_variants(field: &str) -> Option<&'static str> {
    match field {
        "kind" => Some(
            "`Scalar`, `Blue2D`, `Blue3D`, `White`, `GoldenRatio2D`, `RandomShift2D`, \
             `TellusimLayered`, `Vec1`, `Vec2`, `Vec3`, `Vec4`, `UnitVec1`, `UnitVec2`, \
             `UnitVec3`, `UniformHemisphere`, `CosineHemisphere`, `ImagePoints`, `EnvironmentMap`, \
             `FilterAdapted`",
        ),
        "space" => Some(FILTER_ADAPTED_SPACES),
        "spatial_filter" => Some("`Gaussian(σ)`, `Box(size)`, `Binomial(order)`"),
        "temporal_filter" => {
            Some("`Exponential(α)`, `ExponentialHistory(α, β)`, `Gaussian(σ)`, `Box(frames)`")
        }
        "filter_combination" => Some("`Product`, `Separate(spatial_weight)`"),
        "encoding" => Some("`Unorm8`, `Unorm16`, `F32`"),
        "compression" => Some("`None`, `Lz4`, `Deflate`, `Palette`"),
        _ => None,
    }
}

/// `` "; did you mean `name`?" `` for the candidate closest to the misspelt `found`, or `""` when
/// none is close: the same name in another case, or else the nearest within an edit distance of
/// a third of `found`'s length (at least 1; an edit inserts, deletes, replaces or swaps two
/// neighbouring characters). Ties go to the earlier candidate.
fn did_you_mean(found: &str, candidates: &[&str]) -> String {
    let length = found.chars().count();
    let limit = (length / 3).max(1);
    // No candidate whose length differs by more than the limit can be within it: a huge `found`
    // costs nothing.
    let near: Vec<&&str> = candidates
        .iter()
        .filter(|c| c.chars().count().abs_diff(length) <= limit)
        .collect();
    if near.is_empty() {
        return String::new();
    }
    let lower = found.to_lowercase();
    let closest = near
        .iter()
        .copied()
        .find(|c| c.to_lowercase() == lower)
        .or_else(|| {
            near.iter()
                .copied()
                .map(|c| (edit_distance(&lower, &c.to_lowercase()), c))
                .filter(|&(distance, _)| distance <= limit)
                .min_by_key(|&(distance, _)| distance)
                .map(|(_, c)| c)
        });
    closest.map_or_else(String::new, |c| format!("; did you mean `{c}`?"))
}

/// The optimal string alignment distance between `a` and `b`, in characters: the fewest
/// insertions, deletions, replacements and swaps of neighbouring characters that turn one into
/// the other (no substring edited twice).
fn edit_distance(a: &str, b: &str) -> usize {
    let (a, b): (Vec<char>, Vec<char>) = (a.chars().collect(), b.chars().collect());
    // rows[i][j]: distance between a[..i] and b[..j]; three rows are all the recurrence reads.
    let mut before: Vec<usize> = Vec::new();
    let mut previous: Vec<usize> = (0..=b.len()).collect();
    for i in 1..=a.len() {
        let mut row = vec![i; b.len() + 1];
        for j in 1..=b.len() {
            let replace = usize::from(a[i - 1] != b[j - 1]);
            row[j] = (previous[j] + 1)
                .min(row[j - 1] + 1)
                .min(previous[j - 1] + replace);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                row[j] = row[j].min(before[j - 2] + 1);
            }
        }
        before = std::mem::replace(&mut previous, row);
    }
    previous[b.len()]
}

/// `` `a`, `b`, `c` ``.
fn backticked(names: &[&str]) -> String {
    names
        .iter()
        .map(|n| format!("`{n}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// ron's messages start with a capital ("Expected integer"); ours continue a sentence. Leaves a
/// first word with further capitals (`NaN`, `RON`) alone.
fn lowercase_first(message: &str) -> String {
    let first_word = message.split_whitespace().next().unwrap_or_default();
    let mut chars = first_word.chars();
    let capitalised =
        chars.next().is_some_and(char::is_uppercase) && !chars.any(char::is_uppercase);
    if capitalised {
        let mut chars = message.chars();
        chars
            .next()
            .into_iter()
            .flat_map(char::to_lowercase)
            .chain(chars)
            .collect()
    } else {
        message.to_owned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A one-mask manifest; `fields` (whole lines) go after `encoding`, from line 9 on.
    fn manifest(fields: &str) -> String {
        let head = r#"(
    masks: [
        (
            name: "a",
            kind: Scalar,
            size: (8, 8, 4),
            seed: 1,
            encoding: Unorm8,
"#;
        format!("{head}{fields}        ),\n    ],\n)\n")
    }

    /// Without the `images` feature an image kind is refused at its `image` field, naming the
    /// feature; with it, the file is read (here: not a decodable PNG).
    #[test]
    fn image_kinds_need_the_images_feature() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("sky.png"), b"not a png").unwrap();
        let text = manifest("            image: \"sky.png\",\n")
            .replace("kind: Scalar", "kind: EnvironmentMap");
        let path = dir.path().join("assets.ron");
        let error = Manifest::parse(&text, &path).unwrap_err();
        assert_eq!(error.path(), path);
        assert_eq!((error.line(), error.column()), (9, 20), "{error}");
        assert_eq!(error.field(), Some("image"));
        let image = dir.path().join("sky.png");
        if cfg!(feature = "images") {
            assert!(error.message().contains("sky.png"), "{error}");
            assert!(!error.message().contains("feature"), "{error}");
        } else {
            assert_eq!(
                error.message(),
                format!(
                    "reading {} needs the `images` feature of stbn-build-support; enable it \
                     where the build script depends on it: `stbn-build-support = {{ version = \
                     \"{}\", features = [\"images\"] }}` under `[build-dependencies]`",
                    image.display(),
                    env!("CARGO_PKG_VERSION")
                )
            );
        }
    }

    #[test]
    fn defaults_fill_in() {
        let m = Manifest::parse(&manifest(""), "assets.ron").unwrap();
        let entry = &m.masks()[0];
        assert_eq!(entry.spec(), MaskSpec::new(8, 8, 4, 1));
        assert_eq!(entry.compression, Compression::None);
        assert_eq!(entry.static_name(), "A");
    }

    #[test]
    fn sigma_time_defaults_to_sigma_and_some_is_accepted() {
        let text = manifest("            sigma: Some(2.0),\n            compression: Deflate,\n");
        let m = Manifest::parse(&text, "m.ron").unwrap();
        let spec = m.masks()[0].spec();
        assert_eq!((spec.sigma_xy, spec.sigma_z), (2.0, 2.0));
        assert_eq!(m.masks()[0].compression, Compression::Deflate);
    }

    #[test]
    fn sigma_time_error_names_sigma_time() {
        let text = manifest("            sigma_time: -1.0,\n");
        let e = Manifest::parse(&text, "m.ron").unwrap_err();
        assert_eq!(
            (e.field(), e.line(), e.column()),
            (Some("sigma_time"), 9, 25)
        );
        assert_eq!(
            e.to_string(),
            "m.ron:9:25: mask \"a\", field `sigma_time`: must be finite and > 0 (got -1)"
        );
    }

    #[test]
    fn identifiers() {
        for ok in ["a", "_a", "scalar_64", "A1", "union", "raw"] {
            assert_eq!(check_identifier(ok), Ok(()), "{ok}");
        }
        for bad in [
            "", "_", "1a", "a-b", "a b", "é", "fn", "self", "Self", "gen",
        ] {
            assert!(check_identifier(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn tolerance_and_axis_messages() {
        let e = Manifest::parse(&manifest("            kernel_tolerance: 1.0,\n"), "m.ron")
            .unwrap_err();
        assert_eq!(e.field(), Some("kernel_tolerance"));
        assert_eq!(e.message(), "must be in (0, 1) (got 1)");
        let text = manifest("").replace("(8, 8, 4)", "(8, 70000, 4)");
        let e = Manifest::parse(&text, "m.ron").unwrap_err();
        assert_eq!(e.field(), Some("size"));
        assert_eq!(
            e.message(),
            "height (second element) is 70000; it must be in 1..=65536"
        );
    }

    #[test]
    fn assignment_passes_reach_the_vector_spec_and_only_vector_kinds() {
        let vec2 = manifest("").replace("kind: Scalar", "kind: Vec2");
        let entry = Manifest::parse(&vec2, "m.ron").unwrap().masks()[0].clone();
        assert_eq!(
            entry.vector_spec().unwrap().assignment_passes,
            VectorSpec::DEFAULT_ASSIGNMENT_PASSES
        );
        for passes in [0, 8] {
            let text = manifest(&format!("            assignment_passes: {passes},\n"))
                .replace("kind: Scalar", "kind: Vec2");
            let entry = Manifest::parse(&text, "m.ron").unwrap().masks()[0].clone();
            assert_eq!(entry.vector_spec().unwrap().assignment_passes, passes);
        }
        let text = manifest("            assignment_passes: 1001,\n")
            .replace("kind: Scalar", "kind: Vec2");
        let e = Manifest::parse(&text, "m.ron").unwrap_err();
        assert_eq!(e.field(), Some("assignment_passes"));
        assert_eq!(e.message(), "must be in 0..=1000 (got 1001)");
        for kind in ["Scalar", "FilterAdapted"] {
            let text = manifest("            assignment_passes: 8,\n")
                .replace("kind: Scalar", &format!("kind: {kind}"));
            let e = Manifest::parse(&text, "m.ron").unwrap_err();
            assert_eq!(e.field(), Some("assignment_passes"), "{kind}");
            assert!(e.message().contains("the vector kinds"), "{}", e.message());
        }
    }

    #[test]
    fn filter_adapted_fields_resolve_and_default() {
        let text = manifest("").replace("kind: Scalar", "kind: FilterAdapted");
        let entry = Manifest::parse(&text, "m.ron").unwrap().masks()[0].clone();
        let (spec, space) = entry.filter_adapted_spec().unwrap();
        assert_eq!(spec, FilterAdaptedSpec::new(8, 8, 4, 1));
        assert_eq!(space, None);
        assert!(entry.vector_spec().is_none());
        let fields = "            spatial_filter: Binomial(2),\n\
                      \x20           temporal_filter: ExponentialHistory(0.2, 0.05),\n\
                      \x20           filter_combination: Separate(0.25),\n\
                      \x20           space: UnitVec3,\n\
                      \x20           octahedral: false,\n\
                      \x20           swaps_per_pixel: 3.5,\n\
                      \x20           kernel_tolerance: 1e-2,\n";
        let text = manifest(fields).replace("kind: Scalar", "kind: FilterAdapted");
        let entry = Manifest::parse(&text, "m.ron").unwrap().masks()[0].clone();
        let (spec, space) = entry.filter_adapted_spec().unwrap();
        assert_eq!(spec.spatial_filter, SpatialFilter::Binomial { order: 2 });
        assert_eq!(
            spec.temporal_filter,
            TemporalFilter::ExponentialHistory {
                alpha: 0.2,
                beta: 0.05
            }
        );
        assert_eq!(
            spec.combination,
            FilterCombination::Separate {
                spatial_weight: 0.25
            }
        );
        assert_eq!((spec.swaps_per_pixel, spec.kernel_tolerance), (3.5, 1e-2));
        assert_eq!(spec.value_kernel, stbn_gen::ValueKernel::Distance);
        assert_eq!(space, Some(SampleSpace::UnitVec3));
        assert!(!entry.octahedral);
        // The filter fields belong to FilterAdapted only.
        let e = Manifest::parse(&manifest("            space: Vec2,\n"), "m.ron").unwrap_err();
        assert_eq!((e.field(), e.line()), (Some("space"), 9));
        assert!(e.message().contains("(it applies to FilterAdapted)"), "{e}");
    }

    #[test]
    fn edit_distances() {
        for (a, b, distance) in [
            ("", "", 0),
            ("", "seed", 4),
            ("seed", "seed", 0),
            ("densty", "density", 1),
            ("dencity", "density", 1),
            ("sede", "seed", 1),
            ("compresison", "compression", 1),
            ("kitten", "sitting", 3),
            ("ca", "abc", 3),
            ("σ", "s", 1),
        ] {
            assert_eq!(edit_distance(a, b), distance, "{a} → {b}");
            assert_eq!(edit_distance(b, a), distance, "{b} → {a}");
        }
    }

    #[test]
    fn suggestions() {
        let fields = ["sigma", "sigma_time", "seed", "size"];
        assert_eq!(
            did_you_mean("sigma_tme", &fields),
            "; did you mean `sigma_time`?"
        );
        assert_eq!(did_you_mean("SIGMA", &fields), "; did you mean `sigma`?");
        assert_eq!(did_you_mean("sized", &fields), "; did you mean `size`?");
        // Ties go to the earlier candidate.
        assert_eq!(
            did_you_mean("bat", &["cat", "bag"]),
            "; did you mean `cat`?"
        );
        assert_eq!(
            did_you_mean("bat", &["bag", "cat"]),
            "; did you mean `bag`?"
        );
        assert_eq!(did_you_mean("sed", &fields), "; did you mean `seed`?");
        assert_eq!(did_you_mean("sx", &fields), "");
        assert_eq!(did_you_mean("octahedral", &fields), "");
        // A third of the length: two edits allowed from six characters on.
        assert_eq!(
            did_you_mean("sgma_tme", &fields),
            "; did you mean `sigma_time`?"
        );
        assert_eq!(did_you_mean("sgm", &fields), "");
    }

    #[test]
    fn message_casing() {
        assert_eq!(lowercase_first("Expected integer"), "expected integer");
        assert_eq!(lowercase_first("NaN is not"), "NaN is not");
        assert_eq!(
            lowercase_first("Unexpected end of RON"),
            "unexpected end of RON"
        );
        assert_eq!(lowercase_first(""), "");
    }
}
