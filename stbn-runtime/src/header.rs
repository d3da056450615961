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
    #[must_use]
    pub const fn bytes_per_element(self) -> usize {
        match self {
            Self::Unorm8 => 1,
            Self::Unorm16 => 2,
            Self::F32 => 4,
        }
    }

    /// The enum for header byte 21, or `None` if `byte` is not 0, 1 or 2.
    #[must_use]
    pub const fn from_u8(byte: u8) -> Option<Self> {
        match byte {
            0 => Some(Self::Unorm8),
            1 => Some(Self::Unorm16),
            2 => Some(Self::F32),
            _ => None,
        }
    }

    /// The header byte for this encoding (0, 1 or 2).
    #[must_use]
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
    /// The distinct voxels once, then one index per voxel: a little-endian `u32` palette length
    /// `P` (`1 ≤ P ≤` voxel count), the `P` distinct voxels (each `channels × bytes_per_element`
    /// bytes, as decoded) in strictly ascending byte order, then each voxel's palette index in
    /// `max(1, ⌈log2 P⌉)` bits, packed least significant bit first into bytes in voxel order, the
    /// last byte's unused bits 0. Every frame of a scalar mask holds the same `width × height`
    /// levels, so the indices need `log2(width × height)` bits where the data stores 16 or 32;
    /// vector masks, whose voxels are nearly all distinct, do not shrink.
    Palette = 3,
}

impl Compression {
    /// The enum for header byte 22, or `None` if `byte` is not 0, 1, 2 or 3.
    #[must_use]
    pub const fn from_u8(byte: u8) -> Option<Self> {
        match byte {
            0 => Some(Self::None),
            1 => Some(Self::Lz4),
            2 => Some(Self::Deflate),
            3 => Some(Self::Palette),
            _ => None,
        }
    }

    /// The header byte for this compression (0, 1, 2 or 3).
    #[must_use]
    pub const fn to_u8(self) -> u8 {
        self as u8
    }

    /// `true` for [`Compression::None`], whose payload can be viewed without copying.
    #[must_use]
    pub const fn is_none(self) -> bool {
        matches!(self, Self::None)
    }
}

/// How a stored unit value `u` in `[0, 1)` maps to the quantity the mask represents.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum ValueMap {
    /// The stored value `u` (in `(0, 1)` for Unorm encodings, `[0, 1]` for F32) is the quantity
    /// itself.
    Unit = 0,
    /// Each component `c` in `[-1, 1]` is stored as `u = c * 0.5 + 0.5`; decode with
    /// [`ValueMap::apply`] (`c = u * 2 - 1`).
    Signed = 1,
    /// A unit 3D vector stored in two channels as its octahedral map (Cigolle et al. 2014):
    /// `n / (|n.x| + |n.y| + |n.z|)`, the lower hemisphere folded over the diagonals, then
    /// `u = e * 0.5 + 0.5` per channel. [`Stbn::sample_vec3`](crate::Stbn::sample_vec3) decodes
    /// it back to a unit vector. Needs a 3D unit [`Space`] and exactly two value channels.
    Octahedral = 2,
}

impl ValueMap {
    /// The enum for header byte 23, or `None` if `byte` is not 0, 1 or 2.
    #[must_use]
    pub const fn from_u8(byte: u8) -> Option<Self> {
        match byte {
            0 => Some(Self::Unit),
            1 => Some(Self::Signed),
            2 => Some(Self::Octahedral),
            _ => None,
        }
    }

    /// The header byte for this value map (0, 1 or 2).
    #[must_use]
    pub const fn to_u8(self) -> u8 {
        self as u8
    }

    /// Maps a stored unit value `u` (what [`Stbn::sample`](crate::Stbn::sample) returns)
    /// to the represented component: `u` for [`Unit`](Self::Unit), `u * 2 - 1` (in
    /// `[-1, 1]`) for [`Signed`](Self::Signed) and for the octahedral coordinates of
    /// [`Octahedral`](Self::Octahedral) (which then still need
    /// [`octahedral_decode`](crate::octahedral_decode)).
    #[must_use]
    pub const fn apply(self, u: f32) -> f32 {
        match self {
            Self::Unit => u,
            Self::Signed | Self::Octahedral => u * 2.0 - 1.0,
        }
    }
}

