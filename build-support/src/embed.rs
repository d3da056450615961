//! The build-script entry points: manifest → blobs (cached) → files in `OUT_DIR` → statics.

use std::fmt;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use rayon::prelude::*;

use crate::cache::{CACHE_DIR_ENV, Cache, CacheStatus, default_cache_dir, write_atomically};
use crate::codegen::{EmbeddedMask, assets_rs};
use crate::encode::stored_uncompressed;
use crate::{Error, Manifest, MaskKind};

/// File name of the generated module in the output directory.
pub const ASSETS_RS: &str = "stbn_assets.rs";

/// Subdirectory of the output directory that holds the embedded blobs, `<name>.stbn`.
pub const BLOB_DIR: &str = "stbn";

/// What [`embed_with`] works on.
#[derive(Clone, Debug)]
pub struct EmbedConfig {
    /// The manifest file.
    pub manifest: PathBuf,
    /// Where `stbn/<name>.stbn` and [`ASSETS_RS`] are written (`OUT_DIR` in a build script).
    pub out_dir: PathBuf,
    /// The blob cache.
    pub cache: Cache,
}

/// What happened to one mask.
#[derive(Clone, Debug)]
pub struct MaskReport {
    /// The mask's `name`.
    pub name: String,
    /// The generated static's name.
    pub static_name: String,
    /// The mask's kind.
    pub kind: MaskKind,
    /// `(width, height, frames)` in pixels, pixels and frames.
    pub size: (u32, u32, u32),
    /// Whether the blob came from the cache.
    pub cache: CacheStatus,
    /// Whether the blob was written to the cache.
    pub stored: bool,
    /// Size of the embedded blob in bytes, 64-byte header included.
    pub bytes: usize,
    /// Time taken to obtain the blob (cache read and verification, or generation and encoding).
    pub time: Duration,
    /// The embedded blob file, `<out_dir>/stbn/<name>.stbn` (absolute).
    pub blob_path: PathBuf,
}

/// What [`embed`] / [`embed_with`] did.
#[derive(Clone, Debug)]
pub struct EmbedReport {
    /// One report per mask, in manifest order.
    pub masks: Vec<MaskReport>,
    /// The generated module, `<out_dir>/stbn_assets.rs` (absolute).
    pub assets_rs: PathBuf,
    /// Problems that did not stop the build (cache entries that were invalid or could not be
    /// written, stale files that could not be removed).
    pub warnings: Vec<String>,
    /// Files besides the manifest that the masks were made from (the images of image kinds),
    /// each once, in manifest order: [`embed`] tracks them with `rerun-if-changed`.
    pub inputs: Vec<PathBuf>,
}

impl fmt::Display for EmbedReport {
    /// One line per mask: `stbn: NAME: hit|miss|invalid cache entry, BYTES bytes, MS ms`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for mask in &self.masks {
            let cache = match &mask.cache {
                CacheStatus::Hit => "cache hit",
                CacheStatus::Miss => "cache miss, generated",
                CacheStatus::Invalid(_) => "invalid cache entry, regenerated",
            };
            writeln!(
                f,
                "stbn: {}: {cache}, {} bytes, {:.1} ms",
                mask.name,
                mask.bytes,
                mask.time.as_secs_f64() * 1e3
            )?;
        }
        Ok(())
    }
}

