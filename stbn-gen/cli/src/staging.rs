//! Owned, all-or-nothing output: what `generate`, `analyze` and `tradeoff` write into `--out`.
//!
//! **Ownership.** `<out>/.stbn-gen/output` lists every file and folder the finished runs wrote
//! there (relative paths). A run may replace a path in `<out>` only if the list names it with
//! the same kind (file or folder); anything else it would replace (a folder named like a mask
//! holding someone's `notes.txt`, a `report.md` or `plots/` from elsewhere, a symlink in place of
//! a mask folder) makes it refuse, before any work and again just before the switch, naming the
//! paths. Files of `<out>` that the run does not write are never touched. A listed path counts as
//! the tool's even if its content was edited since: the list records paths, not contents. What an
//! earlier run wrote and this one does not (a mask since removed from the manifest) is left in
//! place and stays listed.
//!
//! **All or nothing.** Everything is written into a staging folder
//! `<out>/.stbn-gen/staging-<random>/out/` under its final name. Only when the run has finished
//! is it switched in: the paths it replaces are moved aside into the staging folder, the new ones
//! moved into `<out>` (renames within one file system), and the new list moved over the old one,
//! with SIGINT, SIGTERM and SIGHUP held back until the switch is done. A switch that fails is
//! undone. A run killed outright during the switch (milliseconds) leaves a `switch` journal in
//! its staging folder; the next run completes that switch (the killed run had finished its work)
//! before it looks at anything else. A run stopped at any other moment leaves the previous output
//! as it was.
//!
//! **Staging ownership.** Each staging folder has a lock file beside it,
//! `<out>/.stbn-gen/staging-<random>.lock`, locked (`flock`) for the run's whole life and created
//! before the folder. A staging folder whose lock nobody holds (or which has no lock file) is
//! abandoned and removed by the next run; one whose lock is held belongs to a live run, in
//! whatever process namespace, and is left alone. Recovery, checks and switches are serialised
//! by `<out>/.stbn-gen/lock`, held for milliseconds.

use std::collections::{BTreeMap, BTreeSet};
use std::fs::{self, File};
use std::io;
use std::path::{Path, PathBuf};

use crate::Result;

/// The tool's folder inside `--out`.
pub const STATE_DIR: &str = ".stbn-gen";
/// The list of what the tool wrote, in [`STATE_DIR`].
const LIST: &str = "output";
/// First line of the list.
const LIST_HEADER: &str = "stbn-gen output list, version 1";
/// Lock serialising recovery, checks and switches, in [`STATE_DIR`].
const COMMIT_LOCK: &str = "lock";
/// Start of every staging folder's name (and its lock file's), in [`STATE_DIR`].
const STAGING_PREFIX: &str = "staging-";
/// End of a staging folder's lock file name.
const LOCK_SUFFIX: &str = ".lock";
/// In a staging folder: the new output.
const STAGED: &str = "out";
/// In a staging folder: what the switch moved out of `--out`.
const REPLACED: &str = "replaced";
/// In a staging folder: the journal of a switch under way (the names it moves aside).
const SWITCH: &str = "switch";
/// Most conflicting paths an error names.
const SHOWN_CONFLICTS: usize = 5;
/// Longest path (bytes) the run may hand to the OS (Linux's `PATH_MAX` less its NUL).
const MAX_PATH_BYTES: usize = 4095;
/// Bytes a staged path adds to `<out>/`: `.stbn-gen/staging-XXXXXX/out/` and the aside folder.
const STAGING_OVERHEAD: usize = 64;

/// A file or a folder, as the list records them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    File,
    Dir,
}

/// The list: relative path (`/`-separated) → kind.
type Owned = BTreeMap<String, Kind>;

/// A staging folder inside an output folder, locked for the run's life.
pub struct Staging {
    out: PathBuf,
    state: PathBuf,
    /// `<state>/staging-<random>`.
    root: PathBuf,
    lock_path: PathBuf,
    /// Holds the staging folder's lock until dropped.
    _lock: File,
    /// Leave the staging folder for the next run to complete (a switch that could not be undone).
    keep: bool,
}

