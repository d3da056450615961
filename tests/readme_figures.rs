//! The figures README.md and docs/REFERENCE.md quote are not written by hand: each comes from a
//! table that a command regenerates, and must match it to the rounding it is quoted at. The
//! "What it buys" figures are ratios of two RMSEs in the scenes README's results table (which the
//! scene binaries print); compression ratios, sampling speeds, generation times and peak memory
//! come from BENCHMARKS.md's tables (`stbn-gen tradeoff`, the benches). A regenerated table with
//! new figures fails these tests until the documents quote them.

use std::collections::HashMap;

/// Per `(scene, noise)`: RMSE under EMA, under the mean, blurred under EMA, blurred under the mean.
type Results = HashMap<(String, String), [f64; 4]>;

fn read(path: &str) -> String {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(path);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A table cell without markdown emphasis or code marks.
fn cell(text: &str) -> String {
    text.trim().replace("**", "").replace('`', "")
}

/// The results table of scenes/README.md: rows `| scene | noise | 4 RMSEs |`, the scene cell
/// left empty after its first row.
fn scene_results(text: &str) -> Results {
    let section = text
        .split("## Results")
        .nth(1)
        .expect("scenes/README.md has a Results section");
    let mut results = Results::new();
    let mut scene = String::new();
    for line in section.lines().filter(|l| l.starts_with('|')) {
        let cells: Vec<String> = line.trim_matches('|').split('|').map(cell).collect();
        let Ok(values) = cells[cells.len().saturating_sub(4)..]
            .iter()
            .map(|v| v.parse::<f64>())
            .collect::<Result<Vec<f64>, _>>()
        else {
            continue; // the header and its rule
        };
        if !cells[0].is_empty() {
            scene.clone_from(&cells[0]);
        }
        results.insert(
            (scene.clone(), cells[1].clone()),
            values.try_into().expect("four RMSEs"),
        );
    }
    results
}

/// `−61.7 %` (or `+0.4 %`, `-1.1 %`) as a number.
fn percent(text: &str) -> f64 {
    leading_number(text).unwrap_or_else(|| panic!("{text:?} is not a percentage"))
}

/// `(a / b − 1)` in percent, for the RMSEs of `noise` and `baseline` in `scene`, column `column`.
fn change(results: &Results, scene: &str, noise: &str, baseline: &str, column: usize) -> f64 {
    let get = |noise: &str| {
        results
            .get(&(scene.to_owned(), noise.to_owned()))
            .unwrap_or_else(|| panic!("scenes/README.md has no row {scene} / {noise}"))[column]
    };
    (get(noise) / get(baseline) - 1.0) * 100.0
}

/// The table's RMSEs have 3–4 significant digits: ratios of them are good to about ±0.1 %, and
/// the README rounds to 0.1 %.
const TOLERANCE: f64 = 0.15;

fn assert_quotes(what: &str, quoted: f64, derived: f64) {
    assert!(
        (quoted - derived).abs() <= TOLERANCE,
        "README.md quotes {quoted} % for {what}; scenes/README.md's table gives {derived:.2} %"
    );
}

#[test]
fn what_it_buys_matches_the_scenes_results() {
    let results = scene_results(&read("scenes/README.md"));
    let readme = read("README.md");
    const EMA: usize = 0;
    const BLURRED_EMA: usize = 2;
    let rows = [
        ("stochastic transparency, α 0.5", "transparency_50", "STBN"),
        (
            "stochastic transparency, α ramp",
            "transparency_ramp",
            "STBN",
        ),
        ("single-scattering cloud", "cloud", "STBN"),
        (
            "AO, vector STBN vs white vectors",
            "ao",
            "vector STBN (cosine hemisphere)",
        ),
    ];
    for (label, scene, noise) in rows {
        let baseline = if scene == "ao" {
            "white cosine vectors"
        } else {
            "2D blue noise, independent per frame"
        };
        let line = readme
            .lines()
            .find(|l| l.starts_with(&format!("| {label}")))
            .unwrap_or_else(|| panic!("README.md has no row for {label}"));
        let cells: Vec<&str> = line.trim_matches('|').split('|').collect();
        let [per_pixel, blurred] = [cells[1], cells[2]].map(percent);
        assert_quotes(
            &format!("{label}, per pixel"),
            per_pixel,
            change(&results, scene, noise, baseline, EMA),
        );
        assert_quotes(
            &format!("{label}, blurred"),
            blurred,
            change(&results, scene, noise, baseline, BLURRED_EMA),
        );
    }

    // The sentence comparing vector STBN with two dimensions of scalar STBN in the AO scene.
    let prose = prose(&readme);
    let after = |prefix: &str| {
        let start = prose
            .find(prefix)
            .unwrap_or_else(|| panic!("README.md no longer says {prefix:?}"))
            + prefix.len();
        percent(&prose[start..start + prose[start..].find(')').expect("a closing parenthesis")])
    };
    let pairs = "scalar STBN pairs → cosine";
    assert_quotes(
        "vector vs scalar STBN pairs, per pixel",
        after("two dimensions of scalar STBN per pixel ("),
        change(&results, "ao", rows[3].2, pairs, EMA),
    );
    assert_quotes(
        "vector vs scalar STBN pairs, blurred",
        after("and beats them after the blur ("),
        change(&results, "ao", rows[3].2, pairs, BLURRED_EMA),
    );
}

/// `text` with every run of whitespace one space, so that quotes match across line breaks.
fn prose(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// What follows the first `prefix` in `text` (whitespace-normalised by [`prose`]); `file` names
/// the document in the panic.
fn after<'t>(file: &str, text: &'t str, prefix: &str) -> &'t str {
    let start = text
        .find(prefix)
        .unwrap_or_else(|| panic!("{file} no longer says {prefix:?}"));
    &text[start + prefix.len()..]
}

