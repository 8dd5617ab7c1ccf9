//! Tile pyramids: one sample lattice per zoom level, cut into (2^n + 1)² tiles that share
//! their edge samples.
//!
//! A level's lattice is the next finer one's wavelet low-pass: one level of the real
//! LeGall 5/3 analysis (DESIGN.md §2.1: "lower zoom levels come from the wavelet low-pass, a
//! proper downsample, never nearest-neighbour skipping"). With the codec's normalisation the
//! low-pass has DC gain 1, so it is a height grid again, and its samples sit on the even
//! samples of the finer lattice: a tile's four children cover exactly its area.

use crate::grid::Grid;
use crate::wavelet::{self, Layout};

/// One zoom level: a lattice whose sample (0, 0) is the top-left sample of tile
/// (`tile_x0`, `tile_y0`), covering whole tiles.
#[derive(Clone, Debug, PartialEq)]
pub struct Level {
    pub zoom: u8,
    pub tile_x0: u32,
    pub tile_y0: u32,
    pub heights: Grid<f64>,
}

impl Level {
    /// Tiles across and down: the lattice is `tiles·(side − 1) + 1` samples per axis.
    pub fn tiles(&self, side: usize) -> (u32, u32) {
        let per = |n: usize| (n.saturating_sub(1) / (side - 1)) as u32;
        (per(self.heights.cols()), per(self.heights.rows()))
    }

    /// The `side × side` samples of tile (`x`, `y`) (absolute tile indices), if this level
    /// covers it.
    pub fn tile(&self, x: u32, y: u32, side: usize) -> Option<Grid<f64>> {
        let (dx, dy) = (x.checked_sub(self.tile_x0)?, y.checked_sub(self.tile_y0)?);
        let (w, h) = self.tiles(side);
        if dx >= w || dy >= h {
            return None;
        }
        let step = side - 1;
        self.heights
            .crop(dy as usize * step, dx as usize * step, side, side)
            .ok()
    }

    /// The lattice a coarser level is the low-pass of: this one padded to an even tile
    /// origin and an even tile count, with `outside` (`None`: the edge samples repeated).
    fn padding(&self, side: usize, outside: Option<f64>) -> Padding {
        let step = side - 1;
        let (w, h) = self.tiles(side);
        let (left, top) = ((self.tile_x0 % 2) as usize, (self.tile_y0 % 2) as usize);
        let (tiles_x, tiles_y) = (
            (w as usize + left).div_ceil(2) * 2,
            (h as usize + top).div_ceil(2) * 2,
        );
        Padding {
            left: left * step,
            top: top * step,
            rows: tiles_y * step + 1,
            cols: tiles_x * step + 1,
            outside,
        }
    }

    /// The coarser level of `heights`, the low-pass of this level padded by `pad`.
    fn parent(&self, pad: &Padding, heights: Grid<f64>) -> Level {
        Level {
            zoom: self.zoom.saturating_sub(1),
            tile_x0: (self.tile_x0 - u32::from(pad.left > 0)) / 2,
            tile_y0: (self.tile_y0 - u32::from(pad.top > 0)) / 2,
            heights,
        }
    }

    /// The next coarser level: pad to an even tile origin and an even tile count with the
    /// edge samples repeated, then keep the 5/3 low-pass, clamped to this level's range.
    ///
    /// The low-pass has negative taps, so at a cliff (data beside the 0 m fill of a world
    /// scheme) it overshoots by about a tenth of the step, and again at each coarser level:
    /// unclamped, a coarse tile around N44W072 reached −190 m, a trench around the data.
    ///
    /// The numbers are one level of [`wavelet::forward`] (5/3) on the padded lattice, cropped
    /// to its low-pass quarter, but neither the padded lattice nor a scratch of its size is
    /// made: each padded row is built, lifted and its low half kept (`rows × ⌈cols/2⌉`), then
    /// those columns are lifted (columns never mix, so the high-pass ones are not needed)
    /// and the low rows kept. At its peak that is half this level's size beside it, where
    /// the whole transform took two copies of it (an ingest's peak was 40 bytes a sample).
    pub fn coarser(&self, side: usize) -> Level {
        self.coarser_padded(side, None)
    }