/// What a mask's values are samples of: the space and the distribution they were drawn from.
///
/// It fixes how many components a value has ([`MaskHeader::dims`]), whether the mask stores a
/// pdf channel ([`Space::stores_pdf`]) and, where the pdf is derivable, what
/// [`Stbn::sample_pdf`](crate::Stbn::sample_pdf) returns.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Space {
    /// Independent uniform scalars in `[0, 1)`, one per channel (scalar STBN and its baselines).
    /// pdf 1.
    Scalar = 0,
    /// Uniform vectors in `[0, 1)^n` (or `[-1, 1]^n` with [`ValueMap::Signed`]), optimised
    /// jointly. pdf 1 (`2^-n` when signed).
    Vec = 1,
    /// Uniform unit vectors: `±1` (n = 1, pdf ½ per sign), the circle (n = 2, pdf `1/(2π)` per
    /// radian) or the sphere (n = 3, pdf `1/(4π)` per steradian).
    UnitVec = 2,
    /// Uniform directions on the hemisphere `z ≥ 0`; pdf `1/(2π)` per steradian.
    UniformHemisphere = 3,
    /// Cosine-weighted directions on the hemisphere `z ≥ 0`; pdf `z/π` per steradian.
    CosineHemisphere = 4,
    /// Points in `[0, 1)²` drawn with density proportional to an image's luminance. The last
    /// channel stores the pdf (per unit area of `[0, 1)²`).
    ImagePoints = 5,
    /// Unit directions drawn from a latitude-longitude environment map's luminance. The last
    /// channel stores the pdf per steradian (including the `sin θ` Jacobian).
    EnvironmentDirections = 6,
}

impl Space {
    /// The enum for header byte 40, or `None` if `byte` is above 6.
    #[must_use]
    pub const fn from_u8(byte: u8) -> Option<Self> {
        match byte {
            0 => Some(Self::Scalar),
            1 => Some(Self::Vec),
            2 => Some(Self::UnitVec),
            3 => Some(Self::UniformHemisphere),
            4 => Some(Self::CosineHemisphere),
            5 => Some(Self::ImagePoints),
            6 => Some(Self::EnvironmentDirections),
            _ => None,
        }
    }

    /// The header byte for this space (0..=6).
    #[must_use]
    pub const fn to_u8(self) -> u8 {
        self as u8
    }

    /// `true` for the spaces whose pdf is not derivable from the value, so the last channel
    /// stores it: [`ImagePoints`](Self::ImagePoints) and
    /// [`EnvironmentDirections`](Self::EnvironmentDirections).
    #[must_use]
    pub const fn stores_pdf(self) -> bool {
        matches!(self, Self::ImagePoints | Self::EnvironmentDirections)
    }

    /// `true` for spaces of unit vectors (values are normalised after decoding).
    #[must_use]
    pub const fn is_unit(self) -> bool {
        matches!(
            self,
            Self::UnitVec
                | Self::UniformHemisphere
                | Self::CosineHemisphere
                | Self::EnvironmentDirections
        )
    }

    /// `true` for spaces of 3D unit vectors only (the ones that may use
    /// [`ValueMap::Octahedral`]); [`UnitVec`](Self::UnitVec) is 1D, 2D or 3D.
    const fn is_direction3(self) -> bool {
        matches!(
            self,
            Self::UniformHemisphere | Self::CosineHemisphere | Self::EnvironmentDirections
        )
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
/// | 40     | `u8`     | space ([`Space`]) |
/// | 41     | `[u8;19]`| reserved, zero |
/// | 60     | `u32`    | header_crc32 (CRC-32 of bytes `0..60`) |
///
/// The decoded payload holds `width * height * depth * channels` elements in the
/// order `((z * height + y) * width + x) * channels + c`. The first
/// [`value_channels`](Self::value_channels) channels hold the value; when
/// [`Space::stores_pdf`] the last channel holds the pdf normalised to `[0, 1]` as
/// `t = (pdf - pdf_min) / (pdf_max - pdf_min)`, stored full-range (Unorm `q = round(t · (2^bits - 1))`,
/// read back as `q / (2^bits - 1)`, so `pdf_min` and `pdf_max` are exact; F32 stores `t`).
///
/// Consistency rules checked by [`parse`](Self::parse), in value channels (channels
/// without the pdf): 1..=4 for [`Space::Scalar`] and [`Space::Vec`]; 1..=3 for
/// [`Space::UnitVec`]; 3 for the hemispheres and environment directions; 2 for
/// [`Space::ImagePoints`]; [`ValueMap::Octahedral`] only for 3D unit vectors, in 2 value
/// channels; unit spaces are never [`ValueMap::Unit`]; a pdf range (`0 <= pdf_min <= pdf_max`,
/// `pdf_max > 0`) exactly when the space stores a pdf, both zero otherwise.
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
    /// What the values are samples of.
    pub space: Space,
    /// Bytes stored after the header; equals [`decoded_len`](Self::decoded_len)
    /// when `compression` is [`Compression::None`]; otherwise non-zero and at least
    /// `decoded_len / 255` (LZ4), `decoded_len / 1032` (Deflate) or, for [`Compression::Palette`],
    /// 4 bytes, one voxel and one bit per voxel.
    pub payload_len: u32,
    /// `crc32fast::hash` (CRC-32/IEEE) of the stored (possibly compressed) payload.
    pub payload_crc32: u32,
    /// Smallest pdf value stored in the pdf channel; finite, `>= 0`; 0.0 if the space stores no pdf.
    pub pdf_min: f32,
    /// Largest pdf value stored in the pdf channel; finite, `> 0` and `>= pdf_min` if the space
    /// stores a pdf, 0.0 otherwise.
    pub pdf_max: f32,
}

const MAGIC: [u8; 4] = *b"STBN";
/// Byte offset of `header_crc32`; the checksum covers bytes `0..HEADER_CRC_OFFSET`.
const HEADER_CRC_OFFSET: usize = 60;
/// First reserved byte; bytes `RESERVED_START..HEADER_CRC_OFFSET` must be zero.
const RESERVED_START: usize = 41;

impl MaskHeader {
    /// Size of the serialised header in bytes; the payload starts at this offset.
    pub const SIZE: usize = 64;
    /// The only `format_version` this crate reads and writes. Version 2 added
    /// [`space`](Self::space) and moved `header_crc32` to byte 60.
    pub const FORMAT_VERSION: u16 = 2;

