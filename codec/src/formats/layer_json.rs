//! Cesium's `layer.json`: the manifest a `CesiumTerrainProvider` reads before it asks for a
//! single quantized-mesh tile.
//!
//! References:
//! - TileJSON 2.1.0 (mapbox/tilejson-spec): `tilejson`, `name`, `version`, `scheme`,
//!   `tiles`, `bounds`, `minzoom`, `maxzoom`, `attribution`.
//! - CesiumJS `CesiumTerrainProvider` (`parseMetadataSuccess`): the fields Cesium adds —
//!   `format` (must start with "quantized-mesh-1."), `projection` ("EPSG:4326" or
//!   "EPSG:3857"), `extensions`, `available`, `metadataAvailability` — and two facts its
//!   code fixes: `scheme` is "tms" or "slippyMap", and `available` ranges always count y
//!   from the south (TMS), whatever the scheme; so do the ranges of the metadata extension.
//!
//! ```
//! use zerotile_codec::formats::layer_json::{Extension, LayerJson};
//! use zerotile_codec::geo::{Bounds, Scheme, Tiling};
//!
//! let tiling = Tiling::new(Scheme::Geodetic, 257)?;
//! let srtm = Bounds { min_x: -72.0, min_y: 44.0, max_x: -71.0, max_y: 45.0 };
//! let mut layer = LayerJson::for_tiling(&tiling, srtm, 0, 10)?;
//! layer.extensions = vec![Extension::OctVertexNormals, Extension::Metadata];
//! let json = layer.to_value()?;
//! assert_eq!(json["format"], "quantized-mesh-1.0");
//! assert_eq!(json["available"][0][0]["endX"], 1); // both root tiles
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use serde::{Deserialize, Serialize};

use crate::geo::{Bounds, Scheme, TileId, TileRange, Tiling, TilingError};

/// TileJSON version Cesium's terrain manifests declare.
pub const TILEJSON_VERSION: &str = "2.1.0";

/// The tile format.
pub const FORMAT: &str = "quantized-mesh-1.0";

/// The tiles template zerotile serves by default (relative to the manifest's URL).
pub const DEFAULT_TILES_TEMPLATE: &str = "{z}/{x}/{y}.terrain?v={version}";

/// A quantized-mesh extension a tileset offers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Extension {
    OctVertexNormals,
    WaterMask,
    Metadata,
}

impl Extension {
    /// The name in `layer.json` and in `Accept: …;extensions=` headers.
    pub fn name(self) -> &'static str {
        match self {
            Self::OctVertexNormals => "octvertexnormals",
            Self::WaterMask => "watermask",
            Self::Metadata => "metadata",
        }
    }
}

/// Tiles startX..=endX, startY..=endY of one level, y counted from the south (TMS).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct AvailableRange {
    pub start_x: u32,
    pub start_y: u32,
    pub end_x: u32,
    pub end_y: u32,
}

/// Why a manifest cannot be built.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum LayerJsonError {
    #[error(transparent)]
    Tiling(#[from] TilingError),
    #[error("{name} must be {expected}, got {got}")]
    Parameter {
        name: &'static str,
        expected: &'static str,
        got: String,
    },
}

/// A terrain tileset's manifest, in typed form.
#[derive(Clone, Debug, PartialEq)]
pub struct LayerJson {
    pub name: String,
    pub description: String,
    pub attribution: String,
    /// Substituted for `{version}` in the tiles template: change it to bust caches.
    pub version: String,
    /// URL templates with `{z}`, `{x}`, `{y}` (and optionally `{version}`).
    pub tiles: Vec<String>,
    pub extensions: Vec<Extension>,
    /// The tiling scheme: geodetic (EPSG:4326, "tms") or mercator (EPSG:3857, "slippyMap").
    pub scheme: Scheme,
    /// Data extent, degrees: west, south, east, north.
    pub bounds: Bounds,
    pub minzoom: u8,
    pub maxzoom: u8,
    /// Per level from 0: the tiles that exist, TMS y.
    pub available: Vec<Vec<AvailableRange>>,
    /// Every this many levels, tiles carry their subtree's availability in the metadata
    /// extension ([`availability_metadata`]) instead of `available` listing it all.
    pub metadata_availability: Option<u8>,
}

