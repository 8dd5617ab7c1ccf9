//! The Mallat subband layout shared by the transform, the EZW coder and the mesher.
//!
//! Level `l = 1` is the finest. After `l` levels the low-pass of the rows occupies
//! `low_rows[l] = ceil(low_rows[l-1] / 2)` rows (even samples are low-pass, odd are high-pass),
//! so on a (2^n + 1)-sample side the low-pass keeps both end samples at every level. The
//! detail bands of level `l` sit beside the level-`l` low-pass:
//!
//! ```text
//!   +-------+-------+      HL: rows [0, low_rows[l]),              cols [low_cols[l], low_cols[l-1])
//!   |  LL   |  HL   |      LH: rows [low_rows[l], low_rows[l-1]),  cols [0, low_cols[l])
//!   +-------+-------+      HH: rows [low_rows[l], low_rows[l-1]),  cols [low_cols[l], low_cols[l-1])
//!   |  LH   |  HH   |
//!   +-------+-------+
//! ```
//!
//! Coefficient (i, j) of a level-`m` band sits at sample position
//! HL: (i·2^m, (2j+1)·2^(m-1)), LH: ((2i+1)·2^(m-1), j·2^m), HH: ((2i+1)·2^(m-1), (2j+1)·2^(m-1)):
//! the top-edge midpoint, left-edge midpoint and centre of the mesh cell
//! [i·2^m, (i+1)·2^m] × [j·2^m, (j+1)·2^m]. This is why the zerotree is the mesh quadtree.

/// Which direction a detail band is high-pass in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Orientation {
    /// Low-pass down the columns, high-pass along the rows (odd column positions).
    HL,
    /// High-pass down the columns (odd row positions), low-pass along the rows.
    LH,
    /// High-pass in both directions.
    HH,
}

impl Orientation {
    pub const ALL: [Orientation; 3] = [Orientation::HL, Orientation::LH, Orientation::HH];

    pub fn index(self) -> usize {
        match self {
            Orientation::HL => 0,
            Orientation::LH => 1,
            Orientation::HH => 2,
        }
    }
}

/// A rectangle of coefficients in the Mallat layout.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Band {
    /// 1 = finest detail level; the LL band carries `levels`.
    pub level: usize,
    /// `None` for the coarsest low-pass (LL) band.
    pub orientation: Option<Orientation>,
    pub row0: usize,
    pub col0: usize,
    pub rows: usize,
    pub cols: usize,
}

impl Band {
    pub fn is_empty(&self) -> bool {
        self.rows == 0 || self.cols == 0
    }

    pub fn len(&self) -> usize {
        self.rows * self.cols
    }

    pub fn contains(&self, i: usize, j: usize) -> bool {
        i < self.rows && j < self.cols
    }
}

/// Band geometry of a `rows × cols` grid transformed over `levels` levels.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Layout {
    rows: usize,
    cols: usize,
    levels: usize,
    low_rows: Vec<usize>,
    low_cols: Vec<usize>,
}

/// Deepest decomposition we ever use: 2^12 cells are far larger than any tile.
pub const MAX_LEVELS: usize = 12;

impl Layout {
    /// Layout of `levels` levels; `levels` is clamped to what the grid supports
    /// ([`Layout::max_levels`]).
    pub fn new(rows: usize, cols: usize, levels: usize) -> Self {
        let levels = levels.min(Self::max_levels(rows, cols));
        let mut low_rows = vec![rows];
        let mut low_cols = vec![cols];
        for l in 1..=levels {
            low_rows.push(low_rows[l - 1].div_ceil(2));
            low_cols.push(low_cols[l - 1].div_ceil(2));
        }
        Self {
            rows,
            cols,
            levels,
            low_rows,
            low_cols,
        }
    }

    /// Levels until the longer side's low-pass is at most 2 samples: on a 2^n + 1 side that is
    /// n levels, leaving the corner samples as the LL band and one mesh cell per tile.
    pub fn max_levels(rows: usize, cols: usize) -> usize {
        let mut n = rows.max(cols);
        let mut levels = 0;
        while n > 2 && levels < MAX_LEVELS {
            n = n.div_ceil(2);
            levels += 1;
        }
        levels
    }

    /// The default layout: as deep as [`Layout::max_levels`].
    pub fn full(rows: usize, cols: usize) -> Self {
        Self::new(rows, cols, MAX_LEVELS)
    }

    pub fn rows(&self) -> usize {
        self.rows
    }

    pub fn cols(&self) -> usize {
        self.cols
    }

    pub fn levels(&self) -> usize {
        self.levels
    }

    /// Low-pass rows after `level` levels (`level = 0` is the full grid).
    pub fn low_rows(&self, level: usize) -> usize {
        self.low_rows[level]
    }

    pub fn low_cols(&self, level: usize) -> usize {
        self.low_cols[level]
    }

