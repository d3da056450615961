//! Error tables of a [`Comparison`] as Markdown and CSV.

use std::fmt::Write as _;

use crate::compare::{Accumulation, Comparison, Metric};
use crate::noise::NoiseKind;

/// `error(kind) / error(reference) − 1` in percent at `frames`, if both exist (negative: `kind`
/// has the lower error).
pub fn relative_change(
    cmp: &Comparison,
    kind: NoiseKind,
    reference: NoiseKind,
    accumulation: Accumulation,
    metric: Metric,
    frames: u32,
) -> Option<f64> {
    let a = cmp.error(kind, accumulation, metric, frames)?;
    let b = cmp.error(reference, accumulation, metric, frames)?;
    Some((a / b - 1.0) * 100.0)
}

/// The source the tables highlight: the last spatiotemporal one in table order.
fn highlighted(cmp: &Comparison) -> Option<NoiseKind> {
    cmp.runs.iter().rev().map(|r| r.kind).find(|k| k.is_stbn())
}

/// A Markdown section: a heading with the scene's name, its description, one table per metric
/// and accumulation (rows: noises; columns: frame counts), and the highlighted STBN source's
/// (the last in table order) change against each other noise at the last frame count.
pub fn markdown(cmp: &Comparison) -> String {
    let frames = cmp.frame_counts();
    let stbn = highlighted(cmp);
    let mut out = String::new();
    let _ = writeln!(out, "### `{}` ({}×{})\n", cmp.scene, cmp.width, cmp.height);
    let _ = writeln!(out, "{}.\n", cmp.description);
    for metric in Metric::ALL {
        for accumulation in Accumulation::ALL {
            let title = match accumulation {
                Accumulation::Ema => "EMA α = 0.1",
                Accumulation::Mean => "running mean",
            };
            let _ = write!(out, "| {}, {title} |", metric.label());
            for f in &frames {
                let _ = write!(out, " {f} frame{} |", if *f == 1 { "" } else { "s" });
            }
            let _ = write!(out, "\n|---|");
            for _ in &frames {
                let _ = write!(out, "---:|");
            }
            out.push('\n');
            for run in &cmp.runs {
                let _ = write!(out, "| {} |", run.kind.label());
                for &f in &frames {
                    let value = cmp
                        .error(run.kind, accumulation, metric, f)
                        .unwrap_or(f64::NAN);
                    if Some(run.kind) == stbn {
                        let _ = write!(out, " **{value:.5}** |");
                    } else {
                        let _ = write!(out, " {value:.5} |");
                    }
                }
                out.push('\n');
            }
            out.push('\n');
        }
    }
    if let (Some(&last), Some(stbn)) = (frames.last(), stbn) {
        let references: Vec<NoiseKind> = cmp
            .runs
            .iter()
            .map(|r| r.kind)
            .filter(|&k| k != stbn)
            .collect();
        let _ = writeln!(
            out,
            "{}'s error after {last} frames relative to each other source (negative: lower):\n",
            stbn.label()
        );
        let _ = write!(out, "| metric, accumulation |");
        for r in &references {
            let _ = write!(out, " vs {} |", r.label());
        }
        let _ = write!(out, "\n|---|");
        for _ in &references {
            let _ = write!(out, "---:|");
        }
        out.push('\n');
        for metric in Metric::ALL {
            for accumulation in Accumulation::ALL {
                let _ = write!(out, "| {}, {} |", metric.name(), accumulation.name());
                for &r in &references {
                    let cell = relative_change(cmp, stbn, r, accumulation, metric, last)
                        .map_or_else(|| "–".to_owned(), |c| format!("{c:+.1}%"));
                    let _ = write!(out, " {cell} |");
                }
                out.push('\n');
            }
        }
        out.push('\n');
    }
    out
}

