//! The complexity map: the zerotree the decoder built, summarised per quadtree cell.
//!
//! Yu, Lee and Ra (1997), §II.2: a level-m coefficient stands for the detail of its
//! 2^m × 2^m cell; a cell whose coefficients and all their descendants are below T is flat
//! enough to be one leaf. In the Mallat layout the level-m coefficients of cell (i, j) sit at
//! its top-edge midpoint (HL), left-edge midpoint (LH) and centre (HH); the bottom and right
//! midpoints belong to the cells below and to the right. A cell is judged on every detail
//! sample of its closed square except its corners, edges included, so two cells that share an
//! edge reach the same verdict about the samples on it: that is what keeps the mesh free of
//! cracks inside a tile without a balancing pass.
//!
//! Built once per decoded tile (O(samples)); every threshold at or above the decoded one is
//! then a top-down walk over it ([`Complexity::leaves`]), as the paper's Fig. 5 derives the
//! T_i zerotree from the initial one.

use super::leaves::{Leaf, SplitMap};
use crate::grid::Grid;
use crate::wavelet::{Layout, Orientation};

/// Per-cell maxima of the detail magnitudes, for every level of the quadtree.
#[derive(Clone, Debug)]
pub struct Complexity {
    rows: usize,
    cols: usize,
    /// Level of the top cells: the layout's decomposition depth.
    top: usize,
    /// `levels[m]`: one value per level-m cell, row-major over `cells(m)`; +∞ for a cell that
    /// is not wholly inside the grid (it must split whatever T is). Level 0 is implicit
    /// (1 × 1 cells hold no detail sample besides their corners).
    levels: Vec<Vec<f32>>,
}

