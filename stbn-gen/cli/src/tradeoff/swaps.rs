//! The vector optimiser's swap budget: time and final energy per budget, and the energy curve of
//! one long run.

use std::time::Instant;

use stbn_gen::{
    EnergyTrace, Observer, Progress, SampleSpace, VectorSpec, VectorSpecError, VectorVolume,
    generate_vector,
};

use super::measure::{Quality, timed, with_peak_memory};
use super::{Knob, Plan, Section, size_name};
use crate::Result;
use crate::output::{Axis, Cell, Chart, Series, SeriesLabelPosition, Table};

/// The mask of `spec` and its energy trace.
fn generate_traced(
    spec: &VectorSpec,
) -> std::result::Result<(VectorVolume, EnergyTrace), VectorSpecError> {
    let mut trace = EnergyTrace::default();
    let volume = generate_vector(spec, Observer::default().with_trace(&mut trace))?;
    Ok((volume, trace))
}

/// The energy trace of `spec`'s mask and the seconds from `start` to the end of each pass.
fn generate_stamped(
    spec: &VectorSpec,
    start: Instant,
) -> std::result::Result<(EnergyTrace, Vec<f64>), VectorSpecError> {
    let mut stamps = Vec::new();
    // A pass sweeps four tile colours: a positive multiple of 4 quarter passes ends one.
    let mut progress = |p: Progress| {
        if p.done > 0 && p.done.is_multiple_of(4) {
            stamps.push(start.elapsed().as_secs_f64());
        }
    };
    let mut trace = EnergyTrace::default();
    let observer = Observer::default()
        .with_progress(&mut progress)
        .with_trace(&mut trace);
    generate_vector(spec, observer)?;
    Ok((trace, stamps))
}

