//! `embed_or_exit` as Cargo runs it: in its own process, with build-script environment variables,
//! talking to Cargo through `cargo::` lines on stdout and its exit status.
//!
//! The child process is this test binary again, running only the ignored `child` test.

use std::path::Path;
use std::process::{Command, Output};

/// Set in the child's environment; `child` does nothing without it.
const CHILD: &str = "STBN_TEST_BUILD_SCRIPT_CHILD";

const VALID: &str = r#"(
    masks: [
        (name: "a", kind: Scalar, size: (8, 8, 4), seed: 1, encoding: Unorm8),
    ],
)
"#;

const BROKEN: &str = r#"(
    masks: [
        (
            name: "a",
            kind: Scalar,
            size: (8, 8, 4),
            seed: 1,
            sigma: NaN,
            encoding: Unorm8,
        ),
    ],
)
"#;

#[test]
#[ignore = "run as a child process by the other tests of this file"]
fn child() {
    if std::env::var_os(CHILD).is_some() {
        stbn_build_support::embed_or_exit("assets.ron");
    }
}

/// Runs `embed_or_exit("assets.ron")` as the build script of a package rooted at `root`, with the
/// cache in `cache`; `configure` may adjust the environment further.
fn run_build_script(root: &Path, cache: &Path, configure: impl FnOnce(&mut Command)) -> Output {
    let mut command = Command::new(std::env::current_exe().unwrap());
    command
        .args(["child", "--exact", "--ignored", "--nocapture", "-q"])
        .env(CHILD, "1")
        .env("CARGO_MANIFEST_DIR", root)
        .env("OUT_DIR", root.join("out"))
        .env("STBN_CACHE_DIR", cache);
    configure(&mut command);
    command.output().unwrap()
}

fn project(manifest: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("assets.ron"), manifest).unwrap();
    dir
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

