//! Every kind of manifest mistake is reported at the right line and column, naming the field.

use stbn_build_support::{Error, Manifest, ManifestError};

/// A valid manifest; each case below edits one of its lines.
const BASE: &str = r#"(
    masks: [
        (
            name: "first",
            kind: Scalar,
            size: (16, 16, 8),
            seed: 1,
            encoding: Unorm8,
        ),
        (
            name: "foo",
            sigma: 1.9,
            kind: Blue2D,
            size: (16, 16, 8),
            seed: 2,
            density: 0.1,
            encoding: Unorm8,
            compression: Lz4,
        ),
    ],
)
"#;

/// `BASE` with 1-based line `line` replaced by `text`.
fn edit(line: usize, text: &str) -> String {
    let mut lines: Vec<&str> = BASE.lines().collect();
    lines[line - 1] = text;
    lines.join("\n") + "\n"
}

fn error(text: &str) -> ManifestError {
    match Manifest::parse(text, "assets.ron") {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e,
    }
}

struct Case {
    what: &'static str,
    line: usize,
    replacement: &'static str,
    /// Expected line and column.
    at: (usize, usize),
    field: Option<&'static str>,
    mask: Option<&'static str>,
    message: &'static str,
}

const CASES: &[Case] = &[
    Case {
        what: "syntax error: missing comma",
        line: 15,
        replacement: "            seed: 2",
        at: (15, 20),
        field: Some("seed"),
        mask: Some("foo"),
        message: "expected `,` after this field's value",
    },
    Case {
        what: "syntax error: stray character",
        line: 6,
        replacement: "            size: (16, 16; 8),",
        at: (6, 26),
        field: Some("size"),
        mask: Some("first"),
        message: "expected comma",
    },
    Case {
        what: "unknown field",
        line: 16,
        replacement: "            dencity: 0.1,",
        at: (16, 13),
        field: Some("dencity"),
        mask: Some("foo"),
        message: "unknown field; expected one of `name`, `kind`, `size`, `seed`, `sigma`",
    },
    Case {
        what: "misspelt field",
        line: 16,
        replacement: "            densty: 0.1,",
        at: (16, 13),
        field: Some("densty"),
        mask: Some("foo"),
        message: "; did you mean `density`?",
    },
    Case {
        what: "field with swapped letters",
        line: 18,
        replacement: "            compresison: Lz4,",
        at: (18, 13),
        field: Some("compresison"),
        mask: Some("foo"),
        message: "; did you mean `compression`?",
    },
    Case {
        what: "field in another case",
        line: 12,
        replacement: "            Sigma: 1.9,",
        at: (12, 13),
        field: Some("Sigma"),
        mask: Some("foo"),
        message: "; did you mean `sigma`?",
    },
    Case {
        what: "misspelt top-level field",
        line: 2,
        replacement: "    mask: [",
        at: (2, 5),
        field: Some("mask"),
        mask: None,
        message: "unknown field; expected one of `masks`; did you mean `masks`?",
    },
    Case {
        what: "misspelt kind",
        line: 13,
        replacement: "            kind: Scalr,",
        at: (13, 19),
        field: Some("kind"),
        mask: Some("foo"),
        message: "; did you mean `Scalar`?",
    },
    Case {
        what: "misspelt compression",
        line: 18,
        replacement: "            compression: LZ4,",
        at: (18, 26),
        field: Some("compression"),
        mask: Some("foo"),
        message: "; did you mean `Lz4`?",
    },
    Case {
        what: "unknown top-level field",
        line: 2,
        replacement: "    maskz: [",
        at: (2, 5),
        field: Some("maskz"),
        mask: None,
        message: "unknown field; expected one of `masks`",
    },
    Case {
        what: "wrong type: string for integer",
        line: 15,
        replacement: "            seed: \"two\",",
        at: (15, 19),
        field: Some("seed"),
        mask: Some("foo"),
        message: "expected integer",
    },
    Case {
        what: "wrong type: unknown kind",
        line: 13,
        replacement: "            kind: Scalr,",
        at: (13, 19),
        field: Some("kind"),
        mask: Some("foo"),
        message: "`Scalr`",
    },
    Case {
        what: "wrong type: number for encoding",
        line: 8,
        replacement: "            encoding: 8,",
        at: (8, 23),
        field: Some("encoding"),
        mask: Some("first"),
        message: "expected one of `Unorm8`, `Unorm16`, `F32`",
    },
    Case {
        what: "wrong type: two-element size",
        line: 6,
        replacement: "            size: (16, 16),",
        at: (6, 26),
        field: Some("size"),
        mask: Some("first"),
        message: "a tuple of size 3",
    },
    Case {
        what: "axis beyond u32",
        line: 14,
        replacement: "            size: (16, 16, 5000000000),",
        at: (14, 28),
        field: Some("size"),
        mask: Some("foo"),
        message: "each element must be in 1..=65536 (got 5000000000)",
    },
    Case {
        what: "missing field",
        line: 15,
        replacement: "",
        at: (19, 9),
        field: Some("seed"),
        mask: Some("foo"),
        message: "missing; this field has no default",
    },
    Case {
        what: "field given twice",
        line: 16,
        replacement: "            seed: 3,",
        at: (16, 13),
        field: Some("seed"),
        mask: Some("foo"),
        message: "given more than once",
    },
    Case {
        what: "duplicate name",
        line: 11,
        replacement: "            name: \"first\",",
        at: (11, 19),
        field: Some("name"),
        mask: Some("first"),
        message: "duplicates mask \"first\" (line 4): both would become the static FIRST",
    },
    Case {
        what: "duplicate name after upper-casing",
        line: 11,
        replacement: "            name: \"First\",",
        at: (11, 19),
        field: Some("name"),
        mask: Some("First"),
        message: "duplicates mask \"first\" (line 4)",
    },
    Case {
        what: "name that is not an identifier",
        line: 11,
        replacement: "            name: \"3d-mask\",",
        at: (11, 19),
        field: Some("name"),
        mask: Some("3d-mask"),
        message: "\"3d-mask\" is not a Rust identifier",
    },
    Case {
        what: "name that is a keyword",
        line: 4,
        replacement: "            name: \"type\",",
        at: (4, 19),
        field: Some("name"),
        mask: Some("type"),
        message: "\"type\" is a Rust keyword",
    },
    Case {
        what: "zero size",
        line: 14,
        replacement: "            size: (16, 0, 8),",
        at: (14, 19),
        field: Some("size"),
        mask: Some("foo"),
        message: "height (second element) is 0; it must be in 1..=65536",
    },
    Case {
        what: "huge size",
        line: 6,
        replacement: "            size: (65536, 65536, 64),",
        at: (6, 19),
        field: Some("size"),
        mask: Some("first"),
        message: "`size` 65536x65536x64 is too large: generating it would take about 5120.0 GiB; \
                  the limits are 16777216 pixels per slice and 67108864 pixels per volume",
    },
    Case {
        what: "NaN sigma",
        line: 12,
        replacement: "            sigma: NaN,",
        at: (12, 20),
        field: Some("sigma"),
        mask: Some("foo"),
        message: "must be finite and > 0 (got NaN)",
    },
    Case {
        what: "infinite sigma",
        line: 12,
        replacement: "            sigma: inf,",
        at: (12, 20),
        field: Some("sigma"),
        mask: Some("foo"),
        message: "must be finite and > 0 (got inf)",
    },
    Case {
        what: "negative sigma_time",
        line: 16,
        replacement: "            sigma_time: -2.0,",
        at: (16, 25),
        field: Some("sigma_time"),
        mask: Some("foo"),
        message: "must be finite and > 0 (got -2)",
    },
    Case {
        what: "density above 0.5",
        line: 16,
        replacement: "            density: 0.7,",
        at: (16, 22),
        field: Some("density"),
        mask: Some("foo"),
        message: "must be in (0, 0.5] (got 0.7)",
    },
    Case {
        what: "zero density",
        line: 16,
        replacement: "            density: 0.0,",
        at: (16, 22),
        field: Some("density"),
        mask: Some("foo"),
        message: "must be in (0, 0.5] (got 0)",
    },
    Case {
        what: "kernel tolerance out of range",
        line: 16,
        replacement: "            kernel_tolerance: 0.0,",
        at: (16, 31),
        field: Some("kernel_tolerance"),
        mask: Some("foo"),
        message: "must be in (0, 1) (got 0)",
    },
];