    /// [`Level::coarser`] of a level that is a window of a world lattice holding `fill`
    /// beyond it: padded with `fill`, as the world is there. Repeating the edge samples
    /// instead carried a data edge lying on a tile boundary outwards at each zoom: N44W072's
    /// 45°N row, on the geodetic grid, became a streak of 370–614 m from 45°N to the pole in
    /// the zoom 0 and 1 tiles.
    pub fn coarser_in_world(&self, side: usize, fill: f64) -> Level {
        self.coarser_padded(side, Some(fill))
    }

    fn coarser_padded(&self, side: usize, outside: Option<f64>) -> Level {
        let pad = self.padding(side, outside);
        let (rows, cols) = (pad.rows, pad.cols);
        let src = &self.heights;
        // What `wavelet::forward` does with one level on a `rows × cols` grid.
        let layout = Layout::new(rows, cols, 1);
        let low = layout.ll();
        let (lift_rows, lift_cols) = (
            layout.levels() > 0 && cols >= 2,
            layout.levels() > 0 && rows >= 2,
        );
        // Row pass: padded row r, lifted, its low half stored as row block `split(r)`: even
        // rows first, then odd ones, the order the column pass lifts them in.
        let ns = rows.div_ceil(2);
        let split = |r: usize| match (lift_cols, r % 2) {
            (false, _) => r,
            (true, 0) => r / 2,
            (true, _) => ns + r / 2,
        };
        let mut half = vec![0.0; rows * low.cols];
        let mut line = vec![0.0; cols];
        let mut scratch = vec![0.0; cols];
        let cols_of: Vec<Option<usize>> =
            (0..cols).map(|c| pad.source_col(c, src.cols())).collect();
        // Taken only where the padding is `outside`'s (source_row/col give `None`).
        let outside = pad.outside.unwrap_or_default();
        for r in 0..rows {
            match pad.source_row(r, src.rows()) {
                Some(r) => {
                    let from = src.row(r);
                    for (v, &c) in line.iter_mut().zip(&cols_of) {
                        *v = c.map_or(outside, |c| from[c]);
                    }
                }
                None => line.fill(outside),
            }
            if lift_rows {
                wavelet::analyze_53_line(&mut line, &mut scratch);
            }
            let k = split(r);
            half[k * low.cols..(k + 1) * low.cols].copy_from_slice(&line[..low.cols]);
        }
        drop((line, scratch, cols_of));
        // Column pass over the kept columns, in place: the even-row block becomes the low-pass.
        if lift_cols {
            let (s, d) = half.split_at_mut(ns * low.cols);
            wavelet::analyze_53_split(s, d, low.cols);
        }
        half.truncate(low.rows * low.cols);
        half.shrink_to_fit();
        if let Some((lo, hi)) = pad.range(src) {
            for v in &mut half {
                *v = v.clamp(lo, hi);
            }
        }
        let heights =
            Grid::new(low.rows, low.cols, half).unwrap_or_else(|_| Grid::zeros(low.rows, low.cols));
        self.parent(&pad, heights)
    }

    /// [`Level::coarser`] as it was, the whole transform on a padded copy: the oracle the
    /// row-by-row one must match to the bit.
    #[cfg(test)]
    fn coarser_whole(&self, side: usize) -> Level {
        use crate::wavelet::Wavelet;
        let pad = self.padding(side, None);
        let (rows, cols) = (pad.rows, pad.cols);
        let src = &self.heights;
        let padded: Vec<f64> = (0..rows * cols)
            .map(|k| {
                let r = pad.source_row(k / cols, src.rows()).unwrap_or(0);
                let c = pad.source_col(k % cols, src.cols()).unwrap_or(0);
                *src.get(r, c)
            })
            .collect();
        let mut g = Grid::new(rows, cols, padded).unwrap_or_else(|_| Grid::zeros(rows, cols));
        let layout = Layout::new(rows, cols, 1);
        wavelet::forward(&mut g, Wavelet::LeGall53, &layout);
        let low = layout.ll();
        let heights = g
            .crop(0, 0, low.rows, low.cols)
            .unwrap_or_else(|_| Grid::zeros(low.rows, low.cols));
        let heights = match src.min_max() {
            Some((lo, hi)) => heights.map(|&v| v.clamp(lo, hi)),
            None => heights,
        };
        self.parent(&pad, heights)
    }
}

