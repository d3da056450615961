//! Header serialisation and every kind of blob corruption.

mod common;

use common::{Rng, blob, header, packed_blob, random_payload};
use stbn_runtime::{
    Compression, Encoding, Error, MAX_DECODED_BYTES, MaskHeader, PackedStbn, Space, Stbn, ValueMap,
};

/// Re-signs a header edited through raw bytes, so only the edited field is wrong.
fn resign(bytes: &mut [u8]) {
    let crc = crc32fast::hash(&bytes[..60]);
    bytes[60..64].copy_from_slice(&crc.to_le_bytes());
}

/// A valid 3×5×2 two-channel Unorm16 blob.
fn sample_blob() -> Vec<u8> {
    let h = header(3, 5, 2, 2, Encoding::Unorm16);
    blob(h, &random_payload(&h, &mut Rng(7)))
}

/// Every entry point that validates a header must report the same error.
fn all_reject(bytes: &[u8]) -> Error {
    let packed = PackedStbn::from_bytes(bytes).expect_err("PackedStbn accepted a bad blob");
    let view = Stbn::from_bytes(bytes).expect_err("Stbn accepted a bad blob");
    let unverified =
        Stbn::from_bytes_unverified(bytes).expect_err("from_bytes_unverified accepted a bad blob");
    assert_eq!(packed, view);
    assert_eq!(packed, unverified);
    packed
}

#[test]
fn header_round_trips_and_matches_the_documented_layout() {
    let h = MaskHeader {
        width: 11,
        height: 7,
        depth: 9,
        channels: 3,
        encoding: Encoding::F32,
        compression: Compression::Deflate,
        value_map: ValueMap::Octahedral,
        space: Space::EnvironmentDirections,
        payload_len: 0x0A0B_0C0D,
        payload_crc32: 0xDEAD_BEEF,
        pdf_min: 0.5,
        pdf_max: 2.25,
    };
    let b = h.to_bytes();
    assert_eq!(&b[0..4], b"STBN");
    assert_eq!(u16::from_le_bytes([b[4], b[5]]), 2);
    assert_eq!(u16::from_le_bytes([b[6], b[7]]), 64);
    assert_eq!(u32::from_le_bytes(b[8..12].try_into().unwrap()), 11);
    assert_eq!(u32::from_le_bytes(b[12..16].try_into().unwrap()), 7);
    assert_eq!(u32::from_le_bytes(b[16..20].try_into().unwrap()), 9);
    assert_eq!(&b[20..24], &[3, 2, 2, 2]);
    assert_eq!(
        u32::from_le_bytes(b[24..28].try_into().unwrap()),
        0x0A0B_0C0D
    );
    assert_eq!(
        u32::from_le_bytes(b[28..32].try_into().unwrap()),
        0xDEAD_BEEF
    );
    assert_eq!(f32::from_le_bytes(b[32..36].try_into().unwrap()), 0.5);
    assert_eq!(f32::from_le_bytes(b[36..40].try_into().unwrap()), 2.25);
    assert_eq!(b[40], 6);
    assert!(b[41..60].iter().all(|&x| x == 0));
    assert_eq!(
        u32::from_le_bytes(b[60..64].try_into().unwrap()),
        crc32fast::hash(&b[..60])
    );
    assert_eq!(MaskHeader::parse(&b), Ok(h));
    // Three channels: the octahedral pair and the pdf; values have three components.
    assert_eq!(h.value_channels(), 2);
    assert_eq!(h.dims(), 3);
    assert_eq!(h.decoded_len(), 11 * 7 * 9 * 3 * 4);
    assert_eq!(h.element_count(), 11 * 7 * 9 * 3);

    for encoding in [Encoding::Unorm8, Encoding::Unorm16, Encoding::F32] {
        for compression in [
            Compression::None,
            Compression::Lz4,
            Compression::Deflate,
            Compression::Palette,
        ] {
            for value_map in [ValueMap::Unit, ValueMap::Signed] {
                let h = MaskHeader {
                    encoding,
                    compression,
                    value_map,
                    space: Space::Vec,
                    pdf_min: 0.0,
                    pdf_max: 0.0,
                    channels: 4,
                    payload_len: 11 * 7 * 9 * 4 * encoding.bytes_per_element() as u32,
                    ..h
                };
                assert_eq!(MaskHeader::parse(&h.to_bytes()), Ok(h));
            }
        }
    }
}

