//! `stbn-gen tradeoff`: what each knob of a mask costs (time, memory, bytes) against what it buys
//! (the quality figures of `stbn_gen::analysis`), as CSV files, markdown tables and PNG plots,
//! gathered in `<out>/tradeoff.md`.
//!
//! Knobs ([`Knob`]): mask size and depth, σ and the kernel truncation tolerance, the vector swap
//! budget, the encoding, the compression; and the scale checks: thread-count determinism and
//! speed-up, and the 256×256×128 scalar / 256×256×64 vector masks against their time targets;
//! and how masks read past their depth converge (wrap, progressive, rejected schedules).
//! Every mask uses seed 7. `--quick` runs the same code on small masks (for CI, well under a
//! minute in a debug build); its figures are not the ones to quote.

mod measure;
mod progressive;
mod scalar;
mod scale;
mod storage;
mod swaps;

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use clap::ValueEnum;
use stbn_gen::VectorSpec;

use crate::Result;
use crate::output::{self, Chart, Table};
use crate::staging::Staging;

/// One measured knob (a section of tradeoff.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, ValueEnum)]
pub enum Knob {
    /// Scalar mask size (32² … 256²) and depth (8 … 128 frames).
    Size,
    /// σ and the kernel truncation tolerance of the scalar generator.
    Kernel,
    /// Swap budget of the vector optimiser (Vec2, UnitVec3).
    Swaps,
    /// Unorm8 / Unorm16 / F32, octahedral or three signed channels for unit vectors.
    Encoding,
    /// None / Lz4 / Deflate: embedded bytes and decode time.
    Compression,
    /// One thread against two: time and identical output.
    Threads,
    /// The largest masks against their time targets: scalar 256×256×128, Vec2 256×256×64.
    Scale,
    /// Masks read past their depth: wrap, progressive and white noise, the rejected schedules,
    /// N samples per pixel per frame.
    PastDepth,
}

impl Knob {
    /// Every knob, in report order.
    pub const ALL: [Knob; 8] = [
        Knob::Size,
        Knob::Kernel,
        Knob::Swaps,
        Knob::Encoding,
        Knob::Compression,
        Knob::Threads,
        Knob::Scale,
        Knob::PastDepth,
    ];

    /// The file stem of its section, `size` … `past-depth`.
    pub fn key(self) -> &'static str {
        match self {
            Knob::Size => "size",
            Knob::Kernel => "kernel",
            Knob::Swaps => "swaps",
            Knob::Encoding => "encoding",
            Knob::Compression => "compression",
            Knob::Threads => "threads",
            Knob::Scale => "scale",
            Knob::PastDepth => "past-depth",
        }
    }
}

/// The masks and values each knob measures, full or quick.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// `--quick`.
    pub quick: bool,
    /// Seed of every mask.
    pub seed: u64,
    /// Runs of one timed generation at most (more only while the runs total under
    /// `min_total` seconds); the median is reported.
    pub max_runs: usize,
    /// See `max_runs`.
    pub min_total: f64,
    /// Slice sides of the size knob.
    pub sides: Vec<u32>,
    /// Depths of the size knob.
    pub depths: Vec<u32>,
    /// Mask of the σ / tolerance knob.
    pub kernel_size: (u32, u32, u32),
    /// σ values (tolerance at its default).
    pub sigmas: Vec<f64>,
    /// Tolerances (σ at its default).
    pub tolerances: Vec<f64>,
    /// Vector masks of the swap knob.
    pub swap_size: (u32, u32, u32),
    /// Budgets run one by one, in increasing order.
    pub budgets: Vec<f64>,
    /// Budget of the long run whose per-pass trace gives the curve and the final energy.
    pub longest_budget: u32,
    /// Swaps per pixel before the assignment passes of `assignment_passes`.
    pub assignment_swaps: f64,
    /// Assignment passes after `assignment_swaps` swaps per pixel, each run on its own, in
    /// increasing order; the last run's per-pass trace continues the curve.
    pub assignment_passes: Vec<u32>,
    /// Scalar mask of the encoding knob.
    pub encoding_scalar: (u32, u32, u32),
    /// Vector masks of the encoding and compression knobs.
    pub vector_size: (u32, u32, u32),
    /// Budget of those vector masks.
    pub vector_budget: f64,
    /// Scalar masks of the compression knob.
    pub compression_scalars: Vec<(u32, u32, u32)>,
    /// Scalar mask of the thread check.
    pub threads_scalar: (u32, u32, u32),
    /// Scalar mask of the scale check and its time target in seconds (`None` in quick mode).
    pub scale_scalar: ((u32, u32, u32), Option<f64>),
    /// Vec2 mask of the scale check and its time target in seconds.
    pub scale_vector: ((u32, u32, u32), Option<f64>),
    /// Slice side of the past-depth masks (Unorm16 scalar, square).
    pub past_depth_side: u32,
    /// Depths of the past-depth masks, increasing.
    pub past_depth_depths: Vec<u32>,
    /// Depth of the mask the rejected schedules and the samples-per-frame rows read.
    pub past_depth_alternatives: u32,
    /// Frame counts the past-depth running means are measured after, increasing, `≥ 1`.
    pub past_depth_frames: Vec<usize>,
    /// Frame counts (of several samples each) of the samples-per-frame rows, increasing, `≥ 1`.
    pub past_depth_sample_frames: Vec<usize>,
}