/// Embeds the masks of `config.manifest`: for each mask, gets its blob from `config.cache` (or
/// generates it, different masks in parallel, with deterministic output; a cache directory that
/// cannot be written is one warning when a mask had to be generated, and the cache's orphaned
/// temporary files are removed first:
/// [`Cache::remove_orphans`](crate::Cache::remove_orphans)), writes it to
/// `<out_dir>/stbn/<name>.stbn`, removes blobs there of masks no longer declared, and writes
/// `<out_dir>/stbn_assets.rs` with one `pub static` per mask (see
/// [`codegen::assets_rs`](crate::codegen::assets_rs)). Files whose content is unchanged are not
/// rewritten.
///
/// Prints nothing and reads no environment variables; [`embed`] is the build-script wrapper.
///
/// # Errors
/// [`Error::Manifest`] / [`Error::Io`] if the manifest is invalid or unreadable, [`Error::Io`] if
/// the output directory cannot be written, [`Error::NonUtf8Path`] if it is not valid UTF-8.
pub fn embed_with(config: &EmbedConfig) -> Result<EmbedReport, Error> {
    let manifest = Manifest::load(&config.manifest)?;
    let out_dir = std::path::absolute(&config.out_dir)
        .map_err(|e| Error::io("resolve the output directory", &config.out_dir, e))?;
    let blob_dir = out_dir.join(BLOB_DIR);
    std::fs::create_dir_all(&blob_dir)
        .map_err(|e| Error::io("create the blob directory", &blob_dir, e))?;

    let mut warnings = Vec::new();
    // Checked once, so an unusable directory costs one warning, not one per mask, and only when
    // a mask had to be generated: entries already there are still read.
    let unwritable = config.cache.prepare().err();
    let store = unwritable.is_none();
    let fetched: Vec<_> = manifest
        .masks()
        .par_iter()
        .map(|entry| {
            let start = Instant::now();
            let result =
                config
                    .cache
                    .fetch_with(&entry.recipe(), entry.encoding, entry.compression, store);
            (result, start.elapsed())
        })
        .collect();

    if let Some(e) = unwritable
        && fetched
            .iter()
            .any(|(result, _)| result.as_ref().is_ok_and(|f| f.status != CacheStatus::Hit))
    {
        warnings.push(format!(
            "the cache directory {} cannot be written ({e}); masks are generated but not \
             cached (set {CACHE_DIR_ENV} to a writable directory)",
            config.cache.dir().display()
        ));
    }
    let mut masks = Vec::with_capacity(fetched.len());
    for (entry, (result, time)) in manifest.masks().iter().zip(fetched) {
        let fetched = result.map_err(|source| Error::Generate {
            mask: entry.name.clone(),
            source,
        })?;
        let blob_path = blob_dir.join(format!("{}.stbn", entry.name));
        write_if_changed(&blob_path, &fetched.blob)?;
        warnings.extend(
            fetched
                .warnings
                .into_iter()
                .map(|w| format!("mask {:?}: {w}", entry.name)),
        );
        if stored_uncompressed(&fetched.blob, entry.compression) {
            warnings.push(format!(
                "mask {:?}: `compression: {:?}` does not make this mask smaller, so it is \
                 embedded uncompressed ({} bytes; the static stays a `PackedStbn`); set \
                 `compression: None` to sample it in place",
                entry.name,
                entry.compression,
                fetched.blob.len()
            ));
        }
        masks.push(MaskReport {
            name: entry.name.clone(),
            static_name: entry.static_name(),
            kind: entry.kind,
            size: entry.size,
            cache: fetched.status,
            stored: fetched.stored,
            bytes: fetched.blob.len(),
            time,
            blob_path,
        });
    }
    warnings.extend(remove_stale_blobs(&blob_dir, &masks));

    let embedded: Vec<EmbeddedMask<'_>> = manifest
        .masks()
        .iter()
        .zip(&masks)
        .map(|(entry, report)| EmbeddedMask {
            entry,
            blob_path: &report.blob_path,
            blob_len: report.bytes,
        })
        .collect();
    let code = assets_rs(manifest.path(), &embedded)?;
    let assets_rs = out_dir.join(ASSETS_RS);
    write_if_changed(&assets_rs, code.as_bytes())?;
    let mut inputs: Vec<PathBuf> = Vec::new();
    for image in manifest.masks().iter().filter_map(|e| e.image.as_ref()) {
        if !inputs.contains(&image.path) {
            inputs.push(image.path.clone());
        }
    }
    Ok(EmbedReport {
        masks,
        assets_rs,
        warnings,
        inputs,
    })
}

/// Writes `bytes` to `path` unless it already holds exactly them (only a regular file no longer
/// than `bytes` is read to compare).
fn write_if_changed(path: &Path, bytes: &[u8]) -> Result<(), Error> {
    let old = stbn_gen::file::read_regular_file(path, bytes.len() as u64);
    if old.is_ok_and(|old| old == bytes) {
        return Ok(());
    }
    write_atomically(path, bytes).map_err(|e| Error::io("write", path, e))
}

/// Removes `*.stbn` files in `blob_dir` that belong to no mask of `masks`; returns warnings for
/// those that could not be removed.
fn remove_stale_blobs(blob_dir: &Path, masks: &[MaskReport]) -> Vec<String> {
    let Ok(dir) = std::fs::read_dir(blob_dir) else {
        return Vec::new();
    };
    dir.flatten()
        .map(|file| file.path())
        .filter(|path| {
            path.extension().is_some_and(|e| e == "stbn")
                && !masks.iter().any(|m| &m.blob_path == path)
        })
        .filter_map(|path| {
            std::fs::remove_file(&path)
                .err()
                .map(|e| format!("could not remove the stale blob {} ({e})", path.display()))
        })
        .collect()
}

