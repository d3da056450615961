//! `PackedStbn`: views, no-alloc decoding of LZ4/Deflate/palette payloads, and broken streams.

mod common;

use common::{Rng, blob, compress, header, packed_blob, random_payload, voxel_bytes};
use stbn_runtime::{Compression, Encoding, Error, MaskHeader, PackedStbn, Stbn};

/// The byte-stream codecs, whose decoders report a stream of the wrong length as such.
const COMPRESSED: [Compression; 2] = [Compression::Lz4, Compression::Deflate];
/// Every codec.
const ALL: [Compression; 4] = [
    Compression::None,
    Compression::Lz4,
    Compression::Deflate,
    Compression::Palette,
];

/// Payloads of several kinds: random, constant, ramp (compressible), for a few shapes.
fn cases() -> Vec<(MaskHeader, Vec<u8>)> {
    let mut rng = Rng(11);
    let mut out = Vec::new();
    for (w, h, d, c, e) in [
        (1, 1, 1, 1, Encoding::Unorm8),
        (3, 5, 7, 2, Encoding::Unorm16),
        (16, 16, 4, 1, Encoding::Unorm8),
        (8, 8, 2, 4, Encoding::F32),
        (128, 128, 4, 1, Encoding::Unorm8),
    ] {
        let hd = header(w, h, d, c, e);
        let n = hd.decoded_len();
        out.push((hd, random_payload(&hd, &mut rng)));
        if e == Encoding::F32 {
            // Stored values must be in [0, 1]: a constant and a ramp of them.
            let elements = n / 4;
            out.push((hd, 0.375f32.to_le_bytes().repeat(elements)));
            out.push((
                hd,
                (0..elements)
                    .flat_map(|i| ((i / 3) as f32 / elements as f32).to_le_bytes())
                    .collect(),
            ));
        } else {
            out.push((hd, vec![0x5A; n]));
            out.push((hd, (0..n).map(|i| (i / 3) as u8).collect()));
        }
    }
    out
}

#[test]
fn decode_into_round_trips_every_compression() {
    for (h, data) in cases() {
        for compression in ALL {
            let bytes = packed_blob(h, compression, &data);
            let packed = PackedStbn::from_bytes(&bytes).unwrap();
            assert_eq!(packed.header().compression, compression);
            assert_eq!(packed.decoded_len(), data.len());

            // Exact-size buffer.
            let mut buf = vec![0xEE; data.len()];
            let s = packed.decode_into(&mut buf).unwrap();
            assert_eq!(s.data(), &data[..], "{compression:?} {h:?}");
            // The view's header describes its data as a valid uncompressed blob.
            assert_eq!(s.header().compression, Compression::None);
            assert_eq!(s.header().payload_len as usize, data.len());
            let mut reblob = s.header().to_bytes().to_vec();
            reblob.extend_from_slice(s.data());
            let again = Stbn::from_bytes(&reblob).unwrap();
            assert_eq!(again.data(), &data[..]);
            assert_eq!(
                again.sample(-3, 7, 11).to_bits(),
                s.sample(-3, 7, 11).to_bits()
            );

            // Larger buffer: only the prefix is written.
            let mut big = vec![0xEE; data.len() + 17];
            let s = packed.decode_into(&mut big).unwrap();
            assert_eq!(s.data().len(), data.len());
            assert!(big[data.len()..].iter().all(|&b| b == 0xEE));
            assert_eq!(&big[..data.len()], &data[..]);

            // Too small: an error, and nothing panics.
            for short in [0, data.len() - 1] {
                let mut small = vec![0; short];
                assert_eq!(
                    packed.decode_into(&mut small).unwrap_err(),
                    Error::BufferTooSmall {
                        needed: data.len(),
                        available: short
                    }
                );
            }
        }
    }
}

#[test]
fn views_require_an_uncompressed_payload() {
    let (h, data) = cases().swap_remove(3);
    for compression in COMPRESSED {
        let bytes = packed_blob(h, compression, &data);
        let packed = PackedStbn::from_bytes(&bytes).unwrap();
        assert_eq!(packed.payload(), &bytes[64..]);
        assert_eq!(packed.view().unwrap_err(), Error::Compressed);
        assert_eq!(Stbn::from_bytes(&bytes).unwrap_err(), Error::Compressed);
        assert_eq!(
            Stbn::from_bytes_unverified(&bytes).unwrap_err(),
            Error::Compressed
        );
    }
    let bytes = packed_blob(h, Compression::None, &data);
    let view = PackedStbn::from_bytes(&bytes).unwrap().view().unwrap();
    // Zero-copy: the view borrows the blob's own bytes.
    assert!(std::ptr::eq(view.data().as_ptr(), bytes[64..].as_ptr()));
}

