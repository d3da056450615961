//! Embedding `.stbn` files: [`include_stbn!`](crate::include_stbn) and
//! [`include_packed_stbn!`](crate::include_packed_stbn), checked at compile time.

use crate::Error;
use crate::error::Piece;

/// Alignment in bytes of the blobs [`include_stbn!`](crate::include_stbn) and
/// [`include_packed_stbn!`](crate::include_packed_stbn) embed: 64, a cache line. The payload
/// starts at byte 64 ([`MaskHeader::SIZE`](crate::MaskHeader::SIZE)), so it is 64-byte aligned
/// too, more than any element type needs.
pub const BLOB_ALIGN: usize = 64;

/// Embeds a `.stbn` file that holds an uncompressed mask as a ready-to-sample
/// [`Stbn<'static>`](crate::Stbn), with its header checked at compile time.
///
/// The path is resolved like [`include_bytes!`]'s: relative to the file the macro is called in,
/// or absolute (e.g. `concat!(env!("OUT_DIR"), "/mask.stbn")`). The file is embedded aligned to
/// [`BLOB_ALIGN`] bytes and viewed in place, without copying. The expansion is a constant
/// expression, usable as a `static`'s or a `const`'s initializer or anywhere else; wherever it is
/// used, the header and the blob's length are checked while compiling
/// ([`Stbn::from_bytes_unverified`](crate::Stbn::from_bytes_unverified)): a truncated, corrupt,
/// compressed or wrong-version file fails the build with a message that names the file and what
/// is wrong, such as
///
/// ```text
/// error[E0080]: evaluation panicked: include_stbn!("masks/scalar.stbn"): stbn blob truncated: needs 2112 bytes, only 100 available
/// ```
///
/// The payload, its CRC and its values, is not checked while compiling (that would cost seconds
/// per megabyte): the mask keeps the sampling promises of
/// [`Stbn::from_bytes`](crate::Stbn::from_bytes) (finite values, unit directions, `z >= 0` on
/// hemispheres, finite pdfs `>= 0`) if the file is as the generator wrote it. If it may have been
/// damaged or written by something else, check it once with
/// [`verify`](crate::Stbn::verify) in a test (`NOISE.verify().unwrap()`); sampling a payload that
/// fails it never panics, but returns its values as stored. A compressed file needs
/// [`include_packed_stbn!`](crate::include_packed_stbn).
///
/// # Example
/// A 16 × 16 × 8 scalar Unorm8 mask written by `stbn-gen generate --format stbn`:
/// ```
/// use stbn_runtime::{Stbn, include_stbn};
///
/// static NOISE: Stbn<'static> = include_stbn!("../tests/data/scalar_16.stbn");
///
/// assert_eq!((NOISE.width(), NOISE.height(), NOISE.depth()), (16, 16, 8));
/// let threshold = NOISE.sample(3, -7, 1000);
/// assert!(threshold > 0.0 && threshold < 1.0);
/// assert_eq!(NOISE.data().as_ptr() as usize % stbn_runtime::BLOB_ALIGN, 0);
/// // The payload's CRC and values, checked once (here; a game would do it in a test).
/// assert!(NOISE.verify().is_ok());
/// ```
///
/// A damaged file does not compile (here the same blob cut after 100 bytes):
/// ```compile_fail,E0080
/// static NOISE: stbn_runtime::Stbn<'static> =
///     stbn_runtime::include_stbn!("../tests/data/truncated.stbn");
/// ```
#[macro_export]
macro_rules! include_stbn {
    ($path:expr $(,)?) => {{
        static BYTES: &$crate::__private::Aligned<[u8]> =
            &$crate::__private::Aligned(*::core::include_bytes!($path));
        const MASK: $crate::Stbn<'static> = match $crate::Stbn::from_bytes_unverified(&BYTES.0) {
            ::core::result::Result::Ok(mask) => mask,
            ::core::result::Result::Err(error) => $crate::__private::invalid_blob(
                ::core::concat!("include_stbn!(", ::core::stringify!($path), ")"),
                error,
            ),
        };
        MASK
    }};
}

