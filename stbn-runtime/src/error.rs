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
    /// A decoded value breaks what its space promises: an F32 element that is not a finite
    /// number in `[0, 1]` (the stored unit value, or the pdf channel's `t`), or a direction that
    /// does not decode to a unit vector (or, for a hemisphere, has `z < 0`). Checked by every
    /// verified constructor and by decoding; see [`Stbn::verify`](crate::Stbn::verify).
    InvalidValue {
        /// Voxel column of the first offending value.
        x: u32,
        /// Voxel row.
        y: u32,
        /// Frame.
        frame: u32,
        /// The offending channel, or `None` when the voxel's decoded direction as a whole is
        /// wrong.
        channel: Option<u8>,
        /// What the value must satisfy.
        reason: &'static str,
    },
    /// The allocator refused the buffer for the decoded payload (`PackedStbn::decode`, feature
    /// `alloc`).
    OutOfMemory {
        /// Bytes requested: the header's decoded length.
        bytes: usize,
    },
}

/// One piece of an [`Error`]'s message: text, or a number written in decimal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Piece {
    Text(&'static str),
    Number(u64),
}

/// A message of up to [`Error::MESSAGE_PIECES`] pieces, padded with empty text.
pub(crate) type Message = [Piece; Error::MESSAGE_PIECES];

impl Error {
    /// Pieces in the longest message.
    pub(crate) const MESSAGE_PIECES: usize = 10;

    /// The message, in pieces: what `Display` writes and, assembled in a `const` context, what
    /// [`include_stbn!`](crate::include_stbn) fails the build with.
    pub(crate) const fn message(&self) -> Message {
        use Piece::{Number, Text};
        const fn pad<const N: usize>(pieces: [Piece; N]) -> Message {
            let mut out = [Text(""); Error::MESSAGE_PIECES];
            let mut i = 0;
            while i < N {
                out[i] = pieces[i];
                i += 1;
            }
            out
        }
        match *self {
            Self::Truncated { needed, available } => pad([
                Text("stbn blob truncated: needs "),
                Number(needed as u64),
                Text(" bytes, only "),
                Number(available as u64),
                Text(" available"),
            ]),
            Self::BadMagic => pad([Text("not an stbn blob: magic bytes are not \"STBN\"")]),
            Self::UnsupportedVersion(v) => pad([
                Text("unsupported stbn format_version "),
                Number(v as u64),
                Text(" (this reader supports version "),
                Number(crate::MaskHeader::FORMAT_VERSION as u64),
                Text(")"),
            ]),
            Self::InvalidField { field, reason } => pad([
                Text("invalid stbn header field `"),
                Text(field),
                Text("`: "),
                Text(reason),
            ]),
            Self::DecodedTooLarge => pad([Text(
                "stbn decoded size (width*height*depth*channels*bytes_per_element) \
                 overflows or exceeds MAX_DECODED_BYTES (2 GiB)",
            )]),
            Self::HeaderChecksum => pad([Text(
                "stbn header checksum mismatch: `header_crc32` is wrong",
            )]),
            Self::PayloadChecksum => pad([Text(
                "stbn payload checksum mismatch: `payload_crc32` is wrong",
            )]),
            Self::PayloadLength => pad([Text(
                "stbn blob length does not match `payload_len`: trailing bytes after the payload",
            )]),
            Self::Compressed => pad([Text(
                "stbn payload is compressed: a zero-copy view needs compression None; \
                 use PackedStbn::decode_into",
            )]),
            Self::BufferTooSmall { needed, available } => pad([
                Text("decode buffer too small: needs "),
                Number(needed as u64),
                Text(" bytes, got "),
                Number(available as u64),
            ]),
            Self::Decompress => pad([Text("stbn payload is not a valid compressed stream")]),
            Self::DecodedLength {
                expected,
                actual: Some(actual),
            } => pad([
                Text("stbn payload decompressed to "),
                Number(actual as u64),
                Text(" bytes, header declares "),
                Number(expected as u64),
            ]),
            Self::DecodedLength {
                expected,
                actual: None,
            } => pad([
                Text("stbn payload decompresses to more than the "),
                Number(expected as u64),
                Text(" bytes the header declares"),
            ]),
            Self::InvalidValue {
                x,
                y,
                frame,
                channel: Some(channel),
                reason,
            } => pad([
                Text("invalid stbn value at x "),
                Number(x as u64),
                Text(", y "),
                Number(y as u64),
                Text(", frame "),
                Number(frame as u64),
                Text(", channel "),
                Number(channel as u64),
                Text(": "),
                Text(reason),
            ]),
            Self::InvalidValue {
                x,
                y,
                frame,
                channel: None,
                reason,
            } => pad([
                Text("invalid stbn value at x "),
                Number(x as u64),
                Text(", y "),
                Number(y as u64),
                Text(", frame "),
                Number(frame as u64),
                Text(": "),
                Text(reason),
            ]),
            Self::OutOfMemory { bytes } => pad([
                Text("cannot allocate "),
                Number(bytes as u64),
                Text(" bytes for the decoded stbn payload"),
            ]),
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for piece in self.message() {
            match piece {
                Piece::Text(text) => f.write_str(text)?,
                Piece::Number(number) => write!(f, "{number}")?,
            }
        }
        Ok(())
    }
}

impl core::error::Error for Error {}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::string::ToString;

    use super::*;

    #[test]
    fn messages_write_their_numbers_in_decimal() {
        let truncated = Error::Truncated {
            needed: 2112,
            available: 100,
        };
        assert_eq!(
            truncated.to_string(),
            "stbn blob truncated: needs 2112 bytes, only 100 available"
        );
        assert_eq!(
            Error::UnsupportedVersion(65535).to_string(),
            "unsupported stbn format_version 65535 (this reader supports version 2)"
        );
        assert_eq!(
            Error::DecodedLength {
                expected: 4096,
                actual: Some(0),
            }
            .to_string(),
            "stbn payload decompressed to 0 bytes, header declares 4096"
        );
        assert_eq!(
            Error::InvalidField {
                field: "width",
                reason: "must be at least 1",
            }
            .to_string(),
            "invalid stbn header field `width`: must be at least 1"
        );
        assert_eq!(
            Error::InvalidValue {
                x: 3,
                y: 0,
                frame: 12,
                channel: Some(1),
                reason: "must be in [0, 1]",
            }
            .to_string(),
            "invalid stbn value at x 3, y 0, frame 12, channel 1: must be in [0, 1]"
        );
        assert_eq!(
            Error::InvalidValue {
                x: 0,
                y: 4,
                frame: 0,
                channel: None,
                reason: "z < 0",
            }
            .to_string(),
            "invalid stbn value at x 0, y 4, frame 0: z < 0"
        );
        assert_eq!(
            Error::OutOfMemory { bytes: 2147483648 }.to_string(),
            "cannot allocate 2147483648 bytes for the decoded stbn payload"
        );
    }
}
