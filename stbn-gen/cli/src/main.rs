//! `stbn-gen`: generate the masks of an `assets.ron` manifest as PNG slices, or analyse folders of
//! PNG slices, and write a quality report (`report.md`) for either.

mod analyze;
mod generate;
mod report;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

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
    /// Generate every mask of a manifest: PNG slices in `<OUT>/<name>/` and `<OUT>/report.md`.
    ///
    /// Slices are 8-bit for `Unorm8` masks and 16-bit otherwise.
    Generate {
        /// The `assets.ron` manifest.
        manifest: PathBuf,
        /// Output folder (created if needed).
        #[arg(long)]
        out: PathBuf,
    },
    /// Analyse folders of `<name>_<z>.png` slices (from `generate` or elsewhere) and write
    /// `<OUT>/report.md`.
    Analyze {
        /// Folders of slices, one mask each.
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
        /// Folder for report.md (created if needed).
        #[arg(long)]
        out: PathBuf,
    },
}

fn main() -> ExitCode {
    let result = match Cli::parse().command {
        Command::Generate { manifest, out } => generate::run(&manifest, &out),
        Command::Analyze { dirs, out } => analyze::run(&dirs, &out),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {error}");
            ExitCode::FAILURE
        }
    }
}