/// Embeds a `.stbn` file of any compression as a [`PackedStbn<'static>`](crate::PackedStbn),
/// with its header checked at compile time.
///
/// As [`include_stbn!`](crate::include_stbn) (same path rules, alignment and compile-time
/// checks, through
/// [`PackedStbn::from_bytes_unverified`](crate::PackedStbn::from_bytes_unverified)), for LZ4- or
/// Deflate-compressed masks: decode the result once with
/// [`decode_into`](crate::PackedStbn::decode_into) into a buffer of
/// [`decoded_len`](crate::PackedStbn::decoded_len) bytes, or with `decode` (feature `alloc`).
/// A damaged compressed stream is an error when decoding, never a panic.
///
/// # Example
/// ```
/// use stbn_runtime::{PackedStbn, include_packed_stbn};
///
/// static PACKED: PackedStbn<'static> = include_packed_stbn!("../tests/data/scalar_16.stbn");
///
/// let mut buffer = [0u8; 16 * 16 * 8];
/// let noise = PACKED.decode_into(&mut buffer)?;
/// assert_eq!(noise.sample(3, -7, 1000), stbn_runtime::include_stbn!("../tests/data/scalar_16.stbn").sample(3, -7, 1000));
/// # Ok::<(), stbn_runtime::Error>(())
/// ```
#[macro_export]
macro_rules! include_packed_stbn {
    ($path:expr $(,)?) => {{
        static BYTES: &$crate::__private::Aligned<[u8]> =
            &$crate::__private::Aligned(*::core::include_bytes!($path));
        const MASK: $crate::PackedStbn<'static> =
            match $crate::PackedStbn::from_bytes_unverified(&BYTES.0) {
                ::core::result::Result::Ok(mask) => mask,
                ::core::result::Result::Err(error) => $crate::__private::invalid_blob(
                    ::core::concat!("include_packed_stbn!(", ::core::stringify!($path), ")"),
                    error,
                ),
            };
        MASK
    }};
}

/// What the macros expand to; not part of the API.
#[doc(hidden)]
pub mod __private {
    use super::{BLOB_ALIGN, ConstText};
    use crate::Error;

    /// Bytes aligned to [`BLOB_ALIGN`]: `&Aligned([u8; N])` coerces to `&Aligned<[u8]>`.
    #[repr(C, align(64))]
    pub struct Aligned<Bytes: ?Sized>(pub Bytes);

    const _: () = assert!(core::mem::align_of::<Aligned<[u8; 0]>>() == BLOB_ALIGN);

    /// Fails the constant evaluation of `call` (the macro call, as written) with `error`.
    #[track_caller]
    pub const fn invalid_blob(call: &str, error: Error) -> ! {
        let mut text = ConstText::new();
        text.push(call);
        text.push(": ");
        text.push_error(&error);
        if matches!(error, Error::Compressed) {
            text.push(" (embed a compressed blob with `include_packed_stbn!`)");
        }
        panic!("{}", text.as_str())
    }
}

/// Text assembled in a `const` context, up to [`ConstText::CAPACITY`] bytes: what a compile-time
/// panic can print, which takes one `&str`.
struct ConstText {
    bytes: [u8; ConstText::CAPACITY],
    len: usize,
}

impl ConstText {
    /// The most bytes kept; text beyond it is cut at a character boundary.
    const CAPACITY: usize = 1024;

    const fn new() -> Self {
        Self {
            bytes: [0; Self::CAPACITY],
            len: 0,
        }
    }

    /// Appends as much of `text` as fits, whole characters only.
    const fn push(&mut self, text: &str) {
        let text = text.as_bytes();
        let mut end = if text.len() <= Self::CAPACITY - self.len {
            text.len()
        } else {
            Self::CAPACITY - self.len
        };
        // Back off over UTF-8 continuation bytes (0b10xx_xxxx) to a character boundary.
        while end < text.len() && end > 0 && text[end] & 0xC0 == 0x80 {
            end -= 1;
        }
        let mut i = 0;
        while i < end {
            self.bytes[self.len] = text[i];
            self.len += 1;
            i += 1;
        }
    }

