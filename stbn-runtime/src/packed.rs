//! [`PackedStbn`]: a validated blob of any compression, and its decoders.

use core::fmt;

use miniz_oxide::inflate::TINFLStatus;
use miniz_oxide::inflate::core::{DecompressorOxide, decompress, inflate_flags};

use crate::{Compression, Error, MaskHeader, Stbn};

/// A validated `.stbn` blob whose payload may be compressed.
///
/// Construction checks the header, that the blob is exactly `64 + payload_len`
/// bytes, and the payload CRC; decoding then only has to check the compressed
/// stream itself.
#[derive(Clone, Copy)]
#[must_use]
pub struct PackedStbn<'a> {
    header: MaskHeader,
    payload: &'a [u8],
}

impl fmt::Debug for PackedStbn<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("PackedStbn")
            .field("header", &self.header)
            .field("payload_len", &self.payload.len())
            .finish()
    }
}

/// The payload of `bytes` after a parsed `header`: exactly `payload_len` bytes
/// must follow the 64-byte header.
pub(crate) const fn payload_of<'a>(
    bytes: &'a [u8],
    header: &MaskHeader,
) -> Result<&'a [u8], Error> {
    let payload_len = header.payload_len as u64;
    // `bytes.len() >= 64` (the header parsed), so this subtraction cannot underflow.
    let available = (bytes.len() - MaskHeader::SIZE) as u64;
    if available < payload_len {
        return Err(Error::Truncated {
            // Saturates only on targets whose usize cannot address the blob anyway.
            needed: MaskHeader::SIZE.saturating_add(if payload_len > usize::MAX as u64 {
                usize::MAX
            } else {
                payload_len as usize
            }),
            available: bytes.len(),
        });
    }
    if available > payload_len {
        return Err(Error::PayloadLength);
    }
    Ok(bytes.split_at(MaskHeader::SIZE).1)
}

impl<'a> PackedStbn<'a> {
    /// Validates a complete blob: header ([`MaskHeader::parse`]), total length
    /// exactly `64 + payload_len`, and `payload_crc32`; for an uncompressed payload also its
    /// values ([`Stbn::verify`]), so that [`view`](Self::view) keeps every sampling promise.
    ///
    /// A compressed stream, and the values it holds, are checked when decoding.
    ///
    /// # Errors
    /// Any header error; [`Error::Truncated`] if the blob is shorter than
    /// `64 + payload_len`; [`Error::PayloadLength`] if it is longer;
    /// [`Error::PayloadChecksum`] if the CRC does not match; [`Error::InvalidValue`] if an
    /// uncompressed payload holds a value outside its space's range.
    pub fn from_bytes(bytes: &'a [u8]) -> Result<Self, Error> {
        let header = MaskHeader::parse(bytes)?;
        let payload = payload_of(bytes, &header)?;
        if crc32fast::hash(payload) != header.payload_crc32 {
            return Err(Error::PayloadChecksum);
        }
        if header.compression.is_none() {
            Stbn::from_parts(header, payload).check_values()?;
        }
        Ok(Self { header, payload })
    }

    /// Validates the header and the total length only, in a `const` context: what the statics
    /// the build emits use (`pub static M: PackedStbn<'static> = match PackedStbn::from_bytes_unverified(…)`),
    /// so a malformed embedded blob fails compilation. The payload CRC and values are not checked
    /// here (the build verified them when it wrote the blob); [`PackedStbn::from_bytes`] checks
    /// them, and [`decode_into`](Self::decode_into) checks the decoded values whatever the
    /// constructor, so a damaged payload is an error when decoding, never a panic. Only
    /// [`view`](Self::view) of an uncompressed blob built here skips the value checks (see
    /// [`Stbn::from_bytes_unverified`]).
    ///
    /// # Errors
    /// Any header error; [`Error::Truncated`] or [`Error::PayloadLength`] if the blob is not
    /// exactly `64 + payload_len` bytes.
    pub const fn from_bytes_unverified(bytes: &'a [u8]) -> Result<Self, Error> {
        let header = match MaskHeader::parse(bytes) {
            Ok(h) => h,
            Err(e) => return Err(e),
        };
        match payload_of(bytes, &header) {
            Ok(payload) => Ok(Self { header, payload }),
            Err(e) => Err(e),
        }
    }

