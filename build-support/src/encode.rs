//! Turning a generated [`Volume`] or [`VectorVolume`] into a `.stbn` blob: quantisation,
//! compression, header.

use stbn_gen::{SampleSpace, VectorVolume, Volume};
use stbn_runtime::{Compression, Encoding, MaskHeader, Space, ValueMap, octahedral_encode};

/// The miniz_oxide level used for [`Compression::Deflate`] (0–10; 9 is zlib's "best").
pub const DEFLATE_LEVEL: u8 = 9;

/// Version of the encoder's output, part of every cache key: changed whenever the bytes the
/// encoder writes for a volume change (the quantisation rules, the compression fallback, the
/// hemisphere horizon rule).
pub const ENCODER_VERSION: u32 = 3;

/// Whether `blob` (from [`encode_volume`] or [`encode_vector`]) was asked for `requested`
/// compression but stores its payload uncompressed, because the codec did not make it smaller.
/// `false` for a blob whose header cannot be read.
pub fn stored_uncompressed(blob: &[u8], requested: Compression) -> bool {
    !requested.is_none() && MaskHeader::parse(blob).is_ok_and(|header| header.compression.is_none())
}

/// The Unorm level of rank `rank` in a slice of `pixels` pixels with `bits` bits: the level
/// `q ∈ 0..2^bits` whose midpoint `(q + ½) / 2^bits` is nearest to the exact value
/// `(rank + ½) / pixels`, in integer arithmetic. Ties (the value on a level boundary, which
/// happens when a slice has fewer pixels than levels) go to the level further from ½, so rank
/// `r` and rank `pixels − 1 − r` map to mirrored levels and a slice's decoded mean is exactly ½
/// for an even pixel count. When `2^bits` divides `pixels` there are no ties and every level holds
/// `pixels / 2^bits` ranks.
pub fn unorm_level(rank: u64, pixels: u64, bits: u32) -> u64 {
    debug_assert!(rank < pixels && bits <= 16);
    // The exact value in level units is x = (2r + 1) · 2^bits / (2n).
    let (numerator, denominator) = ((2 * rank + 1) << bits, 2 * pixels);
    let q = numerator / denominator;
    let tie = numerator % denominator == 0;
    if tie && 2 * rank + 1 < pixels {
        q - 1
    } else {
        q
    }
}

/// The stored value of rank `rank` in a slice of `pixels` pixels, as `encoding` stores it
/// (little-endian bytes, 1, 2 or 4 of them):
///
/// * `Unorm8`, `Unorm16`: `q = `[`unorm_level`]`(rank, pixels, 8 or 16)`, read by the runtime as
///   `(q + 0.5) / 2^bits`;
/// * `F32`: `(rank + 0.5) / pixels`, rounded once from `f64`.
///
/// `rank < pixels` for every rank of a [`Volume`], so the Unorm values stay in range.
fn push_value(out: &mut Vec<u8>, rank: u32, pixels: u64, encoding: Encoding) {
    let rank = u64::from(rank);
    match encoding {
        Encoding::Unorm8 => out.push(unorm_level(rank, pixels, 8) as u8),
        Encoding::Unorm16 => {
            out.extend_from_slice(&(unorm_level(rank, pixels, 16) as u16).to_le_bytes())
        }
        Encoding::F32 => {
            let value = ((rank as f64 + 0.5) / pixels as f64) as f32;
            out.extend_from_slice(&value.to_le_bytes());
        }
    }
}

/// The decoded payload of `volume`: one element per pixel in index order
/// `(z · height + y) · width + x`, encoded as described on [`encode_volume`].
pub fn encode_payload(volume: &Volume, encoding: Encoding) -> Vec<u8> {
    let pixels = volume.slice_pixels() as u64;
    let mut out = Vec::with_capacity(volume.ranks().len() * encoding.bytes_per_element());
    for &rank in volume.ranks() {
        push_value(&mut out, rank, pixels, encoding);
    }
    out
}