/// A path from a Cargo build-script environment variable.
fn env_path(var: &'static str) -> Result<PathBuf, Error> {
    std::env::var_os(var)
        .map(PathBuf::from)
        .ok_or(Error::MissingEnv(var))
}

/// Embeds the masks of a manifest; call it from `build.rs`.
///
/// `manifest_path` is relative to the package root (`CARGO_MANIFEST_DIR`). Blobs are cached in
/// [`default_cache_dir`](crate::cache::default_cache_dir) (`$STBN_CACHE_DIR`, else
/// `<target dir>/stbn-cache`) and written to `OUT_DIR`; the generated module is
/// `$OUT_DIR/stbn_assets.rs`, to be included with
/// `include!(concat!(env!("OUT_DIR"), "/stbn_assets.rs"))`.
///
/// Prints `cargo::rerun-if-changed=<manifest>` and `cargo::rerun-if-env-changed=STBN_CACHE_DIR`
/// (so an unchanged manifest does not rerun the script), `cargo::rerun-if-changed=` for every
/// image the manifest references (a changed image regenerates its masks), and each warning of
/// the report as `cargo::warning=`. A build whose manifest or image is broken fails, and Cargo
/// reruns a failed build script on the next build anyway. See [`embed_with`] for what is written.
///
/// When masks were generated rather than taken from the cache, it also prints one
/// `cargo::warning=` line per generated mask (`COSINE_64 (CosineHemisphere, 64×64×32) was
/// generated in 7.3 s when this build script last ran; cached`) and, if this build script runs at
/// opt-level 0 (about 50× slower) or with debug assertions (about 3× slower), the Cargo.toml
/// profile that fixes it. Cargo shows these lines when the build script has finished, and repeats
/// them on every later build until the script runs again (when the manifest, an image it names or
/// `STBN_CACHE_DIR` changes); a run that takes every mask from the cache prints none of them.
///
/// # Errors
/// [`Error::MissingEnv`] outside a build script; otherwise as [`embed_with`].
pub fn embed(manifest_path: impl AsRef<Path>) -> Result<EmbedReport, Error> {
    let manifest = env_path("CARGO_MANIFEST_DIR")?.join(manifest_path);
    let out_dir = env_path("OUT_DIR")?;
    // Printed before anything can fail, so fixing a broken manifest reruns the script.
    println!("cargo::rerun-if-changed={}", manifest.display());
    println!("cargo::rerun-if-env-changed={CACHE_DIR_ENV}");
    let cache = Cache::new(default_cache_dir()?);
    let report = embed_with(&EmbedConfig {
        manifest,
        out_dir,
        cache,
    })?;
    for input in &report.inputs {
        println!("cargo::rerun-if-changed={}", input.display());
    }
    let generated = generation_lines(&report.masks);
    let advice = (!generated.is_empty())
        .then(|| unoptimised_advice(env!("STBN_BUILD_SUPPORT_OPT_LEVEL"), cfg!(debug_assertions)))
        .flatten();
    for warning in report.warnings.iter().chain(&generated).chain(&advice) {
        for line in warning.lines() {
            println!("cargo::warning={line}");
        }
    }
    Ok(report)
}

/// The Cargo.toml sections that make a build script generate at full speed: optimised, without
/// debug assertions and overflow checks. A CosineHemisphere mask takes about 2.5–3× as long with
/// only `opt-level = 3`, and about 50× as long unoptimised.
const BUILD_PROFILE_ADVICE: &str = "\
[profile.dev.build-override]
opt-level = 3
debug-assertions = false
overflow-checks = false
[profile.release.build-override]
opt-level = 3
debug-assertions = false
overflow-checks = false";

/// One line per mask that was generated rather than taken from the cache, in manifest order.
fn generation_lines(masks: &[MaskReport]) -> Vec<String> {
    masks
        .iter()
        .filter(|mask| mask.cache != CacheStatus::Hit)
        .map(|mask| {
            let (width, height, frames) = mask.size;
            let time = mask.time.as_secs_f64();
            let time = if time < 1.0 {
                format!("{:.0} ms", time * 1e3)
            } else {
                format!("{time:.1} s")
            };
            let cached = if mask.stored { "cached" } else { "not cached" };
            // Cargo repeats a build script's warnings on every build until the script runs
            // again, so the line says when the mask was generated.
            format!(
                "{} ({:?}, {width}×{height}×{frames}) was generated in {time} when this build \
                 script last ran; {cached}",
                mask.static_name, mask.kind
            )
        })
        .collect()
}

