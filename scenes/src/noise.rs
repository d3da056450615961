//! The noise sources the scenes are rendered with, built by `stbn-gen` and encoded to `.stbn`
//! blobs, so that the renderers read them through the real runtime path ([`stbn_runtime::Stbn`]
//! on the CPU, [`stbn_runtime::gpu::create_texture_3d`] on the GPU).
//!
//! Scalar sources ([`NoiseKind::SCALAR`]) feed scenes that want one number per pixel; direction
//! sources ([`NoiseKind::DIRECTIONS`]) feed scenes that want a cosine-distributed hemisphere
//! direction ([`SceneInput`]). Every frame of every mask is an exactly stratified sample set
//! (scalar: each value `(rank + ½) / (width · height)` once; vectors: `stbn-gen`'s latinised
//! lattice), so the sources differ only in *where* the values sit.

use stbn_build_support::encode::{Layout, encode_vector, encode_volume};
use stbn_gen::{
    BaselineKind, BaselineSpec, EnergyTopology, InitialArrangement, MaskSpec, Observer,
    SampleSpace, VectorSpec, VectorSpecError, Volume, generate_baseline,
};
use stbn_runtime::{Compression, Encoding, Stbn};

use crate::sample::{FrameOrder, SampleMode};
use crate::scene::SceneInput;

/// Which noise a pixel reads its random numbers from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum NoiseKind {
    /// White noise: every frame an independent random permutation of the frame's values
    /// ([`BaselineKind::White`]; white in space and over time).
    White,
    /// Independent 2D blue noise per frame (void-and-cluster with
    /// [`EnergyTopology::Independent2D`]): blue in space, white over time.
    Blue2D,
    /// One 2D blue-noise frame animated by the golden ratio: frame `z` holds
    /// `fract(v + z · φ⁻¹)` on the rank grid ([`BaselineKind::GoldenRatio2D`]).
    GoldenRatio2D,
    /// Spatiotemporal blue noise ([`EnergyTopology::Spatiotemporal`]): blue in space and time.
    /// Read with plain [`Stbn::sample`], so frame `t` reads slice `t mod depth`: the sequence
    /// repeats every `depth` frames.
    Stbn,
    /// The [`NoiseKind::Stbn`] mask read through [`Stbn::progressive`]: frames `0..depth` are
    /// the mask itself, and each later pass through the depth reads it shifted toroidally by
    /// the pass's R2 offset, so a pixel keeps meeting new values past the depth.
    StbnProgressive,
    /// White cosine-hemisphere directions: each frame a stratified set of cosine-distributed
    /// directions in a random arrangement (a vector mask with no swaps and
    /// [`InitialArrangement::Random`]).
    WhiteVectors,
    /// Two dimensions of the scalar STBN mask (dimension 1 at the runtime's R2 offset) mapped to
    /// a cosine-distributed direction ([`crate::sample::cosine_direction`]).
    StbnPairs,
    /// Vector STBN of cosine-hemisphere directions (`stbn-gen`'s swap optimiser, default budget),
    /// stored octahedrally.
    StbnVectors,
}

impl NoiseKind {
    /// The scalar sources in table order.
    pub const SCALAR: [NoiseKind; 4] = [
        NoiseKind::White,
        NoiseKind::Blue2D,
        NoiseKind::GoldenRatio2D,
        NoiseKind::Stbn,
    ];

    /// The direction sources in table order.
    pub const DIRECTIONS: [NoiseKind; 3] = [
        NoiseKind::WhiteVectors,
        NoiseKind::StbnPairs,
        NoiseKind::StbnVectors,
    ];

