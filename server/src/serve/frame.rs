//! `?frame=` of a mesh file (tiles and views in `json`, `obj`, `glb`): the scheme's own
//! coordinates (the default: degrees or EPSG:3857 metres across, metres up), or `enu`,
//! metres east, north and up about a point of the WGS84 ellipsoid. A geodetic tile in
//! degrees and metres is some 10⁵ times too thin in a glTF viewer or a flight sim that
//! takes its units as equal; in ENU it has its true shape, and the origin, sent in
//! `X-Frame-Origin`, places it on the globe.

use std::collections::HashMap;

use anyhow::Result;
use axum::http::HeaderValue;
use zerotile_codec::container::TileId;
use zerotile_codec::geo::geoid::{self, Patch};
use zerotile_codec::geo::{self, mercator_to_lonlat, Ellipsoid, EnuFrame, Scheme, VerticalDatum};
use zerotile_codec::mesh::TriMesh;

use crate::serve::dataset::Dataset;
use crate::serve::error::{echo, ApiError, ApiResult};

/// The coordinates a mesh file is written in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Frame {
    /// The scheme's CRS across, metres up (see `render::tri_mesh`).
    #[default]
    Scheme,
    /// Metres east, north and up about a point (a tile's centre, a view's target) at
    /// height 0.
    Enu,
}

impl Frame {
    /// `?frame=` of a request for a mesh: `takes` says whether its format is one written in
    /// a frame (json, obj, glb), `format` names it for the refusal. `enu` needs a
    /// georeferenced scheme.
    pub fn from_query(
        q: &HashMap<String, String>,
        scheme: Scheme,
        takes: bool,
        format: &str,
    ) -> ApiResult<Self> {
        let bad = |why: String| ApiError::bad_request("bad_frame", why);
        match q.get("frame").map(String::as_str) {
            None | Some("scheme") => Ok(Self::Scheme),
            Some("enu") if !takes => Err(bad(format!(
                "frame=enu is for json, obj and glb meshes, not {format}"
            ))),
            Some("enu") if matches!(scheme, Scheme::Local { .. }) => Err(bad(
                "frame=enu needs a geodetic or mercator dataset: a local grid has no place on \
                 the Earth"
                    .to_string(),
            )),
            Some("enu") => Ok(Self::Enu),
            Some(other) => Err(bad(format!(
                "frame must be scheme or enu, got {}",
                echo(other)
            ))),
        }
    }
}

/// The ENU frame at a tile's centre, height 0.
pub fn at_tile(d: &Dataset, id: TileId) -> Result<EnuFrame> {
    let b = d.tiling.tile_bounds(geo::TileId::new(id.z, id.x, id.y))?;
    let centre = [(b.min_x + b.max_x) / 2.0, (b.min_y + b.max_y) / 2.0];
    Ok(at_lonlat(lonlat(d.tiling.scheme(), centre)))
}

/// The ENU frame at `[lon°, lat°]`, height 0.
pub fn at_lonlat([lon, lat]: [f64; 2]) -> EnuFrame {
    EnuFrame::at(Ellipsoid::WGS84, lon, lat, 0.0)
}

/// `[lon°, lat°]` of a point in the scheme's CRS (a georeferenced one; a local grid's
/// points are taken as degrees, never reached: [`Frame::from_query`] refuses them).
fn lonlat(scheme: Scheme, p: [f64; 2]) -> [f64; 2] {
    match scheme {
        Scheme::Mercator => mercator_to_lonlat(p),
        Scheme::Geodetic | Scheme::Local { .. } => p,
    }
}

/// `mesh`, in the scheme's coordinates with z up in metres, moved into `frame`, its heights
/// raised by the geoid's undulation from `geoid` where they are above EGM96 (see
/// [`geoid`]): the frame's up is the ellipsoid's. Longitudes past ±180° (a view across the
/// antimeridian) land where they should: the trigonometry goes round.
pub fn to_enu(mesh: &mut TriMesh, scheme: Scheme, frame: &EnuFrame, geoid: Option<&Patch>) {
    for p in &mut mesh.positions {
        let [lon, lat] = lonlat(scheme, [p.x, p.y]);
        let n = geoid.map_or(0.0, |g| g.undulation(lon, lat));
        *p = frame.from_geodetic(lon, lat, p.z + n);
    }
}

/// The geoid's undulation over a mesh's box, `[west, south, east, north]` in degrees (west
/// past east crosses the antimeridian), where the dataset's heights are above EGM96; `None`
/// where they go as they are (above the ellipsoid, or a datum not recorded).
pub fn geoid(d: &Dataset, [west, south, east, north]: [f64; 4]) -> Option<Patch> {
    (d.metadata().vertical_datum == Some(VerticalDatum::Egm96))
        .then(|| geoid::patch_over(west, south, east, north))
}

/// A box `[west, south, east, north]` in the scheme's CRS, in degrees.
pub fn degrees(scheme: Scheme, [west, south, east, north]: [f64; 4]) -> [f64; 4] {
    let [w, s] = lonlat(scheme, [west, south]);
    let [e, n] = lonlat(scheme, [east, north]);
    [w, s, e, n]
}

/// `X-Frame-Origin`: `lon,lat,height` of the frame's origin, in the shortest digits that read
/// back to each.
pub fn origin_header(frame: &EnuFrame) -> ApiResult<HeaderValue> {
    let [lon, lat, h] = frame.origin();
    HeaderValue::from_str(&format!("{lon},{lat},{h}")).map_err(ApiError::internal)
}
