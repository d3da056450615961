//! Sampling throughput on 128×128×64 masks, one 128×128 frame per iteration, every API beside
//! a plain-loop baseline in the same run.
//!
//! Scalar masks (groups `unorm8_128x128`, `unorm16_128x128`, `f32_128x128`): `sample`,
//! `sample` through an offset view (`offset_sample_loop`: an x/y/frame offset;
//! `dimension_sample_loop`: an R2 dimension offset; `progressive_sample_loop`: the
//! `progressive()` view; `progressive_per_frame_offset_sample_loop`: its offset taken once per
//! frame with `sample_offset_at`, then a plain offset view), `fill_row` (a wrapping row start),
//! `fill_frame`, `offset_fill_frame` (an x/y/frame offset: rows split in two runs),
//! `progressive_fill_frame`, and `plain_loop`: a hand-written loop that decodes the frame's
//! bytes straight from the payload (no wrapping, no header), the floor a general sampler is
//! measured against.
//!
//! Vector masks (groups `vec2_<enc>_1080p`, `vec4_<enc>_1080p`, `unitvec3_oct_<enc>_1080p`,
//! `unitvec3_signed_<enc>_1080p`): one 1920×1080 frame per iteration, the mask tiled over it,
//! row by row into a row buffer: `hand_written` (the voxel index by masks, the bytes decoded with
//! std's `sqrt`), `hand_written_crate_decode` (octahedral only: the same loop calling
//! `octahedral_decode`, the samplers' own numerics), `sample` (`sample_vec2` / `sample_vec3` /
//! `sample_vec4` per pixel), `sample_vector`, `fill_vector_row` (whole rows: one period decoded,
//! then copied), `fill_vector_row_by_width` (a mask width per call: every voxel decoded),
//! `sample` / `fill_vector_row` through an offset view, and `progressive_sample` (`sample`
//! through the `progressive()` view).
//!
//! The progressive benches read frame `(depth + 1) · i` at iteration `i`: every iteration is a
//! new epoch (a new R2 offset, almost never zero) and a new slice; the others read frame `i`.
//!
//! `cargo bench -p stbn-runtime --bench sample -- --warm-up-time 1 --measurement-time 3`
//! (`-- _1080p` for the vector groups alone)

use std::hint::black_box;

use criterion::{BenchmarkGroup, Criterion, Throughput, criterion_group, criterion_main};
use stbn_runtime::glam::{Vec2, Vec3, Vec4};
use stbn_runtime::{
    Compression, Encoding, MaskHeader, OffsetStbn, SampleOffset, Space, Stbn, ValueMap,
    VectorOutput, VectorSample, octahedral_decode,
};

const W: u32 = 128;
const H: u32 = 128;
const D: u32 = 64;

/// A 128×128×64 single-channel blob with pseudo-random payload.
fn blob(encoding: Encoding) -> Vec<u8> {
    random_blob(MaskHeader::new(W, H, D, 1, encoding))
}

/// A 128×128×64 blob described by `header` (any channels, space and value map) with a
/// pseudo-random payload: Unorm elements uniform over their codes, F32 elements in `[0, 1)`.
fn random_blob(header: MaskHeader) -> Vec<u8> {
    let encoding = header.encoding;
    let elements = header.element_count();
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let payload: Vec<u8> = match encoding {
        Encoding::Unorm8 => (0..elements).map(|_| next() as u8).collect(),
        Encoding::Unorm16 => (0..elements)
            .flat_map(|_| (next() as u16).to_le_bytes())
            .collect(),
        Encoding::F32 => (0..elements)
            .flat_map(|_| ((next() >> 40) as f32 / (1u64 << 24) as f32).to_le_bytes())
            .collect(),
    };
    let header = header.with_payload(Compression::None, &payload);
    let mut out = header.to_bytes().to_vec();
    out.extend_from_slice(&payload);
    out
}