impl Complexity {
    /// Summarises decoded `coefficients` (Mallat layout of `layout`, height units, as
    /// [`crate::ezw::Decoded::coefficients`]). A sample's magnitude is |coefficient| of the
    /// detail coefficient that sits on it: the height a flat leaf would miss there.
    ///
    /// A mismatch between `layout` and the grid's shape is a broken contract (debug
    /// assertion); in release it yields a map whose every cell splits.
    pub fn new(layout: &Layout, coefficients: &Grid<f64>) -> Self {
        let (rows, cols) = (layout.rows(), layout.cols());
        debug_assert_eq!((coefficients.rows(), coefficients.cols()), (rows, cols));
        let top = layout.levels();
        let mut map = Self {
            rows,
            cols,
            top,
            levels: vec![Vec::new(); top + 1],
        };
        if rows < 2 || cols < 2 || coefficients.rows() != rows || coefficients.cols() != cols {
            return map;
        }

        // Magnitudes moved from the Mallat layout onto the samples they describe.
        let magnitude = sample_magnitudes(layout, coefficients);

        // Bottom-up: a cell's maximum is its children's and its five level-m samples'.
        for m in 1..=top {
            let (cr, cc) = map.cells(m);
            let (size, half) = (1usize << m, 1usize << (m - 1));
            let mut level = vec![f32::INFINITY; cr * cc];
            for i in 0..cr {
                for j in 0..cc {
                    let (r0, c0) = (i * size, j * size);
                    if r0 + size >= rows || c0 + size >= cols {
                        continue; // straddles the grid's edge: stays +∞
                    }
                    let at = |r: usize, c: usize| magnitude[r * cols + c];
                    let mut v = at(r0, c0 + half)
                        .max(at(r0 + half, c0))
                        .max(at(r0 + half, c0 + half))
                        .max(at(r0 + size, c0 + half))
                        .max(at(r0 + half, c0 + size));
                    if m > 1 {
                        let below = &map.levels[m - 1];
                        let (_, bc) = map.cells(m - 1);
                        for (di, dj) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                            v = v.max(below[(2 * i + di) * bc + 2 * j + dj]);
                        }
                    }
                    level[i * cc + j] = v;
                }
            }
            map.levels[m] = level;
        }
        map
    }

    pub fn rows(&self) -> usize {
        self.rows
    }

    pub fn cols(&self) -> usize {
        self.cols
    }

    /// Cells of level `m` needed to cover the grid: ceil((n − 1) / 2^m) per axis.
    fn cells(&self, m: usize) -> (usize, usize) {
        let per = |n: usize| (n.saturating_sub(1)).div_ceil(1 << m);
        (per(self.rows), per(self.cols))
    }

    /// The largest detail magnitude in level-`m` cell (`i`, `j`) (closed square, corners
    /// excluded); +∞ when the cell is not wholly inside the grid, 0 for 1 × 1 cells.
    pub fn cell_max(&self, m: usize, i: usize, j: usize) -> f32 {
        if m == 0 {
            return 0.0;
        }
        let (cr, cc) = self.cells(m);
        if i >= cr || j >= cc {
            return f32::INFINITY; // a column past the grid would read the next row's cell
        }
        self.levels
            .get(m)
            .and_then(|l| l.get(i * cc + j))
            .copied()
            .unwrap_or(f32::INFINITY)
    }

    /// The leaves at `threshold`: top-down, a cell whose maximum is below the threshold is a
    /// leaf, any other splits in four; cells wholly outside the grid are dropped. T ≤ 0 gives
    /// every 1 × 1 cell (the full grid).
    pub fn leaves(&self, threshold: f64) -> SplitMap {
        let mut leaves = Vec::new();
        // Equivalent as `||`: a grid of one row or column has no cells (`cells` is 0 on
        // that axis), so nothing is pushed; the guard says why `rows - 1` cannot underflow.
        if self.rows >= 2 && self.cols >= 2 {
            let (cr, cc) = self.cells(self.top);
            let mut stack: Vec<(usize, usize, usize)> = Vec::with_capacity(4 * self.top + 4);
            // Reverse order on the stack so leaves come out in row-major Z order.
            for i in (0..cr).rev() {
                for j in (0..cc).rev() {
                    stack.push((self.top, i, j));
                }
            }
            while let Some((m, i, j)) = stack.pop() {
                // Wholly outside. Either `<<` as `>>` is equivalent: such a cell is past
                // `cells(m)`, so `cell_max` is +∞ and it splits down to level 0, where the
                // two shifts agree and drop it; the test spares that descent.
                if (i << m) >= self.rows - 1 || (j << m) >= self.cols - 1 {
                    continue;
                }
                if m == 0 || f64::from(self.cell_max(m, i, j)) < threshold {
                    leaves.push(Leaf {
                        row: (i << m) as u32,
                        col: (j << m) as u32,
                        level: m as u8,
                    });
                    continue;
                }
                for (di, dj) in [(1, 1), (1, 0), (0, 1), (0, 0)] {
                    stack.push((m - 1, 2 * i + di, 2 * j + dj));
                }
            }
        }
        SplitMap::new(self.rows, self.cols, leaves)
    }
}

