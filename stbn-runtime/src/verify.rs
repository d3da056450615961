//! What a verified mask promises, and the checks behind it: [`Stbn::verify`], run by every
//! verified constructor and by decoding.
//!
//! The checks run once, when a view is built, so sampling stays the stored data's arithmetic with
//! no per-sample guard, and the WGSL snippet returns the same values as the CPU. Unorm elements
//! are in `(0, 1)` by construction; F32 elements can be anything, so they are checked. Directions
//! are checked voxel by voxel through the vector fills, whose bits are the per-sample reads'.

use glam::Vec4;

use crate::{Encoding, Error, Space, Stbn, ValueMap};

/// How far from 1 the length of a direction a verified mask returns may be: `1e-6`. The
/// normalisation's steps are each correctly rounded, so the samplers stay within a few units in
/// the last place of 1 (about `2.4e-7`) on every direction that passes the check.
pub const UNIT_LENGTH_TOLERANCE: f32 = 1e-6;

/// Voxels decoded per block by the direction check, on the stack (4 KiB).
const CHECK_BLOCK: usize = 256;

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
        let bad = self.data().chunks_exact(4).position(|bytes| {
            let v = f32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]);
            !(0.0..=1.0).contains(&v)
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
            for (k, v) in out.iter().enumerate() {
                // The squared length in f64, against the squared bounds, so that the check adds
                // no rounding worth speaking of (and needs no square root in `core`). A NaN
                // fails the comparisons too.
                let squared = v
                    .to_array()
                    .map(f64::from)
                    .iter()
                    .map(|c| c * c)
                    .sum::<f64>();
                let tolerance = f64::from(UNIT_LENGTH_TOLERANCE);
                let (low, high) = (
                    (1.0 - tolerance) * (1.0 - tolerance),
                    (1.0 + tolerance) * (1.0 + tolerance),
                );
                let unit = (low..=high).contains(&squared);
                if !unit {
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
