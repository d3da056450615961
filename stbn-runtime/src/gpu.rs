//! GPU upload through wgpu and the [`WGSL`] sampling snippet (feature `wgpu`).
//!
//! [`create_texture_3d`] uploads a decoded mask as a 3D texture (depth = frames);
//! [`create_texture_2d_array`] as a 2D array texture (one layer per frame). Compressed
//! masks are decoded first, on the CPU: [`PackedStbn::decode`](crate::PackedStbn::decode)
//! or [`PackedStbn::decode_into`](crate::PackedStbn::decode_into), then upload the
//! resulting [`Stbn`] view.
//!
//! # Texture formats ([`texture_format`])
//!
//! | encoding | 1 channel | 2 channels | 3 or 4 channels |
//! |---|---|---|---|
//! | `Unorm8` | `R8Unorm` | `Rg8Unorm` | `Rgba8Unorm` |
//! | `Unorm16`, device has [`wgpu::Features::TEXTURE_FORMAT_16BIT_NORM`] | `R16Unorm` | `Rg16Unorm` | `Rgba16Unorm` |
//! | `Unorm16`, device lacks it (fallback) | `R32Float` | `Rg32Float` | `Rgba32Float` |
//! | `F32` | `R32Float` | `Rg32Float` | `Rgba32Float` |
//!
//! wgpu has no three-channel formats: 3-channel masks get a fourth channel of zeros.
//! The `Unorm16` fallback stores the *decoded* value `(q + 0.5) / 65536` as `f32`
//! (exact), so it costs twice the memory but samples to the same values. Every other
//! case uploads the mask's bytes unchanged.
//!
//! The texture's usage is the requested one plus `COPY_DST`. Bind it with
//! `TextureSampleType::Float { filterable: false }`: the snippet only uses `textureLoad`,
//! and 32-bit float formats are not filterable on every device.
//!
//! # Sampling in WGSL
//!
//! Concatenate [`WGSL`] in front of your shader and bind a uniform `StbnMask` with the bytes
//! of a [`MaskUniform`]: `stbn_sample_3d(texture, mask, x, y, frame)` /
//! `stbn_sample_2d_array(..)` then return exactly what the [`OffsetStbn`] view the uniform
//! was made from returns on the CPU (channel 0 in `.x`, channel `c` in component `c`), for
//! every `i32` x, y and `u32` frame. One uniform per view: e.g. `mask` and
//! `mask.dimension(1)` for two sample dimensions, `mask.progressive()` for frames past the
//! depth ([`Stbn::progressive`]). `stbn_offset(mask, xy, frame)` adds a further offset in the
//! shader, like [`OffsetStbn::offset`], and `stbn_progressive(mask)` makes a uniform
//! progressive, like [`OffsetStbn::progressive`]. See the comments in `stbn.wgsl`.
//!
//! # Example
//! ```no_run
//! use stbn_runtime::gpu::{self, MaskUniform, TextureOptions};
//! use stbn_runtime::PackedStbn;
//!
//! # fn run(device: &wgpu::Device, queue: &wgpu::Queue, blob: &[u8]) -> Result<(), Box<dyn std::error::Error>> {
//! // Any blob: compressed ones are decoded on the CPU first.
//! let owned = PackedStbn::from_bytes(blob)?.decode()?;
//! let mask = owned.view();
//! let texture = gpu::create_texture_3d(device, queue, &mask, TextureOptions::default())?;
//! // One `StbnMask` uniform per view, and the snippet in front of the shader.
//! let dimension0: [u8; 32] = MaskUniform::new(&mask, &texture).to_bytes();
//! let dimension1: [u8; 32] = MaskUniform::new(mask.dimension(1), &texture).to_bytes();
//! let source = format!(
//!     "{}\n@group(0) @binding(0) var noise: texture_3d<f32>;\n\
//!      @group(0) @binding(1) var<uniform> dimension0: StbnMask;\n\
//!      @group(0) @binding(2) var<uniform> dimension1: StbnMask;\n\
//!      // ... stbn_sample_3d(noise, dimension1, x, y, frame).x\n",
//!     gpu::WGSL
//! );
//! # let _ = (dimension0, dimension1, source);
//! # Ok(())
//! # }
//! ```

extern crate std;

use std::fmt;
use std::vec::Vec;

use crate::{Encoding, OffsetStbn, Stbn};

