//! How masks are stored: the encoding (bytes per pixel against quantisation error, and whether
//! the error moves the quality figures) and the compression (embedded bytes against decode time).

use std::hint::black_box;
use std::time::Instant;

use stbn_build_support::encode::{
    Layout, encode_payload, encode_vector, encode_vector_payload, encode_volume,
};
use stbn_gen::{MaskSpec, Observer, SampleSpace, VectorSpec, VectorVolume, Volume};
use stbn_runtime::{Compression, Encoding, PackedStbn, Stbn};

use super::measure::Quality;
use super::swaps::{first_component, is_signed, spaces};
use super::{Knob, Plan, Section, size_name};
use crate::Result;
use crate::output::{self, Axis, Cell, Chart, Series, SeriesLabelPosition, Style, Table};

const ENCODINGS: [Encoding; 3] = [Encoding::Unorm8, Encoding::Unorm16, Encoding::F32];
const COMPRESSIONS: [Compression; 4] = [
    Compression::None,
    Compression::Lz4,
    Compression::Deflate,
    Compression::Palette,
];

/// A generated mask of either kind.
enum Mask {
    Scalar(Volume),
    Vector {
        space: SampleSpace,
        volume: VectorVolume,
    },
}

impl Mask {
    fn scalar(plan: &Plan, (w, h, d): (u32, u32, u32)) -> Result<Mask> {
        let spec = MaskSpec::new(w, h, d, plan.seed);
        Ok(Mask::Scalar(stbn_gen::generate(
            &spec,
            Observer::default(),
        )?))
    }

    fn vector(plan: &Plan, space: SampleSpace) -> Result<Mask> {
        let (w, h, d) = plan.vector_size;
        let spec = VectorSpec::new(w, h, d, plan.seed, space.clone())
            .with_swaps_per_pixel(plan.vector_budget)
            .with_assignment_passes(0);
        let volume = stbn_gen::generate_vector(&spec, Observer::default())?;
        Ok(Mask::Vector { space, volume })
    }

    fn size(&self) -> (u32, u32, u32) {
        match self {
            Mask::Scalar(v) => (v.width(), v.height(), v.depth()),
            Mask::Vector { volume: v, .. } => (v.width(), v.height(), v.depth()),
        }
    }

    /// The blob in `layout` (ignored for scalar masks).
    fn encode(&self, layout: Layout, encoding: Encoding, compression: Compression) -> Vec<u8> {
        match self {
            Mask::Scalar(volume) => encode_volume(volume, encoding, compression),
            Mask::Vector { volume, .. } => encode_vector(volume, layout, encoding, compression),
        }
    }

    /// The uncompressed payload the blob must decode to.
    fn payload(&self, layout: Layout, encoding: Encoding) -> Vec<u8> {
        match self {
            Mask::Scalar(volume) => encode_payload(volume, encoding),
            Mask::Vector { volume, .. } => encode_vector_payload(volume, layout, encoding).0,
        }
    }
}

/// The quantisation error of one decoded mask and the field its quality is measured on.
struct Decoded {
    max_error: f64,
    rms_error: f64,
    /// Mean of decoded − generated over values or components; `None` for directions.
    mean_error: Option<f64>,
    field: Vec<f64>,
}

