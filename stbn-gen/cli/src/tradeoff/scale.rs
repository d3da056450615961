//! The scale checks: one thread against two (time and identical output), and the largest masks
//! against their time targets, with memory.

use std::sync::Arc;

use stbn_gen::{
    FilterAdaptedSpec, ImagePdf, MaskSpec, Observer, SampleSpace, VectorSpec, VectorVolume, Volume,
};

use super::measure::{Timing, load_average, timed};
use super::{Knob, Plan, Section, size_name};
use crate::Result;
use crate::output::{Cell, Table};

/// Runs `work` under [`timed`] inside a rayon pool of `threads` threads.
fn in_pool<T: PartialEq + Send>(
    plan: &Plan,
    threads: usize,
    work: impl Fn() -> T + Send + Sync,
) -> Result<(T, Timing)> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| format!("cannot start {threads} threads: {e}"))?;
    Ok(pool.install(|| timed(plan.max_runs, plan.min_total, &work)))
}

/// A small luminance image for the image kinds: a bright spot on a horizontal gradient (the sky
/// of an environment map, or a vignette of points).
fn test_image() -> Result<Arc<ImagePdf>> {
    let (w, h) = (64u32, 32u32);
    let luminance = (0..w * h)
        .map(|i| {
            let (x, y) = (
                f64::from(i % w) / f64::from(w),
                f64::from(i / w) / f64::from(h),
            );
            let spot = (-((x - 0.3).powi(2) + (y - 0.25).powi(2)) * 60.0).exp();
            (0.2 + 0.8 * (1.0 - y) + 20.0 * spot) as f32
        })
        .collect();
    Ok(Arc::new(ImagePdf::from_luminance(w, h, luminance)?))
}

/// A scalar mask's ranks as bytes, to compare two runs whole.
fn rank_bytes(volume: &Volume) -> Vec<u8> {
    volume
        .ranks()
        .iter()
        .flat_map(|r| r.to_le_bytes())
        .collect()
}

/// A vector mask's values as bytes, to compare two runs whole (bit for bit, NaN included).
fn vector_bytes(volume: &VectorVolume) -> Vec<u8> {
    volume
        .values()
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect()
}

/// The scalar mask and every swap-optimised kind but UnitVec1 (±1 values) at its default budget,
/// generated in pools of 1 and 2 threads.
pub fn threads(plan: &Plan) -> Result<Section> {
    let mut table = Table::new(&[
        ("mask", "mask", false),
        ("threads", "threads", true),
        ("seconds", "seconds", true),
        ("runs", "runs", true),
        ("speedup", "speed-up over 1 thread", true),
        ("identical_to_1_thread", "identical to 1 thread", false),
    ]);
    let mut findings = Vec::new();
    let mut all_identical = true;
    let mut check = |name: String, work: &(dyn Fn() -> Result<Vec<u8>> + Sync)| -> Result<()> {
        let (one, t1) = in_pool(plan, 1, || work().map_err(|e| e.to_string()))?;
        let (two, t2) = in_pool(plan, 2, || work().map_err(|e| e.to_string()))?;
        let identical = one? == two?;
        rows(&mut table, &name, &t1, &t2, identical);
        findings.push(verdict(&name, &t1, &t2, identical));
        all_identical &= identical;
        Ok(())
    };
    let (w, h, d) = plan.threads_scalar;
    let scalar = MaskSpec::new(w, h, d, plan.seed);
    check(
        format!("scalar {}", size_name(plan.threads_scalar)),
        &|| {
            let volume = stbn_gen::generate(&scalar, Observer::default())?;
            Ok(rank_bytes(&volume))
        },
    )?;
    let image = test_image()?;
    let (w, h, d) = plan.vector_size;
    let spaces = [
        SampleSpace::Vec { dims: 1 },
        SampleSpace::Vec { dims: 2 },
        SampleSpace::Vec { dims: 3 },
        SampleSpace::Vec { dims: 4 },
        SampleSpace::UnitVec2,
        SampleSpace::UnitVec3,
        SampleSpace::UniformHemisphere,
        SampleSpace::CosineHemisphere,
        SampleSpace::ImagePoints(image.clone()),
        SampleSpace::EnvironmentDirections(image),
    ];
    for space in spaces {
        let spec = VectorSpec::new(w, h, d, plan.seed, space.clone());
        let name = format!("{} {}", space.name(), size_name(plan.vector_size));
        check(name, &|| {
            Ok(vector_bytes(&stbn_gen::generate_vector(
                &spec,
                Observer::default(),
            )?))
        })?;
    }
    let adapted = FilterAdaptedSpec::new(w, h, d, plan.seed);
    check(
        format!("filter-adapted scalar {}", size_name(plan.vector_size)),
        &|| {
            let volume = stbn_gen::generate_filter_adapted(&adapted, Observer::default())?;
            Ok(rank_bytes(&volume))
        },
    )?;
    let adapted_vector = adapted.clone().with_space(SampleSpace::UnitVec3);
    check(
        format!("filter-adapted unitvec3 {}", size_name(plan.vector_size)),
        &|| {
            let volume =
                stbn_gen::generate_filter_adapted_vector(&adapted_vector, Observer::default())?;
            Ok(vector_bytes(&volume))
        },
    )?;
    if !all_identical {
        return Err(format!("thread count changed a mask: {}", findings.join(" ")).into());
    }
    Ok(Section {
        knob: Knob::Threads,
        title: "6. One thread against two".to_owned(),
        method: "The same spec generated inside a rayon pool of 1 thread and of 2 threads \
                 (`ThreadPoolBuilder::num_threads`, `install`), compared whole (ranks or values). \
                 Every swap-optimised kind but UnitVec1 at its default budget (the image kinds \
                 over a 64 × 32 test image); the filter-adapted masks with their default filters. \
                 Void-and-cluster runs its phase 2a beside phases 2b/3; the swap optimisers run \
                 the tiles of one colour in parallel. The library promises identical output for \
                 any thread count; the command fails if it is not."
            .to_owned(),
        tables: vec![("threads".to_owned(), "Thread count.".to_owned(), table)],
        charts: Vec::new(),
        findings,
    })
}

