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
//! * Writes go to a uniquely named temporary file in the cache directory (`.tmp-XXXXXX.part`,
//!   six letters or digits), renamed over the entry: concurrent builds each write whole files,
//!   and readers never see a partial one. The writer holds an exclusive lock (`flock` on Unix,
//!   `LockFileEx` on Windows) on its temporary file until the rename.
//! * A temporary file that a killed writer left is an orphan: [`Cache::remove_orphans`] (run by
//!   every [`embed`](crate::embed()) that can write the cache) removes files of exactly that
//!   name pattern that are regular files, unlocked and untouched for [`ORPHAN_GRACE`]; it never
//!   removes anything else. The grace covers the instant between a writer creating its file and
//!   locking it.
//! * Hits refresh the entry's modification time, so it tells when the entry was last used;
//!   [`Cache::entries`] lists entries with their size and last use, and [`Cache::prune`] removes
//!   the least recently used ones down to a size, or those unused for a while, keeping the
//!   entries of given keys ([`manifest_keys`]: those of the current manifest). Only files named
//!   `<64 hex digits>.stbn` that start like a `.stbn` blob and end with the key record of their
//!   name count as entries.
//! * Reads take only a regular file (a FIFO or device is refused without reading it) no larger
//!   than a valid entry of the recipe can be, checked before reading, in one read.
//! * Reads are verified: the blob ([`PackedStbn::from_bytes`] plus a header comparison with the
//!   recipe), then the key record. An entry that fails is regenerated and overwritten, with a
//!   warning.
//! * A cache directory that cannot be created or written only costs a warning: the blob is still
//!   generated and returned. [`embed`](crate::embed()) checks the directory once per build and
//!   warns once.
//!
//! Location ([`default_cache_dir`]): `$STBN_CACHE_DIR` if set and non-empty, else
//! `<target dir>/stbn-cache`.

use std::fs::File;
use std::io::{self, Read as _, Write as _};
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

use stbn_gen::VectorSpecError;
use stbn_runtime::{Compression, Encoding, MaskHeader, PackedStbn};

