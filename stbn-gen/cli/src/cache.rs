//! `stbn-gen cache`: what the build-script blob cache holds, and pruning it.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

use stbn_build_support::cache::{CACHE_DIR_ENV, CacheEntry, PruneRule, Pruned, manifest_keys};
use stbn_build_support::{Cache, CacheKey, Manifest};

/// Most days `--older-than` takes (a century).
const MAX_DAYS: f64 = 36_500.0;

/// The arguments of `stbn-gen cache`.
#[derive(clap::Args)]
pub(crate) struct Args {
    /// The cache directory. Default: `$STBN_CACHE_DIR`, else `$CARGO_TARGET_DIR/stbn-cache`,
    /// else `target/stbn-cache` in the nearest folder, from the current one up, whose `target`
    /// Cargo made (it holds `CACHEDIR.TAG`): where build scripts put it.
    #[arg(long, value_name = "DIR")]
    dir: Option<PathBuf>,
    /// Never remove the entries this manifest's masks use (repeatable).
    #[arg(long, value_name = "FILE")]
    keep: Vec<PathBuf>,
    /// Remove the least recently used entries until the cache takes at most SIZE: bytes, or
    /// with a suffix K, M, G or T (powers of 1024; `KiB`… also read), e.g. `500M`.
    #[arg(
        long,
        value_name = "SIZE",
        value_parser = parse_size,
        conflicts_with = "older_than",
        allow_negative_numbers = true
    )]
    prune_to: Option<u64>,
    /// Remove the entries no build has used for more than DAYS days (fractions allowed).
    #[arg(long, value_name = "DAYS", value_parser = parse_days, allow_negative_numbers = true)]
    older_than: Option<Duration>,
    /// Say what would be removed, and remove nothing.
    #[arg(long)]
    dry_run: bool,
}

/// Lists the cache (entries by last use, their total, orphaned temporary files); with
/// `--prune-to` or `--older-than` also prunes it and removes the orphans.
pub(crate) fn run(args: &Args) -> crate::Result<()> {
    let dir = match &args.dir {
        Some(dir) => dir.clone(),
        None => default_dir()?,
    };
    let cache = Cache::new(&dir);
    let mut keep: Vec<CacheKey> = Vec::new();
    for manifest in &args.keep {
        keep.extend(manifest_keys(&Manifest::load(manifest)?));
    }
    let listing_error = |e: std::io::Error| format!("cannot list the cache {}: {e}", dir.display());
    let rule = match (args.prune_to, args.older_than) {
        (Some(size), _) => Some(PruneRule::ToSize(size)),
        (None, Some(age)) => Some(PruneRule::OlderThan(age)),
        (None, None) => None,
    };
    let now = SystemTime::now();
    let mut out = String::new();
    let verb = if args.dry_run {
        "would remove"
    } else {
        "removed"
    };
    match rule {
        None => {
            let entries = cache.entries().map_err(listing_error)?;
            describe(&mut out, &dir, &entries, &keep, now);
            let orphans = cache.remove_orphans(true).map_err(listing_error)?;
            if !orphans.is_empty() {
                let bytes = orphans.iter().map(|o| o.bytes).sum();
                writeln!(
                    out,
                    "{} orphaned temporary file(s), {}: left by interrupted builds; the next \
                     build or a prune removes them",
                    orphans.len(),
                    size(bytes)
                )?;
            }
        }
        Some(rule) => {
            let orphans = cache.remove_orphans(args.dry_run).map_err(listing_error)?;
            let pruned = cache
                .prune(rule, &keep, args.dry_run)
                .map_err(listing_error)?;
            report_prune(&mut out, verb, &pruned, now);
            if !orphans.is_empty() {
                let bytes = orphans.iter().map(|o| o.bytes).sum();
                writeln!(
                    out,
                    "{verb} {} orphaned temporary file(s), {}",
                    orphans.len(),
                    size(bytes)
                )?;
            }
            let left = if args.dry_run { "would hold" } else { "holds" };
            let kept_bytes = pruned.kept.iter().map(|e| e.bytes).sum();
            writeln!(
                out,
                "{} {left} {} entr{}, {}",
                dir.display(),
                pruned.kept.len(),
                if pruned.kept.len() == 1 { "y" } else { "ies" },
                size(kept_bytes)
            )?;
            if let PruneRule::ToSize(limit) = rule
                && kept_bytes > limit
                && pruned.failures.is_empty()
            {
                writeln!(
                    out,
                    "the entries of the --keep manifests take more than {} on their own",
                    size(limit)
                )?;
            }
            if let Some((path, e)) = pruned.failures.first() {
                print(&out)?;
                return Err(format!(
                    "could not remove {} cache entr{} (first: {}: {e})",
                    pruned.failures.len(),
                    if pruned.failures.len() == 1 {
                        "y"
                    } else {
                        "ies"
                    },
                    path.display()
                )
                .into());
            }
        }
    }
    print(&out)
}

