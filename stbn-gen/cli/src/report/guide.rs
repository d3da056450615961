//! The top of the report: how to read it, a verdict per mask, and which kind of mask serves
//! which use.

use std::fmt::Write as _;

use super::Row;
use super::vector::RATIO_AT;

/// A low band below this is called blue (white noise = 1).
const BLUE: f64 = 0.5;

/// A low band at or above this is no better than white noise (its expected value is 1, and a
/// sample of white noise scatters by a few percent around it).
const WHITE: f64 = 0.9;

/// How blue one axis is, from its low band.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Blueness {
    Blue,
    Partly,
    White,
    /// No figure (a single frame, or 1×1 frames).
    Unmeasured,
}

impl Blueness {
    fn of(band: Option<f64>) -> Blueness {
        match band {
            None => Blueness::Unmeasured,
            Some(b) if b < BLUE => Blueness::Blue,
            Some(b) if b < WHITE => Blueness::Partly,
            Some(_) => Blueness::White,
        }
    }
}

/// The reading guide: what each figure means, which way is better, what white noise scores.
pub fn reading_guide() -> &'static str {
    "## How to read this report\n\n\
     - **Low band** (spatial: within each frame; temporal: each pixel over the frames): the \
     power of the lowest eighth of the frequencies relative to white noise. **White noise = 1; \
     lower is better** (blue noise is far below 1). A mask used over many frames (TAA, an EMA, \
     progressive rendering) wants both low; a mask seen one frame at a time needs only the \
     spatial one.\n\
     - **Histogram deviations** say whether the values have the right distribution: per frame \
     (0 = every frame exactly uniform, or for vector masks exactly the space's pdf) and per pixel \
     over time (lower is better; white noise about 0.87/√frames).\n\
     - **Filtered error** and **convergence RMSE** measure what a renderer sees after blurring \
     or averaging: lower is better; each section states what white noise scores.\n\
     - **Vector masks** (directions, points) are judged in their own space: low bands of each \
     decoded component, distribution against the space's pdf, and test functions integrated \
     beside white noise of the same distribution (ratio: white noise = 1, lower is better).\n"
}

/// The verdict on every mask, one line each.
pub fn verdicts(rows: &[Row]) -> String {
    let mut text = String::from("## Verdict\n\n");
    for row in rows {
        let _ = writeln!(text, "- {}", verdict(row));
    }
    text
}

/// One mask's verdict: how blue it is in space and time, with the figures, and a warning for
/// each axis where it is no better than white noise.
fn verdict(row: &Row) -> String {
    let name = format!("`{}`", crate::output::line_text(&row.name));
    let space = Blueness::of(row.spatial);
    let time = Blueness::of(row.temporal);
    let figures = format!(
        "spatial low band {}, temporal {} (white noise = 1)",
        figure(row.spatial),
        figure(row.temporal)
    );
    let summary = match (space, time) {
        (Blueness::Blue, Blueness::Blue) => "blue in space and time".to_owned(),
        (Blueness::Blue, Blueness::Unmeasured) => "blue in space (a single frame)".to_owned(),
        (Blueness::Blue, Blueness::White) => {
            "blue in space only; ⚠ over time no better than white noise".to_owned()
        }
        (Blueness::Blue, Blueness::Partly) => "blue in space, partly blue over time".to_owned(),
        (Blueness::Partly, Blueness::Blue) => "partly blue in space, blue over time".to_owned(),
        (Blueness::Partly, _) => "partly blue in space".to_owned(),
        (Blueness::White, Blueness::Blue) => {
            "blue over time only; ⚠ in space no better than white noise".to_owned()
        }
        (Blueness::White, _) | (Blueness::Unmeasured, Blueness::White) => {
            "⚠ no better than white noise".to_owned()
        }
        (Blueness::Unmeasured, _) => "no spatial figure (1×1 frames)".to_owned(),
    };
    let mut line = format!("{name} ({}): {summary}: {figures}", row.kind);
    match &row.vector {
        Some(vector) => {
            if let Some(ratio) = vector.worst_ratio() {
                let warn = if ratio >= WHITE { "⚠ " } else { "" };
                let _ = write!(
                    line,
                    "; {warn}its test functions' error at {RATIO_AT} samples is at most \
                     {ratio:.2}× that of white noise of the same distribution"
                );
            }
            let _ = write!(
                line,
                "; {}",
                distribution(row.histogram, "the space's pdf", vector.white.frame)
            );
        }
        None => {
            let _ = write!(
                line,
                "; filtered error {:.4} (white noise ≈ 0.020); {}",
                row.filtered_last(),
                distribution(row.histogram, "uniform", f64::INFINITY)
            );
        }
    }
    line.push('.');
    line
}

