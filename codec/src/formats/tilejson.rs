//! TileJSON 3.0.0 for terrain-RGB / Terrarium raster tiles: what a MapLibre GL `raster-dem`
//! source reads from its `url`, so the page needs no copy of the zooms and bounds.
//!
//! References:
//! - TileJSON 3.0.0 (mapbox/tilejson-spec): `tilejson`, `tiles` (absolute URLs: §3.2 leaves
//!   relative ones undefined and MapLibre fails on them), `scheme`, `minzoom`, `maxzoom`,
//!   `bounds`, `version`, `name`, `description`, `attribution`.
//! - MapLibre GL JS `loadTileJson` (4.x): it takes `tiles`, `minzoom`, `maxzoom`,
//!   `attribution`, `bounds`, `scheme`, `tileSize` and `encoding` from the document, the last
//!   two outside the spec, and the source's own options win over them.
//!
//! A client that is not told `maxzoom` and `bounds` asks for tiles past the deepest zoom and
//! outside the data, which a server can only answer with 404s.
//!
//! ```
//! use zerotile_codec::formats::tilejson::{DemEncoding, RasterDem};
//!
//! let t = RasterDem {
//!     name: "n44".into(),
//!     tiles: vec!["https://tiles.example/n44/{z}/{x}/{y}.png".into()],
//!     minzoom: 0,
//!     maxzoom: 8,
//!     bounds: [-72.0, 44.0, -71.0, 45.0],
//!     encoding: DemEncoding::Mapbox,
//!     tile_size: 512,
//!     ..RasterDem::default()
//! };
//! let json = t.to_value()?;
//! assert_eq!(json["encoding"], "mapbox");
//! assert_eq!(json["maxzoom"], 8);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::geo::Bounds;
use serde_json::{json, Value};

/// The TileJSON version written.
pub const VERSION: &str = "3.0.0";

/// Web Mercator's latitude limit, degrees: XYZ tiles end there.
pub const MAX_MERCATOR_LATITUDE: f64 = 85.051_128_779_806_59;

/// How the PNG pixels hold heights, by MapLibre's names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DemEncoding {
    /// Mapbox terrain-RGB.
    Mapbox,
    /// Mapzen / AWS Terrarium.
    Terrarium,
}

/// Why a document cannot be written.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[error("{name} must be {expected}, got {got}")]
pub struct TileJsonError {
    pub name: &'static str,
    pub expected: &'static str,
    pub got: String,
}

/// A `raster-dem` tileset on the XYZ (Web Mercator) grid.
#[derive(Clone, Debug, PartialEq)]
pub struct RasterDem {
    pub name: String,
    pub description: String,
    pub attribution: String,
    /// Changes whenever the tiles do (a client or CDN may key its cache on it).
    pub version: String,
    /// Absolute URL templates with `{z}`, `{x}`, `{y}`.
    pub tiles: Vec<String>,
    pub minzoom: u8,
    pub maxzoom: u8,
    /// West, south, east, north in degrees.
    pub bounds: [f64; 4],
    pub encoding: DemEncoding,
    /// Pixels a side.
    pub tile_size: u32,
}

impl Default for RasterDem {
    fn default() -> Self {
        Self {
            name: String::new(),
            description: String::new(),
            attribution: String::new(),
            version: "1.0.0".into(),
            tiles: Vec::new(),
            minzoom: 0,
            maxzoom: 0,
            bounds: [-180.0, -MAX_MERCATOR_LATITUDE, 180.0, MAX_MERCATOR_LATITUDE],
            encoding: DemEncoding::Mapbox,
            tile_size: 512,
        }
    }
}

fn error(name: &'static str, expected: &'static str, got: impl ToString) -> TileJsonError {
    TileJsonError {
        name,
        expected,
        got: got.to_string(),
    }
}