/// The number `text` starts with, e.g. `237,942 (90.8%)` → 237942, `−1.1 %` → −1.1; `None` when
/// it starts with none.
fn leading_number(text: &str) -> Option<f64> {
    let text = text.trim_start().replace('−', "-");
    let end = text
        .find(|c: char| !(c.is_ascii_digit() || matches!(c, '.' | ',' | '-')))
        .unwrap_or(text.len());
    text[..end].replace(',', "").parse().ok()
}

/// [`leading_number`] where a number must follow `prefix` in `file`'s `text`.
fn number_after(file: &str, text: &str, prefix: &str) -> f64 {
    let rest = after(file, text, prefix);
    leading_number(rest)
        .unwrap_or_else(|| panic!("{file}: no number after {prefix:?}: {rest:.40?}"))
}

/// The range `a–b` that follows `prefix` in `file`'s `text`.
fn range_after(file: &str, text: &str, prefix: &str) -> (f64, f64) {
    let rest = after(file, text, prefix);
    let (low, high) = rest
        .split_once('–')
        .unwrap_or_else(|| panic!("{file}: no range after {prefix:?}"));
    let parse = |t: &str| {
        leading_number(t)
            .unwrap_or_else(|| panic!("{file}: no range after {prefix:?}: {rest:.40?}"))
    };
    (parse(low), parse(high))
}

/// The lines of `text` under the heading line `heading` (e.g. `### Compression`), up to the next
/// heading outside a code block.
fn section<'t>(file: &str, text: &'t str, heading: &str) -> Vec<&'t str> {
    let mut lines = text.lines().skip_while(|l| *l != heading);
    assert!(lines.next().is_some(), "{file} has no heading {heading:?}");
    let mut in_code = false;
    let mut out = Vec::new();
    for line in lines {
        if line.starts_with("```") {
            in_code = !in_code;
        } else if !in_code && line.starts_with('#') {
            break;
        }
        out.push(line);
    }
    out
}

