//! The report's "Convergence past the depth": generated masks read through the runtime past
//! their depth, plainly (wrapping), progressively and as white noise of their distribution.

use std::collections::BTreeMap;
use std::fs;
use std::path::Path;
use std::process::{Command, Output};

fn stbn_gen(args: &[&Path]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_stbn-gen"))
        .args(args)
        .output()
        .expect("the binary runs")
}

/// `convergence_past_depth.csv` of a report: RMSE by `(mask, function, reading)`, one entry per
/// frame count `(frames, rmse)`, and the error image's low band at the last count.
type Curves = BTreeMap<(String, String, String), (Vec<(u64, f64)>, Option<f64>)>;

fn read_curves(out: &Path) -> Curves {
    let text = fs::read_to_string(out.join("csv/convergence_past_depth.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "mask,function,reading,frames,frames_per_depth,rmse,window_width,window_height,\
         error_spatial_low_band"
    );
    let mut curves = Curves::new();
    for line in lines {
        let cells: Vec<&str> = line.split(',').collect();
        assert_eq!(cells.len(), 9, "{line}");
        let key = (cells[0].into(), cells[1].into(), cells[2].into());
        let entry = curves.entry(key).or_default();
        entry
            .0
            .push((cells[3].parse().unwrap(), cells[5].parse().unwrap()));
        if !cells[8].is_empty() {
            entry.1 = Some(cells[8].parse().unwrap());
        }
    }
    curves
}

#[test]
fn the_report_measures_scalar_and_vector_masks_past_their_depth() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = dir.path().join("assets.ron");
    fs::write(
        &manifest,
        r#"(masks: [
            (name: "scalar_16", kind: Scalar, size: (16, 16, 8), seed: 1, encoding: Unorm16),
            (name: "vec2_16", kind: Vec2, size: (16, 16, 8), seed: 1, encoding: Unorm16,
             swaps_per_pixel: 8),
        ])"#,
    )
    .unwrap();
    let out = dir.path().join("out");
    let output = stbn_gen(&["generate".as_ref(), &manifest, "--out".as_ref(), &out]);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let report = fs::read_to_string(out.join("report.md")).unwrap();
    let section = &report[report
        .find("\n## Convergence past the depth\n")
        .unwrap_or_else(|| panic!("no section in {report}"))..];
    let section = &section[..section[1..].find("\n## ").map_or(section.len(), |e| e + 1)];
    for (name, columns) in [
        ("scalar_16", ["ramp", "step", "sine"].as_slice()),
        ("vec2_16", ["smooth", "edge"].as_slice()),
    ] {
        let heading = format!("**`{name}`** (16×16×8, depth 8): RMSE over all 16×16 pixels.");
        let table = &section[section
            .find(&heading)
            .unwrap_or_else(|| panic!("{heading:?} in {section}"))..];
        for function in columns {
            for reading in ["wrap", "progressive", "white"] {
                assert!(
                    table.contains(&format!("| {function}: {reading} |")),
                    "{function}: {reading} in {table}"
                );
            }
        }
        // One row per frame count: 8 · {1, …, 32}.
        for (frames, multiple) in [(8, 1), (16, 2), (64, 8), (256, 32)] {
            assert!(
                table.contains(&format!("\n| {frames} | {multiple} | ")),
                "{frames} frames in {table}"
            );
        }
        assert!(
            table.contains("Spatial low band of the error image after 256 frames"),
            "{table}"
        );
    }
    assert!(
        section.contains(
            "![Convergence past the depth: step (scalar) or edge (vector), Monte Carlo]\
             (plots/convergence_past_depth.png)"
        ),
        "{section}"
    );
    let plot = fs::read(out.join("plots/convergence_past_depth.png")).unwrap();
    assert!(plot.starts_with(b"\x89PNG"));
    // The caption names each drawn series: three per mask.
    for series in [
        "= scalar_16 wrap",
        "= scalar_16 progressive",
        "= scalar_16 white",
        "= vec2_16 wrap",
        "= vec2_16 progressive",
        "= vec2_16 white",
    ] {
        assert!(section.contains(series), "{series} in {section}");
    }

    let curves = read_curves(&out);
    assert_eq!(curves.len(), 3 * 3 + 2 * 3, "{curves:?}");
    for ((mask, function, reading), (points, band)) in &curves {
        let frames: Vec<u64> = points.iter().map(|p| p.0).collect();
        assert_eq!(
            frames,
            [8, 16, 32, 64, 128, 256],
            "{mask} {function} {reading}"
        );
        assert!(band.is_some(), "{mask} {function} {reading}");
    }
    let curve = |mask: &str, function: &str, reading: &str| {
        let key = (mask.to_owned(), function.to_owned(), reading.to_owned());
        curves[&key].0.iter().map(|p| p.1).collect::<Vec<f64>>()
    };
    for (mask, function) in [
        ("scalar_16", "ramp"),
        ("scalar_16", "step"),
        ("scalar_16", "sine"),
        ("vec2_16", "smooth"),
        ("vec2_16", "edge"),
    ] {
        let wrap = curve(mask, function, "wrap");
        let progressive = curve(mask, function, "progressive");
        let white = curve(mask, function, "white");
        // Wrapping repeats the same 8 values: every count of whole passes has the same mean.
        for e in &wrap {
            assert!(
                (e - wrap[0]).abs() <= 1e-9 * wrap[0].max(1e-12),
                "{mask} {function}: wrap is not flat: {wrap:?}"
            );
        }
        // The progressive view starts where wrapping does, then keeps falling.
        assert_eq!(progressive[0], wrap[0], "{mask} {function}");
        assert!(
            progressive[5] < 0.5 * progressive[0],
            "{mask} {function}: progressive {progressive:?}"
        );
        assert!(
            progressive[5] < progressive[2] && progressive[2] < progressive[0],
            "{mask} {function}: progressive {progressive:?}"
        );
        // ... and beats white noise of the same distribution after 32 · depth frames.
        assert!(
            progressive[5] < white[5],
            "{mask} {function}: progressive {progressive:?}, white {white:?}"
        );
    }
}

#[test]
fn analysed_slices_say_they_are_not_measured_past_the_depth() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = dir.path().join("assets.ron");
    fs::write(
        &manifest,
        r#"(masks: [(name: "s", kind: Scalar, size: (8, 8, 4), seed: 1, encoding: Unorm8)])"#,
    )
    .unwrap();
    let out = dir.path().join("out");
    let output = stbn_gen(&["generate".as_ref(), &manifest, "--out".as_ref(), &out]);
    assert!(output.status.success());
    let analysed = dir.path().join("analysed");
    let output = stbn_gen(&[
        "analyze".as_ref(),
        &out.join("s"),
        "--out".as_ref(),
        &analysed,
    ]);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let report = fs::read_to_string(analysed.join("report.md")).unwrap();
    assert!(
        report.contains(
            "\n- `s`: not measured: analysed slices and baselines are not encoded masks.\n"
        ),
        "{report}"
    );
    // No mask measured: no plot, and the CSV file holds its header only.
    assert!(!analysed.join("plots/convergence_past_depth.png").exists());
    assert!(read_curves(&analysed).is_empty());
}
