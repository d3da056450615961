//! A bounded, deterministic fuzz run of the blob decoder on stable Rust (cargo-fuzz needs a
//! nightly toolchain), in the style of the manifest fuzzer (`tests/fuzz_manifest.rs` at the
//! workspace root).
//!
//! The corpus is a set of valid blobs built here (every space, value map, encoding and
//! compression) plus the `*.stbn` files in `tests/fuzz-corpus/decoder/` (inputs worth keeping, e.g.
//! ones that once failed). Each iteration mutates one corpus blob and runs it through every
//! entry point: `MaskHeader::parse`, `Stbn::from_bytes[_unverified]`, `PackedStbn::from_bytes`
//! and `decode_into`, then samples whatever decoded (scalar, vector, pdf, fills). Mutations
//! include plain bit flips and truncations (which the CRCs catch) and *re-signed* ones, whose
//! header or payload CRC is recomputed after the edit, so they reach the field checks and the
//! LZ4 / Deflate decoders behind the checksums.
//!
//! Some mutations write F32 values that break a space's range (NaN, infinities, 1e30, -5, just
//! above 1, the zero direction) into the payload and re-sign it, so they reach the value checks.
//!
//! Every input must return without panicking; every accepted mask (by `from_bytes`,
//! `decode_into`, or `from_bytes_unverified` then `verify`) must keep the documented promises on
//! every read: finite channel values in `[0, 1]` (`[0, 1)` for Unorm), finite values, directions
//! of unit length within `UNIT_LENGTH_TOLERANCE` with `z >= 0` on hemispheres, and finite pdfs
//! `>= 0` (inside `pdf_min..=pdf_max` where stored), per sample and in the vector fills.
//! `STBN_FUZZ_ITERATIONS` raises the default 200,000 mutations for a longer local run.

mod common;

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use common::{Rng, packed_blob, random_payload};
use glam::Vec3;
use stbn_runtime::{
    Compression, Encoding, Error, MaskHeader, PackedStbn, SampleOffset, Space, Stbn,
    UNIT_LENGTH_TOLERANCE, ValueMap, VectorSample, octahedral_encode,
};

const DEFAULT_ITERATIONS: usize = 200_000;

/// A valid blob of `space` with a payload that makes sense for it (unit directions stored as
/// unit directions, a pdf channel within range), compressed as asked.
fn seed_blob(
    space: Space,
    map: ValueMap,
    channels: u8,
    encoding: Encoding,
    compression: Compression,
    rng: &mut Rng,
) -> Vec<u8> {
    let (w, h, d) = (
        1 + rng.next_u32() % 6,
        1 + rng.next_u32() % 5,
        1 + rng.next_u32() % 4,
    );
    let (pdf_min, pdf_max) = if space.stores_pdf() {
        (0.5, 4.0)
    } else {
        (0.0, 0.0)
    };
    let header =
        MaskHeader::new(w, h, d, channels, encoding).with_space(space, map, pdf_min, pdf_max);
    let mut payload = random_payload(&header, rng);
    if map == ValueMap::Octahedral && encoding == Encoding::F32 {
        // Keep F32 octahedral pairs inside [0, 1]² like real masks.
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        let e = octahedral_encode(n) * 0.5 + 0.5;
        for texel in payload.chunks_exact_mut(usize::from(channels) * 4) {
            texel[..4].copy_from_slice(&e.x.to_le_bytes());
            texel[4..8].copy_from_slice(&e.y.to_le_bytes());
        }
    }
    if matches!(space, Space::UniformHemisphere | Space::CosineHemisphere) {
        above_the_horizon(&header, &mut payload);
    }
    packed_blob(header, compression, &payload)
}

/// Moves every direction of a random hemisphere payload above the horizon: a signed z component
/// into `[0.5, 1)` (z >= 0), octahedral coordinates into `[0.25, 0.75)` (|e.x| + |e.y| < 1).
fn above_the_horizon(header: &MaskHeader, payload: &mut [u8]) {
    let bpe = header.encoding.bytes_per_element();
    let channels = usize::from(header.channels);
    for texel in payload.chunks_exact_mut(channels * bpe) {
        let targets: &[usize] = match header.value_map {
            ValueMap::Octahedral => &[0, 1],
            _ => &[2],
        };
        for &c in targets {
            let element = &mut texel[c * bpe..(c + 1) * bpe];
            let octahedral = header.value_map == ValueMap::Octahedral;
            match header.encoding {
                Encoding::F32 => {
                    let u = f32::from_le_bytes(element[..4].try_into().unwrap());
                    let u = if octahedral {
                        0.25 + u * 0.5
                    } else {
                        0.5 + u * 0.5
                    };
                    element.copy_from_slice(&u.to_le_bytes());
                }
                _ => {
                    // The most significant byte sets the bin's upper bits.
                    let top = &mut element[bpe - 1];
                    *top = if octahedral {
                        64 + *top % 128
                    } else {
                        *top | 0x80
                    };
                }
            }
        }
    }
}

