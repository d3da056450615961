//! [`Image`]: a grayscale frame of linear radiance values, and the error measures between frames.

/// A `width × height` grayscale image, row-major (`pixels[y · width + x]`), linear values
/// (scene radiance, nominally in `[0, 1]`).
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Pixels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// `width · height` values, row-major.
    pub pixels: Vec<f32>,
}

impl Image {
    /// An image of zeros.
    pub fn zeros(width: u32, height: u32) -> Image {
        Image {
            width,
            height,
            pixels: vec![0.0; width as usize * height as usize],
        }
    }

    /// Wraps `pixels`; panics if its length is not `width · height`.
    pub fn from_pixels(width: u32, height: u32, pixels: Vec<f32>) -> Image {
        assert_eq!(
            pixels.len(),
            width as usize * height as usize,
            "pixel count vs size"
        );
        Image {
            width,
            height,
            pixels,
        }
    }

    /// The value at `(x, y)`.
    pub fn get(&self, x: u32, y: u32) -> f32 {
        self.pixels[y as usize * self.width as usize + x as usize]
    }
}

/// Root-mean-square error of `image` against `reference` (same length), in the images' units:
/// `sqrt(mean((image − reference)²))`, accumulated in `f64`.
///
/// Panics if the lengths differ or are zero.
pub fn rmse(image: &[f32], reference: &[f64]) -> f64 {
    let image: Vec<f64> = image.iter().map(|&v| f64::from(v)).collect();
    rmse_f64(&image, reference)
}

/// [`rmse`] of an `f64` image.
pub fn rmse_f64(image: &[f64], reference: &[f64]) -> f64 {
    assert_eq!(image.len(), reference.len(), "image vs reference size");
    assert!(!image.is_empty(), "empty image");
    let sum: f64 = image
        .iter()
        .zip(reference)
        .map(|(&a, &b)| (a - b).powi(2))
        .sum();
    (sum / image.len() as f64).sqrt()
}

/// `pixels` (a `width × height` image, row-major) blurred with a normalised Gaussian of standard
/// deviation `sigma` pixels, truncated at `⌈3σ⌉` pixels, applied separably (rows, then columns)
/// with clamp-to-edge borders. Models the spatial filter of a denoiser or of the eye: blue-noise
/// error, being high-frequency, mostly averages out under it.
///
/// Panics unless `pixels.len() == width · height` and `sigma` is finite and `> 0`.
pub fn gaussian_blur(pixels: &[f64], width: u32, height: u32, sigma: f64) -> Vec<f64> {
    let (w, h) = (width as usize, height as usize);
    assert_eq!(pixels.len(), w * h, "pixel count vs size");
    assert!(
        sigma.is_finite() && sigma > 0.0,
        "sigma must be finite and > 0"
    );
    let radius = (3.0 * sigma).ceil() as isize;
    let weights: Vec<f64> = (-radius..=radius)
        .map(|d| (-(d * d) as f64 / (2.0 * sigma * sigma)).exp())
        .collect();
    let total: f64 = weights.iter().sum();
    let weights: Vec<f64> = weights.iter().map(|w| w / total).collect();
    let pass = |src: &[f64], stride: usize, step: usize, len: usize, lines: usize| {
        let mut out = vec![0.0; src.len()];
        for line in 0..lines {
            for i in 0..len {
                let mut sum = 0.0;
                for (k, weight) in weights.iter().enumerate() {
                    let j = (i as isize + k as isize - radius).clamp(0, len as isize - 1) as usize;
                    sum += weight * src[line * stride + j * step];
                }
                out[line * stride + i * step] = sum;
            }
        }
        out
    };
    let rows = pass(pixels, w, 1, w, h);
    pass(&rows, 1, w, h, w)
}

/// The largest `|a − b|` over two equally long images.
///
/// Panics if the lengths differ.
pub fn max_abs_diff(a: &[f32], b: &[f32]) -> f32 {
    assert_eq!(a.len(), b.len(), "image sizes differ");
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rmse_of_known_errors() {
        assert_eq!(rmse(&[1.0, 1.0], &[1.0, 1.0]), 0.0);
        // Errors 0.5 and -0.5: RMSE 0.5. Errors 3 and 4 over two pixels: sqrt(12.5).
        assert_eq!(rmse(&[1.0, 0.0], &[0.5, 0.5]), 0.5);
        assert!((rmse(&[3.0, 4.0], &[0.0, 0.0]) - 12.5f64.sqrt()).abs() < 1e-15);
    }

    #[test]
    fn blur_keeps_constants_and_spreads_an_impulse() {
        let flat = gaussian_blur(&[0.25; 35], 7, 5, 1.3);
        assert!(flat.iter().all(|v| (v - 0.25).abs() < 1e-15));
        let mut impulse = vec![0.0; 15 * 15];
        impulse[7 * 15 + 7] = 1.0;
        let blurred = gaussian_blur(&impulse, 15, 15, 1.0);
        // Mass is kept away from the borders; the peak is the squared centre weight.
        assert!((blurred.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        let g = |d: f64| (-d * d / 2.0).exp();
        let norm: f64 = (-3..=3).map(|d| g(f64::from(d))).sum();
        assert!((blurred[7 * 15 + 7] - 1.0 / (norm * norm)).abs() < 1e-12);
        // Separable: (dx, dy) = (1, 2) gets g(1)·g(2)/norm².
        let expected = g(1.0) * g(2.0) / (norm * norm);
        assert!((blurred[9 * 15 + 8] - expected).abs() < 1e-12);
    }

    #[test]
    fn max_abs_diff_picks_the_largest() {
        assert_eq!(max_abs_diff(&[0.0, 1.0, 2.0], &[0.5, 1.0, 1.0]), 1.0);
    }

    #[test]
    fn image_indexing_is_row_major() {
        let image = Image::from_pixels(3, 2, vec![0.0, 1.0, 2.0, 3.0, 4.0, 5.0]);
        assert_eq!(image.get(2, 0), 2.0);
        assert_eq!(image.get(0, 1), 3.0);
        assert_eq!(Image::zeros(3, 2).pixels.len(), 6);
    }
}
