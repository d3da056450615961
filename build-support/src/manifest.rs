//! The `assets.ron` manifest: which masks to generate and how to store them.
//!
//! ```ron
//! (
//!     masks: [
//!         (
//!             name: "scalar_64",      // ASCII Rust identifier; becomes the static SCALAR_64
//!             kind: Scalar,           // Scalar | Blue2D | Blue3D
//!             size: (64, 64, 32),     // (width, height, frames)
//!             seed: 7,
//!             sigma: 1.9,             // optional, default 1.9
//!             sigma_time: 1.9,        // optional, default = sigma
//!             density: 0.1,           // optional, default 0.1, in (0, 0.5]
//!             kernel_tolerance: 5e-3, // optional, default 5e-3, in (0, 1)
//!             encoding: Unorm8,       // Unorm8 | Unorm16 | F32
//!             compression: Lz4,       // optional: None (default) | Lz4 | Deflate
//!         ),
//!     ],
//! )
//! ```
//!
//! Unknown fields are errors. Optional fields may also be written `Some(…)`. Every error names the
//! file, line, column and field ([`ManifestError`]).

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use ron::error::SpannedError;
use ron::extensions::Extensions;
use serde::Deserialize;
use stbn_gen::{EnergyTopology, MaskSpec, SpecError};
use stbn_runtime::{Compression, Encoding};

use crate::source::{Pos, SourceMap};
use crate::{Error, ManifestError};

/// Which energy a mask is generated with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Deserialize)]
pub enum MaskKind {
    /// Spatiotemporal blue noise (the STBN paper's scalar mask): blue within every frame and over
    /// time at every pixel. [`EnergyTopology::Spatiotemporal`].
    Scalar,
    /// An independent 2D blue-noise mask per frame (white over time).
    /// [`EnergyTopology::Independent2D`].
    Blue2D,
    /// Isotropic 3D blue noise over (x, y, frame). [`EnergyTopology::Isotropic3D`].
    Blue3D,
}

impl MaskKind {
    /// The generator topology this kind maps to.
    pub fn topology(self) -> EnergyTopology {
        match self {
            MaskKind::Scalar => EnergyTopology::Spatiotemporal,
            MaskKind::Blue2D => EnergyTopology::Independent2D,
            MaskKind::Blue3D => EnergyTopology::Isotropic3D,
        }
    }

    /// A one-line description for generated documentation.
    pub fn description(self) -> &'static str {
        match self {
            MaskKind::Scalar => "spatiotemporal blue noise, blue in space and over time",
            MaskKind::Blue2D => "independent 2D blue noise per frame, white over time",
            MaskKind::Blue3D => "isotropic 3D blue noise over x, y and frames",
        }
    }
}

/// One validated mask of the manifest, with defaults filled in.
#[derive(Clone, Debug, PartialEq)]
pub struct MaskEntry {
    /// ASCII Rust identifier, not a keyword; unique in the manifest even after upper-casing.
    pub name: String,
    /// The energy the mask is generated with.
    pub kind: MaskKind,
    /// `(width, height, frames)` in pixels, pixels and frames; each in
    /// `1..=`[`MaskSpec::MAX_AXIS`], within [`MaskSpec::MAX_SLICE_PIXELS`] per frame and
    /// [`MaskSpec::MAX_PIXELS`] in all.
    pub size: (u32, u32, u32),
    /// Generator seed.
    pub seed: u64,
    /// Spatial Gaussian σ in pixels, finite and `> 0` (default [`MaskSpec::DEFAULT_SIGMA`]).
    pub sigma: f64,
    /// Temporal Gaussian σ in frames, finite and `> 0` (default: `sigma`).
    pub sigma_time: f64,
    /// Initial pattern density in `(0, 0.5]` (default [`MaskSpec::DEFAULT_DENSITY`]).
    pub density: f64,
    /// Kernel truncation tolerance in `(0, 1)` (default [`MaskSpec::DEFAULT_KERNEL_TOLERANCE`]).
    pub kernel_tolerance: f64,
    /// How values are stored.
    pub encoding: Encoding,
    /// How the payload is compressed (default [`Compression::None`]).
    pub compression: Compression,
}

