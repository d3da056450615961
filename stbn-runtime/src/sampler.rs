//! [`Stbn`]: toroidal point sampling and row/frame fills over decoded mask data.

use core::fmt;

use crate::{Encoding, Error, MaskHeader, PackedStbn};

/// Integer offset added to a sample position before wrapping.
///
/// Each component is reduced modulo the mask's size on that axis, so any value
/// is valid and the sum never overflows (see [`Stbn::sample_with`]).
///
/// `frame` is the *start-frame* offset: because the mask is blue in time as well
/// as toroidal (progressive from any starting frame), a pixel may start its
/// temporal sequence at any frame, and an `offset.frame` of `k` makes frame `t`
/// read mask slice `t + k`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct SampleOffset {
    /// Offset along x, in voxels (any value; wrapped modulo width).
    pub x: i32,
    /// Offset along y, in voxels (any value; wrapped modulo height).
    pub y: i32,
    /// Start-frame offset, in frames (any value; wrapped modulo depth).
    pub frame: u32,
}

impl SampleOffset {
    /// The zero offset: samples exactly at the requested position.
    pub const ZERO: Self = Self {
        x: 0,
        y: 0,
        frame: 0,
    };
}

/// 2^64 / g rounded to nearest, g = 1.32471795724474602596... (plastic number):
/// the first R2 sequence constant `a1 = 1/g` in 0.64 fixed point.
const R2_A1: u64 = 0xC13F_A9A9_02A6_328F;
/// 2^64 / g² rounded to nearest: the second R2 constant `a2 = 1/g²` in 0.64 fixed point.
const R2_A2: u64 = 0x91E1_0DA5_C79E_7B1D;

/// One axis of the torus: its length and, when the length is a power of two,
/// the mask that replaces the modulo.
#[derive(Clone, Copy)]
struct Axis {
    len: u32,
    /// `len - 1` when `len` is a power of two; unused otherwise.
    mask: u32,
    pow2: bool,
}

impl Axis {
    const fn new(len: u32) -> Self {
        Self {
            len,
            mask: len.wrapping_sub(1),
            pow2: len.is_power_of_two(),
        }
    }

    /// `(v + dv) mod len` for signed coordinates, exact for every input.
    #[inline(always)]
    fn wrap_signed(self, v: i32, dv: i32) -> usize {
        if self.pow2 {
            // `len` divides 2^32, so wrapping u32 arithmetic preserves the residue
            // (including for negative `v`/`dv`, whose two's complement is ≡ mod 2^32).
            ((v as u32).wrapping_add(dv as u32) & self.mask) as usize
        } else {
            // The i64 sum of two i32 cannot overflow; `len >= 1` so no division by zero.
            (i64::from(v) + i64::from(dv)).rem_euclid(i64::from(self.len)) as usize
        }
    }

    /// `(v + dv) mod len` for frame indices, exact for every input.
    #[inline(always)]
    fn wrap_unsigned(self, v: u32, dv: u32) -> usize {
        if self.pow2 {
            (v.wrapping_add(dv) & self.mask) as usize
        } else {
            ((u64::from(v) + u64::from(dv)) % u64::from(self.len)) as usize
        }
    }

    /// `floor(frac * len)` for a 0.64 fixed-point fraction `frac` in `[0, 1)`.
    const fn scale(self, frac: u64) -> u32 {
        ((frac as u128 * self.len as u128) >> 64) as u32
    }
}