/// Writes `text` to stdout; a reader that went away (`| head`) is not an error: the work is done.
fn print(text: &str) -> crate::Result<()> {
    match std::io::stdout().lock().write_all(text.as_bytes()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(e.into()),
        _ => Ok(()),
    }
}

/// The listing: a summary line, then one line per entry, most recently used first.
fn describe(
    out: &mut String,
    dir: &Path,
    entries: &[CacheEntry],
    keep: &[CacheKey],
    now: SystemTime,
) {
    let total = entries.iter().map(|e| e.bytes).sum();
    let _ = writeln!(
        out,
        "{}: {} entr{}, {}",
        dir.display(),
        entries.len(),
        if entries.len() == 1 { "y" } else { "ies" },
        size(total)
    );
    if entries.is_empty() {
        return;
    }
    let _ = writeln!(out, "{:>10}  {:>10}  key", "last used", "size");
    let keep: Vec<String> = keep.iter().map(CacheKey::to_hex).collect();
    for entry in entries.iter().rev() {
        let kept = if keep.contains(&entry.key) {
            "  (kept)"
        } else {
            ""
        };
        let _ = writeln!(
            out,
            "{:>10}  {:>10}  {}{kept}",
            age(now, entry.last_used),
            size(entry.bytes),
            entry.key
        );
    }
}

/// One line per removed entry, then the count.
fn report_prune(out: &mut String, verb: &str, pruned: &Pruned, now: SystemTime) {
    for entry in &pruned.removed {
        let _ = writeln!(
            out,
            "{verb} {} ({}, last used {})",
            entry.key,
            size(entry.bytes),
            age(now, entry.last_used)
        );
    }
    let bytes = pruned.removed.iter().map(|e| e.bytes).sum();
    let _ = writeln!(
        out,
        "{verb} {} entr{}, {}",
        pruned.removed.len(),
        if pruned.removed.len() == 1 {
            "y"
        } else {
            "ies"
        },
        size(bytes)
    );
}

/// Where build scripts put the cache, seen from the current folder.
fn default_dir() -> crate::Result<PathBuf> {
    if let Some(dir) = std::env::var_os(CACHE_DIR_ENV).filter(|d| !d.is_empty()) {
        return Ok(PathBuf::from(dir));
    }
    if let Some(dir) = std::env::var_os("CARGO_TARGET_DIR").filter(|d| !d.is_empty()) {
        return Ok(PathBuf::from(dir).join("stbn-cache"));
    }
    let cwd = std::env::current_dir()?;
    cwd.ancestors()
        .map(|dir| dir.join("target"))
        .find(|target| target.join("CACHEDIR.TAG").is_file())
        .map(|target| target.join("stbn-cache"))
        .ok_or_else(|| {
            format!(
                "no cache directory: {CACHE_DIR_ENV} and CARGO_TARGET_DIR are unset and no \
                 Cargo `target` folder is in {} or above it; pass --dir",
                cwd.display()
            )
            .into()
        })
}

