//! What a verified mask promises: stored values that break a space's range are refused with
//! the voxel and channel named, by every verified constructor and decoder, whatever the
//! checksums say; the blobs the generator's encoding writes pass.

mod common;

use common::{blob, packed_blob};
use glam::Vec3;
use stbn_runtime::{
    Compression, Encoding, Error, MaskHeader, PackedStbn, Space, Stbn, UNIT_LENGTH_TOLERANCE,
    ValueMap, octahedral_encode,
};

/// The F32 payload of `header` (`w × h × d × channels`) holding `fill` everywhere but element
/// `at`, which holds `bad`.
fn f32_payload(header: &MaskHeader, fill: f32, at: usize, bad: f32) -> Vec<u8> {
    (0..header.element_count())
        .flat_map(|i| if i == at { bad } else { fill }.to_le_bytes())
        .collect()
}

/// Every verified way to get a view of `data` (the decoded payload of `header`): uncompressed
/// through both constructors, and each compression through `decode_into` and `decode`.
fn verified_results(header: MaskHeader, data: &[u8]) -> Vec<(String, Result<(), Error>)> {
    let mut out = Vec::new();
    for compression in [
        Compression::None,
        Compression::Lz4,
        Compression::Deflate,
        Compression::Palette,
    ] {
        let bytes = packed_blob(header, compression, data);
        // The checksums are valid: only the values are wrong.
        let packed = PackedStbn::from_bytes_unverified(&bytes).unwrap();
        assert!(Stbn::from_bytes_unverified(&bytes).is_ok() == compression.is_none());
        if compression.is_none() {
            let view = Stbn::from_bytes_unverified(&bytes).unwrap();
            out.push(("Stbn::verify".into(), view.verify()));
            out.push((
                "Stbn::from_bytes".into(),
                Stbn::from_bytes(&bytes).map(|_| ()),
            ));
        }
        out.push((
            format!("PackedStbn::from_bytes {compression:?}"),
            PackedStbn::from_bytes(&bytes).map(|_| ()),
        ));
        let mut buf = vec![0u8; header.decoded_len()];
        out.push((
            format!("decode_into {compression:?}"),
            packed.decode_into(&mut buf).map(|_| ()),
        ));
        #[cfg(feature = "alloc")]
        out.push((
            format!("decode {compression:?}"),
            packed.decode().map(|_| ()),
        ));
    }
    out
}

/// Asserts that every verified path refuses `data` with exactly `expected`, and every path
/// that must accept it (compressed `PackedStbn::from_bytes`, which has not decoded) does.
fn assert_refused(header: MaskHeader, data: &[u8], expected: Error) {
    for (path, result) in verified_results(header, data) {
        if path.starts_with("PackedStbn::from_bytes") && !path.ends_with("None") {
            assert_eq!(result, Ok(()), "{path}: the stream is not decoded yet");
        } else {
            assert_eq!(result, Err(expected), "{path}");
        }
    }
}

fn assert_accepted(header: MaskHeader, data: &[u8]) {
    for (path, result) in verified_results(header, data) {
        assert_eq!(result, Ok(()), "{path}");
    }
}

#[test]
fn f32_nan_infinite_huge_and_negative_values_are_refused_naming_the_voxel() {
    let header = MaskHeader::new(5, 3, 2, 1, Encoding::F32);
    // Voxel 22 = (x 2, y 1, frame 1).
    for bad in [
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        1e30,
        -5.0,
        1.000_000_1,
        -1e-30,
    ] {
        let data = f32_payload(&header, 0.25, 22, bad);
        let expected = Error::InvalidValue {
            x: 2,
            y: 1,
            frame: 1,
            channel: Some(0),
            reason: "an F32 unit value must be a finite number in [0, 1]",
        };
        assert_refused(header, &data, expected);
        assert_eq!(
            expected.to_string(),
            "invalid stbn value at x 2, y 1, frame 1, channel 0: an F32 unit value must be a \
             finite number in [0, 1]"
        );
    }
}

#[test]
fn the_ends_of_the_unit_range_are_accepted() {
    // The generator stores (r + ½) / n, which rounds to 1.0 in f32 for slices of 2^24 pixels.
    let header = MaskHeader::new(4, 1, 1, 1, Encoding::F32);
    let data: Vec<u8> = [0.0f32, -0.0, 1.0, 0.5]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    assert_accepted(header, &data);
    let bytes = blob(header, &data);
    let view = Stbn::from_bytes(&bytes).unwrap();
    assert_eq!(view.sample(2, 0, 0), 1.0);
}

