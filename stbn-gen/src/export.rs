//! Grayscale PNG slices: [`write_slices_png`] for viewing and sharing masks, [`read_slices_png`]
//! for analysing masks from anywhere (the [`crate::analysis`] measures take its
//! [`SliceStack::field`]).
//!
//! A mask of depth `d` named `name` is the folder `<name>/` holding `<name>_0.png` …
//! `<name>_{d−1}.png`, one grayscale image per slice, row 0 at the top.
//!
//! Quantisation: a value `v ∈ [0, 1]` is written as the sample `min(⌊v · 2^b⌋, 2^b − 1)` for bit
//! depth `b`, and a sample `s` reads back as the centre of its bucket, `(s + ½) / 2^b`. So a read
//! value is within `2^−(b+1)` (1/512 at 8 bits) of the written one, and writing what was read
//! reproduces the same samples.

use std::collections::BTreeMap;
use std::fmt;
use std::fs;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use crate::MaskSpec;
use crate::analysis::Field;
use crate::file::open_regular_file;

/// Bits per PNG sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PngDepth {
    /// 8-bit samples, 256 levels.
    Eight,
    /// 16-bit samples, 65 536 levels.
    Sixteen,
}

impl PngDepth {
    /// Bits per sample: 8 or 16.
    pub fn bits(self) -> u32 {
        match self {
            PngDepth::Eight => 8,
            PngDepth::Sixteen => 16,
        }
    }

    /// Number of levels, `2^bits`.
    fn levels(self) -> f64 {
        f64::from(1u32 << self.bits())
    }

    fn png(self) -> png::BitDepth {
        match self {
            PngDepth::Eight => png::BitDepth::Eight,
            PngDepth::Sixteen => png::BitDepth::Sixteen,
        }
    }
}

/// A failed PNG write or read. `Display` starts with the file or folder concerned.
#[derive(Debug)]
pub struct ExportError {
    path: PathBuf,
    message: String,
}

impl ExportError {
    fn new(path: &Path, message: impl Into<String>) -> ExportError {
        ExportError {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }

    /// The file or folder the error is about.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl fmt::Display for ExportError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path.display(), self.message)
    }
}

impl std::error::Error for ExportError {}

/// Writes every slice of `field` as `<dir>/<name>/<name>_<z>.png` (grayscale, `depth` bits per
/// sample) and returns the folder `<dir>/<name>`.
///
/// Creates the folders as needed. Slices `<name>_<z>.png` with `z ≥ field.depth()` left in the
/// folder by an earlier, deeper mask are removed, so the folder always reads back as this mask;
/// other files are left alone. `name` must be a plain file name (non-empty, no `/`, `\`, `.` or
/// `..`).
pub fn write_slices_png(
    field: &Field,
    dir: &Path,
    name: &str,
    depth: PngDepth,
) -> Result<PathBuf, ExportError> {
    if name.is_empty() || name == "." || name == ".." || name.contains(['/', '\\', '\0']) {
        return Err(ExportError::new(
            dir,
            format!("{name:?} is not a plain file name for a mask"),
        ));
    }
    let folder = dir.join(name);
    fs::create_dir_all(&folder)
        .map_err(|e| ExportError::new(&folder, format!("cannot create the folder: {e}")))?;
    for path in list_pngs(&folder)? {
        if slice_name(&path).is_some_and(|(prefix, z)| prefix == name && z >= field.depth()) {
            fs::remove_file(&path)
                .map_err(|e| ExportError::new(&path, format!("cannot remove: {e}")))?;
        }
    }
    let (width, height) = (field.width(), field.height());
    let too_large = || ExportError::new(&folder, format!("{width}x{height} is too large for PNG"));
    let png_width = u32::try_from(width).map_err(|_| too_large())?;
    let png_height = u32::try_from(height).map_err(|_| too_large())?;
    let max = depth.levels() - 1.0;
    for z in 0..field.depth() {
        let path = folder.join(format!("{name}_{z}.png"));
        let samples = field
            .slice(z)
            .iter()
            .map(|&v| (v * depth.levels()).floor().min(max) as u16);
        let data: Vec<u8> = match depth {
            PngDepth::Eight => samples.map(|s| s as u8).collect(),
            PngDepth::Sixteen => samples.flat_map(u16::to_be_bytes).collect(),
        };
        let write_error =
            |e: &dyn fmt::Display| ExportError::new(&path, format!("cannot write: {e}"));
        // Encoded in memory and written with one call whose every error is reported (a buffered
        // file would drop the error of its last flush, leaving a short file on a full disk).
        let mut encoded = Vec::new();
        let mut encoder = png::Encoder::new(&mut encoded, png_width, png_height);
        encoder.set_color(png::ColorType::Grayscale);
        encoder.set_depth(depth.png());
        let mut writer = encoder.write_header().map_err(|e| write_error(&e))?;
        writer
            .write_image_data(&data)
            .map_err(|e| write_error(&e))?;
        writer.finish().map_err(|e| write_error(&e))?;
        fs::write(&path, encoded).map_err(|e| write_error(&e))?;
    }
    Ok(folder)
}

