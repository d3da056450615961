//! A content-addressed cache of encoded blobs, shared by builds.
//!
//! Each entry is stored as `<dir>/<key>.stbn` where the key is the BLAKE3 hash of a canonical
//! description of everything that determines the blob's bytes: the [`Recipe`] (generator, spec
//! fields, image content hash, layout), the encoding and compression, [`GENERATOR_VERSION`],
//! [`ENCODER_VERSION`], the `.stbn` format version, [`DEFLATE_LEVEL`] and the version of the entry
//! format below. Mask names are not part of the key, so equal masks under different names
//! share an entry.
//!
//! # Entry format
//!
//! An entry is the finished `.stbn` blob, unchanged, followed by a 48-byte key record: the 16
//! bytes `stbn-cache-key\0\x02`, then the entry's 32-byte key ([`CacheKey::entry_bytes`]). The blob format is the runtime's and
//! has no room for the key; the record binds the file to the key it was written for, so a valid
//! blob copied or renamed to another key's path (another mask's bytes) is not a hit.
//!
//! * Writes go to a uniquely named temporary file in the cache directory, renamed over the entry:
//!   concurrent builds each write whole files, and readers never see a partial one.
//! * Reads take only a regular file (a FIFO or device is refused without reading it) no larger
//!   than a valid entry of the recipe can be, checked before reading, in one read.
//! * Reads are verified: the blob ([`PackedStbn::from_bytes`] plus a header comparison with the
//!   recipe), then the key record. An entry that fails is regenerated and overwritten, with a
//!   warning.
//! * A cache directory that cannot be created or written only costs a warning: the blob is still
//!   generated and returned.
//!
//! Location ([`default_cache_dir`]): `$STBN_CACHE_DIR` if set and non-empty, else
//! `<target dir>/stbn-cache`.

use std::io::{self, Write as _};
use std::path::{Path, PathBuf};

use stbn_gen::VectorSpecError;
use stbn_runtime::{Compression, Encoding, MaskHeader, PackedStbn};

use crate::Error;
use crate::encode::{DEFLATE_LEVEL, ENCODER_VERSION};
use crate::recipe::Recipe;

/// Version of the generator's output, part of every cache key.
///
/// Owned by the generator, which bumps it whenever its output changes, so stale cache entries
/// are no longer found.
pub use stbn_gen::GENERATOR_VERSION;

/// Environment variable that overrides the cache directory.
pub const CACHE_DIR_ENV: &str = "STBN_CACHE_DIR";

/// Version of the entry format ([module docs](self)), part of every key: entries of another
/// format are never looked up.
const ENTRY_FORMAT: u32 = 2;

/// The first 16 bytes of the key record that ends every entry.
const KEY_RECORD_MAGIC: [u8; 16] = *b"stbn-cache-key\x00\x02";

/// Bytes of the key record: [`KEY_RECORD_MAGIC`] and the 32-byte key.
const KEY_RECORD_LEN: usize = KEY_RECORD_MAGIC.len() + blake3::OUT_LEN;

/// The identity of a blob: a BLAKE3 hash of its canonical description.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct CacheKey(blake3::Hash);

impl CacheKey {
    /// The key of the blob that `recipe` encoded with `encoding` and `compression` produces.
    pub fn new(recipe: &Recipe, encoding: Encoding, compression: Compression) -> CacheKey {
        CacheKey(blake3::hash(
            canonical_description(recipe, encoding, compression).as_bytes(),
        ))
    }

    /// The key as 64 lowercase hex digits (the entry's file stem).
    pub fn to_hex(&self) -> String {
        self.0.to_hex().to_string()
    }

    /// `blob` followed by the key record that binds it to this key: the bytes of a cache entry.
    pub fn entry_bytes(&self, blob: &[u8]) -> Vec<u8> {
        let mut entry = Vec::with_capacity(blob.len() + KEY_RECORD_LEN);
        entry.extend_from_slice(blob);
        entry.extend_from_slice(&KEY_RECORD_MAGIC);
        entry.extend_from_slice(self.0.as_bytes());
        entry
    }
}