/// The warning for a build script compiled with `opt_level` (Cargo's `OPT_LEVEL`: `0`…`3`, `s`,
/// `z`) and `debug_assertions`, or `None` when it runs at full speed.
fn unoptimised_advice(opt_level: &str, debug_assertions: bool) -> Option<String> {
    let problem = match (opt_level == "0", debug_assertions) {
        (false, false) => return None,
        (true, true) => {
            "unoptimised and with debug assertions, which makes mask generation about \
                         50× slower"
        }
        (true, false) => "unoptimised, which makes mask generation about 50× slower",
        (false, true) => "with debug assertions, which makes mask generation about 3× slower",
    };
    Some(format!(
        "the build script ran {problem}; add to Cargo.toml:\n{BUILD_PROFILE_ADVICE}"
    ))
}

/// [`embed`], turning an error into a clean build failure: the error is printed as
/// `cargo::error=` lines, which Cargo shows once each as `error: …` before failing the build.
/// The process then exits with status 0: a failing status would make Cargo print the script's
/// whole output again, the error included, and (with `RUST_BACKTRACE` set) a note about
/// backtraces, though nothing panicked. Outside a build script ([`Error::MissingEnv`]) no Cargo
/// reads the lines, and the status is 1. On success prints the report (visible with
/// `cargo build -vv`) and returns it.
pub fn embed_or_exit(manifest_path: impl AsRef<Path>) -> EmbedReport {
    match embed(manifest_path) {
        Ok(report) => {
            print!("{report}");
            report
        }
        Err(error) => {
            for line in error.to_string().lines() {
                println!("cargo::error={line}");
            }
            let status = i32::from(matches!(error, Error::MissingEnv(_)));
            std::process::exit(status)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn report(name: &str, cache: CacheStatus, stored: bool, time: Duration) -> MaskReport {
        MaskReport {
            name: name.to_owned(),
            static_name: name.to_ascii_uppercase(),
            kind: MaskKind::CosineHemisphere,
            size: (64, 64, 32),
            cache,
            stored,
            bytes: 64,
            time,
            blob_path: PathBuf::from(format!("{name}.stbn")),
        }
    }

    #[test]
    fn one_line_per_generated_mask() {
        let masks = [
            report("hit", CacheStatus::Hit, false, Duration::from_millis(3)),
            report(
                "slow",
                CacheStatus::Miss,
                true,
                Duration::from_millis(7_345),
            ),
            report(
                "fast",
                CacheStatus::Miss,
                false,
                Duration::from_micros(12_400),
            ),
            report(
                "bad",
                CacheStatus::Invalid("short".to_owned()),
                true,
                Duration::from_millis(999),
            ),
        ];
        assert_eq!(
            generation_lines(&masks),
            [
                "SLOW (CosineHemisphere, 64×64×32) was generated in 7.3 s when this build script last \
                 ran; cached",
                "FAST (CosineHemisphere, 64×64×32) was generated in 12 ms when this build script last \
                 ran; not cached",
                "BAD (CosineHemisphere, 64×64×32) was generated in 999 ms when this build script last \
                 ran; cached",
            ]
        );
        assert!(generation_lines(&masks[..1]).is_empty());
    }

    #[test]
    fn advice_only_for_slow_build_scripts() {
        for level in ["1", "2", "3", "s", "z"] {
            assert_eq!(unoptimised_advice(level, false), None, "{level}");
        }
        for (level, debug, problem) in [
            (
                "0",
                true,
                "ran unoptimised and with debug assertions, which makes mask generation about 50× \
                 slower;",
            ),
            (
                "0",
                false,
                "ran unoptimised, which makes mask generation about 50× slower;",
            ),
            (
                "3",
                true,
                "ran with debug assertions, which makes mask generation about 3× slower;",
            ),
        ] {
            let advice = unoptimised_advice(level, debug).unwrap();
            assert!(advice.contains(problem), "{advice}");
            assert!(advice.ends_with(BUILD_PROFILE_ADVICE), "{advice}");
        }
    }

    /// The advice is valid TOML that sets the three fields in both profiles.
    #[test]
    fn advice_is_a_cargo_profile() {
        let toml: Vec<&str> = BUILD_PROFILE_ADVICE.lines().collect();
        for profile in ["dev", "release"] {
            let header = format!("[profile.{profile}.build-override]");
            let start = toml.iter().position(|l| *l == header).unwrap();
            assert_eq!(
                toml[start + 1..start + 4],
                [
                    "opt-level = 3",
                    "debug-assertions = false",
                    "overflow-checks = false"
                ]
            );
        }
    }
}