/// Every combination the header accepts, once per encoding and compression.
fn built_corpus() -> Vec<Vec<u8>> {
    let shapes = [
        (Space::Scalar, ValueMap::Unit, 1),
        (Space::Scalar, ValueMap::Unit, 4),
        (Space::Vec, ValueMap::Unit, 2),
        (Space::Vec, ValueMap::Signed, 3),
        (Space::UnitVec, ValueMap::Signed, 1),
        (Space::UnitVec, ValueMap::Signed, 2),
        (Space::UnitVec, ValueMap::Octahedral, 2),
        (Space::UniformHemisphere, ValueMap::Signed, 3),
        (Space::CosineHemisphere, ValueMap::Octahedral, 2),
        (Space::ImagePoints, ValueMap::Unit, 3),
        (Space::EnvironmentDirections, ValueMap::Octahedral, 3),
        (Space::EnvironmentDirections, ValueMap::Signed, 4),
    ];
    let mut rng = Rng(2026);
    let mut corpus = Vec::new();
    for (space, map, channels) in shapes {
        for encoding in [Encoding::Unorm8, Encoding::Unorm16, Encoding::F32] {
            for compression in [
                Compression::None,
                Compression::Lz4,
                Compression::Deflate,
                Compression::Palette,
            ] {
                corpus.push(seed_blob(
                    space,
                    map,
                    channels,
                    encoding,
                    compression,
                    &mut rng,
                ));
            }
        }
    }
    corpus
}

/// `built_corpus` plus the recorded files.
fn corpus() -> Vec<Vec<u8>> {
    let mut corpus = built_corpus();
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz-corpus/decoder");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|entry| entry.unwrap().path())
        .collect();
    files.sort();
    for path in files
        .into_iter()
        .filter(|p| p.extension().is_some_and(|e| e == "stbn"))
    {
        corpus.push(std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display())));
    }
    corpus
}

fn resign_header(bytes: &mut [u8]) {
    if bytes.len() >= 64 {
        let crc = crc32fast::hash(&bytes[..60]);
        bytes[60..64].copy_from_slice(&crc.to_le_bytes());
    }
}

/// Recomputes the payload CRC (and the header CRC after it) over whatever follows the header.
fn resign_payload(bytes: &mut [u8]) {
    if bytes.len() >= 64 {
        let crc = crc32fast::hash(&bytes[64..]);
        bytes[28..32].copy_from_slice(&crc.to_le_bytes());
        let len = (bytes.len() - 64) as u32;
        bytes[24..28].copy_from_slice(&len.to_le_bytes());
        resign_header(bytes);
    }
}