    /// The blob's header (describing the stored, possibly compressed, payload).
    #[must_use]
    pub const fn header(&self) -> &MaskHeader {
        &self.header
    }

    /// The stored payload: `payload_len` bytes, compressed per `header().compression`.
    #[must_use]
    pub const fn payload(&self) -> &'a [u8] {
        self.payload
    }

    /// Bytes the payload decodes to (the buffer size [`decode_into`](Self::decode_into) needs).
    #[must_use]
    pub const fn decoded_len(&self) -> usize {
        self.header.decoded_len()
    }

    /// Decodes the payload into the first [`decoded_len`](Self::decoded_len)
    /// bytes of `buf` without allocating, and returns a view of them. Extra bytes
    /// of `buf` are left untouched.
    ///
    /// [`Compression::None`] copies; LZ4 and Deflate decompress and require the
    /// stream to produce exactly `decoded_len` bytes. Deflate decoding keeps its
    /// decompressor state (about 11 KiB) on the stack. The returned view's
    /// header describes the decoded data (see [`Stbn::header`]); for compressed
    /// blobs that costs one CRC pass over the output. The decoded values are then checked as
    /// [`Stbn::verify`] checks them (a pass over F32 elements and over directions), so the view
    /// keeps every sampling promise whichever constructor built `self`.
    ///
    /// # Errors
    /// [`Error::BufferTooSmall`] if `buf` is shorter than `decoded_len`;
    /// [`Error::Decompress`] if the stream is malformed or has trailing bytes;
    /// [`Error::DecodedLength`] if it decodes to the wrong size; [`Error::InvalidValue`] if a
    /// decoded value is outside its space's range.
    pub fn decode_into<'b>(&self, buf: &'b mut [u8]) -> Result<Stbn<'b>, Error> {
        let len = self.decoded_len();
        let available = buf.len();
        let Some(out) = buf.get_mut(..len) else {
            return Err(Error::BufferTooSmall {
                needed: len,
                available,
            });
        };
        let mut header = self.header;
        match self.header.compression {
            Compression::None => out.copy_from_slice(self.payload),
            Compression::Lz4 => lz4_into(self.payload, out)?,
            Compression::Deflate => inflate_into(self.payload, out)?,
            Compression::Palette => {
                let voxel_bytes =
                    usize::from(header.channels) * header.encoding.bytes_per_element();
                unpalette_into(self.payload, voxel_bytes, out)?;
            }
        }
        let data: &'b [u8] = out;
        if !header.compression.is_none() {
            header.compression = Compression::None;
            // `len <= MAX_DECODED_BYTES = 2^31`, so it fits in u32.
            header.payload_len = len as u32;
            header.payload_crc32 = crc32fast::hash(data);
        }
        let view = Stbn::from_parts(header, data);
        view.check_values()?;
        Ok(view)
    }

    /// Views the payload in place, without copying. The view keeps every sampling promise if
    /// `self` came from [`from_bytes`](Self::from_bytes), which checked the values; from
    /// [`from_bytes_unverified`](Self::from_bytes_unverified), see [`Stbn::verify`].
    ///
    /// # Errors
    /// [`Error::Compressed`] if the payload is compressed (use
    /// [`decode_into`](Self::decode_into) instead).
    pub const fn view(&self) -> Result<Stbn<'a>, Error> {
        if self.header.compression.is_none() {
            Ok(Stbn::from_parts(self.header, self.payload))
        } else {
            Err(Error::Compressed)
        }
    }

    /// Decodes the payload into a freshly allocated buffer of
    /// [`decoded_len`](Self::decoded_len) bytes.
    ///
    /// The allocation is fallible: a refused one is an error, not an abort. It is bounded by
    /// the stream before it is made: the header was refused unless the stored payload can
    /// decode to `decoded_len` (at most 255 bytes per stored byte for LZ4, 1032 for Deflate, 128
    /// for a palette), so a blob asks for at most that multiple of its own size.
    ///
    /// # Errors
    /// As [`decode_into`](Self::decode_into), minus [`Error::BufferTooSmall`];
    /// [`Error::OutOfMemory`] if the allocator refuses the buffer.
    #[cfg(feature = "alloc")]
    pub fn decode(&self) -> Result<OwnedStbn, Error> {
        let len = self.decoded_len();
        let mut data = alloc::vec::Vec::new();
        data.try_reserve_exact(len)
            .map_err(|_| Error::OutOfMemory { bytes: len })?;
        data.resize(len, 0);
        let header = *self.decode_into(&mut data)?.header();
        Ok(OwnedStbn { header, data })
    }
}