/// `--prune-to`: bytes, or a number with a binary suffix.
fn parse_size(text: &str) -> Result<u64, String> {
    let error = || {
        format!(
            "must be a size such as 500M, 2G or 1048576 (bytes; K, M, G, T are powers of 1024), \
             got {text:?}"
        )
    };
    let trimmed = text.trim();
    let split = trimmed
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(trimmed.len());
    let (number, suffix) = trimmed.split_at(split);
    let scale: u64 = match suffix.trim().to_ascii_uppercase().as_str() {
        "" | "B" => 1,
        "K" | "KIB" => 1 << 10,
        "M" | "MIB" => 1 << 20,
        "G" | "GIB" => 1 << 30,
        "T" | "TIB" => 1 << 40,
        _ => return Err(error()),
    };
    let value: f64 = number.parse().map_err(|_| error())?;
    let bytes = value * scale as f64;
    if !bytes.is_finite() || bytes >= u64::MAX as f64 {
        return Err(error());
    }
    Ok(bytes as u64)
}

/// `--older-than`: a number of days in `0..=36500`.
fn parse_days(text: &str) -> Result<Duration, String> {
    match text.trim().parse::<f64>() {
        Ok(days) if (0.0..=MAX_DAYS).contains(&days) => {
            Ok(Duration::from_secs_f64(days * 86_400.0))
        }
        _ => Err(format!(
            "must be a number of days in 0..={MAX_DAYS} (got {text:?})"
        )),
    }
}

/// `bytes` in B, KiB, MiB, GiB or TiB.
fn size(bytes: u64) -> String {
    const UNITS: [&str; 4] = ["KiB", "MiB", "GiB", "TiB"];
    if bytes < 1024 {
        return format!("{bytes} B");
    }
    let mut value = bytes as f64 / 1024.0;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < UNITS.len() {
        value /= 1024.0;
        unit += 1;
    }
    format!("{value:.1} {}", UNITS[unit])
}

/// How long before `now` `then` was: `40 s ago`, `12 min ago`, `5.0 h ago`, `3.2 d ago`.
fn age(now: SystemTime, then: SystemTime) -> String {
    let Ok(elapsed) = now.duration_since(then) else {
        return "just now".to_owned();
    };
    let seconds = elapsed.as_secs_f64();
    if seconds < 60.0 {
        format!("{seconds:.0} s ago")
    } else if seconds < 3600.0 {
        format!("{:.0} min ago", seconds / 60.0)
    } else if seconds < 86_400.0 {
        format!("{:.1} h ago", seconds / 3600.0)
    } else {
        format!("{:.1} d ago", seconds / 86_400.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_with_binary_suffixes() {
        for (text, bytes) in [
            ("0", 0),
            ("1048576", 1 << 20),
            ("500M", 500 << 20),
            ("500 MiB", 500 << 20),
            ("2g", 2 << 30),
            ("1.5K", 1536),
            ("3B", 3),
            ("1T", 1 << 40),
        ] {
            assert_eq!(parse_size(text), Ok(bytes), "{text}");
        }
        for bad in ["", "M", "-1", "5 MB", "1e3", "NaN", "99999999999T", "1.2.3"] {
            let error = parse_size(bad).unwrap_err();
            assert!(error.contains(&format!("got {bad:?}")), "{error}");
        }
    }

    #[test]
    fn days_are_bounded() {
        assert_eq!(parse_days("0"), Ok(Duration::ZERO));
        assert_eq!(parse_days("0.5"), Ok(Duration::from_secs(43_200)));
        for bad in ["-1", "36501", "inf", "NaN", "a week"] {
            assert_eq!(
                parse_days(bad),
                Err(format!(
                    "must be a number of days in 0..=36500 (got {bad:?})"
                ))
            );
        }
    }

    #[test]
    fn sizes_and_ages_read_compactly() {
        assert_eq!(size(0), "0 B");
        assert_eq!(size(1023), "1023 B");
        assert_eq!(size(1536), "1.5 KiB");
        assert_eq!(size(5 << 30), "5.0 GiB");
        assert_eq!(size(u64::MAX), "16777216.0 TiB");
        let now = SystemTime::now();
        let ago = |s: u64| age(now, now - Duration::from_secs(s));
        assert_eq!(ago(5), "5 s ago");
        assert_eq!(ago(600), "10 min ago");
        assert_eq!(ago(5 * 3600), "5.0 h ago");
        assert_eq!(ago(3 * 86_400), "3.0 d ago");
        assert_eq!(age(now, now + Duration::from_secs(9)), "just now");
    }
}