fn bench_encoding(c: &mut Criterion, name: &str, encoding: Encoding) {
    let bytes = blob(encoding);
    let mask = Stbn::from_bytes(&bytes).unwrap();
    let mut out = vec![0.0f32; (W * H) as usize];
    let mut group = c.benchmark_group(name);
    group.throughput(Throughput::Elements(u64::from(W * H)));

    let mut frame = 0u32;
    group.bench_function("sample_loop", |b| {
        b.iter(|| {
            frame = frame.wrapping_add(1);
            let f = black_box(frame);
            for y in 0..H as i32 {
                for x in 0..W as i32 {
                    out[(y as u32 * W + x as u32) as usize] = mask.sample(x, y, f);
                }
            }
            black_box(&out);
        })
    });
    group.bench_function("fill_frame", |b| {
        b.iter(|| {
            frame = frame.wrapping_add(1);
            black_box(mask.fill_frame(black_box(frame), &mut out));
            black_box(&out);
        })
    });
    let progressive = mask.progressive();
    // The view is made in the loop, as `offset_sample_loop` makes its own: a view the closure
    // borrows from outside is reloaded from memory on every sample.
    group.bench_function("progressive_sample_loop", |b| {
        b.iter(|| {
            frame = frame.wrapping_add(1);
            let f = black_box(frame.wrapping_mul(D + 1));
            let progressive = black_box(&mask).progressive();
            for y in 0..H as i32 {
                for x in 0..W as i32 {
                    out[(y as u32 * W + x as u32) as usize] = progressive.sample(x, y, f);
                }
            }
            black_box(&out);
        })
    });
    // The progressive view's offset taken once per frame: a plain offset view per frame.
    group.bench_function("progressive_per_frame_offset_sample_loop", |b| {
        b.iter(|| {
            frame = frame.wrapping_add(1);
            let f = black_box(frame.wrapping_mul(D + 1));
            let view = mask.offset(progressive.sample_offset_at(f));
            for y in 0..H as i32 {
                for x in 0..W as i32 {
                    out[(y as u32 * W + x as u32) as usize] = view.sample(x, y, f);
                }
            }
            black_box(&out);
        })
    });
    group.bench_function("offset_fill_frame", |b| {
        b.iter(|| {
            frame = frame.wrapping_add(1);
            let view = mask.offset(black_box(SampleOffset {
                x: 77,
                y: -13,
                frame: 5,
            }));
            black_box(view.fill_frame(black_box(frame), &mut out));
            black_box(&out);
        })
    });
    group.bench_function("progressive_fill_frame", |b| {
        b.iter(|| {
            frame = frame.wrapping_add(1);
            let f = black_box(frame.wrapping_mul(D + 1));
            black_box(progressive.fill_frame(f, &mut out));
            black_box(&out);
        })
    });
    group.bench_function("fill_row_x_offset", |b| {
        b.iter(|| {
            frame = frame.wrapping_add(1);
            let f = black_box(frame);
            for (y, row) in out.chunks_exact_mut(W as usize).enumerate() {
                mask.fill_row(black_box(-37), y as i32, f, row);
            }
            black_box(&out);
        })
    });
    group.bench_function("offset_sample_loop", |b| {
        b.iter(|| {
            frame = frame.wrapping_add(1);
            let f = black_box(frame);
            let view = mask.offset(black_box(SampleOffset {
                x: 77,
                y: -13,
                frame: 5,
            }));
            for y in 0..H as i32 {
                for x in 0..W as i32 {
                    out[(y as u32 * W + x as u32) as usize] = view.sample(x, y, f);
                }
            }
            black_box(&out);
        })
    });
    group.bench_function("plain_loop", |b| {
        b.iter(|| {
            frame = frame.wrapping_add(1);
            let f = black_box(frame) % D;
            let data = mask.data();
            let n = (W * H) as usize;
            match encoding {
                Encoding::Unorm8 => {
                    let bytes = &data[f as usize * n..][..n];
                    for (o, &q) in out.iter_mut().zip(bytes) {
                        *o = (f32::from(q) + 0.5) * (1.0 / 256.0);
                    }
                }
                Encoding::Unorm16 => {
                    let bytes = &data[f as usize * n * 2..][..n * 2];
                    for (o, q) in out.iter_mut().zip(bytes.chunks_exact(2)) {
                        let q = u16::from_le_bytes([q[0], q[1]]);
                        *o = (f32::from(q) + 0.5) * (1.0 / 65536.0);
                    }
                }
                Encoding::F32 => {
                    let bytes = &data[f as usize * n * 4..][..n * 4];
                    for (o, v) in out.iter_mut().zip(bytes.chunks_exact(4)) {
                        *o = f32::from_le_bytes([v[0], v[1], v[2], v[3]]);
                    }
                }
            }
            black_box(&out);
        })
    });
    group.bench_function("dimension_sample_loop", |b| {
        b.iter(|| {
            frame = frame.wrapping_add(1);
            let f = black_box(frame);
            let view = mask.dimension(black_box(3));
            for y in 0..H as i32 {
                for x in 0..W as i32 {
                    out[(y as u32 * W + x as u32) as usize] = view.sample(x, y, f);
                }
            }
            black_box(&out);
        })
    });
    group.finish();
}

