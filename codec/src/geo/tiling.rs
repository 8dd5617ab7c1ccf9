//! Tiling schemes: which part of the world (or of a bare grid) tile z/x/y covers, where its
//! samples sit, and how much geometric error a client allows at each zoom.
//!
//! References:
//! - CesiumGS quantized-mesh-1.0 README, "Tiling Scheme and Coordinate System", and CesiumJS
//!   `GeographicTilingScheme` (2 × 1 tiles at level 0, TMS rows counted from the south).
//! - OSGeo Tile Map Service specification (TMS) and the XYZ ("slippy map") convention
//!   MapLibre uses for EPSG:3857 (one tile at zoom 0, rows from the north, latitudes cut at
//!   ±85.0511°, where the square world ends: atan(sinh π)).
//! - CesiumJS `TerrainProvider.getEstimatedLevelZeroGeometricErrorForAHeightmap`: the
//!   level-0 geometric error a client assumes, Q·2πa / (W·N₀) (see [`Tiling::level_geometric_error`]).
//!
//! Tiles are (2^n + 1) samples a side and neighbours share their edge samples. Sample
//! positions are computed from a global sample index, `lo + (extent · g) / N` with integers g
//! and N, so a shared edge sample is the same f64 in both tiles, and the parent's sample g is
//! bit-identical to its children's sample 2g (both are the correctly rounded value of the same
//! rational). A zoom-(z − 1) tile's samples are therefore exactly the even samples of its four
//! children.
//!
//! ```
//! use zerotile_codec::geo::{Scheme, TileId, Tiling};
//!
//! let geodetic = Tiling::new(Scheme::Geodetic, 257)?;
//! let b = geodetic.tile_bounds(TileId::new(0, 0, 0))?;
//! assert_eq!([b.min_x, b.min_y, b.max_x, b.max_y], [-180.0, -90.0, 0.0, 90.0]);
//! assert!((geodetic.level_geometric_error(0) - 77_067.34).abs() < 0.01);
//! # Ok::<(), zerotile_codec::geo::TilingError>(())
//! ```

use std::f64::consts::PI;

use super::Ellipsoid;

/// Deepest zoom of the geodetic and mercator schemes: 2^29 tiles across, so every global
/// sample index (tiles × 2^15 samples) stays far inside f64's exact integers.
pub const MAX_ZOOM: u8 = 28;

/// Largest tile side accepted, 2^15 + 1 samples.
pub const MAX_SIDE: u32 = (1 << 15) + 1;

/// Latitude where EPSG:3857's square world ends, degrees: atan(sinh π).
pub const MERCATOR_MAX_LATITUDE: f64 = 85.051_128_779_806_59;

/// Half the width of EPSG:3857's square world, metres: π·a.
pub const MERCATOR_HALF_EXTENT: f64 = PI * Ellipsoid::WGS84.a;

/// Cesium's `TerrainProvider.heightmapTerrainQuality`.
const CESIUM_HEIGHTMAP_QUALITY: f64 = 0.25;

/// Cesium's default heightmap width, samples: the "W" in its level-0 error estimate.
const CESIUM_HEIGHTMAP_WIDTH: f64 = 65.0;

/// Metres per degree of longitude on the equator, 2πa / 360.
const METRES_PER_DEGREE: f64 = 2.0 * PI * Ellipsoid::WGS84.a / 360.0;

/// How tiles cut the world, or a grid without georeference.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scheme {
    /// EPSG:4326, Cesium's TMS grid: 2 × 1 tiles at zoom 0, tile y counted from the south.
    /// CRS units: degrees (x = longitude, y = latitude).
    Geodetic,
    /// EPSG:3857 XYZ as MapLibre expects: 1 tile at zoom 0, tile y counted from the north,
    /// latitudes within ±[`MERCATOR_MAX_LATITUDE`]. CRS units: metres.
    Mercator,
    /// The input grid itself (`rows` × `cols` samples, no georeference). The deepest zoom is
    /// the full-resolution grid; each zoom above halves the resolution, until zoom 0 has one
    /// tile covering everything. Tile y counts from the top (row 0). CRS units: full-
    /// resolution sample coordinates (x = column, y = row); tiles at the right and bottom may
    /// reach past the grid, and the caller pads those samples.
    Local { rows: usize, cols: usize },
}

/// One tile: zoom `z`, column `x`, row `y` (counted as the scheme says).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct TileId {
    pub z: u8,
    pub x: u32,
    pub y: u32,
}

impl TileId {
    pub fn new(z: u8, x: u32, y: u32) -> Self {
        Self { z, x, y }
    }

    /// The tile one zoom up that contains this one; `None` at zoom 0.
    pub fn parent(self) -> Option<Self> {
        let z = self.z.checked_sub(1)?;
        Some(Self::new(z, self.x / 2, self.y / 2))
    }

    /// The four tiles one zoom down: (2x, 2y), (2x + 1, 2y), (2x, 2y + 1), (2x + 1, 2y + 1).
    /// `None` when the zoom or the indices would overflow.
    pub fn children(self) -> Option<[Self; 4]> {
        let z = self.z.checked_add(1)?;
        let (x, y) = (self.x.checked_mul(2)?, self.y.checked_mul(2)?);
        let (x1, y1) = (x.checked_add(1)?, y.checked_add(1)?);
        Some([
            Self::new(z, x, y),
            Self::new(z, x1, y),
            Self::new(z, x, y1),
            Self::new(z, x1, y1),
        ])
    }
}

