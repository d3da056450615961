//! Hands the optimisation level this crate is compiled with to its code: `embed` warns when the
//! build script it runs in is unoptimised (Cargo compiles both with the same build-override
//! profile).

fn main() {
    let level = std::env::var("OPT_LEVEL").unwrap_or_default();
    println!("cargo::rustc-env=STBN_BUILD_SUPPORT_OPT_LEVEL={level}");
    println!("cargo::rerun-if-changed=build.rs");
}