/// The stored unit value of element `i` of `data`, decoded as a caller would by hand.
#[inline(always)]
fn unit(data: &[u8], i: usize, encoding: Encoding) -> f32 {
    match encoding {
        Encoding::Unorm8 => (f32::from(data[i]) + 0.5) * (1.0 / 256.0),
        Encoding::Unorm16 => {
            let q = u16::from_le_bytes([data[2 * i], data[2 * i + 1]]);
            (f32::from(q) + 0.5) * (1.0 / 65536.0)
        }
        Encoding::F32 => f32::from_le_bytes([
            data[4 * i],
            data[4 * i + 1],
            data[4 * i + 2],
            data[4 * i + 3],
        ]),
    }
}

/// Width and height of the frame the vector benches fill: 1080p, the mask tiled over it.
const FRAME_W: usize = 1920;
const FRAME_H: usize = 1080;

/// A hand-written octahedral decode with std's `sqrt`: `e` in `[-1, 1]²` to a unit vector.
#[inline(always)]
fn octahedral_by_hand(ex: f32, ey: f32) -> Vec3 {
    let z = 1.0 - ex.abs() - ey.abs();
    let t = (-z).max(0.0);
    let (x, y) = (ex - t.copysign(ex), ey - t.copysign(ey));
    let r = 1.0 / (x * x + y * y + z * z).sqrt();
    Vec3::new(x * r, y * r, z * r)
}

/// One 1080p frame per iteration, row by row into a 1920-value row buffer: `read(x, y, frame,
/// row)` fills `row` for row `y`, then the row is handed to `black_box`.
fn bench_rows<V: Copy>(
    group: &mut BenchmarkGroup<'_, criterion::measurement::WallTime>,
    name: &str,
    zero: V,
    mut read: impl FnMut(i32, u32, &mut [V]),
) {
    let mut frame = 0u32;
    let mut row = vec![zero; FRAME_W];
    group.bench_function(name, |b| {
        b.iter(|| {
            frame = frame.wrapping_add(1);
            let f = black_box(frame);
            for y in 0..FRAME_H as i32 {
                read(y, f, &mut row);
                black_box(&mut row);
            }
        })
    });
}