/// One mutation of `input`.
fn mutate(input: &[u8], rng: &mut Rng) -> Vec<u8> {
    let mut b = input.to_vec();
    let pick = |rng: &mut Rng, n: usize| {
        if n == 0 {
            0
        } else {
            rng.next_u32() as usize % n
        }
    };
    let edits = 1 + pick(rng, 4);
    for _ in 0..edits {
        match pick(rng, 10) {
            // Raw damage: the checksums must catch it.
            0 => {
                let i = pick(rng, b.len());
                if let Some(byte) = b.get_mut(i) {
                    *byte ^= 1 << pick(rng, 8);
                }
            }
            1 => b.truncate(pick(rng, b.len() + 1)),
            2 => {
                let n = 1 + pick(rng, 16);
                let extra = rng.bytes(n);
                b.extend_from_slice(&extra);
            }
            // Header fields overwritten, then re-signed: the field checks must catch it.
            3 | 4 => {
                let field = [8usize, 12, 16, 20, 21, 22, 23, 24, 32, 36, 40][pick(rng, 11)];
                let value: u32 = match pick(rng, 5) {
                    0 => 0,
                    1 => u32::MAX,
                    2 => 1 << pick(rng, 32),
                    3 => f32::from_bits(rng.next_u32()).to_bits(),
                    _ => rng.next_u32() % 8,
                };
                let width = if matches!(field, 20..=23 | 40) { 1 } else { 4 };
                if b.len() >= field + width {
                    b[field..field + width].copy_from_slice(&value.to_le_bytes()[..width]);
                }
                resign_header(&mut b);
            }
            // An F32 value outside every range (or the zero direction) over four payload
            // bytes, re-signed: the value checks must catch what the checksums no longer do.
            7 if b.len() >= 68 && b.get(21) == Some(&2) => {
                let bad = [
                    f32::NAN,
                    f32::INFINITY,
                    f32::NEG_INFINITY,
                    1e30,
                    -5.0,
                    1.000_000_1,
                    -1e-30,
                    0.5,
                    1.0,
                    0.0,
                ][pick(rng, 10)];
                let i = 64 + 4 * pick(rng, (b.len() - 64) / 4);
                b[i..i + 4].copy_from_slice(&bad.to_le_bytes());
                resign_payload(&mut b);
            }
            // Payload bytes changed, then the payload (and header) re-signed: the decompressors
            // and samplers see arbitrary data.
            5..=7 => {
                if b.len() > 64 {
                    let i = 64 + pick(rng, b.len() - 64);
                    b[i] = rng.next_u32() as u8;
                }
                resign_payload(&mut b);
            }
            8 => {
                if b.len() > 64 {
                    let keep = 64 + pick(rng, b.len() - 64);
                    b.truncate(keep);
                }
                resign_payload(&mut b);
            }
            _ => {
                let n = 1 + pick(rng, 64);
                let extra = rng.bytes(n);
                b.extend_from_slice(&extra);
                resign_payload(&mut b);
            }
        }
    }
    b
}

/// Asserts the promises of a verified mask on one vector read.
fn check_vector(header: &MaskHeader, s: &VectorSample, what: &str) {
    assert!(s.value.is_finite(), "{header:?} {what}: {s:?}");
    assert!(
        s.pdf.is_finite() && s.pdf >= 0.0,
        "{header:?} {what}: pdf {}",
        s.pdf
    );
    if header.space.stores_pdf() {
        assert!(
            s.pdf >= header.pdf_min && s.pdf <= header.pdf_max,
            "{header:?} {what}: {s:?}"
        );
    }
    if header.space.is_unit() {
        assert!(
            (s.value.length() - 1.0).abs() <= UNIT_LENGTH_TOLERANCE,
            "{header:?} {what}: length {} of {s:?}",
            s.value.length()
        );
    }
    if matches!(
        header.space,
        Space::UniformHemisphere | Space::CosineHemisphere
    ) {
        assert!(s.value.z >= 0.0, "{header:?} {what}: {s:?}");
    }
}

/// Samples an accepted mask everywhere that matters and checks every value's range.
fn check_samples(stbn: &Stbn<'_>, rng: &mut Rng) {
    let header = stbn.header();
    let unorm = header.encoding != Encoding::F32;
    for _ in 0..8 {
        let (x, y, f) = (rng.next_u32() as i32, rng.next_u32() as i32, rng.next_u32());
        let view = stbn
            .offset(SampleOffset {
                x: rng.next_u32() as i32,
                y: rng.next_u32() as i32,
                frame: rng.next_u32(),
            })
            .dimension(rng.next_u32());
        for c in 0..u32::from(header.channels) {
            for v in [
                stbn.sample_channel(x, y, f, c),
                view.sample_channel(x, y, f, c),
            ] {
                if unorm {
                    assert!((0.0..1.0).contains(&v), "{header:?}: channel {c} = {v}");
                } else {
                    assert!((0.0..=1.0).contains(&v), "{header:?}: channel {c} = {v}");
                }
            }
        }
        check_vector(header, &view.sample_vector(x, y, f), "sample_vector");
        check_vector(header, &stbn.sample_vector(x, y, f), "sample_vector");
    }
    let mut vectors = [VectorSample {
        value: glam::Vec4::NAN,
        pdf: f32::NAN,
    }; 13];
    stbn.fill_vector_row(rng.next_u32() as i32, 0, rng.next_u32(), &mut vectors);
    for s in &vectors {
        check_vector(header, s, "fill_vector_row");
    }
    let mut row = [0.0f32; 13];
    stbn.fill_row(
        rng.next_u32() as i32,
        rng.next_u32() as i32,
        rng.next_u32(),
        &mut row,
    );
    assert!(row.iter().all(|v| (0.0..=1.0).contains(v)), "{row:?}");
    let mut frame = vec![0.0f32; 40];
    stbn.fill_frame(rng.next_u32(), &mut frame);
    let corner = stbn.offset(SampleOffset {
        x: i32::MAX,
        y: i32::MIN,
        frame: u32::MAX,
    });
    let _ = corner.sample(i32::MIN, i32::MAX, u32::MAX);
    corner.fill_row(i32::MAX, i32::MIN, u32::MAX, &mut row);
    corner.fill_frame(rng.next_u32(), &mut frame);
}