#[test]
fn the_base_manifest_is_valid() {
    let manifest = Manifest::parse(BASE, "assets.ron").unwrap();
    let names: Vec<&str> = manifest.masks().iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["first", "foo"]);
}

#[test]
fn each_mistake_is_located_and_named() {
    let mut failures = Vec::new();
    for case in CASES {
        let text = edit(case.line, case.replacement);
        let err = error(&text);
        let display = err.to_string();
        let ok = (err.line(), err.column()) == case.at
            && err.field() == case.field
            && err.mask_name() == case.mask
            && err.path().to_str() == Some("assets.ron")
            && err.message().contains(case.message)
            && display.starts_with(&format!("assets.ron:{}:{}: ", case.at.0, case.at.1))
            && case
                .field
                .is_none_or(|f| display.contains(&format!("field `{f}`: ")));
        if !ok {
            failures.push(format!(
                "{}: expected {:?} field {:?} mask {:?} message ~{:?}\n    got {display}",
                case.what, case.at, case.field, case.mask, case.message
            ));
        }
    }
    assert!(failures.is_empty(), "\n{}", failures.join("\n"));
}

#[test]
fn no_suggestion_for_a_name_far_from_every_field() {
    let err = error(&edit(16, "            flavour: 0.1,"));
    assert_eq!((err.line(), err.field()), (16, Some("flavour")));
    assert!(
        err.message()
            .starts_with("unknown field; expected one of `name`")
    );
    assert!(!err.message().contains("did you mean"), "{err}");
    let err = error(&edit(13, "            kind: Noise,"));
    assert_eq!((err.line(), err.field()), (13, Some("kind")));
    assert!(!err.message().contains("did you mean"), "{err}");
}