/// Reads every voxel of `view` back and compares it with `mask`'s generated values: scalar values
/// and vector components as absolute differences, unit vectors (UnitVec3) as the angle in
/// degrees between the decoded and the generated direction. The field is the decoded value
/// (scalar) or the decoded first component mapped to [0, 1].
fn decode(mask: &Mask, view: &Stbn) -> Decoded {
    let (w, h, d) = mask.size();
    let mut field = Vec::with_capacity((w * h * d) as usize);
    let (mut max, mut sum, mut signed, mut count) = (0.0f64, 0.0f64, 0.0f64, 0usize);
    let mut add = |e: f64| {
        max = max.max(e.abs());
        sum += e * e;
        signed += e;
        count += 1;
    };
    for z in 0..d {
        for y in 0..h {
            for x in 0..w {
                let (xi, yi) = (x as i32, y as i32);
                match mask {
                    Mask::Scalar(volume) => {
                        let v = f64::from(view.sample(xi, yi, z));
                        add(v - volume.value(x, y, z));
                        field.push(v.clamp(0.0, 1.0));
                    }
                    Mask::Vector { space, volume } => {
                        let decoded = view.sample_vector(xi, yi, z).value;
                        let exact = volume.value(x, y, z);
                        if matches!(space, SampleSpace::UnitVec3) {
                            // atan2(|a × b|, a · b): accurate for tiny angles, where acos of
                            // a dot product near 1 would add ~0.02° of f32 rounding noise.
                            let a = [0, 1, 2].map(|c| f64::from(decoded[c]));
                            let b = [0, 1, 2].map(|c| f64::from(exact[c]));
                            let cross = [
                                a[1] * b[2] - a[2] * b[1],
                                a[2] * b[0] - a[0] * b[2],
                                a[0] * b[1] - a[1] * b[0],
                            ];
                            let sine = cross.iter().map(|c| c * c).sum::<f64>().sqrt();
                            let cosine = (0..3).map(|c| a[c] * b[c]).sum::<f64>();
                            add(sine.atan2(cosine).to_degrees());
                        } else {
                            for (c, &v) in exact.iter().enumerate() {
                                add(f64::from(decoded[c]) - f64::from(v));
                            }
                        }
                        let c = f64::from(decoded[0]);
                        let mapped = if is_signed(space) { (c + 1.0) * 0.5 } else { c };
                        field.push(mapped.clamp(0.0, 1.0));
                    }
                }
            }
        }
    }
    let direction = matches!(
        mask,
        Mask::Vector {
            space: SampleSpace::UnitVec3,
            ..
        }
    );
    let count = count.max(1) as f64;
    Decoded {
        max_error: max,
        rms_error: (sum / count).sqrt(),
        mean_error: (!direction).then_some(signed / count),
        field,
    }
}

