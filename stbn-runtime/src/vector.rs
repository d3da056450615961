//! Vector sampling: [`VectorSample`], the value maps applied to several channels, octahedral
//! decoding and the pdf of every [`Space`].

use core::f32::consts::PI;
use core::marker::PhantomData;

use glam::{Vec2, Vec3, Vec4};

use crate::sampler::decode_elements;
use crate::sqrt::sqrt;
use crate::{Encoding, MaskHeader, OffsetStbn, SampleOffset, Space, Stbn, ValueMap};

/// One vector read from a mask: the value and the density it was drawn with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VectorSample {
    /// The value's [`dims`](Stbn::dims) components (1..=4), mapped by the mask's
    /// [`ValueMap`] and, for unit-vector spaces, normalised to length 1; unused components are 0.
    pub value: Vec4,
    /// The pdf the value was drawn from, at the value, in the space's measure (per unit volume
    /// of `[0, 1)^n` for vectors and image points, per steradian for directions, per radian on
    /// the circle, per sign for `±1`): stored for image spaces, derived otherwise (see
    /// [`Space`]). Always finite and `>= 0`.
    pub pdf: f32,
}

/// Decodes an octahedral-mapped unit vector from its two coordinates `e` in `[-1, 1]²`
/// (Cigolle et al., "A Survey of Efficient Representations for Independent Unit Vectors",
/// 2014). The result has length 1 (within `f32` rounding) for every input, including the
/// corners and the fold lines, and is bit for bit what the samplers return for an octahedral
/// mask whose stored coordinates map to `e`.
#[must_use]
pub fn octahedral_decode(e: Vec2) -> Vec3 {
    // The operations of `voxel_value::<Octahedral, _>`, so that the samplers match this.
    let v = octahedral_unfold(e.x, e.y);
    let scale = unit_scale(v);
    Vec3::new(v[0] * scale, v[1] * scale, v[2] * scale)
}

/// The octahedral unfolding of `(ex, ey)` as `[x, y, z, 0]`, before normalisation (its length
/// is at least `1/sqrt(3)`): straight-line `f32` arithmetic, so that loops over it vectorise.
#[inline(always)]
fn octahedral_unfold(ex: f32, ey: f32) -> [f32; 4] {
    let (ax, ay) = (ex.abs(), ey.abs());
    let z = 1.0 - ax - ay;
    // The lower hemisphere (z < 0) was folded over the diagonals: unfold it without a branch
    // (the fold is a coin flip per sample, and a mispredicted branch cost more than this):
    // with t = max(−z, 0), (|x| − t)·sign(x) is (1 − |y|)·sign(x) where z < 0 and x elsewhere.
    // Copying the sign bit (−0.0 included) costs less than multiplying by the sign.
    let t = (-z).max(0.0);
    // |x| + |y| + |z| >= 1 whatever the input, so the squared length is at least 1/3.
    [(ax - t).copysign(ex), (ay - t).copysign(ey), z, 0.0]
}

/// Encodes a unit vector `n` as the octahedral coordinates in `[-1, 1]²` that
/// [`octahedral_decode`] maps back to it. `n` must be non-zero; it need not be normalised.
#[must_use]
pub fn octahedral_encode(n: Vec3) -> Vec2 {
    let p = n / (n.x.abs() + n.y.abs() + n.z.abs());
    if p.z < 0.0 {
        Vec2::new(
            (1.0 - p.y.abs()) * sign_not_zero(p.x),
            (1.0 - p.x.abs()) * sign_not_zero(p.y),
        )
    } else {
        Vec2::new(p.x, p.y)
    }
}

/// `1.0` for `v >= 0` (`-0.0` included, as it compares equal to 0), `-1.0` otherwise.
#[inline(always)]
fn sign_not_zero(v: f32) -> f32 {
    // 1.0 with v's sign bit, except that -0.0 gives 1.0 like +0.0.
    let negative = u32::from(v < 0.0) << 31;
    f32::from_bits(1.0f32.to_bits() | negative)
}

/// What the vector fills write per voxel: [`Vec2`], [`Vec3`], [`Vec4`] (the value's first 2, 3
/// or 4 components, as `sample_vec2/3/4` return them) or [`VectorSample`] (value and pdf, as
/// [`sample_vector`](Stbn::sample_vector) returns them). Sealed: implemented for those four only.
pub trait VectorOutput: Copy + sealed::FromValue {}

mod sealed {
    /// The conversion behind [`VectorOutput`](super::VectorOutput), private to this crate.
    pub trait FromValue: Sized {
        /// Whether [`from_value`](Self::from_value) reads its `pdf` (otherwise it gets 0).
        const NEEDS_PDF: bool;
        /// The [`Hot`](super::Hot) plans whose per-sample reads of this output are tested
        /// first, as a set of `1 << plan` bits.
        const HOT: u8;
        /// The output for the decoded value `value` (unused components 0) and its pdf.
        fn from_value(value: [f32; 4], pdf: f32) -> Self;
        /// The components of the output's value, in order: all of a glam vector's, the four
        /// of a [`VectorSample`](crate::VectorSample)'s `value`.
        fn components_mut(&mut self) -> &mut [f32];
    }
}

