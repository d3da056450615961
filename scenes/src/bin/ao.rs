//! Ambient occlusion on a heightfield with white cosine vectors, scalar STBN pairs and vector
//! STBN. `cargo run --release -p stbn-scenes --bin ao -- --help`

use clap::Parser;
use stbn_scenes::ao::AmbientOcclusion;
use stbn_scenes::cli::{Options, Study, run};

/// Texels per axis of the terrain's heightfield.
const TERRAIN_N: u32 = 128;

fn main() {
    let options = Options::parse();
    let ao = AmbientOcclusion::standard(options.size, options.size, TERRAIN_N, options.seed);
    if let Err(e) = run(&options, Study::AllSources, &[&ao]) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}
