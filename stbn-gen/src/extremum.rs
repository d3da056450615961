//! A lazily refreshed tournament tree that finds the pixel with the smallest (or largest) key
//! among the pixels in one state (on or off), under many small key changes.
//!
//! Void-and-cluster asks for the largest void (min energy among off pixels) or the tightest
//! cluster (max energy among on pixels) once per step, while every step changes the energy of the
//! ~100–200 pixels in a kernel footprint. Scanning the volume per step is O(N²) overall; a
//! binary heap or segment tree pays O(log N) for every touched pixel. This tree instead keeps, per
//! node, its best key and that key's pixel, and on a key change does O(1) work in the common case:
//!
//! * the changed pixel beats the node's best: it becomes the best, and the change moves up;
//! * the changed pixel *was* the best and got worse (or left the set): the node is marked dirty,
//!   and so are its ancestors;
//! * otherwise nothing changes.
//!
//! Dirty nodes are recomputed from their children when the extremum is next asked for.
//!
//! A pixel's key is `state << 63 | energy << 32 | priority`, assembled from two `u32` arrays
//! ([`Keys`]): the energy word carries the on bit in bit 31 ([`ON_BIT`]), so the splat loop touches
//! 4 bytes per pixel, and the priority array is read only by leaf scans. A min tree looks for off
//! pixels and a max tree for on pixels, so a leaf scan is a plain min or max over keys, and a
//! result on the wrong side of bit 63 means "no member here".
//!
//! Invariants: a clean node's `best` is the true extremum of its subtree; every ancestor of a
//! dirty node is dirty; a clean node's `pixel` is a member. Keys are unique (the low 32 bits hold a
//! per-pixel priority), so "best" is always a single pixel and results never depend on scan order.

/// Pixels per leaf node (a run of consecutive indices).
const LEAF_SHIFT: u32 = 4;
/// Children per inner node.
const FANOUT_SHIFT: u32 = 3;
/// `pixel` of a dirty node. Never a pixel index: volumes have at most `2^26` pixels.
const DIRTY: u32 = u32::MAX;
/// `pixel` of a clean node without members.
const NO_PIXEL: u32 = u32::MAX - 1;

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
    #[inline(always)]
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

/// One level of nodes, struct-of-arrays: the worsen check touches only `pixel`.
#[derive(Clone, Debug)]
struct Level {
    /// Best key of each node's subtree (meaningless while dirty).
    best: Vec<u64>,
    /// That key's pixel, [`DIRTY`] or [`NO_PIXEL`].
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
    /// `levels[0]` covers pixels, `levels[k]` covers nodes of `levels[k - 1]`; the last level has
    /// exactly one node, the root.
    levels: Vec<Level>,
}

impl ExtremumTree {
    /// A tree over `pixels` pixels; everything starts dirty, so the first query scans once.
    pub(crate) fn new(pixels: usize, extremum: Extremum) -> ExtremumTree {
        let sentinel = match extremum {
            Extremum::Min => u64::MAX,
            Extremum::Max => 0,
        };
        let mut levels = Vec::new();
        let mut count = pixels.div_ceil(1 << LEAF_SHIFT).max(1);
        loop {
            levels.push(Level {
                best: vec![sentinel; count],
                pixel: vec![DIRTY; count],
            });
            if count == 1 {
                break;
            }
            count = count.div_ceil(1 << FANOUT_SHIFT);
        }
        ExtremumTree {
            extremum,
            sentinel,
            pixels,
            levels,
        }
    }

    /// Which extremum the tree finds.
    #[inline(always)]
    pub(crate) fn extremum(&self) -> Extremum {
        self.extremum
    }

    /// Whether a pixel with `key` is a member (min trees track off pixels, max trees on pixels).
    #[inline(always)]
    fn is_member(&self, key: u64) -> bool {
        (key >> 63 != 0) == (self.extremum == Extremum::Max)
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
        for level in 0..self.levels.len() {
            let current = self.levels[level].pixel[node];
            if current == DIRTY {
                return;
            }
            let best = self.levels[level].best[node];
            if self.better(key, best) || current == pixel && key == best {
                self.levels[level].best[node] = key;
                self.levels[level].pixel[node] = pixel;
            } else if current == pixel {
                self.mark_dirty(level, node);
                return;
            } else {
                return;
            }
            node >>= FANOUT_SHIFT;
        }
    }

