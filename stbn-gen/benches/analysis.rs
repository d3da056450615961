//! Analysis speed: the figures every `stbn-gen generate` report computes, on 128×128×64 fields.
//!
//! `cargo bench -p stbn-gen --features analysis --bench analysis`
//!
//! `filtered_error` (EA's FAST metric: 256 thresholds, each frame blurred and averaged) is most
//! of a report's time; `filtered_error_vector` adds a half-space selection per threshold and
//! frame. The fields are white noise with an exact histogram per frame (the cost does not depend
//! on the values).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use stbn_gen::analysis::{Field, FilteredErrorOptions, filtered_error, filtered_error_vector};

const W: usize = 128;
const H: usize = 128;
const D: usize = 64;

/// A `W × H × D` field whose frames are seeded permutations of `(i + 0.5) / (W·H)`.
fn white(seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = W * H;
    let mut values = Vec::with_capacity(n * D);
    for _ in 0..D {
        let mut frame: Vec<f64> = (0..n).map(|i| (i as f64 + 0.5) / n as f64).collect();
        frame.shuffle(&mut rng);
        values.extend(frame);
    }
    values
}

fn analysis(c: &mut Criterion) {
    let (a, b) = (white(1), white(2));
    let x = Field::new(W, H, D, &a).unwrap();
    let y = Field::new(W, H, D, &b).unwrap();
    let mut group = c.benchmark_group("analysis_128x128x64");
    group.sample_size(10);
    group.throughput(Throughput::Elements((W * H * D) as u64));
    group.bench_function("filtered_error", |bench| {
        bench.iter(|| filtered_error(&x, FilteredErrorOptions::default()))
    });
    group.bench_function("filtered_error_vector_2d", |bench| {
        bench.iter(|| filtered_error_vector(&[x, y], FilteredErrorOptions::default()).unwrap())
    });
    group.finish();
}

criterion_group!(benches, analysis);
criterion_main!(benches);