/// Decompresses an LZ4 block into exactly `out.len()` bytes.
fn lz4_into(payload: &[u8], out: &mut [u8]) -> Result<(), Error> {
    let expected = out.len();
    match lz4_flex::block::decompress_into(payload, out) {
        Ok(written) if written == expected => Ok(()),
        Ok(written) => Err(Error::DecodedLength {
            expected,
            actual: Some(written),
        }),
        Err(lz4_flex::block::DecompressError::OutputTooSmall { .. }) => Err(Error::DecodedLength {
            expected,
            actual: None,
        }),
        Err(_) => Err(Error::Decompress),
    }
}

/// Inflates a raw deflate stream into exactly `out.len()` bytes; the stream
/// must end exactly at the end of `payload`.
fn inflate_into(payload: &[u8], out: &mut [u8]) -> Result<(), Error> {
    let expected = out.len();
    let mut state = DecompressorOxide::new();
    // No zlib header, all input present, `out` is the whole (non-wrapping) output.
    let flags = inflate_flags::TINFL_FLAG_USING_NON_WRAPPING_OUTPUT_BUF;
    let (status, read, written) = decompress(&mut state, payload, out, 0, flags);
    match status {
        TINFLStatus::Done if read != payload.len() => Err(Error::Decompress),
        TINFLStatus::Done if written == expected => Ok(()),
        TINFLStatus::Done => Err(Error::DecodedLength {
            expected,
            actual: Some(written),
        }),
        TINFLStatus::HasMoreOutput => Err(Error::DecodedLength {
            expected,
            actual: None,
        }),
        _ => Err(Error::Decompress),
    }
}

/// Decodes a [`Compression::Palette`] payload into exactly `out.len()` bytes of
/// `voxel_bytes`-byte voxels. Refuses (as [`Error::Decompress`]) a palette length of 0 or above
/// the voxel count, a payload of any length but the one the palette length implies, entries not
/// in strictly ascending byte order (so no duplicates), an index at or beyond the palette, and
/// non-zero padding bits. An entry no index uses is not detected (that needs memory per entry,
/// and the decoder allocates none); the decoded values are checked like any others.
fn unpalette_into(payload: &[u8], voxel_bytes: usize, out: &mut [u8]) -> Result<(), Error> {
    let voxels = out.len() / voxel_bytes;
    let Some((count, rest)) = payload.split_first_chunk::<4>() else {
        return Err(Error::Decompress);
    };
    let count = u32::from_le_bytes(*count) as usize;
    if count == 0 || count > voxels {
        return Err(Error::Decompress);
    }
    // ceil(log2(count)), at least 1; count <= voxels < 2^31, so bits <= 31.
    let bits = (usize::BITS - (count - 1).leading_zeros()).max(1);
    let palette_len = count * voxel_bytes;
    // voxels * bits < 2^31 * 31 fits in u64 (and in usize on 64-bit targets; computed in u64).
    let index_len = (voxels as u64 * u64::from(bits)).div_ceil(8);
    if rest.len() as u64 != palette_len as u64 + index_len {
        return Err(Error::Decompress);
    }
    let (palette, indices) = rest.split_at(palette_len);
    let entries = palette.chunks_exact(voxel_bytes);
    if entries.clone().zip(entries.skip(1)).any(|(a, b)| a >= b) {
        return Err(Error::Decompress);
    }
    let bits = Bits::new(indices, bits);
    // The common voxel sizes get a loop whose copies are fixed-size moves.
    match voxel_bytes {
        1 => unpalette_voxels::<1>(palette, count, &bits, out)?,
        2 => unpalette_voxels::<2>(palette, count, &bits, out)?,
        4 => unpalette_voxels::<4>(palette, count, &bits, out)?,
        8 => unpalette_voxels::<8>(palette, count, &bits, out)?,
        _ => {
            for (i, voxel) in out.chunks_exact_mut(voxel_bytes).enumerate() {
                let index = bits.get(i);
                if index >= count {
                    return Err(Error::Decompress);
                }
                // index < count, so the entry lies inside the palette.
                voxel.copy_from_slice(&palette[index * voxel_bytes..][..voxel_bytes]);
            }
        }
    }
    // The bits after the last index, up to the end of its byte, must be 0.
    let used = voxels as u64 * u64::from(bits.bits);
    let last = indices.last().copied().unwrap_or(0);
    if used % 8 != 0 && last >> (used % 8) != 0 {
        return Err(Error::Decompress);
    }
    Ok(())
}

