//! `embed_with` end to end on small manifests: cache hits, invalid entries, concurrency,
//! unwritable cache directories, and what ends up in the output directory.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Barrier};

use stbn_build_support::{
    Cache, CacheKey, CacheStatus, EmbedConfig, EmbedReport, Error, Manifest, embed_with,
};
use tempfile::TempDir;

const MANIFEST: &str = r#"(
    masks: [
        (name: "a", kind: Scalar, size: (16, 16, 8), seed: 1, encoding: Unorm8),
        (name: "b", kind: Blue3D, size: (16, 8, 4), seed: 2, sigma: 1.5, encoding: F32, compression: Lz4),
        (name: "c", kind: Blue2D, size: (8, 8, 4), seed: 3, encoding: Unorm16, compression: Deflate),
    ],
)
"#;

/// A temporary directory holding a manifest.
struct Project {
    dir: TempDir,
}

impl Project {
    fn new(manifest: &str) -> Project {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("assets.ron"), manifest).unwrap();
        Project { dir }
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    fn config(&self, out: &str, cache: &Path) -> EmbedConfig {
        EmbedConfig {
            manifest: self.path("assets.ron"),
            out_dir: self.path(out),
            cache: Cache::new(cache),
        }
    }

    fn embed(&self, out: &str, cache: &Path) -> EmbedReport {
        embed_with(&self.config(out, cache)).unwrap()
    }

    fn manifest(&self) -> Manifest {
        Manifest::load(self.path("assets.ron")).unwrap()
    }
}

/// The embedded blobs of a report, by mask.
fn blobs(report: &EmbedReport) -> Vec<Vec<u8>> {
    report
        .masks
        .iter()
        .map(|m| std::fs::read(&m.blob_path).unwrap())
        .collect()
}

fn statuses(report: &EmbedReport) -> Vec<CacheStatus> {
    report.masks.iter().map(|m| m.cache.clone()).collect()
}

/// The blob each mask of `manifest` encodes to, straight from the generator.
fn expected_blobs(manifest: &Manifest) -> Vec<Vec<u8>> {
    manifest
        .masks()
        .iter()
        .map(|m| m.recipe().make(m.encoding, m.compression).unwrap().1)
        .collect()
}

