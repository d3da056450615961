//! The DFT magnitude images of the report ([`stbn_gen::analysis::dft_xy_image`],
//! [`stbn_gen::analysis::dft_xz_image`]) as 8-bit grayscale PNGs, enlarged by an integer factor
//! (nearest neighbour) so small masks stay visible.

use std::path::Path;

use stbn_gen::analysis::SpectrumImage;

use crate::Result;
use crate::output;

/// The folder of the images, relative to report.md.
pub const DFT_DIR: &str = "dft";

/// Images are enlarged until their longer side reaches at least this many pixels.
pub const MIN_SIDE: usize = 256;

/// The integer enlargement of a `width × height` image: `⌈MIN_SIDE / longer side⌉`, at least 1.
pub fn enlargement(width: usize, height: usize) -> usize {
    MIN_SIDE.div_ceil(width.max(height).max(1)).max(1)
}

/// Writes `image` ([`SpectrumImage::to_gray8`], enlarged by [`enlargement`]) to `path` as an
/// 8-bit grayscale PNG.
pub fn write(image: &SpectrumImage, path: &Path) -> Result<()> {
    let factor = enlargement(image.width, image.height);
    let (w, h) = (image.width * factor, image.height * factor);
    let gray = image.to_gray8();
    let mut pixels = Vec::with_capacity(w * h);
    for row in gray.chunks_exact(image.width) {
        let wide: Vec<u8> = row
            .iter()
            .flat_map(|&g| std::iter::repeat_n(g, factor))
            .collect();
        for _ in 0..factor {
            pixels.extend_from_slice(&wide);
        }
    }
    output::write_png(path, (w, h), png::ColorType::Grayscale, &pixels)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn images_are_enlarged_and_written_as_gray() {
        assert_eq!(enlargement(128, 64), 2);
        assert_eq!(enlargement(64, 32), 4);
        assert_eq!(enlargement(300, 7), 1);
        let image = SpectrumImage {
            width: 2,
            height: 1,
            values: vec![0.0, 2.0],
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.png");
        write(&image, &path).unwrap();
        let file = std::fs::File::open(&path).unwrap();
        let decoder = png::Decoder::new(std::io::BufReader::new(file));
        let mut reader = decoder.read_info().unwrap();
        let mut pixels = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut pixels).unwrap();
        assert_eq!((info.width, info.height), (256, 128));
        assert_eq!(info.color_type, png::ColorType::Grayscale);
        // Left half black, right half white, on every row.
        assert_eq!(pixels[0], 0);
        assert_eq!(pixels[255], 255);
        assert_eq!(pixels[127 * 256 + 128], 255);
    }
}