/// How well the frames follow the target distribution, from the frame histogram deviation
/// `frame` and white noise's (`white`, infinite when unknown).
fn distribution(frame: f64, target: &str, white: f64) -> String {
    if frame < 1e-12 {
        format!("every frame follows {target} exactly")
    } else if frame < 0.5 * white {
        format!("frames follow {target} closely (frame histogram deviation {frame:.2})")
    } else {
        format!("⚠ frames deviate from {target} (frame histogram deviation {frame:.2})")
    }
}

/// A low band with two decimals, four below 0.01 (so a very blue mask does not read 0.00).
fn figure(band: Option<f64>) -> String {
    match band {
        None => "n/a".to_owned(),
        Some(b) if b < 0.01 => format!("{b:.4}"),
        Some(b) => format!("{b:.2}"),
    }
}

/// Which kind of mask serves which use: true for any manifest.
pub fn which_mask() -> &'static str {
    "## Which mask to pick\n\n\
     Pick by what a pixel needs per frame, then compare the masks of that kind by the figures \
     below. **One number** (a threshold, dither, stochastic transparency, a random offset or \
     rotation): a scalar mask, `Scalar` (blue in space and time) when frames are accumulated, \
     `Blue2D` when each frame is seen on its own. **Several uniform numbers** (a jitter, a point \
     in a square): `Vec2`–`Vec4`, whose components are spread jointly, rather than one scalar \
     mask read at offsets. **Directions**: `UnitVec2`/`UnitVec3` for uniform directions, \
     `UniformHemisphere` or `CosineHemisphere` for rays about a normal (cosine for diffuse light \
     and ambient occlusion, where its pdf cancels the cosine term), `ImagePoints` and \
     `EnvironmentMap` to importance-sample an image. `FilterAdapted` masks are optimised for the \
     filters a renderer applies; prefer them when the filters match yours. A mask whose verdict \
     warns is no better than white noise on that axis: it buys nothing there.\n"
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(spatial: Option<f64>, temporal: Option<f64>) -> Row {
        Row {
            name: "m".to_owned(),
            size: (8, 8, 8),
            kind: "spatiotemporal".to_owned(),
            seconds: None,
            spatial,
            temporal,
            histogram: 0.0,
            pixel_histogram: 0.1,
            radial: Vec::new(),
            temporal_spectrum: Vec::new(),
            filtered: vec![0.01],
            convergence: Vec::new(),
            convergence_late: Vec::new(),
            vector: None,
            past_depth: Err(super::super::past_depth::NOT_ENCODED.to_owned()),
        }
    }

    #[test]
    fn verdicts_name_each_axis_and_warn_where_white() {
        let blue = verdict(&row(Some(0.05), Some(0.13)));
        assert!(
            blue.starts_with(
                "`m` (spatiotemporal): blue in space and time: spatial low band 0.05, \
                 temporal 0.13 (white noise = 1)"
            ),
            "{blue}"
        );
        assert!(
            blue.contains("every frame follows uniform exactly"),
            "{blue}"
        );
        let space_only = verdict(&row(Some(0.05), Some(1.02)));
        assert!(
            space_only.contains("⚠ over time no better than white noise"),
            "{space_only}"
        );
        assert!(verdict(&row(Some(0.98), Some(1.0))).contains("⚠ no better than white noise"));
        assert!(verdict(&row(Some(0.05), None)).contains("a single frame"));
        assert!(verdict(&row(Some(0.0014), Some(0.06))).contains("low band 0.0014, temporal 0.06"));
    }
}