impl MaskEntry {
    /// The generator specification of this mask.
    pub fn spec(&self) -> MaskSpec {
        MaskSpec {
            width: self.size.0,
            height: self.size.1,
            depth: self.size.2,
            seed: self.seed,
            sigma_xy: self.sigma,
            sigma_z: self.sigma_time,
            initial_density: self.density,
            topology: self.kind.topology(),
            kernel_tolerance: self.kernel_tolerance,
        }
    }

    /// The name of the generated static: `name` in upper case (`scalar_64` → `SCALAR_64`).
    pub fn static_name(&self) -> String {
        self.name.to_ascii_uppercase()
    }
}

/// A parsed and validated manifest.
#[derive(Clone, Debug, PartialEq)]
pub struct Manifest {
    path: PathBuf,
    masks: Vec<MaskEntry>,
}

impl Manifest {
    /// Reads and parses the manifest at `path`.
    ///
    /// # Errors
    /// [`Error::Io`] if the file cannot be read, [`Error::Manifest`] as for
    /// [`parse`](Self::parse).
    pub fn load(path: impl AsRef<Path>) -> Result<Manifest, Error> {
        let path = path.as_ref();
        let text =
            std::fs::read_to_string(path).map_err(|e| Error::io("read the manifest", path, e))?;
        Ok(Manifest::parse(&text, path)?)
    }

    /// Parses and validates manifest `text`; `path` is only used in error messages.
    ///
    /// # Errors
    /// The first problem in document order: a syntax or type error, an unknown or missing field,
    /// a name that is not an ASCII Rust identifier (or is a keyword), a name that duplicates an
    /// earlier one (compared in upper case), or a value out of range.
    pub fn parse(text: &str, path: impl AsRef<Path>) -> Result<Manifest, ManifestError> {
        let source = Source {
            text,
            path: path.as_ref(),
            map: SourceMap::scan(text),
        };
        let raw: RawManifest = ron::Options::default()
            .with_default_extension(Extensions::IMPLICIT_SOME)
            .from_str(text)
            .map_err(|e| source.ron_error(&e))?;
        let mut masks = Vec::with_capacity(raw.masks.len());
        let mut statics: HashMap<String, usize> = HashMap::new();
        for (index, raw) in raw.masks.into_iter().enumerate() {
            let entry = raw.resolve();
            let field_error = |field: &str, message: String| {
                source.field_error(index, &entry.name, field, message)
            };
            check_identifier(&entry.name).map_err(|m| field_error("name", m))?;
            if let Some(&first) = statics.get(&entry.static_name()) {
                let other: &MaskEntry = &masks[first];
                let line = source.field_pos(first, "name").line;
                return Err(field_error(
                    "name",
                    format!(
                        "duplicates mask {:?} (line {line}): both would become the static {}",
                        other.name,
                        entry.static_name()
                    ),
                ));
            }
            if let Err(e) = entry.spec().validate() {
                let (field, message) = spec_error_field(&e, raw.sigma_time.is_some());
                return Err(field_error(field, message));
            }
            statics.insert(entry.static_name(), index);
            masks.push(entry);
        }
        Ok(Manifest {
            path: path.as_ref().to_owned(),
            masks,
        })
    }

    /// The manifest's path, as given to [`load`](Self::load) or [`parse`](Self::parse).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The masks in manifest order.
    pub fn masks(&self) -> &[MaskEntry] {
        &self.masks
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename = "Manifest")]
struct RawManifest {
    masks: Vec<RawMask>,
}