fn cache_files(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn second_embed_is_a_hit_with_identical_bytes() {
    let project = Project::new(MANIFEST);
    let cache = project.path("cache");
    let first = project.embed("out1", &cache);
    assert_eq!(statuses(&first), vec![CacheStatus::Miss; 3]);
    assert!(first.masks.iter().all(|m| m.stored));
    assert!(first.warnings.is_empty(), "{:?}", first.warnings);
    assert_eq!(blobs(&first), expected_blobs(&project.manifest()));
    for (report, name) in first.masks.iter().zip(["a", "b", "c"]) {
        assert_eq!(report.name, name);
        assert_eq!(report.static_name, name.to_uppercase());
        assert_eq!(
            report.blob_path,
            project.path("out1").join(format!("stbn/{name}.stbn"))
        );
        assert_eq!(
            report.bytes,
            std::fs::read(&report.blob_path).unwrap().len()
        );
    }
    assert_eq!(cache_files(&cache).len(), 3);

    // Another output directory (a clean build) with the same cache: nothing is generated.
    let second = project.embed("out2", &cache);
    assert_eq!(statuses(&second), vec![CacheStatus::Hit; 3]);
    assert!(second.masks.iter().all(|m| !m.stored));
    assert_eq!(blobs(&second), blobs(&first));

    // The same output directory (an unchanged rebuild): hits, and files are left untouched.
    let modified = |report: &EmbedReport| {
        std::fs::metadata(&report.assets_rs)
            .unwrap()
            .modified()
            .unwrap()
    };
    let before = modified(&second);
    let third = project.embed("out2", &cache);
    assert_eq!(statuses(&third), vec![CacheStatus::Hit; 3]);
    assert_eq!(modified(&third), before);
    assert_eq!(
        std::fs::read_to_string(&third.assets_rs).unwrap(),
        std::fs::read_to_string(&second.assets_rs).unwrap()
    );
}

#[test]
fn generated_module_declares_each_mask() {
    let project = Project::new(MANIFEST);
    let report = project.embed("out", &project.path("cache"));
    assert_eq!(report.assets_rs, project.path("out/stbn_assets.rs"));
    let code = std::fs::read_to_string(&report.assets_rs).unwrap();
    for (name, ty, include) in [
        ("A", "Stbn", "include_stbn"),
        ("B", "PackedStbn", "include_packed_stbn"),
        ("C", "PackedStbn", "include_packed_stbn"),
    ] {
        assert!(
            code.contains(&format!(
                "pub static {name}: ::stbn_runtime::{ty}<'static> =\n    ::stbn_runtime::{include}!("
            )),
            "{code}"
        );
    }
    let path = project.path("out/stbn/a.stbn");
    assert!(code.contains(&format!(
        "::stbn_runtime::include_stbn!({:?});",
        path.to_str().unwrap()
    )));
    assert!(code.contains("/// `b`: Blue3D mask"));
    assert!(code.contains("σ 1.5 pixels in space, 1.5 frames in time"));
}

/// The cache key of mask `index` of the project's manifest.
fn key(project: &Project, index: usize) -> CacheKey {
    let manifest = project.manifest();
    let mask = &manifest.masks()[index];
    CacheKey::new(&mask.recipe(), mask.encoding, mask.compression)
}

/// The cache entry of mask `index` of the project's manifest.
fn entry_path(project: &Project, cache: &Path, index: usize) -> PathBuf {
    Cache::new(cache).entry_path(&key(project, index))
}

#[test]
fn invalid_cache_entries_are_detected_and_regenerated() {
    let project = Project::new(MANIFEST);
    let cache = project.path("cache");
    let good = blobs(&project.embed("out", &cache));
    let entries: Vec<PathBuf> = (0..3).map(|i| entry_path(&project, &cache, i)).collect();

    // A flipped payload byte, a truncated file, and a valid blob of another mask.
    let mut flipped = good[0].clone();
    flipped[100] ^= 0x40;
    std::fs::write(&entries[0], flipped).unwrap();
    std::fs::write(&entries[1], &good[1][..70]).unwrap();
    std::fs::write(&entries[2], &good[0]).unwrap();

    let report = project.embed("out", &cache);
    let reasons: Vec<String> = report
        .masks
        .iter()
        .map(|m| match &m.cache {
            CacheStatus::Invalid(reason) => reason.clone(),
            other => panic!("{}: {other:?}", m.name),
        })
        .collect();
    assert!(reasons[0].contains("checksum"), "{}", reasons[0]);
    assert!(reasons[1].contains("truncated"), "{}", reasons[1]);
    assert!(reasons[2].contains("expected 8x8x4"), "{}", reasons[2]);
    assert_eq!(report.warnings.len(), 3);
    for (warning, entry) in report.warnings.iter().zip(&entries) {
        assert!(warning.contains("is invalid"), "{warning}");
        assert!(warning.contains(&entry.display().to_string()), "{warning}");
    }
    assert!(report.masks.iter().all(|m| m.stored));
    assert_eq!(blobs(&report), good);
    for (index, (entry, blob)) in entries.iter().zip(&good).enumerate() {
        assert_eq!(
            std::fs::read(entry).unwrap(),
            key(&project, index).entry_bytes(blob),
            "entry was not overwritten"
        );
    }
    assert_eq!(
        statuses(&project.embed("out", &cache)),
        vec![CacheStatus::Hit; 3]
    );
}

#[test]
fn concurrent_embeds_into_one_cache_both_succeed() {
    let project = Arc::new(Project::new(MANIFEST));
    let cache = project.path("cache");
    let barrier = Arc::new(Barrier::new(2));
    let threads: Vec<_> = ["out1", "out2"]
        .into_iter()
        .map(|out| {
            let (project, barrier, cache) = (project.clone(), barrier.clone(), cache.clone());
            std::thread::spawn(move || {
                let config = project.config(out, &cache);
                barrier.wait();
                embed_with(&config)
            })
        })
        .collect();
    let reports: Vec<EmbedReport> = threads
        .into_iter()
        .map(|t| t.join().unwrap().unwrap())
        .collect();
    assert_eq!(blobs(&reports[0]), blobs(&reports[1]));
    assert_eq!(blobs(&reports[0]), expected_blobs(&project.manifest()));
    // Whole entries only: no temporary files left behind, and every entry verifies.
    let names = cache_files(&cache);
    assert_eq!(names.len(), 3, "{names:?}");
    assert!(
        names
            .iter()
            .all(|n| n.ends_with(".stbn") && !n.starts_with('.'))
    );
    assert_eq!(
        statuses(&project.embed("out3", &cache)),
        vec![CacheStatus::Hit; 3]
    );
}

#[test]
fn unwritable_cache_location_warns_once_per_build() {
    let project = Project::new(MANIFEST);
    // A directory cannot be created below a regular file, whoever runs the test; and a regular
    // file is no directory (`STBN_CACHE_DIR` naming a file).
    std::fs::write(project.path("file"), "not a directory").unwrap();
    for cache in [project.path("file/cache"), project.path("file")] {
        let report = project.embed("out", &cache);
        assert_eq!(statuses(&report), vec![CacheStatus::Miss; 3]);
        assert!(report.masks.iter().all(|m| !m.stored));
        assert_eq!(report.warnings.len(), 1, "{:?}", report.warnings);
        let prefix = format!(
            "the cache directory {} cannot be written (",
            cache.display()
        );
        assert!(
            report.warnings[0].starts_with(&prefix),
            "{}",
            report.warnings[0]
        );
        assert!(
            report.warnings[0].ends_with(
                "); masks are generated but not cached (set STBN_CACHE_DIR to a writable \
                 directory)"
            ),
            "{}",
            report.warnings[0]
        );
        assert_eq!(blobs(&report), expected_blobs(&project.manifest()));
    }
    assert_eq!(
        std::fs::read_to_string(project.path("file")).unwrap(),
        "not a directory"
    );
}

#[cfg(unix)]
#[test]
fn read_only_cache_dir_still_builds() {
    use std::os::unix::fs::PermissionsExt;

    let project = Project::new(MANIFEST);
    let cache = project.path("cache");
    std::fs::create_dir(&cache).unwrap();
    std::fs::set_permissions(&cache, std::fs::Permissions::from_mode(0o555)).unwrap();
    // Privileged users (root in containers) may write anyway; then the write simply succeeds.
    let writable = std::fs::write(cache.join("probe"), b"").is_ok();
    let _ = std::fs::remove_file(cache.join("probe"));

    let result = embed_with(&project.config("out", &cache));
    std::fs::set_permissions(&cache, std::fs::Permissions::from_mode(0o755)).unwrap();
    let report = result.unwrap();
    assert_eq!(blobs(&report), expected_blobs(&project.manifest()));
    assert!(report.masks.iter().all(|m| m.stored == writable));
    assert_eq!(
        report.warnings.len(),
        usize::from(!writable),
        "{:?}",
        report.warnings
    );

    // A read-only cache that holds every mask: hits, and nothing to warn about.
    project.embed("out", &cache);
    std::fs::set_permissions(&cache, std::fs::Permissions::from_mode(0o555)).unwrap();
    let result = embed_with(&project.config("out2", &cache));
    std::fs::set_permissions(&cache, std::fs::Permissions::from_mode(0o755)).unwrap();
    let report = result.unwrap();
    assert_eq!(statuses(&report), vec![CacheStatus::Hit; 3]);
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
}

#[test]
fn only_declared_masks_are_embedded() {
    let project = Project::new(MANIFEST);
    let cache = project.path("cache");
    project.embed("out", &cache);
    assert_eq!(
        cache_files(&project.path("out/stbn")),
        ["a.stbn", "b.stbn", "c.stbn"]
    );

    let only_c = MANIFEST
        .lines()
        .filter(|l| !l.contains("name: \"a\"") && !l.contains("name: \"b\""))
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(project.path("assets.ron"), only_c).unwrap();
    let report = project.embed("out", &cache);
    assert_eq!(statuses(&report), vec![CacheStatus::Hit]);
    assert_eq!(cache_files(&project.path("out/stbn")), ["c.stbn"]);
    let code = std::fs::read_to_string(&report.assets_rs).unwrap();
    assert_eq!(code.matches("pub static").count(), 1);
    assert!(code.contains("pub static C:"));
}

#[test]
fn output_does_not_depend_on_manifest_order() {
    let forward = Project::new(MANIFEST);
    let mut lines: Vec<&str> = MANIFEST.lines().collect();
    lines[2..5].reverse();
    let backward = Project::new(&lines.join("\n"));
    let a = forward.embed("out", &forward.path("cache"));
    let b = backward.embed("out", &backward.path("cache"));
    let mut blobs_b = blobs(&b);
    blobs_b.reverse();
    assert_eq!(blobs(&a), blobs_b);
}

#[test]
fn manifest_problems_stop_the_embed() {
    let project = Project::new("(masks: [(name: \"a\")])");
    let err = embed_with(&project.config("out", &project.path("cache"))).unwrap_err();
    let Error::Manifest(err) = err else {
        panic!("{err:?}")
    };
    assert_eq!(err.field(), Some("kind"));

    let missing = EmbedConfig {
        manifest: project.path("nope.ron"),
        ..project.config("out", &project.path("cache"))
    };
    let err = embed_with(&missing).unwrap_err();
    assert!(matches!(err, Error::Io { .. }), "{err:?}");
    assert!(
        err.to_string().starts_with("could not read the manifest"),
        "{err}"
    );
}

#[test]
fn an_entry_is_bound_to_its_key() {
    // Two masks of one size and layout: their blobs pass each other's header checks.
    let project = Project::new(
        r#"(masks: [
            (name: "a", kind: Scalar, size: (8, 8, 4), seed: 1, encoding: Unorm8),
            (name: "b", kind: Scalar, size: (8, 8, 4), seed: 2, encoding: Unorm8),
        ])"#,
    );
    let cache = project.path("cache");
    let good = blobs(&project.embed("out", &cache));
    assert_ne!(good[0], good[1]);
    let (a, b) = (
        entry_path(&project, &cache, 0),
        entry_path(&project, &cache, 1),
    );
    assert_eq!(
        std::fs::read(&a).unwrap(),
        key(&project, 0).entry_bytes(&good[0])
    );

    // a's entry copied to b's path: a valid blob of the right shape, bound to another key.
    std::fs::copy(&a, &b).unwrap();
    let report = project.embed("out", &cache);
    assert_eq!(report.masks[0].cache, CacheStatus::Hit);
    let CacheStatus::Invalid(reason) = &report.masks[1].cache else {
        panic!("{:?}", report.masks[1].cache)
    };
    assert!(reason.contains("names another key"), "{reason}");
    assert_eq!(blobs(&report), good, "b embeds its own mask, regenerated");
    assert_eq!(
        std::fs::read(&b).unwrap(),
        key(&project, 1).entry_bytes(&good[1])
    );

    // The bare blob, without its key record.
    std::fs::write(&b, &good[1]).unwrap();
    let report = project.embed("out", &cache);
    let CacheStatus::Invalid(reason) = &report.masks[1].cache else {
        panic!("{:?}", report.masks[1].cache)
    };
    assert!(reason.contains("no key record"), "{reason}");
    assert_eq!(blobs(&report), good);
    assert_eq!(
        statuses(&project.embed("out", &cache)),
        vec![CacheStatus::Hit; 2]
    );
}

