//! Headless demo scenes that show what spatiotemporal blue noise (STBN) buys over white noise,
//! independent 2D blue noise and golden-ratio animated 2D blue noise (scalar scenes), and what
//! vector STBN buys over white vectors and pairs of scalar STBN values (the AO scene).
//!
//! Every scene draws one random sample per pixel per frame from a mask, accumulates 64 frames
//! with an EMA (α = 0.1, as TAA does) and a running mean, and measures the RMSE and the error
//! image's low-band power against a converged ground truth after 1, 4, 16 and 64 frames (the
//! past-depth study, [`cli::Study::PastDepth`]: 1024 frames, with STBN read both wrapping and
//! through `Stbn::progressive`). The masks come from `stbn-gen`, are encoded as `.stbn` blobs
//! and read through `stbn-runtime`: [`render`] on the CPU, [`gpu`] through wgpu compute shaders
//! that sample with the runtime's WGSL snippet.
//!
//! - [`noise`]: the sources; [`sample`]: how a pixel reads its sample; [`scene`]: the [`Scene`]
//!   trait.
//! - [`transparency`]: stochastic transparency (binary alpha test).
//! - [`cloud`] (with [`density`]): single scattering in a heterogeneous volume, free-flight
//!   distances from the mask.
//! - [`ao`] (with [`heightfield`]): ambient occlusion with cosine-distributed directions.
//! - [`procedural`]: value noise for the content.
//! - [`accumulate`], [`image`], [`compare`], [`report`], [`strip`], [`cli`]: accumulation,
//!   RMSE, the comparison, its tables, PNG strips and the binaries' shared command line.

pub mod accumulate;
pub mod ao;
pub mod cli;
pub mod cloud;
pub mod compare;
pub mod density;
pub mod gpu;
pub mod heightfield;
pub mod image;
pub mod noise;
pub mod procedural;
pub mod render;
pub mod report;
pub mod sample;
pub mod scene;
pub mod strip;
pub mod transparency;

pub use compare::{Accumulation, Backend, Comparison};
pub use noise::{NoiseKind, NoiseMask, NoiseSpec};
pub use scene::{Scene, SceneInput};
