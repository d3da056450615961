//! Sampling throughput on a 128×128×64 mask: per-sample calls vs. frame fills.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use stbn_runtime::{Compression, Encoding, MaskHeader, SampleOffset, Stbn};

const W: u32 = 128;
const H: u32 = 128;
const D: u32 = 64;

/// A 128×128×64 single-channel blob with pseudo-random payload.
fn blob(encoding: Encoding) -> Vec<u8> {
    let header = MaskHeader::new(W, H, D, 1, encoding);
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
    group.bench_function("sample_with_loop", |b| {
        b.iter(|| {
            frame = frame.wrapping_add(1);
            let f = black_box(frame);
            let offset = black_box(SampleOffset {
                x: 77,
                y: -13,
                frame: 5,
            });
            for y in 0..H as i32 {
                for x in 0..W as i32 {
                    out[(y as u32 * W + x as u32) as usize] = mask.sample_with(x, y, f, offset);
                }
            }
            black_box(&out);
        })
    });
    group.bench_function("sample_dim_loop", |b| {
        b.iter(|| {
            frame = frame.wrapping_add(1);
            let f = black_box(frame);
            let dim = black_box(3);
            for y in 0..H as i32 {
                for x in 0..W as i32 {
                    out[(y as u32 * W + x as u32) as usize] = mask.sample_dim(x, y, f, dim);
                }
            }
            black_box(&out);
        })
    });
    group.finish();
}

fn sampling(c: &mut Criterion) {
    bench_encoding(c, "unorm8_128x128", Encoding::Unorm8);
    bench_encoding(c, "unorm16_128x128", Encoding::Unorm16);
    bench_encoding(c, "f32_128x128", Encoding::F32);
}

criterion_group!(benches, sampling);
criterion_main!(benches);
