//! Build-script support for embedding spatiotemporal blue-noise masks.
//!
//! Masks are declared in a RON manifest (see [`manifest`] for the format), generated with
//! [`stbn_gen`], encoded as `.stbn` blobs ([`encode`]), cached across builds ([`cache`]) and
//! embedded as `static`s that [`stbn_runtime`] samples without allocating ([`codegen`]).
//!
//! # Use
//!
//! `build.rs`, whose `main` needs only this line:
//! ```no_run
//! stbn_build_support::embed_or_exit("assets.ron");
//! ```
//!
//! The crate (which depends on `stbn-runtime` only):
//! ```ignore
//! pub mod masks {
//!     include!(concat!(env!("OUT_DIR"), "/stbn_assets.rs"));
//! }
//! let value = masks::SCALAR_64.sample(x, y, frame);
//! ```
//!
//! Cargo.toml, with the profile that makes generation fast (at opt-level 0 it is about 50×
//! slower, with debug assertions and overflow checks about 3×; [`embed`] warns when it is):
//! ```toml
//! [build-dependencies]
//! stbn-build-support = "0.1"
//!
//! [profile.dev.build-override]
//! opt-level = 3
//! debug-assertions = false
//! overflow-checks = false
//!
//! [profile.release.build-override]
//! opt-level = 3
//! debug-assertions = false
//! overflow-checks = false
//! ```
//!
//! # Features
//!
//! None is on by default: a build script compiles the generators, the encoder, the cache and
//! the code generator, and no image codec, spectral analysis or plotting.
//!
//! * `images`: the image kinds (`ImagePoints`, `EnvironmentMap`), which read PNG and Radiance
//!   `.hdr` files. Without it a manifest that declares one fails at its `image` field, naming
//!   the feature.
//!
//! # Pieces
//!
//! * [`Manifest::load`] / [`Manifest::parse`]: the validated list of [`MaskEntry`]s; every error is
//!   a [`ManifestError`] naming file, line, column and field.
//! * [`MaskEntry::recipe`] / [`Recipe::make`]: what to generate for a mask, generated and encoded.
//! * [`encode::encode_volume`] / [`encode::encode_vector`]: a generated volume as a complete blob.
//! * [`Cache`]: content-addressed blob cache with verified reads and atomic writes; listed and
//!   pruned with [`Cache::entries`] and [`Cache::prune`] (`stbn-gen cache` on the command line).
//! * [`codegen::assets_rs`]: the module source.
//! * [`embed`] / [`embed_with`] / [`embed_or_exit`]: all of the above for a build script.

#![warn(missing_docs)]

pub mod cache;
pub mod codegen;
mod embed;
pub mod encode;
mod error;
pub mod manifest;
mod quote;
pub mod recipe;
mod source;

pub use cache::{Cache, CacheKey, CacheStatus};
pub use embed::{
    ASSETS_RS, BLOB_DIR, EmbedConfig, EmbedReport, MaskReport, embed, embed_or_exit, embed_with,
};
pub use error::{Error, ManifestError};
pub use manifest::{ImageSource, Manifest, MaskEntry, MaskKind, Method};
pub use recipe::{Generated, Recipe};
