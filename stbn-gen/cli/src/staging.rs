//! Atomic output: a run writes everything into a staging folder inside `--out` and moves each
//! finished file or folder into place only at the end, so an interrupted or failed run leaves the
//! previous complete output untouched and no partial file under a final name.
//!
//! The staging folder is `<out>/.stbn-gen-staging-<pid>-<random>`; it is removed when the run
//! ends, whether it succeeded or not. A run killed outright (SIGINT, SIGKILL) cannot remove its
//! own, so each run first removes those whose process no longer exists.

use std::fs;
use std::path::{Path, PathBuf};

use crate::Result;

/// Start of every staging folder's name.
const PREFIX: &str = ".stbn-gen-staging-";

/// A staging folder inside an output folder.
pub struct Staging {
    out: PathBuf,
    dir: tempfile::TempDir,
}

impl Staging {
    /// Creates `out` (and its parents) if needed and a staging folder in it: proves that `out`
    /// is a writable folder before any work is done.
    pub fn new(out: &Path) -> Result<Staging> {
        let unwritable = |e: &dyn std::fmt::Display| {
            format!("cannot write to the output folder {}: {e}", out.display())
        };
        fs::create_dir_all(out).map_err(|e| unwritable(&e))?;
        remove_abandoned(out);
        let dir = tempfile::Builder::new()
            .prefix(&format!("{PREFIX}{}-", std::process::id()))
            .tempdir_in(out)
            .map_err(|e| unwritable(&e))?;
        Ok(Staging {
            out: out.to_owned(),
            dir,
        })
    }

    /// The staging folder: write everything here, under the name it will have in `out`.
    pub fn dir(&self) -> &Path {
        self.dir.path()
    }

    /// Moves each of `names` (files or folders in the staging folder) to `<out>/<name>`, in
    /// order, replacing what is there, then removes the staging folder. A folder is replaced as
    /// a whole: the previous one is moved aside first and removed with the staging folder.
    pub fn commit(self, names: &[String]) -> Result<()> {
        let replaced = self.dir().join(".replaced");
        fs::create_dir(&replaced)
            .map_err(|e| format!("cannot create {}: {e}", replaced.display()))?;
        for name in names {
            let (staged, target) = (self.dir().join(name), self.out.join(name));
            let staged_is_dir = staged.is_dir();
            if let Ok(old) = fs::symlink_metadata(&target)
                && (old.is_dir() || staged_is_dir)
            {
                let aside = replaced.join(name);
                fs::rename(&target, &aside).map_err(|e| {
                    format!("cannot move {} aside to replace it: {e}", target.display())
                })?;
            }
            fs::rename(&staged, &target).map_err(|e| {
                format!(
                    "cannot move {} to {}: {e}",
                    staged.display(),
                    target.display()
                )
            })?;
        }
        let path = self.dir.path().to_owned();
        self.dir
            .close()
            .map_err(|e| format!("cannot remove {}: {e}", path.display()).into())
    }
}

/// Removes the staging folders in `out` left by runs whose process no longer exists (Unix; a
/// folder that cannot be removed is left alone).
fn remove_abandoned(out: &Path) {
    let Ok(entries) = fs::read_dir(out) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let pid = name
            .to_str()
            .and_then(|n| n.strip_prefix(PREFIX))
            .and_then(|rest| rest.split('-').next())
            .and_then(|pid| pid.parse::<u32>().ok());
        if let Some(pid) = pid
            && !process_exists(pid)
        {
            let _ = fs::remove_dir_all(entry.path());
        }
    }
}

/// Whether a process `pid` exists (`true` where that cannot be told).
fn process_exists(pid: u32) -> bool {
    #[cfg(unix)]
    {
        let Ok(pid) = libc::pid_t::try_from(pid) else {
            return true;
        };
        // SAFETY: signal 0 only checks that the process exists and may be signalled; nothing is
        // sent, and no memory is passed.
        let status = unsafe { libc::kill(pid, 0) };
        status == 0 || std::io::Error::last_os_error().raw_os_error() != Some(libc::ESRCH)
    }
    #[cfg(not(unix))]
    {
        let _ = pid;
        true
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

    #[test]
    fn commit_replaces_files_and_whole_folders_and_leaves_nothing_behind() {
        let out = tempfile::tempdir().unwrap();
        fs::create_dir(out.path().join("mask")).unwrap();
        fs::write(out.path().join("mask/old_5.png"), "old").unwrap();
        fs::write(out.path().join("report.md"), "old").unwrap();
        fs::write(out.path().join("kept.txt"), "kept").unwrap();

        let staging = Staging::new(out.path()).unwrap();
        fs::create_dir(staging.dir().join("mask")).unwrap();
        fs::write(staging.dir().join("mask/mask_0.png"), "new").unwrap();
        fs::write(staging.dir().join("report.md"), "new").unwrap();
        // Until the commit, the output is the previous one.
        assert_eq!(
            fs::read_to_string(out.path().join("report.md")).unwrap(),
            "old"
        );
        staging
            .commit(&["mask".to_owned(), "report.md".to_owned()])
            .unwrap();
        assert_eq!(names(out.path()), ["kept.txt", "mask", "report.md"]);
        assert_eq!(names(&out.path().join("mask")), ["mask_0.png"]);
        assert_eq!(
            fs::read_to_string(out.path().join("report.md")).unwrap(),
            "new"
        );
    }

    #[test]
    fn a_dropped_staging_folder_is_removed_and_abandoned_ones_are_cleared() {
        let out = tempfile::tempdir().unwrap();
        let staging = Staging::new(out.path()).unwrap();
        fs::write(staging.dir().join("report.md"), "partial").unwrap();
        drop(staging);
        assert!(names(out.path()).is_empty());
        // One of a process that cannot exist (above any pid_max), one of this live process.
        let dead = out.path().join(format!("{PREFIX}4294967-abc"));
        let live = out
            .path()
            .join(format!("{PREFIX}{}-abc", std::process::id()));
        fs::create_dir(&dead).unwrap();
        fs::create_dir(&live).unwrap();
        let staging = Staging::new(out.path()).unwrap();
        assert!(!dead.exists());
        assert!(live.exists());
        drop(staging);
    }

    #[test]
    fn an_output_that_is_a_file_is_refused_first() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("file");
        fs::write(&file, "").unwrap();
        let error = Staging::new(&file.join("out")).err().unwrap().to_string();
        assert!(
            error.starts_with("cannot write to the output folder"),
            "{error}"
        );
        assert!(error.contains(&file.display().to_string()), "{error}");
    }
}
