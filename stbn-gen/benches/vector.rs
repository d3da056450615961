//! Vector generator speed, and its energy against the swap budget.
//!
//! `cargo bench -p stbn-gen --bench vector` times Vec2 and UnitVec3 at 32×32×16 with the default
//! budget (swaps, then assignment passes). `STBN_BENCH_LARGE=1 cargo bench -p stbn-gen --bench
//! vector -- vector_128` adds the 128×128×64 (tens of seconds per sample).
//!
//! `STBN_VECTOR_CURVE=WxHxD cargo bench -p stbn-gen --bench vector` instead prints, for Vec2 and
//! UnitVec3 at that size, the energy per pixel after 0.5, 1, 2, 4, … 256 swaps per pixel and no
//! assignment passes (from one long run's trace; 0.5 from its own run), with the time of the
//! whole run and the low-band power of each component at the end. `STBN_VECTOR_CURVE_MAX` sets the longest budget (default 256).
//!
//! `STBN_VECTOR_QUALITY=WxHxD cargo bench -p stbn-gen --bench vector` instead generates Vec2 and
//! UnitVec3 (or the spaces `STBN_VECTOR_SPACES` names, e.g. `vec2,unitvec3,cosine_hemisphere`)
//! at that size once per budget of `STBN_VECTOR_QUALITY_BUDGETS` (default `16,64,1024`
//! swaps per pixel, `default` for [`VectorSpec::DEFAULT_SWAPS_PER_PIXEL`]; seed `STBN_VECTOR_SEED`, default 1) and prints, per run, the time, the energy
//! and what a renderer sees: the low-band power of component 0, FAST's filtered error with random
//! half-space thresholds at the last frame, the integration errors of the report's test functions
//! (Monte Carlo RMSE after `depth/2` frames, EMA RMSE at the last frame), and for Vec2 the same
//! errors of the 2D disc, Gaussian and diagonal step. `STBN_VECTOR_ASSIGNMENT=N` runs `N` assignment passes after each budget's swaps (default
//! [`VectorSpec::DEFAULT_ASSIGNMENT_PASSES`]; 0 for swaps alone).

use std::time::Instant;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use stbn_gen::analysis::{
    Convergence, ConvergenceOptions, Field, FilteredErrorOptions, Integrand2D, TestFunction,
    VectorField, convergence_2d, filtered_error_vector, spatial_low_band, temporal_low_band,
    vector_convergence,
};
use stbn_gen::{
    EnergyTrace, Observer, SampleSpace, VectorSpec, VectorSpecError, VectorVolume, generate_vector,
};

/// The mask of `spec` and its energy trace.
fn with_trace(spec: &VectorSpec) -> Result<(VectorVolume, EnergyTrace), VectorSpecError> {
    let mut trace = EnergyTrace::default();
    let observer = Observer::default().with_trace(&mut trace);
    let volume = generate_vector(spec, observer)?;
    Ok((volume, trace))
}

fn spaces() -> [(SampleSpace, bool); 2] {
    [
        (SampleSpace::Vec { dims: 2 }, false),
        (SampleSpace::UnitVec3, true),
    ]
}

/// The spaces of `STBN_VECTOR_SPACES` (names as [`SampleSpace::name`] writes them, comma
/// separated; the image spaces need an image and are left out), or [`spaces`]. The second field
/// says whether the components are signed.
fn quality_spaces() -> Vec<(SampleSpace, bool)> {
    let Ok(names) = std::env::var("STBN_VECTOR_SPACES") else {
        return spaces().to_vec();
    };
    let all = [
        SampleSpace::Vec { dims: 1 },
        SampleSpace::Vec { dims: 2 },
        SampleSpace::Vec { dims: 3 },
        SampleSpace::Vec { dims: 4 },
        SampleSpace::UnitVec1,
        SampleSpace::UnitVec2,
        SampleSpace::UnitVec3,
        SampleSpace::UniformHemisphere,
        SampleSpace::CosineHemisphere,
    ];
    names
        .split(',')
        .map(|name| {
            let space = all
                .iter()
                .find(|s| s.name() == name)
                .unwrap_or_else(|| panic!("STBN_VECTOR_SPACES: unknown space {name:?}"))
                .clone();
            let signed = !matches!(space, SampleSpace::Vec { .. });
            (space, signed)
        })
        .collect()
}

fn timing(c: &mut Criterion) {
    if std::env::var_os("STBN_VECTOR_CURVE").is_some()
        || std::env::var_os("STBN_VECTOR_QUALITY").is_some()
    {
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
                b.iter(|| generate_vector(&spec, Observer::default()).unwrap())
            });
        }
        group.finish();
    }
}

