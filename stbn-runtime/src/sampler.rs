//! [`Stbn`]: toroidal point sampling and row/frame fills over decoded mask data.

use core::fmt;

use crate::offset::Epochs;
use crate::vector::VectorPlan;
use crate::{Encoding, Error, MaskHeader, PackedStbn, SampleOffset};

/// 2^64 / g rounded to nearest, g = 1.32471795724474602596... (plastic number):
/// the first R2 sequence constant `a1 = 1/g` in 0.64 fixed point.
const R2_A1: u64 = 0xC13F_A9A9_02A6_328F;
/// 2^64 / g² rounded to nearest: the second R2 constant `a2 = 1/g²` in 0.64 fixed point.
const R2_A2: u64 = 0x91E1_0DA5_C79E_7B1D;

/// 2^32 / g² rounded to nearest: `1/g²` in 0.32 fixed point, the x step of the epoch
/// offsets of a progressive view ([`Stbn::epoch_offset`]).
pub(crate) const EPOCH_STEP_X: u32 = 0x91E1_0DA6;
/// 2^32 / g rounded to nearest: `1/g` in 0.32 fixed point, the y step of the epoch offsets.
pub(crate) const EPOCH_STEP_Y: u32 = 0xC13F_A9A9;

/// One axis of the torus: its length and, when the length is a power of two,
/// the mask that replaces the modulo.
#[derive(Clone, Copy)]
struct Axis {
    len: u32,
    /// `len - 1` when `len` is a power of two; unused otherwise.
    mask: u32,
    /// `len - 2^32 mod len`, the residue of `-2^32`, when `len` is not a power of two (then
    /// in `[1, len)`); unused otherwise.
    minus_2_32: u32,
    /// `log2(len)` when `len` is a power of two; unused otherwise.
    shift: u32,
    pow2: bool,
}

impl Axis {
    const fn new(len: u32) -> Self {
        let pow2 = len.is_power_of_two();
        Self {
            len,
            mask: len.wrapping_sub(1),
            minus_2_32: if pow2 {
                0
            } else {
                len - ((1u64 << 32) % len as u64) as u32
            },
            shift: len.trailing_zeros(),
            pow2,
        }
    }

    /// `floor(v / len)`: a shift when `len` is a power of two.
    #[inline(always)]
    fn quotient(self, v: u32) -> u32 {
        if self.pow2 {
            v >> self.shift
        } else {
            v / self.len
        }
    }

    /// A value congruent to `a + b` modulo `len`: their wrapping sum when `len` is a power of
    /// two (which divides 2^32), their exact wrapped sum otherwise.
    #[inline(always)]
    fn add(self, a: i32, b: i32) -> i32 {
        if self.pow2 {
            a.wrapping_add(b)
        } else {
            // Below len <= 2^31, so it fits in i32.
            self.wrap_signed(a, b) as i32
        }
    }

    /// `floor(frac * len / 2^32)` for a 0.32 fixed-point fraction `frac`: in `[0, len)`.
    #[inline(always)]
    const fn scale32(self, frac: u32) -> u32 {
        ((frac as u64 * self.len as u64) >> 32) as u32
    }

    /// A non-negative number congruent to `v` modulo `len` (not a power of two), below 2^33:
    /// `v`'s two's complement, which is `v + 2^32` for a negative `v`, plus the residue of
    /// `-2^32`. Built from `v as u32` and its sign alone, so that a caller's pixel loop, whose
    /// inlined per-sample reads carry this path for masks of other sizes, keeps no 64-bit copy
    /// of `x` (with `i64::from(v)`, `sample_vec2` of a power-of-two Unorm8 mask took 2.3
    /// against 1.9 ms per 1080p frame; BENCHMARKS.md, "Runtime sampling").
    #[inline(always)]
    fn congruent(self, v: i32) -> u64 {
        u64::from(v as u32) + if v < 0 { u64::from(self.minus_2_32) } else { 0 }
    }

