//! `no_std` sampler for embedded spatiotemporal blue-noise (STBN) masks.
//!
//! A mask is a `width × height × depth` torus of 1–4 channel values (a value per pixel per
//! frame), declared once in a manifest, `assets.ron`:
//!
//! ```ron
//! (masks: [(name: "scalar_64", kind: Scalar, size: (64, 64, 32), seed: 7, encoding: Unorm8)])
//! ```
//!
//! # Two ways to embed a mask
//!
//! **Generated in `build.rs`**: declare and forget. `Cargo.toml` lists `stbn-runtime` under
//! `[dependencies]` and `stbn-build-support` under `[build-dependencies]`; `build.rs` is one line
//! and the crate includes one `pub static` per mask:
//!
//! ```ignore
//! // build.rs
//! fn main() {
//!     stbn_build_support::embed_or_exit("assets.ron");
//! }
//!
//! // src/lib.rs: `pub static SCALAR_64: Stbn<'static>` (`PackedStbn` when compressed)
//! mod masks {
//!     include!(concat!(env!("OUT_DIR"), "/stbn_assets.rs"));
//! }
//! let threshold = masks::SCALAR_64.sample(x, y, frame);
//! ```
//!
//! **Committed blobs**: no generator in the build. Generate the masks once, review
//! `assets/report.md`, commit the `.stbn` files and embed them with [`include_stbn!`] (or
//! [`include_packed_stbn!`] for compressed ones); `stbn-runtime` is the only dependency:
//!
//! ```sh
//! stbn-gen generate assets.ron --format stbn --out assets/
//! ```
//! ```
//! use stbn_runtime::{Stbn, include_stbn};
//!
//! // `assets/scalar_64.stbn` in a game; here the 16×16×8 mask in this crate's tests/data.
//! static SCALAR_16: Stbn<'static> = include_stbn!("../tests/data/scalar_16.stbn");
//!
//! let threshold = SCALAR_16.sample(100, -3, 1_000_000);
//! assert!(threshold > 0.0 && threshold < 1.0);
//! ```
//!
//! Both give the same bytes and the same statics, checked while compiling: a broken blob fails
//! the build. Pick `build.rs` to edit the manifest and rebuild (masks are cached across builds and
//! regenerated only when their entry changes, but every clean build compiles the generator);
//! pick committed blobs to keep the generator out of the build and CI entirely, with masks that
//! change only when someone regenerates and reviews them.
//!
//! # The format
//!
//! A `.stbn` blob is a 64-byte [`MaskHeader`] followed by the payload, optionally LZ4- or
//! Deflate-compressed. It is sampled with no allocation:
//!
//! * [`Stbn`] is the sampling view over decoded data. For an uncompressed blob it
//!   is zero-copy and can be built in a `static` with the `const fn`
//!   [`Stbn::from_bytes_unverified`] (what [`include_stbn!`] does).
//! * [`PackedStbn`] validates a blob of any compression and decodes it into a
//!   caller-provided buffer ([`PackedStbn::decode_into`]) or, with the `alloc`
//!   feature, into an `OwnedStbn`.
//!
//! Sampling is toroidal on every axis and accepts every `i32`/`u32` coordinate.
//! Values are the stored unit values: Unorm8/Unorm16 decode to bin midpoints
//! `(q + 0.5) / 2^bits` in `(0, 1)`, F32 values are as stored, in `[0, 1]`.
//!
//! # What a mask promises
//!
//! The verified constructors ([`Stbn::from_bytes`], [`PackedStbn::from_bytes`]) and the
//! decoders ([`PackedStbn::decode_into`], `PackedStbn::decode`) check every stored value once
//! ([`Stbn::verify`]) and refuse a blob that breaks a promise with [`Error::InvalidValue`],
//! naming the voxel and channel. A view they return samples only finite values in `[0, 1]`
//! (signed components in `[-1, 1]`), directions of unit length within
//! [`UNIT_LENGTH_TOLERANCE`] (`z >= 0` for hemispheres), and finite pdfs `>= 0`. Checking once
//! keeps sampling free of per-sample guards and bit for bit equal to the WGSL snippet's.
//!
//! The `const` constructors ([`Stbn::from_bytes_unverified`], hence [`include_stbn!`], and the
//! uncompressed [`PackedStbn::view`] of [`PackedStbn::from_bytes_unverified`]) check the header
//! and the length at compile time but trust the payload, like its CRC: the blobs the generator
//! writes keep every promise; for other bytes call [`Stbn::verify`] once. Sampling never panics
//! or reads out of bounds on any payload.
//!
//! # Sampling API
//! [`Stbn`] samples at the requested position; [`Stbn::offset`] (a [`SampleOffset`]:
//! x, y and a start frame) and [`Stbn::dimension`] (the R2-sequence offset of sample
//! dimension `i`) return an [`OffsetStbn`], a cheap `Copy` view with the same methods that
//! samples at the shifted position. [`Stbn::progressive`] (or [`OffsetStbn::progressive`]) is
//! the view for renderers that accumulate more frames than the mask holds: frames `0..depth`
//! are unchanged, and each later pass through the depth reads the mask at a new R2 offset, so a
//! pixel's running mean keeps converging where [`Stbn::sample`] repeats the same `depth` values.
//! All of them offer:
//!
//! | method | returns |
//! |---|---|
//! | `sample(x, y, frame)` | channel 0, the stored unit value |
//! | `sample_channel(x, y, frame, c)` | channel `c` (panics if `c >= channels`) |
//! | `sample_vector(x, y, frame)` | the decoded [`VectorSample`]: value and pdf |
//! | `sample_vec2` / `sample_vec3` / `sample_vec4` | the decoded value's first 2 / 3 / 4 components |
//! | `sample_pdf(x, y, frame)` | the pdf alone |
//! | `fill_row(x0, y, frame, out)` | channel 0 of a run of x into `out` |
//! | `fill_frame(frame, out)` | channel 0 of a whole frame into `out`, row-major |
//!
//! # Features
//! * `alloc` (off by default): `PackedStbn::decode` and `OwnedStbn`.
//! * `wgpu` (off by default, implies `alloc` and uses `std`): the
#![cfg_attr(feature = "wgpu", doc = "   [`gpu`] module,")]
#![cfg_attr(not(feature = "wgpu"), doc = "   `gpu` module,")]
//!   which uploads masks as wgpu textures (`create_texture_3d`, `create_texture_2d_array`) and
//!   ships the WGSL sampling snippet `gpu::WGSL`. These docs show it when built with the feature,
//!   as docs.rs builds them (`cargo doc --features wgpu` locally).
//!
//! # Example
//! ```
//! use stbn_runtime::glam::Vec3;
//! use stbn_runtime::{SampleOffset, Stbn, include_stbn};
//!
//! // Blobs written by `stbn-gen generate … --format stbn` (or embedded by build.rs): a 16×16×8
//! // scalar mask and an 8×8×4 mask of cosine-weighted hemisphere directions, from this crate's
//! // tests/data. The header and length are checked at compile time.
//! static MASK: Stbn<'static> = include_stbn!("../tests/data/scalar_16.stbn");
//! static DIRECTIONS: Stbn<'static> = include_stbn!("../tests/data/cosine_8.stbn");
//!
//! // Check the payload CRC and every stored value once, e.g. in a unit test or at start-up.
//! MASK.verify()?;
//! DIRECTIONS.verify()?;
//!
//! // Point sampling wraps on all axes.
//! let v = MASK.sample(21, -1, 11);
//! assert_eq!(v, MASK.sample(5, 15, 3));
//! assert!((0.0..1.0).contains(&v));
//!
//! // Offset views: a decorrelated value for sample dimension 1, and a start-frame offset.
//! let _second_dimension = MASK.dimension(1).sample(5, -1, 3);
//! let late_start = MASK.offset(SampleOffset { x: 0, y: 0, frame: 1 });
//! assert_eq!(late_start.sample(5, -1, 3), MASK.sample(5, 15, 4));
//!
//! // A whole frame at once, row-major.
//! let mut frame = [0.0f32; 16 * 16];
//! assert_eq!(MASK.fill_frame(0, &mut frame), 256);
//! assert_eq!(frame[16 + 1], MASK.sample(1, 1, 0));
//!
//! // The direction of sample dimension 2, shifted 3 voxels along x, with its pdf.
//! let view = DIRECTIONS.dimension(2).offset(SampleOffset { x: 3, y: 0, frame: 0 });
//! let d: Vec3 = view.sample_vec3(1, 1, 0);
//! assert!((d.length() - 1.0).abs() < 1e-6 && d.z >= 0.0);
//! let ray = view.sample_vector(1, 1, 0);
//! assert_eq!(ray.value.truncate(), d);
//! assert_eq!(ray.pdf, d.z / core::f32::consts::PI);
//! # Ok::<(), stbn_runtime::Error>(())
//! ```
#![no_std]
// docs.rs (`--cfg docsrs`, nightly): every feature-gated item shows the feature it needs.
#![cfg_attr(docsrs, feature(doc_cfg))]
// `unsafe` only behind `#[allow(unsafe_code)]`, each with a measured reason: the square-root
// instructions (`sqrt.rs`), and the AVX2 build of the vector fills (its detection in `wide.rs`,
// its calls in `vector.rs`).
#![deny(unsafe_code)]
#![warn(missing_docs)]

#[cfg(feature = "alloc")]
extern crate alloc;

mod embed;
mod error;
#[cfg(feature = "wgpu")]
pub mod gpu;
mod header;
mod offset;
mod packed;
mod sampler;
mod sqrt;
mod vector;
mod verify;
#[cfg(target_arch = "x86_64")]
mod wide;

#[doc(hidden)]
pub use embed::__private;
pub use embed::BLOB_ALIGN;
pub use error::Error;
/// The glam version whose `Vec2`/`Vec3`/`Vec4` the vector samplers return.
pub use glam;
pub use header::{Compression, Encoding, MAX_DECODED_BYTES, MaskHeader, Space, ValueMap};
pub use offset::{OffsetStbn, SampleOffset};
#[cfg(feature = "alloc")]
pub use packed::OwnedStbn;
pub use packed::PackedStbn;
pub use sampler::Stbn;
pub use vector::{VectorOutput, VectorSample, octahedral_decode, octahedral_encode};
pub use verify::UNIT_LENGTH_TOLERANCE;
