//! A bounded, deterministic fuzz run of the manifest parser on stable Rust (cargo-fuzz needs a
//! nightly toolchain): seeded mutations of the corpus in `tests/fuzz-corpus/manifest/` (characters
//! and RON tokens inserted, deleted, duplicated and swapped), each parsed with
//! `Manifest::parse`. Every input must return without panicking, and every error must point
//! inside the text it was given (1-based line and column), name the file and stay short however
//! long the input it quotes (runs past the 64 characters a message quotes are among the mutations).
//!
//! `STBN_FUZZ_ITERATIONS` raises the default 20,000 mutations for a longer local run.

use std::panic::{AssertUnwindSafe, catch_unwind};

use stbn_build_support::Manifest;

/// Tokens that steer mutations towards inputs the grammar almost accepts.
const TOKENS: &[&str] = &[
    "(",
    ")",
    "[",
    "]",
    ",",
    ":",
    "\"",
    "//",
    "/*",
    "*/",
    "\n",
    " ",
    "#![enable(implicit_some)]",
    "name",
    "kind",
    "size",
    "seed",
    "sigma",
    "sigma_time",
    "density",
    "kernel_tolerance",
    "encoding",
    "compression",
    "masks",
    "Scalar",
    "Blue2D",
    "Blue3D",
    "White",
    "GoldenRatio2D",
    "RandomShift2D",
    "TellusimLayered",
    "Vec2",
    "UnitVec3",
    "CosineHemisphere",
    "ImagePoints",
    "EnvironmentMap",
    "sigma_value",
    "swaps_per_pixel",
    "octahedral",
    "image",
    "true",
    "\"missing.png\"",
    "\"Cargo.toml\"",
    "Unorm8",
    "Unorm16",
    "F32",
    "None",
    "Lz4",
    "Deflate",
    "Some(",
    "NaN",
    "inf",
    "-inf",
    "-1",
    "0",
    "1e308",
    "4294967296",
    "65536",
    "0.5",
    "1e-300",
    "\"a\"",
    "\"fn\"",
    "\"A\"",
    "r#",
    "é",
    "\u{0}",
];

/// xorshift64*: a small deterministic generator, so a failure reproduces from its iteration.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

fn mutate(text: &str, rng: &mut Rng) -> String {
    let mut chars: Vec<char> = text.chars().collect();
    for _ in 0..1 + rng.below(4) {
        let at = rng.below(chars.len() + 1);
        match rng.below(6) {
            5 => {
                // A long run: a name, number, string or fields past the 64 characters a message quotes.
                let run = ["n", "9", "\"x", "x: "][rng.below(4)].repeat(65 + rng.below(100));
                chars.splice(at..at, run.chars());
            }
            0 => {
                let end = (at + 1 + rng.below(8)).min(chars.len());
                chars.drain(at.min(end)..end);
            }
            1 | 2 => {
                let token = TOKENS[rng.below(TOKENS.len())];
                chars.splice(at..at, token.chars());
            }
            3 => {
                let end = (at + 1 + rng.below(16)).min(chars.len());
                let copy: Vec<char> = chars[at.min(end)..end].to_vec();
                let to = rng.below(chars.len() + 1);
                chars.splice(to..to, copy);
            }
            _ => {
                if !chars.is_empty() {
                    let (a, b) = (rng.below(chars.len()), rng.below(chars.len()));
                    chars.swap(a, b);
                }
            }
        }
    }
    chars.into_iter().collect()
}

/// Longest message a manifest error may have: the longest fixed text (the lists of valid fields
/// and kinds) with a few quoted inputs of at most 64 characters each.
const MAX_MESSAGE_CHARS: usize = 1200;

#[test]
fn mutated_manifests_never_panic_and_errors_point_into_the_text() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz-corpus/manifest");
    let mut corpus: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|entry| std::fs::read_to_string(entry.unwrap().path()).unwrap())
        .collect();
    corpus.sort();
    assert!(corpus.len() >= 2, "corpus in {}", dir.display());
    for seed in &corpus {
        if let Err(error) = Manifest::parse(seed, "corpus.ron") {
            panic!("corpus manifests must be valid: {error}");
        }
    }
    let iterations: usize = std::env::var("STBN_FUZZ_ITERATIONS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(20_000);

    let mut rng = Rng(0x5EED_F00D_CAFE_BEEF);
    let (mut accepted, mut rejected) = (0usize, 0usize);
    for iteration in 0..iterations {
        let input = mutate(&corpus[rng.below(corpus.len())], &mut rng);
        let parsed = catch_unwind(AssertUnwindSafe(|| Manifest::parse(&input, "fuzz.ron")));
        let Ok(result) = parsed else {
            panic!("iteration {iteration}: the parser panicked on {input:?}");
        };
        match result {
            Ok(_) => accepted += 1,
            Err(error) => {
                rejected += 1;
                let lines = input.split('\n').count();
                let line_chars = input
                    .split('\n')
                    .nth(error.line().saturating_sub(1))
                    .map_or(0, |l| l.chars().count());
                assert!(
                    (1..=lines).contains(&error.line())
                        && (1..=line_chars + 1).contains(&error.column()),
                    "iteration {iteration}: {error} points outside {input:?}"
                );
                assert!(error.to_string().starts_with("fuzz.ron:"), "{error}");
                // Quoted input is cut: a message never grows with the text it quotes.
                assert!(
                    error.to_string().chars().count() <= MAX_MESSAGE_CHARS,
                    "iteration {iteration}: a message of {} characters: {error}",
                    error.to_string().chars().count()
                );
            }
        }
    }
    println!("{iterations} mutations: {accepted} accepted, {rejected} rejected");
    // Both outcomes must occur, or the mutations are not exercising the parser.
    assert!(
        accepted > 0 && rejected > 0,
        "{accepted} accepted, {rejected} rejected"
    );
}
