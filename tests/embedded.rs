//! The statics that build.rs embedded from `assets.ron`, checked against the generator.

use stbn_build_support::encode::{encode_payload, encode_volume};
use stbn_build_support::{Manifest, MaskEntry};
use stbn_demo::masks::{BLUE2D_64, SCALAR_64, SCALAR_64_PALETTE};
use stbn_gen::Volume;
use stbn_runtime::{Compression, Encoding, PackedStbn, Stbn};

/// The manifest entry `name` of the demo's `assets.ron`.
fn entry(name: &str) -> MaskEntry {
    let manifest = Manifest::load(concat!(env!("CARGO_MANIFEST_DIR"), "/assets.ron")).unwrap();
    manifest
        .masks()
        .iter()
        .find(|m| m.name == name)
        .unwrap_or_else(|| panic!("assets.ron declares no mask {name:?}"))
        .clone()
}

fn generate(name: &str) -> (MaskEntry, Volume) {
    let entry = entry(name);
    let volume = stbn_gen::generate(&entry.spec(), stbn_gen::Observer::default()).unwrap();
    (entry, volume)
}

/// The complete blob a packed static was built from.
fn blob_of(packed: &PackedStbn<'_>) -> Vec<u8> {
    let mut blob = packed.header().to_bytes().to_vec();
    blob.extend_from_slice(packed.payload());
    blob
}

fn decode(packed: &PackedStbn<'_>) -> Vec<u8> {
    let mut buffer = vec![0u8; packed.decoded_len()];
    let viewed = packed.decode_into(&mut buffer).unwrap().data().len();
    assert_eq!(viewed, buffer.len());
    buffer
}

#[test]
fn scalar_64_matches_the_generator_at_every_voxel() {
    let (entry, volume) = generate("scalar_64");
    assert_eq!(
        (entry.encoding, entry.compression),
        (Encoding::Unorm8, Compression::None)
    );
    let blob = encode_volume(&volume, entry.encoding, entry.compression);
    let expected = Stbn::from_bytes(&blob).unwrap();
    assert_eq!(SCALAR_64.header(), expected.header());
    assert_eq!(SCALAR_64.data(), expected.data());
    let (w, h, d) = entry.size;
    for z in 0..d {
        for y in 0..h as i32 {
            for x in 0..w as i32 {
                assert_eq!(
                    SCALAR_64.sample(x, y, z),
                    expected.sample(x, y, z),
                    "({x}, {y}, {z})"
                );
            }
        }
    }
}

#[test]
fn embedded_blobs_pass_full_validation() {
    let mut plain = SCALAR_64.header().to_bytes().to_vec();
    plain.extend_from_slice(SCALAR_64.data());
    assert!(Stbn::from_bytes(&plain).is_ok());
    for packed in [&SCALAR_64_PALETTE, &BLUE2D_64] {
        assert!(PackedStbn::from_bytes(&blob_of(packed)).is_ok());
    }
    // Unorm16 frames of 4096 pixels all hold the same 4096 levels: a palette stores them once and
    // a 12-bit index per voxel (78 % of the bytes).
    assert_eq!(SCALAR_64_PALETTE.header().compression, Compression::Palette);
    assert!(blob_of(&SCALAR_64_PALETTE).len() * 100 < SCALAR_64_PALETTE.decoded_len() * 79);
    // Unorm8 frames hold every level equally often, at their entropy: Deflate does not shrink
    // them, so the blob is stored uncompressed (still a `PackedStbn`, decoded by a copy).
    assert_eq!(BLUE2D_64.header().compression, Compression::None);
    assert_eq!(blob_of(&BLUE2D_64).len(), 64 + BLUE2D_64.decoded_len());
}