/// A sampling view over a decoded (uncompressed) mask.
///
/// Obtained from an uncompressed blob with [`Stbn::from_bytes`] /
/// [`Stbn::from_bytes_unverified`] (zero-copy), or by decoding any blob with
/// [`PackedStbn::decode_into`] / `PackedStbn::decode` (feature `alloc`).
///
/// All sampling is toroidal: x wraps modulo width, y modulo height and the frame
/// modulo depth, for every `i32`/`u32` input (negative values and
/// `i32::MIN`/`u32::MAX` included). Sampling never panics. Axes whose length is a
/// power of two use a bit mask instead of a division.
///
/// Invariant: [`data`](Self::data) is exactly `header().decoded_len()` bytes, and
/// `header().to_bytes()` followed by `data()` is a valid uncompressed blob.
#[derive(Clone, Copy)]
pub struct Stbn<'a> {
    header: MaskHeader,
    data: &'a [u8],
    x: Axis,
    y: Axis,
    z: Axis,
    /// Elements per voxel (`channels`), 1..=4.
    channels: usize,
    /// Elements per row: `width * channels`.
    row_stride: usize,
    /// Elements per frame: `width * height * channels`.
    frame_stride: usize,
    /// All three axes are powers of two, so the voxel index is
    /// `z << z_shift | y << y_shift | x` with each coordinate masked.
    all_pow2: bool,
    /// `log2(width)` when `all_pow2`.
    y_shift: u32,
    /// `log2(width * height)` when `all_pow2`.
    z_shift: u32,
}

impl fmt::Debug for Stbn<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Stbn")
            .field("header", &self.header)
            .field("data_len", &self.data.len())
            .finish()
    }
}

impl<'a> Stbn<'a> {
    /// Builds the view from a validated header describing uncompressed `data`
    /// (`data.len() == header.decoded_len()`).
    pub(crate) const fn from_parts(header: MaskHeader, data: &'a [u8]) -> Self {
        let channels = header.channels as usize;
        let row_stride = header.width as usize * channels;
        let (x, y, z) = (
            Axis::new(header.width),
            Axis::new(header.height),
            Axis::new(header.depth),
        );
        Self {
            header,
            data,
            x,
            y,
            z,
            channels,
            row_stride,
            frame_stride: row_stride * header.height as usize,
            all_pow2: x.pow2 && y.pow2 && z.pow2,
            y_shift: header.width.trailing_zeros(),
            z_shift: header.width.trailing_zeros() + header.height.trailing_zeros(),
        }
    }

    /// Validates a complete uncompressed blob (header, payload length and
    /// payload CRC) and views its payload without copying.
    ///
    /// # Errors
    /// Any header error from [`MaskHeader::parse`]; [`Error::Compressed`] if the
    /// payload is compressed; [`Error::Truncated`] / [`Error::PayloadLength`] if
    /// the blob is shorter / longer than `64 + payload_len`;
    /// [`Error::PayloadChecksum`] if the payload CRC does not match.
    pub fn from_bytes(bytes: &'a [u8]) -> Result<Self, Error> {
        let header = MaskHeader::parse(bytes)?;
        if !header.compression.is_none() {
            return Err(Error::Compressed);
        }
        PackedStbn::from_bytes(bytes)?.view()
    }

    /// Like [`from_bytes`](Self::from_bytes) but skips the payload CRC, so it is
    /// a `const fn` and suits generated `static`s (see the crate-level example):
    /// `static MASK: Stbn<'static> = match Stbn::from_bytes_unverified(BYTES) { Ok(s) => s,
    /// Err(_) => panic!("...") };` turns an invalid embedded blob into a compile error.
    ///
    /// The header (including its own CRC) and the payload length are still
    /// checked; verify the payload CRC once with [`from_bytes`](Self::from_bytes)
    /// (in a test or at start-up) if the bytes are not trusted.
    ///
    /// # Errors
    /// As [`from_bytes`](Self::from_bytes), except [`Error::PayloadChecksum`].
    pub const fn from_bytes_unverified(bytes: &'a [u8]) -> Result<Self, Error> {
        let header = match MaskHeader::parse(bytes) {
            Ok(h) => h,
            Err(e) => return Err(e),
        };
        if !header.compression.is_none() {
            return Err(Error::Compressed);
        }
        match crate::packed::payload_of(bytes, &header) {
            Ok(payload) => Ok(Self::from_parts(header, payload)),
            Err(e) => Err(e),
        }
    }

    /// Width in voxels (≥ 1).
    pub const fn width(&self) -> u32 {
        self.header.width
    }

