//! `stbn-gen tradeoff --quick` end to end: every file it promises exists and parses, and the
//! relations that must hold between its figures do.

use std::collections::BTreeMap;
use std::fs;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

/// A parsed CSV file: header and rows (RFC 4180 quoting, no line breaks inside fields).
struct Csv {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Csv {
    fn read(path: &Path) -> Csv {
        let text = fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let mut lines = text.lines().map(split);
        let header = lines.next().expect("a header row");
        let rows: Vec<Vec<String>> = lines.collect();
        for row in &rows {
            assert_eq!(row.len(), header.len(), "{}: {row:?}", path.display());
        }
        Csv { header, rows }
    }

    fn column(&self, name: &str) -> usize {
        self.header
            .iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("no column {name} in {:?}", self.header))
    }

    /// Column `name` of every row.
    fn get<'a>(&'a self, name: &str) -> impl Iterator<Item = &'a str> + 'a {
        let c = self.column(name);
        self.rows.iter().map(move |r| r[c].as_str())
    }

    /// Column `name` of every row as numbers (every field must be one).
    fn numbers(&self, name: &str) -> Vec<f64> {
        self.get(name)
            .map(|f| {
                f.parse()
                    .unwrap_or_else(|_| panic!("{name}: {f:?} is not a number"))
            })
            .collect()
    }
}

fn split(line: &str) -> Vec<String> {
    let mut fields = vec![String::new()];
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match (c, quoted) {
            ('"', true) if chars.peek() == Some(&'"') => {
                chars.next();
                fields.last_mut().unwrap().push('"');
            }
            ('"', _) => quoted = !quoted,
            (',', false) => fields.push(String::new()),
            (c, _) => fields.last_mut().unwrap().push(c),
        }
    }
    fields
}

