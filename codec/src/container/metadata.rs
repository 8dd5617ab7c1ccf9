//! What a dataset says about itself: the JSON at the head of the container.

use serde::{Deserialize, Serialize};

use crate::wavelet::Wavelet;

/// Dataset-wide facts, fixed at ingest.
///
/// Unknown fields are kept out of the type but tolerated when reading, so a newer writer's
/// extra facts do not make an older server refuse a dataset.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Metadata {
    pub name: String,
    /// `geodetic` (EPSG:4326 TMS), `mercator` (EPSG:3857 XYZ) or `local` (the source grid).
    pub scheme: String,
    /// Samples per tile side: 2^n + 1.
    pub tile_side: usize,
    pub min_zoom: u8,
    pub max_zoom: u8,
    /// West, south, east, north of the data: degrees, or samples for `local`.
    pub bounds: [f64; 4],
    /// Rows and columns of the source grid (the `local` scheme's full-resolution pyramid).
    pub source_size: [usize; 2],
    pub wavelet: Wavelet,
    /// Height units per coder unit (metres): the source's native step.
    pub step: f64,
    /// Max |stored − source| guaranteed by the streams' residual pass; `None` when the
    /// streams are lossless to the step.
    pub precision: Option<f64>,
    /// Lowest and highest height in the dataset (metres), the fill included where it is
    /// stored.
    pub height_range: [f64; 2],
    /// Lowest and highest height of the source's own samples, which on a world dataset
    /// `height_range` hides behind the fill around it. Absent in datasets ingested before
    /// it was recorded (read as `None`; not written then, so their bytes stay the same).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source_height_range: Option<[f64; 2]>,
    /// Height given to samples outside the source or without data.
    pub fill: f64,
    /// Eq. 4 of the paper: T = a·(A_v / A_t) + b.
    pub view: ViewParams,
    /// Per zoom (index = zoom − min_zoom), the tile ranges that exist.
    pub available: Vec<Vec<Availability>>,
    /// The source file's name and its coordinate reference system.
    pub source: String,
    pub source_crs: String,
    /// Samples coded and stream bytes stored, over the whole pyramid.
    pub samples: u64,
    pub stream_bytes: u64,
    /// RFC 3339 time of the ingest.
    pub created: String,
}

/// Per-dataset settings of the view-driven threshold (paper eq. 4), in height units.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ViewParams {
    pub a: f64,
    pub b: f64,
}

/// An inclusive rectangle of tiles at one zoom (Cesium's layer.json form).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Availability {
    pub start_x: u32,
    pub start_y: u32,
    pub end_x: u32,
    pub end_y: u32,
}

impl Availability {
    /// Tiles in the rectangle, exactly (the whole u32 square holds 2^64, one more than a
    /// u64); 0 for an inverted one (a hand-edited header), not an underflow.
    pub fn tile_count(&self) -> u128 {
        let side = |start: u32, end: u32| end.checked_sub(start).map_or(0, |d| u128::from(d) + 1);
        side(self.start_x, self.end_x) * side(self.start_y, self.end_y)
    }
}

#[cfg(test)]
mod tests {
    use super::Availability;

    #[test]
    fn an_availability_counts_its_inclusive_rectangle() {
        let a = |start_x, start_y, end_x, end_y| Availability {
            start_x,
            start_y,
            end_x,
            end_y,
        };
        assert_eq!(a(0, 0, 0, 0).tile_count(), 1);
        assert_eq!(a(2, 5, 4, 5).tile_count(), 3);
        assert_eq!(a(1, 1, 2, 3).tile_count(), 6);
        assert_eq!(a(0, 0, u32::MAX, 0).tile_count(), 1 << 32);
        assert_eq!(a(0, 0, u32::MAX, u32::MAX).tile_count(), 1 << 64);
        assert_eq!(a(3, 0, 2, 9).tile_count(), 0);
        assert_eq!(a(0, 4, 9, 3).tile_count(), 0);
    }
}
