//! `include_stbn!` / `include_packed_stbn!` on the committed `tests/data/scalar_16.stbn`: a
//! 16 × 16 × 8 scalar Unorm8 mask written by `stbn-gen generate --format stbn` from
//! `tests/data/scalar_16.ron`.

use stbn_runtime::{
    BLOB_ALIGN, Encoding, MaskHeader, PackedStbn, Space, Stbn, include_packed_stbn, include_stbn,
};

static MASK: Stbn<'static> = include_stbn!("data/scalar_16.stbn");
static PACKED: PackedStbn<'static> = include_packed_stbn!("data/scalar_16.stbn");
const BYTES: &[u8] = include_bytes!("data/scalar_16.stbn");

#[test]
fn the_embedded_mask_is_the_file_viewed_in_place_and_aligned() {
    assert_eq!(MASK.data(), &BYTES[MaskHeader::SIZE..]);
    assert_eq!(MASK.data().as_ptr() as usize % BLOB_ALIGN, 0);
    assert_eq!(PACKED.payload().as_ptr() as usize % BLOB_ALIGN, 0);
    // The compile-time check skips the payload CRC; the full check passes too.
    let checked = Stbn::from_bytes(BYTES).unwrap();
    assert_eq!(checked.header(), MASK.header());
    assert_eq!(PACKED.header(), MASK.header());
}

#[test]
fn the_embedded_mask_is_the_manifest_entry() {
    let header = MASK.header();
    assert_eq!((header.width, header.height, header.depth), (16, 16, 8));
    assert_eq!(header.channels, 1);
    assert_eq!(header.encoding, Encoding::Unorm8);
    assert_eq!(header.space, Space::Scalar);
}

#[test]
fn every_frame_holds_each_unorm8_level_once() {
    // 256 pixels per frame ranked 0..256 and stored at 8 bits: each level exactly once, sampled
    // as the bin midpoint (q + 0.5) / 256.
    for frame in 0..8 {
        let mut seen = [false; 256];
        for y in 0..16 {
            for x in 0..16 {
                let level = MASK.sample(x, y, frame) * 256.0 - 0.5;
                assert_eq!(level, level.round(), "({x}, {y}, {frame})");
                let level = level as usize;
                assert!(!seen[level], "level {level} twice in frame {frame}");
                seen[level] = true;
            }
        }
    }
}

#[test]
fn the_packed_form_decodes_to_the_view() {
    let mut buffer = [0u8; 16 * 16 * 8];
    let decoded = PACKED.decode_into(&mut buffer).unwrap();
    assert_eq!(decoded.data(), MASK.data());
    assert_eq!(decoded.sample(-1, 40, 1_000_003), MASK.sample(15, 8, 3));
}