    /// Records that `pixel`'s key got worse for this tree, or that `pixel` left the set. O(1)
    /// unless `pixel` was its leaf's best. Needs no membership test: a clean leaf's best is a member.
    #[inline(always)]
    pub(crate) fn worsen(&mut self, pixel: usize) {
        let leaf = pixel >> LEAF_SHIFT;
        if self.levels[0].pixel[leaf] == pixel as u32 {
            self.mark_dirty(0, leaf);
        }
    }

    fn mark_dirty(&mut self, mut level: usize, mut node: usize) {
        while level < self.levels.len() && self.levels[level].pixel[node] != DIRTY {
            self.levels[level].pixel[node] = DIRTY;
            level += 1;
            node >>= FANOUT_SHIFT;
        }
    }

    /// The member with the best key, or `None` when the set is empty.
    ///
    /// `keys` must be the arrays every `update`/`worsen` call described.
    pub(crate) fn best(&mut self, keys: Keys<'_>) -> Option<usize> {
        let top = self.levels.len() - 1;
        self.refresh(top, 0, keys);
        let pixel = self.levels[top].pixel[0];
        (pixel != NO_PIXEL).then_some(pixel as usize)
    }

    /// The best member key in one leaf, and its offset in the leaf.
    ///
    /// Two cheap passes instead of one over assembled `u64` keys: a `u32` min/max of the energy
    /// words (which LLVM vectorises; the on bit makes members win in a max tree and lose in a min
    /// tree), then the priority tie-break among the pixels holding that word.
    #[inline(always)]
    fn leaf_best(&self, energy: &[u32], priority: &[u32]) -> Option<(usize, u64)> {
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
        let (at, p) = found?;
        let key = key(word, p);
        self.is_member(key).then_some((at, key))
    }

    /// The best key among `children` (never the sentinel) and its offset.
    #[inline(always)]
    fn inner_best(&self, children: &[u64]) -> Option<(usize, u64)> {
        let found = match self.extremum {
            Extremum::Min => children.iter().copied().min(),
            Extremum::Max => children.iter().copied().max(),
        }?;
        // Keys are unique among members, so the position is unambiguous.
        let at = children.iter().position(|&k| k == found)?;
        (found != self.sentinel).then_some((at, found))
    }

    fn refresh(&mut self, level: usize, node: usize, keys: Keys<'_>) {
        if self.levels[level].pixel[node] != DIRTY {
            return;
        }
        let (best, pixel) = if level == 0 {
            let start = node << LEAF_SHIFT;
            let end = (start + (1 << LEAF_SHIFT)).min(self.pixels);
            match self.leaf_best(&keys.energy[start..end], &keys.priority[start..end]) {
                Some((at, key)) => (key, (start + at) as u32),
                None => (self.sentinel, NO_PIXEL),
            }
        } else {
            let first = node << FANOUT_SHIFT;
            let last = (first + (1 << FANOUT_SHIFT)).min(self.levels[level - 1].pixel.len());
            for child in first..last {
                if self.levels[level - 1].pixel[child] == DIRTY {
                    self.refresh(level - 1, child, keys);
                }
            }
            let below = &self.levels[level - 1];
            match self.inner_best(&below.best[first..last]) {
                Some((at, key)) => (key, below.pixel[first + at]),
                None => (self.sentinel, NO_PIXEL),
            }
        };
        self.levels[level].best[node] = best;
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
                .map(|_| (lcg(&mut rng) as u32 % 2) << 31 | lcg(&mut rng) as u32 % 1000)
                .collect();
            let mut tree = ExtremumTree::new(pixels, extremum);
            for step in 0..3000 {
                let i = (lcg(&mut rng) as usize) % pixels;
                let old = energy[i];
                energy[i] = match lcg(&mut rng) % 3 {
                    0 => old ^ ON_BIT,
                    _ => old & ON_BIT | lcg(&mut rng) as u32 % 1000,
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
        let mut tree = ExtremumTree::new(10, Extremum::Min);
        let keys = Keys {
            energy: &[ON_BIT; 10],
            priority: &[1; 10],
        };
        assert_eq!(tree.best(keys), None);
    }
}