/// CSV with a header row: `scene,noise,metric,accumulation,frames,error`, one row per run,
/// metric, accumulation and frame count (`NaN` where a metric has no value: the low band of a
/// 1 × 1 image).
pub fn csv(cmp: &Comparison) -> String {
    let mut out = String::from("scene,noise,metric,accumulation,frames,error\n");
    for run in &cmp.runs {
        for metric in Metric::ALL {
            for accumulation in Accumulation::ALL {
                for checkpoint in &run.checkpoints {
                    let value = cmp
                        .error(run.kind, accumulation, metric, checkpoint.frames)
                        .unwrap_or(f64::NAN);
                    let _ = writeln!(
                        out,
                        "{},{},{},{},{},{value:.7}",
                        cmp.scene,
                        run.kind.name(),
                        metric.name(),
                        accumulation.name(),
                        checkpoint.frames
                    );
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compare::NoiseRun;
    use crate::image::Image;
    use crate::render::Checkpoint;

    fn comparison() -> Comparison {
        let checkpoint = |frames, ema: f32, mean: f32| Checkpoint {
            frames,
            ema: Image::from_pixels(1, 1, vec![ema]),
            mean: Image::from_pixels(1, 1, vec![mean]),
        };
        Comparison {
            scene: "toy".into(),
            description: "a toy".into(),
            width: 1,
            height: 1,
            ground_truth: vec![0.5],
            runs: vec![
                NoiseRun {
                    kind: NoiseKind::White,
                    checkpoints: vec![checkpoint(1, 1.0, 1.0), checkpoint(4, 0.7, 0.6)],
                },
                NoiseRun {
                    kind: NoiseKind::Stbn,
                    checkpoints: vec![checkpoint(1, 0.0, 0.0), checkpoint(4, 0.6, 0.55)],
                },
            ],
        }
    }

    #[test]
    fn tables_hold_every_rmse() {
        let cmp = comparison();
        let md = markdown(&cmp);
        assert!(md.contains("| white noise | 0.50000 | 0.20000 |"), "{md}");
        assert!(md.contains("| STBN | **0.50000** | **0.10000** |"), "{md}");
        assert!(
            md.contains("| RMSE, running mean | 1 frame | 4 frames |"),
            "{md}"
        );
        // One pixel: the blur changes nothing, so both metrics agree.
        assert!(
            md.contains("| RMSE after a Gaussian blur (σ 1.3435 px), EMA α = 0.1 |"),
            "{md}"
        );
        assert!(
            md.contains("| metric, accumulation | vs white noise |"),
            "{md}"
        );
        assert!(md.contains("| rmse, ema | -50.0% |\n"), "{md}");
        assert!(md.contains("| blurred_rmse, mean | -50.0% |\n"), "{md}");
        let csv = csv(&cmp);
        assert_eq!(csv.lines().count(), 1 + 2 * 3 * 2 * 2);
        // A 1 × 1 image has no spatial frequency to measure.
        assert!(
            csv.contains("toy,stbn,error_low_band,mean,4,NaN\n"),
            "{csv}"
        );
        assert!(md.contains("| error_low_band, mean | – |\n"), "{md}");
        assert!(csv.contains("toy,stbn,rmse,mean,4,0.0500000\n"), "{csv}");
        assert!(
            csv.contains("toy,stbn,blurred_rmse,mean,4,0.0500000\n"),
            "{csv}"
        );
    }

    #[test]
    fn the_last_stbn_source_is_highlighted() {
        let mut cmp = comparison();
        let mut progressive = cmp.runs[1].clone();
        progressive.kind = NoiseKind::StbnProgressive;
        cmp.runs.push(progressive);
        let md = markdown(&cmp);
        assert!(md.contains("| STBN | 0.50000 | 0.10000 |"), "{md}");
        assert!(
            md.contains("| STBN, progressive | **0.50000** | **0.10000** |"),
            "{md}"
        );
        assert!(
            md.contains("| metric, accumulation | vs white noise | vs STBN |"),
            "{md}"
        );
    }

    #[test]
    fn relative_change_is_a_percentage() {
        let cmp = comparison();
        let change = relative_change(
            &cmp,
            NoiseKind::Stbn,
            NoiseKind::White,
            Accumulation::Mean,
            Metric::Rmse,
            4,
        )
        .unwrap();
        assert!((change + 50.0).abs() < 1e-4);
        assert!(
            relative_change(
                &cmp,
                NoiseKind::Blue2D,
                NoiseKind::White,
                Accumulation::Mean,
                Metric::Rmse,
                4
            )
            .is_none()
        );
    }
}
