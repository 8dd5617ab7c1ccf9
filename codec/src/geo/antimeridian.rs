//! Longitude bounds across the antimeridian, read as CesiumJS's `Rectangle` reads them: a
//! west edge past the east edge means the rectangle runs east from `min_x` over 180° to
//! `max_x` (Fiji's 177°..−179° is 2° wide, not 356°). Every consumer of a dataset's bounds
//! (layer.json, tiles.json, `/view`, ingest's availability) asks these questions through
//! these methods, so none reads west > east as empty or as the complement.
//!
//! The methods speak of longitude degrees: they are meant for the `geodetic` and `mercator`
//! schemes' lon/lat bounds, never for a local grid's samples (whose `min_x` is never past
//! its `max_x`).
//!
//! ```
//! use zerotile_codec::geo::Bounds;
//!
//! let fiji = Bounds { min_x: 177.0, min_y: -19.0, max_x: -179.0, max_y: -16.0 };
//! assert!(fiji.crosses_antimeridian());
//! assert_eq!(fiji.lon_width(), 4.0);
//! let parts = fiji.split_at_antimeridian();
//! assert_eq!((parts[0].min_x, parts[0].max_x), (177.0, 180.0));
//! assert_eq!((parts[1].min_x, parts[1].max_x), (-180.0, -179.0));
//! assert_eq!(fiji.lon_centre(), 179.0);
//! ```

use super::Bounds;

/// `lon` brought within [−180°, 180°) by whole turns: a difference of longitudes the short
/// way round (179.9° − −179.9° is −0.2°, not 359.8°).
pub fn wrap_longitude(lon: f64) -> f64 {
    lon - 360.0 * ((lon + 180.0) / 360.0).floor()
}

impl Bounds {
    /// Whether west is past east: the rectangle crosses the antimeridian.
    pub fn crosses_antimeridian(&self) -> bool {
        self.min_x > self.max_x
    }

    /// Degrees of longitude from west eastwards to east: `max_x − min_x`, plus 360 when the
    /// rectangle crosses the antimeridian.
    pub fn lon_width(&self) -> f64 {
        if self.crosses_antimeridian() {
            self.max_x + 360.0 - self.min_x
        } else {
            self.max_x - self.min_x
        }
    }

    /// The longitude in the middle of the rectangle: `(west + east) / 2`, or across the
    /// antimeridian that a half turn on, within (−180°, 180°].
    pub fn lon_centre(&self) -> f64 {
        if !self.crosses_antimeridian() {
            return (self.min_x + self.max_x) / 2.0;
        }
        let mid = (self.min_x + self.max_x + 360.0) / 2.0;
        if mid > 180.0 {
            mid - 360.0
        } else {
            mid
        }
    }

    /// The rectangle as parts that do not wrap, west first: itself, or across the
    /// antimeridian its part from west to 180° and its part from −180° to east.
    pub fn split_at_antimeridian(&self) -> Vec<Bounds> {
        if self.crosses_antimeridian() {
            vec![
                Bounds {
                    max_x: 180.0,
                    ..*self
                },
                Bounds {
                    min_x: -180.0,
                    ..*self
                },
            ]
        } else {
            vec![*self]
        }
    }

    /// The smallest rectangle that does not wrap and holds this one: itself, or every
    /// longitude when it crosses the antimeridian (what a format whose bounds may not wrap,
    /// TileJSON's or layer.json's, can say of it).
    pub fn without_wrap(&self) -> Bounds {
        if self.crosses_antimeridian() {
            Bounds {
                min_x: -180.0,
                max_x: 180.0,
                ..*self
            }
        } else {
            *self
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lon(min_x: f64, max_x: f64) -> Bounds {
        Bounds {
            min_x,
            min_y: -10.0,
            max_x,
            max_y: 10.0,
        }
    }

    #[test]
    fn longitudes_wrap_the_short_way_round() {
        assert_eq!(wrap_longitude(359.8), 359.8 - 360.0);
        assert_eq!(wrap_longitude(-359.8), -359.8 + 360.0);
        assert_eq!(wrap_longitude(10.0), 10.0);
        assert_eq!(wrap_longitude(-180.0), -180.0);
        assert_eq!(wrap_longitude(180.0), -180.0);
        assert_eq!(wrap_longitude(725.0), 5.0);
    }

    #[test]
    fn bounds_within_180_are_unchanged() {
        let b = lon(-72.0, -71.0);
        assert!(!b.crosses_antimeridian());
        assert_eq!(b.lon_width(), 1.0);
        assert_eq!(b.lon_centre(), -71.5);
        assert_eq!(b.split_at_antimeridian(), vec![b]);
        assert_eq!(b.without_wrap(), b);
        // The whole world is not across: −180..180 is one part.
        let world = lon(-180.0, 180.0);
        assert!(!world.crosses_antimeridian());
        assert_eq!(world.lon_width(), 360.0);
        assert_eq!(world.split_at_antimeridian(), vec![world]);
    }

    #[test]
    fn west_past_east_is_measured_eastwards_over_180() {
        let b = lon(178.0, -178.0);
        assert!(b.crosses_antimeridian());
        assert_eq!(b.lon_width(), 4.0);
        assert_eq!(b.lon_centre(), 180.0);
        assert_eq!(lon(177.0, -179.0).lon_centre(), 179.0);
        assert_eq!(lon(179.0, -177.0).lon_centre(), -179.0);
        assert_eq!(
            b.split_at_antimeridian(),
            vec![lon(178.0, 180.0), lon(-180.0, -178.0)]
        );
        assert_eq!(b.without_wrap(), lon(-180.0, 180.0));
        // The parts' widths add up to the whole's.
        let sum: f64 = b
            .split_at_antimeridian()
            .iter()
            .map(Bounds::lon_width)
            .sum();
        assert_eq!(sum, b.lon_width());
    }
}