impl RasterDem {
    /// The document, after checking what a client relies on.
    pub fn to_value(&self) -> Result<Value, TileJsonError> {
        if self.tiles.is_empty() {
            return Err(error("tiles", "at least one URL template", "none"));
        }
        for t in &self.tiles {
            let absolute = t.starts_with("http://") || t.starts_with("https://");
            let templated = ["{z}", "{x}", "{y}"].iter().all(|p| t.contains(p));
            if !absolute || !templated {
                return Err(error(
                    "tiles",
                    "absolute http(s) URLs with {z}, {x} and {y}",
                    t,
                ));
            }
        }
        if self.minzoom > self.maxzoom || self.maxzoom > 30 {
            return Err(error(
                "minzoom..maxzoom",
                "an ordered range within 0..=30",
                format!("{}..{}", self.minzoom, self.maxzoom),
            ));
        }
        let [w, s, e, n] = self.bounds;
        let lat = MAX_MERCATOR_LATITUDE + 1e-9;
        let ok = self.bounds.iter().all(|v| v.is_finite())
            && (-180.0..=180.0).contains(&w)
            && (-180.0..=180.0).contains(&e)
            && (-lat..=lat).contains(&s)
            && s <= n
            && n <= lat;
        if !ok {
            return Err(error(
                "bounds",
                "south ≤ north, degrees within Web Mercator",
                format!("{:?}", self.bounds),
            ));
        }
        if !(1..=4096).contains(&self.tile_size) {
            return Err(error("tileSize", "1..=4096 pixels", self.tile_size));
        }
        // West past east crosses the antimeridian (Cesium's convention); TileJSON's bounds
        // may not wrap, so they take every longitude, the centre still the data's.
        let data = Bounds {
            min_x: w,
            min_y: s,
            max_x: e,
            max_y: n,
        };
        let (west, east, centre) = {
            let b = data.without_wrap();
            (b.min_x, b.max_x, data.lon_centre())
        };
        let encoding = match self.encoding {
            DemEncoding::Mapbox => "mapbox",
            DemEncoding::Terrarium => "terrarium",
        };
        Ok(json!({
            "tilejson": VERSION,
            "name": self.name,
            "description": self.description,
            "version": self.version,
            "attribution": self.attribution,
            "scheme": "xyz",
            "tiles": self.tiles,
            "minzoom": self.minzoom,
            "maxzoom": self.maxzoom,
            "bounds": [west, s, east, n],
            "center": [centre, (s + n) / 2.0, self.maxzoom],
            "tileSize": self.tile_size,
            "encoding": encoding,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn valid() -> RasterDem {
        RasterDem {
            name: "n44".into(),
            tiles: vec!["http://127.0.0.1:8080/v1/datasets/n44/tiles/{z}/{x}/{y}.png".into()],
            minzoom: 0,
            maxzoom: 8,
            bounds: [-72.0, 44.0, -71.0, 45.0],
            ..RasterDem::default()
        }
    }

    #[test]
    fn writes_the_fields_maplibre_reads() {
        let v = valid().to_value().unwrap();
        assert_eq!(v["tilejson"], "3.0.0");
        assert_eq!(v["scheme"], "xyz");
        assert_eq!(v["tileSize"], 512);
        assert_eq!(v["encoding"], "mapbox");
        assert_eq!(v["bounds"], json!([-72.0, 44.0, -71.0, 45.0]));
        assert_eq!(v["center"], json!([-71.5, 44.5, 8]));
        let t = RasterDem {
            encoding: DemEncoding::Terrarium,
            ..valid()
        };
        assert_eq!(t.to_value().unwrap()["encoding"], "terrarium");
    }

    #[test]
    fn refuses_what_a_client_would_misread() {
        let relative = RasterDem {
            tiles: vec!["tiles/{z}/{x}/{y}.png".into()],
            ..valid()
        };
        assert_eq!(relative.to_value().unwrap_err().name, "tiles");
        let untemplated = RasterDem {
            tiles: vec!["https://a.example/tile.png".into()],
            ..valid()
        };
        assert_eq!(untemplated.to_value().unwrap_err().name, "tiles");
        let none = RasterDem {
            tiles: vec![],
            ..valid()
        };
        assert_eq!(none.to_value().unwrap_err().name, "tiles");
        let zooms = RasterDem {
            minzoom: 9,
            ..valid()
        };
        assert_eq!(zooms.to_value().unwrap_err().name, "minzoom..maxzoom");
        for bounds in [
            [-72.0, 44.0, 181.0, 45.0],
            [-72.0, 86.0, -71.0, 87.0],
            [f64::NAN, 44.0, -71.0, 45.0],
        ] {
            let b = RasterDem { bounds, ..valid() };
            assert_eq!(b.to_value().unwrap_err().name, "bounds", "{bounds:?}");
        }
        // The grid's own limit is in range (the world, as a mercator dataset stores it).
        let world = RasterDem {
            bounds: RasterDem::default().bounds,
            ..valid()
        };
        assert!(world.to_value().is_ok());
    }

    /// West past east crosses the antimeridian: the bounds, which may not wrap, take every
    /// longitude; the centre is the data's.
    #[test]
    fn bounds_across_the_antimeridian_span_every_longitude() {
        let fiji = RasterDem {
            bounds: [177.0, -19.0, -179.0, -16.0],
            ..valid()
        };
        let v = fiji.to_value().unwrap();
        assert_eq!(v["bounds"], json!([-180.0, -19.0, 180.0, -16.0]));
        assert_eq!(v["center"], json!([179.0, -17.5, 8]));
        let east_of_it = RasterDem {
            bounds: [179.0, -19.0, -177.0, -16.0],
            ..valid()
        };
        assert_eq!(east_of_it.to_value().unwrap()["center"][0], json!(-179.0));
    }

    #[test]
    fn every_field_comes_from_the_tileset() {
        // Values away from the defaults and from each other, so a field written from the
        // wrong source (or a constant) shows.
        let t = RasterDem {
            name: "n44".into(),
            description: "SRTM3 White Mountains".into(),
            attribution: "SRTM (NASA)".into(),
            version: "7".into(),
            tiles: vec![
                "https://a.example/{z}/{x}/{y}.png".into(),
                "https://b.example/{z}/{x}/{y}.png".into(),
            ],
            minzoom: 3,
            maxzoom: 11,
            tile_size: 256,
            ..valid()
        };
        let v = t.to_value().unwrap();
        assert_eq!(v["name"], "n44");
        assert_eq!(v["description"], "SRTM3 White Mountains");
        assert_eq!(v["attribution"], "SRTM (NASA)");
        assert_eq!(v["version"], "7");
        assert_eq!(
            v["tiles"],
            json!([
                "https://a.example/{z}/{x}/{y}.png",
                "https://b.example/{z}/{x}/{y}.png"
            ])
        );
        assert_eq!(
            (v["minzoom"].as_u64(), v["maxzoom"].as_u64()),
            (Some(3), Some(11))
        );
        assert_eq!(v["tileSize"], 256);
        assert_eq!(v["center"], json!([-71.5, 44.5, 11]));
    }
}
