//! The scalar generator's knobs: mask size and depth, σ and the kernel truncation tolerance.

use stbn_gen::{MaskSpec, Observer, Volume};

use super::measure::{Quality, Timing, timed};
use super::{Knob, Plan, Section, size_name};
use crate::Result;
use crate::output::{Axis, Cell, Chart, Series, SeriesLabelPosition, Table};

/// One generated scalar mask: its time, memory and quality.
struct Measured {
    timing: Timing,
    quality: Quality,
}

/// Generates `spec` (timed, see [`timed`]) and measures the result.
fn measure(plan: &Plan, spec: &MaskSpec) -> Result<Measured> {
    let (volume, timing) = timed(plan.max_runs, plan.min_total, || {
        stbn_gen::generate(spec, Observer::default())
    });
    let volume: Volume = volume?;
    if !timing.repeatable {
        return Err(format!("{spec:?}: repeated runs gave different masks").into());
    }
    let quality = Quality::of_values(
        volume.width(),
        volume.height(),
        volume.depth(),
        &volume.values(),
    );
    Ok(Measured { timing, quality })
}

/// Mask size (`plan.sides`², every `plan.depths`): time, time per pixel, peak memory beside the
/// documented estimate, and quality.
pub fn size(plan: &Plan) -> Result<Section> {
    let mut columns = vec![
        ("mask", "mask", false),
        ("pixels", "pixels", true),
        ("seconds", "seconds", true),
        ("runs", "runs", true),
        ("ns_per_pixel", "ns per pixel", true),
        ("peak_bytes", "peak MB", true),
        ("estimate_bytes", "estimate MB", true),
    ];
    columns.extend(Quality::COLUMNS);
    let mut table = Table::new(&columns);
    let mut time_series = Vec::new();
    let mut quality_series = Vec::new();
    let mut ns_range: Option<(f64, String, f64, String)> = None;
    for &side in &plan.sides {
        let mut times = Series {
            name: format!("{side}×{side}"),
            ..Series::default()
        };
        let mut filtered = times.clone();
        for &depth in &plan.depths {
            let spec = MaskSpec::new(side, side, depth, plan.seed);
            let m = measure(plan, &spec)?;
            let pixels = spec.pixels();
            let seconds = m.timing.median();
            let ns = seconds * 1e9 / pixels as f64;
            let name = size_name((side, side, depth));
            outln!("  {name}: {seconds:.3} s");
            let mut row = vec![
                Cell::text(name.clone()),
                Cell::int(pixels),
                Cell::sig(seconds, 3),
                Cell::int(m.timing.runs.len() as u64),
                Cell::sig(ns, 3),
                Cell::megabytes(m.timing.peak_bytes),
                Cell::megabytes(Some(pixels * MaskSpec::BYTES_PER_PIXEL)),
            ];
            row.extend(m.quality.cells());
            table.push(row);
            times.points.push((pixels as f64, seconds));
            filtered
                .points
                .push((f64::from(depth), m.quality.filtered_last));
            // Per-pixel times of masks under 2^16 pixels are dominated by fixed costs.
            if pixels >= 1 << 16 {
                ns_range = Some(match ns_range {
                    None => (ns, name.clone(), ns, name),
                    Some((lo, lo_name, hi, hi_name)) => {
                        let (lo, lo_name) = if ns < lo {
                            (ns, name.clone())
                        } else {
                            (lo, lo_name)
                        };
                        let (hi, hi_name) = if ns > hi { (ns, name) } else { (hi, hi_name) };
                        (lo, lo_name, hi, hi_name)
                    }
                });
            }
        }
        time_series.push(times);
        quality_series.push(filtered);
    }
    let mut findings = Vec::new();
    if let Some((lo, lo_name, hi, hi_name)) = ns_range {
        let pixels_of = |name: &str| -> f64 {
            name.split('×')
                .map(|a| a.parse::<f64>().unwrap_or(1.0))
                .product()
        };
        findings.push(format!(
            "Time per pixel, masks of at least 65,536 pixels: from {lo:.0} ns ({lo_name}) to \
             {hi:.0} ns ({hi_name}): ×{:.2} per pixel for ×{:.0} the pixels (a step quadratic \
             in the volume would make the per-pixel time grow as fast as the volume).",
            hi / lo,
            pixels_of(&hi_name) / pixels_of(&lo_name),
        ));
    }
    Ok(Section {
        knob: Knob::Size,
        title: "1. Mask size and depth (scalar STBN)".to_owned(),
        method: format!(
            "`stbn_gen::generate(&MaskSpec::new(side, side, frames, {}), Observer::default())` \
             with the paper's defaults (σ 1.9, density 0.1, tolerance 5·10⁻³). A bigger slice \
             tiles less often on screen; more frames give a longer sequence per pixel before it \
             repeats (the MC RMSE at 32 and 64 samples shows the repeat for shorter masks).",
            plan.seed
        ),
        tables: vec![("size".to_owned(), "Mask size and depth.".to_owned(), table)],
        charts: vec![
            (
                "size_time".to_owned(),
                Chart {
                    title: "Generation time against pixels".to_owned(),
                    x: Axis::log("pixels (width × height × frames)"),
                    y: Axis::log("seconds"),
                    series: time_series,
                    legend: SeriesLabelPosition::UpperLeft,
                    reference: None,
                },
            ),
            (
                "size_quality".to_owned(),
                Chart {
                    title: "Filtered error of the last frame against depth".to_owned(),
                    x: Axis::log("frames"),
                    y: Axis::linear("filtered error (lower is better)"),
                    series: quality_series,
                    legend: SeriesLabelPosition::UpperRight,
                    reference: None,
                },
            ),
        ],
        findings,
    })
}

