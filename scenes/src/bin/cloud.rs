//! Single-scattering heterogeneous cloud with the four noises (free-flight distances from the
//! mask). `cargo run --release -p stbn-scenes --bin cloud -- --help`

use clap::Parser;
use stbn_scenes::cli::{Options, Study, run};
use stbn_scenes::cloud::Cloud;

/// Voxels per axis of the cloud's density grid.
const GRID_N: u32 = 64;

fn main() {
    let options = Options::parse();
    let cloud = Cloud::standard(options.size, options.size, GRID_N, options.seed);
    if let Err(e) = run(&options, Study::AllSources, &[&cloud]) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}
