//! Centred DFT magnitude images ([`analysis`] docs, "DFT images").
//!
//! [`analysis`]: crate::analysis#dft-images

use rayon::prelude::*;
use rustfft::FftPlanner;

use super::{Field, TASKS, add_slice_spectrum, sum_in_order};

/// A centred image of mean normalised DFT magnitudes ([module docs](crate::analysis#dft-images)).
#[derive(Clone, Debug, PartialEq)]
pub struct SpectrumImage {
    /// Columns: frequencies along the image's first axis (x).
    pub width: usize,
    /// Rows: frequencies along its second axis (y for XY, frames for XZ).
    pub height: usize,
    /// `width · height` magnitudes, row-major, DC at `(width / 2, height / 2)`. Dimensionless,
    /// `≥ 0`.
    pub values: Vec<f64>,
}

impl SpectrumImage {
    /// The magnitude a white pixel of [`SpectrumImage::to_gray8`] stands for: 2, about 2.26 times
    /// white noise's mean magnitude.
    pub const GRAY_FULL_SCALE: f64 = 2.0;

    /// The image as 8-bit grey levels on a fixed linear scale, the same for every mask: black = 0,
    /// white = [`SpectrumImage::GRAY_FULL_SCALE`] and above, so white noise is a flat mid-dark
    /// grey (level ≈ 113) and blue noise has a black centre.
    pub fn to_gray8(&self) -> Vec<u8> {
        self.values
            .iter()
            .map(|&m| {
                (m / Self::GRAY_FULL_SCALE * 255.0)
                    .round()
                    .clamp(0.0, 255.0) as u8
            })
            .collect()
    }

    /// The magnitude at the signed frequency `(fx, fy)` (cycles per image side), for `fx` in
    /// `−width/2..` and `fy` in `−height/2..` within one period. Panics outside the image.
    pub fn at(&self, fx: isize, fy: isize) -> f64 {
        let column = (fx + (self.width / 2) as isize).rem_euclid(self.width as isize) as usize;
        let row = (fy + (self.height / 2) as isize).rem_euclid(self.height as isize) as usize;
        self.values[row * self.width + column]
    }
}

/// The XY image: the 2D DFT magnitude of every slice, averaged over slices; `width × height`.
///
/// Deterministic for any thread count (slice chunks are summed in order).
pub fn dft_xy_image(field: &Field) -> SpectrumImage {
    let (w, h, d) = (field.width(), field.height(), field.depth());
    let images = (0..d).map(|z| field.slice(z).to_vec());
    mean_magnitude(images.collect(), w, h)
}

/// The XZ image: for every row `y`, the 2D DFT magnitude of the `width × depth` image
/// `v(x, y, z)` (x across, frame z down), averaged over rows; `width × depth`.
///
/// Deterministic for any thread count (row chunks are summed in order).
pub fn dft_xz_image(field: &Field) -> SpectrumImage {
    let (w, h, d) = (field.width(), field.height(), field.depth());
    let n = field.slice_pixels();
    let values = field.values();
    let images = (0..h).map(|y| {
        (0..d)
            .flat_map(|z| values[z * n + y * w..z * n + (y + 1) * w].iter().copied())
            .collect()
    });
    mean_magnitude(images.collect(), w, d)
}

/// The centred mean normalised magnitude of `images`, each `w × h` row-major.
fn mean_magnitude(images: Vec<Vec<f64>>, w: usize, h: usize) -> SpectrumImage {
    let mut planner = FftPlanner::<f64>::new();
    let fft_x = planner.plan_fft_forward(w);
    let fft_y = planner.plan_fft_forward(h);
    let count = images.len();
    let sum = sum_in_order(
        images.par_chunks(count.div_ceil(TASKS)).map(|chunk| {
            let mut sum = vec![0.0; w * h];
            for image in chunk {
                add_slice_spectrum(image, w, h, &*fft_x, &*fft_y, &mut sum, f64::sqrt);
            }
            sum
        }),
        w * h,
    );
    let mut values = vec![0.0; w * h];
    for fy in 0..h {
        for fx in 0..w {
            let (column, row) = ((fx + w / 2) % w, (fy + h / 2) % h);
            values[row * w + column] = sum[fy * w + fx] / count as f64;
        }
    }
    SpectrumImage {
        width: w,
        height: h,
        values,
    }
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use super::*;

    #[test]
    fn a_cosine_lights_exactly_its_two_frequencies() {
        // Every slice a cosine of (3, 1) cycles: all power at ±(3, 1), √P = √((n − 1)/2) there.
        let (w, h, d) = (16, 8, 3);
        let values: Vec<f64> = (0..w * h * d)
            .map(|i| {
                let (x, y) = ((i % w) as f64, ((i / w) % h) as f64);
                0.5 + 0.4 * (2.0 * PI * (3.0 * x / w as f64 + y / h as f64)).cos()
            })
            .collect();
        let field = Field::new(w, h, d, &values).unwrap();
        let image = dft_xy_image(&field);
        assert_eq!((image.width, image.height), (w, h));
        let peak = (((w * h - 1) as f64) / 2.0).sqrt();
        for fy in -4..4isize {
            for fx in -8..8isize {
                let expected = if (fx, fy) == (3, 1) || (fx, fy) == (-3, -1) {
                    peak
                } else {
                    0.0
                };
                assert!((image.at(fx, fy) - expected).abs() < 1e-9, "({fx}, {fy})");
            }
        }
        // Constant over time and along nothing else: the XZ image of each row is a cosine along
        // x (3 cycles) with a phase per row, constant over frames: power at (±3, 0) only.
        let xz = dft_xz_image(&field);
        assert_eq!((xz.width, xz.height), (w, d));
        let row_peak = (((w * d - 1) as f64) / 2.0).sqrt();
        assert!((xz.at(3, 0) - row_peak).abs() < 1e-9);
        assert!((xz.at(-3, 0) - row_peak).abs() < 1e-9);
        assert!(xz.at(0, 1).abs() < 1e-9 && xz.at(3, 1).abs() < 1e-9);
        assert_eq!(xz.at(0, 0), 0.0);
    }

    #[test]
    fn gray_scale_is_fixed_and_clamped() {
        let image = SpectrumImage {
            width: 3,
            height: 1,
            values: vec![0.0, 1.0, 5.0],
        };
        assert_eq!(image.to_gray8(), vec![0, 128, 255]);
    }
}