#[derive(Clone, Deserialize)]
#[serde(deny_unknown_fields, rename = "Mask")]
struct RawMask {
    name: String,
    kind: MaskKind,
    size: (u32, u32, u32),
    seed: u64,
    #[serde(default)]
    sigma: Option<f64>,
    #[serde(default)]
    sigma_time: Option<f64>,
    #[serde(default)]
    density: Option<f64>,
    #[serde(default)]
    kernel_tolerance: Option<f64>,
    #[serde(with = "EncodingDef")]
    encoding: Encoding,
    #[serde(default = "no_compression", with = "CompressionDef")]
    compression: Compression,
}

impl RawMask {
    fn resolve(&self) -> MaskEntry {
        let sigma = self.sigma.unwrap_or(MaskSpec::DEFAULT_SIGMA);
        MaskEntry {
            name: self.name.clone(),
            kind: self.kind,
            size: self.size,
            seed: self.seed,
            sigma,
            sigma_time: self.sigma_time.unwrap_or(sigma),
            density: self.density.unwrap_or(MaskSpec::DEFAULT_DENSITY),
            kernel_tolerance: self
                .kernel_tolerance
                .unwrap_or(MaskSpec::DEFAULT_KERNEL_TOLERANCE),
            encoding: self.encoding,
            compression: self.compression,
        }
    }
}

fn no_compression() -> Compression {
    Compression::None
}

/// Deserialises [`stbn_runtime::Encoding`], which has no serde support of its own.
#[derive(Deserialize)]
#[serde(remote = "Encoding", rename = "Encoding")]
enum EncodingDef {
    Unorm8,
    Unorm16,
    F32,
}

/// Deserialises [`stbn_runtime::Compression`].
#[derive(Deserialize)]
#[serde(remote = "Compression", rename = "Compression")]
enum CompressionDef {
    None,
    Lz4,
    Deflate,
}

/// Strict and reserved keywords of Rust 2024 (a mask name must not be one).
const KEYWORDS: &[&str] = &[
    "abstract", "as", "async", "await", "become", "box", "break", "const", "continue", "crate",
    "do", "dyn", "else", "enum", "extern", "false", "final", "fn", "for", "gen", "if", "impl",
    "in", "let", "loop", "macro", "match", "mod", "move", "mut", "override", "priv", "pub", "ref",
    "return", "self", "Self", "static", "struct", "super", "trait", "true", "try", "type",
    "typeof", "unsafe", "unsized", "use", "virtual", "where", "while", "yield",
];

/// Checks that `name` is an ASCII Rust identifier and not a keyword.
fn check_identifier(name: &str) -> Result<(), String> {
    let mut chars = name.chars();
    let identifier = name != "_"
        && chars
            .next()
            .is_some_and(|c| c == '_' || c.is_ascii_alphabetic())
        && chars.all(|c| c == '_' || c.is_ascii_alphanumeric());
    if !identifier {
        Err(format!(
            "{name:?} is not a Rust identifier: use ASCII letters, digits and `_`, \
             not starting with a digit (the name becomes a static and a file name)"
        ))
    } else if KEYWORDS.contains(&name) {
        Err(format!("{name:?} is a Rust keyword"))
    } else {
        Ok(())
    }
}

/// The manifest field a [`SpecError`] is about, and the message to show there.
fn spec_error_field(error: &SpecError, has_sigma_time: bool) -> (&'static str, String) {
    match error {
        SpecError::AxisOutOfRange { field, value } => {
            let axis = match *field {
                "width" => "width (first element)",
                "height" => "height (second element)",
                _ => "frames (third element)",
            };
            (
                "size",
                format!(
                    "{axis} is {value}; it must be in 1..={}",
                    MaskSpec::MAX_AXIS
                ),
            )
        }
        SpecError::TooLarge { .. } => ("size", error.to_string()),
        SpecError::InvalidSigma { field, value } => (
            if *field == "sigma_z" && has_sigma_time {
                "sigma_time"
            } else {
                "sigma"
            },
            format!("must be finite and > 0 (got {value})"),
        ),
        SpecError::InvalidDensity(value) => {
            ("density", format!("must be in (0, 0.5] (got {value})"))
        }
        SpecError::InvalidTolerance(value) => (
            "kernel_tolerance",
            format!("must be in (0, 1) (got {value})"),
        ),
    }
}