    /// `(v + dv) mod len` for signed coordinates, exact for every input.
    #[inline(always)]
    fn wrap_signed(self, v: i32, dv: i32) -> usize {
        if self.pow2 {
            // `len` divides 2^32, so wrapping u32 arithmetic preserves the residue
            // (including for negative `v`/`dv`, whose two's complement is ≡ mod 2^32).
            ((v as u32).wrapping_add(dv as u32) & self.mask) as usize
        } else {
            // Both terms are below 2^33, so the sum cannot overflow; `len >= 1`.
            ((self.congruent(v) + self.congruent(dv)) % u64::from(self.len)) as usize
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
/// `i32::MIN`/`u32::MAX` included). Sampling never panics, except
/// [`sample_channel`](Self::sample_channel) with a channel index at or above
/// [`channels`](Self::channels). Axes whose length is a power of two use a bit mask
/// instead of a division.
///
/// The methods here sample at the requested position; [`offset`](Self::offset) and
/// [`dimension`](Self::dimension) return an [`OffsetStbn`](crate::OffsetStbn) view with
/// the same methods that samples at a shifted position.
///
/// Invariant: [`data`](Self::data) is exactly `header().decoded_len()` bytes, and
/// `header().to_bytes()` followed by `data()` is a valid uncompressed blob.
#[derive(Clone, Copy)]
#[must_use]
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
    /// How the vector samplers turn a voxel's channels into its value.
    pub(crate) plan: VectorPlan,
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
            plan: VectorPlan::new(&header),
        }
    }

    /// Validates a complete uncompressed blob (header, payload length, payload CRC and
    /// values, see [`verify`](Self::verify)) and views its payload without copying.
    ///
    /// The view keeps every sampling promise: finite values in `[0, 1]` (signed components in
    /// `[-1, 1]`), unit vectors within [`UNIT_LENGTH_TOLERANCE`](crate::UNIT_LENGTH_TOLERANCE)
    /// for direction spaces (`z >= 0` for hemispheres), finite pdfs `>= 0`.
    ///
    /// # Errors
    /// Any header error from [`MaskHeader::parse`]; [`Error::Compressed`] if the
    /// payload is compressed; [`Error::Truncated`] / [`Error::PayloadLength`] if
    /// the blob is shorter / longer than `64 + payload_len`;
    /// [`Error::PayloadChecksum`] if the payload CRC does not match;
    /// [`Error::InvalidValue`] if a stored value breaks a promise.
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
    /// checked. The payload is trusted as written: neither its CRC nor its values are checked
    /// (a check of every value would cost seconds per megabyte of compile time), so the
    /// sampling promises of [`from_bytes`](Self::from_bytes) hold for the blobs the generator
    /// writes, and for any other blob only once [`verify`](Self::verify) (or `from_bytes`) has
    /// accepted it; call it once, in a test or at start-up, if the bytes are not trusted. A
    /// payload that fails it still never makes sampling panic or read out of bounds, but its
    /// values are returned as stored (an F32 mask may then return NaN, a hemisphere `z < 0`).
    ///
    /// # Errors
    /// As [`from_bytes`](Self::from_bytes), except [`Error::PayloadChecksum`] and
    /// [`Error::InvalidValue`].
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
    #[must_use]
    pub const fn width(&self) -> u32 {
        self.header.width
    }

    /// Height in voxels (≥ 1).
    #[must_use]
    pub const fn height(&self) -> u32 {
        self.header.height
    }

    /// Depth in frames (≥ 1).
    #[must_use]
    pub const fn depth(&self) -> u32 {
        self.header.depth
    }

    /// Channels per voxel (1..=4).
    #[must_use]
    pub const fn channels(&self) -> u8 {
        self.header.channels
    }

    /// Element encoding of [`data`](Self::data).
    #[must_use]
    pub const fn encoding(&self) -> Encoding {
        self.header.encoding
    }

    /// Header describing this view's data as an uncompressed blob: `compression`
    /// is [`Compression::None`](crate::Compression::None), `payload_len` is the decoded length and
    /// `payload_crc32` the CRC of [`data`](Self::data).
    #[must_use]
    pub const fn header(&self) -> &MaskHeader {
        &self.header
    }

