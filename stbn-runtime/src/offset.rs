//! [`SampleOffset`] and [`OffsetStbn`]: sampling a mask at a shifted position, and
//! progressively past its depth.

use crate::Stbn;
use crate::sampler::{EPOCH_STEP_X, EPOCH_STEP_Y};

/// Integer offset added to a sample position before wrapping.
///
/// Each component is reduced modulo the mask's size on that axis, so any value
/// is valid and the sum never overflows (see [`Stbn::offset`]).
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

/// A mask seen through an offset: every method samples what the same method of the
/// [`Stbn`] returns at `(x + offset.x, y + offset.y, frame + offset.frame)`, plus, for a
/// [progressive](Self::progressive) view past the depth, the offset of the frame's epoch
/// ([`sample_offset_at`](Self::sample_offset_at) gives the total at any frame).
///
/// Made by [`Stbn::offset`], [`Stbn::dimension`] and [`Stbn::progressive`] (or `From<&Stbn>`,
/// at offset zero); [`offset`](Self::offset) and [`dimension`](Self::dimension) add further
/// offsets and [`progressive`](Self::progressive) turns the epochs on. It
/// borrows the mask and is as cheap to copy as a reference. The sums are taken modulo
/// the mask size exactly, as if computed in unbounded integers, even where they overflow
/// `i32`/`u32`.
///
/// ```
/// # use stbn_runtime::{SampleOffset, Stbn};
/// # fn demo(mask: &Stbn<'_>) {
/// // A pixel that starts its temporal sequence 11 frames in, for sample dimension 2.
/// let view = mask.offset(SampleOffset { x: 0, y: 0, frame: 11 }).dimension(2);
/// let u = view.sample(40, -3, 7);
/// # let _ = u;
/// # }
/// ```
#[derive(Clone, Copy, Debug)]
#[must_use]
pub struct OffsetStbn<'m> {
    pub(crate) mask: &'m Stbn<'m>,
    /// As given: each component is wrapped when sampling.
    pub(crate) offset: SampleOffset,
    /// How frames past the depth are read ([`Stbn::progressive`]).
    pub(crate) epochs: Epochs,
}

/// How a view reads frames past the mask's depth.
///
/// The power-of-two case carries its shifts in the view itself, so the epoch offset of a
/// sample is a function of the view's own fields and the frame: in a caller's pixel loop over
/// one frame it depends on nothing the loop writes, and the compiler can compute it once.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Epochs {
    /// Not progressive: every frame at the view's offset.
    Off,
    /// Progressive, every axis a power of two: epoch `frame >> z`, offsets the top bits of the
    /// 0.32 products (`>> x`, `>> y`, each `32 - log2(length)`, in `0..=32`).
    Pow2 { z: u8, x: u8, y: u8 },
    /// Progressive, some axis not a power of two: [`Stbn::progressive_offset`].
    General,
}

impl<'m, 'a: 'm> From<&'m Stbn<'a>> for OffsetStbn<'m> {
    /// The mask at offset zero: samples exactly what the mask's own methods return.
    fn from(mask: &'m Stbn<'a>) -> Self {
        mask.offset(SampleOffset::ZERO)
    }
}