impl sealed::FromValue for Vec2 {
    const HOT: u8 = Hot::Identity2.bit();
    const NEEDS_PDF: bool = false;
    #[inline(always)]
    fn from_value(value: [f32; 4], _: f32) -> Self {
        Vec2::new(value[0], value[1])
    }
    #[inline(always)]
    fn components_mut(&mut self) -> &mut [f32] {
        self.as_mut()
    }
}

impl sealed::FromValue for Vec3 {
    const HOT: u8 = Hot::Octahedral2.bit() | Hot::Normalise3.bit();
    const NEEDS_PDF: bool = false;
    #[inline(always)]
    fn from_value(value: [f32; 4], _: f32) -> Self {
        Vec3::new(value[0], value[1], value[2])
    }
    #[inline(always)]
    fn components_mut(&mut self) -> &mut [f32] {
        self.as_mut()
    }
}

impl sealed::FromValue for Vec4 {
    const HOT: u8 = Hot::Identity4.bit();
    const NEEDS_PDF: bool = false;
    #[inline(always)]
    fn from_value(value: [f32; 4], _: f32) -> Self {
        Vec4::from_array(value)
    }
    #[inline(always)]
    fn components_mut(&mut self) -> &mut [f32] {
        self.as_mut()
    }
}

impl sealed::FromValue for VectorSample {
    const HOT: u8 = 0;
    const NEEDS_PDF: bool = true;
    #[inline(always)]
    fn from_value(value: [f32; 4], pdf: f32) -> Self {
        VectorSample {
            value: Vec4::from_array(value),
            pdf,
        }
    }
    #[inline(always)]
    fn components_mut(&mut self) -> &mut [f32] {
        self.value.as_mut()
    }
}

impl VectorOutput for Vec2 {}
impl VectorOutput for Vec3 {}
impl VectorOutput for Vec4 {}
impl VectorOutput for VectorSample {}

/// How a mask's stored channels become its value, fixed per mask: chosen when the view is built
/// and dispatched once per sample or once per run of a fill, so that each decode loop is
/// straight-line code for one layout.
#[derive(Clone, Copy)]
pub(crate) struct VectorPlan {
    transform: Transform,
    layout: Layout,
    pdf: Pdf,
    /// The plan's hot path, [`Hot::None`] for a mask whose axes are not all powers of two.
    hot: Hot,
}

/// The plans whose per-sample reads into the output that lists them are tested first, with
/// straight-line code per encoding: the common ones, on masks whose axes are all powers of two
/// (so that the voxel index is a few integer instructions). Every other read goes through the
/// full dispatch on the plan, with the same arithmetic. Each hot plan adds code to a caller's
/// pixel loop: signed Vec2 and Vec4 masks as hot plans too made `sample_vec2` of a Unorm8 Vec2
/// mask 2.3 → 2.7 ms per 1080p frame, so they stay out.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Hot {
    /// None of the others.
    None,
    /// [`Transform::Identity`], 2 value channels of 2.
    Identity2,
    /// [`Transform::Identity`], 4 value channels of 4.
    Identity4,
    /// [`Transform::Octahedral`], 2 value channels of 2.
    Octahedral2,
    /// [`Transform::Normalise`], 3 value channels of 3.
    Normalise3,
}

impl Hot {
    /// This plan's bit in a [`FromValue::HOT`](sealed::FromValue::HOT) set.
    const fn bit(self) -> u8 {
        1 << self as u8
    }
}

/// How the pdf of a value is found.
#[derive(Clone, Copy)]
enum Pdf {
    /// The same for every value.
    Constant(f32),
    /// `z / π` (cosine-weighted hemisphere), `z` the value's third component.
    Cosine,
    /// Stored in the last channel, full-range between the header's `pdf_min` and `pdf_max`.
    Stored,
}

/// What happens to the value channels.
#[derive(Clone, Copy)]
enum Transform {
    /// Kept as stored: [`ValueMap::Unit`] outside unit-vector spaces (mapping by `u · 1 + (−0)`
    /// would give the same numbers, in two more operations per channel).
    Identity,
    /// Mapped by [`ValueMap::Signed`]'s `2u − 1` (what every transform but `Identity` starts
    /// with: unit-vector spaces are never [`ValueMap::Unit`]), then kept.
    Keep,
    /// Normalised to length 1 (unit-vector spaces), a zero vector kept.
    Normalise,
    /// The first two decoded as an octahedral direction.
    Octahedral,
}

/// Value channels and channels per voxel (the last one the pdf when they differ): the
/// combinations [`MaskHeader::parse`] accepts.
#[derive(Clone, Copy)]
enum Layout {
    C1S1,
    C2S2,
    C2S3,
    C3S3,
    C3S4,
    C4S4,
}

impl VectorPlan {
    /// The plan of a validated header.
    pub(crate) const fn new(header: &MaskHeader) -> Self {
        let transform = match header.value_map {
            ValueMap::Octahedral => Transform::Octahedral,
            _ if header.space.is_unit() => Transform::Normalise,
            ValueMap::Unit => Transform::Identity,
            ValueMap::Signed => Transform::Keep,
        };
        // Parsing allows 1..=4 channels and gives a pdf channel 2 or 3 value channels.
        let layout = match (header.value_channels(), header.channels) {
            (1, _) => Layout::C1S1,
            (2, 2) => Layout::C2S2,
            (2, _) => Layout::C2S3,
            (3, 3) => Layout::C3S3,
            (3, _) => Layout::C3S4,
            _ => Layout::C4S4,
        };
        let pow2 = header.width.is_power_of_two()
            && header.height.is_power_of_two()
            && header.depth.is_power_of_two();
        let hot = match (pow2, transform, layout) {
            (false, _, _) => Hot::None,
            (true, Transform::Identity, Layout::C2S2) => Hot::Identity2,
            (true, Transform::Identity, Layout::C4S4) => Hot::Identity4,
            (true, Transform::Octahedral, Layout::C2S2) => Hot::Octahedral2,
            (true, Transform::Normalise, Layout::C3S3) => Hot::Normalise3,
            _ => Hot::None,
        };
        Self {
            transform,
            layout,
            pdf: Pdf::new(header),
            hot,
        }
    }