    /// Height in voxels (≥ 1).
    pub const fn height(&self) -> u32 {
        self.header.height
    }

    /// Depth in frames (≥ 1).
    pub const fn depth(&self) -> u32 {
        self.header.depth
    }

    /// Channels per voxel (1..=4).
    pub const fn channels(&self) -> u8 {
        self.header.channels
    }

    /// Element encoding of [`data`](Self::data).
    pub const fn encoding(&self) -> Encoding {
        self.header.encoding
    }

    /// Header describing this view's data as an uncompressed blob: `compression`
    /// is [`Compression::None`](crate::Compression::None), `payload_len` is the decoded length and
    /// `payload_crc32` the CRC of [`data`](Self::data).
    pub const fn header(&self) -> &MaskHeader {
        &self.header
    }

    /// The decoded payload: `decoded_len` bytes, element order
    /// `((z * height + y) * width + x) * channels + c`, little-endian elements.
    pub const fn data(&self) -> &'a [u8] {
        self.data
    }

    /// Channel 0 at `(x, y, frame)`, wrapped toroidally on all three axes.
    ///
    /// Returns the stored unit value `u`: in `[0, 1)` for Unorm encodings (the
    /// bin midpoint `(q + 0.5) / 2^bits`), the stored `f32` for
    /// [`Encoding::F32`]. Use [`ValueMap::apply`](crate::ValueMap::apply) for
    /// signed masks.
    #[inline]
    pub fn sample(&self, x: i32, y: i32, frame: u32) -> f32 {
        self.sample_at(x, y, frame, SampleOffset::ZERO, 0)
    }

    /// Channel `channel` at `(x, y, frame)`, wrapped like [`sample`](Self::sample).
    ///
    /// `channel` should be below [`channels`](Self::channels); larger values are
    /// reduced modulo the channel count (so channel 1 of a one-channel mask is
    /// channel 0).
    #[inline]
    pub fn sample_channel(&self, x: i32, y: i32, frame: u32, channel: u32) -> f32 {
        let c = channel as usize % self.channels;
        self.sample_at(x, y, frame, SampleOffset::ZERO, c)
    }

    /// Channel 0 at `(x + offset.x, y + offset.y, frame + offset.frame)`.
    ///
    /// The sums are taken modulo the mask size exactly, as if computed in
    /// unbounded integers, even where they overflow `i32`/`u32`.
    #[inline]
    pub fn sample_with(&self, x: i32, y: i32, frame: u32, offset: SampleOffset) -> f32 {
        self.sample_at(x, y, frame, offset, 0)
    }

    /// The offset decorrelating sample dimension `dimension` from dimension 0,
    /// taken from the R2 low-discrepancy sequence:
    /// `(floor(fract(i / g) * width), floor(fract(i / g²) * height), 0)` with
    /// `i = dimension` and `g` the plastic number 1.3247179572….
    ///
    /// Dimension 0 gets [`SampleOffset::ZERO`]. `x` is in `[0, width)` and `y` in
    /// `[0, height)`; `frame` is 0 (add a start-frame offset yourself if wanted).
    /// `fract(i·a)` is computed in 0.64 fixed point (`a` rounded to 2^-64, then a
    /// wrapping `u64` multiply and a `u128` scale): integer arithmetic only, so
    /// results are bit-identical on every platform.
    pub const fn dimension_offset(&self, dimension: u32) -> SampleOffset {
        let i = dimension as u64;
        SampleOffset {
            // `scale` returns < width <= MAX_DECODED_BYTES = 2^31, so it fits in i32.
            x: self.x.scale(i.wrapping_mul(R2_A1)) as i32,
            y: self.y.scale(i.wrapping_mul(R2_A2)) as i32,
            frame: 0,
        }
    }

    /// Channel 0 for sample dimension `dimension`: [`sample_with`](Self::sample_with)
    /// at [`dimension_offset(dimension)`](Self::dimension_offset).
    #[inline]
    pub fn sample_dim(&self, x: i32, y: i32, frame: u32, dimension: u32) -> f32 {
        self.sample_with(x, y, frame, self.dimension_offset(dimension))
    }

    /// Fills `out[i]` with `sample(x0 + i, y, frame)` for every `i` (the x sum
    /// wraps exactly, without `i32` overflow); `out` may be longer than the width,
    /// in which case the row repeats.
    pub fn fill_row(&self, x0: i32, y: i32, frame: u32, out: &mut [f32]) {
        let row = self.z.wrap_unsigned(frame, 0) * self.frame_stride
            + self.y.wrap_signed(y, 0) * self.row_stride;
        let width = self.header.width as usize;
        let mut x = self.x.wrap_signed(x0, 0);
        let mut rest = out;
        while !rest.is_empty() {
            let run = (width - x).min(rest.len());
            let (head, tail) = core::mem::take(&mut rest).split_at_mut(run);
            self.convert_run(row + x * self.channels, head);
            rest = tail;
            x = 0;
        }
    }

    /// Fills `out` with channel 0 of frame `frame` (wrapped modulo depth) in
    /// row-major order: `out[y * width + x] = sample(x, y, frame)`.
    ///
    /// Writes `min(out.len(), width * height)` values and returns that count; a
    /// shorter `out` receives the first rows (the last one possibly partial), a
    /// longer one keeps its tail untouched.
    pub fn fill_frame(&self, frame: u32, out: &mut [f32]) -> usize {
        let n = out
            .len()
            .min(self.header.width as usize * self.header.height as usize);
        let (head, _) = out.split_at_mut(n);
        self.convert_run(self.z.wrap_unsigned(frame, 0) * self.frame_stride, head);
        n
    }

    #[inline(always)]
    fn sample_at(&self, x: i32, y: i32, frame: u32, o: SampleOffset, channel: usize) -> f32 {
        self.element(self.voxel(x, y, frame, o) + channel)
    }

    /// The element index of channel 0 of the voxel at `(x + o.x, y + o.y, frame + o.frame)`,
    /// wrapped toroidally; that and the next `channels - 1` elements are in bounds.
    #[inline(always)]
    pub(crate) fn voxel(&self, x: i32, y: i32, frame: u32, o: SampleOffset) -> usize {
        let voxel = if self.all_pow2 {
            // Every axis length divides 2^32, so wrapping u32 sums keep the exact
            // residues; the packed index is < width*height*depth <= 2^31.
            let x = (x as u32).wrapping_add(o.x as u32) & self.x.mask;
            let y = (y as u32).wrapping_add(o.y as u32) & self.y.mask;
            let z = frame.wrapping_add(o.frame) & self.z.mask;
            ((z << self.z_shift) | (y << self.y_shift) | x) as usize
        } else {
            (self.z.wrap_unsigned(frame, o.frame) * self.header.height as usize
                + self.y.wrap_signed(y, o.y))
                * self.header.width as usize
                + self.x.wrap_signed(x, o.x)
        };
        voxel * self.channels
    }

    /// Decodes element `index` (< element count, so every access is in bounds).
    #[inline(always)]
    pub(crate) fn element(&self, index: usize) -> f32 {
        match self.header.encoding {
            Encoding::Unorm8 => unorm8(self.data[index]),
            Encoding::Unorm16 => unorm16(u16::from_le_bytes(self.bytes(index * 2))),
            Encoding::F32 => f32::from_le_bytes(self.bytes(index * 4)),
        }
    }

    /// Decodes element `index` full-range, as the pdf channel is stored: Unorm `q` as
    /// `q / (2^bits - 1)` (so 0 and 1 are exact), F32 as stored but clamped to `[0, 1]`
    /// (NaN becomes 0).
    #[inline(always)]
    pub(crate) fn element_full_range(&self, index: usize) -> f32 {
        match self.header.encoding {
            Encoding::Unorm8 => f32::from(self.data[index]) / 255.0,
            Encoding::Unorm16 => f32::from(u16::from_le_bytes(self.bytes(index * 2))) / 65535.0,
            Encoding::F32 => {
                let t = f32::from_le_bytes(self.bytes(index * 4));
                // NaN fails the comparison and becomes 0.
                if t >= 0.0 { t.min(1.0) } else { 0.0 }
            }
        }
    }

    /// The `N` data bytes starting at byte `at`, with a single bounds check.
    #[inline(always)]
    fn bytes<const N: usize>(&self, at: usize) -> [u8; N] {
        let mut out = [0u8; N];
        out.copy_from_slice(&self.data[at..at + N]);
        out
    }

    /// Writes channel 0 of `out.len()` consecutive voxels, the first at element
    /// `first` (a channel-0 element index); the run must lie inside the data.
    #[inline]
    fn convert_run(&self, first: usize, out: &mut [f32]) {
        let c = self.channels;
        let bpe = self.header.encoding.bytes_per_element();
        let src = &self.data[first * bpe..];
        // Each arm is a simple zip so LLVM vectorises the contiguous (c == 1) cases;
        // the constant chunk sizes let it turn the byte gathers into wide loads.
        match (self.header.encoding, c) {
            (Encoding::Unorm8, 1) => {
                for (o, &q) in out.iter_mut().zip(src) {
                    *o = unorm8(q);
                }
            }
            (Encoding::Unorm8, _) => {
                for (o, &q) in out.iter_mut().zip(src.iter().step_by(c)) {
                    *o = unorm8(q);
                }
            }
            (Encoding::Unorm16, 1) => {
                for (o, q) in out.iter_mut().zip(src.chunks_exact(2)) {
                    *o = unorm16(u16::from_le_bytes([q[0], q[1]]));
                }
            }
            (Encoding::Unorm16, _) => {
                for (o, q) in out.iter_mut().zip(src.chunks_exact(2 * c)) {
                    *o = unorm16(u16::from_le_bytes([q[0], q[1]]));
                }
            }
            (Encoding::F32, 1) => {
                for (o, q) in out.iter_mut().zip(src.chunks_exact(4)) {
                    *o = f32::from_le_bytes([q[0], q[1], q[2], q[3]]);
                }
            }
            (Encoding::F32, _) => {
                for (o, q) in out.iter_mut().zip(src.chunks_exact(4 * c)) {
                    *o = f32::from_le_bytes([q[0], q[1], q[2], q[3]]);
                }
            }
        }
    }
}