impl Stbn<'_> {
    /// The mask seen through `offset`: `mask.offset(o).sample(x, y, frame)` is channel 0
    /// at `(x + o.x, y + o.y, frame + o.frame)`, wrapped toroidally.
    pub const fn offset(&self, offset: SampleOffset) -> OffsetStbn<'_> {
        OffsetStbn {
            mask: self,
            offset,
            epochs: Epochs::Off,
        }
    }

    /// The mask read progressively: frames `0..depth` return exactly what the mask's own
    /// methods return, and every later pass through the depth (epoch `e = frame / depth`)
    /// reads the mask shifted toroidally by the `e`-th point of a 2D R2 (Kronecker)
    /// sequence, so a pixel keeps meeting new values and its running mean keeps converging,
    /// with an error that stays blue in screen space, where [`sample`](Self::sample) repeats
    /// the same `depth` values forever.
    ///
    /// The epoch offset is `(floor(fract(e / g²) · width), floor(fract(e / g) · height))`, `g`
    /// the plastic number, computed in 0.32 fixed point (`e · step` wrapping in `u32`, then the
    /// high word of a 32 × 32-bit product), so it is the same bits in the WGSL snippet; the axes
    /// are swapped against [`dimension`](Self::dimension)'s offsets, so that epoch `e` of one
    /// dimension is not another dimension's first epoch. Every mask kind (scalar, vector,
    /// importance-sampled) keeps its distribution: only the position moves.
    ///
    /// What it buys, measured per pixel and for the error image against wrapping and white
    /// noise: BENCHMARKS.md, "Past the depth"; `stbn-gen generate` reports it per mask, and the
    /// `past_depth` scene (scenes/README.md) in a renderer. A mask one pixel tall is the
    /// exception measured: its shifts move along x alone, and the error image of a 64×1×1 mask
    /// past the depth had 0.36–2.3 times white noise's low band (a 1×64×1 one: 0.08–0.20).
    ///
    /// **Speed.** On a mask whose sizes are powers of two the view carries its epoch shifts, so
    /// the frame's epoch offset (a shift and two 32-bit multiplies) depends only on the view and
    /// the frame and leaves a pixel loop: per sample it reads as fast as the mask itself
    /// (BENCHMARKS.md, "Runtime sampling"). On other sizes it is computed from the mask's axes per
    /// sample; there, `mask.offset(view.sample_offset_at(frame))` is a plain view with the same
    /// values for every frame of that epoch. Row and frame fills compute it once.
    ///
    /// **Several values per pixel per frame** of the same integrand: read consecutive
    /// progressive frames, value `i` of frame `f` being `view.sample(x, y, n * f + i)` (with
    /// `wrapping_mul`/`wrapping_add` past `u32::MAX`). It converges at least as fast as `n`
    /// R2 dimensions read progressively (faster in the first frames) and keeps the error blue;
    /// keep [`dimension`](Self::dimension) for values of *different* dimensions of a sample (the
    /// two coordinates of a lens position, a light choice), which must not be correlated.
    ///
    /// ```
    /// # use stbn_runtime::{Stbn, include_stbn};
    /// static MASK: Stbn<'static> = include_stbn!("../tests/data/scalar_16.stbn");
    /// let view = MASK.progressive();
    /// // The first `depth` frames are the mask itself ...
    /// assert_eq!(view.sample(3, 4, 5), MASK.sample(3, 4, 5));
    /// // ... and frame 8 + 5 (epoch 1) no longer repeats frame 5.
    /// assert_ne!(view.sample_offset_at(8 + 5), view.sample_offset_at(5));
    /// ```
    pub const fn progressive(&self) -> OffsetStbn<'_> {
        self.offset(SampleOffset::ZERO).progressive()
    }

    /// The mask seen through the offset of sample dimension `dimension`, so that one mask
    /// serves several decorrelated dimensions of a pixel's sample (dimension 0 is the mask
    /// itself).
    ///
    /// The offset comes from the R2 low-discrepancy sequence:
    /// `(floor(fract(i / g) * width), floor(fract(i / g²) * height), 0)` with
    /// `i = dimension` and `g` the plastic number 1.3247179572…, so x is in `[0, width)`, y in
    /// `[0, height)` and the frame is unchanged (see [`OffsetStbn::sample_offset`]).
    /// `fract(i·a)` is computed in 0.64 fixed point (`a` rounded to 2^-64, then a wrapping
    /// `u64` multiply and a `u128` scale): integer arithmetic only, so offsets are
    /// bit-identical on every platform.
    pub const fn dimension(&self, dimension: u32) -> OffsetStbn<'_> {
        self.offset(self.dimension_offset(dimension))
    }
}

impl<'m> OffsetStbn<'m> {
    /// This view shifted further by `offset`: the offsets add, exactly.
    pub fn offset(self, offset: SampleOffset) -> Self {
        Self {
            offset: self.mask.add_offsets(self.offset, offset),
            ..self
        }
    }