/// Encodes `volume` as a complete one-channel `.stbn` blob: the 64-byte [`MaskHeader`]
/// (value map [`ValueMap::Unit`], pdf range 0) followed by the payload.
///
/// A slice of `n = width · height` pixels stores rank `r` as
/// * `Unorm8`: the level `q` whose midpoint is nearest to `(r + ½) / n` ([`unorm_level`]),
///   decoded by the runtime as `(q + 0.5) / 256`;
/// * `Unorm16`: likewise with 65536 levels, decoded as `(q + 0.5) / 65536`;
/// * `F32`: `(r + 0.5) / n` as `f32`.
///
/// Compression: [`Compression::Lz4`] is the LZ4 *block* format (no size prefix),
/// [`Compression::Deflate`] raw RFC 1951 at level [`DEFLATE_LEVEL`], [`Compression::Palette`] the
/// sorted distinct voxels and a bit-packed index per voxel. The output is
/// deterministic.
///
/// # Panics
/// If the stored payload exceeds `u32::MAX` bytes, which no volume within [`stbn_gen::MaskSpec`]'s
/// limits (at most 2^26 pixels, 4 bytes each) can reach.
pub fn encode_volume(volume: &Volume, encoding: Encoding, compression: Compression) -> Vec<u8> {
    let header = MaskHeader::new(volume.width(), volume.height(), volume.depth(), 1, encoding);
    finish(header, encode_payload(volume, encoding), compression)
}

/// Compresses `decoded` and puts `header` (completed with the payload fields) in front.
///
/// A compressed payload is kept only when it is smaller than `decoded`; otherwise the blob stores
/// `decoded` with [`Compression::None`] (its header says so), so a blob is never larger than the
/// stored one. [`stored_uncompressed`] tells a caller that asked for compression.
fn finish(header: MaskHeader, decoded: Vec<u8>, compression: Compression) -> Vec<u8> {
    let compressed = match compression {
        Compression::None => None,
        Compression::Lz4 => Some(lz4_flex::block::compress(&decoded)),
        Compression::Deflate => Some(miniz_oxide::deflate::compress_to_vec(
            &decoded,
            DEFLATE_LEVEL,
        )),
        Compression::Palette => {
            let voxel_bytes = usize::from(header.channels) * header.encoding.bytes_per_element();
            Some(palette(&decoded, voxel_bytes))
        }
    };
    let (compression, payload) = match compressed {
        Some(compressed) if compressed.len() < decoded.len() => (compression, compressed),
        _ => (Compression::None, decoded),
    };
    let header = header.with_payload(compression, &payload);
    let mut blob = Vec::with_capacity(MaskHeader::SIZE + payload.len());
    blob.extend_from_slice(&header.to_bytes());
    blob.extend_from_slice(&payload);
    blob
}

/// The [`Compression::Palette`] payload of `decoded` (voxels of `voxel_bytes` bytes): the count
/// `P` of distinct voxels as a little-endian `u32`, those voxels in ascending byte order, then
/// each voxel's index in `max(1, ⌈log2 P⌉)` bits, least significant bit first, the last byte
/// padded with zeros. Memory beside `decoded` is proportional to `P`, not to the voxel count.
fn palette(decoded: &[u8], voxel_bytes: usize) -> Vec<u8> {
    let distinct: std::collections::HashSet<&[u8]> = decoded.chunks_exact(voxel_bytes).collect();
    let mut entries: Vec<&[u8]> = distinct.into_iter().collect();
    entries.sort_unstable();
    let index: std::collections::HashMap<&[u8], u64> = entries
        .iter()
        .enumerate()
        .map(|(i, e)| (*e, i as u64))
        .collect();
    let bits = (usize::BITS - (entries.len() - 1).leading_zeros()).max(1);
    let voxels = decoded.len() / voxel_bytes;
    let mut out =
        Vec::with_capacity(4 + entries.len() * voxel_bytes + (voxels * bits as usize).div_ceil(8));
    // P <= voxel count <= MAX_DECODED_BYTES = 2^31, so it fits in u32.
    out.extend_from_slice(&(entries.len() as u32).to_le_bytes());
    entries.iter().for_each(|e| out.extend_from_slice(e));
    let (mut acc, mut have) = (0u64, 0u32);
    for voxel in decoded.chunks_exact(voxel_bytes) {
        acc |= index[voxel] << have;
        have += bits;
        while have >= 8 {
            out.push(acc as u8);
            acc >>= 8;
            have -= 8;
        }
    }
    if have > 0 {
        out.push(acc as u8);
    }
    out
}

/// How a mask is laid out in a blob: the runtime [`Space`], the [`ValueMap`] of its value
/// channels and the channel count (value channels plus the pdf channel, if any).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    /// What the values are samples of.
    pub space: Space,
    /// How value components are stored.
    pub value_map: ValueMap,
    /// Channels per voxel, 1..=4.
    pub channels: u8,
}

