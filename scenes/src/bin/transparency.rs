//! Stochastic transparency with the four noises: a 50%-alpha layer and an alpha-ramp layer over
//! black. `cargo run --release -p stbn-scenes --bin transparency -- --help`

use clap::Parser;
use stbn_scenes::cli::{Options, Study, run};
use stbn_scenes::transparency::{AlphaMode, Transparency};

fn main() {
    let options = Options::parse();
    let half = Transparency::new(options.size, options.size, AlphaMode::Constant(0.5));
    let ramp = Transparency::new(options.size, options.size, AlphaMode::Ramp);
    if let Err(e) = run(&options, Study::AllSources, &[&half, &ramp]) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}