impl Plan {
    /// The full study (the numbers for BENCHMARKS.md; tens of minutes on two cores).
    pub fn full() -> Plan {
        Plan {
            quick: false,
            seed: 7,
            max_runs: 3,
            min_total: 2.0,
            sides: vec![32, 64, 128, 256],
            depths: vec![8, 16, 32, 64, 128],
            kernel_size: (128, 128, 64),
            sigmas: vec![1.0, 1.5, 1.9, 2.5, 3.0],
            tolerances: vec![1e-3, 2e-3, 5e-3, 1e-2, 2e-2, 5e-2],
            swap_size: (64, 64, 32),
            budgets: vec![0.0, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0],
            longest_budget: 1024,
            assignment_swaps: VectorSpec::DEFAULT_SWAPS_PER_PIXEL,
            assignment_passes: vec![VectorSpec::DEFAULT_ASSIGNMENT_PASSES, 64],
            encoding_scalar: (128, 128, 64),
            vector_size: (64, 64, 32),
            vector_budget: 16.0,
            compression_scalars: vec![(64, 64, 32), (128, 128, 64)],
            threads_scalar: (128, 128, 64),
            scale_scalar: ((256, 256, 128), Some(30.0)),
            scale_vector: ((256, 256, 64), Some(300.0)),
            past_depth_side: 64,
            past_depth_depths: vec![16, 32, 64],
            past_depth_alternatives: 32,
            past_depth_frames: vec![64, 256, 1024, 4096],
            past_depth_sample_frames: vec![16, 64, 256],
        }
    }

    /// Small masks and few points: the same code paths in seconds.
    pub fn quick() -> Plan {
        Plan {
            quick: true,
            seed: 7,
            max_runs: 1,
            min_total: 0.0,
            sides: vec![16, 32],
            depths: vec![8, 16],
            kernel_size: (32, 32, 16),
            sigmas: vec![1.5, 1.9, 2.5],
            tolerances: vec![5e-3, 5e-2],
            swap_size: (16, 16, 8),
            budgets: vec![0.0, 0.5, 1.0, 2.0, 4.0],
            longest_budget: 8,
            assignment_swaps: 2.0,
            assignment_passes: vec![1, 2],
            encoding_scalar: (32, 32, 16),
            vector_size: (16, 16, 8),
            vector_budget: 4.0,
            compression_scalars: vec![(32, 32, 16)],
            threads_scalar: (32, 32, 16),
            scale_scalar: ((64, 64, 16), None),
            scale_vector: ((32, 32, 8), None),
            past_depth_side: 16,
            past_depth_depths: vec![8, 16],
            past_depth_alternatives: 8,
            past_depth_frames: vec![16, 64],
            past_depth_sample_frames: vec![4, 16],
        }
    }
}

/// One knob's results: what tradeoff.md shows and the files behind it.
pub struct Section {
    /// Which knob.
    pub knob: Knob,
    /// Heading.
    pub title: String,
    /// What was measured and how (markdown).
    pub method: String,
    /// `(file stem, caption, table)`: written as `<stem>.csv`, shown in order.
    pub tables: Vec<(String, String, Table)>,
    /// `(file stem, chart)`: written as `<stem>.png`.
    pub charts: Vec<(String, Chart)>,
    /// Figures derived from the tables (markdown list items).
    pub findings: Vec<String>,
}

