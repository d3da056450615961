//! A lazily refreshed tournament tree that finds the pixel with the smallest (or largest) key
//! among the pixels in one state (on or off), under many small key changes.
//!
//! Void-and-cluster asks for the largest void (min energy among off pixels) or the tightest
//! cluster (max energy among on pixels) once per step, while every step changes the energy of the
//! ~100–200 pixels in a kernel footprint. Scanning the volume per step is O(N²) overall; a
//! binary heap or segment tree pays O(log N) for every touched pixel. This tree pays O(1) per
//! touched run of consecutive pixels when keys worsen (and per touched pixel when they may improve)
//! and rescans only what can matter.
//!
//! Every node holds a *bound*: a key at least as good as the best member key in its subtree (a
//! lower bound in a min tree, an upper bound in a max tree), and the pixel it came from. A leaf is
//! *exact* when its bound is its best member's key. Changes:
//!
//! * a member's key improves (or a pixel joins): if it beats the leaf's bound it becomes the
//!   leaf's exact best and moves up while it beats the ancestors' bounds;
//! * a member's key worsens (or it leaves): if it was its leaf's exact best, the leaf becomes
//!   inexact. Its bound, the old key, is still a valid bound, so nothing above changes. A run of
//!   consecutive pixels that all worsen costs one comparison per leaf it overlaps
//!   ([`ExtremumTree::worsen_range`]), not one per pixel.
//!
//! A query follows the best bound down to its leaf. If that leaf is exact, its best is the answer
//! (every other subtree's bound, and so its best key, is no better). If not, the leaf is rescanned,
//! the bounds on its path are recomputed, and the query repeats. After a splat, the leaves it
//! made inexact are rescanned only if their old best could still win: usually one or two per step.
//!
//! A pixel's key is `state << 63 | energy << 32 | priority`, made of two `u32` arrays: the energy
//! word carries the on bit in bit 31 ([`ON_BIT`]), so the splat loop touches 4 bytes per pixel, and
//! the priorities never change. A bound is stored as the energy word and the pixel it came from,
//! which names the key exactly; the priority array is read only when two words tie (it was one
//! cache miss per leaf scan when bounds held whole keys). At σ 1.9 ties come mostly at the end of
//! void filling, where off pixels with fully-on neighbourhoods share one energy. A min tree
//! looks for off pixels and a max tree for on pixels, so a leaf scan is a plain min or max of
//! words, and a result on the wrong side of bit 31 means "no member here".
//!
//! A leaf scan and an inner recompute have no data-dependent branches but for ties (and a leaf
//! scan's one loop exit): the unsigned min/max word (vectorised over a leaf's 128 words), how many
//! hold it, and the first holder; several holders go to the cold priority comparison. Levels below the root are padded with empty nodes to whole
//! groups of 8, so a recompute is fixed-size, unrolled code. A mispredicted branch per candidate
//! cost more than this arithmetic.
//!
//! Invariants: every inner bound equals the best of its children's bounds, and its `pixel` lies in
//! the leaf that bound came from; an exact leaf's `pixel` is a member. Keys are unique (the low 32
//! bits hold a per-pixel priority), so "best" is always a single pixel and results never depend on
//! scan order or layout.

/// Pixels per leaf node (a run of consecutive indices): 128. Larger leaves cost more per rescan
/// (sequential, vectorised words) but are made inexact less often, so a query rescans fewer of
/// them: 3.3, 2.5, 1.9 and 1.5 rescans per query for 32, 64, 128 and 256 pixels at 128×128×64,
/// and 128 was fastest at 64×64×32, 128×128×64 and 256×256×128 (BENCHMARKS.md).
const LEAF_SHIFT: u32 = 7;
/// Children per inner node.
const FANOUT_SHIFT: u32 = 3;
/// `pixel` of a node without members.
const NO_PIXEL: u32 = u32::MAX;
/// Set in a leaf's `pixel` while its bound is not exact (pixel indices are below `2^26`).
const INEXACT: u32 = 1 << 31;

/// Bit of an energy word that marks an on pixel (bit 63 of the key).
pub(crate) const ON_BIT: u32 = 1 << 31;

/// Whether the tree looks for the smallest or the largest key, and so which pixels it tracks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Extremum {
    /// Smallest key among off pixels: the largest void.
    Min,
    /// Largest key among on pixels: the tightest cluster.
    Max,
}

/// A node's bound: the key `word << 32 | priority[pixel]`, stored as the energy word and the
/// pixel it came from. Priorities never change, so the pair names the key exactly, and the
/// priority is read only when two words tie.
#[derive(Clone, Copy, Debug)]
struct Bound {
    /// Energy word (energy and on bit) of the key.
    word: u32,
    /// The pixel the key came from, or [`NO_PIXEL`] for the sentinel; in leaves,
    /// `|`[`INEXACT`] while the bound is not exact.
    pixel: u32,
}

