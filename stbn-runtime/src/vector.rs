//! Vector sampling: [`VectorSample`], the value maps applied to several channels, octahedral
//! decoding and the pdf of every [`Space`].

use core::f32::consts::PI;

use glam::{Vec2, Vec3, Vec4};

use crate::{OffsetStbn, SampleOffset, Space, Stbn, ValueMap};

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
/// corners and the fold lines.
#[must_use]
pub fn octahedral_decode(e: Vec2) -> Vec3 {
    let z = 1.0 - e.x.abs() - e.y.abs();
    // The lower hemisphere (z < 0) was folded over the diagonals: unfold it without a branch
    // (the fold is a coin flip per sample, and a mispredicted branch cost more than this):
    // x − t·sign(x) with t = max(−z, 0) is (1 − |y|)·sign(x) where z < 0 and x elsewhere.
    let t = (-z).max(0.0);
    let x = e.x - t * sign_not_zero(e.x);
    let y = e.y - t * sign_not_zero(e.y);
    // |x| + |y| + |z| >= 1 whatever the input, so the length is never zero.
    Vec3::new(x, y, z).normalize()
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
fn sign_not_zero(v: f32) -> f32 {
    // 1.0 with v's sign bit, except that -0.0 gives 1.0 like +0.0.
    let negative = u32::from(v < 0.0) << 31;
    f32::from_bits(1.0f32.to_bits() | negative)
}

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
    // Not `#[inline]`: inlined into a caller's pixel loop it measures slower (BENCHMARKS.md).
    #[must_use]
    pub fn sample_vector(&self, x: i32, y: i32, frame: u32) -> VectorSample {
        self.vector_at(self.voxel(x, y, frame, SampleOffset::ZERO))
    }

    /// The first two components at `(x, y, frame)` (see [`sample_vector`](Self::sample_vector)).
    #[must_use]
    #[inline]
    pub fn sample_vec2(&self, x: i32, y: i32, frame: u32) -> Vec2 {
        self.sample_vec4(x, y, frame).truncate().truncate()
    }

    /// The first three components at `(x, y, frame)`: a unit vector for direction masks.
    #[must_use]
    #[inline]
    pub fn sample_vec3(&self, x: i32, y: i32, frame: u32) -> Vec3 {
        self.sample_vec4(x, y, frame).truncate()
    }

    /// All four components at `(x, y, frame)` (the value of
    /// [`sample_vector`](Self::sample_vector), without the pdf).
    #[must_use]
    #[inline]
    pub fn sample_vec4(&self, x: i32, y: i32, frame: u32) -> Vec4 {
        self.vector_value(self.voxel(x, y, frame, SampleOffset::ZERO))
    }

    /// The pdf of the value at `(x, y, frame)` (see [`VectorSample::pdf`]).
    #[must_use]
    #[inline]
    pub fn sample_pdf(&self, x: i32, y: i32, frame: u32) -> f32 {
        self.sample_vector(x, y, frame).pdf
    }

    /// The value at `voxel` (a channel-0 element index) with its pdf.
    #[inline]
    fn vector_at(&self, voxel: usize) -> VectorSample {
        let value = self.vector_value(voxel);
        VectorSample {
            value,
            pdf: self.vector_pdf(voxel, value),
        }
    }

    /// The value stored at `voxel` (a channel-0 element index), mapped by the mask's
    /// [`ValueMap`] and normalised for unit-vector spaces.
    #[inline]
    fn vector_value(&self, voxel: usize) -> Vec4 {
        let header = self.header();
        let map = header.value_map;
        let mut raw = [0.0f32; 4];
        for (c, r) in raw
            .iter_mut()
            .enumerate()
            .take(usize::from(header.value_channels()))
        {
            *r = map.apply(self.element(voxel + c));
        }
        match map {
            ValueMap::Octahedral => octahedral_decode(Vec2::new(raw[0], raw[1])).extend(0.0),
            _ if header.space.is_unit() => normalise_or_keep(Vec4::from_array(raw)),
            _ => Vec4::from_array(raw),
        }
    }

    /// The pdf of `value`, the value at `voxel`: the stored channel or the space's density.
    #[inline]
    fn vector_pdf(&self, voxel: usize, value: Vec4) -> f32 {
        let header = self.header();
        if header.space.stores_pdf() {
            let t = self.element_full_range(voxel + usize::from(header.channels) - 1);
            // t in [0, 1], so the result lies in [pdf_min, pdf_max] (both finite, >= 0).
            (header.pdf_min + t * (header.pdf_max - header.pdf_min)).max(0.0)
        } else {
            derived_pdf(header.space, header.value_map, header.dims(), value)
        }
    }
}

impl OffsetStbn<'_> {
    /// [`Stbn::sample_vector`] at the offset position: the vector and its pdf.
    #[must_use]
    pub fn sample_vector(&self, x: i32, y: i32, frame: u32) -> VectorSample {
        self.mask
            .vector_at(self.mask.voxel(x, y, frame, self.offset))
    }

    /// [`Stbn::sample_vec2`] at the offset position: the first two components.
    #[must_use]
    #[inline]
    pub fn sample_vec2(&self, x: i32, y: i32, frame: u32) -> Vec2 {
        self.sample_vec4(x, y, frame).truncate().truncate()
    }

    /// [`Stbn::sample_vec3`] at the offset position: the first three components.
    #[must_use]
    #[inline]
    pub fn sample_vec3(&self, x: i32, y: i32, frame: u32) -> Vec3 {
        self.sample_vec4(x, y, frame).truncate()
    }

    /// [`Stbn::sample_vec4`] at the offset position: all four components.
    #[must_use]
    #[inline]
    pub fn sample_vec4(&self, x: i32, y: i32, frame: u32) -> Vec4 {
        self.mask
            .vector_value(self.mask.voxel(x, y, frame, self.offset))
    }

    /// [`Stbn::sample_pdf`] at the offset position (see [`VectorSample::pdf`]).
    #[must_use]
    #[inline]
    pub fn sample_pdf(&self, x: i32, y: i32, frame: u32) -> f32 {
        self.sample_vector(x, y, frame).pdf
    }
}

/// `v / |v|`, or `v` unchanged if it is zero (a quantised `±1` or circle value never is; the
/// guard keeps hand-made blobs from producing NaN).
fn normalise_or_keep(v: Vec4) -> Vec4 {
    if v.length_squared() > 0.0 {
        v.normalize()
    } else {
        v
    }
}

/// The pdf of spaces that do not store one, at `value` (already mapped and normalised).
fn derived_pdf(space: Space, map: ValueMap, dims: u8, value: Vec4) -> f32 {
    match space {
        Space::Scalar => 1.0,
        Space::Vec => match map {
            // Uniform on [-1, 1]^n: density 2^-n.
            ValueMap::Signed => 1.0 / f32::from(1u8 << dims.min(4)),
            _ => 1.0,
        },
        Space::UnitVec => match dims {
            1 => 0.5,
            2 => 1.0 / (2.0 * PI),
            _ => 1.0 / (4.0 * PI),
        },
        Space::UniformHemisphere => 1.0 / (2.0 * PI),
        Space::CosineHemisphere => value.z.max(0.0) / PI,
        // Parsing guarantees these store their pdf; keep the function total anyway.
        Space::ImagePoints | Space::EnvironmentDirections => 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