/// Spatial and temporal low-band power of each component (signed components mapped to [0, 1]).
fn bands(volume: &VectorVolume, signed: bool) -> String {
    let values = component_values(volume, signed);
    fields(volume, &values)
        .iter()
        .enumerate()
        .map(|(c, field)| {
            format!(
                "c{c}: spatial {:.4} temporal {:.4}",
                spatial_low_band(field).unwrap_or(0.0),
                temporal_low_band(field).unwrap_or(0.0)
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// Each component's values (signed components mapped to [0, 1]).
fn component_values(volume: &VectorVolume, signed: bool) -> Vec<Vec<f64>> {
    (0..volume.dims())
        .map(|c| {
            volume
                .values()
                .chunks_exact(volume.dims())
                .map(|v| {
                    let x = f64::from(v[c]);
                    if signed { x * 0.5 + 0.5 } else { x }
                })
                .collect()
        })
        .collect()
}

/// Fields over `values` shaped like `volume`.
fn fields<'a>(volume: &VectorVolume, values: &'a [Vec<f64>]) -> Vec<Field<'a>> {
    let (w, h, d) = (
        volume.width() as usize,
        volume.height() as usize,
        volume.depth() as usize,
    );
    values
        .iter()
        .map(|v| Field::new(w, h, d, v).unwrap())
        .collect()
}

/// One line of integration errors: MC RMSE after half the frames, EMA RMSE at the last.
fn print_errors(what: &str, c: &Convergence, frames: usize) {
    println!(
        "  {what}: MC RMSE after {} frames {:.4}, EMA RMSE {:.4}",
        frames / 2,
        c.monte_carlo[frames / 2 - 1],
        c.ema[frames - 1]
    );
}

fn quality(_: &mut Criterion) {
    let Ok(size) = std::env::var("STBN_VECTOR_QUALITY") else {
        return;
    };
    let dims: Vec<u32> = size.split('x').map(|s| s.parse().unwrap()).collect();
    let (w, h, d) = (dims[0], dims[1], dims[2]);
    let budgets: Vec<f64> = std::env::var("STBN_VECTOR_QUALITY_BUDGETS")
        .unwrap_or_else(|_| "16,64,1024".to_owned())
        .split(',')
        .map(|s| match s {
            "default" => VectorSpec::DEFAULT_SWAPS_PER_PIXEL,
            _ => s.parse().unwrap(),
        })
        .collect();
    let seed: u64 = std::env::var("STBN_VECTOR_SEED").map_or(1, |s| s.parse().unwrap());
    let assignment: u32 = std::env::var("STBN_VECTOR_ASSIGNMENT")
        .map_or(VectorSpec::DEFAULT_ASSIGNMENT_PASSES, |s| {
            s.parse().unwrap()
        });
    for (space, signed) in quality_spaces() {
        for &budget in &budgets {
            let spec = VectorSpec::new(w, h, d, seed, space.clone())
                .with_swaps_per_pixel(budget)
                .with_assignment_passes(assignment);
            let start = Instant::now();
            let (volume, trace) = with_trace(&spec).unwrap();
            let seconds = start.elapsed().as_secs_f64();
            let energy = trace.points.last().unwrap().energy / spec.pixels() as f64;
            let values = component_values(&volume, signed);
            let fields = fields(&volume, &values);
            let filtered = filtered_error_vector(&fields, FilteredErrorOptions::default()).unwrap();
            println!(
                "{} {w}x{h}x{d}, seed {seed}, {budget} swaps/pixel, {assignment} assignment \
                 passes: {seconds:.2} s, \
                 energy/pixel {energy:.6}, \
                 c0 spatial {:.4} temporal {:.4}, filtered error (half-spaces) {:.5}",
                space.name(),
                spatial_low_band(&fields[0]).unwrap_or(0.0),
                temporal_low_band(&fields[0]).unwrap_or(0.0),
                filtered[d as usize - 1]
            );
            let frames = d as usize;
            let field = VectorField::new(&space, (w as usize, h as usize, frames), volume.values())
                .unwrap();
            for function in TestFunction::ALL {
                let exact = function.expected(&space);
                let c =
                    vector_convergence(&field, function, exact, ConvergenceOptions::new(frames));
                print_errors(&format!("test function {}", function.name()), &c, frames);
            }
            if fields.len() == 2 {
                for integrand in Integrand2D::ALL {
                    let c = convergence_2d(
                        &fields[0],
                        &fields[1],
                        integrand,
                        ConvergenceOptions::new(frames),
                    )
                    .unwrap();
                    print_errors(integrand.name(), &c, frames);
                }
            }
        }
    }
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
        let spec = VectorSpec::new(w, h, d, 1, space.clone()).with_assignment_passes(0);
        let pixels = spec.pixels() as f64;
        let half = with_trace(&spec.clone().with_swaps_per_pixel(0.5))
            .unwrap()
            .1;
        let start = Instant::now();
        let (volume, trace) = with_trace(&spec.clone().with_swaps_per_pixel(max)).unwrap();
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

criterion_group!(benches, timing, curve, quality);
criterion_main!(benches);
