//! Generates (or fetches from the cache) the masks declared in `assets.ron` and writes
//! `$OUT_DIR/stbn_assets.rs`, which `src/lib.rs` includes.

fn main() {
    stbn_build_support::embed_or_exit("assets.ron");
}