impl Layout {
    /// The layout of scalar masks ([`encode_volume`]): one `Unit` channel of [`Space::Scalar`].
    pub const SCALAR: Layout = Layout {
        space: Space::Scalar,
        value_map: ValueMap::Unit,
        channels: 1,
    };

    /// The layout of `space`: components in `[0, 1)` are stored as they are (`Unit`), signed
    /// components as `c · 0.5 + 0.5` (`Signed`), 3D directions as their octahedral map when
    /// `octahedral` (2 channels instead of 3), and image spaces add a pdf channel.
    pub fn new(space: &SampleSpace, octahedral: bool) -> Layout {
        let direction3 = |space| {
            if octahedral {
                (space, ValueMap::Octahedral, 2)
            } else {
                (space, ValueMap::Signed, 3)
            }
        };
        let (space, value_map, value_channels) = match space {
            SampleSpace::Vec { dims } => (Space::Vec, ValueMap::Unit, *dims),
            SampleSpace::UnitVec1 => (Space::UnitVec, ValueMap::Signed, 1),
            SampleSpace::UnitVec2 => (Space::UnitVec, ValueMap::Signed, 2),
            SampleSpace::UnitVec3 => direction3(Space::UnitVec),
            SampleSpace::UniformHemisphere => direction3(Space::UniformHemisphere),
            SampleSpace::CosineHemisphere => direction3(Space::CosineHemisphere),
            SampleSpace::ImagePoints(_) => (Space::ImagePoints, ValueMap::Unit, 2),
            SampleSpace::EnvironmentDirections(_) => direction3(Space::EnvironmentDirections),
        };
        Layout {
            space,
            value_map,
            channels: value_channels + u8::from(space.stores_pdf()),
        }
    }
}

/// `u` in `[0, 1]` as a Unorm element of `encoding` with midpoint decoding: `floor(u · 2^bits)`,
/// clamped to the largest code; F32 stores `u`.
fn push_unit(out: &mut Vec<u8>, u: f32, encoding: Encoding) {
    match unit_element(u, encoding) {
        UnitElement::Code(q) if encoding == Encoding::Unorm8 => out.push(q as u8),
        UnitElement::Code(q) => out.extend_from_slice(&(q as u16).to_le_bytes()),
        UnitElement::Float(u) => out.extend_from_slice(&u.to_le_bytes()),
    }
}

/// What [`push_unit`] stores for `u`: a Unorm code, or the `f32` itself.
enum UnitElement {
    Code(u32),
    Float(f32),
}

