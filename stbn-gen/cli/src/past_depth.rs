//! Reading an encoded mask past its depth, shared by the figures that measure it (the report's
//! "Convergence past the depth"): the three [`Reading`]s of a mask — plain sampling, which wraps
//! in time, the progressive view ([`Stbn::progressive`]), and white noise of the mask's own
//! distribution — as frame sources over a bounded window ([`window`]), and [`running_mean_of`],
//! the per-pixel running-mean error of a function of the samples
//! ([`stbn_gen::analysis::running_mean`]).
//!
//! Everything is read through the runtime from the mask's encoded bytes, so the figures are
//! those of what a user embeds (quantisation, value map and octahedral decoding included).

use stbn_gen::analysis::{RunningMean, running_mean};
use stbn_runtime::glam::Vec4;
use stbn_runtime::{OffsetStbn, Stbn, VectorSample};

/// The frame counts measured, in multiples of the mask's depth.
pub const DEPTH_MULTIPLES: [usize; 6] = [1, 2, 4, 8, 16, 32];

/// The largest measured window side, in pixels: frames wider or taller are measured over their
/// top-left `128 × 128` pixels (or fewer for deep masks, [`window`]).
pub const WINDOW_SIDE: usize = 128;

/// The most pixel-frames one curve reads, `WINDOW_SIDE² · 32 · 64` (2²⁵): a 64-frame mask is
/// read over a full `128 × 128` window, a deeper one over a smaller square ([`window`]).
const PIXEL_FRAMES: usize = WINDOW_SIDE * WINDOW_SIDE * 32 * 64;

/// The key of the hash that draws white noise's sample positions ([`Reading::White`]).
const WHITE_KEY: u64 = 0x5354_424e_5748_4954;

/// How the frames of a mask are read past its depth.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Reading {
    /// `sample` / `fill_vector_row` of the mask itself: frame `t` reads slice `t mod depth`, so
    /// a pixel's running mean stops improving at the depth.
    Wrap,
    /// The progressive view ([`Stbn::progressive`]): every pass through the depth reads the
    /// mask shifted by the epoch's R2 offset.
    Progressive,
    /// White noise of the mask's distribution: pixel `(x, y)` of a window `width` wide reads
    /// frame `t` at a voxel drawn uniformly from the whole mask by a keyed hash (SplitMix64) of
    /// `y · width + x` and `t`: independent draws, with replacement, of the mask's own encoded
    /// values; deterministic.
    White,
}

impl Reading {
    /// Every reading, in report order.
    pub const ALL: [Reading; 3] = [Reading::Wrap, Reading::Progressive, Reading::White];

    /// A lower-case name: `wrap`, `progressive` or `white`.
    pub fn name(self) -> &'static str {
        match self {
            Reading::Wrap => "wrap",
            Reading::Progressive => "progressive",
            Reading::White => "white",
        }
    }

    /// Fills `out` (row-major, `width × height` with `out.len() = width · height`) with the
    /// vectors of `mask` at frame `frame` over the window at the origin, as this reading sees
    /// them. Scalar masks give `(u, 0, 0, 0)` with pdf 1, `u` what `sample` returns.
    pub fn fill(
        self,
        mask: &Stbn<'_>,
        frame: u32,
        (width, height): (usize, usize),
        out: &mut [VectorSample],
    ) {
        debug_assert_eq!(out.len(), width * height);
        let rows = |view: OffsetStbn<'_>, out: &mut [VectorSample]| {
            for (y, row) in out.chunks_exact_mut(width).enumerate() {
                // y < height <= WINDOW_SIDE.
                view.fill_vector_row(0, y as i32, frame, row);
            }
        };
        match self {
            Reading::Wrap => rows(OffsetStbn::from(mask), out),
            Reading::Progressive => rows(mask.progressive(), out),
            Reading::White => {
                let size = [mask.width(), mask.height(), mask.depth()].map(u64::from);
                // Each coordinate: the high word of 32 random bits times the axis length, so
                // uniform on the axis (to 2⁻³² per value) and below it.
                let scale = |bits: u64, axis: u64| ((bits & 0xffff_ffff) * axis) >> 32;
                let frame_key = mix(WHITE_KEY ^ u64::from(frame));
                for (i, value) in out.iter_mut().enumerate() {
                    let xy = mix(frame_key ^ i as u64);
                    let z = mix(xy);
                    let (vx, vy, vz) = (
                        scale(xy, size[0]),
                        scale(xy >> 32, size[1]),
                        scale(z, size[2]),
                    );
                    // Each coordinate is below its axis length, which the decoded-size bound
                    // (2³¹ bytes) keeps below 2³¹.
                    *value = mask.sample_vector(vx as i32, vy as i32, vz as u32);
                }
            }
        }
    }
}