#[test]
fn misspelt_field_names_file_line_field_and_the_fix() {
    let err = error(&edit(16, "            densty: 0.1,"));
    assert_eq!(
        err.to_string(),
        "assets.ron:16:13: mask \"foo\", field `densty`: unknown field; expected one of `name`, \
         `kind`, `size`, `seed`, `sigma`, `sigma_time`, `density`, `kernel_tolerance`, \
         `sigma_value`, `swaps_per_pixel`, `assignment_passes`, `image`, `octahedral`, \
         `spatial_filter`, `temporal_filter`, `filter_combination`, `space`, `encoding`, \
         `compression`; did you mean `density`?"
    );
}

#[test]
fn display_matches_the_documented_format() {
    let err = error(&edit(12, "            sigma: NaN,"));
    assert_eq!(
        err.to_string(),
        "assets.ron:12:20: mask \"foo\", field `sigma`: must be finite and > 0 (got NaN)"
    );
    assert_eq!(err.mask_index(), Some(1));
}

#[test]
fn the_first_problem_in_document_order_is_reported() {
    let text = edit(4, "            name: \"fn\",").replace("sigma: 1.9", "sigma: -1.0");
    let err = error(&text);
    assert_eq!((err.line(), err.field()), (4, Some("name")));
}

#[test]
fn unclosed_manifest_reports_the_end() {
    let text = BASE.trim_end().trim_end_matches(')');
    let err = error(text);
    assert_eq!(
        err.to_string(),
        "assets.ron:21:1: the file ends early: the `(` at line 1, column 1 is never closed"
    );
    assert!(err.mask_name().is_none());
}

#[test]
fn a_manifest_cut_short_names_the_bracket_left_open() {
    // Cut right after the list opens: not "expected opening `(` for struct `Mask`".
    assert_eq!(
        error("(masks: [").to_string(),
        "assets.ron:1:10: the file ends early: the `[` of the `masks` list at line 1, column 9 \
         is never closed"
    );
    assert_eq!(
        error("(\n    masks: [\n  // a comment\n").to_string(),
        "assets.ron:4:1: the file ends early: the `[` of the `masks` list at line 2, column 12 \
         is never closed"
    );
    // Inside an entry, after a complete field: the entry's parenthesis.
    let err = error("(masks: [\n    Mask(name: \"a\", kind: Scalar,\n");
    assert_eq!(
        err.to_string(),
        "assets.ron:3:1: mask \"a\", the file ends early: the `(` of mask entry #1 at line 2, \
         column 9 is never closed"
    );
    // Inside a value.
    let err = error("(masks: [(name: \"a\", size: (8, 8,");
    assert_eq!((err.line(), err.column()), (1, 34), "{err}");
    assert_eq!(err.field(), Some("size"));
    assert_eq!(
        err.message(),
        "the file ends early: the `(` at line 1, column 28 is never closed"
    );
}

#[test]
fn integers_out_of_range_name_the_range_and_the_value() {
    let err = error(&edit(7, "            seed: -1,"));
    assert_eq!(
        err.to_string(),
        "assets.ron:7:19: mask \"first\", field `seed`: must be in 0..=18446744073709551615 \
         (got -1)"
    );
    let err = error(&edit(7, "            seed: 18446744073709551616,"));
    assert_eq!(
        err.message(),
        "must be in 0..=18446744073709551615 (got 18446744073709551616)"
    );
    let err = error(&edit(6, "            size: (16, -16, 8),"));
    assert_eq!((err.line(), err.column()), (6, 24), "{err}");
    assert_eq!(err.message(), "each element must be in 1..=65536 (got -16)");
    let text = "(masks: [(name: \"m\", kind: Vec2, size: (8, 8, 4), seed: 1, \
                assignment_passes: 99999999999, encoding: Unorm8)])";
    assert_eq!(
        error(text).message(),
        "must be in 0..=1000 (got 99999999999)"
    );
    for (filter, message) in [
        (
            "spatial_filter: Box(-3)",
            "Box size must be in 1..=65536 (got -3)",
        ),
        (
            "spatial_filter: Binomial(4294967296)",
            "Binomial order must be in 1..=256 (got 4294967296)",
        ),
        (
            "temporal_filter: Box(4294967296)",
            "Box size must be in 1..=65536 (got 4294967296)",
        ),
    ] {
        let text = format!(
            "(masks: [(name: \"m\", kind: FilterAdapted, size: (8, 8, 4), seed: 1, {filter}, \
             encoding: Unorm8)])"
        );
        assert_eq!(error(&text).message(), message, "{filter}");
    }
}

