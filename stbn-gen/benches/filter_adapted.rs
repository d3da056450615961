//! Filter-adapted generator speed, and its filtered error against the budget.
//!
//! `cargo bench -p stbn-gen --bench filter_adapted` times 32×32×16 with the default spec (EA's
//! Gaussian σ 1.3435 × EMA α 0.1 product filter, distance kernel) and with the product kernel.
//!
//! `STBN_FILTER_ADAPTED_128=1 cargo bench -p stbn-gen --bench filter_adapted` instead runs the
//! issue's target, 128×128×64 with the default spec, and prints the wall time (with the load
//! average), the last frame's filtered error ([`filtered_error`], default options) and, for
//! comparison, STBN's (the `Scalar` void-and-cluster mask of the same seed).
//! `STBN_FILTER_ADAPTED_BUDGETS=16,32,64` sets the budgets (swaps per pixel) it runs, one
//! generation each (default: the spec's default); `STBN_FILTER_ADAPTED_SEED` the seed (default 7).

use std::time::Instant;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use stbn_gen::analysis::{Field, FilteredErrorOptions, filtered_error};
use stbn_gen::{
    FilterAdaptedSpec, MaskSpec, Observer, ValueKernel, Volume, generate_filter_adapted,
};

fn timing(c: &mut Criterion) {
    if std::env::var_os("STBN_FILTER_ADAPTED_128").is_some() {
        return;
    }
    let mut group = c.benchmark_group("filter_adapted_32");
    group.sample_size(10);
    for kernel in [ValueKernel::Distance, ValueKernel::Product] {
        let spec = FilterAdaptedSpec::new(32, 32, 16, 1).with_value_kernel(kernel);
        group.throughput(Throughput::Elements(spec.pixels()));
        group.bench_function(format!("{}_32x32x16", kernel.name()), |b| {
            b.iter(|| generate_filter_adapted(&spec, Observer::default()).unwrap())
        });
    }
    group.finish();
}

/// The last frame's filtered error of `volume` with the default options.
fn filtered_last(volume: &Volume) -> f64 {
    let values = volume.values();
    let (w, h, d) = (volume.width(), volume.height(), volume.depth());
    let field = Field::new(w as usize, h as usize, d as usize, &values).unwrap();
    *filtered_error(&field, FilteredErrorOptions::default())
        .last()
        .unwrap()
}

/// The 1-minute load average, to read timings on a shared machine.
fn load() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|l| l.split_whitespace().next().map(str::to_owned))
        .unwrap_or_else(|| "n/a".to_owned())
}

fn target_128(_: &mut Criterion) {
    if std::env::var_os("STBN_FILTER_ADAPTED_128").is_none() {
        return;
    }
    let seed: u64 = std::env::var("STBN_FILTER_ADAPTED_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(7);
    let budgets: Vec<f64> = std::env::var("STBN_FILTER_ADAPTED_BUDGETS")
        .ok()
        .map(|s| s.split(',').filter_map(|b| b.trim().parse().ok()).collect())
        .unwrap_or_else(|| vec![FilterAdaptedSpec::DEFAULT_SWAPS_PER_PIXEL]);
    let start = Instant::now();
    let stbn = stbn_gen::generate(&MaskSpec::new(128, 128, 64, seed), Observer::default()).unwrap();
    println!(
        "STBN 128×128×64 seed {seed}: {:.1} s, filtered error at the last frame {:.5}",
        start.elapsed().as_secs_f64(),
        filtered_last(&stbn)
    );
    for budget in budgets {
        let spec = FilterAdaptedSpec::new(128, 128, 64, seed).with_swaps_per_pixel(budget);
        let load_before = load();
        let start = Instant::now();
        let volume = generate_filter_adapted(&spec, Observer::default()).unwrap();
        let seconds = start.elapsed().as_secs_f64();
        println!(
            "filter-adapted 128×128×64 seed {seed}, {budget} swaps per pixel: {seconds:.1} s \
             (load average {load_before} before, {} after), filtered error at the last frame {:.5}",
            load(),
            filtered_last(&volume)
        );
    }
}

criterion_group!(benches, timing, target_128);
criterion_main!(benches);
