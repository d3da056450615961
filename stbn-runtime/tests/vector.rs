//! Vector sampling: value maps, octahedral directions, normalisation and pdfs of every space.

mod common;

use core::f32::consts::PI;

use common::{Rng, blob};
use glam::{Vec2, Vec3, Vec4};
use stbn_runtime::{
    Encoding, MaskHeader, SampleOffset, Space, Stbn, ValueMap, octahedral_decode, octahedral_encode,
};

/// Quantises `u` in `[0, 1]` to the Unorm8 bin the encoder uses (`floor(u · 256)`, clamped).
fn q8(u: f32) -> u8 {
    (u * 256.0).floor().clamp(0.0, 255.0) as u8
}

/// A `w × h × d` Unorm8 blob whose voxel `i` holds `texel(i)` (one byte per channel).
fn mask(header: MaskHeader, texel: impl Fn(usize) -> Vec<u8>) -> Vec<u8> {
    let voxels = (header.width * header.height * header.depth) as usize;
    let payload: Vec<u8> = (0..voxels).flat_map(texel).collect();
    assert_eq!(payload.len(), header.decoded_len());
    blob(header, &payload)
}

/// Random unit vectors, uniform on the sphere.
fn directions(n: usize, seed: u64) -> Vec<Vec3> {
    let mut rng = Rng(seed);
    (0..n)
        .map(|_| {
            let u = (rng.next_u32() as f32 + 0.5) / 4_294_967_296.0;
            let v = (rng.next_u32() as f32 + 0.5) / 4_294_967_296.0;
            let z = 1.0 - 2.0 * u;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * PI * v;
            Vec3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect()
}

#[test]
fn octahedral_direction_masks_decode_to_unit_vectors_near_the_originals() {
    let (w, h, d) = (8, 4, 3);
    let dirs = directions(w * h * d, 11);
    for encoding in [Encoding::Unorm8, Encoding::Unorm16] {
        let header = MaskHeader::new(w as u32, h as u32, d as u32, 2, encoding).with_space(
            Space::UnitVec,
            ValueMap::Octahedral,
            0.0,
            0.0,
        );
        let payload: Vec<u8> = dirs
            .iter()
            .flat_map(|&n| {
                let e = octahedral_encode(n) * 0.5 + 0.5;
                match encoding {
                    Encoding::Unorm8 => vec![q8(e.x), q8(e.y)],
                    _ => [e.x, e.y]
                        .iter()
                        .flat_map(|&u| ((u * 65536.0).floor().min(65535.0) as u16).to_le_bytes())
                        .collect(),
                }
            })
            .collect();
        let bytes = blob(header, &payload);
        let stbn = Stbn::from_bytes(&bytes).unwrap();
        assert_eq!(stbn.dims(), 3);
        // Octahedral bins are at most ~2.2/bins wide in angle.
        let tolerance = if encoding == Encoding::Unorm8 {
            0.02
        } else {
            1e-4
        };
        for (i, &n) in dirs.iter().enumerate() {
            let (x, y, z) = (i % w, i / w % h, i / (w * h));
            let v = stbn.sample_vec3(x as i32, y as i32, z as u32);
            assert!((v.length() - 1.0).abs() < 1e-6, "not unit: {v}");
            assert!((v - n).length() < tolerance, "{encoding:?} {n} read as {v}");
            let s = stbn.sample_vector(x as i32, y as i32, z as u32);
            assert_eq!(s.pdf, 1.0 / (4.0 * PI));
            assert_eq!(s.value.w, 0.0);
        }
    }
}

#[test]
fn signed_unit_vectors_are_normalised_and_circles_have_their_pdf() {
    let header = MaskHeader::new(5, 3, 2, 2, Encoding::Unorm8).with_space(
        Space::UnitVec,
        ValueMap::Signed,
        0.0,
        0.0,
    );
    let angle = |i: usize| i as f32 * 0.37;
    let bytes = mask(header, |i| {
        let (s, c) = angle(i).sin_cos();
        vec![q8(c * 0.5 + 0.5), q8(s * 0.5 + 0.5)]
    });
    let stbn = Stbn::from_bytes(&bytes).unwrap();
    for i in 0..30 {
        let (x, y, z) = (i % 5, i / 5 % 3, i / 15);
        let v = stbn.sample_vec2(x as i32, y as i32, z as u32);
        assert!((v.length() - 1.0).abs() < 1e-6);
        let (s, c) = angle(i).sin_cos();
        assert!((v - Vec2::new(c, s)).length() < 0.02, "{v}");
        assert_eq!(stbn.sample_pdf(x as i32, y as i32, z as u32), 0.5 / PI);
    }
}

#[test]
fn cosine_hemisphere_pdf_is_z_over_pi_and_uniform_is_constant() {
    let dirs: Vec<Vec3> = directions(4 * 4 * 2, 5)
        .into_iter()
        .map(|n| Vec3::new(n.x, n.y, n.z.abs()))
        .collect();
    for space in [Space::CosineHemisphere, Space::UniformHemisphere] {
        let header = MaskHeader::new(4, 4, 2, 3, Encoding::F32).with_space(
            space,
            ValueMap::Signed,
            0.0,
            0.0,
        );
        let payload: Vec<u8> = dirs
            .iter()
            .flat_map(|n| (*n * 0.5 + 0.5).to_array())
            .flat_map(f32::to_le_bytes)
            .collect();
        let bytes = blob(header, &payload);
        let stbn = Stbn::from_bytes(&bytes).unwrap();
        for (i, n) in dirs.iter().enumerate() {
            let s = stbn.sample_vector((i % 4) as i32, (i / 4 % 4) as i32, (i / 16) as u32);
            assert!((s.value.truncate() - *n).length() < 1e-6);
            let expected = if space == Space::CosineHemisphere {
                s.value.z / PI
            } else {
                0.5 / PI
            };
            assert_eq!(s.pdf, expected);
        }
    }
}

#[test]
fn stored_pdfs_hit_their_range_exactly_and_wrap_like_values() {
    let (pdf_min, pdf_max) = (0.25f32, 7.5f32);
    for encoding in [Encoding::Unorm8, Encoding::Unorm16, Encoding::F32] {
        let header = MaskHeader::new(4, 2, 2, 3, encoding).with_space(
            Space::ImagePoints,
            ValueMap::Unit,
            pdf_min,
            pdf_max,
        );
        // Voxel i: point (i/16, 1 - i/16), normalised pdf t = i / 15.
        let t = |i: usize| i as f32 / 15.0;
        let element = |u: f32, full_range: bool| -> Vec<u8> {
            match (encoding, full_range) {
                (Encoding::Unorm8, false) => vec![q8(u)],
                (Encoding::Unorm8, true) => vec![(u * 255.0).round() as u8],
                (Encoding::Unorm16, false) => ((u * 65536.0).floor() as u16).to_le_bytes().to_vec(),
                (Encoding::Unorm16, true) => ((u * 65535.0).round() as u16).to_le_bytes().to_vec(),
                (Encoding::F32, _) => u.to_le_bytes().to_vec(),
            }
        };
        let payload: Vec<u8> = (0..16)
            .flat_map(|i| {
                let p = i as f32 / 16.0;
                [
                    element(p, false),
                    element(1.0 - p - 1.0 / 32.0, false),
                    element(t(i), true),
                ]
                .concat()
            })
            .collect();
        let bytes = blob(header, &payload);
        let stbn = Stbn::from_bytes(&bytes).unwrap();
        assert_eq!(stbn.dims(), 2);
        assert_eq!(stbn.sample_pdf(0, 0, 0), pdf_min, "{encoding:?}");
        assert_eq!(stbn.sample_pdf(3, 1, 1), pdf_max, "{encoding:?}");
        for i in 0..16 {
            let (x, y, z) = ((i % 4) as i32, (i / 4 % 2) as i32, (i / 8) as u32);
            let s = stbn.sample_vector(x, y, z);
            let pdf = pdf_min + t(i) * (pdf_max - pdf_min);
            assert!((s.pdf - pdf).abs() <= 1e-5 * pdf_max, "{encoding:?} {i}");
            // Not normalised: image points are not unit vectors.
            assert!((s.value.x - i as f32 / 16.0).abs() <= 1.0 / 256.0);
            // Toroidal like every other read.
            let wrapped = stbn.sample_vector(x - 4 * 1000, y + 2 * 77, z + 2);
            assert_eq!(wrapped, s);
            let view = stbn.offset(SampleOffset { x, y, frame: z });
            assert_eq!(view.sample_vector(0, 0, 0), s);
            assert_eq!(view.sample_vec2(0, 0, 0), s.value.truncate().truncate());
            assert_eq!(view.sample_pdf(0, 0, 0), s.pdf);
        }
    }
}

#[test]
fn scalar_masks_read_as_vectors_give_the_scalar_and_pdf_one() {
    let header = MaskHeader::new(3, 3, 3, 1, Encoding::Unorm8);
    let bytes = mask(header, |i| vec![(i * 9) as u8]);
    let stbn = Stbn::from_bytes(&bytes).unwrap();
    for (x, y, f) in [(0, 0, 0), (-1, 5, 7), (i32::MIN, i32::MAX, u32::MAX)] {
        let v = stbn.sample_vec4(x, y, f);
        assert_eq!(v, Vec4::new(stbn.sample(x, y, f), 0.0, 0.0, 0.0));
        assert_eq!(stbn.sample_pdf(x, y, f), 1.0);
    }
}

#[test]
fn signed_vec_masks_have_pdf_two_to_the_minus_n() {
    let header = MaskHeader::new(2, 2, 1, 3, Encoding::Unorm8).with_space(
        Space::Vec,
        ValueMap::Signed,
        0.0,
        0.0,
    );
    let bytes = mask(header, |i| vec![i as u8 * 60, 128, 255]);
    let stbn = Stbn::from_bytes(&bytes).unwrap();
    let s = stbn.sample_vector(1, 0, 0);
    assert_eq!(s.pdf, 0.125);
    // Not normalised: (60 + 0.5)/256·2 - 1, (128.5/256)·2 - 1, (255.5/256)·2 - 1.
    let expected = Vec3::new(60.5 / 128.0 - 1.0, 128.5 / 128.0 - 1.0, 255.5 / 128.0 - 1.0);
    assert!((s.value.truncate() - expected).length() < 1e-6);
}

#[test]
fn octahedral_decode_never_returns_nan_for_any_stored_byte_pair() {
    for a in 0..=255u8 {
        for b in 0..=255u8 {
            let e = Vec2::new(
                (f32::from(a) + 0.5) / 128.0 - 1.0,
                (f32::from(b) + 0.5) / 128.0 - 1.0,
            );
            let n = octahedral_decode(e);
            assert!(n.is_finite() && (n.length() - 1.0).abs() < 1e-6, "{a} {b}");
        }
    }
}

#[test]
fn offset_views_read_vectors_at_the_shifted_position() {
    let mut rng = Rng(21);
    let layouts = [
        (Space::CosineHemisphere, ValueMap::Octahedral, 2, 0.0, 0.0),
        (Space::UnitVec, ValueMap::Signed, 3, 0.0, 0.0),
        (Space::Vec, ValueMap::Unit, 4, 0.0, 0.0),
        (Space::ImagePoints, ValueMap::Unit, 3, 0.25, 8.0),
    ];
    for (space, map, channels, pdf_min, pdf_max) in layouts {
        let header = MaskHeader::new(5, 4, 3, channels, Encoding::Unorm8)
            .with_space(space, map, pdf_min, pdf_max);
        let bytes = blob(header, &rng.bytes(header.decoded_len()));
        // Random, so hemisphere directions may lie below the horizon: unverified.
        let stbn = Stbn::from_bytes_unverified(&bytes).unwrap();
        for (x, y, f) in [(0, 0, 0), (-1, 5, 7), (i32::MIN, i32::MAX, u32::MAX)] {
            let offset = SampleOffset {
                x: i32::MAX,
                y: -9,
                frame: u32::MAX,
            };
            let view = stbn.offset(offset).dimension(3);
            let o = view.sample_offset();
            // The shifted position, wrapped exactly (o is already wrapped into the mask).
            let (sx, sy, sf) = (
                (i64::from(x) + i64::from(o.x)).rem_euclid(5) as i32,
                (i64::from(y) + i64::from(o.y)).rem_euclid(4) as i32,
                ((u64::from(f) + u64::from(o.frame)) % 3) as u32,
            );
            let s = stbn.sample_vector(sx, sy, sf);
            assert_eq!(view.sample_vector(x, y, f), s, "{space:?}");
            assert_eq!(view.sample_vec4(x, y, f), s.value);
            assert_eq!(view.sample_vec3(x, y, f), s.value.truncate());
            assert_eq!(view.sample_vec2(x, y, f), s.value.truncate().truncate());
            assert_eq!(view.sample_pdf(x, y, f), s.pdf);
            assert_eq!(view.sample_vec4(x, y, f), stbn.sample_vec4(sx, sy, sf));
        }
    }
}

/// Every vector layout a header may declare, as (space, value map, channels, pdf range).
const LAYOUTS: [(Space, ValueMap, u8, f32, f32); 20] = [
    (Space::Scalar, ValueMap::Unit, 1, 0.0, 0.0),
    (Space::Scalar, ValueMap::Unit, 2, 0.0, 0.0),
    (Space::Scalar, ValueMap::Unit, 3, 0.0, 0.0),
    (Space::Scalar, ValueMap::Unit, 4, 0.0, 0.0),
    (Space::Vec, ValueMap::Unit, 1, 0.0, 0.0),
    (Space::Vec, ValueMap::Unit, 2, 0.0, 0.0),
    (Space::Vec, ValueMap::Signed, 3, 0.0, 0.0),
    (Space::Vec, ValueMap::Signed, 4, 0.0, 0.0),
    (Space::UnitVec, ValueMap::Signed, 1, 0.0, 0.0),
    (Space::UnitVec, ValueMap::Signed, 2, 0.0, 0.0),
    (Space::UnitVec, ValueMap::Signed, 3, 0.0, 0.0),
    (Space::UnitVec, ValueMap::Octahedral, 2, 0.0, 0.0),
    (Space::UniformHemisphere, ValueMap::Signed, 3, 0.0, 0.0),
    (Space::UniformHemisphere, ValueMap::Octahedral, 2, 0.0, 0.0),
    (Space::CosineHemisphere, ValueMap::Signed, 3, 0.0, 0.0),
    (Space::CosineHemisphere, ValueMap::Octahedral, 2, 0.0, 0.0),
    (Space::ImagePoints, ValueMap::Unit, 3, 0.25, 8.0),
    (Space::Scalar, ValueMap::Signed, 2, 0.0, 0.0),
    (Space::EnvironmentDirections, ValueMap::Signed, 4, 0.5, 3.0),
    (
        Space::EnvironmentDirections,
        ValueMap::Octahedral,
        3,
        0.0,
        1.5,
    ),
];

/// Small masks of every layout, encoding and a power-of-two and an odd shape, with random
/// payloads (F32 elements in `[0, 1)`). Random hemisphere directions fall below the horizon,
/// which `Stbn::from_bytes` refuses: the tests that read them view them with
/// `from_bytes_unverified`, whose arithmetic on stored values is the same.
fn layout_masks() -> Vec<(MaskHeader, Vec<u8>)> {
    let mut rng = Rng(77);
    let mut out = Vec::new();
    for (w, h, d) in [(4, 4, 2), (3, 5, 3)] {
        for (space, map, channels, pdf_min, pdf_max) in LAYOUTS {
            for encoding in [Encoding::Unorm8, Encoding::Unorm16, Encoding::F32] {
                let header = MaskHeader::new(w, h, d, channels, encoding)
                    .with_space(space, map, pdf_min, pdf_max);
                let payload = common::random_payload(&header, &mut rng);
                let bytes = blob(header, &payload);
                out.push((header, bytes));
            }
        }
    }
    out
}

fn bits4(v: Vec4) -> [u32; 4] {
    v.to_array().map(f32::to_bits)
}

/// The bits of one output, as compared between a fill and the per-sample reads.
trait Bits: Copy + stbn_runtime::VectorOutput {
    fn zero() -> Self;
    fn bits(self) -> [u32; 5];
    fn read(view: &stbn_runtime::OffsetStbn<'_>, x: i32, y: i32, frame: u32) -> Self;
}

impl Bits for Vec2 {
    fn zero() -> Self {
        Vec2::splat(-7.0)
    }
    fn bits(self) -> [u32; 5] {
        bits5(self.extend(0.0).extend(0.0), 0.0)
    }
    fn read(view: &stbn_runtime::OffsetStbn<'_>, x: i32, y: i32, frame: u32) -> Self {
        view.sample_vec2(x, y, frame)
    }
}

impl Bits for Vec3 {
    fn zero() -> Self {
        Vec3::splat(-7.0)
    }
    fn bits(self) -> [u32; 5] {
        bits5(self.extend(0.0), 0.0)
    }
    fn read(view: &stbn_runtime::OffsetStbn<'_>, x: i32, y: i32, frame: u32) -> Self {
        view.sample_vec3(x, y, frame)
    }
}

impl Bits for Vec4 {
    fn zero() -> Self {
        Vec4::splat(-7.0)
    }
    fn bits(self) -> [u32; 5] {
        bits5(self, 0.0)
    }
    fn read(view: &stbn_runtime::OffsetStbn<'_>, x: i32, y: i32, frame: u32) -> Self {
        view.sample_vec4(x, y, frame)
    }
}

impl Bits for stbn_runtime::VectorSample {
    fn zero() -> Self {
        stbn_runtime::VectorSample {
            value: Vec4::splat(-7.0),
            pdf: -7.0,
        }
    }
    fn bits(self) -> [u32; 5] {
        bits5(self.value, self.pdf)
    }
    fn read(view: &stbn_runtime::OffsetStbn<'_>, x: i32, y: i32, frame: u32) -> Self {
        view.sample_vector(x, y, frame)
    }
}

fn bits5(v: Vec4, pdf: f32) -> [u32; 5] {
    let [a, b, c, d] = bits4(v);
    [a, b, c, d, pdf.to_bits()]
}

/// Checks `fill_vector_row` and `fill_vector_frame` of `view` against its per-sample reads of
/// `T`, and those against the mask's reads at the wrapped shifted position, bit for bit.
fn check_fills<T: Bits>(stbn: &Stbn<'_>, view: stbn_runtime::OffsetStbn<'_>, what: &str) -> u64 {
    let (w, h, d) = (stbn.width(), stbn.height(), stbn.depth());
    let o = view.sample_offset();
    let wrapped = |x: i64, y: i64, f: u64| {
        (
            (x + i64::from(o.x)).rem_euclid(w.into()) as i32,
            (y + i64::from(o.y)).rem_euclid(h.into()) as i32,
            ((f + u64::from(o.frame)) % u64::from(d)) as u32,
        )
    };
    let base = stbn_runtime::OffsetStbn::from(stbn);
    let mut checked = 0;
    let rows = [
        (0, 0),
        (-1, -1),
        (i32::MIN, i32::MAX),
        (i32::MAX, i32::MIN),
        (7, -12_345),
    ];
    let lens = [0, 1, w as usize, 3 * w as usize + 2];
    for frame in [0, 1, d + 2, u32::MAX] {
        for (x0, y) in rows {
            for len in lens {
                let mut out = vec![T::zero(); len];
                view.fill_vector_row(x0, y, frame, &mut out);
                for (i, v) in out.iter().enumerate() {
                    let (sx, sy, sf) = wrapped(i64::from(x0) + i as i64, y.into(), frame.into());
                    let expected = T::read(&base, sx, sy, sf);
                    assert_eq!(
                        v.bits(),
                        expected.bits(),
                        "{what} row ({x0},{y},{frame}) i {i}"
                    );
                    if let Ok(x) = i32::try_from(i64::from(x0) + i as i64) {
                        assert_eq!(v.bits(), T::read(&view, x, y, frame).bits(), "{what}");
                    }
                    checked += 1;
                }
            }
        }
        let area = (w * h) as usize;
        for len in [0, 1, area - 1, area, area + 5] {
            let mut out = vec![T::zero(); len];
            assert_eq!(view.fill_vector_frame(frame, &mut out), len.min(area));
            for (i, v) in out.iter().enumerate() {
                if i < area {
                    let (x, y) = (i % w as usize, i / w as usize);
                    let (sx, sy, sf) = wrapped(x as i64, y as i64, frame.into());
                    let expected = T::read(&base, sx, sy, sf);
                    assert_eq!(v.bits(), expected.bits(), "{what} frame {frame} i {i}");
                    checked += 1;
                } else {
                    assert_eq!(v.bits(), T::zero().bits(), "tail must be untouched");
                }
            }
        }
    }
    checked
}

#[test]
fn vector_fills_match_per_sample_reads_bit_for_bit() {
    let mut checked = 0;
    for (header, bytes) in layout_masks() {
        let stbn = Stbn::from_bytes_unverified(&bytes).unwrap();
        let offsets = [
            SampleOffset::ZERO,
            SampleOffset {
                x: 0,
                y: 0,
                frame: u32::MAX,
            },
            SampleOffset {
                x: i32::MIN,
                y: i32::MAX,
                frame: 7,
            },
            stbn.dimension(5).sample_offset(),
        ];
        for offset in offsets {
            let view = stbn.offset(offset);
            let what = format!("{header:?} {offset:?}");
            checked += check_fills::<Vec2>(&stbn, view, &what);
            checked += check_fills::<Vec3>(&stbn, view, &what);
            checked += check_fills::<Vec4>(&stbn, view, &what);
            checked += check_fills::<stbn_runtime::VectorSample>(&stbn, view, &what);
        }
        // The mask's own fills are its view at offset zero.
        let mut row = vec![Vec4::ZERO; 2 * header.width as usize + 1];
        let mut via_view = row.clone();
        stbn.fill_vector_row(-3, 9, 4, &mut row);
        stbn.offset(SampleOffset::ZERO)
            .fill_vector_row(-3, 9, 4, &mut via_view);
        assert_eq!(row, via_view);
        let mut frame = vec![stbn_runtime::VectorSample::zero(); 64];
        let mut via_view = frame.clone();
        assert_eq!(
            stbn.fill_vector_frame(u32::MAX, &mut frame),
            stbn.offset(SampleOffset::ZERO)
                .fill_vector_frame(u32::MAX, &mut via_view)
        );
        assert_eq!(frame, via_view);
    }
    assert!(checked > 1_000_000, "{checked}");
}

#[test]
fn vector_reads_decode_every_layout_as_documented() {
    for (header, bytes) in layout_masks() {
        let stbn = Stbn::from_bytes_unverified(&bytes).unwrap();
        let data = &bytes[64..];
        let c = usize::from(header.channels);
        let unit = |i: usize| match header.encoding {
            Encoding::Unorm8 => (f32::from(data[i]) + 0.5) / 256.0,
            Encoding::Unorm16 => {
                (f32::from(u16::from_le_bytes([data[2 * i], data[2 * i + 1]])) + 0.5) / 65536.0
            }
            Encoding::F32 => f32::from_le_bytes(data[4 * i..4 * i + 4].try_into().unwrap()),
        };
        let voxels = (header.width * header.height * header.depth) as usize;
        for v in 0..voxels {
            let (x, y, z) = (
                v % header.width as usize,
                v / header.width as usize % header.height as usize,
                v / (header.width * header.height) as usize,
            );
            let s = stbn.sample_vector(x as i32, y as i32, z as u32);
            let dims = usize::from(header.value_channels());
            let mapped: Vec<f32> = (0..dims)
                .map(|k| header.value_map.apply(unit(v * c + k)))
                .collect();
            let what = format!("{header:?} voxel {v}");
            match header.value_map {
                ValueMap::Octahedral => {
                    let n = octahedral_decode(Vec2::new(mapped[0], mapped[1]));
                    // The samplers share the public decode, bit for bit.
                    assert_eq!(bits4(s.value), bits4(n.extend(0.0)), "{what}");
                }
                _ if header.space.is_unit() => {
                    let len = mapped.iter().map(|m| m * m).sum::<f32>().sqrt();
                    for (k, m) in mapped.iter().enumerate() {
                        assert!((s.value[k] - m / len).abs() < 1e-6, "{what}");
                    }
                    assert!((s.value.length() - 1.0).abs() < 1e-6, "{what}");
                }
                _ => {
                    for (k, m) in mapped.iter().enumerate() {
                        assert_eq!(s.value[k].to_bits(), m.to_bits(), "{what}");
                    }
                }
            }
            for k in stbn.dims()..4 {
                assert_eq!(s.value[usize::from(k)].to_bits(), 0, "{what}");
            }
            assert!(s.pdf.is_finite() && s.pdf >= 0.0, "{what}");
        }
    }
}

/// F32 payload elements a hand-made blob may hold, beside the `[0, 1)` range of real masks:
/// zeros (zero vectors), the bin edges, negatives, infinities and NaNs.
const F32_EDGES: [f32; 10] = [
    0.0,
    -0.0,
    0.5,
    1.0,
    -1.0,
    1e-30,
    f32::INFINITY,
    f32::NEG_INFINITY,
    f32::NAN,
    2.0,
];

#[test]
fn inlined_reads_match_the_dispatched_read_and_the_fills_on_every_voxel() {
    // `sample_vec2/3/4` inline the common plans (on power-of-two masks); `sample_vector` and the
    // fills take the dispatched code. Every voxel of every layout, both shapes, must agree bit
    // for bit, including F32 payloads with zeros, infinities and NaNs.
    let mut masks = layout_masks();
    let mut rng = Rng(99);
    for (w, h, d) in [(4, 4, 2), (3, 5, 3)] {
        for (space, map, channels, pdf_min, pdf_max) in LAYOUTS {
            let header = MaskHeader::new(w, h, d, channels, Encoding::F32)
                .with_space(space, map, pdf_min, pdf_max);
            let payload: Vec<u8> = (0..header.decoded_len() / 4)
                .flat_map(|_| F32_EDGES[rng.next_u32() as usize % F32_EDGES.len()].to_le_bytes())
                .collect();
            masks.push((header, blob(header, &payload)));
        }
    }
    let mut checked = 0;
    for (header, bytes) in masks {
        let stbn = Stbn::from_bytes_unverified(&bytes).unwrap();
        let (w, h, d) = (stbn.width(), stbn.height(), stbn.depth());
        let view = stbn.offset(SampleOffset {
            x: -1,
            y: 3,
            frame: u32::MAX,
        });
        let (mut row2, mut row3, mut row4) = (
            vec![Vec2::ZERO; w as usize],
            vec![Vec3::ZERO; w as usize],
            vec![Vec4::ZERO; w as usize],
        );
        for f in 0..d {
            for y in 0..h as i32 {
                stbn.fill_vector_row(0, y, f, &mut row2);
                stbn.fill_vector_row(0, y, f, &mut row3);
                stbn.fill_vector_row(0, y, f, &mut row4);
                for x in 0..w as i32 {
                    let what = format!("{header:?} ({x},{y},{f})");
                    let v = stbn.sample_vector(x, y, f).value;
                    let i = x as usize;
                    assert_eq!(bits4(stbn.sample_vec4(x, y, f)), bits4(v), "{what}");
                    assert_eq!(bits4(row4[i]), bits4(v), "{what}");
                    let v3 = stbn.sample_vec3(x, y, f);
                    assert_eq!(
                        bits4(v3.extend(0.0)),
                        bits4(v.truncate().extend(0.0)),
                        "{what}"
                    );
                    assert_eq!(bits4(row3[i].extend(0.0)), bits4(v3.extend(0.0)), "{what}");
                    let v2 = stbn.sample_vec2(x, y, f).extend(0.0).extend(0.0);
                    let expected = v.truncate().truncate().extend(0.0).extend(0.0);
                    assert_eq!(bits4(v2), bits4(expected), "{what}");
                    assert_eq!(bits4(row2[i].extend(0.0).extend(0.0)), bits4(v2), "{what}");
                    // The offset view's inlined reads: the mask's at the shifted position.
                    let (sx, sy, sf) = (
                        (x - 1).rem_euclid(w as i32),
                        (y + 3).rem_euclid(h as i32),
                        ((u64::from(f) + u64::from(u32::MAX)) % u64::from(d)) as u32,
                    );
                    let shifted = stbn.sample_vector(sx, sy, sf).value;
                    assert_eq!(bits4(view.sample_vec4(x, y, f)), bits4(shifted), "{what}");
                    let v3 = view.sample_vec3(x, y, f).extend(0.0);
                    assert_eq!(bits4(v3), bits4(shifted.truncate().extend(0.0)), "{what}");
                    let v2 = view.sample_vec2(x, y, f).extend(0.0).extend(0.0);
                    let expected = shifted.truncate().truncate().extend(0.0).extend(0.0);
                    assert_eq!(bits4(v2), bits4(expected), "{what}");
                    checked += 1;
                }
            }
        }
    }
    assert!(checked > 6_000, "{checked}");
}