/// One line per input, floats as their exact bit patterns.
fn canonical_description(recipe: &Recipe, encoding: Encoding, compression: Compression) -> String {
    format!(
        "stbn-build-support cache entry\n\
         entry_format={ENTRY_FORMAT}\n\
         generator_version={GENERATOR_VERSION}\n\
         encoder_version={ENCODER_VERSION}\n\
         stbn_format_version={}\n\
         deflate_level={DEFLATE_LEVEL}\n\
         encoding={encoding:?}\ncompression={compression:?}\n{}",
        MaskHeader::FORMAT_VERSION,
        recipe.canonical_description(),
    )
}

/// How a blob was obtained.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum CacheStatus {
    /// Read from the cache and verified.
    Hit,
    /// Not in the cache: generated.
    Miss,
    /// The cache entry failed verification (holds why): regenerated.
    Invalid(String),
}

/// A blob from [`Cache::fetch`].
#[derive(Clone, Debug)]
pub struct Fetched {
    /// The complete `.stbn` blob.
    pub blob: Vec<u8>,
    /// Whether it came from the cache.
    pub status: CacheStatus,
    /// Whether this fetch wrote the blob to the cache (`false` for hits and failed writes).
    pub stored: bool,
    /// Problems worth telling the user about (invalid entries, failed reads or writes).
    pub warnings: Vec<String>,
}

/// A cache directory.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Cache {
    dir: PathBuf,
}

impl Cache {
    /// A cache in `dir` (created on the first write).
    pub fn new(dir: impl Into<PathBuf>) -> Cache {
        Cache { dir: dir.into() }
    }

    /// The cache directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Where the entry for `key` lives.
    pub fn entry_path(&self, key: &CacheKey) -> PathBuf {
        self.dir.join(format!("{}.stbn", key.to_hex()))
    }

    /// The blob for `recipe` with `encoding` and `compression`: from the cache if a valid entry
    /// exists, else made with [`Recipe::make`] and stored.
    ///
    /// # Errors
    /// Only if the recipe's spec is invalid; cache problems become [`Fetched::warnings`].
    pub fn fetch(
        &self,
        recipe: &Recipe,
        encoding: Encoding,
        compression: Compression,
    ) -> Result<Fetched, VectorSpecError> {
        let key = CacheKey::new(recipe, encoding, compression);
        let path = self.entry_path(&key);
        let mut warnings = Vec::new();
        let read = stbn_gen::file::read_regular_file(&path, max_entry_len(recipe, encoding));
        let status = match read {
            Ok(entry) => match verify_entry(&entry, &key, recipe, encoding, compression) {
                Ok(()) => {
                    let mut blob = entry;
                    blob.truncate(blob.len() - KEY_RECORD_LEN);
                    return Ok(Fetched {
                        blob,
                        status: CacheStatus::Hit,
                        stored: false,
                        warnings,
                    });
                }
                Err(reason) => {
                    warnings.push(format!(
                        "cache entry {} is invalid ({reason}); regenerating it",
                        path.display()
                    ));
                    CacheStatus::Invalid(reason)
                }
            },
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::NotFound | io::ErrorKind::NotADirectory
                ) =>
            {
                CacheStatus::Miss
            }
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::InvalidInput | io::ErrorKind::InvalidData
                ) =>
            {
                // Not a regular file, or larger than any valid entry of this recipe.
                let reason = e.to_string();
                warnings.push(format!(
                    "cache entry {} is invalid ({reason}); regenerating it",
                    path.display()
                ));
                CacheStatus::Invalid(reason)
            }
            Err(e) => {
                warnings.push(format!(
                    "could not read cache entry {} ({e}); regenerating it",
                    path.display()
                ));
                CacheStatus::Miss
            }
        };
        let (_, blob) = recipe.make(encoding, compression)?;
        let stored = match write_atomically(&path, &key.entry_bytes(&blob)) {
            Ok(()) => true,
            Err(e) => {
                warnings.push(format!(
                    "could not write cache entry {} ({e}); continuing without caching it",
                    path.display()
                ));
                false
            }
        };
        Ok(Fetched {
            blob,
            status,
            stored,
            warnings,
        })
    }
}

