//! Demo of the whole spatiotemporal blue-noise (STBN) pipeline: the masks declared in
//! `assets.ron` are generated (or taken from the build cache) by `build.rs` through
//! `stbn-build-support`, embedded in the binary, and sampled here with `stbn-runtime` — without
//! `std` and, for uncompressed masks, without allocating or copying.
//!
//! Each manifest entry becomes a `static` in [`masks`]: an uncompressed mask is a ready
//! [`Stbn`](stbn_runtime::Stbn) view; a compressed one is a
//! [`PackedStbn`](stbn_runtime::PackedStbn) to decode once into a buffer.
//!
//! ```
//! use stbn_demo::masks::{BLUE2D_64, SCALAR_64, SCALAR_64_PALETTE};
//!
//! // Per-pixel, per-frame noise in (0, 1): one lookup, wrapping on all three axes.
//! let (x, y, frame) = (100, -3, 1_000_000);
//! let threshold = SCALAR_64.sample(x, y, frame);
//! assert!(threshold > 0.0 && threshold < 1.0);
//! assert_eq!(threshold, SCALAR_64.sample(100 - 64, -3 + 64, frame + 32));
//!
//! // A second, decorrelated value for another sampling dimension.
//! let _jitter = SCALAR_64.dimension(1).sample(x, y, frame);
//!
//! // Compressed masks decode into a caller-provided buffer (no allocator needed).
//! let mut buffer = vec![0u8; SCALAR_64_PALETTE.decoded_len()];
//! let decoded = SCALAR_64_PALETTE.decode_into(&mut buffer).expect("embedded masks are valid");
//! assert!((decoded.sample(x, y, frame) - threshold).abs() < 1.0 / 256.0);
//!
//! let mut buffer = vec![0u8; BLUE2D_64.decoded_len()];
//! let blue2d = BLUE2D_64.decode_into(&mut buffer).expect("embedded masks are valid");
//! assert_eq!((blue2d.width(), blue2d.height(), blue2d.depth()), (64, 64, 32));
//!
//! // Vector masks: a cosine-weighted hemisphere direction per pixel per frame, with its pdf.
//! use stbn_demo::masks::COSINE_64;
//! let ray = COSINE_64.sample_vector(x, y, frame);
//! assert!((ray.value.length() - 1.0).abs() < 1e-6 && ray.pdf >= 0.0);
//! let direction: stbn_runtime::glam::Vec3 = COSINE_64.sample_vec3(x, y, frame);
//! # let _ = direction;
//! ```
#![no_std]
// The README's snippets are doctests of this crate: what a user pastes must compile without a
// warning.
#![doc(test(attr(deny(warnings))))]

/// The masks declared in `assets.ron`, one `pub static` per entry (the entry's name in upper
/// case), each documented with its kind, size, seed, σ, encoding and compression.
pub mod masks {
    include!(concat!(env!("OUT_DIR"), "/stbn_assets.rs"));
}

/// The README's Rust snippets, compiled (and run where they can) as doctests of this crate, whose
/// `assets.ron` declares the masks they name.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeSnippets;