/// SplitMix64's finaliser: a bijective mix of all 64 bits.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The window a mask of `width × height × depth` is measured over, at its top-left corner:
/// the whole frame when it has at most [`WINDOW_SIDE`] pixels a side, else at most
/// `WINDOW_SIDE` a side; masks deeper than 64 frames over a square of side
/// `⌊√(2²⁰ / depth)⌋` (at least 1) instead, so that one curve reads at most 2²⁵ pixel-frames.
pub fn window(width: usize, height: usize, depth: usize) -> (usize, usize) {
    let frames = DEPTH_MULTIPLES[DEPTH_MULTIPLES.len() - 1].saturating_mul(depth.max(1));
    let side = ((PIXEL_FRAMES / frames) as f64).sqrt().floor() as usize;
    let side = side.clamp(1, WINDOW_SIDE);
    (width.min(side), height.min(side))
}

/// The frame counts measured for a mask of `depth` frames: `depth ·` [`DEPTH_MULTIPLES`], those
/// of at most 2²⁵ frames (what one curve reads at most over a one-pixel window): empty for a
/// mask deeper than that.
pub fn frame_counts(depth: usize) -> Vec<usize> {
    DEPTH_MULTIPLES
        .iter()
        .filter_map(|&m| m.checked_mul(depth))
        .filter(|&n| (1..=PIXEL_FRAMES).contains(&n))
        .collect()
}

/// The per-pixel running mean of `f` of the samples `reading` gives over `window` (from
/// [`window`]) of `mask`, against `exact`, after each of `frames` ([`frame_counts`]).
///
/// # Panics
/// If `frames` is empty or not increasing ([`running_mean`]).
pub fn running_mean_of(
    mask: &Stbn<'_>,
    reading: Reading,
    window: (usize, usize),
    frames: &[usize],
    exact: f64,
    f: impl Fn(&VectorSample) -> f64,
) -> RunningMean {
    let none = VectorSample {
        value: Vec4::ZERO,
        pdf: 0.0,
    };
    let mut samples = vec![none; window.0 * window.1];
    running_mean(window.0, window.1, frames, exact, |frame, out| {
        reading.fill(mask, frame, window, &mut samples);
        for (o, s) in out.iter_mut().zip(&samples) {
            *o = f(s);
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn windows_stay_within_the_budget() {
        assert_eq!(window(64, 64, 32), (64, 64));
        assert_eq!(window(4096, 4096, 64), (128, 128));
        assert_eq!(window(4096, 16, 4), (128, 16));
        assert_eq!(window(1, 1, 1), (1, 1));
        assert_eq!(window(512, 512, 1024), (32, 32));
        assert_eq!(window(512, 512, usize::MAX / 8), (1, 1));
        for depth in [1, 64, 65, 1000, 1 << 20] {
            let (w, h) = window(1 << 16, 1 << 16, depth);
            assert!(w * h * 32 * depth <= PIXEL_FRAMES || w * h == 1, "{depth}");
        }
    }

    #[test]
    fn frame_counts_are_multiples_of_the_depth_within_u32_frames() {
        assert_eq!(frame_counts(8), [8, 16, 32, 64, 128, 256]);
        assert_eq!(frame_counts(1), [1, 2, 4, 8, 16, 32]);
        assert_eq!(
            frame_counts(1 << 20),
            [1 << 20, 1 << 21, 1 << 22, 1 << 23, 1 << 24, 1 << 25]
        );
        assert_eq!(frame_counts(1 << 22), [1 << 22, 1 << 23, 1 << 24, 1 << 25]);
        assert!(frame_counts((1 << 25) + 1).is_empty());
    }

    #[test]
    fn white_noise_draws_every_value_of_the_mask() {
        // A 4 × 2 × 2 mask whose frames hold the 8 values (r + ½) / 8: 1024 pixel-frames draw
        // each about 128 times, and the same frame twice gives the same draws.
        let ranks: Vec<u32> = (0..16).collect();
        let volume = stbn_gen::Volume::from_global_ranks(4, 2, 2, &ranks);
        let blob = stbn_build_support::encode::encode_volume(
            &volume,
            stbn_runtime::Encoding::F32,
            stbn_runtime::Compression::None,
        );
        let mask = Stbn::from_bytes(&blob).unwrap();
        let none = VectorSample {
            value: Vec4::ZERO,
            pdf: 0.0,
        };
        let mut counts = [0usize; 8];
        let (mut out, mut again) = (vec![none; 16], vec![none; 16]);
        for frame in 0..64 {
            Reading::White.fill(&mask, frame, (4, 4), &mut out);
            Reading::White.fill(&mask, frame, (4, 4), &mut again);
            assert_eq!(out, again);
            for s in &out {
                counts[(s.value.x * 8.0) as usize] += 1;
            }
        }
        assert!(
            counts.iter().all(|&c| (80..=176).contains(&c)),
            "{counts:?}"
        );
    }
}