    /// The sources for scenes that take `input`.
    pub fn for_input(input: SceneInput) -> &'static [NoiseKind] {
        match input {
            SceneInput::Scalar => &Self::SCALAR,
            SceneInput::Direction => &Self::DIRECTIONS,
        }
    }

    /// A short lowercase name for file names and CSV rows.
    pub fn name(self) -> &'static str {
        match self {
            NoiseKind::White => "white",
            NoiseKind::Blue2D => "blue2d",
            NoiseKind::GoldenRatio2D => "golden_ratio_2d",
            NoiseKind::Stbn => "stbn",
            NoiseKind::StbnProgressive => "stbn_progressive",
            NoiseKind::WhiteVectors => "white_vectors",
            NoiseKind::StbnPairs => "stbn_pairs",
            NoiseKind::StbnVectors => "stbn_vectors",
        }
    }

    /// A label for Markdown tables.
    pub fn label(self) -> &'static str {
        match self {
            NoiseKind::White => "white noise",
            NoiseKind::Blue2D => "2D blue noise, independent per frame",
            NoiseKind::GoldenRatio2D => "2D blue noise + golden ratio per frame",
            NoiseKind::Stbn => "STBN",
            NoiseKind::StbnProgressive => "STBN, progressive",
            NoiseKind::WhiteVectors => "white cosine vectors",
            NoiseKind::StbnPairs => "scalar STBN pairs → cosine",
            NoiseKind::StbnVectors => "vector STBN (cosine hemisphere)",
        }
    }

    /// Whether this is a spatiotemporal source (tables highlight the last one of their rows).
    pub fn is_stbn(self) -> bool {
        matches!(
            self,
            NoiseKind::Stbn | NoiseKind::StbnProgressive | NoiseKind::StbnVectors
        )
    }

    /// Which mask slice a pixel reads at each frame.
    pub fn frame_order(self) -> FrameOrder {
        match self {
            NoiseKind::StbnProgressive => FrameOrder::Progressive,
            _ => FrameOrder::Wrap,
        }
    }

    /// The source whose mask this one reads: [`NoiseKind::Stbn`] for the sources that read the
    /// STBN mask differently ([`NoiseKind::StbnPairs`], [`NoiseKind::StbnProgressive`]), else
    /// the source itself.
    pub fn mask_source(self) -> NoiseKind {
        match self {
            NoiseKind::StbnPairs | NoiseKind::StbnProgressive => NoiseKind::Stbn,
            kind => kind,
        }
    }

    /// How a pixel's sample is read from this source's mask.
    pub fn sample_mode(self) -> SampleMode {
        match self {
            NoiseKind::White
            | NoiseKind::Blue2D
            | NoiseKind::GoldenRatio2D
            | NoiseKind::Stbn
            | NoiseKind::StbnProgressive => SampleMode::Scalar,
            NoiseKind::StbnPairs => SampleMode::CosinePair,
            NoiseKind::WhiteVectors | NoiseKind::StbnVectors => SampleMode::Direction,
        }
    }

    /// What the source's samples are.
    pub fn input(self) -> SceneInput {
        self.sample_mode().input()
    }
}

/// Size, seed and storage of the masks a comparison uses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseSpec {
    /// Mask width in pixels (the image tiles it toroidally).
    pub width: u32,
    /// Mask height in pixels.
    pub height: u32,
    /// Frames before the mask repeats.
    pub depth: u32,
    /// Seed of every source (each derives its own generator state from it).
    pub seed: u64,
    /// How the blob stores each value (each component of a vector).
    pub encoding: Encoding,
}

/// One noise source as an uncompressed `.stbn` blob.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NoiseMask {
    /// Which source this is.
    pub kind: NoiseKind,
    /// A complete `.stbn` blob (header and payload), as `encode_volume` or `encode_vector`
    /// writes it.
    pub blob: Vec<u8>,
}

impl NoiseMask {
    /// Generates `kind` at `spec` and encodes it (no compression).
    pub fn generate(kind: NoiseKind, spec: &NoiseSpec) -> Result<NoiseMask, VectorSpecError> {
        let blob = match kind {
            NoiseKind::WhiteVectors | NoiseKind::StbnVectors => {
                let space = SampleSpace::CosineHemisphere;
                let mut vector = VectorSpec::new(
                    spec.width,
                    spec.height,
                    spec.depth,
                    spec.seed,
                    space.clone(),
                );
                if kind == NoiseKind::WhiteVectors {
                    vector = vector.unoptimised();
                    vector.initial_arrangement = InitialArrangement::Random;
                }
                let volume = stbn_gen::generate_vector(&vector, Observer::default())?;
                encode_vector(
                    &volume,
                    Layout::new(&space, true),
                    spec.encoding,
                    Compression::None,
                )
            }
            _ => encode_volume(&noise_volume(kind, spec)?, spec.encoding, Compression::None),
        };
        Ok(NoiseMask { kind, blob })
    }