/// An axis-aligned rectangle in a scheme's CRS (see [`Scheme`] for units). For
/// [`Scheme::Local`], y grows downwards, so `min_y` is the top edge.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub min_x: f64,
    pub min_y: f64,
    pub max_x: f64,
    pub max_y: f64,
}

impl From<[f64; 4]> for Bounds {
    /// West (min x), south, east, north: the order of a dataset's `bounds`.
    fn from([min_x, min_y, max_x, max_y]: [f64; 4]) -> Self {
        Self {
            min_x,
            min_y,
            max_x,
            max_y,
        }
    }
}

/// How a tile's sample rows map to latitude.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RowSpacing {
    /// Rows are evenly spaced in latitude (geodetic tiles).
    Latitude,
    /// Rows are evenly spaced in Web Mercator y (mercator tiles).
    MercatorY,
}

/// A tile's footprint in longitude and latitude, degrees, and how its rows are spaced.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TileGeo {
    pub west: f64,
    pub south: f64,
    pub east: f64,
    pub north: f64,
    pub rows: RowSpacing,
}

impl TileGeo {
    /// A geodetic tile (rows evenly spaced in latitude).
    pub fn geodetic(west: f64, south: f64, east: f64, north: f64) -> Self {
        Self {
            west,
            south,
            east,
            north,
            rows: RowSpacing::Latitude,
        }
    }

    /// Latitude (degrees) of fractional row `t` ∈ [0, 1] from the north edge.
    pub fn latitude_at(&self, t: f64) -> f64 {
        match self.rows {
            RowSpacing::Latitude => self.north - t * (self.north - self.south),
            RowSpacing::MercatorY => {
                let (yn, ys) = (mercator_y(self.north), mercator_y(self.south));
                mercator_latitude(yn - t * (yn - ys))
            }
        }
    }
}

/// The tiles x0..=x1, y0..=y1 of zoom `z`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TileRange {
    pub z: u8,
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
}

impl TileRange {
    /// Number of tiles in the range.
    pub fn count(&self) -> u64 {
        (u64::from(self.x1) - u64::from(self.x0) + 1)
            * (u64::from(self.y1) - u64::from(self.y0) + 1)
    }

    /// Whether `tile` is in the range.
    pub fn contains(&self, tile: TileId) -> bool {
        tile.z == self.z
            && (self.x0..=self.x1).contains(&tile.x)
            && (self.y0..=self.y1).contains(&tile.y)
    }

    /// The tiles, row by row.
    pub fn tiles(&self) -> impl Iterator<Item = TileId> + '_ {
        (self.y0..=self.y1)
            .flat_map(move |y| (self.x0..=self.x1).map(move |x| TileId::new(self.z, x, y)))
    }
}

/// The spacing of a source raster's samples, for [`Tiling::default_max_zoom`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Resolution {
    /// Degrees per sample (a geographic source, e.g. 1/1200 for SRTM3).
    Degrees(f64),
    /// Metres per sample (a projected source; for EPSG:3857 its own pixel size).
    Metres(f64),
}

/// Why a tiling question has no answer.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum TilingError {
    #[error("tile side must be 2^n + 1 samples with 1 ≤ n ≤ 15, got {0}")]
    Side(u32),
    #[error(
        "a local grid needs at least 2 × 2 samples and fits zoom {MAX_ZOOM}, got {rows} × {cols} \
         (rows × columns)"
    )]
    LocalGrid { rows: usize, cols: usize },
    #[error("zoom {z} is deeper than this tiling's deepest zoom {max}")]
    Zoom { z: u8, max: u8 },
    #[error("tile {z}/{x}/{y} is outside zoom {z}'s {nx}×{ny} tiles")]
    Tile {
        z: u8,
        x: u32,
        y: u32,
        nx: u32,
        ny: u32,
    },
    #[error("sample ({row}, {col}) is outside a {side}×{side} tile")]
    Sample { row: u32, col: u32, side: u32 },
    #[error("the local scheme has no georeference")]
    NoGeoreference,
    #[error("{name} must be {expected}, got {got}")]
    Parameter {
        name: &'static str,
        expected: &'static str,
        got: f64,
    },
}

/// A scheme with a tile side: everything needed to place tiles and samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tiling {
    scheme: Scheme,
    side: u32,
    /// Deepest zoom: [`MAX_ZOOM`], or the full-resolution zoom of a local grid.
    max_zoom: u8,
}

impl Tiling {
    /// A tiling of `scheme` with tiles of `side` = 2^n + 1 samples (1 ≤ n ≤ 15; 257 is
    /// zerotile's default).
    pub fn new(scheme: Scheme, side: u32) -> Result<Self, TilingError> {
        // Side: 2^n + 1 so tiles share edges and halve cleanly.
        if !(3..=MAX_SIDE).contains(&side) || !(side - 1).is_power_of_two() {
            return Err(TilingError::Side(side));
        }

        // Deepest zoom: fixed for the world schemes; for a local grid, the first zoom whose
        // single tile covers the whole grid, counted from the top.
        let max_zoom = match scheme {
            Scheme::Geodetic | Scheme::Mercator => MAX_ZOOM,
            Scheme::Local { rows, cols } => {
                let bad = || TilingError::LocalGrid { rows, cols };
                if rows < 2 || cols < 2 {
                    return Err(bad());
                }
                let need = u64::try_from(rows.max(cols) - 1).map_err(|_| bad())?;
                (0..=MAX_ZOOM)
                    .find(|&z| u64::from(side - 1) << z >= need)
                    .ok_or_else(bad)?
            }
        };
        Ok(Self {
            scheme,
            side,
            max_zoom,
        })
    }