impl Staging {
    /// Prepares `out` for a run that writes the top-level names `claims` accepts: creates `out`
    /// (and its parents) if needed, completes a switch a killed run left, removes abandoned
    /// staging folders, refuses if `out` holds something the tool did not write under a claimed
    /// name, checks that paths up to `longest` bytes below `out` stay within the OS limit, and
    /// creates the locked staging folder. All before any work is done.
    pub fn new(out: &Path, claims: &dyn Fn(&str) -> bool, longest: usize) -> Result<Staging> {
        let shown = shown(out);
        if fs::metadata(out).is_ok_and(|m| !m.is_dir()) {
            return Err(format!(
                "the output folder {shown} is a file, not a folder (--out names the folder the \
                 output goes into)"
            )
            .into());
        }
        let length = out.as_os_str().len() + STAGING_OVERHEAD + longest;
        if length > MAX_PATH_BYTES {
            return Err(format!(
                "the output folder's path {shown} is {} bytes long; with the names this run \
                 writes below it (up to {longest} bytes) and its staging folder, paths would \
                 reach {length} bytes, over the limit of {MAX_PATH_BYTES}",
                out.as_os_str().len()
            )
            .into());
        }
        let unwritable =
            |e: &dyn std::fmt::Display| format!("cannot write to the output folder {shown}: {e}");
        let state = out.join(STATE_DIR);
        match fs::symlink_metadata(&state) {
            Ok(m) if m.is_dir() => {}
            Ok(_) => {
                return Err(format!(
                    "{} is not a folder; stbn-gen keeps its list of what it wrote there (move it \
                     away)",
                    self::shown(&state)
                )
                .into());
            }
            Err(_) => {
                // Nothing in `out` is the tool's: refused before anything is created there.
                if out.is_dir() {
                    refuse_conflicts(out, &Owned::new(), claims, "nothing was written")?;
                }
                fs::create_dir_all(&state).map_err(|e| unwritable(&e))?;
            }
        }
        let commit_lock = lock_commits(&state)?;
        recover(out, &state)?;
        let owned = read_list(&state)?;
        refuse_conflicts(out, &owned, claims, "nothing was written")?;
        let (lock_file, lock_path) = tempfile::Builder::new()
            .prefix(STAGING_PREFIX)
            .suffix(LOCK_SUFFIX)
            .tempfile_in(&state)
            .map_err(|e| unwritable(&e))?
            .keep()
            .map_err(|e| unwritable(&e.error))?;
        lock_file.lock().map_err(|e| unwritable(&e))?;
        let root = staging_folder(&lock_path).expect("the lock file was named by its pattern");
        let staging = Staging {
            out: out.to_owned(),
            state,
            root,
            lock_path,
            _lock: lock_file,
            keep: false,
        };
        fs::create_dir(&staging.root)
            .and_then(|()| fs::create_dir(staging.dir()))
            .map_err(|e| unwritable(&e))?;
        drop(commit_lock);
        Ok(staging)
    }

    /// Where the run writes its output, each file or folder under its final name.
    pub fn dir(&self) -> PathBuf {
        self.root.join(STAGED)
    }

    /// Switches the staged output in (see the module's documentation): re-checks ownership, then
    /// moves what it replaces aside, the new output into place and the new list over the old one,
    /// and removes the staging folder with what was replaced.
    pub fn commit(mut self) -> Result<()> {
        let _commit_lock = lock_commits(&self.state)?;
        recover(&self.out, &self.state)?;
        let staged = self.dir();
        let names: BTreeSet<String> = list_names(&staged)?;
        let owned = read_list(&self.state)?;
        refuse_conflicts(
            &self.out,
            &owned,
            &|name| names.contains(name),
            "the new output was discarded and the previous one left as it was",
        )?;
        // The new list: what this run wrote, and what earlier runs wrote that is still there.
        let mut list = Owned::new();
        for name in &names {
            walk(&staged, name, &mut list)?;
        }
        for (path, kind) in owned {
            let top = path.split('/').next().unwrap_or_default();
            if !names.contains(top) && fs::symlink_metadata(self.out.join(&path)).is_ok() {
                list.insert(path, kind);
            }
        }
        write_list(&self.root.join(LIST), &list)?;
        let aside: Vec<&String> = names
            .iter()
            .filter(|name| fs::symlink_metadata(self.out.join(name)).is_ok())
            .collect();
        let mut journal = String::new();
        for name in &aside {
            journal.push_str(name);
            journal.push('\n');
        }
        let replaced = self.root.join(REPLACED);
        fs::create_dir(&replaced).map_err(|e| cannot("create", &replaced, &e))?;
        write_synced(&self.root.join(SWITCH), journal.as_bytes())?;

        let held = signals::Held::new();
        let mut moved_aside = Vec::new();
        let mut moved_in = Vec::new();
        let switched = (|| -> io::Result<()> {
            for name in &aside {
                fs::rename(self.out.join(name), replaced.join(name))?;
                moved_aside.push(*name);
            }
            for name in &names {
                fs::rename(staged.join(name), self.out.join(name))?;
                moved_in.push(name);
            }
            fs::rename(self.root.join(LIST), self.state.join(LIST))
        })();
        if let Err(error) = switched {
            let undone = (|| -> io::Result<()> {
                for name in moved_in.iter().rev() {
                    fs::rename(self.out.join(name), staged.join(name))?;
                }
                for name in moved_aside.iter().rev() {
                    fs::rename(replaced.join(name), self.out.join(name))?;
                }
                fs::remove_file(self.root.join(SWITCH))
            })();
            drop(held);
            return Err(match undone {
                Ok(()) => format!(
                    "cannot move the new output into {}: {error}; the previous output was left \
                     as it was",
                    shown(&self.out)
                ),
                Err(undo) => {
                    self.keep = true;
                    format!(
                        "cannot move the new output into {}: {error}, nor move the previous \
                         output back: {undo}; the next run into that folder completes the \
                         switch",
                        shown(&self.out)
                    )
                }
            }
            .into());
        }
        // Switched: from here on the output is the new one whatever happens.
        let _ = fs::remove_file(self.root.join(SWITCH));
        drop(held);
        Ok(())
    }
}

