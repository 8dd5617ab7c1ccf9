//! Health, metrics, the dataset list and descriptions, Cesium's `layer.json` and MapLibre's
//! TileJSON.

use std::collections::HashMap;
use std::sync::Arc;

use axum::extract::rejection::{PathRejection, QueryRejection};
use axum::extract::{Path, Query, State};
use axum::http::header::{CONTENT_TYPE, VARY};
use axum::http::{HeaderMap, HeaderValue, Uri};
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde_json::{json, Value};
use zerotile_codec::formats::layer_json::{
    AvailableRange, Extension, LayerJson, DEFAULT_TILES_TEMPLATE,
};
use zerotile_codec::formats::tilejson::{DemEncoding, RasterDem, MAX_MERCATOR_LATITUDE};
use zerotile_codec::geo::{Bounds, Scheme};

use crate::serve::dataset::Dataset;
use crate::serve::error::{echo, ApiError, ApiResult};
use crate::serve::public_url;
use crate::serve::revalidate::{self, REVALIDATE};
use crate::serve::routes::tiles::{png_size, png_terrarium};
use crate::serve::state::AppState;
use crate::serve::threshold;

pub async fn healthz(State(state): State<AppState>) -> Json<Value> {
    Json(json!({ "status": "ok", "datasets": state.catalog().len() }))
}

pub async fn metrics(State(state): State<AppState>) -> Response {
    (
        [(CONTENT_TYPE, "text/plain; version=0.0.4; charset=utf-8")],
        state.metrics.render(),
    )
        .into_response()
}

/// layer.json and TileJSON may be reused for a minute without asking: clients fetch them
/// once per map, and their tile URLs carry the dataset's version.
pub const MANIFEST_CACHE_CONTROL: &str = "public, max-age=60";

/// Looks a dataset up by the name in the path.
pub fn dataset(state: &AppState, name: &str) -> ApiResult<Arc<Dataset>> {
    state.catalog().get(name).cloned().ok_or_else(|| {
        // What a client asks for when its base URL lost the dataset's trailing slash.
        let hint = match name {
            "layer.json" | "tiles.json" | "view" | "tiles" => {
                " (a base URL needs the dataset and a trailing slash: /v1/datasets/NAME/)"
            }
            _ => "",
        };
        ApiError::not_found(
            "unknown_dataset",
            format!("no dataset named {}{hint}", echo(name)),
        )
    })
}

/// Files of the data folder not served, as the listings show them.
pub fn skipped_json(skipped: &[(String, String)]) -> Vec<Value> {
    skipped
        .iter()
        .map(|(file, why)| json!({ "file": file, "error": why }))
        .collect()
}

pub async fn list(State(state): State<AppState>, headers: HeaderMap) -> ApiResult<Response> {
    let catalog = state.catalog();
    let datasets: Vec<Value> = catalog.iter().map(|d| summary(d)).collect();
    let skipped = skipped_json(&catalog.skipped);
    revalidate::json(
        &headers,
        &json!({ "datasets": datasets, "skipped": skipped }),
        REVALIDATE,
    )
}

fn summary(d: &Dataset) -> Value {
    let m = d.metadata();
    json!({
        "name": d.name,
        "scheme": m.scheme,
        "minzoom": m.min_zoom,
        "maxzoom": m.max_zoom,
        "bounds": m.bounds,
        "tiles": d.container.len(),
        "url": format!("/v1/datasets/{}", d.name),
    })
}

