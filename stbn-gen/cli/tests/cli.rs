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

/// Writes `text` as `<dir>/assets.ron` and returns its path.
fn write_manifest(dir: &Path, text: &str) -> std::path::PathBuf {
    let manifest = dir.join("assets.ron");
    fs::write(&manifest, text).unwrap();
    manifest
}

/// The JSON sidecar `generate` wrote for vector mask `name` into `out`.
fn sidecar(out: &Path, name: &str) -> serde_json::Value {
    serde_json::from_str(&fs::read_to_string(out.join(format!("{name}/{name}.json"))).unwrap())
        .unwrap()
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
    // The figures table: its heading row and one row per mask.
    let rows: Vec<&str> = report[report.find("\n## Figures\n").unwrap()..]
        .lines()
        .skip_while(|l| !l.starts_with("| "))
        .take_while(|l| l.starts_with('|'))
        .filter(|l| l.starts_with("| "))
        .collect();
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

/// Reads one PNG slice: (color type, bit depth, samples widened to u16).
fn read_png(path: &Path) -> (png::ColorType, png::BitDepth, Vec<u16>) {
    let decoder = png::Decoder::new(std::io::BufReader::new(fs::File::open(path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    let bytes = &buf[..info.buffer_size()];
    let samples = match info.bit_depth {
        png::BitDepth::Sixteen => bytes
            .chunks_exact(2)
            .map(|b| u16::from_be_bytes([b[0], b[1]]))
            .collect(),
        _ => bytes.iter().map(|&b| u16::from(b)).collect(),
    };
    (info.color_type, info.bit_depth, samples)
}

#[test]
fn vector_masks_are_rgba_slices_with_the_pdf_in_alpha_and_a_sidecar_with_the_trace() {
    let dir = tempfile::tempdir().unwrap();
    // A 4×2 gray image: one bright pixel, the rest dim, so the pdf varies.
    let image = dir.path().join("kernel.png");
    let mut encoder = png::Encoder::new(fs::File::create(&image).unwrap(), 4, 2);
    encoder.set_color(png::ColorType::Grayscale);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().unwrap();
    writer
        .write_image_data(&[255, 20, 20, 20, 20, 20, 20, 20])
        .unwrap();
    writer.finish().unwrap();
    let manifest = dir.path().join("assets.ron");
    fs::write(
        &manifest,
        r#"(masks: [
            (name: "points", kind: ImagePoints, size: (8, 8, 4), seed: 1, encoding: Unorm8,
             image: "kernel.png"),
            (name: "dirs", kind: UnitVec3, size: (8, 8, 4), seed: 2, encoding: Unorm16,
             octahedral: false),
        ])"#,
    )
    .unwrap();
    let out = dir.path().join("out");
    let output = stbn_gen(&["generate".as_ref(), &manifest, "--out".as_ref(), &out]);
    assert!(output.status.success(), "{}", text(&output.stderr));

    // ImagePoints: x, y in R, G; B unused; the normalised pdf in A, spanning its full range.
    let (color, depth, px) = read_png(&out.join("points/points_0.png"));
    assert_eq!((color, depth), (png::ColorType::Rgba, png::BitDepth::Eight));
    assert_eq!(px.len(), 8 * 8 * 4);
    assert!(px.chunks_exact(4).all(|p| p[2] == 0), "B is unused");
    let alphas: Vec<u16> = px.chunks_exact(4).map(|p| p[3]).collect();
    assert!(alphas.iter().any(|&a| a < 255), "{alphas:?}");
    // UnitVec3 without octahedral: x, y, z as v·0.5+0.5 in R, G, B; A full scale.
    let (color, depth, px) = read_png(&out.join("dirs/dirs_3.png"));
    assert_eq!(
        (color, depth),
        (png::ColorType::Rgba, png::BitDepth::Sixteen)
    );
    for p in px.chunks_exact(4) {
        assert_eq!(p[3], u16::MAX);
        let v: Vec<f64> = p[..3]
            .iter()
            .map(|&q| (f64::from(q) + 0.5) / 65536.0 * 2.0 - 1.0)
            .collect();
        let norm = v.iter().map(|c| c * c).sum::<f64>().sqrt();
        assert!((norm - 1.0).abs() < 1e-3, "{v:?}");
    }

    let sidecar = sidecar(&out, "points");
    assert_eq!(sidecar["pdf_channel"], 2);
    assert_eq!(
        sidecar["png_layout"],
        "R: channel 0, G: channel 1, B: 0, A: channel 2 (pdf)"
    );
    let trace = sidecar["trace"].as_array().unwrap();
    assert!(trace.len() >= 2, "{sidecar}");
    let energy = |i: usize| trace[i]["energy"].as_f64().unwrap();
    assert!(energy(trace.len() - 1) <= energy(0), "{sidecar}");
    assert!(out.join("points/points_trace.csv").exists());
}

#[test]
fn sidecars_name_the_parameters_that_made_the_mask() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = write_manifest(
        dir.path(),
        r#"(masks: [
            (name: "fa", kind: FilterAdapted, size: (8, 8, 4), seed: 1, encoding: Unorm8,
             space: Vec2, swaps_per_pixel: 1),
            (name: "v", kind: Vec2, size: (8, 8, 4), seed: 1, encoding: Unorm8,
             swaps_per_pixel: 1, assignment_passes: 2),
        ])"#,
    );
    let out = dir.path().join("out");
    let output = stbn_gen(&["generate".as_ref(), &manifest, "--out".as_ref(), &out]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let (fa, v) = (sidecar(&out, "fa"), sidecar(&out, "v"));
    assert!(fa["filter"].as_str().unwrap().contains("Gaussian"), "{fa}");
    assert!(
        fa.get("sigma_image").is_none() && fa.get("sigma_value").is_none(),
        "{fa}"
    );
    assert_eq!(v["sigma_image"], 1.9, "{v}");
    assert!(v.get("filter").is_none(), "{v}");
    // One trace row per swap pass and per assignment pass, after the start.
    assert_eq!(v["assignment_passes"], 2, "{v}");
    assert_eq!(v["trace"].as_array().unwrap().len(), 1 + 1 + 2, "{v}");
    assert!(fa.get("assignment_passes").is_none(), "{fa}");
}

