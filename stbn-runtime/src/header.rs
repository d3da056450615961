//! The 64-byte `.stbn` header: field enums, serialisation and `const` validation.

use crate::Error;

/// Upper bound on a mask's decoded payload, in bytes: 2 GiB (`1 << 31`).
///
/// Headers whose `width * height * depth * channels * bytes_per_element`
/// overflows or exceeds this are rejected with [`Error::DecodedTooLarge`].
/// The bound keeps every element index representable in a 32-bit `usize`
/// and every per-axis offset representable in an `i32`.
pub const MAX_DECODED_BYTES: u64 = 1 << 31;

/// How one stored element (one channel of one voxel) is encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Encoding {
    /// One byte `q`, decoded as `(q + 0.5) / 256`: bin midpoints in `[1/512, 511/512]`.
    Unorm8 = 0,
    /// Two bytes little-endian `q`, decoded as `(q + 0.5) / 65536`.
    Unorm16 = 1,
    /// Four bytes little-endian IEEE-754 `f32`, returned as stored.
    F32 = 2,
}

impl Encoding {
    /// Bytes one element occupies in the decoded payload: 1, 2 or 4.
    pub const fn bytes_per_element(self) -> usize {
        match self {
            Self::Unorm8 => 1,
            Self::Unorm16 => 2,
            Self::F32 => 4,
        }
    }

    /// The enum for header byte 21, or `None` if `byte` is not 0, 1 or 2.
    pub const fn from_u8(byte: u8) -> Option<Self> {
        match byte {
            0 => Some(Self::Unorm8),
            1 => Some(Self::Unorm16),
            2 => Some(Self::F32),
            _ => None,
        }
    }

    /// The header byte for this encoding (0, 1 or 2).
    pub const fn to_u8(self) -> u8 {
        self as u8
    }
}

/// How the payload is stored after the header.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Compression {
    /// The payload is the decoded voxel data itself (`payload_len == decoded_len`).
    None = 0,
    /// LZ4 *block* format without a size prefix.
    Lz4 = 1,
    /// Raw RFC 1951 deflate stream, without a zlib header or trailer.
    Deflate = 2,
}

impl Compression {
    /// The enum for header byte 22, or `None` if `byte` is not 0, 1 or 2.
    pub const fn from_u8(byte: u8) -> Option<Self> {
        match byte {
            0 => Some(Self::None),
            1 => Some(Self::Lz4),
            2 => Some(Self::Deflate),
            _ => None,
        }
    }

    /// The header byte for this compression (0, 1 or 2).
    pub const fn to_u8(self) -> u8 {
        self as u8
    }

    /// `true` for [`Compression::None`], whose payload can be viewed without copying.
    pub const fn is_none(self) -> bool {
        matches!(self, Self::None)
    }
}

/// How a stored unit value `u` in `[0, 1)` maps to the quantity the mask represents.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum ValueMap {
    /// The stored value `u` in `[0, 1)` is the quantity itself.
    Unit = 0,
    /// Each component `c` in `[-1, 1]` is stored as `u = c * 0.5 + 0.5`; decode with
    /// [`ValueMap::apply`] (`c = u * 2 - 1`).
    Signed = 1,
}

impl ValueMap {
    /// The enum for header byte 23, or `None` if `byte` is not 0 or 1.
    pub const fn from_u8(byte: u8) -> Option<Self> {
        match byte {
            0 => Some(Self::Unit),
            1 => Some(Self::Signed),
            _ => None,
        }
    }

    /// The header byte for this value map (0 or 1).
    pub const fn to_u8(self) -> u8 {
        self as u8
    }

    /// Maps a stored unit value `u` (what [`Stbn::sample`](crate::Stbn::sample) returns)
    /// to the represented quantity: `u` for [`Unit`](Self::Unit), `u * 2 - 1` (in
    /// `[-1, 1]`) for [`Signed`](Self::Signed).
    pub const fn apply(self, u: f32) -> f32 {
        match self {
            Self::Unit => u,
            Self::Signed => u * 2.0 - 1.0,
        }
    }
}