    pub fn scheme(&self) -> Scheme {
        self.scheme
    }

    /// Samples along a tile side.
    pub fn side(&self) -> u32 {
        self.side
    }

    /// The deepest zoom: [`MAX_ZOOM`] for the world schemes, the full-resolution zoom of a
    /// local grid.
    pub fn max_zoom(&self) -> u8 {
        self.max_zoom
    }

    /// Tiles across and down at zoom `z`.
    pub fn tiles_per_axis(&self, z: u8) -> Result<(u32, u32), TilingError> {
        if z > self.max_zoom {
            return Err(TilingError::Zoom {
                z,
                max: self.max_zoom,
            });
        }
        Ok(match self.scheme {
            Scheme::Geodetic => (2 << z, 1 << z),
            Scheme::Mercator => (1 << z, 1 << z),
            Scheme::Local { rows, cols } => {
                let span = self.local_span(z);
                let across = |n: usize| ((n as u64 - 1).div_ceil(span)).max(1) as u32;
                (across(cols), across(rows))
            }
        })
    }

    /// The tile's extent in the scheme's CRS: degrees, EPSG:3857 metres, or full-resolution
    /// sample coordinates (see [`Scheme`]). Equal to its corner samples' positions.
    pub fn tile_bounds(&self, tile: TileId) -> Result<Bounds, TilingError> {
        let last = self.side - 1;
        let [min_x, y0] = self.sample_position(tile, 0, 0)?;
        let [max_x, y1] = self.sample_position(tile, last, last)?;
        // Row 0 is the north (top) edge.
        Ok(match self.scheme {
            Scheme::Geodetic | Scheme::Mercator => Bounds {
                min_x,
                min_y: y1,
                max_x,
                max_y: y0,
            },
            Scheme::Local { .. } => Bounds {
                min_x,
                min_y: y0,
                max_x,
                max_y: y1,
            },
        })
    }

    /// The tile's footprint in longitude and latitude; an error for a local grid.
    pub fn tile_geo(&self, tile: TileId) -> Result<TileGeo, TilingError> {
        let b = self.tile_bounds(tile)?;
        match self.scheme {
            Scheme::Geodetic => Ok(TileGeo::geodetic(b.min_x, b.min_y, b.max_x, b.max_y)),
            Scheme::Mercator => {
                let [west, south] = mercator_to_lonlat([b.min_x, b.min_y]);
                let [east, north] = mercator_to_lonlat([b.max_x, b.max_y]);
                Ok(TileGeo {
                    west,
                    south,
                    east,
                    north,
                    rows: RowSpacing::MercatorY,
                })
            }
            Scheme::Local { .. } => Err(TilingError::NoGeoreference),
        }
    }

    /// The tiles of zoom `z` that cover `bbox`: longitude/latitude degrees for the world
    /// schemes, sample coordinates for a local grid. A bbox edge on a tile boundary does not
    /// pull in the tile beyond it. `None` when the bbox misses the scheme's extent.
    pub fn tile_range(&self, z: u8, bbox: &Bounds) -> Result<Option<TileRange>, TilingError> {
        // The bbox must be a real rectangle.
        let coords = [bbox.min_x, bbox.min_y, bbox.max_x, bbox.max_y];
        if let Some(&bad) = coords.iter().find(|v| !v.is_finite()) {
            return Err(param("bbox coordinate", "finite", bad));
        }
        if bbox.min_x > bbox.max_x || bbox.min_y > bbox.max_y {
            return Err(param("bbox min", "≤ max", bbox.min_x.max(bbox.min_y)));
        }
        let (nx, ny) = self.tiles_per_axis(z)?;
        let (fnx, fny) = (f64::from(nx), f64::from(ny));

        // Fractional tile coordinates of the bbox edges, each axis ascending with tile index.
        let ((x_lo, x_hi), (y_lo, y_hi)) = match self.scheme {
            Scheme::Geodetic => {
                let fx = |lon: f64| (lon + 180.0) / 360.0 * fnx;
                let fy = |lat: f64| (lat + 90.0) / 180.0 * fny;
                (
                    (fx(bbox.min_x), fx(bbox.max_x)),
                    (fy(bbox.min_y), fy(bbox.max_y)),
                )
            }
            Scheme::Mercator => {
                let fx = |lon: f64| (lon + 180.0) / 360.0 * fnx;
                let fy = |lat: f64| {
                    let y = mercator_y(lat.clamp(-MERCATOR_MAX_LATITUDE, MERCATOR_MAX_LATITUDE));
                    (MERCATOR_HALF_EXTENT - y) / (2.0 * MERCATOR_HALF_EXTENT) * fny
                };
                (
                    (fx(bbox.min_x), fx(bbox.max_x)),
                    (fy(bbox.max_y), fy(bbox.min_y)),
                )
            }
            Scheme::Local { .. } => {
                let span = self.local_span(z) as f64;
                (
                    (bbox.min_x / span, bbox.max_x / span),
                    (bbox.min_y / span, bbox.max_y / span),
                )
            }
        };

        // Index ranges: floor of the low edge to ceil of the high edge minus one.
        let axis = |lo: f64, hi: f64, n: f64| -> Option<(u32, u32)> {
            if hi < 0.0 || lo > n {
                return None;
            }
            let first = lo.floor().clamp(0.0, n - 1.0);
            let last = (hi.ceil() - 1.0).max(lo.floor()).clamp(0.0, n - 1.0);
            Some((first as u32, last as u32))
        };
        let Some((x0, x1)) = axis(x_lo, x_hi, fnx) else {
            return Ok(None);
        };
        let Some((y0, y1)) = axis(y_lo, y_hi, fny) else {
            return Ok(None);
        };
        Ok(Some(TileRange { z, x0, y0, x1, y1 }))
    }

