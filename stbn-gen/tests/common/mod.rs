//! What the pinned-output tests share: the digests they pin.

use stbn_gen::VectorVolume;

/// FNV-1a of a byte stream: a digest stable across Rust releases.
pub fn fnv1a(bytes: impl IntoIterator<Item = u8>) -> u64 {
    bytes.into_iter().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// [`fnv1a`] over a vector mask's values, each as its little-endian bits.
pub fn value_digest(volume: &VectorVolume) -> u64 {
    fnv1a(
        volume
            .values()
            .iter()
            .flat_map(|v| v.to_bits().to_le_bytes()),
    )
}