impl LayerJson {
    /// A manifest for data covering `bounds` (degrees) on `tiling`, levels `minzoom` to
    /// `maxzoom`: `available` lists the tiles over `bounds` per level, and both level-0
    /// tiles of the geodetic grid (Cesium needs every root tile). Bounds whose west is past
    /// their east cross the antimeridian (Cesium's `Rectangle` convention): the tiles either
    /// side of it are listed, and the manifest's own `bounds` span every longitude.
    pub fn for_tiling(
        tiling: &Tiling,
        bounds: Bounds,
        minzoom: u8,
        maxzoom: u8,
    ) -> Result<Self, LayerJsonError> {
        // A georeferenced scheme and an ordered zoom range.
        if matches!(tiling.scheme(), Scheme::Local { .. }) {
            return Err(TilingError::NoGeoreference.into());
        }
        if minzoom > maxzoom {
            return Err(parameter("minzoom", "≤ maxzoom", minzoom.to_string()));
        }

        // Across the antimeridian: the parts west and east of it; the manifest's own bounds,
        // which may not wrap, take every longitude.
        let parts = bounds.split_at_antimeridian();
        let bounds = bounds.without_wrap();
        // Availability: every root tile at level 0, the bbox's tiles below.
        let mut available = Vec::with_capacity(usize::from(maxzoom) + 1);
        for z in 0..=maxzoom {
            let mut level = Vec::new();
            if z == 0 {
                let (nx, ny) = tiling.tiles_per_axis(0)?;
                let roots = TileRange {
                    z,
                    x0: 0,
                    y0: 0,
                    x1: nx - 1,
                    y1: ny - 1,
                };
                level.push(to_tms(tiling, roots)?);
            } else {
                for part in &parts {
                    if let Some(r) = tiling.tile_range(z, part)? {
                        level.push(to_tms(tiling, r)?);
                    }
                }
            }
            available.push(level);
        }
        Ok(Self {
            name: "zerotile".into(),
            description: String::new(),
            attribution: String::new(),
            version: "1.0.0".into(),
            tiles: vec![DEFAULT_TILES_TEMPLATE.into()],
            extensions: Vec::new(),
            scheme: tiling.scheme(),
            bounds,
            minzoom,
            maxzoom,
            available,
            metadata_availability: None,
        })
    }

    /// The manifest as JSON, after checking the fields a client relies on.
    pub fn to_value(&self) -> Result<serde_json::Value, LayerJsonError> {
        // Checks: templates, zooms, availability depth, unique extensions, real bounds.
        if self.tiles.is_empty() || self.tiles.iter().any(String::is_empty) {
            return Err(parameter(
                "tiles",
                "at least one non-empty template",
                format!("{:?}", self.tiles),
            ));
        }
        if self.minzoom > self.maxzoom {
            return Err(parameter("minzoom", "≤ maxzoom", self.minzoom.to_string()));
        }
        if self.available.len() > usize::from(self.maxzoom) + 1 {
            return Err(parameter(
                "available",
                "at most maxzoom + 1 levels",
                self.available.len().to_string(),
            ));
        }
        for (i, e) in self.extensions.iter().enumerate() {
            if self.extensions[..i].contains(e) {
                return Err(parameter("extensions", "unique", e.name().to_string()));
            }
        }
        let b = self.bounds;
        let real = [b.min_x, b.min_y, b.max_x, b.max_y]
            .iter()
            .all(|v| v.is_finite())
            && -180.0 <= b.min_x
            && b.min_x <= b.max_x
            && b.max_x <= 180.0
            && -90.0 <= b.min_y
            && b.min_y <= b.max_y
            && b.max_y <= 90.0;
        if !real {
            return Err(parameter(
                "bounds",
                "west ≤ east, south ≤ north, in degrees",
                format!("{b:?}"),
            ));
        }
        let (projection, scheme) = match self.scheme {
            Scheme::Geodetic => ("EPSG:4326", "tms"),
            Scheme::Mercator => ("EPSG:3857", "slippyMap"),
            Scheme::Local { .. } => return Err(TilingError::NoGeoreference.into()),
        };

        // The document, in TileJSON's field order.
        let mut json = serde_json::json!({
            "tilejson": TILEJSON_VERSION,
            "name": self.name,
            "description": self.description,
            "version": self.version,
            "format": FORMAT,
            "attribution": self.attribution,
            "scheme": scheme,
            "tiles": self.tiles,
            "projection": projection,
            "bounds": [b.min_x, b.min_y, b.max_x, b.max_y],
            "minzoom": self.minzoom,
            "maxzoom": self.maxzoom,
            "extensions": self.extensions.iter().map(|e| e.name()).collect::<Vec<_>>(),
            "available": self.available,
        });
        if let (Some(levels), Some(map)) = (self.metadata_availability, json.as_object_mut()) {
            map.insert("metadataAvailability".into(), levels.into());
        }
        Ok(json)
    }
}