    /// Position of sample (`row`, `col`) of `tile` in the scheme's CRS as `[x, y]`: `[lon,
    /// lat]` degrees, EPSG:3857 `[x, y]` metres, or full-resolution `[col, row]` for a local
    /// grid. Row 0 is the tile's north (top) edge, column 0 its west (left) edge.
    pub fn sample_position(
        &self,
        tile: TileId,
        row: u32,
        col: u32,
    ) -> Result<[f64; 2], TilingError> {
        // Check the tile and the sample, then index the sample globally at this zoom.
        let (nx, ny) = self.tiles_per_axis(tile.z)?;
        if tile.x >= nx || tile.y >= ny {
            return Err(TilingError::Tile {
                z: tile.z,
                x: tile.x,
                y: tile.y,
                nx,
                ny,
            });
        }
        if row >= self.side || col >= self.side {
            return Err(TilingError::Sample {
                row,
                col,
                side: self.side,
            });
        }
        let cells = u64::from(self.side - 1);
        let g_col = u64::from(tile.x) * cells + u64::from(col);
        // Global row counted from the north (top) edge of the world.
        let top_row = match self.scheme {
            Scheme::Geodetic => u64::from(ny - 1 - tile.y),
            Scheme::Mercator | Scheme::Local { .. } => u64::from(tile.y),
        };
        let g_row = top_row * cells + u64::from(row);
        let (n_cols, n_rows) = (u64::from(nx) * cells, u64::from(ny) * cells);

        // Exact rationals: lo + (extent · g) / n, the same f64 from every tile that has it.
        let lerp = |lo: f64, extent: f64, g: u64, n: u64| lo + (extent * g as f64) / n as f64;
        Ok(match self.scheme {
            Scheme::Geodetic => [
                lerp(-180.0, 360.0, g_col, n_cols),
                lerp(90.0, -180.0, g_row, n_rows),
            ],
            Scheme::Mercator => {
                let e = MERCATOR_HALF_EXTENT;
                [
                    lerp(-e, 2.0 * e, g_col, n_cols),
                    lerp(e, -2.0 * e, g_row, n_rows),
                ]
            }
            Scheme::Local { .. } => {
                let stride = self.local_span(tile.z) / cells;
                [(g_col * stride) as f64, (g_row * stride) as f64]
            }
        })
    }

    /// `[lon, lat]` (degrees) of sample (`row`, `col`) of `tile`; an error for a local grid.
    pub fn sample_lonlat(&self, tile: TileId, row: u32, col: u32) -> Result<[f64; 2], TilingError> {
        let p = self.sample_position(tile, row, col)?;
        match self.scheme {
            Scheme::Geodetic => Ok(p),
            Scheme::Mercator => Ok(mercator_to_lonlat(p)),
            Scheme::Local { .. } => Err(TilingError::NoGeoreference),
        }
    }

    /// The geometric error a client allows at zoom `z`: CesiumJS's level-0 estimate halved
    /// per level, E(z) = Q · C / (W · N₀ · 2^z), with Q = 0.25 (Cesium's
    /// `heightmapTerrainQuality`), C = 2π · 6 378 137 m (the equator), W = 65 (Cesium's
    /// heightmap width) and N₀ the tiles across at zoom 0.
    ///
    /// - Geodetic (N₀ = 2): 77 067.34 m at zoom 0, what CesiumJS uses for quantized-mesh.
    /// - Mercator (N₀ = 1): 154 134.68 m at zoom 0, the same rule for one root tile.
    /// - Local: the same rule with C/N₀ replaced by the zoom-0 tile's width, so the result is
    ///   in full-resolution sample spacings: 0.25 · (side − 1) · 2^(max_zoom − z) / 65.
    pub fn level_geometric_error(&self, z: u8) -> f64 {
        let halvings = f64::from(z).exp2();
        match self.scheme {
            Scheme::Geodetic | Scheme::Mercator => {
                let (n0, _) = self.tiles_per_axis(0).unwrap_or((1, 1));
                let circumference = 2.0 * PI * Ellipsoid::WGS84.a;
                CESIUM_HEIGHTMAP_QUALITY * circumference
                    / (CESIUM_HEIGHTMAP_WIDTH * f64::from(n0) * halvings)
            }
            Scheme::Local { .. } => {
                let width = f64::from(self.side - 1) * f64::from(self.max_zoom).exp2();
                CESIUM_HEIGHTMAP_QUALITY * width / (CESIUM_HEIGHTMAP_WIDTH * halvings)
            }
        }
    }