impl Drop for Staging {
    /// Removes the staging folder (with what a switch replaced) and its lock file, unless a
    /// switch could be neither finished nor undone.
    fn drop(&mut self) {
        if !self.keep {
            let _ = fs::remove_dir_all(&self.root);
            let _ = fs::remove_file(&self.lock_path);
        }
    }
}

/// Takes the lock that serialises recovery, checks and switches in `state` (waiting for a run
/// that is switching, which takes milliseconds).
fn lock_commits(state: &Path) -> Result<File> {
    let path = state.join(COMMIT_LOCK);
    let file = File::options()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&path)
        .map_err(|e| cannot("open", &path, &e))?;
    file.lock().map_err(|e| cannot("lock", &path, &e))?;
    Ok(file)
}

/// The staging folder a lock file `<state>/staging-<random>.lock` belongs to.
fn staging_folder(lock: &Path) -> Option<PathBuf> {
    let name = lock.file_name()?.to_str()?;
    let stem = name.strip_suffix(LOCK_SUFFIX)?;
    stem.starts_with(STAGING_PREFIX)
        .then(|| lock.with_file_name(stem))
}

/// Under the commit lock: completes the switches of killed runs and removes every abandoned
/// staging folder (its lock file unlocked or missing) in `state`; live runs' are left alone.
fn recover(out: &Path, state: &Path) -> Result<()> {
    let entries = fs::read_dir(state).map_err(|e| cannot("list", state, &e))?;
    let mut folders = Vec::new();
    let mut locks = Vec::new();
    for entry in entries.flatten() {
        let path = entry.path();
        if staging_folder(&path).is_some() {
            locks.push(path);
        } else if entry
            .file_name()
            .to_str()
            .is_some_and(|n| n.starts_with(STAGING_PREFIX))
        {
            folders.push(path);
        }
    }
    for lock_path in locks {
        let Ok(lock) = File::open(&lock_path) else {
            continue;
        };
        // Held: a live run's. Free: abandoned (its run ended without removing it).
        if lock.try_lock().is_err() {
            continue;
        }
        let folder = staging_folder(&lock_path).expect("filtered above");
        if folder.exists() {
            abandon(out, state, &folder)?;
        }
        let _ = fs::remove_file(&lock_path);
    }
    for folder in folders {
        let mut lock_name = folder.file_name().expect("a listed entry").to_owned();
        lock_name.push(LOCK_SUFFIX);
        // The lock file is made before the folder and removed after it: a folder without one
        // is abandoned.
        if !folder.with_file_name(lock_name).exists() {
            abandon(out, state, &folder)?;
        }
    }
    Ok(())
}