/// `u` clamped to `[0, 1]` (0 if not finite) and quantised as `encoding` stores it.
fn unit_element(u: f32, encoding: Encoding) -> UnitElement {
    let u = if u.is_finite() {
        u.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let code =
        |levels: f64| UnitElement::Code((f64::from(u) * levels).floor().min(levels - 1.0) as u32);
    match encoding {
        Encoding::Unorm8 => code(256.0),
        Encoding::Unorm16 => code(65536.0),
        Encoding::F32 => UnitElement::Float(u),
    }
}

/// `u` as [`push_unit`] stores it, read back as the runtime reads it (bin midpoints for Unorm).
fn stored_unit(u: f32, encoding: Encoding) -> f32 {
    match unit_element(u, encoding) {
        UnitElement::Code(q) => {
            (q as f32 + 0.5) / (1u32 << (8 * encoding.bytes_per_element())) as f32
        }
        UnitElement::Float(u) => u,
    }
}

/// Octahedral coordinates `(ux, uy)` (stored unit values) of a direction in the upper
/// hemisphere, moved toward the centre by whole storage steps (a Unorm bin, 2^-24 for `f32`)
/// until what is stored decodes to `z >= 0`.
///
/// A direction within about one step of the horizon lies on the octahedron's edge
/// `|ex| + |ey| = 1`; rounding each coordinate to what the encoding stores can push the sum
/// past 1, which [`octahedral_decode`](stbn_runtime::octahedral_decode) folds into the lower
/// hemisphere and the runtime refuses for a hemisphere mask. The moved direction differs from
/// the generated one by about one step.
fn above_the_horizon(mut ux: f32, mut uy: f32, encoding: Encoding) -> (f32, f32) {
    // A step that changes the decoded coordinate `2u - 1`: a Unorm bin, or for F32 one ulp of
    // `u` in [0.5, 1) (finer steps of a small `u` vanish in `2u - 1`).
    let step = match encoding {
        Encoding::Unorm8 => 1.0 / 256.0,
        Encoding::Unorm16 => 1.0 / 65536.0,
        Encoding::F32 => f32::EPSILON / 2.0,
    };
    let toward_centre = |u: f32| if u > 0.5 { u - step } else { u + step };
    let decoded = |u: f32| ValueMap::Octahedral.apply(stored_unit(u, encoding));
    // Each step moves one coordinate's stored value toward the centre, where z = 1; a few
    // suffice (the sum exceeds 1 by at most a step per coordinate).
    for _ in 0..64 {
        let (ex, ey) = (decoded(ux), decoded(uy));
        if stbn_runtime::octahedral_decode(glam::Vec2::new(ex, ey)).z >= 0.0 {
            break;
        }
        if ex.abs() >= ey.abs() {
            ux = toward_centre(ux);
        } else {
            uy = toward_centre(uy);
        }
    }
    (ux, uy)
}

/// `t` in `[0, 1]` as the full-range pdf element: Unorm `round(t · (2^bits - 1))`, F32 `t`.
fn push_full_range(out: &mut Vec<u8>, t: f32, encoding: Encoding) {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    match encoding {
        Encoding::Unorm8 => out.push((f64::from(t) * 255.0).round() as u8),
        Encoding::Unorm16 => {
            out.extend_from_slice(&((f64::from(t) * 65535.0).round() as u16).to_le_bytes());
        }
        Encoding::F32 => out.extend_from_slice(&t.to_le_bytes()),
    }
}

/// The decoded payload of `volume` stored as `layout` says, and the pdf range of its pdf channel
/// (`(0, 0)` without one).
///
/// Element order `((z · height + y) · width + x) · channels + c`. Value components go through
/// the Unorm quantisation of `push_unit` (midpoint decoding) after the value map's inverse (`Signed`: `c · 0.5 + 0.5`;
/// `Octahedral`: [`octahedral_encode`] then the same), so Unorm values decode to bin midpoints
/// within half a bin of the generated value. The pdf channel is stored full-range,
/// `(pdf - pdf_min) / (pdf_max - pdf_min)`, so the extremes are exact.
pub fn encode_vector_payload(
    volume: &VectorVolume,
    layout: Layout,
    encoding: Encoding,
) -> (Vec<u8>, f32, f32) {
    let dims = volume.dims();
    let pdf = volume.pdf().filter(|_| layout.space.stores_pdf());
    let (pdf_min, pdf_max) = pdf.map_or((0.0, 0.0), |pdf| {
        pdf.iter().fold((f32::INFINITY, 0.0f32), |(lo, hi), &p| {
            (lo.min(p), hi.max(p))
        })
    });
    let pixels = volume.values().len() / dims;
    let mut out =
        Vec::with_capacity(pixels * usize::from(layout.channels) * encoding.bytes_per_element());
    for (i, value) in volume.values().chunks_exact(dims).enumerate() {
        match layout.value_map {
            ValueMap::Unit => value.iter().for_each(|&v| push_unit(&mut out, v, encoding)),
            ValueMap::Signed => value
                .iter()
                .for_each(|&v| push_unit(&mut out, v * 0.5 + 0.5, encoding)),
            ValueMap::Octahedral => {
                let e = octahedral_encode(glam::Vec3::new(value[0], value[1], value[2]));
                let (mut ux, mut uy) = (e.x * 0.5 + 0.5, e.y * 0.5 + 0.5);
                if matches!(
                    layout.space,
                    Space::UniformHemisphere | Space::CosineHemisphere
                ) {
                    (ux, uy) = above_the_horizon(ux, uy, encoding);
                }
                push_unit(&mut out, ux, encoding);
                push_unit(&mut out, uy, encoding);
            }
        }
        if let Some(pdf) = pdf {
            let range = pdf_max - pdf_min;
            let t = if range > 0.0 {
                (pdf[i] - pdf_min) / range
            } else {
                0.0
            };
            push_full_range(&mut out, t, encoding);
        }
    }
    (out, pdf_min, pdf_max)
}

/// Encodes a vector volume as a complete `.stbn` blob laid out as `layout` (see
/// [`encode_vector_payload`]), compressed like [`encode_volume`].
pub fn encode_vector(
    volume: &VectorVolume,
    layout: Layout,
    encoding: Encoding,
    compression: Compression,
) -> Vec<u8> {
    let (decoded, pdf_min, pdf_max) = encode_vector_payload(volume, layout, encoding);
    let header = MaskHeader::new(
        volume.width(),
        volume.height(),
        volume.depth(),
        layout.channels,
        encoding,
    )
    .with_space(layout.space, layout.value_map, pdf_min, pdf_max);
    finish(header, decoded, compression)
}

#[cfg(test)]
mod tests {
    use super::*;
    use stbn_runtime::{PackedStbn, Stbn};

    /// A 4×2×2 volume: slice 0 ranks 0..8 in order, slice 1 reversed.
    fn volume() -> Volume {
        let global: Vec<u32> = (0..8).chain((8..16).rev()).collect();
        Volume::from_global_ranks(4, 2, 2, &global)
    }

    #[test]
    fn quantisation_formulas() {
        let mut out = Vec::new();
        // 8 pixels, 256 levels: (r + ½)/8 falls on level boundaries 16 and 240; the lower half
        // rounds down, the upper half up (mirrored: 15 + 240 = 255).
        push_value(&mut out, 0, 8, Encoding::Unorm8);
        push_value(&mut out, 7, 8, Encoding::Unorm8);
        push_value(&mut out, 4095, 4096, Encoding::Unorm8);
        assert_eq!(out, [15, 240, 255]);
        out.clear();
        push_value(&mut out, 3, 8, Encoding::Unorm16);
        assert_eq!(out, (7u16 * 4096 - 1).to_le_bytes());
        out.clear();
        push_value(&mut out, 1, 4, Encoding::F32);
        assert_eq!(out, 0.375f32.to_le_bytes());
    }

    #[test]
    fn unorm_levels_are_nearest_mirrored_and_unbiased() {
        for bits in [8, 16] {
            let levels = 1u64 << bits;
            for n in [
                1u64,
                2,
                7,
                8,
                64,
                255,
                256,
                527,
                4096,
                65536,
                65536 * 3,
                1 << 20,
            ] {
                if n > 1 << 20 {
                    continue;
                }
                let mut sum = 0.0;
                for r in 0..n {
                    let q = unorm_level(r, n, bits);
                    assert!(q < levels);
                    // Nearest level: the exact value lies within half a level of q's midpoint.
                    let exact = (r as f64 + 0.5) / n as f64;
                    let decoded = (q as f64 + 0.5) / levels as f64;
                    assert!(
                        (decoded - exact).abs() <= 0.5 / levels as f64 + 1e-15,
                        "bits {bits} n {n} r {r}: q {q}"
                    );
                    if n % 2 == 0 || r != n / 2 {
                        assert_eq!(
                            q + unorm_level(n - 1 - r, n, bits),
                            levels - 1,
                            "n {n} r {r}"
                        );
                    }
                    sum += decoded;
                }
                if n % 2 == 0 {
                    assert_eq!(sum / n as f64, 0.5, "bits {bits} n {n}");
                }
                // Where the level count divides the slice, version 1's rank · 2^bits / n.
                if n % levels == 0 {
                    assert!((0..n).all(|r| unorm_level(r, n, bits) == r * levels / n));
                }
            }
        }
    }

    #[test]
    fn blobs_validate_and_decode_to_the_same_values() {
        let volume = volume();
        for encoding in [Encoding::Unorm8, Encoding::Unorm16, Encoding::F32] {
            let plain = encode_volume(&volume, encoding, Compression::None);
            let view = Stbn::from_bytes(&plain).unwrap();
            assert_eq!(view.data(), encode_payload(&volume, encoding));
            for compression in [Compression::Lz4, Compression::Deflate, Compression::Palette] {
                let blob = encode_volume(&volume, encoding, compression);
                let packed = PackedStbn::from_bytes(&blob).unwrap();
                assert_eq!(packed.decode().unwrap().data(), view.data());
                // Never larger than the stored blob: a codec that does not shrink the payload
                // is dropped, and the header says so.
                assert!(blob.len() <= plain.len(), "{encoding:?} {compression:?}");
                let kept = packed.header().compression;
                assert_eq!(kept == Compression::None, blob == plain);
                assert!(kept == compression || kept == Compression::None);
                assert_eq!(stored_uncompressed(&blob, compression), kept.is_none());
            }
        }
        let view = Stbn::from_bytes(&encode_volume(&volume, Encoding::F32, Compression::None))
            .unwrap()
            .sample(3, 1, 1);
        // Slice 1 is reversed: pixel (3, 1) has rank 0.
        assert_eq!(view, 0.5 / 8.0);
    }

    #[test]
    fn compression_is_kept_only_where_it_shrinks_the_payload() {
        // Every frame of an 8-bit scalar mask holds each level equally often: at its entropy, so
        // neither codec shrinks it. Its F32 values carry log2(pixels) bits in 32: Deflate halves
        // them.
        let spec = stbn_gen::BaselineSpec::new(stbn_gen::BaselineKind::White, 64, 64, 8, 5);
        let volume = stbn_gen::generate_baseline(&spec, stbn_gen::Observer::default()).unwrap();
        for compression in [Compression::Lz4, Compression::Deflate] {
            let blob = encode_volume(&volume, Encoding::Unorm8, compression);
            assert!(stored_uncompressed(&blob, compression), "{compression:?}");
            assert_eq!(
                blob,
                encode_volume(&volume, Encoding::Unorm8, Compression::None)
            );
        }
        let blob = encode_volume(&volume, Encoding::F32, Compression::Deflate);
        assert!(!stored_uncompressed(&blob, Compression::Deflate));
        let plain = encode_volume(&volume, Encoding::F32, Compression::None);
        assert!(
            blob.len() * 10 < plain.len() * 7,
            "{} vs {}",
            blob.len(),
            plain.len()
        );
        assert!(!stored_uncompressed(&plain, Compression::None));
    }

    #[test]
    fn palettes_store_a_scalar_frame_in_log2_pixels_bits() {
        // Every frame holds the same 4096 levels: 12-bit indices where Unorm16 stores 16 and F32
        // 32, plus the levels once. Unorm8 holds each of its 256 levels 16 times a frame: 8 bits
        // either way, so the palette is dropped.
        let spec = stbn_gen::BaselineSpec::new(stbn_gen::BaselineKind::White, 64, 64, 8, 5);
        let volume = stbn_gen::generate_baseline(&spec, stbn_gen::Observer::default()).unwrap();
        let voxels = 64 * 64 * 8;
        for (encoding, bytes) in [(Encoding::Unorm16, 2), (Encoding::F32, 4)] {
            let blob = encode_volume(&volume, encoding, Compression::Palette);
            assert!(!stored_uncompressed(&blob, Compression::Palette));
            assert_eq!(
                blob.len(),
                MaskHeader::SIZE + 4 + 4096 * bytes + voxels * 12 / 8,
                "{encoding:?}"
            );
            let plain = encode_volume(&volume, encoding, Compression::None);
            let decoded = PackedStbn::from_bytes(&blob).unwrap().decode().unwrap();
            assert_eq!(decoded.data(), &plain[MaskHeader::SIZE..]);
        }
        let blob = encode_volume(&volume, Encoding::Unorm8, Compression::Palette);
        assert!(stored_uncompressed(&blob, Compression::Palette));
    }

    #[test]
    fn hemisphere_directions_at_the_horizon_decode_above_it_in_every_encoding() {
        // Directions a hair above the horizon, all around it: each stored pair must decode to
        // z >= 0 and stay within a few storage steps of the direction.
        for encoding in [Encoding::Unorm8, Encoding::Unorm16, Encoding::F32] {
            let step = match encoding {
                Encoding::Unorm8 => 2.0 / 256.0,
                Encoding::Unorm16 => 2.0 / 65536.0,
                Encoding::F32 => 1e-6,
            };
            for i in 0..3600 {
                let phi = i as f32 * (core::f32::consts::TAU / 3600.0);
                for z in [0.0f32, 1e-9, 3e-8, 1e-7] {
                    let n = glam::Vec3::new(phi.cos(), phi.sin(), z).normalize();
                    let e = octahedral_encode(n);
                    let (ux, uy) = above_the_horizon(e.x * 0.5 + 0.5, e.y * 0.5 + 0.5, encoding);
                    let decoded = |u| ValueMap::Octahedral.apply(stored_unit(u, encoding));
                    let (ex, ey) = (decoded(ux), decoded(uy));
                    let d = stbn_runtime::octahedral_decode(glam::Vec2::new(ex, ey));
                    assert!(d.z >= 0.0, "{encoding:?} phi {phi} z {z}: {d}");
                    assert!(
                        (ex - e.x).abs() <= 2.0 * step && (ey - e.y).abs() <= 2.0 * step,
                        "{encoding:?} phi {phi} z {z}: ({ex}, {ey}) from {e}"
                    );
                }
            }
        }
    }
}