#[test]
fn header_is_const_constructible_and_parsable() {
    const H: MaskHeader = MaskHeader {
        width: 2,
        height: 2,
        depth: 1,
        channels: 1,
        encoding: Encoding::Unorm8,
        compression: Compression::None,
        value_map: ValueMap::Unit,
        space: Space::Scalar,
        payload_len: 4,
        payload_crc32: 0,
        pdf_min: 0.0,
        pdf_max: 0.0,
    };
    const BYTES: [u8; 64] = H.to_bytes();
    const PARSED: Result<MaskHeader, Error> = MaskHeader::parse(&BYTES);
    assert_eq!(PARSED, Ok(H));
}

#[test]
fn valid_blob_is_accepted_everywhere() {
    let bytes = sample_blob();
    let packed = PackedStbn::from_bytes(&bytes).unwrap();
    assert_eq!(packed.payload(), &bytes[64..]);
    assert_eq!(packed.decoded_len(), 3 * 5 * 2 * 2 * 2);
    let view = Stbn::from_bytes(&bytes).unwrap();
    assert_eq!(view.data(), &bytes[64..]);
    assert_eq!(view.header(), packed.header());
    assert_eq!(
        (view.width(), view.height(), view.depth(), view.channels()),
        (3, 5, 2, 2)
    );
    assert_eq!(view.encoding(), Encoding::Unorm16);
    assert_eq!(
        Stbn::from_bytes_unverified(&bytes).unwrap().data(),
        view.data()
    );
}

#[test]
fn truncation_at_every_length_is_an_error() {
    for compression in [
        Compression::None,
        Compression::Lz4,
        Compression::Deflate,
        Compression::Palette,
    ] {
        let h = header(4, 3, 2, 1, Encoding::Unorm8);
        let bytes = packed_blob(h, compression, &random_payload(&h, &mut Rng(1)));
        for len in 0..bytes.len() {
            let err = PackedStbn::from_bytes(&bytes[..len]).unwrap_err();
            let needed = if len < 64 { 64 } else { bytes.len() };
            assert_eq!(
                err,
                Error::Truncated {
                    needed,
                    available: len
                },
                "{compression:?} len {len}"
            );
            assert!(Stbn::from_bytes(&bytes[..len]).is_err());
            assert!(Stbn::from_bytes_unverified(&bytes[..len]).is_err());
            if len < 64 {
                assert_eq!(MaskHeader::parse(&bytes[..len]), Err(err));
            } else {
                assert!(MaskHeader::parse(&bytes[..len]).is_ok());
            }
        }
        assert!(PackedStbn::from_bytes(&bytes).is_ok());
    }
}

#[test]
fn trailing_bytes_are_rejected() {
    let mut bytes = sample_blob();
    bytes.push(0);
    assert_eq!(all_reject(&bytes), Error::PayloadLength);
}

#[test]
fn every_header_bit_flip_is_detected_with_the_right_error() {
    let bytes = sample_blob();
    for i in 0..64 {
        for mask in (0..8).map(|bit| 1u8 << bit).chain([0xFF]) {
            let mut bad = bytes.clone();
            bad[i] ^= mask;
            let err = all_reject(&bad);
            let ok = match i {
                0..4 => err == Error::BadMagic,
                4..6 => matches!(err, Error::UnsupportedVersion(v) if v != 2),
                6..8 => {
                    err == Error::InvalidField {
                        field: "header_len",
                        reason: "must be 64",
                    }
                }
                8..64 => err == Error::HeaderChecksum,
                _ => unreachable!(),
            };
            assert!(ok, "byte {i} ^ {mask:#04x}: {err:?}");
        }
    }
}

