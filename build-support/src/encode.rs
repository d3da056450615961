//! Turning a generated [`Volume`] into a `.stbn` blob: quantisation, compression, header.

use stbn_gen::Volume;
use stbn_runtime::{Compression, Encoding, MaskHeader};

/// The miniz_oxide level used for [`Compression::Deflate`] (0–10; 9 is zlib's "best").
pub const DEFLATE_LEVEL: u8 = 9;

/// The stored value of rank `rank` in a slice of `pixels` pixels, as `encoding` stores it
/// (little-endian bytes, 1, 2 or 4 of them):
///
/// * `Unorm8`: `q = rank · 256 / pixels` (floor), so each of the 256 levels holds the same number
///   of pixels when 256 divides `pixels`; the runtime reads `(q + 0.5) / 256`.
/// * `Unorm16`: `q = rank · 65536 / pixels` (floor); read as `(q + 0.5) / 65536`.
/// * `F32`: `(rank + 0.5) / pixels`, rounded once from `f64`.
///
/// `rank < pixels` for every rank of a [`Volume`], so the Unorm values stay in range.
fn push_value(out: &mut Vec<u8>, rank: u32, pixels: u64, encoding: Encoding) {
    let rank = u64::from(rank);
    match encoding {
        Encoding::Unorm8 => out.push((rank * 256 / pixels) as u8),
        Encoding::Unorm16 => out.extend_from_slice(&((rank * 65536 / pixels) as u16).to_le_bytes()),
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
/// * `Unorm8`: `q = r · 256 / n` (integer floor), decoded by the runtime as `(q + 0.5) / 256`;
/// * `Unorm16`: `q = r · 65536 / n`, decoded as `(q + 0.5) / 65536`;
/// * `F32`: `(r + 0.5) / n` as `f32`.
///
/// Compression: [`Compression::Lz4`] is the LZ4 *block* format (no size prefix),
/// [`Compression::Deflate`] raw RFC 1951 at level [`DEFLATE_LEVEL`]. The output is deterministic.
///
/// # Panics
/// If the stored payload exceeds `u32::MAX` bytes, which no volume within [`stbn_gen::MaskSpec`]'s
/// limits (at most 2^26 pixels, 4 bytes each) can reach.
pub fn encode_volume(volume: &Volume, encoding: Encoding, compression: Compression) -> Vec<u8> {
    let decoded = encode_payload(volume, encoding);
    let payload = match compression {
        Compression::None => decoded,
        Compression::Lz4 => lz4_flex::block::compress(&decoded),
        Compression::Deflate => miniz_oxide::deflate::compress_to_vec(&decoded, DEFLATE_LEVEL),
    };
    let header = MaskHeader::new(volume.width(), volume.height(), volume.depth(), 1, encoding)
        .with_payload(compression, &payload);
    let mut blob = Vec::with_capacity(MaskHeader::SIZE + payload.len());
    blob.extend_from_slice(&header.to_bytes());
    blob.extend_from_slice(&payload);
    blob
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
        push_value(&mut out, 0, 8, Encoding::Unorm8);
        push_value(&mut out, 7, 8, Encoding::Unorm8);
        push_value(&mut out, 4095, 4096, Encoding::Unorm8);
        assert_eq!(out, [0, 224, 255]);
        out.clear();
        push_value(&mut out, 3, 8, Encoding::Unorm16);
        assert_eq!(out, (3u16 * 8192).to_le_bytes());
        out.clear();
        push_value(&mut out, 1, 4, Encoding::F32);
        assert_eq!(out, 0.375f32.to_le_bytes());
    }

    #[test]
    fn blobs_validate_and_decode_to_the_same_values() {
        let volume = volume();
        for encoding in [Encoding::Unorm8, Encoding::Unorm16, Encoding::F32] {
            let plain = encode_volume(&volume, encoding, Compression::None);
            let view = Stbn::from_bytes(&plain).unwrap();
            assert_eq!(view.data(), encode_payload(&volume, encoding));
            for compression in [Compression::Lz4, Compression::Deflate] {
                let blob = encode_volume(&volume, encoding, compression);
                let packed = PackedStbn::from_bytes(&blob).unwrap();
                assert_eq!(packed.header().compression, compression);
                assert_eq!(packed.decode().unwrap().data(), view.data());
            }
        }
        let view = Stbn::from_bytes(&encode_volume(&volume, Encoding::F32, Compression::None))
            .unwrap()
            .sample(3, 1, 1);
        // Slice 1 is reversed: pixel (3, 1) has rank 0.
        assert_eq!(view, 0.5 / 8.0);
    }
}