pub async fn describe(
    State(state): State<AppState>,
    path: Result<Path<String>, PathRejection>,
    headers: HeaderMap,
) -> ApiResult<Response> {
    let Path(name) = path?;
    let d = dataset(&state, &name)?;
    let m = d.metadata();
    let mut v = summary(&d);
    let defaults: Vec<Value> = threshold::defaults(&d)
        .into_iter()
        .map(|(z, t)| json!({ "zoom": z, "threshold": t }))
        .collect();
    let georeferenced = !matches!(d.tiling.scheme(), Scheme::Local { .. });
    let extra = json!({
        "version": d.version_tag(),
        "tile_side": m.tile_side,
        "source_size": m.source_size,
        "height_range": m.height_range,
        "source_height_range": m.source_height_range,
        "fill": m.fill,
        "view": { "a": m.view.a, "b": m.view.b, "equation": "T = a * (A_v / A_t) + b" },
        "default_thresholds": defaults,
        "decode_share": threshold::DECODE_SHARE,
        "available": m.available,
        "codec": {
            "wavelet": m.wavelet.name(),
            "step": m.step,
            "precision": m.precision,
            "samples": m.samples,
            "stream_bytes": m.stream_bytes,
            "bits_per_sample": m.stream_bytes as f64 * 8.0 / m.samples.max(1) as f64,
        },
        "source": m.source,
        "source_crs": m.source_crs,
        // Which heights quantized-mesh and ENU raise to the ellipsoid: "egm96" ones.
        "vertical_datum": m.vertical_datum,
        "created": m.created,
        "formats": if georeferenced {
            json!(["terrain", "png", "json", "bin", "obj", "glb", "ezw"])
        } else {
            json!(["png", "json", "bin", "obj", "glb", "ezw"])
        },
        "layer_json": georeferenced.then(|| format!("/v1/datasets/{}/layer.json", d.name)),
        "tilejson": matches!(d.tiling.scheme(), Scheme::Mercator)
            .then(|| format!("/v1/datasets/{}/tiles.json", d.name)),
        "tile_url": format!("/v1/datasets/{}/tiles/{{z}}/{{x}}/{{y}}.{{format}}", d.name),
    });
    if let (Some(a), Some(b)) = (v.as_object_mut(), extra.as_object()) {
        a.extend(b.clone());
    }
    revalidate::json(&headers, &v, REVALIDATE)
}

pub async fn layer_json(
    State(state): State<AppState>,
    path: Result<Path<String>, PathRejection>,
    headers: HeaderMap,
) -> ApiResult<Response> {
    let Path(name) = path?;
    let d = dataset(&state, &name)?;
    if matches!(d.tiling.scheme(), Scheme::Local { .. }) {
        return Err(ApiError::not_found(
            "not_georeferenced",
            format!(
                "{name} is a local grid without georeference: Cesium's layer.json and \
                 quantized-mesh need a geodetic or mercator dataset"
            ),
        ));
    }
    let layer = layer(&d).map_err(ApiError::internal)?;
    let value = layer.to_value().map_err(ApiError::internal)?;
    revalidate::json(&headers, &value, MANIFEST_CACHE_CONTROL)
}

/// TileJSON for a mercator dataset's PNG tiles: a MapLibre `raster-dem` source with only
/// `url` set learns the tiles, zooms, bounds, tile size and encoding from it.
pub async fn tilejson(
    State(state): State<AppState>,
    path: Result<Path<String>, PathRejection>,
    query: Result<Query<HashMap<String, String>>, QueryRejection>,
    headers: HeaderMap,
    uri: Uri,
) -> ApiResult<Response> {
    let Path(name) = path?;
    let Query(q) = query?;
    let d = dataset(&state, &name)?;
    if !matches!(d.tiling.scheme(), Scheme::Mercator) {
        return Err(ApiError::not_found(
            "not_mercator",
            format!(
                "{name} is not on the Web Mercator grid MapLibre tiles with: ingest the source \
                 with --scheme mercator for raster-dem (its PNG tiles still come by z/x/y)"
            ),
        ));
    }
    let terrarium = png_terrarium(&q)?;
    let size = png_size(&q)?;
    let m = d.metadata();
    // The tile URL repeats the options asked for here; `v` changes with every ingest, so a
    // CDN keying on the URL never serves the old dataset's tiles.
    let mut params = vec![format!("v={}", d.version_tag())];
    if terrarium {
        params.push("encoding=terrarium".into());
    }
    if q.contains_key("size") {
        params.push(format!("size={size}"));
    }
    let base = public_url::origin(&state.config, &headers, &uri)?;
    let template = format!(
        "{base}/v1/datasets/{}/tiles/{{z}}/{{x}}/{{y}}.png?{}",
        d.name,
        params.join("&")
    );
    let doc = raster_dem(&d, template, (m.min_zoom, m.max_zoom), terrarium, size);
    let value = doc.to_value().map_err(ApiError::internal)?;
    let mut res = revalidate::json(&headers, &value, MANIFEST_CACHE_CONTROL)?;
    if let Some(v) = public_url::vary(&state.config) {
        res.headers_mut().append(VARY, HeaderValue::from_static(v));
    }
    Ok(res)
}