/// A mask of the encoding knob and the layouts it is stored in.
struct Stored {
    name: String,
    mask: Mask,
    /// `(name, layout)`.
    layouts: Vec<(&'static str, Layout)>,
}

/// The masks of the encoding knob with their stored layouts.
fn encoding_masks(plan: &Plan) -> Result<Vec<Stored>> {
    let mut masks = vec![Stored {
        name: format!("scalar {}", size_name(plan.encoding_scalar)),
        mask: Mask::scalar(plan, plan.encoding_scalar)?,
        layouts: vec![("1 channel", Layout::SCALAR)],
    }];
    for (name, space) in spaces() {
        let layouts = if matches!(space, SampleSpace::UnitVec3) {
            vec![
                ("octahedral, 2 channels", Layout::new(&space, true)),
                ("signed, 3 channels", Layout::new(&space, false)),
            ]
        } else {
            vec![("2 channels", Layout::new(&space, true))]
        };
        masks.push(Stored {
            name: format!("{name} {}", size_name(plan.vector_size)),
            mask: Mask::vector(plan, space)?,
            layouts,
        });
    }
    Ok(masks)
}

/// Unorm8 / Unorm16 / F32 for a scalar mask, Vec2, and UnitVec3 stored octahedral or as three
/// signed channels: bytes per pixel, quantisation error, and the quality figures of the decoded
/// values beside those of the generated ones.
pub fn encoding(plan: &Plan) -> Result<Section> {
    let mut columns = vec![
        ("mask", "mask", false),
        ("layout", "layout", false),
        ("encoding", "encoding", false),
        ("bytes_per_pixel", "bytes per pixel", true),
        ("max_error", "max error", true),
        ("rms_error", "RMS error", true),
        ("mean_error", "mean error (bias)", true),
        ("error_unit", "error unit", false),
    ];
    columns.extend(Quality::COLUMNS);
    columns.push(("mc_step_rmse_8_change_percent", "MC RMSE 8 change, %", true));
    let mut table = Table::new(&columns);
    let mut series = Vec::new();
    let mut findings = Vec::new();
    for Stored {
        name,
        mask,
        layouts,
    } in encoding_masks(plan)?
    {
        let (w, h, d) = mask.size();
        let exact_field = match &mask {
            Mask::Scalar(volume) => volume.values(),
            Mask::Vector { space, volume } => first_component(volume, is_signed(space)),
        };
        let exact = Quality::of_values(w, h, d, &exact_field);
        let unit = match &mask {
            Mask::Vector {
                space: SampleSpace::UnitVec3,
                ..
            } => "degrees",
            _ => "value",
        };
        let mut row = vec![
            Cell::text(name.clone()),
            Cell::text("generated values"),
            Cell::text("exact (f32 / f64)"),
            Cell::missing(),
            Cell::missing(),
            Cell::missing(),
            Cell::missing(),
            Cell::text(unit),
        ];
        row.extend(exact.cells());
        row.push(Cell::fixed(0.0, 2));
        table.push(row);
        for (layout_name, layout) in layouts {
            let mut points = Series {
                name: format!("{name}, {layout_name}"),
                ..Series::default()
            };
            let mut largest_change = (0.0f64, Encoding::F32);
            for encoding in ENCODINGS {
                let blob = mask.encode(layout, encoding, Compression::None);
                let view = Stbn::from_bytes(&blob).map_err(|e| format!("{name}: {e}"))?;
                let decoded = decode(&mask, &view);
                let quality = Quality::of_values(w, h, d, &decoded.field);
                let bytes = usize::from(layout.channels) * encoding.bytes_per_element();
                let change = 100.0 * (quality.mc_step[0] / exact.mc_step[0] - 1.0);
                if change.abs() >= largest_change.0.abs() {
                    largest_change = (change, encoding);
                }
                let mut row = vec![
                    Cell::text(name.clone()),
                    Cell::text(layout_name),
                    Cell::text(format!("{encoding:?}")),
                    Cell::int(bytes as u64),
                    Cell::sig(decoded.max_error, 3),
                    Cell::sig(decoded.rms_error, 3),
                    Cell::opt_sig(decoded.mean_error, 2),
                    Cell::text(unit),
                ];
                row.extend(quality.cells());
                row.push(Cell::fixed(change, 2));
                table.push(row);
                points.points.push((bytes as f64, decoded.rms_error));
                points.labels.push(format!("{encoding:?}"));
                if encoding == Encoding::Unorm8 {
                    findings.push(format!(
                        "{name}, {layout_name}, Unorm8: RMS error {} {unit}, filtered error \
                         {:.5} against {:.5} exact, MC RMSE at 8 samples {:.4} against {:.4}.",
                        output::significant(decoded.rms_error, 3),
                        quality.filtered_last,
                        exact.filtered_last,
                        quality.mc_step[0],
                        exact.mc_step[0],
                    ));
                }
            }
            outln!(
                "  {name}, {layout_name}: largest MC RMSE change {:+.2}% ({:?})",
                largest_change.0,
                largest_change.1
            );
            series.push(points);
        }
    }
    Ok(Section {
        knob: Knob::Encoding,
        title: "4. Encoding".to_owned(),
        method: format!(
            "Each mask is encoded with `stbn_build_support::encode` (no compression), read back \
             voxel by voxel with `stbn_runtime` (`Stbn::sample` for scalar masks, \
             `sample_vector` for vector masks, which applies the value map, the octahedral \
             decode and the normalisation) and compared with the generated values: absolute \
             error of each scalar value or vector component, and for UnitVec3 the angle between \
             the decoded and the generated direction. Unorm values decode to bin midpoints. A \
             vector component is stored in the level that holds it, so it is off by at most \
             half a bin (2⁻⁹ for Unorm8, 2⁻¹⁷ for Unorm16). A scalar value (r + 0.5)/n (rank r \
             of a slice of n pixels) is stored as level ⌊r·2^bits/n⌋: within half a bin where \
             n ≥ 2^bits, but where n < 2^bits (Unorm16 below 256×256 pixels per frame, Unorm8 \
             below 16×16) every value decodes 1/(2n) − 2^−(bits+1) low, which the max, RMS \
             and mean errors show. The \
             quality columns are measured on the decoded values (the first component mapped to \
             [0, 1] for vectors); the first row of each mask is the generated values. Vector \
             masks: {} swaps per pixel and no assignment passes, seed {}. \"MC RMSE 8 \
             change\" compares the decoded mask's Monte Carlo RMSE after 8 samples with the \
             generated one's.",
            plan.vector_budget, plan.seed
        ),
        tables: vec![("encoding".to_owned(), "Encodings.".to_owned(), table)],
        charts: vec![(
            "encoding".to_owned(),
            Chart {
                title: "RMS quantisation error against bytes per pixel".to_owned(),
                x: Axis::log("bytes per pixel"),
                y: Axis::log("RMS error (value units; degrees for UnitVec3)"),
                series,
                legend: SeriesLabelPosition::UpperRight,
                reference: None,
            },
        )],
        findings,
    })
}

/// The median seconds of `work`, run at least 5 times and until the runs total `min_total`
/// seconds (at most 10,000 runs).
fn median_seconds(min_total: f64, mut work: impl FnMut()) -> f64 {
    let mut runs = Vec::new();
    let mut total = 0.0;
    while runs.len() < 5 || (total < min_total && runs.len() < 10_000) {
        let start = Instant::now();
        work();
        let s = start.elapsed().as_secs_f64();
        total += s;
        runs.push(s);
    }
    runs.sort_by(f64::total_cmp);
    runs[runs.len() / 2]
}

/// None / Lz4 / Deflate / Palette for scalar masks in every encoding and vector masks in Unorm8 and
/// Unorm16: embedded bytes, encode time, and the runtime's verify and decode times.
pub fn compression(plan: &Plan) -> Result<Section> {
    let mut table = Table::new(&[
        ("mask", "mask", false),
        ("encoding", "encoding", false),
        ("compression", "compression", false),
        ("decoded_bytes", "decoded bytes", true),
        ("embedded_bytes", "embedded bytes", true),
        ("embedded_percent_of_decoded", "embedded / decoded, %", true),
        ("encode_seconds", "encode ms", true),
        ("verify_seconds", "verify µs", true),
        ("decode_seconds", "decode µs", true),
        ("decode_bytes_per_second", "decode GB/s", true),
    ]);
    let mut masks = Vec::new();
    for &size in &plan.compression_scalars {
        masks.push((
            format!("scalar {}", size_name(size)),
            Mask::scalar(plan, size)?,
            Layout::SCALAR,
            ENCODINGS.to_vec(),
        ));
    }
    for (name, space) in spaces() {
        let layout = Layout::new(&space, true);
        masks.push((
            format!("{name} {}", size_name(plan.vector_size)),
            Mask::vector(plan, space)?,
            layout,
            vec![Encoding::Unorm8, Encoding::Unorm16],
        ));
    }
    let mut series: Vec<Series> = COMPRESSIONS
        .iter()
        .map(|c| Series {
            name: format!("{c:?}"),
            style: Style::Points,
            ..Series::default()
        })
        .collect();
    let mut findings = Vec::new();
    let decode_total = if plan.quick { 0.0 } else { 0.2 };
    for (name, mask, layout, encodings) in &masks {
        for &encoding in encodings {
            let payload = mask.payload(*layout, encoding);
            let mut sizes = Vec::new();
            for (c, compression) in COMPRESSIONS.into_iter().enumerate() {
                let start = Instant::now();
                let blob = mask.encode(*layout, encoding, compression);
                let encode_seconds = start.elapsed().as_secs_f64();
                let packed = PackedStbn::from_bytes(&blob).map_err(|e| format!("{name}: {e}"))?;
                let mut buf = vec![0u8; packed.decoded_len()];
                let decoded = packed
                    .decode_into(&mut buf)
                    .map_err(|e| format!("{name}: {e}"))?;
                if decoded.data() != payload.as_slice() {
                    return Err(
                        format!("{name} {encoding:?} {compression:?}: decode differs").into(),
                    );
                }
                let verify = median_seconds(decode_total, || {
                    black_box(PackedStbn::from_bytes(black_box(&blob)).is_ok());
                });
                let decode = median_seconds(decode_total, || {
                    let packed = PackedStbn::from_bytes_unverified(black_box(&blob))
                        .expect("verified above");
                    black_box(packed.decode_into(&mut buf).is_ok());
                });
                let (raw, embedded) = (payload.len() as u64, blob.len() as u64);
                sizes.push(embedded);
                table.push(vec![
                    Cell::text(name.clone()),
                    Cell::text(format!("{encoding:?}")),
                    Cell::text(format!("{compression:?}")),
                    Cell::int(raw),
                    Cell::int(embedded),
                    Cell::fixed(100.0 * embedded as f64 / raw as f64, 2),
                    Cell {
                        csv: format!("{encode_seconds}"),
                        md: format!("{:.2}", encode_seconds * 1e3),
                    },
                    Cell {
                        csv: format!("{verify}"),
                        md: output::significant(verify * 1e6, 3),
                    },
                    Cell {
                        csv: format!("{decode}"),
                        md: output::significant(decode * 1e6, 3),
                    },
                    Cell::sig(raw as f64 / decode / 1e9, 3),
                ]);
                let percent = 100.0 * embedded as f64 / raw as f64;
                series[c].points.push((percent, raw as f64 / decode / 1e9));
                // Only the masks that shrink get a label (the others sit together near 100%).
                series[c].labels.push(if percent < 99.0 {
                    format!("{name} {encoding:?}")
                } else {
                    String::new()
                });
            }
            findings.push(format!(
                "{name} {encoding:?}: embedded bytes None / Lz4 / Deflate / Palette = \
                 {} / {} / {} / {}.",
                sizes[0], sizes[1], sizes[2], sizes[3]
            ));
        }
    }
    Ok(Section {
        knob: Knob::Compression,
        title: "5. Compression".to_owned(),
        method: format!(
            "Blobs from `stbn_build_support::encode` (Lz4: LZ4 block format; Deflate: raw \
             RFC 1951 at level 9; Palette: the distinct voxels once and a ⌈log2 P⌉-bit index \
             per voxel). **Embedded bytes** is the whole blob (64-byte header + \
             payload): what `include_bytes!` adds to the binary for this mask; a codec that \
             does not shrink the payload is dropped by the encoder, so its blob is the None \
             one. **Encode** is \
             quantisation plus compression, paid once at build time (single run). **Verify** is \
             `PackedStbn::from_bytes` (header, payload CRC-32 and, uncompressed, every stored \
             value), **decode** \
             `PackedStbn::from_bytes_unverified` + `decode_into` a caller buffer, which checks \
             the decoded values (what the \
             embedded statics pay at start-up; uncompressed masks need no decode at all and are \
             sampled in place, the None row is a plain copy), medians of at least 5 runs and \
             {decode_total} s; every decode is checked against the uncompressed payload. Vector masks: {} \
             swaps per pixel, no assignment passes, UnitVec3 octahedral.",
            plan.vector_budget
        ),
        tables: vec![("compression".to_owned(), "Compression.".to_owned(), table)],
        charts: vec![(
            "compression".to_owned(),
            Chart {
                title: "Decode speed against embedded size".to_owned(),
                x: Axis::linear("embedded bytes, % of the decoded payload"),
                y: Axis::log("decode GB/s (decoded bytes per second)"),
                series,
                legend: SeriesLabelPosition::UpperLeft,
                reference: None,
            },
        )],
        findings,
    })
}