/// Completes the switch an abandoned staging folder `root` was in (if any), then removes it.
fn abandon(out: &Path, state: &Path, root: &Path) -> Result<()> {
    let journal = root.join(SWITCH);
    if journal.exists() {
        let incomplete = |e: &dyn std::fmt::Display| {
            format!(
                "{} holds the switch of a run killed while switching its finished output in, \
                 which cannot be completed: {e}",
                shown(root)
            )
        };
        let aside = fs::read_to_string(&journal).map_err(|e| incomplete(&e))?;
        let (staged, replaced) = (root.join(STAGED), root.join(REPLACED));
        // The killed run checked these against the list before switching; anything that has
        // appeared in them since is someone else's and stops the switch.
        let owned = read_list(state)?;
        let mut conflicts = Vec::new();
        for name in aside.lines().filter(|n| !n.is_empty() && !n.contains('/')) {
            if fs::symlink_metadata(replaced.join(name)).is_err() {
                find_conflicts(out, name, &owned, &mut conflicts);
            }
        }
        if !conflicts.is_empty() {
            let shown_paths: Vec<String> = conflicts
                .iter()
                .take(SHOWN_CONFLICTS)
                .map(|c| shown(&out.join(c)))
                .collect();
            return Err(incomplete(&format!(
                "{} appeared since and stbn-gen did not write {}; move {} away",
                shown_paths.join(", "),
                if conflicts.len() == 1 { "it" } else { "them" },
                if conflicts.len() == 1 { "it" } else { "them" },
            ))
            .into());
        }
        for name in aside.lines().filter(|n| !n.is_empty() && !n.contains('/')) {
            // Present in `out` but not aside yet: the previous output's, still to move.
            if fs::symlink_metadata(out.join(name)).is_ok()
                && fs::symlink_metadata(replaced.join(name)).is_err()
            {
                fs::rename(out.join(name), replaced.join(name)).map_err(|e| incomplete(&e))?;
            }
        }
        for name in list_names(&staged).map_err(|e| incomplete(&e))? {
            let target = out.join(&name);
            if fs::symlink_metadata(&target).is_ok() {
                return Err(incomplete(&format!(
                    "{} appeared in its place; move it away",
                    shown(&target)
                ))
                .into());
            }
            fs::rename(staged.join(&name), &target).map_err(|e| incomplete(&e))?;
        }
        let list = root.join(LIST);
        if list.exists() {
            fs::rename(&list, state.join(LIST)).map_err(|e| incomplete(&e))?;
        }
        fs::remove_file(&journal).map_err(|e| incomplete(&e))?;
    }
    let _ = fs::remove_dir_all(root);
    Ok(())
}

/// Refuses, naming them (at most [`SHOWN_CONFLICTS`]), the paths under the names of `out` that
/// `claims` accepts which the list does not name as the tool's; `consequence` says what the
/// refusal left.
fn refuse_conflicts(
    out: &Path,
    owned: &Owned,
    claims: &dyn Fn(&str) -> bool,
    consequence: &str,
) -> Result<()> {
    let mut conflicts = Vec::new();
    let entries = fs::read_dir(out).map_err(|e| cannot("list", out, &e))?;
    let mut names: Vec<String> = entries
        .flatten()
        .filter_map(|e| e.file_name().into_string().ok())
        .filter(|name| name != STATE_DIR && claims(name))
        .collect();
    names.sort();
    for name in names {
        find_conflicts(out, &name, owned, &mut conflicts);
    }
    if conflicts.is_empty() {
        return Ok(());
    }
    let count = conflicts.len();
    let mut listed: Vec<String> = conflicts
        .iter()
        .take(SHOWN_CONFLICTS)
        .map(|p| shown(&out.join(p)))
        .collect();
    if count > SHOWN_CONFLICTS {
        listed.push(format!("and {} more", count - SHOWN_CONFLICTS));
    }
    Err(format!(
        "{} holds {count} path{} that stbn-gen did not write and this run would replace: {}; \
         {consequence} (move {} away or choose another --out; stbn-gen replaces only what its \
         list {} names)",
        shown(out),
        if count == 1 { "" } else { "s" },
        listed.join(", "),
        if count == 1 { "it" } else { "them" },
        shown(&out.join(STATE_DIR).join(LIST)),
    )
    .into())
}

/// Adds to `conflicts` every path at or below `relative` in `out` that `owned` does not name
/// with its kind (a folder not named is one conflict, not searched further).
fn find_conflicts(out: &Path, relative: &str, owned: &Owned, conflicts: &mut Vec<String>) {
    let path = out.join(relative);
    let kind = match fs::symlink_metadata(&path) {
        Ok(m) if m.is_dir() => Some(Kind::Dir),
        Ok(m) if m.is_file() => Some(Kind::File),
        Ok(_) => None,
        Err(_) => return,
    };
    if kind.is_none() || owned.get(relative).copied() != kind {
        conflicts.push(relative.to_owned());
        return;
    }
    if kind == Some(Kind::Dir) {
        let Ok(entries) = fs::read_dir(&path) else {
            conflicts.push(relative.to_owned());
            return;
        };
        let mut children: Vec<String> = Vec::new();
        for entry in entries.flatten() {
            match entry.file_name().into_string() {
                Ok(name) => children.push(name),
                // Never a name the tool writes.
                Err(name) => conflicts.push(format!("{relative}/{}", name.to_string_lossy())),
            }
        }
        children.sort();
        for child in children {
            find_conflicts(out, &format!("{relative}/{child}"), owned, conflicts);
        }
    }
}