/// The manifest text and what is known about where things are in it.
struct Source<'a> {
    text: &'a str,
    path: &'a Path,
    map: SourceMap,
}

impl Source<'_> {
    /// Where mask `index`'s `field` value starts; the entry's start if the field is not written,
    /// the start of the text if the entry cannot be found.
    fn field_pos(&self, index: usize, field: &str) -> Pos {
        let entry = self.map.masks.get(index);
        entry
            .and_then(|m| m.field(field))
            .map(|f| f.value)
            .or(entry.map(|m| m.start))
            .unwrap_or(Pos {
                offset: 0,
                line: 1,
                col: 1,
            })
    }

    /// An error in a parsed mask's field.
    fn field_error(&self, index: usize, name: &str, field: &str, message: String) -> ManifestError {
        let pos = self.field_pos(index, field);
        ManifestError {
            path: self.path.into(),
            line: pos.line,
            column: pos.col,
            mask_index: Some(index),
            mask_name: Some(name.to_owned()),
            field: Some(field.to_owned()),
            message,
        }
    }

    /// A ron error, completed with the mask and field it is in.
    fn ron_error(&self, error: &SpannedError) -> ManifestError {
        use ron::Error as E;

        // ron may point at the blank before the offending token; step onto the token.
        let start = self.map.next_token(
            self.text,
            self.map
                .offset_of(self.text, error.span.start.line, error.span.start.col),
        );
        let (mut line, mut column, offset) = (start.line, start.col, start.offset);
        let located = self.map.locate(offset);
        let entry = located.and_then(|l| self.map.masks.get(l.mask));
        let mut field_index = located.and_then(|l| l.field);
        let (field, message) = match &error.code {
            E::NoSuchStructField {
                expected, found, ..
            } => (
                Some(found.clone()),
                format!("unknown field; expected one of {}", backticked(expected)),
            ),
            E::MissingStructField { field, .. } => (
                Some((*field).to_owned()),
                "missing; this field has no default".to_owned(),
            ),
            E::DuplicateStructField { field, .. } => {
                (Some((*field).to_owned()), "given more than once".to_owned())
            }
            code => {
                // ron reports a missing comma at the start of the next field: the field that
                // lacks it is the previous one, and the comma belongs right after its value.
                if let (E::ExpectedComma, Some(entry), Some(i)) = (code, entry, field_index) {
                    if i > 0 && entry.fields[i].key.offset == offset {
                        field_index = Some(i - 1);
                        let end = entry.fields[i - 1].value_end;
                        (line, column) = (end.line, end.col);
                    }
                }
                let field = entry
                    .zip(field_index)
                    .map(|(entry, i)| entry.fields[i].name.clone());
                let ron_message = lowercase_first(&code.to_string());
                let message = if (line, column) != (start.line, start.col) {
                    "expected `,` after this field's value".to_owned()
                } else if let (false, Some(variants)) = (
                    matches!(code, E::NoSuchEnumVariant { .. }),
                    field.as_deref().and_then(enum_variants),
                ) {
                    format!("expected one of {variants} ({ron_message})")
                } else {
                    ron_message
                };
                (field, message)
            }
        };
        ManifestError {
            path: self.path.into(),
            line,
            column,
            mask_index: located.map(|l| l.mask),
            mask_name: entry.and_then(|m| m.name.clone()),
            field,
            message,
        }
    }
}

/// The values of the enum-valued field `field`, for messages about malformed values.
fn enum_variants(field: &str) -> Option<&'static str> {
    match field {
        "kind" => Some("`Scalar`, `Blue2D`, `Blue3D`"),
        "encoding" => Some("`Unorm8`, `Unorm16`, `F32`"),
        "compression" => Some("`None`, `Lz4`, `Deflate`"),
        _ => None,
    }
}

