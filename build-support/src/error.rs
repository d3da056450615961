//! [`Error`] and [`ManifestError`].

use std::fmt;
use std::io;
use std::path::{Path, PathBuf};

use stbn_gen::VectorSpecError;

use crate::quote::{backticked, quoted};

/// A problem in the manifest, with the place it was found.
///
/// `Display` reads `FILE:LINE:COLUMN: mask "NAME", field `FIELD`: MESSAGE`; the mask and field
/// parts are left out when the problem is not inside one (a missing `masks` list, say). A name or
/// field longer than 64 characters is shown cut, with its length (`mask "nnnn…" (15728640
/// characters)`); the accessors return it whole.
#[derive(Clone, Debug, PartialEq)]
pub struct ManifestError {
    // Boxed to keep `Result<_, ManifestError>` small.
    pub(crate) path: Box<Path>,
    pub(crate) line: usize,
    pub(crate) column: usize,
    pub(crate) mask_index: Option<usize>,
    pub(crate) mask_name: Option<String>,
    pub(crate) field: Option<String>,
    pub(crate) message: String,
}

impl ManifestError {
    /// The manifest file, as given to [`Manifest::load`](crate::Manifest::load) or
    /// [`Manifest::parse`](crate::Manifest::parse).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// 1-based line of the problem.
    pub fn line(&self) -> usize {
        self.line
    }

    /// 1-based column of the problem, in characters.
    pub fn column(&self) -> usize {
        self.column
    }

    /// Index in the `masks` list of the entry the problem is in.
    pub fn mask_index(&self) -> Option<usize> {
        self.mask_index
    }

    /// `name` of the entry the problem is in, when it could be read.
    pub fn mask_name(&self) -> Option<&str> {
        self.mask_name.as_deref()
    }

    /// The field the problem is in (`"sigma"`, `"size"`, an unknown field's name…).
    pub fn field(&self) -> Option<&str> {
        self.field.as_deref()
    }

    /// What is wrong, without the location prefix.
    pub fn message(&self) -> &str {
        &self.message
    }
}

impl fmt::Display for ManifestError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}: ", self.path.display(), self.line, self.column)?;
        match (&self.mask_name, self.mask_index) {
            (Some(name), _) => write!(f, "mask {}, ", quoted(name))?,
            (None, Some(index)) => write!(f, "mask #{} (unnamed), ", index + 1)?,
            (None, None) => {}
        }
        if let Some(field) = &self.field {
            write!(f, "field {}: ", backticked(field))?;
        }
        f.write_str(&self.message)
    }
}

impl std::error::Error for ManifestError {}

/// Everything that can stop [`embed`](crate::embed) and the functions it is built from.
#[derive(Debug)]
#[non_exhaustive]
pub enum Error {
    /// The manifest does not parse or does not validate.
    Manifest(Box<ManifestError>),
    /// A file operation that the build needs failed (cache failures are warnings, not errors).
    Io {
        /// What was being done, e.g. `"read the manifest"`.
        action: &'static str,
        /// The file or directory involved.
        path: PathBuf,
        /// The underlying error.
        source: io::Error,
    },
    /// An environment variable that Cargo sets for build scripts is missing.
    MissingEnv(&'static str),
    /// A path that has to appear in generated Rust source is not valid UTF-8.
    NonUtf8Path(PathBuf),
    /// The generator rejected a mask (cannot happen for a validated manifest).
    Generate {
        /// The mask's `name`.
        mask: String,
        /// The generator's reason (scalar spec errors come as [`VectorSpecError::Spec`]).
        source: VectorSpecError,
    },
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Manifest(e) => e.fmt(f),
            Error::Io {
                action,
                path,
                source,
            } => write!(f, "could not {action} {}: {source}", path.display()),
            Error::MissingEnv(var) => write!(
                f,
                "environment variable `{var}` is not set: `embed` must run in a Cargo build \
                 script (use `embed_with` elsewhere)"
            ),
            Error::NonUtf8Path(path) => write!(
                f,
                "path {} is not valid UTF-8, so it cannot be embedded with include_bytes!",
                path.display()
            ),
            Error::Generate { mask, source } => write!(f, "mask {mask:?}: {source}"),
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Error::Manifest(e) => Some(e.as_ref()),
            Error::Io { source, .. } => Some(source),
            Error::Generate { source, .. } => Some(source),
            Error::MissingEnv(_) | Error::NonUtf8Path(_) => None,
        }
    }
}

impl From<ManifestError> for Error {
    fn from(e: ManifestError) -> Self {
        Error::Manifest(Box::new(e))
    }
}

impl Error {
    /// An [`Error::Io`] for `action` on `path`.
    pub(crate) fn io(action: &'static str, path: &Path, source: io::Error) -> Error {
        Error::Io {
            action,
            path: path.to_owned(),
            source,
        }
    }
}