#[test]
fn signed_components_and_the_pdf_channel_name_their_channel() {
    // A signed Vec3 mask: channel 2 of voxel (1, 0, 0) holds NaN.
    let header = MaskHeader::new(2, 2, 1, 3, Encoding::F32).with_space(
        Space::Vec,
        ValueMap::Signed,
        0.0,
        0.0,
    );
    assert_refused(
        header,
        &f32_payload(&header, 0.5, 5, f32::NAN),
        Error::InvalidValue {
            x: 1,
            y: 0,
            frame: 0,
            channel: Some(2),
            reason: "an F32 stored component must be a finite number in [0, 1] (the component \
                     2u - 1 in [-1, 1])",
        },
    );
    // Image points: channel 2 is the pdf; -5 there is refused, not clamped.
    let header = MaskHeader::new(2, 2, 1, 3, Encoding::F32).with_space(
        Space::ImagePoints,
        ValueMap::Unit,
        0.5,
        4.0,
    );
    assert_refused(
        header,
        &f32_payload(&header, 0.5, 11, -5.0),
        Error::InvalidValue {
            x: 1,
            y: 1,
            frame: 0,
            channel: Some(2),
            reason: "the F32 pdf channel must be a finite number in [0, 1] (the pdf from \
                     pdf_min to pdf_max)",
        },
    );
}

/// `u` per channel for `n`, as the generator's encoder stores it (`c · 0.5 + 0.5`, or the
/// octahedral map then that).
fn stored(n: Vec3, map: ValueMap) -> Vec<f32> {
    match map {
        ValueMap::Octahedral => {
            let e = octahedral_encode(n) * 0.5 + 0.5;
            vec![e.x, e.y]
        }
        _ => (n * 0.5 + 0.5).to_array().to_vec(),
    }
}

/// `values` (stored unit values in `[0, 1]`) in `encoding`, quantised like the encoder
/// (`floor(u · 2^bits)`, clamped).
fn encode(values: &[f32], encoding: Encoding) -> Vec<u8> {
    values
        .iter()
        .flat_map(|&u| match encoding {
            Encoding::Unorm8 => vec![(f64::from(u) * 256.0).floor().min(255.0) as u8],
            Encoding::Unorm16 => ((f64::from(u) * 65536.0).floor().min(65535.0) as u16)
                .to_le_bytes()
                .to_vec(),
            Encoding::F32 => u.to_le_bytes().to_vec(),
        })
        .collect()
}

#[test]
fn a_hemisphere_direction_below_the_horizon_is_refused_in_every_encoding() {
    let below = Vec3::new(0.3, -0.4, -0.2).normalize();
    let above = Vec3::new(0.1, 0.2, 0.9).normalize();
    for space in [Space::UniformHemisphere, Space::CosineHemisphere] {
        for (map, channels) in [(ValueMap::Octahedral, 2), (ValueMap::Signed, 3)] {
            for encoding in [Encoding::Unorm8, Encoding::Unorm16, Encoding::F32] {
                let header =
                    MaskHeader::new(3, 2, 2, channels, encoding).with_space(space, map, 0.0, 0.0);
                // Voxel 10 = (x 1, y 1, frame 1) points down.
                let values: Vec<f32> = (0..12)
                    .flat_map(|v| stored(if v == 10 { below } else { above }, map))
                    .collect();
                let data = encode(&values, encoding);
                assert_refused(
                    header,
                    &data,
                    Error::InvalidValue {
                        x: 1,
                        y: 1,
                        frame: 1,
                        channel: None,
                        reason: "a hemisphere direction must decode to z >= 0; this one is \
                                 below the horizon",
                    },
                );
                // The same blob as a sphere is fine, and unverified it samples as stored.
                let sphere = MaskHeader {
                    space: Space::UnitVec,
                    ..header
                };
                assert_accepted(sphere, &data);
                let bytes = blob(header, &data);
                let raw = Stbn::from_bytes_unverified(&bytes).unwrap();
                assert!(raw.sample_vec3(1, 1, 1).z < 0.0);
            }
        }
    }
}

#[test]
fn a_zero_direction_is_refused_not_returned() {
    // (0.5, 0.5, 0.5) maps to the zero vector, which cannot be normalised.
    for channels in [1, 2, 3] {
        let header = MaskHeader::new(2, 1, 1, channels, Encoding::F32).with_space(
            Space::UnitVec,
            ValueMap::Signed,
            0.0,
            0.0,
        );
        let mut values = vec![0.9f32; usize::from(channels)];
        values.extend(vec![0.5f32; usize::from(channels)]);
        assert_refused(
            header,
            &encode(&values, Encoding::F32),
            Error::InvalidValue {
                x: 1,
                y: 0,
                frame: 0,
                channel: None,
                reason: "the stored components are zero or too small to normalise: a direction \
                         must decode to unit length (within 1e-6)",
            },
        );
    }
}

