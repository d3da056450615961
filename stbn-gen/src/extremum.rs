//! A lazily refreshed tournament tree that finds the pixel with the smallest (or largest) key
//! among the pixels in one state (on or off), under many small key changes.
//!
//! Void-and-cluster asks for the largest void (min energy among off pixels) or the tightest
//! cluster (max energy among on pixels) once per step, while every step changes the energy of the
//! ~100–200 pixels in a kernel footprint. Scanning the volume per step is O(N²) overall; a
//! binary heap or segment tree pays O(log N) for every touched pixel. This tree pays O(1) per
//! touched pixel and rescans only what can matter.
//!
//! Every node holds a *bound*: a key at least as good as the best member key in its subtree (a
//! lower bound in a min tree, an upper bound in a max tree), and the pixel it came from. A leaf is
//! *exact* when its bound is its best member's key. Changes:
//!
//! * a member's key improves (or a pixel joins): if it beats the leaf's bound it becomes the
//!   leaf's exact best and moves up while it beats the ancestors' bounds;
//! * a member's key worsens (or it leaves): if it was its leaf's exact best, the leaf becomes
//!   inexact. Its bound, the old key, is still a valid bound, so nothing above changes.
//!
//! A query follows the best bound down to its leaf. If that leaf is exact, its best is the answer
//! (every other subtree's bound, and so its best key, is no better). If not, the leaf is rescanned,
//! the bounds on its path are recomputed, and the query repeats. After a splat, the leaves it
//! made inexact are rescanned only if their old best could still win: usually one or two per step.
//!
//! A pixel's key is `state << 63 | energy << 32 | priority`, assembled from two `u32` arrays
//! ([`Keys`]): the energy word carries the on bit in bit 31 ([`ON_BIT`]), so the splat loop touches
//! 4 bytes per pixel, and the priority array is read only by leaf scans. A min tree looks for off
//! pixels and a max tree for on pixels, so a leaf scan is a plain min or max, and a result on the
//! wrong side of bit 63 means "no member here".
//!
//! Invariants: every inner bound equals the best of its children's bounds, and its `pixel` lies in
//! the leaf that bound came from; an exact leaf's `pixel` is a member. Keys are unique (the low 32
//! bits hold a per-pixel priority), so "best" is always a single pixel and results never depend on
//! scan order.

/// Pixels per leaf node (a run of consecutive indices).
const LEAF_SHIFT: u32 = 6;
/// Children per inner node.
const FANOUT_SHIFT: u32 = 3;
/// `pixel` of a node without members.
const NO_PIXEL: u32 = u32::MAX;
/// Set in a leaf's `pixel` while its bound is not exact (pixel indices are below `2^26`).
const INEXACT: u32 = 1 << 31;

/// Bit of an energy word that marks an on pixel (bit 63 of the key).
pub(crate) const ON_BIT: u32 = 1 << 31;

/// The per-pixel arrays a key is made of.
#[derive(Clone, Copy)]
pub(crate) struct Keys<'a> {
    /// Energy (bits 0..31) and on bit (bit 31).
    pub(crate) energy: &'a [u32],
    /// Tie-break priority, `1..=N`, unique.
    pub(crate) priority: &'a [u32],
}

impl Keys<'_> {
    /// The key of pixel `i`.
    #[cfg(test)]
    pub(crate) fn key(&self, i: usize) -> u64 {
        key(self.energy[i], self.priority[i])
    }
}

/// The key of a pixel with energy word `energy` and `priority`.
#[inline(always)]
pub(crate) fn key(energy: u32, priority: u32) -> u64 {
    u64::from(energy) << 32 | u64::from(priority)
}

/// Whether the tree looks for the smallest or the largest key, and so which pixels it tracks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Extremum {
    /// Smallest key among off pixels: the largest void.
    Min,
    /// Largest key among on pixels: the tightest cluster.
    Max,
}

/// One level of nodes, struct-of-arrays.
#[derive(Clone, Debug)]
struct Level {
    /// Bound of each node's subtree (see the module documentation).
    bound: Vec<u64>,
    /// The pixel the bound came from, or [`NO_PIXEL`]; in leaves, `|`[`INEXACT`] while the bound
    /// is not exact.
    pixel: Vec<u32>,
}

