//! The quality figures of one mask ([`Row`]) and the `report.md` table of several.

use std::fmt::Write as _;
use std::fs;
use std::path::{Path, PathBuf};

use stbn_gen::analysis::{Field, slice_histogram_deviation, spatial_low_band, temporal_low_band};

use crate::Result;

/// Bins of the histogram-deviation column. 16 divides every power-of-two slice size from 16
/// pixels up and the 256 levels of 8-bit PNGs, so exactly uniform slices measure exactly 0.
pub const HISTOGRAM_BINS: usize = 16;

/// One mask's line of the report.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// The mask's name.
    pub name: String,
    /// `(width, height, frames)`.
    pub size: (usize, usize, usize),
    /// How it was made: a generator topology, or `png N-bit` for analysed slices.
    pub kind: String,
    /// Generation wall-clock time in seconds; `None` for analysed slices.
    pub seconds: Option<f64>,
    /// [`spatial_low_band`]: dimensionless, white noise ≈ 1; `None` for 1×1 frames.
    pub spatial: Option<f64>,
    /// [`temporal_low_band`]: dimensionless, white noise ≈ 1; `None` for a single frame.
    pub temporal: Option<f64>,
    /// [`slice_histogram_deviation`] over [`HISTOGRAM_BINS`] bins: 0 = exactly uniform frames.
    pub histogram: f64,
}

impl Row {
    /// Measures `field`.
    pub fn measure(name: &str, kind: &str, seconds: Option<f64>, field: &Field) -> Row {
        Row {
            name: name.to_owned(),
            size: (field.width(), field.height(), field.depth()),
            kind: kind.to_owned(),
            seconds,
            spatial: spatial_low_band(field),
            temporal: temporal_low_band(field),
            histogram: slice_histogram_deviation(field, HISTOGRAM_BINS),
        }
    }

    /// One line for the terminal.
    pub fn summary(&self) -> String {
        let time = self
            .seconds
            .map(|s| format!(" in {s:.2} s"))
            .unwrap_or_default();
        format!(
            "{}: {} {}{time}; low band (white noise = 1): spatial {}, temporal {}",
            self.name,
            size(self.size),
            self.kind,
            band(self.spatial),
            band(self.temporal),
        )
    }
}

/// Writes `<out>/report.md` (creating `out`) with `intro` above the table of `rows`, and returns
/// its path.
pub fn write(out: &Path, intro: &str, rows: &[Row]) -> Result<PathBuf> {
    fs::create_dir_all(out).map_err(|e| format!("cannot create {}: {e}", out.display()))?;
    let path = out.join("report.md");
    fs::write(&path, markdown(intro, rows))
        .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    Ok(path)
}

/// The report: heading, `intro`, the table and what its columns mean.
fn markdown(intro: &str, rows: &[Row]) -> String {
    let mut text = format!(
        "# Blue-noise mask report\n\n{intro}\n\n\
         | mask | size | kind | seconds | spatial low band | temporal low band | histogram deviation |\n\
         |---|---|---|---:|---:|---:|---:|\n"
    );
    for row in rows {
        let seconds = row.seconds.map_or("n/a".to_owned(), |s| format!("{s:.2}"));
        writeln!(
            text,
            "| {} | {} | {} | {seconds} | {} | {} | {:.4} |",
            row.name.replace('|', "\\|"),
            size(row.size),
            row.kind,
            band(row.spatial),
            band(row.temporal),
            row.histogram,
        )
        .expect("writing to a String cannot fail");
    }
    text.push_str(&format!(
        "\n\
Columns:\n\n\
- **size**: width × height × frames (pixels, pixels, frames).\n\
- **kind**: the energy a generated mask was made with (`spatiotemporal`: blue in space and over \
time; `independent2d`: an independent 2D blue-noise mask per frame; `isotropic3d`: 3D blue noise), \
or `png N-bit` for analysed slice files.\n\
- **seconds**: wall-clock generation time (n/a for analysed files).\n\
- **spatial low band**: each frame's 2D power spectrum with the mean removed, divided by what \
white noise of the same variance would have, averaged over the low frequencies 0 < |ν| ≤ 1/8 \
cycles per pixel (radius ≤ width/8 for square frames), then over frames. **White noise = 1**; \
blue noise is far below 1. n/a for 1×1 frames.\n\
- **temporal low band**: the same for every pixel's values over the frames, over the \
frequencies 1 ≤ f ≤ frames/8 cycles per sequence (just f = 1 below 8 frames), averaged over \
pixels. **White noise = 1**; a mask that is blue over time is far below 1, one that is white \
over time (`independent2d`) about 1. n/a for a single frame.\n\
- **histogram deviation**: the largest relative deviation of any frame's {HISTOGRAM_BINS}-bin \
histogram of values from uniform, |count − expected| / expected. 0 = every frame exactly \
uniform (void-and-cluster ranks always are); white noise measures about 0.2 over 32 frames \
 of 64×64.\n\n\
Figures of generated masks are measured on the exact ranks, before PNG quantisation; those of \
analysed files on the decoded samples, (sample + ½) / 2^bits.\n"
    ));
    text
}

fn size((width, height, depth): (usize, usize, usize)) -> String {
    format!("{width}×{height}×{depth}")
}

fn band(value: Option<f64>) -> String {
    value.map_or("n/a".to_owned(), |v| format!("{v:.4}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(name: &str, seconds: Option<f64>, temporal: Option<f64>) -> Row {
        Row {
            name: name.to_owned(),
            size: (64, 32, 1),
            kind: "png 8-bit".to_owned(),
            seconds,
            spatial: Some(0.00123456),
            temporal,
            histogram: 0.0,
        }
    }

    #[test]
    fn table_rows_show_missing_figures_as_n_a_and_escape_pipes() {
        let text = markdown(
            "Intro.",
            &[
                row("a|b", None, None),
                row("scalar", Some(1.234), Some(0.5)),
            ],
        );
        assert!(text.starts_with("# Blue-noise mask report\n\nIntro.\n\n| mask |"));
        assert!(
            text.contains("| a\\|b | 64×32×1 | png 8-bit | n/a | 0.0012 | n/a | 0.0000 |\n"),
            "{text}"
        );
        assert!(
            text.contains("| scalar | 64×32×1 | png 8-bit | 1.23 | 0.0012 | 0.5000 | 0.0000 |\n")
        );
        assert!(text.contains("**White noise = 1**"));
    }

    #[test]
    fn summary_names_mask_size_time_and_bands() {
        assert_eq!(
            row("scalar", Some(0.5), Some(0.04)).summary(),
            "scalar: 64×32×1 png 8-bit in 0.50 s; low band (white noise = 1): spatial 0.0012, \
             temporal 0.0400"
        );
        assert!(row("x", None, None).summary().ends_with("temporal n/a"));
    }

    #[test]
    fn measure_reads_the_field() {
        let values: Vec<f64> = (0..64).map(|i| (i as f64 + 0.5) / 64.0).collect();
        let field = Field::new(8, 8, 1, &values).unwrap();
        let row = Row::measure("ramp", "png 8-bit", None, &field);
        assert_eq!(row.size, (8, 8, 1));
        assert_eq!(row.temporal, None);
        assert_eq!(row.histogram, 0.0);
        // A ramp along the rows is all low frequency: far above white.
        assert!(row.spatial.unwrap() > 1.0);
    }
}