    /// Calls `visitor` with the transform, value channels `C` and channels per voxel `S` of
    /// this plan as types and constants.
    #[inline(always)]
    fn dispatch<V: PlanVisitor>(&self, visitor: V) -> V::Out {
        macro_rules! layouts {
            ($t:ty) => {
                match self.layout {
                    Layout::C1S1 => visitor.visit::<$t, 1, 1>(),
                    Layout::C2S2 => visitor.visit::<$t, 2, 2>(),
                    Layout::C2S3 => visitor.visit::<$t, 2, 3>(),
                    Layout::C3S3 => visitor.visit::<$t, 3, 3>(),
                    Layout::C3S4 => visitor.visit::<$t, 3, 4>(),
                    Layout::C4S4 => visitor.visit::<$t, 4, 4>(),
                }
            };
        }
        match self.transform {
            Transform::Identity => layouts!(Identity),
            Transform::Keep => layouts!(Keep),
            Transform::Normalise => layouts!(Normalise),
            Transform::Octahedral => layouts!(Octahedral),
        }
    }
}

/// Code run for one plan, with its transform `T`, `C` value channels and `S` channels per voxel.
trait PlanVisitor {
    type Out;
    fn visit<T: ValueTransform, const C: usize, const S: usize>(self) -> Self::Out;
}

/// The value of one voxel from its first `C` stored unit values `u` (later lanes 0), in two
/// steps so that fills can run each over a block: [`value`](Self::value), then, for unit
/// values, a multiplication by [`unit_scale`].
trait ValueTransform {
    /// Whether the value is scaled to length 1 after [`value`](Self::value).
    const UNIT: bool;
    /// Whether [`value`](Self::value) keeps the stored unit values.
    const IDENTITY: bool = false;
    /// The value before the scaling to length 1.
    fn value<const C: usize>(u: [f32; 4]) -> [f32; 4];
}

/// [`Transform::Identity`].
struct Identity;
/// [`Transform::Keep`].
struct Keep;
/// [`Transform::Normalise`].
struct Normalise;
/// [`Transform::Octahedral`].
struct Octahedral;

impl ValueTransform for Identity {
    const UNIT: bool = false;
    const IDENTITY: bool = true;
    #[inline(always)]
    fn value<const C: usize>(u: [f32; 4]) -> [f32; 4] {
        let mut v = [0.0; 4];
        v[..C].copy_from_slice(&u[..C]);
        v
    }
}

impl ValueTransform for Keep {
    const UNIT: bool = false;
    #[inline(always)]
    fn value<const C: usize>(u: [f32; 4]) -> [f32; 4] {
        let mut v = [0.0; 4];
        for (v, u) in v.iter_mut().zip(u).take(C) {
            *v = u * 2.0 - 1.0;
        }
        v
    }
}

impl ValueTransform for Normalise {
    const UNIT: bool = true;
    #[inline(always)]
    fn value<const C: usize>(u: [f32; 4]) -> [f32; 4] {
        Keep::value::<C>(u)
    }
}

impl ValueTransform for Octahedral {
    const UNIT: bool = true;
    #[inline(always)]
    fn value<const C: usize>(u: [f32; 4]) -> [f32; 4] {
        let e = Keep::value::<C>(u);
        octahedral_unfold(e[0], e[1])
    }
}

/// The factor that scales `v` to length 1: `1 / |v|`, or 1 for a zero vector (never a
/// quantised ±1, circle, sphere or octahedral value; the guard keeps hand-made blobs from
/// producing NaN).
#[inline(always)]
fn unit_scale(v: [f32; 4]) -> f32 {
    scale_of_squared_length(squared_length(v))
}

/// `|v|²`, summed in lane order.
#[inline(always)]
fn squared_length(v: [f32; 4]) -> f32 {
    v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[3] * v[3]
}

/// [`unit_scale`] from the squared length `d`: `1 / sqrt(d)`, each step correctly rounded (so
/// within 1 ulp, and exactly 1 for `d = 1`, the pole of every direction space), the same bits
/// on every target (see [`sqrt`]).
#[inline(always)]
fn scale_of_squared_length(d: f32) -> f32 {
    if d > 0.0 { 1.0 / sqrt(d) } else { 1.0 }
}

/// The value of a voxel whose `C` value channels hold the stored unit values `u`: what every
/// per-sample read returns, and what the fills compute in the same operations over a block.
#[inline(always)]
fn voxel_value<T: ValueTransform, const C: usize>(u: [f32; 4]) -> [f32; 4] {
    let v = T::value::<C>(u);
    if T::UNIT {
        let scale = unit_scale(v);
        v.map(|c| c * scale)
    } else {
        v
    }
}

