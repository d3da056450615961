//! [`Volume`]: a generated scalar mask as per-slice ranks.

use rayon::prelude::*;

/// A scalar mask of `width × height × depth` pixels, stored as ranks within each slice.
///
/// Invariant: the `width · height` ranks of every slice are a permutation of `0..width·height`,
/// so each slice's values `(rank + 0.5) / (width · height)` have an exactly uniform histogram.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Volume {
    width: u32,
    height: u32,
    depth: u32,
    ranks: Vec<u32>,
}

impl Volume {
    /// Re-ranks global ranks (any total order of the volume's pixels, index
    /// `(z · height + y) · width + x`) within each slice: a slice's pixels keep their relative
    /// order and get ranks `0..width·height`.
    ///
    /// Panics if `global.len() != width · height · depth`.
    pub fn from_global_ranks(width: u32, height: u32, depth: u32, global: &[u32]) -> Volume {
        let slice = width as usize * height as usize;
        assert_eq!(
            global.len(),
            slice * depth as usize,
            "rank count must match the size"
        );
        let mut ranks = vec![0u32; global.len()];
        ranks
            .par_chunks_mut(slice)
            .zip(global.par_chunks(slice))
            .for_each(|(out, global)| {
                let mut order: Vec<u32> = (0..slice as u32).collect();
                order.sort_unstable_by_key(|&i| global[i as usize]);
                for (rank, &i) in order.iter().enumerate() {
                    out[i as usize] = rank as u32;
                }
            });
        Volume {
            width,
            height,
            depth,
            ranks,
        }
    }

    /// Pixels per row.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Rows per slice.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Slices (frames).
    pub fn depth(&self) -> u32 {
        self.depth
    }

    /// Pixels per slice.
    pub fn slice_pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Every pixel's rank within its slice, index `(z · height + y) · width + x`.
    pub fn ranks(&self) -> &[u32] {
        &self.ranks
    }

    /// The ranks of slice `z`, row-major.
    pub fn slice(&self, z: u32) -> &[u32] {
        let n = self.slice_pixels();
        &self.ranks[z as usize * n..(z as usize + 1) * n]
    }

    /// The value of pixel `(x, y, z)`: `(rank + 0.5) / (width · height)`, in `(0, 1)`.
    pub fn value(&self, x: u32, y: u32, z: u32) -> f64 {
        let i = (z as usize * self.height as usize + y as usize) * self.width as usize + x as usize;
        (f64::from(self.ranks[i]) + 0.5) / self.slice_pixels() as f64
    }

    /// Every pixel's value, in index order (see [`Volume::value`]).
    pub fn values(&self) -> Vec<f64> {
        let n = self.slice_pixels() as f64;
        self.ranks
            .iter()
            .map(|&r| (f64::from(r) + 0.5) / n)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reranking_keeps_order_within_slices() {
        // Two 2×1 slices; global ranks interleave across slices.
        let volume = Volume::from_global_ranks(2, 1, 2, &[3, 0, 1, 2]);
        assert_eq!(volume.ranks(), &[1, 0, 0, 1]);
        assert_eq!(volume.value(0, 0, 0), 0.75);
    }
}