#[test]
fn every_frame_has_an_exactly_uniform_histogram() {
    let (w, h, d) = (SCALAR_64.width(), SCALAR_64.height(), SCALAR_64.depth());
    let pixels = (w * h) as usize;
    assert_eq!((w, h, d), (64, 64, 32));
    let mut frame = vec![0.0f32; pixels];
    for z in 0..d {
        assert_eq!(SCALAR_64.fill_frame(z, &mut frame), pixels);
        let mut counts = [0usize; 256];
        for &v in &frame {
            // Unorm8 samples are bin midpoints (q + 0.5) / 256.
            let q = v * 256.0 - 0.5;
            assert_eq!(q, q.round(), "{v} is not a bin midpoint");
            counts[q as usize] += 1;
        }
        // 4096 pixels over 256 levels: 16 of each.
        assert!(
            counts.iter().all(|&c| c == pixels / 256),
            "frame {z}: {counts:?}"
        );
    }
}

#[test]
fn sampling_wraps_on_every_axis() {
    let (w, h, d) = (64i32, 64i32, 32u32);
    for (x, y, z) in [(0, 0, 0), (5, 17, 3), (63, 63, 31), (31, 2, 30)] {
        let v = SCALAR_64.sample(x, y, z);
        assert_eq!(SCALAR_64.sample(x + w, y, z), v);
        assert_eq!(SCALAR_64.sample(x - w, y - h, z), v);
        assert_eq!(SCALAR_64.sample(x - 5 * w, y + 7 * h, z + 3 * d), v);
        assert_eq!(SCALAR_64.sample(x, y, z + 1_000_000 * d), v);
        // Large coordinates wrap as if computed in unbounded integers: 2^31 and 2^32 are
        // multiples of 64 and 32.
        assert_eq!(SCALAR_64.sample(x + i32::MIN, y + i32::MIN, z), v);
        assert_eq!(
            SCALAR_64.sample(i32::MAX - 63 + x, y, z + (u32::MAX - 31)),
            v
        );
    }
    assert_eq!(
        SCALAR_64.sample(-1, -1, u32::MAX),
        SCALAR_64.sample(63, 63, 31)
    );
    assert_eq!(
        SCALAR_64.sample(i32::MAX, i32::MAX, 0),
        SCALAR_64.sample(63, 63, 0)
    );
}

#[test]
fn palette_mask_decodes_to_the_uncompressed_generation() {
    let (entry, volume) = generate("scalar_64_palette");
    assert_eq!(
        (entry.encoding, entry.compression),
        (Encoding::Unorm16, Compression::Palette)
    );
    let decoded = decode(&SCALAR_64_PALETTE);
    assert_eq!(decoded, encode_payload(&volume, Encoding::Unorm16));
    let uncompressed = encode_volume(&volume, Encoding::Unorm16, Compression::None);
    let expected = Stbn::from_bytes(&uncompressed).unwrap();
    let mut buffer = vec![0u8; SCALAR_64_PALETTE.decoded_len()];
    let view = SCALAR_64_PALETTE.decode_into(&mut buffer).unwrap();
    assert_eq!(view.header(), expected.header());
    for (x, y, z) in [(0, 0, 0), (-1, 70, 33), (12, 34, 5)] {
        assert_eq!(view.sample(x, y, z), expected.sample(x, y, z));
    }
    // Same spec as SCALAR_64 at a finer quantisation: Unorm16 level 16·r vs Unorm8 level r/16.
    for z in 0..32 {
        for y in 0..64 {
            for x in 0..64 {
                let fine = view.sample(x, y, z);
                let coarse = SCALAR_64.sample(x, y, z);
                assert!((fine - coarse).abs() < 1.0 / 256.0, "({x}, {y}, {z})");
            }
        }
    }
}

#[test]
fn decode_into_respects_the_caller_buffer() {
    let len = SCALAR_64_PALETTE.decoded_len();
    assert_eq!(len, 64 * 64 * 32 * 2);
    let mut short = vec![0u8; len - 1];
    assert!(SCALAR_64_PALETTE.decode_into(&mut short).is_err());
    let mut long = vec![0xAAu8; len + 16];
    let view = SCALAR_64_PALETTE.decode_into(&mut long).unwrap();
    assert_eq!(
        view.data().len(),
        len,
        "the view covers the decoded bytes only"
    );
    assert!(long[len..].iter().all(|&b| b == 0xAA));
    assert_eq!(&long[..len], decode(&SCALAR_64_PALETTE));
}