/// The vector benches of one mask layout (see the module docs) into 1080p rows of `V`:
/// `by_hand` decodes the voxel at an element index, `crate_decode` too (when given) with the
/// crate's public decode.
fn bench_vector_frame<V: Copy + Default + VectorOutput, S: SampleRead<V>>(
    c: &mut Criterion,
    name: &str,
    header: MaskHeader,
    _sample: S,
    by_hand: impl Fn(&[u8], usize) -> V,
    crate_decode: Option<impl Fn(&[u8], usize) -> V>,
) {
    let bytes = random_blob(header);
    let mask = Stbn::from_bytes(&bytes).unwrap();
    let suffix = match header.encoding {
        Encoding::Unorm8 => "unorm8",
        Encoding::Unorm16 => "unorm16",
        Encoding::F32 => "f32",
    };
    let mut group = c.benchmark_group(format!("{name}_{suffix}_1080p"));
    group.throughput(Throughput::Elements((FRAME_W * FRAME_H) as u64));
    group.sample_size(20);
    let data = mask.data();
    let channels = usize::from(header.channels);
    bench_rows(
        &mut group,
        "hand_written",
        V::default(),
        |y, f, row: &mut [V]| hand_written_row(data, channels, y, f, row, &by_hand),
    );
    if let Some(decode) = crate_decode {
        bench_rows(
            &mut group,
            "hand_written_crate_decode",
            V::default(),
            |y, f, row| hand_written_row(data, channels, y, f, row, &decode),
        );
    }
    let plain = OffsetStbn::from(&mask);
    bench_rows(&mut group, "sample", V::default(), |y, f, row: &mut [V]| {
        sample_row::<V, S>(&plain, y, f, row);
    });
    let progressive = mask.progressive();
    bench_rows(
        &mut group,
        "progressive_sample",
        V::default(),
        |y, f, row: &mut [V]| {
            sample_row::<V, S>(&progressive, y, f.wrapping_mul(D + 1), row);
        },
    );
    let zero = mask.sample_vector(0, 0, 0);
    bench_rows(
        &mut group,
        "sample_vector",
        zero,
        |y, f, row: &mut [VectorSample]| {
            for (x, v) in row.iter_mut().enumerate() {
                *v = mask.sample_vector(x as i32, y, f);
            }
        },
    );
    bench_rows(
        &mut group,
        "fill_vector_row",
        V::default(),
        |y, f, row: &mut [V]| {
            mask.fill_vector_row(0, y, f, row);
        },
    );
    // Rows filled a mask width at a time: each call decodes every voxel it writes (a longer
    // row copies its first period), so this is the decode's own speed.
    let width = header.width as usize;
    bench_rows(
        &mut group,
        "fill_vector_row_by_width",
        V::default(),
        |y, f, row: &mut [V]| {
            for (k, part) in row.chunks_mut(width).enumerate() {
                mask.fill_vector_row((k * width) as i32, y, f, part);
            }
        },
    );
    let view = mask.offset(black_box(SampleOffset {
        x: 77,
        y: -13,
        frame: 5,
    }));
    bench_rows(
        &mut group,
        "offset_sample",
        V::default(),
        |y, f, row: &mut [V]| sample_row::<V, S>(&view, y, f, row),
    );
    bench_rows(
        &mut group,
        "offset_fill_vector_row",
        V::default(),
        |y, f, row: &mut [V]| {
            view.fill_vector_row(0, y, f, row);
        },
    );
    group.finish();
}

/// Row `y` of frame `frame` decoded by hand: `by_hand` at each voxel's element index.
///
/// The per-pixel loops are functions of their inputs, as in a renderer that takes the mask and
/// the output by reference, so the compiler sees the same aliasing facts for the hand-written
/// loop and the crate's.
#[inline(never)]
fn hand_written_row<V>(
    data: &[u8],
    channels: usize,
    y: i32,
    frame: u32,
    row: &mut [V],
    by_hand: &impl Fn(&[u8], usize) -> V,
) {
    let base = ((frame % D) * H + (y as u32 % H)) * W;
    for (x, v) in row.iter_mut().enumerate() {
        let voxel = (base + x as u32 % W) as usize * channels;
        *v = by_hand(data, voxel);
    }
}

/// Row `y` of frame `frame` read through `view`, one [`SampleRead::read`] per pixel.
#[inline(never)]
fn sample_row<V, S: SampleRead<V>>(view: &OffsetStbn<'_>, y: i32, frame: u32, row: &mut [V]) {
    for (x, v) in row.iter_mut().enumerate() {
        *v = S::read(view, x as i32, y, frame);
    }
}