/// A blob whose header declares `h` but whose stream encodes `stream_data`.
fn mismatched(h: MaskHeader, compression: Compression, stream_data: &[u8]) -> Vec<u8> {
    blob(
        MaskHeader { compression, ..h },
        &compress(compression, stream_data, voxel_bytes(&h)),
    )
}

#[test]
fn wrong_decoded_size_is_reported() {
    let h = header(16, 16, 4, 1, Encoding::Unorm8);
    let n = h.decoded_len();
    let mut rng = Rng(5);
    for compression in COMPRESSED {
        let mut buf = vec![0; n + 100];
        // Stream one byte short.
        let bytes = mismatched(h, compression, &rng.bytes(n - 1));
        let err = PackedStbn::from_bytes(&bytes)
            .unwrap()
            .decode_into(&mut buf)
            .unwrap_err();
        assert_eq!(
            err,
            Error::DecodedLength {
                expected: n,
                actual: Some(n - 1)
            },
            "{compression:?}"
        );
        // Stream one byte long, and much longer.
        for extra in [1, 5000] {
            let bytes = mismatched(h, compression, &rng.bytes(n + extra));
            let err = PackedStbn::from_bytes(&bytes)
                .unwrap()
                .decode_into(&mut buf)
                .unwrap_err();
            assert_eq!(
                err,
                Error::DecodedLength {
                    expected: n,
                    actual: None
                },
                "{compression:?} +{extra}"
            );
        }
    }
}

#[test]
fn deflate_trailing_bytes_after_the_stream_are_rejected() {
    let (h, data) = cases().swap_remove(2);
    let mut stored = compress(Compression::Deflate, &data, 1);
    stored.push(0);
    let bytes = blob(
        MaskHeader {
            compression: Compression::Deflate,
            ..h
        },
        &stored,
    );
    let mut buf = vec![0; data.len()];
    assert_eq!(
        PackedStbn::from_bytes(&bytes)
            .unwrap()
            .decode_into(&mut buf)
            .unwrap_err(),
        Error::Decompress
    );
}

#[test]
fn corrupted_streams_error_and_never_panic() {
    let mut rng = Rng(77);
    let mut errors = 0;
    for (h, data) in cases().into_iter().take(9) {
        for compression in [Compression::Lz4, Compression::Deflate, Compression::Palette] {
            let good = compress(compression, &data, voxel_bytes(&h));
            let header = MaskHeader { compression, ..h };
            let mut buf = vec![0; data.len()];
            // Truncated streams (re-signed so the CRC passes): always an error, from the
            // header's ratio check when too short to hold the decoded size, else the decoder.
            for cut in 1..good.len() {
                let bytes = blob(header, &good[..cut]);
                let r = PackedStbn::from_bytes(&bytes).and_then(|p| p.decode_into(&mut buf));
                assert!(r.is_err(), "{compression:?} truncated to {cut} decoded");
                errors += 1;
            }
            // Random byte corruption: may decode to other data, must not panic.
            for _ in 0..300 {
                let mut stored = good.clone();
                let i = rng.next_u32() as usize % stored.len();
                stored[i] ^= 1 << (rng.next_u32() % 8);
                let bytes = blob(header, &stored);
                if PackedStbn::from_bytes(&bytes)
                    .unwrap()
                    .decode_into(&mut buf)
                    .is_err()
                {
                    errors += 1;
                }
            }
            // Pure garbage streams.
            for len in [1, 2, 7, 64, 1000] {
                let bytes = blob(header, &rng.bytes(len));
                let r = PackedStbn::from_bytes(&bytes).and_then(|p| p.decode_into(&mut buf));
                if let Err(e) = r {
                    assert!(
                        matches!(
                            e,
                            Error::Decompress
                                | Error::DecodedLength { .. }
                                | Error::InvalidValue { .. }
                                | Error::InvalidField {
                                    field: "payload_len",
                                    ..
                                }
                        ),
                        "{e:?}"
                    );
                    errors += 1;
                }
            }
        }
    }
    assert!(errors > 1000, "{errors}");
}

#[test]
fn corrupting_a_stored_stream_without_resigning_is_a_checksum_error() {
    let (h, data) = cases().swap_remove(4);
    for compression in COMPRESSED {
        let mut bytes = packed_blob(h, compression, &data);
        let last = bytes.len() - 1;
        bytes[last] ^= 0x80;
        assert_eq!(
            PackedStbn::from_bytes(&bytes).unwrap_err(),
            Error::PayloadChecksum
        );
    }
}