/// `` `a`, `b`, `c` ``.
fn backticked(names: &[&str]) -> String {
    names
        .iter()
        .map(|n| format!("`{n}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// ron's messages start with a capital ("Expected integer"); ours continue a sentence. Leaves a
/// first word with further capitals (`NaN`, `RON`) alone.
fn lowercase_first(message: &str) -> String {
    let first_word = message.split_whitespace().next().unwrap_or_default();
    let mut chars = first_word.chars();
    let capitalised =
        chars.next().is_some_and(char::is_uppercase) && !chars.any(char::is_uppercase);
    if capitalised {
        let mut chars = message.chars();
        chars
            .next()
            .into_iter()
            .flat_map(char::to_lowercase)
            .chain(chars)
            .collect()
    } else {
        message.to_owned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A one-mask manifest; `fields` (whole lines) go after `encoding`, from line 9 on.
    fn manifest(fields: &str) -> String {
        let head = r#"(
    masks: [
        (
            name: "a",
            kind: Scalar,
            size: (8, 8, 4),
            seed: 1,
            encoding: Unorm8,
"#;
        format!("{head}{fields}        ),\n    ],\n)\n")
    }

    #[test]
    fn defaults_fill_in() {
        let m = Manifest::parse(&manifest(""), "assets.ron").unwrap();
        let entry = &m.masks()[0];
        assert_eq!(entry.spec(), MaskSpec::new(8, 8, 4, 1));
        assert_eq!(entry.compression, Compression::None);
        assert_eq!(entry.static_name(), "A");
    }

    #[test]
    fn sigma_time_defaults_to_sigma_and_some_is_accepted() {
        let text = manifest("            sigma: Some(2.5),\n            compression: Deflate,\n");
        let m = Manifest::parse(&text, "m.ron").unwrap();
        let spec = m.masks()[0].spec();
        assert_eq!((spec.sigma_xy, spec.sigma_z), (2.5, 2.5));
        assert_eq!(m.masks()[0].compression, Compression::Deflate);
    }

    #[test]
    fn sigma_time_error_names_sigma_time() {
        let text = manifest("            sigma_time: -1.0,\n");
        let e = Manifest::parse(&text, "m.ron").unwrap_err();
        assert_eq!(
            (e.field(), e.line(), e.column()),
            (Some("sigma_time"), 9, 25)
        );
        assert_eq!(
            e.to_string(),
            "m.ron:9:25: mask \"a\", field `sigma_time`: must be finite and > 0 (got -1)"
        );
    }

    #[test]
    fn identifiers() {
        for ok in ["a", "_a", "scalar_64", "A1", "union", "raw"] {
            assert_eq!(check_identifier(ok), Ok(()), "{ok}");
        }
        for bad in [
            "", "_", "1a", "a-b", "a b", "é", "fn", "self", "Self", "gen",
        ] {
            assert!(check_identifier(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn tolerance_and_axis_messages() {
        let e = Manifest::parse(&manifest("            kernel_tolerance: 1.0,\n"), "m.ron")
            .unwrap_err();
        assert_eq!(e.field(), Some("kernel_tolerance"));
        assert_eq!(e.message(), "must be in (0, 1) (got 1)");
        let text = manifest("").replace("(8, 8, 4)", "(8, 70000, 4)");
        let e = Manifest::parse(&text, "m.ron").unwrap_err();
        assert_eq!(e.field(), Some("size"));
        assert_eq!(
            e.message(),
            "height (second element) is 70000; it must be in 1..=65536"
        );
    }

    #[test]
    fn message_casing() {
        assert_eq!(lowercase_first("Expected integer"), "expected integer");
        assert_eq!(lowercase_first("NaN is not"), "NaN is not");
        assert_eq!(
            lowercase_first("Unexpected end of RON"),
            "unexpected end of RON"
        );
        assert_eq!(lowercase_first(""), "");
    }
}