/// `(q + 0.5) / 256`, written as a multiply-add; both forms are exact in f32.
#[inline(always)]
fn unorm8(q: u8) -> f32 {
    f32::from(q) * (1.0 / 256.0) + 1.0 / 512.0
}

/// `(q + 0.5) / 65536`, written as a multiply-add; both forms are exact in f32.
#[inline(always)]
fn unorm16(q: u16) -> f32 {
    f32::from(q) * (1.0 / 65536.0) + 1.0 / 131_072.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn r2_constants_match_the_plastic_number() {
        // The 0.64 fixed-point constants are exact to 2^-64; f64 checks them to ~1e-15.
        let g = 1.324_717_957_244_746_f64;
        let scale = 18_446_744_073_709_551_616.0_f64; // 2^64
        assert!((R2_A1 as f64 / scale - 1.0 / g).abs() < 1e-15);
        assert!((R2_A2 as f64 / scale - 1.0 / (g * g)).abs() < 1e-15);
    }

    #[test]
    fn unorm_conversions_are_exact_midpoints() {
        for q in 0..=255u8 {
            assert_eq!(unorm8(q), (f32::from(q) + 0.5) / 256.0);
        }
        for q in 0..=u16::MAX {
            assert_eq!(unorm16(q), (f32::from(q) + 0.5) / 65536.0);
        }
    }

    #[test]
    fn axis_scale_is_floor_of_fraction_times_len() {
        let a = Axis::new(10);
        assert_eq!(a.scale(0), 0);
        assert_eq!(a.scale(u64::MAX), 9);
        assert_eq!(a.scale(1 << 63), 5);
    }
}
