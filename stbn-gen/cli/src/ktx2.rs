//! KTX2 export: a 1–4 channel mask as a KTX 2.0 3D texture (depth = frames).
//!
//! The file holds one mip level, no supercompression, a basic data format descriptor and a
//! `KTXwriter` key. Texel bytes are the mask's decoded `.stbn` payload as is
//! (`stbn_build_support::encode::encode_payload`), so a GPU reading a `UNORM` texel gets
//! `q / (2^bits - 1)` where the CPU runtime returns the bin midpoint `(q + 0.5) / 2^bits`;
//! `stbn_runtime::gpu::WGSL` converts between the two.

use stbn_runtime::Encoding;

/// The KTX 2.0 file identifier, `«KTX 20»\r\n\x1A\n`.
const IDENTIFIER: [u8; 12] = [
    0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A,
];
/// Identifier, nine `u32` header fields and the 32-byte section index, in bytes.
const HEADER_LEN: usize = 80;
/// One level index entry: byte offset, byte length, uncompressed byte length (`u64` each).
const LEVEL_INDEX_LEN: usize = 24;

/// `VkFormat` of a mask of `channels` (1..=4) stored with `encoding`: `R8_UNORM` (9),
/// `R8G8_UNORM` (16), `R8G8B8_UNORM` (23), `R8G8B8A8_UNORM` (37); `R16_UNORM` (70) … `R16G16B16A16_UNORM`
/// (91); `R32_SFLOAT` (100) … `R32G32B32A32_SFLOAT` (109).
pub fn vk_format(encoding: Encoding, channels: u8) -> u32 {
    let c = usize::from(channels.clamp(1, 4)) - 1;
    match encoding {
        Encoding::Unorm8 => [9, 16, 23, 37][c],
        Encoding::Unorm16 => [70, 77, 84, 91][c],
        Encoding::F32 => [100, 103, 106, 109][c],
    }
}

/// Why a mask cannot be written as KTX2.
#[derive(Debug)]
pub struct TooLarge {
    bytes: usize,
}

impl std::fmt::Display for TooLarge {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} bytes of texels do not fit a KTX2 file's 32-bit section offsets",
            self.bytes
        )
    }
}

impl std::error::Error for TooLarge {}

/// A complete KTX2 file for a `width × height × depth` mask of `channels` (1..=4) whose texels
/// are `payload` (index order `((z · height + y) · width + x) · channels + c`, little-endian
/// elements of `encoding`'s size).
///
/// # Errors
/// [`TooLarge`] if the file would exceed 4 GiB (KTX2 keeps some offsets in `u32`).
///
/// # Panics
/// If `payload` is not `width · height · depth · channels` elements long (a caller bug: the
/// payload is encoded from the same volume).
pub fn write(
    width: u32,
    height: u32,
    depth: u32,
    channels: u8,
    encoding: Encoding,
    payload: &[u8],
) -> Result<Vec<u8>, TooLarge> {
    let bpe = encoding.bytes_per_element();
    let texels = width as usize * height as usize * depth as usize;
    assert_eq!(
        payload.len(),
        texels * bpe * usize::from(channels),
        "payload size"
    );

    let dfd = basic_dfd(encoding, channels);
    let kvd = key_value(
        "KTXwriter",
        concat!("stbn-gen ", env!("CARGO_PKG_VERSION"), "\0").as_bytes(),
    );
    let dfd_offset = HEADER_LEN + LEVEL_INDEX_LEN;
    let kvd_offset = dfd_offset + dfd.len();
    // Level data is aligned to lcm(texel size, 4) (KTX 2.0 section 3.9.7): 4 for 1-, 2- and
    // 4-byte texels, 8 for 8-byte, 12 for 3- and 6-byte and 16 for 16-byte ones.
    let texel = bpe * usize::from(channels);
    let align = texel * 4 / gcd(texel, 4);
    let level_offset = (kvd_offset + kvd.len()).next_multiple_of(align);
    let total = level_offset + payload.len();
    if u32::try_from(total).is_err() {
        return Err(TooLarge {
            bytes: payload.len(),
        });
    }

    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(&IDENTIFIER);
    for word in [
        vk_format(encoding, channels),
        bpe as u32, // typeSize: one component
        width,
        height,
        depth,
        0, // layerCount: not an array
        1, // faceCount
        1, // levelCount
        0, // supercompressionScheme: none
    ] {
        out.extend_from_slice(&word.to_le_bytes());
    }
    for word in [dfd_offset, dfd.len(), kvd_offset, kvd.len()] {
        out.extend_from_slice(&(word as u32).to_le_bytes());
    }
    out.extend_from_slice(&[0; 16]); // sgdByteOffset, sgdByteLength: no global data
    for word in [level_offset, payload.len(), payload.len()] {
        out.extend_from_slice(&(word as u64).to_le_bytes());
    }
    out.extend_from_slice(&dfd);
    out.extend_from_slice(&kvd);
    out.resize(level_offset, 0);
    out.extend_from_slice(payload);
    Ok(out)
}

/// Greatest common divisor.
fn gcd(a: usize, b: usize) -> usize {
    if b == 0 { a } else { gcd(b, a % b) }
}