#[test]
fn swaps_per_pixel_overrides_the_budget_of_swap_optimised_masks_only() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = write_manifest(
        dir.path(),
        r#"(masks: [
            (name: "v", kind: Vec2, size: (16, 16, 8), seed: 1, encoding: Unorm8,
             swaps_per_pixel: 6),
            (name: "fa", kind: FilterAdapted, size: (8, 8, 4), seed: 1, encoding: Unorm8,
             space: Vec2, swaps_per_pixel: 6),
            (name: "s", kind: Scalar, size: (16, 16, 8), seed: 1, encoding: Unorm8),
        ])"#,
    );
    // Swaps attempted after the swap passes (the assignment passes follow them in the trace).
    let attempted = |sidecar: &serde_json::Value, swap_passes: usize| {
        let trace = sidecar["trace"].as_array().unwrap();
        let passes = sidecar["assignment_passes"].as_u64().unwrap() as usize;
        assert_eq!(trace.len(), 1 + swap_passes + passes, "{sidecar}");
        trace[swap_passes]["swaps_attempted"].as_u64().unwrap()
    };
    let (full, quick) = (dir.path().join("full"), dir.path().join("quick"));
    let output = stbn_gen(&["generate".as_ref(), &manifest, "--out".as_ref(), &full]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let output = stbn_gen(&[
        "generate".as_ref(),
        &manifest,
        "--out".as_ref(),
        &quick,
        "--swaps-per-pixel".as_ref(),
        "2".as_ref(),
    ]);
    assert!(output.status.success(), "{}", text(&output.stderr));

    // Every pixel proposes once per pass: 6 passes from the manifest, 2 with the flag.
    let pixels = 16 * 16 * 8;
    assert_eq!(sidecar(&full, "v")["swaps_per_pixel"], 6.0);
    assert_eq!(attempted(&sidecar(&full, "v"), 6), 6 * pixels);
    assert_eq!(sidecar(&quick, "v")["swaps_per_pixel"], 2.0);
    assert_eq!(attempted(&sidecar(&quick, "v"), 2), 2 * pixels);
    assert_eq!(sidecar(&full, "fa")["swaps_per_pixel"], 6.0);
    assert_eq!(sidecar(&quick, "fa")["swaps_per_pixel"], 2.0);
    let report = fs::read_to_string(quick.join("report.md")).unwrap();
    assert!(report.contains("ran 2 swaps per pixel"), "{report}");
    // The scalar mask has no budget and comes out the same.
    let slices = |out: &Path| read_slices_png(&out.join("s")).unwrap();
    assert_eq!(slices(&full), slices(&quick));

    for bad in ["-1", "10001", "NaN", "many"] {
        let output = stbn_gen(&[
            "generate".as_ref(),
            &manifest,
            "--out".as_ref(),
            &quick,
            "--swaps-per-pixel".as_ref(),
            bad.as_ref(),
        ]);
        let stderr = text(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{bad}: {stderr}");
        assert!(
            stderr.contains("--swaps-per-pixel") && stderr.contains("0..=10000"),
            "{bad}: {stderr}"
        );
    }
}

#[test]
fn stbn_blobs_are_the_bytes_build_support_embeds() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = write_manifest(
        dir.path(),
        r#"(masks: [
            (name: "scalar", kind: Scalar, size: (16, 16, 8), seed: 1, encoding: Unorm8),
            (name: "blue2d_lz4", kind: Blue2D, size: (16, 8, 4), seed: 2, encoding: Unorm16,
             compression: Lz4),
            (name: "white_deflate", kind: White, size: (8, 8, 4), seed: 3, encoding: F32,
             compression: Deflate),
            (name: "cosine", kind: CosineHemisphere, size: (8, 8, 4), seed: 4, encoding: Unorm8,
             swaps_per_pixel: 4),
            (name: "fa_vec2", kind: FilterAdapted, size: (8, 8, 4), seed: 5, encoding: Unorm16,
             space: Vec2, swaps_per_pixel: 4, compression: Lz4),
        ])"#,
    );
    let out = dir.path().join("out");
    let output = stbn_gen(&[
        "generate".as_ref(),
        &manifest,
        "--out".as_ref(),
        &out,
        "--format".as_ref(),
        "stbn".as_ref(),
    ]);
    assert!(output.status.success(), "{}", text(&output.stderr));

    let embedded = stbn_build_support::embed_with(&stbn_build_support::EmbedConfig {
        manifest,
        out_dir: dir.path().join("embedded"),
        cache: stbn_build_support::Cache::new(dir.path().join("cache")),
    })
    .unwrap();
    assert_eq!(embedded.masks.len(), 5);
    for mask in &embedded.masks {
        let written = fs::read(out.join(format!("{}.stbn", mask.name))).unwrap();
        assert_eq!(written, fs::read(&mask.blob_path).unwrap(), "{}", mask.name);
        // Only the blob: no slice folder, no sidecar.
        assert!(!out.join(&mask.name).exists(), "{}", mask.name);
        assert!(
            !out.join(format!("{}.json", mask.name)).exists(),
            "{}",
            mask.name
        );
    }
    let report = fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("`.stbn` blobs `<name>.stbn`"), "{report}");
    // A codec that does not shrink a mask is dropped, and said so: never a silent no-op.
    let stderr = text(&output.stderr);
    let mut dropped = 0;
    for (name, codec) in [
        ("blue2d_lz4", "Lz4"),
        ("white_deflate", "Deflate"),
        ("fa_vec2", "Lz4"),
    ] {
        let blob = fs::read(out.join(format!("{name}.stbn"))).unwrap();
        let header = stbn_runtime::MaskHeader::parse(&blob).unwrap();
        let warning = format!("warning: mask \"{name}\": `compression: {codec}` does not make");
        assert_eq!(
            header.compression.is_none(),
            stderr.contains(&warning),
            "{name}: {stderr}"
        );
        dropped += usize::from(header.compression.is_none());
    }
    assert!(
        dropped > 0,
        "no codec was dropped: the check above tested nothing"
    );
}