/// A palette blob of `h` with the payload given as its parts.
fn palette_blob(h: MaskHeader, count: u32, palette: &[u8], indices: &[u8]) -> Vec<u8> {
    let mut payload = count.to_le_bytes().to_vec();
    payload.extend_from_slice(palette);
    payload.extend_from_slice(indices);
    blob(
        MaskHeader {
            compression: Compression::Palette,
            ..h
        },
        &payload,
    )
}

/// Palette sizes around every bit-width step decode exactly, in the documented size.
#[test]
fn palettes_use_ceil_log2_bits_per_voxel() {
    for (count, bits) in [
        (1u32, 1u32),
        (2, 1),
        (3, 2),
        (4, 2),
        (5, 3),
        (256, 8),
        (257, 9),
    ] {
        let h = header(32, 16, 2, 1, Encoding::Unorm16);
        let voxels = 32 * 16 * 2;
        let data: Vec<u8> = (0..voxels)
            .flat_map(|i| ((i * 7 % count as usize) as u16 * 3).to_le_bytes())
            .collect();
        let bytes = packed_blob(h, Compression::Palette, &data);
        assert_eq!(
            bytes.len() - 64,
            4 + 2 * count as usize + (voxels * bits as usize).div_ceil(8),
            "{count} entries"
        );
        let mut buf = vec![0; data.len()];
        let view = PackedStbn::from_bytes(&bytes)
            .unwrap()
            .decode_into(&mut buf)
            .unwrap();
        assert_eq!(view.data(), &data[..], "{count} entries");
    }
}

/// Every malformed palette payload is refused as a bad stream; none panics.
#[test]
fn malformed_palettes_are_refused() {
    let h = header(4, 2, 1, 1, Encoding::Unorm8); // 8 voxels of 1 byte
    let palette = [10, 20, 30];
    // 8 two-bit indices (0, 1, 2, 0, 1, 2, 0, 1), least significant bit first.
    let good = [0b00_10_01_00, 0b01_00_10_01];
    let decode = |bytes: &[u8]| {
        let mut buf = vec![0; 8];
        PackedStbn::from_bytes(bytes)
            .and_then(|p| p.decode_into(&mut buf).map(|v| v.data().to_vec()))
    };
    assert_eq!(
        decode(&palette_blob(h, 3, &palette, &good)).unwrap(),
        [10, 20, 30, 10, 20, 30, 10, 20]
    );
    let bad: [(&str, Vec<u8>); 9] = [
        ("a repeated entry", palette_blob(h, 3, &[10, 10, 30], &good)),
        (
            "entries out of order",
            palette_blob(h, 3, &[20, 10, 30], &good),
        ),
        (
            "two-byte entries out of order in their first byte",
            // 4 one-bit indices into 2 Unorm16 voxels: (1, 0) sorts after (0, 1).
            palette_blob(
                header(4, 1, 1, 1, Encoding::Unorm16),
                2,
                &[1, 0, 0, 1],
                &[0b1010],
            ),
        ),
        (
            "empty palette",
            palette_blob(h, 0, &[10, 20, 30, 40, 50, 60, 70], &[0; 2]),
        ),
        (
            "more entries than voxels",
            palette_blob(h, 9, &[0; 9], &[0; 3]),
        ),
        (
            "an index past the palette",
            palette_blob(h, 3, &palette, &[0b11_00_00_00, 0]),
        ),
        (
            "non-zero padding",
            // 5 voxels of 2 bits: 10 bits, the last 6 of the second byte unused.
            palette_blob(
                header(5, 1, 1, 1, Encoding::Unorm8),
                3,
                &palette,
                &[0, 0b0100],
            ),
        ),
        (
            "a trailing byte",
            palette_blob(h, 3, &palette, &[good[0], good[1], 0]),
        ),
        ("a missing byte", palette_blob(h, 3, &palette, &[good[0]])),
    ];
    for (what, bytes) in &bad {
        let mut buf = vec![0; 8];
        let err = PackedStbn::from_bytes(bytes)
            .and_then(|p| p.decode_into(&mut buf).map(|_| ()))
            .unwrap_err();
        assert!(
            matches!(err, Error::Decompress | Error::InvalidField { .. }),
            "{what}: {err:?}"
        );
    }
    // A payload shorter than its length field, one voxel and a bit per voxel is refused by
    // the header, before anything is allocated.
    let tiny = palette_blob(header(2048, 2048, 8, 4, Encoding::F32), 1, &[0; 16], &[]);
    assert!(matches!(
        PackedStbn::from_bytes(&tiny).unwrap_err(),
        Error::InvalidField {
            field: "payload_len",
            ..
        }
    ));
}