    /// The decoded payload: `decoded_len` bytes, element order
    /// `((z * height + y) * width + x) * channels + c`, little-endian elements.
    #[must_use]
    pub const fn data(&self) -> &'a [u8] {
        self.data
    }

    /// Channel 0 at `(x, y, frame)`, wrapped toroidally on all three axes.
    ///
    /// Returns the stored unit value `u`: in `(0, 1)` for Unorm encodings (the
    /// bin midpoint `(q + 0.5) / 2^bits`), the stored `f32` for
    /// [`Encoding::F32`] (in `[0, 1]` for a verified view, see [`verify`](Self::verify)).
    /// Use [`ValueMap::apply`](crate::ValueMap::apply) for
    /// signed masks. Sample at an offset through [`offset`](Self::offset) or
    /// [`dimension`](Self::dimension).
    #[must_use]
    #[inline]
    pub fn sample(&self, x: i32, y: i32, frame: u32) -> f32 {
        self.sample_at(x, y, frame, SampleOffset::ZERO, 0)
    }

    /// Channel `channel` (`0..channels`) at `(x, y, frame)`, wrapped like
    /// [`sample`](Self::sample).
    ///
    /// # Panics
    /// If `channel >= channels()`, like an out-of-range slice index, in debug and release
    /// builds: the channel count is fixed per mask, so a larger index is a bug in the caller.
    #[must_use]
    #[inline]
    #[track_caller]
    pub fn sample_channel(&self, x: i32, y: i32, frame: u32, channel: u32) -> f32 {
        self.channel_at(x, y, frame, SampleOffset::ZERO, channel)
    }

    /// Fills `out[i]` with `sample(x0 + i, y, frame)` for every `i` (the x sum
    /// wraps exactly, without `i32` overflow); `out` may be longer than the width,
    /// in which case the row repeats: one period is decoded and copied over the rest.
    pub fn fill_row(&self, x0: i32, y: i32, frame: u32, out: &mut [f32]) {
        self.fill_row_at(x0, y, frame, SampleOffset::ZERO, out);
    }

    /// Fills `out` with channel 0 of frame `frame` (wrapped modulo depth) in
    /// row-major order: `out[y * width + x] = sample(x, y, frame)`.
    ///
    /// Writes `min(out.len(), width * height)` values and returns that count; a
    /// shorter `out` receives the first rows (the last one possibly partial), a
    /// longer one keeps its tail untouched.
    pub fn fill_frame(&self, frame: u32, out: &mut [f32]) -> usize {
        self.fill_frame_at(frame, SampleOffset::ZERO, out)
    }

    /// The R2-sequence offset of sample dimension `dimension`, as [`Stbn::dimension`]
    /// documents it: `fract(i / g)` and `fract(i / g²)` in 0.64 fixed point, scaled to the
    /// width and height.
    pub(crate) const fn dimension_offset(&self, dimension: u32) -> SampleOffset {
        let i = dimension as u64;
        SampleOffset {
            // `scale` returns < width <= MAX_DECODED_BYTES = 2^31, so it fits in i32.
            x: self.x.scale(i.wrapping_mul(R2_A1)) as i32,
            y: self.y.scale(i.wrapping_mul(R2_A2)) as i32,
            frame: 0,
        }
    }

    /// The offset a progressive view adds in `epoch` (frames `epoch * depth ..`): the
    /// `epoch`-th point of the R2 sequence with its axes swapped, `(fract(e / g²), fract(e / g))`
    /// in 0.32 fixed point (`e · step` wrapping in `u32`), scaled to the width and height with
    /// the high word of a 32 × 32-bit product: x in `[0, width)`, y in `[0, height)`, frame 0.
    /// Epoch 0 is the zero offset. The axes are swapped against [`dimension_offset`]
    /// (`(fract(i / g), fract(i / g²))`) so that epoch `e` of dimension `i` is not dimension
    /// `i + e` of epoch 0. Integer arithmetic only, so the WGSL snippet computes the same bits.
    #[inline(always)]
    pub(crate) fn epoch_offset(&self, epoch: u32) -> SampleOffset {
        SampleOffset {
            // `scale32` returns < len <= 2^31, so each fits in i32.
            x: self.x.scale32(epoch.wrapping_mul(EPOCH_STEP_X)) as i32,
            y: self.y.scale32(epoch.wrapping_mul(EPOCH_STEP_Y)) as i32,
            frame: 0,
        }
    }

    /// How a progressive view of this mask computes its epochs: from shifts it carries when every
    /// axis is a power of two, through [`progressive_offset`](Self::progressive_offset) otherwise.
    pub(crate) const fn epochs(&self) -> Epochs {
        if self.all_pow2 {
            // Each shift is at most 31, so `32 - shift` is in 1..=32 and every value fits in u8.
            Epochs::Pow2 {
                z: self.z.shift as u8,
                x: (32 - self.x.shift) as u8,
                y: (32 - self.y.shift) as u8,
            }
        } else {
            Epochs::General
        }
    }

    /// The offset a progressive view with offset `o` applies at `frame`: `o` plus the
    /// [`epoch_offset`](Self::epoch_offset) of epoch `frame / depth`, each component congruent
    /// to the exact sum modulo its axis (not necessarily wrapped).
    #[inline(always)]
    pub(crate) fn progressive_offset(&self, o: SampleOffset, frame: u32) -> SampleOffset {
        let epoch = self.epoch_offset(self.z.quotient(frame));
        SampleOffset {
            x: self.x.add(o.x, epoch.x),
            y: self.y.add(o.y, epoch.y),
            frame: o.frame,
        }
    }

    /// `a + b` with each component reduced modulo its axis, exactly (as if summed in
    /// unbounded integers): x in `[0, width)`, y in `[0, height)`, frame in `[0, depth)`.
    pub(crate) fn add_offsets(&self, a: SampleOffset, b: SampleOffset) -> SampleOffset {
        // Each wrapped sum is below its axis length <= MAX_DECODED_BYTES = 2^31.
        SampleOffset {
            x: self.x.wrap_signed(a.x, b.x) as i32,
            y: self.y.wrap_signed(a.y, b.y) as i32,
            frame: self.z.wrap_unsigned(a.frame, b.frame) as u32,
        }
    }

    /// [`fill_row`](Self::fill_row) at `(x0 + o.x, y + o.y, frame + o.frame)`.
    #[inline]
    pub(crate) fn fill_row_at(
        &self,
        x0: i32,
        y: i32,
        frame: u32,
        o: SampleOffset,
        out: &mut [f32],
    ) {
        self.row_runs(x0, y, frame, o, out, |first, run| {
            self.convert_run(first, run);
        });
    }

    /// [`fill_frame`](Self::fill_frame) at offset `o`, which must be wrapped (as
    /// [`add_offsets`](Self::add_offsets) returns it).
    #[inline]
    pub(crate) fn fill_frame_at(&self, frame: u32, o: SampleOffset, out: &mut [f32]) -> usize {
        self.frame_runs(frame, o, out, |first, run| self.convert_run(first, run))
    }

    /// Fills the row of `out.len()` voxels from `(x0 + o.x, y + o.y, frame + o.frame)` (x
    /// wrapping, so the row may repeat): splits its first `width` voxels into runs contiguous in
    /// the data (one or two) and calls `run(first, part)` for each, `first` the channel-0 element
    /// index of the run's first voxel and `part` the matching part of `out`; then copies those
    /// `width` values over the rest of `out`, which repeats them (a 1080p row of a 128-wide mask
    /// decodes 128 voxels, not 1920).
    #[inline(always)]
    pub(crate) fn row_runs<T: Copy>(
        &self,
        x0: i32,
        y: i32,
        frame: u32,
        o: SampleOffset,
        out: &mut [T],
        mut run: impl FnMut(usize, &mut [T]),
    ) {
        let row = self.z.wrap_unsigned(frame, o.frame) * self.frame_stride
            + self.y.wrap_signed(y, o.y) * self.row_stride;
        let width = self.header.width as usize;
        let x = self.x.wrap_signed(x0, o.x);
        let (period, repeats) = out.split_at_mut(width.min(out.len()));
        let (head, tail) = period.split_at_mut((width - x).min(period.len()));
        run(row + x * self.channels, head);
        if !tail.is_empty() {
            run(row, tail);
        }
        for part in repeats.chunks_mut(width) {
            part.copy_from_slice(&period[..part.len()]);
        }
    }

    /// Splits the first `min(out.len(), width * height)` voxels of frame `frame` at offset `o`
    /// (wrapped, as [`add_offsets`](Self::add_offsets) returns it), row-major, into runs like
    /// [`row_runs`](Self::row_runs) and returns that count: one run when `o` shifts only the
    /// frame, row by row otherwise.
    #[inline(always)]
    pub(crate) fn frame_runs<T: Copy>(
        &self,
        frame: u32,
        o: SampleOffset,
        out: &mut [T],
        mut run: impl FnMut(usize, &mut [T]),
    ) -> usize {
        let width = self.header.width as usize;
        let n = out.len().min(width * self.header.height as usize);
        let (head, _) = out.split_at_mut(n);
        if o.x == 0 && o.y == 0 {
            let z = self.z.wrap_unsigned(frame, o.frame);
            run(z * self.frame_stride, head);
        } else {
            for (y, row) in head.chunks_mut(width).enumerate() {
                // y < height <= 2^31, so it fits in i32.
                self.row_runs(0, y as i32, frame, o, row, &mut run);
            }
        }
        n
    }

    /// Channel `channel` at `(x + o.x, y + o.y, frame + o.frame)`.
    ///
    /// # Panics
    /// If `channel >= channels`.
    #[inline]
    #[track_caller]
    pub(crate) fn channel_at(
        &self,
        x: i32,
        y: i32,
        frame: u32,
        o: SampleOffset,
        channel: u32,
    ) -> f32 {
        let c = channel as usize;
        assert!(
            c < self.channels,
            "channel {channel} out of range for a mask with {} channels",
            self.channels
        );
        self.sample_at(x, y, frame, o, c)
    }

    /// Channel `channel` (< channels) at `(x + o.x, y + o.y, frame + o.frame)`.
    #[inline(always)]
    pub(crate) fn sample_at(
        &self,
        x: i32,
        y: i32,
        frame: u32,
        o: SampleOffset,
        channel: usize,
    ) -> f32 {
        self.element(self.voxel(x, y, frame, o) + channel)
    }

    /// The element index of channel 0 of the voxel at `(x + o.x, y + o.y, frame + o.frame)`,
    /// wrapped toroidally; that and the next `channels - 1` elements are in bounds.
    #[inline(always)]
    pub(crate) fn voxel(&self, x: i32, y: i32, frame: u32, o: SampleOffset) -> usize {
        if self.all_pow2 {
            return self.voxel_pow2(x, y, frame, o);
        }
        let voxel = (self.z.wrap_unsigned(frame, o.frame) * self.header.height as usize
            + self.y.wrap_signed(y, o.y))
            * self.header.width as usize
            + self.x.wrap_signed(x, o.x);
        voxel * self.channels
    }

    /// [`voxel`](Self::voxel) for a mask whose axes are all powers of two (`all_pow2`).
    #[inline(always)]
    pub(crate) fn voxel_pow2(&self, x: i32, y: i32, frame: u32, o: SampleOffset) -> usize {
        debug_assert!(self.all_pow2);
        self.voxel_number_pow2(x, y, frame, o) * self.channels
    }

    /// The voxel number `(z · height + y) · width + x` of [`voxel_pow2`](Self::voxel_pow2)
    /// (its channel-0 element index divided by the channels), for callers that know the
    /// channel count as a constant. Meaningless unless `all_pow2`, but computed without
    /// overflow for every mask (both shifts are at most 31: width × height ≤ 2^31 voxels), so a
    /// caller may compute it before it tests `all_pow2`.
    #[inline(always)]
    pub(crate) fn voxel_number_pow2(&self, x: i32, y: i32, frame: u32, o: SampleOffset) -> usize {
        // Every axis length divides 2^32, so wrapping u32 sums keep the exact residues; the
        // packed index is < width*height*depth <= 2^31.
        let x = (x as u32).wrapping_add(o.x as u32) & self.x.mask;
        let y = (y as u32).wrapping_add(o.y as u32) & self.y.mask;
        let z = frame.wrapping_add(o.frame) & self.z.mask;
        ((z << self.z_shift) | (y << self.y_shift) | x) as usize
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
            (encoding, 1) => decode_elements(encoding, src, out),
            (Encoding::Unorm8, _) => {
                for (o, &q) in out.iter_mut().zip(src.iter().step_by(c)) {
                    *o = unorm8(q);
                }
            }
            (Encoding::Unorm16, _) => {
                for (o, q) in out.iter_mut().zip(src.chunks_exact(2 * c)) {
                    *o = unorm16(u16::from_le_bytes([q[0], q[1]]));
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

/// Decodes the elements of `src` in order into `out`, as many as both hold: a simple zip per
/// encoding that LLVM vectorises.
#[inline(always)]
pub(crate) fn decode_elements(encoding: Encoding, src: &[u8], out: &mut [f32]) {
    match encoding {
        Encoding::Unorm8 => {
            for (o, &q) in out.iter_mut().zip(src) {
                *o = unorm8(q);
            }
        }
        Encoding::Unorm16 => {
            for (o, q) in out.iter_mut().zip(src.chunks_exact(2)) {
                *o = unorm16(u16::from_le_bytes([q[0], q[1]]));
            }
        }
        Encoding::F32 => {
            for (o, q) in out.iter_mut().zip(src.chunks_exact(4)) {
                *o = f32::from_le_bytes([q[0], q[1], q[2], q[3]]);
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
    fn epoch_steps_match_the_plastic_number() {
        let g = 1.324_717_957_244_746_f64;
        let scale = 4_294_967_296.0_f64; // 2^32
        assert!((f64::from(EPOCH_STEP_X) / scale - 1.0 / (g * g)).abs() <= 0.5 / scale);
        assert!((f64::from(EPOCH_STEP_Y) / scale - 1.0 / g).abs() <= 0.5 / scale);
    }

    #[test]
    fn axis_quotient_add_and_scale32_are_exact() {
        for len in [1, 3, 10, 64, 96, 1 << 31, (1 << 31) - 1] {
            let axis = Axis::new(len);
            for v in [0, 1, 63, 64, 65, 1000, u32::MAX - 1, u32::MAX] {
                assert_eq!(axis.quotient(v), v / len);
            }
            for a in [i32::MIN, -65, -1, 0, 1, 63, i32::MAX] {
                for b in [i32::MIN, -7, 0, 5, i32::MAX] {
                    let exact = (i64::from(a) + i64::from(b)).rem_euclid(i64::from(len));
                    assert_eq!(i64::from(axis.add(a, b)).rem_euclid(i64::from(len)), exact);
                }
            }
            assert_eq!(axis.scale32(0), 0);
            assert_eq!(axis.scale32(u32::MAX), len - 1);
            assert_eq!(axis.scale32(1 << 31), len / 2);
        }
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

    #[test]
    fn signed_wrap_is_the_euclidean_remainder_of_the_exact_sum() {
        let values = [
            i32::MIN,
            i32::MIN + 1,
            -1_000_003,
            -129,
            -128,
            -1,
            0,
            1,
            127,
            128,
            i32::MAX,
        ];
        for len in [1, 3, 10, 96, 100, 127, 128, 1000, (1 << 31) - 1, 1 << 31] {
            let axis = Axis::new(len);
            for v in values {
                for dv in values {
                    let exact = (i64::from(v) + i64::from(dv)).rem_euclid(i64::from(len));
                    assert_eq!(
                        axis.wrap_signed(v, dv),
                        exact as usize,
                        "{v} + {dv} mod {len}"
                    );
                }
            }
        }
    }
}