#[test]
fn broken_manifest_is_a_clean_cargo_error() {
    let dir = project(BROKEN);
    let output = run_build_script(dir.path(), &dir.path().join("cache"), |_| {});
    let (stdout, stderr) = (text(&output.stdout), text(&output.stderr));
    // Cargo fails the build on the `cargo::error` line; a failing status would make it print the
    // error a second time (with the script's whole output).
    assert_eq!(output.status.code(), Some(0), "{stdout}\n{stderr}");
    let manifest = dir.path().join("assets.ron");
    let error = format!(
        "cargo::error={}:8:20: mask \"a\", field `sigma`: must be finite and > 0 (got NaN)\n",
        manifest.display()
    );
    assert!(stdout.contains(&error), "{stdout}");
    // Cargo must rerun the script once the manifest is fixed.
    let rerun = format!("cargo::rerun-if-changed={}\n", manifest.display());
    assert!(stdout.find(&rerun) < stdout.find(&error), "{stdout}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(!dir.path().join("out/stbn_assets.rs").exists());
}

#[test]
fn missing_build_script_environment_is_reported() {
    let dir = project(VALID);
    let output = run_build_script(dir.path(), &dir.path().join("cache"), |c| {
        c.env_remove("OUT_DIR");
    });
    assert_eq!(output.status.code(), Some(1));
    assert!(
        text(&output.stdout).contains("cargo::error=environment variable `OUT_DIR` is not set"),
        "{}",
        text(&output.stdout)
    );
}

#[test]
fn success_prints_rerun_directives_and_the_report() {
    let dir = project(VALID);
    let cache = dir.path().join("cache");
    let output = run_build_script(dir.path(), &cache, |_| {});
    let stdout = text(&output.stdout);
    assert!(
        output.status.success(),
        "{stdout}\n{}",
        text(&output.stderr)
    );
    for line in [
        format!(
            "cargo::rerun-if-changed={}",
            dir.path().join("assets.ron").display()
        ),
        "cargo::rerun-if-env-changed=STBN_CACHE_DIR".to_owned(),
        "stbn: a: cache miss, generated, 320 bytes".to_owned(),
    ] {
        assert!(stdout.contains(&line), "{line:?} missing from\n{stdout}");
    }
    // Generating prints one line for the mask and, when the build script is unoptimised (as
    // this test binary is in the dev profile, which build-support shares), the profile advice.
    let warnings: Vec<&str> = stdout
        .lines()
        .filter_map(|l| l.strip_prefix("cargo::warning="))
        .collect();
    let (generated, advice) = warnings.split_first().expect(&stdout);
    assert!(
        generated.starts_with("A (Scalar, 8×8×4) was generated in ")
            && generated.ends_with(" ms when this build script last ran; cached"),
        "{stdout}"
    );
    if cfg!(debug_assertions) {
        assert!(
            advice[0].starts_with("the build script ran ")
                && advice[0].ends_with("add to Cargo.toml:"),
            "{stdout}"
        );
        assert_eq!(
            advice[1..],
            [
                "[profile.dev.build-override]",
                "opt-level = 3",
                "debug-assertions = false",
                "overflow-checks = false",
                "[profile.release.build-override]",
                "opt-level = 3",
                "debug-assertions = false",
                "overflow-checks = false",
            ]
        );
    } else {
        assert!(advice.is_empty(), "{stdout}");
    }
    assert!(dir.path().join("out/stbn_assets.rs").is_file());
    assert!(dir.path().join("out/stbn/a.stbn").is_file());

    // A build that generates nothing prints no warning at all.
    let again = text(&run_build_script(dir.path(), &cache, |_| {}).stdout);
    assert!(again.contains("stbn: a: cache hit, 320 bytes"), "{again}");
    assert!(!again.contains("cargo::warning"), "{again}");
}

#[test]
fn cache_problems_become_cargo_warnings() {
    let dir = project(VALID);
    std::fs::write(dir.path().join("file"), "").unwrap();
    let output = run_build_script(dir.path(), &dir.path().join("file/cache"), |_| {});
    let stdout = text(&output.stdout);
    assert!(output.status.success(), "{stdout}");
    // One warning for the build, not one per mask.
    let warning = format!(
        "cargo::warning=the cache directory {} cannot be written (",
        dir.path().join("file/cache").display()
    );
    assert_eq!(stdout.matches(&warning).count(), 1, "{stdout}");
    assert!(!stdout.contains("could not write cache entry"), "{stdout}");
}

#[test]
fn a_huge_name_is_a_short_cargo_error() {
    let name = "n".repeat(1 << 20);
    let dir = project(&VALID.replacen("name: \"a\"", &format!("name: \"{name}\""), 1));
    let output = run_build_script(dir.path(), &dir.path().join("cache"), |_| {});
    let stdout = text(&output.stdout);
    let error = stdout
        .lines()
        .find(|line| line.starts_with("cargo::error="))
        .unwrap_or_else(|| panic!("no error in {:?}", &stdout[..stdout.len().min(2000)]));
    assert!(error.len() < 600, "{error}");
    assert!(
        error.contains(&format!(
            "mask \"{}…\" (1048576 characters), field `name`: is 1048576 characters long",
            &name[..64]
        )),
        "{error}"
    );
}

/// The real thing: `cargo build` of a crate whose build script uses a broken manifest fails with
/// the manifest error and without a backtrace. Slow (it compiles the build script's dependencies
/// into `target/stbn-build-script-test`), hence ignored; run with `--ignored`.
#[test]
#[ignore = "runs cargo build on a temporary crate"]
fn broken_manifest_fails_a_real_cargo_build() {
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = project(BROKEN);
    let support = workspace.join("build-support");
    std::fs::write(
        dir.path().join("Cargo.toml"),
        format!(
            "[package]\nname = \"broken-manifest\"\nversion = \"0.0.0\"\nedition = \"2024\"\n\
             [build-dependencies]\nstbn-build-support = {{ path = {:?} }}\n[workspace]\n",
            support.to_str().unwrap()
        ),
    )
    .unwrap();
    std::fs::write(
        dir.path().join("build.rs"),
        "fn main() { stbn_build_support::embed_or_exit(\"assets.ron\"); }\n",
    )
    .unwrap();
    std::fs::create_dir(dir.path().join("src")).unwrap();
    std::fs::write(dir.path().join("src/lib.rs"), "").unwrap();
    let output = Command::new(env!("CARGO"))
        .args(["build", "--offline", "--quiet"])
        .current_dir(dir.path())
        .env(
            "CARGO_TARGET_DIR",
            workspace.join("target/stbn-build-script-test"),
        )
        // Cargo notes how to improve backtraces after a failed build script when this is set.
        .env("RUST_BACKTRACE", "1")
        .output()
        .unwrap();
    let stderr = text(&output.stderr);
    assert!(!output.status.success());
    let message = format!(
        "{}:8:20: mask \"a\", field `sigma`: must be finite and > 0 (got NaN)",
        dir.path().join("assets.ron").display()
    );
    let error = format!("error: broken-manifest@0.0.0: {message}");
    assert!(stderr.contains(&error), "{stderr}");
    assert_eq!(stderr.matches(&message).count(), 1, "{stderr}");
    assert!(!stderr.contains("backtrace"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn images_are_tracked_with_rerun_if_changed() {
    let dir = project(
        r#"(masks: [
            (name: "sky", kind: EnvironmentMap, size: (4, 4, 2), seed: 1, encoding: Unorm8,
             image: "sky.png", swaps_per_pixel: 1),
            (name: "sky_again", kind: ImagePoints, size: (4, 4, 2), seed: 2, encoding: Unorm8,
             image: "sky.png", swaps_per_pixel: 1),
        ])"#,
    );
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/sky_16x8.png"),
        dir.path().join("sky.png"),
    )
    .unwrap();
    let output = run_build_script(dir.path(), &dir.path().join("cache"), |_| {});
    let stdout = text(&output.stdout);
    assert!(
        output.status.success(),
        "{stdout}\n{}",
        text(&output.stderr)
    );
    let line = format!(
        "cargo::rerun-if-changed={}",
        dir.path().join("sky.png").display()
    );
    assert_eq!(stdout.matches(&line).count(), 1, "{stdout}");
}