/// Fixed-width indices packed least significant bit first, read at any position.
struct Bits<'p> {
    bytes: &'p [u8],
    /// Index width, 1..=31.
    bits: u32,
}

impl<'p> Bits<'p> {
    const fn new(bytes: &'p [u8], bits: u32) -> Self {
        Self { bytes, bits }
    }

    /// Index `i`: the `bits` bits from bit `i · bits`. Reads the 8 bytes from the index's first
    /// byte at once where they exist (the index and its shift span at most 38 bits), byte by
    /// byte near the end; bytes past the end read as 0 (the caller checked the length).
    #[inline(always)]
    fn get(&self, i: usize) -> usize {
        let at = i as u64 * u64::from(self.bits);
        let (byte, shift) = ((at / 8) as usize, (at % 8) as u32);
        let word = match self.bytes.get(byte..byte + 8) {
            Some(b) => u64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]),
            None => self
                .bytes
                .get(byte..)
                .unwrap_or(&[])
                .iter()
                .rev()
                .fold(0, |w, &b| w << 8 | u64::from(b)),
        };
        ((word >> shift) & ((1 << self.bits) - 1)) as usize
    }
}

/// The palette loop for voxels of `B` bytes: `palette` holds `count` of them, and each index is
/// checked against `count`.
fn unpalette_voxels<const B: usize>(
    palette: &[u8],
    count: usize,
    bits: &Bits<'_>,
    out: &mut [u8],
) -> Result<(), Error> {
    for (i, voxel) in out.chunks_exact_mut(B).enumerate() {
        let index = bits.get(i);
        if index >= count {
            return Err(Error::Decompress);
        }
        // index < count, so the entry lies inside the palette.
        voxel.copy_from_slice(&palette[index * B..][..B]);
    }
    Ok(())
}

/// A decoded mask that owns its data (feature `alloc`).
#[cfg(feature = "alloc")]
#[derive(Clone)]
pub struct OwnedStbn {
    header: MaskHeader,
    data: alloc::vec::Vec<u8>,
}

#[cfg(feature = "alloc")]
impl fmt::Debug for OwnedStbn {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("OwnedStbn")
            .field("header", &self.header)
            .field("data_len", &self.data.len())
            .finish()
    }
}

#[cfg(feature = "alloc")]
impl OwnedStbn {
    /// Header describing the decoded data as an uncompressed blob (as [`Stbn::header`]).
    #[must_use]
    pub const fn header(&self) -> &MaskHeader {
        &self.header
    }

    /// The decoded payload, `header().decoded_len()` bytes.
    #[must_use]
    pub fn data(&self) -> &[u8] {
        &self.data
    }

    /// A sampling view borrowing this mask's data.
    pub fn view(&self) -> Stbn<'_> {
        Stbn::from_parts(self.header, &self.data)
    }
}