/// Directions on the upper hemisphere down to 1e-6 above the horizon, at many azimuths,
/// written as the generator's encoder writes them, pass in every encoding and map, and sample
/// to unit vectors with z >= 0.
#[test]
fn encoded_hemisphere_directions_near_the_horizon_pass() {
    let mut directions = Vec::new();
    for z in [1.0f32, 0.5, 0.1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6] {
        for k in 0..360 {
            let phi = (k as f32 + 0.25).to_radians();
            let r = (1.0 - z * z).sqrt();
            directions.push(Vec3::new(r * phi.cos(), r * phi.sin(), z).normalize());
        }
    }
    let (w, h) = (360u32, 8u32);
    for space in [Space::UniformHemisphere, Space::CosineHemisphere] {
        for (map, channels) in [(ValueMap::Octahedral, 2), (ValueMap::Signed, 3)] {
            for encoding in [Encoding::Unorm8, Encoding::Unorm16, Encoding::F32] {
                let header =
                    MaskHeader::new(w, h, 1, channels, encoding).with_space(space, map, 0.0, 0.0);
                let values: Vec<f32> = directions.iter().flat_map(|&n| stored(n, map)).collect();
                let data = encode(&values, encoding);
                assert_accepted(header, &data);
                let bytes = blob(header, &data);
                let view = Stbn::from_bytes(&bytes).unwrap();
                for y in 0..h as i32 {
                    for x in 0..w as i32 {
                        let s = view.sample_vector(x, y, 0);
                        assert!(s.value.z >= 0.0, "{header:?} ({x}, {y}): {s:?}");
                        assert!(
                            (s.value.length() - 1.0).abs() <= UNIT_LENGTH_TOLERANCE,
                            "{header:?} ({x}, {y}): {s:?}"
                        );
                        assert!(s.pdf.is_finite() && s.pdf >= 0.0);
                    }
                }
            }
        }
    }
}

#[test]
fn a_tiny_compressed_blob_claiming_gigabytes_is_refused_by_its_header() {
    // 69 bytes: a 5-byte LZ4 or Deflate "payload" for 32768 × 32768 × 2 = 2 GiB.
    for (compression, ratio) in [(Compression::Lz4, "255"), (Compression::Deflate, "1032")] {
        let header = MaskHeader::new(32768, 32768, 1, 2, Encoding::Unorm8);
        let bytes = blob(
            MaskHeader {
                compression,
                ..header
            },
            &[0x1f, 0, 0, 0, 0],
        );
        assert_eq!(bytes.len(), 69);
        let err = PackedStbn::from_bytes(&bytes).unwrap_err();
        let Error::InvalidField { field, reason } = err else {
            panic!("{err:?}");
        };
        assert_eq!(field, "payload_len");
        assert!(reason.contains(ratio), "{reason}");
        assert_eq!(PackedStbn::from_bytes_unverified(&bytes).unwrap_err(), err);
    }
}

#[test]
fn compression_ratio_bounds_are_exact_and_real_streams_stay_within_them() {
    // At the bound the header is accepted, one byte less is refused.
    for (compression, ratio) in [(Compression::Lz4, 255u32), (Compression::Deflate, 1032)] {
        let decoded = 4 * 1024 * 255 * 1032u32;
        let mut header = MaskHeader::new(decoded / 4, 1, 1, 1, Encoding::F32);
        header.compression = compression;
        header.payload_len = decoded / ratio;
        assert!(
            MaskHeader::parse(&header.to_bytes()).is_ok(),
            "{compression:?}"
        );
        header.payload_len -= 1;
        assert!(
            matches!(
                MaskHeader::parse(&header.to_bytes()),
                Err(Error::InvalidField {
                    field: "payload_len",
                    ..
                })
            ),
            "{compression:?}"
        );
    }
    // The most compressible payload, all zeros, compresses well inside the bounds.
    let header = MaskHeader::new(1024, 1024, 4, 1, Encoding::Unorm8);
    let zeros = vec![0u8; header.decoded_len()];
    for compression in [Compression::Lz4, Compression::Deflate] {
        let bytes = packed_blob(header, compression, &zeros);
        let packed = PackedStbn::from_bytes(&bytes).unwrap();
        let mut buf = vec![1u8; zeros.len()];
        assert_eq!(packed.decode_into(&mut buf).unwrap().data(), &zeros[..]);
    }
}