#[test]
fn blue2d_mask_is_the_independent_2d_generation_and_differs() {
    let (entry, volume) = generate("blue2d_64");
    assert_eq!(
        (entry.encoding, entry.compression),
        (Encoding::Unorm8, Compression::Deflate)
    );
    let decoded = decode(&BLUE2D_64);
    assert_eq!(decoded, encode_payload(&volume, Encoding::Unorm8));
    // Same size and seed as SCALAR_64 but another energy: most values differ.
    let differing = decoded
        .iter()
        .zip(SCALAR_64.data())
        .filter(|(a, b)| a != b)
        .count();
    assert!(
        differing > decoded.len() * 9 / 10,
        "only {differing} of {} differ",
        decoded.len()
    );
    // Still an exact permutation per frame.
    for frame in decoded.chunks(64 * 64) {
        let mut counts = [0usize; 256];
        frame.iter().for_each(|&q| counts[q as usize] += 1);
        assert!(counts.iter().all(|&c| c == 16));
    }
}

/// The blob `name`'s recipe makes, straight from the generator.
fn made(name: &str) -> Vec<u8> {
    let entry = entry(name);
    entry
        .recipe()
        .make(entry.encoding, entry.compression)
        .unwrap()
        .1
}

#[test]
fn vector_masks_are_their_recipes_and_sample_as_vectors() {
    use stbn_demo::masks::{COSINE_64, VEC2_32};
    use stbn_runtime::{Space, ValueMap};

    // The cosine mask: two octahedral Unorm8 channels, unit vectors with z ≥ 0, pdf z/π.
    let mut plain = COSINE_64.header().to_bytes().to_vec();
    plain.extend_from_slice(COSINE_64.data());
    assert_eq!(plain, made("cosine_64"));
    let h = COSINE_64.header();
    assert_eq!(
        (h.space, h.value_map, h.channels, COSINE_64.dims()),
        (Space::CosineHemisphere, ValueMap::Octahedral, 2, 3)
    );
    let mut mean_z = 0.0f64;
    for z in 0..32 {
        for y in 0..64 {
            for x in 0..64 {
                let s = COSINE_64.sample_vector(x, y, z);
                assert!((s.value.length() - 1.0).abs() < 1e-6);
                // Octahedral Unorm8 bins are ~0.01 wide: a direction at the horizon may
                // quantise a hair below it.
                assert!(s.value.z > -0.02, "({x}, {y}, {z}): {s:?}");
                assert!((s.pdf - s.value.z.max(0.0) / core::f32::consts::PI).abs() < 1e-6);
                mean_z += f64::from(s.value.z);
            }
        }
    }
    // Cosine-weighted: E[cos θ] = 2/3 (uniform would give 1/2).
    mean_z /= (64 * 64 * 32) as f64;
    assert!((mean_z - 2.0 / 3.0).abs() < 0.01, "mean z {mean_z}");

    // The Vec2 mask: LZ4-compressed Unorm16 pairs in [0, 1)².
    assert_eq!(blob_of(&VEC2_32), made("vec2_32"));
    let mut buffer = vec![0u8; VEC2_32.decoded_len()];
    let view = VEC2_32.decode_into(&mut buffer).unwrap();
    assert_eq!((view.space(), view.dims()), (Space::Vec, 2));
    let v = view.sample_vec2(-1, 40, u32::MAX);
    assert_eq!(v, view.sample_vec2(31, 8, 15));
    assert!(v.x >= 0.0 && v.x < 1.0 && v.y >= 0.0 && v.y < 1.0);
    assert_eq!(view.sample_pdf(3, 4, 5), 1.0);
}