/// The spaces the vector knobs measure, with their names.
pub fn spaces() -> [(&'static str, SampleSpace); 2] {
    [
        ("Vec2", SampleSpace::Vec { dims: 2 }),
        ("UnitVec3", SampleSpace::UnitVec3),
    ]
}

/// The first component of every value of `volume` mapped to `[0, 1]`: as stored for `[0, 1)`
/// spaces, `(c + 1) / 2` for signed ones (the x component of a uniform unit vector is uniform in
/// `[−1, 1]`, so both are uniform in `[0, 1]`).
pub fn first_component(volume: &VectorVolume, signed: bool) -> Vec<f64> {
    volume
        .values()
        .chunks_exact(volume.dims())
        .map(|v| {
            let c = f64::from(v[0]);
            if signed {
                ((c + 1.0) * 0.5).clamp(0.0, 1.0)
            } else {
                c.clamp(0.0, 1.0)
            }
        })
        .collect()
}

/// Whether `space`'s components are signed.
pub fn is_signed(space: &SampleSpace) -> bool {
    !matches!(space, SampleSpace::Vec { .. })
}

/// A point of the energy curve: budget, energy, seconds since the run started (if known).
#[derive(Clone, Copy, Debug)]
struct Point {
    budget: f64,
    energy: f64,
    seconds: Option<f64>,
}

/// Budgets `plan.budgets` run one by one, and one run of `plan.longest_budget` swaps per pixel
/// whose per-pass energies (the [`stbn_gen::EnergyTrace`]) give the curve, for Vec2 and
/// UnitVec3 at `plan.swap_size`.
pub fn run(plan: &Plan) -> Result<Section> {
    let (w, h, d) = plan.swap_size;
    let pixels = u64::from(w) * u64::from(h) * u64::from(d);
    let mut columns = vec![
        ("space", "space", false),
        ("swaps_per_pixel", "swaps per pixel", true),
        ("assignment_passes", "assignment passes", true),
        ("seconds", "seconds", true),
        ("runs", "runs", true),
        ("energy", "energy", false),
        ("energy_per_pixel", "energy per pixel", true),
        (
            "excess_over_longest_percent",
            "above longest run's final, %",
            true,
        ),
        ("accepted_per_pixel", "accepted swaps per pixel", true),
        ("same_as_longest_run_trace", "= long run's trace", false),
    ];
    columns.extend(Quality::COLUMNS);
    let mut table = Table::new(&columns);
    let mut trace_table = Table::new(&[
        ("space", "space", false),
        ("swaps_per_pixel", "swaps per pixel", true),
        ("assignment_passes", "assignment passes", true),
        ("seconds_since_start", "seconds since start", true),
        ("energy_per_pixel", "energy per pixel", true),
        ("excess_over_final_percent", "above final, %", true),
        (
            "share_of_decrease_percent",
            "share of the decrease, %",
            true,
        ),
    ]);
    let mut excess_series = Vec::new();
    let mut time_series = Vec::new();
    let mut findings = Vec::new();
    for (name, space) in spaces() {
        let signed = is_signed(&space);
        // The long run of swaps alone, with the time at the end of every pass.
        let spec = VectorSpec::new(w, h, d, plan.seed, space.clone())
            .with_swaps_per_pixel(f64::from(plan.longest_budget))
            .with_assignment_passes(0);
        let start = Instant::now();
        let (made, peak) = with_peak_memory(|| generate_stamped(&spec, start));
        let long_seconds = start.elapsed().as_secs_f64();
        let (trace, stamps) = made?;
        let energies: Vec<f64> = trace.points.iter().map(|p| p.energy).collect();
        let (initial, last) = (energies[0], energies[energies.len() - 1]);
        outln!(
            "  {name}: {} swaps per pixel in {long_seconds:.2} s",
            plan.longest_budget
        );
        let mut curve: Vec<Point> = energies
            .iter()
            .enumerate()
            .map(|(k, &energy)| Point {
                budget: k as f64,
                energy,
                seconds: k.checked_sub(1).and_then(|i| stamps.get(i).copied()),
            })
            .collect();
        // The budgets run one by one.
        let mut times = Series {
            name: name.to_owned(),
            ..Series::default()
        };
        for &budget in &plan.budgets {
            let spec = VectorSpec::new(w, h, d, plan.seed, space.clone())
                .with_swaps_per_pixel(budget)
                .with_assignment_passes(0);
            let (made, timing) = timed(plan.max_runs, plan.min_total, || generate_traced(&spec));
            let (volume, trace) = made?;
            if !timing.repeatable {
                return Err(format!("{name} budget {budget}: repeated runs differ").into());
            }
            let end = trace.points.last().expect("a trace has its initial point");
            let seconds = timing.median();
            outln!("  {name}: {budget} swaps per pixel in {seconds:.3} s");
            let same = (budget.fract() == 0.0 && (budget as usize) < energies.len())
                .then(|| energies[budget as usize].to_bits() == end.energy.to_bits());
            if budget == 0.0 {
                // The long run's initial point: what a run without swaps costs.
                curve[0].seconds = Some(seconds);
            } else if budget.fract() != 0.0 {
                curve.push(Point {
                    budget,
                    energy: end.energy,
                    seconds: Some(seconds),
                });
            }
            let quality = Quality::of_values(w, h, d, &first_component(&volume, signed));
            let mut row = vec![
                Cell::text(name),
                Cell::sig(budget, 3),
                Cell::int(0),
                Cell::sig(seconds, 3),
                Cell::int(timing.runs.len() as u64),
                Cell::sig(end.energy, 12),
                Cell::fixed(end.energy / pixels as f64, 5),
                Cell::sig(100.0 * (end.energy / last - 1.0), 3),
                Cell::fixed(end.swaps_accepted as f64 / pixels as f64, 3),
                same.map_or_else(Cell::missing, Cell::yes_no),
            ];
            row.extend(quality.cells());
            table.push(row);
            if budget > 0.0 {
                times.points.push((budget, seconds));
            }
        }
        time_series.push(times);
        curve.sort_by(|a, b| a.budget.total_cmp(&b.budget));
        let decrease = initial - last;
        let first_within = |ok: &dyn Fn(f64) -> bool| curve.iter().find(|p| ok(p.energy)).copied();
        let describe = |p: Option<Point>| match p {
            Some(p) => format!(
                "{} swaps per pixel ({})",
                p.budget,
                p.seconds
                    .map_or("time n/a".to_owned(), |s| format!("{s:.2} s"))
            ),
            None => "not reached".to_owned(),
        };
        let within = first_within(&|e| e <= last * 1.01);
        let ninety = first_within(&|e| initial - e >= 0.9 * decrease);
        let ninety_nine = first_within(&|e| initial - e >= 0.99 * decrease);
        findings.push(format!(
            "{name} {}: the long run ({} swaps per pixel, {long_seconds:.1} s, peak memory {}, \
             estimate {:.1} MB) went from {:.5} to {:.5} energy per pixel ({:.2}% lower). Within \
             1% of its final energy at {}; 90% of the decrease at {}; 99% at {}.",
            size_name(plan.swap_size),
            plan.longest_budget,
            peak.map_or("n/a".to_owned(), |b| format!("{:.1} MB", b as f64 / 1e6)),
            (pixels * spec.bytes_per_pixel()) as f64 / 1e6,
            initial / pixels as f64,
            last / pixels as f64,
            100.0 * decrease / initial,
            describe(within),
            describe(ninety),
            describe(ninety_nine),
        ));
        let mut excess = Series {
            name: name.to_owned(),
            ..Series::default()
        };
        for p in &curve {
            if p.budget > 0.0 {
                excess.points.push((p.budget, 100.0 * p.energy / initial));
            }
            let shown = p.budget.fract() == 0.0
                && (p.budget == 0.0
                    || (p.budget as u64).is_power_of_two()
                    || p.budget == f64::from(plan.longest_budget));
            if shown {
                trace_table.push(vec![
                    Cell::text(name),
                    Cell::sig(p.budget, 3),
                    Cell::int(0),
                    Cell::opt_sig(p.seconds, 3),
                    Cell::fixed(p.energy / pixels as f64, 5),
                    Cell::sig(100.0 * (p.energy / last - 1.0), 3),
                    Cell::fixed(
                        if decrease > 0.0 {
                            100.0 * (initial - p.energy) / decrease
                        } else {
                            100.0
                        },
                        1,
                    ),
                ]);
            }
        }
        excess_series.push(excess);
        findings.push(assignment_rows(
            plan,
            (name, &space),
            last,
            long_seconds,
            &mut table,
            &mut trace_table,
        )?);
    }
    Ok(Section {
        knob: Knob::Swaps,
        title: "3. Vector swap budget (Vec2, UnitVec3)".to_owned(),
        method: format!(
            "`stbn_gen::generate_vector(&VectorSpec::new({w}, {h}, {d}, {}, space)\
             .with_swaps_per_pixel(b).with_assignment_passes(0), observer)` for each budget b \
             (swaps alone; the observer records the energy trace), other fields at their \
             defaults \
             (σi 1.9, σs 1.0, tolerance 5·10⁻³, initial arrangement from a scalar STBN mask: \
             `InitialArrangement::default_for` the space). \
             *Energy* is the optimiser's own objective (the sum over interacting pixel pairs of \
             the paper's §4.2 energy; lower is better) at the end of the run. Pass k of a run \
             draws its proposals from streams keyed by (seed, k), so a run of b whole swaps per \
             pixel is exactly the first b passes of a longer run: the column \"= long run's \
             trace\" checks that bit for bit against one run of {} swaps per pixel, whose energy \
             after each pass (and the time since it started, from the progress callback) gives \
             the second table and the curve. Its final energy is the reference of the \
             \"above … final\" columns. Quality columns: the first component of each value, \
             mapped to [0, 1] ((x + 1)/2 for UnitVec3). They are not the optimiser's \
             objective, and the step integrand [x < ½] of the MC and EMA columns is a special \
             case here: the initial arrangement makes the first component follow the ranks of a scalar \
             STBN mask (Vec2) or hands out values in Hilbert-curve order by those ranks, the \
             first half of that curve being the half x < ½ of the value box (UnitVec3), so at \
             budget 0 this integrand converges as the scalar mask of the same size does \
             (compare section 1), and swaps, which lower the energy of the whole vector, give \
             some of that back. The rows with assignment passes run \
             {} swaps per pixel and then a passes (`.with_assignment_passes(a)`); their trace \
             is one run of {} passes, and their \"above … final\" columns compare with the \
             swap-only long run, so a negative value beats it. Their accepted swaps count each \
             kept permutation as one.",
            plan.seed,
            plan.longest_budget,
            plan.assignment_swaps,
            plan.assignment_passes.last().copied().unwrap_or(0),
        ),
        tables: vec![
            (
                "swaps".to_owned(),
                "Budgets run one by one (swaps alone, then swaps and assignment passes)."
                    .to_owned(),
                table,
            ),
            (
                "swaps_trace".to_owned(),
                format!(
                    "The long run ({} swaps per pixel), at 0, 1, 2, 4, … swaps per pixel; then \
                     the run of {} swaps per pixel and {} assignment passes, at 1, 2, 4, … \
                     passes.",
                    plan.longest_budget,
                    plan.assignment_swaps,
                    plan.assignment_passes.last().copied().unwrap_or(0),
                ),
                trace_table,
            ),
        ],
        charts: vec![
            (
                "swaps_energy".to_owned(),
                Chart {
                    title: "Energy against the budget".to_owned(),
                    x: Axis::log("swaps per pixel"),
                    y: Axis::linear("energy, % of the initial (budget 0) energy"),
                    series: excess_series,
                    legend: SeriesLabelPosition::LowerLeft,
                    reference: None,
                },
            ),
            (
                "swaps_time".to_owned(),
                Chart {
                    title: "Generation time against the budget".to_owned(),
                    x: Axis::log("swaps per pixel"),
                    y: Axis::log("seconds"),
                    series: time_series,
                    legend: SeriesLabelPosition::UpperLeft,
                    reference: None,
                },
            ),
        ],
        findings,
    })
}

/// The rows of `space` with assignment passes: `plan.assignment_swaps` swaps per pixel, then each
/// count of `plan.assignment_passes` run on its own (time, energy, quality) into `table`, and the
/// per-pass trace of the longest into `trace_table`. Energies are compared with `swap_final`, the
/// final energy of the swap-only long run that took `swap_seconds`; returns the finding.
fn assignment_rows(
    plan: &Plan,
    (name, space): (&str, &SampleSpace),
    swap_final: f64,
    swap_seconds: f64,
    table: &mut Table,
    trace_table: &mut Table,
) -> Result<String> {
    let (w, h, d) = plan.swap_size;
    let pixels = (u64::from(w) * u64::from(h) * u64::from(d)) as f64;
    let swaps = plan.assignment_swaps;
    let spec_with = |passes: u32| {
        VectorSpec::new(w, h, d, plan.seed, space.clone())
            .with_swaps_per_pixel(swaps)
            .with_assignment_passes(passes)
    };
    let Some(&longest) = plan.assignment_passes.last() else {
        return Ok(format!("{name}: no assignment passes asked for."));
    };
    // The longest run, with the time at the end of every pass.
    let (trace, stamps) = generate_stamped(&spec_with(longest), Instant::now())?;
    let energies: Vec<f64> = trace.points.iter().map(|p| p.energy).collect();
    let swap_passes = swaps.ceil() as usize;
    let mut summary = Vec::new();
    for &passes in &plan.assignment_passes {
        let spec = spec_with(passes);
        let (made, timing) = timed(plan.max_runs, plan.min_total, || generate_traced(&spec));
        let (volume, trace) = made?;
        if !timing.repeatable {
            return Err(format!("{name}, {passes} assignment passes: repeated runs differ").into());
        }
        let end = trace.points.last().expect("a trace has its initial point");
        let seconds = timing.median();
        outln!(
            "  {name}: {swaps} swaps per pixel and {passes} assignment passes in {seconds:.3} s"
        );
        let same = energies
            .get(swap_passes + passes as usize)
            .map(|e| e.to_bits() == end.energy.to_bits());
        let excess = 100.0 * (end.energy / swap_final - 1.0);
        let quality = Quality::of_values(w, h, d, &first_component(&volume, is_signed(space)));
        let mut row = vec![
            Cell::text(name),
            Cell::sig(swaps, 3),
            Cell::int(u64::from(passes)),
            Cell::sig(seconds, 3),
            Cell::int(timing.runs.len() as u64),
            Cell::sig(end.energy, 12),
            Cell::fixed(end.energy / pixels, 5),
            Cell::sig(excess, 3),
            Cell::fixed(end.swaps_accepted as f64 / pixels, 3),
            same.map_or_else(Cell::missing, Cell::yes_no),
        ];
        row.extend(quality.cells());
        table.push(row);
        summary.push(format!(
            "{passes} passes in {seconds:.2} s end {excess:+.3}%"
        ));
    }
    let initial = energies[0];
    let decrease = initial - swap_final;
    // From the first pass on: the point before it is the swap-only trace's.
    for (k, &energy) in energies.iter().enumerate().skip(swap_passes + 1) {
        let passes = (k - swap_passes) as u64;
        if passes.is_power_of_two() || passes == u64::from(longest) {
            trace_table.push(vec![
                Cell::text(name),
                Cell::sig(swaps, 3),
                Cell::int(passes),
                Cell::opt_sig(k.checked_sub(1).and_then(|i| stamps.get(i).copied()), 3),
                Cell::fixed(energy / pixels, 5),
                Cell::sig(100.0 * (energy / swap_final - 1.0), 3),
                Cell::fixed(
                    if decrease > 0.0 {
                        100.0 * (initial - energy) / decrease
                    } else {
                        100.0
                    },
                    1,
                ),
            ]);
        }
    }
    Ok(format!(
        "{name}: {swaps} swaps per pixel and then {}, against the final energy of {} swaps per \
         pixel alone ({swap_seconds:.1} s; negative is lower).",
        summary.join(", "),
        plan.longest_budget
    ))
}