    /// The runtime's view of the blob (validates header and CRC).
    pub fn view(&self) -> Stbn<'_> {
        Stbn::from_bytes(&self.blob).expect("the encoder writes valid blobs")
    }
}

/// Generates every source of `kinds` at `spec`; sources that read one mask
/// ([`NoiseKind::mask_source`]) share a single generation.
pub fn generate_all(
    kinds: &[NoiseKind],
    spec: &NoiseSpec,
) -> Result<Vec<NoiseMask>, VectorSpecError> {
    let mut masks: Vec<NoiseMask> = Vec::with_capacity(kinds.len());
    for &kind in kinds {
        let shared = masks
            .iter()
            .find(|m| m.kind.mask_source() == kind.mask_source());
        let blob = match shared {
            Some(mask) => mask.blob.clone(),
            None => NoiseMask::generate(kind, spec)?.blob,
        };
        masks.push(NoiseMask { kind, blob });
    }
    Ok(masks)
}

/// The masks of the past-depth comparison, for runs of `frames` frames, in table order: white
/// noise with one slice per frame (`max(spec.depth, frames)` deep, so it never repeats: the
/// reference of independent samples, which a white mask read past its depth is not), then the
/// STBN mask at `spec` read with plain `sample` ([`NoiseKind::Stbn`], repeating every `depth`
/// frames) and progressively ([`NoiseKind::StbnProgressive`]).
pub fn generate_past_depth(
    spec: &NoiseSpec,
    frames: u32,
) -> Result<Vec<NoiseMask>, VectorSpecError> {
    let white = NoiseSpec {
        depth: spec.depth.max(frames),
        ..*spec
    };
    let mut masks = vec![NoiseMask::generate(NoiseKind::White, &white)?];
    masks.extend(generate_all(
        &[NoiseKind::Stbn, NoiseKind::StbnProgressive],
        spec,
    )?);
    Ok(masks)
}