/// The availability of `tile`'s descendants over `bounds` (degrees), for the `depth` levels
/// below it, in TMS y: what the metadata extension's `available` array holds (its entry 0
/// is level z + 1).
pub fn subtree_availability(
    tiling: &Tiling,
    tile: TileId,
    bounds: &Bounds,
    depth: u8,
) -> Result<Vec<Vec<AvailableRange>>, LayerJsonError> {
    let mut levels = Vec::with_capacity(usize::from(depth));
    for d in 1..=depth {
        let z = tile
            .z
            .checked_add(d)
            .ok_or_else(|| parameter("depth", "within the zoom range", d.to_string()))?;
        // Descendants of `tile` at level z form a block of 2^d × 2^d tiles.
        let (x0, y0) = (u64::from(tile.x) << d, u64::from(tile.y) << d);
        let (x1, y1) = (x0 + (1 << d) - 1, y0 + (1 << d) - 1);
        let level = match tiling.tile_range(z, bounds)? {
            Some(r) => {
                let (ax, bx) = (x0.max(u64::from(r.x0)), x1.min(u64::from(r.x1)));
                let (ay, by) = (y0.max(u64::from(r.y0)), y1.min(u64::from(r.y1)));
                if ax <= bx && ay <= by {
                    let clipped = TileRange {
                        z,
                        x0: ax as u32,
                        y0: ay as u32,
                        x1: bx as u32,
                        y1: by as u32,
                    };
                    vec![to_tms(tiling, clipped)?]
                } else {
                    Vec::new()
                }
            }
            None => Vec::new(),
        };
        levels.push(level);
    }
    Ok(levels)
}

/// The metadata extension's JSON for child availability: `{"available": levels}`.
pub fn availability_metadata(levels: &[Vec<AvailableRange>]) -> serde_json::Value {
    serde_json::json!({ "available": levels })
}

/// A range in the scheme's own y, as Cesium's TMS-y availability range.
fn to_tms(tiling: &Tiling, r: TileRange) -> Result<AvailableRange, TilingError> {
    let (_, ny) = tiling.tiles_per_axis(r.z)?;
    Ok(match tiling.scheme() {
        // Geodetic tiles already count from the south.
        Scheme::Geodetic => AvailableRange {
            start_x: r.x0,
            start_y: r.y0,
            end_x: r.x1,
            end_y: r.y1,
        },
        _ => AvailableRange {
            start_x: r.x0,
            start_y: ny - 1 - r.y1,
            end_x: r.x1,
            end_y: ny - 1 - r.y0,
        },
    })
}