/// The markdown tables among `lines`: each a list of rows of [`cell`]s, its header first, its
/// rule left out.
fn tables(lines: &[&str]) -> Vec<Vec<Vec<String>>> {
    let mut tables: Vec<Vec<Vec<String>>> = Vec::new();
    let mut in_table = false;
    for line in lines {
        if !line.starts_with('|') {
            in_table = false;
            continue;
        }
        let cells: Vec<String> = line.trim().trim_matches('|').split('|').map(cell).collect();
        if cells
            .iter()
            .all(|c| !c.is_empty() && c.chars().all(|ch| matches!(ch, '-' | ':')))
        {
            continue; // the rule under the header
        }
        if !in_table {
            tables.push(Vec::new());
            in_table = true;
        }
        tables.last_mut().expect("pushed above").push(cells);
    }
    tables
}

/// The one table among `lines` whose header's first cell is `first_header`.
fn table(file: &str, lines: &[&str], first_header: &str) -> Vec<Vec<String>> {
    tables(lines)
        .into_iter()
        .find(|t| t[0][0] == first_header)
        .unwrap_or_else(|| panic!("{file} has no table headed {first_header:?}"))
}

/// Asserts that `quoted` is `derived` to the `step` it is rounded to (0.1 for one decimal): within
/// half a step, and a little for the binary representation of both.
fn assert_rounds_to(file: &str, what: &str, quoted: f64, derived: f64, step: f64) {
    assert!(
        (quoted - derived).abs() <= step / 2.0 + 1e-9,
        "{file} quotes {quoted} for {what}; BENCHMARKS.md's table gives {derived:.4}"
    );
}

/// One row of BENCHMARKS.md's compression table: blob bytes per codec and whether the encoder
/// stored the payload uncompressed, the Deflate and Palette decode times.
struct Compressed {
    none: f64,
    lz4: f64,
    lz4_stored: bool,
    deflate: f64,
    deflate_stored: bool,
    deflate_decode_us: f64,
    palette: f64,
    palette_stored: bool,
    palette_decode_us: f64,
}

impl Compressed {
    /// The bytes of a blob's header, which the table's blobs include and its raw payload does not.
    const HEADER: f64 = 64.0;

    /// The uncompressed payload's bytes: the "raw" the table's percentages divide by.
    fn raw(&self) -> f64 {
        self.none - Self::HEADER
    }

    /// What Lz4 saves, in percent of the raw payload.
    fn lz4_saving(&self) -> f64 {
        (1.0 - self.lz4 / self.raw()) * 100.0
    }

    /// The Deflate blob in percent of the raw payload.
    fn deflate_percent(&self) -> f64 {
        self.deflate / self.raw() * 100.0
    }

    /// The Palette blob in percent of the raw payload.
    fn palette_percent(&self) -> f64 {
        self.palette / self.raw() * 100.0
    }
}

/// BENCHMARKS.md's "Compression" table by `(mask, encoding)`, each Deflate percentage it prints
/// checked against its bytes and each "(stored)" against the uncompressed size.
fn compression_table(benchmarks: &str) -> HashMap<(String, String), Compressed> {
    let lines = section("BENCHMARKS.md", benchmarks, "### Compression");
    let rows = table("BENCHMARKS.md", &lines, "mask");
    let mut out = HashMap::new();
    for row in &rows[1..] {
        let what = format!("{} {}", row[0], row[1]);
        let bytes = |cell: &str| {
            leading_number(cell)
                .unwrap_or_else(|| panic!("BENCHMARKS.md, {what}: {cell:?} is not a byte count"))
        };
        let none = bytes(&row[2]);
        let decode: Vec<&str> = row[7].split('/').collect();
        let decode_us = |i: usize, codec: &str| {
            decode
                .get(i)
                .and_then(|d| leading_number(d))
                .unwrap_or_else(|| panic!("BENCHMARKS.md, {what}: no {codec} decode time"))
        };
        let entry = Compressed {
            none,
            lz4: bytes(&row[3]),
            lz4_stored: row[3].contains("(stored)"),
            deflate: bytes(&row[4]),
            deflate_stored: row[4].contains("(stored)"),
            deflate_decode_us: decode_us(2, "Deflate"),
            palette: bytes(&row[5]),
            palette_stored: row[5].contains("(stored)"),
            palette_decode_us: decode_us(3, "Palette"),
        };
        for (stored, size) in [
            (entry.lz4_stored, entry.lz4),
            (entry.deflate_stored, entry.deflate),
            (entry.palette_stored, entry.palette),
        ] {
            assert!(
                !stored || size == none,
                "BENCHMARKS.md, {what}: a stored blob of {size} bytes, not {none}"
            );
        }
        for (codec, column, stored, percent) in [
            ("Deflate", 4, entry.deflate_stored, entry.deflate_percent()),
            ("Palette", 5, entry.palette_stored, entry.palette_percent()),
        ] {
            if stored {
                continue;
            }
            let printed = row[column]
                .split_once('(')
                .and_then(|(_, p)| leading_number(p))
                .unwrap_or_else(|| panic!("BENCHMARKS.md, {what}: no {codec} % of raw"));
            assert_rounds_to(
                "BENCHMARKS.md",
                &format!("{what}, {codec} % of raw"),
                printed,
                percent,
                0.1,
            );
        }
        out.insert((row[0].clone(), row[1].clone()), entry);
    }
    out
}