/// The parsed 64-byte header of a `.stbn` blob.
///
/// Layout (all little-endian; the payload starts at byte 64):
///
/// | offset | type     | field |
/// |-------:|----------|-------|
/// | 0      | `[u8;4]` | magic `b"STBN"` |
/// | 4      | `u16`    | format_version = 1 |
/// | 6      | `u16`    | header_len = 64 |
/// | 8      | `u32`    | width (≥ 1) |
/// | 12     | `u32`    | height (≥ 1) |
/// | 16     | `u32`    | depth (≥ 1, frames) |
/// | 20     | `u8`     | channels (1..=4) |
/// | 21     | `u8`     | encoding ([`Encoding`]) |
/// | 22     | `u8`     | compression ([`Compression`]) |
/// | 23     | `u8`     | value_map ([`ValueMap`]) |
/// | 24     | `u32`    | payload_len (stored bytes) |
/// | 28     | `u32`    | payload_crc32 (`crc32fast::hash` of the stored payload) |
/// | 32     | `f32`    | pdf_min |
/// | 36     | `f32`    | pdf_max |
/// | 40     | `u32`    | header_crc32 (CRC-32 of bytes `0..40`) |
/// | 44     | `[u8;20]`| reserved, zero |
///
/// The decoded payload holds `width * height * depth * channels` elements in the
/// order `((z * height + y) * width + x) * channels + c`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaskHeader {
    /// Voxels along x, at least 1.
    pub width: u32,
    /// Voxels along y, at least 1.
    pub height: u32,
    /// Frames (voxels along the time axis), at least 1.
    pub depth: u32,
    /// Elements per voxel, 1..=4.
    pub channels: u8,
    /// Element encoding of the decoded payload.
    pub encoding: Encoding,
    /// How the payload is stored.
    pub compression: Compression,
    /// Meaning of the stored unit values.
    pub value_map: ValueMap,
    /// Bytes stored after the header; equals [`decoded_len`](Self::decoded_len)
    /// when `compression` is [`Compression::None`], and is non-zero otherwise.
    pub payload_len: u32,
    /// `crc32fast::hash` (CRC-32/IEEE) of the stored (possibly compressed) payload.
    pub payload_crc32: u32,
    /// Smallest sampling-pdf value the mask was generated for; finite, 0.0 if the mask stores no pdf.
    pub pdf_min: f32,
    /// Largest sampling-pdf value; finite, `>= pdf_min`, 0.0 if the mask stores no pdf.
    pub pdf_max: f32,
}

const MAGIC: [u8; 4] = *b"STBN";
/// Byte offset of `header_crc32`; the checksum covers bytes `0..HEADER_CRC_OFFSET`.
const HEADER_CRC_OFFSET: usize = 40;

impl MaskHeader {
    /// Size of the serialised header in bytes; the payload starts at this offset.
    pub const SIZE: usize = 64;
    /// The only `format_version` this crate reads and writes.
    pub const FORMAT_VERSION: u16 = 1;

    /// The header of an uncompressed mask of unit values (`ValueMap::Unit`) without a pdf, with
    /// an empty payload; [`with_payload`](Self::with_payload) describes the bytes to store.
    pub const fn new(
        width: u32,
        height: u32,
        depth: u32,
        channels: u8,
        encoding: Encoding,
    ) -> Self {
        MaskHeader {
            width,
            height,
            depth,
            channels,
            encoding,
            compression: Compression::None,
            value_map: ValueMap::Unit,
            payload_len: 0,
            payload_crc32: 0,
            pdf_min: 0.0,
            pdf_max: 0.0,
        }
    }

    /// This header describing `stored`, the payload bytes as written after the header (already
    /// compressed with `compression`): sets `compression`, `payload_len` and `payload_crc32`.
    ///
    /// A payload longer than `u32::MAX` bytes records `u32::MAX`, which [`parse`](Self::parse)
    /// rejects as not matching the blob; masks within [`MAX_DECODED_BYTES`](crate::MAX_DECODED_BYTES)
    /// never come close.
    pub fn with_payload(mut self, compression: Compression, stored: &[u8]) -> Self {
        self.compression = compression;
        self.payload_len = u32::try_from(stored.len()).unwrap_or(u32::MAX);
        self.payload_crc32 = crc32fast::hash(stored);
        self
    }

    /// Serialises the header, filling in magic, version, `header_len`,
    /// `header_crc32` and zero reserved bytes.
    ///
    /// Field values are written as they are; a header with out-of-range fields
    /// serialises fine but [`parse`](Self::parse) will reject it.
    pub const fn to_bytes(&self) -> [u8; 64] {
        let mut b = [0u8; 64];
        put(&mut b, 0, &MAGIC);
        put(&mut b, 4, &Self::FORMAT_VERSION.to_le_bytes());
        put(&mut b, 6, &(Self::SIZE as u16).to_le_bytes());
        put(&mut b, 8, &self.width.to_le_bytes());
        put(&mut b, 12, &self.height.to_le_bytes());
        put(&mut b, 16, &self.depth.to_le_bytes());
        b[20] = self.channels;
        b[21] = self.encoding.to_u8();
        b[22] = self.compression.to_u8();
        b[23] = self.value_map.to_u8();
        put(&mut b, 24, &self.payload_len.to_le_bytes());
        put(&mut b, 28, &self.payload_crc32.to_le_bytes());
        put(&mut b, 32, &self.pdf_min.to_le_bytes());
        put(&mut b, 36, &self.pdf_max.to_le_bytes());
        let (covered, _) = b.split_at(HEADER_CRC_OFFSET);
        let crc = crc32_ieee(covered);
        put(&mut b, HEADER_CRC_OFFSET, &crc.to_le_bytes());
        b
    }

