//! The parent→children coefficient tree over the Mallat layout (Shapiro 1993, §III): LL
//! roots own the coefficient at the same position in each level-L detail band; a detail
//! coefficient owns its 2×2 block one level finer (the last row/column of a band also owns
//! any remainder, as [`Layout::child_range`] says). On very anisotropic grids a band can be
//! empty while the finer band of the same orientation is not; its coefficients then hang
//! from the nearest non-empty coarser band of that orientation, or from the LL band.

use crate::wavelet::{Band, Layout};

/// Sentinel for "no parent".
pub const NO_PARENT: u32 = u32::MAX;

/// Per-band geometry, the parent of every coefficient and children lists (CSR), built once
/// per layout.
pub struct Tree {
    pub cols: usize,
    /// Bands in scan order: LL, then coarse → fine, HL/LH/HH within a level.
    pub bands: Vec<Band>,
    /// Flat index of each coefficient's parent, or [`NO_PARENT`].
    pub parent: Vec<u32>,
    /// Scan-order band index of every coefficient.
    pub band_of: Vec<u8>,
    child_start: Vec<u32>,
    children: Vec<u32>,
}

impl Tree {
    pub fn new(layout: &Layout) -> Self {
        let bands = layout.bands_coarse_to_fine();
        let cols = layout.cols();
        let n = layout.rows() * cols;
        let levels = layout.levels();
        let mut parent = vec![NO_PARENT; n];
        let mut band_of = vec![0u8; n];
        for (bi, b) in bands.iter().enumerate() {
            for i in 0..b.rows {
                for j in 0..b.cols {
                    band_of[(b.row0 + i) * cols + b.col0 + j] = bi as u8;
                }
            }
            if b.orientation.is_none() || b.is_empty() {
                continue;
            }
            // Nearest non-empty coarser band of the same orientation, else the LL band.
            let up = (1..=levels - b.level)
                .map(|d| (d, bi - 3 * d))
                .find(|&(_, pi)| !bands[pi].is_empty());
            let (shift, pb) = match up {
                Some((d, pi)) => (d, &bands[pi]),
                None => (levels - b.level, &bands[0]),
            };
            for i in 0..b.rows {
                for j in 0..b.cols {
                    let pr = (i >> shift).min(pb.rows - 1);
                    let pc = (j >> shift).min(pb.cols - 1);
                    parent[(b.row0 + i) * cols + b.col0 + j] =
                        ((pb.row0 + pr) * cols + pb.col0 + pc) as u32;
                }
            }
        }
        // Children lists in scan order, so a zerotree marks its children before they are visited.
        let mut count = vec![0u32; n + 1];
        for &p in &parent {
            if p != NO_PARENT {
                count[p as usize + 1] += 1;
            }
        }
        for i in 0..n {
            count[i + 1] += count[i];
        }
        let child_start = count.clone();
        let mut fill = count;
        let mut children = vec![0u32; child_start[n] as usize];
        for b in &bands {
            for i in 0..b.rows {
                for j in 0..b.cols {
                    let idx = (b.row0 + i) * cols + b.col0 + j;
                    let p = parent[idx];
                    if p != NO_PARENT {
                        children[fill[p as usize] as usize] = idx as u32;
                        fill[p as usize] += 1;
                    }
                }
            }
        }
        Self {
            cols,
            bands,
            parent,
            band_of,
            child_start,
            children,
        }
    }

    /// The flat indices of the children of coefficient `idx`.
    #[inline]
    pub fn children(&self, idx: usize) -> &[u32] {
        &self.children[self.child_start[idx] as usize..self.child_start[idx + 1] as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_non_root_coefficient_has_a_parent_in_a_coarser_band() {
        for (r, c) in [(257, 257), (512, 512), (1, 257), (300, 17), (5, 3), (2, 40)] {
            let layout = Layout::full(r, c);
            let t = Tree::new(&layout);
            for idx in 0..r * c {
                let bi = t.band_of[idx] as usize;
                if bi == 0 {
                    assert_eq!(t.parent[idx], NO_PARENT);
                } else {
                    let p = t.parent[idx];
                    assert_ne!(
                        p, NO_PARENT,
                        "{r}x{c}: coefficient {idx} in band {bi} is an orphan"
                    );
                    assert!((t.band_of[p as usize] as usize) < bi);
                    assert!(t.children(p as usize).contains(&(idx as u32)));
                }
            }
        }
    }

    #[test]
    fn square_tiles_follow_the_quadtree() {
        // On 257² every detail coefficient's parent is the 2×2-block owner one level up.
        let layout = Layout::full(257, 257);
        let t = Tree::new(&layout);
        let hl1 = layout.band(1, crate::wavelet::Orientation::HL);
        let hl2 = layout.band(2, crate::wavelet::Orientation::HL);
        let idx = (hl1.row0 + 9) * 257 + hl1.col0 + 6;
        assert_eq!(t.parent[idx] as usize, (hl2.row0 + 4) * 257 + hl2.col0 + 3);
    }
}
