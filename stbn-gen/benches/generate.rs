//! Generator speed: scalar STBN at the sizes BENCHMARKS.md reports.
//!
//! `cargo bench -p stbn-gen --bench generate`
//! (set `STBN_BENCH_LARGE=1` to add 256×256×128, about 15 s per sample on the 2-core VM).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use stbn_gen::{EnergyTopology, MaskSpec, Observer, generate};

fn scalar(c: &mut Criterion) {
    let mut sizes = vec![(64, 64, 32), (128, 128, 64)];
    if std::env::var_os("STBN_BENCH_LARGE").is_some() {
        sizes.push((256, 256, 128));
    }
    let mut group = c.benchmark_group("scalar_stbn");
    group.sample_size(10);
    for (w, h, d) in sizes {
        let spec = MaskSpec::new(w, h, d, 1);
        group.throughput(Throughput::Elements(spec.pixels()));
        group.bench_function(format!("{w}x{h}x{d}"), |b| {
            b.iter(|| generate(&spec, Observer::default()).unwrap())
        });
    }
    group.finish();

    // The baselines share the engine; Independent2D has the smaller footprint, Isotropic3D the
    // much larger one.
    let mut group = c.benchmark_group("topology_64x64x32");
    group.sample_size(10);
    for topology in [EnergyTopology::Independent2D, EnergyTopology::Isotropic3D] {
        let spec = MaskSpec::new(64, 64, 32, 1).with_topology(topology);
        group.bench_function(topology.name(), |b| {
            b.iter(|| generate(&spec, Observer::default()).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, scalar);
criterion_main!(benches);