    /// Parses and validates the header at the start of `bytes` (bytes after the
    /// first 64 are ignored; the payload is not looked at).
    ///
    /// Checks, in order: length ≥ 64, magic, `format_version`, `header_len`,
    /// `header_crc32`, reserved bytes zero, every field's range (see the field
    /// docs), the decoded size bound ([`MAX_DECODED_BYTES`]) and, for
    /// [`Compression::None`], `payload_len == decoded_len`.
    ///
    /// # Errors
    /// [`Error::Truncated`], [`Error::BadMagic`], [`Error::UnsupportedVersion`],
    /// [`Error::HeaderChecksum`], [`Error::InvalidField`] or [`Error::DecodedTooLarge`].
    pub const fn parse(bytes: &[u8]) -> Result<Self, Error> {
        if bytes.len() < Self::SIZE {
            return Err(Error::Truncated {
                needed: Self::SIZE,
                available: bytes.len(),
            });
        }
        if bytes[0] != MAGIC[0]
            || bytes[1] != MAGIC[1]
            || bytes[2] != MAGIC[2]
            || bytes[3] != MAGIC[3]
        {
            return Err(Error::BadMagic);
        }
        let version = read_u16(bytes, 4);
        if version != Self::FORMAT_VERSION {
            return Err(Error::UnsupportedVersion(version));
        }
        if read_u16(bytes, 6) as usize != Self::SIZE {
            return Err(invalid("header_len", "must be 64"));
        }
        let (covered, _) = bytes.split_at(HEADER_CRC_OFFSET);
        if crc32_ieee(covered) != read_u32(bytes, HEADER_CRC_OFFSET) {
            return Err(Error::HeaderChecksum);
        }
        let mut i = 44;
        while i < Self::SIZE {
            if bytes[i] != 0 {
                return Err(invalid("reserved", "bytes 44..64 must be zero"));
            }
            i += 1;
        }

        let width = read_u32(bytes, 8);
        let height = read_u32(bytes, 12);
        let depth = read_u32(bytes, 16);
        if width == 0 {
            return Err(invalid("width", "must be at least 1"));
        }
        if height == 0 {
            return Err(invalid("height", "must be at least 1"));
        }
        if depth == 0 {
            return Err(invalid("depth", "must be at least 1"));
        }
        let channels = bytes[20];
        if channels == 0 || channels > 4 {
            return Err(invalid("channels", "must be in 1..=4"));
        }
        let Some(encoding) = Encoding::from_u8(bytes[21]) else {
            return Err(invalid(
                "encoding",
                "must be 0 (Unorm8), 1 (Unorm16) or 2 (F32)",
            ));
        };
        let Some(compression) = Compression::from_u8(bytes[22]) else {
            return Err(invalid(
                "compression",
                "must be 0 (None), 1 (Lz4) or 2 (Deflate)",
            ));
        };
        let Some(value_map) = ValueMap::from_u8(bytes[23]) else {
            return Err(invalid("value_map", "must be 0 (Unit) or 1 (Signed)"));
        };
        let pdf_min = f32::from_bits(read_u32(bytes, 32));
        let pdf_max = f32::from_bits(read_u32(bytes, 36));
        if !pdf_min.is_finite() {
            return Err(invalid("pdf_min", "must be finite"));
        }
        if !pdf_max.is_finite() {
            return Err(invalid("pdf_max", "must be finite"));
        }
        if pdf_min > pdf_max {
            return Err(invalid("pdf_max", "must be >= pdf_min"));
        }

        let header = Self {
            width,
            height,
            depth,
            channels,
            encoding,
            compression,
            value_map,
            payload_len: read_u32(bytes, 24),
            payload_crc32: read_u32(bytes, 28),
            pdf_min,
            pdf_max,
        };
        let Some(decoded_len) = header.checked_decoded_len() else {
            return Err(Error::DecodedTooLarge);
        };
        match compression {
            Compression::None => {
                if header.payload_len as usize != decoded_len {
                    return Err(invalid(
                        "payload_len",
                        "must equal width*height*depth*channels*bytes_per_element \
                         when compression is None",
                    ));
                }
            }
            Compression::Lz4 | Compression::Deflate => {
                if header.payload_len == 0 {
                    return Err(invalid(
                        "payload_len",
                        "must be non-zero for a compressed payload",
                    ));
                }
            }
        }
        Ok(header)
    }

