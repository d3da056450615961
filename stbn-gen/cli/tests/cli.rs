//! The `stbn-gen` binary end to end: generate from a manifest, analyse the result, fail cleanly.

use std::fs;
use std::path::Path;
use std::process::{Command, Output};

use stbn_gen::export::{PngDepth, read_slices_png};

const MANIFEST: &str = r#"(
    masks: [
        (name: "scalar_16", kind: Scalar, size: (16, 16, 8), seed: 1, encoding: Unorm8),
        (name: "blue2d_16", kind: Blue2D, size: (16, 16, 8), seed: 2, encoding: Unorm16),
    ],
)"#;

fn stbn_gen(args: &[&Path]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_stbn-gen"))
        .args(args)
        .output()
        .expect("the binary runs")
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8(bytes.to_vec()).unwrap()
}

/// Asserts a clean failure: status 1, one `error: ` line naming `needle`, no panic.
fn assert_fails_naming(output: &Output, needle: &str) {
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(stderr.starts_with("error: "), "{stderr}");
    assert!(stderr.contains(needle), "{stderr:?} lacks {needle:?}");
    assert!(
        !stderr.contains("panicked") && !stderr.contains("backtrace"),
        "{stderr}"
    );
}

#[test]
fn generate_writes_slices_and_a_report_that_analyze_reproduces() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = dir.path().join("assets.ron");
    fs::write(&manifest, MANIFEST).unwrap();
    let out = dir.path().join("out");
    let output = stbn_gen(&["generate".as_ref(), &manifest, "--out".as_ref(), &out]);
    assert!(output.status.success(), "{}", text(&output.stderr));

    let stdout = text(&output.stdout);
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines.len(), 3, "{stdout}");
    assert!(
        lines[0].starts_with("scalar_16: 16×16×8 spatiotemporal in "),
        "{stdout}"
    );
    assert!(
        lines[1].starts_with("blue2d_16: 16×16×8 independent2d in "),
        "{stdout}"
    );
    assert!(lines[2].starts_with("report: "), "{stdout}");

    let scalar = read_slices_png(&out.join("scalar_16")).unwrap();
    assert_eq!(scalar.bit_depth(), PngDepth::Eight);
    assert_eq!(scalar.field().depth(), 8);
    let blue2d = read_slices_png(&out.join("blue2d_16")).unwrap();
    assert_eq!(blue2d.bit_depth(), PngDepth::Sixteen);

    let report = fs::read_to_string(out.join("report.md")).unwrap();
    let rows: Vec<&str> = report.lines().filter(|l| l.starts_with("| ")).collect();
    assert_eq!(rows.len(), 3, "{report}");
    assert!(
        rows[1].starts_with("| scalar_16 | 16×16×8 | spatiotemporal | "),
        "{report}"
    );
    assert!(report.contains("**White noise = 1**"));
    let figures = |row: &str| -> Vec<String> {
        row.split('|')
            .map(|c| c.trim().to_owned())
            .filter(|c| !c.is_empty())
            .skip(4)
            .collect()
    };
    let generated = figures(rows[1]);
    // Blue in space; histograms exactly uniform (256 ranks per slice, 16 bins).
    assert!(generated[0].parse::<f64>().unwrap() < 0.1, "{report}");
    assert_eq!(generated[2], "0.0000");

    // 256 pixels per slice: the 8-bit slices hold the ranks exactly, so analyse agrees.
    let analysed = dir.path().join("analysed");
    let output = stbn_gen(&[
        "analyze".as_ref(),
        &out.join("scalar_16"),
        &out.join("blue2d_16"),
        "--out".as_ref(),
        &analysed,
    ]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let report = fs::read_to_string(analysed.join("report.md")).unwrap();
    let row = report
        .lines()
        .find(|l| l.starts_with("| scalar_16 "))
        .unwrap();
    assert!(row.contains("| png 8-bit | n/a |"), "{row}");
    assert_eq!(figures(row), generated);
    assert!(
        report.contains("| blue2d_16 | 16×16×8 | png 16-bit | n/a |"),
        "{report}"
    );
}

#[test]
fn a_bad_manifest_fails_with_its_location() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = dir.path().join("assets.ron");
    fs::write(&manifest, MANIFEST.replace("seed: 2", "seed: 2, colour: 3")).unwrap();
    let out = dir.path().join("out");
    let output = stbn_gen(&["generate".as_ref(), &manifest, "--out".as_ref(), &out]);
    assert_fails_naming(&output, "assets.ron:4:");
    assert_fails_naming(&output, "colour");

    let missing = dir.path().join("absent.ron");
    let output = stbn_gen(&["generate".as_ref(), &missing, "--out".as_ref(), &out]);
    assert_fails_naming(&output, "absent.ron");
}

#[test]
fn analyze_fails_naming_the_folder() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("no_such_mask");
    let output = stbn_gen(&["analyze".as_ref(), &missing, "--out".as_ref(), dir.path()]);
    assert_fails_naming(&output, "no_such_mask");
    assert!(!dir.path().join("report.md").exists());
}