/// See the module documentation.
#[derive(Clone, Debug)]
pub(crate) struct ExtremumTree<'p> {
    extremum: Extremum,
    /// Tie-break priority of every pixel, `1..=N`, unique.
    priority: &'p [u32],
    /// The word of the worst possible bound, carried by the sentinel (pixel [`NO_PIXEL`]); never a
    /// member's word (members of a min tree have bit 31 clear, members of a max tree have it set).
    sentinel: u32,
    /// `levels[0]` are the leaves, `levels[k]` covers nodes of `levels[k - 1]`; the last level has
    /// exactly one node, the root.
    levels: Vec<Vec<Bound>>,
}

impl<'p> ExtremumTree<'p> {
    /// A tree over every pixel of `energy` (energy words, on bit in bit 31), built exactly.
    /// `priority` holds each pixel's tie-break priority: unique, and as long as `energy`.
    pub(crate) fn new(extremum: Extremum, energy: &[u32], priority: &'p [u32]) -> Self {
        debug_assert_eq!(energy.len(), priority.len());
        let sentinel = match extremum {
            Extremum::Min => u32::MAX,
            Extremum::Max => 0,
        };
        let empty = Bound {
            word: sentinel,
            pixel: NO_PIXEL,
        };
        // Every level below the root is padded with sentinels to a whole number of 8-child
        // groups, so a recompute always reads exactly 8 children (unrolled, branch-free code).
        let leaves = energy.len().div_ceil(1 << LEAF_SHIFT).max(1);
        let mut levels = Vec::new();
        let mut count = leaves;
        while count > 1 {
            let groups = count.div_ceil(1 << FANOUT_SHIFT);
            levels.push(vec![empty; groups << FANOUT_SHIFT]);
            count = groups;
        }
        levels.push(vec![empty; 1]);
        let mut tree = ExtremumTree {
            extremum,
            priority,
            sentinel,
            levels,
        };
        for leaf in 0..leaves {
            tree.rescan_leaf(leaf, energy);
        }
        for level in 1..tree.levels.len() {
            // Only nodes over real children; the padding stays sentinel.
            for node in 0..tree.levels[level - 1].len() >> FANOUT_SHIFT {
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

    /// Records that member `pixel` now has energy word `word`, which may be better than before.
    /// Also used when `pixel` joins the set.
    #[inline(always)]
    pub(crate) fn update(&mut self, pixel: usize, word: u32) {
        let mut node = pixel >> LEAF_SHIFT;
        let candidate = Bound {
            word,
            pixel: pixel as u32,
        };
        // Not better than a node's bound: an exact leaf keeps its best (another pixel, or this
        // one if its key did not change); an inexact one stays a valid bound; an inner node's
        // bound is no worse than its children's.
        for level in &mut self.levels {
            let bound = &mut level[node];
            if !better(self.extremum, self.priority, candidate, *bound) {
                return;
            }
            *bound = candidate;
            node >>= FANOUT_SHIFT;
        }
    }

    /// Records that `pixel`'s key got worse for this tree, or that `pixel` left the set. O(1):
    /// needs no membership test, since an exact leaf's best is a member.
    #[inline(always)]
    pub(crate) fn worsen(&mut self, pixel: usize) {
        let leaf_pixel = &mut self.levels[0][pixel >> LEAF_SHIFT].pixel;
        if *leaf_pixel == pixel as u32 {
            *leaf_pixel |= INEXACT;
        }
    }

    /// Records that the keys of pixels `start..start + len` got worse for this tree, or that those
    /// pixels left the set. Needs no membership test, since an exact leaf's best is a member: one
    /// check per leaf the range overlaps, which marks the leaf inexact if its best is in the range.
    #[inline(always)]
    pub(crate) fn worsen_range(&mut self, start: usize, len: usize) {
        if len == 0 {
            return;
        }
        let (first, last) = (start >> LEAF_SHIFT, (start + len - 1) >> LEAF_SHIFT);
        for bound in &mut self.levels[0][first..=last] {
            // An inexact leaf's pixel has bit 31 set and so lies outside any range.
            if (bound.pixel as usize).wrapping_sub(start) < len {
                bound.pixel |= INEXACT;
            }
        }
    }

    /// The member with the best key, or `None` when the set is empty.
    ///
    /// `energy` must be the words every `update`/`worsen` call described.
    pub(crate) fn best(&mut self, energy: &[u32]) -> Option<usize> {
        let top = self.levels.len() - 1;
        loop {
            let pixel = self.levels[top][0].pixel;
            if pixel == NO_PIXEL {
                return None;
            }
            let leaf = (pixel & !INEXACT) as usize >> LEAF_SHIFT;
            if self.levels[0][leaf].pixel & INEXACT == 0 {
                return Some(pixel as usize);
            }
            self.rescan_leaf(leaf, energy);
            let mut node = leaf;
            for level in 1..self.levels.len() {
                node >>= FANOUT_SHIFT;
                self.recompute(level, node);
            }
        }
    }

    /// Makes `leaf` exact by scanning its pixels: the min/max energy word (the on bit makes
    /// members win in a max tree and lose in a min tree), then the first pixel holding it, with
    /// the priority tie-break only when several do.
    fn rescan_leaf(&mut self, leaf: usize, energy: &[u32]) {
        let start = leaf << LEAF_SHIFT;
        let end = (start + (1 << LEAF_SHIFT)).min(energy.len());
        let words = &energy[start..end];
        // A full leaf gets code specialised to its length (unrolled and vectorised).
        let (word, at, holders) = match <&[u32; 1 << LEAF_SHIFT]>::try_from(words) {
            Ok(full) => extremum_word(self.extremum, full),
            Err(_) => extremum_word(self.extremum, words),
        };
        let is_member = (word & ON_BIT != 0) == (self.extremum == Extremum::Max);
        let bound = if !is_member {
            Bound {
                word: self.sentinel,
                pixel: NO_PIXEL,
            }
        } else if holders == 1 {
            Bound {
                word,
                pixel: (start + at) as u32,
            }
        } else {
            let pixels = (at..words.len())
                .filter(|&k| words[k] == word)
                .map(|k| (start + k) as u32);
            Bound {
                word,
                pixel: self.best_priority(pixels),
            }
        };
        self.levels[0][leaf] = bound;
    }

    /// Sets inner node `node` of `level` to the best of its 8 children (levels are padded).
    /// Branch-free but for ties: which child wins is data, and a mispredicted branch per child
    /// cost more than the arithmetic.
    fn recompute(&mut self, level: usize, node: usize) {
        let first = node << FANOUT_SHIFT;
        let children: &[Bound; 1 << FANOUT_SHIFT] = self.levels[level - 1]
            [first..first + (1 << FANOUT_SHIFT)]
            .try_into()
            .expect("levels are padded to whole groups");
        let word = match self.extremum {
            Extremum::Min => children.iter().fold(u32::MAX, |a, c| a.min(c.word)),
            Extremum::Max => children.iter().fold(0, |a, c| a.max(c.word)),
        };
        let holders = children
            .iter()
            .enumerate()
            .fold(0u32, |mask, (at, c)| mask | u32::from(c.word == word) << at);
        let pixel = if holders & (holders - 1) == 0 || word == self.sentinel {
            // One holder, or only sentinels (whose pixel is NO_PIXEL whichever is taken).
            children[holders.trailing_zeros() as usize].pixel
        } else {
            let mut holders = holders;
            let pixels = std::iter::from_fn(|| {
                let at = holders.trailing_zeros() as usize;
                holders &= holders.wrapping_sub(1);
                children.get(at).map(|c| c.pixel)
            });
            self.best_priority(pixels)
        };
        // NO_PIXEL has the INEXACT bit too, and must stay NO_PIXEL.
        let pixel = if pixel == NO_PIXEL {
            NO_PIXEL
        } else {
            pixel & !INEXACT
        };
        self.levels[level][node] = Bound { word, pixel };
    }

    /// Of several member pixels (possibly flagged [`INEXACT`]) whose keys share one word, the one
    /// with the best priority. Cold: at the usual σ, words of distinct pixels rarely tie.
    #[cold]
    #[inline(never)]
    fn best_priority(&self, mut pixels: impl Iterator<Item = u32>) -> u32 {
        let first = pixels.next().expect("at least one pixel");
        pixels.fold(first, |best, pixel| {
            if better_tie(self.extremum, self.priority, pixel, best) {
                pixel
            } else {
                best
            }
        })
    }
}

/// The best word of `words` for `extremum` (unsigned min or max), the index of its first
/// holder, and how many words hold it. Three simple passes that vectorise (the first two) or
/// mispredict once (the third); `words` must not be empty.
#[inline(always)]
fn extremum_word(extremum: Extremum, words: &[u32]) -> (u32, usize, u32) {
    let word = match extremum {
        Extremum::Min => words.iter().fold(u32::MAX, |a, &e| a.min(e)),
        Extremum::Max => words.iter().fold(0, |a, &e| a.max(e)),
    };
    let holders = words.iter().fold(0, |n, &e| n + u32::from(e == word));
    let at = words.iter().position(|&e| e == word).unwrap_or(0);
    (word, at, holders)
}

/// Whether energy word `a` is strictly better than `b` for `extremum`.
#[inline(always)]
fn better_word(extremum: Extremum, a: u32, b: u32) -> bool {
    match extremum {
        Extremum::Min => a < b,
        Extremum::Max => a > b,
    }
}

/// Whether bound `a` is strictly better than `b`: by word, then by priority. A free function so
/// loops holding one level of the tree mutably can call it.
#[inline(always)]
fn better(extremum: Extremum, priority: &[u32], a: Bound, b: Bound) -> bool {
    better_word(extremum, a.word, b.word)
        || (a.word == b.word
            && a.pixel != NO_PIXEL
            && better_tie(extremum, priority, a.pixel, b.pixel))
}

/// Between two bounds with equal words, whether the one from pixel `a` is strictly better (both
/// pixels may carry [`INEXACT`]). Words tie between members only (the sentinel's word is no
/// member's), so a sentinel here meets another sentinel, which is not better. Cold: at the usual
/// σ, energies of distinct pixels rarely tie.
#[cold]
#[inline(never)]
fn better_tie(extremum: Extremum, priority: &[u32], a: u32, b: u32) -> bool {
    if a == NO_PIXEL || b == NO_PIXEL {
        return false;
    }
    let (pa, pb) = (
        priority[(a & !INEXACT) as usize],
        priority[(b & !INEXACT) as usize],
    );
    better_word(extremum, pa, pb)
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

    /// The key of pixel `i`.
    fn key(energy: &[u32], priority: &[u32], i: usize) -> u64 {
        u64::from(energy[i]) << 32 | u64::from(priority[i])
    }

    fn brute(energy: &[u32], priority: &[u32], extremum: Extremum) -> Option<usize> {
        let on = extremum == Extremum::Max;
        let members = (0..energy.len()).filter(|&i| (energy[i] & ON_BIT != 0) == on);
        match extremum {
            Extremum::Min => members.min_by_key(|&i| key(energy, priority, i)),
            Extremum::Max => members.max_by_key(|&i| key(energy, priority, i)),
        }
    }

    #[test]
    fn matches_brute_force_under_random_changes() {
        for (pixels, extremum) in [
            (1, Extremum::Min),
            (70, Extremum::Max),
            (5000, Extremum::Min),
            (5000, Extremum::Max),
        ] {
            let mut rng = 42u64;
            let member = |energy: u32| (energy & ON_BIT != 0) == (extremum == Extremum::Max);
            // A shuffled permutation of 1..=pixels, so ties do not follow index order.
            let mut priority: Vec<u32> = (1..=pixels as u32).collect();
            for i in (1..pixels).rev() {
                priority.swap(i, lcg(&mut rng) as usize % (i + 1));
            }
            // Energies below 1000: ties between pixels are common.
            let mut energy: Vec<u32> = (0..pixels)
                .map(|_| ((lcg(&mut rng) as u32 % 2) << 31) | (lcg(&mut rng) as u32 % 1000))
                .collect();
            let mut tree = ExtremumTree::new(extremum, &energy, &priority);
            for step in 0..3000 {
                if lcg(&mut rng).is_multiple_of(4) {
                    // A run of pixels all worsen (or leave), reported as one range.
                    let start = (lcg(&mut rng) as usize) % pixels;
                    let len = ((lcg(&mut rng) as usize) % 40).min(pixels - start);
                    for e in &mut energy[start..start + len] {
                        *e = match extremum {
                            Extremum::Min => (*e + 1 + lcg(&mut rng) as u32 % 50) | (*e & ON_BIT),
                            Extremum::Max => {
                                (*e & !ON_BIT).saturating_sub(1 + lcg(&mut rng) as u32 % 50)
                                    | (*e & ON_BIT)
                            }
                        };
                        if lcg(&mut rng).is_multiple_of(5) {
                            // Leave the set (or stay out of it).
                            *e = match extremum {
                                Extremum::Min => *e | ON_BIT,
                                Extremum::Max => *e & !ON_BIT,
                            };
                        }
                    }
                    tree.worsen_range(start, len);
                } else {
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
                        tree.update(i, energy[i]);
                    } else if member(old) {
                        tree.worsen(i);
                    }
                }
                if step % 7 == 0 {
                    assert_eq!(
                        tree.best(&energy),
                        brute(&energy, &priority, extremum),
                        "step {step}, {pixels} pixels, {extremum:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn empty_set_has_no_best() {
        // One leaf (the root), and a tree several levels deep.
        for pixels in [10, 5000] {
            let energy = vec![ON_BIT; pixels];
            let priority: Vec<u32> = (1..=pixels as u32).collect();
            assert_eq!(
                ExtremumTree::new(Extremum::Min, &energy, &priority).best(&energy),
                None
            );
            let energy = vec![0; pixels];
            assert_eq!(
                ExtremumTree::new(Extremum::Max, &energy, &priority).best(&energy),
                None
            );
        }
    }
}
