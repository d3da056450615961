//! Seeded random streams. Every random decision of the generators draws from a ChaCha8
//! generator keyed by `(seed, stream tag, a, b)`, never from one shared sequence, so a decision
//! does not depend on how many were drawn before it: on which thread, or in which order, the
//! tiles of a pass run.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The stream tags of one generator: distinct tags keep the streams of one seed apart.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Streams {
    /// The initial arrangement; `a` is the frame.
    pub init: u64,
    /// The tile grid's offset; `a` is the pass.
    pub grid: u64,
    /// One tile's proposals; `a` is the pass, `b` the tile's id.
    pub tile: u64,
}

/// Vector masks' streams: the stratified start of every vector mask (also those the
/// filter-adapted optimiser improves) and the swap optimiser's passes.
pub(crate) const VECTOR: Streams = Streams {
    init: 1,
    grid: 2,
    tile: 3,
};

/// Filter-adapted masks' streams: the random start of scalar masks and the greedy optimiser's
/// passes.
pub(crate) const FILTER_ADAPTED: Streams = Streams {
    init: 0x4641_5354_0001,
    grid: 0x4641_5354_0002,
    tile: 0x4641_5354_0003,
};

/// A ChaCha8 generator keyed by `(seed, tag, a, b)`: distinct keys give independent streams.
pub(crate) fn keyed_rng(seed: u64, tag: u64, a: u64, b: u64) -> ChaCha8Rng {
    let mut key = [0u8; 32];
    for (chunk, word) in key.chunks_exact_mut(8).zip([seed, tag, a, b]) {
        chunk.copy_from_slice(&word.to_le_bytes());
    }
    ChaCha8Rng::from_seed(key)
}

/// A uniform index in `0..n` other than `i` (`n ≥ 2`), from one `u32` of `rng` (multiply-shift,
/// bias below 2⁻¹⁶ for tiles of up to 2¹⁶ pixels).
#[inline(always)]
fn other_index(rng: &mut ChaCha8Rng, i: u32, n: u32) -> u32 {
    let j = ((u64::from(rng.next_u32()) * u64::from(n - 1)) >> 32) as u32;
    if j >= i { j + 1 } else { j }
}

/// The swap partner of tile pixel `i` (of `n ≥ 2`), as both swap optimisers choose it: of
/// `candidates` indices drawn uniformly among the other pixels (with replacement, one `u32` of
/// `rng` each), the one with the least `distance` (the first of equals). `distance(j)` is how far
/// pixel `j`'s value is from `i`'s; it is not called when `candidates ≤ 1` (a uniform partner).
#[inline(always)]
pub(crate) fn nearest_partner<K: PartialOrd>(
    rng: &mut ChaCha8Rng,
    i: u32,
    n: u32,
    candidates: u32,
    mut distance: impl FnMut(u32) -> K,
) -> u32 {
    let mut partner = other_index(rng, i, n);
    if candidates > 1 {
        let mut nearest = distance(partner);
        for _ in 1..candidates {
            let candidate = other_index(rng, i, n);
            let d = distance(candidate);
            if d < nearest {
                (partner, nearest) = (candidate, d);
            }
        }
    }
    partner
}