#[test]
fn compression_figures_match_the_benchmarks_table() {
    let benchmarks = read("BENCHMARKS.md");
    let compression = compression_table(&benchmarks);
    let row = |mask: &str, encoding: &str| {
        compression
            .get(&(mask.to_owned(), encoding.to_owned()))
            .unwrap_or_else(|| panic!("BENCHMARKS.md's compression table has no {mask} {encoding}"))
    };
    let (scalar_64, scalar_128) = ("scalar 64×64×32", "scalar 128×128×64");

    // The README's manifest: the Unorm16 64×64×32 mask under Palette.
    let readme = read("README.md");
    let manifest_line = readme
        .lines()
        .find(|l| l.contains("compression: Palette,"))
        .expect("README.md's manifest has a Palette mask");
    assert_rounds_to(
        "README.md",
        "Palette on scalar Unorm16 64×64×32",
        number_after("README.md", manifest_line, "// "),
        row(scalar_64, "Unorm16").palette_percent(),
        1.0,
    );

    // docs/REFERENCE.md's `compression` field.
    let reference = read("docs/REFERENCE.md");
    let field = prose(
        reference
            .lines()
            .find(|l| l.starts_with("| `compression`"))
            .expect("docs/REFERENCE.md has a compression row"),
    );
    let file = "docs/REFERENCE.md";
    let f32_row = [scalar_64, scalar_128].map(|m| row(m, "F32"));
    let f32_values = after(file, &field, "`F32` values (Palette: ");
    for (codec, text, percent) in [
        ("Palette", f32_values, f32_row.map(|r| r.palette_percent())),
        (
            "Deflate",
            after(file, f32_values, "Deflate: "),
            f32_row.map(|r| r.deflate_percent()),
        ),
    ] {
        let (low, high) = range_after(file, text, "");
        assert_rounds_to(
            file,
            &format!("{codec} on F32, least"),
            low,
            percent[0].min(percent[1]),
            1.0,
        );
        assert_rounds_to(
            file,
            &format!("{codec} on F32, most"),
            high,
            percent[0].max(percent[1]),
            1.0,
        );
    }
    let unorm16 = after(
        file,
        &field,
        "`Unorm16` frames under 65,536 pixels (Palette: ",
    );
    let unorm16_rows = [scalar_64, scalar_128].map(|m| row(m, "Unorm16"));
    assert_rounds_to(
        file,
        "Palette on Unorm16 64×64",
        leading_number(unorm16).expect("a percentage"),
        unorm16_rows[0].palette_percent(),
        1.0,
    );
    assert_rounds_to(
        file,
        "Palette on Unorm16 128×128",
        number_after(file, unorm16, "at 64×64, "),
        unorm16_rows[1].palette_percent(),
        1.0,
    );
    let deflate = after(file, unorm16, "Deflate: ");
    assert_rounds_to(
        file,
        "Deflate on Unorm16 64×64",
        leading_number(deflate).expect("a percentage"),
        unorm16_rows[0].deflate_percent(),
        1.0,
    );
    assert_rounds_to(
        file,
        "Deflate on Unorm16 128×128",
        number_after(file, deflate, "%, "),
        unorm16_rows[1].deflate_percent(),
        1.0,
    );
    // "shrinks it most and decodes faster than Deflate", wherever both shrink.
    assert!(field.contains("`Palette`"));
    assert!(field.contains("shrinks it most and decodes faster than Deflate"));
    for ((mask, encoding), entry) in &compression {
        if !entry.palette_stored || !entry.deflate_stored {
            assert!(
                !entry.palette_stored
                    && entry.palette < entry.deflate
                    && entry.palette_decode_us < entry.deflate_decode_us,
                "{file} says Palette shrinks most and decodes faster; {mask} {encoding} disagrees"
            );
        }
    }
    assert_rounds_to(
        file,
        "Lz4's largest saving",
        number_after(file, &field, "Lz4 saves at most "),
        compression
            .values()
            .map(Compressed::lz4_saving)
            .fold(0.0, f64::max),
        1.0,
    );
    assert!(field.contains("`Unorm8` frames hold each level equally often and never shrink"));
    for ((mask, encoding), entry) in &compression {
        if encoding == "Unorm8" {
            assert!(
                entry.lz4_stored && entry.deflate_stored && entry.palette_stored,
                "{file} says Unorm8 never shrinks; BENCHMARKS.md shrinks {mask} {encoding}"
            );
        }
    }

    // BENCHMARKS.md's "Choosing a mask" row for exact values.
    let file = "BENCHMARKS.md";
    let choosing = section(file, &benchmarks, "## Choosing a mask");
    let exact = table(file, &choosing, "you want")
        .into_iter()
        .find(|r| r[0] == "exact values")
        .expect("BENCHMARKS.md chooses a mask for exact values");
    let cost = &exact[2];
    let f32_64 = row(scalar_64, "F32");
    assert_eq!(
        exact[1], "F32 + Palette",
        "BENCHMARKS.md's pick for exact values"
    );
    assert_rounds_to(
        file,
        "F32 + Palette, KB",
        leading_number(cost).expect("KB"),
        f32_64.palette / 1000.0,
        1.0,
    );
    assert_rounds_to(
        file,
        "F32 + Palette, % of raw",
        number_after(file, cost, "("),
        f32_64.palette_percent(),
        1.0,
    );
    assert_rounds_to(
        file,
        "F32 + Palette, decode ms",
        number_after(file, cost, "of raw), "),
        f32_64.palette_decode_us / 1000.0,
        0.1,
    );
}