/// A mercator dataset's TileJSON with tiles at `template` (absolute), zooms `z0..=z1`.
pub(crate) fn raster_dem(
    d: &Dataset,
    template: String,
    (z0, z1): (u8, u8),
    terrarium: bool,
    size: u32,
) -> RasterDem {
    let m = d.metadata();
    // A source reaching past Web Mercator's ±85.05° is stored as it came; the XYZ tiles
    // (and MapLibre) end there.
    let [w, s, e, n] = m.bounds;
    let lat = |v: f64| v.clamp(-MAX_MERCATOR_LATITUDE, MAX_MERCATOR_LATITUDE);
    RasterDem {
        name: d.name.clone(),
        description: format!("zerotile EZW terrain from {}", m.source),
        attribution: String::new(),
        // TileJSON's version is semver; the build id is in the tile URLs' `v`.
        version: "1.0.0".into(),
        tiles: vec![template],
        minzoom: z0,
        maxzoom: z1,
        bounds: [w, lat(s), e, lat(n)],
        encoding: if terrarium {
            DemEncoding::Terrarium
        } else {
            DemEncoding::Mapbox
        },
        tile_size: size,
    }
}

/// The dataset's layer.json, tiles at `tiles/{z}/{x}/{y}.terrain` beside it.
pub(crate) fn layer(d: &Dataset) -> anyhow::Result<LayerJson> {
    let m = d.metadata();
    // Cesium wants bounds in degrees and every root tile available.
    let [west, south, east, north] = m.bounds;
    let bounds = Bounds {
        min_x: west,
        min_y: south,
        max_x: east,
        max_y: north,
    };
    let mut layer = LayerJson::for_tiling(&d.tiling, bounds, 0, m.max_zoom)?;
    layer.name = d.name.clone();
    layer.version = d.version_tag();
    // Not `metadata`: CesiumJS takes that as a promise of `metadataAvailability` (tile-held
    // availability every N levels) and fails every tile without it. The full availability is
    // published here instead; tiles still carry the extension when a client asks for it.
    layer.extensions = vec![Extension::OctVertexNormals, Extension::WaterMask];
    // Relative to the manifest's own URL, which sits beside the `tiles/` folder.
    layer.tiles = vec![format!("tiles/{DEFAULT_TILES_TEMPLATE}")];
    layer.description = format!("zerotile EZW terrain from {}", m.source);
    // Availability as stored (scheme y → TMS y), roots kept from the tiling.
    for (k, ranges) in m.available.iter().enumerate() {
        let z = usize::from(m.min_zoom) + k;
        let ny = match layer.available.get(z) {
            Some(_) if z > 0 => d.tiling.tiles_per_axis(z as u8)?.1,
            _ => continue,
        };
        let converted: Vec<AvailableRange> = ranges
            .iter()
            .map(|a| match d.tiling.scheme() {
                Scheme::Geodetic => AvailableRange {
                    start_x: a.start_x,
                    start_y: a.start_y,
                    end_x: a.end_x,
                    end_y: a.end_y,
                },
                _ => AvailableRange {
                    start_x: a.start_x,
                    start_y: ny.saturating_sub(1).saturating_sub(a.end_y),
                    end_x: a.end_x,
                    end_y: ny.saturating_sub(1).saturating_sub(a.start_y),
                },
            })
            .collect();
        if let Some(slot) = layer.available.get_mut(z) {
            *slot = converted;
        }
    }
    Ok(layer)
}