/// What [`exercise`] did with one input.
#[derive(Default)]
struct Outcome {
    /// A mask was decoded and sampled.
    decoded: bool,
    /// A verified path refused a stored value.
    invalid_value: bool,
}

/// Runs every entry point on `bytes` and samples whatever is accepted.
fn exercise(bytes: &[u8], buf: &mut [u8], rng: &mut Rng) -> Outcome {
    let mut outcome = Outcome::default();
    let header = MaskHeader::parse(bytes);
    let unverified = Stbn::from_bytes_unverified(bytes);
    let verified = Stbn::from_bytes(bytes);
    if let Ok(view) = &unverified {
        // `verify` on the unverified view decides exactly as `from_bytes`.
        let checked = view.verify();
        assert_eq!(checked.err(), verified.as_ref().err().copied());
        if checked.is_ok() {
            check_samples(view, rng);
        }
    }
    match verified {
        Ok(view) => {
            assert!(header.is_ok() && unverified.is_ok());
            check_samples(&view, rng);
        }
        Err(Error::InvalidValue { .. }) => outcome.invalid_value = true,
        Err(_) => {}
    }
    let packed = match PackedStbn::from_bytes(bytes) {
        Ok(packed) => packed,
        Err(e) => {
            outcome.invalid_value |= matches!(e, Error::InvalidValue { .. });
            return outcome;
        }
    };
    assert_eq!(Ok(*packed.header()), header);
    let needed = packed.header().decoded_len();
    if needed > buf.len() {
        // Within MAX_DECODED_BYTES but larger than this run's buffer: the decoder must say so.
        assert!(packed.decode_into(buf).is_err());
        return outcome;
    }
    match packed.decode_into(buf) {
        Ok(view) => {
            check_samples(&view, rng);
            outcome.decoded = true;
        }
        Err(e) => outcome.invalid_value |= matches!(e, Error::InvalidValue { .. }),
    }
    outcome
}

#[test]
fn decoder_survives_seeded_mutations_of_the_corpus() {
    let corpus = corpus();
    for (i, blob) in corpus.iter().enumerate() {
        let mut buf = vec![0u8; 1 << 16];
        assert!(
            exercise(blob, &mut buf, &mut Rng(i as u64)).decoded,
            "corpus entry {i} does not decode"
        );
    }
    let iterations = std::env::var("STBN_FUZZ_ITERATIONS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(DEFAULT_ITERATIONS);
    let mut rng = Rng(0x5EED_DEC0);
    let mut buf = vec![0u8; 1 << 16];
    let (mut decoded, mut invalid_values) = (0usize, 0usize);
    for i in 0..iterations {
        let input = &corpus[rng.next_u32() as usize % corpus.len()];
        let mutated = mutate(input, &mut rng);
        let result = catch_unwind(AssertUnwindSafe(|| {
            exercise(&mutated, &mut buf, &mut Rng(i as u64))
        }));
        match result {
            Ok(outcome) => {
                decoded += usize::from(outcome.decoded);
                invalid_values += usize::from(outcome.invalid_value);
            }
            Err(_) => panic!(
                "iteration {i} panicked on a {}-byte input: {:02x?}",
                mutated.len(),
                mutated
            ),
        }
    }
    // The mutations must reach the samplers, not only the checksums.
    assert!(
        decoded > iterations / 20,
        "only {decoded} of {iterations} mutations decoded"
    );
    // And the value checks, not only the header's.
    assert!(
        invalid_values > iterations / 200,
        "only {invalid_values} of {iterations} mutations reached a value check"
    );
    println!(
        "{iterations} mutations, {decoded} decoded and sampled, {invalid_values} refused for a \
         stored value"
    );
}
