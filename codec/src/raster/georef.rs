//! Where a heightmap's samples sit on the Earth: a coordinate reference system and an affine
//! transform from (row, col) to world coordinates.
//!
//! Convention: the transform maps sample *centres* ("pixel is point"). A height sample is a
//! measurement at a point, and SRTM tiles make the difference visible: N44W072 has 1201 samples
//! from lat 44 to lat 45 inclusive, so its first sample is centred exactly on lat 45, lon −72.
//! GDAL's geotransform instead maps pixel *corners* ("pixel is area"), half a sample up and to
//! the left; [`Georef::to_gdal`] converts for tools that expect that.

use std::fmt;

/// A coordinate reference system, as far as zerotile's tiling schemes care.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Crs {
    /// EPSG:4326, x = longitude and y = latitude in degrees.
    Geographic,
    /// EPSG:3857 (Web/Pseudo-Mercator), metres.
    WebMercator,
    /// Another EPSG code (e.g. 32632, UTM zone 32N).
    Epsg(u16),
    /// The file gives a georeference but no CRS we can name.
    Unknown,
}

impl Crs {
    /// EPSG:4326 and EPSG:3857, the CRSs of the `geodetic` and `mercator` tiling schemes.
    pub const EPSG_GEOGRAPHIC: u16 = 4326;
    pub const EPSG_WEB_MERCATOR: u16 = 3857;

    /// Names an EPSG code, folding the two the tiling schemes use into their variants.
    pub fn from_epsg(code: u16) -> Self {
        match code {
            Self::EPSG_GEOGRAPHIC => Self::Geographic,
            // 3785 is the deprecated code for the same projection.
            Self::EPSG_WEB_MERCATOR | 3785 => Self::WebMercator,
            code => Self::Epsg(code),
        }
    }

    /// The EPSG code, if there is one.
    pub fn epsg(self) -> Option<u16> {
        match self {
            Self::Geographic => Some(Self::EPSG_GEOGRAPHIC),
            Self::WebMercator => Some(Self::EPSG_WEB_MERCATOR),
            Self::Epsg(code) => Some(code),
            Self::Unknown => None,
        }
    }
}

impl fmt::Display for Crs {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.epsg() {
            Some(code) => write!(f, "EPSG:{code}"),
            None => f.write_str("unknown CRS"),
        }
    }
}

/// A georeference: sample (`row`, `col`) has its centre at
/// `x = t[0] + col·t[1] + row·t[2]`, `y = t[3] + col·t[4] + row·t[5]` in `crs` units
/// (GDAL's layout of the six numbers, but centre-based: see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Georef {
    pub crs: Crs,
    pub transform: [f64; 6],
}

impl Georef {
    /// A north-up grid whose first sample is centred at (`x0`, `y0`), with sample spacings
    /// `dx` (east) and `dy` (south, positive).
    pub fn north_up(crs: Crs, x0: f64, y0: f64, dx: f64, dy: f64) -> Self {
        Self {
            crs,
            transform: [x0, dx, 0.0, y0, 0.0, -dy],
        }
    }

    /// World coordinates of the centre of sample (`row`, `col`); fractional indices
    /// interpolate, so (−0.5, −0.5) is the outer corner of the first sample.
    pub fn position(&self, row: f64, col: f64) -> (f64, f64) {
        let t = &self.transform;
        (
            t[0] + col * t[1] + row * t[2],
            t[3] + col * t[4] + row * t[5],
        )
    }

    /// The georeference of a window whose first sample is this grid's (`row`, `col`).
    #[must_use]
    pub fn shifted(&self, row: usize, col: usize) -> Self {
        // Grid indices are far below 2^52, so the conversion is exact.
        let (x, y) = self.position(row as f64, col as f64);
        let mut transform = self.transform;
        transform[0] = x;
        transform[3] = y;
        Self {
            crs: self.crs,
            transform,
        }
    }

    /// The same placement as a GDAL (corner-based, "pixel is area") geotransform.
    pub fn to_gdal(&self) -> [f64; 6] {
        let (x, y) = self.position(-0.5, -0.5);
        let t = &self.transform;
        [x, t[1], t[2], y, t[4], t[5]]
    }

    /// The inverse of [`Georef::to_gdal`].
    pub fn from_gdal(crs: Crs, gdal: [f64; 6]) -> Self {
        let t = gdal;
        Self {
            crs,
            transform: [
                t[0] + 0.5 * (t[1] + t[2]),
                t[1],
                t[2],
                t[3] + 0.5 * (t[4] + t[5]),
                t[4],
                t[5],
            ],
        }
    }

    /// Whether every number is finite and the transform is invertible (a file can hold zeros
    /// or NaNs where the scale belongs; such a georeference is useless, so readers drop it).
    pub fn is_valid(&self) -> bool {
        let t = &self.transform;
        let det = t[1] * t[5] - t[2] * t[4];
        t.iter().all(|v| v.is_finite()) && det != 0.0 && det.is_finite()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gdal_round_trip_moves_half_a_sample() {
        let g = Georef::north_up(Crs::Geographic, -72.0, 45.0, 0.5, 0.25);
        let gdal = g.to_gdal();
        assert_eq!(gdal, [-72.25, 0.5, 0.0, 45.125, 0.0, -0.25]);
        assert_eq!(Georef::from_gdal(Crs::Geographic, gdal), g);
    }

    #[test]
    fn shifted_moves_the_origin_to_the_window() {
        let g = Georef::north_up(Crs::WebMercator, 100.0, 200.0, 10.0, 5.0);
        let s = g.shifted(3, 4);
        assert_eq!(s.position(0.0, 0.0), g.position(3.0, 4.0));
        assert_eq!(s.position(2.0, 1.0), g.position(5.0, 5.0));
    }

    #[test]
    fn crs_names_epsg_codes() {
        assert_eq!(Crs::from_epsg(4326), Crs::Geographic);
        assert_eq!(Crs::from_epsg(3857), Crs::WebMercator);
        assert_eq!(Crs::from_epsg(32632), Crs::Epsg(32632));
        assert_eq!(Crs::Epsg(32632).to_string(), "EPSG:32632");
        assert_eq!(Crs::Unknown.epsg(), None);
    }
}