/// A mask read from PNG slices by [`read_slices_png`].
#[derive(Clone, Debug, PartialEq)]
pub struct SliceStack {
    name: String,
    width: usize,
    height: usize,
    depth: usize,
    bit_depth: PngDepth,
    values: Vec<f64>,
    colour_slice: Option<usize>,
    constant_slices: usize,
}

impl SliceStack {
    /// The first slice whose green or blue channel differs from its red one somewhere: only red
    /// is read, so such a mask is not what was analysed. `None` for gray images and colour images
    /// that repeat one value in every channel.
    pub fn colour_slice(&self) -> Option<usize> {
        self.colour_slice
    }

    /// How many slices hold a single value in every pixel (a constant slice measures as perfectly
    /// uniform and says nothing about the mask).
    pub fn constant_slices(&self) -> usize {
        self.constant_slices
    }

    /// The `<name>` of the `<name>_<z>.png` files.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Bits per sample of the files (after expanding palettes and sub-byte depths to 8 bits).
    pub fn bit_depth(&self) -> PngDepth {
        self.bit_depth
    }

    /// The values, `width × height × depth`, each `(sample + ½) / 2^bits` in `(0, 1)`.
    pub fn field(&self) -> Field<'_> {
        Field::new(self.width, self.height, self.depth, &self.values)
            .expect("read_slices_png checks the shape, and sample centres lie in (0, 1)")
    }
}