/// The WGSL sampling snippet (`stbn.wgsl`): the `StbnMask` struct ([`MaskUniform`]), the
/// samplers `stbn_sample_3d` and `stbn_sample_2d_array`, `stbn_offset`, and the vector
/// helpers `stbn_signed`, `stbn_octahedral` and `stbn_stored_pdf` that turn a sample into
/// what [`Stbn::sample_vector`] returns; its internal functions start with `stbn_` too.
/// Declares no bindings; prepend it to a shader module's source.
pub const WGSL: &str = include_str!("stbn.wgsl");

/// How [`create_texture_3d`] / [`create_texture_2d_array`] create the texture.
#[derive(Clone, Copy, Debug)]
pub struct TextureOptions<'a> {
    /// Debug label of the texture.
    pub label: Option<&'a str>,
    /// Usages of the texture; `COPY_DST` is always added (the upload needs it).
    pub usage: wgpu::TextureUsages,
}

impl Default for TextureOptions<'_> {
    /// No label, usage `TEXTURE_BINDING` (plus the implied `COPY_DST`).
    fn default() -> Self {
        Self {
            label: None,
            usage: wgpu::TextureUsages::TEXTURE_BINDING,
        }
    }
}

/// Why a mask could not be uploaded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum GpuError {
    /// One of the mask's axes is longer than the device allows for this texture kind.
    TooLarge {
        /// `"width"`, `"height"` or `"depth"` (frames).
        axis: &'static str,
        /// The mask's length on that axis, in voxels.
        size: u32,
        /// The device limit that applies (`max_texture_dimension_3d`,
        /// `max_texture_dimension_2d` or `max_texture_array_layers`).
        limit: u32,
    },
}

impl fmt::Display for GpuError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::TooLarge { axis, size, limit } => write!(
                f,
                "mask {axis} {size} exceeds the device's texture limit of {limit}"
            ),
        }
    }
}

impl std::error::Error for GpuError {}

/// The texture format [`create_texture_3d`] / [`create_texture_2d_array`] use for a mask
/// with this `encoding` and `channels` (1..=4) on a device with `features` (see the
/// [module docs](self) for the table).
#[must_use]
pub fn texture_format(
    encoding: Encoding,
    channels: u8,
    features: wgpu::Features,
) -> wgpu::TextureFormat {
    use wgpu::TextureFormat as F;
    let norm16 = features.contains(wgpu::Features::TEXTURE_FORMAT_16BIT_NORM);
    match (encoding, channels) {
        (Encoding::Unorm8, 1) => F::R8Unorm,
        (Encoding::Unorm8, 2) => F::Rg8Unorm,
        (Encoding::Unorm8, _) => F::Rgba8Unorm,
        (Encoding::Unorm16, 1) if norm16 => F::R16Unorm,
        (Encoding::Unorm16, 2) if norm16 => F::Rg16Unorm,
        (Encoding::Unorm16, _) if norm16 => F::Rgba16Unorm,
        (Encoding::Unorm16 | Encoding::F32, 1) => F::R32Float,
        (Encoding::Unorm16 | Encoding::F32, 2) => F::Rg32Float,
        (Encoding::Unorm16 | Encoding::F32, _) => F::Rgba32Float,
    }
}

/// The 32-byte uniform the [`WGSL`] sampling functions read, WGSL type `StbnMask`: the size
/// and decode mode of a mask's texture and the offset of an [`OffsetStbn`] view, so that
/// `stbn_sample_3d(texture, mask, x, y, frame)` returns what the view's methods return on
/// the CPU.
///
/// Layout of [`to_bytes`](Self::to_bytes) (little-endian `u32`s, as the WGSL struct):
/// `size: vec3<u32>` (width, height, depth in voxels) at byte 0, `decode: u32` at 12,
/// `offset: vec3<u32>` (x in `[0, width)`, y in `[0, height)`, frame in `[0, depth)`) at 16,
/// and `progressive: u32` (1 for a [progressive](OffsetStbn::progressive) view, else 0) at 28.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[must_use]
pub struct MaskUniform {
    /// Width, height and depth (frames) of the mask, in voxels; each in 1..=2^31.
    size: [u32; 3],
    /// [`DECODE_FLOAT`], [`DECODE_UNORM8`] or [`DECODE_UNORM16`].
    decode: u32,
    /// The view's offset, each component wrapped into `[0, size)` of its axis.
    offset: [u32; 3],
    /// 1 when the view is progressive, else 0.
    progressive: u32,
}