/// The most bytes a valid entry of `recipe` stored with `encoding` can have: the 64-byte header,
/// the payload uncompressed plus what compression may add to incompressible data (LZ4 and
/// deflate's stored blocks both add under 1%), and the key record.
fn max_entry_len(recipe: &Recipe, encoding: Encoding) -> u64 {
    let (width, height, depth) = recipe.size();
    let raw = u64::from(width)
        * u64::from(height)
        * u64::from(depth)
        * u64::from(recipe.layout().channels)
        * encoding.bytes_per_element() as u64;
    64 + raw + raw / 64 + 4096 + KEY_RECORD_LEN as u64
}

/// Checks a cache entry read from `key`'s path: its blob as [`verify`] does, then that its key
/// record names `key`.
fn verify_entry(
    entry: &[u8],
    key: &CacheKey,
    recipe: &Recipe,
    encoding: Encoding,
    compression: Compression,
) -> Result<(), String> {
    let (blob, record) = match entry.len().checked_sub(KEY_RECORD_LEN) {
        Some(end) if entry[end..].starts_with(&KEY_RECORD_MAGIC) => {
            (&entry[..end], Some(&entry[end + KEY_RECORD_MAGIC.len()..]))
        }
        _ => (entry, None),
    };
    verify(blob, recipe, encoding, compression)?;
    match record {
        None => Err("it has no key record: not written by this cache for its key".to_owned()),
        Some(recorded) if recorded != key.0.as_bytes() => Err(format!(
            "its key record names another key ({}): another mask's entry under this key's name",
            blake3::Hash::from_slice(recorded)
                .map_or_else(|_| "?".to_owned(), |h| h.to_hex().to_string())
        )),
        Some(_) => Ok(()),
    }
}

/// Checks that `blob` is a valid `.stbn` blob (header, length, payload CRC) describing exactly
/// the mask `recipe`, `encoding` and `compression` produce.
fn verify(
    blob: &[u8],
    recipe: &Recipe,
    encoding: Encoding,
    compression: Compression,
) -> Result<(), String> {
    let packed = PackedStbn::from_bytes(blob).map_err(|e| e.to_string())?;
    let h = packed.header();
    let (width, height, depth) = recipe.size();
    let layout = recipe.layout();
    let describe = |(w, h, d): (u32, u32, u32),
                    channels: u8,
                    e: Encoding,
                    c: Compression,
                    layout: (stbn_runtime::Space, stbn_runtime::ValueMap)| {
        format!(
            "{w}x{h}x{d}, {channels} channel(s), {e:?}, {c:?}, {:?}/{:?}",
            layout.0, layout.1
        )
    };
    let found = describe(
        (h.width, h.height, h.depth),
        h.channels,
        h.encoding,
        h.compression,
        (h.space, h.value_map),
    );
    let expected = describe(
        (width, height, depth),
        layout.channels,
        encoding,
        compression,
        (layout.space, layout.value_map),
    );
    if found == expected {
        Ok(())
    } else {
        Err(format!(
            "header describes {found} (size, channels, encoding, compression, space/value map); \
             expected {expected}"
        ))
    }
}

/// Writes `bytes` to a fresh temporary file next to `path` and renames it over `path`, creating
/// the directory first: readers see the old file or the new one, never a partial one. The
/// temporary file is removed on failure.
pub(crate) fn write_atomically(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let dir = path.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir)?;
    let mut builder = tempfile::Builder::new();
    builder.prefix(".tmp-").suffix(".part");
    // Readable by everyone sharing the cache, like any other build output (umask applies);
    // temporary files are otherwise private to their creator.
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o644));
    let mut file = builder.tempfile_in(dir)?;
    file.write_all(bytes)?;
    file.persist(path).map_err(|e| e.error)?;
    Ok(())
}