#[cfg(unix)]
#[test]
fn entries_that_are_not_regular_files_or_too_large_are_regenerated_without_reading() {
    let project = Project::new(MANIFEST);
    let cache = project.path("cache");
    let good = blobs(&project.embed("out", &cache));
    let entries: Vec<PathBuf> = (0..3).map(|i| entry_path(&project, &cache, i)).collect();
    std::fs::remove_file(&entries[0]).unwrap();
    assert!(
        std::process::Command::new("mkfifo")
            .arg(&entries[0])
            .status()
            .unwrap()
            .success()
    );
    std::fs::remove_file(&entries[1]).unwrap();
    std::os::unix::fs::symlink("/dev/zero", &entries[1]).unwrap();
    // Far larger than any entry of this mask can be.
    std::fs::write(&entries[2], vec![0u8; 1 << 20]).unwrap();

    let config = project.config("out", &cache);
    let (send, receive) = std::sync::mpsc::channel();
    std::thread::spawn(move || send.send(embed_with(&config)));
    let report = receive
        .recv_timeout(std::time::Duration::from_secs(60))
        .expect("embed_with returned within 60 s")
        .unwrap();
    let reasons: Vec<String> = report
        .masks
        .iter()
        .map(|m| match &m.cache {
            CacheStatus::Invalid(reason) => reason.clone(),
            other => panic!("{}: {other:?}", m.name),
        })
        .collect();
    assert!(reasons[0].contains("not a regular file"), "{}", reasons[0]);
    assert!(reasons[1].contains("not a regular file"), "{}", reasons[1]);
    assert!(reasons[2].contains("over the limit"), "{}", reasons[2]);
    assert_eq!(blobs(&report), good);
}

