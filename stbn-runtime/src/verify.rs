//! What a verified mask promises, and the checks behind it: [`Stbn::verify`], run by every
//! verified constructor and by decoding.
//!
//! The checks run once, when a view is built, so sampling stays the stored data's arithmetic with
//! no per-sample guard, and the WGSL snippet returns the same values as the CPU. Unorm elements
//! are in `(0, 1)` by construction; F32 elements can be anything, so they are checked. Directions
//! are checked voxel by voxel through the vector fills, whose bits are the per-sample reads'.

use glam::Vec4;

use crate::{Encoding, Error, Space, Stbn, ValueMap};

/// How far from 1 the length of a direction a verified mask returns may be: `1e-6`. Every
/// voxel of a unit-vector space is decoded as the samplers decode it and checked against this
/// once; the normalisation's steps are each correctly rounded, so every direction the stored
/// components can hold, but the zero vector, passes.
pub const UNIT_LENGTH_TOLERANCE: f32 = 1e-6;

/// Voxels (or F32 elements) checked per block, the directions decoded on the stack (4 KiB).
const CHECK_BLOCK: usize = 256;

/// Whether `v`'s length is certainly within [`UNIT_LENGTH_TOLERANCE`] of 1: its squared length,
/// summed in `f32` (so that the check vectorises), inside the squared bounds narrowed by
/// [`SQUARED_LENGTH_ERROR`]. A NaN fails the comparisons.
#[inline(always)]
fn is_unit(v: Vec4) -> bool {
    const TOLERANCE: f32 = UNIT_LENGTH_TOLERANCE;
    // (1 ± t)² = 1 ± 2t + t²; t² (1e-12) is below f32's resolution at 1 and only widens the
    // true range, so leaving it out keeps the bounds inside it.
    const LOW: f32 = 1.0 - 2.0 * TOLERANCE + SQUARED_LENGTH_ERROR;
    const HIGH: f32 = 1.0 + 2.0 * TOLERANCE - SQUARED_LENGTH_ERROR;
    let squared = v.x * v.x + v.y * v.y + v.z * v.z + v.w * v.w;
    (LOW..=HIGH).contains(&squared)
}

/// A bound on the rounding of [`is_unit`]'s squared length near 1: four products and three sums,
/// each off by at most half an ulp (2^-24) of a value below 1.000002, about 4.2e-7 in all; with
/// the rounding of the bounds themselves, 5e-7.
const SQUARED_LENGTH_ERROR: f32 = 5e-7;