    /// Decoded payload size in bytes: `width * height * depth * channels *
    /// bytes_per_element`, at most [`MAX_DECODED_BYTES`] for a parsed header.
    ///
    /// For a hand-built header whose product overflows or exceeds the bound this
    /// saturates to `usize::MAX`.
    pub const fn decoded_len(&self) -> usize {
        match self.checked_decoded_len() {
            Some(len) => len,
            None => usize::MAX,
        }
    }

    /// Number of elements (`width * height * depth * channels`) in the decoded payload.
    pub const fn element_count(&self) -> usize {
        self.decoded_len() / self.encoding.bytes_per_element()
    }

    /// The decoded size if it is within [`MAX_DECODED_BYTES`] (and `usize`).
    const fn checked_decoded_len(&self) -> Option<usize> {
        let factors = [
            self.height as u64,
            self.depth as u64,
            self.channels as u64,
            self.encoding.bytes_per_element() as u64,
        ];
        let mut len = self.width as u64;
        let mut i = 0;
        while i < factors.len() {
            len = match len.checked_mul(factors[i]) {
                Some(v) => v,
                None => return None,
            };
            i += 1;
        }
        if len > MAX_DECODED_BYTES || len > usize::MAX as u64 {
            return None;
        }
        Some(len as usize)
    }
}

const fn invalid(field: &'static str, reason: &'static str) -> Error {
    Error::InvalidField { field, reason }
}

const fn put(dst: &mut [u8; 64], offset: usize, src: &[u8]) {
    let mut i = 0;
    while i < src.len() {
        dst[offset + i] = src[i];
        i += 1;
    }
}

const fn read_u16(b: &[u8], offset: usize) -> u16 {
    u16::from_le_bytes([b[offset], b[offset + 1]])
}

const fn read_u32(b: &[u8], offset: usize) -> u32 {
    u32::from_le_bytes([b[offset], b[offset + 1], b[offset + 2], b[offset + 3]])
}

/// Bitwise CRC-32/IEEE (reflected, polynomial `0xEDB88320`, init and xor-out
/// `0xFFFF_FFFF`): the same function as `crc32fast::hash`, but usable in `const`
/// contexts. Eight shift steps per byte, so it is used only for the 40 header
/// bytes; payloads go through `crc32fast`.
pub(crate) const fn crc32_ieee(bytes: &[u8]) -> u32 {
    let mut crc = u32::MAX;
    let mut i = 0;
    while i < bytes.len() {
        crc ^= bytes[i] as u32;
        let mut bit = 0;
        while bit < 8 {
            crc = if crc & 1 == 1 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
            bit += 1;
        }
        i += 1;
    }
    !crc
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn const_crc_matches_crc32fast() {
        assert_eq!(crc32_ieee(b""), crc32fast::hash(b""));
        assert_eq!(crc32_ieee(b"123456789"), 0xCBF4_3926);
        let mut data = [0u8; 300];
        let mut state = 0x1234_5678u32;
        for b in data.iter_mut() {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            *b = (state >> 24) as u8;
        }
        for len in 0..data.len() {
            assert_eq!(
                crc32_ieee(&data[..len]),
                crc32fast::hash(&data[..len]),
                "len {len}"
            );
        }
    }

    #[test]
    fn const_crc_is_usable_in_const_context() {
        const CHECK: u32 = crc32_ieee(b"123456789");
        assert_eq!(CHECK, crc32fast::hash(b"123456789"));
    }

    #[test]
    fn decoded_len_saturates_for_hand_built_headers() {
        let h = MaskHeader::new(u32::MAX, u32::MAX, u32::MAX, 4, Encoding::F32);
        assert_eq!(h.decoded_len(), usize::MAX);
        assert_eq!(
            MaskHeader::parse(&h.to_bytes()),
            Err(Error::DecodedTooLarge)
        );
    }

    #[test]
    fn enum_bytes_round_trip() {
        for b in 0..=255u8 {
            if let Some(e) = Encoding::from_u8(b) {
                assert_eq!(e.to_u8(), b);
            }
            if let Some(c) = Compression::from_u8(b) {
                assert_eq!(c.to_u8(), b);
            }
            if let Some(v) = ValueMap::from_u8(b) {
                assert_eq!(v.to_u8(), b);
            }
        }
        assert_eq!(Encoding::from_u8(3), None);
        assert_eq!(Compression::from_u8(3), None);
        assert_eq!(ValueMap::from_u8(2), None);
        assert_eq!(ValueMap::Signed.apply(0.75), 0.5);
        assert_eq!(ValueMap::Unit.apply(0.75), 0.75);
    }
}
