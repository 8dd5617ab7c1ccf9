//! What every reader returns: heights in metres (or the file's unit), no-data as NaN, and what
//! the file says about precision and placement.

use super::georef::Georef;
use crate::error::ParamError;
use crate::geo::VerticalDatum;
use crate::grid::Grid;

/// A heightmap read from a file.
#[derive(Clone, Debug, PartialEq)]
pub struct Heightmap {
    /// Heights, row-major, row 0 = north (the top of the image); no-data samples are NaN.
    pub heights: Grid<f64>,
    /// The file's native height quantum: every valid height is an integer multiple of it
    /// (1 for integer rasters, 0.1 for terrain-RGB, 1/256 for Terrarium); `None` for float
    /// rasters, where the caller picks a step.
    pub step: Option<f64>,
    /// How many samples of `heights` are NaN.
    pub nodata_count: usize,
    /// Where the samples sit, when the file says.
    pub georef: Option<Georef>,
    /// What the heights are measured from, when the format says (SRTM: EGM96).
    pub vertical_datum: Option<VerticalDatum>,
}

impl Heightmap {
    /// Wraps heights read by a reader, counting the no-data samples once.
    pub fn new(heights: Grid<f64>, step: Option<f64>, georef: Option<Georef>) -> Self {
        let nodata_count = count_nodata(&heights);
        Self {
            heights,
            step,
            nodata_count,
            georef: georef.filter(Georef::is_valid),
            vertical_datum: None,
        }
    }

    /// Whether any sample is no-data.
    pub fn has_nodata(&self) -> bool {
        self.nodata_count > 0
    }

    /// The lowest and highest valid heights; `None` when every sample is no-data.
    pub fn min_max(&self) -> Option<(f64, f64)> {
        self.heights.min_max()
    }

    /// The `rows × cols` window whose first sample is (`row`, `col`), with its georeference
    /// moved to the window and its no-data recounted.
    pub fn crop(
        &self,
        row: usize,
        col: usize,
        rows: usize,
        cols: usize,
    ) -> Result<Heightmap, ParamError> {
        let heights = self.heights.crop(row, col, rows, cols)?;
        Ok(Self {
            nodata_count: count_nodata(&heights),
            heights,
            step: self.step,
            georef: self.georef.map(|g| g.shifted(row, col)),
            vertical_datum: self.vertical_datum,
        })
    }
}

fn count_nodata(heights: &Grid<f64>) -> usize {
    heights.data().iter().filter(|h| h.is_nan()).count()
}

#[cfg(test)]
mod tests {
    use super::super::georef::Crs;
    use super::*;

    fn sample() -> Heightmap {
        let heights = Grid::new(2, 3, vec![1.0, f64::NAN, 3.0, -4.0, 5.0, f64::NAN]).unwrap();
        let georef = Georef::north_up(Crs::Geographic, 10.0, 50.0, 0.5, 0.25);
        Heightmap::new(heights, Some(1.0), Some(georef))
    }

    #[test]
    fn counts_nodata_and_skips_it_in_min_max() {
        let map = sample();
        assert_eq!(map.nodata_count, 2);
        assert!(map.has_nodata());
        assert_eq!(map.min_max(), Some((-4.0, 5.0)));
    }

    #[test]
    fn crop_recounts_nodata_and_shifts_the_origin() {
        let map = sample();
        let crop = map.crop(1, 1, 1, 2).unwrap();
        assert_eq!((crop.heights.rows(), crop.heights.cols()), (1, 2));
        assert_eq!(crop.heights.data()[0], 5.0);
        assert!(crop.heights.data()[1].is_nan());
        assert_eq!(crop.nodata_count, 1);
        assert_eq!(crop.georef.unwrap().position(0.0, 0.0), (10.5, 49.75));
        assert!(map.crop(1, 1, 2, 2).is_err());
    }

    #[test]
    fn all_nodata_has_no_range_and_invalid_georef_is_dropped() {
        let heights = Grid::new(1, 2, vec![f64::NAN; 2]).unwrap();
        let flat = Georef::north_up(Crs::Unknown, 0.0, 0.0, 0.0, 1.0);
        let map = Heightmap::new(heights, None, Some(flat));
        assert_eq!(map.min_max(), None);
        assert_eq!(map.georef, None);
    }
}