use crate::encode::{DEFLATE_LEVEL, ENCODER_VERSION};
use crate::recipe::Recipe;
use crate::{Error, Manifest};

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
        self.fetch_with(recipe, encoding, compression, true)
    }

    /// [`fetch`](Self::fetch), storing a generated blob only if `store`.
    pub(crate) fn fetch_with(
        &self,
        recipe: &Recipe,
        encoding: Encoding,
        compression: Compression,
        store: bool,
    ) -> Result<Fetched, VectorSpecError> {
        let key = CacheKey::new(recipe, encoding, compression);
        let path = self.entry_path(&key);
        let mut warnings = Vec::new();
        let read = stbn_gen::file::read_regular_file(&path, max_entry_len(recipe, encoding));
        let status = match read {
            Ok(entry) => match verify_entry(&entry, &key, recipe, encoding, compression) {
                Ok(()) => {
                    // The modification time records the last use (best effort: a shared cache's
                    // entries may belong to another user).
                    let _ = std::fs::OpenOptions::new()
                        .write(true)
                        .open(&path)
                        .and_then(|f| f.set_modified(SystemTime::now()));
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
        let stored = store
            && match write_atomically(&path, &key.entry_bytes(&blob)) {
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

/// Name prefix of the temporary files writes go through.
const TEMP_PREFIX: &str = ".tmp-";
/// Name suffix of the temporary files writes go through.
const TEMP_SUFFIX: &str = ".part";
/// Random letters and digits between the prefix and suffix of a temporary file's name.
const TEMP_RANDOM_CHARS: usize = 6;

/// How long an unlocked temporary file must have been untouched before
/// [`Cache::remove_orphans`] takes it for a killed writer's: a live writer locks its file right
/// after creating it, and this covers that instant many times over.
pub const ORPHAN_GRACE: Duration = Duration::from_secs(60);

/// Whether `name` is exactly the name of one of this crate's temporary files.
fn is_temp_name(name: &str) -> bool {
    name.strip_prefix(TEMP_PREFIX)
        .and_then(|rest| rest.strip_suffix(TEMP_SUFFIX))
        .is_some_and(|random| {
            random.len() == TEMP_RANDOM_CHARS && random.bytes().all(|b| b.is_ascii_alphanumeric())
        })
}

/// Whether `name` is an entry's name: 64 lowercase hex digits and `.stbn`.
fn entry_key(name: &str) -> Option<&str> {
    let key = name.strip_suffix(".stbn")?;
    (key.len() == 2 * blake3::OUT_LEN
        && key.bytes().all(|b| matches!(b, b'0'..=b'9' | b'a'..=b'f')))
    .then_some(key)
}

/// One entry of a cache directory ([`Cache::entries`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CacheEntry {
    /// The entry's file.
    pub path: PathBuf,
    /// Its key, 64 lowercase hex digits (the file stem).
    pub key: String,
    /// Its size in bytes.
    pub bytes: u64,
    /// When it was last written or read by a build (its modification time).
    pub last_used: SystemTime,
}

/// A temporary file left by a writer that did not finish ([`Cache::remove_orphans`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Orphan {
    /// The file.
    pub path: PathBuf,
    /// Its size in bytes.
    pub bytes: u64,
}

/// Which entries [`Cache::prune`] removes (never those it is told to keep).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PruneRule {
    /// The least recently used, until the entries take at most this many bytes.
    ToSize(u64),
    /// Those last used longer ago than this.
    OlderThan(Duration),
}

/// What [`Cache::prune`] did (or, in a dry run, would do).
#[derive(Debug, Default)]
pub struct Pruned {
    /// Entries removed, least recently used first.
    pub removed: Vec<CacheEntry>,
    /// Entries left, least recently used first.
    pub kept: Vec<CacheEntry>,
    /// Entries that could not be removed, and why.
    pub failures: Vec<(PathBuf, io::Error)>,
}

/// The keys of every mask of `manifest`: the entries a build of it reads.
pub fn manifest_keys(manifest: &Manifest) -> Vec<CacheKey> {
    manifest
        .masks()
        .iter()
        .map(|m| CacheKey::new(&m.recipe(), m.encoding, m.compression))
        .collect()
}

impl Cache {
    /// Creates the directory if needed and checks that a file can be written in it (a temporary
    /// file, removed at once); then removes its orphans ([`remove_orphans`](Self::remove_orphans)).
    ///
    /// # Errors
    /// Why the directory cannot be created or written.
    pub(crate) fn prepare(&self) -> io::Result<()> {
        std::fs::create_dir_all(&self.dir)?;
        // Dropped at once: removed.
        TempFile::create_in(&self.dir)?;
        let _ = self.remove_orphans(false);
        Ok(())
    }

    /// The temporary files that writers killed mid-entry left in the directory, removed unless
    /// `dry_run`. A file counts only if its name is exactly `.tmp-XXXXXX.part` (six ASCII letters
    /// or digits), it is a regular file (not a link), it has not been modified for
    /// [`ORPHAN_GRACE`], and no writer holds its lock; nothing else is ever removed. A
    /// directory that does not exist has none.
    ///
    /// # Errors
    /// Only if the directory cannot be listed; files that cannot be checked or removed are left.
    pub fn remove_orphans(&self, dry_run: bool) -> io::Result<Vec<Orphan>> {
        let listing = match std::fs::read_dir(&self.dir) {
            Ok(listing) => listing,
            Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(Vec::new()),
            Err(e) => return Err(e),
        };
        let now = SystemTime::now();
        let mut orphans = Vec::new();
        for item in listing.flatten() {
            if !item.file_name().to_str().is_some_and(is_temp_name) {
                continue;
            }
            let path = item.path();
            let Ok(meta) = std::fs::symlink_metadata(&path) else {
                continue;
            };
            let untouched = meta
                .modified()
                .ok()
                .and_then(|modified| now.duration_since(modified).ok())
                .is_some_and(|age| age >= ORPHAN_GRACE);
            if !meta.file_type().is_file() || !untouched || !unlocked(&path) {
                continue;
            }
            if dry_run || std::fs::remove_file(&path).is_ok() {
                orphans.push(Orphan {
                    path,
                    bytes: meta.len(),
                });
            }
        }
        orphans.sort_by(|a, b| a.path.cmp(&b.path));
        Ok(orphans)
    }

    /// The entries of the directory, least recently used first (ties by key). Only regular
    /// files named `<64 hex digits>.stbn` that start with the `.stbn` magic and end with the key
    /// record of that key count: anything else in the directory is neither listed nor pruned. A
    /// directory that does not exist holds none.
    ///
    /// # Errors
    /// Only if the directory cannot be listed.
    pub fn entries(&self) -> io::Result<Vec<CacheEntry>> {
        let listing = match std::fs::read_dir(&self.dir) {
            Ok(listing) => listing,
            Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(Vec::new()),
            Err(e) => return Err(e),
        };
        let mut entries = Vec::new();
        for item in listing.flatten() {
            let name = item.file_name();
            let Some(key) = name.to_str().and_then(entry_key) else {
                continue;
            };
            let path = item.path();
            let Ok(meta) = std::fs::symlink_metadata(&path) else {
                continue;
            };
            if !meta.file_type().is_file() || !written_for(&path, key) {
                continue;
            }
            entries.push(CacheEntry {
                key: key.to_owned(),
                path,
                bytes: meta.len(),
                last_used: meta.modified().unwrap_or(SystemTime::UNIX_EPOCH),
            });
        }
        entries.sort_by(|a, b| a.last_used.cmp(&b.last_used).then(a.key.cmp(&b.key)));
        Ok(entries)
    }

    /// Removes entries by `rule` (unless `dry_run`), never those of `keep`: least recently used
    /// first. With [`PruneRule::ToSize`] the kept entries may still exceed the size when `keep`
    /// alone does.
    ///
    /// # Errors
    /// Only if the directory cannot be listed; entries that cannot be removed are reported in
    /// [`Pruned::failures`] and stay in [`Pruned::kept`].
    pub fn prune(&self, rule: PruneRule, keep: &[CacheKey], dry_run: bool) -> io::Result<Pruned> {
        let keep: Vec<String> = keep.iter().map(CacheKey::to_hex).collect();
        let entries = self.entries()?;
        let mut total: u64 = entries.iter().map(|e| e.bytes).sum();
        let now = SystemTime::now();
        let mut pruned = Pruned::default();
        for entry in entries {
            let remove = !keep.contains(&entry.key)
                && match rule {
                    PruneRule::ToSize(limit) => total > limit,
                    PruneRule::OlderThan(age) => now
                        .duration_since(entry.last_used)
                        .is_ok_and(|unused| unused > age),
                };
            if !remove {
                pruned.kept.push(entry);
                continue;
            }
            match if dry_run {
                Ok(())
            } else {
                std::fs::remove_file(&entry.path)
            } {
                Ok(()) => {
                    total -= entry.bytes;
                    pruned.removed.push(entry);
                }
                Err(e) => {
                    pruned.failures.push((entry.path.clone(), e));
                    pruned.kept.push(entry);
                }
            }
        }
        Ok(pruned)
    }
}

/// Whether no one holds the lock of the file at `path` (it is taken and released at once).
/// `false` when that cannot be told: the file cannot be opened or locks are unsupported.
fn unlocked(path: &Path) -> bool {
    let Ok(file) = File::open(path) else {
        return false;
    };
    file.try_lock().is_ok()
}

/// Whether the file at `path` is an entry this cache wrote for `key` (64 hex digits): it starts
/// with the `.stbn` magic and ends with the key record naming `key`.
fn written_for(path: &Path, key: &str) -> bool {
    use std::io::{Seek as _, SeekFrom};

    let check = || -> io::Result<bool> {
        let mut file = File::open(path)?;
        let mut magic = [0u8; 4];
        file.read_exact(&mut magic)?;
        file.seek(SeekFrom::End(-(KEY_RECORD_LEN as i64)))?;
        let mut record = [0u8; KEY_RECORD_LEN];
        file.read_exact(&mut record)?;
        let (record_magic, recorded) = record.split_at(KEY_RECORD_MAGIC.len());
        Ok(&magic == b"STBN"
            && record_magic == KEY_RECORD_MAGIC
            && blake3::Hash::from_slice(recorded).is_ok_and(|h| h.to_hex().as_str() == key))
    };
    check().unwrap_or(false)
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
/// the mask `recipe`, `encoding` and `compression` produce: stored with `compression`, or
/// uncompressed where the encoder dropped a codec that did not shrink the payload.
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
    // The encoder stores a payload uncompressed when the codec does not shrink it.
    let stored = if h.compression.is_none() {
        compression
    } else {
        h.compression
    };
    let found = describe(
        (h.width, h.height, h.depth),
        h.channels,
        h.encoding,
        stored,
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
    let mut temp = TempFile::create_in(dir)?;
    // Marks the file as live for `remove_orphans`, held until the rename (and the close after
    // it). A file system without locks leaves the grace period as the only protection.
    let _ = temp.file.try_lock();
    temp.file.write_all(bytes)?;
    temp.persist(path)
}

/// A fresh `.tmp-XXXXXX.part` file ([`is_temp_name`]) in a directory, removed when dropped
/// unless [`persist`](Self::persist)ed. Written with `std` alone, so that a game's build script
/// compiles no temporary-file crate (and its system-call layer).
struct TempFile {
    path: PathBuf,
    file: File,
    persisted: bool,
}

impl TempFile {
    /// Creates the file exclusively (`create_new`: never an existing file, nor through a link),
    /// readable by everyone sharing the cache like any other build output (umask applies).
    fn create_in(dir: &Path) -> io::Result<TempFile> {
        let mut options = std::fs::OpenOptions::new();
        options.write(true).create_new(true);
        #[cfg(unix)]
        std::os::unix::fs::OpenOptionsExt::mode(&mut options, 0o644);
        // A clash needs another live writer with the same six random characters; a few
        // attempts make it vanishingly rare.
        for _ in 0..16 {
            let path = dir.join(format!(
                "{TEMP_PREFIX}{}{TEMP_SUFFIX}",
                random_alphanumerics(TEMP_RANDOM_CHARS)
            ));
            match options.open(&path) {
                Ok(file) => {
                    return Ok(TempFile {
                        path,
                        file,
                        persisted: false,
                    });
                }
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists => continue,
                Err(e) => return Err(e),
            }
        }
        Err(io::Error::new(
            io::ErrorKind::AlreadyExists,
            format!("no free temporary file name in {}", dir.display()),
        ))
    }

    /// Renames the file over `path`: readers see the old file or this one, never a partial one.
    fn persist(mut self, path: &Path) -> io::Result<()> {
        std::fs::rename(&self.path, path)?;
        self.persisted = true;
        Ok(())
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if !self.persisted {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

/// `n` random ASCII letters and digits for a temporary file name: from `std`'s randomly keyed
/// hasher, the process id, a per-process counter and the time (names, not secrets).
fn random_alphanumerics(n: usize) -> String {
    use std::hash::{BuildHasher as _, Hasher as _};
    use std::sync::atomic::{AtomicU64, Ordering};
    static CALLS: AtomicU64 = AtomicU64::new(0);
    const ALPHABET: &[u8; 62] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789";
    let mut hasher = std::collections::hash_map::RandomState::new().build_hasher();
    hasher.write_u64(CALLS.fetch_add(1, Ordering::Relaxed));
    hasher.write_u32(std::process::id());
    if let Ok(now) = SystemTime::now().duration_since(SystemTime::UNIX_EPOCH) {
        hasher.write_u128(now.as_nanos());
    }
    let mut bits = hasher.finish();
    (0..n)
        .map(|_| {
            let c = ALPHABET[(bits % 62) as usize];
            bits /= 62;
            char::from(c)
        })
        .collect()
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

    #[test]
    fn temporary_files_are_exclusive_named_for_orphan_removal_and_removed_unless_persisted() {
        let dir = tempfile::tempdir().unwrap();
        let dropped = TempFile::create_in(dir.path()).unwrap();
        let dropped_path = dropped.path.clone();
        let name = dropped_path
            .file_name()
            .unwrap()
            .to_str()
            .unwrap()
            .to_owned();
        assert!(is_temp_name(&name), "{name}");
        let kept = TempFile::create_in(dir.path()).unwrap();
        assert_ne!(
            kept.path, dropped_path,
            "two live writers never share a file"
        );
        drop(dropped);
        assert!(!dropped_path.exists());
        let target = dir.path().join("entry.stbn");
        write_atomically(&target, b"bytes").unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"bytes");
        drop(kept);
        let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().flatten().collect();
        assert_eq!(left.len(), 1, "only the persisted entry: {left:?}");
    }
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
    fn a_dropped_codec_is_a_cache_hit_on_the_next_fetch() {
        // Deflate does not shrink an 8-bit frame: the encoder stores it uncompressed, and the
        // next fetch must take that entry, not regenerate it as invalid.
        let dir = tempfile::tempdir().unwrap();
        let cache = Cache::new(dir.path());
        let spec = Recipe::VoidAndCluster(MaskSpec::new(16, 16, 4, 3));
        let first = cache
            .fetch(&spec, Encoding::Unorm8, Compression::Deflate)
            .unwrap();
        assert!(first.warnings.is_empty(), "{:?}", first.warnings);
        assert!(
            PackedStbn::from_bytes(&first.blob)
                .unwrap()
                .header()
                .compression
                .is_none()
        );
        let second = cache
            .fetch(&spec, Encoding::Unorm8, Compression::Deflate)
            .unwrap();
        assert_eq!(second.status, CacheStatus::Hit);
        assert!(second.warnings.is_empty(), "{:?}", second.warnings);
        assert_eq!(second.blob, first.blob);
        // A stored compressed blob still has to carry the requested codec.
        assert!(verify(&first.blob, &spec, Encoding::Unorm16, Compression::Deflate).is_err());
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