/// Sets the modification time of `path` to `ago` before now.
fn age_file(path: &Path, ago: std::time::Duration) {
    std::fs::File::options()
        .write(true)
        .open(path)
        .unwrap()
        .set_modified(std::time::SystemTime::now() - ago)
        .unwrap();
}

const HOUR: std::time::Duration = std::time::Duration::from_secs(3600);

#[test]
fn orphaned_temporaries_are_removed_and_nothing_else() {
    let project = Project::new(MANIFEST);
    let cache = project.path("cache");
    std::fs::create_dir_all(&cache).unwrap();
    let file = |name: &str, ago: std::time::Duration| {
        let path = cache.join(name);
        std::fs::write(&path, b"partial entry").unwrap();
        age_file(&path, ago);
        path
    };
    // A killed writer's file: unlocked and untouched for an hour.
    let stale = file(".tmp-Ab12Cd.part", HOUR);
    // A live writer's file: locked, however old.
    let live = file(".tmp-Ef34Gh.part", HOUR);
    let lock = std::fs::File::open(&live).unwrap();
    lock.try_lock().unwrap();
    // Just created: its writer may not have locked it yet.
    let fresh = file(".tmp-Ij56Kl.part", std::time::Duration::ZERO);
    // Not ours: other names, a folder and a link with the pattern's name.
    let foreign: Vec<PathBuf> = [
        ".tmp-Ab12Cd.partial",
        ".tmp-Ab12C.part",
        ".tmp-Ab12Cde.part",
        ".tmp-Ab-2Cd.part",
        "tmp-Ab12Cd.part",
        "notes.txt",
    ]
    .iter()
    .map(|name| file(name, HOUR))
    .collect();
    std::fs::create_dir(cache.join(".tmp-Dir123.part")).unwrap();
    let target = project.path("elsewhere");
    std::fs::write(&target, b"a user's file").unwrap();
    #[cfg(unix)]
    std::os::unix::fs::symlink(&target, cache.join(".tmp-Lnk123.part")).unwrap();

    let listed = Cache::new(&cache).remove_orphans(true).unwrap();
    assert_eq!(
        listed,
        [stbn_build_support::cache::Orphan {
            path: stale.clone(),
            bytes: 13
        }]
    );
    assert!(stale.exists(), "a dry run removes nothing");

    let report = project.embed("out", &cache);
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    assert!(!stale.exists());
    assert!(live.exists() && fresh.exists());
    assert!(foreign.iter().all(|path| path.exists()));
    assert!(cache.join(".tmp-Dir123.part").is_dir());
    assert_eq!(std::fs::read(&target).unwrap(), b"a user's file");
    #[cfg(unix)]
    assert!(cache.join(".tmp-Lnk123.part").is_symlink());

    // Once its writer is gone, the live file is an orphan too.
    drop(lock);
    assert_eq!(Cache::new(&cache).remove_orphans(false).unwrap().len(), 1);
    assert!(!live.exists() && fresh.exists());
}