/// See the module documentation.
#[derive(Clone, Debug)]
pub(crate) struct ExtremumTree {
    extremum: Extremum,
    /// The worst possible key; never a member's key (members of a min tree have bit 63 clear,
    /// members of a max tree have it set and a priority `>= 1` in the low bits).
    sentinel: u64,
    pixels: usize,
    /// `levels[0]` are the leaves, `levels[k]` covers nodes of `levels[k - 1]`; the last level has
    /// exactly one node, the root.
    levels: Vec<Level>,
}

impl ExtremumTree {
    /// A tree over every pixel of `keys`, built exactly.
    pub(crate) fn new(extremum: Extremum, keys: Keys<'_>) -> ExtremumTree {
        let pixels = keys.energy.len();
        let sentinel = match extremum {
            Extremum::Min => u64::MAX,
            Extremum::Max => 0,
        };
        let mut levels = Vec::new();
        let mut count = pixels.div_ceil(1 << LEAF_SHIFT).max(1);
        loop {
            levels.push(Level {
                bound: vec![sentinel; count],
                pixel: vec![NO_PIXEL; count],
            });
            if count == 1 {
                break;
            }
            count = count.div_ceil(1 << FANOUT_SHIFT);
        }
        let leaves = levels[0].bound.len();
        let mut tree = ExtremumTree {
            extremum,
            sentinel,
            pixels,
            levels,
        };
        for leaf in 0..leaves {
            tree.rescan_leaf(leaf, keys);
        }
        for level in 1..tree.levels.len() {
            for node in 0..tree.levels[level].bound.len() {
                tree.recompute(level, node);
            }
        }
        tree
    }

    /// Which extremum the tree finds.
    #[inline(always)]
    pub(crate) fn extremum(&self) -> Extremum {
        self.extremum
    }

    #[inline(always)]
    fn better(&self, a: u64, b: u64) -> bool {
        match self.extremum {
            Extremum::Min => a < b,
            Extremum::Max => a > b,
        }
    }

    /// Records that member `pixel` now has `key`, which may be better than before. Also used when
    /// `pixel` joins the set.
    #[inline(always)]
    pub(crate) fn update(&mut self, pixel: usize, key: u64) {
        let mut node = pixel >> LEAF_SHIFT;
        let pixel = pixel as u32;
        // Not better than the leaf's bound: an exact leaf keeps its best (another pixel, or this
        // one if its key did not change); an inexact one stays a valid bound.
        if !self.better(key, self.levels[0].bound[node]) {
            return;
        }
        for level in 0..self.levels.len() {
            if !self.better(key, self.levels[level].bound[node]) {
                return;
            }
            self.levels[level].bound[node] = key;
            self.levels[level].pixel[node] = pixel;
            node >>= FANOUT_SHIFT;
        }
    }

    /// Records that `pixel`'s key got worse for this tree, or that `pixel` left the set. O(1):
    /// needs no membership test, since an exact leaf's best is a member.
    #[inline(always)]
    pub(crate) fn worsen(&mut self, pixel: usize) {
        let leaf_pixel = &mut self.levels[0].pixel[pixel >> LEAF_SHIFT];
        if *leaf_pixel == pixel as u32 {
            *leaf_pixel |= INEXACT;
        }
    }

    /// The member with the best key, or `None` when the set is empty.
    ///
    /// `keys` must be the arrays every `update`/`worsen` call described.
    pub(crate) fn best(&mut self, keys: Keys<'_>) -> Option<usize> {
        let top = self.levels.len() - 1;
        loop {
            let pixel = self.levels[top].pixel[0];
            if pixel == NO_PIXEL {
                return None;
            }
            let leaf = (pixel & !INEXACT) as usize >> LEAF_SHIFT;
            if self.levels[0].pixel[leaf] & INEXACT == 0 {
                return Some(pixel as usize);
            }
            self.rescan_leaf(leaf, keys);
            let mut node = leaf;
            for level in 1..self.levels.len() {
                node >>= FANOUT_SHIFT;
                self.recompute(level, node);
            }
        }
    }