/// The blobs stbn-runtime's doctests and tests embed with `include_stbn!`: regenerating each from
/// its manifest must give the committed bytes, or the committed file has gone stale.
#[test]
fn the_runtime_test_blobs_are_what_generate_writes_for_their_manifests() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stbn-runtime/tests/data");
    for name in ["scalar_16", "cosine_8"] {
        let dir = tempfile::tempdir().unwrap();
        let output = stbn_gen(&[
            "generate".as_ref(),
            &data.join(format!("{name}.ron")),
            "--out".as_ref(),
            dir.path(),
            "--format".as_ref(),
            "stbn".as_ref(),
        ]);
        assert!(output.status.success(), "{}", text(&output.stderr));
        let committed = fs::read(data.join(format!("{name}.stbn"))).unwrap();
        assert_eq!(
            fs::read(dir.path().join(format!("{name}.stbn"))).unwrap(),
            committed,
            "regenerate stbn-runtime/tests/data/{name}.stbn with `stbn-gen generate \
             stbn-runtime/tests/data/{name}.ron --format stbn` (and, for scalar_16, \
             truncated.stbn: its first 100 bytes)"
        );
        if name == "scalar_16" {
            let truncated = fs::read(data.join("truncated.stbn")).unwrap();
            assert_eq!(truncated, committed[..100]);
        }
    }
}