/// The seconds in a `old → new` cell: `(old, new)`.
fn old_new(cell: &str) -> (f64, f64) {
    let (old, new) = cell
        .split_once('→')
        .unwrap_or_else(|| panic!("{cell:?} is no old → new"));
    let parse = |t: &str| leading_number(t).unwrap_or_else(|| panic!("{cell:?}: no seconds"));
    (parse(old), parse(new))
}

/// The least and the most of `values`.
fn extent(values: impl IntoIterator<Item = f64>) -> (f64, f64) {
    values
        .into_iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        })
}

#[test]
fn speeds_times_and_memory_match_the_benchmarks_tables() {
    let benchmarks = read("BENCHMARKS.md");
    let readme = prose(&read("README.md"));
    let reference = prose(&read("docs/REFERENCE.md"));
    let (b, ref_md) = ("BENCHMARKS.md", "docs/REFERENCE.md");

    // README: `fill_frame` on Unorm8, in the runtime sampling table.
    let sampling = section(b, &benchmarks, "## Runtime sampling");
    let scalar = table(b, &sampling, "encoding");
    let column = scalar[0]
        .iter()
        .position(|h| h == "fill_frame")
        .expect("a fill_frame column");
    let unorm8 = scalar
        .iter()
        .find(|r| r[0] == "Unorm8")
        .expect("a Unorm8 row");
    assert_rounds_to(
        "README.md",
        "fill_frame, Unorm8, G samples/s",
        number_after("README.md", &readme, "(fast path: ~"),
        leading_number(&unorm8[column]).expect("G samples/s"),
        1.0,
    );

    // README: the build-override profile against unoptimised and assertion-checked builds.
    let decisions = section(b, &benchmarks, "## Design decisions");
    let profile = table(b, &decisions, "decision")
        .into_iter()
        .find(|r| r[0] == "the README's build-override profile")
        .expect("BENCHMARKS.md measures the README's build-override profile");
    let measured = prose(&profile[2]);
    let profile_s = number_after(b, &measured, "in build.rs: ");
    let assertions_s = number_after(b, &measured, " vs ");
    let unoptimised_s = number_after(b, &measured, "s; ");
    assert_rounds_to(
        "README.md",
        "opt-level 0 against the profile, ×",
        number_after("README.md", &readme, "at opt-level 0 that is about "),
        unoptimised_s / profile_s,
        1.0,
    );
    assert_rounds_to(
        "README.md",
        "debug assertions and overflow checks against the profile, ×",
        number_after("README.md", &readme, "overflow checks about "),
        assertions_s / profile_s,
        1.0,
    );

    // REFERENCE: vector generation times against version 4, quoted as the "Vector masks"
    // tables print them (one decimal).
    let vector = section(b, &benchmarks, "## Vector masks");
    let runs = |header: &str| -> Vec<(f64, f64)> {
        table(b, &vector, header)[1..]
            .iter()
            .map(|r| old_new(&r[1]))
            .collect()
    };
    let range = |values: Vec<f64>| {
        let (low, high) = extent(values);
        format!("{low:.1}–{high:.1} s")
    };
    let [vec2, unit, cosine] = ["Vec2, seed", "UnitVec3, seed", "CosineHemisphere, seed"].map(runs);
    let new = |runs: &[(f64, f64)]| range(runs.iter().map(|r| r.1).collect());
    let old = |runs: &[(f64, f64)]| range(runs.iter().map(|r| r.0).collect());
    for quote in [
        format!("masks in {} (Vec2), {} (UnitVec3)", new(&vec2), new(&unit)),
        format!(
            "and {} (CosineHemisphere; version 4 took {} in that sitting)",
            new(&cosine),
            old(&cosine)
        ),
        format!("version 4 took {} for Vec2 in that sitting", old(&vec2)),
    ] {
        assert!(
            reference.contains(&quote),
            "{ref_md} does not say {quote:?}, as BENCHMARKS.md's tables do"
        );
    }

    // REFERENCE: the default vector budget's filtered error against 1024 swaps (seed 1).
    let filtered = |rows: &[Vec<String>], label: &str| -> f64 {
        let column = rows[0]
            .iter()
            .position(|h| h == "filtered")
            .expect("a filtered column");
        let row = rows
            .iter()
            .find(|r| r[0] == label)
            .unwrap_or_else(|| panic!("{b}: no row {label:?}"));
        match row[column].split_once('→') {
            Some((_, new)) => leading_number(new),
            None => leading_number(&row[column]),
        }
        .unwrap_or_else(|| panic!("{b}: no filtered error for {label:?}"))
    };
    let budgets = table(b, &vector, "mask, budget");
    let excess = ["Vec2", "UnitVec3"]
        .map(|kind| {
            let default = filtered(&table(b, &vector, &format!("{kind}, seed")), "1");
            (default / filtered(&budgets, &format!("{kind}, 1024 swaps")) - 1.0) * 100.0
        })
        .into_iter()
        .fold(0.0, f64::max);
    assert_rounds_to(
        ref_md,
        "the default vector budget above 1024 swaps, %",
        number_after(ref_md, &reference, "14 passes come within "),
        excess,
        0.1,
    );

    // REFERENCE: 16 threads, in "Threads and scale targets".
    let threads = prose(&section(b, &benchmarks, "### Threads and scale targets").join("\n"));
    let before_16 = &threads[..threads
        .find(" s on 4 / 8 / 16")
        .expect("times on 4 / 8 / 16 threads")];
    let sixteen =
        leading_number(&before_16[before_16.rfind(' ').expect("a time") + 1..]).expect("seconds");
    assert_rounds_to(
        ref_md,
        "128×128×64 Vec2 on 16 cores, s",
        number_after(ref_md, &reference, "a 128×128×64 Vec2 took "),
        sixteen,
        0.1,
    );

    // REFERENCE: FilterAdapted's default budget at 128×128×64, over every run BENCHMARKS.md has.
    let fast = section(
        b,
        &benchmarks,
        "## Filter-adapted masks (EA's FAST) against STBN",
    );
    let seeds = prose(&fast.join("\n"));
    let (fastest, slowest) =
        range_after(b, after(b, &seeds, "Scalar 128×128×64, seeds 1–3: "), "→ ");
    let mut fast_times = vec![fastest, slowest];
    let default = table(b, &fast, "mask")
        .into_iter()
        .find(|r| r[0] == "filter-adapted (default)")
        .expect("a filter-adapted (default) row");
    fast_times.push(leading_number(&default[2]).expect("seconds"));
    let quote = format!("mask in {} on a 2-core AVX2 machine", range(fast_times));
    assert!(
        reference.contains(&quote),
        "{ref_md} does not say {quote:?}, as BENCHMARKS.md's tables do"
    );

    // REFERENCE: peak memory at the size limit.
    let memory = table(
        b,
        &section(b, &benchmarks, "### Memory at the size limit"),
        "mask",
    );
    let bytes_per_pixel = |kind: &str| {
        let row = memory
            .iter()
            .find(|r| r[0].starts_with(kind))
            .unwrap_or_else(|| panic!("{b}: no memory row for {kind}"));
        leading_number(&row[3]).expect("bytes per pixel")
    };
    for row in memory.iter().filter(|r| r[0].starts_with("White ")) {
        let size = row[0].trim_start_matches("White ").replace('×', " × ");
        let gib = leading_number(&row[2]).expect("GiB");
        let quote = format!("{size} {gib:.2} GiB");
        assert!(
            reference.contains(&quote),
            "{ref_md} does not say {quote:?}, as BENCHMARKS.md's table does"
        );
    }
    let (low, high) = range_after(ref_md, &reference, "Vector kinds take more: ");
    let [vec2, unit, vec4] = ["Vec2 ", "UnitVec3 ", "Vec4 "].map(bytes_per_pixel);
    // Whole bytes, cut: 85.5 and 86.2 are "85–86".
    assert_eq!(
        (low, high),
        (vec2.min(unit).floor(), vec2.max(unit).floor()),
        "{ref_md}: bytes per pixel of Vec2 and UnitVec3"
    );
    assert_rounds_to(
        ref_md,
        "Vec4 bytes per pixel",
        number_after(
            ref_md,
            after(ref_md, &reference, "Vector kinds take more: "),
            "UnitVec3 and ",
        ),
        vec4,
        1.0,
    );
    let at_limit = after(ref_md, &reference, "without swaps; about ");
    let gib_at_limit = |bytes: f64| bytes * f64::from(1u32 << 26) / f64::from(1u32 << 30);
    assert_rounds_to(
        ref_md,
        "Vec2 GiB at 2²⁶ pixels",
        leading_number(at_limit).expect("GiB"),
        gib_at_limit(vec2.min(unit)),
        0.1,
    );
    assert_rounds_to(
        ref_md,
        "Vec4 GiB at 2²⁶ pixels",
        number_after(ref_md, at_limit, " and "),
        gib_at_limit(vec4),
        0.1,
    );
}

/// BENCHMARKS.md's opening line names the generator and encoder versions its figures are for:
/// the current ones (a version bump without re-measuring, or without updating the line, fails).
#[test]
fn benchmarks_name_the_current_versions() {
    let benchmarks = read("BENCHMARKS.md");
    let quote = format!(
        "Figures for `GENERATOR_VERSION` {}, `ENCODER_VERSION` {},",
        stbn_gen::GENERATOR_VERSION,
        stbn_build_support::encode::ENCODER_VERSION
    );
    assert!(
        benchmarks.contains(&quote),
        "BENCHMARKS.md does not open with {quote:?}"
    );
}