/// The texel already holds the value (32-bit float formats).
const DECODE_FLOAT: u32 = 0;
/// 8-bit unorm: `textureLoad` gives `q / 255`, the value is `(q + 0.5) / 256`.
const DECODE_UNORM8: u32 = 1;
/// 16-bit unorm: `textureLoad` gives `q / 65535`, the value is `(q + 0.5) / 65536`.
const DECODE_UNORM16: u32 = 2;

impl MaskUniform {
    /// Size of [`to_bytes`](Self::to_bytes) and of the WGSL struct `StbnMask`, in bytes: the
    /// `min_binding_size` of its uniform binding.
    pub const SIZE: u64 = 32;

    /// The uniform for sampling `mask` (an [`OffsetStbn`] view, or `&Stbn` for offset zero)
    /// from `texture`, which [`create_texture_3d`] or [`create_texture_2d_array`] made from
    /// that mask: the mask's size, the decode mode of the texture's format and the view's
    /// offset.
    ///
    /// # Panics
    /// If `texture`'s size is not the mask's width × height × depth.
    pub fn new<'m>(mask: impl Into<OffsetStbn<'m>>, texture: &wgpu::Texture) -> Self {
        use wgpu::TextureFormat as F;
        let view = mask.into();
        let size = [view.mask.width(), view.mask.height(), view.mask.depth()];
        let extent = texture.size();
        assert_eq!(
            [extent.width, extent.height, extent.depth_or_array_layers],
            size,
            "the texture is not an upload of this mask"
        );
        let decode = match texture.format() {
            F::R8Unorm | F::Rg8Unorm | F::Rgba8Unorm => DECODE_UNORM8,
            F::R16Unorm | F::Rg16Unorm | F::Rgba16Unorm => DECODE_UNORM16,
            _ => DECODE_FLOAT,
        };
        let offset = view.sample_offset();
        // The wrapped components are non-negative (below their axis length).
        Self {
            size,
            decode,
            offset: [offset.x as u32, offset.y as u32, offset.frame],
            progressive: u32::from(view.is_progressive()),
        }
    }

    /// The little-endian bytes of the uniform, ready for `queue.write_buffer` or a
    /// buffer's initial contents.
    #[must_use]
    pub fn to_bytes(&self) -> [u8; 32] {
        let mut out = [0u8; 32];
        let words = self
            .size
            .iter()
            .chain([&self.decode])
            .chain(&self.offset)
            .chain([&self.progressive]);
        for (chunk, word) in out.chunks_exact_mut(4).zip(words) {
            chunk.copy_from_slice(&word.to_le_bytes());
        }
        out
    }
}

/// Uploads `mask` as a 3D texture: `width × height × depth`, one mip level, dimension
/// `D3`, format from [`texture_format`] for the device's features (request
/// `TEXTURE_FORMAT_16BIT_NORM` when creating the device to keep `Unorm16` masks at 2 bytes
/// per element; without it they are stored as `f32`).
///
/// The upload is queued with `queue.write_texture` (in chunks of at most ~16 MiB of
/// source data); it reaches the GPU with the next `queue.submit`.
///
/// # Errors
/// [`GpuError::TooLarge`] if an axis exceeds the device's `max_texture_dimension_3d`.
/// Usages that the format does not support (e.g. `STORAGE_BINDING` on 8-bit formats)
/// are wgpu validation errors, reported through the device's error handler.
pub fn create_texture_3d(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    mask: &Stbn<'_>,
    desc: TextureOptions<'_>,
) -> Result<wgpu::Texture, GpuError> {
    let limit = device.limits().max_texture_dimension_3d;
    check(mask, [limit, limit, limit])?;
    Ok(upload(
        device,
        queue,
        mask,
        desc,
        wgpu::TextureDimension::D3,
    ))
}