#[test]
fn the_report_opens_with_a_reading_guide_and_judges_vector_masks_in_their_own_space() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = write_manifest(
        dir.path(),
        r#"(masks: [
            (name: "scalar_16", kind: Scalar, size: (16, 16, 8), seed: 1, encoding: Unorm8),
            (name: "cosine_16", kind: CosineHemisphere, size: (16, 16, 8), seed: 1,
             encoding: Unorm8, swaps_per_pixel: 8),
        ])"#,
    );
    let out = dir.path().join("out");
    let output = stbn_gen(&["generate".as_ref(), &manifest, "--out".as_ref(), &out]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let report = fs::read_to_string(out.join("report.md")).unwrap();
    let order = [
        "## How to read this report\n",
        "## Verdict\n",
        "## Which mask to pick\n",
        "## Figures\n",
        "## Vector masks in their own space\n",
    ];
    let at: Vec<usize> = order
        .iter()
        .map(|h| {
            report
                .find(h)
                .unwrap_or_else(|| panic!("{h:?} in {report}"))
        })
        .collect();
    assert!(at.windows(2).all(|w| w[0] < w[1]), "{report}");
    assert!(
        report.contains("White noise = 1; lower is better"),
        "{report}"
    );
    let verdict = |name: &str| {
        let prefix = format!("- `{name}` (");
        report
            .lines()
            .find(|l| l.starts_with(&prefix))
            .unwrap_or_else(|| panic!("no verdict for {name} in {report}"))
            .to_owned()
    };
    let scalar = verdict("scalar_16");
    assert!(scalar.contains("blue in space and time"), "{scalar}");
    assert!(scalar.contains("(white noise = 1)"), "{scalar}");
    // The cosine hemisphere follows its own pdf exactly in every frame (its stored octahedral
    // channel does not, which is not what it is for) and integrates better than white noise of
    // its distribution.
    let cosine = verdict("cosine_16");
    assert!(
        cosine.contains("every frame follows the space's pdf exactly"),
        "{cosine}"
    );
    assert!(
        cosine.contains("that of white noise of the same distribution"),
        "{cosine}"
    );
    assert!(!cosine.contains("⚠ its test functions"), "{cosine}");
    let row = report
        .lines()
        .find(|l| l.starts_with("| cosine_16 | 16×16×8 |"))
        .unwrap();
    let cells: Vec<&str> = row.split('|').map(str::trim).collect();
    assert_eq!(cells[7], "0.0000", "frame histogram deviation: {row}");
    assert!(
        report.contains("| cosine_16 | cosine_hemisphere | z |"),
        "{report}"
    );
    assert!(out.join("csv/vector_convergence.csv").exists());
    assert!(out.join("plots/vector_01_cosine_16.png").exists());
}