/// σ (tolerance at its default) and the kernel truncation tolerance (σ at its default): taps per
/// splat, time and quality at `plan.kernel_size`.
pub fn kernel(plan: &Plan) -> Result<Section> {
    let (w, h, d) = plan.kernel_size;
    let base = MaskSpec::new(w, h, d, plan.seed);
    let mut columns = vec![
        ("sweep", "sweep", false),
        ("sigma", "σ", true),
        ("kernel_tolerance", "tolerance", true),
        ("taps", "taps per splat", true),
        ("seconds", "seconds", true),
        ("runs", "runs", true),
    ];
    columns.extend(Quality::COLUMNS);
    let mut table = Table::new(&columns);
    let sigma_specs = plan
        .sigmas
        .iter()
        .map(|&s| ("σ", base.clone().with_sigma(s)));
    let tolerance_specs = plan.tolerances.iter().map(|&t| {
        let mut spec = base.clone();
        spec.kernel_tolerance = t;
        ("tolerance", spec)
    });
    let mut sigma_series = (Series::default(), Series::default());
    let mut tolerance_series = (Series::default(), Series::default());
    let mut default_row = None;
    let mut rows = Vec::new();
    for (sweep, spec) in sigma_specs.chain(tolerance_specs) {
        let taps = spec.kernel_taps();
        let m = measure(plan, &spec)?;
        let seconds = m.timing.median();
        outln!(
            "  σ {} tolerance {}: {taps} taps, {seconds:.3} s",
            spec.sigma_xy,
            spec.kernel_tolerance
        );
        let mut row = vec![
            Cell::text(sweep),
            Cell::fixed(spec.sigma_xy, 1),
            Cell::sig(spec.kernel_tolerance, 1),
            Cell::int(taps as u64),
            Cell::sig(seconds, 3),
            Cell::int(m.timing.runs.len() as u64),
        ];
        row.extend(m.quality.cells());
        table.push(row);
        let (series, label) = if sweep == "σ" {
            (&mut sigma_series, format!("σ {}", spec.sigma_xy))
        } else {
            (
                &mut tolerance_series,
                format!("{:e}", spec.kernel_tolerance),
            )
        };
        series.0.points.push((seconds, m.quality.filtered_last));
        series.0.labels.push(label.clone());
        series.1.points.push((seconds, m.quality.mc_step[0]));
        series.1.labels.push(label);
        if spec == base && default_row.is_none() {
            default_row = Some((seconds, m.quality));
        }
        rows.push((sweep, spec, taps, seconds, m.quality));
    }
    let mut findings = Vec::new();
    if let Some((base_seconds, base_quality)) = default_row {
        for (sweep, spec, taps, seconds, quality) in &rows {
            if *sweep != "tolerance" || *spec == base {
                continue;
            }
            findings.push(format!(
                "Tolerance {:e} ({taps} taps): {:+.1}% time, {:+.2}% filtered error, {:+.2}% MC \
                 RMSE at 8 samples against the default 5e-3.",
                spec.kernel_tolerance,
                100.0 * (seconds / base_seconds - 1.0),
                100.0 * (quality.filtered_last / base_quality.filtered_last - 1.0),
                100.0 * (quality.mc_step[0] / base_quality.mc_step[0] - 1.0),
            ));
        }
    }
    let name = |pair: (Series, Series), sweep: &str| {
        let (mut a, mut b) = pair;
        a.name = sweep.to_owned();
        b.name = sweep.to_owned();
        (a, b)
    };
    let (sigma_f, sigma_mc) = name(sigma_series, "σ (tolerance 5e-3)");
    let (tol_f, tol_mc) = name(tolerance_series, "tolerance (σ 1.9)");
    Ok(Section {
        knob: Knob::Kernel,
        title: "2. σ and the kernel truncation tolerance (scalar STBN)".to_owned(),
        method: format!(
            "{} masks, seed {}: σ (`MaskSpec::with_sigma`, the same in space and time) at the \
             default tolerance, then `kernel_tolerance` at the default σ 1.9. Taps per splat: \
             `MaskSpec::kernel_taps`, the footprint each void-and-cluster step updates (its cost). \
             σ changes what the mask *is* (the frequency where blue noise starts); the \
             tolerance only how exactly the energy is computed.",
            size_name(plan.kernel_size),
            plan.seed
        ),
        tables: vec![("kernel".to_owned(), "σ and tolerance.".to_owned(), table)],
        charts: vec![
            (
                "kernel_filtered".to_owned(),
                Chart {
                    title: "Filtered error against generation time".to_owned(),
                    x: Axis::linear("seconds"),
                    y: Axis::linear("filtered error, last frame (lower is better)"),
                    series: vec![sigma_f, tol_f],
                    legend: SeriesLabelPosition::UpperRight,
                    reference: None,
                },
            ),
            (
                "kernel_rmse".to_owned(),
                Chart {
                    title: "MC RMSE after 8 samples against generation time".to_owned(),
                    x: Axis::linear("seconds"),
                    y: Axis::linear("step MC RMSE at 8 samples (lower is better)"),
                    series: vec![sigma_mc, tol_mc],
                    legend: SeriesLabelPosition::UpperRight,
                    reference: None,
                },
            ),
        ],
        findings,
    })
}
