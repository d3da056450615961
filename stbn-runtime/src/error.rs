//! The error type shared by header parsing, payload validation and decoding.

use core::fmt;

/// Everything that can go wrong while validating or decoding a `.stbn` blob.
///
/// Every fallible function in this crate returns this type; none of them
/// panics on malformed input.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Error {
    /// The input ends before the data it must contain.
    Truncated {
        /// Bytes required: 64 for the header, `64 + payload_len` for a blob.
        needed: usize,
        /// Bytes actually present.
        available: usize,
    },
    /// The first four bytes are not `b"STBN"`.
    BadMagic,
    /// `format_version` is not [`MaskHeader::FORMAT_VERSION`](crate::MaskHeader::FORMAT_VERSION);
    /// holds the version found.
    UnsupportedVersion(u16),
    /// A header field holds a value outside its allowed range.
    InvalidField {
        /// The field's name as written in the format description (`"width"`, `"channels"`, ...).
        field: &'static str,
        /// What the field must satisfy.
        reason: &'static str,
    },
    /// `width * height * depth * channels * bytes_per_element` overflows or
    /// exceeds [`MAX_DECODED_BYTES`](crate::MAX_DECODED_BYTES).
    DecodedTooLarge,
    /// `header_crc32` does not match the CRC-32 of header bytes `0..60`.
    HeaderChecksum,
    /// `payload_crc32` does not match the CRC-32 of the stored payload.
    PayloadChecksum,
    /// The blob holds bytes after the `payload_len` payload bytes.
    PayloadLength,
    /// A zero-copy view was requested of a blob whose payload is compressed;
    /// decode it with [`PackedStbn::decode_into`](crate::PackedStbn::decode_into) instead.
    Compressed,
    /// The destination buffer cannot hold the decoded payload.
    BufferTooSmall {
        /// Decoded payload size in bytes.
        needed: usize,
        /// Size of the buffer that was passed, in bytes.
        available: usize,
    },
    /// The compressed payload is not a well-formed stream of its declared
    /// compression (or has bytes after the end of the stream).
    Decompress,
    /// The compressed payload decodes to a size other than the header's decoded length.
    DecodedLength {
        /// Decoded length declared by the header, in bytes.
        expected: usize,
        /// Bytes the stream produced, or `None` if it would produce more than `expected`.
        actual: Option<usize>,
    },
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::Truncated { needed, available } => write!(
                f,
                "stbn blob truncated: needs {needed} bytes, only {available} available"
            ),
            Self::BadMagic => f.write_str("not an stbn blob: magic bytes are not \"STBN\""),
            Self::UnsupportedVersion(v) => write!(
                f,
                "unsupported stbn format_version {v} (this reader supports version 1)"
            ),
            Self::InvalidField { field, reason } => {
                write!(f, "invalid stbn header field `{field}`: {reason}")
            }
            Self::DecodedTooLarge => f.write_str(
                "stbn decoded size (width*height*depth*channels*bytes_per_element) \
                 overflows or exceeds MAX_DECODED_BYTES (2 GiB)",
            ),
            Self::HeaderChecksum => {
                f.write_str("stbn header checksum mismatch: `header_crc32` is wrong")
            }
            Self::PayloadChecksum => {
                f.write_str("stbn payload checksum mismatch: `payload_crc32` is wrong")
            }
            Self::PayloadLength => f.write_str(
                "stbn blob length does not match `payload_len`: trailing bytes after the payload",
            ),
            Self::Compressed => f.write_str(
                "stbn payload is compressed: a zero-copy view needs compression None; \
                 use PackedStbn::decode_into",
            ),
            Self::BufferTooSmall { needed, available } => write!(
                f,
                "decode buffer too small: needs {needed} bytes, got {available}"
            ),
            Self::Decompress => f.write_str("stbn payload is not a valid compressed stream"),
            Self::DecodedLength {
                expected,
                actual: Some(actual),
            } => write!(
                f,
                "stbn payload decompressed to {actual} bytes, header declares {expected}"
            ),
            Self::DecodedLength {
                expected,
                actual: None,
            } => write!(
                f,
                "stbn payload decompresses to more than the {expected} bytes the header declares"
            ),
        }
    }
}

impl core::error::Error for Error {}