#[test]
fn a_seed_of_millions_of_digits_is_quoted_cut() {
    let digits = "9".repeat(2_000_000);
    let err = error(&edit(7, &format!("            seed: {digits},")));
    assert_eq!(
        err.to_string(),
        format!(
            "assets.ron:7:19: mask \"first\", field `seed`: must be in \
             0..=18446744073709551615 (got {}… (2000000 characters))",
            "9".repeat(64)
        )
    );
}

#[test]
fn long_names_and_strings_are_quoted_cut_with_their_length() {
    // A valid identifier of 4 Mi characters: refused for its length, and quoted cut.
    let long = "n".repeat(4 << 20);
    let n64 = "n".repeat(64);
    let err = error(&edit(4, &format!("            name: \"{long}\",")));
    assert_eq!(err.mask_name(), Some(long.as_str()));
    assert_eq!(
        err.to_string(),
        format!(
            "assets.ron:4:19: mask \"{n64}…\" (4194304 characters), field `name`: is 4194304 \
             characters long; at most 128 are allowed (the name becomes file names, which file \
             systems limit to 255 bytes)"
        )
    );
    // Not an identifier: the message quotes it too.
    let spaced = "a b".repeat(1000);
    let err = error(&edit(4, &format!("            name: \"{spaced}\",")));
    assert!(
        err.message().starts_with(&format!(
            "{:?} (3000 characters) is not a Rust identifier",
            format!("{}…", &spaced[..64])
        )),
        "{err}"
    );
    assert!(err.to_string().len() < 400, "{err}");
    // An unknown field and an unknown variant of 100000 characters.
    let field = "x".repeat(100_000);
    let err = error(&edit(16, &format!("            {field}: 0.1,")));
    assert_eq!(err.field(), Some(field.as_str()));
    assert!(
        err.to_string().contains(&format!(
            "field `{}…` (100000 characters): unknown field",
            &field[..64]
        )),
        "{err}"
    );
    assert!(err.to_string().len() < 800, "{err}");
    let err = error(&edit(13, &format!("            kind: {field},")));
    assert_eq!(err.field(), Some("kind"));
    assert!(
        err.message()
            .contains(&format!("`{}…` (100000 characters)", &field[..64])),
        "{err}"
    );
    assert!(err.to_string().len() < 1200, "{err}");
    // A struct name where `Mask` belongs.
    let err = error(&edit(3, &format!("        {field}(")));
    assert!(
        err.message()
            .contains(&format!("`{}…` (100000 characters)", &field[..64])),
        "{err}"
    );
    assert!(err.to_string().len() < 400, "{err}");
}

#[test]
fn huge_and_tiny_numbers_read_compactly() {
    let mask = |fields: &str| {
        format!(
            "(masks: [(name: \"m\", kind: FilterAdapted, size: (16, 16, 8), seed: 1, {fields}, \
             encoding: Unorm8)])"
        )
    };
    for (fields, field, message) in [
        (
            "spatial_filter: Gaussian(1e300)",
            "spatial_filter",
            "Gaussian sigma is 1e300; it must be in [1e-150, 4096] (below, 1/(2σ²) overflows and \
             the filter's weights are not a Gaussian's)",
        ),
        (
            "temporal_filter: Exponential(1e-300)",
            "temporal_filter",
            "Exponential alpha is 1e-300; it must be in [0.001, 1]",
        ),
        (
            "swaps_per_pixel: 1e300",
            "swaps_per_pixel",
            "must be in 0..=10000 (got 1e300)",
        ),
    ] {
        let err = error(&mask(fields));
        assert_eq!(
            (err.field(), err.message()),
            (Some(field), message),
            "{fields}"
        );
    }
    let err = error(
        "(masks: [(name: \"m\", kind: Vec2, size: (8, 8, 4), seed: 1, swaps_per_pixel: -1e200, \
         encoding: Unorm8)])",
    );
    assert_eq!(err.message(), "must be in 0..=10000 (got -1e200)");
}