/// Voxels a row fill decodes per block, in stack buffers of `8 * FILL_BLOCK` `f32`s (1 KB):
/// in AVX2 fills of 1080p rows, 32 measured 2–6% faster than 64 (less to zero per run of
/// voxels), and 128 about 15% slower than 64.
const FILL_BLOCK: usize = 32;

impl Stbn<'_> {
    /// What the values are samples of.
    #[must_use]
    pub const fn space(&self) -> Space {
        self.header().space
    }

    /// Components of one value: 1..=4 (3 for octahedral-encoded directions).
    #[must_use]
    pub const fn dims(&self) -> u8 {
        self.header().dims()
    }

    /// The vector at `(x, y, frame)`, wrapped toroidally like [`sample`](Self::sample),
    /// with its pdf.
    ///
    /// Works for every mask: a scalar mask gives `(u, 0, 0, 0)` with pdf 1.
    #[must_use]
    #[inline]
    pub fn sample_vector(&self, x: i32, y: i32, frame: u32) -> VectorSample {
        self.vector_at(x, y, frame, SampleOffset::ZERO)
    }

    /// The first two components at `(x, y, frame)` (see [`sample_vector`](Self::sample_vector)).
    #[must_use]
    #[inline]
    pub fn sample_vec2(&self, x: i32, y: i32, frame: u32) -> Vec2 {
        self.vector_at(x, y, frame, SampleOffset::ZERO)
    }

    /// The first three components at `(x, y, frame)`: a unit vector for direction masks.
    #[must_use]
    #[inline]
    pub fn sample_vec3(&self, x: i32, y: i32, frame: u32) -> Vec3 {
        self.vector_at(x, y, frame, SampleOffset::ZERO)
    }

    /// All four components at `(x, y, frame)` (the value of
    /// [`sample_vector`](Self::sample_vector), without the pdf).
    #[must_use]
    #[inline]
    pub fn sample_vec4(&self, x: i32, y: i32, frame: u32) -> Vec4 {
        self.vector_at(x, y, frame, SampleOffset::ZERO)
    }

    /// The pdf of the value at `(x, y, frame)` (see [`VectorSample::pdf`]).
    #[must_use]
    #[inline]
    pub fn sample_pdf(&self, x: i32, y: i32, frame: u32) -> f32 {
        self.sample_vector(x, y, frame).pdf
    }

    /// Fills `out[i]` with the vector at `(x0 + i, y, frame)` for every `i`: exactly what
    /// [`sample_vec2`](Self::sample_vec2) / [`sample_vec3`](Self::sample_vec3) /
    /// [`sample_vec4`](Self::sample_vec4) / [`sample_vector`](Self::sample_vector) return
    /// there, for an `out` of [`Vec2`] / [`Vec3`] / [`Vec4`] / [`VectorSample`]. The x sum
    /// wraps exactly, so `out` may be longer than the width (the row repeats).
    ///
    /// Decodes runs of contiguous voxels in blocks, 2.4–7.1× faster than a call per voxel; a row
    /// longer than the width decodes one period and copies it over the rest (1080p rows of a
    /// 128-wide mask: 4.8–27× faster than a call per pixel; BENCHMARKS.md, "Runtime sampling").
    pub fn fill_vector_row<V: VectorOutput>(&self, x0: i32, y: i32, frame: u32, out: &mut [V]) {
        self.fill_vector_row_at(x0, y, frame, SampleOffset::ZERO, out);
    }

    /// Fills `out` with the vectors of frame `frame` (wrapped modulo depth) in row-major order,
    /// `out[y * width + x]` the vector at `(x, y, frame)` as
    /// [`fill_vector_row`](Self::fill_vector_row) writes it.
    ///
    /// Writes `min(out.len(), width * height)` values and returns that count, like
    /// [`fill_frame`](Self::fill_frame).
    pub fn fill_vector_frame<V: VectorOutput>(&self, frame: u32, out: &mut [V]) -> usize {
        self.fill_vector_frame_at(frame, SampleOffset::ZERO, out)
    }

    /// The vector at `(x + o.x, y + o.y, frame + o.frame)` as `V`: behind every per-sample
    /// vector method.
    ///
    /// Inlined whole. The output's [hot plans](Hot) come first, each with each encoding one
    /// well-predicted compare of a key (plan and encoding) and then straight-line code (against
    /// a compare of the plan and a match on the encoding: Vec2 per 1080p frame 2.6 → 2.3 ms
    /// for Unorm8, 2.3 → 1.7 ms for F32); every other plan takes the full dispatch on the plan.
    /// The fields a hot read needs are read before any branch, so that a caller's pixel loop
    /// keeps them in registers (read inside the branches, or with an out-of-line call for the
    /// other plans in the loop, they were reloaded every sample: up to 2.8× slower per sample).
    #[inline(always)]
    pub(crate) fn vector_at<V: VectorOutput>(
        &self,
        x: i32,
        y: i32,
        frame: u32,
        o: SampleOffset,
    ) -> V {
        // `V::HOT` is a constant: only the tests of this output's hot plans remain.
        let hot = self.plan.hot;
        // Meaningful only for a hot plan (all axes powers of two); reading it is harmless.
        let number = self.voxel_number_pow2(x, y, frame, o);
        let (data, encoding) = (self.data(), self.encoding());
        let visitor = |voxel, encoding| VoxelVisitor {
            data,
            encoding,
            mask: self,
            voxel,
            output: PhantomData,
        };
        // The plan and the encoding in one key, so that each hot read is one compare away from
        // straight-line code for its encoding.
        let key = |hot: Hot, encoding: Encoding| (hot as u8) << 2 | encoding as u8;
        let mask_key = key(hot, encoding);
        macro_rules! hot_reads {
            ($($plan:ident, $t:ty, $c:literal;)*) => {
                $(
                    if V::HOT & Hot::$plan.bit() != 0 {
                        for e in [Encoding::Unorm8, Encoding::Unorm16, Encoding::F32] {
                            if mask_key == key(Hot::$plan, e) {
                                return visitor(number * $c, e).visit::<$t, $c, $c>();
                            }
                        }
                    }
                )*
            };
        }
        hot_reads! {
            Identity2, Identity, 2;
            Identity4, Identity, 4;
            Octahedral2, Octahedral, 2;
            Normalise3, Normalise, 3;
        }
        self.plan
            .dispatch(visitor(self.voxel(x, y, frame, o), encoding))
    }

    /// [`fill_vector_row`](Self::fill_vector_row) at `(x0 + o.x, y + o.y, frame + o.frame)`.
    pub(crate) fn fill_vector_row_at<V: VectorOutput>(
        &self,
        x0: i32,
        y: i32,
        frame: u32,
        o: SampleOffset,
        out: &mut [V],
    ) {
        self.row_runs(x0, y, frame, o, out, |first, run| {
            self.fill_vector_run(first, run);
        });
    }

    /// [`fill_vector_frame`](Self::fill_vector_frame) at offset `o`, which must be wrapped (as
    /// [`add_offsets`](Self::add_offsets) returns it).
    pub(crate) fn fill_vector_frame_at<V: VectorOutput>(
        &self,
        frame: u32,
        o: SampleOffset,
        out: &mut [V],
    ) -> usize {
        self.frame_runs(frame, o, out, |first, run| {
            self.fill_vector_run(first, run);
        })
    }

    /// Decodes the run of contiguous voxels starting at channel-0 element `first` into `out`,
    /// with AVX2 where the CPU has it ([`wide`](crate::wide)).
    #[inline]
    pub(crate) fn fill_vector_run<V: VectorOutput>(&self, first: usize, out: &mut [V]) {
        #[cfg(target_arch = "x86_64")]
        if crate::wide::has_avx2() {
            // SAFETY: the CPU runs AVX2 code (checked just above), all that
            // `fill_vector_run_avx2` requires.
            #[allow(unsafe_code)]
            unsafe {
                self.fill_vector_run_avx2(first, out);
            }
            return;
        }
        self.fill_vector_run_portable(first, out);
    }

    /// [`fill_vector_run`](Self::fill_vector_run) compiled for the target's baseline.
    #[inline(never)]
    fn fill_vector_run_portable<V: VectorOutput>(&self, first: usize, out: &mut [V]) {
        self.plan.dispatch(RunVisitor::<V, false> {
            mask: self,
            first,
            out,
        });
    }

    /// [`fill_vector_run`](Self::fill_vector_run) compiled with AVX2: the same operations, 8
    /// lanes wide.
    ///
    /// # Safety
    /// The CPU must run AVX2 code ([`has_avx2`](crate::wide::has_avx2)).
    #[cfg(target_arch = "x86_64")]
    #[allow(unsafe_code)]
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    unsafe fn fill_vector_run_avx2<V: VectorOutput>(&self, first: usize, out: &mut [V]) {
        self.plan.dispatch(RunVisitor::<V, true> {
            mask: self,
            first,
            out,
        });
    }

    /// The output for `value`, the value of the voxel whose `S` elements start at element
    /// `voxel`.
    #[inline(always)]
    fn vector_output<V: VectorOutput, const S: usize>(&self, value: [f32; 4], voxel: usize) -> V {
        let pdf = if V::NEEDS_PDF {
            self.vector_pdf::<S>(voxel, value)
        } else {
            0.0
        };
        V::from_value(value, pdf)
    }

    /// The pdf of `value`, the value of the voxel whose `S` elements start at `voxel`.
    #[inline(always)]
    fn vector_pdf<const S: usize>(&self, voxel: usize, value: [f32; 4]) -> f32 {
        match self.plan.pdf {
            Pdf::Constant(pdf) => pdf,
            Pdf::Cosine => value[2].max(0.0) / PI,
            Pdf::Stored => {
                let header = self.header();
                let t = self.element_full_range(voxel + S - 1);
                // t in [0, 1], so the result lies in [pdf_min, pdf_max] (both finite, >= 0).
                (header.pdf_min + t * (header.pdf_max - header.pdf_min)).max(0.0)
            }
        }
    }
}

