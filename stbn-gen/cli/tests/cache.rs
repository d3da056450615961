//! `stbn-gen cache`: listing the build-script blob cache and pruning it.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, SystemTime};

use stbn_build_support::cache::manifest_keys;
use stbn_build_support::{CacheKey, Manifest};

const DAY: Duration = Duration::from_secs(86_400);

/// Runs `stbn-gen cache ARGS` in `cwd` without the variables that pick a default directory.
fn cache_command(cwd: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_stbn-gen"))
        .arg("cache")
        .args(args)
        .current_dir(cwd)
        .env_remove("STBN_CACHE_DIR")
        .env_remove("CARGO_TARGET_DIR")
        .output()
        .expect("the binary runs")
}

fn stdout(output: &Output) -> String {
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8(output.stdout.clone()).unwrap()
}

/// Writes an entry for `key`, `bytes` long in all (a stand-in blob and the key record), last
/// used `ago` before now.
fn entry(dir: &Path, key: &CacheKey, bytes: usize, ago: Duration) -> PathBuf {
    let path = dir.join(format!("{}.stbn", key.to_hex()));
    let mut blob = b"STBN".to_vec();
    blob.resize(bytes - 48, 0);
    fs::write(&path, key.entry_bytes(&blob)).unwrap();
    assert_eq!(fs::metadata(&path).unwrap().len(), bytes as u64);
    set_age(&path, ago);
    path
}

fn set_age(path: &Path, ago: Duration) {
    fs::File::options()
        .write(true)
        .open(path)
        .unwrap()
        .set_modified(SystemTime::now() - ago)
        .unwrap();
}

#[test]
fn lists_prunes_by_size_and_age_and_keeps_a_manifest() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("cache");
    fs::create_dir(&dir).unwrap();
    let mask = |seed: u32| {
        format!("(name: \"m{seed}\", kind: White, size: (4, 4, 2), seed: {seed}, encoding: Unorm8)")
    };
    let manifest = root.path().join("assets.ron");
    fs::write(&manifest, format!("(masks: [{}])", mask(1))).unwrap();
    let others = root.path().join("others.ron");
    fs::write(&others, format!("(masks: [{}, {}])", mask(2), mask(3))).unwrap();
    let keys = |path: &Path| manifest_keys(&Manifest::load(path).unwrap());
    let (kept, other) = (keys(&manifest), keys(&others));
    let oldest = entry(&dir, &kept[0], 3072, DAY * 5);
    let old = entry(&dir, &other[0], 2048, DAY * 3);
    let recent = entry(&dir, &other[1], 1024, DAY / 2);
    let (kept_key, k1, k2) = (kept[0].to_hex(), other[0].to_hex(), other[1].to_hex());
    // A blob under an entry's name whose key record names another key: not the cache's.
    let copied = dir.join(format!("{}.stbn", "f".repeat(64)));
    fs::copy(&old, &copied).unwrap();
    // A killed writer's temporary file, and a file that is not the cache's.
    let orphan = dir.join(".tmp-Zz99Yy.part");
    fs::write(&orphan, [0u8; 100]).unwrap();
    set_age(&orphan, DAY);
    let notes = dir.join("notes.txt");
    fs::write(&notes, "mine").unwrap();
    let d = dir.to_str().unwrap();

    let listing = stdout(&cache_command(
        root.path(),
        &["--dir", d, "--keep", "assets.ron"],
    ));
    assert_eq!(
        listing,
        format!(
            "{d}: 3 entries, 6.0 KiB\n\
             \x20last used        size  key\n\
             12.0 h ago     1.0 KiB  {k2}\n\
             \x203.0 d ago     2.0 KiB  {k1}\n\
             \x205.0 d ago     3.0 KiB  {kept_key}  (kept)\n\
             1 orphaned temporary file(s), 100 B: left by interrupted builds; the next build or \
             a prune removes them\n"
        )
    );

    // A dry run says what would go and removes nothing; kept entries stay even when they alone
    // exceed the size, and the output says so.
    let dry = stdout(&cache_command(
        root.path(),
        &[
            "--dir",
            d,
            "--prune-to",
            "1K",
            "--keep",
            "assets.ron",
            "--dry-run",
        ],
    ));
    assert_eq!(
        dry,
        format!(
            "would remove {k1} (2.0 KiB, last used 3.0 d ago)\n\
             would remove {k2} (1.0 KiB, last used 12.0 h ago)\n\
             would remove 2 entries, 3.0 KiB\n\
             would remove 1 orphaned temporary file(s), 100 B\n\
             {d} would hold 1 entry, 3.0 KiB\n\
             the entries of the --keep manifests take more than 1.0 KiB on their own\n"
        )
    );
    assert!(oldest.exists() && old.exists() && recent.exists() && orphan.exists());

    // Unused for more than a day, not kept: only k1 (the kept entry stays, whatever its age).
    let pruned = stdout(&cache_command(
        root.path(),
        &["--dir", d, "--older-than", "1", "--keep", "assets.ron"],
    ));
    assert_eq!(
        pruned,
        format!(
            "removed {k1} (2.0 KiB, last used 3.0 d ago)\n\
             removed 1 entry, 2.0 KiB\n\
             removed 1 orphaned temporary file(s), 100 B\n\
             {d} holds 2 entries, 4.0 KiB\n"
        )
    );
    assert!(oldest.exists() && !old.exists() && recent.exists() && !orphan.exists());
    assert_eq!(fs::read_to_string(&notes).unwrap(), "mine");

    // Without `--keep`, down to 1 KiB: the least recently used goes first.
    let pruned = stdout(&cache_command(
        root.path(),
        &["--dir", d, "--prune-to", "1K"],
    ));
    assert!(
        pruned.starts_with(&format!("removed {kept_key} ")),
        "{pruned}"
    );
    assert!(
        pruned.ends_with(&format!("{d} holds 1 entry, 1.0 KiB\n")),
        "{pruned}"
    );
    assert!(!oldest.exists() && recent.exists() && notes.exists() && copied.exists());
}

