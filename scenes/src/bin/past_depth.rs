//! Stochastic transparency at alpha 0.5 over 1024 frames, 16 passes through a 64-frame mask:
//! white noise, STBN read with plain `sample` (repeating every 64 frames) and STBN read through
//! `Stbn::progressive`, with the error image's low-band power and DFT images beside the RMSE.
//! `cargo run --release -p stbn-scenes --bin past_depth -- --help`

use stbn_scenes::cli::{Options, Study, run};
use stbn_scenes::transparency::{AlphaMode, Transparency};

fn main() {
    let options = Options::parse_with_checkpoints("16,64,256,1024");
    let half = Transparency::new(options.size, options.size, AlphaMode::Constant(0.5));
    if let Err(e) = run(&options, Study::PastDepth, &[&half]) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}
