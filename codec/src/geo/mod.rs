//! Geodesy for terrain tiles: the WGS84 ellipsoid, tiling schemes, and the bounding volumes
//! clients cull tiles with.
//!
//! - [`ellipsoid`]: geodetic ↔ ECEF, surface normals, Cesium's ellipsoid-scaled space.
//! - [`enu`]: a local east-north-up frame in metres, for meshes a viewer takes at face value.
//! - [`geoid`]: the EGM96 geoid's undulation, which makes heights above sea level heights
//!   above the ellipsoid.
//! - [`tiling`]: the `geodetic`, `mercator` and `local` schemes of DESIGN.md §2.1: tile
//!   bounds, tile ranges, sample positions shared exactly between neighbours and zooms, and
//!   the per-zoom geometric error clients budget for (§2.5).
//! - [`bounds`]: bounding spheres and the horizon occlusion point of quantized-mesh headers.
//! - [`antimeridian`]: lon/lat [`Bounds`] across the antimeridian (west past east): width,
//!   centre, and the parts either side of 180°.
//!
//! ```
//! use zerotile_codec::geo::{Ellipsoid, Scheme, TileId, Tiling};
//!
//! let tiling = Tiling::new(Scheme::Geodetic, 257)?;
//! let tile = TileId::new(7, 76, 95);
//! let [lon, lat] = tiling.sample_lonlat(tile, 0, 0)?; // the tile's north-west corner
//! let ecef = Ellipsoid::WGS84.to_ecef(lon, lat, 1_917.0);
//! assert!((ecef.length() - 6_369_000.0).abs() < 10_000.0);
//! # Ok::<(), zerotile_codec::geo::TilingError>(())
//! ```

pub mod antimeridian;
pub mod bounds;
pub mod ellipsoid;
pub mod enu;
pub mod geoid;
pub mod tiling;

pub use antimeridian::wrap_longitude;
pub use bounds::{horizon_occlusion_point, is_scaled_point_visible, BoundingSphere};
pub use ellipsoid::Ellipsoid;
pub use enu::EnuFrame;
pub use geoid::VerticalDatum;
pub use tiling::{
    lonlat_to_mercator, mercator_latitude, mercator_to_lonlat, mercator_y, Bounds, Resolution,
    RowSpacing, Scheme, TileGeo, TileId, TileRange, Tiling, TilingError, MAX_SIDE, MAX_ZOOM,
    MERCATOR_HALF_EXTENT, MERCATOR_MAX_LATITUDE,
};
