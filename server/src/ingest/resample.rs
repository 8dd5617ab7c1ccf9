//! Heights of a georeferenced source at arbitrary points: what the geodetic and mercator
//! lattices sample, since their sample positions never coincide with the source's.
//!
//! Bilinear interpolation between the four surrounding sample centres. Ingest picks the
//! deepest zoom so its spacing is no coarser than the source's (`Tiling::default_max_zoom`),
//! so this upsamples and needs no prefilter; coarser zooms come from the wavelet low-pass.
//! No-data corners drop out of the weights; points farther than half a sample outside the
//! source, or with no valid corner, get the fill height.

use anyhow::{bail, Result};
use zerotile_codec::raster::{Crs, Georef};
use zerotile_codec::Grid;

/// Samples past the half-sample border still read as on it: far below any spacing a source
/// has, far above the rounding of its georeference's arithmetic.
const EDGE_SLACK: f64 = 1e-6;

/// A source grid and the inverse of its georeference. It owns the grid, so the world pyramid
/// can free the source's samples once its deepest lattice is sampled.
#[derive(Clone)]
pub struct Source {
    heights: Grid<f64>,
    crs: Crs,
    georef: Georef,
    /// (x, y) → (col, row): `[x0, y0, a, b, c, d]` with col = a·dx + b·dy, row = c·dx + d·dy.
    inverse: [f64; 6],
    fill: f64,
}

impl Source {
    pub fn new(heights: Grid<f64>, georef: &Georef, fill: f64) -> Result<Self> {
        let t = georef.transform;
        let det = t[1] * t[5] - t[2] * t[4];
        if !(det.is_finite() && det != 0.0) || heights.is_empty() {
            bail!("the source's georeference cannot be inverted");
        }
        Ok(Self {
            heights,
            crs: georef.crs,
            georef: *georef,
            inverse: [t[0], t[3], t[5] / det, -t[2] / det, -t[4] / det, t[1] / det],
            fill,
        })
    }

    pub fn crs(&self) -> Crs {
        self.crs
    }

    pub fn fill(&self) -> f64 {
        self.fill
    }

    /// Rows and columns.
    pub fn size(&self) -> (usize, usize) {
        (self.heights.rows(), self.heights.cols())
    }

    /// CRS coordinates of (fractional) sample (`row`, `col`).
    pub fn position(&self, row: f64, col: f64) -> [f64; 2] {
        let (x, y) = self.georef.position(row, col);
        [x, y]
    }

    /// The finer of the two sample spacings, CRS units: what the deepest zoom must resolve.
    pub fn spacing(&self) -> f64 {
        let t = &self.georef.transform;
        t[1].hypot(t[4]).min(t[2].hypot(t[5]))
    }

    /// How far apart neighbouring columns lie in x, CRS units (a north-up grid's column
    /// spacing).
    pub fn column_spacing(&self) -> f64 {
        self.georef.transform[1].abs()
    }

    /// The fractional (row, col) of (`x`, `y`) in the source's CRS units, and whether that
    /// lies within half a sample of the grid (where [`Source::height_at`] reads the grid).
    fn locate(&self, x: f64, y: f64) -> (f64, f64, bool) {
        let [x0, y0, a, b, c, d] = self.inverse;
        let (dx, dy) = (x - x0, y - y0);
        let (col, row) = (a * dx + b * dy, c * dx + d * dy);
        let (rows, cols) = (self.heights.rows() as f64, self.heights.cols() as f64);
        // Half a sample out, give or take the rounding of the georeference's arithmetic: a
        // pole exactly there (a cap's outer edge) came out a hair inside on one cap and a
        // hair outside on the other.
        let edge = 0.5 + EDGE_SLACK;
        let inside =
            row >= -edge && col >= -edge && row <= rows - 1.0 + edge && col <= cols - 1.0 + edge;
        (row, col, inside)
    }

    /// Whether (`x`, `y`) lies within half a sample of the grid: where [`Source::height_at`]
    /// reads the source rather than giving the fill.
    pub fn covers(&self, x: f64, y: f64) -> bool {
        self.locate(x, y).2
    }

    /// Whether (`x`, `y`) lies among the sample centres, not in the half-sample border
    /// where [`Source::height_at`] repeats the edge.
    pub fn holds(&self, x: f64, y: f64) -> bool {
        let (row, col, _) = self.locate(x, y);
        let (rows, cols) = (self.heights.rows() as f64, self.heights.cols() as f64);
        (0.0..=rows - 1.0).contains(&row) && (0.0..=cols - 1.0).contains(&col)
    }