/// A per-sample read of `V` from a view, as a type so that the pixel loops inline it exactly as
/// they inline `by_hand` (a closure or function item passed to two loops can stay behind an
/// out-of-line `Fn::call`, and that call would be the bench's overhead, not the crate's).
trait SampleRead<V> {
    fn read(view: &OffsetStbn<'_>, x: i32, y: i32, frame: u32) -> V;
}

/// [`OffsetStbn::sample_vec2`].
struct ReadVec2;
/// [`OffsetStbn::sample_vec3`].
struct ReadVec3;
/// [`OffsetStbn::sample_vec4`].
struct ReadVec4;

impl SampleRead<Vec2> for ReadVec2 {
    #[inline(always)]
    fn read(view: &OffsetStbn<'_>, x: i32, y: i32, frame: u32) -> Vec2 {
        view.sample_vec2(x, y, frame)
    }
}

impl SampleRead<Vec4> for ReadVec4 {
    #[inline(always)]
    fn read(view: &OffsetStbn<'_>, x: i32, y: i32, frame: u32) -> Vec4 {
        view.sample_vec4(x, y, frame)
    }
}

impl SampleRead<Vec3> for ReadVec3 {
    #[inline(always)]
    fn read(view: &OffsetStbn<'_>, x: i32, y: i32, frame: u32) -> Vec3 {
        view.sample_vec3(x, y, frame)
    }
}

fn vector_sampling(c: &mut Criterion) {
    let header = |channels, encoding, space, map| {
        MaskHeader::new(W, H, D, channels, encoding).with_space(space, map, 0.0, 0.0)
    };
    for encoding in [Encoding::Unorm16, Encoding::Unorm8, Encoding::F32] {
        let u = move |data: &[u8], i: usize| unit(data, i, encoding);
        bench_vector_frame(
            c,
            "unitvec3_oct",
            header(2, encoding, Space::UnitVec, ValueMap::Octahedral),
            ReadVec3,
            |d, i| octahedral_by_hand(u(d, i) * 2.0 - 1.0, u(d, i + 1) * 2.0 - 1.0),
            Some(|d: &[u8], i| octahedral_decode(Vec2::new(u(d, i), u(d, i + 1)) * 2.0 - 1.0)),
        );
    }
    for encoding in [Encoding::Unorm8, Encoding::Unorm16, Encoding::F32] {
        let u = move |data: &[u8], i: usize| unit(data, i, encoding);
        bench_vector_frame(
            c,
            "unitvec3_signed",
            header(3, encoding, Space::UnitVec, ValueMap::Signed),
            ReadVec3,
            |d, i| {
                let v = Vec3::new(u(d, i), u(d, i + 1), u(d, i + 2)) * 2.0 - 1.0;
                v * (1.0 / v.dot(v).sqrt())
            },
            None::<fn(&[u8], usize) -> Vec3>,
        );
        bench_vector_frame(
            c,
            "vec2",
            header(2, encoding, Space::Vec, ValueMap::Unit),
            ReadVec2,
            |d, i| Vec2::new(u(d, i), u(d, i + 1)),
            None::<fn(&[u8], usize) -> Vec2>,
        );
        bench_vector_frame(
            c,
            "vec4",
            header(4, encoding, Space::Vec, ValueMap::Unit),
            ReadVec4,
            |d, i| Vec4::new(u(d, i), u(d, i + 1), u(d, i + 2), u(d, i + 3)),
            None::<fn(&[u8], usize) -> Vec4>,
        );
    }
}

fn sampling(c: &mut Criterion) {
    bench_encoding(c, "unorm8_128x128", Encoding::Unorm8);
    bench_encoding(c, "unorm16_128x128", Encoding::Unorm16);
    bench_encoding(c, "f32_128x128", Encoding::F32);
}

criterion_group!(benches, sampling, vector_sampling);
criterion_main!(benches);