fn rows(table: &mut Table, name: &str, t1: &Timing, t2: &Timing, identical: bool) {
    for (threads, t) in [(1, t1), (2, t2)] {
        table.push(vec![
            Cell::text(name),
            Cell::int(threads),
            Cell::sig(t.median(), 3),
            Cell::int(t.runs.len() as u64),
            Cell::fixed(t1.median() / t.median(), 2),
            if threads == 1 {
                Cell::missing()
            } else {
                Cell::yes_no(identical)
            },
        ]);
    }
}

fn verdict(name: &str, t1: &Timing, t2: &Timing, identical: bool) -> String {
    format!(
        "{name}: {:.3} s on 1 thread, {:.3} s on 2 (×{:.2}); output {}.",
        t1.median(),
        t2.median(),
        t1.median() / t2.median(),
        if identical { "identical" } else { "DIFFERENT" }
    )
}

/// The largest scalar and Vec2 masks against their time targets: time, peak memory and the
/// estimate.
pub fn scale(plan: &Plan) -> Result<Section> {
    let mut table = Table::new(&[
        ("mask", "mask", false),
        ("seconds", "seconds", true),
        ("target_seconds", "target s", true),
        ("met", "met", false),
        ("peak_bytes", "peak MB", true),
        ("estimate_bytes", "estimate MB", true),
        ("load_before", "load before", false),
        ("load_after", "load after", false),
    ]);
    let mut findings = Vec::new();
    let ((w, h, d), target) = plan.scale_scalar;
    let spec = MaskSpec::new(w, h, d, plan.seed);
    let before = load_average();
    let (volume, timing) = timed(1, 0.0, || stbn_gen::generate(&spec, Observer::default()));
    volume?;
    let name = format!("scalar {}", size_name((w, h, d)));
    push(
        &mut table,
        &mut findings,
        &name,
        &timing,
        target,
        spec.pixels() * MaskSpec::BYTES_PER_PIXEL,
        before,
    );
    let ((w, h, d), target) = plan.scale_vector;
    let spec = VectorSpec::new(w, h, d, plan.seed, SampleSpace::Vec { dims: 2 });
    let before = load_average();
    let (volume, timing) = timed(1, 0.0, || {
        stbn_gen::generate_vector(&spec, Observer::default())
    });
    volume?;
    let name = format!(
        "Vec2 {}, {} swaps per pixel and {} assignment passes",
        size_name((w, h, d)),
        spec.swaps_per_pixel,
        spec.assignment_passes
    );
    push(
        &mut table,
        &mut findings,
        &name,
        &timing,
        target,
        spec.pixels() * spec.bytes_per_pixel(),
        before,
    );
    let note = if plan.quick {
        " In `--quick` mode the masks are small stand-ins and there are no targets."
    } else {
        ""
    };
    Ok(Section {
        knob: Knob::Scale,
        title: "7. Scale targets".to_owned(),
        method: format!(
            "Targets: scalar 256×256×128 in ≤ 30 s and vector 256×256×64 in ≤ 5 min (release, \
             two cores), memory reported. One run each, seed {}, default settings (Vec2 at the \
             default {} swaps per pixel), on the global rayon pool (all cores).{note}",
            plan.seed,
            VectorSpec::DEFAULT_SWAPS_PER_PIXEL
        ),
        tables: vec![("scale".to_owned(), "Scale.".to_owned(), table)],
        charts: Vec::new(),
        findings,
    })
}

fn push(
    table: &mut Table,
    findings: &mut Vec<String>,
    name: &str,
    timing: &Timing,
    target: Option<f64>,
    estimate: u64,
    before: String,
) {
    let seconds = timing.median();
    let met = target.map(|t| seconds <= t);
    let after = load_average();
    outln!("  {name}: {seconds:.2} s");
    findings.push(format!(
        "{name}: {seconds:.2} s{}; peak memory {} (estimate {:.1} MB); load {before} → {after}.",
        match (target, met) {
            (Some(t), Some(true)) => format!(" (target {t} s: met)"),
            (Some(t), _) => format!(" (target {t} s: NOT met)"),
            _ => String::new(),
        },
        timing
            .peak_bytes
            .map_or("n/a".to_owned(), |b| format!("{:.1} MB", b as f64 / 1e6)),
        estimate as f64 / 1e6,
    ));
    table.push(vec![
        Cell::text(name),
        Cell::sig(seconds, 3),
        Cell::opt_sig(target, 3),
        met.map_or_else(Cell::missing, Cell::yes_no),
        Cell::megabytes(timing.peak_bytes),
        Cell::megabytes(Some(estimate)),
        Cell::text(before),
        Cell::text(after),
    ]);
}
