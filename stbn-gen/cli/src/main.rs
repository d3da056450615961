//! `stbn-gen`: generate the masks of an `assets.ron` manifest as PNG slices, KTX2 textures or
//! `.stbn` blobs, or analyse folders of PNG slices, and write a quality report (`report.md`) for
//! either.

/// `println!` that cannot panic: a line to stdout, dropped if stdout is closed (`| head -1`
/// closes the pipe; the run goes on and commits its output).
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::write_line(&mut std::io::stdout(), format_args!($($arg)*))
    };
}

/// `eprintln!` that cannot panic: a line to stderr, dropped if stderr is closed.
macro_rules! errln {
    ($($arg:tt)*) => {
        $crate::write_line(&mut std::io::stderr(), format_args!($($arg)*))
    };
}

mod analyze;
mod cache;
mod generate;
mod ktx2;
mod output;
mod pairs;
mod past_depth;
mod report;
mod staging;
mod tradeoff;
mod vector;

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

use crate::generate::OutputFormat;

/// What every command returns: errors are printed with their `Display` and end the process with
/// status 1.
type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

#[derive(Parser)]
#[command(version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Generate every mask of a manifest: PNG slices in `<OUT>/<name>/` (or `<OUT>/<name>.ktx2`
    /// with `--format ktx2`, `<OUT>/<name>.stbn` with `--format stbn`) and `<OUT>/report.md`.
    ///
    /// Slices are 8-bit for `Unorm8` masks and 16-bit otherwise; vector masks get RGBA slices
    /// (values in R, G, B; the pdf, or full scale, in A), a `<name>.json` sidecar describing the
    /// channels with the optimiser's energy trace, and the trace as `<name>_trace.csv`. KTX2
    /// files are 3D textures (depth = frames) in the mask's own encoding and channel count
    /// (R8_UNORM … R32G32B32A32_SFLOAT). `.stbn` files are the blobs `stbn-build-support` embeds
    /// for the same entries, to commit and embed with `stbn_runtime::include_stbn!`.
    Generate {
        /// The `assets.ron` manifest.
        manifest: PathBuf,
        /// Output folder (created if needed). Only what stbn-gen wrote there is replaced (listed
        /// in `<OUT>/.stbn-gen/output`); anything else in the way is refused before any work,
        /// other files are left alone. The output switches in whole when the run is done.
        #[arg(long)]
        out: PathBuf,
        /// Output format of the masks.
        #[arg(long, value_enum, default_value_t = OutputFormat::Png)]
        format: OutputFormat,
        /// Run every swap-optimised mask (the vector kinds and `FilterAdapted`) with this budget
        /// instead of its manifest's `swaps_per_pixel`: swaps proposed per pixel, 0 to 10000.
        /// Time grows linearly with it; 16–32 makes quick drafts (BENCHMARKS.md has the time and
        /// quality per budget). The manifest file is not changed.
        #[arg(
            long,
            value_name = "N",
            value_parser = parse_swaps_per_pixel,
            allow_negative_numbers = true
        )]
        swaps_per_pixel: Option<f64>,
    },
    /// Analyse folders of `<name>_<z>.png` slices (from `generate` or elsewhere) and write
    /// `<OUT>/report.md`.
    Analyze {
        /// Folders of slices, one mask each.
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
        /// Folder for report.md (created if needed; only what stbn-gen wrote there is replaced,
        /// see `generate --help`).
        #[arg(long)]
        out: PathBuf,
        /// Also measure six baselines generated from this seed at each mask size, side by side:
        /// white noise, independent 2D and isotropic 3D blue noise, golden-ratio and random-shift
        /// animated 2D blue noise, and Tellusim's layered masks; then the STBN (`Scalar`) and
        /// filter-adapted (`FilterAdapted`) masks of that size and seed for reference.
        #[arg(long, value_name = "SEED")]
        baselines: Option<u64>,
    },
    /// Measure what each knob of a mask costs against what it buys (size and depth, σ and
    /// kernel tolerance, vector swap budget, encoding, compression, thread count, the scale
    /// targets): CSV files, markdown tables and PNG plots per knob, gathered in
    /// `<OUT>/tradeoff.md`.
    Tradeoff {
        /// Output folder (created if needed; only what stbn-gen wrote there is replaced, see
        /// `generate --help`).
        #[arg(long)]
        out: PathBuf,
        /// Small masks and few points (a check that runs in seconds; not figures to quote).
        #[arg(long)]
        quick: bool,
        /// Only these knobs (comma-separated); all by default.
        #[arg(long, value_enum, value_delimiter = ',')]
        only: Vec<tradeoff::Knob>,
    },
    /// Show the build-script blob cache (entries by last use, sizes, orphaned temporary files)
    /// and prune it: `--prune-to SIZE` removes the least recently used entries, `--older-than
    /// DAYS` those unused that long; `--keep MANIFEST` protects a manifest's entries.
    Cache(cache::Args),
}

/// `--swaps-per-pixel`: a finite number in the range both swap optimisers accept.
fn parse_swaps_per_pixel(text: &str) -> std::result::Result<f64, String> {
    let max = stbn_gen::VectorSpec::MAX_SWAPS_PER_PIXEL
        .min(stbn_gen::FilterAdaptedSpec::MAX_SWAPS_PER_PIXEL);
    match text.parse::<f64>() {
        Ok(n) if (0.0..=max).contains(&n) => Ok(n),
        _ => Err(format!("must be a number in 0..={max} (got {text:?})")),
    }
}

fn main() -> ExitCode {
    let result = match Cli::parse().command {
        Command::Generate {
            manifest,
            out,
            format,
            swaps_per_pixel,
        } => generate::run(&manifest, &out, format, swaps_per_pixel),
        Command::Analyze {
            dirs,
            out,
            baselines,
        } => analyze::run(&dirs, &out, baselines),
        Command::Tradeoff { out, quick, only } => tradeoff::run(&out, quick, &only),
        Command::Cache(args) => cache::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            errln!("error: {error}");
            ExitCode::FAILURE
        }
    }
}

/// Writes `args` and a line break to `stream`, ignoring errors (a closed pipe above all): what
/// the command prints is a courtesy, its output folder the result.
fn write_line(stream: &mut dyn Write, args: std::fmt::Arguments<'_>) {
    let _ = stream
        .write_fmt(args)
        .and_then(|()| stream.write_all(b"\n"))
        .and_then(|()| stream.flush());
}