/// The data format descriptor: `dfdTotalSize` and one Khronos basic block with one sample per
/// channel (RGBSDA colour model, BT.709 primaries, linear transfer, channels R, G, B, A), as the
/// Khronos Data Format specification lists it for the `VkFormat`.
fn basic_dfd(encoding: Encoding, channels: u8) -> Vec<u8> {
    let samples = u32::from(channels);
    let block_len: u32 = 24 + 16 * samples; // basic block header + one sample per channel
    let bytes = encoding.bytes_per_element() as u32;
    // Sample channelType: channel 0 (red) with qualifier bits; lower/upper: the values that
    // map to 0.0 and 1.0 (UNORM codes) or -1.0 and 1.0 as f32 bits (float formats).
    let (qualifiers, lower, upper): (u32, u32, u32) = match encoding {
        Encoding::Unorm8 => (0, 0, 0xFF),
        Encoding::Unorm16 => (0, 0, 0xFFFF),
        Encoding::F32 => (0x40 | 0x80, (-1.0f32).to_bits(), 1.0f32.to_bits()), // SIGNED | FLOAT
    };
    let mut words = vec![
        4 + block_len,        // dfdTotalSize
        0,                    // vendorId 0 (Khronos), descriptorType 0 (basic)
        2 | block_len << 16,  // versionNumber 2, descriptorBlockSize
        1 | 1 << 8 | 1 << 16, // colorModel RGBSDA, colorPrimaries BT709, transfer linear, flags 0
        0,                    // texelBlockDimension0..3: 1×1×1×1 (stored minus one)
        bytes * samples,      // bytesPlane0 = texel size, bytesPlane1..3 = 0
        0,                    // bytesPlane4..7
    ];
    for c in 0..samples {
        // Channel ids: R 0, G 1, B 2, A 15.
        let channel = if c == 3 { 15 } else { c };
        words.extend([
            (c * bytes * 8) | ((bytes * 8 - 1) << 16) | ((channel | qualifiers) << 24), // offset, length - 1, type
            0, // samplePosition0..3
            lower,
            upper,
        ]);
    }
    words.iter().flat_map(|w| w.to_le_bytes()).collect()
}

/// One key/value entry: `keyAndValueByteLength`, the NUL-terminated key, the value, and zero
/// padding to a multiple of 4 bytes.
fn key_value(key: &str, value: &[u8]) -> Vec<u8> {
    let len = key.len() + 1 + value.len();
    let mut out = Vec::with_capacity(4 + len.next_multiple_of(4));
    out.extend_from_slice(&(len as u32).to_le_bytes());
    out.extend_from_slice(key.as_bytes());
    out.push(0);
    out.extend_from_slice(value);
    out.resize(4 + len.next_multiple_of(4), 0);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every section as an independent reader (the `ktx2` crate) sees it.
    #[test]
    fn the_ktx2_crate_reads_back_every_field_and_byte() {
        use ::ktx2::Format as F;
        for (encoding, channels, format) in [
            (Encoding::Unorm8, 1, F::R8_UNORM),
            (Encoding::Unorm16, 1, F::R16_UNORM),
            (Encoding::F32, 1, F::R32_SFLOAT),
            (Encoding::Unorm8, 2, F::R8G8_UNORM),
            (Encoding::Unorm8, 3, F::R8G8B8_UNORM),
            (Encoding::Unorm8, 4, F::R8G8B8A8_UNORM),
            (Encoding::Unorm16, 2, F::R16G16_UNORM),
            (Encoding::Unorm16, 3, F::R16G16B16_UNORM),
            (Encoding::Unorm16, 4, F::R16G16B16A16_UNORM),
            (Encoding::F32, 2, F::R32G32_SFLOAT),
            (Encoding::F32, 3, F::R32G32B32_SFLOAT),
            (Encoding::F32, 4, F::R32G32B32A32_SFLOAT),
        ] {
            let (w, h, d) = (5, 3, 2);
            let len = w * h * d * encoding.bytes_per_element() * usize::from(channels);
            let payload: Vec<u8> = (0..len).map(|i| (i * 37 % 251) as u8).collect();
            let file = write(w as u32, h as u32, d as u32, channels, encoding, &payload).unwrap();
            let texel = encoding.bytes_per_element() * usize::from(channels);
            let level_offset = u64::from_le_bytes(file[80..88].try_into().unwrap()) as usize;
            assert_eq!(level_offset % texel, 0, "{format:?} level alignment");
            let reader = ::ktx2::Reader::new(&file[..]).unwrap();
            let header = reader.header();
            assert_eq!(header.format, Some(format));
            assert_eq!(
                (header.pixel_width, header.pixel_height, header.pixel_depth),
                (5, 3, 2)
            );
            assert_eq!((header.layer_count, header.face_count), (0, 1));
            assert_eq!(header.level_count, 1);
            assert_eq!(header.supercompression_scheme, None);
            let (dfd, type_size) = ::ktx2::dfd::Basic::from_format(format).unwrap();
            assert_eq!(header.type_size, type_size);
            assert_eq!(reader.dfd_blocks().len(), 1);
            assert_eq!(reader.basic_dfd(), Some(&dfd), "{format:?}");
            assert_eq!(
                reader.writer(),
                Some(concat!("stbn-gen ", env!("CARGO_PKG_VERSION"), "\0"))
            );
            let levels: Vec<_> = reader.levels().collect();
            assert_eq!(levels.len(), 1);
            assert_eq!(levels[0].data, &payload[..]);
            assert_eq!(levels[0].uncompressed_byte_length, len as u64);
        }
    }
}