    /// The height at (`x`, `y`) in the source's CRS units.
    pub fn height_at(&self, x: f64, y: f64) -> f64 {
        let (row, col, inside) = self.locate(x, y);
        let (rows, cols) = (self.heights.rows() as f64, self.heights.cols() as f64);
        if !inside {
            return self.fill;
        }
        let (row, col) = (row.clamp(0.0, rows - 1.0), col.clamp(0.0, cols - 1.0));
        let (r0, c0) = (row.floor() as usize, col.floor() as usize);
        let (r1, c1) = (
            (r0 + 1).min(self.heights.rows() - 1),
            (c0 + 1).min(self.heights.cols() - 1),
        );
        let (fr, fc) = (row - r0 as f64, col - c0 as f64);
        let corners = [
            (r0, c0, (1.0 - fr) * (1.0 - fc)),
            (r0, c1, (1.0 - fr) * fc),
            (r1, c0, fr * (1.0 - fc)),
            (r1, c1, fr * fc),
        ];
        let (mut sum, mut weight) = (0.0, 0.0);
        for (r, c, w) in corners {
            let h = *self.heights.get(r, c);
            if h.is_finite() {
                sum += w * h;
                weight += w;
            }
        }
        if weight > 1e-12 {
            sum / weight
        } else {
            // Every weighted corner is no-data: take any valid corner, else the fill.
            corners
                .iter()
                .map(|&(r, c, _)| *self.heights.get(r, c))
                .find(|h| h.is_finite())
                .unwrap_or(self.fill)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp() -> Grid<f64> {
        // h = 10·row + col on a 4×5 grid, one no-data sample.
        let mut g = Grid::new(
            4,
            5,
            (0..20).map(|k| f64::from(10 * (k / 5) + k % 5)).collect(),
        )
        .unwrap();
        *g.get_mut(3, 4) = f64::NAN;
        g
    }

    /// A cap whose outer cells end on a pole reaches it whichever way the arithmetic rounds:
    /// the pole lies exactly half a sample past the last centre, and was the fill on the
    /// south cap (its row came out a hair past `rows − 0.5`) but the edge on the north one.
    #[test]
    fn a_cap_ending_on_a_pole_reaches_it() {
        for (north, pole) in [(-80.025, -90.0), (89.975, 90.0)] {
            let g = Grid::new(200, 3, vec![2800.0; 600]).unwrap();
            let geo = Georef::north_up(Crs::Geographic, 10.0, north, 0.05, 0.05);
            let s = Source::new(g, &geo, 0.0).unwrap();
            assert_eq!(s.height_at(10.05, pole), 2800.0, "pole {pole}");
            // Farther out is still the fill.
            assert_eq!(
                s.height_at(10.05, pole + (pole - north).signum() * 0.03),
                0.0
            );
        }
    }

    #[test]
    fn bilinear_reproduces_a_plane_and_honours_the_georeference() {
        let g = ramp();
        // Sample centres at lon 10 + 0.5·col, lat 50 − 0.25·row.
        let geo = Georef::north_up(Crs::Geographic, 10.0, 50.0, 0.5, 0.25);
        let s = Source::new(g, &geo, -1.0).unwrap();
        assert_eq!(s.height_at(10.0, 50.0), 0.0);
        assert!((s.height_at(10.75, 49.625) - 16.5).abs() < 1e-12);
        assert_eq!(s.height_at(11.0, 49.5), 22.0);
        // Half a sample outside still clamps to the edge; farther gets the fill.
        assert_eq!(s.height_at(9.8, 50.0), 0.0);
        assert_eq!(s.height_at(9.7, 50.0), -1.0);
        assert_eq!(s.height_at(10.0, 50.2), -1.0);
        // The same half sample on the far sides: columns 0..=4 end at lon 12, rows 0..=3 at
        // lat 49.25 (column 4 of row 0 is 4).
        assert_eq!(s.height_at(12.2, 50.0), 4.0);
        assert_eq!(s.height_at(12.3, 50.0), -1.0);
        assert_eq!(s.height_at(10.0, 49.25 - 0.1), 30.0);
        assert_eq!(s.height_at(10.0, 49.25 - 0.15), -1.0);
    }

    #[test]
    fn no_data_corners_drop_out() {
        let g = ramp();
        let geo = Georef::north_up(Crs::Geographic, 0.0, 0.0, 1.0, 1.0);
        let s = Source::new(g, &geo, -1.0).unwrap();
        // Between (2,3)=23, (2,4)=24, (3,3)=33 and the no-data (3,4).
        let h = s.height_at(3.5, -2.5);
        assert!((h - (23.0 + 24.0 + 33.0) / 3.0).abs() < 1e-12, "{h}");
        assert!(h.is_finite());
    }

    #[test]
    fn a_no_data_sample_itself_takes_a_valid_corner_not_the_fill() {
        let mut g = ramp();
        *g.get_mut(1, 1) = f64::NAN;
        let geo = Georef::north_up(Crs::Geographic, 0.0, 0.0, 1.0, 1.0);
        let s = Source::new(g, &geo, -1.0).unwrap();
        // On sample (1, 1) all the weight is on it; the zero-weight corners still hold data:
        // (1, 2) = 12 comes first.
        assert_eq!(s.height_at(1.0, -1.0), 12.0);
    }
}