#[test]
fn oversized_manifests_are_refused_before_parsing() {
    let limit = Manifest::MAX_FILE_BYTES as usize;
    // Over the limit by one byte: refused at once, however it would parse.
    let text = format!("{BASE}{}", " ".repeat(limit + 1 - BASE.len()));
    let err = error(&text);
    assert_eq!(
        err.to_string(),
        format!(
            "assets.ron:1:1: the manifest is {} bytes; at most {limit} bytes ({} MiB) are read",
            limit + 1,
            limit >> 20
        )
    );
    // At the limit: parsed.
    assert!(Manifest::parse(&text[..limit], "assets.ron").is_ok());
    // From a file: refused before reading, naming the file and the limit.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("assets.ron");
    std::fs::write(&path, &text).unwrap();
    let err = Manifest::load(&path).unwrap_err().to_string();
    assert_eq!(
        err,
        format!(
            "could not read the manifest {}: is {} bytes, over the limit of {limit} bytes",
            path.display(),
            limit + 1
        )
    );
}

#[test]
fn unnamed_masks_are_numbered() {
    let err = error(&edit(11, ""));
    assert_eq!(err.field(), Some("name"));
    assert_eq!(err.mask_index(), Some(1));
    assert!(
        err.to_string()
            .contains("mask #2 (unnamed), field `name`: missing"),
        "{err}"
    );
}

#[test]
fn load_reports_the_file_path_and_io_errors() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("assets.ron");
    std::fs::write(&path, edit(16, "            density: 0.7,")).unwrap();
    let Err(Error::Manifest(err)) = Manifest::load(&path) else {
        panic!("expected a manifest error")
    };
    assert_eq!(err.path(), path);
    assert!(
        err.to_string()
            .starts_with(&format!("{}:16:22: mask \"foo\"", path.display())),
        "{err}"
    );
    let missing = Manifest::load(dir.path().join("missing.ron")).unwrap_err();
    assert!(matches!(missing, Error::Io { .. }), "{missing:?}");
}

#[test]
fn comments_and_struct_names_do_not_confuse_positions() {
    let text = r#"#![enable(implicit_some)]
// (masks: [ "not", "real" ])
Manifest(
    /* name: "decoy", sigma: NaN, */ masks: [
        Mask(name: "x", kind: Blue3D, size: (8, 8, 8), seed: 0, encoding: F32),
        Mask(name: "y", kind: Blue3D, size: (8, 8, 8), seed: 0, encoding: F32, density: 0.9),
    ],
)
"#;
    let err = error(text);
    assert_eq!((err.line(), err.column()), (6, 89));
    assert_eq!((err.mask_name(), err.field()), (Some("y"), Some("density")));
}

/// A one-mask manifest in `dir` whose mask is `fields` (one line, inside the parentheses).
fn image_manifest(dir: &std::path::Path, fields: &str) -> std::path::PathBuf {
    let path = dir.join("assets.ron");
    std::fs::write(
        &path,
        format!("(\n    masks: [\n        ({fields}),\n    ],\n)\n"),
    )
    .unwrap();
    path
}

fn load_error(path: &std::path::Path) -> ManifestError {
    match Manifest::load(path) {
        Err(Error::Manifest(e)) => *e,
        other => panic!("expected a manifest error, got {other:?}"),
    }
}