/// A level padded to `rows × cols`, `left`/`top` samples before it: with `outside`, or with
/// its edge samples repeated.
struct Padding {
    left: usize,
    top: usize,
    rows: usize,
    cols: usize,
    outside: Option<f64>,
}

impl Padding {
    /// The level's row that padded row `r` (of `n`) is or repeats; `None` where it takes
    /// `outside`.
    fn source_row(&self, r: usize, n: usize) -> Option<usize> {
        Self::source(r, self.top, n, self.outside.is_some())
    }

    /// The level's column that padded column `c` (of `n`) is or repeats; `None` where it
    /// takes `outside`.
    fn source_col(&self, c: usize, n: usize) -> Option<usize> {
        Self::source(c, self.left, n, self.outside.is_some())
    }

    fn source(k: usize, before: usize, n: usize, filled: bool) -> Option<usize> {
        match k.checked_sub(before) {
            Some(i) if i < n => Some(i),
            _ if filled => None,
            Some(_) => Some(n - 1),
            None => Some(0),
        }
    }

    /// The heights the padded lattice holds: the level's, and `outside` where any is.
    fn range(&self, src: &Grid<f64>) -> Option<(f64, f64)> {
        let (lo, hi) = src.min_max()?;
        let padded = self.left > 0
            || self.top > 0
            || self.rows > src.rows() + self.top
            || self.cols > src.cols() + self.left;
        Some(match self.outside.filter(|_| padded) {
            Some(v) => (lo.min(v), hi.max(v)),
            None => (lo, hi),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(rows: usize, cols: usize) -> Grid<f64> {
        Grid::new(
            rows,
            cols,
            (0..rows * cols)
                .map(|k| (k / cols) as f64 * 2.0 + (k % cols) as f64)
                .collect(),
        )
        .unwrap()
    }

    #[test]
    fn neighbouring_tiles_share_their_edge_samples() {
        let level = Level {
            zoom: 3,
            tile_x0: 0,
            tile_y0: 0,
            heights: crate::fixtures::n44w072_crop(0, 0, 33),
        };
        assert_eq!(level.tiles(9), (4, 4));
        let (a, b) = (level.tile(1, 2, 9).unwrap(), level.tile(2, 2, 9).unwrap());
        for r in 0..9 {
            assert_eq!(a.get(r, 8), b.get(r, 0));
        }
        assert!(level.tile(4, 0, 9).is_none());
    }

    #[test]
    fn a_coarser_level_keeps_a_plane_and_halves_the_tiles() {
        // A plane survives the low-pass exactly (DC gain 1, linear interpolation predict),
        // away from the repeated padding.
        let level = Level {
            zoom: 5,
            tile_x0: 2,
            tile_y0: 4,
            heights: ramp(33, 65),
        };
        let up = level.coarser(9);
        assert_eq!((up.zoom, up.tile_x0, up.tile_y0), (4, 1, 2));
        assert_eq!(up.tiles(9), (4, 2));
        // Coarse sample (i, j) sits on fine sample (2i, 2j).
        for i in 2..14 {
            for j in 2..30 {
                let want = ramp(33, 65).get(2 * i, 2 * j).to_owned();
                assert!((up.heights.get(i, j) - want).abs() < 1e-9, "({i}, {j})");
            }
        }
    }

    #[test]
    fn a_cliff_does_not_ring_below_or_above_its_sides() {
        // Data beside a 0 m fill, as a world scheme's lattice has at the data's edge.
        let cliff = Grid::new(
            33,
            65,
            (0..33 * 65)
                .map(|k| if k % 65 < 30 { 1900.0 } else { 0.0 })
                .collect(),
        )
        .unwrap();
        let mut level = Level {
            zoom: 4,
            tile_x0: 0,
            tile_y0: 0,
            heights: cliff,
        };
        for _ in 0..3 {
            level = level.coarser(9);
            let (lo, hi) = level.heights.min_max().unwrap();
            assert!(lo >= 0.0 && hi <= 1900.0, "zoom {}: {lo}..{hi}", level.zoom);
            assert!(hi > lo, "the cliff is still there");
        }
    }

    /// The row-by-row coarser level is the whole-lattice transform's to the bit: every tile
    /// count odd and even, every origin parity, lattices with samples past their last whole
    /// tile, sides down to 2, a cliff and a hole.
    #[test]
    fn a_coarser_level_is_the_whole_transform_to_the_bit() {
        use crate::wavelet::testutil::grid_f64;
        let mut seed = 1;
        let mut checked = 0;
        for side in [2usize, 3, 5, 9, 17] {
            let step = side - 1;
            for (tiles_x, tiles_y) in [
                (0, 0),
                (1, 1),
                (1, 2),
                (2, 1),
                (3, 3),
                (4, 3),
                (5, 6),
                (7, 2),
            ] {
                for extra in [0, 1, step.saturating_sub(1)] {
                    for (x0, y0) in [(0, 0), (1, 0), (0, 1), (3, 5), (6, 4)] {
                        seed += 1;
                        let (rows, cols) = (tiles_y * step + 1 + extra, tiles_x * step + 1);
                        let mut heights = grid_f64(rows, cols, 3000.0, seed);
                        match seed % 4 {
                            // A cliff down to a constant fill, as a world lattice has.
                            0 => heights.data_mut()[..rows * cols / 2].fill(0.0),
                            1 => heights.data_mut()[rows * cols / 3] = f64::NAN,
                            _ => {}
                        }
                        let level = Level {
                            zoom: 7,
                            tile_x0: x0,
                            tile_y0: y0,
                            heights,
                        };
                        let (got, want) = (level.coarser(side), level.coarser_whole(side));
                        let what = format!(
                            "side {side}, {tiles_x}×{tiles_y} tiles + {extra}, origin ({x0}, {y0})"
                        );
                        assert_eq!(
                            (
                                got.zoom,
                                got.tile_x0,
                                got.tile_y0,
                                got.heights.rows(),
                                got.heights.cols()
                            ),
                            (
                                want.zoom,
                                want.tile_x0,
                                want.tile_y0,
                                want.heights.rows(),
                                want.heights.cols()
                            ),
                            "{what}"
                        );
                        let bits = |l: &Level| {
                            l.heights
                                .data()
                                .iter()
                                .map(|v| v.to_bits())
                                .collect::<Vec<_>>()
                        };
                        assert!(bits(&got) == bits(&want), "{what}");
                        checked += 1;
                        // And the level above that, from a lattice the low-pass made.
                        if tiles_x > 1 && tiles_y > 1 {
                            let (a, b) = (got.coarser(side), want.coarser_whole(side));
                            assert!(
                                bits(&a) == bits(&b) && a.tile_x0 == b.tile_x0,
                                "{what}, twice"
                            );
                        }
                    }
                }
            }
        }
        assert_eq!(checked, 5 * 8 * 3 * 5);
    }

    #[test]
    fn an_odd_origin_is_padded_so_children_nest() {
        let level = Level {
            zoom: 2,
            tile_x0: 1,
            tile_y0: 3,
            heights: ramp(17, 25),
        };
        let up = level.coarser(9);
        assert_eq!((up.tile_x0, up.tile_y0), (0, 1));
        // Tiles 1..=3 × 3..=4 at zoom 2 pad to 0..=3 × 2..=5: 2 × 2 parents.
        assert_eq!(up.tiles(9), (2, 2));
    }
}