    /// Appends `number` in decimal.
    const fn push_number(&mut self, mut number: u64) {
        let mut digits = [0u8; 20];
        let mut start = digits.len();
        loop {
            start -= 1;
            digits[start] = b'0' + (number % 10) as u8;
            number /= 10;
            if number == 0 {
                break;
            }
        }
        let (_, digits) = digits.split_at(start);
        match core::str::from_utf8(digits) {
            Ok(digits) => self.push(digits),
            Err(_) => unreachable!(),
        }
    }

    /// Appends `error`'s message, the text its `Display` writes.
    const fn push_error(&mut self, error: &Error) {
        let message = error.message();
        let mut i = 0;
        while i < message.len() {
            match message[i] {
                Piece::Text(text) => self.push(text),
                Piece::Number(number) => self.push_number(number),
            }
            i += 1;
        }
    }

    const fn as_str(&self) -> &str {
        let (text, _) = self.bytes.split_at(self.len);
        match core::str::from_utf8(text) {
            Ok(text) => text,
            Err(_) => unreachable!(),
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::string::ToString;

    use super::*;

    fn text_of(error: Error) -> ConstText {
        let mut text = ConstText::new();
        text.push_error(&error);
        text
    }

    #[test]
    fn const_text_is_the_display_text() {
        for error in [
            Error::Truncated {
                needed: 2112,
                available: 100,
            },
            Error::BadMagic,
            Error::UnsupportedVersion(7),
            Error::InvalidField {
                field: "width",
                reason: "must be at least 1",
            },
            Error::DecodedTooLarge,
            Error::HeaderChecksum,
            Error::PayloadChecksum,
            Error::PayloadLength,
            Error::Compressed,
            Error::BufferTooSmall {
                needed: 0,
                available: usize::MAX,
            },
            Error::Decompress,
            Error::DecodedLength {
                expected: 10,
                actual: Some(u64::MAX as usize),
            },
            Error::DecodedLength {
                expected: 10,
                actual: None,
            },
            Error::InvalidValue {
                x: u32::MAX,
                y: 0,
                frame: 7,
                channel: Some(3),
                reason: "an F32 unit value must be a finite number in [0, 1]",
            },
            Error::InvalidValue {
                x: 1,
                y: 2,
                frame: 3,
                channel: None,
                reason: "a hemisphere direction must decode to z >= 0",
            },
            Error::OutOfMemory { bytes: 1 << 31 },
        ] {
            assert_eq!(text_of(error).as_str(), error.to_string());
        }
    }

    #[test]
    fn long_text_is_cut_at_a_character_boundary() {
        let mut text = ConstText::new();
        text.push(&"a".repeat(ConstText::CAPACITY - 1));
        text.push("σσ");
        assert_eq!(text.as_str().len(), ConstText::CAPACITY - 1);
        text.push("b");
        assert_eq!(text.as_str().len(), ConstText::CAPACITY);
        text.push("c");
        assert!(text.as_str().ends_with("ab"));
    }

    #[test]
    #[should_panic(
        expected = "include_stbn!(\"masks/scalar.stbn\"): stbn payload is compressed: a zero-copy \
                    view needs compression None; use PackedStbn::decode_into (embed a compressed \
                    blob with `include_packed_stbn!`)"
    )]
    fn a_compressed_blob_names_the_packed_macro() {
        __private::invalid_blob("include_stbn!(\"masks/scalar.stbn\")", Error::Compressed);
    }

    #[test]
    #[should_panic(
        expected = "include_packed_stbn!(\"x.stbn\"): unsupported stbn format_version 3 (this \
                    reader supports version 2)"
    )]
    fn a_wrong_version_names_both_versions() {
        __private::invalid_blob(
            "include_packed_stbn!(\"x.stbn\")",
            Error::UnsupportedVersion(3),
        );
    }
}