#[test]
fn image_kinds_load_their_image_relative_to_the_manifest() {
    let dir = tempfile::tempdir().unwrap();
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    std::fs::copy(data.join("sky_16x8.png"), dir.path().join("sky.png")).unwrap();
    std::fs::copy(data.join("black_4x4.png"), dir.path().join("black.png")).unwrap();
    std::fs::write(dir.path().join("notes.txt"), "not an image").unwrap();
    let head = r#"name: "sky", kind: EnvironmentMap, size: (8, 8, 4), seed: 1, encoding: Unorm16"#;

    let ok = image_manifest(dir.path(), &format!(r#"{head}, image: "sky.png""#));
    let manifest = Manifest::load(&ok).unwrap();
    let image = manifest.masks()[0].image.as_ref().unwrap();
    assert_eq!(image.path, dir.path().join("sky.png"));

    // Each problem names line 3, the mask and the field, at the field's value.
    let col = head.len() + 19; // 8 spaces, "(", head, ", image: " -> the value's column
    let cases = [
        (format!(r#"{head}, image: "missing.png""#), "cannot read"),
        (format!(r#"{head}, image: "black.png""#), "zero"),
        (format!(r#"{head}, image: "notes.txt""#), "notes.txt"),
    ];
    for (fields, message) in cases {
        let err = load_error(&image_manifest(dir.path(), &fields));
        assert_eq!(
            (err.line(), err.column(), err.field(), err.mask_name()),
            (3, col, Some("image"), Some("sky")),
            "{err}"
        );
        assert!(err.message().contains(message), "{err}");
        assert!(
            err.to_string().starts_with(&format!("{}:3:", ok.display())),
            "{err}"
        );
    }

    // An image kind without `image`, and `image` on a kind that takes none.
    let err = load_error(&image_manifest(dir.path(), head));
    assert_eq!(err.field(), Some("image"));
    assert!(err.message().starts_with("missing"), "{err}");
    let err = load_error(&image_manifest(
        dir.path(),
        r#"name: "v", kind: Vec2, size: (8, 8, 4), seed: 1, image: "sky.png", encoding: Unorm8"#,
    ));
    assert_eq!(err.field(), Some("image"));
    assert!(err.message().contains("does not apply to Vec2"), "{err}");
}

#[test]
fn fields_that_do_not_apply_to_a_kind_are_refused() {
    for (kind, field) in [
        ("Vec2", "density: 0.2"),
        ("UnitVec3", "sigma_time: 2.0"),
        ("Vec2", "octahedral: true"),
        ("Scalar", "swaps_per_pixel: 4.0"),
        ("Scalar", "sigma_value: 1.0"),
        ("White", "sigma: 1.0"),
        ("TellusimLayered", "kernel_tolerance: 1e-3"),
    ] {
        let text = format!(
            "(masks: [(name: \"m\", kind: {kind}, size: (8, 8, 4), seed: 1, {field}, \
             encoding: Unorm8)])"
        );
        let err = error(&text);
        let name = field.split(':').next().unwrap();
        assert_eq!(err.field(), Some(name), "{kind} {field}: {err}");
        assert!(
            err.message()
                .starts_with(&format!("does not apply to {kind} masks")),
            "{err}"
        );
    }
    // Vector fields out of range name themselves.
    let err = error(
        "(masks: [(name: \"m\", kind: Vec2, size: (8, 8, 4), seed: 1, swaps_per_pixel: -1.0, \
         encoding: Unorm8)])",
    );
    assert_eq!(err.field(), Some("swaps_per_pixel"));
    let err = error(
        "(masks: [(name: \"m\", kind: Vec2, size: (8, 8, 4), seed: 1, sigma_value: NaN, \
         encoding: Unorm8)])",
    );
    assert_eq!(err.field(), Some("sigma_value"));
}

#[test]
fn filter_adapted_fields_are_checked_and_named() {
    let mask = |fields: &str| {
        format!(
            "(masks: [(name: \"m\", kind: FilterAdapted, size: (16, 16, 8), seed: 1, {fields}, \
             encoding: Unorm8)])"
        )
    };
    // Accepted: every filter, a vector space, the budget and tolerance.
    for fields in [
        "spatial_filter: Gaussian(1.3435), temporal_filter: Exponential(0.1)",
        "spatial_filter: Box(3), temporal_filter: Box(4), filter_combination: Separate(0.5)",
        "spatial_filter: Binomial(2), temporal_filter: ExponentialHistory(0.1, 0.1)",
        "temporal_filter: Gaussian(2.0), filter_combination: Product",
        "space: Vec2, swaps_per_pixel: 2.0, kernel_tolerance: 1e-2",
        "space: UnitVec3, octahedral: false",
    ] {
        let text = mask(fields);
        Manifest::parse(&text, "assets.ron").unwrap_or_else(|e| panic!("{fields}: {e}"));
    }
    let cases = [
        (
            "spatial_filter: Gaussian(-1.0)",
            "spatial_filter",
            "Gaussian sigma is -1",
        ),
        ("spatial_filter: Box(0)", "spatial_filter", "Box size is 0"),
        ("spatial_filter: Gauss(1.0)", "spatial_filter", "Gauss"),
        (
            "temporal_filter: Exponential(1.5)",
            "temporal_filter",
            "alpha is 1.5",
        ),
        (
            "temporal_filter: ExponentialHistory(0.1, 0.0)",
            "temporal_filter",
            "beta is 0",
        ),
        (
            "filter_combination: Separate(2.0)",
            "filter_combination",
            "spatial_weight is 2",
        ),
        ("space: Scalar", "space", "Scalar is not a vector kind"),
        (
            "space: ImagePoints",
            "space",
            "ImagePoints is not a vector kind",
        ),
        ("octahedral: true", "octahedral", "3D unit `space`"),
        (
            "space: Vec2, octahedral: true",
            "octahedral",
            "3D unit `space`",
        ),
        (
            "sigma: 1.9",
            "sigma",
            "does not apply to FilterAdapted masks",
        ),
        (
            "density: 0.2",
            "density",
            "does not apply to FilterAdapted masks",
        ),
        (
            "swaps_per_pixel: -3.0",
            "swaps_per_pixel",
            "must be in 0..=10000",
        ),
        (
            "kernel_tolerance: 2.0",
            "kernel_tolerance",
            "must be in (0, 1)",
        ),
    ];
    for (fields, field, message) in cases {
        let text = mask(fields);
        let err = error(&text);
        assert_eq!(err.field(), Some(field), "{fields}: {err}");
        assert_eq!(
            (err.line(), err.mask_name()),
            (1, Some("m")),
            "{fields}: {err}"
        );
        // The column is where the field's value starts.
        let value = text.find(&format!("{field}: ")).unwrap() + field.len() + 3;
        assert_eq!(err.column(), value, "{fields}: {err}");
        assert!(err.message().contains(message), "{fields}: {err}");
    }
    // Filter fields on other kinds are refused, naming the kind they apply to.
    for field in [
        "spatial_filter: Box(3)",
        "temporal_filter: Box(3)",
        "filter_combination: Product",
        "space: Vec2",
    ] {
        let text = format!(
            "(masks: [(name: \"m\", kind: Vec2, size: (8, 8, 4), seed: 1, {field}, \
             encoding: Unorm8)])"
        );
        let err = error(&text);
        assert_eq!(err.field(), field.split(':').next(), "{err}");
        assert!(
            err.message()
                .starts_with("does not apply to Vec2 masks (it applies to FilterAdapted)"),
            "{err}"
        );
    }
}

#[test]
fn a_byte_order_mark_is_skipped_and_positions_stay_as_an_editor_shows_them() {
    let text = format!("\u{feff}{}", edit(16, "            density: 0.7,"));
    let err = error(&text);
    assert_eq!((err.line(), err.column()), (16, 22), "{err}");
    assert_eq!(
        Manifest::parse(&format!("\u{feff}{BASE}"), "a.ron")
            .unwrap()
            .masks()
            .len(),
        2
    );
}

#[test]
fn a_fractional_integer_says_an_integer_is_expected() {
    let err = error(&edit(15, "            seed: 1.5,"));
    assert_eq!((err.line(), err.field()), (15, Some("seed")), "{err}");
    assert_eq!(
        err.message(),
        "expected an integer (this field takes whole numbers), found `1.5`"
    );
    let err = error(&edit(14, "            size: (16, 16.0, 8),"));
    assert_eq!(err.field(), Some("size"), "{err}");
    assert!(err.message().starts_with("expected an integer"), "{err}");
}

#[test]
fn sigma_whose_kernel_would_lose_its_centre_is_refused_with_the_smallest_that_works() {
    for (kind, field) in [
        ("Scalar", "sigma"),
        ("Blue2D", "sigma"),
        ("GoldenRatio2D", "sigma"),
        ("Blue3D", "sigma_time"),
    ] {
        let text = format!(
            "(masks: [(name: \"m\", kind: {kind}, size: (8, 8, 4), seed: 1, {field}: 1e-200, \
             encoding: Unorm8)])"
        );
        let err = error(&text);
        assert_eq!(err.field(), Some(field), "{kind}: {err}");
        assert!(
            err.message()
                .starts_with("must be at least 1e-150 (got 1e-200)"),
            "{kind}: {err}"
        );
    }
}

#[test]
fn long_names_are_refused_with_the_limit() {
    let long = "n".repeat(Manifest::MAX_NAME_LEN + 1);
    let text = format!(
        "(masks: [(name: \"{long}\", kind: Scalar, size: (8, 8, 4), seed: 1, encoding: Unorm8)])"
    );
    let err = error(&text);
    assert_eq!(err.field(), Some("name"));
    assert!(
        err.message().contains("129 characters long; at most 128"),
        "{err}"
    );
    let fits = text.replace(&long, &"n".repeat(Manifest::MAX_NAME_LEN));
    assert!(Manifest::parse(&fits, "a.ron").is_ok());
}

#[test]
fn too_many_masks_are_refused_at_the_first_one_over_the_limit() {
    let mask = |i: usize| {
        format!("(name: \"m{i}\", kind: White, size: (1, 1, 1), seed: 1, encoding: Unorm8),\n")
    };
    let all: String = (0..=Manifest::MAX_MASKS).map(mask).collect();
    let err = error(&format!("(masks: [\n{all}])"));
    assert_eq!(err.line(), Manifest::MAX_MASKS + 2, "{err}");
    assert_eq!(err.mask_index(), Some(Manifest::MAX_MASKS));
    assert!(
        err.message().contains("declares 1025 masks; at most 1024"),
        "{err}"
    );
    let limit: String = (0..Manifest::MAX_MASKS).map(mask).collect();
    let manifest = Manifest::parse(&format!("(masks: [\n{limit}])"), "a.ron").unwrap();
    assert_eq!(manifest.masks().len(), Manifest::MAX_MASKS);
}

#[test]
fn the_missing_image_message_reads_as_one_sentence() {
    let err = error(
        "(masks: [(name: \"m\", kind: ImagePoints, size: (8, 8, 4), seed: 1, encoding: Unorm8)])",
    );
    assert_eq!(
        err.message(),
        "missing: ImagePoints masks are importance-sampled from an image; add \
         `image: \"path/to/file.hdr\"` (PNG or Radiance .hdr, relative to the manifest)"
    );
}

#[test]
fn name_errors_point_at_the_name() {
    let manifest = Manifest::parse(BASE, "assets.ron").unwrap();
    let err = manifest.name_error(1, "is reserved");
    assert_eq!(
        err.to_string(),
        "assets.ron:11:19: mask \"foo\", field `name`: is reserved"
    );
}

/// Runs `load` on a thread and fails if it has not returned within 20 s.
#[cfg(unix)]
fn load_within_deadline(path: std::path::PathBuf) -> Result<Manifest, Error> {
    let (send, receive) = std::sync::mpsc::channel();
    std::thread::spawn(move || send.send(Manifest::load(&path)));
    receive
        .recv_timeout(std::time::Duration::from_secs(20))
        .expect("Manifest::load returned within 20 s")
}

#[cfg(unix)]
#[test]
fn fifos_and_devices_are_refused_without_reading_them() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("assets.ron");
    assert!(
        std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success()
    );
    let err = load_within_deadline(fifo.clone()).unwrap_err().to_string();
    assert!(err.contains("not a regular file"), "{err}");
    assert!(err.contains(&fifo.display().to_string()), "{err}");

    // An image that is a FIFO, or a link to an endless device.
    let sky = dir.path().join("sky.hdr");
    std::os::unix::fs::symlink("/dev/zero", &sky).unwrap();
    let pipe = dir.path().join("pipe.png");
    std::fs::rename(&fifo, &pipe).unwrap();
    for image in ["sky.hdr", "pipe.png"] {
        let path = image_manifest(
            dir.path(),
            &format!(
                "name: \"m\", kind: ImagePoints, size: (8, 8, 4), seed: 1, image: \"{image}\", \
                 encoding: Unorm8"
            ),
        );
        let Err(Error::Manifest(err)) = load_within_deadline(path) else {
            panic!("{image}: expected a manifest error");
        };
        assert_eq!(err.field(), Some("image"));
        assert!(err.message().contains("not a regular file"), "{err}");
        assert!(err.message().contains(image), "{err}");
    }
}

#[test]
fn a_manifest_that_is_not_utf8_names_the_offset() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("assets.ron");
    std::fs::write(&path, b"(masks: [\xff])").unwrap();
    let err = Manifest::load(&path).unwrap_err().to_string();
    assert!(
        err.contains("not UTF-8 text (invalid byte at offset 9)"),
        "{err}"
    );
    assert!(err.contains("assets.ron"), "{err}");
}

#[test]
fn a_sigma_outside_the_working_range_is_refused_at_its_line_with_the_range() {
    // Line 12 is `sigma` of the 16×16×8 Blue2D mask: 0.2 leaves its kernel no neighbour, 100 is
    // far wider than its 16-pixel slice.
    let err = error(&edit(12, "            sigma: 0.2,"));
    assert_eq!(
        (err.line(), err.column(), err.field()),
        (12, 20, Some("sigma"))
    );
    assert!(
        err.to_string().starts_with(
            "assets.ron:12:20: mask \"foo\", field `sigma`: must be in [0.3072, 8] for this \
             mask (got 0.2): below 0.3072"
        ),
        "{err}"
    );
    let err = error(&edit(12, "            sigma: 100.0,"));
    assert_eq!((err.line(), err.field()), (12, Some("sigma")));
    assert!(
        err.message()
            .starts_with("must be in [0.3072, 8] for this mask (got 100)"),
        "{err}"
    );
    // A scalar mask's `sigma_time` against its 8 frames; a vector mask's `sigma` and
    // `sigma_value`.
    for (kind, field, value, range) in [
        ("Scalar", "sigma_time", "9.0", "in [0.3072, 4]"),
        ("Vec2", "sigma", "0.2", "in [0.4345, 27.2]"),
        ("Vec2", "sigma_value", "1e4", "in (0, "),
        ("CosineHemisphere", "sigma_value", "1e30", "in (0, "),
    ] {
        let text = format!(
            "(masks: [(name: \"m\", kind: {kind}, size: (16, 16, 8), seed: 1,\n    {field}: \
             {value}, encoding: Unorm8)])"
        );
        let err = error(&text);
        assert_eq!(
            (err.line(), err.column(), err.field()),
            (2, 7 + field.len(), Some(field)),
            "{kind}: {err}"
        );
        assert!(err.message().starts_with("must be "), "{kind}: {err}");
        assert!(err.message().contains(range), "{kind}: {err}");
    }
}