#[test]
fn quick_tradeoff_writes_every_table_and_plot_and_its_figures_hold_together() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("tradeoff");
    let start = Instant::now();
    let output = Command::new(env!("CARGO_BIN_EXE_stbn-gen"))
        .args(["tradeoff", "--quick", "--out"])
        .arg(&out)
        .output()
        .expect("the binary runs");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    eprintln!(
        "tradeoff --quick took {:.1} s",
        start.elapsed().as_secs_f64()
    );

    // tradeoff.md gathers every section, and every file it links exists and parses.
    let report = fs::read_to_string(out.join("tradeoff.md")).unwrap();
    for section in [
        "## 1. Mask size and depth",
        "## 2. σ and the kernel truncation tolerance",
        "## 3. Vector swap budget",
        "## 4. Encoding",
        "## 5. Compression",
        "## 6. One thread against two",
        "## 7. Scale targets",
        "## 8. Past the depth",
    ] {
        assert!(report.contains(section), "{section} missing");
    }
    let links: Vec<&str> = report
        .split("](")
        .skip(1)
        .map(|rest| &rest[..rest.find(')').unwrap()])
        .collect();
    let (mut csvs, mut pngs) = (0, 0);
    for link in &links {
        let path = out.join(link);
        if link.ends_with(".csv") {
            Csv::read(&path);
            csvs += 1;
        } else if link.ends_with(".png") {
            let decoder =
                png::Decoder::new(std::io::BufReader::new(fs::File::open(&path).unwrap()));
            let mut reader = decoder.read_info().unwrap();
            let mut pixels = vec![0; reader.output_buffer_size().unwrap()];
            reader.next_frame(&mut pixels).unwrap();
            // Not blank: a plot has white background and coloured curves.
            assert!(pixels.iter().any(|&p| p != 255), "{link} is blank");
            pngs += 1;
        } else {
            panic!("unexpected link {link}");
        }
    }
    assert_eq!(csvs, 11, "{links:?}");
    assert_eq!(pngs, 9, "{links:?}");
    for knob in [
        "size",
        "kernel",
        "swaps",
        "encoding",
        "compression",
        "threads",
        "scale",
        "past-depth",
    ] {
        let md = fs::read_to_string(out.join(format!("{knob}.md"))).unwrap();
        assert!(
            md.contains("| ---") || md.contains("|---"),
            "{knob}.md has no table"
        );
    }

    // Size: one row per size and depth, with time and quality figures.
    let size = Csv::read(&out.join("size.csv"));
    assert_eq!(size.rows.len(), 4);
    assert!(size.numbers("seconds").iter().all(|&s| s > 0.0));
    for f in size.numbers("filtered_error_last_frame") {
        // Blue noise beats white noise (≈ 0.0197) on EA's metric.
        assert!(f > 0.0 && f < 0.0197, "{f}");
    }

    // Swap budget: for each space, a bigger budget never ends at a higher energy (each run of b
    // whole swaps per pixel is the first b passes of a longer one, and every accepted swap lowers
    // the energy), and the integer budgets match the long run's trace bit for bit.
    let swaps = Csv::read(&out.join("swaps.csv"));
    let mut by_space: BTreeMap<&str, Vec<(f64, f64)>> = BTreeMap::new();
    let budgets = swaps.numbers("swaps_per_pixel");
    let energies = swaps.numbers("energy");
    for (i, space) in swaps.get("space").enumerate() {
        by_space
            .entry(space)
            .or_default()
            .push((budgets[i], energies[i]));
    }
    assert_eq!(
        by_space.keys().copied().collect::<Vec<_>>(),
        ["UnitVec3", "Vec2"]
    );
    for (space, mut points) in by_space {
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        assert!(points.len() >= 4, "{space}: {points:?}");
        for pair in points.windows(2) {
            assert!(pair[1].1 <= pair[0].1, "{space}: energy rose: {pair:?}");
        }
        assert!(
            points.last().unwrap().1 < points[0].1,
            "{space}: no swap kept"
        );
    }
    for same in swaps.get("same_as_longest_run_trace") {
        assert!(same == "yes" || same.is_empty(), "{same}");
    }
    let trace = Csv::read(&out.join("swaps_trace.csv"));
    assert!(
        trace
            .numbers("excess_over_final_percent")
            .iter()
            .all(|&e| e >= 0.0)
    );

    // Encoding: Unorm values decode to bin midpoints. A vector component is stored in the level
    // that holds it, so it is off by at most half a bin. A scalar value (r + 0.5) / n (rank r of
    // a slice of n pixels) is stored as level floor(r · 2^bits / n): within half a bin where
    // n ≥ 2^bits, off by 1/(2n) − 2^−(bits+1) where n < 2^bits. F32 keeps f32 rounding.
    let encoding = Csv::read(&out.join("encoding.csv"));
    let masks: Vec<&str> = encoding.get("mask").collect();
    let layouts: Vec<&str> = encoding.get("layout").collect();
    let encodings: Vec<&str> = encoding.get("encoding").collect();
    let units: Vec<&str> = encoding.get("error_unit").collect();
    let max_error: Vec<&str> = encoding.get("max_error").collect();
    let mut checked = 0;
    for i in 0..encoding.rows.len() {
        if units[i] != "value" || layouts[i] == "generated values" {
            continue;
        }
        let e: f64 = max_error[i].parse().unwrap();
        let half_bin: f64 = match encodings[i] {
            "Unorm8" => 0.5 / 256.0,
            "Unorm16" => 0.5 / 65536.0,
            "F32" => 0.0,
            other => panic!("encoding {other}"),
        };
        let bound = match masks[i].strip_prefix("scalar ") {
            Some(size) if half_bin > 0.0 => {
                let axes: Vec<f64> = size.split('×').map(|a| a.parse().unwrap()).collect();
                let n = axes[0] * axes[1];
                half_bin.max(0.5 / n - half_bin)
            }
            _ => half_bin,
        };
        assert!(
            e <= bound + 1e-7,
            "{} {}: {e} > {bound}",
            masks[i],
            encodings[i]
        );
        checked += 1;
    }
    assert_eq!(checked, 6);

    // Compression: every compression of a mask decodes to the same bytes; an uncompressed blob
    // is the payload plus the 64-byte header.
    let compression = Csv::read(&out.join("compression.csv"));
    let decoded = compression.numbers("decoded_bytes");
    let embedded = compression.numbers("embedded_bytes");
    for (i, kind) in compression.get("compression").enumerate() {
        if kind == "None" {
            assert_eq!(embedded[i], decoded[i] + 64.0);
        }
        assert_eq!(decoded[i], decoded[i - i % 4]);
    }
    assert!(
        compression
            .numbers("decode_seconds")
            .iter()
            .all(|&s| s > 0.0)
    );

    // Threads: the same masks on 1 and 2 threads: the scalar mask and 12 swap-optimised
    // kinds, each a 1-thread row then an identical 2-thread row.
    let threads = Csv::read(&out.join("threads.csv"));
    let identical: Vec<&str> = threads.get("identical_to_1_thread").collect();
    assert_eq!(identical, ["", "yes"].repeat(13));

    // Scale: quick mode has no targets, but measures time and the estimate.
    let scale = Csv::read(&out.join("scale.csv"));
    assert_eq!(scale.rows.len(), 2);
    assert!(scale.get("target_seconds").all(str::is_empty));
    assert!(scale.numbers("estimate_bytes").iter().all(|&b| b > 0.0));
}