    /// The shallowest zoom whose sample spacing is no coarser than the source's, so the
    /// deepest tiles keep every source sample's detail; capped at [`Tiling::max_zoom`].
    ///
    /// Geodetic tiles have 180° / (2^z · (side − 1)) per sample; mercator tiles
    /// 2πa / (2^z · (side − 1)) metres per sample on the equator (degrees convert at
    /// 111 319.49 m/°, exact for mercator x). Metres for a geodetic tiling convert at the
    /// equator too. A local grid's deepest zoom is its own resolution, whatever `source` says.
    pub fn default_max_zoom(&self, source: Resolution) -> Result<u8, TilingError> {
        // Source spacing in the scheme's units per sample.
        let (value, name) = match source {
            Resolution::Degrees(d) => (d, "source resolution (degrees)"),
            Resolution::Metres(m) => (m, "source resolution (metres)"),
        };
        if !(value.is_finite() && value > 0.0) {
            return Err(param(name, "finite and > 0", value));
        }
        let (source_spacing, zoom0_spacing) = match (self.scheme, source) {
            (Scheme::Local { .. }, _) => return Ok(self.max_zoom),
            (Scheme::Geodetic, Resolution::Degrees(d)) => (d, 180.0),
            (Scheme::Geodetic, Resolution::Metres(m)) => (m / METRES_PER_DEGREE, 180.0),
            (Scheme::Mercator, Resolution::Degrees(d)) => {
                (d * METRES_PER_DEGREE, 2.0 * MERCATOR_HALF_EXTENT)
            }
            (Scheme::Mercator, Resolution::Metres(m)) => (m, 2.0 * MERCATOR_HALF_EXTENT),
        };

        // Halve until fine enough; a relative slack absorbs rounding at exact powers of two.
        let cells = f64::from(self.side - 1);
        Ok((0..=self.max_zoom)
            .find(|&z| {
                zoom0_spacing / (cells * f64::from(z).exp2()) <= source_spacing * (1.0 + 1e-9)
            })
            .unwrap_or(self.max_zoom))
    }

    /// Full-resolution samples spanned by one local tile at zoom `z`.
    fn local_span(&self, z: u8) -> u64 {
        u64::from(self.side - 1) << (self.max_zoom - z.min(self.max_zoom))
    }
}

/// EPSG:3857 y (metres) of latitude `lat` (degrees); unbounded towards the poles.
pub fn mercator_y(lat: f64) -> f64 {
    let phi = lat.to_radians();
    Ellipsoid::WGS84.a * (PI / 4.0 + phi / 2.0).tan().ln()
}

/// Latitude (degrees) of EPSG:3857 y (metres).
pub fn mercator_latitude(y: f64) -> f64 {
    (y / Ellipsoid::WGS84.a).sinh().atan().to_degrees()
}

/// `[lon, lat]` degrees of EPSG:3857 `[x, y]` metres.
pub fn mercator_to_lonlat([x, y]: [f64; 2]) -> [f64; 2] {
    [(x / Ellipsoid::WGS84.a).to_degrees(), mercator_latitude(y)]
}

/// EPSG:3857 `[x, y]` metres of `[lon, lat]` degrees.
pub fn lonlat_to_mercator([lon, lat]: [f64; 2]) -> [f64; 2] {
    [Ellipsoid::WGS84.a * lon.to_radians(), mercator_y(lat)]
}

