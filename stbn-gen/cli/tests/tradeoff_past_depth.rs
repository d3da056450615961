//! `stbn-gen tradeoff --quick --only past-depth`: the section's three tables hold every row, and
//! the relations that must hold between their figures do.

use std::fs;
use std::process::Command;

/// The rows of a CSV file without quoted fields: header, then rows.
fn csv(text: &str) -> (Vec<&str>, Vec<Vec<&str>>) {
    let mut lines = text.lines().map(|l| l.split(',').collect::<Vec<_>>());
    let header = lines.next().expect("a header row");
    let rows: Vec<Vec<&str>> = lines.collect();
    for row in &rows {
        assert_eq!(row.len(), header.len(), "{row:?}");
    }
    (header, rows)
}

/// Column `name` of `header`.
fn column(header: &[&str], name: &str) -> usize {
    header
        .iter()
        .position(|h| *h == name)
        .unwrap_or_else(|| panic!("no column {name} in {header:?}"))
}

#[test]
fn quick_past_depth_measures_every_schedule_and_progressive_beats_wrap() {
    let dir = tempfile::tempdir().unwrap();
    let output = Command::new(env!("CARGO_BIN_EXE_stbn-gen"))
        .args(["tradeoff", "--quick", "--only", "past-depth", "--out"])
        .arg(dir.path())
        .output()
        .expect("the binary runs");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let report = fs::read_to_string(dir.path().join("tradeoff.md")).unwrap();
    assert!(report.contains("knobs: past-depth)"), "{report}");
    assert!(report.contains("## 8. Past the depth"), "{report}");
    assert!(!report.contains("## 1."));
    for file in ["past-depth.md", "past-depth.png"] {
        assert!(dir.path().join(file).exists(), "{file}");
    }

    // Quick plan: 16×16 masks of 8 and 16 frames, counts 16 and 64.
    let text = fs::read_to_string(dir.path().join("past-depth.csv")).unwrap();
    let (header, rows) = csv(&text);
    let (mask, schedule, integrand) = (
        column(&header, "mask"),
        column(&header, "schedule"),
        column(&header, "integrand"),
    );
    let last = column(&header, "rmse_64_frames");
    let band = column(&header, "error_low_band");
    column(&header, "rmse_16_frames");
    // White noise once, then wrap and progressive per depth, each on three integrands.
    assert_eq!(rows.len(), 3 * (1 + 2 * 2));
    let rmse = |m: &str, s: &str, i: &str| -> f64 {
        let row = rows
            .iter()
            .find(|r| r[mask] == m && r[schedule] == s && r[integrand] == i)
            .unwrap_or_else(|| panic!("no row {m} {s} {i}"));
        row[last].parse().unwrap()
    };
    for i in ["ramp", "step", "sine"] {
        for m in ["16×16×8", "16×16×16"] {
            let wrap = rmse(m, "wrap (sample)", i);
            let progressive = rmse(m, "progressive (R2 epochs)", i);
            // 64 frames wrap an 8- or 16-frame mask 4 to 8 times: its error stays where it was
            // after `depth` frames, while progressive reads keep converging.
            assert!(progressive < wrap, "{m} {i}: {progressive} vs {wrap}");
            assert!(progressive > 0.0);
        }
        assert!(rmse("no mask", "white noise", i) > 0.0);
    }
    for row in &rows {
        let b: f64 = row[band].parse().unwrap();
        assert!(b.is_finite() && b >= 0.0, "{row:?}");
    }

    // The rejected schedules on the 8-frame mask, beside white noise, wrap and progressive, on
    // the asymmetric integrands.
    let text = fs::read_to_string(dir.path().join("past-depth_schedules.csv")).unwrap();
    let (header, rows) = csv(&text);
    let schedule = column(&header, "schedule");
    let mut names: Vec<&str> = rows.iter().map(|r| r[schedule]).collect();
    names.dedup();
    assert_eq!(
        names,
        [
            "white noise",
            "wrap (sample)",
            "progressive (R2 epochs)",
            "CP golden-ratio shift per epoch",
            "CP van der Corput shift",
            "R2 + van der Corput shift",
            "sunflower (local) offsets",
            "2×2 clusters of R2 offsets",
            "R2 + antithetic pairs",
        ]
    );
    assert_eq!(rows.len(), 9 * 3);
    let integrand = column(&header, "integrand");
    assert_eq!(
        rows[..3].iter().map(|r| r[integrand]).collect::<Vec<_>>(),
        ["step 0.37", "x²", "sin²(πx)"]
    );

    // Four samples per frame, after 4 and 16 frames.
    let text = fs::read_to_string(dir.path().join("past-depth_samples.csv")).unwrap();
    let (header, rows) = csv(&text);
    column(&header, "rmse_4_frames");
    column(&header, "rmse_16_frames");
    let samples = column(&header, "samples");
    let mut ways: Vec<&str> = rows.iter().map(|r| r[samples]).collect();
    ways.dedup();
    assert_eq!(
        ways,
        [
            "consecutive progressive frames",
            "R2 dimensions (progressive)",
            "R2 dimensions (wrap)",
            "white noise",
        ]
    );
    assert_eq!(rows.len(), 4 * 3);
}
