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

/// `data` compressed as `compression` prescribes.
pub fn compress(compression: Compression, data: &[u8]) -> Vec<u8> {
    match compression {
        Compression::None => data.to_vec(),
        Compression::Lz4 => lz4_flex::block::compress(data),
        Compression::Deflate => miniz_oxide::deflate::compress_to_vec(data, 6),
    }
}

/// A complete blob of `data` (the decoded payload of `h`) stored with `compression`.
pub fn packed_blob(mut h: MaskHeader, compression: Compression, data: &[u8]) -> Vec<u8> {
    assert_eq!(data.len(), h.decoded_len());
    h.compression = compression;
    blob(h, &compress(compression, data))
}
