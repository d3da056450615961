//! Centred DFT magnitude images ([`analysis`] docs, "DFT images").
//!
//! [`analysis`]: crate::analysis#dft-images

use rustfft::FftPlanner;

use super::{
    Field, PLANE_TASK_BYTES, TASKS, add_plane_spectrum, spectrum_fold, sum_tasks_in_order,
};

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
/// Slices over [`MAX_SPECTRUM_PLANE`](super::MAX_SPECTRUM_PLANE) pixels are folded by
/// [`spectrum_fold`]: the image is then the `(width / fx) × (height / fy)` grid of every
/// `fx`-th and `fy`-th frequency, exactly. Deterministic for any thread count (slice chunks are
/// summed in order).
pub fn dft_xy_image(field: &Field) -> SpectrumImage {
    let (w, h, d) = (field.width(), field.height(), field.depth());
    mean_magnitude(d, (w, h), &|z, y| &field.slice(z)[y * w..(y + 1) * w])
}

/// The XZ image: for every row `y`, the 2D DFT magnitude of the `width × depth` image
/// `v(x, y, z)` (x across, frame z down), averaged over rows; `width × depth`.
///
/// Planes over [`MAX_SPECTRUM_PLANE`](super::MAX_SPECTRUM_PLANE) pixels are folded by
/// [`spectrum_fold`]`(width, depth)`, as in [`dft_xy_image`]. Deterministic for any thread count
/// (row chunks are summed in order).
pub fn dft_xz_image(field: &Field) -> SpectrumImage {
    let (w, h, d) = (field.width(), field.height(), field.depth());
    let n = field.slice_pixels();
    let values = field.values();
    mean_magnitude(h, (w, d), &|y, z| {
        &values[z * n + y * w..z * n + (y + 1) * w]
    })
}

/// The centred mean normalised magnitude of `count` planes of `w × h` values, row `j` of plane
/// `i` being `row(i, j)` (`w` values), read as they are transformed.
fn mean_magnitude<'a>(
    count: usize,
    (w, h): (usize, usize),
    row: &(dyn Fn(usize, usize) -> &'a [f64] + Sync),
) -> SpectrumImage {
    let fold = spectrum_fold(w, h);
    let (gw, gh) = (w / fold.0, h / fold.1);
    let mut planner = FftPlanner::<f64>::new();
    let fft_x = planner.plan_fft_forward(gw);
    let fft_y = planner.plan_fft_forward(gh);
    let chunk = count.div_ceil(TASKS);
    let sum = sum_tasks_in_order(
        count.div_ceil(chunk),
        PLANE_TASK_BYTES * gw * gh,
        gw * gh,
        |task| {
            let mut sum = vec![0.0; gw * gh];
            for plane in task * chunk..((task + 1) * chunk).min(count) {
                let rows = |j: usize| row(plane, j);
                add_plane_spectrum(&rows, (w, h), fold, (&*fft_x, &*fft_y), &mut sum, f64::sqrt);
            }
            sum
        },
    );
    let mut values = vec![0.0; gw * gh];
    for fy in 0..gh {
        for fx in 0..gw {
            let (column, row) = ((fx + gw / 2) % gw, (fy + gh / 2) % gh);
            values[row * gw + column] = sum[fy * gw + fx] / count as f64;
        }
    }
    SpectrumImage {
        width: gw,
        height: gh,
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