fn parameter(name: &'static str, expected: &'static str, got: String) -> LayerJsonError {
    LayerJsonError::Parameter {
        name,
        expected,
        got,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geodetic() -> Tiling {
        Tiling::new(Scheme::Geodetic, 257).unwrap()
    }

    const SRTM: Bounds = Bounds {
        min_x: -72.0,
        min_y: 44.0,
        max_x: -71.0,
        max_y: 45.0,
    };

    #[test]
    fn manifest_has_the_fields_cesium_reads() {
        let mut layer = LayerJson::for_tiling(&geodetic(), SRTM, 0, 8).unwrap();
        layer.extensions = vec![
            Extension::OctVertexNormals,
            Extension::WaterMask,
            Extension::Metadata,
        ];
        layer.attribution = "SRTM (NASA)".into();
        let j = layer.to_value().unwrap();
        assert_eq!(j["tilejson"], "2.1.0");
        assert_eq!(j["format"], "quantized-mesh-1.0");
        assert_eq!(j["version"], "1.0.0");
        assert_eq!(j["scheme"], "tms");
        assert_eq!(j["projection"], "EPSG:4326");
        assert_eq!(
            j["tiles"],
            serde_json::json!(["{z}/{x}/{y}.terrain?v={version}"])
        );
        assert_eq!(
            j["extensions"],
            serde_json::json!(["octvertexnormals", "watermask", "metadata"])
        );
        assert_eq!(j["bounds"], serde_json::json!([-72.0, 44.0, -71.0, 45.0]));
        assert_eq!(
            (j["minzoom"].as_u64(), j["maxzoom"].as_u64()),
            (Some(0), Some(8))
        );
        assert!(j.get("metadataAvailability").is_none());
        // Both roots, then the tiles over the SRTM cell (lon −72..−71: x = 76..77 at z7).
        let avail = j["available"].as_array().unwrap();
        assert_eq!(avail.len(), 9);
        assert_eq!(
            avail[0],
            serde_json::json!([{"startX": 0, "startY": 0, "endX": 1, "endY": 0}])
        );
        assert_eq!(
            avail[7],
            serde_json::json!([{"startX": 76, "startY": 95, "endX": 77, "endY": 95}])
        );
        // Round trip through text, as a client reads it.
        let text = serde_json::to_string(&j).unwrap();
        let back: serde_json::Value = serde_json::from_str(&text).unwrap();
        let ranges: Vec<Vec<AvailableRange>> =
            serde_json::from_value(back["available"].clone()).unwrap();
        assert_eq!(ranges, layer.available);
    }

    /// West past east crosses the antimeridian: the tiles either side are listed, and the
    /// manifest's bounds (which may not wrap) take every longitude.
    #[test]
    fn bounds_across_the_antimeridian_list_both_sides() {
        let fiji = Bounds {
            min_x: 177.0,
            min_y: -19.0,
            max_x: -179.0,
            max_y: -16.0,
        };
        let layer = LayerJson::for_tiling(&geodetic(), fiji, 0, 3).unwrap();
        // Zoom 3 is 16 × 8 tiles of 22.5°: x 15 west of 180°, x 0 east; TMS y 3.
        let range = |x0, x1| AvailableRange {
            start_x: x0,
            start_y: 3,
            end_x: x1,
            end_y: 3,
        };
        assert_eq!(layer.available[3], vec![range(15, 15), range(0, 0)]);
        let j = layer.to_value().unwrap();
        assert_eq!(
            j["bounds"],
            serde_json::json!([-180.0, -19.0, 180.0, -16.0])
        );
    }

    #[test]
    fn mercator_manifest_is_slippy_with_tms_availability() {
        let merc = Tiling::new(Scheme::Mercator, 257).unwrap();
        let sf = Bounds {
            min_x: -122.6,
            min_y: 37.75,
            max_x: -122.4,
            max_y: 37.9,
        };
        let mut layer = LayerJson::for_tiling(&merc, sf, 0, 10).unwrap();
        layer.metadata_availability = Some(10);
        let j = layer.to_value().unwrap();
        assert_eq!(
            (j["projection"].as_str(), j["scheme"].as_str()),
            (Some("EPSG:3857"), Some("slippyMap"))
        );
        assert_eq!(j["metadataAvailability"], 10);
        // XYZ tile 10/163/395 is TMS y 1023 − 395 = 628.
        assert_eq!(
            layer.available[10],
            vec![AvailableRange {
                start_x: 163,
                start_y: 628,
                end_x: 163,
                end_y: 628
            }]
        );
    }

    #[test]
    fn subtree_availability_is_relative_to_the_tile() {
        let t = geodetic();
        // Tile 6/38/47 holds the SRTM cell (x 76..77, y 95 at z7 → 38, 47 at z6).
        let levels = subtree_availability(&t, TileId::new(6, 38, 47), &SRTM, 2).unwrap();
        assert_eq!(
            levels[0],
            vec![AvailableRange {
                start_x: 76,
                start_y: 95,
                end_x: 77,
                end_y: 95
            }]
        );
        assert_eq!(levels[1].len(), 1);
        let meta = availability_metadata(&levels);
        assert_eq!(meta["available"][0][0]["startX"], 76);
        // A tile away from the data has nothing below it.
        let empty = subtree_availability(&t, TileId::new(6, 0, 0), &SRTM, 2).unwrap();
        assert!(empty.iter().all(Vec::is_empty));
    }

    #[test]
    fn bad_manifests_are_errors() {
        let t = geodetic();
        assert!(matches!(
            LayerJson::for_tiling(&t, SRTM, 5, 4),
            Err(LayerJsonError::Parameter { .. })
        ));
        let local = Tiling::new(
            Scheme::Local {
                rows: 300,
                cols: 300,
            },
            257,
        )
        .unwrap();
        assert!(matches!(
            LayerJson::for_tiling(&local, SRTM, 0, 1),
            Err(LayerJsonError::Tiling(_))
        ));
        let good = LayerJson::for_tiling(&t, SRTM, 0, 3).unwrap();
        let mut l = good.clone();
        l.tiles.clear();
        assert!(l.to_value().is_err());
        let mut l = good.clone();
        l.extensions = vec![Extension::Metadata, Extension::Metadata];
        assert!(l.to_value().is_err());
        let mut l = good.clone();
        l.maxzoom = 1;
        assert!(l.to_value().is_err());
        let mut l = good;
        l.bounds.max_x = 181.0;
        assert!(l.to_value().is_err());
    }

    #[test]
    fn the_manifest_carries_the_callers_text_fields() {
        // Not the defaults: a writer that ignored a field would still match "1.0.0" or "".
        let mut layer = LayerJson::for_tiling(&geodetic(), SRTM, 0, 3).unwrap();
        layer.name = "n44w072".into();
        layer.description = "SRTM3, White Mountains".into();
        layer.attribution = "SRTM (NASA)".into();
        layer.version = "2026-12-02.1".into();
        layer.tiles = vec!["t/{z}/{x}/{y}.terrain?v={version}".into()];
        let j = layer.to_value().unwrap();
        assert_eq!(j["name"], "n44w072");
        assert_eq!(j["description"], "SRTM3, White Mountains");
        assert_eq!(j["attribution"], "SRTM (NASA)");
        assert_eq!(j["version"], "2026-12-02.1");
        assert_eq!(
            j["tiles"],
            serde_json::json!(["t/{z}/{x}/{y}.terrain?v={version}"])
        );
    }

    #[test]
    fn sibling_subtrees_split_the_data_between_them() {
        // At z8 tiles are 0.703125° wide: lon −72..−71 is x 153.6..155.02 → 153..=155, and
        // lat 44..45 is y 190.58..192.0 → 190..=191 (45° is exactly row 192's lower edge).
        // 7/76/95's children are x 152..=153, 7/77/95's x 154..=155 (y 190..=191 for both).
        let t = geodetic();
        let range = |x0, x1| AvailableRange {
            start_x: x0,
            start_y: 190,
            end_x: x1,
            end_y: 191,
        };
        let west = subtree_availability(&t, TileId::new(7, 76, 95), &SRTM, 1).unwrap();
        let east = subtree_availability(&t, TileId::new(7, 77, 95), &SRTM, 1).unwrap();
        assert_eq!(west, vec![vec![range(153, 153)]]);
        assert_eq!(east, vec![vec![range(154, 155)]]);
        // Together they are the whole level, as for_tiling lists it.
        let layer = LayerJson::for_tiling(&t, SRTM, 0, 8).unwrap();
        assert_eq!(layer.available[8], vec![range(153, 155)]);
    }
}