    /// The coarsest low-pass band.
    pub fn ll(&self) -> Band {
        Band {
            level: self.levels,
            orientation: None,
            row0: 0,
            col0: 0,
            rows: self.low_rows[self.levels],
            cols: self.low_cols[self.levels],
        }
    }

    /// Detail band of `level` (1..=levels). Bands may be empty (a 1-row grid has no LH/HH).
    pub fn band(&self, level: usize, orientation: Orientation) -> Band {
        debug_assert!((1..=self.levels).contains(&level));
        let (lr, lc) = (self.low_rows[level], self.low_cols[level]);
        let (pr, pc) = (self.low_rows[level - 1], self.low_cols[level - 1]);
        let (row0, rows, col0, cols) = match orientation {
            Orientation::HL => (0, lr, lc, pc - lc),
            Orientation::LH => (lr, pr - lr, 0, lc),
            Orientation::HH => (lr, pr - lr, lc, pc - lc),
        };
        Band {
            level,
            orientation: Some(orientation),
            row0,
            col0,
            rows,
            cols,
        }
    }

    /// LL first, then each level from coarse to fine as HL, LH, HH: the EZW scan order.
    pub fn bands_coarse_to_fine(&self) -> Vec<Band> {
        let mut out = vec![self.ll()];
        for level in (1..=self.levels).rev() {
            for o in Orientation::ALL {
                out.push(self.band(level, o));
            }
        }
        out
    }

    /// Index range of the children of band position `i` (rows or cols) one level finer, given
    /// the parent band's and child band's extents along that axis. Each parent owns
    /// `[2i, 2i+2)`; the last parent also owns any remainder so every child has a parent.
    pub fn child_range(i: usize, parent_len: usize, child_len: usize) -> std::ops::Range<usize> {
        let start = (2 * i).min(child_len);
        let end = if i + 1 == parent_len {
            child_len
        } else {
            (2 * i + 2).min(child_len)
        };
        start..end.max(start)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tile_257_has_eight_levels_and_corner_ll() {
        let l = Layout::full(257, 257);
        assert_eq!(l.levels(), 8);
        assert_eq!((l.ll().rows, l.ll().cols), (2, 2));
        let hl1 = l.band(1, Orientation::HL);
        assert_eq!((hl1.row0, hl1.col0, hl1.rows, hl1.cols), (0, 129, 129, 128));
        let hh8 = l.band(8, Orientation::HH);
        assert_eq!((hh8.row0, hh8.col0, hh8.rows, hh8.cols), (2, 2, 1, 1));
    }

    #[test]
    fn bands_tile_the_grid_exactly() {
        for (r, c) in [(257, 257), (512, 512), (1, 257), (300, 17), (3, 2), (1, 1)] {
            let l = Layout::full(r, c);
            let mut seen = vec![0u8; r * c];
            for b in l.bands_coarse_to_fine() {
                for i in 0..b.rows {
                    for j in 0..b.cols {
                        seen[(b.row0 + i) * c + b.col0 + j] += 1;
                    }
                }
            }
            assert!(
                seen.iter().all(|&s| s == 1),
                "{r}x{c} bands overlap or leave gaps"
            );
        }
    }

    #[test]
    fn orientation_index_is_its_place_in_all() {
        for (k, o) in Orientation::ALL.into_iter().enumerate() {
            assert_eq!(o.index(), k, "{o:?}");
        }
    }

    #[test]
    fn band_len_and_contains_follow_its_extent() {
        // 7 × 11 over 3 levels: HH1 is rows 4..7, cols 6..11; indices are band-relative.
        let b = Layout::full(7, 11).band(1, Orientation::HH);
        assert_eq!((b.row0, b.col0, b.rows, b.cols, b.len()), (4, 6, 3, 5, 15));
        for (i, j, inside) in [
            (0, 0, true),
            (2, 4, true),
            (1, 3, true),
            (3, 0, false),
            (0, 5, false),
            (3, 5, false),
        ] {
            assert_eq!(b.contains(i, j), inside, "({i}, {j})");
        }
    }

    #[test]
    fn levels_stop_at_max_levels() {
        // 2^12 + 1 needs exactly 12 levels to reach 2 samples; 2^13 + 1 would need 13.
        assert_eq!(Layout::max_levels(4097, 1), 12);
        assert_eq!(Layout::max_levels(1, 8193), MAX_LEVELS);
        assert_eq!(Layout::full(8193, 3).levels(), MAX_LEVELS);
        assert_eq!(Layout::full(8193, 3).ll().rows, 3);
    }

    #[test]
    fn every_child_has_exactly_one_parent() {
        for (p, c) in [(4, 8), (5, 9), (5, 10), (1, 1), (2, 3), (3, 7)] {
            let mut seen = vec![0; c];
            for i in 0..p {
                for k in Layout::child_range(i, p, c) {
                    seen[k] += 1;
                }
            }
            assert!(
                seen.iter().all(|&s| s == 1),
                "parent {p} child {c}: {seen:?}"
            );
        }
    }
}