/// Decodes the single voxel whose channel-0 element index is `voxel`.
struct VoxelVisitor<'s, 'a, V> {
    mask: &'s Stbn<'a>,
    /// The mask's [`data`](Stbn::data) and [`encoding`](Stbn::encoding).
    data: &'a [u8],
    encoding: Encoding,
    voxel: usize,
    output: PhantomData<fn() -> V>,
}

impl<V: VectorOutput> PlanVisitor for VoxelVisitor<'_, '_, V> {
    type Out = V;
    #[inline(always)]
    fn visit<T: ValueTransform, const C: usize, const S: usize>(self) -> V {
        let data = self.data;
        let i = self.voxel;
        let mut u = [0.0; 4];
        // The voxel's elements are in bounds (see `voxel`). Matching the encoding here makes
        // each slice a constant length: one bounds check, then straight-line code.
        let encoding = self.encoding;
        let bytes = match encoding {
            Encoding::Unorm8 => &data[i..i + C],
            Encoding::Unorm16 => &data[2 * i..2 * (i + C)],
            Encoding::F32 => &data[4 * i..4 * (i + C)],
        };
        decode_elements(encoding, bytes, &mut u[..C]);
        let value = voxel_value::<T, C>(u);
        self.mask.vector_output::<V, S>(value, i)
    }
}