/// Reads the folder `dir` of slices `<name>_<z>.png`, sorted by `z` numerically.
///
/// Files not ending in `.png` (any case) are ignored. Every PNG must be named `<name>_<z>` with
/// one common `<name>` and decimal `z`, the `z` must be consecutive (any start; `_0` … is what
/// [`write_slices_png`] writes), and every slice must have the same size and bit depth. Grayscale,
/// gray-alpha, RGB, RGBA and palette images are accepted; the value is the gray (or red) channel —
/// scalar masks distributed as colour images repeat the value in every channel
/// ([`SliceStack::colour_slice`] finds those that do not). Errors name the offending file (or the
/// folder, for a missing slice).
///
/// Memory is bounded before it is allocated: a slice whose header declares more than
/// [`MaskSpec::MAX_SLICE_PIXELS`] pixels (at most 128 MiB decoded, 16-bit RGBA) is refused before
/// its pixels are decoded, and so is a folder whose slices hold more than
/// [`MaskSpec::MAX_PIXELS`] pixels in all (512 MiB of values). Only regular files are read
/// (as by [`read_regular_file`](crate::file::read_regular_file)).
pub fn read_slices_png(dir: &Path) -> Result<SliceStack, ExportError> {
    let mut slices = Vec::new();
    for path in list_pngs(dir)? {
        let Some((prefix, z)) = slice_name(&path) else {
            return Err(ExportError::new(
                &path,
                "is not named `<name>_<z>.png` with a decimal slice index z",
            ));
        };
        slices.push(SliceFile { path, prefix, z });
    }
    slices.sort_by(|a, b| (a.z, &a.path).cmp(&(b.z, &b.path)));
    // The mask is the prefix most slices share (ties: the first name); any other is a stranger.
    let mut counts = BTreeMap::new();
    for slice in &slices {
        *counts.entry(slice.prefix.as_str()).or_insert(0usize) += 1;
    }
    let Some((name, count)) = counts.iter().rev().max_by_key(|&(_, &count)| count) else {
        return Err(ExportError::new(dir, "holds no `<name>_<z>.png` slices"));
    };
    if let Some(stranger) = slices.iter().find(|slice| slice.prefix != *name) {
        return Err(ExportError::new(
            &stranger.path,
            format!(
                "is not a slice of `{name}`, whose {count} slices the same folder holds; \
                 one mask per folder"
            ),
        ));
    }
    let name = name.to_string();
    for pair in slices.windows(2) {
        if pair[1].z == pair[0].z {
            return Err(ExportError::new(
                &pair[1].path,
                format!("is slice {} again ({})", pair[0].z, pair[0].path.display()),
            ));
        }
        if pair[1].z != pair[0].z + 1 {
            return Err(ExportError::new(
                dir,
                format!(
                    "slice {} of `{name}` is missing (the next one is {})",
                    pair[0].z + 1,
                    pair[1].path.display()
                ),
            ));
        }
    }

    let mut values = Vec::new();
    let mut shape = None;
    let (mut colour_slice, mut constant_slices) = (None, 0);
    // Checked against each slice's header before its pixels are decoded.
    let within_limit = |width: u32, height: u32| {
        let pixels = slices.len() as u64 * u64::from(width) * u64::from(height);
        if pixels > MaskSpec::MAX_PIXELS {
            return Err(ExportError::new(
                dir,
                format!(
                    "holds {} slices of {width}x{height}: {pixels} pixels, over the limit of {} \
                     pixels a mask may have",
                    slices.len(),
                    MaskSpec::MAX_PIXELS
                ),
            ));
        }
        Ok(())
    };
    for (z, slice) in slices.iter().enumerate() {
        let image = decode(&slice.path, &within_limit)?;
        let this = (image.width, image.height, image.depth);
        if image.colour {
            colour_slice = colour_slice.or(Some(z));
        }
        constant_slices += usize::from(image.constant);
        match shape {
            None => {
                values.reserve_exact(slices.len() * image.width * image.height);
                shape = Some(this);
            }
            Some(expected) if expected != this => {
                let (w, h, b) = expected;
                return Err(ExportError::new(
                    &slice.path,
                    format!(
                        "is {}x{} at {} bits, but {} is {w}x{h} at {} bits",
                        this.0,
                        this.1,
                        this.2.bits(),
                        slices[0].path.display(),
                        b.bits()
                    ),
                ));
            }
            Some(_) => {}
        }
        values.extend(image.values);
    }
    let (width, height, bit_depth) = shape.expect("there is at least one slice");
    Ok(SliceStack {
        name,
        width,
        height,
        depth: slices.len(),
        bit_depth,
        values,
        colour_slice,
        constant_slices,
    })
}

/// A file named `<prefix>_<z>.png`.
struct SliceFile {
    path: PathBuf,
    prefix: String,
    z: usize,
}

/// Every file of `dir` whose name ends in `.png` (any case).
fn list_pngs(dir: &Path) -> Result<Vec<PathBuf>, ExportError> {
    let list_error = |e: std::io::Error| ExportError::new(dir, format!("cannot list: {e}"));
    let mut pngs = Vec::new();
    for entry in fs::read_dir(dir).map_err(list_error)? {
        let path = entry.map_err(list_error)?.path();
        if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("png"))
        {
            pngs.push(path);
        }
    }
    Ok(pngs)
}

/// `(name, z)` of a file named `<name>_<z>.png` with decimal `z`.
fn slice_name(path: &Path) -> Option<(String, usize)> {
    let (prefix, z) = path.file_stem()?.to_str()?.rsplit_once('_')?;
    if z.is_empty() || !z.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    Some((prefix.to_owned(), z.parse().ok()?))
}

/// One decoded slice.
struct Image {
    width: usize,
    height: usize,
    depth: PngDepth,
    values: Vec<f64>,
    /// Green or blue differ from red somewhere.
    colour: bool,
    /// Every value is the same.
    constant: bool,
}