#[test]
fn every_payload_byte_flip_is_a_checksum_error() {
    for compression in [
        Compression::None,
        Compression::Lz4,
        Compression::Deflate,
        Compression::Palette,
    ] {
        let h = header(5, 3, 2, 1, Encoding::Unorm8);
        let bytes = packed_blob(h, compression, &random_payload(&h, &mut Rng(3)));
        for i in 64..bytes.len() {
            let mut bad = bytes.clone();
            bad[i] ^= 0x10;
            assert_eq!(
                PackedStbn::from_bytes(&bad).unwrap_err(),
                Error::PayloadChecksum
            );
            let expected = if compression == Compression::None {
                Error::PayloadChecksum
            } else {
                Error::Compressed
            };
            assert_eq!(Stbn::from_bytes(&bad).unwrap_err(), expected);
        }
    }
    // The unverified constructor skips exactly this check.
    let mut bad = sample_blob();
    bad[70] ^= 1;
    assert!(Stbn::from_bytes_unverified(&bad).is_ok());
}

/// Sets raw header bytes at `offset`, re-signs, and returns the parse error.
fn field_error(offset: usize, value: &[u8]) -> Error {
    let mut bytes = sample_blob();
    bytes[offset..offset + value.len()].copy_from_slice(value);
    resign(&mut bytes);
    all_reject(&bytes)
}

fn invalid(field: &'static str) -> impl Fn(Error) -> bool {
    move |e| matches!(e, Error::InvalidField { field: f, .. } if f == field)
}

#[test]
fn each_field_range_is_enforced() {
    assert_eq!(
        field_error(4, &1u16.to_le_bytes()),
        Error::UnsupportedVersion(1)
    );
    assert_eq!(
        field_error(4, &0u16.to_le_bytes()),
        Error::UnsupportedVersion(0)
    );
    assert!(invalid("header_len")(field_error(6, &63u16.to_le_bytes())));
    assert!(invalid("width")(field_error(8, &0u32.to_le_bytes())));
    assert!(invalid("height")(field_error(12, &0u32.to_le_bytes())));
    assert!(invalid("depth")(field_error(16, &0u32.to_le_bytes())));
    assert!(invalid("channels")(field_error(20, &[0])));
    assert!(invalid("channels")(field_error(20, &[5])));
    assert!(invalid("channels")(field_error(20, &[255])));
    assert!(invalid("encoding")(field_error(21, &[3])));
    for bad in [4u8, 5, 128, 255] {
        assert!(invalid("encoding")(field_error(21, &[bad])));
        assert!(invalid("compression")(field_error(22, &[bad])));
    }
    assert!(invalid("value_map")(field_error(23, &[3])));
    // Octahedral needs a 3D unit space; the sample blob is a two-channel scalar mask.
    assert!(invalid("space")(field_error(23, &[2])));
    assert!(invalid("space")(field_error(40, &[7])));
    assert!(invalid("space")(field_error(40, &[255])));
    // Two Signed channels are a circle, not a hemisphere (which needs 3) ...
    assert!(invalid("space")(field_error(
        40,
        &[Space::CosineHemisphere.to_u8()]
    )));
    // ... and a space that stores a pdf needs a pdf range.
    assert!(invalid("pdf_max")(field_error(
        40,
        &[Space::ImagePoints.to_u8()]
    )));
    assert!(invalid("value_map")(field_error(23, &[255])));
    // payload_len must equal decoded_len (120) when uncompressed.
    assert!(invalid("payload_len")(field_error(
        24,
        &119u32.to_le_bytes()
    )));
    assert!(invalid("payload_len")(field_error(
        24,
        &121u32.to_le_bytes()
    )));
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        assert!(invalid("pdf_min")(field_error(32, &bad.to_le_bytes())));
        assert!(invalid("pdf_max")(field_error(36, &bad.to_le_bytes())));
    }
    // A space without a stored pdf must have a zero range.
    assert!(invalid("pdf_min")(field_error(36, &1.0f32.to_le_bytes())));
    // An image space: 2 value channels + pdf = 3 channels, Unit values.
    let image = |pdf_min: f32, pdf_max: f32| {
        let h = header(3, 5, 2, 3, Encoding::Unorm8).with_space(
            Space::ImagePoints,
            ValueMap::Unit,
            pdf_min,
            pdf_max,
        );
        blob(h, &random_payload(&h, &mut Rng(9)))
    };
    assert!(Stbn::from_bytes(&image(0.0, 3.5)).is_ok());
    assert!(invalid("pdf_max")(all_reject(&image(2.0, 1.0))));
    assert!(invalid("pdf_max")(all_reject(&image(0.0, 0.0))));
    assert!(invalid("pdf_min")(all_reject(&image(-1.0, 1.0))));
    // Reserved bytes must be zero (re-signed, so this is the range check, not the CRC).
    for i in 41..60 {
        let mut bytes = sample_blob();
        bytes[i] = 1;
        resign(&mut bytes);
        assert!(invalid("reserved")(all_reject(&bytes)), "reserved byte {i}");
    }
    // Magic
    let mut bytes = sample_blob();
    bytes[0..4].copy_from_slice(b"STBM");
    resign(&mut bytes);
    assert_eq!(all_reject(&bytes), Error::BadMagic);
}

