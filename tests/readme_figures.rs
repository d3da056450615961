//! The README's "What it buys" figures are not written by hand: each is a ratio of two RMSEs in
//! the scenes README's results table (which the scene binaries print), and must match it to the
//! rounding of that table's figures. A regenerated table with new RMSEs fails this test until the
//! README quotes the new ratios.

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
    text.trim()
        .trim_end_matches('%')
        .trim()
        .replace('−', "-")
        .parse()
        .unwrap_or_else(|e| panic!("{text:?} is not a percentage: {e}"))
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
    let prose = readme.split_whitespace().collect::<Vec<_>>().join(" ");
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