/// |coefficient| of every detail coefficient, at the sample position it describes (see
/// [`crate::wavelet::subbands`]): HL (i·2^m, (2j+1)·2^(m−1)), LH ((2i+1)·2^(m−1), j·2^m),
/// HH ((2i+1)·2^(m−1), (2j+1)·2^(m−1)). The LL samples (the top cells' corners) stay 0.
fn sample_magnitudes(layout: &Layout, coefficients: &Grid<f64>) -> Vec<f32> {
    let (rows, cols) = (layout.rows(), layout.cols());
    let mut out = vec![0f32; rows * cols];
    for m in 1..=layout.levels() {
        let half = 1usize << (m - 1);
        for o in Orientation::ALL {
            let band = layout.band(m, o);
            for i in 0..band.rows {
                let src = coefficients.row(band.row0 + i);
                for j in 0..band.cols {
                    let (r, c) = match o {
                        Orientation::HL => (i << m, (2 * j + 1) * half),
                        Orientation::LH => ((2 * i + 1) * half, j << m),
                        Orientation::HH => ((2 * i + 1) * half, (2 * j + 1) * half),
                    };
                    debug_assert!(r < rows && c < cols, "band {o:?}{m} ({i},{j}) → ({r},{c})");
                    if let Some(slot) = out.get_mut(r * cols + c) {
                        *slot = src[band.col0 + j].abs() as f32;
                    }
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn layout_with(rows: usize, cols: usize) -> Layout {
        Layout::full(rows, cols)
    }

    #[test]
    fn every_detail_sample_is_reached_exactly_once() {
        for (r, c) in [(257, 257), (256, 256), (33, 65), (2, 2), (5, 3), (300, 17)] {
            let layout = layout_with(r, c);
            let mut count = vec![0u8; r * c];
            for m in 1..=layout.levels() {
                let half = 1usize << (m - 1);
                for o in Orientation::ALL {
                    let b = layout.band(m, o);
                    for i in 0..b.rows {
                        for j in 0..b.cols {
                            let (rr, cc) = match o {
                                Orientation::HL => (i << m, (2 * j + 1) * half),
                                Orientation::LH => ((2 * i + 1) * half, j << m),
                                Orientation::HH => ((2 * i + 1) * half, (2 * j + 1) * half),
                            };
                            count[rr * c + cc] += 1;
                        }
                    }
                }
            }
            let ll = layout.ll();
            assert_eq!(
                count.iter().filter(|&&n| n == 0).count(),
                ll.rows * ll.cols,
                "{r}×{c}: only LL samples are unreached"
            );
            assert!(
                count.iter().all(|&n| n <= 1),
                "{r}×{c}: a sample reached twice"
            );
        }
    }

    #[test]
    fn one_significant_sample_splits_exactly_the_cells_that_contain_it() {
        // A single detail on the shared edge of the two top-left level-7 cells of 257²:
        // both must split (the edge is judged alike from both sides), the other two not.
        let layout = layout_with(257, 257);
        let mut coefficients = Grid::<f64>::zeros(257, 257);
        // Sample (64, 128): on the vertical edge x = 128 between cells (0,0) and (0,1) of
        // level 7; it is an LH coefficient of level 7, position i = 0, j = 1.
        let b = layout.band(7, Orientation::LH);
        *coefficients.get_mut(b.row0, b.col0 + 1) = 5.0;
        let map = Complexity::new(&layout, &coefficients);
        assert_eq!(map.cell_max(8, 0, 0), 5.0);
        assert_eq!(map.cell_max(7, 0, 0), 5.0);
        assert_eq!(map.cell_max(7, 0, 1), 5.0);
        assert_eq!(map.cell_max(7, 1, 0), 0.0);
        assert_eq!(map.cell_max(7, 1, 1), 0.0);
        let leaves = map.leaves(1.0);
        // A cell is a leaf only below T: a maximum equal to T splits it.
        assert_eq!(map.leaves(5.0), leaves);
        let sizes: Vec<u8> = leaves.leaves().iter().map(|l| l.level).collect();
        assert_eq!(sizes.iter().filter(|&&l| l == 7).count(), 2);
        assert_eq!(sizes.iter().filter(|&&l| l == 6).count(), 8);
        assert_eq!(map.leaves(6.0).leaves().len(), 1);
    }

    #[test]
    fn zero_threshold_gives_the_full_grid_and_straddling_cells_split() {
        for (r, c) in [(257, 257), (256, 256), (9, 20), (2, 2)] {
            let layout = layout_with(r, c);
            let map = Complexity::new(&layout, &Grid::zeros(r, c));
            let full = map.leaves(0.0);
            assert_eq!(full.leaves().len(), (r - 1) * (c - 1), "{r}×{c}");
            // A flat grid at any positive T keeps only what the grid's edges force.
            let flat = map.leaves(1.0);
            let area: usize = flat.leaves().iter().map(|l| 1usize << (2 * l.level)).sum();
            assert_eq!(area, (r - 1) * (c - 1), "{r}×{c}: leaves tile the grid");
            if r == 257 {
                assert_eq!(flat.leaves().len(), 1);
            }
        }
    }

    /// Each sample's magnitude is read from the coefficient that describes it, found here
    /// from the sample's side instead of the band's: level m = 1 + the trailing zeros of the
    /// coarser coordinate, HL if the row is a multiple of 2^m, LH if the column is, else HH,
    /// at (row >> m, col >> m) in that band. Distinct signed values make every slot count.
    #[test]
    fn magnitudes_land_on_the_samples_they_describe() {
        for (rows, cols) in [(33, 33), (20, 37)] {
            let layout = layout_with(rows, cols);
            let coefficients = Grid::new(
                rows,
                cols,
                (0..rows * cols).map(|k| -1.0 - k as f64).collect(),
            )
            .unwrap();
            let got = sample_magnitudes(&layout, &coefficients);
            let tz = |v: usize| {
                if v == 0 {
                    usize::MAX
                } else {
                    v.trailing_zeros() as usize
                }
            };
            for r in 0..rows {
                for c in 0..cols {
                    let m = 1 + tz(r).min(tz(c)).min(layout.levels());
                    let want = if m > layout.levels() {
                        0.0 // LL
                    } else {
                        let o = if tz(r) >= m {
                            Orientation::HL
                        } else if tz(c) >= m {
                            Orientation::LH
                        } else {
                            Orientation::HH
                        };
                        let b = layout.band(m, o);
                        coefficients.get(b.row0 + (r >> m), b.col0 + (c >> m)).abs() as f32
                    };
                    assert_eq!(got[r * cols + c], want, "{rows}×{cols} ({r}, {c})");
                }
            }
        }
    }

    #[test]
    fn the_map_and_its_leaves_keep_the_grid_shape() {
        let map = Complexity::new(&layout_with(9, 20), &Grid::zeros(9, 20));
        assert_eq!((map.rows(), map.cols()), (9, 20));
        let leaves = map.leaves(1.0);
        assert_eq!((leaves.rows(), leaves.cols()), (9, 20));
    }

    #[test]
    fn degenerate_grids_have_no_leaves() {
        for (r, c) in [(1, 1), (1, 40), (40, 1)] {
            let layout = layout_with(r, c);
            let map = Complexity::new(&layout, &Grid::zeros(r, c));
            assert!(map.leaves(0.0).leaves().is_empty());
        }
    }

    /// The definition: a cell's value is the largest magnitude on its closed square, its four
    /// corners excluded (edges included, so both cells of an edge judge it alike), +∞ for a
    /// cell that is not wholly inside the grid. Random coefficients make every sample count.
    #[test]
    fn cell_maxima_are_the_closed_square_maxima() {
        for (r, c) in [(65, 65), (40, 70)] {
            let layout = layout_with(r, c);
            let coefficients = crate::wavelet::testutil::grid_f64(r, c, 100.0, (r * c) as u64);
            let map = Complexity::new(&layout, &coefficients);
            let magnitude = sample_magnitudes(&layout, &coefficients);
            for m in 1..=layout.levels() {
                let (cr, cc) = map.cells(m);
                let size = 1usize << m;
                // One cell past each edge too: wholly outside, +∞.
                for i in 0..=cr {
                    for j in 0..=cc {
                        let (r0, c0) = (i * size, j * size);
                        let got = map.cell_max(m, i, j);
                        if r0 + size >= r || c0 + size >= c {
                            assert_eq!(got, f32::INFINITY, "{r}×{c} level {m} ({i}, {j})");
                            continue;
                        }
                        let corner = |y: usize, x: usize| {
                            (y == r0 || y == r0 + size) && (x == c0 || x == c0 + size)
                        };
                        let mut want = 0f32;
                        for y in r0..=r0 + size {
                            for x in (c0..=c0 + size).filter(|&x| !corner(y, x)) {
                                want = want.max(magnitude[y * c + x]);
                            }
                        }
                        assert_eq!(got, want, "{r}×{c} level {m} ({i}, {j})");
                    }
                }
            }
        }
    }

    #[test]
    fn a_sample_on_a_horizontal_edge_splits_both_cells_of_that_edge() {
        // Sample (128, 64) of 257²: on the edge y = 128 between level-7 cells (0, 0) and
        // (1, 0); it is the HL coefficient (1, 0) of level 7.
        let layout = layout_with(257, 257);
        let mut coefficients = Grid::<f64>::zeros(257, 257);
        let b = layout.band(7, Orientation::HL);
        *coefficients.get_mut(b.row0 + 1, b.col0) = 5.0;
        let map = Complexity::new(&layout, &coefficients);
        assert_eq!(map.cell_max(7, 0, 0), 5.0);
        assert_eq!(map.cell_max(7, 1, 0), 5.0);
        assert_eq!(map.cell_max(7, 0, 1), 0.0);
        assert_eq!(map.cell_max(7, 1, 1), 0.0);
    }
}