/// Runs the knobs of `only` (every knob if empty) with the full plan or, with `quick`, the
/// quick one, writes `<out>/<knob>.md`, its CSV files and plots, and `<out>/tradeoff.md`.
///
/// `out` is checked first: a writable folder holding nothing stbn-gen did not write under the
/// names the chosen knobs write (`tradeoff.md`, `<knob>*.csv`, `<knob>*.png`, `<knob>*.md`).
/// Everything is written into a staging folder and switched in when every knob is done
/// ([`Staging`]): a stopped or failed run leaves the previous output as it was.
pub fn run(out: &Path, quick: bool, only: &[Knob]) -> Result<()> {
    let plan = if quick { Plan::quick() } else { Plan::full() };
    let knobs: Vec<Knob> = if only.is_empty() {
        Knob::ALL.to_vec()
    } else {
        Knob::ALL.into_iter().filter(|k| only.contains(k)).collect()
    };
    let claims = |name: &str| {
        name == "tradeoff.md"
            || knobs.iter().any(|knob| {
                name.starts_with(knob.key())
                    && [".csv", ".png", ".md"].iter().any(|e| name.ends_with(e))
            })
    };
    let staging = Staging::new(out, &claims, 100)?;
    let dir = staging.dir();
    let mut text = header(&plan, &knobs);
    for knob in knobs {
        let (started, load_before) = (measure::utc_now(), measure::load_average());
        outln!("{}: started {started}, load {load_before}", knob.key());
        let clock = Instant::now();
        let section = match knob {
            Knob::Size => scalar::size(&plan),
            Knob::Kernel => scalar::kernel(&plan),
            Knob::Swaps => swaps::run(&plan),
            Knob::Encoding => storage::encoding(&plan),
            Knob::Compression => storage::compression(&plan),
            Knob::Threads => scale::threads(&plan),
            Knob::Scale => scale::scale(&plan),
            Knob::PastDepth => progressive::past_depth(&plan),
        }?;
        let seconds = clock.elapsed().as_secs_f64();
        let load_after = measure::load_average();
        let markdown = write_section(&dir, &section, &started, &load_before, &load_after, seconds)?;
        outln!(
            "{}: {seconds:.1} s, load {load_after}; {}",
            knob.key(),
            section.findings.join(" ")
        );
        text.push_str(&markdown);
    }
    output::write_text(&dir.join("tradeoff.md"), &text)?;
    staging.commit()?;
    outln!("tradeoff: {}", out.join("tradeoff.md").display());
    Ok(())
}

/// The top of tradeoff.md: what ran, where and when.
fn header(plan: &Plan, knobs: &[Knob]) -> String {
    let mode = if plan.quick {
        "`--quick` (small masks, few points: a check of the code, not figures to quote)"
    } else {
        "full"
    };
    let keys: Vec<&str> = knobs.iter().map(|k| k.key()).collect();
    format!(
        "# Speed against quality: what each knob of a mask costs\n\n\
         Written by `stbn-gen tradeoff` ({mode} mode; knobs: {}) on {}; seed {} for every mask.\n\n\
         Machine: {}. Load average (1, 5, 15 min, as `uptime` prints it) at the start: {}. \
         The machine may be shared: every time here is wall-clock and an upper bound for an \
         idle machine; each section gives the load before and after it.\n\n\
         **Time** is the wall-clock time of the generator call alone (not analysis or file \
         writing), {}. **Peak memory** is the resident \
         memory the first run added at its peak: `VmHWM` of `/proc/self/status` after \
         resetting it through `/proc/self/clear_refs` (Linux ≥ 4.0), minus `VmRSS` before the \
         run; the **estimate** beside it is the generator's documented bound \
         (`MaskSpec::BYTES_PER_PIXEL` or `VectorSpec::bytes_per_pixel` × pixels).\n\n{}\n\n\
         Each section's table is also in `<section>.csv` (every digit), its plots in \
         `<section>*.png` and the section alone in `<section>.md`. Runtime sampling costs are \
         measured by `cargo bench -p stbn-runtime --bench sample` (criterion), not here.\n",
        keys.join(", "),
        measure::utc_now(),
        plan.seed,
        measure::machine(),
        measure::load_average(),
        if plan.max_runs > 1 {
            format!(
                "the median of the runs column (a generation is repeated while its runs total \
                 under {} s, at most {} runs; the repeats must return identical masks)",
                plan.min_total, plan.max_runs
            )
        } else {
            "one run each".to_owned()
        },
        measure::QUALITY_LEGEND,
    )
}

/// Writes the section's CSV files, plots and `<knob>.md`; returns its markdown.
fn write_section(
    out: &Path,
    section: &Section,
    started: &str,
    load_before: &str,
    load_after: &str,
    seconds: f64,
) -> Result<String> {
    let mut text = format!(
        "\n## {}\n\nStarted {started}, load average {load_before} before and {load_after} after; \
         the section took {seconds:.1} s in all (generation, analysis and files).\n\n{}\n",
        section.title, section.method
    );
    for (stem, caption, table) in &section.tables {
        let file = format!("{stem}.csv");
        table.write_csv(&out.join(&file))?;
        write!(
            text,
            "\n{caption} ([`{file}`]({file}))\n\n{}",
            table.markdown()
        )
        .expect("String");
    }
    if !section.findings.is_empty() {
        text.push('\n');
        for finding in &section.findings {
            writeln!(text, "- {finding}").expect("String");
        }
    }
    for (stem, chart) in &section.charts {
        let file = format!("{stem}.png");
        chart.write_png(&out.join(&file))?;
        write!(
            text,
            "\n{}\n\n![{}]({file})\n",
            chart.caption(),
            chart.title
        )
        .expect("String");
    }
    output::write_text(&out.join(format!("{}.md", section.knob.key())), &text)?;
    Ok(text)
}

/// `w×h×d`.
fn size_name((w, h, d): (u32, u32, u32)) -> String {
    format!("{w}×{h}×{d}")
}