    /// The header of an uncompressed mask of [`Space::Scalar`] unit values (`ValueMap::Unit`)
    /// without a pdf, with an empty payload; [`with_payload`](Self::with_payload) describes the
    /// bytes to store and [`with_space`](Self::with_space) other spaces.
    #[must_use]
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
            space: Space::Scalar,
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
    /// rejects as not matching the blob; masks within [`MAX_DECODED_BYTES`]
    /// never come close.
    #[must_use]
    pub fn with_payload(mut self, compression: Compression, stored: &[u8]) -> Self {
        self.compression = compression;
        self.payload_len = u32::try_from(stored.len()).unwrap_or(u32::MAX);
        self.payload_crc32 = crc32fast::hash(stored);
        self
    }

    /// This header with `space`, `value_map` and the stored pdf range `pdf_min..=pdf_max`
    /// (pass `0.0, 0.0` for spaces that store no pdf).
    #[must_use]
    pub const fn with_space(
        mut self,
        space: Space,
        value_map: ValueMap,
        pdf_min: f32,
        pdf_max: f32,
    ) -> Self {
        self.space = space;
        self.value_map = value_map;
        self.pdf_min = pdf_min;
        self.pdf_max = pdf_max;
        self
    }

    /// Channels holding the value: [`channels`](Self::channels) minus the pdf channel, if any.
    #[must_use]
    pub const fn value_channels(&self) -> u8 {
        if self.space.stores_pdf() {
            self.channels.saturating_sub(1)
        } else {
            self.channels
        }
    }

    /// Components of one decoded value: 3 for [`ValueMap::Octahedral`], otherwise
    /// [`value_channels`](Self::value_channels).
    #[must_use]
    pub const fn dims(&self) -> u8 {
        match self.value_map {
            ValueMap::Octahedral => 3,
            _ => self.value_channels(),
        }
    }

