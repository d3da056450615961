//! Blob builders and a deterministic RNG shared by the integration tests.
#![allow(dead_code)] // each test binary uses a different subset of the helpers

use stbn_runtime::{Compression, Encoding, MaskHeader};

/// SplitMix64: small, deterministic, good enough for test data.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    pub fn next_u32(&mut self) -> u32 {
        (self.next_u64() >> 32) as u32
    }

    pub fn bytes(&mut self, n: usize) -> Vec<u8> {
        (0..n).map(|_| self.next_u64() as u8).collect()
    }
}

/// An uncompressed header for the given shape; payload fields filled by [`blob`].
pub fn header(w: u32, h: u32, d: u32, channels: u8, encoding: Encoding) -> MaskHeader {
    MaskHeader::new(w, h, d, channels, encoding)
}

/// Header bytes followed by `stored`, with `payload_len`/`payload_crc32` set to match.
pub fn blob(h: MaskHeader, stored: &[u8]) -> Vec<u8> {
    let mut out = h.with_payload(h.compression, stored).to_bytes().to_vec();
    out.extend_from_slice(stored);
    out
}

/// Random decoded payload for `h`: F32 elements are random values in [0, 1).
pub fn random_payload(h: &MaskHeader, rng: &mut Rng) -> Vec<u8> {
    match h.encoding {
        Encoding::Unorm8 | Encoding::Unorm16 => rng.bytes(h.decoded_len()),
        Encoding::F32 => (0..h.decoded_len() / 4)
            .flat_map(|_| ((rng.next_u32() >> 8) as f32 / (1 << 24) as f32).to_le_bytes())
            .collect(),
    }
}

/// `data` (voxels of `voxel_bytes` bytes) compressed as `compression` prescribes.
pub fn compress(compression: Compression, data: &[u8], voxel_bytes: usize) -> Vec<u8> {
    match compression {
        Compression::None => data.to_vec(),
        Compression::Lz4 => lz4_flex::block::compress(data),
        Compression::Deflate => miniz_oxide::deflate::compress_to_vec(data, 6),
        Compression::Palette => palette(data, voxel_bytes),
    }
}

/// A [`Compression::Palette`] payload of `data`, written from the format's description (an
/// oracle independent of build-support's encoder): the sorted distinct voxels, then each
/// voxel's index in `max(1, ⌈log2 P⌉)` bits, least significant bit first.
pub fn palette(data: &[u8], voxel_bytes: usize) -> Vec<u8> {
    let mut entries: Vec<&[u8]> = data.chunks_exact(voxel_bytes).collect();
    entries.sort_unstable();
    entries.dedup();
    let bits = (usize::BITS - (entries.len() - 1).leading_zeros()).max(1);
    let mut out = (entries.len() as u32).to_le_bytes().to_vec();
    entries.iter().for_each(|e| out.extend_from_slice(e));
    let (mut acc, mut have) = (0u128, 0u32);
    for voxel in data.chunks_exact(voxel_bytes) {
        let index = entries
            .binary_search(&voxel)
            .expect("every voxel is an entry");
        acc |= (index as u128) << have;
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

/// Bytes per voxel of `h`'s decoded data.
pub fn voxel_bytes(h: &MaskHeader) -> usize {
    usize::from(h.channels) * h.encoding.bytes_per_element()
}

/// A complete blob of `data` (the decoded payload of `h`) stored with `compression`.
pub fn packed_blob(mut h: MaskHeader, compression: Compression, data: &[u8]) -> Vec<u8> {
    assert_eq!(data.len(), h.decoded_len());
    h.compression = compression;
    blob(h, &compress(compression, data, voxel_bytes(&h)))
}