/// The names in folder `dir`, sorted.
fn list_names(dir: &Path) -> io::Result<BTreeSet<String>> {
    let mut names = BTreeSet::new();
    for entry in fs::read_dir(dir)? {
        let name = entry?.file_name();
        names.insert(name.into_string().map_err(|name| {
            io::Error::other(format!("{} is not UTF-8", name.to_string_lossy()))
        })?);
    }
    Ok(names)
}

/// Adds `relative` below `root` and everything under it to `list`.
fn walk(root: &Path, relative: &str, list: &mut Owned) -> Result<()> {
    let path = root.join(relative);
    let meta = fs::symlink_metadata(&path).map_err(|e| cannot("read", &path, &e))?;
    if relative.contains('\n') {
        return Err(format!("{}: a name with a line break", shown(&path)).into());
    }
    if meta.is_dir() {
        list.insert(relative.to_owned(), Kind::Dir);
        for name in list_names(&path).map_err(|e| cannot("list", &path, &e))? {
            walk(root, &format!("{relative}/{name}"), list)?;
        }
    } else {
        list.insert(relative.to_owned(), Kind::File);
    }
    Ok(())
}

/// Reads the list in `state` (empty where there is none).
fn read_list(state: &Path) -> Result<Owned> {
    let path = state.join(LIST);
    let text = match fs::read_to_string(&path) {
        Ok(text) => text,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(Owned::new()),
        Err(e) => return Err(cannot("read", &path, &e).into()),
    };
    let mut lines = text.lines();
    let not_a_list = |line: usize| {
        format!(
            "{}:{line}: not a list stbn-gen wrote (line 1 is `{LIST_HEADER}`, then `f <path>` or \
             `d <path>` per line); remove the file only if nothing else under {} matters, \
             since stbn-gen then refuses to replace anything there",
            shown(&path),
            shown(state.parent().unwrap_or(state)),
        )
    };
    if lines.next() != Some(LIST_HEADER) {
        return Err(not_a_list(1).into());
    }
    let mut owned = Owned::new();
    for (index, line) in lines.enumerate() {
        let kind = match line.get(..2) {
            Some("f ") => Kind::File,
            Some("d ") => Kind::Dir,
            _ => return Err(not_a_list(index + 2).into()),
        };
        owned.insert(line[2..].to_owned(), kind);
    }
    Ok(owned)
}

/// Writes `list` to `path`, synced to disk.
fn write_list(path: &Path, list: &Owned) -> Result<()> {
    let mut text = format!("{LIST_HEADER}\n");
    for (relative, kind) in list {
        text.push_str(if *kind == Kind::Dir { "d " } else { "f " });
        text.push_str(relative);
        text.push('\n');
    }
    write_synced(path, text.as_bytes())
}

/// Writes `bytes` to a new file `path` and syncs it.
fn write_synced(path: &Path, bytes: &[u8]) -> Result<()> {
    use std::io::Write as _;
    let mut file = File::create(path).map_err(|e| cannot("create", path, &e))?;
    file.write_all(bytes)
        .and_then(|()| file.sync_all())
        .map_err(|e| cannot("write", path, &e).into())
}

/// `cannot <verb> <path>: <error>`.
fn cannot(verb: &str, path: &Path, error: &dyn std::fmt::Display) -> String {
    format!("cannot {verb} {}: {error}", shown(path))
}

/// `path` for a message, at most 300 characters (the middle elided).
pub fn shown(path: &Path) -> String {
    bounded(&path.display().to_string(), 300)
}

/// `text`, at most `max` characters: longer ones keep their start and end around `…`.
pub fn bounded(text: &str, max: usize) -> String {
    let count = text.chars().count();
    if count <= max {
        return text.to_owned();
    }
    let keep = (max - 1) / 2;
    let head: String = text.chars().take(keep).collect();
    let tail: String = text.chars().skip(count - keep).collect();
    format!("{head}…{tail}")
}

/// Holding back the signals that stop a run while it switches its output in.
mod signals {
    /// SIGINT, SIGTERM and SIGHUP are noted instead of acted on while this lives; on drop the
    /// previous handlers come back and a noted signal is raised again, so it takes effect with
    /// the switch complete (or undone).
    pub struct Held {
        #[cfg(unix)]
        previous: Vec<(libc::c_int, libc::sighandler_t)>,
        #[cfg(unix)]
        _one_at_a_time: std::sync::MutexGuard<'static, ()>,
    }

    /// Held by every [`Held`]: dispositions are process-wide, so holds do not overlap (one per
    /// run; several only in tests).
    #[cfg(unix)]
    pub static HOLDS: std::sync::Mutex<()> = std::sync::Mutex::new(());