/// Decodes the slice at `path`; `within_limit(width, height)` may refuse its declared size before
/// the pixels are decoded.
fn decode(
    path: &Path,
    within_limit: &dyn Fn(u32, u32) -> Result<(), ExportError>,
) -> Result<Image, ExportError> {
    let read_error = |e: &dyn fmt::Display| ExportError::new(path, format!("cannot read: {e}"));
    let file = open_regular_file(path).map_err(|e| read_error(&e))?;
    let mut decoder = png::Decoder::new(BufReader::new(file));
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().map_err(|e| read_error(&e))?;
    let (declared_width, declared_height) = reader.info().size();
    let declared = u64::from(declared_width) * u64::from(declared_height);
    if declared > MaskSpec::MAX_SLICE_PIXELS {
        return Err(ExportError::new(
            path,
            format!(
                "declares {declared_width}x{declared_height} pixels, over the limit of {} pixels \
                 per slice",
                MaskSpec::MAX_SLICE_PIXELS
            ),
        ));
    }
    within_limit(declared_width, declared_height)?;
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| read_error(&"the image does not fit in memory"))?;
    let mut buffer = vec![0; size];
    let info = reader.next_frame(&mut buffer).map_err(|e| read_error(&e))?;
    let channels = info.color_type.samples();
    let (width, height) = (info.width as usize, info.height as usize);
    let depth = match info.bit_depth {
        png::BitDepth::Sixteen => PngDepth::Sixteen,
        // EXPAND widens 1, 2 and 4 bits to 8.
        _ => PngDepth::Eight,
    };
    let bytes = depth.bits() as usize / 8;
    let mut values = Vec::with_capacity(width * height);
    let mut colour = false;
    for row in buffer.chunks_exact(info.line_size).take(height) {
        for pixel in row.chunks_exact(channels * bytes).take(width) {
            // Channel `c`'s sample (big-endian at 16 bits).
            let sample = |c: usize| match depth {
                PngDepth::Eight => u16::from(pixel[c]),
                PngDepth::Sixteen => u16::from_be_bytes([pixel[2 * c], pixel[2 * c + 1]]),
            };
            // RGB and RGBA: the colour channels are 1 and 2 (gray + alpha has no colour).
            colour |= channels >= 3 && (sample(1) != sample(0) || sample(2) != sample(0));
            values.push((f64::from(sample(0)) + 0.5) / depth.levels());
        }
    }
    let constant = values.windows(2).all(|pair| pair[0] == pair[1]);
    Ok(Image {
        width,
        height,
        depth,
        values,
        colour,
        constant,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{MaskSpec, generate};

    /// `(z · 7 + i) mod 64`-ish values, distinct per slice, in `(0, 1)`.
    fn ramp(width: usize, height: usize, depth: usize) -> Vec<f64> {
        (0..width * height * depth)
            .map(|i| ((i * 37 + i / (width * height) * 11) % 1000) as f64 / 1000.0)
            .collect()
    }

    fn write(dir: &Path, name: &str, w: usize, h: usize, d: usize, depth: PngDepth) -> PathBuf {
        let values = ramp(w, h, d);
        write_slices_png(&Field::new(w, h, d, &values).unwrap(), dir, name, depth).unwrap()
    }

    #[test]
    fn quantisation_follows_the_documented_formula() {
        let dir = tempfile::tempdir().unwrap();
        let values = [0.0, 0.5 / 256.0, 1.0 / 256.0, 0.999, 1.0, 0.25];
        let field = Field::new(3, 2, 1, &values).unwrap();
        let folder = write_slices_png(&field, dir.path(), "q", PngDepth::Eight).unwrap();
        assert_eq!(folder, dir.path().join("q"));
        assert!(folder.join("q_0.png").is_file());
        let read = read_slices_png(&folder).unwrap();
        let samples: Vec<f64> = read
            .field()
            .values()
            .iter()
            .map(|v| v * 256.0 - 0.5)
            .collect();
        assert_eq!(samples, [0.0, 0.0, 1.0, 255.0, 255.0, 64.0]);
    }

    #[test]
    fn a_volume_round_trips_exactly_at_8_bits() {
        // 256 pixels per slice: value (rank + ½) / 256 is exactly a sample centre.
        let volume = generate(&MaskSpec::new(16, 16, 12, 3), crate::Observer::default()).unwrap();
        let values = volume.values();
        let field = Field::new(16, 16, 12, &values).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let folder = write_slices_png(&field, dir.path(), "mask", PngDepth::Eight).unwrap();
        let read = read_slices_png(&folder).unwrap();
        assert_eq!(read.name(), "mask");
        assert_eq!(read.bit_depth(), PngDepth::Eight);
        // Slices 10 and 11 must come after 9, not after 1.
        assert_eq!(read.field(), field);
    }

    #[test]
    fn sixteen_bits_round_trip_within_half_a_level_and_rewrite_identically() {
        let (w, h, d) = (9, 5, 3);
        let values = ramp(w, h, d);
        let field = Field::new(w, h, d, &values).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let folder = write_slices_png(&field, dir.path(), "a", PngDepth::Sixteen).unwrap();
        let read = read_slices_png(&folder).unwrap();
        assert_eq!(read.bit_depth(), PngDepth::Sixteen);
        let back = read.field();
        assert_eq!((back.width(), back.height(), back.depth()), (w, h, d));
        for (a, b) in values.iter().zip(back.values()) {
            assert!((a - b).abs() <= 0.5 / 65536.0, "{a} vs {b}");
        }
        let again =
            write_slices_png(&back, &dir.path().join("again"), "a", PngDepth::Sixteen).unwrap();
        for z in 0..d {
            let file = format!("a_{z}.png");
            assert_eq!(
                fs::read(folder.join(&file)).unwrap(),
                fs::read(again.join(&file)).unwrap()
            );
        }
    }

    #[test]
    fn rewriting_a_shallower_mask_removes_stale_slices() {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "m", 4, 4, 5, PngDepth::Eight);
        for kept in ["notes.txt", "preview.png", "other_7.png"] {
            fs::write(dir.path().join("m").join(kept), "kept").unwrap();
        }
        let folder = write(dir.path(), "m", 4, 4, 2, PngDepth::Eight);
        let mut names: Vec<_> = fs::read_dir(&folder)
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        names.sort();
        assert_eq!(
            names,
            [
                "m_0.png",
                "m_1.png",
                "notes.txt",
                "other_7.png",
                "preview.png"
            ]
        );
    }

    #[test]
    fn reads_the_red_channel_of_colour_images() {
        let dir = tempfile::tempdir().unwrap();
        let file = fs::File::create(dir.path().join("rgb_0.png")).unwrap();
        let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), 2, 1);
        encoder.set_color(png::ColorType::Rgba);
        let mut writer = encoder.write_header().unwrap();
        writer
            .write_image_data(&[10, 99, 99, 255, 200, 0, 0, 255])
            .unwrap();
        writer.finish().unwrap();
        let read = read_slices_png(dir.path()).unwrap();
        assert_eq!(read.field().values(), [10.5 / 256.0, 200.5 / 256.0]);
        assert_eq!(read.colour_slice(), Some(0));
        assert_eq!(read.constant_slices(), 0);
    }

    #[test]
    fn gray_slices_have_no_colour_and_constant_slices_are_counted() {
        let dir = tempfile::tempdir().unwrap();
        let values = [0.5; 8];
        let field = Field::new(2, 2, 2, &values).unwrap();
        let folder = write_slices_png(&field, dir.path(), "flat", PngDepth::Eight).unwrap();
        let read = read_slices_png(&folder).unwrap();
        assert_eq!((read.colour_slice(), read.constant_slices()), (None, 2));
        let folder = write(dir.path(), "ramp", 4, 4, 3, PngDepth::Sixteen);
        let read = read_slices_png(&folder).unwrap();
        assert_eq!((read.colour_slice(), read.constant_slices()), (None, 0));
    }

    /// A PNG of `width × height` RGBA16 whose header is valid and whose image data is an empty
    /// zlib stream: a few dozen bytes that claim gigabytes.
    fn header_only_png(width: u32, height: u32) -> Vec<u8> {
        let mut ihdr = width.to_be_bytes().to_vec();
        ihdr.extend(height.to_be_bytes());
        ihdr.extend([16, 6, 0, 0, 0]);
        let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
        for (kind, data) in [
            (b"IHDR", ihdr),
            (b"IDAT", vec![0x78, 0x9c, 0x03, 0, 0, 0, 0, 1]),
            (b"IEND", Vec::new()),
        ] {
            let mut chunk = kind.to_vec();
            chunk.extend(&data);
            png.extend((data.len() as u32).to_be_bytes());
            png.extend(&chunk);
            png.extend(crc32(&chunk).to_be_bytes());
        }
        png
    }

    /// CRC-32 (ISO-HDLC) as PNG chunks use it.
    fn crc32(bytes: &[u8]) -> u32 {
        let mut crc = !0u32;
        for &b in bytes {
            crc ^= u32::from(b);
            for _ in 0..8 {
                crc = if crc & 1 == 1 {
                    (crc >> 1) ^ 0xEDB8_8320
                } else {
                    crc >> 1
                };
            }
        }
        !crc
    }

    #[test]
    fn a_header_declaring_a_huge_slice_is_refused_before_decoding() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("huge_0.png");
        fs::write(&path, header_only_png(65535, 65535)).unwrap();
        assert!(fs::metadata(&path).unwrap().len() < 100);
        let message = read_slices_png(dir.path()).unwrap_err().to_string();
        assert!(
            message.contains("huge_0.png: declares 65535x65535 pixels, over the limit of 16777216"),
            "{message}"
        );
        // Within the slice limit, but more slices than a mask may hold in all.
        let dir = tempfile::tempdir().unwrap();
        for z in 0..5 {
            fs::write(
                dir.path().join(format!("tall_{z}.png")),
                header_only_png(4096, 4096),
            )
            .unwrap();
        }
        let message = read_slices_png(dir.path()).unwrap_err().to_string();
        assert!(message.contains("holds 5 slices of 4096x4096"), "{message}");
    }

    #[cfg(unix)]
    #[test]
    fn only_regular_files_are_read() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe_0.png");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        assert!(made.unwrap().success());
        let message = read_slices_png(dir.path()).unwrap_err().to_string();
        assert!(message.contains("pipe_0.png"), "{message}");
        assert!(message.contains("not a regular file"), "{message}");
    }

    /// The error of reading `dir` after `damage`, checked to name `culprit`.
    fn read_error(damage: impl FnOnce(&Path), culprit: &str) -> String {
        let dir = tempfile::tempdir().unwrap();
        let folder = write(dir.path(), "m", 4, 3, 4, PngDepth::Eight);
        damage(&folder);
        let error = read_slices_png(&folder).unwrap_err();
        let message = error.to_string();
        assert!(
            message.contains(culprit),
            "{message:?} does not name {culprit:?}"
        );
        assert!(error.path().ends_with(culprit));
        message
    }

    #[test]
    fn read_errors_name_the_file() {
        let message = read_error(|f| fs::remove_file(f.join("m_1.png")).unwrap(), "m");
        assert!(message.contains("slice 1 of `m` is missing"), "{message}");
        read_error(|f| fs::write(f.join("notes.png"), "").unwrap(), "notes.png");
        read_error(|f| fs::write(f.join("m_x.png"), "").unwrap(), "m_x.png");
        read_error(
            |f| fs::write(f.join("m_2.png"), "not a png").unwrap(),
            "m_2.png",
        );
        let message = read_error(
            |f| {
                fs::copy(f.join("m_2.png"), f.join("m_02.png"))
                    .map(drop)
                    .unwrap()
            },
            "m_2.png",
        );
        assert!(message.contains("again"), "{message}");
        read_error(
            |f| {
                let values = ramp(3, 4, 1);
                let field = Field::new(3, 4, 1, &values).unwrap();
                let other = write_slices_png(&field, f, "m", PngDepth::Eight).unwrap();
                fs::rename(other.join("m_0.png"), f.join("m_4.png")).unwrap();
            },
            "m_4.png",
        );
        read_error(
            |f| {
                let folder = write(f, "n", 4, 3, 1, PngDepth::Eight);
                fs::rename(folder.join("n_0.png"), f.join("n_0.png")).unwrap();
            },
            "n_0.png",
        );
        let empty = tempfile::tempdir().unwrap();
        let message = read_slices_png(empty.path()).unwrap_err().to_string();
        assert!(message.contains("no `<name>_<z>.png` slices"), "{message}");
        let missing = empty.path().join("absent");
        assert!(
            read_slices_png(&missing)
                .unwrap_err()
                .to_string()
                .contains("absent")
        );
    }

    #[test]
    fn mixed_bit_depths_are_rejected() {
        let dir = tempfile::tempdir().unwrap();
        let folder = write(dir.path(), "m", 4, 3, 2, PngDepth::Eight);
        let deep = write(&dir.path().join("deep"), "m", 4, 3, 2, PngDepth::Sixteen);
        fs::rename(deep.join("m_1.png"), folder.join("m_1.png")).unwrap();
        let message = read_slices_png(&folder).unwrap_err().to_string();
        assert!(message.contains("m_1.png: is 4x3 at 16 bits"), "{message}");
    }

    #[test]
    fn writer_rejects_names_that_are_paths() {
        let dir = tempfile::tempdir().unwrap();
        let values = [0.5];
        let field = Field::new(1, 1, 1, &values).unwrap();
        for name in ["", ".", "..", "a/b", "a\\b"] {
            let error = write_slices_png(&field, dir.path(), name, PngDepth::Eight).unwrap_err();
            assert!(
                error.to_string().contains("not a plain file name"),
                "{error}"
            );
        }
    }
}