    /// Serialises the header, filling in magic, version, `header_len`,
    /// `header_crc32` and zero reserved bytes.
    ///
    /// Field values are written as they are; a header with out-of-range fields
    /// serialises fine but [`parse`](Self::parse) will reject it.
    #[must_use]
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
        b[40] = self.space.to_u8();
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
    /// docs), the decoded size bound ([`MAX_DECODED_BYTES`]), for
    /// [`Compression::None`] `payload_len == decoded_len`, and for a compressed payload that
    /// `payload_len` can hold `decoded_len` (at most 255 decoded bytes per stored byte for LZ4,
    /// 1032 for Deflate, the formats' largest expansions; for a palette, its length, one voxel and
    /// one bit per voxel).
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
        let mut i = RESERVED_START;
        while i < HEADER_CRC_OFFSET {
            if bytes[i] != 0 {
                return Err(invalid("reserved", "bytes 41..60 must be zero"));
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
            return Err(invalid(
                "value_map",
                "must be 0 (Unit), 1 (Signed) or 2 (Octahedral)",
            ));
        };
        let Some(space) = Space::from_u8(bytes[40]) else {
            return Err(invalid("space", "must be in 0..=6"));
        };
        let pdf_min = f32::from_bits(read_u32(bytes, 32));
        let pdf_max = f32::from_bits(read_u32(bytes, 36));
        if !pdf_min.is_finite() {
            return Err(invalid("pdf_min", "must be finite"));
        }
        if !pdf_max.is_finite() {
            return Err(invalid("pdf_max", "must be finite"));
        }
        if space.stores_pdf() {
            if pdf_min < 0.0 {
                return Err(invalid("pdf_min", "must be >= 0"));
            }
            if pdf_max <= 0.0 {
                return Err(invalid(
                    "pdf_max",
                    "must be > 0 for a space that stores a pdf",
                ));
            }
            if pdf_min > pdf_max {
                return Err(invalid("pdf_max", "must be >= pdf_min"));
            }
            if channels < 2 {
                return Err(invalid(
                    "channels",
                    "a space that stores a pdf needs a value channel and the pdf channel",
                ));
            }
        } else if pdf_min.to_bits() != 0 || pdf_max.to_bits() != 0 {
            return Err(invalid(
                "pdf_min",
                "pdf_min and pdf_max must be 0.0 for a space that stores no pdf",
            ));
        }
        let value_channels = if space.stores_pdf() {
            channels - 1
        } else {
            channels
        };
        let shape_ok = match (space, value_map) {
            (Space::Scalar | Space::Vec, ValueMap::Unit | ValueMap::Signed) => true,
            (Space::UnitVec, ValueMap::Signed) => value_channels <= 3,
            (Space::ImagePoints, ValueMap::Unit) => value_channels == 2,
            (_, ValueMap::Signed) if space.is_direction3() => value_channels == 3,
            (Space::UnitVec, ValueMap::Octahedral) => value_channels == 2,
            (_, ValueMap::Octahedral) if space.is_direction3() => value_channels == 2,
            _ => false,
        };
        if !shape_ok {
            return Err(invalid(
                "space",
                "does not fit value_map and channels (see the MaskHeader docs)",
            ));
        }

        let header = Self {
            width,
            height,
            depth,
            channels,
            encoding,
            compression,
            value_map,
            space,
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
                // A stream cannot expand beyond its format's ratio: refused here, a blob whose
                // header claims gigabytes from a few bytes never reaches an allocation.
                let (ratio, reason) = match compression {
                    Compression::Lz4 => (
                        LZ4_MAX_RATIO,
                        "too small for the decoded size: an LZ4 block decodes to at most \
                         255 bytes per stored byte",
                    ),
                    _ => (
                        DEFLATE_MAX_RATIO,
                        "too small for the decoded size: a Deflate stream decodes to at most \
                         1032 bytes per stored byte",
                    ),
                };
                if decoded_len as u64 > header.payload_len as u64 * ratio {
                    return Err(invalid("payload_len", reason));
                }
            }
            Compression::Palette => {
                // At least the length, one palette voxel and one bit per voxel: a blob asks for
                // at most 8 × (bytes per voxel <= 16) = 128 decoded bytes per stored byte.
                let voxel_bytes =
                    header.channels as u64 * header.encoding.bytes_per_element() as u64;
                let voxels = decoded_len as u64 / voxel_bytes;
                if (header.payload_len as u64) < 4 + voxel_bytes + voxels.div_ceil(8) {
                    return Err(invalid(
                        "payload_len",
                        "too small for the decoded size: a palette payload holds its length, \
                         one palette voxel and at least one bit per voxel",
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
    #[must_use]
    pub const fn decoded_len(&self) -> usize {
        match self.checked_decoded_len() {
            Some(len) => len,
            None => usize::MAX,
        }
    }

    /// Number of elements (`width * height * depth * channels`) in the decoded payload.
    #[must_use]
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

/// The most bytes one stored byte of an LZ4 block decodes to. A sequence whose match length
/// has `n` extension bytes costs at least `3 + n` stored bytes (token, offset, extensions) and
/// copies at most `18 + 255 n`; a literal costs its own byte. So a block of `s` bytes decodes to
/// fewer than `255 s`.
const LZ4_MAX_RATIO: u64 = 255;

/// The most bytes one stored byte of a Deflate stream decodes to: 258 bytes per length/distance
/// pair of two 1-bit codes, 4 pairs per byte (the format's well-known 1032:1 limit).
const DEFLATE_MAX_RATIO: u64 = 1032;

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
/// contexts. Eight shift steps per byte, so it is used only for the 60 checked
/// header bytes; payloads go through `crc32fast`.
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
        assert_eq!(Compression::from_u8(4), None);
        assert_eq!(ValueMap::from_u8(3), None);
        for b in 0..=255u8 {
            if let Some(s) = Space::from_u8(b) {
                assert_eq!(s.to_u8(), b);
            }
        }
        assert_eq!(Space::from_u8(7), None);
        assert_eq!(ValueMap::Signed.apply(0.75), 0.5);
        assert_eq!(ValueMap::Unit.apply(0.75), 0.75);
    }
}