/// `stbn-gen tradeoff --quick --only <knobs>` into a fresh folder, which must succeed: the
/// folder and its `tradeoff.md`.
fn quick_only(knobs: &str) -> (tempfile::TempDir, String) {
    let dir = tempfile::tempdir().unwrap();
    let output = Command::new(env!("CARGO_BIN_EXE_stbn-gen"))
        .args(["tradeoff", "--quick", "--only", knobs, "--out"])
        .arg(dir.path())
        .output()
        .expect("the binary runs");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let report = fs::read_to_string(dir.path().join("tradeoff.md")).unwrap();
    (dir, report)
}

/// `--only past-depth`: the section's three tables hold every row, and the relations that must
/// hold between their figures do.
#[test]
fn quick_past_depth_measures_every_schedule_and_progressive_beats_wrap() {
    let (dir, report) = quick_only("past-depth");
    assert!(report.contains("knobs: past-depth)"), "{report}");
    assert!(report.contains("## 8. Past the depth"), "{report}");
    assert!(!report.contains("## 1."));
    for file in ["past-depth.md", "past-depth.png"] {
        assert!(dir.path().join(file).exists(), "{file}");
    }

    // Quick plan: 16×16 masks of 8 and 16 frames, counts 16 and 64.
    let table = Csv::read(&dir.path().join("past-depth.csv"));
    let rows = &table.rows;
    let (mask, schedule, integrand) = (
        table.column("mask"),
        table.column("schedule"),
        table.column("integrand"),
    );
    let last = table.column("rmse_64_frames");
    let band = table.column("error_low_band");
    table.column("rmse_16_frames");
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
    for row in rows {
        let b: f64 = row[band].parse().unwrap();
        assert!(b.is_finite() && b >= 0.0, "{row:?}");
    }

    // The rejected schedules on the 8-frame mask, beside white noise, wrap and progressive, on
    // the asymmetric integrands.
    let table = Csv::read(&dir.path().join("past-depth_schedules.csv"));
    let rows = &table.rows;
    let schedule = table.column("schedule");
    let mut names: Vec<&str> = rows.iter().map(|r| r[schedule].as_str()).collect();
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
    let integrand = table.column("integrand");
    assert_eq!(
        rows[..3]
            .iter()
            .map(|r| r[integrand].as_str())
            .collect::<Vec<_>>(),
        ["step 0.37", "x²", "sin²(πx)"]
    );

    // Four samples per frame, after 4 and 16 frames.
    let table = Csv::read(&dir.path().join("past-depth_samples.csv"));
    let rows = &table.rows;
    table.column("rmse_4_frames");
    table.column("rmse_16_frames");
    let samples = table.column("samples");
    let mut ways: Vec<&str> = rows.iter().map(|r| r[samples].as_str()).collect();
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

#[test]
fn only_runs_the_named_knobs() {
    let (dir, report) = quick_only("threads,size");
    assert!(report.contains("knobs: size, threads)"), "{report}");
    assert!(!report.contains("## 3."));
    assert!(!dir.path().join("swaps.csv").exists());
    let bad = Command::new(env!("CARGO_BIN_EXE_stbn-gen"))
        .args(["tradeoff", "--quick", "--only", "colour", "--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));
}