/// Decodes a run of contiguous voxels, the first with channel-0 element index `first`, into
/// `out`: the steps of [`voxel_value`], so the same bits, in loops LLVM vectorises, block by
/// block in passes: the element conversion, the values before normalisation, then (for unit
/// values) their [`unit_scale`]s with the outputs. Identity-mapped values whose channels are the
/// output's components (Vec2, Vec3, Vec4 masks into their own type) skip that: the element
/// conversion writes each output's `f32`s, voxel by voxel (1080p Vec4 Unorm8 rows a mask width
/// at a time: 2.2 → 4.0 G samples/s; converting blocks into a buffer and copying them to the
/// outputs measured 1.3–4.7× slower than this). With `ONE_PASS` (the AVX2 build), the other values without scaling (signed
/// maps, a pdf channel, an output of another width) take one pass instead ([`fill_unscaled`]),
/// measured on Vec2 Unorm8 rows per voxel: 0.25 against 0.45 ms per 1080p frame in blocks;
/// without AVX2 one pass measured 1.8 against 0.75 ms, and for unit values up to 15% slower in
/// either build.
struct RunVisitor<'s, 'a, 'o, V, const ONE_PASS: bool> {
    mask: &'s Stbn<'a>,
    first: usize,
    out: &'o mut [V],
}

/// The run of [`RunVisitor`] for a transform without scaling (`!T::UNIT`), whose elements are
/// `BPE` bytes each (the mask's encoding): one pass, each voxel decoded from its `S · BPE`
/// bytes, the operations of [`voxel_value`].
#[inline(always)]
fn fill_unscaled<
    T: ValueTransform,
    V: VectorOutput,
    const C: usize,
    const S: usize,
    const BPE: usize,
>(
    mask: &Stbn<'_>,
    first: usize,
    bytes: &[u8],
    out: &mut [V],
) {
    let encoding = mask.encoding();
    for (i, (o, q)) in out.iter_mut().zip(bytes.chunks_exact(S * BPE)).enumerate() {
        let mut u = [0.0; 4];
        decode_elements(encoding, &q[..C * BPE], &mut u[..C]);
        let value = T::value::<C>(u);
        *o = mask.vector_output::<V, S>(value, first + i * S);
    }
}

impl<V: VectorOutput, const ONE_PASS: bool> PlanVisitor for RunVisitor<'_, '_, '_, V, ONE_PASS> {
    type Out = ();
    #[inline(always)]
    fn visit<T: ValueTransform, const C: usize, const S: usize>(self) {
        let mask = self.mask;
        let encoding = mask.encoding();
        let bpe = encoding.bytes_per_element();
        // The run's bytes, for the two single-loop paths (the blocks below slice their own).
        let bytes = &mask.data()[self.first * bpe..(self.first + self.out.len() * S) * bpe];
        // Stored values kept as they are, every channel a component of the output (a glam
        // vector of `C` components, no pdf): each voxel's `C` elements converted straight into
        // its output's components, one loop per encoding so that each voxel's bytes are a
        // constant-length chunk.
        if T::IDENTITY && C == S && !V::NEEDS_PDF && size_of::<V>() == 4 * C {
            let out = self.out.iter_mut();
            match encoding {
                Encoding::Unorm8 => {
                    for (o, q) in out.zip(bytes.chunks_exact(C)) {
                        decode_elements(Encoding::Unorm8, q, o.components_mut());
                    }
                }
                Encoding::Unorm16 => {
                    for (o, q) in out.zip(bytes.chunks_exact(2 * C)) {
                        decode_elements(Encoding::Unorm16, q, o.components_mut());
                    }
                }
                Encoding::F32 => {
                    for (o, q) in out.zip(bytes.chunks_exact(4 * C)) {
                        decode_elements(Encoding::F32, q, o.components_mut());
                    }
                }
            }
            return;
        }
        if !T::UNIT && ONE_PASS {
            // One loop per encoding, so that each voxel's bytes are a constant-length chunk.
            let out = self.out;
            let first = self.first;
            match encoding {
                Encoding::Unorm8 => fill_unscaled::<T, V, C, S, 1>(mask, first, bytes, out),
                Encoding::Unorm16 => fill_unscaled::<T, V, C, S, 2>(mask, first, bytes, out),
                Encoding::F32 => fill_unscaled::<T, V, C, S, 4>(mask, first, bytes, out),
            }
            return;
        }
        let mut elements = [0.0f32; 4 * FILL_BLOCK];
        // The block's values before normalisation, one array per component.
        let mut xs = [0.0f32; FILL_BLOCK];
        let mut ys = [0.0f32; FILL_BLOCK];
        let mut zs = [0.0f32; FILL_BLOCK];
        let mut ws = [0.0f32; FILL_BLOCK];
        for (k, block) in self.out.chunks_mut(FILL_BLOCK).enumerate() {
            let first = self.first + k * FILL_BLOCK * S;
            let elements = &mut elements[..block.len() * S];
            let len = elements.len();
            decode_elements(
                encoding,
                &mask.data()[first * bpe..(first + len) * bpe],
                elements,
            );
            if !T::UNIT {
                // Nothing to scale: one pass over the decoded elements.
                for (i, (o, e)) in block.iter_mut().zip(elements.chunks_exact(S)).enumerate() {
                    let mut u = [0.0; 4];
                    u[..C].copy_from_slice(&e[..C]);
                    let value = T::value::<C>(u);
                    *o = mask.vector_output::<V, S>(value, first + i * S);
                }
                continue;
            }
            for ((((e, x), y), z), w) in elements
                .chunks_exact(S)
                .zip(&mut xs)
                .zip(&mut ys)
                .zip(&mut zs)
                .zip(&mut ws)
            {
                let mut u = [0.0; 4];
                u[..C].copy_from_slice(&e[..C]);
                let v = T::value::<C>(u);
                [*x, *y, *z] = [v[0], v[1], v[2]];
                // Below 4 value channels the fourth component is 0 (octahedral values have 2
                // channels and 3 components): neither stored nor read.
                if C == 4 {
                    *w = v[3];
                }
            }
            for (i, ((((o, x), y), z), w)) in block
                .iter_mut()
                .zip(&xs)
                .zip(&ys)
                .zip(&zs)
                .zip(&ws)
                .enumerate()
            {
                let v = [*x, *y, *z, if C == 4 { *w } else { 0.0 }];
                let scale = unit_scale(v);
                let value = v.map(|c| c * scale);
                *o = mask.vector_output::<V, S>(value, first + i * S);
            }
        }
    }
}