#[test]
fn entries_are_listed_by_last_use_and_pruned_keeping_the_manifest() {
    use stbn_build_support::cache::{PruneRule, manifest_keys};

    let project = Project::new(MANIFEST);
    let cache_dir = project.path("cache");
    project.embed("out", &cache_dir);
    let cache = Cache::new(&cache_dir);
    let paths: Vec<PathBuf> = (0..3)
        .map(|i| entry_path(&project, &cache_dir, i))
        .collect();
    // Used 3, 2 and 1 days ago: a, b, c.
    for (path, days) in paths.iter().zip([72, 48, 24]) {
        age_file(path, HOUR * days);
    }
    // Not entries: a foreign file with an entry's name, a file with another name.
    let foreign = cache_dir.join(format!("{}.stbn", "0".repeat(64)));
    std::fs::write(&foreign, b"not a blob").unwrap();
    std::fs::write(cache_dir.join("notes.stbn"), b"STBN notes").unwrap();
    // An entry copied under another key's name: its key record names the original key.
    let copied = cache_dir.join(format!("{}.stbn", "f".repeat(64)));
    std::fs::copy(&paths[0], &copied).unwrap();

    let entries = cache.entries().unwrap();
    let listed: Vec<&PathBuf> = entries.iter().map(|e| &e.path).collect();
    assert_eq!(listed, paths.iter().collect::<Vec<_>>());
    for (entry, path) in entries.iter().zip(&paths) {
        assert_eq!(entry.bytes, std::fs::metadata(path).unwrap().len());
        assert_eq!(
            entry.key,
            path.file_stem().unwrap().to_str().unwrap(),
            "the key is the file stem"
        );
    }
    let bytes: Vec<u64> = entries.iter().map(|e| e.bytes).collect();

    // Unused for more than 36 hours: a and b; a dry run only says so.
    let dry = cache
        .prune(PruneRule::OlderThan(HOUR * 36), &[], true)
        .unwrap();
    let removed: Vec<&PathBuf> = dry.removed.iter().map(|e| &e.path).collect();
    assert_eq!(removed, [&paths[0], &paths[1]]);
    assert!(paths.iter().all(|p| p.exists()));

    // Down to c's size + 1, keeping a (the manifest of mask a alone): b and then c go.
    let manifest_a = project.path("a.ron");
    std::fs::write(
        &manifest_a,
        "(masks: [(name: \"a\", kind: Scalar, size: (16, 16, 8), seed: 1, encoding: Unorm8)])",
    )
    .unwrap();
    let keep = manifest_keys(&Manifest::load(&manifest_a).unwrap());
    assert_eq!(keep, [key(&project, 0)]);
    let pruned = cache
        .prune(PruneRule::ToSize(bytes[2] + 1), &keep, false)
        .unwrap();
    assert!(pruned.failures.is_empty());
    let removed: Vec<&PathBuf> = pruned.removed.iter().map(|e| &e.path).collect();
    assert_eq!(removed, [&paths[1], &paths[2]]);
    let kept: Vec<&PathBuf> = pruned.kept.iter().map(|e| &e.path).collect();
    assert_eq!(kept, [&paths[0]]);
    assert!(paths[0].exists() && !paths[1].exists() && !paths[2].exists());
    assert!(foreign.exists() && cache_dir.join("notes.stbn").exists() && copied.exists());

    // A size the entries already fit removes nothing; a hit refreshes the last use.
    let pruned = cache
        .prune(PruneRule::ToSize(bytes[0]), &[], false)
        .unwrap();
    assert!(pruned.removed.is_empty());
    let report = project.embed("out", &cache_dir);
    assert_eq!(report.masks[0].cache, CacheStatus::Hit);
    let used = cache.entries().unwrap();
    let a = used.iter().find(|e| e.path == paths[0]).unwrap();
    assert!(a.last_used.elapsed().unwrap() < HOUR, "{:?}", a.last_used);
    // A directory that does not exist holds nothing.
    let missing = Cache::new(project.path("missing"));
    assert!(missing.entries().unwrap().is_empty());
    assert!(missing.remove_orphans(false).unwrap().is_empty());
}