impl Stbn<'_> {
    /// Checks what [`Stbn::from_bytes`] checks of the payload: that [`data`](Self::data) matches
    /// the header's `payload_crc32` and that every value keeps the promises of the samplers:
    ///
    /// * every F32 element is a finite number in `[0, 1]` (so values are in `[0, 1]`, signed
    ///   components in `[-1, 1]`, and the pdf channel between `pdf_min` and `pdf_max`; Unorm
    ///   elements always are, as bin midpoints in `(0, 1)`);
    /// * every voxel of a unit-vector space decodes to a vector whose length is within
    ///   [`UNIT_LENGTH_TOLERANCE`] of 1, with `z >= 0` for the two hemisphere spaces.
    ///
    /// A view from [`from_bytes`](Self::from_bytes), [`PackedStbn::from_bytes`]'s
    /// [`view`](crate::PackedStbn::view), [`PackedStbn::decode_into`] or `PackedStbn::decode` has
    /// passed these checks. One from [`from_bytes_unverified`](Self::from_bytes_unverified) (what
    /// [`include_stbn!`](crate::include_stbn) embeds) has not: call this once, e.g. in a test,
    /// for a blob the build did not just write.
    ///
    /// [`PackedStbn::from_bytes`]: crate::PackedStbn::from_bytes
    /// [`PackedStbn::decode_into`]: crate::PackedStbn::decode_into
    ///
    /// # Errors
    /// [`Error::PayloadChecksum`] if the CRC does not match; [`Error::InvalidValue`], naming the
    /// first offending voxel (and channel), if a value breaks a promise.
    pub fn verify(&self) -> Result<(), Error> {
        if crc32fast::hash(self.data()) != self.header().payload_crc32 {
            return Err(Error::PayloadChecksum);
        }
        self.check_values()
    }

    /// The value checks of [`verify`](Self::verify), without the CRC.
    pub(crate) fn check_values(&self) -> Result<(), Error> {
        let header = *self.header();
        if header.encoding == Encoding::F32 {
            self.check_f32_elements()?;
        }
        if header.space.is_unit() {
            self.check_directions()?;
        }
        Ok(())
    }

    /// Every F32 element finite and in `[0, 1]`.
    fn check_f32_elements(&self) -> Result<(), Error> {
        let header = self.header();
        // NaN fails both comparisons, so it is caught with the infinities and the range.
        let in_range = |bytes: &[u8]| {
            let v = f32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]);
            (0.0..=1.0).contains(&v)
        };
        // A branch-free pass per block (it vectorises), then a search in the block that fails.
        let bad = self
            .data()
            .chunks(4 * CHECK_BLOCK)
            .enumerate()
            .find(|(_, block)| !block.chunks_exact(4).fold(true, |ok, e| ok & in_range(e)))
            .and_then(|(k, block)| {
                let within = block.chunks_exact(4).position(|e| !in_range(e))?;
                Some(k * CHECK_BLOCK + within)
            });
        let Some(element) = bad else {
            return Ok(());
        };
        let channels = usize::from(header.channels);
        let channel = element % channels;
        let reason = if header.space.stores_pdf() && channel == channels - 1 {
            "the F32 pdf channel must be a finite number in [0, 1] (the pdf from pdf_min to pdf_max)"
        } else if header.value_map == ValueMap::Unit {
            "an F32 unit value must be a finite number in [0, 1]"
        } else {
            "an F32 stored component must be a finite number in [0, 1] (the component 2u - 1 in \
             [-1, 1])"
        };
        // channel < channels <= 4.
        Err(self.invalid_at(element / channels, Some(channel as u8), reason))
    }

    /// Every voxel a unit vector, above the horizon for a hemisphere.
    fn check_directions(&self) -> Result<(), Error> {
        let hemisphere = matches!(
            self.space(),
            Space::UniformHemisphere | Space::CosineHemisphere
        );
        let channels = usize::from(self.channels());
        let voxels = self.header().element_count() / channels;
        let mut block = [Vec4::ZERO; CHECK_BLOCK];
        let mut first = 0;
        while first < voxels {
            let out = &mut block[..(voxels - first).min(CHECK_BLOCK)];
            self.fill_vector_run(first * channels, out);
            // A branch-free pass over the block (it vectorises), then a search in one that
            // fails.
            let bad: u32 = out
                .iter()
                .map(|v| u32::from(!is_unit(*v)) | u32::from(hemisphere & (v.z < 0.0)))
                .sum();
            if bad == 0 {
                first += out.len();
                continue;
            }
            for (k, v) in out.iter().enumerate() {
                if !is_unit(*v) {
                    return Err(self.invalid_at(
                        first + k,
                        None,
                        "the stored components are zero or too small to normalise: a direction \
                         must decode to unit length (within 1e-6)",
                    ));
                }
                if hemisphere && v.z < 0.0 {
                    return Err(self.invalid_at(
                        first + k,
                        None,
                        "a hemisphere direction must decode to z >= 0; this one is below the \
                         horizon",
                    ));
                }
            }
            first += out.len();
        }
        Ok(())
    }

    /// [`Error::InvalidValue`] at voxel number `voxel` (`(frame · height + y) · width + x`).
    fn invalid_at(&self, voxel: usize, channel: Option<u8>, reason: &'static str) -> Error {
        let (width, height) = (self.width() as usize, self.height() as usize);
        // Each coordinate is below its axis length <= MAX_DECODED_BYTES = 2^31.
        Error::InvalidValue {
            x: (voxel % width) as u32,
            y: (voxel / width % height) as u32,
            frame: (voxel / (width * height)) as u32,
            channel,
            reason,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `is_unit` accepts only lengths within the tolerance (checked in f64 on vectors swept
    /// across both bounds), and accepts every vector the normalisation produces.
    #[test]
    fn the_unit_check_is_sound_and_passes_normalised_vectors() {
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
        };
        let tolerance = f64::from(UNIT_LENGTH_TOLERANCE);
        let (mut accepted, mut refused) = (0, 0);
        for i in 0..200_000 {
            let v = Vec4::new(
                next(),
                next(),
                next(),
                if i % 2 == 0 { next() } else { 0.0 },
            );
            if v.length_squared() < 1e-6 {
                continue;
            }
            let unit = v / v.length();
            assert!(is_unit(unit), "{unit}: length {}", unit.length());
            // Scaled across the bounds: 1 ± 3e-6 in steps of about 2e-8.
            let scaled = unit * (1.0 + (i % 300) as f32 * 2e-8 - 3e-6);
            let length = scaled
                .to_array()
                .map(f64::from)
                .iter()
                .map(|c| c * c)
                .sum::<f64>()
                .sqrt();
            if is_unit(scaled) {
                assert!((length - 1.0).abs() <= tolerance, "{scaled}: {length}");
                accepted += 1;
            } else {
                refused += 1;
            }
        }
        assert!(
            accepted > 10_000 && refused > 10_000,
            "{accepted} {refused}"
        );
        for v in [
            Vec4::ZERO,
            Vec4::NAN,
            Vec4::new(1e-20, 0.0, 0.0, 0.0),
            Vec4::X * 2.0,
        ] {
            assert!(!is_unit(v), "{v}");
        }
    }
}
