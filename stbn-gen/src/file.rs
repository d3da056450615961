//! Reading input files: only regular files, and only up to a size limit checked before reading.
//!
//! Manifests, images, cache entries and PNG slices all come from paths a user or a build names;
//! a FIFO or a huge file there must cost an error, not a hang or an allocation.

use std::fs::{self, File};
use std::io::{self, Read as _};
use std::path::Path;

/// Opens `path` for reading if it is a regular file (after following symbolic links). A FIFO,
/// device, socket or folder is refused without reading from it; on Unix the file is opened
/// non-blocking, so a FIFO without a writer cannot stall the open either.
///
/// # Errors
/// The open's error, or [`io::ErrorKind::InvalidInput`] for anything but a regular file. The
/// message does not name the path: callers add it.
pub(crate) fn open_regular_file(path: &Path) -> io::Result<File> {
    let mut options = fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::custom_flags(&mut options, libc::O_NONBLOCK);
    let file = options.open(path)?;
    let kind = file.metadata()?.file_type();
    if kind.is_file() {
        Ok(file)
    } else {
        let what = if kind.is_dir() {
            "a folder"
        } else {
            "a FIFO, device or socket"
        };
        Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("is {what}, not a regular file"),
        ))
    }
}

/// Reads the whole file at `path` in one pass if it is a regular file (after following symbolic
/// links; a FIFO, device, socket or folder is refused without reading from it, and on Unix the
/// file is opened non-blocking, so a FIFO without a writer cannot stall the open either) and
/// holds at most `max_bytes` bytes: the size is checked before anything is read, and again while
/// reading (a file that grows is cut off at the limit and refused).
///
/// # Errors
/// The open's error; [`io::ErrorKind::InvalidInput`] for anything but a regular file; a read
/// error; [`io::ErrorKind::InvalidData`] for a file over the limit. The message does not name the
/// path: callers add it.
pub fn read_regular_file(path: &Path, max_bytes: u64) -> io::Result<Vec<u8>> {
    let file = open_regular_file(path)?;
    let too_large = |len: u64| {
        io::Error::new(
            io::ErrorKind::InvalidData,
            format!("is {len} bytes, over the limit of {max_bytes} bytes"),
        )
    };
    let len = file.metadata()?.len();
    if len > max_bytes {
        return Err(too_large(len));
    }
    let mut bytes = Vec::with_capacity(len as usize);
    file.take(max_bytes + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max_bytes {
        return Err(too_large(bytes.len() as u64));
    }
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_regular_files_are_read() {
        let dir = tempfile::tempdir().unwrap();
        let error = read_regular_file(dir.path(), 10).unwrap_err();
        assert!(error.to_string().contains("a folder"), "{error}");
        let file = dir.path().join("eleven");
        fs::write(&file, b"eleven byte").unwrap();
        assert_eq!(read_regular_file(&file, 11).unwrap(), b"eleven byte");
        let error = read_regular_file(&file, 10).unwrap_err();
        assert!(
            error.to_string().contains("over the limit of 10"),
            "{error}"
        );
    }
}