impl OffsetStbn<'_> {
    /// [`Stbn::sample_vector`] at the offset position: the vector and its pdf.
    #[must_use]
    #[inline]
    pub fn sample_vector(&self, x: i32, y: i32, frame: u32) -> VectorSample {
        self.mask.vector_at(x, y, frame, self.offset_at(frame))
    }

    /// [`Stbn::sample_vec2`] at the offset position: the first two components.
    #[must_use]
    #[inline]
    pub fn sample_vec2(&self, x: i32, y: i32, frame: u32) -> Vec2 {
        self.mask.vector_at(x, y, frame, self.offset_at(frame))
    }

    /// [`Stbn::sample_vec3`] at the offset position: the first three components.
    #[must_use]
    #[inline]
    pub fn sample_vec3(&self, x: i32, y: i32, frame: u32) -> Vec3 {
        self.mask.vector_at(x, y, frame, self.offset_at(frame))
    }

    /// [`Stbn::sample_vec4`] at the offset position: all four components.
    #[must_use]
    #[inline]
    pub fn sample_vec4(&self, x: i32, y: i32, frame: u32) -> Vec4 {
        self.mask.vector_at(x, y, frame, self.offset_at(frame))
    }

    /// [`Stbn::sample_pdf`] at the offset position (see [`VectorSample::pdf`]).
    #[must_use]
    #[inline]
    pub fn sample_pdf(&self, x: i32, y: i32, frame: u32) -> f32 {
        self.sample_vector(x, y, frame).pdf
    }

    /// [`Stbn::fill_vector_row`] at the offset position: `out[i]` is the vector at
    /// `(x0 + i, y, frame)` of this view.
    pub fn fill_vector_row<V: VectorOutput>(&self, x0: i32, y: i32, frame: u32, out: &mut [V]) {
        self.mask
            .fill_vector_row_at(x0, y, frame, self.offset_at(frame), out);
    }

    /// [`Stbn::fill_vector_frame`] at the offset position: `out[y * width + x]` is the vector at
    /// `(x, y, frame)` of this view; writes `min(out.len(), width * height)` values and returns
    /// that count.
    pub fn fill_vector_frame<V: VectorOutput>(&self, frame: u32, out: &mut [V]) -> usize {
        self.mask
            .fill_vector_frame_at(frame, self.sample_offset_at(frame), out)
    }
}

