//! Vector generator speed, and its energy against the swap budget.
//!
//! `cargo bench -p stbn-gen --bench vector` times Vec2 and UnitVec3 at 32×32×16 with the default
//! budget. `STBN_BENCH_LARGE=1 cargo bench -p stbn-gen --bench vector -- vector_128` adds the
//! issue's 128×128×64 (tens of seconds per sample).
//!
//! `STBN_VECTOR_CURVE=WxHxD cargo bench -p stbn-gen --bench vector` instead prints, for Vec2 and
//! UnitVec3 at that size, the energy per pixel after 0.5, 1, 2, 4, … 256 swaps per pixel (from one
//! long run's trace; 0.5 from its own run), with the time of the whole run and the low-band power
//! of each component at the end. `STBN_VECTOR_CURVE_MAX` sets the longest budget (default 256).

use std::time::Instant;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use stbn_gen::analysis::{Field, spatial_low_band, temporal_low_band};
use stbn_gen::{SampleSpace, VectorSpec, VectorVolume, generate_vector};

fn spaces() -> [(SampleSpace, bool); 2] {
    [
        (SampleSpace::Vec { dims: 2 }, false),
        (SampleSpace::UnitVec3, true),
    ]
}

fn timing(c: &mut Criterion) {
    if std::env::var_os("STBN_VECTOR_CURVE").is_some() {
        return;
    }
    let mut sizes = vec![(32, 32, 16)];
    if std::env::var_os("STBN_BENCH_LARGE").is_some() {
        sizes.push((128, 128, 64));
    }
    for (w, h, d) in sizes {
        let mut group = c.benchmark_group(format!("vector_{w}"));
        group.sample_size(10);
        for (space, _) in spaces() {
            let spec = VectorSpec::new(w, h, d, 1, space.clone());
            group.throughput(Throughput::Elements(spec.pixels()));
            group.bench_function(format!("{}_{w}x{h}x{d}", space.name()), |b| {
                b.iter(|| generate_vector(&spec).unwrap())
            });
        }
        group.finish();
    }
}

/// Spatial and temporal low-band power of each component (signed components mapped to [0, 1]).
fn bands(volume: &VectorVolume, signed: bool) -> String {
    let (w, h, d) = (
        volume.width() as usize,
        volume.height() as usize,
        volume.depth() as usize,
    );
    (0..volume.dims())
        .map(|c| {
            let values: Vec<f64> = volume
                .values()
                .chunks_exact(volume.dims())
                .map(|v| {
                    let x = f64::from(v[c]);
                    if signed { x * 0.5 + 0.5 } else { x }
                })
                .collect();
            let field = Field::new(w, h, d, &values).unwrap();
            format!(
                "c{c}: spatial {:.4} temporal {:.4}",
                spatial_low_band(&field).unwrap_or(0.0),
                temporal_low_band(&field).unwrap_or(0.0)
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

fn curve(_: &mut Criterion) {
    let Ok(size) = std::env::var("STBN_VECTOR_CURVE") else {
        return;
    };
    let dims: Vec<u32> = size.split('x').map(|s| s.parse().unwrap()).collect();
    let (w, h, d) = (dims[0], dims[1], dims[2]);
    let max: f64 = std::env::var("STBN_VECTOR_CURVE_MAX")
        .map(|s| s.parse().unwrap())
        .unwrap_or(256.0);
    for (space, signed) in spaces() {
        let spec = VectorSpec::new(w, h, d, 1, space.clone());
        let pixels = spec.pixels() as f64;
        let half = generate_vector(&spec.clone().with_swaps_per_pixel(0.5))
            .unwrap()
            .1;
        let start = Instant::now();
        let (volume, trace) = generate_vector(&spec.clone().with_swaps_per_pixel(max)).unwrap();
        let seconds = start.elapsed().as_secs_f64();
        println!(
            "{} {w}x{h}x{d}: {max} swaps/pixel in {seconds:.1} s",
            space.name()
        );
        println!("  swaps/pixel  accepted/pixel  energy/pixel");
        let last = trace.points.last().unwrap().energy;
        let mut rows = vec![half.points[1]];
        let mut budget = 1;
        while budget < trace.points.len() {
            rows.push(trace.points[budget]);
            budget *= 2;
        }
        rows.insert(0, trace.points[0]);
        for p in rows {
            println!(
                "  {:>11.1}  {:>14.3}  {:.6} ({:+.3}% of the final)",
                p.swaps_attempted as f64 / pixels,
                p.swaps_accepted as f64 / pixels,
                p.energy / pixels,
                100.0 * (p.energy - last) / last
            );
        }
        println!("  final: {}", bands(&volume, signed));
    }
}

criterion_group!(benches, timing, curve);
criterion_main!(benches);