    /// This view read progressively past the mask's depth (see [`Stbn::progressive`]): frames
    /// `0..depth` are unchanged; epoch `e = frame / depth` (of the frame passed to the
    /// sampling methods, before this view's start-frame offset) adds the epoch's R2 offset to
    /// this view's offset.
    pub const fn progressive(self) -> Self {
        Self {
            epochs: self.mask.epochs(),
            ..self
        }
    }

    /// Whether this view is progressive ([`progressive`](Self::progressive)).
    #[must_use]
    pub const fn is_progressive(&self) -> bool {
        !matches!(self.epochs, Epochs::Off)
    }

    /// This view shifted further by the offset of sample dimension `dimension` (see
    /// [`Stbn::dimension`]).
    pub fn dimension(self, dimension: u32) -> Self {
        self.offset(self.mask.dimension_offset(dimension))
    }

    /// The offset this view adds at frames `0..depth`, each component wrapped into its axis:
    /// x in `[0, width)`, y in `[0, height)`, frame in `[0, depth)`. Views with equal
    /// `sample_offset` and [`is_progressive`](Self::is_progressive) over the same mask sample
    /// the same values.
    #[must_use]
    pub fn sample_offset(&self) -> SampleOffset {
        self.mask.add_offsets(self.offset, SampleOffset::ZERO)
    }

    /// The offset this view adds at `frame`, wrapped like [`sample_offset`](Self::sample_offset):
    /// every method samples the mask itself at `(x, y, frame)` plus this offset. It is
    /// `sample_offset()` for every frame of a view that is not progressive, and for frames
    /// `0..depth` of one that is.
    #[must_use]
    pub fn sample_offset_at(&self, frame: u32) -> SampleOffset {
        self.mask
            .add_offsets(self.offset_at(frame), SampleOffset::ZERO)
    }

    /// The offset to sample `frame` at, not necessarily wrapped.
    #[inline(always)]
    pub(crate) fn offset_at(&self, frame: u32) -> SampleOffset {
        match self.epochs {
            Epochs::Off => self.offset,
            Epochs::Pow2 { z, x, y } => {
                // Every length divides 2^32: wrapping sums keep the residues, and `scale32`
                // of a power-of-two length is the fraction's top bits (see `epoch_offset`).
                let epoch = frame >> z;
                let top =
                    |step: u32, shift: u8| (u64::from(epoch.wrapping_mul(step)) >> shift) as i32;
                SampleOffset {
                    x: self.offset.x.wrapping_add(top(EPOCH_STEP_X, x)),
                    y: self.offset.y.wrapping_add(top(EPOCH_STEP_Y, y)),
                    frame: self.offset.frame,
                }
            }
            Epochs::General => self.mask.progressive_offset(self.offset, frame),
        }
    }

    /// [`Stbn::sample`] at the offset position: channel 0, the stored unit value.
    #[must_use]
    #[inline]
    pub fn sample(&self, x: i32, y: i32, frame: u32) -> f32 {
        self.mask.sample_at(x, y, frame, self.offset_at(frame), 0)
    }

    /// [`Stbn::sample_channel`] at the offset position: channel `channel`
    /// (`0..channels`).
    ///
    /// # Panics
    /// If `channel >= channels()` of the mask, in debug and release builds.
    #[must_use]
    #[inline]
    #[track_caller]
    pub fn sample_channel(&self, x: i32, y: i32, frame: u32, channel: u32) -> f32 {
        self.mask
            .channel_at(x, y, frame, self.offset_at(frame), channel)
    }

    /// Fills `out[i]` with `sample(x0 + i, y, frame)` for every `i`, like
    /// [`Stbn::fill_row`].
    pub fn fill_row(&self, x0: i32, y: i32, frame: u32, out: &mut [f32]) {
        self.mask
            .fill_row_at(x0, y, frame, self.offset_at(frame), out);
    }

    /// Fills `out` in row-major order with `out[y * width + x] = sample(x, y, frame)`,
    /// like [`Stbn::fill_frame`]: writes `min(out.len(), width * height)` values and
    /// returns that count.
    pub fn fill_frame(&self, frame: u32, out: &mut [f32]) -> usize {
        self.mask
            .fill_frame_at(frame, self.sample_offset_at(frame), out)
    }
}