impl Pdf {
    /// How the pdf of a validated header's values is found: stored for image spaces, derived
    /// from the space otherwise (see [`Space`]).
    const fn new(header: &MaskHeader) -> Self {
        match header.space {
            Space::Scalar => Pdf::Constant(1.0),
            Space::Vec => match header.value_map {
                // Uniform on [-1, 1]^n: density 2^-n.
                ValueMap::Signed => {
                    let dims = if header.dims() < 4 { header.dims() } else { 4 };
                    Pdf::Constant(1.0 / (1u8 << dims) as f32)
                }
                _ => Pdf::Constant(1.0),
            },
            Space::UnitVec => Pdf::Constant(match header.dims() {
                1 => 0.5,
                2 => 1.0 / (2.0 * PI),
                _ => 1.0 / (4.0 * PI),
            }),
            Space::UniformHemisphere => Pdf::Constant(1.0 / (2.0 * PI)),
            Space::CosineHemisphere => Pdf::Cosine,
            Space::ImagePoints | Space::EnvironmentDirections => Pdf::Stored,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::MaskHeader;

    #[test]
    fn octahedral_round_trips_on_a_sphere_grid() {
        for i in 0..64 {
            for j in 0..128 {
                let theta = (i as f32 + 0.5) / 64.0 * PI;
                let phi = j as f32 / 128.0 * 2.0 * PI;
                let n = Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                );
                let e = octahedral_encode(n);
                assert!(e.x.abs() <= 1.0 && e.y.abs() <= 1.0);
                let back = octahedral_decode(e);
                assert!((back - n).length() < 1e-5, "{n} -> {e} -> {back}");
            }
        }
    }

    #[test]
    fn unit_scale_is_the_rounded_reciprocal_of_the_rounded_root() {
        // Every squared length a Unorm or F32 unit-vector mask can produce lies in [2^-48, 4]
        // (or is 0, which the normalisation skips); f32 patterns in that range, in steps.
        let (lo, hi) = ((-48.0f32).exp2().to_bits(), 4.0f32.to_bits());
        let mut worst = 0.0f64;
        for bits in (lo..=hi).step_by(1021).chain([hi]) {
            let d = f32::from_bits(bits);
            let scale = scale_of_squared_length(d);
            assert_eq!(scale, 1.0 / (f64::from(d).sqrt() as f32), "{d:e}");
            let exact = 1.0 / f64::from(d).sqrt();
            worst = worst.max((f64::from(scale) - exact).abs() / exact);
        }
        assert!(worst < 1.2e-7, "{worst}");
        assert_eq!(scale_of_squared_length(1.0), 1.0);
        assert_eq!(scale_of_squared_length(0.0), 1.0);
    }

    /// The AVX2 build of the fills gives the portable build's bits, for every transform, pdf
    /// and encoding, over runs long enough for whole 8-lane blocks and their remainders.
    #[test]
    #[cfg(target_arch = "x86_64")]
    fn avx2_fills_match_the_portable_build() {
        use crate::{Encoding, Space};
        if !crate::wide::has_avx2() {
            extern crate std;
            std::eprintln!("no AVX2 on this CPU: the AVX2 build is not compared");
            return;
        }
        let layouts = [
            (Space::Vec, ValueMap::Unit, 2, 0.0, 0.0),
            (Space::Vec, ValueMap::Signed, 4, 0.0, 0.0),
            (Space::UnitVec, ValueMap::Signed, 3, 0.0, 0.0),
            (Space::UnitVec, ValueMap::Octahedral, 2, 0.0, 0.0),
            (Space::CosineHemisphere, ValueMap::Octahedral, 2, 0.0, 0.0),
            (Space::ImagePoints, ValueMap::Unit, 3, 0.25, 8.0),
            (Space::EnvironmentDirections, ValueMap::Signed, 4, 0.5, 3.0),
        ];
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        for (space, map, channels, pdf_min, pdf_max) in layouts {
            for encoding in [Encoding::Unorm8, Encoding::Unorm16, Encoding::F32] {
                let header = MaskHeader::new(77, 3, 2, channels, encoding)
                    .with_space(space, map, pdf_min, pdf_max);
                // Room for the largest payload: 4 `f32` channels.
                let data: [u8; 77 * 3 * 2 * 4 * 4] = core::array::from_fn(|i| {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    // F32 elements in [0, 1) (exponent byte below 0x3f), Unorm ones anything.
                    match encoding {
                        Encoding::F32 if i % 4 == 3 => (state as u8) % 0x3f,
                        _ => state as u8,
                    }
                });
                let data = &data[..header.decoded_len()];
                let mask = Stbn::from_parts(header, data);
                let voxels = (77 * 3 * 2) as usize;
                for (first, len) in [(0, voxels), (5, 70), (77, 31), (100, 1)] {
                    let start = first * usize::from(channels);
                    let mut portable = [VectorSample {
                        value: Vec4::splat(9.0),
                        pdf: 9.0,
                    }; 77 * 3 * 2];
                    let mut wide = portable;
                    mask.fill_vector_run_portable(start, &mut portable[..len]);
                    // SAFETY: the CPU runs AVX2 code (checked above).
                    #[allow(unsafe_code)]
                    unsafe {
                        mask.fill_vector_run_avx2(start, &mut wide[..len]);
                    }
                    for (p, w) in portable.iter().zip(&wide) {
                        let bits = |v: &VectorSample| {
                            (v.value.to_array().map(f32::to_bits), v.pdf.to_bits())
                        };
                        assert_eq!(bits(p), bits(w), "{header:?} run {first}+{len}");
                    }
                }
            }
        }
    }

    #[test]
    fn octahedral_decode_is_unit_everywhere() {
        for i in 0..=40 {
            for j in 0..=40 {
                let e = Vec2::new(i as f32 / 20.0 - 1.0, j as f32 / 20.0 - 1.0);
                let n = octahedral_decode(e);
                assert!((n.length() - 1.0).abs() < 1e-6, "{e} -> {n}");
            }
        }
        // The poles and the corners.
        assert_eq!(octahedral_decode(Vec2::ZERO), Vec3::Z);
        assert!((octahedral_decode(Vec2::new(1.0, 1.0)) - Vec3::NEG_Z).length() < 1e-6);
        assert!((octahedral_decode(Vec2::new(-1.0, -1.0)) - Vec3::NEG_Z).length() < 1e-6);
    }
}