/// The scalar [`Volume`] of `kind` at `spec`: [`stbn_gen::generate`] for the void-and-cluster
/// masks ([`NoiseKind::StbnPairs`] and [`NoiseKind::StbnProgressive`] read the
/// [`NoiseKind::Stbn`] mask), [`generate_baseline`] for white noise and the golden-ratio
/// animation (all with the paper's σ 1.9 and density 0.1).
///
/// Panics for the vector kinds, which have no scalar volume.
pub fn noise_volume(kind: NoiseKind, spec: &NoiseSpec) -> Result<Volume, VectorSpecError> {
    let mask = MaskSpec::new(spec.width, spec.height, spec.depth, spec.seed);
    let baseline = |kind| {
        let spec = BaselineSpec {
            kind,
            mask: mask.clone(),
        };
        generate_baseline(&spec, Observer::default())
    };
    Ok(match kind {
        NoiseKind::Stbn | NoiseKind::StbnPairs | NoiseKind::StbnProgressive => {
            stbn_gen::generate(&mask, Observer::default())?
        }
        NoiseKind::Blue2D => {
            let mask = mask.with_topology(EnergyTopology::Independent2D);
            stbn_gen::generate(&mask, Observer::default())?
        }
        NoiseKind::White => baseline(BaselineKind::White)?,
        NoiseKind::GoldenRatio2D => baseline(BaselineKind::GoldenRatio2D)?,
        NoiseKind::WhiteVectors | NoiseKind::StbnVectors => {
            panic!("{kind:?} is a vector mask")
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> NoiseSpec {
        NoiseSpec {
            width: 8,
            height: 8,
            depth: 4,
            seed: 3,
            encoding: Encoding::F32,
        }
    }

    #[test]
    fn every_source_has_exactly_uniform_frames() {
        let spec = spec();
        for mask in generate_all(&NoiseKind::SCALAR, &spec).unwrap() {
            let view = mask.view();
            assert_eq!((view.width(), view.height(), view.depth()), (8, 8, 4));
            for z in 0..4 {
                let mut frame = [0f32; 64];
                view.fill_frame(z, &mut frame);
                frame.sort_by(f32::total_cmp);
                for (i, v) in frame.iter().enumerate() {
                    assert_eq!(*v, ((i as f64 + 0.5) / 64.0) as f32, "{:?}", mask.kind);
                }
            }
        }
    }

    #[test]
    fn vector_sources_hold_cosine_distributed_unit_directions() {
        let spec = spec();
        for kind in [NoiseKind::WhiteVectors, NoiseKind::StbnVectors] {
            let mask = NoiseMask::generate(kind, &spec).unwrap();
            let view = mask.view();
            assert_eq!(view.space(), stbn_runtime::Space::CosineHemisphere);
            let mut mean_z = 0.0;
            for z in 0..4 {
                for y in 0..8 {
                    for x in 0..8 {
                        let d = view.sample_vec3(x, y, z);
                        assert!((d.length() - 1.0).abs() < 1e-5, "{kind:?} {d}");
                        assert!(d.z >= -1e-3, "{kind:?} {d}");
                        mean_z += f64::from(d.z) / 256.0;
                    }
                }
            }
            // E[cos θ] = 2/3 under the cosine distribution; stratified sets are close.
            assert!((mean_z - 2.0 / 3.0).abs() < 0.02, "{kind:?}: {mean_z}");
        }
    }

    #[test]
    fn past_depth_white_noise_has_a_slice_per_frame() {
        let masks = generate_past_depth(&spec(), 10).unwrap();
        let kinds: Vec<NoiseKind> = masks.iter().map(|m| m.kind).collect();
        let depths: Vec<u32> = masks.iter().map(|m| m.view().depth()).collect();
        assert_eq!(
            kinds,
            [
                NoiseKind::White,
                NoiseKind::Stbn,
                NoiseKind::StbnProgressive
            ]
        );
        assert_eq!(depths, [10, 4, 4]);
        assert_eq!(masks[1].blob, masks[2].blob);
        // Fewer frames than the depth keep the white mask at the spec's depth.
        assert_eq!(
            generate_past_depth(&spec(), 3).unwrap()[0].view().depth(),
            4
        );
    }

    #[test]
    fn golden_ratio_frames_are_rotations_of_frame_zero() {
        let volume = noise_volume(NoiseKind::GoldenRatio2D, &spec()).unwrap();
        let n = volume.slice_pixels() as u32;
        for z in 1..4 {
            // fract(v + z·φ⁻¹) rotates the value order: ranks shift by one constant mod n.
            let shift = (volume.slice(z)[0] + n - volume.slice(0)[0]) % n;
            for (a, b) in volume.slice(0).iter().zip(volume.slice(z)) {
                assert_eq!((a + shift) % n, *b, "frame {z}");
            }
            assert_ne!(shift, 0);
        }
    }

    #[test]
    fn sources_are_deterministic_and_distinct() {
        let kinds = [
            NoiseKind::SCALAR.as_slice(),
            &NoiseKind::DIRECTIONS,
            &[NoiseKind::StbnProgressive],
        ]
        .concat();
        let a = generate_all(&kinds, &spec()).unwrap();
        assert_eq!(a, generate_all(&kinds, &spec()).unwrap());
        // A shared mask is the one its source generates on its own.
        for mask in &a {
            let alone = NoiseMask::generate(mask.kind, &spec()).unwrap();
            assert_eq!(mask.blob, alone.blob, "{:?}", mask.kind);
        }
        for i in 0..a.len() {
            for j in i + 1..a.len() {
                // The pairs and the progressive views read the masks of their sources.
                let same_mask = a[i].kind.mask_source() == a[j].kind.mask_source();
                assert_eq!(
                    a[i].blob == a[j].blob,
                    same_mask,
                    "{:?} {:?}",
                    a[i].kind,
                    a[j].kind
                );
            }
        }
    }
}