/// Uploads `mask` as a 2D array texture: `width × height`, one layer per frame, one
/// mip level, format from [`texture_format`] for the device's features. Create the
/// view with `TextureViewDimension::D2Array`.
///
/// # Errors
/// [`GpuError::TooLarge`] if width or height exceeds `max_texture_dimension_2d` or the
/// depth exceeds `max_texture_array_layers`. Unsupported usages as in
/// [`create_texture_3d`].
pub fn create_texture_2d_array(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    mask: &Stbn<'_>,
    desc: TextureOptions<'_>,
) -> Result<wgpu::Texture, GpuError> {
    let limits = device.limits();
    let d2 = limits.max_texture_dimension_2d;
    check(mask, [d2, d2, limits.max_texture_array_layers])?;
    Ok(upload(
        device,
        queue,
        mask,
        desc,
        wgpu::TextureDimension::D2,
    ))
}

/// Checks width, height and depth against `limits` (in that order).
fn check(mask: &Stbn<'_>, limits: [u32; 3]) -> Result<(), GpuError> {
    let sizes = [mask.width(), mask.height(), mask.depth()];
    for ((axis, size), limit) in ["width", "height", "depth"]
        .into_iter()
        .zip(sizes)
        .zip(limits)
    {
        if size > limit {
            return Err(GpuError::TooLarge { axis, size, limit });
        }
    }
    Ok(())
}

/// Source bytes per upload chunk: whole frames, at least one, about 16 MiB.
const CHUNK_BYTES: usize = 16 << 20;

fn upload(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    mask: &Stbn<'_>,
    desc: TextureOptions<'_>,
    dimension: wgpu::TextureDimension,
) -> wgpu::Texture {
    let format = texture_format(mask.encoding(), mask.channels(), device.features());
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: desc.label,
        size: wgpu::Extent3d {
            width: mask.width(),
            height: mask.height(),
            depth_or_array_layers: mask.depth(),
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension,
        format,
        usage: desc.usage | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });

    // Limits were checked, so width * texel size (<= 16 B) and the per-frame sizes fit.
    let texel_bytes = format
        .block_copy_size(None)
        .expect("texture_format returns uncompressed color formats") as usize;
    let (width, height) = (mask.width() as usize, mask.height() as usize);
    let src_frame =
        width * height * usize::from(mask.channels()) * mask.encoding().bytes_per_element();
    let frames_per_chunk = (CHUNK_BYTES / src_frame).max(1);
    let mut scratch = Vec::new();
    let mut z = 0;
    for src in mask.data().chunks(frames_per_chunk * src_frame) {
        let frames = src.len() / src_frame;
        let bytes = texels(mask, format, src, &mut scratch);
        queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &texture,
                mip_level: 0,
                origin: wgpu::Origin3d { x: 0, y: 0, z },
                aspect: wgpu::TextureAspect::All,
            },
            bytes,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some((width * texel_bytes) as u32),
                rows_per_image: Some(height as u32),
            },
            wgpu::Extent3d {
                width: width as u32,
                height: height as u32,
                depth_or_array_layers: frames as u32,
            },
        );
        z += frames as u32;
    }
    texture
}

/// The texel bytes of `format` for the mask elements `src` (whole voxels): `src` itself
/// when the layouts agree, else the converted bytes in `scratch` (3 channels padded
/// with a zero fourth, Unorm16 decoded to `f32` for the float fallback).
fn texels<'s>(
    mask: &Stbn<'_>,
    format: wgpu::TextureFormat,
    src: &'s [u8],
    scratch: &'s mut Vec<u8>,
) -> &'s [u8] {
    let channels = usize::from(mask.channels());
    let float_fallback = mask.encoding() == Encoding::Unorm16
        && !matches!(
            format,
            wgpu::TextureFormat::R16Unorm
                | wgpu::TextureFormat::Rg16Unorm
                | wgpu::TextureFormat::Rgba16Unorm
        );
    if channels != 3 && !float_fallback {
        return src;
    }
    let bpe = mask.encoding().bytes_per_element();
    let out_bpe = if float_fallback { 4 } else { bpe };
    let out_channels = if channels == 3 { 4 } else { channels };
    scratch.clear();
    for voxel in src.chunks_exact(channels * bpe) {
        for element in voxel.chunks_exact(bpe) {
            if float_fallback {
                let q = u16::from_le_bytes([element[0], element[1]]);
                let value = (f32::from(q) + 0.5) * (1.0 / 65536.0);
                scratch.extend_from_slice(&value.to_le_bytes());
            } else {
                scratch.extend_from_slice(element);
            }
        }
        let padding = (out_channels - channels) * out_bpe;
        scratch.resize(scratch.len() + padding, 0);
    }
    scratch
}
