//! A blob assembled in const context and validated into a `static Stbn`, as
//! `include_stbn!` does with a file.

use stbn_runtime::{Compression, Encoding, Error, MaskHeader, PackedStbn, Space, Stbn, ValueMap};

const W: u32 = 8;
const H: u32 = 4;
const D: u32 = 2;
const PAYLOAD_LEN: usize = (W * H * D) as usize;
const BLOB_LEN: usize = MaskHeader::SIZE + PAYLOAD_LEN;

/// Payload byte `i`: a permutation of 0..64 scaled to the byte range.
const fn payload_byte(i: usize) -> u8 {
    ((i * 29 % PAYLOAD_LEN) * 4) as u8
}

const fn payload() -> [u8; PAYLOAD_LEN] {
    let mut p = [0u8; PAYLOAD_LEN];
    let mut i = 0;
    while i < PAYLOAD_LEN {
        p[i] = payload_byte(i);
        i += 1;
    }
    p
}

/// CRC-32 of [`payload`], checked against `crc32fast` at run time below.
const PAYLOAD_CRC: u32 = 0x8AA8_E31D;

const HEADER: MaskHeader = MaskHeader {
    width: W,
    height: H,
    depth: D,
    channels: 1,
    encoding: Encoding::Unorm8,
    compression: Compression::None,
    value_map: ValueMap::Unit,
    space: Space::Scalar,
    payload_len: PAYLOAD_LEN as u32,
    payload_crc32: PAYLOAD_CRC,
    pdf_min: 0.0,
    pdf_max: 0.0,
};

const fn build_blob() -> [u8; BLOB_LEN] {
    let header = HEADER.to_bytes();
    let payload = payload();
    let mut out = [0u8; BLOB_LEN];
    let mut i = 0;
    while i < BLOB_LEN {
        out[i] = if i < MaskHeader::SIZE {
            header[i]
        } else {
            payload[i - MaskHeader::SIZE]
        };
        i += 1;
    }
    out
}

static BYTES: [u8; BLOB_LEN] = build_blob();

/// The generated-code pattern: an invalid blob would be a compile-time panic.
pub static SCALAR_8X4X2: Stbn<'static> = match Stbn::from_bytes_unverified(&BYTES) {
    Ok(s) => s,
    Err(_) => panic!("embedded STBN blob is invalid"),
};

/// The generated-code pattern for compressed masks (the same const validation; this blob
/// happens to be stored uncompressed, which a `PackedStbn` also accepts).
pub static PACKED_8X4X2: PackedStbn<'static> = match PackedStbn::from_bytes_unverified(&BYTES) {
    Ok(s) => s,
    Err(_) => panic!("embedded STBN blob is invalid"),
};

/// A packed blob one byte short is rejected in const context.
const PACKED_TRUNCATED: Result<PackedStbn<'static>, Error> =
    PackedStbn::from_bytes_unverified(BYTES.split_at(BLOB_LEN - 1).0);

#[test]
fn static_packed_mask_decodes() {
    let mut buf = [0u8; PAYLOAD_LEN];
    let view = PACKED_8X4X2.decode_into(&mut buf).unwrap();
    assert_eq!(view.data(), &payload());
    assert!(matches!(PACKED_TRUNCATED, Err(Error::Truncated { .. })));
}

/// `from_bytes_unverified` really is evaluated at compile time: errors are constants too.
const TRUNCATED: Result<Stbn<'static>, Error> = Stbn::from_bytes_unverified(BYTES.split_at(70).0);

#[test]
fn static_mask_samples_its_payload() {
    assert_eq!(
        crc32fast::hash(&payload()),
        PAYLOAD_CRC,
        "update PAYLOAD_CRC"
    );
    // Full validation (payload CRC included) agrees with the const-validated static.
    let verified = Stbn::from_bytes(&BYTES).unwrap();
    assert_eq!(verified.header(), SCALAR_8X4X2.header());
    assert_eq!(SCALAR_8X4X2.data(), &payload()[..]);
    assert_eq!(
        (
            SCALAR_8X4X2.width(),
            SCALAR_8X4X2.height(),
            SCALAR_8X4X2.depth()
        ),
        (W, H, D)
    );
    for f in 0..D {
        for y in 0..H {
            for x in 0..W {
                let i = ((f * H + y) * W + x) as usize;
                let expected = (f32::from(payload_byte(i)) + 0.5) / 256.0;
                assert_eq!(SCALAR_8X4X2.sample(x as i32, y as i32, f), expected);
                assert_eq!(
                    SCALAR_8X4X2.sample(x as i32 - W as i32, y as i32 + 3 * H as i32, f + D),
                    expected
                );
            }
        }
    }
    assert_eq!(
        TRUNCATED.unwrap_err(),
        Error::Truncated {
            needed: BLOB_LEN,
            available: 70
        }
    );
}