    #[cfg(unix)]
    static NOTED: std::sync::atomic::AtomicI32 = std::sync::atomic::AtomicI32::new(0);

    #[cfg(unix)]
    extern "C" fn note(signal: libc::c_int) {
        NOTED.store(signal, std::sync::atomic::Ordering::SeqCst);
    }

    #[cfg(unix)]
    const SIGNALS: [libc::c_int; 3] = [libc::SIGINT, libc::SIGTERM, libc::SIGHUP];

    impl Held {
        pub fn new() -> Held {
            #[cfg(unix)]
            {
                let one_at_a_time = HOLDS.lock().unwrap_or_else(|e| e.into_inner());
                let previous = SIGNALS
                    .iter()
                    .map(|&signal| {
                        let handler = note as extern "C" fn(libc::c_int) as libc::sighandler_t;
                        // SAFETY: `note` only stores to an atomic, which is async-signal-safe;
                        // `signal` takes no memory from us.
                        (signal, unsafe { libc::signal(signal, handler) })
                    })
                    .collect();
                Held {
                    previous,
                    _one_at_a_time: one_at_a_time,
                }
            }
            #[cfg(not(unix))]
            Held {}
        }
    }

    impl Drop for Held {
        fn drop(&mut self) {
            #[cfg(unix)]
            {
                for &(signal, handler) in &self.previous {
                    if handler != libc::SIG_ERR {
                        // SAFETY: puts back the disposition `signal` returned (default, ignore
                        // or a handler installed before); no memory is passed.
                        unsafe { libc::signal(signal, handler) };
                    }
                }
                let noted = NOTED.swap(0, std::sync::atomic::Ordering::SeqCst);
                if noted != 0 {
                    // SAFETY: raises a signal at this process under its restored disposition,
                    // as it would have arrived without the hold.
                    unsafe { libc::raise(noted) };
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        names.sort();
        names
    }

    fn all(_: &str) -> bool {
        true
    }

    /// A run into `out` that writes `files` (relative path → content) and commits.
    fn run(out: &Path, files: &[(&str, &str)]) -> Result<()> {
        let staging = Staging::new(out, &all, 100)?;
        for (path, text) in files {
            let path = staging.dir().join(path);
            fs::create_dir_all(path.parent().unwrap()).unwrap();
            fs::write(path, text).unwrap();
        }
        staging.commit()
    }

    #[test]
    fn commit_replaces_its_own_output_whole_and_leaves_other_files_alone() {
        let out = tempfile::tempdir().unwrap();
        let out = out.path();
        run(
            out,
            &[("mask/mask_0.png", "old"), ("mask/mask_1.png", "old")],
        )
        .unwrap();
        fs::write(out.join("kept.txt"), "kept").unwrap();

        let claims = |name: &str| name == "mask" || name == "report.md";
        let staging = Staging::new(out, &claims, 100).unwrap();
        fs::create_dir(staging.dir().join("mask")).unwrap();
        fs::write(staging.dir().join("mask/mask_0.png"), "new").unwrap();
        fs::write(staging.dir().join("report.md"), "new").unwrap();
        // Until the commit, the output is the previous one.
        assert!(!out.join("report.md").exists());
        staging.commit().unwrap();
        assert_eq!(names(out), [STATE_DIR, "kept.txt", "mask", "report.md"]);
        assert_eq!(names(&out.join("mask")), ["mask_0.png"]);
        assert_eq!(fs::read_to_string(out.join("report.md")).unwrap(), "new");
        assert_eq!(names(&out.join(STATE_DIR)), [COMMIT_LOCK, LIST]);
        let list = read_list(&out.join(STATE_DIR)).unwrap();
        assert_eq!(
            list.keys().collect::<Vec<_>>(),
            ["mask", "mask/mask_0.png", "report.md"]
        );
    }

    #[test]
    fn what_the_list_does_not_name_is_refused_before_and_at_the_switch() {
        let out = tempfile::tempdir().unwrap();
        let out = out.path();
        // Someone's folder named like a mask.
        fs::create_dir(out.join("mask")).unwrap();
        fs::write(out.join("mask/notes.txt"), "mine").unwrap();
        let error = Staging::new(out, &|n| n == "mask", 100)
            .err()
            .unwrap()
            .to_string();
        assert!(
            error.contains("1 path that stbn-gen did not write"),
            "{error}"
        );
        assert!(error.contains("mask"), "{error}");
        assert!(error.contains("nothing was written"), "{error}");
        fs::remove_dir_all(out.join("mask")).unwrap();

        // An owned folder in which a file appeared, found at the switch.
        run(out, &[("mask/mask_0.png", "old")]).unwrap();
        let staging = Staging::new(out, &all, 100).unwrap();
        fs::create_dir(staging.dir().join("mask")).unwrap();
        fs::write(staging.dir().join("mask/mask_0.png"), "new").unwrap();
        fs::write(out.join("mask/notes.txt"), "mine").unwrap();
        let error = staging.commit().err().unwrap().to_string();
        assert!(error.contains("mask/notes.txt"), "{error}");
        assert!(error.contains("previous one left as it was"), "{error}");
        assert_eq!(
            fs::read_to_string(out.join("mask/mask_0.png")).unwrap(),
            "old"
        );
        assert_eq!(
            fs::read_to_string(out.join("mask/notes.txt")).unwrap(),
            "mine"
        );
        assert_eq!(names(&out.join(STATE_DIR)), [COMMIT_LOCK, LIST]);

        // A symlink in place of a mask folder, and more conflicts than are named.
        fs::remove_file(out.join("mask/notes.txt")).unwrap();
        for i in 0..7 {
            fs::write(out.join(format!("foreign_{i}")), "").unwrap();
        }
        #[cfg(unix)]
        {
            fs::remove_dir_all(out.join("mask")).unwrap();
            std::os::unix::fs::symlink(out.join("foreign_0"), out.join("mask")).unwrap();
        }
        let error = Staging::new(out, &all, 100).err().unwrap().to_string();
        assert!(error.contains("and 3 more"), "{error}");
        assert!(error.contains("foreign_0"), "{error}");
        #[cfg(unix)]
        assert!(error.contains("8 paths"), "{error}");
    }

    #[test]
    fn abandoned_staging_folders_are_removed_and_live_ones_kept() {
        let out = tempfile::tempdir().unwrap();
        let out = out.path();
        let state = out.join(STATE_DIR);
        let staging = Staging::new(out, &all, 100).unwrap();
        fs::write(staging.dir().join("report.md"), "partial").unwrap();
        drop(staging);
        assert!(names(&state).iter().all(|n| !n.starts_with(STAGING_PREFIX)));

        // A live run's (its lock held, here by this process through another open file
        // description, as a run in another PID namespace would), an abandoned one (lock free) and
        // one without a lock file.
        let live = state.join("staging-live");
        let held = File::create(state.join("staging-live.lock")).unwrap();
        held.lock().unwrap();
        let dead = state.join("staging-dead");
        File::create(state.join("staging-dead.lock")).unwrap();
        let bare = state.join("staging-bare");
        for folder in [&live, &dead, &bare] {
            fs::create_dir_all(folder.join(STAGED)).unwrap();
        }
        let staging = Staging::new(out, &all, 100).unwrap();
        assert!(live.exists());
        assert!(!dead.exists() && !state.join("staging-dead.lock").exists());
        assert!(!bare.exists());
        drop(staging);
        drop(held);
        run(out, &[]).unwrap();
        assert!(!live.exists());
    }

    #[test]
    fn a_switch_killed_half_way_is_completed_by_the_next_run() {
        let out = tempfile::tempdir().unwrap();
        let out = out.path();
        run(
            out,
            &[
                ("a/a_0.png", "old a"),
                ("b.stbn", "old b"),
                ("report.md", "old"),
            ],
        )
        .unwrap();
        // A run that moved `a` aside and `a` in, then was killed: `b.stbn` and the report still
        // old, the list still the old one.
        let staging = Staging::new(out, &all, 100).unwrap();
        let root = staging.root.clone();
        for (path, text) in [
            ("a/a_0.png", "new a"),
            ("b.stbn", "new b"),
            ("report.md", "new"),
        ] {
            let path = staging.dir().join(path);
            fs::create_dir_all(path.parent().unwrap()).unwrap();
            fs::write(path, text).unwrap();
        }
        let mut list = Owned::new();
        for name in ["a", "b.stbn", "report.md"] {
            walk(&staging.dir(), name, &mut list).unwrap();
        }
        write_list(&root.join(LIST), &list).unwrap();
        fs::create_dir(root.join(REPLACED)).unwrap();
        fs::write(root.join(SWITCH), "a\nb.stbn\nreport.md\n").unwrap();
        fs::rename(out.join("a"), root.join(REPLACED).join("a")).unwrap();
        fs::rename(staging.dir().join("a"), out.join("a")).unwrap();
        // Killed: the lock goes with the process; the folder and its lock file stay.
        let mut staging = staging;
        staging.keep = true;
        drop(staging);

        run(out, &[("other.txt", "x")]).unwrap();
        for (path, text) in [
            ("a/a_0.png", "new a"),
            ("b.stbn", "new b"),
            ("report.md", "new"),
        ] {
            assert_eq!(fs::read_to_string(out.join(path)).unwrap(), text, "{path}");
        }
        assert!(!root.exists());
        let list = read_list(&out.join(STATE_DIR)).unwrap();
        assert!(list.contains_key("b.stbn") && list.contains_key("other.txt"));
    }

    #[test]
    fn a_killed_switch_is_not_completed_over_files_that_appeared_since() {
        let out = tempfile::tempdir().unwrap();
        let out = out.path();
        run(out, &[("a/a_0.png", "old a"), ("report.md", "old")]).unwrap();
        // A run killed after writing its journal, before moving anything.
        let staging = Staging::new(out, &all, 100).unwrap();
        let root = staging.root.clone();
        for (path, text) in [("a/a_0.png", "new a"), ("report.md", "new")] {
            let path = staging.dir().join(path);
            fs::create_dir_all(path.parent().unwrap()).unwrap();
            fs::write(path, text).unwrap();
        }
        fs::create_dir(root.join(REPLACED)).unwrap();
        fs::write(root.join(SWITCH), "a\nreport.md\n").unwrap();
        let mut staging = staging;
        staging.keep = true;
        drop(staging);
        // Someone's file, put into the old mask folder after the kill.
        fs::write(out.join("a/notes.txt"), "mine").unwrap();

        let error = run(out, &[]).unwrap_err().to_string();
        assert!(
            error.contains("notes.txt") && error.contains("move it away"),
            "{error}"
        );
        assert_eq!(fs::read_to_string(out.join("a/notes.txt")).unwrap(), "mine");
        assert_eq!(fs::read_to_string(out.join("a/a_0.png")).unwrap(), "old a");
        assert_eq!(fs::read_to_string(out.join("report.md")).unwrap(), "old");
    }

    #[test]
    fn an_output_that_is_a_file_or_too_long_is_refused_first() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("file");
        fs::write(&file, "").unwrap();
        let error = Staging::new(&file, &all, 100).err().unwrap().to_string();
        assert!(error.contains("is a file, not a folder"), "{error}");
        let error = Staging::new(&file.join("out"), &all, 100)
            .err()
            .unwrap()
            .to_string();
        assert!(
            error.starts_with("cannot write to the output folder"),
            "{error}"
        );
        assert!(error.contains(&file.display().to_string()), "{error}");
        let long = dir.path().join("x".repeat(200)).join("y".repeat(200));
        let error = Staging::new(&long, &all, 4000).err().unwrap().to_string();
        assert!(error.contains("over the limit of 4095"), "{error}");
        assert!(error.chars().count() < 800, "{error}");
        assert!(!dir.path().join("x".repeat(200)).exists());
    }

    #[test]
    fn a_list_that_is_not_one_is_refused() {
        let out = tempfile::tempdir().unwrap();
        fs::create_dir(out.path().join(STATE_DIR)).unwrap();
        fs::write(out.path().join(STATE_DIR).join(LIST), "hello\n").unwrap();
        let error = Staging::new(out.path(), &all, 100)
            .err()
            .unwrap()
            .to_string();
        assert!(
            error.contains("output:1: not a list stbn-gen wrote"),
            "{error}"
        );
    }

    #[cfg(unix)]
    #[test]
    fn a_signal_during_the_switch_takes_effect_after_it() {
        use std::sync::atomic::{AtomicI32, Ordering};
        static SEEN: AtomicI32 = AtomicI32::new(0);
        extern "C" fn seen(signal: libc::c_int) {
            SEEN.store(signal, Ordering::SeqCst);
        }
        let install = |handler: libc::sighandler_t| {
            let _no_hold = signals::HOLDS.lock().unwrap_or_else(|e| e.into_inner());
            // SAFETY: `seen` only stores to an atomic (async-signal-safe); installed while no
            // hold is active, so none restores an older handler over it.
            unsafe { libc::signal(libc::SIGHUP, handler) }
        };
        let previous = install(seen as extern "C" fn(libc::c_int) as libc::sighandler_t);
        let held = signals::Held::new();
        // SAFETY: raises SIGHUP at this thread, which `held` notes instead of acting on.
        unsafe { libc::raise(libc::SIGHUP) };
        assert_eq!(SEEN.load(Ordering::SeqCst), 0);
        drop(held);
        assert_eq!(SEEN.load(Ordering::SeqCst), libc::SIGHUP);
        install(previous);
    }

    #[test]
    fn long_text_is_bounded() {
        assert_eq!(bounded("abc", 3), "abc");
        let long = bounded(&"é".repeat(1000), 9);
        assert_eq!(long, "éééé…éééé");
    }
}