fn param(name: &'static str, expected: &'static str, got: f64) -> TilingError {
    TilingError::Parameter {
        name,
        expected,
        got,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tiling(scheme: Scheme, side: u32) -> Tiling {
        Tiling::new(scheme, side).unwrap()
    }

    fn corners(b: Bounds) -> [f64; 4] {
        [b.min_x, b.min_y, b.max_x, b.max_y]
    }

    #[test]
    fn geodetic_tiles_match_the_quantized_mesh_readme() {
        let t = tiling(Scheme::Geodetic, 257);
        assert_eq!(t.tiles_per_axis(0).unwrap(), (2, 1));
        assert_eq!(t.tiles_per_axis(1).unwrap(), (4, 2));
        let cases = [
            ((0, 0, 0), [-180.0, -90.0, 0.0, 90.0]),
            ((0, 1, 0), [0.0, -90.0, 180.0, 90.0]),
            ((1, 0, 0), [-180.0, -90.0, -90.0, 0.0]),
            ((1, 1, 0), [-90.0, -90.0, 0.0, 0.0]),
            ((1, 2, 0), [0.0, -90.0, 90.0, 0.0]),
            ((1, 3, 0), [90.0, -90.0, 180.0, 0.0]),
            ((1, 0, 1), [-180.0, 0.0, -90.0, 90.0]),
            ((1, 3, 1), [90.0, 0.0, 180.0, 90.0]),
        ];
        for ((z, x, y), expect) in cases {
            let b = t.tile_bounds(TileId::new(z, x, y)).unwrap();
            assert_eq!(corners(b), expect, "{z}/{x}/{y}");
        }
        let g = t.tile_geo(TileId::new(1, 0, 1)).unwrap();
        assert_eq!(g, TileGeo::geodetic(-180.0, 0.0, -90.0, 90.0));
    }

    #[test]
    fn mercator_tiles_match_the_slippy_map_formulas() {
        let t = tiling(Scheme::Mercator, 257);
        let e = MERCATOR_HALF_EXTENT;
        assert_eq!(e, 20_037_508.342_789_244);
        assert_eq!(
            corners(t.tile_bounds(TileId::new(0, 0, 0)).unwrap()),
            [-e, -e, e, e]
        );
        // Zoom 1, y counted from the north: 1/0/0 is the north-west quarter.
        assert_eq!(
            corners(t.tile_bounds(TileId::new(1, 0, 0)).unwrap()),
            [-e, 0.0, 0.0, e]
        );
        // 10/163/395 (San Francisco): the OSM wiki's lon/lat ↔ tile formulas.
        let g = t.tile_geo(TileId::new(10, 163, 395)).unwrap();
        assert!((g.west + 122.695_312_5).abs() < 1e-9 && (g.east + 122.343_75).abs() < 1e-9);
        assert!(
            (g.north - 37.996_162_679_728_12).abs() < 1e-9,
            "{}",
            g.north
        );
        assert!(
            (g.south - 37.718_590_325_588_146).abs() < 1e-9,
            "{}",
            g.south
        );
        assert_eq!(g.rows, RowSpacing::MercatorY);
        let world = t.tile_geo(TileId::new(0, 0, 0)).unwrap();
        assert!((world.north - MERCATOR_MAX_LATITUDE).abs() < 1e-9);
        assert!((world.south + MERCATOR_MAX_LATITUDE).abs() < 1e-9);
    }

    #[test]
    fn mercator_rows_are_even_in_projected_y() {
        let t = tiling(Scheme::Mercator, 9);
        let tile = TileId::new(3, 2, 1);
        let g = t.tile_geo(tile).unwrap();
        for row in 0..9 {
            let [_, lat] = t.sample_lonlat(tile, row, 4).unwrap();
            let at = g.latitude_at(f64::from(row) / 8.0);
            assert!((lat - at).abs() < 1e-9, "row {row}: {lat} vs {at}");
        }
        let [x, y] = lonlat_to_mercator([12.5, -33.0]);
        let [lon, lat] = mercator_to_lonlat([x, y]);
        assert!((lon - 12.5).abs() < 1e-12 && (lat + 33.0).abs() < 1e-12);
    }

    /// Every (scheme, side) pair the sample tests walk.
    fn tilings() -> Vec<Tiling> {
        let mut all = Vec::new();
        for side in [3, 9, 257] {
            all.push(tiling(Scheme::Geodetic, side));
            all.push(tiling(Scheme::Mercator, side));
            all.push(tiling(
                Scheme::Local {
                    rows: 1201,
                    cols: 700,
                },
                side,
            ));
        }
        all
    }

    #[test]
    fn neighbouring_tiles_share_edge_samples_bit_for_bit() {
        for t in tilings() {
            let last = t.side() - 1;
            for z in 0..=t.max_zoom().min(6) {
                let (nx, ny) = t.tiles_per_axis(z).unwrap();
                for (x, y) in [
                    (0, 0),
                    (nx / 2, ny / 2),
                    (nx.saturating_sub(2), ny.saturating_sub(2)),
                ] {
                    let a = TileId::new(z, x, y);
                    for k in 0..=last {
                        if x + 1 < nx {
                            let b = TileId::new(z, x + 1, y);
                            let pa = t.sample_position(a, k, last).unwrap();
                            let pb = t.sample_position(b, k, 0).unwrap();
                            assert_eq!(pa, pb, "{t:?} east edge of {a:?} row {k}");
                        }
                        if y + 1 < ny {
                            let b = TileId::new(z, x, y + 1);
                            // Tile y + 1 is north of y in TMS (geodetic), south otherwise.
                            let (ra, rb) = match t.scheme() {
                                Scheme::Geodetic => (0, last),
                                _ => (last, 0),
                            };
                            let pa = t.sample_position(a, ra, k).unwrap();
                            let pb = t.sample_position(b, rb, k).unwrap();
                            assert_eq!(pa, pb, "{t:?} shared row of {a:?} and {b:?}, col {k}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn parent_samples_are_the_even_samples_of_its_children() {
        for t in tilings() {
            let half = (t.side() - 1) / 2;
            for z in 0..t.max_zoom().min(6) {
                let (nx, ny) = t.tiles_per_axis(z).unwrap();
                for parent in [
                    TileId::new(z, 0, 0),
                    TileId::new(z, nx - 1, ny - 1),
                    TileId::new(z, nx / 2, ny / 3),
                ] {
                    for child in parent.children().unwrap() {
                        let (cx, cy) = t.tiles_per_axis(z + 1).unwrap();
                        if child.x >= cx || child.y >= cy {
                            continue; // a local grid's edge parent can have fewer children
                        }
                        assert_eq!(child.parent(), Some(parent));
                        // Where the child sits in the parent, in parent samples.
                        let col0 = (child.x - 2 * parent.x) * half;
                        let row0 = match t.scheme() {
                            Scheme::Geodetic => (1 - (child.y - 2 * parent.y)) * half,
                            _ => (child.y - 2 * parent.y) * half,
                        };
                        for r in 0..=half {
                            for c in 0..=half {
                                let pp = t.sample_position(parent, row0 + r, col0 + c).unwrap();
                                let pc = t.sample_position(child, 2 * r, 2 * c).unwrap();
                                assert_eq!(pp, pc, "{t:?} {parent:?} → {child:?} ({r}, {c})");
                            }
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn local_pyramid_halves_until_one_tile_covers_the_grid() {
        // 1201 × 1201 (an SRTM3 tile) in 257-sample tiles: 1200 ≤ 256 · 2^3.
        let t = tiling(
            Scheme::Local {
                rows: 1201,
                cols: 1201,
            },
            257,
        );
        assert_eq!(t.max_zoom(), 3);
        assert_eq!(t.tiles_per_axis(3).unwrap(), (5, 5));
        assert_eq!(t.tiles_per_axis(2).unwrap(), (3, 3));
        assert_eq!(t.tiles_per_axis(0).unwrap(), (1, 1));
        // Full resolution: stride 1; tile 3/4/4 reaches past the grid's last sample (1200).
        assert_eq!(
            corners(t.tile_bounds(TileId::new(3, 4, 4)).unwrap()),
            [1024.0, 1024.0, 1280.0, 1280.0]
        );
        assert_eq!(
            t.sample_position(TileId::new(3, 1, 2), 3, 5).unwrap(),
            [261.0, 515.0]
        );
        // Zoom 0: one tile, every 8th sample.
        assert_eq!(
            corners(t.tile_bounds(TileId::new(0, 0, 0)).unwrap()),
            [0.0, 0.0, 2048.0, 2048.0]
        );
        assert_eq!(
            t.sample_position(TileId::new(0, 0, 0), 1, 2).unwrap(),
            [16.0, 8.0]
        );
        // Exactly one tile's worth needs no pyramid above it.
        let one = tiling(
            Scheme::Local {
                rows: 257,
                cols: 100,
            },
            257,
        );
        assert_eq!(
            (one.max_zoom(), one.tiles_per_axis(0).unwrap()),
            (0, (1, 1))
        );
        assert_eq!(
            one.tile_geo(TileId::new(0, 0, 0)),
            Err(TilingError::NoGeoreference)
        );
    }

    #[test]
    fn tile_ranges_cover_a_bbox_without_spilling_over_boundaries() {
        let geo = tiling(Scheme::Geodetic, 257);
        let world = Bounds {
            min_x: -180.0,
            min_y: -90.0,
            max_x: 180.0,
            max_y: 90.0,
        };
        let r = geo.tile_range(0, &world).unwrap().unwrap();
        assert_eq!((r.x0, r.y0, r.x1, r.y1, r.count()), (0, 0, 1, 0, 2));
        // N44W072 (lon −72..−71, lat 44..45) at zoom 7: tiles of 1.40625°, and lat 45° is
        // exactly the top of row 95 (−90 + 96 · 1.40625), so row 96 stays out.
        let srtm = Bounds {
            min_x: -72.0,
            min_y: 44.0,
            max_x: -71.0,
            max_y: 45.0,
        };
        let r = geo.tile_range(7, &srtm).unwrap().unwrap();
        assert_eq!((r.x0, r.x1, r.y0, r.y1), (76, 77, 95, 95));
        for tile in r.tiles() {
            let b = geo.tile_bounds(tile).unwrap();
            assert!(
                b.max_x > srtm.min_x
                    && b.min_x < srtm.max_x
                    && b.max_y > srtm.min_y
                    && b.min_y < srtm.max_y
            );
        }
        // Edges on tile boundaries pull in nothing beyond them.
        let quarter = Bounds {
            min_x: -90.0,
            min_y: 0.0,
            max_x: 0.0,
            max_y: 90.0,
        };
        let r = geo.tile_range(1, &quarter).unwrap().unwrap();
        assert_eq!((r.x0, r.x1, r.y0, r.y1), (1, 1, 1, 1));
        assert!(r.contains(TileId::new(1, 1, 1)) && !r.contains(TileId::new(1, 2, 1)));
        // A point, and a bbox off the world.
        let point = Bounds {
            min_x: 10.0,
            min_y: 10.0,
            max_x: 10.0,
            max_y: 10.0,
        };
        assert_eq!(geo.tile_range(1, &point).unwrap().unwrap().count(), 1);
        let off = Bounds {
            min_x: 200.0,
            min_y: 0.0,
            max_x: 210.0,
            max_y: 1.0,
        };
        assert_eq!(geo.tile_range(3, &off).unwrap(), None);

        // Mercator: y from the north, and the poles clamp to the square world.
        let merc = tiling(Scheme::Mercator, 257);
        let all = merc.tile_range(2, &world).unwrap().unwrap();
        assert_eq!((all.x0, all.x1, all.y0, all.y1), (0, 3, 0, 3));
        let sf = Bounds {
            min_x: -122.6,
            min_y: 37.75,
            max_x: -122.4,
            max_y: 37.9,
        };
        let r = merc.tile_range(10, &sf).unwrap().unwrap();
        assert_eq!((r.x0, r.x1, r.y0, r.y1), (163, 163, 395, 395));

        // Local: sample coordinates.
        let local = tiling(
            Scheme::Local {
                rows: 1201,
                cols: 1201,
            },
            257,
        );
        let b = Bounds {
            min_x: 0.0,
            min_y: 250.0,
            max_x: 512.0,
            max_y: 260.0,
        };
        let r = local.tile_range(3, &b).unwrap().unwrap();
        assert_eq!((r.x0, r.x1, r.y0, r.y1), (0, 1, 0, 1));

        let nan = Bounds {
            min_x: f64::NAN,
            ..world
        };
        assert!(matches!(
            geo.tile_range(0, &nan),
            Err(TilingError::Parameter { .. })
        ));
        let flipped = Bounds {
            min_x: 10.0,
            max_x: 0.0,
            ..world
        };
        assert!(geo.tile_range(0, &flipped).is_err());
    }

    #[test]
    fn level_zero_error_is_cesiums_and_halves_per_level() {
        let geo = tiling(Scheme::Geodetic, 257);
        assert!((geo.level_geometric_error(0) - 77_067.339_78).abs() < 1e-4);
        assert!((geo.level_geometric_error(1) * 2.0 - geo.level_geometric_error(0)).abs() < 1e-9);
        assert!((geo.level_geometric_error(10) - 77_067.339_78 / 1024.0).abs() < 1e-6);
        let merc = tiling(Scheme::Mercator, 257);
        assert!((merc.level_geometric_error(0) - 154_134.679_56).abs() < 1e-4);
        let local = tiling(
            Scheme::Local {
                rows: 1201,
                cols: 1201,
            },
            257,
        );
        // Deepest zoom: 0.25 · 256 / 65 sample spacings.
        assert!((local.level_geometric_error(3) - 0.25 * 256.0 / 65.0).abs() < 1e-12);
        assert_eq!(
            local.level_geometric_error(0),
            8.0 * local.level_geometric_error(3)
        );
    }

    #[test]
    fn default_max_zoom_keeps_the_source_detail() {
        let geo = tiling(Scheme::Geodetic, 257);
        // SRTM3, 3″: 180° / (2^10 · 256) = 0.000687° ≤ 0.000833° < 0.00137° at zoom 9.
        assert_eq!(
            geo.default_max_zoom(Resolution::Degrees(1.0 / 1200.0))
                .unwrap(),
            10
        );
        // SRTM1, 1″: 180° / (2^12 · 256) = 0.000172° ≤ 0.000278° < 0.000343° at zoom 11.
        assert_eq!(
            geo.default_max_zoom(Resolution::Degrees(1.0 / 3600.0))
                .unwrap(),
            12
        );
        // Exactly a zoom's spacing lands on that zoom.
        assert_eq!(
            geo.default_max_zoom(Resolution::Degrees(180.0 / 256.0))
                .unwrap(),
            0
        );
        assert_eq!(
            geo.default_max_zoom(Resolution::Degrees(1e-12)).unwrap(),
            MAX_ZOOM
        );
        let merc = tiling(Scheme::Mercator, 257);
        // 30 m: 40 075 016.7 m / (2^13 · 256) = 19.1 m ≤ 30 m < 38.2 m at zoom 12.
        assert_eq!(merc.default_max_zoom(Resolution::Metres(30.0)).unwrap(), 13);
        assert_eq!(
            merc.default_max_zoom(Resolution::Degrees(1.0 / 1200.0))
                .unwrap(),
            11
        );
        let local = tiling(
            Scheme::Local {
                rows: 1201,
                cols: 1201,
            },
            257,
        );
        assert_eq!(local.default_max_zoom(Resolution::Metres(90.0)).unwrap(), 3);
        assert!(geo.default_max_zoom(Resolution::Metres(0.0)).is_err());
        assert!(geo.default_max_zoom(Resolution::Degrees(f64::NAN)).is_err());
    }

    #[test]
    fn bad_parameters_are_errors_not_panics() {
        assert_eq!(
            Tiling::new(Scheme::Geodetic, 256),
            Err(TilingError::Side(256))
        );
        assert_eq!(Tiling::new(Scheme::Geodetic, 2), Err(TilingError::Side(2)));
        assert_eq!(
            Tiling::new(Scheme::Geodetic, MAX_SIDE + 2),
            Err(TilingError::Side(MAX_SIDE + 2))
        );
        assert!(matches!(
            Tiling::new(Scheme::Local { rows: 1, cols: 9 }, 9),
            Err(TilingError::LocalGrid { .. })
        ));
        let geo = tiling(Scheme::Geodetic, 9);
        assert!(matches!(
            geo.tiles_per_axis(MAX_ZOOM + 1),
            Err(TilingError::Zoom { .. })
        ));
        assert!(matches!(
            geo.tile_bounds(TileId::new(1, 4, 0)),
            Err(TilingError::Tile { .. })
        ));
        assert!(matches!(
            geo.tile_bounds(TileId::new(1, 0, 2)),
            Err(TilingError::Tile { .. })
        ));
        assert!(matches!(
            geo.sample_position(TileId::new(0, 0, 0), 9, 0),
            Err(TilingError::Sample { .. })
        ));
        assert_eq!(TileId::new(0, 0, 0).parent(), None);
        assert_eq!(TileId::new(u8::MAX, 0, 0).children(), None);
        // The deepest zoom's corner tile is still addressable and exact.
        let (nx, ny) = geo.tiles_per_axis(MAX_ZOOM).unwrap();
        let b = geo
            .tile_bounds(TileId::new(MAX_ZOOM, nx - 1, ny - 1))
            .unwrap();
        assert_eq!((b.max_x, b.max_y), (180.0, 90.0));
    }
}