#[test]
fn the_default_directory_is_the_nearest_cargo_target() {
    let root = tempfile::tempdir().unwrap();
    let none = cache_command(root.path(), &[]);
    assert_eq!(none.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&none.stderr);
    assert!(
        stderr.starts_with(
            "error: no cache directory: STBN_CACHE_DIR and CARGO_TARGET_DIR are unset and no \
             Cargo `target` folder is in "
        ),
        "{stderr}"
    );
    // A `target` with Cargo's tag above the current folder; no cache in it yet.
    fs::create_dir_all(root.path().join("target")).unwrap();
    fs::write(
        root.path().join("target/CACHEDIR.TAG"),
        "Signature: 8a477f597d28d172789f06886806bc55",
    )
    .unwrap();
    let nested = root.path().join("src/deep");
    fs::create_dir_all(&nested).unwrap();
    let listing = stdout(&cache_command(&nested, &[]));
    assert_eq!(
        listing,
        format!(
            "{}: 0 entries, 0 B\n",
            root.path().join("target/stbn-cache").display()
        )
    );
    // `STBN_CACHE_DIR` wins.
    let output = Command::new(env!("CARGO_BIN_EXE_stbn-gen"))
        .args(["cache"])
        .current_dir(&nested)
        .env("STBN_CACHE_DIR", root.path().join("shared"))
        .output()
        .unwrap();
    assert!(stdout(&output).starts_with(&format!(
        "{}: 0 entries",
        root.path().join("shared").display()
    )));
}

#[test]
fn bad_sizes_and_ages_are_refused() {
    let root = tempfile::tempdir().unwrap();
    for (args, needle) in [
        (
            ["--prune-to", "5MB"],
            "must be a size such as 500M, 2G or 1048576",
        ),
        (
            ["--older-than", "-2"],
            "must be a number of days in 0..=36500",
        ),
    ] {
        let output = cache_command(root.path(), &[&["--dir", "."][..], &args[..]].concat());
        assert_eq!(output.status.code(), Some(2));
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(stderr.contains(needle), "{stderr}");
    }
    let both = cache_command(
        root.path(),
        &["--dir", ".", "--prune-to", "1G", "--older-than", "3"],
    );
    assert_eq!(both.status.code(), Some(2));
}