/// The cache directory a build script uses: `$STBN_CACHE_DIR` if set and non-empty (a relative
/// path is relative to the build script's working directory, the package root), else
/// `<target dir>/stbn-cache` with the target directory found by [`target_dir`] from `OUT_DIR` and
/// `CARGO_TARGET_DIR`.
///
/// # Errors
/// [`Error::MissingEnv`] if neither `STBN_CACHE_DIR` nor `OUT_DIR` is set.
pub fn default_cache_dir() -> Result<PathBuf, Error> {
    if let Some(dir) = std::env::var_os(CACHE_DIR_ENV).filter(|d| !d.is_empty()) {
        return Ok(PathBuf::from(dir));
    }
    let out_dir = std::env::var_os("OUT_DIR").ok_or(Error::MissingEnv("OUT_DIR"))?;
    let cargo_target_dir = std::env::var_os("CARGO_TARGET_DIR").map(PathBuf::from);
    Ok(target_dir(Path::new(&out_dir), cargo_target_dir.as_deref()).join("stbn-cache"))
}

/// The Cargo target directory a build script's `out_dir` lives in.
///
/// Cargo does not tell build scripts the target directory, so it is derived, in order of
/// preference:
/// 1. the nearest ancestor of `out_dir` holding the `CACHEDIR.TAG` that Cargo writes at the root
///    of every target directory;
/// 2. `cargo_target_dir` (the `CARGO_TARGET_DIR` variable) if it is absolute — a relative one is
///    relative to where Cargo was started, which a build script cannot know;
/// 3. the nearest ancestor of `out_dir` named `target`;
/// 4. `out_dir` itself (the cache then only lives as long as this build script's output).
pub fn target_dir(out_dir: &Path, cargo_target_dir: Option<&Path>) -> PathBuf {
    if let Some(dir) = out_dir
        .ancestors()
        .find(|dir| dir.join("CACHEDIR.TAG").is_file())
    {
        return dir.to_owned();
    }
    if let Some(dir) = cargo_target_dir.filter(|d| d.is_absolute()) {
        return dir.to_owned();
    }
    out_dir
        .ancestors()
        .find(|dir| dir.file_name().is_some_and(|n| n == "target"))
        .unwrap_or(out_dir)
        .to_owned()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::encode::Layout;
    use stbn_gen::{BaselineKind, EnergyTopology, MaskSpec, SampleSpace, VectorSpec};

    #[test]
    fn keys_separate_every_input() {
        let base = MaskSpec::new(8, 8, 4, 1);
        let key = |spec: &MaskSpec| {
            CacheKey::new(
                &Recipe::VoidAndCluster(spec.clone()),
                Encoding::Unorm8,
                Compression::None,
            )
        };
        let variants = [
            MaskSpec {
                width: 9,
                ..base.clone()
            },
            MaskSpec {
                height: 9,
                ..base.clone()
            },
            MaskSpec {
                depth: 5,
                ..base.clone()
            },
            MaskSpec {
                seed: 2,
                ..base.clone()
            },
            MaskSpec {
                sigma_xy: 2.0,
                ..base.clone()
            },
            MaskSpec {
                sigma_z: 2.0,
                ..base.clone()
            },
            MaskSpec {
                initial_density: 0.2,
                ..base.clone()
            },
            MaskSpec {
                kernel_tolerance: 1e-4,
                ..base.clone()
            },
            base.clone().with_topology(EnergyTopology::Independent2D),
        ];
        let mut keys: Vec<CacheKey> = variants.iter().map(key).collect();
        keys.push(key(&base));
        let plain = Recipe::VoidAndCluster(base.clone());
        keys.push(CacheKey::new(&plain, Encoding::Unorm16, Compression::None));
        keys.push(CacheKey::new(&plain, Encoding::Unorm8, Compression::Lz4));
        for kind in [BaselineKind::White, BaselineKind::GoldenRatio2D] {
            let recipe = Recipe::Baseline(kind, base.clone());
            keys.push(CacheKey::new(&recipe, Encoding::Unorm8, Compression::None));
        }
        let vector = |space: SampleSpace, octahedral: bool, edit: &dyn Fn(&mut VectorSpec)| {
            let mut spec = VectorSpec::new(8, 8, 4, 1, space);
            edit(&mut spec);
            let recipe = Recipe::Vector {
                layout: Layout::new(&spec.space, octahedral),
                spec,
                image_hash: None,
            };
            CacheKey::new(&recipe, Encoding::Unorm8, Compression::None)
        };
        keys.push(vector(SampleSpace::Vec { dims: 2 }, true, &|_| {}));
        keys.push(vector(SampleSpace::Vec { dims: 3 }, true, &|_| {}));
        keys.push(vector(SampleSpace::UnitVec3, true, &|_| {}));
        keys.push(vector(SampleSpace::UnitVec3, false, &|_| {}));
        keys.push(vector(SampleSpace::UnitVec3, true, &|s| {
            s.sigma_value = 0.5
        }));
        keys.push(vector(SampleSpace::UnitVec3, true, &|s| {
            s.swaps_per_pixel = 0.5
        }));
        keys.push(vector(SampleSpace::UnitVec3, true, &|s| s.seed = 9));
        keys.push(vector(SampleSpace::UnitVec3, true, &|s| {
            s.assignment_passes = 0
        }));
        keys.push(vector(SampleSpace::UnitVec3, true, &|s| {
            s.assignment_passes = 9
        }));
        let unique: std::collections::HashSet<_> = keys.iter().collect();
        assert_eq!(unique.len(), keys.len());
        assert_eq!(key(&base), key(&base.clone()));
        assert_eq!(key(&base).to_hex().len(), 64);
    }

    #[test]
    fn target_dir_prefers_the_cachedir_tag() {
        let root = tempfile::tempdir().unwrap();
        let target = root.path().join("custom-target");
        let out = target.join("x86_64-unknown-linux-gnu/debug/build/demo-0123/out");
        std::fs::create_dir_all(&out).unwrap();
        // No tag, no variable: the directory named `target` is not there either.
        assert_eq!(target_dir(&out, None), out);
        assert_eq!(target_dir(&out, Some(Path::new("rel/target"))), out);
        let absolute = root.path().join("elsewhere");
        assert_eq!(target_dir(&out, Some(&absolute)), absolute);
        std::fs::write(
            target.join("CACHEDIR.TAG"),
            "Signature: 8a477f597d28d172789f06886806bc55",
        )
        .unwrap();
        assert_eq!(target_dir(&out, Some(&absolute)), target);

        let plain = root.path().join("target/debug/build/demo-0123/out");
        std::fs::create_dir_all(&plain).unwrap();
        assert_eq!(target_dir(&plain, None), root.path().join("target"));
    }

    #[test]
    fn atomic_write_replaces_and_leaves_no_temporaries() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("nested/entry.stbn");
        write_atomically(&path, b"first").unwrap();
        write_atomically(&path, b"second").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"second");
        let names: Vec<_> = std::fs::read_dir(path.parent().unwrap())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, ["entry.stbn"]);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&path).unwrap().permissions().mode();
            assert_eq!(mode & 0o444, 0o444, "{mode:o}");
        }
    }

    #[test]
    fn verify_rejects_other_masks() {
        let spec = Recipe::VoidAndCluster(MaskSpec::new(4, 4, 2, 3));
        let (_, blob) = spec.make(Encoding::Unorm8, Compression::None).unwrap();
        assert_eq!(
            verify(&blob, &spec, Encoding::Unorm8, Compression::None),
            Ok(())
        );
        let err = verify(&blob, &spec, Encoding::Unorm16, Compression::None).unwrap_err();
        assert!(
            err.contains("expected 4x4x2, 1 channel(s), Unorm16, None, Scalar/Unit"),
            "{err}"
        );
        let other = Recipe::VoidAndCluster(MaskSpec::new(4, 4, 3, 3));
        assert!(verify(&blob, &other, Encoding::Unorm8, Compression::None).is_err());
        let vector = Recipe::Vector {
            spec: VectorSpec::new(4, 4, 2, 3, SampleSpace::Vec { dims: 1 }),
            layout: Layout::new(&SampleSpace::Vec { dims: 1 }, true),
            image_hash: None,
        };
        // Same size, one channel, but the header says Scalar, not Vec.
        assert!(verify(&blob, &vector, Encoding::Unorm8, Compression::None).is_err());
        let mut corrupt = blob.clone();
        *corrupt.last_mut().unwrap() ^= 1;
        let err = verify(&corrupt, &spec, Encoding::Unorm8, Compression::None).unwrap_err();
        assert!(err.contains("checksum"), "{err}");
    }
}
