//! The parent→children coefficient tree over the Mallat layout (Shapiro 1993, §III): LL
//! roots own the coefficient at the same position in each level-L detail band; a detail
//! coefficient owns its 2×2 block one level finer (the last row/column of a band also owns
//! any remainder, as [`Layout::child_range`] says). On very anisotropic grids a band can be
//! empty while the finer band of the same orientation is not; its coefficients then hang
//! from the nearest non-empty coarser band of that orientation, or from the LL band.
//!
//! The tree is kept per band, not per coefficient: a band knows its parent band and the
//! level distance `depth` to it, and coefficient (i, j) hangs from parent-band coefficient
//! (min(i >> depth, rows − 1), min(j >> depth, cols − 1)). That is all the passes need to
//! turn a parent band's row bitmap into its children's (see `bitmap::expand`), so a zerotree
//! covers its descendants in O(1) per 64 coefficients instead of one write per descendant.

use crate::wavelet::{Layout, Orientation};

/// Sentinel for "no parent".
pub const NO_PARENT: u32 = u32::MAX;

/// One subband's place in the grid, in the tree and in the band bitmaps.
#[derive(Clone, Debug)]
pub struct TreeBand {
    pub row0: usize,
    pub col0: usize,
    pub rows: usize,
    pub cols: usize,
    pub level: usize,
    pub orientation: Option<Orientation>,
    /// Scan-order index of the band holding this band's parents (`None` for LL and empty
    /// bands), and how many levels coarser it is (0 when LL is the parent at the top level).
    pub parent: Option<usize>,
    pub depth: u32,
    /// First word of the band in a band bitmap, and words per band row.
    pub word0: usize,
    pub words: usize,
    /// Index of the band's first row among all band rows (for per-row summaries).
    pub row_id0: usize,
    /// Per band hanging from this one: the (rows, cols) of this band that own a child in it.
    /// Each is a rectangle at the band's origin; their union is where children are.
    pub reach: Vec<(usize, usize)>,
}

impl TreeBand {
    pub fn is_empty(&self) -> bool {
        self.rows == 0 || self.cols == 0
    }
}

/// Per-band geometry and parent links, built once per layout.
pub struct Tree {
    pub cols: usize,
    /// Bands in scan order: LL, then coarse → fine, HL/LH/HH within a level.
    pub bands: Vec<TreeBand>,
    /// Words in a band bitmap (one bit per coefficient, rows padded to words).
    pub words: usize,
    /// Most words in one band row.
    pub max_row_words: usize,
    /// Rows of all bands together.
    pub band_rows: usize,
}

impl Tree {
    pub fn new(layout: &Layout) -> Self {
        let levels = layout.levels();
        let mut bands = Vec::new();
        let mut words = 0;
        let mut max_row_words = 0;
        let mut band_rows = 0;
        let scan = layout.bands_coarse_to_fine();
        for (bi, b) in scan.iter().enumerate() {
            let row_words = b.cols.div_ceil(64);
            // Nearest non-empty coarser band of the same orientation, else the LL band.
            let (parent, depth) = if b.orientation.is_none() || b.is_empty() {
                (None, 0)
            } else {
                let up = (1..=levels - b.level)
                    .map(|d| (d, bi - 3 * d))
                    .find(|&(_, pi)| !scan[pi].is_empty());
                match up {
                    Some((d, pi)) => (Some(pi), d as u32),
                    None => (Some(0), (levels - b.level) as u32),
                }
            };
            bands.push(TreeBand {
                row0: b.row0,
                col0: b.col0,
                rows: b.rows,
                cols: b.cols,
                level: b.level,
                orientation: b.orientation,
                parent,
                depth,
                word0: words,
                words: row_words,
                row_id0: band_rows,
                reach: Vec::new(),
            });
            band_rows += b.rows;
            words += b.rows * row_words;
            max_row_words = max_row_words.max(row_words);
        }
        for c in 0..bands.len() {
            if let (Some(pi), false) = (bands[c].parent, bands[c].is_empty()) {
                // Parent row p owns a child iff p << depth < rows: p < ceil(rows / 2^depth).
                let reach = |len: usize| len.div_ceil(1usize << bands[c].depth);
                let r = (reach(bands[c].rows), reach(bands[c].cols));
                bands[pi].reach.push(r);
            }
        }
        Self {
            cols: layout.cols(),
            bands,
            words,
            max_row_words,
            band_rows,
        }
    }

    /// The parent-band row of row `i` of band `bi` (which must have a parent).
    #[inline]
    pub fn parent_row(&self, bi: usize, i: usize) -> usize {
        let b = &self.bands[bi];
        let pb = self.bands[b.parent.unwrap_or(0)].rows;
        (i >> b.depth).min(pb.saturating_sub(1))
    }