#[test]
fn compressed_payload_len_zero_is_rejected() {
    let h = MaskHeader {
        compression: Compression::Lz4,
        ..header(2, 2, 2, 1, Encoding::Unorm8)
    };
    let bytes = blob(h, &[]);
    assert!(invalid("payload_len")(
        MaskHeader::parse(&bytes).unwrap_err()
    ));
}

#[test]
fn decoded_length_overflow_and_bound_are_rejected() {
    let too_large = |w: u32, h: u32, d: u32, c: u8, e: Encoding| {
        let mut hd = header(w, h, d, c, e);
        hd.compression = Compression::Lz4;
        // Enough stored bytes for any decoded size within the bound (LZ4 expands at most 255×).
        hd.payload_len = u32::MAX;
        MaskHeader::parse(&hd.to_bytes())
    };
    // Overflows u64.
    assert_eq!(
        too_large(u32::MAX, u32::MAX, u32::MAX, 4, Encoding::F32),
        Err(Error::DecodedTooLarge)
    );
    // Fits u64 but exceeds 2^31 by one element.
    assert_eq!(
        too_large(1 << 16, 1 << 15, 1, 1, Encoding::Unorm16),
        Err(Error::DecodedTooLarge)
    );
    assert_eq!(
        too_large((1 << 31) + 1, 1, 1, 1, Encoding::Unorm8),
        Err(Error::DecodedTooLarge)
    );
    // Exactly the bound is allowed.
    let ok = too_large(1 << 16, 1 << 14, 2, 1, Encoding::Unorm8).unwrap();
    assert_eq!(ok.decoded_len() as u64, MAX_DECODED_BYTES);
    let ok = too_large(1 << 31, 1, 1, 1, Encoding::Unorm8).unwrap();
    assert_eq!(ok.decoded_len() as u64, MAX_DECODED_BYTES);
}

#[test]
fn random_garbage_never_panics() {
    let mut rng = Rng(99);
    let good = sample_blob();
    for round in 0..20_000 {
        let mut bytes = good.clone();
        let flips = 1 + round % 4;
        for _ in 0..flips {
            let i = rng.next_u32() as usize % bytes.len();
            bytes[i] = rng.next_u64() as u8;
        }
        let cut = rng.next_u32() as usize % (bytes.len() + 1);
        let bytes = if round % 3 == 0 {
            &bytes[..cut]
        } else {
            &bytes[..]
        };
        let _ = MaskHeader::parse(bytes);
        let _ = PackedStbn::from_bytes(bytes);
        let _ = Stbn::from_bytes(bytes);
        let _ = Stbn::from_bytes_unverified(bytes);
    }
}

#[test]
fn display_messages_name_the_problem() {
    let msg = |e: Error| e.to_string();
    assert!(msg(field_error(20, &[9])).contains("`channels`"));
    assert!(msg(field_error(8, &0u32.to_le_bytes())).contains("`width`"));
    assert!(
        msg(Error::Truncated {
            needed: 64,
            available: 3
        })
        .contains("64")
    );
    assert!(msg(Error::UnsupportedVersion(7)).contains('7'));
    assert!(msg(Error::PayloadChecksum).contains("payload_crc32"));
    assert!(msg(Error::HeaderChecksum).contains("header_crc32"));
    assert!(
        msg(Error::BufferTooSmall {
            needed: 10,
            available: 4
        })
        .contains("10")
    );
    assert!(
        msg(Error::DecodedLength {
            expected: 8,
            actual: None
        })
        .contains('8')
    );
    let boxed: Box<dyn std::error::Error> = Box::new(Error::BadMagic);
    assert!(boxed.to_string().contains("STBN"));
}
