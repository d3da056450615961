//! `PackedStbn::decode` / `OwnedStbn` (feature `alloc`).

mod common;

use common::{Rng, header, packed_blob, random_payload};
use stbn_runtime::{Compression, Encoding, Error, MaskHeader, PackedStbn};

#[test]
fn decode_matches_decode_into() {
    let h = header(9, 4, 3, 2, Encoding::Unorm16);
    let data = random_payload(&h, &mut Rng(4));
    for compression in [
        Compression::None,
        Compression::Lz4,
        Compression::Deflate,
        Compression::Palette,
    ] {
        let bytes = packed_blob(h, compression, &data);
        let packed = PackedStbn::from_bytes(&bytes).unwrap();
        let owned = packed.decode().unwrap();
        let mut buf = vec![0; packed.decoded_len()];
        let borrowed = packed.decode_into(&mut buf).unwrap();
        assert_eq!(owned.data(), &data[..]);
        assert_eq!(owned.header(), borrowed.header());
        assert_eq!(owned.view().data(), borrowed.data());
        assert_eq!(
            owned.view().dimension(3).sample(-4, 9, 2).to_bits(),
            borrowed.dimension(3).sample(-4, 9, 2).to_bits()
        );
    }
}

#[test]
fn decode_reports_stream_errors() {
    let h = header(4, 4, 4, 1, Encoding::Unorm8);
    let stored = [0xFFu8; 3];
    let h = MaskHeader {
        compression: Compression::Lz4,
        ..h
    };
    let bytes = common::blob(h, &stored);
    let err = PackedStbn::from_bytes(&bytes)
        .unwrap()
        .decode()
        .unwrap_err();
    assert!(
        matches!(err, Error::Decompress | Error::DecodedLength { .. }),
        "{err:?}"
    );
}