    /// The parent row of row `i` of band `bi` among all band rows, if it has a parent.
    #[inline]
    pub fn parent_row_id(&self, bi: usize, i: usize) -> Option<usize> {
        let p = self.bands[bi].parent?;
        Some(self.bands[p].row_id0 + self.parent_row(bi, i))
    }

    /// How many leading coefficients of row `i` of band `bi` have at least one child.
    pub fn children_cols(&self, bi: usize, i: usize) -> usize {
        self.bands[bi]
            .reach
            .iter()
            .filter(|&&(rows, _)| i < rows)
            .map(|&(_, cols)| cols)
            .max()
            .unwrap_or(0)
    }

    /// Flat index of every coefficient's parent, or [`NO_PARENT`] (the encoder's zerotree
    /// truth propagates "a descendant becomes significant" up these links).
    pub fn parents(&self) -> Vec<u32> {
        let n = self.bands.iter().map(|b| b.rows * b.cols).sum();
        let mut parent = vec![NO_PARENT; n];
        for b in &self.bands {
            let Some(pi) = b.parent else { continue };
            let pb = &self.bands[pi];
            for i in 0..b.rows {
                let pr = (i >> b.depth).min(pb.rows - 1);
                let row = (b.row0 + i) * self.cols + b.col0;
                for j in 0..b.cols {
                    let pc = (j >> b.depth).min(pb.cols - 1);
                    parent[row + j] = ((pb.row0 + pr) * self.cols + pb.col0 + pc) as u32;
                }
            }
        }
        parent
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Children per coefficient, the slow way: every coefficient names its parent.
    fn child_counts(t: &Tree, n: usize) -> Vec<usize> {
        let mut count = vec![0; n];
        for p in t.parents() {
            if p != NO_PARENT {
                count[p as usize] += 1;
            }
        }
        count
    }

    #[test]
    fn every_non_root_coefficient_has_a_parent_in_a_coarser_band() {
        for (r, c) in [(257, 257), (512, 512), (1, 257), (300, 17), (5, 3), (2, 40)] {
            let layout = Layout::full(r, c);
            let t = Tree::new(&layout);
            let parents = t.parents();
            let band_of = |idx: usize| {
                t.bands
                    .iter()
                    .position(|b| {
                        let (i, j) = (idx / c, idx % c);
                        (b.row0..b.row0 + b.rows).contains(&i)
                            && (b.col0..b.col0 + b.cols).contains(&j)
                    })
                    .unwrap()
            };
            let counts = child_counts(&t, r * c);
            for idx in 0..r * c {
                let bi = band_of(idx);
                if bi == 0 {
                    assert_eq!(parents[idx], NO_PARENT);
                } else {
                    let p = parents[idx];
                    assert_ne!(p, NO_PARENT, "{r}x{c}: {idx} in band {bi} is an orphan");
                    assert!(band_of(p as usize) < bi);
                }
                let b = &t.bands[bi];
                let (i, j) = (idx / c - b.row0, idx % c - b.col0);
                assert_eq!(
                    j < t.children_cols(bi, i),
                    counts[idx] > 0,
                    "{r}x{c}: children of {idx}"
                );
            }
        }
    }

    #[test]
    fn square_tiles_follow_the_quadtree() {
        // On 257² every detail coefficient's parent is the 2×2-block owner one level up.
        let layout = Layout::full(257, 257);
        let t = Tree::new(&layout);
        let hl1 = layout.band(1, Orientation::HL);
        let hl2 = layout.band(2, Orientation::HL);
        let idx = (hl1.row0 + 9) * 257 + hl1.col0 + 6;
        assert_eq!(
            t.parents()[idx] as usize,
            (hl2.row0 + 4) * 257 + hl2.col0 + 3
        );
        assert!(t.bands[1..].iter().all(|b| b.depth <= 1));
    }

    /// A band's `depth` is the level distance to the band it hangs from (the LL band counts
    /// as the top level), also when the bands between are empty: on 2 × 40 only LH1 and
    /// HH1 have rows, and they hang from LL four levels up.
    #[test]
    fn depth_is_the_level_distance_to_the_parent_band() {
        for (r, c) in [(257, 257), (2, 40), (40, 2), (1, 257), (300, 17), (5, 3)] {
            let layout = Layout::full(r, c);
            let t = Tree::new(&layout);
            for (bi, b) in t.bands.iter().enumerate() {
                let Some(pi) = b.parent else { continue };
                let p = &t.bands[pi];
                assert_eq!(b.depth as usize, p.level - b.level, "{r}x{c} band {bi}");
                assert!(!p.is_empty(), "{r}x{c} band {bi} hangs from an empty band");
            }
        }
        let t = Tree::new(&Layout::full(2, 40));
        let lh1 = t.bands.len() - 2;
        assert_eq!((t.bands[lh1].parent, t.bands[lh1].depth), (Some(0), 4));
    }
}