    /// Makes `leaf` exact by scanning its pixels.
    ///
    /// Two cheap passes instead of one over assembled `u64` keys: a `u32` min/max of the energy
    /// words (the on bit makes members win in a max tree and lose in a min tree), then the priority
    /// tie-break among the pixels holding that word.
    fn rescan_leaf(&mut self, leaf: usize, keys: Keys<'_>) {
        let start = leaf << LEAF_SHIFT;
        let end = (start + (1 << LEAF_SHIFT)).min(self.pixels);
        let (energy, priority) = (&keys.energy[start..end], &keys.priority[start..end]);
        let word = match self.extremum {
            Extremum::Min => energy.iter().fold(u32::MAX, |a, &e| a.min(e)),
            Extremum::Max => energy.iter().fold(0, |a, &e| a.max(e)),
        };
        let mut found: Option<(usize, u32)> = None;
        for (at, (&e, &p)) in energy.iter().zip(priority).enumerate() {
            if e == word && found.is_none_or(|(_, q)| self.better(u64::from(p), u64::from(q))) {
                found = Some((at, p));
            }
        }
        let member = |(at, p): (usize, u32)| {
            let key = key(word, p);
            ((key >> 63 != 0) == (self.extremum == Extremum::Max))
                .then_some((key, (start + at) as u32))
        };
        let (bound, pixel) = found.and_then(member).unwrap_or((self.sentinel, NO_PIXEL));
        self.levels[0].bound[leaf] = bound;
        self.levels[0].pixel[leaf] = pixel;
    }

    /// Sets inner node `node` of `level` to the best of its children.
    fn recompute(&mut self, level: usize, node: usize) {
        let first = node << FANOUT_SHIFT;
        let below = &self.levels[level - 1];
        let last = (first + (1 << FANOUT_SHIFT)).min(below.bound.len());
        let mut best = first;
        for child in first + 1..last {
            if self.better(below.bound[child], below.bound[best]) {
                best = child;
            }
        }
        let (bound, pixel) = (below.bound[best], below.pixel[best] & !INEXACT);
        self.levels[level].bound[node] = bound;
        self.levels[level].pixel[node] = pixel;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tiny deterministic generator for the test's random walk.
    fn lcg(state: &mut u64) -> u64 {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        *state >> 33
    }

    fn brute(keys: Keys<'_>, extremum: Extremum) -> Option<usize> {
        let on = extremum == Extremum::Max;
        let members = (0..keys.energy.len()).filter(|&i| (keys.energy[i] & ON_BIT != 0) == on);
        match extremum {
            Extremum::Min => members.min_by_key(|&i| keys.key(i)),
            Extremum::Max => members.max_by_key(|&i| keys.key(i)),
        }
    }

    #[test]
    fn matches_brute_force_under_random_changes() {
        for (pixels, extremum) in [
            (1, Extremum::Min),
            (70, Extremum::Max),
            (5000, Extremum::Min),
        ] {
            let mut rng = 42u64;
            let member = |energy: u32| (energy & ON_BIT != 0) == (extremum == Extremum::Max);
            let priority: Vec<u32> = (1..=pixels as u32).collect();
            let mut energy: Vec<u32> = (0..pixels)
                .map(|_| ((lcg(&mut rng) as u32 % 2) << 31) | (lcg(&mut rng) as u32 % 1000))
                .collect();
            let mut tree = ExtremumTree::new(
                extremum,
                Keys {
                    energy: &energy,
                    priority: &priority,
                },
            );
            for step in 0..3000 {
                let i = (lcg(&mut rng) as usize) % pixels;
                let old = energy[i];
                energy[i] = match lcg(&mut rng) % 3 {
                    0 => old ^ ON_BIT,
                    _ => (old & ON_BIT) | (lcg(&mut rng) as u32 % 1000),
                };
                let better = match extremum {
                    Extremum::Min => energy[i] < old,
                    Extremum::Max => energy[i] > old,
                };
                if member(energy[i]) && better {
                    tree.update(i, key(energy[i], priority[i]));
                } else if member(old) {
                    tree.worsen(i);
                }
                let keys = Keys {
                    energy: &energy,
                    priority: &priority,
                };
                if step % 7 == 0 {
                    assert_eq!(
                        tree.best(keys),
                        brute(keys, extremum),
                        "step {step}, {pixels} pixels"
                    );
                }
            }
        }
    }

    #[test]
    fn empty_set_has_no_best() {
        let keys = Keys {
            energy: &[ON_BIT; 10],
            priority: &[1; 10],
        };
        assert_eq!(ExtremumTree::new(Extremum::Min, keys).best(keys), None);
    }
}
